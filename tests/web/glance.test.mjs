// Browser tests of what lets a reader decide at a glance (issue 34): one
// colour per renderer keyed by its label, one frame-time statistic, one number
// format, where the bytes go (a ranked pass -> resource table), the
// per-resource chart's top 10, and the layout of every view at 1440x900 and
// 390x844 checked by geometry (boxes inside the window and their containers,
// labels that do not overlap), with a screenshot of each view at both sizes
// in $TALLY_SCREENSHOTS. A real `tallyd serve` on lavapipe, filled by three
// small captures; where a figure depends on the machine (a crossing, a point
// above a roof), the API's answer is replaced by a Playwright route with the
// case to show.
//
// Environment (tests/web/run.sh sets it): TALLYD, TALLY_WEB_ROOT,
// TALLY_SCREENSHOTS, CHROMIUM.
import assert from 'node:assert/strict';
import { mkdirSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';
import { after, before, describe, test } from 'node:test';

import { chromium } from 'playwright-core';

import { Daemon } from './daemon.mjs';

const env = process.env;
const fmt = await import(pathToFileURL(join(env.TALLY_WEB_ROOT, 'format.js')).href);
const palette = JSON.parse(readFileSync(join(env.TALLY_WEB_ROOT, 'palette.json'), 'utf8'));

const kViewports = { wide: { width: 1440, height: 900 }, phone: { width: 390, height: 844 } };
const kViewMs = 30_000;
const kCaptureMs = 180_000;
const kLongBranch = 'feature/a-rather-long-branch-name-for-the-new-clustered-lighting-path';

let daemon;
let browser;
const data = {};

async function open(hash, viewport = kViewports.wide, setup = null) {
  const context = await browser.newContext({ viewport });
  if (!data.hostsServed) await context.route((url) => url.pathname === '/api/hosts', (route) => route.fulfill({ json: { hosts: [], stale_after_s: 30 } }));
  if (setup) await setup(context);
  const page = await context.newPage();
  const errors = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(`uncaught: ${e.message}`));
  await page.goto(`${daemon.url}/${hash}`);
  await ready(page);
  return { page, errors, close: () => context.close() };
}

async function ready(page) {
  await page.waitForFunction(() => {
    const view = document.getElementById('view');
    return view && !view.hasAttribute('aria-busy') && view.querySelector('.page');
  }, null, { timeout: kViewMs });
  assert.deepEqual(await page.locator('#view .panel.error').allTextContents(), [], 'the view shows an error');
}

const shot = (page, name) => page.screenshot({ path: join(env.TALLY_SCREENSHOTS, `${name}.png`), fullPage: true });

// A chart's datasets as drawn: label, colours, data, and any flags the views set.
function chartOf(page, id) {
  return page.evaluate((chartId) => {
    const c = window.Chart.getChart(document.querySelector(`[data-chart="${chartId}"] canvas`));
    if (!c) return null;
    return {
      labels: c.data.labels,
      datasets: c.data.datasets.map((d) => ({ label: d.label, colorKey: d.colorKey ?? null, backgroundColor: d.backgroundColor, borderColor: d.borderColor, data: d.data, join: Boolean(d.join), ceiling: Boolean(d.ceiling) })),
      scales: Object.fromEntries(Object.entries(c.scales).map(([k, s]) => [k, { min: s.min, max: s.max, type: s.type, title: s.options.title?.text ?? '', ticks: s.ticks.map((t) => t.label) }])),
      area: c.chartArea,
      labelBoxes: c.tallyLabelBoxes || null,
      crossingLabels: c.tallyCrossingLabels || null,
    };
  }, id);
}

// CIE L*a*b* of "#rrggbb", and the CIE76 distance between two colours.
function lab(hex) {
  const n = parseInt(hex.slice(1), 16);
  const [r, g, b] = [n >> 16, (n >> 8) & 255, n & 255].map((v) => { const c = v / 255; return c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4; });
  const f = (t) => (t > 0.008856 ? Math.cbrt(t) : 7.787 * t + 16 / 116);
  const [x, y, z] = [(r * 0.4124 + g * 0.3576 + b * 0.1805) / 0.95047, r * 0.2126 + g * 0.7152 + b * 0.0722, (r * 0.0193 + g * 0.1192 + b * 0.9505) / 1.08883];
  return [116 * f(y) - 16, 500 * (f(x) - f(y)), 200 * (f(y) - f(z))];
}
const distance = (a, b) => Math.hypot(...lab(a).map((v, i) => v - lab(b)[i]));

const median = (values) => {
  const v = [...values].sort((a, b) => a - b);
  const m = v.length >> 1;
  return v.length % 2 ? v[m] : (v[m - 1] + v[m]) / 2;
};

// The median of a run's frames, pooled over its samples, from the API.
async function frameMedian(runId) {
  const { samples } = await daemon.get(`/runs/${runId}/samples`);
  const details = await Promise.all(samples.map((s) => daemon.get(`/samples/${s.id}`)));
  return median(details.flatMap((d) => d.frame_ms_frames));
}

// Elements of the view (matching selector) whose box leaves the window sideways.
function outsideWindow(page, selector) {
  return page.evaluate((sel) => [...document.querySelectorAll(sel)]
    .filter((e) => e.getClientRects().length && (e.getBoundingClientRect().left < -0.5 || e.getBoundingClientRect().right > window.innerWidth + 0.5))
    .map((e) => `${e.tagName.toLowerCase()}.${e.className}: ${e.textContent.trim().slice(0, 40)}`), selector);
}

// The layout rules every view keeps, at any size: no sideways scrolling of the
// page; every chart's canvas inside its figure, every figure, table box,
// heading and paragraph inside the page column (wide tables scroll inside
// their own box).
async function checkLayout(page, what) {
  const overflow = await page.evaluate(() => document.documentElement.scrollWidth - document.documentElement.clientWidth);
  assert.ok(overflow <= 0, `${what}: the page is ${overflow}px wider than the window`);
  const escaped = await page.evaluate(() => {
    const pageBox = document.querySelector('#view .page').getBoundingClientRect();
    const inside = (inner, outer) => inner.left >= outer.left - 0.5 && inner.right <= outer.right + 0.5;
    const out = [];
    for (const fig of document.querySelectorAll('#view figure.chart')) {
      const canvas = fig.querySelector('canvas');
      if (canvas && !inside(canvas.getBoundingClientRect(), fig.getBoundingClientRect())) out.push(`canvas of ${fig.dataset.chart}`);
    }
    for (const el of document.querySelectorAll('#view figure, #view .table-wrap, #view h1, #view h2, #view p, #view .tiles, #view form, #view .panel')) {
      if (!el.getClientRects().length) continue;
      if (!inside(el.getBoundingClientRect(), pageBox)) out.push(`${el.tagName.toLowerCase()}.${el.className} ${el.textContent.trim().slice(0, 30)}`);
    }
    return out;
  });
  assert.deepEqual(escaped, [], `${what}: elements outside their container`);
}

// Boxes {x, y, w, h} that overlap.
function overlaps(boxes) {
  const hits = [];
  boxes.forEach((a, i) => boxes.slice(i + 1).forEach((b) => {
    if (a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h) hits.push(`${a.text} / ${b.text}`);
  }));
  return hits;
}

const runOf = (variant, width, capture = data.scaling) => data.runs.find((r) => r.variant === variant && r.width === width && r.capture === capture);

before(async () => {
  for (const key of ['TALLYD', 'TALLY_WEB_ROOT', 'TALLY_SCREENSHOTS', 'CHROMIUM']) assert.ok(env[key], `${key} is not set`);
  mkdirSync(env.TALLY_SCREENSHOTS, { recursive: true });
  daemon = await new Daemon(env.TALLYD, env.TALLY_WEB_ROOT).start();
  data.hostsServed = (await daemon.api('/hosts').catch(() => ({ status: 0 }))).status === 200;
  // Three renderers at three resolutions: scaling charts, fits, roofline.
  data.scaling = (await daemon.capture({ renderers: ['forward', 'deferred', 'visbuffer'], scenes: ['atrium'], resolutions: [[32, 18], [64, 36], [96, 54]], frames: 3, counting: 'exact' }, kCaptureMs)).id;
  // One resolution on another scene, with footprint and long labels.
  data.single = (await daemon.capture({ renderers: ['forward', 'deferred'], scenes: ['planes'], resolutions: [[48, 27]], frames: 2, counting: 'exact', footprint: 64,
    labels: { branch: kLongBranch, commit: '4f2a9c1e77d0' } }, kCaptureMs)).id;
  // A small floor heatmap.
  data.heatmap = (await daemon.capture({ renderers: ['forward'], scenes: ['atrium'], resolutions: [[32, 18]], frames: 2, counting: 'exact',
    heatmap: { layout: 'floor', cells: [2, 2], yaws: 1 } }, kCaptureMs)).id;
  data.runs = (await daemon.get('/runs?limit=1000')).runs;
  data.renderers = (await daemon.get('/renderers')).renderers;
  browser = await chromium.launch({ executablePath: env.CHROMIUM });
});

after(async () => {
  await browser?.close();
  await daemon?.stop();
});

describe('colours', () => {
  test('the palette: every built-in renderer pinned, colours apart, none near red or green', () => {
    assert.deepEqual(Object.keys(palette.pinned).sort(), [...data.renderers].sort(), 'one pinned colour per built-in renderer');
    const colours = [...Object.entries(palette.pinned), ...palette.series.map((c, i) => [`series ${i}`, c]), ['read', palette.read], ['written', palette.written]];
    for (const [i, [a, ca]] of colours.entries()) {
      for (const [b, cb] of colours.slice(i + 1)) assert.ok(distance(ca, cb) >= 20, `${a} ${ca} and ${b} ${cb} are ${distance(ca, cb).toFixed(1)} apart`);
      // Red and green mean worse and better: no renderer, read or written looks like either.
      for (const [meaning, c] of [['worse', palette.worse], ['better', palette.better]]) {
        assert.ok(distance(ca, c) >= 20, `${a} ${ca} is ${distance(ca, c).toFixed(1)} from ${meaning} ${c}`);
      }
    }
  });

  test('a renderer keeps its colour whatever the order of selection and the view', async () => {
    const [f, d] = [runOf('forward', 64), runOf('deferred', 64)];
    const seen = {};
    for (const order of [[f, d], [d, f]]) {
      const { page, errors, close } = await open(`#/compare?runs=${order.map((r) => r.id).join(',')}`);
      for (const id of ['compare-pass-ms', 'compare-pass-bytes', 'compare-resources', 'scaling-bytes', 'scaling-frame-ms']) {
        const chart = await chartOf(page, id);
        for (const ds of chart.datasets) {
          const variant = ds.colorKey ?? ds.label;
          if (!['forward', 'deferred', 'visbuffer'].includes(variant)) continue;
          const colour = ds.borderColor ?? ds.backgroundColor;
          assert.equal(colour, palette.pinned[variant], `${id} ${ds.label}: ${colour}`);
          (seen[variant] ||= new Set()).add(colour);
        }
      }
      // Bars of the frame-time chart, one per run, in the run's colour.
      const frame = await chartOf(page, 'compare-frame-ms');
      assert.deepEqual(frame.datasets[0].backgroundColor, order.map((r) => palette.pinned[r.variant]));
      // Read and written: neutral, the same in every chart.
      const bytes = await chartOf(page, 'compare-bytes');
      assert.deepEqual(bytes.datasets.map((ds) => [ds.label, ds.backgroundColor]), [['read', palette.read], ['written', palette.written]]);
      assert.deepEqual(errors, []);
      await close();
    }
    assert.deepEqual(Object.keys(seen).sort(), ['deferred', 'forward', 'visbuffer']);
    const { page, close } = await open(`#/runs/${f.id}`);
    const perSample = await chartOf(page, 'per-sample');
    assert.deepEqual(perSample.datasets.map((ds) => ds.backgroundColor), [palette.read, palette.written]);
    await close();
  });

  test('green for better and red for worse, by what better means: higher reuse is better', async () => {
    const [f, d] = [runOf('forward', 48, data.single), runOf('deferred', 48, data.single)];
    const c = await daemon.get(`/compare?runs=${f.id},${d.id}`);
    const { page, errors, close } = await open(`#/compare?runs=${f.id},${d.id}`);
    const cell = (row) => page.locator(`[data-table="totals"] tr[data-row="${row}"] td`).nth(1).locator('[data-change]');
    const expect = (delta, higherIsBetter) => (delta === 0 ? 'same' : (delta > 0) === higherIsBetter ? 'better' : 'worse');
    assert.equal(await cell('total_bytes').getAttribute('data-change'), expect(c.total_bytes[1].delta, false));
    assert.equal(await cell('reuse').getAttribute('data-change'), expect(c.reuse[1].delta, true), `reuse ${c.reuse[0].value} -> ${c.reuse[1].value}`);
    const colour = await cell('reuse').evaluate((el) => getComputedStyle(el).color);
    assert.equal(colour, c.reuse[1].delta > 0 ? 'rgb(27, 110, 58)' : 'rgb(166, 27, 27)');
    assert.deepEqual(errors, []);
    await close();
  });
});

describe('one statistic, one number format', () => {
  test('the run tile and compare\'s totals show the median of all frames, labelled; the runs list labels its mean', async () => {
    const [f, d] = [runOf('forward', 96), runOf('deferred', 96)];
    const [mf, md] = await Promise.all([frameMedian(f.id), frameMedian(d.id)]);
    {
      const { page, close } = await open(`#/runs/${f.id}`);
      assert.match(await page.locator('[data-tile="frame-ms"] .label').textContent(), /median of all frames/);
      assert.equal(await page.locator('[data-tile="frame-ms"] .value').textContent(), fmt.ms(mf));
      await close();
    }
    {
      const { page, close } = await open(`#/compare?runs=${f.id},${d.id}`);
      const row = page.locator('[data-table="totals"] tr[data-row="frame_ms"]');
      assert.match(await row.locator('th').textContent(), /median of all frames/);
      assert.equal(Number(await row.locator('td').nth(0).getAttribute('data-value')), mf);
      assert.equal(Number(await row.locator('td').nth(1).getAttribute('data-value')), md);
      assert.equal(Number(await row.locator('td').nth(1).getAttribute('data-ratio')), md / mf);
      assert.deepEqual((await chartOf(page, 'compare-frame-ms')).datasets[0].data, [mf, md]);
      assert.match(await page.locator('[data-table="significance"] thead').textContent(), /Ratio of medians \(each camera aligned\)/);
      await close();
    }
    {
      const { page, close } = await open('#/runs');
      assert.match(await page.locator('button.sort[data-sort="frame_ms_median"]').textContent(), /median/);
      await close();
    }
  });

  test('one minus sign, no e-notation, units on the axes, slopes in ms/Mpx', async () => {
    const ids = ['forward', 'deferred', 'visbuffer'].map((v) => runOf(v, 64).id);
    for (const hash of [`#/compare?runs=${ids.join(',')}`, `#/runs/${ids[0]}`]) {
      const { page, close } = await open(hash);
      const cells = await page.locator('#view td.num, #view .tile .value').allTextContents();
      assert.ok(cells.length > 10);
      for (const text of cells) {
        assert.doesNotMatch(text, /(^|[\s([])-\d/, `a hyphen for a minus: "${text}"`);
        assert.doesNotMatch(text, /\d(\.\d+)?e[+\-−]?\d/, `e-notation: "${text}"`);
      }
      for (const canvas of await page.locator('[data-chart] canvas').all()) {
        const id = await canvas.evaluate((c) => c.closest('[data-chart]').dataset.chart);
        const chart = await chartOf(page, id);
        for (const [axis, scale] of Object.entries(chart.scales)) {
          const ticks = scale.ticks.filter(Boolean);
          for (const t of ticks) assert.doesNotMatch(String(t), /\de[+\-−]?\d|^-/, `${id} ${axis}: tick "${t}"`);
          // A value axis says its unit in its ticks or its title; a category axis names things.
          const numeric = ticks.length && ticks.every((t) => /\d/.test(t));
          if (numeric) assert.ok(/[a-zA-Z%×)]/.test(ticks.join(' ') + scale.title), `${id} ${axis}: no unit in "${ticks.join(', ')}" or "${scale.title}"`);
        }
      }
      if (hash.startsWith('#/compare')) {
        const slopes = await page.locator('[data-table="fits"] tbody tr td:nth-child(4)').allTextContents();
        assert.ok(slopes.length > 0);
        for (const s of slopes) assert.match(s, /^−?[\d.,]+ (ms|B|KiB|MiB|GiB)\/Mpx \(/, s);
      }
      await close();
    }
    assert.equal(fmt.ms(-1.5), '−1.500 ms');
    assert.equal(fmt.ms(1.5), '1.500 ms');
    assert.equal(fmt.signed(-0.5, 2), '−0.50');
    assert.equal(fmt.number(1e6), '1,000,000');
    assert.equal(fmt.count(-1696.4), '−1,696');
  });
});

describe('where the bytes go', () => {
  test('the run view ranks passes, opens each onto its resources, with shares and a top 5', async () => {
    const run = await daemon.get(`/runs/${runOf('forward', 96).id}`);
    const { page, errors, close } = await open(`#/runs/${run.id}`);
    const table = page.locator('[data-breakdown="run"]');
    // Before the charts.
    assert.ok(await table.evaluate((t) => Boolean(t.compareDocumentPosition(document.querySelector('[data-chart]')) & Node.DOCUMENT_POSITION_FOLLOWING)));
    const passBytes = run.passes.map((p) => [p.name, p.resources.reduce((sum, r) => sum + r.bytes, 0)]).sort((a, b) => b[1] - a[1]);
    const total = passBytes.reduce((sum, [, v]) => sum + v, 0);
    const rows = await table.locator('tr[data-depth="0"][data-node]').evaluateAll((trs) => trs.map((tr) => [tr.dataset.node, Number(tr.cells[1].dataset.value), Number(tr.cells[2].dataset.share)]));
    assert.deepEqual(rows.map((r) => r[0]), passBytes.map((p) => p[0]), 'ranked by bytes');
    rows.forEach(([name, v, share], i) => {
      assert.ok(Math.abs(v - passBytes[i][1]) <= 1e-9 * total, `${name}: ${v}`);
      assert.ok(Math.abs(share - v / total) < 1e-12, `${name}: share ${share}`);
    });
    // The largest pass opens onto its resource lines, ranked, the top 5 first.
    const top = run.passes.find((p) => p.name === passBytes[0][0]);
    // One line per resource and access (a resource read by two sources is one line).
    const byLine = new Map();
    for (const r of top.resources) byLine.set(`${r.name} (${r.access})`, (byLine.get(`${r.name} (${r.access})`) || 0) + r.bytes);
    const lines = [...byLine.entries()];
    assert.ok(lines.length > 5, 'enough lines for a top 5');
    await table.locator(`tr[data-node="${top.name}"] .tree-toggle`).click();
    const shown = await table.locator(`tr[data-parent="${top.name}"]:not([hidden])`).evaluateAll((trs) => trs.map((tr) => tr.dataset.node));
    assert.equal(shown.length, 5);
    const sorted = [...lines].sort((a, b) => b[1] - a[1]);
    assert.deepEqual(shown.map((k) => k.split('/').slice(1).join('/')), sorted.slice(0, 5).map((l) => l[0]));
    assert.match(await table.locator(`tr[data-rest-of="${top.name}"]`).textContent(), new RegExp(`${lines.length - 5} more`));
    await table.locator(`button[data-show-all="${top.name}"]`).click();
    assert.equal(await table.locator(`tr[data-parent="${top.name}"]:not([hidden])`).count(), lines.length);
    const sum = await table.locator(`tr[data-parent="${top.name}"]`).evaluateAll((trs) => trs.reduce((s, tr) => s + Number(tr.cells[1].dataset.value || 0), 0));
    assert.ok(Math.abs(sum - passBytes[0][1]) <= 1e-9 * total, 'the lines add up to their pass');
    // Closing the pass hides its lines again.
    await table.locator(`tr[data-node="${top.name}"] .tree-toggle`).click();
    assert.equal(await table.locator(`tr[data-parent="${top.name}"]:not([hidden])`).count(), 0);
    assert.deepEqual(errors, []);
    await close();
  });

  test('compare: one column per run, ranked by the largest, before the charts; the per-resource chart sorted, top 10, log scale', async () => {
    const ids = ['forward', 'deferred', 'visbuffer'].map((v) => runOf(v, 96).id);
    const c = await daemon.get(`/compare?runs=${ids.join(',')}`);
    const { page, errors, close } = await open(`#/compare?runs=${ids.join(',')}`);
    const table = page.locator('[data-breakdown="compare"]');
    assert.ok(await table.evaluate((t) => Boolean(t.compareDocumentPosition(document.querySelector('[data-chart]')) & Node.DOCUMENT_POSITION_FOLLOWING)));
    assert.deepEqual(await table.locator('thead th.num:not(.share-col)').allTextContents(), c.runs.map((r) => `${r.variant} #${r.id}`));
    const totals = await table.locator('tfoot td.num:not(.share-col)').evaluateAll((tds) => tds.map((td) => Number(td.dataset.value)));
    assert.deepEqual(totals, c.total_bytes.map((v) => v.value));
    // Ranked by the largest value over the runs, so that a pass one run lacks still ranks by its size.
    const largest = await table.locator('tr[data-depth="0"][data-node]').evaluateAll((trs) => trs.map((tr) =>
      Math.max(...[...tr.querySelectorAll('td[data-value]')].map((td) => (td.dataset.value === '' ? -1 : Number(td.dataset.value))))));
    assert.deepEqual(largest, [...largest].sort((a, b) => b - a));
    const passes = new Set(c.passes.map((p) => p.pass));
    assert.equal(await table.locator('tr[data-depth="0"][data-node]').count(), passes.size);
    assert.equal(await table.locator('tr[data-depth="0"][data-node]:not([hidden])').count(), Math.min(5, passes.size));

    const size = (r) => Math.max(...r.bytes.map((v) => v.value ?? 0));
    const sorted = [...c.resources].sort((a, b) => size(b) - size(a)).map((r) => `${r.resource} (${r.access})`);
    assert.ok(sorted.length > 10);
    let chart = await chartOf(page, 'compare-resources');
    assert.deepEqual(chart.labels, sorted.slice(0, 10));
    await page.click('[data-show-all-resources="true"]');
    chart = await chartOf(page, 'compare-resources');
    assert.deepEqual(chart.labels, sorted);
    await page.locator('[data-chart="compare-resources"] input[name="log"]').check();
    chart = await chartOf(page, 'compare-resources');
    assert.equal(chart.scales.x.type, 'logarithmic');
    assert.deepEqual(errors, []);
    await close();
  });
});

describe('layout', () => {
  test('runs: figures in view at 1440 px with long labels, truncated text with its title, a sticky first column, cards on a phone', async () => {
    {
      const { page, close } = await open('#/runs');
      const labels = page.locator('table.runs td[data-column="labels"] .clip', { hasText: kLongBranch }).first();
      assert.equal(await labels.getAttribute('title'), `branch=${kLongBranch}, commit=4f2a9c1e77d0`);
      assert.ok(await labels.evaluate((el) => el.scrollWidth > el.clientWidth), 'the long label is cut with an ellipsis');
      assert.deepEqual(await outsideWindow(page, 'table.runs th, table.runs td'), [], 'cells beyond the window');
      assert.equal(await page.locator('table.runs tbody td.sticky-col').first().evaluate((td) => getComputedStyle(td).position), 'sticky');
      await shot(page, 'glance-runs-wide');
      await close();
    }
    {
      // Narrower than the table: it scrolls, the first column stays.
      const { page, close } = await open('#/runs', { width: 820, height: 900 });
      const wrap = page.locator('table.runs').locator('xpath=..');
      assert.ok(await wrap.evaluate((w) => w.scrollWidth > w.clientWidth), 'the table scrolls at 820 px');
      const left = () => page.locator('table.runs tbody td.sticky-col').first().evaluate((td) => td.getBoundingClientRect().left);
      const before = await left();
      await wrap.evaluate((w) => { w.scrollLeft = w.scrollWidth; });
      assert.equal(await left(), before);
      await close();
    }
    {
      const { page, close } = await open('#/runs', kViewports.phone);
      assert.equal(await page.locator('table.runs thead').evaluate((t) => getComputedStyle(t).display), 'none');
      assert.equal(await page.locator('table.runs tbody tr').first().evaluate((tr) => getComputedStyle(tr).display), 'grid');
      assert.deepEqual(await outsideWindow(page, 'table.runs td'), [], 'card cells beyond the window');
      const named = await page.locator('table.runs tbody tr').first().locator('td[data-column="mean_bytes"]').evaluate((td) => getComputedStyle(td, '::before').content);
      assert.equal(named, '"Bytes / frame"');
      await checkLayout(page, 'runs phone');
      await shot(page, 'glance-runs-phone');
      await close();
    }
  });

  test('runs: "Compare selected" says why it is disabled', async () => {
    const { page, close } = await open('#/runs');
    const button = page.locator('.toolbar button', { hasText: 'Compare selected' });
    const reason = page.locator('[data-selection-reason]');
    assert.ok(await button.isDisabled());
    assert.equal(await reason.textContent(), 'Tick 2 to 4 runs to compare.');
    const boxes = page.locator('table.runs tbody input[type="checkbox"]');
    await boxes.nth(0).check();
    assert.equal(await reason.textContent(), 'Tick one more run to compare.');
    for (let i = 1; i < 5; ++i) await boxes.nth(i).check();
    assert.ok(await button.isDisabled());
    assert.equal(await reason.textContent(), 'Compare takes at most 4 runs: untick 1.');
    assert.ok(await reason.isVisible());
    await boxes.nth(4).uncheck();
    assert.ok(await button.isEnabled());
    assert.equal(await reason.textContent(), '');
    await close();
  });

  test('compare: the Why column stays in view; crossing labels do not overlap', async () => {
    const runs = ['forward', 'deferred', 'visbuffer'].map((v) => runOf(v, 96));
    const hash = `#/compare?runs=${runs.map((r) => r.id).join(',')}`;
    // Two crossings 400 pixels apart (71x40 and 66x37, as reported), on fitted lines.
    const crossover = (metric) => ({
      capture: data.scaling, metric, confidence: 0.95, poor_fit_r2: 0.9, truncated: false,
      series: runs.map((r, i) => ({ variant: r.variant, renderer: r.renderer, scene: r.scene, counting: r.counting, lights: r.lights, footprint_block_bytes: null,
        device_id: r.device_id, error: null, fit: { n: 3, a: 1 + i, b: (metric === 'bytes' ? 2000 : 0.001) * (3 - i), a_ci: [0, 2 + i], b_ci: [0, 1], r2: 0.99, poor_fit: false, min_pixels: 576, max_pixels: 5184 } })),
      crossings: [
        { kind: 'crosses', first: runs[0].variant, second: runs[1].variant, pixels: 2840, pixels_ci: [2700, 2990], resolution: { width: 71, height: 40 }, resolution_ci: [{ width: 69, height: 39 }, { width: 73, height: 41 }], lower_below: runs[0].variant, lower_above: runs[1].variant },
        { kind: 'crosses', first: runs[0].variant, second: runs[2].variant, pixels: 2442, pixels_ci: [2300, 2600], resolution: { width: 66, height: 37 }, resolution_ci: [{ width: 64, height: 36 }, { width: 68, height: 38 }], lower_below: runs[0].variant, lower_above: runs[2].variant },
      ],
    });
    for (const [size, viewport] of Object.entries(kViewports)) {
      const { page, errors, close } = await open(hash, viewport, (context) => context.route((url) => url.pathname === '/api/crossover',
        (route) => route.fulfill({ json: crossover(new URL(route.request().url()).searchParams.get('metric')) })));
      for (const id of ['scaling-bytes', 'scaling-frame-ms']) {
        const labels = (await chartOf(page, id)).crossingLabels;
        assert.deepEqual(labels.map((l) => l.text).sort(), ['66×37', '71×40']);
        assert.deepEqual(overlaps(labels), [], `${id} ${size}: crossing labels overlap`);
      }
      if (size === 'wide') {
        assert.ok(await page.locator('[data-table="significance"] td.why').count() > 0);
        assert.deepEqual(await outsideWindow(page, '[data-table="significance"] th, [data-table="significance"] td'), [], 'significance cells beyond the window');
      }
      await checkLayout(page, `compare ${size}`);
      await shot(page, `glance-compare-${size}`);
      assert.deepEqual(errors, []);
      await close();
    }
  });

  test('compare: with one resolution per renderer the scaling charts are left out, with the reason', async () => {
    const ids = ['forward', 'deferred'].map((v) => runOf(v, 48, data.single).id);
    const { page, errors, close } = await open(`#/compare?runs=${ids.join(',')}`);
    assert.match(await page.locator('[data-scaling="one-resolution"]').textContent(), /measured at one resolution only \(48×27\).*needs two or more/);
    assert.equal(await page.locator('[data-chart="scaling-bytes"]').count(), 0);
    assert.equal(await page.locator('[data-chart="scaling-frame-ms"]').count(), 0);
    assert.deepEqual(errors, []);
    await close();
  });

  test('roofline: points labelled, requested and footprint joined, ceilings whole', async () => {
    const run = runOf('forward', 48, data.single);
    const { page, errors, close } = await open(`#/runs/${run.id}`);
    const chart = await chartOf(page, 'roofline');
    const requested = chart.datasets.find((d) => d.label === 'requested bytes').data;
    const footprint = chart.datasets.find((d) => d.label === 'footprint bytes').data;
    assert.ok(requested.length > 1);
    // Every requested point labelled with its pass, inside the plot, no two labels overlapping.
    assert.deepEqual(chart.labelBoxes.map((b) => b.text).sort(), requested.map((p) => p.pass).sort());
    assert.deepEqual(overlaps(chart.labelBoxes), []);
    for (const b of chart.labelBoxes) assert.ok(b.x >= chart.area.left && b.x + b.w <= chart.area.right && b.y >= chart.area.top && b.y + b.h <= chart.area.bottom, `label ${b.text} outside the plot`);
    // One dotted line per pass from its requested point to its footprint point.
    const joins = chart.datasets.filter((d) => d.join);
    assert.equal(joins.length, footprint.length);
    for (const f of footprint) {
      const r = requested.find((p) => p.pass === f.pass);
      assert.ok(joins.some((j) => j.data[0].x === r.x && j.data[0].y === r.y && j.data[1].x === f.x && j.data[1].y === f.y), `${f.pass}: no join`);
    }
    // The ceilings end inside the axes, the flat one below the top.
    const ceilings = chart.datasets.filter((d) => d.ceiling).flatMap((d) => d.data);
    assert.ok(ceilings.length === 4);
    for (const p of ceilings) {
      assert.ok(p.x >= chart.scales.x.min && p.x <= chart.scales.x.max, `ceiling x ${p.x} outside [${chart.scales.x.min}, ${chart.scales.x.max}]`);
      assert.ok(p.y >= chart.scales.y.min && p.y < chart.scales.y.max, `ceiling y ${p.y} outside [${chart.scales.y.min}, ${chart.scales.y.max})`);
    }
    // On lavapipe every pass lies under its roof or the view says otherwise: both read from the same flags.
    const flagged = requested.filter((p) => p.flag).length + footprint.filter((p) => p.flag).length;
    assert.equal(await page.locator('[data-roofline-above]').count(), flagged ? 1 : 0);
    await shot(page, 'glance-run-wide');
    assert.deepEqual(errors, []);
    await close();
  });

  test('roofline: points above a roof are flagged, and the view says the ceilings were measured low', async () => {
    const run = runOf('forward', 96);
    // Ceilings far below what the passes reached, as a busy machine measures them.
    const lower = (context) => context.route((url) => url.pathname === `/api/runs/${run.id}`, async (route) => {
      const body = await (await route.fetch()).json();
      body.ceilings = { ...body.ceilings, bandwidth_bytes_per_s: 1, arithmetic_ops_per_s: 10, ridge_intensity: 10 };
      await route.fulfill({ json: body });
    });
    const { page, errors, close } = await open(`#/runs/${run.id}`, kViewports.wide, lower);
    const chart = await chartOf(page, 'roofline');
    const requested = chart.datasets.find((d) => d.label === 'requested bytes').data;
    assert.ok(requested.length > 0 && requested.every((p) => p.flag));
    assert.equal(await page.locator('[data-roofline-above]').getAttribute('data-roofline-above'), String(requested.length));
    assert.match(await page.locator('[data-roofline-above]').textContent(), /above a roof.*measured while the machine was busy/);
    const above = await page.locator('[data-table="roofline"] [data-above]').evaluateAll((els) => els.map((e) => e.dataset.above));
    assert.equal(above.filter((a) => a === 'true').length, requested.length);
    assert.deepEqual(errors, []);
    await close();
  });

  test('capture form: a live cost, a light default, progress beside Start, fields that do not apply disabled', async () => {
    const { page, errors, close } = await open('#/capture');
    const checked = await page.locator('input[name="renderers"]:checked').evaluateAll((boxes) => boxes.map((b) => b.value));
    assert.deepEqual(checked, ['deferred', 'visbuffer']);
    assert.equal(await page.inputValue('input[name="frames"]'), '10');
    const cost = page.locator('[data-cost] [data-samples]');
    // 2 variants x 1 scene x 10 cameras x 1 resolution, 10 frames each, 320x180.
    assert.equal(await cost.getAttribute('data-samples'), '20');
    assert.equal(await cost.getAttribute('data-pixel-frames'), String(2 * 10 * 10 * 320 * 180));
    await page.fill('input[name="frames"]', '4');
    await page.fill('input[name="resolutions"]', '64x36, 128x72');
    assert.equal(await cost.getAttribute('data-samples'), '40');
    assert.equal(await cost.getAttribute('data-frames'), '160');
    assert.equal(await cost.getAttribute('data-pixel-frames'), String(2 * 10 * 4 * (64 * 36 + 128 * 72)));
    // Three finished captures on this host: an estimate in seconds.
    assert.ok(Number(await page.locator('[data-cost] [data-estimate]').getAttribute('data-estimate')) > 0);
    // Start and its cost are in view on load, at the window's bottom while the form scrolls.
    for (const el of [page.locator('form.capture-form button[type="submit"]'), page.locator('[data-cost]')]) {
      const box = await el.boundingBox();
      assert.ok(box.y >= 0 && box.y + box.height <= kViewports.wide.height, `${await el.textContent()} below the fold`);
    }
    // Fields that do not apply.
    assert.ok(await page.locator('input[name="sample_n"]').isDisabled());
    assert.ok(await page.locator('input[name="heatmap_grid"]').isDisabled());
    await page.selectOption('select[name="counting"]', 'sampled');
    assert.ok(await page.locator('input[name="sample_n"]').isEnabled());
    await page.selectOption('select[name="cameras_mode"]', 'sphere');
    assert.ok(await page.locator('input[name="heatmap_grid"]').isEnabled());
    assert.ok(await page.locator('input[name="heatmap_yaws"]').isDisabled());
    await page.selectOption('select[name="cameras_mode"]', 'floor');
    assert.ok(await page.locator('input[name="heatmap_yaws"]').isEnabled());
    assert.equal(await cost.getAttribute('data-samples'), String(2 * 8 * 4 * 4 * 2));
    // A capture started: its progress in the same row as Start.
    await page.selectOption('select[name="counting"]', 'exact');
    await page.selectOption('select[name="cameras_mode"]', 'auto');
    while (await page.locator('input[name="renderers"]:checked').count()) await page.locator('input[name="renderers"]:checked').first().uncheck();
    await page.locator('input[name="renderers"][value="forward"]').first().check();
    await page.fill('input[name="resolutions"]', '32x18');
    await page.fill('input[name="frames"]', '1');
    await page.click('form.capture-form button[type="submit"]');
    const panel = page.locator('.start-row .progress-box [data-status]');
    await panel.waitFor({ timeout: kViewMs });
    const [start, progress] = [await page.locator('form.capture-form button[type="submit"]').boundingBox(), await panel.boundingBox()];
    assert.ok(progress.y < start.y + start.height && progress.x > start.x + start.width, 'the progress is beside Start');
    await page.locator('.start-row [data-status="done"]').waitFor({ timeout: kCaptureMs });
    await shot(page, 'glance-capture-wide');
    assert.deepEqual(errors, []);
    await close();
  });

  test('captures list: every column in view at 1440 px', async () => {
    const { page, close } = await open('#/capture');
    await page.locator('table.jobs').waitFor();
    assert.deepEqual(await outsideWindow(page, 'table.jobs th, table.jobs td'), []);
    assert.equal(await page.locator(`a[data-heatmap-link="${data.heatmap}"]`).isVisible(), true);
    await close();
  });

  test('heatmap: the value on hover and in a table, linked from its run; a plain sentence for another capture', async () => {
    const body = await daemon.get(`/heatmap?capture=${data.heatmap}&renderer=forward`);
    const run = data.runs.find((r) => r.capture === data.heatmap);
    {
      const { page, errors, close } = await open(`#/runs/${run.id}`);
      assert.equal(await page.locator(`a[data-heatmap-link="${data.heatmap}"]`).getAttribute('href'), `#/heatmap?capture=${data.heatmap}`);
      assert.deepEqual(errors, []);
      await close();
    }
    for (const [size, viewport] of Object.entries(kViewports)) {
      const { page, errors, close } = await open(`#/heatmap?capture=${data.heatmap}`, viewport);
      const measured = body.cells.filter((c) => c.value_a !== null);
      assert.ok(measured.length > 0);
      const cell = measured[0];
      await page.locator(`g.cell[data-column="${cell.column}"][data-row="${cell.row}"]`).hover();
      assert.equal(await page.locator('[data-hover]').getAttribute('data-hover'), `${cell.column},${cell.row}`);
      assert.match(await page.locator('[data-hover]').textContent(), new RegExp(fmt.ms(cell.value_a).replace('.', '\\.')));
      const values = await page.locator('.heatmap-table tbody [data-value]').evaluateAll((els) => els.map((e) => Number(e.dataset.value)));
      assert.deepEqual(values, measured.map((c) => c.value_a));
      await checkLayout(page, `heatmap ${size}`);
      await shot(page, `glance-heatmap-${size}`);
      assert.deepEqual(errors, []);
      await close();
    }
    const { page, errors, close } = await open(`#/heatmap?capture=${data.scaling}`);
    assert.match(await page.locator('[data-heatmap="not-a-heatmap"]').textContent(), new RegExp(`Capture #${data.scaling} is not a heatmap capture`));
    assert.doesNotMatch(await page.locator('#view').textContent(), /no heatmap run/);
    assert.deepEqual(errors, []);
    await close();
  });

  test('every view at 1440x900 and 390x844: nothing outside its container, a screenshot each', async () => {
    const f = runOf('forward', 96);
    const views = {
      runs: '#/runs', run: `#/runs/${f.id}`, 'run-footprint': `#/runs/${runOf('forward', 48, data.single).id}`,
      compare: `#/compare?runs=${['forward', 'deferred', 'visbuffer'].map((v) => runOf(v, 96).id).join(',')}`,
      accuracy: '#/accuracy', capture: '#/capture', alerts: '#/alerts', hosts: '#/hosts', heatmap: `#/heatmap?capture=${data.heatmap}`,
    };
    for (const [name, hash] of Object.entries(views)) {
      for (const [size, viewport] of Object.entries(kViewports)) {
        const { page, errors, close } = await open(hash, viewport);
        await checkLayout(page, `${name} ${size}`);
        await shot(page, `glance-${name}-${size}`);
        assert.deepEqual(errors, [], `${name} ${size}`);
        await close();
      }
    }
  });
});

// Browser tests of the heatmap view: a real `tallyd serve` with one floor
// heatmap of the atrium (deferred and visbuffer, 4 x 2 cells, 1 yaw, 32x18,
// 3 frames; lavapipe) and one sphere heatmap (forward, 2 x 3). The view must
// draw the plan from /api/heatmap/{id}/topdown.png under one cell per entry of
// GET /api/heatmap, coloured by the ratio on a diverging scale (blue below 1,
// red above), hatch exactly the cells whose difference is not significant,
// give each cell a tooltip with its values and verdict, open a cell's samples
// and screenshots on a click, switch to one renderer's sequential scale, and
// draw a sphere as a longitude/latitude grid. The capture view links a
// heatmap capture to it. At 360 px nothing scrolls sideways, and no page logs
// a console error.
//
// Environment (tests/web/run.sh sets it): TALLYD, TALLY_WEB_ROOT,
// TALLY_SCREENSHOTS, CHROMIUM.
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';
import { after, before, describe, test } from 'node:test';

import { chromium } from 'playwright-core';

import { Daemon } from './daemon.mjs';

// The dashboard's own number formatting, so that the expected text follows its
// one rule (web/format.js) instead of a copy of it.
const fmt = await import(pathToFileURL(join(process.env.TALLY_WEB_ROOT, 'format.js')).href);

const env = process.env;
const kViewMs = 30_000;
const kCaptureMs = 180_000;
const kViewports = { narrow: { width: 360, height: 800 }, wide: { width: 1280, height: 800 } };

let daemon;
let browser;
const data = {};

async function open(hash, viewport) {
  const context = await browser.newContext({ viewport });
  await context.route((url) => url.pathname === '/api/hosts', (route) => route.fulfill({ json: { hosts: [], stale_after_s: 30 } }));
  const page = await context.newPage();
  const errors = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(`uncaught: ${e.message}`));
  await page.goto(`${daemon.url}/${hash}`);
  await page.waitForFunction(() => {
    const view = document.getElementById('view');
    return view && !view.hasAttribute('aria-busy') && view.querySelector('.page');
  }, null, { timeout: kViewMs });
  assert.deepEqual(await page.locator('#view .panel.error').allTextContents(), [], 'the view shows an error');
  return { page, errors, close: () => context.close() };
}

// The drawn cells: position in the grid, data attributes, fill, hatch, tooltip.
function drawnCells(page) {
  return page.evaluate(() => [...document.querySelectorAll('.heatmap-svg g.cell')].map((g) => ({
    column: Number(g.dataset.column),
    row: Number(g.dataset.row),
    empty: g.dataset.empty || null,
    ratio: g.dataset.ratio === undefined ? null : Number(g.dataset.ratio),
    value: g.dataset.value === undefined ? null : Number(g.dataset.value),
    significant: g.dataset.significant === undefined ? null : g.dataset.significant === 'true',
    fill: g.querySelector('rect')?.getAttribute('fill') || null,
    hatched: Boolean(g.querySelector('rect.hatch')),
    title: g.querySelector('title')?.textContent || '',
  })));
}

const rgb = (fill) => fill.match(/\d+/g).map(Number);

before(async () => {
  for (const key of ['TALLYD', 'TALLY_WEB_ROOT', 'TALLY_SCREENSHOTS', 'CHROMIUM']) assert.ok(env[key], `${key} is not set`);
  mkdirSync(env.TALLY_SCREENSHOTS, { recursive: true });
  daemon = await new Daemon(env.TALLYD, env.TALLY_WEB_ROOT).start();
  const floor = await daemon.capture({
    renderers: ['deferred', 'visbuffer'], scenes: ['atrium'], resolutions: [[32, 18]],
    heatmap: { layout: 'floor', cells: [4, 2], yaws: 1 }, frames: 3, counted_frames: 1, ceilings: false,
  }, kCaptureMs);
  data.floor = floor.id;
  data.map = await daemon.get(`/heatmap?capture=${floor.id}&renderer=deferred&versus=visbuffer&metric=frame_ms`);
  const sphere = await daemon.capture({
    renderers: ['forward'], resolutions: [[32, 18], [48, 27]], heatmap: { layout: 'sphere', rings: 2, segments: 3 },
    frames: 2, counted_frames: 1, ceilings: false,
  }, kCaptureMs);
  data.sphere = sphere.id;
  browser = await chromium.launch({ executablePath: env.CHROMIUM });
});

after(async () => {
  await browser?.close();
  await daemon?.stop();
});

describe('heatmap', () => {
  test('the plan with one cell per API cell, coloured by the ratio, hatched where not significant', async () => {
    for (const [size, viewport] of Object.entries(kViewports)) {
      const { page, errors, close } = await open(`#/heatmap?capture=${data.floor}&renderer=deferred&versus=visbuffer`, viewport);
      // The plan is shown and has loaded (its size is the layout's image size).
      assert.equal(await page.locator('.heatmap').getAttribute('data-topdown'), 'shown');
      const plan = await page.evaluate(async () => {
        const href = document.querySelector('.heatmap-svg image').getAttribute('href');
        const img = new Image();
        img.src = href;
        await img.decode();
        return { href, width: img.naturalWidth, height: img.naturalHeight };
      });
      assert.equal(plan.href, `/api/heatmap/${data.floor}/topdown.png?scene=atrium`);
      assert.equal(plan.width, data.map.layout.image.width);
      assert.equal(plan.height, data.map.layout.image.height);

      const cells = await drawnCells(page);
      assert.equal(cells.length, data.map.cells.length);
      // The scale's span as the page defines it: the largest |log2 ratio|, at least 5 %.
      const logs = data.map.cells.filter((c) => c.value_a !== null && c.ratio !== null).map((c) => Math.abs(Math.log2(c.ratio)));
      const span = Math.max(Math.log2(1.05), ...logs);
      let measured = 0;
      for (const want of data.map.cells) {
        const got = cells.find((c) => c.column === want.column && c.row === want.row);
        assert.ok(got, `cell ${want.column},${want.row} drawn`);
        if (want.value_a === null) {
          assert.ok(got.empty, `empty cell ${want.column},${want.row} marked`);
          assert.ok(/empty/.test(got.title), got.title);
          continue;
        }
        ++measured;
        assert.equal(got.ratio, want.ratio);
        assert.equal(got.significant, want.significant);
        assert.equal(got.hatched, want.significant === false, `hatch of ${want.column},${want.row}`);
        // Diverging scale on log2(ratio) / span: blue below 1 (versus lower),
        // red above, white at 1. A ratio within 2 % of the span of 1 rounds
        // to white or next to it (timings put some cells there), so the hue
        // is checked beyond that and near-white within a quarter of it.
        const [r, , b] = rgb(got.fill);
        const l = Math.log2(want.ratio) / span;
        if (l < -0.02) assert.ok(b > r, `ratio ${want.ratio} drawn ${got.fill}`);
        if (l > 0.02) assert.ok(r > b, `ratio ${want.ratio} drawn ${got.fill}`);
        if (Math.abs(l) < 0.005) assert.ok(Math.abs(r - b) <= 2, `ratio ${want.ratio} drawn ${got.fill}, not white`);
        // The tooltip: both values, the ratio and the verdict.
        assert.ok(got.title.includes(`deferred: ${fmt.ms(want.value_a)}`), got.title);
        assert.ok(got.title.includes(`visbuffer / deferred: ${want.ratio.toFixed(3)}`), got.title);
        assert.ok(got.title.includes(`verdict: ${want.verdict}`), got.title);
      }
      assert.ok(measured >= 4, 'the court has floor');
      assert.equal(await page.locator('[data-legend="ratio"]').count(), 1);
      assert.ok(!/\bnull\b|undefined|NaN/.test(await page.locator('#view').innerText()), 'a missing value shown as text');
      assert.match(await page.locator('[data-summary="significant"]').textContent(),
        new RegExp(`significant in ${data.map.summary.significant} of ${data.map.summary.cells_measured} cells`));
      const overflow = await page.evaluate(() => document.documentElement.scrollWidth - document.documentElement.clientWidth);
      assert.ok(overflow <= 0, `${size}: scrolls sideways by ${overflow}px`);
      await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, `heatmap-${size}.png`), fullPage: true });
      assert.deepEqual(errors, []);
      await close();
    }
  });

  test('a click opens the cell\'s samples and screenshots', async () => {
    const { page, errors, close } = await open(`#/heatmap?capture=${data.floor}&renderer=deferred&versus=visbuffer`, kViewports.wide);
    const cell = data.map.cells.find((c) => c.value_a !== null);
    await page.locator(`.heatmap-svg g.cell[data-column="${cell.column}"][data-row="${cell.row}"]`).click();
    await page.waitForSelector('.heatmap-details figure.shot img[src]');
    const shown = await page.evaluate(async () => {
      const imgs = [...document.querySelectorAll('.heatmap-details figure.shot img')];
      await Promise.all(imgs.map((i) => i.decode()));
      return {
        samples: [...document.querySelectorAll('.heatmap-details figure.shot')].map((f) => Number(f.dataset.sample)),
        widths: imgs.map((i) => i.naturalWidth),
        links: [...document.querySelectorAll('.heatmap-details figcaption a')].map((a) => a.getAttribute('href')),
      };
    });
    assert.deepEqual(shown.samples, [...cell.samples_a, ...cell.samples_b]);
    assert.deepEqual(shown.widths, shown.samples.map(() => 32));  // the 32x18 screenshots
    assert.ok(shown.links.every((l) => /^#\/runs\/\d+$/.test(l)), shown.links.join(' '));
    assert.deepEqual(errors, []);
    await close();
  });

  test('one renderer: a sequential scale, no hatching; the versus select switches to it', async () => {
    const { page, errors, close } = await open(`#/heatmap?capture=${data.floor}&renderer=deferred&versus=visbuffer`, kViewports.wide);
    const rendered = await page.evaluate(() => document.getElementById('view').dataset.rendered);
    await page.selectOption('select[name="versus"]', 'none');
    await page.waitForFunction((n) => document.getElementById('view').dataset.rendered !== n, rendered, { timeout: kViewMs });
    assert.ok(page.url().includes('versus=none'), page.url());
    assert.equal(await page.locator('[data-legend="value"]').count(), 1);
    const single = await daemon.get(`/heatmap?capture=${data.floor}&renderer=deferred&metric=frame_ms`);
    const cells = await drawnCells(page);
    const values = single.cells.filter((c) => c.value_a !== null);
    const low = Math.min(...values.map((c) => c.value_a)), high = Math.max(...values.map((c) => c.value_a));
    for (const want of values) {
      const got = cells.find((c) => c.column === want.column && c.row === want.row);
      assert.equal(got.value, want.value_a);
      assert.equal(got.hatched, false);
      // The lowest value is drawn lightest (the ramp starts light), the highest darkest.
      if (want.value_a === low) assert.equal(got.fill, 'rgb(253, 231, 37)');
      if (want.value_a === high && high > low) assert.equal(got.fill, 'rgb(68, 1, 84)');
    }
    assert.deepEqual(errors, []);
    await close();
  });

  test('a sphere is a longitude/latitude grid without a plan', async () => {
    const { page, errors, close } = await open(`#/heatmap?capture=${data.sphere}`, kViewports.narrow);
    assert.equal(await page.locator('.heatmap').getAttribute('data-layout'), 'sphere');
    assert.equal(await page.locator('.heatmap-svg image').count(), 0);
    const cells = await drawnCells(page);
    assert.equal(cells.length, 6);
    assert.ok(cells.every((c) => c.value !== null && c.fill.startsWith('rgb(')));
    assert.ok(cells[0].title.startsWith('ring 0, segment 0 (lat 45°, lon −120°)'), cells[0].title);
    // Two resolutions: two maps, the first shown, the other one select away.
    assert.match(await page.locator('#view .meta').textContent(), /32×18/);
    const rendered = await page.evaluate(() => document.getElementById('view').dataset.rendered);
    await page.selectOption('select[name="config"]', { label: 'atrium · 48×27 · accumulate' });
    await page.waitForFunction((n) => document.getElementById('view').dataset.rendered !== n, rendered, { timeout: kViewMs });
    assert.match(await page.locator('#view .meta').textContent(), /48×27/);
    const at48 = await daemon.get(`/heatmap?capture=${data.sphere}&renderer=forward&width=48&height=27`);
    assert.deepEqual((await drawnCells(page)).map((c) => c.value), at48.cells.map((c) => c.value_a));
    assert.deepEqual(errors, []);
    await close();
  });

  test('the capture form makes a heatmap spec; a bad grid shows the server\'s field beside it', async () => {
    const { page, errors, close } = await open('#/capture', kViewports.wide);
    const before = (await daemon.get('/captures?limit=1000')).captures.length;
    const posted = [];
    page.on('request', (r) => { if (r.method() === 'POST' && new URL(r.url()).pathname === '/api/captures') posted.push(r.postDataJSON()); });
    await page.selectOption('select[name="cameras_mode"]', 'floor');
    await page.fill('input[name="heatmap_grid"]', '4x0');
    await page.fill('input[name="heatmap_yaws"]', '2');
    await page.click('form.capture-form button[type="submit"]');
    const panel = page.locator('.form-error .panel.error');
    await panel.waitFor({ timeout: kViewMs });
    assert.equal(await panel.locator('.field-name').textContent(), 'heatmap.cells[1]');
    assert.equal(await page.locator('input[name="heatmap_grid"]').getAttribute('aria-invalid'), 'true');
    assert.equal(posted.length, 1);
    assert.deepEqual(posted[0].heatmap, { layout: 'floor', cells: [4, 0], yaws: 2 });
    assert.equal(posted[0].cameras, undefined);
    // A sphere: rings x segments.
    await page.selectOption('select[name="cameras_mode"]', 'sphere');
    await page.fill('input[name="heatmap_grid"]', '0x3');
    await page.click('form.capture-form button[type="submit"]');
    await page.waitForFunction(() => document.querySelector('.form-error .field-name')?.textContent === 'heatmap.rings', null, { timeout: kViewMs });
    assert.deepEqual(posted[1].heatmap, { layout: 'sphere', rings: 0, segments: 3 });
    assert.equal((await daemon.get('/captures?limit=1000')).captures.length, before, 'a refused spec stores no job');
    // The only console lines: Chromium's notes of the two 400 answers.
    assert.equal(errors.length, 2, errors.join('\n'));
    await close();
  });

  test('the capture view links a heatmap capture to its heatmap', async () => {
    const { page, errors, close } = await open('#/capture', kViewports.wide);
    const link = page.locator(`a[data-heatmap-link="${data.floor}"]`);
    assert.equal(await link.count(), 1);
    assert.equal(await link.getAttribute('href'), `#/heatmap?capture=${data.floor}`);
    assert.equal(await page.locator(`a[data-heatmap-link="${data.sphere}"]`).count(), 1);
    assert.deepEqual(errors, []);
    await close();
  });
});

// Browser tests of the shader view (#/shader/RUN): a real `tallyd serve` with
// two tiny forward captures on lavapipe. Their samples carry no per-site
// counts (the capture writes them only with "sites": true), so Playwright
// routes answer the sites, draws and shader routes in the API's shape with
// values computed here from each real sample's resource lines: every counted
// line split over sites on code lines of the real shaders/forward.frag.glsl,
// draws and materials splitting the pass's bytes. The view must show each
// site's line with its bytes, share and a heat bar scaled to the heaviest
// line; clicking a line lists exactly its sites' resources; the ranked
// table's shares add up to each pass's whole; and against the second run,
// whose source has one line more, exactly that line is marked added. At
// 360 px nothing scrolls sideways, and no page logs a console error.
//
// Environment (tests/web/run.sh sets it): TALLYD, TALLY_WEB_ROOT,
// TALLY_SCREENSHOTS, CHROMIUM.
import assert from 'node:assert/strict';
import { mkdirSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { after, before, describe, test } from 'node:test';

import { chromium } from 'playwright-core';

import { Daemon } from './daemon.mjs';
import { viewPage } from './view_page.mjs';

const env = process.env;
const kViewMs = 30_000;
const kCaptureMs = 180_000;
const kShader = 'forward.frag.glsl';
const kViewports = { narrow: { width: 360, height: 800 }, wide: { width: 1280, height: 800 } };

let daemon;
let browser;
const data = { samples: {}, sources: {} };

// Sites of one real sample: each counted line over two sites (a third and
// two thirds of its bytes) on the source's code lines, in turn.
function sitesOf(sample, codeLines) {
  const sites = [];
  let next = 0;
  sample.passes.forEach((pass, position) => {
    for (const line of pass.resources) {
      if (line.source !== 'counter') continue;
      for (const part of [1 / 3, 2 / 3]) {
        const at = codeLines[next++ % codeLines.length];
        sites.push({ pass: pass.name, pass_position: position, shader: kShader, stage: 'fragment', entry_point: 'main',
          instruction: 100 + sites.length, opcode: 'OpImageSampleImplicitLod', resource: line.name, access: line.access,
          kind: line.kind, file: kShader, line: at, disassembly: `%${100 + sites.length} = OpImageSampleImplicitLod`,
          count: line.count * part, bytes: line.bytes * part, sites: 1, resources: [`${line.name} (${line.access})`] });
      }
    }
  });
  return sites;
}

const passBytes = (pass) => pass.resources.reduce((sum, r) => sum + r.bytes, 0);

function passesOf(sample, sites) {
  return sample.passes.map((p, position) => ({ name: p.name, position, bytes: passBytes(p),
    sites: sites.filter((s) => s.pass_position === position).length, draws: 3, materials: 2 }));
}

// Three draws per pass (weights 1, 2, 3 of its bytes); materials "stone" (draws 0, 2) and "wood" (draw 1).
function drawsOf(sample) {
  const draws = [], materials = [];
  sample.passes.forEach((pass, position) => {
    const total = passBytes(pass);
    const mats = { stone: { bytes: 0, draws: 0 }, wood: { bytes: 0, draws: 0 } };
    for (const d of [0, 1, 2]) {
      const bytes = (total * (d + 1)) / 6, material = d === 1 ? 'wood' : 'stone';
      draws.push({ pass: pass.name, pass_position: position, rank: 2 - d, index: d, name: `mesh ${d}`, mesh: String(d), material,
        count: 1, bytes_read: bytes, bytes_written: 0, bytes, share: total > 0 ? bytes / total : null });
      mats[material].bytes += bytes;
      mats[material].draws += 1;
    }
    for (const [material, m] of Object.entries(mats)) {
      materials.push({ pass: pass.name, pass_position: position, material, draws: m.draws, bytes_read: m.bytes, bytes_written: 0,
        bytes: m.bytes, share: total > 0 ? m.bytes / total : null });
    }
  });
  return { draws, materials };
}

const bySampleId = (url) => data.samples[Number(/\/api\/samples\/(\d+)\//.exec(url.pathname)[1])];

async function open(hash, viewport) {
  const context = await browser.newContext({ viewport });
  await context.route((url) => url.pathname === '/api/hosts', (route) => route.fulfill({ json: { hosts: [], stale_after_s: 30 } }));
  await context.route((url) => /^\/api\/samples\/\d+\/(sites|draws)$/.test(url.pathname), (route) => {
    const url = new URL(route.request().url());
    const s = bySampleId(url);
    const limit = Number(url.searchParams.get('limit') || 100), offset = Number(url.searchParams.get('offset') || 0);
    const page = { sample: s.id, passes: passesOf(s.real, s.sites), limit, offset };
    const rows = url.pathname.endsWith('/sites') ? [...s.sites].sort((a, b) => b.bytes - a.bytes)
      : url.searchParams.get('by') === 'material' ? s.draws.materials : s.draws.draws;
    const slice = rows.slice(offset, offset + limit);
    const next = offset + limit < rows.length ? offset + limit : null;
    if (url.pathname.endsWith('/sites')) return route.fulfill({ json: { ...page, by: 'site', sites: slice, total: rows.length, next_offset: next } });
    const material = url.searchParams.get('by') === 'material';
    return route.fulfill({ json: { ...page, by: material ? 'material' : 'draw', draws: material ? [] : slice, materials: material ? slice : [],
      rest: [], total: rows.length, next_offset: next } });
  });
  await context.route((url) => /^\/api\/runs\/\d+\/shaders(\/.*)?$/.test(url.pathname), (route) => {
    const url = new URL(route.request().url());
    const [, run, name] = /^\/api\/runs\/(\d+)\/shaders(?:\/(.*))?$/.exec(url.pathname);
    const text = data.sources[run];
    if (!name) return route.fulfill({ json: { run: Number(run), shaders: [{ name: kShader, hash: '0', length: text.length }] } });
    return route.fulfill({ json: { run: Number(run), name: decodeURIComponent(name), hash: '0', length: text.length, lines: text.split('\n').length, source: text } });
  });
  const { page, errors } = await viewPage(context, `${daemon.url}/${hash}`, kViewMs);
  return { page, errors, close: () => context.close() };
}

before(async () => {
  for (const key of ['TALLYD', 'TALLY_WEB_ROOT', 'TALLY_SCREENSHOTS', 'CHROMIUM']) assert.ok(env[key], `${key} is not set`);
  mkdirSync(env.TALLY_SCREENSHOTS, { recursive: true });
  daemon = await new Daemon(env.TALLYD, env.TALLY_WEB_ROOT).start();
  const spec = { renderers: ['forward'], scenes: ['atrium'], resolutions: [[64, 36]],
    cameras: [{ eye: [0, 1.6, -4], target: [0, 1.6, 4], fov_deg: 60 }], frames: 2, counting: 'exact' };
  const text = readFileSync(join(env.TALLY_WEB_ROOT, '..', 'shaders', kShader), 'utf8');
  // The second run's source: one line inserted after line 3 (a variant's change).
  const lines = text.split('\n');
  const changed = [...lines.slice(0, 3), '  // a variant inserted this line', ...lines.slice(3)].join('\n');
  data.runs = [];
  for (const source of [text, changed]) {
    const job = await daemon.capture(spec, kCaptureMs);
    const [run] = (await daemon.get(`/runs?capture=${job.id}`)).runs;
    data.runs.push(run.id);
    data.sources[run.id] = source;
    const codeLines = source.split('\n').map((l, i) => [l, i + 1]).filter(([l]) => /\S/.test(l) && !/^\s*(\/\/|#)/.test(l)).map(([, n]) => n);
    const { samples } = await daemon.get(`/runs/${run.id}/samples`);
    data.first = { ...data.first, [run.id]: samples[0].id };  // the view's default sample
    for (const s of samples) {
      const real = await daemon.get(`/samples/${s.id}`);
      data.samples[s.id] = { id: s.id, real, sites: sitesOf(real, codeLines), draws: drawsOf(real) };
    }
  }
  browser = await chromium.launch({ executablePath: env.CHROMIUM });
});

after(async () => {
  await browser?.close();
  await daemon?.stop();
});

describe('shader view', () => {
  for (const [size, viewport] of Object.entries(kViewports)) {
    test(`source lines, heat bars and shares (${size})`, async () => {
      const { page, errors, close } = await open(`#/shader/${data.runs[0]}`, viewport);
      try {
        const sample = data.samples[data.first[data.runs[0]]];
        // The default pass: where the shader moves the most bytes.
        const byPass = new Map();
        for (const s of sample.sites) byPass.set(s.pass_position, (byPass.get(s.pass_position) || 0) + s.bytes);
        const position = [...byPass.entries()].sort((a, b) => b[1] - a[1])[0][0];
        const total = passBytes(sample.real.passes[position]);
        const expected = new Map();
        for (const s of sample.sites.filter((x) => x.pass_position === position)) {
          const e = expected.get(s.line) || { bytes: 0, resources: [] };
          e.bytes += s.bytes;
          e.resources.push(s.resource);
          expected.set(s.line, e);
        }
        const rows = await page.locator('[data-source] tr[data-bytes]').evaluateAll((trs) => trs.map((tr) => ({
          line: Number(tr.dataset.line), bytes: Number(tr.dataset.bytes), share: tr.dataset.share,
          width: parseFloat(tr.querySelector('.heat > span').style.width) })));
        assert.equal(rows.length, expected.size);
        const heaviest = Math.max(...[...expected.values()].map((e) => e.bytes));
        for (const row of rows) {
          const e = expected.get(row.line);
          assert.ok(e, `line ${row.line} has no site`);
          assert.ok(Math.abs(row.bytes - e.bytes) <= 1e-9 * Math.max(1, e.bytes), `line ${row.line}: ${row.bytes} vs ${e.bytes}`);
          if (total > 0) assert.ok(Math.abs(Number(row.share) - e.bytes / total) < 1e-9);
          assert.ok(Math.abs(row.width - (100 * e.bytes) / heaviest) < 0.01, `line ${row.line}: bar ${row.width}%`);
        }
        // Click the heaviest line: its sites' resources, no more.
        const top = [...expected.entries()].sort((a, b) => b[1].bytes - a[1].bytes)[0];
        await page.locator(`[data-source] tr[data-line="${top[0]}"]`).click();
        const shown = await page.locator(`[data-line-sites="${top[0]}"] tbody tr`).evaluateAll((trs) => trs.map((tr) => tr.dataset.resource));
        assert.deepEqual([...shown].sort(), [...top[1].resources].sort());
        // The ranked table: per pass, its resources' shares (with the derived rest) make the whole.
        const ranked = await page.locator('[data-ranked] tbody tr').evaluateAll((trs) => trs.map((tr) => ({ level: tr.dataset.level, share: Number(tr.dataset.share) })));
        let sum = null;
        for (const r of [...ranked, { level: '1' }]) {
          if (r.level === '1') {
            if (sum !== null) assert.ok(Math.abs(sum - 1) < 1e-9, `a pass's shares sum to ${sum}`);
            sum = 0;
          } else if (r.level === '2') sum += r.share;
        }
        assert.doesNotMatch(await page.locator('#view').innerText(), /\bnull\b/, 'a value shows as null');
        const scroll = await page.evaluate(() => document.documentElement.scrollWidth - document.documentElement.clientWidth);
        assert.ok(scroll <= 1, `scrolls sideways by ${scroll} px`);
        await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, `shader-${size}.png`), fullPage: true });
        assert.deepEqual(errors, []);
      } finally {
        await close();
      }
    });
  }

  test('draws and materials ranked with shares', async () => {
    const { page, errors, close } = await open(`#/shader/${data.runs[0]}?by=material`, kViewports.wide);
    try {
      const ranked = await page.locator('[data-ranked] tbody tr[data-level="2"] td:first-child').allTextContents();
      assert.ok(ranked.includes('stone') && ranked.includes('wood'), ranked.join(', '));
      // stone is draws 0 and 2: 4/6 of every pass, wood 2/6.
      const shares = await page.locator('[data-ranked] tbody tr[data-level="2"]').evaluateAll((trs) => trs.map((tr) => Number(tr.dataset.share)));
      for (const share of shares) assert.ok(Math.abs(share - 4 / 6) < 1e-9 || Math.abs(share - 2 / 6) < 1e-9, String(share));
      assert.deepEqual(errors, []);
    } finally {
      await close();
    }
  });

  test('against another run: the inserted line is marked, the rest match', async () => {
    const { page, errors, close } = await open(`#/shader/${data.runs[0]}?against=${data.runs[1]}`, kViewports.wide);
    try {
      const changes = await page.locator('[data-compare] tbody tr').evaluateAll((trs) => trs.map((tr) => ({ change: tr.dataset.change, a: tr.dataset.a, b: tr.dataset.b })));
      const lines = data.sources[data.runs[0]].split('\n').length;
      assert.equal(changes.length, lines + 1);
      assert.deepEqual(changes.filter((c) => c.change !== 'same'), [{ change: 'added', a: '', b: '4' }]);
      assert.ok(changes.filter((c) => c.change === 'same').every((c) => Number(c.b) === Number(c.a) + (Number(c.a) > 3 ? 1 : 0)));
      await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, 'shader-compare.png'), fullPage: true });
      assert.deepEqual(errors, []);
    } finally {
      await close();
    }
  });

  test('the run view links to it', async () => {
    const { page, errors, close } = await open(`#/runs/${data.runs[0]}`, kViewports.wide);
    try {
      assert.equal(await page.locator('[data-shader-link]').getAttribute('href'), `#/shader/${data.runs[0]}`);
      assert.deepEqual(errors, []);
    } finally {
      await close();
    }
  });
});

// Browser tests of the compare view's crossover overlay: a real `tallyd serve`
// with one capture of three renderers at four resolutions (lavapipe, one
// camera, 2 frames). The scaling charts must draw one dashed line per fit of
// GET /api/crossover (a + b x at the ends of the fitted range), one mark per
// crossing inside the range with its interval, and the fits (R², poor-fit
// flag) and crossings in tables. Whether tiny lavapipe frames cross is up to
// the renderers, so a second page gets the same answer with one crossing
// turned into a constructed one (a Playwright route over the real response):
// the mark and the table must show exactly it. At 360 px nothing scrolls
// sideways, and no page logs a console error.
//
// Environment (tests/web/run.sh sets it): TALLYD, TALLY_WEB_ROOT,
// TALLY_SCREENSHOTS, CHROMIUM.
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { join } from 'node:path';
import { after, before, describe, test } from 'node:test';

import { chromium } from 'playwright-core';

import { Daemon } from './daemon.mjs';

const env = process.env;
const kViewMs = 30_000;
const kCaptureMs = 180_000;
const kViewports = { narrow: { width: 360, height: 800 }, wide: { width: 1280, height: 800 } };

let daemon;
let browser;
const data = {};

async function open(hash, viewport, { crossover } = {}) {
  const context = await browser.newContext({ viewport });
  // A daemon without GET /api/hosts answers 404 there; the runs view never asks here, but be safe.
  await context.route((url) => url.pathname === '/api/hosts', (route) => route.fulfill({ json: { hosts: [], stale_after_s: 30 } }));
  if (crossover) {
    await context.route((url) => url.pathname === '/api/crossover', async (route) => {
      const response = await route.fetch();
      const body = await response.json();
      route.fulfill({ response, json: crossover(body, new URL(route.request().url()).searchParams.get('metric')) });
    });
  }
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

// The chart's datasets (label, data, fit) and its crossing marks.
async function chart(page, id) {
  return page.evaluate((chartId) => {
    const c = window.Chart.getChart(document.querySelector(`[data-chart="${chartId}"] canvas`));
    return {
      datasets: c.data.datasets.map((d) => ({ label: d.label, data: d.data.map((p) => ({ x: p.x, y: p.y })), fit: d.fit || null })),
      marks: c.options.plugins.tallyCrossings.marks,
    };
  }, id);
}

function assertClose(actual, expected, what) {
  assert.ok(Math.abs(actual - expected) <= 1e-9 * Math.max(1, Math.abs(expected)), `${what}: ${actual} != ${expected}`);
}

// The chart draws the answer: a line per fit over the fits' whole range, a mark per crossing in range.
function assertDrawn(drawn, answer) {
  const fits = answer.series.filter((s) => s.fit);
  assert.ok(fits.length >= 2, 'the capture has fits');
  const low = Math.min(...fits.map((s) => s.fit.min_pixels)), high = Math.max(...fits.map((s) => s.fit.max_pixels));
  const lines = drawn.datasets.filter((d) => d.fit);
  assert.deepEqual(lines.map((d) => d.label).sort(), fits.map((s) => `${s.variant} fit`).sort());
  for (const s of fits) {
    const line = lines.find((d) => d.fit.variant === s.variant);
    assert.equal(line.data.length, 2);
    assert.equal(line.data[0].x, low);
    assert.equal(line.data[1].x, high);
    assertClose(line.data[0].y, s.fit.a + s.fit.b * low, `${s.variant} at ${low}`);
    assertClose(line.data[1].y, s.fit.a + s.fit.b * high, `${s.variant} at ${high}`);
    assert.equal(line.fit.r2, s.fit.r2);
  }
  const crossing = answer.crossings.filter((c) => c.kind === 'crosses');
  assert.deepEqual(drawn.marks.map((m) => [m.first, m.second, m.x, m.low, m.high]),
    crossing.map((c) => [c.first, c.second, c.pixels, c.pixels_ci[0], c.pixels_ci[1]]));
}

before(async () => {
  for (const key of ['TALLYD', 'TALLY_WEB_ROOT', 'TALLY_SCREENSHOTS', 'CHROMIUM']) assert.ok(env[key], `${key} is not set`);
  mkdirSync(env.TALLY_SCREENSHOTS, { recursive: true });
  daemon = await new Daemon(env.TALLYD, env.TALLY_WEB_ROOT).start();
  const job = await daemon.capture({
    renderers: ['forward', 'deferred', 'visbuffer'], scenes: ['atrium'],
    resolutions: [[64, 36], [96, 54], [128, 72], [160, 90]],
    cameras: [{ eye: [0, 1.6, -4], target: [0, 1.6, 4], fov_deg: 60 }], frames: 2, counting: 'exact',
  }, kCaptureMs);
  data.capture = job.id;
  data.runs = (await daemon.get(`/runs?capture=${job.id}&limit=1000`)).runs;
  assert.equal(data.runs.length, 12);
  data.bytes = await daemon.get(`/crossover?capture=${job.id}&metric=bytes`);
  data.frameMs = await daemon.get(`/crossover?capture=${job.id}&metric=frame_ms`);
  browser = await chromium.launch({ executablePath: env.CHROMIUM });
});

after(async () => {
  await browser?.close();
  await daemon?.stop();
});

const at160 = (renderer) => data.runs.find((r) => r.renderer === renderer && r.width === 160).id;

describe('crossover', () => {
  test('the scaling charts draw the API\'s fitted lines and crossings; the tables list them', async () => {
    const ids = [at160('deferred'), at160('visbuffer')];
    for (const [size, viewport] of Object.entries(kViewports)) {
      const { page, errors, close } = await open(`#/compare?runs=${ids.join(',')}`, viewport);
      assertDrawn(await chart(page, 'scaling-bytes'), data.bytes);
      assertDrawn(await chart(page, 'scaling-frame-ms'), data.frameMs);
      const fitRows = page.locator('[data-table="fits"] tbody tr');
      assert.equal(await fitRows.count(), data.bytes.series.length + data.frameMs.series.length);
      for (const s of data.bytes.series) {
        const row = page.locator(`[data-table="fits"] tr[data-metric="bytes"][data-variant="${s.variant}"]`);
        assert.equal(Number(await row.getAttribute('data-r2')), s.fit.r2);
        assert.equal(await row.getAttribute('data-poor'), String(s.fit.poor_fit));
      }
      const rows = page.locator('[data-table="crossings"] tbody tr');
      assert.equal(await rows.count(), data.bytes.crossings.length + data.frameMs.crossings.length);
      assert.deepEqual(await page.locator('[data-table="crossings"] tr[data-metric="bytes"]').evaluateAll((trs) => trs.map((tr) => tr.dataset.kind)),
        data.bytes.crossings.map((c) => c.kind));
      const overflow = await page.evaluate(() => document.documentElement.scrollWidth - document.documentElement.clientWidth);
      assert.ok(overflow <= 0, `${size}: the page is ${overflow}px wider than the window`);
      assert.deepEqual(errors, []);
      await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, `crossover-${size}.png`), fullPage: true });
      await close();
    }
  });

  test('a crossing inside the range is marked with its interval and listed with its 16:9 resolution', async () => {
    // The real answer with its first bytes crossing placed in the middle of the range, +-10 %.
    const constructed = (body, metric) => {
      if (metric !== 'bytes') return body;
      const [low, high] = body.crossings[0].range;
      const x = (low + high) / 2;
      body.crossings[0] = { ...body.crossings[0], kind: 'crosses', pixels: x, pixels_se: x * 0.05, pixels_ci: [x * 0.9, x * 1.1],
        resolution: { width: 107, height: 60 }, resolution_ci: [{ width: 101, height: 57 }, { width: 112, height: 63 }],
        lower_below: body.crossings[0].first, lower_above: body.crossings[0].second, lower_throughout: null };
      return body;
    };
    const expected = constructed(structuredClone(data.bytes), 'bytes');
    const ids = [at160('deferred'), at160('visbuffer')];
    for (const [size, viewport] of Object.entries(kViewports)) {
      const { page, errors, close } = await open(`#/compare?runs=${ids.join(',')}`, viewport, { crossover: constructed });
      const drawn = await chart(page, 'scaling-bytes');
      assertDrawn(drawn, expected);
      const c = expected.crossings[0];
      const mark = drawn.marks.find((m) => m.first === c.first && m.second === c.second);
      assert.ok(mark, 'the constructed crossing is marked');
      assert.equal(mark.label, '107×60');
      const row = page.locator(`[data-table="crossings"] tr[data-metric="bytes"][data-first="${c.first}"][data-second="${c.second}"]`);
      assert.equal(await row.getAttribute('data-kind'), 'crosses');
      assert.equal(Number(await row.getAttribute('data-pixels')), c.pixels);
      const text = await row.textContent();
      for (const part of ['crosses', '107×60', '101×57 to 112×63', `${c.first} below, ${c.second} above`]) {
        assert.ok(text.includes(part), `${part} in ${text}`);
      }
      // The mark is drawn: the canvas differs from the same chart without marks.
      const changed = await page.evaluate(() => {
        const c = window.Chart.getChart(document.querySelector('[data-chart="scaling-bytes"] canvas'));
        const withMarks = c.canvas.toDataURL();
        const marks = c.options.plugins.tallyCrossings.marks;
        c.options.plugins.tallyCrossings.marks = [];
        c.update();
        const without = c.canvas.toDataURL();
        c.options.plugins.tallyCrossings.marks = marks;
        c.update();
        return withMarks !== without;
      });
      assert.ok(changed, 'the crossing mark changes the drawing');
      const overflow = await page.evaluate(() => document.documentElement.scrollWidth - document.documentElement.clientWidth);
      assert.ok(overflow <= 0, `${size}: the page is ${overflow}px wider than the window`);
      assert.deepEqual(errors, []);
      await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, `crossover-constructed-${size}.png`), fullPage: true });
      await close();
    }
  });
});

// Browser tests of the dashboard (web/), with Playwright driving Debian's
// Chromium against a real `tallyd serve` filled by real captures (tiny
// resolutions, 2 frames) through POST /api/captures. The charts must draw the
// API's numbers (read back from the Chart.js objects and the tables beside
// them), the compare view must show the API's ratios, a stability sweep's
// view must state its fails_at and chart its points as the API has them, the
// run view its counter headroom, the capture form must start a capture (and a
// sweep) and see it finish, bad input must show the server's error,
// and no page may log a console error. Every view is saved as a PNG, wide
// (1280x800) and narrow (400x800), into $TALLY_SCREENSHOTS.
//
// Environment (tests/web/run.sh sets it): TALLYD, TALLY_WEB_ROOT,
// TALLY_SCREENSHOTS, CHROMIUM.
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { mkdirSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';
import { after, before, describe, test } from 'node:test';

import { chromium } from 'playwright-core';

import { Daemon } from './daemon.mjs';

// The dashboard's own number formatting, so that the expected text follows its
// one rule (web/format.js) instead of a copy of it.
const fmt = await import(pathToFileURL(join(process.env.TALLY_WEB_ROOT, 'format.js')).href);

const env = process.env;
const kViewports = { wide: { width: 1280, height: 800 }, narrow: { width: 400, height: 800 } };
const kViewMs = 30_000;      // a view is drawn within this (lavapipe machines are slow and shared)
const kCaptureMs = 180_000;  // a tiny capture finishes within this

// Within a relative 1e-9: sums of the same numbers in another order.
function assertClose(actual, expected, what) {
  assert.ok(typeof actual === 'number' && typeof expected === 'number', `${what}: ${actual} vs ${expected}`);
  assert.ok(Math.abs(actual - expected) <= 1e-9 * Math.max(1, Math.abs(expected)), `${what}: ${actual} != ${expected}`);
}

const mean = (values) => values.reduce((a, b) => a + b, 0) / values.length;

// The median of a run's frames, pooled over its samples (every camera's
// frame_ms_frames): the frame time the run and compare views show.
async function frameMedian(runId) {
  const { samples } = await daemon.get(`/runs/${runId}/samples`);
  const frames = (await Promise.all(samples.map((s) => daemon.get(`/samples/${s.id}`)))).flatMap((d) => d.frame_ms_frames).sort((a, b) => a - b);
  const m = frames.length >> 1;
  return frames.length % 2 ? frames[m] : (frames[m - 1] + frames[m]) / 2;
}

const kSweepSpec = { sweep: 'depth-reconstruction', near: [0.01], far: [1000], distances: [3, 300], resolution: [32, 18], threshold: { relative: 1e-3 } };

// A point's value at a dotted path ("error.max_relative").
const at = (point, path) => path.split('.').reduce((v, k) => v[k], point);

let daemon;
let browser;
const data = {};  // what the captures produced, from the API

// A fresh page at `hash`, recording its console errors and uncaught exceptions.
async function open(hash, viewport = kViewports.wide) {
  const context = await browser.newContext({ viewport });
  // A daemon without GET /api/hosts (the fleet's route): the runs view's host
  // select asks for it, and Chromium would log the 404. An empty fleet instead.
  if (!data.hostsServed) await context.route((url) => url.pathname === '/api/hosts', (route) => route.fulfill({ json: { hosts: [], stale_after_s: 30 } }));
  const page = await context.newPage();
  const errors = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push({ text: m.text(), url: m.location().url }); });
  page.on('pageerror', (e) => errors.push({ text: `uncaught: ${e.message}`, url: '' }));
  const requests = [];
  page.on('request', (r) => requests.push(new URL(r.url())));
  await page.goto(`${daemon.url}/${hash}`);
  await ready(page);
  return { page, errors, requests, close: () => context.close() };
}

// The view has finished drawing (app.js clears aria-busy) without an error panel.
async function ready(page) {
  await page.waitForFunction(() => {
    const view = document.getElementById('view');
    return view && !view.hasAttribute('aria-busy') && view.querySelector('.page');
  }, null, { timeout: kViewMs });
  const failure = await page.locator('#view .panel.error').allTextContents();
  assert.deepEqual(failure, [], 'the view shows an error');
}

// Runs action (which navigates within the app) and waits for the next view.
async function go(page, action) {
  const before = Number(await page.locator('#view').getAttribute('data-rendered'));
  await action();
  await page.waitForFunction((n) => Number(document.getElementById('view').dataset.rendered) > n, before, { timeout: kViewMs });
  await ready(page);
}

async function chart(page, id) {
  return page.evaluate((chartId) => {
    const canvas = document.querySelector(`[data-chart="${chartId}"] canvas`);
    const c = canvas && window.Chart.getChart(canvas);
    if (!c) return null;
    return { labels: c.data.labels, datasets: c.data.datasets.map((d) => ({ label: d.label, data: d.data, whiskers: d.whiskers || null })) };
  }, id);
}

async function screenshot(page, name) {
  await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, `${name}.png`), fullPage: true });
}

// The run of `renderer` as it is (no options), or of a variant label.
const runOf = (renderer, width, counting = 'exact') =>
  data.runs.find((r) => r.variant === renderer && r.width === width && r.counting === counting);
// The founding study's clamped uv derivatives: measured against the float32 ones (their reference).
const kVariant = { renderer: 'visbuffer', options: { uv_derivatives: 'unorm16-clamped' } };
const kVariantLabel = 'visbuffer uv_derivatives=unorm16-clamped';

before(async () => {
  for (const key of ['TALLYD', 'TALLY_WEB_ROOT', 'TALLY_SCREENSHOTS', 'CHROMIUM']) assert.ok(env[key], `${key} is not set`);
  mkdirSync(env.TALLY_SCREENSHOTS, { recursive: true });
  daemon = await new Daemon(env.TALLYD, env.TALLY_WEB_ROOT).start();
  data.hostsServed = (await daemon.api('/hosts').catch(() => ({ status: 0 }))).status === 200;
  // Four renderers at two resolutions (the scaling chart needs two), counted
  // exactly (the references), then three counting modes next to exact for the
  // speed/accuracy view (one of them accumulate, the default). 10 cameras each.
  await daemon.capture({ renderers: ['forward', 'deferred', 'visbuffer', 'visbuffer-lean'], scenes: ['atrium'], resolutions: [[64, 36], [128, 72]], frames: 2, counting: 'exact' }, kCaptureMs);
  for (const counting of ['subgroup', 'sampled:4', undefined]) {
    await daemon.capture({ renderers: ['deferred', 'visbuffer'], resolutions: [[128, 72]], frames: 2, ...(counting ? { counting } : {}) }, kCaptureMs);
  }
  // A repeated capture of one configuration: the compare view's spread across captures.
  await daemon.capture({ renderers: ['visbuffer-lean'], scenes: ['atrium'], resolutions: [[128, 72]], frames: 2, counting: 'exact' }, kCaptureMs);
  // One variant of visbuffer beside the default one at 128x72.
  await daemon.capture({ renderers: [kVariant], scenes: ['atrium'], resolutions: [[128, 72]], frames: 2, counting: 'exact' }, kCaptureMs);
  data.runs = (await daemon.get('/runs?limit=1000')).runs;
  assert.equal(data.runs.length, 16);
  // One small stability sweep: one point holds (3 m), one fails (300 m), so
  // fails_at states a value and a hold (tests/service/sweeps_test.cpp).
  const sweepJob = await daemon.capture(kSweepSpec, kCaptureMs);
  assert.equal(sweepJob.sweeps.length, 1);
  data.sweep = await daemon.get(`/sweeps/${sweepJob.sweeps[0]}`);
  browser = await chromium.launch({ executablePath: env.CHROMIUM });
});

after(async () => {
  await browser?.close();
  await daemon?.stop();
});

describe('dashboard', () => {
  test('every view loads, wide and narrow, without console errors or sideways scrolling', async () => {
    const deferred = runOf('deferred', 128);
    const views = {
      runs: '#/runs',
      run: `#/runs/${deferred.id}`,
      compare: `#/compare?runs=${deferred.id},${runOf('visbuffer', 128).id},${runOf('visbuffer-lean', 128).id}`,
      'accuracy-counting': '#/accuracy?error=counting&cost=overhead',
      'accuracy-image': '#/accuracy?error=image&cost=frame',
      sweeps: '#/sweeps',
      sweep: `#/sweeps/${data.sweep.id}`,
      capture: '#/capture',
    };
    for (const [name, hash] of Object.entries(views)) {
      for (const [size, viewport] of Object.entries(kViewports)) {
        const { page, errors, close } = await open(hash, viewport);
        assert.ok(await page.locator('#view h1').count() === 1, `${name}: a heading`);
        const overflow = await page.evaluate(() => document.documentElement.scrollWidth - document.documentElement.clientWidth);
        assert.ok(overflow <= 0, `${name} ${size}: the page is ${overflow}px wider than the window`);
        if (name === 'run') {
          // Lazy screenshots load once scrolled to; wait for each to show.
          for (const img of await page.locator('.gallery img').all()) await img.scrollIntoViewIfNeeded();
          await page.waitForFunction(() => [...document.querySelectorAll('.gallery img')].every((i) => i.complete && i.naturalWidth > 0), null, { timeout: kViewMs });
        }
        await screenshot(page, `${name}-${size}`);
        assert.deepEqual(errors, [], `${name} ${size}: console errors`);
        await close();
      }
    }
  });

  test('runs view: the API\'s runs, a page at a time, filtered, sorted, linked', async () => {
    const { page, errors, requests, close } = await open('#/runs');
    const ids = () => page.locator('tbody tr[data-run-id]').evaluateAll((rows) => rows.map((r) => Number(r.dataset.runId)));
    assert.deepEqual(await ids(), data.runs.map((r) => r.id), 'newest first, as the API lists them');

    // One page of runs, and no samples: the view stays fast with thousands of runs.
    const lists = requests.filter((u) => u.pathname === '/api/runs');
    assert.ok(lists.length >= 1);
    for (const u of lists) assert.equal(u.searchParams.get('limit'), '100');
    assert.equal(requests.filter((u) => u.pathname.startsWith('/api/samples') || u.pathname.endsWith('/samples')).length, 0);

    // Each row links to its run.
    const first = data.runs[0];
    assert.equal(await page.locator(`tr[data-run-id="${first.id}"] a`).first().getAttribute('href'), `#/runs/${first.id}`);

    // Sorting by bytes per frame: ascending, then descending.
    const byBytes = [...data.runs].sort((a, b) => a.mean_bytes - b.mean_bytes || b.id - a.id).map((r) => r.id);
    await page.click('button.sort[data-sort="mean_bytes"]');
    assert.deepEqual(await ids(), byBytes);
    await page.click('button.sort[data-sort="mean_bytes"]');
    assert.deepEqual(await ids(), [...data.runs].sort((a, b) => b.mean_bytes - a.mean_bytes || b.id - a.id).map((r) => r.id));

    // Renderer filter: the server's answer for renderer=deferred.
    await go(page, () => page.selectOption('select[name="renderer"]', 'deferred'));
    const deferred = (await daemon.get('/runs?renderer=deferred&limit=1000')).runs.map((r) => r.id);
    assert.ok(deferred.length >= 2);
    assert.deepEqual(await ids(), deferred);

    // Resolution filter, with the renderer kept.
    await page.fill('input[name="resolution"]', '64x36');
    await go(page, () => page.click('form.filters button[type="submit"]'));
    assert.deepEqual(await ids(), (await daemon.get('/runs?renderer=deferred&width=64&height=36')).runs.map((r) => r.id));

    // Dates: every run is from the day of its capture; nothing before it.
    const day = first.created_at.slice(0, 10);
    await go(page, () => page.goto(`${daemon.url}/#/runs?since=${day}&until=${day}`));
    assert.deepEqual(await ids(), data.runs.map((r) => r.id));
    const before = new Date(Date.parse(day) - 86_400_000).toISOString().slice(0, 10);
    await go(page, () => page.fill('input[name="until"]', before));  // a date applies when it changes
    assert.deepEqual(await ids(), []);
    assert.match(await page.locator('#view').textContent(), /No runs match/);

    // Device filter, from the device list.
    await go(page, () => page.goto(`${daemon.url}/#/runs`));
    await go(page, () => page.selectOption('select[name="device"]', String(first.device_id)));
    assert.deepEqual(await ids(), data.runs.filter((r) => r.device_id === first.device_id).map((r) => r.id));

    // A row's link opens its run.
    await go(page, () => page.click(`tr[data-run-id="${first.id}"] a`));
    assert.match(await page.locator('h1').textContent(), new RegExp(`Run #${first.id}:`));
    assert.deepEqual(errors, []);
    await close();
  });

  test('run view: the charts draw the API\'s per-pass, per-resource and per-camera numbers', async () => {
    const id = runOf('deferred', 128).id;
    const run = await daemon.get(`/runs/${id}`);
    const { samples } = await daemon.get(`/runs/${id}/samples`);
    assert.equal(samples.length, 10);

    // The API's own consistency: a run's passes are its samples' averages, and
    // a sample's bytes_read/bytes_written sum its counters.
    const details = await Promise.all(samples.map((s) => daemon.get(`/samples/${s.id}`)));
    for (const [i, s] of samples.entries()) {
      const counters = details[i].passes.flatMap((p) => p.resources);
      assertClose(s.bytes_read, counters.filter((c) => c.access === 'read').reduce((a, c) => a + c.bytes, 0), `sample ${s.id} read`);
      assertClose(s.bytes_written, counters.filter((c) => c.access === 'write').reduce((a, c) => a + c.bytes, 0), `sample ${s.id} written`);
      assertClose(s.bytes_read + s.bytes_written, s.bytes, `sample ${s.id} total`);
    }
    for (const [k, pass] of run.passes.entries()) {
      assertClose(pass.gpu_ms, mean(details.map((d) => d.passes[k].gpu_ms)), `${pass.name} gpu_ms`);
      for (const r of pass.resources) {
        const per = details.map((d) => d.passes[k].resources.filter((c) => c.name === r.name && c.access === r.access && c.source === r.source).reduce((a, c) => a + c.bytes, 0));
        assertClose(r.bytes, mean(per), `${pass.name} ${r.name} ${r.access}`);
      }
    }

    const { page, errors, close } = await open(`#/runs/${id}`);
    // The build that made the run, as the API has it.
    assert.ok(run.tally_commit, 'the run records its build');
    assert.equal(await page.locator('[data-build]').textContent(), `tally ${run.tally_version} (${run.tally_commit})`);
    for (const access of ['read', 'write']) {
      const c = await chart(page, `pass-resource-${access}`);
      assert.deepEqual(c.labels, run.passes.map((p) => p.name));
      const names = [...new Set(run.passes.flatMap((p) => p.resources.filter((r) => r.access === access).map((r) => r.name)))];
      assert.deepEqual(c.datasets.map((d) => d.label).sort(), [...names].sort(), `${access}: one stack segment per resource`);
      for (const d of c.datasets) {
        run.passes.forEach((p, i) => {
          const mine = p.resources.filter((r) => r.name === d.label && r.access === access);
          if (mine.length === 0) assert.equal(d.data[i], null, `${p.name} ${d.label}`);
          else assertClose(d.data[i], mine.reduce((a, r) => a + r.bytes, 0), `${p.name} ${d.label} ${access}`);
        });
      }
    }
    const perSample = await chart(page, 'per-sample');
    assert.deepEqual(perSample.datasets[0].data, samples.map((s) => s.bytes_read));
    assert.deepEqual(perSample.datasets[1].data, samples.map((s) => s.bytes_written));
    // The table beside the chart carries the same numbers.
    const cells = await page.locator('[data-chart-table="per-sample"] tbody tr').evaluateAll((rows) => rows.map((r) => [...r.querySelectorAll('td')].map((td) => Number(td.dataset.value))));
    assert.deepEqual(cells, samples.map((s) => [s.bytes_read, s.bytes_written]));

    const time = await chart(page, 'pass-time');
    assert.deepEqual(time.datasets[0].data, run.passes.map((p) => p.gpu_ms));
    assert.deepEqual(time.datasets[1].data, run.passes.map((p) => p.gpu_ms_instrumented));
    // Whiskers: each pass's IQR over frames, q1 and q3 of the samples' gpu_ms_spread averaged like the bar.
    run.passes.forEach((p, k) => {
      const w = time.datasets[0].whiskers[k];
      assert.ok(w, `${p.name} has a whisker`);
      assertClose(w[0], mean(details.map((d) => d.passes[k].gpu_ms_spread.q1)), `${p.name} q1`);
      assertClose(w[1], mean(details.map((d) => d.passes[k].gpu_ms_spread.q3)), `${p.name} q3`);
      assert.ok(w[0] <= w[1], `${p.name} q1 <= q3`);
    });
    // Per camera: the frame time bar is the API's median, its whisker exactly the API's q1 and q3.
    const sampleTime = await chart(page, 'sample-time');
    assert.deepEqual(sampleTime.datasets[0].data, samples.map((s) => s.frame_ms));
    assert.deepEqual(sampleTime.datasets[0].whiskers, samples.map((s) => [s.frame_ms_spread.q1, s.frame_ms_spread.q3]));
    for (const s of samples) assert.equal(s.frame_ms_spread.median, s.frame_ms, `sample ${s.id}: frame_ms is the median`);
    const iqrCells = await page.locator('[data-chart-table="sample-time"] tbody td').evaluateAll((tds) => tds.map((td) => [Number(td.dataset.q1), Number(td.dataset.q3)]));
    assert.deepEqual(iqrCells, samples.map((s) => [s.frame_ms_spread.q1, s.frame_ms_spread.q3]));

    // Tiles: overhead ratio and image error against forward, as the API gives them.
    assert.equal((await page.locator('[data-tile="overhead"] .value').textContent()), fmt.ratio(run.mean_overhead_ratio));
    assert.equal((await page.locator('[data-tile="image-error"] .value').textContent()), fmt.psnr(run.image_error.mean_psnr));
    // Frame time: the median of all the run's frames (every camera's), as the trend and compare show it.
    assert.equal((await page.locator('[data-tile="frame-ms"] .value').textContent()), fmt.ms(await frameMedian(run.id)));

    // Gallery: one screenshot per camera, at the run's resolution, with its sky fraction.
    const shots = page.locator('.gallery figure');
    assert.equal(await shots.count(), samples.length);
    for (const [i, s] of samples.entries()) {
      const shot = shots.nth(i);
      await shot.scrollIntoViewIfNeeded();
      assert.equal(Number(await shot.getAttribute('data-sample')), s.id);
      assert.match(await shot.textContent(), new RegExp(`Camera ${s.camera_index}`));
      assert.ok((await shot.textContent()).includes(`sky ${(100 * s.sky_fraction).toFixed(1)} %`) || s.sky_fraction < 0.01, `camera ${s.camera_index} sky fraction`);
    }
    await page.waitForFunction(() => [...document.querySelectorAll('.gallery img')].every((i) => i.complete && i.naturalWidth > 0), null, { timeout: kViewMs });
    const sizes = await page.locator('.gallery img').evaluateAll((imgs) => imgs.map((i) => [i.naturalWidth, i.naturalHeight]));
    for (const size of sizes) assert.deepEqual(size, [run.width, run.height]);
    assert.deepEqual(errors, []);
    await close();
  });

  test('compare view: totals, ratios and per-resource figures are the API\'s; scaling and images', async () => {
    const runs = [runOf('deferred', 128), runOf('visbuffer', 128), runOf('visbuffer-lean', 128)];
    const ids = runs.map((r) => r.id);
    const c = await daemon.get(`/compare?runs=${ids.join(',')}`);
    const medians = await Promise.all(ids.map(frameMedian));
    const { page, errors, close } = await open(`#/compare?runs=${ids.join(',')}`);

    // The ratio of total bytes per frame against the first run: the API's, and
    // the runs' own totals divided.
    const totalCells = page.locator('[data-table="totals"] tr[data-row="total_bytes"] td');
    assert.equal(await totalCells.count(), 3);
    for (let i = 1; i < 3; ++i) {
      const ratio = Number(await totalCells.nth(i).getAttribute('data-ratio'));
      assert.equal(ratio, c.total_bytes[i].ratio);
      assertClose(ratio, runs[i].mean_bytes / runs[0].mean_bytes, `ratio of run ${ids[i]}`);
      assert.ok((await totalCells.nth(i).textContent()).includes(`×${ratio.toFixed(3)}`));
      const frameRatio = Number(await page.locator('[data-table="totals"] tr[data-row="frame_ms"] td').nth(i).getAttribute('data-ratio'));
      assertClose(frameRatio, medians[i] / medians[0], `frame time ratio of run ${ids[i]}`);
    }

    // Per resource: the 10 largest first (glance.test.mjs checks the order and "show all").
    const resources = await chart(page, 'compare-resources');
    const shown = resources.labels.map((label) => c.resources.find((r) => `${r.resource} (${r.access})` === label));
    assert.equal(shown.length, Math.min(10, c.resources.length));
    resources.datasets.forEach((d, i) => assert.deepEqual(d.data, shown.map((r) => r.bytes[i].value)));
    const passes = await chart(page, 'compare-pass-ms');
    passes.datasets.forEach((d, i) => assert.deepEqual(d.data, c.passes.map((p) => p.gpu_ms[i].value)));
    const frame = await chart(page, 'compare-frame-ms');
    assert.deepEqual(frame.datasets[0].data, medians);

    // Across repeated captures: visbuffer-lean was captured twice with one
    // configuration, the others once. The table and the chart give the API's
    // group median and IQR for it, and nothing for the others. Each capture's
    // value is its run's frame_ms_median, the frame time of every other view,
    // shown with its interval where the API gives one.
    const { groups } = await daemon.get(`/repeats?renderer=visbuffer-lean&width=128&height=72`);
    const group = groups.find((g) => g.runs.includes(ids[2]));
    assert.ok(group, 'the repeated visbuffer-lean capture forms a group');
    assert.equal(group.runs.length, 2);
    assert.equal(group.frame_ms.statistic, 'frame_ms_median');
    const groupRuns = group.runs.map((id) => data.runs.find((r) => r.id === id));
    assert.deepEqual(group.frame_ms.per_run, groupRuns.map((r) => r.frame_ms_median));
    assert.deepEqual(group.bytes.per_run, groupRuns.map((r) => r.mean_bytes));
    const rows = page.locator('[data-table="repeats"] tbody tr');
    await rows.first().waitFor({ timeout: kViewMs });
    assert.deepEqual(await rows.evaluateAll((trs) => trs.map((tr) => Number(tr.dataset.captures))), [1, 1, 2]);
    const leanRow = page.locator(`[data-table="repeats"] tr[data-run="${ids[2]}"]`);
    for (const key of ['median', 'q1', 'q3']) assert.equal(Number(await leanRow.getAttribute(`data-${key}`)), group.frame_ms[key], key);
    assert.equal(await leanRow.getAttribute('data-statistic'), 'frame_ms_median');
    assert.match(await page.locator('[data-table="repeats"] thead').innerText(), /median of all frames/);
    const captureCells = leanRow.locator('[data-cell="captures"] [data-capture]');
    assert.deepEqual(await captureCells.evaluateAll((divs) => divs.map((d) => [Number(d.dataset.capture), Number(d.dataset.value)])),
      group.runs.map((id, k) => [id, group.frame_ms.per_run[k]]));
    for (let k = 0; k < group.runs.length; ++k) {
      const text = await captureCells.nth(k).innerText();
      const lower = group.frame_ms.per_run_lower[k];
      assert.ok(text.includes(`#${group.runs[k]}: `), text);
      // An interval appears exactly where the API gives one (20 frames: it does).
      assert.equal(text.includes('['), lower !== null, text);
    }
    const repeated = await chart(page, 'compare-repeats-ms');
    assert.deepEqual(repeated.datasets[0].data, [null, null, group.frame_ms.median]);
    assert.deepEqual(repeated.datasets[0].whiskers, [null, null, [group.frame_ms.q1, group.frame_ms.q3]]);

    // Scaling: per renderer, bytes per frame at each pixel count (64x36 and 128x72).
    const scaling = await chart(page, 'scaling-bytes');
    assert.deepEqual(scaling.datasets.map((d) => d.label), ['deferred', 'visbuffer', 'visbuffer-lean']);
    for (const d of scaling.datasets) {
      const expected = [runOf(d.label, 64), runOf(d.label, 128)].map((r) => ({ x: r.width * r.height, y: r.mean_bytes, run: r.id }));
      assert.deepEqual(d.data, expected);
    }

    // Images: A against itself differs nowhere; against forward, the mean
    // absolute difference is the capture's own image error for that camera.
    await page.waitForSelector('[data-image="diff"]', { timeout: kViewMs });
    await page.selectOption('select[name="b"]', String(ids[0]));
    await page.waitForSelector('[data-image="diff"][data-max-abs="0"]', { timeout: kViewMs });
    const withForward = await open(`#/compare?runs=${runOf('forward', 128).id},${ids[0]}`);
    const viewer = withForward.page;
    await viewer.waitForSelector('[data-image="diff"]', { timeout: kViewMs });
    await viewer.selectOption('select[name="camera"]', '2');
    const diff = viewer.locator('[data-image="diff"][data-camera="2"]');
    await diff.waitFor({ timeout: kViewMs });
    const { samples } = await daemon.get(`/runs/${ids[0]}/samples`);
    const sample = samples.find((s) => s.camera_index === 2);
    const meanAbs = Number(await diff.getAttribute('data-mean-abs'));
    assertClose(meanAbs, sample.image_error.mean_abs, 'mean absolute difference against forward');
    await screenshot(viewer, 'compare-images-wide');
    assert.deepEqual(withForward.errors, []);
    await withForward.close();
    assert.deepEqual(errors, []);
    await close();
  });

  test('compare view: each run\'s significance is the API\'s, its ratio the camera-aligned frames\' medians; level and pooling can be changed', async () => {
    const runs = [runOf('forward', 128), runOf('deferred', 128), runOf('visbuffer', 128)];
    const ids = runs.map((r) => r.id);
    const c = await daemon.get(`/compare?runs=${ids.join(',')}`);
    assert.equal(c.significance.length, 2);
    // Every run's per-frame times by camera, from the samples route.
    const framesOf = async (id) => {
      const { samples } = await daemon.get(`/runs/${id}/samples`);
      const byCamera = new Map();
      for (const s of samples) byCamera.set(s.camera_index, (await daemon.get(`/samples/${s.id}`)).frame_ms_frames);
      return byCamera;
    };
    const median = (values) => {
      const v = [...values].sort((x, y) => x - y);
      return v.length % 2 ? v[(v.length - 1) / 2] : 0.5 * (v[v.length / 2 - 1] + v[v.length / 2]);
    };
    // Each camera's frames of both runs scaled by (median of all) / (median of the camera's).
    const alignedRatio = (fa, fb) => {
      const grand = median([...fa.values(), ...fb.values()].flat());
      const a = [], b = [];
      for (const [camera, times] of fa) {
        const m = median([...times, ...fb.get(camera)]);
        a.push(...times.map((t) => (t * grand) / m));
        b.push(...fb.get(camera).map((t) => (t * grand) / m));
      }
      return median(b) / median(a);
    };
    const framesA = await framesOf(ids[0]);
    const { page, errors, close } = await open(`#/compare?runs=${ids.join(',')}`);
    const table = page.locator('[data-table="significance"]');
    await table.waitFor({ timeout: kViewMs });
    for (const s of c.significance) {
      const framesB = await framesOf(s.run_b);
      assert.equal(s.frame.strata, 'cameras');
      assert.equal(s.frame.n_a, [...framesA.values()].flat().length);
      assert.equal(s.frame.n_b, [...framesB.values()].flat().length);
      assertClose(s.frame.ratio, alignedRatio(framesA, framesB), `frame ratio of run ${s.run_b}`);
      const row = page.locator(`[data-table="significance"] tr[data-run="${s.run_b}"][data-figure="frame"]`);
      assert.equal(await row.getAttribute('data-verdict'), s.frame.verdict);
      assert.equal(Number(await row.getAttribute('data-ratio')), s.frame.ratio);
      assert.equal(Number(await row.getAttribute('data-p')), s.frame.mann_whitney.p);
      assert.ok((await row.textContent()).includes(`×${s.frame.ratio.toFixed(3)}`));
      const figures = await page.locator(`[data-table="significance"] tr[data-run="${s.run_b}"]`).evaluateAll((trs) => trs.map((tr) => tr.dataset.figure));
      assert.deepEqual(figures, ['frame', ...s.passes.map((p) => p.pass), ...s.passes_missing.map((p) => p.pass)]);
      const counts = page.locator(`ul.counts-verdicts li[data-run="${s.run_b}"]`);
      assert.equal(await counts.getAttribute('data-counts'), s.counts.verdict);
      assert.equal(Number(await counts.getAttribute('data-changes')), s.counts.changes.length);
    }
    // Different renderers write different attachments: their counts changed.
    assert.equal(c.significance[0].counts.verdict, 'changed');
    // At 99% the interval is the API's at 99%, and no narrower than at 95%.
    const c99 = await daemon.get(`/compare?runs=${ids.join(',')}&confidence=0.99`);
    await page.selectOption('select[name="confidence"]', '0.99');
    await page.locator('[data-table="significance"][data-confidence="0.99"]').waitFor({ timeout: kViewMs });
    for (const [i, s] of c99.significance.entries()) {
      const row = page.locator(`[data-table="significance"] tr[data-run="${s.run_b}"][data-figure="frame"]`);
      const lower = await row.getAttribute('data-lower');
      assert.equal(lower === '' ? null : Number(lower), s.frame.interval.lower);
      if (s.frame.interval.lower !== null && c.significance[i].frame.interval.lower !== null) {
        assert.ok(s.frame.interval.lower <= c.significance[i].frame.interval.lower, '99% is no narrower than 95%');
      }
    }
    // Unticking "Align each camera" asks for the raw frames pooled: the ratio of pooled medians.
    await page.uncheck('input[name="strata"]');
    await page.locator('[data-table="significance"][data-strata="none"]').waitFor({ timeout: kViewMs });
    const pooledRow = page.locator(`[data-table="significance"] tr[data-run="${ids[1]}"][data-figure="frame"]`);
    const framesB = await framesOf(ids[1]);
    assertClose(Number(await pooledRow.getAttribute('data-ratio')), median([...framesB.values()].flat()) / median([...framesA.values()].flat()), 'pooled frame ratio');
    await screenshot(page, 'compare-significance');
    assert.deepEqual(errors, []);
    await close();
  });

  test('speed vs accuracy: one point per run, error against exact, the Pareto front', async () => {
    const { page, errors, close } = await open('#/accuracy?error=counting&cost=overhead');
    const c = await chart(page, 'accuracy');
    const plotted = c.datasets.filter((d) => d.label !== 'Pareto front').flatMap((d) => d.data.map((p) => ({ ...p, mode: d.label })));

    // Expected: the API's rows (deferred and visbuffer at 128x72 in subgroup,
    // sampled:4 and accumulate), each against the exact run of its renderer,
    // which is drawn at error 0 with its own overhead ratio.
    const { rows: accuracyRows } = await daemon.get('/accuracy');
    assert.equal(accuracyRows.length, 6);
    assert.equal(accuracyRows.filter((r) => r.counting === 'accumulate').length, 2, 'the accumulate mode has its points');
    const expectedOf = (field) => {
      const points = [];
      for (const row of accuracyRows) {
        const exact = runOf(row.renderer, 128);
        assert.equal(row.reference, exact.id, `run ${row.run}: the exact run of the same frames`);
        assert.equal(row.run, runOf(row.renderer, 128, row.counting).id);
        points.push({ x: row[field], y: row.overhead_ratio, run: row.run, mode: row.counting });
        if (!points.some((p) => p.run === exact.id)) points.push({ x: 0, y: row.reference_overhead_ratio, run: exact.id, mode: 'exact' });
      }
      return points;
    };
    for (const row of accuracyRows) {
      // The error of the totals is what comparing the runs' mean bytes gives.
      const r = runOf(row.renderer, 128, row.counting);
      const exact = runOf(row.renderer, 128);
      assertClose(row.total_error, Math.abs(r.mean_bytes - exact.mean_bytes) / exact.mean_bytes, `run ${row.run} total error`);
      // Subgroup and accumulate counting are exact on lavapipe: no line differs.
      if (row.counting === 'subgroup' || row.counting === 'accumulate') assert.equal(row.l1_error, 0, `run ${row.run} ${row.counting} L1 error`);
      assert.ok(row.total_error <= row.l1_error + 1e-12, `run ${row.run}: totals cancel, lines do not`);
    }
    const expected = expectedOf('l1_error');
    const byRun = (a, b) => a.run - b.run;
    assert.deepEqual(plotted.sort(byRun), expected.sort(byRun));

    // The other measures: the same points at the API's other figures.
    for (const [metric, field] of [['total', 'total_error'], ['worst', 'worst_error']]) {
      await go(page, () => page.selectOption('select[name="metric"]', metric));
      const other = await chart(page, 'accuracy');
      const points = other.datasets.filter((d) => d.label !== 'Pareto front').flatMap((d) => d.data.map((p) => ({ ...p, mode: d.label })));
      assert.deepEqual(points.sort(byRun), expectedOf(field).sort(byRun), `${metric}: the API's ${field}`);
    }
    await go(page, () => page.selectOption('select[name="metric"]', 'l1'));
    await chart(page, 'accuracy');

    // The front: no point beats a front point on both axes, and every other
    // point is beaten (or matched) by one on the front.
    const rows = await page.locator('[data-chart-table="accuracy"] tbody tr').evaluateAll((trs) => trs.map((t) => ({ run: Number(t.dataset.run), front: t.dataset.front === 'true' })));
    const front = new Set(rows.filter((r) => r.front).map((r) => r.run));
    assert.ok(front.size >= 1);
    const beats = (a, b) => a.x <= b.x && a.y <= b.y && (a.x < b.x || a.y < b.y);
    for (const p of expected) {
      if (front.has(p.run)) assert.ok(!expected.some((q) => beats(q, p)), `run ${p.run} is on the front but beaten`);
      else assert.ok(expected.some((q) => front.has(q.run) && (beats(q, p) || (q.x === p.x && q.y === p.y))), `run ${p.run} is off the front but unbeaten`);
    }
    const line = c.datasets.find((d) => d.label === 'Pareto front');
    assert.deepEqual(new Set(line.data.map((p) => p.run)), front);

    // Image error: one point per run compared against forward, at its mean
    // PSNR; the cost chosen before (overhead ratio) stays.
    await go(page, () => page.selectOption('select[name="error"]', 'image'));
    const image = await chart(page, 'accuracy');
    const points = image.datasets.filter((d) => d.label !== 'Pareto front').flatMap((d) => d.data);
    const compared = data.runs.filter((r) => r.image_error);
    assert.equal(points.length, compared.length);
    for (const r of compared.filter((run) => run.image_error.mean_psnr !== null)) {
      const p = points.find((q) => q.run === r.id);
      assert.equal(p.x, r.image_error.mean_psnr);
      assert.equal(p.y, r.mean_overhead_ratio);
    }
    assert.deepEqual(errors, []);
    await close();
  });

  test('variants: labelled in the runs list, their own column in compare, their own series in accuracy, variant error in the run view', async () => {
    const variant = runOf(kVariantLabel, 128);
    const plain = runOf('visbuffer', 128);
    assert.ok(variant && plain, 'the variant and the default visbuffer at 128x72');
    assert.deepEqual(variant.options, kVariant.options);
    assert.notEqual(variant.id, plain.id);

    // Runs list: the renderer column carries the label.
    const runsPage = await open('#/runs');
    const row = runsPage.page.locator(`tbody tr[data-run-id="${variant.id}"]`);
    await row.waitFor({ timeout: kViewMs });
    assert.ok((await row.textContent()).includes(kVariantLabel));
    assert.deepEqual(runsPage.errors, []);
    await runsPage.close();

    // Compare: the variant is a column of its own next to the default visbuffer, at the API's ratio.
    const c = await daemon.get(`/compare?runs=${plain.id},${variant.id}`);
    const { page, errors, close } = await open(`#/compare?runs=${plain.id},${variant.id}`);
    const headers = await page.locator('[data-table="totals"] thead th').allTextContents();
    assert.ok(headers.some((t) => t.includes(`visbuffer #${plain.id}`)), headers.join(' | '));
    assert.ok(headers.some((t) => t.includes(`${kVariantLabel} #${variant.id}`)), headers.join(' | '));
    const ratio = Number(await page.locator('[data-table="totals"] tr[data-row="total_bytes"] td').nth(1).getAttribute('data-ratio'));
    assert.equal(ratio, c.total_bytes[1].ratio);
    assertClose(ratio, variant.mean_bytes / plain.mean_bytes, 'variant bytes ratio');
    // Scaling: the two are separate series, not merged into one visbuffer line.
    const scaling = await chart(page, 'scaling-bytes');
    assert.deepEqual(scaling.datasets.map((d) => d.label).sort(), ['visbuffer', kVariantLabel].sort());
    assert.deepEqual(scaling.datasets.find((d) => d.label === kVariantLabel).data, [{ x: 128 * 72, y: variant.mean_bytes, run: variant.id }]);
    assert.deepEqual(errors, []);
    await close();

    // Speed vs accuracy (image error): the variant is its own series with its own point.
    const accuracy = await open('#/accuracy?error=image&cost=frame');
    const image = await chart(accuracy.page, 'accuracy');
    const series = image.datasets.find((d) => d.label === kVariantLabel);
    assert.ok(series, `a series named ${kVariantLabel}: ${image.datasets.map((d) => d.label).join(', ')}`);
    assert.deepEqual(series.data.map((p) => p.run), [variant.id]);
    if (variant.image_error.mean_psnr !== null) assert.equal(series.data[0].x, variant.image_error.mean_psnr);
    assert.ok(!image.datasets.find((d) => d.label === 'visbuffer').data.some((p) => p.run === variant.id));
    assert.deepEqual(accuracy.errors, []);
    await accuracy.close();

    // Run view: the options are listed; each sample's error against the
    // reference variant (float32 derivatives) is the API's.
    const { samples } = await daemon.get(`/runs/${variant.id}/samples`);
    assert.ok(samples.every((s) => s.variant_error && s.variant_error.against === 'visbuffer uv_derivatives=float32'));
    const runView = await open(`#/runs/${variant.id}`);
    assert.ok((await runView.page.locator('h1').textContent()).includes(kVariantLabel));
    assert.equal(await runView.page.locator('[data-options]').textContent(), 'options: uv_derivatives=unorm16-clamped');
    const shown = await runView.page.locator('[data-variant-error]').evaluateAll((els) => els.map((e) => e.dataset.variantError));
    assert.deepEqual(shown, samples.map((s) => String(s.variant_error.psnr)));
    assert.deepEqual(runView.errors, []);
    await runView.close();
  });

  test('capture form: starts a capture and follows it to the end', async () => {
    const { page, errors, close } = await open('#/capture');
    for (const box of await page.locator('input[name="renderers"]').all()) {
      if ((await box.getAttribute('value')) !== 'forward') await box.uncheck();
    }
    // forward is not among the form's default renderers (deferred and visbuffer).
    await page.locator('input[name="renderers"][value="forward"]').first().check();
    await page.fill('input[name="resolutions"]', '64x36');
    await page.fill('input[name="frames"]', '1');
    // Record every status the progress panel shows.
    await page.evaluate(() => {
      window.seenStatuses = [];
      new MutationObserver(() => {
        const s = document.querySelector('.progress-box [data-status]')?.dataset.status;
        if (s && window.seenStatuses.at(-1) !== s) window.seenStatuses.push(s);
      }).observe(document.querySelector('.progress-box'), { childList: true, subtree: true });
    });
    await page.click('form.capture-form button[type="submit"]');
    const panel = page.locator('.progress-box [data-status="done"]');
    await panel.waitFor({ timeout: kCaptureMs });
    const id = Number(await panel.getAttribute('data-capture'));
    const job = await daemon.get(`/captures/${id}`);
    assert.equal(job.status, 'done');
    assert.deepEqual(job.spec.renderers, ['forward']);
    assert.equal(job.spec.counting, 'accumulate', 'the form preselects the default mode');
    assert.ok(!('counted_frames' in job.spec), 'an empty counted-frames field leaves the default');
    assert.deepEqual(job.spec.resolutions, [[64, 36]]);
    const statuses = await page.evaluate(() => window.seenStatuses);
    assert.equal(statuses.at(-1), 'done');
    for (const s of statuses) assert.ok(['queued', 'running', 'done'].includes(s), `status ${s}`);
    assert.equal(Number(await panel.locator('progress').getAttribute('value')), job.progress.total);
    // The job list catches up, and the capture's runs are a click away.
    await page.locator(`table.jobs tr[data-capture="${id}"][data-status="done"]`).waitFor({ timeout: kViewMs });
    await go(page, () => page.click('.progress-box a'));
    const runs = (await daemon.get(`/runs?capture=${id}`)).runs;
    assert.equal(runs.length, 1);
    assert.deepEqual(await page.locator('tbody tr[data-run-id]').evaluateAll((rows) => rows.map((r) => Number(r.dataset.runId))), runs.map((r) => r.id));
    assert.deepEqual(errors, []);
    await close();
  });

  test('capture form: a renderer\'s option select makes a variant entry in the spec', async () => {
    const { page, errors, close } = await open('#/capture');
    const table = (await daemon.get('/renderers')).options;
    const barycentrics = table.find((o) => o.name === 'barycentrics');
    const select = page.locator('[data-variant-row="visbuffer"] select[data-option="barycentrics"]').first();
    // The default is preselected.
    assert.equal(JSON.parse(await select.inputValue()), barycentrics.default);
    for (const box of await page.locator('input[name="renderers"]').all()) {
      if ((await box.getAttribute('value')) !== 'visbuffer') await box.uncheck();
    }
    await select.selectOption(JSON.stringify('float32'));
    await page.fill('input[name="resolutions"]', '32x18');
    await page.fill('input[name="frames"]', '2');
    await page.fill('input[name="counted_frames"]', '1');
    await page.selectOption('select[name="counting"]', 'exact');
    await page.click('form.capture-form button[type="submit"]');
    const panel = page.locator('.progress-box [data-status="done"]');
    await panel.waitFor({ timeout: kCaptureMs });
    const job = await daemon.get(`/captures/${Number(await panel.getAttribute('data-capture'))}`);
    assert.deepEqual(job.spec.renderers, [{ renderer: 'visbuffer', options: { barycentrics: 'float32' } }]);
    assert.equal(job.spec.counted_frames, 1);
    assert.equal(job.spec.counting, 'exact');
    const { runs } = await daemon.get(`/runs?capture=${job.id}`);
    assert.deepEqual(runs.map((r) => r.variant), ['visbuffer barycentrics=float32']);
    assert.deepEqual(errors, []);
    await close();
  });

  test('capture form: bad input shows the server\'s error message and field', async () => {
    const { page, errors, close } = await open('#/capture');
    const before = (await daemon.get('/captures?limit=1000')).captures.length;
    const renderers = await page.locator('input[name="renderers"]:checked').evaluateAll((boxes) => boxes.map((b) => b.value));
    const spec = { renderers, scenes: ['atrium'], cameras: 'auto', counting: 'accumulate', lights: 400 };
    const cases = [
      { fill: { resolutions: '64x0', frames: '2' }, spec: { ...spec, resolutions: [[64, 0]], frames: 2 }, input: 'resolutions' },
      { fill: { resolutions: '64x36', frames: '5000' }, spec: { ...spec, resolutions: [[64, 36]], frames: 5000 }, input: 'frames' },
      { fill: { frames: '4', counted_frames: '5' }, spec: { ...spec, resolutions: [[64, 36]], frames: 4, counted_frames: 5 }, input: 'counted_frames' },
    ];
    for (const k of cases) {
      const expected = await daemon.api('/captures', { method: 'POST', body: k.spec });
      assert.equal(expected.status, 400);
      for (const [name, value] of Object.entries(k.fill)) await page.fill(`input[name="${name}"]`, value);
      await page.click('form.capture-form button[type="submit"]');
      const panel = page.locator('.form-error .panel.error');
      await panel.waitFor({ timeout: kViewMs });
      await page.waitForFunction((message) => document.querySelector('.form-error .message')?.textContent === message, expected.body.error.message, { timeout: kViewMs });
      assert.equal(await panel.getAttribute('data-code'), expected.body.error.code);
      assert.equal(await panel.locator('.field-name').textContent(), expected.body.error.field);
      assert.equal(await page.locator(`input[name="${k.input}"]`).getAttribute('aria-invalid'), 'true');
    }
    await screenshot(page, 'capture-error-wide');
    assert.equal((await daemon.get('/captures?limit=1000')).captures.length, before, 'a refused spec stores no job');
    // The only console lines: Chromium's own notes of the two 400 answers to
    // POST /api/captures. The page itself logs nothing.
    assert.deepEqual(errors.map((e) => [new URL(e.url).pathname, /status of 400/.test(e.text)]), cases.map(() => ['/api/captures', true]));
    await close();
  });

  test('sweeps: the list is the API\'s, the sweep view states fails_at and charts the points', async () => {
    const sweep = data.sweep;
    const result = sweep.result;
    const { page, errors, close } = await open('#/sweeps');
    const ids = () => page.locator('table.sweeps tbody tr').evaluateAll((rows) => rows.map((r) => Number(r.dataset.sweepId)));
    assert.deepEqual(await ids(), (await daemon.get('/sweeps')).sweeps.map((s) => s.id));
    assert.equal(await page.locator(`tr[data-sweep-id="${sweep.id}"] [data-fails-at]`).getAttribute('data-fails-at'), sweep.fails_at === null ? 'none' : 'some');
    // The name filter goes to the server.
    await page.fill('input[name="name"]', 'material-edges');
    await go(page, () => page.click('form.filters button[type="submit"]'));
    assert.deepEqual(await ids(), (await daemon.get('/sweeps?name=material-edges')).sweeps.map((s) => s.id));
    assert.match(await page.locator('#view').textContent(), /No sweeps match/);
    await go(page, () => page.goto(`${daemon.url}/#/sweeps?name=depth-reconstruction`));
    assert.deepEqual(await ids(), [sweep.id]);
    await go(page, () => page.click(`tr[data-sweep-id="${sweep.id}"] a`));
    assert.match(await page.locator('h1').textContent(), new RegExp(`Sweep #${sweep.id}: depth-reconstruction`));

    // Threshold tile: the API's.
    assert.equal(Number(await page.locator('[data-tile="threshold-relative"]').getAttribute('data-value')), sweep.threshold.relative);

    // Where it fails: per swept axis and group, recomputed from the points
    // (the smallest value of the axis whose max relative error reaches the
    // threshold, the other parameters held), and equal to the API's fails_at.
    const expected = [];
    for (const [axis, others] of [['distance', ['near', 'far']], ['far_over_near', ['distance', 'far']]]) {
      const groups = new Map();
      for (const p of result.points) {
        const key = JSON.stringify(others.map((o) => p[o]));
        if (!groups.has(key)) groups.set(key, null);
        if (p.error.max_relative >= sweep.threshold.relative && (groups.get(key) === null || p[axis] < groups.get(key))) groups.set(key, p[axis]);
      }
      for (const value of groups.values()) expected.push([axis, value]);
    }
    const api = Object.entries(sweep.fails_at).flatMap(([axis, groups]) => groups.map((g) => [axis, g[axis]]));
    const byKey = (a, b) => JSON.stringify(a).localeCompare(JSON.stringify(b));
    assert.deepEqual([...api].sort(byKey), [...expected].sort(byKey));
    const shown = await page.locator('[data-table="fails-at"] tbody tr').evaluateAll((trs) => trs.map((tr) => [tr.cells[0].textContent, tr.querySelector('[data-value]').dataset.value]));
    assert.deepEqual(shown.map(([axis, v]) => [axis, v === '' ? null : Number(v)]), api);
    assert.ok(expected.some(([, v]) => v === null) && expected.some(([, v]) => v !== null), 'one group holds and one fails');
    const words = await page.locator('[data-table="fails-at"] tbody').textContent();
    assert.match(words, /holds over the range/);
    assert.match(words, /fails at distance 300/);

    // One chart per plot: a line per series combination with the API's points
    // in x order, the threshold dashed across, log axes as flagged.
    assert.equal(await page.locator('[data-chart^="sweep-plot-"]').count(), result.plots.length);
    for (const [k, plot] of result.plots.entries()) {
      const drawn = await page.evaluate((id) => {
        const c = window.Chart.getChart(document.querySelector(`[data-chart="${id}"] canvas`));
        return { x: c.options.scales.x.type, y: c.options.scales.y.type,
          datasets: c.data.datasets.map((d) => ({ data: d.data, threshold: Boolean(d.threshold), dash: d.borderDash || null })) };
      }, `sweep-plot-${k}`);
      assert.equal(drawn.x, plot.x_log ? 'logarithmic' : 'linear');
      assert.equal(drawn.y, plot.y_log ? 'logarithmic' : 'linear');
      const lines = new Map();
      for (const p of result.points) {
        const key = JSON.stringify(plot.series.map((f) => at(p, f)));
        if (!lines.has(key)) lines.set(key, []);
        lines.get(key).push({ x: at(p, plot.x), y: at(p, plot.y) });
      }
      const want = [...lines.values()].map((line) => line.sort((a, b) => a.x - b.x));
      assert.deepEqual(drawn.datasets.filter((d) => !d.threshold).map((d) => d.data), want, plot.title);
      const threshold = drawn.datasets.filter((d) => d.threshold);
      assert.equal(threshold.length, 1);
      const xs = result.points.map((p) => at(p, plot.x));
      assert.deepEqual(threshold[0].data, [{ x: Math.min(...xs), y: plot.threshold }, { x: Math.max(...xs), y: plot.threshold }]);
      assert.ok(threshold[0].dash && threshold[0].dash.length > 0, 'the threshold is dashed');
    }
    // The points table: one row per point, the values the API gives.
    const distances = await page.locator('[data-table="points"] tbody tr').evaluateAll((trs) => trs.map((tr) => JSON.parse(tr.cells[2].querySelector('[data-value]').dataset.value)));
    assert.deepEqual(distances, result.points.map((p) => p.distance));
    assert.deepEqual(errors, []);
    await close();
  });

  test('run view: the counter headroom is the API\'s', async () => {
    const run = await daemon.get(`/runs/${runOf('deferred', 128).id}`);
    const hr = run.counter_headroom;
    assert.ok(hr && hr.max_slot_count_per_frame > 0, 'the run has a headroom');
    const { page, errors, close } = await open(`#/runs/${run.id}`);
    const value = (key) => page.locator(`[data-headroom="${key}"]`).getAttribute('data-value');
    assert.equal(Number(await value('max-slot-count')), hr.max_slot_count_per_frame);
    assert.equal(await value('max-slot'), hr.max_slot);
    assert.equal(Number(await value('wrap-32')), hr.wrap_factor_32bit);
    assert.equal(Number(await value('wrap')), hr.wrap_factor);
    // The factors are 2^bits over the largest slot's count per readback.
    assert.ok(Math.abs(hr.wrap_factor_32bit - 2 ** 32 / (hr.max_slot_count_per_frame * hr.frames_accumulated)) <= 1e-9 * hr.wrap_factor_32bit);
    assert.equal(await page.locator('[data-headroom="max-slot-count"] .value').textContent(), hr.max_slot_count_per_frame.toLocaleString('en-US'));
    assert.match(await page.locator('[data-headroom="sentence"]').textContent(), /^32-bit counters would wrap at [0-9.,]+( (million|billion|trillion))?× this resolution × overshading/);
    // No e-notation: a large factor in words.
    assert.doesNotMatch(await page.locator('[data-headroom="sentence"]').textContent(), /\de\d/);
    assert.deepEqual(errors, []);
    await close();
  });

  test('run view: each sample\'s "Download trace" link fetches its trace, Chrome trace-event JSON', async () => {
    const id = runOf('deferred', 64).id;
    const { samples } = await daemon.get(`/runs/${id}/samples`);
    const { page, errors, close } = await open(`#/runs/${id}`);
    const links = page.locator('[data-table="samples"] a[data-trace]');
    assert.equal(await links.count(), samples.length);
    const first = links.first();
    assert.equal(await first.textContent(), 'Download trace');
    assert.equal(Number(await first.getAttribute('data-trace')), samples[0].id);
    assert.ok(await first.getAttribute('download'), 'the link downloads a file');
    // What the link fetches: the sample's trace, JSON with traceEvents.
    const href = await first.getAttribute('href');
    const trace = await page.evaluate(async (url) => (await fetch(url)).json(), href);
    assert.ok(Array.isArray(trace.traceEvents) && trace.traceEvents.length > 0, 'traceEvents');
    assert.equal(trace.displayTimeUnit, 'ms');
    assert.equal(trace.metadata.sample, samples[0].id);
    assert.equal(trace.metadata.frame_times, 'measured');
    const frames = trace.traceEvents.filter((e) => e.ph === 'X' && e.cat === 'frame');
    assert.equal(frames.length, samples[0].frames);
    for (const e of trace.traceEvents) {
      assert.equal(typeof e.name, 'string');
      assert.ok(['X', 'C', 'M'].includes(e.ph), e.ph);
      assert.ok(Number.isInteger(e.pid) && Number.isInteger(e.tid));
      if (e.ph === 'X') assert.ok(e.dur >= 0);
    }
    // The download itself: a click saves the file the link names.
    const [download] = await Promise.all([page.waitForEvent('download'), first.click()]);
    assert.equal(download.suggestedFilename(), `tally-sample-${samples[0].id}.trace.json`);
    assert.deepEqual(errors, []);
    await close();
  });

  test('roofline: one point per pass against the run\'s ceilings; compare shows each pass\'s share of the bandwidth ceiling', async () => {
    const run = await daemon.get(`/runs/${runOf('deferred', 128).id}`);
    const ceilings = run.ceilings;
    assert.ok(ceilings && ceilings.bandwidth_bytes_per_s > 0 && ceilings.arithmetic_ops_per_s > 0, 'the capture measured ceilings');
    const { samples } = await daemon.get(`/runs/${run.id}/samples`);
    const names = run.passes.map((p) => p.name);
    for (const s of samples) assert.deepEqual(Object.keys(s.extras.roofline.passes).sort(), [...names].sort());
    const { page, errors, close } = await open(`#/runs/${run.id}`);
    const c = await chart(page, 'roofline');
    assert.ok(c, 'the roofline chart is drawn');
    const requested = c.datasets.find((d) => d.label === 'requested bytes');
    assert.equal(requested.data.length, names.length, 'one point per pass');
    assert.deepEqual(requested.data.map((p) => p.pass).sort(), [...names].sort());
    for (const name of names) {
      const list = samples.map((s) => s.extras.roofline.passes[name]);
      const ops = mean(list.map((r) => r.arithmetic_ops));
      const bytes = mean(list.map((r) => r.bytes_requested));
      const seconds = mean(list.map((r) => r.gpu_ms)) / 1e3;
      assert.ok(ops > 0 && bytes > 0 && seconds > 0, `${name}: arithmetic, bytes and time`);
      const point = requested.data.find((p) => p.pass === name);
      assertClose(point.x, ops / bytes, `${name} intensity`);
      assertClose(point.y, ops / seconds, `${name} ops/s`);
    }
    // No footprint is measured by these captures: no footprint series.
    assert.equal(c.datasets.find((d) => d.label === 'footprint bytes'), undefined);
    // The bandwidth ceiling is the line y = bandwidth x up to the ridge, the arithmetic one flat from there.
    const slope = c.datasets.find((d) => d.label === 'bandwidth ceiling').data;
    assertClose(slope[0].y / slope[0].x, ceilings.bandwidth_bytes_per_s, 'bandwidth ceiling slope');
    assertClose(slope[1].y, ceilings.arithmetic_ops_per_s, 'bandwidth ceiling meets the arithmetic one');
    const flat = c.datasets.find((d) => d.label === 'arithmetic ceiling').data;
    assert.deepEqual(flat.map((p) => p.y), [ceilings.arithmetic_ops_per_s, ceilings.arithmetic_ops_per_s]);
    assertClose(flat[0].x, ceilings.arithmetic_ops_per_s / ceilings.bandwidth_bytes_per_s, 'ridge');
    // Both axes are logarithmic, and a point's tooltip names its pass.
    const view = await page.evaluate(() => {
      const ch = window.Chart.getChart(document.querySelector('[data-chart="roofline"] canvas'));
      const d = ch.data.datasets[0];
      return { x: ch.options.scales.x.type, y: ch.options.scales.y.type, tooltip: ch.options.plugins.tooltip.callbacks.label({ dataset: d, raw: d.data[0] }), pass: d.data[0].pass };
    });
    assert.equal(view.x, 'logarithmic');
    assert.equal(view.y, 'logarithmic');
    assert.ok(view.tooltip.startsWith(`${view.pass} (requested bytes)`), view.tooltip);
    assert.deepEqual(errors, []);
    await screenshot(page, 'run-roofline-wide');
    await close();

    // Compare: per pass and run, bytes / (gpu_ms / 1000) / that run's bandwidth ceiling.
    const ids = [run.id, runOf('visbuffer', 128).id];
    const compared = await daemon.get(`/compare?runs=${ids.join(',')}`);
    const ceilingOf = await Promise.all(ids.map(async (id) => (await daemon.get(`/runs/${id}`)).ceilings.bandwidth_bytes_per_s));
    const cmp = await open(`#/compare?runs=${ids.join(',')}`);
    const cells = await cmp.page.locator('[data-table="bandwidth-fraction"] td').evaluateAll((tds) => tds.map((td) => ({ run: Number(td.dataset.run), fraction: td.dataset.fraction, text: td.textContent })));
    assert.equal(cells.length, compared.passes.length * ids.length);
    let k = 0;
    for (const p of compared.passes) {
      ids.forEach((id, i) => {
        const cell = cells[k++];
        assert.equal(cell.run, id);
        const bytes = p.bytes[i].value, ms = p.gpu_ms[i].value;
        if (bytes === null || !ms) {
          assert.equal(cell.fraction, '', `${p.pass} of run ${id} has no fraction`);
          return;
        }
        const expected = bytes / (ms / 1e3) / ceilingOf[i];
        assertClose(Number(cell.fraction), expected, `${p.pass} of run ${id}`);
        assert.ok(expected > 0);
        assert.match(cell.text, / %$/);
      });
    }
    const bars = await chart(cmp.page, 'compare-pass-bandwidth-fraction');
    assert.equal(bars.datasets.length, ids.length);
    assert.deepEqual(bars.labels, compared.passes.map((p) => p.pass));
    assert.deepEqual(cmp.errors, []);
    await screenshot(cmp.page, 'compare-bandwidth-fraction-wide');
    await cmp.close();
  });

  test('capture form: a sweep spec starts a sweep; a bad one shows the server\'s field', async () => {
    const { page, errors, close } = await open('#/capture');
    await page.click('details.sweep-box summary');
    const bad = { ...kSweepSpec, colour: 'red' };
    const expected = await daemon.api('/captures', { method: 'POST', body: bad });
    assert.equal(expected.status, 400);
    await page.fill('textarea[name="sweep_spec"]', JSON.stringify(bad));
    await page.click('form.sweep-form button[type="submit"]');
    const panel = page.locator('form.sweep-form .form-error .panel.error');
    await panel.waitFor({ timeout: kViewMs });
    assert.equal(await panel.locator('.message').textContent(), expected.body.error.message);
    assert.equal(await panel.locator('.field-name').textContent(), 'colour');
    assert.equal(await page.locator('textarea[name="sweep_spec"]').getAttribute('aria-invalid'), 'true');

    await page.fill('textarea[name="sweep_spec"]', JSON.stringify(kSweepSpec));
    await page.click('form.sweep-form button[type="submit"]');
    const done = page.locator('.progress-box [data-status="done"]');
    await done.waitFor({ timeout: kCaptureMs });
    const job = await daemon.get(`/captures/${await done.getAttribute('data-capture')}`);
    assert.deepEqual(job.spec, kSweepSpec);
    assert.equal(job.sweeps.length, 1);
    await go(page, () => page.click('.progress-box a'));
    assert.match(await page.locator('h1').textContent(), new RegExp(`Sweep #${job.sweeps[0]}:`));
    // The one console line: Chromium's note of the 400 answer to the bad spec.
    assert.deepEqual(errors.map((e) => [new URL(e.url).pathname, /status of 400/.test(e.text)]), [['/api/captures', true]]);
    await close();
  });

  test('run view and API: the notes of a user\'s glTF scene (what its loader ignored) reach the run', async () => {
    // One quad whose file uses an extension Tally does not draw: the loader's note must be in the run.
    const positions = new Float32Array([0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]);
    const indices = new Uint16Array([0, 1, 2, 0, 2, 3, 0]);  // padded to 4 bytes
    const bin = Buffer.concat([Buffer.from(positions.buffer), Buffer.from(indices.buffer)]);
    const gltf = {
      asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }],
      meshes: [{ primitives: [{ attributes: { POSITION: 0 }, indices: 1 }] }],
      extensionsUsed: ['KHR_materials_clearcoat'],
      buffers: [{ byteLength: bin.length, uri: `data:application/octet-stream;base64,${bin.toString('base64')}` }],
      bufferViews: [{ buffer: 0, byteOffset: 0, byteLength: 48 }, { buffer: 0, byteOffset: 48, byteLength: 12 }],
      accessors: [{ bufferView: 0, componentType: 5126, count: 4, type: 'VEC3', min: [0, 0, 0], max: [1, 1, 0] },
        { bufferView: 1, componentType: 5123, count: 6, type: 'SCALAR' }],
    };
    writeFileSync(join(daemon.scenes, 'clearcoat-quad.gltf'), JSON.stringify(gltf));
    const job = await daemon.capture({ renderers: ['forward'], scenes: [{ gltf: 'clearcoat-quad.gltf' }], resolutions: [[64, 36]], frames: 1,
      cameras: [{ eye: [0.5, 0.5, 2], target: [0.5, 0.5, 0] }] }, kCaptureMs);
    const { runs } = await daemon.get(`/runs?capture=${job.id}`);
    assert.equal(runs.length, 1);
    const run = await daemon.get(`/runs/${runs[0].id}`);
    const note = 'KHR_materials_clearcoat: used but not implemented; clearcoat is not drawn';
    assert.deepEqual(run.notes.scene, [note], 'the API carries the scene\'s notes');
    const { page, errors, close } = await open(`#/runs/${run.id}`);
    assert.deepEqual(await page.locator('[data-scene-notes] li').allTextContents(), [note]);
    await screenshot(page, 'run-notes');
    assert.deepEqual(errors, []);
    await close();
  });
  test('footprint: the run and compare views switch their byte charts between requested and footprint; accuracy draws it apart', async () => {
    // A run counted with footprint on (64-byte blocks), captured like any other ...
    const job = await daemon.capture({ renderers: ['deferred'], resolutions: [[64, 36]], frames: 2, footprint: 64 }, kCaptureMs);
    const { runs } = await daemon.get(`/runs?capture=${job.id}`);
    assert.equal(runs.length, 1);
    const id = runs[0].id;
    assert.equal(runs[0].footprint_block_bytes, 64, 'the spec\'s block size reaches the stored run');
    // ... whose lines' footprints are stored as the counting measures them:
    // each counted line touches a half, a third or a quarter of the bytes it
    // requests (reuse 2, 3, 4), derived lines have none; the samples' sums
    // as ingest keeps them.
    execFileSync('python3', ['-c', `
import sqlite3, sys
db = sqlite3.connect(sys.argv[1], timeout=30)
run = int(sys.argv[2])
with db:
    db.execute("UPDATE counters SET footprint_bytes = bytes / (2 + position % 3) WHERE source = 'counter' AND pass_id IN "
               "(SELECT p.id FROM passes p JOIN samples s ON s.id = p.sample_id WHERE s.run_id = ?)", (run,))
    db.execute("UPDATE samples SET footprint_bytes = (SELECT SUM(c.footprint_bytes) FROM counters c JOIN passes p "
               "ON p.id = c.pass_id WHERE p.sample_id = samples.id), footprint_requested_bytes = (SELECT SUM(c.bytes) "
               "FROM counters c JOIN passes p ON p.id = c.pass_id WHERE p.sample_id = samples.id AND "
               "c.footprint_bytes IS NOT NULL) WHERE run_id = ?", (run,))
    # and the run's means over its samples, as ingest keeps them on the run (migration 0013)
    db.execute("UPDATE runs SET (mean_footprint_bytes, mean_footprint_requested_bytes) = (SELECT AVG(s.footprint_bytes), "
               "AVG(s.footprint_requested_bytes) FROM samples s WHERE s.run_id = runs.id) WHERE id = ?", (run,))
`, join(daemon.dir, 'tally.db'), String(id)]);
    const run = await daemon.get(`/runs/${id}`);
    const { samples } = await daemon.get(`/runs/${id}/samples`);
    const details = await Promise.all(samples.map((s) => daemon.get(`/samples/${s.id}`)));
    const lines = run.passes.flatMap((p) => p.resources);
    assert.ok(lines.some((l) => l.footprint_bytes !== null && l.footprint_bytes < l.bytes), 'counted lines have a footprint below their bytes');
    for (const l of lines.filter((x) => x.footprint_bytes > 0)) assertClose(l.reuse, l.bytes / l.footprint_bytes, `${l.name} reuse`);
    assert.ok(run.mean_footprint_bytes > 0 && run.mean_footprint_bytes < run.mean_bytes);

    // Per pass and resource: the sum of the lines' footprints (null where none has one).
    const expected = (access, key) => (name) => run.passes.map((p) => {
      const mine = p.resources.filter((r) => r.name === name && r.access === access && r[key] !== null);
      return mine.length ? mine.reduce((a, r) => a + r[key], 0) : null;
    });
    const checkPassCharts = async (page, key) => {
      for (const access of ['read', 'write']) {
        const c = await chart(page, `pass-resource-${access}`);
        for (const d of c.datasets) {
          expected(access, key)(d.label).forEach((v, i) => {
            if (v === null) assert.equal(d.data[i], null, `${key} ${access} ${d.label} pass ${i}`);
            else assertClose(d.data[i], v, `${key} ${access} ${d.label} pass ${i}`);
          });
        }
      }
    };
    const { page, errors, close } = await open(`#/runs/${id}`);
    assert.equal(await page.locator('[data-footprint-block]').textContent(), 'footprint in 64-byte blocks');
    await checkPassCharts(page, 'bytes');
    const footprintRadio = page.locator('[data-measure-switch="run-measure"] input[value="footprint"]');
    assert.equal(await footprintRadio.isDisabled(), false);
    await footprintRadio.check();
    await checkPassCharts(page, 'footprint_bytes');
    const readChart = await chart(page, 'pass-resource-read');
    assert.ok(readChart.datasets.some((d) => d.data.some((v) => v > 0)), 'the footprint chart has values');
    assert.match(readChart.datasets.length ? (await page.locator('[data-chart="pass-resource-read"] figcaption strong').textContent()) : '', /^Footprint read per frame/);
    // Per camera: each sample's footprint read and written, from its lines.
    const perSample = await chart(page, 'per-sample');
    const byAccess = (d, access) => {
      const mine = d.passes.flatMap((p) => p.resources).filter((r) => r.access === access && r.footprint_bytes !== null);
      return mine.length ? mine.reduce((a, r) => a + r.footprint_bytes, 0) : null;
    };
    const same = (actual, wanted, what) => (wanted === null ? assert.equal(actual, null, what) : assertClose(actual, wanted, what));
    details.forEach((d, i) => {
      same(perSample.datasets[0].data[i], byAccess(d, 'read'), `sample ${i} footprint read`);
      same(perSample.datasets[1].data[i], byAccess(d, 'write'), `sample ${i} footprint written`);
      assertClose((byAccess(d, 'read') ?? 0) + (byAccess(d, 'write') ?? 0), samples[i].footprint_bytes, `sample ${i} footprint total`);
    });
    assert.ok(byAccess(details[0], 'read') > 0);
    // The data table beside the chart follows the switch.
    const tableValues = await page.locator('[data-chart-table="per-sample"] tbody tr').evaluateAll((rows) => rows.map((r) => [...r.querySelectorAll('td')].map((td) => Number(td.dataset.value))));
    details.forEach((d, i) => assertClose(tableValues[i][0], byAccess(d, 'read'), `table sample ${i}`));
    assertClose(samples.reduce((a, x) => a + x.footprint_bytes, 0) / samples.length, run.mean_footprint_bytes, 'the run\'s mean footprint');
    // Tables show both: per pass requested bytes, footprint and reuse; per sample the same.
    const passFootprints = await page.locator('[data-table="passes"] tbody tr').evaluateAll((rows) => rows.map((r) => r.querySelectorAll('td')[7].querySelector('span').dataset.value));
    assert.deepEqual(passFootprints, run.passes.map((p) => (p.footprint_bytes === null ? '' : String(p.footprint_bytes))));
    const lineReuse = await page.locator('[data-table="lines"] tbody tr').evaluateAll((rows) => rows.map((r) => r.querySelectorAll('td')[6].querySelector('span').dataset.value));
    assert.deepEqual(lineReuse, lines.map((l) => (l.reuse === null ? '' : String(l.reuse))));
    assert.equal(await page.locator('[data-tile="reuse"] .value').textContent(), `×${run.mean_reuse.toFixed(2)}`);
    await screenshot(page, 'run-footprint');
    // And back: requested bytes again.
    await page.locator('[data-measure-switch="run-measure"] input[value="requested"]').check();
    await checkPassCharts(page, 'bytes');
    assert.deepEqual((await chart(page, 'per-sample')).datasets[0].data, samples.map((s) => s.bytes_read));
    assert.deepEqual(errors, []);
    await close();

    // A run without footprint: the switch offers none, and says why.
    const plain = runOf('deferred', 64);
    const other = await open(`#/runs/${plain.id}`);
    const disabled = other.page.locator('[data-measure-switch="run-measure"] input[value="footprint"]');
    assert.equal(await disabled.isDisabled(), true);
    assert.match(await other.page.locator('[data-measure-switch="run-measure"] label[data-measure="footprint"]').getAttribute('title'), /no footprint/);
    assert.deepEqual(other.errors, []);
    await other.close();

    // Compare: the footprint run against the exact one without footprint.
    const c = await daemon.get(`/compare?runs=${id},${plain.id}`);
    assert.ok(c.total_footprint_bytes[0].value > 0);
    assert.equal(c.total_footprint_bytes[1].value, null);
    const cmp = await open(`#/compare?runs=${id},${plain.id}`);
    // Every resource ("show all"), in the order drawn: the largest first.
    const resourceData = async (key) => {
      if (await cmp.page.locator('[data-show-all-resources="true"]').count()) await cmp.page.click('[data-show-all-resources="true"]');
      const drawn = await chart(cmp.page, 'compare-resources');
      const rows = drawn.labels.map((label) => c.resources.find((r) => `${r.resource} (${r.access})` === label));
      assert.equal(rows.length, c.resources.length);
      return { drawn: drawn.datasets.map((d) => d.data), expected: [0, 1].map((i) => rows.map((r) => r[key][i].value)) };
    };
    const requested = await resourceData('bytes');
    assert.deepEqual(requested.drawn, requested.expected);
    await cmp.page.locator('[data-measure-switch="compare-measure"] input[value="footprint"]').check();
    const footprint = await resourceData('footprint_bytes');
    assert.deepEqual(footprint.drawn, footprint.expected);
    const passBytes = await chart(cmp.page, 'compare-pass-bytes');
    assert.deepEqual(passBytes.datasets[0].data, c.passes.map((p) => p.footprint_bytes[0].value));
    const totals = await chart(cmp.page, 'compare-bytes');
    const sumOf = (access) => c.resources.filter((r) => r.access === access && r.footprint_bytes[0].value !== null).reduce((a, r) => a + r.footprint_bytes[0].value, 0);
    assertClose(totals.datasets[0].data[0], sumOf('read'), 'footprint read of the first run');
    assertClose(totals.datasets[1].data[0], sumOf('write'), 'footprint written of the first run');
    assert.deepEqual([totals.datasets[0].data[1], totals.datasets[1].data[1]], [null, null], 'no footprint for the second run');
    // The totals table shows both, with the API's reuse.
    assert.equal(Number(await cmp.page.locator('[data-table="totals"] tr[data-row="total_footprint_bytes"] td').first().getAttribute('data-value')), c.total_footprint_bytes[0].value);
    assert.equal(Number(await cmp.page.locator('[data-table="totals"] tr[data-row="reuse"] td').first().getAttribute('data-value')), c.reuse[0].value);
    // Scaling: the footprint run is a series of its own, apart from the accumulate runs without.
    const scalingSeries = await chart(cmp.page, 'scaling-bytes');
    assert.deepEqual(scalingSeries.datasets.find((d) => d.label === 'deferred (accumulate + footprint 64)')?.data.map((p) => p.run), [id]);
    await screenshot(cmp.page, 'compare-footprint');
    assert.deepEqual(cmp.errors, []);
    await cmp.close();

    // Speed against accuracy: the run is a point of its own, "accumulate + footprint 64".
    const acc = await open('#/accuracy?error=counting&cost=overhead');
    const points = await chart(acc.page, 'accuracy');
    const series = points.datasets.find((d) => d.label === 'accumulate + footprint 64');
    assert.ok(series, `a series of its own among ${points.datasets.map((d) => d.label)}`);
    assert.deepEqual(series.data.map((p) => p.run), [id]);
    assert.ok(!points.datasets.find((d) => d.label === 'accumulate').data.some((p) => p.run === id));
    assert.deepEqual(acc.errors, []);
    await acc.close();
  });

  test('capture form: the footprint select puts the block size in the spec, off by default', async () => {
    const { page, close } = await open('#/capture');
    assert.equal(await page.locator('select[name="footprint"]').inputValue(), 'off');
    assert.deepEqual(await page.locator('select[name="footprint"] option').evaluateAll((os) => os.map((o) => o.value)), ['off', '32', '64', '128']);
    const posted = [];
    await page.route('**/api/captures', async (route) => {
      if (route.request().method() !== 'POST') return route.continue();
      posted.push(route.request().postDataJSON());
      // Refused, so that nothing runs: the spec is what this test reads.
      return route.fulfill({ status: 400, contentType: 'application/json', body: JSON.stringify({ error: { code: 'invalid_field', message: 'footprint: refused by the test', field: 'footprint' } }) });
    });
    await page.click('form.capture-form button[type="submit"]');
    await page.locator('.form-error .panel.error').waitFor({ timeout: kViewMs });
    await page.selectOption('select[name="footprint"]', '32');
    await page.click('form.capture-form button[type="submit"]');
    for (let i = 0; i < 200 && posted.length < 2; ++i) await new Promise((resolve) => setTimeout(resolve, 50));
    assert.equal(posted.length, 2);
    assert.ok(!('footprint' in posted[0]), 'off leaves the key out');
    assert.equal(posted[1].footprint, 32);
    // The server's error lands beside the select.
    await page.locator('[data-field="footprint"] .field-error').waitFor({ timeout: kViewMs });
    assert.equal(await page.locator('[data-field="footprint"] .field-error').textContent(), 'footprint: refused by the test');
    await close();
  });
});

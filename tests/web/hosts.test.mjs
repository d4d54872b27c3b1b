// Browser tests of the dashboard's fleet views against a real `tallyd serve`,
// with the fleet's fields served by Playwright routes in place of the server:
// GET /api/hosts is a canned list (two hosts alive, one stale), and the runs
// and captures of the real daemon gain the fields a fleet's server gives them
// (a run's `host`; a job's `host`, `max_attempts`, `attempt_errors` and
// `waiting`). The hosts view must list the hosts with the stale one marked,
// fetch the list again while shown and stop when left; the runs browser must
// show each run's host and filter by one through ?host= (and, from a daemon
// without /api/hosts, offer the hosts its runs name); the captures list
// and the progress panel must show a job's host, attempts, earlier attempts'
// errors and why a queued job waits. No view may scroll sideways at 360 px,
// or log a console error.
//
// Environment (tests/web/run.sh sets it): TALLYD, TALLY_WEB_ROOT,
// TALLY_SCREENSHOTS, CHROMIUM.
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { join } from 'node:path';
import { setTimeout as sleep } from 'node:timers/promises';
import { after, before, describe, test } from 'node:test';

import { chromium } from 'playwright-core';

import { Daemon } from './daemon.mjs';

const env = process.env;
const kViewMs = 30_000;
const kCaptureMs = 180_000;
const kViewports = { narrow: { width: 360, height: 800 }, wide: { width: 1280, height: 800 } };
const kRefreshMs = 5000;  // web/views/hosts.js

// GET /api/hosts as the contract has it: gpu-a and gpu-b alive (gpu-b
// reporting an overridden device name), gpu-c stale and never probed.
function hostList({ staleHost = 'gpu-c' } = {}) {
  const host = (name, fields) => ({
    name, role: 'worker', device: null, device_override: null, tally_version: '0.1.0', tally_commit: 'abc1234',
    started_at: '2026-11-21T06:00:00Z', last_heartbeat: '2026-11-21T06:30:00Z', seconds_since_heartbeat: 2.5,
    alive: name !== staleHost, jobs_done: 0, jobs_failed: 0, current_job: null, ...fields,
  });
  return {
    hosts: [
      host('gpu-a', { device: { name: 'NVIDIA H100 80GB HBM3', vendor: 'NVIDIA', driver: '550.54.15', api_version: '1.3.280' }, seconds_since_heartbeat: staleHost === 'gpu-a' ? 45 : 3.2, jobs_done: 4, jobs_failed: 1, current_job: 12 }),
      host('gpu-b', { role: 'all', device: { name: 'NVIDIA H200', vendor: 'NVIDIA', driver: '560.35.03', api_version: '1.3.289' }, device_override: 'FakeGPU-A', seconds_since_heartbeat: 0.4 }),
      host('gpu-c', { tally_commit: 'def5678', seconds_since_heartbeat: staleHost === 'gpu-c' ? 125 : 1, jobs_done: 7, jobs_failed: 2 }),
    ],
    stale_after_s: 30,
  };
}

const kWaiting = 'no live worker has a device matching {"name":"AMD"}';
const kLost = 'attempt 1 on gpu-b: lease expired (no heartbeat for 31 s)';

let daemon;
let browser;
const data = {};

// A fresh page at `hash` whose /api/hosts answers `hosts(n)` for its n-th
// request (counted in `calls`; a number: that status, as a server without the
// route answers), recording console errors.
async function open(hash, viewport, { hosts = () => hostList(), setup } = {}) {
  const context = await browser.newContext({ viewport });
  const calls = { hosts: 0 };
  await context.route((url) => url.pathname === '/api/hosts', (route) => {
    const reply = hosts(++calls.hosts);
    return typeof reply === 'number'
      ? route.fulfill({ status: reply, json: { error: { code: 'not_found', message: 'no route /api/hosts' } } })
      : route.fulfill({ json: reply });
  });
  if (setup) await setup(context);
  const page = await context.newPage();
  const errors = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(`uncaught: ${e.message}`));
  const requests = [];
  page.on('request', (r) => requests.push(new URL(r.url())));
  await page.goto(`${daemon.url}/${hash}`);
  await ready(page);
  return { page, errors, calls, requests, close: () => context.close() };
}

async function ready(page) {
  await page.waitForFunction(() => {
    const view = document.getElementById('view');
    return view && !view.hasAttribute('aria-busy') && view.querySelector('.page');
  }, null, { timeout: kViewMs });
  assert.deepEqual(await page.locator('#view .panel.error').allTextContents(), [], 'the view shows an error');
}

async function go(page, action) {
  const before = Number(await page.locator('#view').getAttribute('data-rendered'));
  await action();
  await page.waitForFunction((n) => Number(document.getElementById('view').dataset.rendered) > n, before, { timeout: kViewMs });
  await ready(page);
}

const overflow = (page) => page.evaluate(() => document.documentElement.scrollWidth - document.documentElement.clientWidth);

// The cells of a table's body, row by row, as text.
const cells = (page, selector) => page.locator(`${selector} tbody tr`).evaluateAll((rows) =>
  rows.map((r) => [...r.querySelectorAll('td')].map((td) => td.textContent.trim())));

before(async () => {
  for (const key of ['TALLYD', 'TALLY_WEB_ROOT', 'TALLY_SCREENSHOTS', 'CHROMIUM']) assert.ok(env[key], `${key} is not set`);
  mkdirSync(env.TALLY_SCREENSHOTS, { recursive: true });
  daemon = await new Daemon(env.TALLYD, env.TALLY_WEB_ROOT).start();
  // Three real runs; the routes below say which host made each.
  const job = await daemon.capture({ renderers: ['forward', 'deferred', 'visbuffer'], scenes: ['atrium'], resolutions: [[32, 18]], frames: 1, counting: 'exact' }, kCaptureMs);
  data.runs = (await daemon.get(`/runs?capture=${job.id}`)).runs;
  assert.equal(data.runs.length, 3);
  // gpu-a, a host since removed from the registry, and a run stored before hosts.
  data.hostOf = new Map(data.runs.map((r, i) => [r.id, ['gpu-a', 'gpu-old', null][i]]));
  browser = await chromium.launch({ executablePath: env.CHROMIUM });
});

after(async () => {
  await browser?.close();
  await daemon?.stop();
});

// /api/runs and /api/runs/{id} as a fleet's server answers: the daemon's runs,
// each with its host, filtered by ?host= (which this daemon does not know, so
// it is taken off before the request goes on).
async function runsWithHosts(context) {
  await context.route((url) => url.pathname === '/api/runs' || /^\/api\/runs\/\d+$/.test(url.pathname), async (route) => {
    const url = new URL(route.request().url());
    const host = url.searchParams.get('host');
    url.searchParams.delete('host');
    const response = await route.fetch({ url: url.toString() });
    const body = await response.json();
    if (body.runs) {
      body.runs = body.runs.map((r) => ({ ...r, host: data.hostOf.get(r.id) ?? null })).filter((r) => !host || r.host === host);
    } else {
      body.host = data.hostOf.get(body.id) ?? null;
    }
    return route.fulfill({ status: response.status(), json: body });
  });
}

describe('a fleet of hosts', () => {
  test('hosts view: the hosts, the stale one marked, refreshed while shown, no sideways scroll', async () => {
    for (const [size, viewport] of Object.entries(kViewports)) {
      // From the third request on, gpu-a has gone stale and gpu-c is back.
      const { page, errors, calls, close } = await open('#/hosts', viewport, { hosts: (n) => hostList({ staleHost: n >= 3 ? 'gpu-a' : 'gpu-c' }) });
      assert.equal(await page.locator('#view h1').textContent(), 'Hosts');
      assert.equal(await page.locator('nav a[aria-current]').getAttribute('data-section'), 'hosts');
      assert.deepEqual(await page.locator('table.hosts th').allTextContents(),
        ['Host', 'Role', 'Device', 'Driver', 'Tally', 'Started (UTC)', 'Last heartbeat', 'State', 'Done', 'Failed', 'Current job']);
      assert.deepEqual(await cells(page, 'table.hosts'), [
        ['gpu-a', 'worker', 'NVIDIA H100 80GB HBM3', '550.54.15', '0.1.0 (abc1234)', '2026-11-21 06:00', '3 s ago', 'alive', '4', '1', '#12'],
        ['gpu-b', 'all', 'FakeGPU-A (override)', '560.35.03', '0.1.0 (abc1234)', '2026-11-21 06:00', '0 s ago', 'alive', '0', '0', '–'],
        ['gpu-c', 'worker', 'not probed yet', '–', '0.1.0 (def5678)', '2026-11-21 06:00', '2 min ago', 'stale', '7', '2', '–'],
      ]);
      // Marked: the stale row, its badge; the override says what it overrides.
      assert.deepEqual(await page.locator('table.hosts tbody tr').evaluateAll((rows) => rows.map((r) => [r.dataset.host, r.dataset.alive, r.classList.contains('stale')])),
        [['gpu-a', 'true', false], ['gpu-b', 'true', false], ['gpu-c', 'false', true]]);
      const badge = page.locator('tr[data-host="gpu-c"] .badge.stale');
      assert.equal(await badge.getAttribute('title'), 'no heartbeat in the last 30 s');
      assert.notEqual(await badge.evaluate((b) => getComputedStyle(b).color), await page.locator('tr[data-host="gpu-a"] .badge.alive').evaluate((b) => getComputedStyle(b).color));
      assert.equal(await page.locator('tr[data-host="gpu-b"] [data-override]').getAttribute('title'), 'override; the device: NVIDIA H200 (NVIDIA), Vulkan 1.3.289');
      assert.match(await page.locator('#view [role="status"]').textContent(), /^3 hosts: 2 alive, 1 stale \(no heartbeat in the last 30 s\)/);
      // Each host links to its runs.
      assert.equal(await page.locator('tr[data-host="gpu-a"] a').getAttribute('href'), '#/runs?host=gpu-a');
      const wider = await overflow(page);
      assert.ok(wider <= 0, `hosts ${size}: the page is ${wider}px wider than the window`);
      await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, `hosts-${size}.png`), fullPage: true });

      // Refreshed: the third list shows without a reload.
      await page.locator('tr[data-host="gpu-a"][data-alive="false"]').waitFor({ timeout: 12 * kRefreshMs });
      assert.ok(calls.hosts >= 3);
      assert.equal(await page.locator('tr[data-host="gpu-c"]').getAttribute('data-alive'), 'true');
      assert.equal(await page.locator('tr[data-host="gpu-c"] td').nth(6).textContent(), '1 s ago');
      assert.equal(await page.locator('tr.stale').count(), 1);

      // Left: no more requests for it.
      await go(page, () => page.click('nav a[data-section="capture"]'));
      const seen = calls.hosts;
      await sleep(kRefreshMs + 1000);
      assert.equal(calls.hosts, seen, 'the hosts view polls on after it was left');
      assert.deepEqual(errors, []);
      await close();
    }
  });

  test('hosts view: an empty fleet says so', async () => {
    const { page, errors, close } = await open('#/hosts', kViewports.narrow, { hosts: () => ({ hosts: [], stale_after_s: 30 }) });
    assert.match(await page.locator('#view .panel').textContent(), /No host has registered/);
    assert.match(await page.locator('#view [role="status"]').textContent(), /^0 hosts: 0 alive, 0 stale/);
    assert.deepEqual(errors, []);
    await close();
  });

  test('runs view: a host column, and a host filter sent as ?host=', async () => {
    const { page, errors, requests, close } = await open('#/runs', kViewports.narrow, { setup: runsWithHosts });
    const column = await page.locator('table.runs thead th').allTextContents();
    const at = column.indexOf('Host');
    assert.ok(at > 0, `a Host column: ${column}`);
    const hostsShown = () => page.locator('table.runs tbody tr').evaluateAll((rows, i) => rows.map((r) => [Number(r.dataset.runId), r.querySelectorAll('td')[i].textContent]), at);
    assert.deepEqual(await hostsShown(), data.runs.map((r) => [r.id, data.hostOf.get(r.id) ?? '–']));
    // The select: the registered hosts (the stale one says so) and the one only a run names.
    assert.deepEqual(await page.locator('select[name="host"] option').evaluateAll((o) => o.map((x) => [x.value, x.textContent])),
      [['', 'any'], ['gpu-a', 'gpu-a'], ['gpu-b', 'gpu-b'], ['gpu-c', 'gpu-c (stale)'], ['gpu-old', 'gpu-old']]);
    const wider = await overflow(page);
    assert.ok(wider <= 0, `runs narrow: the page is ${wider}px wider than the window`);

    await go(page, () => page.selectOption('select[name="host"]', 'gpu-a'));
    assert.match(await page.evaluate(() => location.hash), /[?&]host=gpu-a(&|$)/);
    assert.equal(requests.filter((u) => u.pathname === '/api/runs').at(-1).searchParams.get('host'), 'gpu-a');
    const gpuA = data.runs.find((r) => data.hostOf.get(r.id) === 'gpu-a');
    assert.deepEqual(await hostsShown(), [[gpuA.id, 'gpu-a']]);
    assert.equal(await page.locator('select[name="host"]').inputValue(), 'gpu-a');

    // The run names its host, which links back to the filter.
    await go(page, () => page.click(`tr[data-run-id="${gpuA.id}"] a`));
    assert.equal(await page.locator('.meta [data-host="gpu-a"] a').getAttribute('href'), '#/runs?host=gpu-a');
    assert.deepEqual(errors, []);
    await close();
  });

  test('runs view: without /api/hosts (a daemon before hosts), the runs\' hosts fill the select', async () => {
    const { page, errors, close } = await open('#/runs', kViewports.narrow, { hosts: () => 404, setup: runsWithHosts });
    assert.deepEqual(await page.locator('select[name="host"] option').evaluateAll((o) => o.map((x) => x.value)), ['', 'gpu-a', 'gpu-old']);
    // Chromium's own note of the 404; the page logs nothing else.
    assert.equal(errors.length, 1, JSON.stringify(errors));
    assert.match(errors[0], /status of 404/);
    await close();
  });

  test('captures: host, attempts, earlier attempts\' errors and why a queued job waits', async () => {
    const spec = { renderers: ['forward'], scenes: ['atrium'], resolutions: [[32, 18]] };
    const jobs = [
      { id: 903, status: 'queued', host: null, attempts: 1, max_attempts: 3, attempt_errors: [kLost], waiting: kWaiting, progress: { done: 0, total: 10, current: '' }, spec: { ...spec, device: { name: 'AMD' } }, created_at: '2026-11-21T06:33:00Z', finished_at: null, error: null },
      { id: 902, status: 'running', host: 'gpu-a', attempts: 2, max_attempts: 3, attempt_errors: [kLost], waiting: null, progress: { done: 4, total: 10, current: 'forward atrium 32x18 camera 4' }, spec, created_at: '2026-11-21T06:32:00Z', finished_at: null, error: null },
      { id: 901, status: 'done', host: 'gpu-b', attempts: 1, max_attempts: 3, attempt_errors: [], waiting: null, progress: { done: 10, total: 10, current: '' }, spec, created_at: '2026-11-21T06:31:00Z', finished_at: '2026-11-21T06:31:30Z', error: null },
    ];
    const setup = async (context) => {
      await context.route((url) => url.pathname === '/api/captures', (route) => (route.request().method() === 'POST'
        ? route.fulfill({ status: 202, json: { id: 903, status: 'queued' } })
        : route.fulfill({ json: { captures: jobs, next_cursor: null } })));
      await context.route((url) => url.pathname === '/api/captures/903', (route) => route.fulfill({ json: jobs[0] }));
    };
    const { page, errors, close } = await open('#/capture', kViewports.narrow, { setup });
    const header = await page.locator('table.jobs thead th').allTextContents();
    const col = (name) => header.indexOf(name);
    const rows = await cells(page, 'table.jobs');
    assert.deepEqual(rows.map((r) => [r[0], r[col('Host')]]), [['#903', '–'], ['#902', 'gpu-a'], ['#901', 'gpu-b']]);
    assert.equal(await page.locator('tr[data-capture="903"] [data-waiting]').textContent(), `Waiting: ${kWaiting}`);
    assert.equal(await page.locator('tr[data-capture="902"] [data-waiting]').count(), 0);
    assert.deepEqual(await page.locator('tr[data-capture="903"] [data-cell="attempts"] li').allTextContents(), [kLost]);
    assert.match(await page.locator('tr[data-capture="902"] [data-cell="attempts"]').textContent(), /^2 \/ 3/);
    assert.equal(await page.locator('tr[data-capture="901"] [data-cell="attempts"]').textContent(), '1 / 3');
    let wider = await overflow(page);
    assert.ok(wider <= 0, `capture narrow: the page is ${wider}px wider than the window`);

    // A capture just started that no host can take: its panel says why.
    await page.click('form.capture-form button[type="submit"]');
    const panel = page.locator('.progress-box [data-capture="903"]');
    await panel.waitFor({ timeout: kViewMs });
    assert.equal(await panel.locator('[data-waiting]').textContent(), `Waiting: ${kWaiting}`);
    assert.deepEqual(await panel.locator('.attempt-errors li').allTextContents(), [kLost]);
    wider = await overflow(page);
    assert.ok(wider <= 0, `capture narrow, a waiting capture: the page is ${wider}px wider than the window`);
    await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, 'capture-fleet-narrow.png'), fullPage: true });
    assert.deepEqual(errors, []);
    await close();
  });
});

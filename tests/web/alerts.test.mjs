// Browser test of the alert flow on a real `tallyd serve` (lavapipe): a small
// capture (forward, 64x36, one camera, 8 frames, 4 lights) is marked as its
// configuration's baseline from its run view; the same configuration captured
// with 400 lights (a change that makes the frame slower and its counts
// different) must raise alerts. The navigation's badge must show the open
// alerts' count, the alerts view must list them (acknowledging one lowers the
// badge), and the trend view must chart the configuration's runs with the
// baseline drawn across and the alerted run marked. Which time alerts are
// raised is up to lavapipe: every expectation is read from the API's answers,
// except that a change of lights must change the counts.
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
const kEvaluationMs = 30_000;

let daemon;
let browser;
const data = {};

function spec(lights, commit) {
  return {
    renderers: ['forward'], scenes: ['atrium'], resolutions: [[64, 36]],
    cameras: [{ eye: [0, 1.6, -4], target: [0, 1.6, 4], fov_deg: 60 }],
    frames: 8, counting: 'exact', lights, ceilings: false, labels: { commit },
  };
}

async function open(hash) {
  const context = await browser.newContext({ viewport: { width: 1280, height: 900 } });
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

async function badge(page, expected) {
  await page.waitForFunction((n) => document.getElementById('alert-badge')?.dataset.count === String(n), expected, { timeout: kViewMs });
  return page.locator('#alert-badge');
}

before(async () => {
  for (const key of ['TALLYD', 'TALLY_WEB_ROOT', 'TALLY_SCREENSHOTS', 'CHROMIUM']) assert.ok(env[key], `${key} is not set`);
  mkdirSync(env.TALLY_SCREENSHOTS, { recursive: true });
  daemon = await new Daemon(env.TALLYD, env.TALLY_WEB_ROOT).start();
  const base = await daemon.capture(spec(4, 'base'), kCaptureMs);
  data.baseRun = (await daemon.get(`/runs?capture=${base.id}`)).runs[0];
  browser = await chromium.launch({ executablePath: env.CHROMIUM });
});

after(async () => {
  await browser?.close();
  await daemon?.stop();
});

describe('alerts', () => {
  test('baseline from the run view, a regressed capture, the badge, the list and the trend', async () => {
    // The baseline, marked in the run view (threshold 5 %).
    {
      const { page, errors, close } = await open(`#/runs/${data.baseRun.id}`);
      assert.match(await page.locator('[data-labels]').textContent(), /commit=base/);
      await page.click(`[data-mark-baseline="${data.baseRun.id}"]`);
      await page.waitForFunction(() => /baseline #\d+/.test(document.querySelector('[data-baseline-status]')?.textContent || ''), null, { timeout: kViewMs });
      assert.deepEqual(errors, []);
      await close();
    }
    const { baselines } = await daemon.get('/baselines');
    assert.equal(baselines.length, 1);
    const baseline = baselines[0];
    assert.equal(baseline.run, data.baseRun.id);
    assert.equal(baseline.threshold, 0.05);

    // The same configuration with 100 times the lights.
    const regressed = await daemon.capture(spec(400, 'more-lights'), kCaptureMs);
    const run = (await daemon.get(`/runs?capture=${regressed.id}`)).runs[0];
    assert.equal(run.lights, 400);
    assert.deepEqual(run.labels, { commit: 'more-lights' });
    // The evaluator's alerts on it arrive together (one transaction).
    let alerts = [];
    for (const until = Date.now() + kEvaluationMs; !alerts.length && Date.now() < until;) {
      alerts = (await daemon.get(`/alerts?run=${run.id}`)).alerts;
      if (!alerts.length) await sleep(250);
    }
    const counts = alerts.filter((a) => a.kind === 'counts');
    assert.equal(counts.length, 1, `a change of lights changes the counts: ${JSON.stringify(alerts)}`);
    // Its totals are the runs' bytes per frame (one camera each).
    assert.equal(counts[0].value_a, data.baseRun.mean_bytes);
    assert.equal(counts[0].value_b, run.mean_bytes);
    assert.ok(counts[0].details.changes.some((c) => c.line === 'total'));
    for (const a of alerts) {
      assert.equal(a.baseline, baseline.id);
      if (a.kind === 'time') assert.ok(Math.abs(a.ratio - 1) > baseline.threshold, `${a.metric}: ratio ${a.ratio} within the threshold`);
    }
    const open0 = (await daemon.get('/alerts?status=open')).counts.open;
    assert.equal(open0, alerts.length);

    // The badge and the list.
    {
      const { page, errors, close } = await open('#/alerts');
      assert.equal(await (await badge(page, open0)).textContent(), String(open0));
      assert.doesNotMatch(await page.locator('#view').textContent(), /\b(null|undefined|NaN)\b/);
      const rows = page.locator('table.alerts tbody tr[data-alert]');
      assert.equal(await rows.count(), alerts.length);
      // Grouped by run: one header row for the regressed run, its alerts under it.
      const group = page.locator(`tr[data-alert-group="${run.id}"]`);
      assert.equal(await page.locator('tr[data-alert-group]').count(), 1);
      assert.match(await group.textContent(), new RegExp(`Run #${run.id}: ${alerts.length} alerts? against baseline run #${data.baseRun.id}`));
      // A link comparing the two runs, and the spec fields that changed.
      assert.equal(await group.locator('a[data-compare-runs]').getAttribute('href'), `#/compare?runs=${data.baseRun.id},${run.id}`);
      assert.equal(await group.locator('[data-spec-changes]').getAttribute('data-spec-changes'), 'lights,commit');
      assert.match(await group.textContent(), /lights 4 → 400; commit base → more-lights/);
      for (const a of alerts) {
        const row = page.locator(`tr[data-alert="${a.id}"]`);
        assert.equal(await row.getAttribute('data-status'), 'open');
        // Regressions red, improvements green: a slower time or more bytes is worse.
        const worse = a.kind === 'time' ? a.verdict === 'slower' : a.ratio > 1;
        const change = await row.locator('td.what span').getAttribute('data-change');
        assert.equal(change, worse ? 'worse' : 'better', `alert ${a.id} (${a.metric} ${a.verdict}, ratio ${a.ratio})`);
        assert.equal(await row.locator('td.what span').evaluate((el) => getComputedStyle(el).color),
          worse ? 'rgb(166, 27, 27)' : 'rgb(27, 110, 58)');
        // "What" is never cut off: its text fits its cell, and the cell the window.
        const fit = await row.locator('td.what').evaluate((td) => ({ over: td.scrollWidth - td.clientWidth, right: td.getBoundingClientRect().right, width: window.innerWidth }));
        assert.ok(fit.over <= 0 && fit.right <= fit.width, `alert ${a.id}: What is cut off (${JSON.stringify(fit)})`);
      }
      // More lights, more bytes: the counts alert is a regression.
      assert.ok(counts[0].ratio > 1);
      assert.match(await page.locator(`tr[data-alert="${counts[0].id}"]`).textContent(), /counts changed/);
      // Every cell of the table lies inside the window at 1280 px.
      const outside = await page.locator('table.alerts').evaluate((t) => [...t.querySelectorAll('th, td')]
        .filter((c) => c.getBoundingClientRect().right > window.innerWidth + 0.5).map((c) => c.textContent));
      assert.deepEqual(outside, [], 'cells beyond the right edge');
      await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, 'alerts.png'), fullPage: true });
      // Acknowledging one: its row says so, and the badge counts one fewer.
      await page.click(`[data-ack="${counts[0].id}"]`);
      await page.waitForFunction((id) => document.querySelector(`tr[data-alert="${id}"]`) === null, counts[0].id, { timeout: kViewMs });
      await badge(page, open0 - 1);
      assert.equal((await daemon.get(`/alerts/${counts[0].id}`)).status, 'acknowledged');
      assert.deepEqual(errors, []);
      await close();
    }

    // The runs browser filtered by a label: only the regressed run, its labels shown.
    {
      const { page, errors, close } = await open('#/runs?label=commit%3Dmore-lights');
      assert.equal(await page.inputValue('input[name="label"]'), 'commit=more-lights');
      const rows = await page.locator('table.runs tbody tr').evaluateAll((trs) => trs.map((r) => Number(r.dataset.runId)));
      assert.deepEqual(rows, [run.id]);
      const column = (await page.locator('table.runs thead th').allTextContents()).indexOf('Labels');
      assert.ok(column > 0, 'a Labels column');
      assert.equal(await page.locator('table.runs tbody tr td').nth(column).textContent(), 'commit=more-lights');
      assert.deepEqual(errors, []);
      await close();
    }

    // The trend: both runs, by their commit label; the baseline across, the alerts marked.
    {
      const trend = await daemon.get(`/trend?baseline=${baseline.id}`);
      assert.deepEqual(trend.runs.map((r) => r.id), [data.baseRun.id, run.id]);
      const { page, errors, close } = await open(`#/trend/${baseline.id}`);
      const drawn = await page.evaluate(() => Object.fromEntries(['trend-frame', 'trend-bytes'].map((id) => {
        const c = window.Chart.getChart(document.querySelector(`[data-chart="${id}"] canvas`));
        const ticks = c.scales.x.ticks.map((t) => t.label);
        return [id, { ticks, datasets: c.data.datasets.map((d) => ({ label: d.label, baseline: Boolean(d.baseline), alerts: Boolean(d.alerts), data: d.data.map((p) => ({ x: p.x, y: p.y, run: p.run })) })) }];
      })));
      const timeAlerted = alerts.some((a) => a.kind === 'time');
      for (const [id, y, alerted] of [['trend-frame', (r) => r.frame_ms.median, timeAlerted], ['trend-bytes', (r) => r.mean_bytes, true]]) {
        const chart = drawn[id];
        const series = chart.datasets[0];
        assert.deepEqual(series.data.map((p) => p.y), trend.runs.map(y), `${id}: the runs' values`);
        const line = chart.datasets.find((d) => d.baseline);
        assert.ok(line, `${id}: no baseline line`);
        assert.equal(line.data[0].y, y(trend.runs[0]));
        const marks = chart.datasets.find((d) => d.alerts);
        assert.deepEqual(marks.data.map((p) => p.run), alerted ? [run.id] : [], `${id}: alert marks`);
        assert.ok(chart.ticks.includes('base') && chart.ticks.includes('more-lights'), `${id}: x by commit: ${chart.ticks}`);
      }
      // The frame time's interval as a shaded band (the high edge filled down
      // to the low one), and the baseline ± threshold as a second band.
      const bands = await page.evaluate(() => {
        const c = window.Chart.getChart(document.querySelector('[data-chart="trend-frame"] canvas'));
        return c.data.datasets.filter((d) => d.band).map((d) => ({ band: d.band, edge: d.edge, fill: d.fill ?? null, legend: d.legend ?? true, ys: d.data.map((p) => p.y) }));
      });
      const interval = bands.filter((b) => b.band === 'interval');
      assert.deepEqual(interval.map((b) => [b.edge, b.fill]), [['low', null], ['high', '-1']]);
      assert.deepEqual(interval[0].ys, trend.runs.map((r) => r.frame_ms.lower).filter((v) => v !== null));
      assert.deepEqual(interval[1].ys, trend.runs.map((r) => r.frame_ms.upper).filter((v) => v !== null));
      const limits = bands.filter((b) => b.band === 'threshold');
      const median0 = trend.runs[0].frame_ms.median;
      const t = baseline.threshold;
      assert.deepEqual(limits.map((b) => b.ys), [[median0 * (1 - t), median0 * (1 - t)], [median0 * (1 + t), median0 * (1 + t)]]);
      // The alert marks: red for a regression, green for an improvement.
      const timeAlerts = alerts.filter((a) => a.kind === 'time');
      if (timeAlerts.length) {
        const markColors = await page.evaluate(() => {
          const c = window.Chart.getChart(document.querySelector('[data-chart="trend-frame"] canvas'));
          return c.data.datasets.find((d) => d.alerts).data.map((p) => p.change);
        });
        const slower = timeAlerts.some((a) => a.verdict === 'slower');
        assert.deepEqual(markColors, [slower ? 'worse' : timeAlerts.every((a) => a.verdict === 'faster') ? 'better' : 'same']);
      }
      assert.equal(await page.locator('[data-trend-table] tbody tr').count(), 2);
      await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, 'trend.png'), fullPage: true });
      assert.deepEqual(errors, []);
      await close();
    }
  });
});

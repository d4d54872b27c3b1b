// Browser test of an application's run (docs/layer.md): a `tallyd serve
// --allow-applications` (its application token in the page's storage and the
// test's requests, tests/capture as the application root, as nobody when the
// test runs as root) whose capture runs tests/capture/fake_app.sh in place
// of a Vulkan application under the layer (a manifest folder of our own in
// $TALLY_LAYER_PATH). The run view must show its frames, the layer's notes
// and the shaders left uninstrumented, and do without cameras, screenshots,
// image error and an uninstrumented baseline, with no console error; the
// captures list must name the application. No GPU is needed.
//
// Environment (tests/web/run.sh sets it): TALLYD, TALLY_WEB_ROOT,
// TALLY_SCREENSHOTS, CHROMIUM.
import assert from 'node:assert/strict';
import { chmodSync, mkdirSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join } from 'node:path';
import { after, before, describe, test } from 'node:test';
import { fileURLToPath } from 'node:url';

import { chromium } from 'playwright-core';

import { Daemon } from './daemon.mjs';

const env = process.env;
const here = dirname(fileURLToPath(import.meta.url));
const kFakeApp = join(here, '..', 'capture', 'fake_app.sh');
const kViewMs = 30_000;
const kTokens = {
  read: 'r3ad-0123456789abcdefghijklmnopqrstuv',
  capture: 'c4pture-0123456789abcdefghijklmnopqrst',
  application: 'app1ication-0123456789abcdefghijklmnop',
};

let daemon;
let browser;
let layer;

async function open(hash, viewport = { width: 1280, height: 800 }) {
  const context = await browser.newContext({ viewport });
  // The dashboard keeps its token in this browser's storage (web/api.js).
  await context.addInitScript((token) => localStorage.setItem('tally.token', token), kTokens.application);
  const page = await context.newPage();
  const errors = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(`uncaught: ${e.message}`));
  await page.goto(`${daemon.url}/${hash}`);
  await page.waitForFunction(() => {
    const view = document.getElementById('view');
    return view && !view.hasAttribute('aria-busy') && view.querySelector('.page');
  }, null, { timeout: kViewMs });
  return { page, errors, close: () => context.close() };
}

before(async () => {
  for (const key of ['TALLYD', 'TALLY_WEB_ROOT', 'TALLY_SCREENSHOTS', 'CHROMIUM']) assert.ok(env[key], `${key} is not set`);
  mkdirSync(env.TALLY_SCREENSHOTS, { recursive: true });
  layer = mkdtempSync(join(tmpdir(), 'tally-web-layer-'));
  writeFileSync(join(layer, 'VkLayer_tally_counters.json'), '{}');
  const tokens = join(layer, 'tokens');
  writeFileSync(tokens, Object.entries(kTokens).map(([k, v]) => `${k}=${v}\n`).join(''), { mode: 0o600 });
  const args = ['--allow-applications', '--token-file', tokens, '--application-root', dirname(kFakeApp), '--application-env', 'FAKE_APP_*'];
  if (process.geteuid() === 0) args.push('--run-as', 'nobody');
  daemon = new Daemon(env.TALLYD, env.TALLY_WEB_ROOT, { args, env: { TALLY_LAYER_PATH: layer }, token: kTokens.application });
  // Its job folders live in the daemon's folder, which the application's user must reach.
  chmodSync(daemon.dir, 0o755);
  chmodSync(layer, 0o755);
  daemon = await daemon.start();
  browser = await chromium.launch({ executablePath: env.CHROMIUM });
});

after(async () => {
  await browser?.close();
  await daemon?.stop();
  if (layer) rmSync(layer, { recursive: true, force: true });
});

describe('an application captured under the layer', () => {
  test('run view: frames, the layer\'s notes, no cameras or screenshots', async () => {
    const job = await daemon.capture({ application: { command: [kFakeApp, '--c', '100'], frames: 3, skip_frames: 5, name: 'cube' } }, 60_000);
    const runs = (await daemon.get(`/runs?capture=${job.id}`)).runs;
    assert.equal(runs.length, 1);
    const run = runs[0];
    assert.equal(run.renderer, 'app:cube');

    for (const [size, viewport] of Object.entries({ wide: { width: 1280, height: 800 }, narrow: { width: 400, height: 800 } })) {
      const { page, errors, close } = await open(`#/runs/${run.id}`, viewport);
      assert.match(await page.locator('#view h1').textContent(), /app:cube/);
      assert.match(await page.locator('[data-source="application"]').textContent(), /fake_app\.sh --c 100/);
      assert.equal(await page.locator('[data-layer-notes] li').count(), 1);
      assert.match(await page.locator('[data-uninstrumented-shaders] li').first().textContent(), /shader 0x11 \(vertex\): OpCapability Foo/);
      assert.equal(await page.locator('[data-screenshots="none"]').count(), 1);
      assert.equal(await page.locator('.gallery').count(), 0);
      assert.equal(await page.locator('[data-tile="overhead"]').count(), 0);
      assert.equal(await page.locator('[data-tile="image-error"]').count(), 0);
      assert.match(await page.locator('[data-headroom="none"]').textContent(), /application/);
      // The samples are the frames the layer read back.
      const samples = page.locator('[data-table="samples"]');
      assert.equal(await samples.locator('thead th').first().textContent(), 'Frame');
      assert.deepEqual(await samples.locator('tbody tr td:first-child').allTextContents(), ['frame 5', 'frame 6', 'frame 7']);
      // Pass times: one series, measured under the layer.
      const datasets = await page.evaluate(() => {
        const c = window.Chart.getChart(document.querySelector('[data-chart="pass-time"] canvas'));
        return c.data.datasets.map((d) => ({ label: d.label, data: d.data }));
      });
      assert.deepEqual(datasets.map((d) => d.label), ['under the layer']);
      assert.deepEqual(datasets[0].data, run.passes ? run.passes.map((p) => p.gpu_ms) : (await daemon.get(`/runs/${run.id}`)).passes.map((p) => p.gpu_ms));
      const overflow = await page.evaluate(() => document.documentElement.scrollWidth - document.documentElement.clientWidth);
      assert.ok(overflow <= 0, `${size}: the page is ${overflow}px wider than the window`);
      await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, `run-application-${size}.png`), fullPage: true });
      assert.deepEqual(errors, [], 'console errors');
      await close();
    }

    // The captures list names the application.
    {
      // The application form: a command with a quoted argument, frames, a
      // name; the job runs and stores app:NAME. A bad field is named by the server.
      const { page, errors, close } = await open('#/capture');
      await page.locator('[data-box="application"] summary').click();
      const form = page.locator('form.app-form');
      await form.locator('[name="application.command"]').fill(`${kFakeApp} --c "100"`);
      await form.locator('[name="application.frames"]').fill('2');
      await form.locator('[name="application.name"]').fill('formcube');
      await form.locator('button[type="submit"]').click();
      await page.waitForFunction(() => /done/.test(document.querySelector('.progress, [data-job]')?.textContent || ''), null, { timeout: kViewMs }).catch(() => {});
      const formRuns = await (async () => {
        for (let i = 0; i < 100; i++) {
          const r = (await daemon.get('/runs?renderer=app:formcube')).runs;
          if (r.length) return r;
          await new Promise((f) => setTimeout(f, 200));
        }
        return [];
      })();
      assert.equal(formRuns.length, 1, 'the form\'s capture stored app:formcube');
      assert.equal(formRuns[0].sample_count, 2);
      await form.locator('[name="application.frames"]').fill('0');
      await form.locator('button[type="submit"]').click();
      await page.locator('form.app-form .form-error .panel.error').waitFor({ timeout: kViewMs });
      assert.equal(await form.locator('.form-error [data-field]').getAttribute('data-field'), 'application.frames');
      assert.equal(await form.locator('[data-field="application.frames"] input').getAttribute('aria-invalid'), 'true');
      await page.screenshot({ path: join(env.TALLY_SCREENSHOTS, 'capture-application-form.png'), fullPage: true });
      // The refused POST is logged by the browser itself: the only error allowed.
      assert.deepEqual(errors.filter((e) => !/status of 400/.test(e)), [], 'console errors');
      await close();
    }
    // The captures list names the application.
    const { page, errors, close } = await open('#/capture');
    assert.match(await page.locator(`tr[data-capture="${job.id}"]`).textContent(), /application .*fake_app\.sh --c 100/);
    assert.deepEqual(errors, [], 'console errors');
    await close();
  });
});

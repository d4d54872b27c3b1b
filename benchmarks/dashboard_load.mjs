// How long each dashboard view takes to draw in Chromium with many runs
// stored: from navigation to the view's "drawn" state (app.js clears
// aria-busy on #view), over fresh browser contexts so that nothing is cached.
// Prints figures; asserts nothing about them. Run by dashboard_load.sh.
//
// Environment: TALLYD, TALLY_WEB_ROOT, TALLY_DB (a filled database),
// CHROMIUM, REPEATS.
import { spawn } from 'node:child_process';
import { createRequire } from 'node:module';
import { setTimeout as sleep } from 'node:timers/promises';

// playwright-core is installed for the browser tests (tests/web, by scripts/setup.sh).
const require = createRequire(new URL('../tests/web/package.json', import.meta.url));
const { chromium } = require('playwright-core');

const env = process.env;
const repeats = Number(env.REPEATS || 5);

async function startDaemon() {
  const child = spawn(env.TALLYD, ['serve', '--db', env.TALLY_DB, '--port', '0', '--web', env.TALLY_WEB_ROOT],
    { stdio: ['ignore', 'pipe', 'inherit'] });
  let out = '';
  const url = await Promise.race([
    new Promise((resolve) => child.stdout.on('data', (d) => {
      out += d;
      const m = /tallyd: serving (http:\/\/127\.0\.0\.1:\d+)\//.exec(out);
      if (m) resolve(m[1]);
    })),
    sleep(30_000).then(() => { throw new Error('tallyd serve printed no address in 30 s'); }),
  ]);
  return { child, url };
}

async function api(url, path) {
  const r = await fetch(url + path);
  if (!r.ok) throw new Error(`${path}: ${r.status} ${await r.text()}`);
  return r.json();
}

function summary(values) {
  const s = [...values].sort((a, b) => a - b);
  const at = (q) => s[Math.min(s.length - 1, Math.floor(q * s.length))];
  return { median: at(0.5), min: s[0], max: s[s.length - 1] };
}

const { child, url } = await startDaemon();
const browser = await chromium.launch({ executablePath: env.CHROMIUM, args: ['--no-sandbox'] });
try {
  // How many runs are stored: walk the pages (ids only matter).
  let stored = 0;
  let cursor = '';
  do {
    const page = await api(url, `/api/runs?limit=1000${cursor ? `&cursor=${cursor}` : ''}`);
    stored += page.runs.length;
    cursor = page.next_cursor || '';
  } while (cursor);
  const newest = (await api(url, '/api/runs?limit=1')).runs[0];
  const peers = (await api(url, `/api/runs?scene=${encodeURIComponent(newest.scene)}&width=${newest.width}` +
    `&height=${newest.height}&device=${newest.device_id}&limit=3`)).runs.map((r) => r.id);
  const views = [
    ['runs', '#/runs'],
    ['run', `#/runs/${newest.id}`],
    ['compare', `#/compare?runs=${peers.join(',')}`],
    ['speed vs accuracy', '#/accuracy'],
    ['capture', '#/capture'],
  ];
  console.log(`${stored} runs stored; ${repeats} loads per view, each in a fresh browser context, 1280x800`);
  console.log('view                 median ms    min ms    max ms   console errors');
  const figures = {};
  for (const [name, hash] of views) {
    const times = [];
    let errors = 0;
    for (let i = 0; i < repeats; ++i) {
      const context = await browser.newContext({ viewport: { width: 1280, height: 800 } });
      const page = await context.newPage();
      page.on('console', (m) => { if (m.type() === 'error') ++errors; });
      page.on('pageerror', () => ++errors);
      const start = performance.now();
      await page.goto(`${url}/${hash}`);
      await page.waitForFunction(() => {
        const view = document.getElementById('view');
        return view && !view.hasAttribute('aria-busy') && view.querySelector('.page');
      }, null, { timeout: 60_000 });
      times.push(performance.now() - start);
      await context.close();
    }
    const s = summary(times);
    figures[name] = { ...s, errors };
    console.log(`${name.padEnd(20)} ${s.median.toFixed(0).padStart(9)} ${s.min.toFixed(0).padStart(9)} ` +
      `${s.max.toFixed(0).padStart(9)}   ${errors}`);
  }
  if (env.JSON_OUT) console.log(JSON.stringify({ runs: stored, repeats, figures }));
} finally {
  await browser.close();
  child.kill('SIGTERM');
}

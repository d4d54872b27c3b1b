// The fleet test's look at the dashboard of the API daemon it started: the
// hosts view lists every worker (the killed one stale) and the runs browser
// shows each run's host, filtered by the host select's ?host=.
//   node dashboard_check.mjs BASE_URL worker-a,worker-b,worker-c
// It sits in tests/web, beside the node_modules that hold playwright-core; CHROMIUM names
// the browser (default /usr/bin/chromium).
import assert from 'node:assert/strict';

import { chromium } from 'playwright-core';

const [base, names] = process.argv.slice(2);
const workers = names.split(',');
const browser = await chromium.launch({ executablePath: process.env.CHROMIUM || '/usr/bin/chromium' });
try {
  const page = await browser.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));

  await page.goto(`${base}/#/hosts`);
  await page.waitForSelector('tr[data-host]');
  const rows = await page.$$eval('tr[data-host]', (trs) => trs.map((tr) => ({ host: tr.dataset.host, alive: tr.dataset.alive })));
  assert.deepEqual(rows.map((r) => r.host).sort(), [...workers].sort(), 'the hosts view lists every worker');
  const killed = rows.find((r) => r.host === workers[0]);
  assert.equal(killed.alive, 'false', `${workers[0]} shows as alive`);

  // Every run shows its host; the host filter keeps only that host's runs.
  const api = await (await fetch(`${base}/api/runs?limit=1000`)).json();
  for (const host of workers.slice(1)) {
    const expected = api.runs.filter((r) => r.host === host).length;
    await page.goto(`${base}/#/runs?host=${encodeURIComponent(host)}`);
    await page.waitForFunction(() => document.querySelectorAll('table tbody tr').length > 0);
    const cells = await page.$$eval('table tbody tr', (trs, h) => trs.map((tr) => tr.textContent.includes(h)), host);
    assert.ok(cells.every(Boolean), `a run listed for ?host=${host} does not show ${host}`);
    assert.equal(cells.length, Math.min(expected, 100), `runs listed for ${host}`);
  }
  assert.deepEqual(errors, [], 'page errors');
  console.log(`dashboard: ${rows.length} hosts listed (${workers[0]} stale); runs show and filter by host`);
} finally {
  await browser.close();
}

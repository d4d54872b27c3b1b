// Hosts (#/hosts): the daemons that share the store (GET /api/hosts), one row
// each with its device, build, last heartbeat, state and jobs. A host whose
// last heartbeat is older than the server's stale_after_s is stale: its row
// is marked and says so. The list is fetched again every few seconds while
// the view is shown; leaving it stops that.
import { get } from '../api.js';
import { h } from '../dom.js';
import * as fmt from '../format.js';
import { sleep } from '../poll.js';

const kRefreshMs = 5000;

// The device it reports: an override (a site's or a test's name for it) is
// marked as one, with the probed device in its tooltip.
function deviceCell(host) {
  const probed = host.device ? `${host.device.name} (${host.device.vendor}), Vulkan ${host.device.api_version}` : 'not probed yet';
  if (host.device_override) {
    return h('span', { dataset: { override: '' }, title: `override; the device: ${probed}` },
      host.device_override, ' ', h('span', { class: 'muted' }, '(override)'));
  }
  if (!host.device) return h('span', { class: 'muted' }, 'not probed yet');
  return h('span', { class: 'clip', title: probed }, host.device.name);
}

function stateCell(host, staleAfter) {
  return host.alive
    ? h('span', { class: 'badge alive' }, 'alive')
    : h('span', { class: 'badge stale', title: `no heartbeat in the last ${staleAfter} s` }, 'stale');
}

const kColumns = [
  { label: 'Host', value: (x) => h('a', { href: `#/runs?host=${encodeURIComponent(x.name)}`, title: `runs captured on ${x.name}` }, x.name) },
  { label: 'Role', value: (x) => x.role },
  { label: 'Device', value: deviceCell },
  { label: 'Driver', value: (x) => (x.device ? x.device.driver : '–') },
  { label: 'Tally', value: (x) => `${x.tally_version}${x.tally_commit ? ` (${x.tally_commit})` : ''}` },
  { label: 'Started (UTC)', value: (x) => fmt.date(x.started_at) },
  { label: 'Last heartbeat', className: 'num', value: (x) => h('span', { title: x.last_heartbeat }, fmt.ago(x.seconds_since_heartbeat)) },
  { label: 'State', value: stateCell },
  { label: 'Done', className: 'num', value: (x) => fmt.count(x.jobs_done) },
  { label: 'Failed', className: 'num', value: (x) => fmt.count(x.jobs_failed) },
  { label: 'Current job', className: 'num', value: (x) => (x.current_job === null || x.current_job === undefined ? '–' : `#${x.current_job}`) },
];

function hostTable(hosts, staleAfter) {
  return h('div', { class: 'table-wrap' }, h('table', { class: 'hosts', 'aria-label': 'Hosts' },
    h('thead', {}, h('tr', {}, kColumns.map((c) => h('th', { scope: 'col', class: c.className }, c.label)))),
    h('tbody', {}, hosts.map((x) => h('tr', { class: x.alive ? null : 'stale', dataset: { host: x.name, alive: String(Boolean(x.alive)) } },
      kColumns.map((c) => h('td', { class: c.className }, c.value(x, staleAfter))))))));
}

function summaryText(hosts, staleAfter) {
  const stale = hosts.filter((x) => !x.alive).length;
  const n = hosts.length;
  return `${n} host${n === 1 ? '' : 's'}: ${n - stale} alive, ${stale} stale (no heartbeat in the last ${staleAfter} s). Refreshed every ${kRefreshMs / 1000} s.`;
}

export async function render(page, { signal }) {
  const first = await get('/hosts', signal);
  const list = h('div', { dataset: { refreshes: '0' } });
  const status = h('p', { class: 'muted', role: 'status' });
  let refreshes = 0;

  function draw({ hosts, stale_after_s: staleAfter }) {
    list.replaceChildren(hosts.length ? hostTable(hosts, staleAfter)
      : h('p', { class: 'panel' }, 'No host has registered with this store yet.'));
    list.dataset.refreshes = String(refreshes);
    status.textContent = summaryText(hosts, staleAfter);
  }

  // Until the view is left; a failed refresh says so and the next one tries again.
  async function refresh() {
    while (!signal.aborted) {
      await sleep(kRefreshMs, signal);
      if (signal.aborted) return;
      try {
        const reply = await get('/hosts', signal);
        ++refreshes;
        draw(reply);
      } catch (error) {
        if (!signal.aborted) status.textContent = `Could not refresh the hosts: ${error.message}`;
      }
    }
  }

  page.append(
    h('h1', {}, 'Hosts'),
    h('p', { class: 'muted' }, 'The daemons that share this store: each runs captures on its own device and sends a heartbeat while it lives.'),
    status, list);
  draw(first);
  refresh();
}

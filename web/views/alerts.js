// Alerts (#/alerts, #/alerts/ID): regression alerts, newest first (GET
// /api/alerts), filtered by status, each with its figures, its run and the
// trend of its baseline's configuration; an open alert can be acknowledged,
// and any alert's status set (PATCH /api/alerts/{id}). The active baselines
// are listed above, each with its trend. The list is fetched again every
// few seconds while shown.
import { refreshBadge } from '../alert_badge.js';
import { get, queryString, request } from '../api.js';
import { append, h, table } from '../dom.js';
import * as fmt from '../format.js';
import { changeClass } from '../palette.js';
import { sleep } from '../poll.js';

const kRefreshMs = 5000;
const kStatuses = ['open', 'acknowledged', 'invalid', 'fixed'];

function interval(a) {
  return a.interval ? `[${a.interval[0].toFixed(3)}, ${a.interval[1].toFixed(3)}]` : '–';
}

// A: the baseline's value, B: the run's: medians in ms for time, bytes per frame for counts.
const value = (a, v) => (a.kind === 'counts' ? fmt.bytes(v) : fmt.ms(v));

function whatChanged(a) {
  if (a.kind !== 'counts') return `${a.metric} ${a.verdict}`;
  const changes = a.details?.changes || [];
  const shown = changes.slice(0, 3).map((c) => `${c.line} ${fmt.count(c.a)} → ${fmt.count(c.b)}`).join('; ');
  return `counts changed in ${changes.length} line${changes.length === 1 ? '' : 's'}${shown ? `: ${shown}${changes.length > 3 ? '; …' : ''}` : ''}`;
}

function statusControl(a, onChange) {
  const select = h('select', { name: 'status', 'aria-label': `Status of alert ${a.id}` },
    kStatuses.map((s) => h('option', { value: s, selected: s === a.status }, s)));
  select.addEventListener('change', () => onChange(a, select.value));
  const ack = a.status === 'open'
    ? h('button', { type: 'button', dataset: { ack: String(a.id) }, onclick: () => onChange(a, 'acknowledged') }, 'Acknowledge')
    : null;
  return h('span', {}, select, ' ', ack);
}

// Compact enough for 1280 px: the ratio carries its interval, A and B share a
// cell, and the run and its trend are named once, in the run's header row.
function alertColumns(onChange) {
  return [
    { label: 'Alert', value: (a) => h('a', { href: `#/alerts/${a.id}` }, `#${a.id}`) },
    { label: 'Status', value: (a) => h('span', { dataset: { status: a.status } }, a.status) },
    { label: 'What', className: 'what', value: (a) => h('span', { class: alertClass(a), dataset: { change: alertClass(a) || 'same' } }, whatChanged(a)) },
    { label: 'Ratio [95% interval]', className: 'num', value: (a) => [h('div', {}, fmt.ratio(a.ratio)), h('div', { class: 'muted' }, interval(a))] },
    { label: 'p', className: 'num', value: (a) => fmt.pValue(a.p_value) },
    { label: 'Baseline (A) → run (B)', className: 'num', value: (a) => [h('div', {}, value(a, a.value_a)), h('div', {}, `→ ${value(a, a.value_b)}`)] },
    { label: 'Raised (UTC)', className: 'date', value: (a) => fmt.date(a.created_at) },
    { label: 'Webhook', value: (a) => (a.delivery.state === 'none' ? '–' : h('span', { title: a.delivery.last_error || '' }, `${a.delivery.state} (${a.delivery.attempts})`)) },
    { label: '', className: 'controls', value: (a) => statusControl(a, onChange) },
  ];
}

// Red for a regression, green for an improvement: time by its verdict, counts
// by whether the bytes went up or down.
export function alertClass(a) {
  if (a.kind === 'time') return a.verdict === 'slower' ? 'worse' : a.verdict === 'faster' ? 'better' : '';
  return changeClass(a.ratio === null || a.ratio === undefined ? null : a.ratio - 1);
}

// What differs between the baseline's run and the tested one, beyond the
// configuration (which they share): lights, labels, build, host, samples.
export function specChanges(base, run) {
  if (!base || !run) return [];
  const out = [];
  const add = (field, a, b) => { if (JSON.stringify(a ?? null) !== JSON.stringify(b ?? null)) out.push({ field, a: a ?? '–', b: b ?? '–' }); };
  add('lights', base.lights, run.lights);
  for (const key of [...new Set([...Object.keys(base.labels || {}), ...Object.keys(run.labels || {})])].sort()) add(key, base.labels?.[key], run.labels?.[key]);
  add('tally commit', base.tally_commit, run.tally_commit);
  add('host', base.host, run.host);
  add('samples', base.sample_count, run.sample_count);
  return out;
}

// The alerts grouped by the run they were raised on: a header row per run with
// a link comparing it with its baseline's run and the spec fields that changed,
// then its alerts.
function alertTable(alerts, onChange, highlight, runsById) {
  const columns = alertColumns(onChange);
  const groups = new Map();
  for (const a of alerts) {
    if (!groups.has(a.run)) groups.set(a.run, []);
    groups.get(a.run).push(a);
  }
  const rows = [];
  for (const [runId, list] of groups) {
    const a0 = list[0];
    const changes = specChanges(runsById.get(a0.baseline_run), runsById.get(runId));
    const worst = list.some((a) => alertClass(a) === 'worse') ? 'worse' : list.every((a) => alertClass(a) === 'better') ? 'better' : '';
    rows.push(h('tr', { class: `alert-group ${worst}`, dataset: { alertGroup: String(runId) } },
      h('th', { scope: 'rowgroup', colspan: columns.length },
        h('span', { class: `group-mark ${worst}` }), h('a', { href: `#/runs/${runId}` }, `Run #${runId}`),
        `: ${list.length} alert${list.length === 1 ? '' : 's'} against baseline run #${a0.baseline_run} · `,
        h('a', { href: `#/compare?runs=${a0.baseline_run},${runId}`, dataset: { compareRuns: `${a0.baseline_run},${runId}` } }, 'compare these two runs'),
        ' · ', h('a', { href: `#/trend/${a0.baseline}`, dataset: { trend: String(a0.baseline) } }, `trend of baseline #${a0.baseline}`),
        h('span', { class: 'spec-changes', dataset: { specChanges: changes.map((c) => c.field).join(',') } },
          changes.length ? ` · changed: ${changes.map((c) => `${c.field} ${c.a} → ${c.b}`).join('; ')}` : ' · no spec field changed'))));
    for (const a of list) {
      const tr = h('tr', { dataset: { alert: String(a.id), status: a.status } }, columns.map((c) => h('td', { class: c.className }, c.value(a))));
      tr.classList.toggle('alert-open', a.status === 'open');
      tr.classList.toggle('alert-highlight', String(a.id) === highlight);
      rows.push(tr);
    }
  }
  return h('div', { class: 'table-wrap' }, h('table', { class: 'alerts', 'aria-label': 'Alerts' },
    h('thead', {}, h('tr', {}, columns.map((c) => h('th', { scope: 'col', class: c.className }, c.label)))), h('tbody', {}, rows)));
}

// The runs the alerts name (tested and baseline), fetched once each.
async function alertRuns(alerts, cache, signal) {
  const ids = [...new Set(alerts.flatMap((a) => [a.run, a.baseline_run]))].filter((id) => !cache.has(id));
  const got = await Promise.all(ids.map((id) => get(`/runs/${id}`, signal).catch((error) => {
    if (signal.aborted) throw error;
    return null;
  })));
  ids.forEach((id, i) => cache.set(id, got[i]));
  return cache;
}

function baselineTable(baselines) {
  const columns = [
    { label: 'Baseline', value: (b) => `#${b.id}${b.name ? ` ${b.name}` : ''}` },
    { label: 'Configuration', value: (b) => `${b.configuration.variant} · ${b.configuration.scene} · ${b.configuration.width}×${b.configuration.height} · ${b.configuration.device} · ${b.configuration.counting}` },
    { label: 'Run', value: (b) => h('a', { href: `#/runs/${b.run}` }, `#${b.run}`) },
    { label: 'Labels', value: (b) => fmt.labels(b.labels) || '–' },
    { label: 'Threshold', className: 'num', value: (b) => fmt.percent(b.threshold) },
    { label: 'Open alerts', className: 'num', value: (b) => String(b.open_alerts) },
    { label: 'Trend', value: (b) => h('a', { href: `#/trend/${b.id}`, dataset: { trend: String(b.id) } }, 'trend') },
  ];
  return table(columns, baselines, { class: 'baselines', 'aria-label': 'Baselines' });
}

export async function render(page, { params, query, signal }) {
  const status = query.get('status') ?? 'open';
  const filter = h('select', { name: 'status', 'aria-label': 'Status' },
    h('option', { value: '', selected: status === '' || status === 'all' }, 'all'),
    kStatuses.map((s) => h('option', { value: s, selected: s === status }, s)));
  filter.addEventListener('change', () => { location.hash = `#/alerts${queryString({ status: filter.value || 'all' })}`; });
  const apiStatus = kStatuses.includes(status) ? status : '';
  const path = `/alerts${queryString({ status: apiStatus, limit: 200 })}`;
  const [first, { baselines }] = await Promise.all([get(path, signal), get('/baselines', signal)]);
  const list = h('div', { dataset: { refreshes: '0' } });
  const summary = h('p', { class: 'muted', role: 'status' });
  const highlight = params.id;
  let refreshes = 0;

  async function setStatus(a, next) {
    try {
      await request(`/alerts/${a.id}`, { method: 'PATCH', body: { status: next }, signal });
      await draw(await get(path, signal));
      refreshBadge();
    } catch (error) {
      if (!signal.aborted) summary.textContent = `Could not change alert #${a.id}: ${error.message}`;
    }
  }

  const runsById = new Map();
  async function draw(reply) {
    const c = reply.counts;
    await alertRuns(reply.alerts, runsById, signal);
    list.replaceChildren(reply.alerts.length ? alertTable(reply.alerts, setStatus, highlight, runsById)
      : h('p', { class: 'panel', dataset: { empty: '' } }, apiStatus ? `No ${apiStatus} alert.` : 'No alert yet.'));
    list.dataset.refreshes = String(refreshes);
    summary.textContent = `${c.open} open, ${c.acknowledged} acknowledged, ${c.invalid} invalid, ${c.fixed} fixed.${reply.next_cursor ? ' Showing the newest 200.' : ''}`;
  }

  let detail = null;
  if (highlight) {
    const a = await get(`/alerts/${encodeURIComponent(highlight)}`, signal);
    detail = h('section', { class: 'panel', dataset: { alertDetail: String(a.id) } },
      h('h2', {}, `Alert #${a.id}: ${whatChanged(a)}`),
      h('p', {}, `Run `, h('a', { href: `#/runs/${a.run}` }, `#${a.run}`), ` against baseline run `,
        h('a', { href: `#/runs/${a.baseline_run}` }, `#${a.baseline_run}`), ' (', h('a', { href: `#/trend/${a.baseline}` }, 'trend'), ')',
        a.run_row && fmt.labels(a.run_row.labels) ? `; labels ${fmt.labels(a.run_row.labels)}` : ''),
      a.kind === 'time' ? h('p', {}, `ratio ${fmt.ratio(a.ratio)} ${interval(a)}, p ${a.p_value < 1e-4 ? '' : '= '}${fmt.pValue(a.p_value)}, Cliff's delta ${fmt.signed(a.cliffs_delta, 3)}; ${a.details?.reason || ''}`) : null,
      a.kind === 'counts' ? table([
        { label: 'Line', value: (c) => c.line },
        { label: 'Baseline', className: 'num', value: (c) => fmt.count(c.a) },
        { label: 'Run', className: 'num', value: (c) => fmt.count(c.b) },
        { label: 'Change', className: 'num', value: (c) => fmt.count(c.delta) },
      ], a.details?.changes || [], { 'aria-label': 'Count changes' }) : null);
  }

  async function refresh() {
    while (!signal.aborted) {
      await sleep(kRefreshMs, signal);
      if (signal.aborted) return;
      try {
        const reply = await get(path, signal);
        ++refreshes;
        await draw(reply);
      } catch (error) {
        if (!signal.aborted) summary.textContent = `Could not refresh the alerts: ${error.message}`;
      }
    }
  }

  append(page, [
    h('h1', {}, 'Alerts'),
    h('p', { class: 'muted' }, 'Each new run of a configuration with a baseline is tested against the baseline run: a significant change of frame or pass time beyond the baseline\'s threshold, or any change of counts, raises an alert.'),
    detail,
    h('h2', {}, 'Baselines'),
    baselines.length ? baselineTable(baselines) : h('p', { class: 'panel' }, 'No baseline yet: mark a run as its configuration\'s baseline in its run view.'),
    h('h2', {}, 'Alerts'),
    h('label', {}, 'Status ', filter), summary, list]);
  await draw(first);
  refresh();
}

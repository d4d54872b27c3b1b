// Trend (#/trend/ID): every run of a baseline's configuration in order (GET
// /api/trend?baseline=ID), charted against a label of the runs (commit,
// branch, ...) or their dates: the frame time's median with its 95%
// interval, and the bytes per frame, with the baseline run's value drawn
// across as a dashed line and the runs that raised alerts marked.
import { get } from '../api.js';
import { destroyCharts, xyChart } from '../charts.js';
import { h, table } from '../dom.js';
import * as fmt from '../format.js';

const kBaselineColor = '#555';
const kAlertColor = '#c62828';

// The x axis's text for run i: one of its labels, or its date.
function xLabel(run, axis) {
  if (axis === 'date') return fmt.date(run.created_at);
  return run.labels[axis] ?? `#${run.id}`;
}

function dataTable(runs, axis, alertsById) {
  return table([
    { label: 'Run', value: (r) => h('a', { href: `#/runs/${r.id}` }, `#${r.id}${r.baseline ? ' (baseline)' : ''}`) },
    { label: axis === 'date' ? 'Date (UTC)' : axis, value: (r) => xLabel(r, axis) },
    { label: 'Labels', value: (r) => fmt.labels(r.labels) || '–' },
    { label: 'Lights', className: 'num', value: (r) => String(r.lights) },
    { label: 'Frame time (median)', className: 'num', value: (r) => fmt.ms(r.frame_ms.median) },
    { label: '95% interval', className: 'num', value: (r) => (r.frame_ms.lower === null ? '–' : `${fmt.ms(r.frame_ms.lower)} – ${fmt.ms(r.frame_ms.upper)}`) },
    { label: 'Bytes / frame', className: 'num', value: (r) => fmt.bytes(r.mean_bytes) },
    { label: 'Alerts', value: (r) => (r.alerts.length ? r.alerts.map((id) => h('a', { href: `#/alerts/${id}`, title: alertsById.get(id)?.metric }, `#${id} `)) : '–') },
  ], runs, { 'aria-label': 'Runs of the configuration', dataset: { trendTable: '' } });
}

// One chart: the series, the baseline's value as a dashed line, the alerts' runs marked.
function trendChart(parent, { id, title, runs, axis, y, yFormat, alertKinds, alertsById, interval }) {
  const points = runs.map((r, i) => ({ x: i, y: y(r), run: r.id })).filter((p) => p.y !== null && p.y !== undefined);
  const baselineRun = runs.find((r) => r.baseline);
  const datasets = [{ label: title, data: points, showLine: true, borderWidth: 2 }];
  if (interval) {
    const lows = runs.map((r, i) => ({ x: i, y: r.frame_ms.lower })).filter((p) => p.y !== null);
    const highs = runs.map((r, i) => ({ x: i, y: r.frame_ms.upper })).filter((p) => p.y !== null);
    datasets.push({ label: '95% interval (low)', data: lows, showLine: true, borderDash: [2, 3], pointRadius: 0, borderWidth: 1, borderColor: '#999', backgroundColor: '#999' });
    datasets.push({ label: '95% interval (high)', data: highs, showLine: true, borderDash: [2, 3], pointRadius: 0, borderWidth: 1, borderColor: '#999', backgroundColor: '#999' });
  }
  if (baselineRun && y(baselineRun) !== null && y(baselineRun) !== undefined) {
    const v = y(baselineRun);
    datasets.push({ label: `baseline (run #${baselineRun.id})`, baseline: true, threshold: true, data: [{ x: 0, y: v }, { x: Math.max(0, runs.length - 1), y: v }],
      borderColor: kBaselineColor, backgroundColor: kBaselineColor, pointRadius: 0, showLine: false });
  }
  const alerted = runs.map((r, i) => ({ r, i })).filter(({ r }) => r.alerts.some((a) => alertKinds.includes(alertsById.get(a)?.kind)));
  datasets.push({ label: 'alerts', alerts: true, data: alerted.map(({ r, i }) => ({ x: i, y: y(r), run: r.id, alerts: r.alerts })),
    pointStyle: 'triangle', pointRadius: 9, borderColor: kAlertColor, backgroundColor: kAlertColor, showLine: false });
  return xyChart(parent, {
    id, title, caption: `over ${axis === 'date' ? 'dates' : `label ${axis}`}, oldest first`,
    datasets,
    x: { title: axis === 'date' ? 'date (UTC)' : axis, format: (v) => (Number.isInteger(v) && runs[v] ? xLabel(runs[v], axis) : ''), type: 'linear' },
    y: { title, format: yFormat },
    tooltip: (c) => `${c.dataset.label}: ${yFormat(c.raw.y)}${c.raw.run ? ` (run #${c.raw.run})` : ''}`,
    table: h('p', { class: 'muted' }, 'The figures are in the table below.'),
  });
}

export async function render(page, { params, query, signal }) {
  const trend = await get(`/trend?baseline=${encodeURIComponent(params.id)}`, signal);
  const { baseline, runs, alerts } = trend;
  const alertsById = new Map(alerts.map((a) => [a.id, a]));
  const labelKeys = [...new Set(runs.flatMap((r) => Object.keys(r.labels)))].sort();
  let axis = query.get('x') || (labelKeys.includes('commit') ? 'commit' : labelKeys[0] || 'date');
  const c = baseline.configuration;
  const axisSelect = h('select', { name: 'x', 'aria-label': 'X axis' },
    [...labelKeys.map((k) => h('option', { value: k, selected: k === axis }, `label ${k}`)), h('option', { value: 'date', selected: axis === 'date' }, 'date')]);
  const charts = h('div', { class: 'charts' });
  const tableBox = h('div');

  function draw() {
    destroyCharts(charts);
    charts.replaceChildren();
    trendChart(charts, { id: 'trend-frame', title: 'Frame time', runs, axis, y: (r) => r.frame_ms.median, yFormat: fmt.ms, alertKinds: ['time'], alertsById, interval: true });
    trendChart(charts, { id: 'trend-bytes', title: 'Bytes per frame', runs, axis, y: (r) => r.mean_bytes, yFormat: fmt.bytes, alertKinds: ['counts'], alertsById });
    tableBox.replaceChildren(dataTable(runs, axis, alertsById));
  }
  axisSelect.addEventListener('change', () => { axis = axisSelect.value; draw(); });

  page.append(
    h('h1', {}, `Trend of baseline #${baseline.id}${baseline.name ? ` (${baseline.name})` : ''}`),
    h('ul', { class: 'meta' },
      h('li', {}, `${c.variant} · ${c.scene} · ${c.width}×${c.height} · ${c.device} · counting ${c.counting}`),
      h('li', {}, 'baseline run ', h('a', { href: `#/runs/${baseline.run}` }, `#${baseline.run}`)),
      h('li', {}, `threshold ${fmt.percent(baseline.threshold)}`),
      h('li', {}, `status ${baseline.status}`),
      h('li', { dataset: { alertCount: String(alerts.length) } }, h('a', { href: `#/alerts?status=all` }, `${alerts.length} alert${alerts.length === 1 ? '' : 's'}`))),
    h('label', {}, 'X axis ', axisSelect),
    charts, tableBox);
  draw();
}

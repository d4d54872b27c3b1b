// Trend (#/trend/ID): every run of a baseline's configuration in order (GET
// /api/trend?baseline=ID), charted against a label of the runs (commit,
// branch, ...) or their dates: the frame time's median with its 95%
// interval, and the bytes per frame, with the baseline run's value drawn
// across as a dashed line and the runs that raised alerts marked.
import { get } from '../api.js';
import { destroyCharts, xyChart } from '../charts.js';
import { h, table } from '../dom.js';
import * as fmt from '../format.js';
import { kBetter, kPalette, kSame, kWorse } from '../palette.js';
import { alertClass } from './alerts.js';

const kBaselineColor = '#555';

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

// A shaded band between two edges (each [{x, y}]): the low edge has no legend
// entry, the high one fills down to it and names the band.
function band(label, lows, highs, fillColor, kind) {
  return [
    { label: `${label} (low)`, legend: false, band: kind, edge: 'low', data: lows, showLine: true, pointRadius: 0, borderWidth: 0, borderColor: 'rgba(0,0,0,0)', backgroundColor: fillColor },
    { label, band: kind, edge: 'high', data: highs, showLine: true, pointRadius: 0, borderWidth: 0, borderColor: 'rgba(0,0,0,0)', backgroundColor: fillColor, fill: '-1' },
  ];
}

// One chart: the series with its interval as a shaded band, the baseline's
// value as a dashed line inside its ± threshold band (time only: counts are
// exact), and the alerts' runs marked, regressions red and improvements green.
function trendChart(parent, { id, title, runs, axis, y, yFormat, alertKinds, alertsById, interval, threshold }) {
  const points = runs.map((r, i) => ({ x: i, y: y(r), run: r.id })).filter((p) => p.y !== null && p.y !== undefined);
  const baselineRun = runs.find((r) => r.baseline);
  const datasets = [{ label: title, data: points, showLine: true, borderWidth: 2 }];
  if (interval) {
    const lows = runs.map((r, i) => ({ x: i, y: r.frame_ms.lower })).filter((p) => p.y !== null);
    const highs = runs.map((r, i) => ({ x: i, y: r.frame_ms.upper })).filter((p) => p.y !== null);
    datasets.push(...band('95% interval', lows, highs, kPalette.band, 'interval'));
  }
  if (baselineRun && y(baselineRun) !== null && y(baselineRun) !== undefined) {
    const v = y(baselineRun);
    const ends = [0, Math.max(0, runs.length - 1)];
    if (threshold) {
      datasets.push(...band(`baseline ± ${fmt.percent(threshold)} threshold`, ends.map((x) => ({ x, y: v * (1 - threshold) })),
        ends.map((x) => ({ x, y: v * (1 + threshold) })), kPalette.threshold_band, 'threshold'));
    }
    datasets.push({ label: `baseline (run #${baselineRun.id})`, baseline: true, threshold: true, data: ends.map((x) => ({ x, y: v })),
      borderColor: kBaselineColor, backgroundColor: kBaselineColor, pointRadius: 0, showLine: false });
  }
  const alerted = runs.map((r, i) => ({ r, i })).filter(({ r }) => r.alerts.some((a) => alertKinds.includes(alertsById.get(a)?.kind)));
  // A run's mark is red if any of its alerts of this chart is a regression, green if all are improvements.
  const change = (r) => {
    const classes = r.alerts.map((a) => alertsById.get(a)).filter((a) => a && alertKinds.includes(a.kind)).map(alertClass);
    return classes.includes('worse') ? 'worse' : classes.every((c) => c === 'better') ? 'better' : 'same';
  };
  const markColor = { worse: kWorse, better: kBetter, same: kSame };
  const marks = alerted.map(({ r, i }) => ({ x: i, y: y(r), run: r.id, alerts: r.alerts, change: change(r) }));
  datasets.push({ label: 'alerts (red: regression, green: improvement)', alerts: true, data: marks,
    pointStyle: 'triangle', pointRadius: 9, borderColor: marks.map((m) => markColor[m.change]), backgroundColor: marks.map((m) => markColor[m.change]),
    pointBackgroundColor: marks.map((m) => markColor[m.change]), pointBorderColor: marks.map((m) => markColor[m.change]), showLine: false });
  return xyChart(parent, {
    id, title, caption: `over ${axis === 'date' ? 'dates' : `label ${axis}`}, oldest first${interval ? '; shaded: the 95 % interval of the median' : ''}${threshold ? '; grey band: the baseline ± its threshold' : ''}`,
    datasets,
    x: { title: axis === 'date' ? 'date (UTC)' : axis, format: (v) => (Number.isInteger(v) && runs[v] ? xLabel(runs[v], axis) : ''), type: 'linear' },
    y: { title: `${title} (${yFormat === fmt.ms ? 'ms' : 'bytes'})`, format: yFormat },
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
    trendChart(charts, { id: 'trend-frame', title: 'Frame time (median)', runs, axis, y: (r) => r.frame_ms.median, yFormat: fmt.ms, alertKinds: ['time'], alertsById, interval: true, threshold: baseline.threshold });
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

// One stability sweep (#/sweeps/ID): what was swept on which device against
// which threshold, where the method fails (the result's fails_at, group by
// group, in words), one line chart per entry of the result's "plots" and the
// points themselves. Everything is drawn from GET /api/sweeps/{id}, whatever
// the sweep: the charts follow the plots' dotted paths into the points, a
// line per distinct combination of the plot's series fields, the threshold as
// a dashed horizontal line.
import { get } from '../api.js';
import { xyChart } from '../charts.js';
import { h, table } from '../dom.js';
import * as fmt from '../format.js';

// A point's value at a dotted path ("error.max_relative"); undefined when absent.
export function valueAt(point, path) {
  return path.split('.').reduce((v, key) => (v !== null && typeof v === 'object' && key in v ? v[key] : undefined), point);
}

// Short text for a sweep value: four significant digits, large values
// grouped ("300", "0.01", "2,000,000"), an exponent only below 1e-3, where
// zeros would hide the digits ("6.525e−5"); one minus sign; names as they are.
export function num(v) {
  if (v === null || v === undefined) return '–';
  if (typeof v !== 'number') return String(v);
  const a = Math.abs(v);
  if (v === 0 || a >= 1e-3) return fmt.number(v, 4);
  return v.toExponential(3).replace(/\.?0+e/, 'e').replace(/-/g, '−');
}

// The rows of fails_at: {swept, group: [[field, value]...], value (null: holds)}.
// fails_at is {parameter: [groups] | null} or one [groups] list; in a list the
// swept parameter is the last of `parameters` that every group carries as a
// number or null (as the tally client reads it).
export function failsAtRows(failsAt, parameters) {
  const rows = [];
  const add = (swept, groups) => {
    if (!Array.isArray(groups)) {
      rows.push({ swept, group: [], value: groups === null || groups === undefined ? null : groups });
      return;
    }
    for (const g of groups) {
      if (g === null || typeof g !== 'object') {
        rows.push({ swept, group: [], value: g });
        continue;
      }
      rows.push({ swept, group: Object.entries(g).filter(([k]) => k !== swept), value: g[swept] ?? null });
    }
  };
  if (Array.isArray(failsAt)) {
    const numeric = (p) => failsAt.length > 0 && failsAt.every((g) => g && typeof g === 'object' && p in g && (g[p] === null || typeof g[p] === 'number'));
    const swept = [...parameters].reverse().find(numeric) || '';
    add(swept, failsAt);
  } else if (failsAt && typeof failsAt === 'object') {
    for (const [swept, groups] of Object.entries(failsAt)) add(swept, groups);
  }
  return rows;
}

// In a few words, for the list: per swept parameter, how many groups fail.
export function failsAtSummary(sweep) {
  if (sweep.fails_at === null) return 'holds over the range';
  const counts = new Map();
  for (const row of failsAtRows(sweep.fails_at, sweep.parameters)) {
    const c = counts.get(row.swept) || { fail: 0, all: 0 };
    c.fail += row.value === null ? 0 : 1;
    c.all += 1;
    counts.set(row.swept, c);
  }
  return [...counts].map(([swept, c]) => `${swept || 'groups'}: ${c.fail} of ${c.all} fail`).join('; ');
}

// {"relative": 0.001} -> "relative 0.001".
export const thresholdText = (threshold) => Object.entries(threshold || {}).map(([k, v]) => `${k} ${num(v)}`).join(', ') || '–';

const groupText = (group) => (group.length ? group.map(([k, v]) => `${k} ${num(v)}`).join(', ') : 'all points');

function failsAtTable(sweep) {
  if (sweep.fails_at === null) {
    return h('p', { class: 'panel', dataset: { failsAt: 'none' } },
      `Holds over the whole range: no point reaches the threshold (${thresholdText(sweep.threshold)}).`);
  }
  const rows = failsAtRows(sweep.fails_at, sweep.parameters);
  return table([
    { label: 'Swept', value: (r) => r.swept || '–' },
    { label: 'Held fixed', value: (r) => groupText(r.group) },
    { label: 'Where it fails', value: (r) => h('span', { dataset: { value: r.value === null ? '' : String(r.value) } },
      r.value === null ? 'holds over the range' : `fails at ${r.swept} ${num(r.value)}`) },
  ], rows, { 'aria-label': 'Where it fails', dataset: { table: 'fails-at' } });
}

// The lines of one plot: a dataset per distinct combination of its series
// fields (first-seen order), points sorted by x. On a log axis a value <= 0
// cannot be drawn: it is left out of the line (y null) and shown in the table.
export function plotLines(points, plot) {
  const lines = new Map();
  for (const point of points) {
    const values = plot.series.map((f) => valueAt(point, f));
    const key = JSON.stringify(values);
    if (!lines.has(key)) {
      lines.set(key, { label: plot.series.length ? plot.series.map((f, i) => `${f} ${num(values[i])}`).join(' · ') : 'all points', data: [] });
    }
    const y = valueAt(point, plot.y);
    lines.get(key).data.push({ x: valueAt(point, plot.x), y: plot.y_log && !(y > 0) ? null : y, raw: y });
  }
  const out = [...lines.values()];
  for (const line of out) line.data.sort((a, b) => a.x - b.x);
  return out;
}

function plotTable(id, plot, lines) {
  return h('div', { class: 'table-wrap' },
    h('table', { dataset: { chartTable: id } },
      h('thead', {}, h('tr', {}, ['Line', plot.x, plot.y].map((t) => h('th', { scope: 'col' }, t)))),
      h('tbody', {}, lines.flatMap((line) => line.data.map((p) => h('tr', {},
        h('th', { scope: 'row' }, line.label),
        h('td', { class: 'num', dataset: { value: String(p.x) } }, num(p.x)),
        h('td', { class: 'num', dataset: { value: String(p.raw) } }, num(p.raw) + (p.y === null && p.raw !== null && p.raw !== undefined ? ' (not drawn on a log axis)' : ''))))))));
}

// A log axis labels its decades only (1-9 ticks per decade would crowd it).
const tickFormat = (log) => (v) => (!log || Math.abs(Math.log10(v) - Math.round(Math.log10(v))) < 1e-9 ? num(v) : '');

function plotChart(parent, plot, index, points) {
  const id = `sweep-plot-${index}`;
  const lines = plotLines(points, plot);
  const xs = lines.flatMap((l) => l.data.map((p) => p.x));
  const datasets = lines.map((l) => ({ label: l.label, data: l.data.map(({ x, y }) => ({ x, y })), showLine: true }));
  if (plot.threshold !== null && xs.length) {
    // Its two points span the x range (and keep the value inside the y
    // axis); charts.js draws it dashed across the whole plot.
    datasets.push({
      label: `threshold ${num(plot.threshold)}`,
      data: [{ x: Math.min(...xs), y: plot.threshold }, { x: Math.max(...xs), y: plot.threshold }],
      showLine: false,
      borderDash: [6, 4],
      borderColor: '#a61b1b',
      backgroundColor: '#a61b1b',
      pointRadius: 0,
      threshold: true,
    });
  }
  xyChart(parent, {
    id,
    title: plot.title,
    caption: `${plot.y} against ${plot.x}${plot.series.length ? `, a line per ${plot.series.join(' × ')}` : ''}`,
    datasets,
    x: { title: plot.x, format: tickFormat(plot.x_log), type: plot.x_log ? 'logarithmic' : 'linear' },
    y: { title: plot.y_label, format: tickFormat(plot.y_log), type: plot.y_log ? 'logarithmic' : 'linear' },
    table: plotTable(id, plot, lines),
    tooltip: (c) => `${c.dataset.label}: ${plot.x} ${num(c.raw.x)}, ${num(c.raw.y)}`,
  });
}

// Every leaf of the points, as dotted paths in first-seen order: the columns
// of the points table.
function leafPaths(points) {
  const paths = [];
  const walk = (v, prefix) => {
    for (const [k, child] of Object.entries(v)) {
      const path = prefix ? `${prefix}.${k}` : k;
      if (child !== null && typeof child === 'object' && !Array.isArray(child)) walk(child, path);
      else if (!paths.includes(path)) paths.push(path);
    }
  };
  for (const p of points) walk(p, '');
  return paths;
}

function pointsTable(result) {
  const paths = leafPaths(result.points);
  // The parameters first, in the result's order.
  const columns = [...result.parameters.filter((p) => paths.includes(p)), ...paths.filter((p) => !result.parameters.includes(p))];
  return table(columns.map((path) => ({
    label: path,
    className: 'num',
    value: (point) => {
      const v = valueAt(point, path);
      return h('span', { dataset: { value: JSON.stringify(v ?? null) } }, Array.isArray(v) ? JSON.stringify(v) : num(v));
    },
  })), result.points, { 'aria-label': 'Points', dataset: { table: 'points' } });
}

export async function render(page, { params, signal }) {
  const sweep = await get(`/sweeps/${encodeURIComponent(params.id)}`, signal);
  const result = sweep.result;
  page.append(
    h('h1', {}, `Sweep #${sweep.id}: ${sweep.name}`),
    h('ul', { class: 'meta' },
      h('li', {}, sweep.device.name),
      h('li', {}, `${fmt.date(sweep.created_at)} UTC`),
      h('li', {}, `${sweep.point_count} points over ${sweep.parameters.join(' × ')}`),
      h('li', {}, h('a', { href: `#/sweeps?capture=${sweep.job_id}` }, `capture #${sweep.job_id}`)),
      h('li', {}, h('a', { href: `#/sweeps?name=${encodeURIComponent(sweep.name)}` }, `other ${sweep.name} sweeps`))),
    h('div', { class: 'tiles' },
      Object.entries(sweep.threshold).map(([key, value]) => h('div', { class: 'tile', dataset: { tile: `threshold-${key}`, value: String(value) } },
        h('div', { class: 'label' }, `Threshold (${key})`), h('div', { class: 'value' }, num(value))))));

  page.append(h('h2', {}, 'Where it fails'), failsAtTable(sweep));

  page.append(h('h2', {}, 'Charts'));
  const charts = h('div', { class: 'charts' });
  page.append(charts);
  result.plots.forEach((plot, i) => plotChart(charts, plot, i, result.points));
  if (!result.plots.length) charts.append(h('p', { class: 'muted' }, 'This sweep states no plots.'));

  page.append(h('h2', {}, 'Points'), pointsTable(result));
  page.append(h('details', {}, h('summary', {}, h('h2', { class: 'inline' }, 'Spec')), h('pre', { class: 'spec' }, JSON.stringify(result.spec, null, 2))));
}

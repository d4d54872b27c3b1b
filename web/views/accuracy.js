// Speed against accuracy (#/accuracy?error=counting|image&metric=l1|total|worst&cost=frame|overhead):
// one point per run, with the Pareto front (no other point is both cheaper and
// more accurate) drawn over them.
//   counting error: from /api/accuracy, which compares every run counted with
//     "subgroup" or "sampled:N" with the exact run of the same frames
//     (docs/accuracy.md): the L1 error over pass x resource x access lines
//     (errors cannot cancel), the error of the total bytes, or the worst
//     line's error. The exact runs measured against are drawn at error 0.
//     Cost: the counted frame's time, or the overhead ratio of counting.
//   image error: a run's mean PSNR against forward over its cameras (higher
//     is better, so that axis runs right to left). Cost: the uninstrumented
//     frame time, or the overhead ratio.
// Needs the run rows (/api/runs, up to 10 pages of 1000) and, for counting
// error, the accuracy rows; no samples.
import { get, getAll, queryString } from '../api.js';
import { xyChart } from '../charts.js';
import { h } from '../dom.js';
import * as fmt from '../format.js';

const kCosts = {
  frame: { label: 'frame time', format: fmt.ms, counting: (r) => r.mean_frame_ms_instrumented, image: (r) => r.mean_frame_ms },
  overhead: { label: 'overhead ratio of counting', format: (v) => fmt.ratio(v), counting: (r) => r.mean_overhead_ratio, image: (r) => r.mean_overhead_ratio },
};

// Counting-error measures of an /api/accuracy row.
const kMetrics = {
  l1: { label: 'L1 error over resources', field: 'l1_error' },
  total: { label: 'error of the total bytes', field: 'total_error' },
  worst: { label: 'worst resource error', field: 'worst_error' },
};

// One point per accuracy row with a reference, and one per exact reference
// (error 0). Overhead ratios come from the rows (medians over samples); frame
// times from the run rows.
// A counting mode with footprint counting on is a point of its own (it costs
// more): "accumulate + footprint 64".
const withFootprint = (label, blockBytes) => (blockBytes ? `${label} + footprint ${blockBytes}` : label);

function countingPoints(rows, runs, metric, costName) {
  const byId = new Map(runs.map((r) => [r.id, r]));
  const runOf = (id, row, counting) => byId.get(id) || { id, renderer: row.renderer, variant: row.variant, options: row.options, scene: row.scene, width: row.width, height: row.height, counting };
  const frameCost = (id) => byId.get(id)?.mean_frame_ms_instrumented ?? null;
  const points = [];
  const references = new Map();  // exact run id -> point
  for (const row of rows) {
    if (row.reference === null) continue;
    const cost = costName === 'overhead' ? row.overhead_ratio : frameCost(row.run);
    if (cost !== null) points.push({ run: runOf(row.run, row, row.counting), group: withFootprint(row.counting, row.footprint_block_bytes), error: row[metric.field], worst: row.worst_resource, cost });
    const refCost = costName === 'overhead' ? row.reference_overhead_ratio : frameCost(row.reference);
    if (!references.has(row.reference) && refCost !== null) {
      references.set(row.reference, { run: runOf(row.reference, row, 'exact'), group: withFootprint('exact', byId.get(row.reference)?.footprint_block_bytes), error: 0, worst: null, cost: refCost });
    }
  }
  return [...points, ...references.values()];
}

// Image error (mean PSNR) of every run compared against forward; runs whose
// every image is identical are drawn at `identicalAt` dB.
function imagePoints(runs, cost) {
  const compared = runs.filter((r) => r.image_error && cost(r) !== null);
  const finite = compared.map((r) => r.image_error.mean_psnr).filter((v) => v !== null);
  const identicalAt = Math.ceil((finite.length ? Math.max(...finite) : 50) + 10);
  const points = compared.map((r) => {
    const identical = r.image_error.mean_psnr === null;
    return { run: r, group: withFootprint(fmt.variant(r), r.footprint_block_bytes), error: identical ? identicalAt : r.image_error.mean_psnr, identical, cost: cost(r) };
  });
  return { points, identicalAt };
}

// Points no other point beats on both axes. better(a, b): a's error is lower
// (or PSNR higher); ties in error keep the cheaper point only.
function paretoFront(points, lowerErrorIsBetter) {
  const sign = lowerErrorIsBetter ? 1 : -1;
  const sorted = [...points].sort((a, b) => sign * (a.error - b.error) || a.cost - b.cost);
  const front = [];
  for (const p of sorted) {
    if (front.length === 0 || p.cost < front[front.length - 1].cost) front.push(p);
  }
  return new Set(front);
}

function controls(query, onApply) {
  const field = (label, control) => h('label', { class: 'field' }, h('span', {}, label), control);
  const select = (name, options) => h('select', { name }, options.map(([value, text]) => h('option', { value, selected: (query.get(name) || options[0][0]) === value }, text)));
  const text = (name, placeholder) => h('input', { name, value: query.get(name) || '', placeholder, size: 12 });
  const form = h('form', { class: 'filters', 'aria-label': 'Speed against accuracy' },
    field('Error', select('error', [['counting', 'counting error of a mode'], ['image', 'image error against forward']])),
    field('Counting error', select('metric', [['l1', 'L1 over resources'], ['total', 'total bytes'], ['worst', 'worst resource']])),
    field('Cost', select('cost', [['frame', 'frame time'], ['overhead', 'overhead ratio']])),
    field('Renderer', text('renderer', 'any')),
    field('Scene', text('scene', 'any')),
    field('Resolution', h('input', { name: 'resolution', value: query.get('resolution') || '', placeholder: 'e.g. 320x180', pattern: '\\s*\\d+\\s*[x×]\\s*\\d+\\s*', size: 10 })),
    h('div', { class: 'field buttons' }, h('button', { type: 'submit' }, 'Apply')));
  form.addEventListener('submit', (e) => {
    e.preventDefault();
    if (form.reportValidity()) onApply(Object.fromEntries([...new FormData(form)].map(([k, v]) => [k, v.trim()])));
  });
  form.addEventListener('change', (e) => { if (e.target.tagName === 'SELECT') form.requestSubmit(); });
  return form;
}

function pointTable(points, front, errorLabel, errorText, costFormat) {
  return h('div', { class: 'table-wrap' }, h('table', { 'aria-label': 'Points', dataset: { chartTable: 'accuracy' } },
    h('thead', {}, h('tr', {}, ['Run', 'Renderer', 'Scene', 'Resolution', 'Counting', errorLabel, 'Cost', 'Pareto front'].map((t) => h('th', { scope: 'col' }, t)))),
    h('tbody', {}, points.map((p) => h('tr', { dataset: { run: p.run.id, error: p.identical ? 'identical' : p.error, cost: p.cost, front: front.has(p) } },
      h('td', {}, h('a', { href: `#/runs/${p.run.id}` }, `#${p.run.id}`)),
      h('td', {}, fmt.variant(p.run)), h('td', {}, p.run.scene), h('td', {}, fmt.resolution(p.run)), h('td', {}, withFootprint(p.run.counting, p.run.footprint_block_bytes)),
      h('td', { class: 'num' }, errorText(p)), h('td', { class: 'num' }, costFormat(p.cost)),
      h('td', {}, front.has(p) ? 'yes' : ''))))));
}

export async function render(page, { query, signal }) {
  const errorKind = query.get('error') === 'image' ? 'image' : 'counting';
  const costName = kCosts[query.get('cost')] ? query.get('cost') : 'frame';
  const cost = kCosts[costName];
  const metric = kMetrics[query.get('metric')] || kMetrics.l1;
  const res = /^(\d+)\s*[x×]\s*(\d+)$/.exec(query.get('resolution') || '');
  const filters = { renderer: query.get('renderer'), scene: query.get('scene'), width: res?.[1], height: res?.[2] };
  page.append(h('h1', {}, 'Speed against accuracy'),
    controls(query, (values) => { location.hash = '#/accuracy' + queryString(values); }));

  const { items: runs, complete } = await getAll('/runs' + queryString(filters), 'runs', { signal });
  let unreferenced = 0;
  let points;
  let x;
  let errorText;
  let caption;
  if (errorKind === 'counting') {
    const accuracy = await get('/accuracy' + queryString(filters), signal);
    unreferenced = accuracy.rows.filter((r) => r.reference === null).length;
    points = countingPoints(accuracy.rows, runs, metric, costName);
    x = { title: `counting error: ${metric.label} (vs exact)`, format: (v) => fmt.percent(v) };
    errorText = (p) => fmt.percent(p.error) + (metric.field === 'worst_error' && p.worst ? ` (${p.worst})` : '');
    caption = 'each counting mode against the exact run of the same frames (renderer, scene, resolution, device, lights, cameras); exact runs at 0';
  } else {
    const image = imagePoints(runs, cost.image);
    points = image.points;
    x = { title: 'mean PSNR against forward (dB; better to the left)', format: (v) => fmt.psnr(v), reverse: true };
    errorText = (p) => (p.identical ? 'identical' : fmt.psnr(p.error));
    caption = `one point per run; runs whose images are all identical to forward's are drawn at ${image.identicalAt} dB`;
  }
  const front = paretoFront(points, errorKind === 'counting');
  if (!complete) page.append(h('p', { class: 'panel' }, 'Only the newest 10,000 runs are shown: narrow the filters.'));
  if (unreferenced > 0) page.append(h('p', { class: 'muted', dataset: { unreferenced } }, `${unreferenced} run(s) in another mode have no exact run of the same frames and are not drawn.`));
  if (points.length === 0) {
    page.append(h('p', { class: 'panel' }, errorKind === 'counting'
      ? 'No run here was captured with a counting mode other than exact next to an exact run. Capture the same configuration with "counting": "subgroup" or "sampled:N".'
      : 'No run here has an image error (they are compared against forward captured alongside).'));
    return;
  }
  const groups = [...new Set(points.map((p) => p.group))];
  const frontLine = [...front].sort((a, b) => a.error - b.error);
  const datasets = [
    { label: 'Pareto front', data: frontLine.map((p) => ({ x: p.error, y: p.cost, run: p.run.id })), showLine: true, borderColor: '#111', backgroundColor: 'rgba(0,0,0,0)', pointRadius: 8, pointBorderWidth: 2, borderWidth: 1.5, order: 0 },
    ...groups.map((g) => ({ label: g, data: points.filter((p) => p.group === g).map((p) => ({ x: p.error, y: p.cost, run: p.run.id })), order: 1 })),
  ];
  const table = pointTable(points, front, errorKind === 'counting' ? `Counting error (${metric.label})` : 'PSNR vs forward', errorText, cost.format);
  xyChart(page, {
    id: 'accuracy', title: `${cost.label} against ${errorKind === 'counting' ? 'counting error' : 'image error'}`, caption,
    x, y: { title: cost.label, format: cost.format }, datasets, table,
    tooltip: (c) => `run #${c.raw.run} (${c.dataset.label}): ${x.format(c.raw.x)}, ${cost.format(c.raw.y)}`,
  });
  page.querySelector('[data-chart="accuracy"] .chart-box').classList.add('tall');
  page.append(h('p', { class: 'muted' }, `${points.length} points from ${runs.length} runs; ${front.size} on the Pareto front (outlined).`));
}

// Compare's "Scaling with resolution": how bytes and frame time grow with the
// pixel count for each compared run's variant (the newest run of each
// resolution on the same scene and device), with the fitted lines and
// crossings of the first run's capture (GET /api/crossover) dashed over them,
// and tables of the fits and crossings. With one resolution per variant the
// charts are left out, and the view says why.
import { get, queryString } from '../api.js';
import { xyChart } from '../charts.js';
import { h } from '../dom.js';
import * as fmt from '../format.js';

// For each compared run's variant: the newest run at every resolution with
// the same scene, device, counting mode and light count. Variants of one
// renderer are series of their own.
async function scalingSeries(runs, signal) {
  const byKey = new Map();  // one series per variant, counting mode, scene, device, lights
  for (const run of runs) {
    const key = `${fmt.variant(run)}|${run.scene}|${JSON.stringify(run.scene_params)}|${run.device_id}|${run.counting}|${run.lights}|${run.footprint_block_bytes ?? ''}`;
    if (!byKey.has(key)) byKey.set(key, run);
  }
  return Promise.all([...byKey.values()].map(async (run) => {
    const filter = run.variant ? { variant: run.variant } : { renderer: run.renderer };
    const { runs: found } = await get('/runs' + queryString({ ...filter, scene: run.scene, device: run.device_id, limit: 1000 }), signal);
    const newest = new Map();  // "WxH" -> run; the list is newest first
    for (const r of found) {
      if (r.counting !== run.counting || r.lights !== run.lights || JSON.stringify(r.scene_params) !== JSON.stringify(run.scene_params)) continue;
      if ((r.footprint_block_bytes ?? null) !== (run.footprint_block_bytes ?? null)) continue;  // footprint runs are a series of their own
      if (!newest.has(fmt.resolution(r))) newest.set(fmt.resolution(r), r);
    }
    const points = [...newest.values()].sort((a, b) => a.width * a.height - b.width * b.height);
    const footprint = run.footprint_block_bytes ? ` + footprint ${run.footprint_block_bytes}` : '';
    return { label: `${fmt.variant(run)}${run.counting !== 'exact' || footprint ? ` (${run.counting}${footprint})` : ''}`, variant: fmt.variant(run), points };
  }));
}

// Fits against pixel count and crossings (GET /api/crossover) over the
// capture of the first compared run, on its scene and device, for both
// metrics; a metric's answer is null when the server gives none.
async function crossovers(run, signal) {
  const fetchOne = (metric) => get('/crossover' + queryString({ capture: run.capture, metric, scene: run.scene, device: run.device_id }), signal)
    .catch((error) => {
      if (signal.aborted) throw error;
      return null;
    });
  const [bytes, frameMs] = await Promise.all([fetchOne('bytes'), fetchOne('frame_ms')]);
  return { bytes, frame_ms: frameMs };
}

// The crossover series that belong to the compared runs' configuration
// (counting mode, lights, footprint block of the first run): those with a fit.
function fittedSeries(answer, run) {
  if (!answer) return [];
  return answer.series.filter((s) => s.fit && s.counting === run.counting && s.lights === run.lights
    && (s.footprint_block_bytes ?? null) === (run.footprint_block_bytes ?? null));
}

// One dashed line per fit across the pixel range of all fits, coloured as its
// renderer's points; crossings inside the range as marks with their interval.
function fitOverlay(answer, run) {
  const fits = fittedSeries(answer, run);
  if (!fits.length) return { datasets: [], marks: [] };
  const low = Math.min(...fits.map((s) => s.fit.min_pixels)), high = Math.max(...fits.map((s) => s.fit.max_pixels));
  const datasets = fits.map((s) => {
    const { a, b } = s.fit;
    return { label: `${s.variant} fit`, colorKey: s.variant, showLine: true, pointRadius: 0, borderWidth: 2, borderDash: [6, 4], fit: { variant: s.variant, a, b, r2: s.fit.r2, poor: s.fit.poor_fit },
      data: [{ x: low, y: a + b * low }, { x: high, y: a + b * high }] };
  });
  const names = new Set(fits.map((s) => s.variant));
  const marks = answer.crossings.filter((c) => c.kind === 'crosses' && names.has(c.first) && names.has(c.second))
    .map((c) => ({ x: c.pixels, low: c.pixels_ci?.[0] ?? null, high: c.pixels_ci?.[1] ?? null,
      label: c.resolution ? `${c.resolution.width}×${c.resolution.height}` : fmt.count(c.pixels), first: c.first, second: c.second }));
  return { datasets, marks };
}

const kCrossingText = {
  crosses: 'crosses',
  outside_range: 'no crossing in range',
  parallel: 'parallel within error',
  no_significant_crossing: 'no significant crossing',
};
const kMetricText = { bytes: 'Bytes', frame_ms: 'Frame time' };
const resolutionText = (r) => (r ? `${r.width}×${r.height}` : '–');

// The fits (with R² and the poor-fit flag) and the crossings of both metrics.
function crossoverTables(answers, run) {
  const fitRows = [], crossingRows = [];
  for (const [metric, answer] of Object.entries(answers)) {
    if (!answer) continue;
    const format = metric === 'bytes' ? fmt.bytes : fmt.ms;
    const fits = fittedSeries(answer, run);
    const names = new Set(fits.map((s) => s.variant));
    for (const s of fits) {
      fitRows.push(h('tr', { dataset: { metric, variant: s.variant, r2: s.fit.r2, poor: String(s.fit.poor_fit) } },
        h('td', {}, kMetricText[metric]), h('td', {}, s.variant),
        h('td', { class: 'num', dataset: { value: s.fit.a } }, `${format(s.fit.a)} (${format(s.fit.a_ci[0])} to ${format(s.fit.a_ci[1])})`),
        h('td', { class: 'num', dataset: { value: s.fit.b } }, `${format(s.fit.b * 1e6)}/Mpx (${format(s.fit.b_ci[0] * 1e6)} to ${format(s.fit.b_ci[1] * 1e6)})`),
        h('td', { class: `num ${s.fit.poor_fit ? 'worse' : ''}` }, `${fmt.fixed(s.fit.r2, 4)}${s.fit.poor_fit ? ' poor fit' : ''}`)));
    }
    for (const c of answer.crossings.filter((x) => names.has(x.first) && names.has(x.second))) {
      const interval = c.pixels_ci ? `${fmt.count(c.pixels_ci[0])} to ${fmt.count(c.pixels_ci[1])}` : '–';
      const resolutions = c.resolution_ci ? `${resolutionText(c.resolution_ci[0])} to ${resolutionText(c.resolution_ci[1])}` : '';
      const lower = c.kind === 'crosses' ? `${c.lower_below} below, ${c.lower_above} above` : `${c.lower_throughout} throughout`;
      crossingRows.push(h('tr', { dataset: { metric, kind: c.kind, first: c.first, second: c.second, pixels: c.pixels ?? '' } },
        h('td', {}, kMetricText[metric]), h('td', {}, `${c.first} / ${c.second}`), h('td', {}, kCrossingText[c.kind] || c.kind),
        h('td', { class: 'num' }, c.kind === 'crosses' ? `${resolutionText(c.resolution)} (${fmt.count(c.pixels)} px)` : '–'),
        h('td', { class: 'num' }, c.kind === 'crosses' ? `${interval} px${resolutions ? ` (${resolutions})` : ''}` : '–'),
        h('td', {}, lower)));
    }
  }
  if (!fitRows.length) {
    return h('p', { class: 'muted', dataset: { crossover: 'none' } },
      `No fitted lines: capture #${run.capture} needs 3 or more resolutions per renderer (docs/measurement.md, "Crossover").`);
  }
  const head = (titles) => h('thead', {}, h('tr', {}, titles.map((t) => h('th', { scope: 'col' }, t))));
  return h('div', { class: 'crossover' },
    h('p', { class: 'muted' }, `Lines: y = a + b × pixels, least squares over capture #${run.capture}; 95 % intervals (t for a and b, delta method for the crossing). R² below 0.9: the line does not describe the points.`),
    h('div', { class: 'table-wrap' }, h('table', { 'aria-label': 'Fits', dataset: { table: 'fits' } },
      head(['Metric', 'Renderer', 'a (fixed)', 'b (per pixel)', 'R²']), h('tbody', {}, fitRows))),
    h('div', { class: 'table-wrap' }, h('table', { 'aria-label': 'Crossings', dataset: { table: 'crossings' } },
      head(['Metric', 'Renderers', 'Result', 'Where (16:9)', '95 % interval', 'Lower']), h('tbody', {}, crossingRows))));
}

export async function scaling(page, c, signal) {
  page.append(h('h2', {}, 'Scaling with resolution'));
  const [series, answers] = await Promise.all([scalingSeries(c.runs, signal), crossovers(c.runs[0], signal)]);
  const rows = series.flatMap((s) => s.points.map((r) => ({ s, r })));
  const table = h('div', { class: 'table-wrap' }, h('table', { 'aria-label': 'Scaling', dataset: { chartTable: 'scaling' } },
    h('thead', {}, h('tr', {}, ['Renderer', 'Resolution', 'Pixels', 'Bytes per frame', 'Frame time', 'Run'].map((t) => h('th', { scope: 'col' }, t)))),
    h('tbody', {}, rows.map(({ s, r }) => h('tr', {},
      h('td', {}, s.label), h('td', {}, fmt.resolution(r)), h('td', { class: 'num' }, fmt.count(r.width * r.height)),
      h('td', { class: 'num', dataset: { value: r.mean_bytes } }, fmt.bytes(r.mean_bytes)),
      h('td', { class: 'num', dataset: { value: r.mean_frame_ms } }, fmt.ms(r.mean_frame_ms)),
      h('td', {}, h('a', { href: `#/runs/${r.id}` }, `#${r.id}`)))))));
  // A series needs two resolutions to show a slope: with fewer, its dots
  // would stand in one column. Such charts are left out, and the view says why.
  const single = series.filter((s) => new Set(s.points.map((r) => r.width * r.height)).size < 2);
  if (single.length === series.length) {
    const at = [...new Set(rows.map(({ r }) => fmt.resolution(r)))].join(', ');
    page.append(h('p', { class: 'panel muted', dataset: { scaling: 'one-resolution' } },
      `Not drawn: ${series.length === 1 ? 'this renderer was' : 'these renderers were'} measured at one resolution only (${at || 'none'}) on this scene and device, `,
      'and a scaling chart needs two or more. Capture the same renderers at more resolutions (three or more also fit lines and find crossings).'), table);
    return;
  }
  const box = h('div', { class: 'charts' });
  page.append(box);
  if (single.length) {
    page.append(h('p', { class: 'muted', dataset: { scaling: 'some-single' } },
      `${single.map((s) => s.label).join(', ')}: measured at one resolution only, drawn as a single point.`));
  }
  const pixels = { title: 'pixels (px)', format: (v) => fmt.count(v) };
  const datasets = (value) => series.map((s) => ({ label: s.label, colorKey: s.variant, showLine: true, data: s.points.map((r) => ({ x: r.width * r.height, y: r[value], run: r.id })) }));
  const bytesFit = fitOverlay(answers.bytes, c.runs[0]), msFit = fitOverlay(answers.frame_ms, c.runs[0]);
  const caption = `per renderer, same scene and device${bytesFit.datasets.length ? '; dashed: fitted lines, vertical: crossings with their interval' : ''}`;
  xyChart(box, { id: 'scaling-bytes', title: 'Bytes per frame against pixel count', caption, x: pixels, y: { title: 'bytes per frame (B)', format: fmt.bytes }, datasets: [...datasets('mean_bytes'), ...bytesFit.datasets], marks: bytesFit.marks, table });
  xyChart(box, { id: 'scaling-frame-ms', title: 'Frame time against pixel count', caption, x: pixels, y: { title: 'frame time (ms)', format: fmt.ms }, datasets: [...datasets('mean_frame_ms'), ...msFit.datasets], marks: msFit.marks, table: table.cloneNode(true) });
  page.append(crossoverTables(answers, c.runs[0]));
}

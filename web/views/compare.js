// Compare 2 to 4 runs (#/compare?runs=a,b,c): totals and per-resource and
// per-pass traffic side by side with deltas and ratios against the first run
// (all from /api/compare), how bytes and frame time scale with the pixel
// count for each run's renderer (views/scaling.js) with the
// fitted lines and crossings of the first run's capture (/api/crossover), the
// spread across repeated captures of each run's configuration (/api/repeats),
// whether each run's times differ from the first's (significance, from
// /api/compare) and an A/B/difference viewer of one camera's screenshots.
import { get, imageSource, queryString } from '../api.js';
import { barChart, destroyCharts } from '../charts.js';
import { h, measureSwitch } from '../dom.js';
import * as fmt from '../format.js';
import { breakdownTable, passNodes } from '../breakdown.js';
import { changeClass, kRead, kWritten, labelColor } from '../palette.js';
import { frameTime, kStatisticText, sampleDetails } from '../stats.js';
import { scaling } from './scaling.js';

// A compared run's dataset fields: its label, and its variant's colour (paler
// for a second run of a variant already shown), whatever the order of selection.
function runSeries(runs, i) {
  const variant = fmt.variant(runs[i]);
  const repeat = runs.slice(0, i).some((r) => fmt.variant(r) === variant);
  return { label: `${variant} #${runs[i].id}`, colorKey: variant, backgroundColor: labelColor(variant, repeat ? 0.5 : 1), borderColor: labelColor(variant) };
}

// "value (Δ delta, ×ratio)" cells for one quantity of every run; the first run is the reference.
// Lower is better (time, bytes) unless higherIsBetter (reuse).
function comparedCells(values, format, higherIsBetter = false) {
  return values.map((c, i) => h('td', { class: 'num', dataset: { value: c.value ?? '', delta: c.delta ?? '', ratio: c.ratio ?? '' } },
    h('div', {}, c.value === null ? '–' : format(c.value)),
    i === 0 || c.value === null ? null : h('div', { class: `muted ${changeClass(c.delta, higherIsBetter)}`, dataset: { change: changeClass(c.delta, higherIsBetter) || 'same' } },
      `${fmt.delta(c.delta, format)} · ${fmt.ratio(c.ratio)}`)));
}

function comparedTable(runs, rows, label) {
  return h('div', { class: 'table-wrap' }, h('table', { 'aria-label': label, dataset: { table: label } },
    h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, ''), runs.map((r, i) => h('th', { scope: 'col', class: 'num' }, `${i === 0 ? 'reference: ' : ''}${fmt.variant(r)} #${r.id}`)))),
    h('tbody', {}, rows.map((row) => h('tr', { dataset: { row: row.key } }, h('th', { scope: 'row' }, row.label), comparedCells(row.values, row.format, row.higherIsBetter))))));
}

// The two byte measures: requested bytes ("bytes") and footprint
// ("footprint_bytes": distinct bytes touched; null for a run without).
const kMeasures = {
  requested: { key: 'bytes', noun: 'Requested bytes' },
  footprint: { key: 'footprint_bytes', noun: 'Footprint' },
};

// Bytes read and written per frame for each run, from the per-resource rows
// (requested bytes, or footprint: null for a run with none).
function byAccess(comparison, access, key = 'bytes') {
  return comparison.runs.map((_, i) => {
    const values = comparison.resources.filter((r) => r.access === access).map((r) => r[key][i].value);
    if (key !== 'bytes' && values.every((v) => v === null)) return null;
    return values.reduce((sum, v) => sum + (v ?? 0), 0);
  });
}

const anyFootprint = (c) => c.total_footprint_bytes.some((v) => v.value !== null);
const reuseText = (v) => `×${v.toFixed(2)}`;


function against(values) {
  return values.map((v) => ({ value: v, delta: v - values[0], ratio: values[0] ? v / values[0] : null }));
}

// Each run's frame time as one statistic: the median of its frames, or the
// mean of its cameras' medians where a run has no per-frame times (then every
// run is shown by the mean, so that the ratio compares like with like).
function frameTimes(c, details) {
  const each = c.runs.map((r, i) => frameTime(r, details[i]));
  const statistic = each.every((t) => t.statistic === 'median') ? 'median' : 'mean';
  const values = statistic === 'median' ? each.map((t) => t.value) : c.runs.map((r) => r.mean_frame_ms);
  return { statistic, values: against(values) };
}

function totals(page, c, bytesBox, details) {
  const time = frameTimes(c, details);
  const rows = [
    { key: 'total_bytes', label: 'Requested bytes per frame', values: c.total_bytes, format: fmt.bytes },
    { key: 'read_bytes', label: 'read', values: against(byAccess(c, 'read')), format: fmt.bytes },
    { key: 'written_bytes', label: 'written', values: against(byAccess(c, 'write')), format: fmt.bytes },
    ...(anyFootprint(c)
      ? [{ key: 'total_footprint_bytes', label: 'Footprint per frame', values: c.total_footprint_bytes, format: fmt.bytes },
        { key: 'reuse', label: 'Reuse (requested / footprint)', values: c.reuse, format: reuseText, higherIsBetter: true }]
      : []),
    { key: 'frame_ms', label: `Frame time (${kStatisticText[time.statistic]})`, values: time.values, format: fmt.ms },
  ];
  page.append(h('h2', {}, 'Totals'), comparedTable(c.runs, rows, 'totals'));
  const box = h('div', { class: 'charts' });
  page.append(box);
  const labels = c.runs.map((r) => `${fmt.variant(r)} #${r.id}`);
  box.append(bytesBox);
  barChart(box, {
    id: 'compare-frame-ms', title: `Frame time (${kStatisticText[time.statistic]})`, labels, labelHeader: 'Run', format: fmt.ms,
    datasets: [{ label: 'frame time', data: time.values.map((v) => v.value), backgroundColor: c.runs.map((_, i) => runSeries(c.runs, i).backgroundColor) }],
  });
}

const kTopResources = 10;

// Per resource, sorted by size (the largest value over the runs), the top 10
// first with "show all"; the log switch keeps small resources visible.
function resourceChart(c, key, noun, box, all = false) {
  destroyCharts(box);
  box.replaceChildren();
  const size = (res) => Math.max(0, ...res[key].map((v) => v.value ?? 0));
  const sorted = [...c.resources].sort((x, y) => size(y) - size(x));
  const shown = all ? sorted : sorted.slice(0, kTopResources);
  const chart = barChart(box, {
    id: 'compare-resources', title: `${noun} per frame by resource`,
    caption: `summed over passes, largest first${shown.length < sorted.length ? `; the ${shown.length} largest of ${sorted.length}` : ''}`,
    labels: shown.map((r) => `${r.resource} (${r.access})`), labelHeader: 'Resource', horizontal: true, logSwitch: true, format: fmt.bytes,
    datasets: c.runs.map((r, i) => ({ ...runSeries(c.runs, i), data: shown.map((res) => res[key][i].value) })),
  });
  box.querySelector('.chart-box').style.height = `${Math.max(260, 16 * shown.length * Math.min(c.runs.length, 3) + 60)}px`;
  chart.resize();
  if (sorted.length > kTopResources) {
    box.append(h('button', { type: 'button', class: 'secondary', dataset: { showAllResources: String(!all) },
      onclick: () => resourceChart(c, key, noun, box, !all) }, all ? `Show the ${kTopResources} largest` : `Show all ${sorted.length} resources`));
  }
}

// The byte charts of one measure: per run (read and written stacked), per
// resource and per pass. Redrawn when the switch changes.
function byteCharts(c, measure, boxes) {
  const { key, noun } = kMeasures[measure];
  for (const box of Object.values(boxes)) {
    destroyCharts(box);
    box.replaceChildren();
    box.dataset.measure = measure;
  }
  const runLabels = c.runs.map((r) => `${fmt.variant(r)} #${r.id}`);
  barChart(boxes.totals, {
    id: 'compare-bytes', title: `${noun} per frame`, labels: runLabels, labelHeader: 'Run', stacked: true, format: fmt.bytes,
    datasets: [{ label: 'read', data: byAccess(c, 'read', key), backgroundColor: kRead }, { label: 'written', data: byAccess(c, 'write', key), backgroundColor: kWritten }],
  });
  resourceChart(c, key, noun, boxes.resources);
  barChart(boxes.passes, {
    id: 'compare-pass-bytes', title: `${noun} per frame by pass`, labels: c.passes.map((p) => p.pass), labelHeader: 'Pass', logSwitch: true, format: fmt.bytes,
    datasets: c.runs.map((r, i) => ({ ...runSeries(c.runs, i), data: c.passes.map((p) => p[key][i].value) })),
  });
}

function perResource(page, c, box) {
  page.append(h('h2', {}, 'Per resource'), box);
  const footprint = anyFootprint(c);
  page.append(h('details', {}, h('summary', {}, 'Per resource: values, deltas and ratios'),
    comparedTable(c.runs, c.resources.flatMap((r) => [
      { key: `${r.resource}|${r.access}`, label: `${r.resource} (${r.access})${footprint ? ' requested' : ''}`, values: r.bytes, format: fmt.bytes },
      ...(footprint
        ? [{ key: `${r.resource}|${r.access}|footprint`, label: `${r.resource} (${r.access}) footprint`, values: r.footprint_bytes, format: fmt.bytes },
          { key: `${r.resource}|${r.access}|reuse`, label: `${r.resource} (${r.access}) reuse`, values: r.reuse, format: reuseText, higherIsBetter: true }]
        : []),
    ]), 'resources')));
}

function perPass(page, c, bytesBox) {
  const labels = c.passes.map((p) => p.pass);
  page.append(h('h2', {}, 'Per pass'));
  const box = h('div', { class: 'charts' });
  page.append(box);
  box.append(bytesBox);
  const series = (key) => c.runs.map((r, i) => ({ ...runSeries(c.runs, i), data: c.passes.map((p) => p[key][i].value) }));
  barChart(box, { id: 'compare-pass-ms', title: 'GPU time by pass', labels, labelHeader: 'Pass', format: fmt.ms, datasets: series('gpu_ms') });
  const footprint = anyFootprint(c);
  page.append(h('details', {}, h('summary', {}, 'Per pass: values, deltas and ratios'),
    comparedTable(c.runs, c.passes.flatMap((p) => [
      { key: `${p.pass}|bytes`, label: `${p.pass} requested bytes`, values: p.bytes, format: fmt.bytes },
      ...(footprint
        ? [{ key: `${p.pass}|footprint_bytes`, label: `${p.pass} footprint`, values: p.footprint_bytes, format: fmt.bytes },
          { key: `${p.pass}|reuse`, label: `${p.pass} reuse`, values: p.reuse, format: reuseText, higherIsBetter: true }]
        : []),
      { key: `${p.pass}|gpu_ms`, label: `${p.pass} time`, values: p.gpu_ms, format: fmt.ms },
    ]), 'passes')));
}

// Each pass's achieved bandwidth (its bytes per frame over its uninstrumented
// GPU time, both averaged over the run's samples) as a fraction of the
// bandwidth ceiling measured by that run's capture (GET /runs/{id}
// "ceilings"; null for runs without one).
function bandwidthFractions(page, c, runs) {
  const ceiling = runs.map((r) => (r.ceilings ? r.ceilings.bandwidth_bytes_per_s : null));
  const fraction = (p, i) => {
    const bytes = p.bytes[i].value, ms = p.gpu_ms[i].value;
    return ceiling[i] && bytes !== null && ms ? bytes / (ms / 1e3) / ceiling[i] : null;
  };
  page.append(h('h2', {}, 'Share of the bandwidth ceiling per pass'));
  if (ceiling.every((v) => v === null)) {
    page.append(h('p', { class: 'panel muted', dataset: { bandwidthFraction: 'none' } }, 'None of these runs has measured device ceilings.'));
    return;
  }
  const labels = c.passes.map((p) => p.pass);
  const box = h('div', { class: 'charts' });
  page.append(box);
  barChart(box, {
    id: 'compare-pass-bandwidth-fraction', title: 'Achieved fraction of the bandwidth ceiling',
    caption: "bytes per frame (requested) over the pass's GPU time, against the ceiling each run's capture measured",
    labels, labelHeader: 'Pass', format: fmt.percent,
    datasets: c.runs.map((r, i) => ({ ...runSeries(c.runs, i), data: c.passes.map((p) => fraction(p, i)) })),
  });
  page.append(h('div', { class: 'table-wrap' }, h('table', { 'aria-label': 'Bandwidth fraction', dataset: { table: 'bandwidth-fraction' } },
    h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Pass'), c.runs.map((r, i) => h('th', { scope: 'col', class: 'num' },
      `${fmt.variant(r)} #${r.id}`, h('div', { class: 'muted' }, ceiling[i] ? `ceiling ${fmt.bytes(ceiling[i])}/s` : 'no ceiling'))))),
    h('tbody', {}, c.passes.map((p) => h('tr', { dataset: { row: p.pass } }, h('th', { scope: 'row' }, p.pass),
      c.runs.map((r, i) => {
        const f = fraction(p, i);
        return h('td', { class: 'num', dataset: { run: r.id, fraction: f === null ? '' : String(f) } }, fmt.percent(f));
      })))))));
}

// ---- Repeated captures ---------------------------------------------------------

// Each compared run's repeat group: the stored runs with its exact configuration
// (/api/repeats lists groups of two or more), or null when it was captured once.
async function repeatGroups(runs, signal) {
  return Promise.all(runs.map(async (run) => {
    const { groups } = await get('/repeats' + queryString({ ...(run.variant ? { variant: run.variant } : { renderer: run.renderer }), scene: run.scene, device: run.device_id, width: run.width, height: run.height }), signal);
    return groups.find((g) => g.runs.includes(run.id)) || null;
  }));
}

// One capture's frame time with its 95% interval: "1.234 ms [1.200–1.270]",
// or the value alone where the run has no interval (below 8 frames, or stored
// before per-frame times were kept).
function captureFrameMs(f, i) {
  const lower = f.per_run_lower?.[i], upper = f.per_run_upper?.[i];
  const interval = lower === null || lower === undefined || upper === null || upper === undefined ? '' : ` [${fmt.ms(lower)}–${fmt.ms(upper)}]`;
  return `${fmt.ms(f.per_run[i])}${interval}`;
}

// Across-capture median and IQR of frame time and bytes beside the within-run
// noise: is a difference between compared runs larger than what repeating one
// capture gives? Each capture's value is the statistic every other view shows
// (the run's median of all frames, its mean bytes), so the spread here is of
// the same numbers as the runs list and the totals above.
async function repeats(page, c, signal) {
  page.append(h('h2', {}, 'Across repeated captures'));
  const groups = await repeatGroups(c.runs, signal);
  if (groups.every((g) => g === null)) {
    page.append(h('p', { class: 'panel', dataset: { repeats: 'none' } },
      'None of these runs has a repeated capture (same renderer, scene, resolution, device, counting mode, lights and cameras). Capture the same spec again to see the spread across captures.'));
    return;
  }
  const spread = (f, format) => (f ? `${format(f.median)} [${format(f.q1)} – ${format(f.q3)}]` : '–');
  const headers = ['Run', 'Captures', 'Frame time (median of all frames): median over captures [IQR]', 'Each capture (95% interval)',
    'Within-run noise (frame-to-frame IQR of a camera)', 'Agrees', 'Bytes / frame (mean over cameras): median [IQR]', 'Counts'];
  const table = h('div', { class: 'table-wrap' }, h('table', { 'aria-label': 'Repeated captures', dataset: { table: 'repeats' } },
    h('thead', {}, h('tr', {}, headers.map((t) => h('th', { scope: 'col' }, t)))),
    h('tbody', {}, c.runs.map((r, i) => {
      const g = groups[i];
      return h('tr', { dataset: { run: r.id, captures: g ? g.runs.length : 1, statistic: g ? g.frame_ms.statistic : '', median: g ? g.frame_ms.median : '', q1: g ? g.frame_ms.q1 : '', q3: g ? g.frame_ms.q3 : '' } },
        h('th', { scope: 'row' }, fmt.runLabel(r)),
        h('td', { class: 'num' }, g ? String(g.runs.length) : '1'),
        h('td', { class: 'num' }, g ? spread(g.frame_ms, fmt.ms) : 'captured once'),
        h('td', { class: 'num', dataset: { cell: 'captures' } }, g ? g.runs.map((id, k) => h('div', { dataset: { capture: id, value: g.frame_ms.per_run[k] } }, `#${id}: ${captureFrameMs(g.frame_ms, k)}`)) : '–'),
        h('td', { class: 'num' }, g ? fmt.ms(g.frame_ms.noise_iqr) : '–'),
        h('td', {}, g ? (g.frame_ms.agrees ? 'yes' : 'no: outside the noise band') : '–'),
        h('td', { class: 'num' }, g ? spread(g.bytes, fmt.bytes) : '–'),
        h('td', {}, g ? (g.counts.identical ? 'identical' : `differ: ${g.counts.first_difference}`) : '–'));
    }))));
  const box = h('div', { class: 'charts' });
  page.append(box);
  barChart(box, {
    id: 'compare-repeats-ms', title: 'Frame time across repeated captures', caption: 'each capture\'s frame time is its median of all frames, as everywhere; bar: the median over captures, whiskers q1–q3; runs captured once have no bar',
    labels: c.runs.map((r) => `${fmt.variant(r)} #${r.id}`), labelHeader: 'Run', format: fmt.ms,
    datasets: [{ label: 'median over captures', data: groups.map((g) => (g ? g.frame_ms.median : null)), whiskers: groups.map((g) => (g ? [g.frame_ms.q1, g.frame_ms.q3] : null)) }],
  });
  page.append(table);
}

// ---- A/B/difference viewer --------------------------------------------------------

function loadImage(src) {
  return new Promise((resolve, reject) => {
    const img = new Image();
    img.onload = () => resolve(img);
    img.onerror = () => reject(new Error('screenshot did not load'));
    img.src = src;
  });
}

function pixelsOf(img) {
  const canvas = document.createElement('canvas');
  canvas.width = img.naturalWidth;
  canvas.height = img.naturalHeight;
  const ctx = canvas.getContext('2d', { willReadFrequently: true });
  ctx.drawImage(img, 0, 0);
  return ctx.getImageData(0, 0, canvas.width, canvas.height);
}

// |A - B| per channel, times gain; with the mean and largest absolute
// difference over RGB (8-bit levels), as the capture's image error counts them.
function difference(a, b, gain) {
  const out = new ImageData(a.width, a.height);
  let sum = 0;
  let max = 0;
  for (let i = 0; i < a.data.length; i += 4) {
    for (let ch = 0; ch < 3; ++ch) {
      const d = Math.abs(a.data[i + ch] - b.data[i + ch]);
      sum += d;
      max = Math.max(max, d);
      out.data[i + ch] = Math.min(255, d * gain);
    }
    out.data[i + 3] = 255;
  }
  return { image: out, meanAbs: sum / (3 * a.width * a.height), maxAbs: max };
}

function canvasOf(imageData) {
  const canvas = h('canvas', { width: imageData.width, height: imageData.height });
  canvas.getContext('2d').putImageData(imageData, 0, 0);
  return canvas;
}

function imageViewer(page, runs, signal) {
  page.append(h('h2', {}, 'Images: A, B and their difference'));
  const samplesOf = new Map();  // run id -> its samples, fetched once
  const samples = async (id) => {
    if (!samplesOf.has(id)) samplesOf.set(id, (await get(`/runs/${id}/samples`, signal)).samples);
    return samplesOf.get(id);
  };
  const runSelect = (name, chosen) => h('select', { name }, runs.map((r) => h('option', { value: r.id, selected: r.id === chosen }, fmt.runLabel(r))));
  const a = runSelect('a', runs[0].id);
  const b = runSelect('b', runs[1].id);
  const camera = h('select', { name: 'camera' });
  const gain = h('select', { name: 'gain' }, [1, 4, 16, 64].map((g) => h('option', { value: g, selected: g === 16 }, `×${g}`)));
  const out = h('div', { class: 'viewer' });
  const field = (label, control) => h('label', { class: 'field' }, h('span', {}, label), control);
  page.append(h('form', { class: 'filters', 'aria-label': 'Image viewer' }, field('A', a), field('B', b), field('Camera', camera), field('Difference gain', gain)), out);

  let drawn = 0;  // the latest draw wins when choices change quickly
  async function draw() {
    const ticket = ++drawn;
    const [sa, sb] = await Promise.all([samples(Number(a.value)), samples(Number(b.value))]);
    const common = sa.map((s) => s.camera_index).filter((i) => sb.some((s) => s.camera_index === i));
    const keep = common.includes(Number(camera.value)) ? Number(camera.value) : common[0];
    camera.replaceChildren(...common.map((i) => h('option', { value: i, selected: i === keep }, `camera ${i}`)));
    if (common.length === 0) {
      out.replaceChildren(h('p', { class: 'panel' }, 'These runs share no camera.'));
      return;
    }
    const pa = sa.find((s) => s.camera_index === keep);
    const pb = sb.find((s) => s.camera_index === keep);
    if (!pa.screenshot || !pb.screenshot) {
      out.replaceChildren(h('p', { class: 'panel' }, 'A screenshot is missing for this camera.'));
      return;
    }
    const [ia, ib] = await Promise.all([pa, pb].map(async (s) => loadImage(await imageSource(s.screenshot, signal))));
    if (ticket !== drawn || signal.aborted) return;
    const da = pixelsOf(ia);
    const db = pixelsOf(ib);
    const note = JSON.stringify(pa.camera.eye) === JSON.stringify(pb.camera.eye) && JSON.stringify(pa.camera.target) === JSON.stringify(pb.camera.target)
      ? null : h('p', { class: 'error' }, 'The two runs placed this camera differently.');
    if (da.width !== db.width || da.height !== db.height) {
      out.replaceChildren(h('p', { class: 'panel' }, `Different resolutions (${da.width}×${da.height} and ${db.width}×${db.height}): no difference image.`));
      return;
    }
    const diff = difference(da, db, Number(gain.value));
    out.replaceChildren(note || '',
      h('div', { class: 'images' },
        h('figure', { dataset: { image: 'a' } }, canvasOf(da), h('figcaption', {}, `A: ${fmt.runLabel(runs.find((r) => r.id === Number(a.value)))}`)),
        h('figure', { dataset: { image: 'b' } }, canvasOf(db), h('figcaption', {}, `B: ${fmt.runLabel(runs.find((r) => r.id === Number(b.value)))}`)),
        h('figure', { dataset: { image: 'diff', camera: keep, a: a.value, b: b.value, meanAbs: diff.meanAbs, maxAbs: diff.maxAbs } }, canvasOf(diff.image),
          h('figcaption', {}, `|A − B| ×${gain.value}: mean ${diff.meanAbs.toFixed(3)}, max ${diff.maxAbs} (8-bit levels)`))));
  }
  const redraw = () => draw().catch((error) => {
    if (!signal.aborted) out.replaceChildren(h('p', { class: 'panel error', role: 'alert' }, error.message));
  });
  for (const control of [a, b, camera, gain]) control.addEventListener('change', redraw);
  return redraw();
}

// ---- significance ---------------------------------------------------------------

const verdictText = { faster: 'faster', slower: 'slower', same: 'no significant difference' };
const endText = (v) => (v === null || v === undefined ? '∞' : `×${v.toFixed(3)}`);

// One figure's test as a table row: ratio of medians, interval, p, Cliff's
// delta and the verdict with its reason (and the across-capture widening).
function significanceRow(run, figure, t) {
  if (!t) return null;
  const widened = t.interval.widening !== null && t.interval.widening > 1;
  const note = [t.verdict === 'same' ? t.reason : '',
    widened ? `interval widened ×${t.interval.widening.toFixed(1)} by ${t.across_capture.runs.length} repeated captures` : '']
    .filter(Boolean).join('; ');
  return h('tr', { dataset: { run: run.id, figure, verdict: t.verdict, ratio: t.ratio, p: t.mann_whitney.p, lower: t.interval.lower ?? '', upper: t.interval.upper ?? '' } },
    h('th', { scope: 'row' }, `${fmt.variant(run)} #${run.id}`),
    h('td', {}, figure),
    h('td', { class: 'num' }, fmt.ratio(t.ratio)),
    h('td', { class: 'num' }, `[${endText(t.interval.lower)}, ${endText(t.interval.upper)}]`),
    h('td', { class: 'num' }, fmt.pValue(t.mann_whitney.p)),
    h('td', { class: 'num' }, `${fmt.signed(t.cliffs_delta.delta, 2)} (${t.cliffs_delta.magnitude})`),
    h('td', {}, h('span', { class: `badge verdict ${t.verdict}` }, verdictText[t.verdict])),
    h('td', { class: 'muted why' }, note));
}

function missingRow(run, figure, reason) {
  return h('tr', { dataset: { run: run.id, figure, verdict: 'missing' } },
    h('th', { scope: 'row' }, `${fmt.variant(run)} #${run.id}`), h('td', {}, figure),
    h('td', { colspan: 5, class: 'muted' }, '–'), h('td', { class: 'muted why' }, reason));
}

function significanceTable(c) {
  const runOf = (id) => c.runs.find((r) => r.id === id);
  const rows = [];
  const counts = [];
  for (const s of c.significance) {
    const run = runOf(s.run_b);
    if (s.error) {
      counts.push(h('li', { dataset: { run: run.id, counts: 'incomparable' } }, `${fmt.variant(run)} #${run.id}: ${s.error}`));
      continue;
    }
    rows.push(s.frame ? significanceRow(run, 'frame', s.frame) : missingRow(run, 'frame', s.frame_missing));
    for (const p of s.passes) rows.push(significanceRow(run, p.pass, p));
    for (const p of s.passes_missing) rows.push(missingRow(run, p.pass, p.reason));
    const changes = s.counts.changes;
    counts.push(h('li', { dataset: { run: run.id, counts: s.counts.verdict, changes: changes.length } },
      h('span', { class: `badge verdict ${s.counts.verdict === 'same' ? 'same' : 'slower'}` }, `counts ${s.counts.verdict}`),
      ` ${fmt.variant(run)} #${run.id}: ${changes.length} of ${s.counts.lines} lines differ (exact, no test)`,
      changes.length === 0 ? null : h('details', {}, h('summary', {}, 'Changed lines'),
        h('ul', {}, changes.map((x) => h('li', { dataset: { line: x.line } },
          `${x.line}: ${x.line === 'total' ? fmt.bytes(x.a) : fmt.count(x.a)} → ${x.line === 'total' ? fmt.bytes(x.b) : fmt.count(x.b)}`))))));
  }
  const pct = Math.round(c.confidence * 1000) / 10;
  return h('div', {},
    h('div', { class: 'table-wrap' }, h('table', { 'aria-label': 'significance', dataset: { table: 'significance', confidence: c.confidence, strata: c.significance.find((s) => s.frame)?.frame.strata ?? '' } },
      h('thead', {}, h('tr', {}, ['Run', 'Figure', c.significance.some((x) => x.frame?.strata === 'cameras') ? 'Ratio of medians (each camera aligned)' : 'Ratio of medians', `${pct}% interval`, 'Mann-Whitney p', "Cliff's delta", 'Verdict', 'Why'].map((t) => h('th', { scope: 'col' }, t)))),
      h('tbody', {}, rows))),
    h('ul', { class: 'counts-verdicts' }, counts));
}

// Times against the first run, with their significance; the level, the
// practical threshold and the across-capture widening can be changed (each a
// new request).
function significance(page, c, ids, signal) {
  page.append(h('h2', {}, 'Is it real? Times tested, counts exact'),
    h('p', { class: 'muted' }, 'Each run against the reference, over the per-frame times of the cameras both measured, each camera\'s frames aligned on their median so that differences between cameras do not hide one between runs. The interval is Hodges-Lehmann on log times, the test Mann-Whitney U, widened by the spread of repeated captures of the same configuration where there are any (docs/statistics.md).'));
  const confidence = h('select', { name: 'confidence' }, [0.9, 0.95, 0.99].map((v) => h('option', { value: v, selected: v === 0.95 }, `${v * 100}%`)));
  const threshold = h('select', { name: 'threshold' }, [0, 0.01, 0.02, 0.05, 0.1].map((v) => h('option', { value: v, selected: v === 0 }, v === 0 ? 'none' : `${v * 100}%`)));
  const across = h('input', { type: 'checkbox', name: 'across_capture', checked: true });
  const strata = h('input', { type: 'checkbox', name: 'strata', checked: true });
  const field = (label, control) => h('label', { class: 'field' }, h('span', {}, label), control);
  const out = h('div', { dataset: { significance: 'table' } }, significanceTable(c));
  page.append(h('form', { class: 'filters', 'aria-label': 'Significance' },
    field('Level', confidence), field('Practical threshold', threshold), field('Align each camera', strata),
    field('Widen by repeated captures', across)), out);
  let asked = 0;
  const redraw = async () => {
    const ticket = ++asked;
    out.dataset.significance = 'loading';
    try {
      const again = await get('/compare' + queryString({ runs: ids.join(','), confidence: confidence.value, threshold: threshold.value, across_capture: across.checked, strata: strata.checked ? 'cameras' : 'none' }), signal);
      if (ticket !== asked) return;
      out.replaceChildren(significanceTable(again));
      out.dataset.significance = 'table';
    } catch (error) {
      if (!signal.aborted) out.replaceChildren(h('p', { class: 'panel error', role: 'alert' }, error.message));
    }
  };
  for (const control of [confidence, threshold, strata, across]) control.addEventListener('change', redraw);
}

function chooser() {
  return h('div', { class: 'panel' },
    h('p', {}, 'Pick 2 to 4 runs in the ', h('a', { href: '#/runs' }, 'runs browser'), ' (tick them, then "Compare selected"), for example deferred, visbuffer and visbuffer-lean on one scene and resolution.'));
}

export async function render(page, { query, signal }) {
  page.append(h('h1', {}, 'Compare runs'));
  const ids = (query.get('runs') || '').split(',').filter(Boolean);
  if (ids.length === 0) {
    page.append(chooser());
    return;
  }
  const c = await get('/compare' + queryString({ runs: ids.join(',') }), signal);
  page.append(h('ul', { class: 'meta' }, c.runs.map((r, i) => h('li', {},
    `${i === 0 ? 'reference ' : ''}`, h('a', { href: `#/runs/${r.id}` }, fmt.runLabel(r)), ` on ${r.device}`))),
  h('p', {}, h('a', { href: `#/runs?select=${ids.join(',')}` }, 'Change the selection')));
  // One switch draws every byte chart below in requested bytes or footprint.
  const boxes = { totals: h('div', {}), resources: h('div', {}), passes: h('div', {}) };
  page.append(measureSwitch('compare-measure', anyFootprint(c),
    'None of these runs has a footprint: capture with "footprint" on (the capture form\'s Footprint select).', (measure) => byteCharts(c, measure, boxes)));
  const [runs, details] = await Promise.all([Promise.all(c.runs.map((r) => get(`/runs/${r.id}`, signal))),
    Promise.all(c.runs.map((r) => sampleDetails(r.id, signal)))]);
  page.append(h('h2', {}, 'Where the bytes go'), breakdownTable({
    id: 'compare', columns: c.runs.map((r) => `${fmt.variant(r)} #${r.id}`), nodes: passNodes(runs.map((r) => r.passes)),
    total: c.total_bytes.map((v) => v.value), title: null,
    caption: 'requested bytes per frame; passes ranked by their largest value over the runs, each opening onto its resources; shares of each run\'s total.' }));
  totals(page, c, boxes.totals, details);
  significance(page, c, ids, signal);
  perResource(page, c, boxes.resources);
  perPass(page, c, boxes.passes);
  byteCharts(c, 'requested', boxes);
  // Both need more requests: fetch them side by side, each into its own section.
  const [fractionSection, repeatSection, scalingSection, imageSection] = [h('section'), h('section'), h('section'), h('section')];
  page.append(fractionSection, repeatSection, scalingSection, imageSection);
  bandwidthFractions(fractionSection, c, runs);
  await Promise.all([repeats(repeatSection, c, signal),
    scaling(scalingSection, c, signal), imageViewer(imageSection, c.runs, signal)]);
}

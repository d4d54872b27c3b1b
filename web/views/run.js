// One run: what it is, its traffic per pass and resource (the founding
// study's per-resource figure), per camera (its per-sample figure), frame time
// per pass with the cost of counting, and the screenshots with sky fraction
// and image error against forward; how far its counters are from wrapping
// (counter headroom). Time figures carry their IQR over frames
// (whiskers, table columns). Requests: the run (with its passes averaged over
// the samples), its samples, and each sample (its passes' spreads).
import { downloadSource, get, hasToken, imageSource, request } from '../api.js';
import { breakdownTable, passNodes } from '../breakdown.js';
import { barChart, destroyCharts, xyChart } from '../charts.js';
import { h, measureSwitch, table } from '../dom.js';
import * as fmt from '../format.js';
import { kRead, kWritten } from '../palette.js';
import { rooflineSection } from './roofline.js';
import { frameTime, kStatisticText } from '../stats.js';

const tile = (label, value, key) => h('div', { class: 'tile', dataset: { tile: key } },
  h('div', { class: 'label' }, label), h('div', { class: 'value' }, value));

// The two byte measures (docs/result-schema.md): requested bytes (count x
// element size, "bytes") and footprint (distinct bytes touched, in blocks;
// "footprint_bytes", null where not measured).
const kMeasures = {
  requested: { key: 'bytes', noun: 'Requested bytes' },
  footprint: { key: 'footprint_bytes', noun: 'Footprint' },
};

// bytes[pass][resource] for one access, and the resources in first-seen order.
// A line without the measure (no footprint) adds nothing; a resource none of
// whose lines has it stays out of the pass's sums (null in the chart).
function trafficBy(passes, access, key = 'bytes') {
  const resources = [];
  const byPass = passes.map((p) => {
    const sums = {};
    for (const r of p.resources) {
      if (r.access !== access) continue;
      if (!resources.includes(r.name)) resources.push(r.name);
      if (r[key] === null || r[key] === undefined) continue;
      sums[r.name] = (sums[r.name] || 0) + r[key];
    }
    return sums;
  });
  return { resources, byPass };
}

const hasFootprint = (run) => run.mean_footprint_bytes !== null && run.mean_footprint_bytes !== undefined;

// An application or a replay captured under the Vulkan layer (docs/layer.md):
// its notes.source, else null. Its samples are frames (no cameras, sky or
// screenshots), timed under the layer (no uninstrumented baseline).
function appSource(run) {
  const source = run.notes && run.notes.source;
  return source && (source.kind === 'application' || source.kind === 'replay') ? source : null;
}


// The ranked pass -> resource table above the charts. A resource line has no
// children yet; per-site and per-draw figures (GET /api/samples/{id}/sites,
// /draws) nest here as a third level through breakdownTable's childrenOf.
function bytesBreakdown(run, measure) {
  const { key, noun } = kMeasures[measure];
  const nodes = passNodes([run.passes], key);
  const total = nodes.reduce((sum, n) => sum + (n.values[0] ?? 0), 0);
  return breakdownTable({ id: 'run', columns: [`${noun} per frame`], nodes, total: [total],
    caption: `${noun.toLowerCase()} per frame, passes ranked by their share, each opening onto its resources; averaged over the samples.` });
}

function passResourceCharts(parent, run, measure = 'requested') {
  const { key, noun } = kMeasures[measure];
  const labels = run.passes.map((p) => p.name);
  const box = h('div', { class: 'charts', dataset: { measure } });
  parent.append(box);
  for (const [access, title] of [['read', `${noun} read per frame`], ['write', `${noun} written per frame`]]) {
    const { resources, byPass } = trafficBy(run.passes, access, key);
    barChart(box, {
      id: `pass-resource-${access}`,
      title,
      caption: `per pass, stacked by resource; averaged over the samples${measure === 'footprint' ? ` (distinct bytes touched, ${run.footprint_block_bytes}-byte blocks; lines without one are left out)` : ''}. Click a resource to hide it.`,
      labels,
      labelHeader: 'Pass',
      stacked: true,
      format: fmt.bytes,
      datasets: resources.map((name) => ({
        label: name,
        data: byPass.map((sums) => (name in sums ? sums[name] : null)),
      })),
    });
  }
}

// "frame 12" for an application's sample (the camera's place holds its frame).
const frameLabel = (s) => (s.camera && s.camera.frame !== undefined && s.camera.label ? s.camera.label : null);

function cameraLabel(s) {
  if (frameLabel(s)) return frameLabel(s);
  return s.sky_fraction === null ? `cam ${s.camera_index}` : `cam ${s.camera_index} (${Math.round(100 * s.sky_fraction)}% sky)`;
}

// A sample's footprint read and written, from its lines (the sample list carries the total only).
function footprintByAccess(detail, access) {
  const lines = detail.passes.flatMap((p) => p.resources).filter((r) => r.access === access && r.footprint_bytes !== null);
  return lines.length ? lines.reduce((sum, r) => sum + r.footprint_bytes, 0) : null;
}

function perSampleChart(parent, samples, details, measure = 'requested') {
  const footprint = measure === 'footprint';
  barChart(parent, {
    id: 'per-sample',
    title: `${kMeasures[measure].noun} per frame${samples.some(frameLabel) ? '' : ', per camera'}`,
    caption: 'read on the left axis, written on the right',
    labels: samples.map(cameraLabel),
    labelHeader: samples.some(frameLabel) ? 'Frame' : 'Camera',
    format: fmt.bytes,
    datasets: [
      { label: 'read', data: footprint ? details.map((d) => footprintByAccess(d, 'read')) : samples.map((s) => s.bytes_read), yAxisID: 'y', backgroundColor: kRead },
      { label: 'written', data: footprint ? details.map((d) => footprintByAccess(d, 'write')) : samples.map((s) => s.bytes_written), yAxisID: 'y2', backgroundColor: kWritten },
    ],
    yTitle: 'read',
    axes: { y2: { position: 'right', beginAtZero: true, grid: { drawOnChartArea: false }, title: { display: true, text: 'written' }, ticks: { callback: (v) => fmt.bytes(v) } } },
  });
}

// Per pass, the IQR over frames of its uninstrumented time, averaged over the
// samples like the bar itself: [mean q1, mean q3], or null without spreads.
function passIqr(run, details) {
  return run.passes.map((p) => {
    const spreads = details.map((d) => (d.passes.find((x) => x.name === p.name) || {}).gpu_ms_spread).filter((x) => x);
    if (!spreads.length) return null;
    const mean = (key) => spreads.reduce((sum, x) => sum + x[key], 0) / spreads.length;
    return [mean('q1'), mean('q3')];
  });
}

function frameTimeChart(parent, samples, app) {
  barChart(parent, {
    id: 'sample-time',
    title: app ? 'GPU time per frame' : 'Frame time per camera',
    caption: app ? 'the sum of the passes\' GPU times, measured under the layer (instrumented)' : 'uninstrumented; median over the frames, whiskers the IQR (q1 to q3)',
    labels: samples.map(cameraLabel),
    labelHeader: app ? 'Frame' : 'Camera',
    format: fmt.ms,
    datasets: [{
      label: 'frame time',
      data: samples.map((s) => s.frame_ms),
      whiskers: samples.map((s) => (s.frame_ms_spread ? [s.frame_ms_spread.q1, s.frame_ms_spread.q3] : null)),
    }],
  });
}

function passTimeChart(parent, run, iqr) {
  const app = appSource(run);
  barChart(parent, {
    id: 'pass-time',
    title: 'GPU time per pass',
    caption: app
      ? 'measured under the layer (instrumented), averaged over the frames'
      : 'uninstrumented and counted frames; median per sample, averaged over the samples; whiskers: the uninstrumented IQR over frames (q1 to q3, averaged over the samples)',
    labels: run.passes.map((p) => p.name),
    labelHeader: 'Pass',
    format: fmt.ms,
    horizontal: true,
    datasets: app
      ? [{ label: 'under the layer', data: run.passes.map((p) => p.gpu_ms) }]
      : [
        { label: 'uninstrumented', data: run.passes.map((p) => p.gpu_ms), whiskers: iqr },
        { label: 'counted', data: run.passes.map((p) => p.gpu_ms_instrumented) },
      ],
  });
}

function passTable(run, iqr) {
  const at = (p) => iqr[run.passes.indexOf(p)];
  // An application's passes are timed under the layer only: no spread, counted time or overhead.
  const timed = !appSource(run);
  return table([
    { label: 'Pass', value: (p) => p.name },
    { label: 'GPU time', className: 'num', value: (p) => fmt.ms(p.gpu_ms) },
    ...(timed ? [
      { label: 'IQR (q1–q3)', className: 'num', value: (p) => (at(p) ? `${fmt.ms(at(p)[0])}–${fmt.ms(at(p)[1])}` : '–') },
      { label: 'Counted', className: 'num', value: (p) => fmt.ms(p.gpu_ms_instrumented) },
      { label: 'Overhead', className: 'num', value: (p) => fmt.ratio(p.overhead_ratio) }] : []),
    { label: 'Fragment invocations', className: 'num', value: (p) => fmt.count(p.fragment_invocations) },
    { label: 'Requested bytes', className: 'num', value: (p) => fmt.bytes(p.resources.reduce((sum, r) => sum + r.bytes, 0)) },
    ...(hasFootprint(run)
      ? [{ label: 'Footprint', className: 'num', value: (p) => valueCell(p.footprint_bytes, fmt.bytes) },
        { label: 'Reuse', className: 'num', value: (p) => valueCell(p.reuse, reuseText) }]
      : []),
  ], run.passes, { 'aria-label': 'Passes', dataset: { table: 'passes' } });
}

// "×2.50": requested bytes per footprint byte.
const reuseText = (v) => `×${v.toFixed(2)}`;

// A number with its raw value in data-value ('' for none), for readers and tests.
function valueCell(v, format) {
  const none = v === null || v === undefined;
  return h('span', { dataset: { value: none ? '' : String(v) } }, none ? '–' : format(v));
}

// Every line (pass x resource x access x source): requested bytes beside its
// footprint and reuse, per frame, averaged over the samples.
function lineTable(run) {
  const lines = run.passes.flatMap((p) => p.resources.map((r) => ({ pass: p.name, ...r })));
  return table([
    { label: 'Pass', value: (l) => l.pass },
    { label: 'Resource', value: (l) => l.name },
    { label: 'Access', value: (l) => l.access },
    { label: 'Source', value: (l) => l.source },
    { label: 'Requested bytes', className: 'num', value: (l) => valueCell(l.bytes, fmt.bytes) },
    { label: 'Footprint', className: 'num', value: (l) => valueCell(l.footprint_bytes, fmt.bytes) },
    { label: 'Reuse', className: 'num', value: (l) => valueCell(l.reuse, reuseText) },
  ], lines, { 'aria-label': 'Lines', dataset: { table: 'lines' } });
}

function errorText(e) {
  if (!e) return 'not compared';
  return e.identical ? `identical to ${e.against}` : `${fmt.psnr(e.psnr)} vs ${e.against}`;
}
const imageErrorText = (s) => errorText(s.image_error);

// "barycentrics=float32, material_selection=uniform"; "" for none.
function optionsText(options) {
  return Object.entries(options || {}).map(([k, v]) => `${k}=${typeof v === 'string' ? v : JSON.stringify(v)}`).join(', ');
}

// A sample's technique measurements, shown without knowing the techniques:
// a table of key and value per technique, nested values as JSON.
function extrasSection(samples) {
  // The roofline has its own section.
  const techniques = (s) => Object.entries(s.extras || {}).filter(([k]) => k !== 'roofline');
  const withExtras = samples.filter((s) => techniques(s).length);
  if (!withExtras.length) return null;
  return h('div', { dataset: { extras: '' } }, withExtras.map((s) => techniques(s).map(([technique, value]) =>
    h('section', { dataset: { extrasSample: String(s.camera_index), technique } },
      h('h3', {}, `Camera ${s.camera_index}: ${technique}`),
      value !== null && typeof value === 'object' && !Array.isArray(value)
        ? table([
          { label: 'Measure', value: ([k]) => k },
          { label: 'Value', className: 'num', value: ([, v]) => (typeof v === 'number' ? String(v) : h('pre', {}, JSON.stringify(v, null, 2))) },
        ], Object.entries(value), { 'aria-label': `${technique} of camera ${s.camera_index}` })
        : h('pre', {}, JSON.stringify(value, null, 2))))));
}

function gallery(run, samples, signal) {
  // Applications captured under the layer keep none.
  if (!samples.some((s) => s.screenshot)) {
    return h('p', { class: 'panel muted', dataset: { screenshots: 'none' } }, 'No screenshots for this run.');
  }
  return h('div', { class: 'gallery' }, samples.map((s) => {
    const img = h('img', { alt: `Camera ${s.camera_index}`, loading: 'lazy', width: run.width, height: run.height });
    if (s.screenshot) {
      imageSource(s.screenshot, signal).then((src) => { img.src = src; }, () => { img.alt = 'screenshot not available'; });
    }
    return h('figure', { class: 'shot', dataset: { sample: s.id } }, img,
      h('figcaption', {},
        h('strong', {}, `Camera ${s.camera_index}`), s.camera.label ? h('div', { class: 'muted' }, s.camera.label) : null,
        h('div', {}, `sky ${fmt.percent(s.sky_fraction)} · ${fmt.ms(s.frame_ms)}`),
        h('div', {}, imageErrorText(s))));
  }));
}

// A sample's trace (GET /api/samples/{id}/trace): Chrome trace-event JSON of
// its frames and passes, for ui.perfetto.dev. With a token the file is
// fetched with it and handed to the link as an object URL.
function traceLink(s) {
  const path = `/api/samples/${s.id}/trace`;
  const name = `tally-sample-${s.id}.trace.json`;
  const onclick = async (event) => {
    if (!hasToken() || event.currentTarget.dataset.fetched) return;
    event.preventDefault();
    const link = event.currentTarget;
    try {
      link.href = await downloadSource(path);
    } catch (e) {
      link.title = `trace not available: ${e.message}`;
      return;
    }
    link.dataset.fetched = 'true';
    link.click();
  };
  return h('a', { href: path, download: name, title: 'Chrome trace-event JSON: open it in ui.perfetto.dev', dataset: { trace: String(s.id) }, onclick }, 'Download trace');
}

function sampleTable(samples) {
  // An application's samples are single frames under the layer: no sky, spread, overhead or image error.
  const frames = samples.some((s) => frameLabel(s));
  return table([
    frames ? { label: 'Frame', value: (s) => frameLabel(s) || String(s.camera_index) } : { label: 'Camera', value: (s) => String(s.camera_index) },
    ...(frames ? [] : [{ label: 'Sky', className: 'num', value: (s) => fmt.percent(s.sky_fraction) }]),
    { label: frames ? 'GPU time' : 'Frame time', className: 'num', value: (s) => fmt.ms(s.frame_ms) },
    ...(frames ? [] : [
      { label: 'IQR', className: 'num', value: (s) => fmt.ms(s.frame_ms_spread ? s.frame_ms_spread.iqr : null) },
      { label: 'q1–q3', className: 'num', value: (s) => (s.frame_ms_spread ? `${fmt.ms(s.frame_ms_spread.q1)}–${fmt.ms(s.frame_ms_spread.q3)}` : '–') },
      { label: 'Overhead', className: 'num', value: (s) => fmt.ratio(s.overhead_ratio) }]),
    { label: 'Requested read', className: 'num', value: (s) => fmt.bytes(s.bytes_read) },
    { label: 'Requested written', className: 'num', value: (s) => fmt.bytes(s.bytes_written) },
    ...(samples.some((s) => s.footprint_bytes !== null && s.footprint_bytes !== undefined)
      ? [{ label: 'Footprint', className: 'num', value: (s) => valueCell(s.footprint_bytes, fmt.bytes) },
        { label: 'Reuse', className: 'num', value: (s) => valueCell(s.reuse, reuseText) }]
      : []),
    ...(frames ? [] : [{ label: 'Image vs forward', className: 'num', value: imageErrorText }]),
    ...(samples.some((s) => s.variant_error)
      ? [{ label: 'Image vs reference variant', className: 'num', value: (s) => h('span', { dataset: { variantError: s.variant_error ? String(s.variant_error.psnr) : 'none' } }, errorText(s.variant_error)) }]
      : []),
    { label: 'Trace', value: traceLink },
  ], samples, { 'aria-label': 'Samples', dataset: { table: 'samples' } });
}

function resourceTable(run) {
  return table([
    { label: 'Resource', value: (r) => r.name },
    { label: 'Kind', value: (r) => r.kind },
    { label: 'Format', value: (r) => r.format || '–' },
    { label: 'Size', className: 'num', value: (r) => (r.width ? `${r.width}×${r.height}` : '–') },
    { label: 'Format bytes', className: 'num', value: (r) => fmt.bytes(r.format_bytes) },
    { label: 'Allocated', className: 'num', value: (r) => fmt.bytes(r.allocation_bytes) },
    { label: 'Usage', value: (r) => r.usage || '–' },
  ], run.resources, { 'aria-label': 'Resources' });
}

// A wrap factor in a few characters and no e-notation: "3.2", "186",
// "4,300", "8.0 billion".
function factor(v) {
  if (v === null || v === undefined) return '–';
  const words = [[1e12, 'trillion'], [1e9, 'billion'], [1e6, 'million']].find(([k]) => v >= k);
  if (words) return `${(v / words[0]).toFixed(1)} ${words[1]}`;
  return v >= 100 ? fmt.number(v, 2) : v.toFixed(1);
}

// How far the run's counters are from wrapping (docs/measurement.md,
// "Counter overflow"): the largest count one slot reached in a frame, and how
// many times resolution x overshading could grow before a counter wraps.
// What the scene's loader simplified or ignored (notes.scene), then the
// renderer's own choices (every other key of notes).
// An application's notes add the layer's notes (notes.layer_notes) and the
// shaders it could not instrument (notes.uninstrumented_shaders).
function notesSection(run) {
  const notes = run.notes && typeof run.notes === 'object' ? run.notes : {};
  const scene = Array.isArray(notes.scene) ? notes.scene : [];
  const layer = Array.isArray(notes.layer_notes) ? notes.layer_notes : [];
  const shaders = Array.isArray(notes.uninstrumented_shaders) ? notes.uninstrumented_shaders : [];
  const others = Object.entries(notes).filter(([k]) => !['scene', 'layer_notes', 'uninstrumented_shaders'].includes(k));
  if (!scene.length && !layer.length && !shaders.length && !others.length) return null;
  return h('div', { class: 'panel', dataset: { notes: '' } },
    scene.length ? h('ul', { dataset: { sceneNotes: '' } }, scene.map((n) => h('li', {}, String(n)))) : null,
    layer.length ? h('ul', { dataset: { layerNotes: '' } }, layer.map((n) => h('li', {}, String(n)))) : null,
    shaders.length ? h('ul', { dataset: { uninstrumentedShaders: '' } }, shaders.map((s) =>
      h('li', {}, `uninstrumented: ${s.name} (${s.stage}): ${s.reason}`))) : null,
    others.length ? h('ul', { dataset: { rendererNotes: '' } }, others.map(([k, v]) =>
      h('li', {}, `${k}: ${typeof v === 'string' ? v : JSON.stringify(v)}`))) : null);
}

function headroomSection(run) {
  const hr = run.counter_headroom;
  if (!hr) {
    return h('p', { class: 'panel muted', dataset: { headroom: 'none' } }, appSource(run)
      ? 'Not measured for an application captured under the layer.'
      : 'Not recorded for this run (captured before counter headroom was stored).');
  }
  const hTile = (label, value, key, raw) => h('div', { class: 'tile', dataset: { headroom: key, value: String(raw) } },
    h('div', { class: 'label' }, label), h('div', { class: 'value' }, value));
  const inUse = hr.width === 'int64' ? '64-bit (int64)' : '64-bit (uint32 pair)';
  const per = hr.frames_accumulated === 1 ? 'per frame' : `over ${hr.frames_accumulated} frames`;
  return h('div', { class: 'headroom' },
    h('div', { class: 'tiles' },
      hTile(`Largest slot count, ${per}`, fmt.count(hr.max_slot_count_per_frame), 'max-slot-count', hr.max_slot_count_per_frame),
      hTile('Slot', h('span', { class: 'clip', title: hr.max_slot }, hr.max_slot), 'max-slot', hr.max_slot),
      hTile('32-bit wrap factor', `×${factor(hr.wrap_factor_32bit)}`, 'wrap-32', hr.wrap_factor_32bit),
      hTile(`${inUse} wrap factor`, `×${factor(hr.wrap_factor)}`, 'wrap', hr.wrap_factor)),
    hr.wrap_factor_32bit === null
      ? h('p', { dataset: { headroom: 'sentence' } }, 'Nothing was counted, so no counter comes near wrapping.')
      : h('p', { dataset: { headroom: 'sentence' } },
        `32-bit counters would wrap at ${factor(hr.wrap_factor_32bit)}× this resolution × overshading; `,
        `the ${inUse} counters in use at ${factor(hr.wrap_factor)}×.`));
}

// "Mark as baseline": this run becomes its configuration's baseline (POST
// /api/baselines); later runs of the configuration are tested against it.
function baselineControl(run) {
  const status = h('span', { role: 'status', dataset: { baselineStatus: '' } });
  const threshold = h('input', { type: 'number', name: 'threshold', min: '0', max: '1000', step: '0.5', value: '5', 'aria-label': 'Threshold (%)', class: 'narrow' });
  const button = h('button', { type: 'button', dataset: { markBaseline: String(run.id) }, onclick: async () => {
    button.disabled = true;
    try {
      const b = await request('/baselines', { method: 'POST', body: { run: run.id, threshold: Number(threshold.value) / 100 } });
      status.replaceChildren(` baseline #${b.id}${b.replaced ? ` (replaced #${b.replaced})` : ''}: `,
        h('a', { href: `#/trend/${b.id}` }, 'trend'));
    } catch (error) {
      status.textContent = ` ${error.message}`;
    } finally {
      button.disabled = false;
    }
  } }, 'Mark as baseline');
  return h('span', { class: 'baseline-control' }, button, ' threshold ', threshold, ' %', status);
}

export async function render(page, { params, signal }) {
  const [run, { samples }] = await Promise.all([get(`/runs/${params.id}`, signal), get(`/runs/${params.id}/samples`, signal)]);
  // Per-pass spreads live with each sample: one request per camera.
  const details = await Promise.all(samples.map((s) => get(`/samples/${s.id}`, signal)));
  const iqr = passIqr(run, details);
  const time = frameTime(run, details);
  const read = samples.reduce((sum, s) => sum + s.bytes_read, 0) / (samples.length || 1);
  const written = samples.reduce((sum, s) => sum + s.bytes_written, 0) / (samples.length || 1);
  const compareHref = `#/runs?scene=${encodeURIComponent(run.scene)}&resolution=${run.width}x${run.height}&device=${run.device_id}&select=${run.id}`;
  const app = appSource(run);
  const sourceText = app && (app.kind === 'replay' ? `replay of ${app.replay}` : `application: ${(app.command || []).join(' ')}`);

  page.append(
    h('h1', {}, `Run #${run.id}: ${fmt.variant(run)} · ${run.scene} · ${fmt.resolution(run)}`),
    h('ul', { class: 'meta' },
      optionsText(run.options) ? h('li', { dataset: { options: '' } }, `options: ${optionsText(run.options)}`) : null,
      h('li', {}, run.device),
      run.host ? h('li', { dataset: { host: run.host } }, 'on host ', h('a', { href: `#/runs?host=${encodeURIComponent(run.host)}` }, run.host)) : null,
      app ? h('li', { dataset: { source: app.kind } }, sourceText) : null,
      app ? h('li', {}, `frames ${app.skip_frames} to ${app.skip_frames + app.frames - 1}, timed under the layer`) : null,
      h('li', {}, `counting ${run.counting}`),
      run.footprint_block_bytes ? h('li', { dataset: { footprintBlock: String(run.footprint_block_bytes) } }, `footprint in ${run.footprint_block_bytes}-byte blocks`) : null,
      app ? null : h('li', {}, `${run.lights} lights`),
      h('li', {}, app ? `${run.sample_count} frames` : `${run.sample_count} samples`),
      h('li', {}, `${fmt.date(run.created_at)} UTC`),
      fmt.labels(run.labels) ? h('li', { dataset: { labels: '' } }, 'labels: ', Object.entries(run.labels).map(([k, v], i) =>
        [i ? ', ' : '', h('a', { href: `#/runs?label=${encodeURIComponent(`${k}=${v}`)}`, title: `runs labelled ${k}=${v}` }, `${k}=${v}`)])) : null,
      run.tally_commit ? h('li', { dataset: { build: '' } }, `tally ${run.tally_version} (${run.tally_commit})`) : null,
      h('li', {}, h('a', { href: `#/runs?capture=${run.capture}` }, `capture #${run.capture}`)),
      run.notes && run.notes.heatmap ? h('li', {}, h('a', { href: `#/heatmap?capture=${run.capture}`, dataset: { heatmapLink: String(run.capture) } }, 'its camera heatmap')) : null,
      h('li', {}, h('a', { href: compareHref }, 'compare with other runs at this scene and resolution')),
      h('li', {}, h('a', { href: `#/shader/${run.id}`, dataset: { shaderLink: '' } }, 'shaders: bytes per source line, draw and material')),
      app ? null : h('li', {}, baselineControl(run))),
    h('div', { class: 'tiles' },
      tile(app ? `GPU time per frame (under the layer, ${kStatisticText[time.statistic]})` : `Frame time (${kStatisticText[time.statistic]})`, fmt.ms(time.value), 'frame-ms'),
      ...(app ? [] : [
        tile('Counted frame', fmt.ms(run.mean_frame_ms_instrumented), 'frame-ms-instrumented'),
        tile('Overhead of counting', fmt.ratio(run.mean_overhead_ratio), 'overhead'),
        tile('Image error vs forward', fmt.imageError(run), 'image-error')]),
      tile('Read per frame', fmt.bytes(read), 'read'),
      tile('Written per frame', fmt.bytes(written), 'written'),
      ...(hasFootprint(run)
        ? [tile('Footprint per frame', fmt.bytes(run.mean_footprint_bytes), 'footprint'),
          tile('Reuse (requested / footprint)', run.mean_reuse === null ? '–' : reuseText(run.mean_reuse), 'reuse')]
        : []),
      tile('Render targets', fmt.bytes(run.render_target_bytes), 'render-targets')));

  const notes = notesSection(run);
  if (notes) page.append(h('h2', {}, 'Notes'), notes);
  page.append(h('h2', {}, 'Counter headroom'), headroomSection(run));

  // The byte charts draw requested bytes or the footprint: one switch for both sections.
  const traffic = h('div', {});
  const cameraBytes = h('div', {});
  const draw = (measure) => {
    destroyCharts(traffic);
    destroyCharts(cameraBytes);
    traffic.replaceChildren();
    cameraBytes.replaceChildren();
    traffic.append(bytesBreakdown(run, measure));
    passResourceCharts(traffic, run, measure);
    perSampleChart(cameraBytes, samples, details, measure);
  };
  page.append(h('h2', {}, 'Traffic per pass and resource'), measureSwitch('run-measure', hasFootprint(run),
    'This run has no footprint: capture it with "footprint" on (the capture form\'s Footprint select).', draw), traffic);
  page.append(h('h2', {}, app ? 'Per frame' : 'Per camera'), cameraBytes);
  draw('requested');
  frameTimeChart(page, samples, app);

  page.append(h('h2', {}, app ? 'GPU time per pass' : 'Frame time per pass'));
  const timing = h('div', { class: 'charts' });
  page.append(timing);
  passTimeChart(timing, run, iqr);
  page.append(passTable(run, iqr));  // below the chart, at full width: its columns need it

  page.append(h('h2', {}, 'Roofline'), rooflineSection(run, samples, Boolean(app), tile));

  page.append(h('h2', {}, 'Screenshots'), gallery(run, samples, signal));
  page.append(h('h2', {}, 'Samples'), sampleTable(samples));
  page.append(hasFootprint(run)
    ? h('div', {}, h('h2', {}, 'Lines: requested bytes and footprint'), lineTable(run))
    : h('details', {}, h('summary', {}, h('h2', { class: 'inline' }, 'Lines')), lineTable(run)));
  const extras = extrasSection(samples);
  if (extras) page.append(h('h2', {}, 'Technique measurements'), extras);
  page.append(h('details', {}, h('summary', {}, h('h2', { class: 'inline' }, 'Resources')), resourceTable(run)));
}

// The run view's roofline (docs/measurement.md, "Device ceilings",
// "Arithmetic per pass"): one point per pass for requested bytes and, where
// measured, one for footprint bytes, the two joined; each labelled with its
// pass; under the run's bandwidth and arithmetic ceilings, drawn whole (the
// axes reach past both ends). A point above a roof is flagged: a pass cannot
// beat the device's ceiling, so the ceilings were measured low (a busy
// machine) or the arithmetic is over-estimated; the view says which the data
// points to.
import { xyChart } from '../charts.js';
import { h, table } from '../dom.js';
import * as fmt from '../format.js';
import { kWorse, labelColor } from '../palette.js';

// "1.23 G": a rate or a count in a few characters.
export function si(v, unit) {
  if (v === null || v === undefined || !Number.isFinite(v)) return '–';
  const steps = [[1e12, 'T'], [1e9, 'G'], [1e6, 'M'], [1e3, 'k']];
  const [scale, prefix] = steps.find(([k]) => Math.abs(v) >= k) || [1, ''];
  return `${(v / scale).toPrecision(3)} ${prefix}${unit}`;
}

// A decade's tick: "0.01", "1", "100 M op/s" (no trailing zeros, one rule for every tick).
function decadeText(v, unit) {
  const steps = [[1e12, 'T'], [1e9, 'G'], [1e6, 'M'], [1e3, 'k']];
  const [scale, prefix] = steps.find(([k]) => v >= k) || [1, ''];
  const number = String(Number((v / scale).toPrecision(3)));
  return unit || prefix ? `${number} ${prefix}${unit}` : number;
}
const decades = (unit) => (v) => (Math.abs(Math.log10(v) - Math.round(Math.log10(v))) < 1e-9 ? decadeText(v, unit) : '');

// A point this far above its roof is flagged (timers and averages blur the rest).
const kAboveTolerance = 1.05;

// Per pass, its roofline averaged over the samples (extras.roofline.passes,
// stored by the capture): arithmetic, requested and footprint bytes and time,
// then intensity (ops per byte) and rate (ops per second) from the means.
function rooflinePasses(samples) {
  const byPass = new Map();
  for (const s of samples) {
    const passes = (s.extras && s.extras.roofline && s.extras.roofline.passes) || {};
    for (const [name, r] of Object.entries(passes)) {
      if (!byPass.has(name)) byPass.set(name, []);
      byPass.get(name).push(r);
    }
  }
  const mean = (list, key) => (list.every((r) => typeof r[key] === 'number') ? list.reduce((sum, r) => sum + r[key], 0) / list.length : null);
  return [...byPass.entries()].map(([name, list]) => {
    const ops = mean(list, 'arithmetic_ops');
    const bytes = mean(list, 'bytes_requested');
    const footprint = mean(list, 'footprint_bytes');
    const seconds = mean(list, 'gpu_ms') === null ? null : mean(list, 'gpu_ms') / 1e3;
    const per = (a, b) => (a !== null && b ? a / b : null);
    // "counted" (executed operations, the accumulate mode) where every sample counted them, else an estimate.
    const counted = list.every((r) => r.arithmetic === 'counted');
    return { name, ops, bytes, footprint, seconds, counted,
      intensity: per(ops, bytes), intensityFootprint: per(ops, footprint), rate: per(ops, seconds),
      bandwidth: per(bytes, seconds), bandwidthFootprint: per(footprint, seconds) };
  });
}

function arithmeticNote(passes) {
  if (passes.every((p) => p.counted)) return 'Arithmetic is counted as executed.';
  return 'Arithmetic is a static estimate (loops counted once) where it was not counted (modes other than accumulate).';
}

// The roof over intensity x: the bandwidth slope up to the ridge, flat after it.
const roof = (c, x) => Math.min(x * c.bandwidth_bytes_per_s, c.arithmetic_ops_per_s);
const plotted = (x, y) => x > 0 && y > 0 && Number.isFinite(x) && Number.isFinite(y);

function points(passes, c) {
  const point = (p, x, measure) => ({ x, y: p.rate, pass: p.name, measure, label: p.name,
    flag: Boolean(c) && p.rate > kAboveTolerance * roof(c, x) });
  const requested = passes.filter((p) => plotted(p.intensity, p.rate)).map((p) => point(p, p.intensity, 'requested'));
  const footprint = passes.filter((p) => plotted(p.intensityFootprint, p.rate)).map((p) => ({ ...point(p, p.intensityFootprint, 'footprint'), label: '' }));
  return { requested, footprint };
}

// Why points sit above a roof, in the data's words: the ceilings' own timing,
// and how the passes' bandwidth compares with the copy's.
function aboveNote(flagged, c) {
  if (!flagged.length) return null;
  const names = [...new Set(flagged.map((p) => p.pass))];
  const host = c.method && c.method.timing === 'host' ? ' The ceilings were timed on the host around each submission (the queue wrote no timestamps), which adds the submission\'s cost.' : '';
  return h('p', { class: 'panel worse', dataset: { rooflineAbove: String(names.length) } },
    `${names.join(', ')} ${names.length === 1 ? 'lies' : 'lie'} above a roof. A pass cannot run faster than the device's ceiling, so these ceilings are too low: `,
    'they were most likely measured while the machine was busy (on lavapipe the copy shares the host\'s cores with everything else), or the pass\'s arithmetic is over-estimated. ',
    'Measure the ceilings again on an idle machine before reading a fraction of peak.', host);
}

function rooflineTable(passes, c) {
  return table([
    { label: 'Pass', value: (p) => p.name },
    { label: 'Arithmetic', className: 'num', value: (p) => `${si(p.ops, 'op')}${p.counted ? '' : ' (estimate)'}` },
    { label: 'Bytes', className: 'num', value: (p) => fmt.bytes(p.bytes) },
    { label: 'Footprint', className: 'num', value: (p) => (p.footprint === null ? '–' : fmt.bytes(p.footprint)) },
    { label: 'Ops per byte', className: 'num', value: (p) => fmt.number(p.intensity) },
    { label: 'Ops per footprint byte', className: 'num', value: (p) => fmt.number(p.intensityFootprint) },
    { label: 'Ops/s', className: 'num', value: (p) => si(p.rate, 'op/s') },
    { label: 'Bandwidth', className: 'num', value: (p) => si(p.bandwidth, 'B/s') },
    { label: 'Of peak bandwidth', className: 'num', value: (p) => h('span', { dataset: { fraction: p.bandwidth !== null && c ? String(p.bandwidth / c.bandwidth_bytes_per_s) : '' } },
      p.bandwidth !== null && c ? fmt.percent(p.bandwidth / c.bandwidth_bytes_per_s) : '–') },
    { label: 'Above the roof', value: (p) => {
      const above = c && plotted(p.intensity, p.rate) && p.rate > kAboveTolerance * roof(c, p.intensity);
      return h('span', { class: above ? 'worse' : null, dataset: { above: String(Boolean(above)) } }, c ? (above ? 'yes' : 'no') : '–');
    } },
  ], passes, { 'aria-label': 'Roofline', dataset: { table: 'roofline' } });
}

// The datasets: the points, a dotted line from each pass's requested point to
// its footprint point, and the two ceilings over the whole x range.
function datasets(req, foot, c, range) {
  const flagBorder = (list, color) => list.map((p) => (p.flag ? kWorse : color));
  const reqColor = labelColor('requested bytes'), footColor = labelColor('footprint bytes');
  const out = [{ label: 'requested bytes', data: req, pointRadius: 5, pointLabels: true,
    pointBorderColor: flagBorder(req, reqColor), pointBorderWidth: req.map((p) => (p.flag ? 3 : 1)) }];
  if (foot.length) {
    out.push({ label: 'footprint bytes', data: foot, pointRadius: 5, pointStyle: 'triangle',
      pointBorderColor: flagBorder(foot, footColor), pointBorderWidth: foot.map((p) => (p.flag ? 3 : 1)) });
    for (const f of foot) {
      const r = req.find((p) => p.pass === f.pass);
      if (r) out.push({ label: `${f.pass}: requested to footprint`, legend: false, join: true, showLine: true, pointRadius: 0, borderWidth: 1,
        borderDash: [2, 3], borderColor: '#8a8f99', backgroundColor: '#8a8f99', data: [{ x: r.x, y: r.y }, { x: f.x, y: f.y }] });
    }
  }
  if (c) {
    const ridge = c.arithmetic_ops_per_s / c.bandwidth_bytes_per_s;
    out.push(
      { label: 'bandwidth ceiling', ceiling: true, showLine: true, pointRadius: 0, borderWidth: 2, borderColor: '#444', backgroundColor: '#444',
        data: [{ x: range.lo, y: range.lo * c.bandwidth_bytes_per_s }, { x: ridge, y: c.arithmetic_ops_per_s }] },
      { label: 'arithmetic ceiling', ceiling: true, showLine: true, pointRadius: 0, borderWidth: 2, borderDash: [6, 4], borderColor: '#888', backgroundColor: '#888',
        data: [{ x: ridge, y: c.arithmetic_ops_per_s }, { x: range.hi, y: c.arithmetic_ops_per_s }] });
  }
  return out;
}

// Axes that hold the points and both ceilings whole, with a margin, so that no
// line runs into the plot's edge.
function axisRange(all, c) {
  const xs = all.map((p) => p.x), ys = all.map((p) => p.y);
  if (!c) return { lo: Math.min(...xs) / 3, hi: Math.max(...xs) * 3, ylo: Math.min(...ys) / 3, yhi: Math.max(...ys) * 3 };
  const ridge = c.arithmetic_ops_per_s / c.bandwidth_bytes_per_s;
  const lo = Math.min(ridge, ...xs) / 10, hi = Math.max(ridge, ...xs) * 10;
  return { lo, hi, ylo: Math.min(lo * c.bandwidth_bytes_per_s, ...ys) / 2, yhi: Math.max(c.arithmetic_ops_per_s, ...ys) * 3 };
}

// tile(label, value, key): the run view's summary tile.
export function rooflineSection(run, samples, application, tile) {
  const passes = rooflinePasses(samples);
  const c = run.ceilings;
  if (!passes.length) {
    return h('p', { class: 'panel muted', dataset: { roofline: 'none' } }, application
      ? 'Not measured for an application captured under the layer.'
      : 'Not recorded for this run (captured before the roofline was measured).');
  }
  const box = h('div', { dataset: { roofline: '' } });
  const { requested, footprint } = points(passes, c);
  const all = [...requested, ...footprint];
  const range = all.length ? axisRange(all, c) : null;
  const chart = h('div', { class: 'charts' });
  box.append(chart);
  xyChart(chart, {
    id: 'roofline',
    title: 'Roofline',
    caption: `${c
      ? `per pass, averaged over the samples, labelled with its pass (a dotted line joins a pass's requested and footprint points); ceilings measured at the capture's start: ${si(c.bandwidth_bytes_per_s, 'B/s')}, ${si(c.arithmetic_ops_per_s, 'op/s')}; a point ringed in red lies above a roof.`
      : 'per pass, averaged over the samples; no ceilings were measured for this capture.'} ${arithmeticNote(passes)}`,
    // A log axis ticks 1-9 per decade: label the decades only.
    x: { title: 'arithmetic intensity (ops per byte)', type: 'logarithmic', format: decades(''), min: range?.lo, max: range?.hi },
    y: { title: 'ops per second (op/s)', type: 'logarithmic', format: decades('op/s'), min: range?.ylo, max: range?.yhi },
    datasets: datasets(requested, footprint, c, range || { lo: 1, hi: 1 }),
    table: rooflineTable(passes, c),
    tooltip: (ctx) => (ctx.dataset.ceiling || ctx.dataset.join
      ? `${ctx.dataset.label}`
      : `${ctx.raw.pass} (${ctx.dataset.label}): ${fmt.number(ctx.raw.x)} ops/byte, ${si(ctx.raw.y, 'op/s')}${ctx.raw.flag ? ', above the roof' : ''}`),
  });
  box.append(aboveNote(all.filter((p) => p.flag), c) || '');
  const tiles = c ? h('div', { class: 'tiles' },
    tile('Bandwidth ceiling', si(c.bandwidth_bytes_per_s, 'B/s'), 'ceiling-bandwidth'),
    tile('Arithmetic ceiling', si(c.arithmetic_ops_per_s, 'op/s'), 'ceiling-arithmetic'),
    tile('Ridge', `${fmt.number(c.ridge_intensity)} ops/byte`, 'ceiling-ridge')) : null;
  return h('div', {}, tiles, box);
}

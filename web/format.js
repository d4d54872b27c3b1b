// Number and label formatting shared by the views. Values keep their unit in
// the text ("1.25 MiB", "3.40 ms"); tables that tests read also carry the raw
// number in a data-value attribute.

export function bytes(n) {
  if (n === null || n === undefined) return '–';
  const units = ['B', 'KiB', 'MiB', 'GiB', 'TiB'];
  let v = Math.abs(n);
  let u = 0;
  while (v >= 1024 && u < units.length - 1) {
    v /= 1024;
    ++u;
  }
  const text = u === 0 ? String(Math.round(v)) : v.toFixed(v < 10 ? 2 : v < 100 ? 1 : 0);
  return `${n < 0 ? '−' : ''}${text} ${units[u]}`;
}

// Milliseconds: three decimals below 10 ms, two from 10 ms, by magnitude, so
// that a negative time gets as many decimals as a positive one (one minus sign, −).
export function ms(n) {
  if (n === null || n === undefined) return '–';
  const v = Math.abs(n);
  return `${n < 0 ? '−' : ''}${v.toFixed(v < 10 ? 3 : 2)} ms`;
}
export const ratio = (n) => (n === null || n === undefined ? '–' : `×${n.toFixed(3)}`);
// Percentages keep two significant digits below 1 % (0.052 %), one decimal above.
export function percent(n) {
  if (n === null || n === undefined) return '–';
  const p = 100 * n;
  const digits = p === 0 ? 1 : Math.max(1, Math.min(6, 1 - Math.floor(Math.log10(Math.abs(p)))));
  return `${p.toFixed(digits).replace('-', '−')} %`;
}
export const psnr = (n) => (n === null || n === undefined ? '–' : `${n.toFixed(1)} dB`);
// Grouped digits, one minus sign (toLocaleString writes a hyphen): "−1,696".
export const count = (n) => (n === null || n === undefined ? '–' : Math.round(n).toLocaleString('en-US').replace('-', '−'));

// A signed difference in the value's own format: "+1.20 MiB", "−0.40 ms".
export function delta(n, fmt) {
  if (n === null || n === undefined) return '–';
  const text = fmt(Math.abs(n)).replace(/^−/, '');
  return n === 0 ? text : `${n > 0 ? '+' : '−'}${text}`;
}

export const resolution = (run) => `${run.width}×${run.height}`;

// "2026-11-21 06:30" from the API's UTC timestamps (shown in UTC, as stored).
export const date = (iso) => (iso ? iso.slice(0, 16).replace('T', ' ') : '–');

// Time since an event, as the CLI says it: "3 s ago" below 90 s, "12 min ago"
// below 90 min, "5 h ago" below 48 h, else "3 d ago" (negative: clocks apart, 0).
export function ago(seconds) {
  if (seconds === null || seconds === undefined) return '–';
  const s = Math.max(0, seconds);
  if (s < 90) return `${Math.floor(s)} s ago`;
  if (s < 90 * 60) return `${Math.floor(s / 60)} min ago`;
  if (s < 48 * 3600) return `${Math.floor(s / 3600)} h ago`;
  return `${Math.floor(s / 86400)} d ago`;
}

// A run's variant label: "visbuffer barycentrics=float32", or the renderer
// for a run without options (and for servers from before variants).
export const variant = (run) => run.variant || run.renderer;

// "deferred · atrium · 320×180 (#12)": how a run is named in legends.
export const runLabel = (run) => `${variant(run)} · ${run.scene} · ${resolution(run)}${run.counting !== 'exact' ? ` · ${run.counting}` : ''}${run.footprint_block_bytes ? ` + footprint ${run.footprint_block_bytes}` : ''} (#${run.id})`;

// The run's image error against forward in a few words.
export function imageError(run) {
  const e = run.image_error;
  if (!e) return '–';
  if (e.identical === e.samples) return 'identical';
  return psnr(e.mean_psnr);
}

// A capture's labels as "commit=4f2a9c1, branch=main"; '' for none.
export const labels = (l) => Object.entries(l || {}).map(([k, v]) => `${k}=${v}`).join(', ');

// One minus sign everywhere: U+2212, never the hyphen that toFixed writes.
const minus = (text) => text.replace(/^-/, '−');

// A number with fixed decimals: "−12.0", "3.50".
export const fixed = (n, digits) => (n === null || n === undefined ? '–' : minus(n.toFixed(digits)));

// A signed number: "+0.52", "−1.00", "0.00".
export const signed = (n, digits) => (n === null || n === undefined ? '–' : `${n > 0 ? '+' : ''}${fixed(n, digits)}`);

// A plain number in a few significant digits, never in e-notation: 0.0123,
// 4.56, 1,230, 3,800,000,000 (grouped), so that 1e6 and 100000 never meet.
export function number(n, digits = 3) {
  if (n === null || n === undefined || !Number.isFinite(n)) return '–';
  const rounded = Number(n.toPrecision(digits));
  return minus(Math.abs(rounded) >= 1000 ? Math.round(rounded).toLocaleString('en-US') : String(rounded));
}

// A p-value: four decimals, "< 0.0001" below them.
export const pValue = (p) => (p === null || p === undefined ? '–' : p < 1e-4 ? '< 0.0001' : p.toFixed(4));

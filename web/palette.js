// One colour per renderer or variant, keyed by its label, in every view
// (web/palette.json holds the colours so that the command line can use the
// same ones). The built-in renderers are pinned; any other label (a variant
// with options, an application, a counting mode) is hashed into a series
// chosen to stay apart from each other and from the pinned colours. Red and
// green are kept for worse and better; read and written are neutral.
import palette from './palette.json' with { type: 'json' };

export const kPalette = palette;
export const kRead = palette.read;
export const kWritten = palette.written;
export const kBetter = palette.better;
export const kWorse = palette.worse;
export const kSame = palette.same;

// FNV-1a, 32 bits, over the label's UTF-8 bytes: the same index in any language.
export function fnv1a(text) {
  let hash = 0x811c9dc5;
  for (const byte of new TextEncoder().encode(text)) {
    hash ^= byte;
    hash = Math.imul(hash, 0x01000193) >>> 0;
  }
  return hash;
}

// "#rrggbb" with an alpha as "rgba(r, g, b, a)".
export function withAlpha(hex, alpha) {
  if (alpha === 1) return hex;
  const n = parseInt(hex.slice(1), 16);
  return `rgba(${n >> 16}, ${(n >> 8) & 255}, ${n & 255}, ${alpha})`;
}

// The colour of a label: pinned, else hashed into the series.
export function labelColor(label, alpha = 1) {
  const text = String(label);
  const hex = palette.pinned[text] ?? palette.series[fnv1a(text) % palette.series.length];
  return withAlpha(hex, alpha);
}

// The n-th colour of the series, for things without a label of their own
// (a chart's only dataset).
export const seriesColor = (i, alpha = 1) => withAlpha(palette.series[i % palette.series.length], alpha);

// Worse (red), better (green) or neither (grey), for a change whose sign says
// which: `higherIsBetter` for reuse and the like, else lower is better (time, bytes).
export function changeClass(delta, higherIsBetter = false) {
  if (delta === null || delta === undefined || delta === 0 || Number.isNaN(delta)) return '';
  return (delta > 0) === higherIsBetter ? 'better' : 'worse';
}

// The capture form's live cost: how many samples and frames a spec renders,
// its pixel-frames (the server's cost measure and bound, docs/api.md
// "Limits"), and how long that took on this daemon's host lately; and which
// fields apply to the choices made (the others are disabled).
import { h } from '../dom.js';
import * as fmt from '../format.js';

const kMaxCost = 1e11;      // the server's default --max-cost
const kAutoCameras = 10;   // "auto": 10 cameras per scene
const kRecentJobs = 10;    // the estimate's window

const num = (v) => (typeof v === 'number' && Number.isFinite(v) && v > 0 ? v : null);

// Cameras per scene of a spec: 10 for auto, a heatmap's poses (cells x yaws, rings x segments).
function camerasPerScene(spec) {
  const m = spec.heatmap;
  if (!m) return Array.isArray(spec.cameras) ? spec.cameras.length : kAutoCameras;
  if (m.layout === 'floor') return (num(m.cells?.[0]) ?? 0) * (num(m.cells?.[1]) ?? 0) * (num(m.yaws) ?? 1);
  return (num(m.rings) ?? 0) * (num(m.segments) ?? 0);
}

// {variants, scenes, cameras, resolutions, samples, frames, pixelFrames}, or null for a spec that is not a capture of renderers.
export function costOf(spec) {
  if (!spec || spec.sweep || spec.application || spec.replay) return null;
  const variants = (spec.renderers || []).length + (spec.workloads || []).length;
  const scenes = (spec.scenes || ['atrium']).length;
  const resolutions = (spec.resolutions || []).filter((r) => Array.isArray(r) && num(r[0]) && num(r[1]));
  const cameras = camerasPerScene(spec);
  const frames = num(spec.frames) ?? 0;
  const samples = variants * scenes * cameras * resolutions.length;
  const pixels = resolutions.reduce((sum, [w, hgt]) => sum + w * hgt, 0);
  return { variants, scenes, cameras, resolutions: resolutions.length, samples, frames, pixelFrames: variants * scenes * cameras * frames * pixels };
}

// A capture's time as a per-sample cost (building, reference images,
// counting) plus a per-pixel-frame cost, fitted by least squares over the
// newest finished captures of the host that ran the newest one. Where the two
// cannot be told apart (one capture, or a negative term), the per-sample term
// alone. {perSample, perPixelFrame, host, jobs}, or null without captures.
export function captureRate(jobs) {
  const done = jobs.filter((j) => j.status === 'done' && j.started_at && j.finished_at && costOf(j.spec)?.samples);
  if (!done.length) return null;
  const host = done[0].host;
  const points = done.filter((j) => j.host === host).slice(0, kRecentJobs).map((j) => {
    const c = costOf(j.spec);
    return { s: c.samples, p: c.pixelFrames, t: (Date.parse(j.finished_at) - Date.parse(j.started_at)) / 1000 };
  }).filter((x) => x.t > 0);
  if (!points.length) return null;
  const sum = (f) => points.reduce((acc, x) => acc + f(x), 0);
  const [ss, pp, sp, ts, tp] = [sum((x) => x.s * x.s), sum((x) => x.p * x.p), sum((x) => x.s * x.p), sum((x) => x.t * x.s), sum((x) => x.t * x.p)];
  const det = ss * pp - sp * sp;
  let perSample = (ts * pp - tp * sp) / det, perPixelFrame = (tp * ss - ts * sp) / det;
  if (!(det > 1e-9 * ss * pp) || perSample < 0 || perPixelFrame < 0) [perSample, perPixelFrame] = [ts / ss, 0];
  return { perSample, perPixelFrame, host, jobs: points.length };
}

// "about 40 s", "about 3 min", "about 1.5 h".
function duration(seconds) {
  if (seconds < 90) return `about ${Math.max(1, Math.round(seconds))} s`;
  if (seconds < 5400) return `about ${Math.round(seconds / 60)} min`;
  return `about ${(seconds / 3600).toFixed(1)} h`;
}

export function costText(spec, rate) {
  const c = costOf(spec);
  if (!c) return [];
  const over = c.pixelFrames > kMaxCost;
  return [
    h('strong', { dataset: { samples: String(c.samples), frames: String(c.samples * c.frames), pixelFrames: String(c.pixelFrames) } },
      `${fmt.count(c.samples)} samples × ${fmt.count(c.frames)} frames = ${fmt.count(c.samples * c.frames)} frames`),
    ` (${c.variants} variant${c.variants === 1 ? '' : 's'} × ${c.scenes} scene${c.scenes === 1 ? '' : 's'} × ${c.cameras} camera${c.cameras === 1 ? '' : 's'} × ${c.resolutions} resolution${c.resolutions === 1 ? '' : 's'}); `,
    h('span', { class: over ? 'worse' : null }, `${fmt.count(c.pixelFrames)} pixel-frames${over ? `, over the server's default bound of ${fmt.count(kMaxCost)}` : ''}`),
    rate && c.samples
      ? h('span', { dataset: { estimate: String(rate.perSample * c.samples + rate.perPixelFrame * c.pixelFrames) } },
        `; ${duration(rate.perSample * c.samples + rate.perPixelFrame * c.pixelFrames)} on ${rate.host || 'this host'}, from its last ${rate.jobs} capture${rate.jobs === 1 ? '' : 's'}`)
      : h('span', { dataset: { estimate: '' } }, '; no finished capture yet to estimate the time from'),
    '.',
  ];
}

// Disables the fields that do not apply: the sampling N unless counting is
// sampled, the heatmap grid unless the cameras are a heatmap, its yaws unless
// it is a floor grid. A disabled field is left out of the spec.
export function applicable(form) {
  const mode = form.querySelector('select[name="cameras_mode"]')?.value;
  const counting = form.querySelector('select[name="counting"]')?.value;
  const set = (name, on, why) => {
    const input = form.querySelector(`[name="${name}"]`);
    if (!input) return;
    input.disabled = !on;
    input.title = on ? '' : why;
    input.closest('.field')?.classList.toggle('not-applicable', !on);
  };
  set('sample_n', counting === 'sampled', 'applies to sampled counting only');
  set('heatmap_grid', mode === 'floor' || mode === 'sphere', 'applies to a heatmap (choose one under Cameras)');
  set('heatmap_yaws', mode === 'floor', 'applies to a floor grid heatmap only');
}

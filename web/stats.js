// One statistic for a frame time everywhere: the median of the run's frames
// (every uninstrumented frame of every camera, pooled), computed here from the
// per-frame times the API serves, so that the run tiles, compare's totals and
// the trend agree. Runs stored before per-frame times have none: the API's
// mean over cameras of each camera's median stands in, labelled as such.
import { get } from './api.js';

export function median(values) {
  const v = values.filter((x) => typeof x === 'number' && Number.isFinite(x)).sort((a, b) => a - b);
  if (!v.length) return null;
  const m = v.length >> 1;
  return v.length % 2 ? v[m] : (v[m - 1] + v[m]) / 2;
}

// The pooled median of samples' frame_ms_frames (GET /api/samples/{id}), or null.
export function pooledFrameMedian(details) {
  if (!details.length || details.some((d) => !Array.isArray(d.frame_ms_frames) || !d.frame_ms_frames.length)) return null;
  return median(details.flatMap((d) => d.frame_ms_frames));
}

// {value, statistic}: 'median' of the frames where they are stored, else 'mean'
// (the API's mean over cameras of each camera's median).
export function frameTime(run, details) {
  const m = details ? pooledFrameMedian(details) : null;
  if (m !== null) return { value: m, statistic: 'median' };
  if (typeof run.frame_ms_median === 'number') return { value: run.frame_ms_median, statistic: 'median' };
  return { value: run.mean_frame_ms, statistic: 'mean' };
}

export const kStatisticText = {
  median: 'median of all frames',
  mean: 'mean of the cameras\' medians',
};

// A run's samples with their per-frame times (one request per sample).
export async function sampleDetails(runId, signal) {
  const { samples } = await get(`/runs/${runId}/samples`, signal);
  return Promise.all(samples.map((s) => get(`/samples/${s.id}`, signal)));
}

// New capture (#/capture): a form that builds a capture spec
// (docs/result-schema.md) and POSTs it; the server validates it, and its error
// (message and field) is shown beside the field it names. A started capture's
// progress is polled until it finishes; below, the list of captures with their
// status, the host that holds or last ran each, its attempts (and why the
// earlier ones ended), why a queued one waits, and errors. A second form
// takes a spec as JSON, posted to the same route: a stability sweep
// ({"sweep": NAME, ...}, docs/result-schema.md "Sweep results"; a finished
// sweep links to its view), or an application or a replay under the Vulkan
// layer ({"application": {...}}, {"replay": FILE}; docs/layer.md), where the
// daemon allows them.
import { ApiError, get, request } from '../api.js';
import { h } from '../dom.js';
import * as fmt from '../format.js';
import { poll } from '../poll.js';
import { applicable, captureRate, costText } from './capture_cost.js';

const kPollMs = 500;      // progress of the capture just started
const kListPollMs = 2000;  // the job list, while any job is queued or running
const kFinished = ['done', 'failed', 'cancelled'];
// A first capture that finishes in a minute or so on a laptop, not 5 renderers
// x 10 cameras x 20 frames: the two renderers the founding study compares.
const kDefaultRenderers = ['deferred', 'visbuffer'];
const kDefaultFrames = 10;

// "320x180, 640x360" -> [[320, 180], [640, 360]]. A token that is not WxH goes
// to the server as it is, so that the server's message names it.
function parseResolutions(text) {
  return text.split(/[\s,;]+/).filter(Boolean).map((token) => {
    const m = /^(\d+)[x×](\d+)$/.exec(token);
    return m ? [Number(m[1]), Number(m[2])] : token;
  });
}

// A number when the text is one; else the text, for the server to refuse by name.
const numberOr = (text) => (text.trim() !== '' && Number.isFinite(Number(text)) ? Number(text) : text);

// Each checked renderer row: its name, or {renderer, options} where an option
// is set away from its default (the server drops defaults anyway).
// `list`: "renderers" or "workloads" (the compute workloads' rows).
function variantsOf(form, list = 'renderers') {
  return [...form.querySelectorAll('[data-variant-row]')].filter((row) => (row.dataset.list || 'renderers') === list && row.querySelector('input[name="renderers"]').checked).map((row) => {
    const options = {};
    for (const control of row.querySelectorAll('[data-option]')) {
      const def = JSON.parse(control.dataset.default);
      const value = control.dataset.kind === 'range' ? numberOr(control.value) : JSON.parse(control.value);
      if (JSON.stringify(value) !== JSON.stringify(def)) options[control.dataset.option] = value;
    }
    const name = row.dataset.variantRow;
    return Object.keys(options).length ? { renderer: name, options } : name;
  });
}

// One renderer's row: its checkbox and a select per option it takes (the
// option table of GET /api/renderers), the default preselected; "+ variant"
// adds another row of the same renderer.
function variantRow(renderer, optionDefs, checked, list = 'renderers') {
  const own = optionDefs.filter((o) => o.renderers.includes(renderer));
  const controls = own.map((o) => {
    const attrs = { dataset: { option: o.name, default: JSON.stringify(o.default), kind: o.range ? 'range' : 'values' }, 'aria-label': `${renderer} ${o.name}`, title: o.description };
    const control = o.range
      ? h('input', { ...attrs, value: String(o.default), size: 6, inputmode: 'decimal' })
      : h('select', attrs, o.values.map((v) => h('option', { value: JSON.stringify(v), selected: JSON.stringify(v) === JSON.stringify(o.default) }, typeof v === 'string' ? v : JSON.stringify(v))));
    return h('label', { class: 'option' }, ` ${o.name} `, control);
  });
  const row = h('div', { class: 'variant-row', dataset: { variantRow: renderer, list } },
    h('label', {}, h('input', { type: 'checkbox', name: 'renderers', value: renderer, checked }), ' ', renderer), controls);
  if (own.length) {
    row.append(' ', h('button', { type: 'button', class: 'secondary', dataset: { addVariant: renderer },
      onclick: () => row.after(variantRow(renderer, optionDefs, true, list)) }, '+ variant'));
  }
  return row;
}

// "auto", or a camera heatmap (docs/measurement.md, "Camera heatmaps"): a
// floor grid "CxR" with yaws per cell, or a sphere "RINGSxSEGMENTS".
function camerasOf(data) {
  const mode = data.get('cameras_mode');
  if (mode !== 'floor' && mode !== 'sphere') return { cameras: 'auto' };
  const [a, b] = String(data.get('heatmap_grid')).split(/[x×,]/).map((v) => numberOr(v.trim()));
  return mode === 'floor'
    ? { heatmap: { layout: 'floor', cells: [a, b], yaws: numberOr(data.get('heatmap_yaws')) } }
    : { heatmap: { layout: 'sphere', rings: a, segments: b } };
}

function specOf(form) {
  const data = new FormData(form);
  const counting = data.get('counting') === 'sampled' ? `sampled:${data.get('sample_n').trim()}` : data.get('counting');
  const renderers = variantsOf(form);
  const workloads = variantsOf(form, 'workloads');
  return {
    ...(renderers.length || !workloads.length ? { renderers } : {}),
    ...(workloads.length ? { workloads } : {}),
    scenes: [...data.getAll('scenes'), ...data.getAll('gltf').map((path) => ({ gltf: path }))],
    resolutions: parseResolutions(data.get('resolutions')),
    ...camerasOf(data),
    frames: numberOr(data.get('frames')),
    ...(data.get('counted_frames').trim() !== '' ? { counted_frames: numberOr(data.get('counted_frames')) } : {}),
    counting,
    lights: numberOr(data.get('lights')),
    // Footprint: off leaves the key out (the server's default); else the block size.
    ...(data.get('footprint') !== 'off' ? { footprint: Number(data.get('footprint')) } : {}),
  };
}

// A small depth-reconstruction sweep: a few seconds on lavapipe.
const kExampleSweep = {
  sweep: 'depth-reconstruction',
  near: [0.01],
  far: [1000],
  distances: [3, 30, 300],
  resolution: [32, 18],
  threshold: { relative: 0.001 },
};

function sweepForm(onSubmit) {
  const text = h('textarea', { name: 'sweep_spec', class: 'spec', rows: 9, spellcheck: 'false', 'aria-label': 'Sweep spec (JSON)' });
  text.value = JSON.stringify(kExampleSweep, null, 2);
  const form = h('form', { class: 'sweep-form', novalidate: true, 'aria-label': 'New stability sweep' },
    h('label', { class: 'field', dataset: { field: 'sweep_spec' } },
      h('span', {}, 'Spec (JSON): a stability sweep ("sweep" names it), or an application under the Vulkan layer ({"application": {"command": ["vkcube"], "frames": 10}}) or a GFXReconstruct replay ({"replay": "/path/capture.gfxr"}) where the daemon allows them; the server names any field it refuses'), text),
    h('button', { type: 'submit' }, 'Start'),
    h('div', { class: 'form-error', role: 'alert' }));
  form.addEventListener('submit', (e) => {
    e.preventDefault();
    let spec;
    try {
      spec = JSON.parse(text.value);
    } catch (error) {
      clearError(form);
      form.querySelector('.form-error').replaceChildren(h('div', { class: 'panel error', dataset: { code: 'bad_json' } },
        h('strong', {}, 'Not valid JSON: '), h('span', { class: 'message' }, error.message)));
      return;
    }
    onSubmit(spec);
  });
  return form;
}

// "vkcube --c 100" -> ["vkcube", "--c", "100"]; single or double quotes keep spaces.
export function splitCommand(text) {
  const words = [];
  let word = null, quote = null;
  for (const c of text) {
    if (quote) {
      if (c === quote) quote = null;
      else word += c;
    } else if (c === '"' || c === "'") {
      quote = c;
      word = word ?? '';
    } else if (/\s/.test(c)) {
      if (word !== null) words.push(word);
      word = null;
    } else {
      word = (word ?? '') + c;
    }
  }
  if (quote) throw new Error(`unclosed ${quote}`);
  if (word !== null) words.push(word);
  return words;
}

// An application (or a GFXReconstruct replay) under the Vulkan layer
// (docs/layer.md): the spec from fields; the server checks every one.
function appForm(onSubmit) {
  const field = (label, control, hint) => h('label', { class: 'field', dataset: { field: control.name } }, h('span', {}, label), control, hint ? h('small', { class: 'muted' }, hint) : null);
  const command = h('input', { name: 'application.command', placeholder: 'vkcube --c 100', size: 40, spellcheck: 'false' });
  const replay = h('input', { name: 'replay', placeholder: '/srv/traces/scene.gfxr', size: 40, spellcheck: 'false' });
  const frames = h('input', { name: 'application.frames', type: 'number', min: 1, max: 1000, value: 10 });
  const skip = h('input', { name: 'application.skip_frames', type: 'number', min: 0, value: 0 });
  const submits = h('input', { name: 'application.frame_submits', type: 'number', min: 0, value: 0 });
  const display = h('select', { name: 'application.display' }, h('option', { value: 'none' }, 'none'), h('option', { value: 'xvfb' }, 'xvfb (a virtual X server)'));
  const name = h('input', { name: 'application.name', placeholder: 'from the application', size: 16 });
  const form = h('form', { class: 'app-form', novalidate: true, 'aria-label': 'New application capture' },
    field('Command', command, 'the program and its arguments, run on the daemon\'s host: the daemon needs --allow-applications, the program must lie in its --application-root, and the token must be its application token'),
    field('Or replay', replay, 'a GFXReconstruct capture file on the daemon\'s host, replayed by gfxrecon-replay'),
    h('div', { class: 'form-grid' },
      field('Frames', frames), field('Skip frames', skip, 'frames to let pass first'),
      field('Submissions per frame', submits, '0: a frame ends at present; N: for applications that never present'),
      field('Display', display), field('Name', name)),
    h('button', { type: 'submit' }, 'Start'),
    h('div', { class: 'form-error', role: 'alert' }));
  form.addEventListener('submit', (e) => {
    e.preventDefault();
    clearError(form);
    let argv;
    try {
      argv = splitCommand(command.value.trim());
    } catch (error) {
      form.querySelector('.form-error').replaceChildren(h('div', { class: 'panel error', dataset: { code: 'bad_command' } },
        h('strong', {}, 'Command: '), h('span', { class: 'message' }, error.message)));
      return;
    }
    const common = { frames: Number(frames.value), skip_frames: Number(skip.value), display: display.value };
    if (replay.value.trim() && !argv.length) {
      onSubmit({ replay: replay.value.trim(), ...common });
      return;
    }
    const application = { command: argv, ...common };
    if (Number(submits.value) > 0) application.frame_submits = Number(submits.value);
    if (name.value.trim()) application.name = name.value.trim();
    onSubmit({ application });
  });
  return form;
}

function captureForm(renderers, optionDefs, scenes, onSubmit, workloads = []) {
  const choice = (name, value, checked) => h('label', {}, h('input', { type: 'checkbox', name, value, checked }), ' ', value);
  const field = (label, control, hint, name = control.name) => h('label', { class: 'field', dataset: { field: name } }, h('span', {}, label), control, hint ? h('small', { class: 'muted' }, hint) : null);
  const samplingN = h('input', { name: 'sample_n', value: '4', size: 4, 'aria-label': 'Sampling tile size N' });
  // The server's modes, the default (accumulate) first.
  const counting = h('select', { name: 'counting' },
    ['accumulate', 'accumulate:subgroup', 'accumulate:lane', 'exact', 'subgroup', 'sampled'].map((m) => h('option', { value: m }, m === 'sampled' ? 'sampled:N' : m)));
  const gltf = scenes.gltf.flatMap((folder) => folder.files);
  const form = h('form', { class: 'capture-form', novalidate: true, 'aria-label': 'New capture' },
    h('fieldset', { dataset: { field: 'renderers' } }, h('legend', {}, 'Renderers'),
      h('div', { class: 'variants' }, renderers.map((r) => variantRow(r, optionDefs, kDefaultRenderers.includes(r) || !renderers.some((x) => kDefaultRenderers.includes(x)))))),
    workloads.length
      ? h('fieldset', { dataset: { field: 'workloads' } }, h('legend', {}, 'Workloads (compute: scene bounds and cameras only)'),
        h('div', { class: 'variants' }, workloads.map((w) => variantRow(w, optionDefs, false, 'workloads'))))
      : null,
    h('fieldset', { dataset: { field: 'scenes' } }, h('legend', {}, 'Scenes'),
      h('div', { class: 'choices' },
        scenes.procedural.map((s) => choice('scenes', s.name, s.name === 'atrium')),
        gltf.map((path) => choice('gltf', path, false)))),
    h('div', { class: 'form-grid' },
      field('Resolutions', h('input', { name: 'resolutions', value: '320x180', required: true }), 'WxH, comma-separated'),
      field('Frames per sample', h('input', { name: 'frames', value: String(kDefaultFrames), inputmode: 'numeric' }), 'timed, uninstrumented'),
      field('Counted frames', h('input', { name: 'counted_frames', value: '', placeholder: '2', inputmode: 'numeric' }), 'instrumented frames per sample; left blank, the server counts 2 (never more than the frames)'),
      field('Counting', counting),
      h('label', { class: 'field', dataset: { field: 'counting' } }, h('span', {}, 'N (sampled only)'), samplingN),
      field('Lights', h('input', { name: 'lights', value: '400', inputmode: 'numeric' }), '0 to 400'),
      field('Footprint', h('select', { name: 'footprint' }, [['off', 'off'], ['32', '32 B blocks'], ['64', '64 B blocks'], ['128', '128 B blocks']]
        .map(([value, text]) => h('option', { value, selected: value === 'off' }, text))),
      'distinct bytes touched per line, beside the requested bytes; counted frames cost more'),
      h('label', { class: 'field', dataset: { field: 'heatmap' } }, h('span', {}, 'Cameras'),
        h('select', { name: 'cameras_mode' }, [['auto', 'auto: 10 per scene'], ['floor', 'heatmap: floor grid'], ['sphere', 'heatmap: sphere']]
          .map(([value, text]) => h('option', { value, selected: value === 'auto' }, text)))),
      field('Heatmap grid', h('input', { name: 'heatmap_grid', value: '8x4' }), 'floor: cells along x × z; sphere: rings × segments', 'heatmap.cells'),
      field('Heatmap yaws', h('input', { name: 'heatmap_yaws', value: '4', inputmode: 'numeric' }), 'floor: directions per cell', 'heatmap.yaws')),
    h('div', { class: 'start-row' }, h('button', { type: 'submit' }, 'Start capture'),
      h('p', { class: 'cost', role: 'status', dataset: { cost: '' } })),
    h('div', { class: 'form-error', role: 'alert' }));
  form.addEventListener('submit', (e) => {
    e.preventDefault();
    onSubmit(specOf(form));
  });
  return form;
}

// The server's error, shown at the top of the form and beside the field it names
// ("resolutions[0][1]" belongs to the resolutions input).
function showError(form, error) {
  clearError(form);
  const field = error.field || '';
  const top = field.split(/[.[]/)[0];
  const box = form.querySelector('.form-error');
  box.replaceChildren(h('div', { class: 'panel error', dataset: { code: error.code || '', field } },
    h('strong', {}, 'The server refused this capture: '), h('span', { class: 'message' }, error.message),
    field ? h('div', {}, 'Field: ', h('code', { class: 'field-name' }, field)) : null));
  // The sweep form has one control, the whole spec: any field is in it. (The
  // error panel carries data-field too: it is not a holder.)
  // The application form names its controls by the whole field (application.frames).
  const exact = field.replace(/\[\d+\]$/, '');
  const holder = (exact && form.querySelector(`[data-field="${CSS.escape(exact)}"]:not(.panel)`)) ||
    form.querySelector(`[data-field="${CSS.escape(top)}"]:not(.panel)`) || (field ? form.querySelector('[data-field="sweep_spec"]') : null);
  if (holder) {
    holder.querySelector('input, select, textarea')?.setAttribute('aria-invalid', 'true');
    holder.append(h('span', { class: 'field-error' }, error.message));
  }
}

function clearError(form) {
  form.querySelector('.form-error').replaceChildren();
  for (const el of form.querySelectorAll('.field-error')) el.remove();
  for (const el of form.querySelectorAll('[aria-invalid]')) el.removeAttribute('aria-invalid');
}

const progressText = (job) => `${job.progress.done} / ${job.progress.total}${job.progress.current ? `: ${job.progress.current}` : ''}`;

// "2 / 3": attempts so far of the most a job gets (a server before hosts gives no maximum).
const attemptsText = (job) => `${job.attempts ?? '–'}${job.max_attempts ? ` / ${job.max_attempts}` : ''}`;

// Why a queued job waits (no live host can take it), and why its earlier attempts ended.
const waitingNote = (job) => (job.status === 'queued' && job.waiting ? h('div', { class: 'waiting', dataset: { waiting: '' } }, `Waiting: ${job.waiting}`) : null);
const attemptErrors = (job) => (job.attempt_errors && job.attempt_errors.length
  ? h('ul', { class: 'attempt-errors', 'aria-label': 'Earlier attempts' }, job.attempt_errors.map((e) => h('li', {}, e)))
  : null);

function progressPanel(job) {
  const done = job.status === 'done';
  return h('div', { class: 'panel', dataset: { capture: job.id, status: job.status }, role: 'status' },
    h('div', {}, h('strong', {}, `Capture #${job.id}: `), h('span', { class: `job-status status-${job.status}` }, job.status),
      job.host ? h('span', { dataset: { host: job.host } }, ` on ${job.host}`) : null,
      job.max_attempts && job.attempts > 1 ? h('span', { class: 'muted' }, ` (attempt ${job.attempts} of ${job.max_attempts})`) : null),
    waitingNote(job),
    h('progress', { max: Math.max(job.progress.total, 1), value: job.progress.done }),
    h('div', { class: 'muted' }, progressText(job)),
    job.error ? h('div', { class: 'error' }, job.error) : null,
    attemptErrors(job),
    done && job.sweeps && job.sweeps.length ? h('a', { href: `#/sweeps/${job.sweeps[0]}` }, 'See its sweep') : null,
    done && !job.spec.sweep ? h('a', { href: `#/runs?capture=${job.id}` }, 'See its runs') : null,
    done && job.spec.heatmap ? [' · ', h('a', { href: `#/heatmap?capture=${job.id}`, dataset: { heatmapLink: job.id } }, 'See its heatmap')] : null);
}

function summary(spec) {
  if (spec.sweep) return `sweep ${spec.sweep}`;
  if (spec.application) return `application ${(spec.application.command || []).join(' ')}`;
  if (spec.replay) return `replay ${spec.replay}`;
  const scenes = (spec.scenes || ['atrium']).map((s) => (typeof s === 'string' ? s : s.name || s.gltf)).join(', ');
  const res = (spec.resolutions || []).map((r) => (Array.isArray(r) ? r.join('×') : String(r))).join(', ');
  const variant = (r) => (typeof r === 'string' ? r : [r.renderer, ...Object.entries(r.options || {}).map(([k, v]) => `${k}=${typeof v === 'string' ? v : JSON.stringify(v)}`)].join(' '));
  const heatmap = spec.heatmap ? ` · heatmap ${spec.heatmap.layout}${spec.heatmap.cells ? ` ${spec.heatmap.cells.join('×')}` : ''}` : '';
  return `${[...(spec.renderers || []), ...(spec.workloads || [])].map(variant).join(', ')} · ${scenes} · ${res}${spec.counting && spec.counting !== 'exact' ? ` · ${spec.counting}` : ''}${heatmap}`;
}

function jobTable(jobs, onCancel) {
  return h('div', { class: 'table-wrap' }, h('table', { 'aria-label': 'Captures', class: 'jobs' },
    h('thead', {}, h('tr', {}, ['Capture', 'Status', 'Host', 'Progress', 'Attempts', 'Spec', 'Created (UTC)', 'Finished', 'Error', ''].map((t) => h('th', { scope: 'col' }, t)))),
    h('tbody', {}, jobs.map((j) => h('tr', { dataset: { capture: j.id, status: j.status } },
      h('td', {}, `#${j.id}`),
      h('td', { class: `status-${j.status}` }, j.status, waitingNote(j)),
      h('td', { dataset: { cell: 'host' } }, j.host || '–'),
      h('td', {}, progressText(j)),
      h('td', { dataset: { cell: 'attempts' } }, attemptsText(j), attemptErrors(j)),
      h('td', { class: 'spec-cell' }, summary(j.spec)),
      h('td', {}, fmt.date(j.created_at)),
      h('td', {}, fmt.date(j.finished_at)),
      h('td', { class: 'error', style: 'white-space: normal; min-width: 12rem' }, j.error || ''),
      h('td', {}, kFinished.includes(j.status)
        ? (j.status === 'done' ? (j.spec.sweep ? h('a', { href: `#/sweeps?capture=${j.id}` }, 'sweep') : [h('a', { href: `#/runs?capture=${j.id}` }, 'runs'),
          j.spec.heatmap ? [' · ', h('a', { href: `#/heatmap?capture=${j.id}`, dataset: { heatmapLink: j.id } }, 'heatmap')] : null]) : '')
        : h('button', { type: 'button', class: 'secondary', onclick: () => onCancel(j.id) }, 'Cancel')))))));
}

export async function render(page, { signal }) {
  const [renderers, scenes, first] = await Promise.all([get('/renderers', signal), get('/scenes', signal), get('/captures?limit=25', signal)]);
  const progress = h('div', { class: 'progress-box' });
  const list = h('div', {});
  const listStatus = h('p', { class: 'muted', role: 'status' });

  const drawList = (jobs) => list.replaceChildren(jobs.length ? jobTable(jobs, cancel) : h('p', { class: 'muted' }, 'No captures yet.'));
  let listPolling = false;
  async function refreshList() {
    const { captures } = await get('/captures?limit=25', signal);
    drawList(captures);
    return captures.every((j) => kFinished.includes(j.status));
  }
  // Polls the list while any capture is unfinished; one loop at a time.
  function watchList() {
    if (listPolling) return;
    listPolling = true;
    poll(refreshList, kListPollMs, signal)
      .catch((error) => { if (!signal.aborted) listStatus.textContent = `Could not refresh the list: ${error.message}`; })
      .finally(() => { listPolling = false; });
  }

  async function cancel(id) {
    try {
      await request(`/captures/${id}`, { method: 'DELETE', signal });
    } catch (error) {
      if (!signal.aborted) listStatus.textContent = `Capture #${id}: ${error.message}`;
    }
    watchList();
  }

  async function start(spec, form) {
    const button = form.querySelector('button[type="submit"]');
    // The progress shows beside the Start that was pressed, not below the fold.
    const row = form.querySelector('.start-row');
    if (row) row.append(progress);
    else button.after(progress);
    clearError(form);
    button.disabled = true;
    let created;
    try {
      created = await request('/captures', { method: 'POST', body: spec, signal });
    } catch (error) {
      if (signal.aborted) return;
      if (error instanceof ApiError && error.status < 500) showError(form, error);
      else progress.replaceChildren(h('div', { class: 'panel error', role: 'alert' }, error.message));
      return;
    } finally {
      button.disabled = false;
    }
    watchList();
    try {
      await poll(async () => {
        const job = await get(`/captures/${created.id}`, signal);
        progress.replaceChildren(progressPanel(job));
        return kFinished.includes(job.status);
      }, kPollMs, signal);
    } catch (error) {
      if (!signal.aborted) progress.replaceChildren(h('div', { class: 'panel error', role: 'alert' }, `Capture #${created.id}: ${error.message}`));
    }
  }

  const form = captureForm(renderers.renderers, renderers.options || [], scenes, (spec) => start(spec, form),
    renderers.workloads || []);
  const rate = captureRate(first.captures);
  const update = () => {
    applicable(form);
    form.querySelector('[data-cost]').replaceChildren(...costText(specOf(form), rate));
  };
  form.querySelector('.start-row').append(progress);
  form.addEventListener('input', update);
  form.addEventListener('change', update);
  update();
  const sweeps = sweepForm((spec) => start(spec, sweeps));
  const apps = appForm((spec) => start(spec, apps));
  page.append(h('h1', {}, 'New capture'), form,
    h('details', { class: 'app-box', dataset: { box: 'application' } },
      h('summary', {}, h('h2', { class: 'inline' }, 'Or profile an application under the Vulkan layer')), apps),
    h('details', { class: 'sweep-box' }, h('summary', {}, h('h2', { class: 'inline' }, 'Or a spec as JSON: a stability sweep, an application, a replay')), sweeps),
    h('h2', {}, 'Captures'), listStatus, list);
  drawList(first.captures);
  if (!first.captures.every((j) => kFinished.includes(j.status))) watchList();
}

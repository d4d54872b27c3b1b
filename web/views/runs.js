// Runs browser. The filters (renderer, scene, resolution, device, host,
// dates, capture) live in the URL and go to the server as /api/runs query
// parameters (the host select offers the hosts of /api/hosts and those the
// loaded runs name); rows arrive a page at a time (the store may hold
// thousands), and a header click sorts the rows loaded so far. Ticking 2 to 4 rows opens them
// in the compare view.
import { get, queryString } from '../api.js';
import { h } from '../dom.js';
import * as fmt from '../format.js';

const kPageSize = 100;

// Long text (labels, device names, a command line for a scene) is cut to its
// column's width with an ellipsis; the whole text is its title.
const clipped = (text) => h('span', { class: 'clip', title: text }, text);

// Sortable columns: key -> how a run sorts and shows. The figures a reader
// decides by (frame time, bytes per frame) come right after the renderer, so
// that they stay on screen however long the labels are.
const kColumns = [
  { key: 'id', label: 'Run', sort: (r) => r.id, cell: (r) => h('a', { href: `#/runs/${r.id}` }, `#${r.id}`) },
  { key: 'renderer', label: 'Renderer', sort: (r) => fmt.variant(r), cell: (r) => clipped(fmt.variant(r)) },
  // The API's mean over cameras of each camera's median frame time, labelled so
  // (the run view and compare show the median of all frames, from the samples).
  { key: 'frame_ms_median', label: 'Frame time (median)', title: 'the median of all the run\'s frame times, as the run view, the trend, alerts and compare show it', sort: (r) => r.frame_ms_median ?? r.mean_frame_ms, cell: (r) => fmt.ms(r.frame_ms_median ?? r.mean_frame_ms), num: true },
  { key: 'mean_bytes', label: 'Bytes / frame', sort: (r) => r.mean_bytes, cell: (r) => fmt.bytes(r.mean_bytes), num: true },
  { key: 'psnr', label: 'PSNR', sort: psnrKey, cell: fmt.imageError, num: true },
  { key: 'scene', label: 'Scene', sort: (r) => r.scene, cell: (r) => clipped(r.scene) },
  { key: 'resolution', label: 'Resolution', sort: (r) => r.width * r.height, cell: fmt.resolution, num: true },
  { key: 'device', label: 'Device', sort: (r) => r.device, cell: (r) => clipped(r.device) },
  // null for runs stored before hosts existed
  { key: 'host', label: 'Host', sort: (r) => r.host, cell: (r) => (r.host ? clipped(r.host) : '–') },
  { key: 'counting', label: 'Counting', sort: (r) => r.counting, cell: (r) => r.counting },
  // The capture's labels (commit, branch, ...); {} for none
  { key: 'labels', label: 'Labels', sort: (r) => fmt.labels(r.labels), cell: (r) => (fmt.labels(r.labels) ? clipped(fmt.labels(r.labels)) : '–') },
  { key: 'sample_count', label: 'Samples', sort: (r) => r.sample_count, cell: (r) => String(r.sample_count), num: true },
  { key: 'mean_overhead_ratio', label: 'Overhead', sort: (r) => r.mean_overhead_ratio, cell: (r) => fmt.ratio(r.mean_overhead_ratio), num: true },
  { key: 'created_at', label: 'Date (UTC)', sort: (r) => r.created_at, cell: (r) => fmt.date(r.created_at) },
];

// Identical images rank above any PSNR; runs never compared rank last.
function psnrKey(run) {
  const e = run.image_error;
  if (!e) return null;
  return e.identical === e.samples ? Infinity : e.mean_psnr;
}

function compareRows(column, direction) {
  return (a, b) => {
    const x = column.sort(a);
    const y = column.sort(b);
    if (x === y) return b.id - a.id;
    if (x === null || x === undefined) return 1;  // missing values last, either way
    if (y === null || y === undefined) return -1;
    return (x < y ? -1 : 1) * direction;
  };
}

// The API query for the filters in the URL: "resolution=320x180" becomes width and height.
function apiFilters(query) {
  const f = {};
  for (const key of ['renderer', 'scene', 'device', 'host', 'label', 'since', 'until', 'capture']) f[key] = query.get(key);
  const res = /^(\d+)\s*[x×]\s*(\d+)$/.exec(query.get('resolution') || '');
  if (res) [f.width, f.height] = [res[1], res[2]];
  return f;
}

function filterForm(query, { renderers, scenes, devices, hosts }, onApply) {
  const field = (label, control) => h('label', { class: 'field' }, h('span', {}, label), control);
  const select = (name, options) => h('select', { name },
    h('option', { value: '' }, 'any'),
    options.map(([value, text]) => h('option', { value, selected: query.get(name) === String(value) }, text)));
  const form = h('form', { class: 'filters', 'aria-label': 'Filter runs' },
    field('Renderer', select('renderer', renderers.map((r) => [r, r]))),
    field('Scene', h('input', { name: 'scene', list: 'scene-names', value: query.get('scene') || '', placeholder: 'any' })),
    h('datalist', { id: 'scene-names' }, scenes.map((s) => h('option', { value: s }))),
    field('Resolution', h('input', { name: 'resolution', value: query.get('resolution') || '', placeholder: 'e.g. 320x180', pattern: '\\s*\\d+\\s*[x×]\\s*\\d+\\s*', size: 10 })),
    field('Device', select('device', devices.map((d) => [d.id, d.name]))),
    hosts.length ? field('Host', select('host', hosts)) : null,
    field('Label', h('input', { name: 'label', value: query.get('label') || '', placeholder: 'commit=4f2a9c1', pattern: '\\s*[^=\\s]+=.+', size: 14, title: 'NAME=VALUE: runs of captures with this label' })),
    field('From', h('input', { type: 'date', name: 'since', value: query.get('since') || '' })),
    field('To', h('input', { type: 'date', name: 'until', value: query.get('until') || '' })),
    query.get('capture') ? h('input', { type: 'hidden', name: 'capture', value: query.get('capture') }) : null,
    h('div', { class: 'field buttons' }, h('button', { type: 'submit' }, 'Apply'), h('a', { href: '#/runs', class: 'button secondary' }, 'Clear')));
  form.addEventListener('submit', (e) => {
    e.preventDefault();
    if (!form.reportValidity()) return;
    onApply(Object.fromEntries([...new FormData(form)].map(([k, v]) => [k, v.trim()])));
  });
  form.addEventListener('change', (e) => {
    if (e.target.tagName === 'SELECT' || e.target.type === 'date') form.requestSubmit();
  });
  return form;
}

// The host select's [value, text] pairs: the registered hosts (a stale one
// says so), the hosts the loaded runs name (one since removed, say) and the
// one in the URL, by name.
function hostOptions(registered, runs, current) {
  const stale = new Set(registered.filter((x) => !x.alive).map((x) => x.name));
  const names = new Set([...registered.map((x) => x.name), ...runs.map((r) => r.host).filter(Boolean)]);
  if (current) names.add(current);
  return [...names].sort().map((name) => [name, stale.has(name) ? `${name} (stale)` : name]);
}

export async function render(page, { query, signal }) {
  const filters = apiFilters(query);
  const [renderers, scenes, devices, hosts, first] = await Promise.all([
    get('/renderers', signal),
    get('/scenes', signal),
    get('/devices', signal),
    // A daemon from before hosts has no /api/hosts: the runs' hosts fill the select then.
    get('/hosts', signal).catch((error) => {
      if (signal.aborted) throw error;
      return { hosts: [] };
    }),
    get('/runs' + queryString({ ...filters, limit: kPageSize }), signal),
  ]);
  const sceneNames = [...scenes.procedural.map((s) => s.name), ...scenes.gltf.flatMap((f) => f.files)];

  const rows = [...first.runs];
  let cursor = first.next_cursor;
  let sort = { key: 'id', direction: -1 };  // as the server sends them: newest first
  const selected = (query.get('select') || '').split(',').filter(Boolean).map(Number);

  const tbody = h('tbody');
  const thead = h('thead');
  const status = h('p', { class: 'muted', role: 'status' });
  const more = h('button', { type: 'button', class: 'secondary' }, `Load ${kPageSize} more`);
  const selectionReason = h('span', { class: 'muted selection-reason', id: 'selection-reason', dataset: { selectionReason: '' } });
  const compareButton = h('button', { type: 'button', 'aria-describedby': 'selection-reason', onclick: () => { location.hash = `#/compare?runs=${selected.join(',')}`; } });

  function drawHead() {
    thead.replaceChildren(h('tr', {},
      kColumns.map((c, i) => h('th', { scope: 'col', class: [c.num ? 'num' : '', i === 0 ? 'sticky-col' : ''].join(' ').trim() || null, title: c.title,
        'aria-sort': sort.key === c.key ? (sort.direction > 0 ? 'ascending' : 'descending') : 'none' },
        i === 0 ? h('span', { class: 'visually-hidden' }, 'Select, ') : null,
        h('button', { type: 'button', class: 'sort', dataset: { sort: c.key }, onclick: () => sortBy(c.key) }, c.label)))));
  }

  function drawRows() {
    const column = kColumns.find((c) => c.key === sort.key);
    rows.sort(compareRows(column, sort.direction));
    // The first cell (tick and run) stays in view when the table scrolls sideways;
    // data-label names each cell on a phone, where the rows become cards.
    tbody.replaceChildren(...rows.map((r) => h('tr', { dataset: { runId: r.id } },
      kColumns.map((c, i) => h('td', { class: [c.num ? 'num' : '', i === 0 ? 'sticky-col' : ''].join(' ').trim() || null, dataset: { label: c.label, column: c.key } },
        i === 0 ? [h('input', { type: 'checkbox', 'aria-label': `Select run ${r.id}`, checked: selected.includes(r.id), onchange: (e) => toggle(r.id, e.target.checked) }), ' '] : null,
        c.cell(r))))));
    status.textContent = `${rows.length} run${rows.length === 1 ? '' : 's'} loaded${cursor ? ', more on the server' : ''}. Sorting applies to the loaded runs; PSNR is the image error against forward.`;
    more.hidden = !cursor;
    drawSelection();
  }

  // Why the button is greyed out, beside it rather than in a tooltip only.
  function drawSelection() {
    compareButton.textContent = `Compare selected (${selected.length})`;
    const n = selected.length;
    const why = n > 4 ? `Compare takes at most 4 runs: untick ${n - 4}.` : n < 2 ? `Tick ${n ? 'one more run' : '2 to 4 runs'} to compare.` : '';
    compareButton.disabled = Boolean(why);
    compareButton.title = why || `Compare runs ${selected.join(', ')}`;
    selectionReason.textContent = why;
  }

  function toggle(id, on) {
    const at = selected.indexOf(id);
    if (on && at < 0) selected.push(id);
    if (!on && at >= 0) selected.splice(at, 1);
    drawSelection();
  }

  function sortBy(key) {
    sort = { key, direction: sort.key === key ? -sort.direction : (key === 'id' || key === 'created_at' ? -1 : 1) };
    drawHead();
    drawRows();
  }

  more.addEventListener('click', async () => {
    more.disabled = true;
    try {
      const next = await get('/runs' + queryString({ ...filters, limit: kPageSize, cursor }), signal);
      rows.push(...next.runs);
      cursor = next.next_cursor;
      drawRows();
    } catch (error) {
      if (!signal.aborted) status.textContent = `Could not load more runs: ${error.message}`;
    } finally {
      more.disabled = false;
    }
  });

  const apply = (values) => {
    location.hash = '#/runs' + queryString(values);
  };
  page.append(
    h('h1', {}, 'Runs'),
    filterForm(query, { renderers: [...renderers.renderers, ...(renderers.workloads || [])], scenes: sceneNames, devices: devices.devices,
      hosts: hostOptions(hosts.hosts, rows, query.get('host')) }, apply),
    h('div', { class: 'toolbar' }, compareButton, selectionReason, status),
    rows.length
      ? h('div', { class: 'table-wrap' }, h('table', { class: 'runs', 'aria-label': 'Runs' }, thead, tbody))
      : h('p', { class: 'panel' }, 'No runs match. ', h('a', { href: '#/capture' }, 'Start a capture'), '.'),
    more);
  drawHead();
  drawRows();
}

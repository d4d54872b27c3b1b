// Stability sweeps (#/sweeps?name=&device=&capture=): the stored sweeps,
// newest first, a page at a time from /api/sweeps with the filters in the URL;
// each row says in a few words where the sweep fails and links to it.
import { get, queryString } from '../api.js';
import { h, table } from '../dom.js';
import * as fmt from '../format.js';
import { failsAtSummary, thresholdText } from './sweep.js';

const kPageSize = 100;

function filterForm(query, names, devices, onApply) {
  const field = (label, control) => h('label', { class: 'field' }, h('span', {}, label), control);
  const form = h('form', { class: 'filters', 'aria-label': 'Filter sweeps' },
    field('Sweep', h('input', { name: 'name', list: 'sweep-names', value: query.get('name') || '', placeholder: 'any' })),
    h('datalist', { id: 'sweep-names' }, names.map((n) => h('option', { value: n }))),
    field('Device', h('select', { name: 'device' },
      h('option', { value: '' }, 'any'),
      devices.map((d) => h('option', { value: d.id, selected: query.get('device') === String(d.id) }, d.name)))),
    query.get('capture') ? h('input', { type: 'hidden', name: 'capture', value: query.get('capture') }) : null,
    h('div', { class: 'field buttons' }, h('button', { type: 'submit' }, 'Apply'), h('a', { href: '#/sweeps', class: 'button secondary' }, 'Clear')));
  form.addEventListener('submit', (e) => {
    e.preventDefault();
    onApply(Object.fromEntries([...new FormData(form)].map(([k, v]) => [k, v.trim()])));
  });
  form.addEventListener('change', (e) => {
    if (e.target.tagName === 'SELECT') form.requestSubmit();
  });
  return form;
}

const kColumns = [
  { label: 'Sweep', value: (s) => h('a', { href: `#/sweeps/${s.id}` }, `#${s.id}`) },
  { label: 'Date (UTC)', value: (s) => fmt.date(s.created_at) },
  { label: 'Name', value: (s) => s.name },
  { label: 'Device', value: (s) => h('span', { class: 'clip', title: s.device.name }, s.device.name) },
  { label: 'Points', className: 'num', value: (s) => String(s.point_count) },
  { label: 'Swept', value: (s) => s.parameters.join(' × ') },
  { label: 'Threshold', value: (s) => thresholdText(s.threshold) },
  { label: 'Where it fails', value: (s) => h('span', { dataset: { failsAt: s.fails_at === null ? 'none' : 'some' } }, failsAtSummary(s)) },
];

export async function render(page, { query, signal }) {
  const filters = { name: query.get('name'), device: query.get('device'), capture: query.get('capture') };
  const [devices, first] = await Promise.all([
    get('/devices', signal),
    get('/sweeps' + queryString({ ...filters, limit: kPageSize }), signal),
  ]);
  const rows = [...first.sweeps];
  let cursor = first.next_cursor;
  const list = h('div', {});
  const status = h('p', { class: 'muted', role: 'status' });
  const more = h('button', { type: 'button', class: 'secondary' }, `Load ${kPageSize} more`);

  function draw() {
    const t = table(kColumns, rows, { class: 'sweeps', 'aria-label': 'Sweeps' });
    t.querySelectorAll('tbody tr').forEach((tr, i) => { tr.dataset.sweepId = rows[i].id; });
    list.replaceChildren(rows.length ? t : h('p', { class: 'panel' }, 'No sweeps match. ',
      h('a', { href: '#/capture' }, 'Start one'), ' from the capture page with a sweep spec.'));
    status.textContent = `${rows.length} sweep${rows.length === 1 ? '' : 's'} loaded${cursor ? ', more on the server' : ''}.`;
    more.hidden = !cursor;
  }

  more.addEventListener('click', async () => {
    more.disabled = true;
    try {
      const next = await get('/sweeps' + queryString({ ...filters, limit: kPageSize, cursor }), signal);
      rows.push(...next.sweeps);
      cursor = next.next_cursor;
      draw();
    } catch (error) {
      if (!signal.aborted) status.textContent = `Could not load more sweeps: ${error.message}`;
    } finally {
      more.disabled = false;
    }
  });

  const names = [...new Set(rows.map((s) => s.name))].sort();
  page.append(
    h('h1', {}, 'Stability sweeps'),
    h('p', { class: 'muted' }, 'Each sweep varies a parameter of a method until its error reaches a stated threshold, and says where it does.'),
    filterForm(query, names, devices.devices, (values) => { location.hash = '#/sweeps' + queryString(values); }),
    status, list, more);
  draw();
}

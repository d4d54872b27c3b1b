// A small element builder, so that views read as the markup they make.
// h('a', {href: '#/runs', class: 'nav'}, 'Runs') -> <a href="#/runs" class="nav">Runs</a>.
// Attributes: on* take listeners, `dataset` an object of data-* values,
// anything else is set with setAttribute (false/null/undefined: left out).
// Children: strings (as text, never HTML), nodes, arrays of them, or null.
export function h(tag, attrs = {}, ...children) {
  const el = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs || {})) {
    if (value === false || value === null || value === undefined) continue;
    if (key.startsWith('on') && typeof value === 'function') el.addEventListener(key.slice(2), value);
    else if (key === 'dataset') Object.assign(el.dataset, value);
    else if (key === 'value' && 'value' in el) el.value = value;
    else if (key === 'checked' || key === 'selected') el[key] = Boolean(value);
    else el.setAttribute(key, value === true ? '' : String(value));
  }
  append(el, children);
  return el;
}

export function append(parent, children) {
  for (const child of [children].flat(Infinity)) {
    if (child === null || child === undefined || child === false) continue;
    parent.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
  return parent;
}

// A table from column definitions {label, value(row) -> text or node, className}.
export function table(columns, rows, attrs = {}) {
  return h('div', { class: 'table-wrap' },
    h('table', attrs,
      h('thead', {}, h('tr', {}, columns.map((c) => h('th', { scope: 'col', class: c.className }, c.label)))),
      h('tbody', {}, rows.map((row) => h('tr', {}, columns.map((c) => h('td', { class: c.className }, c.value(row))))))));
}

// "requested | footprint": which bytes the byte charts under it draw.
// Footprint is disabled, with `why` as its tooltip, where there is none.
export function measureSwitch(name, available, why, onChange) {
  const option = (value, text, enabled) => h('label', { title: enabled ? null : why, dataset: { measure: value } },
    h('input', { type: 'radio', name, value, checked: value === 'requested', disabled: !enabled }), ` ${text}`);
  const box = h('div', { class: 'measure-switch', role: 'radiogroup', 'aria-label': 'Bytes shown', dataset: { measureSwitch: name } },
    h('span', { class: 'muted' }, 'Bytes: '), option('requested', 'requested', true), ' | ', option('footprint', 'footprint', available));
  box.addEventListener('change', (e) => onChange(e.target.value));
  return box;
}

// A camera heatmap (#/heatmap?capture=&renderer=&versus=&metric=&yaw=&scene=&width=&height=&counting=):
// GET /api/heatmap drawn over the top-down plan of the scene (a floor layout;
// GET /api/heatmap/{capture}/topdown.png) or as a longitude/latitude grid (a
// sphere layout). One renderer: a sequential scale of its value. Two: their
// ratio versus / renderer on a diverging scale centred on 1 (blue: versus
// lower, red: versus higher); cells whose difference is not significant are
// hatched. A cell's tooltip gives its values, interval and verdict; a click
// shows its samples with their screenshots.
import { get, imageSource, queryString } from '../api.js';
import { append, h, table } from '../dom.js';
import * as fmt from '../format.js';

const kSvg = 'http://www.w3.org/2000/svg';

function s(tag, attrs = {}, ...children) {
  const el = document.createElementNS(kSvg, tag);
  for (const [k, v] of Object.entries(attrs)) if (v !== null && v !== undefined) el.setAttribute(k, String(v));
  for (const c of children.flat()) if (c !== null && c !== undefined) el.append(c instanceof Node ? c : document.createTextNode(String(c)));
  return el;
}

// Sequential: light yellow to dark purple (viridis-like stops).
const kSequential = [[253, 231, 37], [94, 201, 98], [33, 145, 140], [59, 82, 139], [68, 1, 84]];
function ramp(stops, t) {
  const x = Math.min(1, Math.max(0, t)) * (stops.length - 1);
  const i = Math.min(stops.length - 2, Math.floor(x));
  const f = x - i;
  const c = stops[i].map((v, k) => Math.round(v + (stops[i + 1][k] - v) * f));
  return `rgb(${c[0]}, ${c[1]}, ${c[2]})`;
}
// Diverging on log2(ratio): blue below 1, white at 1, red above.
const kBlue = [[247, 247, 247], [146, 197, 222], [33, 102, 172]];
const kRed = [[247, 247, 247], [244, 165, 130], [178, 24, 43]];
export function ratioColor(ratio, span) {
  const l = Math.log2(ratio) / span;
  return l < 0 ? ramp(kBlue, -l) : ramp(kRed, l);
}

// The scale: for ratios, the largest |log2 ratio| (at least 5 %), symmetric
// about 1; for values, their range.
export function scaleOf(body) {
  const cells = body.cells.filter((c) => c.value_a !== null);
  if (body.versus) {
    const logs = cells.filter((c) => c.ratio !== null).map((c) => Math.abs(Math.log2(c.ratio)));
    return { kind: 'ratio', span: Math.max(Math.log2(1.05), ...logs) };
  }
  const values = cells.map((c) => c.value_a);
  return { kind: 'value', min: Math.min(...values), max: Math.max(...values) };
}

function colorOf(cell, scale) {
  if (cell.value_a === null) return null;
  if (scale.kind === 'ratio') return cell.ratio === null ? null : ratioColor(cell.ratio, scale.span);
  const t = scale.max > scale.min ? (cell.value_a - scale.min) / (scale.max - scale.min) : 0.5;
  return ramp(kSequential, t);
}

const valueText = (metric, v) => (metric === 'bytes' ? fmt.bytes(v) : fmt.ms(v));

// The tooltip: where, the values, the ratio with its interval, the verdict.
export function cellTitle(body, cell) {
  const layout = body.layout;
  const where = layout.layout === 'floor'
    ? `cell ${cell.column},${cell.row} (x ${fmt.fixed(layout.origin[0] + (cell.column + 0.5) * layout.cell_size[0], 1)}, z ${fmt.fixed(layout.origin[1] + (cell.row + 0.5) * layout.cell_size[1], 1)})`
    : `ring ${cell.row}, segment ${cell.column} (lat ${fmt.fixed(layout.latitudes_deg[cell.row], 0)}°, lon ${fmt.fixed(layout.longitudes_deg[cell.column], 0)}°)`;
  if (cell.value_a === null) {
    const why = { no_surface: 'no floor below', no_headroom: 'no headroom above the floor', eye_blocked: 'the eye would be in or next to geometry', off_level: 'floor off the ground level', incomplete: 'measured by one renderer only', not_measured: 'not measured' };
    return `${where}: empty (${why[cell.empty] || cell.empty || 'no samples'})`;
  }
  const lines = [where];
  if (cell.floor !== null && cell.floor !== undefined) lines.push(`floor y ${fmt.fixed(cell.floor, 2)}`);
  lines.push(`${body.renderer}: ${valueText(body.metric, cell.value_a)}`);
  if (body.versus) {
    lines.push(`${body.versus}: ${valueText(body.metric, cell.value_b)}`);
    const sig = cell.significance;
    const interval = sig && sig.interval && sig.interval.lower !== undefined
      ? ` [${sig.interval.lower === null ? '–' : sig.interval.lower.toFixed(3)}, ${sig.interval.upper === null ? '∞' : sig.interval.upper.toFixed(3)}] 95 %`
      : '';
    lines.push(`${body.versus} / ${body.renderer}: ${cell.ratio === null ? '–' : cell.ratio.toFixed(3)}${interval}`);
    if (sig && sig.error) lines.push(`significance: ${sig.error}`);
    else if (cell.verdict) lines.push(`verdict: ${cell.verdict}${cell.significant ? '' : ' (not significant)'}${sig && sig.mann_whitney ? `, p = ${sig.mann_whitney.p.toPrecision(2)}` : ''}`);
  }
  if (cell.yaw !== null && cell.yaw !== undefined && layout.yaws_deg && layout.yaws_deg.length > 1) lines.push(`yaw ${layout.yaws_deg[cell.yaw]}°`);
  return lines.join('\n');
}

// The cell's rectangle in the drawing's units: the plan's pixels (floor) or a unit grid (sphere).
function cellRect(layout, cell, unit) {
  if (layout.layout === 'floor') {
    const im = layout.image;
    const sx = im.width / (im.x1 - im.x0), sz = im.height / (im.z1 - im.z0);
    return {
      x: (layout.origin[0] + cell.column * layout.cell_size[0] - im.x0) * sx,
      y: (layout.origin[1] + cell.row * layout.cell_size[1] - im.z0) * sz,
      w: layout.cell_size[0] * sx,
      hgt: layout.cell_size[1] * sz,
    };
  }
  return { x: cell.column * unit, y: cell.row * unit, w: unit, hgt: unit };
}

function legend(body, scale) {
  const stops = [];
  for (let i = 0; i <= 10; ++i) {
    const t = i / 10;
    stops.push(s('stop', { offset: `${t * 100}%`, 'stop-color': scale.kind === 'ratio' ? ratioColor(2 ** ((2 * t - 1) * scale.span), scale.span) : ramp(kSequential, t) }));
  }
  const labels = scale.kind === 'ratio'
    ? [`×${(2 ** -scale.span).toFixed(2)} (${body.versus} lower)`, '×1', `×${(2 ** scale.span).toFixed(2)} (${body.versus} higher)`]
    : [valueText(body.metric, scale.min), '', valueText(body.metric, scale.max)];
  return h('figure', { class: 'heatmap-legend', dataset: { legend: scale.kind } },
    s('svg', { viewBox: '0 0 300 16', width: '300', height: '16', role: 'img', 'aria-label': `Colour scale: ${labels.filter(Boolean).join(' to ')}` },
      s('defs', {}, s('linearGradient', { id: 'heatmap-gradient' }, stops)),
      s('rect', { x: 0, y: 0, width: 300, height: 16, fill: 'url(#heatmap-gradient)' })),
    h('figcaption', { class: 'legend-labels' }, labels.map((l) => h('span', {}, l))),
    body.versus ? h('p', { class: 'caption' }, 'Hatched: the difference is not significant (', body.metric === 'bytes' ? 'counts equal' : 'Mann-Whitney and the 95 % interval of the ratio', '). Empty cells have no walkable floor.') : null);
}

// A capture's run sets: one per scene, resolution and counting mode, each a map of its own.
const configKey = (c) => `${c.scene}|${c.width}|${c.height}|${c.counting}`;
export function configsOf(runs) {
  const seen = new Map();
  for (const r of runs) {
    const c = { scene: r.scene, width: r.width, height: r.height, counting: r.counting };
    if (!seen.has(configKey(c))) seen.set(configKey(c), c);
  }
  // By scene, then smallest first.
  return [...seen.values()].sort((a, b) => a.scene.localeCompare(b.scene) || a.width * a.height - b.width * b.height || a.counting.localeCompare(b.counting));
}

function controls(query, variants, configs, layout, onApply) {
  const field = (label, control) => h('label', { class: 'field' }, h('span', {}, label), control);
  const option = (value, text, current) => h('option', { value, selected: value === current }, text);
  const yaws = layout && layout.yaws_deg && layout.yaws_deg.length > 1 ? layout.yaws_deg : [];
  const current = configKey(query);
  const form = h('form', { class: 'filters', 'aria-label': 'Heatmap' },
    configs.length > 1
      ? field('Scene and resolution', h('select', { name: 'config' },
        configs.map((c) => option(configKey(c), `${c.scene} · ${c.width}×${c.height} · ${c.counting}`, current))))
      : null,
    field('Renderer', h('select', { name: 'renderer' }, variants.map((v) => option(v, v, query.renderer)))),
    field('Versus', h('select', { name: 'versus' }, option('none', 'none', query.versus || 'none'), variants.map((v) => option(v, v, query.versus)))),
    field('Metric', h('select', { name: 'metric' }, option('frame_ms', 'frame time', query.metric), option('bytes', 'bytes', query.metric))),
    field('Yaw', h('select', { name: 'yaw', disabled: yaws.length === 0 },
      option('mean', 'mean over yaws', query.yaw), option('worst', 'worst yaw', query.yaw),
      yaws.map((deg, i) => option(String(i), `${deg}°`, query.yaw)))));
  form.addEventListener('change', () => {
    const values = Object.fromEntries(new FormData(form));
    if (values.config) {
      const [scene, width, height, counting] = values.config.split('|');
      Object.assign(values, { scene, width, height, counting });
      delete values.config;
    }
    onApply(values);
  });
  return form;
}

async function cellDetails(box, body, cell, signal) {
  box.replaceChildren(h('p', { class: 'muted' }, 'Loading the cell\'s samples…'));
  const ids = [...cell.samples_a.map((id) => ['a', id]), ...cell.samples_b.map((id) => ['b', id])];
  const samples = await Promise.all(ids.map(([side, id]) => get(`/samples/${id}`, signal).then((sm) => ({ side, sm }))));
  const figure = ({ side, sm }) => {
    const img = h('img', { alt: `${side === 'a' ? body.renderer : body.versus}, ${sm.camera.label || ''}`, loading: 'lazy' });
    if (sm.screenshot) imageSource(sm.screenshot, signal).then((src) => { img.src = src; }, () => { img.alt = 'screenshot not available'; });
    return h('figure', { class: 'shot', dataset: { sample: sm.id } },
      sm.screenshot ? img : null,
      h('figcaption', {}, h('a', { href: `#/runs/${sm.run}` }, `${side === 'a' ? body.renderer : body.versus} · sample #${sm.id}`),
        ` · ${fmt.ms(sm.frame_ms)} · ${fmt.bytes(sm.bytes)}`, h('div', { class: 'muted' }, sm.camera.label || '')));
  };
  box.replaceChildren(h('h3', {}, cellTitle(body, cell).split('\n')[0]),
    h('pre', { class: 'cell-title' }, cellTitle(body, cell)),
    h('div', { class: 'shots' }, samples.map(figure)));
}

function drawing(body, src, details, signal) {
  const layout = body.layout;
  const scale = scaleOf(body);
  const floor = layout.layout === 'floor';
  const unit = 40;
  const width = floor ? layout.image.width : layout.columns * unit;
  const height = floor ? layout.image.height : layout.rows * unit;
  const svg = s('svg', { viewBox: `0 0 ${width} ${height}`, class: 'heatmap-svg', role: 'img', 'aria-label': `Heatmap of ${body.versus ? `${body.versus} / ${body.renderer}` : body.renderer}`, preserveAspectRatio: 'xMidYMid meet' },
    s('defs', {}, s('pattern', { id: 'heatmap-hatch', width: 8, height: 8, patternUnits: 'userSpaceOnUse', patternTransform: 'rotate(45)' },
      s('line', { x1: 0, y1: 0, x2: 0, y2: 8, stroke: '#333', 'stroke-width': 2, 'stroke-opacity': 0.45 }))));
  if (floor && src) svg.append(s('image', { href: src, x: 0, y: 0, width, height, preserveAspectRatio: 'none' }));
  let selected = null;
  for (const cell of body.cells) {
    const r = cellRect(layout, cell, unit);
    const color = colorOf(cell, scale);
    const g = s('g', { class: 'cell', 'data-column': cell.column, 'data-row': cell.row, 'data-empty': cell.value_a === null ? (cell.empty || 'empty') : null,
      'data-ratio': cell.ratio, 'data-value': cell.value_a, 'data-significant': cell.significant === null || cell.significant === undefined ? null : String(cell.significant),
      'data-color': color, tabindex: cell.value_a === null ? null : 0 },
    s('title', {}, cellTitle(body, cell)));
    if (color) {
      g.append(s('rect', { x: r.x, y: r.y, width: r.w, height: r.hgt, fill: color, 'fill-opacity': floor ? 0.62 : 1, stroke: '#fff', 'stroke-width': Math.max(0.5, r.w / 40) }));
      if (body.versus && cell.significant === false) g.append(s('rect', { class: 'hatch', x: r.x, y: r.y, width: r.w, height: r.hgt, fill: 'url(#heatmap-hatch)' }));
      const open = () => {
        selected?.classList.remove('selected');
        selected = g;
        g.classList.add('selected');
        cellDetails(details, body, cell, signal).catch((e) => { if (!signal.aborted) details.replaceChildren(h('p', { class: 'error' }, e.message)); });
      };
      g.addEventListener('click', open);
      g.addEventListener('keydown', (e) => { if (e.key === 'Enter' || e.key === ' ') { e.preventDefault(); open(); } });
    } else if (!floor) {
      g.append(s('rect', { x: r.x, y: r.y, width: r.w, height: r.hgt, fill: '#eee', stroke: '#fff' }));
    } else {
      g.append(s('rect', { x: r.x, y: r.y, width: r.w, height: r.hgt, fill: 'none', stroke: '#000', 'stroke-opacity': 0.12, 'stroke-width': Math.max(0.5, r.w / 60) }));
    }
    svg.append(g);
  }
  return { svg, scale };
}

function summaryList(body) {
  const sm = body.summary;
  const layout = body.layout;
  const where = (ref) => (ref ? cellTitle(body, body.cells[ref.row * layout.columns + ref.column]).split('\n')[0] : '–');
  const items = [h('li', { dataset: { summary: 'cells' } }, `${sm.cells_measured} of ${sm.cells} cells measured (${sm.cells_empty} empty${sm.cells_incomplete ? `, ${sm.cells_incomplete} incomplete` : ''})`)];
  if (sm.a) items.push(h('li', {}, `${body.renderer}: median ${valueText(body.metric, sm.a.median)}, from ${valueText(body.metric, sm.a.min.value)} (${where(sm.a.min)}) to ${valueText(body.metric, sm.a.max.value)} (${where(sm.a.max)})`));
  if (body.versus && sm.ratio) {
    const pct = (r) => `${r < 1 ? '−' : '+'}${Math.abs((r - 1) * 100).toFixed(1)} %`;
    items.push(h('li', { dataset: { summary: 'ratio' } }, `${body.versus} / ${body.renderer}: median ×${sm.ratio.median.toFixed(3)}, geometric mean ×${sm.ratio.geometric_mean.toFixed(3)}`));
    items.push(h('li', { dataset: { summary: 'gains' } }, `best for ${body.versus} (lowest ratio): ${where(sm.ratio.min)}, ×${sm.ratio.min.value.toFixed(3)} (${pct(sm.ratio.min.value)}); worst (highest): ${where(sm.ratio.max)}, ×${sm.ratio.max.value.toFixed(3)} (${pct(sm.ratio.max.value)})`));
    items.push(h('li', { dataset: { summary: 'significant' } }, `significant in ${sm.significant} of ${sm.cells_measured} cells: ${body.versus} lower in ${sm.b_lower}, higher in ${sm.b_higher}`));
  }
  return h('ul', { class: 'heatmap-summary' }, items);
}

export async function render(page, { query, signal }) {
  const capture = query.get('capture');
  page.append(h('h1', {}, `Heatmap of capture #${capture || '?'}`));
  if (!capture) {
    page.append(h('p', { class: 'panel' }, 'Open a heatmap from its capture (Capture view: "See its heatmap").'));
    return;
  }
  const runs = (await get(`/runs${queryString({ capture, limit: 1000 })}`, signal)).runs;
  // A capture whose cameras were not a heatmap's (auto, or listed) has no cells: say so plainly.
  if (!runs.some((r) => r.notes && r.notes.heatmap)) {
    page.append(h('p', { class: 'panel', dataset: { heatmap: 'not-a-heatmap' } },
      runs.length
        ? `Capture #${capture} is not a heatmap capture: its cameras were not placed on a grid, so there is no map to draw. `
        : `Capture #${capture} has no runs (yet), so there is no map to draw. `,
      'A heatmap comes from a capture whose Cameras are "heatmap: floor grid" or "heatmap: sphere" in the ',
      h('a', { href: '#/capture' }, 'capture form'), '. ', runs.length ? h('a', { href: `#/runs?capture=${capture}` }, `The runs of capture #${capture}`) : null,
      runs.length ? '.' : null));
    return;
  }
  const variants = [...new Set(runs.map(fmt.variant))];
  const configs = configsOf(runs);
  const first = configs[0] || {};
  const q = {
    renderer: query.get('renderer') || variants[0],
    // "none": one renderer (an absent versus takes the capture's second variant).
    versus: query.get('versus') ?? (variants.length > 1 ? variants[1] : 'none'),
    metric: query.get('metric') || 'frame_ms',
    yaw: query.get('yaw') || 'mean',
    // The run set: the URL's, else the capture's first (a capture of several needs one).
    scene: query.get('scene') || first.scene || '',
    width: query.get('width') || (first.width ? String(first.width) : ''),
    height: query.get('height') || (first.height ? String(first.height) : ''),
    counting: query.get('counting') || first.counting || '',
  };
  const body = await get(`/heatmap${queryString({ capture, ...q, versus: q.versus === 'none' ? '' : q.versus })}`, signal);
  const go = (changed) => { location.hash = `#/heatmap${queryString({ capture, ...q, ...changed })}`; };
  page.append(h('ul', { class: 'meta' },
    h('li', {}, `${body.scene} · ${body.width}×${body.height} · ${body.counting}`),
    h('li', {}, body.device),
    h('li', {}, `${body.layout.layout} layout, ${body.layout.columns} × ${body.layout.rows} cells`),
    h('li', {}, h('a', { href: `#/runs?capture=${capture}` }, 'its runs'))));
  page.append(controls(q, variants, configs, body.layout, go));
  page.append(h('p', { class: 'caption' }, body.versus
    ? `Each cell: ${body.versus} / ${body.renderer}, ${body.metric === 'bytes' ? 'bytes per frame' : 'median frame time'}${body.yaw === 'mean' ? ', mean over the cell\'s yaws' : body.yaw === 'worst' ? ', the yaw least favourable to ' + body.versus : ''}. Below 1 (blue): ${body.versus} is lower.`
    : `Each cell: ${body.renderer}, ${body.metric === 'bytes' ? 'bytes per frame' : 'median frame time'}.`));
  let src = null;
  if (body.topdown) {
    try {
      src = await imageSource(body.topdown, signal);
    } catch (e) {
      page.append(h('p', { class: 'panel muted', dataset: { topdown: 'missing' } }, `No top-down plan: ${e.message}`));
    }
  }
  const details = h('div', { class: 'panel heatmap-details', dataset: { details: '' } }, h('p', { class: 'muted' }, 'Click a cell for its samples and screenshots.'));
  const { svg, scale } = drawing(body, src, details, signal);
  const hover = hoverReadout(svg, body);
  append(page, [hover, h('div', { class: 'heatmap', dataset: { layout: body.layout.layout, topdown: src ? 'shown' : 'none' } }, svg),
    body.layout.layout === 'sphere' ? h('p', { class: 'caption' }, 'Rows: latitude from north (top, +y) to south; columns: longitude from −180° to 180°. Each pose looks at the scene\'s centre.') : null,
    legend(body, scale), summaryList(body), details, cellTable(body)]);
}

// The value of the cell under the pointer (or focused), in words, above the
// map: the SVG title shows it too, but only after a delay and not on touch.
function hoverReadout(svg, body) {
  const out = h('p', { class: 'heatmap-hover', role: 'status', dataset: { hover: '' } }, 'Point at a cell for its value.');
  const show = (e) => {
    const g = e.target.closest?.('g.cell');
    if (!g) return;
    const cell = body.cells.find((c) => String(c.column) === g.dataset.column && String(c.row) === g.dataset.row);
    out.textContent = cellTitle(body, cell).split('\n').join(' · ');
    out.dataset.hover = `${cell.column},${cell.row}`;
  };
  svg.addEventListener('mouseover', show);
  svg.addEventListener('focusin', show);
  return out;
}

// Every cell as a row: where, the values, the ratio and the verdict.
function cellTable(body) {
  const measured = body.cells.filter((c) => c.value_a !== null);
  const columns = [
    { label: 'Cell', value: (c) => cellTitle(body, c).split('\n')[0] },
    { label: body.renderer, className: 'num', value: (c) => h('span', { dataset: { value: String(c.value_a) } }, valueText(body.metric, c.value_a)) },
    ...(body.versus ? [
      { label: body.versus, className: 'num', value: (c) => valueText(body.metric, c.value_b) },
      { label: `${body.versus} / ${body.renderer}`, className: 'num', value: (c) => (c.ratio === null ? '–' : fmt.ratio(c.ratio)) },
      { label: 'Verdict', value: (c) => (c.verdict ? `${c.verdict}${c.significant ? '' : ' (not significant)'}` : '–') }] : []),
  ];
  return h('details', { class: 'heatmap-table', dataset: { cellTable: String(measured.length) } },
    h('summary', {}, `The ${measured.length} measured cells as a table`), table(columns, measured, { 'aria-label': 'Heatmap cells' }));
}

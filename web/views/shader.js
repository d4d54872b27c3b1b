// The shader view of a run (#/shader/RUN?sample=&pass=&shader=&by=&against=):
// where in the shaders a sample's bytes go, from its per-site counts
// (docs/api.md, "Sites, draws and shaders").
// - "Where the bytes go": per pass, ranked, pass -> resource -> source line,
//   or pass -> draw, or pass -> material, each with its share of the pass.
// - The source of one shader in one pass, a heat bar per line (its bytes
//   against the pass's heaviest line), the line's share of the pass and its
//   count; clicking a line lists its sites: resource, access, bytes.
// - Against another run (?against=ID): the same shader's two sources side by
//   side, line by line (a diff), with both runs' bytes per line, so a variant's
//   changed lines and what they cost show together.
// Requests: the run, its samples and shaders, the sample's sites (every
// page), its draws or materials, and the shown shader's text.
import { get, queryString } from '../api.js';
import { append, h } from '../dom.js';
import * as fmt from '../format.js';

const kPage = 1000;     // rows per request: the API's most
const kMaxPages = 200;  // 200 000 sites at most: a bound, so a view cannot load forever
const kTopDraws = 10;   // draws or materials per pass in the ranked table; the rest summed
const kDiffCells = 4_000_000;  // line pairs the diff may compare; beyond, lines are paired by position

// The view's few rules of its own (the shared stylesheet has no heat bars), added once.
function addStyle() {
  if (document.getElementById('shader-view-style')) return;
  document.head.append(h('style', { id: 'shader-view-style' }, `
.shader-source { font-family: ui-monospace, monospace; font-size: 0.82rem; border-collapse: collapse; width: 100%; }
.shader-source td { padding: 0 0.4rem; white-space: pre; vertical-align: top; }
.shader-source tr[data-bytes] { cursor: pointer; }
.shader-source tr[aria-selected="true"] { outline: 2px solid var(--accent, #345); }
.shader-source .code { white-space: pre-wrap; overflow-wrap: anywhere; width: 100%; }
.heat { display: inline-block; width: 6rem; height: 0.7rem; background: rgba(127,127,127,0.15); vertical-align: middle; }
.heat > span { display: block; height: 100%; background: #d2553a; }
.diff-added { background: rgba(46,160,67,0.15); }
.diff-removed { background: rgba(218,54,51,0.15); }
.rank-pass { font-weight: 600; }
.rank-2 td:first-child { padding-left: 1.2rem; }
.rank-3 td:first-child { padding-left: 2.4rem; }
`));
}

// Every page of a sample's sites (or draws): rows, passes and rests.
async function allPages(path, params, key, signal) {
  const rows = [];
  let reply = null;
  for (let page = 0, offset = 0; page < kMaxPages; ++page) {
    reply = await get(`${path}${queryString({ ...params, limit: kPage, offset })}`, signal);
    rows.push(...reply[key]);
    if (reply.next_offset === null || reply.next_offset === undefined) break;
    offset = reply.next_offset;
  }
  return { rows, passes: reply.passes, rest: reply.rest || [] };
}

const lineKey = (site) => (site.line !== null ? String(site.line) : site.instruction !== null ? `%${site.instruction}` : site.disassembly || '(no line)');
const resourceOf = (site) => `${site.resource} (${site.access})`;
const sumBy = (rows, key) => {
  const out = new Map();
  for (const r of rows) out.set(key(r), (out.get(key(r)) || 0) + r.bytes);
  return out;
};
const ranked = (map) => [...map.entries()].sort((a, b) => b[1] - a[1]);

// A row of the ranked table: level 1 pass, 2 resource or draw, 3 line.
function rankRow(level, label, bytes, share, extra = '') {
  return h('tr', { class: `rank-${level}${level === 1 ? ' rank-pass' : ''}`, dataset: { level: String(level), bytes: String(bytes), share: share === null ? '' : String(share) } },
    h('td', {}, label), h('td', { class: 'num' }, fmt.bytes(bytes)), h('td', { class: 'num' }, fmt.percent(share)), h('td', {}, extra));
}

// pass -> resource -> source line, every pass by bytes, with shares of the pass.
function linesTable(passes, sites) {
  const rows = [];
  for (const pass of [...passes].sort((a, b) => b.bytes - a.bytes)) {
    const mine = sites.filter((s) => s.pass_position === pass.position);
    if (!mine.length) continue;
    const share = (bytes) => (pass.bytes > 0 ? bytes / pass.bytes : null);
    rows.push(rankRow(1, pass.name, pass.bytes, pass.bytes > 0 ? 1 : null, `${mine.length} sites`));
    let covered = 0;
    for (const [resource, bytes] of ranked(sumBy(mine, resourceOf))) {
      covered += bytes;
      rows.push(rankRow(2, resource, bytes, share(bytes)));
      const ofResource = mine.filter((s) => resourceOf(s) === resource);
      for (const [line, lineBytes] of ranked(sumBy(ofResource, (s) => `${s.shader}:${lineKey(s)}`))) {
        rows.push(rankRow(3, line, lineBytes, share(lineBytes)));
      }
    }
    if (pass.bytes - covered > 0) rows.push(rankRow(2, 'lines without sites (derived)', pass.bytes - covered, share(pass.bytes - covered)));
  }
  return rows;
}

// pass -> draw (or material): the top ones, the rest and what no draw covers.
function drawsTable(passes, items, rests, by) {
  const rows = [];
  for (const pass of [...passes].sort((a, b) => b.bytes - a.bytes)) {
    const mine = items.filter((d) => d.pass_position === pass.position).sort((a, b) => b.bytes - a.bytes);
    if (!mine.length) continue;
    const share = (bytes) => (pass.bytes > 0 ? bytes / pass.bytes : null);
    rows.push(rankRow(1, pass.name, pass.bytes, pass.bytes > 0 ? 1 : null, `${mine.length} ${by === 'material' ? 'materials' : 'draws kept'}`));
    let covered = 0, restBytes = 0, restCount = 0;
    mine.forEach((d, i) => {
      covered += d.bytes;
      const label = by === 'material' ? d.material : `#${d.index} ${d.name}`;
      const split = `read ${fmt.bytes(d.bytes_read)} · written ${fmt.bytes(d.bytes_written)}${by === 'material' ? ` · ${d.draws} draws` : ''}`;
      if (i < kTopDraws) rows.push(rankRow(2, label, d.bytes, share(d.bytes), split));
      else { restBytes += d.bytes; ++restCount; }
    });
    const rest = rests.find((r) => r.pass_position === pass.position);
    if (rest) { restBytes += rest.bytes; restCount += rest.draws; covered += rest.bytes; }
    if (restCount) rows.push(rankRow(2, `rest (${restCount} ${by === 'material' ? 'materials' : 'draws'})`, restBytes, share(restBytes)));
    if (pass.bytes - covered > 0) rows.push(rankRow(2, by === 'material' ? 'outside any material' : 'outside any draw', pass.bytes - covered, share(pass.bytes - covered)));
  }
  return rows;
}

function rankedSection(rows) {
  return h('div', { class: 'table-wrap' }, h('table', { dataset: { ranked: '' } },
    h('thead', {}, h('tr', {}, ['Pass → resource → line', 'Bytes per frame', 'Share of pass', ''].map((t) => h('th', { scope: 'col' }, t)))),
    h('tbody', {}, rows)));
}

// The shader's lines in one pass: bytes, count and sites per source line.
function lineStats(sites, shader, passPosition) {
  const byLine = new Map();
  for (const s of sites) {
    if (s.shader !== shader || s.pass_position !== passPosition || s.line === null) continue;
    const entry = byLine.get(s.line) || { bytes: 0, count: 0, sites: [] };
    entry.bytes += s.bytes;
    entry.count += s.count;
    entry.sites.push(s);
    byLine.set(s.line, entry);
  }
  return byLine;
}

function siteDetails(box, line, entry, passBytes) {
  box.replaceChildren(
    h('h3', {}, `Line ${line}: ${fmt.bytes(entry.bytes)} per frame, ${fmt.percent(passBytes > 0 ? entry.bytes / passBytes : null)} of the pass`),
    h('div', { class: 'table-wrap' }, h('table', { dataset: { lineSites: String(line) } },
      h('thead', {}, h('tr', {}, ['Resource', 'Access', 'Kind', 'Bytes per frame', 'Count', 'Instruction'].map((t) => h('th', { scope: 'col' }, t)))),
      h('tbody', {}, entry.sites.sort((a, b) => b.bytes - a.bytes).map((s) => h('tr', { dataset: { resource: s.resource } },
        h('td', {}, s.resource), h('td', {}, s.access), h('td', {}, s.kind || '–'), h('td', { class: 'num' }, fmt.bytes(s.bytes)),
        h('td', { class: 'num' }, fmt.count(s.count)), h('td', {}, h('code', {}, s.disassembly))))))));
}

// The source with a heat bar per line; a click shows the line's sites.
function sourceTable(text, stats, passBytes, details) {
  const heaviest = Math.max(0, ...[...stats.values()].map((e) => e.bytes));
  const rows = text.split('\n').map((code, i) => {
    const line = i + 1;
    const entry = stats.get(line);
    const width = entry && heaviest > 0 ? (100 * entry.bytes) / heaviest : 0;
    const attrs = entry ? { dataset: { line: String(line), bytes: String(entry.bytes), share: passBytes > 0 ? String(entry.bytes / passBytes) : '' }, tabindex: '0', 'aria-selected': 'false' }
      : { dataset: { line: String(line) } };
    return h('tr', attrs,
      h('td', { class: 'num muted' }, String(line)),
      h('td', {}, entry ? h('span', { class: 'heat', title: `${fmt.bytes(entry.bytes)} per frame` }, h('span', { style: `width: ${width.toFixed(2)}%` })) : ''),
      h('td', { class: 'num', dataset: { shareCell: '' } }, entry ? fmt.percent(passBytes > 0 ? entry.bytes / passBytes : null) : ''),
      h('td', { class: 'num' }, entry ? fmt.count(entry.count) : ''),
      h('td', { class: 'code' }, code));
  });
  const body = h('tbody', {}, rows);
  const pick = (row) => {
    if (!row || !row.dataset.bytes) return;
    for (const r of body.querySelectorAll('tr[aria-selected="true"]')) r.setAttribute('aria-selected', 'false');
    row.setAttribute('aria-selected', 'true');
    const line = Number(row.dataset.line);
    siteDetails(details, line, stats.get(line), passBytes);
  };
  body.addEventListener('click', (e) => pick(e.target.closest('tr')));
  body.addEventListener('keydown', (e) => { if (e.key === 'Enter') pick(e.target.closest('tr')); });
  return h('div', { class: 'table-wrap' }, h('table', { class: 'shader-source', dataset: { source: '' } },
    h('thead', {}, h('tr', {}, ['Line', 'Bytes', 'Share of pass', 'Count', 'Source'].map((t) => h('th', { scope: 'col' }, t)))), body));
}

// Line pairs of two texts: [a line number or null, b line number or null], by
// longest common subsequence (after the common head and tail), so inserted
// and removed lines show as such; paired by position when too large.
export function diffLines(a, b) {
  let head = 0;
  while (head < a.length && head < b.length && a[head] === b[head]) ++head;
  let tail = 0;
  while (tail < a.length - head && tail < b.length - head && a[a.length - 1 - tail] === b[b.length - 1 - tail]) ++tail;
  const ma = a.slice(head, a.length - tail), mb = b.slice(head, b.length - tail);
  const pairs = [];
  for (let i = 0; i < head; ++i) pairs.push([i + 1, i + 1]);
  if (ma.length * mb.length > kDiffCells) {
    for (let i = 0; i < Math.max(ma.length, mb.length); ++i) {
      const same = i < ma.length && i < mb.length && ma[i] === mb[i];
      if (same) pairs.push([head + i + 1, head + i + 1]);
      else {
        if (i < ma.length) pairs.push([head + i + 1, null]);
        if (i < mb.length) pairs.push([null, head + i + 1]);
      }
    }
  } else {
    const n = ma.length, m = mb.length;
    const lcs = Array.from({ length: n + 1 }, () => new Uint32Array(m + 1));
    for (let i = n - 1; i >= 0; --i) for (let j = m - 1; j >= 0; --j) lcs[i][j] = ma[i] === mb[j] ? lcs[i + 1][j + 1] + 1 : Math.max(lcs[i + 1][j], lcs[i][j + 1]);
    let i = 0, j = 0;
    while (i < n || j < m) {
      if (i < n && j < m && ma[i] === mb[j]) { pairs.push([head + i + 1, head + j + 1]); ++i; ++j; }
      else if (j >= m || (i < n && lcs[i + 1][j] >= lcs[i][j + 1])) { pairs.push([head + i + 1, null]); ++i; }
      else { pairs.push([null, head + j + 1]); ++j; }
    }
  }
  for (let i = 0; i < tail; ++i) pairs.push([a.length - tail + i + 1, b.length - tail + i + 1]);
  return pairs;
}

function compareTable(textA, statsA, textB, statsB) {
  const a = textA.split('\n'), b = textB.split('\n');
  const pairs = diffLines(a, b);
  const bytesCell = (stats, line) => h('td', { class: 'num' }, line !== null && stats.has(line) ? fmt.bytes(stats.get(line).bytes) : '');
  return h('div', { class: 'table-wrap' }, h('table', { class: 'shader-source', dataset: { compare: '' } },
    h('thead', {}, h('tr', {}, ['This run', 'Bytes', 'Other run', 'Bytes', 'Δ bytes', 'Source'].map((t) => h('th', { scope: 'col' }, t)))),
    h('tbody', {}, pairs.map(([la, lb]) => {
      const change = la === null ? 'added' : lb === null ? 'removed' : 'same';
      const ba = la !== null && statsA.has(la) ? statsA.get(la).bytes : 0, bb = lb !== null && statsB.has(lb) ? statsB.get(lb).bytes : 0;
      return h('tr', { class: change === 'same' ? null : `diff-${change}`, dataset: { change, a: la === null ? '' : String(la), b: lb === null ? '' : String(lb) } },
        h('td', { class: 'num muted' }, la === null ? '' : String(la)), bytesCell(statsA, la),
        h('td', { class: 'num muted' }, lb === null ? '' : String(lb)), bytesCell(statsB, lb),
        h('td', { class: 'num' }, ba || bb ? fmt.delta(bb - ba, fmt.bytes) : ''),
        h('td', { class: 'code' }, `${change === 'added' ? '+ ' : change === 'removed' ? '− ' : '  '}${la === null ? b[lb - 1] : a[la - 1]}`));
    }))));
}

// The other run's sites and text of the same shader, in the pass of the same name of its first sample.
async function otherRun(id, shader, passName, signal) {
  const [{ samples }, source] = await Promise.all([get(`/runs/${id}/samples`, signal), get(`/runs/${id}/shaders/${encodeURIComponent(shader)}`, signal)]);
  if (!samples.length) throw new Error(`run ${id} has no samples`);
  const { rows, passes } = await allPages(`/samples/${samples[0].id}/sites`, {}, 'sites', signal);
  const pass = passes.find((p) => p.name === passName);
  return { text: source.source, stats: pass ? lineStats(rows, shader, pass.position) : new Map() };
}

function go(id, query, changes) {
  const next = new URLSearchParams(query);
  for (const [k, v] of Object.entries(changes)) (v === '' || v === null || v === undefined ? next.delete(k) : next.set(k, v));
  location.hash = `#/shader/${id}?${next}`;
}

function picker(label, name, options, value, onChange) {
  return h('label', { class: 'field' }, label, h('select', { name, onchange: (e) => onChange(e.target.value) },
    options.map(([v, text]) => h('option', { value: v, selected: v === value }, text))));
}

export async function render(page, { params, query, signal }) {
  addStyle();
  const id = params.id;
  const [run, { samples }, { shaders }] = await Promise.all([get(`/runs/${id}`, signal), get(`/runs/${id}/samples`, signal), get(`/runs/${id}/shaders`, signal)]);
  page.append(h('h1', {}, `Shaders of run #${run.id}: ${fmt.runLabel(run)}`),
    h('p', {}, h('a', { href: `#/runs/${run.id}` }, `← run #${run.id}`)));
  if (!samples.length) { page.append(h('div', { class: 'panel' }, 'This run has no samples.')); return; }
  const sample = samples.find((s) => String(s.id) === query.get('sample')) || samples[0];
  const { rows: sites, passes } = await allPages(`/samples/${sample.id}/sites`, {}, 'sites', signal);
  const toolbar = h('div', { class: 'filters' },
    samples.length > 1 ? picker('Sample', 'sample', samples.map((s) => [String(s.id), `#${s.id} camera ${s.camera_index}`]), String(sample.id), (v) => go(id, query, { sample: v })) : null);
  page.append(toolbar);
  if (!sites.length) {
    page.append(h('div', { class: 'panel', dataset: { noSites: '' } }, 'This sample has no per-site counts: capture with "sites": true (or the layer\'s --sites) to see where in the shaders its bytes go.'));
    return;
  }

  // Where the bytes go.
  const by = ['line', 'draw', 'material'].includes(query.get('by')) ? query.get('by') : 'line';
  toolbar.append(picker('Break down by', 'by', [['line', 'resource → source line'], ['draw', 'draw'], ['material', 'material']], by, (v) => go(id, query, { by: v })));
  let rankedRows;
  if (by === 'line') rankedRows = linesTable(passes, sites);
  else {
    const draws = await allPages(`/samples/${sample.id}/draws`, { by }, by === 'material' ? 'materials' : 'draws', signal);
    rankedRows = drawsTable(passes, draws.rows, draws.rest, by);
  }
  append(page, [h('h2', {}, 'Where the bytes go'), h('p', { class: 'caption muted' }, `Sample #${sample.id}, per frame; shares of each pass's bytes (all its resource lines).`),
    rankedRows.length ? rankedSection(rankedRows) : h('div', { class: 'panel' }, `No ${by}s stored for this sample.`)]);

  // One shader's source in one pass.
  const used = ranked(sumBy(sites.filter((s) => s.line !== null), (s) => s.shader)).map(([name]) => name);
  const known = new Set(shaders.map((s) => s.name));
  const withSource = used.filter((name) => known.has(name));
  page.append(h('h2', {}, 'Source'));
  if (!withSource.length) {
    page.append(h('div', { class: 'panel' }, 'No source is stored for the shaders with sites (a module without line information gets its sites\' disassembly only).'));
    return;
  }
  const shader = withSource.includes(query.get('shader')) ? query.get('shader') : withSource[0];
  const passesOfShader = ranked(sumBy(sites.filter((s) => s.shader === shader), (s) => s.pass_position)).map(([p]) => passes.find((x) => x.position === p));
  const pass = passesOfShader.find((p) => p.name === query.get('pass')) || passesOfShader[0];
  const source = await get(`/runs/${id}/shaders/${encodeURIComponent(shader)}`, signal);
  const stats = lineStats(sites, shader, pass.position);
  const details = h('div', { class: 'panel', dataset: { siteDetails: '' } }, 'Click a line to see its resources.');
  const against = query.get('against');
  const againstInput = h('input', { name: 'against', inputmode: 'numeric', value: against || '', size: 6, 'aria-label': 'Run to compare with' });
  page.append(h('div', { class: 'filters' },
    picker('Shader', 'shader', withSource.map((s) => [s, s]), shader, (v) => go(id, query, { shader: v, pass: '' })),
    picker('Pass', 'pass', passesOfShader.map((p) => [p.name, p.name]), pass.name, (v) => go(id, query, { pass: v })),
    h('form', { class: 'field', onsubmit: (e) => { e.preventDefault(); go(id, query, { against: againstInput.value.trim() }); } },
      h('label', {}, 'Compare with run ', againstInput), h('button', { type: 'submit' }, 'Compare'))));
  const unmapped = sites.filter((s) => s.shader === shader && s.pass_position === pass.position && s.line === null);
  append(page, [h('p', { class: 'caption muted' }, `${shader} in ${pass.name}: ${fmt.bytes(pass.bytes)} per frame in the pass; bars against its heaviest line.`),
    details, sourceTable(source.source, stats, pass.bytes, details),
    unmapped.length ? [h('h3', {}, 'Sites without a source line'), h('ul', { dataset: { unmapped: '' } }, unmapped.map((s) => h('li', {}, h('code', {}, s.disassembly), ` ${resourceOf(s)}: ${fmt.bytes(s.bytes)}`)))] : null]);
  if (against) {
    const other = await otherRun(against, shader, pass.name, signal);
    page.append(h('h2', {}, `Against run #${against}`),
      h('p', { class: 'caption muted' }, `${shader}, pass ${pass.name}: lines only in this run are marked −, lines only in run #${against} +; Δ is the other run's bytes minus this run's.`),
      compareTable(source.source, stats, other.text, other.stats));
  }
}

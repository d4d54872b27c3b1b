// Where the bytes go: a ranked table of passes, each opening onto its
// resources (a tree), with each row's share of the frame's bytes and a top-N
// with "show all". One value column per run (the run view has one; compare
// one per run), rows ranked by their largest value over the runs.
//
// A node is {key, name, values: [bytes per column], children}, where
// children is an array of nodes, or a function returning a promise of them
// (fetched when the row is first opened), or null for a leaf. Any depth
// nests: a resource's access sites or draws (GET /api/samples/{id}/sites,
// /draws) become a third level by giving resource nodes children, through
// the `childrenOf` option of breakdownTable (node, depth) -> children.
import { h } from './dom.js';
import * as fmt from './format.js';

export const kTopN = 5;

// Passes with their resource lines ("name (access)"), as nodes, from a run's
// passes (GET /api/runs/{id}); key: 'bytes' or 'footprint_bytes'.
export function passNodes(runsPasses, key = 'bytes') {
  const names = [...new Set(runsPasses.flatMap((passes) => passes.map((p) => p.name)))];
  return names.map((name) => {
    const perRun = runsPasses.map((passes) => passes.find((p) => p.name === name));
    const lines = [...new Set(perRun.flatMap((p) => (p ? p.resources.map((r) => `${r.name} (${r.access})`) : [])))];
    const children = lines.map((line) => ({
      key: `${name}/${line}`,
      name: line,
      values: perRun.map((p) => {
        if (!p) return null;
        const hits = p.resources.filter((r) => `${r.name} (${r.access})` === line && r[key] !== null && r[key] !== undefined);
        return hits.length ? hits.reduce((sum, r) => sum + r[key], 0) : null;
      }),
    }));
    const values = perRun.map((_, i) => {
      const known = children.map((c) => c.values[i]).filter((v) => v !== null);
      return perRun[i] && known.length ? known.reduce((a, b) => a + b, 0) : null;
    });
    return { key: name, name, values, children };
  });
}

// Largest first, by the largest value over the columns: a pass only one of the
// compared runs has (deferred's lighting) ranks by its own size.
const largest = (n) => Math.max(-1, ...n.values.map((v) => v ?? -1));
const rank = (nodes) => [...nodes].sort((a, b) => largest(b) - largest(a) || a.name.localeCompare(b.name));

// spec: {id, columns: [header text], nodes, total: [bytes per column], title, caption, topN, childrenOf}.
export function breakdownTable(spec) {
  const { id, columns, nodes, total } = spec;
  const topN = spec.topN ?? kTopN;
  const tbody = h('tbody');
  const head = h('thead', {}, h('tr', {},
    h('th', { scope: 'col', class: 'sticky-col' }, 'Pass → resource'),
    columns.map((c) => [h('th', { scope: 'col', class: 'num' }, c), h('th', { scope: 'col', class: 'num share-col' }, 'share')])));
  const shareOf = (v, i) => (v === null || !total[i] ? null : v / total[i]);

  function row(node, depth, parentKey) {
    const opener = node.children || spec.childrenOf?.(node, depth)
      ? h('button', { type: 'button', class: 'tree-toggle', 'aria-expanded': 'false', 'aria-label': `Open ${node.name}` }, '▸')
      : h('span', { class: 'tree-leaf' });
    const tr = h('tr', { class: `depth-${depth}`, dataset: { node: node.key, depth: String(depth), parent: parentKey ?? '' } },
      h('th', { scope: 'row', class: 'sticky-col', style: `padding-left: ${0.4 + 1.1 * depth}rem` }, opener, ' ',
        h('span', { class: 'clip wide', title: node.name }, node.name)),
      node.values.map((v, i) => {
        const share = shareOf(v, i);
        return [h('td', { class: 'num', dataset: { value: v ?? '' } }, v === null ? '–' : fmt.bytes(v)),
          h('td', { class: 'num share-col', dataset: { share: share ?? '' } },
            share === null ? '–' : [h('span', { class: 'share-bar', style: `width: ${Math.max(1, Math.round(60 * share))}px` }), ' ', fmt.percent(share)])];
      }));
    if (opener.tagName === 'BUTTON') {
      let open = false, built = null;
      opener.addEventListener('click', async () => {
        open = !open;
        opener.setAttribute('aria-expanded', String(open));
        opener.textContent = open ? '▾' : '▸';
        if (!built) {
          const got = node.children || spec.childrenOf(node, depth);
          const kids = typeof got === 'function' ? await got() : await got;
          built = level(rank(kids || []), depth + 1, node.key);
          tr.after(...built);
        }
        for (const r of built) {
          if (!open) r.closeTree?.();
          r.hidden = !open || r.dataset.rest === 'hidden';
        }
      });
      tr.closeTree = () => { if (open) opener.click(); };
    }
    return tr;
  }

  // The top N rows of a level, then a "k more" row that shows the rest.
  function level(ranked, depth, parentKey) {
    const rows = ranked.map((n) => row(n, depth, parentKey));
    if (ranked.length <= topN) return rows;
    const rest = rows.slice(topN);
    for (const r of rest) { r.hidden = true; r.dataset.rest = 'hidden'; }
    const restValues = columns.map((_, i) => ranked.slice(topN).reduce((sum, n) => sum + (n.values[i] ?? 0), 0));
    const more = h('tr', { class: `depth-${depth} rest-row`, dataset: { restOf: parentKey ?? '', depth: String(depth) } },
      h('th', { scope: 'row', class: 'sticky-col', style: `padding-left: ${0.4 + 1.1 * depth}rem` },
        h('button', { type: 'button', class: 'secondary show-all', dataset: { showAll: parentKey ?? '' } }, `show all ${ranked.length}`),
        ` ${ranked.length - topN} more`),
      restValues.map((v, i) => [h('td', { class: 'num muted' }, fmt.bytes(v)), h('td', { class: 'num share-col muted' }, total[i] ? fmt.percent(v / total[i]) : '–')]));
    more.querySelector('button').addEventListener('click', () => {
      for (const r of rest) { delete r.dataset.rest; r.hidden = false; }
      more.remove();
    });
    return [...rows, more];
  }

  tbody.append(...level(rank(nodes), 0, null));
  return h('figure', { class: 'breakdown', dataset: { breakdown: id } },
    // No title where the section's heading already says it (spec.title null).
    h('figcaption', {}, spec.title === null ? null : h('strong', {}, spec.title || 'Where the bytes go'), h('span', { class: 'caption' }, ' ', spec.caption || '')),
    h('div', { class: 'table-wrap' }, h('table', { class: 'breakdown-table', 'aria-label': 'Where the bytes go', dataset: { table: `breakdown-${id}` } },
      head, tbody, h('tfoot', {}, h('tr', {}, h('th', { scope: 'row', class: 'sticky-col' }, 'Total per frame'),
        total.map((v) => [h('td', { class: 'num', dataset: { value: v ?? '' } }, fmt.bytes(v)), h('td', { class: 'num share-col' }, v ? '100 %' : '–')]))))));
}

// The dashboard's shell: a hash router over one module per view.
// "#/runs?renderer=deferred" -> views/runs.js render(page, {params, query, signal}).
// Each view draws into its own page element; leaving it aborts its signal,
// which cancels its requests and timers, and detaches the page, so a view
// that is still finishing cannot draw over the next one.
import { startBadge } from './alert_badge.js';
import { ApiError, setToken, token } from './api.js';
import { destroyCharts } from './charts.js';
import { h } from './dom.js';
import * as accuracy from './views/accuracy.js';
import * as alerts from './views/alerts.js';
import * as capture from './views/capture.js';
import * as compare from './views/compare.js';
import * as heatmap from './views/heatmap.js';
import * as hosts from './views/hosts.js';
import * as run from './views/run.js';
import * as runs from './views/runs.js';
import * as shader from './views/shader.js';
import * as sweep from './views/sweep.js';
import * as sweeps from './views/sweeps.js';
import * as trend from './views/trend.js';

// pattern -> view; ":id" captures one path segment.
const kRoutes = [
  ['/runs', runs, 'runs'],
  ['/runs/:id', run, 'runs'],
  ['/shader/:id', shader, 'runs'],
  ['/compare', compare, 'compare'],
  ['/accuracy', accuracy, 'accuracy'],
  ['/sweeps', sweeps, 'sweeps'],
  ['/sweeps/:id', sweep, 'sweeps'],
  ['/capture', capture, 'capture'],
  ['/heatmap', heatmap, 'capture'],
  ['/hosts', hosts, 'hosts'],
  ['/alerts', alerts, 'alerts'],
  ['/alerts/:id', alerts, 'alerts'],
  ['/trend/:id', trend, 'alerts'],
];

function match(path) {
  const parts = path.split('/').filter(Boolean);
  for (const [pattern, view, section] of kRoutes) {
    const want = pattern.split('/').filter(Boolean);
    if (want.length !== parts.length) continue;
    const params = {};
    if (want.every((w, i) => (w.startsWith(':') ? ((params[w.slice(1)] = decodeURIComponent(parts[i])), true) : w === parts[i]))) {
      return { view, section, params };
    }
  }
  return null;
}

let controller = null;
let renders = 0;  // views drawn so far, as #view's data-rendered: lets a test wait for the next one

function leave(root) {
  controller?.abort();
  destroyCharts(root);
  root.replaceChildren();
}

// With tokens on, the server answers 401/403: ask for the token here.
function tokenForm() {
  const input = h('input', { type: 'password', name: 'token', autocomplete: 'off', value: token(), 'aria-label': 'Token' });
  return h('form', { class: 'token-form', onsubmit: (e) => { e.preventDefault(); setToken(input.value.trim()); route(); } },
    h('label', {}, 'Token (read or capture) ', input), ' ', h('button', { type: 'submit' }, 'Use token'));
}

function showError(root, error) {
  const unauthorized = error instanceof ApiError && (error.status === 401 || error.status === 403);
  root.append(h('div', { class: 'panel error', role: 'alert' },
    h('strong', {}, 'Could not load this view: '), error.message,
    unauthorized ? tokenForm() : null));
}

async function route() {
  const root = document.getElementById('view');
  const hash = location.hash.replace(/^#/, '') || '/runs';
  startBadge();  // polls the open alerts' count; again after a token is given
  const [path, search = ''] = hash.split('?');
  leave(root);
  const found = match(path);
  for (const link of document.querySelectorAll('nav a')) {
    link.toggleAttribute('aria-current', Boolean(found) && link.dataset.section === found.section);
  }
  if (!found) {
    root.append(h('div', { class: 'panel error', role: 'alert' }, `No such page: ${path}. `, h('a', { href: '#/runs' }, 'Runs')));
    return;
  }
  const mine = new AbortController();
  controller = mine;
  const page = h('div', { class: 'page' });
  root.append(page);
  root.setAttribute('aria-busy', 'true');
  try {
    await found.view.render(page, { params: found.params, query: new URLSearchParams(search), signal: mine.signal });
  } catch (error) {
    if (!mine.signal.aborted) showError(page, error);  // else: left meanwhile, nothing to show
  } finally {
    if (controller === mine) {
      root.removeAttribute('aria-busy');
      root.dataset.rendered = String(++renders);
    }
  }
}

window.addEventListener('hashchange', route);
route();

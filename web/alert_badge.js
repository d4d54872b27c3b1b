// The navigation's alert badge: the number of open regression alerts
// (GET /api/alerts?status=open), fetched now and every kRefreshMs, and again
// whenever a view changes an alert (refreshBadge()).
import { get } from './api.js';

const kRefreshMs = 10000;

let pending = null;

export async function refreshBadge() {
  const badge = document.getElementById('alert-badge');
  if (!badge) return;
  try {
    const reply = await get('/alerts?status=open&limit=1');
    const open = reply.counts?.open ?? 0;
    badge.textContent = String(open);
    badge.dataset.count = String(open);
    badge.hidden = open === 0;
    badge.title = `${open} open alert${open === 1 ? '' : 's'}`;
  } catch {
    // No token yet, or the server is away: the badge keeps its last count.
  }
}

// Polls until the page is closed; the timer is the page's, not a view's.
export function startBadge() {
  if (pending) return;
  const tick = async () => {
    await refreshBadge();
    pending = setTimeout(tick, kRefreshMs);
  };
  tick();
}

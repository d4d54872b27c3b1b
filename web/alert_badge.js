// The navigation's alert badge: the number of open regression alerts
// (GET /api/alerts?status=open), fetched now and every kRefreshMs, and again
// whenever a view changes an alert (refreshBadge()). Without a token where
// the server wants one it stops asking until the next view is shown.
import { ApiError, get } from './api.js';

const kRefreshMs = 10000;

let polling = false;

// False when the server refused the request (401/403): no point asking again yet.
export async function refreshBadge() {
  const badge = document.getElementById('alert-badge');
  if (!badge) return false;
  try {
    const reply = await get('/alerts?status=open&limit=1');
    const open = reply.counts?.open ?? 0;
    badge.textContent = String(open);
    badge.dataset.count = String(open);
    badge.hidden = open === 0;
    badge.title = `${open} open alert${open === 1 ? '' : 's'}`;
    return true;
  } catch (error) {
    // The server is away: the badge keeps its last count and the next tick asks again.
    return !(error instanceof ApiError && (error.status === 401 || error.status === 403));
  }
}

// Polls until the page is closed or the server refuses; called again at each
// view, when it starts polling anew if it had stopped.
export function startBadge() {
  if (polling) return;
  polling = true;
  const tick = async () => {
    if (await refreshBadge()) {
      setTimeout(tick, kRefreshMs);
    } else {
      polling = false;
    }
  };
  tick();
}

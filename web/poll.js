// Waiting and polling that stop when a view is left (its AbortSignal).

// Waits ms, or less when the view is left.
export function sleep(ms, signal) {
  return new Promise((resolve) => {
    const done = () => {
      clearTimeout(timer);
      signal.removeEventListener('abort', done);
      resolve();
    };
    const timer = setTimeout(done, ms);
    signal.addEventListener('abort', done);
  });
}

const kWatchMs = 2 * 3600 * 1000;  // stop polling after two hours: reload to watch again

// Calls fn every `ms` until it returns true, the view is left, or kWatchMs pass.
export async function poll(fn, ms, signal) {
  const until = Date.now() + kWatchMs;
  while (!signal.aborted && Date.now() < until) {
    if (await fn()) return;
    await sleep(ms, signal);
  }
}

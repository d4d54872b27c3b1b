// A page of a browser context opened on one dashboard view and waited for:
// its console errors and uncaught exceptions collected, and no error panel.
import assert from 'node:assert/strict';

// { page, errors }: `errors` fills as the page logs; the view must have drawn within timeoutMs.
export async function viewPage(context, url, timeoutMs) {
  const page = await context.newPage();
  const errors = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(`uncaught: ${e.message}`));
  await page.goto(url);
  await page.waitForFunction(() => {
    const root = document.getElementById('view');
    return root && !root.hasAttribute('aria-busy') && root.querySelector('.page');
  }, null, { timeout: timeoutMs });
  assert.deepEqual(await page.locator('#view .panel.error').allTextContents(), [], 'the view shows an error');
  return { page, errors };
}

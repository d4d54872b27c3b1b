// The dashboard's one door to tallyd: every request goes through request()
// here (STYLE.md item 8: one module calls fetch). A JSON error from the server
// ({"error": {"code", "message", "field"}}) becomes an ApiError carrying them.

const kTokenKey = 'tally.token';

export class ApiError extends Error {
  constructor(status, code, message, field) {
    super(message);
    this.name = 'ApiError';
    this.status = status;
    this.code = code;
    this.field = field || null;
  }
}

// The bearer token, when the daemon runs with a token file; kept in this
// browser only.
export function token() {
  return localStorage.getItem(kTokenKey) || '';
}

export function setToken(value) {
  if (value) localStorage.setItem(kTokenKey, value);
  else localStorage.removeItem(kTokenKey);
}

// "?a=1&b=2" from an object, leaving out empty values; '' when none is set.
export function queryString(params) {
  const q = new URLSearchParams();
  for (const [key, value] of Object.entries(params)) {
    if (value !== undefined && value !== null && value !== '') q.set(key, String(value));
  }
  const text = q.toString();
  return text ? `?${text}` : '';
}

async function errorOf(response) {
  let body = null;
  try {
    body = await response.json();
  } catch {
    // Not JSON (a proxy's page, say): the status is all there is.
  }
  const e = body && body.error;
  if (e && typeof e.message === 'string') return new ApiError(response.status, e.code, e.message, e.field);
  return new ApiError(response.status, 'http_' + response.status, `${response.status} ${response.statusText}`);
}

// JSON in, JSON out. path is below /api ("/runs?limit=10"); options: method,
// body (sent as JSON), headers, signal (an AbortSignal, so that leaving a view
// drops its requests).
export async function request(path, { method = 'GET', body, headers = {}, signal } = {}) {
  const init = { method, headers: { Accept: 'application/json', ...headers }, signal };
  if (token()) init.headers.Authorization = `Bearer ${token()}`;
  if (body !== undefined) {
    init.headers['Content-Type'] = 'application/json';
    init.body = JSON.stringify(body);
  }
  const response = await fetch('/api' + path, init);
  if (!response.ok) throw await errorOf(response);
  return response.json();
}

export const get = (path, signal) => request(path, { signal });

// Every page of a cursor-paginated list, at most maxPages of them (a bound,
// so a growing table cannot keep a view loading forever).
export async function getAll(path, key, { limit = 1000, maxPages = 10, signal } = {}) {
  const items = [];
  let cursor = '';
  for (let page = 0; page < maxPages; ++page) {
    const sep = path.includes('?') ? '&' : '?';
    const reply = await get(`${path}${sep}limit=${limit}${cursor ? `&cursor=${encodeURIComponent(cursor)}` : ''}`, signal);
    items.push(...reply[key]);
    cursor = reply.next_cursor;
    if (!cursor) return { items, complete: true };
  }
  return { items, complete: false };
}

// An <img> source for an /api image path (a sample's "screenshot"). An <img>
// cannot send a bearer token, so with a token the image is fetched here and
// handed over as an object URL.
export async function imageSource(apiPath, signal) {
  if (!token()) return apiPath;
  const response = await fetch(apiPath, { headers: { Authorization: `Bearer ${token()}` }, signal });
  if (!response.ok) throw await errorOf(response);
  return URL.createObjectURL(await response.blob());
}

// The same for a download link (a sample's trace): a link cannot send a
// token either.
export const downloadSource = imageSource;

// Whether requests carry a token (links to /api paths then need downloadSource).
export const hasToken = () => Boolean(token());

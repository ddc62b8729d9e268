// The service's JSON API (/api/v1, docs/service.md). Every refusal is an RFC 9457 problem document
// (application/problem+json) whose `errors` lists every invalid field, {field, message}; ApiError carries them so
// that the page can show each message beside the field it names.

export const API = '/api/v1';
const TOKEN_KEY = 'runout.token';

export class ApiError extends Error {
  // errors: [{field, message}], the first also as `field` and the Error's message.
  constructor(status, field, message, errors = [{ field, message }]) {
    super(errors.length ? errors[0].message : message);
    this.status = status;
    this.errors = errors.length ? errors : [{ field, message }];
    this.field = this.errors[0].field || '';
  }
}

// The bearer token lives in sessionStorage only: this tab, gone when it closes.
export function token() {
  return sessionStorage.getItem(TOKEN_KEY) || '';
}
export function setToken(t) {
  if (t) sessionStorage.setItem(TOKEN_KEY, t);
  else sessionStorage.removeItem(TOKEN_KEY);
}

async function errorOf(res) {
  let body = null;
  try {
    body = await res.json();
  } catch {
    /* not JSON: a proxy's page, say */
  }
  if (body && Array.isArray(body.errors)) {
    const status = body.status || res.status;
    const detail = body.detail || body.title || `HTTP ${res.status}`;
    return new ApiError(status, '', detail, body.errors.length ? body.errors : [{ field: '', message: detail }]);
  }
  return new ApiError(res.status, '', `HTTP ${res.status} ${res.statusText}`);
}

// method, path under /api/v1, and a body: an object (sent as JSON) or a string (sent as it is, so that the
// API, not the page, judges pasted JSON).
export async function request(method, path, body) {
  const headers = { Accept: 'application/json' };
  if (body !== undefined) headers['Content-Type'] = 'application/json';
  if (method !== 'GET' && token()) headers.Authorization = `Bearer ${token()}`;
  let res;
  try {
    res = await fetch(API + path, {
      method,
      headers,
      body: body === undefined ? undefined : typeof body === 'string' ? body : JSON.stringify(body),
    });
  } catch (e) {
    throw new ApiError(0, '', `the service did not answer (${e.message})`);
  }
  if (!res.ok) throw await errorOf(res);
  const type = res.headers.get('Content-Type') || '';
  return type.startsWith('application/json') ? res.json() : res.text();
}

export const get = (path) => request('GET', path);
// Every item of a paged list (docs/service.md, "Lists"): the pages of `path`, following each one's `next`.
export async function getAll(path, member) {
  const items = [];
  for (let next = path; next; ) {
    const page = await get(next);
    items.push(...page[member]);
    next = page.next ? page.next.slice(API.length) : null;
  }
  return items;
}
export const post = (path, body) => request('POST', path, body);
export const del = (path) => request('DELETE', path);

// A CSV series (header row, then numbers) as {columns: [...], rows: number[][] by column}.
export function parseCsv(text) {
  const lines = text.split(/\r?\n/).filter((l) => l.length > 0);
  if (lines.length === 0) return { columns: [], data: [] };
  const columns = lines[0].split(',');
  const data = columns.map(() => []);
  for (let i = 1; i < lines.length; i++) {
    const cells = lines[i].split(',');
    for (let c = 0; c < columns.length; c++) {
      const v = Number(cells[c]);
      data[c].push(cells[c] === undefined || cells[c] === '' || !Number.isFinite(v) ? null : v);
    }
  }
  return { columns, data };
}

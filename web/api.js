// The service's JSON API (/api/v1, docs/service.md). Every refusal is {"error": {status, field, message}};
// ApiError carries it so the page can show the message beside the field it names.

export const API = '/api/v1';
const TOKEN_KEY = 'runout.token';

export class ApiError extends Error {
  constructor(status, field, message) {
    super(message);
    this.status = status;
    this.field = field || '';
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
  const e = body && body.error;
  if (e) return new ApiError(e.status || res.status, e.field, e.message);
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

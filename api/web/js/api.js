// The sketchslam HTTP API as the page calls it: every request carries the bearer token the
// user typed (kept in sessionStorage, so it lasts as long as the tab), and every failure
// becomes an ApiError holding the API's own words ({"error": {"code", "message"}}).

const TOKEN_KEY = 'sketchslam.token';

export function token() {
  return sessionStorage.getItem(TOKEN_KEY) || '';
}

export function setToken(value) {
  if (value) sessionStorage.setItem(TOKEN_KEY, value);
  else sessionStorage.removeItem(TOKEN_KEY);
}

export class ApiError extends Error {
  constructor(status, code, message) {
    super(message);
    this.status = status;
    this.code = code;
  }
  // "413 image_too_large: the image has ... pixels; the limit is ..."
  toString() {
    return this.status ? `${this.status} ${this.code}: ${this.message}` : this.message;
  }
}

export function authHeaders(extra = {}) {
  const h = { ...extra };
  const t = token();
  if (t) h.Authorization = `Bearer ${t}`;
  return h;
}

async function errorOf(resp) {
  let code = `http_${resp.status}`;
  let message = resp.statusText || 'request failed';
  try {
    const body = await resp.json();
    code = body.error.code;
    message = body.error.message;
  } catch (_) {
    // not an API error body: keep the status line
  }
  return new ApiError(resp.status, code, message);
}

// fetch() with the token; throws ApiError on a network failure or a 4xx/5xx.
// A 304 is returned as is (the caller asked with If-None-Match).
export async function request(method, path, { body, contentType, headers = {}, signal } = {}) {
  const h = authHeaders(headers);
  if (contentType) h['Content-Type'] = contentType;
  let resp;
  try {
    resp = await fetch(path, { method, body, headers: h, signal });
  } catch (e) {
    if (e.name === 'AbortError') throw e;
    throw new ApiError(0, 'network', `cannot reach the service (${e.message})`);
  }
  if (!resp.ok && resp.status !== 304) throw await errorOf(resp);
  return resp;
}

export async function getJson(path) {
  return (await request('GET', path)).json();
}

export async function postJson(path, value) {
  return (await request('POST', path, { body: JSON.stringify(value), contentType: 'application/json' })).json();
}

export async function del(path) {
  const resp = await request('DELETE', path);
  return resp.status === 204 ? null : resp.json();
}

// Uploads a drawing with its name and, when known, its scale (meters per pixel).
export async function uploadSketch(file, name, metersPerPixel) {
  const params = new URLSearchParams();
  if (name) params.set('name', name);
  if (metersPerPixel) params.set('meters_per_pixel', String(metersPerPixel));
  const query = params.toString();
  const q = query ? `?${query}` : '';
  const type = file.type || 'application/octet-stream';
  const resp = await request('POST', `/v1/sketches${q}`, { body: file, contentType: type });
  return resp.json();
}

// An object URL of a picture fetched with the token (an <img src> cannot send one).
export async function pictureUrl(path) {
  const resp = await request('GET', path);
  return URL.createObjectURL(await resp.blob());
}

// Saves what `path` answers as `filename`.
export async function download(path, filename) {
  const resp = await request('GET', path);
  const url = URL.createObjectURL(await resp.blob());
  const a = document.createElement('a');
  a.href = url;
  a.download = filename;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

// A picture that changes while a session maps, fetched again only when it changed:
// the ETag of the copy held goes out in If-None-Match and a 304 costs no bytes.
export class TaggedPicture {
  constructor(path) {
    this.path = path;
    this.etag = null;
    this.url = null;
  }

  // { changed, url, blob, headers } — `changed` false (and no blob) on a 304.
  async refresh() {
    const headers = this.etag ? { 'If-None-Match': this.etag } : {};
    const resp = await request('GET', this.path, { headers });
    if (resp.status === 304) return { changed: false, url: this.url, headers: resp.headers };
    const blob = await resp.blob();
    if (this.url) URL.revokeObjectURL(this.url);
    this.url = URL.createObjectURL(blob);
    this.etag = resp.headers.get('ETag');
    return { changed: true, url: this.url, blob, headers: resp.headers };
  }

  dispose() {
    if (this.url) URL.revokeObjectURL(this.url);
    this.url = null;
  }
}

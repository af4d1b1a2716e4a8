// A session's server-sent events (GET /v1/sessions/{id}/events) read with fetch() rather
// than EventSource, which cannot send the bearer token. Parses the text/event-stream
// format (event:, data:, id: lines; a blank line ends an event) and, when the connection
// drops while the session still runs, reconnects with Last-Event-ID so no pose is missed.

import { authHeaders } from './api.js';

const RETRY_MS = 1000;

export class SessionEvents {
  // handlers: { pose(PoseResponse), status(SessionInfo), end(), error(message) }
  constructor(sessionId, handlers) {
    this.path = `/v1/sessions/${encodeURIComponent(sessionId)}/events`;
    this.handlers = handlers;
    this.lastId = null;
    this.controller = null;
    this.closed = false;
    this.ended = false;
    this.run();
  }

  close() {
    this.closed = true;
    if (this.controller) this.controller.abort();
  }

  async run() {
    while (!this.closed && !this.ended) {
      try {
        await this.readOnce();
      } catch (e) {
        if (this.closed) return;
        this.handlers.error?.(`event stream: ${e.message}; reconnecting`);
      }
      if (!this.closed && !this.ended) await new Promise((r) => setTimeout(r, RETRY_MS));
    }
  }

  async readOnce() {
    this.controller = new AbortController();
    const headers = authHeaders({ Accept: 'text/event-stream' });
    if (this.lastId !== null) headers['Last-Event-ID'] = this.lastId;
    const resp = await fetch(this.path, { headers, signal: this.controller.signal });
    if (!resp.ok) {
      let message = `${resp.status}`;
      try { message = (await resp.json()).error.message; } catch (_) { /* keep the status */ }
      if (resp.status === 404) this.ended = true;
      throw new Error(message);
    }
    const reader = resp.body.pipeThrough(new TextDecoderStream()).getReader();
    let buffer = '';
    let event = { name: 'message', data: [], id: null };
    for (;;) {
      const { value, done } = await reader.read();
      if (done) break;
      buffer += value;
      let nl;
      while ((nl = buffer.search(/\r\n|\r|\n/)) >= 0) {
        const line = buffer.slice(0, nl);
        buffer = buffer.slice(nl + (buffer.startsWith('\r\n', nl) ? 2 : 1));
        if (line === '') {
          this.dispatch(event);
          event = { name: 'message', data: [], id: null };
          continue;
        }
        if (line.startsWith(':')) continue; // keep-alive comment
        const colon = line.indexOf(':');
        const field = colon < 0 ? line : line.slice(0, colon);
        let val = colon < 0 ? '' : line.slice(colon + 1);
        if (val.startsWith(' ')) val = val.slice(1);
        if (field === 'event') event.name = val;
        else if (field === 'data') event.data.push(val);
        else if (field === 'id') event.id = val;
      }
    }
    // The service ends the stream when the session stops.
    this.ended = true;
    this.handlers.end?.();
  }

  dispatch(event) {
    if (event.id !== null) this.lastId = event.id;
    if (event.data.length === 0) return;
    let value;
    try {
      value = JSON.parse(event.data.join('\n'));
    } catch (_) {
      return;
    }
    if (event.name === 'pose') this.handlers.pose?.(value);
    else if (event.name === 'status') this.handlers.status?.(value);
  }
}

// sketchslam's page: the wiring of its four parts. Drawings are uploaded (drop or file
// picker) and listed; the chosen one is shown with its numbered lines, and a click-and-drag
// on it marks the robot's start (or, in the other mode, a scale line whose length the user
// types); the page shows the exact POST /v1/sessions body it sends; sessions are listed and
// one is watched live (live_view.js).

import { ApiError, del, getJson, pictureUrl, postJson, setToken, token, uploadSketch } from './api.js';
import { LiveView } from './live_view.js';
import { PictureView } from './picture_view.js';

const $ = (id) => document.getElementById(id);
const DEG = 180 / Math.PI;

const state = {
  sketch: null,      // SketchInfo of the chosen drawing
  startView: null,   // PictureView of the start section
  drag: null,        // { mode, from } while the pointer is down on the drawing
  scaleLine: null,   // [a, b] pixels
  live: null,        // LiveView
};

function number(id) {
  const v = $(id).value.trim();
  return v === '' ? null : Number(v);
}

// ---- token -------------------------------------------------------------------------

function wireToken() {
  $('token').value = token();
  $('token').addEventListener('change', () => {
    setToken($('token').value.trim());
    refreshAll();
  });
}

async function checkService() {
  try {
    await getJson('/v1/sessions');
    $('service-status').textContent = 'connected';
  } catch (e) {
    $('service-status').textContent = e instanceof ApiError && e.status === 401
      ? 'this service needs a bearer token' : String(e);
  }
}

// ---- drawings ----------------------------------------------------------------------

async function upload(file) {
  $('upload-error').textContent = '';
  if (!file) return;
  $('upload-status').textContent = `uploading ${file.name} (${Math.round(file.size / 1024)} kB)…`;
  try {
    const info = await uploadSketch(file, $('sketch-name').value.trim() || file.name, number('sketch-mpp'));
    $('upload-status').textContent = `${info.name ?? info.id}: ${info.lines.length} lines found`;
    await listSketches();
    await chooseSketch(info.id);
  } catch (e) {
    $('upload-status').textContent = '';
    $('upload-error').textContent = `Upload refused: ${e}`;
  }
}

function wireUpload() {
  const zone = $('dropzone');
  $('file-input').addEventListener('change', () => upload($('file-input').files[0]));
  zone.addEventListener('dragover', (e) => { e.preventDefault(); zone.classList.add('over'); });
  zone.addEventListener('dragleave', () => zone.classList.remove('over'));
  zone.addEventListener('drop', (e) => {
    e.preventDefault();
    zone.classList.remove('over');
    upload(e.dataTransfer.files[0]);
  });
  zone.addEventListener('keydown', (e) => {
    if (e.target === zone && (e.key === 'Enter' || e.key === ' ')) {
      e.preventDefault();
      $('file-input').click();
    }
  });
}

async function listSketches() {
  const list = $('sketch-list');
  try {
    const { sketches } = await getJson('/v1/sketches');
    list.replaceChildren(...sketches.map((s) => {
      const li = document.createElement('li');
      li.dataset.id = s.id;
      if (state.sketch?.id === s.id) li.classList.add('selected');
      const name = document.createElement('span');
      name.className = 'grow';
      const scale = s.meters_per_pixel ? ` · ${s.meters_per_pixel} m/px` : '';
      name.textContent = `${s.name ?? s.id} · ${s.width_px}×${s.height_px} px · ${s.line_count} lines${scale}`;
      const use = document.createElement('button');
      use.type = 'button';
      use.textContent = 'Use';
      use.setAttribute('aria-label', `Use drawing ${s.name ?? s.id}`);
      use.onclick = () => chooseSketch(s.id);
      const remove = document.createElement('button');
      remove.type = 'button';
      remove.className = 'secondary';
      remove.textContent = 'Delete';
      remove.setAttribute('aria-label', `Delete drawing ${s.name ?? s.id}`);
      remove.onclick = async () => {
        try {
          await del(`/v1/sketches/${encodeURIComponent(s.id)}`);
          if (state.sketch?.id === s.id) clearSketch();
          await listSketches();
        } catch (e) {
          $('upload-error').textContent = `Delete refused: ${e}`;
        }
      };
      li.append(name, use, remove);
      return li;
    }));
  } catch (e) {
    $('upload-error').textContent = String(e);
  }
}

function clearSketch() {
  state.sketch = null;
  state.startView = new PictureView($('start-svg'));
  renderRequest();
}

async function chooseSketch(id) {
  $('start-error').textContent = '';
  try {
    const sketch = await getJson(`/v1/sketches/${encodeURIComponent(id)}`);
    const url = await pictureUrl(`/v1/sketches/${encodeURIComponent(id)}/lines.png`);
    state.sketch = sketch;
    state.scaleLine = null;
    state.startView = new PictureView($('start-svg'));
    state.startView.setPicture(url, sketch.width_px, sketch.height_px);
    state.startView.setLines(sketch.lines);
    $('start-svg').dataset.sketch = sketch.id;
    // A scale declared at upload is the drawing's: the form starts from it.
    if (sketch.meters_per_pixel) $('mpp').value = sketch.meters_per_pixel;
    const declared = sketch.meters_per_pixel ? ` Its scale, declared at upload: ${sketch.meters_per_pixel} m/px.` : '';
    $('start-hint').textContent = `Drawing ${sketch.name ?? sketch.id}: ${sketch.lines.length} numbered lines.${declared} `
      + 'Click where the robot stands and drag toward where it faces.';
    for (const li of $('sketch-list').children) li.classList.toggle('selected', li.dataset.id === id);
    drawStart();
    renderRequest();
  } catch (e) {
    $('start-error').textContent = String(e);
  }
}

// ---- start and scale on the drawing ------------------------------------------------

function markMode() {
  return $('mode-scale').checked ? 'scale' : 'start';
}

function drawStart() {
  const u = number('start-u');
  const v = number('start-v');
  const h = number('start-heading') ?? 0;
  state.startView?.setArrow('start', u === null || v === null ? null : { u, v, headingDeg: h }, 'start-marker');
  if (state.scaleLine) state.startView?.setScaleLine(...state.scaleLine);
}

function scaleFromLine() {
  if (!state.scaleLine) return;
  const [a, b] = state.scaleLine;
  const px = Math.hypot(b.u - a.u, b.v - a.v);
  $('scale-line-px').textContent = `scale line: ${px.toFixed(1)} px`;
  const m = number('scale-length');
  if (m !== null && m > 0 && px > 0) $('mpp').value = (m / px).toPrecision(4);
}

function wireDrawing() {
  const svg = $('start-svg');
  svg.addEventListener('pointerdown', (e) => {
    if (!state.sketch) return;
    const p = state.startView.toPixel(e);
    if (!p) return;
    svg.setPointerCapture(e.pointerId);
    state.drag = { mode: markMode(), from: p };
    if (state.drag.mode === 'start') {
      $('start-u').value = p.u.toFixed(1);
      $('start-v').value = p.v.toFixed(1);
    } else {
      state.scaleLine = [p, p];
    }
    drawStart();
    renderRequest();
  });
  svg.addEventListener('pointermove', (e) => {
    if (!state.drag) return;
    const p = state.startView.toPixel(e);
    if (!p) return;
    const { from } = state.drag;
    if (state.drag.mode === 'start') {
      // Rows grow downward: counter-clockwise on screen is atan2(-dv, du).
      if (Math.hypot(p.u - from.u, p.v - from.v) > 2) {
        $('start-heading').value = (Math.atan2(-(p.v - from.v), p.u - from.u) * DEG).toFixed(1);
      }
    } else {
      state.scaleLine = [from, p];
      scaleFromLine();
    }
    drawStart();
    renderRequest();
  });
  const end = () => { state.drag = null; };
  svg.addEventListener('pointerup', end);
  svg.addEventListener('pointercancel', end);
  for (const id of ['start-u', 'start-v', 'start-heading']) {
    $(id).addEventListener('input', () => { drawStart(); renderRequest(); });
  }
  $('scale-length').addEventListener('input', () => { scaleFromLine(); renderRequest(); });
  for (const id of ['mpp', 'robot-id', 'method']) $(id).addEventListener('input', renderRequest);
}

// ---- the request -------------------------------------------------------------------

function buildRequest() {
  const request = { robot_id: $('robot-id').value.trim(), method: $('method').value };
  if (request.method === 'sketch') {
    request.sketch_id = state.sketch?.id ?? null;
    const u = number('start-u');
    const v = number('start-v');
    request.start = u === null || v === null ? null : { u, v, heading_deg: number('start-heading') ?? 0 };
    request.meters_per_pixel = number('mpp');
  }
  return request;
}

function renderRequest() {
  $('request-preview').textContent = JSON.stringify(buildRequest(), null, 2);
}

async function startSession() {
  $('start-error').textContent = '';
  const request = buildRequest();
  if (request.method === 'sketch') {
    const missing = [];
    if (!request.sketch_id) missing.push('choose a drawing');
    if (!request.start) missing.push('mark the start on it');
    if (!request.meters_per_pixel) missing.push('set the scale (a line and its length, or meters per pixel)');
    if (missing.length) {
      $('start-error').textContent = `Before starting: ${missing.join('; ')}.`;
      return;
    }
  }
  try {
    const info = await postJson('/v1/sessions', request);
    await listSessions();
    watch(info);
  } catch (e) {
    $('start-error').textContent = `The service refused: ${e}`;
  }
}

// ---- sessions ----------------------------------------------------------------------

function sessionLine(s) {
  return `${s.id} · ${s.robot_id} · ${s.method} · ${s.state} · ${s.scans_processed} scans`;
}

// A status event of the watched session: its line in the list follows.
function sessionChanged(s) {
  const li = [...$('session-list').children].find((e) => e.dataset.id === s.id);
  const text = li?.querySelector('.grow');
  if (text) text.textContent = sessionLine(s);
}

async function listSessions() {
  try {
    const { sessions } = await getJson('/v1/sessions');
    $('session-list').replaceChildren(...sessions.slice().reverse().map((s) => {
      const li = document.createElement('li');
      li.dataset.id = s.id;
      if (state.live?.id === s.id) li.classList.add('selected');
      const text = document.createElement('span');
      text.className = 'grow';
      text.textContent = sessionLine(s);
      const open = document.createElement('button');
      open.type = 'button';
      open.textContent = 'Watch';
      open.setAttribute('aria-label', `Watch session ${s.id}`);
      open.onclick = () => watch(s);
      li.append(text, open);
      return li;
    }));
  } catch (e) {
    $('service-status').textContent = String(e);
  }
}

function watch(info) {
  state.live?.close();
  state.live = new LiveView(info, sessionChanged);
  for (const li of $('session-list').children) li.classList.toggle('selected', li.dataset.id === info.id);
  $('live').scrollIntoView({ behavior: 'smooth', block: 'start' });
}

async function refreshAll() {
  // A new token: what the old one was refused is no longer news.
  $('upload-error').textContent = '';
  $('start-error').textContent = '';
  await checkService();
  await Promise.all([listSketches(), listSessions()]);
}

wireToken();
wireUpload();
wireDrawing();
state.startView = new PictureView($('start-svg'));
$('start-button').addEventListener('click', startSession);
$('refresh-sessions').addEventListener('click', listSessions);
renderRequest();
refreshAll();

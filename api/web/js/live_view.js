// The live view of one session: the map as it grows with the trajectory and the robot on
// it, the robot and its trail on the drawing, the map laid on the drawing once registered,
// and the health panel. Poses and status come from the server-sent events; the map PNG is
// polled about once a second with its ETag (a 304 when nothing changed), the trajectory
// re-read when the map changed (loop closures move the past), and polling ends with the
// session.

import { ApiError, TaggedPicture, del, download, getJson, pictureUrl } from './api.js';
import { SessionEvents } from './events.js';
import { PictureView } from './picture_view.js';

const MAP_PERIOD_MS = 1000;
const OVERLAY_PERIOD_MS = 2000;
const TRAJECTORY_PERIOD_MS = 3000;
const RAD_TO_DEG = 180 / Math.PI;

const $ = (id) => document.getElementById(id);

function fmt(x, digits) {
  return x === null || x === undefined || Number.isNaN(x) ? '–' : Number(x).toFixed(digits);
}

export class LiveView {
  // info: SessionInfo; onChange(info): called with every status the view receives.
  constructor(info, onChange) {
    this.id = info.id;
    this.base = `/v1/sessions/${encodeURIComponent(info.id)}`;
    this.info = info;
    this.onChange = onChange;
    this.closed = false;
    this.mapFrame = null;
    this.mapTrail = [];
    this.sketchTrail = [];
    this.lastTrajectoryMs = 0;
    this.mapRefreshes = 0;
    this.mapView = new PictureView($('map-svg'));
    this.drawingView = new PictureView($('drawing-svg'));
    this.mapPicture = new TaggedPicture(`${this.base}/map.png`);
    this.overlayPicture = new TaggedPicture(`${this.base}/sketch-overlay.png`);
    $('live').hidden = false;
    $('live-id').textContent = `${info.id} · robot ${info.robot_id} · ${info.method}`;
    $('live-error').textContent = '';
    $('map-svg').dataset.refreshes = '0';
    const hasDrawing = info.method === 'sketch';
    $('drawing-figure').hidden = !hasDrawing;
    $('overlay-figure').hidden = !hasDrawing;
    $('overlay-image').removeAttribute('src');
    this.showHealth(info);
    this.wireButtons();
    if (hasDrawing) this.loadDrawing(info.sketch_id);
    this.events = new SessionEvents(info.id, {
      pose: (p) => this.onPose(p),
      status: (s) => this.onStatus(s),
      end: () => this.onStatus(this.info, true),
      error: (m) => { $('live-error').textContent = m; },
    });
    this.pollMap();
    if (hasDrawing) this.pollOverlay();
  }

  close() {
    this.closed = true;
    this.events.close();
    this.mapPicture.dispose();
    this.overlayPicture.dispose();
  }

  get running() {
    return !['stopped', 'failed', 'interrupted'].includes(this.info.state);
  }

  wireButtons() {
    const report = (e) => { $('live-error').textContent = String(e); };
    $('download-pgm').onclick = () => download(`${this.base}/map.pgm`, 'map.pgm').catch(report);
    $('download-yaml').onclick = () => download(`${this.base}/map.yaml`, 'map.yaml').catch(report);
    $('download-png').onclick = () => download(`${this.base}/map.png`, 'map.png').catch(report);
    $('stop-button').onclick = async () => {
      $('stop-button').disabled = true;
      try {
        this.onStatus(await del(this.base));
      } catch (e) {
        report(e);
        $('stop-button').disabled = false;
      }
    };
    $('stop-button').disabled = !this.running;
  }

  async loadDrawing(sketchId) {
    try {
      const sketch = await getJson(`/v1/sketches/${encodeURIComponent(sketchId)}`);
      const url = await pictureUrl(`/v1/sketches/${encodeURIComponent(sketchId)}/lines.png`);
      this.drawingView.setPicture(url, sketch.width_px, sketch.height_px);
    } catch (e) {
      // A deleted drawing: the session keeps its copy, the page has none to show.
      $('live-error').textContent = `the drawing: ${e}`;
    }
  }

  showHealth(s) {
    $('h-state').textContent = s.stop_reason ? `${s.state} (${s.stop_reason})` : s.state;
    $('h-scans').textContent = String(s.scans_processed);
    $('h-lost').textContent = String(s.scans_lost);
    $('h-score').textContent = fmt(s.localization_score, 2);
    $('h-scale').textContent = fmt(s.estimated_meters_per_pixel, 4);
    $('h-recoveries').textContent = String(s.recoveries);
    $('h-loops').textContent = String(s.loop_closures);
    // A running session is checkpointed; a stopped one is stored; an interrupted one is
    // what its last checkpoint kept when the service ended.
    const at = (ms) => new Date(ms).toLocaleTimeString();
    $('h-saved').textContent = s.state === 'interrupted'
      ? `its last checkpoint${s.checkpoint_unix_ms ? `, ${at(s.checkpoint_unix_ms)}` : ''}: the service ended while it ran`
      : s.stopped_unix_ms ? `stored at its stop, ${at(s.stopped_unix_ms)}`
      : s.checkpoint_unix_ms ? `checkpoint at ${at(s.checkpoint_unix_ms)}` : 'not yet';
    if (s.last_error) $('live-error').textContent = s.last_error;
  }

  onStatus(s, ended = false) {
    const before = this.info.state;
    this.info = ended && this.running ? { ...s, state: 'stopped' } : s;
    this.showHealth(this.info);
    $('stop-button').disabled = !this.running;
    this.onChange?.(this.info);
    if (before !== this.info.state && !this.running) this.refreshTrajectory();
  }

  onPose(p) {
    $('h-pose').textContent = `x ${fmt(p.x, 2)} m, y ${fmt(p.y, 2)} m, ${fmt(p.theta * RAD_TO_DEG, 1)}°`;
    this.mapTrail.push({ x: p.x, y: p.y });
    this.lastMapPose = { x: p.x, y: p.y, theta: p.theta };
    this.drawMapMarks();
    if (p.sketch) {
      const s = { u: p.sketch.u, v: p.sketch.v, headingDeg: p.sketch.heading_deg };
      this.sketchTrail.push(s);
      this.drawingView.setTrail(this.sketchTrail);
      this.drawingView.setArrow('robot', s, 'robot');
    }
  }

  // Map meters to map-picture pixels (rows from the top).
  toMapPixel(x, y) {
    const f = this.mapFrame;
    return { u: (x - f.ox) / f.res, v: f.h - (y - f.oy) / f.res };
  }

  drawMapMarks() {
    if (!this.mapFrame) return;
    this.mapView.setTrail(this.mapTrail.map((p) => this.toMapPixel(p.x, p.y)));
    const p = this.lastMapPose;
    if (p) {
      const q = this.toMapPixel(p.x, p.y);
      this.mapView.setArrow('robot', { ...q, headingDeg: p.theta * RAD_TO_DEG }, 'robot');
    }
  }

  async refreshTrajectory() {
    this.lastTrajectoryMs = Date.now();
    try {
      const t = await getJson(`${this.base}/trajectory`);
      this.mapTrail = t.points.map((p) => ({ x: p.x, y: p.y }));
      const last = t.points[t.points.length - 1];
      if (last) this.lastMapPose = { x: last.x, y: last.y, theta: last.theta };
      this.drawMapMarks();
      if (this.info.method === 'sketch') {
        const s = await getJson(`${this.base}/trajectory?frame=sketch`);
        this.sketchTrail = s.points.map((p) => ({ u: p.u, v: p.v, headingDeg: p.heading * RAD_TO_DEG }));
        this.drawingView.setTrail(this.sketchTrail);
        const end = this.sketchTrail[this.sketchTrail.length - 1];
        if (end) this.drawingView.setArrow('robot', end, 'robot');
      }
    } catch (e) {
      if (!(e instanceof ApiError && e.status === 422)) $('live-error').textContent = `trajectory: ${e}`;
    }
  }

  async pollMap() {
    while (!this.closed) {
      const wasRunning = this.running;
      try {
        const r = await this.mapPicture.refresh();
        if (r.changed) {
          const res = Number(r.headers.get('X-Map-Resolution-M'));
          const ox = Number(r.headers.get('X-Map-Origin-X-M'));
          const oy = Number(r.headers.get('X-Map-Origin-Y-M'));
          const img = await createImageBitmap(r.blob);
          this.mapFrame = { res, ox, oy, h: img.height };
          this.mapView.setPicture(r.url, img.width, img.height);
          img.close();
          this.mapRefreshes += 1;
          $('map-svg').dataset.refreshes = String(this.mapRefreshes);
          if (Date.now() - this.lastTrajectoryMs > TRAJECTORY_PERIOD_MS) await this.refreshTrajectory();
          else this.drawMapMarks();
        }
      } catch (e) {
        if (this.closed) return;
        $('live-error').textContent = `map: ${e}`;
      }
      // One last look after the session ended, then stop.
      if (!wasRunning) return;
      await new Promise((r) => setTimeout(r, MAP_PERIOD_MS));
    }
  }

  async pollOverlay() {
    while (!this.closed) {
      const wasRunning = this.running;
      try {
        const r = await this.overlayPicture.refresh();
        if (r.changed) $('overlay-image').src = r.url;
        $('overlay-status').textContent = '';
      } catch (e) {
        if (this.closed) return;
        // 409 not_registered: nothing mapped to lay on the drawing yet.
        $('overlay-status').textContent = e instanceof ApiError && e.status === 409 ? '(nothing mapped to lay on it yet)' : String(e);
      }
      if (!wasRunning) return;
      await new Promise((r) => setTimeout(r, OVERLAY_PERIOD_MS));
    }
  }
}

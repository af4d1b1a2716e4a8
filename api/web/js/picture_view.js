// An SVG view of a picture in its own pixels (a drawing, or a map PNG) with marks drawn
// over it: numbered lines, a trail, an arrow for a pose, a dashed scale line. The viewBox
// is the picture's pixel grid, so a mark at pixel (u, v) is drawn at (u, v) whatever the
// size on screen; toPixel() turns a pointer position back into picture pixels.
//
// Headings are counter-clockwise from the picture's +u axis (rows grow downward), as the
// API gives them; SVG's rotate() turns clockwise on screen, hence the minus signs.

const NS = 'http://www.w3.org/2000/svg';

function el(name, attrs = {}, parent = null) {
  const e = document.createElementNS(NS, name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (parent) parent.append(e);
  return e;
}

export class PictureView {
  constructor(svg) {
    this.svg = svg;
    this.width = 0;
    this.height = 0;
    svg.replaceChildren();
    this.image = el('image', { x: 0, y: 0, preserveAspectRatio: 'none' }, svg);
    this.lines = el('g', { class: 'lines' }, svg);
    this.overlay = el('g', {}, svg);
    this.trail = el('polyline', { class: 'trail', points: '' }, svg);
    this.marks = el('g', {}, svg);
    this.named = new Map();
  }

  // A size for marks: about 1/80 of the picture's larger side, in its pixels.
  get unit() {
    return Math.max(this.width, this.height, 40) / 80;
  }

  setPicture(url, width, height) {
    const resized = width !== this.width || height !== this.height;
    this.width = width;
    this.height = height;
    this.svg.setAttribute('viewBox', `0 0 ${width} ${height}`);
    this.image.setAttribute('width', width);
    this.image.setAttribute('height', height);
    this.image.setAttribute('href', url);
    if (resized) this.trail.setAttribute('stroke-width', this.unit * 0.35);
  }

  // The drawing's extracted lines (the PNG draws and numbers them) as SVG lines a pointer
  // or a screen reader can find: each titled with its number, length and direction.
  setLines(lines) {
    this.lines.replaceChildren();
    for (const line of lines) {
      const l = el('line', {
        x1: line.a.u, y1: line.a.v, x2: line.b.u, y2: line.b.v,
        class: 'sketch-line', 'stroke-width': this.unit * 0.8, 'data-index': line.index,
      }, this.lines);
      el('title', {}, l).textContent =
        `line ${line.index}: ${line.length_px.toFixed(0)} px at ${line.angle_deg.toFixed(0)}°`;
    }
  }

  // Picture pixels under a pointer event.
  toPixel(event) {
    const ctm = this.svg.getScreenCTM();
    if (!ctm) return null;
    const p = new DOMPoint(event.clientX, event.clientY).matrixTransform(ctm.inverse());
    return { u: p.x, v: p.y };
  }

  // An arrow named `name` at (u, v) facing `headingDeg`; null removes it.
  setArrow(name, pose, cls) {
    let g = this.named.get(name);
    if (!pose) {
      if (g) g.remove();
      this.named.delete(name);
      return;
    }
    if (!g) {
      g = el('g', { class: cls, 'data-name': name }, this.marks);
      const s = 1;
      el('polygon', { points: `${2.2 * s},0 ${-1.2 * s},${1.3 * s} ${-0.6 * s},0 ${-1.2 * s},${-1.3 * s}` }, g);
      this.named.set(name, g);
    }
    const k = this.unit * 1.4;
    g.setAttribute('transform', `translate(${pose.u} ${pose.v}) rotate(${-pose.headingDeg}) scale(${k})`);
    g.setAttribute('stroke-width', 0.15);
    g.dataset.u = pose.u.toFixed(2);
    g.dataset.v = pose.v.toFixed(2);
  }

  // A dashed line from a to b (pixels); null removes it.
  setScaleLine(a, b) {
    this.overlay.replaceChildren();
    if (!a || !b) return;
    el('line', { x1: a.u, y1: a.v, x2: b.u, y2: b.v, class: 'scale-line', 'stroke-width': this.unit * 0.4 }, this.overlay);
    for (const p of [a, b]) el('circle', { cx: p.u, cy: p.v, r: this.unit * 0.6, fill: '#f29900' }, this.overlay);
  }

  // The trail through `points` ([{u, v}]), in picture pixels.
  setTrail(points) {
    this.trail.setAttribute('points', points.map((p) => `${p.u.toFixed(1)},${p.v.toFixed(1)}`).join(' '));
    this.trail.setAttribute('stroke-width', this.unit * 0.35);
  }
}

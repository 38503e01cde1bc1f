"""What runs in the page besides Dash: brushes turned into a selection, the view's state in
the URL, and a record of the main thread's long tasks.

N, ND and NP are *not* computed here: the server counts (:func:`~vectorid.views.ui.explore.
counts_view`, over the cached columns, a tightened constraint narrowed from the last D, see
:meth:`~vectorid.analysis.Analysis.narrowed`) and the page only waits for the answer, so the
page's main thread never scans a million trials. Measured at 1e6 trials, the server's answer
comes back in a fraction of the time the former in-page scan held the page frozen (see
``docs/ui.md``), and the page no longer loads the columns at all (41 MB at 1e6).

* :data:`VID_JS` (served at ``/_vid/vid.js``) defines ``window.vid``:

  - ``vid.parRender(data, selection, view)``: the parallel coordinates drawn by the page
    (SVG axes, the lines on a 2D canvas by a Web Worker; no plotly.js, no WebGL) from the
    server's answer (:func:`vectorid.views.ui.parallel.parallel_view`). A drag along an axis
    adds a range to the ``selection`` (``{"kind": "ranges", "ranges": {name: [[lo, hi],
    ...]}}``, every range of every brushed axis, both edges; overlapping ranges of one axis
    merge), a click on a range removes it, a title dragged sideways moves its axis (the
    ``par-view`` store's ``order``); each is set in the page's stores at once
    (``dash_clientside.set_props``);
  - ``vid.readState(hash)`` / ``vid.writeState(state, defaults)``: the view's state to and
    from the URL's fragment (``#lim.f1=20&tab=parallel&trial=110&...``, see
    :data:`STATE_KEYS`);
  - ``vid.lazyRows(ids, figs, rev)``: the rows of a figure grid (the refine view's
    histograms: nine rows of four panels at 33 variables) drawn by plotly.js into the
    elements ``ids``, each once it is shown and within 300 px of the window, one row a task,
    top first; ``vid.lazyIdle()`` says whether every row on screen shows the latest answer
    (each drawn row's element carries ``data-rev`` and ``data-at``);
  - ``window.__vidLongTasks``: durations (ms) of the main thread's tasks over 50 ms
    (``PerformanceObserver`` ``longtask``), read by ``benchmarks/ui.py``.
"""

from __future__ import annotations

__all__ = ["PAR_JS", "READ_URL_JS", "STATE_KEYS", "VID_JS", "WRITE_URL_JS"]

#: The keys of the URL fragment: ``lim.<criterion>`` (the Φ** field's text), ``role.<criterion>``
#: (``pure``/``pseudo``), ``low.<constraint>``/``high.<constraint>`` (functional bounds), ``tab``,
#: ``x``/``y`` (criterion plot axes), ``panel`` and ``crit`` (lower panel), ``trial`` (chosen
#: trial), ``sel`` (the selection as JSON), ``axes``/``hide``/``colour`` (parallel axes: order,
#: hidden ones, colour-by). A field equal to the value the page opens with is left out.
STATE_KEYS = (
    "lim.",
    "role.",
    "low.",
    "high.",
    "tab",
    "x",
    "y",
    "panel",
    "crit",
    "trial",
    "sel",
    "axes",
    "hide",
    "colour",
)

VID_JS = r"""
(function(){
window.__vidLongTasks = window.__vidLongTasks || [];
try {
  new PerformanceObserver(list => {
    for (const e of list.getEntries()) window.__vidLongTasks.push(e.duration);
  }).observe({type: 'longtask', buffered: true});
} catch (e) { /* no longtask timing in this browser */ }

function ranges(v) {
  // [lo, hi] | [[lo, hi], ...] | [[[lo, hi], ...]] | null -> [[lo, hi], ...] (sorted)
  if (v === null || v === undefined) return [];
  while (Array.isArray(v) && v.length === 1 && Array.isArray(v[0])) v = v[0];
  if (!Array.isArray(v) || !v.length) return [];
  const list = typeof v[0] === 'number' ? [v] : v;
  const out = [];
  for (const r of list) {
    if (!Array.isArray(r) || r.length < 2) continue;
    const a = Number(r[0]), b = Number(r[1]);
    if (isFinite(a) && isFinite(b)) out.push([Math.min(a, b), Math.max(a, b)]);
  }
  return out.sort((p, q) => p[0] - q[0]);
}

// the view's state <-> the URL's fragment
function readState(hash) {
  const p = new URLSearchParams(String(hash || '').replace(/^#/, ''));
  const s = {};
  for (const [k, v] of p.entries()) s[k] = v;
  return s;
}
function writeState(state, defaults) {
  const p = new URLSearchParams();
  for (const k of Object.keys(state)) {
    let v = state[k];
    if (v === null || v === undefined) v = '';
    if (typeof v !== 'string') v = JSON.stringify(v);
    let d = defaults && k in defaults ? defaults[k] : undefined;
    if (d !== undefined && d !== null && typeof d !== 'string') d = JSON.stringify(d);
    if (d !== undefined && (d === null ? '' : d) === v) continue;
    if (d === undefined && v === '') continue;
    p.set(k, v);
  }
  const h = p.toString();
  const url = window.location.pathname + window.location.search + (h ? '#' + h : '');
  if (url !== window.location.pathname + window.location.search + window.location.hash) {
    window.history.replaceState(null, '', url);
  }
  return h;
}
// what a tab's views are sent: its fields while it is shown, and only when they differ from
// what its views were last sent (``current``, the gate's own data): coming back to a tab
// redraws nothing that did not change
window.vidGate = function(name, tab, fields, sel, version, current) {
  if (tab !== name) return dash_clientside.no_update;
  const out = [fields, version];
  if (sel !== undefined) out.push(sel);
  if (current && JSON.stringify(current) === JSON.stringify(out)) {
    return dash_clientside.no_update;
  }
  return out;
};
// -- the parallel coordinates' lines, drawn by the page -------------------------------------
// plotly.js keeps the axes, brushes and axis order (its WebGL canvases are hidden by the
// page's style); the lines of ``layout.meta.lines`` are drawn on a 2D canvas by a Web Worker
// (OffscreenCanvas), or on the main thread where the browser has no OffscreenCanvas.
function parDraw(g, job) {
  const r = job.dpr, W = job.w, H = job.h;
  if (g.canvas.width !== Math.round(W * r) || g.canvas.height !== Math.round(H * r)) {
    g.canvas.width = Math.round(W * r); g.canvas.height = Math.round(H * r);
  }
  g.setTransform(r, 0, 0, r, 0, 0);
  g.clearRect(0, 0, W, H);
  g.lineWidth = 1;
  const ax = job.axes, n = job.n, sel = job.sel, style = job.style, cls = job.cls;
  let drawn = 0, chosen = 0;
  function one(i) {
    let pen = false;
    g.beginPath();
    for (let k = 0; k < ax.length; k++) {
      const v = ax[k].v[i];
      if (!(v === v) || !isFinite(v)) { pen = false; continue; }
      const y = ax[k].a * v + ax[k].b;
      if (pen) g.lineTo(ax[k].x, y); else { g.moveTo(ax[k].x, y); pen = true; }
    }
    g.stroke();
    drawn++;
  }
  // lines outside the brushes first, in the unselected colour; then the others in order
  // (infeasible, in D, Pareto: Pareto on top), each stroke adding to the density
  if (job.anySel) {
    g.strokeStyle = job.unsel.color; g.globalAlpha = job.unsel.alpha;
    for (let i = 0; i < n; i++) if (!sel[i]) one(i);
  }
  let cur = -1;
  for (let i = 0; i < n; i++) {
    if (job.anySel && !sel[i]) continue;
    const c = cls[i];
    if (c !== cur) { g.strokeStyle = style[c][0]; g.globalAlpha = style[c][1]; cur = c; }
    one(i); chosen++;
  }
  g.globalAlpha = 1;
  return {lines: n, selected: chosen, drawn: drawn};
}

const PAR_WORKER = 'const parDraw = ' + parDraw.toString() + ';\n' +
  'let g = null, latest = null, due = false;\n' +
  'onmessage = (e) => {\n' +
  '  if (e.data.canvas) g = e.data.canvas.getContext("2d");\n' +
  '  if (e.data.job) { latest = e.data.job; if (!due) { due = true; setTimeout(run, 0); } }\n' +
  '};\n' +
  'function run() {\n' +
  '  due = false; if (!g || !latest) return; const job = latest; latest = null;\n' +
  '  const t0 = performance.now(); const out = parDraw(g, job);\n' +
  '  out.ms = performance.now() - t0; out.seq = job.seq; postMessage(out);\n' +
  '}\n';

const VIRIDIS = ['#440154', '#482878', '#3e4989', '#31688e', '#26828e', '#1f9e89',
  '#35b779', '#6ece58', '#b5de2b', '#fde725'];
const decoded = new WeakMap();
const DTYPES = {f4: Float32Array, f8: Float64Array, i1: Int8Array, u1: Uint8Array,
  i2: Int16Array, u2: Uint16Array, i4: Int32Array, u4: Uint32Array};
function typed(v) {
  // an array as plotly.py sends it (plain, or {dtype, bdata}) as a typed array, decoded once
  if (v && typeof v === 'object' && !Array.isArray(v) && v.bdata !== undefined) {
    let hit = decoded.get(v);
    if (!hit) {
      const bin = atob(v.bdata), buf = new Uint8Array(bin.length);
      for (let i = 0; i < bin.length; i++) buf[i] = bin.charCodeAt(i);
      hit = new (DTYPES[v.dtype] || Float32Array)(buf.buffer);
      decoded.set(v, hit);
    }
    return hit;
  }
  if (ArrayBuffer.isView(v)) return v;
  return Float64Array.from(v || []);
}

// -- the parallel coordinates, drawn by the page ---------------------------------------------
// The server sends the axes (name, title with unit, hover text, range, the limit in force)
// and the lines (float32 per axis, thinned per set); the page lays the axes out in SVG and a
// Web Worker draws the lines on a 2D canvas (OffscreenCanvas; on the main thread where a
// browser has none). No WebGL: plotly.js's parcoords needed three WebGL layers, and in
// software rendering their first draw held the main thread 4-14 s at 41 axes.
//
// Axes 86 px or more apart get their titles across, on two lines (name, [unit]); closer ones
// get them upright, one line, so that no two titles overlap however many axes are shown.
// Tick labels sit left of each axis where they fit between two axes; where they do not, each
// axis shows only its two ends, centred on it, on alternate rows. Below MIN_GAP px the axes
// are spread wider than the page, which then scrolls sideways.
const SVGNS = 'http://www.w3.org/2000/svg';
const FONT = '12px system-ui, -apple-system, Segoe UI, Roboto, sans-serif';
const TICK_FONT = '11px system-ui, -apple-system, Segoe UI, Roboto, sans-serif';
const MIN_GAP = 18;
const par = {worker: null, seq: 0, data: null, sel: null, order: null, host: null,
  geom: null, view: null, shown: null, due: false};
let measurer = null;
function textWidth(s, font) {
  measurer = measurer || document.createElement('canvas').getContext('2d');
  measurer.font = font;
  return measurer.measureText(String(s)).width;
}
function svg(tag, attrs, parent) {
  const e = document.createElementNS(SVGNS, tag);
  for (const k of Object.keys(attrs || {})) e.setAttribute(k, attrs[k]);
  if (parent) parent.appendChild(e);
  return e;
}
function tip(e, text) { svg('title', {}, e).textContent = text; return e; }
function niceTicks(lo, hi, n) {
  const span = hi - lo;
  if (!(span > 0)) return {ticks: [lo], step: 1};
  const raw = span / n, p = Math.pow(10, Math.floor(Math.log10(raw))), m = raw / p;
  const step = (m >= 5 ? 10 : m >= 2 ? 5 : m >= 1 ? 2 : 1) * p;
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) {
    out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  }
  return {ticks: out, step: step};
}
function num(v) {  // a tick or range label, at most about six characters
  if (v === 0) return '0';
  let s = String(Number(v.toPrecision(3)));
  if (s.length > 6) s = Number(v.toPrecision(2)).toExponential().replace('e+', 'e');
  return s;
}
function ensureWorker() {
  if (par.worker !== null || !window.Worker) return;
  try {
    const url = URL.createObjectURL(new Blob([PAR_WORKER], {type: 'text/javascript'}));
    par.worker = new Worker(url);
    par.worker.onmessage = e => {
      const c = document.querySelector('#par-graph canvas.vid-lines');
      if (c) parDone(c, e.data);
    };
  } catch (e) { par.worker = false; }
}
function parDone(cv, out) {  // what was drawn, for tests and benchmarks
  cv.dataset.lines = out.lines; cv.dataset.selected = out.selected;
  cv.dataset.ms = Math.round(out.ms || 0); cv.dataset.seq = out.seq || 0;
  cv.dataset.at = Math.round(performance.now());
}
function shownAxes() {
  const by = {};
  for (const a of par.data.axes) by[a.name] = a;
  const order = (par.order || []).filter(n => by[n]);
  for (const a of par.data.axes) if (!order.includes(a.name)) order.push(a.name);
  const show = par.shown ? new Set(par.shown) : null;
  return order.map(n => by[n]).filter(a => (show ? show.has(a.name) : !a.hidden));
}
function layout(host) {
  const axes = shownAxes(), n = axes.length;
  const width0 = Math.max(320, host.clientWidth || 1200);
  const mL = 60, mR = 60;
  const tickW = axes.map(a => {
    const t = niceTicks(a.range[0], a.range[1], 5).ticks;
    return Math.max(0, ...t.map(v => textWidth(num(v), TICK_FONT)));
  });
  const endW = axes.map(a => Math.max(textWidth(num(a.range[0]), TICK_FONT),
    textWidth(num(a.range[1]), TICK_FONT)));
  let gap = n > 1 ? (width0 - mL - mR) / (n - 1) : 0;
  const need = Math.max(MIN_GAP, (Math.max(0, ...endW) + 6) / 2);
  if (n > 1 && gap < need) gap = need;  // wider than the page: it scrolls sideways
  const width = n > 1 ? Math.ceil(mL + mR + gap * (n - 1)) : width0;
  const two = axes.map(a => [a.name, '[' + a.unit + ']']);
  const across = n < 2 || Math.max(...two.map(t => Math.max(textWidth(t[0], FONT),
    textWidth(t[1], FONT)))) + 10 <= gap;
  const upright = across ? 0 : Math.max(...axes.map(a => textWidth(a.title, FONT)));
  const ticksFit = n < 2 || Math.max(...tickW) + 14 <= gap;
  const titleH = across ? 34 : Math.ceil(upright) + 12;
  const ends = ticksFit ? 18 : 32;
  const top = titleH + ends, H = par.data.height || 470, bottom = H - (ticksFit ? 28 : 40);
  const xs = axes.map((a, i) => n > 1 ? mL + gap * i : width / 2);
  return {axes: axes, xs: xs, gap: gap, width: width, height: H, top: top, bottom: bottom,
    across: across, ticksFit: ticksFit, titleH: titleH};
}
function yOf(g, a, v) {
  const lo = a.range[0], hi = a.range[1];
  if (!(hi > lo)) return (g.top + g.bottom) / 2;
  return g.top + (hi - v) / (hi - lo) * (g.bottom - g.top);
}
function vOf(g, a, y) {
  const lo = a.range[0], hi = a.range[1];
  const t = Math.max(0, Math.min(1, (y - g.top) / (g.bottom - g.top)));
  return hi - t * (hi - lo);
}
function selRanges() {
  return (par.sel && par.sel.kind === 'ranges' && par.sel.ranges) ? par.sel.ranges : {};
}
function drawBrushes() {
  const g = par.geom;
  if (!g) return;
  const rs = selRanges();
  g.axes.forEach((a, i) => {
    const grp = g.brushes[i];
    while (grp.firstChild) grp.removeChild(grp.firstChild);
    for (const r of ranges(rs[a.name])) {
      const y1 = yOf(g, a, r[1]), y0 = yOf(g, a, r[0]);
      tip(svg('rect', {x: g.xs[i] - 6, y: Math.min(y0, y1), width: 12,
        height: Math.max(2, Math.abs(y0 - y1)), class: 'vid-brush',
        'data-lo': r[0], 'data-hi': r[1]}, grp),
        a.name + ' in [' + num(r[0]) + ', ' + num(r[1]) + '] (click to remove)');
    }
  });
}
function setSel(sel) {
  par.sel = sel;
  drawBrushes();
  linesSoon();
  if (window.dash_clientside && dash_clientside.set_props) {
    dash_clientside.set_props('selection', {data: sel});
  }
}
function commitRange(name, lo, hi, remove) {
  const cur = selRanges(), next = {};
  for (const k of Object.keys(cur)) next[k] = ranges(cur[k]);
  let rs = next[name] || [];
  if (remove) {
    rs = rs.filter(r => !(remove >= r[0] && remove <= r[1]));
  } else {
    rs.push([lo, hi]);
    rs.sort((p, q) => p[0] - q[0]);
    const merged = [];
    for (const r of rs) {  // overlapping bands of one axis become one
      const last = merged[merged.length - 1];
      if (last && r[0] <= last[1]) last[1] = Math.max(last[1], r[1]);
      else merged.push([r[0], r[1]]);
    }
    rs = merged;
  }
  if (rs.length) next[name] = rs; else delete next[name];
  setSel(Object.keys(next).length ? {kind: 'ranges', ranges: next} : null);
}
function setOrder(names) {
  if (!par.data) {  // not drawn yet: the order is kept for the first drawing
    par.view = Object.assign({order: []}, par.view || {}, {order: names.slice()});
    if (window.dash_clientside && dash_clientside.set_props) {
      dash_clientside.set_props('par-view', {data: par.view});
    }
    return;
  }
  const all = par.data.axes.map(a => a.name), shown = names.slice();
  const rest = (par.order || all).filter(n => !shown.includes(n));
  par.order = shown.concat(rest.filter(n => all.includes(n)));
  const v = Object.assign({order: []}, par.view || {}, {order: par.order});
  par.view = v;
  if (window.dash_clientside && dash_clientside.set_props) {
    dash_clientside.set_props('par-view', {data: v});
  }
  build();
}
function build() {
  const host = document.querySelector('#par-graph');
  if (!host || !par.data) return;
  par.host = host;
  while (host.firstChild) host.removeChild(host.firstChild);
  const g = layout(host);
  par.geom = g;
  const head = document.createElement('div');
  head.className = 'vid-par-title';
  head.textContent = par.data.title;
  host.appendChild(head);
  if (par.data.colour) {
    const c = par.data.colour, bar = document.createElement('div');
    bar.className = 'vid-par-colour muted';
    bar.append('colour: ' + c.title + ' ' + num(c.min) + ' ');
    for (const col of VIRIDIS) {
      const s = document.createElement('span');
      s.style.cssText = 'display:inline-block;width:14px;height:10px;background:' + col;
      bar.appendChild(s);
    }
    bar.append(' ' + num(c.max));
    host.appendChild(bar);
  }
  const box = document.createElement('div');
  box.className = 'vid-par-box';
  box.style.cssText = 'position:relative;width:' + g.width + 'px;height:' + g.height + 'px';
  host.appendChild(box);
  const cv = document.createElement('canvas');
  cv.className = 'vid-lines';
  cv.style.cssText = 'position:absolute;left:0;top:0;pointer-events:none;width:' + g.width +
    'px;height:' + g.height + 'px';
  box.appendChild(cv);
  ensureWorker();
  if (par.worker && cv.transferControlToOffscreen) {
    try {
      const off = cv.transferControlToOffscreen();
      par.worker.postMessage({canvas: off}, [off]);
      cv.vidWorker = true;
    } catch (e) { cv.vidWorker = false; }
  }
  const root = svg('svg', {width: g.width, height: g.height, class: 'vid-par-svg'}, box);
  root.style.cssText = 'position:absolute;left:0;top:0;overflow:visible';
  g.brushes = [];
  g.axes.forEach((a, i) => {
    const x = g.xs[i];
    const grp = svg('g', {class: 'vid-axis', 'data-name': a.name}, root);
    svg('line', {x1: x, x2: x, y1: g.top, y2: g.bottom, class: 'vid-axis-line'}, grp);
    // ticks: labels left of the axis where they fit, else only the two ends, centred
    const t = niceTicks(a.range[0], a.range[1], 5).ticks;
    for (const v of t) {
      const y = yOf(g, a, v);
      svg('line', {x1: x - 3, x2: x, y1: y, y2: y, class: 'vid-tick'}, grp);
      if (g.ticksFit) {
        svg('text', {x: x - 5, y: y + 4, 'text-anchor': 'end', class: 'vid-tick-label'}, grp)
          .textContent = num(v);
      }
    }
    if (!g.ticksFit) {
      const row = i % 2 ? 13 : 0;
      svg('text', {x: x, y: g.top - 6 - row, 'text-anchor': 'middle',
        class: 'vid-tick-label vid-end'}, grp).textContent = num(a.range[1]);
      svg('text', {x: x, y: g.bottom + 14 + row, 'text-anchor': 'middle',
        class: 'vid-tick-label vid-end'}, grp).textContent = num(a.range[0]);
    }
    // the limit in force: a criterion's worse-side bound, a functional's bounds
    if (a.limit) {
      const vals = a.limit[0] === 'in' ? a.limit[1] : [a.limit[1]];
      for (const v of vals) {
        if (v === null || v === undefined || v < a.range[0] || v > a.range[1]) continue;
        const y = yOf(g, a, v);
        tip(svg('path', {d: 'M' + (x + 2) + ',' + y + 'l7,-4v8z', class: 'vid-limit'}, grp),
          a.name + ' ' + (a.limit[0] === 'in' ? 'bound ' : a.limit[0] + ' ') + num(v) +
          ' (constraint in force)');
      }
    }
    // the title: across on two lines, or upright; hover: unit, meaning and more
    const title = svg('g', {class: 'vid-title', 'data-name': a.name}, grp);
    if (g.across) {
      const txt = svg('text', {x: x, y: 14, 'text-anchor': 'middle', class: 'vid-axis-title'},
        title);
      svg('tspan', {x: x, dy: 0}, txt).textContent = a.name;
      svg('tspan', {x: x, dy: 14, class: 'vid-unit'}, txt).textContent = '[' + a.unit + ']';
    } else {
      const y = g.titleH - 6;
      svg('text', {x: x + 4, y: y, 'text-anchor': 'start', class: 'vid-axis-title',
        transform: 'rotate(-90 ' + (x + 4) + ' ' + y + ')'}, title).textContent = a.title;
    }
    tip(title, a.tip + ' — drag to move this axis');
    const bg = svg('g', {class: 'vid-brushes'}, grp);
    g.brushes.push(bg);
    const half = Math.max(5, Math.min(12, g.gap / 2 - 2));
    const hit = tip(svg('rect', {x: x - half, y: g.top, width: 2 * half,
      height: g.bottom - g.top, class: 'vid-hit', 'data-name': a.name}, grp),
      a.tip + ' — drag along the axis to select a range; click a range to remove it');
    hit.addEventListener('pointerdown', ev => brushStart(ev, i, hit));
    title.addEventListener('pointerdown', ev => moveStart(ev, i, grp));
  });
  drawBrushes();
  linesSoon();
}
function brushStart(ev, i, hit) {
  const g = par.geom, a = g.axes[i];
  const box = hit.ownerSVGElement.getBoundingClientRect();
  const y0 = ev.clientY - box.top;
  const band = svg('rect', {x: g.xs[i] - 6, y: y0, width: 12, height: 0,
    class: 'vid-brush vid-brushing'}, hit.parentNode);
  hit.setPointerCapture(ev.pointerId);
  ev.preventDefault();
  let y1 = y0;
  function move(e) {
    y1 = Math.max(g.top, Math.min(g.bottom, e.clientY - box.top));
    band.setAttribute('y', Math.min(y0, y1));
    band.setAttribute('height', Math.abs(y1 - y0));
  }
  function up(e) {
    hit.removeEventListener('pointermove', move);
    hit.removeEventListener('pointerup', up);
    band.remove();
    if (Math.abs(y1 - y0) < 3) {  // a click: remove the range under it, if any
      const v = vOf(g, a, y0);
      if (ranges(selRanges()[a.name]).some(r => v >= r[0] && v <= r[1])) {
        commitRange(a.name, 0, 0, v);
      }
      return;
    }
    const p = vOf(g, a, y0), q = vOf(g, a, y1);
    commitRange(a.name, Math.min(p, q), Math.max(p, q));
  }
  hit.addEventListener('pointermove', move);
  hit.addEventListener('pointerup', up);
}
function moveStart(ev, i, grp) {
  const g = par.geom, x0 = ev.clientX;
  const title = ev.currentTarget;
  title.setPointerCapture(ev.pointerId);
  ev.preventDefault();
  let dx = 0;
  function move(e) {
    dx = e.clientX - x0;
    grp.setAttribute('transform', 'translate(' + dx + ',0)');
  }
  function up() {
    title.removeEventListener('pointermove', move);
    title.removeEventListener('pointerup', up);
    grp.removeAttribute('transform');
    if (Math.abs(dx) < 3) return;
    const at = g.xs[i] + dx, names = g.axes.map(a => a.name), me = names[i];
    names.splice(i, 1);
    let k = 0;
    while (k < names.length && g.xs[k + (k >= i ? 1 : 0)] < at) k++;
    names.splice(k, 0, me);
    setOrder(names);
  }
  title.addEventListener('pointermove', move);
  title.addEventListener('pointerup', up);
}
function linesJob() {
  const g = par.geom, meta = par.data.lines;
  const vals = {};
  for (const k of Object.keys(meta.values)) vals[k] = typed(meta.values[k]);
  const axes = g.axes.map((a, i) => {
    const lo = a.range[0], hi = a.range[1], h = g.bottom - g.top;
    const k = hi > lo ? -h / (hi - lo) : 0;
    return {x: g.xs[i], a: k, b: hi > lo ? g.top - k * hi : (g.top + g.bottom) / 2,
      v: vals[a.name]};
  }).filter(q => q.v);
  if (!axes.length) return null;
  const n = axes[0].v.length;
  // which lines lie in one range of every brushed axis (hidden axes too)
  const brushed = [];
  const rs = selRanges();
  for (const name of Object.keys(rs)) {
    const r = ranges(rs[name]);
    if (r.length && vals[name]) brushed.push([vals[name], r]);
  }
  const sel = new Uint8Array(n).fill(1);
  for (const [v, rr] of brushed) {
    for (let i = 0; i < n; i++) {
      if (!sel[i]) continue;
      const x = v[i];
      let hit = false;
      for (const q of rr) if (x >= q[0] && x <= q[1]) { hit = true; break; }
      if (!hit) sel[i] = 0;
    }
  }
  const c = typed(meta.color), cls = new Uint8Array(n);
  let style;
  if (meta.mode === 'set') {
    for (let i = 0; i < n; i++) cls[i] = Math.max(0, Math.min(2, Math.round(c[i])));
    style = [[meta.colours[0], 0.35], [meta.colours[1], 0.35], [meta.colours[2], 0.9]];
  } else {
    const lo = meta.cmin, span = (meta.cmax - meta.cmin) || 1;
    for (let i = 0; i < n; i++) {
      const t = (c[i] - lo) / span;
      cls[i] = t === t ? Math.max(0, Math.min(9, Math.floor(t * 10))) : 0;
    }
    style = VIRIDIS.map(col => [col, 0.6]);
  }
  const un = meta.unselected || {};
  return {w: g.width, h: g.height, dpr: window.devicePixelRatio || 1, n: n, axes: axes,
    sel: sel, anySel: brushed.length > 0, cls: cls, style: style,
    unsel: {color: un.color || '#bbb', alpha: un.opacity === undefined ? 0.08 : un.opacity}};
}
function linesNow() {
  par.due = false;
  const cv = document.querySelector('#par-graph canvas.vid-lines');
  if (!cv || !par.geom) return;
  const job = linesJob();
  if (!job) return;
  job.seq = ++par.seq;
  cv.dataset.asked = job.seq;
  if (cv.vidWorker) {
    par.worker.postMessage({job: job});
  } else {
    const t0 = performance.now();
    const out = parDraw(cv.getContext('2d'), job);
    out.ms = performance.now() - t0; out.seq = job.seq;
    parDone(cv, out);
  }
}
function linesSoon() {
  if (!par.due) { par.due = true; requestAnimationFrame(linesNow); }
}
// a new answer from the server, or a new selection (from a brush, or from another view)
function parRender(data, selection, view, shown) {
  const show = shown ? shown.slice() : null;
  if (data && data !== par.data) {
    par.data = data;
    par.order = ((view && view.order) || []).slice();
    par.view = view || null;
    par.sel = selection || null;
    par.shown = show;
    build();
  } else if (JSON.stringify(show) !== JSON.stringify(par.shown || null)) {
    par.shown = show;
    par.sel = selection || null;
    build();
  } else {
    const same = JSON.stringify(selection || null) === JSON.stringify(par.sel || null);
    par.sel = selection || null;
    if (!same) { drawBrushes(); linesSoon(); }
  }
  return data ? data.rev : null;
}
// the tab's content is mounted anew when it is shown again: draw it again from what we hold
let lastWidth = 0;
setInterval(() => {
  const host = document.querySelector('#par-graph');
  if (!host || !par.data || !host.offsetParent) return;
  const w = host.clientWidth;
  if (!host.querySelector('.vid-par-box') || Math.abs(w - lastWidth) > 20) {
    lastWidth = w;
    build();
  }
}, 300);

// -- rows of a figure grid drawn when they come near the screen -----------------------------
// ``lazyRows(ids, figs, rev, graph)``: row r's figure is drawn into the element ``ids[r]``
// once that element is shown (its tab selected) and within LAZY_MARGIN px of the window,
// one row a task, top first; a row on screen is redrawn at once with a new answer, one off
// screen when it comes near, one whose tab was left and shown again (Dash mounts the tab's
// elements anew) too. ``graph``: the elements are Dash graphs (their clicks go to the
// server): the figure is set as the graph's ``figure`` (``dash_clientside.set_props``), with
// the sets hidden in the first row's legend hidden in it too, and the row counts as drawn
// once the graph shows it (its ``layout.meta.rev``); otherwise plotly.js draws into the
// element. Each drawn row's element carries ``data-rev`` (the answer drawn) and ``data-at``
// (performance.now() when drawn).
const LAZY_MARGIN = 300;
const lazy = {want: new Map(), busy: false, timer: 0, plots: new Map()};
function lazyNear(el) {
  if (!el || !el.offsetParent) return false;
  const r = el.getBoundingClientRect();
  return r.bottom > -LAZY_MARGIN && r.top < window.innerHeight + LAZY_MARGIN;
}
function lazyDue(id, job) {
  const el = document.getElementById(id);
  return el && el.dataset.rev !== String(job.rev) && lazyNear(el) ? el : null;
}
function lazyLegend(job) {
  const gd = document.querySelector('#' + job.first + ' .js-plotly-plot');
  if (job.id === job.first || !gd || !gd._fullData) return job.fig;
  const hidden = new Set(gd._fullData.filter(t => t.visible === 'legendonly')
    .map(t => t.legendgroup));
  if (!hidden.size) return job.fig;
  return Object.assign({}, job.fig, {data: job.fig.data.map(t => hidden.has(t.legendgroup) ?
    Object.assign({}, t, {visible: 'legendonly'}) : t)});
}
function lazyDraw(el, job, done) {
  const f = job.fig || {data: [], layout: {}};
  if (!job.graph) {
    const old = lazy.plots.get(job.id);  // a plot in an element the tab no longer holds
    if (old && old !== el) { try { Plotly.purge(old); } catch (e) { /* gone already */ } }
    lazy.plots.set(job.id, el);
    Promise.resolve(Plotly.react(el, f.data, f.layout,
      {displaylogo: false, responsive: true})).then(done, done);
    return;
  }
  dash_clientside.set_props(job.id, {figure: lazyLegend(job)});
  const t0 = performance.now();
  (function shown() {
    const gd = el.querySelector('.js-plotly-plot');
    const m = gd && gd._fullLayout && gd._fullLayout.meta;
    if ((m && m.rev === job.rev) || !f.layout.meta || performance.now() - t0 > 5000) done();
    else setTimeout(shown, 4);
  })();
}
function lazyNext() {
  if (lazy.busy) return;
  for (const [id, job] of lazy.want) {
    const el = lazyDue(id, job);
    if (!el) continue;
    lazy.busy = true;
    setTimeout(function() {  // a task of its own
      const done = function() {
        el.dataset.rev = job.rev; el.dataset.at = performance.now();
        lazy.busy = false; setTimeout(lazyNext, 0);
      };
      try { lazyDraw(el, job, done); } catch (e) { console.error(e); done(); }
    }, 0);
    return;
  }
}
function lazyRows(ids, figs, rev, graph) {
  ids.forEach(function(id, r) {
    lazy.want.set(id, {id: id, first: ids[0], fig: figs[r], rev: rev, graph: !!graph});
  });
  lazyNext();
  if (!lazy.timer) {  // scrolled, resized, a tab shown or a table above grown: look again
    lazy.timer = setInterval(lazyNext, 250);
    const look = function() { requestAnimationFrame(lazyNext); };
    document.addEventListener('scroll', look, {capture: true, passive: true});
    window.addEventListener('resize', look);
  }
}
// whether every row on screen (or within LAZY_MARGIN of it) shows the latest answer
function lazyIdle() {
  if (lazy.busy) return false;
  for (const [id, job] of lazy.want) { if (lazyDue(id, job)) return false; }
  return true;
}

// -- markup sent whole (a table of 33 rows as one element, not ~600 Dash components) ---------
// every ``.vid-html`` element shows its ``data-html`` (escaped by the server), whenever Dash
// mounts it or changes the attribute. Only the nodes a mutation names are looked at: plotly.js
// drawing a figure makes thousands of mutations (SVG), and a whole-page query for each batch
// was 50 ms of a 33-gain page load.
function fillOne(el) {
  if (el.__vidHtml === el.dataset.html) return;
  el.__vidHtml = el.dataset.html;
  el.innerHTML = el.dataset.html;
}
function fillHtml(records) {
  for (const r of records) {
    if (r.type === 'attributes') {
      if (r.target.classList && r.target.classList.contains('vid-html')) fillOne(r.target);
      continue;
    }
    for (const n of r.addedNodes) {
      if (n.nodeType !== 1 || n instanceof SVGElement) continue;
      if (n.matches('.vid-html[data-html]')) fillOne(n);
      if (n.firstElementChild) n.querySelectorAll('.vid-html[data-html]').forEach(fillOne);
    }
  }
}
new MutationObserver(fillHtml).observe(document.documentElement,
  {subtree: true, childList: true, attributes: true, attributeFilter: ['data-html']});

window.vid = {ranges: ranges, readState: readState, writeState: writeState,
  parRender: parRender, parDraw: parDraw, parOrder: setOrder, textWidth: textWidth,
  lazyRows: lazyRows, lazyIdle: lazyIdle};
})();
"""

#: Clientside callback: the parallel coordinates drawn by the page from the server's answer
#: (``par-data``), and their brushes and lines drawn again when the selection changes (a
#: brush, or a selection made in another view).
PAR_JS = """
function(data, selection, shown, view) {
  return window.vid.parRender(data, selection, view, shown);
}
"""

#: Clientside callback (``READ_URL_JS % {...}``): the URL's fragment to every field at page
#: load. Filled in by :func:`vectorid.views.ui.app.create_app` with the field order.
READ_URL_JS = """
function(hash, defaults) {
  const nc = dash_clientside.no_update;
  const s = window.vid.readState(hash);
  const crit = %(crit)s, cons = %(cons)s, axes = %(axes)s;
  const pick = k => (k in s ? s[k] : nc);
  const role = k => (k in s && ['pure', 'pseudo'].includes(s[k]) ? s[k] : nc);
  const json = k => { try { return k in s ? JSON.parse(s[k]) : nc; } catch (e) { return nc; } };
  const list = k => (k in s ? (s[k] ? s[k].split(',') : []) : nc);
  return [
    ...crit.map(n => pick('lim.' + n)),
    ...crit.map(n => role('role.' + n)),
    ...cons.map(n => pick('low.' + n)),
    ...cons.map(n => pick('high.' + n)),
    pick('tab'), pick('x'), pick('y'), pick('panel'), pick('crit'), pick('trial'),
    json('sel'), 'axes' in s ? {order: list('axes')} : nc, pick('colour'),
    'hide' in s ? axes.filter(n => !list('hide').includes(n)) : nc,
  ];
}
"""

#: Clientside callback (``WRITE_URL_JS % {...}``): every field to the URL's fragment
#: (``history.replaceState``: no reload, no new history entry per keystroke).
WRITE_URL_JS = """
function(...v) {
  const crit = %(crit)s, cons = %(cons)s, axes = %(axes)s;
  const k = crit.length, q = cons.length;
  const defaults = v[v.length - 1] || {};
  const s = {};
  crit.forEach((n, j) => { s['lim.' + n] = v[j]; });
  crit.forEach((n, j) => { s['role.' + n] = v[k + j]; });
  cons.forEach((n, j) => { s['low.' + n] = v[2 * k + j]; s['high.' + n] = v[2 * k + q + j]; });
  const [tab, x, y, panel, crit0, trial, sel, view, colour, shown] = v.slice(2 * k + 2 * q);
  const hide = shown ? axes.filter(n => !shown.includes(n)) : [];
  Object.assign(s, {tab: tab, x: x, y: y, panel: panel, crit: crit0, trial: trial,
    sel: sel ? JSON.stringify(sel) : '', axes: ((view || {}).order || []).join(','),
    colour: colour || 'set', hide: (hide || []).join(',')});
  const d = Object.assign({axes: '', colour: 'set', hide: '', sel: ''}, defaults.fields || {});
  return window.vid.writeState(s, d);
}
"""

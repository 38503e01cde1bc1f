"""What runs in the page besides Dash: brushes turned into a selection, the view's state in
the URL, and a record of the main thread's long tasks.

N, ND and NP are *not* computed here: the server counts (:func:`~vectorid.views.ui.explore.
counts_view`, over the cached columns, a tightened constraint narrowed from the last D, see
:meth:`~vectorid.analysis.Analysis.narrowed`) and the page only waits for the answer, so the
page's main thread never scans a million trials. Measured at 1e6 trials, the server's answer
comes back in a fraction of the time the former in-page scan held the page frozen (see
``docs/ui.md``), and the page no longer loads the columns at all (41 MB at 1e6).

* :data:`VID_JS` (served at ``/_vid/vid.js``) defines ``window.vid``:

  - ``vid.brush(event, selection, view)``: a ``restyleData`` event of the parallel
    coordinates to the new ``selection`` (``{"kind": "ranges", "ranges": {name: [[lo, hi],
    ...]}}``, every range of every brushed axis, both edges) and the new axis ``view``
    (``{"order": [...], "hidden": [...], "colour": ...}``; an axis dragged elsewhere changes
    ``order``);
  - ``vid.readState(hash)`` / ``vid.writeState(state, defaults)``: the view's state to and
    from the URL's fragment (``#lim.f1=20&tab=parallel&trial=110&...``, see
    :data:`STATE_KEYS`);
  - ``window.__vidLongTasks``: durations (ms) of the main thread's tasks over 50 ms
    (``PerformanceObserver`` ``longtask``), read by ``benchmarks/ui.py``.
"""

from __future__ import annotations

__all__ = ["BRUSH_JS", "READ_URL_JS", "STATE_KEYS", "VID_JS", "WRITE_URL_JS"]

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

function liveDims() {
  const gd = document.querySelector('#par-graph .js-plotly-plot');
  return (gd && gd.data && gd.data[0] && gd.data[0].dimensions) || null;
}

// a brush (or an axis moved) on the parallel coordinates
function brush(event, selection, view) {
  const out = {selection: undefined, view: undefined};
  if (!event || !event[0]) return out;
  const dims = liveDims();
  if (!dims) return out;
  const ev = event[0];
  if (ev.dimensions) {  // axes reordered: plotly sorted its dimensions in place
    const v = Object.assign({order: [], hidden: [], colour: 'set'}, view || {});
    v.order = dims.map(d => d.name);
    out.view = v;
    return out;
  }
  const cur = (selection && selection.kind === 'ranges') ? selection.ranges : {};
  const next = {};
  for (const k of Object.keys(cur)) next[k] = ranges(cur[k]);
  let any = false;
  for (const key of Object.keys(ev)) {
    const m = /^dimensions\[(\d+)\]\.constraintrange$/.exec(key);
    if (!m || !dims[Number(m[1])]) continue;
    const name = dims[Number(m[1])].name;
    const r = ranges(ev[key]);
    if (r.length) next[name] = r; else delete next[name];
    any = true;
  }
  if (!any) return out;
  out.selection = Object.keys(next).length ? {kind: 'ranges', ranges: next} : null;
  return out;
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

const par = {worker: null, canvas: null, seq: 0, due: false};
function parJob(gd) {
  const meta = gd.layout && gd.layout.meta && gd.layout.meta.lines;
  const fl = gd._fullLayout;
  if (!meta || !fl) return null;
  const vals = {};
  for (const k of Object.keys(meta.values)) vals[k] = typed(meta.values[k]);
  const axes = [];
  let model = null;
  gd.querySelectorAll('.y-axis').forEach(el => {
    const d = el.__data__;
    if (!d || !d.model || !d.domainScale) return;
    model = d.model;
    const dim = d.model.dimensions[d.visibleIndex] || {};
    const v = vals[dim.name];
    if (!v) return;
    const dom = d.domainScale.domain(), rng = d.domainScale.range();
    const lo = dom[0], hi = dom[dom.length - 1];
    const a = hi !== lo ? (rng[rng.length - 1] - rng[0]) / (hi - lo) : 0;
    axes.push({x: d.x, a: a, b: rng[0] - a * lo, v: v, name: dim.name});
  });
  if (!model || !axes.length) return null;
  axes.sort((p, q) => p.x - q.x);
  const x0 = model.translateX + model.pad.l, y0 = model.translateY + model.pad.t;
  for (const q of axes) { q.x += x0; q.b += y0; }
  const n = axes[0].v.length;
  // which lines lie in one range of every brushed axis (plotly.js's brushes, live)
  const live = (gd.data && gd.data[0] && gd.data[0].dimensions) || [];
  const brushed = [];
  for (const d of live) {
    const rs = ranges(d.constraintrange);
    if (rs.length && vals[d.name]) brushed.push([vals[d.name], rs]);
  }
  const sel = new Uint8Array(n).fill(1);
  for (const [v, rs] of brushed) {
    for (let i = 0; i < n; i++) {
      if (!sel[i]) continue;
      const x = v[i];
      let hit = false;
      for (const q of rs) if (x >= q[0] && x <= q[1]) { hit = true; break; }
      if (!hit) sel[i] = 0;
    }
  }
  // colour class per line: set (0 infeasible, 1 in D, 2 Pareto) or ten steps of a column
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
  return {
    w: fl.width, h: fl.height, dpr: window.devicePixelRatio || 1, n: n,
    axes: axes.map(q => ({x: q.x, a: q.a, b: q.b, v: q.v})), sel: sel,
    anySel: brushed.length > 0, cls: cls, style: style,
    unsel: {color: un.color || '#bbb', alpha: un.opacity === undefined ? 0.08 : un.opacity},
  };
}
function parCanvas(gd) {
  let cv = gd.querySelector('canvas.vid-lines');
  if (cv) return cv;
  const box = gd.querySelector('.gl-container') || gd.querySelector('.svg-container');
  if (!box) return null;
  cv = document.createElement('canvas');
  cv.className = 'vid-lines';
  cv.style.cssText = 'position:absolute;top:0;left:0;pointer-events:none';
  box.appendChild(cv);
  if (window.Worker && cv.transferControlToOffscreen) {
    try {
      if (!par.worker) {
        const url = URL.createObjectURL(new Blob([PAR_WORKER], {type: 'text/javascript'}));
        par.worker = new Worker(url);
        par.worker.onmessage = e => {  // on the canvas shown now (a tab may remount it)
          const c = document.querySelector('#par-graph canvas.vid-lines');
          if (c) parDone(c, e.data);
        };
      }
      const off = cv.transferControlToOffscreen();
      par.worker.postMessage({canvas: off}, [off]);
      cv.vidWorker = true;
    } catch (e) { cv.vidWorker = false; }
  }
  return cv;
}
function parDone(cv, out) {  // what was drawn, for tests and benchmarks
  cv.dataset.lines = out.lines; cv.dataset.selected = out.selected;
  cv.dataset.ms = Math.round(out.ms || 0); cv.dataset.seq = out.seq || 0;
  cv.dataset.at = Math.round(performance.now());
}
function parRedraw() {
  par.due = false;
  const gd = document.querySelector('#par-graph .js-plotly-plot');
  if (!gd || !gd.offsetParent) return;
  const job = parJob(gd);
  if (!job) return;
  const cv = parCanvas(gd);
  if (!cv) return;
  cv.style.width = job.w + 'px'; cv.style.height = job.h + 'px';
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
function parSchedule() {
  if (!par.due) { par.due = true; requestAnimationFrame(parRedraw); }
}
// listen to the graph (created once by dcc.Graph) for new figures, brushes and moved axes
setInterval(() => {
  const gd = document.querySelector('#par-graph .js-plotly-plot');
  if (gd && gd.on && gd.__vidPar !== gd._ev) {
    gd.__vidPar = gd._ev;
    gd.on('plotly_afterplot', parSchedule);
    gd.on('plotly_restyle', parSchedule);
    parSchedule();
  }
}, 300);

window.vid = {brush: brush, ranges: ranges, readState: readState, writeState: writeState,
  parRedraw: parRedraw, parDraw: parDraw};
})();
"""

#: Clientside callback: a ``restyleData`` event of the parallel coordinates to the selection
#: and the axis view (no server round trip; the server then counts the selection).
BRUSH_JS = """
function(event, selection, view) {
  const nc = dash_clientside.no_update;
  const r = window.vid.brush(event, selection, view);
  return [r.selection === undefined ? nc : r.selection, r.view === undefined ? nc : r.view];
}
"""

#: Clientside callback (``READ_URL_JS % {...}``): the URL's fragment to every field at page
#: load. Filled in by :func:`vectorid.views.ui.app.create_app` with the field order.
READ_URL_JS = """
function(hash, defaults) {
  const nc = dash_clientside.no_update;
  const s = window.vid.readState(hash);
  const crit = %(crit)s, cons = %(cons)s;
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
    json('sel'), 'axes' in s ? {order: list('axes')} : nc, pick('colour'), list('hide'),
  ];
}
"""

#: Clientside callback (``WRITE_URL_JS % {...}``): every field to the URL's fragment
#: (``history.replaceState``: no reload, no new history entry per keystroke).
WRITE_URL_JS = """
function(...v) {
  const crit = %(crit)s, cons = %(cons)s;
  const k = crit.length, q = cons.length;
  const defaults = v[v.length - 1] || {};
  const s = {};
  crit.forEach((n, j) => { s['lim.' + n] = v[j]; });
  crit.forEach((n, j) => { s['role.' + n] = v[k + j]; });
  cons.forEach((n, j) => { s['low.' + n] = v[2 * k + j]; s['high.' + n] = v[2 * k + q + j]; });
  const [tab, x, y, panel, crit0, trial, sel, view, colour, hide] = v.slice(2 * k + 2 * q);
  Object.assign(s, {tab: tab, x: x, y: y, panel: panel, crit: crit0, trial: trial,
    sel: sel ? JSON.stringify(sel) : '', axes: ((view || {}).order || []).join(','),
    colour: colour || 'set', hide: (hide || []).join(',')});
  const d = Object.assign({axes: '', colour: 'set', hide: '', sel: ''}, defaults.fields || {});
  return window.vid.writeState(s, d);
}
"""

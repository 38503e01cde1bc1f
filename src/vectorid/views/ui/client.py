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
window.vid = {brush: brush, ranges: ranges, readState: readState, writeState: writeState};
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

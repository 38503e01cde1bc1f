"""N, ND and NP in the browser: the criteria and functionals of every trial are shipped once
(float64, exactly the numbers the server compares) and a constraint typed or brushed is
counted in the page without a round trip. The server's counts callback stays as the fallback
and the truth: it runs on every change as well, and whenever a field does not parse
strictly here (anything but a plain decimal number or ``inf``) the page leaves the counts to
it.

The rule is :class:`~vectorid.analysis.Analysis`'s: a trial is in D when its status is ok,
every functional constraint lies within its bounds and every criterion within its criteria
constraint; the Pareto set is the non-dominated rows of D over the pure criteria (duplicates
kept: exact copies do not dominate each other), found by a scan in lexicographic order that
keeps the non-dominated rows so far (a dominating row always comes first in that order).

``/_vid/columns.bin?v=VERSION`` serves the arrays: an 8-byte little-endian header length,
a JSON header (``n``, ``k``, ``q``, names, senses, the study's limits and bounds and their field
texts), then ``status == ok`` as n bytes padded to 8, then the k criteria columns and the q
functional columns as float64, column after column.
"""

from __future__ import annotations

import json
import math
import struct

import numpy as np

from .data import StoreCache, _text_of

__all__ = ["BRUSH_JS", "COUNTS_JS", "LOAD_JS", "VID_JS", "columns_payload"]


def columns_payload(cache: StoreCache) -> bytes:
    """The binary document of ``/_vid/columns.bin`` for the trials cached now."""
    key, t, _ = cache.state()
    spec = cache.spec

    def num(v: float | None) -> float | None:
        return None if v is None or not math.isfinite(v) else float(v)

    head = {
        "version": list(key),
        "n": len(t),
        "k": len(spec.criteria),
        "q": len(spec.constraints),
        "criteria": [
            {
                "name": c.name,
                "sense": c.sense,
                "limit": num(c.limit),
                "text": _text_of(c.limit),
            }
            for c in spec.criteria
        ],
        "constraints": [
            {
                "name": g.name,
                "low": num(g.low),
                "high": num(g.high),
                "low_text": _text_of(g.low),
                "high_text": _text_of(g.high),
            }
            for g in spec.constraints
        ],
    }
    hj = json.dumps(head).encode()
    hj += b" " * (-len(hj) % 8)
    ok = (t.status == 0).astype(np.uint8).tobytes()
    ok += b"\0" * (-len(ok) % 8)
    F = np.ascontiguousarray(t.F.T, dtype="<f8").tobytes()
    G = np.ascontiguousarray(t.G.T, dtype="<f8").tobytes()
    return struct.pack("<Q", len(hj)) + hj + ok + F + G


#: The page's library (served at ``/_vid/vid.js``): ``vid.load``, ``vid.counts``,
#: ``vid.children`` and ``vid.brushed``.
VID_JS = r"""
(function(){
function load(version) {
  const V = window.__vid;
  if (V && V.ready && JSON.stringify(V.head.version) === JSON.stringify(version)) return;
  if (window.__vidLoading) return;
  window.__vidLoading = true;
  {
    {
      fetch('/_vid/columns.bin').then(r => r.arrayBuffer()).then(buf => {
        const dv = new DataView(buf);
        const hl = Number(dv.getBigUint64(0, true));
        const head = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 8, hl)));
        let off = 8 + hl;
        const n = head.n, k = head.k, q = head.q;
        const ok = new Uint8Array(buf, off, n); off += n + ((8 - n % 8) % 8);
        const F = [], G = [];
        for (let j = 0; j < k; j++) { F.push(new Float64Array(buf, off, n)); off += 8 * n; }
        for (let j = 0; j < q; j++) { G.push(new Float64Array(buf, off, n)); off += 8 * n; }
        window.__vid = {head: head, ok: ok, F: F, G: G, ready: true};
        window.__vidLoading = false;
      }).catch(() => { window.__vidLoading = false; });
    }
  }
}
// counts from the constraint fields: values = [texts(k), roles(k), lows(q), highs(q)];
// null when the columns are not loaded (or stale) or a field does not parse strictly
function counts(values, version) {
  const V = window.__vid;
  if (!V || !V.ready || JSON.stringify(V.head.version) !== JSON.stringify(version)) {
    load(version);
    return null;
  }
  const nc = null;
  const h = V.head, k = h.k, q = h.q, n = h.n;
  const texts = values.slice(0, k), roles = values.slice(k, 2 * k);
  const lows = values.slice(2 * k, 2 * k + q), highs = values.slice(2 * k + q, 2 * k + 2 * q);
  const NUM = /^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/;
  // null: no bound; undefined: not strictly parsed (leave it to the server)
  function parse(text, stored, storedText) {
    if (text === null || text === undefined) return null;
    const s = String(text).trim();
    if (s === '') return null;
    if (storedText !== '' && s === storedText) return stored;
    if (/^[+-]?inf(inity)?$/i.test(s)) return null;
    if (!NUM.test(s) || s.length > 64) return undefined;
    const v = Number(s);
    return isFinite(v) ? v : undefined;
  }
  const lo = [], hi = [];
  for (let j = 0; j < k; j++) {
    const c = h.criteria[j];
    const v = parse(texts[j], c.limit, c.text);
    if (v === undefined) return nc;
    if (c.sense === 'min') { lo.push(-Infinity); hi.push(v === null ? Infinity : v); }
    else { lo.push(v === null ? -Infinity : v); hi.push(Infinity); }
  }
  const glo = [], ghi = [];
  for (let j = 0; j < q; j++) {
    const g = h.constraints[j];
    const a = parse(lows[j], g.low, g.low_text), b = parse(highs[j], g.high, g.high_text);
    if (a === undefined || b === undefined) return nc;
    if (a !== null && b !== null && a > b) return nc;
    glo.push(a === null ? -Infinity : a); ghi.push(b === null ? Infinity : b);
  }
  let failed = 0, functional = 0;
  const inD = [];
  for (let i = 0; i < n; i++) {
    if (!V.ok[i]) { failed++; continue; }
    let good = true;
    for (let j = 0; j < q && good; j++) { const x = V.G[j][i]; good = x >= glo[j] && x <= ghi[j]; }
    if (!good) continue;
    functional++;
    for (let j = 0; j < k && good; j++) { const x = V.F[j][i]; good = x >= lo[j] && x <= hi[j]; }
    if (good) inD.push(i);
  }
  // Pareto over the pure criteria, each turned into a minimisation
  const pure = [];
  for (let j = 0; j < k; j++) if (roles[j] !== 'pseudo') pure.push(j);
  let np = 0;
  if (pure.length && inD.length) {
    const m = pure.length, nd = inD.length;
    const X = new Float64Array(nd * m);
    for (let r = 0; r < nd; r++) {
      for (let c = 0; c < m; c++) {
        const j = pure[c];
        const x = V.F[j][inD[r]];
        X[r * m + c] = h.criteria[j].sense === 'max' ? -x : x;
      }
    }
    const order = new Uint32Array(nd);
    for (let r = 0; r < nd; r++) order[r] = r;
    order.sort((a, b) => {
      for (let c = 0; c < m; c++) {
        const d = X[a * m + c] - X[b * m + c];
        if (d !== 0) return d < 0 ? -1 : 1;
      }
      return 0;
    });
    const front = [];
    for (let t = 0; t < nd; t++) {
      const p = order[t];
      let dominated = false;
      for (let f = 0; f < front.length && !dominated; f++) {
        const r = front[f];
        let le = true, lt = false;
        for (let c = 0; c < m; c++) {
          const a = X[r * m + c], b = X[p * m + c];
          if (a > b) { le = false; break; }
          if (a < b) lt = true;
        }
        dominated = le && lt;
      }
      if (!dominated) front.push(p);
    }
    np = front.length;
  }
  return {n: n, nd: inD.length, np: np, failed: failed, functional: functional};
}
function children(c) {
  const B = (text, id, cls) => ({namespace: 'dash_html_components', type: 'B',
    props: cls ? {children: text, id: id, className: cls} : {children: text, id: id}});
  return ['N ', B(String(c.n), 'count-n'), ' ND ', B(String(c.nd), 'count-nd', 'nd'),
    ' NP ', B(String(c.np), 'count-np', 'np'),
    {namespace: 'dash_html_components', type: 'Span', props: {className: 'muted',
      children: ' (failed ' + c.failed + ', meeting functional constraints ' + c.functional
        + ')'}}];
}
// a brush on the parallel coordinates, applied to the fields as the server applies it
function brushed(event, names, values) {
  const h = window.__vid && window.__vid.head;
  if (!h || !event || !event[0]) return null;
  const k = h.k, q = h.q, out = values.slice();
  const cn = h.criteria.map(c => c.name), gn = h.constraints.map(g => g.name);
  const p5 = v => String(Number(Number(v).toPrecision(5)));
  let any = false;
  for (const key of Object.keys(event[0])) {
    const m = /^dimensions\[(\d+)\]\.constraintrange$/.exec(key);
    if (!m) continue;
    const name = names[Number(m[1])];
    let v = event[0][key];
    while (Array.isArray(v) && v.length === 1 && Array.isArray(v[0])) v = v[0];
    const rng = (v && v.length) ? [Math.min(...v.flat()), Math.max(...v.flat())] : null;
    const j = cn.indexOf(name), g = gn.indexOf(name);
    if (j >= 0) {
      out[j] = rng === null ? '' : p5(h.criteria[j].sense === 'min' ? rng[1] : rng[0]);
      any = true;
    } else if (g >= 0) {
      out[2 * k + g] = rng === null ? '' : p5(rng[0]);
      out[2 * k + q + g] = rng === null ? '' : p5(rng[1]);
      any = true;
    }
  }
  return any ? out : null;
}
window.vid = {load: load, counts: counts, children: children, brushed: brushed};
})();
"""

#: Clientside callbacks: counts from the fields; the columns loaded at page load; counts
#: from a parallel-coordinates brush.
COUNTS_JS = """
function(...args) {
  const version = args[args.length - 1];
  const c = window.vid.counts(args.slice(0, -1), version);
  return c === null ? dash_clientside.no_update : window.vid.children(c);
}
"""
LOAD_JS = """
function(version) { window.vid.load(version); return dash_clientside.no_update; }
"""
BRUSH_JS = """
function(event, fig, version, ...values) {
  const names = (((fig || {}).layout || {}).meta || {}).names || [];
  const fields = window.vid.brushed(event, names, values);
  if (fields === null) return dash_clientside.no_update;
  const c = window.vid.counts(fields, version);
  return c === null ? dash_clientside.no_update : window.vid.children(c);
}
"""

"""Fixed-step RK4 over a whole batch of trials, compiled with numba, and how a model plugs in.

How a model plugs in (read this before writing a model)
--------------------------------------------------------
numba's ``cache=True`` does **not** cache a ``parallel`` function that receives another jitted
function as an argument (measured with numba 0.68: such a driver recompiles in every new process,
~3 s). It *does* cache a kernel that is defined in the model's own module and that calls the
shared helpers below with the model's jitted functions as first-class arguments (the callees are
compiled into the kernel's cached library). So every model module defines three things:

1. ``_rhs(t, x, p, u, atm, gust, dx)`` — ``@njit(cache=True, inline="always")``. Writes dx/dt
   into ``dx``. Inlined into the RK4 loop (which calls it from one place, in a loop over the
   four stages, so it is compiled in once), the compiler keeps the state in registers and
   hoists the per-trial constants out of the time loop: measured 1.6x faster for the
   parachute (146 -> 89 ns per evaluation) and 1.3x for the parafoil, for ~30 s more compile
   time on first use (cached afterwards). Helpers it calls should be ``inline="always"`` too.

   - ``t`` float, s; ``x`` (n_state,) float64 state of ONE trial; ``p`` (n_const,) float64
     per-trial constants the model's Python side derived from the (n, p) parameter matrix;
   - ``u`` (m,) float64 control commands at ``t`` in the order of ``model.inputs`` (already
     interpolated by the driver);
   - ``atm`` and ``gust`` are the environment tables of :class:`Environment`; read them only
     through :func:`env_at` (``rho, g, wn, we, wd = env_at(atm, gust, t, altitude)``);
   - ``dx`` (n_state,) output. No allocation inside ``_rhs`` if you care about speed.

2. ``_observe(t, x, p, u, atm, gust, y)`` — ``@njit(cache=True)``. Writes the output channels
   of one trial at one output time into ``y`` (n_out,). The first 15 channels are fixed by
   :mod:`vectorid.models.base` (``BASE_CHANNELS``): position N, E, D (m), inertial velocity
   N, E, D (m/s), Euler φ, θ, ψ (rad), body rates p, q, r (rad/s), airspeed (m/s), angle of
   attack (rad), sideslip (rad); model-specific channels follow, named in ``model.outputs``.

3. The parallel kernel, copied verbatim (only the two function names change)::

       @njit(parallel=True, cache=True)
       def _kernel(x0, p, ctrl_t, ctrl_v, ctrl_mode, atm, gust, dt, n_steps, stride,
                   x_max, y, status, t_fail):
           for i in prange(x0.shape[0]):
               if status[i] != 0:          # rejected before integration: leave NaN outputs
                   continue
               status[i], t_fail[i] = rk4_trial(
                   _rhs, _observe, x0[i], p[i], ctrl_t, ctrl_v, ctrl_mode, atm, gust,
                   dt, n_steps, stride, x_max, y[i])

   and the model's ``_simulate`` hook (see ``base.Model``) allocates ``y`` with
   :func:`allocate_outputs`, sets ``status`` for trials it rejects up front, and calls
   ``_kernel``. Array layouts: ``x0`` (n, n_state) C-contiguous, ``p`` (n, n_const),
   ``ctrl_t`` (K,), ``ctrl_v`` (K, m), ``x_max`` (n_state,) absolute bound per state (``inf`` for
   none), ``y`` (n, T, n_out) with T = n_steps // stride + 1, ``status`` (n,) int64,
   ``t_fail`` (n,) float64.

``rk4_trial`` is ``inline="always"``: inlined into the model's kernel, it keeps that kernel
cacheable (measured: a non-inlined helper receiving the jitted functions made numba refuse to
cache the kernel, "uses dynamic globals").

Lockstep (structure-of-arrays) models
-------------------------------------
A model whose right-hand side is dominated by arithmetic can instead integrate :data:`LANES`
trials at once, one per SIMD lane, with :func:`rk4_lanes` (``parachute6dof`` does: 89 -> 15 ns
per right-hand-side evaluation on an AVX-512 machine). Its ``_rhs(t, X, P, u, atm, gust, DX, W)``
and ``_observe(t, X, P, u, atm, gust, W, Y)`` take ``(n, LANES)`` arrays, one trial per column,
and loop over the columns; for LLVM to vectorise that loop:

- no calls without a vector version: use :mod:`vectorid.models.vecmath` instead of ``np.sin``,
  ``np.cos``, ``np.arctan2``, ``np.arccos``, ``np.exp`` (``np.sqrt`` and ``abs`` are fine); its
  ``*_hot`` twins, inlined by numba, in the one loop that dominates the run time (each such
  call site costs compile time: the parachute's kernel compiles in ~40 s, 62 s with every call
  numba-inlined);
- no branches with work in them: compute both values, then select (``a if c else b`` with
  ``a`` and ``b`` already computed); conditional loads stay branches;
- no table reads at computed rows in a loop that also stores: compute the rows with
  :func:`table_position` in the loop, read the table with :func:`env_gather` after it;
- no arrays passed to helpers inside the loop (numba adds reference counting calls): helpers
  take and return scalars;
- short loops on their own are unrolled and stay scalar: merge the small per-column work into
  one loop;
- work a whole group may skip (e.g. control terms while every actuator rests) goes in its own
  loop behind a group-level test, so that calm groups do not pay for it.

The kernel is the parallel loop over groups of :data:`LANES` rows of ``np.flatnonzero(status
== 0)`` (see ``parachute6dof._kernel``), compiled with ``error_model="numpy"`` (no division
checks) and ``fastmath={"contract"}`` (fused multiply-add; NaN and inf semantics kept).

Caveat of numba's cache: it is invalidated only when the file that defines the cached kernel
changes (numba 0.68 compares a hash of its content; touching it is not enough). After editing
this file, ``vecmath.py`` or ``controls.py``, delete the model modules' ``__pycache__/*.nbi``
files, or the old compiled helpers keep running.

Status codes (``STATUS_*``): 0 ok; 1 a state became NaN/inf; 2 a state left its bound ``x_max``
(runaway); 3 a parameter is NaN/inf; 4 the model rejected the parameters (e.g. a mass matrix that
is not positive definite). A failing trial is frozen at the failing step: its outputs from that
output time on are NaN, ``t_fail`` holds the time, the other trials are not affected (each trial
is integrated independently, so a good trial gives bit-identical results alone or in any batch).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

from vectorid.models.atmosphere import ISA, UniformAtmosphere
from vectorid.models.controls import control_at
from vectorid.models.wind import Wind, WindProfile

__all__ = [
    "ENV_ROWS",
    "LANES",
    "LANE_WORK",
    "STATUS_BAD_PARAMETER",
    "STATUS_MESSAGES",
    "STATUS_NONFINITE",
    "STATUS_OK",
    "STATUS_REJECTED",
    "STATUS_RUNAWAY",
    "Environment",
    "allocate_outputs",
    "env_at",
    "env_gather",
    "gust_at",
    "rk4_lanes",
    "rk4_trial",
    "table_position",
]

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_RUNAWAY = 2
STATUS_BAD_PARAMETER = 3
STATUS_REJECTED = 4
STATUS_MESSAGES = {
    STATUS_OK: "ok",
    STATUS_NONFINITE: "a state became NaN or inf (numerical divergence); try a smaller dt",
    STATUS_RUNAWAY: "a state left its physical bound (runaway: speed, rate or attitude limit)",
    STATUS_BAD_PARAMETER: "a parameter is NaN or inf",
    STATUS_REJECTED: "the model rejected the parameters (non-physical, e.g. mass matrix not SPD)",
}


@dataclass(frozen=True)
class Environment:
    """Tabulated atmosphere, wind and gusts in the layout compiled code reads.

    ``atm`` has shape (1 + H, 5): row 0 is a header ``[h_min, dh, H, windy, 0]`` (``windy`` is 1
    if the profile has wind anywhere, else 0); rows 1..H hold
    ``[rho (kg/m³), g (m/s²), wind_north, wind_east, wind_down (m/s)]`` at altitudes
    ``h_min + k dh``. ``gust`` has shape (1 + G, 3): header ``[t0, dt, G]`` then gust velocities
    (north, east, down) in m/s at times ``t0 + k dt``. Both are interpolated linearly and held
    constant outside their range; use :func:`env_at` to read them.
    """

    atm: NDArray[np.float64]
    gust: NDArray[np.float64]

    @classmethod
    def build(
        cls,
        *,
        atmosphere: ISA | UniformAtmosphere | None = None,
        wind: Wind | WindProfile | None = None,
        h_min: float = -200.0,
        h_max: float = 3_000.0,
        dh: float = 1.0,
        t_final: float = 0.0,
        h0: float = 1_000.0,
    ) -> Environment:
        """Tabulate ``atmosphere`` and ``wind`` between ``h_min`` and ``h_max`` (m) every ``dh``.

        ``t_final`` and ``h0`` (s, m) are used only to generate turbulence, if ``wind`` has it.
        """
        atmosphere = ISA() if atmosphere is None else atmosphere
        if not (h_max > h_min and dh > 0):
            raise ValueError(f"need h_max > h_min and dh > 0, got {h_min}, {h_max}, {dh}")
        n_h = int(np.ceil((h_max - h_min) / dh)) + 1
        h = h_min + dh * np.arange(n_h)
        atm = np.zeros((n_h + 1, 5))
        atm[0, :3] = h_min, dh, n_h
        atm[1:, 0] = atmosphere.density(h)
        atm[1:, 1] = atmosphere.gravity(h)
        gust = np.zeros((2, 3))
        gust[0] = 0.0, 1.0, 1.0
        if wind is not None:
            if isinstance(wind, WindProfile):
                wind = Wind(wind)
            if not isinstance(wind, Wind):
                raise TypeError(
                    f"wind must be a Wind, a WindProfile or None (calm), got {type(wind).__name__}"
                )
            atm[1:, 2:4] = wind.profile(h)
            atm[0, 3] = float(np.any(atm[1:, 2:5] != 0.0))
            if wind.turbulence is not None:
                t, g = wind.turbulence.series(t_final, h0, wind.profile)
                gust = np.zeros((t.size + 1, 3))
                gust[0] = t[0], wind.turbulence.dt, t.size
                gust[1:] = g
        return cls(np.ascontiguousarray(atm), np.ascontiguousarray(gust))


@njit(cache=True, inline="always")
def env_at(atm, gust, t, h):  # pragma: no cover - compiled
    """Density, gravity and wind (north, east, down) at time ``t`` (s) and altitude ``h`` (m)."""
    n_h = int(atm[0, 2])
    s = (h - atm[0, 0]) / atm[0, 1]
    if s <= 0.0 or n_h == 1:
        k = 1
        w = 0.0
    elif s >= n_h - 1:
        k = n_h
        w = 0.0
    else:
        i = int(s)
        k = i + 1
        w = s - i
    r0 = atm[k]
    if w != 0.0:
        r1 = atm[k + 1]
        rho = r0[0] + w * (r1[0] - r0[0])
        g = r0[1] + w * (r1[1] - r0[1])
        wn = r0[2] + w * (r1[2] - r0[2])
        we = r0[3] + w * (r1[3] - r0[3])
        wd = r0[4] + w * (r1[4] - r0[4])
    else:
        rho = r0[0]
        g = r0[1]
        wn = r0[2]
        we = r0[3]
        wd = r0[4]
    if int(gust[0, 2]) > 1:
        gn, ge, gd = gust_at(gust, t)
        wn += gn
        we += ge
        wd += gd
    return rho, g, wn, we, wd


@njit(cache=True, inline="always")
def gust_at(gust, t):  # pragma: no cover - compiled
    """Gust velocity (north, east, down), m/s, at time ``t`` (s); zero without turbulence."""
    n_g = int(gust[0, 2])
    if n_g <= 1:
        return 0.0, 0.0, 0.0
    sg = (t - gust[0, 0]) / gust[0, 1]
    if sg <= 0.0:
        return gust[1, 0], gust[1, 1], gust[1, 2]
    if sg >= n_g - 1:
        return gust[n_g, 0], gust[n_g, 1], gust[n_g, 2]
    j = int(sg)
    a = sg - j
    return (
        gust[j + 1, 0] + a * (gust[j + 2, 0] - gust[j + 1, 0]),
        gust[j + 1, 1] + a * (gust[j + 2, 1] - gust[j + 1, 1]),
        gust[j + 1, 2] + a * (gust[j + 2, 2] - gust[j + 1, 2]),
    )


@njit(cache=True, inline="always", error_model="numpy")
def table_position(h, h_min, dh, n_h):  # pragma: no cover - compiled
    """Row and weight of altitude ``h`` (m) in the atmosphere table, without branches.

    ``h_min, dh, n_h`` are ``atm[0, 0], atm[0, 1], int(atm[0, 2])``. Returns ``(i, w)`` with
    ``i`` a float: the value at ``h`` interpolates table rows ``i + 1`` and ``i + 2`` with
    weight ``w``, as in :func:`env_at` (clamped at the ends, where ``w`` is 0). A NaN altitude
    gives row 0: a diverging trial still reads a valid row. For :func:`env_gather`.
    """
    s = (h - h_min) / dh
    s = s if s > 0.0 else 0.0
    s_max = n_h - 1.0
    s = s if s < s_max else s_max
    i = np.floor(s)
    return i, s - i


@njit(cache=True, inline="always", error_model="numpy")
def env_gather(atm, gust, t, W):  # pragma: no cover - compiled
    """Environment of a group of trials, for :func:`rk4_lanes` right-hand sides.

    Expects ``W[5, k], W[6, k] = table_position(altitude of column k, ...)`` and writes
    ``W[0:5, k] = env_at(atm, gust, t, altitude)`` (density, gravity, wind north, east, down),
    bit for bit. Models use the rows of ``W`` from :data:`ENV_ROWS` on.

    Why it is split so: table reads at data-dependent rows (gathers) in the same loop as
    stores stop LLVM from vectorising the loop ("cannot identify array bounds"), so the rows
    are computed in the model's vectorised loop (with :func:`table_position`), the table is
    read here in a short scalar loop (only the wind columns if the profile has wind,
    ``atm[0, 3]``, see :meth:`Environment.build`), and the gust, the same for every column, is
    computed once.
    """
    # unsigned row numbers: numba adds no negative-index wraparound to the reads
    n_h = np.uint64(atm[0, 2])
    n = W.shape[1]
    for k in range(n):
        k0 = np.uint64(W[5, k]) + np.uint64(1)
        w = W[6, k]
        k1 = k0 + np.uint64(1) if k0 < n_h else n_h
        W[0, k] = atm[k0, 0] + w * (atm[k1, 0] - atm[k0, 0])
        W[1, k] = atm[k0, 1] + w * (atm[k1, 1] - atm[k0, 1])
    gn, ge, gd = gust_at(gust, t)
    if atm[0, 3] != 0.0:
        for k in range(n):
            k0 = np.uint64(W[5, k]) + np.uint64(1)
            w = W[6, k]
            k1 = k0 + np.uint64(1) if k0 < n_h else n_h
            W[2, k] = atm[k0, 2] + w * (atm[k1, 2] - atm[k0, 2]) + gn
            W[3, k] = atm[k0, 3] + w * (atm[k1, 3] - atm[k0, 3]) + ge
            W[4, k] = atm[k0, 4] + w * (atm[k1, 4] - atm[k0, 4]) + gd
    else:
        for k in range(n):
            W[2, k] = gn
            W[3, k] = ge
            W[4, k] = gd


@njit(inline="always")
def rk4_trial(
    rhs, observe, x0, p, ctrl_t, ctrl_v, ctrl_mode, atm, gust, dt, n_steps, stride, x_max, y
):  # pragma: no cover - compiled
    """Integrate ONE trial with classical RK4; write outputs every ``stride`` steps into ``y``.

    Returns ``(status, t_fail)``: status 0 with ``t_fail = nan`` on success; on failure the
    trial stops, outputs from the failing output time on are NaN and ``t_fail`` is the time of
    the step that failed. See the module docstring for the argument layouts.
    """
    ns = x0.shape[0]
    x = x0.copy()
    k = np.empty((4, ns))  # the four stage slopes
    xt = np.empty(ns)
    u = np.empty(ctrl_v.shape[1])
    n_out = y.shape[0]
    # output at t = 0
    control_at(ctrl_t, ctrl_v, ctrl_mode, 0.0, u)
    observe(0.0, x, p, u, atm, gust, y[0])
    half = 0.5 * dt
    sixth = dt / 6.0  # a product per state, not a division
    for step in range(n_steps):
        t = step * dt
        # One call site for the right-hand side, in a loop over the stages: a model whose
        # ``_rhs`` is ``inline="always"`` is compiled into this loop once, not four times.
        for stage in range(4):
            if stage == 0:
                ts = t
                for j in range(ns):
                    xt[j] = x[j]
            elif stage == 3:
                ts = t + dt
                for j in range(ns):
                    xt[j] = x[j] + dt * k[2, j]
            else:
                ts = t + half
                for j in range(ns):
                    xt[j] = x[j] + half * k[stage - 1, j]
            if stage != 2:  # stages 1 and 2 share the time t + dt/2
                control_at(ctrl_t, ctrl_v, ctrl_mode, ts, u)
            rhs(ts, xt, p, u, atm, gust, k[stage])
        status = 0
        for j in range(ns):
            xn = x[j] + sixth * (k[0, j] + 2.0 * (k[1, j] + k[2, j]) + k[3, j])
            if not np.isfinite(xn):
                status = 1
            elif abs(xn) > x_max[j]:
                if status == 0:
                    status = 2
            x[j] = xn
        if status != 0:
            first = (step + stride) // stride  # first output index not yet written
            for i_out in range(first, n_out):
                for c in range(y.shape[1]):
                    y[i_out, c] = np.nan
            return status, (step + 1) * dt
        if (step + 1) % stride == 0:
            observe((step + 1) * dt, x, p, u, atm, gust, y[(step + 1) // stride])
    return 0, np.nan


#: Trials integrated in lockstep by :func:`rk4_lanes`, one per SIMD lane: 8 float64 fill an
#: AVX-512 register (two AVX2 registers).
LANES = 16
#: Rows of the scratch array ``W`` (LANE_WORK, LANES) that :func:`rk4_lanes` lends to the
#: right-hand side; :func:`env_gather` uses the first ``ENV_ROWS``.
LANE_WORK = 12
ENV_ROWS = 7


@njit(inline="always", error_model="numpy")
def rk4_lanes(
    rhs,
    observe,
    x0,
    p,
    rows,
    ctrl_t,
    ctrl_v,
    ctrl_mode,
    atm,
    gust,
    dt,
    n_steps,
    stride,
    x_max,
    y,
    status,
    t_fail,
):  # pragma: no cover - compiled
    """Integrate the trials ``rows`` (at most :data:`LANES`) in lockstep with classical RK4.

    The structure-of-arrays twin of :func:`rk4_trial`: the states of the group are held as
    ``(n_state, LANES)`` arrays, one trial per column, and ``rhs(t, X, P, u, atm, gust, DX, W)``
    computes all columns at once in a loop over the last axis that the compiler vectorises
    (see the module docstring); ``W`` is a (LANE_WORK, LANES) scratch array, and
    ``observe(t, X, P, u, atm, gust, W, Y)`` writes the output channels of every column into
    ``Y`` (n_out, LANES). ``x0`` (n, n_state) and ``p`` (n, n_const) are the whole batch;
    ``rows`` (k,) int64 are the trials of this group; ``y``, ``status`` and ``t_fail`` are the
    batch's outputs, written for ``rows`` only.

    Semantics equal :func:`rk4_trial` trial by trial: the same status codes and ``t_fail``; a
    failed trial's outputs from the failing output time on are NaN; each column is computed
    with the same instructions whatever its neighbours (no reductions across columns; the
    column loops run LANES times, a multiple of any vector width, so no column falls into
    scalar remainder code), so a trial gives bit-identical results in any group, position or
    batch.
    Columns past ``k`` repeat the last trial and are discarded; a failed column restarts from
    its initial state (so that it stays finite) and is no longer written.
    """
    n_rows = rows.shape[0]
    ns = x0.shape[1]
    npar = p.shape[1]
    # Arrays with LANES, a compile-time constant, as their last extent: the compiler then knows
    # the distance between rows and vectorises the loops over columns (a reshaped view, whose
    # extents it cannot see, measured 5x slower).
    X = np.empty((ns, LANES))
    XT = np.empty((ns, LANES))
    K = np.empty((4, ns, LANES))
    P = np.empty((npar, LANES))
    W = np.empty((LANE_WORK, LANES))
    # flat views of the same memory for the element-wise RK4 loops: one loop of
    # n_state * LANES iterations vectorises (the nested loops were unrolled and stayed scalar)
    n_el = ns * LANES
    Xf = X.reshape(n_el)
    XTf = XT.reshape(n_el)
    Kf = K.reshape((4, n_el))
    bound = np.empty(n_el)
    for lane in range(LANES):
        r = rows[lane if lane < n_rows else n_rows - 1]
        for j in range(ns):
            X[j, lane] = x0[r, j]
            bound[j * LANES + lane] = x_max[j]
        for c in range(npar):
            P[c, lane] = p[r, c]
    alive = np.zeros(LANES, dtype=np.bool_)
    for lane in range(n_rows):
        alive[lane] = True
    n_alive = n_rows
    n_out = y.shape[1]
    n_chan = y.shape[2]
    Y = np.empty((n_chan, LANES))
    u = np.empty(ctrl_v.shape[1])
    control_at(ctrl_t, ctrl_v, ctrl_mode, 0.0, u)
    half = 0.5 * dt
    sixth = dt / 6.0
    for step in range(n_steps + 1):
        if step % stride == 0:  # one call site: the inlined observer is compiled in once
            observe(step * dt, X, P, u, atm, gust, W, Y)
            i_out = step // stride
            for lane in range(n_rows):
                if alive[lane]:
                    r = rows[lane]
                    for c in range(n_chan):
                        y[r, i_out, c] = Y[c, lane]
        if step == n_steps:
            return
        t = step * dt
        for stage in range(4):
            if stage == 0:
                ts = t
                for e in range(n_el):
                    XTf[e] = Xf[e]
            elif stage == 3:
                ts = t + dt
                for e in range(n_el):
                    XTf[e] = Xf[e] + dt * Kf[2, e]
            else:
                ts = t + half
                for e in range(n_el):
                    XTf[e] = Xf[e] + half * Kf[stage - 1, e]
            if stage != 2:
                control_at(ctrl_t, ctrl_v, ctrl_mode, ts, u)
            rhs(ts, XT, P, u, atm, gust, K[stage], W)
        n_bad = 0  # elements that are NaN, inf or out of bounds (an integer sum vectorises)
        for e in range(n_el):
            xn = Xf[e] + sixth * (Kf[0, e] + 2.0 * (Kf[1, e] + Kf[2, e]) + Kf[3, e])
            Xf[e] = xn
            n_bad += 0 if (xn - xn == 0.0) & (abs(xn) <= bound[e]) else 1
        if n_bad > 0:
            for lane in range(LANES):
                nonfinite = False
                runaway = False
                for j in range(ns):
                    xn = X[j, lane]
                    nonfinite |= not (xn - xn == 0.0)
                    runaway |= abs(xn) > x_max[j]
                if not (nonfinite or runaway):
                    continue
                r = rows[lane if lane < n_rows else n_rows - 1]
                if alive[lane]:
                    alive[lane] = False
                    n_alive -= 1
                    status[r] = 1 if nonfinite else 2
                    t_fail[r] = (step + 1) * dt
                    for i_out in range((step + stride) // stride, n_out):
                        for c in range(n_chan):
                            y[r, i_out, c] = np.nan
                for j in range(ns):  # restart the column so that it stays finite
                    X[j, lane] = x0[r, j]
            if n_alive == 0:
                return


def allocate_outputs(n: int, n_steps: int, stride: int, n_out: int) -> NDArray[np.float64]:
    """NaN-filled output array (n, n_steps // stride + 1, n_out) for :func:`rk4_trial`."""
    return np.full((n, n_steps // stride + 1, n_out), np.nan)

"""Measurement noise and the criteria constraints it implies (noise floors).

In the PSI method the criteria constraints Φ** say how close the model must come to the
measurements. Where the measurement noise is known, the closest a *perfect* model can come is
known too: the value a criterion takes when the model is exact and only the noise differs —
its **noise floor**. A limit at the floor (at a stated quantile) keeps in the feasible set D
every parameter vector that the data cannot tell from the truth, and no more; a
**discrepancy** allowance adds what the expert grants the model for what it does not
represent (gusts, actuator lag, ...), in the spirit of history matching's implausibility
cut-off.

The study file
--------------
::

    [identification]
    noise = { position_h = 1.5, position_v = 3.0, velocity = 0.15, euler_deg = 0.5,
              rates = 0.01 }                 # one σ per channel key (one line in TOML)
    # noise = "estimate"                    # σ of each channel from its high-frequency residual
    limits = "noise"                        # every criterion without a number gets its floor
    # noise_quantile = 0.99                 # per-criterion quantile (default: joint coverage)
    # noise_coverage = 0.95                 # joint coverage of the floors (default 0.95)
    # noise_draws = 2000                    # Monte Carlo draws (default 2000)
    # noise_seed = 0
    discrepancy = { position_h = 20.0 }     # model-discrepancy allowance (see below)

    [[criteria]]
    name = "pos_h_abs"
    limit = "noise"                         # this criterion only (instead of limits = "noise")

    [[identification.drops]]
    noise = { position_v = 5.0 }            # per drop: overrides the study-level keys

Noise keys (values in the key's unit; a number is the σ of white noise, a table
``{ sigma = 1.5, correlation_time = 20.0, white = 0.2 }`` is a first-order Gauss–Markov
error of σ ``sigma`` and correlation time ``correlation_time`` s plus white noise of σ
``white``): ``position_h`` (m, north and east each), ``position_v`` (m, down),
``position`` (m, all three), ``velocity`` / ``velocity_h`` / ``velocity_v`` (m/s),
``euler`` (rad) or ``euler_deg`` (deg), ``rates`` (rad/s) or ``rates_deg`` (deg/s),
``altitude`` (m).

The floor (:func:`vectorid.identify.noise.floor.noise_floor`): a seeded Monte Carlo of the
twin experiment the noise statement describes, through the study's own criterion functions
on the drop's own sample times and comparison grid. For each draw: noise is drawn at every
sample of each channel (white, or Gauss–Markov with the exact discretisation for uneven
steps), the "truth" is the model's own trajectory from the drop's initial state, the
measurement is truth + noise interpolated onto the comparison grid as the real data are, the
initial state is re-fitted to the noisy data by the same least-squares lines as the
identification's (so a noisy start is part of the floor), and the "perfect model" is flown
from that fitted state. The propagation of the initial-state error is linearised (central
differences over the twelve initial-state components, 25 simulations per drop and wind
realisation instead of one per draw: the model takes one initial state per batch);
``noise_floor`` with ``linear=False`` flies each draw, and the test suite checks that both
agree. With ``wind_realisations = M > 1`` the truth flies in the measured profile and the
model in each realisation, so the floor of the expectation criterion includes the wind
uncertainty.

Quantile (:meth:`vectorid.identify.noise.floor.NoiseFloor.limits`): with ``noise_quantile``
unset, one per-criterion quantile level q is found such that all constrained criteria are
below their q-quantiles together in ``noise_coverage`` (95 %) of the draws — a joint Monte
Carlo rather than Šidák's q = 0.95^(1/K), because the criteria share the same noise
(``pos_h_abs`` and ``pos_h_sq`` are almost the same statistic) and Šidák, which assumes
independence, would over-cover. The limit's note states q, the coverage, the draws and the
allowance.

Discrepancy allowance (same keys and units as the noise, or a criterion name in the
criterion's unit): a channel allowance δ is a bound on the model's deviation from the truth
in that channel (the horizontal distance for ``*_h`` keys, each axis otherwise), converted
per criterion by the triangle inequality: ∫|e + d| ≤ ∫|e| + δ·T for the absolute-residual
criteria (δ in time-mean form with window variables), (√∫e² + δ√T)² for the squared ones
(Minkowski), + δ for the final miss; applied draw by draw before the quantile. Criteria that
no channel bound limits (frequencies, rate extremes, indices) take an allowance only under
their own name. A criterion-name allowance is added to the limit.

The estimator (``noise = "estimate"``, :func:`estimate_sigma`): σ̂ = 1.4826 MAD(Δ³y) / √20,
the robust spread of the third differences of each component, scaled by Var(Δ³n) =
C(6, 3) σ² = 20σ² for white noise n; on unevenly spaced samples (a logger that writes rows at
jittered times) the third divided differences, each divided by the norm of its weights, which
have variance σ² whatever the steps. The third difference removes a smooth signal (it leaves
s'''·Δt³) and the MAD (recomputed without the differences beyond 5 σ̂) ignores spikes;
differences across a gap (a step over twice the median) are left out. Only the channels the
drop's criteria and its initial-state fit read are estimated. It sees the *white* part of
the noise: a correlated error slower than the sampling (a GPS position error of 20 s
correlation time) is indistinguishable from motion and is estimated as its small
high-frequency share (:func:`highfreq_sigma` gives it); state such errors explicitly, or
grant them as discrepancy.

The package, by job (each module imports only those above it)
--------------------------------------------------------------
- :mod:`~vectorid.identify.noise.statements`: the noise statement and the discrepancy table
  parsed (:class:`ComponentNoise`, :class:`NoiseModel`, :func:`parse_noise`,
  :func:`parse_discrepancy`, :data:`NOISE_KEYS`, :data:`DISCREPANCY_RULES`);
- :mod:`~vectorid.identify.noise.estimate`: noise estimated from the data
  (:func:`estimate_sigma`, :func:`estimate_correlated`, :func:`highfreq_sigma`,
  :func:`estimate_noise`);
- :mod:`~vectorid.identify.noise.floor`: the floor's Monte Carlo (``noise_floor`` for flight
  drops, ``record_noise_floor`` for a model of your own, ``NoiseFloor``); it flies the
  identification's model, so it sits above :mod:`vectorid.identify.identification`;
- :mod:`~vectorid.identify.noise.resolve`: study-level resolution (``noise_limits``,
  ``resolve_noise_limits``: the identification builder's ``prepare`` hook).

The names of the first two are importable from here; the floor and the resolution from their
modules (they build on the identification, which itself reads noise statements from here).
"""

from __future__ import annotations

from vectorid.identify.noise.estimate import (
    estimate_correlated,
    estimate_noise,
    estimate_sigma,
    highfreq_sigma,
)
from vectorid.identify.noise.statements import (
    DISCREPANCY_RULES,
    NOISE_KEYS,
    ComponentNoise,
    NoiseModel,
    allowance_label,
    parse_component,
    parse_discrepancy,
    parse_noise,
)

__all__ = [
    "DISCREPANCY_RULES",
    "NOISE_KEYS",
    "ComponentNoise",
    "NoiseModel",
    "allowance_label",
    "estimate_correlated",
    "estimate_noise",
    "estimate_sigma",
    "highfreq_sigma",
    "parse_component",
    "parse_discrepancy",
    "parse_noise",
]

"""The sequential PSI sampler's parts that only compute (nothing here evaluates or stores).

Split at the seams ABC-SMC samplers use (pyABC's driver / epsilon / transition / weights /
population size), in PSI's terms:

* :mod:`.tolerance` — one limit per constrained criterion, tightened each generation toward
  the stated Φ** (a quantile of the accepted population, never below Φ**);
* :mod:`.kernel` — the proposal: a Gaussian mixture on the accepted members, truncated to the
  box, with its in-box mass estimated from draws;
* :mod:`.weights` — deterministic-mixture importance weights against the box over every
  generation's proposal, and Kish's effective sample size.

The driver that evaluates each generation as batches and stores it lives in
:mod:`vectorid.run.sequential` (``run/`` is the one place that evaluates and stores).
"""

from .kernel import Proposal, fit_proposal
from .tolerance import next_tolerance, oriented
from .weights import kish_ess, log_weights

__all__ = ["Proposal", "fit_proposal", "kish_ess", "log_weights", "next_tolerance", "oriented"]

"""The sequential PSI sampler, split at the seams ABC-SMC samplers use (pyABC's driver /
epsilon / transition / weights), in PSI's terms:

* :mod:`.sampler` — :class:`SequentialSampler`: generations as rounds of the run driver, and
  its summary;
* :mod:`.schedule` — how far each generation tightens the limits and what it draws;
* :mod:`.tolerance` — one limit per constrained criterion, tightened each generation toward
  the stated Φ** (a quantile of the accepted population, never below Φ**);
* :mod:`.kernel` — the proposal: a Gaussian mixture on the accepted members, truncated to the
  box, with its in-box mass estimated from draws;
* :mod:`.moves` — with many variables, random-walk moves of equally weighted particles;
* :mod:`.weights` — deterministic-mixture importance weights against the box over every
  generation's proposal;
* :mod:`.state` — the generations replayed from the store's sampler records, D and its ESS;
* :mod:`.search` — the local search when the budget is spent before D is reached.
"""

from .sampler import SequentialSampler, SequentialSummary, describe_state, sample_note
from .search import LocalSearch, search_edges
from .state import Generation, SequentialState, assess, final_chains, generations, trial_log_weights

__all__ = [
    "Generation",
    "LocalSearch",
    "SequentialSampler",
    "SequentialState",
    "SequentialSummary",
    "assess",
    "describe_state",
    "final_chains",
    "generations",
    "sample_note",
    "search_edges",
    "trial_log_weights",
]

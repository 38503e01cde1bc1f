"""The ``vectorid`` command line: :func:`main` parses the verb and hands it to its module.

* :mod:`.main` — the parser, the run verbs (``run``, ``info``, ``verify``, ``repair``,
  ``init``, ``demo``) and the shared options;
* :mod:`.analysis` — the analysis verbs (``table``, ``pareto``, ``report``, ``hist``, ...);
* :mod:`.descent` — ``vectorid descent``; :mod:`.step` — ``vectorid step``;
  :mod:`.ui` — ``vectorid ui``.

The verbs' modules are imported when their verb runs, so ``vectorid --help`` starts without
loading the models, numba or the analysis.
"""

from .main import main

__all__ = ["main"]

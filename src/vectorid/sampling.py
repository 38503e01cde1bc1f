"""Uniformly distributed point sequences: Sobol LP_tau sequences and Latin hypercubes.

A *point sequence* gives the points a sampler (:mod:`vectorid.samplers`) starts from: the plain
table evaluates them as they come, the sequential sampler takes its generation 0 from them.

Points are addressed by a *sequence index* ``i = 0, 1, 2, ...``. The point with index ``i``
is always the same for a given sampler, so a study run as 1024 + 1024 trials holds exactly
the trials of one 2048-trial run, whatever the batching.

* ``"sobol"`` (default): Sobol's LP_tau sequence from :class:`scipy.stats.qmc.Sobol`,
  unscrambled as the PSI method prescribes. Index ``i`` is the point ``Q_{i+1}`` of the
  sequence: the all-zeros point ``Q_0`` (a corner of the box) is skipped, as in Sobol's
  LP_tau tables which number points from 1. With ``scramble=True`` the sequence is
  Owen-scrambled with the given seed and index ``i`` is point ``i``.
* ``"lhs"``: Latin hypercubes from :class:`scipy.stats.qmc.LatinHypercube`, in blocks of
  ``block`` points; block ``b`` is drawn with a generator seeded by ``(seed, b)``, so every
  block is a Latin hypercube and any index range is reproducible.
"""

from __future__ import annotations

import warnings

import numpy as np

from .errors import StudyDefinitionError

__all__ = ["SEQUENCES", "PointSequence"]

#: The point sequences.
SEQUENCES = ("sobol", "lhs")


class PointSequence:
    """Reproducible points of the unit cube ``[0, 1)^d`` addressed by sequence index.

    Parameters
    ----------
    d : int
        Dimension (number of design variables).
    kind : {"sobol", "lhs"}
        Sequence type.
    scramble : bool
        Owen-scramble the Sobol sequence (needs ``seed`` for reproducibility).
    seed : int, optional
        Seed for scrambling and for Latin hypercubes.
    block : int
        Latin hypercube block size.
    """

    def __init__(
        self,
        d: int,
        kind: str = "sobol",
        *,
        scramble: bool = False,
        seed: int | None = None,
        block: int = 1024,
    ) -> None:
        if kind not in SEQUENCES:
            raise StudyDefinitionError(
                "study.sampler",
                f"unknown point sequence {kind!r}",
                f"use one of {', '.join(SEQUENCES)}",
            )
        if d < 1:
            raise ValueError(f"dimension must be >= 1, got {d}")
        from scipy.stats import qmc  # here, not at import: scipy.stats takes ~0.5 s to load

        if d > qmc.Sobol.MAXDIM and kind == "sobol":
            raise StudyDefinitionError(
                "variables",
                f"Sobol sequences support at most {qmc.Sobol.MAXDIM} variables, got {d}",
                'use sampler = "lhs"',
            )
        self.d = int(d)
        self.kind = kind
        self.scramble = bool(scramble)
        self.seed = seed
        self.block = int(block)

    def points(self, start: int, n: int) -> np.ndarray:
        """Points with sequence indices ``start, ..., start + n - 1``.

        Parameters
        ----------
        start : int
            Sequence index of the first point (index i is LP_tau point Q_{i+1}).
        n : int
            Number of points.

        Returns
        -------
        (n, d) ndarray of float
            Points of the unit cube [0, 1)^d (dimensionless); the same indices give the same
            points however the sequence is split.
        """
        if start < 0 or n < 0:
            raise ValueError(f"start and n must be >= 0, got start={start}, n={n}")
        if n == 0:
            return np.empty((0, self.d))
        if self.kind == "sobol":
            return self._sobol(start, n)
        return self._lhs(start, n)

    def _sobol(self, start: int, n: int) -> np.ndarray:
        from scipy.stats import qmc

        engine = qmc.Sobol(
            self.d, scramble=self.scramble, seed=self.seed if self.scramble else None
        )
        offset = start if self.scramble else start + 1
        if offset:
            engine.fast_forward(offset)
        with warnings.catch_warnings():
            # scipy warns that balance needs powers of two; continuation by index is the
            # point here, and the sequence itself is unchanged.
            warnings.simplefilter("ignore", UserWarning)
            return engine.random(n)

    def _lhs(self, start: int, n: int) -> np.ndarray:
        from scipy.stats import qmc

        out = np.empty((n, self.d))
        first, last = start // self.block, (start + n - 1) // self.block
        pos = 0
        for b in range(first, last + 1):
            rng = np.random.default_rng([0 if self.seed is None else self.seed, b])
            pts = qmc.LatinHypercube(self.d, seed=rng).random(self.block)
            lo = max(start, b * self.block) - b * self.block
            hi = min(start + n, (b + 1) * self.block) - b * self.block
            out[pos : pos + hi - lo] = pts[lo:hi]
            pos += hi - lo
        return out

"""Polynomial coefficients of :mod:`vectorid.models.vecmath` (sin, cos and atan kernels).

Each kernel is a polynomial in ``z = r²`` interpolated at Chebyshev nodes in 50-digit
arithmetic (near-minimax), then rounded to float64 (a float64 conversion from the Chebyshev
basis loses about 10 ulp):

- ``sin r = r + r z S(z)`` and ``cos r = 1 - z/2 + z² C(z)`` on ``|r| <= π/4``, S and C of
  degree 5;
- ``atan t = t + t z A(z)`` on ``|t| <= tan(π/8)``, A of degree 9.

Prints the coefficients and the largest error of each kernel against numpy on 400,000 points
(in ulp of the result). Needs ``mpmath`` (``pip install mpmath``), which is not a dependency
of vectorid: run it only to regenerate the tables.

Run::

    python scripts/fit_vecmath.py
"""

import mpmath as mp
import numpy as np

mp.mp.dps = 50


def fit(f, b, degree: int) -> list[float]:
    """Float64 monomial coefficients of the degree-``degree`` interpolant of f on [0, b]."""
    n = degree + 1
    nodes = [b / 2 * (1 + mp.cos(mp.pi * (k + mp.mpf(1) / 2) / n)) for k in range(n)]
    vandermonde = mp.matrix([[x**j for j in range(n)] for x in nodes])
    c = mp.lu_solve(vandermonde, mp.matrix([f(x) for x in nodes]))
    return [float(c[j]) for j in range(n)]


def horner(c: list[float], z: np.ndarray) -> np.ndarray:
    p = np.zeros_like(z)
    for cj in c[::-1]:
        p = p * z + cj
    return p


def ulp_error(approx: np.ndarray, exact: np.ndarray) -> float:
    return float(np.max(np.abs(approx - exact) / np.spacing(np.abs(exact))))


def main() -> None:
    quarter = (mp.pi / 4) ** 2
    s = fit(lambda z: (mp.sin(mp.sqrt(z)) - mp.sqrt(z)) / mp.sqrt(z) ** 3, quarter, 5)
    c = fit(lambda z: (mp.cos(mp.sqrt(z)) - 1 + z / 2) / z**2, quarter, 5)
    a = fit(
        lambda z: (mp.atan(mp.sqrt(z)) - mp.sqrt(z)) / mp.sqrt(z) ** 3, mp.tan(mp.pi / 8) ** 2, 9
    )
    r = np.linspace(-np.pi / 4, np.pi / 4, 400_001)
    r = r[r != 0.0]
    z = r * r
    t = np.linspace(-np.tan(np.pi / 8), np.tan(np.pi / 8), 400_001)
    t = t[t != 0.0]
    for name, coeffs in (("SIN", s), ("COS", c), ("ATAN", a)):
        print(f"_{name} = (")
        for cj in coeffs:
            print(f"    {cj!r},")
        print(")")
    print(
        f"# sin: {ulp_error(r + r * z * horner(s, z), np.sin(r)):.1f} ulp, "
        f"cos: {ulp_error(1.0 - 0.5 * z + z * z * horner(c, z), np.cos(r)):.1f} ulp, "
        f"atan: {ulp_error(t + t * t * t * horner(a, t * t), np.arctan(t)):.1f} ulp"
    )


if __name__ == "__main__":
    main()

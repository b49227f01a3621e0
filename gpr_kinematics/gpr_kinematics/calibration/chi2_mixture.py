"""The distribution of a positive combination of independent chi-squares, ``T = sum_j lambda_j chi^2_(h_j)`` (the sum
of squared residuals whose covariance has the eigenvalues ``lambda_j``, ``h_j`` times each): its survival function
by Imhof's inversion of the characteristic function (Imhof, "Computing the distribution of quadratic forms in
normal variables", 1961),

    P(T > x) = 1/2 + 1/pi int_0^inf sin(theta(u)) / (u rho(u)) du,
    theta(u) = 1/2 sum_j h_j arctan(lambda_j u) - x u / 2,   rho(u) = prod_j (1 + lambda_j^2 u^2)^(h_j / 4),

the integral taken to where ``rho`` has cut the rest below :data:`CUT` (``|tail| <= 2 / (sum h rho(U))``), and its
quantiles by bracketing. With ``sum h`` below :data:`MIN_DOF` the integrand decays too slowly for that: the upper
quantiles then come from the three-moment approximation that paper compares (Pearson's: ``a + b chi^2_d`` with the
first three cumulants matched), which holds the upper tail (0.11 % for 0.1 % in a mixture of 3 + 2 degrees of
freedom) but not the lower one (5 %), and no lower quantile is given.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import integrate, optimize
from scipy.stats import chi2 as chi2_distribution

Array = NDArray[np.float64]

#: Least total degrees of freedom for Imhof's integral (below it: the three-moment approximation, upper tail only).
MIN_DOF = 10
#: What the integral's cut may leave out of a probability.
CUT = 1e-10


def survival(x: float, lam: Array, h: Array) -> float:
    """``P(T > x)`` (module docstring) for the weights ``lam > 0`` and degrees of freedom ``h`` ``(J,)``, ``sum h >=
    MIN_DOF``."""
    upper = _cut(lam, h)

    def integrand(u: float) -> float:
        theta = 0.5 * float(np.sum(h * np.arctan(lam * u))) - 0.5 * x * u
        return math.sin(theta) / (u * math.exp(0.25 * float(np.sum(h * np.log1p((lam * u) ** 2)))))

    return 0.5 + float(integrate.quad(integrand, 0.0, upper, limit=1000, epsabs=1e-12)[0]) / math.pi


def _cut(lam: Array, h: Array) -> float:
    """Where the integral may stop: the least ``U`` with ``rho(U) >= 2 / (CUT sum h)`` (by bisection in ``log U``;
    weights of many sizes: the large ones cut it early, or millions of the integrand's cycles would lie before)."""
    need = math.log(2.0 / (CUT * float(np.sum(h))))

    def log_rho(u: float) -> float:
        return 0.25 * float(np.sum(h * np.log1p((lam * u) ** 2)))

    lo, hi = 0.5 / float(np.max(lam)), 1.0 / float(np.max(lam))
    while log_rho(hi) < need:
        lo, hi = hi, 2.0 * hi
    while log_rho(lo) >= need:
        lo, hi = 0.5 * lo, lo
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if log_rho(mid) < need else (lo, mid)
    return hi


def quantile(p: float, lam: Array, h: Array) -> float | None:
    """The ``p`` point of ``T``: ``P(T <= x) = p`` (module docstring); None for a lower one (``p < 1/2``) below
    :data:`MIN_DOF` degrees of freedom."""
    lam, h = np.asarray(lam, dtype=float), np.asarray(h, dtype=float)
    k1, k2, k3 = (float(np.sum(h * lam ** j)) * c for j, c in ((1, 1.0), (2, 2.0), (3, 8.0)))   # cumulants
    if float(np.sum(h)) < MIN_DOF:
        if p < 0.5:
            return None
        d, b = 8.0 * k2 ** 3 / k3 ** 2, k3 / (4.0 * k2)
        return k1 - b * d + b * float(chi2_distribution.ppf(p, d))
    sd = math.sqrt(k2)
    lo, hi = (max(k1 - 40.0 * sd, 1e-12 * k1), k1) if p < 0.5 else (k1, k1 + 60.0 * sd)
    return float(optimize.brentq(lambda x: survival(x, lam, h) - (1.0 - p), lo, hi, xtol=1e-12, rtol=1e-12))

"""The normal, Student's t and chi-square points the calibration's gates and tests use, from ``scipy.special`` as
``scipy.stats`` computes them (the same functions in the same order, so the same floats): importing ``scipy.stats``
took 0.2-0.5 s, a quarter of a whole ``gpr calibrate`` run and of ``gpr accuracy``'s start.

All arguments are scalars within the distribution's domain (the callers' probabilities lie in (0, 1), their degrees
of freedom are positive).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import special

#: ``sqrt(2 pi)``, the normal density's constant.
SQRT_2PI = math.sqrt(2.0 * math.pi)


def normal_pdf(x: float) -> float:
    """The standard normal density ``phi(x) = exp(-x^2 / 2) / sqrt(2 pi)``."""
    return float(np.exp(-x ** 2 / 2.0) / SQRT_2PI)


def normal_sf(x: float) -> float:
    """The standard normal survival function ``1 - Phi(x) = Phi(-x)``."""
    return float(special.ndtr(-x))


def normal_isf(p: float) -> float:
    """The point the standard normal exceeds with probability ``p``: ``-Phi^-1(p)``."""
    return float(-special.ndtri(p))


def t_isf(p: float, nu: float) -> float:
    """The point Student's t with ``nu`` degrees of freedom exceeds with probability ``p``."""
    return float(-special.stdtrit(nu, p))


def chi2_ppf(q: float, dof: float) -> float:
    """The ``q`` quantile of the chi-square distribution with ``dof`` degrees of freedom: ``2 P^-1(dof / 2, q)``
    (``P`` the regularised lower incomplete gamma function)."""
    return float(2.0 * special.gammaincinv(dof / 2.0, q))

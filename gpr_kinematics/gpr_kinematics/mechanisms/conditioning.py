"""Conditioning of Jacobians: homogenisation by a characteristic length, singular values, dexterity.

Homogenisation (Toz & Kucuk §4.3, ``docs/references.md``): the angular columns of an inverse Jacobian are divided
by the characteristic length ``L`` and rows of angular joints multiplied by it, so every entry is dimensionless.
Dexterity is the inverse condition number ``sigma_min / sigma_max`` (1 isotropic, 0 singular).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core.config import LEAST_LENGTH
from ..errors import ConfigError, brief
from ..inputs.validation import MAX_COORDINATE

#: Joint types: ``prismatic`` (a distance, m) or ``revolute`` (an angle, rad).
LINEAR_JOINTS = frozenset({'prismatic', 'distance'})
ANGULAR_JOINTS = frozenset({'revolute', 'angle'})

#: Range of a characteristic length [m]: the GPR core's least (``core.config``) to every coordinate's bound. The
#: homogenised Jacobian's angular columns are divided by it: 1e-300 m made them 1e300, whose squares overflow
#: (numpy's LinAlgError from every dexterity map), and a regular pose read as singular.
CHARACTERISTIC_LENGTH = (LEAST_LENGTH, MAX_COORDINATE)


def check_characteristic_length(value: Any, where: str) -> float:
    """``value`` as a length [m] within :data:`CHARACTERISTIC_LENGTH`, else :class:`ConfigError` naming ``where``
    (e.g. ``'file.yaml: characteristic_length'``) and the range."""
    lo, hi = CHARACTERISTIC_LENGTH
    ok = isinstance(value, (int, float, np.floating)) and not isinstance(value, bool)
    if not ok or not (math.isfinite(float(value)) and lo <= float(value) <= hi):
        raise ConfigError(f'{where} = {brief(value)}; allowed: a length from {lo:g} to {hi:g} m (it homogenises the '
                          'angular columns of the Jacobians)')
    return float(value)


#: Inverse condition number below which a configuration counts as singular.
SINGULAR_TOLERANCE = 1e-9


def homogenize(jac: np.ndarray, joint_types: tuple[str, ...], length: float,
               column_kinds: tuple[str, ...] | None = None) -> np.ndarray:
    """Dimensionless inverse Jacobian by a characteristic length ``length`` (m) (Toz & Kucuk §4.3).

    Columns whose kind is ``'angular'`` (default: the last three, ``w_x w_y w_z``) are divided by
    ``length``; rows of angular joints are multiplied by ``length``.
    """
    jac = np.asarray(jac, dtype=float)
    if column_kinds is None:
        column_kinds = ('linear',) * 3 + ('angular',) * 3
    col = np.array([1.0 / length if k == 'angular' else 1.0 for k in column_kinds])
    row = np.array([length if t in ANGULAR_JOINTS else 1.0 for t in joint_types])
    return np.asarray(jac * row[:, None] * col[None, :])


#: Above this condition number the fast Gram-matrix estimate is replaced by an SVD (see :func:`dexterity_index`).
GRAM_CONDITION_LIMIT = 1e4


def singular_values(jac: np.ndarray) -> np.ndarray:
    """Singular values ``(N, min(n, m))`` of a batch of matrices, descending."""
    return np.linalg.svd(np.asarray(jac, dtype=float), compute_uv=False)


def _svd_dexterity(J: np.ndarray) -> np.ndarray:
    sv = singular_values(J)
    with np.errstate(divide='ignore', invalid='ignore'):
        return np.where(sv[..., 0] > 0, sv[..., -1] / sv[..., 0], 0.0)


def zero_line(jac: np.ndarray) -> np.ndarray:
    """True where a row (``m <= n``) or a column (``n <= m``) of an ``m x n`` matrix is exactly zero: its least
    singular value is exactly 0 (rounding left 1e-17 of it for a GSP's D4 row: cond 6.2e16, not singular)."""
    J = np.asarray(jac, dtype=float)
    m, n = J.shape[-2:]
    out = np.zeros(J.shape[:-2], dtype=bool)
    if m <= n:
        out |= np.any(np.all(J == 0, axis=-1), axis=-1)
    if n <= m:
        out |= np.any(np.all(J == 0, axis=-2), axis=-1)
    return out


def dexterity_index(jac: np.ndarray) -> np.ndarray:
    """Dexterity = inverse condition number ``sigma_min / sigma_max`` in ``[0, 1]`` (0 at a singularity, and where
    ``J`` is not finite).

    For tall or square ``J`` the singular values come from the eigenvalues of the Gram matrix ``J^T J``
    (``sigma^2``; about twice as fast as an SVD on small matrices). The Gram matrix squares the condition
    number, so its estimate carries a relative error of about ``eps cond^2``: wherever ``cond`` exceeds
    :data:`GRAM_CONDITION_LIMIT` (or the Gram estimate is not positive) the value is recomputed by an SVD,
    so the result is accurate to ~1e-8 relative everywhere and singularities are resolved to ``eps``; a matrix with
    an exactly zero row or column (:func:`zero_line`) has dexterity 0.
    """
    J = np.asarray(jac, dtype=float)
    broken = ~np.all(np.isfinite(J), axis=(-2, -1)) if J.ndim >= 2 else np.zeros((), dtype=bool)
    if np.any(broken):  # an infinite or undefined Jacobian (a leg of zero length): singular, dexterity 0
        out = np.zeros(J.shape[:-2])
        if not np.all(broken):
            out[~broken] = dexterity_index(J[~broken])
        return out
    if J.ndim < 2:
        return _svd_dexterity(J)
    if J.shape[-2] < J.shape[-1]:
        return np.where(zero_line(J), 0.0, _svd_dexterity(J))
    lam = np.linalg.eigvalsh(np.swapaxes(J, -1, -2) @ J)
    with np.errstate(divide='ignore', invalid='ignore'):
        dex = np.sqrt(np.maximum(lam[..., 0], 0.0) / lam[..., -1])
    redo = ~(np.isfinite(dex) & (lam[..., 0] > 0) & (dex * GRAM_CONDITION_LIMIT > 1.0))
    if np.any(redo):
        dex = np.where(np.isfinite(dex), dex, 0.0)
        dex[redo] = _svd_dexterity(J[redo])
    return np.where(zero_line(J), 0.0, dex)


def condition_number(jac: np.ndarray) -> np.ndarray:
    """2-norm condition number ``sigma_max / sigma_min`` per matrix (``inf`` when ``sigma_min = 0``).

    Computed as ``1 / dexterity_index(jac)`` (Gram eigenvalues, SVD where ill-conditioned).
    """
    dex = dexterity_index(jac)
    with np.errstate(divide='ignore'):
        return np.where(dex > 0, 1.0 / np.where(dex > 0, dex, 1.0), np.inf)


def is_singular(jac: np.ndarray, tol: float = SINGULAR_TOLERANCE) -> np.ndarray:
    """True where the (homogenised) matrix's inverse condition number is below ``tol``."""
    return dexterity_index(jac) < tol

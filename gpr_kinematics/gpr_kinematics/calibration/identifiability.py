"""Identifiability: which parameters, or combinations of them, a set of measured poses can determine.

The weighted identification Jacobian ``J`` (pose residuals divided by their standard deviations, so each row
has unit variance) is scaled by the parameters' a-priori uncertainties ``s_j`` (:attr:`Parameter.scale`):
``J_s = J diag(s)``. In these units the information of the measurements along a unit direction ``v`` of the
parameter space is ``|J_s v|^2``, and the prior's is 1: a singular value ``sigma_i`` of ``J_s`` below 1 means
the poses determine that combination of parameters *less* well than it was known before measuring, so fitting
it would only fit noise (its standard error ``1 / sigma_i`` exceeds the prior uncertainty). Such directions
are **not identifiable** with these poses; ``threshold`` (default 1) sets the bound, and a direction below
``rcond * sigma_max`` is rank-deficient in any case.

For each deficient direction one parameter is **held at its nominal value** and the rest are fitted:
starting from all free parameters, the right singular vector ``v`` of the smallest singular value names the
combination the poses cannot see; the parameter with the largest ``|v_j|`` is held (on a tie within 1 %, the
one listed last: models list frame-like parameters such as a base height after the per-rod ones), and the
analysis repeats on the remaining columns until every singular value passes. This is a backward-elimination
form of subset selection (Golub, Klema & Stewart, *Rank degeneracy and least squares problems*, Stanford report
STAN-CS-76-559, 1976; Golub & Van Loan, *Matrix Computations*, 3rd ed., 1996, §12.2, choose the subset by QR with
column pivoting of the leading right singular vectors instead): the fitted subset is well conditioned, and the
held combination keeps its nominal value instead of a value fitted to noise.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, brief
from ..inputs.validation import plain_number

Array = NDArray[np.float64]

#: Default bound on the scaled singular values (1: the measurements must beat the prior).
DEFAULT_THRESHOLD = 1.0
#: Relative bound below which a singular value is numerically zero.
DEFAULT_RCOND = 1e-9
#: Coefficients of a combination below this fraction of its largest are left out of its description.
DESCRIBE_BELOW = 0.05


@dataclass(frozen=True)
class Combination:
    """A direction of the parameter space the poses cannot determine.

    Attributes:
        singular_value: scaled singular value of the direction when it was found.
        coefficients: parameter name -> coefficient of the direction, in units of each parameter's scale,
            the largest scaled to +-1 (terms below :data:`DESCRIBE_BELOW` left out).
        held: the parameter held for it. held_at: where (``nominal``; a platform joint of a machine far off its
            nominal one: ``its rod's place``, :func:`~.identification.identify`).
    """

    singular_value: float
    coefficients: dict[str, float]
    held: str
    held_at: str = 'nominal'

    def describe(self) -> str:
        """The combination in words, e.g. ``base_z, offset1, offset2, offset3 are not separable: the poses
        cannot see a change of +1 base_z -1 offset1 -1 offset2 -1 offset3 (each in units of its a-priori
        uncertainty; ...)``."""
        names = ', '.join(self.coefficients)
        terms = ' '.join(f'{c:+.2g} {n}' for n, c in self.coefficients.items())
        if len(self.coefficients) == 1:
            return (f'{names} is not identifiable from these poses (scaled singular value '
                    f'{self.singular_value:.3g}); held at {self.held_at}')
        return (f'{names} are not separable: the poses cannot see a change of {terms} (each in units of its a-priori '
                f'uncertainty; scaled singular value {self.singular_value:.3g}); {self.held} held at {self.held_at}')

    def as_dict(self) -> dict[str, Any]:
        return {'singular_value': self.singular_value, 'coefficients': dict(self.coefficients),
                'held': self.held, 'held_at': self.held_at, 'description': self.describe()}


@dataclass(frozen=True)
class Identifiability:
    """Result of :func:`analyse`.

    Attributes:
        names: the parameters analysed (the free ones), in order.
        singular_values: scaled singular values of the Jacobian of all of them, descending.
        threshold: the bound a singular value had to reach (the larger of ``threshold`` and
            ``rcond * sigma_max``).
        identified: the parameters fitted; held: those held, at nominal or where their combination says
            (``held_at``), in the order they were chosen.
        combinations: one :class:`Combination` per held parameter.
        fitted_singular_values: scaled singular values of the identified subset, descending.
    """

    names: tuple[str, ...]
    singular_values: Array
    threshold: float
    identified: tuple[str, ...]
    held: tuple[str, ...]
    combinations: tuple[Combination, ...]
    fitted_singular_values: Array

    @property
    def condition_number(self) -> float:
        """``sigma_max / sigma_min`` of the identified subset (1 for a single parameter; inf for none)."""
        s = self.fitted_singular_values
        return float(s[0] / s[-1]) if s.size else float('inf')

    def as_dict(self) -> dict[str, Any]:
        return {'parameters': list(self.names), 'singular_values': self.singular_values.tolist(),
                'threshold': self.threshold, 'identified': list(self.identified), 'held': list(self.held),
                'combinations': [c.as_dict() for c in self.combinations],
                'fitted_singular_values': self.fitted_singular_values.tolist(),
                'condition_number': self.condition_number if self.fitted_singular_values.size else None}


#: Rows of the blocks of :func:`triangular_factor` (small factorisations: LAPACK runs them in one thread).
QR_BLOCK = 96


def triangular_factor(J_scaled: Array) -> Array:
    """The ``R`` of a QR factorisation of ``J_scaled (m, C)``: ``C x C`` with the same singular values and right
    singular vectors, so later analyses cost ``O(C^3)`` however many rows ``J`` has.

    A tall ``J`` is factorised as a tree of small QR factorisations (TSQR: the ``R`` of blocks of rows, stacked and
    factorised again; Demmel, Grigori, Hoemmen & Langou, *Communication-optimal parallel and sequential QR and LU
    factorizations*, SIAM J. Sci. Comput. 34(1), 2012): orthogonal transformations only, as stable as one QR, and
    each block small enough that the multithreaded LAPACK does not spin threads for it (on a loaded two-core
    machine one QR of a 1200 x 24 matrix took 140 ms that way, its blocks 3 ms).

    >>> J = np.random.default_rng(0).normal(size=(1000, 5))
    >>> bool(np.allclose(np.abs(triangular_factor(J)), np.abs(np.linalg.qr(J, mode='r'))))
    True
    """
    J = np.asarray(J_scaled, dtype=float)
    m, C = J.shape
    if m < C:
        return np.vstack([J, np.zeros((C - m, C))])
    rows = max(QR_BLOCK, 2 * C)
    while J.shape[0] > rows:
        k = -(-J.shape[0] // rows)                        # blocks of at most `rows` rows, padded with zeros
        padded = np.zeros((k * rows, C))
        padded[:J.shape[0]] = J
        blocks: Array = np.linalg.qr(padded.reshape(k, rows, C), mode='r')  # type: ignore[assignment]
        J = blocks.reshape(k * C, C)
    R: Array = np.linalg.qr(J, mode='r')  # type: ignore[assignment]  # mode 'r' returns R alone
    return R


def analyse(J_scaled: Array, names: Sequence[str], threshold: float = DEFAULT_THRESHOLD,
            rcond: float = DEFAULT_RCOND) -> Identifiability:
    """Identifiability of the parameters ``names`` from the scaled, weighted Jacobian ``J_scaled (m, C)``
    (module docstring): singular values, the parameters to hold at nominal and the combinations they stand for.
    """
    if not 0.0 < plain_number(threshold) < math.inf:  # NaN fitted nothing and said nothing
        raise InputError(f'threshold = {brief(threshold)}; allowed: a finite number > 0 (the bound on the scaled '
                         'singular values)')
    names = tuple(names)
    R = triangular_factor(J_scaled)
    s_all = np.linalg.svd(R, compute_uv=False)
    bound = max(float(threshold), rcond * float(s_all[0]) if s_all.size else 0.0)
    keep = list(range(len(names)))
    combos: list[Combination] = []
    s = s_all
    while keep:
        _, s, vt = np.linalg.svd(R[:, keep])
        if s[-1] >= bound:
            break
        v = vt[-1]
        mag = np.abs(v)
        top = np.flatnonzero(mag >= 0.99 * mag.max())[-1]  # ties: the one listed last
        coef = v / v[top]
        terms = {names[keep[j]]: float(coef[j]) for j in np.argsort(-mag, kind='stable')
                 if mag[j] >= DESCRIBE_BELOW * mag[top]}
        combos.append(Combination(float(s[-1]), terms, names[keep[top]]))
        del keep[top]
    return Identifiability(names=names, singular_values=np.asarray(s_all, dtype=float), threshold=bound,
                           identified=tuple(names[k] for k in keep),
                           held=tuple(c.held for c in combos), combinations=tuple(combos),
                           fitted_singular_values=np.asarray(s if keep else np.zeros(0), dtype=float))

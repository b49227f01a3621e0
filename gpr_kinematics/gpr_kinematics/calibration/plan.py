"""Measurement planning: ``N`` configurations that make the identification well conditioned.

Each candidate configuration ``c`` (rod lengths within the stroke, tilt within the limit) contributes the
block ``B_c`` (6 x F) of the weighted, scaled identification Jacobian (:mod:`.identifiability`) of the
identifiable parameters, and a design ``D`` the information ``M(D) = sum_{c in D} B_c^T B_c``, whose eigenvalues
are the squared scaled singular values ``sigma_i`` of the design's Jacobian. Observability indices
(Nahvi & Hollerbach, *The noise amplification index for optimal pose selection in robot calibration*,
IEEE ICRA 1996, which compares them):

* ``product``: ``O1 = (sigma_1 ... sigma_F)^(1/F) / sqrt(N)`` (Borm & Menq, *Determination of optimal
  measurement configurations for robot calibration based on observability measure*, IJRR 10(1), 1991):
  maximising it is D-optimal design (the smallest volume of the parameters' confidence ellipsoid);
* ``smallest``: ``O3 = sigma_F``, the smallest singular value (E-optimal: the worst-determined combination).

The design is built greedily and then improved by exchanges (Fedorov's exchange algorithm, *Theory of Optimal
Experiments*, 1972, in its sequential form): greedy: from ``M = eps I`` add, ``N`` times, the unused candidate
that increases the index most; exchange: for each chosen configuration in turn, remove it and add the unused
candidate that gives the largest index, if that beats keeping it; passes repeat until a pass changes nothing
(at most :data:`MAX_PASSES`); a parameter the chosen design cannot separate is held as well and the design
optimised again for the rest. For ``product``, candidates are ranked by the matrix determinant lemma,
``det(M + B^T B) = det(M) det(I_6 + B M^-1 B^T)``; for ``smallest`` by the eigenvalues of each ``M + B_c^T B_c``.
Parameters that no candidate can identify are held (reported) and left out of the index.

Candidates: the naive inverse (:func:`~gpr_kinematics.core.naive_inverse`) of a grid of heights, tilts
and tilt azimuths, kept when every rod length lies in the stroke; tilts up to :data:`TILT_FRACTION` of the
limit: the real machine, off the nominal geometry, tilts a little more or less at the same rod lengths, and must
stay within its limit where it is measured.
"""
from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core import naive_inverse
from ..core.config import GprConfig
from ..errors import InputError, brief
from ..inputs.validation import random_seed
from .core_model import TILT_MARGIN
from .identifiability import DEFAULT_THRESHOLD, Identifiability, analyse, triangular_factor
from .identification import DEFAULT_SIGMA_ANGLE, DEFAULT_SIGMA_POSITION, check_sigmas, least_rows
from .model import ParameterSet, PoseModel, pose_jacobian, prior_scale
from .tolerances import free_of

Array = NDArray[np.float64]

INDICES = ('product', 'smallest')
#: Largest fraction of the tilt limit a candidate is tilted by: as far inside the limit (5 %, 0.1 deg of 2 deg) as
#: a measured configuration may lie beyond it (:data:`~.core_model.TILT_MARGIN`), so that a machine whose tilt differs
#: from the nominal geometry's by as much stays within its limit at every planned configuration (the tilt of the
#: plane of the joint centres moves by up to ``4 / (3 R)`` rad per metre of zero offsets, ``R`` the radius: 0.1 deg
#: is 122 um at the default radius; 0.80 mrad for the example table's tolerances, worst case).
TILT_FRACTION = 2.0 - TILT_MARGIN
MAX_PASSES = 20
#: Most configurations a plan may ask for, and most candidates.
MAX_PLAN = 10_000
MAX_CANDIDATES = 20_000


@dataclass(frozen=True)
class Candidates:
    """Candidate configurations: rod lengths ``q (C, 3)`` [m] and the naive targets that give them."""

    q: Array
    height: Array
    tilt: Array
    azimuth: Array


def candidate_configurations(config: GprConfig, heights: int = 6, tilts: int = 3, azimuths: int = 12) -> Candidates:
    """A grid of ``heights`` levels over the stroke, the untilted pose and ``tilts`` tilt levels up to
    :data:`TILT_FRACTION` of ``config.tilt_limit`` at ``azimuths`` azimuths each; rows outside the stroke dropped."""
    for name, v, lo in (('heights', heights, 1), ('tilts', tilts, 0), ('azimuths', azimuths, 1)):
        if not (isinstance(v, int) and lo <= v <= 1000):
            raise InputError(f'{name} = {v!r}; allowed: an integer from {lo} to 1000')
    lever = config.radius * np.sin(config.tilt_limit)
    h = np.linspace(config.stroke_min + lever, config.stroke_max - lever, heights) if heights > 1 else \
        np.array([0.5 * (config.stroke_min + config.stroke_max)])
    t_levels = TILT_FRACTION * config.tilt_limit * np.arange(1, tilts + 1) / max(tilts, 1)
    g = 2.0 * np.pi * np.arange(azimuths) / azimuths
    tt = np.concatenate([[0.0], np.repeat(t_levels, azimuths)])
    gg = np.concatenate([[0.0], np.tile(g, tilts)])
    H, T = np.meshgrid(h, tt, indexing='ij')
    G = np.broadcast_to(gg, H.shape)
    H, T, G = H.ravel(), T.ravel(), G.ravel().copy()
    if H.size > MAX_CANDIDATES:
        raise InputError(f'{H.size} candidate configurations; allowed: at most {MAX_CANDIDATES}')
    Q = naive_inverse(H, T, G, config)
    ok = np.all((config.stroke_min <= Q) & (config.stroke_max >= Q), axis=1)
    return Candidates(Q[ok], H[ok], T[ok], G[ok])


@dataclass(frozen=True)
class MeasurementPlan:
    """The planned configurations and their observability.

    Attributes:
        q: rod lengths ``(N, 3)`` [m]; height, tilt, azimuth: the naive targets that give them [m, rad].
        index_name: ``product`` or ``smallest``; index: its value for the plan; random_index: the median over
            :data:`RANDOM_DESIGNS` random designs of the same size from the same candidates (for comparison).
        identifiability: the plan's identifiability analysis (its scaled singular values, what it holds).
        fitted: indices of the parameters the plan identifies; covariance: their covariance ``(F, F)`` (SI) for
            the noise the plan was made for.
        held_indices: the free parameters the plan holds (``(H,)``: free, not fitted); alias: ``(F, H)``, how a
            deviation ``dh`` of the held ones from the value the fit holds them at moves the fitted estimates,
            ``f_true + alias dh`` (Box & Draper, *Empirical model-building and response surfaces*, 1987, sec. 10.2:
            ``A = (J_f' W J_f)^-1 J_f' W J_h`` of the plan's weighted Jacobians, in parameter coordinates).
        candidates: number of candidates; passes: exchange passes run; exchanges: swaps made.
        parameters: the model's parameters (names and units of ``fitted``).
        theta: the parameter coordinates the plan was made at (the Jacobians' linearisation point).
    """

    q: Array
    height: Array
    tilt: Array
    azimuth: Array
    index_name: str
    index: float
    random_index: float
    identifiability: Identifiability
    fitted: NDArray[np.int64]
    covariance: Array
    candidates: int
    passes: int
    exchanges: int
    parameters: ParameterSet
    theta: Array | None = None
    held_indices: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    alias: Array = field(default_factory=lambda: np.zeros((0, 0)))

    def as_dict(self) -> dict[str, Any]:
        """Plain data for JSON: the configurations, the indices, the identifiability, and the predicted standard
        errors of the values (SI), for a stiffness ratio of its anisotropy, with its 1-sigma interval of values in
        ``intervals`` (:meth:`readable`)."""
        names = [self.parameters[int(j)].name for j in self.fitted]
        coord = np.sqrt(np.diag(self.covariance)) if self.fitted.size else np.zeros(0)
        se = [float(c) if self.parameters[int(j)].transform else float(v)
              for j, c, v in zip(self.fitted, coord, self.standard_errors, strict=True)]
        return {'configurations': [{'q': self.q[i].tolist(), 'height': float(self.height[i]),
                                    'tilt': float(self.tilt[i]), 'azimuth': float(self.azimuth[i])}
                                   for i in range(self.q.shape[0])],
                'index_name': self.index_name, 'index': self.index, 'random_index': self.random_index,
                'identifiability': self.identifiability.as_dict(), 'candidates': self.candidates,
                'passes': self.passes, 'exchanges': self.exchanges,
                'standard_errors': dict(zip(names, se, strict=True)),
                'intervals': {n: list(iv) for n, iv in self.intervals().items()}}

    @property
    def at(self) -> Array:
        """The coordinates the plan was made at (:attr:`theta`, else the nominal)."""
        return self.parameters.nominal if self.theta is None else self.theta

    @property
    def standard_errors(self) -> Array:
        """Predicted standard errors of the identified parameters' values (``fitted`` order; a transformed
        parameter's by the delta method at :attr:`at`: meaningless where the transform saturates, use
        :meth:`intervals`), SI."""
        if not self.fitted.size:
            return np.zeros(0)
        slope = self.parameters.value_slopes(self.at)[self.fitted]
        return np.asarray(np.abs(slope) * np.sqrt(np.diag(self.covariance)), dtype=np.float64)

    def intervals(self) -> dict[str, tuple[float, float]]:
        """For each identified transformed parameter (a stiffness ratio), the values at its coordinate plus and minus
        one predicted standard error, within its range: ``kappa`` 0.9 .. 1.1, where the delta method at ``kappa``
        1000 would say 31479."""
        out = {}
        for i, j in enumerate(self.fitted):
            p = self.parameters[int(j)]
            if p.transform:
                u, s = float(self.at[j]), math.sqrt(float(self.covariance[i, i]))
                lo, hi = p.bounds
                out[p.name] = (float(p.value(max(u - s, lo))), float(p.value(min(u + s, hi))))
        return out


#: Random designs drawn for :attr:`MeasurementPlan.random_index`.
RANDOM_DESIGNS = 20


def observability_index(singular_values: Array, rows: int, index: str) -> float:
    """``product``: ``(prod sigma_i)^(1/F) / sqrt(rows)``; ``smallest``: ``sigma_F`` (module docstring)."""
    s = np.asarray(singular_values, dtype=float)
    if s.size == 0:
        return 0.0
    if index == 'product':
        return float(np.exp(np.mean(np.log(np.maximum(s, 1e-300)))) / np.sqrt(rows))
    return float(s.min())


def _log_index(M: Array, index: str) -> Array:
    """``log`` of the index (up to constants) of information matrices ``(..., F, F)``."""
    lam = np.linalg.eigvalsh(M)
    lam = np.maximum(lam, 1e-300)
    return np.asarray(np.mean(np.log(lam), axis=-1) if index == 'product' else np.log(lam[..., 0]), dtype=np.float64)


def _best_addition(M: Array, blocks: Array, infos: Array, allowed: NDArray[np.bool_], index: str) -> tuple[int, float]:
    """The allowed candidate whose information added to ``M`` gives the largest index, and that log index."""
    idx = np.flatnonzero(allowed)
    if index == 'product':
        Minv = np.linalg.inv(M)
        small = np.eye(6) + np.einsum('cif,fg,cjg->cij', blocks[idx], Minv, blocks[idx])
        _, logdet = np.linalg.slogdet(small)
        score = (logdet + np.linalg.slogdet(M)[1]) / M.shape[0]
    else:
        score = _log_index(M[None] + infos[idx], index)
    k = int(np.argmax(score))
    return int(idx[k]), float(score[k])


def _design(J: Array, n: int, index: str, start: list[int]) -> tuple[list[int], int, int]:
    """``n`` rows of the weighted Jacobians ``J (C, 6, F)`` chosen greedily (or from ``start``), then improved by
    exchanges until none raises the ``index``; returns the rows, the exchange passes and the swaps made."""
    C, F = J.shape[0], J.shape[2]
    if not F:
        return list(range(n)), 0, 0
    blocks = np.ascontiguousarray(J)
    infos = np.einsum('cif,cig->cfg', blocks, blocks)
    eps = 1e-9 * float(np.trace(infos.sum(0))) / F / C
    M = eps * np.eye(F)
    used = np.zeros(C, dtype=bool)
    chosen = list(start)
    for c in chosen:
        used[c] = True
        M = M + infos[c]
    while len(chosen) < n:
        c, _ = _best_addition(M, blocks, infos, ~used, index)
        chosen.append(c)
        used[c] = True
        M = M + infos[c]
    passes = exchanges = 0
    while passes < MAX_PASSES:
        passes += 1
        changed = False
        for pos in range(n):
            c_old = chosen[pos]
            current = float(_log_index(M, index))
            M_minus = M - infos[c_old]
            c_new, score = _best_addition(M_minus, blocks, infos, ~used, index) if (~used).any() else (c_old, -np.inf)
            if score > current + 1e-12 * abs(current) + 1e-12:
                chosen[pos] = c_new
                used[c_old], used[c_new] = False, True
                M = M_minus + infos[c_new]
                exchanges += 1
                changed = True
        if not changed:
            break
    return chosen, passes, exchanges


def _check_something_to_fit(fit: list[str], threshold: float, source: str, allowed: str) -> None:
    """InputError when no parameter reaches ``threshold``: there is nothing to design a plan for."""
    if not fit:
        raise InputError(f'no parameter can be determined to the threshold {threshold:g} {source}; allowed: {allowed}')


def plan_measurements(model: PoseModel, config: GprConfig, n: int, index: str = 'product',
                      free: Iterable[str] | None = None, sigma_position: float = DEFAULT_SIGMA_POSITION,
                      sigma_angle: float = DEFAULT_SIGMA_ANGLE, candidates: Candidates | None = None,
                      threshold: float = DEFAULT_THRESHOLD, seed: int = 0,
                      prior: ArrayLike | None = None, theta: ArrayLike | None = None,
                      points: bool = False) -> MeasurementPlan:
    """Choose ``n`` of the ``candidates`` (default :func:`candidate_configurations` of ``config``) that maximise
    the observability ``index`` for the parameters ``free`` of ``model`` (module docstring); ``prior``: the
    a-priori standard deviations scaling the Jacobian, as in :func:`~.identification.identify`; ``theta``: the
    coordinates the Jacobians are taken at (default nominal; with a tolerance table, where its tolerances are:
    :func:`~.tolerances.centre_of`); ``points``: the configurations will be measured as points (positions only:
    a reflector), so orientations give no information.

    Raises:
        InputError: ``n`` outside ``[1, number of candidates]`` or above :data:`MAX_PLAN`; unknown index or
            parameter; bad sigmas; a ``threshold`` no parameter reaches even with every candidate.
    """
    if index not in INDICES:
        raise InputError(f'observability index {index!r}; allowed: {", ".join(INDICES)}')
    check_sigmas(sigma_position, sigma_angle)
    seed = random_seed(seed)
    cand = candidates if candidates is not None else candidate_configurations(config)
    C = cand.q.shape[0]
    params = model.parameters
    free_idx = np.flatnonzero(free_of(params, free, prior)).astype(np.int64)   # a tolerance of 0: fixed
    k = 3 if points else 6
    least = least_rows(free_idx.size, k)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n > min(C, MAX_PLAN):
        raise InputError(f'plan size {brief(n)}; allowed: an integer from {least} to {min(C, MAX_PLAN)} (the fewest '
                         f'that identify {free_idx.size} parameters, the number of candidate configurations within the '
                         f'stroke and tilt limits is {C})')
    if n < least:   # gpr calibrate refuses the file measured at such a plan
        raise InputError(f'plan size {brief(n)}: {n} configuration(s) measured as {"points" if points else "poses"} '
                         f'give {k * n} residuals, too few to identify {free_idx.size} parameters (gpr calibrate '
                         f'refuses a file of so few rows); allowed: at least {least}')
    theta0 = params.nominal if theta is None else np.asarray(theta, dtype=float)
    scale = prior_scale(params, prior)
    w = np.array([1.0 / sigma_position] * 3 + [0.0 if points else 1.0 / sigma_angle] * 3)
    J = pose_jacobian(model, theta0, cand.q, free_idx) * w[None, :, None] * scale[free_idx]  # (C, 6, F)
    names = [params[int(j)].name for j in free_idx]
    # Optimise the design for the parameters the candidates can identify. If the design cannot separate one of
    # them (it falls below the threshold), hold it too and optimise again for the rest: the set only shrinks, so
    # this ends, and the plan is a local optimum of the exchange for exactly the parameters it reports as fitted.
    ident = analyse(J.reshape(-1, free_idx.size), names, threshold)
    combos = list(ident.combinations)
    fit = list(ident.identified)
    _check_something_to_fit(fit, threshold, f'even from all {C} candidate configurations', 'a lower threshold')
    chosen: list[int] = []
    passes = exchanges = 0
    while True:
        keep = [names.index(nm) for nm in fit]
        chosen, p, e = _design(J[:, :, keep], n, index, chosen)
        passes, exchanges = passes + p, exchanges + e
        ident = analyse(J[np.array(chosen)][:, :, keep].reshape(-1, len(keep)), fit, threshold)
        combos += ident.combinations
        if list(ident.identified) == fit:
            break
        fit = list(ident.identified)
        _check_something_to_fit(fit, threshold, f'from the {n} configurations chosen',
                                'a lower threshold or a larger plan')
    sel = np.array(chosen)
    Jp = J[sel].reshape(-1, free_idx.size)
    s_all = np.asarray(np.linalg.svd(triangular_factor(Jp), compute_uv=False), dtype=np.float64)
    ident = replace(ident, names=tuple(names), singular_values=s_all,
                    held=tuple(c.held for c in combos), combinations=tuple(combos))
    fit_cols = [names.index(nm) for nm in fit]
    fitted = free_idx[fit_cols]
    held_cols = [c for c in range(free_idx.size) if c not in set(fit_cols)]
    held = free_idx[held_cols]
    cov, alias = np.zeros((0, 0)), np.zeros((len(fit_cols), len(held_cols)))
    if fit_cols:
        _, s, vt = np.linalg.svd(triangular_factor(Jp[:, fit_cols]))
        cov = (vt.T / s ** 2) @ vt * np.outer(scale[fitted], scale[fitted])
        if held_cols:   # the least-squares fit of the fitted columns to the held ones, unscaled to coordinates
            alias = np.linalg.lstsq(Jp[:, fit_cols], Jp[:, held_cols], rcond=None)[0] * \
                np.outer(scale[fitted], 1.0 / scale[held])
    value = observability_index(ident.fitted_singular_values, n, index)
    rng = np.random.default_rng(seed)
    rand = []
    for _ in range(RANDOM_DESIGNS):
        pick = rng.choice(C, size=n, replace=False)
        design = J[pick][:, :, fit_cols].reshape(-1, len(fit_cols))
        sv = np.asarray(np.linalg.svd(triangular_factor(design), compute_uv=False), dtype=np.float64) if fit_cols \
            else np.zeros(0)
        rand.append(observability_index(sv, n, index))
    return MeasurementPlan(q=cand.q[sel], height=cand.height[sel], tilt=cand.tilt[sel], azimuth=cand.azimuth[sel],
                           index_name=index, index=value, random_index=float(np.median(rand)),
                           identifiability=ident, fitted=fitted, covariance=cov, candidates=C, passes=passes,
                           exchanges=exchanges, parameters=params, theta=theta0, held_indices=held, alias=alias)

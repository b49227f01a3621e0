"""Identification of geometric parameters from measured platform poses: weighted nonlinear least squares.

For measurements ``i = 1..N`` (rod lengths ``q_i``, measured pose ``(p_i, R_i)``) and a pose model with
parameters ``theta``, the residual of row ``i`` is the 6-vector

    r_i(theta) = ( (p(theta, q_i) - p_i) / sigma_p,i ,  phi(R(theta, q_i) R_i^T) / sigma_a,i )

(metres and radians divided by the row's standard deviations: unit variance), ``phi`` the rotation vector.
``theta`` minimises ``sum_i |r_i|^2`` over the free, identifiable parameters (:mod:`.identifiability`); the
others stay at their nominal values. The minimiser is Levenberg-Marquardt in the scaled coordinates
``theta_j / s_j`` (Nocedal & Wright, *Numerical Optimization*, 2nd ed., §10.3), with the Jacobian of the
residuals by central differences (:func:`~.model.pose_jacobian`, exact for Gauss-Newton to ``O(h^2)``).

Standard errors come from the covariance ``C = (J^T J)^-1`` at the solution (Gauss-Newton approximation of the
inverse Hessian). With standard deviations from the file (both sigma columns) ``C`` is absolute; otherwise the
defaults only weight position against angle, and ``C`` is multiplied by the reduced chi-square
``chi2 / (6N - F)`` (the usual estimate of the unknown noise scale).
"""
from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ConvergenceError, InputError
from .identifiability import DEFAULT_THRESHOLD, Identifiability, analyse, triangular_factor
from .measurements import SIGMA_RANGE, Measurements
from .model import ParameterSet, PoseModel, evaluate, pose_error, pose_jacobian, prior_scale

Array = NDArray[np.float64]

#: Default standard deviation of a measured position coordinate [m] (a laser tracker's 6-DOF probe).
DEFAULT_SIGMA_POSITION = 5e-6
#: Default standard deviation of a measured rotation-vector component [rad].
DEFAULT_SIGMA_ANGLE = 2e-5
#: A measured pose farther than this from the nominal model's is not a measurement of this machine in
#: ``gpr_base`` (wrong units, wrong frame, wrong row): [m] and [rad].
PLAUSIBLE_POSITION = 0.01
PLAUSIBLE_ANGLE = 0.05
#: Levenberg-Marquardt stops when the largest step is below this, in units of the parameters' scales.
STEP_TOLERANCE = 1e-9
#: ... or when a step is below this fraction of every parameter's standard error (statistically nothing: the
#: model's rounding, ~1e-15 m, moves a fit of micrometre-noise data by ~1e-9 standard errors) ...
SE_TOLERANCE = 1e-4
#: ... or when a step below 1e-5 scales lowers the cost by less than this fraction.
COST_TOLERANCE = 1e-12
MAX_ITERATIONS = 40
#: Largest reduced chi-square of a fit to measurements with their own standard deviations: beyond it the residuals
#: are 100 times the stated noise, and no geometry of this machine explains the poses.
MAX_CHI2 = 1e4
NOT_THIS_MACHINE = ('not measurements of this machine in the declared units (lengths in other units than the file\'s '
                    '"# units:" line says, m by default? a measured frame other than gpr_platform in gpr_base?)')


@dataclass(frozen=True)
class ResidualStats:
    """Pose residuals of a set of measurements: RMS and worst of ``|p - p_meas|`` [m] and of the rotation
    angle between predicted and measured orientation [rad], with the file lines of the worst."""

    rms_position: float
    max_position: float
    rms_angle: float
    max_angle: float
    worst_position_line: int
    worst_angle_line: int

    @staticmethod
    def of(errors: Array, lines: tuple[int, ...]) -> ResidualStats:
        """From pose errors ``(N, 6)`` (:func:`~.model.pose_error`)."""
        dp = np.linalg.norm(errors[:, :3], axis=1)
        da = np.linalg.norm(errors[:, 3:], axis=1)
        return ResidualStats(float(np.sqrt(np.mean(dp ** 2))), float(dp.max()), float(np.sqrt(np.mean(da ** 2))),
                             float(da.max()), lines[int(np.argmax(dp))], lines[int(np.argmax(da))])

    def as_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


@dataclass(frozen=True)
class CalibrationResult:
    """Identified parameters with standard errors, residuals before and after, identifiability.

    Attributes:
        parameters: the model's parameters (order of every array here).
        estimate: identified coordinates (nominal for held and fixed parameters), SI: the values, except a
            transformed parameter's coordinate (a stiffness ratio's anisotropy, :class:`~.model.Parameter`);
            :attr:`values` has the values.
        standard_error: standard errors of the fitted coordinates (``nan`` for held and fixed ones);
            :attr:`value_standard_error` those of the values.
        status: per parameter ``fitted``, ``held`` (free, but the poses cannot identify it) or ``fixed``
            (not asked for).
        fitted: indices of the fitted parameters; covariance: their covariance ``(F, F)``, SI.
        before, after: residuals with the nominal and with the identified parameters.
        identifiability: the analysis that chose what to fit.
        chi2_reduced: ``sum |r|^2 / (6N - F)`` at the solution (about 1 when the sigmas are right).
        absolute_sigma: the file gave the standard deviations (the covariance is not rescaled).
        iterations: Levenberg-Marquardt iterations; rows: number of measurements; source: their file.
    """

    parameters: ParameterSet
    estimate: Array
    standard_error: Array
    status: tuple[str, ...]
    fitted: NDArray[np.int64]
    covariance: Array
    before: ResidualStats
    after: ResidualStats
    identifiability: Identifiability
    chi2_reduced: float
    absolute_sigma: bool
    iterations: int
    rows: int
    source: str

    @property
    def values(self) -> Array:
        """Identified values (the estimate's coordinates turned into values: ``kappa`` from its anisotropy)."""
        return self.parameters.values(self.estimate)

    @property
    def value_standard_error(self) -> Array:
        """Standard errors of the values (the delta method, ``|d value / d coordinate|`` times the coordinate's)."""
        return np.abs(self.parameters.value_slopes(self.estimate)) * self.standard_error

    @property
    def correlation(self) -> Array:
        """Correlation matrix of the fitted parameters."""
        d = np.sqrt(np.diag(self.covariance))
        return np.asarray(self.covariance / np.outer(d, d), dtype=np.float64)

    def as_dict(self) -> dict[str, Any]:
        """Plain data for JSON: per parameter its value (``nominal``, ``estimate``, ``change``, ``standard_error``;
        ``None`` where not fitted) and, for a transformed one, the same of its ``coordinate``."""
        params = []
        nominal, values, se_v = self.parameters.values(self.parameters.nominal), self.values, self.value_standard_error
        for j, p in enumerate(self.parameters):
            se = self.standard_error[j]
            entry = {'name': p.name, 'unit': p.unit, 'nominal': float(nominal[j]), 'estimate': float(values[j]),
                     'change': float(values[j] - nominal[j]),
                     'standard_error': float(se_v[j]) if math.isfinite(se) else None, 'status': self.status[j]}
            if p.transform:
                entry['coordinate'] = {'name': p.transform, 'nominal': p.nominal, 'estimate': float(self.estimate[j]),
                                       'standard_error': float(se) if math.isfinite(se) else None}
            params.append(entry)
        return {'source': self.source, 'rows': self.rows, 'parameters': params,
                'residuals': {'before': self.before.as_dict(), 'after': self.after.as_dict()},
                'identifiability': self.identifiability.as_dict(), 'chi2_reduced': self.chi2_reduced,
                'absolute_sigma': self.absolute_sigma, 'iterations': self.iterations,
                'fitted': [self.parameters[j].name for j in self.fitted],
                'correlation': self.correlation.tolist()}


def check_sigmas(sigma_position: float, sigma_angle: float) -> None:
    """Refuse standard deviations outside :data:`~.measurements.SIGMA_RANGE` (m, rad)."""
    lo, hi = SIGMA_RANGE
    for name, v in (('sigma_position', sigma_position), ('sigma_angle', sigma_angle)):
        if isinstance(v, bool) or not (isinstance(v, (int, float)) and lo <= v <= hi):
            raise InputError(f'{name} = {v!r}; allowed: a standard deviation from {lo:g} to {hi:g} (m, rad)')


def _sigmas(meas: Measurements, sigma_position: float, sigma_angle: float) -> tuple[Array, Array, bool]:
    check_sigmas(sigma_position, sigma_angle)
    n = len(meas)
    sp = meas.sigma_position if meas.sigma_position is not None else np.full(n, float(sigma_position))
    sa = meas.sigma_angle if meas.sigma_angle is not None else np.full(n, float(sigma_angle))
    return sp, sa, meas.sigma_position is not None and meas.sigma_angle is not None


def _check_plausible(meas: Measurements, errors: Array) -> None:
    dp = np.linalg.norm(errors[:, :3], axis=1)
    da = np.linalg.norm(errors[:, 3:], axis=1)
    bad = np.flatnonzero((dp > PLAUSIBLE_POSITION) | (da > PLAUSIBLE_ANGLE))
    if bad.size:
        i = int(bad[0])
        raise InputError(f'{meas.where(i)}: the measured pose is {dp[i]:.4g} m and {da[i]:.4g} rad from the nominal '
                         f'model\'s (allowed: {PLAUSIBLE_POSITION} m, {PLAUSIBLE_ANGLE} rad): not a pose of '
                         'gpr_platform in gpr_base in SI units (millimetres? declare "# units: mm")')


def identify(model: PoseModel, meas: Measurements, free: Iterable[str] | None = None,
             sigma_position: float = DEFAULT_SIGMA_POSITION, sigma_angle: float = DEFAULT_SIGMA_ANGLE,
             threshold: float = DEFAULT_THRESHOLD, prior: ArrayLike | None = None) -> CalibrationResult:
    """Identify the parameters ``free`` (names or configuration keys; all by default) of ``model`` from ``meas``.

    ``sigma_position`` [m] and ``sigma_angle`` [rad] weight rows without sigma columns; ``threshold`` bounds the
    scaled singular values of the identifiable directions (:mod:`.identifiability`); ``prior`` gives the
    a-priori standard deviations that scale them (:func:`~.model.prior_scale`: a tolerance table's, or the
    parameters' scales).

    Raises:
        InputError: too few rows for the free parameters, a pose implausibly far from the nominal model, a bad
            sigma, an unknown parameter name.
        ConvergenceError: Levenberg-Marquardt did not converge in :data:`MAX_ITERATIONS` iterations.
    """
    params = model.parameters
    mask = params.select(free)
    n_free = int(mask.sum())
    n = len(meas)
    if 6 * n <= n_free:
        raise InputError(f'{meas.source}: {n} row(s) give {6 * n} residuals, too few to identify {n_free} '
                         f'parameters; at least {n_free // 6 + 1} rows are needed (more for a useful fit)')
    sp, sa, absolute = _sigmas(meas, sigma_position, sigma_angle)
    w = np.column_stack([np.repeat(1.0 / sp[:, None], 3, 1), np.repeat(1.0 / sa[:, None], 3, 1)])  # (N, 6)
    ref = (meas.position, meas.rotation)
    theta0 = params.nominal
    scale = prior_scale(params, prior)

    def errors(theta: Array) -> Array:
        pos, rot = evaluate(model, theta, meas.q)
        return pose_error(pos, rot, ref[0], ref[1])

    def weighted_jacobian(theta: Array, cols: NDArray[np.int64]) -> Array:
        J = pose_jacobian(model, theta, meas.q, cols, reference=ref) * w[:, :, None]
        return J.reshape(6 * n, cols.size) * scale[cols]

    e0 = errors(theta0)
    _check_plausible(meas, e0)
    free_idx = np.flatnonzero(mask).astype(np.int64)
    ident = analyse(weighted_jacobian(theta0, free_idx), [params[int(j)].name for j in free_idx], threshold)
    fit = np.array([params.index(name) for name in ident.identified], dtype=np.int64)
    try:
        theta, e, iterations = _levenberg_marquardt(errors, weighted_jacobian, theta0, fit, w, scale, params.bounds)
    except InputError as exc:   # the fit took the geometry to the edge of what a machine file allows
        raise InputError(f'{meas.source}: the fit moved the geometry out of its allowed ranges ({exc}): '
                         f'{NOT_THIS_MACHINE}') from None
    F = fit.size
    chi2 = float(np.sum((e * w) ** 2))
    dof = 6 * n - F
    chi2_red = chi2 / dof
    if absolute and chi2_red > MAX_CHI2:
        raise InputError(f'{meas.source}: the best fit leaves residuals {math.sqrt(chi2_red):.3g} times the standard '
                         f'deviations of the file (reduced chi-square {chi2_red:.3g}; allowed: at most {MAX_CHI2:g}): '
                         f'{NOT_THIS_MACHINE}, or sigma columns far too small')
    cov = np.zeros((0, 0))
    se = np.full(len(params), np.nan)
    if F:
        Js = weighted_jacobian(theta, fit)
        _, s, vt = np.linalg.svd(triangular_factor(Js))
        cov_scaled = (vt.T / s ** 2) @ vt
        cov = cov_scaled * np.outer(scale[fit], scale[fit]) * (1.0 if absolute else chi2_red)
        se[fit] = np.sqrt(np.diag(cov))
    held = set(ident.held)
    status = tuple('fitted' if j in set(fit.tolist()) else 'held' if p.name in held else 'fixed'
                   for j, p in enumerate(params))
    return CalibrationResult(parameters=params, estimate=theta, standard_error=se, status=status, fitted=fit,
                             covariance=cov, before=ResidualStats.of(e0, meas.lines),
                             after=ResidualStats.of(e, meas.lines), identifiability=ident, chi2_reduced=chi2_red,
                             absolute_sigma=absolute, iterations=iterations, rows=n, source=meas.source)


def _levenberg_marquardt(errors: Any, weighted_jacobian: Any, theta0: Array, fit: NDArray[np.int64], w: Array,
                         scale: Array, bounds: tuple[Array, Array]) -> tuple[Array, Array, int]:
    """Minimise ``|errors(theta) * w|^2`` over ``theta[fit]`` from ``theta0``; returns ``(theta, errors, steps)``.

    Steps solve ``(J_s^T J_s + lam D) d = -J_s^T r`` in scaled coordinates (``D`` the diagonal of ``J_s^T J_s``,
    Marquardt's scaling); ``lam`` shrinks tenfold after a step that lowers the cost and grows tenfold after one
    that does not, or that leaves the coordinates' open ``bounds`` (``(P,)`` lowest, highest).
    """
    theta = theta0.copy()
    e = errors(theta)
    if fit.size == 0:
        return theta, e, 0
    cost = float(np.sum((e * w) ** 2))
    lam = 1e-6
    lower, upper = bounds[0][fit], bounds[1][fit]
    for it in range(1, MAX_ITERATIONS + 1):
        Js = weighted_jacobian(theta, fit)
        r = (e * w).ravel()
        A = Js.T @ Js
        g = Js.T @ r
        D = np.diag(np.diag(A))
        while True:
            d = np.linalg.solve(A + lam * D, -g)
            trial = theta.copy()
            trial[fit] += d * scale[fit]
            cost_t = math.inf   # outside a coordinate's range or the model's domain (a degenerate geometry): failed
            if not (np.any(trial[fit] <= lower) or np.any(trial[fit] >= upper)):
                try:
                    e_t = errors(trial)
                    cost_t = float(np.sum((e_t * w) ** 2))
                except InputError:          # the model refuses the trial's parameters (they changed, not the data)
                    pass
            if cost_t <= cost or (np.max(np.abs(d)) < STEP_TOLERANCE and math.isfinite(cost_t)):
                break
            lam *= 10.0
            if lam > 1e12:
                raise ConvergenceError(f'identification stalled after {it} iterations (cost {cost:.6g}); the '
                                       'measurements do not fit this model')
        gain = cost - cost_t
        theta, e, cost = trial, e_t, cost_t
        lam = max(lam / 10.0, 1e-12)
        step = float(np.max(np.abs(d)))
        # Converged: a step far below the parameters' standard errors (sqrt of the diagonal of (J^T J)^-1 in these
        # scaled units), or one that no longer lowers the cost (rounding of the model: its last digits make tiny
        # steps wander without changing the fit).
        se = np.sqrt(np.maximum(np.diag(np.linalg.pinv(A)), 0.0))
        if step < STEP_TOLERANCE or float(np.max(np.abs(d) / np.maximum(se, 1e-300))) < SE_TOLERANCE \
                or (step < 1e-5 and gain <= COST_TOLERANCE * cost):
            return theta, e, it
    raise ConvergenceError(f'identification did not converge in {MAX_ITERATIONS} iterations (last step '
                           f'{np.max(np.abs(d)):.3g} parameter scales)')

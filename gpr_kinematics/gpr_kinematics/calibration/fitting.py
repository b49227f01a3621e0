"""Weighted nonlinear least squares for the calibrations: a bounded Levenberg-Marquardt from several starts, and the
diagnostics that say whether it reached a minimum.

A *problem* is a function ``residuals(theta) -> r``: for parameter coordinate rows ``theta (S, P)`` the weighted
residual blocks ``r (S, N, k)``, one block per measured row (``k = 6`` for a measured pose, 3 for a measured point),
every entry divided by its standard deviation. The engine minimises ``|r(theta)|^2`` over the coordinates ``fit``
in the scaled coordinates ``theta_j / s_j`` (``s`` the a-priori uncertainties; Nocedal & Wright, *Numerical
Optimization*, 2nd ed., 2006, §10.3, with Marquardt's diagonal scaling). Its Jacobian is by central differences
(:meth:`~.model.ParameterSet.steps`: all ``2 C`` perturbed rows in one call of ``residuals``).

**Bounds** (a stiffness ratio's anisotropy in ``(-1, 1)``): a trial step is projected into the range (not refused),
and a coordinate at a bound whose gradient points out of the range is *active*: left out of the next step
(the projected Levenberg-Marquardt method of Kanzow, Yamashita & Fukushima, *Levenberg-Marquardt methods with
strong local convergence properties for solving nonlinear equations with convex constraints*, J. Comput. Appl.
Math. 172, 2004). Refusing such steps instead let the damping grow until the steps were too small to matter and
the fit stopped far from the minimum.

**Converged** means: at the point returned, the undamped Gauss-Newton step over the coordinates that are not
active is below :data:`SE_TOLERANCE` of their standard errors (statistically nothing), or below
:data:`STEP_TOLERANCE` a-priori scales. The *damped* step is never the test (a large damping makes it small far
from any minimum). When no step lowers the cost any more while the Gauss-Newton step is still large, the fit
*stalled*; after :data:`MAX_ITERATIONS` it *ran out of iterations*; both are reported, not raised.

**Starts** (:func:`minimise`): the fit runs from each start (the nominal parameters, and for the stiffness ratios
isotropic joints as well: a minimum the nominal start misses shows as a lower cost from the other); the start
that ends at the lowest cost wins, one whose model could be evaluated about its end before one that could not.
A start after the first gets :data:`OTHER_START_ITERATIONS` iterations.

**Progress**: a listener ``progress(stage, share)`` (the one of :func:`~gpr_kinematics.safety.check.check_program`,
shown by :mod:`gpr_kinematics.cli.progress`) hears each Jacobian's share done after each call of the model, in the
stage ``fit from <start>: iteration k, reduced chi-square c`` (the point it linearises at: iteration 0 the start).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..callbacks import StageProgress
from ..errors import ConvergenceError, InputError
from .identifiability import triangular_factor
from .model import ParameterSet

Array = NDArray[np.float64]
Residuals = Callable[[Array], Array]
#: A fit's listener: the iteration, the cost ``|r|^2`` at the point it linearises at, the share of its Jacobian done.
IterationProgress = Callable[[int, float, float], None]

MAX_ITERATIONS = 60
#: Iterations of a start after the first (an insurance: from a start near the first's minimum it converges in a
#: few; one that wanders costs no more than this).
OTHER_START_ITERATIONS = 25
#: Converged when the Gauss-Newton step left is below this fraction of every standard error ...
SE_TOLERANCE = 1e-4
#: ... or below this many a-priori scales.
STEP_TOLERANCE = 1e-9
#: A fit that can no longer lower the cost (rounding of the model) counts as converged when the Gauss-Newton step
#: left is below this fraction of a standard error.
STALL_SE = 1e-2
#: Largest damping before a fit counts as stalled.
MAX_DAMPING = 1e12
#: Residuals evaluated in one call of the model for a Jacobian (200,000 poses): a file of 100,000 rows needs
#: 4,800,000 perturbed poses for 24 parameters, which at once took ~1.5 kB each (7 GB); in chunks about 0.3 GB.
JACOBIAN_RESIDUALS = 1_200_000
#: How a fit ended: at a minimum; no step lowers the cost while the Gauss-Newton step is large; out of iterations;
#: the model cannot be evaluated about the point reached (its Jacobian: a machine the core cannot close).
STATUSES = ('converged', 'stalled', 'iterations', 'undefined')


def _differences(r: Array, h: Array) -> Array:
    """The central differences ``(C, N k)`` of the residuals ``r (2 C, N, k)`` of ``C`` pairs of rows ``+h, -h``."""
    return (r[0::2] - r[1::2]).reshape(h.size, -1) / h[:, None]


def residual_jacobian(residuals: Residuals, params: ParameterSet, theta: Array, cols: NDArray[np.int64],
                      scale: Array, progress: Callable[[float], None] | None = None) -> Array:
    """``d r / d (theta_j / s_j)`` ``(N k, C)`` for the coordinates ``cols`` at ``theta``, by central differences
    with each parameter's step (one-sided at a bound: :meth:`~.model.ParameterSet.steps`); ``progress`` hears the
    share of the columns done after each call of the model."""
    if cols.size == 0:
        r = residuals(theta[None])[0]
        return np.zeros((r.size, 0))
    up, down = (s[cols] for s in params.steps(theta))
    rows = np.repeat(theta[None, :], 2 * cols.size, axis=0)
    k = np.arange(cols.size)
    rows[2 * k, cols] += up
    rows[2 * k + 1, cols] -= down
    per = max(1, JACOBIAN_RESIDUALS // (2 * residuals(theta[None]).size))   # columns per call of the model
    parts = []
    for a in range(0, cols.size, per):
        parts.append(_differences(residuals(rows[2 * a:2 * (a + per)]), (up + down)[a:a + per]))
        if progress is not None:
            progress(min(a + per, cols.size) / cols.size)
    d = np.vstack(parts)
    return np.ascontiguousarray(d.T * scale[cols])


@dataclass(frozen=True)
class Minimum:
    """Where a fit ended.

    Attributes:
        theta: coordinates ``(P,)``; residual: weighted residual blocks ``(N, k)`` there; cost: ``|residual|^2``.
        iterations: Levenberg-Marquardt iterations; status: one of :data:`STATUSES`.
        at_bound: ``(P,)`` the coordinate ended at a bound of its range (an active constraint).
        step_se: the Gauss-Newton step left at ``theta`` (over the coordinates not at a bound), in standard errors
            (its largest component; 0 when nothing is fitted).
        label: the start it came from.
    """

    theta: Array
    residual: Array
    cost: float
    iterations: int
    status: str
    at_bound: NDArray[np.bool_]
    step_se: float
    label: str = ''

    @property
    def converged(self) -> bool:
        return self.status == 'converged'


def gram(J: Array) -> Array:
    """``J^T J`` through the triangular factor of ``J`` (:func:`~.identifiability.triangular_factor`: small blocks,
    which a multithreaded BLAS on a loaded machine does not slow down)."""
    R = triangular_factor(J)
    return np.asarray(R.T @ R, dtype=np.float64)


def _gauss_newton(J: Array, r: Array, active: NDArray[np.bool_]) -> tuple[Array, Array, Array, Array]:
    """``A = J^T J``, ``g = J^T r``, the undamped step over the inactive columns and their standard errors."""
    A, g = gram(J), np.einsum('mi,m->i', J, r)
    free = ~active
    Ainv = np.linalg.pinv(A[np.ix_(free, free)])
    d = np.zeros(g.size)
    d[free] = -Ainv @ g[free]
    se = np.full(g.size, np.inf)
    se[free] = np.sqrt(np.maximum(np.diag(Ainv), 1e-300))
    return A, g, d, se


@dataclass(frozen=True)
class _Linear:
    """The fit linearised at a point: coordinates, residuals, cost, the Gauss-Newton system over ``fit`` (with the
    coordinates active at a bound), the undamped step in standard errors."""

    theta: Array
    r: Array
    cost: float
    A: Array
    g: Array
    active: NDArray[np.bool_]
    step_se: float
    small: bool


def _linearise(residuals: Residuals, params: ParameterSet, theta: Array, r: Array, fit: NDArray[np.int64],
               scale: Array, progress: Callable[[float], None] | None = None) -> _Linear | None:
    """:class:`_Linear` at ``theta``, or ``None`` where the model cannot be evaluated about it."""
    try:
        J = residual_jacobian(residuals, params, theta, fit, scale, progress)
    except (InputError, ConvergenceError):
        return None
    lower, upper = (b[fit] for b in params.bounds)
    th = theta[fit]
    g0 = np.einsum('mi,m->i', J, r.ravel())
    active = ((th <= lower) & (g0 > 0.0)) | ((th >= upper) & (g0 < 0.0))
    A, g, gn, se = _gauss_newton(J, r.ravel(), active)
    return _Linear(theta, r, float(np.sum(r * r)), A, g, active, float(np.max(np.abs(gn) / se)),
                   float(np.max(np.abs(gn))) < STEP_TOLERANCE)


def _step(residuals: Residuals, lin: _Linear, fit: NDArray[np.int64], scale: Array, bounds: tuple[Array, Array],
          lam: float) -> tuple[Array, Array, float, float] | None:
    """The damped step from ``lin`` that lowers the cost, with the damping it took (``None``: none does)."""
    free = ~lin.active
    D = np.diag(lin.A) + 1e-300
    Aff, Dff, gf = lin.A[np.ix_(free, free)], D[free], lin.g[free]
    th = lin.theta[fit]
    while lam <= MAX_DAMPING:
        d = np.zeros(fit.size)
        d[free] = np.linalg.solve(Aff + lam * np.diag(Dff), -gf)
        trial = lin.theta.copy()
        trial[fit] = np.clip(th + d * scale[fit], bounds[0], bounds[1])
        try:
            r_t = residuals(trial[None])[0]
            cost_t = float(np.sum(r_t * r_t))
        except (InputError, ConvergenceError):  # the model refuses the trial's parameters, or cannot close the
            cost_t = math.inf                     # machine they make (they changed, not the data)
        if cost_t < lin.cost:
            return trial, r_t, cost_t, lam
        lam *= 10.0
    return None


def levenberg_marquardt(residuals: Residuals, params: ParameterSet, theta0: Array, fit: NDArray[np.int64],
                        scale: Array, label: str = '', max_iterations: int | None = None,
                        progress: IterationProgress | None = None) -> Minimum:
    """Minimise ``|residuals(theta)|^2`` over ``theta[fit]`` from ``theta0`` (module docstring); ``progress``
    hears each linearisation's iteration, cost and share of its Jacobian done.

    A trial the model refuses (an :class:`InputError`: a degenerate geometry) or cannot evaluate (a
    :class:`ConvergenceError`: no closure for that machine) counts as a failed step, and so does one about which
    the Jacobian cannot be evaluated (the damping grows and the step shrinks).
    """
    bounds = tuple(b[fit] for b in params.bounds)
    theta = np.array(theta0, dtype=float)
    r = residuals(theta[None])[0]
    cost = float(np.sum(r * r))
    at = np.zeros(len(params), dtype=bool)
    if fit.size == 0:
        return Minimum(theta, r, cost, 0, 'converged', at, 0.0, label)
    def told(it: int, cost: float) -> Callable[[float], None] | None:
        return None if progress is None else (lambda share: progress(it, cost, share))

    lin = _linearise(residuals, params, theta, r, fit, scale, told(0, cost))
    if lin is None:
        return Minimum(theta, r, cost, 0, 'undefined', at, math.inf, label)
    lam, status, it = 1e-6, 'iterations', 0
    while it < (MAX_ITERATIONS if max_iterations is None else max_iterations):
        it += 1
        if lin.step_se < SE_TOLERANCE or lin.small:
            status = 'converged'
            break
        step = _step(residuals, lin, fit, scale, (bounds[0], bounds[1]), lam)
        if step is None:   # no step lowers the cost: rounding of the model near a minimum, or a stall
            status = 'converged' if lin.step_se < STALL_SE else 'stalled'
            break
        trial, r_t, cost_t, lam = step
        nxt = _linearise(residuals, params, trial, r_t, fit, scale, told(it, cost_t))
        if nxt is None:    # a point the model cannot be evaluated about: a shorter step from here
            lam *= 100.0
            continue
        lin, lam = nxt, max(lam / 10.0, 1e-12)
    at[fit] = (lin.theta[fit] <= bounds[0]) | (lin.theta[fit] >= bounds[1])
    return Minimum(lin.theta, lin.r, lin.cost, it, status, at, lin.step_se, label)


@dataclass(frozen=True)
class StartOutcome:
    """One start of :func:`minimise`: its label, the reduced cost it ended at (``cost / dof``), its status."""

    label: str
    chi2_reduced: float
    status: str
    iterations: int


def fit_progress(progress: StageProgress | None, label: str, dof: int) -> IterationProgress | None:
    """The listener of the fit from the start ``label`` that tells ``progress`` its stage (module docstring): the
    iteration and the reduced chi-square ``cost / dof`` of the point it linearises at."""
    if progress is None:
        return None
    tell = progress
    return lambda it, cost, share: tell(f'fit from {label}: iteration {it}, reduced chi-square '
                                        f'{cost / max(dof, 1):.4g}', share)


def minimise(residuals: Residuals, params: ParameterSet, starts: Sequence[tuple[str, Array]],
             fit: NDArray[np.int64], scale: Array, dof: int, progress: StageProgress | None = None
             ) -> tuple[Minimum, tuple[StartOutcome, ...]]:
    """The lowest minimum from ``starts`` (``(label, theta)``, module docstring): the best :class:`Minimum` and every
    start's outcome; ``progress`` hears each start's iterations (:func:`fit_progress`)."""
    best: Minimum | None = None
    outcomes = []
    for k, (label, theta) in enumerate(starts):
        m = levenberg_marquardt(residuals, params, theta, fit, scale, label,
                                MAX_ITERATIONS if k == 0 else OTHER_START_ITERATIONS,
                                fit_progress(progress, label, dof))
        outcomes.append(StartOutcome(label, m.cost / max(dof, 1), m.status, m.iterations))
        if best is None or (m.status == 'undefined', m.cost) < (best.status == 'undefined', best.cost):
            best = m
    assert best is not None
    return best, tuple(outcomes)

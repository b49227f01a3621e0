"""How far a fitted calibration can be trusted: leave-one-out cross-validation, the bias the held parameters can
cause, and the gate a fit must pass before its file is written.

All of it is linear algebra on the weighted Jacobian ``J`` of the fit at its solution (each column scaled by the
parameter's a-priori uncertainty ``s_j``), ``A = J^T J``:

* **Cross-validation** (leave one row out, the PRESS statistic; Allen, *The relationship between variable
  selection and data augmentation and a method for prediction*, Technometrics 16(1), 1974): the residual block
  ``r_i`` of row ``i`` predicted by the fit of all the other rows is ``(I - H_ii)^-1 r_i`` with
  ``H_ii = J_i A^-1 J_i^T`` (exact for the linearised model: one Gauss-Newton step from the fit of all rows). Under
  the model, with unit-variance residuals, its expected square is ``tr (I - H_ii)^-1``; the **ratio** of the
  summed squares to that expectation, divided by the fit's own reduced chi-square, is about 1 when the rows left
  out are predicted as well as the fitted ones are explained, and grows when some rows are fitted only because they
  were in the fit. A row with ``H_ii`` near the identity determines a combination alone: nothing predicts it
  (listed, left out of the ratio).
* **Bias from what is held** (the alias matrix of regression; Box & Draper, *Empirical Model-Building and Response
  Surfaces*, 1987, §10.2): a held (or fixed) parameter ``h`` off its nominal value by ``x_h`` moves the fitted ones
  by ``-A^-1 J^T J_h x_h``; over its a-priori bound (a tolerance table's interval, else 3 a-priori standard
  deviations, within the coordinate's range) the **worst case** is the sum of the absolute effects, the
  **standard deviation** the root-sum-square over their a-priori standard deviations. The standard errors are
  conditional on the held parameters; the bias is what that condition can cost. A quantity ``y = G theta`` (the
  parameters a registration's datum derives) has the sensitivity ``G_h + G_fitted alias_h`` (the chain rule).
* **The gate** (:class:`Gate`): the fit reached a minimum (:mod:`.fitting`); with standard deviations from the
  measurement file, ``chi2`` at most the :data:`CHI2_QUANTILE` point of the chi-square distribution with its
  degrees of freedom (a correct model fails it once in a thousand fits); the cross-validation ratio at most
  :data:`CV_GATE`; and, with standard deviations given, the residuals of each kind (positions; angles) not far
  below them: each kind's reduced chi-square ``sum r^2 / sum (1 - h_ii)`` over its residuals (``h_ii`` the diagonal
  of the hat matrix ``J A^-1 J^T``, exact expectation for the linearised model) at least the ``1 - CHI2_QUANTILE``
  point of its distribution (:func:`sigma_check`): a sigma column in other units than the file's (3 mm for 3 um) had
  the fit ignore the positions, moved the zero offsets by 14 um and passed with a reduced chi-square of 0.44.
  With them too, no residual an outlier: the largest studentized residual ``|r| / sqrt(1 - h_ii)`` at most the
  point the largest of ``N k`` normal residuals exceeds with probability ``1 - CHI2_QUANTILE`` (Bonferroni;
  :func:`outlier_check`): one row 20 um off (6.6 sigma) among 40 passed the chi-square gate (1.12). Their messages
  give the residuals' robust scale per kind (:func:`spread`), which tells a noise larger than declared (every kind
  about the square root of the reduced chi-square; no row an outlier alone) from a few bad rows (about 1).
  Without a declared noise the sigmas used (a laser tracker's default noise, or a tolerance table's) are the noise
  the chi-square must not much exceed (swapped x and y columns passed with a reduced chi-square of 1.93 when they
  only weighted), there is no ``sigmas`` check (residuals below an assumed noise are no fault), and the outliers
  are found in units of the residuals' own robust scale (:func:`robust_scale`): a row 200 um off passed. That
  scale is estimated from the same residuals, so the point is Student's t's with its kind's ``nu`` degrees of
  freedom in place of the normal's (:func:`robust_dof`): the normal's failed 8 of 1000 right fits.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .distributions import chi2_ppf, normal_isf, t_isf
from .fitting import gram
from .model import ParameterSet

Array = NDArray[np.float64]

#: The chi-square gate: a fit passes when ``chi2`` (with the declared noise, else the assumed one) is at most this
#: quantile of the chi-square distribution with its degrees of freedom.
CHI2_QUANTILE = 0.999
#: The cross-validation gate: rows left out may be predicted this much worse than the fit explains the rows
#: (ratio of the PRESS to its expectation, over the reduced chi-square).
CV_GATE = 2.0
#: A row whose ``I - H_ii`` has an eigenvalue below this determines a combination alone.
LEVERAGE_ONE = 1e-9
#: The standard deviation of a normal distribution over its median absolute deviation (``1 / Phi^-1(3/4)``).
MAD_NORMAL = 1.482602218505602
#: The MAD's scale over the standard deviation's in degrees of freedom, ``8 phi(c)^2 c^2`` (``c = Phi^-1(3/4)``): its
#: relative variance ``1.3605 / n`` is a chi-square scale's of ``0.3676 n`` degrees of freedom (0.37 asymptotic
#: efficiency; 1000 synthetic fits of 40 poses gave 41 for 41.0 predicted).
MAD_EFFICIENCY = 0.36757
#: Smallest robust scale of the outlier check without a declared noise, in units of the sigmas used: residuals of
#: exact data (rounding) are no outliers.
ROBUST_FLOOR = 0.01


@dataclass(frozen=True)
class CrossValidation:
    """Leave-one-row-out prediction errors (module docstring).

    Attributes:
        errors: per row the prediction error of the fit of the other rows ``(N, k)`` (metres, radians: position,
            and rotation vector for a measured pose); ``nan`` for rows listed in ``alone``.
        ratio: PRESS over its expectation, over the fit's reduced chi-square (about 1 for a model that holds).
        alone: file lines of rows that alone determine a fitted combination (no prediction for them);
            alone_files: their files where files are merged (else empty).
    """

    errors: Array
    ratio: float
    alone: tuple[int, ...]
    alone_files: tuple[str, ...] = ()

    def rms(self, part: slice) -> float:
        """RMS norm of ``errors[:, part]`` over the rows that have a prediction."""
        e = self.errors[:, part]
        ok = np.all(np.isfinite(e), axis=1)
        return float(np.sqrt(np.mean(np.sum(e[ok] ** 2, axis=1)))) if ok.any() else math.nan


def cross_validation(J: Array, residual: Array, weights: Array, lines: Sequence[int], chi2_reduced: float,
                     files: Sequence[str] = ()) -> CrossValidation:
    """:class:`CrossValidation` of a fit with scaled weighted Jacobian ``J (N k, F)`` and weighted residual blocks
    ``residual (N, k)`` (``weights (N, k)``: the residuals' ``1 / sigma``); ``lines`` and ``files`` (merged files
    only) name the rows."""
    n, k = residual.shape
    if J.shape[1] == 0:
        return CrossValidation(residual / weights, 1.0, ())
    if not np.all(np.isfinite(J)):   # no Jacobian at the solution: nothing predicted
        return CrossValidation(np.full((n, k), np.nan), math.nan, ())
    Ainv = np.linalg.pinv(gram(J))
    Jb = J.reshape(n, k, -1)
    M = np.eye(k)[None] - np.einsum('nkf,fg,nlg->nkl', Jb, Ainv, Jb)
    alone = np.linalg.eigvalsh(0.5 * (M + np.swapaxes(M, 1, 2)))[:, 0] < LEVERAGE_ONE
    errors = np.full((n, k), np.nan)
    ok = ~alone
    if ok.any():
        errors[ok] = np.linalg.solve(M[ok], residual[ok][..., None])[..., 0] / weights[ok]
        press = float(np.sum((errors[ok] * weights[ok]) ** 2))
        expected = float(np.sum(np.trace(np.linalg.inv(M[ok]), axis1=1, axis2=2)))
        ratio = press / expected / chi2_reduced if chi2_reduced > 0 and expected > 0 else 1.0
    else:   # every row alone determines a combination: nothing to predict a row by (a ratio of 1 passed the gate)
        ratio = math.nan
    rows = np.flatnonzero(alone)
    return CrossValidation(errors, float(ratio), tuple(int(lines[int(i)]) for i in rows),
                           tuple(files[int(i)] for i in rows) if len(files) else ())


@dataclass(frozen=True)
class HeldBias:
    """Per parameter ``(P,)`` (coordinates; ``nan`` for those not fitted): the worst-case and the standard deviation
    of the bias the held and fixed parameters can cause, and the held parameter that causes most of the worst case
    (``''``: none); and what gives them: the indices of the ``fitted`` and ``held`` (and fixed) parameters, the
    alias matrix ``d theta_fitted / d theta_held (F, H)`` in coordinates (``nan``: no Jacobian at the solution),
    the held ones' a-priori bounds and standard deviations ``(H,)``, and the parameters' names."""

    worst: Array
    std: Array
    source: tuple[str, ...]
    fitted: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    held: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    alias: Array = field(default_factory=lambda: np.zeros((0, 0)))
    held_bound: Array = field(default_factory=lambda: np.zeros(0))
    held_std: Array = field(default_factory=lambda: np.zeros(0))
    names: tuple[str, ...] = ()

    def of(self, G: Array) -> tuple[Array, Array, tuple[str, ...]]:
        """Worst case, standard deviation and main source of the bias of quantities ``y = G theta`` (``G (D, P)``,
        linear functions of the coordinates, e.g. the parameters a datum derives): by the chain rule their
        sensitivity to the held parameters is ``S = G_held + G_fitted alias``, the worst case ``sum_h |S_h| b_h``,
        the standard deviation ``sqrt(sum_h (S_h s_h)^2)`` (``nan`` where the alias is not known)."""
        G = np.atleast_2d(np.asarray(G, dtype=float))
        S = G[:, self.held]
        moved = np.any(G[:, self.fitted] != 0.0, axis=1)    # through the fitted ones (else no alias is needed)
        S[moved] += G[np.ix_(moved, self.fitted)] @ self.alias
        effect = np.abs(S) * self.held_bound[None, :]
        worst = effect.sum(axis=1)
        sd = np.sqrt(np.sum((S * self.held_std[None, :]) ** 2, axis=1))
        source = tuple(self.names[int(self.held[int(np.argmax(e))])] if e.size and e.max() > 0.0 else ''
                       for e in effect)
        return np.asarray(worst, dtype=np.float64), np.asarray(sd, dtype=np.float64), source


def held_bias(J_fit: Array, J_held: Array, fitted: NDArray[np.int64], held: NDArray[np.int64], scale: Array,
              bound: Array, std: Array, names: Sequence[str]) -> HeldBias:
    """:class:`HeldBias` from the scaled weighted Jacobians of the fitted (``J_fit``) and the held parameters
    (``J_held``, columns scaled by ``scale[held]``), the held ones' a-priori bounds and standard deviations (SI,
    ``(H,)``) and the ``scale (P,)``."""
    P = len(names)
    worst, sd = np.full(P, np.nan), np.full(P, np.nan)
    source = [''] * P

    def result(alias_si: Array) -> HeldBias:
        return HeldBias(worst, sd, tuple(source), fitted, held, alias_si, np.asarray(bound, dtype=np.float64),
                        np.asarray(std, dtype=np.float64), tuple(names))

    if fitted.size == 0 or not (np.all(np.isfinite(J_fit)) and np.all(np.isfinite(J_held))):
        return result(np.zeros((0, held.size)) if fitted.size == 0 else np.full((fitted.size, held.size), np.nan))
    A = gram(np.hstack([J_fit, J_held]))
    F = J_fit.shape[1]
    alias = -np.linalg.pinv(A[:F, :F]) @ A[:F, F:]                     # (F, H), scaled units
    effect = np.abs(alias) * (bound / scale[held])[None, :] * scale[fitted][:, None]
    worst[fitted] = effect.sum(axis=1)
    sd[fitted] = scale[fitted] * np.sqrt(np.sum((alias * (std / scale[held])[None, :]) ** 2, axis=1))
    if held.size:
        for i, j in enumerate(fitted):
            if effect[i].max() > 0.0:
                source[int(j)] = names[int(held[int(np.argmax(effect[i]))])]
    return result(alias * scale[fitted][:, None] / scale[held][None, :])   # coordinates: d theta_f / d theta_h


@dataclass(frozen=True)
class GateCheck:
    """One check of the gate: ``name``, whether it ``passed``, its ``value`` and ``limit``, and what it found."""

    name: str
    passed: bool
    value: float
    limit: float
    detail: str
    #: The check passes when ``value >= limit`` (not ``<=``).
    at_least: bool = False
    #: False: the fit cannot support the check's verdict (``detail`` says why); it passes, ``value`` and ``limit`` NaN.
    judged: bool = True


@dataclass(frozen=True)
class Gate:
    """The checks a fit must pass before its calibrated file is written (module docstring)."""

    checks: tuple[GateCheck, ...]

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    def message(self) -> str:
        """The failed checks in one sentence each, then the checks not judged (empty when it passed): a check not
        judged led the arm gate's line (``FAILED: noise chi square: ...``, which passed) before the one that failed."""
        if self.passed:
            return ''
        return ' '.join([c.detail for c in self.checks if not c.passed]
                        + [c.detail for c in self.checks if c.passed and not c.judged])

    def as_dict(self) -> dict[str, Any]:
        return {'passed': self.passed,
                'checks': [dict(c.__dict__) | {k: v if math.isfinite(v) else None
                                               for k, v in (('value', c.value), ('limit', c.limit))}
                           for c in self.checks]}


def chi2_limit(dof: int) -> float:
    """The reduced chi-square at :data:`CHI2_QUANTILE` for ``dof`` degrees of freedom."""
    return float(chi2_ppf(CHI2_QUANTILE, dof) / dof)


#: Residuals of each kind, columns of the residual blocks: a measured pose's, a measured point's.
KINDS = {6: (('position', slice(0, 3)), ('angle', slice(3, 6))), 3: (('position', slice(0, 3)),)}


def hat_diagonal(J: Array, shape: tuple[int, int]) -> Array | None:
    """The diagonal of the hat matrix ``J A^-1 J^T`` of a scaled weighted Jacobian ``J (N k, F)`` as ``shape``
    ``(N, k)`` (``None`` when ``J`` is not finite)."""
    if J.shape[1] == 0:
        return np.zeros(shape)
    if not np.all(np.isfinite(J)):
        return None
    return np.asarray(np.einsum('if,fg,ig->i', J, np.linalg.pinv(gram(J)), J).reshape(shape), dtype=np.float64)


def kind_variances(h: Array, residual: Array) -> Array:
    """Per column of weighted residual blocks ``residual (N, k)`` the reduced chi-square of its kind
    (:data:`KINDS`), ``sum r^2 / sum (1 - h_ii)`` over the kind's residuals (``h (N, k)`` the hat diagonal): the
    variance of a weighted residual of that kind, 1 when its sigmas are the noise. A kind with less than one degree
    of freedom takes the reduced chi-square of all residuals (its own cannot be estimated: 1 trusted the assumed
    sigmas), 1 when that has none either."""
    total = float(np.sum(1.0 - h))
    out = np.full(residual.shape[1], float(np.sum(residual ** 2)) / total if total >= 1.0 else 1.0)
    for _, part in KINDS[residual.shape[1]]:
        dof = float(np.sum(1.0 - h[:, part]))
        if dof >= 1.0:
            out[part] = float(np.sum(residual[:, part] ** 2)) / dof
    return out


def robust_scale(z: Array, h: Array) -> Array:
    """Per column of studentized residuals ``|z| (N, k)`` the robust scale of its kind (:data:`KINDS`):
    ``1.4826 median |z|`` over the rows that do not determine a combination alone (the normal's standard deviation
    from its median absolute deviation), at least :data:`ROBUST_FLOOR`."""
    out = np.ones(z.shape[1])
    for _, part in KINDS[z.shape[1]]:
        zk = z[:, part][h[:, part] < 1.0 - LEVERAGE_ONE]
        out[part] = max(MAD_NORMAL * float(np.median(zk)) if zk.size else 1.0, ROBUST_FLOOR)
    return out


def robust_dof(h: Array) -> Array:
    """Per column of hat diagonals ``h (N, k)`` the degrees of freedom ``nu`` of its kind's robust scale
    (:func:`robust_scale`): ``MAD_EFFICIENCY sum (1 - h_ii)`` over the kind's rows that do not determine a
    combination alone (``inf`` for none: no scale estimated)."""
    out = np.full(h.shape[1], np.inf)
    for _, part in KINDS[h.shape[1]]:
        hk = h[:, part][h[:, part] < 1.0 - LEVERAGE_ONE]
        if hk.size:
            out[part] = max(MAD_EFFICIENCY * float(np.sum(1.0 - hk)), 1.0)
    return out


def outlier_limit(count: int, nu: float = math.inf) -> float:
    """The point the largest of ``count`` residuals exceeds with probability ``1 - CHI2_QUANTILE`` (Bonferroni,
    two-sided): the normal's, or Student's t's with ``nu`` degrees of freedom for residuals over a scale estimated
    from them (:func:`robust_dof`)."""
    p = (1.0 - CHI2_QUANTILE) / 2.0 / count
    return normal_isf(p) if math.isinf(nu) else t_isf(p, nu)


def studentized(h: Array, residual: Array) -> Array:
    """``|r| / sqrt(1 - h_ii)`` of weighted residual blocks ``(N, k)`` (0 for a row that determines a combination
    alone)."""
    with np.errstate(divide='ignore', invalid='ignore'):
        return np.asarray(np.where(h < 1.0 - LEVERAGE_ONE,
                                   np.abs(residual) / np.sqrt(np.maximum(1.0 - h, LEVERAGE_ONE)), 0.0))


def spread(h: Array | None, residual: Array) -> str:
    """The residuals' robust scale per kind in units of their sigmas, in words (``''`` without a hat diagonal):
    about the square root of the reduced chi-square when every residual is as much larger than its sigma (a noise
    larger than declared), about 1 when a few rows or a model error make the chi-square."""
    if h is None:
        return ''
    scale = robust_scale(studentized(h, residual), h)
    return ', '.join(f'{kind}s {scale[part][0]:.3g}' for kind, part in KINDS[residual.shape[1]])


def outlier_rows(fitted: int, k: int) -> int:
    """The fewest rows of ``k`` residuals each whose outliers a fit of ``fitted`` parameters can judge: more residuals
    than twice the parameters (mean leverage ``F / (k N)`` below 1/2), else a row's residual shows the other rows'
    errors more than its own (5 poses for 16 parameters, 0.53: a row 60 um off in z was named as another line)."""
    return 2 * fitted // k + 1


def outlier_check(h: Array | None, residual: Array, names: Sequence[str], robust: bool | Sequence[bool] = False,
                  fitted: int = 0) -> GateCheck | None:
    """The gate's ``outliers`` check (module docstring): the largest studentized residual ``|r| / sqrt(1 - h)``
    against the point the largest of the fit's ``N k`` normal residuals exceeds with probability ``1 -
    CHI2_QUANTILE`` (Bonferroni; :func:`outlier_limit`); ``None`` without a hat diagonal. ``names``: the rows' names
    (:attr:`~.measurements.Measurements.row_names`). ``robust`` (no declared noise; or per kind, positions and
    angles, where one kind's is declared): in units of the residuals' own robust scale per kind
    (:func:`robust_scale`), not of the sigmas, against Student's t's point with the scale's degrees of freedom
    (:func:`robust_dof`): the residual furthest beyond its limit is named. With fewer rows than
    :func:`outlier_rows` of the ``fitted`` parameters, not judged: no row is named."""
    if h is None:
        return None
    n, k = residual.shape
    if n < outlier_rows(fitted, k):
        return GateCheck('outliers', True, math.nan, math.nan,
                         f'Too few rows beyond the fitted parameters to judge outliers: {n} rows, {fitted} fitted '
                         f'parameters; at least {outlier_rows(fitted, k)} rows needed (more residuals than twice the '
                         "fitted parameters: with fewer a row's residual shows the other rows' errors more than its "
                         'own), so no row is named an outlier.', judged=False)
    z = studentized(h, residual)
    scale = robust_scale(z, h)
    per_kind = [bool(robust)] * len(KINDS[k]) if isinstance(robust, bool) else [bool(b) for b in robust]
    by_scale = np.repeat(per_kind[:len(KINDS[k])], 3)
    z = np.where(by_scale[None, :], z / scale[None, :], z)
    nu = np.where(by_scale, robust_dof(h), np.inf)
    points = {float(v): outlier_limit(n * k, float(v)) for v in set(nu.tolist())}
    limits = np.array([points[float(v)] for v in nu])
    i, j = np.unravel_index(int(np.argmax(z / limits[None, :])), z.shape)
    scaled = bool(by_scale[j])
    limit = float(limits[j])
    value = float(z[i, j])
    what = ('x', 'y', 'z', 'rx', 'ry', 'rz')[j]
    name = names[int(i)]
    units = ('robust standard deviations of its kind (1.4826 times the median studentized residual: no noise '
             'declared)' if scaled else 'standard deviations (studentized)')
    kind = KINDS[k][j // 3][0]
    cause = ('a mismeasured row (remove it)' if scaled else
             'a mismeasured row (remove it), or its standard deviation larger than given'
             if value > limit * scale[j] or scale[j] <= 1.0 else
             f'not this row alone: the {kind}s\' robust scale is {scale[j]:.3g} sigma, this one '
             f'{value / scale[j]:.3g} of it (more noise than declared?)')
    return GateCheck('outliers', value <= limit, value, limit,
                     f'{name[:1].upper()}{name[1:]} is an outlier: its {what} residual is {value:.3g} {units}, above '
                     f'{limit:.3g} (the largest of {n * k} residuals of a right model exceeds it once in '
                     f'{1 / (1 - CHI2_QUANTILE):.0f} fits): {cause}.')


def sigma_check(h: Array | None, residual: Array, kinds: Sequence[str] | None = None,
                options: Sequence[str] = ()) -> GateCheck | None:
    """The gate's ``sigmas`` check (module docstring) of a fit with hat diagonal ``h (N, k)`` (:func:`hat_diagonal`)
    and weighted residual blocks ``residual (N, k)``: of the ``kinds`` whose sigmas are given (all by default), the
    one whose reduced chi-square is furthest below its ``1 - CHI2_QUANTILE`` point, every one below named (one named
    alone was mended, the other then refused); ``None`` when none has a degree of freedom or no hat diagonal. The
    hint names ``--sigma-position``/``--sigma-angle`` for the ``options`` kinds (their sigmas the option's)."""
    n, k = residual.shape
    if h is None:
        return None
    judged: list[tuple[float, str, float, float]] = []
    for kind, part in KINDS[k]:
        dof = float(np.sum(1.0 - h[:, part]))
        if dof < 1.0 or (kinds is not None and kind not in kinds):
            continue
        red = float(np.sum(residual[:, part] ** 2)) / dof
        judged.append((red, kind, dof, float(chi2_ppf(1.0 - CHI2_QUANTILE, dof) / dof)))
    if not judged:
        return None
    red, kind, dof, low = min(judged, key=lambda j: j[0] / j[3])
    below = [j for j in judged if j[0] < j[3]] or [(red, kind, dof, low)]
    unit = {'position': '--mm', 'angle': '--deg'}
    column = 'a sigma column in other units than the file\'s (mm or deg in a file in m and rad?)'
    causes = dict.fromkeys(f'--sigma-{b} in other units than meant (with or without {unit[b]}?)' if b in options
                           else column for _, b, _, _ in below)
    one = len(below) == 1
    return GateCheck('sigmas', red >= low, red, low,
                     f'The {" and ".join(b for _, b, _, _ in below)} residuals are far smaller than the standard '
                     f'deviations given: their reduced chi-square{"" if one else "s"} '
                     f'{" and ".join(f"{r:.3g}" for r, _, _, _ in below)} {"is" if one else "are"} below '
                     f'{" and ".join(f"{lo:.3g}" for _, _, _, lo in below)} (the {100 * (1 - CHI2_QUANTILE):g} % '
                     f'point{"" if one else "s"} for {" and ".join(f"{d:.4g}" for _, _, d, _ in below)} degrees of '
                     f'freedom), and the fit weights the {" and ".join(b + "s" for _, b, _, _ in below)} too little: '
                     f'{" or ".join(causes)}, or the noise overstated; give the measurement noise.', at_least=True)


def worst_rows(residual: Array, names: Sequence[str], count: int = 3) -> str:
    """The ``count`` rows of largest weighted residual, as ``line 8 (3.1 sigma), ... (each row's RMS over its 6
    coordinates)`` (``names``: the rows'): not a residual's own size, which the outlier check quotes studentized."""
    norm = np.sqrt(np.mean(residual ** 2, axis=1))
    order = np.argsort(-norm)[:count]
    return (', '.join(f'{names[i]} ({norm[i]:.2g} sigma)' for i in order)
            + f' (each row\'s RMS over its {residual.shape[1]} coordinates)')


#: A fitted parameter further from its nominal value than this many a-priori standard deviations is named in a
#: warning: a tracker frame left unregistered moved the rods by 3-7 mm, 30-66 of them, and passed the gate.
FAR_FROM_PRIOR = 20.0


def _named(params: ParameterSet, fit: NDArray[np.int64], ratio: Array, above: float, digits: str) -> str:
    """The fitted parameters (not the stiffness ratios) whose ``ratio`` exceeds ``above``, largest first, as
    ``name ratio`` (at most four; '' for none)."""
    over = sorted(((int(j), float(ratio[j])) for j in fit if not params[int(j)].transform and ratio[j] > above),
                  key=lambda item: -item[1])
    return ', '.join(f'{params[j].name} {r:{digits}}' for j, r in over[:4]) + (', ...' if len(over) > 4 else '')


def far_from_prior(params: ParameterSet, fit: NDArray[np.int64], theta: Array, theta0: Array, scale: Array,
                   frame: str) -> tuple[str, ...]:
    """A warning naming the fitted parameters (not the stiffness ratios) more than :data:`FAR_FROM_PRIOR` a-priori
    standard deviations from nominal: the gate passes such a fit when the measurements are consistent, which
    measurements in another frame than the one named are."""
    named = _named(params, fit, np.abs(theta - theta0) / scale, FAR_FROM_PRIOR, '.0f')
    if not named:
        return ()
    return (f'fitted parameters far beyond their a-priori standard deviations (in those: {named}): are the '
            f'measurements in another frame than {frame}? (--frame NAME identifies the tracker\'s frame with the '
            'machine), or are the a-priori uncertainties too small (--tolerances)?',)


def weak_at_estimate(params: ParameterSet, fit: NDArray[np.int64], se: Array, scale: Array) -> tuple[str, ...]:
    """A warning naming the fitted parameters (not the stiffness ratios) whose standard error at the estimate exceeds
    their a-priori standard deviation: identifiability is decided at the nominal machine, and at the estimate (a
    joint far softer than nominal) the poses may see a parameter worse than it was known, its value then noise."""
    named = _named(params, fit, se / scale, 1.0, '.3g')
    if not named:
        return ()
    return (f'fitted parameters the poses determine worse at the estimate than they were known before (standard error '
            f'over a-priori standard deviation: {named}): their values are noise; leave them out of --free (held at '
            'nominal) and calibrate again',)

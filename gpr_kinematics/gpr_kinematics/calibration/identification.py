"""Identification of geometric parameters from measured poses or points: weighted nonlinear least squares.

For measurements ``i = 1..N`` (rod lengths ``q_i``, measured pose ``(p_i, R_i)``) and a pose model with
parameters ``theta``, the residual of row ``i`` is the 6-vector

    r_i(theta) = ( (p(theta, q_i) - p_i) / sigma_p,i ,  phi(R(theta, q_i) R_i^T) / sigma_a,i )

(metres and radians divided by the row's standard deviations: unit variance), ``phi`` the rotation vector; for a
measured point (no orientation) its first three components. ``theta`` minimises ``sum_i |r_i|^2`` over the free,
identifiable parameters (:mod:`.identifiability`, analysed at the nominal parameters); the others stay at their
nominal values. The minimiser (:mod:`.fitting`) is a bounded Levenberg-Marquardt from two starts (the nominal
stiffness ratios and isotropic joints); the lower minimum wins.

Standard errors come from the covariance ``C = (J^T J)^-1`` at the solution (Gauss-Newton approximation of the
inverse Hessian). With standard deviations from the file (both sigma columns, or the one of a file of points), or
given by the user as the measurement noise (``declared``), ``C`` is absolute; otherwise the sigmas used (the
defaults :data:`DEFAULT_SIGMA_POSITION` and :data:`DEFAULT_SIGMA_ANGLE`, a laser tracker's noise, or a tolerance
table's ``measurement_noise``) weight position against angle, ``C`` is the sandwich ``A^-1 J^T V J A^-1`` with
``V`` each residual's variance, its kind's reduced chi-square ``sum r^2 / sum (1 - h_ii)`` (the ratio of the
assumed sigmas is assumed too: one factor for both kinds misstated the standard errors by -20 to +31 %), and the
gate judges the residuals against them as the noise they cannot much exceed (its
``chi_square`` check) and finds outliers by the residuals' own robust scale (:func:`~.quality.outlier_check`).
One kind declared alone (a ``sigma_position`` column without ``sigma_angle``, ``--sigma-position`` alone) is judged
as declared (the gate's ``sigmas`` check, its outliers in its sigmas, :data:`MAX_CHI2`), the other as assumed.
Beside them: the leave-one-out cross-validation, the worst-case bias the held parameters can cause, and the gate
(:mod:`.quality`).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..callbacks import StageProgress, reporter
from ..core.config import MAX_SIDE_MISMATCH
from ..errors import ConvergenceError, InputError, brief
from .fitting import Minimum, fit_progress, gram, levenberg_marquardt, minimise, residual_jacobian
from .held import prior_bound, table_held, with_table_held
from .identifiability import DEFAULT_THRESHOLD, Identifiability, analyse, triangular_factor
from .measurements import SIGMA_RANGE, Measurements
from .model import ParameterSet, PoseModel, pose_model, prior_scale
from .plausibility import measured_errors, other_reading, plausible_start, with_reading
from .quality import (
    CHI2_QUANTILE,
    CV_GATE,
    KINDS,
    Gate,
    GateCheck,
    chi2_limit,
    cross_validation,
    far_from_prior,
    hat_diagonal,
    held_bias,
    kind_variances,
    outlier_check,
    sigma_check,
    spread,
    weak_at_estimate,
    worst_rows,
)
from .repeats import check_repeats
from .results import CalibrationResult, Convergence, ResidualStats
from .tolerances import free_of

Array = NDArray[np.float64]

#: Default standard deviation of a measured position coordinate [m] (a laser tracker's 6-DOF probe at a few metres):
#: without a declared noise the residuals weighted by it must pass the chi-square gate (swapped x and y columns of
#: the demonstration's file left 7.9 um per coordinate and passed when the defaults only weighted).
DEFAULT_SIGMA_POSITION = 5e-6
#: Default standard deviation of a measured rotation-vector component [rad] (the same probe).
DEFAULT_SIGMA_ANGLE = 2e-5
#: Largest reduced chi-square of a fit to measurements with their own standard deviations: beyond it the residuals
#: are 100 times the stated noise, and no geometry of this machine explains the poses (a refusal, exit 2).
MAX_CHI2 = 1e4
#: The linearised estimate's mismatch of the rods' triangle from the nominal joints' (a fraction of a side) beyond
#: which the joints' held places follow their rods (:func:`_joints_on_rods`): half what a geometry allows, so that
#: the fit has room about the estimate.
GROSS_MISMATCH = 0.5 * MAX_SIDE_MISMATCH
#: The label of the start with the joints on their rods.
ON_RODS = 'joints on their rods'
#: The label of the start from the frames fitted alone (:meth:`~.frames.FramedModel.registered`), tried where the
#: closed-form registration leaves a pose beyond :data:`PLAUSIBLE_POSITION` or :data:`PLAUSIBLE_ANGLE`.
REGISTERED = 'frames fitted alone'
#: A fit's status (:data:`~.fitting.STATUSES`) in the gate's words.
STATUS_WORDS = {'iterations': 'out of iterations'}
NOT_THIS_MACHINE = ('not measurements of this machine in the declared units (lengths in other units than the file\'s '
                    '"# units:" line says, m by default? a measured frame other than the one declared?)')


def check_sigmas(sigma_position: float, sigma_angle: float) -> None:
    """Refuse standard deviations outside :data:`~.measurements.SIGMA_RANGE` (m, rad)."""
    lo, hi = SIGMA_RANGE
    for name, v in (('sigma_position', sigma_position), ('sigma_angle', sigma_angle)):
        if isinstance(v, bool) or not (isinstance(v, (int, float)) and lo <= v <= hi):
            raise InputError(f'{name} = {v!r}; allowed: a standard deviation from {lo:g} to {hi:g} (m, rad)')


def weights(meas: Measurements, sigma_position: float, sigma_angle: float,
            declared: tuple[bool, bool] = (False, False)) -> tuple[Array, bool]:
    """``1 / sigma`` of every residual ``(N, k)`` and whether the sigmas are the measurement noise (absolute): the
    file's, or ``sigma_position``/``sigma_angle`` where ``declared`` says the user gave them as such (not the
    defaults, which only weight position against angle)."""
    check_sigmas(sigma_position, sigma_angle)
    n = len(meas)
    sp = meas.sigma_position if meas.sigma_position is not None else np.full(n, float(sigma_position))
    position = meas.sigma_position is not None or declared[0]
    if meas.quaternion is None:
        return np.repeat(1.0 / sp[:, None], 3, 1), position
    sa = meas.sigma_angle if meas.sigma_angle is not None else np.full(n, float(sigma_angle))
    w = np.column_stack([np.repeat(1.0 / sp[:, None], 3, 1), np.repeat(1.0 / sa[:, None], 3, 1)])
    return w, position and (meas.sigma_angle is not None or declared[1])


def known_kinds(meas: Measurements, declared: tuple[bool, bool] = (False, False)) -> tuple[str, ...]:
    """The kinds (``position``, ``angle``: :data:`~.quality.KINDS`) whose sigmas are the measurement noise: the
    file's column, or ``declared`` (``--sigma-position``, ``--sigma-angle``)."""
    kinds = ['position'] if meas.sigma_position is not None or declared[0] else []
    if meas.quaternion is not None and (meas.sigma_angle is not None or declared[1]):
        kinds.append('angle')
    return tuple(kinds)


def _refuse_far(meas: Measurements, params: ParameterSet, mask: NDArray[np.bool_], residual: Array, dof: int,
                kinds: tuple[str, ...], absolute: bool, reading: Callable[[], str] = lambda: '') -> None:
    """Refuse a fit whose residuals of a kind with declared sigmas (all: ``absolute``) exceed them beyond
    :data:`MAX_CHI2` in reduced chi-square: ``sum r^2 / dof`` over all residuals, or over a declared kind's its
    share of the ``dof`` (``dof`` times its share of the residuals) where the other kind's noise is assumed;
    ``reading()``: :func:`~.plausibility.other_reading`'s hint."""
    k = residual.shape[1]
    if absolute:
        found = [('', float(np.sum(residual ** 2)) / dof)]
    else:
        found = [(f'{kind} ', float(np.sum(residual[:, part] ** 2)) / (dof * 3 / k))
                 for kind, part in KINDS[k] if kind in kinds]
    for kind, chi2_red in found:
        if not chi2_red > MAX_CHI2:
            continue
        fixed_names = [p.name for j, p in enumerate(params) if not mask[j]]
        shown = ', '.join(fixed_names[:4]) + (', ...' if len(fixed_names) > 4 else '')
        fixed = (f', or parameters held that are off nominal ({len(fixed_names)} held by --free or a tolerance of 0: '
                 f'{shown})?' if fixed_names else '')
        hint = reading()
        raise InputError(f'{meas.source}: the best fit leaves {kind}residuals {math.sqrt(chi2_red):.3g} times the '
                         f'standard deviations of the file (reduced chi-square {chi2_red:.3g}; allowed: at most '
                         f'{MAX_CHI2:g}): {NOT_THIS_MACHINE}, or sigma columns far too small{fixed}'
                         + (f'; {hint}' if hint else ''))


def least_rows(n_free: int, per_row: int) -> int:
    """The fewest rows of ``per_row`` residuals each (6 for poses, 3 for points) that give more residuals than
    ``n_free`` free parameters: what an identification needs (and a measurement plan must give)."""
    return n_free // per_row + 1


def _starts(params: ParameterSet, theta0: Array, fit: NDArray[np.int64], label: str = 'nominal'
            ) -> list[tuple[str, Array]]:
    """The start ``theta0`` (``label``), and one with isotropic joints (anisotropy 0) when a fitted anisotropy starts
    elsewhere."""
    starts = [(label, theta0)]
    transformed = np.array([params[int(j)].transform != '' for j in fit], dtype=bool)
    if transformed.any() and np.any(np.abs(theta0[fit[transformed]]) > 1e-6):
        iso = theta0.copy()
        iso[fit[transformed]] = 0.0
        starts.append(('isotropic joints' if label == 'nominal' else f'{label}, isotropic', iso))
    return starts


def _joints_on_rods(model: PoseModel, params: ParameterSet, residuals: Callable[[Array], Array], theta0: Array,
                    free: NDArray[np.int64], fit: NDArray[np.int64], J: Array, scale: Array,
                    progress: StageProgress | None = None) -> tuple[Array, tuple[str, ...], float] | None:
    """The start and held values of a machine far off its nominal one, or ``None`` (hold at nominal, start there).

    The poses cannot see the platform joints' radial places (the identifiability report holds them), so holding
    them at nominal is a choice, which is wrong for a machine millimetres off its drawing: with the rods' triangle
    fitted larger (another radius) the joints' would stay nominal, beyond :data:`~gpr_kinematics.core.config.
    MAX_SIDE_MISMATCH` of it (1.8 mm of radius: 1.9 %), a geometry no file allows, and the fit stopped at that wall.
    When the linearised estimate from nominal (one Gauss-Newton step, ``J (N k, fit)`` the scaled Jacobian there)
    puts the rods' triangle more than :data:`GROSS_MISMATCH` from the joints', a first fit with every joint on its
    rod (:meth:`~.core_model.CoreModel.joints_on_rods`: the machine family whose triangles are congruent, always a
    valid geometry) over the other fitted parameters gives the start; the held joint coordinates keep its values
    (on their rods), the rest is fitted from there. Returns ``(start, moved, mismatch)``: the start, the held
    parameters it moved, the linearised estimate's mismatch. Only a model with ``joints_on_rods`` and
    ``side_mismatch`` (the core's, and a registration's over it: :class:`~.frames.FramedModel`) takes this path, and
    only with every platform joint ``free``: one left out of the fit stays where the configuration puts it.
    ``progress`` hears the first fit's iterations (:func:`~.fitting.fit_progress`)."""
    on_rods = getattr(model, 'joints_on_rods', None)
    mismatch = getattr(model, 'side_mismatch', None)
    if not (callable(on_rods) and callable(mismatch)) or fit.size == 0:
        return None
    chosen = set(free.tolist())
    if any(p.key == 'platform_joints' and j not in chosen for j, p in enumerate(params)):
        return None
    r0 = residuals(theta0[None])[0].ravel()
    estimate = theta0.copy()
    estimate[fit] = np.clip(theta0[fit] + np.linalg.lstsq(J, -r0, rcond=None)[0] * scale[fit],
                            *(b[fit] for b in params.bounds))
    gross = float(mismatch(estimate))
    if not gross > GROSS_MISMATCH:
        return None
    joints = np.array([params[int(j)].key == 'platform_joints' for j in fit], dtype=bool)
    first = levenberg_marquardt(lambda th: residuals(on_rods(th)), params, theta0, fit[~joints], scale,
                                ON_RODS, progress=fit_progress(progress, ON_RODS, r0.size - int(np.sum(~joints))))
    start = on_rods(first.theta)
    moved = tuple(p.name for j, p in enumerate(params)
                  if j not in fit and p.key == 'platform_joints' and start[j] != theta0[j])
    return start, moved, gross


def noise_origin(kind: str, column: Array | None, given: bool, value: float) -> str:
    """What the sigma ``value`` of a ``kind`` (``position``, ``angle``) is: ``the file's sigma_position`` (its
    ``column``), ``declared`` (``given``: ``--sigma-position``), ``a laser tracker's`` (the defaults
    :data:`DEFAULT_SIGMA_POSITION`, :data:`DEFAULT_SIGMA_ANGLE`) or ``assumed`` (a tolerance table's
    ``measurement_noise``, which declares nothing)."""
    if column is not None:
        return f'the file\'s sigma_{kind}'
    default = DEFAULT_SIGMA_POSITION if kind == 'position' else DEFAULT_SIGMA_ANGLE
    return 'declared' if given else 'a laser tracker\'s' if math.isclose(value, default) else 'assumed'


def assumed_noise(meas: Measurements, residual: Array, w: Array, declared: tuple[bool, bool] = (False, False)
                  ) -> str:
    """The noise the residuals of a fit without a declared noise are judged against, and their RMS per coordinate,
    in words (the gate's message): ``w (N, k)`` the weights ``1 / sigma``, ``residual`` the weighted residuals.
    Each sigma says what it is: the file's column, ``declared``, the defaults (a laser tracker's), or ``assumed``
    (e.g. a tolerance table's ``measurement_noise``, which declares nothing)."""
    e = residual / w
    kinds = [('position', slice(0, 3), 'um', meas.sigma_position, declared[0])]
    if w.shape[1] == 6:
        kinds.append(('angle', slice(3, 6), 'urad', meas.sigma_angle, declared[1]))
    said, origins = [], set()
    for kind, part, unit, column, given in kinds:
        value = 1.0 / float(w[0, part][0])
        rms = f'residuals {1e6 * math.sqrt(float(np.mean(e[:, part] ** 2))):.3g} {unit} RMS per coordinate'
        if column is not None:
            said.append((f'{kind}s the file\'s sigma_{kind}', '', rms))
            continue
        origin = noise_origin(kind, column, given, value)
        origins.add(origin)
        said.append((f'{kind}s {1e6 * value:.3g} {unit}', f' ({origin})', rms))
    if origins == {'a laser tracker\'s'} and all(label for _, label, _ in said):
        return 'a laser tracker\'s: ' + '; '.join(f'{s}, {r}' for s, _, r in said)
    return '; '.join(f'{s}{label}, {r}' for s, label, r in said)


def noise_variances(meas: Measurements, h: Array | None, residual: Array, declared: tuple[bool, bool],
                    absolute: bool) -> Array:
    """Per residual column ``(k,)`` the variance of a weighted residual: 1 for a kind whose sigmas are the noise
    (the file's column, or ``declared``), else its reduced chi-square (:func:`~.quality.kind_variances`): with an
    assumed noise the ratio of position to angle sigmas is assumed too, and one factor for both (the reduced
    chi-square) left the rod directions' standard errors 20 % too small and the rods' 15 % too large when the
    positions' noise was 3 um against the 5 um assumed."""
    k = residual.shape[1]
    if absolute or h is None:
        return np.ones(k)
    known = [meas.sigma_position is not None or declared[0], meas.sigma_angle is not None or declared[1]]
    scaled = kind_variances(h, residual)
    return np.array([1.0 if known[c // 3] else scaled[c] for c in range(k)])


def _gate(best: Minimum, params: ParameterSet, fit: NDArray[np.int64], chi2_red: float, dof: int,
          noise: str | None, cv_ratio: float, names: tuple[str, ...], more: tuple[GateCheck | None, ...],
          spread: str = '', weak: tuple[str, ...] = ()) -> Gate:
    """The gate (:mod:`.quality`); ``noise``: ``None`` when the sigmas are the declared noise, else what the
    residuals are judged against (:func:`assumed_noise`); ``spread``: the residuals' robust scale per kind
    (:func:`~.quality.spread`); ``weak``: :func:`~.quality.weak_at_estimate`'s warning, a cause of no minimum."""
    at = [params[int(j)].name for j in np.flatnonzero(best.at_bound)]
    bounds = f'; parameters at a bound of their range: {", ".join(at)}' if at else ''
    # passed or not by the fit's status (the step left decides it with the way the fit ended): 1 for converged
    checks = [GateCheck('minimum', best.converged, float(best.converged), 1.0,
                        f'The fit did not reach a minimum ({STATUS_WORDS.get(best.status, best.status)} after '
                        f'{best.iterations} iterations, the '
                        f'Gauss-Newton step left {best.step_se:.3g} standard errors{bounds}).'
                        + ''.join(f' Where it stopped, {w}.' for w in weak), at_least=True)]
    worst = worst_rows(best.residual, names)
    limit = chi2_limit(dof)
    point = f'the {100 * CHI2_QUANTILE:g} % point for {dof} degrees of freedom'
    if noise is None:
        scale = f' (robust scale: {spread} sigma)' if spread else ''
        checks.append(GateCheck('chi_square', chi2_red <= limit, chi2_red, limit,
                                f'The model does not explain the measurements: reduced chi-square {chi2_red:.4g} '
                                f'above the gate {limit:.4g} ({point}); largest residuals {worst}{bounds}. '
                                f'Swapped or mis-unit columns, another frame or machine, more noise than declared'
                                f'{scale}, parameters fixed that are off nominal (--free, a tolerance of 0)?'))
    else:
        checks.append(GateCheck('chi_square', chi2_red <= limit, chi2_red, limit,
                                f'The residuals exceed the noise assumed without a declared one ({noise}): reduced '
                                f'chi-square {chi2_red:.4g} above the gate {limit:.4g} ({point}); largest residuals '
                                f'{worst}{bounds}. Columns swapped or in other units, another frame, mismeasured '
                                'rows? Or a noisier instrument: declare its noise (sigma_position and sigma_angle '
                                'columns, --sigma-position and --sigma-angle; a table\'s measurement_noise is only '
                                'assumed).'))
    checks.extend(c for c in more if c is not None)
    checks.append(GateCheck('cross_validation', cv_ratio <= CV_GATE, cv_ratio, CV_GATE,
                            f'Rows left out are predicted {cv_ratio:.3g} times worse than the fit explains them '
                            f'(gate {CV_GATE:g}): some rows are fitted only because they are in the fit; largest '
                            f'residuals {worst}{bounds}.' if not math.isnan(cv_ratio) else
                            'No row can be left out: each alone determines a fitted combination, so no other row '
                            'checks it; allowed: more rows than the fitted parameters need (or fewer parameters '
                            'free).'))
    # what a check found is said where it failed (a passed check's sentence read as a failure in the JSON), and why
    # a check was not judged
    return Gate(tuple(c if not c.passed or not c.judged else replace(c, detail='') for c in checks))


def _identified(model: PoseModel, mask: NDArray[np.bool_], fit: NDArray[np.int64], held: tuple[str, ...]) -> GateCheck:
    """That a free parameter of the machine (before ``n_inner``) is fitted; limit 0 where ``mask`` frees none."""
    inner = int(getattr(model, 'n_inner', len(model.parameters)))
    n, limit = int(np.sum(fit < inner)), float(np.any(mask[:inner]))   # all fixed on purpose: another arm's --free
    free = ', '.join(name for name in held if model.parameters.index(name) < inner)
    return GateCheck('identified', n >= limit, float(n), limit, '' if n >= limit else
                     f'No free parameter of the machine is identifiable from these measurements ({free} held at '
                     'nominal): nothing was calibrated. Measure configurations that move them (gpr calibrate --plan '
                     'N), or free others (--free).', at_least=True)


def identify(model: PoseModel, meas: Measurements, free: Iterable[str] | None = None,
             sigma_position: float = DEFAULT_SIGMA_POSITION, sigma_angle: float = DEFAULT_SIGMA_ANGLE,
             threshold: float = DEFAULT_THRESHOLD, prior: ArrayLike | None = None,
             bound: ArrayLike | None = None, frame: str = 'gpr_base',
             declared: tuple[bool, bool] = (False, False), progress: StageProgress | None = None
             ) -> CalibrationResult:
    """Identify the parameters ``free`` (names or configuration keys; all by default) of ``model`` from ``meas``.

    ``sigma_position`` [m] and ``sigma_angle`` [rad] weight rows without sigma columns, and are their noise where
    ``declared`` (position, angle) says so (``--sigma-position``, ``--sigma-angle``: the whole gate applies), else
    the noise assumed (the gate's chi-square against it, its outliers by the residuals' robust scale);
    ``threshold`` bounds the scaled singular values of the identifiable directions (:mod:`.identifiability`);
    ``prior`` gives the a-priori standard deviations that scale them (:func:`~.model.prior_scale`: a tolerance
    table's, or the parameters' scales) and ``bound`` their worst-case deviations (:func:`~.held.prior_bound`) for
    the bias of the held ones (a failed chi-square names those the table held: :func:`~.held.table_held`);
    ``frame`` names the frame the measurements are in (for messages). ``progress`` hears the share done of each
    stage as it goes: ``identifiability`` (the Jacobian at nominal), each start's iterations
    (:func:`~.fitting.fit_progress`), ``standard errors`` (the Jacobian at the estimate), ``cross-validation``.

    A fit that does not converge is returned with its diagnostics (``convergence``, ``gate``), not raised.

    Raises:
        InputError: too few rows for the free parameters, a row that repeats another to far below the noise
            (:func:`~.repeats.check_repeats`), a pose implausibly far from the nominal model, a bad sigma, an
            unknown parameter name, a fit that leaves the model's domain or explains nothing.
    """
    model = pose_model(model)   # a text or a config raised a bare AttributeError
    if not isinstance(meas, Measurements):
        raise InputError(f'meas = {brief(meas)}; allowed: Measurements (read_measurements)')
    params = model.parameters
    free = free if free is None or isinstance(free, (str, bytes)) else list(free)   # selected twice
    mask = free_of(params, free, prior)   # a tolerance of 0 fixes its parameter
    n_free = int(mask.sum())
    n = len(meas)
    k = 3 if meas.quaternion is None else 6
    if n < least_rows(n_free, k):
        raise InputError(f'{meas.source}: {n} row(s) give {k * n} residuals, too few to identify {n_free} '
                         f'parameters; at least {least_rows(n_free, k)} rows are needed (more for a useful fit)')
    w, absolute = weights(meas, sigma_position, sigma_angle, declared)
    check_repeats(meas, float(np.min(1.0 / w[:, 0])), float(np.min(1.0 / w[:, -1])))
    theta0 = params.nominal
    scale = prior_scale(params, prior)

    def residuals(theta: Array) -> Array:
        return measured_errors(model, meas, theta) * w

    e0 = measured_errors(model, meas, theta0)
    registered = plausible_start(model, meas, theta0, frame)
    free_idx = np.flatnonzero(mask).astype(np.int64)
    tell = reporter(progress)
    J0 = residual_jacobian(residuals, params, theta0, free_idx, scale, lambda share: tell('identifiability', share))
    ident = analyse(J0, [params[int(j)].name for j in free_idx], threshold)
    fit = np.array([params.index(name) for name in ident.identified], dtype=np.int64)
    dof = k * n - fit.size
    try:
        gross = _joints_on_rods(model, params, residuals, theta0, free_idx, fit,
                                J0[:, np.searchsorted(free_idx, fit)], scale, progress)
        starts = _starts(params, theta0, fit) if gross is None else \
            _starts(params, gross[0], fit, ON_RODS) + [('nominal', theta0)]
        if registered is not None:   # the frames' best start under the nominal geometry, and the closed form's
            starts = [(REGISTERED, registered)] + starts
        best, outcomes = minimise(residuals, params, starts, fit, scale, dof, progress)
    except InputError as exc:   # the fit took the geometry to the edge of what a machine file allows
        raise InputError(f'{meas.source}: the fit moved the geometry out of its allowed ranges ({exc}): '
                         f'{NOT_THIS_MACHINE}') from None
    theta, chi2_red = best.theta, best.cost / dof
    known = known_kinds(meas, declared)
    _refuse_far(meas, params, mask, best.residual, dof, known, absolute, lambda: other_reading(model, meas, theta0))
    cov = np.zeros((0, 0))
    se = np.full(len(params), np.nan)
    other = np.flatnonzero(~np.isin(np.arange(len(params)), fit)).astype(np.int64)
    try:
        J = residual_jacobian(residuals, params, theta, np.concatenate([fit, other]), scale,
                              lambda share: tell('standard errors', share))
    except (InputError, ConvergenceError):   # the model cannot be evaluated about the point reached: no statistics
        J = np.full((best.residual.size, len(params)), np.nan)
    Jf, Jh = J[:, :fit.size], J[:, fit.size:]
    h = hat_diagonal(Jf, best.residual.shape)
    variance = noise_variances(meas, h, best.residual, declared, absolute)
    if fit.size and np.all(np.isfinite(Jf)):
        _, s, vt = np.linalg.svd(triangular_factor(Jf))
        Ainv = (vt.T / s ** 2) @ vt
        if not np.all(variance == 1.0):   # the sandwich A^-1 J^T V J A^-1, V each residual's variance
            Ainv = Ainv @ gram(Jf * np.sqrt(np.tile(variance, n))[:, None]) @ Ainv
        cov = Ainv * np.outer(scale[fit], scale[fit])
        se[fit] = np.sqrt(np.diag(cov))
    tell('cross-validation', 0.0)
    cv = cross_validation(Jf, best.residual, w, meas.lines, chi2_red, meas.files)
    tell('cross-validation', 1.0)
    hb = prior_bound(params, scale, bound)
    bias = held_bias(Jf, Jh, fit, other, scale, hb[other], scale[other], params.names)
    held = set(ident.held)
    fitted = set(fit.tolist())
    status = tuple('fitted' if j in fitted else 'held' if p.name in held else 'fixed' for j, p in enumerate(params))
    at = tuple(params[int(j)].name for j in np.flatnonzero(best.at_bound))
    names = meas.row_names
    noise = None if absolute else assumed_noise(meas, best.residual, w, declared)
    # the sigmas check of each kind whose sigmas are given (a sigma_position in mm with no sigma_angle passed), the
    # outliers of the others in units of their own robust scale
    options = [kind for kind in known if getattr(meas, f'sigma_{kind}') is None]   # the options', not a column's
    more = (sigma_check(h, best.residual, known, options) if known else None,
            outlier_check(h, best.residual, names, robust=[kind not in known for kind, _ in KINDS[k]],
                          fitted=fit.size), _identified(model, mask, fit, tuple(ident.held)))
    weak = weak_at_estimate(params, fit, se, scale)
    gate = with_reading(_gate(best, params, fit, chi2_red, dof, noise, cv.ratio, names, more,
                              spread(h, best.residual), weak), model, meas, theta0)   # a hint where far off
    gate = with_table_held(gate, lambda: table_held(params, J0, free_idx, scale, ident, params.select(free), mask))
    warnings = far_from_prior(params, fit, theta, theta0, scale, frame) + weak
    if gross is not None and gross[1] and best.label.startswith(ON_RODS):   # held on their rods, not nominal
        ident = replace(ident, combinations=tuple(replace(c, held_at='its rod\'s place') if c.held in gross[1] else c
                                                  for c in ident.combinations))
        shifts = ', '.join(f'{name} {1e3 * (theta[params.index(name)] - theta0[params.index(name)]):+.3f} mm'
                           for name in gross[1])
        warnings += (f'the rods\' triangle is {100 * gross[2]:.2g} % off the nominal joints\' (a geometry allows '
                     f'{100 * MAX_SIDE_MISMATCH:g} %): the joints\' radial places, which these poses cannot see, are '
                     f'held where a first fit with every joint on its rod put them, not at nominal ({shifts})',)
    return CalibrationResult(parameters=params, estimate=theta, standard_error=se, status=status, fitted=fit,
                             covariance=cov, before=ResidualStats.of(e0, meas.lines, meas.files),
                             after=ResidualStats.of(best.residual / w, meas.lines, meas.files), identifiability=ident,
                             chi2_reduced=chi2_red, absolute_sigma=absolute, iterations=best.iterations, rows=n,
                             source=meas.source, convergence=Convergence(best.status, best.step_se, at, outcomes),
                             cross_validation=cv, bias=bias, gate=gate, lines=meas.lines, files=meas.files,
                             warnings=warnings, declared=known)


__all__ = ['DEFAULT_SIGMA_ANGLE', 'DEFAULT_SIGMA_POSITION', 'CalibrationResult', 'Identifiability', 'ResidualStats',
           'check_sigmas', 'identify']

"""The checks of an accuracy budget's inputs beyond their options (:func:`~.budget.accuracy_budget`): stations a
model of the machine can take, a calibration's covariance, at least one error source. SI units."""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.config import GprConfig
from ..core.ops import ARRAY
from ..core.stroke import STROKE_SLACK, check_stroke
from ..errors import InputError, LimitError, brief
from ..inputs.validation import float_array
from .core_model import TILT_MARGIN, platform_tilts
from .model import PoseModel
from .monte_carlo import Alias, Calibrated
from .tolerances import Tolerance, ToleranceTable

Array = NDArray[np.float64]


def check_stations(model: PoseModel, rods: Array, labels: tuple[str, ...]) -> None:
    """Refuse stations a model of the machine (one with a ``config``, :class:`~.core_model.CoreModel`) cannot take,
    with the core's rules: a rod outside the stroke (:func:`~gpr_kinematics.core.stroke.check_stroke`), rods that
    tilt the platform beyond its tilt limit by more than :data:`~.core_model.TILT_MARGIN` (the rule of measured
    configurations, :func:`~.core_model.check_limits`): the budget of a pose the machine never takes is no number
    of it."""
    config = getattr(model, 'config', None)
    if not isinstance(config, GprConfig):   # a model without a machine's limits
        return
    lo, hi = config.stroke_min - STROKE_SLACK, config.stroke_max + STROKE_SLACK
    for i in np.flatnonzero(~np.all((rods >= lo) & (rods <= hi), axis=1))[:1]:   # the first station outside, by name
        try:
            check_stroke(ARRAY, [rods[i:i + 1, 0], rods[i:i + 1, 1], rods[i:i + 1, 2]], config, what='q', typed=True)
        except LimitError as exc:
            raise LimitError(f'station {labels[i]}: {exc}') from None
    tilt = platform_tilts(rods, config)
    bad = np.flatnonzero(~(tilt <= TILT_MARGIN * config.tilt_limit))
    if bad.size:
        i, limit = int(bad[0]), config.tilt_limit
        raise LimitError(f'station {labels[i]}: q = {rods[i].tolist()} m tilt the platform by {tilt[i]:.4g} rad '
                         f'({np.degrees(tilt[i]):.4g} deg), beyond the tilt limit {limit:.4g} rad '
                         f'({np.degrees(limit):.4g} deg); allowed: at most {100 * (TILT_MARGIN - 1):.0f} % beyond it, '
                         f'{TILT_MARGIN * limit:.4g} rad')


def check_calibrated(calibrated: Any, P: int) -> Calibrated:
    """``(indices, covariance)`` or ``(indices, covariance, alias)`` of calibrated parameters, checked: distinct
    indices below ``P``, a finite, symmetric, positive semi-definite covariance of matching size; ``alias``: ``None``
    or ``(held_indices, A)`` (:attr:`~.plan.MeasurementPlan.alias`), distinct indices below ``P`` that are not
    calibrated and a finite ``A`` of shape ``(calibrated, held)``."""
    if isinstance(calibrated, (str, bytes)) or not isinstance(calibrated, Sequence) or len(calibrated) not in (2, 3):
        raise InputError(f'calibrated = {brief(calibrated)}; allowed: a pair (indices, covariance) of the calibrated '
                         'parameters (e.g. CalibrationResult.fitted and .covariance), or a triple (indices, '
                         'covariance, (held_indices, alias)) with the alias of the held parameters (e.g. a '
                         'MeasurementPlan\'s)')
    idx = _indices(calibrated[0])
    cov = float_array(calibrated[1], 'calibrated covariance', 'a finite symmetric matrix')
    if idx.dtype.kind not in 'iu' or len(set(idx.tolist())) != idx.size or np.any((idx < 0) | (idx >= P)):
        raise InputError(f'calibrated parameter indices must be distinct integers from 0 to {P - 1}')
    if cov.shape != (idx.size, idx.size) or not np.all(np.isfinite(cov)) or \
            np.max(np.abs(cov - cov.T), initial=0.0) > 1e-9 * np.max(np.abs(cov), initial=0.0):
        raise InputError(f'calibrated covariance must be a finite symmetric ({idx.size}, {idx.size}) matrix, '
                         f'got shape {cov.shape}')
    if idx.size and np.linalg.eigvalsh(cov)[0] < -1e-9 * max(float(np.max(np.diag(cov))), 1e-300):
        raise InputError('calibrated covariance is not positive semi-definite')
    alias = None if len(calibrated) == 2 or calibrated[2] is None else _alias(calibrated[2], idx, P)
    return idx.astype(np.int64), cov, alias


def _indices(value: Any) -> NDArray[Any]:
    try:
        return np.asarray(value).ravel()
    except (TypeError, ValueError):   # a ragged list
        return np.array([], dtype=float)


def _alias(alias: Any, idx: NDArray[Any], P: int) -> Alias:
    """``(held_indices, A)`` of :func:`check_calibrated`, checked."""
    if isinstance(alias, (str, bytes)) or not isinstance(alias, Sequence) or len(alias) != 2:
        raise InputError(f'calibrated alias = {brief(alias)}; allowed: None or a pair (held_indices, A) with A of '
                         f'shape ({idx.size}, number of held parameters) (MeasurementPlan.held_indices and .alias)')
    held = _indices(alias[0])
    if held.dtype.kind not in 'iu' or len(set(held.tolist())) != held.size or np.any((held < 0) | (held >= P)):
        raise InputError(f'held parameter indices of the calibrated alias must be distinct integers from 0 to {P - 1}')
    both = sorted(set(held.tolist()) & set(idx.tolist()))
    if both:
        raise InputError(f'held parameter indices of the calibrated alias {both} are calibrated as well; allowed: '
                         'parameters the calibration holds (not fitted)')
    A = float_array(alias[1], 'calibrated alias', f'a finite ({idx.size}, {held.size}) matrix')
    if A.shape != (idx.size, held.size) or not np.all(np.isfinite(A)):
        raise InputError(f'calibrated alias must be a finite ({idx.size}, {held.size}) matrix (calibrated x held '
                         f'parameters), got shape {A.shape}' + ('' if A.shape != (idx.size, held.size) else
                                                                ' with values not finite'))
    return held.astype(np.int64), A


def check_sources(table: ToleranceTable, tols: list[Tolerance | None], cal: Calibrated | None) -> None:
    """Refuse a budget without any error source: a table without a parameter tolerance above 0 for the model, a
    rod-length error or joint play (``parameters: {}``: meaningful for ``gpr calibrate``, its measurement noise
    alone), and no calibration's covariance; its budget is 0 everywhere, which a machine never is."""
    if any(t is not None for t in tols) or table.rod_length is not None or max(table.joint_clearance) > 0 or (
            cal is not None and cal[0].size):
        return
    what = 'parameters: {}' if not table.entries else 'no tolerance above 0 in parameters'
    raise InputError(f'{table.source}: no error source for the accuracy budget ({what}, no rod_length, no '
                     'joint_clearance): every error would be 0; allowed: a table with at least one of a parameter\'s '
                     'tolerance > 0 or range (e.g. parameters: {rod_offsets: {tolerance: 5.0e-5}}), rod_length, '
                     'joint_clearance, or a calibration (--calibration-plan N)')

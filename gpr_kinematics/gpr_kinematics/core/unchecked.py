"""Rods far outside the limits (``check_limits=False``): the refusals of forward kinematics where floats or the
closure give no pose, one path's (one pose) as the other's (a batch). Lengths in metres.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from ..errors import ConvergenceError, InputError, apart
from ..inputs.validation import MAX_COORDINATE
from .config import GprConfig
from .ops import Ops, Value
from .stroke import q_rows

#: Rod lengths: three floats, or three columns.
Rods = TypeVar('Rods', bound=Sequence[Value])


def check_bound(ops: Ops, q: Rods, what: str = 'q') -> Rods:
    """Refuse rods beyond +-:data:`~gpr_kinematics.inputs.validation.MAX_COORDINATE` [m], the bound of every joint
    value, where the limits are not checked (``check_limits=False``): floats keep no faithful pose there (rods of
    1e308 m gave an infinite position), as the state publisher leaves such rods out. Returns ``q``."""
    big = MAX_COORDINATE
    if not ops.any((ops.fabs(q[0]) > big) | (ops.fabs(q[1]) > big) | (ops.fabs(q[2]) > big)):
        return q
    rods = q_rows(q)
    i, k = np.argwhere(np.abs(rods) > big)[0]
    where = f' (sample {i})' if rods.shape[0] > 1 else ''
    shown, bound = apart(abs(float(rods[i, k])), big)   # 1000000.1 was written 1e+06, as its bound
    sign = '-' if rods[i, k] < 0 else ''
    raise InputError(f'{what}{k + 1} = {sign}{shown} m{where} is beyond the bound of any joint value; allowed: '
                     f'|{what}| <= {bound} m (check_limits=False skips the stroke and the tilt limit, not this bound)')


def turned_over(model: str, config: GprConfig, q: list[float], trace: float, sample: int | None = None
                ) -> ConvergenceError:
    """The refusal of rods whose closure turned the platform over (a rotation's trace ``<= -1``: no quaternion, no
    tilt; rods far outside the limits, ``check_limits=False``), one path's as the other's."""
    where = '' if sample is None else f' (sample {sample})'
    return ConvergenceError(f'virtual-joint closure ({model}) did not converge for q = {q} m{where}: it turned the '
                            f'platform over (its rotation\'s trace {trace:.6g} <= -1: no pose; the limits were not '
                            f'checked; the stroke is [{config.stroke_min:g}, {config.stroke_max:g}] m)')


def check_turned_over(model: str, config: GprConfig, q: NDArray[np.float64], rotation: NDArray[np.float64]) -> None:
    """Refuse the first sample of rods ``q (N, 3)`` whose closure turned the platform over (its ``rotation``'s trace
    ``<= -1`` or NaN; :func:`turned_over`)."""
    trace = np.trace(rotation, axis1=1, axis2=2)
    for i in map(int, np.flatnonzero(~(1.0 + trace > 0.0))[:1]):
        raise turned_over(model, config, q[i].tolist(), float(trace[i]), i if len(q) > 1 else None)


def singular(exc: BaseException) -> bool:
    """Whether ``exc`` is a :func:`not_converged` whose last step was not finite (its error NaN)."""
    return isinstance(exc, ConvergenceError) and exc.error is not None and math.isnan(exc.error)


def singular_step(model: str, config: GprConfig, q: list[float], sample: int | None = None) -> ConvergenceError:
    """The refusal of rods whose closure took a step that was not finite (a singular Newton step: rods far outside
    the limits, ``check_limits=False``), one path's as the other's."""
    where = '' if sample is None else f' (sample {sample})'
    return ConvergenceError(f'virtual-joint closure ({model}) did not converge for q = {q} m{where}: a Newton step '
                            f'was singular (no finite step; the limits were not checked; the stroke is '
                            f'[{config.stroke_min:g}, {config.stroke_max:g}] m)', sample, math.nan)

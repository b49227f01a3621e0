"""The stroke of the rods: the one check of rod lengths against ``[stroke_min, stroke_max]`` and its words.

Forward kinematics (:mod:`gpr_kinematics.core.forward`), inverse kinematics' answers, the accuracy budget and the
robot's paths (rods named by the robot: ``rod_1``; a joint table's row with its file and line) refuse a rod
length here, so that one rule and one message serve them all. Lengths in metres.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np
from numpy.typing import NDArray

from ..errors import LimitError, apart
from .config import GprConfig
from .ops import Ops, Value

#: Margin [m] by which a rod length may leave the stroke (rounding).
STROKE_SLACK = 1e-12
#: True while the lengths checked were given in millimetres (``gpr ... --mm``): no hint then says "millimetres given
#: as metres?" of a value 1000 times too large (:func:`typed_in_millimetres`).
_TYPED_IN_MILLIMETRES: ContextVar[bool] = ContextVar('typed_in_millimetres', default=False)


@contextmanager
def typed_in_millimetres(on: bool) -> Iterator[None]:
    """Within it (``on``), :func:`within_as_millimetres` holds of no value: the lengths were typed in millimetres,
    and a value 1000 times too large cannot be millimetres typed as metres."""
    token = _TYPED_IN_MILLIMETRES.set(on)
    try:
        yield
    finally:
        _TYPED_IN_MILLIMETRES.reset(token)


def lengths_in_millimetres() -> bool:
    """Whether the lengths checked now were typed in millimetres (within :func:`typed_in_millimetres`): a refusal
    names them in mm beside the metres."""
    return _TYPED_IN_MILLIMETRES.get()


def q_rows(q: Sequence[Value]) -> NDArray[np.float64]:
    """Rod lengths as an array ``(N, 3)`` for messages (from floats or columns)."""
    return np.atleast_2d(np.stack([np.asarray(v, dtype=float) for v in q], axis=-1))


def within_as_millimetres(value: float, lo: float, hi: float) -> bool:
    """A length ``value`` [m] far outside ``[lo, hi]`` (ten times its largest end) that would lie within it read as
    millimetres (250 for 0.25 m; not 0.6 m for a stroke of 0.508 m): the rule of every hint that a length was typed
    in mm (a rod, a platform height, a goal's joint); never within :func:`typed_in_millimetres`."""
    return not _TYPED_IN_MILLIMETRES.get() and abs(value) > 10.0 * max(abs(lo), abs(hi)) and lo <= value / 1000.0 <= hi


def millimetres_within(value: float, config: GprConfig) -> bool:
    """:func:`within_as_millimetres` of a rod length ``value`` [m] and the stroke."""
    return within_as_millimetres(value, config.stroke_min - STROKE_SLACK, config.stroke_max + STROKE_SLACK)


def check_stroke(ops: Ops, q: Sequence[Value], config: GprConfig, what: str = 'q', typed: bool = False,
                 detail: Callable[[int, int], str] | None = None, names: Sequence[str] | None = None) -> None:
    """Refuse rods outside ``[stroke_min, stroke_max]`` (+- :data:`STROKE_SLACK`) naming rod (``what`` and number, or
    ``names``) and sample; ``typed``: a user's (a value within as millimetres says so); ``detail(i, k)``: of sample
    i's rod k."""
    lo, hi = config.stroke_min - STROKE_SLACK, config.stroke_max + STROKE_SLACK
    if not ops.any((q[0] < lo) | (q[0] > hi) | (q[1] < lo) | (q[1] > hi) | (q[2] < lo) | (q[2] > hi)):
        return
    rods = q_rows(q)
    i, k = np.argwhere((rods < lo) | (rods > hi))[0]
    where = f' (sample {i})' if rods.shape[0] > 1 else ''
    value = float(rods[i, k])
    hint = ''
    if typed and _TYPED_IN_MILLIMETRES.get():   # named as typed too: 300000 mm was told "q1 = 300 m" alone
        hint = (f' ({value * 1000.0:.9g} mm as typed; the stroke is [{config.stroke_min * 1000.0:g}, '
                f'{config.stroke_max * 1000.0:g}] mm)')
    elif typed and millimetres_within(value, config):
        hint = f'; {value:.9g} mm would be within it: millimetres given as metres?'
    more = '' if detail is None else detail(int(i), int(k))
    shown, ends = stroke_words(value, config.stroke_min, config.stroke_max)
    raise LimitError(f'{names[k] if names else f"{what}{k + 1}"} = {shown} m{where} is outside the stroke {ends} m'
                     f'{hint}{more}')


def stroke_words(value: float, lo: float, hi: float) -> tuple[str, str]:
    """A rod length outside the stroke ``[lo, hi]`` [m] and the stroke, as a refusal prints them: the value and the
    end it passed told apart (:func:`~gpr_kinematics.errors.apart`; "0.508 m is outside [0, 0.508] m" had
    contradicted itself)."""
    low = value < lo
    shown, end = apart(value, lo if low else hi, 9)
    return shown, f'[{end}, {hi:g}]' if low else f'[{lo:g}, {end}]'

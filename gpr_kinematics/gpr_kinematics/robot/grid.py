"""The instants at which a motion is sampled at a rate: one rule for a robot program's samples
(:func:`~gpr_kinematics.robot.timing.sample_times`), a platform program's
(:func:`~gpr_kinematics.robot.platform_program.sample_program`) and a trajectory goal's
(:func:`~gpr_kinematics.robot.controller.plan_motion`)."""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, brief
from ..inputs.validation import plain_number

#: The sample rates [Hz] a program is sampled at (a sample every 0.2 ms to every 10 s): the rates trajectory_node
#: publishes at, too (its parameter ``rate``).
RATES = (0.1, 5000.0)
#: What :data:`RATES` allows, in words (the messages of a rate and a typed ``--rate``).
RATES_ALLOWED = f'{RATES[0]:g} <= rate <= {RATES[1]:g} Hz (a sample every 0.2 ms to every 10 s)'


def lower_rate(rate: float) -> str:
    """The end of a refusal of too many samples at ``rate`` [Hz]: lower it, or, at the lowest of :data:`RATES`,
    split the program (it said "lower the rate" at 0.1 Hz)."""
    return ('; lower the rate' if rate > RATES[0] else f'; {RATES[0]:g} Hz is the lowest rate: split the program into '
            'shorter ones')


def check_rate(rate: object) -> float:
    """``rate`` [Hz] as a float within :data:`RATES`; :class:`InputError` naming it and the range otherwise."""
    value = plain_number(rate)
    if not RATES[0] <= value <= RATES[1]:
        raise InputError(f'rate = {brief(rate)} is invalid; allowed: {RATES_ALLOWED}')
    return value


def grid_times(total: float, rate: float) -> NDArray[np.float64]:
    """The instants of a motion of ``total`` [s] sampled at ``rate`` [Hz]: ``t_k = k / rate`` for ``k = 0 ..
    floor(total rate)`` and the end, ``total`` itself: appended when it lies more than 1 ns after the last ``t_k``
    (or the motion is shorter than that), else the last ``t_k`` is the end (a sample within 1 ns of the end, before
    or after it, is the end: never a sample past it). The caller bounds the count
    (:data:`~gpr_kinematics.robot.timing.MAX_SAMPLES`).

    >>> grid_times(0.25, 10.0).tolist(), grid_times(0.3, 10.0).tolist()[-2:], grid_times(1e-12, 10.0).tolist()
    ([0.0, 0.1, 0.2, 0.25], [0.2, 0.3], [0.0, 1e-12])
    >>> float(grid_times(0.3 - 1e-12, 10.0)[-1]) == 0.3 - 1e-12   # floor(total rate) was 3: t_3 = 0.3 past the end
    True
    """
    n = int(math.floor(total * rate + 1e-9))
    t = np.arange(n + 1, dtype=float) / rate
    if total - t[-1] > 1e-9 or (n == 0 and total > 0.0):
        return np.append(t, total)
    t[-1] = total
    return t


def grid_count(total: float, rate: float) -> int:
    """How many instants :func:`grid_times` gives for ``total`` [s] at ``rate`` [Hz], counted without making them (the
    bound :data:`~gpr_kinematics.robot.timing.MAX_SAMPLES` is checked before any array): ``2**53`` for a motion
    beyond the floats' integers (and NaN).

    >>> [grid_count(t, 10.0) == len(grid_times(t, 10.0)) for t in (0.0, 1e-12, 0.25, 0.3, 0.3 - 1e-12, 1999.99)]
    [True, True, True, True, True, True]
    """
    x = total * rate + 1e-9
    if not x < 2.0 ** 53:
        return 2 ** 53
    n = int(math.floor(x))
    return n + 1 + int(total - n / rate > 1e-9 or (n == 0 and total > 0.0))


def _first_k(x: float, rate: float, top: int, after: bool) -> int:
    """The smallest ``k`` in ``0 .. top + 1`` whose ``k / rate`` (as :func:`grid_times` computes it) is ``> x``
    (``after``) or ``>= x``; ``top + 1`` where none is. From the estimate ``ceil(x rate)``, corrected one step at a
    time (``k / rate`` rises with ``k``: a step or two)."""
    k = min(max(math.ceil(x * rate), 0), top + 1)
    while k > 0 and ((k - 1) / rate > x if after else (k - 1) / rate >= x):
        k -= 1
    while k <= top and not (k / rate > x if after else k / rate >= x):
        k += 1
    return k


def grid_between(total: float, rate: float, a: float, b: float, closed: bool) -> tuple[int, int, bool]:
    """The samples of :func:`grid_times` ``(total, rate)`` in ``[a, b]`` (``closed``) or ``(a, b)`` [s], without making
    them (a hold of 1e6 s): ``k / rate`` for ``k`` in ``range(lo, hi)``, and whether the end sample (``total``) is one.

    >>> grid_between(6.6, 3.0, 3.666666666666667, 6.333333333433334, True)   # 4.0 .. 6.333 (11 / 3 < a)
    (12, 20, False)
    >>> grid_between(0.9999999999995, 1.0, 0.0, 0.9999999999995, True)      # 0.0 and the end
    (0, 1, True)
    """
    n = int(math.floor(total * rate + 1e-9))
    top = n if total - n / rate > 1e-9 or (n == 0 and total > 0.0) else n - 1   # sample n is total itself otherwise
    lo, hi = _first_k(a, rate, top, not closed), _first_k(b, rate, top, closed)
    end = a <= total <= b if closed else a < total < b
    return lo, max(hi, lo), end

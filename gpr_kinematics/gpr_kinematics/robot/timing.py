"""Time parameterisation of joint-space moves within velocity and acceleration limits, and sampling.

A move from joint values ``P_i`` to ``P_{i+1}`` (rods and arm joints together) follows the straight line
``P(t) = P_i + s(t) (P_{i+1} - P_i)`` with one normalised profile ``s`` for all joints, so they start and stop
together. ``s`` is a trapezoid in velocity: constant acceleration ``A``, cruise at ``V``, constant deceleration.
Joint ``k`` then moves at ``|D_k| V`` and accelerates at ``|D_k| A``, so the limits ``v_k``, ``a_k`` hold when

    ``V <= min_k v_k / |D_k|``,  ``A <= min_k a_k / |D_k|``.

The shortest such move takes ``T_min = 1/V + V/A`` (with a cruise phase, when ``V^2 <= A``) or ``2 / sqrt(A)``
(a triangle). A requested duration ``T >= T_min`` keeps the acceleration ``A`` and cruises at
``V' = (A T - sqrt(A^2 T^2 - 4 A)) / 2`` (the root of ``V' T - V'^2 / A = 1``); a shorter one is refused, naming
the joint that limits it. Linear interpolation keeps every joint within its range and, since the naive platform
normal is linear in the rods, the platform within the tilt limit of its end points.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, LimitError

Array = NDArray[np.float64]

#: Joint changes below this [m or rad] do not move (and do not limit) a joint.
STILL = 1e-15
#: Most samples a program may be sampled into: a sample costs about 1.8 kB until its table is written (its forward
#: kinematics and a row of Python numbers), 0.36 GB at the limit (5,000,000 asked for 9 GB).
MAX_SAMPLES = 200_000
#: The sample rates [Hz] a program is sampled at (a sample every 0.2 ms to every 10 s): the rates trajectory_node
#: publishes at, too (its parameter ``rate``).
RATES = (0.1, 5000.0)


def check_rate(rate: object) -> float:
    """``rate`` [Hz] as a float within :data:`RATES`; :class:`InputError` naming it and the range otherwise."""
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not RATES[0] <= rate <= RATES[1]:
        raise InputError(f'rate = {rate!r} is invalid; allowed: {RATES[0]:g} <= rate <= {RATES[1]:g} Hz (a sample '
                         'every 0.2 ms to every 10 s)')
    return float(rate)


@dataclass(frozen=True)
class Timing:
    """Waypoints in time.

    Attributes:
        positions: joint values at the waypoints ``(W, J)``; arrive, depart: times [s] ``(W,)``.
        duration: of the move into waypoint ``i + 1`` ``(W - 1,)`` [s]; speed, accel: its profile's ``V'`` and ``A``
            [1/s, 1/s^2] (``inf`` for a move that moves nothing).
        velocity, acceleration: the joints' limits ``(J,)``.
    """

    positions: Array
    arrive: Array
    depart: Array
    duration: Array
    speed: Array
    accel: Array
    velocity: Array
    acceleration: Array

    @property
    def total(self) -> float:
        """Duration of the whole program [s]."""
        return float(self.depart[-1])

    def usage(self) -> tuple[Array, Array]:
        """Per joint, the largest speed and acceleration reached as a fraction of its limit ``(J,)``."""
        D = np.abs(np.diff(self.positions, axis=0))
        moving = D > STILL
        v = np.where(moving, D * np.where(np.isfinite(self.speed), self.speed, 0.0)[:, None], 0.0)
        a = np.where(moving, D * np.where(np.isfinite(self.accel), self.accel, 0.0)[:, None], 0.0)
        if D.shape[0] == 0:
            return np.zeros(self.velocity.shape), np.zeros(self.velocity.shape)
        return np.max(v, axis=0) / self.velocity, np.max(a, axis=0) / self.acceleration


def shortest(D: Array, velocity: Array, acceleration: Array) -> tuple[Array, Array, Array]:
    """For moves ``D (M, J)``: the profile limits ``V``, ``A`` and the shortest duration ``T_min`` ``(M,)``."""
    aD = np.abs(D)
    moving = aD > STILL
    with np.errstate(divide='ignore'):
        V = np.min(np.where(moving, velocity / np.where(moving, aD, 1.0), np.inf), axis=1)
        A = np.min(np.where(moving, acceleration / np.where(moving, aD, 1.0), np.inf), axis=1)
    still = ~moving.any(axis=1)
    cruise = V * V <= A
    with np.errstate(invalid='ignore', divide='ignore'):
        T = np.where(cruise, 1.0 / V + V / A, 2.0 / np.sqrt(A))
    return V, A, np.where(still, 0.0, T)


def joint_time(d: Array, v: Array, a: Array) -> Array:
    """Shortest time of each joint's move alone (for messages): ``d/v + v/a`` or ``2 sqrt(d/a)``."""
    d = np.abs(d)
    return np.where(d * a >= v * v, d / v + v / a, 2.0 * np.sqrt(d / a))


def parameterise(positions: Array, velocity: Array, acceleration: Array, requested: Array, dwell: Array,
                 names: tuple[str, ...], labels: tuple[str, ...]) -> Timing:
    """Time the moves between waypoints ``positions (W, J)``.

    Args:
        requested: duration [s] of the move into each waypoint ``(W,)``, NaN for the shortest (the first unused).
        dwell: time held at each waypoint ``(W,)`` [s].
        names: the joints' names; labels: how messages name each waypoint.

    Raises:
        LimitError: a requested duration shorter than the limits allow (the move, the duration, the joint).
    """
    W = positions.shape[0]
    if W == 0:
        raise InputError('a program needs at least one waypoint')
    D = np.diff(positions, axis=0)
    V, A, T_min = shortest(D, velocity, acceleration)
    req = requested[1:]
    given = np.isfinite(req)
    short = given & (req < T_min * (1.0 - 1e-12))
    if short.any():
        i = int(np.argmax(short))
        t = joint_time(D[i], velocity, acceleration)
        k = int(np.argmax(t))
        raise LimitError(f'the move into {labels[i + 1]} needs at least {T_min[i]:.4g} s within the limits, time = '
                         f'{req[i]:.4g} s is too short ({names[k]} alone needs {t[k]:.4g} s at {velocity[k]:g} /s and '
                         f'{acceleration[k]:g} /s^2)')
    T = np.where(given, req, T_min)
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        disc = np.maximum(A * A * T * T - 4.0 * A, 0.0)
        speed = np.where(given & np.isfinite(A), (A * T - np.sqrt(disc)) / 2.0, V)
    arrive = np.concatenate([[0.0], np.cumsum(dwell[:-1] + T)])
    return Timing(positions, arrive, arrive + dwell, T, speed, A, velocity, acceleration)


def profile(tau: Array, T: Array, V: Array, A: Array) -> Array:
    """The normalised trapezoid ``s(tau)`` in [0, 1] of moves of durations ``T`` (module docstring)."""
    with np.errstate(invalid='ignore', divide='ignore'):
        ta = np.where(np.isfinite(A), np.minimum(V / A, T / 2.0), 0.0)
        up = 0.5 * A * tau * tau
        cruise = V * (tau - 0.5 * ta)
        down = 1.0 - 0.5 * A * (T - tau) ** 2
        s = np.where(tau < ta, up, np.where(tau <= T - ta, cruise, down))
    return np.clip(np.where(np.isfinite(A) & (T > 0), s, 1.0), 0.0, 1.0)


@dataclass(frozen=True)
class Samples:
    """A program sampled in time: ``time (S,)`` [s], joint values ``positions (S, J)``, the waypoint held
    (``-1`` while moving) and the waypoint being moved to or held ``target (S,)``."""

    time: Array
    positions: Array
    held: NDArray[np.int64]
    target: NDArray[np.int64]

    def __len__(self) -> int:
        return int(self.time.shape[0])


def sample(timing: Timing, rate: float) -> Samples:
    """Samples at ``t_k = k / rate`` for ``k = 0 .. floor(total rate)``, plus the final instant."""
    rate = check_rate(rate)
    total = timing.total
    count = int(math.floor(total * rate + 1e-9)) + 1
    if count > MAX_SAMPLES:
        raise InputError(f'the program lasts {total:.6g} s: at {rate:g} Hz that is {count} samples; allowed: at most '
                         f'{MAX_SAMPLES}; lower the rate')
    t = np.arange(count, dtype=float) / rate
    if total - t[-1] > 1e-9:
        t = np.append(t, total)
    i = np.clip(np.searchsorted(timing.arrive, t, side='right') - 1, 0, len(timing.arrive) - 1)
    held = t <= timing.depart[i] + 1e-12
    last = len(timing.arrive) - 1
    m = np.minimum(i, max(last - 1, 0))
    if last == 0:
        return Samples(t, np.repeat(timing.positions, t.shape[0], axis=0), np.zeros(t.shape, dtype=np.int64),
                       np.zeros(t.shape, dtype=np.int64))
    s = profile(t - timing.depart[m], timing.duration[m], timing.speed[m], timing.accel[m])
    D = np.diff(timing.positions, axis=0)
    pos = np.where(held[:, None], timing.positions[i], timing.positions[m] + s[:, None] * D[m])
    return Samples(t, pos, np.where(held, i, -1), np.where(held, i, m + 1))

"""Time parameterisation of the moves between waypoints within velocity, acceleration and jerk limits; sampling.

A move from joint values ``P_i`` to ``P_{i+1}`` (rods and arm joints together) follows a path ``P(s)``, ``s`` from 0
to 1, with one normalised profile ``s(t)`` for all joints, so they start and stop together: the straight line
``P_i + s (P_{i+1} - P_i)`` in joint space, or (a straight entry, :mod:`gpr_kinematics.robot.paths`) the joints that
keep the wafer on a line. ``s`` is an **S-curve**: the jerk ``+-J`` ramps the acceleration up to at most ``A`` and
down, the speed cruises at ``V``, and the braking mirrors the start; without a jerk limit (``J = inf``) it is the
trapezoid (constant acceleration). With ``G1_k = max |dP_k/ds|`` along the path (``|D_k|`` on a joint-space line)
and, on a curved path, ``G2_k = max |d^2P_k/ds^2|``, ``G3_k = max |d^3P_k/ds^3|``, the joint's velocity, acceleration
and jerk are at most ``G1 V``, ``G1 A + G2 V^2`` and ``G1 J + 3 G2 V A + G3 V^3`` (chain rule); the profile takes
``V = min_k v_k / G1_k``, ``A = min_k a_k / G1_k``, ``J = min_k j_k / G1_k`` on a joint-space line and, on a curved
path, the ``(V, A, J)`` of the shortest move for which the three bounds hold (:func:`fastest_limits`), so that no
higher limit lengthens a move.

Profile of a unit move (``v`` the cruise speed reached, ``t_a`` the time to reach it, ``d_a = v t_a / 2`` the
distance then): with ``v J >= A^2`` the acceleration saturates, ``t_a = v/A + A/J``; else it peaks at
``sqrt(v J)``, ``t_a = 2 sqrt(v/J)``. ``v = V`` when ``V t_a(V) <= 1`` (then a cruise of ``(1 - V t_a)/V``), else the
root of ``v t_a(v) = 1``: ``v = A (sqrt(A^2/J^2 + 4/A) - A/J) / 2`` or ``(J/4)^(1/3)``. The duration is
``2 t_a + cruise``; with ``J = inf``, ``1/V + V/A`` or ``2/sqrt(A)`` (a triangle), the trapezoid's. A requested
duration ``T >= T_min`` keeps ``A`` and ``J`` and lowers the cruise speed until the duration is ``T`` (closed form
for the trapezoid, ``V' = (A T - sqrt(A^2 T^2 - 4 A)) / 2``; bisection for the S-curve); a shorter one is refused,
naming the joint that limits it. docs/robot.md compares the S-curve's durations with the trapezoid's.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, LimitError
from .grid import check_rate, grid_count, grid_times, lower_rate

Array = NDArray[np.float64]

#: Joint changes below this [m or rad] do not move (and do not limit) a joint.
STILL = 1e-15
#: Most samples a program may be sampled into: a sample costs about 1.8 kB until its table is written (its forward
#: kinematics and a row of Python numbers), 0.36 GB at the limit (5,000,000 asked for 9 GB).
MAX_SAMPLES = 200_000
@dataclass(frozen=True)
class Profiles:
    """The unit S-curves of ``M`` moves: cruise speed ``v`` [1/s] and peak acceleration ``a`` [1/s^2] reached, jerk
    ``j`` [1/s^3] (``inf``: a trapezoid), the jerk phases' ``tj``, the constant acceleration's ``tc``, the time ``ta``
    to reach ``v`` and the duration ``T`` [s] (``(M,)`` each)."""

    v: Array
    a: Array
    j: Array
    tj: Array
    tc: Array
    ta: Array
    T: Array


def _accel_time(v: Array, A: Array, J: Array) -> tuple[Array, Array, Array]:
    """``(tj, tc, a_peak)`` of the acceleration phase up to ``v`` (module docstring)."""
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        sat = v * J >= A * A
        tj = np.where(np.isinf(J), 0.0, np.where(sat, A / J, np.sqrt(v / J)))
        tc = np.where(sat, v / A - np.where(np.isinf(J), 0.0, A / J), 0.0)
        peak = np.where(sat, A, np.sqrt(v * J))
    return np.maximum(tj, 0.0), np.maximum(tc, 0.0), peak


def unit_profiles(V: Array, A: Array, J: Array) -> Profiles:
    """The shortest unit S-curves within ``V``, ``A``, ``J`` (``inf`` where the move is still: duration 0)."""
    V, A, J = (np.asarray(x, dtype=float) for x in (V, A, J))
    still = ~np.isfinite(V) | ~np.isfinite(A)
    Vs, As = np.where(still, 1.0, V), np.where(still, 1.0, A)
    tj, tc, _ = _accel_time(Vs, As, J)
    cruise = Vs * (2 * tj + tc) <= 1.0
    with np.errstate(invalid='ignore', divide='ignore'):
        r = np.where(np.isinf(J), 0.0, As / J)
        v_sat = As * (np.sqrt(r * r + 4.0 / As) - r) / 2.0
        v_tri = np.cbrt(np.where(np.isinf(J), 1.0, J) / 4.0)
    v = np.where(cruise, Vs, np.where(v_sat * np.where(np.isinf(J), np.inf, J) >= As * As, v_sat, v_tri))
    return _with_speed(v, As, J, still)


def _with_speed(v: Array, A: Array, J: Array, still: NDArray[np.bool_]) -> Profiles:
    tj, tc, peak = _accel_time(v, A, J)
    ta = 2 * tj + tc
    with np.errstate(invalid='ignore', divide='ignore'):
        T = 2 * ta + np.maximum(1.0 - v * ta, 0.0) / v
    return Profiles(np.where(still, np.inf, v), np.where(still, np.inf, peak), J, np.where(still, 0.0, tj),
                    np.where(still, 0.0, tc), np.where(still, 0.0, ta), np.where(still, 0.0, T))


def stretched(p: Profiles, A: Array, J: Array, T: Array) -> Profiles:
    """Profiles of durations ``T >= p.T`` with the same ``A``, ``J`` and a lower cruise speed."""
    A, J, T = np.asarray(A, float), np.asarray(J, float), np.asarray(T, float)
    with np.errstate(invalid='ignore'):
        disc = np.maximum(A * A * T * T - 4.0 * A, 0.0)
        v = (A * T - np.sqrt(disc)) / 2.0       # the trapezoid's closed form (J = inf)
    lo, hi = np.zeros_like(T), np.where(np.isfinite(p.v), p.v, 0.0)
    for _ in range(80):  # the S-curve: duration decreases with the cruise speed
        mid = 0.5 * (lo + hi)
        slow = _with_speed(mid, A, J, np.zeros(T.shape, dtype=bool)).T > T
        lo, hi = np.where(slow, mid, lo), np.where(slow, hi, mid)
    v = np.where(np.isinf(J), v, hi)
    return _with_speed(v, A, J, ~np.isfinite(p.v))


def evaluate(p: Profiles, m: NDArray[np.int64], tau: Array) -> tuple[Array, Array, Array]:
    """``s``, ``ds/dt``, ``d^2s/dt^2`` of moves ``m`` at times ``tau`` [s] after their start (clipped to the move)."""
    T = p.T[m]
    tau = np.clip(tau, 0.0, T)
    back = tau > 0.5 * T
    u = np.where(back, T - tau, tau)                # the braking half mirrors the start
    v, a, j, tj, tc, ta = (x[m] for x in (p.v, p.a, p.j, p.tj, p.tc, p.ta))
    jj = np.where(np.isinf(j), 0.0, j)
    with np.errstate(invalid='ignore', over='ignore'):
        v1, s1 = 0.5 * jj * tj ** 2, jj * tj ** 3 / 6.0
        v2, s2 = v1 + a * tc, s1 + v1 * tc + 0.5 * a * tc ** 2
        u2, u3 = u - tj, u - tj - tc
        s = np.select([u < tj, u < tj + tc, u < ta],
                      [jj * u ** 3 / 6.0, s1 + v1 * u2 + 0.5 * a * u2 ** 2,
                       s2 + v2 * u3 + 0.5 * a * u3 ** 2 - jj * u3 ** 3 / 6.0],
                      0.5 * v * ta + v * (u - ta))
        ds = np.select([u < tj, u < tj + tc, u < ta],
                       [0.5 * jj * u ** 2, v1 + a * u2, v2 + a * u3 - 0.5 * jj * u3 ** 2], v)
        dds = np.select([u < tj, u < tj + tc, u < ta], [jj * u, a, a - jj * u3], 0.0)
    still = ~np.isfinite(v) | (T <= 0.0)
    s = np.where(back, 1.0 - s, s)
    return (np.clip(np.where(still, 1.0, s), 0.0, 1.0), np.where(still, 0.0, ds),
            np.where(still, 0.0, np.where(back, -dds, dds)))


@dataclass(frozen=True)
class Timing:
    """Waypoints in time.

    Attributes:
        positions: joint values at the waypoints ``(W, J)``; arrive, depart: times [s] ``(W,)``.
        duration: of the move into waypoint ``i + 1`` ``(W - 1,)`` [s]; speed, accel: its profile's cruise speed and
            peak acceleration [1/s, 1/s^2] (``inf`` for a move that moves nothing); profiles: the unit S-curves.
        velocity, acceleration, jerk: the joints' limits ``(J,)`` (jerk ``inf``: none).
        gains: ``(G1, G2, G3)`` per move and joint ``(W - 1, J)``: the path's largest first, second and third
            derivatives in ``s`` (module docstring).
    """

    positions: Array
    arrive: Array
    depart: Array
    duration: Array
    speed: Array
    accel: Array
    velocity: Array
    acceleration: Array
    profiles: Profiles
    jerk: Array
    gains: tuple[Array, Array, Array]

    @property
    def total(self) -> float:
        """Duration of the whole program [s]."""
        return float(self.depart[-1])

    def corners(self) -> Array:
        """The instants [s] where a move's profile changes phase, sorted: the ends of its jerk ramps, of its constant
        acceleration and of its cruise (``tj``, ``tj + tc``, ``ta`` from either end of the move), where the
        acceleration has its corners and its plateaus' ends. A check sampled in time includes them: the largest
        acceleration of a move lies on them."""
        p = self.profiles
        start, T = self.depart[:-1], p.T
        offsets = (p.tj, p.tj + p.tc, p.ta, T - p.ta, T - p.tj - p.tc, T - p.tj)
        t = np.concatenate([start + x for x in offsets]) if start.size else np.zeros(0)
        return np.unique(t[np.isfinite(t) & (t >= 0.0) & (t <= self.total)])

    def peaks(self) -> tuple[Array, Array, Array]:
        """Per move and joint ``(W - 1, J)``, bounds on the speed, acceleration and jerk reached (chain rule)."""
        G1, G2, G3 = self.gains
        p = self.profiles
        v, a = (np.where(np.isfinite(x), x, 0.0)[:, None] for x in (p.v, p.a))
        j = np.where(np.isfinite(p.j) & np.isfinite(p.v), p.j, 0.0)[:, None]
        return G1 * v, G1 * a + G2 * v * v, G1 * j + 3 * G2 * v * a + G3 * v ** 3

    def usage(self) -> tuple[Array, Array]:
        """Per joint, the bounds of speed and acceleration over the limits ``(J,)`` (reached: plan.peak_usage)."""
        if self.duration.shape[0] == 0:
            return np.zeros(self.velocity.shape), np.zeros(self.velocity.shape)
        v, a, _ = self.peaks()
        return np.max(v, axis=0) / self.velocity, np.max(a, axis=0) / self.acceleration

    def jerk_usage(self) -> Array:
        """Per joint, the bound of :meth:`peaks` on its jerk as a fraction of its limit ``(J,)`` (0 without a limit)."""
        if self.duration.shape[0] == 0:
            return np.zeros(self.velocity.shape)
        return np.asarray(np.max(self.peaks()[2], axis=0) / self.jerk, dtype=np.float64)


def _limits(G: Array, limit: Array) -> Array:
    moving = G > STILL
    with np.errstate(divide='ignore'):
        return np.asarray(np.min(np.where(moving, limit / np.where(moving, G, 1.0), np.inf), axis=1), dtype=np.float64)


def _ramp(v: Array, G1: Array, G2: Array, G3: Array, acceleration: Array, jerk: Array) -> tuple[Array, Array, Array]:
    """For cruise speeds ``v (M, N)`` [1/s] of moves of gains ``G1, G2, G3 (M, K)``: the least ramp time ``t_a = v/a
    + a/J`` [s] over the peak accelerations ``a`` with ``G1 a + G2 v^2 <= acceleration`` and ``J = min_k (jerk_k - 3
    G2_k v a - G3_k v^3) / G1_k > 0``, that ``a`` [1/s^2] and ``J`` [1/s^3] (``t_a`` inf where no ``a`` is left).
    ``t_a`` is convex in ``a``: its least value lies at the top ``a``, at a piece's stationary point ``a = c sqrt(v) /
    (sqrt(G1 c) + b sqrt(v))`` (``c = jerk - G3 v^3``, ``b = 3 G2 v``) or where two pieces of the ``min`` cross."""
    M, N, K = v.shape[0], v.shape[1], G1.shape[1]
    w = v[:, :, None]
    g1, g2, g3 = (x[:, None, :] for x in (G1, G2, G3))
    moving = g1 > STILL
    piece = moving & np.isfinite(jerk)
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        safe = np.where(moving, g1, 1.0)
        top = np.min(np.where(moving, (acceleration - g2 * w * w) / safe, np.inf), axis=2)
        c = np.where(np.isfinite(jerk), jerk - g3 * w ** 3, np.inf)
        b = 3.0 * g2 * w
        top = np.minimum(top, np.min(np.where(np.isfinite(jerk) & (b > 0), c / b, np.inf), axis=2))
        stat = np.where(piece, np.sqrt(w) * c / (np.sqrt(g1 * c) + b * np.sqrt(w)), np.nan)
        cross = ((g1[:, :, None, :] * c[:, :, :, None] - g1[:, :, :, None] * c[:, :, None, :])
                 / (g1[:, :, None, :] * b[:, :, :, None] - g1[:, :, :, None] * b[:, :, None, :]))
        cross = np.where(piece[:, :, :, None] & piece[:, :, None, :], cross, np.nan).reshape(M, N, K * K)
        cand = np.concatenate([top[:, :, None], stat, cross], axis=2)
        cand = np.where((cand > 0) & (cand < top[:, :, None]), cand, top[:, :, None])
        den = c[:, :, None, :] - b[:, :, None, :] * cand[:, :, :, None]
        h = np.where(piece[:, :, None, :], np.where(den > 0, g1[:, :, None, :] * cand[:, :, :, None] / den, np.inf),
                     0.0)
        t = np.where(top[:, :, None] > 0, w / cand + np.max(h, axis=3), np.inf)
        k = np.argmin(t, axis=2)[:, :, None]
        a = np.take_along_axis(cand, k, axis=2)
        J = np.min(np.where(piece, (c - b * a) / safe, np.inf), axis=2)
    return np.take_along_axis(t, k, axis=2)[:, :, 0], a[:, :, 0], J


#: Cruise speeds tried per round on a curved path (:func:`fastest_limits`): each round narrows the interval
#: searched to 1 or 2 of its steps (12 and 14 rounds: below the rounding).
SPEEDS = 32


def fastest_limits(G1: Array, G2: Array, G3: Array, velocity: Array, acceleration: Array, jerk: Array
                   ) -> tuple[Array, Array, Array]:
    """The profile limits ``V`` [1/s], ``A`` [1/s^2], ``J`` [1/s^3] ``(M,)`` of the shortest unit move on curved
    paths of gains ``G1, G2, G3 (M, K)`` with ``G1 V <= v``, ``G1 A + G2 V^2 <= a`` and ``G1 J + 3 G2 V A + G3 V^3
    <= j`` for every joint (module docstring): the least ``T = 1/V + t_a(V)`` (:func:`_ramp`) over the speeds the
    move reaches, ``V t_a(V) <= 1`` (an interval: ``t_a`` grows with ``V``), searched on ever finer grids."""
    M = G1.shape[0]
    used = np.any((G1 > STILL) | (G2 > 0) | (G3 > 0), axis=0)  # the other joints do not move on any of the paths
    G1, G2, G3, velocity, acceleration, jerk = (x[..., used] for x in (G1, G2, G3, velocity, acceleration, jerk))
    moving = G1 > STILL
    with np.errstate(invalid='ignore', divide='ignore'):
        cap = np.min(np.minimum(np.minimum(
            np.where(moving, velocity / np.where(moving, G1, 1.0), np.inf),
            np.where(G2 > 0, np.sqrt(acceleration / np.where(G2 > 0, G2, 1.0)), np.inf)),
            np.where((G3 > 0) & np.isfinite(jerk), np.cbrt(jerk / np.where(G3 > 0, G3, 1.0)), np.inf)), axis=1)

    def ramp(x: Array) -> tuple[Array, Array, Array]:
        return _ramp(x, G1, G2, G3, acceleration, jerk)

    rows, step = np.arange(M), np.arange(1, SPEEDS + 1) / SPEEDS
    lo, hi = np.zeros(M), cap
    for _ in range(12):  # the fastest cruise reached: the last speed with v t_a(v) <= 1
        x = lo[:, None] + (hi - lo)[:, None] * step
        n = np.count_nonzero(x * ramp(x)[0] <= 1.0, axis=1)
        lo, hi = np.where(n > 0, x[rows, np.maximum(n - 1, 0)], lo), x[rows, np.minimum(n, SPEEDS - 1)]
    best, lo, hi = lo, np.zeros(M), lo
    for _ in range(14):  # the least duration: the grid's least point and its neighbours bracket it
        x = np.column_stack([best, lo[:, None] + (hi - lo)[:, None] * step])
        with np.errstate(divide='ignore'):
            T = 1.0 / x + ramp(x)[0]
        best = x[rows, np.argmin(T, axis=1)]
        i = np.argmin(T[:, 1:], axis=1) + 1
        lo, hi = np.where(i > 1, x[rows, i - 1], lo), x[rows, np.minimum(i + 1, SPEEDS)]
    _, a, J = ramp(best[:, None])
    return best, a[:, 0], J[:, 0]


def shortest(D: Array, velocity: Array, acceleration: Array, jerk: Array | None = None
             ) -> tuple[Array, Array, Array]:
    """For joint-space moves ``D (M, J)``: the profile limits ``V``, ``A`` and the shortest duration ``T_min``."""
    aD = np.abs(D)
    V, A = _limits(aD, velocity), _limits(aD, acceleration)
    J = np.full(V.shape, np.inf) if jerk is None else _limits(aD, jerk)
    return V, A, unit_profiles(V, A, J).T


def least_total(positions: Array, velocity: Array, acceleration: Array, jerk: Array, requested: Array,
                dwell: Array, names: tuple[str, ...], labels: tuple[str, ...]) -> float:
    """A lower bound of :func:`parameterise`'s total duration [s] on any paths: the dwells plus, per move, the longer of
    its time and the joint-space line's ``T_min`` (:func:`shortest`; a curved path is longer), less 1e-9 for rounding.
    LimitError: a requested time below that ``T_min``, as :func:`parameterise` words it (``names``, ``labels``)."""
    D = np.diff(positions, axis=0)
    T = shortest(D, velocity, acceleration, jerk)[2]
    req = requested[1:]
    _refuse_short(D, T, req, velocity, acceleration, jerk, names, labels)
    T = np.where(np.isfinite(req), np.maximum(req, T), T)
    return float(np.sum(dwell[:-1] + T) + dwell[-1]) * (1.0 - 1e-9)   # less the sums' and bisection's rounding


def _refuse_short(D: Array, T_min: Array, req: Array, v: Array, a: Array, j: Array, names: tuple[str, ...],
                  labels: tuple[str, ...]) -> None:
    """LimitError for the first move whose time ``req`` is below ``T_min`` [s]: the slowest joint's own S-curve."""
    if (short := np.isfinite(req) & (req < T_min * (1.0 - 1e-12))).any():
        i = int(np.argmax(short))
        t = shortest(D[i][:, None], v[:, None], a[:, None], j[:, None])[2]   # each joint alone
        u = 'm' if (k := int(np.argmax(t))) < 3 else 'rad'   # joint k's unit: the three rods, then the arms' joints
        jerk = f', {a[k]:g} {u}/s^2 and {j[k]:g} {u}/s^3' if np.isfinite(j[k]) else f' and {a[k]:g} {u}/s^2'
        alone = f'{names[k]} alone needs {t[k]:.4g} s at {v[k]:g} {u}/s{jerk}'
        raise LimitError(f'the move into {labels[i + 1]} needs at least {T_min[i]:.4g} s within the limits, time = '
                         f'{req[i]:.4g} s is too short (' + (alone if t[k] >= req[i] else f'no joint alone needs as '
                         f'long, the slowest: {alone}; their limits together, on this path, need more') + ')')


def parameterise(positions: Array, velocity: Array, acceleration: Array, requested: Array, dwell: Array,
                 names: tuple[str, ...], labels: tuple[str, ...], jerk: Array | None = None,
                 gains: tuple[Array, Array, Array] | None = None) -> Timing:
    """Time the moves between waypoints ``positions (W, J)``.

    Args:
        requested: duration [s] of the move into each waypoint ``(W,)``, NaN for the shortest (the first unused).
        dwell: time held at each waypoint ``(W,)`` [s].
        names: the joints' names; labels: how messages name each waypoint.
        jerk: the joints' jerk limits ``(J,)`` (None or ``inf``: none).
        gains: ``(G1, G2, G3)`` per move (module docstring); default the joint-space lines ``(|D|, 0, 0)``.

    Raises:
        LimitError: a requested duration shorter than the limits allow (the move, the duration, the joint).
    """
    W = positions.shape[0]
    if W == 0:
        raise InputError('a program needs at least one waypoint')
    D = np.diff(positions, axis=0)
    jerk_lim = np.full(velocity.shape, np.inf) if jerk is None else np.asarray(jerk, dtype=float)
    G1, G2, G3 = (np.abs(D), np.zeros(D.shape), np.zeros(D.shape)) if gains is None else gains
    V, A, J = _limits(G1, velocity), _limits(G1, acceleration), _limits(G1, jerk_lim)
    curved = np.any((G2 > 0) | (G3 > 0), axis=1) & np.isfinite(V)
    if curved.any():
        V[curved], A[curved], J[curved] = fastest_limits(G1[curved], G2[curved], G3[curved], velocity, acceleration,
                                                         jerk_lim)
    p = unit_profiles(V, A, J)
    T_min = p.T
    req = requested[1:]
    given = np.isfinite(req)
    _refuse_short(D, T_min, req, velocity, acceleration, jerk_lim, names, labels)
    if given.any():
        slow = stretched(p, A, J, np.where(given, req, T_min))
        fields = ('v', 'a', 'j', 'tj', 'tc', 'ta', 'T')
        p = Profiles(*(np.where(given, getattr(slow, f), getattr(p, f)) for f in fields))
        # A move of no length (its profile still: speed inf) with a time stays at its waypoint for that time.
        p = replace(p, T=np.where(given & ~np.isfinite(p.v), req, p.T))
    T = p.T
    arrive = np.concatenate([[0.0], np.cumsum(dwell[:-1] + T)])
    return Timing(positions, arrive, arrive + dwell, T, p.v, p.a, velocity, acceleration, p, jerk_lim, (G1, G2, G3))


def profile(tau: Array, T: Array, V: Array, A: Array, J: Array | None = None) -> Array:
    """The normalised profile ``s(tau)`` in [0, 1] of unit moves of durations ``T`` with cruise speed ``V``, peak
    acceleration ``A`` and jerk ``J`` (None: the trapezoid)."""
    J = np.full(np.shape(V), np.inf) if J is None else np.asarray(J, dtype=float)
    tj, tc, _ = _accel_time(np.asarray(V, float), np.asarray(A, float), J)
    p = Profiles(np.asarray(V, float), np.asarray(A, float), J, tj, tc, 2 * tj + tc, np.asarray(T, float))
    return evaluate(p, np.arange(np.shape(T)[0]), np.asarray(tau, float))[0]


@dataclass(frozen=True)
class Samples:
    """A program sampled in time: ``time (S,)`` [s], joint values ``positions (S, J)``, the waypoint held
    (``-1`` while moving) and the waypoint being moved to or held ``target (S,)``; ``s (S,)`` the profile's value
    in the move into ``target`` (1 while held)."""

    time: Array
    positions: Array
    held: NDArray[np.int64]
    target: NDArray[np.int64]
    s: Array

    def __len__(self) -> int:
        return int(self.time.shape[0])


def locate(timing: Timing, t: Array) -> tuple[NDArray[np.int64], NDArray[np.bool_], NDArray[np.int64], Array]:
    """For times ``t``: the waypoint last arrived at ``i``, whether it is held, the move ``m`` (into ``m + 1``) and
    the time into that move."""
    last = len(timing.arrive) - 1
    i = np.clip(np.searchsorted(timing.arrive, t, side='right') - 1, 0, last)
    held = t <= timing.depart[i] + 1e-12
    m = np.minimum(i, max(last - 1, 0))
    return i, held, m, t - timing.depart[m]


def sample_count(total: float, rate: float) -> int:
    """The count of :func:`sample_times` (:func:`~.grid.grid_count`) for a program of ``total`` [s] at ``rate``
    [Hz]; :class:`InputError` beyond :data:`MAX_SAMPLES` (or a rate outside :data:`~.grid.RATES`)."""
    rate = check_rate(rate)
    count = grid_count(total, rate)
    if count > MAX_SAMPLES:
        raise InputError(f'the program lasts {total:.6g} s: at {rate:g} Hz that is {count} samples; allowed: at most '
                         f'{MAX_SAMPLES}{lower_rate(rate)}')
    return count


def sample_times(timing: Timing, rate: float) -> Array:
    """:func:`grid_times` of the program's ``total`` (:func:`sample_count` bounds them by MAX_SAMPLES)."""
    rate = check_rate(rate)
    sample_count(timing.total, rate)
    return grid_times(timing.total, rate)


def sample(timing: Timing, rate: float) -> Samples:
    """Samples at :func:`sample_times`; the joints on the joint-space line of each move (a curved path's rows are
    replaced by its caller, :func:`gpr_kinematics.robot.plan.sample_plan`)."""
    return sample_at(timing, sample_times(timing, rate))


def sample_at(timing: Timing, t: Array) -> Samples:
    """:class:`Samples` at the times ``t`` [s] (within ``[0, total]``)."""
    if len(timing.arrive) == 1:
        n = t.shape[0]
        return Samples(t, np.repeat(timing.positions, n, axis=0), np.zeros(n, dtype=np.int64),
                       np.zeros(n, dtype=np.int64), np.ones(n))
    i, held, m, tau = locate(timing, t)
    s = evaluate(timing.profiles, m, tau)[0]
    D = np.diff(timing.positions, axis=0)
    pos = np.where(held[:, None], timing.positions[i], timing.positions[m] + s[:, None] * D[m])
    return Samples(t, pos, np.where(held, i, -1), np.where(held, i, m + 1), np.where(held, 1.0, s))


def velocities(timing: Timing, t: Array) -> Array:
    """The joints' velocities ``(S, J)`` at times ``t (S,)`` [m/s, rad/s] on the joint-space line of each move:
    ``ds/dt D`` of the move under way, 0 while a waypoint is held (the derivative of :func:`sample_at`; a curved
    path's rows are its caller's, :func:`gpr_kinematics.robot.plan.plan_velocities`)."""
    t = np.asarray(t, dtype=float)
    if len(timing.arrive) == 1:
        return np.zeros((t.shape[0], timing.positions.shape[1]))
    _, held, m, tau = locate(timing, t)
    ds = evaluate(timing.profiles, m, tau)[1]
    out: Array = np.where(held[:, None], 0.0, ds[:, None] * np.diff(timing.positions, axis=0)[m])
    return out

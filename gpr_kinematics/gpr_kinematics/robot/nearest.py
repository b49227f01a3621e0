"""The ``nearest`` redundancy rule of a 4-joint arm: the held joint's value whose posture is nearest the reference
(:class:`~gpr_kinematics.robot.description.Redundancy`), for ``N`` targets at once (:func:`nearest_value`).

Holding joint ``j`` at ``v`` leaves a two-link problem (:mod:`gpr_kinematics.robot.planar_arm`); over ``v`` the
postures form the arm's *self-motion*, and joint limits and the reach cut it into *runs* of feasible postures. The
cost ``C(v) = sum_k w_k ((theta_k(v) - ref_k) / (upper_k - lower_k))^2`` is smooth within a run (split where a joint
wraps, below), so its minimum over the feasible postures lies at an edge of a run or where ``C'(v) = 0`` inside one.
The edges in closed form:

* **reach**: the two-link sub-chain stretched or folded, ``r = L1 + L2`` or ``r = |L1 - L2|``. Exactly one of the
  target distance ``r`` and the link lengths depends on ``v``, and its square is ``A + B cos v + C sin v`` (the law
  of cosines: ``|c - Rz(v) a|^2`` for a held shoulder or hand, ``|a + Rz(v) b|^2`` for a held middle joint), so
  each edge solves ``A + B cos v + C sin v = T``: ``v = atan2(C, B) +- acos((T - A) / hypot(B, C))``;
* **joint limits**: joint ``k`` at a limit is the posture with ``k`` held there (a ``fixed_joint`` solve, both
  branches: the other branch's answer is a value of ``v`` where nothing changes, a harmless extra point);
* **wraps**: a joint whose range exceeds a turn is given as the representative nearest the middle of its range, which
  jumps from the middle + pi to the middle - pi where the joint passes there, and the cost jumps with it: those
  values of ``v`` (the held joint's own, or another joint held there as at a limit) split a run like an edge, and
  are evaluated :data:`NEAREST_WRAP_SIDE` to either side as well.

Between consecutive edges every posture has the same feasibility; the rule evaluates the cost and its slope at every
edge, at :data:`NEAREST_SAMPLES` values of the range and at :data:`NEAREST_RUN_SAMPLES` more inside each run that
held few of those points (:func:`_narrow_runs`), and each pair of neighbours whose slope goes from negative to
positive brackets a minimum, found by Newton's method on the slope (its analytic derivative; bisection where a step
would leave the bracket) to :data:`NEAREST_TOLERANCE` (:func:`_minimum`). The slope comes from the self-motion's
joint rates ``n = d theta / dv`` (``n_j = 1``): the wafer and its heading stay put, so ``sum_k n_k = 0`` and
``sum_k n_k a_k = 0`` for the joint axes ``a_k`` (``a_1`` at the mount), three linear equations for the other three
rates. The answer is the best of these candidates; where no posture is feasible, the middle of the range (the caller
reports why). SI units: metres, radians.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..core.rotations import rotate_z
from .arm_chain import LIMIT_SLACK, REACH_SLACK, fixed_one, floats2, representative, solve_fixed, wrap_one
from .description import Arm

Array = NDArray[np.float64]
Index = NDArray[np.intp]

#: Samples of the held joint's range besides the edges: they find the minima inside a run.
NEAREST_SAMPLES = 17
#: A run of feasible postures evaluated at fewer points than this gets a grid of its own (:func:`_narrow_runs`) ...
NEAREST_RUN_POINTS = 4
#: ... of this many points inside it.
NEAREST_RUN_SAMPLES = 7
#: Where the slope at an edge of the reach is infinite, it is taken this fraction of the way to the neighbour.
NEAREST_PROBE = 1e-6
#: A pair beside an edge of the reach without a bracket is scanned at these fractions of its width from the edge.
NEAREST_SCAN = (0.01, 0.05, 0.25, 0.5)
#: A minimum is found when its bracket is this narrow [rad] (or the slope vanishes there) ...
NEAREST_TOLERANCE = 1e-14
#: ... or after a Newton step this small [rad] and this fraction of the one before (converging quadratically: the
#: error left is of the order of its square; beside a reach's edge it converges linearly: 1e-7 there left 1e-8 rad).
NEAREST_LAST_STEP, NEAREST_SUPERLINEAR = 1e-7, 0.01
#: At most this many points are evaluated in floats (one target's Newton steps), more with numpy.
NEAREST_FLOATS = 4
#: Newton steps at most (it converges quadratically: some 5 are taken).
NEAREST_STEPS = 60
#: Where a joint whose range exceeds a turn wraps (the cost jumps there), the held values this far [rad] to either
#: side are evaluated too: the lower side's cost need not be attained at the jump itself.
NEAREST_WRAP_SIDE = 1e-12


class Evaluation(NamedTuple):
    """Postures at held values: ``cost`` (``inf``: infeasible), its ``slope`` dC/dv and ``curvature`` d2C/dv2."""

    cost: Array
    slope: Array
    curvature: Array


def nearest_value(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array, sign: Array) -> Array:
    """The held joint's value of the posture nearest the reference for targets ``p (N, 2)`` [m] and headings
    ``phi (N,)`` [rad] in the mount frame on the branches ``sign (N,)`` (module docstring)."""
    red = arm.redundancy
    assert red is not None
    joint = arm.joints[red.joint]
    lo, hi = joint.lower, joint.upper
    n = p.shape[0]
    reach = reach_edges(arm, d, beta, p, phi)
    wraps = _wrap_edges(arm, d, beta, p, phi)
    wraps = np.concatenate([wraps - NEAREST_WRAP_SIDE, wraps, wraps + NEAREST_WRAP_SIDE], axis=1)
    edges = np.concatenate([reach, limit_edges(arm, d, beta, p, phi), wraps], axis=1)
    edges = lo + np.mod(edges - lo, 2.0 * math.pi)  # every representative within the range (which may exceed 2 pi)
    edges = np.concatenate([edges, edges + 2.0 * math.pi, edges + 4.0 * math.pi], axis=1)
    singular = np.tile(np.arange(edges.shape[1] // 3) < reach.shape[1], 3)  # the reach's edges: infinite slopes
    with np.errstate(invalid='ignore'):
        rows, cols = np.nonzero((edges > lo) & (edges < hi))
    grid = np.linspace(lo, hi, NEAREST_SAMPLES)
    rows = np.concatenate([np.repeat(np.arange(n), NEAREST_SAMPLES), rows])
    x = np.concatenate([np.tile(grid, n), edges[rows[n * NEAREST_SAMPLES:], cols]])
    at_reach = np.concatenate([np.zeros(n * NEAREST_SAMPLES, dtype=bool), singular[cols]])
    order = np.lexsort((x, rows))  # by target, then held value
    rows, x, at_reach = rows[order], x[order], at_reach[order]
    ev = _evaluate(arm, d, beta, p, phi, sign, rows, x)
    rows, x, at_reach, ev = _narrow_runs(arm, d, beta, p, phi, sign, rows, x, at_reach, ev)
    cand_rows, cand_x, cand_f = [rows], [x], [ev.cost]
    finite = np.isfinite(ev.cost)
    pair = np.flatnonzero((rows[1:] == rows[:-1]) & finite[1:] & finite[:-1])
    r, a, b, ga, gb = rows[pair], x[pair], x[pair + 1], ev.slope[pair], ev.slope[pair + 1]
    # At an edge of the reach the slope is infinite (its sign lost in rounding): probe just inside the pair instead.
    for end, other, g, singular_end in ((a, b, ga, at_reach[pair]), (b, a, gb, at_reach[pair + 1])):
        bad = np.flatnonzero(singular_end | ~np.isfinite(g))
        if bad.size:
            probe = end[bad] + NEAREST_PROBE * (other[bad] - end[bad])
            end[bad], g[bad] = probe, _evaluate(arm, d, beta, p, phi, sign, r[bad], probe).slope
    _split_dips(arm, d, beta, p, phi, sign, r, a, b, ga, gb, ev.cost[pair], ev.cost[pair + 1])
    # Beside an edge of the reach the cost goes like the square root of the distance: no cubic models it, so a pair
    # there without a bracket is scanned at fractions of its width from that edge (NEAREST_SCAN).
    with np.errstate(invalid='ignore'):
        scan = np.flatnonzero((at_reach[pair] | at_reach[pair + 1]) & ~((ga < 0.0) & (gb > 0.0)))
    if scan.size:
        from_b = ~at_reach[pair[scan]]
        f = np.array(NEAREST_SCAN)
        f = np.where(from_b[:, None], 1.0 - f[::-1], f)  # ordered from a to b either way
        xs = a[scan, None] + f * (b[scan] - a[scan])[:, None]
        gs = _evaluate(arm, d, beta, p, phi, sign, np.repeat(r[scan], f.shape[1]), xs.ravel()).slope.reshape(xs.shape)
        X = np.column_stack([a[scan], xs, b[scan]])
        G = np.column_stack([ga[scan], gs, gb[scan]])
        with np.errstate(invalid='ignore'):
            up = (G[:, :-1] < 0.0) & (G[:, 1:] > 0.0)
        has = up.any(axis=1)
        k = np.argmax(up, axis=1)[has]
        i = scan[has]
        a[i], ga[i], b[i], gb[i] = X[has, k], G[has, k], X[has, k + 1], G[has, k + 1]
    with np.errstate(invalid='ignore'):
        i = np.flatnonzero((ga < 0.0) & (gb > 0.0))
    if i.size:
        xm = _minimum(arm, d, beta, p, phi, sign, r[i], a[i], b[i], ga[i], gb[i])
        cand_rows.append(r[i])
        cand_x.append(xm)
        cand_f.append(_evaluate(arm, d, beta, p, phi, sign, r[i], xm).cost)
    R, X, F = np.concatenate(cand_rows), np.concatenate(cand_x), np.concatenate(cand_f)
    order = np.lexsort((F, R))  # by target, then cost
    R, X, F = R[order], X[order], F[order]
    first = np.flatnonzero(np.r_[True, R[1:] != R[:-1]])
    out = np.full(n, 0.5 * (lo + hi))
    best = first[np.isfinite(F[first])]
    out[R[best]] = X[best]
    return out


def _narrow_runs(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array, sign: Array, rows: Index, x: Array,
                 at_reach: NDArray[np.bool_], ev: Evaluation) -> tuple[Index, Array, NDArray[np.bool_], Evaluation]:
    """The points ``x`` of the targets ``rows`` (sorted) with a grid of :data:`NEAREST_RUN_SAMPLES` inside each run of
    feasible postures that holds fewer than :data:`NEAREST_RUN_POINTS` of them: a run narrower than the range's grid
    spacing held two minima between its edges, and the bracket's one Newton search found the worse."""
    finite = np.isfinite(ev.cost)
    same = np.r_[False, rows[1:] == rows[:-1]]
    first = np.flatnonzero(finite & ~(same & np.r_[False, finite[:-1]]))   # where each run starts
    last = np.flatnonzero(finite & ~(np.r_[same[1:], False] & np.r_[finite[1:], False]))
    narrow = (last - first + 1 < NEAREST_RUN_POINTS) & (x[last] > x[first])
    if not narrow.any():
        return rows, x, at_reach, ev
    i, k = first[narrow], NEAREST_RUN_SAMPLES
    a, b = x[i], x[last[narrow]]
    new_x = (a[:, None] + (b - a)[:, None] * np.linspace(0.0, 1.0, k + 2)[1:-1]).ravel()
    new_rows = np.repeat(rows[i], k)
    # Merged in order: a new point goes after its run's first point and the middle one (of three) below it; one on
    # the middle point itself (an equally spaced run) is left out, not evaluated twice.
    mid = np.repeat(np.where(last[narrow] - i == 2, x[np.minimum(i + 1, x.size - 1)], np.inf), k)
    slot = np.repeat(i + 1, k) + (mid < new_x)
    kept = new_x != mid
    new_x, new_rows, slot = new_x[kept], new_rows[kept], slot[kept]
    extra = _evaluate(arm, d, beta, p, phi, sign, new_rows, new_x)
    key = np.concatenate([2 * np.arange(x.size) + 1, 2 * slot])
    order = np.argsort(key, kind='stable')
    merged = [np.concatenate(pair)[order] for pair in ((rows, new_rows), (x, new_x),
                                                      (at_reach, np.zeros(new_x.size, dtype=bool)))]
    return merged[0], merged[1], merged[2], Evaluation(*(np.concatenate([u, v])[order]
                                                         for u, v in zip(ev, extra, strict=True)))


def _split_dips(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array, sign: Array, rows: Index, a: Array,
                b: Array, ga: Array, gb: Array, fa: Array, fb: Array) -> None:
    """Where a pair's slopes do not bracket a minimum (both of one sign) but the cubic through the costs ``fa, fb``
    and slopes ``ga, gb`` at its ends dips inside, a point of the dip whose slope has the other sign replaces the end
    it brackets a minimum with (in place): the cubic's inflection, where its slope is farthest from the ends' sign,
    else its minimum (the slope there is near zero, of either sign: tried second)."""
    h = b - a
    m0, m1 = ga * h, gb * h
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        A = 6.0 * (fa - fb) + 3.0 * (m0 + m1)
        B = 6.0 * (fb - fa) - 4.0 * m0 - 2.0 * m1
        t = (-B + np.sqrt(B * B - 4.0 * A * m0)) / (2.0 * A)  # the root of p' where p'' = 2 A t + B > 0
        same = ((ga > 0.0) & (gb > 0.0)) | ((ga < 0.0) & (gb < 0.0))
        i = np.flatnonzero(same & (t > 0.0) & (t < 1.0))
    if not i.size:
        return
    # p' is a quadratic of the ends' sign at both ends: both its roots lie inside, its extremum -B / (2 A) between
    inflection = np.clip(-B[i] / (2.0 * A[i]), 0.0, 1.0)
    xs = np.concatenate([a[i] + inflection * h[i], a[i] + t[i] * h[i]])
    gs = _evaluate(arm, d, beta, p, phi, sign, np.concatenate([rows[i], rows[i]]), xs).slope
    rising = ga[i] > 0.0  # + - +: a minimum right of a dip below zero; - + -: left of a rise above zero
    first = np.where(rising, gs[:i.size] < 0.0, gs[:i.size] > 0.0)
    x, g = np.where(first, xs[:i.size], xs[i.size:]), np.where(first, gs[:i.size], gs[i.size:])
    left = rising & (g < 0.0)
    right = ~rising & (g > 0.0)
    a[i[left]], ga[i[left]] = x[left], g[left]
    b[i[right]], gb[i[right]] = x[right], g[right]


def reach_edges(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array) -> Array:
    """Held values ``(N, 4)`` where the two-link sub-chain is stretched or folded (module docstring; NaN where an
    edge does not exist)."""
    red = arm.redundancy
    assert red is not None
    j = red.joint
    c = p - rotate_z(phi - beta, d[3])  # the wrist axis: the two-link target unless the hand is held
    if j in (0, 3):  # the target distance varies: r^2 = |c|^2 + |a|^2 - 2 c . Rz(+-v) a
        a = d[0] if j == 0 else rotate_z(phi - beta, d[2])
        L1, L2 = (np.hypot(*d[1]), np.hypot(*d[2])) if j == 0 else (np.hypot(*d[0]), np.hypot(*d[1]))
        A = np.sum(c * c, axis=-1) + np.sum(a * a, axis=-1)
        B = -2.0 * np.sum(c * a, axis=-1)
        C = -2.0 * (a[..., 0] * c[..., 1] - a[..., 1] * c[..., 0]) * (1.0 if j == 0 else -1.0)
        targets = [(L1 + L2) ** 2, (L1 - L2) ** 2]
    else:  # a link length varies: L^2 = |a|^2 + |b|^2 + 2 a . Rz(v) b, the other link and r fixed
        a, b = d[j - 1], d[j]
        fixed = np.hypot(*d[2]) if j == 1 else np.hypot(*d[0])
        r = np.hypot(c[..., 0], c[..., 1])
        A = np.full(p.shape[0], float(a @ a + b @ b))
        B = np.full(p.shape[0], 2.0 * float(a @ b))
        C = np.full(p.shape[0], 2.0 * float(a[0] * b[1] - a[1] * b[0]))
        targets = [(r - fixed) ** 2, (r + fixed) ** 2]
    psi, R = np.arctan2(C, B), np.hypot(B, C)
    out = []
    with np.errstate(invalid='ignore', divide='ignore'):
        for T in targets:
            g = np.arccos((T - A) / R)  # NaN where |.| > 1: no such edge
            out += [psi + g, psi - g]
    return np.stack(out, axis=1) - arm.joints[j].zero_offset


def limit_edges(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array) -> Array:
    """Held values ``(N, 12)`` of the postures with another joint at one of its limits, on either branch (module
    docstring; NaN where out of reach)."""
    red = arm.redundancy
    assert red is not None
    return np.concatenate([_held_where(arm, d, beta, p, phi, k, (joint.lower, joint.upper))
                           for k, joint in enumerate(arm.joints) if k != red.joint], axis=1)


def _held_where(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array, k: int, values: Sequence[float]
                ) -> Array:
    """Held values ``(N, 2 len(values))`` of the postures with joint ``k`` at each of ``values`` [rad], on either
    branch (NaN where out of reach): a ``fixed_joint`` solve with ``k`` held."""
    red = arm.redundancy
    assert red is not None
    j, o = red.joint, arm.zero_offset
    held = np.broadcast_to(np.repeat(np.asarray(values, dtype=float), 2) + o[k], (p.shape[0], 2 * len(values)))
    theta, tl = solve_fixed(d, beta, k, held, p[:, None, :], phi[:, None], np.tile([1.0, -1.0], len(values)))
    return np.asarray(np.where(tl.reachable, theta[..., j] - o[j], np.nan), dtype=np.float64)


def _wrap_edges(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array) -> Array:
    """Held values ``(N, m)`` where a joint whose range exceeds a turn wraps: its representative (the one nearest the
    middle of its range) jumps from the middle + pi to the middle - pi there, and so does the cost. The held joint's
    own and, on either branch, another joint's (the posture with it held there, as at a limit: NaN where out of
    reach); ``(N, 0)`` where no range exceeds a turn (module docstring)."""
    red = arm.redundancy
    assert red is not None
    n = p.shape[0]
    out = [np.zeros((n, 0))]
    for k, joint in enumerate(arm.joints):
        if joint.upper - joint.lower <= 2.0 * math.pi:
            continue
        w = 0.5 * (joint.lower + joint.upper) + math.pi
        out.append(np.full((n, 1), w) if k == red.joint else _held_where(arm, d, beta, p, phi, k, (w,)))
    return np.concatenate(out, axis=1)


def _evaluate(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array, sign: Array, rows: Index,
              x: Array, curvature: bool = False) -> Evaluation:
    """The cost, its slope and (``curvature``) its second derivative at held values ``x (M,)`` of the targets
    ``rows (M,)`` (module docstring; the curvature is NaN without)."""
    red = arm.redundancy
    assert red is not None
    if x.size <= NEAREST_FLOATS:  # a few points (one target's Newton steps): floats, not numpy per operation
        out = [_evaluate_one(arm, d, beta, p[i].tolist(), float(phi[i]), float(sign[i]), v, curvature)
               for i, v in zip(rows.tolist(), x.tolist(), strict=True)]
        return Evaluation(*(np.array(c, dtype=np.float64).reshape(-1) for c in zip(*out, strict=True)))
    # Column by column: numpy's reductions over a short last axis and its (M, 4) temporaries cost more than the
    # arithmetic (the same operations in the same order: the same bits).
    j, joints = red.joint, arm.joints
    chain, tl = solve_fixed(d, beta, j, x + joints[j].zero_offset, p[rows], phi[rows], sign[rows])
    c = [chain[:, k] for k in range(4)]
    bad = ~tl.reachable
    g: list[Array] = []
    costs: list[Array] = []
    for k, joint in enumerate(joints):
        lo, hi, ref, w = joint.lower, joint.upper, red.reference[k], red.weights[k]
        theta = representative(c[k] - joint.zero_offset, 0.5 * (lo + hi))
        bad |= (lo - theta - LIMIT_SLACK > 0.0) | (theta - hi - LIMIT_SLACK > 0.0)
        scaled = (theta - ref) / (hi - lo)
        costs.append(w * scaled * scaled)
        g.append(2.0 * w * scaled / (hi - lo))
    cost = costs[0] + costs[1] + costs[2] + costs[3]
    # The joint axes a_2..a_4 (a_1 at the mount), then the rates n of the three other joints and their derivatives
    # n' (Cramer's rule: sum n_k = 0, sum n_k a_k = 0; sum n'_k = 0, sum n'_k a_k = -sum n_k a'_k, n_j = 1, n'_j = 0,
    # a'_k = sum_{i<k} n_i perp(a_k - a_i)).
    zero = np.zeros(x.size)
    ax, ay, turned = [zero], [zero], c[0]
    for k in range(3):
        if k:
            turned = turned + c[k]
        cos, sin = np.cos(turned), np.sin(turned)
        (dx, dy) = d[k].tolist()
        ax.append(ax[-1] + (cos * dx - sin * dy))
        ay.append(ay[-1] + (sin * dx + cos * dy))
    others = [k for k in range(4) if k != j]
    xs, ys = [ax[k] for k in others], [ay[k] for k in others]
    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
        inv = 1.0 / _det3([1.0, 1.0, 1.0], xs, ys)
        rates: list[Array | float] = [1.0] * 4
        for k, n in zip(others, _cramer(xs, ys, (-1.0, -ax[j], -ay[j]), inv), strict=True):
            rates[k] = n
        slope = g[0] * rates[0] + g[1] * rates[1] + g[2] * rates[2] + g[3] * rates[3]
        second = np.full(x.size, np.nan)
        if curvature:
            vx: Array | float = 0.0
            vy: Array | float = 0.0
            for k in range(1, 4):  # sum_k n_k a'_k
                ux: Array | float = 0.0
                uy: Array | float = 0.0
                for i in range(k):
                    ux = ux - rates[i] * (ay[k] - ay[i])
                    uy = uy + rates[i] * (ax[k] - ax[i])
                vx = vx + rates[k] * ux
                vy = vy + rates[k] * uy
            accel: list[Array | float] = [0.0] * 4
            for k, n in zip(others, _cramer(xs, ys, (0.0, -np.asarray(vx), -np.asarray(vy)), inv), strict=True):
                accel[k] = n
            terms = [2.0 * w * (rates[k] / (jt.upper - jt.lower)) ** 2 + g[k] * accel[k]
                     for k, (jt, w) in enumerate(zip(joints, red.weights, strict=True))]
            second = np.asarray(terms[0] + terms[1] + terms[2] + terms[3], dtype=np.float64)
    return Evaluation(np.where(bad, np.inf, cost), slope, second)


def _evaluate_one(arm: Arm, d: list[Array], beta: float, p: list[float], phi: float, sign: float, v: float,
                  curvature: bool) -> tuple[float, float, float]:
    """:func:`_evaluate` of one held value ``v`` in floats (the same steps): cost, slope, curvature."""
    red = arm.redundancy
    assert red is not None
    j, joints = red.joint, arm.joints
    links = floats2(d)
    chain, r, lo, hi = fixed_one(links, beta, j, v + joints[j].zero_offset, p[0], p[1], phi, sign)
    theta, violation = wrap_one(arm, [c - joint.zero_offset for c, joint in zip(chain, joints, strict=True)])
    span = [joint.upper - joint.lower for joint in joints]
    g = [2.0 * w * (t - ref) / (s * s) for t, ref, w, s in zip(theta, red.reference, red.weights, span, strict=True)]
    cost = sum(w * ((t - ref) / s) ** 2 for t, ref, w, s in zip(theta, red.reference, red.weights, span, strict=True))
    if not hi + REACH_SLACK >= r >= lo - REACH_SLACK or max(violation) > 0.0:
        cost = math.inf
    ax, ay, turned = [0.0], [0.0], 0.0
    for k in range(3):
        turned += chain[k]
        c, s_ = math.cos(turned), math.sin(turned)
        ax.append(ax[-1] + c * links[k][0] - s_ * links[k][1])
        ay.append(ay[-1] + s_ * links[k][0] + c * links[k][1])
    others = [k for k in range(4) if k != j]
    xs, ys = [ax[k] for k in others], [ay[k] for k in others]
    det = _det3_one((1.0, 1.0, 1.0), xs, ys)
    if det == 0.0:
        return cost, math.nan, math.nan
    rates = [0.0] * 4
    rates[j] = 1.0
    for m, k in enumerate(others):
        rates[k] = _det3_one(*_column(m, (1.0, 1.0, 1.0), xs, ys, (-1.0, -ax[j], -ay[j]))) / det
    slope = sum(gk * n for gk, n in zip(g, rates, strict=True))
    if not curvature:
        return cost, slope, math.nan
    vx = vy = 0.0
    for k in range(1, 4):  # sum_k n_k a'_k
        vx -= rates[k] * sum(rates[i] * (ay[k] - ay[i]) for i in range(k))
        vy += rates[k] * sum(rates[i] * (ax[k] - ax[i]) for i in range(k))
    accel = [0.0] * 4
    for m, k in enumerate(others):
        accel[k] = _det3_one(*_column(m, (1.0, 1.0, 1.0), xs, ys, (0.0, -vx, -vy))) / det
    second = sum(2.0 * w * (n / s) ** 2 + gk * a
                 for w, n, s, gk, a in zip(red.weights, rates, span, g, accel, strict=True))
    return cost, slope, second


def _column(m: int, t: tuple[float, float, float], x: list[float], y: list[float], rhs: tuple[float, float, float]
            ) -> tuple[list[float], list[float], list[float]]:
    """The columns ``(t, x, y)`` with column ``m`` replaced by ``rhs``."""
    t2, x2, y2 = list(t), list(x), list(y)
    t2[m], x2[m], y2[m] = rhs
    return t2, x2, y2


def _det3_one(t: Sequence[float], x: Sequence[float], y: Sequence[float]) -> float:
    """:func:`_det3` of one matrix in floats."""
    return (t[0] * (x[1] * y[2] - x[2] * y[1]) - t[1] * (x[0] * y[2] - x[2] * y[0])
            + t[2] * (x[0] * y[1] - x[1] * y[0]))


def _cramer(xs: list[Array], ys: list[Array], rhs: tuple[float, Array, Array], inv: Array) -> list[Array]:
    """Cramer's rule for the columns ``(1, x_m, y_m)``: the unknowns, column ``m`` replaced by ``rhs`` for each."""
    out = []
    for m in range(3):
        t: list[Array | float] = [1.0, 1.0, 1.0]
        u, v = list(xs), list(ys)
        t[m], u[m], v[m] = rhs
        out.append(_det3(t, u, v) * inv)
    return out


def _det3(t: list[Array | float], x: list[Array], y: list[Array]) -> Array:
    """The determinant of the 3 x 3 matrices of columns ``(t_m, x_m, y_m)``."""
    return np.asarray(t[0] * (x[1] * y[2] - x[2] * y[1]) - t[1] * (x[0] * y[2] - x[2] * y[0])
                      + t[2] * (x[0] * y[1] - x[1] * y[0]), dtype=np.float64)


def _minimum(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array, sign: Array, rows: Index, a: Array,
             b: Array, ga: Array, gb: Array) -> Array:
    """The zero of the slope in each bracket ``[a, b]`` (slopes ``ga < 0 < gb``): Newton's method on the slope from
    the secant's zero, a step leaving the bracket replaced by bisection, the bracket kept."""
    a, b = a.copy(), b.copy()
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        x = a - ga * (b - a) / (gb - ga)
    x = np.where((x > a) & (x < b), x, 0.5 * (a + b))
    active = np.arange(a.size)
    before = np.zeros(a.size)   # each search's Newton step before (0: none, the start or a bisection)
    for _ in range(NEAREST_STEPS):
        t = x[active]
        ev = _evaluate(arm, d, beta, p, phi, sign, rows[active], t, curvature=True)
        g = ev.slope
        left, right = g < 0.0, g > 0.0  # the minimum lies right of t, left of t (neither: found, or NaN)
        A, B = np.where(left, t, a[active]), np.where(right, t, b[active])
        a[active], b[active] = A, B
        with np.errstate(invalid='ignore', divide='ignore'):
            dt = g / ev.curvature
        step = t - dt
        inside = (step >= A) & (step <= B)
        nxt = np.where(inside, step, 0.5 * (A + B))
        last = inside & (np.abs(dt) <= NEAREST_LAST_STEP) & (np.abs(dt) <= NEAREST_SUPERLINEAR * before[active])
        done = ~(left | right) | last | (B - A <= NEAREST_TOLERANCE)
        x[active] = np.where(done & ~last, t, nxt)
        before[active] = np.where(inside, np.abs(dt), 0.0)   # after a bisection a step can't show its convergence
        active = active[~done]
        if not active.size:
            break
    return x

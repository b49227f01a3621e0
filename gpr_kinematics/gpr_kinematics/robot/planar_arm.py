"""A serial planar arm in its mount frame: forward kinematics and closed-form inverse kinematics, vectorised.

All joint axes are parallel to the platform normal, so in the *mount frame* (the first joint axis, rotated by the
mount yaw) the arm is a planar chain. With ``Theta_k = theta_1 + ... + theta_k`` the direction of link ``k``,
``d_k = (length_k, 0)`` the link vectors and the blade folded into the last one,

    ``p = sum_k Rz(Theta_k) d_k``,  ``d_n = (length_n, 0) + b_xy + Rz(beta) w_xy``,  ``phi = Theta_n + beta``

(``b``, ``beta``: blade position and yaw in the flange frame; ``w``: wafer centre in the blade frame; ``p``,
``phi``: wafer centre and blade heading in the mount frame). A joint's ``zero_offset`` ``o_k`` (a calibration's) turns
it by ``theta_k + o_k``: the chain works on those angles, the joint values in and out are the ``theta_k``.
Inverse kinematics in closed form:

* **2 joints**: the wafer position alone; the heading ``phi`` is an *outcome* (one per branch).
* **3 joints**: ``Theta_3 = phi - beta``, the wrist axis ``p_3 = p - Rz(Theta_3) d_3``, then the two-link
  problem for the shoulder and elbow.
* **4 joints**: one joint ``j`` is held at a value ``v`` (rule ``fixed_joint``, or each candidate of the rule
  ``nearest``): it is folded into its neighbours (link ``j-1`` becomes ``d_{j-1} + Rz(v) d_j``; joint ``j+1``
  gains the offset ``v``), which leaves a 3-joint chain.

**Two-link problem** (cosine rule) for links ``D1, D2`` (lengths ``L1, L2``, directions ``delta1, delta2``) and
a target ``p`` at distance ``r``: the relative angle ``g`` of the two links has ``cos g = (r^2 - L1^2 - L2^2) /
(2 L1 L2)`` and ``sin g = s sqrt(((L1+L2)^2 - r^2)(r^2 - (L1-L2)^2)) / (2 L1 L2)`` (the product form keeps the
digits near full stretch); ``A1 = atan2(p) - atan2(L2 sin g, L1 + L2 cos g)``. The **branch** is the sign ``s``:
``right`` (``s = +1``) puts the elbow to the right of the line from the shoulder axis to the wrist axis, seen
from above the platform (the second link turns counterclockwise relative to the first), ``left`` (``s = -1``)
to its left. Reachable when ``|L1 - L2| <= r <= L1 + L2``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..core.rotations import rotate_z
from .description import Arm

Array = NDArray[np.float64]

#: Slack [m] on the reach interval (rounding of targets at full stretch).
REACH_SLACK = 1e-12
#: Slack [rad] on the joint limits (rounding of targets at a limit).
LIMIT_SLACK = 1e-12
#: The ``nearest`` rule's sweep of the held joint's range and its refinement steps (:func:`nearest_value`).
NEAREST_GRID = 121
NEAREST_REFINE = 32
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def branch_sign(branch: str) -> float:
    """``+1`` for ``right``, ``-1`` for ``left`` (module docstring)."""
    return 1.0 if branch == 'right' else -1.0


def link_vectors(arm: Arm) -> tuple[list[Array], float]:
    """The planar link vectors ``d_k`` (mount-frame units, blade folded into the last) and the blade yaw."""
    js = arm.joints
    b, beta, w = arm.blade.position, arm.blade.yaw, arm.blade.wafer_centre
    d = [np.array([j.length, 0.0]) for j in js]
    d[-1] = np.array([js[-1].length + b[0] + math.cos(beta) * w[0] - math.sin(beta) * w[1],
                      b[1] + math.sin(beta) * w[0] + math.cos(beta) * w[1]])
    return d, beta


def chain_forward(arm: Arm, theta: Array) -> tuple[Array, Array, Array]:
    """Forward kinematics in the mount frame of joint values ``theta (N, n)``.

    Returns ``(axes (N, n, 2), wafer (N, 2), heading (N,))``: every joint axis, the wafer centre, the blade heading.
    """
    d, beta = link_vectors(arm)
    Theta = np.cumsum(theta + arm.zero_offset, axis=1)
    n = theta.shape[1]
    axes = np.zeros(theta.shape + (2,))
    for k in range(1, n):
        axes[:, k] = axes[:, k - 1] + rotate_z(Theta[:, k - 1], d[k - 1])
    wafer = axes[:, n - 1] + rotate_z(Theta[:, n - 1], d[n - 1])
    return axes, wafer, Theta[:, n - 1] + beta


def wrap_to_limits(theta: Array, lower: Array, upper: Array) -> tuple[Array, Array]:
    """The representative ``theta + 2 pi k`` nearest the middle of ``[lower, upper]`` and how far it lies beyond
    the range [rad] (0 inside). Joints of a planar arm are defined modulo ``2 pi``; a range wider than ``2 pi``
    always holds the representative."""
    mid = 0.5 * (lower + upper)
    t = mid + np.mod(theta - mid + math.pi, 2.0 * math.pi) - math.pi
    violation = np.maximum(np.maximum(lower - t, t - upper) - LIMIT_SLACK, 0.0)
    return t, violation


@dataclass(frozen=True)
class TwoLink:
    """Two-link solution: absolute link directions ``Theta1, Theta2`` [rad], the distance ``r`` of the target
    and the reach interval ``[r_min, r_max]`` [m]."""

    Theta1: Array
    Theta2: Array
    r: Array
    r_min: Array
    r_max: Array

    @property
    def reachable(self) -> NDArray[np.bool_]:
        return (self.r <= self.r_max + REACH_SLACK) & (self.r >= self.r_min - REACH_SLACK)


def two_link(D1: Array, D2: Array, p: Array, sign: Array | float) -> TwoLink:
    """Closed-form two-link inverse kinematics (module docstring); ``D1, D2, p`` broadcast as ``(..., 2)``.
    Out of reach, the nearest posture (stretched or folded) is returned and ``reachable`` is False."""
    L1, L2 = np.hypot(D1[..., 0], D1[..., 1]), np.hypot(D2[..., 0], D2[..., 1])
    r = np.hypot(p[..., 0], p[..., 1])
    lo, hi = np.abs(L1 - L2), L1 + L2
    inv = 1.0 / (2.0 * L1 * L2)
    cos_g = np.clip((r * r - L1 * L1 - L2 * L2) * inv, -1.0, 1.0)
    sin_g = sign * np.sqrt(np.maximum((hi - r) * (hi + r) * (r - lo) * (r + lo), 0.0)) * inv
    g = np.arctan2(sin_g, cos_g)
    A1 = np.arctan2(p[..., 1], p[..., 0]) - np.arctan2(L2 * np.sin(g), L1 + L2 * np.cos(g))
    Theta1 = A1 - np.arctan2(D1[..., 1], D1[..., 0])
    Theta2 = A1 + g - np.arctan2(D2[..., 1], D2[..., 0])
    shape = np.broadcast_shapes(r.shape, lo.shape, Theta1.shape)
    return TwoLink(np.broadcast_to(Theta1, shape), np.broadcast_to(Theta2, shape), np.broadcast_to(r, shape),
                   np.broadcast_to(lo, shape), np.broadcast_to(hi, shape))


def _solve3(d: list[Array], c: list[Array | float], beta: Array | float, p: Array, phi: Array,
            sign: Array | float) -> tuple[Array, TwoLink]:
    """Three-joint chain with offsets ``c`` (joint ``k`` turns link ``k`` by ``theta_k + c_k``): returns the joint
    values ``(..., 3)`` and the shoulder-elbow two-link solution."""
    Theta3 = phi - beta
    tl = two_link(d[0], d[1], p - rotate_z(Theta3, d[2]), sign)
    theta = np.stack([tl.Theta1 - c[0], tl.Theta2 - tl.Theta1 - c[1], Theta3 - tl.Theta2 - c[2]], axis=-1)
    return theta, tl


def _solve_fixed(d: list[Array], beta: float, j: int, v: Array, p: Array, phi: Array,
                 sign: Array | float) -> tuple[Array, TwoLink]:
    """Four-joint chain with joint ``j`` held at ``v``: fold it into its neighbours, solve three joints, put it
    back. Returns the joint values ``(..., 4)`` and the two-link solution of the reduced chain."""
    zero = np.zeros_like(v)
    c: list[Array | float]
    b: Array | float
    if j == 0:
        p = p - rotate_z(v, d[0])
        dd, c, b = d[1:], [v, zero, zero], beta
    else:
        merged = d[j - 1] + rotate_z(v, d[j])
        dd = d[:j - 1] + [merged] + d[j + 1:]
        c = [zero, zero, zero]
        b = beta
        if j == 3:
            b = beta + v
        else:
            c[j] = v  # the joint after the held one turns from the held one's direction
    theta3, tl = _solve3(dd, c, b, p, phi, sign)
    theta = np.concatenate([theta3[..., :j], v[..., None], theta3[..., j:]], axis=-1)
    return theta, tl


@dataclass(frozen=True)
class ArmSolution:
    """Inverse kinematics of ``N`` wafer targets in the mount frame.

    Attributes:
        theta: joint values ``(N, n)`` [rad], each the representative nearest the middle of its range.
        heading: blade heading reached in the mount frame ``(N,)`` [rad] (an outcome for 2-joint arms).
        reachable: ``(N,)`` the two-link sub-chain reaches the target.
        reach, reach_min, reach_max: ``(N,)`` [m] distance shoulder-to-wrist and the reach interval.
        violation: ``(N, n)`` [rad] how far each joint lies beyond its limits (0 inside).
    """

    theta: Array
    heading: Array
    reachable: NDArray[np.bool_]
    reach: Array
    reach_min: Array
    reach_max: Array
    violation: Array


def solve_arm(arm: Arm, p: Array, phi: Array | None, sign: Array, value: Array | None = None) -> ArmSolution:
    """Joint values that put the wafer at ``p (N, 2)`` with heading ``phi (N,)`` in the mount frame.

    Args:
        phi: required for 3- and 4-joint arms; ignored (an outcome) for 2-joint arms.
        sign: branch sign per target (:func:`branch_sign`).
        value: for a 4-joint arm under ``fixed_joint``, the held joint's value per target (default: the rule's).
    """
    d, beta = link_vectors(arm)
    n = len(arm.joints)
    lower, upper, offset = arm.lower, arm.upper, arm.zero_offset
    if n == 2:
        tl = two_link(d[0], d[1], p, sign)
        theta = np.stack([tl.Theta1, tl.Theta2 - tl.Theta1], axis=-1)
    elif n == 3:
        assert phi is not None
        theta, tl = _solve3(d, [0.0, 0.0, 0.0], beta, p, phi, sign)
    else:
        assert phi is not None and arm.redundancy is not None
        red = arm.redundancy
        if red.rule == 'fixed_joint':
            v = np.full(p.shape[0], red.value) if value is None else np.asarray(value, dtype=float)
        else:
            v = nearest_value(arm, d, beta, p, phi, sign)
        theta, tl = _solve_fixed(d, beta, red.joint, v + offset[red.joint], p, phi, sign)
    heading = np.sum(theta, axis=1) + beta
    theta, violation = wrap_to_limits(theta - offset, lower, upper)
    return ArmSolution(theta=theta, heading=heading, reachable=tl.reachable, reach=tl.r, reach_min=tl.r_min,
                       reach_max=tl.r_max, violation=violation)


class OneArm(NamedTuple):
    """:class:`ArmSolution` of one target in floats: joint values (wrapped) [rad], heading [rad], reachable, the reach
    and its interval [m], each joint's violation of its limits [rad]."""

    theta: list[float]
    heading: float
    reachable: bool
    reach: float
    reach_min: float
    reach_max: float
    violation: list[float]


def _turn(angle: float, x: float, y: float) -> tuple[float, float]:
    c, s = math.cos(angle), math.sin(angle)
    return c * x - s * y, s * x + c * y


def _two_link_one(D1: tuple[float, float], D2: tuple[float, float], px: float, py: float, sign: float
                  ) -> tuple[float, float, float, float, float]:
    """:func:`two_link` of one target in floats: ``(Theta1, Theta2, r, r_min, r_max)``."""
    L1, L2, r = math.hypot(D1[0], D1[1]), math.hypot(D2[0], D2[1]), math.hypot(px, py)
    lo, hi = abs(L1 - L2), L1 + L2
    inv = 1.0 / (2.0 * L1 * L2)
    cos_g = min(max((r * r - L1 * L1 - L2 * L2) * inv, -1.0), 1.0)
    prod = (hi - r) * (hi + r) * (r - lo) * (r + lo)
    g = math.atan2(sign * math.sqrt(prod if prod >= 0.0 else 0.0) * inv, cos_g)
    A1 = math.atan2(py, px) - math.atan2(L2 * math.sin(g), L1 + L2 * math.cos(g))
    return A1 - math.atan2(D1[1], D1[0]), A1 + g - math.atan2(D2[1], D2[0]), r, lo, hi


def _fixed_one(d: list[tuple[float, float]], beta: float, j: int, v: float, px: float, py: float, phi: float,
               sign: float) -> tuple[list[float], float, float, float]:
    """:func:`_solve_fixed` (``j >= 0``) or :func:`_solve3` (``j = -1``) of one target in floats: the joint values
    (not wrapped) and the two-link sub-chain's reach and interval ``(r, r_min, r_max)``."""
    c, b = [0.0, 0.0, 0.0], beta
    if j == 0:
        mx, my = _turn(v, d[0][0], d[0][1])
        px, py, d, c[0] = px - mx, py - my, d[1:], v
    elif j > 0:
        mx, my = _turn(v, d[j][0], d[j][1])
        d = d[:j - 1] + [(d[j - 1][0] + mx, d[j - 1][1] + my)] + d[j + 1:]
        if j == 3:
            b = beta + v
        else:
            c[j] = v
    Theta3 = phi - b
    wx, wy = _turn(Theta3, d[2][0], d[2][1])
    T1, T2, r, lo, hi = _two_link_one(d[0], d[1], px - wx, py - wy, sign)
    theta = [T1 - c[0], T2 - T1 - c[1], Theta3 - T2 - c[2]]
    if j >= 0:
        theta.insert(j, v)
    return theta, r, lo, hi


def _wrap_one(arm: Arm, theta: list[float]) -> tuple[list[float], list[float]]:
    """:func:`wrap_to_limits` of one posture in floats."""
    wrapped, violation = [], []
    for t, joint in zip(theta, arm.joints, strict=True):
        mid = 0.5 * (joint.lower + joint.upper)
        t = mid + (t - mid + math.pi) % (2.0 * math.pi) - math.pi
        beyond = max(joint.lower - t, t - joint.upper) - LIMIT_SLACK
        wrapped.append(t)
        violation.append(beyond if beyond >= 0.0 else 0.0)
    return wrapped, violation


def _floats2(d: list[Array]) -> list[tuple[float, float]]:
    return [(float(v[0]), float(v[1])) for v in d]


def solve_arm_one(arm: Arm, px: float, py: float, phi: float, sign: float, value: float | None = None) -> OneArm:
    """:func:`solve_arm` of one target ``(px, py)`` [m], heading ``phi`` [rad] in floats (the same steps)."""
    d_arrays, beta = link_vectors(arm)
    d = _floats2(d_arrays)
    offset = [joint.zero_offset for joint in arm.joints]
    if len(arm.joints) == 2:
        T1, T2, r, lo, hi = _two_link_one(d[0], d[1], px, py, sign)
        theta = [T1, T2 - T1]
    else:
        j, v, red = -1, 0.0, arm.redundancy
        if red is not None:
            j = red.joint
            if red.rule == 'fixed_joint':
                v = red.value if value is None else value
            else:
                v = float(nearest_value(arm, d_arrays, beta, np.array([[px, py]]), np.array([phi]),
                                        np.array([sign]))[0])
            v = v + offset[j]
        theta, r, lo, hi = _fixed_one(d, beta, j, v, px, py, phi, sign)
    heading = sum(theta) + beta
    wrapped, violation = _wrap_one(arm, [t - o for t, o in zip(theta, offset, strict=True)])
    return OneArm(wrapped, heading, hi + REACH_SLACK >= r >= lo - REACH_SLACK, r, lo, hi, violation)


def _nearest_cost_one(arm: Arm, d: list[tuple[float, float]], beta: float, px: float, py: float, phi: float,
                      sign: float, v: float) -> float:
    """:func:`_nearest_cost` of one target and one held value in floats."""
    red = arm.redundancy
    assert red is not None
    theta, r, lo, hi = _fixed_one(d, beta, red.joint, v + arm.joints[red.joint].zero_offset, px, py, phi, sign)
    wrapped, violation = _wrap_one(arm, [t - joint.zero_offset for t, joint in zip(theta, arm.joints, strict=True)])
    if not hi + REACH_SLACK >= r >= lo - REACH_SLACK or max(violation) > 0.0:
        return math.inf
    cost = 0.0
    for t, joint, ref, w in zip(wrapped, arm.joints, red.reference, red.weights, strict=True):
        s = (t - ref) / (joint.upper - joint.lower)
        cost = cost + w * s * s
    return cost


def _nearest_cost(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array, sign: Array, v: Array) -> Array:
    """Cost of the ``nearest`` rule for held values ``v (N, G)``; ``inf`` where unreachable or beyond limits."""
    red = arm.redundancy
    assert red is not None
    offset = arm.zero_offset
    theta, tl = _solve_fixed(d, beta, red.joint, v + offset[red.joint], p[:, None, :], phi[:, None], sign[:, None])
    lower, upper = arm.lower, arm.upper
    theta, violation = wrap_to_limits(theta - offset, lower, upper)
    scaled = (theta - np.asarray(red.reference)) / (upper - lower)
    cost = np.sum(np.asarray(red.weights) * scaled * scaled, axis=-1)
    bad = ~tl.reachable | (np.max(violation, axis=-1) > 0.0)
    return np.where(bad, np.inf, cost)


def nearest_value(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array, sign: Array) -> Array:
    """The held joint's value of the posture nearest the reference.

    Joint limits and the reach cut the self-motion into *runs* of feasible postures; within a run the cost is
    smooth, and its minimum lies inside the run or at an edge. The joint is swept over :data:`NEAREST_GRID` values
    of its range; every grid value whose cost is no higher than its neighbours' (an infeasible neighbour counts as
    higher) is refined on both sides by golden-section search up to the neighbour or, if the neighbour is
    infeasible, up to the run's edge found by bisection (:data:`NEAREST_REFINE` steps each). The answer
    is the best over every run that holds a grid value; a run narrower than one grid step (the range / 120) can be
    missed. Where no posture is feasible the middle of the range is returned and the caller reports why."""
    red = arm.redundancy
    assert red is not None
    j = arm.joints[red.joint]
    n = p.shape[0]
    grid = np.linspace(j.lower, j.upper, NEAREST_GRID)
    cost = _nearest_cost(arm, d, beta, p, phi, sign, np.broadcast_to(grid, (n, NEAREST_GRID)))
    padded = np.pad(cost, ((0, 0), (1, 1)), constant_values=np.inf)
    local_min = np.isfinite(cost) & (cost <= padded[:, :-2]) & (cost <= padded[:, 2:])
    rows, cols = np.nonzero(local_min)
    cand_rows, cand_x, cand_f = [rows], [grid[cols]], [cost[rows, cols]]

    def f(r: NDArray[np.intp], x: Array) -> Array:
        if n == 1:  # one target: its few candidates in floats, without numpy's overhead per operation
            return np.array([_nearest_cost_one(arm, one, beta, px, py, phi0, sign0, v) for v in x.tolist()])
        return _nearest_cost(arm, d, beta, p[r], phi[r], sign[r], x[:, None])[:, 0]

    if n == 1:
        one, (px, py), phi0, sign0 = _floats2(d), p[0].tolist(), float(phi[0]), float(sign[0])

    for side in (-1, 1):
        nb = cols + side
        inside = (nb >= 0) & (nb < NEAREST_GRID)
        r, c, nb = rows[inside], cols[inside], nb[inside]
        # towards an infeasible neighbour, bisect to the edge of the run first
        edge = grid[nb]
        to_edge = ~np.isfinite(cost[r, nb])
        good, bad = grid[c][to_edge], grid[nb][to_edge]
        for _ in range(NEAREST_REFINE):
            mid = 0.5 * (good + bad)
            ok = np.isfinite(f(r[to_edge], mid))
            good, bad = np.where(ok, mid, good), np.where(ok, bad, mid)
        edge[to_edge] = good
        # golden section between the local minimum and its neighbour (or the run's edge)
        a, b = np.minimum(grid[c], edge), np.maximum(grid[c], edge)
        x1, x2 = b - _GOLDEN * (b - a), a + _GOLDEN * (b - a)
        f1, f2 = f(r, x1), f(r, x2)
        cand_rows += [r, r]
        cand_x += [edge, x1]
        cand_f += [f(r, edge), f1]
        for _ in range(NEAREST_REFINE):
            left = f1 <= f2  # the minimum lies in [a, x2]
            a, b = np.where(left, a, x1), np.where(left, x2, b)
            x1n, x2n = np.where(left, b - _GOLDEN * (b - a), x2), np.where(left, x1, a + _GOLDEN * (b - a))
            fn = f(r, np.where(left, x1n, x2n))
            f1, f2, x1, x2 = np.where(left, fn, f2), np.where(left, f1, fn), x1n, x2n
            cand_rows.append(r)
            cand_x.append(np.where(left, x1, x2))
            cand_f.append(np.where(left, f1, f2))
    R, X, F = np.concatenate(cand_rows), np.concatenate(cand_x), np.concatenate(cand_f)
    order = np.lexsort((F, R))  # by station, then cost
    R, X, F = R[order], X[order], F[order]
    first = np.flatnonzero(np.r_[True, R[1:] != R[:-1]]) if R.size else np.zeros(0, dtype=int)
    out = np.full(n, 0.5 * (j.lower + j.upper))
    out[R[first]] = X[first]
    return out


def branch_of(arm: Arm, theta: Array) -> tuple[str, ...]:
    """The branch of each posture ``theta (N, n)``: on which side of the line from the shoulder axis to the wrist
    axis (the wafer centre for 2 joints) the elbow lies, seen from above the platform (module docstring). For a
    4-joint arm the two-link sub-chain is the one left after folding the held (or swept) joint."""
    axes, wafer, _ = chain_forward(arm, theta)
    if len(arm.joints) == 2:
        points = [axes[:, 0], axes[:, 1], wafer]
    else:
        keep = [k for k in range(len(arm.joints)) if arm.redundancy is None or k != arm.redundancy.joint]
        points = [axes[:, k] for k in keep[:3]]
    u, v = points[1] - points[0], points[2] - points[1]
    cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    return tuple('right' if c >= 0.0 else 'left' for c in cross)


def line_rate_bounds(arm: Arm, theta0: Array, theta1: Array, s0: Array, s1: Array) -> Array:
    """Upper bounds ``(K, n)`` of ``|d theta_k / ds|`` over ``[s0_i, s1_i]`` on the straight line that translates the
    wafer, its heading fixed, from the posture ``theta0 (n,)`` (``s = 0``) to ``theta1 (n,)`` (``s = 1``).

    The heading is fixed, so the reduced chain's wrist axis (:func:`branch_of`'s three axes: shoulder, elbow, wrist
    after folding a held joint) moves on a line too, ``w(s) = w_0 + s (w_1 - w_0)`` from the shoulder axis, and only
    the two-link problem changes along it. With ``a_1``, ``a_2`` the two links (lengths ``L1``, ``L2``, relative
    angle ``g``), ``w' = A1' a_1^perp + A2' a_2^perp`` for the links' directions ``A1``, ``A2``; crossing with
    ``a_2``, ``a_1`` and ``a_1 + a_2 = w``:

        ``|A1'| <= |w'| / (L1 |sin g|)``, ``|A2' - A1'| <= |w'| r / (L1 L2 |sin g|)``, ``|A2'| <= |w'| / (L2 |sin g|)``

    for the shoulder, the elbow and the wrist (which turns by ``-A2'``: the heading is fixed); a held joint does not
    move. On ``[s0, s1]``: ``r^2(s)`` is a convex quadratic, so its range is exact, ``r <= r_max``, and
    ``sin^2 g = ((L1 + L2)^2 - r^2)(r^2 - (L1 - L2)^2) / (2 L1 L2)^2`` is concave in ``r^2``: its minimum is at an
    end of that range. A line through a stretched or folded posture (``sin g = 0``) has an infinite bound.
    """
    axes, _, _ = chain_forward(arm, np.stack([theta0, theta1]))
    n = len(arm.joints)
    keep = [k for k in range(n) if arm.redundancy is None or n < 4 or k != arm.redundancy.joint][:3]
    sh, el, wr = (axes[:, k] for k in keep)
    L1, L2 = float(np.hypot(*(el[0] - sh[0]))), float(np.hypot(*(wr[0] - el[0])))
    w0, dw = wr[0] - sh[0], (wr[1] - sh[1]) - (wr[0] - sh[0])
    s0, s1 = np.minimum(s0, s1), np.maximum(s0, s1)
    speed = float(np.hypot(*dw))
    sq = float(dw @ dw)
    star = np.clip(-float(w0 @ dw) / sq, s0, s1) if sq > 0.0 else s0

    def r2(s: Array) -> Array:
        return np.asarray((w0[0] + s * dw[0]) ** 2 + (w0[1] + s * dw[1]) ** 2, dtype=np.float64)

    lo, hi = r2(star), np.maximum(r2(s0), r2(s1))
    sin2 = np.minimum(*(((L1 + L2) ** 2 - x) * (x - (L1 - L2) ** 2) for x in (lo, hi))) / (2.0 * L1 * L2) ** 2
    with np.errstate(divide='ignore', invalid='ignore'):
        sg = np.sqrt(np.maximum(sin2, 0.0))
        rates = [speed / (L1 * sg), speed * np.sqrt(hi) / (L1 * L2 * sg), speed / (L2 * sg)]
    out = np.zeros((s0.shape[0], n))
    for k, rate in zip(keep, rates, strict=True):
        out[:, k] = np.where(speed > 0.0, rate, 0.0)
    return out

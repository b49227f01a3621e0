"""The ``nearest`` redundancy rule of a 4-joint arm: the held joint's value whose posture is nearest the reference
(:class:`~gpr_kinematics.robot.description.Redundancy`), for ``N`` targets at once (:func:`nearest_value`).
SI units: metres, radians.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .arm_chain import REACH_SLACK, fixed_one, floats2, solve_fixed, wrap_one, wrap_to_limits
from .description import Arm

Array = NDArray[np.float64]

#: The ``nearest`` rule's sweep of the held joint's range and its refinement steps (:func:`nearest_value`).
NEAREST_GRID = 121
NEAREST_REFINE = 32
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def nearest_cost_one(arm: Arm, d: list[tuple[float, float]], beta: float, px: float, py: float, phi: float,
                      sign: float, v: float) -> float:
    """:func:`nearest_cost` of one target and one held value in floats."""
    red = arm.redundancy
    assert red is not None
    theta, r, lo, hi = fixed_one(d, beta, red.joint, v + arm.joints[red.joint].zero_offset, px, py, phi, sign)
    wrapped, violation = wrap_one(arm, [t - joint.zero_offset for t, joint in zip(theta, arm.joints, strict=True)])
    if not hi + REACH_SLACK >= r >= lo - REACH_SLACK or max(violation) > 0.0:
        return math.inf
    cost = 0.0
    for t, joint, ref, w in zip(wrapped, arm.joints, red.reference, red.weights, strict=True):
        s = (t - ref) / (joint.upper - joint.lower)
        cost = cost + w * s * s
    return cost


def nearest_cost(arm: Arm, d: list[Array], beta: float, p: Array, phi: Array, sign: Array, v: Array) -> Array:
    """Cost of the ``nearest`` rule for held values ``v (N, G)``; ``inf`` where unreachable or beyond limits."""
    red = arm.redundancy
    assert red is not None
    offset = arm.zero_offset
    theta, tl = solve_fixed(d, beta, red.joint, v + offset[red.joint], p[:, None, :], phi[:, None], sign[:, None])
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
    cost = nearest_cost(arm, d, beta, p, phi, sign, np.broadcast_to(grid, (n, NEAREST_GRID)))
    padded = np.pad(cost, ((0, 0), (1, 1)), constant_values=np.inf)
    local_min = np.isfinite(cost) & (cost <= padded[:, :-2]) & (cost <= padded[:, 2:])
    rows, cols = np.nonzero(local_min)
    cand_rows, cand_x, cand_f = [rows], [grid[cols]], [cost[rows, cols]]

    def f(r: NDArray[np.intp], x: Array) -> Array:
        if n == 1:  # one target: its few candidates in floats, without numpy's overhead per operation
            return np.array([nearest_cost_one(arm, one, beta, px, py, phi0, sign0, v) for v in x.tolist()])
        return nearest_cost(arm, d, beta, p[r], phi[r], sign[r], x[:, None])[:, 0]

    if n == 1:
        one, (px, py), phi0, sign0 = floats2(d), p[0].tolist(), float(phi[0]), float(sign[0])

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

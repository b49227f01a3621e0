"""Why no posture of a ``nearest`` arm's self-motion reaches a station (:func:`self_motion_fault`), the refusal of
:func:`~gpr_kinematics.robot.inverse.solve_stations` where the rule answers the middle of the held joint's range
(:func:`~gpr_kinematics.robot.nearest.nearest_value`, whose partial chain a reach message would describe). SI units:
metres, radians."""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .arm_chain import link_vectors, solve_fixed, wrap_to_limits
from .description import Arm
from .nearest import limit_edges, reach_edges

Array = NDArray[np.float64]

#: Held values sampled over the held joint's range, besides the edges of the self-motion's runs.
FAULT_SAMPLES = 3601


def held_values(arm: Arm, d: list[Array], beta: float, p: Array, phi: float) -> Array:
    """The held joint's values searched for target ``p (2,)`` [m], heading ``phi`` [rad]: :data:`FAULT_SAMPLES` over
    its range and, within it, the edges of the self-motion's runs in closed form (the sub-chain stretched or folded,
    another joint at a limit: :mod:`~gpr_kinematics.robot.nearest`), where the least excess over a limit often lies."""
    assert arm.redundancy is not None
    held = arm.joints[arm.redundancy.joint]
    lo, hi = held.lower, held.upper
    pp, ff = p[None], np.array([phi])
    edges = np.concatenate([reach_edges(arm, d, beta, pp, ff), limit_edges(arm, d, beta, pp, ff)], axis=1).ravel()
    edges = lo + np.mod(edges[np.isfinite(edges)] - lo, 2.0 * math.pi)  # representatives from lo (a range over a turn:
    edges = np.concatenate([edges, edges + 2.0 * math.pi, edges + 4.0 * math.pi])   # the next turns too)
    return np.unique(np.concatenate([np.linspace(lo, hi, FAULT_SAMPLES), edges[(edges >= lo) & (edges <= hi)]]))


def self_motion_fault(a: Arm, p: Array, phi: float, sign: float, branch: str) -> str:
    """Why no posture of the self-motion of ``nearest`` arm ``a`` reaches target ``p (2,)`` [m] at heading ``phi``
    [rad] on the branch of ``sign`` (named by ``branch``): out of reach at every held value, or beyond a joint limit
    wherever in reach, by the least violation over :func:`held_values`."""
    assert a.redundancy is not None
    k, o = a.redundancy.joint, a.zero_offset
    held = a.joints[k]
    d, beta = link_vectors(a)
    v = held_values(a, d, beta, p, phi)
    chain, tl = solve_fixed(d, beta, k, v + o[k], np.broadcast_to(p, (v.size, 2)), np.full(v.size, phi), sign)
    theta, violation = wrap_to_limits(chain - o, a.lower, a.upper)
    if not tl.reachable.any():
        miss = float(np.min(np.maximum(tl.r - tl.r_max, tl.r_min - tl.r)))
        return (f'out of reach of arm {a.name}: at no value of its held joint {held.name} within [{held.lower:g}, '
                f'{held.upper:g}] rad does it reach the station, the closest misses by {miss * 1e3:.4g} mm ({branch})')
    worst = np.where(tl.reachable, np.max(violation, axis=1), np.inf)
    b = int(np.argmin(worst))
    m = int(np.argmax(violation[b]))
    j, value = a.joints[m], float(theta[b, m])
    side, limit = ('upper', j.upper) if value > j.upper else ('lower', j.lower)
    span = v[tl.reachable]
    return (f'no posture of arm {a.name} within its joint limits reaches the station: it is in reach for its held '
            f'joint {held.name} within [{span.min():.4g}, {span.max():.4g}] rad, where {j.name} stays beyond its '
            f'{side} limit {limit:g} rad, by {abs(value - limit):.3g} rad at the least ({held.name} = {v[b]:.4g} '
            f'rad; {branch})')

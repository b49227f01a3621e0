"""Straight entries: the joints that move the wafer on a straight line with its orientation fixed.

A move into an ``exit`` waypoint, or out of an ``entry`` one (:func:`gpr_kinematics.robot.program.expand`), keeps
the wafer on the segment from the pose ``p_0`` of its first waypoint to ``p_1`` of its second, with their common
orientation: ``p(s) = p_0 + s (p_1 - p_0)``, ``s`` in [0, 1] (the profile of :mod:`gpr_kinematics.robot.timing`).
The segment is parallel to the station plane (both ends are the same station pose moved along its heading), so the
platform's normal and height, hence the rods, do not change along it: only the arm moves, solved in closed form at
every point on the waypoints' branch (a 4-joint arm holds its redundant joint), so the wafer lies on the line to
rounding (~1e-15 m) at every instant, not only at samples. The other arm holds its joints.

For the timing (:func:`~gpr_kinematics.robot.timing.parameterise`) the path's derivatives are **bounded**, not
sampled: ``G1 = max |dP/ds|`` over the line is at most the largest of the closed-form bounds of
:func:`~gpr_kinematics.robot.line_bounds.line_rate_bounds` on the :data:`GRID` - 1 pieces of the line, so a
profile with ``G1 s' <= v`` keeps every joint within its velocity limit at every instant (what the clearance
certificate relies on; docs/cell.md, "Straight entries"); ``G2`` and ``G3``, for the acceleration and jerk limits,
bound ``max |d^2P/ds^2|`` and ``max |d^3P/ds^3|`` likewise, from the exact derivatives at 32 points per piece and
a bound of the next derivative on each piece, the loose pieces split
(:func:`~gpr_kinematics.robot.line_bounds.line_derivative_bounds`).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..core import forward_batch
from ..errors import LimitError
from .description import Arm, RobotDescription
from .forward import base_pose
from .inverse import _arm_target, _heading_in, solve_stations
from .line_bounds import line_derivative_bounds, line_rate_bounds
from .planar_arm import branch_sign, solve_arm
from .stations import Stations

Array = NDArray[np.float64]

#: Points on which a line's joint derivatives are taken (the ends of its pieces).
GRID = 257
#: Largest joint change between grid points [rad or m] before a line is taken to jump (a branch change).
MAX_STEP = 0.25


def line_stations(way: Stations, m: int, s: Array) -> Stations:
    """The wafer poses at ``s`` on the line of the move from waypoint ``m`` to ``m + 1`` (orientation of ``m + 1``)."""
    p0, p1 = way.position[m], way.position[m + 1]
    n = s.shape[0]
    rep = np.full(n, m + 1)
    return Stations(p0 + s[:, None] * (p1 - p0), way.tilt[rep], way.azimuth[rep], way.heading[rep],
                    way.heading_free[rep], tuple(way.names[m + 1] for _ in range(n)))


def line_positions(robot: RobotDescription, way: Stations, arm: str, branch: str, start: Array, cols: slice,
                   m: int, s: Array, label: str = '') -> Array:
    """Joint rows ``(len(s), J)`` on the line of move ``m``: ``start`` (the joints at waypoint ``m``) with ``arm``'s
    columns ``cols`` solved at each point (module docstring). The line lies in the station plane, so the rods stay
    those of ``start`` and the platform pose with them; the arm is solved in closed form for the wafer targets in the
    platform (the steps of :func:`~gpr_kinematics.robot.inverse.solve_stations` after the platform).

    Raises:
        LimitError: a point of the line out of reach or beyond a limit (the move and where on it).
    """
    a = robot.arm(arm)
    stations = line_stations(way, m, s)
    n = s.shape[0]
    base = base_pose(robot, n)
    gpr = forward_batch(np.repeat(start[None, :3], n, axis=0), robot.config, check_limits=False)
    R_b = np.swapaxes(base.rotation, 1, 2) @ stations.rotation
    w = np.einsum('nji,nj->ni', gpr.rotation, base.inverse_apply(stations.position) - gpr.position)
    p_m, phi_m = _arm_target(a, w, _heading_in(gpr.rotation, R_b))
    sol = solve_arm(a, p_m, phi_m, np.full(n, branch_sign(branch)))
    bad = ~sol.reachable | np.any(sol.violation > 0.0, axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        try:
            solve_stations(robot, line_stations(way, m, s[k:k + 1]), arm, branch=branch)
        except LimitError as exc:
            raise LimitError(f'{label}: the straight line into it, at {s[k]:.3g} of its length: {exc}') from None
    out = np.repeat(start[None, :], n, axis=0)
    out[:, cols] = sol.theta
    return out


def line_gains(arm: Arm, cols: slice, rows: Array, label: str) -> tuple[Array, Array, Array]:
    """``(G1, G2, G3)`` ``(J,)`` of the line whose joint rows ``(GRID, J)`` are taken at ``s`` evenly spaced in
    [0, 1] (``arm``'s joints in the columns ``cols``): bounds of ``max |dP/ds|``, ``max |d^2P/ds^2|`` and
    ``max |d^3P/ds^3|`` over the line (module docstring).

    Raises:
        LimitError: the line passes through a stretched or folded posture (no finite bound) or jumps.
    """
    jump = np.max(np.abs(np.diff(rows, axis=0)))
    if jump > MAX_STEP:
        raise LimitError(f'{label}: the straight line into it changes a joint by {jump:.3g} between neighbouring '
                         'points: the arm would change its branch or wrap a joint on the way; move the entry')
    s = np.linspace(0.0, 1.0, rows.shape[0])
    G1, G2, G3 = (np.zeros(rows.shape[1]) for _ in range(3))
    G1[cols] = np.max(line_rate_bounds(arm, rows[0, cols], rows[-1, cols], s[:-1], s[1:]), axis=0)
    G2[cols], G3[cols] = line_derivative_bounds(arm, rows[:, cols], s)
    if not (np.all(np.isfinite(G1)) and np.all(np.isfinite(G2)) and np.all(np.isfinite(G3))):
        raise LimitError(f'{label}: the straight line into it passes through a stretched or folded arm posture; '
                         'move the entry or the station')
    return G1, G2, G3

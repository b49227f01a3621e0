"""A joint trajectory as a motion of the robot's bodies (a FollowJointTrajectory goal as the controller interpolates
it), with proven bounds on how far any point of a body moves between two instants (docs/cell.md, "Goals of the robot
simulator"): :class:`TrajectoryMotion`, the interface of :class:`~gpr_kinematics.safety.motion.PlanMotion`.

**Joints.** Between two instants joint ``i`` travels exactly ``V_i``, its total variation on the spline
(:meth:`~gpr_kinematics.robot.spline.Spline.travel`: from the roots of the derivative of every segment's polynomial,
over any number of segments); the arm bound is then :class:`~gpr_kinematics.safety.motion.PlanMotion`'s,
``arm_b = sum_i L_ib V_i``.

**Platform** (:func:`platform_travel`). The rods follow any curve ``q(t)``; the bounds of a joint-space line
(:func:`~gpr_kinematics.safety.motion.platform_motion`) generalise with the rods' common motion ``m = mean_k q_k`` and
their differences ``d_k = q_k - m`` (polynomials of the same spline, their travels ``T_m``, ``T_dk`` exact), since
``qdot_k = mdot + ddot_k``. With ``E_ab = P_b - P_a`` (``P_k = B_k + (q_k + o_k) u_k``, affine in ``q``):

* the closure's flux: ``d(L_ab^2)/dt = 2 (mdot E_ab.(u_b - u_a) + ddot_b E_ab.u_b - ddot_a E_ab.u_a)``, so
  ``int |d(L^2)/dt| <= 2 sum_ab (max|E_ab.(u_b - u_a)| T_m + max|E_ab.u_b| T_db + max|E_ab.u_a| T_da)``, then the
  drift bound (docs/cell.md, eq. (4): Bratovanov & Sotirov's closure, eq. (6), differentiated as their eq. (3));
* the normal ``N = E_12 x E_13``: ``Ndot = sum_k qdot_k c_k`` with ``c_1 = -(u_1 x E_13) - E_12 x u_1``,
  ``c_2 = u_2 x E_13``, ``c_3 = E_12 x u_3``, so (``sum_k ddot_k = 0``) ``int |Ndot| <= max|sum_k c_k| T_m + sum_k
  max|c_k - cbar| T_dk`` (``cbar = mean_k c_k``), and the normal turns by at most that over ``min |N| >= (|N0| + |N1|
  - int |Ndot|) / 2``;
* the turn about the normal: per edge ``((T_a + T_b) sin a + 2 int |rdot|) / min |E_ab|``, ``min |E_ab| >= (|E0| +
  |E1| - T_a - T_b) / 2``;
* the reference point: ``int |mean_k u_k qdot_k| <= |ubar| T_m + sum_k |u_k - ubar| T_dk / 3`` (``ubar = mean_k
  u_k``; again ``sum_k ddot_k = 0``), plus the drift.

Every ``max`` is over the rods' box on the interval, ``q_k`` within ``(q0_k + q1_k -+ T_k) / 2``, of a function
affine in ``q``: ``|f(q)| <= |f(q_mid)| + sum_j |df/dq_j| |q_j - q_mid_j|``. With parallel rods a common motion has
``E.(u_b - u_a) = 0`` and ``sum_k c_k = 0``: a platform lifted straight up neither drifts nor turns, as on a line.
No body is said to translate (the convex bound of a straight entry needs a known line), except where nothing moves.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from ..core.machine import MachineGeometry
from ..core.virtual_joints import EDGES
from ..robot.description import RobotDescription
from ..robot.plan import joint_limits
from ..robot.spline import Spline
from ..robot.trajectory import JointTrajectory, spline
from .motion import (
    LIPSCHITZ,
    IntervalBounds,
    Levers,
    Snapshot,
    drift_bound,
    platform_bound,
    robot_snapshot,
    rod_angles,
    rod_directions,
)

Array = NDArray[np.float64]
Ints = NDArray[np.int64]


def _with_rod_modes(X: Array) -> Array:
    """Joint rows ``(n, N)`` with the rods' mean and their differences from it appended ``(n, N + 4)``."""
    mean = X[:, :3].mean(axis=1, keepdims=True)
    return np.hstack([X, mean, X[:, :3] - mean])


def _box_max(f: Callable[[Array], Array], mid: Array, steps: list[Array], half: Array) -> Array:
    """``max |f|`` ``(K,)`` over the rods' box ``mid +- half`` of ``f``, affine in the rods, given the joint centres
    at ``mid`` and at ``mid + e_j`` (``steps``): ``|f(mid)| + sum_j |f(mid + e_j) - f(mid)| half_j``."""
    def size(v: Array) -> Array:
        return np.asarray(np.abs(v) if v.ndim == 1 else np.linalg.norm(v, axis=1), dtype=np.float64)

    at = f(mid)
    return size(at) + sum(size(f(s) - at) * half[:, j] for j, s in enumerate(steps))


def _normal_rates(P: Array, u: Array) -> list[Array]:
    """``c_1, c_2, c_3`` ``(K, 3)`` of ``Ndot = sum_k qdot_k c_k`` at joint centres ``P (K, 3, 3)`` (module
    docstring)."""
    E12, E13 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    return [-np.cross(u[0], E13) - np.cross(E12, u[0]), np.cross(u[1], E13), np.cross(E12, u[2])]


def platform_travel(geo: MachineGeometry, Q0: Array, Q1: Array, T: Array, Tm: Array, Td: Array, sigma: Array,
                    gamma: Array, lip: float) -> tuple[Array, Array, Array]:
    """``(A, Omega, drift)`` ``(K,)`` as :func:`~gpr_kinematics.safety.motion.platform_motion` gives them, for rods
    that go from ``Q0`` to ``Q1`` ``(K, 3)`` on any path: each rod travelling ``T (K, 3)``, their mean ``Tm (K,)`` and
    their differences from it ``Td (K, 3)`` [m] (module docstring); ``sigma``, ``gamma`` ``(K, 2)`` at the ends."""
    u = rod_directions(geo)
    mid, half = 0.5 * (Q0 + Q1), 0.5 * T
    Pm = geo.base_points(mid)
    steps = [geo.base_points(mid + np.eye(3)[j]) for j in range(3)]
    P0, P1 = geo.base_points(Q0), geo.base_points(Q1)
    flux = np.zeros(Tm.shape)
    for a, b in EDGES:
        def along(w: Array, a: int = a, b: int = b) -> Callable[[Array], Array]:
            return lambda P: np.asarray((P[:, b] - P[:, a]) @ w, dtype=np.float64)

        flux += 2.0 * (_box_max(along(u[b] - u[a]), Pm, steps, half) * Tm
                       + _box_max(along(u[b]), Pm, steps, half) * Td[:, b]
                       + _box_max(along(u[a]), Pm, steps, half) * Td[:, a])
    rv = drift_bound(flux, sigma, gamma, lip)
    turn = _box_max(lambda P: np.asarray(sum(_normal_rates(P, u)), dtype=np.float64), Pm, steps, half) * Tm
    for k in range(3):
        def rate(P: Array, k: int = k) -> Array:     # c_k - mean_j c_j: sum_k ddot_k = 0
            c = _normal_rates(P, u)
            return np.asarray(c[k] - sum(c) / 3.0, dtype=np.float64)

        turn += _box_max(rate, Pm, steps, half) * Td[:, k]
    N0, N1 = (np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]) for P in (P0, P1))
    n0, n1 = np.linalg.norm(N0, axis=1), np.linalg.norm(N1, axis=1)
    nmin = 0.5 * (n0 + n1 - turn)
    with np.errstate(invalid='ignore', divide='ignore'):
        omega_t = np.where(turn > 0.0, np.where(nmin > 0.0, turn / nmin, np.inf), 0.0)
    sin_a = rod_angles(u, (N0, N1), (n0, n1)) + omega_t
    omega_n = np.zeros(Tm.shape)
    for a, b in EDGES:
        lmin = 0.5 * (np.linalg.norm(P0[:, b] - P0[:, a], axis=1) + np.linalg.norm(P1[:, b] - P1[:, a], axis=1)
                      - T[:, a] - T[:, b])
        move = (T[:, a] + T[:, b]) * sin_a + 2.0 * rv
        with np.errstate(invalid='ignore', divide='ignore'):
            omega_n = np.maximum(omega_n, np.where(move > 0.0, np.where(lmin > 0.0, move / lmin, np.inf), 0.0))
    ubar = u.mean(axis=0)
    A = float(np.linalg.norm(ubar)) * Tm + Td @ np.linalg.norm(u - ubar, axis=1) / 3.0 + rv
    return A, omega_t + omega_n, rv


@dataclass(frozen=True)
class TrajectoryMotion:
    """A joint trajectory of the robot as a motion (module docstring): ``spline`` over the robot's joints (rods, then
    every arm's: :func:`~gpr_kinematics.robot.plan.joint_limits`' order), then the rods' mean and differences."""

    robot: RobotDescription
    spline: Spline

    @classmethod
    def of(cls, robot: RobotDescription, traj: JointTrajectory, columns: Ints, start: Array) -> TrajectoryMotion:
        """``traj`` over the robot's joints ``columns`` (indices in that order), every other joint held at ``start``
        ``(N,)`` (every joint at ``t = 0``; the goal's joints start there at rest when its first point lies after
        ``t = 0``), interpolated as :func:`~gpr_kinematics.robot.trajectory.evaluate` does."""
        names, _, _, _ = joint_limits(robot)
        start = np.asarray(start, dtype=float)
        n = len(traj)

        def full(values: Array | None, fill: Array) -> Array | None:
            if values is None:
                return None
            out = np.repeat(fill[None, :], n, axis=0)
            out[:, columns] = values
            return _with_rod_modes(out)

        zero = np.zeros_like(start)
        P = full(traj.positions, start)
        assert P is not None
        whole = JointTrajectory((*names, 'rods_mean', 'rod_1_mode', 'rod_2_mode', 'rod_3_mode'), traj.time, P,
                                full(traj.velocities, zero), full(traj.accelerations, zero))
        return cls(robot, spline(whole, _with_rod_modes(start[None, :])[0]))

    @property
    def joints(self) -> int:
        return int(self.spline.last.shape[1]) - 4

    @cached_property
    def knots(self) -> Array:
        """The start and the last point's time [s]: the bounds hold over any interval, across the trajectory's
        points."""
        return np.array([0.0, float(self.spline.knots[-1])])

    @cached_property
    def geometry(self) -> MachineGeometry:
        return MachineGeometry.of(self.robot.config)

    def snapshot(self, t: Array) -> Snapshot:
        """The robot at times ``t`` [s] (the controller's interpolation)."""
        return robot_snapshot(self.robot, self.spline.evaluate(np.asarray(t, dtype=float))[0][:, :self.joints])

    def bounds(self, t0: Array, t1: Array, lev: Levers, sigma: Array, gamma: Array, displacement: Array
               ) -> IntervalBounds:
        """Bounds over the intervals ``[t0, t1]`` (module docstring); ``sigma``, ``gamma``, ``displacement``
        ``(K, 2)`` the :class:`~gpr_kinematics.safety.motion.Snapshot` values at the ends."""
        N, K = self.joints, t0.shape[0]
        T = self.spline.travel(t0, t1)
        ends = self.spline.evaluate(np.concatenate([t0, t1]))[0][:, :3]
        arm = T[:, :N] @ lev.lever
        A, omega, drift = platform_travel(self.geometry, ends[:K], ends[K:], T[:, :3], T[:, N], T[:, N + 1:],
                                          sigma, gamma, LIPSCHITZ)
        plat = platform_bound(self.geometry, lev, A, omega, drift, displacement)
        shift = np.where(((arm + plat) > 0.0)[:, :, None], np.nan, 0.0) * np.ones(3)
        return IntervalBounds(arm, plat, shift)

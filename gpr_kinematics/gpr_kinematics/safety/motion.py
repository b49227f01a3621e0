"""A checked program as a motion of the robot's bodies, and proven bounds on how far any point of a body moves
between two instants (docs/cell.md, "The certificate").

:class:`PlanMotion` gives the exact joint values, frame poses and platform state at any instant, and for an interval
``[t0, t1]`` inside one move (or hold) three bounds per body: ``arm`` (the displacement relative to the platform
caused by the arm joints), ``platform`` (the displacement caused by the platform's motion) and, where the body's
motion is a pure translation (the wafer and blade on a straight entry; everything during a hold), that translation.

**Arm joints.** Joint ``i`` turns the bodies after it about its axis (parallel to the platform normal); a point at
in-plane distance at most ``L_ib`` from that axis (the link lengths from axis ``i`` to the body's link frame plus the
body's reach from that frame, by the triangle inequality, whatever the other joints do) moves by at most ``L_ib``
times the joint's path length ``V_i``, so ``arm_b = sum_i L_ib V_i``. ``V_i = |D_i| |s1 - s0|`` on a joint-space line
(``P = P_m + s D``, every joint monotone in ``s``); on a straight entry ``V_i <= |s1 - s0| max |dtheta_i/ds|`` with
the closed-form bound of :func:`~gpr_kinematics.robot.line_bounds.line_rate_bounds` on ``[s0, s1]``.

**Platform** (:func:`platform_motion`). The joint centres ``P_k = B_k + (q_k + o_k) u_k`` move along the rods; the
platform is a rigid body whose points at the joint centres have body coordinates ``r_k(X)`` that drift with the
virtual joints ``X``. With ``w_k = u_k qdot_k - R rdot_k`` the body's velocity at those points, a body point ``x``
moves at ``|v(x)| <= |mean_k w_k| + |omega| (|x| + |rbar|)`` (``rbar`` the joint centres' centroid in the body).
``|omega_t| = |ndot|``, the turn rate of the joint-centre triangle's normal ``N = E12 x E13`` (a quadratic in ``s``:
model-free); ``|omega_n| L_ab <= |qdot_a| sin(a_a) + |qdot_b| sin(a_b) + |rdot_a| + |rdot_b|`` (the in-plane parts of
an edge's end velocities, ``a_k`` the angle of rod ``k`` from the normal). The virtual joints follow from the
closure ``F(X) = L(q)^2`` (Bratovanov & Sotirov, eq. (6), differentiated as their eq. (3)):
``|Xdot|_W <= |d(L^2)/dt| / sigma(t)``, ``sigma`` the smallest singular value of ``dF/dX`` in the solver's metric;
``sigma(t) >= sigma(t0) - Lip |X(t) - X(t0)|_W`` gives ``int |Xdot|_W <= (sigma0 - sqrt(sigma0^2 - 2 Lip I)) / Lip``
with ``I = int |d(L^2)/dt|`` (the rods' motion), and ``|rdot_k| <= gamma |Xdot|_W``. For the ``radial`` model
(square closure, ``Lip = 4 sqrt(2)``, ``gamma = 1``) this is exact; for the underdetermined models it is the
first-order sensitivity of eqs. (3)-(5).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..core import ForwardBatch, forward_batch
from ..core.config import GprConfig
from ..core.machine import MachineGeometry
from ..core.virtual_joints import EDGES, coordinate_scale, make_model
from ..robot.description import RobotDescription
from ..robot.forward import arm_transforms, base_pose
from ..robot.line_bounds import line_rate_bounds
from ..robot.plan import ProgramPlan, joint_limits, line_moves, plan_samples
from ..robot.timing import evaluate, locate, sample_at
from ..robot.transforms import PoseBatch
from .bodies import Body

Array = NDArray[np.float64]

#: Lipschitz constant of ``dF/dX`` in ``X`` for the radial model (each entry ``2 (l_b - l_a cos)`` moves by at
#: most ``2 (|dl_a| + |dl_b|)``; six entries): ``4 sqrt(2)``.
LIPSCHITZ = 4.0 * np.sqrt(2.0)
#: The virtual-joint models whose bounds between samples are proofs: the square closure of ``radial``. For the
#: underdetermined models (their ``X`` a minimum-norm or least-cost solution) the virtual joints' rates enter to first
#: order (module docstring), as the slip bound's higher derivatives do (:mod:`~gpr_kinematics.safety.slip_bound`).
PROVEN_MODELS = ('radial',)


@dataclass(frozen=True)
class Snapshot:
    """The robot at instants: joint ``rows (N, J)``, world poses ``frames[name] = (positions (N, 3), rotations
    (N, 3, 3))``, and the platform's ``sigma`` (smallest singular value of ``dF/dX`` in the solver's metric),
    ``gamma`` (``|rdot_k| / |Xdot|_W``) and ``displacement`` (largest joint displacement [m]), ``(N,)`` each."""

    rows: Array
    frames: dict[str, tuple[Array, Array]]
    sigma: Array
    gamma: Array
    displacement: Array


@dataclass(frozen=True)
class Levers:
    """Per body: ``lever (J, B)`` the displacement per unit path length of each joint (0 for the rods), ``reach
    (B,)`` the farthest point from the platform origin [m], ``platform (B,)`` carried by the platform, ``arm`` the
    arm that carries it and ``rides`` whether it is fixed to the arm's last link frame (the last link, the blade and
    the wafer), whose orientation is the blade's heading: on a straight entry it translates with the wafer."""

    lever: Array
    reach: Array
    platform: NDArray[np.bool_]
    arm: tuple[str | None, ...]
    rides: NDArray[np.bool_]


@dataclass(frozen=True)
class IntervalBounds:
    """Bounds over intervals ``(K,)`` for bodies ``(B,)``: ``arm``, ``platform`` ``(K, B)`` [m] and ``shift (K, B, 3)``
    the body's translation where its motion is one (NaN elsewhere) (module docstring)."""

    arm: Array
    platform: Array
    shift: Array


def _corners(body: Body) -> Array:
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    return np.asarray(body.position + (signs * body.half) @ body.rotation.T, dtype=np.float64)


def levers(robot: RobotDescription, bodies: Sequence[Body]) -> Levers:
    """The :class:`Levers` of ``bodies`` (module docstring); fixed bodies and the column get zeros."""
    names, _, _, slices = joint_limits(robot)
    B = len(bodies)
    L, reach = np.zeros((len(names), B)), np.zeros(B)
    platform, rides = np.zeros(B, dtype=bool), np.zeros(B, dtype=bool)
    arms: list[str | None] = [None] * B
    for b, body in enumerate(bodies):
        if body.frame is None or body.frame == 'gpr_base':
            continue
        platform[b] = True
        corners = _corners(body)
        if body.frame == 'gpr_platform':
            reach[b] = float(np.max(np.linalg.norm(corners, axis=1)))
            continue
        arm_i = next(i for i, a in enumerate(robot.arms) if body.frame.startswith(a.name + '_'))
        arm, cols = robot.arms[arm_i], slices[arm_i]
        frames = arm_transforms(arm, np.zeros((1, len(arm.joints))))
        idx = [f for f, _, _ in frames].index(body.frame)
        link = min(idx, len(arm.joints) - 1)          # the last link frame carries the blade and the wafer
        arms[b], rides[b] = arm.name, idx >= len(arm.joints) - 1
        chain = PoseBatch.fixed(np.zeros(3), np.eye(3), 1)
        for _, _, pose in frames[link + 1:idx + 1]:
            chain = chain.compose(pose)
        pts = (chain.rotation[0] @ corners.T).T + chain.position[0]
        plane, up = float(np.max(np.hypot(pts[:, 0], pts[:, 1]))), float(np.max(np.abs(pts[:, 2])))
        lengths = [j.length for j in arm.joints]
        for i in range(link + 1):
            L[cols.start + i, b] = sum(lengths[i:link]) + plane
        height = abs(arm.mount_position[2]) + sum(abs(j.height) for j in arm.joints[:link]) + up
        reach[b] = float(np.hypot(float(np.hypot(*arm.mount_position[:2])) + sum(lengths[:link]) + plane, height))
    return Levers(L, reach, platform, tuple(arms), rides)


def drift_bound(flux: Array, sigma: Array, gamma: Array, lip: float) -> Array:
    """``int |rdot_k|`` ``(K,)`` [m]: how far the joint centres drift in the body while the rods' squared side lengths
    change by ``flux = int |d(L^2)/dt|`` (eq. (4) of docs/cell.md, from either end; ``sigma``, ``gamma`` ``(K, 2)``
    at the ends; ``inf`` where ``sigma^2 <= 2 lip flux``)."""
    with np.errstate(invalid='ignore', divide='ignore'):
        roots = (sigma - np.sqrt(np.maximum(sigma ** 2 - 2.0 * lip * flux[:, None], 0.0))) / lip
        x = np.min(np.where(sigma ** 2 > 2.0 * lip * flux[:, None], roots, np.inf), axis=1)
        g = np.max(gamma, axis=1)   # a point that does not move with X does not drift, whatever x (0 inf was NaN)
        return np.asarray(np.where((flux > 0.0) & (g > 0.0), g * x, 0.0), dtype=np.float64)


def rod_angles(u: Array, normals: Sequence[Array], norms: Sequence[Array]) -> Array:
    """The largest ``sin`` of a rod's angle (directions ``u (3, 3)``) from the joint-centre triangle's normal
    (``N (K, 3)`` of length ``n (K,)``, at each end) ``(K,)``."""
    return np.asarray(np.max(np.stack([np.linalg.norm(np.cross(u[None], (N / n[:, None])[:, None, :]), axis=2)
                                       .max(axis=1) for N, n in zip(normals, norms, strict=True)]), axis=0),
                      dtype=np.float64)


def rod_directions(geo: MachineGeometry) -> Array:
    """The rods' unit directions ``u_k`` as rows ``(3 rods, 3)``."""
    return np.stack([np.array(geo.ux), np.array(geo.uy), np.array(geo.uz)], axis=1)


def shortest_edge(E0: Array, Ep: Array, ds: Array) -> Array:
    """The least length ``|E0 + t Ep|`` over ``0 <= t <= ds`` ``(K,)`` [m] of an edge ``E0 (K, 3)`` changing at
    ``Ep`` per unit of ``t``: at ``t = -E0.Ep / |Ep|^2`` clipped to the interval (the edge may shrink inside it)."""
    tau = np.clip(-np.einsum('ki,ki->k', E0, Ep) / np.maximum(np.einsum('ki,ki->k', Ep, Ep), 1e-300), 0.0, ds)
    return np.asarray(np.linalg.norm(E0 + tau[:, None] * Ep, axis=1), dtype=np.float64)


def platform_motion(geo: MachineGeometry, Q0: Array, D: Array, s0: Array, s1: Array, sigma: Array, gamma: Array,
                    lip: float) -> tuple[Array, Array, Array]:
    """``(A, Omega, drift)`` ``(K,)``: the path length of the platform's reference point (the joint centres'
    centroid) [m], the angle its rotation sweeps [rad] and how far the joint centres drift in the body [m] while the
    rods go from ``Q0 + s0 D`` to ``Q0 + s1 D`` (module docstring); ``sigma``, ``gamma`` ``(K, 2)`` at the two ends.
    A body point at distance ``rho`` from the reference moves by at most ``A + Omega rho``."""
    u = rod_directions(geo)
    P0, P1 = geo.base_points(Q0 + s0[:, None] * D), geo.base_points(Q0 + s1[:, None] * D)
    ds = np.abs(s1 - s0)
    vel = D[:, :, None] * u[None]                                                     # u_k D_k (K, 3, 3)
    flux = np.zeros(ds.shape)   # int |d(L^2)/dt|
    for a, b in EDGES:
        Ep = vel[:, b] - vel[:, a]
        flux += 2.0 * ds * np.maximum(np.abs(np.einsum('ki,ki->k', P0[:, b] - P0[:, a], Ep)),
                                   np.abs(np.einsum('ki,ki->k', P1[:, b] - P1[:, a], Ep)))
    rv = drift_bound(flux, sigma, gamma, lip)                                             # int |rdot_k|
    e12p, e13p = vel[:, 1] - vel[:, 0], vel[:, 2] - vel[:, 0]
    N0, N1 = (np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]) for P in (P0, P1))
    dN = [np.linalg.norm(np.cross(e12p, P[:, 2] - P[:, 0]) + np.cross(P[:, 1] - P[:, 0], e13p), axis=1)
          for P in (P0, P1)]
    G = np.maximum(*dN)
    n0, n1 = np.linalg.norm(N0, axis=1), np.linalg.norm(N1, axis=1)
    nmin = 0.5 * (n0 + n1 - ds * G)
    with np.errstate(invalid='ignore', divide='ignore'):
        omega_t = np.where(ds * G > 0.0, np.where(nmin > 0.0, ds * G / nmin, np.inf), 0.0)
    sin_a = rod_angles(u, (N0, N1), (n0, n1)) + omega_t
    omega_n = np.full(ds.shape, np.inf)
    for a, b in EDGES:
        E0, Ep = P0[:, b] - P0[:, a], (vel[:, b] - vel[:, a]) * np.sign(s1 - s0)[:, None]
        lmin = shortest_edge(E0, Ep, ds)
        move = ds * (np.abs(D[:, a]) + np.abs(D[:, b])) * sin_a + 2.0 * rv
        with np.errstate(invalid='ignore', divide='ignore'):
            omega_n = np.minimum(omega_n, np.where(move > 0.0, move / lmin, 0.0))
    A = np.linalg.norm(vel.mean(axis=1), axis=1) * ds + rv
    return A, omega_t + omega_n, rv


def platform_state(cfg: GprConfig, gpr: ForwardBatch) -> tuple[Array, Array, Array]:
    """At forward solutions ``gpr``: ``sigma`` the smallest singular value of ``dF/dX`` in the solver's metric,
    ``gamma`` the largest ``|dr_k/dX|`` in that metric and the largest joint displacement [m] ``(N,)`` each."""
    vjm = make_model(cfg)
    scale = coordinate_scale(vjm, cfg)
    _, J, _ = vjm.closure(gpr.virtual_joints, gpr.side_lengths ** 2)
    sigma = np.linalg.svd(J / scale, compute_uv=False)[:, -1]
    _, dlin, dang = vjm.points_and_partials(gpr.virtual_joints)
    g2 = np.sum(dlin ** 2, axis=2) / scale[None, :3] ** 2
    if vjm.size == 6:
        g2 = g2 + np.sum(dang ** 2, axis=2) / scale[None, 3:] ** 2
    return (np.asarray(sigma, dtype=np.float64), np.sqrt(np.max(g2, axis=1)),
            np.max(gpr.joint_displacement, axis=1))


def robot_snapshot(robot: RobotDescription, rows: Array) -> Snapshot:
    """The robot at joint ``rows (N, J)`` (rods, then every arm's joints: :func:`joint_limits`' order): every frame's
    world pose (forward kinematics of the rods under the virtual-joint model, then the arms) and the platform data."""
    base = base_pose(robot, rows.shape[0])
    cfg = robot.config
    gpr = forward_batch(rows[:, :3], cfg, check_limits=False)
    poses = {'gpr_base': base, 'gpr_platform': base.compose(PoseBatch(gpr.position, gpr.rotation))}
    _, _, _, slices = joint_limits(robot)
    for arm, cols in zip(robot.arms, slices, strict=True):
        for frame, parent, pose in arm_transforms(arm, rows[:, cols]):
            poses[frame] = poses[parent].compose(pose)
    sigma, gamma, displacement = platform_state(cfg, gpr)
    return Snapshot(rows, {k: (p.position, p.rotation) for k, p in poses.items()}, sigma, gamma, displacement)


def platform_bound(geo: MachineGeometry, lev: Levers, A: Array, omega: Array, drift: Array, displacement: Array
                   ) -> Array:
    """``platform_b = A + Omega (rho_b + |rbar|)`` ``(K, B)`` [m] (docs/cell.md, eq. (3) integrated): the reference
    point's path ``A``, the swept angle ``Omega``, the drift of the joint centres and their displacement ``(K, 2)`` at
    the ends; zero for bodies the platform does not carry."""
    rbar = float(np.linalg.norm(geo.platform_points().mean(axis=0))) + np.max(displacement, axis=1) + drift
    with np.errstate(invalid='ignore'):
        b = np.where(lev.platform[None, :], A[:, None] + omega[:, None] * (lev.reach[None, :] + rbar[:, None]), 0.0)
    # a bound that is not a number (0 inf) bounds nothing: inf, so that no interval is settled by it (a NaN bound
    # compared false everywhere and entered the floor as NaN, which no margin check sees)
    return np.asarray(np.where(np.isnan(b), np.inf, b), dtype=np.float64)


class BodyMotion(Protocol):
    """What the clearance search needs of a motion (:class:`PlanMotion`, a controller's joint trajectory
    :class:`~gpr_kinematics.safety.joint_motion.TrajectoryMotion`): the robot, the instants where its law changes,
    the robot at instants, and the bounds of :meth:`PlanMotion.bounds` on intervals between knots."""

    @property
    def robot(self) -> RobotDescription: ...

    @property
    def knots(self) -> Array: ...

    def snapshot(self, t: Array) -> Snapshot: ...

    def bounds(self, t0: Array, t1: Array, lev: Levers, sigma: Array, gamma: Array, displacement: Array
               ) -> IntervalBounds: ...


@dataclass(frozen=True)
class PlanMotion:
    """A checked program as a motion (module docstring)."""

    plan: ProgramPlan

    @cached_property
    def knots(self) -> Array:
        """Times [s] where the motion changes its law (waypoints' arrivals and departures)."""
        t = self.plan.timing
        return np.unique(np.concatenate([t.arrive, t.depart]))

    @property
    def robot(self) -> RobotDescription:
        return self.plan.robot

    def snapshot(self, t: Array) -> Snapshot:
        """The robot at times ``t`` [s] (exact joint values: S-curves on joint-space lines and straight entries)."""
        rows = plan_samples(self.plan, sample_at(self.plan.timing, np.asarray(t, dtype=float))).positions
        return robot_snapshot(self.plan.robot, rows)

    def bounds(self, t0: Array, t1: Array, lev: Levers, sigma: Array, gamma: Array, displacement: Array
               ) -> IntervalBounds:
        """Bounds over the intervals ``[t0, t1]`` (each within one move or hold; module docstring); ``sigma``,
        ``gamma``, ``displacement`` ``(K, 2)`` the :class:`Snapshot` values at the ends."""
        plan, timing = self.plan, self.plan.timing
        K, B = t0.shape[0], lev.reach.shape[0]
        _, held, m, _ = locate(timing, 0.5 * (t0 + t1))
        if len(timing.duration):
            s0 = evaluate(timing.profiles, m, t0 - timing.depart[m])[0]
            s1 = evaluate(timing.profiles, m, t1 - timing.depart[m])[0]
        else:
            s0 = s1 = np.ones(K)
        s0, s1 = np.where(held, 1.0, s0), np.where(held, 1.0, s1)
        ds = np.abs(s1 - s0)
        P = plan.positions
        D = P[np.minimum(m + 1, len(P) - 1)] - P[m]
        V = np.abs(D) * ds[:, None]
        shift = np.full((K, B, 3), np.nan)
        shift[held] = 0.0
        shift[:, ~lev.platform] = 0.0
        _, _, _, slices = joint_limits(plan.robot)
        way = plan.waypoints.stations.position
        for mv in line_moves(plan.waypoints):
            sel = np.flatnonzero((m == mv) & ~held)
            if not sel.size:
                continue
            arm = plan.waypoints.arm[mv + 1]
            cols = slices[plan.robot.arm_names.index(arm)]
            V[sel, cols] = ds[sel, None] * line_rate_bounds(plan.robot.arm(arm), P[mv, cols], P[mv + 1, cols],
                                                            s0[sel], s1[sel])
            # the rods are constant along the line: the wafer frame translates, the other bodies of this arm turn,
            # everything else stands still (up to the platform bound, which is then the rods' rounding)
            ride = lev.rides & np.array([a == arm for a in lev.arm])
            still = lev.platform & np.array([a != arm for a in lev.arm])
            step = (s1[sel] - s0[sel])[:, None] * (way[mv + 1] - way[mv])[None]
            shift[np.ix_(sel, np.flatnonzero(ride))] = step[:, None, :]
            shift[np.ix_(sel, np.flatnonzero(still))] = 0.0
        arm_mu = V @ lev.lever
        travel = np.linalg.norm(np.nan_to_num(shift, nan=np.inf), axis=2)
        arm_mu = np.where(lev.rides[None, :], np.minimum(arm_mu, travel), arm_mu)
        geo = MachineGeometry.of(plan.robot.config)
        A, omega, drift = platform_motion(geo, P[m, :3], D[:, :3], s0, s1, sigma, gamma, LIPSCHITZ)
        plat = platform_bound(geo, lev, A, omega, drift, displacement)
        plat[held] = 0.0
        arm_mu[held] = 0.0
        return IntervalBounds(arm_mu, plat, shift)


def grid_within(starts: Array, ends: Array, total: float, rate: float) -> Array:
    """The instants ``k / rate`` of ``[0, total)`` [s] that ``np.arange(0, total, 1 / rate)`` gives, those within
    an interval ``[starts[j], ends[j]]`` only (a robot that holds needs no instant inside the hold: a dwell of 1e6 s
    was a million instants here and 2e8 in the slip check)."""
    step = 1.0 / rate
    parts = [np.zeros(0)]
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        k = np.arange(max(math.floor(a / step) - 1, 0), math.ceil(min(b, total) / step) + 2) * step
        parts.append(k[(k >= a) & (k <= b) & (k < total)])
    return np.unique(np.concatenate(parts))


def move_counts(durations: Array, rate: float, most: int) -> Array:
    """How many instants each move of ``durations`` [s] gets: ``rate`` times its duration, but at most ``c`` each,
    the largest ``c`` that keeps the sum within ``most`` (water filling: the short, fast moves, where a wafer is
    accelerated hard, keep ``rate``; one rate for all, ``most`` over the moves' total, sampled a 2 s swing at 2 Hz
    once the program also held a move of 1e5 s, and missed its slip ratio of 1.0002 between the corners)."""
    want = rate * np.maximum(durations, 0.0)
    if float(np.sum(want)) <= most:
        return want
    order = np.sort(want)
    below = np.concatenate([[0.0], np.cumsum(order)[:-1]])     # the moves shorter than the k-th, whole
    cap = (most - below) / np.arange(order.shape[0], 0, -1)    # the rest shared by the k-th and longer ones
    k = int(np.flatnonzero(cap <= order)[0])
    return np.asarray(np.minimum(want, cap[k]), dtype=np.float64)


def moving_intervals(motion: BodyMotion, knots: Array, lev: Levers) -> NDArray[np.bool_]:
    """Whether anything may move between consecutive knots (the motion's own bounds over each interval)."""
    if knots.shape[0] < 2:
        return np.zeros(0, dtype=bool)
    snap = motion.snapshot(knots)
    ends = [np.stack([x[:-1], x[1:]], axis=1) for x in (snap.sigma, snap.gamma, snap.displacement)]
    mb = motion.bounds(knots[:-1], knots[1:], lev, *ends)
    return np.asarray(np.any(mb.arm > 0.0, axis=1) | np.any(mb.platform > 0.0, axis=1))

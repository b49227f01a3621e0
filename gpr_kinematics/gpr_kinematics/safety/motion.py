"""The robot's bodies along a motion, and bounds on how far any of their points can move between two instants.

A *motion* gives the joint values (rods, then every arm's joints, :func:`~gpr_kinematics.robot.plan.joint_limits`'
order) at any time, and a bound on each joint's **total variation** over a time interval. :class:`PlanMotion` is a
checked program (the S-curves of :mod:`~gpr_kinematics.robot.timing`, exact: joint-space lines and the straight
entries of :mod:`~gpr_kinematics.robot.paths`); :class:`SampledMotion` is a joint trajectory given at times and
interpolated linearly between them (what a controller executes from a ``JointTrajectory``).

Every point of a body moves, over an interval where joint ``j`` varies by at most ``V_j``, by at most
``mu = sum_j V_j L_jb`` (docs/cell.md, "The certificate"): :func:`lever_arms` gives ``L``:

* an arm joint ``i`` turns the bodies after it about its axis (along the platform normal): a point at in-plane
  distance ``r`` from the axis moves by at most ``r`` times the angle, and ``r <= sum of the link lengths from
  axis i to the body's link frame + the body's in-plane reach from that frame`` (triangle inequality), whatever the
  other joints do;
* a rod ``k`` moves the platform: a point of the platform (or of an arm on it) at distance ``rho`` from the
  platform frame's origin moves at speed ``|do/dq_k| + |dw/dq_k| rho`` per unit rod speed, with the platform's
  translation and rotation rates ``do/dq_k``, ``dw/dq_k`` from the **exact virtual-joint kinematics**
  (:func:`platform_gains`: their largest norms over the admissible rods, heights and tilts, times
  :data:`GAIN_MARGIN`). ``rho`` is bounded the same way as ``r``, heights included.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..core import forward_batch
from ..core.rotations import rpy_matrix
from ..robot.collision import Shape, robot_shapes
from ..robot.description import RobotDescription
from ..robot.forward import arm_transforms, base_pose
from ..robot.plan import ProgramPlan, joint_limits, plan_samples
from ..robot.timing import locate, sample_at
from ..robot.transforms import PoseBatch

Array = NDArray[np.float64]

#: Margin on the platform's rate gains sampled over the admissible configurations (they vary by a few per cent).
GAIN_MARGIN = 1.5


class Motion(Protocol):
    """What the clearance check needs of a trajectory (module docstring)."""

    @property
    def knots(self) -> Array:
        """Times [s] where the motion changes its law (waypoints, samples): intervals never straddle one."""
        ...

    def positions(self, t: Array) -> Array:
        """Joint values ``(len(t), J)`` at times ``t``."""
        ...

    def variation(self, t0: Array, t1: Array) -> Array:
        """Bounds ``(len(t0), J)`` on each joint's total variation over ``[t0, t1]`` (within one knot interval)."""
        ...


@dataclass(frozen=True)
class PlanMotion:
    """A checked program as a motion: exact joint values; variation ``|P(t1) - P(t0)|`` on joint-space lines (every
    joint monotone in ``s``), ``G1 |s1 - s0|`` on a straight entry (``G1``: the path's derivative bound of the
    timing), 0 while a waypoint is held."""

    plan: ProgramPlan

    @cached_property
    def knots(self) -> Array:
        t = self.plan.timing
        return np.unique(np.concatenate([t.arrive, t.depart]))

    def positions(self, t: Array) -> Array:
        return plan_samples(self.plan, sample_at(self.plan.timing, np.asarray(t, dtype=float))).positions

    def variation(self, t0: Array, t1: Array) -> Array:
        timing = self.plan.timing
        mid = 0.5 * (np.asarray(t0) + np.asarray(t1))
        _, held, m, _ = locate(timing, mid)
        a, b = sample_at(timing, np.asarray(t0, float)), sample_at(timing, np.asarray(t1, float))
        out = np.abs(b.positions - a.positions)   # joint-space lines: the samples are on them
        line = ~held & np.isin(m, [k for k in range(len(timing.duration))
                                   if self.plan.waypoints.path and self.plan.waypoints.path[k + 1] == 'line'])
        if line.any():
            s0 = np.where(a.held[line] >= 0, 0.0, a.s[line])
            out[line] = timing.gains[0][m[line]] * np.abs(b.s[line] - s0)[:, None]
        return np.where(held[:, None], 0.0, out)


@dataclass(frozen=True)
class SampledMotion:
    """Joint values ``positions (N, J)`` at increasing ``times (N,)`` [s], linear in between."""

    times: Array
    rows: Array

    @property
    def knots(self) -> Array:
        return self.times

    def positions(self, t: Array) -> Array:
        t = np.asarray(t, dtype=float)
        return np.stack([np.interp(t, self.times, self.rows[:, j]) for j in range(self.rows.shape[1])], axis=1)

    def variation(self, t0: Array, t1: Array) -> Array:
        return np.abs(self.positions(t1) - self.positions(t0))


def frame_poses(robot: RobotDescription, rows: Array) -> dict[str, PoseBatch]:
    """World poses of ``gpr_base``, ``gpr_platform`` and every arm frame for joint rows ``(N, J)`` (exact platform
    pose, no limit checks: the motion was checked)."""
    n = rows.shape[0]
    base = base_pose(robot, n)
    gpr = forward_batch(rows[:, :3], robot.config, check_limits=False)
    platform = base.compose(PoseBatch(gpr.position, gpr.rotation))
    out = {'gpr_base': base, 'gpr_platform': platform}
    _, _, _, slices = joint_limits(robot)
    for arm, cols in zip(robot.arms, slices, strict=True):
        for frame, parent, pose in arm_transforms(arm, rows[:, cols]):
            out[frame] = out['gpr_platform' if parent == 'gpr_platform' else parent].compose(pose)
    return out


def shape_pose(shape: Shape) -> tuple[Array, Array]:
    """The shape's rotation and centre in its frame."""
    return np.asarray(rpy_matrix(*shape.rpy), dtype=np.float64), np.asarray(shape.xyz, dtype=np.float64)


def _reach(shape: Shape, chain: PoseBatch) -> tuple[float, float]:
    """In-plane and vertical reach of a shape's points from the origin of the frame ``chain`` maps it from (the
    shape's frame in that frame, one pose): corners of its bounding box."""
    R, c = shape_pose(shape)
    half = (np.array(shape.size) / 2 if shape.kind == 'box' else
            np.array([shape.size[0], shape.size[0], shape.size[1] / 2]))
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    pts = chain.rotation[0] @ (R @ corners.T + c[:, None]) + chain.position[0][:, None]
    return float(np.max(np.hypot(pts[0], pts[1]))), float(np.max(np.abs(pts[2])))


def lever_arms(robot: RobotDescription, shapes: tuple[Shape, ...], rod_gains: tuple[Array, Array]) -> Array:
    """``L (J, B)``: how far a point of body ``b`` can move per unit variation of joint ``j`` (module docstring)."""
    names, _, _, slices = joint_limits(robot)
    L = np.zeros((len(names), len(shapes)))
    lin, ang = rod_gains
    for b, shape in enumerate(shapes):
        if shape.frame == 'gpr_base':
            continue
        if shape.frame == 'gpr_platform':
            plane, up = _reach(shape, PoseBatch.fixed(np.zeros(3), np.eye(3), 1))
            L[:3, b] = lin + ang * (plane + up)
            continue
        arm_i = next(i for i, a in enumerate(robot.arms) if shape.frame.startswith(a.name + '_'))
        arm, cols = robot.arms[arm_i], slices[arm_i]
        frames = arm_transforms(arm, np.zeros((1, len(arm.joints))))
        idx = [f for f, _, _ in frames].index(shape.frame)
        link = min(idx, len(arm.joints) - 1)          # the last link frame carries the blade and the wafer
        chain = PoseBatch.fixed(np.zeros(3), np.eye(3), 1)
        for _, _, pose in frames[link + 1:idx + 1]:
            chain = chain.compose(pose)
        plane, up = _reach(shape, chain)
        lengths = [j.length for j in arm.joints]
        for i in range(link + 1):
            L[cols.start + i, b] = sum(lengths[i:link]) + plane
        mount = float(np.hypot(*arm.mount_position[:2]))
        height = abs(arm.mount_position[2]) + sum(abs(j.height) for j in arm.joints[:link]) + up
        L[:3, b] = lin + ang * (mount + sum(lengths[:link]) + plane + height)
    return L


def platform_gains(robot: RobotDescription, heights: int = 3, tilts: int = 5, azimuths: int = 12,
                   step: float = 1e-6) -> tuple[Array, Array]:
    """``(|do/dq_k|, |dw/dq_k|)`` ``(3,)`` each: the platform's largest translation [m/m] and rotation [rad/m] rates
    per unit speed of rod ``k`` over the stroke and the tilts up to the limit (the exact kinematics, central
    differences), times :data:`GAIN_MARGIN`."""
    from ..core.inverse import inverse_batch

    cfg = robot.config
    h = np.linspace(cfg.stroke_min + 0.1 * (cfg.stroke_max - cfg.stroke_min),
                    cfg.stroke_max - 0.1 * (cfg.stroke_max - cfg.stroke_min), heights)
    a = np.linspace(0.0, cfg.tilt_limit, tilts)
    g = np.linspace(0.0, 2 * np.pi, azimuths, endpoint=False)
    H, A, G = (x.ravel() for x in np.meshgrid(h, a, g))
    Q = inverse_batch(H, A, G, cfg).q
    Q = Q[np.all((cfg.stroke_min + step < Q) & (cfg.stroke_max - step > Q), axis=1)]
    lin, ang = np.zeros(3), np.zeros(3)
    for k in range(3):
        e = np.zeros(3)
        e[k] = step
        up = forward_batch(Q + e, cfg, check_limits=False)
        down = forward_batch(Q - e, cfg, check_limits=False)
        lin[k] = np.max(np.linalg.norm(up.position - down.position, axis=1)) / (2 * step)
        dR = np.einsum('nij,nkj->nik', up.rotation - down.rotation, 0.5 * (up.rotation + down.rotation))
        w = np.stack([dR[:, 2, 1] - dR[:, 1, 2], dR[:, 0, 2] - dR[:, 2, 0], dR[:, 1, 0] - dR[:, 0, 1]], axis=1) / 2
        ang[k] = np.max(np.linalg.norm(w, axis=1)) / (2 * step)
    return GAIN_MARGIN * lin, GAIN_MARGIN * ang


def robot_bodies(robot: RobotDescription) -> tuple[Shape, ...]:
    """The robot's collision bodies (:func:`~gpr_kinematics.robot.collision.robot_shapes`)."""
    return robot_shapes(robot)

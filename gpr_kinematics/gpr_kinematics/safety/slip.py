"""Wafer slip: does the blade's grip hold the wafer along the program (docs/cell.md, "Wafer slip")?

The wafer (mass ``m``, a point at its centre) follows the wafer frame; the blade must supply the force
``f = m (a - g)`` (``a`` its acceleration in the world, ``g = (0, 0, -9.80665) m/s^2``). With ``n`` the wafer
frame's z axis (the paddle's normal), the normal part ``f_n = f . n`` presses the wafer on the paddle and the
tangential part ``f_t = |f - f_n n|`` must be held by static friction: the **slip ratio**

    ``ratio = |f_t| / (mu (f_n + F_vac))``

(``mu`` the blade's ``friction``, ``F_vac`` its ``vacuum`` holding force) must stay below 1; a non-positive
denominator (the wafer lifted off the paddle) is an infinite ratio. Gravity alone on a blade tilted by ``alpha``
gives ``tan(alpha) / mu`` (0.035 g along the blade at 2 degrees). ``a`` comes from the path: on a joint-space line
``a = dp/ds s'' + d^2p/ds^2 s'^2`` (the path derivatives by central differences of the exact forward kinematics in
``s`` over the move's :func:`difference_step`), on a straight entry ``a = (p_1 - p_0) s''`` exactly; ``s'``, ``s''``
from the S-curve. There, with the orientation fixed, the ratio is a quasi-convex function of ``s''`` alone: its
largest value over the move lies on one of the S-curve's corners (docs/cell.md), which the check evaluates, and on
both sides of them (a trapezoid's acceleration jumps there); on joint-space moves it is sampled here and bounded
between the samples by :mod:`~gpr_kinematics.safety.slip_bound`.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.config import GprConfig
from ..robot.forward import robot_forward
from ..robot.plan import ProgramPlan, joint_limits, move_rows, plan_samples
from ..robot.timing import MAX_SAMPLES, evaluate, locate, sample_at
from ..robot.trajectory import JointTrajectory, spline
from .bodies import Windows

Array = NDArray[np.float64]

GRAVITY = 9.80665
#: Step in ``s`` of the central differences of the wafer's path; on a joint-space move whose joints change by less than
#: 1 (rad or m) the step is ``STEP`` over that change, at most ``STEP / LEAST_CHANGE`` (:func:`difference_step`).
STEP = 1e-4
#: The least joint change [m or rad] :func:`difference_step` divides by: below it (a move of no length as doubles go
#: near joints of order 1 changes by at least 1e-17) the step stays at ``STEP / LEAST_CHANGE`` and its products with
#: the joints' change and the bound's terms stay finite.
LEAST_CHANGE = 1e-30
#: The closure's tolerance [m] the slip check solves the forward kinematics to (the package's default): its second
#: differences over ``STEP`` amplify the closure's error by ``4 / STEP^2``, so a robot's looser ``tolerance`` (up to
#: 1e-6 m is allowed; 3.7e-7 m of position error then) is tightened to it here.
CLOSURE_TOLERANCE = GprConfig.tolerance
#: Rate [Hz] at which :func:`trajectory_slip` samples a trajectory's spline (and each segment at its thirds), and how
#: far [s] on each side of a point, where a cubic's acceleration jumps.
TRAJECTORY_SLIP_RATE, CORNER = 200.0, 1e-9


def closure_exact(plan: ProgramPlan) -> ProgramPlan:
    """``plan`` with its robot's closure solved to :data:`CLOSURE_TOLERANCE` (at least the default iterations)."""
    cfg = plan.robot.config
    if cfg.tolerance <= CLOSURE_TOLERANCE:
        return plan
    tight = cfg.replace(tolerance=CLOSURE_TOLERANCE, max_iterations=max(cfg.max_iterations,
                                                                       GprConfig.max_iterations))
    return dataclasses.replace(plan, robot=dataclasses.replace(plan.robot, config=tight))


@dataclass(frozen=True)
class SlipSeries:
    """The slip ratio ``ratio (N,)`` at ``time (N,)`` [s] of the arm carrying a wafer (NaN: none carried), and the
    wafer's acceleration ``acceleration (N, 3)`` [m/s^2, world]."""

    time: Array
    ratio: Array
    acceleration: Array


def wafer_path(plan: ProgramPlan, arm: str, m: int, s: Array) -> Array:
    """Wafer positions ``(len(s), 3)`` of ``arm`` at profile values ``s`` of move ``m`` (or of its hold, ``s = 1``)."""
    robot = plan.robot
    line = plan.waypoints.is_line(m)
    rows = move_rows(robot, plan.waypoints, plan.positions, m, np.clip(s, -1.0, 2.0) if line else s, plan.labels[m + 1])
    _, _, _, slices = joint_limits(robot)
    cols = slices[robot.arm_names.index(arm)]
    return robot_forward(robot, rows[:, :3], rows[:, cols], arm, check_limits=False).wafer.position


def difference_step(plan: ProgramPlan, arm: str, m: NDArray[np.int64]) -> Array:
    """The step in ``s`` of the central differences of ``arm``'s wafer path on the joint-space moves ``m``:
    ``STEP / c``, ``c`` the move's largest change of a rod [m] or of the arm's joints [rad] taken within
    [:data:`LEAST_CHANGE`, 1], so the joints move by ``STEP`` between the differences' points on a move shorter than
    1 (by ``c STEP`` beyond it, as the example's swings), the points beyond the move's ends on the joints' line when
    ``c < STEP``. The rounding's share ``4 POSITION_ERROR / h^2`` then shrinks with ``c^2``, as the path's second
    derivative does: over a fixed ``STEP`` a 1 um move's bound read 1.31 for its ratio of 0.09, and with the step
    at most 1 a jog of 1e-14 m read 3.1 for 0.37."""
    robot = plan.robot
    _, _, _, slices = joint_limits(robot)
    cols = np.r_[0:3, slices[robot.arm_names.index(arm)]]
    D = np.abs(plan.positions[m + 1][:, cols] - plan.positions[m][:, cols])
    return np.asarray(STEP / np.clip(np.max(D, axis=1, initial=0.0), LEAST_CHANGE, 1.0), dtype=np.float64)


def slip_series(plan: ProgramPlan, times: Array, carrying: Array) -> SlipSeries:
    """The slip ratio at ``times`` for the arm named in ``carrying (N,)`` ('' where no wafer is carried); the forward
    kinematics to :data:`CLOSURE_TOLERANCE`."""
    plan = closure_exact(plan)
    timing = plan.timing
    robot = plan.robot
    _, held, m, tau = locate(timing, times)
    if len(timing.duration):
        s, ds, dds = evaluate(timing.profiles, m, tau)
    else:
        s, ds, dds = np.ones(times.shape), np.zeros(times.shape), np.zeros(times.shape)
    s, ds, dds = np.where(held, 1.0, s), np.where(held, 0.0, ds), np.where(held, 0.0, dds)
    acc = np.zeros((times.shape[0], 3))
    ratio = np.full(times.shape[0], np.nan)
    for arm in robot.arms:
        idx = np.flatnonzero((carrying == arm.name) & ~held)
        moves = np.unique(m[idx])
        steps = difference_step(plan, arm.name, moves) if moves.size else moves
        for k, step in zip(moves.tolist(), steps.tolist(), strict=True):
            sel = idx[m[idx] == k]
            line = plan.waypoints.is_line(k)
            h = STEP if line else float(step)
            # a line's wafer path is linear in s: its points kept on it (s - h at its start lay beyond the station,
            # out of the arm's reach for one at full stretch, and refused the line)
            back, ahead = (np.maximum(s[sel] - h, 0.0), np.minimum(s[sel] + h, 1.0)) if line else (s[sel] - h,
                                                                                                    s[sel] + h)
            p = wafer_path(plan, arm.name, int(k), np.concatenate([back, s[sel], ahead]))
            n = sel.size
            d1 = (p[2 * n:] - p[:n]) / (ahead - back)[:, None]
            d2 = np.zeros_like(d1) if line else (p[2 * n:] - 2 * p[n:2 * n] + p[:n]) / h ** 2
            acc[sel] = d1 * dds[sel, None] + d2 * ds[sel, None] ** 2
        idx = np.flatnonzero(carrying == arm.name)
        if idx.size:
            ratio[idx] = _ratio(plan, arm.name, times[idx], acc[idx])
    return SlipSeries(times, ratio, acc)


def trajectory_slip(plan: ProgramPlan, traj: JointTrajectory, carried: dict[str, Windows]) -> tuple[float, float]:
    """The largest slip ratio and its instant [s] of the wafers ``carried`` (each arm's windows, the program's time)
    along the spline a controller follows through ``traj`` (the program's trajectory at a rate; its points carry
    velocities), sampled at :data:`TRAJECTORY_SLIP_RATE`, at the thirds of each segment and on both sides of every
    point, where a segment's linear acceleration peaks: the cubic's acceleration leaves the program's between
    points (at 10 Hz a program of 0.989 read 1.005). Sampled, not bounded between the samples. The wafer's
    acceleration ``a = J q'' + q'^T H q'`` by central differences of the exact forward kinematics along ``q''`` and
    ``q'`` (steps of :data:`STEP` in the joints); (0, 0) with nothing carried."""
    plan = closure_exact(plan)
    robot, spline_of = plan.robot, spline(traj, traj.positions[0])
    knots = traj.time
    _, _, _, slices = joint_limits(robot)
    best, at = 0.0, 0.0
    for arm, windows in carried.items():
        cols = np.r_[0:3, slices[robot.arm_names.index(arm)]]
        for t0, t1 in windows:
            n = min(int(math.ceil((t1 - t0) * TRAJECTORY_SLIP_RATE)) + 1, MAX_SAMPLES)
            inside = knots[(knots > t0) & (knots < t1)]
            edges = np.concatenate([[t0], inside, [t1]])   # each segment's thirds: its own, not the shortest's rate
            thirds = (edges[:-1, None] + np.diff(edges)[:, None] * np.array([1.0, 2.0]) / 3.0).ravel()
            t = np.unique(np.concatenate([np.linspace(t0, t1, n), thirds, inside - CORNER, inside + CORNER]))
            q, v, acc = (x[:, cols] for x in spline_of.evaluate(t))
            wafer = robot_forward(robot, q[:, :3], q[:, 3:], arm, check_limits=False).wafer   # once: both use it
            ratio = _ratio_at(plan, arm, wafer.rotation, _acceleration(plan, arm, q, v, acc, wafer.position))
            k = int(np.argmax(ratio))
            if ratio[k] > best:
                best, at = float(ratio[k]), float(t[k])
    return best, at


def _acceleration(plan: ProgramPlan, arm: str, q: Array, v: Array, acc: Array, p: Array) -> Array:
    """The wafer's acceleration ``(K, 3)`` [m/s^2] at joints ``q`` (rods and the arm's; ``p`` its position there),
    velocities ``v`` and accelerations ``acc``: ``J acc + v^T H v`` by central differences along ``acc`` and ``v``."""
    def wafer(x: Array) -> Array:
        return robot_forward(plan.robot, x[:, :3], x[:, 3:], arm, check_limits=False).wafer.position
    out = np.zeros((q.shape[0], 3))
    for d, second in ((acc, False), (v, True)):
        size = np.max(np.abs(d), axis=1)
        moving = size > 0.0
        if not moving.any():
            continue
        h = STEP / size[moving]
        step = d[moving] * h[:, None]
        ahead, back = wafer(q[moving] + step), wafer(q[moving] - step)
        if second:
            out[moving] += (ahead - 2.0 * p[moving] + back) / h[:, None] ** 2
        else:
            out[moving] += (ahead - back) / (2.0 * h[:, None])
    return out


def _ratio(plan: ProgramPlan, arm: str, t: Array, acc: Array) -> Array:
    robot = plan.robot
    rows = plan_samples(plan, sample_at(plan.timing, t)).positions
    _, _, _, slices = joint_limits(robot)
    cols = slices[robot.arm_names.index(arm)]
    R = robot_forward(robot, rows[:, :3], rows[:, cols], arm, check_limits=False).wafer.rotation
    return _ratio_at(plan, arm, R, acc)


def _ratio_at(plan: ProgramPlan, arm: str, R: Array, acc: Array) -> Array:
    """The slip ratio of ``arm``'s wafer of orientation ``R (K, 3, 3)`` for its acceleration ``acc``."""
    robot = plan.robot
    a = robot.arm(arm)
    f = acc + np.array([0.0, 0.0, GRAVITY])          # per unit mass: a - g
    n = R[:, :, 2]
    fn = np.einsum('ni,ni->n', f, n)
    ft = np.linalg.norm(f - fn[:, None] * n, axis=1)
    hold = a.bodies.friction * (fn + a.bodies.vacuum / robot.wafer.mass)
    with np.errstate(divide='ignore', invalid='ignore'):
        return np.asarray(np.where(hold > 0.0, ft / hold, np.inf), dtype=np.float64)

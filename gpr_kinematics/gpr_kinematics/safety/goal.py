"""The robot simulator's clearance check of a trajectory goal: the motion the controller will execute (its spline
interpolation, :class:`~gpr_kinematics.safety.joint_motion.TrajectoryMotion`) against the process cell and the robot
itself, certified between samples as ``gpr program check`` certifies a program (docs/cell.md, "Goals of the robot
simulator").

Bodies and pairs are ``gpr program check``'s (:func:`~gpr_kinematics.safety.bodies.default_pairs`): every robot body
against every obstacle, each arm's bodies against the other arm's and against the column and the platform.
A controller does not know which blade holds a wafer: ``wafer_arms`` names the arms that carry one throughout every
goal (their wafer discs are bodies; default none: the robot's links, blades, column and platform only), and wafers
lying in stations are not known to it either (not checked). :class:`GoalClearance` is the ``clearance`` hook of
:func:`~gpr_kinematics.robot.controller.plan_motion`: it answers a refusal naming the two bodies, the time and the
distance, or None; the jump from where the joints are to a first point at ``t = 0`` (one sample) is checked as the
joint-space line between the two states, and a current state already within the margin is named as such.
:meth:`GoalClearance.move` judges another publisher's joint values for the simulator: the state and the line to it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError
from ..robot.controller import Motion
from ..robot.description import RobotDescription
from ..robot.plan import joint_limits
from ..robot.trajectory import JointTrajectory
from .bodies import Body, cell_bodies, default_pairs, robot_body_set
from .cell import Cell
from .clearance import TOLERANCE, ClearanceReport, PairClearance, check_numbers, clearance, slack_note
from .distances import require_library
from .joint_motion import TrajectoryMotion
from .margin import MARGIN


@dataclass(frozen=True)
class GoalClearance:
    """The clearance check of goals for ``robot`` in ``cell`` (module docstring): ``margin`` and ``tolerance`` [m] as
    ``gpr program check``'s, ``wafer_arms`` the arms carrying a wafer."""

    robot: RobotDescription
    cell: Cell
    margin: float = MARGIN
    tolerance: float = TOLERANCE
    wafer_arms: tuple[str, ...] = ()
    bodies: tuple[Body, ...] = field(init=False, repr=False, compare=False)
    pairs: tuple[tuple[int, int, tuple[tuple[float, float], ...]], ...] = field(init=False, repr=False,
                                                                                 compare=False)

    def __post_init__(self) -> None:
        check_numbers(self.margin, self.tolerance, 1.0)
        require_library('the clearance check of goals (cell_file)')
        for arm in self.wafer_arms:
            if arm not in self.robot.arm_names:
                raise ConfigError(f'wafer_arms: unknown arm {arm!r}; allowed: some of '
                                  f'{", ".join(self.robot.arm_names)}, or none')
        bodies = robot_body_set(self.robot, {a: ((0.0, math.inf),) for a in self.wafer_arms})
        bodies += cell_bodies(self.cell.in_frame(self.robot.world_frame))
        object.__setattr__(self, 'bodies', tuple(bodies))
        object.__setattr__(self, 'pairs', tuple((i, j, ()) for i, j in default_pairs(bodies)))

    def report(self, motion: Motion) -> ClearanceReport:
        """The certified clearance of every pair over a checked goal's ``motion`` (times from the goal's start)."""
        moving = TrajectoryMotion.of(self.robot, motion.trajectory, motion.goal, motion.positions[0])
        return clearance(moving, self.bodies, self.pairs, self.margin, self.tolerance, decide=True)

    def line(self, a: NDArray[np.float64], b: NDArray[np.float64]) -> ClearanceReport:
        """The certified clearance of every pair over the joint-space line from every joint at ``a`` to ``b``
        ``(N,)`` (``s`` from 0 to 1 as time; ``a`` equal to ``b``: the state ``a`` alone)."""
        return self.polyline(np.vstack([a, b]), np.array([0.0, 1.0]))

    def polyline(self, points: NDArray[np.float64], times: NDArray[np.float64]) -> ClearanceReport:
        """The certified clearance of every pair over the joint-space lines between consecutive ``points (M, N)``
        of every joint, passed at ``times (M,)`` [s] (increasing, the first 0)."""
        names = joint_limits(self.robot)[0]
        traj = JointTrajectory(names, np.asarray(times, dtype=float), np.asarray(points, dtype=float), None, None)
        moving = TrajectoryMotion.of(self.robot, traj, np.arange(len(names)), traj.positions[0])
        return clearance(moving, self.bodies, self.pairs, self.margin, self.tolerance, decide=True)

    def state(self, a: NDArray[np.float64], what: str) -> str | None:
        """None when every pair of the state ``a`` ``(N,)`` is at least the margin apart; else ``what`` (the state,
        named) has the closest pair below the margin, its distance, and the margin."""
        below = self.line(a, a).below_margin
        if not below:
            return None
        p, d = _closest(below)
        return (f'{what} has {p.bodies[0]} and {p.bodies[1]} {d:.6g} m ({d * 1e3:.3f} mm) apart, within '
                f'clearance_margin {self.margin:g} m (negative: penetration; cell {self.cell.source})')

    def __call__(self, motion: Motion) -> str | None:
        """None when every pair stays at least the margin apart over the whole motion, the jump from where the joints
        are to a first point at ``t = 0`` included; else the refusal: the robot's current state already too close,
        the jump, or the pair below the margin first, when, and how close it comes. A lagging motion
        (``motion.lag``) is checked along the path the joints take (:meth:`~gpr_kinematics.robot.servo.Lag.path`)."""
        lag = motion.lag
        here = self.state(motion.current if lag is None else lag.arrival,
                          "the robot's current state (where every goal starts, t = 0)")
        if here:
            return (f'{here}; allowed: a current state with every pair at least clearance_margin apart (every goal '
                    'starts there; joint_states of another publisher outside the margin move it while no goal runs)')
        if lag is not None:   # the joints' path: the wait's line, the lines between samples, the settling to the end
            return refusal(self.polyline(*lag.path(motion.time, motion.positions[-1])), self.cell.source,
                           f"s from the goal's arrival, the joints lagging {lag.tau:g} s (servo_time_constant) "
                           'behind its samples')
        first = motion.positions[0]
        if motion.trajectory.time[0] == 0.0 and not np.array_equal(first, motion.current):
            below = self.line(motion.current, first).below_margin
            if below:
                p, d = _closest(below)
                return (f'the jump from where the joints are to the first point at time_from_start 0 (in one sample) '
                        f'brings {p.bodies[0]} and {p.bodies[1]} within the margin: {d:.6g} m ({d * 1e3:.3f} mm) '
                        f'apart (negative: penetration; cell {self.cell.source}); allowed: every pair at least '
                        f'clearance_margin {self.margin:g} m apart over the jump too, or a first point after 0 s, '
                        'which the joints then reach along the interpolated motion that is checked')
        return refusal(self.report(motion), self.cell.source)

    def move(self, held: NDArray[np.float64], state: NDArray[np.float64]) -> str | None:
        """Why another publisher's ``state`` ``(N,)`` may not replace the ``held`` one: it lies within the margin, or
        the joint-space line from ``held`` to it passes within (from a ``held`` state itself within the margin, a
        ``state`` outside it may be taken: the way out); None when neither. One clearance check when the line is
        clear (about 15 ms), three at most."""
        below = self.line(held, state).below_margin
        if not below:
            return None
        bad = self.state(state, 'it')
        if bad or self.state(held, 'held') is not None:
            return bad
        p, d = _closest(below)
        return (f'the joint-space line from the held state to it brings {p.bodies[0]} and {p.bodies[1]} within '
                f'clearance_margin {self.margin:g} m: {d:.6g} m ({d * 1e3:.3f} mm) apart (negative: penetration; '
                f'cell {self.cell.source})')


def _closest(below: tuple[PairClearance, ...]) -> tuple[PairClearance, float]:
    """The closest of pairs below the margin and its distance: the one measured, else the certified bound [m]."""
    p = min(below, key=lambda q: q.distance)
    return p, p.measured if math.isfinite(p.measured) else p.distance


def refusal(report: ClearanceReport, cell: str, clock: str = 'time_from_start') -> str | None:
    """The refusal of a goal whose ``report`` (:func:`~gpr_kinematics.safety.clearance.clearance` deciding the margin)
    has pairs below its margin, or None. It names the pair the library measured below the margin first, the instant
    of the smallest distance measured for it and that distance (where the search stopped: the pair's minimum is at
    most that); a pair whose bounds could not prove the margin within the search's budget, without a measurement
    below it (``first_below`` NaN), is named with its certified lower bound."""
    below = report.below_margin
    if not below:
        return None
    found = [p for p in below if math.isfinite(p.first_below)]
    others = f'; {len(below) - 1} more pair(s) below the margin' if len(below) > 1 else ''
    allowed = (f'; allowed: every pair at least clearance_margin {report.margin:g} m ({report.margin * 1e3:g} mm) '
               'apart over the whole motion')
    if found:
        p = min(found, key=lambda q: q.first_below)
        return (f'{p.bodies[0]} and {p.bodies[1]} would come within the margin: {p.measured:.6g} m '
                f'({p.measured * 1e3:.3f} mm) apart at t = {p.time:.6g} s ({clock}; negative: penetration; '
                f'found by the clearance check over the whole motion, cell {cell}){others}{allowed}')
    p = min(below, key=lambda q: q.distance)
    return (f'{p.bodies[0]} and {p.bodies[1]} could not be shown the margin apart: at least {p.distance:.6g} m '
            f'({p.distance * 1e3:.3f} mm) by the bounds between samples, {p.measured:.6g} m measured at '
            f't = {p.time:.6g} s{slack_note(p.measured, report.margin)} ({clock}; cell {cell}){others}'
            f'{allowed}')

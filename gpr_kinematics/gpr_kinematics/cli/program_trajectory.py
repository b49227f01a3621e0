"""The trajectory ``gpr program export --trajectory`` writes and ``gpr program send`` sends, checked before either:
as ``robot_simulator_node`` checks a goal, for the clearance of its spline in the program's cell, and against the
program it stands for (refused where its spline leaves it). A program ``gpr program check`` finds not safe is
refused as it is (:class:`~gpr_kinematics.errors.UnsafeError`, status 1, as the check's); a trajectory refused at its
``--rate`` where a higher one helps is bad input (:class:`~gpr_kinematics.errors.InputError`, status 2)."""
from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import InputError, UnsafeError
from ..safety.margin import MARGIN
from .options import number

if TYPE_CHECKING:
    from ..callbacks import StageProgress
    from ..robot.controller import Motion
    from ..robot.plan import ProgramPlan
    from ..robot.trajectory import JointTrajectory
    from ..safety.check import SafetyReport
    from ..safety.clearance import ClearanceReport, PairClearance

#: What lowers a carried wafer's slip ratio (``gpr program check``'s and the refusals' hint).
SLIP_HELPS = ("the ratio is lowered by lower acceleration limits of the arm's joints or blades of more friction (a "
              "longer 'time' on a move lowers its cruise speed, not its accelerations; a straight entry takes none)")

#: The rate [Hz] at which a trajectory is checked as robot_simulator_node checks a goal (its default ``rate``).
CONTROLLER_RATE = 100.0


def add_margin(p: argparse.ArgumentParser, what: str) -> None:
    """``--margin M`` on ``p``: the clearance [m] below which a pair of bodies collides in ``what``."""
    p.add_argument('--margin', type=number, default=None, metavar='M',
                   help=f'clearance below which a pair collides in {what} [m] (default {MARGIN:g}; 0 to 1)')


#: A ``--margin`` this large [m] or larger gets a warning: millimetres typed as metres? (25 times the default.)
LARGE_MARGIN = 0.05


def margin_of(args: argparse.Namespace, warn: bool = False) -> float:
    """``--margin`` [m] (:data:`MARGIN` when not given), refused before any work outside [0, 1] m, named as typed
    (:func:`~gpr_kinematics.safety.clearance.check_length`, which names a margin typed in mm); with ``warn``, one
    at or above :data:`LARGE_MARGIN` is warned of on stderr (``--margin 0.5``: 500 mm, or 0.5 mm meant?)."""
    from ..safety.clearance import check_length
    from ..safety.margin import MARGIN_RANGE
    if args.margin is None:
        return MARGIN
    typed = repr(float(args.margin))   # the shortest that reads back: 1.0000000000000002 is not 1
    shown = typed[:-2] if typed.endswith('.0') else typed
    check_length('--margin', args.margin, *MARGIN_RANGE, shown=shown)
    if warn and args.margin >= LARGE_MARGIN:
        print(f'gpr program {args.program_command}: warning: --margin {shown} m keeps every pair of bodies '
              f'{args.margin * 1e3:g} mm apart: millimetres meant? (--margin is in metres: {args.margin / 1e3:g} for '
              f'{shown} mm; the default is {MARGIN:g})', file=sys.stderr)
    return float(args.margin) + 0.0   # -0 typed: 0 (it printed 'margin -0 mm')


def as_a_controller_takes_it(plan: ProgramPlan, traj: JointTrajectory, rate: float, command: str,
                             margin: float = MARGIN, progress: StageProgress | None = None) -> SafetyReport:
    """Refuse a trajectory at ``--rate`` whose spline between points is not the checked program: one
    ``robot_simulator_node`` would refuse (:func:`~gpr_kinematics.robot.controller.plan_motion` from its first point,
    sampled at :data:`CONTROLLER_RATE`, or fewer per second for a program longer than the samples it takes: a warning
    then says the node needs a lower ``rate``), one whose spline comes within the clearance margin in the program's
    cell or against the robot itself (:func:`~gpr_kinematics.safety.check.trajectory_clearance`), makes a wafer slip
    or leaves the program by more than :data:`DEVIATION_ALLOWED` (``margin`` [m]: the clearance's, ``--margin``;
    ``progress``: the check's progress line); the program's :class:`~gpr_kinematics.safety.check.SafetyReport`.
    The cubic between points a few per second apart overshoots the program's velocities (the example cell program's
    rod_1 by 1.05 % at 5 Hz, beyond the 1 % a controller allows), and at 0.3 Hz put arm2's blade 8.7 mm into a
    chamber's wall: such files were written, or sent."""
    from ..robot.controller import ControllerJoints, GoalError, Tolerances, plan_motion
    from ..robot.timing import MAX_SAMPLES
    joints = ControllerJoints.of(plan.robot)
    current = joints.rest.copy()
    current[joints.indices(traj.joint_names)] = traj.positions[0]
    longest = (MAX_SAMPLES - 1) / CONTROLLER_RATE
    check_rate = min(CONTROLLER_RATE, (MAX_SAMPLES - 1) / max(traj.duration, 1e-9))
    try:
        motion = plan_motion(joints, traj, current, check_rate, plan.robot.config,
                             Tolerances.uniform(len(joints.names), 0.0, 0.0, 0.0), 0.0)   # tolerances are the run's
    except GoalError as exc:
        raise InputError(f'at --rate {rate:g} Hz a controller refuses the trajectory: {exc} (a higher --rate gives it '
                         'more points)') from None
    fcl, report = the_program_is_safe(plan, rate, command, margin, progress)
    if fcl:
        _keeps_the_clearance(plan, plan.program.cell, traj, rate, margin)
    _holds_the_wafers(plan, traj, rate)
    _follows_the_program(plan, motion, joints.names, rate)
    if traj.duration > longest:
        print(f'gpr program {command}: warning: the trajectory lasts {traj.duration:.6g} s: robot_simulator_node '
              f'samples a goal at its rate into at most {MAX_SAMPLES} samples and refuses it at its default rate of '
              f'{CONTROLLER_RATE:g} Hz (at most {longest:.6g} s); give the node a lower rate '
              f'(at most {(MAX_SAMPLES - 1) / traj.duration:.6g} Hz)', file=sys.stderr)
    return report


def the_program_is_safe(plan: ProgramPlan, rate: float, command: str, margin: float = MARGIN,
                        progress: StageProgress | None = None) -> tuple[bool, SafetyReport]:
    """Refuse (:class:`~gpr_kinematics.errors.UnsafeError`, status 1) a program ``gpr program check`` finds not safe
    (:func:`~gpr_kinematics.safety.check.check_program`: the clearance in its cell or against itself, the wafers'
    slip, the imperfection budget at ``rate``), naming the first reason: a program whose wafer slipped (ratio 2.26 at
    a friction of 0.1) had its trajectory written and sent. Without python-fcl the clearance is left out with a
    warning; whether it was checked, and the report. ``progress``: told each stage's share done (``gpr program
    check``'s line)."""
    from ..safety.cell import load_cell
    from ..safety.check import check_program
    cell = plan.program.cell
    where = f'in cell {cell}' if cell is not None else 'against itself (no cell)'
    fcl = _has_fcl(where, command, 'the program and its trajectory')
    loaded = None if cell is None else load_cell(cell)
    report, clear, _ = check_program(plan, loaded, margin, progress=progress, rate=rate, with_clearance=fcl)
    if report.safe:
        return fcl, report
    if report.collisions:
        from ..safety.check import program_clearance
        p = _least(program_clearance(plan, loaded, margin, decide=False, only=_names(clear)))
        first = min(report.collisions, key=lambda c: c.time)
        why = (f' {where}: {_pair(p, plan)}, within the margin of {margin * 1000:g} mm ({len(report.collisions)} '
               f'pair(s) below it, the first {" and ".join(first.bodies)} at t = {first.time:.3f} s, {first.label})')
    elif report.max_slip_ratio >= 1.0:
        ratio = report.max_slip_evaluated
        how = ('lifts off the blade (ratio inf)' if ratio == math.inf
               else f'slips on the blade (ratio {ratio:.3f} >= 1)' if ratio >= 1.0
               else f'may slip on the blade (its ratio bounded by {report.max_slip_ratio:.3f}, not below 1)')
        why = f': the wafer {how} at {report.max_slip_at:.3f} s, {report.slip_label}; {SLIP_HELPS}'
    else:
        b = report.budget
        assert b is not None
        why = (f': {sum(f.samples for f in b.beyond)} sample(s) at {b.rate:g} Hz beyond the imperfection budget of '
               f'{b.budget * 1e6:g} um (the largest joint displacement {b.max_displacement * 1e6:.3f} um at '
               f'{b.max_at:.3f} s, {b.max_label})')
    check = 'gpr program check' + (f' --margin {margin:g}' if margin != MARGIN else '')
    raise UnsafeError(f'the program itself is not safe{why} (no --rate helps); '
                      f'allowed: a program {check} finds safe (it names every pair and move)')


def _keeps_the_clearance(plan: ProgramPlan, cell: Path | None, traj: JointTrajectory, rate: float,
                         margin: float) -> None:
    """Refuse ``traj`` (the program at ``--rate``, which :func:`the_program_is_safe` passed) whose spline comes within
    the clearance margin in the program's ``cell`` file, or against itself without one (its arms, the column, the
    platform: :func:`~gpr_kinematics.safety.check.trajectory_clearance`): a higher rate helps (python-fcl needed:
    ``program export`` alone needs only numpy, scipy and PyYAML). Without a cell the spline was not checked (the
    example robot program at 0.2 Hz put arm2's link 6.7 mm into a wafer it places)."""
    from ..safety.cell import load_cell
    from ..safety.check import trajectory_clearance
    loaded = None if cell is None else load_cell(cell)
    report = trajectory_clearance(plan, loaded, traj, margin)
    if not report.below_margin:
        return
    p = _least(trajectory_clearance(plan, loaded, traj, margin, decide=False, only=_names(report)))
    where = f'in cell {cell}' if cell is not None else 'against the robot itself (no cell)'
    raise InputError(f'at --rate {rate:g} Hz the spline between the trajectory\'s points leaves the checked '
                     f'program: {_pair(p, plan)}, within the margin of {margin * 1000:g} mm {where} (the program '
                     'itself keeps it); allowed: a higher --rate (points closer together follow the program)')


def _holds_the_wafers(plan: ProgramPlan, traj: JointTrajectory, rate: float) -> None:
    """Refuse ``traj`` (the program at ``--rate``, which :func:`the_program_is_safe` passed) along whose spline a
    carried wafer slips (:func:`~gpr_kinematics.safety.slip.trajectory_slip`): a higher rate helps (at 10 Hz a
    program of 0.989 read 1.005, written and sent)."""
    from ..safety.check import label_at, wafer_plan
    from ..safety.slip import trajectory_slip
    ratio, at = trajectory_slip(plan, traj, wafer_plan(plan).carried)
    if ratio >= 1.0:
        raise InputError(f'at --rate {rate:g} Hz the spline between the trajectory\'s points makes the wafer slip on '
                         f'the blade (ratio {ratio:.3f} >= 1 at t = {at:.3f} s, {label_at(plan, at)}; the program '
                         'itself stays below 1); allowed: a higher --rate (points closer together follow the program)')


def lead_in_keeps_clearance(plan: ProgramPlan, goal: JointTrajectory, start: float, margin: float = MARGIN) -> None:
    """Refuse (:class:`~gpr_kinematics.errors.RobotStateError`: the robot's state, status 1) a ``goal`` whose move
    from where the robot is to the program's start (its first ``start`` s, :func:`~gpr_kinematics.robot.trajectory.
    lead_in`) comes within the clearance margin in the program's cell
    (:func:`~gpr_kinematics.safety.check.lead_in_clearance`), or against the robot itself without a cell (its arms,
    the column, the platform); nothing without a move, a warning without python-fcl."""
    import numpy as np

    from ..errors import RobotStateError
    from ..robot.trajectory import JointTrajectory
    cell = plan.program.cell
    where = f'in cell {cell}' if cell is not None else 'against the robot itself (no cell)'
    if start <= 0.0 or not _has_fcl(where, 'send', 'the move to the program\'s start'):
        return
    from ..safety.cell import load_cell
    from ..safety.check import lead_in_clearance
    n = int(np.searchsorted(goal.time, start, side='right'))   # the move's points and the program's first
    lead = JointTrajectory(goal.joint_names, goal.time[:n], goal.positions[:n],
                           None if goal.velocities is None else goal.velocities[:n],
                           None if goal.accelerations is None else goal.accelerations[:n])
    loaded = None if cell is None else load_cell(cell)
    report = lead_in_clearance(plan, loaded, lead, margin)
    if report.below_margin:
        names = _names(report)
        p = _least(lead_in_clearance(plan, loaded, lead, margin, decide=False, only=names))
        raise RobotStateError(f'the move from where the robot is to the program\'s start ({start:.3f} s, added by '
                              f'send) is not safe {where}: {_pair(p)} of the move, within the margin of '
                              f'{margin * 1000:g} mm; allowed: a robot whose joint-space line to the program\'s first '
                              'point keeps the margin (move it clear first, or start the program where it is)')


def _has_fcl(where: str, command: str, what: str) -> bool:
    """Whether python-fcl imports; a warning on stderr that ``what`` is not checked for clearance ``where`` (``in
    cell ...``, ``against itself``) when not."""
    try:
        import fcl  # noqa: F401
    except ModuleNotFoundError as exc:
        if (exc.name or '').split('.')[0] != 'fcl':
            raise
        print(f'gpr program {command}: warning: {what} {"are" if " and " in what else "is"} not checked for clearance '
              f'{where}: '
              "that needs the optional package 'fcl' (pip install 'gpr_kinematics[safety]')", file=sys.stderr)
        return False
    return True


def _names(report: ClearanceReport) -> set[tuple[str, str]]:
    """The pairs below the margin in ``report``, by their bodies' names."""
    return {p.bodies for p in report.below_margin}


def _least(report: ClearanceReport) -> PairClearance:
    """The closest pair of ``report`` (searched to its minimum)."""
    return min(report.pairs, key=lambda p: p.distance)


def _pair(p: PairClearance, plan: ProgramPlan | None = None) -> str:
    """A pair in words: its bodies, their least distance and its instant (with ``plan``, the program's instant: the
    step there)."""
    step = ''
    if plan is not None:
        from ..safety.check import label_at
        step = f', {label_at(plan, p.time)}'
    return f'{p.bodies[0]} and {p.bodies[1]} come to {p.distance * 1000:.3f} mm at t = {p.time:.3f} s{step}'


#: How far [m or rad] the spline between a trajectory's points may leave the program (the simulator's default goal
#: tolerance).
DEVIATION_ALLOWED = 1e-3


def _follows_the_program(plan: ProgramPlan, motion: Motion, names: Sequence[str], rate: float) -> None:
    """Refuse a trajectory whose spline through its points (``motion``, sampled as a controller samples it) leaves
    the planned program by more than :data:`DEVIATION_ALLOWED` at those instants: it is not the program checked (the
    example robot program at 0.1 Hz: by 3.5 rad, visiting none of its stations, was written with a warning); a
    higher rate helps."""
    import numpy as np

    from ..robot.plan import plan_samples
    from ..robot.timing import sample_at
    planned = plan_samples(plan, sample_at(plan.timing, motion.time)).positions
    gap = np.abs(motion.positions - planned)
    i, j = (int(k) for k in np.unravel_index(int(np.argmax(gap)), gap.shape))
    if gap[i, j] > DEVIATION_ALLOWED:
        unit = 'm' if j < 3 else 'rad'
        raise InputError(f'at --rate {rate:g} Hz the spline between the trajectory\'s points leaves the program by up '
                         f'to {gap[i, j]:.3g} {unit} ({names[j]} at t = {motion.time[i]:.3f} s), not the program '
                         f'checked; allowed: at most {DEVIATION_ALLOWED:g} m or rad (a robot simulator\'s goal '
                         'tolerance), at a higher --rate (points closer together follow the program)')

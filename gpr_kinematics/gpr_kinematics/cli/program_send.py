"""``gpr program send``: a robot program run on a robot's ``control_msgs/action/FollowJointTrajectory`` server
(docs/robot.md#programs).

The program's trajectory at ``--rate`` (checked as ``gpr program export --trajectory`` checks it), from where the
robot is (``joint_states``), sent to the action; its progress and result reported. Exit 0 when the goal succeeded, 1
when the server refused or aborted it, none answered, no joint states came, another robot is there or the robot
cannot start where it is (one line on stderr saying which; with ``--json`` the :class:`SendResult` on stdout too, its
``failure`` that line), 1 too for a program ``gpr program check`` finds not safe (refused before any node is made, as
``export --trajectory`` refuses it: one ``error:`` line; with ``--json`` the :class:`SendResult` of status
``unsafe``), 2 on bad input (a ``--rate`` at which the
trajectory is refused and a higher one helps among it). Needs the ``ros`` extra, in a ROS environment.
"""
from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from ..core.messages import FOLLOW_JOINT_TRAJECTORY, RosMessage, Topic
from ..errors import InputError, RobotStateError, UnsafeError
from ..inputs.resources import PROGRAMS
from .options import number, program_plan, robot_options, sample_rate, shipped
from .output import emit_json
from .program_trajectory import add_margin, as_a_controller_takes_it, lead_in_keeps_clearance, margin_of

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from ..nodes.client import GprClient
    from ..robot.plan import ProgramPlan
    from ..robot.trajectory import JointTrajectory
    from .main import Subparsers


@dataclass(frozen=True)
class SendResult:
    """What ``gpr program send`` did: the program, robot and action (its full name, resolved in the namespace, as the
    text output prints it); the trajectory sent (points, duration [s], the lead-in from where the robot was [s]; before
    a goal was made, the program's trajectory and no lead-in, None); how it ended (``status``: the goal's, or
    ``not_sent`` when it could not be sent, ``unsafe`` when ``gpr program check`` finds the program not safe,
    ``no_result`` when no answer or result came; the result's ``error_code``,
    its name and ``error_string``), the feedback received, and ``failure``: the line on stderr of a send that failed
    before the goal's outcome ('' otherwise)."""

    program: str
    robot: str
    action: str
    joint_names: list[str]
    points: int
    duration: float
    lead_in: float | None
    status: str
    error_code: int
    error_name: str
    error_string: str
    feedback: int
    failure: str = ''

    @property
    def succeeded(self) -> bool:
        return self.status == 'succeeded' and self.error_code == 0


def _ros_modules() -> ModuleType:
    """The ROS side of ``send`` (the ``ros`` extra), in this repository's ROS environment when none is sourced."""
    from ..errors import GprError
    try:
        from ..nodes import trajectory_client
    except ModuleNotFoundError as exc:
        if (exc.name or '').split('.')[0] == 'rclpy':
            raise
        from ..ros import env as ros_env
        try:
            ros_env.activate()
            from ..nodes import trajectory_client
        except (FileNotFoundError, OSError, ImportError):
            raise GprError(f'gpr program send needs a ROS 2 environment: {exc.name} cannot be imported; source '
                           'install/setup.bash (or run make setup in a checkout)') from None
    return trajectory_client


#: The node ``gpr program send`` runs as (a private name, ``~/...``, resolves in it).
SEND_NODE = 'gpr_program_send'


def _ros_names(args: argparse.Namespace) -> tuple[str, str]:
    """``--namespace``, ``--joint-states`` and ``--action`` by ROS 2's own name rules, before any node is made (rclpy
    raised them as tracebacks); the topic's and the action's full names, as the node :data:`SEND_NODE` in the
    namespace resolves them (``joint_states`` in ``r3``: ``/r3/joint_states``)."""
    from rclpy.exceptions import NameValidationException
    from rclpy.expand_topic_name import expand_topic_name
    from rclpy.validate_full_topic_name import validate_full_topic_name
    from rclpy.validate_namespace import validate_namespace
    from rclpy.validate_topic_name import validate_topic_name

    from ..errors import brief
    ns = args.namespace if args.namespace.startswith('/') else '/' + args.namespace
    full: dict[str, str] = {}
    for option, name in (('--namespace', args.namespace), ('--joint-states', args.joint_states),
                         ('--action', args.action)):
        try:
            if option == '--namespace':
                validate_namespace(ns)
                continue
            validate_topic_name(name)
            if not name.startswith('~'):  # private names expand with the node's name
                validate_full_topic_name(name if name.startswith('/') else ns.rstrip('/') + '/' + name)
            full[option] = expand_topic_name(name, SEND_NODE, ns)
            validate_full_topic_name(full[option])
        except (NameValidationException, ValueError) as exc:  # ValueError: rcl's expansion (a substitution)
            rule = str(exc).splitlines()[0].rstrip(':').split(', at ')[0]
            raise InputError(f'{option} {brief(name)}: {rule}; allowed: a ROS 2 name') from None
    return full['--joint-states'], full['--action']


def _no_answer(what: str, given: str, name: str, timeout: float, option: str, outcome: str = '') -> str:
    """The line of a wait of ``gpr program send`` that ended with nothing: what did not come, on which full ROS name
    ``name`` (``given`` as ``option``), within how long, and the options that change the name and the wait."""
    where = option if given.startswith('/') else f'{option} and --namespace'
    return (f'gpr program send: {what} on {name} within {timeout:g} s{": " + outcome if outcome else ""} (change the '
            f'name with {where}, the wait with --timeout)')


def _where_the_robot_is(tc: ModuleType, client: GprClient, names: Sequence[str], joint_states: str,
                        args: argparse.Namespace) -> tuple[NDArray[np.float64] | None, str]:
    """The robot's positions of ``names`` from ``joint_states``, or None with the line that says why: no joint states
    came, or they came without some of the joints (another robot's: it said none came)."""
    try:
        current: NDArray[np.float64] | None = tc.current_positions(client, names, joint_states, args.timeout)
    except tc.MissingJointsError as exc:
        return None, (f'gpr program send: joint states on {joint_states} came {exc}: is the program\'s robot the one '
                      'there? (change the topic with --joint-states and --namespace)')
    if current is None:
        return None, _no_answer(f'no joint states with the joints {", ".join(names)}', args.joint_states,
                                joint_states, args.timeout, '--joint-states', 'cannot tell where the robot is')
    return current, ''


#: Largest change [m or rad] of a joint while the lead-in is planned for a robot at rest (robot_simulator_node's
#: default ``start_tolerance``).
MOVED = 1e-3


def _lead_in(args: argparse.Namespace, plan: ProgramPlan, traj: JointTrajectory, tc: ModuleType, client: GprClient,
             joint_states: str, current: NDArray[np.float64]) -> tuple[JointTrajectory, float | None, str]:
    """The goal from where the robot is (``current``) and its lead-in [s], with the line that says why it cannot
    be sent ('' if it can): a start it cannot leave, or a robot that moved beyond :data:`MOVED` while the lead-in was
    planned (still running another goal, it had been sent a start where it had been and refused it, naming its start
    tolerance: ``INVALID_GOAL``)."""
    from ..robot.controller import ControllerJoints
    from ..robot.trajectory import lead_in
    try:
        goal, start = lead_in(plan, traj, current, args.rate)
    except RobotStateError as exc:   # a start it cannot leave: no lead-in
        return traj, None, f'gpr program send: {exc}'
    unsafe = ''
    try:
        lead_in_keeps_clearance(plan, goal, start, margin_of(args))
    except RobotStateError as exc:   # the lead-in known (its --json said null while the line named it)
        unsafe = f'gpr program send: {exc}'
    now, _ = _where_the_robot_is(tc, client, traj.joint_names, joint_states, args)
    off = np.zeros(1) if now is None else abs(now - current)
    k = int(off.argmax())
    if not off[k] > MOVED:   # a moving robot first: its move from where it was is no move of where it is
        return goal, start, unsafe
    joints = ControllerJoints.of(plan.robot)
    unit = joints.units[joints.names.index(traj.joint_names[k])]
    return goal, start, (f'gpr program send: the robot is moving: {traj.joint_names[k]} went {off[k]:.3g} {unit} '
                         'while the move from where it was was planned (another goal under way?); allowed: a robot at '
                         'rest (wait for its goal to end, or cancel it)')


def _failed(args: argparse.Namespace, plan: ProgramPlan, action: str, traj: JointTrajectory, line: str,
            status: str = 'not_sent', lead_in: float | None = None) -> int:
    """A send that ended before the goal's outcome: ``line`` on stderr and, with ``--json``, the :class:`SendResult`
    saying so on stdout (``check --json`` and ``verify --json`` print theirs on status 1 too); status 1."""
    print(line, file=sys.stderr)
    if args.json:
        emit_json(SendResult(plan.program.source, plan.robot.name, action, list(traj.joint_names), len(traj),
                             traj.duration, lead_in, status, 0, '', '', 0, line.removeprefix('gpr program send: ')))
    return 1


def _check_times(args: argparse.Namespace) -> None:
    """``--timeout``, ``--progress``, ``--rate`` and ``--margin`` within their bounds
    (:class:`~gpr_kinematics.errors.InputError`)."""
    if not 0.0 < args.timeout <= 3600.0:
        raise InputError(f'--timeout = {args.timeout:.12g} s; allowed: 0 < timeout <= 3600 s')
    if not 0.0 < args.progress <= 3600.0:  # NaN printed nothing, 0 or less a line per feedback
        raise InputError(f'--progress = {args.progress:.12g} s; allowed: 0 < progress <= 3600 s')
    sample_rate(args.rate)
    margin_of(args, warn=True)


def _refused_as_unsafe(args: argparse.Namespace, plan: ProgramPlan, traj: JointTrajectory, exc: UnsafeError) -> int:
    """A program ``gpr program check`` finds not safe, with ``--json``: the line ``main`` prints for an
    :class:`~gpr_kinematics.errors.UnsafeError` and the :class:`SendResult` of status ``unsafe``, its ``failure`` the
    reason; the action's full name where a ROS environment is found (else the name as given); status 1."""
    from ..errors import GprError, one_line
    try:
        _ros_modules()
        action = _ros_names(args)[1]
    except (GprError, ImportError) as err:
        if isinstance(err, InputError):   # a bad --action or --namespace: bad input first, as without the refusal
            raise
        action = args.action
    reason = one_line(str(exc))
    print(f'gpr program send: error: {reason}', file=sys.stderr)
    emit_json(SendResult(plan.program.source, plan.robot.name, action, list(traj.joint_names), len(traj),
                         traj.duration, None, 'unsafe', 0, '', '', 0, reason))
    return 1


def _cmd_send(args: argparse.Namespace) -> int:
    from ..robot.trajectory import program_trajectory
    _check_times(args)
    _, plan = program_plan(args, args.rate)
    traj = program_trajectory(plan, args.rate)
    try:
        as_a_controller_takes_it(plan, traj, args.rate, 'send', margin_of(args))
    except UnsafeError as exc:
        if not args.json:
            raise
        return _refused_as_unsafe(args, plan, traj, exc)
    tc = _ros_modules()
    joint_states, action = _ros_names(args)
    with tc.GprClient(SEND_NODE, namespace=args.namespace) as client:
        current, why = _where_the_robot_is(tc, client, traj.joint_names, joint_states, args)
        other = None if current is None else tc.other_robot_there(client, plan.robot.name)
        if current is None or other is not None:   # another robot there, status 1
            return _failed(args, plan, action, traj, why or f'gpr program send: {other}')
        goal, start, why = _lead_in(args, plan, traj, tc, client, joint_states, current)
        if why:   # the robot's state, not the command's input: as a refused goal, status 1
            return _failed(args, plan, action, goal, why, lead_in=start)

        def found() -> None:   # said once the server is found, not before "no FollowJointTrajectory server"
            if not args.json:
                print(f'sending {len(goal)} points over {len(goal.joint_names)} joints, {goal.duration:.3f} s '
                      f'({start:.3f} s from where the robot is to the program\'s start) to {action}', flush=True)
        clock = {'next': 0.0, 'end': False}

        def progress(fb: RosMessage) -> None:   # the end once, then every --progress s (a lag settles sample by sample)
            t = fb.desired.time_from_start.sec + fb.desired.time_from_start.nanosec * 1e-9
            end = t >= goal.duration and not clock['end']
            if not (args.json or args.no_progress) and (t >= clock['next'] or end):
                error = max((abs(e) for e in fb.error.positions), default=0.0)
                print(f'  t = {t:8.3f} s of {goal.duration:.3f} s, largest error {error:.3g}', flush=True)
                clock['next'], clock['end'] = t + args.progress, clock['end'] or t >= goal.duration
        try:
            outcome = tc.follow_trajectory(client, goal, action, args.timeout, progress, found)
        except tc.NoServerError:
            return _failed(args, plan, action, goal, _no_answer('no FollowJointTrajectory server', args.action, action,
                                                                args.timeout, '--action'), lead_in=start)
        except tc.ServiceTimeoutError as exc:
            return _failed(args, plan, action, goal, f'gpr program send: {exc}', 'no_result', start)
    result = SendResult(plan.program.source, plan.robot.name, action, list(goal.joint_names), len(goal),
                        goal.duration, start, outcome.status, outcome.error_code, outcome.error_name,
                        outcome.error_string, outcome.feedback)
    if args.json:
        emit_json(result)
    else:
        code = f'error_code {result.error_code}' + (f' {result.error_name}' if result.error_name else '')
        print(f'{result.status} ({code}){": " + result.error_string if result.error_string else ""}')
    return 0 if result.succeeded else 1


def send_parser(psub: Subparsers) -> None:
    """Add ``gpr program send`` to ``gpr program``'s subcommands ``psub``."""
    p = psub.add_parser('send', help='run the program on a robot: a FollowJointTrajectory goal (ROS)')
    p.add_argument('program', metavar='PROGRAM', type=shipped(PROGRAMS), help='robot program YAML file')
    p.add_argument('--action', default=FOLLOW_JOINT_TRAJECTORY, metavar='NAME',
                   help='the FollowJointTrajectory action (relative names resolve in --namespace; default '
                        f'{FOLLOW_JOINT_TRAJECTORY})')
    p.add_argument('--namespace', default='', metavar='NS', help="the robot's namespace, e.g. /r1 (default: none)")
    p.add_argument('--joint-states', default=Topic.JOINT_STATES, metavar='TOPIC',
                   help='where the robot publishes its joint states (default joint_states)')
    p.add_argument('--rate', type=number, default=100.0, help='points per second [Hz] (default 100)')
    p.add_argument('--timeout', type=number, default=10.0,
                   help='longest wait [s] for the server, the joint states, and the result after the end (default 10)')
    p.add_argument('--progress', type=number, default=1.0, help='seconds between progress lines (default 1)')
    p.add_argument('--no-progress', action='store_true', help='no progress lines: the goal sent and its outcome only')
    add_margin(p, 'the program, its trajectory and the move to its start')
    robot_options(p, program=True, cell=True)
    p.set_defaults(handler=_cmd_send)

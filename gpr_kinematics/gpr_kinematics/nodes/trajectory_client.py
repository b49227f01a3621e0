"""The client side of ``control_msgs/action/FollowJointTrajectory``: where the robot is, and a trajectory sent to a
controller (``robot_simulator_node``, ros2_control's ``joint_trajectory_controller``, any server of the action).

:func:`current_positions` waits for ``joint_states`` messages that together carry every joint of a trajectory
(:func:`other_robot_there` reads the robot's name on ``robot_description``);
:func:`follow_trajectory` sends a :class:`~gpr_kinematics.robot.trajectory.JointTrajectory` as a goal, reports its
feedback and returns the outcome (:class:`FollowOutcome`: the goal status and the result's ``error_code`` and
``error_string``); an interrupt (Ctrl-C, SIGTERM) cancels the goal before it leaves: while a goal is sent and
followed the signal is noted (:func:`noted_signals`), the goal cancelled, then the signal raised again for the
handler it was meant for. ``gpr program send`` runs on these.
"""
from __future__ import annotations

import re
import signal
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any
from xml.sax.saxutils import unescape

import numpy as np
from action_msgs.msg import GoalStatus
from control_msgs.action import FollowJointTrajectory
from rclpy.action import ActionClient
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg
from trajectory_msgs.msg import JointTrajectoryPoint

from ..errors import GprError, brief
from ..robot.controller import ERROR_NAMES, joint_state_values
from ..robot.trajectory import JointTrajectory
from .client import GprClient, ServiceTimeoutError
from .conversions import duration_msg
from .qos import action_client_options, latched_qos, stream_qos

#: Time [s] for a subscription to match a publisher the graph already shows.
SETTLE = 0.3
_STATUS = {GoalStatus.STATUS_SUCCEEDED: 'succeeded', GoalStatus.STATUS_ABORTED: 'aborted',
           GoalStatus.STATUS_CANCELED: 'canceled'}


def trajectory_msg(traj: JointTrajectory) -> JointTrajectoryMsg:
    """``trajectory_msgs/JointTrajectory`` of ``traj`` (header stamp 0: start when it arrives)."""
    points = []
    for i in range(len(traj)):
        pt = JointTrajectoryPoint(positions=traj.positions[i].tolist(),
                                  time_from_start=duration_msg(float(traj.time[i])))
        if traj.velocities is not None:
            pt.velocities = traj.velocities[i].tolist()
        if traj.accelerations is not None:
            pt.accelerations = traj.accelerations[i].tolist()
        points.append(pt)
    return JointTrajectoryMsg(joint_names=list(traj.joint_names), points=points)


#: Most joint names a :class:`MissingJointsError` lists of those the messages carried.
CARRIED_SHOWN = 16


class MissingJointsError(ServiceTimeoutError):
    """Joint states came within the wait, but without some of the joints asked for: ``missing``, ``heard`` (the
    joints the messages carried, at most :data:`CARRIED_SHOWN` of them named in the text) and ``ignored`` (what the
    last message left out, or '')."""

    def __init__(self, missing: Sequence[str], heard: Sequence[str], ignored: str = '') -> None:
        shown = ', '.join(heard[:CARRIED_SHOWN]) + (f' and {len(heard) - CARRIED_SHOWN} more'
                                                    if len(heard) > CARRIED_SHOWN else '')
        carry = f' (they carry {shown})' if heard else ''
        why = f' (left out of the last message that left one out: {ignored})' if ignored else ''
        super().__init__(f'without {", ".join(missing)}{carry}{why}')
        self.missing, self.heard, self.ignored = tuple(missing), tuple(heard), ignored


def current_positions(client: GprClient, names: Sequence[str], topic: str, timeout: float) -> np.ndarray | None:
    """The latest positions of ``names`` from ``joint_states`` messages on ``topic`` (several messages may share
    them), read as the simulator and the state publisher read them
    (:func:`~gpr_kinematics.robot.controller.joint_state_values`: a malformed message ignored, a value not finite left
    out), waiting at most ``timeout`` s for every one; None if no message came, :class:`MissingJointsError` if
    messages came without some of ``names`` (another robot's, or malformed: it said no joint states came, and took a
    joint named twice)."""
    latest: dict[str, float] = {}
    carried: set[str] = set()   # every name the messages carried (only the program's were listed: 'they carry
    ignored = ['']              # rod_1, rod_2, rod_3' of a robot whose arms had other names)

    def take(msg: JointState) -> None:
        if len(carried) < 10 * CARRIED_SHOWN:
            carried.update(str(n) for n in list(msg.name)[:10 * CARRIED_SHOWN])
        try:
            taken, values, left = joint_state_values(names, msg.name, msg.position)
        except GprError as exc:
            ignored[0] = f'the whole message, {exc}'
            return
        if left:
            ignored[0] = f'{", ".join(left)} not finite'
        latest.update((names[k], v) for k, v in zip(taken.tolist(), values.tolist(), strict=True))

    sub = client.node.create_subscription(JointState, topic, take, stream_qos(100))
    try:
        if not client.spin_until(lambda: all(n in latest for n in names), timeout):
            if latest or ignored[0]:
                raise MissingJointsError([n for n in names if n not in latest], sorted(carried), ignored[0])
            return None
        return np.array([latest[n] for n in names])
    finally:
        client.node.destroy_subscription(sub)


#: How long [s] ``gpr program send`` waits for the robot's ``robot_description`` once its joint states came (a
#: simulator without a state publisher describes none: the wait is spent, and nothing is compared).
DESCRIPTION_WAIT = 1.5
#: Characters of a URDF read for its robot's name (its ``<robot name=...>`` opens it).
URDF_HEAD = 4096


def other_robot_there(client: GprClient, robot: str, timeout: float = DESCRIPTION_WAIT) -> str | None:
    """Why a program for ``robot`` (its name) is not for the robot there, or None: the name of the URDF on
    ``robot_description`` (latched, the state publisher's, in the client's namespace) where it is another (a
    program of robot 2 ran on robot 1 without a word: their joints are named alike); None also where none came."""
    from std_msgs.msg import String
    got: list[Any] = []
    sub = client.node.create_subscription(String, 'robot_description', got.append, latched_qos(1))
    try:
        client.spin_until(lambda: bool(got), timeout)
    finally:
        client.node.destroy_subscription(sub)
    found = re.search(r'<robot\s+name=(["\'])(.*?)\1', str(got[-1].data)[:URDF_HEAD]) if got else None
    there = None if found is None else unescape(found.group(2), {'&quot;': '"', '&apos;': "'"})
    if there is None or there == robot:
        return None
    topic = client.node.resolve_topic_name('robot_description')
    shown = there if len(there) <= 64 else brief(there)   # a robot's name has at most 64 characters; a message more
    return (f'{topic} describes robot {shown}, and the program is for robot {robot}: is the program\'s robot the one '
            'there? (another robot with --namespace, or that robot\'s program)')



class NoServerError(ServiceTimeoutError):
    """No FollowJointTrajectory server answered on the action within the wait."""


@dataclass(frozen=True)
class FollowOutcome:
    """How a goal ended: ``status`` (succeeded, aborted, canceled, rejected), the result's ``error_code``, its name
    and ``error_string``, and the feedback messages received."""

    status: str
    error_code: int
    error_name: str
    error_string: str
    feedback: int


def follow_trajectory(client: GprClient, traj: JointTrajectory, action: str, timeout: float,
                      progress: Callable[[Any], None] | None = None,
                      found: Callable[[], None] | None = None) -> FollowOutcome:
    """Send ``traj`` to the FollowJointTrajectory server ``action`` (waiting at most ``timeout`` s for it) and wait
    for the result (the trajectory's duration plus ``timeout``); ``progress`` gets every feedback message, ``found``
    is called once the server is found, before the goal is sent.

    Raises:
        NoServerError: no server answered on ``action`` (named in full) within ``timeout``.
        ServiceTimeoutError: no answer to the goal or no result in time (a goal under way is cancelled first).
    """
    cli = ActionClient(client.node, FollowJointTrajectory, action, **action_client_options(1000))
    try:
        if not cli.wait_for_server(timeout_sec=timeout):
            raise NoServerError(f'no FollowJointTrajectory server on {client.node.resolve_topic_name(action)} within '
                                f'{timeout:g} s')
        # The server's services answer before its feedback topic may be matched: wait until the graph shows the
        # feedback publisher, and a moment for the match, so the first samples' feedback is not lost.
        feedback_topic = client.node.resolve_topic_name(action) + '/_action/feedback'
        if client.spin_until(lambda: bool(client.node.get_publishers_info_by_topic(feedback_topic)), timeout):
            client.spin_for(SETTLE)
        count = [0]
        if found is not None:
            found()

        def on_feedback(msg: Any) -> None:
            count[0] += 1
            if progress is not None:
                progress(msg.feedback)

        goal = FollowJointTrajectory.Goal(trajectory=trajectory_msg(traj))
        with noted_signals() as signals:   # noted, not raised within rclpy (module docstring)
            handle = client.wait(cli.send_goal_async(goal, feedback_callback=on_feedback), timeout, f'{action} goal')
            future = handle.get_result_async() if handle.accepted else None
            end = time.monotonic() + traj.duration + timeout
            while future is not None and not future.done() and not signals and time.monotonic() < end:
                client.executor.spin_once(timeout_sec=0.05)
            if signals and future is not None and not future.done():
                _cancel(client, handle)
        if signals:
            signal.raise_signal(signals[0])   # to the handler it was meant for (gpr's: interrupted, 130/143)
        if future is None:
            return FollowOutcome('rejected', 0, '', f'{action} rejected the goal', 0)
        if not future.done():
            _cancel(client, handle)
            raise ServiceTimeoutError(f'{action}: no result {timeout:g} s after the trajectory\'s end; the goal was '
                                      'cancelled')
        res = future.result()
        code = int(res.result.error_code)
        return FollowOutcome(_STATUS.get(res.status, f'status {res.status}'), code, ERROR_NAMES.get(code, ''),
                             str(res.result.error_string), count[0])
    finally:
        cli.destroy()


@contextmanager
def noted_signals() -> Iterator[list[int]]:
    """SIGINT and SIGTERM noted in the list it yields, not handled, while the block runs (in the main thread; a
    signal ignored stays ignored); the handlers restored after it. A ``KeyboardInterrupt`` raised by the handler
    while rclpy converted a message became a ``TypeError`` ("Unable to convert function return value"): a traceback,
    and the goal left running."""
    noted: list[int] = []
    previous: dict[signal.Signals, Any] = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(signum) is signal.SIG_IGN:
            continue
        try:
            previous[signum] = signal.signal(signum, lambda n, _frame: noted.append(n))
        except ValueError:   # not the main thread: nothing to note
            break
    try:
        yield noted
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def _cancel(client: GprClient, handle: Any) -> None:
    """Ask the server to cancel ``handle``'s goal and wait briefly for the answer (best effort)."""
    future = handle.cancel_goal_async()
    end = time.monotonic() + 2.0
    while not future.done() and time.monotonic() < end:
        client.executor.spin_once(timeout_sec=0.05)

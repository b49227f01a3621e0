"""robot_simulator_node over real DDS: control_msgs/action/FollowJointTrajectory as joint_trajectory_controller
serves it. A feasible goal runs to SUCCESSFUL with joint_states at the rate (stamped start + k / rate, the points met
exactly, the rest held) and ordered feedback; refused goals end with the standard error codes and a message (beyond a
limit, unknown joints, too fast, old stamps), and the node serves the next goal; cancel holds the joints where they
are; path and goal tolerances against a lagging servo; joint_states held at idle_rate, following another
publisher while idle."""
from __future__ import annotations

import math
import re
import time

import numpy as np
import pytest
from gpr_kinematics.robot.controller import ControllerJoints
from gpr_kinematics.robot.trajectory import JointTrajectory, evaluate
from robot_support import ROBOT
from ros_support import start, wait_for_log

pytestmark = pytest.mark.ros

JOINTS = ControllerJoints.of(ROBOT)
NS = '/gpr_sim'
ACTION = 'joint_trajectory_controller/follow_joint_trajectory'
RATE = 100.0
NS_PER_S = 1_000_000_000


def _stamp(msg) -> int:
    return msg.header.stamp.sec * NS_PER_S + msg.header.stamp.nanosec


def _seconds(d) -> float:
    return d.sec + 1e-9 * d.nanosec


def session(proc, ready: str, name: str, namespace: str):
    """A module fixture's body: once ``proc`` (a simulator) logged ``ready``, a client ``name`` in ``namespace``, its
    joint_states subscription and its action client; the simulator stopped after the module."""
    from control_msgs.action import FollowJointTrajectory
    from gpr_kinematics.nodes.client import GprClient
    from gpr_kinematics.nodes.qos import action_client_options, stream_qos
    from rclpy.action import ActionClient
    from sensor_msgs.msg import JointState

    try:
        wait_for_log(proc, ready)
        with GprClient(name, namespace=namespace) as c:
            # The simulator's own states (all its joints, in its order): the tests' foreign messages, still queued
            # after their test on a loaded machine, were taken for its held state (two alike in a row: 'rod_1' only).
            states: list[JointState] = []
            c.node.create_subscription(JointState, 'joint_states',
                                       lambda m: states.append(m) if tuple(m.name) == JOINTS.names else None,
                                       stream_qos(100_000))
            cli = ActionClient(c.node, FollowJointTrajectory, ACTION, **action_client_options(1000))
            # The feedback topic itself: rclpy's action client drops the feedback it has not taken yet once the
            # result arrives (it forgets the goal's callback), so a count of feedback needs its own subscription.
            c.feedback_topic = c.subscribe(FollowJointTrajectory.Impl.FeedbackMessage,
                                           f'{namespace}/{ACTION}/_action/feedback', 1000)
            assert cli.wait_for_server(timeout_sec=20.0), proc.output()
            _feedback_matched(c, namespace)
            assert c.spin_until(lambda: len(states) >= 2, 10), proc.output()
            yield c, cli, states, proc
    finally:
        proc.stop()
        print(proc.output())


def _feedback_matched(c, namespace):
    """The action's services answer before its feedback topic is matched: wait until the graph shows the server's
    feedback publisher, and a moment for the match (as ``gpr program send`` does), so no feedback is lost."""
    topic = f'{namespace}/{ACTION}/_action/feedback'
    assert c.spin_until(lambda: bool(c.node.get_publishers_info_by_topic(topic)), 20), topic
    c.spin_for(1.0)


@pytest.fixture(scope='module')
def sim(ros_environment):
    """A simulator and a client in NS; the client's joint_states subscription and its action client."""
    proc = start('robot_simulator_node', namespace=NS, rate=RATE, idle_rate=20.0)
    yield from session(proc, r'serving /gpr_sim/joint_trajectory_controller/follow_joint_trajectory',
                       'gpr_test_simulator', NS)


def _goal(names, times, positions, velocities=None, **extra):
    from builtin_interfaces.msg import Duration
    from control_msgs.action import FollowJointTrajectory
    from trajectory_msgs.msg import JointTrajectoryPoint

    goal = FollowJointTrajectory.Goal(**extra)
    goal.trajectory.joint_names = list(names)
    for i, (t, p) in enumerate(zip(times, positions, strict=True)):
        ns = round(t * NS_PER_S)
        pt = JointTrajectoryPoint(positions=[float(v) for v in p], time_from_start=Duration(sec=ns // NS_PER_S,
                                                                                         nanosec=ns % NS_PER_S))
        if velocities is not None:
            pt.velocities = [float(v) for v in velocities[i]]
        goal.trajectory.points.append(pt)
    return goal


def _run(c, cli, goal, feedback=None, cancel_after=None):
    """Send ``goal``; its result message and status (cancelled after ``cancel_after`` s if given)."""
    handle = c.wait(cli.send_goal_async(goal, feedback_callback=(lambda m: feedback.append(m.feedback))
                                        if feedback is not None else None), 20, 'goal')
    assert handle.accepted
    if cancel_after is not None:
        c.spin_for(cancel_after)
        c.wait(handle.cancel_goal_async(), 10, 'cancel')
    res = c.wait(handle.get_result_async(), 60, 'result')
    return res.result, res.status


def _held(c, states, name, timeout=10.0):
    """The value of joint ``name`` the simulator holds: two messages in a row that came after the call agree (during a
    motion every sample moves the joints; messages of a motion may still be queued behind its result)."""
    n = len(states)
    assert c.spin_until(lambda: len(states) >= n + 2 and list(states[-1].position) == list(states[-2].position),
                        timeout)
    msg = states[-1]
    return msg.position[list(msg.name).index(name)]


def test_error_codes_are_control_msgs(sim):
    from control_msgs.action import FollowJointTrajectory
    from gpr_kinematics.robot import controller

    R = FollowJointTrajectory.Result
    assert (R.SUCCESSFUL, R.INVALID_GOAL, R.INVALID_JOINTS, R.OLD_HEADER_TIMESTAMP, R.PATH_TOLERANCE_VIOLATED,
            R.GOAL_TOLERANCE_VIOLATED) == (controller.SUCCESSFUL, controller.INVALID_GOAL, controller.INVALID_JOINTS,
                                           controller.OLD_HEADER_TIMESTAMP, controller.PATH_TOLERANCE_VIOLATED,
                                           controller.GOAL_TOLERANCE_VIOLATED)


def test_idle_joint_states_hold_the_rest_state(sim):
    _, _, states, _ = sim
    msg = states[0]
    assert tuple(msg.name) == JOINTS.names
    np.testing.assert_array_equal(msg.position, JOINTS.rest)
    assert not any(msg.velocity)


def test_idle_joint_states_come_at_the_idle_rate(sim):
    """Idle at idle_rate 20 Hz: the states 0.05 s apart by their stamps (the node's clock, not the client's
    reading); a tick the timer's jitter made early was skipped, every other one: 0.1 s, 10 Hz."""
    c, _, states, _ = sim
    n = len(states)
    assert c.spin_until(lambda: len(states) >= n + 21, 20)
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in states[n:]])
    assert 0.04 < float(np.median(np.diff(stamps))) < 0.07, np.diff(stamps)


def test_a_feasible_two_point_trajectory_succeeds_and_is_published_at_the_rate(sim):
    from action_msgs.msg import GoalStatus

    c, cli, states, _ = sim
    names = ('arm1_elbow', 'rod_2')
    current = {n: _held(c, states, n) for n in names}
    targets = [[1.0, 0.256], [1.5, 0.255]]
    feedback: list = []
    n0, f0 = len(states), len(c.feedback_topic)
    result, status = _run(c, cli, _goal(names, [1.0, 2.0], targets), feedback)
    assert status == GoalStatus.STATUS_SUCCEEDED and result.error_code == 0, result.error_string
    assert 'reached the last point' in result.error_string
    # The result and the last feedback travel apart (on a loaded machine the feedback comes later): wait for it.
    c.spin_until(lambda: len(c.feedback_topic) - f0 >= 201, 10)
    c.spin_for(0.2)
    published = [m.feedback for m in c.feedback_topic[f0:]]
    # The goal's samples: consecutive stamps 10 ms apart from its start.
    stamps = np.array([_stamp(m) for m in states[n0:]])
    gaps = np.diff(stamps)
    first = int(np.argmax(gaps == NS_PER_S // 100))
    goal_msgs = states[n0 + first:n0 + first + 201]
    t = (np.array([_stamp(m) for m in goal_msgs]) - _stamp(goal_msgs[0])) / NS_PER_S
    np.testing.assert_allclose(t, np.arange(201) / RATE, rtol=0, atol=1e-9)
    traj = JointTrajectory(names, np.array([1.0, 2.0]), np.array(targets))
    expected, _, _ = evaluate(traj, np.array([current[n] for n in names]), np.arange(201) / RATE)
    idx = [JOINTS.names.index(n) for n in names]
    got = np.array([[m.position[k] for k in idx] for m in goal_msgs])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    assert np.array_equal(got[[100, 200]], np.array(targets))          # the points, exactly
    others = [k for k in range(len(JOINTS.names)) if k not in idx]
    assert all(np.array_equal(np.array(m.position)[others], np.array(goal_msgs[0].position)[others])
               for m in goal_msgs)
    # Feedback: one per sample, over the goal's joints, in order; the joints follow exactly (tau = 0). The action
    # client's callback saw the same messages up to the result (all of them on a quiet machine).
    assert len(published) == 201 and all(list(f.joint_names) == list(names) for f in published)
    times = [f.desired.time_from_start.sec + f.desired.time_from_start.nanosec / 1e9 for f in published]
    np.testing.assert_allclose(times, np.arange(201) / RATE, rtol=0, atol=1e-9)
    assert all(max(abs(e) for e in f.error.positions) == 0.0 for f in published)
    assert feedback and feedback == published[:len(feedback)]
    # After the goal the joints hold the last point.
    assert _held(c, states, 'arm1_elbow') == 1.5


@pytest.mark.parametrize('names, positions, times, code, words', [
    (['arm1_elbow'], [[1.0], [3.0]], [1.0, 2.0], -1,
     r'point 1 \(t = 2 s\): arm1_elbow = 3 rad is beyond its upper limit 2.9 rad by 0.1 rad'),
    (['arm1_elbw'], [[1.0]], [1.0], -2, r"unknown joint 'arm1_elbw'"),
    (['rod_1'], [[0.254], [0.3]], [1.0, 1.1], -1, r'needs rod_1 at .* m/s on average; allowed: at most 0.15 m/s'),
    (['arm1_elbow'], [[1.0], [0.5]], [1.0, 1.0], -1, 'strictly increasing'),
])
def test_bad_goals_fail_with_the_standard_code_and_the_node_serves_on(sim, names, positions, times, code, words):
    from action_msgs.msg import GoalStatus

    c, cli, _, _ = sim
    result, status = _run(c, cli, _goal(names, times, positions))
    assert status == GoalStatus.STATUS_ABORTED and result.error_code == code
    assert re.search(words, result.error_string), result.error_string


def test_a_goal_that_ends_moving_is_refused_as_joint_trajectory_controller_refuses_it(sim):
    """joint_trajectory_controller (Jazzy: allow_nonzero_velocity_at_trajectory_end false by default) refuses a goal
    whose last point gives a joint a velocity; the simulator accepted it and stopped the joint dead at the end. The
    same goal ending at rest runs."""
    from action_msgs.msg import GoalStatus

    c, cli, states, _ = sim
    here = _held(c, states, 'arm1_elbow')
    points = [[here - 0.1], [here - 0.2]]
    result, status = _run(c, cli, _goal(['arm1_elbow'], [1.0, 2.0], points, velocities=[[-0.1], [-0.05]]))
    assert status == GoalStatus.STATUS_ABORTED and result.error_code == -1
    assert result.error_string == ('points[1] (the last) gives arm1_elbow a velocity of -0.05 rad/s; allowed: 0 at '
                                   'the last point (parameter allow_nonzero_velocity_at_trajectory_end, false as '
                                   "joint_trajectory_controller's)")
    assert _held(c, states, 'arm1_elbow') == here
    result, status = _run(c, cli, _goal(['arm1_elbow'], [1.0, 2.0], points, velocities=[[-0.1], [0.0]]))
    assert status == GoalStatus.STATUS_SUCCEEDED and result.error_code == 0, result.error_string


def test_an_old_header_stamp(sim):
    c, cli, _, _ = sim
    goal = _goal(['arm1_elbow'], [0.5], [[1.5]])
    goal.trajectory.header.stamp.sec = int(time.time()) - 10
    result, _ = _run(c, cli, goal)
    assert result.error_code == -3 and 'in the past' in result.error_string


def test_a_stamp_in_the_past_whose_trajectory_has_not_ended_runs_with_its_points_at_their_instants(sim):
    """As joint_trajectory_controller: a goal stamped by its client and late on arrival (here 0.4 s, as a goal of
    5,000 points is in transit) runs; each point is reached at header.stamp + its time_from_start. It was refused
    OLD_HEADER_TIMESTAMP whenever the stamp lay more than one sample period in the past."""
    from action_msgs.msg import GoalStatus

    c, cli, states, _ = sim
    here = _held(c, states, 'arm1_elbow')
    targets = [here - 0.2, here - 0.3]
    goal = _goal(['arm1_elbow'], [2.0, 2.5], [[targets[0]], [targets[1]]])     # 1.6 s ahead on arrival: a load's margin
    stamp = c.node.get_clock().now().nanoseconds - 400_000_000
    goal.trajectory.header.stamp.sec, goal.trajectory.header.stamp.nanosec = divmod(stamp, NS_PER_S)
    n = len(states)
    feedback: list = []
    result, status = _run(c, cli, goal, feedback)
    assert status == GoalStatus.STATUS_SUCCEEDED and result.error_code == 0, result.error_string
    # the goal's times count from its stamp (they counted from the arrival: 'at t = 2.1 s', feedback from 0)
    assert result.error_string.startswith('reached the last point at t = 2.5 s'), result.error_string
    assert feedback and all(abs(_stamp(f) - stamp - round(_seconds(f.desired.time_from_start) * NS_PER_S)) <= 1000
                            for f in feedback)
    k = JOINTS.names.index('arm1_elbow')
    assert c.spin_until(lambda: any(abs(_stamp(m) - (stamp + 2_500_000_000)) <= 1000 for m in states[n:]), 10)
    for t, target in zip((2.0, 2.5), targets, strict=True):   # the samples at the points' instants (to 1 us)
        (msg,) = [m for m in states[n:] if abs(_stamp(m) - (stamp + round(t * NS_PER_S))) <= 1000]
        assert msg.position[k] == pytest.approx(target, abs=1e-12)


def test_a_goal_waiting_for_its_stamp_keeps_the_held_state_on_joint_states(sim):
    """A goal stamped ahead waits for its instant (as joint_trajectory_controller's); meanwhile the held state goes
    out at idle_rate, stamped now, still: the simulator was silent until the stamp (up to a day ahead), and a client
    that needs the robot's state (``gpr program send``, MoveIt's state monitor) took the robot for gone."""
    from action_msgs.msg import GoalStatus

    c, cli, states, _ = sim
    here = _held(c, states, 'arm1_elbow')
    goal = _goal(['arm1_elbow'], [0.5], [[here - 0.1]])
    stamp = c.node.get_clock().now().nanoseconds + 2_500_000_000
    goal.trajectory.header.stamp.sec, goal.trajectory.header.stamp.nanosec = divmod(stamp, NS_PER_S)
    handle = c.wait(cli.send_goal_async(goal), 20, 'goal')
    assert handle.accepted
    n = len(states)
    c.spin_for(1.0)
    waiting = [m for m in states[n:] if _stamp(m) < stamp]
    assert len(waiting) >= 10, len(waiting)   # 20 Hz for 1 s (none before)
    k = list(waiting[0].name).index('arm1_elbow')
    assert all(m.position[k] == here and not any(m.velocity) for m in waiting)
    assert float(np.median(np.diff([_stamp(m) for m in waiting]))) == pytest.approx(0.05 * NS_PER_S, rel=0.4)
    res = c.wait(handle.get_result_async(), 30, 'result')
    assert res.status == GoalStatus.STATUS_SUCCEEDED and res.result.error_code == 0, res.result.error_string
    assert _held(c, states, 'arm1_elbow') == pytest.approx(here - 0.1, abs=1e-12)


def test_a_goal_cancelled_while_it_waits_for_its_stamp_says_nothing_moved(sim):
    """It said 'cancelled at t = 0 s of 0.5 s' of a goal that had not started."""
    from action_msgs.msg import GoalStatus

    c, cli, states, _ = sim
    here = _held(c, states, 'arm1_elbow')
    goal = _goal(['arm1_elbow'], [0.5], [[here - 0.1]])
    stamp = c.node.get_clock().now().nanoseconds + 3_000_000_000
    goal.trajectory.header.stamp.sec, goal.trajectory.header.stamp.nanosec = divmod(stamp, NS_PER_S)
    result, status = _run(c, cli, goal, cancel_after=0.3)
    assert status == GoalStatus.STATUS_CANCELED and result.error_code == 0
    assert result.error_string == 'cancelled before its start; nothing moved', result.error_string
    assert _held(c, states, 'arm1_elbow') == here


def test_cancel_holds_the_joints_where_they_are(sim):
    from action_msgs.msg import GoalStatus

    c, cli, states, _ = sim
    start_value = _held(c, states, 'arm1_shoulder')
    feedback: list = []
    result, status = _run(c, cli, _goal(['arm1_shoulder'], [3.0], [[start_value + 1.5]]), feedback, cancel_after=0.6)
    assert status == GoalStatus.STATUS_CANCELED and result.error_code == 0
    stopped = _held(c, states, 'arm1_shoulder')
    # the time named is the last sample sent, the one the joints hold (it named the next, never sent)
    last = feedback[-1].desired
    t = last.time_from_start.sec + 1e-9 * last.time_from_start.nanosec
    assert re.match(rf'cancelled at t = {t:.6g} s of 3 s', result.error_string), (t, result.error_string)
    assert stopped == last.positions[0]
    assert start_value < stopped < start_value + 1.5
    n = len(states)
    c.spin_for(0.3)
    k = list(states[-1].name).index('arm1_shoulder')
    assert c.spin_until(lambda: len(states) > n, 5) and all(m.position[k] == stopped for m in states[n:])


def test_idle_simulator_follows_another_publisher(sim):
    """While idle, the joint values another node publishes (newer stamps) become the simulator's state."""
    from sensor_msgs.msg import JointState

    c, _, states, _ = sim
    pub = c.node.create_publisher(JointState, 'joint_states', 10)
    msg = JointState(name=['arm2_hand', 'nope'], position=[0.75, 1.0])
    msg.header.stamp = c.node.get_clock().now().to_msg()
    pub.publish(msg)
    assert c.spin_until(lambda: states[-1].position[list(states[-1].name).index('arm2_hand')] == 0.75, 5)
    c.node.destroy_publisher(pub)


def test_joint_states_it_ignores_do_not_silence_the_simulator(sim):
    """Another publisher's joint_states silenced the idle simulator (its own state stopped) even when it took
    nothing from them (a gripper's joints only, a malformed message, values beyond a limit), and a client then found
    no robot state: only values it takes silence it."""
    from sensor_msgs.msg import JointState

    c, _, states, _ = sim
    pub = c.node.create_publisher(JointState, 'joint_states', 10)
    for names, values in ((['finger_joint'], [0.0]), (['arm1_elbow', 'rod_1'], [0.1]), (['rod_1'], [9.0])):
        n = len(states)
        end = time.monotonic() + 1.0
        while time.monotonic() < end:   # 20 Hz of foreign messages for 1 s
            msg = JointState(name=names, position=values)
            msg.header.stamp = c.node.get_clock().now().to_msg()
            pub.publish(msg)
            c.spin_for(0.05)
        own = [m for m in states[n:] if tuple(m.name) == JOINTS.names]
        assert len(own) >= 10, (names, len(own))   # the simulator's own state at its idle rate (20 Hz) throughout
    c.node.destroy_publisher(pub)


def test_a_goal_while_another_node_streams_the_robot_is_refused(sim):
    """A goal sent while trajectory_node streamed a program was accepted: both moved the robot (``joint_states``
    interleaved two robots, /tf flickered) and the stream undid the goal after its SUCCEEDED. Refused while another
    publisher's states stream (INVALID_GOAL, naming the stream), taken once it has ended."""
    from action_msgs.msg import GoalStatus
    from sensor_msgs.msg import JointState

    c, cli, states, _ = sim
    held = states[-1]
    pub = c.node.create_publisher(JointState, 'joint_states', 10)

    def stream():
        msg = JointState(name=list(held.name), position=list(held.position))
        msg.header.stamp = c.node.get_clock().now().to_msg()
        pub.publish(msg)

    timer = c.node.create_timer(0.02, stream)   # 50 Hz, while the goal is sent and answered
    c.spin_for(0.5)
    goal = _goal(['arm1_shoulder'], [0.5], [[_held(c, states, 'arm1_shoulder') + 0.05]])
    result, status = _run(c, cli, goal)
    c.node.destroy_timer(timer)
    c.node.destroy_publisher(pub)
    assert status == GoalStatus.STATUS_ABORTED and result.error_code == -1, result.error_string
    assert result.error_string == ("another node streams this robot's joint_states (a program or sweep of "
                                   'trajectory_node, say); allowed: a goal once that stream has ended')
    c.spin_for(0.5)
    result, status = _run(c, cli, goal)
    assert status == GoalStatus.STATUS_SUCCEEDED, result.error_string


def test_joint_states_beyond_the_limits_are_ignored_with_a_warning(sim):
    """Another publisher cannot put the simulator where no goal can start: values beyond a joint's limits, or rods
    that tilt the platform beyond its limit, are ignored (with a warning); a good goal runs afterwards."""
    from action_msgs.msg import GoalStatus
    from sensor_msgs.msg import JointState

    c, cli, states, proc = sim
    pub = c.node.create_publisher(JointState, 'joint_states', 10)
    before = {n: _held(c, states, n) for n in ('rod_1', 'rod_2', 'arm1_elbow')}
    for names, values in ((['rod_1', 'arm1_elbow'], [1e300, 50.0]), (['rod_1', 'rod_2'], [0.0, 0.508]),
                          (['arm1_elbow'], [50.0])):
        msg = JointState(name=names, position=values)
        msg.header.stamp = c.node.get_clock().now().to_msg()
        pub.publish(msg)
        c.spin_for(0.3)
        assert {n: _held(c, states, n) for n in before} == before
    wait_for_log(proc, r'joint_states of another publisher ignored: .*allowed: values within the joints. limits')
    c.node.destroy_publisher(pub)
    result, status = _run(c, cli, _goal(['arm1_shoulder'], [0.5], [[_held(c, states, 'arm1_shoulder') + 0.1]]))
    assert status == GoalStatus.STATUS_SUCCEEDED, result.error_string


def test_a_foreign_state_is_named_by_its_joints(ros_environment):
    """The warning of a foreign state that tilts the platform named the core's ``q``, not the joints it came as; one
    just beyond a limit read '2.9 rad is outside [-2.9, 2.9] rad': told apart, and by how much, as a goal's (no DDS)."""
    from gpr_kinematics.nodes.foreign_states import outside as refusal

    joints = ControllerJoints.of(ROBOT)

    def outside(state):
        return refusal(joints, ROBOT.config, state)

    state = joints.rest.copy()
    assert outside(state) == ''
    state[1] += 0.05   # rod_2 50 mm above the others: about 21 deg
    words = outside(state)
    assert re.fullmatch(r'rod_1, rod_2, rod_3: q = \[.*\] m tilts the platform by about \S+ rad \(\S+ deg\) in the '
                        r'naive model, beyond the tilt limit 0\.03491 rad \(2 deg\); allowed: rods within the tilt '
                        r'limit', words), words
    state = joints.rest.copy()
    state[joints.names.index('arm1_elbow')] = 50.0
    assert outside(state) == ("arm1_elbow = 50 rad is beyond its upper limit 2.9 rad by 47.1 rad; allowed: values "
                              "within the joints' limits ([-2.9, 2.9] rad)")
    state[joints.names.index('arm1_elbow')] = 2.9000000001
    assert outside(state).startswith('arm1_elbow = 2.9000000001 rad is beyond its upper limit 2.9 rad by 1e-10 rad; ')


def test_each_different_refusal_of_a_foreign_state_is_logged_a_repeated_one_at_most_every_5_s(sim):
    """One throttle of 5 s for every warning left a different refusal within 5 s of another unlogged (five bad
    states 1.5 s apart: the first and the last logged): each refusal (its kind and joint) has its own."""
    from sensor_msgs.msg import JointState

    c, _, _, proc = sim
    pub = c.node.create_publisher(JointState, 'joint_states', 10)
    cases = ((['arm2_wrist'], [3.0], r'arm2_wrist = 3 rad is beyond its upper limit 2\.5 rad'),
             (['arm2_wrist'], [-3.0], r'arm2_wrist = -3 rad is beyond its lower limit -2\.5 rad'),
             (['arm2_shoulder'], [4.0], r'arm2_shoulder = 4 rad is beyond its upper limit 3\.05 rad'),
             (['arm2_elbow', 'arm2_elbow'], [0.0, 0.0], r"joint 'arm2_elbow' named twice"))
    t0 = time.monotonic()
    for names, values, warning in cases:
        end = time.monotonic() + 3.0
        while not re.search(warning, proc.output()) and time.monotonic() < end:   # until the subscription matched
            msg = JointState(name=names, position=values)
            msg.header.stamp = c.node.get_clock().now().to_msg()
            pub.publish(msg)
            c.spin_for(0.2)
        assert re.search(warning, proc.output()), (warning, proc.output()[-2000:])
    assert time.monotonic() - t0 < 5.0   # all four within one throttle period
    seen = len(re.findall(cases[0][2], proc.output()))
    for _ in range(5):   # the first again, at once and 1 s on: within its 5 s, not logged again
        msg = JointState(name=cases[0][0], position=[2.95])
        msg.header.stamp = c.node.get_clock().now().to_msg()
        pub.publish(msg)
        c.spin_for(0.2)
    assert len(re.findall(r'arm2_wrist = \S+ rad is beyond its upper limit', proc.output())) == seen
    c.node.destroy_publisher(pub)


def test_a_refused_goal_does_not_preempt_the_running_one(sim):
    """As joint_trajectory_controller: a goal is checked before it preempts; one refused leaves the motion as it
    was (it stopped the running goal before)."""
    from action_msgs.msg import GoalStatus

    c, cli, states, _ = sim
    start_value = _held(c, states, 'arm1_elbow')
    target = start_value + 0.5 if start_value + 0.5 < JOINTS.upper[JOINTS.names.index('arm1_elbow')] \
        else start_value - 0.5
    first = c.wait(cli.send_goal_async(_goal(['arm1_elbow'], [1.5], [[target]])), 20, 'goal')
    assert first.accepted
    c.spin_for(0.4)
    result, status = _run(c, cli, _goal(['nope'], [0.5], [[0.0]]))
    assert status == GoalStatus.STATUS_ABORTED and result.error_code == -2, result.error_string
    res = c.wait(first.get_result_async(), 20, 'result')
    assert res.status == GoalStatus.STATUS_SUCCEEDED and 'reached the last point' in res.result.error_string, \
        res.result.error_string
    assert _held(c, states, 'arm1_elbow') == target


def test_a_burst_of_goals_is_answered_every_one(sim):
    """The goal service keeps every request (rclpy's default kept the last 10: 13 of 30 were answered); so does the
    client (its own default queue of 10 lost 2 of 30 on a loaded machine: ``nodes.qos.action_client_options``)."""
    c, cli, _, _ = sim
    futures = [cli.send_goal_async(_goal(['nope'], [0.5], [[0.0]])) for _ in range(30)]
    assert c.spin_until(lambda: all(f.done() for f in futures), 60), sum(f.done() for f in futures)
    results = [c.wait(f.result().get_result_async(), 20, 'result') for f in futures]
    assert all(r.result.error_code == -2 for r in results)


def _rss_mb(pid: int) -> float:
    with open(f'/proc/{pid}/status') as f:
        return next(int(line.split()[1]) for line in f if line.startswith('VmRSS:')) / 1024


@pytest.mark.slow
def test_refused_large_goals_do_not_pile_up_in_memory(sim):
    """rclpy keeps a goal handle, and with it the request, for result_timeout after the goal ends (900 s by
    default): four refused goals of 120,000 points each kept about 60 MB each. The node drops the request once read,
    so the memory of one is reused by the next."""
    c, cli, _, proc = sim
    big = _goal(['nope'], np.arange(1, 120_001) * 1e-3, np.zeros((120_000, 1)))
    rss = []
    for _ in range(4):
        handle = c.wait(cli.send_goal_async(big), 120, 'goal')
        res = c.wait(handle.get_result_async(), 120, 'result')
        assert res.result.error_code == -2, res.result.error_string
        c.spin_for(0.5)
        rss.append(_rss_mb(proc.proc.pid))
    assert rss[-1] - rss[0] < 40, rss


@pytest.fixture(scope='module')
def lagging(ros_environment):
    """A simulator whose joints lag the trajectory (first order, 50 ms)."""
    from control_msgs.action import FollowJointTrajectory
    from gpr_kinematics.nodes.client import GprClient
    from rclpy.action import ActionClient

    proc = start('robot_simulator_node', namespace='/gpr_sim_lag', rate=RATE, servo_time_constant=0.05,
                 goal_time=0.5)
    try:
        wait_for_log(proc, r'serving /gpr_sim_lag/')
        with GprClient('gpr_test_simulator_lag', namespace='/gpr_sim_lag') as c:
            cli = ActionClient(c.node, FollowJointTrajectory, ACTION)
            assert cli.wait_for_server(timeout_sec=20.0), proc.output()
            _feedback_matched(c, '/gpr_sim_lag')
            yield c, cli
    finally:
        proc.stop()


def test_path_and_goal_tolerances(lagging):
    """A lag of tau = 50 ms behind a ramp at v lags by about v tau: 1 rad/s -> 0.05 rad. A path tolerance of 0.01 rad
    aborts the goal (-4) naming the joint; 0.1 rad passes, and the goal tolerance is reached while the joint settles
    within goal_time; a goal tolerance of 1e-9 rad within 0.02 s is not (-5)."""
    from control_msgs.msg import JointTolerance

    c, cli = lagging
    rest = JOINTS.rest[JOINTS.names.index('arm1_shoulder')]

    def goal(target, path, tol, goal_time):
        g = _goal(['arm1_shoulder'], [1.0], [[target]],
                  path_tolerance=[JointTolerance(name='arm1_shoulder', position=path)],
                  goal_tolerance=[JointTolerance(name='arm1_shoulder', position=tol)])
        g.goal_time_tolerance.nanosec = int(goal_time * 1e9)
        return g

    from sensor_msgs.msg import JointState

    states: list = []
    c.node.create_subscription(JointState, '/gpr_sim_lag/joint_states', states.append, 100)
    result, _ = _run(c, cli, goal(rest + 1.0, 0.01, 1e-4, 0.5))
    assert result.error_code == -4, result.error_string
    assert re.search(r'arm1_shoulder: position error 0\.01\d* rad exceeds the path tolerance 0\.01 rad',
                     result.error_string), result.error_string
    n = len(states)   # an aborted goal holds the lagging joints where they are (a succeeded one's converge on)
    c.spin_for(0.6)
    k = list(states[-1].name).index('arm1_shoulder')
    held = [m for m in states[n:] if not any(m.velocity)]
    assert len(held) >= 3 and len({m.position[k] for m in held[1:]}) == 1, [m.position[k] for m in states[n:]]
    result, _ = _run(c, cli, goal(rest, 0.1, 1e-4, 0.5))      # back (from where the aborted goal stopped)
    assert result.error_code == 0, result.error_string
    # the samples published while the joints settled are told apart from the trajectory's (it said '(101 samples)'
    # of a goal that published 244)
    m = re.fullmatch(r'reached the last point at t = ([\d.]+) s \((\d+) samples, then (\d+) as the joints settled\)',
                     result.error_string)
    assert m and int(m[2]) == round(RATE) + 1 and int(m[3]) == round((float(m[1]) - 1.0) * RATE) > 0, \
        result.error_string
    result, _ = _run(c, cli, goal(rest + 1.0, 0.1, 1e-9, 0.02))
    assert result.error_code == -5 and 'exceeds the goal tolerance 1e-09 rad' in result.error_string
    assert math.isfinite(rest)




def test_a_settling_goal_is_named_by_its_time_after_the_last_point(lagging):
    """With a lag, samples go on after the last point while the joints settle: a goal preempted then was 'preempted
    by a newer goal after 58 of its 51 samples', and a goal tolerance missed was told at its goal_time_tolerance
    with the error of one sample later. Both name the time after the last point now."""
    from action_msgs.msg import GoalStatus
    from control_msgs.msg import JointTolerance
    from sensor_msgs.msg import JointState

    c, cli = lagging
    states: list = []
    c.node.create_subscription(JointState, '/gpr_sim_lag/joint_states', states.append, 100)
    assert c.spin_until(lambda: len(states) >= 3, 10)
    c.spin_for(0.6)   # where earlier tests left it, settled
    here = states[-1].position[list(states[-1].name).index('arm1_shoulder')]
    there = here - 0.3 if here > JOINTS.rest[JOINTS.names.index('arm1_shoulder')] else here + 0.3

    def goal(target, tol, goal_time):
        g = _goal(['arm1_shoulder'], [0.3], [[target]], path_tolerance=[JointTolerance(name='arm1_shoulder',
                                                                                       position=-1.0)],
                  goal_tolerance=[JointTolerance(name='arm1_shoulder', position=tol)])
        g.goal_time_tolerance.nanosec = int(goal_time * 1e9)
        return g

    result, _ = _run(c, cli, goal(there, 1e-9, 0.05))
    assert result.error_code == -5, result.error_string
    after = float(result.error_string.split(' s after', 1)[0])
    assert re.match(r'^\S+ s after the last point \(goal_time_tolerance 0\.05 s\): arm1_shoulder: position error',
                    result.error_string) and 0.05 < after < 0.05 + 0.05, result.error_string
    first = c.wait(cli.send_goal_async(goal(here, 1e-9, 0.6)), 20, 'goal')
    c.spin_for(0.55)   # its last point at 0.3 s, settling until 0.9 s: preempted in between
    result, status = _run(c, cli, goal(here, 0.1, 0.6))
    assert status == GoalStatus.STATUS_SUCCEEDED, result.error_string
    res = c.wait(first.get_result_async(), 20, 'result')
    assert re.match(r'^preempted by a newer goal (\S+) s after its last point$', res.result.error_string), \
        res.result.error_string


def test_lagging_joints_converge_to_the_last_point_after_the_goal(lagging):
    """With a lag and the goal tolerance not checked (-1) the goal succeeds at its last point's time with the joint
    about v tau short; the joints froze there (0.071 rad short with tau 0.1 s), where joint_trajectory_controller
    keeps commanding the last point: they converge to it while idle, their velocity published, and hold it exactly."""
    from control_msgs.msg import JointTolerance
    from sensor_msgs.msg import JointState

    c, cli = lagging
    states: list = []
    c.node.create_subscription(JointState, '/gpr_sim_lag/joint_states', states.append, 100)
    c.spin_for(0.5)
    at = states[-1].position[list(states[-1].name).index('arm1_shoulder')]
    target = at + 0.5 if at < 0.0 else at - 0.5
    goal = _goal(['arm1_shoulder'], [0.5], [[target]],
                 goal_tolerance=[JointTolerance(name='arm1_shoulder', position=-1.0, velocity=-1.0)])
    result, _ = _run(c, cli, goal)
    assert result.error_code == 0, result.error_string
    k = list(states[-1].name).index('arm1_shoulder')
    ended = next(i for i in range(len(states) - 1, -1, -1) if round(states[i].header.stamp.sec + 1e-9 *
                                                                      states[i].header.stamp.nanosec, 6) > 0 and
                 abs(states[i].position[k] - target) > 0.01)   # the goal's end: about v tau = 0.05 rad short
    assert c.spin_until(lambda: states[-1].position[k] == target and states[-1].velocity[k] == 0.0, 10.0), \
        [m.position[k] for m in states[-5:]]
    idle = [m for m in states[ended + 1:] if m.position[k] != target]
    assert idle and all(abs(m.velocity[k]) > 0.0 for m in idle), [m.position[k] for m in states[ended:]]
    assert any(0.0 < abs(m.position[k] - target) < 1e-6 for m in idle)   # on to within 1e-12, not snapped sooner


def test_malformed_joint_states_are_ignored_with_a_warning(sim):
    """A JointState of two names and one position moved the first joint (its value misaligned or not), one naming a
    joint twice took the last value: each is ignored with a warning naming why."""
    from sensor_msgs.msg import JointState

    c, _, states, proc = sim
    pub = c.node.create_publisher(JointState, 'joint_states', 10)
    before = _held(c, states, 'arm1_elbow')
    for names, values, warning in (
            (['arm1_elbow', 'arm1_shoulder'], [before + 0.1], r'joint_states of another publisher ignored: 2 names and '
                                                              r'1 positions; allowed: one position per name, or none'),
            (['arm1_elbow', 'arm1_elbow'], [before + 0.1, before + 0.1],
             r"joint_states of another publisher ignored: joint 'arm1_elbow' named twice; allowed: each joint once")):
        seen = len(re.findall(warning, proc.output()))
        end = time.monotonic() + 30.0
        # a new publisher's first messages may go before the simulator's subscription has matched it: sent again
        # until the warning is logged
        while len(re.findall(warning, proc.output())) == seen and time.monotonic() < end:
            msg = JointState(name=names, position=values)
            msg.header.stamp = c.node.get_clock().now().to_msg()
            pub.publish(msg)
            c.spin_for(0.3)
        assert len(re.findall(warning, proc.output())) > seen, proc.output()
        assert _held(c, states, 'arm1_elbow') == before
    c.node.destroy_publisher(pub)


def test_a_goal_whose_cancel_came_first_ends_cancelled_when_a_newer_goal_preempts_it(ros_environment):
    """A cancel accepted, then a newer goal before the next sample (a simulator at 1 Hz: its first sample 1 s after
    the goal): the cancelled goal ended ABORTED, 'preempted by a newer goal', its client's accepted cancel ignored. It
    ends CANCELED (SUCCESSFUL, the joints held), and the newer goal runs."""
    from action_msgs.msg import GoalStatus
    from control_msgs.action import FollowJointTrajectory
    from gpr_kinematics.nodes.client import GprClient
    from rclpy.action import ActionClient

    proc = start('robot_simulator_node', namespace='/gpr_sim_slow', rate=1.0)
    try:
        wait_for_log(proc, r'serving /gpr_sim_slow/')
        with GprClient('gpr_test_simulator_slow', namespace='/gpr_sim_slow') as c:
            cli = ActionClient(c.node, FollowJointTrajectory, ACTION)
            assert cli.wait_for_server(timeout_sec=20.0), proc.output()
            rest = JOINTS.rest[JOINTS.names.index('arm1_shoulder')]
            first = c.wait(cli.send_goal_async(_goal(['arm1_shoulder'], [10.0], [[rest + 0.2]])), 20, 'goal')
            assert first.accepted
            c.wait(first.cancel_goal_async(), 10, 'cancel')
            second = c.wait(cli.send_goal_async(_goal(['arm1_shoulder'], [2.0], [[rest + 0.05]])), 20, 'goal')
            res = c.wait(first.get_result_async(), 20, 'result')
            assert res.status == GoalStatus.STATUS_CANCELED, res.result.error_string
            assert res.result.error_code == 0   # before its first sample (or, on a loaded machine, at it)
            assert re.match(r'cancelled (before its start; nothing moved|at t = 0 s of 10 s)', res.result.error_string)
            res = c.wait(second.get_result_async(), 20, 'result')
            assert res.status == GoalStatus.STATUS_SUCCEEDED, res.result.error_string
    finally:
        proc.stop()


def test_a_best_effort_joint_states_publisher_is_heard_with_the_parameter(ros_environment):
    """With joint_states_reliability:=best_effort the idle simulator takes a best-effort publisher's joint values
    (as robot_state_publisher's SensorDataQoS hears them) and still publishes its own reliable state."""
    from gpr_kinematics.nodes.client import GprClient
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import JointState

    proc = start('robot_simulator_node', namespace='/gpr_sim_be', joint_states_reliability='best_effort')
    try:
        wait_for_log(proc, r'serving /gpr_sim_be/')
        with GprClient('gpr_test_sim_be', namespace='/gpr_sim_be') as c:
            states = c.subscribe(JointState, 'joint_states')
            pub = c.node.create_publisher(JointState, 'joint_states', qos_profile_sensor_data)

            def hand() -> float | None:
                return states[-1].position[list(states[-1].name).index('arm2_hand')] if states else None

            assert c.spin_until(lambda: pub.get_subscription_count() > 0 and states, 20), proc.output()
            for _ in range(3):      # best effort: sent a few times; the simulator is quiet while they arrive
                msg = JointState(name=['arm2_hand'], position=[0.75])
                msg.header.stamp = c.node.get_clock().now().to_msg()
                pub.publish(msg)
                c.spin_for(0.05)
            assert c.spin_until(lambda: hand() == 0.75, 10), proc.output()
        assert proc.alive() and 'Traceback' not in proc.output()
    finally:
        proc.stop()


def test_a_preempted_goal_ends_canceled_as_in_joint_trajectory_controller(sim):
    """A newer valid goal ended the running one ABORTED, where docs and joint_trajectory_controller (its
    preempt_active_goal: setCanceled, INVALID_GOAL) say canceled: it ends CANCELED, INVALID_GOAL, saying how many of
    its samples were sent; the newer goal runs to its end."""
    from action_msgs.msg import GoalStatus

    c, cli, states, _ = sim
    here = _held(c, states, 'arm1_wrist')
    step = 0.3 if here + 0.3 < JOINTS.upper[JOINTS.names.index('arm1_wrist')] else -0.3
    first = c.wait(cli.send_goal_async(_goal(['arm1_wrist'], [3.0], [[here + step]])), 20, 'goal')
    assert first.accepted
    c.spin_for(0.5)
    result, status = _run(c, cli, _goal(['arm1_wrist'], [0.5], [[here]]))
    assert status == GoalStatus.STATUS_SUCCEEDED, result.error_string
    res = c.wait(first.get_result_async(), 20, 'result')
    assert res.status == GoalStatus.STATUS_CANCELED and res.result.error_code == -1, res.result.error_string
    assert re.match(r'preempted by a newer goal after \d+ of its \d+ samples$', res.result.error_string)
    assert _held(c, states, 'arm1_wrist') == here


@pytest.mark.parametrize('sig', ['SIGTERM', 'SIGINT'])
def test_a_goal_running_when_the_simulator_stops_gets_its_result(ros_environment, sig):
    """Stopped with a goal running, the simulator logged the goal aborted but destroyed its action server before rclpy
    sent the result: the client waited for ever. Its client now gets ABORTED, 'the controller is shutting down'."""
    import signal

    from action_msgs.msg import GoalStatus
    from control_msgs.action import FollowJointTrajectory
    from gpr_kinematics.nodes.client import GprClient
    from rclpy.action import ActionClient

    ns = f'/gpr_sim_stop_{sig.lower()}'
    proc = start('robot_simulator_node', namespace=ns)
    try:
        wait_for_log(proc, rf'serving {ns}/')
        with GprClient(f'gpr_test_sim_stop_{sig.lower()}', namespace=ns) as c:
            cli = ActionClient(c.node, FollowJointTrajectory, ACTION)
            assert cli.wait_for_server(timeout_sec=20.0), proc.output()
            rest = JOINTS.rest[JOINTS.names.index('arm1_shoulder')]
            handle = c.wait(cli.send_goal_async(_goal(['arm1_shoulder'], [10.0], [[rest + 0.2]])), 20, 'goal')
            assert handle.accepted
            result = handle.get_result_async()
            c.spin_for(0.5)   # the result request reaches the server
            proc.proc.send_signal(getattr(signal, sig))
            res = c.wait(result, 20, 'result')
            assert res.status == GoalStatus.STATUS_ABORTED and res.result.error_code == -1
            assert res.result.error_string == 'the controller is shutting down'
        assert proc.wait(timeout=20) == 0, proc.output()
        assert 'Traceback' not in proc.output() and 'never retrieved' not in proc.output()
    finally:
        proc.stop()


@pytest.mark.slow
def test_under_a_stepped_simulated_clock_a_stream_silences_the_simulator_and_a_clock_set_back_too(ros_environment):
    """use_sim_time with /clock in 0.1 s steps (a simulator at 10 Hz) and another node streaming rods at 100 Hz, every
    sample of a step stamped within it: the simulator dropped every sample not newer than its own held state (stamped
    at the step, so later than each of them), never took one, and published its rest state among them (/tf flickered
    between the rest and the stream). And after the clock was set back (a simulation reset) it took none again. Now
    it tells its own messages by stamp and values, and measures its quiet on the node's clock."""
    from builtin_interfaces.msg import Time
    from gpr_kinematics.nodes.client import GprClient
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    ns = '/gpr_sim_stepclock'
    proc = start('robot_simulator_node', namespace=ns, rate=RATE, idle_rate=10.0, use_sim_time=True)
    try:
        wait_for_log(proc, 'serving ')
        with GprClient('gpr_test_sim_stepclock', namespace=ns) as c:
            states = c.subscribe(JointState, 'joint_states')
            clock = c.node.create_publisher(Clock, '/clock', 10)
            pub = c.node.create_publisher(JointState, 'joint_states', 100)
            now = {'ns': 1000 * NS_PER_S, 'value': 0.30, 'stream': True}

            def step() -> None:   # the clock, then the stream's ten samples of the step just gone, stamped in it
                now['ns'] += 100_000_000
                clock.publish(Clock(clock=Time(sec=now['ns'] // NS_PER_S, nanosec=now['ns'] % NS_PER_S)))
                for k in range(10 if now['stream'] else 0):
                    now['value'] += 1e-5
                    msg = JointState(name=['rod_1', 'rod_2', 'rod_3'], position=[now['value']] * 3)
                    t = now['ns'] - 100_000_000 + (k + 1) * 10_000_000
                    msg.header.stamp = Time(sec=t // NS_PER_S, nanosec=t % NS_PER_S)
                    pub.publish(msg)

            def theirs(m) -> bool:
                return tuple(m.name) == ('rod_1', 'rod_2', 'rod_3')

            def own_after(n: int) -> list:
                return [(_stamp(m), m.position[0]) for m in states[n:] if not theirs(m)]

            c.node.create_timer(0.1, step)
            assert c.spin_until(lambda: sum(theirs(m) for m in states) >= 100, 30), proc.output()
            n = len(states)
            c.spin_for(2.0)
            assert own_after(n) == []   # silent while the stream goes on
            now['ns'] = 10 * NS_PER_S   # a simulation reset: the clock set back
            c.spin_for(1.0)
            n = len(states)
            c.spin_for(2.0)
            assert own_after(n) == []   # and after it
            now['stream'] = False       # the stream ends: the simulator holds its last sample
            last = now['value']
            assert c.spin_until(lambda: len(own_after(n)) >= 3, 20), proc.output()
            assert all(v == last for _, v in own_after(n)[1:]), own_after(n)
    finally:
        proc.stop()


def test_a_clock_set_back_during_a_goal_aborts_it_naming_the_jump_and_the_node_serves_on(ros_environment):
    """use_sim_time, /clock from 1000 s in 10 ms steps, set back to 10 s one second into a 4 s goal (a simulation reset,
    ``ros2 bag play --loop --clock``): the goal waited, silent, until the clock came back to 1001 s. Now it ends
    aborted, naming the jump, and the next goal runs on the new clock."""
    import threading

    from builtin_interfaces.msg import Time
    from control_msgs.action import FollowJointTrajectory
    from gpr_kinematics.nodes.client import GprClient
    from gpr_kinematics.nodes.qos import action_client_options
    from rclpy.action import ActionClient
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    ns = '/gpr_sim_clockback'
    proc = start('robot_simulator_node', namespace=ns, rate=RATE, idle_rate=10.0, use_sim_time=True)
    now = {'ns': 1000 * NS_PER_S}
    stop = threading.Event()
    try:
        wait_for_log(proc, 'serving ')
        with GprClient('gpr_test_sim_clockback', namespace=ns) as c:
            clock = c.node.create_publisher(Clock, '/clock', 10)

            def ticks() -> None:
                while not stop.is_set():
                    now['ns'] += 10_000_000
                    t = now['ns']
                    clock.publish(Clock(clock=Time(sec=t // NS_PER_S, nanosec=t % NS_PER_S)))
                    time.sleep(0.01)

            ticker = threading.Thread(target=ticks, daemon=True)
            ticker.start()
            states = c.subscribe(JointState, 'joint_states')
            cli = ActionClient(c.node, FollowJointTrajectory, ACTION, **action_client_options(1000))
            assert cli.wait_for_server(timeout_sec=20.0), proc.output()
            assert c.spin_until(lambda: len(states) >= 2, 10), proc.output()
            k = JOINTS.names.index('arm1_elbow')
            rest = float(JOINTS.rest[k])
            handle = c.wait(cli.send_goal_async(_goal(['arm1_elbow'], [4.0], [[rest + 0.4]])), 20, 'goal')
            assert handle.accepted
            c.spin_for(1.0)
            now['ns'] = 10 * NS_PER_S
            res = c.wait(handle.get_result_async(), 10, 'result after the clock was set back')
            from action_msgs.msg import GoalStatus
            assert res.status == GoalStatus.STATUS_ABORTED
            assert res.result.error_code == -1
            assert re.fullmatch(r'the clock was set back \d+\.?\d* s \(from 10\d\d\.?\d* s to 1\d\.?\d* s\) at '
                                r't = \d\.?\d* s of the goal: its samples are stamped on that clock; allowed: a clock '
                                r'that does not go back while a goal runs \(send the goal again\)',
                                res.result.error_string), res.result.error_string
            back = float(res.result.error_string.split()[5])
            assert 985.0 < back < 995.0, res.result.error_string
            result, status = _run(c, cli, _goal(['arm1_elbow'], [0.5], [[rest + 0.3]]))
            assert (status, result.error_code) == (GoalStatus.STATUS_SUCCEEDED, 0), result.error_string
            stop.set()
            ticker.join(timeout=5.0)   # before the client's node (its /clock publisher) is destroyed
    finally:
        stop.set()
        proc.stop()


def test_a_first_point_at_time_zero_beyond_one_sample_at_the_velocity_limit_is_refused(ros_environment):
    """start_tolerance 1 (within its range): a first point at t = 0 1 rad away was jumped to in one 10 ms sample
    (100 rad/s against 1.5 rad/s) and reported SUCCEEDED. Now INVALID_GOAL naming the jump; nothing moves."""
    from action_msgs.msg import GoalStatus
    from control_msgs.action import FollowJointTrajectory
    from gpr_kinematics.nodes.client import GprClient
    from gpr_kinematics.nodes.qos import action_client_options
    from rclpy.action import ActionClient
    from sensor_msgs.msg import JointState

    ns = '/gpr_sim_jump'
    proc = start('robot_simulator_node', namespace=ns, rate=RATE, idle_rate=20.0, start_tolerance=1.0)
    try:
        wait_for_log(proc, 'serving ')
        with GprClient('gpr_test_sim_jump', namespace=ns) as c:
            states = c.subscribe(JointState, 'joint_states')
            cli = ActionClient(c.node, FollowJointTrajectory, ACTION, **action_client_options(1000))
            assert cli.wait_for_server(timeout_sec=20.0), proc.output()
            assert c.spin_until(lambda: len(states) >= 2, 10), proc.output()
            result, status = _run(c, cli, _goal(['arm1_shoulder'], [0.0, 1.0], [[1.0], [1.2]]))
            assert (status, result.error_code) == (GoalStatus.STATUS_ABORTED, -1)
            assert result.error_string == (
                'points[0] at time_from_start 0 makes arm1_shoulder jump 1 rad from where it is (0 rad) in one sample '
                '(0.01 s at rate 100 Hz): 100 rad/s; allowed: at most 0.015 rad (its velocity limit 1.5 rad/s for '
                'one sample), or a first point after 0 s, which the joints then reach from where they are')
            assert _held(c, states, 'arm1_shoulder') == 0.0
    finally:
        proc.stop()


def test_lagging_joints_a_next_goal_leaves_out_go_on_to_their_point(lagging):
    """A reviewer's case with the real CLI: a goal on arm1_shoulder succeeds with the joint lagging, the next goal
    names arm1_elbow only; the shoulder froze 0.262 rad short of its point for good (the new goal held it where it
    was). The joints a goal leaves out are commanded where the last goal left them, as joint_trajectory_controller
    keeps them: the shoulder reaches its point, exactly, and so does the elbow."""
    from control_msgs.msg import JointTolerance
    from sensor_msgs.msg import JointState

    c, cli = lagging
    states: list = []
    c.node.create_subscription(JointState, '/gpr_sim_lag/joint_states', states.append, 100)
    c.spin_for(0.5)
    names = list(states[-1].name)
    s, e = names.index('arm1_shoulder'), names.index('arm1_elbow')
    shoulder, elbow = states[-1].position[s], states[-1].position[e]
    targets = (shoulder + 0.4 if shoulder < 0.0 else shoulder - 0.4, elbow + 0.3 if elbow < 0.0 else elbow - 0.3)
    free = [JointTolerance(name=n, position=-1.0, velocity=-1.0) for n in ('arm1_shoulder', 'arm1_elbow')]
    for joint, target in zip(('arm1_shoulder', 'arm1_elbow'), targets, strict=True):
        result, _ = _run(c, cli, _goal([joint], [0.3], [[target]], goal_tolerance=free[:1] if joint == 'arm1_shoulder'
                                       else free[1:]))
        assert result.error_code == 0, result.error_string
    assert c.spin_until(lambda: states[-1].position[s] == targets[0] and states[-1].position[e] == targets[1], 10.0), \
        (states[-1].position[s] - targets[0], states[-1].position[e] - targets[1])


@pytest.mark.parametrize('name, position, taken', [
    (['arm1_elbow'], [0.1], True),   # a state it takes: the robot is where that publisher says, and stays there
    (['arm1_elbow'], [100.0], False),   # beyond the limit: ignored
    (['arm1_elbow', 'arm1_wrist'], [0.1], False),   # malformed: ignored
    (['gripper_finger'], [0.1], False),   # none of its joints: nothing taken
])
def test_another_publishers_state_ends_the_lagging_joints_command_only_when_taken(ros_environment, name, position,
                                                                                   taken):
    """Without a cell file a state of another publisher becomes the robot's state (docs/ros.md, Idle): the lagging
    joints' command goes with it, else the idle ticks dragged them on toward the last goal's point, away from the
    state taken; a message it ignores or takes nothing from leaves the command, the joints converging on to it. The
    node's methods on a stub (no DDS): a foreign message, then 5 s of idle ticks at 10 Hz (``tau`` 0.05 s)."""
    import types

    import gpr_kinematics.nodes.robot_simulator_node as sim

    clock = types.SimpleNamespace(nanoseconds=0)
    joints = ControllerJoints.of(ROBOT)
    s, e = joints.names.index('arm1_shoulder'), joints.names.index('arm1_elbow')
    command = joints.rest.copy()
    command[s] += 0.3   # where the last goal left arm1_shoulder, lagging at rest
    node = types.SimpleNamespace(run=None, own={}, joints=joints, actual=joints.rest.copy(), command=command.copy(),
                                 velocity=np.zeros(len(joints.names)), pending=None, last_check=None, cfg=ROBOT.config,
                                 last_foreign=None, last_published=0, refusing=False, clearance=None,
                                 p={'idle_rate': 10.0, 'servo_time_constant': 0.05},
                                 get_clock=lambda: types.SimpleNamespace(now=lambda: clock),
                                 refusals=types.SimpleNamespace(warn=lambda text: True))
    node.publish_state = lambda ns: setattr(node, 'last_published', clock.nanoseconds)
    for method in ('_outside', '_settle', '_converge'):
        setattr(node, method, types.MethodType(getattr(sim.RobotSimulatorNode, method), node))
    on_states = types.MethodType(sim.RobotSimulatorNode._on_joint_states, node)
    idle = types.MethodType(sim.RobotSimulatorNode._idle, node)
    clock.nanoseconds = 50_000_000
    on_states(types.SimpleNamespace(header=types.SimpleNamespace(stamp=types.SimpleNamespace(sec=0, nanosec=1)),
                                    name=name, position=position))
    for k in range(1, 51):
        clock.nanoseconds = k * 100_000_000
        idle()
    if taken:
        assert node.command is None and node.actual[s] == joints.rest[s] and node.actual[e] == 0.1, node.actual[s]
    else:
        assert node.command is None and node.actual[s] == command[s] and node.actual[e] == joints.rest[e], \
            node.actual[s] - command[s]   # converged, then snapped to it exactly


def test_a_goal_waiting_for_its_stamp_moves_the_lagging_joints_as_its_check_did(ros_environment):
    """The node's methods on a stub (no DDS): arm1's shoulder lagging at rest, commanded 0.3 rad on by the last goal,
    a goal on the elbow accepted with a stamp 2 s ahead (``tau`` 0.5 s). Its idle ticks at 10 Hz took the shoulder
    nowhere (the command dropped at the acceptance) and, the goal cancelled before its start, it stayed 0.3 rad short
    for good. Now the waiting joints move on the line the goal's check followed (:meth:`Lag.waited`: equal to it at
    every tick, never past the motion's first sample), and once the goal is cancelled the last command stands: the
    shoulder converges to it exactly."""
    import types

    import gpr_kinematics.nodes.robot_simulator_node as sim
    from gpr_kinematics.robot.controller import Tolerances
    from gpr_kinematics.robot.goal import Controller, Goal, plan_goal

    ns = 1_000_000_000
    clock = types.SimpleNamespace(nanoseconds=10 * ns)
    s, e = JOINTS.names.index('arm1_shoulder'), JOINTS.names.index('arm1_elbow')
    command = JOINTS.rest.copy()
    command[s] += 0.3
    controller = Controller(JOINTS, Tolerances.uniform(len(JOINTS.names), 0.0, 1e-3, 0.5), 100.0, ROBOT.config, 1e-3,
                            False, None, 0.5)
    goal = Goal(['arm1_elbow'], [1.0], [[JOINTS.rest[e] - 0.1]], [[]], [[]], False, False, False, [], [], 0.0,
                12 * ns)
    motion, start = plan_goal(goal, controller, JOINTS.rest, clock.nanoseconds, command)
    done: list = []
    run = types.SimpleNamespace(motion=motion, start_ns=start, started=None, k=0, goal=None,
                                done=types.SimpleNamespace(set_result=done.append))
    node = types.SimpleNamespace(run=run, own={}, joints=JOINTS, actual=JOINTS.rest.copy(), command=command.copy(),
                                 velocity=np.zeros(len(JOINTS.names)), pending=None, last_check=None, cfg=ROBOT.config,
                                 last_foreign=None, last_published=clock.nanoseconds, refusing=False, clearance=None,
                                 p={'idle_rate': 10.0, 'servo_time_constant': 0.5},
                                 motion_timer=types.SimpleNamespace(cancel=lambda: None),
                                 get_clock=lambda: types.SimpleNamespace(now=lambda: clock),
                                 get_logger=lambda: types.SimpleNamespace(warning=lambda *a, **k: None,
                                                                          info=lambda *a, **k: None))
    node.publish_state = lambda stamp: setattr(node, 'last_published', clock.nanoseconds)
    for method in ('_settle', '_converge', '_end', '_cancelled'):
        setattr(node, method, types.MethodType(getattr(sim.RobotSimulatorNode, method), node))
    idle = types.MethodType(sim.RobotSimulatorNode._idle, node)
    for k in range(1, 20):   # 1.9 s of the 2 s wait
        clock.nanoseconds = 10 * ns + k * ns // 10
        idle()
        np.testing.assert_allclose(node.actual, motion.lag.waited(k / 10), rtol=0, atol=1e-15)
    assert 0.0 < command[s] - node.actual[s] < 0.3 * math.exp(-3.8) * 1.001
    assert abs(command[s] - node.actual[s]) > abs(command[s] - motion.current[s])   # short of the first sample
    started = types.SimpleNamespace(**vars(run))   # the same goal had it started: the run commands the joints
    started.goal = types.SimpleNamespace(is_cancel_requested=False, publish_feedback=lambda fb: None)
    started.clock_ns, started.done = clock.nanoseconds, types.SimpleNamespace(set_result=lambda r: None)
    twin = types.SimpleNamespace(**(vars(node) | {'period': 0.01, 'catch_up': lambda: 1, 'command': command.copy(),
                                                  'pace_clock': lambda: clock.nanoseconds / ns, 'run': started}))
    for method in ('_step', '_feedback', '_end', '_tick'):
        setattr(twin, method, types.MethodType(getattr(sim.RobotSimulatorNode, method), twin))
    clock.nanoseconds = start
    twin._tick()
    assert twin.command is None and started.started is not None and np.array_equal(twin.actual, motion.lag.samples[0])
    node._cancelled(run)
    assert done[0][0] == 'canceled' and np.array_equal(node.command, command)
    assert done[0][2] == "cancelled before its start; lagging joints go on to the last goal's end"   # not 'nothing
    # moved' (a reviewer's)
    node.run = None
    for k in range(20, 250):
        clock.nanoseconds = 10 * ns + k * ns // 10
        idle()
    assert node.command is None and np.array_equal(node.actual, command)


@pytest.mark.slow
def test_a_second_server_of_the_action_is_warned_of_and_its_end_said() -> None:
    """Two simulators in one namespace both ran every goal (a goal reaches every server of an action) without a word:
    each now warns once of the other, a simulator in another namespace does not, and the first says when the second
    is gone (nodes/foreign_states.OtherServers)."""
    twin = '/gpr_twin'
    a = start('robot_simulator_node', '-r', '__node:=sim_a', namespace=twin)
    b = start('robot_simulator_node', '-r', '__node:=sim_b', namespace=twin)
    c = start('robot_simulator_node', '-r', '__node:=sim_c', namespace='/gpr_single')
    action = re.escape(f'{twin}/{ACTION}')
    try:
        for p in (a, b):
            wait_for_log(p, rf'1 other server\(s\) of {action} on the ROS graph: a goal sent there runs on each '
                            r'\(another robot_simulator_node or controller in this namespace\?\); allowed: one server '
                            r'per action')
        wait_for_log(c, rf'serving /gpr_single/{ACTION}')
        time.sleep(2.5)   # c counted its action's servers since a and b were found
        assert b.stop() == 0, b.output()
        wait_for_log(a, rf'no other server of {action} is left')
    finally:
        for p in (a, b, c):
            p.stop()
    assert a.output().count('other server(s)') == 1, a.output()
    assert 'other server' not in c.output(), c.output()


def test_a_cancel_ends_the_goal_while_the_simulated_clock_is_missing_or_paused(ros_environment):
    """A ROS trial: under use_sim_time with no /clock (or one paused mid-goal) a cancel was accepted and its result
    never came (the motion's timer runs on the ROS clock), until the clock moved or another goal came; now it ends at
    once, CANCELED, and the wait for simulated time is logged, as trajectory_node does."""
    import threading

    from action_msgs.msg import GoalStatus
    from builtin_interfaces.msg import Time
    from control_msgs.action import FollowJointTrajectory
    from gpr_kinematics.nodes.client import GprClient
    from gpr_kinematics.nodes.qos import action_client_options
    from rclpy.action import ActionClient
    from rosgraph_msgs.msg import Clock

    ns = '/gpr_sim_noclock'
    proc = start('robot_simulator_node', namespace=ns, rate=RATE, idle_rate=10.0, use_sim_time=True)
    now, ticking, stop = {'ns': 0}, threading.Event(), threading.Event()
    try:
        wait_for_log(proc, 'serving ')
        with GprClient('gpr_test_sim_noclock', namespace=ns) as c:
            cli = ActionClient(c.node, FollowJointTrajectory, ACTION, **action_client_options(1000))
            assert cli.wait_for_server(timeout_sec=20.0), proc.output()
            rest = float(JOINTS.rest[JOINTS.names.index('arm1_elbow')])
            handle = c.wait(cli.send_goal_async(_goal(['arm1_elbow'], [2.0], [[rest + 0.2]])), 20, 'goal')
            assert handle.accepted
            wait_for_log(proc, r'no /clock has arrived in 3 s: use_sim_time is true and the goal \(at sample 0 of '
                               r'\d+\) waits for simulated time')
            c.wait(handle.cancel_goal_async(), 10, 'cancel')
            res = c.wait(handle.get_result_async(), 5, 'result of the cancel without /clock')
            assert (res.status, res.result.error_code) == (GoalStatus.STATUS_CANCELED, 0), res.result.error_string
            assert res.result.error_string.startswith('cancelled before its start'), res.result.error_string
            clock = c.node.create_publisher(Clock, '/clock', 10)

            def ticks() -> None:   # 10 ms steps while ticking, then a clock that stands still
                now['ns'] = 100 * NS_PER_S
                while not stop.is_set():
                    if ticking.is_set():
                        now['ns'] += 10_000_000
                    t = now['ns']
                    clock.publish(Clock(clock=Time(sec=t // NS_PER_S, nanosec=t % NS_PER_S)))
                    time.sleep(0.01)

            ticking.set()
            ticker = threading.Thread(target=ticks, daemon=True)
            ticker.start()
            handle = c.wait(cli.send_goal_async(_goal(['arm1_elbow'], [2.0], [[rest + 0.2]])), 20, 'goal')
            assert handle.accepted
            c.spin_for(0.5)
            ticking.clear()   # paused mid-goal
            c.spin_for(0.3)
            c.wait(handle.cancel_goal_async(), 10, 'cancel')
            res = c.wait(handle.get_result_async(), 5, 'result of the cancel with /clock paused')
            assert (res.status, res.result.error_code) == (GoalStatus.STATUS_CANCELED, 0), res.result.error_string
            assert re.match(r'cancelled at t = 0\.\d+ s of 2 s; the joints hold where they are',
                            res.result.error_string), res.result.error_string
            stop.set()
            ticker.join(timeout=5.0)
    finally:
        stop.set()
        proc.stop()

"""`gpr program send` over real DDS: the example robot program runs on robot_simulator_node from where the robot is
(the lead-in from its rest state), exit 0, and the joint states the simulator published equal `gpr program export`'s
samples at every point of the trajectory (1e-9); without a server it exits 1 with one line."""
from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.controller import ControllerJoints
from gpr_kinematics.robot.export import sample_table
from gpr_kinematics.robot.plan import plan_program, sample_plan
from gpr_kinematics.robot.program import load_program
from robot_support import ROBOT
from ros_support import start, wait_for_log

pytestmark = pytest.mark.ros

PROGRAM = str(config_path('programs/example_robot_program.yaml'))
NS = '/gpr_send'
RATE = 10.0          # points per second of the goal
SIM_RATE = 100.0     # the simulator's samples
NS_PER_S = 1_000_000_000


def _send(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, '-m', 'gpr_kinematics.cli.main', 'program', 'send', *args],
                          capture_output=True, text=True, timeout=timeout, env=dict(os.environ))


@pytest.fixture(scope='module')
def sent(ros_environment):
    """The example program sent to a simulator in NS; the command's result and every joint_states message."""
    from gpr_kinematics.nodes.client import GprClient
    from sensor_msgs.msg import JointState

    sim = start('robot_simulator_node', namespace=NS, rate=SIM_RATE, idle_rate=20.0)
    try:
        wait_for_log(sim, r'serving /gpr_send/')
        with GprClient('gpr_test_program_send', namespace=NS) as c:
            states = c.subscribe(JointState, 'joint_states')
            assert c.spin_until(lambda: len(states) >= 2, 20), sim.output()
            proc = subprocess.Popen([sys.executable, '-m', 'gpr_kinematics.cli.main', 'program', 'send', PROGRAM,
                                     '--namespace', NS, '--rate', str(RATE), '--json'],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ))
            assert c.spin_until(lambda: proc.poll() is not None, 180), sim.output()
            out, err = proc.communicate()
            c.spin_for(0.5)
            yield proc.returncode, out, err, states, sim
    finally:
        sim.stop()


@pytest.mark.slow
def test_the_example_program_runs_on_the_simulator(sent):
    status, out, err, _, sim = sent
    assert status == 0, out + err + sim.output()
    result = json.loads(out)
    assert (result['status'], result['error_code'], result['error_name']) == ('succeeded', 0, 'SUCCESSFUL')
    assert result['lead_in'] > 0 and result['action'] == f'{NS}/joint_trajectory_controller/follow_joint_trajectory'
    assert result['joint_names'] == list(ControllerJoints.of(ROBOT).names)
    # Feedback, one per sample (the client waits for the feedback topic's match before it sends the goal).
    assert result['feedback'] == math.floor(result['duration'] * SIM_RATE + 1e-9) + 1 + \
        (result['duration'] * SIM_RATE % 1 > 1e-6)


@pytest.mark.slow
def test_recorded_joint_states_equal_the_export_samples_at_every_point(sent):
    """The goal's joint_states (stamped start + k / rate) at the program's points equal the rows of `gpr program
    export --samples --rate 10` (the rods named rod_1..rod_3 there as rod_1..3 by the description)."""
    status, out, _, states, _ = sent
    assert status == 0
    result = json.loads(out)
    plan = plan_program(ROBOT, load_program(PROGRAM))
    _, rows = sample_table(plan, sample_plan(plan, RATE))
    J = len(plan.joint_names)
    times = np.array([r[0] for r in rows])
    expected = np.array([r[3:3 + J] for r in rows], dtype=float)
    stamps = np.array([m.header.stamp.sec * NS_PER_S + m.header.stamp.nanosec for m in states])
    # The goal's messages: 10 ms apart from its start on; the first of that run is t = 0.
    step = np.flatnonzero(np.diff(stamps) == NS_PER_S // int(SIM_RATE))
    start = stamps[step[0]]
    by_stamp = {int(s): m for s, m in zip(stamps, states, strict=True)}
    names = list(states[-1].name)
    order = [names.index(n) for n in result['joint_names']]
    lead = result['lead_in']
    n_lead = round(lead * RATE)
    found = 0
    for i, t in enumerate(times):
        on_grid = abs(t * RATE - round(t * RATE)) < 1e-6
        goal_t = (n_lead + round(t * RATE)) / RATE if on_grid else t + lead
        msg = by_stamp.get(int(start + round(goal_t * NS_PER_S)))
        assert msg is not None, (i, t)
        np.testing.assert_allclose(np.array(msg.position)[order], expected[i], rtol=0, atol=1e-9)
        found += 1
    assert found == len(rows) > 150
    # Before the goal the robot was at rest; the lead-in starts there.
    rest = ControllerJoints.of(ROBOT).rest
    np.testing.assert_array_equal(np.array(by_stamp[int(start)].position)[order], rest)


def test_no_server_exits_1_with_one_line(ros_environment):
    """The line names the topic waited on in full and how to change it (it said 'no joint_states with the joints')."""
    res = _send(PROGRAM, '--namespace', '/gpr_nobody', '--timeout', '1')
    assert res.returncode == 1 and res.stdout == ''
    joints = ', '.join(ControllerJoints.of(ROBOT).names)
    assert res.stderr == (f'gpr program send: no joint states with the joints {joints} on /gpr_nobody/joint_states '
                          'within 1 s: cannot tell where the robot is (change the name with --joint-states and '
                          '--namespace, the wait with --timeout)\n')


def _send_beside(name: str, names: list[str], positions: list[float], description: str | None = None
                 ) -> tuple[int, str, str]:
    """``gpr program send`` in the namespace ``/name`` while a publisher there streams ``joint_states`` of
    ``names`` at ``positions`` at 20 Hz (and, given, latches ``description`` on ``robot_description``): its status,
    stdout and stderr."""
    from gpr_kinematics.nodes.client import GprClient
    from gpr_kinematics.nodes.qos import latched_qos, stream_qos
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    state = JointState(name=names, position=[float(v) for v in positions])
    with GprClient(f'gpr_test_{name}', namespace=f'/{name}') as c:
        if description is not None:
            c.node.create_publisher(String, 'robot_description', latched_qos(1)).publish(String(data=description))
        pub = c.node.create_publisher(JointState, 'joint_states', stream_qos(100))
        timer = c.node.create_timer(0.05, lambda: pub.publish(state))
        proc = subprocess.Popen([sys.executable, '-m', 'gpr_kinematics.cli.main', 'program', 'send', PROGRAM,
                                 '--namespace', name, '--timeout', '8'],   # (discovery: up to ~3 s)
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ))
        assert c.spin_until(lambda: proc.poll() is not None, 120)
        out, err = proc.communicate()
        c.node.destroy_timer(timer)
    return proc.returncode, out, err


@pytest.mark.slow
def test_joint_states_without_the_programs_joints_are_named_not_taken_for_none(ros_environment):
    """Joint states of another robot (only the rods here) came, and send said no joint states came at all."""
    joints = ControllerJoints.of(ROBOT)
    status, out, err = _send_beside('gpr_other', ['rod_1', 'rod_2', 'rod_3', 'gripper'], [0.25, 0.25, 0.25, 0.0])
    missing = ', '.join(n for n in joints.names if not n.startswith('rod_'))
    assert (status, out) == (1, '')
    assert err == (f'gpr program send: joint states on /gpr_other/joint_states came without {missing} (they carry '
                   "gripper, rod_1, rod_2, rod_3): is the program's robot the one there? (change the topic with "
                   '--joint-states and --namespace)\n')   # every joint they carry: it listed the program's alone
    # a message naming rod_1 twice is malformed (the simulator ignores it): send took its last value and planned
    # from there; now it reads joint states as the simulator does (controller.joint_state_values), and says so
    status, out, err = _send_beside('gpr_twice', [*joints.names, 'rod_1'], [*joints.rest, 0.3])
    assert (status, out) == (1, '')
    assert err == (f'gpr program send: joint states on /gpr_twice/joint_states came without {", ".join(joints.names)}'
                   f' (they carry {", ".join(sorted(joints.names))}) (left out of the last message that left one '
                   "out: the whole message, joint 'rod_1' named twice; "
                   "allowed: each joint once): is the program's robot the one there? (change the topic with "
                   '--joint-states and --namespace)\n')


@pytest.mark.slow
def test_a_program_for_another_robot_than_the_one_there_is_not_sent(ros_environment):
    """Robot 2's program (its base 3 m away) ran on robot 1 without a word: their joints are named alike. The robot
    there is read from its robot_description (the state publisher's URDF) and another robot's refused, status 1."""
    joints = ControllerJoints.of(ROBOT)
    urdf = '<?xml version="1.0"?>\n<robot name="example_dual_arm_r2">\n  <link name="world"/>\n</robot>\n'
    status, out, err = _send_beside('gpr_r2', list(joints.names), list(joints.rest), urdf)
    assert (status, out) == (1, '')
    assert err == ('gpr program send: /gpr_r2/robot_description describes robot example_dual_arm_r2, and the program '
                   "is for robot example_dual_arm: is the program's robot the one there? (another robot with "
                   "--namespace, or that robot's program)\n")
    # a URDF's name from the graph is quoted cut, not whole (a name of 3,000 characters)
    urdf = '<robot name="' + 'x' * 3000 + '"/>'
    status, _, err = _send_beside('gpr_r2', list(joints.names), list(joints.rest), urdf)
    assert status == 1 and err.count('\n') == 1 and len(err) < 400 and '(3000 characters)' in err, err


@pytest.mark.slow
def test_no_action_server_names_the_full_action_and_how_to_change_it(ros_environment):
    """Joint states come but no FollowJointTrajectory server answers: one line naming the action as resolved in the
    namespace (it said 'on joint_trajectory_controller/follow_joint_trajectory'), the wait and the options."""
    joints = ControllerJoints.of(ROBOT)
    status, _, err = _send_beside('gpr_noserver', list(joints.names), list(joints.rest))
    assert status == 1
    assert err == ('gpr program send: no FollowJointTrajectory server on '
                   '/gpr_noserver/joint_trajectory_controller/follow_joint_trajectory within 8 s (change the name with '
                   '--action and --namespace, the wait with --timeout)\n')


@pytest.mark.parametrize('option, value, words', [
    ('--namespace', 'r 1', "--namespace 'r 1': Invalid namespace: namespace must not contain characters other than"),
    ('--namespace', '/r1/', "--namespace '/r1/': Invalid namespace: namespace must not end with a '/'"),
    ('--joint-states', '', "--joint-states '': Invalid topic name: topic name must not be empty string"),
    ('--joint-states', '1x', "--joint-states '1x': Invalid topic name: topic name token must not start with a number"),
    ('--action', '//x', "--action '//x': Invalid topic name: topic name must not contain repeated '/'"),
    ('--progress', 'nan', '--progress = nan s; allowed: 0 < progress <= 3600 s'),
    ('--progress', '-1', '--progress = -1 s; allowed: 0 < progress <= 3600 s'),
])
def test_bad_names_and_progress_exit_2_with_one_line_before_any_node(ros_environment, option, value, words):
    """rclpy raised bad names as tracebacks (exit 1); --progress nan printed no progress line at all."""
    res = _send(PROGRAM, option, value, '--timeout', '1')
    assert res.returncode == 2 and res.stdout == '', res.stderr
    assert res.stderr.count('\n') == 1 and 'Traceback' not in res.stderr
    assert words in res.stderr, res.stderr


def test_a_robot_reporting_joints_outside_their_limits_exits_1(ros_environment):
    """The robot's state is not the command's input: joint states with a rod at 600 m (a driver in mm) exited 2, as
    a bad option does; now 1 with one line, as a goal the robot refuses (docs/robot.md, "send")."""
    from gpr_kinematics.nodes.client import GprClient
    from gpr_kinematics.nodes.qos import stream_qos
    from sensor_msgs.msg import JointState

    joints = ControllerJoints.of(ROBOT)
    position = [float(v) for v in joints.rest]
    position[0] = 600.0
    state = JointState(name=list(joints.names), position=position)
    with GprClient('gpr_test_send_outside', namespace='/gpr_outside') as c:
        pub = c.node.create_publisher(JointState, 'joint_states', stream_qos(100))
        timer = c.node.create_timer(0.05, lambda: pub.publish(state))
        proc = subprocess.Popen([sys.executable, '-m', 'gpr_kinematics.cli.main', 'program', 'send', PROGRAM,
                                 '--namespace', 'gpr_outside', '--timeout', '8'],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ))
        assert c.spin_until(lambda: proc.poll() is not None, 120)
        out, err = proc.communicate()
        c.node.destroy_timer(timer)
    assert proc.returncode == 1 and out == '' and err.count('\n') == 1, (out, err)
    assert err.startswith(f'gpr program send: the robot reports {joints.names[0]} = 600 m, ') and \
        'outside its limits [0, 0.508] m; allowed: a robot within its limits' in err, err


@pytest.mark.slow
def test_a_lagging_robot_prints_the_end_once_then_by_progress(ros_environment, tmp_path):
    """With a lag the simulator's feedback goes on while the joints settle after the last point: `--progress 100`
    printed a line per 10 ms sample from the end on (about 50); now the first feedback's and the end's, and the
    lagging robot succeeds within a goal_time of several time constants; `--no-progress` prints none of them."""
    program = tmp_path / 'short.yaml'
    program.write_text(f'format: gpr_robot_program\nversion: 1\nrobot: {config_path("robots/example_robot.yaml")}\n'
                       'units: {length: mm, angle: deg}\ndefaults: {arm: arm1}\nstations:\n'
                       '  - {name: home, position: [750, 850, 260], heading: 90}\n'
                       '  - {name: near, position: [750, 800, 280], heading: 90}\n'
                       'steps:\n  - {move: home}\n  - {move: near}\n')
    sim = start('robot_simulator_node', namespace='/gpr_lagsend', rate=SIM_RATE, servo_time_constant=0.1,
                goal_time=3.0)
    try:
        wait_for_log(sim, r'serving /gpr_lagsend/')
        res = _send(str(program), '--namespace', '/gpr_lagsend', '--progress', '100')
        quiet = _send(str(program), '--namespace', '/gpr_lagsend', '--no-progress')   # from where the first ended
    finally:
        sim.stop()
    assert quiet.returncode == 0 and quiet.stdout.startswith('sending ') and '  t = ' not in quiet.stdout \
        and '\nsucceeded (error_code 0 SUCCESSFUL): ' in quiet.stdout, quiet.stdout + quiet.stderr
    lines = [line for line in res.stdout.splitlines() if line.startswith('  t = ')]
    assert res.returncode == 0 and '\nsucceeded (error_code 0 SUCCESSFUL): ' in res.stdout, \
        res.stdout + res.stderr + sim.output()
    assert len(lines) == 2 and lines[0].startswith('  t =    0.000 s of ') and lines[1].split()[2] == \
        lines[1].split()[5], lines   # the first feedback's and the last point's


@pytest.mark.slow
def test_a_signal_while_the_goal_runs_cancels_it_and_ends_with_one_line(ros_environment):
    """Ctrl-C or SIGTERM while a goal ran: the handler's KeyboardInterrupt, raised while rclpy converted a feedback
    message, became a TypeError ("Unable to convert function return value"): 47-56 lines of traceback, exit 1, and the
    goal ran on to its end (a trial: 2 of 6 signals at a simulator's 1 kHz; the old code failed this test). The
    signal is noted while the goal is followed: the goal is cancelled, then the command ends as interrupted (130) or
    terminated (143), one line."""
    import signal
    import time

    ns = '/gpr_send_stop'
    sim = start('robot_simulator_node', namespace=ns, rate=1000.0)
    try:
        wait_for_log(sim, rf'serving {ns}/')
        for k, (signum, status, word) in enumerate([(signal.SIGINT, 130, 'interrupted'),
                                                    (signal.SIGTERM, 143, 'terminated')]):
            proc = subprocess.Popen([sys.executable, '-m', 'gpr_kinematics.cli.main', 'program', 'send', PROGRAM,
                                     '--namespace', ns], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                    env=dict(os.environ))
            end = time.monotonic() + 120
            while sim.output().count('goal accepted') <= k and proc.poll() is None and time.monotonic() < end:
                time.sleep(0.05)
            time.sleep(0.4 + 0.7 * k)   # at different places of the feedback stream
            proc.send_signal(signum)
            out, err = proc.communicate(timeout=60)
            assert (proc.returncode, err) == (status, f'gpr program send: {word}\n'), (out, err, sim.output())
            wait_for_log(sim, '(?s)' + '.*goal canceled \\(0\\): cancelled at t = ' * (k + 1), timeout=10)
        assert 'goal succeeded' not in sim.output(), sim.output()
        # a send while another goal runs: it planned the lead-in from a state the robot left, and the simulator
        # refused the goal's start ("aborted (error_code -1 INVALID_GOAL): points[0] ... start_tolerance"); now the
        # moving robot is named before any goal is sent
        first = subprocess.Popen([sys.executable, '-m', 'gpr_kinematics.cli.main', 'program', 'send', PROGRAM,
                                  '--namespace', ns], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                 env=dict(os.environ))
        end = time.monotonic() + 120
        while sim.output().count('goal accepted') <= 2 and first.poll() is None and time.monotonic() < end:
            time.sleep(0.05)
        second = _send(PROGRAM, '--namespace', ns)
        first.send_signal(signal.SIGINT)
        first.communicate(timeout=60)
        assert second.returncode == 1 and second.stderr.count('\n') == 1, second.stderr
        assert re.fullmatch(r'gpr program send: the robot is moving: \w+ went [\d.e-]+ (m|rad) while the move from '
                            r'where it was was planned \(another goal under way\?\); allowed: a robot at rest \(wait '
                            r'for its goal to end, or cancel it\)\n', second.stderr), second.stderr
        assert sim.output().count('goal accepted') == 3, sim.output()   # the second was not sent
    finally:
        sim.stop()

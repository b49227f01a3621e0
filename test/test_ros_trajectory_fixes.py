"""trajectory_node, defects a user trial found (2026-12-06): a stream under use_sim_time waiting for a /clock that
never comes said nothing; a cancel while the simulated clock stood still never ended the goal; loop jumped from a
program's end to its start in one sample (arm2_hand 87 rad/s); a sweep at a high rate moved the rods beyond their
velocity limit silently; rate:=0 was told to write 0.0 (out of range); a signal mid-stream said nothing of where it
stopped; a clock set back left the stream at one sample per clock step and its last line without a rate."""
from __future__ import annotations

import math
import re
import signal

import pytest
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.description import load_robot
from gpr_kinematics.robot.program import RobotProgram, load_any_program
from ros_support import assert_one_error_line, start, wait_for_log

pytestmark = pytest.mark.ros

ROBOT = load_robot()
STATIONS = [{'name': 'p', 'height': 0.4, 'tilt': 0.02, 'azimuth': 0.0, 'dwell': 0.5},
            {'name': 'm', 'height': 0.42, 'tilt': 0.02, 'azimuth': math.pi, 'dwell': 0.5, 'move_time': 4.0}]


# -- without nodes -------------------------------------------------------------------------------------------------
def test_the_clock_watch_speaks_after_3_s_then_every_10_s_and_not_while_time_moves():
    from gpr_kinematics.nodes.trajectory_watch import ClockWatch

    w = ClockWatch()
    w.reset(0, 100.0)
    said = [(t, w.check(0, t, 'the goal stream (before sample 0 of 151)')) for t in (101.0, 102.9, 103.0, 104.0,
                                                                                      112.9, 113.0)]
    assert [t for t, s in said if s] == [103.0, 113.0]
    text, warning = said[2][1]
    assert warning and text == ('no /clock has arrived in 3 s: use_sim_time is true and the goal stream (before '
                                'sample 0 of 151) waits for simulated time; allowed: a /clock publisher (a simulator, '
                                'ros2 bag play --clock, replay_node with clock_rate), or use_sim_time false')
    assert w.check(5 * 10**9, 114.0, 'x') is None           # time moved: quiet again, for 3 s
    assert w.check(5 * 10**9, 116.9, 'x') is None
    assert w.check(5 * 10**9, 117.0, 'the sweep stream') == (
        'the simulated clock has stood at 5.000 s for 3 s (/clock paused or stopped): the sweep stream waits for it',
        False)


def _trajectory(name: str, rate: float):
    from gpr_kinematics.ros.streams import trajectory_of

    prog = load_any_program(config_path(f'programs/{name}'))
    robot = load_robot(prog.robot) if isinstance(prog, RobotProgram) and prog.robot else ROBOT
    return trajectory_of(prog, robot, rate, 2.0), robot


def test_a_program_that_does_not_end_where_it_starts_cannot_loop_and_one_that_does_can(tmp_path):
    from gpr_kinematics.robot.platform_program import load_platform_program
    from gpr_kinematics.ros.stream_limits import loop_refusal
    from gpr_kinematics.ros.streams import trajectory_of

    traj, robot = _trajectory('example_robot_program.yaml', 50.0)
    assert loop_refusal(traj, robot, 50.0) == (
        'loop = true: the program ends 1.74824 rad from where it starts in arm2_hand (0.75176 rad at its last sample, '
        '2.5 rad at its first): looping moves it in one sample, 87.4 rad/s at 50 Hz, beyond its velocity limit 2.5 '
        'rad/s (3 joints beyond theirs); allowed: a program whose last state equals its first (each joint within one '
        'sample at its velocity limit: 0.05 rad for arm2_hand at 50 Hz), or loop false')
    open_ = tmp_path / 'open.yaml'
    open_.write_text('move_time: 2.0\nstations:\n  - {name: low, height: 0.30, tilt: 0.0, azimuth: 0.0, dwell: 0.2}\n'
                     '  - {name: high, height: 0.45, tilt: 0.02, azimuth: 1.0, dwell: 0.2}\n')
    traj = trajectory_of(load_platform_program(open_), ROBOT, 50.0, 2.0)
    assert re.match(r'loop = true: the program ends 0\.151657 m from where it starts in rod_2 .* 7\.58 m/s at 50 Hz, '
                    r'beyond its velocity limit 0\.15 m/s', loop_refusal(traj, ROBOT, 50.0))
    closed = tmp_path / 'closed.yaml'
    closed.write_text(open_.read_text() + '  - {name: back, height: 0.30, tilt: 0.0, azimuth: 0.0, dwell: 0.2}\n')
    assert loop_refusal(trajectory_of(load_platform_program(closed), ROBOT, 50.0, 2.0), ROBOT, 50.0) == ''


def test_a_sweep_beyond_the_rods_velocity_at_its_rate_is_warned_with_the_rate_it_allows():
    from gpr_kinematics.ros.stream_limits import sweep_beyond_rod_limits
    from gpr_kinematics.ros.streams import sweep_trajectory

    sw = sweep_trajectory(ROBOT.config, 0.5, math.radians(2.0), math.radians(0.2), math.radians(10.0), 1)
    assert sweep_beyond_rod_limits(sw, ROBOT.rods, 265.0, True) is sw          # within the limit: unchanged
    fast = sweep_beyond_rod_limits(sw, ROBOT.rods, 5000.0, False)
    assert fast.warning.startswith('755 steps need the rods beyond their velocity limit 0.15 m/s (rods.velocity): at '
                                   '5000 Hz about 2.82 m/s (0.000565 m between samples ')
    assert fast.warning.endswith('a robot cannot follow them as timed (a sweep is timed by its rate: at most 265.5 Hz '
                                 'for this grid, or a smaller tilt_step)')
    assert fast.description.endswith('; warning: ' + fast.warning)
    assert sweep_beyond_rod_limits(sw, ROBOT.rods, 5000.0, True).warning.startswith('756 steps need')  # the loop's


def test_a_bounded_numbers_refusal_names_its_range():
    from gpr_kinematics.nodes.params import allowed_number
    from gpr_kinematics.nodes.runtime import type_hint
    from gpr_kinematics.ros.specs import TRAJECTORY

    rate = next(s for s in TRAJECTORY if s.name == 'rate')
    assert allowed_number(rate) == 'a floating-point value from 0.1 to 5000.0, e.g. 100.0'
    assert allowed_number(rate, 0) == allowed_number(rate, -1) == allowed_number(rate)
    assert allowed_number(rate, 200) == 'a floating-point value from 0.1 to 5000.0 (write 200.0)'
    markers = next(s for s in TRAJECTORY if s.name == 'markers_every')
    assert allowed_number(markers) == 'an integer from 1 to 100000, e.g. 1'
    assert type_hint("to '0' of type 'INTEGER', expecting type 'DOUBLE': rate; allowed: a floating-point value") == ''


# -- the node ------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize('value,words', [
    ('0', r"'0' of type 'INTEGER', expecting type 'DOUBLE': rate; allowed: a floating-point value from 0\.1 to "
          r'5000\.0, e\.g\. 100\.0$'),
    ('abc', r"'abc' of type 'STRING', expecting type 'DOUBLE': rate; allowed: a floating-point value from 0\.1 to "
            r'5000\.0, e\.g\. 100\.0$'),
    ('1e400', r'rate; allowed: a floating-point value from 0\.1 to 5000\.0, e\.g\. 100\.0$'),
    ('0.0', r'out of range .*: rate; allowed: a floating-point value from 0\.1 to 5000\.0, e\.g\. 100\.0$'),
    ('200', r"'200' of type 'INTEGER'.*; allowed: a floating-point value from 0\.1 to 5000\.0 \(write 200\.0\)$"),
])
def test_a_bad_rate_is_refused_naming_its_range(ros_environment, value, words):
    proc = start('trajectory_node', '-p', f'rate:={value}', mode='idle')
    try:
        status = proc.wait(timeout=30)
        assert_one_error_line(proc.output(), status, 2, 'cannot start: ', words)
    finally:
        proc.stop()


def test_a_program_that_does_not_end_where_it_starts_is_refused_for_loop(ros_environment):
    proc = start('trajectory_node', mode='program', loop=True, rate=50.0,
                 program_file=str(config_path('programs/example_robot_program.yaml')))
    try:
        status = proc.wait(timeout=60)
        assert_one_error_line(proc.output(), status, 2, r'cannot start: loop = true: the program ends 1\.74824 rad '
                              r'from where it starts in arm2_hand .*; allowed: a program whose last state equals its '
                              r'first .*, or loop false$')
    finally:
        proc.stop()


def test_without_a_clock_a_goal_is_said_to_wait_and_a_cancel_ends_it(ros_environment):
    """use_sim_time and no /clock: the goal was accepted and nothing followed, not a word; its cancel was accepted and
    no result came (the stream's timer runs on the ROS clock, which stood still)."""
    from action_msgs.msg import GoalStatus
    from gpr_kinematics.nodes.client import GprClient

    ns = '/traj_fix_noclock'
    proc = start('trajectory_node', namespace=ns, mode='idle', rate=50.0, use_sim_time=True)
    try:
        wait_for_log(proc, 'idle: serving')
        with GprClient('gpr_test_traj_fix_noclock', namespace=ns) as c:
            handle = c.send_program(stations=STATIONS)
            assert handle.accepted
            wait_for_log(proc, r'\[WARN\].*no /clock has arrived in 3 s: use_sim_time is true and the goal stream '
                               r'\(before sample 0 of 251\) waits for simulated time; allowed: a /clock publisher')
            c.wait(handle.cancel_goal_async(), 10, 'cancel')
            res = c.wait(handle.get_result_async(), 10, 'result')
            assert res.status == GoalStatus.STATUS_CANCELED, res
            assert res.result.message == 'cancelled before sample 0 of 251 (at station 0 (p))'
        assert proc.alive()
    finally:
        proc.stop()


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_a_start_up_stream_stopped_by_a_signal_says_where(ros_environment, sig):
    proc = start('trajectory_node', namespace=f'/traj_fix_sig_{int(sig)}', mode='program', rate=50.0,
                 program_file=str(config_path('programs/example_stations.yaml')))
    try:
        wait_for_log(proc, 'started: publishing 326 samples')
        proc.proc.send_signal(sig)
        assert proc.wait(timeout=20) == 0, proc.output()
        name = signal.Signals(sig).name
        m = wait_for_log(proc, rf'finished: published (\d+) samples?(?: in [^:]*)?: stopped by {name} at sample '
                               r'(\d+) of 326: the node is shutting down')
        assert m.group(1) == m.group(2)
    finally:
        proc.stop()


@pytest.mark.slow
def test_after_a_simulated_clock_set_back_the_stream_keeps_its_rate(ros_environment):
    """/clock in 100 ms steps at 10 Hz, set back from 1000 s to 10 s: the stream's pace kept its start at 1000 s, so
    it fell to one sample per clock step (10 Hz for 200 Hz). It now starts its pace again at the new time: every step
    gets its 20 samples, 5 ms apart."""
    import numpy as np
    from test_ros_trajectory import RATE, _simulated_clock

    with _simulated_clock('/traj_fix_back', 100_000_000, 0.1) as (c, msgs, now):
        assert c.spin_until(lambda: len(msgs['gpr/platform_state']) > 10, 30)
        now['ns'] = 10 * 10**9
        c.spin_for(4.0)   # 2 s gave a loaded fresh-clone run (three test runs at once) 83 of the 100 samples
    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in msgs['gpr/platform_state']])
    after = stamps[stamps < 20 * 10**9]
    assert len(after) >= 100, (len(after), np.diff(after)[:10])
    assert np.max(np.abs(np.diff(after) - 1e9 / RATE)) <= 2, np.diff(after)[:20]

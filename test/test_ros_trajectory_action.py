"""The gpr/run_program action of trajectory_node over real DDS: a program runs to its end with ordered feedback
and the stream the core computes; cancel stops within one sample period and says where; bad goals are aborted
with a message and the node goes on serving; a second goal while one runs is rejected."""
from __future__ import annotations

import math
import time

import numpy as np
import pytest
from gpr_kinematics.core import inverse_batch
from gpr_kinematics.core.config import load_config
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.platform_program import load_platform_program, parse_platform_program, sample_program
from ros_support import client_session, running, start

pytestmark = pytest.mark.ros

CFG = load_config()
RATE = 100.0
NS = '/gpr_action'
STATIONS = [{'name': 'load', 'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0, 'dwell': 0.1},
            {'name': 'a', 'height': 0.42, 'tilt': math.radians(1.2), 'azimuth': 0.6, 'dwell': 0.1, 'move_time': 0.5},
            {'name': 'b', 'height': 0.38, 'tilt': math.radians(0.8), 'azimuth': -2.5, 'dwell': 0.05}]


@pytest.fixture(scope='module')
def node(ros_environment):
    yield from running(start('trajectory_node', namespace=NS, mode='idle', rate=RATE, move_time=0.4), 'idle: serving')


@pytest.fixture(scope='module')
def client(node):
    yield from client_session('gpr_test_action', NS)


def test_program_runs_to_the_end_with_ordered_feedback(client, node):
    from gpr_interfaces.msg import PlatformState

    states = client.subscribe(PlatformState, 'gpr/platform_state')
    feedback: list = []
    result = client.run_program(stations=STATIONS, feedback=feedback.append, timeout=60)
    client.spin_for(0.3)
    samples = sample_program(parse_platform_program({'stations': STATIONS}), RATE, 0.4)
    n = len(samples)
    assert result.success, result.message
    assert result.samples_published == result.samples_total == n
    assert [f.sample_index for f in feedback] == list(range(n))
    assert [f.station for f in feedback] == samples.station.tolist()
    names = [s['name'] for s in STATIONS]
    assert [f.station_name for f in feedback] == [names[k] if k >= 0 else '' for k in samples.station]
    # The stream is the program's: q from inverse_batch of the samples, counters as in the feedback.
    assert len(states) == n
    assert [m.sample for m in states] == [f.sample for f in feedback]
    ik = inverse_batch(samples.height, samples.tilt, samples.azimuth, CFG)
    np.testing.assert_allclose([m.q for m in states], ik.q, rtol=0, atol=1e-12)
    assert node.alive()


def test_program_file_goal(client):
    path = config_path('programs/example_stations.yaml')
    result = client.run_program(program_file=str(path), timeout=60)
    assert result.success, result.message
    assert result.samples_total == len(sample_program(load_platform_program(path), RATE, 0.4))


def test_cancel_stops_within_one_sample_period_and_says_where(client):
    from action_msgs.msg import GoalStatus

    from gpr_interfaces.msg import PlatformState

    long = [{'name': 'hold', 'height': 0.35, 'tilt': 0.0, 'azimuth': 0.0, 'dwell': 30.0}]
    states = client.subscribe(PlatformState, 'gpr/platform_state')
    feedback: list = []
    handle = client.send_program(stations=long, feedback=feedback.append)
    assert handle.accepted
    assert client.spin_until(lambda: len(feedback) >= 20, 30)
    t_cancel = time.time_ns()
    client.wait(handle.cancel_goal_async(), 10, 'cancel')
    response = client.wait(handle.get_result_async(), 10, 'result')
    client.spin_for(0.3)
    result = response.result
    assert response.status == GoalStatus.STATUS_CANCELED
    assert not result.success
    k = result.samples_published
    assert f'cancelled before sample {k} of {result.samples_total}' in result.message
    assert 'at station 0 (hold)' in result.message
    assert feedback[-1].sample_index == k - 1
    # The stream stops within one sample period of the cancel request leaving this process: the samples stamped
    # after it are the tick in flight, one sample or, on a loaded machine, that tick's catch-up burst (at most
    # CATCH_UP samples, published back to back), never samples one period later.
    from gpr_kinematics.nodes.trajectory_node import CATCH_UP

    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in states])
    late = np.sort(stamps[stamps > t_cancel])
    assert len(late) <= CATCH_UP
    assert len(late) <= 1 or late[-1] - late[0] < 1e9 / RATE, late
    assert k < result.samples_total


@pytest.mark.parametrize('goal,words', [
    ({}, 'exactly one'),
    ({'program_file': 'x.yaml', 'stations': STATIONS[:1]}, 'exactly one'),
    ({'program_file': '/nonexistent/program.yaml'}, 'cannot read program file'),
    ({'stations': [{'height': 0.3, 'tilt': float('nan'), 'azimuth': 0.0}]}, 'tilt'),
    ({'stations': [{'height': 0.3, 'tilt': 0.1, 'azimuth': 0.0}]}, r'station 0 .* tilt'),
    ({'stations': [{'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0, 'dwell': -1.0}]}, 'dwell'),
    ({'stations': STATIONS[:1], 'move_time': float('inf')}, 'move_time'),
], ids=['neither', 'both', 'missing-file', 'nan-tilt', 'beyond-tilt-limit', 'negative-dwell', 'inf-move-time'])
def test_bad_goal_aborted_with_message_node_keeps_serving(client, node, goal, words):
    import re

    from action_msgs.msg import GoalStatus

    handle = client.send_program(**goal)
    assert handle.accepted
    response = client.wait(handle.get_result_async(), 20, 'result')
    assert response.status == GoalStatus.STATUS_ABORTED
    assert not response.result.success and response.result.samples_published == 0
    assert re.search(words, response.result.message), response.result.message
    ok = client.run_program(stations=STATIONS[:1], timeout=30)
    assert ok.success, ok.message
    assert node.alive() and 'Traceback' not in node.output()


def test_second_goal_rejected_while_one_runs(client):
    long = [{'name': 'hold', 'height': 0.35, 'tilt': 0.0, 'azimuth': 0.0, 'dwell': 30.0}]
    first = client.send_program(stations=long)
    assert first.accepted
    second = client.send_program(stations=STATIONS)
    assert not second.accepted
    client.wait(first.cancel_goal_async(), 10, 'cancel')
    client.wait(first.get_result_async(), 10, 'result')

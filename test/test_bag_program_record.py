"""The record of what a stream was asked to do (``gpr/program``, bags/program_record.py): a program survives the
round trip through its record exactly, a record recomputes the node's stream, the markers' cadence is read per
sample where recorded, bad records are refused naming what is wrong, and every numeric field of the recorded
messages is placed as checked or unchecked (bags/coverage.py)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from gpr_kinematics.bags.checks_program import marker_cadence
from gpr_kinematics.bags.coverage import numeric_fields, rule_of, unchecked_fields
from gpr_kinematics.bags.program_record import expected, parse_record, record_text, sample_index
from gpr_kinematics.bags.typestore import GPR_TOPICS
from gpr_kinematics.core import inverse_batch
from gpr_kinematics.core.config import load_config
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import load_robot
from gpr_kinematics.robot.platform_program import load_platform_program, sample_program
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.robot.stream import robot_stream

CFG = load_config()


def test_a_robot_program_survives_its_record_and_recomputes_the_stream() -> None:
    program = load_program(config_path('programs/example_robot_program.yaml'))
    robot = load_robot()
    rs = robot_stream(robot, program, 10.0)
    n = len(rs.gpr.q)                  # the example program's samples at 10 Hz
    record = parse_record(record_text('robot_program', 17, n, 10.0, False, 2.0, program=program))
    back = record.program
    assert back.steps == program.steps and back.stations.branch == program.stations.branch
    for name in ('position', 'tilt', 'azimuth', 'heading', 'heading_free'):
        assert np.array_equal(getattr(back.stations.stations, name), getattr(program.stations.stations, name))
    assert back.stations.stations.names == program.stations.stations.names
    assert (back.arm, back.branch, back.approach_height, back.retract_height, back.dwell) == (
        program.arm, program.branch, program.approach_height, program.retract_height, program.dwell)
    ex = expected(record, robot.config, robot)
    assert np.array_equal(ex.q, rs.gpr.q) and np.array_equal(ex.joints, rs.joints) and len(ex.q) == n > 100
    assert [sample_index(record, s) for s in (16, 17, 16 + n, 17 + n)] == [-1, 0, n - 1, -1]


def test_a_program_with_straight_entries_and_wafers_survives_its_record() -> None:
    """The record left out the stations' straight entries (and the declared wafers): every honest recording of the
    example cell program failed gpr verify (597 samples recomputed to 399, the entries' lines missing)."""
    program = load_program(config_path('programs/example_cell_program.yaml'))
    robot = load_robot()
    rs = robot_stream(robot, program, 10.0)
    record = parse_record(record_text('robot_program', 0, len(rs.gpr.q), 10.0, False, 2.0, program=program))
    assert record.program.stations.entry == program.stations.entry and any(program.stations.entry)
    assert record.program.wafers == program.wafers == ('load_port_1',)
    ex = expected(record, robot.config, robot)
    assert np.array_equal(ex.q, rs.gpr.q) and np.array_equal(ex.joints, rs.joints)


@pytest.mark.parametrize('name', ['1e5', '2E-3', '.5', '007', 'yes', 'null', '2024-01-15', '1_000'])
def test_a_station_named_like_a_number_survives_its_record(name: str) -> None:
    """A station named ``1e5`` (YAML 1.2 reads a number, PyYAML's dumper left it plain) came back as 100000.0 and
    was refused: ``gpr verify`` failed such a bag."""
    stations = [{'name': name, 'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0},
                {'name': 'b', 'height': 0.4, 'tilt': 0.0, 'azimuth': 0.0}]
    from gpr_kinematics.robot.platform_program import parse_platform_program
    record = parse_record(record_text('platform_program', 0, 10, 50.0, False, 2.0,
                                      program=parse_platform_program({'stations': stations})))
    assert record.program is not None and record.program.stations[0].name == name


def test_a_platform_program_and_a_sweep_recompute_exactly() -> None:
    program = load_platform_program(config_path('programs/example_stations.yaml'))
    record = parse_record(record_text('platform_program', 0, 10, 50.0, True, 0.4, program=program))
    assert record.program == dataclasses.replace(program, source=record.program.source)
    ex = expected(record, CFG, None)
    samples = sample_program(program, 50.0, 0.4)
    assert np.array_equal(ex.q, inverse_batch(samples.height, samples.tilt, samples.azimuth, CFG, CFG.model).q)
    assert sample_index(record, 23) == 3       # it loops: counters run on, the stream starts over
    sweep = {'height': 0.5, 'max_tilt': math.radians(2), 'tilt_step': math.radians(0.2),
             'azimuth_step': math.radians(10), 'passes': 1}
    ex = expected(parse_record(record_text('sweep', 0, 756, 100.0, False, 2.0, sweep=sweep)), CFG, None)
    assert ex.q.shape == (756, 3) and np.max(np.abs(ex.commanded_tilt)) == pytest.approx(math.radians(2))


def test_markers_every_is_recorded_optionally_and_read_per_sample() -> None:
    """A record with markers_every (the node's since it was recorded) and one without (before): the cadence of each
    sample is its record's, 0 where none is recorded or no record covers the sample."""
    sweep = {'height': 0.5, 'max_tilt': 0.01, 'tilt_step': 0.01, 'azimuth_step': 1.0, 'passes': 1}
    new = parse_record(record_text('sweep', 5, 3, 10.0, True, 2.0, sweep=sweep, markers_every=4))
    old_text = record_text('sweep', 20, 3, 10.0, False, 2.0, sweep=sweep)
    assert new.markers_every == 4 and 'markers_every' not in old_text
    assert parse_record(old_text).markers_every is None
    samples = np.array([0, 4, 5, 19, 20, 30], dtype=np.int64)
    assert marker_cadence([new, parse_record(old_text)], samples).tolist() == [0, 0, 4, 4, 0, 0]
    assert marker_cadence([], samples).tolist() == [0] * 6


_SWEEP_RECORD = ('kind: sweep\nfirst_sample: 0\nsamples: 1\nrate: 1.0\nloop: false\nmove_time: 1.0\n'
                 'sweep: {height: 0.5, max_tilt: 0.01, tilt_step: 0.01, azimuth_step: 1.0, passes: 1}\n')


@pytest.mark.parametrize('value', ['0', '100001', '2.5', '1e3', 'true', 'two', 'null', '-3'])
def test_a_bad_markers_every_is_refused_naming_it(value: str) -> None:
    shown = {'2.5': '2.5', '1e3': '1000.0', 'true': 'True', 'two': "'two'", 'null': 'None'}.get(value, value)
    with pytest.raises(ConfigError, match=rf"^/gpr/program: markers_every = {shown}; allowed: an integer from 1 to "
                                          r"100000 \(trajectory_node's markers_every\)$"):
        parse_record(_SWEEP_RECORD + f'markers_every: {value}\n')
    assert parse_record(_SWEEP_RECORD + 'markers_every: 100000\n').markers_every == 100000


@pytest.mark.parametrize('text, words', [
    ('kind: teleport\nfirst_sample: 0\nsamples: 1\nrate: 1.0\nloop: false\nmove_time: 1.0\n', 'kind = '),
    ('kind: sweep\nfirst_sample: -1\nsamples: 1\nrate: 1.0\nloop: false\nmove_time: 1.0\n', 'first_sample = -1'),
    ('kind: sweep\nfirst_sample: 0\nsamples: 1\nrate: .nan\nloop: false\nmove_time: 1.0\n', 'rate = nan'),
    ('kind: sweep\nfirst_sample: 0\nsamples: 1\nrate: 1.0\nloop: 1\nmove_time: 1.0\n', 'loop = 1'),
    ('kind: sweep\nfirst_sample: 0\nsamples: 1\nrate: 1.0\nloop: false\nmove_time: 1.0\nsweep: {height: 1}\n',
     'sweep: height, max_tilt'),
    ('kind: robot_program\nfirst_sample: 0\nsamples: 1\nrate: 1.0\nloop: false\nmove_time: 1.0\nprogram: 3\n',
     'expected a mapping'),
    ('kind: sweep\nfirst_sample: 0\nfirst_sample: 1\n', "duplicate key 'first_sample'"),
    ('secret: [a, b]\n', 'unknown key'),
    # a record names no file (the robot is the recorded one): 'robot: /etc/passwd' passed, dropped unchecked
    ('kind: robot_program\nfirst_sample: 0\nsamples: 1\nrate: 1.0\nloop: false\nmove_time: 1.0\nprogram: {format: '
     'gpr_robot_program, version: 1, robot: /etc/passwd, stations: [], steps: []}\n',
     r'program: unknown key\(s\) robot; allowed keys: defaults, format, stations, steps, version, wafers'),
    ('kind: robot_program\nfirst_sample: 0\nsamples: 1\nrate: 1.0\nloop: false\nmove_time: 1.0\nprogram: {format: '
     'gpr_robot_program, version: 1, import: /etc/hosts, stations: [], steps: []}\n', r'unknown key\(s\) import'),
])
def test_bad_records_are_refused_naming_what_is_wrong(text: str, words: str) -> None:
    with pytest.raises(ConfigError, match=words):
        parse_record(text)


def test_every_numeric_field_of_the_recorded_messages_is_checked_or_declared_unchecked() -> None:
    for msgtype in set(GPR_TOPICS.values()):
        for path in numeric_fields(msgtype):
            assert rule_of(msgtype, path) is not None, (msgtype, path)
    unchecked = unchecked_fields(dict(GPR_TOPICS))
    assert set(unchecked) == {'/gpr/markers'} and 'markers[].color' in unchecked['/gpr/markers'][0]
    assert rule_of('gpr_interfaces/msg/PlatformState', 'commanded_tilt') == ('checked',
                                                                             'state.commanded, stream.program')


def test_a_field_the_tables_do_not_place_is_named_unchecked(monkeypatch: pytest.MonkeyPatch) -> None:
    """A field added to a message and placed in neither table is listed as not checked, saying so; a rule covers its
    own field and those under it only (``q`` covers ``q`` and ``q[...]``/``q.x``, not ``q_extra``)."""
    from gpr_kinematics.bags import coverage

    state = 'gpr_interfaces/msg/PlatformState'
    monkeypatch.setitem(coverage.CHECKED, state, tuple(r for r in coverage.CHECKED[state] if r[0] != 'residual'))
    coverage.unchecked_of.cache_clear()
    try:
        assert coverage.unchecked_of(state) == ('residual (not placed in the tables of bags/coverage.py)',)
    finally:
        coverage.unchecked_of.cache_clear()
    assert rule_of(state, 'q_extra') is None and rule_of(state, 'tilt_azimuth') == ('checked', 'state.tilt')


def test_a_recorded_stream_is_recomputed_once_per_verify(tmp_path, monkeypatch) -> None:
    """The stream's samples, the joint states and the wafer poses without their RobotState each planned the robot
    program again (three plans a record); the checks now share one (program_record.Recomputed)."""
    from bag_support import write_bag
    from gpr_kinematics.bags import program_record
    from gpr_kinematics.bags.synthetic import robot_program_messages
    from gpr_kinematics.bags.typestore import ROBOT_STATE_TOPIC
    from gpr_kinematics.bags.verify import verify_bag

    program = load_program(config_path('programs/example_robot_program.yaml'))
    types = {k: v for k, v in GPR_TOPICS.items() if k != ROBOT_STATE_TOPIC}
    bag = write_bag(tmp_path / 'fewer', [m for m in robot_program_messages(load_robot(), program, 10.0)
                                         if m[0] != ROBOT_STATE_TOPIC], types)
    calls = []
    plan = program_record.expected
    monkeypatch.setattr(program_record, 'expected', lambda *a: calls.append(a) or plan(*a))
    result = verify_bag(bag)
    assert result.passed and len(calls) == 1
    assert {c.name for c in result.checks if c.checked} >= {'stream.program', 'topic.joint_states_recomputed',
                                                          'topic.wafer_pose_recomputed'}


def test_records_naming_different_frame_prefixes_name_none() -> None:
    """recorded_prefix: the prefix every record names; None when two name different ones, or one names none (a node
    from before frame_prefix was recorded) and another 'r1/'."""
    from gpr_kinematics.bags.program_record import recorded_prefix
    sweep = {'height': 0.5, 'max_tilt': 0.01, 'tilt_step': 0.01, 'azimuth_step': 1.0, 'passes': 1}

    def record(prefix: str | None):
        return parse_record(record_text('sweep', 0, 1, 1.0, False, 1.0, sweep=sweep, frame_prefix=prefix))

    assert record('r1/').frame_prefix == 'r1/' and record(None).frame_prefix is None
    assert recorded_prefix([record('r1/'), record('r1/')]) == 'r1/'
    assert recorded_prefix([record('r1/'), record('r2/')]) is None
    assert recorded_prefix([record(None), record('r1/')]) is None
    assert recorded_prefix([record('r1/'), record(None)]) is None
    assert recorded_prefix([record('')]) == '' and recorded_prefix([]) is None


@pytest.mark.parametrize('value, shown', [("'r1 /'", "'r1 /'"), ('5', '5'), ('/r1/', "'/r1/'"), ('r1//', "'r1//'"),
                                          ('x' * 100, "'" + 'x' * 59 + '... (100 characters)'),
                                          ('x' * 300, "'" + 'x' * 59 + '... (300 characters)')],
                         ids=['a space', 'a number', 'a leading slash', 'two slashes', '100 characters',
                              '300 characters'])
def test_a_bad_frame_prefix_is_refused_naming_it(value: str, shown: str) -> None:
    """A recorded frame_prefix: what trajectory_node takes as its parameter (one rule, core.messages'), no other."""
    with pytest.raises(ConfigError) as e:
        parse_record(_SWEEP_RECORD + f'frame_prefix: {value}\n')
    assert str(e.value) == (f"/gpr/program: frame_prefix = {shown}; allowed: empty, or letters, digits, _ and single / "
                            'between parts, not starting with /, at most 99 characters (a prefixed frame is a tf frame '
                            "name of at most 100), e.g. r1/ (trajectory_node's frame_prefix)")
    assert parse_record(_SWEEP_RECORD + f"frame_prefix: {'x' * 99}\n").frame_prefix == 'x' * 99
    assert parse_record(_SWEEP_RECORD + 'frame_prefix: r1/arm_2\n').frame_prefix == 'r1/arm_2'

"""Sampling a platform program (``robot.platform_program.sample_program``): the stream starts at the first station
and ends at the last one, at the program's end, whatever the moves' durations."""
from __future__ import annotations

import math

import numpy as np
import pytest
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.robot.platform_program import parse_platform_program, sample_program


@pytest.mark.parametrize('move_time, dwell', [(1e-3, 0.0), (0.5, 0.0), (0.5, 0.0105), (0.25 + 5e-10, 0.0),
                                              (1e-3, 0.3)])
def test_the_last_sample_is_the_last_station_at_the_programs_end(move_time, dwell):
    stations = [{'name': 'a', 'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0, 'dwell': dwell},
                {'name': 'b', 'height': 0.4, 'tilt': math.radians(1.0), 'azimuth': 0.5, 'dwell': 0.0,
                 'move_time': move_time}]
    s = sample_program(parse_platform_program({'stations': stations}), 100.0)
    total = dwell + move_time
    assert s.time[0] == 0.0 and s.time[-1] == pytest.approx(total, abs=1e-15)
    assert np.all(np.diff(s.time) > 0)
    assert s.station[-1] == 1 and s.height[-1] == 0.4
    assert s.tilt[-1] == pytest.approx(math.radians(1.0), abs=1e-15)
    n = math.floor(total * 100.0 + 1e-9)
    assert len(s) == n + 1 + (total - n / 100.0 > 1e-9 or n == 0)


@pytest.mark.parametrize('move_time', [1e-6, 5000.0, 0.0, -1.0, float('nan'), 'abc', [1], True])
def test_a_move_time_is_the_node_parameters_range(move_time):
    """A file's (and a goal's) move_time took 1e-6 s and 5000 s, which trajectory_node's move_time parameter refused:
    one range, MOVE_TIMES, for all."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.robot.platform_program import MOVE_TIMES
    from gpr_kinematics.ros.specs import TRAJECTORY

    assert {p.name: p for p in TRAJECTORY}['move_time'].limits == MOVE_TIMES == (1e-3, 3600.0)
    stations = [{'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0}, {'height': 0.4, 'tilt': 0.0, 'azimuth': 0.0}]
    with pytest.raises(ConfigError, match=r'^f: file: move_time = \S+ is invalid; allowed: seconds from 0.001 to '
                                          r'3600$'):
        parse_platform_program({'move_time': move_time, 'stations': stations}, 'f')
    assert parse_platform_program({'move_time': 3600.0, 'stations': stations}, 'f').move_time == 3600.0
    program = parse_platform_program({'stations': stations}, 'f')   # and the Python API's default move time
    with pytest.raises(ConfigError, match=r'^move_time = \S+ is invalid; allowed: seconds from 0.001 to 3600$'):
        sample_program(program, 100.0, move_time)
    assert len(sample_program(program, 100.0, 1e-3)) == 2 and len(sample_program(program, 1.0, 3600.0)) == 3601


@pytest.mark.parametrize('name', ['x' * 65, 'A\nB: station (9, 9, 9) m, FAKE', '', True, 'a b', 'A\n'])
def test_station_names_follow_the_station_rule(name):
    """A name is repeated in feedback, results and logs: 1 to 64 letters, digits, _ . - as in station files (a 4 MB
    name went into every feedback message; a newline forged a line of output)."""
    from gpr_kinematics.errors import ConfigError

    with pytest.raises(ConfigError, match=r'station 0: name = .* is invalid.*allowed: 1 to 64 letters, digits, _ \. -'):
        parse_platform_program({'stations': [{'name': name, 'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0}]}, 'p.yaml')
    # a YAML number (007 read as 7, 1.5) is refused with the hint to quote it, as a cell obstacle's name
    for number in (7, 1.5):
        with pytest.raises(ConfigError, match=r'name = \S+ is invalid \(YAML read it as a number: quote the name to '
                                              r'keep it as written\); allowed: '):
            parse_platform_program({'stations': [{'name': number, 'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0}]})
    assert parse_platform_program({'stations': [{'name': '007', 'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0}]}
                                  ).stations[0].name == '007'


def test_an_azimuth_beyond_a_turn_is_refused_as_degrees():
    """A platform program is in radians only: ``azimuth: 90`` (degrees meant) was 14.3 turns, the tilt axis at
    2.04 rad; refused naming the station, the value and its radians; 6.2 rad and -2 pi pass as written."""
    def program(azimuth):
        return parse_platform_program({'stations': [{'name': 'a', 'height': 0.3, 'tilt': 0.01, 'azimuth': azimuth}]},
                                      'p.yaml')
    with pytest.raises(ConfigError, match=r'^p.yaml: station 0 \(a\): azimuth = 90 rad is beyond one turn; allowed: '
                                          r'\[-2pi, 2pi\] rad \(radians only here: 90 deg is 1.57079633 '
                                          r'rad\)$'):
        program(90)
    assert program(6.2).stations[0].azimuth == 6.2 and program(-2 * math.pi).stations[0].azimuth == -2 * math.pi


def test_the_rods_peak_speed_and_acceleration_of_a_move_match_dense_finite_differences():
    """rod_demand's first-order peaks (1.5 and 6 times the rods' change over T and T^2) against the rods of the
    program sampled at 10 kHz, differenced: within 1e-3 (the tilt's second-order part of a rod)."""
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.platform_program import load_platform_program, rod_demand

    from gpr_kinematics import inverse_batch, load_config

    cfg = load_config()
    program = load_platform_program(config_path('programs/example_stations.yaml'))
    st = program.stations
    at = inverse_batch([s.height for s in st], [s.tilt for s in st], [s.azimuth for s in st], cfg).q
    speed, accel = rod_demand(program, at, 2.0)
    assert speed.shape == accel.shape == (3,)
    s = sample_program(program, 10_000.0)
    q = inverse_batch(s.height, s.tilt, s.azimuth, cfg).q
    moving = s.station < 0
    v = np.abs(np.diff(q, axis=0)) * 1e4
    a = np.abs(np.diff(q, 2, axis=0)) * 1e8
    for k in range(3):   # each move's samples: those moving toward station k + 1
        on = np.flatnonzero(moving & (s.target == k + 1))
        assert np.max(v[on[:-1]]) == pytest.approx(speed[k], rel=1e-3)
        assert np.max(a[on[1:-1] - 1]) == pytest.approx(accel[k], rel=1e-3)
    assert speed[0] < 0.15 and accel[0] < 0.6   # the example keeps the example robot's limits


@pytest.mark.parametrize('move_time, warned', [(2.0, False), (1.0, True)])
def test_a_move_beyond_the_rods_limits_streams_with_a_warning(move_time, warned):
    """A platform program is timed by its move times: at 1 s the example's first move needs the rods at about
    0.229 m/s and 0.914 m/s^2, beyond the example robot's 0.15 m/s and 0.6 m/s^2 (it streamed without a word)."""
    import yaml
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.description import load_robot
    from gpr_kinematics.ros.streams import trajectory_of

    data = yaml.safe_load(config_path('programs/example_stations.yaml').read_text())
    program = parse_platform_program({**data, 'move_time': move_time}, 'example')
    traj = trajectory_of(program, load_robot(), 100.0, 2.0)
    if not warned:
        assert traj.warning == '' and 'warning' not in traj.description
        return
    assert traj.warning == (
        '2 moves need the rods beyond their limits 0.15 m/s or 0.6 m/s^2 (rods.velocity, rods.acceleration): to '
        'station 1 (station_a) about 0.229 m/s and 0.914 m/s^2; to station 3 (unload) about 0.152 m/s and 0.607 '
        'm/s^2; a robot cannot follow them as timed (a platform program is timed by its move_time only; a longer '
        'move_time, or a robot program, timed within the limits)')   # every such move: it named the worst alone
    assert traj.description.endswith(f'; warning: {traj.warning}')


def test_a_move_at_the_rods_limits_is_within_them():
    """0.30 -> 0.40 m in 1 s needs 0.15000000000000002 m/s and 0.6000000000000001 m/s^2 by rounding: it was warned as
    beyond the limits 0.15 and 0.6 it meets."""
    from gpr_kinematics.robot.description import load_robot
    from gpr_kinematics.ros.streams import trajectory_of

    at = parse_platform_program({'stations': [{'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0},
                                              {'height': 0.4, 'tilt': 0.0, 'azimuth': 0.0, 'move_time': 1.0}]}, 'at')
    assert trajectory_of(at, load_robot(), 100.0, 2.0).warning == ''
    over = parse_platform_program({'stations': [{'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0},
                                                {'height': 0.4001, 'tilt': 0.0, 'azimuth': 0.0, 'move_time': 1.0}]},
                                  'over')
    assert trajectory_of(over, load_robot(), 100.0, 2.0).warning.startswith('a move needs the rods beyond')


def test_a_station_name_given_twice_is_refused_naming_both_stations():
    """Robot programs refused a repeated station name, platform programs (a file's, a goal's stations) took it and
    their feedback named two stations alike: refused, naming the name and both stations."""
    from types import SimpleNamespace

    from gpr_kinematics.robot.description import load_robot
    from gpr_kinematics.ros.streams import GoalFiles, goal_program

    stations = [{'name': 'a', 'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0},
                {'name': 'b', 'height': 0.31, 'tilt': 0.0, 'azimuth': 0.0},
                {'name': 'a', 'height': 0.32, 'tilt': 0.0, 'azimuth': 0.0}]
    with pytest.raises(ConfigError, match=r"^p\.yaml: station name 'a' is given twice, as station 0 and as station 2; "
                                          r'allowed: each station name once$'):
        parse_platform_program({'stations': stations}, 'p.yaml')
    # a default name (station_i) is a name as well
    with pytest.raises(ConfigError, match=r"station name 'station_1' is given twice, as station 0 and as station 1"):
        parse_platform_program({'stations': [dict(stations[0], name='station_1'),
                                              {k: v for k, v in stations[1].items() if k != 'name'}]})
    goal = SimpleNamespace(program_file='', move_time=0.0, stations=[
        SimpleNamespace(name=n, height=h, tilt=0.0, azimuth=0.0, dwell=0.0, move_time=0.0)
        for n, h in (('a', 0.3), ('a', 0.31))])
    with pytest.raises(ConfigError, match=r"^goal stations: station name 'a' is given twice, as station 0 and as "
                                          r'station 1; allowed: each station name once$'):
        goal_program(goal, load_robot(None), GoalFiles.of(['']))
    assert [s.name for s in parse_platform_program({'stations': stations[:2]}).stations] == ['a', 'b']

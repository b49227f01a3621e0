"""Offline programs of trajectory_node (gpr_kinematics.robot.platform_program): parsing, validation, interpolation."""
from __future__ import annotations

import math

import numpy as np
import pytest
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.platform_program import load_platform_program, parse_platform_program, sample_program


def _prog(*stations, move_time=None):
    data = {'stations': [dict(zip(('height', 'tilt', 'azimuth', 'dwell'), s, strict=True)) for s in stations]}
    if move_time is not None:
        data['move_time'] = move_time
    return parse_platform_program(data)


def test_timeline_dwell_and_move():
    p = _prog((0.3, 0.0, 0.0, 0.5), (0.4, 0.02, 1.0, 0.25), move_time=1.0)
    s = sample_program(p, 100.0)
    assert s.time[-1] == pytest.approx(0.5 + 1.0 + 0.25)
    assert len(s) == 176
    np.testing.assert_allclose(np.diff(s.time), 0.01, atol=1e-12)
    dwell0 = s.time <= 0.5 + 1e-12
    np.testing.assert_allclose(s.height[dwell0], 0.3)
    assert np.all(s.station[dwell0] == 0)
    dwell1 = s.time >= 1.5 - 1e-12
    np.testing.assert_allclose(s.height[dwell1], 0.4)
    np.testing.assert_allclose(s.tilt[dwell1], 0.02)
    np.testing.assert_allclose(s.azimuth[dwell1], 1.0)
    assert np.all(s.station[(s.time > 0.5 + 1e-9) & (s.time < 1.5 - 1e-9)] == -1)
    # Smooth step: half way through the move, half way in height; zero velocity at both ends.
    mid = np.argmin(np.abs(s.time - 1.0))
    assert s.height[mid] == pytest.approx(0.35, abs=1e-12)
    i0 = np.argmin(np.abs(s.time - 0.5))
    assert s.height[i0 + 1] - s.height[i0] < 0.1 * (s.height[mid + 1] - s.height[mid])


def test_move_through_untilted_configuration_is_continuous():
    # From 1 deg about azimuth 0 to 1 deg about azimuth pi: the tilt vector passes through zero.
    t = math.radians(1.0)
    p = _prog((0.4, t, 0.0, 0.0), (0.4, t, math.pi, 0.0), move_time=1.0)
    s = sample_program(p, 1000.0)
    vx = s.tilt * np.cos(s.azimuth)
    vy = s.tilt * np.sin(s.azimuth)
    assert s.tilt.min() < 1e-12                    # the singular configuration is crossed
    assert np.abs(np.diff(vx)).max() < 3.1 * t / 1000    # smooth step peak speed 1.5 * 2t per second
    np.testing.assert_allclose(vy, 0.0, atol=1e-15)
    assert s.tilt.max() <= t + 1e-15                # never tilts beyond its stations


def test_signed_tilt_and_tilt_bound():
    a, b = math.radians(1.5), math.radians(-1.0)      # negative: about azimuth + pi
    p = _prog((0.4, a, 0.3, 0.0), (0.45, b, 1.2, 0.1), move_time=0.5)
    s = sample_program(p, 500.0)
    assert s.tilt.max() <= max(abs(a), abs(b)) + 1e-15
    assert s.tilt[-1] == pytest.approx(abs(b))
    assert math.remainder(s.azimuth[-1] - (1.2 + math.pi), 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def test_single_station_and_final_instant():
    p = _prog((0.3, 0.0, 0.0, 0.105))
    s = sample_program(p, 100.0)
    assert s.time[-1] == pytest.approx(0.105)
    assert len(s) == 12                            # 0 .. 0.10 plus the final instant 0.105
    np.testing.assert_allclose(s.height, 0.3)


def test_example_program_loads():
    p = load_platform_program(config_path('programs/example_stations.yaml'))
    assert [st.name for st in p.stations] == ['load', 'station_a', 'station_b', 'unload']
    assert p.stations[2].move_time == 1.5 and p.move_time == 2.0


@pytest.mark.parametrize('data,words', [
    ({}, ['stations']),
    ({'stations': []}, ['non-empty']),
    ({'stations': [{'height': 0.3, 'tilt': 0.0}]}, ['station 0', 'azimuth']),
    ({'stations': [{'height': 0.3, 'tilt': float('nan'), 'azimuth': 0.0}]}, ['tilt', 'finite']),
    ({'stations': [{'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0, 'dwell': -1}]}, ['dwell', '>= 0']),
    ({'stations': [{'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0, 'move_time': 0}]},
     ['move_time', 'seconds from 0.001 to 3600']),
    ({'stations': [{'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0, 'speed': 1}]}, ['speed', 'allowed']),
    ({'stations': [{'height': 'high', 'tilt': 0.0, 'azimuth': 0.0}]}, ['height', 'high']),
    ({'stations': [], 'rate': 5}, ['rate']),
])
def test_bad_programs_named(data, words):
    with pytest.raises(ConfigError) as err:
        parse_platform_program(data, 'prog.yaml')
    for w in words:
        assert w in str(err.value)


def test_bad_file_and_rate(tmp_path):
    with pytest.raises(ConfigError, match='cannot read program file'):
        load_platform_program(tmp_path / 'missing.yaml')
    f = tmp_path / 'broken.yaml'
    f.write_text('stations: [\n')
    with pytest.raises(ConfigError, match='not valid YAML'):
        load_platform_program(f)
    with pytest.raises(ConfigError, match='rate'):
        sample_program(_prog((0.3, 0.0, 0.0, 1.0)), 0.0)
    # counted before any array is made (a dwell of 1e12 s was a MemoryError, 1e300 s a ValueError of numpy); a
    # dwell beyond 1e6 s is refused as a number already (the one number rule)
    for dwell in (1e5, 1e6):
        with pytest.raises(ConfigError, match=r'samples at 100 Hz; allowed: at most 200000 samples'):
            sample_program(_prog((0.3, 0.0, 0.0, dwell)), 100.0)
    for dwell in (1e12, 1e300):
        with pytest.raises(ConfigError, match=r'dwell = .* is invalid; allowed: seconds >= 0 \(of magnitude at most'):
            _prog((0.3, 0.0, 0.0, dwell))
    # the bound counts the samples made (the one at t = 0 too): a dwell of 1000 s at 200 Hz has 200,001 and passed
    assert len(sample_program(_prog((0.3, 0.0, 0.0, 999.995)), 200.0).time) == 200_000
    with pytest.raises(ConfigError, match=r'lasts 1000 s: 200001 samples at 200 Hz; allowed: at most 200000 samples'):
        sample_program(_prog((0.3, 0.0, 0.0, 1000.0)), 200.0)


@pytest.mark.parametrize('rate, move_time, words', [
    (None, 2.0, r'rate = None is invalid'), ('a', 2.0, r"rate = 'a' is invalid"),
    (10 ** 400, 2.0, r'rate = <an integer of about 401 digits> is invalid'), (True, 2.0, r'rate = True is invalid'),
    (50.0, None, r'move_time = None is invalid'), (50.0, float('inf'), r'move_time = inf is invalid'),
])
def test_sample_program_names_a_rate_or_move_time_that_is_not_a_number(rate, move_time, words):
    """None and strings were bare TypeErrors, a 400-digit rate an OverflowError."""
    with pytest.raises(ConfigError, match=words):
        sample_program(_prog((0.3, 0.0, 0.0, 0.5), (0.4, 0.02, 1.0, 0.25)), rate, move_time)

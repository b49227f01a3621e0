"""The slip ratio's bound between the check's instants on joint-space moves (safety.slip_bound, docs/cell.md "Wafer
slip"): never below the true ratio (dense scans of the example program and of random joint-space moves, with and
without jerk limits), within its tolerance of it, and refusing a program whose ratio passes 1 between the instants
only."""
from __future__ import annotations

import dataclasses
import json
import re
import subprocess
import sys

import numpy as np
import pytest
import yaml
from gpr_kinematics.core import forward_batch
from gpr_kinematics.core.rotations import tilt_rotation
from gpr_kinematics.core.virtual_joints import make_model
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.plan import jerk_limits, joint_limits, plan_program
from gpr_kinematics.robot.program import load_program, parse_program
from gpr_kinematics.robot.timing import evaluate, locate, parameterise
from gpr_kinematics.safety import slip_bound as slip_bound_module
from gpr_kinematics.safety.check import _slip_times, check_program, corner_sides, wafer_plan
from gpr_kinematics.safety.slip import STEP, _ratio, difference_step, slip_series, wafer_path
from gpr_kinematics.safety.slip_bound import (
    POSITION_ERROR,
    SLIP_TOLERANCE,
    _frames,
    _halves,
    _leibniz,
    anchors,
    slip_bound,
    unit_rates,
)
from robot_support import make_robot, random_postures, robot_data

PROGRAM = config_path('programs/example_cell_program.yaml')


def _carrying(plan, times):
    out = np.full(times.shape, '', dtype=object)
    for arm, windows in wafer_plan(plan).carried.items():
        for t0, t1 in windows:
            out[(times >= t0) & (times <= t1)] = arm
    return out


def _bound(plan, carrying=_carrying):
    times = _slip_times(plan)
    held = carrying(plan, times)
    return slip_bound(plan, times, slip_series(plan, times, held).ratio, held)


def _scan(plan, bound, times, carrying=_carrying):
    """The true ratio at ``times`` inside the bound's intervals (a corner shared by two: the larger bound; its value
    takes one side of a trapezoid's jump), on the moves (an instant that starts a move is its hold's, exact there),
    and the bound of the interval holding each."""
    order = np.argsort(bound.start)
    start, end, value, moves = bound.start[order], bound.end[order], bound.bound[order], bound.move[order]
    k1 = np.minimum(np.searchsorted(end, times), end.size - 1)
    k2 = np.maximum(np.searchsorted(start, times, side='right') - 1, 0)
    in1, in2 = (start[k1] <= times) & (times <= end[k1]), (start[k2] <= times) & (times <= end[k2])
    top = np.maximum(np.where(in1, value[k1], -np.inf), np.where(in2, value[k2], -np.inf))
    keep = (in1 | in2) & ~locate(plan.timing, times)[1]
    times = times[keep]
    return (slip_series(plan, times, carrying(plan, times)).ratio, top[keep],
            np.where(in1, moves[k1], moves[k2])[keep])


def _no_jerk(data):
    data['rods'].pop('jerk')
    for arm in data['arms']:
        for joint in arm['joints']:
            joint.pop('jerk', None)
    return data


def test_unit_rates_bound_the_derivatives_of_a_unit_vector():
    """``e/|e|`` for a random cubic ``e(s)``: its first three derivatives (finite differences) stay below the bounds
    from ``|e^(k)| <= rho_k min |e|``, within a factor 3.2 of them at worst over 200 curves."""
    rng = np.random.default_rng(1)
    h = 1e-3
    worst = []
    for _ in range(200):
        c = rng.normal(size=(4, 3)) * np.array([[1.0], [0.5], [0.3], [0.2]])
        s = np.linspace(-0.2, 0.2, 401)
        e = c[0] + s[:, None] * c[1] + s[:, None] ** 2 * c[2] + s[:, None] ** 3 * c[3]
        d = [c[1] + 2 * s[:, None] * c[2] + 3 * s[:, None] ** 2 * c[3], 2 * c[2] + 6 * s[:, None] * c[3], 6 * c[3]]
        least = float(np.min(np.linalg.norm(e, axis=1)))
        rho = [float(np.max(np.linalg.norm(np.broadcast_to(x, e.shape), axis=1))) / least for x in d]
        bounds = unit_rates(*(np.array([r]) for r in rho))
        u = e / np.linalg.norm(e, axis=1)[:, None]
        for k, b in enumerate(bounds, start=1):
            du = np.diff(u, n=k, axis=0) / (s[1] - s[0]) ** k
            assert np.max(np.linalg.norm(du, axis=1)) <= b[0] * (1.0 + h)
        worst.append(max(float(np.max(np.linalg.norm(np.diff(u, n=k, axis=0), axis=1)) / (s[1] - s[0]) ** k
                               / bounds[k - 1][0]) for k in (1, 2, 3)))
    assert 0.3 < max(worst) <= 1.0


def test_the_central_differences_rounding_is_within_the_assumed_error():
    """The bound assumes the forward kinematics' noise from one ``s`` to the next at most ``POSITION_ERROR``
    (1e-14 m) in the central differences, which allows the second difference of the wafer's path 4 POSITION_ERROR
    / STEP^2 = 4e-6 m of noise: moving ``s`` by 1e-9 moves it by at most 1e-7 m on three moves of the example (the
    path's own change there is below 1e-8 m), 2.5e-16 m of noise in the positions, 40 times less than assumed."""
    plan = plan_program(make_robot(robot_data()), load_program(PROGRAM))
    s = np.linspace(0.05, 0.95, 50)
    for label in ('steps[2] (move low, move)', 'steps[5] (place pm1, at)', 'steps[8] (move pm2_front, move)'):
        k = plan.labels.index(label) - 1
        second = []
        for shift in (0.0, 1e-9):
            p = wafer_path(plan, 'arm2', k, np.concatenate([s + shift - STEP, s + shift, s + shift + STEP]))
            second.append((p[100:] - 2 * p[50:100] + p[:50]) / STEP ** 2)
        assert np.max(np.linalg.norm(second[1] - second[0], axis=1)) < 1.2e-7 < 4.0 * POSITION_ERROR / STEP ** 2 / 30


def test_the_bound_holds_100_khz_about_every_peak_of_the_example():
    """The example cell program (S-curves): 100 kHz about each move's largest bound and its instants' largest ratio
    (+-10 ms) finds no ratio above the bound of its interval, and each move's bound is within SLIP_TOLERANCE (0.001)
    of the largest ratio found (0.75382 over 0.75288 for the peak)."""
    plan = plan_program(make_robot(robot_data()), load_program(PROGRAM))
    bound = _bound(plan)
    assert bound.closed
    times = _slip_times(plan)
    ratio = slip_series(plan, times, _carrying(plan, times)).ratio
    _, _, m_of, _ = locate(plan.timing, times)
    peaks = [bound.start[bound.move == m][np.argmax(bound.bound[bound.move == m])] for m in np.unique(bound.move)]
    peaks += [times[m_of == m][np.nanargmax(ratio[m_of == m])] for m in np.unique(bound.move)]
    times = np.unique(np.concatenate([np.arange(t - 0.01, t + 0.01, 1e-5) for t in peaks]))
    ratio, value, move = _scan(plan, bound, times)
    assert np.all(ratio <= value)
    for m in np.unique(bound.move):
        top = float(np.max(bound.bound[bound.move == m]))
        assert float(np.max(ratio[move == m])) <= top <= float(np.max(ratio[move == m])) + SLIP_TOLERANCE
    assert float(np.max(bound.bound)) == pytest.approx(0.75382, abs=2e-5)
    assert float(np.max(ratio)) == pytest.approx(0.752885, abs=1e-6)


@pytest.mark.slow
@pytest.mark.parametrize('jerk', [True, False])
def test_the_bound_holds_the_whole_example_at_100_khz(jerk):
    """Every carried joint-space move of the example cell program, with and without jerk limits, scanned at 100 kHz:
    no ratio above its interval's bound, every move's bound within SLIP_TOLERANCE of the scan's maximum."""
    data = robot_data()
    plan = plan_program(make_robot(data if jerk else _no_jerk(data)), load_program(PROGRAM))
    bound = _bound(plan)
    assert bound.closed
    times = np.concatenate([np.arange(a, b, 1e-5) for a, b in zip(bound.start, bound.end, strict=True)])
    ratio, value, move = _scan(plan, bound, times)
    assert ratio.size > 1_000_000 and np.all(ratio <= value)
    for m in np.unique(bound.move):
        assert float(np.max(bound.bound[bound.move == m])) <= float(np.max(ratio[move == m])) + SLIP_TOLERANCE


def _random_plan(seed, jerk):
    """Three random postures of arm1 (rods at random heights and tilts, joints anywhere in their ranges) joined by
    joint-space moves, the wafer carried throughout."""
    data = robot_data()
    robot = make_robot(data if jerk else _no_jerk(data))
    base = plan_program(robot, load_program(PROGRAM))
    rods, joints = random_postures(robot, 'arm1', 3, seed=seed, tilt_fraction=0.8)
    names, velocity, acceleration, slices = joint_limits(robot)
    positions = np.zeros((3, len(names)))
    positions[:, :3], positions[:, slices[0]] = rods, joints
    labels = ('a', 'b', 'c')
    timing = parameterise(positions, velocity, acceleration, np.full(3, np.nan), np.zeros(3), names, labels,
                          jerk_limits(robot))
    return dataclasses.replace(base, positions=positions, timing=timing, labels=labels,
                               waypoints=dataclasses.replace(base.waypoints, path=()))


def _arm1(plan, times):
    return np.full(times.shape, 'arm1', dtype=object)


def _check_random(seed, jerk, rate):
    plan = _random_plan(seed, jerk)
    bound = _bound(plan, _arm1)
    assert bound.closed
    _, _, m_of, _ = locate(plan.timing, bound.time)
    peaks = [bound.start[bound.move == m][np.argmax(bound.bound[bound.move == m])] for m in (0, 1)]
    peaks += [bound.time[m_of == m][np.argmax(bound.ratio[m_of == m])] for m in (0, 1) if np.any(m_of == m)]
    times = np.unique(np.concatenate([np.arange(0.0, plan.timing.total, 1.0 / rate)]
                                     + [np.arange(t - 0.005, t + 0.005, 1e-5) for t in peaks]))
    ratio, value, move = _scan(plan, bound, times, _arm1)
    assert np.all(ratio <= value), seed
    for m in (0, 1):
        k = int(np.argmax(np.where(bound.move == m, bound.bound, -1.0)))
        assert float(np.max(ratio[move == m])) <= bound.bound[k]
        assert bound.bound[k] <= max(float(np.max(ratio[move == m])) + SLIP_TOLERANCE,
                                     bound.floor[k] + 0.5 * SLIP_TOLERANCE)
    return float(np.max(ratio)), float(np.max(bound.bound))


@pytest.mark.parametrize('jerk, peak', [(True, 1.59798), (False, 1.76081)])
def test_the_bound_holds_random_joint_space_moves(jerk, peak):
    """Random joint-space moves of arm1 (with and without jerk limits): 10 kHz over both moves and 100 kHz about
    each move's largest bound find no ratio above its interval's bound; the bound is closed, within SLIP_TOLERANCE
    of the largest ratio found on each move."""
    found, top = _check_random(3, jerk, 1e4)
    assert found == pytest.approx(peak, abs=1e-5) and found < top < found + 1.1e-3


@pytest.mark.slow
@pytest.mark.parametrize('jerk', [True, False])
def test_the_bound_holds_more_random_joint_space_moves_at_100_khz(jerk):
    """As above for two more seeds, scanned at 100 kHz throughout (four took 22-28 s a run in CI)."""
    for seed in (4, 6):
        _check_random(seed, jerk, 1e5)


def test_a_cruise_takes_no_jerk():
    """A move of arm1 timed to 1e4 s (an S-curve: its jerk ramps last 3.3 ms, then it cruises at s' = 1e-4 /s), the
    ratio at 0.1 Hz and on its corners: the bound took the profile's jerk J = 9.1 /s^3 on every interval, the cruise's
    too, where s''' = 0 (s' then grew by J L^2 / 8 = 114 /s over an interval of 10 s), and was infinite (so was a move
    of 1e5 s between the check's 200,000 instants: 2.860 on the example robot, unsafe, for 0.006). Now 0.014108 for the
    0.013953 evaluated, closed, and a scan (100,000 instants and 1 MHz over the ramps) finds no ratio above it."""
    robot = make_robot(robot_data())
    base = plan_program(robot, load_program(PROGRAM))
    rods, joints = random_postures(robot, 'arm1', 2, seed=0, tilt_fraction=0.999)
    names, velocity, acceleration, slices = joint_limits(robot)
    positions = np.zeros((2, len(names)))
    positions[:, :3], positions[:, slices[0]] = rods, joints
    timing = parameterise(positions, velocity, acceleration, np.array([np.nan, 1e4]), np.zeros(2), names, ('a', 'b'),
                          jerk_limits(robot))
    plan = dataclasses.replace(base, positions=positions, timing=timing, labels=('a', 'b'),
                               waypoints=dataclasses.replace(base.waypoints, path=()))
    corners = timing.corners()
    times = np.unique(np.concatenate([np.arange(0.0, timing.total, 10.0), corners,
                                      np.clip(corner_sides(corners), 0.0, timing.total), [timing.total]]))
    ratio = slip_series(plan, times, _arm1(plan, times)).ratio
    bound = slip_bound(plan, times, ratio, _arm1(plan, times))
    assert bound.closed and float(np.nanmax(ratio)) == pytest.approx(0.013953, abs=1e-6)
    assert float(np.max(bound.bound)) == pytest.approx(0.014108, abs=1e-6)
    ramps = np.arange(0.0, 0.01, 1e-6)
    dense = np.unique(np.concatenate([ramps, np.linspace(0.0, timing.total, 100_001), timing.total - ramps]))
    found, value, _ = _scan(plan, bound, dense, _arm1)
    assert np.all(found <= value) and float(np.max(found)) > 0.01395


@pytest.mark.slow
def test_a_slow_move_is_safe(tmp_path):
    """A pick, a move of 1e5 s with the wafer (level: a ratio of 0.006) and a place: the check read the move's bound as
    2.860 (every cruise interval took the profile's jerk) and refused the program (exit 1); now it is safe (exit 0),
    the move's bound 0.006, the largest that of the place's straight approach, exact there."""
    program = {'format': 'gpr_robot_program', 'version': 1, 'robot': str(config_path('robots/example_robot.yaml')),
               'wafers': ['load_port_1'], 'units': {'length': 'mm', 'angle': 'deg'},
               'defaults': {'arm': 'arm1', 'approach_height': 8, 'retract_height': 8, 'dwell': 0.5},
               'stations': [{'name': 'home', 'position': [750, 850, 260], 'heading': 90},
                            {'name': 'load_port_1', 'position': [750, -100, 400], 'heading': -90},
                            {'name': 'chamber_a', 'position': [1200, 1000, 440], 'tilt': 1.2, 'azimuth': 30,
                             'heading': 45}],
               'steps': [{'pick': 'load_port_1'}, {'move': 'home', 'time': 100000}, {'place': 'chamber_a'}]}
    (tmp_path / 'p.yaml').write_text(yaml.safe_dump(program))
    res = subprocess.run([sys.executable, '-m', 'gpr_kinematics', 'program', 'check', 'p.yaml', '--json'],
                         cwd=tmp_path, capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stdout + res.stderr
    d = json.loads(res.stdout)
    assert d['safe'] is True and d['slip_certified'] is True
    move = next(m for m in d['moves'] if m['label'] == 'steps[1] (move home, move)')
    assert move['max_slip_ratio'] == pytest.approx(0.006, abs=5e-4)
    assert d['max_slip_ratio'] == pytest.approx(0.4162, abs=1e-4)


def _fitted_ratio(plan, arm, times, half=1.0):
    """The slip ratio at ``times`` (in one joint-space move) from a Chebyshev fit of degree 6 to the wafer's exact path
    at 401 points of ``s`` in [0.5 - half, 0.5 + half] (a fit within 1e-14 m of them): derivatives without the
    differences' rounding."""
    _, _, m, tau = locate(plan.timing, times)
    s, ds, dds = evaluate(plan.timing.profiles, m, tau)
    grid = np.linspace(0.5 - half, 0.5 + half, 401)
    path = wafer_path(plan, arm, int(m[0]), grid)
    x = (grid - 0.5) / half
    c = np.polynomial.chebyshev.chebfit(x, path, 6)
    assert np.all(m == m[0]) and np.max(np.abs(np.polynomial.chebyshev.chebval(x, c).T - path)) < 1e-14
    d1, d2 = (np.polynomial.chebyshev.chebval((s - 0.5) / half, np.polynomial.chebyshev.chebder(c, k)).T / half ** k
              for k in (1, 2))
    return _ratio(plan, arm, times, d1 * dds[:, None] + d2 * (ds ** 2)[:, None])


def _pm1_pick(tmp_path):
    data = _no_jerk(robot_data())
    data['gpr']['config'] = str(config_path('gpr.yaml'))
    program = {'format': 'gpr_robot_program', 'version': 1, 'robot': 'robot.yaml', 'wafers': ['pm1'],
               'units': {'length': 'mm', 'angle': 'deg'},
               'defaults': {'arm': 'arm2', 'branch': 'right', 'approach_height': 8, 'retract_height': 8},
               'stations': [{'name': 'pm1', 'position': [1450, 500, 720], 'tilt': 1.5, 'azimuth': 120,
                             'heading': 0}],
               'steps': [{'pick': 'pm1'}]}
    (tmp_path / 'p.yaml').write_text(yaml.safe_dump(program))
    (tmp_path / 'robot.yaml').write_text(yaml.safe_dump(data))
    return plan_program(make_robot(data), load_program(tmp_path / 'p.yaml'))


def test_the_differences_of_a_short_move_are_not_its_rounding(tmp_path):
    """A pick from pm1 (tilted 1.5 deg) without jerk limits: its retract (rods 8 mm, arm joints 1.3 mrad) read a
    ratio peaking between the 200 Hz instants (0.0929806 at 0.34678 s, 0.3 ms from an instant, which read 0.0929787;
    0.34729 s on numpy 1.26), taken for a slip between the instants: it was the rounding of differences over
    ``STEP = 1e-4`` (2e-6 of the ratio, moving with the numpy version). Over the move's step (0.0125) the ratio agrees
    with a polynomial fit of the exact path to 1e-9, 0.0929788 at most, which the instants find."""
    plan = _pm1_pick(tmp_path)
    times = _slip_times(plan)
    sampled = float(np.nanmax(slip_series(plan, times, _carrying(plan, times)).ratio))
    dense = np.linspace(plan.timing.depart[1], plan.timing.arrive[2], 20_001)[1:-1]    # the retract
    true = slip_series(plan, dense, _carrying(plan, dense)).ratio
    assert float(difference_step(plan, 'arm2', np.array([1]))[0]) == pytest.approx(STEP / 0.0080027, rel=1e-4)
    assert float(np.max(np.abs(true - _fitted_ratio(plan, 'arm2', dense)))) < 1e-9
    assert sampled == pytest.approx(0.0929788, abs=2e-7) and float(np.max(true)) <= sampled + 1e-9


def test_a_slip_between_the_instants_is_refused():
    """Random joint-space moves of arm1 (seed 5, S-curves): the second move's ratio peaks between the check's instants
    (0.5590352 at 4.9036 s, 1.4 ms from the nearest instant, 100 kHz; the instants read 0.5590128). With the blade's
    friction set between the two the instants alone stay below 1, the true ratio passes 1, and the bound is above 1
    (closed)."""
    plan = _random_plan(5, True)
    times = _slip_times(plan)
    sampled = float(np.nanmax(slip_series(plan, times, _arm1(plan, times)).ratio))
    dense = np.arange(4.89, 4.92, 1e-5)
    true = slip_series(plan, dense, _arm1(plan, dense)).ratio
    peak, at = float(np.max(true)), dense[np.argmax(true)]
    assert sampled == pytest.approx(0.5590128, abs=2e-7) and peak == pytest.approx(0.5590352, abs=2e-7)
    assert at == pytest.approx(4.9036, abs=2e-4) and np.min(np.abs(times - at)) > 1e-3   # between the instants
    data = robot_data()
    data['arms'][0]['blade']['friction'] = 0.3 * float(np.sqrt(sampled * peak))
    plan = dataclasses.replace(plan, robot=make_robot(data))
    ratio = slip_series(plan, times, _arm1(plan, times)).ratio
    assert float(np.max(ratio)) < 1.0 < float(np.max(slip_series(plan, dense, _arm1(plan, dense)).ratio))
    bound = slip_bound(plan, times, ratio, _arm1(plan, times))
    assert bound.closed and float(np.max(bound.bound)) > 1.0


def _jog(tmp_path, distance, axis):
    """A pick from a station tilted 1.5 deg (without jerk limits) and a joint-space move of ``distance`` [m] along
    the station's ``axis`` (0: in its plane, the arm's joints; 2: its normal, the rods)."""
    data = _no_jerk(robot_data())
    data['gpr']['config'] = str(config_path('gpr.yaml'))
    R = tilt_rotation(np.radians(1.5), np.radians(90.0))
    A = np.array([750.0, -100.0, 400.0])
    B = A + 8.0 * R[:, 2] + 1e3 * distance * R[:, axis]      # the retract pose moved, in mm
    station = {'heading': -90, 'tilt': 1.5, 'azimuth': 90}
    program = {'format': 'gpr_robot_program', 'version': 1, 'wafers': ['A'], 'units': {'length': 'mm', 'angle': 'deg'},
               'defaults': {'arm': 'arm2', 'branch': 'right', 'approach_height': 8, 'retract_height': 8,
                            'dwell': 0.5},
               'stations': [{'name': 'A', 'position': A.tolist(), **station},
                            {'name': 'B', 'position': B.tolist(), **station}],
               'steps': [{'pick': 'A'}, {'move': 'B'}]}
    return plan_program(make_robot(data), parse_program(program, str(tmp_path / 'p.yaml'), tmp_path))


@pytest.mark.parametrize('distance, axis, true', [(1e-6, 2, 0.0929749), (1e-5, 2, 0.0929749),
                                                  (1e-6, 0, 0.3720113), (1e-5, 0, 0.3720079)])
def test_a_jog_of_a_micrometre_is_not_refused(tmp_path, distance, axis, true):
    """A joint-space move of 1 um (or 10 um) of the blade, a trapezoid of 2.2-8.2 ms, carrying a wafer: the central
    differences over ``STEP = 1e-4`` rounded 1e-14 m into 4e-6 m of the path's second derivative, times ``s'^2`` up
    to 6e5 /s^2, and the bound read 1.305 (2.300 in the plane) for the true 0.093 (0.372): the program was refused.
    Over the move's step (``STEP / c``: 10 to 400, the joints +-1e-4 about the move) the ratio agrees with a
    polynomial fit of the exact path to 5e-9 (the differences' rounding: 2.3e-9 on an AVX-512 machine with numpy
    1.26, below 1e-9 elsewhere), and its bound is at most 1.2e-5 above the largest of 20,000 instants
    (within SLIP_TOLERANCE asserted; 0.185 and 0.503 for 10 um before)."""
    plan = _jog(tmp_path, distance, axis)
    report = check_program(plan, None)[0]
    assert report.safe and report.slip_certified
    t = plan.timing
    dense = np.linspace(t.depart[-2], t.arrive[-1], 20_001)[1:-1]
    found = slip_series(plan, dense, np.full(dense.shape, 'arm2', dtype=object)).ratio
    c = float(np.max(np.abs(plan.positions[-1] - plan.positions[-2])))
    assert float(difference_step(plan, 'arm2', np.array([len(t.depart) - 2]))[0]) == pytest.approx(STEP / c)
    assert float(np.max(np.abs(found - _fitted_ratio(plan, 'arm2', dense)))) < 5e-9
    move = report.moves[-1]
    assert move.label == 'steps[1] (move B, move)' and float(np.max(found)) == pytest.approx(true, abs=2e-7)
    assert float(np.max(found)) <= move.max_slip_ratio <= float(np.max(found)) + SLIP_TOLERANCE


@pytest.mark.parametrize('distance, axis', [(1e-12, 0), (1e-14, 0), (1e-15, 0), (1e-15, 2)])
def test_a_jog_below_the_rounding_is_not_refused(tmp_path, distance, axis):
    """Jogs of 1e-12 to 1e-15 m (the joints' change ``c`` of 2.5e-12 to 1.1e-15, rounding included): with the
    differences' step at most 1 in ``s`` the rounding of 1e-14 m swamped the path (the 1e-14 m jog read 3.11 for
    0.369, the 1e-15 m jogs an infinite bound: refused). The step ``STEP / c`` takes the differences' points beyond
    the move's ends on the joints' line: the ratio agrees within 1e-8 with a fit of the exact path over joints
    +-1e-3 about the move (independent of the step), and the bound is at least the largest of 20,000 instants and
    within SLIP_TOLERANCE of it."""
    plan = _jog(tmp_path, distance, axis)
    report = check_program(plan, None)[0]
    assert report.safe and report.slip_certified
    t, P = plan.timing, plan.positions
    c = float(np.max(np.abs(P[-1] - P[-2])))
    assert 1e-16 < c < 3e-12
    dense = np.linspace(t.depart[-2], t.arrive[-1], 20_001)[1:-1]
    found = slip_series(plan, dense, np.full(dense.shape, 'arm2', dtype=object)).ratio
    assert float(difference_step(plan, 'arm2', np.array([len(t.depart) - 2]))[0]) == pytest.approx(STEP / c)
    assert float(np.max(np.abs(found - _fitted_ratio(plan, 'arm2', dense, half=1e-3 / c)))) < 1e-8
    move = report.moves[-1]
    assert float(np.max(found)) <= move.max_slip_ratio <= float(np.max(found)) + SLIP_TOLERANCE


def test_the_bound_is_the_verdicts_and_the_moves(tmp_path):
    """check_program reports the bound (max_slip_ratio, each move's row) over the ratio evaluated (max_slip_evaluated
    at max_slip_at): on the example, 0.75382 >= 0.75288, every row at least its instants' largest ratio."""
    plan = plan_program(make_robot(robot_data()), load_program(PROGRAM))
    report, _, (times, ratio) = check_program(plan, None)
    assert report.slip_certified and report.safe
    assert report.max_slip_evaluated == pytest.approx(0.752885, abs=1e-6)
    assert report.max_slip_ratio == pytest.approx(0.75382, abs=2e-5)
    assert report.max_slip_ratio == max(m.max_slip_ratio for m in report.moves)
    for m in report.moves:
        sel = (times >= m.start) & (times <= m.end)
        assert m.max_slip_ratio >= float(np.max(ratio[sel], initial=0.0))
    assert report.cell is None
    _, held, _, _ = locate(plan.timing, np.array([report.max_slip_at]))
    assert not held[0]


def test_a_bound_that_runs_out_of_instants_stays_a_bound_and_says_so(monkeypatch, capsys):
    """With no instant to spare for refinement the example's bound is the first one, from the 200 Hz intervals' ends:
    0.77992, still above the true 0.752885 and below 1 (safe), and the check says it was not closed."""
    from gpr_kinematics.cli.program import _print_safety
    from gpr_kinematics.safety import slip_bound as module

    monkeypatch.setattr(module, 'MAX_REFINEMENTS', 0)
    plan = plan_program(make_robot(robot_data()), load_program(PROGRAM))
    report = check_program(plan, None)[0]
    assert not report.slip_certified and report.safe
    assert report.max_slip_ratio == pytest.approx(0.77992, abs=1e-5) and report.max_slip_evaluated < 0.752885
    _print_safety(report, plan)
    out = capsys.readouterr().out
    assert ('  the slip bound was not refined to within 0.001 of the evaluated ratios (too many instants): it is '
            'looser, still a bound\n') in out
    assert 'max slip ratio 0.780 (a bound over the motion; 0.753 evaluated at 54.683 s, steps[14] (place ' in out



def test_a_budget_too_small_for_every_loose_interval_refines_the_loosest(monkeypatch):
    """When the loose intervals needed more instants than were left, none was refined (all or nothing: a 640-step
    program's bound stayed at 0.783 for 0.753 evaluated); the loosest are refined first, as many as fit: with 1,000
    instants the example's bound falls from the first one (0.77992) to 0.7639 (the settled one 0.75382), still a bound
    above the true 0.752885."""
    from gpr_kinematics.safety import slip_bound as module

    plan = plan_program(make_robot(robot_data()), load_program(PROGRAM))
    monkeypatch.setattr(module, 'MAX_REFINEMENTS', 1000)
    report = check_program(plan, None)[0]
    assert not report.slip_certified and report.safe
    assert 0.752885 < report.max_slip_ratio < 0.77992 - 0.01
    assert report.max_slip_ratio == pytest.approx(0.7639, abs=5e-4)

@pytest.mark.parametrize('model', ['compliant', 'polar', 'offset'])
def test_the_bound_holds_under_the_first_order_models(model):
    """The bound's platform terms are exact for the radial model only, first order for the others (their virtual
    joints are a minimum-norm or least-cost solution): on the example under each, 1 kHz over every carried
    joint-space move and 100 kHz about each move's largest bound find no ratio above it (the platform's share of the
    wafer's jerk is small there: the bound is the radial model's, 0.75382, or 0.75387 under polar, whose halving
    stopped elsewhere)."""
    data = robot_data()
    data['gpr']['model'] = model
    plan = plan_program(make_robot(data), load_program(PROGRAM))
    bound = _bound(plan)
    assert bound.closed and float(np.max(bound.bound)) == pytest.approx(0.75387 if model == 'polar' else 0.75382,
                                                                        abs=2e-5)
    peaks = [bound.start[bound.move == m][np.argmax(bound.bound[bound.move == m])] for m in np.unique(bound.move)]
    times = np.unique(np.concatenate([np.arange(a, b, 1e-3) for a, b in zip(bound.start, bound.end, strict=True)]
                                     + [np.arange(t - 0.005, t + 0.005, 1e-5) for t in peaks]))
    ratio, value, _ = _scan(plan, bound, times)
    assert ratio.size > 30_000 and np.all(ratio <= value)


def test_a_loose_closure_tolerance_is_tightened_for_the_slip_check():
    """A robot may solve its closure to 1e-6 m (``tolerance``'s range), 3.7e-7 m of position error, which the second
    differences over STEP amplify 4e8 times: random moves of arm1 under it read a slip ratio of 12.57 at 1 kHz for
    the true 0.34140 (and the bound let the true ratio pass it). The slip check solves to 1e-14 m whatever the
    robot's tolerance: the same ratios and bound as the default's."""
    plan = _random_plan(4, True)
    data = robot_data()
    data['gpr']['tolerance'] = 1e-6
    loose = dataclasses.replace(plan, robot=make_robot(data))
    times = np.arange(0.0, plan.timing.total, 1e-3)
    ratio, tight = (slip_series(p, times, _arm1(p, times)).ratio for p in (loose, plan))
    assert float(np.max(np.abs(ratio - tight))) < 1e-9 and float(np.max(ratio)) == pytest.approx(0.341401, abs=1e-6)
    assert float(np.max(_bound(loose, _arm1).bound)) == pytest.approx(float(np.max(_bound(plan, _arm1).bound)),
                                                                      abs=1e-9)


def test_over_a_fixed_step_a_jog_was_refused(tmp_path, monkeypatch, capsys):
    """The 1 um jog along the station's normal with the differences over ``STEP`` on every move (as before): the
    bound read 1.305 for the true 0.093 (the instants' ratio moved by the rounding, 0.093-0.103) and the program was
    refused, its bound not below 1."""
    from gpr_kinematics.cli.program import _print_safety
    from gpr_kinematics.safety import slip as slip_module
    from gpr_kinematics.safety import slip_bound as bound_module

    def fixed(plan, arm, m):
        return np.full(m.shape, STEP)

    monkeypatch.setattr(slip_module, 'difference_step', fixed)
    monkeypatch.setattr(bound_module, 'difference_step', fixed)
    plan = _jog(tmp_path, 1e-6, 2)
    report = check_program(plan, None)[0]
    assert not report.safe and report.max_slip_ratio == pytest.approx(1.305, abs=0.1)
    assert report.max_slip_evaluated < 0.11
    _print_safety(report, plan)
    assert re.search(r'  UNSAFE: the slip ratio is not bounded below 1 \(its bound 1\.\d{3}; evaluated at most '
                     r'0\.\d{3}, at 0\.\d{3} s, steps\[\d\] \(.+\)\)\n', capsys.readouterr().out)


def test_a_vacuum_adds_its_force_to_the_normal_force_it_is_held_by():
    """A blade's ``vacuum`` (0.5 N here; the example's blades have none) presses the wafer (0.128 kg) on the paddle:
    held at pm1's front (tilted 1.5 deg: gravity alone, ``tan(1.5 deg) / 0.3 = 0.087286`` without it) the ratio is
    ``sin a / (mu (cos a + F_vac / (m g))) = 0.062416``, the vacuum's force under the friction as the gravity's. The
    bound's ratio at the middle of its intervals, from its anchors (its own vacuum term), is the slip series' there."""
    data = robot_data()
    for arm in data['arms']:
        arm['blade']['vacuum'] = 0.5
    plan = plan_program(make_robot(data), load_program(PROGRAM))
    k = plan.labels.index('steps[4] (move pm1_front, move)')
    t = np.array([0.5 * (plan.timing.arrive[k] + plan.timing.depart[k])])
    a = np.radians(1.5)
    expected = np.sin(a) / (0.3 * (np.cos(a) + 0.5 / (0.128 * 9.80665)))
    assert float(slip_series(plan, t, _carrying(plan, t)).ratio[0]) == pytest.approx(expected, rel=1e-12)
    assert expected == pytest.approx(0.0624159, abs=1e-7)
    bound = _bound(plan)
    assert bound.closed and float(np.max(bound.bound)) < 0.7
    mid = 0.5 * (bound.start + bound.end)
    ratio, top, _ = _halves(plan, bound.start, bound.end, bound.move, _carrying(plan, mid))
    series = slip_series(plan, mid, _carrying(plan, mid)).ratio
    assert float(np.max(series)) > 0.5 and np.allclose(ratio, series, rtol=0.0, atol=1e-6) and np.all(top >= ratio)


def test_the_leibniz_bound_of_a_product_is_the_binomial_theorem():
    """``_leibniz`` with ``a_j = x^j``, ``b_j = y^j`` (the derivatives of ``e^(x s)`` and ``e^(y s)`` at 0) is the
    ``k``-th derivative of ``e^((x + y) s)`` there, ``(x + y)^k``: 1.3 and 0.7 give 2, 4 and 8."""
    x, y = np.array([1.3]), np.array([0.7])
    a, b = [x ** j for j in range(4)], [y ** j for j in range(4)]
    assert [float(_leibniz(a, b, k)[0]) for k in (1, 2, 3)] == pytest.approx([2.0, 4.0, 8.0], rel=1e-15)


def test_the_s_curves_bounds_about_a_midpoint_hold_on_its_interval(monkeypatch):
    """The bounds ``S = (S_1, S_2, S_3)`` of ``|s'|``, ``|s''|``, ``|s'''|`` that the bound takes within ``half`` of a
    midpoint (``s' + |s''| h + S_3 h^2 / 2``, ``|s''| + S_3 h``) hold at 201 points of each interval of the first
    move of a random plan (its corners instants), the jerk ramps' too: over the first 16 ms ``s'`` grows from 0 to
    ``J h^2 / 2 + s'' h + J h^2 / 2 = 2 J h^2``, which the first two terms alone leave at ``1.5 J h^2``."""
    plan = _random_plan(0, True)
    seen = []

    def capture(plan, m, at, arms, s1, s2, half, S):
        seen.append((half, S))
        return s1, s1, s1

    monkeypatch.setattr(slip_bound_module, 'bound_about', capture)
    timing = plan.timing
    corners = timing.corners()
    edges = np.unique(np.concatenate([np.linspace(0.0, timing.arrive[1], 200), corners[corners < timing.arrive[1]]]))
    t0, t1 = edges[:-1], edges[1:]   # as the check's instants: no corner inside an interval
    _halves(plan, t0, t1, np.zeros(t0.size, dtype=np.int64), np.full(t0.size, 'arm1', dtype=object))
    (half, (S1, S2, S3)), = seen
    t = t0[:, None] + (t1 - t0)[:, None] * np.linspace(0.0, 1.0, 201)
    _, ds, dds = evaluate(timing.profiles, np.zeros(t.size, dtype=np.int64), t.ravel() - timing.depart[0])
    assert np.all(np.max(np.abs(ds.reshape(t.shape)), axis=1) <= S1 * (1.0 + 1e-12))
    assert np.all(np.max(np.abs(dds.reshape(t.shape)), axis=1) <= S2 * (1.0 + 1e-12))
    J = float(timing.profiles.j[0])
    assert S3[0] == J and float(np.max(np.abs(ds.reshape(t.shape)[0]))) == pytest.approx(2.0 * J * half[0] ** 2,
                                                                                         rel=1e-6)


def test_a_level_wafer_slips_by_its_normals_turn():
    """Rods from ``q + (1.5, -0.75, -0.75)`` mm to ``q - (1.5, -0.75, -0.75)`` mm at a thousandth of their speed
    (20 s) tilt arm1's paddle through level at the move's middle, where the ratio is the wafer's acceleration's alone
    (7.3e-7): 0.2 s either side the normal has turned 0.32 mrad and the ratio is ``tan(0.32 mrad) / mu = 0.0010735``.
    The bound over that interval from its middle, ``|n'| S_1 h`` of turn in its spread, reads 0.0010755; 0.99 of that
    turn would read 0.0010647, below the ratio."""
    robot = make_robot(robot_data())
    base = plan_program(robot, load_program(PROGRAM))
    names, velocity, acceleration, slices = joint_limits(robot)
    positions = np.zeros((2, len(names)))
    positions[:, :3] = 0.3 + np.array([[1.0, -0.5, -0.5], [-1.0, 0.5, 0.5]]) * 1.5e-3
    positions[:, slices[0]] = np.linspace(0.2, -0.2, slices[0].stop - slices[0].start)
    timing = parameterise(positions, velocity * 1e-3, acceleration, np.full(2, np.nan), np.zeros(2), names,
                          ('a', 'b'), jerk_limits(robot))
    plan = dataclasses.replace(base, positions=positions, timing=timing, labels=('a', 'b'),
                               waypoints=dataclasses.replace(base.waypoints, path=()))
    middle = 0.5 * timing.duration[0]
    assert timing.duration[0] == pytest.approx(20.01, abs=1e-9) and np.all(np.abs(timing.corners() - middle) > 9.0)
    t0, t1 = np.array([middle - 0.2]), np.array([middle + 0.2])
    ratio, bound, _ = _halves(plan, t0, t1, np.zeros(1, dtype=np.int64), np.array(['arm1'], dtype=object))
    times = np.linspace(t0[0], t1[0], 41)
    true = slip_series(plan, times, _arm1(plan, times)).ratio
    assert float(ratio[0]) == pytest.approx(7.346e-7, rel=1e-3) and float(np.max(true)) == pytest.approx(0.00107349,
                                                                                                        rel=1e-5)
    assert float(np.max(true)) <= float(bound[0]) == pytest.approx(0.00107545, rel=1e-5)


def test_the_platform_joints_curvature_is_in_their_second_derivative():
    """``|r_k''| <= gamma |X''|`` with ``J X'' = G'' - H[X', X']`` (module docstring): the curvature ``H`` matters
    where the sides' lengths change at first order, ``|E . E'|`` near ``|E| |E'|``, and ``sigma`` is small: on a flat
    machine (rods and joints at azimuths 0, 15 and 35 deg, a triangle of 7.5, 10 and 162.5 deg) rod 1 rising 6 mm
    from level, which tilts it 39 deg (beyond any tilt limit; the bound is the closure's, for any rods), the joints'
    second derivative in ``s`` (central differences over 0.01 at 19 points) reaches 1.29 times ``G''`` alone,
    ``gamma |G''| / sigma`` (``2 |E'|^2`` per side, ``E'`` the rods' relative velocity; ``sigma`` from 0.0044), and
    0.46 of the bound with ``Lip X_1^2``."""
    data = robot_data()
    data['gpr'].update(rod_azimuths=[0.0, np.radians(15.0), np.radians(35.0)], tilt_limit=np.radians(15.0),
                       max_iterations=100)
    robot = make_robot(data)
    names, _, _, _ = joint_limits(robot)
    P = np.full((2, len(names)), 0.0)
    P[:, :3] = [[0.3, 0.3, 0.3], [0.306, 0.3, 0.3]]
    plan = dataclasses.replace(plan_program(make_robot(robot_data()), load_program(PROGRAM)), robot=robot,
                               positions=P)
    s = np.linspace(0.05, 0.95, 19)
    m = np.zeros(s.size, dtype=np.int64)
    at = anchors(plan, m, s, np.full(s.size, 'arm1', dtype=object))
    R = _frames(plan, P[m + 1] - P[m], at, np.full(s.size, 1e-6))[1]
    h = 0.01
    rows = P[0, :3] + (s[:, None] + np.array([-h, 0.0, h])[None]).reshape(-1, 1) * (P[1, :3] - P[0, :3])
    gpr = forward_batch(rows, robot.config, check_limits=False)
    r = make_model(robot.config).points_and_partials(gpr.virtual_joints)[0].reshape(s.size, 3, 3, 2)
    second = np.max(np.linalg.norm(r[:, 2] - 2.0 * r[:, 1] + r[:, 0], axis=2), axis=1) / h ** 2
    alone = np.sqrt(2.0) * 2.0 * 0.006 ** 2 / at.sigma    # |E'|^2 = (6 mm)^2 on the two sides with rod 1, gamma 1
    assert np.all(at.gamma == 1.0) and float(np.min(at.sigma)) == pytest.approx(0.0044, abs=1e-4)
    assert float(np.max(second / alone)) == pytest.approx(1.29, abs=0.01)
    assert np.all(second <= R[1]) and float(np.max(second / R[1])) == pytest.approx(0.46, abs=0.01)


FULL_STRETCH_ROBOT = """name: fab_r1
base: {frame: world, position: [2.0, 1.0, 0.05], rpy: [0.0, 0.0, 0.5]}
rods: {names: [zA, zB, zC], velocity: 0.12, acceleration: 0.5}
wafer: {diameter: 0.300, thickness: 0.000775, mass: 0.128}
arms:
  - name: lo
    mount: {position: [0.0, 0.0, 0.07], yaw: -0.5}
    joints:
      - {name: lo_j1, length: 0.34, height: 0.04, lower: -3.1, upper: 3.1, velocity: 1.2, acceleration: 1.8}
      - {name: lo_j2, length: 0.32, height: 0.04, lower: -2.8, upper: 2.8, velocity: 1.6, acceleration: 2.2}
      - {name: lo_j3, length: 0.0, height: 0.02, lower: -3.0, upper: 3.0, velocity: 2.0, acceleration: 2.5}
    blade: {position: [0.0, 0.0, 0.01], yaw: 0.0, wafer_centre: [0.21, 0.0, 0.004], friction: 0.35}
    branch: right
    home: [0.0, 2.4, -2.4]
"""


@pytest.mark.slow
def test_a_straight_entry_to_a_station_near_full_stretch_is_checked_on_its_line(tmp_path):
    """An OLP trial: a station 0.01 mm inside the arm's reach with a 300 mm straight entry was refused (exit 2, no
    file named) 'at -0.0001 of its length': the slip's central difference took a point beyond the line's end, out of
    reach. A line's wafer path is linear: its difference points stay on it, and the line's slip is that of its
    profile alone (the wafer's direction of travel fixed)."""
    (tmp_path / 'robot.yaml').write_text(FULL_STRETCH_ROBOT)
    program = {'format': 'gpr_robot_program', 'version': 1, 'robot': 'robot.yaml',
               'units': {'length': 'mm', 'angle': 'deg'}, 'wafers': ['far'],
               'stations': [{'name': 'near', 'position': [2400, 1000, 450], 'heading': 0},
                            {'name': 'far', 'position': [2869.99, 1000, 450], 'heading': 0, 'entry': 300}],
               'steps': [{'move': 'near'}, {'pick': 'far'}, {'move': 'near'}]}
    (tmp_path / 'p.yaml').write_text(yaml.safe_dump(program))
    from gpr_kinematics.robot import load_robot
    program = load_program(tmp_path / 'p.yaml')
    plan = plan_program(load_robot(program.robot), program)
    lines = [k for k in range(len(plan.labels) - 1) if plan.waypoints.is_line(k)]
    assert [plan.labels[k + 1] for k in lines] == ['steps[1] (pick far, approach)', 'steps[1] (pick far, exit)']
    k = lines[1]   # carrying: both ends of the line, where s -+ h left it
    t = np.array([plan.timing.depart[k], plan.timing.arrive[k + 1]])
    assert np.all(np.isfinite(slip_series(plan, t, np.array(['lo', 'lo'])).ratio))
    report = check_program(plan, None)[0]
    assert report.safe and 0.0 < report.max_slip_ratio < 1.0

"""The kinematics at the edges of their domains: exactly at the tilt limit (accepted wherever inverse kinematics
accepts it), machines far from the shipped one (a joint triangle of 0.1 mm, rods of 10 m), millimetres converted
exactly, and refusals that print the refused value apart from its limit."""
from __future__ import annotations

import math

import numpy as np
import pytest
from gpr_kinematics.cli.main import main
from gpr_kinematics.core import TILT_LIMIT_SLACK
from gpr_kinematics.core.config import GprConfig
from gpr_kinematics.core.inverse import IK_TOLERANCE, ik_tolerances
from gpr_kinematics.core.rotations import quaternion_from_matrix, tilt_rotation
from gpr_kinematics.errors import ConfigError, LimitError, apart
from gpr_kinematics.inputs.units import to_si

from gpr_kinematics import compensate, forward, forward_batch, inverse, inverse_batch

LIMIT = math.radians(2.0)


def test_compensation_takes_a_command_exactly_at_the_tilt_limit_at_every_azimuth():
    """2 deg at 45 deg of azimuth came out of the quaternion a few ulps beyond the limit and was refused (168 of
    360 whole-degree azimuths), where inverse kinematics takes the same target: both allow TILT_LIMIT_SLACK now."""
    for deg in range(0, 360, 5):
        quat = quaternion_from_matrix(tilt_rotation(LIMIT, math.radians(deg)))
        c = compensate((0.0, 0.0, 0.4), quat)
        assert c.achieved.tilt == pytest.approx(LIMIT, abs=1e-12)
    beyond = quaternion_from_matrix(tilt_rotation(LIMIT + 2 * TILT_LIMIT_SLACK, 0.7))
    with pytest.raises(LimitError, match=r'commanded tilt 0\.034906587 rad \(2\.0000001\d* deg\) is beyond the '
                                         r'tilt limit; allowed: a commanded tilt <= 0\.034906585 rad \(2 deg\)'):
        compensate((0.0, 0.0, 0.4), beyond)


def test_inverse_answers_only_rods_forward_kinematics_accepts():
    """A target at the limit + 1e-9 (the slack) was answered with rods tilting the platform a few ulps further, which
    forward kinematics then refused; a target's slack is now forward's less ten normal tolerances
    (``tilt_target_slack``), inverse checks its answer as forward does, and every answer passes forward."""
    refused = 0
    for model in ('radial', 'polar'):
        for az in np.linspace(-math.pi, math.pi, 41):
            for t in (LIMIT, LIMIT + TILT_LIMIT_SLACK, -(LIMIT + TILT_LIMIT_SLACK)):
                try:
                    ik = inverse(0.254, t, az, model=model)
                except LimitError as exc:
                    assert 'beyond the tilt limit' in str(exc)
                    refused += 1
                    continue
                forward(ik.q, model=model)
                forward_batch(ik.q[None, :], model=model)
    assert refused > 0      # some answers at the slack's edge lie beyond it (polar at azimuth 1 rad among them)
    with pytest.raises(LimitError, match='beyond the tilt limit'):
        inverse(0.254, LIMIT + TILT_LIMIT_SLACK, 1.0, model='polar')
    az = np.linspace(-math.pi, math.pi, 41)
    for t in (LIMIT, LIMIT + TILT_LIMIT_SLACK):
        for k in range(41):   # the batch rounds otherwise: its answers, where it gives them, pass forward too
            try:
                ik_b = inverse_batch([0.254], [t], [az[k]], model='polar')
            except LimitError:
                continue
            forward_batch(ik_b.q, model='polar')


@pytest.mark.parametrize('changes', [{'radius': 1e-4}, {'radius': 1e-3}, {'stroke_min': -10.0, 'stroke_max': 10.0},
                                     {'radius': 10.0, 'stroke_min': -10.0, 'stroke_max': 10.0, 'tolerance': 7.2e-15}])
def test_machines_far_from_the_shipped_one_converge_inside_their_limits(changes):
    """A joint triangle of 0.1 mm (60 of 60 targets did not converge: the normal is known to about 5e-13 there) and
    rods of up to 10 m (height errors of 1.2e-14 m): the Newton loop stops at the rounding of the pose
    (:func:`ik_tolerances`); the one-pose and batch paths agree, and the answer's forward kinematics is the target."""
    cfg = GprConfig().replace(**changes)
    tol_h, tol_n = ik_tolerances(cfg)
    rng = np.random.default_rng(7)
    lo, hi = cfg.stroke_min, cfg.stroke_max
    h = rng.uniform(lo + 0.3 * (hi - lo), hi - 0.3 * (hi - lo), 40)
    t = rng.uniform(0.0, cfg.tilt_limit, 40)
    g = rng.uniform(-math.pi, math.pi, 40)
    batch = inverse_batch(h, t, g, cfg)
    for i in range(40):
        one = inverse(h[i], t[i], g[i], cfg)
        np.testing.assert_allclose(one.q, batch.q[i], rtol=0, atol=1e-12)
        fk = forward(one.q, cfg)
        assert abs(fk.position[2] - h[i]) <= tol_h
        assert np.max(np.abs(fk.rotation[:, 2] - tilt_rotation(t[i], g[i])[:, 2])) <= tol_n


def test_the_shipped_machine_keeps_the_tolerance_and_small_ones_are_scaled():
    """The shipped geometry stops at IK_TOLERANCE for both (nothing loosened); a 0.1 mm triangle's normal at 8
    ulps of its longest rod per radius."""
    assert ik_tolerances(GprConfig()) == (IK_TOLERANCE, IK_TOLERANCE)
    small = GprConfig().replace(radius=1e-4)
    assert ik_tolerances(small) == (IK_TOLERANCE, pytest.approx(8 * math.ulp(0.508) / 1e-4, rel=1e-12))


def test_a_closure_tolerance_below_the_side_lengths_rounding_is_refused():
    """1e-16 m at a radius of 10 m (sides of 17.3 m, whose ulp is 3.6e-15 m): forward kinematics could not converge;
    the geometry is refused naming the least tolerance. At the shipped radius 1e-16 m stays allowed."""
    with pytest.raises(ConfigError, match=r'tolerance = 1e-16 m is below the rounding of the side lengths the '
                                          r'closure solves \(17\.3311 m at most: 2 ulps are 7\.11e-15 m\); allowed: '
                                          r'at least 7\.11e-15 m for this geometry'):
        GprConfig().replace(radius=10.0, stroke_min=-10.0, stroke_max=10.0, tolerance=1e-16)
    assert GprConfig().replace(tolerance=1e-16).tolerance == 1e-16


def test_whole_millimetres_are_the_metres_typed():
    """``9 * 1e-3`` is 0.009000000000000001 (72 of the whole millimetres 0..508 were an ulp off the metres typed), and
    -1e-9 mm was refused where -1e-12 m passed; every whole millimetre now gives the typed metres' double."""
    mm = np.arange(509.0)
    assert np.array_equal(to_si(mm, 1e-3), np.array([float(f'{k:g}e-3') for k in range(509)]))
    assert to_si(9.0, 1e-3) == 0.009 and to_si(2.0, math.pi / 180.0) == math.radians(2.0)


def test_the_command_line_reads_millimetres_exactly(capsys):
    assert main(['fk', '9', '9', '9', '--mm', '--json']) == 0
    assert '"q": [0.009, 0.009, 0.009]' in capsys.readouterr().out
    assert main(['fk', '--mm', '--', '-1e-9', '0', '0']) == main(['fk', '--', '-1e-12', '0', '0']) == 0


@pytest.mark.parametrize('argv, message', [
    (['fk', '0.5080000000010001', '0.508', '0.508'], 'q1 = 0.508000000001 m is outside the stroke [0, 0.508] m'),
    (['fk', '--', '-0.0000000000011', '0', '0'], 'q1 = -1.1e-12 m is outside the stroke [0, 0.508] m'),
    (['robot', 'ik', '--position', '1.3', '0.6', '0.45', '--azimuth', '6.2831853082'],
     '--azimuth = 6.283185308 rad is outside [-2pi, 2pi] rad (2pi = 6.283185307)'),
    (['robot', 'ik', '--position', '1.3', '0.6', '0.45', '--azimuth', '-400', '--deg'],
     '--azimuth = -400 deg is outside [-360, 360] deg'),
    # a typed tilt beyond a turn was taken modulo 2 pi (1000 turns + 0.02 rad solved as 0.02 rad)
    (['robot', 'ik', '--position', '1.2', '1.0', '0.455', '--tilt', '6283.205307179586'],
     '--tilt = 6283.21 rad is outside [-2pi, 2pi] rad; allowed: an angle in radians (give --deg for degrees)'),
    (['compensate', '--height', '0.25', '--tilt', '361', '--azimuth', '0', '--deg'],
     '--tilt = 361 deg is outside [-360, 360] deg'),
    (['mobility', '0.3', '0.3', '0.3', '--dq', '0.2080000000001', '0', '0'],
     'q1 + dq1 = 0.5080000000001 m is outside the stroke [0, 0.508] m'),
    (['ik', '--height', '0.25', '--tilt', '2.00000006', '--azimuth', '0', '--deg'],
     '--tilt = 2.0000001 deg (0.0349065861 rad) is beyond the tilt limit; allowed: |tilt| <= 2 deg (0.034906585 rad)'),
    (['sweep', '--max-tilt', '2.00000006', '--deg'],   # under --deg the degrees first (docs/core.md)
     '--max-tilt = 2.0000001 deg (0.0349065861 rad) is beyond the tilt limit; allowed: --max-tilt <= 2 deg '
     '(0.034906585 rad)')])
def test_a_refusal_prints_the_value_apart_from_its_limit(capsys, argv, message):
    """"0.508 m is outside the stroke [0, 0.508] m" contradicted itself; the value takes the digits that tell it
    from the limit it passed (:func:`~gpr_kinematics.errors.apart`)."""
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_a_typed_direction_within_the_files_slack_of_a_turn_is_taken(capsys):
    """The files' and the requests' rule (one turn + 1e-9 rad): 6.28318530718 was refused on the command line and
    accepted by the station service."""
    assert main(['robot', 'ik', '--position', '1.3', '0.6', '0.45', '--tilt', '0.02', '--azimuth', '6.28318530718',
                 '--heading', '0.349']) == 0
    capsys.readouterr()


def test_apart_adds_the_digits_needed_and_no_more():
    assert apart(0.6, 0.508) == ('0.6', '0.508')
    assert apart(0.5080000000010001, 0.508) == ('0.508000000001', '0.508')
    assert apart(math.nextafter(2.0, 3.0), 2.0) == ('2.0000000000000004', '2')
    assert apart(1.0, 1.0) == ('1.0', '1.0')


def test_a_station_at_the_tilt_slack_is_refused_by_its_name_and_marked_in_a_batch():
    """A station plane tilted by the limit + 1e-9 rad: the GPR's answer lay a few ulps beyond the slack, and
    ``solve_stations`` raised the core's unlabelled refusal even with ``check=False``; the station's slack is the
    targets' now: marked infeasible in a batch, refused naming the station alone."""
    from gpr_kinematics.robot import Stations, load_robot, solve_stations
    robot = load_robot()
    limit = robot.config.tilt_limit
    for az in np.linspace(-math.pi, math.pi, 37):
        st = Stations.of([[0.75, 0.15, 0.45], [1.2, 0.5, 0.45]], tilt=[limit + TILT_LIMIT_SLACK, 0.0], azimuth=az,
                         heading=0.3, names=['edge', 'level'])
        assert solve_stations(robot, st, 'arm1', check=False).feasible.tolist() == [False, True]
        with pytest.raises(LimitError, match=r'^station edge: the station plane tilts 2\.0000001 deg in gpr_base, '
                                             r'beyond the tilt limit 2 deg'):
            solve_stations(robot, st.take([0]), 'arm1')


def test_a_target_at_the_tilt_limit_is_one_on_every_allowed_machine():
    """A joint triangle of 0.1 mm on rods of 10 m (both allowed) made the target slack negative: 2 deg itself, and
    the default sweep, were refused as beyond 2 deg. The slack is never below 0 (``tilt_target_slack``)."""
    from gpr_kinematics.core.inverse import tilt_target_slack
    from gpr_kinematics.core.sweep import paper_sweep
    cfg = GprConfig().replace(radius=1e-4, stroke_max=10.0)
    assert 0.0 < tilt_target_slack(cfg) < TILT_LIMIT_SLACK
    for az in np.linspace(-math.pi, math.pi, 13):
        ik = inverse(5.0, cfg.tilt_limit, az, cfg)
        forward(ik.q, cfg)
    assert len(paper_sweep(height=5.0, config=cfg)) == 756

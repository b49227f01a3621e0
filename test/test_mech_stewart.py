"""6-SPS Gough-Stewart platform and the accuracy analysis of Alwan (Alwan 2011)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from gpr_kinematics.errors import ConfigError, InputError, SingularityError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.mechanisms import load_mechanism, mechanism_from_dict
from gpr_kinematics.mechanisms.accuracy import accuracy_analysis, linearized_deviation
from gpr_kinematics.mechanisms.stewart import StewartPlatform

DEG = math.pi / 180


@pytest.fixture(scope='module')
def alwan() -> StewartPlatform:
    return load_mechanism(config_path('mechanisms/stewart_alwan.yaml'))


def test_pose1_leg_lengths_reproduce(alwan):
    pose1 = np.array([0.66, -0.35, 1.8, -5 * DEG, 2 * DEG, 1.4 * DEG])
    np.testing.assert_allclose(alwan.trajectory[0], pose1, atol=1e-15)
    s = alwan.leg_lengths(pose1)
    printed = np.array([2.003, 2.255, 2.375, 2.153, 1.948, 1.80])
    half_digit = np.array([5e-4] * 5 + [5e-3])          # the last value is printed with two decimals
    assert np.all(np.abs(s - printed) <= half_digit)


def test_pose6_printed_lengths_do_not_reproduce(alwan):
    """Documented: the paper's point-6 lengths are not those of its point-6 pose (any Euler order tried)."""
    printed = np.array([2.318, 2.155, 2.02, 2.281, 2.38, 2.54])
    s6 = alwan.leg_lengths(alwan.trajectory[5])
    assert np.max(np.abs(s6 - printed)) > 0.02


def test_forward_kinematics_round_trip(alwan):
    s = alwan.leg_lengths(alwan.trajectory)
    poses = alwan.forward(s)              # from the default start: untilted, centred
    np.testing.assert_allclose(poses, alwan.trajectory, atol=1e-9)
    np.testing.assert_allclose(alwan.leg_lengths(poses), s, atol=1e-12)


def test_forward_kinematics_from_the_default_start_for_any_number_of_poses(alwan):
    """The default start is built per pose: one, two or five poses (not only the trajectory's six) round-trip."""
    for n in (1, 2, 5):
        s = alwan.leg_lengths(alwan.trajectory[:n])
        np.testing.assert_allclose(alwan.forward(s), alwan.trajectory[:n], atol=1e-9)


def test_parameter_jacobian_closed_form_matches_differences(alwan):
    pose = alwan.trajectory[2]
    for name in ('A_i', 'B_i'):
        closed = alwan.parameter_jacobian(pose, name)
        fd = super(StewartPlatform, alwan).parameter_jacobian(pose, name)
        np.testing.assert_allclose(closed, fd, atol=1e-7)


def test_alwan_accuracy_linear_and_exact(alwan):
    res = accuracy_analysis(alwan, alwan.trajectory, alwan.leg_deformations)
    assert res.linearized.shape == (6, 6)
    # Leg deformations of 0.12-0.45 mm move the centre by ~1.5-2.4 mm along x here (not the paper's 0.2 mm).
    assert np.all(np.abs(res.linearized[:, 0]) > 1e-3) and np.all(np.abs(res.linearized[:, 0]) < 3e-3)
    # The exact solution reproduces the perturbed leg lengths.
    np.testing.assert_allclose(alwan.leg_lengths(res.exact_poses), alwan.leg_lengths(alwan.trajectory)
                               + alwan.leg_deformations, atol=1e-12)
    # Position agrees to second order (errors ~0.4 mm, lever ~1 m: differences of a few micrometres).
    assert np.max(np.abs(res.difference[:, :3])) < 1e-5
    assert round(float(np.max(np.abs(res.difference[:, :3]))) * 1e6, 1) == 4.3   # docs/mechanisms.md: 4.3 um
    # Near the Z-X-Z gimbal lock (theta = 2 deg at point 1) psi and phi deviations are large and opposite,
    # while the rotation itself (rotation vector) moves by about 2 mrad.
    assert abs(res.linearized[0, 3]) > 0.05 and res.linearized[0, 3] == pytest.approx(-res.linearized[0, 5],
                                                                                       rel=0.05)
    assert np.max(np.abs(res.exact_twist[:, 3:])) < 3e-3
    np.testing.assert_allclose(res.linearized_twist, res.exact_twist, atol=1e-5)


def test_alwan_tables_do_not_reproduce_as_documented(alwan):
    """docs/mechanisms.md: Tables 1-3 print 0.13-0.26 mm (x, y) and 0.85-1.2 mm (z); eq. (7) with the leg
    deformations gives 1.5-2.3 mm (x), 0.7-0.9 mm (y), -0.3..0.6 mm (z), the ratio printed/ours along x 0.08-0.15
    (no constant factor); the rotation vector moves by 0.02-0.12 deg per component, the printed angles 0.01-0.07."""
    printed = np.array([[0.213, 0.146, 0.129, 0.201, 0.222, 0.256],       # Table 1, dx [mm]
                        [0.135, 0.211, 0.183, 0.186, 0.177, 0.232],       # Table 2, dy
                        [0.996, 0.946, 0.987, 0.849, 1.064, 1.213]])      # Table 3, dz
    res = accuracy_analysis(alwan, alwan.trajectory, alwan.leg_deformations)
    du = res.linearized[:, :3].T * 1e3
    np.testing.assert_allclose(du.min(axis=1), [1.460, 0.687, -0.288], atol=1e-3)
    np.testing.assert_allclose(du.max(axis=1), [2.343, 0.927, 0.552], atol=1e-3)
    ratio = printed[0] / du[0]
    assert (ratio.min(), ratio.max()) == pytest.approx((0.078, 0.147), abs=1e-3)
    rv = np.degrees(np.abs(res.linearized_twist[:, 3:]))
    assert (rv.min(), rv.max()) == pytest.approx((0.024, 0.119), abs=1e-3)


def test_exact_minus_linearized_is_second_order(alwan):
    rng = np.random.default_rng(11)
    ds, da, db = rng.normal(size=6), rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    pose = alwan.trajectory[3]
    diffs, lins = [], []
    for eps in (1e-3, 1e-4, 1e-5):
        res = accuracy_analysis(alwan, pose, ds * eps, {'A_i': da * eps, 'B_i': db * eps})
        diffs.append(np.max(np.abs(res.difference)))
        lins.append(np.max(np.abs(res.linearized)))
    assert lins[0] / lins[1] == pytest.approx(10, rel=1e-9)
    assert 70 < diffs[0] / diffs[1] < 130 and 70 < diffs[1] / diffs[2] < 130


def test_singular_pose_is_detected_and_refused(alwan):
    flat = np.array([0.0, 0.0, 0.0, 0.1, 0.0, 0.0])     # platform in the base plane: every leg horizontal
    assert alwan.is_singular(flat)[0]
    assert alwan.report(flat).singular
    with pytest.raises(SingularityError, match='singular'):
        linearized_deviation(alwan, flat, np.full(6, 1e-4))
    assert not alwan.is_singular(alwan.trajectory).any()


def test_yaml_validation():
    base = {'type': 'stewart_6sps', 'base_radius': 1.2, 'base_azimuths': [0, 1, 2, 3, 4, 5],
            'platform_radius': 0.4, 'platform_azimuths': [0, 1, 2, 3, 4, 5]}
    mech = mechanism_from_dict(dict(base, workspace={'box': {}}), 's.yaml')
    assert mech.euler_convention == 'ZXZ'
    with pytest.raises(ConfigError, match=r's\.yaml: base_azimuths must be a list of 6 finite numbers'):
        mechanism_from_dict(dict(base, base_azimuths=[0, 1]), 's.yaml')
    with pytest.raises(ConfigError, match=r's\.yaml: platform_radius must be a positive'):
        mechanism_from_dict(dict(base, platform_radius=0), 's.yaml')
    with pytest.raises(ConfigError, match='leg_min = 2.0 must be below leg_max = 1.0'):
        mechanism_from_dict(dict(base, leg_min=2.0, leg_max=1.0), 's.yaml')
    with pytest.raises(ConfigError, match='leg_min = 1.0 must be below leg_max = 1.0'):
        mechanism_from_dict(dict(base, leg_min=1.0, leg_max=1.0), 's.yaml')
    for given, missing in (('leg_max', 'leg_min'), ('leg_min', 'leg_max')):        # one end alone is refused
        with pytest.raises(ConfigError, match=f's.yaml: missing key {missing}'):
            mechanism_from_dict(dict(base, **{given: 1.5}), 's.yaml')
    limited = mechanism_from_dict(dict(base, leg_min=1.0, leg_max=2.5), 's.yaml')
    assert np.asarray(limited.joint_limits).tolist() == [[1.0, 2.5]] * 6
    with pytest.raises(InputError, match='joint errors must be 6 finite values'):
        accuracy_analysis(mech, [0, 0, 1, 0, 0.3, 0], [1e-3, 2e-3])
    with pytest.raises(InputError, match="unknown geometric parameter 'C_i'; allowed: A_i, B_i"):
        accuracy_analysis(mech, [0, 0, 1, 0, 0.3, 0], None, {'C_i': np.zeros((6, 3))})


def test_euler_deviations_next_to_the_gimbal_lock_are_flagged(alwan):
    """Next to the Z-X-Z lock (theta -> 0) the linearised psi and phi deviations grow without bound while the rotation
    barely changes (theta = 1e-4: 21 rad each for a rotation of 2.6 mrad), and were given without a word. The result
    now warns for every pose within EULER_LOCK_WARNING = 0.1 rad of the lock: Alwan's point 1 (theta = 2 deg),
    not points 2-6 (theta 10-12.7 deg)."""
    from gpr_kinematics.mechanisms.accuracy import EULER_LOCK_WARNING, euler_lock_distance
    assert EULER_LOCK_WARNING == 0.1
    theta = alwan.trajectory[:, 4]
    np.testing.assert_allclose(euler_lock_distance(alwan, alwan.trajectory), theta, rtol=1e-12)
    np.testing.assert_allclose(euler_lock_distance(alwan, [0, 0, 2, 0, math.pi - 0.03, 0]), [0.03], rtol=1e-9)
    res = accuracy_analysis(alwan, alwan.trajectory, alwan.leg_deformations)
    assert res.warnings == (
        'pose 1: B = 0.0349066 rad is 0.0349 rad from the gimbal lock of the ZXZ Euler angles (warned within 0.1 rad): '
        'the deviations of A and C are magnified up to about 28.7 times and are not meaningful there; read the '
        'rotation vector of the rigid motion (rx ry rz, base frame) instead',)
    assert res.report('stewart_6sps').warnings == res.warnings
    near = np.array([0.66, -0.35, 1.8, -0.0873, 1e-4, 0.0244])
    res = accuracy_analysis(alwan, near, alwan.leg_deformations)
    assert abs(res.linearized[0, 3]) > 20 and abs(res.linearized[0, 5]) > 20
    assert np.linalg.norm(res.linearized_twist[0, 3:]) < 3e-3
    assert len(res.warnings) == 1 and 'is 0.0001 rad from the gimbal lock' in res.warnings[0]
    assert 'magnified up to about 1e+04 times' in res.warnings[0]
    # roll-pitch-yaw (a GSP): the lock is at B = +-pi/2; the 3-UPU has no Euler coordinates
    gsp = load_mechanism(config_path('mechanisms/gsp_d3_6.yaml'))
    np.testing.assert_allclose(euler_lock_distance(gsp, [0.01, -0.01, 0.138, 0.1, 89 * DEG, 0.2]), [DEG], rtol=1e-9)
    assert accuracy_analysis(gsp, [0.01, -0.01, 0.138, 0.1, 0.2, 0.3], np.full(6, 1e-5)).warnings == ()
    upu = load_mechanism(config_path('mechanisms/upu3.yaml'))
    assert accuracy_analysis(upu, [0, 0, 0.2, 0, 0, 0], [1e-5, 0, 0]).warnings == ()


@pytest.mark.parametrize('prefix', ['base', 'platform'])
def test_joint_azimuths_in_degrees_are_refused(prefix):
    """A mechanism file is in radians only: ``platform_azimuths: [15, 90, ...]`` (the paper's degrees) put the joints
    at 15 and 90 rad modulo 2 pi, silently; refused naming the entry, the value and its radians. 6.2 rad passes, and
    the joint point is at the radius along it."""
    base = {'type': 'stewart_6sps', 'base_radius': 1.2, 'base_azimuths': [0, 1, 2, 3, 4, 5],
            'platform_radius': 0.4, 'platform_azimuths': [0, 1, 2, 3, 4, 5]}
    with pytest.raises(ConfigError, match=rf'^s\.yaml: {prefix}_azimuths\[1\] = 90 rad is beyond one turn; allowed: '
                                          r'\[-2pi, 2pi\] rad \(radians only here: 90 deg is 1.57079633 rad\)$'):
        mechanism_from_dict(dict(base, **{f'{prefix}_azimuths': [0, 90, 2, 3, 4, 5]}), 's.yaml')
    mech = mechanism_from_dict(dict(base, **{f'{prefix}_azimuths': [0, 6.2, 2, 3, 4, 5]}), 's.yaml')
    r = base[f'{prefix}_radius']
    point = mech.constraints[1].A_i if prefix == 'base' else mech.constraints[1].B_i
    np.testing.assert_allclose(point, [r * math.cos(6.2), r * math.sin(6.2), 0.0], atol=1e-15)


def test_two_legs_between_the_same_joints_are_refused():
    """Legs 1 and 2 both from base azimuth 0 to platform azimuth 0 loaded and answered every pose as singular
    (condition number 1.7e16); refused at load naming both legs. A leg sharing only its base joint is allowed (the
    paper's pairs share joints), as is the same leg moved by 1e-6 m."""
    base = {'type': 'stewart_6sps', 'base_radius': 1.2, 'base_azimuths': [0, 1, 2, 3, 4, 5],
            'platform_radius': 0.4, 'platform_azimuths': [0.5, 1.5, 2.5, 3.5, 4.5, 5.5]}
    twice = dict(base, base_azimuths=[0, 0, 2, 3, 4, 5], platform_azimuths=[0.5, 0.5, 2.5, 3.5, 4.5, 5.5])
    with pytest.raises(ConfigError, match=r'^s\.yaml.*constraints 1 and 2 \(s1, s2\) are one D1 between the same '
                                          r'points .*allowed: six distinct constraints$'):
        mechanism_from_dict(twice, 's.yaml')
    mechanism_from_dict(dict(base, base_azimuths=[0, 0, 2, 3, 4, 5]), 's.yaml')
    mechanism_from_dict(dict(twice, platform_azimuths=[0.5, 0.5 + 2.5e-6, 2.5, 3.5, 4.5, 5.5]), 's.yaml')

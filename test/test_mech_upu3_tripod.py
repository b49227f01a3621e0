"""3-UPU (Aboulissane & El Bakkali 2015) and 3-RPS tripod (Posypkin et al.)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from gpr_kinematics.errors import ConfigError, InputError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.mechanisms import load_mechanism, mechanism_from_dict
from gpr_kinematics.mechanisms.accuracy import accuracy_analysis
from gpr_kinematics.mechanisms.dexterity import dexterity_grid, dexterity_sweep, plot_dexterity
from gpr_kinematics.mechanisms.tripod import Tripod3RPS, parasitic_motion
from gpr_kinematics.mechanisms.upu3 import UPU3


@pytest.fixture(scope='module')
def upu():
    return load_mechanism(config_path('mechanisms/upu3.yaml'))


@pytest.fixture(scope='module')
def tripod():
    return load_mechanism(config_path('mechanisms/tripod_3rps.yaml'))


# ---------------------------------------------------------------- 3-UPU
def test_upu_inverse_kinematics_eq6(upu):
    assert (upu.b, upu.p) == (0.2, 0.17)
    np.testing.assert_allclose(upu.joint_limits, [[0.17, 0.27]] * 3)
    h = np.array([0.01, -0.02, 0.2])
    pose = np.concatenate([h, [0.3, 0.2, 0.1]])          # angles are ignored: the platform only translates
    u = upu.base_points - upu.platform_points             # eq. (3)
    expected = np.sqrt(np.sum((h - u) ** 2, axis=1))      # eq. (6)
    np.testing.assert_allclose(upu.inverse_kinematics(pose), expected, atol=1e-15)
    np.testing.assert_allclose(upu.complete_pose(pose)[3:], 0.0)
    # At the centre line every limb has length sqrt((b - p)^2 + z^2).
    np.testing.assert_allclose(upu.inverse_kinematics([0, 0, 0.2, 0, 0, 0]), np.hypot(0.03, 0.2), atol=1e-15)


def test_upu_jacobian_unit_limb_vectors(upu):
    rng = np.random.default_rng(5)
    poses = np.column_stack([rng.uniform(-0.03, 0.03, (6, 2)), rng.uniform(0.17, 0.25, 6), np.zeros((6, 3))])
    J = upu.unit_limb_jacobian(poses)
    np.testing.assert_allclose(np.linalg.norm(J, axis=-1), 1.0, atol=1e-15)
    h = 1e-7
    for k in range(3):
        d = np.zeros(6)
        d[k] = h
        fd = (upu.inverse_kinematics(poses + d) - upu.inverse_kinematics(poses - d)) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=1e-8)
    np.testing.assert_allclose(upu.task_jacobian(poses), J, atol=0)


def test_upu_singularities(upu):
    # Coplanar limbs: the platform in the base plane.
    assert upu.singularity([0.01, 0.02, 0.0, 0, 0, 0])[0] == 'coplanar'
    assert upu.is_singular([0.01, 0.02, 0.0, 0, 0, 0])[0]
    # Parallel limbs: identical base and platform, untranslated sideways.
    twin = UPU3(b=0.2, p=0.2, limb_min=0.1, limb_max=0.3)
    assert twin.singularity([0, 0, 0.2, 0, 0, 0])[0] == 'parallel'
    assert twin.singularity([0.05, -0.03, 0.2, 0, 0, 0])[0] == 'parallel'   # b = p: always parallel
    # Regular inside the workspace.
    assert upu.singularity([0.01, 0.02, 0.2, 0, 0, 0])[0] == ''
    assert not upu.is_singular([0.01, 0.02, 0.2, 0, 0, 0])[0]


def test_upu_dexterity_against_height_fig6(upu, tmp_path):
    z = np.linspace(0.17, 0.27, 21)
    dmap = dexterity_sweep(upu, np.zeros(6), 'z', z)
    a, c = np.sqrt(1.5) * (upu.b - upu.p), np.sqrt(3) * z
    np.testing.assert_allclose(dmap.dexterity, np.minimum(a, c) / np.maximum(a, c), atol=1e-14)
    assert np.all(np.diff(dmap.dexterity) < 0)            # falls with height (the paper's Fig. 6)
    assert dmap.within_limits[:-2].all()                  # the limbs stay in [170, 270] mm up to z ~ 0.268
    png = plot_dexterity(dmap, tmp_path / 'fig6.png')
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    grid = dexterity_grid(upu, np.zeros(6), 'x', np.linspace(-0.02, 0.02, 5), 'z', np.linspace(0.18, 0.25, 4))
    assert grid.dexterity.shape == (5, 4)
    np.testing.assert_allclose(grid.dexterity[2], dexterity_sweep(upu, np.zeros(6), 'z', grid.values2).dexterity)
    with pytest.raises(InputError, match="cannot vary 'A'"):
        dexterity_sweep(upu, np.zeros(6), 'A', [0.1])


def test_upu_accuracy_second_order(upu):
    pose = [0.01, 0.02, 0.21, 0, 0, 0]
    rng = np.random.default_rng(8)
    e, db = rng.normal(size=3), rng.normal(size=(3, 3))
    d = [np.max(np.abs(accuracy_analysis(upu, pose, e * eps, {'base_points': db * eps}).difference))
         for eps in (1e-4, 1e-5)]
    assert 70 < d[0] / d[1] < 130


def test_upu_yaml_errors():
    good = {'type': 'upu3', 'b': 0.2, 'p': 0.17, 'limb_min': 0.17, 'limb_max': 0.27}
    assert mechanism_from_dict(dict(good, workspace={'box': {}}), 'u.yaml').n_joints == 3
    with pytest.raises(ConfigError, match=r'u\.yaml: b must be a positive finite length'):
        mechanism_from_dict(dict(good, b=-1), 'u.yaml')
    with pytest.raises(ConfigError, match=r'u\.yaml: limb_min = 0\.3 must be below limb_max = 0\.27'):
        mechanism_from_dict(dict(good, limb_min=0.3), 'u.yaml')
    with pytest.raises(ConfigError, match=r'u\.yaml: missing key p'):
        mechanism_from_dict({k: v for k, v in good.items() if k != 'p'}, 'u.yaml')



@pytest.mark.parametrize('data, where, message', [
    ({'type': 'upu3', 'b': 0.2, 'p': 0.17, 'limb_min': 0.3, 'limb_max': 0.27}, 'u.yaml: ',
     'limb_min = 0.3 must be below limb_max = 0.27 (m); allowed: limb_min < limb_max'),
    ({'type': 'tripod_3rps', 'base_radius': 0.05, 'platform_radius': 0.05, 'leg_min': 0.13, 'leg_max': 0.13},
     'u.yaml: ', 'leg_min = 0.13 must be below leg_max = 0.13 (m); allowed: leg_min < leg_max'),
])
def test_a_stroke_upside_down_names_the_rule_in_the_file_and_in_the_constructor(data, where, message):
    """Both three-leg mechanisms refuse ``min >= max`` from a file (naming it) and from their constructor with one
    rule (it named what was wrong, not what is allowed)."""
    with pytest.raises(ConfigError) as err:
        mechanism_from_dict(data, 'u.yaml')
    assert str(err.value) == where + message
    cls = {'upu3': UPU3, 'tripod_3rps': Tripod3RPS}[data['type']]
    with pytest.raises(ConfigError) as err:
        cls(**{k: v for k, v in data.items() if k != 'type'})   # the file's keys are the constructor's
    assert str(err.value) == message


def test_the_legs_of_both_mechanisms_lie_on_their_circles():
    """The joints of the 3-UPU and of the tripod at their azimuths on circles of their radii (independent: the
    radius and the angle of each joint), the limits the stroke, the characteristic length the platform's radius."""
    upu = mechanism_from_dict({'type': 'upu3', 'b': 0.2, 'p': 0.17, 'limb_min': 0.17, 'limb_max': 0.27,
                               'base_azimuths': [0.1, 2.0, 4.0]}, 'u.yaml')
    tri = mechanism_from_dict({'type': 'tripod_3rps', 'base_radius': 0.06, 'platform_radius': 0.05,
                               'leg_min': 0.07, 'leg_max': 0.13}, 't.yaml')
    for m, (rb, rp), az, stroke in ((upu, (0.2, 0.17), [0.1, 2.0, 4.0], (0.17, 0.27)),
                                    (tri, (0.06, 0.05), [0.0, 2 * math.pi / 3, 4 * math.pi / 3], (0.07, 0.13))):
        for pts, r in ((m.base_points, rb), (m.platform_points, rp)):
            np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1]), r, rtol=1e-15)
            np.testing.assert_allclose(np.unwrap(np.arctan2(pts[:, 1], pts[:, 0])), az, atol=1e-15)
            assert np.all(pts[:, 2] == 0.0)
        np.testing.assert_array_equal(m.joint_limits, [stroke] * 3)
        assert m.characteristic_length == rp


# ---------------------------------------------------------------- 3-RPS tripod
def _paper_rotation(theta, psi, phi):
    """Eq. (3) of Posypkin et al. for the tripod, element by element."""
    ct, st, cp, sp, cf, sf = np.cos(theta), np.sin(theta), np.cos(psi), np.sin(psi), np.cos(phi), np.sin(phi)
    return np.array([[ct * cf + sp * st * sf, -ct * sf + sp * st * cf, st * cp],
                     [cp * sf, cp * cf, -sp],
                     [-st * cf + sp * ct * sf, st * sf + sp * ct * cf, ct * cp]])


def test_tripod_parasitic_motion_and_rotation(tripod):
    assert (tripod.base_radius, tripod.platform_radius) == (0.05, 0.05)
    np.testing.assert_allclose(tripod.joint_limits, [[0.07, 0.13]] * 3)
    rng = np.random.default_rng(9)
    for theta, psi in rng.uniform(-0.5, 0.5, (6, 2)):
        pose = tripod.complete_pose([0, 0, 0.1, theta, psi, 0])
        phi, x, y = parasitic_motion(theta, psi, 0.05)
        np.testing.assert_allclose(pose, [x, y, 0.1, theta, psi, phi], atol=1e-15)
        np.testing.assert_allclose(tripod.rotation(pose)[0], _paper_rotation(theta, psi, phi), atol=1e-15)
        R = _paper_rotation(theta, psi, phi)
        # Eq. (5): leg 1 (in the xz plane).
        L1 = np.hypot(x + 0.05 * R[0, 0] - 0.05, 0.1 + 0.05 * R[2, 0])
        assert tripod.inverse_kinematics(pose)[0] == pytest.approx(L1, abs=1e-15)
    assert parasitic_motion(0.0, 0.3, 0.05)[0] == 0.0 and parasitic_motion(0.2, 0.0, 0.05)[0] == 0.0


def test_tripod_eq7_as_printed_is_the_leg_at_120_deg_and_eq6_mixes_legs(tripod):
    """Posypkin et al.'s eq. (7) as printed is the length of the leg at 120 deg; eq. (6) has the x term of a leg at
    60 deg (both signs turned) with the y and z terms of the leg at 240 deg, so it is no leg's length."""
    r = big_r = 0.05
    h3 = np.sqrt(3.0)
    rng = np.random.default_rng(11)
    for theta, psi in rng.uniform(-0.5, 0.5, (6, 2)):
        pose = tripod.complete_pose([0, 0, 0.1, theta, psi, 0])
        x, y, z = pose[:3]
        R = _paper_rotation(theta, psi, pose[5])
        eq6 = np.sqrt((x + 0.5 * r * (R[0, 0] + h3 * R[0, 1]) - 0.5 * big_r) ** 2
                      + (y - 0.5 * r * (R[1, 0] + h3 * R[1, 1]) + h3 / 2 * big_r) ** 2
                      + (z - 0.5 * r * (R[2, 0] + h3 * R[2, 1])) ** 2)
        eq7 = np.sqrt((x - 0.5 * r * (R[0, 0] - h3 * R[0, 1]) + 0.5 * big_r) ** 2
                      + (y - 0.5 * r * (R[1, 0] - h3 * R[1, 1]) - h3 / 2 * big_r) ** 2
                      + (z - 0.5 * r * (R[2, 0] - h3 * R[2, 1])) ** 2)
        legs = tripod.inverse_kinematics(pose)               # legs at 0, 120, 240 deg
        assert eq7 == pytest.approx(legs[1], abs=1e-15)
        # eq. (6)'s x term is the leg at 240 deg's with r and R negated: x - r/2 (..) + R/2 became x + r/2 (..) - R/2
        x240 = x - 0.5 * r * (R[0, 0] + h3 * R[0, 1]) + 0.5 * big_r
        x_eq6 = x + 0.5 * r * (R[0, 0] + h3 * R[0, 1]) - 0.5 * big_r
        assert eq6 ** 2 - legs[2] ** 2 == pytest.approx(x_eq6 ** 2 - x240 ** 2, abs=1e-15)
        assert abs(x_eq6 - x240) > 1e-6 and abs(eq6 - legs[2]) > 1e-9   # tilted: the two x terms differ


def test_tripod_spherical_joints_lie_in_leg_planes(tripod):
    rng = np.random.default_rng(10)
    poses = np.column_stack([np.zeros((200, 2)), rng.uniform(0.05, 0.12, 200), rng.uniform(-1.0, 1.0, (200, 2)),
                             np.zeros(200)])
    assert np.max(np.abs(tripod.plane_residuals(poses))) < 1e-15
    # Without the parasitic motions the joints leave their planes.
    R = tripod.rotation(np.column_stack([poses[:, :5], np.zeros(200)]))
    P = np.einsum('nij,kj->nki', R, tripod.platform_points)
    normal = np.column_stack([-np.sin([0, 2 * np.pi / 3, 4 * np.pi / 3]), np.cos([0, 2 * np.pi / 3, 4 * np.pi / 3]),
                              np.zeros(3)])
    assert np.max(np.abs(np.einsum('nki,ki->nk', P, normal))) > 1e-3


def test_tripod_task_jacobian_matches_finite_differences(tripod):
    rng = np.random.default_rng(12)
    poses = np.column_stack([np.zeros((5, 2)), rng.uniform(0.08, 0.11, 5), rng.uniform(-0.4, 0.4, (5, 2)),
                             np.zeros(5)])
    J = tripod.task_jacobian(poses)
    h = 1e-7
    for k, idx in enumerate((2, 3, 4)):
        d = np.zeros(6)
        d[idx] = h
        fd = (tripod.inverse_kinematics(poses + d) - tripod.inverse_kinematics(poses - d)) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=1e-8)
    assert np.all(tripod.condition_number(poses) < 10)


def test_tripod_accuracy_second_order_and_limits(tripod):
    pose = [0, 0, 0.1, 0.1, -0.15, 0]
    d = [np.max(np.abs(accuracy_analysis(tripod, pose, np.array([1.0, -0.5, 0.3]) * eps).difference))
         for eps in (1e-4, 1e-5)]
    assert 70 < d[0] / d[1] < 130
    with pytest.raises(InputError, match=r'joint L1 = .* is outside its limits \[0\.07, 0\.13\] m'):
        tripod.check_limits(tripod.inverse_kinematics([0, 0, 0.2, 0, 0, 0]))


def test_upu3_parameters_of_the_wrong_size_are_refused():
    m = load_mechanism('upu3.yaml')
    with pytest.raises(InputError, match=r'parameter base_points must be 9 numbers \(3 points x, y, z\) \[m\]; got 8'):
        m.with_parameters({'base_points': [0.1] * 8})
    moved = m.with_parameters({'base_points': (m.base_points + 1e-3).ravel().tolist()})
    np.testing.assert_allclose(moved.base_points, m.base_points + 1e-3, rtol=0, atol=0)


def test_dexterity_maps_count_and_check_their_values_before_converting():
    """range(10**12) ran out of memory in np.asarray; strings were bare ValueErrors."""
    from gpr_kinematics.errors import InputError
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.mechanisms import load_mechanism

    upu = load_mechanism(config_path('mechanisms/upu3.yaml'))
    home = [0.0, 0.0, 0.2, 0.0, 0.0, 0.0]
    with pytest.raises(InputError, match=r'dexterity along z: 1000000000000 poses; allowed: at most'):
        dexterity_sweep(upu, home, 'z', range(10 ** 12))
    with pytest.raises(InputError, match=r'dexterity on a 1000000 x 2000 grid: 2000000000 poses'):
        dexterity_grid(upu, home, 'x', range(10 ** 6), 'y', range(2000))
    with pytest.raises(InputError, match=r'values of z must be numbers'):
        dexterity_sweep(upu, home, 'z', 'abc')
    with pytest.raises(InputError, match=r'values of z = \[nan\]; allowed: finite values'):
        dexterity_sweep(upu, home, 'z', [np.nan])
    assert dexterity_sweep(upu, home, 'z', range(1)).dexterity.shape == (1,)


# (1 - 4 pi, two turns away, is refused in a file before: an azimuth beyond one turn is degrees)
@pytest.mark.parametrize('azimuths', [[0.0, 0.0, 2.0], [0.0, 2 * math.pi, 2.0], [1.0, 3.0, 1.0 - 2 * math.pi]])
def test_upu3_limbs_sharing_an_azimuth_are_refused(azimuths):
    """base_azimuths [0, 0, 0] was taken: three limbs on one joint pair (a Jacobian of rank 1 everywhere, a
    'workspace' of one limb's shell); azimuths equal modulo 2 pi are refused, named, in the loader and the class."""
    data = {'type': 'upu3', 'b': 0.2, 'p': 0.17, 'limb_min': 0.17, 'limb_max': 0.27, 'base_azimuths': azimuths}
    with pytest.raises(ConfigError, match=r'<dict>: base_azimuths \[.*\] rad: limbs [12] and [23] share an azimuth '
                                          r'\(mod 2 pi\), one joint pair for two limbs; allowed: three azimuths at '
                                          r'least 1e-06 rad apart modulo 2 pi'):
        mechanism_from_dict(data)
    with pytest.raises(ConfigError, match=r'^base_azimuths \[.*\] rad: limbs [12] and [23] share an azimuth'):
        UPU3(azimuths=azimuths)


@pytest.mark.parametrize('azimuths, limbs, apart', [
    ([0.0, 1e-9, 2.0], (1, 2), [0.0, 1.5e-6, 2.0]),
    ([0.0, 2.0, 2 * math.pi - 5e-7], (1, 3), [0.0, 2.0, 2 * math.pi - 1.5e-6]),
    ([1.0, 3.0, 3.0 + 9e-7], (2, 3), [1.0, 3.0, 3.0 + 1.1e-6]),
])
def test_upu3_limbs_nearly_sharing_an_azimuth_are_refused(azimuths, limbs, apart):
    """Not only equal azimuths: any two closer than AZIMUTH_GAP (1e-6 rad) modulo 2 pi are one joint pair to the
    Jacobian's rank; two just farther apart are three limbs."""
    from gpr_kinematics.mechanisms.upu3 import AZIMUTH_GAP, check_azimuths

    assert AZIMUTH_GAP == 1e-6
    i, j = limbs
    with pytest.raises(ConfigError) as info:
        UPU3(azimuths=azimuths)
    assert str(info.value) == (f'base_azimuths {np.round(azimuths, 9).tolist()} rad: limbs {i} and {j} share an '
                               'azimuth (mod 2 pi), one joint pair for two limbs; allowed: three azimuths at least '
                               '1e-06 rad apart modulo 2 pi (the paper: 120 deg apart)')
    np.testing.assert_array_equal(check_azimuths(apart), apart)


@pytest.mark.filterwarnings('error')
def test_a_tilt_of_half_a_turn_about_one_axis_is_singular_in_a_map_and_named_elsewhere(tripod):
    """At theta = 180 deg, psi = 0 the parasitic phi is 0 / 0: the map of theta over -180..180 deg (its ends exactly
    there) was refused whole, with a RuntimeWarning, as 'poses must be finite numbers; got [nan nan 0.1 3.14159265 0
    nan]', tilts the user gave finite. The map marks those poses singular (dexterity 0, outside the limits, x y phi
    NaN) and keeps the others as they were; a single pose is refused naming the tilts."""
    from gpr_kinematics.errors import SingularityError
    values = np.linspace(-math.pi, math.pi, 5)
    sweep = dexterity_sweep(tripod, [0, 0, 0.1, 0, 0, 0], 'theta', values)
    inner = dexterity_sweep(tripod, [0, 0, 0.1, 0, 0, 0], 'theta', values[1:-1])
    assert sweep.singular.tolist() == [True, *inner.singular.tolist(), True]
    assert sweep.dexterity[[0, 4]].tolist() == [0.0, 0.0] and np.isinf(sweep.condition_number[[0, 4]]).all()
    assert not sweep.within_limits[[0, 4]].any() and np.array_equal(sweep.dexterity[1:4], inner.dexterity)
    assert np.isnan(sweep.poses[0, [0, 1, 5]]).all() and sweep.poses[0, [2, 3, 4]].tolist() == [0.1, -math.pi, 0]
    grid = dexterity_grid(tripod, [0, 0, 0.1, 0, 0, 0], 'theta', [math.pi], 'psi', [0.0])   # nothing to complete
    assert grid.singular.tolist() == [[True]] and grid.dexterity.tolist() == [[0.0]]
    assert tripod.undetermined([[0, 0, 0.1, 0, math.pi, 0], [0, 0, 0.1, 3.0, 0, 0]]).tolist() == [True, False]
    message = (r'3-RPS tripod \(Posypkin et al.\): at theta = 3.14159 rad, psi = 0 rad the parasitic rotation phi is '
               r'not determined \(sin psi sin theta = 0 = cos psi \+ cos theta: .*\); allowed: tilts where cos psi \+ '
               r'cos theta or sin psi sin theta is not 0')
    with pytest.raises(SingularityError, match=message):
        tripod.report([0, 0, 0.1, math.pi, 0, 0])
    with pytest.raises(SingularityError, match=r'psi = 3.14159 rad \(pose 2\) the parasitic rotation'):
        accuracy_analysis(tripod, [[0, 0, 0.1, 0, 0, 0], [0, 0, 0.1, 0, math.pi, 0]], [1e-3, 0, 0])


def test_upu3_azimuths_in_degrees_are_refused():
    """``base_azimuths: [90, 210, 330]`` (the paper's degrees) in a file in radians passed as three distinct angles
    modulo 2 pi, a wrong machine silently; refused naming the entry and its radians; 6.2 rad passes."""
    data = dict(load_yaml_data(), base_azimuths=[90, 210, 330])
    with pytest.raises(ConfigError, match=r'^u\.yaml: base_azimuths\[0\] = 90 rad is beyond one turn; allowed: '
                                          r'\[-2pi, 2pi\] rad \(radians only here: 90 deg is 1.57079633 rad\)$'):
        mechanism_from_dict(data, 'u.yaml')
    mech = mechanism_from_dict(dict(data, base_azimuths=[6.2, 2.0, 4.0]), 'u.yaml')
    np.testing.assert_array_equal(mech.azimuths, [6.2, 2.0, 4.0])


def load_yaml_data():
    from gpr_kinematics.inputs.schema import read_yaml
    return dict(read_yaml(config_path('mechanisms/upu3.yaml')))


def test_upu3_file_without_azimuths_places_the_limbs_120_degrees_apart_like_the_workspace_model():
    """Without ``base_azimuths`` the limbs sit at 90, 210 and 330 deg (the paper's 120 deg spacing), the defaults of
    the workspace model too: both give the same limb lengths."""
    from gpr_kinematics.workspace.upu3 import Upu3Model
    data = {'type': 'upu3', 'b': 0.2, 'p': 0.17, 'limb_min': 0.17, 'limb_max': 0.27}
    mech = mechanism_from_dict(data, 'u.yaml')
    np.testing.assert_allclose(mech.azimuths, np.radians([90.0, 210.0, 330.0]), rtol=0, atol=1e-15)
    model = Upu3Model(b=0.2, p=0.17, limb_min=0.17, limb_max=0.27)
    pts = np.array([[0.01, -0.02, 0.2], [0.0, 0.0, 0.25], [-0.03, 0.01, 0.18]])
    poses = np.column_stack([pts, np.zeros((3, 3))])               # translational: no rotation
    np.testing.assert_allclose(mech.inverse_kinematics(poses), model.evaluate(pts), atol=1e-15)


def test_a_dexterity_record_writes_an_infinite_condition_number_as_inf(tripod):
    """The tripod at z = 0 (legs of zero length) is singular, its condition number infinite: the record that
    ``gpr dexterity --json`` prints holds inf there (JSON's "inf", as every command's; it was -1, then null) and the
    finite ones as they are."""
    from gpr_kinematics.cli.output import jsonable
    dmap = dexterity_sweep(tripod, [0, 0, 0.1, 0, 0, 0], 'z', [0.0, 0.05, 0.1])
    assert dmap.singular.tolist() == [True, False, False] and np.isinf(dmap.condition_number[0])
    record = dmap.record('tripod_3rps')
    assert record.condition_number[0] == np.inf and jsonable(record)['condition_number'][0] == 'inf'
    assert record.condition_number[1:].tolist() == dmap.condition_number[1:].tolist()
    assert all(c >= 1.0 for c in record.condition_number[1:])


def test_mechanisms_without_euler_angles_are_never_near_a_gimbal_lock(upu, tripod):
    """The 3-UPU and the tripod have no three Euler angles among their pose coordinates: their distance from a
    gimbal lock is the largest there is, pi/2, whatever the pose, and their accuracy results carry no warning."""
    from gpr_kinematics.mechanisms.accuracy import euler_lock_distance
    poses = np.array([[0.0, 0.0, 0.2, 0.0, 0.0, 0.0], [0.01, -0.02, 0.22, 0.0, 0.0, 0.0]])
    assert euler_lock_distance(upu, poses).tolist() == [math.pi / 2] * 2
    assert euler_lock_distance(tripod, [0, 0, 0.1, 0, 0.3, 0]).tolist() == [math.pi / 2]
    assert accuracy_analysis(upu, poses[1], joint_errors=[1e-5] * 3).warnings == ()


def test_forward_kinematics_from_unreachable_joints_says_it_diverged():
    """Limb lengths of 0.5, 0.1, 0.1 m (no pose has them) made Newton's iterate run off to 3e6 and the refusal named
    that iterate as bad 'coordinates' the user never gave: it now says the solve diverged and which joint values."""
    from gpr_kinematics.errors import ConvergenceError
    m = load_mechanism(config_path('mechanisms/upu3.yaml'))
    with pytest.raises(ConvergenceError, match=r'diverged for pose 0: the joint values \[0.5, 0.1, 0.1\] are out of '
                                               r'reach'):
        m.forward_kinematics([0.5, 0.1, 0.1], [0, 0, 0.2, 0, 0, 0])
    pose = np.array([0.01, -0.02, 0.2, 0.0, 0.0, 0.0])  # a reachable pose is still found from the same guess
    got = m.forward_kinematics(m.inverse_kinematics(pose), [0, 0, 0.2, 0, 0, 0])
    np.testing.assert_allclose(got[0], pose, atol=1e-10)

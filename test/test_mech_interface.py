"""The common Mechanism interface on every packaged mechanism: shapes, Jacobians against differences."""
from __future__ import annotations

import math
import re
import zlib

import numpy as np
import pytest
from gpr_kinematics.errors import InputError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.mechanisms import MECHANISM_TYPES, load_mechanism

FILES = {
    'gsp_d3_6.yaml': [0.01, -0.01, 0.138, 0.0873, -0.0873, -0.1745],
    'gsp_d1d2d3d4a1a1.yaml': [0.007, -0.008, 0.124, 0.0349, 0.0873, -0.0873],
    'stewart_alwan.yaml': [0.07, -0.09, 1.85, -0.1745, 0.1745, 0.0454],
    'upu3.yaml': [0.01, 0.02, 0.2, 0.0, 0.0, 0.0],
    'tripod_3rps.yaml': [0.0, 0.0, 0.1, 0.12, -0.2, 0.0],
    'gpr.yaml': [0.0, 0.0, 0.3, 0.02, -0.01, 0.0],
}


def test_every_type_has_a_packaged_example():
    kinds = {load_mechanism(config_path(f'mechanisms/{name}')).kind for name in FILES}
    assert kinds == set(MECHANISM_TYPES)


@pytest.mark.parametrize('name', sorted(FILES))
def test_interface_shapes_and_coordinate_jacobian(name):
    mech = load_mechanism(config_path(f'mechanisms/{name}'))
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    idx = mech.variable_indices
    base = np.array(FILES[name])
    poses = np.repeat(base[None], 3, axis=0)
    poses[:, idx] += rng.uniform(-1, 1, (3, idx.size)) * np.where(idx < 3, 2e-3, 5e-3)
    n, m = mech.n_joints, len(mech.pose_variables)
    assert mech.coordinate_jacobian(poses).shape == (3, n, m) and mech.motion_basis(poses).shape == (3, 6, m)
    assert mech.inverse_kinematics(poses).shape == (3, n)
    assert mech.inverse_kinematics(poses[0]).shape == (n,)
    assert mech.inverse_jacobian(poses).shape == (3, n, 6)
    assert np.asarray(mech.joint_limits).shape == (n, 2)
    assert len(mech.joint_types) == n and mech.characteristic_length > 0
    assert mech.within_limits(mech.inverse_kinematics(poses)).all()
    # dq/du over the pose coordinates (Euler angles for six DOF) against central differences of the IK.
    J = mech.coordinate_jacobian(poses)
    h = 1e-6
    for k, i in enumerate(idx):
        d = np.zeros(6)
        d[i] = h
        fd = (mech.inverse_kinematics(poses + d) - mech.inverse_kinematics(poses - d)) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=2e-8, err_msg=f'{name}: column {mech.pose_variables[k]}')
    # Conditioning helpers agree with an SVD of the homogenised task Jacobian.
    sv = np.linalg.svd(mech.homogenized_task_jacobian(poses), compute_uv=False)
    np.testing.assert_allclose(mech.dexterity(poses), sv[:, -1] / sv[:, 0], rtol=1e-8)
    assert not mech.is_singular(poses).any()


@pytest.mark.parametrize('name', sorted(FILES))
@pytest.mark.parametrize('kwargs, words', [
    ({'tol': 0.0, 'max_iterations': 10 ** 9}, r'tol = 0.0 is invalid; allowed: a number from 1e-15 to 1'),
    ({'max_iterations': 10 ** 9}, r'max_iterations = 1000000000 is invalid; allowed: an integer from 1 to 1000'),
    ({'max_iterations': float('nan')}, r'max_iterations = nan is invalid'),
    ({'tol': 'a'}, r"tol = 'a' is invalid"),
])
def test_forward_kinematics_refuses_settings_that_never_end(name, kwargs, words):
    """tol = 0 with 1e9 iterations ran past 30 s on the six-joint mechanisms; a NaN count was a bare TypeError."""
    from gpr_kinematics.errors import InputError

    mech = load_mechanism(config_path(f'mechanisms/{name}'))
    pose = mech.complete_pose(np.array([FILES[name]]))
    with pytest.raises(InputError, match=words):
        mech.forward_kinematics(mech.inverse_kinematics(pose), pose, **kwargs)


@pytest.mark.parametrize('name', ['gsp_d3_6.yaml', 'upu3.yaml', 'gpr.yaml'])
@pytest.mark.parametrize('step', [0.0, -0.0, -1e-7, 1.0, float('nan'), 'a', 10 ** 400])
def test_parameter_jacobian_refuses_a_step_that_divides_by_zero(name, step):
    """step = 0 gave a Jacobian of NaN."""
    from gpr_kinematics.errors import InputError

    mech = load_mechanism(config_path(f'mechanisms/{name}'))
    with pytest.raises(InputError, match=r'step = .* is invalid; allowed: a number > 0 and at most 0.01'):
        mech.parameter_jacobian(FILES[name], next(iter(mech.parameters())), step=step)


@pytest.mark.parametrize('poses', ['a', [1j, 0, 0, 0, 0, 0], [10 ** 400, 0, 0, 0, 0, 0], [[0.0] * 6, [0.0] * 5]])
def test_poses_that_are_not_numbers_are_named(poses):
    from gpr_kinematics.errors import InputError

    mech = load_mechanism(config_path('mechanisms/stewart_alwan.yaml'))
    with pytest.raises(InputError, match='poses must be numbers'):
        mech.inverse_kinematics(poses)


@pytest.mark.parametrize('path', [None, 3])
def test_a_path_that_is_no_path_is_refused_as_load_config_refuses_it(path):
    """load_mechanism(None) and (3) raised a bare TypeError from os.fspath."""
    from gpr_kinematics.errors import ConfigError

    with pytest.raises(ConfigError) as err:
        load_mechanism(path)
    assert str(err.value) == (f'mechanism file path = {path}; allowed: a file path (str or Path) of a mechanism YAML '
                              'file, or the name of a packaged one such as upu3.yaml')


def test_conditioning_where_a_leg_has_zero_length_is_singular_not_an_error():
    """The 3-RPS tripod at z = 0 has legs of zero length: its Jacobian is NaN there (LAPACK raised)."""
    tripod = load_mechanism(config_path('mechanisms/tripod_3rps.yaml'))
    poses = np.array([[0.0] * 6, FILES['tripod_3rps.yaml']])
    dex = tripod.dexterity(poses)
    assert dex[0] == 0.0 and dex[1] == tripod.dexterity(poses[1:])[0] > 0.0
    assert tripod.condition_number(poses)[0] == np.inf and tripod.is_singular(poses).tolist() == [True, False]


def test_accuracy_of_a_pose_whose_joints_leave_the_bound_names_the_pose():
    """1000 km up the legs are longer than the bound of any value: the pose the user gave is named, before any solve
    (so the same on every CPU: whether ``dq/du`` there is singular to rounding is not)."""
    from gpr_kinematics.mechanisms.accuracy import accuracy_analysis

    stewart = load_mechanism(config_path('mechanisms/stewart_alwan.yaml'))
    with pytest.raises(InputError, match=r'the pose \[0.0, 0.0, 1000000.0, 0.0, 0.0, 0.0\] needs joint values of '
                                         r'1000000.0000\d*; allowed: poses whose joint values stay within '
                                         r'\+-1e\+06 \(SI\)'):
        accuracy_analysis(stewart, [0, 0, 1e6, 0, 0, 0], joint_errors=[1e-5] * 6)
    # among several poses, the one that leaves the bound is named (its joint values, not another pose's)
    with pytest.raises(InputError, match=r'the pose \[0.0, 0.0, 1000000.0, 0.0, 0.0, 0.0\] needs joint values of '
                                         r'1000000.0000\d*;'):
        accuracy_analysis(stewart, [[0, 0, 0.5, 0, 0, 0], [0, 0, 0.6, 0, 0, 0], [0, 0, 1e6, 0, 0, 0]],
                          joint_errors=[1e-5] * 6)
    assert accuracy_analysis(stewart, [0, 0, 0.5, 0, 0, 0], joint_errors=[1e-5] * 6).exact.shape == (1, 6)


def test_accuracy_where_the_jacobian_is_singular_to_rounding_names_the_pose(monkeypatch):
    """A ``dq/du`` that passes the conditioning check yet that LAPACK finds singular (it depends on the CPU's
    rounding: forced here) is a :class:`SingularityError` naming the pose."""
    from gpr_kinematics.errors import SingularityError
    from gpr_kinematics.mechanisms.accuracy import linearized_deviation

    stewart = load_mechanism(config_path('mechanisms/stewart_alwan.yaml'))
    pose = [0.0, 0.0, 0.5, 0.0, 0.3, 0.0]
    assert np.all(np.isfinite(linearized_deviation(stewart, pose, [1e-5] * 6)))

    def singular(*_):
        raise np.linalg.LinAlgError('Singular matrix')

    monkeypatch.setattr(np.linalg, 'solve', singular)
    with pytest.raises(SingularityError, match=r'singular to rounding at a pose of \[\[0.0, 0.0, 0.5, 0.0, 0.3, '):
        linearized_deviation(stewart, pose, [1e-5] * 6)


@pytest.mark.parametrize('name, lock, size', [('stewart_alwan.yaml', [0.0, 0.0, 1.8, 0.4, 0.0, -0.2], 1e-5),
                                              ('gsp_d3_6.yaml', [0.0, 0.0, 0.138, 0.1, math.pi / 2, 0.2], 1e-6)])
def test_accuracy_on_the_euler_angles_gimbal_lock(name, lock, size):
    """On the lock (Z-X-Z at B = 0, roll-pitch-yaw at B = 90 deg) the solve over the Euler coordinates gave +-8.4e12
    rad and the rigid motion built from them was wrong by 4e-4 m; the mechanism itself is regular there. Now the
    rigid motion is solved over twists: it equals an independent solve of the inverse Jacobian and the limit of poses
    approaching the lock, the exact deviation to second order; the angles' deviations are NaN, said so."""
    from gpr_kinematics.mechanisms.accuracy import accuracy_analysis, linearized_deviation, linearized_motion

    mech = load_mechanism(config_path(f'mechanisms/{name}'))
    ds = size * np.array([1.0, -2.0, 0.0, 3.0, 0.0, -1.0])   # joint errors [m] of the mechanism's size
    twist = np.linalg.solve(mech.inverse_jacobian([lock])[0], ds)   # independent of the Euler coordinates
    res = accuracy_analysis(mech, lock, ds)
    np.testing.assert_allclose(res.linearized_twist[0], twist, rtol=0, atol=1e-15)
    np.testing.assert_allclose(linearized_motion(mech, lock, ds)[0], twist, rtol=0, atol=1e-15)
    np.testing.assert_allclose(res.exact_twist[0], twist, rtol=0, atol=2e-3 * np.abs(twist).max())  # second order
    near = np.array(lock)
    near[4] += 1e-7
    np.testing.assert_allclose(accuracy_analysis(mech, near, ds).linearized_twist[0], twist, rtol=0, atol=1e-9)
    lin = linearized_deviation(mech, lock, ds)[0]
    np.testing.assert_allclose(lin[:3], twist[:3], rtol=0, atol=1e-15)
    assert np.isnan(lin[3:]).all()
    assert 'are not defined there (NaN); read the rotation vector' in res.warnings[0]
    # the exact deviations of the angles too (they printed -1.005 and +1.006 rad for a platform turned by 2 mrad)
    assert np.isnan(res.exact[0, 3:]).all() and np.isfinite(res.exact[0, :3]).all()
    np.testing.assert_allclose(res.exact[0, :3], res.exact_twist[0, :3], rtol=0, atol=1e-15)   # the position's own
    off = accuracy_analysis(mech, near, ds).exact[0]   # off the lock: defined
    assert np.isfinite(off).all()


@pytest.mark.parametrize('name', ['gsp_d1d2d3d4a1a1.yaml', 'stewart_alwan.yaml', 'upu3.yaml', 'tripod_3rps.yaml'])
@pytest.mark.parametrize('length', [1e-300, 1e-7, 1e300, 0, -0.1, float('nan'), True, 'a'])
def test_a_characteristic_length_out_of_range_is_refused_naming_it(name, length):
    """characteristic_length 1e-300 m divided the angular columns to 1e300: every dexterity map and gpr mechanism of
    the file ended in numpy's LinAlgError ('Eigenvalues did not converge'), 1e-150 read a regular pose as singular
    (gpr accuracy refused it), 1e300 passed for a GSP. It is a length from 1e-6 m to 1e6 m (the GPR core's least)."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.inputs.safe_yaml import read_file
    from gpr_kinematics.mechanisms import mechanism_from_dict
    data = read_file(config_path(f'mechanisms/{name}'), 'mechanism') | {'characteristic_length': length}
    with pytest.raises(ConfigError) as err:
        mechanism_from_dict(data, 'm.yaml')
    assert str(err.value).startswith('m.yaml: characteristic_length = ') and str(err.value).endswith(
        '; allowed: a length from 1e-06 to 1e+06 m (it homogenises the angular columns of the Jacobians)')
    for ok in (1e-6, 1e6):   # the bounds are allowed, and every map stays finite
        mech = mechanism_from_dict(data | {'characteristic_length': ok}, 'm.yaml')
        assert mech.characteristic_length == ok and np.isfinite(mech.condition_number(FILES[name])).all()


def test_a_default_characteristic_length_out_of_range_is_refused_naming_where_it_came_from():
    """The tripod's and the 3-UPU's default is the platform radius: 1e-300 m of it went through unchecked."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.mechanisms.tripod import Tripod3RPS
    from gpr_kinematics.mechanisms.upu3 import UPU3
    with pytest.raises(ConfigError, match=r'^tripod: characteristic_length \(platform_radius, when none is given\) = '
                                          r'1e-300; allowed: a length from 1e-06'):
        Tripod3RPS(platform_radius=1e-300, name='tripod')
    with pytest.raises(ConfigError, match=r'^upu: characteristic_length = 0; allowed'):   # 0 was the radius
        UPU3(characteristic_length=0, name='upu')
    assert UPU3(name='upu').characteristic_length == 0.17


@pytest.mark.parametrize('value, shown', [(1e6, '1e+06'), (-0.01000001, '-0.01000001')])
def test_a_parameter_error_beyond_a_centimetre_is_refused_by_the_api_too(value, shown):
    """The bound of gpr accuracy --parameter-error (0.01 m, a tolerance table's) held on the command line only:
    accuracy_analysis took 1e6 m and moved the GPR's platform by 333 km."""
    from gpr_kinematics.errors import InputError
    from gpr_kinematics.mechanisms.accuracy import PARAMETER_ERROR_MOST, accuracy_analysis

    mech = load_mechanism(config_path('mechanisms/gpr.yaml'))
    p = np.zeros((3, 3))
    p[1, 2] = value
    words = (rf'joint_imperfections: value 6 of 9 is {re.escape(shown)} m, beyond 0.01 m; allowed: errors of at '
             r'most 0.01 m')
    with pytest.raises(InputError, match=words):
        accuracy_analysis(mech, [0, 0, 0.5, 0.0349, 0, 0], None, {'joint_imperfections': p})
    p[1, 2] = PARAMETER_ERROR_MOST
    assert np.isfinite(accuracy_analysis(mech, [0, 0, 0.5, 0.0349, 0, 0], None,
                                         {'joint_imperfections': p}).exact_twist).all()

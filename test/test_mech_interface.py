"""The common Mechanism interface on every packaged mechanism: shapes, Jacobians against differences."""
from __future__ import annotations

import zlib

import numpy as np
import pytest
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

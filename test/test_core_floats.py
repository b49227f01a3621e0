"""One pose in floats (core/floats.py) against the batch forms (core/rotations.py): quaternions of rotations of every
pivot, matrices of quaternions, tilt rotations and rotation angles; compensation in floats against the numpy steps
it replaced, and the mobility analysis's one-pose Jacobian and rank against the batch's."""
import math

import numpy as np
import pytest
from gpr_kinematics.core.compensation import compensate
from gpr_kinematics.core.config import MODELS, load_config
from gpr_kinematics.core.floats import angle_between, matrix_of, quaternion_of, tilt_matrix
from gpr_kinematics.core.inverse import inverse
from gpr_kinematics.core.mobility import _closure_jacobian, analyze_mobility, rigid_rank
from gpr_kinematics.core.rotations import (
    matrix_from_quaternion,
    quaternion_from_matrix,
    rotation_angle,
    tilt_from_matrix,
    tilt_rotation,
)
from gpr_kinematics.core.virtual_joints import make_model
from scipy.spatial.transform import Rotation

CFG = load_config()


def _rows(R):
    return tuple(tuple(r) for r in np.asarray(R).tolist())


def _rotations(n, seed):
    """Random rotations, and the half turns about x, y, z and a diagonal near which each pivot of Shepperd's method
    is taken."""
    R = Rotation.random(n, random_state=seed).as_matrix()
    near = [Rotation.from_rotvec(a * (math.pi - 1e-3)).as_matrix() for a in np.eye(3)]
    near.append(Rotation.from_rotvec(np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0) * (math.pi - 1e-9)).as_matrix())
    return np.concatenate([R, np.array(near), np.eye(3)[None]])


def test_quaternion_of_a_rotation_equals_the_batch_for_every_pivot():
    R = _rotations(500, 1)
    batch = quaternion_from_matrix(R)
    pivots = set()
    for Ri, qi in zip(R, batch, strict=True):
        q = quaternion_of(_rows(Ri))
        np.testing.assert_allclose(q, qi, rtol=0, atol=2e-16)
        assert q[3] >= 0.0
        pivots.add(int(np.argmax([1 + np.trace(Ri), *(1 + 2 * Ri[k, k] - np.trace(Ri) for k in range(3))])))
    assert pivots == {0, 1, 2, 3}


def test_matrix_of_a_quaternion_equals_the_batch_and_inverts_quaternion_of():
    rng = np.random.default_rng(2)
    Q = rng.normal(size=(300, 4))
    Q[:100] /= np.linalg.norm(Q[:100], axis=1, keepdims=True)      # unit and not unit: both are normalised first
    batch = matrix_from_quaternion(Q)
    for q, Rb in zip(Q, batch, strict=True):
        R = matrix_of(tuple(q.tolist()))
        np.testing.assert_allclose(R, Rb, rtol=0, atol=4e-16)
        np.testing.assert_allclose(matrix_of(quaternion_of(R)), R, rtol=0, atol=2e-15)


def test_tilt_matrix_and_angle_between_equal_the_batch():
    rng = np.random.default_rng(3)
    t, g = rng.uniform(-0.1, 0.1, 200), rng.uniform(-4.0, 4.0, 200)
    T = tilt_rotation(t, g)
    for ti, gi, Ti in zip(t, g, T, strict=True):
        np.testing.assert_allclose(tilt_matrix(float(ti), float(gi)), Ti, rtol=0, atol=4e-16)
    A, B = _rotations(200, 4), _rotations(200, 5)
    angles = rotation_angle(A, B)
    for a, b, angle in zip(A, B, angles, strict=True):
        assert angle_between(_rows(a), _rows(b)) == pytest.approx(angle, rel=0, abs=1e-15)
    small = Rotation.from_rotvec([1e-9, -2e-9, 0.5e-9]).as_matrix()
    assert angle_between(_rows(np.eye(3)), _rows(small)) == pytest.approx(math.sqrt(5.25) * 1e-9, rel=1e-9)


def _compensate_by_arrays(position, quaternion, tool, cfg, model):
    """Compensation by the numpy steps the float path replaced (docs/core.md): q, the pose reached, the tool shift,
    the arm correction's translation and quaternion."""
    R_c = matrix_from_quaternion(quaternion)
    tilt, az, twist = (float(v) for v in tilt_from_matrix(R_c))
    commanded = position + R_c @ tool
    c, s = np.cos(twist), np.sin(twist)
    point = np.array([c * tool[0] - s * tool[1], s * tool[0] + c * tool[1], tool[2]])
    fk = inverse(float(commanded[2]), tilt, az, cfg, model, point).achieved
    return (fk.q, fk.position, fk.position + fk.rotation @ tool - commanded,
            fk.rotation.T @ (position - fk.position), quaternion_from_matrix(fk.rotation.T @ R_c))


@pytest.mark.parametrize('model', MODELS)
def test_compensation_in_floats_equals_the_numpy_steps(model):
    rng = np.random.default_rng(6)
    for _ in range(25):
        tilt, az, heading = rng.uniform(0.0, 0.03), rng.uniform(-4.0, 4.0), rng.uniform(-0.5, 0.5)
        quaternion = quaternion_from_matrix(tilt_rotation(tilt, az) @ Rotation.from_rotvec([0, 0, heading]).as_matrix())
        position, tool = np.array([0.01, -0.02, rng.uniform(0.3, 0.45)]), rng.uniform(-0.1, 0.1, 3)
        res = compensate(position, quaternion, tool, CFG, model)
        expect = _compensate_by_arrays(position, quaternion, tool, CFG, model)
        got = (res.q, res.achieved.position, res.tool_shift, res.arm_correction_translation,
               res.arm_correction_quaternion)
        for a, b in zip(got, expect, strict=True):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)


@pytest.mark.parametrize('model', MODELS)
def test_mobility_of_one_pose_uses_the_batch_jacobian_and_rank(model):
    vjm = make_model(CFG, model)
    for q in ([0.5, 0.5, 0.5], [0.45, 0.448, 0.452], [0.2, 0.2015, 0.199]):
        m = analyze_mobility(q, CFG, model)
        _, J, _ = vjm.closure(m.virtual_joints[None, :], np.zeros((1, 3)))
        np.testing.assert_array_equal(np.array(_closure_jacobian(vjm, m.virtual_joints.tolist())), J[0])
        np.testing.assert_array_equal(m.dphi_dx[9:], -J[0])
        assert m.rank_dphi_dp == int(rigid_rank(q, CFG)[0])

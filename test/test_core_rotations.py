"""The rotations of core/rotations.py checked against scipy's ``Rotation`` and against their definitions (a finite
difference for the Euler rates): rotation vectors both ways, the Hamilton product, URDF ``rpy``, planar rotation,
elementary and Euler rotations. Each form is an independent computation of the same rotation, so they agree to
rounding; batches are used so that an axis mix-up between samples would show."""
import math

import numpy as np
import pytest
from gpr_kinematics.core.floats import compose_one
from gpr_kinematics.core.rotations import (
    euler_rate_matrix,
    euler_rotation,
    quaternion_multiply,
    rodrigues,
    rotate_z,
    rotation_from_vector,
    rotation_vector,
    rpy_matrix,
    tilt_from_matrix,
    tilt_rotation,
    wrap_angle,
)
from scipy.spatial.transform import Rotation


def _vectors(seed):
    """Rotation vectors of random directions and angles from 1e-10 rad (the series branch) to 3 rad."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(40, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return d * np.geomspace(1e-10, 3.0, 40)[:, None]


def test_rotation_from_vector_and_rodrigues_equal_scipy_from_rotvec():
    """``exp([w]x)`` of a rotation vector is scipy's ``from_rotvec`` (an independent implementation); the batch
    and the float form agree with it to rounding, and ``rotation_vector`` inverts it."""
    W = _vectors(1)
    expect = Rotation.from_rotvec(W).as_matrix()
    np.testing.assert_allclose(rotation_from_vector(W), expect, rtol=0, atol=4e-16)
    for w, R in zip(W, expect, strict=True):
        np.testing.assert_allclose(rodrigues(*w.tolist()), R, rtol=0, atol=4e-16)
    np.testing.assert_allclose(rotation_vector(expect), W, rtol=1e-13, atol=1e-22)
    # Leading axes of any number: one vector (3,), a grid (2, 20, 3).
    np.testing.assert_allclose(rotation_from_vector(W[7]), expect[7], rtol=0, atol=4e-16)
    np.testing.assert_allclose(rotation_from_vector(W.reshape(2, 20, 3)), expect.reshape(2, 20, 3, 3), rtol=0,
                               atol=4e-16)
    # A quarter turn about z takes x to y (the sign of the skew matrix).
    np.testing.assert_allclose(rotation_from_vector(np.array([[0.0, 0.0, math.pi / 2]]))[0] @ [1.0, 0.0, 0.0],
                               [0.0, 1.0, 0.0], rtol=0, atol=4e-16)


def test_quaternion_multiply_is_the_product_of_rotations():
    """The Hamilton product of (x, y, z, w) quaternions is the quaternion of the product of their rotations, in a
    batch ``(N, 4)`` (scipy composes ``a * b`` as ``R_a R_b``)."""
    a, b = Rotation.random(30, random_state=2), Rotation.random(30, random_state=3)
    q = quaternion_multiply(a.as_quat(), b.as_quat())
    np.testing.assert_allclose(Rotation.from_quat(q).as_matrix(), a.as_matrix() @ b.as_matrix(), rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, rtol=0, atol=1e-15)


def test_rpy_matrix_is_the_urdf_fixed_axis_product():
    """URDF ``rpy`` is ``Rz(yaw) Ry(pitch) Rx(roll)``: scipy's extrinsic ``xyz`` Euler angles."""
    rng = np.random.default_rng(4)
    for roll, pitch, yaw in rng.uniform(-3.0, 3.0, (20, 3)):
        np.testing.assert_allclose(rpy_matrix(roll, pitch, yaw),
                                   Rotation.from_euler('xyz', [roll, pitch, yaw]).as_matrix(), rtol=0, atol=1e-15)


def test_rotate_z_turns_planar_vectors_counter_clockwise():
    """``rotate_z`` is the upper-left block of a rotation about z: lengths kept, (1, 0) at 30 deg goes to
    (cos 30, sin 30), (0, 1) to (-sin 30, cos 30)."""
    a = math.radians(30.0)
    out = rotate_z(np.array([a, a]), np.array([[1.0, 0.0], [0.0, 1.0]]))
    np.testing.assert_allclose(out, [[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]], rtol=0, atol=1e-16)
    xy = np.random.default_rng(5).normal(size=(10, 2))
    ang = np.linspace(-3.0, 3.0, 10)
    expect = Rotation.from_rotvec(np.c_[0 * ang, 0 * ang, ang]).apply(np.c_[xy, 0 * ang])[:, :2]
    np.testing.assert_allclose(rotate_z(ang, xy), expect, rtol=0, atol=1e-15)


@pytest.mark.parametrize('convention', ['xyz', 'zyx', 'zxz', 'yzy', 'XYZ', 'ZYX', 'ZXZ', 'XZX'])
def test_euler_rotation_equals_scipy_and_its_rates_a_finite_difference(convention):
    """``euler_rotation`` is ``Rotation.from_euler`` (every axis in every slot); ``euler_rate_matrix E`` gives the
    angular velocity in the base frame, ``[omega]x = R' R^T``, here from a central difference of ``R``."""
    rng = np.random.default_rng(6)
    ang = rng.uniform(-1.2, 1.2, (12, 3))
    R = euler_rotation(ang, convention)
    np.testing.assert_allclose(R, Rotation.from_euler(convention, ang).as_matrix(), rtol=0, atol=1e-15)
    rates = rng.normal(size=(12, 3))
    h = 1e-6
    dR = (euler_rotation(ang + h * rates, convention) - euler_rotation(ang - h * rates, convention)) / (2 * h)
    S = dR @ np.swapaxes(R, -1, -2)
    omega = np.stack([S[:, 2, 1], S[:, 0, 2], S[:, 1, 0]], axis=-1)
    np.testing.assert_allclose(np.einsum('nij,nj->ni', euler_rate_matrix(ang, convention), rates), omega,
                               rtol=0, atol=1e-9)


def test_tilt_from_matrix_recovers_tilt_azimuth_and_twist():
    """``R = tilt_rotation(tilt, azimuth) Rz(twist)`` decomposed back into its three angles."""
    rng = np.random.default_rng(7)
    t, g, w = rng.uniform(1e-3, 0.5, 50), rng.uniform(-3.0, 3.0, 50), rng.uniform(-3.0, 3.0, 50)
    R = tilt_rotation(t, g) @ Rotation.from_rotvec(np.c_[0 * w, 0 * w, w]).as_matrix()
    for got, expect in zip(tilt_from_matrix(R), (t, g, w), strict=True):
        np.testing.assert_allclose(got, expect, rtol=0, atol=1e-12)


def test_compose_one_is_the_product_of_homogeneous_transforms():
    """``compose_one`` of a child pose in a parent pose is the product of their 4 x 4 transforms."""
    rng = np.random.default_rng(8)
    Ra, Rb = Rotation.random(2, random_state=9).as_matrix()
    pa, pb = rng.normal(size=3), rng.normal(size=3)
    p, R = compose_one(tuple(pa), tuple(map(tuple, Ra)), tuple(pb), tuple(map(tuple, Rb)))
    Ta, Tb = np.eye(4), np.eye(4)
    Ta[:3, :3], Ta[:3, 3], Tb[:3, :3], Tb[:3, 3] = Ra, pa, Rb, pb
    T = Ta @ Tb
    np.testing.assert_allclose(p, T[:3, 3], rtol=0, atol=1e-15)
    np.testing.assert_allclose(R, T[:3, :3], rtol=0, atol=1e-15)


def test_euler_conventions_taken_and_refused():
    """Three axes from xyz, all lower (extrinsic) or all upper case (intrinsic), no axis twice in a row."""
    from gpr_kinematics.core.rotations import check_euler_convention
    from gpr_kinematics.errors import InputError

    for good in ('xyz', 'zxz', 'ZYX', 'XZX'):
        assert check_euler_convention(good) == good
    for bad in ('xy', 'xyzx', 'xYz', 'xxz', 'xzz', 'abc', 3):
        with pytest.raises(InputError, match='Euler convention must be three axes from xyz'):
            check_euler_convention(bad)


def test_kabsch_recovers_a_rotation_and_never_returns_a_singular_matrix():
    """One Kabsch for the mechanisms' pose fit and the calibration's frames (two copies before, one formula; the
    determinant of the SVD's orthogonal factors is +-1, so its sign is never 0, even for a degenerate set)."""
    from gpr_kinematics.core.rotations import kabsch
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(5)
    R = Rotation.random(20, random_state=7).as_matrix()
    a = rng.normal(size=(20, 6, 3))
    a -= a.mean(axis=1, keepdims=True)
    b = np.einsum('nij,nkj->nki', R, a) + 1e-9 * rng.normal(size=a.shape)
    got = kabsch(a, b)
    assert np.max(np.abs(got - R)) < 1e-8
    np.testing.assert_allclose(np.linalg.det(got), 1.0, atol=1e-12)
    np.testing.assert_allclose(kabsch(a[0], b[0]), got[0], atol=1e-15)     # one set as the batch
    flat = np.zeros((4, 3))                                                   # every vector zero: H = 0
    assert abs(np.linalg.det(kabsch(flat, flat)) - 1.0) < 1e-12


def test_wrap_angle_range_is_minus_pi_inclusive_pi_exclusive():
    """``wrap_angle`` documents ``[-pi, pi)``: pi, -pi, 3 pi, -3 pi and 5 pi all give -pi exactly (never +pi), 2 pi
    gives 0; values 1e-9 rad inside either end stay as they are; a float stays a float, an array an array."""
    pi = math.pi
    for a in (pi, -pi, 3 * pi, -3 * pi, 5 * pi):
        got = wrap_angle(a)
        assert got == -pi and isinstance(got, float), (a, got)
    assert wrap_angle(2 * pi) == 0.0 and wrap_angle(0.0) == 0.0
    assert wrap_angle(pi - 1e-9) == pytest.approx(pi - 1e-9, abs=1e-15)
    assert wrap_angle(-pi + 1e-9) == pytest.approx(-pi + 1e-9, abs=1e-15)
    assert wrap_angle(pi + 1e-9) == pytest.approx(-pi + 1e-9, abs=1e-15)
    got = wrap_angle(np.array([pi, -pi, 3 * pi, pi - 1e-9, -pi + 1e-9, 0.5]))
    assert isinstance(got, np.ndarray)
    np.testing.assert_allclose(got, [-pi, -pi, -pi, pi - 1e-9, -pi + 1e-9, 0.5], rtol=0, atol=1e-15)
    dense = wrap_angle(np.linspace(-20.0, 20.0, 100_001))
    assert dense.min() >= -pi and dense.max() < pi

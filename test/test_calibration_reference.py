"""The tests' reference model of the imperfect GPR (test/calibration_reference.py) checked on its own: its closure
against scipy pose by pose, the rigid fit, and its limits against the core (kappa -> infinity: the radial
model; kappa = 1: no centre shift)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from calibration_reference import ReferenceModel
from gpr_kinematics.calibration.model import evaluate
from gpr_kinematics.core import forward_batch, naive_inverse
from scipy.optimize import least_squares


def perturbed(model: ReferenceModel, rng: np.random.Generator, kappa: float) -> np.ndarray:
    th = model.parameters.nominal.copy()
    th[0:6] += rng.normal(0, 50e-6, 6)
    th[6:9] += rng.normal(0, 50e-6, 3)
    th[9:15] += rng.normal(0, 2e-4, 6)
    th[15:21] += rng.normal(0, 50e-6, 6)
    th[21] = kappa
    th[22] = 30e-6
    return th


def machine_and_poses(seed: int, kappa: float, n: int):
    """A perturbed reference machine, ``n`` random configurations within the limits, its poses and joint centres."""
    m = ReferenceModel()
    rng = np.random.default_rng(seed)
    th = perturbed(m, rng, kappa)
    Q = naive_inverse(rng.uniform(0.05, 0.45, n), rng.uniform(-0.0349, 0.0349, n), rng.uniform(-3, 3, n))
    pos, rot = evaluate(m, th, Q)
    return m, th, Q, pos, rot, m.joint_centres(th[None], Q[None])[0]


def test_closure_matches_scipy_pose_by_pose():
    m, th, Q, pos, rot, P = machine_and_poses(1, 3.0, 6)
    p = th[15:21].reshape(3, 2)
    er = p / np.linalg.norm(p, axis=1, keepdims=True)
    et = np.stack([-er[:, 1], er[:, 0]], axis=1)
    for i in range(Q.shape[0]):
        # The same minimum-cost closure, formulated independently: the unknowns are the platform origin in the
        # plane of the joints (offset u, v from their centroid) and the rotation psi about the normal; the
        # residuals are sqrt(W_k) d_k, d_k = (platform coordinates of P_k) - p_k.
        n = np.cross(P[i, 1] - P[i, 0], P[i, 2] - P[i, 0])
        n /= np.linalg.norm(n)
        e1 = np.array([1.0, 0.0, 0.0]) - n[0] * n
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)

        def frame(x, n=n, e1=e1, e2=e2, i=i):
            c, s = math.cos(x[2]), math.sin(x[2])
            R = np.column_stack([c * e1 - s * e2, s * e1 + c * e2, n])
            return P[i].mean(0) + x[0] * e1 + x[1] * e2, R

        def residuals(x, i=i):
            o, R = frame(x)
            d = (P[i] - o) @ R[:, :2] - p
            return np.concatenate([np.sum(d * er, 1), math.sqrt(th[21]) * np.sum(d * et, 1)])

        # Central differences: a one-sided Jacobian moves the stationary point itself by ~1e-11 m (scipy 1.11).
        x = least_squares(residuals, np.zeros(3), method='trf', jac='3-point', xtol=1e-15, ftol=1e-15, gtol=1e-15).x
        o, R = frame(x)
        np.testing.assert_allclose(pos[i], o, rtol=0, atol=1e-13)
        np.testing.assert_allclose(rot[i], R, rtol=0, atol=1e-11)   # scipy stops at its tolerances (~3e-12 rad)
    assert m.last_iterations <= 6


def test_rigid_fit_is_exact_and_displacements_small():
    _, th, _, pos, rot, P = machine_and_poses(2, 0.4, 50)
    r = np.einsum('nji,nkj->nki', rot, P - pos[:, None, :])     # joint centres in gpr_platform
    assert np.max(np.abs(r[..., 2])) < 1e-15                    # in the platform plane
    d = r[..., :2] - th[15:21].reshape(3, 2)                    # virtual-joint displacements
    assert 1e-6 < np.max(np.linalg.norm(d, axis=-1)) < 5e-4
    np.testing.assert_allclose(np.einsum('nij,nkj->nik', rot, rot), np.broadcast_to(np.eye(3), rot.shape), atol=1e-15)
    assert np.all(np.linalg.det(rot) > 0) and np.all(rot[:, 2, 2] > 0.999)


@pytest.mark.parametrize('tilt, azimuth', [(math.radians(2.0), 0.0), (0.03, 1.1), (0.02, -2.5)])
def test_stiff_tangential_limit_is_the_core_radial_model(tilt, azimuth):
    m = ReferenceModel()
    th = m.parameters.nominal.copy()
    th[21] = 1e10
    Q = naive_inverse([0.1, 0.5], tilt, azimuth)
    pos, rot = evaluate(m, th, Q)
    fk = forward_batch(Q)
    np.testing.assert_allclose(pos, fk.position, atol=1e-13)
    np.testing.assert_allclose(rot, fk.rotation, atol=1e-13)
    assert np.max(np.abs(fk.centre_shift[:, :2])) > 5e-6          # the comparison is not trivial


def test_isotropic_joints_do_not_shift_the_centre_and_the_shift_changes_sign_with_kappa():
    m = ReferenceModel()
    Q = naive_inverse(0.5, math.radians(2.0), 0.0)[None]
    naive = forward_batch(Q).nominal_position[0]
    shift = {}
    for kappa in (0.1, 1.0, 10.0, 1e3):
        th = m.parameters.nominal.copy()
        th[21] = kappa
        shift[kappa] = evaluate(m, th, Q)[0][0] - naive
    assert np.max(np.abs(shift[1.0])) < 1e-15
    assert shift[1e3][0] > shift[10.0][0] > 20e-6 > 0 > -20e-6 > shift[0.1][0]
    assert shift[1e3][0] < forward_batch(Q).centre_shift[0, 0]     # below the radial limit

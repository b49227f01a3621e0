"""The compliant virtual-joint model: the closure of minimum elastic cost, against an independent solution of its
KKT system, its limits (kappa -> infinity: radial; kappa = 1: no centre shift), the approximate law, batches."""
import math

import numpy as np
import pytest
from gpr_kinematics.core import forward, forward_batch, inverse, inverse_batch, naive_inverse
from gpr_kinematics.core.config import GprConfig, load_config
from gpr_kinematics.errors import ConvergenceError
from scipy.optimize import root
from scipy.spatial.transform import Rotation

CFG = load_config()
R = CFG.radius
EDGES = ((0, 1), (1, 2), (2, 0))


def compliant(kappa, **changes):
    return CFG.replace(model='compliant', kappa=kappa, **changes)


def independent_minimum(q, kappa, cfg=CFG):
    """The minimum of 1/2 sum (dr_k^2 + kappa dt_k^2) over the joints' radial and tangential displacements subject
    to the paper's closure F_i(X) = |r_b - r_a|^2 - L_i^2 = 0, written here from scratch: the KKT equations
    (W X + J^T lambda = 0, F = 0) solved by scipy's root, then checked to be a minimum on the constraint (the
    Hessian of the Lagrangian on the null space of J is positive); the pose by a Kabsch fit of the joints onto the
    rods (scipy's align_vectors). Returns (position, X)."""
    th = np.asarray(cfg.rod_azimuths)
    p = np.stack([R * np.cos(th), R * np.sin(th)], -1)
    er = p / R
    et = np.stack([-er[:, 1], er[:, 0]], -1)
    P = np.column_stack([p, q])
    L = np.array([np.linalg.norm(P[b] - P[a]) for a, b in EDGES])
    k = np.broadcast_to(np.asarray(kappa, dtype=float), (3,))
    w = np.concatenate([np.ones(3), k]) / (1.0 + k.mean())

    def points(X):
        return p + X[:3, None] * er + X[3:, None] * et

    def closure(X):
        r = points(X)
        return np.array([np.sum((r[b] - r[a]) ** 2) - L[i] ** 2 for i, (a, b) in enumerate(EDGES)])

    def jacobian(X):
        r = points(X)
        out = np.zeros((3, 6))
        for i, (a, b) in enumerate(EDGES):
            e = r[b] - r[a]
            out[i, [b, 3 + b]] += 2 * e @ er[b], 2 * e @ et[b]
            out[i, [a, 3 + a]] -= 2 * e @ er[a], 2 * e @ et[a]
        return out

    def kkt(z):
        X, lam = z[:6] * 1e-6, z[6:]
        return np.concatenate([(w * X + jacobian(X).T @ lam) * 1e6, closure(X) * 1e6])

    z = root(kkt, np.zeros(9), method='hybr', options={'xtol': 1e-15}).x  # from the joints at rest
    X = z[:6] * 1e-6
    assert np.max(np.abs(kkt(z))) < 1e-9  # the KKT equations hold (in micrometres)
    # second order: the Hessian of the Lagrangian, W + sum lambda_i d2F_i (by differences), on the null space of J
    h = 1e-7
    hess = np.array([(w * (X + h * e) + jacobian(X + h * e).T @ z[6:] - w * (X - h * e)
                      - jacobian(X - h * e).T @ z[6:]) / (2 * h) for e in np.eye(6)])
    null = np.linalg.svd(jacobian(X))[2][3:].T
    assert np.linalg.eigvalsh(null.T @ hess @ null).min() > 0
    r = np.column_stack([points(X), np.zeros(3)])
    rot, _ = Rotation.align_vectors(P - P.mean(0), r - r.mean(0))
    return P.mean(0) - rot.apply(r.mean(0)), X


#: Centre shift [um] along x at 0.5 m, 2 deg about the x axis, rods from the naive model (docs/core.md).
REFERENCE = {1e-3: -28.32, 0.1: -23.22, 1.0: 0.00, 10.0: 23.22, 1e3: 28.32, 1e6: 28.38}


@pytest.mark.parametrize('kappa', sorted(REFERENCE))
def test_centre_shift_matches_an_independent_minimum_and_the_reference_values(kappa):
    q = naive_inverse(0.5, math.radians(2.0), 0.0)
    fk = forward(q, config=compliant(kappa))
    position, X = independent_minimum(q, kappa)
    np.testing.assert_allclose(fk.position, position, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fk.virtual_joints, X, rtol=0, atol=1e-12)
    assert fk.centre_shift[0] * 1e6 == pytest.approx(REFERENCE[kappa], abs=0.005)
    assert abs(fk.centre_shift[1]) < 1e-15 and fk.residual <= CFG.tolerance and fk.iterations <= 4


def test_an_asymmetric_pose_and_per_joint_stiffness_match_the_independent_minimum():
    q = naive_inverse(0.3, math.radians(1.3), 2.2)
    for kappa in ((3.0, 0.2, 40.0), (1e-2, 1e-2, 1e-2)):
        fk = forward(q, config=compliant(kappa))
        position, X = independent_minimum(q, np.asarray(kappa))
        np.testing.assert_allclose(fk.position, position, rtol=0, atol=1e-12)
        np.testing.assert_allclose(fk.virtual_joints, X, rtol=0, atol=1e-12)


def test_kappa_to_infinity_is_the_radial_model():
    rng = np.random.default_rng(1)
    Q = naive_inverse(rng.uniform(0.1, 0.4, 50), rng.uniform(-1, 1, 50) * CFG.tilt_limit, rng.uniform(-3, 3, 50))
    radial = forward_batch(Q, model='radial')
    gaps = []
    for kappa in (1e2, 1e4, 1e6):
        fb = forward_batch(Q, config=compliant(kappa))
        gaps.append(np.max(np.linalg.norm(fb.position - radial.position, axis=-1)))
        np.testing.assert_allclose(fb.virtual_joints[:, :3] + R, radial.virtual_joints, rtol=0, atol=30 * R / kappa)
        assert np.max(np.abs(fb.virtual_joints[:, 3:])) < 1e-4 / kappa  # tangential displacements vanish
    assert gaps[2] < 1e-10
    assert gaps[0] / gaps[1] == pytest.approx(100.0, rel=0.05)  # the gap falls like 1 / kappa
    assert gaps[1] / gaps[2] == pytest.approx(100.0, rel=0.05)


def test_isotropic_joints_give_no_centre_shift():
    rng = np.random.default_rng(2)
    h, t, g = rng.uniform(0.1, 0.4, 200), rng.uniform(-1, 1, 200) * CFG.tilt_limit, rng.uniform(-3, 3, 200)
    fb = forward_batch(naive_inverse(h, t, g), config=compliant(1.0))
    assert np.max(np.abs(fb.centre_shift)) < 1e-15
    # isotropic cost: the displacements d_k = dr_k e_r + dt_k e_t sum to zero (the centroid stays)
    th = np.asarray(CFG.rod_azimuths)
    dx = fb.virtual_joints[:, :3] * np.cos(th) - fb.virtual_joints[:, 3:] * np.sin(th)
    dy = fb.virtual_joints[:, :3] * np.sin(th) + fb.virtual_joints[:, 3:] * np.cos(th)
    assert np.max(np.abs(dx.sum(axis=-1))) < 1e-15 and np.max(np.abs(dy.sum(axis=-1))) < 1e-15


@pytest.mark.parametrize('gamma', [0.0, 0.4, 1.3, 2.5, -2.0])
@pytest.mark.parametrize('kappa', [0.05, 3.0, 200.0])
def test_approximate_law_of_the_centre_shift(gamma, kappa):
    """|shift| ~ R alpha^2 / 4 (kappa - 1) / (kappa + 1), in the direction -2 gamma (docs/core.md)."""
    alpha = CFG.tilt_limit
    shift = inverse(0.4, alpha, gamma, config=compliant(kappa)).achieved.centre_shift
    law = R * alpha ** 2 / 4 * (kappa - 1) / (kappa + 1)
    assert math.hypot(shift[0], shift[1]) == pytest.approx(abs(law), rel=0.005)
    direction = math.atan2(shift[1], shift[0]) - (0.0 if law > 0 else math.pi)
    assert abs(math.remainder(direction + 2 * gamma, 2 * math.pi)) < 1e-3


def test_batch_equals_single_and_the_inverse_round_trip():
    rng = np.random.default_rng(3)
    cfg = compliant((2.0, 15.0, 0.5))
    h, t, g = rng.uniform(0.1, 0.4, 60), rng.uniform(-1, 1, 60) * CFG.tilt_limit, rng.uniform(-3, 3, 60)
    ib = inverse_batch(h, t, g, config=cfg)
    assert np.max(np.abs(ib.achieved.position[:, 2] - h)) < 1e-12
    assert np.max(np.abs(ib.achieved.tilt - np.abs(t))) < 1e-12
    fb = forward_batch(ib.q, config=cfg)
    for i in range(0, 60, 7):
        one = forward(ib.q[i], config=cfg)
        np.testing.assert_allclose(fb.position[i], one.position, rtol=0, atol=1e-15)
        np.testing.assert_allclose(fb.virtual_joints[i], one.virtual_joints, rtol=0, atol=1e-15)
        assert fb.iterations[i] == one.iterations <= 4


def test_rest_and_non_convergence():
    fk = forward([0.3, 0.3, 0.3], config=compliant(7.0))
    assert fk.iterations == 0 and np.all(fk.virtual_joints == 0.0) and np.max(np.abs(fk.centre_shift)) < 1e-30
    with pytest.raises(ConvergenceError, match=r'compliant closure .* did not converge in 1 iterations'):
        forward(naive_inverse(0.3, 0.03, 0.5), config=compliant(7.0, max_iterations=1))


def test_stiffness_is_validated_by_name():
    for bad in (0.0, -1.0, 1e7, [1.0, 2.0], '10', True, float('nan')):
        with pytest.raises(Exception, match=r'kappa = .* is invalid; allowed: one number or a list of 3, '
                                            r'1e-6 <= kappa <= 1e6'):
            GprConfig.from_mapping({'kappa': bad})


def test_isotropic_joints_start_at_the_optimum():
    """For kappa = 1 the cost is isotropic and its minimum is the 2-D Kabsch fit, the start of Newton's method: the
    first step is below the tolerance, so every sample takes exactly one iteration (a wrong start takes more)."""
    rng = np.random.default_rng(4)
    h, t, g = rng.uniform(0.1, 0.4, 100), rng.uniform(-1, 1, 100) * CFG.tilt_limit, rng.uniform(-3, 3, 100)
    fb = forward_batch(naive_inverse(h, t, g), config=compliant(1.0))
    assert np.all(fb.iterations == 1)
    assert forward(naive_inverse(0.3, 0.03, 0.5), config=compliant(1.0)).iterations == 1


def test_newton_step_is_the_gradient_over_the_hessian_of_the_elastic_cost():
    """The step on (tau_x, tau_y, psi) is H^-1 g of the cost C = 1/2 sum d_k^T W_k d_k, d_k = R(psi) Q_k + tau - p_k,
    with the cost written here from its definition and its gradient and Hessian taken by central differences,
    at a point away from the minimum (where every term of the Hessian counts)."""
    from gpr_kinematics.core.compliance import _newton_step, stiffness
    from gpr_kinematics.core.virtual_joints import make_model

    kappa = np.array([3.0, 0.2, 40.0])
    cfg = compliant(tuple(kappa))
    th = np.asarray(cfg.rod_azimuths)
    p = R * np.stack([np.cos(th), np.sin(th)], -1)
    er = p / R
    et = np.stack([-er[:, 1], er[:, 0]], -1)
    W = [np.outer(er[k], er[k]) + kappa[k] * np.outer(et[k], et[k]) for k in range(3)]
    L = np.array([0.99 * math.sqrt(3.0) * R, 1.01 * math.sqrt(3.0) * R, math.sqrt(3.0) * R])  # sides 1-2, 2-3, 3-1
    x3 = (L[0] ** 2 + L[2] ** 2 - L[1] ** 2) / (2 * L[0])
    Q = np.array([[0.0, 0.0], [L[0], 0.0], [x3, math.sqrt(L[2] ** 2 - x3 ** 2)]])

    def cost(z):
        c, s = math.cos(z[2]), math.sin(z[2])
        d = Q @ np.array([[c, s], [-s, c]]) + z[:2] - p
        return 0.5 * sum(d[k] @ W[k] @ d[k] for k in range(3))

    z0 = np.array([p[0, 0] + 0.004, p[0, 1] - 0.003, math.pi / 2 + 0.3])   # Q_1 near p_1, Q_2 - Q_1 along e_y
    hs = np.array([1e-5, 1e-5, 1e-4])
    E = np.diag(hs)
    g = np.array([(cost(z0 + E[i]) - cost(z0 - E[i])) / (2 * hs[i]) for i in range(3)])
    H = np.array([[(cost(z0 + E[i] + E[j]) - cost(z0 + E[i] - E[j]) - cost(z0 - E[i] + E[j])
                    + cost(z0 - E[i] - E[j])) / (4 * hs[i] * hs[j]) for j in range(3)] for i in range(3)])
    w = stiffness(make_model(cfg, 'compliant'))
    step = _newton_step(w, math.cos(z0[2]), math.sin(z0[2]), Q[:, 0].tolist(), Q[:, 1].tolist(), z0[0], z0[1], 0.0)
    np.testing.assert_allclose(step, np.linalg.solve(H, g), rtol=1e-6)

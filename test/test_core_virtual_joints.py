"""Virtual-joint models: analytic Jacobians, the kernel step, convergence from the singular X."""
import numpy as np
import pytest
from gpr_kinematics.core import forward, forward_batch, naive_inverse
from gpr_kinematics.core.closure import newton_terms, solve_virtual_joints
from gpr_kinematics.core.config import MODELS, load_config
from gpr_kinematics.core.ops import ARRAY
from gpr_kinematics.core.virtual_joints import CLOSURE_MODELS, coordinate_scale, joint_components, make_model
from gpr_kinematics.errors import ConvergenceError

CFG = load_config()


def _random_X(vjm, rng, n):
    X = vjm.singular(n)
    X[:, :3] += rng.normal(scale=2e-4, size=(n, 3))
    if vjm.size == 6:
        X[:, 3:] += rng.normal(scale=3e-3, size=(n, 3))
        if vjm.name == 'offset':  # dr around 0 needs a finite value for the dphi columns to matter
            X[:, :3] += 1e-4
    return X


@pytest.mark.parametrize('model', MODELS)
def test_dF_dX_matches_central_differences(model):
    vjm = make_model(CFG, model)
    rng = np.random.default_rng(1)
    X = _random_X(vjm, rng, 5)
    L2 = np.full((5, 3), 3 * CFG.radius ** 2)
    _, J, _ = vjm.closure(X, L2)
    h = 1e-7
    for m in range(vjm.size):
        e = np.zeros(vjm.size)
        e[m] = h
        fd = (vjm.closure(X + e, L2)[0] - vjm.closure(X - e, L2)[0]) / (2 * h)
        np.testing.assert_allclose(J[:, :, m], fd, rtol=1e-6, atol=1e-10)


@pytest.mark.parametrize('model', CLOSURE_MODELS)
@pytest.mark.parametrize('weighting', ['characteristic', 'unweighted'])
def test_kernel_step_is_weighted_pseudo_inverse_step(model, weighting):
    """The sparse closed-form step equals -W J^T (J W J^T)^-1 F computed densely (paper eq. 8)."""
    cfg = CFG.replace(weighting=weighting)
    vjm = make_model(cfg, model)
    rng = np.random.default_rng(2)
    X = _random_X(vjm, rng, 4)
    L = np.sqrt(3) * cfg.radius + rng.normal(scale=1e-4, size=(4, 3))
    F, J, _ = vjm.closure(X, L ** 2)
    W = coordinate_scale(vjm, cfg) ** -2.0
    dense = -np.einsum('m,nim,nij,nj->nm', W, J, np.linalg.inv(np.einsum('nim,m,njm->nij', J, W, J)), F)
    comps = joint_components(ARRAY, vjm, list(X.T))
    kernel = np.stack(newton_terms(ARRAY, comps, list(L.T), 1.0 / cfg.characteristic_length ** 2
                                   if weighting == 'characteristic' else 1.0), axis=-1)
    np.testing.assert_allclose(kernel, dense, rtol=1e-10, atol=1e-18)
    if vjm.size == 6:  # minimum norm in the weighted metric: the step lies in the row space of J W
        proj = np.einsum('nm,nim->ni', kernel / W, J)
        assert np.all(np.isfinite(proj))


@pytest.mark.parametrize('model', MODELS)
def test_singular_configuration_gives_nominal_X_without_iterations(model):
    fk = forward([0.3, 0.3, 0.3], model=model)
    vjm = make_model(CFG, model)
    np.testing.assert_array_equal(fk.virtual_joints, vjm.singular(1)[0])
    assert fk.iterations == 0
    assert fk.tilt == 0.0 and fk.tilt_azimuth == 0.0
    np.testing.assert_allclose(fk.joint_displacement, 0.0, atol=1e-17)


@pytest.mark.parametrize('model', MODELS)
@pytest.mark.parametrize('weighting', ['characteristic', 'unweighted'])
def test_at_most_four_newton_steps_over_the_workspace(model, weighting):
    cfg = CFG.replace(weighting=weighting)
    rng = np.random.default_rng(3)
    n = 2000
    Q = naive_inverse(rng.uniform(0.05, 0.45, n), rng.uniform(-1, 1, n) * cfg.tilt_limit,
                      rng.uniform(-np.pi, np.pi, n), cfg)
    fb = forward_batch(Q, config=cfg, model=model)
    assert fb.iterations.max() <= 4
    assert fb.residual.max() <= cfg.tolerance


def test_radial_symmetry_tilt_about_x_gives_l2_equal_l3():
    # Tilting about the x axis (azimuth 0) moves rods 2 and 3 symmetrically (rod 1 sits on the axis).
    q = naive_inverse(0.4, np.radians(1.7), 0.0)
    fk = forward(q, model='radial')
    assert fk.virtual_joints[1] == pytest.approx(fk.virtual_joints[2], abs=1e-16)
    assert fk.virtual_joints[0] != pytest.approx(fk.virtual_joints[1], abs=1e-9)


def test_non_convergence_is_an_error_not_an_answer():
    cfg = CFG.replace(max_iterations=1)
    vjm = make_model(cfg, 'polar')
    L = np.array([[0.1615, 0.1616, 0.1614]] * 2)
    with pytest.raises(ConvergenceError, match=r'did not converge in 1 iterations for sample 0'):
        solve_virtual_joints(L, vjm, cfg)
    with pytest.raises(ConvergenceError, match=r'did not converge in 1 iterations: '):   # a batch of one: as one pose
        solve_virtual_joints(L[:1], vjm, cfg)
    with pytest.raises(ConvergenceError, match='did not converge'):
        forward([0.5, 0.503, 0.498], config=cfg)


def test_closure_is_solved_to_tolerance():
    rng = np.random.default_rng(4)
    Q = 0.3 + rng.uniform(-2e-3, 2e-3, (500, 3))
    for model in MODELS:
        fb = forward_batch(Q, model=model)
        vjm = make_model(CFG, model)
        F, _, d = vjm.closure(fb.virtual_joints, fb.side_lengths ** 2)
        assert np.max(np.abs(d - fb.side_lengths)) <= CFG.tolerance


def test_offset_model_is_degenerate_at_its_start_and_stays_radial():
    """At dr = 0 the offset model's angular coordinates have zero derivative (docs/core.md)."""
    vjm = make_model(CFG, 'offset')
    _, _, dang = vjm.points_and_partials(vjm.singular(1))
    assert np.all(dang == 0.0)
    rng = np.random.default_rng(6)
    Q = naive_inverse(rng.uniform(0.05, 0.45, 2000), rng.uniform(-1, 1, 2000) * CFG.tilt_limit,
                      rng.uniform(-np.pi, np.pi, 2000))
    radial, offset = forward_batch(Q, model='radial'), forward_batch(Q, model='offset')
    assert np.max(np.abs(offset.position - radial.position)) < 1e-14
    assert np.max(np.abs(offset.virtual_joints[:, 3:])) < 1e-9
    np.testing.assert_allclose(offset.virtual_joints[:, :3] + CFG.radius, radial.virtual_joints, rtol=0, atol=1e-14)


def test_non_convergence_names_the_worst_sample_and_its_error():
    """A batch that runs out of iterations names the sample with the largest side-length error, and that error as
    the sample alone gives it: here a sample at rest (converged, no error), and two that each fail alone."""
    import re

    from gpr_kinematics.core.closure import solve_virtual_joints

    cfg = CFG.replace(max_iterations=1)
    vjm = make_model(cfg, 'polar')
    s = np.sqrt(3.0) * CFG.radius   # the side of the joint triangle at rest
    rows = np.array([[s, s, s], [s * 1.001, s, s * 0.999], [0.1615, 0.1616, 0.1614]])
    alone = []
    for row in rows[1:]:
        with pytest.raises(ConvergenceError) as exc:
            solve_virtual_joints(row[None], vjm, cfg)
        alone.append(float(re.search(r'side-length error (\S+) m', str(exc.value)).group(1)))
    worst = 1 + int(np.argmax(alone))
    with pytest.raises(ConvergenceError, match=rf'for sample {worst}: side-length error {max(alone):.3e} m > '
                                               r'tolerance 1\.0e-14 m'):
        solve_virtual_joints(rows, vjm, cfg)

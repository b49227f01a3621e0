"""Parameter models (gpr_kinematics.calibration.model): parameters, the model interface's checks, pose errors,
rotation vectors, and the finite-difference Jacobians against independent higher-order differences and exact
derivatives."""
from __future__ import annotations

import doctest

import numpy as np
import pytest
from calibration_reference import ReferenceModel
from gpr_kinematics.calibration import model as model_mod
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.model import (
    Parameter,
    ParameterSet,
    displacement_jacobian,
    evaluate,
    pose_error,
    pose_jacobian,
    rod_jacobian,
)
from gpr_kinematics.core import naive_inverse
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.parameters import PARAMETER_NAMES
from gpr_kinematics.core.rotations import rotation_vector
from gpr_kinematics.errors import InputError
from scipy.spatial.transform import Rotation


def test_doctests():
    assert doctest.testmod(model_mod).failed == 0


def test_parameters_and_selection():
    ps = CoreModel(load_config()).parameters
    assert ps.names == PARAMETER_NAMES and len(ps) == 24
    assert ps.groups == ('rod_positions', 'rod_offsets', 'rod_directions', 'platform_joints', 'kappa')
    assert ps.select(['rod_offsets']).nonzero()[0].tolist() == [2, 10, 18]
    assert ps.select(['rod1_x', 'kappa3']).nonzero()[0].tolist() == [0, 23]
    assert ps.select(None).all() and not ps.select([]).any()
    with pytest.raises(InputError, match=r"unknown parameter 'radius'; allowed: rod1_x, rod1_y.*whole key: "
                                         r'rod_positions, rod_offsets, rod_directions, platform_joints, kappa'):
        ps.select(['radius'])
    with pytest.raises(InputError, match=r'unit .inch.; allowed: m, rad, 1'):
        Parameter('a', 0.0, 'inch', 1.0, 'a')
    with pytest.raises(InputError, match=r'scale .* must be finite, the nominal within \[-inf, inf\], the scale > 0'):
        Parameter('a', 0.0, 'm', 0.0, 'a')
    with pytest.raises(InputError, match=r"transform 'log'; allowed: '', 'anisotropy'"):
        Parameter('a', 0.0, '1', 1.0, 'a', (), 'log')
    with pytest.raises(InputError, match=r'repeated: a'):
        ParameterSet((Parameter('a', 0.0, 'm', 1.0, 'a'), Parameter('a', 1.0, 'm', 1.0, 'b')))
    assert ps.index('rod2_offset') == 10 and ps[2].step == pytest.approx(1e-6)


def test_stiffness_ratios_are_identified_as_anisotropies():
    """kappa <-> u = (kappa - 1) / (kappa + 1): the nominal kappa 1000 of the default file is u = 0.998; the value,
    its slope (against a central difference) and the steps that stay inside the coordinate's range."""
    ps = CoreModel(load_config()).parameters
    j = ps.index('kappa2')
    p = ps[j]
    assert p.transform == 'anisotropy' and p.unit == '1' and p.nominal == pytest.approx(999 / 1001, rel=1e-15)
    u = np.array([-0.9, -0.2, 0.0, 0.5, 0.99])
    np.testing.assert_allclose(p.value(u), (1 + u) / (1 - u), rtol=1e-15)
    np.testing.assert_allclose(p.coordinate(p.value(u)), u, rtol=0, atol=1e-15)
    h = 1e-6
    np.testing.assert_allclose(p.value_slope(u), (p.value(u + h) - p.value(u - h)) / (2 * h), rtol=1e-7)
    assert p.bounds == pytest.approx(((1e-6 - 1) / (1e-6 + 1), (1e6 - 1) / (1e6 + 1)), rel=1e-15)
    theta = ps.nominal.copy()
    theta[j] = p.coordinate(9e5)                           # near the top of the range: the step shrinks inside it
    up, down = ps.steps(theta)
    assert up[j] == pytest.approx(0.5 * (p.bounds[1] - theta[j]), rel=1e-12) and up[j] < p.step
    assert theta[j] + up[j] < p.bounds[1] and up[0] == down[0] == ps.step[0] and down[j] == up[j]
    theta[j] = p.bounds[1]                                 # at the bound (kappa 1e6, allowed): one-sided
    up, down = ps.steps(theta)
    assert up[j] == 0.0 and down[j] == p.step
    theta[j] = p.coordinate(9e5)
    values = ps.values(theta)
    assert values[j] == pytest.approx(9e5, rel=1e-9) and values[0] == theta[0]
    np.testing.assert_allclose(ps.coordinates(values), theta, rtol=0, atol=1e-15)
    with pytest.raises(InputError, match=r'the nominal within \[-0\.999998, 0\.999998\]'):
        Parameter('kappa1', 1.0, '1', 0.5, 'kappa', (0,), 'anisotropy')


def test_evaluate_checks_shapes_and_values():
    m = CoreModel(load_config())
    with pytest.raises(InputError, match=r'theta must have 24 values per row'):
        evaluate(m, [0.1, 0.2], [[0.3, 0.3, 0.3]])
    with pytest.raises(InputError, match=r'rod lengths must have shape'):
        evaluate(m, m.parameters.nominal, [[0.3, 0.3]])

    class Broken:
        parameters = m.parameters
        supports_displacement = False

        def poses(self, theta, Q, displacement=None):
            return np.full(Q.shape, np.nan), np.zeros(Q.shape + (3,))

    with pytest.raises(InputError, match=r'Broken cannot displace its joint centres'):
        evaluate(Broken(), m.parameters.nominal, [[0.3, 0.3, 0.3]], np.zeros((1, 3, 3)))
    with pytest.raises(InputError, match=r'Broken\.poses returned a non-finite pose'):
        evaluate(Broken(), m.parameters.nominal, [[0.3, 0.3, 0.3]])
    with pytest.raises(InputError, match=r'q2 = nan is not a finite number'):
        pose_jacobian(m, m.parameters.nominal, [[0.3, np.nan, 0.3]])
    bad = m.parameters.nominal.copy()
    bad[m.parameters.index('rod3_offset')] = 0.5
    with pytest.raises(InputError, match=r'per-row geometry, row 0: rod3_offset = 0\.5 is outside \[-0\.1, 0\.1\]'):
        evaluate(m, bad, [[0.3, 0.3, 0.3]])


def test_a_configuration_given_for_its_model_is_named():
    """A GprConfig where its CoreModel belongs raised a bare AttributeError (no ``parameters``) in ``evaluate``
    and ``accuracy_budget``."""
    from gpr_kinematics.calibration.budget import accuracy_budget
    cfg = load_config()
    message = (r'^model is a GprConfig; allowed: a pose model such as gpr_kinematics\.calibration\.core_model\.'
               r'CoreModel\(config\) \(a GprConfig goes in there\)$')
    with pytest.raises(InputError, match=message):
        evaluate(cfg, CoreModel(cfg).parameters.nominal, [[0.3, 0.3, 0.3]])
    with pytest.raises(InputError, match=message):
        accuracy_budget(cfg, [[0.3, 0.3, 0.3]], None)   # type: ignore[arg-type]
    for jacobian in (pose_jacobian, model_mod.rod_jacobian):   # pose_jacobian's sibling checked, it was not
        with pytest.raises(InputError, match=message):
            jacobian(cfg, CoreModel(cfg).parameters.nominal, [[0.3, 0.3, 0.3]])


def core_to_reference(values):
    """The reference model's parameters (test/calibration_reference.py) of a core machine (values in the order of
    PARAMETER_NAMES, equal kappas): its rod directions are (t_x, t_y, 1) normalised, the core's (u_x, u_y, u_z)."""
    v = dict(zip(PARAMETER_NAMES, values, strict=True))
    out = []
    for k in (1, 2, 3):
        out += [v[f'rod{k}_x'], v[f'rod{k}_y']]
    out += [v[f'rod{k}_offset'] for k in (1, 2, 3)]
    for k in (1, 2, 3):
        uz = np.sqrt(1 - v[f'rod{k}_ux'] ** 2 - v[f'rod{k}_uy'] ** 2)
        out += [v[f'rod{k}_ux'] / uz, v[f'rod{k}_uy'] / uz]
    for k in (1, 2, 3):
        out += [v[f'joint{k}_x'], v[f'joint{k}_y']]
    assert v['kappa1'] == v['kappa2'] == v['kappa3']
    return np.array(out + [v['kappa1']])


def test_core_model_agrees_with_the_independent_reference_model():
    """A perturbed machine through the core (per-row batch, the compliant closure) and through the tests' reference
    model (its own geometry and Gauss-Newton closure): the same platform poses."""
    cfg = load_config()
    core, ref = CoreModel(cfg), ReferenceModel(base_z=False)
    rng = np.random.default_rng(8)
    Q = naive_inverse(rng.uniform(0.05, 0.45, 30), rng.uniform(-1, 1, 30) * cfg.tilt_limit, rng.uniform(-3, 3, 30),
                      cfg)
    values = np.repeat(core.parameters.values(core.parameters.nominal)[None], 4, axis=0)
    values += rng.normal(size=values.shape) * np.tile([3e-5, 3e-5, 4e-5, 1e-4, 1e-4, 3e-5, 3e-5, 0.0], 3)
    for s, kappa in enumerate((0.3, 1.0, 3.0, 50.0)):
        values[s, 7::8] = kappa
    theta = core.parameters.coordinates(values)
    pos, rot = evaluate(core, theta, Q)
    rpos, rrot = evaluate(ref, np.array([core_to_reference(v) for v in values]), Q)
    np.testing.assert_allclose(pos, rpos, rtol=0, atol=1e-13)
    np.testing.assert_allclose(rot, rrot, rtol=0, atol=1e-13)


def test_rotation_vector_and_pose_error_conventions():
    rng = np.random.default_rng(0)
    for scale in (1e-9, 1e-4, 0.5, 3.0):
        rv = rng.normal(size=(200, 3))
        rv *= rng.uniform(0, scale, (200, 1)) / np.linalg.norm(rv, axis=1, keepdims=True)
        np.testing.assert_allclose(rotation_vector(Rotation.from_rotvec(rv).as_matrix()), rv, rtol=0,
                                   atol=1e-15 * max(scale, 1.0))
    R0 = Rotation.from_rotvec(rng.normal(size=(5, 3)) * 0.1).as_matrix()
    dphi = rng.normal(size=(5, 3)) * 1e-5
    R = Rotation.from_rotvec(dphi).as_matrix() @ R0             # a rotation dphi in gpr_base applied after R0
    e = pose_error(np.ones((5, 3)), R, np.zeros(3), R0)
    np.testing.assert_allclose(e[:, :3], 1.0)
    np.testing.assert_allclose(e[:, 3:], dphi, rtol=1e-9, atol=0)


def five_point(f, x, h):
    """Fourth-order central difference of f at x along each coordinate (step h per coordinate)."""
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h[j]
        cols.append((-f(x + 2 * e) + 8 * f(x + e) - 8 * f(x - e) + f(x - 2 * e)) / (12 * h[j]))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize('which', ['core', 'reference'])
def test_parameter_jacobian_against_five_point_differences(which):
    cfg = load_config()
    m = CoreModel(cfg) if which == 'core' else ReferenceModel()
    rng = np.random.default_rng(3)
    Q = naive_inverse(rng.uniform(0.05, 0.45, 8), rng.uniform(-0.0349, 0.0349, 8), rng.uniform(-3, 3, 8), cfg)
    th = m.parameters.nominal + m.parameters.scale * rng.normal(0, 0.3, len(m.parameters))
    if which == 'reference':
        th[21] = 2.5
    else:
        th[7::8] = [0.4, 0.6, -0.2]                                # anisotropies: kappa 2.3, 4, 0.67
    ref = evaluate(m, th, Q)
    meas = (ref[0] + 1e-5, Rotation.from_rotvec(rng.normal(0, 1e-4, (8, 3))).as_matrix() @ ref[1])
    J = pose_jacobian(m, th, Q, reference=meas)
    K = five_point(lambda t: pose_error(*evaluate(m, t, Q), *meas), th, 4 * m.parameters.step)
    scale = np.max(np.abs(K), axis=(0, 1))
    assert np.all(scale > 0)
    np.testing.assert_allclose(J / scale, K / scale, rtol=0, atol=2e-5)
    # Without a reference: the pose's own sensitivities (the reference at theta itself).
    J0 = pose_jacobian(m, th, Q, columns=[1, 3])
    K0 = five_point(lambda t: pose_error(*evaluate(m, t, Q), *ref), th, 4 * m.parameters.step)[:, :, [1, 3]]
    np.testing.assert_allclose(J0 / scale[[1, 3]], K0 / scale[[1, 3]], rtol=0, atol=2e-5)


def test_a_parameter_at_its_bound_has_a_one_sided_finite_column():
    """kappa2 at the top of its range (1e6, which a geometry file allows): its column is the one-sided difference
    down from the bound (it was 0 / 0 = NaN)."""
    cfg = load_config()
    m = CoreModel(cfg)
    ps = m.parameters
    j = ps.index('kappa2')
    Q = naive_inverse(np.array([0.2, 0.4]), np.array([0.02, 0.03]), np.array([0.5, -2.0]), cfg)
    th = ps.nominal.copy()
    th[j] = ps[j].bounds[1]
    J = pose_jacobian(m, th, Q)
    assert np.all(np.isfinite(J))
    h = ps.step[j]
    down = th.copy()
    down[j] -= h
    ref = evaluate(m, th, Q)
    one_sided = (pose_error(*ref, *ref) - pose_error(*evaluate(m, down, Q), *ref)) / h
    np.testing.assert_allclose(J[:, :, j], one_sided, rtol=0, atol=1e-12)
    assert np.max(np.abs(one_sided)) > 0


def test_exact_columns_of_the_reference_model():
    m = ReferenceModel()
    rng = np.random.default_rng(4)
    Q = naive_inverse(rng.uniform(0.05, 0.45, 5), rng.uniform(-0.0349, 0.0349, 5), rng.uniform(-3, 3, 5))
    th = m.parameters.nominal.copy()
    J = pose_jacobian(m, th, Q, columns=[22])[:, :, 0]          # base_z lifts every joint: the platform rises
    np.testing.assert_allclose(J, np.broadcast_to([0, 0, 1, 0, 0, 0], J.shape), atol=1e-9)
    D = displacement_jacobian(m, th, Q)                          # moving all three joints by v moves the pose by v
    np.testing.assert_allclose(D.sum(axis=2), np.broadcast_to(np.vstack([np.eye(3), np.zeros((3, 3))]),
                                                              (5, 6, 3)), atol=1e-9)
    Jq = rod_jacobian(m, th, Q)                                  # equal rod changes lift (parallel nominal rods)
    np.testing.assert_allclose(Jq.sum(axis=2), np.broadcast_to([0, 0, 1, 0, 0, 0], (5, 6)), atol=1e-9)



def test_exact_columns_of_the_core_model():
    """Columns known in closed form: a zero offset is a rod length; moving every base point by v moves the platform
    by v; moving every joint centre by v (joint play) moves the pose by v; equal rod changes lift the platform."""
    core = CoreModel(load_config())
    rng = np.random.default_rng(5)
    Q = naive_inverse(rng.uniform(0.05, 0.45, 6), rng.uniform(-0.0349, 0.0349, 6), rng.uniform(-3, 3, 6))
    th = core.parameters.nominal.copy()
    th[core.parameters.select(['kappa'])] = 0.5
    ps = core.parameters
    J = pose_jacobian(core, th, Q)
    Jq = rod_jacobian(core, th, Q)
    for k in (1, 2, 3):
        np.testing.assert_allclose(J[:, :, ps.index(f'rod{k}_offset')], Jq[:, :, k - 1], rtol=0, atol=1e-9)
    for axis, unit in (('x', [1, 0, 0, 0, 0, 0]), ('y', [0, 1, 0, 0, 0, 0])):
        cols = [ps.index(f'rod{k}_{axis}') for k in (1, 2, 3)]
        np.testing.assert_allclose(J[:, :, cols].sum(axis=2), np.broadcast_to(unit, (6, 6)), atol=1e-9)
    np.testing.assert_allclose(Jq.sum(axis=2), np.broadcast_to([0, 0, 1, 0, 0, 0], (6, 6)), atol=1e-9)
    D = displacement_jacobian(core, th, Q)
    np.testing.assert_allclose(D.sum(axis=2), np.broadcast_to(np.vstack([np.eye(3), np.zeros((3, 3))]), (6, 6, 3)),
                               atol=1e-9)
    # the play of joint 2 along its rod (d = s u_2) is a zero offset s of rod 2
    u = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(D[:, :, 1, :] @ u, J[:, :, ps.index('rod2_offset')], atol=1e-9)


def test_pose_jacobian_names_a_theta_that_is_not_one_row_of_parameters():
    """theta=None was an IndexError deep in the steps (evaluate already named it)."""
    import pytest
    from gpr_kinematics.calibration.core_model import CoreModel
    from gpr_kinematics.calibration.model import pose_jacobian
    from gpr_kinematics.core.config import load_config
    from gpr_kinematics.errors import InputError

    model = CoreModel(load_config())
    for theta, words in ((None, r'theta must be 24 numbers, got None'), ([0.0] * 3, r'got shape \(3,\)'),
                         ([float('nan')] * 24, r'theta\[0\] = nan is not a finite number')):
        with pytest.raises(InputError, match=words):
            pose_jacobian(model, theta, [[0.3, 0.3, 0.3]])

"""Parameter models (gpr_kinematics.calibration.model): parameters, the model interface's checks, pose errors,
rotation vectors, and the finite-difference Jacobians against independent higher-order differences and exact
derivatives."""
from __future__ import annotations

import doctest

import numpy as np
import pytest
from calibration_reference import ReferenceModel
from scipy.spatial.transform import Rotation

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
    rotation_vector,
)
from gpr_kinematics.config import load_config
from gpr_kinematics.errors import InputError
from gpr_kinematics.kinematics import naive_inverse


def test_doctests():
    assert doctest.testmod(model_mod).failed == 0


def test_parameters_and_selection():
    ps = CoreModel(load_config()).parameters
    assert ps.names == ('radius', 'rod_azimuth1', 'rod_azimuth2', 'rod_azimuth3')
    assert ps.groups == ('radius', 'rod_azimuths')
    assert ps.select(['rod_azimuths']).tolist() == [False, True, True, True]
    assert ps.select(['radius', 'rod_azimuth3']).tolist() == [True, False, False, True]
    assert ps.select(None).all() and not ps.select([]).any()
    with pytest.raises(InputError, match=r"unknown parameter 'kappa'; allowed: radius, rod_azimuth1.*whole key: "
                                         r'radius, rod_azimuths'):
        ps.select(['kappa'])
    with pytest.raises(InputError, match=r'unit .inch.; allowed: m, rad, 1'):
        Parameter('a', 0.0, 'inch', 1.0, 'a')
    with pytest.raises(InputError, match=r'scale .* must be finite, the scale > 0'):
        Parameter('a', 0.0, 'm', 0.0, 'a')
    with pytest.raises(InputError, match=r'repeated: a'):
        ParameterSet((Parameter('a', 0.0, 'm', 1.0, 'a'), Parameter('a', 1.0, 'm', 1.0, 'b')))
    assert ps.index('rod_azimuth2') == 2 and ps[0].step == pytest.approx(1e-6)


def test_nested_config_values():
    ps = ReferenceModel().parameters
    th = ps.nominal + 1e-6
    vals = model_mod.config_values(ps, th, {'rod_bases': [[0, 0]] * 3, 'rod_offsets': [0, 0, 0],
                                            'rod_directions': [[0, 0]] * 3, 'platform_joints': [[0, 0]] * 3})
    assert vals['rod_bases'][2] == [th[4], th[5]] and vals['rod_offsets'] == th[6:9].tolist()
    assert vals['kappa'] == th[21] and vals['platform_joints'][0] == [th[15], th[16]]


def test_evaluate_checks_shapes_and_values():
    m = CoreModel(load_config())
    with pytest.raises(InputError, match=r'theta must have 4 values per row'):
        evaluate(m, [0.1, 0.2], [[0.3, 0.3, 0.3]])
    with pytest.raises(InputError, match=r'rod lengths must have shape'):
        evaluate(m, m.parameters.nominal, [[0.3, 0.3]])
    with pytest.raises(InputError, match=r'CoreModel cannot displace its joint centres'):
        evaluate(m, m.parameters.nominal, [[0.3, 0.3, 0.3]], np.zeros((1, 3, 3)))

    class Broken:
        parameters = m.parameters
        supports_displacement = False

        def poses(self, theta, Q, displacement=None):
            return np.full(Q.shape, np.nan), np.zeros(Q.shape + (3,))

    with pytest.raises(InputError, match=r'Broken\.poses returned a non-finite pose'):
        evaluate(Broken(), m.parameters.nominal, [[0.3, 0.3, 0.3]])
    with pytest.raises(InputError, match=r'q2 = nan is not a finite number'):
        pose_jacobian(m, m.parameters.nominal, [[0.3, np.nan, 0.3]])


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
    Jq_core = rod_jacobian(CoreModel(load_config()), CoreModel(load_config()).parameters.nominal, Q)
    np.testing.assert_allclose(Jq_core.sum(axis=2), np.broadcast_to([0, 0, 1, 0, 0, 0], (5, 6)), atol=1e-9)

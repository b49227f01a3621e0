"""The alias of the held parameters on the fitted ones of a measurement plan (gpr_kinematics.calibration.plan
``MeasurementPlan.alias``) against an independent least-squares fit."""
from __future__ import annotations

import numpy as np
import pytest
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.model import evaluate, pose_error
from gpr_kinematics.calibration.plan import plan_measurements
from gpr_kinematics.calibration.tolerances import centre_of, parse_tolerances, prior_of
from gpr_kinematics.core.config import load_config

SP, SA = 3e-6, 2e-5                    # the example table's measurement_noise
#: The example table's parameters only (no rod-length error, no joint play: the calibration's effect alone).
PARAMETERS = {'parameters': {'rod_positions': {'tolerance': 3e-5}, 'rod_offsets': {'tolerance': 5e-5},
                             'rod_directions': {'tolerance': 2e-4, 'distribution': 'normal'},
                             'platform_joints': {'tolerance': 3e-5},
                             'kappa': {'range': [0.5, 2.0], 'distribution': 'log-uniform'}},
              'measurement_noise': {'position': SP, 'angle': SA}}


@pytest.fixture(scope='module')
def planned():
    model = CoreModel(load_config())
    table = parse_tolerances(PARAMETERS)
    plan = plan_measurements(model, model.config, 40, sigma_position=SP, sigma_angle=SA,
                             prior=prior_of(table, model.parameters), theta=centre_of(table, model.parameters))
    return model, table, plan


def _error(model, theta, theta0, Q, tool=None):
    """Pose error vectors (N, 6) of ``theta`` against ``theta0`` by the model's exact evaluation; with ``tool``
    the 9 components of the budget (platform position, rotation vector, tool point)."""
    p, R = evaluate(model, theta, Q)
    p0, R0 = evaluate(model, theta0, Q)
    e = pose_error(p, R, p0, R0)
    if tool is None:
        return e
    return np.concatenate([e, p + R @ tool - p0 - R0 @ tool], axis=1)


def _jacobian(model, theta, Q, cols, step=1e-7, tool=None):
    """Central differences of the exact model: (rows, len(cols)) of the stacked error vectors."""
    out = []
    for j in cols:
        d = np.zeros_like(theta)
        d[j] = step * max(1.0, abs(theta[j]))
        out.append(((_error(model, theta + d, theta, Q, tool) - _error(model, theta - d, theta, Q, tool))
                    / (2 * d[j])).ravel())
    return np.array(out).T


def test_the_plans_alias_is_the_least_squares_fit_of_a_held_deviation(planned):
    """Each held parameter moved by a small amount: the fitted ones fitted by weighted linear least squares to the
    plan's pose errors (the exact model's, its Jacobian by central differences) move by ``alias[:, h]`` of it."""
    model, _, plan = planned
    th0 = plan.at
    assert plan.held_indices.size == 9 and plan.alias.shape == (plan.fitted.size, 9)
    assert set(plan.held_indices.tolist()).isdisjoint(plan.fitted.tolist())
    w = np.tile([1 / SP] * 3 + [1 / SA] * 3, plan.q.shape[0])
    Jf = _jacobian(model, th0, plan.q, plan.fitted) * w[:, None]
    for k, h in enumerate(plan.held_indices):
        delta = np.zeros_like(th0)
        delta[h] = 1e-6
        y = _error(model, th0 + delta, th0, plan.q).ravel() * w        # what the tracker sees of the held deviation
        df = np.linalg.lstsq(Jf, y, rcond=None)[0] / 1e-6
        big = np.max(np.abs(df))
        np.testing.assert_allclose(plan.alias[:, k], df, rtol=0, atol=2e-3 * max(big, 1e-3))
    # the held joint x coordinates of a 120 deg symmetric machine: a rod base moves with them, nearly one to one
    names = model.parameters.names
    r2x = list(plan.fitted).index(names.index('rod2_x'))
    assert plan.alias[r2x, list(plan.held_indices).index(names.index('joint2_x'))] == pytest.approx(-0.996, abs=0.01)

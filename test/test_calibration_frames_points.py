"""Registration of measured points (a reflector) where the tracker stands: the closed-form start and its half turn.

A point ``t`` on a platform tilted by a small horizontal rotation vector ``a`` moves by ``a x t``; turning
``gpr_base`` by half a turn about its z axis and changing the sign of ``t_z`` gives the same motion to first order
in the tilt (``Rz(pi) (a x t') = a x t`` with ``t' = (t_x, t_y, -t_z)``), so the heading search of the closed form
could start the fit there: for 5 of 40 seeded machines (seeds 0, 8, 10, 20, 30 below) it did, and the honest
files failed the gate (out of iterations, ``kappa`` at a bound, reduced chi-square 18-36, the tracker's heading
read as -2.63 rad for 0.52). The second order of the tilt (~60 um here) tells them apart: the start keeps the one
that leaves the smaller errors."""
from __future__ import annotations

import math

import numpy as np
import pytest
from calibration_support import configurations, imperfect
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.frames import FramedModel, Transform, initial_frames, measuring_model
from gpr_kinematics.calibration.identification import identify
from gpr_kinematics.calibration.synthetic import synthetic_measurements
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.rotations import rotation_vector, rpy_matrix

TRACKER = Transform(np.array([1.8, -2.4, 0.7]), rpy_matrix(0.01, -0.02, math.radians(30.0)))
REFLECTOR = Transform(np.array([0.1, 0.0, 0.05]), np.eye(3))
#: The seeds whose closed-form start was half a turn off before.
TURNED = (0, 8, 10, 20, 30)


def points_of(seed: int):
    """60 measured points (3 um noise) of the reflector on a seeded imperfect machine at its datum, in the tracker's
    frame, at random configurations; the model that made them and its coordinates."""
    cfg = load_config()
    core = CoreModel(cfg)
    true_model = FramedModel(core, TRACKER, REFLECTOR, True, 'position', points=True)
    th = imperfect(core, seed, joints=False)
    inner = true_model.inner_theta(th[true_model.independent][None])[0]
    theta = np.concatenate([inner[true_model.independent], TRACKER.position, np.zeros(3), REFLECTOR.position])
    meas = synthetic_measurements(true_model, theta, configurations(cfg, 60, seed), 3e-6, 2e-5, seed=seed,
                                  points=True)
    return core, meas


@pytest.mark.parametrize('seed', TURNED)
def test_the_closed_form_start_of_points_is_not_half_a_turn_off(seed):
    core, meas = points_of(seed)
    base, target = initial_frames(core, meas, None, None, None)
    turn = float(np.linalg.norm(rotation_vector(base.rotation @ TRACKER.rotation.T)))
    assert turn < math.radians(1.0)                              # was 179.7-180.0 deg
    assert abs(target.position[2] - REFLECTOR.position[2]) < 1e-3   # was -0.0497..-0.0506 m: t_z's sign turned
    assert np.linalg.norm(base.position - TRACKER.position) < 2e-3   # was 0.2 m off


def test_an_honest_file_the_start_had_turned_passes_and_registers_the_tracker():
    core, meas = points_of(TURNED[0])
    model = measuring_model(core, meas, 'tracker')
    assert isinstance(model, FramedModel)
    res = identify(model, meas, frame='tracker')
    assert res.gate.passed                                      # failed: out of iterations, chi-square 36.3
    assert res.chi2_reduced < 1.3
    k = model.n_inner
    err = res.estimate[k:k + 3] - TRACKER.position
    se = res.standard_error[k:k + 3]
    assert np.all(np.abs(err) < 4.0 * se)                       # was 0.17, 0.10, 0.10 m off
    base, _ = model.frames(res.estimate)
    heading = rotation_vector(base.rotation @ TRACKER.rotation.T)[2]
    assert abs(heading) < 4.0 * res.standard_error[k + 5]

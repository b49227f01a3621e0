"""The GPR under the mechanism analyses: Jacobians from the core, accuracy, conditioning at the singularity."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from gpr_kinematics.core import forward, forward_batch, inverse
from gpr_kinematics.errors import ConfigError, LimitError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.mechanisms import load_mechanism, mechanism_from_dict
from gpr_kinematics.mechanisms.accuracy import accuracy_analysis
from gpr_kinematics.mechanisms.dexterity import dexterity_sweep

DEG = math.pi / 180


@pytest.fixture(scope='module')
def gpr():
    return load_mechanism(config_path('mechanisms/gpr.yaml'))


POSES = np.array([[0, 0, 0.3, 0.0, 0.0, 0],            # the singular configuration q1 = q2 = q3
                  [0, 0, 0.3, 1e-7, 0.0, 0],           # next to it
                  [0, 0, 0.25, 1.0 * DEG, 0.0, 0],
                  [0, 0, 0.4, 1.2 * DEG, -1.5 * DEG, 0]])


def test_inverse_kinematics_is_the_core(gpr):
    q = gpr.inverse_kinematics(POSES)
    for i, p in enumerate(POSES):
        ref = inverse(p[2], math.hypot(p[3], p[4]), math.atan2(p[4], p[3]), gpr.config)
        np.testing.assert_allclose(q[i], ref.q, atol=1e-14)
    full = gpr.complete_pose(POSES[3])
    fk = forward(q[3], gpr.config)
    np.testing.assert_allclose(full[:3], fk.position, atol=1e-15)
    np.testing.assert_allclose(full[2:5], POSES[3, 2:5], atol=1e-13)      # height and tilt as requested
    np.testing.assert_allclose(gpr.rotation(full)[0], fk.rotation, atol=1e-13)


def test_task_jacobian_matches_differences_of_the_inverse(gpr):
    J = gpr.task_jacobian(POSES)
    h = 1e-6
    for k, idx in enumerate((2, 3, 4)):
        d = np.zeros(6)
        d[idx] = h
        fd = (gpr.inverse_kinematics(POSES + d) - gpr.inverse_kinematics(POSES - d)) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=1e-8)
    # Naive model check: dq_k/dz = 1 for every rod.
    np.testing.assert_allclose(J[:, :, 0], 1.0, atol=1e-8)


def test_inverse_jacobian_exact_on_the_gpr_twists(gpr):
    J6, T = gpr.inverse_jacobian(POSES), gpr.motion_basis(POSES)
    np.testing.assert_allclose(J6 @ T, gpr.task_jacobian(POSES), atol=1e-12)
    assert J6.shape == (4, 3, 6)


def test_conditioning_through_the_singular_configuration(gpr):
    """The virtual joints keep dq/du regular at q1 = q2 = q3: condition ~sqrt(2) (homogenised by R)."""
    cond = gpr.condition_number(POSES)
    np.testing.assert_allclose(cond, math.sqrt(2), rtol=2e-3)
    assert not gpr.is_singular(POSES).any()
    dmap = dexterity_sweep(gpr, gpr.home_pose, 'tilt_x', np.linspace(-2 * DEG, 2 * DEG, 9))
    assert np.all(dmap.within_limits) and np.all(np.isfinite(dmap.condition_number))
    assert np.ptp(dmap.dexterity) < 1e-3


def test_a_dexterity_map_beyond_the_limits_marks_those_poses(gpr):
    """A sweep or map reaching past the tilt limit or the stroke was refused whole (the core's LimitError); every
    other mechanism marks such poses outside the limits (white cells). The poses within are computed as before (the
    same numbers to the last bit), those beyond with the model's domain (15 deg, the stroke's span either side)."""
    from gpr_kinematics.errors import LimitError
    from gpr_kinematics.mechanisms.dexterity import dexterity_grid

    tilts = np.linspace(-0.05, 0.05, 5)     # the limit is 2 deg = 0.0349 rad
    dmap = dexterity_sweep(gpr, gpr.home_pose, 'tilt_x', tilts)
    assert dmap.within_limits.tolist() == [False, True, True, True, False]
    inside = dexterity_sweep(gpr, gpr.home_pose, 'tilt_x', tilts[1:4])
    assert dmap.dexterity[1:4].tolist() == inside.dexterity.tolist()
    np.testing.assert_allclose(dmap.dexterity[[0, 4]], 1.0 / gpr.unlimited().condition_number(dmap.poses[[0, 4]]),
                               rtol=1e-12)
    with pytest.raises(LimitError):
        gpr.inverse_kinematics(dmap.poses[0])   # the GPR itself still refuses it
    heights = dexterity_sweep(gpr, gpr.home_pose, 'z', [0.4, 0.5, 0.55])   # 0.55 m puts a rod beyond 0.508 m
    assert heights.within_limits.tolist() == [True, True, False] and np.all(np.isfinite(heights.dexterity))
    square = dexterity_grid(gpr, gpr.home_pose, 'tilt_x', [-0.03, 0.0, 0.03], 'tilt_y', [-0.03, 0.0, 0.03])
    assert square.within_limits.tolist() == [[False, True, False], [True, True, True], [False, True, False]]


def test_accuracy_rod_errors_and_imperfections_second_order(gpr):
    rng = np.random.default_rng(4)
    dq, delta = rng.normal(size=3), rng.normal(size=(3, 3))
    diffs, twist_diffs = [], []
    for eps in (1e-4, 1e-5, 1e-6):
        res = accuracy_analysis(gpr, POSES[2], dq * eps, {'joint_imperfections': delta * eps})
        diffs.append(np.max(np.abs(res.difference)))
        twist_diffs.append(np.max(np.abs(res.exact_twist - res.linearized_twist)))
        assert np.max(np.abs(res.linearized)) > eps * 0.1
    assert 50 < diffs[0] / diffs[1] < 200 and 50 < diffs[1] / diffs[2] < 200
    assert 50 < twist_diffs[0] / twist_diffs[1] < 200


def test_joint_imperfections_keep_every_joint_on_its_rod_tip(gpr):
    """A joint displaced by delta_k (platform frame) is solved as the closure with r_k(X) + delta_k on the rod tip P_k
    (a trial's own radial closure): the radial model's radial joints take a radial 0.1 mm whole (the platform stays;
    it moved -33.3 um, a least-squares fit of the old X leaving each joint 33 um off its tip), a tangential one moves
    the platform -66.6 um sideways and 2.3 um down. Each joint lands on its tip to 1e-14 m."""
    from gpr_kinematics.core import base_points
    from gpr_kinematics.core.virtual_joints import make_model

    pose = np.array([0, 0, 0.5, 2 * DEG, 0, 0])
    q = gpr.inverse_kinematics(pose)
    nominal = gpr.forward_poses(q[None])[0]
    for k, (d, moved) in enumerate(((1e-4, [0.0, 0.0, 0.0]), (1e-4, [-23.84e-9, -66.6464e-6, -2.3273e-6]))):
        delta = np.zeros((3, 3))
        delta[0, k] = d
        imperfect = gpr.with_parameters({'joint_imperfections': delta})
        out = imperfect.forward_poses(q[None])[0]
        np.testing.assert_allclose(out[:3] - nominal[:3], moved, rtol=0, atol=1e-10)
        R = imperfect.rotation(out[None])[0]
        D = -(R @ delta.T).T   # the model's joints at P_k - R delta_k: the closure's virtual joints
        X = forward_batch(q[None], gpr.config, check_limits=False, displacement=D[None]).virtual_joints
        r2 = make_model(gpr.config).points_and_partials(X)[0][0]
        joints = (R @ (np.column_stack([r2, np.zeros(3)]) + delta).T).T + out[:3]
        np.testing.assert_allclose(joints, base_points(q[None], gpr.config)[0], rtol=0, atol=1e-14)
    assert accuracy_analysis(gpr, pose, None, {'joint_imperfections': np.eye(3)[:1].T @ [[1e-4, 0, 0]]}
                             ).exact_twist[0, :3] == pytest.approx([0, 0, 0], abs=1e-14)


def test_rod_errors_alone_equal_forward_kinematics(gpr):
    dq = np.array([2e-4, -1e-4, 5e-5])
    res = accuracy_analysis(gpr, POSES[0], dq)
    fk = forward(gpr.inverse_kinematics(POSES[0]) + dq, gpr.config)
    np.testing.assert_allclose(res.exact_poses[0, :3], fk.position, atol=1e-15)
    # At the singular configuration a pure height error moves the platform straight up.
    res_z = accuracy_analysis(gpr, POSES[0], np.full(3, 1e-4))
    np.testing.assert_allclose(res_z.exact[0], [1e-4, 0, 0], atol=1e-15)


def test_limits_and_yaml(gpr):
    with pytest.raises(LimitError, match='tilt'):
        gpr.inverse_kinematics([0, 0, 0.3, 3 * DEG, 0, 0])
    mech = mechanism_from_dict({'type': 'gpr', 'overrides': {'model': 'polar'}, 'workspace': {}}, 'g.yaml')
    assert mech.config.model == 'polar'
    with pytest.raises(ConfigError, match=r'^g\.yaml: overrides: radius = -1 is invalid'):
        mechanism_from_dict({'type': 'gpr', 'overrides': {'radius': -1}}, 'g.yaml')
    with pytest.raises(ConfigError, match=r'^g\.yaml: overrides: unknown key\(s\) imperfection_budgt'):  # said twice
        mechanism_from_dict({'type': 'gpr', 'overrides': {'imperfection_budgt': 1e-3}}, 'g.yaml')


def test_the_documented_conditioning_range_over_the_tilt_range(gpr):
    """docs/mechanisms.md: the condition number over the whole +-2 deg tilt range is 1.4136..1.4142 (it said
    1.4137: at 2 deg, about any axis and at any height, it is 1.41364)."""
    a = 2 * DEG
    g = np.linspace(0.0, 2 * math.pi, 25)
    poses = np.zeros((3 * g.size, 6))
    poses[:, 2] = np.repeat([0.05, 0.25, 0.45], g.size)
    poses[:, 3], poses[:, 4] = np.tile(a * np.cos(g), 3), np.tile(a * np.sin(g), 3)
    cond = gpr.condition_number(np.concatenate([poses, [[0, 0, 0.25, 0, 0, 0]]]))
    text = (Path(__file__).resolve().parents[1] / 'docs' / 'mechanisms.md').read_text()
    lo, hi = re.search(r'and (1\.\d{4})\.\.(1\.\d{4}) over the whole \+-2 deg tilt', text).groups()
    assert f'{cond.min():.4f}' == lo and f'{cond.max():.4f}' == hi

"""gpr_kinematics.robot_model (no ROS): the URDF and the joint transforms follow the geometry configuration; an
independent URDF parser (yourdfpy) reads the same kinematics; the shipped urdf/gpr.urdf is the generated one."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gpr_kinematics.config import load_config
from gpr_kinematics.errors import InputError
from gpr_kinematics.geometry import matrix_from_quaternion
from gpr_kinematics.robot_model import Joint, Link, RobotModel, gpr_model, joint_transform, rpy_matrix

ROOT = Path(__file__).resolve().parents[1]
CFG = load_config()


def _urdf(tmp_path, model):
    import yourdfpy

    path = tmp_path / 'robot.urdf'
    path.write_text(model.to_urdf())
    return yourdfpy.URDF.load(str(path), build_collision_scene_graph=False, load_meshes=False)


def test_shipped_urdf_is_the_generated_one():
    assert (ROOT / 'urdf' / 'gpr.urdf').read_text() == gpr_model(CFG).to_urdf()


def test_frames_and_joints():
    model = gpr_model(CFG)
    assert model.root == 'gpr_base'
    names = {link.name for link in model.links}
    assert {'gpr_base', 'gpr_platform', 'gpr_platform_nominal'} <= names
    assert {f'gpr_rod_{k}' for k in (1, 2, 3)} | {f'gpr_rod_guide_{k}' for k in (1, 2, 3)} <= names
    kinds = {j.name: j.kind for j in model.joints}
    assert [n for n, k in kinds.items() if k == 'prismatic'] == ['rod_1', 'rod_2', 'rod_3']
    assert kinds['gpr_platform_pose'] == kinds['gpr_platform_nominal_pose'] == 'floating'
    rod = model.joint('rod_2')
    assert (rod.lower, rod.upper) == (CFG.stroke_min, CFG.stroke_max)


@pytest.mark.parametrize('q', [(0.5, 0.5, 0.5), (0.1, 0.3, 0.45)])
def test_rod_tops_are_the_joint_centres(q):
    """guide (fixed, at the foot) then the prismatic joint: the rod top is P_k = (R cos t_k, R sin t_k, q_k)."""
    model = gpr_model(CFG)
    for k, (theta, qk) in enumerate(zip(CFG.rod_azimuths, q, strict=True), start=1):
        t1, r1 = model.transform(f'gpr_rod_guide_{k}_mount')
        t2, r2 = model.transform(f'rod_{k}', qk)
        top = np.asarray(t1) + matrix_from_quaternion(r1) @ np.asarray(t2)
        np.testing.assert_allclose(top, [CFG.radius * math.cos(theta), CFG.radius * math.sin(theta), qk],
                                   rtol=0, atol=1e-15)
        np.testing.assert_allclose(r2, [0, 0, 0, 1], atol=0)


def test_geometry_is_the_configuration():
    """One source of truth: another radius and stroke change the URDF."""
    other = CFG.replace(radius=0.12, stroke_max=0.3)
    model = gpr_model(other)
    t, _ = model.transform('gpr_rod_guide_1_mount')
    assert t == pytest.approx([0.12, 0.0, 0.0], abs=1e-15)
    assert model.joint('rod_1').upper == 0.3
    assert gpr_model(other).to_urdf() != gpr_model(CFG).to_urdf()


def test_independent_urdf_parser_agrees(tmp_path):
    """yourdfpy (a URDF library from the registry) reads the generated file: same links and joints, and its
    forward kinematics of the rods equals robot_model's."""
    model = gpr_model(CFG)
    urdf = _urdf(tmp_path, model)
    assert set(urdf.link_map) == {link.name for link in model.links}
    assert {j.name: j.type for j in urdf.robot.joints} == {j.name: j.kind for j in model.joints}
    q = (0.12, 0.34, 0.25)
    urdf.update_cfg({'rod_1': q[0], 'rod_2': q[1], 'rod_3': q[2]})
    for k in (1, 2, 3):
        T = urdf.get_transform(f'gpr_rod_{k}', 'gpr_base')
        theta = CFG.rod_azimuths[k - 1]
        np.testing.assert_allclose(T[:3, 3], [CFG.radius * math.cos(theta), CFG.radius * math.sin(theta), q[k - 1]],
                                   atol=1e-15)


def test_extended_model_revolute_joint_and_rpy(tmp_path):
    """The model takes more links (an arm on the platform): a revolute joint with an rpy origin, checked
    against yourdfpy's kinematics."""
    arm = (Link('arm_link_1'), Link('arm_link_2'))
    joints = (Joint('arm_mount', 'fixed', 'gpr_platform', 'arm_link_1', xyz=(0.05, 0.0, 0.02), rpy=(0.1, -0.2, 0.3)),
              Joint('arm_joint_1', 'revolute', 'arm_link_1', 'arm_link_2', xyz=(0.3, 0.0, 0.0), axis=(0.0, 0.0, 1.0),
                    lower=-3.0, upper=3.0))
    model = gpr_model(CFG).extended(arm, joints)
    urdf = _urdf(tmp_path, model)
    urdf.update_cfg({'arm_joint_1': 0.7, 'rod_1': 0.1, 'rod_2': 0.1, 'rod_3': 0.1})
    expect = urdf.get_transform('arm_link_2', 'arm_link_1')
    t, r = joint_transform(model.joint('arm_joint_1'), 0.7)
    np.testing.assert_allclose(expect[:3, 3], t, atol=1e-15)
    np.testing.assert_allclose(expect[:3, :3], matrix_from_quaternion(r), atol=1e-15)
    mount = urdf.get_transform('arm_link_1', 'gpr_platform')
    np.testing.assert_allclose(mount[:3, :3], rpy_matrix((0.1, -0.2, 0.3)), atol=1e-15)


def test_invalid_models_refused():
    with pytest.raises(InputError, match='floating'):
        gpr_model(CFG).transform('gpr_platform_pose')
    with pytest.raises(InputError, match='no joint'):
        gpr_model(CFG).joint('nope')
    with pytest.raises(InputError, match='exactly one parent'):
        RobotModel('r', 'a', (Link('a'), Link('b')), ())
    with pytest.raises(InputError, match='invalid'):
        RobotModel('r', 'a', (Link('a'), Link('b')), (Joint('j', 'ball', 'a', 'b'),))


def test_robot_figure_draws_the_true_shift(tmp_path):
    """The picture of docs/ros.md: a PNG; the shift it labels is forward kinematics' centre shift."""
    from gpr_kinematics.kinematics import forward, inverse
    from gpr_kinematics.robot_plot import robot_figure

    q = inverse(0.4, math.radians(2.0), math.radians(30.0), CFG).q
    fig = robot_figure(CFG, q, tmp_path / 'robot.png', exaggeration=1500.0)
    assert (tmp_path / 'robot.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    np.testing.assert_array_equal(fig.centre_shift, forward(q, CFG).centre_shift)
    assert 20e-6 < np.linalg.norm(fig.centre_shift) < 40e-6 and fig.exaggeration == 1500.0

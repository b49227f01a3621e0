"""gpr_kinematics.robot.urdf (no ROS): the URDF and the joint transforms follow the geometry configuration and the
robot description (the arms, blades, wafers); an independent URDF parser (yourdfpy) reads the same kinematics as
the robot core; the shipped urdf/gpr.urdf and urdf/example_robot.urdf are the generated ones; the figure."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.rotations import matrix_from_quaternion, rpy_matrix
from gpr_kinematics.errors import InputError
from gpr_kinematics.robot import Stations, load_robot, robot_forward, solve_stations
from gpr_kinematics.robot.forward import platform_to_blade
from gpr_kinematics.robot.urdf import Joint, Link, RobotUrdf, gpr_urdf, joint_transform, main, robot_urdf

ROOT = Path(__file__).resolve().parents[1]
CFG = load_config()
ROBOT = load_robot()


def _urdf(tmp_path, model):
    import yourdfpy

    path = tmp_path / 'robot.urdf'
    path.write_text(model.to_urdf())
    return yourdfpy.URDF.load(str(path), build_collision_scene_graph=False, load_meshes=False)


def test_shipped_urdf_is_the_generated_one():
    assert (ROOT / 'gpr_kinematics' / 'urdf' / 'gpr.urdf').read_text() == \
        gpr_urdf(CFG, rod_velocity=ROBOT.rods.velocity).to_urdf()


def test_frames_and_joints():
    model = gpr_urdf(CFG)
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
    model = gpr_urdf(CFG)
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
    model = gpr_urdf(other)
    t, _ = model.transform('gpr_rod_guide_1_mount')
    assert t == pytest.approx([0.12, 0.0, 0.0], abs=1e-15)
    assert model.joint('rod_1').upper == 0.3
    assert gpr_urdf(other).to_urdf() != gpr_urdf(CFG).to_urdf()


def test_independent_urdf_parser_agrees(tmp_path):
    """yourdfpy (a URDF library from the registry) reads the generated file: same links and joints, and its
    forward kinematics of the rods equals robot_model's."""
    model = gpr_urdf(CFG)
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
    model = gpr_urdf(CFG).extended(arm, joints)
    urdf = _urdf(tmp_path, model)
    urdf.update_cfg({'arm_joint_1': 0.7, 'rod_1': 0.1, 'rod_2': 0.1, 'rod_3': 0.1})
    expect = urdf.get_transform('arm_link_2', 'arm_link_1')
    t, r = joint_transform(model.joint('arm_joint_1'), 0.7)
    np.testing.assert_allclose(expect[:3, 3], t, atol=1e-15)
    np.testing.assert_allclose(expect[:3, :3], matrix_from_quaternion(r), atol=1e-15)
    mount = urdf.get_transform('arm_link_1', 'gpr_platform')
    np.testing.assert_allclose(mount[:3, :3], rpy_matrix(0.1, -0.2, 0.3), atol=1e-15)


def test_invalid_models_refused():
    with pytest.raises(InputError, match='floating'):
        gpr_urdf(CFG).transform('gpr_platform_pose')
    with pytest.raises(InputError, match='no joint'):
        gpr_urdf(CFG).joint('nope')
    with pytest.raises(InputError, match='exactly one parent'):
        RobotUrdf('r', 'a', (Link('a'), Link('b')), ())
    with pytest.raises(InputError, match='invalid'):
        RobotUrdf('r', 'a', (Link('a'), Link('b')), (Joint('j', 'ball', 'a', 'b'),))
    # an arm joint named like a rod joint gave a URDF with two joints rod_1 (and the wrong tf for the arm)
    robot = load_robot()
    arm = robot.arms[0]
    renamed = dataclasses.replace(arm, joints=(dataclasses.replace(arm.joints[0], name='rod_1'), *arm.joints[1:]))
    with pytest.raises(InputError, match=r'joint name\(s\) rod_1 used twice'):
        robot_urdf(dataclasses.replace(robot, arms=(renamed, *robot.arms[1:])))
    # a frame parameter named like a link of the robot: "link names must be unique" named neither
    for key, value in (('platform_frame', 'world'), ('nominal_frame', 'arm1_link1'), ('base_frame', 'arm2_wafer')):
        with pytest.raises(InputError, match=rf"^{key} = '{value}' is the name of another frame of robot "
                                             f'{robot.name} .*; allowed: a frame of its own$'):
            robot_urdf(robot, **{key: value})
    with pytest.raises(InputError, match=r"^robot model r: 'b' is the name of two links; allowed: unique link names"):
        RobotUrdf('r', 'a', (Link('a'), Link('b'), Link('b')), ())
    with pytest.raises(InputError, match=r"^robot model r: no link is the root 'c'; allowed: unique link names"):
        RobotUrdf('r', 'c', (Link('a'), Link('b')), ())


def test_robot_figure_draws_the_true_errors(tmp_path):
    """The picture of docs/ros.md: a PNG of the whole robot; the centre shift and wafer errors it labels are the
    kinematics' own; the exaggeration scales the exact platform's difference from the naive one."""
    from gpr_kinematics.robot.plot import exaggerated, robot_figure

    sol = solve_stations(ROBOT, Stations.of([[1.2, 0.95, 0.45]], math.radians(2.0), math.radians(30.0), 0.8), 'arm1')
    fig = robot_figure(ROBOT, sol.rods[0], {'arm1': sol.joints[0]}, tmp_path / 'robot.png', exaggeration=1500.0)
    assert (tmp_path / 'robot.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    fk = robot_forward(ROBOT, sol.rods, sol.joints, 'arm1')
    np.testing.assert_array_equal(fig.centre_shift, fk.gpr.centre_shift[0])
    np.testing.assert_array_equal(fig.wafer_error['arm1'], fk.naive_wafer_error[0])
    np.testing.assert_array_equal(fig.joints['arm2'], ROBOT.arm('arm2').home)     # not given: at home
    assert 20e-6 < np.linalg.norm(fig.centre_shift) < 40e-6 and fig.exaggeration == 1500.0
    # exaggerated(): k times the relative transform, translation and rotation (a small rotation about z here).
    a = np.eye(4)
    b = np.eye(4)
    b[:3, :3] = rpy_matrix(0.0, 0.0, 1e-5)
    b[:3, 3] = (1e-6, -2e-6, 0.0)
    d = exaggerated(a, b, 1000.0)
    np.testing.assert_allclose(d[:3, 3], [1e-3, -2e-3, 0.0], rtol=1e-12)
    np.testing.assert_allclose(d[:3, :3], rpy_matrix(0.0, 0.0, 1e-2), atol=1e-15)


def test_shipped_example_robot_urdf_is_the_generated_one():
    assert (ROOT / 'gpr_kinematics' / 'urdf' / 'example_robot.urdf').read_text() == robot_urdf(ROBOT).to_urdf()


def test_whole_robot_frames_and_the_arm_chain_equal_the_robot_core(tmp_path):
    """robot_urdf of the example robot: world -> gpr_base fixed at the description's base; every arm's revolute
    joints by the description's names; yourdfpy's forward kinematics of gpr_platform -> wafer equals the robot
    core's (platform_to_blade) for random postures."""
    model = robot_urdf(ROBOT)
    assert model.root == 'world'
    assert model.joint('gpr_base_mount').xyz == ROBOT.base_position
    kinds = {j.name: j.kind for j in model.joints}
    for arm in ROBOT.arms:
        assert [kinds[n] for n in arm.joint_names] == ['revolute'] * len(arm.joints)
        assert kinds[f'{arm.name}_blade_mount'] == kinds[f'{arm.name}_wafer_mount'] == 'fixed'
        assert model.joint(arm.joint_names[0]).parent == 'gpr_platform'
    urdf = _urdf(tmp_path, model)
    assert urdf.base_link == 'world'
    rng = np.random.default_rng(4)
    for arm in ROBOT.arms:
        J = rng.uniform(arm.lower, arm.upper)
        urdf.update_cfg(dict(zip(arm.joint_names, J, strict=True)))
        T = urdf.get_transform(arm.wafer_frame, 'gpr_platform')
        blade, wafer = platform_to_blade(arm, J[None, :])
        np.testing.assert_allclose(T[:3, 3], wafer.position[0], rtol=0, atol=1e-14)
        np.testing.assert_allclose(T[:3, :3], wafer.rotation[0], rtol=0, atol=1e-14)
        B = urdf.get_transform(arm.blade_frame, 'gpr_platform')
        np.testing.assert_allclose(B[:3, 3], blade.position[0], rtol=0, atol=1e-14)
        assert model.joint(arm.joint_names[1]).lower == arm.joints[1].lower


def test_an_imperfect_machines_rods_in_the_model(tmp_path):
    """Rod guides at the feet P_k(0) = B_k + o_k u_k, prismatic axes along u_k: guide + rod at q is the joint centre
    of the kinematics (base_points) on that machine."""
    from gpr_kinematics.core import base_points
    from ros_support import imperfect_config_file

    _, cfg = imperfect_config_file(tmp_path)
    model = gpr_urdf(cfg)
    q = np.array([0.21, 0.33, 0.27])
    centres = base_points(q[None, :], cfg)[0]
    for k in range(3):
        t1, r1 = model.transform(f'gpr_rod_guide_{k + 1}_mount')
        t2, _ = model.transform(f'rod_{k + 1}', q[k])
        np.testing.assert_allclose(np.asarray(t1) + matrix_from_quaternion(r1) @ np.asarray(t2), centres[k],
                                   rtol=0, atol=1e-15)
    assert model.joint('rod_1').axis != (0.0, 0.0, 1.0)


def test_docstring_examples_of_the_model_and_the_figure():
    import doctest

    from gpr_kinematics.robot import plot as robot_plot
    from gpr_kinematics.robot import urdf as model_module

    for module in (model_module, robot_plot):
        result = doctest.testmod(module)
        assert result.attempted > 0 and result.failed == 0, module.__name__


def test_main_refuses_an_unreadable_robot_file_in_one_line(capsys, tmp_path):
    assert main([str(tmp_path / 'missing.yaml')]) == 2
    err = capsys.readouterr().err
    assert err.startswith('robot_urdf: error: cannot read robot file') and err.count('\n') == 1
    assert 'Traceback' not in err


def test_urdf_for_a_motion_stack(tmp_path):
    """The example robot's URDF as a motion stack reads it (yourdfpy): every moving joint's velocity limit is the
    description's (rods: rods.velocity), effort 0 (not given); every link with a shape has a positive mass and a
    positive definite inertia (the triangle inequality holds); the wafer's is the silicon disc's; the closed chain is
    explained next to the floating platform joint."""
    import yourdfpy

    model = robot_urdf(ROBOT)
    path = tmp_path / 'robot.urdf'
    path.write_text(model.to_urdf())
    urdf = yourdfpy.URDF.load(str(path), build_collision_scene_graph=False, load_meshes=False)
    limits = {j.name: j.limit for j in urdf.robot.joints if j.type in ('revolute', 'prismatic')}
    want = {**{f'rod_{k}': ROBOT.rods.velocity for k in (1, 2, 3)},
            **{j.name: j.velocity for a in ROBOT.arms for j in a.joints}}
    assert {n: lim.velocity for n, lim in limits.items()} == want and all(v > 0 for v in want.values())
    assert all(lim.effort == 0.0 for lim in limits.values())
    for link in urdf.robot.links:
        if not link.visuals or link.name == 'gpr_platform_nominal':
            # the world, and the naive model's ghost of the platform: not bodies (the platform counted once)
            assert link.inertial is None and not link.collisions and link.name in ('world', 'gpr_platform_nominal')
            continue
        eig = np.linalg.eigvalsh(link.inertial.inertia)
        assert link.inertial.mass > 0 and eig.min() > 0, link.name
        assert eig.max() <= eig.sum() - eig.max() + 1e-15, link.name
    wafer = next(link for link in urdf.robot.links if link.name == 'arm1_wafer').inertial
    r, h, m = ROBOT.wafer.diameter / 2, ROBOT.wafer.thickness, ROBOT.wafer.mass
    assert wafer.mass == pytest.approx(m, rel=1e-5)           # the URDF prints 6 digits
    np.testing.assert_allclose(np.diag(wafer.inertia), [m * (3 * r * r + h * h) / 12] * 2 + [m * r * r / 2],
                               rtol=1e-5)
    text = model.to_urdf()
    note = text.index('<!-- The platform closes an overconstrained loop')
    assert note < text.index('<joint name="gpr_platform_pose" type="floating">') and 'robot_state_publisher' in \
        text[note:text.index('-->', note)]


def test_the_wafer_is_drawn_and_weighed_as_the_description_gives_it():
    """A 200 mm wafer of 53 g: the URDF drew and weighed a 300 mm one of 127.6 g (its collision disc was right)."""
    import dataclasses

    from gpr_kinematics.robot.collision import WaferShape

    robot = dataclasses.replace(ROBOT, wafer=WaferShape(0.200, 0.000725, 0.053))
    link = next(k for k in robot_urdf(robot).links if k.name == 'arm2_wafer')
    assert link.visuals[0].shape == 'cylinder' and link.visuals[0].size == (0.1, 0.000725)
    assert link.collisions[0].size == link.visuals[0].size
    assert link.inertial.mass == 0.053 and link.inertial.inertia[5] == pytest.approx(0.5 * 0.053 * 0.01, rel=1e-15)


def test_composite_inertia_by_the_parallel_axis_theorem():
    """Two spheres at x = +-d, and a box turned by 90 deg about z: the inertia about the common centre of mass."""
    from gpr_kinematics.robot.shapes import DENSITY, Visual, default_inertial

    r, d = 0.01, 0.05
    two = default_inertial([Visual('sphere', (r,), (d, 0.0, 0.0)), Visual('sphere', (r,), (-d, 0.0, 0.0))])
    m = DENSITY * 4 / 3 * math.pi * r ** 3
    assert two.mass == pytest.approx(2 * m, rel=1e-15) and two.xyz == pytest.approx((0, 0, 0), abs=1e-18)
    np.testing.assert_allclose(two.inertia, [0.8 * m * r * r, 0, 0, 0.8 * m * r * r + 2 * m * d * d, 0,
                                             0.8 * m * r * r + 2 * m * d * d], rtol=1e-12, atol=1e-20)
    box = default_inertial([Visual('box', (0.3, 0.1, 0.02), (0.1, 0.0, 0.0), (0.0, 0.0, math.pi / 2))])
    mb = DENSITY * 0.3 * 0.1 * 0.02
    np.testing.assert_allclose(box.inertia, [mb * (0.3 ** 2 + 0.02 ** 2) / 12, 0, 0, mb * (0.1 ** 2 + 0.02 ** 2) / 12,
                                             0, mb * (0.3 ** 2 + 0.1 ** 2) / 12], rtol=1e-12, atol=1e-18)
    assert default_inertial([]) is None


def test_frame_prefix_names_every_link_and_keeps_the_joints(tmp_path):
    """robot_urdf(frame_prefix='r1/'): every link (tf frame) r1/..., joints as before, the same kinematics."""
    plain, prefixed = robot_urdf(ROBOT), robot_urdf(ROBOT, frame_prefix='r1/')
    assert prefixed.root == 'r1/world'
    assert [link.name for link in prefixed.links] == ['r1/' + link.name for link in plain.links]
    assert [j.name for j in prefixed.joints] == [j.name for j in plain.joints]
    assert all(j.parent.startswith('r1/') and j.child.startswith('r1/') for j in prefixed.joints)
    urdf = _urdf(tmp_path, prefixed)
    urdf.update_cfg({'arm1_elbow': 0.7, 'rod_2': 0.3})
    T = urdf.get_transform('r1/arm1_wafer', 'r1/gpr_platform')
    blade, wafer = platform_to_blade(ROBOT.arm('arm1'), np.array([[0.0, 0.7, 0.0]]))
    np.testing.assert_allclose(T[:3, 3], wafer.position[0], rtol=0, atol=1e-14)


def test_collision_shapes_are_written(tmp_path):
    """A link's collision shapes (the hook the robot description's collision shapes fill) become <collision>."""
    from gpr_kinematics.robot.shapes import Visual

    shape = Visual('box', (0.3, 0.05, 0.02), (0.15, 0.0, 0.0))
    model = RobotUrdf('m', 'a', (Link('a'), Link('b', (shape,), collisions=(shape,))),
                      (Joint('j', 'revolute', 'a', 'b', lower=-1.0, upper=1.0, velocity=2.0),))
    urdf = _urdf(tmp_path, model)
    (col,) = urdf.link_map['b'].collisions
    np.testing.assert_allclose(col.geometry.box.size, [0.3, 0.05, 0.02])
    assert urdf.robot.joints[0].limit.velocity == 2.0


def test_the_naive_platform_is_a_ghost_not_a_body(tmp_path):
    """gpr_platform_nominal (the old tool's pose of the platform) is drawn only: no <inertial>, no <collision>, in the
    GPR's URDF and the whole robot's (the shipped files too), so the platform's mass and shape count once, on
    gpr_platform; a ghost keeps no inertia or collision even when given them."""
    from gpr_kinematics.robot.shapes import Visual, default_inertial

    share = Path(__file__).resolve().parents[1] / 'gpr_kinematics' / 'urdf'
    for model, shipped in ((gpr_urdf(ROBOT.config, rod_velocity=ROBOT.rods.velocity), 'gpr.urdf'),
                           (robot_urdf(ROBOT), 'example_robot.urdf')):
        urdf = _urdf(tmp_path, model)
        ghost, platform = urdf.link_map['gpr_platform_nominal'], urdf.link_map['gpr_platform']
        assert ghost.visuals and ghost.inertial is None and not ghost.collisions
        assert platform.inertial.mass > 0.0 and ghost.visuals[0].geometry.cylinder.radius == \
            platform.visuals[0].geometry.cylinder.radius
        text = (share / shipped).read_text()
        start = text.index('<link name="gpr_platform_nominal">')
        block = text[start:text.index('</link>', start)]
        assert '<inertial>' not in block and '<collision>' not in block and '<visual>' in block
        assert text.count('<inertial>') == sum(1 for link in urdf.robot.links if link.inertial is not None)
    shape = Visual('box', (0.3, 0.05, 0.02))
    forced = RobotUrdf('m', 'a', (Link('a'), Link('g', (shape,), (shape,), default_inertial([shape]), ghost=True)),
                       (Joint('j', 'fixed', 'a', 'g'),))
    g = _urdf(tmp_path, forced).link_map['g']
    assert g.inertial is None and not g.collisions and g.visuals


@pytest.mark.parametrize('text', ['arm1_link1', 'a&b<c>d', 'say "hi"', "it's", 'both \' and "', 'tab\there\nnew\rline',
                                  '&amp; already', ''])
def test_urdf_quoteattr_writes_what_the_standard_library_writes(text):
    """The URDF's own attribute quoting (no xml.sax import at a node's start) equals xml.sax.saxutils.quoteattr."""
    from xml.sax.saxutils import quoteattr as standard

    from gpr_kinematics.robot.urdf import quoteattr

    assert quoteattr(text) == standard(text)


def test_the_shipped_urdf_collides_with_the_bodies_the_clearance_check_measures():
    """Issue 21's "a <collision> on every arm link, blade and wafer" and issue 19's "the same shapes": in the shipped
    urdf/example_robot.urdf read by yourdfpy, every link of every arm (its links, blade and wafer) has a <collision>,
    and link by link the collisions are the bodies of `gpr program check` (kind, size, pose in the link), the column
    and the platform included; no other link collides."""
    import yourdfpy
    from gpr_kinematics.safety.bodies import robot_body_set

    urdf = yourdfpy.URDF.load(str(ROOT / 'gpr_kinematics' / 'urdf' / 'example_robot.urdf'),
                              build_collision_scene_graph=False, load_meshes=False)
    bodies: dict[str, list] = {}
    for b in robot_body_set(ROBOT):
        bodies.setdefault(b.frame, []).append(b)
    arm_links = [link.name for link in urdf.robot.links if any(link.name.startswith(f'{a.name}_') for a in ROBOT.arms)]
    for a in ROBOT.arms:
        assert {f'{a.name}_blade', f'{a.name}_wafer', f'{a.name}_link1'} <= set(arm_links)
    assert all(urdf.link_map[name].collisions for name in arm_links)
    colliding = {link.name for link in urdf.robot.links if link.collisions}
    assert colliding == set(bodies) and set(arm_links) | {'gpr_base', 'gpr_platform'} == colliding
    for name in colliding:
        cols, want = urdf.link_map[name].collisions, bodies[name]
        assert len(cols) == len(want), name
        for c, b in zip(cols, want, strict=True):
            g = c.geometry
            size = tuple(g.box.size) if b.kind == 'box' else (g.cylinder.radius, g.cylinder.length)
            assert (g.box is not None) == (b.kind == 'box') and (g.cylinder is not None) == (b.kind == 'cylinder')
            np.testing.assert_allclose(size, b.size, rtol=1e-12, atol=0, err_msg=name)
            np.testing.assert_allclose(c.origin[:3, 3], b.position, rtol=0, atol=1e-15, err_msg=name)
            np.testing.assert_allclose(c.origin[:3, :3], b.rotation, rtol=0, atol=1e-12, err_msg=name)


def test_main_refuses_extra_arguments_in_one_line_and_prints_its_usage(capsys):
    """Extra arguments were ignored (the first file's URDF printed as if they were not there)."""
    assert main(['example', 'other.yaml']) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and captured.err.count('\n') == 1
    assert captured.err.startswith("robot_urdf: error: 2 arguments ['example', 'other.yaml']; allowed: at most one")
    assert main(['--help']) == 0 and capsys.readouterr().out.startswith('usage: python -m gpr_kinematics.robot.urdf')


@pytest.mark.parametrize('flag', ['-h', '--help'])
def test_main_prints_its_usage_for_h_as_for_help(capsys, flag):
    """`python -m gpr_kinematics.robot.urdf -h` prints the usage and exits 0, as --help does (not a robot file -h)."""
    import subprocess
    import sys

    usage = 'usage: python -m gpr_kinematics.robot.urdf [ROBOT_FILE | example]\n'
    assert main([flag]) == 0
    assert capsys.readouterr() == (usage, '')
    res = subprocess.run([sys.executable, '-m', 'gpr_kinematics.robot.urdf', flag], capture_output=True, text=True,
                         timeout=120)
    assert (res.returncode, res.stdout, res.stderr) == (0, usage, '')

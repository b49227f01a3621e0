"""state_publisher_node over real DDS: robot_description latched and parseable as URDF, /tf_static with the fixed
joints, and for every streamed sample a /tf message whose gpr_base -> gpr_platform equals forward kinematics
(1e-12), plus the naive platform and the rods."""
from __future__ import annotations

import math

import numpy as np
import pytest
from ros_support import quat, start, vec, wait_for_log

from gpr_kinematics.config import load_config
from gpr_kinematics.geometry import matrix_from_quaternion
from gpr_kinematics.sweep import paper_sweep

pytestmark = pytest.mark.ros

CFG = load_config()
STEP, AZ_STEP, MAX_TILT, HEIGHT = math.radians(0.5), math.radians(60.0), math.radians(2.0), 0.45


@pytest.fixture(scope='module')
def run(ros_environment):
    """state_publisher_node, then a sweep from trajectory_node; every message of /tf, /tf_static, the state."""
    from std_msgs.msg import String
    from tf2_msgs.msg import TFMessage

    from gpr_interfaces.msg import PlatformState
    from gpr_kinematics.nodes.client import GprClient

    core = paper_sweep(height=HEIGHT, max_tilt=MAX_TILT, tilt_step=STEP, azimuth_step=AZ_STEP, config=CFG)
    sp = start('state_publisher_node')
    traj = None
    with GprClient('gpr_test_state_publisher') as c:
        try:
            wait_for_log(sp, r'publishing robot_description')
            tf = c.subscribe(TFMessage, '/tf')
            static = c.subscribe(TFMessage, '/tf_static', latched=True)
            states = c.subscribe(PlatformState, 'gpr/platform_state')
            # Subscribers: this client and the state publisher.
            traj = start('trajectory_node', rate=200.0, height=HEIGHT, max_tilt=MAX_TILT, tilt_step=STEP,
                         azimuth_step=AZ_STEP, wait_for_subscribers=2, wait_all_topics=False)
            assert c.spin_until(lambda: not traj.alive() and len(tf) >= len(core), 60), traj.output() + sp.output()
            c.spin_for(0.3)
            # A subscriber that comes late still gets the latched robot_description (transient local).
            description = c.subscribe(String, 'robot_description', latched=True)
            assert c.spin_until(lambda: description, 20), sp.output()
            yield core, tf, static, states, description, sp
        finally:
            if traj is not None:
                traj.stop()
            sp.stop()


def test_one_tf_message_per_sample_equal_to_forward_kinematics(run):
    core, tf, _, states, _, _ = run
    assert len(states) == len(core) == len(tf)
    fk = core.forward
    for i, (msg, st) in enumerate(zip(tf, states, strict=True)):
        by_child = {t.child_frame_id: t for t in msg.transforms}
        assert set(by_child) == {'gpr_platform', 'gpr_platform_nominal', 'gpr_rod_1', 'gpr_rod_2', 'gpr_rod_3'}
        exact, nominal = by_child['gpr_platform'], by_child['gpr_platform_nominal']
        assert exact.header.stamp == st.header.stamp and exact.header.frame_id == 'gpr_base'
        np.testing.assert_allclose(vec(exact.transform.translation), fk.position[i], rtol=0, atol=1e-12)
        np.testing.assert_allclose(quat(exact.transform.rotation), fk.quaternion[i], rtol=0, atol=1e-12)
        np.testing.assert_allclose(vec(nominal.transform.translation), fk.nominal_position[i], rtol=0, atol=1e-12)
        np.testing.assert_allclose(quat(nominal.transform.rotation), fk.nominal_quaternion[i], rtol=0, atol=1e-12)
        for k in (1, 2, 3):
            rod = by_child[f'gpr_rod_{k}']
            assert rod.header.frame_id == f'gpr_rod_guide_{k}'
            np.testing.assert_allclose(vec(rod.transform.translation), [0.0, 0.0, core.q[i, k - 1]], atol=1e-15)


def test_static_transforms_and_rod_tops(run):
    """/tf_static: the guides at the rod feet; guide + rod = the joint centres P_k."""
    core, tf, static, _, _, _ = run
    (msg,) = static
    guides = {t.child_frame_id: t for t in msg.transforms}
    assert set(guides) == {'gpr_rod_guide_1', 'gpr_rod_guide_2', 'gpr_rod_guide_3'}
    last = {t.child_frame_id: t for t in tf[-1].transforms}
    for k, theta in enumerate(CFG.rod_azimuths, start=1):
        g = guides[f'gpr_rod_guide_{k}'].transform
        assert guides[f'gpr_rod_guide_{k}'].header.frame_id == 'gpr_base'
        top = vec(g.translation) + matrix_from_quaternion(quat(g.rotation)) @ vec(last[f'gpr_rod_{k}'].transform
                                                                               .translation)
        np.testing.assert_allclose(top, [CFG.radius * math.cos(theta), CFG.radius * math.sin(theta),
                                         core.q[-1, k - 1]], atol=1e-15)


def test_robot_description_latched_urdf_naming_the_tf_frames(run, tmp_path):
    import yourdfpy

    _, tf, static, _, description, _ = run
    (msg,) = description
    path = tmp_path / 'robot_description.urdf'
    path.write_text(msg.data)
    urdf = yourdfpy.URDF.load(str(path), build_collision_scene_graph=False, load_meshes=False)
    frames = {t.header.frame_id for m in (*tf, *static) for t in m.transforms} | \
        {t.child_frame_id for m in (*tf, *static) for t in m.transforms}
    assert frames <= set(urdf.link_map)
    assert urdf.base_link == 'gpr_base'
    assert sorted(j.name for j in urdf.robot.joints if j.type == 'prismatic') == ['rod_1', 'rod_2', 'rod_3']

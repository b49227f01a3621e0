"""state_publisher_node over real DDS: robot_description latched and parseable as URDF (the whole robot: world,
GPR, arms, blades, wafers), /tf_static with the fixed joints, and for every streamed joint_states message one /tf
message whose gpr_base -> gpr_platform equals forward kinematics (1e-12), with the naive platform, the rods and the
arms (held at home in a platform sweep); tf is always there: the rest state before the first sample, the last
sample after the stream; for a whole-robot program the tf chain world -> wafer of every sample equals the robot
core's forward kinematics (1e-12)."""
from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.rotations import matrix_from_quaternion
from gpr_kinematics.core.sweep import paper_sweep
from gpr_kinematics.robot import load_robot, robot_forward
from gpr_kinematics.robot.forward import arm_transforms
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.robot.stream import robot_stream
from robot_support import SHORT_PROGRAM
from ros_support import quat, start, vec, wait_for_log

pytestmark = pytest.mark.ros

CFG = load_config()
ROBOT = load_robot()
STEP, AZ_STEP, MAX_TILT, HEIGHT = math.radians(0.5), math.radians(60.0), math.radians(2.0), 0.45
#: How long a stream waits before its first sample, so that the state publisher listens to it [s].
WAIT = 4.0


def _wait_matched(client, topic: str, sp, namespace: str = '/') -> None:
    """Wait until the graph shows the state publisher of ``namespace`` publishing ``topic`` and the client's
    subscriptions to it are matched with every publisher the graph shows: the stream starts once the state
    publisher subscribed to it, and a /tf message it sends before its publisher matched this client's subscription
    would be lost to the test (seen on a loaded machine; another module fixture's state publisher may publish /tf
    too, so one matched publisher is not enough)."""
    subs = [s for s in client.node.subscriptions if s.topic_name == topic]

    def matched() -> bool:
        infos = client.node.get_publishers_info_by_topic(topic)
        ours = any(i.node_name == 'state_publisher_node' and i.node_namespace == namespace for i in infos)
        return ours and all(s.get_publisher_count() >= len(infos) for s in subs)

    assert subs and client.spin_until(matched, 30), sp.output()


@pytest.fixture(scope='module')
def run(ros_environment):
    """state_publisher_node, then a sweep from trajectory_node; every message of /tf, /tf_static, the state."""
    from gpr_kinematics.nodes.client import GprClient
    from std_msgs.msg import String
    from tf2_msgs.msg import TFMessage

    from gpr_interfaces.msg import PlatformState

    core = paper_sweep(height=HEIGHT, max_tilt=MAX_TILT, tilt_step=STEP, azimuth_step=AZ_STEP, config=CFG)
    sp = start('state_publisher_node')
    traj = None
    with GprClient('gpr_test_state_publisher') as c:
        try:
            wait_for_log(sp, r'publishing robot_description')
            tf = c.subscribe(TFMessage, '/tf')
            static = c.subscribe(TFMessage, '/tf_static', latched=True)
            states = c.subscribe(PlatformState, 'gpr/platform_state')
            _wait_matched(c, '/tf', sp)
            c.spin_for(0.5)      # the held rest state before the first sample
            # The stream waits for two nodes on gpr/platform_state, this client's and none other (the state publisher
            # listens to joint_states): WAIT s, by which the state publisher's subscription has matched as well.
            traj = start('trajectory_node', rate=200.0, height=HEIGHT, max_tilt=MAX_TILT, tilt_step=STEP,
                         azimuth_step=AZ_STEP, wait_for_subscribers=2, wait_all_topics=False, wait_timeout=WAIT)
            assert c.spin_until(lambda: not traj.alive() and len(_by_stamp(tf, states)[0]) >= len(core), 60), \
                traj.output() + sp.output()
            # the held state after the last sample, at idle_rate (waited for: a loaded machine may take a while)
            assert c.spin_until(lambda: _held_after(tf, states), 10), sp.output()
            # A subscriber that comes late still gets the latched robot_description (transient local).
            description = c.subscribe(String, 'robot_description', latched=True)
            assert c.spin_until(lambda: description, 20), sp.output()
            yield core, tf, static, states, description, sp
        finally:
            if traj is not None:
                traj.stop()
            sp.stop()


def _stamp(msg):
    t = msg.transforms[0].header.stamp
    return t.sec, t.nanosec


def _held_after(tf, states):
    """The /tf messages of the held state published after the last sample (stamped later than it)."""
    samples, held = _by_stamp(tf, states)
    return [m for m in held if samples and _stamp(m) > _stamp(samples[-1])]


def _by_stamp(tf, states):
    """The /tf messages stamped as the states (one per joint_states message), and the others (the held state, at
    idle_rate, before the first and after the last sample)."""
    stamps = {(st.header.stamp.sec, st.header.stamp.nanosec) for st in states}
    return [m for m in tf if _stamp(m) in stamps], [m for m in tf if _stamp(m) not in stamps]


ARM_LINKS = {f'{a.name}_link{k + 1}' for a in ROBOT.arms for k in range(len(a.joints))}
MOVING = {'gpr_platform', 'gpr_platform_nominal', 'gpr_rod_1', 'gpr_rod_2', 'gpr_rod_3'} | ARM_LINKS


@pytest.mark.slow
def test_one_tf_message_per_sample_equal_to_forward_kinematics(run):
    core, tf, _, states, _, _ = run
    samples, _ = _by_stamp(tf, states)
    assert len(states) == len(core) == len(samples)
    fk = core.forward
    for i, (msg, st) in enumerate(zip(samples, states, strict=True)):
        by_child = {t.child_frame_id: t for t in msg.transforms}
        assert set(by_child) == MOVING
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


def test_tf_is_always_there_held_before_and_after_the_stream(run):
    """Before the first sample /tf carries the rest state (equal rods at mid-stroke: a level platform, the arms at
    home), after the last one the last sample, at idle_rate, stamped with the time of publishing."""
    core, tf, _, states, _, _ = run
    samples, held = _by_stamp(tf, states)
    first, last = tf.index(samples[0]), tf.index(samples[-1])
    before, after = [m for m in held if tf.index(m) < first], [m for m in held if tf.index(m) > last]
    assert before and after
    mid = 0.5 * (CFG.stroke_min + CFG.stroke_max)
    for msgs, q in ((before, [mid] * 3), (after, core.q[-1])):
        for msg in msgs:
            by_child = {t.child_frame_id: t for t in msg.transforms}
            assert set(by_child) == MOVING
            np.testing.assert_allclose([by_child[f'gpr_rod_{k}'].transform.translation.z for k in (1, 2, 3)], q,
                                       rtol=0, atol=1e-15)
    assert all(_stamp(a) > _stamp(samples[-1]) for a in after)
    level = {t.child_frame_id: t for t in before[0].transforms}['gpr_platform'].transform.rotation
    assert abs(level.w) == pytest.approx(1.0, abs=1e-12)


def test_arms_at_home_in_a_platform_sweep(run):
    """A sweep's joint states carry the rods only: the arms' links are drawn at the postures held, home."""
    _, tf, _, states, _, _ = run
    samples, _ = _by_stamp(tf, states)
    for msg, st in zip(samples, states, strict=True):
        assert {t.header.stamp.nanosec for t in msg.transforms} == {st.header.stamp.nanosec}
        by_child = {t.child_frame_id: t for t in msg.transforms if t.child_frame_id in ARM_LINKS}
        assert set(by_child) == ARM_LINKS
        for arm in ROBOT.arms:
            for k, (frame, parent, pose) in enumerate(arm_transforms(arm, np.array([arm.home]))):
                if k < len(arm.joints):
                    assert by_child[frame].header.frame_id == parent
                    np.testing.assert_allclose(quat(by_child[frame].transform.rotation), pose.quaternion[0],
                                               rtol=0, atol=1e-15)


def test_static_transforms_and_rod_tops(run):
    """/tf_static: the robot's base in the world, the guides at the rod feet, the blades and wafers; guide + rod =
    the joint centres P_k."""
    core, tf, static, _, _, _ = run
    (msg,) = static
    fixed = {t.child_frame_id: t for t in msg.transforms}
    assert set(fixed) == {'gpr_base', 'gpr_rod_guide_1', 'gpr_rod_guide_2', 'gpr_rod_guide_3', 'arm1_blade',
                          'arm1_wafer', 'arm2_blade', 'arm2_wafer'}
    base = fixed['gpr_base']
    assert base.header.frame_id == 'world'
    np.testing.assert_allclose(vec(base.transform.translation), ROBOT.base_position, rtol=0, atol=0)
    guides = {k: v for k, v in fixed.items() if k.startswith('gpr_rod_guide')}
    last = {t.child_frame_id: t for t in _by_stamp(tf, run[3])[0][-1].transforms}
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
    assert urdf.base_link == 'world'
    assert sorted(j.name for j in urdf.robot.joints if j.type == 'prismatic') == ['rod_1', 'rod_2', 'rod_3']
    revolute = [j.name for j in urdf.robot.joints if j.type == 'revolute']
    assert revolute == [n for a in ROBOT.arms for n in a.joint_names]
    assert {'arm1_wafer', 'arm2_wafer', 'arm1_blade', 'arm2_blade'} <= frames


ROBOT_RATE = 40.0


def _matrix(t):
    """4 x 4 of a TransformStamped."""
    T = np.eye(4)
    T[:3, :3] = matrix_from_quaternion(quat(t.transform.rotation))
    T[:3, 3] = vec(t.transform.translation)
    return T


@pytest.fixture(scope='module')
def robot_run(ros_environment, tmp_path_factory):
    """state_publisher_node, then the short robot program from trajectory_node; /tf, /tf_static, the states."""
    from gpr_kinematics.nodes.client import GprClient
    from tf2_msgs.msg import TFMessage

    from gpr_interfaces.msg import PlatformState, RobotState

    path = tmp_path_factory.mktemp('robot') / 'program.yaml'
    path.write_text(SHORT_PROGRAM)
    expected = robot_stream(ROBOT, load_program(path), ROBOT_RATE)
    ns = '/gpr_tf_robot'
    sp = start('state_publisher_node', namespace=ns)
    traj = None
    with GprClient('gpr_test_tf_robot', namespace=ns) as c:
        try:
            wait_for_log(sp, r'publishing robot_description')
            tf = c.subscribe(TFMessage, '/tf')
            static = c.subscribe(TFMessage, '/tf_static', latched=True)
            states = c.subscribe(PlatformState, 'gpr/platform_state')
            robot_states = c.subscribe(RobotState, 'gpr/robot_state')
            _wait_matched(c, '/tf', sp, ns)
            traj = start('trajectory_node', namespace=ns, mode='program', program_file=str(path), rate=ROBOT_RATE,
                         wait_for_subscribers=2, wait_all_topics=False, wait_timeout=WAIT)
            done = c.spin_until(lambda: not traj.alive() and len(_by_stamp(tf, states)[0]) >= len(expected), 120)
            c.spin_for(0.3)
            assert done, (f'{len(tf)} /tf messages for {len(expected)} samples, {len(states)} states\n'
                          + traj.output() + sp.output())
            yield expected, tf, static, states, robot_states
        finally:
            if traj is not None:
                traj.stop()
            sp.stop()


@pytest.mark.slow
def test_tf_chain_world_to_wafer_equals_the_robot_core_for_every_sample(robot_run):
    """world -> gpr_base (static) -> gpr_platform (per state) -> the arm's links (per joint state) -> blade ->
    wafer (static), composed here from the transforms, equals robot_forward of the sample's rods and joints."""
    expected, tf, static, states, robot_states = robot_run
    assert len(states) == len(robot_states) == len(expected)
    fixed = {t.child_frame_id: t for m in static for t in m.transforms}
    by_stamp: dict = {}
    for m in tf:
        for t in m.transforms:
            by_stamp.setdefault((t.header.stamp.sec, t.header.stamp.nanosec), {})[t.child_frame_id] = t
    for st, rs in zip(states, robot_states, strict=True):
        assert rs.header.stamp == st.header.stamp and rs.sample == st.sample
        frames = {**fixed, **by_stamp[(st.header.stamp.sec, st.header.stamp.nanosec)]}
        arm = ROBOT.arm(rs.arm)
        chain = ['gpr_base', 'gpr_platform', *arm.link_frames, arm.blade_frame, arm.wafer_frame]
        T = np.eye(4)
        for frame in chain:
            T = T @ _matrix(frames[frame])
        assert frames['gpr_base'].header.frame_id == 'world'
        joints = dict(zip(rs.joint_names, rs.joints, strict=True))
        core = robot_forward(ROBOT, [st.q], [[joints[n] for n in arm.joint_names]], arm.name)
        np.testing.assert_allclose(T[:3, 3], core.wafer.position[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(T[:3, :3], core.wafer.rotation[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(T[:3, 3], vec(rs.wafer.position), rtol=0, atol=1e-12)
    # Both arms moved and both were in use.
    assert {rs.arm for rs in robot_states} == {'arm1', 'arm2'}
    np.testing.assert_allclose([list(rs.joints) for rs in robot_states], expected.joints, rtol=0, atol=1e-12)


@pytest.mark.slow
def test_process_cell_published_latched_as_markers(ros_environment, tmp_path):
    """With ``cell_file``, gpr/cell is latched: a late subscriber gets one MarkerArray, a marker per obstacle at its
    pose and size in the cell's frame; a bad cell file stops the node with one line and status 2."""
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.nodes.client import GprClient
    from gpr_kinematics.safety.cell import load_cell
    from visualization_msgs.msg import Marker, MarkerArray

    path = config_path('cells/example_cell.yaml')
    cell = load_cell(path)
    ns = '/gpr_cell_markers'
    sp = start('state_publisher_node', namespace=ns, cell_file=str(path))
    try:
        wait_for_log(sp, r'gpr/cell: \d+ obstacles')
        with GprClient('gpr_test_cell', namespace=ns) as c:
            got = c.subscribe(MarkerArray, 'gpr/cell', latched=True)
            assert c.spin_until(lambda: got, 30), sp.output()
            c.spin_for(0.3)
    finally:
        sp.stop()
    assert len(got) == 1
    markers = got[0].markers
    assert len(markers) == len(cell.obstacles) and {m.header.frame_id for m in markers} == {'world'}
    for m, ob in zip(markers, cell.obstacles, strict=True):
        assert m.type == (Marker.CUBE if ob.kind == 'box' else Marker.CYLINDER)
        np.testing.assert_allclose(vec(m.pose.position), ob.position, atol=1e-12)
        np.testing.assert_allclose(matrix_from_quaternion(quat(m.pose.orientation)), ob.rotation, atol=1e-12)
        size = ob.size if ob.kind == 'box' else (2 * ob.size[0], 2 * ob.size[0], ob.size[1])
        np.testing.assert_allclose([m.scale.x, m.scale.y, m.scale.z], size, atol=1e-15)
    bad = tmp_path / 'bad_cell.yaml'
    bad.write_text('format: gpr_cell\nobstacles:\n  - {name: a, box: [-1, 1, 1], position: [0, 0, 0]}\n')
    proc = start('state_publisher_node', namespace=ns + '_bad', cell_file=str(bad))
    assert proc.wait(30) == 2
    assert 'box[0] = -1 is invalid' in proc.output() and 'Traceback' not in proc.output()


def test_a_new_tf_subscription_gets_the_held_state_when_it_matches(ros_environment):
    """While no joint_states arrive, a /tf subscription that matches gets the held state then, not at the next idle
    publication: with idle_rate 0.1 Hz (one every 10 s), a second subscription made right after the first message
    receives gpr_base -> gpr_platform stamped less than 5 s after it (the idle timer's next is 10 s after it)."""
    from gpr_kinematics.nodes.client import GprClient
    from tf2_msgs.msg import TFMessage

    sp = start('state_publisher_node', namespace='/tf_at_match', frame_prefix='m/', idle_rate=0.1)

    def platform(msgs):
        return [t.header.stamp for m in msgs for t in m.transforms if t.child_frame_id == 'm/gpr_platform']

    try:
        wait_for_log(sp, r'publishing robot_description')
        with GprClient('gpr_test_tf_at_match') as c:
            first = c.subscribe(TFMessage, '/tf')
            assert c.spin_until(lambda: platform(first), 30), sp.output()
            late = c.subscribe(TFMessage, '/tf')
            assert c.spin_until(lambda: platform(late), 9), sp.output()
            t0, t1 = platform(first)[0], platform(late)[0]
            dt = (t1.sec - t0.sec) + (t1.nanosec - t0.nanosec) * 1e-9
            assert 0.0 <= dt < 5.0
    finally:
        sp.stop()


@contextlib.contextmanager
def _joint_states_to(namespace: str, prefix: str, qos: Any = 10,
                     **params: Any) -> Iterator[tuple[Any, Any, Any, Callable[[], list[float]]]]:
    """A state publisher in ``namespace`` with ``frame_prefix`` ``prefix`` (and ``params``), a client subscribed to
    ``/tf`` and a JointState publisher (``qos``) to the node, matched and the platform shown: ``(node process, client,
    publisher, the platform's heights on /tf so far)``; the node still alive without a traceback at the end."""
    from gpr_kinematics.nodes.client import GprClient
    from sensor_msgs.msg import JointState
    from tf2_msgs.msg import TFMessage

    sp = start('state_publisher_node', namespace=namespace, frame_prefix=prefix, **params)
    try:
        wait_for_log(sp, r'publishing robot_description')
        with GprClient(f'gpr_test{namespace.replace("/", "_")}') as c:
            tf = c.subscribe(TFMessage, '/tf')
            pub = c.node.create_publisher(JointState, f'{namespace}/joint_states', qos)

            def platform_z() -> list[float]:
                return [t.transform.translation.z for m in tf for t in m.transforms
                        if t.child_frame_id == f'{prefix}gpr_platform']

            assert c.spin_until(lambda: pub.get_subscription_count() > 0 and platform_z(), 30), sp.output()
            yield sp, c, pub, platform_z
        assert sp.alive() and 'Traceback' not in sp.output()
    finally:
        sp.stop()


def test_rods_without_a_platform_pose_are_reported_and_the_node_keeps_publishing(ros_environment):
    """joint_states of any publisher reach the node with the limits unchecked: rods that no tilt makes, also beyond the
    stroke (a ROS trial: 2 mm beyond showed 62 deg), are logged (the platform keeps its last pose), and the next rods
    are shown."""
    from gpr_kinematics.core import forward
    from sensor_msgs.msg import JointState

    names = ['rod_1', 'rod_2', 'rod_3']
    with _joint_states_to('/tf_bad_rods', 'b/') as (sp, c, pub, platform_z):
        # rods that differ by more than any tilt makes: the warning said so and /tf showed the platform tilted 62 deg
        # (a closure solved without the limits); it keeps its last pose (at rest, 0.254 m)
        pub.publish(JointState(name=names, position=[0.1, 0.4, 0.3]))
        wait_for_log(sp, r'imply no platform orientation .*; the platform keeps its last pose')
        n = len(platform_z())
        assert c.spin_until(lambda: len(platform_z()) > n + 2, 10)
        assert all(abs(z - 0.254) < 1e-12 for z in platform_z()), sorted(set(platform_z()))
        # beyond the stroke, judged first, their differences were not: 2 mm beyond showed the platform tilted 62 deg,
        # and rods far outside it met a closure's singular Newton step; both keep the last pose (the warning is the
        # one above, throttled)
        for rods in ([0.51, 0.25, 0.25], [-1769.0291745130303, 1303.4307942578168, -0.008524297508037591]):
            pub.publish(JointState(name=names, position=rods))
            n = len(platform_z())
            assert c.spin_until(lambda n=n: len(platform_z()) > n + 2, 10)
            assert all(abs(z - 0.254) < 1e-12 for z in platform_z()), (rods, sorted(set(platform_z())))
        # rods of 1e308 m put inf and NaN on /tf, of 1e15 m a naive platform tilted 90 deg; one rod of 1e300 m went
        # on /tf as its rod's transform (the platform kept its pose) and was held; an arm joint of 1e155 rad
        # overflowed its transform and stopped the node: each beyond 1e6 m or rad is left out, held as before (one
        # message: the warning is throttled)
        pub.publish(JointState(name=['rod_1', 'arm1_elbow', 'rod_3'], position=[1e300, 1e155, 1e308]))
        wait_for_log(sp, r'joint_states: rod_1 = 1e\+300 m, arm1_elbow = 1e\+155 rad, rod_3 = 1e\+308 m: left out '
                         r'\(held as before\); allowed: within \+-1e\+06 m or rad')
        n = len(platform_z())
        assert c.spin_until(lambda: len(platform_z()) > n + 2, 10)
        assert all(math.isfinite(v) and abs(v) < 10.0 for v in platform_z()), sorted(set(platform_z()))
        # positions that are not numbers were left out without a word
        pub.publish(JointState(name=names, position=[math.nan] * 3))
        wait_for_log(sp, r'joint_states: rod_1, rod_2, rod_3 not finite, left out \(held as before\); allowed: '
                         'finite positions')
        pub.publish(JointState(name=names, position=[0.3, 0.3, 0.3]))
        z = forward([0.3, 0.3, 0.3]).position[2]
        assert c.spin_until(lambda: any(abs(v - z) < 1e-12 for v in platform_z()), 10), sp.output()


def test_malformed_joint_states_are_ignored_with_a_warning(ros_environment):
    """A JointState of three names and two positions moved rod_1 and rod_2 (the first values taken), one naming rod_1
    twice took its last value: each is ignored, as robot_state_publisher ignores it, with a warning naming why (the
    platform stays at rest)."""
    from gpr_kinematics.core import forward
    from gpr_kinematics.robot.controller import ControllerJoints
    from robot_support import ROBOT
    from sensor_msgs.msg import JointState

    rest = float(ControllerJoints.of(ROBOT).rest[0])
    with _joint_states_to('/tf_malformed', 'w/') as (sp, c, pub, platform_z):
        pub.publish(JointState(name=['rod_1', 'rod_2', 'rod_3'], position=[0.35, 0.35]))
        wait_for_log(sp, r'joint_states: 3 names and 2 positions; allowed: one position per name, or none; '
                         'message ignored')
        # (its warning is throttled: one per 5 s; the messages of one publisher arrive in order)
        pub.publish(JointState(name=['rod_1', 'rod_2', 'rod_3', 'rod_1'], position=[0.35, 0.35, 0.35, 0.36]))
        pub.publish(JointState(name=['rod_3'], position=[rest]))   # rods 1 and 2 as held: at rest
        z = forward([rest] * 3, ROBOT.config).position[2]
        assert c.spin_until(lambda: any(abs(v - z) < 1e-12 for v in platform_z()), 10), sp.output()


def test_a_best_effort_joint_states_publisher_is_named_or_heard(ros_environment):
    """A driver publishing joint_states best effort (robot_state_publisher subscribes with SensorDataQoS) cannot
    match the default reliable subscription: the node names the parameter that hears it; with
    joint_states_reliability:=best_effort its rods move the platform (forward kinematics, 1e-12)."""
    from gpr_kinematics.core import forward
    from gpr_kinematics.nodes.client import GprClient
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import JointState

    sp = start('state_publisher_node', namespace='/tf_reliable_only')
    try:
        wait_for_log(sp, r'publishing robot_description')
        with GprClient('gpr_test_reliable_only') as c:
            c.node.create_publisher(JointState, '/tf_reliable_only/joint_states', qos_profile_sensor_data)
            wait_for_log(sp, r'joint_states: a publisher offers a QoS this reliable subscription cannot match '
                             r'\(RELIABILITY\).*-p joint_states_reliability:=best_effort')
        assert sp.alive() and 'Traceback' not in sp.output()
    finally:
        sp.stop()
    names, rods = ['rod_1', 'rod_2', 'rod_3'], [0.3005, 0.3, 0.2995]
    z = forward(rods).position[2]
    with _joint_states_to('/tf_best_effort', 'e/', qos_profile_sensor_data,
                          joint_states_reliability='best_effort') as (sp, c, pub, platform_z):
        assert c.spin_until(lambda: (pub.publish(JointState(name=names, position=rods)) or
                                     any(abs(v - z) < 1e-12 for v in platform_z())), 10), sp.output()
        assert 'cannot match' not in sp.output()


@pytest.mark.slow
def test_a_second_state_publisher_with_the_same_frame_prefix_is_warned_of(ros_environment):
    """Two state publishers in two namespaces with one frame_prefix (two robots, the prefix forgotten) put two robots
    on the same frames, and tf alternated between them without a word: each now warns once that another publisher
    sends its frames on /tf_static, naming it; one with a prefix of its own does not
    (nodes/foreign_states.OtherFramePublishers)."""
    # c and a first, b once a has seen c for 3 s: a names every publisher it knows, c among them (started together,
    # a warned before it had discovered c on a loaded machine, and named two stale nodes of earlier tests instead)
    c = start('state_publisher_node', namespace='/sp_single', frame_prefix='single/')
    a = start('state_publisher_node', namespace='/sp_twin_a', frame_prefix='twin/')
    procs = [c, a]
    try:
        for p in procs:
            wait_for_log(p, r'publishing robot_description')
        time.sleep(3.0)
        b = start('state_publisher_node', namespace='/sp_twin_b', frame_prefix='twin/')
        procs.append(b)
        named = {}
        for p, other in ((a, '/sp_twin_b'), (b, '/sp_twin_a')):
            m = wait_for_log(p, r"another publisher sends this robot's frames \((twin/[^)]*)\) on /tf_static \(of "
                                r'its publishers: ([^)]*)\): a second state publisher with the same frame_prefix',
                             timeout=60)
            named[other] = m.group(2).split(', ')
            assert m.group(1).startswith('twin/') and f'{other}/state_publisher_node' in named[other], m[0]
        assert '/sp_single/state_publisher_node' in named['/sp_twin_b'], named   # every other publisher is named
        time.sleep(2.0)   # c heard b's latched transforms in the same while
    finally:
        for p in procs:
            p.stop()
    assert a.output().count('another publisher sends') == 1, a.output()
    assert 'another publisher sends' not in c.output(), c.output()


def test_the_held_state_continues_the_time_base_of_the_joint_states(ros_environment):
    """A replayed bag's joint_states carry the bag's stamps (a minute old): the held state between them was stamped
    with the wall clock, so /tf jumped 64 s back and forth and tf2 (RViz) dropped the older data. It is stamped in the
    joint_states' time base: their stamp plus the time since they arrived."""
    from builtin_interfaces.msg import Time
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Header

    names = ['rod_1', 'rod_2', 'rod_3']
    from tf2_msgs.msg import TFMessage

    with _joint_states_to('/tf_time_base', 't/', idle_rate=20.0) as (sp, c, pub, _):
        tf = c.subscribe(TFMessage, '/tf')

        def platform_stamps() -> list[float]:
            return [t.header.stamp.sec + t.header.stamp.nanosec * 1e-9 for m in tf for t in m.transforms
                    if t.child_frame_id == 't/gpr_platform']

        now = c.node.get_clock().now().nanoseconds * 1e-9
        old = now - 63.0
        sec = int(old)
        n = len(platform_stamps())
        pub.publish(JointState(header=Header(stamp=Time(sec=sec, nanosec=0)), name=names, position=[0.3, 0.3, 0.3]))
        assert c.spin_until(lambda: sec in platform_stamps()[n:] and len(platform_stamps()) > n + 6, 10), \
            sp.output()
        stamps = platform_stamps()[n:]
        held = stamps[stamps.index(sec) + 1:]   # after the sample itself, at its stamp (a held one may come first)
        assert len(held) >= 3, stamps
        assert all(sec < s < sec + 5.0 for s in held), (sec, held)   # not the wall clock's, 63 s later
        assert held == sorted(held)

"""Two robots side by side, as offline_loop.launch.py starts them with namespace:=/r1 frame_prefix:=r1/ and
namespace:=/r2 frame_prefix:=r2/ (here without launch: each node with -r __ns:=... and -p frame_prefix:=...): the
graph (rclpy) shows no topic, service or action of one robot in the other's, the only shared names being ROS's own
(/tf, /tf_static, /rosout, /parameter_events), and every tf frame either robot publishes carries its prefix, so the
two trees on /tf are disjoint; each robot_description names its own frames."""
from __future__ import annotations

import pytest
from ros_support import start, wait_for_log

pytestmark = pytest.mark.ros

ROBOTS = (('/r1', 'r1/'), ('/r2', 'r2/'))
#: Names both robots use by design: tf is one tree of prefixed frames, the rest belongs to ROS itself.
SHARED = {'/tf', '/tf_static', '/rosout', '/parameter_events'}
ACTIONS = ('joint_trajectory_controller/follow_joint_trajectory', 'gpr/run_program')


@pytest.fixture(scope='module')
def graph(ros_environment):
    """The four long-running nodes of offline_loop in both namespaces; the graph's names and the tf frames."""
    from gpr_kinematics.nodes.client import GprClient
    from rclpy.action import get_action_names_and_types
    from std_msgs.msg import String
    from tf2_msgs.msg import TFMessage

    procs = []
    try:
        for ns, prefix in ROBOTS:
            procs += [start('kinematics_node', namespace=ns),
                      start('robot_simulator_node', namespace=ns),
                      start('state_publisher_node', namespace=ns, frame_prefix=prefix),
                      start('trajectory_node', namespace=ns, mode='idle', frame_prefix=prefix)]
        for p in procs:
            wait_for_log(p, r'serving|publishing robot_description|idle:', timeout=60)
        with GprClient('gpr_test_two_robots') as c:
            tf = c.subscribe(TFMessage, '/tf')
            static = c.subscribe(TFMessage, '/tf_static', latched=True)
            descriptions = {ns: c.subscribe(String, f'{ns}/robot_description', latched=True) for ns, _ in ROBOTS}
            wanted = {f'{ns}/{a}' for ns, _ in ROBOTS for a in ACTIONS}

            def mirrored(names: set[str]) -> bool:   # discovery of both robots' names is complete
                r1, r2, _ = _split(names)
                return bool(r1) and {n.replace('/r1/', '/r2/', 1) for n in r1} == r2

            def complete() -> bool:
                actions = {name for name, _ in get_action_names_and_types(c.node)}
                return (wanted <= actions and len(static) >= 2 and all(descriptions.values())
                        and mirrored({n for n, _ in c.node.get_topic_names_and_types()})
                        and mirrored({n for n, _ in c.node.get_service_names_and_types()}))

            assert c.spin_until(complete, 60), '\n'.join(p.output() for p in procs)
            c.spin_for(1.0)      # the held states on /tf, at idle_rate
            yield {'topics': {n for n, _ in c.node.get_topic_names_and_types()},
                   'services': {n for n, _ in c.node.get_service_names_and_types()},
                   'actions': {n for n, _ in get_action_names_and_types(c.node)},
                   'tf': list(tf), 'static': list(static),
                   'descriptions': {ns: d[0].data for ns, d in descriptions.items()}}
    finally:
        for p in procs:
            p.stop()


def _split(names: set[str]) -> tuple[set[str], set[str], set[str]]:
    r1 = {n for n in names if n.startswith('/r1/')}
    r2 = {n for n in names if n.startswith('/r2/')}
    return r1, r2, names - r1 - r2


@pytest.mark.parametrize('kind', ['topics', 'services', 'actions'])
def test_no_topic_service_or_action_is_shared(graph, kind):
    r1, r2, other = _split(graph[kind])
    assert r1 and {n.replace('/r1/', '/r2/', 1) for n in r1} == r2            # the same robot twice, apart
    other = {n for n in other if not n.startswith('/gpr_test_two_robots/')}   # this test's own node
    assert other <= SHARED, other
    if kind == 'actions':
        assert r1 == {f'/r1/{a}' for a in ACTIONS}
    if kind == 'topics':
        assert {'/r1/joint_states', '/r1/robot_description', '/r1/gpr/platform_state'} <= r1


def test_every_frame_carries_its_robots_prefix(graph):
    frames: dict[str, set[str]] = {'r1/': set(), 'r2/': set()}
    for msg in (*graph['tf'], *graph['static']):
        for t in msg.transforms:
            for frame in (t.header.frame_id, t.child_frame_id):
                prefix = frame[:3]
                assert prefix in frames, frame
                frames[prefix].add(frame[3:])
    assert frames['r1/'] == frames['r2/'] and {'world', 'gpr_base', 'gpr_platform', 'arm1_wafer'} <= frames['r1/']
    for ns, prefix in ROBOTS:
        text = graph['descriptions'][ns]
        assert f'<link name="{prefix}gpr_platform">' in text and '<robot name="example_dual_arm">' in text
        other = 'r2/' if prefix == 'r1/' else 'r1/'
        assert other not in text

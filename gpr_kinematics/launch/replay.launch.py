"""Replay a recorded bag (replay_node) with its robot model and transforms (state_publisher_node turns the replayed
joint_states into /tf), optionally into RViz.

    ros2 launch gpr_kinematics replay.launch.py bag:=bags/run1 [rate:=2.0] [loop:=true] [robot:=my_robot.yaml]
        [model:=polar] [rviz:=true] [joint_states:=gpr/joint_states] [clock_rate:=50.0 use_sim_time:=true]

The replay waits (up to 10 s) until the state publisher subscribes to the joint states, so /tf shows the bag from
its first sample; ``model`` is the recording's virtual-joint model (the state publisher's /tf used the geometry's,
28 um from the replayed platform pose of a bag recorded under another). ``clock_rate`` publishes /clock with the
bag's time (as ``ros2 bag play --clock``): with ``use_sim_time:=true`` the nodes then run on the bag's time.
"""
from gpr_kinematics.nodes.launch_common import arguments, node, rviz, typed
from launch import LaunchDescription
from launch.substitutions import LaunchConfiguration

ARGUMENTS = (
    ('bag', '', 'bag folder, .mcap or .db3 file to replay (required)'),
    ('rate', '1.0', 'replay speed factor (2.0: twice as fast)'),
    ('loop', 'false', 'start over at the end of the bag (true/false)'),
    ('clock_rate', '0.0', "publish /clock with the bag's time at this rate [Hz] (for use_sim_time; 0: none)"),
    ('namespace', '', 'namespace of the nodes and the replayed topics, e.g. /robot1'),
    ('frame_prefix', '', "prefix of every tf frame (robot_state_publisher's frame_prefix), e.g. r1/"),
    ('joint_states', 'joint_states', 'the topic of the joint states in the bag (gpr/joint_states in bags recorded '
                                     'before joint_states)'),
    ('config_file', '', "geometry YAML for the robot model, replacing the robot's gpr section; empty: that "
                        'section'),
    ('model', '', "virtual-joint model the bag was recorded with: radial, polar, offset or compliant; empty: the "
                  "geometry's"),
    ('robot', '', 'robot description YAML of the robot model (state_publisher_node): the GPR, the arms, blades and '
                  'wafers; empty: config/robots/example_robot.yaml'),
    ('rviz', 'false', 'start RViz with rviz/gpr.rviz (true/false)'),
)


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        *arguments(ARGUMENTS, 'replay.launch.py'),
        node('state_publisher_node', [{'robot_file': typed('robot'), 'config_file': typed('config_file'),
                                       'model': typed('model'), 'frame_prefix': typed('frame_prefix')}],
             remappings=[('joint_states', LaunchConfiguration('joint_states'))]),
        node('replay_node', [{'bag': typed('bag'), 'rate': typed('rate', float), 'loop': typed('loop', bool),
                              'clock_rate': typed('clock_rate', float),
                              'wait_for_subscribers': 1, 'wait_topic': typed('joint_states')}]),
        rviz(),
    ])

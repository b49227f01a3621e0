"""Replay a recorded bag (replay_node) with its robot model and transforms (state_publisher_node turns the replayed
gpr/platform_state into /tf), optionally into RViz.

    ros2 launch gpr_kinematics replay.launch.py bag:=bags/run1 [rate:=2.0] [loop:=true] [robot:=my_robot.yaml]
        [rviz:=true]
"""
from gpr_kinematics.nodes.launch_common import arguments, rviz, typed
from launch import LaunchDescription
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

ARGUMENTS = (
    ('bag', '', 'bag folder, .mcap or .db3 file to replay (required)'),
    ('rate', '1.0', 'replay speed factor (2.0: twice as fast)'),
    ('loop', 'false', 'start over at the end of the bag (true/false)'),
    ('namespace', '', 'namespace of the nodes and the replayed topics, e.g. /robot1'),
    ('config_file', '', "geometry YAML for the robot model, replacing the robot's gpr section; empty: that "
                        'section'),
    ('robot', '', 'robot description YAML of the robot model (state_publisher_node): the GPR, the arms, blades and '
                  'wafers; empty: config/robots/example_robot.yaml'),
    ('rviz', 'false', 'start RViz with rviz/gpr.rviz (true/false)'),
)


def generate_launch_description() -> LaunchDescription:
    ns, params_file = LaunchConfiguration('namespace'), LaunchConfiguration('params_file')
    return LaunchDescription([
        *arguments(ARGUMENTS),
        Node(package='gpr_kinematics', executable='state_publisher_node', namespace=ns, output='screen',
             parameters=[params_file, {'robot_file': typed('robot'), 'config_file': typed('config_file')}]),
        Node(package='gpr_kinematics', executable='replay_node', namespace=ns, output='screen',
             parameters=[params_file, {'bag': typed('bag'), 'rate': typed('rate', float),
                                       'loop': typed('loop', bool)}]),
        rviz(),
    ])

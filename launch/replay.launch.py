"""Replay a recorded bag (replay_node) with its robot model and transforms (state_publisher_node turns the replayed
gpr/platform_state into /tf), optionally into RViz.

    ros2 launch gpr_kinematics replay.launch.py bag:=bags/run1 [rate:=2.0] [loop:=true] [rviz:=true]
"""
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

from launch import LaunchDescription

ARGUMENTS = (
    ('bag', '', 'bag folder, .mcap or .db3 file to replay (required)'),
    ('rate', '1.0', 'replay speed factor (2.0: twice as fast)'),
    ('loop', 'false', 'start over at the end of the bag (true/false)'),
    ('namespace', '', 'namespace of the nodes and the replayed topics, e.g. /robot1'),
    ('config_file', '', "geometry YAML for the robot model; empty: the package's config/gpr.yaml"),
    ('rviz', 'false', 'start RViz with rviz/gpr.rviz (true/false)'),
)


def generate_launch_description() -> LaunchDescription:
    share = FindPackageShare('gpr_kinematics')
    arg = LaunchConfiguration
    ns = arg('namespace')
    params_file = arg('params_file')
    return LaunchDescription([
        DeclareLaunchArgument('params_file', default_value=PathJoinSubstitution([share, 'config', 'gpr_params.yaml']),
                              description='ROS parameters file (ros__parameters form)'),
        *(DeclareLaunchArgument(name, default_value=default, description=text) for name, default, text in ARGUMENTS),
        Node(package='gpr_kinematics', executable='state_publisher_node', namespace=ns, output='screen',
             parameters=[params_file, {'config_file': ParameterValue(arg('config_file'), value_type=str)}]),
        Node(package='gpr_kinematics', executable='replay_node', namespace=ns, output='screen',
             parameters=[params_file, {'bag': ParameterValue(arg('bag'), value_type=str),
                                       'rate': ParameterValue(arg('rate'), value_type=float),
                                       'loop': ParameterValue(arg('loop'), value_type=bool)}]),
        Node(package='rviz2', executable='rviz2', output='screen', condition=IfCondition(arg('rviz')),
             arguments=['-d', PathJoinSubstitution([share, 'rviz', 'gpr.rviz'])]),
    ])

"""kinematics_node: the GPR's forward/inverse kinematics, compensation and mobility services.

    ros2 launch gpr_kinematics kinematics.launch.py [namespace:=/robot1] [model:=polar] [config_file:=my_gpr.yaml]
"""
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

from launch import LaunchDescription


def generate_launch_description() -> LaunchDescription:
    share = FindPackageShare('gpr_kinematics')
    return LaunchDescription([
        DeclareLaunchArgument('namespace', default_value='',
                              description='namespace of the node and its services, e.g. /robot1'),
        DeclareLaunchArgument('params_file', default_value=PathJoinSubstitution([share, 'config', 'gpr_params.yaml']),
                              description='ROS parameters file (ros__parameters form)'),
        DeclareLaunchArgument('config_file', default_value='',
                              description="geometry YAML (GprConfig keys) over the package's config/gpr.yaml; "
                                          'empty: the package geometry'),
        DeclareLaunchArgument('model', default_value='',
                              description="virtual-joint model: radial, polar or offset; empty: config_file's"),
        Node(package='gpr_kinematics', executable='kinematics_node', namespace=LaunchConfiguration('namespace'),
             output='screen',
             parameters=[LaunchConfiguration('params_file'),
                         {'config_file': ParameterValue(LaunchConfiguration('config_file'), value_type=str),
                          'model': ParameterValue(LaunchConfiguration('model'), value_type=str)}]),
    ])

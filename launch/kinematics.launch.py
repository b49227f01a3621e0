"""kinematics_node: the GPR's forward/inverse kinematics, compensation and mobility services.

    ros2 launch gpr_kinematics kinematics.launch.py [namespace:=/robot1] [model:=polar] [config_file:=my_gpr.yaml]
"""
from launch import LaunchDescription
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from gpr_kinematics.nodes.launch_common import arguments, typed

ARGUMENTS = (
    ('namespace', '', 'namespace of the node and its services, e.g. /robot1'),
    ('config_file', '', "geometry YAML (GprConfig keys) over the package's config/gpr.yaml; empty: the package "
                        'geometry'),
    ('model', '', "virtual-joint model: radial, polar or offset; empty: config_file's"),
)


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        *arguments(ARGUMENTS),
        Node(package='gpr_kinematics', executable='kinematics_node', namespace=LaunchConfiguration('namespace'),
             output='screen', parameters=[LaunchConfiguration('params_file'),
                                          {'config_file': typed('config_file'), 'model': typed('model')}]),
    ])

"""kinematics_node: the GPR's forward/inverse kinematics, compensation and mobility services, and the whole robot's
(gpr/robot_forward_kinematics, gpr/station_inverse_kinematics).

    ros2 launch gpr_kinematics kinematics.launch.py [namespace:=/robot1] [frame_prefix:=r1/] [model:=polar]
        [config_file:=my_gpr.yaml] [robot:=my_robot.yaml] [use_sim_time:=true] [respawn:=true]
"""
from gpr_kinematics.nodes.launch_common import arguments, node, typed
from launch import LaunchDescription

ARGUMENTS = (
    ('namespace', '', 'namespace of the node and its services, e.g. /robot1'),
    ('frame_prefix', '', "prefix of the world frame the robot services name (robot_state_publisher's frame_prefix), "
                     'e.g. r1/'),
    ('config_file', '', "geometry YAML (GprConfig keys) over the package's config/gpr.yaml, replacing the robot's "
                        'gpr section; empty: that section (the package geometry for the shipped robot)'),
    ('model', '', "virtual-joint model: radial, polar, offset or compliant; empty: the geometry's"),
    ('robot', '', 'robot description YAML (the GPR, the arms, blades and wafers) for the robot services; its gpr '
                  'section is the geometry unless config_file is given; empty: config/robots/example_robot.yaml'),
)


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        *arguments(ARGUMENTS, 'kinematics.launch.py'),
        node('kinematics_node', [{'robot_file': typed('robot'), 'config_file': typed('config_file'),
                                  'model': typed('model'), 'frame_prefix': typed('frame_prefix')}]),
    ])

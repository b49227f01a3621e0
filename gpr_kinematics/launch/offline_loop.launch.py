"""The offline-programming loop: kinematics_node (services), trajectory_node (the paper's sweep, an offline program
of the platform or of the whole robot, or idle for gpr/run_program), recorder_node (the stream into a bag),
state_publisher_node (robot_description, tf), optionally RViz.

    ros2 launch gpr_kinematics offline_loop.launch.py [mode:=program program_file:=...] [bag:=bags/run1]
        [rate:=200.0] [model:=polar] [config_file:=my_gpr.yaml] [robot:=my_robot.yaml] [namespace:=/robot1]
        [record:=false] [rviz:=true]
"""
from gpr_kinematics.nodes.launch_common import arguments, rviz, typed
from launch import LaunchDescription
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PythonExpression
from launch_ros.actions import Node

ARGUMENTS = (
    ('namespace', '', 'namespace of the nodes, their services and topics, e.g. /robot1'),
    ('config_file', '', "geometry YAML (GprConfig keys) over the package's config/gpr.yaml, replacing the robot's "
                        'gpr section; empty: that section (the package geometry for the shipped robot)'),
    ('model', '', "virtual-joint model: radial, polar, offset or compliant; empty: the geometry's"),
    ('robot', '', 'robot description YAML (the GPR, the arms, blades and wafers) of kinematics_node, '
                  "trajectory_node and state_publisher_node; its gpr section is the geometry unless config_file is "
                  "given; empty: config/robots/example_robot.yaml (trajectory_node: a robot program's own robot)"),
    ('mode', 'sweep', 'trajectory_node: sweep (the paper grid), program (program_file) or idle (gpr/run_program)'),
    ('program_file', '', 'offline program YAML for mode program: a platform program or a whole-robot program '
                         '(format gpr_robot_program), as in config/programs/'),
    ('rate', '100.0', 'publishing rate of the stream [Hz]'),
    ('record', 'true', 'record the stream with recorder_node (true/false)'),
    ('bag', '', 'bag folder the recorder creates; empty: bags/gpr_<date>-<time>'),
    ('rviz', 'false', 'start RViz with rviz/gpr.rviz (true/false)'),
)


def generate_launch_description() -> LaunchDescription:
    arg = LaunchConfiguration
    ns, params_file = arg('namespace'), arg('params_file')
    geometry = {'robot_file': typed('robot'), 'config_file': typed('config_file'), 'model': typed('model')}
    return LaunchDescription([
        *arguments(ARGUMENTS),
        Node(package='gpr_kinematics', executable='kinematics_node', namespace=ns, output='screen',
             parameters=[params_file, geometry]),
        Node(package='gpr_kinematics', executable='state_publisher_node', namespace=ns, output='screen',
             parameters=[params_file, geometry]),
        Node(package='gpr_kinematics', executable='recorder_node', namespace=ns, output='screen',
             condition=IfCondition(arg('record')), parameters=[params_file, {'output': typed('bag')}]),
        Node(package='gpr_kinematics', executable='trajectory_node', namespace=ns, output='screen',
             parameters=[params_file, geometry, {
                 'mode': typed('mode'), 'program_file': typed('program_file'), 'rate': typed('rate', float),
                 # With the recorder: wait until it subscribed to every stream topic (at most wait_timeout).
                 'wait_for_subscribers': PythonExpression(["1 if '", arg('record'), "'.lower() == 'true' else 0"])}]),
        rviz(),
    ])

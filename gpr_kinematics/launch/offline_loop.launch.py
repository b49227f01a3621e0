"""The offline-programming loop: kinematics_node (services), robot_simulator_node (the robot's FollowJointTrajectory
controller, joint_states), state_publisher_node (robot_description, tf, always), trajectory_node (the paper's sweep,
an offline program of the platform or of the whole robot, or idle for gpr/run_program), recorder_node (the stream into
a bag), optionally RViz.

    ros2 launch gpr_kinematics offline_loop.launch.py [mode:=program program_file:=...] [bag:=bags/run1]
        [flush_interval:=10.0]
        [rate:=200.0] [model:=polar] [config_file:=my_gpr.yaml] [robot:=my_robot.yaml] [namespace:=/r1]
        [frame_prefix:=r1/] [record:=false] [rviz:=true] [cell:=my_cell.yaml] [use_sim_time:=true] [respawn:=true]
"""
from gpr_kinematics.nodes.launch_common import arguments, node, rviz, typed
from launch import LaunchDescription
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PythonExpression

ARGUMENTS = (
    ('namespace', '', 'namespace of the nodes, their services, actions and topics, e.g. /r1'),
    ('frame_prefix', '', "prefix of every tf frame (robot_state_publisher's frame_prefix), e.g. r1/"),
    ('config_file', '', "geometry YAML (GprConfig keys) over the package's config/gpr.yaml, replacing the robot's "
                        'gpr section; empty: that section (the package geometry for the shipped robot)'),
    ('model', '', "virtual-joint model: radial, polar, offset or compliant; empty: the geometry's"),
    ('robot', '', 'robot description YAML (the GPR, the arms, blades and wafers) of kinematics_node, '
                  'robot_simulator_node, trajectory_node and state_publisher_node; its gpr section is the geometry '
                  'unless config_file is given; empty: config/robots/example_robot.yaml (trajectory_node: a robot '
                  "program's own robot)"),
    ('mode', 'sweep', 'trajectory_node: sweep (the paper grid), program (program_file) or idle (gpr/run_program)'),
    ('program_file', '', 'offline program YAML for mode program: a platform program or a whole-robot program '
                         '(format gpr_robot_program), as in config/programs/'),
    ('rate', '100.0', 'publishing rate of the stream [Hz]'),
    ('record', 'true', 'record the stream with recorder_node (true/false)'),
    ('bag', '', 'bag folder the recorder creates; empty: bags/gpr_<date>-<time>'),
    ('flush_interval', '1.0', "recorder_node's longest time [s] a received message stays outside a closed segment: "
                              "a segment file per interval while messages flow (the simulator's joint_states always "
                              'do); 10.0 for a long session'),
    ('rviz', 'false', 'start RViz with rviz/gpr.rviz (true/false)'),
    ('cell', '', 'process cell YAML (format gpr_cell) of state_publisher_node (its obstacles on gpr/cell) and '
                 'robot_simulator_node (every goal checked against it); empty: none'),
)


def generate_launch_description() -> LaunchDescription:
    arg = LaunchConfiguration
    geometry = {'robot_file': typed('robot'), 'config_file': typed('config_file'), 'model': typed('model')}
    frames = {'frame_prefix': typed('frame_prefix')}
    cell = {'cell_file': typed('cell')}
    return LaunchDescription([
        *arguments(ARGUMENTS, 'offline_loop.launch.py'),
        node('kinematics_node', [geometry, frames]),
        node('robot_simulator_node', [geometry, cell]),
        node('state_publisher_node', [geometry, frames, cell]),
        node('recorder_node', [{'output': typed('bag'), 'flush_interval': typed('flush_interval', float)}],
             condition=IfCondition(arg('record'))),
        node('trajectory_node', [geometry, frames, {
            'mode': typed('mode'), 'program_file': typed('program_file'), 'rate': typed('rate', float),
            # With the recorder: wait until it subscribed to every stream topic (at most wait_timeout).
            'wait_for_subscribers': PythonExpression(["1 if '", arg('record'), "'.lower() in ('true', '1') else 0"])}]),
        rviz(),
    ])

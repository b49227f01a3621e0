"""Two robots side by side: offline_loop.launch.py twice, as /r1 with frames r1/... and as /r2 with frames r2/...: no
topic, service, action or tf frame of one robot is the other's. With rviz:=true each robot gets its RViz, in its
namespace, its fixed frame r1/gpr_base or r2/gpr_base.

    ros2 launch gpr_kinematics two_robots.launch.py [mode:=idle] [robot:=my_robot.yaml] [rviz:=true]
    gpr program send gpr_kinematics/config/programs/example_robot_program.yaml --namespace /r1   # robot 1 moves
"""
from gpr_kinematics.nodes.launch_common import COMMON, checked, share_file
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration

#: The robots: namespace and frame prefix.
ROBOTS = (('/r1', 'r1/'), ('/r2', 'r2/'))
ARGUMENTS = (
    ('mode', 'idle', 'trajectory_node of both robots: idle (goals only), sweep or program (program_file)'),
    ('program_file', '', 'offline program YAML of both robots for mode program'),
    ('robot', '', 'robot description YAML of both robots; empty: config/robots/example_robot.yaml'),
    ('rviz', 'false', 'start an RViz per robot, in its namespace, fixed frame <prefix>gpr_base (true/false)'),
    ('cell', '', 'process cell YAML of both robots (shown on gpr/cell, goals checked against it); empty: none'),
    *COMMON,
)
#: The arguments each robot's offline_loop.launch.py gets from this file's arguments.
PASSED = ('mode', 'program_file', 'robot', 'rviz', 'cell', 'use_sim_time', 'respawn')


def generate_launch_description() -> LaunchDescription:
    entities = [DeclareLaunchArgument(name, default_value=default, description=text)
                for name, default, text in ARGUMENTS]
    entities.append(checked('two_robots.launch.py'))     # before any node (each loop checks its own too)
    for ns, prefix in ROBOTS:
        entities.append(IncludeLaunchDescription(
            PythonLaunchDescriptionSource(share_file('launch', 'offline_loop.launch.py')),
            launch_arguments={'namespace': ns, 'frame_prefix': prefix, 'record': 'false',
                              **{name: LaunchConfiguration(name) for name in PASSED}}.items()))
    return LaunchDescription(entities)

"""The check of an XML launch file's arguments (launch_xml runs no code): each of the package's XML launch files
includes this file after its <arg>s and before its nodes, naming itself in the launch argument checked_launch_file,
so a bad argument ends the launch with one line before any node started (launch_common.checked, as the Python
files do).

    <include file="$(find-pkg-share gpr_kinematics)/launch/check_arguments.launch.py">
      <arg name="checked_launch_file" value="offline_loop.launch.xml"/>
    </include>
"""
from gpr_kinematics.nodes.launch_common import checked
from launch import LaunchDescription


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([checked()])

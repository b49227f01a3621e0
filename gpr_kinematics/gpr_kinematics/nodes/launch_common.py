"""Pieces the package's Python launch files share (``launch/*.launch.py``): the ``params_file`` argument, the
declared arguments of a table, and RViz with ``rviz/gpr.rviz``. Imported by the launch files only, under
``ros2 launch`` (the ``launch`` and ``launch_ros`` packages of a ROS 2 install)."""
from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

PACKAGE = 'gpr_kinematics'


def share_file(folder: str, name: str) -> Any:
    """``<share>/gpr_kinematics/<folder>/<name>`` as a substitution."""
    return PathJoinSubstitution([FindPackageShare(PACKAGE), folder, name])


def arguments(table: Iterable[tuple[str, str, str]]) -> list[Any]:
    """``params_file`` (the shipped config/gpr_params.yaml), then one declared argument per (name, default,
    description) of ``table``."""
    return [DeclareLaunchArgument('params_file', default_value=share_file('config', 'gpr_params.yaml'),
                                  description='ROS parameters file (ros__parameters form)'),
            *(DeclareLaunchArgument(name, default_value=default, description=text) for name, default, text in table)]


def typed(name: str, value_type: type = str) -> Any:
    """The launch argument ``name`` as a parameter value of ``value_type`` (an empty string stays a string)."""
    return ParameterValue(LaunchConfiguration(name), value_type=value_type)


def rviz() -> Any:
    """rviz2 with rviz/gpr.rviz, if the argument ``rviz`` is true."""
    return Node(package='rviz2', executable='rviz2', output='screen',
                condition=IfCondition(LaunchConfiguration('rviz')), arguments=['-d', share_file('rviz', 'gpr.rviz')])

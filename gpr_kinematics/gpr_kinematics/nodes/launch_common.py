"""Pieces the package's Python launch files share (``launch/*.launch.py``): the common arguments, the package's nodes
with the launch's robustness rules, and RViz with ``rviz/gpr.rviz``. Imported by the launch files only, under
``ros2 launch`` (the ``launch`` and ``launch_ros`` packages of a ROS 2 install).

Every node gets ``use_sim_time`` (the launch argument). A *required* node (the services, the robot simulator, the
state publisher: they run until the launch stops) is restarted when it dies if the argument ``respawn`` is true;
otherwise its end, and the failure (a non-zero exit status) of any other node, ends the launch with status 1 and
the reason (which node, its exit status). ``launch`` itself would end a launch whose node emitted ``Shutdown`` with
status 0; an error raised while handling the exit is what makes ``ros2 launch`` return 1, so that is how the reason
is given.

Every launch file checks its arguments right after declaring them (:func:`checked`, the rules of
:mod:`~gpr_kinematics.nodes.launch_arguments`), before any node starts: ``launch`` converts an argument only when the
action that uses it runs, after earlier nodes started, and an exception then left those nodes running
(ros2/launch#747).
"""
from __future__ import annotations

import logging
from collections.abc import Iterable
from typing import Any

from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.conditions import IfCondition
from launch.launch_context import LaunchContext
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

from ..errors import EXIT_BAD_INPUT
from ..inputs.resources import PACKAGE
from .launch_arguments import CHECKED_FILE, check_arguments, misspelt_arguments, refusal, yaml_bool

#: Nodes that run until the launch stops: restarted (``respawn``) or the end of the launch when they die.
REQUIRED = ('kinematics_node', 'robot_simulator_node', 'state_publisher_node')
#: Arguments every launch file of the package declares (name, default, description).
COMMON = (
    ('use_sim_time', 'false', 'every node takes its time from /clock (a simulation) instead of the wall clock '
                              '(true/false)'),
    ('respawn', 'false', 'restart a required node (kinematics_node, robot_simulator_node, state_publisher_node) '
                         'that dies; false: its end, or any node failing, ends the launch with status 1 (true/false)'),
)


def share_file(folder: str, name: str) -> Any:
    """``<share>/gpr_kinematics/<folder>/<name>`` as a substitution."""
    return PathJoinSubstitution([FindPackageShare(PACKAGE), folder, name])


def arguments(table: Iterable[tuple[str, str, str]], launch_file: str) -> list[Any]:
    """``params_file`` (the shipped config/gpr_params.yaml), one declared argument per (name, default, description)
    of ``table``, then :data:`COMMON`, then the check of their values (:func:`checked`) for ``launch_file``."""
    return [DeclareLaunchArgument('params_file', default_value=share_file('config', 'gpr_params.yaml'),
                                  description='ROS parameters file (ros__parameters form)'),
            *(DeclareLaunchArgument(name, default_value=default, description=text)
              for name, default, text in (*table, *COMMON)),
            checked(launch_file)]


def _installed(package: str) -> bool:
    """Whether the ROS package ``package`` is on the ament index (as launch_ros looks a Node's package up)."""
    from ament_index_python.packages import PackageNotFoundError, get_package_prefix

    try:
        get_package_prefix(package)
    except PackageNotFoundError:
        return False
    return True


def _check(context: LaunchContext, launch_file: str | None) -> None:
    """End the launch (status 1) with one line naming every bad argument, before any node started."""
    configurations = context.launch_configurations
    if launch_file is None:
        if CHECKED_FILE not in configurations:
            raise RuntimeError(f'check_arguments.launch.py checks the arguments of a launch file named by the launch '
                               f'argument {CHECKED_FILE} (the package\'s XML launch files include it); none given')
        launch_file = configurations[CHECKED_FILE]
    for warning in misspelt_arguments(launch_file, configurations):   # rat:=400 ran at the default rate
        logging.getLogger('launch').warning(warning)   # launch.logging's logger (its handlers print it)
    errors = check_arguments(launch_file, configurations, installed=_installed)
    if errors:
        raise RuntimeError(refusal(errors))


def checked(launch_file: str | None = None) -> Any:
    """The action that checks the arguments of ``launch_file`` (``offline_loop.launch.py``, ...; None: the one
    named by the launch configuration :data:`~gpr_kinematics.nodes.launch_arguments.CHECKED_FILE`, as
    launch/check_arguments.launch.py does for the XML files), to put after their declarations and before any
    node."""
    return OpaqueFunction(function=_check, args=[launch_file])


def typed(name: str, value_type: type = str) -> Any:
    """The launch argument ``name`` as a parameter value of ``value_type`` (an empty string stays a string)."""
    return ParameterValue(LaunchConfiguration(name), value_type=value_type)


def launch_bool(text: str) -> bool:
    """A launch argument read as ``launch`` reads a bool (``launch.utilities.type_utils.coerce_to_type``, which the
    Node's ``respawn`` goes through): ``1`` and ``0``, else YAML 1.1 (``true``, ``True``, ``yes``, ``on``, ...): the
    exit rule and the respawn agree (``respawn:=yes`` restarted the node and ended the launch)."""
    return yaml_bool(text) is True


def _exited(context: LaunchContext, name: str, required: bool) -> None:
    """On a node's exit: nothing while the launch stops, or when the node is being restarted, or when a node that
    finishes on its own (a sweep) ended well; else end the launch with status 1 and the reason. A node that refused
    to start (status 2: its arguments, parameters or files) is not restarted: it would refuse again, every second,
    for ever."""
    event = context.locals.event
    code = int(event.returncode)
    restarted = (required and code != EXIT_BAD_INPUT
                 and launch_bool(LaunchConfiguration('respawn').perform(context)))
    if context.is_shutdown or restarted or (code == 0 and not required):
        return
    what = ('refused to start' if code == EXIT_BAD_INPUT else 'died') if code else 'is required and ended'
    raise RuntimeError(f'{name} {what} (exit status {code}): ending the launch')


def node(executable: str, parameters: list[Any], namespace: Any = None, condition: Any = None,
         remappings: list[tuple[str, Any]] | None = None) -> Any:
    """The package's ``executable`` in ``namespace`` with ``params_file``, ``parameters`` and ``use_sim_time``, and
    the exit rules of the module docstring."""
    required = executable in REQUIRED
    return Node(package=PACKAGE, executable=executable, namespace=namespace or LaunchConfiguration('namespace'),
                output='screen', condition=condition, remappings=remappings or [],
                parameters=[LaunchConfiguration('params_file'), *parameters,
                            {'use_sim_time': typed('use_sim_time', bool)}],
                respawn=LaunchConfiguration('respawn') if required else False, respawn_delay=1.0,
                on_exit=[OpaqueFunction(function=_exited, args=[executable, required])])


def rviz() -> Any:
    """rviz2 in the launch's namespace with rviz/gpr.rviz (its topics relative: they follow the namespace) and the
    fixed frame ``<frame_prefix>gpr_base``, if the argument ``rviz`` is true."""
    return Node(package='rviz2', executable='rviz2', output='screen', namespace=LaunchConfiguration('namespace'),
                condition=IfCondition(LaunchConfiguration('rviz')),
                parameters=[{'use_sim_time': typed('use_sim_time', bool)}],
                arguments=['-d', share_file('rviz', 'gpr.rviz'), '-f', [LaunchConfiguration('frame_prefix'),
                                                                        'gpr_base']])

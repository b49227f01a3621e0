"""The launch files' arguments checked before any node starts (no ROS, no ``launch`` import: plain text in, messages
out; :func:`gpr_kinematics.nodes.launch_common.checked` runs it in every launch file).

``launch`` converts a typed argument only when the action that uses it runs: ``rate:=abc`` raised in
trajectory_node's action, after kinematics_node, robot_simulator_node and state_publisher_node had started, and an
exception in a launch leaves the processes it started running (ros2/launch#747: three orphans serving on). Its
messages named no argument (``Cannot convert value 'maybe' to '<class 'bool'>'``, ``invalid condition expression
... <LaunchConfiguration object at 0x...>``), and a ``params_file`` that is no file was skipped with a warning.

Each argument is accepted exactly as ``launch`` takes it where it is used: a ``condition`` (``IfCondition``,
``UnlessCondition``: ``record``, ``rviz``, and ``respawn`` in the XML files) takes true, false, 1 or 0 in any case
and with spaces around; a ``bool`` (a bool parameter, the Node's ``respawn``: ``use_sim_time``, ``loop``, and
``respawn`` in the Python files) takes what YAML 1.1 reads as a bool (``yes``, ``On``, ...) and 1 or 0; a
``number`` is what Python's ``float`` reads (the parameter's type), within the node parameter's range; a
``choice`` is one of the node parameter's choices; ``params_file`` an existing file; ``frame_prefix`` a frame
prefix; ``namespace`` a ROS namespace. The other arguments (paths, names) go to the nodes as text, which check them
at start.
"""
from __future__ import annotations

import difflib
import math
import os
import re
from collections.abc import Callable, Mapping

import yaml

from ..core.messages import frame_prefix_refusal
from ..errors import brief
from ..ros.specs import ParamSpec, node_specs

#: The arguments each launch file declares (in its order), Python and XML variants alike.
FILES: dict[str, tuple[str, ...]] = {
    'kinematics': ('params_file', 'namespace', 'frame_prefix', 'config_file', 'model', 'robot', 'use_sim_time',
                   'respawn'),
    'offline_loop': ('params_file', 'namespace', 'frame_prefix', 'config_file', 'model', 'robot', 'mode',
                     'program_file', 'rate', 'record', 'bag', 'flush_interval', 'rviz', 'cell', 'use_sim_time',
                     'respawn'),
    'replay': ('params_file', 'bag', 'rate', 'loop', 'clock_rate', 'namespace', 'frame_prefix', 'joint_states',
               'config_file', 'model', 'robot', 'rviz', 'use_sim_time', 'respawn'),
    'two_robots': ('mode', 'program_file', 'robot', 'rviz', 'cell', 'use_sim_time', 'respawn'),
}
#: The node whose parameter of the argument's name gives a number's range or a choice's choices (per launch file
#: where it differs).
PARAMETER_OF: dict[str, str | dict[str, str]] = {
    'rate': {'offline_loop': 'trajectory_node', 'replay': 'replay_node'}, 'clock_rate': 'replay_node',
    'flush_interval': 'recorder_node', 'mode': 'trajectory_node', 'model': 'kinematics_node',
}
#: What a condition (``launch.conditions``) takes, after ``strip().lower()``.
CONDITION = ('true', 'false', '1', '0')
CONDITION_ALLOWED = 'true or false (any case), 1 or 0'
BOOL_ALLOWED = 'true/false, yes/no or on/off (lower, Capitalised or UPPER case, as YAML 1.1 reads a bool), 1 or 0'
#: The package an argument needs when it is true (its node's), with the way to install it.
NEEDS = {'rviz': ('rviz2', 'apt install ros-jazzy-rviz2')}
#: The launch configuration that names the XML launch file whose arguments launch/check_arguments.launch.py checks.
CHECKED_FILE = 'checked_launch_file'


def condition_bool(text: str) -> bool | None:
    """``text`` as a launch condition reads it (``launch.conditions.evaluate_condition_expression``), or None when
    the condition would raise."""
    value = text.strip().lower()
    return value in ('true', '1') if value in CONDITION else None


def yaml_bool(text: str) -> bool | None:
    """``text`` as ``launch`` coerces it to a bool (``launch.utilities.type_utils.coerce_to_type``: 1 and 0, else
    YAML 1.1), or None when it would raise."""
    try:
        value = yaml.safe_load({'1': 'true', '0': 'false'}.get(text, text)) if text else None
    except yaml.YAMLError:
        return None
    return value if isinstance(value, bool) else None


def _node_of(name: str, launch_file: str) -> str:
    node = PARAMETER_OF[name]
    return node if isinstance(node, str) else node[launch_file]


def _spec(name: str, launch_file: str) -> tuple[ParamSpec, str]:
    node = _node_of(name, launch_file)
    return next(s for s in node_specs(node) if s.name == name), node


def _number(name: str, text: str, launch_file: str) -> tuple[str, str] | None:
    spec, node = _spec(name, launch_file)
    allowed = f"a number, {spec.constraint_text()} ({node}'s {name})"
    try:
        value = float(text)
    except ValueError:
        return 'is not a number', allowed
    lo, hi = spec.limits or (-math.inf, math.inf)
    if not (math.isfinite(value) and lo <= value <= hi):
        return 'is out of range', allowed
    return None


def _choice(name: str, text: str, launch_file: str) -> tuple[str, str] | None:
    spec, node = _spec(name, launch_file)
    if text in (spec.choices or ()):
        return None
    return 'is not among the choices', f"{spec.constraint_text().removeprefix('one of: ')} ({node}'s {name})"


def _condition(_name: str, text: str, _launch_file: str) -> tuple[str, str] | None:
    return None if condition_bool(text) is not None else ('is not a condition', CONDITION_ALLOWED)


def _bool(_name: str, text: str, _launch_file: str) -> tuple[str, str] | None:
    return None if yaml_bool(text) is not None else ('is not a bool', BOOL_ALLOWED)


def _params_file(_name: str, text: str, _launch_file: str) -> tuple[str, str] | None:
    if os.path.isfile(text):
        return None
    problem = 'is not a file' if os.path.exists(text) else 'does not exist'
    return problem, 'an existing ROS parameters file (ros__parameters form), by default the shipped gpr_params.yaml'


def _frame_prefix(_name: str, text: str, _launch_file: str) -> tuple[str, str] | None:
    allowed = frame_prefix_refusal(text)   # the nodes' check_frame_prefix's rule, with the default frames
    return None if allowed is None else ('is not a frame prefix', allowed)


#: A token of a ROS namespace (rmw's rule: letters, digits and underscores, not starting with a digit).
_TOKEN = re.compile(r'[A-Za-z_][A-Za-z0-9_]*')


def _namespace(_name: str, text: str, _launch_file: str) -> tuple[str, str] | None:
    """A node's namespace as launch_ros takes it (made absolute): ``namespace:=1bad`` was refused by launch_ros with an
    object's repr (``namespace=<...LaunchConfiguration object at 0x...>``) after the argument checks."""
    body = text[1:] if text.startswith('/') else text
    if text in ('', '/') or all(_TOKEN.fullmatch(t) for t in body.split('/')):
        return None
    return ('is not a ROS namespace', 'empty, or names of letters, digits and underscores (none starting with a '
            'digit) separated by single slashes, e.g. /r1 or cell/r1')


Rule = Callable[[str, str, str], 'tuple[str, str] | None']
#: The rule of each checked argument; ``respawn`` is a condition in the XML files (if/unless), a bool in Python.
RULES: dict[str, Rule] = {
    'params_file': _params_file, 'frame_prefix': _frame_prefix, 'namespace': _namespace, 'model': _choice,
    'mode': _choice, 'rate': _number, 'clock_rate': _number, 'flush_interval': _number, 'record': _condition,
    'rviz': _condition, 'loop': _bool,
    'use_sim_time': _bool, 'respawn': _bool,
}


def launch_file_name(launch_file: str) -> tuple[str, bool]:
    """``offline_loop.launch.xml`` -> (``offline_loop``, True: the XML variant); a name not of :data:`FILES` is
    refused naming those that are."""
    base = os.path.basename(launch_file)
    for suffix, xml in (('.launch.py', False), ('.launch.xml', True)):
        if base.endswith(suffix) and base[:-len(suffix)] in FILES:
            return base[:-len(suffix)], xml
    allowed = ', '.join(f'{name}.launch.py/.xml' for name in FILES)
    raise ValueError(f'launch file {brief(launch_file)} is not checked; allowed: {allowed}')


def check_arguments(launch_file: str, values: Mapping[str, str],
                    installed: Callable[[str], bool] = lambda _package: True) -> list[str]:
    """One message per argument of ``launch_file`` (``offline_loop.launch.py``, ...) in ``values`` that ``launch``
    or the node would refuse, naming it, its value and what is allowed; empty when all are good. ``installed``
    tells whether a ROS package is (``rviz:=true`` without rviz2 raised at the rviz2 node, after the others
    started)."""
    name, xml = launch_file_name(launch_file)
    errors = []
    for arg in FILES[name]:
        if arg not in values or arg not in RULES:
            continue
        rule = _condition if xml and arg == 'respawn' else RULES[arg]
        text = values[arg]
        bad = rule(arg, text, name)
        if bad is None and arg in NEEDS and condition_bool(text) and not installed(NEEDS[arg][0]):
            package, how = NEEDS[arg]
            bad = f'needs {package}, which is not installed', f'false, or install {package} ({how})'
        if bad is not None:
            errors.append(f'{arg}:={brief(text)} {bad[0]}; allowed: {bad[1]}')
    return errors


def misspelt_arguments(launch_file: str, values: Mapping[str, str]) -> list[str]:
    """One warning per given argument ``launch_file`` does not declare that is close to one it does (``rat:=400``
    for ``rate``: ``launch`` ignores an undeclared argument, and the node ran at its default); an argument far from
    every declared one says nothing (an including launch file's own configurations reach the included one's)."""
    name, _ = launch_file_name(launch_file)
    declared = FILES[name]
    out = []
    for given in sorted(k for k in values if k not in declared and k != CHECKED_FILE):
        close = difflib.get_close_matches(given, declared, n=1, cutoff=0.75)
        if close:
            out.append(f'launch argument {given}:={brief(values[given])} is not an argument of {name} (did you mean '
                       f'{close[0]}?): ignored, as launch ignores an undeclared argument')
    return out


def refusal(errors: list[str]) -> str:
    """The one line that ends a launch with bad arguments."""
    return ('invalid launch argument' + ('s' if len(errors) > 1 else '') + ', no node started: '
            + ' | '.join(errors))

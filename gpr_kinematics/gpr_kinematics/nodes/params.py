"""Declaring the nodes' ROS parameters from their specs (:mod:`.specs`), and the GPR configuration as parameters.

:func:`declare_parameters` is the one declaration loop of every node: descriptors carry the type, the
description, the range (``floating_point_range`` / ``integer_range``), the allowed strings and any further
constraint as ``additional_constraints`` text, and ``read_only``; the start-up values are checked against the
spec (rclpy checks ranges, not allowed strings) and a bad one raises :class:`~gpr_kinematics.errors.ConfigError`.

:class:`ConfigParameters` declares ``config_file`` and every ``GprConfig`` key (defaults from ``config_file``,
else the node's robot description's ``gpr`` section, else the package's ``config/gpr.yaml``) and keeps ``config``
in step with them. A run-time change follows rclpy's two stages: the on-set callback only *validates* (the whole
configuration, through ``GprConfig.from_mapping``, rejected with the reason when invalid); the post-set callback,
called once the change is accepted, *applies* it.
"""
from __future__ import annotations

import dataclasses
import difflib
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..core.config import MODELS, GprConfig, load_config, parameter_rules
from ..errors import ConfigError, GprError
from ..robot.description import RobotDescription, load_robot
from ..ros.specs import CONFIG_FILE, ROBOT_FILE, ParamSpec, config_mapping, config_specs

_TYPES = {
    'double': ParameterType.PARAMETER_DOUBLE,
    'integer': ParameterType.PARAMETER_INTEGER,
    'string': ParameterType.PARAMETER_STRING,
    'bool': ParameterType.PARAMETER_BOOL,
    'double_array': ParameterType.PARAMETER_DOUBLE_ARRAY,
    'string_array': ParameterType.PARAMETER_STRING_ARRAY,
}


def descriptor(spec: ParamSpec, read_only: bool = False) -> ParameterDescriptor:
    """The ParameterDescriptor of ``spec`` (``read_only`` forces read-only)."""
    d = ParameterDescriptor(name=spec.name, type=_TYPES[spec.kind], description=spec.description,
                            additional_constraints=spec.constraint_text(), read_only=spec.read_only or read_only)
    if spec.limits is not None and spec.kind == 'double':
        d.floating_point_range = [FloatingPointRange(from_value=float(spec.limits[0]),
                                                     to_value=float(spec.limits[1]), step=0.0)]
    elif spec.limits is not None and spec.kind == 'integer':
        d.integer_range = [IntegerRange(from_value=int(spec.limits[0]), to_value=int(spec.limits[1]), step=1)]
    return d


def declare_parameters(node: Node, specs: Sequence[ParamSpec], read_only: bool = False) -> dict[str, Any]:
    """Declare every spec on ``node``; return the start-up values by name, each checked against its spec.

    An empty array given on the command line (``-p topics:=[]``) has no type in ROS and arrives as ``None``; it
    is returned as an empty list. Raises :class:`~gpr_kinematics.errors.ConfigError` naming the parameter, its
    value and what is allowed, also where rclpy refused a bounded number's type or range (its words, then the range:
    ``allowed: a floating-point value from 0.1 to 5000.0, e.g. 100.0``; ``-p rate:=0`` was told to write 0.0); rclpy's
    own ``ParameterException`` for another parameter's wrong type.
    """
    values: dict[str, Any] = {}
    for spec in specs:
        try:
            value = node.declare_parameter(spec.name, spec.default, descriptor(spec, read_only)).value
        except ParameterException as exc:   # rclpy's refusal of the type or the range: a bounded number's range added
            if spec.limits is None or spec.kind not in ('double', 'integer'):
                raise
            whole = re.search(r"to '(-?\d+)' of type 'INTEGER'", str(exc)) if spec.kind == 'double' else None
            raise ConfigError(f'{exc}; allowed: {allowed_number(spec, int(whole.group(1)) if whole else None)}'
                              ) from None
        if value is None and spec.kind.endswith('_array'):
            value = []
        if isinstance(value, (list, tuple)) or type(value).__name__ == 'array':
            value = list(value)
        spec.check(value)
        values[spec.name] = value
    return values


def allowed_number(spec: ParamSpec, written: int | None = None) -> str:
    """What a bounded number parameter takes, with an example: ``written``, an integer given to a double, as the
    double to write where it is in range, else the default (``a floating-point value from 0.1 to 5000.0, e.g.
    100.0``)."""
    lo, hi = spec.limits or (-math.inf, math.inf)
    noun = 'a floating-point value' if spec.kind == 'double' else 'an integer'
    if written is not None and lo <= written <= hi:
        return f'{noun} from {lo!r} to {hi!r} (write {written}.0)'
    return f'{noun} from {lo!r} to {hi!r}, e.g. {spec.default!r}'


def unknown_overrides(node: Node) -> list[str]:
    """Warn once for each start-up parameter (``-p NAME:=VALUE``, a parameters file) that names no parameter of
    ``node``: rclpy ignores it silently, so a typo (``idle_rat``) would leave the default in force unnoticed. The
    warning names the closest parameter, if any; returns the names warned about."""
    overrides = getattr(node, '_parameter_overrides', None) or {}   # rclpy has no public reader of them
    unknown = sorted(name for name in overrides if not node.has_parameter(name))
    declared = sorted(node.get_parameters_by_prefix(''))
    for name in unknown:
        close = difflib.get_close_matches(name, declared, n=1)
        hint = f'did you mean {close[0]!r}? ' if close else ''
        node.get_logger().warning(f'parameter {name[:200]!r} given at start is not a parameter of {node.get_name()} '
                                  f'and is ignored; {hint}allowed: {", ".join(declared)}')
    return unknown


def declare_robot(node: Node, default: str | Path | None = None) -> RobotDescription:
    """Declare ``robot_file`` on ``node`` and load that robot description (empty: ``default``, else the shipped
    example); :class:`~gpr_kinematics.errors.ConfigError` names the file and what is wrong."""
    robot_file = declare_parameters(node, (ROBOT_FILE,))['robot_file']
    try:
        return load_robot(robot_file or default)
    except ConfigError as exc:
        raise ConfigError(f'robot_file: {exc}') from None


def parameter_words(message: str) -> str:
    """A configuration's refusal in the parameters' terms: a characteristic length follows the radius at 0 (a
    parameter cannot be null) and an empty ``model`` is the geometry's
    (:func:`~gpr_kinematics.ros.specs.config_mapping`), which the configuration's own words leave out."""
    message = parameter_rules(message.replace(', or null for the radius', ', or 0 for the radius'))
    if 'model = ' in message and message.endswith('allowed: ' + ' or '.join(MODELS)):
        message += " or '' (the geometry's model)"
    return message


class ConfigParameters:
    """Declares ``config_file`` and the ``GprConfig`` parameters on ``node``; ``config`` follows them.

    The base configuration is ``config_file`` when given, else the geometry of ``robot`` (its description's
    ``gpr`` section), else the package's ``config/gpr.yaml``; the parameters override it. ``robot`` then always
    computes with ``config`` (:attr:`robot`): one geometry per node. ``read_only=True`` declares them all read-only
    (a node that precomputes with the configuration). Raises :class:`~gpr_kinematics.errors.ConfigError` at
    construction when the start-up values (defaults plus overrides) do not form a valid configuration.
    """

    def __init__(self, node: Node, read_only: bool = False, robot: RobotDescription | None = None) -> None:
        self._node = node
        config_file = declare_parameters(node, (CONFIG_FILE,))['config_file']
        self._base = load_config(config_file or None) if config_file or robot is None else robot.config
        self._robot = robot
        self._specs = {s.name: s for s in config_specs(self._base, read_only)}
        self._values = declare_parameters(node, tuple(self._specs.values()))
        self.config = self._build(self._values)
        node.add_on_set_parameters_callback(self._validate)
        node.add_post_set_parameters_callback(self._apply)

    @property
    def robot(self) -> RobotDescription:
        """The node's robot description computing with the node's current configuration."""
        if self._robot is None:
            raise ConfigError('this node has no robot description')
        if self._robot.config is not self.config:
            self._robot = dataclasses.replace(self._robot, config=self.config)
        return self._robot

    def _build(self, values: dict[str, Any]) -> GprConfig:
        """Every key of the loaded configuration file with the parameters' values on top (validated as a whole):
        keys that no ROS parameter holds (an imperfect machine's ``rod_positions``, ``rod_directions``,
        ``platform_joints``) keep the file's values."""
        try:
            return GprConfig.from_mapping({**self._base.to_dict(), **config_mapping(values)}, source='ROS parameters')
        except ConfigError as exc:
            raise ConfigError(parameter_words(str(exc))) from None

    def _changes(self, params: Sequence[Parameter]) -> dict[str, Any]:
        return {p.name: p.value for p in params if p.name in self._specs}

    def _validate(self, params: list[Parameter]) -> SetParametersResult:
        """On-set stage: accept the change only if the whole configuration stays valid (no state change)."""
        changes = self._changes(params)
        if changes:
            try:
                self._build({**self._values, **changes})
            except GprError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply(self, params: list[Parameter]) -> None:
        """Post-set stage: the change was accepted; apply it."""
        changes = self._changes(params)
        if not changes:
            return
        self._values = {**self._values, **changes}
        self.config = self._build(self._values)
        self._node.get_logger().info('configuration changed: ' + ', '.join(f'{k}={v!r}' for k, v in changes.items()))

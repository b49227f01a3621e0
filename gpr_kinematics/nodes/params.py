"""ROS parameters of the GPR geometry and model, declared with descriptors, mapped onto ``GprConfig``.

Every field of :class:`~gpr_kinematics.config.GprConfig` is a parameter of the same name (SI units), its
default taken from the package's embedded ``config/gpr.yaml`` (or from the YAML named by the read-only
parameter ``config_file``), overridable with ``--ros-args -p name:=value`` or ``--params-file``.
The machine's geometry (``radius``, ``rod_azimuths``, ``stroke_min``, ``stroke_max``) and ``config_file``
are read-only: they describe the hardware and cannot change while the node runs. The model and solver
settings may change at run time; a change is validated through ``GprConfig.replace`` and rejected with the
reason when invalid.
"""
from __future__ import annotations

import math
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..config import MODELS, WEIGHTINGS, GprConfig, load_config
from ..errors import GprError

#: (name, type, description, range or choices, read_only)
_SPECS: tuple[tuple[str, int, str, Any, bool], ...] = (
    ('radius', ParameterType.PARAMETER_DOUBLE, 'radius R of the circle of rod axes [m]', (1e-4, 10.0), True),
    ('rod_azimuths', ParameterType.PARAMETER_DOUBLE_ARRAY,
     'azimuths of rods 1, 2, 3 in gpr_base [rad]', None, True),
    ('stroke_min', ParameterType.PARAMETER_DOUBLE, 'lowest rod length q [m]', (-10.0, 10.0), True),
    ('stroke_max', ParameterType.PARAMETER_DOUBLE, 'highest rod length q [m]', (-10.0, 10.0), True),
    ('tilt_limit', ParameterType.PARAMETER_DOUBLE, 'largest platform tilt [rad]', (1e-6, math.radians(15.0)),
     False),
    ('imperfection_budget', ParameterType.PARAMETER_DOUBLE,
     'largest virtual-joint displacement of a joint centre [m]', (1e-9, 0.01), False),
    ('model', ParameterType.PARAMETER_STRING, 'default virtual-joint model', MODELS, False),
    ('characteristic_length', ParameterType.PARAMETER_DOUBLE,
     'weight of angular virtual joints in the Newton step [m]; 0 = radius', (0.0, 100.0), False),
    ('weighting', ParameterType.PARAMETER_STRING, 'Newton step norm', WEIGHTINGS, False),
    ('max_iterations', ParameterType.PARAMETER_INTEGER, 'bound of Newton iterations per solve', (1, 100),
     False),
    ('tolerance', ParameterType.PARAMETER_DOUBLE, 'closure tolerance on the side lengths [m]', (1e-16, 1e-6),
     False),
)

CONFIG_KEYS: tuple[str, ...] = tuple(s[0] for s in _SPECS)


def descriptor(name: str, ptype: int, description: str, limits: Any = None,
               read_only: bool = False) -> ParameterDescriptor:
    """A ParameterDescriptor with a float/int range or a list of allowed strings."""
    d = ParameterDescriptor(name=name, type=ptype, description=description, read_only=read_only)
    if ptype == ParameterType.PARAMETER_DOUBLE and limits is not None:
        d.floating_point_range = [FloatingPointRange(from_value=float(limits[0]), to_value=float(limits[1]),
                                                     step=0.0)]
    elif ptype == ParameterType.PARAMETER_INTEGER and limits is not None:
        d.integer_range = [IntegerRange(from_value=int(limits[0]), to_value=int(limits[1]), step=1)]
    elif ptype == ParameterType.PARAMETER_STRING and limits is not None:
        d.additional_constraints = 'one of: ' + ', '.join(limits)
    return d


def _config_values(cfg: GprConfig) -> dict[str, Any]:
    values = cfg.to_dict()
    values['rod_azimuths'] = [float(a) for a in cfg.rod_azimuths]
    if cfg.characteristic_length == cfg.radius:
        values['characteristic_length'] = 0.0
    return values


def _to_config_mapping(values: dict[str, Any]) -> dict[str, Any]:
    out = dict(values)
    out['rod_azimuths'] = list(out['rod_azimuths'])
    if out.get('characteristic_length') == 0.0:
        out['characteristic_length'] = None
    return out


class ConfigParameters:
    """Declares the GprConfig parameters on ``node`` and keeps ``self.config`` in step with them.

    ``read_only=True`` declares them all read-only (a node that precomputes with the configuration).

    Raises :class:`~gpr_kinematics.errors.ConfigError` at construction when the initial values (defaults
    plus overrides) do not form a valid configuration.
    """

    def __init__(self, node: Node, read_only: bool = False) -> None:
        self._node = node
        config_file = node.declare_parameter(
            'config_file', '', descriptor('config_file', ParameterType.PARAMETER_STRING,
                                          'YAML with GprConfig keys loaded over the package default; '
                                          'empty: the package default (config/gpr.yaml)', read_only=True)
        ).value
        base = load_config(config_file or None)
        defaults = _config_values(base)
        values: dict[str, Any] = {}
        for name, ptype, text, limits, ro in _SPECS:
            param = node.declare_parameter(name, defaults[name],
                                           descriptor(name, ptype, text, limits, ro or read_only))
            values[name] = param.value
        self._values = values
        self.config = GprConfig.from_mapping(_to_config_mapping(values), source='ROS parameters')
        node.add_on_set_parameters_callback(self._on_set)

    def _on_set(self, params: list[Parameter]) -> SetParametersResult:
        changes = {p.name: p.value for p in params if p.name in CONFIG_KEYS}
        if not changes:
            return SetParametersResult(successful=True)
        values = dict(self._values)
        values.update(changes)
        try:
            cfg = GprConfig.from_mapping(_to_config_mapping(values), source='ROS parameters')
        except GprError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        self._values = values
        self.config = cfg
        self._node.get_logger().info('configuration changed: ' + ', '.join(f'{k}={v!r}' for k, v in
                                                                           changes.items()))
        return SetParametersResult(successful=True)

"""The whole-robot services of ``kinematics_node``: requests -> the robot core -> responses (docs/ros.md).

- ``gpr/robot_forward_kinematics`` (RobotForwardKinematics): rod lengths and one arm's joints -> the platform, blade
  and wafer in the world, exact and naive (core :func:`gpr_kinematics.robot.robot_forward`);
- ``gpr/station_inverse_kinematics`` (StationInverseKinematics): a station (the wafer's position in the world, the
  station plane's tilt and azimuth, the blade heading) -> rod lengths and the arm's joints, with the wafer error the
  naive model's joints would make (core :func:`gpr_kinematics.robot.solve_stations`).

The node's robot description (parameter ``robot_file``) computes with the node's geometry; a request may name
another virtual-joint model. Every field of a request is checked (finite numbers, the arm, the number of joints,
the branch; names exactly as sent: ``"arm1 "`` is no arm) and a bad one raises
:class:`~gpr_kinematics.errors.InputError` naming the field and what is allowed; the core refuses what is beyond
the robot's limits (stroke, tilt, reach, joint limits) with its message. SI units (metres, radians) and quaternions
(x, y, z, w), as in the core.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any

from ..core import ForwardResult
from ..core.config import MODELS
from ..errors import ConfigError, InputError, brief
from ..inputs.validation import finite_number
from ..robot import robot_forward, solve_stations
from ..robot.description import BRANCHES, Arm, RobotDescription
from ..robot.forward import forward_floats, joints_within_limits, naive_floats
from .conversions import floats_of, set_pose, set_vector
from .station_request import one_station_request, request_stations


class RobotModels:
    """The node's robot under each virtual-joint model a request names (one description per model, kept, so a
    model's per-configuration caches survive between requests)."""

    def __init__(self) -> None:
        # keyed by the description's identity; the entry holds the description, so its id is not reused while cached
        self._cache: dict[tuple[int, str], tuple[RobotDescription, RobotDescription]] = {}

    def get(self, robot: RobotDescription, model: str) -> RobotDescription:
        """``robot`` under ``model`` (empty: its own; a name exactly as sent); InputError for a model that does not
        exist."""
        if not model or model == robot.config.model:
            return robot
        if model not in MODELS:
            raise InputError(f'model = {brief(model)} is invalid; allowed: {", ".join(MODELS)}, or empty for the '
                             "node's model")
        key = (id(robot), model)
        entry = self._cache.get(key)
        if entry is None:
            if len(self._cache) > 16:  # a description changed at run time: forget the old ones
                self._cache.clear()
            entry = self._cache[key] = (robot, dataclasses.replace(robot, config=robot.config.replace(model=model)))
        return entry[1]


def _arm(robot: RobotDescription, name: str) -> Arm:
    """The arm ``name`` (empty: the first) by :meth:`RobotDescription.arm`; InputError naming the request's field."""
    try:
        return robot.arm(name or None)
    except ConfigError:
        raise InputError(f'arm = {brief(name)} is invalid; allowed: {", ".join(robot.arm_names)} (the arms of robot '
                         f'{robot.name})') from None


def _joints(values: Any, arm: Arm, field: str) -> list[float]:
    """The arm's joint values [rad]: as many as it has, finite (InputError naming the joint otherwise)."""
    n = len(arm.joints)
    if len(values) != n:
        raise InputError(f'{field}: {len(values)} values given; arm {arm.name} has {n} joints '
                         f'({", ".join(arm.joint_names)}) [rad]; allowed: one value per joint, shoulder first')
    out = [float(v) for v in values]
    for name, v in zip(arm.joint_names, out, strict=True):
        if not math.isfinite(v):
            raise InputError(f'{field}: {name} = {v} is not a finite number; allowed: radians within its limits')
    return out


def _branch(name: str, arm: Arm) -> str:
    """The request's branch (empty: the arm's own); InputError for another name (the core's said "left or right",
    not that empty is allowed too)."""
    if name and name not in BRANCHES:
        raise InputError(f"branch = {brief(name)} is invalid; allowed: left, right or empty (the arm's own, "
                         f'{arm.branch} for arm {arm.name})')
    return name or arm.branch


def _platform_fields(response: Any, gpr: ForwardResult) -> None:
    response.tilt = gpr.tilt
    response.tilt_azimuth = gpr.tilt_azimuth
    response.twist = gpr.twist
    x, y, z = gpr.centre_shift.tolist()
    set_vector(response.centre_shift, (x, y, z))


def fill_robot_forward(robot: RobotDescription, request: Any, response: Any, prefix: str = '') -> Any:
    """A RobotForwardKinematics response for ``request`` (module docstring): the one-configuration path in floats
    (:func:`~gpr_kinematics.robot.forward.forward_floats`), the batch where it refuses (its message); the world
    frame named with the node's frame ``prefix``."""
    arm = _arm(robot, request.arm)
    rods = floats_of(request.rods, 'rods', 3)
    joints = _joints(request.joints, arm, 'joints')
    if not joints_within_limits(arm, joints):
        robot_forward(robot, [rods], [joints], arm.name)  # raises, naming the joint
    one = forward_floats(robot, arm, rods, joints)
    naive = naive_floats(robot, rods, one)
    if naive is None:
        robot_forward(robot, [rods], [joints], arm.name).naive_platform.floats(0)  # raises, naming the rods
        raise AssertionError('unreachable: the batch refuses rods that imply no orientation')
    response.world_frame = prefix + robot.world_frame
    response.arm = arm.name
    response.joint_names = list(arm.joint_names)
    for name, pose in (('wafer', one.wafer), ('blade', one.blade), ('platform', one.platform),
                       ('naive_wafer', naive.naive_wafer), ('naive_platform', naive.naive_platform)):
        set_pose(getattr(response, name), pose)
    set_vector(response.naive_wafer_error, naive.naive_wafer_error)
    response.naive_wafer_error_norm = naive.norm
    response.naive_wafer_angle_error = naive.naive_wafer_angle_error
    _platform_fields(response, one.gpr)
    return response


def fill_station_inverse(robot: RobotDescription, request: Any, response: Any, prefix: str = '') -> Any:
    """A StationInverseKinematics response for ``request`` (module docstring): the one-station path in floats
    (:func:`~gpr_kinematics.robot.one_station.station_floats`), the batch path where it refuses (its message); the
    world frame named with the node's frame ``prefix``."""
    arm = _arm(robot, request.arm)
    branch = _branch(request.branch, arm)
    use = request.use_redundancy_value
    value = float(request.redundancy_value) if use else None
    one = one_station_request(robot, request, arm, branch, value)
    if one is None:  # a refusal, named by the batch path (or its answer, where the float path declined)
        stations = request_stations(robot, request, arm)
        value = finite_number(request.redundancy_value, 'redundancy_value') if use else None
        sol = solve_stations(robot, stations, arm.name, branch=request.branch or None, redundancy_value=value)
        one, branch = sol.floats(0), sol.branch[0]
    response.world_frame = prefix + robot.world_frame
    response.arm = arm.name
    response.branch = branch
    response.rods = one.rods
    response.joint_names = list(arm.joint_names)
    response.joints = one.joints
    set_pose(response.wafer, one.wafer)
    set_pose(response.blade, one.blade)
    set_pose(response.platform, one.platform)
    response.position_error = one.position_error
    response.angle_error = one.angle_error
    response.naive_rods = one.naive_rods
    response.naive_joints = one.naive_joints
    e = one.naive_wafer_error
    set_vector(response.naive_wafer_error_vector, e)
    response.naive_wafer_error = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    response.naive_wafer_angle_error = one.naive_wafer_angle_error
    _platform_fields(response, one.gpr)
    return response

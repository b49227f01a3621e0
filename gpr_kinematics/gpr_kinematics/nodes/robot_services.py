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

import numpy as np

from ..core.config import MODELS
from ..errors import InputError, brief
from ..inputs.validation import finite_number, finite_vector
from ..robot import Stations, robot_forward, solve_stations
from ..robot.description import Arm, RobotDescription
from ..robot.transforms import PoseBatch
from .conversions import point_array, pose_msg, vector_msg

#: The name the refusals of the station service give the requested station (``station request: out of reach``).
REQUEST_NAME = 'request'


class RobotModels:
    """The node's robot under each virtual-joint model a request names (one description per model, kept, so a
    model's per-configuration caches survive between requests)."""

    def __init__(self) -> None:
        self._cache: dict[tuple[int, str], RobotDescription] = {}

    def get(self, robot: RobotDescription, model: str) -> RobotDescription:
        """``robot`` under ``model`` (empty: its own; a name exactly as sent); InputError for a model that does not
        exist."""
        if not model or model == robot.config.model:
            return robot
        if model not in MODELS:
            raise InputError(f'model = {brief(model)} is invalid; allowed: {", ".join(MODELS)}, or empty for the '
                             "node's model")
        key = (id(robot.config), model)
        if key not in self._cache:
            if len(self._cache) > 16:  # a configuration changed at run time: forget the old ones
                self._cache.clear()
            self._cache[key] = dataclasses.replace(robot, config=robot.config.replace(model=model))
        return self._cache[key]


def _arm(robot: RobotDescription, name: str) -> Arm:
    """The arm ``name`` (empty: the first); InputError naming the arms there are."""
    if not name:
        return robot.arms[0]
    for a in robot.arms:
        if a.name == name:
            return a
    raise InputError(f'arm = {brief(name)} is invalid; allowed: {", ".join(robot.arm_names)} (the arms of robot '
                     f'{robot.name})')


def _joints(values: Any, arm: Arm, field: str) -> np.ndarray:
    """The arm's joint values [rad]: as many as it has, finite (InputError naming the joint otherwise)."""
    n = len(arm.joints)
    if len(values) != n:
        raise InputError(f'{field}: {len(values)} values given; arm {arm.name} has {n} joints '
                         f'({", ".join(arm.joint_names)}) [rad]')
    out = np.asarray(values, dtype=float)
    for name, v in zip(arm.joint_names, out.tolist(), strict=True):
        if not math.isfinite(v):
            raise InputError(f'{field}: {name} = {v} is not a finite number; allowed: radians within its limits')
    return out


def _pose(poses: PoseBatch) -> Any:
    return pose_msg(poses.position[0], poses.quaternion[0])


def _platform_fields(response: Any, gpr: Any) -> None:
    response.tilt = float(gpr.tilt[0])
    response.tilt_azimuth = float(gpr.tilt_azimuth[0])
    response.twist = float(gpr.twist[0])
    response.centre_shift = vector_msg(gpr.centre_shift[0])


def fill_robot_forward(robot: RobotDescription, request: Any, response: Any) -> Any:
    """A RobotForwardKinematics response for ``request`` (module docstring)."""
    arm = _arm(robot, request.arm)
    rods = finite_vector(request.rods, 'rods', 3)
    joints = _joints(request.joints, arm, 'joints')
    fk = robot_forward(robot, rods[None, :], joints[None, :], arm.name)
    response.world_frame = robot.world_frame
    response.arm = arm.name
    response.joint_names = list(arm.joint_names)
    response.wafer, response.blade, response.platform = _pose(fk.wafer), _pose(fk.blade), _pose(fk.platform)
    response.naive_wafer, response.naive_platform = _pose(fk.naive_wafer), _pose(fk.naive_platform)
    response.naive_wafer_error = vector_msg(fk.naive_wafer_error[0])
    response.naive_wafer_error_norm = float(fk.naive_wafer_error_norm[0])
    response.naive_wafer_angle_error = float(fk.naive_wafer_angle_error[0])
    _platform_fields(response, fk.gpr)
    return response


def request_stations(robot: RobotDescription, request: Any, arm: Arm) -> Stations:
    """The station of a StationInverseKinematics request, checked field by field."""
    position = point_array(request.position, 'position')
    angles = {k: finite_number(getattr(request, k), k) for k in ('tilt', 'azimuth', 'heading')}
    free = bool(request.heading_free)
    if free and len(arm.joints) > 2:
        raise InputError(f'heading_free: arm {arm.name} has {len(arm.joints)} joints and needs the blade heading; '
                         'allowed: heading_free only for a 2-joint arm')
    return Stations.of(position[None, :], angles['tilt'], angles['azimuth'], None if free else angles['heading'],
                       names=(REQUEST_NAME,))


def fill_station_inverse(robot: RobotDescription, request: Any, response: Any) -> Any:
    """A StationInverseKinematics response for ``request`` (module docstring)."""
    arm = _arm(robot, request.arm)
    stations = request_stations(robot, request, arm)
    branch = request.branch or None
    value = finite_number(request.redundancy_value, 'redundancy_value') if request.use_redundancy_value else None
    sol = solve_stations(robot, stations, arm.name, branch=branch, redundancy_value=value)
    fk = sol.forward
    response.world_frame = robot.world_frame
    response.arm = arm.name
    response.branch = sol.branch[0]
    response.rods = sol.rods[0]
    response.joint_names = list(arm.joint_names)
    response.joints = sol.joints[0].tolist()
    response.wafer, response.blade, response.platform = _pose(fk.wafer), _pose(fk.blade), _pose(fk.platform)
    response.position_error = float(sol.position_error[0])
    response.angle_error = float(sol.angle_error[0])
    response.naive_rods = sol.naive_rods[0]
    response.naive_joints = sol.naive_joints[0].tolist()
    response.naive_wafer_error_vector = vector_msg(sol.naive_wafer_error[0])
    response.naive_wafer_error = float(sol.naive_wafer_error_norm[0])
    response.naive_wafer_angle_error = float(sol.naive_wafer_angle_error[0])
    _platform_fields(response, fk.gpr)
    return response

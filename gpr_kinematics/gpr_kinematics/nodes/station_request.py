"""The station of a ``StationInverseKinematics`` request, checked field by field without ROS (the request read by
attribute: ``position.x``, ``tilt``, ...): the batch path's stations (:func:`request_stations`) and the one-station
float path where the request is within what it takes (:func:`one_station_request`)."""
from __future__ import annotations

import math
from typing import Any

from ..errors import InputError
from ..inputs.validation import MAX_COORDINATE, WORLD_BOUND, beyond_turn, finite_vector, within_turn
from ..robot import Stations
from ..robot.description import BRANCHES, Arm, RobotDescription
from ..robot.fields import check_world_position
from ..robot.inverse import held_refusal
from ..robot.one_station import StationFloats, station_floats
from ..robot.planar_arm import branch_sign

#: The name the refusals of the station service give the requested station (``station request: out of reach``).
REQUEST_NAME = 'request'


def request_stations(robot: RobotDescription, request: Any, arm: Arm) -> Stations:
    """The station of a StationInverseKinematics request, checked field by field."""
    p = request.position
    position = finite_vector((p.x, p.y, p.z), 'position', 3)
    check_world_position(position.tolist(), 'position', '; as millimetres it would be {mm} m: millimetres given as '
                         'metres? (the service takes metres)', InputError)   # as a station file's and gpr robot ik's
    free = bool(request.heading_free)
    angles = {'tilt': within_turn(request.tilt, 'tilt'), 'azimuth': within_turn(request.azimuth, 'azimuth'),
              'heading': 0.0 if free else within_turn(request.heading, 'heading')}
    if free and len(arm.joints) > 2:
        raise InputError(f'heading_free: arm {arm.name} has {len(arm.joints)} joints and needs the blade heading; '
                         'allowed: heading_free only for a 2-joint arm')
    return Stations.of(position[None, :], angles['tilt'], angles['azimuth'], None if free else angles['heading'],
                       names=(REQUEST_NAME,))


def one_station_request(robot: RobotDescription, request: Any, arm: Arm, branch: str, value: float | None
                        ) -> StationFloats | None:
    """The float path of one station where the request is within what it takes (every number finite and within
    +-MAX_COORDINATE, the position within the world's bound, the tilt, azimuth, heading and held value within a turn, a
    known branch, a held value only for a ``fixed_joint`` arm and within its joint's limits), else ``None``."""
    p = request.position
    numbers = (p.x, p.y, p.z, request.tilt, request.azimuth, request.heading, 0.0 if value is None else value)
    if not all(math.isfinite(v) and abs(v) <= MAX_COORDINATE for v in numbers) or branch not in BRANCHES:
        return None
    if any(beyond_turn(v) for v in (request.tilt, request.azimuth, request.heading)) or beyond_turn(numbers[-1]):
        return None  # the batch path names which
    if max(abs(p.x), abs(p.y), abs(p.z)) > WORLD_BOUND:
        return None  # beyond the world: the batch path refuses it (check_world_position)
    if value is not None:   # a held value for a fixed_joint arm within its joint's limits as given, else the batch's
        if arm.redundancy is None or arm.redundancy.rule != 'fixed_joint':
            return None
        if held_refusal(arm.joints[arm.redundancy.joint], value, '{}'):
            return None
    free = bool(request.heading_free)
    if free and len(arm.joints) > 2:
        return None
    return station_floats(robot, arm, (p.x, p.y, p.z), request.tilt, request.azimuth, request.heading, free,
                          branch_sign(branch), value)

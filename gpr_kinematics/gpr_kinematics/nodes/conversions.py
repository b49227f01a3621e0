"""Conversions between ROS messages and the numpy core (SI units: metres, radians; REP 103).

Quaternions are (x, y, z, w) both in geometry_msgs and in the core. Incoming messages are checked here
(finite numbers, unit quaternions) and a bad field raises :class:`~gpr_kinematics.errors.InputError` naming
the field, its value and what is allowed; the core checks the machine's limits (stroke, tilt).
"""
from __future__ import annotations

import array
import functools
import importlib
import math
import re
from collections.abc import Sequence
from typing import Any, TypeAlias

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseStamped, Quaternion, Transform, Vector3
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from gpr_interfaces.msg import PlatformState, RobotState

from ..bags.errors import BagError
from ..core.messages import MessageTypes, fill_fields, forward_fields
from ..core.rotations import matrix_from_quaternion, tilt_from_matrix
from ..errors import InputError, brief
from ..inputs.validation import finite_vector, unit_quaternion

#: A vector of numbers given to a message builder: a sequence or a numpy array (SI units).
Vector: TypeAlias = Sequence[float] | np.ndarray


def point_array(p: Point | Vector3, name: str) -> np.ndarray:
    """(x, y, z) of a Point or Vector3 [m], checked finite."""
    return finite_vector((p.x, p.y, p.z), name, 3)


def quaternion_array(q: Quaternion, name: str) -> np.ndarray:
    """(x, y, z, w) of a Quaternion, checked finite and of unit norm (within 1e-6), normalised."""
    return unit_quaternion((q.x, q.y, q.z, q.w), name)


def pose_arrays(pose: Pose, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Position [m] and unit quaternion (x, y, z, w) of a Pose, checked."""
    return point_array(pose.position, f'{name}.position'), quaternion_array(pose.orientation,
                                                                             f'{name}.orientation')


def tilt_of_quaternion(quat: np.ndarray) -> tuple[float, float, float]:
    """(tilt >= 0, tilt azimuth in (-pi, pi], twist) [rad] of a unit quaternion.

    ``R = tilt_rotation(tilt, azimuth) @ Rz(twist)`` (geometry.tilt_from_matrix).
    """
    tilt, az, twist = tilt_from_matrix(matrix_from_quaternion(quat))
    return float(tilt), float(az), float(twist)


def _set_vector(msg: Any, values: Vector) -> Any:
    msg.x, msg.y, msg.z = (float(v) for v in values)
    return msg


def point_msg(values: Vector) -> Point:
    return _set_vector(Point(), values)


def vector_msg(values: Vector) -> Vector3:
    return _set_vector(Vector3(), values)


def quaternion_msg(values: Vector) -> Quaternion:
    x, y, z, w = (float(v) for v in values)
    return Quaternion(x=x, y=y, z=z, w=w)


def pose_msg(position: Vector, quaternion: Vector) -> Pose:
    """Pose from a position [m] and a quaternion (x, y, z, w)."""
    return Pose(position=point_msg(position), orientation=quaternion_msg(quaternion))


def transform_msg(translation: Vector, quaternion: Vector) -> Transform:
    """Transform from a translation [m] and a quaternion (x, y, z, w)."""
    return Transform(translation=vector_msg(translation), rotation=quaternion_msg(quaternion))


#: rclpy's classes of the messages :mod:`gpr_kinematics.core.messages` builds.
ROS_TYPES = MessageTypes(Time=Time, Header=Header, Point=Point, Quaternion=Quaternion, Vector3=Vector3, Pose=Pose,
                         PoseStamped=PoseStamped, JointState=JointState, PlatformState=PlatformState,
                         float_sequence=lambda values: array.array('d', values), RobotState=RobotState)


def fill_forward(msg: Any, fk: Any) -> Any:
    """Copy a core ``ForwardResult`` into a ForwardKinematics response (the fields of
    :data:`gpr_kinematics.core.messages.STATE_FROM_RESULT` but ``q``, which the request carries)."""
    fields = forward_fields(ROS_TYPES, fk)
    del fields['q']
    return fill_fields(msg, fields)


def non_negative_finite(value: float, name: str) -> float:
    v = float(value)
    if not math.isfinite(v) or v < 0.0:
        raise InputError(f'{name} = {value!r} is invalid; allowed: a finite number >= 0')
    return v


#: The form of a ROS 2 message type name (``package/msg/Type``).
_MESSAGE_TYPE = re.compile(r'[a-z][a-z0-9_]*/msg/[A-Z][A-Za-z0-9]*')


@functools.cache
def message_class(msgtype: str) -> Any:
    """The rclpy message class of ``pkg/msg/Type`` (or ``pkg/Type``); :class:`BagError` when it cannot be imported."""
    from ..bags.typestore import normalize_type  # (rosbags: imported by the nodes that handle bags only)

    full = normalize_type(msgtype)
    # a bag's type string is data: only the form of a ROS message type is ever imported
    if _MESSAGE_TYPE.fullmatch(full) is None:
        raise BagError(f'type {brief(msgtype)} is not a ROS message type; allowed: package/msg/Type')
    pkg, kind, name = full.split('/')
    try:
        return getattr(importlib.import_module(f'{pkg}.{kind}'), name)
    except (ImportError, AttributeError) as exc:
        raise BagError(f'type {msgtype!r} cannot be imported in this ROS environment ({exc})') from None


def make_message(msgtype: str, **fields: Any) -> Any:
    """An rclpy message of ``pkg/msg/Type`` with ``fields`` (the others at their defaults): the ``make`` factory
    of the ROS-free message builders (:func:`gpr_kinematics.robot.markers.marker_array`)."""
    return message_class(msgtype)(**fields)

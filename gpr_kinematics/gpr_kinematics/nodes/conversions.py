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
import operator
import re
from collections.abc import Callable, Sequence
from typing import Any, TypeAlias

import numpy as np
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import Point, Pose, PoseStamped, Quaternion, Transform, Vector3
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from gpr_interfaces.msg import PlatformState, RobotState

from ..bags.errors import BagError
from ..core import ForwardResult
from ..core.floats import FloatPose, Quat, Vec3, quaternion_of
from ..core.messages import NS_PER_S, STATE_FROM_RESULT, MessageTypes, duration_parts
from ..core.rotations import matrix_from_quaternion, tilt_from_matrix
from ..errors import InputError, brief
from ..inputs.validation import QUATERNION_NORM_TOLERANCE, finite_vector, unit_quaternion
from ..robot.goal import Goal, check_point_count

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


def _path(name: str) -> tuple[str, ...]:
    return tuple(name.split('.'))


#: The response fields of :data:`~gpr_kinematics.core.messages.STATE_FROM_RESULT` but ``q`` (the request carries it),
#: as attribute paths, with the result's attribute.
_FORWARD_PATHS = tuple((_path(field), attr) for field, attr in STATE_FROM_RESULT if field != 'q')


def fill_forward(msg: Any, fk: ForwardResult) -> Any:
    """Copy a core ``ForwardResult`` into a ForwardKinematics response in place (the fields of
    :data:`gpr_kinematics.core.messages.STATE_FROM_RESULT` but ``q``, which the request carries): vectors into the
    response's own Point, Quaternion and Vector3, no message built."""
    for path, attr in _FORWARD_PATHS:
        value = getattr(fk, attr)
        parent = msg
        for name in path[:-1]:
            parent = getattr(parent, name)
        if isinstance(value, np.ndarray):
            values = value.tolist()
            target = getattr(parent, path[-1])
            if isinstance(target, (Point, Vector3)):
                target.x, target.y, target.z = values
            elif isinstance(target, Quaternion):
                target.x, target.y, target.z, target.w = values
            else:
                setattr(parent, path[-1], values)
        else:
            setattr(parent, path[-1], list(value) if isinstance(value, tuple) else value)
    return msg


def floats_of(values: Any, name: str, size: int) -> list[float]:
    """``size`` finite floats of a message's array field (:func:`~gpr_kinematics.inputs.validation.finite_vector`'s
    refusal, naming the field, where they are not)."""
    if len(values) == size:
        out = [float(v) for v in values]
        if all(map(math.isfinite, out)):
            return out
    finite_vector(values, name, size)
    raise AssertionError('finite_vector accepted what was refused')  # pragma: no cover - it raises


def point_floats(p: Point | Vector3, name: str) -> Vec3:
    """(x, y, z) of a Point or Vector3 [m] as floats, checked finite (:func:`point_array`'s refusal otherwise)."""
    x, y, z = p.x, p.y, p.z
    if math.isfinite(x) and math.isfinite(y) and math.isfinite(z):
        return x, y, z
    point_array(p, name)
    raise AssertionError('point_array accepted what was refused')  # pragma: no cover - it raises


def quaternion_floats(q: Quaternion, name: str) -> Quat:
    """(x, y, z, w) of a Quaternion, checked finite and of unit norm, normalised, as floats
    (:func:`quaternion_array`'s refusal otherwise)."""
    x, y, z, w = q.x, q.y, q.z, q.w
    if math.isfinite(x) and math.isfinite(y) and math.isfinite(z) and math.isfinite(w):
        norm = math.sqrt(x * x + y * y + z * z + w * w)
        if abs(norm - 1.0) <= QUATERNION_NORM_TOLERANCE:
            return x / norm, y / norm, z / norm, w / norm
    quaternion_array(q, name)
    raise AssertionError('quaternion_array accepted what was refused')  # pragma: no cover - it raises


def set_vector(msg: Point | Vector3, v: Vec3) -> None:
    """Set a Point's or Vector3's x, y, z in place."""
    msg.x, msg.y, msg.z = v


def set_pose(msg: Pose, pose: FloatPose) -> None:
    """Set a Pose in place from a position [m] and a rotation matrix (its quaternion, w >= 0)."""
    msg.position.x, msg.position.y, msg.position.z = pose[0]
    o = msg.orientation
    o.x, o.y, o.z, o.w = quaternion_of(pose[1])


#: The numbers a message class holds: attribute paths of its float fields and of its float arrays, in field order
#: (False: an array), or None where it holds messages in arrays (then every value is walked).
NumberPaths = tuple[tuple[str, bool], ...] | None


_NUMBER_PATHS: dict[type, NumberPaths] = {}


def _number_paths(cls: type) -> NumberPaths:
    if cls in _NUMBER_PATHS:
        return _NUMBER_PATHS[cls]
    out: list[tuple[str, bool]] = []

    def walk(msg: Any, prefix: str) -> bool:
        for name, kind in msg.get_fields_and_field_types().items():
            value = getattr(msg, name)
            if hasattr(value, 'get_fields_and_field_types'):
                if not walk(value, f'{prefix}{name}.'):
                    return False
            elif kind in ('double', 'float'):
                out.append((prefix + name, True))
            elif kind.startswith(('sequence<double', 'sequence<float', 'double[', 'float[')):
                out.append((prefix + name, False))
            elif '/' in kind:  # an array of messages
                return False
        return True

    found = _NUMBER_PATHS[cls] = tuple(out) if walk(cls(), '') else None
    return found


@functools.cache
def _getter(paths: tuple[str, ...]) -> Callable[[Any], Any]:
    get = operator.attrgetter(*paths)
    return (lambda msg: (get(msg),)) if len(paths) == 1 else get


def first_non_finite(msg: Any) -> str | None:
    """Path and value of the first non-finite number in a message (nested messages and arrays included), or
    None: a response never reports success with an infinite or NaN number in it. The float fields of a message
    class are found once and read with one getter (:func:`non_finite_field` walks every field)."""
    paths = _number_paths(type(msg))
    if paths is None:
        return non_finite_field(msg)
    values = _getter(tuple(p for p, _ in paths))(msg)
    ok = True
    for (_, scalar), value in zip(paths, values, strict=True):
        if not (math.isfinite(value) if scalar else all(map(math.isfinite, value))):
            ok = False
            break
    return None if ok else non_finite_field(msg)


def non_finite_field(msg: Any, prefix: str = '') -> str | None:
    """:func:`first_non_finite` by walking every field of the message (nested messages and arrays included)."""
    for name in msg.get_fields_and_field_types():
        value = getattr(msg, name)
        path = f'{prefix}{name}'
        if hasattr(value, 'get_fields_and_field_types'):
            found = non_finite_field(value, path + '.')
            if found:
                return found
        elif isinstance(value, float):
            if not math.isfinite(value):
                return f'{path} = {value!r}'
        elif isinstance(value, (list, tuple, np.ndarray, array.array)) and len(value) and \
                isinstance(value[0], (float, np.floating)):
            bad = [i for i, v in enumerate(value) if not math.isfinite(float(v))]
            if bad:
                return f'{path}[{bad[0]}] = {float(value[bad[0]])!r}'
    return None


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


def duration_msg(t: float) -> Duration:
    """``builtin_interfaces/Duration`` of ``t`` [s]."""
    sec, nanosec = duration_parts(t)
    return Duration(sec=sec, nanosec=nanosec)


def _seconds(d: Any) -> float:
    return float(d.sec) + float(d.nanosec) / NS_PER_S


def goal_of_request(req: Any) -> Goal:
    """The :class:`~gpr_kinematics.robot.goal.Goal` of a ``control_msgs/action/FollowJointTrajectory`` request (its
    point count checked before its points are read), for :func:`~gpr_kinematics.robot.goal.plan_goal`."""
    points = req.trajectory.points
    check_point_count(len(points))
    stamp = req.trajectory.header.stamp
    return Goal(list(req.trajectory.joint_names), [_seconds(pt.time_from_start) for pt in points],
                [pt.positions for pt in points], [pt.velocities for pt in points],
                [pt.accelerations for pt in points], any(len(pt.effort) for pt in points),
                bool(req.multi_dof_trajectory.joint_names or req.multi_dof_trajectory.points),
                bool(req.component_path_tolerance or req.component_goal_tolerance),
                [(t.name, t.position, t.velocity, t.acceleration) for t in req.path_tolerance],
                [(t.name, t.position, t.velocity, t.acceleration) for t in req.goal_tolerance],
                _seconds(req.goal_time_tolerance), stamp.sec * NS_PER_S + stamp.nanosec)

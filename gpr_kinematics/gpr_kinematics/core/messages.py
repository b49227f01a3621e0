"""The one mapping from the core's forward-kinematics result to the package's ROS messages, without ROS.

``gpr_interfaces/msg/PlatformState`` and the ``gpr/forward_kinematics`` response carry the fields of a
:class:`~gpr_kinematics.core.ForwardResult`; :data:`STATE_FROM_RESULT` names which message field holds
which result attribute, and :func:`forward_fields` builds those fields. The trajectory node (rclpy message
classes), the kinematics node (the service response) and the synthetic bag writer (``rosbags`` classes) all
build their messages here, and ``gpr verify`` compares recorded messages with a fresh forward solution through
the same table, so a field added to the result reaches every message and every check in one place.

The message classes come in a :class:`MessageTypes` namespace: rclpy's generated classes and the ``rosbags``
typestore's dataclasses both take their fields as keyword arguments, which is all this module uses; they differ
only in the container of an unbounded ``float64[]`` (rclpy: ``array.array('d')``, rosbags: a numpy array), which
the namespace's ``float_sequence`` makes.
Units are SI (metres, radians), quaternions (x, y, z, w), as in the core.
"""
from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ..inputs.safe_yaml import YamlValue, dump

if TYPE_CHECKING:
    from .config import GprConfig
    from .forward import ForwardResult

#: A tf frame name, as a node's frame parameters and every frame it names (prefixed) must be: letters, digits, _ - and
#: ., parts joined by single slashes, not starting with one (tf2 refuses a leading slash), at most
#: :data:`FRAME_NAME_MOST` characters.
FRAME_NAME_RULE = re.compile(r'[A-Za-z0-9_.\-]+(/[A-Za-z0-9_.\-]+)*')
FRAME_NAME_MOST = 100
#: What a node's ``frame_prefix`` may be (the parameter, and the prefix ``trajectory_node`` records with each stream):
#: empty, or letters, digits and ``_`` in parts each followed by a single ``/`` (the last may end without one), so
#: that a prefixed frame is a tf frame name (:func:`frame_prefix_refusal`: ``r1//gpr_base`` was not).
FRAME_PREFIX_RULE = re.compile(r'(?:[A-Za-z0-9_]+/)*[A-Za-z0-9_]*')
FRAME_PREFIX_WORDS = 'empty, or letters, digits, _ and single / between parts, not starting with /'
#: The frames the nodes name by default, prefixed: a prefix is checked against them where a node's own are unknown
#: (a launch file's argument).
DEFAULT_FRAMES = ('world', 'gpr_base', 'gpr_platform', 'gpr_platform_nominal')


def is_frame_name(value: object) -> bool:
    """Whether ``value`` is a tf frame name (:data:`FRAME_NAME_RULE`, at most :data:`FRAME_NAME_MOST` characters)."""
    return isinstance(value, str) and len(value) <= FRAME_NAME_MOST and FRAME_NAME_RULE.fullmatch(value) is not None


def frame_prefix_refusal(prefix: object, frames: Sequence[str] | None = None) -> str | None:
    """What ``prefix`` may be if ``prefix + f`` is not a tf frame name (:func:`is_frame_name`) for each frame name
    ``f`` of ``frames`` (:data:`DEFAULT_FRAMES` by default; none known: at least one character's), else ``None``:
    the one rule of every node's, launch file's and bag record's frame prefix."""
    names = DEFAULT_FRAMES if frames is None else frames
    longest = max(names, key=len, default='')
    most = FRAME_NAME_MOST - max(len(longest), 1)
    if isinstance(prefix, str) and len(prefix) <= most and FRAME_PREFIX_RULE.fullmatch(prefix):
        return None
    before = f'{longest}: ' if longest else ''
    return (f'{FRAME_PREFIX_WORDS}, at most {most} characters ({before}a prefixed frame is a tf frame name of at most '
            f'{FRAME_NAME_MOST}), e.g. r1/')


#: A ROS message or one of its field values, of a class generated from a ``.msg`` file (rclpy's, or the ``rosbags``
#: typestore's): its type is made at run time, so this module, which takes either, cannot name it.
RosMessage = Any
#: A position or a quaternion as the core gives it (an array) or a caller writes it.
Vector = Sequence[float] | NDArray[np.float64]
#: A generated message class: its fields as keyword arguments -> the message.
MessageClass = Callable[..., RosMessage]

#: ``(message field, ForwardResult attribute)`` of every PlatformState / ForwardKinematics response field that is
#: a copy of the forward solution. ``pose`` and ``nominal_pose`` combine two attributes each (position and
#: quaternion); the rest are one to one.
STATE_FROM_RESULT: tuple[tuple[str, str], ...] = (
    ('q', 'q'),
    ('model', 'model'),
    ('pose.position', 'position'),
    ('pose.orientation', 'quaternion'),
    ('nominal_pose.position', 'nominal_position'),
    ('nominal_pose.orientation', 'nominal_quaternion'),
    ('centre_shift', 'centre_shift'),
    ('virtual_joints', 'virtual_joints'),
    ('virtual_joint_names', 'virtual_joint_names'),
    ('side_lengths', 'side_lengths'),
    ('tilt', 'tilt'),
    ('tilt_azimuth', 'tilt_azimuth'),
    ('twist', 'twist'),
    ('joint_displacement', 'joint_displacement'),
    ('within_budget', 'within_budget'),
    ('iterations', 'iterations'),
    ('residual', 'residual'),
)

#: The names of the three actuated joints (rods) in ``sensor_msgs/JointState`` and the robot model.
ROD_JOINT_NAMES: tuple[str, str, str] = ('rod_1', 'rod_2', 'rod_3')


class Topic:
    """The node suite's topics, relative to a node's namespace (a bag records them absolute: ``'/' + name``)."""

    PLATFORM_STATE = 'gpr/platform_state'    #: gpr_interfaces/PlatformState, one per sample of a stream
    PLATFORM_POSE = 'gpr/platform_pose'      #: geometry_msgs/PoseStamped, the platform with its centre shift
    NOMINAL_POSE = 'gpr/nominal_pose'        #: geometry_msgs/PoseStamped, the platform without it
    JOINT_STATES = 'joint_states'            #: sensor_msgs/JointState, the rods (and a robot's arm joints)
    VIRTUAL_JOINTS = 'gpr/virtual_joints'    #: sensor_msgs/JointState, the virtual joints by the model's names
    MARKERS = 'gpr/markers'                  #: visualization_msgs/MarkerArray of a stream
    ROBOT_STATE = 'gpr/robot_state'          #: gpr_interfaces/RobotState, the whole robot of a robot program
    WAFER_POSE = 'gpr/wafer_pose'            #: geometry_msgs/PoseStamped, the wafer in the world frame
    GEOMETRY = 'gpr/geometry'                #: std_msgs/String (latched), the geometry's YAML
    ROBOT = 'gpr/robot'                      #: std_msgs/String (latched), the robot description's YAML
    PROGRAM = 'gpr/program'                  #: std_msgs/String (latched), what a stream was asked to do
    CELL = 'gpr/cell'                        #: visualization_msgs/MarkerArray (latched), the process cell
    ROBOT_DESCRIPTION = 'robot_description'  #: std_msgs/String (latched), the URDF


class Service:
    """The kinematics node's services and the trajectory node's action, relative to a node's namespace."""

    FORWARD_KINEMATICS = 'gpr/forward_kinematics'
    INVERSE_KINEMATICS = 'gpr/inverse_kinematics'
    COMPENSATE = 'gpr/compensate'
    ANALYZE_MOBILITY = 'gpr/analyze_mobility'
    ROBOT_FORWARD_KINEMATICS = 'gpr/robot_forward_kinematics'
    STATION_INVERSE_KINEMATICS = 'gpr/station_inverse_kinematics'
    RUN_PROGRAM = 'gpr/run_program'          #: the action gpr_interfaces/RunProgram


#: The FollowJointTrajectory action of a ros2_control joint_trajectory_controller named ``joint_trajectory_controller``
#: (relative: in the robot's namespace).
FOLLOW_JOINT_TRAJECTORY = 'joint_trajectory_controller/follow_joint_trajectory'
#: Nanoseconds per second: a ``builtin_interfaces`` Time or Duration is ``sec`` and ``nanosec`` in ``[0, NS_PER_S)``.
NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class MessageTypes:
    """Constructors of the messages this module builds (rclpy classes or ``rosbags`` typestore classes)."""

    Time: MessageClass
    Header: MessageClass
    Point: MessageClass
    Quaternion: MessageClass
    Vector3: MessageClass
    Pose: MessageClass
    PoseStamped: MessageClass
    JointState: MessageClass
    PlatformState: MessageClass
    #: A ``float64[]`` field's value of float64 values (rclpy: ``array.array('d')``, rosbags: a numpy array).
    float_sequence: Callable[[NDArray[np.float64]], RosMessage]
    #: ``gpr_interfaces/RobotState`` (the robot streams of :mod:`gpr_kinematics.robot.stream`).
    RobotState: MessageClass


class Described(Protocol):
    """What has a description file form: ``to_dict()``, the YAML mapping its loader reads back equal."""

    def to_dict(self) -> Mapping[str, YamlValue]: ...


#: The range of a ``builtin_interfaces`` Time's or Duration's ``sec`` (``int32``): Time ends in January 2038.
SEC_MIN, SEC_MAX = -2**31, 2**31 - 1


def time_parts(ns: int) -> tuple[int, int]:
    """``(sec, nanosec)`` of a ``builtin_interfaces`` Time or Duration of ``ns`` integer nanoseconds;
    :class:`InputError` for a ``sec`` beyond ``int32`` (a stamp after 2038-01-19T03:14:07Z wrapped negative).

    >>> time_parts(1_500_000_000), time_parts(-1)
    ((1, 500000000), (-1, 999999999))
    """
    ns = int(ns)
    sec = ns // NS_PER_S
    if not SEC_MIN <= sec <= SEC_MAX:
        raise InputError(f'a time of {ns} ns: sec = {sec} does not fit builtin_interfaces\' int32 sec; allowed: '
                         f'{SEC_MIN} to {SEC_MAX} s (up to 2038-01-19T03:14:07Z)')
    return sec, ns % NS_PER_S


def duration_parts(seconds: float) -> tuple[int, int]:
    """``(sec, nanosec)`` of a duration of ``seconds`` [s], rounded to the nearest nanosecond.

    >>> duration_parts(0.005), duration_parts(2.0000000004)
    ((0, 5000000), (2, 0))
    """
    return time_parts(round(seconds * NS_PER_S))


def header(types: MessageTypes, stamp_ns: int, frame_id: str) -> RosMessage:
    """``std_msgs/Header`` with a stamp given in integer nanoseconds."""
    sec, nanosec = time_parts(stamp_ns)
    return types.Header(stamp=types.Time(sec=sec, nanosec=nanosec), frame_id=str(frame_id))


def pose(types: MessageTypes, position: Vector, quaternion: Vector) -> RosMessage:
    """``geometry_msgs/Pose`` from a position [m] and a quaternion (x, y, z, w)."""
    x, y, z = (float(v) for v in position)
    qx, qy, qz, qw = (float(v) for v in quaternion)
    return types.Pose(position=types.Point(x=x, y=y, z=z),
                      orientation=types.Quaternion(x=qx, y=qy, z=qz, w=qw))


def _floats(values: ArrayLike) -> NDArray[np.float64]:
    return np.array(values, dtype=np.float64).reshape(-1)


def forward_fields(types: MessageTypes, fk: ForwardResult) -> dict[str, RosMessage]:
    """The message fields of :data:`STATE_FROM_RESULT` built from one forward result ``fk``
    (a :class:`~gpr_kinematics.core.ForwardResult`, or a row of a ``ForwardBatch``), as keyword
    arguments of ``PlatformState`` (or attributes of a ``ForwardKinematics`` response)."""
    cs = [float(v) for v in fk.centre_shift]
    return {
        'q': _floats(fk.q),
        'model': str(fk.model),
        'pose': pose(types, fk.position, fk.quaternion),
        'nominal_pose': pose(types, fk.nominal_position, fk.nominal_quaternion),
        'centre_shift': types.Vector3(x=cs[0], y=cs[1], z=cs[2]),
        'virtual_joints': types.float_sequence(_floats(fk.virtual_joints)),
        'virtual_joint_names': [str(n) for n in fk.virtual_joint_names],
        'side_lengths': _floats(fk.side_lengths),
        'tilt': float(fk.tilt),
        'tilt_azimuth': float(fk.tilt_azimuth),
        'twist': float(fk.twist),
        'joint_displacement': _floats(fk.joint_displacement),
        'within_budget': bool(fk.within_budget),
        'iterations': int(fk.iterations),
        'residual': float(fk.residual),
    }


def platform_state(types: MessageTypes, fk: ForwardResult, *, stamp_ns: int, frame_id: str, sample: int,
                   commanded_tilt: float, commanded_azimuth: float) -> RosMessage:
    """``gpr_interfaces/PlatformState`` of one sample of a stream: the forward result ``fk`` (its pose in
    ``frame_id``), the running sample counter and the commanded (program) tilt and azimuth [rad]."""
    return types.PlatformState(header=header(types, stamp_ns, frame_id), sample=int(sample),
                               commanded_tilt=float(commanded_tilt), commanded_azimuth=float(commanded_azimuth),
                               **forward_fields(types, fk))


def stream_messages(types: MessageTypes, fk: ForwardResult, *, stamp_ns: int, frame_id: str, sample: int,
                    commanded_tilt: float, commanded_azimuth: float) -> dict[str, RosMessage]:
    """Every message the trajectory node publishes for one sample, by topic (relative names):
    ``gpr/platform_state``, ``gpr/platform_pose`` and ``gpr/nominal_pose`` (PoseStamped),
    ``joint_states`` (the physical joints only: the rods ``rod_1..3`` [m], as ``robot_state_publisher``
    expects) and ``gpr/virtual_joints`` (the virtual joints by their core names [m, rad])."""
    st = platform_state(types, fk, stamp_ns=stamp_ns, frame_id=frame_id, sample=sample,
                        commanded_tilt=commanded_tilt, commanded_azimuth=commanded_azimuth)
    empty = types.float_sequence(np.zeros(0))
    return {
        Topic.PLATFORM_STATE: st,
        Topic.PLATFORM_POSE: types.PoseStamped(header=st.header, pose=st.pose),
        Topic.NOMINAL_POSE: types.PoseStamped(header=st.header, pose=st.nominal_pose),
        Topic.JOINT_STATES: types.JointState(header=st.header, name=list(ROD_JOINT_NAMES),
                                         position=types.float_sequence(_floats(fk.q)), velocity=empty, effort=empty),
        Topic.VIRTUAL_JOINTS: types.JointState(header=st.header, name=list(st.virtual_joint_names),
                                               position=types.float_sequence(_floats(fk.virtual_joints)),
                                               velocity=empty, effort=empty),
    }


def geometry_text(config: GprConfig) -> str:
    """``data`` of ``gpr/geometry`` (std_msgs/String, latched): the YAML of a ``GprConfig.to_dict()``, which
    ``GprConfig.from_mapping`` reads back equal; a recording names the geometry and model that produced it."""
    text = dump(config.to_dict(), default_flow_style=False, sort_keys=False)
    return text


def robot_text(robot: Described) -> str:
    """``data`` of ``gpr/robot`` (std_msgs/String, latched): the YAML of a ``RobotDescription.to_dict()`` (the
    robot description file format, its geometry inline), which ``parse_robot`` reads back equal."""
    text = dump(robot.to_dict(), default_flow_style=False, sort_keys=False)
    return text

"""The ``rosbags`` typestore of the suite: ROS 2 Jazzy's standard types plus ``gpr_interfaces``.

``Stores.ROS2_JAZZY`` carries the standard messages (std_msgs, geometry_msgs, sensor_msgs,
visualization_msgs, ...); the custom messages are registered from the ``.msg`` texts of ``gpr_interfaces``
(the repository's ``gpr_interfaces/msg`` or an installed ``share/gpr_interfaces/msg``). The type hashes
(RIHS01) that ``rosbags`` computes equal the ones rosidl generates, so ``ros2 bag`` accepts the bags.
"""
from __future__ import annotations

import functools
import os
from collections.abc import Collection
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from ..core.messages import MessageTypes, Topic
from .errors import BagError

INTERFACES_PACKAGE = 'gpr_interfaces'

#: The geometry and model that produced a stream: ``std_msgs/String`` whose ``data`` is the YAML of the producing
#: node's ``GprConfig.to_dict()``, published once at start (reliable, transient local, depth 1).
GEOMETRY_TOPIC = '/' + Topic.GEOMETRY
#: The virtual joints of each sample (``sensor_msgs/JointState``, names of the model), apart from the physical joints.
VIRTUAL_JOINTS_TOPIC = '/' + Topic.VIRTUAL_JOINTS

#: The robot description that produced a stream: ``std_msgs/String`` whose ``data`` is the YAML of the producing
#: node's ``RobotDescription.to_dict()`` (the description file format), published once at start, latched.
ROBOT_TOPIC = '/' + Topic.ROBOT
#: The whole robot at each sample of a robot program (``gpr_interfaces/RobotState``: arm joints, the arm in use,
#: its wafer) and the wafer pose alone (``geometry_msgs/PoseStamped``), in the robot's world frame.
ROBOT_STATE_TOPIC = '/' + Topic.ROBOT_STATE
WAFER_POSE_TOPIC = '/' + Topic.WAFER_POSE
#: What each stream was asked to do (``std_msgs/String``: the YAML of a :class:`~.program_record.Record`), latched,
#: published with the first sample of every stream.
PROGRAM_TOPIC = '/' + Topic.PROGRAM

#: The robot's joint states (``sensor_msgs/JointState``: the rods, and the arm joints in a robot program), on the
#: topic ``robot_state_publisher`` reads; bags recorded before carry them on ``/gpr/joint_states`` (still verified).
JOINT_STATES_TOPIC = '/' + Topic.JOINT_STATES
LEGACY_JOINT_STATES_TOPIC = '/gpr/joint_states'

#: The platform stream's state, poses and markers, recorded.
PLATFORM_STATE_TOPIC = '/' + Topic.PLATFORM_STATE
PLATFORM_POSE_TOPIC = '/' + Topic.PLATFORM_POSE
NOMINAL_POSE_TOPIC = '/' + Topic.NOMINAL_POSE
MARKERS_TOPIC = '/' + Topic.MARKERS

#: Topics the trajectory node publishes and their types: the recorder's default topic list.
GPR_TOPICS: dict[str, str] = {
    PLATFORM_STATE_TOPIC: 'gpr_interfaces/msg/PlatformState',
    PLATFORM_POSE_TOPIC: 'geometry_msgs/msg/PoseStamped',
    NOMINAL_POSE_TOPIC: 'geometry_msgs/msg/PoseStamped',
    JOINT_STATES_TOPIC: 'sensor_msgs/msg/JointState',
    VIRTUAL_JOINTS_TOPIC: 'sensor_msgs/msg/JointState',
    MARKERS_TOPIC: 'visualization_msgs/msg/MarkerArray',
    ROBOT_STATE_TOPIC: 'gpr_interfaces/msg/RobotState',
    WAFER_POSE_TOPIC: 'geometry_msgs/msg/PoseStamped',
    GEOMETRY_TOPIC: 'std_msgs/msg/String',
    ROBOT_TOPIC: 'std_msgs/msg/String',
    PROGRAM_TOPIC: 'std_msgs/msg/String',
}

#: Every topic ``gpr verify`` knows the type of: the suite's and those of earlier recordings.
KNOWN_TOPICS: dict[str, str] = {**GPR_TOPICS, LEGACY_JOINT_STATES_TOPIC: 'sensor_msgs/msg/JointState'}

def suite_topic(namespace: str, name: str) -> str:
    """``name`` (with or without the leading slash) as a suite recorded in ``namespace`` (``''``, ``/r1``) names it:
    always ``namespace + name`` (``/r1/gpr/platform_pose`` for ``gpr/platform_pose``, ``/gpr/gpr/platform_pose`` in
    ``/gpr``); ``name`` is the suite's own name, never one already in the namespace."""
    absolute = name if name.startswith('/') else '/' + name
    return namespace + absolute


def suite_namespaces(name: str) -> list[str]:
    """The namespaces a topic named like a suite topic (:data:`KNOWN_TOPICS`) may be recorded in, the legacy reading
    first: ``name`` without each suite name it ends with, the longest first (``/r1/gpr/joint_states``: ``/r1``'s
    legacy ``gpr/joint_states``, then ``/r1/gpr``'s ``joint_states``); none for another topic."""
    return [name[:-len(k)] for k in sorted(KNOWN_TOPICS, key=len, reverse=True) if name.endswith(k)]


def topics_namespace(topics: Collection[str]) -> str:
    """The namespace every suite topic among ``topics`` is in (:func:`suite_namespaces`), the legacy reading where
    two are (a lone ``/r1/gpr/joint_states``: ``/r1``, as :func:`legacy_joint_states` reads it); ``''`` when none
    is shared (``/r1/gpr/platform_pose`` beside ``/r1/arm_controller/joint_states``) or there is no suite topic."""
    common: list[str] | None = None
    for name in topics:
        found = suite_namespaces(name)
        if found:
            common = found if common is None else [ns for ns in common if ns in found]
    return common[0] if common else ''


def legacy_joint_states(topics: Collection[str], namespace: str) -> str | None:
    """``/gpr/joint_states`` as a bag of ``topics`` recorded in ``namespace`` names it, when the bag's joint states
    are there only (recorded before they moved to ``/joint_states``, which a recorder's default topics and a state
    publisher read); None when it has no such topic or ``/joint_states`` beside it (the joint states are there).
    :func:`topics_namespace` takes the topic as its namespace's legacy one too."""
    legacy = suite_topic(namespace, LEGACY_JOINT_STATES_TOPIC)
    return legacy if legacy in topics and suite_topic(namespace, JOINT_STATES_TOPIC) not in topics else None


#: The topics of every sample of a platform stream (a sweep, a platform program), in publishing order.
PLATFORM_STREAM_TOPICS = (PLATFORM_STATE_TOPIC, PLATFORM_POSE_TOPIC, NOMINAL_POSE_TOPIC, JOINT_STATES_TOPIC,
                          VIRTUAL_JOINTS_TOPIC, MARKERS_TOPIC)

#: Topics published once and latched (transient local): their recorded QoS says so, for ``ros2 bag play``.
LATCHED_TOPICS = frozenset({GEOMETRY_TOPIC, ROBOT_TOPIC, PROGRAM_TOPIC})

PLATFORM_STATE = 'gpr_interfaces/msg/PlatformState'
ROBOT_STATE = 'gpr_interfaces/msg/RobotState'


def interface_msg_dirs() -> list[Path]:
    """Folders that may hold the ``gpr_interfaces`` ``.msg`` files: the source tree, then the ament prefixes."""
    here = Path(__file__).resolve().parent
    dirs = [here.parents[2] / INTERFACES_PACKAGE / 'msg']  # <repository>/gpr_interfaces in a source checkout
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix:
            dirs.append(Path(prefix) / 'share' / INTERFACES_PACKAGE / 'msg')
    return dirs


@functools.lru_cache(maxsize=1)
def typestore() -> Typestore:
    """ROS 2 Jazzy standard types + every ``gpr_interfaces/msg/*.msg`` (cached)."""
    store = get_typestore(Stores.ROS2_JAZZY)
    for folder in interface_msg_dirs():
        files = sorted(folder.glob('*.msg')) if folder.is_dir() else []
        if files:
            types = {}
            for f in files:
                types.update(get_types_from_msg(f.read_text(), f'{INTERFACES_PACKAGE}/msg/{f.stem}'))
            store.register(types)
            return store
    raise BagError('cannot find the gpr_interfaces message definitions (.msg); looked in '
                   + ', '.join(str(d) for d in interface_msg_dirs()))


#: Kinds of a field definition in :func:`fields_of` (``rosbags``' ``Nodetype``).
BASE, NAME, ARRAY, SEQUENCE = 1, 2, 3, 4


def fields_of(msgtype: str) -> list[tuple[str, tuple[int, Any]]]:
    """``(name, (kind, detail))`` of each field of a known type: ``kind`` :data:`BASE` (detail
    ``(primitive, bound)``), :data:`NAME` (detail the type name), :data:`ARRAY` or :data:`SEQUENCE` (detail
    ``((kind, detail), count or bound)``)."""
    fields: Any = typestore().fielddefs[msgtype][1]
    return list(fields)


def normalize_type(msgtype: str) -> str:
    """``pkg/Type`` or ``pkg/msg/Type`` -> ``pkg/msg/Type``."""
    parts = msgtype.strip().split('/')
    if len(parts) == 2:
        return f'{parts[0]}/msg/{parts[1]}'
    return '/'.join(parts)


def check_known(msgtype: str, topic: str = '') -> str:
    """Return the normalised type name or raise :class:`BagError` naming the topic when it is unknown."""
    name = normalize_type(msgtype)
    if name not in typestore().fielddefs:
        where = f'topic {topic!r} has ' if topic else ''
        raise BagError(f'{where}type {msgtype!r}, which is not in the typestore (ROS 2 Jazzy standard types '
                       f'and {INTERFACES_PACKAGE}); allowed: a type of those packages, e.g. '
                       f'geometry_msgs/msg/PoseStamped')
    return name


@functools.cache
def definition(msgtype: str) -> tuple[str, str]:
    """(message definition text as rosbag2 stores it, RIHS01 type hash) of a known type."""
    store = typestore()
    msgdef, _ = store.generate_msgdef(msgtype, ros_version=2)
    return msgdef, store.hash_rihs01(msgtype)


@functools.lru_cache(maxsize=1)
def message_types() -> MessageTypes:
    """The typestore's classes of the messages :mod:`gpr_kinematics.core.messages` builds (bags written without ROS)."""
    T = typestore().types
    return MessageTypes(
        Time=T['builtin_interfaces/msg/Time'], Header=T['std_msgs/msg/Header'], Point=T['geometry_msgs/msg/Point'],
        Quaternion=T['geometry_msgs/msg/Quaternion'], Vector3=T['geometry_msgs/msg/Vector3'],
        Pose=T['geometry_msgs/msg/Pose'], PoseStamped=T['geometry_msgs/msg/PoseStamped'],
        JointState=T['sensor_msgs/msg/JointState'], PlatformState=T[PLATFORM_STATE],
        float_sequence=lambda values: np.asarray(values, dtype=np.float64), RobotState=T[ROBOT_STATE])

"""Which check of ``gpr verify`` covers each numeric field of each message the node suite records, and which fields
are not checked, with why: every numeric field is one or the other (a test holds the tables to the message
definitions, so a field added to a message must be placed), and the result names the unchecked fields of the topics
in the bag (:func:`unchecked_fields`).

Fields are named by their path, ``[]`` for every element of a sequence of messages (``markers[].scale.x``); a rule
covers a field when it is the field or a prefix of it (``pose`` covers ``pose.position.x``). Bools count as
numeric; strings are compared where they matter (names, frames, models) and are not listed here.
"""
from __future__ import annotations

import functools

from .typestore import ARRAY, BASE, GPR_TOPICS, NAME, SEQUENCE, fields_of

_STAMP = ('header.stamp', 'stamp and frame matched to a PlatformState (topic.*), ordered (stream.stamps)')

#: Message type -> (field prefix, the checks that cover it).
CHECKED: dict[str, tuple[tuple[str, str], ...]] = {
    'gpr_interfaces/msg/PlatformState': (
        ('header.stamp', 'stream.stamps'), ('sample', 'stream.counter'),
        ('q', 'state.forward, state.limits, stream.jump, stream.program'),
        ('pose', 'state.pose_position, state.pose_orientation'),
        ('nominal_pose', 'state.nominal_position, state.nominal_orientation'),
        ('centre_shift', 'state.centre_shift'), ('virtual_joints', 'state.virtual_joints'),
        ('side_lengths', 'state.side_lengths'), ('tilt', 'state.tilt'), ('tilt_azimuth', 'state.tilt'),
        ('twist', 'state.tilt'), ('commanded_tilt', 'state.commanded, stream.program'),
        ('commanded_azimuth', 'state.commanded, stream.program'), ('joint_displacement', 'state.joint_displacement'),
        ('within_budget', 'state.within_budget'), ('iterations', 'state.iterations'), ('residual', 'state.residual'),
    ),
    'geometry_msgs/msg/PoseStamped': (_STAMP, ('pose', 'topic.platform_pose, topic.nominal_pose, topic.wafer_pose')),
    'sensor_msgs/msg/JointState': (_STAMP, ('position', 'topic.joint_states, topic.joint_states_recomputed, '
                                                        'topic.virtual_joints'),
                                   ('velocity', 'topic.joint_states (empty)'),
                                   ('effort', 'topic.joint_states (empty)')),
    'visualization_msgs/msg/MarkerArray': (
        ('markers[].header.stamp', 'topic.markers'), ('markers[].id', 'topic.markers'),
        ('markers[].type', 'topic.markers'), ('markers[].action', 'topic.markers'),
        ('markers[].pose', 'topic.markers'), ('markers[].points', 'topic.markers')),
    'gpr_interfaces/msg/RobotState': (
        ('header.stamp', 'robot.structure'), ('sample', 'robot.structure'),
        ('joints', 'robot.*, robot.joint_limits, stream.program'), ('wafer', 'robot.wafer_position, '
                                                                             'robot.wafer_orientation'),
        ('blade', 'robot.blade'), ('naive_wafer_error', 'robot.naive_wafer_error'), ('waypoint', 'stream.program')),
    'std_msgs/msg/String': (),
}

_DISPLAY = 'how RViz draws the marker, not kinematics'
#: Message type -> (field prefix, why it is not checked).
UNCHECKED: dict[str, tuple[tuple[str, str], ...]] = {
    'visualization_msgs/msg/MarkerArray': (
        ('markers[].scale', _DISPLAY), ('markers[].color', _DISPLAY), ('markers[].lifetime', _DISPLAY),
        ('markers[].frame_locked', _DISPLAY), ('markers[].colors', _DISPLAY), ('markers[].texture', _DISPLAY),
        ('markers[].uv_coordinates', _DISPLAY), ('markers[].mesh_file', _DISPLAY),
        ('markers[].mesh_use_embedded_materials', _DISPLAY)),
}


def numeric_fields(msgtype: str, prefix: str = '') -> list[str]:
    """The paths of every numeric (or bool) field of ``msgtype``, nested messages and sequences expanded."""
    out: list[str] = []
    for name, (kind, detail) in fields_of(msgtype):
        path = prefix + name
        if kind in (ARRAY, SEQUENCE):
            (kind, detail), _ = detail
            if kind == NAME:
                out += numeric_fields(detail, path + '[].')
                continue
        if kind == BASE and detail[0] not in ('string', 'wstring'):
            out.append(path)
        elif kind == NAME:
            out += numeric_fields(detail, path + '.')
    return out


def _covers(prefix: str, path: str) -> bool:
    return path == prefix or path.startswith(prefix + '.') or path.startswith(prefix + '[')


def rule_of(msgtype: str, path: str) -> tuple[str, str] | None:
    """``('checked', checks)`` or ``('unchecked', why)`` for a field, None when the tables do not place it."""
    for kind, table in (('checked', CHECKED), ('unchecked', UNCHECKED)):
        for prefix, text in table.get(msgtype, ()):
            if _covers(prefix, path):
                return kind, text
    return None


@functools.cache
def unchecked_of(msgtype: str) -> tuple[str, ...]:
    """The unchecked fields of ``msgtype``, grouped by why (``markers[].scale, markers[].color, ... (how RViz draws
    the marker, not kinematics)``), and any field the tables do not place, as unchecked."""
    reasons: dict[str, list[str]] = {}
    for prefix, why in UNCHECKED.get(msgtype, ()):
        reasons.setdefault(why, []).append(prefix)
    loose = [path for path in numeric_fields(msgtype) if rule_of(msgtype, path) is None]
    if loose:
        reasons.setdefault('not placed in the tables of bags/coverage.py', []).extend(loose)
    return tuple(f'{", ".join(paths)} ({why})' for why, paths in reasons.items())


def unchecked_fields(topics: dict[str, str]) -> dict[str, list[str]]:
    """For the suite's topics of a bag (topic -> type, :data:`.typestore.GPR_TOPICS` ones only), the numeric fields
    no check covers, with why."""
    return {t: list(unchecked_of(ty)) for t, ty in sorted(topics.items())
            if GPR_TOPICS.get(t) == ty and unchecked_of(ty)}

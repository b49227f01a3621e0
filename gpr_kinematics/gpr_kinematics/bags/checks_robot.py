"""The whole robot in a recording: which robot description, and the ``robot.*`` checks of its wafer poses.

``trajectory_node`` publishes its robot description once at start on :data:`.typestore.ROBOT_TOPIC`
(``std_msgs/String``, latched: the YAML of ``RobotDescription.to_dict()``) and, for every sample of a whole-robot
program, a ``gpr_interfaces/RobotState`` on :data:`.typestore.ROBOT_STATE_TOPIC` (every arm's joints, the arm in
use, its wafer and blade in the world, the naive model's wafer error) and the wafer alone on
:data:`.typestore.WAFER_POSE_TOPIC`. ``gpr verify`` uses the recorded description by default (``--robot FILE``
overrides it), with the geometry the platform is verified against (:mod:`.recorded_geometry`), and checks:

- ``topic.robot``: the recorded descriptions are one text, YAML (with the package's parser and its limits) that
  :func:`gpr_kinematics.robot.description.parse_robot` accepts, its geometry inline (never a file name), whose
  ``gpr`` section equals the recorded geometry (under ``--config`` it is replaced by the given one instead);
- ``robot.structure``: every RobotState has a PlatformState of its stamp with the same sample counter, the robot's
  world frame, an arm of the robot and every arm's joints by the robot's names, and every PlatformState of a robot
  program (by the records on ``gpr/program``; every one in a recording without them) has its RobotState but at the
  ends of the recording (:mod:`.checks_topics`: before the first RobotState, and the last sample's), also where
  the topic is recorded without a message;
- ``robot.wafer_position``, ``robot.wafer_orientation``, ``robot.blade``, ``robot.naive_wafer_error``: the stored
  poses and error against :func:`gpr_kinematics.robot.robot_forward` of the PlatformState's rods and the RobotState's
  joints of its arm (one batch per arm) [m, rad];
- ``robot.joint_limits``: every arm joint within its range (by how much it is beyond, 1e-9 rad of slack);
- ``topic.wafer_pose``: a PoseStamped with the stamp and frame of every RobotState and the same pose (1e-12); those
  without a RobotState (at the ends, or none recorded): :mod:`.checks_wafer`.

Robot states without a robot description (none recorded, none given) fail ``topic.robot``: the wafer cannot be
verified without knowing the arm. A recording without robot states (a sweep, a platform program) skips the rest.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.config import GprConfig
from ..errors import GprError, brief
from ..inputs import safe_yaml
from ..robot import robot_forward
from ..robot.arm_chain import LIMIT_SLACK
from ..robot.description import RobotDescription, parse_robot
from ..robot.transforms import PoseBatch
from .cdr import Columns
from .checks_topics import match
from .columns import matrix, quaternion_angle, stamp_ns, vec
from .ends import cut_detail, extra, missing, unordered, without_messages
from .reader import Bag, TopicData
from .results import Check, bag_check, bool_check, skipped, value_check
from .tolerances import Tolerances
from .typestore import GPR_TOPICS, ROBOT_STATE_TOPIC, ROBOT_TOPIC, WAFER_POSE_TOPIC

#: Largest robot description message read.
MAX_ROBOT_BYTES = 1 << 20


@dataclass
class RobotChoice:
    """The robot description verified against (None: none known), where it came from, the ``topic.robot`` check
    and notes for the result."""

    robot: RobotDescription | None
    source: str
    check: Check
    notes: list[str] = field(default_factory=list)


def _parse(text: str, config: GprConfig, compare: bool, topic: str) -> RobotDescription:
    """The recorded description (bounded, its geometry inline: a recording never names a file to read), with
    ``config`` as its geometry; ``compare``: its own ``gpr`` section must equal ``config``; ``topic``: where it was
    recorded."""
    if len(text.encode('utf-8', errors='replace')) > MAX_ROBOT_BYTES:
        raise GprError(f'{len(text)} characters; allowed: at most {MAX_ROBOT_BYTES} bytes')
    data = safe_yaml.load_text(text, f'{topic} (recorded robot description)')
    gpr = data.get('gpr') if isinstance(data, dict) else None
    if isinstance(gpr, dict) and gpr.get('config') is not None:
        raise GprError(f'its gpr section names a geometry file ({brief(gpr["config"], 40)}); allowed: the geometry '
                       'inline (config: null), as the recorder writes it')
    if not compare:
        return parse_robot(data, topic, geometry=config)
    recorded = parse_robot(data, topic)
    if recorded.config != config:
        raise GprError('its gpr section differs from the geometry verified against')
    return recorded


def _topic(bag: Bag, name: str) -> TopicData | None:
    t = bag.topic(name)
    return t if t is not None and len(t) > 0 else None


def choose_robot(bag: Bag, given: RobotDescription | None, given_source: str, config: GprConfig,
                 config_given: bool) -> RobotChoice:
    """The robot to verify the wafer poses against: ``given`` (computing with ``config``), else the recorded one.

    ``config_given``: the geometry came from ``--config``, not from the bag; the recorded description's own ``gpr``
    section is then not compared with it (the description is read with ``config`` instead)."""
    t = _topic(bag, ROBOT_TOPIC)
    states = _topic(bag, ROBOT_STATE_TOPIC) is not None
    if given is not None:
        return RobotChoice(given, 'given', skipped('topic.robot', ROBOT_TOPIC, '', f'{given_source} given'),
                           [f'robot description: {given_source} (given){_other_than_recorded(t, given, config)}'])
    if t is None:
        if states:
            return RobotChoice(None, '', bag_check('topic.robot', ROBOT_TOPIC, [(ROBOT_TOPIC, 1.0, 0.0, (
                'robot states recorded but no robot description: give the robot with --robot FILE'))], 0, ''))
        return RobotChoice(None, '', skipped('topic.robot', ROBOT_TOPIC, '', 'no robot description recorded'),
                           ['no robot topics (a platform recording): no robot checks'])
    if t.msgtype != GPR_TOPICS[ROBOT_TOPIC]:
        return RobotChoice(None, '', bag_check('topic.robot', ROBOT_TOPIC, [
            (ROBOT_TOPIC, 1.0, 0.0, f'type {t.msgtype}, not a std_msgs/msg/String')], len(t), ''))
    texts = list(dict.fromkeys(str(v) for v in t.columns()['data']))
    if len(texts) > 1:
        return RobotChoice(None, '', bag_check('topic.robot', ROBOT_TOPIC, [
            (ROBOT_TOPIC, float(len(texts)), 1.0, 'the robot description messages differ')], len(t), '', 1.0))
    try:
        robot = _parse(texts[0], config, not config_given, t.name)
    except GprError as exc:
        return RobotChoice(None, '', bag_check('topic.robot', ROBOT_TOPIC, [
            (ROBOT_TOPIC, 1.0, 0.0, f'not a usable robot description: {exc}')], len(t), ''))
    note = (f'verified the wafer poses against the robot {robot.name} recorded on {t.name}' if states else
            f'robot {robot.name} recorded on {t.name}; no robot states (a platform stream, or a recording of '
            'fewer topics): no wafer pose verified')
    return RobotChoice(robot, 'recorded', bag_check('topic.robot', ROBOT_TOPIC, [], len(t), ''), [note])


def _other_than_recorded(t: TopicData | None, given: RobotDescription, config: GprConfig) -> str:
    """Words for a ``--robot`` other than the robot the bag recorded (by name; '' where it is that robot, or none
    readable was recorded): verified against robot 2's file, a recording of robot 1 failed at its wafer poses without
    saying the robot differed."""
    if t is None or t.msgtype != GPR_TOPICS[ROBOT_TOPIC]:
        return ''
    try:
        recorded = _parse(str(t.columns()['data'][0]), config, False, t.name)
    except (GprError, IndexError):
        return ''
    return '' if recorded.name == given.name else (f': robot {given.name}, but the bag recorded robot {recorded.name} '
                                                   f'on {t.name}')


@dataclass(frozen=True)
class RobotRows:
    """Per PlatformState row, the arm joints of the RobotState of its stamp (its names and values; none where the
    state has no RobotState): what ``joint_states`` must carry after the rods. Taken from the recorded robot
    states alone, so the joint states are checked against them whether or not a robot description is known."""

    rows: dict[int, tuple[tuple[str, ...], NDArray[np.float64]]]
    #: Per state row, the waypoint its RobotState says it holds (-1: moving), that waypoint's name (its station) and
    #: the arm in use.
    waypoints: dict[int, int] = field(default_factory=dict)
    stations: dict[int, str] = field(default_factory=dict)
    arms: dict[int, str] = field(default_factory=dict)

    def joints(self, r: int) -> tuple[tuple[str, ...], NDArray[np.float64]] | None:
        return self.rows.get(r)

    def names(self) -> tuple[str, ...] | None:
        """The arm joints the robot states name (the first's; None without one): what a state without its RobotState
        (a late recorder's first ones, a cut's last) must carry after the rods."""
        return next(iter(self.rows.values()))[0] if self.rows else None


def arm_joint_names(robot: RobotDescription) -> tuple[str, ...]:
    """Every arm's joints, in the description's order: what a robot recording's ``joint_states`` carry after the
    rods and its RobotStates' ``joint_names``."""
    return tuple(n for a in robot.arms for n in a.joint_names)


def in_world(frames: Any, state_frames: Any, robot: RobotDescription, prefix: str | None = None
             ) -> NDArray[np.bool_]:
    """Per message, whether its frame is the robot's world frame with the node's frame prefix. With the ``prefix``
    the records name (:func:`~.program_record.recorded_prefix`): exactly ``prefix + world``, beside a PlatformState
    frame ``prefix + base`` (``r1_world`` beside ``r1_gpr_base``; ``world`` beside ``r1/gpr_base`` fails). Without
    (an older node's records): some prefix ``P`` with the frame ``P + world`` and the PlatformState's frame ``P +
    base`` for a non-empty base (``world`` beside a ``base_frame`` of ``gpr/base``; ``evil/world`` beside
    ``gpr_base`` fails; what the prefix was is not in such a bag: ``world`` beside ``r1/gpr_base`` passes, as a
    ``base_frame`` of ``r1/gpr_base`` would publish it)."""
    world = robot.world_frame

    def prefixed(f: str, base: str) -> bool:
        p = f[:len(f) - len(world)] if prefix is None else prefix
        return f == p + world and base.startswith(p) and len(base) > len(p)

    return np.array([prefixed(str(f), str(base)) for f, base in zip(frames, state_frames, strict=True)], dtype=bool)


def _structure(rc: Columns, j: NDArray[np.int64], rows: NDArray[np.int64], c: Columns,
               robot: RobotDescription, prefix: str | None) -> NDArray[np.bool_]:
    """Per matched RobotState ``j`` (of the state ``rows``): frame (the world frame, with the node's frame prefix:
    ``r1/world`` beside a PlatformState in ``r1/gpr_base``, ``world`` beside ``gpr_base``), sample counter, arm and
    joint names right."""
    names = arm_joint_names(robot)
    frame_ok = in_world(rc['header.frame_id'][j], np.asarray(c['header.frame_id'])[rows], robot, prefix)
    sample_ok = np.asarray(rc['sample'])[j] == np.asarray(c['sample'])[rows]
    arm_ok = np.isin(rc['arm'][j], robot.arm_names)
    names_ok = np.array([tuple(n) == names for n in rc['joint_names'][j]], dtype=bool)
    count = np.asarray(rc['joints#'])[j] == len(names) if 'joints#' in rc else np.zeros(len(j), dtype=bool)
    out: NDArray[np.bool_] = frame_ok & sample_ok & arm_ok & names_ok & count
    return out


def _pose(rc: Columns, name: str, j: NDArray[np.int64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    return vec(rc, f'{name}.position')[j], vec(rc, f'{name}.orientation', 'xyzw')[j]


def _pose_error(stored: tuple[NDArray[np.float64], NDArray[np.float64]], pose: PoseBatch
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Position error [m] and rotation angle + quaternion norm defect [rad] of stored against computed poses."""
    p, q = stored
    angle = quaternion_angle(pose.quaternion, q) + np.abs(np.linalg.norm(q, axis=1) - 1.0)
    return np.max(np.abs(p - pose.position), axis=1), angle


def _no_robot_states(bag: Bag, stamps: NDArray[np.int64], samples: NDArray[np.int64],
                     due: NDArray[np.bool_] | None) -> list[Check]:
    """No RobotState in the bag: skipped, unless the topic is recorded (listed) without a message and records say
    robot program samples were streamed (``due``): those fail ``robot.structure``, but the first and the last state
    (:func:`.checks_topics.missing`)."""
    why = 'no robot states in the bag'
    poses = _wafer_poses_without_states(bag, due)
    t = bag.topic(ROBOT_STATE_TOPIC)
    absent = missing(stamps, np.zeros(0, np.int64))
    if due is not None:
        absent[~due] = 0.0
    if t is None or t.msgtype != GPR_TOPICS[ROBOT_STATE_TOPIC] or due is None or not np.any(absent > 0):
        return [skipped('robot.wafer_position', ROBOT_STATE_TOPIC, 'm', why), *poses]
    return [*poses, skipped('robot.wafer_position', ROBOT_STATE_TOPIC, 'm', f'{why} (their structure fails)'),
            bool_check('robot.structure', ROBOT_STATE_TOPIC, absent == 0, samples,
                       'the robot states topic is recorded without a message; a sample of a robot program '
                       '(gpr/program) without its RobotState (the first and the last state are not counted: a '
                       'recording started or cut in the middle of a sample)')]


def _wafer_poses_without_states(bag: Bag, due: NDArray[np.bool_] | None) -> list[Check]:
    """Messages on :data:`WAFER_POSE_TOPIC` in a bag without RobotStates: extra where the records say no sample is a
    robot program's (a platform stream publishes no wafer pose); elsewhere each is checked as one without its
    RobotState (:mod:`.checks_wafer`: against the stream recomputed from the record)."""
    t = bag.topic(WAFER_POSE_TOPIC)
    if t is None or not len(t) or due is None or due.any():
        return []
    return [bag_check('topic.wafer_pose', WAFER_POSE_TOPIC, [(WAFER_POSE_TOPIC, float(len(t)), 0.0, (
        f'{len(t)} wafer poses where the records (gpr/program) show no robot program: a platform stream '
        'publishes none'))], len(t), '')]


def beyond_limits(joints: NDArray[np.float64], names: tuple[str, ...], robot: RobotDescription) -> NDArray[np.float64]:
    """Per row of ``joints (N, J)`` [rad], the arm joints ``names``: by how much its farthest joint is beyond its range
    (1e-12 rad of slack, :data:`~gpr_kinematics.robot.arm_chain.LIMIT_SLACK`; 0 within; inf for a NaN or a name
    that is not one of the robot's joints): the rule of ``robot.joint_limits`` and of the arm joints on
    ``joint_states`` (:mod:`.checks_joints`)."""
    limits = {n: (lo, hi) for a in robot.arms for n, lo, hi in zip(a.joint_names, a.lower, a.upper, strict=True)}
    if not all(n in limits for n in names):
        return np.full(len(joints), np.inf)
    lower = np.array([limits[n][0] for n in names])
    upper = np.array([limits[n][1] for n in names])
    out = np.max(np.maximum(lower - LIMIT_SLACK - joints, joints - upper - LIMIT_SLACK).clip(0.0), axis=1,
                 initial=0.0)
    return np.where(np.isnan(out), np.inf, out)


def robot_checks(bag: Bag, c: Columns, samples: NDArray[np.int64], choice: RobotChoice, tol: Tolerances,
                 due: NDArray[np.bool_] | None = None, prefix: str | None = None
                 ) -> tuple[list[Check], RobotRows | None]:
    """The ``robot.*`` and ``topic.wafer_pose`` checks (module docstring) against the PlatformState columns ``c``,
    and the robot joints per state row for the ``joint_states`` check (None without robot states). ``due``: per
    state, whether it is a robot program's (:func:`~.checks_program.robot_program_states`; None: no records, all)."""
    stamps = stamp_ns(c)
    t = _topic(bag, ROBOT_STATE_TOPIC)
    if t is None or t.msgtype != GPR_TOPICS[ROBOT_STATE_TOPIC]:
        return _no_robot_states(bag, stamps, samples, due), None
    rc = t.columns()
    rstamps = stamp_ns(rc)
    idx = match(rstamps, np.zeros(len(rstamps), dtype=object), stamps, np.zeros(len(stamps), dtype=object))
    rows = np.flatnonzero(idx >= 0)
    j = idx[rows]
    pairs = list(zip(rows.tolist(), j.tolist(), strict=True))
    recorded = RobotRows({int(r): (tuple(rc['joint_names'][k]), np.asarray(rc['joints'][k], dtype=float))
                          for r, k in pairs},
                         {int(r): int(rc['waypoint'][k]) for r, k in pairs},
                         {int(r): str(rc['station'][k]) for r, k in pairs},
                         {int(r): str(rc['arm'][k]) for r, k in pairs})
    robot = choice.robot
    if robot is None:
        return [skipped('robot.wafer_position', ROBOT_STATE_TOPIC, 'm', 'no robot description (topic.robot)')], \
            recorded
    ok = _structure(rc, j, rows, c, robot, prefix)
    names = arm_joint_names(robot)
    joints = np.full((len(stamps), len(names)), np.nan)
    J = matrix(rc['joints'], len(names))[j]
    if J.shape[1] == len(names):   # (else no message has the robot's joints: ok is all False)
        joints[rows[ok]] = J[ok]
    q = matrix(c['q'], 3)
    absent = missing(stamps, rstamps)
    if due is not None:
        absent[~due] = 0.0
    e_pos, e_ang, e_blade, e_naive = (absent.copy() for _ in range(4))
    e_limit = np.zeros(len(stamps))
    structure = np.ones(len(stamps), dtype=bool)
    structure[rows] = ok
    structure[(absent > 0) & (idx < 0)] = False
    if due is not None:
        structure[rows[~due[rows]]] = False   # a platform stream publishes no RobotState
    arms = rc['arm'][j]
    # every arm's joints against their limits, the arms at rest included
    checked = rows[ok]
    e_limit[checked] = beyond_limits(joints[checked], names, robot)
    start = 0
    for a in robot.arms:
        cols = slice(start, start + len(a.joints))
        start += len(a.joints)
        sel = rows[ok & (arms == a.name)]
        Q, Ja = q[sel], joints[sel, cols]
        good = np.all(np.isfinite(Q), axis=1) & np.all(np.isfinite(Ja), axis=1)
        r = sel[good]
        e_pos[sel[~good]] = e_ang[sel[~good]] = e_blade[sel[~good]] = e_naive[sel[~good]] = np.inf
        if r.size == 0:
            continue
        try:
            fk = robot_forward(robot, q[r], joints[r, cols], a.name, check_limits=False)
        except GprError:
            e_pos[r] = e_ang[r] = e_blade[r] = e_naive[r] = np.inf
            continue
        k = idx[r]
        e_pos[r], e_ang[r] = _pose_error(_pose(rc, 'wafer', k), fk.wafer)
        bp, ba = _pose_error(_pose(rc, 'blade', k), fk.blade)
        e_blade[r] = np.maximum(bp, ba)
        e_naive[r] = np.max(np.abs(vec(rc, 'naive_wafer_error')[k] - fk.naive_wafer_error), axis=1)
    for e in (e_pos, e_ang, e_blade, e_naive):
        e[~structure] = np.inf
    inf_detail = 'inf = no RobotState of this stamp, or its frame, sample, arm or joints are wrong'
    checks = [
        bool_check('robot.structure', ROBOT_STATE_TOPIC, structure, samples,
                   f'RobotState missing, or not in {robot.world_frame}, of another sample, an arm not of robot '
                   f'{robot.name}, joints other than {", ".join(names)}, or at a sample of no robot program '
                   '(gpr/program: a platform stream publishes none)'
                   + cut_detail(stamps, rstamps, samples, np.where(idx < 0, absent, 0.0))),
        value_check('robot.wafer_position', ROBOT_STATE_TOPIC, e_pos, tol.position, 'm', samples, inf_detail),
        value_check('robot.wafer_orientation', ROBOT_STATE_TOPIC, e_ang, tol.angle, 'rad', samples, inf_detail),
        value_check('robot.blade', ROBOT_STATE_TOPIC, e_blade, max(tol.position, tol.angle), 'm|rad', samples,
                    inf_detail),
        value_check('robot.naive_wafer_error', ROBOT_STATE_TOPIC, e_naive, tol.position, 'm', samples, inf_detail),
        value_check('robot.joint_limits', ROBOT_STATE_TOPIC, e_limit, 0.0, 'rad', samples,
                    'beyond the joint range by this much'),
    ]
    checks += [x for x in [extra('robot.structure', ROBOT_STATE_TOPIC, rstamps, stamps, rows.size),
                           unordered('robot.structure', ROBOT_STATE_TOPIC, rstamps)] if x]
    checks += _wafer_pose_checks(bag, rc, np.asarray(rc['sample'], dtype=np.int64), tol.consistency,
                                 int(stamps.max()))
    return checks, recorded


def _wafer_pose_checks(bag: Bag, rc: Columns, samples: NDArray[np.int64], tol: float, end: int) -> list[Check]:
    """``gpr/wafer_pose``: a PoseStamped with the stamp and frame of every RobotState, the same pose (``end``: the
    stamp of the recording's last sample, the only one whose wafer pose a cut may lose)."""
    name = WAFER_POSE_TOPIC
    t = bag.topic(name)
    why = 'inf = no message with the stamp and frame of this RobotState'
    if t is None or t.msgtype != GPR_TOPICS[name]:
        return [skipped('topic.wafer_pose', name, 'm|rad', 'topic not in the bag', tol)]
    if len(t) == 0:
        return [without_messages('topic.wafer_pose', name, stamp_ns(rc), samples, tol, 'm|rad', why, end)]
    pc = t.columns()
    stamps, pstamps = stamp_ns(rc), stamp_ns(pc)
    idx = match(pstamps, pc['header.frame_id'], stamps, rc['header.frame_id'])
    ok = idx >= 0
    e = missing(stamps, pstamps, end)
    stored = np.concatenate([vec(pc, 'pose.position'), vec(pc, 'pose.orientation', 'xyzw')], axis=1)
    wafer = np.concatenate(_pose(rc, 'wafer', np.arange(len(stamps))), axis=1)
    e[ok] = np.max(np.abs(stored[idx[ok]] - wafer[ok]), axis=1)
    out = [value_check('topic.wafer_pose', name, e, tol, 'm|rad', samples,
                       why + cut_detail(stamps, pstamps, samples, e))]
    return out + [x for x in [extra('topic.wafer_pose', name, pstamps, stamps, int(ok.sum()), of_states=False),
                               unordered('topic.wafer_pose', name, pstamps)] if x]


def robot_summary(choice: RobotChoice) -> dict[str, Any]:
    """What the result says about the robot (JSON): its name, arms and where it came from."""
    if choice.robot is None:
        return {}
    return {'name': choice.robot.name, 'arms': list(choice.robot.arm_names), 'source': choice.source}

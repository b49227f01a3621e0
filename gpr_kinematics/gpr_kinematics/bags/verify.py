"""Offline verification of a recorded GPR stream against the current kinematics core (``gpr verify``).

:func:`verify_bag` reads the bag (:mod:`.reader`: every MCAP CRC checked, files hashed; a bag that cannot be
read raises :class:`~gpr_kinematics.bags.errors.BagError`), decodes every topic, chooses the geometry
(:mod:`.recorded_geometry`: the recorded one by default) and runs the families of checks, each in its module:

- ``bag.*`` (:mod:`.checks_bag`): types, type hashes, ``metadata.yaml`` against the files, the checksums;
- ``topic.geometry`` (:mod:`.recorded_geometry`): the recorded geometry is one usable configuration;
- ``state.*`` (:mod:`.checks_state`): every PlatformState against forward kinematics of its ``q``;
- ``stream.*`` (:mod:`.checks_stream`): counters, stamps, jumps at singular crossings;
- ``topic.*`` (:mod:`.checks_topics`): poses, joint states and markers against the state of the same stamp, the
  markers' sequence against the recorded ``markers_every``; ``topic.joint_states_recomputed``
  (:mod:`.checks_joints`): the arm joints of the joint states without their RobotState against the stream
  recomputed from the record (without one: the joint limits);
- ``topic.robot``, ``robot.*``, ``topic.wafer_pose`` (:mod:`.checks_robot`): a whole-robot recording's wafer poses
  against the robot's forward kinematics, with the recorded robot description (or a given one);
  ``topic.wafer_pose_recomputed`` (:mod:`.checks_wafer`): the wafer poses without their RobotState (at the ends of
  the recording, or none recorded) against the stream recomputed from the record;
- ``topic.program``, ``stream.program`` (:mod:`.checks_program`): every sample against its stream recomputed from the
  recorded record of what it was asked to do (``gpr/program``).

Every numeric field of the suite's messages is covered by one of these checks or named in the result as not checked,
with why (:mod:`.coverage`). Limits are SI units, in :class:`~.tolerances.Tolerances`. Together with the checksums
this makes a bag that differs from what was recorded fail: a changed byte of a storage file changes its SHA-256
(and, in MCAP, a CRC), a changed byte of ``metadata.yaml`` its digest; a bag whose checksums were recomputed after
an edit still has to pass every content check.
"""
from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path

import numpy as np

from ..core import resolve_config
from ..core.config import GprConfig
from ..core.machine import slope_gain
from ..errors import brief
from ..robot.description import RobotDescription
from .checks_bag import bag_checks
from .checks_joints import joint_state_checks
from .checks_program import marker_cadence, program_checks, read_records, robot_program_states
from .checks_robot import arm_joint_names, choose_robot, robot_checks, robot_summary
from .checks_state import frame_check, state_checks
from .checks_stream import singular_crossings, stream_checks
from .checks_topics import topic_checks
from .checks_wafer import wafer_pose_checks
from .columns import matrix
from .coverage import unchecked_fields
from .ends import cut_recording, stream_ends, whole_stream
from .errors import BagError
from .program_record import ROBOT_PROGRAM, Recomputed, recorded_prefix
from .reader import OPEN_SEGMENT_DIR, Bag, read_bag
from .recorded_geometry import choose
from .results import Check, Failure, VerifyResult, format_table
from .tolerances import Tolerances
from .typestore import (
    JOINT_STATES_TOPIC,
    KNOWN_TOPICS,
    LEGACY_JOINT_STATES_TOPIC,
    PLATFORM_STATE,
    ROBOT_STATE_TOPIC,
    suite_topic,
    typestore,
)
from .typestore import PLATFORM_STATE_TOPIC as STATE_TOPIC

__all__ = ['Tolerances', 'VerifyResult', 'format_table', 'verify_bag']

def _no_states(namespace: str) -> Check:
    why = f'no gpr_interfaces/msg/PlatformState messages on {suite_topic(namespace, STATE_TOPIC)}: nothing to verify'
    return Check('state.present', STATE_TOPIC, 1, 1.0, 0.0, 'messages', 1,
                 [Failure('state.present', STATE_TOPIC, None, 1.0, 0.0, why)])  # 1 missing > 0


def _as_recorded(namespace: str, checks: list[Check]) -> None:
    """Every check and failure names a suite topic as the bag has it, in its ``namespace`` (the checks look the
    topics up there; ``topic.platform_pose`` on ``/gpr/platform_pose`` was read from ``/r1/gpr/platform_pose``)."""
    for check in checks:
        check.topic = suite_topic(namespace, check.topic) if check.topic in KNOWN_TOPICS else check.topic
        for f in check.failures:
            f.topic = suite_topic(namespace, f.topic) if f.topic in KNOWN_TOPICS else f.topic


def _several_suites(suites: list[str]) -> Check:
    where = ', '.join(ns or '/' for ns in suites)
    why = (f'{len(suites)} node suites recorded ({where}: a gpr/platform_state in each): verify checks the one suite '
           'of a bag and cannot choose; nothing verified (record each suite in its own bag)')
    return Check('state.present', STATE_TOPIC, len(suites), float(len(suites)), 1.0, 'suites', 1,
                 [Failure('state.present', STATE_TOPIC, None, float(len(suites)), 1.0, why)])


def verify_bag(bag: Bag | str | Path, config: GprConfig | None = None, tolerances: Tolerances | None = None,
               config_source: str = 'the given configuration', allow_missing_checksums: bool = False,
               robot: RobotDescription | None = None, robot_source: str = 'the given robot description'
               ) -> VerifyResult:
    """Verify a bag (a path or an already read :class:`Bag`); see the module docstring.

    Args:
        config: the geometry to verify against instead of the recorded one (``config_source`` names it).
        robot: the robot description to verify the wafer poses against instead of the recorded one (it computes
            with the geometry verified against); ``robot_source`` names it.
        allow_missing_checksums: a bag without checksums (another recorder) skips ``bag.checksums``.

    Raises:
        BagError: the bag cannot be read, or a message does not decode.
    """
    t0 = time.perf_counter()
    for name, value, kind, allowed in (
            ('bag', bag, (Bag, str, os.PathLike), 'a bag folder or file path, or a Bag of read_bag'),
            ('config', config, (GprConfig, type(None)), 'a GprConfig (load_config) or None (the recorded one)'),
            ('tolerances', tolerances, (Tolerances, type(None)), 'Tolerances or None (the defaults)'),
            ('robot', robot, (RobotDescription, type(None)), 'a RobotDescription (load_robot) or None')):
        if not isinstance(value, kind):
            raise BagError(f'{name} = {brief(value)}; allowed: {allowed}')
    if not isinstance(bag, Bag):
        bag = read_bag(bag)
    t_read = time.perf_counter() - t0
    tol = Tolerances() if tolerances is None else tolerances
    # Recorded numbers may be anything (a corrupt q of 1e290): what overflows is a failed check, not a warning.
    # a recorder killed while it wrote (a segment left unfinished): the ends' rule of a cut recording (.ends)
    cut = any(not u.startswith(f'{OPEN_SEGMENT_DIR} (') for u in bag.unfinished)   # a segment's file, not a note
    with np.errstate(all='ignore'), cut_recording(cut):
        checks = bag_checks(bag, allow_missing_checksums)
        known = typestore().fielddefs
        for topic in bag.topics.values():
            if topic.msgtype in known:
                topic.columns()  # every recorded topic must decode (BagError otherwise)
        st = bag.topic(STATE_TOPIC)
        has_states = st is not None and len(st) > 0 and st.msgtype == PLATFORM_STATE
        c = st.columns() if st is not None and has_states else None
        q = matrix(c['q'], 3) if c is not None else np.zeros((0, 3))
        geo = choose(bag, config, config_source, q, resolve_config(None))
        checks.append(geo.check)
        given_robot = dataclasses.replace(robot, config=geo.config) if robot is not None else None
        arms = choose_robot(bag, given_robot, robot_source, geo.config, config_given=config is not None)
        checks.append(arms.check)
        series, crossings, ratio = None, 0, 0.0
        if len(bag.suites) > 1:
            checks.append(_several_suites(bag.suites))
        elif st is None or c is None:
            checks.append(_no_states(bag.namespace))
        else:
            samples = np.asarray(c['sample'], dtype=np.int64)
            cross = singular_crossings(np.asarray(c['commanded_tilt'], dtype=float), q,
                                       np.asarray(c['commanded_azimuth'], dtype=float))
            state = state_checks(c, samples, st.name, geo.config, tol, cross)
            stream = stream_checks(c, samples, st.name, state.series, slope_gain(geo.config), tol)
            recorded = read_records(bag)
            ends = stream_ends([(r.first_sample, r.samples, r.loop) for r in recorded[0]], samples)
            with whole_stream(*ends):   # no companion before or after a whole stream's states (.ends)
                due = robot_program_states(recorded[0], samples)
                robot_part, robot_rows = robot_checks(bag, c, samples, arms, tol, due, recorded_prefix(recorded[0]))
                # the rods alone in joint_states without robot states: only where they are not recorded at all (a
                # sweep's listed empty says it has none) and no record says the stream is not a robot program's
                fewer = bag.topic(ROBOT_STATE_TOPIC) is None and (
                    not recorded[0] or any(r.kind == ROBOT_PROGRAM for r in recorded[0]))
                robot_joints = arm_joint_names(arms.robot) if arms.robot is not None and fewer else None
                checks += [frame_check(c, samples, st.name, recorded_prefix(recorded[0]),
                                       arms.robot.world_frame if arms.robot is not None else None)]
                checks += state.checks + stream.checks + topic_checks(
                    bag, c, samples, state.series, geo.config, tol.consistency, robot_rows,
                    marker_cadence(recorded[0], samples), robot_joints, due) + robot_part
                streams = Recomputed(recorded[0], geo.config, arms.robot)   # each record's stream planned once
                checks += joint_state_checks(bag, c, samples, streams, robot_rows, robot_joints, due, tol)
                checks += wafer_pose_checks(bag, c, samples, streams, tol)
                checks += program_checks(bag, c, samples, streams, robot_rows, tol, recorded)
            series, crossings, ratio = state.series, stream.crossings, stream.crossing_ratio
    _as_recorded(bag.namespace, checks)
    notes = list(geo.notes) + arms.notes
    if bag.namespace:
        notes.append(f"the node suite's topics were recorded in the namespace {bag.namespace} (verified as such)")
    if bag.outside() and len(bag.suites) <= 1:
        notes.append(f"topics named like the node suite's outside its namespace {bag.namespace or '/'}, not verified: "
                     f'{", ".join(bag.outside())}')
    if bag.joint_states_topic() == JOINT_STATES_TOPIC and bag.topic(LEGACY_JOINT_STATES_TOPIC) is not None:
        ns = bag.namespace or ''
        notes.append(f'{ns}{LEGACY_JOINT_STATES_TOPIC} recorded beside {ns}{JOINT_STATES_TOPIC}: the legacy topic of '
                     'older recordings, not verified (the current one is)')
    if bag.unlisted:
        notes.append(f'storage file(s) in the folder that metadata.yaml does not list, not read: '
                     f'{", ".join(bag.unlisted)}')
    return VerifyResult(path=str(bag.path), storage=bag.storage, files=bag.files,
                        counts={k: len(t) for k, t in bag.topics.items()}, checks=checks, series=series,
                        crossings=crossings, crossing_ratio=ratio, elapsed=time.perf_counter() - t0, read_time=t_read,
                        unfinished=bag.unfinished, config=geo.config.to_dict(), notes=notes, geometry=geo.report,
                        robot=robot_summary(arms),
                        unchecked={suite_topic(bag.namespace, k): v for k, v in unchecked_fields(
                            {bag.relative(k): t.msgtype for k, t in bag.topics.items()
                             if len(t) and (not bag.namespace or k.startswith(bag.namespace + '/'))}).items()})

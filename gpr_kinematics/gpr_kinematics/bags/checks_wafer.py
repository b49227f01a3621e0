"""``topic.wafer_pose_recomputed``: the wafer poses without their RobotState, against the recomputed stream.

``topic.wafer_pose`` (:mod:`.checks_robot`) checks each wafer pose against the RobotState of its stamp and frame.
The ends of a recording (:mod:`.checks_topics`) leave wafer poses without one: those before the first RobotState (a
recorder that subscribed to the robot states after the wafer poses), those after the last (a cut), and all of them
where the robot states are not recorded (a recording of fewer topics). They passed unchecked: the first 7 RobotStates
dropped with wafer poses 0-6 moved 5 cm, an extra wafer pose 1 m off between two samples, the last wafer pose moved
with the last RobotState dropped, wafer poses in frame ``nowhere`` at stamps of no state. The record of the stream
(``gpr/program``) fixes every wafer pose of a robot program, so each of those is checked:

- its stamp is a PlatformState's: ``topic.wafer_pose_recomputed_extra`` otherwise, by the rule of ``topic.*_extra``
  (inside the states' span; after the last state beyond the messages of one stamp; before the first state they are
  a late subscriber's);
- it is in the robot's world frame (with its PlatformState's frame prefix: :func:`.checks_robot.in_world`), its
  sample is a robot program's (by the records: a platform stream publishes none) and it is the wafer of that sample
  of the stream recomputed from its record (:func:`.program_record.expected`: the node's ``robot_stream``):
  position [m] and rotation angle + quaternion norm defect [rad] within ``Tolerances.position`` / ``angle`` (1e-9).

Without a record (an older node's recording) or a robot description their values cannot be recomputed: the check is
skipped, saying how many and why (their stamps are still checked, and their frame where the robot is known). Wafer
poses without a RobotState inside the RobotStates' span stay ``topic.wafer_pose_extra`` (:mod:`.checks_robot`).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..errors import GprError
from .cdr import Columns
from .checks_program import owners
from .checks_robot import in_world
from .checks_topics import match
from .columns import quaternion_angle, stamp_ns, vec
from .ends import extra
from .program_record import ROBOT_PROGRAM, Recomputed, recorded_prefix, sample_index
from .reader import Bag
from .results import Check, skipped, value_check
from .tolerances import Tolerances
from .typestore import GPR_TOPICS, ROBOT_STATE_TOPIC, WAFER_POSE_TOPIC

CHECK = 'topic.wafer_pose_recomputed'
_DETAIL = ('a wafer pose without its RobotState (before the first, after the last, or none recorded) against the '
           'wafer of its sample in the stream recomputed from the record (gpr/program); inf = not in the robot\'s '
           'world frame, its sample not a robot program\'s (a platform stream publishes no wafer pose), or not '
           'recomputable')


def _without_robot_state(bag: Bag, wc: Columns, wstamps: NDArray[np.int64]) -> NDArray[np.int64]:
    """The wafer poses (indices) without a RobotState of their stamp and frame outside the RobotStates' span, all of
    them without RobotStates (those inside the span are ``topic.wafer_pose_extra``)."""
    t = bag.topic(ROBOT_STATE_TOPIC)
    if t is None or not len(t) or t.msgtype != GPR_TOPICS[ROBOT_STATE_TOPIC]:
        return np.arange(len(wstamps))
    rc = t.columns()
    rstamps = stamp_ns(rc)
    paired = np.zeros(len(wstamps), dtype=bool)
    idx = match(wstamps, wc['header.frame_id'], rstamps, rc['header.frame_id'])
    paired[idx[idx >= 0]] = True
    out: NDArray[np.int64] = np.flatnonzero(~paired & ((wstamps < rstamps.min()) | (wstamps > rstamps.max())))
    return out


def _errors(wc: Columns, w: NDArray[np.int64], samples: NDArray[np.int64], streams: Recomputed
            ) -> NDArray[np.float64]:
    """Per wafer pose ``w`` (at the state counters ``samples``): the largest difference from the recomputed wafer of
    its sample, inf where its sample is no robot program's or the stream cannot be recomputed."""
    out = np.full(len(w), np.inf)
    owner = owners(streams.records, samples)
    position, orientation = vec(wc, 'pose.position')[w], vec(wc, 'pose.orientation', 'xyzw')[w]
    for k in np.unique(owner[owner >= 0]).tolist():
        record = streams.records[k]
        if record.kind != ROBOT_PROGRAM:
            continue
        try:
            ex = streams(k)
        except GprError:   # named in topic.program
            continue
        if ex.wafer is None:
            continue
        for j in np.flatnonzero(owner == k).tolist():
            i = sample_index(record, int(samples[j]))
            if 0 <= i < len(ex.q):
                q = orientation[j:j + 1]
                angle = quaternion_angle(ex.wafer.quaternion[i:i + 1], q) + np.abs(np.linalg.norm(q, axis=1) - 1.0)
                out[j] = max(float(np.max(np.abs(position[j] - ex.wafer.position[i]))), float(angle[0]))
    return np.where(np.isnan(out), np.inf, out)


def wafer_pose_checks(bag: Bag, c: Columns, samples: NDArray[np.int64], streams: Recomputed,
                      tol: Tolerances) -> list[Check]:
    """The checks of the module docstring against the PlatformState columns ``c`` (``streams``: the recorded
    records' streams, :func:`~.checks_program.read_records`, with the robot verified against, None: none); none
    where every wafer pose has its RobotState."""
    robot = streams.robot
    t = bag.topic(WAFER_POSE_TOPIC)
    if t is None or not len(t) or t.msgtype != GPR_TOPICS[WAFER_POSE_TOPIC]:
        return []
    wc = t.columns()
    wstamps = stamp_ns(wc)
    alone = _without_robot_state(bag, wc, wstamps)
    if not alone.size:
        return []
    stamps = stamp_ns(c)
    state = match(stamps, np.zeros(len(stamps), dtype=object), wstamps[alone], np.zeros(alone.size, dtype=object))
    w, rows = alone[state >= 0], state[state >= 0]
    out = [x for x in [extra(CHECK, WAFER_POSE_TOPIC, wstamps[alone], stamps, int(w.size))] if x]
    limit = max(tol.position, tol.angle)
    if robot is None or not streams.records:
        why = 'no robot description (topic.robot)' if robot is None else \
            'no record of the stream (gpr/program) to recompute them from: a recording of an older node'
        wrong = (~in_world(wc['header.frame_id'][w], c['header.frame_id'][rows], robot) if robot is not None
                 else np.zeros(w.size, dtype=bool))
        if np.any(wrong):
            out.append(value_check(CHECK, WAFER_POSE_TOPIC, np.full(int(wrong.sum()), np.inf), limit, 'm|rad',
                                   samples[rows[wrong]], f"not in the robot's world frame (values not checked: {why})"))
        if w.size:
            out.append(skipped(CHECK, WAFER_POSE_TOPIC, 'm|rad', f'{w.size} wafer poses without their RobotState not '
                               f'checked: {why}', limit))
        return out
    e = _errors(wc, w, samples[rows], streams)
    e[~in_world(wc['header.frame_id'][w], c['header.frame_id'][rows], robot, recorded_prefix(streams.records))] = \
        np.inf
    return out + [value_check(CHECK, WAFER_POSE_TOPIC, e, limit, 'm|rad', samples[rows], _DETAIL)]

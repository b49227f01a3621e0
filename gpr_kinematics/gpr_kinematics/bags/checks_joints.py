"""``topic.joint_states_recomputed``: the arm joints of the joint_states without their RobotState.

``topic.joint_states`` (:mod:`.checks_topics`) checks a robot program's joint_states against the RobotState of their
stamp: the rods, then every arm's joints. Where that RobotState is not in the bag (before the first one: a recorder
that subscribed to the robot states late; the last sample's: a cut; every state where ``gpr/robot_state`` is not
recorded at all, a recording of fewer topics: :func:`.checks_topics.without_robot_state_at_the_ends`) it checks the
rods and the names of the arm joints after them, not the arm joints' values: every arm joint at 1000 rad passed
(``topic.joint_states ok 0.000e+00``), in the reference sweep without its listed robot states and in a robot program
recorded without ``gpr/robot_state``. Each such message (the stream's: positions only) that carries the robot's arm
joints after the rods is checked here:

- with the records (``gpr/program``) and the robot known: its arm joints, by name and value, are that sample's joints
  of the stream recomputed from the record that covers it (:func:`.program_record.expected`: the node's
  ``robot_stream``), within ``Tolerances.angle`` (1e-9 rad, as ``stream.program`` holds the RobotStates' joints);
  inf where the sample is not a robot program's or cannot be recomputed (named in ``topic.program``);
- without a record (an older node's recording) but the robot known: every arm joint within its range with the
  robot core's slack (:data:`~gpr_kinematics.robot.arm_chain.LIMIT_SLACK`, by how much beyond, as
  ``robot.joint_limits``); the values within the limits are declared not checked (a skipped check saying how many
  and why), never an ``ok`` of 0;
- without a robot description: declared not checked.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.messages import ROD_JOINT_NAMES
from ..errors import GprError
from .cdr import Columns
from .checks_program import owners
from .checks_robot import beyond_limits
from .checks_topics import match, without_robot_state_at_the_ends
from .columns import stamp_ns
from .program_record import ROBOT_PROGRAM, Recomputed, sample_index
from .reader import Bag
from .results import Check, skipped, value_check
from .tolerances import Tolerances
from .typestore import KNOWN_TOPICS

CHECK = 'topic.joint_states_recomputed'
_DETAIL = ("the arm joints of a joint_states message without its RobotState against that sample's joints of the "
           'stream recomputed from the record (gpr/program); inf = other joints, or its sample not a robot '
           "program's or not recomputable")


def _carried(bag: Bag, name: str, c: Columns, rows: frozenset[int], after: tuple[str, ...]
             ) -> tuple[NDArray[np.int64], list[NDArray[np.float64]]]:
    """The state rows (of ``rows``) whose stream message (positions only) carries the rods then the joints ``after``,
    and those joints' values (NaN where the positions do not match the names)."""
    t = bag.topic(name)
    if t is None or not len(t) or t.msgtype != KNOWN_TOPICS[name] or not rows:
        return np.zeros(0, np.int64), []
    jc = t.columns()
    idx = match(stamp_ns(jc), jc['header.frame_id'], stamp_ns(c), c['header.frame_id'])
    n = len(ROD_JOINT_NAMES)
    out, values = [], []
    for r in sorted(rows):
        k = int(idx[r])
        if k < 0 or np.size(jc['velocity'][k]) or np.size(jc['effort'][k]):
            continue   # a controller's message, or none: topic.joint_states
        names, position = tuple(jc['name'][k]), np.asarray(jc['position'][k], dtype=float)
        if names[:n] != ROD_JOINT_NAMES or names[n:] != after:
            continue   # no arm joints (or others): topic.joint_states decides
        out.append(r)
        values.append(position[n:] if position.size == len(names) else np.full(len(after), np.nan))
    return np.asarray(out, dtype=np.int64), values


def _recomputed(rows: NDArray[np.int64], values: list[NDArray[np.float64]], samples: NDArray[np.int64],
                after: tuple[str, ...], streams: Recomputed) -> NDArray[np.float64]:
    """Per row: the largest difference of its arm joints from the recomputed stream's (inf: not recomputable)."""
    out = np.full(rows.size, np.inf)
    owner = owners(streams.records, samples[rows])
    for k in np.unique(owner[owner >= 0]).tolist():
        record = streams.records[k]
        if record.kind != ROBOT_PROGRAM:
            continue
        try:
            ex = streams(k)
        except GprError:   # named in topic.program
            continue
        if ex.joints is None or ex.joint_names != after:
            continue
        for j in np.flatnonzero(owner == k).tolist():
            i = sample_index(record, int(samples[rows[j]]))
            if 0 <= i < len(ex.joints):
                out[j] = float(np.max(np.abs(values[j] - ex.joints[i]), initial=0.0))
    return np.where(np.isnan(out), np.inf, out)


def joint_state_checks(bag: Bag, c: Columns, samples: NDArray[np.int64], streams: Recomputed, arms: Any,
                       robot_joints: tuple[str, ...] | None, due: NDArray[np.bool_] | None,
                       tol: Tolerances) -> list[Check]:
    """The checks of the module docstring against the PlatformState columns ``c`` (``arms``, ``robot_joints``,
    ``due``: as :func:`.checks_topics.topic_checks` takes them; ``streams``: the recorded records' streams, with the
    robot verified against, None: none); none where every joint_states message has its RobotState or carries no
    arm joints."""
    robot = streams.robot
    after = robot_joints if arms is None else arms.names()
    if not after:
        return []
    name = bag.joint_states_topic()
    rods_only = without_robot_state_at_the_ends(stamp_ns(c), arms, robot_joints is not None, due)
    rows, values = _carried(bag, name, c, rods_only, after)
    if not rows.size:
        return []
    if robot is not None and streams.records:
        e = _recomputed(rows, values, samples, after, streams)
        return [value_check(CHECK, name, e, tol.angle, 'rad', samples[rows], _DETAIL)]
    what = f'{rows.size} joint_states messages without their RobotState carry the arm joints'
    if robot is None:
        return [skipped(CHECK, name, 'rad', f'{what}; their values not checked: no robot description (topic.robot)',
                        tol.angle)]
    why = 'no record of the stream (gpr/program) to recompute them from: a recording of an older node'
    e = beyond_limits(np.array(values), after, robot)
    beyond = ~(e <= 0.0)
    out = []
    if np.any(beyond):
        out.append(value_check(CHECK, name, e[beyond], 0.0, 'rad', samples[rows[beyond]],
                               f'an arm joint beyond its range by this much (robot {robot.name}; values not checked '
                               f'against the stream: {why})'))
    if not np.all(beyond):
        out.append(skipped(CHECK, name, 'rad', f'{what}; {int((~beyond).sum())} within the joint limits of robot '
                           f'{robot.name}, their values not checked: {why}', tol.angle))
    return out

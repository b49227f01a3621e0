"""``topic.program`` and ``stream.program``: every sample against its stream recomputed from the record of what the
stream was asked to do (``gpr/program``, :mod:`.program_record`).

- ``topic.program``: every recorded record parses (the package's YAML reader and bounds, known keys, a program of
  either format), no two records of one first sample differ (the node publishes one per first sample: an appended
  one would decide the stream by the order of the messages), it recomputes (:func:`.program_record.expected`,
  with the geometry and the robot description verified against) to as many samples as it says, and its ``loop``
  agrees with the recording (:func:`loop_problems`);
- ``stream.program``: each PlatformState, by its sample counter the sample ``i`` of the record that covers it (the
  last one that starts at or before it), carries that sample's rods ``q`` [m], commanded tilt and commanded azimuth
  [rad], and, in a robot program, the RobotState of its stamp carries that sample's joints of every arm [rad] and
  its waypoint with the waypoint's name (``station``) and the arm in use (``arm``; a name that differs is also
  named in ``topic.program``), each within ``Tolerances.position`` / ``angle`` (1e-9). So a recorded robot
  description that disagrees with the stream (an arm's default branch, home posture, redundancy rule or limits
  edited: the branch is in the joints of every waypoint it decides) fails, and so does a recorded program, or a
  recorded geometry, that did not produce it, or a station renamed in the record.

A recording without a record (of a node before it was published) skips both; its commanded tilts are still checked
against the states (``state.commanded``, :mod:`.checks_state`). The records are read once (:func:`read_records`) for
these checks, for ``topic.markers_sequence`` (:func:`marker_cadence`, the recorded cadence of each state's markers)
and for ``robot.structure`` (:func:`robot_program_states`, the states that have RobotStates).
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GprError, brief
from ..inputs import safe_yaml
from .cdr import Columns
from .columns import matrix, wrapped
from .program_record import ROBOT_PROGRAM, SWEEP, Expected, Recomputed, Record, parse_record, sample_index
from .reader import Bag
from .results import Check, bag_check, skipped, value_check
from .tolerances import Tolerances
from .typestore import GPR_TOPICS, PROGRAM_TOPIC

_DETAIL = ('inf = no recorded stream covers this sample (or it cannot be recomputed), or its RobotState holds '
           'another waypoint or names it or the arm in use otherwise; else the largest difference')


Problem = tuple[str, float, float, str]


_ABSENT = object()


def _difference(first: str, other: str) -> str:
    """The keys in which two records' YAML (both read by :func:`parse_record`) differ, a scalar's two values given
    (``markers_every (1 and absent)``); empty when they read alike."""
    a, b = (safe_yaml.load_text(text, PROGRAM_TOPIC) for text in (first, other))
    assert isinstance(a, dict) and isinstance(b, dict)  # parse_record accepted both
    parts = []
    for key in dict.fromkeys([*a, *b]):
        x, y = a.get(key, _ABSENT), b.get(key, _ABSENT)
        if x == y:
            continue
        if isinstance(x, (dict, list)) or isinstance(y, (dict, list)):
            parts.append(key)
        else:
            parts.append(f'{key} ({" and ".join("absent" if v is _ABSENT else brief(v) for v in (x, y))})')
    return ', '.join(parts)


def read_records(bag: Bag) -> tuple[list[Record], list[Problem]]:
    """The distinct records of the bag, by first sample, and what is wrong with the others (none without
    :data:`PROGRAM_TOPIC` or a message on it): a text that is no record, or a second record of a first sample that
    differs from the first one (the node publishes one record per first sample; the same one received twice is one
    record)."""
    t = bag.topic(PROGRAM_TOPIC)
    if t is None or len(t) == 0:   # a topic listed without a message has no columns
        return [], []
    if t.msgtype != GPR_TOPICS[PROGRAM_TOPIC]:
        return [], [(PROGRAM_TOPIC, 1.0, 0.0, f'type {t.msgtype}, not a std_msgs/msg/String')]
    records: dict[int, tuple[Record, str]] = {}
    problems: list[Problem] = []
    for text in dict.fromkeys(str(v) for v in t.columns()['data']):
        try:
            record = parse_record(text)
        except GprError as exc:
            problems.append((PROGRAM_TOPIC, 1.0, 0.0, f'not a record of a stream: {exc}'))
            continue
        if record.first_sample not in records:
            records[record.first_sample] = (record, text)
        elif diff := _difference(records[record.first_sample][1], text):
            problems.append((PROGRAM_TOPIC, 1.0, 0.0, f'two records of the stream from sample {record.first_sample} '
                             f'differ in {diff}; allowed: one record per first sample (the first one read is used)'))
    return [r for r, _ in sorted(records.values(), key=lambda rt: rt[0].first_sample)], problems


def owners(records: list[Record], samples: NDArray[np.int64]) -> NDArray[np.int64]:
    """Per sample counter, the index of the record that covers it (the last one that starts at or before it; -1:
    none). ``records`` sorted by first sample, as :func:`read_records` gives them."""
    out: NDArray[np.int64] = np.searchsorted([r.first_sample for r in records], samples, side='right') - 1
    return out


def marker_cadence(records: list[Record], samples: NDArray[np.int64]) -> NDArray[np.int64]:
    """Per sample counter, the ``markers_every`` of the record that covers it; 0 where none covers it or it has
    none (recorded before records carried it)."""
    every = np.array([r.markers_every or 0 for r in records] + [0], dtype=np.int64)
    return every[owners(records, samples)]   # -1 (no record) reads the 0 appended


def robot_program_states(records: list[Record], samples: NDArray[np.int64]) -> NDArray[np.bool_] | None:
    """Per sample counter, whether the record that covers it is a robot program's (its samples have RobotStates);
    None without records (a recording of an older node: every state counts)."""
    if not records:
        return None
    robot = np.array([r.kind == ROBOT_PROGRAM for r in records] + [False], dtype=bool)
    out: NDArray[np.bool_] = robot[owners(records, samples)]
    return out


def loop_problems(records: list[Record], samples: NDArray[np.int64], owner: NDArray[np.int64]) -> list[Problem]:
    """What the recording shows against each record's ``loop`` (and kind: a node streams a sweep only at its start,
    and nothing after it):
    only the node's start-up stream loops, and it starts
    at sample 0 (a ``gpr/run_program`` goal's stream never loops) and runs until the node stops, so no stream follows
    it; a stream that does not loop ends after its samples, so no sample counter it covers (before the next record's
    first sample) lies past them. ``records`` as :func:`read_records` gives them, ``owner`` the record of each sample
    (:func:`owners`)."""
    problems: list[Problem] = []
    for k, r in enumerate(records):
        # a sweep is only ever the node's start-up stream: from sample 0, and it ends the node (or loops until the
        # node stops; goals are refused while it runs): another run spliced before or after it
        if r.kind == SWEEP and (k > 0 or r.first_sample != 0):
            before = records[k - 1] if k else None
            after = 'starts there' if before is None else f'follows the {before.kind} from sample {before.first_sample}'
            problems.append((PROGRAM_TOPIC, 1.0, 0.0, f'the sweep from sample {r.first_sample} {after}; a node streams '
                             'a sweep only as its start-up stream, from sample 0 (a gpr/run_program goal runs a '
                             'program or stations)'))
        if r.kind == SWEEP and not r.loop and k + 1 < len(records):
            problems.append((PROGRAM_TOPIC, 1.0, 0.0, f'the recording has a stream from sample '
                             f'{records[k + 1].first_sample} after the sweep from sample {r.first_sample}; a sweep is '
                             'the node\'s start-up stream, which ends the node after its last sample'))
        what = f'the {r.kind} from sample {r.first_sample} says loop = '
        if r.loop and r.first_sample != 0:
            problems.append((PROGRAM_TOPIC, 1.0, 0.0, f'{what}true; only the node\'s start-up stream loops, and it '
                             'starts at sample 0 (a gpr/run_program goal\'s stream never loops)'))
        if r.loop and k + 1 < len(records):
            problems.append((PROGRAM_TOPIC, 1.0, 0.0, f'{what}true; the recording has a stream from sample '
                             f'{records[k + 1].first_sample} after it (a looping stream runs until the node stops)'))
        past = samples[(owner == k) & (samples - r.first_sample >= r.samples)]
        if not r.loop and past.size:
            problems.append((PROGRAM_TOPIC, float(past.size), 0.0, f'{what}false and {r.samples} samples; the '
                             f'recording has {past.size} samples after them ({past.min()} to {past.max()}) and no '
                             'record of a stream from them, as a looping stream has'))
    return problems


#: A RobotState that names what it holds otherwise than the recomputed stream: (state row, what the record says
#: (``names waypoint 6``, ``uses the arm``), the RobotState's field, the record's name, the RobotState's).
Renamed = tuple[int, str, str, str, str]


def _joint_errors(robot_rows: Any, rows: NDArray[np.int64], ii: NDArray[np.int64], ex: Expected
                  ) -> tuple[NDArray[np.float64], list[Renamed]]:
    """Per state row of a robot program: the largest joint difference of its RobotState (inf: other joints, another
    waypoint held, the waypoint or the arm in use named otherwise: those listed; 0 where the recording has no
    RobotState of the row)."""
    out = np.zeros(rows.size)
    renamed: list[Renamed] = []
    if ex.joints is None or robot_rows is None:
        return out, renamed
    for k, (r, i) in enumerate(zip(rows.tolist(), ii.tolist(), strict=True)):
        got = robot_rows.joints(r)
        if got is None:
            continue
        names, values = got
        w, station = -1 if ex.waypoint is None else int(ex.waypoint[i]), ex.station(i)
        held = robot_rows.waypoints.get(r, w) == w
        named = robot_rows.stations.get(r, station)
        if held and named != station:
            renamed.append((r, f'names waypoint {w}', 'station', station, named))
        arm = ex.arm[i] if ex.arm else ''
        used = robot_rows.arms.get(r, arm) if arm else arm
        if used != arm:
            renamed.append((r, 'uses the arm', 'arm', arm, used))
        same = names == ex.joint_names and values.shape == ex.joints[i].shape and held and named == station \
            and used == arm
        out[k] = float(np.max(np.abs(values - ex.joints[i]), initial=0.0)) if same else np.inf
    return out, renamed


def _renamed_problems(record: Record, renamed: list[Renamed], samples: NDArray[np.int64]) -> list[Problem]:
    """One problem per name in ``record`` (a waypoint's, the arm in use) that its RobotStates carry otherwise."""
    by: dict[tuple[str, str, str, str], list[int]] = {}
    for r, what, field, name, named in renamed:
        by.setdefault((what, field, name, named), []).append(int(samples[r]))
    return [(PROGRAM_TOPIC, float(len(at)), 0.0, f'the {record.kind} from sample {record.first_sample} {what} '
             f'{brief(name)}; its RobotStates ({field}) name it {brief(named)} at '
             + (f'sample {at[0]}' if len(at) == 1 else f'{len(at)} samples ({min(at)} to {max(at)})'))
            for (what, field, name, named), at in by.items()]


def program_checks(bag: Bag, c: Columns, samples: NDArray[np.int64], streams: Recomputed, robot_rows: Any,
                   tol: Tolerances, recorded: tuple[list[Record], list[Problem]]) -> list[Check]:
    """The checks of the module docstring for the PlatformState columns ``c`` (``streams``: the records' streams
    recomputed; ``robot_rows``: the joints of the RobotState of each state row, :class:`~.checks_robot.RobotRows`,
    or None; ``recorded``: what :func:`read_records` gave)."""
    t = bag.topic(PROGRAM_TOPIC)
    if t is None or len(t) == 0:
        why = ('no record of the stream (gpr/program): a recording of an older node' if t is None else
               'the record topic (gpr/program) is recorded without a message: as a recording of an older node')
        return [skipped('topic.program', PROGRAM_TOPIC, '', why),
                skipped('stream.program', PROGRAM_TOPIC, 'm|rad', why, max(tol.position, tol.angle))]
    records, problems = recorded[0], list(recorded[1])
    errors = np.full(len(samples), np.inf)
    if records:
        owner = owners(records, samples)
        problems += loop_problems(records, samples, owner)
        q, ct, ca = matrix(c['q'], 3), np.asarray(c['commanded_tilt'], float), np.asarray(c['commanded_azimuth'], float)
        for k, record in enumerate(records):
            rows = np.flatnonzero(owner == k)
            try:
                ex = streams(k)
            except GprError as exc:
                problems.append((PROGRAM_TOPIC, 1.0, 0.0, f'the {record.kind} from sample {record.first_sample} '
                                 f'cannot be recomputed: {exc}'))
                continue
            if len(ex.q) != record.samples:
                problems.append((PROGRAM_TOPIC, float(abs(len(ex.q) - record.samples)), 0.0, f'the {record.kind} '
                                 f'from sample {record.first_sample} says {record.samples} samples; it recomputes to '
                                 f'{len(ex.q)}'))
            ii = np.array([sample_index(record, int(s)) for s in samples[rows]], dtype=np.int64)
            ok = (ii >= 0) & (ii < len(ex.q))
            r, i = rows[ok], ii[ok]
            with np.errstate(invalid='ignore'):
                e = np.max(np.abs(q[r] - ex.q[i]), axis=1, initial=0.0)
                e = np.maximum(e, np.abs(ct[r] - ex.commanded_tilt[i]))
                e = np.maximum(e, wrapped(ca[r] - ex.commanded_azimuth[i]))
            joint_errors, renamed = _joint_errors(robot_rows, r, i, ex)
            e = np.maximum(e, joint_errors)
            problems += _renamed_problems(record, renamed, samples)
            errors[r] = np.where(np.isnan(e), np.inf, e)
    return [bag_check('topic.program', PROGRAM_TOPIC, problems, len(t), ''),
            value_check('stream.program', PROGRAM_TOPIC, errors, max(tol.position, tol.angle), 'm|rad', samples,
                        _DETAIL)]

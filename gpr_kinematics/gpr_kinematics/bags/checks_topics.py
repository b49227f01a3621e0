"""``topic.*`` checks: every companion topic against the PlatformState of the same sample (matched by stamp).

- ``platform_pose`` / ``nominal_pose``: a PoseStamped with the stamp and frame of every PlatformState and the
  same pose (<= ``consistency``, 1e-12);
- ``joint_states``: no velocity or effort (the node publishes positions only), names ``rod_1..rod_3``
  (:data:`gpr_kinematics.core.messages.ROD_JOINT_NAMES`), positions ``q``
  (in a whole-robot recording followed by every arm's joints, the names and values of the RobotState of the
  stamp; in bags recorded before the virtual joints got their own topic: the rods then the virtual joints' names,
  positions ``q`` then the virtual joints) (<= 1e-12); ``virtual_joints``: the state's virtual-joint names and
  values (<= 1e-12);
- ``markers``: each MarkerArray has the four markers of :data:`.markers.MARKERS` (ids, namespaces, types,
  ADD), each with the stamp and frame of a PlatformState and the identity pose (so the points are in the
  base frame), and the points of :func:`.markers.marker_points` for that state (rod tops = joint centres
  ``P_k``, the platform triangle, the naive outline) within 1e-12 m. Markers may be published for every n-th
  sample only (``markers_every``), so a state without markers is not a failure by itself; markers without a state
  are, and so is a gap: ``markers_sequence`` takes ``n`` as the stream's ``markers_every`` recorded on
  ``gpr/program`` (:mod:`.program_record`), and every sample whose counter is a multiple of ``n``
  (:func:`~gpr_kinematics.robot.markers.marked`, as the node decides) must have its markers, and no other: removing
  every other MarkerArray of a stream with markers at every sample fails at the first one removed. For samples no
  record with ``markers_every`` covers (recordings before it was recorded, such as the reference bag) ``n`` is
  inferred as the smallest step between the counters of their samples that have markers, counted from the first
  of them (a MarkerArray removed mid-stream passed before: 1927 markers for 1928 states); removing every other one
  is then what ``markers_every: 2`` records, and passes. Either way the sequence runs from the first MarkerArray
  to the recording's last sample (the ends, below): after the last MarkerArray the states may go on to the next
  marked sample (whose MarkerArray a cut lost), not beyond. The topic recorded without a message (every
  MarkerArray removed passed as "no markers in the bag"): the samples a recorded ``markers_every`` marks between
  the first and the last state fail ``markers_sequence``; a bag without the topic skips the markers.

The ends of a recording (which companion messages an honest recording may lack there): :mod:`.ends`.

A controller's joint states: ``joint_states`` is the robot's topic, and the robot's controller publishes on it too
(``robot_simulator_node`` holding the robot before, between and after streams, and moving it for its goals, as
ros2_control's joint_state_broadcaster does), every joint's position with its velocity; the stream's messages carry
positions only. A message with velocities or efforts that no state's stamp matches is the controller's, not the
stream's: neither ``topic.joint_states_extra`` nor ``_order`` (the offline loop's recorder beside the simulator failed
with its held state after the sweep), also at a state's stamp beside the node's message (a simulator's held state at
a step of a simulated clock); one alone at a state's stamp is checked as the stream's (and fails).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.config import GprConfig
from ..core.messages import ROD_JOINT_NAMES
from ..core.rotations import matrix_from_quaternion
from ..robot.markers import ADD, MARKERS, marked, marker_points
from .cdr import COUNT, Columns
from .columns import field_matrix, matrix, stamp_ns, vec
from .ends import cut_detail, extra, lagging, missing, unordered, without_messages
from .reader import Bag, TopicData
from .results import Check, Failure, Series, bool_check, skipped, value_check
from .typestore import (
    KNOWN_TOPICS,
    MARKERS_TOPIC,
    NOMINAL_POSE_TOPIC,
    PLATFORM_POSE_TOPIC,
    VIRTUAL_JOINTS_TOPIC,
)

_UNIT = 'm|rad'


def match(companion_stamps: NDArray[np.int64], companion_frames: NDArray[np.object_], stamps: NDArray[np.int64],
          frames: NDArray[np.object_]) -> NDArray[np.int64]:
    """Index of the companion message with each PlatformState's stamp and frame, -1 if none."""
    out = np.full(len(stamps), -1, dtype=np.int64)
    if len(companion_stamps) == 0:
        return out
    order = np.argsort(companion_stamps, kind='stable')
    sorted_stamps = companion_stamps[order]
    pos = np.clip(np.searchsorted(sorted_stamps, stamps), 0, len(companion_stamps) - 1)
    cand = order[pos]
    hit = (sorted_stamps[pos] == stamps) & np.array([companion_frames[j] == frames[i] for i, j in enumerate(cand)],
                                                    dtype=bool)
    out[hit] = cand[hit]
    return out


def _topic(bag: Bag, name: str) -> TopicData | None:
    t = bag.topic(name)
    return t if t is not None and t.msgtype == KNOWN_TOPICS[name] else None


def _pose_checks(bag: Bag, c: Columns, samples: NDArray[np.int64], tol: float) -> list[Check]:
    stamps, frames = stamp_ns(c), c['header.frame_id']
    out: list[Check] = []
    for name, field in ((PLATFORM_POSE_TOPIC, 'pose'), (NOMINAL_POSE_TOPIC, 'nominal_pose')):
        check = f'topic.{name.rsplit("/", 1)[-1]}'
        t = _topic(bag, name)
        why = 'inf = no message with the stamp and frame of this PlatformState'
        if t is None:
            out.append(skipped(check, name, _UNIT, 'topic not in the bag', tol))
            continue
        if len(t) == 0:
            out.append(without_messages(check, name, stamps, samples, tol, _UNIT, why))
            continue
        pc = t.columns()
        pstamps = stamp_ns(pc)
        idx = match(pstamps, pc['header.frame_id'], stamps, frames)
        ok = idx >= 0
        e = missing(stamps, pstamps)
        e[ok] = np.max(np.abs(field_matrix(pc, 'pose')[idx[ok]] - field_matrix(c, field)[ok]), axis=1)
        out.append(value_check(check, name, e, tol, _UNIT, samples, why + cut_detail(stamps, pstamps, samples, e)))
        out += [x for x in [extra(check, name, pstamps, stamps, int(ok.sum())), unordered(check, name, pstamps)]
                if x]
    return out


#: A layout of a JointState topic: for the state ``r``, the joint names and positions it must carry.
_Layout = Callable[[int], tuple[tuple[str, ...], NDArray[np.float64]]]


def _joint_checks(bag: Bag, c: Columns, samples: NDArray[np.int64], tol: float, name: str,
                  layouts: tuple[_Layout, ...], detail: str, rods_only: frozenset[int] = frozenset(),
                  shared: bool = False, after_rods: tuple[str, ...] | None = None, recorded: bool = False
                  ) -> list[Check]:
    """A JointState topic against the states: per matched message, the largest position error of the first
    layout whose names it carries (inf when it carries none); of the states ``rods_only`` their first three joints
    only where none of the layouts matches the whole message (those of a robot recording whose RobotState is not in
    the bag at its ends: a cut lost the last one, a recorder that subscribed late missed the first ones; or not
    recorded at all, where ``after_rods`` names the joints the message must carry after the rods: the robot's;
    ``recorded``: the records say ``rods_only`` are a robot program's, whose messages always carry those joints).
    ``shared``: the robot's topic, on which a controller publishes too (module docstring, *a controller's joint
    states*): its messages with velocities or efforts and no state's stamp are not counted extra nor ordered, nor
    those beside the node's message of their stamp (one alone at a state's stamp is checked as the stream's)."""
    check = f'topic.{name.rsplit("/", 1)[-1]}'
    t = _topic(bag, name)
    if t is None:
        return [skipped(check, name, _UNIT, 'topic not in the bag', tol)]
    stamps = stamp_ns(c)
    why = f'inf = missing, velocity or effort given, or {detail}'
    if len(t) == 0:
        return [without_messages(check, name, stamps, samples, tol, _UNIT, why)]
    jc = t.columns()
    jstamps = stamp_ns(jc)
    ctrl = np.array([bool(np.size(v) or np.size(f)) for v, f in zip(jc['velocity'], jc['effort'], strict=True)],
                    dtype=bool) if shared else np.zeros(len(jstamps), dtype=bool)
    beside = ctrl & np.isin(jstamps, jstamps[~ctrl])   # a controller's beside the node's at its stamp: claims nothing
    usable = np.flatnonzero(~beside)
    found = match(jstamps[usable], jc['header.frame_id'][usable], stamps, c['header.frame_id'])
    idx = np.where(found >= 0, usable[np.maximum(found, 0)], -1)
    rows = np.flatnonzero(idx >= 0)
    e = missing(stamps, jstamps)
    names, positions = jc['name'], jc['position']
    for r in rows:
        got_names, got = tuple(names[idx[r]]), np.asarray(positions[idx[r]], dtype=float)
        e[r] = np.inf
        if np.size(jc['velocity'][idx[r]]) or np.size(jc['effort'][idx[r]]):
            continue   # the node publishes positions only
        whole = [(got_names, got)]    # the whole message first (a layout it carries whole is checked whole)
        if r in rods_only and (after_rods is None or got_names[len(ROD_JOINT_NAMES):] == after_rods):
            whole.append((got_names[:len(ROD_JOINT_NAMES)], got[:len(ROD_JOINT_NAMES)]))
        if r in rods_only and recorded:   # never the rods alone
            whole = whole[1:]
        e[r] = next((float(np.max(np.abs(values - want), initial=0.0)) for carried, values in whole
                     for want_names, want in (layout(int(r)) for layout in layouts)
                     if carried == want_names and values.shape == want.shape), np.inf)
    out = [value_check(check, name, e, tol, _UNIT, samples, why + cut_detail(stamps, jstamps, samples, e))]
    own = ~ctrl
    if shared:   # a state's stamp: the stream's, whichever message matched it (but a controller's beside the node's)
        own |= np.isin(jstamps, stamps) & ~beside
    numbers = np.flatnonzero(own)
    return out + [x for x in [extra(check, name, jstamps[own], stamps, rows.size),
                              unordered(check, name, jstamps[own], numbers)] if x]


def _joint_state_checks(bag: Bag, c: Columns, samples: NDArray[np.int64], series: Series, tol: float,
                        arms: Any = None, robot_joints: tuple[str, ...] | None = None,
                        due: NDArray[np.bool_] | None = None) -> list[Check]:
    """``/joint_states`` (``/gpr/joint_states`` in bags recorded before) carries the rods (``rod_1..rod_3``, ``q``),
    and in a whole-robot recording then every arm's joints (``arms``: the :class:`~.checks_robot.RobotRows` of the
    robot states; without them, the rods alone where the message carries the known robot's joints, ``robot_joints``,
    after them; ``due``: per state, whether the records say it is a robot program's, whose messages carry the rods
    then the robot's joints, the others the rods alone); bags recorded before the virtual joints got their own topic
    carry the rods then the virtual joints.
    ``/gpr/virtual_joints`` carries the virtual joints."""
    vnames = c['virtual_joint_names']

    def rods(r: int) -> tuple[tuple[str, ...], NDArray[np.float64]]:
        robot = arms.joints(r) if arms is not None else None
        if robot is not None:
            return ROD_JOINT_NAMES + robot[0], np.concatenate([series.q[r], robot[1]])
        return ROD_JOINT_NAMES, series.q[r]

    def rods_and_virtual(r: int) -> tuple[tuple[str, ...], NDArray[np.float64]]:
        return ROD_JOINT_NAMES + tuple(vnames[r]), np.concatenate([series.q[r], series.virtual(r)])

    def virtual(r: int) -> tuple[tuple[str, ...], NDArray[np.float64]]:
        return tuple(vnames[r]), series.virtual(r)

    return (_joint_checks(bag, c, samples, tol, bag.joint_states_topic(), (rods, rods_and_virtual),
                          'names not rod_1..rod_3 (then the arm joints of the RobotState of the stamp, in a robot '
                          'recording, or of the robot recorded or given without its states; or, recorded before, '
                          'rod_1..rod_3 + the virtual joints)',
                          without_robot_state_at_the_ends(stamp_ns(c), arms, robot_joints is not None, due),
                          shared=True, after_rods=robot_joints if arms is None else arms.names(),
                          recorded=due is not None)
            + _joint_checks(bag, c, samples, tol, VIRTUAL_JOINTS_TOPIC, (virtual,),
                            "names not the state's virtual_joint_names"))


def without_robot_state_at_the_ends(stamps: NDArray[np.int64], arms: Any, robot: bool,
                                     due: NDArray[np.bool_] | None = None) -> frozenset[int]:
    """The states of a robot recording without their RobotState before the first that has one (a recorder that
    subscribed to the robot states after the joint states: an honest late recording failed) and the last one (a cut);
    every state where no robot states are recorded but the robot is known (``robot``: recorded or given; a recording
    of fewer topics); none where neither is (a platform recording: its messages carry the rods alone). Where the records
    say which states are a robot program's (``due``), those only: a platform stream's carry the rods alone, also
    before a robot program's first RobotState. The rods checked here, the arm joints in :mod:`.checks_joints`."""
    if due is not None:
        return frozenset(r for r in without_robot_state_at_the_ends(stamps, arms, robot) if due[r])
    if arms is None:
        return frozenset(range(len(stamps))) if robot else frozenset()
    if not len(stamps):
        return frozenset()
    order = np.argsort(stamps, kind='stable')
    known = [arms.joints(int(r)) is not None for r in order]
    first = known.index(True) if True in known else len(order)
    ends = {int(r) for r in order[:first]}
    return frozenset(ends | ({int(order[-1])} if not known[-1] else set()))


def _column(mc: Columns, name: str) -> NDArray[Any] | None:
    return mc.get(name)


def _marker_errors(mc: Columns, j: NDArray[np.int64], rows: NDArray[np.int64], c: Columns,
                   expected: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """Per matched MarkerArray ``j`` (of the state ``rows``): largest point error [m], inf if its structure,
    stamp, frame or pose differ from the description."""
    n = len(mc['markers' + COUNT])
    err = np.where(np.asarray(mc['markers' + COUNT])[j] == len(MARKERS), 0.0, np.inf)
    stamps, frames = stamp_ns(c)[rows], c['header.frame_id'][rows]
    for spec in MARKERS:
        p = f'markers[{spec.id}].'
        ns, count = _column(mc, p + 'ns'), _column(mc, p + 'points' + COUNT)
        pts = expected[spec.ns]
        if ns is None or count is None:
            return np.full(len(j), np.inf)
        same = ((ns[j] == spec.ns) & (np.asarray(mc[p + 'id'])[j] == spec.id)
                & (np.asarray(mc[p + 'type'])[j] == spec.type) & (np.asarray(mc[p + 'action'])[j] == ADD)
                & (stamp_ns(mc, p + 'header.stamp')[j] == stamps) & (mc[p + 'header.frame_id'][j] == frames)
                & (np.asarray(count)[j] == pts.shape[1]))
        pose = np.concatenate([vec(mc, p + 'pose.position'), vec(mc, p + 'pose.orientation', 'xyzw')], axis=1)[j]
        err = np.maximum(err, np.where(same, np.max(np.abs(pose - [0, 0, 0, 0, 0, 0, 1.0]), axis=1), np.inf))
        for k in range(pts.shape[1]):
            got = vec(mc, f'{p}points[{k}]') if f'{p}points[{k}].x' in mc else np.full((n, 3), np.nan)
            err = np.maximum(err, np.max(np.abs(got[j] - pts[:, k]), axis=1))
    return err


def _inferred_gaps(samples: NDArray[np.int64], has: NDArray[np.bool_], end: int) -> NDArray[np.bool_]:
    """Per state: a gap or an irregular sample of the markers' sequence every ``n`` from the first marked state,
    ``n`` the smallest step between the counters of the marked ones, up to the recording's last sample ``end``
    (module docstring)."""
    marked_samples = samples[has]
    steps = np.diff(marked_samples)
    if marked_samples.size < 2 or not np.any(steps > 0):
        return np.zeros(len(samples), dtype=bool)
    n, first = int(np.min(steps[steps > 0])), int(marked_samples.min())
    on = (samples - first) % n == 0
    inside = (samples >= first) & (samples < end)
    out: NDArray[np.bool_] = (inside & on & ~has) | (has & ~on)
    return out


def _recorded_marks(samples: NDArray[np.int64], every: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Per state: whether a recorded ``every`` (0: none) marks its counter (:func:`marked`)."""
    out: NDArray[np.bool_] = (every > 0) & marked(samples, np.maximum(every, 1))
    return out


def _marker_gaps(samples: NDArray[np.int64], rows: NDArray[np.int64], every: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Per state: a gap or an irregular sample of the markers' sequence (module docstring, ``markers_sequence``):
    where ``every`` (the recorded ``markers_every`` per state, 0: none) is known, the counters :func:`marked` by it
    from the first marked state to the recording's last sample (whose MarkerArray a cut mid-sample may lose);
    elsewhere the cadence inferred from those states alone."""
    has = np.zeros(len(samples), dtype=bool)
    has[rows] = True
    known = every > 0
    out = np.zeros(len(samples), dtype=bool)
    end = int(samples.max()) if samples.size else 0
    if np.any(~known):
        out[~known] = _inferred_gaps(samples[~known], has[~known], end)
    if np.any(known) and rows.size:
        on = _recorded_marks(samples, every)
        inside = (samples >= samples[rows].min()) & (samples < end)
        out |= known & ((inside & on & ~has) | (has & ~on))
    return out


def _sequence_detail(every: NDArray[np.int64]) -> str:
    """What ``markers_sequence`` held the states to: the recorded ``markers_every`` values and/or the inferred n."""
    recorded = sorted({int(n) for n in every if n > 0})
    parts = [f'a counter that is a multiple of the recorded markers_every = {", ".join(map(str, recorded))}'] \
        if recorded else []
    if np.any(every <= 0):
        parts.append('every n-th from the first marked sample, n the smallest step between marked counters '
                     '(no markers_every recorded)')
    return f"a sample of the markers' sequence ({'; '.join(parts)}) without its MarkerArray, or one out of it"


def _no_marker_checks(name: str, samples: NDArray[np.int64], tol: float, every: NDArray[np.int64]) -> list[Check]:
    """The markers topic recorded without a message: skipped, unless a recorded ``markers_every`` says a sample
    between the first and the last state had its MarkerArray (the end states' may be lost to a recording started
    or cut in the middle of a sample, as on every companion topic); those fail ``markers_sequence``."""
    due = _recorded_marks(samples, every)
    if samples.size:
        due &= (samples > samples.min()) & (samples < samples.max())
    if not np.any(due):
        return [skipped('topic.markers', name, 'm', 'no markers in the bag', tol)]
    return [skipped('topic.markers', name, 'm', 'no markers in the bag (their sequence fails)', tol),
            bool_check('topic.markers_sequence', name, ~due, samples,
                       f'the markers topic is recorded without a message; {_sequence_detail(every)}')]


def _marker_checks(bag: Bag, c: Columns, samples: NDArray[np.int64], cfg: GprConfig, tol: float,
                   every: NDArray[np.int64]) -> list[Check]:
    name = MARKERS_TOPIC
    t = _topic(bag, name)
    if t is None:
        return [skipped('topic.markers', name, 'm', 'no markers in the bag', tol)]
    if len(t) == 0:
        return _no_marker_checks(name, samples, tol, every)
    mc = t.columns()
    first = 'markers[0].header.'
    if first + 'frame_id' not in mc:
        return [Check('topic.markers', name, len(t), np.inf, tol, 'm', len(t),
                      [Failure('topic.markers', name, None, np.inf, tol, 'no marker in the arrays')])]
    stamps = stamp_ns(c)
    idx = match(stamp_ns(mc, first + 'stamp'), mc[first + 'frame_id'], stamps, c['header.frame_id'])
    rows = np.flatnonzero(idx >= 0)
    expected = marker_points(cfg, matrix(c['q'], 3)[rows], vec(c, 'nominal_pose.position')[rows],
                             matrix_from_quaternion(vec(c, 'nominal_pose.orientation', 'xyzw')[rows]))
    err = _marker_errors(mc, idx[rows], rows, c, expected)
    gaps = _marker_gaps(samples, rows, every) & ~lagging(stamps, int(stamps[rows].max()) if rows.size else 0)
    cut = cut_detail(stamps, stamps[rows], samples, np.where(gaps, np.inf, 0.0), 'of them after the last MarkerArray')
    out = [value_check('topic.markers', name, err, tol, 'm', samples[rows],
                       'inf = structure, stamp, frame or pose differ; else the largest point error'),
           bool_check('topic.markers_sequence', name, ~gaps, samples, _sequence_detail(every) + cut)]
    marker_stamps = stamp_ns(mc, first + 'stamp')
    return out + [x for x in [extra('topic.markers', name, marker_stamps, stamps, rows.size),
                               unordered('topic.markers', name, marker_stamps)] if x]


def topic_checks(bag: Bag, c: Columns, samples: NDArray[np.int64], series: Series, cfg: GprConfig,
                 tol: float, arms: Any, markers_every: NDArray[np.int64],
                 robot_joints: tuple[str, ...] | None = None, due: NDArray[np.bool_] | None = None) -> list[Check]:
    """The ``topic.*`` checks of the companion topics against the PlatformState columns ``c`` (``arms``: the robot
    joints per state of a whole-robot recording, :class:`~.checks_robot.RobotRows`, or None; ``markers_every``: the
    recorded cadence of the markers per state, 0 where none is recorded, :func:`~.checks_program.marker_cadence`;
    ``robot_joints``: every arm joint of the robot recorded or given, None without one; ``due``: per state, whether
    the records say it is a robot program's, None without records)."""
    every = np.asarray(markers_every, np.int64)
    return (_pose_checks(bag, c, samples, tol)
            + _joint_state_checks(bag, c, samples, series, tol, arms, robot_joints, due)
            + _marker_checks(bag, c, samples, cfg, tol, every))

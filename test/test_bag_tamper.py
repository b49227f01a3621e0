"""Tampered bags that passed ``gpr verify`` (issue 18), each written again by the public ``mcap`` library with every
CRC recomputed and ``metadata.yaml`` recounted and re-signed (:mod:`mcap_tamper`): each fails, naming what is wrong.
Then a seeded fuzz of the same kind: a random checked number of a random message changed, a random message dropped,
a line of a random embedded definition changed; none passes. ``GPR_FUZZ_EXAMPLES`` and ``GPR_FUZZ_SEED`` make it
deeper, as for the other fuzz tests."""
from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bag_support import MARKERS, example_robot_bag, messages_of, small_sweep, write_bag
from gpr_kinematics.bags.coverage import numeric_fields, rule_of
from gpr_kinematics.bags.results import MAX_DETAILS
from gpr_kinematics.bags.synthetic import (
    make_message,
    platform_program_messages,
    robot_program_messages,
    sweep_messages,
)
from gpr_kinematics.bags.typestore import (
    GEOMETRY_TOPIC,
    GPR_TOPICS,
    PLATFORM_STREAM_TOPICS,
    PROGRAM_TOPIC,
    ROBOT_TOPIC,
    typestore,
)
from gpr_kinematics.bags.verify import verify_bag
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import load_robot
from gpr_kinematics.robot.platform_program import load_platform_program
from gpr_kinematics.robot.program import load_program
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st
from mcap_tamper import edited, set_path, swapped_poses, tampered

STATE = '/gpr/platform_state'
EXAMPLES = int(os.environ.get('GPR_FUZZ_EXAMPLES', '12'))
SEED = os.environ.get('GPR_FUZZ_SEED')


def _failed(result: Any) -> dict[str, set[int | None]]:
    out: dict[str, set[int | None]] = {}
    for f in result.failures:
        out.setdefault(f.check, set()).add(f.sample)
    return out


@pytest.fixture(scope='module')
def sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    msgs = small_sweep()
    bag = write_bag(tmp_path_factory.mktemp('tamper') / 'sweep', msgs, {t: GPR_TOPICS[t] for t in
                                                                        dict.fromkeys(m[0] for m in msgs)})
    assert verify_bag(bag).passed
    return bag


@pytest.fixture(scope='module')
def robot_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return example_robot_bag(tmp_path_factory.mktemp('tamper') / 'robot')


def test_a_rewrite_without_an_edit_passes(sweep: Path, tmp_path: Path) -> None:
    """The independent writer itself is faithful: what fails below fails for its edit."""
    assert verify_bag(tampered(sweep, tmp_path / 'same')).passed


def test_a_marker_array_removed_mid_stream_fails(sweep: Path, tmp_path: Path) -> None:
    bag = tampered(sweep, tmp_path / 'gap', lambda topic, i, raw: None if (topic, i) == ('/gpr/markers', 13) else raw)
    assert _failed(verify_bag(bag)) == {'topic.markers_sequence': {13}}


def _types(msgs: list[tuple[str, int, bytes]]) -> dict[str, str]:
    return {t: GPR_TOPICS[t] for t in dict.fromkeys(m[0] for m in msgs)}


def _sequence(result: Any) -> Any:
    return next(c for c in result.checks if c.name == 'topic.markers_sequence')


def test_every_other_marker_array_removed_fails_at_the_first_one(sweep: Path, tmp_path: Path) -> None:
    """The sweep's record says markers_every: 1: every other MarkerArray removed (those of the odd samples) passed
    as what markers_every: 2 records; now each removed one of samples 1 to 27 fails (29, after the last MarkerArray
    left, is where a recording cut in the middle of a sample ends: not counted, as on every companion topic)."""
    bag = tampered(sweep, tmp_path / 'halved', lambda topic, i, raw: None if topic == MARKERS and i % 2 else raw)
    result = verify_bag(bag)
    assert _failed(result) == {'topic.markers_sequence': set(range(1, 29, 2))}
    check = _sequence(result)
    assert (check.checked, check.failed, check.failures[0].sample) == (30, 14, 1)
    assert 'a counter that is a multiple of the recorded markers_every = 1' in check.failures[0].detail


def test_a_recorded_markers_every_of_2_passes_and_a_gap_in_it_fails(tmp_path: Path) -> None:
    msgs = small_sweep(markers_every=2)
    assert [m[1] for m in msgs if m[0] == MARKERS] == [1_700_000_000_000_000_000 + k * 1_000_000 for k in
                                                        range(0, 30, 2)]
    bag = write_bag(tmp_path / 'every2', msgs, _types(msgs))
    assert verify_bag(bag).passed
    gap = tampered(bag, tmp_path / 'gap', lambda topic, i, raw: None if (topic, i) == (MARKERS, 3) else raw)
    assert _failed(verify_bag(gap)) == {'topic.markers_sequence': {6}}


def test_a_record_without_markers_every_infers_the_cadence_as_before(tmp_path: Path) -> None:
    """Records written before markers_every was recorded: every other MarkerArray removed is still what
    markers_every: 2 records, and passes; one removed mid-stream still fails."""
    msgs = small_sweep(markers_every=None)
    record = next(raw for topic, _, raw in msgs if topic == PROGRAM_TOPIC)
    assert b'markers_every' not in record and sum(m[0] == MARKERS for m in msgs) == 30
    bag = write_bag(tmp_path / 'old', msgs, _types(msgs))
    halved = tampered(bag, tmp_path / 'halved', lambda topic, i, raw: None if topic == MARKERS and i % 2 else raw)
    assert verify_bag(halved).passed
    gap = tampered(bag, tmp_path / 'gap', lambda topic, i, raw: None if (topic, i) == (MARKERS, 13) else raw)
    result = verify_bag(gap)
    assert _failed(result) == {'topic.markers_sequence': {13}}
    assert 'every n-th from the first marked sample' in result.failures[0].detail


def _record_edit(every: str) -> Any:
    def edit(topic: str, i: int, raw: bytes) -> bytes:
        if topic != PROGRAM_TOPIC:
            return raw
        return edited('std_msgs/msg/String', raw, lambda m: dataclasses.replace(
            m, data=m.data.replace('markers_every: 1\n', f'markers_every: {every}\n', 1)))
    return edit


def test_markers_off_the_recorded_cadence_fail(sweep: Path, tmp_path: Path) -> None:
    """The record edited to markers_every: 2 while every sample has its MarkerArray: those of the odd samples are
    not the node's (its rule: sample % markers_every == 0), to the last one."""
    assert _failed(verify_bag(tampered(sweep, tmp_path / 'every2', _record_edit('2')))) == {
        'topic.markers_sequence': set(range(1, 30, 2))}


def test_a_record_with_a_bad_markers_every_is_refused(sweep: Path, tmp_path: Path) -> None:
    result = verify_bag(tampered(sweep, tmp_path / 'every0', _record_edit('0')))
    assert set(_failed(result)) == {'topic.program', 'stream.program'}   # no record left to recompute the stream
    assert result.failures[0].detail == ("not a record of a stream: /gpr/program: markers_every = 0; allowed: an "
                                         "integer from 1 to 100000 (trajectory_node's markers_every)")


@pytest.mark.parametrize('states, markers, fails', [
    ((7, 24), (11, 23), set()),        # 24 due, the last state: its MarkerArray lost to a cut mid-sample
    ((7, 23), (11, 23), set()),        # 22 and 23 are not marked: the allowance runs to the next marked sample
    ((7, 25), (11, 23), {24}),         # 24 due, and the recording went on to 25
    ((7, 25), (11, 20), {21, 24})])    # the markers' tail removed beyond the allowance
def test_a_recording_started_late_and_cut_mid_sample_passes_with_a_recorded_markers_every(
        tmp_path: Path, states: tuple[int, int], markers: tuple[int, int], fails: set[int]) -> None:
    """markers_every: 3 recorded; the recorder's states begin at sample 7, its markers later (sample 12: 9 had one
    the recorder did not yet receive: discovery matches each topic on its own). At the end the node publishes a
    sample's messages in one tick and a cut stops every topic at once: after the last MarkerArray (21) the states may
    go on to the next marked sample (24), whose MarkerArray a cut mid-sample lost, and no further."""
    start, period = 1_700_000_000_000_000_000, 1_000_000
    span = {MARKERS: markers}
    msgs = [m for m in small_sweep(markers_every=3) if m[0] in (GEOMETRY_TOPIC, PROGRAM_TOPIC)
            or span.get(m[0], states)[0] <= (m[1] - start) // period <= span.get(m[0], states)[1]]
    assert [(m[1] - start) // period for m in msgs if m[0] == MARKERS][0] == 12
    result = verify_bag(write_bag(tmp_path / 'late', msgs, _types(msgs)))
    assert _failed(result) == ({'topic.markers_sequence': fails} if fails else {})
    assert (_sequence(result).checked, result.counts[STATE]) == (states[1] - 6, states[1] - 6)
    if fails:
        assert result.failures[0].detail.endswith(
            f'; {len(fails)} of them after the last MarkerArray (samples {min(fails)} to {max(fails)}; a recording '
            "cut in the middle of a sample lacks only the last sample's)")


#: The companion topics of a sweep and the check that counts a message missing from each.
SWEEP_COMPANIONS = {'/gpr/platform_pose': 'topic.platform_pose', '/gpr/nominal_pose': 'topic.nominal_pose',
                    '/joint_states': 'topic.joint_states', '/gpr/virtual_joints': 'topic.virtual_joints',
                    MARKERS: 'topic.markers_sequence'}


def _tail_removed(name: str, keep: int) -> Any:
    return lambda topic, i, raw: None if topic == name and i >= keep else raw


@pytest.mark.parametrize('topic', SWEEP_COMPANIONS)
@pytest.mark.parametrize('removed, fails', [
    (1, set()),                       # the last sample's: a recording cut (SIGKILL) in the middle of it
    (2, {28}),
    (20, set(range(10, 29))),
    (29, set(range(1, 29)))])         # every message after the first sample's
def test_a_companion_topic_without_its_tail_fails(sweep: Path, tmp_path: Path, topic: str, removed: int,
                                                  fails: set[int]) -> None:
    """The last messages of a companion topic removed (the metadata recounted): a state after the topic's last
    message was not counted as missing, so any tail removed passed. The node publishes all of a sample's messages
    in one tick and a cut stops every topic at once, so only the last sample's may be missing: each other state
    after the topic's last message fails, the topic and the samples named, and how many."""
    result = verify_bag(tampered(sweep, tmp_path / 'cut', _tail_removed(topic, 30 - removed)))
    assert result.counts[topic] == 30 - removed
    if not fails:
        assert result.passed, [f.line() for f in result.failures]
        return
    check = SWEEP_COMPANIONS[topic]
    assert _failed(result) == {check: set(sorted(fails)[:MAX_DETAILS])}   # the first 20 named, all counted
    failed = next(c for c in result.checks if c.name == check)
    assert (failed.topic, failed.checked, failed.failed) == (topic, 30, len(fails))
    where = 'of them after the last MarkerArray' if topic == MARKERS else "missing after the topic's last message"
    assert failed.failures[0].detail.endswith(f'; {len(fails)} {where} (samples {min(fails)} to {max(fails)}; a '
                                              "recording cut in the middle of a sample lacks only the last sample's)")




@pytest.fixture(scope='module')
def slow_sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The small sweep at 20 Hz: 30 samples over 1.45 s, the last 0.2 s (CUT_LAG) holding 5 of them."""
    msgs = small_sweep(period_ns=50_000_000)
    return write_bag(tmp_path_factory.mktemp('tamper') / 'slow', msgs, {t: GPR_TOPICS[t] for t in
                                                                         dict.fromkeys(m[0] for m in msgs)})


def _open_segment(bag: Path) -> None:
    """A recorder's unfinished segment, as a SIGKILL leaves it."""
    (bag / '.recording' / 'cut_9').mkdir(parents=True)
    (bag / '.recording' / 'cut_9' / 'cut_9.mcap').write_bytes(b'\x89MCAP0\r\n')


@pytest.mark.parametrize('topic', SWEEP_COMPANIONS)
def test_a_recording_cut_while_a_segment_was_open_may_lack_its_last_companions(slow_sweep: Path, tmp_path: Path,
                                                                               topic: str) -> None:
    """A recorder killed at 400 Hz left bags that failed verify: at a segment's close the companion topics lagged the
    states by 12-70 ms, their rest in the unfinished segment (not read). With one noted (.recording), a companion
    topic may lack the states of the last 0.2 s after its last message; beyond, and without one, they fail."""
    from gpr_kinematics.bags.ends import CUT_LAG
    assert CUT_LAG == 200_000_000   # 4 samples before the last at 20 Hz
    bag = tampered(slow_sweep, tmp_path / 'cut', _tail_removed(topic, 25))
    assert _failed(verify_bag(bag)) == {SWEEP_COMPANIONS[topic]: set(range(25, 29))}   # finished: a tail removed
    _open_segment(bag)
    result = verify_bag(bag)
    assert result.passed and result.unfinished == ['.recording/cut_9/cut_9.mcap'], [f.line() for f in result.failures]
    deeper = tampered(slow_sweep, tmp_path / 'deeper', _tail_removed(topic, 20))
    _open_segment(deeper)
    assert _failed(verify_bag(deeper)) == {SWEEP_COMPANIONS[topic]: set(range(20, 25))}   # before the last 0.2 s


def test_a_cut_recordings_companions_beyond_its_last_state_still_fail(slow_sweep: Path, tmp_path: Path) -> None:
    """Companions after the last state have no state to be checked against: a cut recording gets no more of them
    than a finished one (the states' last 5 removed, every joint position of theirs set to 1000 rad, passed with an
    8-byte '.recording' file in review); a symbolic link named .recording is no open segment."""
    bag = tampered(slow_sweep, tmp_path / 'cut', _tail_removed(STATE, 25))
    _open_segment(bag)
    assert {f.check for f in verify_bag(bag).failures} == {f'{c.replace("_sequence", "")}_extra'
                                                            for c in SWEEP_COMPANIONS.values()}
    linked = tampered(slow_sweep, tmp_path / 'linked', _tail_removed('/joint_states', 25))
    (linked / '.recording').symlink_to(tmp_path)
    assert _failed(verify_bag(linked)) == {'topic.joint_states': set(range(25, 29))}

@pytest.mark.parametrize('removed', [1, 2, 5, 29])
def test_the_states_without_their_tail_fail_by_the_companions_after_them(sweep: Path, tmp_path: Path,
                                                                        removed: int) -> None:
    """The last PlatformStates removed, their companions kept (the metadata recounted): a companion message after
    the last state was not counted, so a stream's tail (where it went wrong) could be cut from the states alone.
    A cut in the middle of a sample may lose that sample's state only: the companions of one stamp after the last
    state pass, each further one is an extra message of its topic."""
    result = verify_bag(tampered(sweep, tmp_path / 'cut', _tail_removed(STATE, 30 - removed)))
    assert result.counts[STATE] == 30 - removed
    if removed == 1:
        assert result.passed, [f.line() for f in result.failures]
        return
    names = [f'{check.replace("_sequence", "")}_extra' for check in SWEEP_COMPANIONS.values()]
    assert _failed(result) == dict.fromkeys(names, {None})
    extras = {c.name: (c.checked, c.worst) for c in result.checks if c.name in names}
    assert extras == dict.fromkeys(names, (30, removed - 1))
    assert result.failures[0].detail == (f"messages without a PlatformState of the same stamp; {removed - 1} of them "
                                         "after the last PlatformState's next sample (a recording cut in the middle "
                                         "of a sample holds at most that sample's)")


def test_a_recording_cut_after_whole_samples_passes(sweep: Path, tmp_path: Path) -> None:
    """Every topic's last 5 samples removed: a recording stopped earlier (nothing tells it from one)."""
    bag = tampered(sweep, tmp_path / 'cut', lambda topic, i, raw: None if topic not in (GEOMETRY_TOPIC, PROGRAM_TOPIC)
                   and i >= 25 else raw)
    result = verify_bag(bag)
    assert result.passed and result.counts[STATE] == 25, [f.line() for f in result.failures]



@pytest.mark.parametrize('topic', SWEEP_COMPANIONS)
def test_a_companion_topic_logged_out_of_the_order_of_its_stamps_fails(tmp_path: Path, topic: str) -> None:
    """The recorder's log times of two messages of a companion topic swapped, their header stamps kept: the topic
    is matched to the states by stamp, so it passed (the state topic's own order is stream.stamps). The node
    publishes a topic in order and the recorder logs it so: the stamps going back in log order fail."""
    msgs = small_sweep()
    a, b = [k for k, m in enumerate(msgs) if m[0] == topic][10:12]
    msgs[a], msgs[b] = (topic, msgs[b][1], msgs[a][2]), (topic, msgs[a][1], msgs[b][2])
    result = verify_bag(write_bag(tmp_path / 'order', msgs, _types(msgs)))
    check = f'{SWEEP_COMPANIONS[topic].replace("_sequence", "")}_order'
    assert _failed(result) == {check: {None}}
    start = 1_700_000_000_000_000_000
    assert result.failures[0].detail == (
        f'header stamps that go back in log-time order (the first: message 11 of the topic, stamped '
        f'{start + 10_000_000} ns, logged after one stamped {start + 11_000_000} ns)')


@pytest.mark.parametrize('topic', [t for t in SWEEP_COMPANIONS if t != MARKERS])
def test_a_companion_topic_recorded_without_a_message_fails_but_at_the_ends(sweep: Path, tmp_path: Path,
                                                                             topic: str) -> None:
    """Every message of the topic removed, the topic left listed: every state but the first and the last fails
    (as the markers do where they were due: a recording started and cut in the middle of a sample)."""
    result = verify_bag(tampered(sweep, tmp_path / 'empty', _tail_removed(topic, 0)))
    check = next(c for c in result.checks if c.failed)
    assert (result.counts[topic], check.name, check.topic, check.failed) == (0, SWEEP_COMPANIONS[topic], topic, 28)
    assert {c.name for c in result.checks if c.failed} == {check.name}
    assert [f.sample for f in check.failures] == list(range(1, 21))
    assert check.failures[0].detail.endswith("; 28 missing of a topic without a message (samples 1 to 28; a "
                                             "recording cut in the middle of a sample lacks only the last sample's)")


ROBOT_STATE, WAFER_POSE = '/gpr/robot_state', '/gpr/wafer_pose'
#: What a RobotState missing fails (the joint states' arm joints are those of the RobotState of the stamp).
ROBOT_STATE_CHECKS = ('robot.structure', 'robot.wafer_position', 'robot.wafer_orientation', 'robot.blade',
                      'robot.naive_wafer_error', 'topic.joint_states')


@pytest.mark.parametrize('topic, checks', [(ROBOT_STATE, ROBOT_STATE_CHECKS), (WAFER_POSE, ('topic.wafer_pose',))])
@pytest.mark.parametrize('removed, fails', [(1, set()), (2, {285}), (286, set(range(1, 286)))])
def test_a_robot_topic_without_its_tail_fails(robot_bag: Path, tmp_path: Path, topic: str, checks: tuple[str, ...],
                                              removed: int, fails: set[int]) -> None:
    """The robot topics of a robot program's 287 samples likewise: the last sample's RobotState or wafer pose lost
    to a cut passes (its joint states then carry arm joints no RobotState gives: their rods are checked), two or
    all but the first removed fail at every state but the last (20 named, all counted)."""
    result = verify_bag(tampered(robot_bag, tmp_path / 'cut', _tail_removed(topic, 287 - removed)))
    if not fails:
        assert result.passed, [f.line() for f in result.failures]
        return
    # the wafer poses after the last RobotState left are more than a cut mid-sample leaves (all but the first)
    wafer_extra = {'topic.wafer_pose_extra': {None}} if topic == ROBOT_STATE else {}
    assert _failed(result) == dict.fromkeys(checks, set(sorted(fails)[:MAX_DETAILS])) | wafer_extra
    assert {(c.name, c.failed if c.name not in wafer_extra else c.worst) for c in result.checks if c.failed} == {
        (name, len(fails)) for name in checks} | {(name, removed - 1) for name in wafer_extra}
    first = next(c for c in result.checks if c.name == checks[0]).failures[0]
    assert (first.topic, first.sample) == (topic, min(fails))
    assert first.detail.endswith(f"; {len(fails)} missing after the topic's last message (samples {min(fails)} to "
                                 f"{max(fails)}; a recording cut in the middle of a sample lacks only the last "
                                 "sample's)")


def test_a_wafer_pose_topic_recorded_without_a_message_fails_but_at_the_ends(robot_bag: Path, tmp_path: Path) -> None:
    """An emptied companion topic had no columns to match and verify raised KeyError; now it fails at every state
    but the first and the last."""
    result = verify_bag(tampered(robot_bag, tmp_path / 'empty', _tail_removed(WAFER_POSE, 0)))
    assert {(c.name, c.failed) for c in result.checks if c.failed} == {('topic.wafer_pose', 285)}
    assert result.failures[0].line() == (
        'FAIL topic.wafer_pose on /gpr/wafer_pose at sample 1: value inf > limit 1e-12 (inf = no message with the '
        'stamp and frame of this RobotState; 285 missing of a topic without a message (samples 1 to 285; a recording '
        "cut in the middle of a sample lacks only the last sample's))")


def _robot_then_platform(tmp_path: Path) -> Path:
    """A robot program's 287 samples, then a platform program's 45 (counters 287 to 331, its record's first sample
    287): an idle node runs two gpr/run_program goals, the second a platform program, without RobotStates."""
    robot = load_robot()
    msgs = robot_program_messages(robot, load_program(config_path('programs/example_robot_program.yaml')), 10.0)

    def later(topic: str, t: int, raw: bytes) -> tuple[str, int, bytes]:
        if topic == STATE:
            raw = edited(GPR_TOPICS[topic], raw, lambda m: dataclasses.replace(m, sample=m.sample + 287))
        elif topic == PROGRAM_TOPIC:
            raw = edited(GPR_TOPICS[topic], raw, lambda m: dataclasses.replace(
                m, data=m.data.replace('first_sample: 0\n', 'first_sample: 287\n', 1)))
        return topic, t, raw

    platform = platform_program_messages(load_platform_program(config_path('programs/example_stations.yaml')),
                                         robot.config, 10.0, start_ns=msgs[-1][1] + 100_000_000,
                                         topics=(*PLATFORM_STREAM_TOPICS, PROGRAM_TOPIC))
    return write_bag(tmp_path / 'robot_then_platform', msgs + [later(*m) for m in platform], dict(GPR_TOPICS))


def test_robot_states_are_due_only_in_a_robot_program(tmp_path: Path) -> None:
    """With the records (gpr/program) a RobotState is due for the samples of a robot program only: a platform
    program after it has none, and the recording's last sample is the platform program's. So the robot program's
    last RobotState removed fails (no cut lost it: the recording went on), and so does the topic emptied (listed, no
    message: skipped as 'no robot states' before), at every robot program sample but the first."""
    bag = _robot_then_platform(tmp_path)
    result = verify_bag(bag)
    assert result.passed, [f.line() for f in result.failures]
    assert (result.counts[STATE], result.counts[ROBOT_STATE]) == (353, 287)   # and 66 samples of 6.5 s at 10 Hz
    last = verify_bag(tampered(bag, tmp_path / 'last', _tail_removed(ROBOT_STATE, 286)))
    assert _failed(last) == dict.fromkeys(ROBOT_STATE_CHECKS, {286})
    empty = verify_bag(tampered(bag, tmp_path / 'empty', _tail_removed(ROBOT_STATE, 0)))
    assert empty.counts[ROBOT_STATE] == 0
    structure = next(c for c in empty.checks if c.name == 'robot.structure')
    assert (structure.failed, structure.failures[0].sample, structure.failures[-1].sample) == (286, 1, 20)
    assert structure.failures[0].detail == (
        'the robot states topic is recorded without a message; a sample of a robot program (gpr/program) without '
        'its RobotState (the first and the last state are not counted: a recording started or cut in the middle of '
        'a sample)')


def test_robot_states_at_a_platform_programs_samples_fail_structure(tmp_path: Path) -> None:
    """A platform stream publishes no RobotState: the robot program's first 40 RobotStates copied onto the platform
    program's samples (stamps and counters of theirs, frame and names right) passed robot.structure there, and with
    the rods' own wafer they passed every check (a reviewer's forged sweep). Now robot.structure fails at each."""
    bag = _robot_then_platform(tmp_path)
    msgs = messages_of(bag)
    ts = typestore()
    sample = {m[1]: ts.deserialize_cdr(m[2], GPR_TOPICS[STATE]).sample for m in msgs if m[0] == STATE}
    platform = sorted(t for t, n in sample.items() if n >= 287)[:40]
    robot_states = [m for m in msgs if m[0] == ROBOT_STATE][:40]
    forged = [(ROBOT_STATE, t, edited(GPR_TOPICS[ROBOT_STATE], raw, lambda m, t=t: dataclasses.replace(
        m, sample=sample[t],
        header=dataclasses.replace(m.header, stamp=dataclasses.replace(m.header.stamp, sec=t // 10**9,
                                                                        nanosec=t % 10**9)))))
              for (_, _, raw), t in zip(robot_states, platform, strict=True)]
    result = verify_bag(write_bag(tmp_path / 'forged', msgs + forged, dict(GPR_TOPICS)))
    structure = next(c for c in result.checks if c.name == 'robot.structure')
    assert structure.failed == 40 and [f.sample for f in structure.failures] == list(range(287, 307))


def _record(msgs: list[tuple[str, int, bytes]]) -> tuple[str, int, bytes]:
    return next(m for m in msgs if m[0] == PROGRAM_TOPIC)


@pytest.mark.parametrize('other, diff', [
    (lambda: _record(small_sweep(markers_every=None))[2], 'markers_every (1 and absent)'),
    (lambda: edited('std_msgs/msg/String', _record(small_sweep())[2],
                    lambda m: dataclasses.replace(m, data=m.data.replace('loop: false', 'loop: true'))),
     'loop (False and True)'),
    (lambda: _record(sweep_messages(tilt_step=math.radians(0.5), azimuth_step=math.radians(60.0)))[2],
     'samples (30 and 54), sweep')])
def test_a_second_record_of_a_first_sample_that_differs_fails(tmp_path: Path, other: Any, diff: str) -> None:
    """A record of sample 0 appended after the stream: which one governed was an accident of order, so every other
    MarkerArray removed passed with a record without markers_every appended. Two records of one first sample that
    differ now fail topic.program, naming the sample and the difference (the node publishes one per first sample)."""
    msgs = [m for m in small_sweep() if not (m[0] == MARKERS and (m[1] // 1_000_000) % 2)]
    result = verify_bag(write_bag(tmp_path / 'two', msgs + [(PROGRAM_TOPIC, msgs[-1][1] + 1, other())], _types(msgs)))
    program = next(c for c in result.checks if c.name == 'topic.program')
    assert (program.checked, program.failed) == (2, 1)
    assert program.failures[0].detail == (f'two records of the stream from sample 0 differ in {diff}; allowed: one '
                                          'record per first sample (the first one read is used)')
    assert _failed(result)['topic.markers_sequence'] == set(range(1, 29, 2))   # the first record's markers_every: 1



def _record_edited(old: str, new: str, count: int = 1) -> Any:
    """A message edit that replaces the first ``old`` by ``new`` in the ``count``-th record of the bag (1: its first;
    0: every ``old`` of every record)."""
    def edit(topic: str, i: int, raw: bytes) -> bytes:
        if topic != PROGRAM_TOPIC or count and i != count - 1:
            return raw
        return edited('std_msgs/msg/String', raw, lambda m: dataclasses.replace(
            m, data=m.data.replace(old, new, 1 if count else -1)))
    return edit


def _program_details(result: Any) -> list[str]:
    return [f.detail for f in result.failures if f.check == 'topic.program']


def test_a_looping_sweeps_record_edited_to_loop_false_fails_naming_loop(tmp_path: Path) -> None:
    """A sweep streamed with loop: true (75 samples of its 30) passes; its record edited to loop: false failed only
    stream.program at samples 30 to 74 ('no recorded stream covers this sample'), not naming the record's loop. Now
    topic.program names the field, its value and what the recording shows."""
    msgs = small_sweep(loop=75)
    bag = write_bag(tmp_path / 'looped', msgs, _types(msgs))
    assert verify_bag(bag).passed
    result = verify_bag(tampered(bag, tmp_path / 'noloop', _record_edited('loop: true', 'loop: false')))
    assert _program_details(result) == [
        'the sweep from sample 0 says loop = false and 30 samples; the recording has 45 samples after them (30 to 74) '
        'and no record of a stream from them, as a looping stream has']
    assert _failed(result) == {'topic.program': {None}, 'stream.program': set(range(30, 50))}   # 20 with details


@pytest.mark.parametrize('count, detail', [
    (1, 'the robot_program from sample 0 says loop = true; the recording has a stream from sample 287 after it (a '
        'looping stream runs until the node stops)'),
    (2, "the platform_program from sample 287 says loop = true; only the node's start-up stream loops, and it starts "
        "at sample 0 (a gpr/run_program goal's stream never loops)")])
def test_a_record_edited_to_loop_true_fails_where_the_recording_shows_no_loop(tmp_path: Path, count: int,
                                                                             detail: str) -> None:
    """Only the node's start-up stream loops (loop and no goal): it starts at sample 0 and never ends, so no other
    stream follows it. A robot program followed by a platform stream, either record edited to loop: true, passed."""
    bag = _robot_then_platform(tmp_path)
    result = verify_bag(tampered(bag, tmp_path / 'loop', _record_edited('loop: false', 'loop: true', count)))
    assert (_failed(result), _program_details(result)) == ({'topic.program': {None}}, [detail])


def test_a_sweeps_rate_move_time_and_a_loop_the_recording_ends_before_are_not_determined(sweep: Path,
                                                                                        tmp_path: Path) -> None:
    """What no recording determines passes when edited (docs/bags.md, *What a record's fields are checked against*):
    a sweep's samples do not depend on the rate, the stamps are the node's clock at publishing, not the plan's times;
    a sweep does not use move_time; a looping stream stopped by a signal at its last sample is recorded as one that
    does not loop."""
    for old, new in (('rate: 1000.0', 'rate: 10.0'), ('move_time: 2.0', 'move_time: 9.0'),
                     ('loop: false', 'loop: true')):
        result = verify_bag(tampered(sweep, tmp_path / old.split(':')[0], _record_edited(old, new)))
        assert result.passed, (old, [f.line() for f in result.failures])


def test_a_record_topic_recorded_without_a_message_reads_as_a_recording_without_records(tmp_path: Path) -> None:
    """gpr/program listed in the metadata without a message (the record removed) raised KeyError: 'data' (a
    traceback from gpr verify); it reads as a recording of a node before the records: both checks skipped, saying
    so (the same limit as the topic removed whole)."""
    msgs = [m for m in small_sweep() if m[0] != PROGRAM_TOPIC]
    result = verify_bag(write_bag(tmp_path / 'norecord', msgs, {**_types(msgs), PROGRAM_TOPIC: 'std_msgs/msg/String'}))
    assert result.passed and result.counts[PROGRAM_TOPIC] == 0, [f.line() for f in result.failures]
    assert {c.name: c.skipped for c in result.checks if c.name in ('topic.program', 'stream.program')} == dict.fromkeys(
        ('topic.program', 'stream.program'), 'the record topic (gpr/program) is recorded without a message: as a '
        'recording of an older node')


def test_the_same_record_recorded_twice_passes(tmp_path: Path) -> None:
    """The same latched record received twice (a replay recorded again, a copy in a later segment) is one record."""
    msgs = small_sweep()
    bag = write_bag(tmp_path / 'twice', msgs + [(PROGRAM_TOPIC, msgs[-1][1] + 1, _record(msgs)[2])], _types(msgs),
                    max_bag_duration=0.01)
    result = verify_bag(bag)
    assert result.passed, [f.line() for f in result.failures]
    assert (result.counts[PROGRAM_TOPIC], len(result.files) > 1) == (2, True)


def test_every_marker_array_removed_fails_from_the_first_one_due(sweep: Path, tmp_path: Path) -> None:
    """The markers topic recorded, its every message removed: 'no markers in the bag' skipped the markers and the bag
    passed. The record says markers_every: 1, so samples 1 to 28 fail (0 and 29, the first and last state, are where
    a recording started or cut in the middle of a sample ends, not counted, as on every companion topic)."""
    result = verify_bag(tampered(sweep, tmp_path / 'none', lambda topic, i, raw: None if topic == MARKERS else raw))
    assert result.counts[MARKERS] == 0 and set(_failed(result)) == {'topic.markers_sequence'}
    check = _sequence(result)
    assert (check.checked, check.failed, check.failures[0].sample) == (30, 28, 1)
    assert result.failures[0].detail.startswith('the markers topic is recorded without a message; a sample of the '
                                                "markers' sequence (a counter that is a multiple of the recorded "
                                                'markers_every = 1)')


@pytest.mark.parametrize('every, states, fails', [
    (10, (1, 9), set()),          # stopped before the first marked sample after 0, which it started after
    (100, (1, 29), set()),        # a stream shorter than markers_every: sample 0's markers only
    (5, (6, 10), set()),          # 10 due, the last state: its MarkerArray may be lost to a cut mid-sample
    (5, (6, 11), {10}),           # 10 due between the first and the last state
    (None, (1, 29), set())])      # no recorded markers_every: nothing is known to be due
def test_an_empty_markers_topic_fails_only_where_markers_were_due(tmp_path: Path, every: int | None,
                                                                   states: tuple[int, int], fails: set[int]) -> None:
    start, period = 1_700_000_000_000_000_000, 1_000_000
    msgs = [m for m in small_sweep(markers_every=every) if m[0] in (GEOMETRY_TOPIC, PROGRAM_TOPIC)
            or (m[0] != MARKERS and states[0] <= (m[1] - start) // period <= states[1])]
    result = verify_bag(write_bag(tmp_path / 'empty', msgs, {**_types(msgs), MARKERS: GPR_TOPICS[MARKERS]}))
    assert (result.counts[MARKERS], result.counts[STATE]) == (0, states[1] - states[0] + 1)
    assert _failed(result) == ({'topic.markers_sequence': fails} if fails else {})


def test_a_recording_without_the_markers_topic_passes(sweep: Path, tmp_path: Path) -> None:
    """A recorder whose topics leave out gpr/markers (its topic list is a parameter): nothing says markers are due."""
    msgs = [m for m in small_sweep() if m[0] != MARKERS]
    result = verify_bag(write_bag(tmp_path / 'without', msgs, _types(msgs)))
    assert result.passed and MARKERS not in result.counts
    assert next(c for c in result.checks if c.name == 'topic.markers').skipped == 'no markers in the bag'


def test_a_claimed_serialization_format_fails(sweep: Path, tmp_path: Path) -> None:
    def json(info: dict[str, Any]) -> None:
        for t in info['topics_with_message_count']:
            t['topic_metadata']['serialization_format'] = 'json'

    result = verify_bag(tampered(sweep, tmp_path / 'json', metadata=json))
    assert set(_failed(result)) == {'bag.metadata'}
    assert any("serialization_format in sweep_0.mcap: metadata.yaml says 'json', the files hold 'cdr'" in f.detail
               for f in result.failures)



def test_a_claimed_offered_qos_fails(sweep: Path, tmp_path: Path) -> None:
    """The latched record topic listed as volatile in metadata.yaml (re-signed), its MCAP channel still transient
    local: the QoS listed was not compared with the files' (a replay would not latch the record)."""
    def volatile(info: dict[str, Any]) -> None:
        for t in info['topics_with_message_count']:
            if t['topic_metadata']['name'] == PROGRAM_TOPIC:
                t['topic_metadata']['offered_qos_profiles'][0]['durability'] = 'volatile'

    result = verify_bag(tampered(sweep, tmp_path / 'volatile', metadata=volatile))
    assert set(_failed(result)) == {'bag.metadata'}
    details = [f.detail for f in result.failures]
    assert len(details) == 1 and details[0].startswith('offered_qos_profiles in sweep_0.mcap: metadata.yaml says [{')
    assert "'durability': 'volatile'" in details[0].split('the files hold')[0]
    assert "'durability': 'transient_local'" in details[0].split('the files hold')[1]



@pytest.mark.parametrize('copies', [2, 1000])
def test_a_segment_listed_more_than_once_is_refused_before_reading(sweep: Path, tmp_path: Path, copies: int) -> None:
    """A 31 kB metadata.yaml listing one file 1000 times had the bag read 1000 times (4 GB, then a traceback)."""
    def repeat(info: dict[str, Any]) -> None:
        info['relative_file_paths'] = info['relative_file_paths'] * copies

    from gpr_kinematics.bags.errors import BagError

    bag = tampered(sweep, tmp_path / 'dup', metadata=repeat)
    with pytest.raises(BagError, match=f"relative_file_paths lists 'sweep_0.mcap' {copies} times; allowed: each "
                                       'segment file once'):
        verify_bag(bag)

@pytest.mark.parametrize('fmt, mode', [('zstd', 'file'), ('zstd', 'message'), ('', 'FILE')])
def test_a_claimed_file_compression_fails(sweep: Path, tmp_path: Path, fmt: str, mode: str) -> None:
    def compressed(info: dict[str, Any]) -> None:
        info['compression_format'], info['compression_mode'] = fmt, mode

    result = verify_bag(tampered(sweep, tmp_path / 'zstd', metadata=compressed))
    assert set(_failed(result)) == {'bag.metadata'}
    assert any('the files are not compressed' in f.detail for f in result.failures)


def test_an_edited_robot_description_fails_against_its_recorded_program(robot_bag: Path, tmp_path: Path) -> None:
    """arm1's default branch edited from right to left: every joint and wafer still agrees with forward kinematics,
    but the recorded program, planned again on the edited robot, puts arm1's elbow the other way."""
    def edit(topic: str, i: int, raw: bytes) -> bytes:
        if topic != ROBOT_TOPIC:
            return raw
        return edited('std_msgs/msg/String', raw, lambda m: dataclasses.replace(
            m, data=m.data.replace('branch: right', 'branch: left', 1)))

    result = verify_bag(tampered(robot_bag, tmp_path / 'branch', edit))
    failed = _failed(result)
    assert 'stream.program' in failed and set(failed) <= {'stream.program', 'topic.program'}, failed
    check = next(c for c in result.checks if c.name == 'stream.program')
    assert check.failed > 10 and check.worst > 0.1       # radians: the elbow on the other side (or no plan: inf)


def test_a_station_renamed_in_the_record_or_in_a_robot_state_fails_naming_both_names(robot_bag: Path,
                                                                                      tmp_path: Path) -> None:
    """Every RobotState names the station it holds (station, the waypoint's name), which nothing compared: the
    record's station 'aligner' renamed 'aligner_2' (in its steps too, so it parses) passed, and so did one
    RobotState's station edited. Both fail now, at the samples that hold it, naming the record's and the recorded
    name."""
    def station(topic: str, i: int, raw: bytes) -> bytes:
        if topic != ROBOT_STATE or i != 100:
            return raw
        return edited(GPR_TOPICS[topic], raw, lambda m: dataclasses.replace(m, station='load_port_1'))

    record = verify_bag(tampered(robot_bag, tmp_path / 'record', _record_edited('aligner', 'aligner_2', count=0)))
    assert (_failed(record), _program_details(record)) == (
        {'topic.program': {None}, 'stream.program': set(range(100, 110)) | set(range(117, 122))},
        ["the robot_program from sample 0 names waypoint 6 'aligner_2'; its RobotStates (station) name it 'aligner' "
         "at 10 samples (100 to 109)", "the robot_program from sample 0 names waypoint 9 'aligner_2'; its RobotStates "
         "(station) name it 'aligner' at 5 samples (117 to 121)"])
    state = verify_bag(tampered(robot_bag, tmp_path / 'state', station))
    assert (_failed(state), _program_details(state)) == (
        {'topic.program': {None}, 'stream.program': {100}},
        ["the robot_program from sample 0 names waypoint 6 'aligner'; its RobotStates (station) name it "
         "'load_port_1' at sample 100"])


def test_the_arm_in_use_edited_in_a_robot_state_fails_naming_both_arms(robot_bag: Path, tmp_path: Path) -> None:
    """A RobotState's arm (the arm in use) was compared with nothing of the program: only the wafer and blade poses
    computed with the named arm's joints caught an edit, so a forger who recomputed them passed. The recomputed
    stream's arm is compared now, and topic.program names both."""
    seen: dict[str, str] = {}

    def arm(topic: str, i: int, raw: bytes) -> bytes:
        if topic != ROBOT_STATE or i != 100:
            return raw

        def swap(m: Any) -> Any:
            seen['was'] = m.arm
            return dataclasses.replace(m, arm='arm2' if m.arm == 'arm1' else 'arm1')
        return edited(GPR_TOPICS[topic], raw, swap)

    result = verify_bag(tampered(robot_bag, tmp_path / 'arm', arm))
    failed = _failed(result)
    other = 'arm2' if seen['was'] == 'arm1' else 'arm1'
    assert failed['stream.program'] == {100} and failed['topic.program'] == {None}, failed
    assert _program_details(result) == [f"the robot_program from sample 0 uses the arm '{seen['was']}'; its "
                                        f"RobotStates (arm) name it '{other}' at sample 100"]


@pytest.mark.parametrize('field, value', [('commanded_tilt', 0.002), ('commanded_tilt', math.nan),
                                          ('commanded_azimuth', math.inf), ('commanded_azimuth', 1.0)])
def test_a_changed_commanded_value_fails(sweep: Path, tmp_path: Path, field: str, value: float) -> None:
    def edit(topic: str, i: int, raw: bytes) -> bytes:
        if topic != STATE or i != 8:    # a tilted sample (the azimuth of an untilted one is not the platform's)
            return raw
        return edited(GPR_TOPICS[STATE], raw, lambda m: dataclasses.replace(m, **{field: value}))

    failed = _failed(verify_bag(tampered(sweep, tmp_path / 'cmd', edit)))
    assert failed == {'state.commanded': {8}, 'stream.program': {8}}, failed


def test_an_edited_embedded_schema_fails(sweep: Path, tmp_path: Path) -> None:
    def schema(name: str, text: str) -> str:
        return text.replace('float64 residual', 'float32 residual') if name.endswith('PlatformState') else text

    result = verify_bag(tampered(sweep, tmp_path / 'schema', schema=schema))
    assert set(_failed(result)) == {'bag.schemas'}
    (failure,) = result.failures
    assert "gpr_interfaces/msg/PlatformState embedded in sweep_0.mcap differs from the package's" in failure.detail
    assert "'float32 residual', the package's 'float64 residual'" in failure.detail



def _volatile(topic: str, meta: dict[str, str]) -> dict[str, str]:
    return {**meta, 'offered_qos_profiles': meta['offered_qos_profiles'].replace('transient_local', 'volatile')}


@pytest.mark.parametrize('topic, edit, ids, differ', [
    (STATE, {'schema': swapped_poses}, (8, 9), 'embedded definition'),
    (GEOMETRY_TOPIC, {'channel': _volatile}, (8, 9), "metadata 'offered_qos_profiles'"),
])
def test_a_second_channel_of_a_topic_that_differs_is_refused(sweep: Path, tmp_path: Path, topic: str,
                                                            edit: dict[str, Any], ids: tuple[int, int],
                                                            differ: str) -> None:
    """The messages on a channel whose definition swaps pose and nominal_pose (or which offers the latched geometry
    volatile), an empty second channel of the topic with the package's definition and QoS (re-signed): the reader
    kept one definition and one QoS per topic, the last channel's, and read the messages of both, so verify passed
    while an independent decoder (mcap_ros2) read every state's pose as its nominal pose. rosbag2 writes one channel
    per topic: two that differ are refused, both named; an identical twin reads alike and passes."""
    from gpr_kinematics.bags.errors import BagError

    bag = tampered(sweep, tmp_path / 'twin', twin=topic, **edit)
    with pytest.raises(BagError) as info:
        verify_bag(bag)
    count = 30 if topic == STATE else 1
    assert str(info.value) == (f"{bag / 'sweep_0.mcap'}: topic {topic!r} has two channels (ids {ids[0]} and "
                               f'{ids[1]}, with {count} and 0 messages) that differ in their {differ}; allowed: one '
                               'channel per topic (rosbag2 writes one), or channels alike in type, definition, '
                               'encoding and metadata')
    assert verify_bag(tampered(sweep, tmp_path / 'alike', twin=topic)).passed

# -- the fuzz ---------------------------------------------------------------------------------------------------------

def _leaves(msg: Any, prefix: list[str | int], template: str) -> list[tuple[list[str | int], str]]:
    """Every numeric field of a message instance, with its concrete path and its template (``markers[].id``)."""
    out: list[tuple[list[str | int], str]] = []
    for f in dataclasses.fields(msg):
        if f.name == '__msgtype__':
            continue
        value, name = getattr(msg, f.name), f'{template}{f.name}'
        if dataclasses.is_dataclass(value):
            out += _leaves(value, [*prefix, f.name], name + '.')
        elif isinstance(value, np.ndarray) and value.dtype.kind in 'fiub':
            out += [([*prefix, f.name, k], name) for k in range(value.size)]
        elif isinstance(value, list) and value and dataclasses.is_dataclass(value[0]):
            for k, item in enumerate(value):
                out += _leaves(item, [*prefix, f.name, k], name + '[].')
        elif isinstance(value, (bool, int, float)):
            out.append(([*prefix, f.name], name))
    return out


def _changed(value: Any, how: float) -> Any:
    if isinstance(value, (bool, np.bool_)):
        return not value
    if isinstance(value, (int, np.integer)):
        return int(value) + 1000
    return float(value) + how if math.isfinite(how) else how


@settings(max_examples=EXAMPLES, deadline=None, derandomize=SEED is None, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@seed(int(SEED or 0))
@given(data=st.data())
def test_tampered_bags_never_pass(sweep: Path, robot_bag: Path, tmp_path_factory: pytest.TempPathFactory,
                                  data: st.DataObject) -> None:
    src = data.draw(st.sampled_from([sweep, robot_bag]), label='bag')
    kind = data.draw(st.sampled_from(['number', 'drop', 'schema']), label='edit')
    dst = tmp_path_factory.mktemp('fuzz') / 'bag'
    from gpr_kinematics.bags.reader import read_bag
    from gpr_kinematics.bags.typestore import typestore

    topics = {k: t for k, t in read_bag(src).topics.items() if len(t) and t.msgtype != 'std_msgs/msg/String'}
    topic = data.draw(st.sampled_from(sorted(topics)), label='topic')
    index = data.draw(st.integers(1, len(topics[topic]) - 2), label='message')   # inside the stream
    if kind == 'schema':
        msgtype = topics[topic].msgtype
        lines = [k for k, line in enumerate(line for line in ''.join(typestore().generate_msgdef(
            msgtype, ros_version=2)[0]).splitlines()) if line and not line.startswith(('#', '=', 'MSG'))]
        k = data.draw(st.sampled_from(lines), label='line')

        def schema(name: str, text: str) -> str:
            if name != msgtype:
                return text
            rows = text.splitlines()
            rows[k] = rows[k].replace('float64', 'float32', 1) if 'float64' in rows[k] else rows[k] + '_x'
            return '\n'.join(rows) + ('\n' if text.endswith('\n') else '')

        bag = tampered(src, dst, schema=schema)
    elif kind == 'drop':
        bag = tampered(src, dst, lambda t, i, raw: None if (t, i) == (topic, index) else raw)
    else:
        msgtype = topics[topic].msgtype
        msg = typestore().deserialize_cdr(topics[topic].raw[index], msgtype)
        checked = [(path, name) for path, name in _leaves(msg, [], '') if rule_of(msgtype, name) is not None
                   and rule_of(msgtype, name)[0] == 'checked']
        path, name = data.draw(st.sampled_from(checked), label='field')
        how = data.draw(st.sampled_from([1e-6, 1e-3, 1.0, math.nan, math.inf]), label='change')
        value = msg
        for p in path:
            value = value[p] if isinstance(p, int) else getattr(value, p)
        new = set_path(msg, path, _changed(value, how))

        bag = tampered(src, dst, lambda t, i, raw: bytes(typestore().serialize_cdr(new, msgtype))
                       if (t, i) == (topic, index) else raw)
    result = verify_bag(bag)
    assert not result.passed, (kind, topic, index)
    assert numeric_fields(topics[topic].msgtype)   # every recorded type has its fields placed (bags/coverage.py)


def _controller_joint_states(stamps: list[int], velocities: bool = True) -> list[tuple[str, int, bytes]]:
    """``joint_states`` of the robot's controller (robot_simulator_node: every joint, positions and velocities,
    frame ''), logged at their stamps: the example robot's rods at 0.254 m and its arms' nine joints."""
    names = ['rod_1', 'rod_2', 'rod_3', 'arm1_shoulder', 'arm1_elbow', 'arm1_wrist', 'arm2_shoulder', 'arm2_elbow',
             'arm2_wrist', 'arm2_hand']
    out = []
    for t in stamps:
        header = make_message('std_msgs/msg/Header', stamp=make_message(
            'builtin_interfaces/msg/Time', sec=t // 10**9, nanosec=t % 10**9), frame_id='')
        msg = make_message(GPR_TOPICS['/joint_states'], header=header, name=names,
                           position=np.full(len(names), 0.254), velocity=np.zeros(len(names) if velocities else 0))
        out.append(('/joint_states', t, bytes(typestore().serialize_cdr(msg, GPR_TOPICS['/joint_states']))))
    return out


@pytest.mark.parametrize('velocities, fails', [(True, {}), (False, {'topic.joint_states_extra': {None},
                                                                     'topic.joint_states_order': {None}})])
def test_a_controllers_joint_states_around_the_stream_pass(tmp_path: Path, velocities: bool,
                                                          fails: dict[str, set[None]]) -> None:
    """The offline loop records joint_states beside the robot simulator, which holds the robot there at 10 Hz before
    and after a stream (and one message may come between the stream's first samples, stamped later than the next):
    its bag failed topic.joint_states_extra with every held state after the sweep. A controller's messages carry
    velocities, the stream's positions only: those are not the stream's. The same messages without velocities fail."""
    start, period = 1_700_000_000_000_000_000, 1_000_000
    msgs = small_sweep()
    held = [start - 200_000_000, start - 100_000_000, start + period * 5 // 2] + \
        [start + 29 * period + k * 100_000_000 for k in range(1, 6)]
    extra = _controller_joint_states(held, velocities)
    before, inside, after = extra[:2], extra[2:3], extra[3:]
    second = next(k for k, m in enumerate(msgs) if m[0] == '/joint_states' and m[1] == start + period)
    msgs = before + msgs[:second + 1] + [(inside[0][0], start + period + 1, inside[0][2])] + msgs[second + 1:] + after
    result = verify_bag(write_bag(tmp_path / 'loop', msgs, _types(msgs)))
    assert result.counts['/joint_states'] == 30 + 8
    assert _failed(result) == fails, [f.line() for f in result.failures]
    if fails:
        extras = next(c for c in result.checks if c.name == 'topic.joint_states_extra')
        # one inside, and the whole sweep recorded (its records' first and last samples): all 5 after the last
        # state and the 2 before the first (the old rule let all but one after it and all before it pass)
        assert (extras.checked, extras.worst) == (31 + 5 + 2, 1 + 5 + 2)
        assert result.failures[1].detail == (
            f'header stamps that go back in log-time order (the first: message 5 of the topic, stamped '
            f'{start + 2 * period} ns, logged after one stamped {start + period * 5 // 2} ns)')


@pytest.mark.parametrize('frame', ['', 'gpr_base'])
def test_a_controllers_joint_state_at_a_samples_stamp_claims_nothing_beside_the_streams(tmp_path: Path,
                                                                                         frame: str) -> None:
    """A robot simulator under a simulated clock in steps holds its state at a step, the stamp of a stream's sample
    (the rods at 0.3 m, zero velocities, logged after the stream's): beside the stream's message of that stamp it is
    the controller's and claims nothing (it failed topic.joint_states_extra, and the simulator's honest recording
    with it); in place of the stream's message it is checked as the stream's and fails."""
    start, period = 1_700_000_000_000_000_000, 1_000_000
    t = start + 10 * period
    msgs = small_sweep()
    k = next(k for k, m in enumerate(msgs) if m[0] == '/joint_states' and m[1] == t)
    header = make_message('std_msgs/msg/Header', stamp=make_message(
        'builtin_interfaces/msg/Time', sec=t // 10**9, nanosec=t % 10**9), frame_id=frame)
    msg = make_message(GPR_TOPICS['/joint_states'], header=header, name=['rod_1', 'rod_2', 'rod_3'],
                       position=np.full(3, 0.3), velocity=np.zeros(3))
    held = ('/joint_states', t, bytes(typestore().serialize_cdr(msg, GPR_TOPICS['/joint_states'])))
    beside = msgs[:k + 1] + [held] + msgs[k + 1:]
    result = verify_bag(write_bag(tmp_path / 'beside', beside, _types(beside)))
    assert result.passed, [f.line() for f in result.failures]
    instead = msgs[:k] + [held] + msgs[k + 1:]
    result = verify_bag(write_bag(tmp_path / 'instead', instead, _types(instead)))
    assert {c for c, samples in _failed(result).items() if 10 in samples} == {'topic.joint_states'}


def _shifted(topic: str, raw: bytes, shift: int, change: Any) -> bytes:
    """The message ``raw`` of ``topic`` stamped ``shift`` ns later, then ``change``d."""
    def edit(m: Any) -> Any:
        t = m.header.stamp.sec * 10**9 + m.header.stamp.nanosec + shift
        stamp = dataclasses.replace(m.header.stamp, sec=t // 10**9, nanosec=t % 10**9)
        return change(dataclasses.replace(m, header=dataclasses.replace(m.header, stamp=stamp)))
    return edited(GPR_TOPICS[topic], raw, edit)


@pytest.mark.parametrize('shift', [1_000_000, 3600 * 10**9, -1_000_000, -3600 * 10**9])
def test_companions_beyond_a_whole_streams_states_fail(tmp_path: Path, shift: int) -> None:
    """The sweep recorded whole (its record's first and last samples): a platform pose 5 cm off at z = 0.9 m and rods
    of [0.9, 0, 0.3] m (beyond the stroke), stamped a sample or an hour after the last state (before the first),
    passed: after the last state one stamp was let through as a cut sample's, before the first any as a late
    subscriber's. No sample follows or precedes a whole stream's states: both fail as extra."""
    msgs = small_sweep()
    end = max if shift > 0 else min   # the stream's last (first) message of a topic
    pose, joints = (end((m for m in msgs if m[0] == t), key=lambda m: m[1])
                    for t in ('/gpr/platform_pose', '/joint_states'))
    off = ('/gpr/platform_pose', pose[1] + shift, _shifted(pose[0], pose[2], shift, lambda m: dataclasses.replace(
        m, pose=dataclasses.replace(m.pose, position=dataclasses.replace(m.pose.position, x=m.pose.position.x + 0.05,
                                                                          z=0.9)))))
    rods = ('/joint_states', joints[1] + shift, _shifted(joints[0], joints[2], shift,
                                                          lambda m: dataclasses.replace(m, position=np.array(
                                                              [0.9, 0.0, 0.3]))))
    out = msgs + [off, rods] if shift > 0 else [msgs[0], off, rods] + msgs[1:]   # the geometry stays first
    result = verify_bag(write_bag(tmp_path / 'ends', out, _types(out)))
    failed = _failed(result)
    assert set(failed) == {'topic.platform_pose_extra', 'topic.joint_states_extra'}, [f.line() for f in
                                                                                     result.failures]
    side = 'after the last PlatformState' if shift > 0 else 'before the first PlatformState'
    assert all(side in f.detail for f in result.failures)


def test_companions_before_a_late_recorders_first_state_still_pass(tmp_path: Path) -> None:
    """A recorder that subscribed to the states after the companion topics lacks the first samples' states: their
    companions (before its first state) are a late subscriber's, not extra (the stream's first sample is not
    recorded)."""
    msgs = small_sweep()
    states = [k for k, m in enumerate(msgs) if m[0] == '/gpr/platform_state']
    drop = set(states[:3])
    out = [m for k, m in enumerate(msgs) if k not in drop]
    assert verify_bag(write_bag(tmp_path / 'late', out, _types(out))).passed

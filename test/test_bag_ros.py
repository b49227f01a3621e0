"""recorder_node and replay_node over real DDS (nodes started as ``ros2 run`` would): trajectory -> recorder ->
stop -> verify, both storage formats and both stop signals; SIGKILL loses nothing beyond the flush interval;
refusals; replay of the reference bag into a fresh recorder gives the same bytes."""
from __future__ import annotations

import math
import os
import re
import signal
import time
from pathlib import Path

import numpy as np
import pytest
from ros_support import NodeProcess

from gpr_kinematics.bags.reader import read_bag
from gpr_kinematics.bags.typestore import GEOMETRY_TOPIC, GPR_TOPICS
from gpr_kinematics.bags.verify import verify_bag

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / 'bags' / 'reference_sweep'
STATE = '/gpr/platform_state'
STREAM = [t for t in GPR_TOPICS if t != GEOMETRY_TOPIC]  # a message per sample
# Own domain per run (101..200, by process id): concurrent runs of this module on one machine stay apart,
# and it differs from ros_support's range (10..99) used by the other ROS test modules.
DOMAIN_ID = str(101 + os.getpid() % 100)


@pytest.fixture(autouse=True, scope='module')
def own_domain():
    """This module's own ROS_DOMAIN_ID for every node it starts (restored afterwards)."""
    old = os.environ.get('ROS_DOMAIN_ID')
    os.environ['ROS_DOMAIN_ID'] = DOMAIN_ID
    yield
    if old is None:
        os.environ.pop('ROS_DOMAIN_ID', None)
    else:
        os.environ['ROS_DOMAIN_ID'] = old


def wait_for_log(proc: NodeProcess, pattern: str, timeout: float = 30.0) -> re.Match[str]:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        m = re.search(pattern, proc.output())
        if m:
            return m
        if not proc.alive():
            break
        time.sleep(0.05)
    raise AssertionError(f'{proc.exe}: no {pattern!r} in its output:\n{proc.output()}')


def recorder(output: Path, *params: str) -> NodeProcess:
    args = ['-p', f'output:={output}']
    for p in params:
        args += ['-p', p]
    return NodeProcess('recorder_node', args)


def trajectory(rate: float, tilt_step_deg: float, azimuth_step_deg: float, subscribers: int = 1) -> NodeProcess:
    return NodeProcess('trajectory_node', ['-p', f'rate:={rate}', '-p', f'wait_for_subscribers:={subscribers}',
                                           '-p', 'wait_all_topics:=true',
                                           '-p', f'tilt_step:={math.radians(tilt_step_deg)!r}',
                                           '-p', f'azimuth_step:={math.radians(azimuth_step_deg)!r}'])


def published(traj: NodeProcess) -> int:
    return int(wait_for_log(traj, r'finished: published (\d+) samples').group(1))


def independent_read(bag: Path, files: list[str]) -> dict[str, list[bytes]]:
    """Messages per topic read without rosbags: the ``mcap`` package with the ``mcap_ros2`` decoder (every
    message must decode), or SQLite3 queries on the rosbag2 schema."""
    out: dict[str, list[bytes]] = {}
    for name in files:
        f = bag / name
        if f.suffix == '.mcap':
            from mcap.reader import make_reader
            from mcap_ros2.decoder import DecoderFactory

            with f.open('rb') as fh:
                reader = make_reader(fh, decoder_factories=[DecoderFactory()])
                for _schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
                    assert decoded is not None
                    if channel.topic == STATE:
                        assert decoded.model == 'radial' and len(decoded.q) == 3
                    out.setdefault(channel.topic, []).append(bytes(message.data))
        else:
            import sqlite3

            con = sqlite3.connect(f)
            try:
                rows = con.execute('SELECT topics.name, messages.data FROM messages JOIN topics '
                                   'ON messages.topic_id = topics.id ORDER BY messages.timestamp, messages.id')
                for topic, data in rows:
                    out.setdefault(topic, []).append(bytes(data))
            finally:
                con.close()
    return out


@pytest.mark.parametrize('storage,sig', [('mcap', signal.SIGINT), ('sqlite3', signal.SIGTERM)])
def test_recorded_sweep_verifies_and_counts_match(tmp_path: Path, storage: str, sig: int) -> None:
    bag = tmp_path / 'bag'
    rec = recorder(bag, f'storage:={storage}', 'flush_interval:=0.25')
    traj = None
    try:
        wait_for_log(rec, rf'recording {len(GPR_TOPICS)} topic')
        # 2 deg steps of 0.4 deg x azimuth 30 deg: 12 rows of 11 samples, 12 singular crossings, at 400 Hz.
        traj = trajectory(400.0, 0.4, 30.0)
        assert traj.wait(60) == 0, traj.output()
        n = published(traj)
        assert n == 132
        time.sleep(0.3)
        status, _ = rec.signal(sig, timeout=15)
        assert status == 0, rec.output()
        log = rec.output()
        # The stream topics, and the geometry once if the trajectory node publishes it.
        assert re.search(rf'stopped: wrote ({len(STREAM) * n}|{len(STREAM) * n + 1}) messages', log), log
        assert f'{STATE} {n}/{n}' in log
    finally:
        rec.stop()
        if traj is not None:
            traj.stop()
    suffix = '.mcap' if storage == 'mcap' else '.db3'
    b = read_bag(bag)
    assert b.storage == storage and all(f.endswith(suffix) for f in b.files)
    assert not (bag / '.recording').exists()
    assert {k: len(t) for k, t in b.topics.items() if k != GEOMETRY_TOPIC} == dict.fromkeys(STREAM, n)
    assert independent_read(bag, b.files) == {k: t.raw for k, t in b.topics.items() if len(t)}
    result = verify_bag(b)
    assert result.passed, [f.line() for f in result.failures]
    assert result.crossings == 12


def test_sigkill_loses_nothing_older_than_the_flush_interval(tmp_path: Path) -> None:
    """Two recorders on the same stream: ``full`` is stopped cleanly (the truth), ``killed`` gets SIGKILL
    mid-stream. The killed bag is a valid bag holding a gapless prefix of the stream, byte for byte, that
    contains everything received more than flush_interval (0.5 s) before the kill."""
    flush = 0.5
    full = recorder(tmp_path / 'full', 'flush_interval:=1.0')
    killed = recorder(tmp_path / 'killed', f'flush_interval:={flush}')
    traj = None
    try:
        wait_for_log(full, rf'recording {len(GPR_TOPICS)} topic')
        wait_for_log(killed, rf'recording {len(GPR_TOPICS)} topic')
        traj = trajectory(200.0, 0.2, 20.0, subscribers=2)  # 18 x 21 = 378 samples, ~1.9 s
        wait_for_log(traj, r'started: publishing')
        time.sleep(1.3)
        kill_ns = time.time_ns()
        killed.proc.send_signal(signal.SIGKILL)
        assert killed.wait(10) == -signal.SIGKILL
        assert traj.wait(60) == 0, traj.output()
        time.sleep(0.3)
        assert full.signal(signal.SIGINT, timeout=15)[0] == 0, full.output()
    finally:
        for p in (full, killed, traj):
            if p is not None:
                p.stop()
    truth = read_bag(tmp_path / 'full')
    got = read_bag(tmp_path / 'killed')
    assert len(truth.topic(STATE)) == 378
    result = verify_bag(got)
    assert result.passed, [f.line() for f in result.failures]
    t_state, g_state = truth.topic(STATE), got.topic(STATE)
    assert 50 < len(g_state) < 378
    for name, topic in got.topics.items():
        ref = truth.topic(name)
        assert topic.raw == ref.raw[:len(topic)], name  # a prefix, byte for byte
        old = int(np.count_nonzero(ref.log_time < kill_ns - int((flush + 0.1) * 1e9)))
        assert len(topic) >= old, (name, len(topic), old)
    assert np.array_equal(g_state.columns()['sample'], np.arange(len(g_state)))
    assert len(t_state) - len(g_state) > 0

    from mcap.reader import make_reader

    n = 0
    for f in got.files:
        with (tmp_path / 'killed' / f).open('rb') as fh:
            n += sum(1 for _ in make_reader(fh).iter_messages(topics=[STATE]))
    assert n == len(g_state)


def test_recorder_refuses_bad_output_and_unknown_types(tmp_path: Path) -> None:
    (tmp_path / 'exists').mkdir()
    (tmp_path / 'exists' / 'keep.txt').write_text('mine')
    cases = [
        ([f'output:={tmp_path / "exists"}'], 'exists already'),
        (['output:=/proc/gpr_bag_test/bag'], 'cannot be created|not writable'),
        ([f'output:={tmp_path / "new1"}', 'topics:=[gpr/platform_state, "odd:nonexistent_msgs/msg/Thing"]'],
         'not in the typestore'),
        ([f'output:={tmp_path / "new2"}', 'topics:=[nobody/publishes_this]', 'discovery_timeout:=0.5'],
         'unknown: not published'),
        ([f'output:={tmp_path / "new3"}', 'storage:=rosbag1'], 'storage'),
    ]
    procs = []
    for params, _ in cases:
        args = []
        for p in params:
            args += ['-p', p]
        procs.append(NodeProcess('recorder_node', args))
    for proc, (_params, words) in zip(procs, cases, strict=True):
        assert proc.wait(30) == 2, proc.output()
        out = proc.output()
        assert re.search(words, out), out
        assert 'Traceback' not in out
    assert sorted(p.name for p in (tmp_path / 'exists').iterdir()) == ['keep.txt']
    assert not any((tmp_path / f'new{i}').exists() for i in (1, 2, 3))
    assert not Path('/proc/gpr_bag_test').exists()


def test_replay_into_a_fresh_recorder_gives_the_same_messages(tmp_path: Path) -> None:
    ref = read_bag(REFERENCE)
    rate = 4.0
    rec = recorder(tmp_path / 'again', 'flush_interval:=0.5')
    replay = None
    try:
        wait_for_log(rec, rf'recording {len(GPR_TOPICS)} topic')
        replay = NodeProcess('replay_node', ['-p', f'bag:={REFERENCE}', '-p', f'rate:={rate}',
                                             '-p', 'wait_for_subscribers:=1'])
        assert replay.wait(60) == 0, replay.output()
        assert 'finished: published' in replay.output()
        time.sleep(0.3)
        assert rec.signal(signal.SIGINT, timeout=15)[0] == 0, rec.output()
    finally:
        rec.stop()
        if replay is not None:
            replay.stop()
    again = read_bag(tmp_path / 'again')
    assert set(again.topics) == set(ref.topics)
    for name, topic in ref.topics.items():
        assert again.topic(name).raw == topic.raw, name
    # The original spacing scaled by the rate: the replay cannot run ahead of its schedule.
    span_ref = (ref.topic(STATE).log_time[-1] - ref.topic(STATE).log_time[0]) * 1e-9
    span = (again.topic(STATE).log_time[-1] - again.topic(STATE).log_time[0]) * 1e-9
    assert span >= 0.9 * span_ref / rate
    assert span < span_ref / rate + 2.0
    assert verify_bag(again).passed


def test_replay_topic_filter(tmp_path: Path) -> None:
    rec = recorder(tmp_path / 'states', 'flush_interval:=0.5')
    replay = None
    try:
        wait_for_log(rec, rf'recording {len(GPR_TOPICS)} topic')
        replay = NodeProcess('replay_node', ['-p', f'bag:={REFERENCE}', '-p', 'rate:=10.0',
                                             '-p', 'topics:=[gpr/platform_state]', '-p', 'wait_for_subscribers:=1'])
        assert replay.wait(60) == 0, replay.output()
        time.sleep(0.3)
        assert rec.signal(signal.SIGINT, timeout=15)[0] == 0
    finally:
        rec.stop()
        if replay is not None:
            replay.stop()
    b = read_bag(tmp_path / 'states')
    assert {k: len(t) for k, t in b.topics.items()} == {**dict.fromkeys(GPR_TOPICS, 0), STATE: 756}
    bad = NodeProcess('replay_node', ['-p', f'bag:={tmp_path / "nothing"}'])
    assert bad.wait(30) == 2 and 'does not exist' in bad.output()


def test_replay_loop_repeats_until_sigint(tmp_path: Path) -> None:
    rec = recorder(tmp_path / 'looped', 'flush_interval:=0.5', 'topics:=[gpr/platform_state]')
    replay = None
    try:
        wait_for_log(rec, r'recording 1 topic')
        replay = NodeProcess('replay_node', ['-p', f'bag:={REFERENCE}', '-p', 'rate:=3.0', '-p', 'loop:=true',
                                             '-p', 'topics:=[gpr/platform_state]', '-p', 'wait_for_subscribers:=1'])
        wait_for_log(replay, r'replaying 756 messages')
        wait_for_log(replay, r'started: publishing')  # after the subscription was discovered
        time.sleep(2.0)  # one pass takes 2.3 s / 3 = 0.77 s
        status, _ = replay.signal(signal.SIGINT, timeout=15)
        assert status == 0, replay.output()
        time.sleep(0.3)
        assert rec.signal(signal.SIGINT, timeout=15)[0] == 0
        logs = rec.output() + replay.output()
    finally:
        rec.stop()
        if replay is not None:
            replay.stop()
    ref = read_bag(REFERENCE).topic(STATE).raw
    got = read_bag(tmp_path / 'looped').topic(STATE).raw
    assert len(got) > len(ref), logs
    assert got == (ref * (len(got) // len(ref) + 1))[:len(got)]

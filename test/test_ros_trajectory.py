"""trajectory_node over real DDS: the stream equals the core's precomputation, arrives in order, crosses
alpha = 0 without a jump, carries consistent poses; the latched geometry; program mode; clean exits."""
from __future__ import annotations

import contextlib
import math
import signal
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import yaml
from gpr_kinematics.core import inverse_batch
from gpr_kinematics.core.config import GprConfig, load_config
from gpr_kinematics.core.sweep import paper_sweep
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.platform_program import load_platform_program, sample_program
from ros_support import imperfect_config_file, start, wait_for_log

pytestmark = pytest.mark.ros

CFG = load_config()
TIGHT = dict(rtol=0.0, atol=1e-12)
STEP = math.radians(0.5)
MAX_TILT = math.radians(2.0)
AZ_STEP = math.radians(60.0)
HEIGHT = 0.4
RATE = 200.0


def subscribe_stream(client, ns: str) -> dict[str, list]:
    """Keep every message of the trajectory node's topics (reliable, deep queues; gpr/geometry latched)."""
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String
    from visualization_msgs.msg import MarkerArray

    from gpr_interfaces.msg import PlatformState

    topics = {'gpr/platform_state': PlatformState, 'gpr/platform_pose': PoseStamped,
              'gpr/nominal_pose': PoseStamped, 'joint_states': JointState, 'gpr/virtual_joints': JointState,
              'gpr/markers': MarkerArray}
    out = {t: client.subscribe(ty, f'{ns}/{t}') for t, ty in topics.items()}
    out['gpr/geometry'] = client.subscribe(String, f'{ns}/gpr/geometry', latched=True)
    return out


def _run_stream(ns: str, expect: int, timeout: float = 60.0, **values):
    """Start the node, record until it exits; return (messages by topic, exit status, output)."""
    from gpr_kinematics.nodes.client import GprClient

    with GprClient(f'gpr_test_traj_{ns.strip("/")}') as c:
        msgs = subscribe_stream(c, ns)
        proc = start('trajectory_node', namespace=ns, **{'wait_for_subscribers': 1, 'rate': RATE, **values})
        try:
            done = c.spin_until(lambda: not proc.alive() and len(msgs['gpr/platform_state']) >= expect, timeout)
            c.spin_for(0.3)
            assert done, f'stream incomplete: {len(msgs["gpr/platform_state"])} of {expect}\n{proc.output()}'
            status = proc.wait(timeout=10)
            return msgs, status, proc.output()
        finally:
            proc.stop()


def _pos(p):
    return np.array([p.position.x, p.position.y, p.position.z])


def _quat(p):
    return np.array([p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w])


@pytest.fixture(scope='module')
def sweep_run(ros_environment):
    core = paper_sweep(height=HEIGHT, max_tilt=MAX_TILT, tilt_step=STEP, azimuth_step=AZ_STEP, passes=2,
                       config=CFG)
    rec, status, out = _run_stream('/traj_sweep', expect=len(core), mode='sweep', height=HEIGHT, max_tilt=MAX_TILT,
                                   tilt_step=STEP, azimuth_step=AZ_STEP, passes=2, markers_every=3)
    return core, rec, status, out


def test_sweep_exits_0_and_logs_start_and_finish(sweep_run):
    core, rec, status, out = sweep_run
    assert status == 0, out
    assert 'started: publishing' in out and 'finished: published' in out and 'Traceback' not in out
    assert f'published {len(core)} samples' in out


def test_sweep_stream_in_order_and_equal_to_core(sweep_run):
    core, rec, _, _ = sweep_run
    states = rec['gpr/platform_state']
    assert [m.sample for m in states] == list(range(len(core)))
    fk = core.forward
    np.testing.assert_allclose([m.q for m in states], core.q, **TIGHT)
    np.testing.assert_allclose([_pos(m.pose) for m in states], fk.position, **TIGHT)
    np.testing.assert_allclose([_quat(m.pose) for m in states], fk.quaternion, **TIGHT)
    np.testing.assert_allclose([_pos(m.nominal_pose) for m in states], fk.nominal_position, **TIGHT)
    np.testing.assert_allclose([m.virtual_joints for m in states], fk.virtual_joints, **TIGHT)
    np.testing.assert_allclose([m.commanded_tilt for m in states], core.alpha, **TIGHT)
    np.testing.assert_allclose([m.commanded_azimuth for m in states], core.gamma, **TIGHT)
    assert all(m.model == CFG.model and m.header.frame_id == 'gpr_base' for m in states)
    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in states])
    # sample k at start + k / rate on the wall clock too: samples a late tick caught up were stamped as they went
    # out, 0.4 ms apart at 200 Hz (a 12x velocity spike to whatever differentiates them); here a monotonic clock's
    # intervals carried over to the ROS clock, each within microseconds of 5 ms
    assert np.all(np.diff(stamps) > 0) and np.max(np.abs(np.diff(stamps) - 1e9 / RATE)) < 2e4, np.diff(stamps)
    # Every pass crosses the singular configuration: alpha = 0 appears once per azimuth row.
    rows = 2 * round(2 * math.pi / AZ_STEP)
    assert sum(1 for m in states if m.commanded_tilt == 0.0) == rows


def test_sweep_crosses_singularity_without_jump(sweep_run):
    core, rec, _, _ = sweep_run
    states = rec['gpr/platform_state']
    q = np.array([m.q for m in states])
    pos = np.array([_pos(m.pose) for m in states])
    tilt = np.array([m.tilt for m in states])
    alpha = np.array([m.commanded_tilt for m in states])
    crossings = np.flatnonzero(alpha == 0.0)
    assert crossings.size > 0
    # Within an azimuth row the rods move by at most R * sin(step) * sqrt(3) per sample (naive inverse
    # q_k = z + (Rot r_k)_z); the steps into and out of alpha = 0 are no larger than their neighbours.
    bound = CFG.radius * math.sin(STEP) * math.sqrt(3) * 1.01
    for i in crossings:
        steps = np.abs(q[i - 2:i + 3] - q[i - 3:i + 2]).max(axis=1)
        assert steps.max() <= bound
        assert steps[2:4].max() <= 1.05 * max(steps[0], steps[4])     # no jump at the crossing
        assert tilt[i] < 1e-9                                          # untilted at alpha = 0
        np.testing.assert_allclose(q[i], q[i].mean(), atol=1e-12)      # q1 = q2 = q3 there
        dpos = np.linalg.norm(np.diff(pos[i - 2:i + 3], axis=0), axis=1)
        assert dpos.max() < 1e-4                                       # centre moves by micrometres
    # The centre shift changes sign smoothly through the crossing (|shift| ~ tilt^2, paper §III).
    shift = np.array([[m.centre_shift.x, m.centre_shift.y] for m in states])
    assert np.linalg.norm(shift[crossings], axis=1).max() < 1e-12


def test_sweep_poses_consistent(sweep_run):
    core, rec, _, _ = sweep_run
    states = rec['gpr/platform_state']
    for m in states:
        shift = _pos(m.pose) - _pos(m.nominal_pose)
        np.testing.assert_allclose(shift, [m.centre_shift.x, m.centre_shift.y, m.centre_shift.z], atol=1e-15)
        assert m.tilt == pytest.approx(abs(m.commanded_tilt), abs=1e-9)
        assert m.pose.position.z == pytest.approx(HEIGHT, abs=1e-9)
        assert abs(np.linalg.norm(_quat(m.pose)) - 1.0) < 1e-12
        qa = np.asarray(m.q)
        np.testing.assert_allclose(m.side_lengths, np.sqrt(3 * CFG.radius ** 2 + (np.roll(qa, -1) - qa) ** 2),
                                   rtol=1e-12)
    poses = rec['gpr/platform_pose']
    nominal = rec['gpr/nominal_pose']
    joints = rec['joint_states']
    virtual = rec['gpr/virtual_joints']
    assert len(poses) == len(nominal) == len(joints) == len(virtual) == len(states)
    for s, p, n, j, v in zip(states, poses, nominal, joints, virtual, strict=True):
        assert p.header.stamp == s.header.stamp and p.header.frame_id == 'gpr_base'
        np.testing.assert_array_equal(_pos(p.pose), _pos(s.pose))
        np.testing.assert_array_equal(_quat(n.pose), _quat(s.nominal_pose))
        # Physical joints only on joint_states (robot_state_publisher's convention), the virtual ones apart.
        assert list(j.name) == ['rod_1', 'rod_2', 'rod_3'] and j.header.stamp == s.header.stamp
        np.testing.assert_array_equal(j.position, list(s.q))
        assert list(v.name) == list(s.virtual_joint_names) and v.header.stamp == s.header.stamp
        np.testing.assert_array_equal(v.position, list(s.virtual_joints))
    assert list(states[0].virtual_joint_names) == list(core.forward.virtual_joint_names)


def test_sweep_markers(sweep_run):
    from visualization_msgs.msg import Marker

    core, rec, _, _ = sweep_run
    markers = rec['gpr/markers']
    assert len(markers) == math.ceil(len(core) / 3)
    last = markers[-1]
    by_ns = {m.ns: m for m in last.markers}
    assert set(by_ns) == {'base', 'rods', 'platform', 'nominal_platform'}
    assert by_ns['rods'].type == Marker.LINE_LIST and len(by_ns['rods'].points) == 6
    # The platform triangle is the joint centres P_k = (R cos theta_k, R sin theta_k, q_k).
    i = 3 * (len(markers) - 1)
    zs = [p.z for p in by_ns['platform'].points]
    np.testing.assert_allclose(zs, core.q[i], atol=1e-15)


def test_geometry_latched_and_loadable(sweep_run):
    """gpr/geometry: one latched message, the YAML of the node's GprConfig.to_dict()."""
    _, rec, _, _ = sweep_run
    (msg,) = rec['gpr/geometry']
    data = yaml.safe_load(msg.data)
    assert data == CFG.to_dict()
    assert GprConfig.from_mapping(data) == CFG


@pytest.mark.slow
def test_an_imperfect_machine_streams_its_own_kinematics_and_markers(ros_environment, tmp_path):
    """A config_file with the keys no ROS parameter holds: the stream is forward kinematics on that machine, the
    markers draw its rods and platform joints (MachineGeometry), gpr/geometry records it whole."""
    from gpr_kinematics.robot.markers import marker_points

    path, cfg = imperfect_config_file(tmp_path)
    core = paper_sweep(height=HEIGHT, max_tilt=MAX_TILT, tilt_step=math.radians(1.0), azimuth_step=math.radians(120.0),
                       config=cfg, model=cfg.model)
    rec, status, out = _run_stream('/traj_imperfect', expect=len(core), config_file=str(path), height=HEIGHT,
                                   max_tilt=MAX_TILT, tilt_step=math.radians(1.0), azimuth_step=math.radians(120.0))
    assert status == 0, out
    states = rec['gpr/platform_state']
    fk = core.forward
    assert all(m.model == 'compliant' for m in states)
    np.testing.assert_allclose([m.q for m in states], fk.q, **TIGHT)
    np.testing.assert_allclose([_pos(m.pose) for m in states], fk.position, **TIGHT)
    np.testing.assert_allclose([_quat(m.pose) for m in states], fk.quaternion, **TIGHT)
    points = marker_points(cfg, fk.q, fk.nominal_position, fk.nominal_rotation)
    for i, arr in enumerate(rec['gpr/markers']):
        for m in arr.markers:
            np.testing.assert_allclose([[p.x, p.y, p.z] for p in m.points], points[m.ns][i], **TIGHT)
    # The rods stand where the file puts them: foot P_k(0) = B_k + o_k u_k, not on the nominal circle.
    feet = np.array([[p.x, p.y] for p in rec['gpr/markers'][0].markers[0].points[:3]])
    u = np.array(cfg.rod_directions)
    np.testing.assert_allclose(feet, np.array(cfg.rod_positions) + np.array(cfg.rod_offsets)[:, None] * u,
                               rtol=0, atol=1e-15)
    (geometry,) = rec['gpr/geometry']
    assert GprConfig.from_mapping(yaml.safe_load(geometry.data)) == cfg


@pytest.mark.slow
def test_program_mode_streams_the_sampled_program(ros_environment):
    path = config_path('programs/example_stations.yaml')
    prog = load_platform_program(path)
    rate = 50.0
    samples = sample_program(prog, rate, 2.0)
    rec, status, out = _run_stream('/traj_program', expect=len(samples), mode='program', program_file=path,
                                   rate=rate)
    assert status == 0, out
    states = rec['gpr/platform_state']
    assert [m.sample for m in states] == list(range(len(samples)))
    ik = inverse_batch(samples.height, samples.tilt, samples.azimuth, CFG)
    np.testing.assert_allclose([m.q for m in states], ik.q, **TIGHT)
    z = np.array([m.pose.position.z for m in states])
    np.testing.assert_allclose(z, samples.height, atol=1e-9)
    first, last = prog.stations[0], prog.stations[-1]
    assert states[0].pose.position.z == pytest.approx(first.height, abs=1e-9)
    assert states[-1].pose.position.z == pytest.approx(last.height, abs=1e-9)
    assert states[-1].tilt == pytest.approx(abs(last.tilt), abs=1e-9)
    # Stations with tilt reach it; the stream between a and b passes the untilted configuration smoothly.
    tilts = np.array([m.tilt for m in states])
    assert tilts.max() == pytest.approx(max(abs(s.tilt) for s in prog.stations), abs=1e-9)
    q = np.array([m.q for m in states])
    assert np.abs(np.diff(q, axis=0)).max() < 0.01


def test_program_mode_bad_file_exits_2(ros_environment, tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('stations:\n  - {height: 0.4, tilt: 0.1, azimuth: 0.0}\n')     # 5.7 deg: beyond the limit
    proc = start('trajectory_node', mode='program', program_file=bad)
    assert proc.wait(timeout=30) == 2
    out = proc.output()
    assert 'cannot start' in out and 'station 0' in out and 'tilt' in out and 'Traceback' not in out


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_looping_node_exits_0_on_signal(ros_environment, sig):
    from gpr_kinematics.nodes.client import GprClient

    from gpr_interfaces.msg import PlatformState

    ns = f'/traj_sig_{int(sig)}'
    with GprClient(f'gpr_test_traj_sig_{int(sig)}') as c:
        states = c.subscribe(PlatformState, f'{ns}/gpr/platform_state')
        proc = start('trajectory_node', namespace=ns, loop=True, rate=100.0, wait_for_subscribers=1,
                     wait_all_topics=False, tilt_step=STEP, azimuth_step=AZ_STEP)
        try:
            assert c.spin_until(lambda: len(states) > 60, 30), proc.output()
            status, took = proc.signal(sig, timeout=2.0)
            out = proc.output()
            assert status == 0, out
            assert took < 2.0 and 'Traceback' not in out
            # It looped: more samples than one pass, the counter kept counting.
            n = len(paper_sweep(max_tilt=MAX_TILT, tilt_step=STEP, azimuth_step=AZ_STEP, config=CFG))
            assert n < 60 and states[60].sample == 60
        finally:
            proc.stop()


@pytest.mark.slow
def test_under_a_simulated_clock_the_samples_stamps_increase(ros_environment):
    """use_sim_time with /clock at 20 Hz and the stream at 200 Hz: a tick catches up the samples due by the wall
    clock while /clock stands still, and they shared its stamp (518 of 755 intervals zero: stream.stamps failed in
    gpr verify, tf dropped the repeats). Each sample is stamped at its instant, start + k / rate."""
    from builtin_interfaces.msg import Time
    from gpr_kinematics.nodes.client import GprClient
    from rosgraph_msgs.msg import Clock

    ns = '/traj_simclock'
    with GprClient('gpr_test_traj_simclock') as c:
        msgs = subscribe_stream(c, ns)
        clock = c.node.create_publisher(Clock, '/clock', 10)
        now = {'ns': 1000 * 10**9}

        def tick() -> None:
            now['ns'] += 50_000_000
            clock.publish(Clock(clock=Time(sec=now['ns'] // 10**9, nanosec=now['ns'] % 10**9)))

        c.node.create_timer(0.05, tick)
        proc = start('trajectory_node', namespace=ns, wait_for_subscribers=1, rate=RATE, mode='sweep', height=HEIGHT,
                     max_tilt=math.radians(1.0), tilt_step=STEP, azimuth_step=math.radians(120.0), passes=1,
                     use_sim_time=True)
        try:
            assert c.spin_until(lambda: not proc.alive(), 60), proc.output()
            c.spin_for(0.3)
        finally:
            proc.stop()
    states = msgs['gpr/platform_state']
    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in states])
    assert len(stamps) > 10 and np.all(np.diff(stamps) > 0), np.diff(stamps)[:20]
    assert stamps[0] >= 1000 * 10**9 and stamps[-1] <= now['ns']   # the simulated clock's time
    # each at its own instant, start + k / rate (a clock in 50 ms steps: ten samples a step, five went out and they
    # were stamped a nanosecond apart: the stream ran at half its rate in a staircase)
    assert np.max(np.abs(np.diff(stamps) - 1e9 / RATE)) <= 2, np.diff(stamps)[:20]


@contextlib.contextmanager
def _simulated_clock(ns: str, step_ns: int, every: float) -> Iterator[tuple[Any, dict[str, list], dict[str, int]]]:
    """A trajectory_node sweeping at RATE under use_sim_time in ``ns``, /clock advanced by ``step_ns`` every ``every``
    s of wall time from 1000 s: (client, the stream's messages, the clock ``{'ns': now}``, settable)."""
    from builtin_interfaces.msg import Time
    from gpr_kinematics.nodes.client import GprClient
    from rosgraph_msgs.msg import Clock

    with GprClient(f'gpr_test{ns.replace("/", "_")}') as c:
        msgs = subscribe_stream(c, ns)
        clock = c.node.create_publisher(Clock, '/clock', 10)
        now = {'ns': 1000 * 10**9}

        def tick() -> None:
            now['ns'] += step_ns
            clock.publish(Clock(clock=Time(sec=now['ns'] // 10**9, nanosec=now['ns'] % 10**9)))

        c.node.create_timer(every, tick)
        proc = start('trajectory_node', namespace=ns, wait_for_subscribers=1, rate=RATE, mode='sweep', height=HEIGHT,
                     max_tilt=math.radians(1.0), tilt_step=math.radians(0.05), azimuth_step=math.radians(120.0),
                     passes=1, use_sim_time=True)
        try:
            assert c.spin_until(lambda: len(msgs['gpr/platform_state']) > 0, 30), proc.output()
            yield c, msgs, now
        finally:
            proc.stop()


@pytest.mark.slow
def test_a_simulated_clock_slower_than_real_time_sets_the_streams_pace(ros_environment):
    """use_sim_time with /clock advancing 1 ms every 20 ms of wall time (a simulation at 1/20 of real time): the
    samples due were counted on the wall clock, so every tick caught up CATCH_UP samples and the stream ran five times
    its rate in simulated time (1 kHz for 200 Hz). Now at most the samples of the simulated time gone by, plus one
    tick's catch-up, are out."""
    from gpr_kinematics.nodes.runtime import CATCH_UP

    with _simulated_clock('/traj_slowclock', 1_000_000, 0.02) as (c, msgs, now):
        first = msgs['gpr/platform_state'][0].header.stamp
        c.spin_for(3.0)
        states = list(msgs['gpr/platform_state'])
        elapsed = now['ns'] - (first.sec * 10**9 + first.nanosec)
    assert 5 <= len(states) <= elapsed * 1e-9 * RATE + CATCH_UP + 2, (len(states), elapsed)


def test_a_simulated_clock_set_back_is_followed(ros_environment):
    """A simulation reset sets /clock back (1000 s to 10 s): each sample was stamped a nanosecond after the last
    whatever the clock said, so the stream went on at 1000 s; the stamps follow the clock back."""
    with _simulated_clock('/traj_clockback', 5_000_000, 0.01) as (c, msgs, now):
        assert c.spin_until(lambda: len(msgs['gpr/platform_state']) > 10, 30)
        now['ns'] = 10 * 10**9
        c.spin_for(1.5)
    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in msgs['gpr/platform_state']])
    assert stamps[0] >= 1000 * 10**9 and stamps[-1] < 20 * 10**9, (stamps[0], stamps[-1])


@pytest.mark.parametrize('sig', ['SIGINT', 'SIGTERM'])
def test_a_start_up_stream_stopped_mid_stream_leaves_without_an_exception(ros_environment, sig):
    """A looping sweep at 300 Hz stopped by a signal: status 0, but 'The following exception was never retrieved:
    cannot use Destroyable because destruction was requested' on stderr (a tick queued to the executor's threads ran
    after its guard conditions were destroyed). The threads' callbacks now end first."""
    proc = start('trajectory_node', namespace=f'/traj_stop_{sig.lower()}', rate=300.0, loop=True, mode='sweep')
    try:
        wait_for_log(proc, 'started: publishing')
        time.sleep(2.0)
        proc.proc.send_signal(getattr(signal, sig))
        assert proc.wait(timeout=20) == 0, proc.output()
        assert 'never retrieved' not in proc.output() and 'Traceback' not in proc.output(), proc.output()
    finally:
        proc.stop()

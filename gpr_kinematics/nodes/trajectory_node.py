"""``trajectory_node``: streams compensated GPR platform poses, continuously through singular tilts.

Topics (relative names), frames ``gpr_base`` (parent) / ``gpr_platform`` (child), SI units (m, rad):

- ``gpr/platform_state`` (gpr_interfaces/PlatformState): the full state of each sample;
- ``gpr/platform_pose`` (geometry_msgs/PoseStamped): platform pose under the virtual-joint model;
- ``gpr/nominal_pose`` (geometry_msgs/PoseStamped): platform pose under the naive model;
- ``gpr/joint_states`` (sensor_msgs/JointState): ``rod_1..rod_3`` (the rod lengths q [m]) followed by the
  virtual joints named as in the core (lengths [m], angles [rad]);
- ``gpr/markers`` (visualization_msgs/MarkerArray): base triangle, rods, platform and naive platform outline
  for RViz, every ``markers_every``-th sample.

Modes (parameter ``mode``, read-only): ``sweep`` -- the paper's grid (core ``sweep.paper_sweep``): for each
azimuth ``gamma`` in steps of ``azimuth_step``, the tilt ``alpha`` from ``-max_tilt`` to ``+max_tilt`` in steps of
``tilt_step`` at height ``height``, serpentine, ``passes`` times, so every pass crosses the singular
configuration ``alpha = 0``; ``program`` -- an offline program (``program_file``, see :mod:`.program`),
interpolated between stations and sampled at ``rate``. The whole stream is precomputed with the batch API
(``paper_sweep`` / ``inverse_batch``) before the first sample; a wall timer at ``rate`` [Hz] then publishes
one sample per tick. The node logs when it starts and finishes and exits with status 0 after the last
sample, unless ``loop`` is true (then it starts over; the sample counter keeps counting).
"""
from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import rclpy
from builtin_interfaces.msg import Duration as DurationMsg
from geometry_msgs.msg import Point, PoseStamped
from rcl_interfaces.msg import ParameterType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from gpr_interfaces.msg import PlatformState

from ..errors import ConfigError, GprError
from ..kinematics import ForwardBatch, inverse_batch
from ..messages import stream_messages
from ..sweep import paper_sweep
from .conversions import ROS_TYPES
from .params import ConfigParameters, descriptor
from .program import load_program, sample_program
from .runtime import run

NODE_NAME = 'trajectory_node'
MODES = ('sweep', 'program')

D, INT, S, B = (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_INTEGER,
              ParameterType.PARAMETER_STRING, ParameterType.PARAMETER_BOOL)

#: (name, default, type, description, limits) -- all read-only: the stream is precomputed at start.
_PARAMS: tuple[tuple[str, Any, int, str, Any], ...] = (
    ('mode', 'sweep', S, 'sweep (the paper grid) or program (an offline program file)', MODES),
    ('rate', 100.0, D, 'publishing rate [Hz]', (0.1, 5000.0)),
    ('height', 0.5, D, 'sweep: height of the platform centre [m]', (-10.0, 10.0)),
    ('max_tilt', math.radians(2.0), D, 'sweep: largest |alpha| [rad]', (1e-6, math.radians(15.0))),
    ('tilt_step', math.radians(0.2), D, 'sweep: step of alpha [rad]', (1e-7, math.radians(15.0))),
    ('azimuth_step', math.radians(10.0), D, 'sweep: step of the azimuth gamma [rad]', (1e-4, 2 * math.pi)),
    ('passes', 1, INT, 'sweep: number of passes over the grid', (1, 1000)),
    ('program_file', '', S, 'program: path of the offline program YAML', None),
    ('move_time', 2.0, D, 'program: default duration of a move between stations [s]', (1e-3, 3600.0)),
    ('loop', False, B, 'start over after the last sample instead of exiting', None),
    ('base_frame', 'gpr_base', S, 'frame of the base (header.frame_id)', None),
    ('platform_frame', 'gpr_platform', S, 'frame of the platform (child frame)', None),
    ('markers_every', 1, INT, 'publish gpr/markers every n-th sample', (1, 100000)),
    ('wait_for_subscribers', 0, INT,
     'before the first sample, wait until gpr/platform_state has this many subscriptions', (0, 1000)),
    ('wait_all_topics', False, B, 'wait_for_subscribers counts on every topic, not only gpr/platform_state',
     None),
    ('wait_timeout', 10.0, D, 'longest wait for subscribers [s]; then start anyway', (0.0, 3600.0)),
    ('queue_depth', 1000, INT, 'publisher history depth (reliable, keep last)', (1, 100000)),
)


class Trajectory:
    """A precomputed stream: commanded tilt/azimuth ``(N,)`` and the forward kinematics ``ForwardBatch``."""

    def __init__(self, commanded_tilt: np.ndarray, commanded_azimuth: np.ndarray, fk: ForwardBatch,
                 description: str) -> None:
        self.fk = fk
        self.description = description
        # Plain Python floats: a sample is published without per-sample numpy conversions of these two.
        self.cmd_tilt = np.asarray(commanded_tilt, dtype=float).tolist()
        self.cmd_azimuth = np.asarray(commanded_azimuth, dtype=float).tolist()

    def __len__(self) -> int:
        return len(self.fk)


def sweep_trajectory(cfg: Any, height: float, max_tilt: float, tilt_step: float, azimuth_step: float,
                     passes: int) -> Trajectory:
    sw = paper_sweep(height=height, max_tilt=max_tilt, tilt_step=tilt_step, azimuth_step=azimuth_step,
                     passes=passes, config=cfg, model=cfg.model)
    desc = (f'sweep at height {height} m, |alpha| <= {max_tilt:.6g} rad in steps of {tilt_step:.6g} rad, '
            f'azimuth step {azimuth_step:.6g} rad, {passes} pass(es)')
    return Trajectory(sw.alpha, sw.gamma, sw.forward, desc)


def program_trajectory(cfg: Any, path: str, rate: float, move_time: float) -> Trajectory:
    if not path:
        raise ConfigError('mode program needs the parameter program_file (path of an offline program YAML)')
    prog = load_program(path)
    # Stations first, for a message that names the station at fault.
    for i, st in enumerate(prog.stations):
        try:
            inverse_batch(st.height, st.tilt, st.azimuth, cfg, cfg.model)
        except GprError as exc:
            raise ConfigError(f'{path}: station {i} ({st.name}): {exc}') from None
    samples = sample_program(prog, rate, move_time)
    ik = inverse_batch(samples.height, samples.tilt, samples.azimuth, cfg, cfg.model)
    desc = (f'program {path}: {len(prog.stations)} stations, {samples.time[-1]:.6g} s, '
            f'{len(samples)} samples')
    return Trajectory(samples.tilt, samples.azimuth, ik.achieved, desc)


def _color(r: float, g: float, b: float, a: float = 1.0) -> ColorRGBA:
    return ColorRGBA(r=r, g=g, b=b, a=a)


class TrajectoryNode(Node):
    """Precomputes the stream at start, then publishes one sample per timer tick."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.params = ConfigParameters(self, read_only=True)
        p: dict[str, Any] = {}
        for name, default, ptype, text, limits in _PARAMS:
            p[name] = self.declare_parameter(name, default,
                                             descriptor(name, ptype, text, limits, read_only=True)).value
        if p['mode'] not in MODES:
            raise ConfigError(f"mode = {p['mode']!r} is invalid; allowed: {' or '.join(MODES)}")
        self.p = p
        cfg = self.params.config
        self.cfg = cfg
        t0 = time.perf_counter()
        if p['mode'] == 'sweep':
            self.traj = sweep_trajectory(cfg, p['height'], p['max_tilt'], p['tilt_step'], p['azimuth_step'],
                                         p['passes'])
        else:
            self.traj = program_trajectory(cfg, p['program_file'], p['rate'], p['move_time'])
        self.precompute_time = time.perf_counter() - t0
        theta = np.asarray(cfg.rod_azimuths)
        self._feet = np.stack([cfg.radius * np.cos(theta), cfg.radius * np.sin(theta), np.zeros(3)], -1)
        self._r_nominal = self._feet.copy()

        qos = QoSProfile(depth=int(p['queue_depth']), reliability=ReliabilityPolicy.RELIABLE)
        self.pub_state = self.create_publisher(PlatformState, 'gpr/platform_state', qos)
        self.stream_publishers = {
            'gpr/platform_state': self.pub_state,
            'gpr/platform_pose': self.create_publisher(PoseStamped, 'gpr/platform_pose', qos),
            'gpr/nominal_pose': self.create_publisher(PoseStamped, 'gpr/nominal_pose', qos),
            'gpr/joint_states': self.create_publisher(JointState, 'gpr/joint_states', qos),
        }
        self.pub_markers = self.create_publisher(MarkerArray, 'gpr/markers', qos)
        self.publishers_all = (*self.stream_publishers.values(), self.pub_markers)

        self.done: Future = Future()
        self.index = 0
        self.sample = 0
        self.loops = 0
        self.started_at: float | None = None
        self.period = 1.0 / float(p['rate'])
        self._wait_start = time.monotonic()
        self.get_logger().info(f'precomputed {len(self.traj)} samples in {self.precompute_time:.3f} s '
                               f'({self.traj.description}, model {cfg.model})')
        self.timer = self.create_timer(self.period, self._tick)

    # -- publishing ---------------------------------------------------------------------------------------
    def _ready(self) -> bool:
        want = int(self.p['wait_for_subscribers'])
        if want <= 0:
            return True
        pubs = self.publishers_all if self.p['wait_all_topics'] else (self.pub_state,)
        if min(pub.get_subscription_count() for pub in pubs) >= want:
            return True
        if time.monotonic() - self._wait_start > float(self.p['wait_timeout']):
            where = 'every topic' if self.p['wait_all_topics'] else 'gpr/platform_state'
            self.get_logger().warning(f'no {want} subscriber(s) on {where} after '
                                      f'{self.p["wait_timeout"]} s; starting anyway')
            return True
        return False

    def _tick(self) -> None:
        if self.started_at is None:
            if not self._ready():
                return
            self.started_at = time.monotonic()
            self.get_logger().info(f'started: publishing {len(self.traj)} samples at {self.p["rate"]} Hz '
                                   f'({self.p["mode"]} mode{", looping" if self.p["loop"] else ""})')
        try:
            self.publish_sample(self.index)
        except Exception as exc:  # noqa: BLE001 - an escaping exception would end the spin with a traceback
            if not self.context.ok():
                # SIGINT/SIGTERM shut the context down while this callback ran: a normal exit.
                self._finish(0, quiet=True)
                return
            self.get_logger().error(f'publishing sample {self.sample} failed: {type(exc).__name__}: {exc}')
            self._finish(1)
            return
        self.index += 1
        self.sample += 1
        if self.index >= len(self.traj):
            if self.p['loop']:
                self.index = 0
                self.loops += 1
            else:
                self._finish(0)

    def _finish(self, status: int, quiet: bool = False) -> None:
        self.timer.cancel()
        elapsed = time.monotonic() - (self.started_at or time.monotonic())
        achieved = (self.sample - 1) / elapsed if self.sample > 1 and elapsed > 0 else float('nan')
        if not quiet:
            self.get_logger().info(f'finished: published {self.sample} samples in {elapsed:.3f} s '
                                   f'(achieved {achieved:.3f} Hz, requested {self.p["rate"]} Hz)')
        if not self.done.done():
            self.done.set_result(status)

    def publish_sample(self, i: int) -> None:
        tr = self.traj
        msgs = stream_messages(ROS_TYPES, tr.fk[i], stamp_ns=self.get_clock().now().nanoseconds,
                               frame_id=self.p['base_frame'], sample=self.sample,
                               commanded_tilt=tr.cmd_tilt[i], commanded_azimuth=tr.cmd_azimuth[i])
        for topic, pub in self.stream_publishers.items():
            pub.publish(msgs[topic])
        if self.sample % int(self.p['markers_every']) == 0:
            self.pub_markers.publish(self.markers(i, msgs['gpr/platform_state'].header))

    def markers(self, i: int, header: Any) -> MarkerArray:
        """Base triangle, rods (foot to joint centre), platform triangle (the joint centres ``P_k``) and the
        naive platform's outline, all in the base frame."""
        fk = self.traj.fk
        P = self._feet.copy()
        P[:, 2] = fk.q[i]
        nominal = fk.nominal_position[i] + self._r_nominal @ fk.nominal_rotation[i].T
        life = DurationMsg(sec=0, nanosec=0)

        def marker(mid: int, ns: str, mtype: int, width: float, color: ColorRGBA, pts: Sequence) -> Marker:
            m = Marker()
            m.header = header
            m.ns = ns
            m.id = mid
            m.type = mtype
            m.action = Marker.ADD
            m.pose.orientation.w = 1.0
            m.scale.x = width
            if mtype == Marker.TRIANGLE_LIST:
                m.scale.x = m.scale.y = m.scale.z = 1.0
            m.color = color
            m.lifetime = life
            m.points = [Point(x=float(a), y=float(b), z=float(c)) for a, b, c in pts]
            return m

        feet, plat = self._feet.tolist(), P.tolist()
        rods = [p for k in range(3) for p in (feet[k], plat[k])]
        return MarkerArray(markers=[
            marker(0, 'base', Marker.LINE_STRIP, 0.004, _color(0.5, 0.5, 0.5), feet + feet[:1]),
            marker(1, 'rods', Marker.LINE_LIST, 0.008, _color(0.2, 0.4, 0.9), rods),
            marker(2, 'platform', Marker.TRIANGLE_LIST, 1.0, _color(0.95, 0.55, 0.1, 0.8), plat),
            marker(3, 'nominal_platform', Marker.LINE_STRIP, 0.002, _color(0.1, 0.8, 0.2),
                   nominal.tolist() + nominal.tolist()[:1]),
        ])

    def flush(self, timeout: float = 2.0) -> None:
        """Wait until every subscription has acknowledged what was published (reliable QoS)."""
        for pub in self.publishers_all:
            try:
                pub.wait_for_all_acked(Duration(seconds=timeout))
            except Exception:  # noqa: BLE001 - best effort on the way out
                pass


def _spin_until_done(node: Node) -> int:
    assert isinstance(node, TrajectoryNode)
    rclpy.spin_until_future_complete(node, node.done)
    status = int(node.done.result()) if node.done.done() else 0
    node.flush()
    return status


def main(args: Sequence[str] | None = None) -> int:
    return run(NODE_NAME, TrajectoryNode, args, spin=_spin_until_done)


if __name__ == '__main__':
    sys.exit(main())

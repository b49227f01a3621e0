"""``trajectory_node``: streams compensated GPR platform poses, continuously through singular tilts.

Topics (relative names), frame ``gpr_base`` (``base_frame``), SI units (m, rad):

- ``gpr/platform_state`` (gpr_interfaces/PlatformState): the full state of each sample;
- ``gpr/platform_pose`` / ``gpr/nominal_pose`` (geometry_msgs/PoseStamped): platform pose under the virtual-joint
  model / the naive model;
- ``gpr/joint_states`` (sensor_msgs/JointState): the physical joints, ``rod_1..rod_3`` (rod lengths q [m]), as
  ``robot_state_publisher`` expects; ``gpr/virtual_joints`` (sensor_msgs/JointState): the virtual joints,
  named as in the core (lengths [m], angles [rad]);
- ``gpr/markers`` (visualization_msgs/MarkerArray): every ``markers_every``-th sample (:mod:`.markers`);
- ``gpr/geometry`` (std_msgs/String, reliable, transient local, depth 1): published once at start, the YAML of
  the node's ``GprConfig.to_dict()`` (loadable with ``GprConfig.from_mapping``), so a recording names the
  geometry and model that produced it.

Modes (parameter ``mode``, read-only): ``sweep`` -- the paper's grid (core ``sweep.paper_sweep``): for each
azimuth ``gamma`` in steps of ``azimuth_step``, the tilt ``alpha`` from ``-max_tilt`` to ``+max_tilt`` in steps of
``tilt_step`` at height ``height``, serpentine, ``passes`` times, so every pass crosses the singular
configuration ``alpha = 0``; ``program`` -- an offline program (``program_file``, see :mod:`.program`),
interpolated between stations and sampled at ``rate``; ``idle`` -- nothing at start. In every mode the node serves
the action ``gpr/run_program`` (gpr_interfaces/RunProgram: a program file or inline stations; feedback per
sample; cancel stops before the next sample) whenever no stream is running. A stream is precomputed with the
batch API (``paper_sweep`` / ``inverse_batch``) before its first sample; a wall timer at ``rate`` [Hz] then
publishes one sample per tick. A start-up stream ends the node with status 0 after its last sample unless
``loop`` is true (then it starts over; the sample counter keeps counting); ``idle`` runs until SIGINT/SIGTERM.
"""
from __future__ import annotations

import dataclasses
import math
import sys
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import yaml
from geometry_msgs.msg import PoseStamped
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.executors import Executor
from rclpy.task import Future
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from gpr_interfaces.action import RunProgram
from gpr_interfaces.msg import PlatformState

from ..bags.markers import marker_array, marker_points
from ..config import GprConfig
from ..errors import ConfigError, GprError
from ..kinematics import ForwardBatch, inverse_batch
from ..messages import stream_messages
from ..sweep import paper_sweep
from .conversions import ROS_TYPES, make_message
from .params import ConfigParameters, declare_parameters
from .program import Program, load_program, parse_program, sample_program
from .qos import latched_qos, stream_qos
from .runtime import EXIT_FAILED, EXIT_OK, GprNode, one_line, run, wait_acknowledged
from .specs import TRAJECTORY

NODE_NAME = 'trajectory_node'
#: Time [s] the subscribers waited for must stay in place before the first sample (see :meth:`TrajectoryNode._ready`).
SETTLE = 0.1
#: Most samples one timer tick publishes to make up for ticks the process could not serve in time.
CATCH_UP = 5
#: The topics of one sample (published together, in this order) and their message types.
STREAM_TOPICS: dict[str, Any] = {'gpr/platform_state': PlatformState, 'gpr/platform_pose': PoseStamped,
                                 'gpr/nominal_pose': PoseStamped, 'gpr/joint_states': JointState,
                                 'gpr/virtual_joints': JointState}


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """A precomputed stream: commanded tilt/azimuth per sample [rad], the forward kinematics, and the station
    each sample is at (-1 while moving or in a sweep) with the stations' names."""

    fk: ForwardBatch
    cmd_tilt: list[float]
    cmd_azimuth: list[float]
    station: list[int]
    station_names: tuple[str, ...]
    description: str
    #: Points of every marker of every sample, by namespace: the machine's own rods and joints
    #: (:func:`gpr_kinematics.bags.markers.marker_points`, from ``MachineGeometry``), for the whole stream at once.
    markers: dict[str, np.ndarray]

    def __len__(self) -> int:
        return len(self.fk)


def stream_markers(cfg: GprConfig, fk: ForwardBatch) -> dict[str, np.ndarray]:
    """The ``gpr/markers`` points of every sample of a stream (what ``gpr verify`` checks them against)."""
    return marker_points(cfg, fk.q, fk.nominal_position, fk.nominal_rotation)


def sweep_trajectory(cfg: GprConfig, height: float, max_tilt: float, tilt_step: float, azimuth_step: float,
                     passes: int) -> Trajectory:
    sw = paper_sweep(height=height, max_tilt=max_tilt, tilt_step=tilt_step, azimuth_step=azimuth_step,
                     passes=passes, config=cfg, model=cfg.model)
    desc = (f'sweep at height {height} m, |alpha| <= {max_tilt:.6g} rad in steps of {tilt_step:.6g} rad, '
            f'azimuth step {azimuth_step:.6g} rad, {passes} pass(es)')
    n = len(sw.forward)
    return Trajectory(sw.forward, np.asarray(sw.alpha, float).tolist(), np.asarray(sw.gamma, float).tolist(),
                      [-1] * n, (), desc, stream_markers(cfg, sw.forward))


def program_trajectory(cfg: GprConfig, prog: Program, rate: float, move_time: float) -> Trajectory:
    """The stream of an offline program; :class:`ConfigError` names the first station out of reach."""
    for i, st in enumerate(prog.stations):  # stations first, for a message that names the station at fault
        try:
            inverse_batch(st.height, st.tilt, st.azimuth, cfg, cfg.model)
        except GprError as exc:
            raise ConfigError(f'{prog.source}: station {i} ({st.name}): {exc}') from None
    samples = sample_program(prog, rate, move_time)
    ik = inverse_batch(samples.height, samples.tilt, samples.azimuth, cfg, cfg.model)
    desc = (f'program {prog.source}: {len(prog.stations)} stations, {samples.time[-1]:.6g} s, '
            f'{len(samples)} samples')
    return Trajectory(ik.achieved, samples.tilt.tolist(), samples.azimuth.tolist(),
                      [int(s) for s in samples.station], tuple(st.name for st in prog.stations), desc,
                      stream_markers(cfg, ik.achieved))


def goal_program(goal: Any) -> Program:
    """The program of a ``RunProgram`` goal: its file, or its inline stations validated as a program file's."""
    has_file, has_stations = bool(goal.program_file), len(goal.stations) > 0
    if has_file == has_stations:
        raise ConfigError('goal: give either program_file or stations; allowed: exactly one of the two')
    if has_file:
        prog = load_program(goal.program_file)
    else:
        stations = []
        for st in goal.stations:
            entry = {'height': st.height, 'tilt': st.tilt, 'azimuth': st.azimuth, 'dwell': st.dwell}
            if st.name:
                entry['name'] = st.name
            if st.move_time != 0.0:
                entry['move_time'] = st.move_time
            stations.append(entry)
        prog = parse_program({'stations': stations}, 'goal stations')
    move_time = float(goal.move_time)
    if move_time != 0.0:
        if not (math.isfinite(move_time) and move_time > 0.0):
            raise ConfigError(f'goal: move_time = {move_time!r} is invalid; allowed: seconds > 0, or 0 for the '
                              'program\'s default')
        prog = dataclasses.replace(prog, move_time=move_time)
    return prog


def geometry_yaml(cfg: GprConfig) -> str:
    """The ``gpr/geometry`` text: YAML of ``cfg.to_dict()`` (a geometry file ``load_config`` accepts)."""
    return yaml.safe_dump(cfg.to_dict(), sort_keys=False)


class TrajectoryNode(GprNode):
    """Publishes precomputed streams, one sample per timer tick; serves ``gpr/run_program``."""

    NODE_NAME = NODE_NAME

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.cfg = ConfigParameters(self, read_only=True).config
        p = self.p = declare_parameters(self, TRAJECTORY)
        qos = stream_qos(int(p['queue_depth']))
        self.stream_publishers = {t: self.create_publisher(ty, t, qos) for t, ty in STREAM_TOPICS.items()}
        self.pub_markers = self.create_publisher(MarkerArray, 'gpr/markers', qos)
        self.publishers_all = (*self.stream_publishers.values(), self.pub_markers)
        self.pub_geometry = self.create_publisher(String, 'gpr/geometry', latched_qos())
        self.pub_geometry.publish(String(data=geometry_yaml(self.cfg)))

        self.sample = 0
        self.stream: Trajectory | None = None
        self.goal: ServerGoalHandle | None = None
        self._goal_done: Future | None = None
        self._reserved = False
        self.index = 0
        self.sent = 0
        self.started_at: float | None = None
        self._wait_start = time.monotonic()
        self._ready_since: float | None = None
        self.period = 1.0 / float(p['rate'])
        self.timer = self.create_timer(self.period, self._tick)
        self.timer.cancel()
        self.action = ActionServer(self, RunProgram, 'gpr/run_program', execute_callback=self._execute,
                                   goal_callback=self._on_goal, cancel_callback=lambda _goal: CancelResponse.ACCEPT)
        t0 = time.perf_counter()
        if p['mode'] == 'sweep':
            traj = sweep_trajectory(self.cfg, p['height'], p['max_tilt'], p['tilt_step'], p['azimuth_step'],
                                    p['passes'])
        elif p['mode'] == 'program':
            if not p['program_file']:
                raise ConfigError('mode program needs the parameter program_file (path of an offline program YAML)')
            traj = program_trajectory(self.cfg, load_program(p['program_file']), p['rate'], p['move_time'])
        else:
            self.get_logger().info(f'idle: serving gpr/run_program at {p["rate"]} Hz (model {self.cfg.model})')
            return
        self.get_logger().info(f'precomputed {len(traj)} samples in {time.perf_counter() - t0:.3f} s '
                               f'({traj.description}, model {self.cfg.model})')
        self.start(traj)

    # -- streams -------------------------------------------------------------------------------------------------
    def start(self, traj: Trajectory, goal: ServerGoalHandle | None = None, done: Future | None = None) -> None:
        """Publish ``traj`` from the next tick on (for ``goal``, completing ``done`` at the end)."""
        self.stream, self.goal, self._goal_done = traj, goal, done
        self.index = 0
        self.started_at = None
        self._wait_start = time.monotonic()
        self._ready_since = None
        self.timer.reset()

    def subscribed_nodes(self) -> int:
        """How many nodes subscribe to every stream topic (``wait_all_topics``) or to ``gpr/platform_state``, and
        are matched: nodes, not subscriptions, so a node that listens to one topic only (a state publisher on
        ``gpr/platform_state``, RViz on ``gpr/markers``) does not count as a recorder of the stream."""
        pubs = self.publishers_all if self.p['wait_all_topics'] else (self.stream_publishers['gpr/platform_state'],)
        nodes = set.intersection(*({(i.node_namespace, i.node_name) for i in
                                    self.get_subscriptions_info_by_topic(pub.topic_name)} for pub in pubs))
        return min(len(nodes), *(pub.get_subscription_count() for pub in pubs))

    def _ready(self) -> bool:
        want = int(self.p['wait_for_subscribers'])
        if want <= 0:
            return True
        if self.subscribed_nodes() >= want:
            # Discovery announces a subscription a moment before every publisher has matched it: settle briefly.
            self._ready_since = self._ready_since or time.monotonic()
            return time.monotonic() - self._ready_since >= SETTLE
        self._ready_since = None
        if time.monotonic() - self._wait_start > float(self.p['wait_timeout']):
            where = 'every stream topic' if self.p['wait_all_topics'] else 'gpr/platform_state'
            self.get_logger().warning(f'no {want} subscriber(s) on {where} after {self.p["wait_timeout"]} s; '
                                      'starting anyway')
            return True
        return False

    def _tick(self) -> None:
        """Publish every sample due by now: sample k of a stream at ``start + k / rate``. A tick the process could
        not serve in time (the machine is busy) is made up at the next one, at most :data:`CATCH_UP` samples at
        once, so the stream keeps its rate on average instead of losing the ticks."""
        if self.stream is None:
            self.timer.cancel()
            return
        cancelled = self.goal is not None and self.goal.is_cancel_requested   # then _step ends it at once
        if self.started_at is None and not cancelled:
            if not self._ready():
                return
            self.started_at = time.monotonic()
            self.sent = 0
            self.get_logger().info(f'started: publishing {len(self.stream)} samples at {self.p["rate"]} Hz '
                                   f'({"goal" if self.goal else self.p["mode"]}'
                                   f'{", looping" if self.p["loop"] and not self.goal else ""})')
        due = int((time.monotonic() - (self.started_at or time.monotonic())) / self.period) + 1
        for _ in range(max(1, min(due - self.sent, CATCH_UP))):
            if self.stream is None or not self._step(self.stream):
                return

    def _step(self, traj: Trajectory) -> bool:
        """Publish sample ``index`` of ``traj`` (and its feedback); False once the stream ended."""
        if self.goal is not None and self.goal.is_cancel_requested:
            self._end('cancelled', f'cancelled before sample {self.index} of {len(traj)} ({self._where(traj)})')
            return False
        try:
            self.publish_sample(traj, self.index)
        except Exception as exc:  # noqa: BLE001 - an escaping exception would end the spin with a traceback
            if not self.context.ok():
                self._end('stopped', 'the node is shutting down')  # SIGINT/SIGTERM while publishing
            else:
                self._end('failed', f'publishing sample {self.sample} failed: {type(exc).__name__}: {one_line(exc)}')
            return False
        if self.goal is not None:
            self.goal.publish_feedback(RunProgram.Feedback(
                sample_index=self.index, sample=self.sample, station=traj.station[self.index],
                station_name=self._station_name(traj, self.index)))
        self.index += 1
        self.sample += 1
        self.sent += 1
        if self.index >= len(traj):
            if self.p['loop'] and self.goal is None:
                self.index = 0
            else:
                self._end('succeeded', f'published all {len(traj)} samples')
                return False
        return True

    @staticmethod
    def _station_name(traj: Trajectory, i: int) -> str:
        k = traj.station[i] if i < len(traj) else -1
        return traj.station_names[k] if k >= 0 else ''

    def _where(self, traj: Trajectory) -> str:
        i = self.index
        if not traj.station_names:
            return 'sweep'
        if i < len(traj) and traj.station[i] >= 0:
            return f'at station {traj.station[i]} ({self._station_name(traj, i)})'
        before = max((traj.station[j] for j in range(min(i, len(traj)))), default=-1)
        return f'moving from station {before} to station {before + 1}'

    def _end(self, outcome: str, message: str) -> None:
        self.timer.cancel()
        elapsed = time.monotonic() - (self.started_at or time.monotonic())
        published = self.index
        achieved = (published - 1) / elapsed if published > 1 and elapsed > 0 else float('nan')
        if outcome != 'stopped':
            self.get_logger().info(f'finished: published {published} samples in {elapsed:.3f} s (achieved '
                                   f'{achieved:.3f} Hz, requested {self.p["rate"]} Hz)'
                                   + ('' if outcome == 'succeeded' else f': {message}'))
        traj, self.stream = self.stream, None
        if self._goal_done is not None:
            self._goal_done.set_result((outcome, message, published, len(traj) if traj else 0))
            self._goal_done = None
        elif outcome in ('succeeded', 'stopped'):
            self.finish(EXIT_OK)
        else:
            self.get_logger().error(f'stopped: {message}')
            self.finish(EXIT_FAILED)

    def publish_sample(self, traj: Trajectory, i: int) -> None:
        msgs = stream_messages(ROS_TYPES, traj.fk[i], stamp_ns=self.get_clock().now().nanoseconds,
                               frame_id=self.p['base_frame'], sample=self.sample,
                               commanded_tilt=traj.cmd_tilt[i], commanded_azimuth=traj.cmd_azimuth[i])
        for topic, pub in self.stream_publishers.items():
            pub.publish(msgs[topic])
        if self.sample % int(self.p['markers_every']) == 0:
            self.pub_markers.publish(marker_array(make_message, msgs['gpr/platform_state'].header,
                                                  {ns: p[i] for ns, p in traj.markers.items()}))

    # -- the gpr/run_program action ----------------------------------------------------------------------------
    def _on_goal(self, _goal: Any) -> GoalResponse:
        """Accept a goal only while no stream runs (one program at a time)."""
        if self.stream is not None or self._reserved:
            self.get_logger().warning('gpr/run_program: goal rejected: a stream is running')
            return GoalResponse.REJECT
        self._reserved = True
        return GoalResponse.ACCEPT

    async def _execute(self, goal: ServerGoalHandle) -> Any:
        result = RunProgram.Result()
        try:
            traj = program_trajectory(self.cfg, goal_program(goal.request), self.p['rate'], self.p['move_time'])
        except GprError as exc:
            self._reserved = False
            result.message = f'cannot run the program: {one_line(exc)}'
            self.get_logger().warning(f'gpr/run_program: {result.message}')
            goal.abort()
            return result
        self.get_logger().info(f'gpr/run_program: {traj.description}')
        done = Future()
        self.start(traj, goal, done)
        self._reserved = False
        outcome, message, published, total = await done
        result.success, result.message = outcome == 'succeeded', message
        result.samples_published, result.samples_total = published, total
        {'succeeded': goal.succeed, 'cancelled': goal.canceled}.get(outcome, goal.abort)()
        return result

    def on_exit(self, executor: Executor, status: int) -> int:
        """After the last sample, wait until every subscription acknowledged what was published (reliable QoS,
        at most 2 s each); a stop signal leaves at once."""
        if not self.signalled:
            wait_acknowledged(self.publishers_all, 2.0)
        self.action.destroy()
        return status


def main(args: Sequence[str] | None = None) -> int:
    return run(TrajectoryNode, args)


if __name__ == '__main__':
    sys.exit(main())

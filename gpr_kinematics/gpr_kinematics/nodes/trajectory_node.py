"""``trajectory_node``: streams compensated GPR platform poses, continuously through singular tilts, and whole-robot
programs (the arm joints and the wafer too).

Topics (relative names), frame ``gpr_base`` (``base_frame``; every frame with ``frame_prefix``), SI units (m, rad):

- ``gpr/platform_state`` (gpr_interfaces/PlatformState): the full state of each sample;
- ``gpr/platform_pose`` / ``gpr/nominal_pose`` (geometry_msgs/PoseStamped): platform pose under the virtual-joint
  model / the naive model;
- ``joint_states`` (sensor_msgs/JointState): the physical joints only, ``rod_1..rod_3`` (rod lengths q [m])
  and, in a robot program, every arm's joints [rad], as ``robot_state_publisher`` expects; ``gpr/virtual_joints``
  (sensor_msgs/JointState): the virtual joints, named as in the core (lengths [m], angles [rad]);
- ``gpr/markers`` (visualization_msgs/MarkerArray): every sample whose counter is a multiple of ``markers_every``
  (:func:`gpr_kinematics.robot.markers.marked`);
- robot programs only: ``gpr/robot_state`` (gpr_interfaces/RobotState) and ``gpr/wafer_pose``
  (geometry_msgs/PoseStamped), both in the robot's world frame (:mod:`gpr_kinematics.robot.stream`);
- ``gpr/geometry`` and ``gpr/robot`` (std_msgs/String, reliable, transient local, depth 1): published once at
  start, the YAML of the node's ``GprConfig.to_dict()`` and of its robot description (``RobotDescription.to_dict``),
  so a recording names the geometry, model and robot that produced it; ``gpr/program`` (the same QoS): as the first
  sample of every stream goes out, what it was asked to do (the sweep's parameters or the program, its first sample
  counter, rate, length and ``markers_every``: :mod:`gpr_kinematics.bags.program_record`), so ``gpr verify``
  recomputes the stream and knows which samples have markers. A goal cancelled before its first sample publishes no
  record: the next stream starts at the same counter, and one counter has one record.

Modes (parameter ``mode``, read-only): ``sweep`` -- the paper's grid (core ``sweep.paper_sweep``): for each
azimuth ``gamma`` in steps of ``azimuth_step``, the tilt ``alpha`` from ``-max_tilt`` to ``+max_tilt`` in steps of
``tilt_step`` at height ``height``, serpentine, ``passes`` times, so every pass crosses the singular
configuration ``alpha = 0``; ``program`` -- an offline program (``program_file``): a platform program (see
:mod:`.program`), interpolated between stations, or a whole-robot program (``format: gpr_robot_program``),
planned and sampled by the robot core, sampled at ``rate``; ``idle`` -- nothing at start. In every mode the node
serves the action ``gpr/run_program`` (gpr_interfaces/RunProgram: a program file of either kind or inline
stations; feedback per sample; cancel stops before the next sample) whenever no stream is running. A stream is
precomputed with the batch API (:mod:`.streams`) before its first sample; a wall timer at ``rate`` [Hz] then
publishes sample k stamped at ``start + k / rate``. A start-up stream ends the node with status 0 after its last
sample unless ``loop`` is true (then it starts over; the sample counter keeps counting; a program must end where it
starts, :func:`~gpr_kinematics.ros.stream_limits.loop_refusal`); ``idle`` runs until SIGINT/SIGTERM.

The action is served by threads of its own (a ``MultiThreadedExecutor``; the action server's callbacks in a
callback group apart from the timer's, a goal planned in the executing thread): while one goal is planned or
streamed, new goals are answered at once (rejected: one program at a time) and cancels too (a goal cancelled while
it is planned ends as cancelled before its first sample). A goal's program file is looked up in the package's
``config/programs`` and the folders of the parameter ``program_folders``, and its files are read only under these
folders and the package's ``config`` (:class:`~gpr_kinematics.ros.streams.GoalFiles`): any other path is refused
naming the path and the rule, never the file's content; every bound of a goal (its stations, its samples) is checked
before the work it bounds.

The node's robot (parameter ``robot_file``; empty: the start-up robot program's robot, else the shipped example)
runs every robot program; its ``gpr`` section is the node's geometry unless ``config_file`` is given.
"""
from __future__ import annotations

import sys
import threading
import time
from collections.abc import Sequence
from typing import Any

from geometry_msgs.msg import PoseStamped
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.clock import Clock, ClockType
from rclpy.executors import Executor, MultiThreadedExecutor
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from gpr_interfaces.action import RunProgram
from gpr_interfaces.msg import PlatformState, RobotState

from ..core.messages import DEFAULT_FRAMES, NS_PER_S, Service, Topic, geometry_text, robot_text, stream_messages
from ..errors import ConfigError, GprError
from ..robot.markers import marked, marker_array
from ..robot.program import RobotProgram, load_any_program, program_robot
from ..robot.urdf import robot_urdf
from ..ros.specs import TRAJECTORY, check_frame_names, check_frame_prefix
from ..ros.stream_limits import loop_refusal, sweep_beyond_rod_limits
from ..ros.streams import (
    GoalFiles,
    Trajectory,
    goal_program,
    record_of,
    sweep_trajectory,
    trajectory_of,
)
from .conversions import ROS_TYPES, make_message
from .params import ConfigParameters, declare_parameters, declare_robot
from .qos import action_server_options, latched_qos, release_request, stream_qos
from .runtime import (
    EXIT_FAILED,
    EXIT_OK,
    GprNode,
    deliver_results,
    finish_callbacks,
    one_line,
    run,
    stop_signal,
    tell,
    wait_acknowledged,
)
from .trajectory_watch import WATCH_PERIOD, ClockWatch, GoalEnd, published_text, station_name, where

NODE_NAME = 'trajectory_node'
#: Time [s] the subscribers waited for must stay in place before the first sample (see :meth:`TrajectoryNode._ready`).
SETTLE = 0.1
#: The topics of one sample (published together, in this order) and their message types.
STREAM_TOPICS: dict[str, Any] = {Topic.PLATFORM_STATE: PlatformState, Topic.PLATFORM_POSE: PoseStamped,
                                 Topic.NOMINAL_POSE: PoseStamped, Topic.JOINT_STATES: JointState,
                                 Topic.VIRTUAL_JOINTS: JointState}
#: The topics a robot program adds to each sample (their types: :data:`gpr_kinematics.bags.typestore.GPR_TOPICS`).
ROBOT_STREAM_TOPICS: dict[str, Any] = {Topic.ROBOT_STATE: RobotState, Topic.WAFER_POSE: PoseStamped}
#: Threads of the node's executor: the timer, the action server's requests, a goal being planned or run, one spare.
THREADS = 4


class TrajectoryNode(GprNode):
    """Publishes precomputed streams, one sample per timer tick; serves ``gpr/run_program``."""

    NODE_NAME = NODE_NAME

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        p = self.p = declare_parameters(self, TRAJECTORY)
        check_frame_names(p, ('base_frame',))
        program = None
        if p['mode'] == 'program':
            if not p['program_file']:
                raise ConfigError('mode program needs the parameter program_file; allowed: the path of an offline '
                                  'program YAML file (-p program_file:=FILE), or another mode')
            program = load_any_program(p['program_file'])
        self.goal_files = GoalFiles.of(p['program_folders'])
        robot_program = program if isinstance(program, RobotProgram) else None
        params = ConfigParameters(self, read_only=True,
                                  robot=declare_robot(self, robot_program.robot if robot_program else None))
        self.cfg, self.robot = params.config, params.robot
        robot_urdf(self.robot, p['base_frame'])  # a base_frame naming another of the robot's frames: refused
        frames = (p['base_frame'], DEFAULT_FRAMES[0], self.robot.world_frame)   # and 'world'
        self.prefix = check_frame_prefix(p['frame_prefix'], frames)
        self.base_frame = self.prefix + p['base_frame']
        if robot_program is not None:
            program_robot(robot_program, self.robot)
        qos = stream_qos(int(p['queue_depth']))
        topics = {**STREAM_TOPICS, **ROBOT_STREAM_TOPICS}
        self.stream_publishers = {t: self.create_publisher(ty, t, qos) for t, ty in topics.items()}
        self.pub_markers = self.create_publisher(MarkerArray, Topic.MARKERS, qos)
        self.publishers_all = (*self.stream_publishers.values(), self.pub_markers)
        self.pub_geometry = self.create_publisher(String, Topic.GEOMETRY, latched_qos())
        self.pub_geometry.publish(String(data=geometry_text(self.cfg)))
        self.pub_robot = self.create_publisher(String, Topic.ROBOT, latched_qos())
        self.pub_robot.publish(String(data=robot_text(self.robot)))
        self.pub_program = self.create_publisher(String, Topic.PROGRAM, latched_qos())

        self.sample = 0
        self._stamped = -1   # the last sample's stamp [ns]: each one later (a simulated clock stands within a tick)
        self._due_ns: int | None = None   # under use_sim_time the instant of the sample published next [ns]
        self.stream: Trajectory | None = None
        self._record_due = False   # the stream's record is published with its first sample
        self.goal: ServerGoalHandle | None = None
        self._goal_done: GoalEnd | None = None
        self._reserved = False
        self._lock = threading.Lock()   # the goal callback, the executing thread and the timer run apart
        self._closing = False
        self.index = 0
        self.sent = self._origin_ns = 0   # _origin_ns: the ROS clock's reading at the pace clock's 0 (wall)
        self.started_at: float | None = None
        self._wait_start = time.monotonic()
        self._ready_since: float | None = None
        self.period = 1.0 / float(p['rate'])
        self.timer = self.create_timer(self.period, self._tick)
        self.timer.cancel()
        self._paced: tuple[float, float] = (0.0, 0.0)   # the pace clock's last reading; seconds before a set-back
        self.clock_watch = ClockWatch()   # a cancel, and simulated time that does not come (on the steady clock)
        self.create_timer(WATCH_PERIOD, self._watch, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.action = ActionServer(self, RunProgram, Service.RUN_PROGRAM, execute_callback=self._execute,
                                   goal_callback=self._on_goal, cancel_callback=lambda _goal: CancelResponse.ACCEPT,
                                   callback_group=MutuallyExclusiveCallbackGroup(), feedback_pub_qos_profile=qos,
                                   **action_server_options())
        t0 = time.perf_counter()
        if p['mode'] == 'sweep':   # a step beyond the rods' velocity at the rate is warned (as a program's move)
            traj = sweep_beyond_rod_limits(sweep_trajectory(self.cfg, p['height'], p['max_tilt'], p['tilt_step'],
                                                            p['azimuth_step'], p['passes']),
                                           self.robot.rods, float(p['rate']), bool(p['loop']))
        elif program is not None:
            traj = trajectory_of(program, self.robot, p['rate'], p['move_time'])
            if p['loop'] and (refusal := loop_refusal(traj, self.robot, float(p['rate']))):   # a jump back
                raise ConfigError(refusal)
        else:
            self.get_logger().info(f'idle: serving gpr/run_program at {p["rate"]} Hz (model {self.cfg.model})')
            return
        tell(self.get_logger(), f'precomputed {len(traj)} samples in {time.perf_counter() - t0:.3f} s '
             f'({traj.description}, model {self.cfg.model})', bool(traj.warning))   # a move beyond the rods' limits
        self.start(traj)

    # -- streams -------------------------------------------------------------------------------------------------
    def make_executor(self) -> Executor:
        """A multi-threaded executor: goals and cancels are answered while a goal is planned (module docstring)."""
        return MultiThreadedExecutor(num_threads=THREADS)

    def start(self, traj: Trajectory, goal: ServerGoalHandle | None = None, done: GoalEnd | None = None) -> None:
        """Publish ``traj`` from the next tick on (for ``goal``, completing ``done`` at the end; its record with its
        first sample, :meth:`_step`)."""
        self._record_due = True   # before the stream: a tick that sees the stream sees its record due
        self.stream, self.goal, self._goal_done = traj, goal, done
        self.index = 0
        self.started_at = None
        self._wait_start = time.monotonic()
        self._ready_since = None
        self.clock_watch.reset(self.get_clock().now().nanoseconds, self._wait_start)
        self.timer.reset()

    def stream_topics(self) -> tuple[Any, ...]:
        """The publishers of the running stream's topics: the platform's and the markers, and the robot's for a robot
        program (a recorder of a platform stream need not subscribe to the robot topics)."""
        robot = self.stream is not None and self.stream.robot is not None
        return tuple(pub for topic, pub in self.stream_publishers.items()
                     if robot or topic not in ROBOT_STREAM_TOPICS) + (self.pub_markers,)

    def subscribed_nodes(self) -> int:
        """How many nodes subscribe to every stream topic (``wait_all_topics``) or to ``gpr/platform_state``, and
        are matched: nodes, not subscriptions, so a node that listens to one topic only (a state publisher on
        ``gpr/platform_state``, RViz on ``gpr/markers``) does not count as a recorder of the stream."""
        pubs = self.stream_topics() if self.p['wait_all_topics'] else (self.stream_publishers[Topic.PLATFORM_STATE],)
        nodes = set.intersection(*({(i.node_namespace, i.node_name) for i in
                                    self.get_subscriptions_info_by_topic(pub.topic_name)} for pub in pubs))
        return int(min(len(nodes), *(pub.get_subscription_count() for pub in pubs)))

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
            where = 'every stream topic' if self.p['wait_all_topics'] else Topic.PLATFORM_STATE
            self.get_logger().warning(f'no {want} subscriber(s) on {where} after {self.p["wait_timeout"]} s; '
                                      'starting anyway')
            return True
        return False

    def _tick(self) -> None:
        """Publish every sample due by now: sample k of a stream at ``start + k / rate``. A tick the process could
        not serve in time (the machine is busy) is made up at the next one, at most :data:`CATCH_UP` samples at
        once, so the stream keeps its rate on average instead of losing the ticks, each sample stamped at its
        instant; under ``use_sim_time`` every sample due at a step of the clock goes out (:data:`~.runtime
        .SIM_CATCH_UP`)."""
        if self.stream is None:
            self.timer.cancel()
            return
        cancelled = self.goal is not None and self.goal.is_cancel_requested   # then _step ends it at once
        if self.started_at is None and not cancelled:
            if not self._ready():
                return
            self.started_at = self.pace_clock()
            self.sent, self._origin_ns = 0, self.get_clock().now().nanoseconds - round(self.started_at * NS_PER_S)
            self._paced = (self.started_at, 0.0)
            self.get_logger().info(f'started: publishing {len(self.stream)} samples at {self.p["rate"]} Hz '
                                   f'({"goal" if self.goal else self.p["mode"]}'
                                   f'{", looping" if self.p["loop"] and not self.goal else ""})')
        now, start = self.pace_clock(), self.started_at   # (a simulated clock may start at 0.0)
        if start is not None and now < self._paced[0] - self.period:   # a simulated clock set back: the rest of the
            self._paced = (now, self._paced[1] + self._paced[0] - start)   # stream from now on, at its rate
            self.get_logger().info(f'the simulated clock went back to {now:.3f} s: the stream goes on from sample '
                                   f'{self.index} of {len(self.stream)} at its rate from there')
            self.started_at, start, self.sent = now, now, 0
        self._paced = (now, self._paced[1])
        due = int((now - (now if start is None else start)) / self.period) + 1
        for _ in range(max(1, min(due - self.sent, self.catch_up()))):
            self._due_ns = None if start is None else round((start + self.sent * self.period) * NS_PER_S) + (
                0 if self.simulated else self._origin_ns)   # the wall's offset taken once: not a jitter per tick
            if self.stream is None or not self._step(self.stream):
                return

    def _step(self, traj: Trajectory) -> bool:
        """Publish sample ``index`` of ``traj`` (and its feedback); False once the stream ended."""
        if self.goal is not None and self.goal.is_cancel_requested:
            self._end('cancelled', f'cancelled before sample {self.index} of {len(traj)} ({where(traj, self.index)})')
            return False
        if self._record_due:   # after the cancel: a stream that publishes no sample publishes no record
            self._record_due = False
            self.pub_program.publish(String(data=record_of(
                traj, self.sample, float(self.p['rate']), bool(self.p['loop']) and self.goal is None,
                float(self.p['move_time']), int(self.p['markers_every']), self.prefix)))
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
                station_name=station_name(traj, self.index)))
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

    def _watch(self) -> None:
        """On the steady clock (:mod:`.trajectory_watch`): end a cancelled goal's stream at once (its timer runs on
        the ROS clock, which a paused simulation stops), and say where a stream waits for simulated time."""
        traj = self.stream
        if traj is None:
            return
        if self.goal is not None and self.goal.is_cancel_requested:
            self._step(traj)   # ends it: 'cancelled before sample k of n (...)'
        elif self.simulated:
            what = 'goal' if self.goal is not None else self.p['mode']
            said = self.clock_watch.check(self.get_clock().now().nanoseconds, time.monotonic(),
                                          f'the {what} stream (before sample {self.index} of {len(traj)})')
            if said is not None:
                tell(self.get_logger(), *said)

    def _end(self, outcome: str, message: str) -> None:
        self.timer.cancel()
        published = self.index
        if outcome != 'stopped':
            elapsed = None if self.started_at is None else self.pace_clock() - self.started_at + self._paced[1]
            self.get_logger().info(f'finished: {published_text(published, elapsed, self.p["rate"])}'
                                   + ('' if outcome == 'succeeded' else f': {message}'))
        with self._lock:  # on_exit may end a goal's stream while the timer's thread ends it too
            traj, self.stream = self.stream, None
            done, self._goal_done = self._goal_done, None
        if done is not None:
            done.set_result((outcome, message, published, len(traj) if traj else 0))
        elif traj is None and self.goal is not None:
            return  # ended already (by the other thread)
        elif outcome in ('succeeded', 'stopped'):
            self.finish(EXIT_OK)
        else:
            self.get_logger().error(f'stopped: {message}')
            self.finish(EXIT_FAILED)

    def publish_sample(self, traj: Trajectory, i: int) -> None:
        # the sample's instant (_tick; an early tick's up to a period ahead), after the last stamp (tf drops repeats);
        # a clock set back a period or more (a simulation reset) is followed. As sent, catch-ups were 12x fast.
        now, period = self.get_clock().now().nanoseconds, round(self.period * NS_PER_S)
        at = now if self._due_ns is None else min(now + period, self._due_ns)
        back = at < self._stamped - period
        stamp_ns = self._stamped = at if back else max(at, self._stamped + 1)
        msgs = stream_messages(ROS_TYPES, traj.fk[i], stamp_ns=stamp_ns,
                               frame_id=self.base_frame, sample=self.sample,
                               commanded_tilt=traj.cmd_tilt[i], commanded_azimuth=traj.cmd_azimuth[i])
        if traj.robot is not None:  # the arm joints join the rods on joint_states; the wafer on its topics
            msgs.update(traj.robot.messages(ROS_TYPES, i, stamp_ns=stamp_ns, sample=self.sample,
                                            base_frame=self.base_frame, frame_prefix=self.prefix))
        for topic, msg in msgs.items():
            self.stream_publishers[topic].publish(msg)
        if marked(self.sample, int(self.p['markers_every'])):
            self.pub_markers.publish(marker_array(make_message, msgs[Topic.PLATFORM_STATE].header,
                                                  {ns: p[i] for ns, p in traj.markers.items()}))

    # -- the gpr/run_program action ----------------------------------------------------------------------------
    def _on_goal(self, _goal: Any) -> GoalResponse:
        """Accept a goal only while no stream runs and no goal is being planned (one program at a time)."""
        with self._lock:
            if self.stream is not None or self._reserved or self._closing:
                why = ('the node is shutting down' if self._closing else 'a goal is being planned' if self._reserved
                       else 'a stream is running')
                self.get_logger().warning(f'gpr/run_program: goal rejected: {why}')
                return GoalResponse.REJECT
            self._reserved = True
        return GoalResponse.ACCEPT

    def _refuse(self, goal: ServerGoalHandle, result: Any, message: str, cancelled: bool = False) -> Any:
        with self._lock:
            self._reserved = False
        result.message = message
        self.get_logger().warning(f'gpr/run_program: {message}')
        if cancelled:
            goal.canceled()
        else:
            goal.abort()
        return result

    def _execute(self, goal: ServerGoalHandle) -> Any:
        """Plan the goal's program in this thread (the executor's others answer goals and cancels meanwhile), then
        stream it and wait for its end."""
        result = RunProgram.Result()
        try:
            traj = trajectory_of(goal_program(goal.request, self.robot, self.goal_files), self.robot, self.p['rate'],
                                 self.p['move_time'])
        except Exception as exc:  # noqa: BLE001 - a goal must end with a result, and later goals be served
            reason = one_line(exc) if isinstance(exc, GprError) else f'internal error: {type(exc).__name__}: ' \
                f'{one_line(exc)}'
            return self._refuse(goal, result, f'cannot run the program: {reason}')
        finally:
            release_request(goal)
        if goal.is_cancel_requested:
            result.samples_total = len(traj)
            return self._refuse(goal, result, f'cancelled before sample 0 of {len(traj)} (while it was planned)',
                                cancelled=True)
        if self._closing:
            return self._refuse(goal, result, 'the node is shutting down')
        tell(self.get_logger(), f'gpr/run_program: {traj.description}', bool(traj.warning))
        done = GoalEnd()
        with self._lock:
            self.start(traj, goal, done)
            self._reserved = False
        outcome, message, published, total = done.wait()
        result.success, result.message = outcome == 'succeeded', message
        result.samples_published, result.samples_total = published, total
        if outcome == 'succeeded':
            goal.succeed()
        elif outcome == 'cancelled':
            goal.canceled()
        else:
            goal.abort()
        return result

    def on_exit(self, executor: Executor, status: int) -> int:
        """After the last sample, wait until every subscription acknowledged what was published (reliable QoS,
        at most 2 s each); a stop signal leaves at once."""
        with self._lock:
            self._closing = True
        traj = self.stream
        if traj is not None and self.signalled:   # where the stream stopped (a goal's client gets it in its result)
            looping = self.goal is None and self.p['loop']
            published = self.sample if looping else self.index   # (a start-up stream counts from 0)
            elapsed = None if self.started_at is None else self.pace_clock() - self.started_at + self._paced[1]
            self.get_logger().info(f'finished: {published_text(published, elapsed, self.p["rate"])}: stopped by '
                                   f'{stop_signal() or "a signal"} at sample {self.index} of {len(traj)}'
                                   f'{f" (pass {self.sample // len(traj) + 1})" if looping else ""}: the node is '
                                   'shutting down')
        goal = self.goal if traj is not None and self._goal_done is not None else None
        if goal is not None:  # the thread executing the goal returns, and its client hears the result
            self._end('stopped', 'the node is shutting down')
            deliver_results(executor, [goal])
        finish_callbacks(executor)
        if not self.signalled:
            wait_acknowledged(self.publishers_all, 2.0)
        self.action.destroy()
        return status


def main(args: Sequence[str] | None = None) -> int:
    return run(TrajectoryNode, args)


if __name__ == '__main__':
    sys.exit(main())

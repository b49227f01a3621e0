"""``robot_simulator_node``: the robot's stand-in controller, a ``control_msgs/action/FollowJointTrajectory`` server.

It serves ``joint_trajectory_controller/follow_joint_trajectory`` (in the node's namespace, as ros2_control's
``joint_trajectory_controller`` would), so MoveIt, ``gpr program send`` or ``ros2 action send_goal`` drive it as the
real robot's controller. A goal names any of the robot's joints (the rods ``rod_1 .. rod_3``, the arms' joints; the
others hold) and is checked before anything moves (:func:`gpr_kinematics.robot.goal.plan_goal`: names, limits,
times, the platform's tilt; with ``cell_file``, the clearance of the whole interpolated motion, certified between
samples: :class:`gpr_kinematics.safety.goal.GoalClearance`); a goal it refuses is aborted with the standard
``error_code`` and an ``error_string`` naming what was wrong. A goal it accepts is sampled at ``rate`` and published
on ``joint_states`` (every joint, position and velocity, stamped at the start plus ``t_k = k / rate``) with one
feedback per sample; the joints follow the samples exactly, or with the first-order lag ``servo_time_constant``
(checked along the path it takes, :class:`~gpr_kinematics.robot.servo.Lag`). Path tolerances are checked at every
sample, the goal tolerance after the last point within ``goal_time_tolerance``; cancel stops at once (``SUCCESSFUL``,
the state held; watched on the steady clock: a paused or missing ``/clock`` held it; a wait for it is told); a new
goal that passes the checks preempts the running one (canceled, ``INVALID_GOAL``, as joint_trajectory_controller
does); a goal running when the node stops ends aborted, its client told, and one whose clock goes back more than a
sample period ends aborted naming the jump (:func:`~gpr_kinematics.robot.goal.clock_set_back`). A ``header.stamp``
of 0 starts at once, a later one then, one in the past as joint_trajectory_controller takes it
(:func:`~gpr_kinematics.robot.controller.late_start`).

While no goal runs it publishes the state it holds on ``joint_states`` at ``idle_rate`` (before the first goal its
rest, :attr:`~..robot.controller.ControllerJoints.rest`; then where one ended, lagging joints converging), and takes
the joint values other publishers send on ``joint_states`` as its state, quietly while they stream
(``trajectory_node``; values beyond the limits, a tilt beyond the limit, with ``cell_file`` a state or a line to it
within ``clearance_margin``: :meth:`~..safety.goal.GoalClearance.move`, at most every :data:`FOREIGN_CHECK` s, are
ignored with a warning). Parameters: ``robot_file``, ``config_file``, the geometry (read-only) and
:data:`gpr_kinematics.ros.specs.SIMULATOR` (docs/ros.md).
"""
from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from control_msgs.action import FollowJointTrajectory
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import GoalEvent, ServerGoalHandle
from rclpy.clock import Clock, ClockType
from rclpy.executors import Executor
from rclpy.task import Future
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectoryPoint

from ..core.messages import FOLLOW_JOINT_TRAJECTORY, NS_PER_S, Topic, time_parts
from ..errors import ConfigError, GprError
from ..robot.controller import (
    GOAL_TOLERANCE_VIOLATED,
    INVALID_GOAL,
    PATH_TOLERANCE_VIOLATED,
    SUCCESSFUL,
    ControllerJoints,
    GoalError,
    Motion,
    Tolerances,
    joint_state_values,
)
from ..robot.goal import Controller, clock_set_back, plan_goal
from ..robot.servo import servo, violation
from ..ros.specs import SIMULATOR
from ..safety.cell import load_cell
from ..safety.goal import GoalClearance
from .conversions import duration_msg, goal_of_request
from .foreign_states import OtherServers, RefusalLog, outside
from .params import ConfigParameters, declare_parameters, declare_robot
from .qos import action_server_options, joint_states_subscription, release_request, stream_qos
from .runtime import GprNode, deliver_results, one_line, run, tell
from .trajectory_watch import WATCH_PERIOD, ClockWatch

NODE_NAME = 'robot_simulator_node'
#: How many of its latest states it remembers to tell its own messages heard back from another publisher's.
OWN_KEPT = 256
#: Shortest time [s, the node's clock] between two clearance checks of another publisher's states (with a cell): a
#: faster stream's latest state (by the line from the held one; ~15 ms a check), the one pending at the next tick.
FOREIGN_CHECK = 0.1


@dataclass
class _Run:
    """A goal under way: handle, motion, start [ns], the future its execution awaits, latest clock [ns], next sample."""

    goal: ServerGoalHandle
    motion: Motion
    start_ns: int
    done: Future
    clock_ns: int
    k: int = 0
    started: float | None = None


def _within(now: int, then: int | None, span: int) -> bool:
    """``then`` lies at most ``span`` [ns] before ``now`` on the node's clock (a clock set back since: no)."""
    return then is not None and 0 <= now - then <= span


def _streaming(now: int, last_foreign: int | None, idle_rate: Any) -> bool:
    """Another publisher streams the robot's states: its last one at most two idle periods before ``now`` [ns]."""
    return _within(now, last_foreign, 2 * round(NS_PER_S / float(idle_rate)))


class RobotSimulatorNode(GprNode):
    """Serves FollowJointTrajectory on the robot's joints, publishes ``joint_states`` (module docstring)."""

    NODE_NAME = NODE_NAME

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        params = ConfigParameters(self, read_only=True, robot=declare_robot(self))
        self.cfg, self.robot = params.config, params.robot
        p = self.p = declare_parameters(self, SIMULATOR)
        self.joints = ControllerJoints.of(self.robot)
        n = len(self.joints.names)
        #: The cell's clearance check of a goal's whole motion (None: no cell_file).
        self.clearance: GoalClearance | None = None
        wafer_arms = tuple(a for a in p['wafer_arms'] if a)
        if p['cell_file']:
            self.clearance = GoalClearance(self.robot, load_cell(p['cell_file']), float(p['clearance_margin']),
                                           wafer_arms=wafer_arms)
        elif wafer_arms:  # taken without a word before: the wafers are checked against a cell only
            raise ConfigError(f'wafer_arms = {list(wafer_arms)} needs a cell_file (the carried wafers are checked '
                              "against the cell's bodies); allowed: [''] (none) without a cell_file")
        self.actual, self.velocity = self.joints.rest.copy(), np.zeros(n)
        self.command: Any = None   # a goal's last point the lagging joints converge to (servo_time_constant)
        self.period = 1.0 / float(p['rate'])
        tol = Tolerances.uniform(n, p['path_tolerance'], p['goal_tolerance'], p['goal_time'])
        self.controller = Controller(self.joints, tol, float(p['rate']), self.cfg, float(p['start_tolerance']),
                                     bool(p['allow_nonzero_velocity_at_trajectory_end']), self.clearance,
                                     float(p['servo_time_constant']))
        self.run: _Run | None = None
        #: The states it published lately, stamp [ns] -> positions: its own messages heard back are not another
        #: publisher's (told by content: under a stepped simulated clock a stream's samples share or precede the stamp
        #: of its held state, and after a clock set back every stamp is older than the last one it published).
        self.own: dict[int, tuple[float, ...]] = {}
        #: When [ns, the node's clock] it last took another publisher's values, and last published its own.
        self.last_foreign: int | None = None
        self.refusing = False   # the cell refused the last foreign state checked: its stream does not silence the node
        self.refusals = RefusalLog(self.get_logger())   # its warnings, throttled per refusal
        self.last_published: int | None = None
        #: Another publisher's latest state, waiting for its clearance check (with a cell), and when one last ran [ns].
        self.pending: Any = None
        self.last_check: int | None = None
        qos = stream_qos(int(p['queue_depth']))
        self.pub = self.create_publisher(JointState, Topic.JOINT_STATES, qos)
        joint_states_subscription(self, self._on_joint_states, qos.depth, p['joint_states_reliability'])
        self.motion_timer = self.create_timer(self.period, self._tick)
        self.motion_timer.cancel()
        self.create_timer(1.0 / float(p['idle_rate']), self._idle)
        self.clock_watch = ClockWatch()   # a cancel, and simulated time that does not come (on the steady clock)
        self.create_timer(WATCH_PERIOD, self._watch, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.action = ActionServer(self, FollowJointTrajectory, FOLLOW_JOINT_TRAJECTORY, execute_callback=self._execute,
                                   goal_callback=lambda _goal: GoalResponse.ACCEPT,
                                   cancel_callback=lambda _goal: CancelResponse.ACCEPT, feedback_pub_qos_profile=qos,
                                   **action_server_options())
        self.other_servers, cell = OtherServers(self, self.action_name()), self.clearance
        self.get_logger().info(f'serving {self.action_name()} (control_msgs/action/FollowJointTrajectory) for '
                               f'{n} joints ({", ".join(self.joints.names)}) of robot {self.robot.name} at '
                               f'{p["rate"]} Hz; joint_states held at {p["idle_rate"]} Hz while idle; '
                               + (f'goals checked against cell {cell.cell.source} ({len(cell.cell.obstacles)} '
                                  f'obstacles, {len(cell.pairs)} pairs, margin {cell.margin:g} m, wafers on '
                                  f'{", ".join(cell.wafer_arms) or "no arm"})' if cell is not None
                                  else 'no cell_file: no clearance check'))

    def action_name(self) -> str:
        ns = self.get_namespace().rstrip('/')
        return f'{ns}/{FOLLOW_JOINT_TRAJECTORY}'

    # -- joint_states ---------------------------------------------------------------------------------------------
    def publish_state(self, stamp_ns: int) -> None:
        msg = JointState(name=list(self.joints.names), position=self.actual.tolist(), velocity=self.velocity.tolist())
        msg.header.stamp.sec, msg.header.stamp.nanosec = time_parts(stamp_ns)
        self.pub.publish(msg)
        self.own[stamp_ns] = tuple(msg.position)
        if len(self.own) > OWN_KEPT:
            del self.own[next(iter(self.own))]
        self.last_published = self.get_clock().now().nanoseconds

    def _on_joint_states(self, msg: JointState) -> None:
        """While idle, take another publisher's joint values as the robot's state (module docstring); a
        message whose values leave the joints' limits or tilt the platform beyond its limit, or that is malformed
        (not one position per name, a joint named twice: :func:`~gpr_kinematics.robot.controller.joint_state_values`),
        is ignored, with a warning, so no publisher can put the robot where no goal can start."""
        stamp = msg.header.stamp.sec * NS_PER_S + msg.header.stamp.nanosec
        if self.run is not None or self.own.get(stamp) == tuple(msg.position):   # running, or its own message
            return
        try:
            taken, values, left = joint_state_values(self.joints.names, msg.name, msg.position)
        except GprError as exc:
            self.refusals.warn(f'joint_states of another publisher ignored: {one_line(exc)}')
            return
        if left:
            self.refusals.warn(f'joint_states of another publisher: {", ".join(left)} not finite, left out; '
                               'allowed: finite positions')
        if not taken.size:   # none of this robot's joints (a gripper's, say): nothing to take, nothing to silence
            return
        state = (self.actual if self.pending is None else self.pending).copy()
        state[taken] = values
        wrong = self._outside(state)
        if wrong:
            self.refusals.warn(f'joint_states of another publisher ignored: {wrong}')
            return
        now = self.get_clock().now().nanoseconds
        if not self.refusing:   # quiet while values it takes stream (not others, nor a stream the cell refuses)
            self.last_foreign = now
        if self.clearance is None:
            self.actual, self.command = state, None
            self.velocity[:] = 0.0
            return
        self.pending = state
        if not _within(now, self.last_check, round(FOREIGN_CHECK * NS_PER_S)):
            self._settle()

    def _settle(self) -> None:
        """Take the pending state of another publisher if the cell allows it
        (:meth:`~gpr_kinematics.safety.goal.GoalClearance.move`: outside ``clearance_margin``, and so is the
        joint-space line from the held state), else ignore it with a warning: no publisher puts the robot in an
        obstacle or through one."""
        state, self.pending = self.pending, None
        if state is None or self.clearance is None or self.run is not None:   # a goal moves the robot now
            return
        why = self.clearance.move(self.actual, state)
        self.last_check = self.get_clock().now().nanoseconds   # from the check's end: one slower than FOREIGN_CHECK
        # (a refused move is up to three checks, 0.13 s) made every queued message start another: 20 s stalled
        self.refusing = bool(why)
        if why:
            self.last_foreign = None   # the held state is the robot's: published at idle_rate again
            self.refusals.warn(f'joint_states of another publisher ignored: {why}; allowed: states with every pair at '
                               'least clearance_margin apart, reached along a joint-space line that keeps it')
            return
        self.actual, self.command = state, None
        self.velocity[:] = 0.0

    def _outside(self, state: Any) -> str:
        """:func:`~gpr_kinematics.nodes.foreign_states.outside` with the node's joints and geometry."""
        return outside(self.joints, self.cfg, state)

    def _idle(self) -> None:
        period = round(NS_PER_S / float(self.p['idle_rate']))
        # Quiet while another publisher streams (two periods since its last message), and not right after a state of
        # its own (half a period: the end of a goal); a whole period skipped every other tick, early by the timer's
        # jitter, and held the state at half the rate. A goal waiting for its header.stamp holds the state too (it
        # was silent until then, up to a day: clients took the robot for gone).
        stamp = self.get_clock().now().nanoseconds
        if not _within(stamp, self.last_check, round(FOREIGN_CHECK * NS_PER_S)):
            self._settle()   # the last state a stream left pending, at most every FOREIGN_CHECK s (any idle_rate)
            stamp = self.get_clock().now().nanoseconds
        waiting = self.run is None or stamp < self.run.start_ns
        if waiting and not _streaming(stamp, self.last_foreign, self.p['idle_rate']) and \
                not _within(stamp, self.last_published, period // 2):
            self._converge(stamp)
            self.publish_state(stamp)

    def _converge(self, stamp: int) -> None:
        """Lagging joints move on toward the ended goal's last point, commanded still (as in a real controller); while a
        goal waits for its start, on the line its checks followed (:meth:`~..robot.servo.Lag.waited`)."""
        before, dt, r = self.actual, max(stamp - (self.last_published or stamp), 0) / NS_PER_S, self.run
        if self.command is None or dt == 0.0:
            self.velocity[:] = 0.0
            return
        self.actual = lag.waited(lag.wait - (r.start_ns - stamp) / NS_PER_S) if r and (lag := r.motion.lag) else \
            servo(before, self.command, dt, float(self.p['servo_time_constant']))
        self.velocity = (self.actual - before) / dt
        if np.max(np.abs(self.actual - self.command)) <= 1e-12:   # there, to the last picometre or picoradian
            self.actual, self.command = self.command, None

    # -- goals ----------------------------------------------------------------------------------------------------
    def _check(self, req: Any) -> tuple[Motion, int]:
        """The motion of a goal and its start [ns] (:func:`~gpr_kinematics.robot.goal.plan_goal`); :class:`GoalError`
        with the result code (module docstring)."""
        if self.run is None:
            self._settle()   # another publisher's latest state, before the goal starts from it
            if _streaming(self.get_clock().now().nanoseconds, self.last_foreign, self.p['idle_rate']):   # /tf flickered
                raise GoalError(INVALID_GOAL, "another node streams this robot's joint_states (a program or sweep of "
                                'trajectory_node, say); allowed: a goal once that stream has ended')
        goal = goal_of_request(req)
        # lagging joints the goal leaves out go on toward their command (they froze where it found them)
        return plan_goal(goal, self.controller, self.actual, self.get_clock().now().nanoseconds, self.command)

    async def _execute(self, goal: ServerGoalHandle) -> Any:
        result = FollowJointTrajectory.Result()
        try:    # checked before it preempts a running goal: a goal refused leaves the robot's motion as it was
            motion, start = self._check(goal.request)
        except GprError as exc:
            code = exc.code if isinstance(exc, GoalError) else INVALID_GOAL
            result.error_code, result.error_string = code, one_line(exc)
            self.get_logger().warning(f'goal refused ({code}): {result.error_string}')
            goal.abort()
            return result
        except Exception as exc:  # noqa: BLE001 - a goal must end with a result, and later goals be served
            result.error_code = INVALID_GOAL
            result.error_string = f'internal error: {type(exc).__name__}: {one_line(exc)}'
            self.get_logger().error(f'goal refused: {result.error_string}')
            goal.abort()
            return result
        finally:
            release_request(goal)
        if self.run is not None and self.run.goal.is_cancel_requested:   # its cancel came first: it ends cancelled
            self._cancelled(self.run)
        elif self.run is not None:    # preempted by a valid goal, as joint_trajectory_controller does
            old, n = self.run, len(self.run.motion)   # past its samples while lagging joints settle ('58 of its 51')
            when = f'after {old.k} of its {n} samples' if old.k <= n else \
                f'{(old.k - n) * self.period:.6g} s after its last point'
            self._end('preempted', INVALID_GOAL, f'preempted by a newer goal {when}')
        done = Future()
        self.run = _Run(goal, motion, start, done, self.get_clock().now().nanoseconds)   # the command: at its start
        self.get_logger().info(f'goal accepted: {len(motion.trajectory)} points over '
                               f'{", ".join(motion.trajectory.joint_names)}, {motion.duration:.6g} s, '
                               f'{len(motion)} samples')
        self.motion_timer.reset()
        self.clock_watch.reset(self.run.clock_ns, time.monotonic())
        outcome, code, text = await done
        result.error_code, result.error_string = code, text
        if outcome == 'succeeded':
            goal.succeed()
        elif outcome == 'canceled':
            goal.canceled()
        elif outcome == 'preempted':  # canceled, as joint_trajectory_controller ends a preempted goal: rclpy's handle
            goal._update_state(GoalEvent.CANCEL_GOAL)   # gets there through canceling, as a client's cancel takes it
            goal.canceled()
        else:
            goal.abort()
        return result

    def _end(self, outcome: str, code: int, text: str) -> None:
        r, self.run = self.run, None
        self.motion_timer.cancel()
        self.velocity[:] = 0.0
        if r is None:
            return
        if r.started is not None:   # else the last goal's command stands (the joints converge on); lagging: on to
            self.command = r.motion.positions[-1].copy() if outcome == 'succeeded' and r.motion.lag else None  # its end
        if outcome == 'succeeded':   # rclpy: one severity per call site
            self.get_logger().info(f'goal {outcome} ({code}): {text}')
        else:
            self.get_logger().warning(f'goal {outcome} ({code}): {text}')
        r.done.set_result((outcome, code, text))

    def _cancelled(self, r: _Run) -> None:
        """End ``r``, whose cancel was accepted, as cancelled (at the next tick, or when a newer goal preempts it
        first: it ended aborted as 'preempted' although its client's cancel had been accepted)."""
        m, before = r.motion, 'nothing moved' if self.command is None else "lagging joints go on to the last goal's end"
        k = max(r.k - 1, 0)   # the last sample sent (r.k: the next), goal's time; lagging joints settle after the last
        t = m.late + (m.time[k] if k < len(m) else m.time[-1] + (k - len(m) + 1) * self.period)
        self._end('canceled', SUCCESSFUL, f'cancelled before its start; {before}' if r.started is None else
                  f'cancelled at t = {t:.6g} s of {m.late + m.duration:.6g} s; the joints hold where they are')

    def _watch(self) -> None:
        """On the steady clock: a cancelled goal ends at once (the motion's timer runs on the ROS clock, which a
        missing or paused ``/clock`` stops: a cancel waited for it without a word), and a goal waiting for simulated
        time says so (:class:`~.trajectory_watch.ClockWatch`)."""
        r = self.run
        if r is not None and r.goal.is_cancel_requested:
            self._cancelled(r)
        elif r is not None and self.simulated:
            said = self.clock_watch.check(self.get_clock().now().nanoseconds, time.monotonic(),
                                          f'the goal (at sample {r.k} of {len(r.motion)})')
            if said is not None:
                tell(self.get_logger(), *said)

    def _tick(self) -> None:
        """Publish every sample due by now (at most :meth:`~.runtime.GprNode.catch_up`), checking the tolerances."""
        r = self.run
        if r is None:
            self.motion_timer.cancel()
            return
        if r.goal.is_cancel_requested:
            self._cancelled(r)
            return
        clock = self.get_clock().now().nanoseconds
        back = clock_set_back(r.clock_ns, clock, self.period, None if r.started is None else
                              float(r.motion.time[min(max(r.k - 1, 0), len(r.motion) - 1)]))
        if back:   # it waited, silent, for as long as the jump
            self._end('aborted', INVALID_GOAL, back)
            return
        r.clock_ns = max(r.clock_ns, clock)
        if clock < r.start_ns:
            return
        now = self.pace_clock()
        if r.started is None:
            r.started, self.command = now, None
        due = int((now - r.started) / self.period) + 1
        for _ in range(max(1, min(due - r.k, self.catch_up()))):
            if self.run is not r or not self._step(r):
                return

    def _step(self, r: _Run) -> bool:
        """Sample ``r.k``: move, publish, feedback, tolerances; False once the goal ended."""
        m, tol = r.motion, r.motion.tolerances
        K = len(m)
        settling = r.k >= K
        t = m.time[-1] + (r.k - K + 1) * self.period if settling else float(m.time[r.k])
        desired = m.positions[-1] if settling else m.positions[r.k]
        desired_v = np.zeros_like(desired) if settling else m.velocities[r.k]
        dt = 0.0 if r.k == 0 else (self.period if settling else float(m.time[r.k] - m.time[r.k - 1]))
        tau = float(self.p['servo_time_constant'])
        before = self.actual
        self.actual = servo(before, desired, dt, tau) if m.lag is None or settling else m.lag.samples[r.k].copy()
        self.velocity = desired_v.copy() if tau <= 0.0 else (self.actual - before) / dt if dt > 0 else 0 * before
        self.publish_state(r.start_ns + round(t * NS_PER_S))
        self._feedback(r, t, desired, desired_v)
        r.k += 1
        err, err_v = desired - self.actual, desired_v - self.velocity
        if not settling:
            broken = violation(self.joints, m.goal, err, err_v, tol.path_position, tol.path_velocity, 'path')
            if broken:
                self._end('aborted', PATH_TOLERANCE_VIOLATED, f'at t = {m.late + t:.6g} s: {broken}')
                return False
        if r.k >= K:
            final = m.positions[-1] - self.actual
            off = violation(self.joints, m.goal, final, -self.velocity, tol.goal_position, tol.goal_velocity, 'goal')
            if off is None:
                self._end('succeeded', SUCCESSFUL, f'reached the last point at t = {m.late + t:.6g} s ({K} samples'
                          + (f', then {r.k - K} as the joints settled)' if r.k > K else ')'))   # not all of r.k
                return False
            if t > m.duration + tol.goal_time + 1e-9:
                self._end('aborted', GOAL_TOLERANCE_VIOLATED, f'{t - m.duration:.6g} s after the last point '
                          f'(goal_time_tolerance {tol.goal_time:g} s): {off}')   # the error's instant: one sample later
                return False
        return True

    def _feedback(self, r: _Run, t: float, desired: Any, desired_v: Any) -> None:
        g = r.motion.goal
        stamp = r.start_ns + round(t * NS_PER_S)
        fb = FollowJointTrajectory.Feedback(joint_names=list(r.motion.trajectory.joint_names))
        fb.header.stamp.sec, fb.header.stamp.nanosec = time_parts(stamp)
        at = duration_msg(r.motion.late + t)   # from the goal's header.stamp, where its points' times count from
        fb.desired = JointTrajectoryPoint(positions=desired[g].tolist(), velocities=desired_v[g].tolist(),
                                          time_from_start=at)
        fb.actual = JointTrajectoryPoint(positions=self.actual[g].tolist(), velocities=self.velocity[g].tolist(),
                                         time_from_start=at)
        fb.error = JointTrajectoryPoint(positions=(desired[g] - self.actual[g]).tolist(),
                                        velocities=(desired_v[g] - self.velocity[g]).tolist(), time_from_start=at)
        r.goal.publish_feedback(fb)

    def on_exit(self, executor: Executor, status: int) -> int:
        goal = None if self.run is None else self.run.goal
        if self.run is not None:
            self._end('aborted', INVALID_GOAL, 'the controller is shutting down')
        deliver_results(executor, [goal])   # its client hears the result before the server goes
        self.action.destroy()
        return status


def main(args: Sequence[str] | None = None) -> int:
    return run(RobotSimulatorNode, args)


if __name__ == '__main__':
    sys.exit(main())

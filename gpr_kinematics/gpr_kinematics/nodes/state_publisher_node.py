"""``state_publisher_node``: the robot model and its transforms for RViz and tf (the robot's robot_state_publisher).

Publishes, from the robot description (``robot_file``, default the shipped example) and the geometry parameters
(the same ``GprConfig`` keys as the other nodes, read-only; the description's ``gpr`` section unless
``config_file`` is given):

- ``robot_description`` (std_msgs/String, reliable, transient local, depth 1, as ``robot_state_publisher``): the
  URDF of :func:`gpr_kinematics.robot.urdf.robot_urdf`: the world, the GPR, the arms, blades and wafers, every link
  named with ``frame_prefix``;
- ``/tf_static`` (tf2_msgs/TFMessage, transient local): the fixed joints: ``world -> gpr_base`` (the robot's base),
  the rod guides on the base, each arm's blade and wafer;
- ``/tf`` (tf2_msgs/TFMessage): for every ``joint_states`` message received (sensor_msgs/JointState, relative: the
  node's namespace, remappable; from ``robot_simulator_node``, ``trajectory_node`` or a replayed bag), stamped with
  its stamp, the robot at the joint values it carries and those it holds for the joints it does not carry:
  ``base_frame -> platform_frame`` (the exact pose: forward kinematics of the rods under the node's virtual-joint
  model), ``base_frame -> nominal_frame`` (the naive model's pose), ``gpr_rod_guide_k -> gpr_rod_k`` (rod k at its
  length ``q_k``) and each arm's links (``platform_frame -> <arm>_link1 -> ... -> <arm>_link<n>``);
- ``gpr/cell`` (visualization_msgs/MarkerArray, transient local), when ``cell_file`` names a process cell: its
  obstacles in the cell's frame (with ``frame_prefix``; :func:`gpr_kinematics.safety.markers.cell_marker_array`).

The state is held: the joints start at the robot's rest (equal rods at mid-stroke, each arm at its ``home``; the
robot simulator's state before its first goal) and keep the last value received (a value beyond its joint's
limits, or rods beyond the stroke or the tilt limit, shown as received, as robot_state_publisher shows a measured
state, with a warning at most every 5 s), and while no ``joint_states``
arrive the held state is published again at ``idle_rate``, stamped in the time base of the last ``joint_states``
(its stamp plus the node clock's time since it arrived; the current time before any: a replayed bag's /tf had the
bag's stamps and the wall clock's, 64 s apart, and tf2 drops data that old), as ``joint_state_publisher``
keeps ``robot_state_publisher`` fed, and at once to a /tf subscription that matches meanwhile (a publisher-matched
event): so ``/tf`` has the whole robot before the first motion, between motions and after the last, a listener
getting it as soon as DDS discovery connects them (docs/ros.md, "tf at start-up"). ``frame_prefix`` (``r1/``)
prefixes every frame, as robot_state_publisher's does; another publisher of the robot's frames on ``/tf_static`` (a
second state publisher with the same prefix) is warned of once (:class:`~.foreign_states.OtherFramePublishers`).

A robot_state_publisher cannot do this from the URDF alone: the platform closes an overconstrained loop (three rods,
one platform), so its pose is not a function of a joint tree; here it is the kinematics' answer for the rods.
Parameters: ``robot_file``, ``base_frame``, ``platform_frame``, ``nominal_frame``, ``frame_prefix``, ``idle_rate``,
``queue_depth``, ``joint_states_reliability`` (reliable; ``best_effort`` hears a best-effort driver, as
robot_state_publisher does), ``cell_file`` (see :mod:`.specs`).
"""
from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from geometry_msgs.msg import TransformStamped
from rclpy.event_handler import PublisherEventCallbacks, QoSPublisherMatchedInfo
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from ..core import forward
from ..core.messages import Topic
from ..errors import GprError, LimitError, NoPoseError
from ..inputs.validation import MAX_COORDINATE
from ..robot.controller import ControllerJoints, joint_state_values
from ..robot.urdf import Joint, RobotUrdf, robot_urdf
from ..ros.specs import STATE_PUBLISHER, check_frame_names, check_frame_prefix
from ..safety.cell import load_cell
from ..safety.markers import cell_marker_array
from .conversions import make_message, message_class, transform_msg
from .foreign_states import OtherFramePublishers
from .params import ConfigParameters, declare_parameters, declare_robot
from .qos import joint_states_subscription, latched_qos, stream_qos
from .runtime import GprNode, one_line, run

NODE_NAME = 'state_publisher_node'


def _stamped(stamp: Any, parent: str, child: str, translation: Sequence[float],
             rotation: Sequence[float]) -> TransformStamped:
    t = TransformStamped(child_frame_id=child, transform=transform_msg(translation, rotation))
    t.header.stamp = stamp
    t.header.frame_id = parent
    return t


class StatePublisherNode(GprNode):
    """Publishes the URDF and the fixed transforms once, then the transforms of the held state (module docstring)."""

    NODE_NAME = NODE_NAME

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        params = ConfigParameters(self, read_only=True, robot=declare_robot(self))
        self.cfg, robot = params.config, params.robot
        p = declare_parameters(self, STATE_PUBLISHER)
        check_frame_names(p, ('base_frame', 'platform_frame', 'nominal_frame'))
        model = robot_urdf(robot, p['base_frame'], p['platform_frame'], p['nominal_frame'])
        prefix = check_frame_prefix(p['frame_prefix'], [link.name for link in model.links])   # every frame it names
        self.model: RobotUrdf = model.prefixed(prefix)
        self.base, self.platform, self.nominal = (prefix + p[k] for k in ('base_frame', 'platform_frame',
                                                                            'nominal_frame'))
        joints = self.joints = ControllerJoints.of(robot)
        #: The robot model's joints moved by joint values (rods, then every arm's), and their held values.
        self.moving: list[Joint] = [self.model.joint(n) for n in joints.names]
        self.held = joints.rest.copy()
        self.lower, self.upper = joints.lower, joints.upper
        self.pub_description = self.create_publisher(String, Topic.ROBOT_DESCRIPTION, latched_qos())
        self.pub_description.publish(String(data=self.model.to_urdf()))
        self.pub_static = self.create_publisher(TFMessage, '/tf_static', latched_qos())
        now = self.get_clock().now().to_msg()
        static = [_stamped(now, j.parent, j.child, *self.model.transform(j.name))
                  for j in self.model.joints if j.kind == 'fixed']
        self.pub_static.publish(TFMessage(transforms=static))
        self.other_frames = OtherFramePublishers(self, TFMessage(transforms=static))
        self.cell = load_cell(p['cell_file']).in_frame(robot.world_frame) if p['cell_file'] else None
        if self.cell is not None:
            self.pub_cell = self.create_publisher(message_class('visualization_msgs/msg/MarkerArray'), Topic.CELL,
                                                  latched_qos())
            header = make_message('std_msgs/msg/Header', frame_id=prefix + self.cell.frame, stamp=now)
            self.pub_cell.publish(cell_marker_array(make_message, header, self.cell))
        depth = int(p['queue_depth'])
        # a subscription that matches gets the held state at once (not up to an idle period later)
        self.pub_tf = self.create_publisher(TFMessage, '/tf', stream_qos(depth),
                                            event_callbacks=PublisherEventCallbacks(matched=self._on_matched))
        joint_states_subscription(self, self.on_joints, depth, p['joint_states_reliability'])
        self.received = 0
        self.last_received = -math.inf
        #: The last joint_states' stamp and the node clock when it arrived [ns] (None: none yet).
        self.time_base: tuple[int, int] | None = None
        self.idle_period = 1.0 / float(p['idle_rate'])
        self.platform_pose: tuple[Any, Any] | None = None
        self._pose_of(self.held[:3])
        self.create_timer(self.idle_period, self._idle)
        self.pub_tf.publish(self.transforms(now))
        self.get_logger().info(f'publishing robot_description (robot {robot.name}, {len(self.model.links)} links), '
                               f'/tf_static ({len(static)} fixed joints) and /tf per joint_states ({self.base} -> '
                               f'{self.platform}, {self.nominal}, rods, arms {", ".join(robot.arm_names)}), held at '
                               f'{p["idle_rate"]} Hz while none arrive'
                               + (f'; gpr/cell: {len(self.cell.obstacles)} obstacles of {self.cell.source}'
                                  if self.cell is not None else ''))

    def _on_matched(self, info: QoSPublisherMatchedInfo) -> None:
        """A new subscription of /tf matched: publish the held state now (between joint_states, as the idle timer)."""
        if info.current_count_change > 0 and time.monotonic() - self.last_received > 1.5 * self.idle_period:
            self.pub_tf.publish(self.transforms(self.held_stamp()))

    def _pose_of(self, rods: Any) -> None:
        """The exact and naive platform poses of ``rods`` (within :data:`~..inputs.validation.MAX_COORDINATE`: the
        joints beyond are left out on arrival, where floats give no faithful pose: 1e308 m put inf and NaN on /tf,
        1e15 m a 90 deg naive tilt; kept as they were when the rods have none or differ by more than any tilt makes);
        rods beyond the stroke or the tilt limit are shown as received, with a warning."""
        fk = None
        try:
            fk = forward(rods, self.cfg)
        except LimitError as exc:   # NoPoseError: no tilt makes them, a pose solved without the limits is fiction
            beyond = exc
            if not isinstance(exc, NoPoseError) and not (self.cfg.stroke_min <= min(rods) and
                                                         max(rods) <= self.cfg.stroke_max):
                try:   # beyond the stroke, judged first: their differences too (2 mm beyond showed 62 deg on /tf)
                    forward(rods, self.cfg, stroke=False)
                except NoPoseError as none:
                    beyond = none
                except GprError:
                    pass
            if isinstance(beyond, NoPoseError):
                self.get_logger().warning(f'joint_states: {one_line(beyond)}; the platform keeps its last pose',
                                          throttle_duration_sec=5.0)
                return
            self.get_logger().warning(f'joint_states: {one_line(exc)}; shown as received', throttle_duration_sec=5.0)
        except GprError:
            pass
        try:
            if fk is None:
                fk = forward(rods, self.cfg, check_limits=False)
        except GprError as exc:
            self.get_logger().warning(f'rods {[float(v) for v in rods]} m have no platform pose: {one_line(exc)}; the '
                                      'platform keeps its last pose', throttle_duration_sec=5.0)
            return
        self.platform_pose = ((fk.position, fk.quaternion), (fk.nominal_position, fk.nominal_quaternion))

    def transforms(self, stamp: Any) -> TFMessage:
        """The transforms of the held state (module docstring), stamped ``stamp``."""
        out = []
        if self.platform_pose is not None:
            exact, naive = self.platform_pose
            out += [_stamped(stamp, self.base, self.platform, *exact), _stamped(stamp, self.base, self.nominal, *naive)]
        out += [_stamped(stamp, j.parent, j.child, *self.model.transform(j.name, float(v)))
                for j, v in zip(self.moving, self.held, strict=True)]
        return TFMessage(transforms=out)

    def on_joints(self, joints: JointState) -> None:
        """Take the finite values of the joints the message names, then publish the transforms at its stamp; a
        malformed message (not one position per name, a joint named twice) is ignored with a warning, as
        robot_state_publisher ignores it."""
        try:
            taken, values, left = joint_state_values(self.joints.names, joints.name, joints.position)
        except GprError as exc:
            self.get_logger().warning(f'joint_states: {one_line(exc)}; message ignored', throttle_duration_sec=5.0)
            return
        if left:
            self.get_logger().warning(f'joint_states: {", ".join(left)} not finite, left out (held as before); '
                                      'allowed: finite positions', throttle_duration_sec=5.0)
        # a joint beyond: no faithful transform there (an arm joint of 1e155 rad overflowed one and stopped the node;
        # a rod of 1e300 m went on /tf as its own transform)
        far = np.abs(values) > MAX_COORDINATE
        if far.any():
            told = ', '.join(f'{self.joints.names[k]} = {v:.6g} {self.joints.units[k]}'
                             for k, v in zip(taken[far], values[far], strict=True))
            self.get_logger().warning(f'joint_states: {told}: left out (held as before); allowed: within '
                                      f'+-{MAX_COORDINATE:g} m or rad', throttle_duration_sec=5.0)
            taken, values = taken[~far], values[~far]
        rods = self.held[:3].copy()
        self.held[taken] = values
        for k, value in zip(taken.tolist(), values.tolist(), strict=True):
            if k >= 3 and not self.lower[k] <= value <= self.upper[k]:
                self.get_logger().warning(f'joint_states: {self.joints.names[k]} = {value:.9g} rad is outside its '
                                          f'limits [{self.lower[k]:.9g}, {self.upper[k]:.9g}] rad; shown as received',
                                          throttle_duration_sec=5.0)
        if self.platform_pose is None or not np.array_equal(rods, self.held[:3]):
            self._pose_of(self.held[:3])
        self.received += 1
        self.last_received = time.monotonic()
        stamp = joints.header.stamp
        self.time_base = (stamp.sec * 1_000_000_000 + stamp.nanosec, self.get_clock().now().nanoseconds)
        self.pub_tf.publish(self.transforms(stamp))

    def held_stamp(self) -> Any:
        """The stamp of the held state: the last joint_states' plus the node clock's time since (at least 0: a clock
        set back), the current time before any (module docstring)."""
        now = self.get_clock().now()
        if self.time_base is None:
            return now.to_msg()
        ns = self.time_base[0] + max(0, now.nanoseconds - self.time_base[1])
        return make_message('builtin_interfaces/msg/Time', sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def _idle(self) -> None:
        if time.monotonic() - self.last_received > 1.5 * self.idle_period:
            self.pub_tf.publish(self.transforms(self.held_stamp()))


def main(args: Sequence[str] | None = None) -> int:
    return run(StatePublisherNode, args)


if __name__ == '__main__':
    sys.exit(main())

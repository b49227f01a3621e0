"""``state_publisher_node``: the robot model and its transforms for RViz and tf (the robot's robot_state_publisher).

Publishes, from the robot description (``robot_file``, default the shipped example) and the geometry parameters
(the same ``GprConfig`` keys as the other nodes, read-only; the description's ``gpr`` section unless
``config_file`` is given):

- ``robot_description`` (std_msgs/String, reliable, transient local, depth 1, as ``robot_state_publisher``): the
  URDF of :func:`gpr_kinematics.robot.urdf.robot_urdf`: the world, the GPR, the arms, blades and wafers;
- ``/tf_static`` (tf2_msgs/TFMessage, transient local): the fixed joints: ``world -> gpr_base`` (the robot's base),
  the rod guides on the base, each arm's blade and wafer;
- ``/tf`` (tf2_msgs/TFMessage): for every ``gpr/platform_state`` received (from ``trajectory_node`` or a replayed
  bag), stamped with that state's header stamp: ``base_frame -> platform_frame`` (the exact pose, copied from
  the state), ``base_frame -> nominal_frame`` (the naive model's pose) and ``gpr_rod_guide_k -> gpr_rod_k``
  (rod k at its length ``q_k``); and for every ``gpr/joint_states`` received, stamped with its stamp, each arm's
  links (``platform_frame -> <arm>_link1 -> ... -> <arm>_link<n>``) at the joint values it carries. An arm whose
  joints a message does not carry (the rods-only joint states of a platform stream) is drawn at its ``home``
  posture, as ``joint_state_publisher`` would draw a joint nobody publishes;
- ``gpr/cell`` (visualization_msgs/MarkerArray, transient local), when ``cell_file`` names a process cell: its
  obstacles in the cell's frame (:func:`gpr_kinematics.safety.markers.cell_marker_array`).

A robot_state_publisher cannot do this: the platform closes an overconstrained loop, so its pose is not a
function of a joint tree; here it is the kinematics' answer carried by the state message. Parameters:
``robot_file``, ``base_frame``, ``platform_frame``, ``nominal_frame``, ``queue_depth``, ``cell_file`` (see
:mod:`.specs`).
"""
from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import Any

from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from gpr_interfaces.msg import PlatformState

from ..robot.urdf import Joint, RobotUrdf, robot_urdf
from ..ros.specs import STATE_PUBLISHER
from ..safety.cell import load_cell
from ..safety.markers import cell_marker_array
from .conversions import make_message, message_class, transform_msg
from .params import ConfigParameters, declare_parameters, declare_robot
from .qos import latched_qos, stream_qos
from .runtime import GprNode, run

NODE_NAME = 'state_publisher_node'


def _stamped(stamp: Any, parent: str, child: str, translation: Sequence[float],
             rotation: Sequence[float]) -> TransformStamped:
    t = TransformStamped(child_frame_id=child, transform=transform_msg(translation, rotation))
    t.header.stamp = stamp
    t.header.frame_id = parent
    return t


class StatePublisherNode(GprNode):
    """Publishes the URDF and the fixed transforms once, then the transforms of every platform state."""

    NODE_NAME = NODE_NAME

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        robot = ConfigParameters(self, read_only=True, robot=declare_robot(self)).robot
        p = declare_parameters(self, STATE_PUBLISHER)
        self.model: RobotUrdf = robot_urdf(robot, p['base_frame'], p['platform_frame'], p['nominal_frame'])
        self.base, self.platform, self.nominal = p['base_frame'], p['platform_frame'], p['nominal_frame']
        self.rods = [self.model.joint(f'rod_{k}') for k in (1, 2, 3)]
        #: Per arm: its revolute joints in the model and its home posture [rad].
        self.arms: list[tuple[list[Joint], tuple[float, ...]]] = [
            ([self.model.joint(n) for n in arm.joint_names], arm.home) for arm in robot.arms]
        self.pub_description = self.create_publisher(String, 'robot_description', latched_qos())
        self.pub_description.publish(String(data=self.model.to_urdf()))
        self.pub_static = self.create_publisher(TFMessage, '/tf_static', latched_qos())
        now = self.get_clock().now().to_msg()
        static = [_stamped(now, j.parent, j.child, *self.model.transform(j.name))
                  for j in self.model.joints if j.kind == 'fixed']
        self.pub_static.publish(TFMessage(transforms=static))
        self.cell = load_cell(p['cell_file']) if p['cell_file'] else None
        if self.cell is not None:
            self.pub_cell = self.create_publisher(message_class('visualization_msgs/msg/MarkerArray'), 'gpr/cell',
                                                  latched_qos())
            header = make_message('std_msgs/msg/Header', frame_id=self.cell.frame, stamp=now)
            self.pub_cell.publish(cell_marker_array(make_message, header, self.cell))
        depth = int(p['queue_depth'])
        self.pub_tf = self.create_publisher(TFMessage, '/tf', stream_qos(depth))
        # gpr/platform_state last: a trajectory node waiting for its subscribers finds the other one matched by then.
        self.create_subscription(JointState, 'gpr/joint_states', self.on_joints, stream_qos(depth))
        self.create_subscription(PlatformState, 'gpr/platform_state', self.on_state, stream_qos(depth))
        self.received = 0
        self.get_logger().info(f'publishing robot_description (robot {robot.name}, {len(self.model.links)} links), '
                               f'/tf_static ({len(static)} fixed joints) and /tf per gpr/platform_state '
                               f'({self.base} -> {self.platform}, {self.nominal}, rods) and per gpr/joint_states '
                               f'(arms {", ".join(robot.arm_names)})'
                               + (f'; gpr/cell: {len(self.cell.obstacles)} obstacles of {self.cell.source}'
                                  if self.cell is not None else ''))

    def transforms(self, state: PlatformState) -> TFMessage:
        """The transforms of one platform state (see the module docstring)."""
        h = state.header.stamp
        pose, nominal = state.pose, state.nominal_pose
        out = [
            _stamped(h, self.base, self.platform, (pose.position.x, pose.position.y, pose.position.z),
                     (pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w)),
            _stamped(h, self.base, self.nominal, (nominal.position.x, nominal.position.y, nominal.position.z),
                     (nominal.orientation.x, nominal.orientation.y, nominal.orientation.z, nominal.orientation.w)),
        ]
        for joint, q in zip(self.rods, state.q, strict=True):
            out.append(_stamped(h, joint.parent, joint.child, *self.model.transform(joint.name, q)))
        return TFMessage(transforms=out)

    def arm_transforms(self, joints: JointState) -> TFMessage:
        """The arms' link transforms at the joint values of ``joints`` (an arm it does not carry, or carries with a
        value that is not a finite number: at its home posture), stamped with its stamp."""
        values = dict(zip(joints.name, joints.position, strict=False))
        out = []
        for arm_joints, home in self.arms:
            posture = [values.get(j.name, math.nan) for j in arm_joints]
            if not all(math.isfinite(v) for v in posture):
                posture = list(home)
            out += [_stamped(joints.header.stamp, j.parent, j.child, *self.model.transform(j.name, v))
                    for j, v in zip(arm_joints, posture, strict=True)]
        return TFMessage(transforms=out)

    def on_joints(self, joints: JointState) -> None:
        self.pub_tf.publish(self.arm_transforms(joints))

    def on_state(self, state: PlatformState) -> None:
        self.received += 1
        self.pub_tf.publish(self.transforms(state))


def main(args: Sequence[str] | None = None) -> int:
    return run(StatePublisherNode, args)


if __name__ == '__main__':
    sys.exit(main())

"""``state_publisher_node``: the robot model and its transforms for RViz and tf (the GPR's robot_state_publisher).

Publishes, from the geometry parameters (the same ``GprConfig`` keys as the other nodes, read-only):

- ``robot_description`` (std_msgs/String, reliable, transient local, depth 1, as ``robot_state_publisher``): the
  URDF of :func:`gpr_kinematics.robot_model.gpr_model`;
- ``/tf_static`` (tf2_msgs/TFMessage, transient local): the fixed joints (the rod guides on the base);
- ``/tf`` (tf2_msgs/TFMessage): for every ``gpr/platform_state`` received (from ``trajectory_node`` or a replayed
  bag), stamped with that state's header stamp: ``base_frame -> platform_frame`` (the exact pose, copied from
  the state), ``base_frame -> nominal_frame`` (the naive model's pose) and ``gpr_rod_guide_k -> gpr_rod_k``
  (rod k at its length ``q_k``).

A robot_state_publisher cannot do this: the platform closes an overconstrained loop, so its pose is not a
function of a joint tree; here it is the kinematics' answer carried by the state message. Parameters:
``base_frame``, ``platform_frame``, ``nominal_frame``, ``queue_depth`` (see :mod:`.specs`).
"""
from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

from geometry_msgs.msg import TransformStamped
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from gpr_interfaces.msg import PlatformState

from ..robot_model import RobotModel, gpr_model
from .conversions import transform_msg
from .params import ConfigParameters, declare_parameters
from .qos import latched_qos, stream_qos
from .runtime import GprNode, run
from .specs import STATE_PUBLISHER

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
        cfg = ConfigParameters(self, read_only=True).config
        p = declare_parameters(self, STATE_PUBLISHER)
        self.model: RobotModel = gpr_model(cfg, p['base_frame'], p['platform_frame'], p['nominal_frame'])
        self.base, self.platform, self.nominal = p['base_frame'], p['platform_frame'], p['nominal_frame']
        self.rods = [self.model.joint(f'rod_{k}') for k in (1, 2, 3)]
        self.pub_description = self.create_publisher(String, 'robot_description', latched_qos())
        self.pub_description.publish(String(data=self.model.to_urdf()))
        self.pub_static = self.create_publisher(TFMessage, '/tf_static', latched_qos())
        now = self.get_clock().now().to_msg()
        static = [_stamped(now, j.parent, j.child, *self.model.transform(j.name))
                  for j in self.model.joints if j.kind == 'fixed']
        self.pub_static.publish(TFMessage(transforms=static))
        depth = int(p['queue_depth'])
        self.pub_tf = self.create_publisher(TFMessage, '/tf', stream_qos(depth))
        self.create_subscription(PlatformState, 'gpr/platform_state', self.on_state, stream_qos(depth))
        self.received = 0
        self.get_logger().info(f'publishing robot_description ({len(self.model.links)} links), /tf_static '
                               f'({len(static)} fixed joints) and /tf per gpr/platform_state '
                               f'({self.base} -> {self.platform}, {self.nominal}, rods)')

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

    def on_state(self, state: PlatformState) -> None:
        self.received += 1
        self.pub_tf.publish(self.transforms(state))


def main(args: Sequence[str] | None = None) -> int:
    return run(StatePublisherNode, args)


if __name__ == '__main__':
    sys.exit(main())

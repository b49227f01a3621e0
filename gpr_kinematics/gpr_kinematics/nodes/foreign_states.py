"""What the nodes say of other nodes: ``robot_simulator_node`` of another publisher's ``joint_states`` it ignores, the
refusal of a state (:func:`outside`) and its warnings, throttled per refusal (:class:`RefusalLog`), and of another
server of its action, a warning (:class:`OtherServers`); ``state_publisher_node`` of another publisher of its robot's
frames, a warning (:class:`OtherFramePublishers`)."""
from __future__ import annotations

import re
import time
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from tf2_msgs.msg import TFMessage

from ..core.config import GprConfig
from ..core.forward import forward
from ..errors import GprError
from ..robot.arm_chain import LIMIT_SLACK
from ..robot.controller import ControllerJoints, beyond_words
from .qos import latched_qos
from .runtime import one_line

#: The name the ROS graph gives a node not yet discovered, and how often (every 0.5 s) a warning naming the other
#: publishers waits for it.
UNKNOWN_NODE = '_NODE_NAME_UNKNOWN_'
NAME_TRIES = 10

#: Shortest time [s] between two warnings of one refusal (the same again; a different one is logged at once).
REFUSAL_PERIOD = 5.0
#: How often [s, steady time] the servers of the simulator's action are counted on the ROS graph.
SERVER_CHECK = 2.0
#: How many refusals' last warnings are remembered (the oldest forgotten: a stream of ever new ones costs no memory).
REFUSALS_KEPT = 64
# A number in a refusal's text (not a digit of a name: arm1_elbow, rod_2): the key leaves the numbers out.
_NUMBER = re.compile(r'(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?')


class RefusalLog:
    """Warnings of ``logger`` throttled per refusal: one keyed by its text without its numbers (its kind and joints,
    e.g. arm1_elbow beyond its upper limit) is logged at once, the same again at most every :data:`REFUSAL_PERIOD` s.
    One throttle for all had let a different refusal within 5 s of another go unlogged."""

    def __init__(self, logger: Any, period: float = REFUSAL_PERIOD) -> None:
        self.logger, self.period = logger, period
        self.last: dict[str, float] = {}

    def warn(self, text: str) -> bool:
        """Log ``text`` unless the same refusal was logged within the period; whether it was logged."""
        key, now = _NUMBER.sub('#', text), time.monotonic()
        then = self.last.pop(key, None)
        if then is not None and now - then < self.period:
            self.last[key] = then
            return False
        self.last[key] = now
        if len(self.last) > REFUSALS_KEPT:
            del self.last[next(iter(self.last))]
        self.logger.warning(text)
        return True


def outside(joints: ControllerJoints, cfg: GprConfig, state: Any) -> str:
    """What of a state leaves the joints' limits or tilts the platform beyond its limit ('' if nothing)."""
    j = joints   # a streamed sample may lie LIMIT_SLACK beyond a limit, as the planner allows
    for k in np.flatnonzero((state < j.lower - LIMIT_SLACK) | (state > j.upper + LIMIT_SLACK)):
        lo, hi, u = float(j.lower[k]), float(j.upper[k]), j.units[k]   # told apart: '2.9 rad is outside [.., 2.9]'
        return (f"{beyond_words(j.names[k], float(state[k]), lo, hi, u)}; allowed: values within the joints' limits "
                f'([{lo:.12g}, {hi:.12g}] {u})')   # the tilt's has its own
    try:
        forward(state[:3], cfg)
    except GprError as exc:   # the core names the rods q: said which joints they are
        return (f'{", ".join(j.names[:3])}: {one_line(exc)}'
                + ('' if 'allowed:' in str(exc) else '; allowed: rods within the tilt limit'))
    return ''


class OtherServers:
    """Warns while another node serves the simulator's action too: a client's goal reaches every server of an action,
    so two simulators in one namespace both ran each goal, and took each other's states, without a word. The servers
    of the action's ``send_goal`` service are counted every :data:`SERVER_CHECK` s (``count_services``); said once
    when another appears, and when the last other is gone."""

    def __init__(self, node: Any, action: str) -> None:
        self.node, self.action, self.others = node, action, 0
        node.create_timer(SERVER_CHECK, self.check, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def check(self) -> int:
        """The number of other servers of the action now (a warning when there were none)."""
        others = max(int(self.node.count_services(f'{self.action}/_action/send_goal')) - 1, 0)
        if others and not self.others:
            self.node.get_logger().warning(
                f'{others} other server(s) of {self.action} on the ROS graph: a goal sent there runs on each (another '
                'robot_simulator_node or controller in this namespace?); allowed: one server per action (start the '
                'other in a namespace of its own, -r __ns:=/robot2)')
        elif self.others and not others:
            self.node.get_logger().info(f'no other server of {self.action} is left')
        self.others = others
        return others


class OtherFramePublishers:
    """Warns once when another publisher sends the robot's fixed frames on ``/tf_static``: two state publishers with
    one ``frame_prefix`` (two robots in two namespaces, the prefix forgotten) put two robots on the same frames, and
    tf alternated between them without a word. Each state publisher stamps its fixed transforms with its start time
    and hears ``/tf_static`` latched: a transform of one of its frames under another stamp is another's (or a replayed
    recording's). Two started within the same clock tick (a simulated clock at 0) are not told apart."""

    def __init__(self, node: Any, static: Any, topic: str = '/tf_static') -> None:
        self.node, self.topic, self.warned = node, topic, False
        self.mine = {(t.child_frame_id, t.header.stamp.sec, t.header.stamp.nanosec) for t in static.transforms}
        self.frames = {t.child_frame_id for t in static.transforms}
        node.create_subscription(TFMessage, topic, self.heard, latched_qos(depth=100))  # tf2's static listener's

    def heard(self, msg: Any) -> list[str]:
        """This robot's frames in ``msg`` that another publisher sent (a warning the first time there are any)."""
        theirs = sorted({t.child_frame_id for t in msg.transforms if t.child_frame_id in self.frames
                         and (t.child_frame_id, t.header.stamp.sec, t.header.stamp.nanosec) not in self.mine})
        if theirs and not self.warned:
            self.warned = True
            self._warn(theirs, NAME_TRIES)
        return theirs

    def _warn(self, theirs: list[str], tries: int) -> None:
        """The warning naming the other publishers; while the graph names one ``_NODE_NAME_UNKNOWN_`` (its node's
        discovery behind its publisher's: the twin went unnamed on a loaded machine), again every 0.5 s, ``tries``
        times at most."""
        me = (self.node.get_name(), self.node.get_namespace())
        infos = [e for e in self.node.get_publishers_info_by_topic(self.topic) if (e.node_name, e.node_namespace) != me]
        if tries > 0 and any(e.node_name == UNKNOWN_NODE for e in infos):
            timer = None

            def again() -> None:
                if timer is not None:
                    timer.cancel()
                    self.node.destroy_timer(timer)
                self._warn(theirs, tries - 1)
            timer = self.node.create_timer(0.5, again)
            return
        others = sorted({f'{e.node_namespace.rstrip("/")}/{e.node_name}' for e in infos})
        named = ', '.join(theirs[:3]) + (f' and {len(theirs) - 3} more' if len(theirs) > 3 else '')
        self.node.get_logger().warning(
            f'another publisher sends this robot\'s frames ({named}) on {self.topic} (of its publishers: '
            f'{", ".join(others) or "one gone since"}): a second state publisher with the same frame_prefix, or '
            'a replayed recording of them; tf takes either, and /tf alternates between two robots; allowed: '
            'one state publisher per frame_prefix (give each robot its own, e.g. frame_prefix:=r2/)')

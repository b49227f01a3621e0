"""What ``robot_simulator_node`` says of other nodes: of another publisher's ``joint_states`` it ignores, the refusal
of a state (:func:`outside`) and its warnings, throttled per refusal (:class:`RefusalLog`); of another server of its
action, a warning (:class:`OtherServers`)."""
from __future__ import annotations

import re
import time
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType

from ..core.config import GprConfig
from ..core.forward import forward
from ..errors import GprError
from ..robot.arm_chain import LIMIT_SLACK
from ..robot.controller import ControllerJoints, beyond_words
from .runtime import one_line

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

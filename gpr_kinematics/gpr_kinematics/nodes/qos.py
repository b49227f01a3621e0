"""Quality of service of the package's topics, the latched topics, and topic-name checks.

Streams (``gpr/platform_state`` and its companions, ``/tf``) are reliable, keep last ``depth``, volatile: a
subscriber gets every sample published after it matched. Latched topics (``gpr/geometry``, ``gpr/robot``,
``robot_description``, ``/tf_static``) are reliable, keep last 1, transient local, as ``robot_state_publisher``
publishes ``robot_description``: a subscriber that joins later still gets the one sample. A subscription must
ask for transient local to receive it, and a transient-local subscription does not match a volatile publisher,
so the recorder and the replay pick the durability per topic (:data:`LATCHED`).
"""
from __future__ import annotations

from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import NameValidationException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..errors import ConfigError

#: Topics published once and latched (fully qualified names as in the root namespace).
LATCHED: frozenset[str] = frozenset({'/gpr/geometry', '/gpr/robot', '/robot_description', '/tf_static'})


def stream_qos(depth: int) -> QoSProfile:
    """Reliable, keep last ``depth``, volatile."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(depth), reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


def latched_qos() -> QoSProfile:
    """Reliable, keep last 1, transient local (``robot_state_publisher``'s ``robot_description`` QoS)."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


def valid_topic_name(node: Node, name: str, parameter: str) -> str:
    """The fully qualified name of ``name`` in ``node``'s namespace; :class:`ConfigError` naming the parameter
    when it is empty or not a valid ROS topic name."""
    allowed = ('a ROS topic name: letters, digits, _ and / (not starting with a digit, no // or trailing /), '
               'e.g. gpr/platform_state')
    if not name:
        raise ConfigError(f'{parameter}: an empty topic name is invalid; allowed: {allowed}')
    try:
        return node.resolve_topic_name(name)
    except (NameValidationException, RCLError) as exc:
        text = ' '.join(str(exc).split()).replace('failed to resolve name: ', '')
        raise ConfigError(f'{parameter}: {name[:200]!r} is not a valid topic name ({text[:200]}); '
                          f'allowed: {allowed}') from None

"""Quality of service of the package's topics, services and action feedback, the latched topics, and topic-name
checks.

Streams (``gpr/platform_state`` and its companions, ``/tf``) are reliable, keep last ``depth``, volatile: a
subscriber gets every sample published after it matched. Latched topics (``gpr/geometry``, ``gpr/robot``,
``gpr/program``, ``robot_description``, ``/tf_static``) are reliable, keep last 1, transient local, as
``robot_state_publisher`` publishes ``robot_description``: a subscriber that joins later still gets the last
sample. A subscription must
ask for transient local to receive it, and a transient-local subscription does not match a volatile publisher,
so the recorder and the replay pick the durability per topic (:data:`LATCHED`).

Services (the node's request queue and response writer, :class:`~gpr_kinematics.nodes.client.GprClient`'s too) are
reliable, keep all (:func:`service_qos`): no request or response is dropped because a queue is full (with keep last
100, a burst of 600 requests from one client got 208 answers, the rest vanished); a node that cannot keep up answers
``success: false`` "saturated" instead (:mod:`gpr_kinematics.nodes.kinematics_node`). The action's feedback is a
stream (:func:`stream_qos`), so a client that is slow for a moment loses no sample's feedback. The actions' goal,
cancel and result services are services too (:func:`action_server_options`: keep all, where rclpy's default keeps
the last 10 and a burst of 30 goals got 13 answers, the others none; the package's action clients keep all too,
:func:`action_client_options`), and a goal's result is kept
:data:`RESULT_TIMEOUT` after it ends (rclpy's default 900 s kept every goal's request with it: about 100 MB for a
trajectory of 200,000 points).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rclpy._rclpy_pybind11 import RCLError
from rclpy.event_handler import QoSRequestedIncompatibleQoSInfo, SubscriptionEventCallbacks
from rclpy.exceptions import NameValidationException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..core.messages import Topic
from ..errors import ConfigError

#: Topics published once and latched (fully qualified names as in the root namespace).
LATCHED: frozenset[str] = frozenset({*('/' + t for t in (Topic.GEOMETRY, Topic.ROBOT, Topic.PROGRAM,
                                                          Topic.ROBOT_DESCRIPTION)), '/tf_static'})


def is_latched(name: str) -> bool:
    """``name`` (fully qualified) is one of :data:`LATCHED`, at the root or in a namespace (``/r1/gpr/geometry``;
    ``/tf_static`` is absolute): a recorder in ``/r1`` subscribed to ``/r1/gpr/geometry`` as a stream and lost it."""
    return name in LATCHED or any(name.endswith(k) for k in LATCHED if k != '/tf_static')


def stream_qos(depth: int) -> QoSProfile:
    """Reliable, keep last ``depth``, volatile."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(depth), reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


def joint_states_subscription(node: Node, callback: Callable[[Any], None], depth: int, reliability: str) -> Any:
    """Subscribe ``node`` to ``joint_states`` (relative), keep last ``depth``, volatile, ``reliability``
    (``reliable``: every sample; ``best_effort``: as robot_state_publisher's ``SensorDataQoS``, which also hears a
    best-effort driver). A publisher whose QoS cannot match (a best-effort one for a reliable subscription) gets a
    warning that says which parameter hears it, in place of rclpy's (which names no remedy)."""
    from sensor_msgs.msg import JointState

    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(depth), durability=DurabilityPolicy.VOLATILE,
                     reliability=ReliabilityPolicy.RELIABLE if reliability == 'reliable'
                     else ReliabilityPolicy.BEST_EFFORT)

    def incompatible(info: QoSRequestedIncompatibleQoSInfo) -> None:
        policy = str(getattr(info.last_policy_kind, 'name', info.last_policy_kind)).replace('RMW_QOS_POLICY_', '')
        node.get_logger().warning(
            f'joint_states: a publisher offers a QoS this {reliability} subscription cannot match ({policy}); none of '
            'its messages are received; allowed: a reliable publisher, or start the node with '
            '-p joint_states_reliability:=best_effort to hear a best-effort one (robot_state_publisher\'s '
            'SensorDataQoS)')

    return node.create_subscription(JointState, Topic.JOINT_STATES, callback, qos,
                                    event_callbacks=SubscriptionEventCallbacks(incompatible_qos=incompatible))


def service_qos() -> QoSProfile:
    """Reliable, keep all (module docstring)."""
    return QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


#: How long an action server keeps a goal's result (and rclpy its request) after the goal ends [s]: long enough for
#: a client that asks for the result after it ended, short enough that refused large goals do not pile up.
RESULT_TIMEOUT = 30.0


def action_server_options() -> dict[str, Any]:
    """``rclpy.action.ActionServer`` keyword arguments: the goal, cancel and result services with
    :func:`service_qos` (no goal request dropped by a full queue) and results kept :data:`RESULT_TIMEOUT`."""
    return {'goal_service_qos_profile': service_qos(), 'cancel_service_qos_profile': service_qos(),
            'result_service_qos_profile': service_qos(), 'result_timeout': RESULT_TIMEOUT}


def action_client_options(feedback_depth: int) -> dict[str, Any]:
    """``rclpy.action.ActionClient`` keyword arguments: the goal, cancel and result services with
    :func:`service_qos` on the client's side too (rclpy's default keeps the last 10: a client that sent 30 goals at
    once and took the answers late lost some of them in its own response queue, on a loaded machine) and the
    feedback as a stream of ``feedback_depth``."""
    return {'goal_service_qos_profile': service_qos(), 'cancel_service_qos_profile': service_qos(),
            'result_service_qos_profile': service_qos(), 'feedback_sub_qos_profile': stream_qos(feedback_depth)}


def release_request(goal: Any) -> None:
    """Drop a goal handle's reference to its request once the goal has been read: rclpy keeps the handle, and
    with it the request, until :data:`RESULT_TIMEOUT` after the goal ends (``ServerGoalHandle._goal_request``;
    on an rclpy without that attribute this does nothing)."""
    if hasattr(goal, '_goal_request'):
        goal._goal_request = None


def latched_qos(depth: int = 1) -> QoSProfile:
    """Reliable, keep last ``depth``, transient local (``robot_state_publisher``'s ``robot_description`` QoS with the
    default 1, for a publisher). A subscription keeps more (``depth``: every publisher's latched sample, as tf2's
    static listener keeps 100): ``/tf_static`` has a publisher per robot, and a reader of depth 1 that got two
    robots' samples before it took the first kept only the second."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(depth), reliability=ReliabilityPolicy.RELIABLE,
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

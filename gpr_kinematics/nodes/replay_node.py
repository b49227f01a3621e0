"""``replay_node``: publishes a bag's messages back on their topics, like ``ros2 bag play``.

The stored serialized bytes are published as they are (no decode/encode round trip), in log-time order,
with the original spacing divided by ``rate``. Parameters (read-only):

- ``bag``: the bag folder (or a single ``.mcap``/``.db3`` file); required;
- ``rate``: speed factor (default 1; 2 = twice as fast);
- ``loop``: start over after the last message (until SIGINT/SIGTERM);
- ``topics``: replay only these topics (default: all);
- ``wait_for_subscribers``: before the first message wait until every topic has this many subscriptions
  (default 0), at most ``wait_timeout`` seconds;
- ``queue_depth``: publisher history depth (reliable, keep last; default 10000).

Exits 0 at the end of the bag (after the reliable publishers' acknowledgements, at most 5 s) or on
SIGINT/SIGTERM; 2 with one error line when the bag cannot be read or a parameter is invalid.
"""
from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import rclpy
from rcl_interfaces.msg import ParameterType
from rclpy.duration import Duration
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..bags.errors import BagError
from ..bags.reader import read_bag
from ..errors import GprError
from .params import descriptor
from .recorder_node import message_class
from .runtime import init_with_stop_flag

NODE_NAME = 'replay_node'
EXIT_BAD_CONFIG = 2
D, INT, S, B, SA = (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_INTEGER,
                    ParameterType.PARAMETER_STRING, ParameterType.PARAMETER_BOOL,
                    ParameterType.PARAMETER_STRING_ARRAY)

_PARAMS: tuple[tuple[str, Any, int, str, Any], ...] = (
    ('bag', '', S, 'bag folder or .mcap/.db3 file to replay', None),
    ('rate', 1.0, D, 'replay speed factor', (1e-3, 1e6)),
    ('loop', False, B, 'start over after the last message', None),
    ('topics', [''], SA, 'topics to replay (empty: all)', None),
    ('wait_for_subscribers', 0, INT, 'wait for this many subscriptions on every topic first', (0, 1000)),
    ('wait_timeout', 10.0, D, 'longest wait for subscribers [s]', (0.0, 3600.0)),
    ('queue_depth', 10000, INT, 'publisher history depth (reliable, keep last)', (1, 10_000_000)),
)


class ReplayNode(Node):
    """Reads the bag at start and publishes it on :meth:`play`."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        p: dict[str, Any] = {}
        for name, default, ptype, text, limits in _PARAMS:
            p[name] = self.declare_parameter(name, default, descriptor(name, ptype, text, limits,
                                                                       read_only=True)).value
        if not p['bag']:
            raise BagError('parameter bag is empty; allowed: the path of a bag folder, .mcap or .db3 file')
        self.p = p
        wanted = [t for t in p['topics'] if t]
        bag = read_bag(p['bag'], topics=[self.resolve_topic_name(t) for t in wanted] or None)
        if wanted:
            missing = [t for t in wanted if bag.topic(self.resolve_topic_name(t)) is None]
            if missing:
                raise BagError(f'topic(s) {", ".join(missing)} not in the bag {p["bag"]}; it has: '
                               + ', '.join(read_bag(p['bag']).topics))
        self.bag = bag
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(p['queue_depth']),
                         reliability=ReliabilityPolicy.RELIABLE)
        self.pubs = {name: self.create_publisher(message_class(t.msgtype), name, qos)
                     for name, t in bag.topics.items()}
        # One stream in log-time order (stable: the bag's order for equal times).
        names = list(bag.topics)
        times = np.concatenate([bag.topics[n].log_time for n in names]) if names else np.zeros(0, np.int64)
        which = np.concatenate([np.full(len(bag.topics[n]), k) for k, n in enumerate(names)]) if names else times
        order = np.argsort(times, kind='stable')
        self.times = times[order]
        raws = [r for n in names for r in bag.topics[n].raw]
        self.stream = [(self.pubs[names[int(which[i])]], raws[i]) for i in order]
        self.published: dict[str, int] = dict.fromkeys(names, 0)
        self._names = {id(pub): n for n, pub in self.pubs.items()}
        self.get_logger().info(f'replaying {len(self.stream)} messages of {len(names)} topic(s) from {p["bag"]} '
                               f'at rate {p["rate"]}{" in a loop" if p["loop"] else ""}')

    def wait_for_subscribers(self, stop: list[int]) -> None:
        want = int(self.p['wait_for_subscribers'])
        if want <= 0:
            return
        deadline = time.monotonic() + float(self.p['wait_timeout'])
        while not stop and time.monotonic() < deadline:
            if all(pub.get_subscription_count() >= want for pub in self.pubs.values()):
                return
            time.sleep(0.02)
        if not stop:
            self.get_logger().warning(f'not every topic has {want} subscriber(s) after {self.p["wait_timeout"]} s; '
                                      'starting anyway')

    def play(self, stop: list[int]) -> None:
        """Publish the stream (again and again with ``loop``) until it ends or ``stop`` is non-empty."""
        rate = float(self.p['rate'])
        if not stop:
            self.get_logger().info('started: publishing')
        while not stop:
            if not self.stream:
                return
            t0 = time.monotonic()
            first = int(self.times[0])
            for (pub, raw), t in zip(self.stream, self.times.tolist(), strict=True):
                due = t0 + (t - first) * 1e-9 / rate
                delay = due - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
                if stop:
                    return
                pub.publish(raw)
                self.published[self._names[id(pub)]] += 1
            if not self.p['loop']:
                return

    def flush(self, timeout: float = 5.0) -> None:
        for pub in self.pubs.values():
            try:
                pub.wait_for_all_acked(Duration(seconds=timeout))
            except Exception:  # noqa: BLE001 - best effort on the way out
                pass


def main(args: Sequence[str] | None = None) -> int:
    stop = init_with_stop_flag(args)
    node: ReplayNode | None = None
    status = 0
    try:
        node = ReplayNode()
        node.wait_for_subscribers(stop)
        node.play(stop)
        node.flush()
        node.get_logger().info('finished: published ' + ', '.join(f'{t} {n}' for t, n in node.published.items()))
    except (GprError, ParameterException) as exc:
        rclpy.logging.get_logger(NODE_NAME).error(f'cannot start: {exc}'.replace('\n', ' '))
        status = EXIT_BAD_CONFIG
    finally:
        if node is not None:
            try:
                node.destroy_node()
            except Exception:  # noqa: BLE001 - leaving anyway
                pass
        rclpy.try_shutdown()
    return status


if __name__ == '__main__':
    sys.exit(main())

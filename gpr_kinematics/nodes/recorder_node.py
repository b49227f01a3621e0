"""``recorder_node``: records topics into a crash-safe rosbag2 bag (MCAP by default, SQLite3 on request).

Messages arrive serialized (``raw=True`` subscriptions, reliable QoS, keep-last ``queue_depth``) and are
written unchanged, with their receive time [ns since the epoch] as log time, by
:class:`~gpr_kinematics.bags.writer.SegmentedBagWriter` (bag format version 9, type definitions of the
ROS 2 Jazzy standard types and of ``gpr_interfaces``). Parameters (all read-only):

- ``output``: bag folder (default ``bags/gpr_YYYY_MM_DD-HH_MM_SS`` under the working directory); it must not
  exist and its parent must be writable;
- ``storage``: ``mcap`` (default) or ``sqlite3``;
- ``topics``: topic names, optionally ``name:pkg/msg/Type`` (default: the trajectory node's ``gpr/*`` topics,
  whose types are known); a name without a type gets it from the ROS graph within ``discovery_timeout``;
- ``flush_interval`` [s] (default 1): a message is in a closed, readable segment at most this long after it
  was received (see the writer); ``max_bag_size`` [bytes] and ``max_bag_duration`` [s]: extra splits (0 = off);
  ``compression``: ``none`` or ``zstd`` (MCAP chunk compression); ``fsync`` (default true);
- ``queue_depth``: subscription history depth (default 10000).

SIGINT and SIGTERM: the node stops taking new work, drains what DDS already delivered, closes the bag, logs
the counts per topic and exits 0. SIGKILL: the closed segments stay a valid bag (everything received more
than ``flush_interval`` before the kill). It refuses to start (one error line, exit status 2, no folder left
behind) when the output exists or is not writable, a topic's type is unknown or a parameter is invalid.
"""
from __future__ import annotations

import importlib
import sys
import time
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import Any

import rclpy
from rcl_interfaces.msg import ParameterType
from rclpy.exceptions import ParameterException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..bags.errors import BagError
from ..bags.typestore import GPR_TOPICS, check_known, normalize_type
from ..bags.writer import COMPRESSIONS, STORAGES, SegmentedBagWriter, check_output_path
from ..errors import GprError
from .params import descriptor
from .runtime import init_with_stop_flag

NODE_NAME = 'recorder_node'
EXIT_BAD_CONFIG = 2
D, INT, S, B, SA = (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_INTEGER,
                    ParameterType.PARAMETER_STRING, ParameterType.PARAMETER_BOOL,
                    ParameterType.PARAMETER_STRING_ARRAY)
DEFAULT_TOPICS = [t.lstrip('/') for t in GPR_TOPICS]

_PARAMS: tuple[tuple[str, Any, int, str, Any], ...] = (
    ('output', '', S, 'bag folder to create (default bags/gpr_<date>-<time>)', None),
    ('storage', 'mcap', S, 'storage format', tuple(STORAGES)),
    ('topics', DEFAULT_TOPICS, SA, 'topics to record: name or name:pkg/msg/Type', None),
    ('flush_interval', 1.0, D, 'longest time [s] a received message stays outside a closed segment (0 = off)',
     (0.0, 3600.0)),
    ('max_bag_size', 0, INT, 'split when a segment holds this many bytes (0 = off)', (0, 2**62)),
    ('max_bag_duration', 0.0, D, 'split when a segment spans this many seconds (0 = off)', (0.0, 1e9)),
    ('compression', 'none', S, 'MCAP chunk compression', COMPRESSIONS),
    ('fsync', True, B, 'fsync every closed segment and the bag folder', None),
    ('queue_depth', 10000, INT, 'subscription history depth (reliable, keep last)', (1, 10_000_000)),
    ('discovery_timeout', 5.0, D, 'wait this long [s] for the type of a topic given without one', (0.0, 3600.0)),
)


def default_output() -> Path:
    return Path('bags') / datetime.now().strftime('gpr_%Y_%m_%d-%H_%M_%S')


def message_class(msgtype: str) -> Any:
    """The rclpy message class of ``pkg/msg/Type``; :class:`BagError` when it cannot be imported."""
    pkg, kind, name = normalize_type(msgtype).split('/')
    try:
        return getattr(importlib.import_module(f'{pkg}.{kind}'), name)
    except (ImportError, AttributeError) as exc:
        raise BagError(f'type {msgtype!r} cannot be imported in this ROS environment ({exc})') from None


class RecorderNode(Node):
    """Subscribes to the topics and writes every message into the bag; see the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        p: dict[str, Any] = {}
        for name, default, ptype, text, limits in _PARAMS:
            p[name] = self.declare_parameter(name, default, descriptor(
                name, ptype, text, limits if ptype != S or limits is None else limits, read_only=True)).value
        for name, allowed in (('storage', STORAGES), ('compression', COMPRESSIONS)):
            if p[name] not in allowed:
                raise BagError(f'{name} = {p[name]!r} is invalid; allowed: {" or ".join(allowed)}')
        self.p = p
        output = Path(p['output']) if p['output'] else default_output()
        check_output_path(output)
        topics = self._resolve_topics(list(p['topics']))
        self.writer = SegmentedBagWriter(output, topics, storage=p['storage'], flush_interval=p['flush_interval'],
                                         max_bag_size=p['max_bag_size'], max_bag_duration=p['max_bag_duration'],
                                         compression=p['compression'], fsync=p['fsync'],
                                         custom_data={'recorder': NODE_NAME})
        classes = {t: message_class(ty) for t, ty in topics.items()}
        self.received: dict[str, int] = dict.fromkeys(topics, 0)
        self.last_message = time.monotonic()
        self.writer.open()
        try:
            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(p['queue_depth']),
                             reliability=ReliabilityPolicy.RELIABLE)
            # The state topic last: a publisher that waits for a subscription on it (trajectory_node's
            # wait_for_subscribers) then finds the other subscriptions announced already.
            order = sorted(topics, key=lambda t: t == '/gpr/platform_state')
            self.subs = [self.create_subscription(classes[t], t, self._callback(t), qos, raw=True) for t in order]
            if p['flush_interval'] > 0:
                self.timer = self.create_timer(max(0.005, p['flush_interval'] / 20.0), self.writer.poll)
        except BaseException:
            self.writer.abort(remove=True)
            raise
        self.get_logger().info(f'recording {len(topics)} topic(s) into {output} ({p["storage"]}, flush interval '
                               f'{p["flush_interval"]} s): ' + ', '.join(f'{t} [{ty}]' for t, ty in topics.items()))

    def _resolve_topics(self, entries: list[str]) -> dict[str, str]:
        if not entries:
            raise BagError('topics is empty; allowed: one or more topic names (name or name:pkg/msg/Type)')
        topics: dict[str, str | None] = {}
        for entry in entries:
            name, sep, msgtype = entry.partition(':')
            full = self.resolve_topic_name(name.strip())
            if sep:
                topics[full] = check_known(msgtype, full)
            elif full in GPR_TOPICS:
                topics[full] = GPR_TOPICS[full]
            else:
                topics[full] = None
        missing = [t for t, ty in topics.items() if ty is None]
        if missing:
            deadline = time.monotonic() + float(self.p['discovery_timeout'])
            while True:
                graph = dict(self.get_topic_names_and_types())
                for t in missing:
                    if t in graph and graph[t]:
                        topics[t] = check_known(graph[t][0], t)
                missing = [t for t, ty in topics.items() if ty is None]
                if not missing or time.monotonic() >= deadline:
                    break
                time.sleep(0.1)
            if missing:
                raise BagError(f'type of topic(s) {", ".join(missing)} unknown: not published within '
                               f'{self.p["discovery_timeout"]} s; allowed: give it as name:pkg/msg/Type')
        return {t: str(ty) for t, ty in topics.items()}

    def _callback(self, topic: str) -> Any:
        writer, received = self.writer, self.received

        def cb(data: bytes) -> None:
            received[topic] += 1
            writer.write(topic, time.time_ns(), data)
            self.last_message = time.monotonic()

        return cb

    def finish(self) -> None:
        """Close the bag and log the counts per topic."""
        self.writer.close()
        counts = ', '.join(f'{t} {self.writer.counts[t]}/{self.received[t]}' for t in self.received)
        self.get_logger().info(f'stopped: wrote {sum(self.writer.counts.values())} messages into {self.writer.path} '
                               f'in {len(self.writer.files)} file(s) (written/received per topic: {counts}; '
                               f'longest segment close {self.writer.max_close_time * 1e3:.1f} ms)')


def main(args: Sequence[str] | None = None) -> int:
    """Entry point: spin until SIGINT/SIGTERM, then drain, close the bag and exit 0."""
    stop = init_with_stop_flag(args)
    node: RecorderNode | None = None
    status = 0
    executor = SingleThreadedExecutor()
    try:
        node = RecorderNode()
        executor.add_node(node)
        while not stop:
            executor.spin_once(timeout_sec=0.05)
        # Drain what DDS has already delivered: spin until 0.2 s pass without a message (at most 5 s).
        end = time.monotonic() + 5.0
        while time.monotonic() < end and time.monotonic() - node.last_message < 0.2:
            executor.spin_once(timeout_sec=0.02)
        node.finish()
    except (GprError, ParameterException) as exc:
        rclpy.logging.get_logger(NODE_NAME).error(f'cannot start: {exc}'.replace('\n', ' '))
        status = EXIT_BAD_CONFIG
        if node is not None:
            node.writer.abort(remove=node.writer.closed_message_count == 0)
    except OSError as exc:
        rclpy.logging.get_logger(NODE_NAME).error(f'recording failed: {exc}')
        status = 1
    finally:
        try:
            executor.shutdown()
        except Exception:  # noqa: BLE001 - leaving anyway
            pass
        if node is not None:
            try:
                node.destroy_node()
            except Exception:  # noqa: BLE001
                pass
        rclpy.try_shutdown()
    return status


if __name__ == '__main__':
    sys.exit(main())

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
- ``queue_depth``: subscription history depth (default 10000);
- ``drain_timeout`` [s] (default 5): the longest drain at a stop (below).

Latched topics (``gpr/geometry``, ``robot_description``, ``/tf_static``, and any topic whose publishers all offer
transient-local durability when the recorder starts) are subscribed with a transient-local, reliable QoS, so
the sample a publisher sent before the recorder started is recorded too.

SIGINT and SIGTERM: the node stops taking new work, drains what DDS already delivered (at most ``drain_timeout``
seconds, 0: none; a warning when that ended it with messages still coming), closes the bag, logs the counts per
topic and exits 0. SIGKILL: the closed segments stay a valid bag (everything received more than ``flush_interval``
before the kill). It refuses to start (one ``cannot start:`` line, exit status 2, no
folder left behind) when the output exists or is not writable, a topic name is empty or invalid, a topic's
type is unknown or not the one the graph shows it published as at the start (discovery usually finds running
publishers a second later: then a warning, once), or a parameter is invalid. An error while recording (a full
disk) ends it with one ``stopped:`` line and exit status 1; the segments closed before the error stay a valid bag.
"""
from __future__ import annotations

import sqlite3
import sys
import time
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import Any

from rclpy.exceptions import InvalidHandle
from rclpy.executors import Executor
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription
from rosbags.rosbag2.errors import WriterError

from ..bags.errors import BagError
from ..bags.typestore import KNOWN_TOPICS, PLATFORM_STATE_TOPIC, check_known, normalize_type
from ..bags.writer import SegmentedBagWriter, check_output_path
from ..ros.specs import node_specs
from .conversions import message_class
from .params import declare_parameters
from .qos import is_latched, latched_qos, stream_qos, valid_topic_name
from .runtime import EXIT_FAILED, EXIT_OK, GprNode, StoppedAtStartError, one_line, run, stop_requested

NODE_NAME = 'recorder_node'
#: What writing a segment raises when the disk is full or a file size limit is reached.
WRITE_ERRORS: tuple[type[BaseException], ...] = (OSError, sqlite3.Error, WriterError, BagError)
#: The spins in a row that take no message, without waiting, which end the drain after a stop request before its
#: ``drain_timeout``: what DDS already delivered is written, what a live stream sends after the stop is not waited for
#: (a quiet time of 0.2 s never came beside the simulator's idle joint_states: 5 s more were recorded after every stop).
#: A spin is empty too when its wait woke for guard conditions only (the SIGINT's, the graph's as a publisher ends):
#: the drain then reads the readers themselves (:func:`take_waiting`) and ends only where they hold nothing.
DRAIN_EMPTY_SPINS = 3


def take_waiting(subscriptions: Sequence[Any], end: float) -> int:
    """Take every message the ``subscriptions``' readers hold now (as rclpy's executor takes one per wait), each
    through its callback (with its message info where the callback takes it; a destroyed subscription holds none),
    until they hold none or ``time.monotonic()`` reaches ``end``; the number taken. A recorder behind its stream
    stopped after three spins woken by guard conditions with 27 messages a topic waiting."""
    taken = 0
    for sub in subscriptions:
        # a callback of (message, info) is given both, as by the executor (it raised a TypeError)
        given = 2 if getattr(sub, '_callback_type', None) is Subscription.CallbackType.WithMessageInfo else 1
        while time.monotonic() < end:
            try:
                with sub.handle:
                    got = sub.handle.take_message(sub.msg_type, sub.raw)
            except InvalidHandle:   # a destroyed subscription holds nothing (rclpy's executor skips it so)
                break
            if got is None:
                break
            sub.callback(*got[:given])
            taken += 1
    return taken


def default_output() -> Path:
    return Path('bags') / datetime.now().strftime('gpr_%Y_%m_%d-%H_%M_%S')


class RecorderNode(GprNode):
    """Subscribes to the topics and writes every message into the bag; see the module docstring."""

    NODE_NAME = NODE_NAME

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        p = declare_parameters(self, node_specs(NODE_NAME))
        self.p = p
        output = Path(p['output']) if p['output'] else default_output()
        check_output_path(output)
        topics = self._resolve_topics(list(p['topics']))
        wrong = self._wrong_types(topics)
        if wrong:
            raise BagError(next(iter(wrong.values())) + '; allowed: the type it is published as (or the name alone: '
                           'its type is taken from the graph)')
        self.writer = SegmentedBagWriter(output, topics, storage=p['storage'], flush_interval=p['flush_interval'],
                                         max_bag_size=p['max_bag_size'], max_bag_duration=p['max_bag_duration'],
                                         compression=p['compression'], fsync=p['fsync'],
                                         custom_data={'recorder': NODE_NAME})
        classes = {t: message_class(ty) for t, ty in topics.items()}
        self.types, self.warned = topics, set[str]()
        self.received: dict[str, int] = dict.fromkeys(topics, 0)
        self.writer.open()
        try:
            # The state topic last: a publisher that waits for a subscription on it (trajectory_node's
            # wait_for_subscribers) then finds the other subscriptions announced already.
            order = sorted(topics, key=lambda t: t == PLATFORM_STATE_TOPIC)
            self.subs = [self.create_subscription(classes[t], t, self._callback(t), self._qos(t), raw=True)
                         for t in order]
            if p['flush_interval'] > 0:
                self.timer = self.create_timer(max(0.005, p['flush_interval'] / 20.0), self._poll)
            self.type_timer = self.create_timer(1.0, self._watch_types)
        except BaseException:
            self.writer.abort(remove=True)
            raise
        self.get_logger().info(f'recording {len(topics)} topic(s) into {output} ({p["storage"]}, flush interval '
                               f'{p["flush_interval"]} s): ' + ', '.join(f'{t} [{ty}]' for t, ty in topics.items()))

    def _qos(self, topic: str) -> QoSProfile:
        """Transient local for a latched topic (a known one, or one whose publishers all offer it), so the
        sample published before this subscription is delivered too, each publisher's (``queue_depth`` of them: two
        robots' ``/tf_static``); else the stream QoS."""
        depth = int(self.p['queue_depth'])
        offered = {i.qos_profile.durability for i in self.get_publishers_info_by_topic(topic)}
        latched = is_latched(topic) or offered == {latched_qos().durability}
        return latched_qos(depth) if latched else stream_qos(depth)

    def _resolve_topics(self, entries: list[str]) -> dict[str, str]:
        if not entries:
            raise BagError('topics is empty; allowed: one or more topic names (name or name:pkg/msg/Type)')
        topics: dict[str, str | None] = {}
        ns = self.get_namespace().rstrip('/')
        for entry in entries:
            name, sep, msgtype = entry.partition(':')
            full = valid_topic_name(self, name.strip(), 'topics')
            if full in topics:   # the last entry won without a word (another type, perhaps)
                raise BagError(f'topics: {full} is given twice ({entry!r} and an entry before it); allowed: each '
                               'topic once')
            # the suite's topics (and those of bags recorded before) by their name in the node's namespace too: in
            # /r1, gpr/platform_state waited for the graph and was refused where nothing published it yet
            known = KNOWN_TOPICS.get(full) or (KNOWN_TOPICS.get(full[len(ns):]) if ns and full.startswith(ns + '/')
                                                else None)
            topics[full] = check_known(msgtype, full) if sep else known
        return self._discover(topics)

    def _discover(self, topics: dict[str, str | None]) -> dict[str, str]:
        """The types of the topics given without one (``None``), from the graph within ``discovery_timeout``; a stop
        signal meanwhile ends the start (:class:`~.runtime.StoppedAtStartError`)."""
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
                if stop_requested():   # up to discovery_timeout (an hour) of SIGINT/SIGTERM ignored before
                    raise StoppedAtStartError(f'waiting for the type of topic(s) {", ".join(missing)}; no bag '
                                              'written')
                time.sleep(0.1)
            if missing:
                raise BagError(f'type of topic(s) {", ".join(missing)} unknown: not published within '
                               f'{self.p["discovery_timeout"]} s; allowed: give it as name:pkg/msg/Type')
        return {t: str(ty) for t, ty in topics.items()}

    def _wrong_types(self, topics: dict[str, str]) -> dict[str, str]:
        """The topics the graph publishes as other types only (no publisher matches: their bag stays empty, and
        looked valid), each with ``'topics: <topic> is published as <types>, not <type>'``."""
        out = {}
        for t, ty in topics.items():   # the publishers' types (the graph's list holds the recorder's subscription)
            offered = sorted({normalize_type(i.topic_type) for i in self.get_publishers_info_by_topic(t)})
            if offered and ty not in offered:
                out[t] = f'topics: {t} is published as {" and ".join(offered)}, not {ty}'
        return out

    def _watch_types(self) -> None:
        """A publisher discovered after the start with another type than the one recorded: a warning, once a
        topic (nothing of it is recorded)."""
        for topic, line in self._wrong_types({t: ty for t, ty in self.types.items() if t not in self.warned}).items():
            self.warned.add(topic)
            self.get_logger().warning(f'{line}: nothing of it is recorded')

    def _callback(self, topic: str) -> Any:
        writer, received = self.writer, self.received

        def cb(data: bytes) -> None:
            received[topic] += 1
            try:
                writer.write(topic, time.time_ns(), data)
            except WRITE_ERRORS as exc:
                raise self._write_failed(exc) from None

        return cb

    def _poll(self) -> None:
        try:
            self.writer.poll()
        except WRITE_ERRORS as exc:
            raise self._write_failed(exc) from None

    def _write_failed(self, exc: BaseException) -> BagError:
        return BagError(f'cannot write the bag {self.writer.path} ({type(exc).__name__}: {one_line(exc)}): is the '
                        'disk full, or a file size limit reached?')

    def on_exit(self, executor: Executor, status: int) -> int:
        """Drain what DDS already delivered (the timers cancelled, until :data:`DRAIN_EMPTY_SPINS` spins in a row that
        do not wait take no message and the readers then hold none, at most ``drain_timeout`` s: a warning when that
        ends it), close the bag and log the counts per topic. After an error (status 1), or a write that fails in the
        drain or the close (a full disk), the bag keeps the segments closed before it (:func:`keep_closed`)."""
        if status != EXIT_OK:
            keep_closed(self.writer, self.get_logger())
            return status
        for timer in (getattr(self, 'timer', None), getattr(self, 'type_timer', None)):
            if timer is not None:   # a due timer took the spins: a recorder behind stopped with messages waiting
                timer.cancel()
        limit = float(self.p['drain_timeout'])
        end, empty, start, drained = time.monotonic() + limit, 0, sum(self.received.values()), False
        try:
            while not drained and time.monotonic() < end:
                taken = sum(self.received.values())
                executor.spin_once(timeout_sec=0.0)
                empty = empty + 1 if sum(self.received.values()) == taken else 0
                if empty >= DRAIN_EMPTY_SPINS:   # the readers hold nothing (woken by a guard condition only: go on)
                    drained, empty = take_waiting(self.subs, end) == 0, 0
            self.writer.close()
        except WRITE_ERRORS as exc:   # as a write failing while recording: one line, the closed segments kept
            failed = exc if isinstance(exc, BagError) else self._write_failed(exc)
            self.get_logger().error(f'stopped: {type(failed).__name__}: {one_line(failed)}')
            keep_closed(self.writer, self.get_logger())
            return EXIT_FAILED
        if not drained and limit > 0:   # a recorder behind its stream lost the rest without a word
            after = sum(self.received.values()) - start
            self.get_logger().warning(f'the drain ended at drain_timeout = {limit:g} s with messages still coming '
                                      f'({after} taken after the stop): the rest is not recorded; a longer '
                                      'drain_timeout waits for it')
        counts = ', '.join(f'{t} {self.writer.counts[t]}/{self.received[t]}' for t in self.received)
        self.get_logger().info(f'stopped: wrote {sum(self.writer.counts.values())} messages into {self.writer.path} '
                               f'in {len(self.writer.files)} file(s) (written/received per topic: {counts}; '
                               f'longest segment close {self.writer.max_close_time * 1e3:.1f} ms)')
        return status


def keep_closed(writer: SegmentedBagWriter, logger: Any) -> None:
    """After an error: drop the open segment and keep the bag's closed segments (the bag folder removed when none
    was closed), saying which."""
    kept = writer.closed_message_count
    writer.abort(remove=kept == 0)
    logger.info(f'{writer.path}: kept the {kept} messages of the {len(writer.files)} segment(s) closed before the '
                'error' if kept else f'{writer.path}: no segment was closed before the error; removed')


def main(args: Sequence[str] | None = None) -> int:
    """Entry point: record until SIGINT/SIGTERM, then drain, close the bag and exit 0."""
    return run(RecorderNode, args)


if __name__ == '__main__':
    sys.exit(main())

"""``replay_node``: publishes a bag's messages back on their topics, like ``ros2 bag play``.

The stored serialized bytes are published as they are (no decode/encode round trip), in log-time order,
with the original spacing divided by ``rate``. Parameters (read-only):

- ``bag``: the bag folder (or a single ``.mcap``/``.db3`` file); required;
- ``rate``: speed factor (default 1; 2 = twice as fast);
- ``loop``: start over after the last message (until SIGINT/SIGTERM), one mean interval of the bag later (0.1 s for a
  bag whose messages share one instant);
- ``clock_rate``: publish ``/clock`` (``rosgraph_msgs/Clock``, best effort, as ``ros2 bag play --clock``) this often
  [Hz]: the bag's log time of that instant (the first message's while it waits for subscribers and at the start of
  a pass, back to it at each pass of a ``loop``), for nodes with ``use_sim_time``; 0 (the default): none; a bag whose
  log times pass 2038-01-19 (beyond ``builtin_interfaces/Time``) is refused with it;
- ``topics``: replay only these topics (default: all);
- ``wait_for_subscribers``: before the first message wait until every topic (or ``wait_topic`` alone: the replay
  launch's ``joint_states``, which its state publisher turns into /tf) has this many subscriptions (default 0), at
  most ``wait_timeout`` seconds;
- ``queue_depth``: publisher history depth (reliable, keep last; default 10000).

The node suite's topics (``gpr/platform_state``, ``joint_states``, ...: ``bags.typestore.KNOWN_TOPICS``) are
published in the node's namespace, whatever namespace they were recorded in (``-r __ns:=/r1``, the launch file's
``namespace``: where the state publisher and RViz of that namespace read them); other topics as recorded. A bag
whose joint states are on the legacy ``gpr/joint_states`` only is warned about, with the remap
(:func:`~gpr_kinematics.bags.typestore.legacy_joint_states`).

Latched topics (:func:`~gpr_kinematics.nodes.qos.is_latched`, e.g. ``gpr/geometry``) are published transient
local, so a subscriber that starts during the replay still gets them, every one of them in the bag (several
robots' ``/tf_static``; at most ``queue_depth``). Exits 0 at the end of the bag (after the
reliable publishers' acknowledgements, at most 5 s) or on SIGINT/SIGTERM; 2 with one ``cannot start:`` line when
the bag cannot be read (missing, corrupt, not a regular file), a topic name is invalid or a parameter is invalid.
A bag that no longer matches the checksums it carries (``gpr verify``'s ``bag.checksums``: a storage file or
``metadata.yaml`` changed since it was written) is warned about once at the start, naming what differs, and
replayed as it is; a bag without checksums (another recorder's) is not.
"""
from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from rclpy.exceptions import NameValidationException
from rclpy.executors import Executor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.validate_full_topic_name import validate_full_topic_name
from rosgraph_msgs.msg import Clock

from ..bags.checks_bag import checksum_check
from ..bags.errors import BagError
from ..bags.reader import read_bag
from ..bags.typestore import JOINT_STATES_TOPIC, KNOWN_TOPICS, LEGACY_JOINT_STATES_TOPIC, legacy_joint_states
from ..ros.specs import node_specs
from .conversions import message_class
from .params import declare_parameters
from .qos import is_latched, latched_qos, stream_qos, valid_topic_name
from .runtime import SPIN_TIMEOUT, GprNode, StopFlag, run, wait_acknowledged

NODE_NAME = 'replay_node'
#: Seconds between the passes of a looped bag whose messages share one instant (whatever the ``rate``).
LOOP_GAP = 0.1
#: While behind the bag, pending callbacks are served at most this often [s].
SERVE_PERIOD = 0.01
#: A pass later than this share of the bag's span (and 0.1 s) is warned about.
BEHIND = 0.1
#: The latest instant a ``builtin_interfaces/Time`` carries [ns] (its ``sec`` is an int32: 2038-01-19).
LAST_TIME_NS = (2 ** 31 - 1) * 1_000_000_000 + 999_999_999


class ReplayNode(GprNode):
    """Reads the bag at start and publishes it when spun (:meth:`spin`)."""

    NODE_NAME = NODE_NAME

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        p = declare_parameters(self, node_specs(NODE_NAME))
        if not p['bag']:
            raise BagError('parameter bag is empty; allowed: the path of a bag folder, .mcap or .db3 file')
        self.p = p
        # a name as recorded: a relative one resolves in this node's namespace, or is the bag's at the root (a
        # replay in /lp refused gpr/platform_state, recorded as /gpr/platform_state)
        asked = [(valid_topic_name(self, t, 'topics'), t) for t in p['topics'] if t]
        choices = [(full, '/' + t.strip('/')) if not t.startswith('/') else (full,) for full, t in asked]
        bag = read_bag(p['bag'], topics=[n for c in choices for n in c] or None)
        missing = [c[0] for c in choices if all(n not in bag.topics for n in c)]
        if missing:
            raise BagError(f'topic(s) {", ".join(missing)} not in the bag {p["bag"]}; it has: '
                           + ', '.join(read_bag(p['bag']).topics))
        self.bag = bag
        depth = int(p['queue_depth'])
        # a latched topic keeps every message of it in the bag (several robots' /tf_static: each a late subscriber
        # must get), at most queue_depth
        self.pubs = {name: self.create_publisher(message_class(t.msgtype), self.published_name(bag, name),
                                                 latched_qos(min(max(len(t), 1), depth)) if is_latched(name)
                                                 else stream_qos(depth))
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
        #: The publishers whose subscriptions ``wait_for_subscribers`` counts.
        self.waited = list(self.pubs.values())
        if p['wait_topic']:
            topic = valid_topic_name(self, p['wait_topic'], 'wait_topic')
            self.waited = [pub for pub in self.pubs.values() if pub.topic_name == topic]
            if not self.waited:
                legacy = legacy_joint_states(bag.topics, bag.namespace)   # replay.launch's joint_states:= left out
                hint = '' if legacy is None or topic != self.resolve_topic_name(JOINT_STATES_TOPIC.lstrip('/')) else (
                    f' (the bag carries its joint states on {self.pubs[legacy].topic_name}: replay.launch '
                    'joint_states:=gpr/joint_states)')
                raise BagError(f'wait_topic = {p["wait_topic"]!r} ({topic}) is not published by this replay; allowed: '
                               'one of ' + ', '.join(sorted(pub.topic_name for pub in self.pubs.values())) + hint)
        self._names = {id(pub): n for n, pub in self.pubs.items()}
        self._served, self._warned_behind = 0.0, False
        self.clock = None
        if p['clock_rate'] > 0.0:
            if len(self.times) and int(self.times[-1]) > LAST_TIME_NS:   # publish() would raise in a pass
                raise BagError(f'clock_rate = {p["clock_rate"]:g}: the bag\'s log times reach '
                               f'{int(self.times[-1])} ns, beyond what /clock carries (builtin_interfaces/Time: '
                               f'{LAST_TIME_NS} ns, 2038-01-19); allowed: clock_rate 0 for this bag')
            self.clock = self.create_publisher(Clock, '/clock', QoSProfile(   # rclcpp's ClockQoS, rosbag2's
                depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
        #: The pass under way: its start (monotonic), its first log time [ns] and the rate (0 while it waits for
        #: subscribers: the clock held at the bag's start); the next /clock due.
        self._pass: tuple[float, int, float] | None = None
        self._next_clock = 0.0
        self.get_logger().info(f'replaying {len(self.stream)} messages of {len(names)} topic(s) from {p["bag"]} '
                               f'at rate {p["rate"]}{" in a loop" if p["loop"] else ""}')
        self._warn_checksums(bag)
        for line in bag.unread():   # what gpr verify notes and does not read: here not replayed
            self.get_logger().warning(f'{line}: not replayed')
        legacy = legacy_joint_states(bag.topics, bag.namespace)
        # a recorder's defaults miss them (a bag with joint_states too: they are there), unless remapped there
        joint_states = self.resolve_topic_name(JOINT_STATES_TOPIC.lstrip('/'))
        if legacy is not None and self.pubs[legacy].topic_name != joint_states:
            self.get_logger().warning(   # the rule relative to the node's namespace, as it resolves the bag's topic
                f'the bag carries its joint states on {self.pubs[legacy].topic_name}, where the node suite published '
                f'them before they moved to joint_states: a recorder with its default topics and a state publisher '
                f'read joint_states (remap: -r {LEGACY_JOINT_STATES_TOPIC.lstrip("/")}:='
                f'{JOINT_STATES_TOPIC.lstrip("/")}; replay.launch: joint_states:=gpr/joint_states)')

    def _warn_checksums(self, bag: Any) -> None:
        """Warn where ``bag`` no longer matches its recorded checksums (:func:`~gpr_kinematics.bags.checks_bag.
        checksum_check`, as ``gpr verify`` checks them; none recorded: nothing to say): a tampered bag was replayed
        without a word."""
        check = checksum_check(bag, allow_missing=True)
        if check.passed:
            return
        what = '; '.join(f'{f.topic}: {f.detail}' for f in check.failures)
        more = check.failed - len(check.failures)
        self.get_logger().warning(
            f'the bag {self.p["bag"]} does not match its recorded checksums ({what}{f"; {more} more" if more else ""}):'
            ' gpr verify judges whether it can be trusted (its bag.checksums fails); replaying it as it is')

    def published_name(self, bag: Any, name: str) -> str:
        """Where the bag's topic ``name`` is published: a topic of the node suite (recorded in the bag's namespace,
        :attr:`~gpr_kinematics.bags.reader.Bag.namespace`, the root for a bag without one) in this node's namespace,
        as the nodes of a replay launched in a namespace read it (``/gpr/joint_states`` of a bag recorded at the root
        is ``/r1/gpr/joint_states`` for a replay in ``/r1``); any other topic (``/tf``, another node's, a suite's name
        outside the bag's namespace, which gpr verify does not check) as recorded: a root ``/joint_states`` beside a
        bag's ``/r1/joint_states`` was published with it, unverified states among the verified ones."""
        try:   # as recorded, a full name (rosbag2's): '/{node}/geometry' or '~/markers' were expanded in this node
            validate_full_topic_name(name)
        except NameValidationException as exc:
            raise BagError(f'{bag.path}: topic {name[:200]!r} is not a full ROS topic name ({str(exc).splitlines()[0]}'
                           '); allowed: the absolute names rosbag2 records (/gpr/platform_state)') from None
        ns = bag.namespace
        if ns and not name.startswith(ns + '/'):
            return name
        relative = bag.relative(name)
        return self.resolve_topic_name(relative.lstrip('/')) if relative in KNOWN_TOPICS else name

    def _wait(self, executor: Executor, stop: StopFlag, due: float) -> None:
        """Serve callbacks (the parameter services) until ``due`` (monotonic time) or a stop signal; a message due
        already still serves what is pending, at most every :data:`SERVE_PERIOD` (a dense replay starved the services;
        a spin at every message due added its cost to each, where the replay is behind already)."""
        while not stop:
            now = time.monotonic()
            delay = due - now
            if delay <= 0:
                self._tick(now)
                if now - self._served >= SERVE_PERIOD:
                    executor.spin_once(timeout_sec=0.0)
                    self._served = now
                return
            executor.spin_once(timeout_sec=min(delay, SPIN_TIMEOUT, self._tick(now)))
            self._served = time.monotonic()

    def wait_for_subscribers(self, executor: Executor, stop: StopFlag) -> None:
        want = int(self.p['wait_for_subscribers'])
        if want <= 0:
            return
        now = time.monotonic()
        if len(self.times):   # /clock holds the bag's start meanwhile (ros2 bag play --clock's paused clock)
            self._pass, self._next_clock = (now, int(self.times[0]), 0.0), now
        deadline = now + float(self.p['wait_timeout'])
        while not stop and time.monotonic() < deadline:
            if all(pub.get_subscription_count() >= want for pub in self.waited):
                return
            self._wait(executor, stop, time.monotonic() + 0.02)
        if not stop:
            which = f'{self.p["wait_topic"]} has fewer than' if self.p['wait_topic'] else 'not every topic has'
            self.get_logger().warning(f'{which} {want} subscriber(s) after {self.p["wait_timeout"]} s; starting '
                                      'anyway')

    def spin(self, executor: Executor, stop: StopFlag) -> None:
        """Publish the stream (again and again with ``loop``) until it ends or a stop signal arrives."""
        self.wait_for_subscribers(executor, stop)
        rate = float(self.p['rate'])
        if not stop:
            self.get_logger().info('started: publishing')
        while not stop and self.stream:
            t0 = time.monotonic()
            first = int(self.times[0])
            self._pass, self._next_clock = (t0, first, rate), t0
            for (pub, raw), t in zip(self.stream, self.times.tolist(), strict=True):
                self._wait(executor, stop, t0 + (t - first) * 1e-9 / rate)
                if stop:
                    return
                pub.publish(raw)
                self.published[self._names[id(pub)]] += 1
            self._behind(time.monotonic() - t0, rate)
            if not self.p['loop']:
                break
            self._wait(executor, stop, t0 + self._pass_period(rate))
        self.finish()

    def _tick(self, now: float) -> float:
        """Publish ``/clock`` if it is due at ``now`` (monotonic; ``clock_rate``): the bag's log time of the pass at
        that instant; the seconds until the next one is due (inf without ``clock_rate`` or before the first pass)."""
        if self.clock is None or self._pass is None:
            return math.inf
        if now >= self._next_clock:
            t0, first, rate = self._pass
            ns = min(first + round((now - t0) * rate * 1e9), LAST_TIME_NS)   # a loop's gap past the bag's end
            self.clock.publish(Clock(clock=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)))
            period = 1.0 / float(self.p['clock_rate'])
            self._next_clock += period
            if self._next_clock <= now:   # behind (a long publish): the next one period from now, no burst
                self._next_clock = now + period
        return max(self._next_clock - now, 0.0)

    def _behind(self, took: float, rate: float) -> None:
        """Warn (once) where a pass took ``took`` s, more than :data:`BEHIND` of the bag's span at ``rate`` late: the
        machine publishes no faster (a dense bag at rate 1 took 2.7 times its span, without a word)."""
        span = float(self.times[-1] - self.times[0]) * 1e-9 / rate
        late = took - span
        if late > max(BEHIND * span, 0.1) and not self._warned_behind:
            self._warned_behind = True
            self.get_logger().warning(f'the replay fell {late:.3g} s behind the bag ({took:.3g} s for {span:.3g} s at '
                                      f'rate {rate:g}, {len(self.times) / took:.0f} messages/s): this machine '
                                      'publishes no faster')

    def _pass_period(self, rate: float) -> float:
        """Seconds from one pass's start to the next with ``loop``: the bag's span and one mean interval between its
        messages, at ``rate``; :data:`LOOP_GAP` when its messages share one instant (a one-message bag looped at
        1,200 messages/s, starving the services)."""
        n = len(self.times)
        span = float(self.times[-1] - self.times[0]) * 1e-9 / rate
        return span + (span / (n - 1) if n > 1 and span > 0 else LOOP_GAP)

    def on_exit(self, executor: Executor, status: int) -> int:
        """Wait for the reliable subscribers' acknowledgements (at most 5 s per topic) and log the counts."""
        wait_acknowledged(self.pubs.values(), 5.0)
        self.get_logger().info('finished: published ' + ', '.join(f'{self.pubs[t].topic_name} {n}'   # where it went
                                                                  for t, n in self.published.items()))
        return status


def main(args: Sequence[str] | None = None) -> int:
    return run(ReplayNode, args)


if __name__ == '__main__':
    sys.exit(main())

"""What ``trajectory_node`` tells about a stream beside its samples (no rclpy object): how a goal's stream ended
(:class:`GoalEnd`), what a stream published (:func:`published_text`), and a stream that waits for simulated time
that does not come (:class:`ClockWatch`: under ``use_sim_time`` no ``/clock`` has arrived, or it stands still).

The node looks at the clock from a timer on the steady clock (``WATCH_PERIOD``): its stream's timer runs on the
ROS clock, which under ``use_sim_time`` does not fire while ``/clock`` is silent, so the stream, its goal and a
cancel of it waited without a word.
"""
from __future__ import annotations

import threading

from ..ros.streams import Trajectory

#: How often [s] the node's steady timer looks at a running stream (a cancel, the simulated clock).
WATCH_PERIOD = 0.1
#: Wall time [s] a stream waits for simulated time before the first word of it, and between the next ones.
CLOCK_FIRST_WORD = 3.0
CLOCK_WORD_EVERY = 10.0


class GoalEnd:
    """How a goal's stream ended, set once by the stream (``TrajectoryNode._end``) and awaited by the thread that
    executes the goal."""

    def __init__(self) -> None:
        self._event = threading.Event()
        self.outcome: tuple[str, str, int, int] = ('failed', '', 0, 0)

    def set_result(self, outcome: tuple[str, str, int, int]) -> None:
        self.outcome = outcome
        self._event.set()

    def wait(self) -> tuple[str, str, int, int]:
        self._event.wait()
        return self.outcome


def published_text(published: int, elapsed: float | None, rate: float) -> str:
    """What a stream published, in how long and at what rate [Hz]; a stream of fewer than two samples has no rate
    (one cancelled before its first sample read 'published 0 samples in -0.000 s (achieved nan Hz, ...)')."""
    if elapsed is None or published < 2 or elapsed <= 0.0:
        return f'published {published} sample{"" if published == 1 else "s"}'
    return (f'published {published} samples in {elapsed:.3f} s (achieved {(published - 1) / elapsed:.3f} Hz, '
            f'requested {rate} Hz)')


class ClockWatch:
    """Whether a stream under ``use_sim_time`` waits for simulated time that does not move: :meth:`check`, called
    every :data:`WATCH_PERIOD` with the ROS clock's time [ns] (0: no ``/clock`` has arrived) and the steady clock's
    [s], returns what to say once the time stood still :data:`CLOCK_FIRST_WORD` s, then every
    :data:`CLOCK_WORD_EVERY` s (else None), and whether it is a warning (no ``/clock`` at all)."""

    def __init__(self) -> None:
        self._ns: int | None = None
        self._since = 0.0
        self._next = CLOCK_FIRST_WORD

    def reset(self, sim_ns: int, now: float) -> None:
        """A stream starts waiting now."""
        self._ns, self._since, self._next = sim_ns, now, CLOCK_FIRST_WORD

    def check(self, sim_ns: int, now: float, waiting: str) -> tuple[str, bool] | None:
        """What to say of ``waiting`` (the stream and its next sample, in words), if anything."""
        if sim_ns != self._ns:   # simulated time moved
            self.reset(sim_ns, now)
            return None
        waited = now - self._since
        if waited < self._next:
            return None
        self._next += CLOCK_WORD_EVERY
        if sim_ns == 0:
            return (f'no /clock has arrived in {waited:.0f} s: use_sim_time is true and {waiting} waits for simulated '
                    'time; allowed: a /clock publisher (a simulator, ros2 bag play --clock, replay_node with '
                    'clock_rate), or use_sim_time false', True)
        return (f'the simulated clock has stood at {sim_ns * 1e-9:.3f} s for {waited:.0f} s (/clock paused or '
                f'stopped): {waiting} waits for it', False)


def station_name(traj: Trajectory, i: int) -> str:
    """The name of the station (waypoint) sample ``i`` of ``traj`` is at ('' while moving, or past the end)."""
    k = traj.station[i] if i < len(traj) else -1
    return traj.station_names[k] if k >= 0 else ''


def where(traj: Trajectory, i: int) -> str:
    """Where ``traj`` is at sample ``i``, in words: ``sweep``, ``at station 1 (a)``, ``moving from station 0 to
    station 1`` (waypoints for a robot program)."""
    if not traj.station_names:
        return 'sweep'
    unit = traj.unit
    if i < len(traj) and traj.station[i] >= 0:
        return f'at {unit} {traj.station[i]} ({station_name(traj, i)})'
    # the sample's own target (the largest station passed was 0 where no sample fell on a station: dwell 0)
    to = traj.target[min(i, len(traj) - 1)] if traj.target else 1
    return f'moving from {unit} {to - 1} to {unit} {to}'

"""The simulated controller at run time (no ROS import): :func:`servo`, the actuators' first-order response,
:class:`Lag`, a goal's motion under it (planned and checked before it runs, then played as planned), and
:func:`violation`, the check of a tolerance (``PATH_TOLERANCE_VIOLATED``, ``GOAL_TOLERANCE_VIOLATED``). SI units.

Under a first-order response to a command held over a step the joints move on the straight joint-space line from
where they are towards it (``desired + (actual - desired) exp(-t / tau)``: one scalar factor for every joint), so
the path a lagging robot takes between two samples is the line between them: the polyline :meth:`Lag.path` is that
path exactly, whatever the sample times."""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


class NamedJoints(Protocol):
    """The joints' names and units (:class:`~.controller.ControllerJoints`, which imports this module)."""

    @property
    def names(self) -> Sequence[str]: ...

    @property
    def units(self) -> Sequence[str]: ...


def servo(actual: Array, desired: Array, dt: float, tau: float) -> Array:
    """The joints after ``dt`` [s] of a first-order response with time constant ``tau`` [s] to ``desired`` held over
    the step: ``desired + (actual - desired) exp(-dt / tau)``; ``tau = 0``: ``desired`` exactly."""
    return np.array(desired if tau <= 0.0 else desired + (actual - desired) * math.exp(-dt / tau), dtype=np.float64)


def after_wait(arrival: Array, command: Array, wait: float, tau: float) -> Array:
    """Every joint ``wait`` [s] after the ``arrival`` (its state then), converging to ``command``: :func:`servo`
    over the wait, the arrival itself (a copy) for none."""
    return servo(arrival, command, wait, tau) if wait > 0.0 else np.array(arrival, dtype=np.float64)


#: Corners of :meth:`Lag.path` on the wait's line and on the settling line, a fourth of a halving apart: the last
#: within 2^-20 of the line's end.
LINE_CORNERS = 80


@dataclass(frozen=True)
class Lag:
    """A goal's motion under the lag ``tau`` [s] (module docstring): every joint ``(N,)`` at the goal's ``arrival``,
    converging to ``command`` (the last goal's end; the arrival where none) while it ``wait`` s for its start, then at
    each sample ``samples (K, N)`` (row 0: after the wait) as :func:`servo` takes them towards the motion's
    positions. Its arrays are read-only."""

    tau: float
    arrival: Array
    command: Array
    wait: float
    samples: Array

    def __post_init__(self) -> None:
        for a in (self.arrival, self.command, self.samples):
            a.flags.writeable = False

    @classmethod
    def of(cls, tau: float, arrival: Array, command: Array | None, wait: float, time: Array, positions: Array) -> Lag:
        """The lag of a motion sampled at ``time (K,)`` [s] with every joint's desired ``positions (K, N)``: a step
        ``dt = t_k - t_(k-1)`` per sample, none at the first (as the simulator steps)."""
        arrival = np.array(arrival, dtype=np.float64)
        command = arrival.copy() if command is None else np.array(command, dtype=np.float64)
        samples = np.empty_like(positions, dtype=np.float64)
        samples[0] = after_wait(arrival, command, wait, tau)
        if tau <= 0.0:
            samples[1:] = positions[1:]
            return cls(tau, arrival, command, wait, samples)
        # servo's operations in its order, in place row by row (half the time of a new array per sample)
        factors = [math.exp(-dt / tau) for dt in np.diff(np.asarray(time, dtype=np.float64)).tolist()]
        rows, desired = list(samples), list(positions)
        for k in range(1, len(rows)):
            row = rows[k]
            np.subtract(rows[k - 1], desired[k], out=row)
            np.multiply(row, factors[k - 1], out=row)
            np.add(desired[k], row, out=row)
        return cls(tau, arrival, command, wait, samples)

    def waited(self, elapsed: float) -> Array:
        """Every joint ``elapsed`` [s] into the wait (clamped to it): on the line from the arrival to the command,
        never past the first sample."""
        return after_wait(self.arrival, self.command, min(max(elapsed, 0.0), self.wait), self.tau)

    def path(self, time: Array, end: Array) -> tuple[Array, Array]:
        """The joints' whole path: its corners ``(M, N)``, the lines between them, and the instants they pass them
        ``(M,)`` [s from the goal's arrival]: on the wait's line from the arrival, then every sample (at the wait
        plus its ``time (K,)``), then the line from the last sample to ``end`` (the last point, which they settle
        to). On the two lines a corner at every ``tau ln 2 / 4`` (the response goes a fourth of the way left in
        halves), their instants exact (a refusal on a line names when the joints are there, not a share of its
        length), at least a nanosecond apart (a message's quantum; a ``tau`` below it)."""
        step = self.tau * math.log(2.0) / 4.0
        t = step * np.arange(1, 1 + LINE_CORNERS)
        shown = np.maximum(t, 1e-9 * np.arange(1, 1 + LINE_CORNERS))
        waits = np.flatnonzero(shown < self.wait) if self.wait > 0.0 else np.zeros(0, dtype=np.int64)
        last = float(time[-1]) + self.wait
        corners = [self.arrival[None, :]] if self.wait > 0.0 else []
        corners += [servo(self.arrival, self.command, float(t[j]), self.tau)[None, :] for j in waits]
        corners += [self.samples, *(servo(self.samples[-1], end, float(x), self.tau)[None, :] for x in t),
                    np.asarray(end, dtype=np.float64)[None, :]]
        times = np.concatenate([[0.0] if self.wait > 0.0 else [], shown[waits],
                                self.wait + np.asarray(time, dtype=float), last + shown, [last + shown[-1] + shown[0]]])
        return np.vstack(corners), times


def violation(joints: NamedJoints, cols: NDArray[np.int64], error_position: Array, error_velocity: Array,
              position: Array, velocity: Array, what: str) -> str | None:
    """The first joint of ``cols`` whose position or velocity error ``(N,)`` exceeds its tolerance ``(N,)``, named with
    the tolerance and the error (``what``: path or goal), or None."""
    for err, tol, kind, suffix in ((error_position, position, 'position', ''), (error_velocity, velocity, 'velocity',
                                                                                '/s')):
        bad = np.abs(err[cols]) > tol[cols]
        if bad.any():
            j = int(cols[int(np.argmax(bad))])
            return (f'{joints.names[j]}: {kind} error {abs(err[j]):.6g} {joints.units[j]}{suffix} exceeds the {what} '
                    f'tolerance {tol[j]:.6g} {joints.units[j]}{suffix}')
    return None

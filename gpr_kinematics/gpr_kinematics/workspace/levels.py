"""The level loop of the covering, and its split into parts that run anywhere (here or on a Dask cluster).

A run processes its pending boxes level by level (:func:`run_levels`), each level cut into chunks of a fixed
size (numpy's unit of work). Once a level holds enough work (:func:`distribute_at`), the pending boxes are
cut into ``parts`` contiguous parts and each part is covered to the end on its own (:func:`cover_part`):
that is the unit of work of a cluster, sent once and returned once, with no synchronisation between levels.
The parts are put back together in their order, so the boxes and their order depend on ``chunk`` and
``parts`` only, not on where the parts run (one process or any number of workers). Every box's fate depends
on that box alone, so the set of boxes does not depend on them either.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .boxes import box_volume

#: Parts a run is cut into once it holds enough work (fixed, so that results do not depend on the workers).
PARTS = 16

# In this process, the driver's stop test and progress report reach the parts it runs itself (a part that
# runs on a cluster worker only has its deadline).
_LOCAL = threading.local()


def distribute_at(chunk: int, parts: int = PARTS) -> int:
    """Pending work units from which a run is cut into parts: enough for every part to fill part of a chunk."""
    return parts * max(chunk // 16, 1)


#: The reasons a signal gives (``terminated``: SIGTERM, as the command line renames ``interrupted``).
SIGNALLED = ('interrupted', 'terminated')


@dataclass
class Outcome:
    """What some levels of a covering decided, and what is left (``frontier``; empty when done)."""

    inner: list[np.ndarray] = field(default_factory=list)
    boundary: list[np.ndarray] = field(default_factory=list)
    outside: list[np.ndarray] = field(default_factory=list)
    outside_count: int = 0
    evaluations: int = 0
    levels: int = 0
    stopped: str = ''
    frontier: Any = None
    diameter: float = float('inf')
    outside_volume: float = 0.0
    reported: bool = False

    def merge(self, other: Outcome, keep_outside: bool) -> None:
        self.inner += other.inner
        self.boundary += other.boundary
        if keep_outside:
            self.outside += other.outside
        self.outside_count += other.outside_count
        self.evaluations += other.evaluations
        self.outside_volume += other.outside_volume
        self.levels = max(self.levels, other.levels)
        self.diameter = min(self.diameter, other.diameter)
        self.stop(other.stopped)

    def stop(self, reason: str) -> None:
        """Add a reason the run stopped, once (parts stop for reasons of their own: the first no longer hides the
        others, as a part's share of the box limit hid the time limit that ended the run); a signal's first (Ctrl-C
        read ``box limit (10000000 boxes, shared among the parts); interrupted`` at 1.2 million boxes)."""
        reasons = [r for r in self.stopped.split('; ') if r]
        if reason and reason not in reasons:
            reasons.insert(0 if reason in SIGNALLED else len(reasons), reason)
            self.stopped = '; '.join(reasons)


def run_levels(
    model: Any,
    step: Callable[..., Any],
    args: tuple[Any, ...],
    frontier: Any,
    delta: float,
    chunk: int,
    keep_outside: bool,
    max_boxes: int,
    stop: Callable[[], str],
    report: Callable[[int, float, Any], None] | None = None,
    level: int = 0,
    until: int | None = None,
    budget: int | None = None,
) -> Outcome:
    """Cover ``frontier`` level by level until it is empty, ``stop()`` returns a reason, the boxes kept could
    exceed ``budget`` (default ``max_boxes``, the run's limit, which the reason names), or (``until``) it holds at
    least that many work units. A level turns each pending box into at most two, so the boxes kept plus the
    pending ones never exceed the budget (when the frontier starts within it)."""
    out = Outcome(levels=level)
    kept = 0
    limit = max_boxes if budget is None else budget
    while frontier.size:
        reason = stop()
        if reason:
            out.stopped = reason
            break
        if until is not None and frontier.size >= until:
            break
        if kept + 2 * frontier.size > limit:
            out.stopped = f'box limit ({max_boxes} boxes{"" if budget is None else ", shared among the parts"})'
            break
        out.levels += 1
        out.diameter = frontier.diameter(model_scale(model, frontier))
        children = []
        chunks = frontier.split(chunk)
        for i, c in enumerate(chunks):
            if i and stop():
                children.extend(chunks[i:])
                break
            try:
                r = step(model, c, delta, *args)
            except KeyboardInterrupt:                 # inside a model's evaluation: keep what is recorded
                out.stopped = 'interrupted'
                children.extend(chunks[i:])
                break
            out.inner.append(r.inner)
            out.boundary.append(r.boundary)
            if keep_outside:
                out.outside.append(r.outside)
            out.outside_count += r.outside.shape[0]
            out.outside_volume += box_volume(r.outside)
            out.evaluations += r.evaluations
            kept += r.inner.shape[0] + r.boundary.shape[0] + (r.outside.shape[0] if keep_outside else 0)
            children.append(r.children)
            if report is not None:
                report(out.levels, out.diameter, r)
        frontier = frontier.join(children)
        if out.stopped:
            break
    out.frontier = frontier
    return out


def model_scale(model: Any, frontier: Any) -> np.ndarray:
    """The scale (m per unit) of the boxes the frontier reports diameters for: the outputs'."""
    index = getattr(model, 'output_index', None)
    return np.asarray(model.scale if index is None else np.asarray(model.scale)[index])


def cover_part(
    model: Any,
    part: Any,
    delta: float,
    step: Callable[..., Any],
    args: tuple[Any, ...],
    chunk: int,
    keep_outside: bool,
    max_boxes: int,
    deadline: float | None,
    level: int,
    spare: int = 0,
) -> Outcome:
    """Cover one part to the end (the unit of work of a cluster). Stops at ``deadline`` (``time.time()``), or,
    in the driver's process, when the driver stops, or before it keeps more than its own boxes plus ``spare``
    (its share of the run's ``max_boxes``: the parts run apart, so each has a budget of its own, and the budgets
    add up to the run's limit)."""
    local_stop = getattr(_LOCAL, 'stop', None)
    report = getattr(_LOCAL, 'report', None)

    def stop() -> str:
        if local_stop is not None:
            return str(local_stop())
        return 'time limit' if deadline is not None and time.time() > deadline else ''

    out = run_levels(model, step, args, part, delta, chunk, keep_outside, max_boxes, stop, report, level,
                     budget=part.size + spare)
    out.reported = report is not None
    if out.frontier.size:                                   # stopped: what is left counts as boundary
        out.boundary.append(out.frontier.output_boxes())
    out.frontier = None
    return out


class LocalContext:
    """While alive, parts run in this process see the driver's stop test and progress report."""

    def __init__(self, stop: Callable[[], str], report: Callable[[int, float, Any], None]) -> None:
        _LOCAL.stop, _LOCAL.report = stop, report

    def __enter__(self) -> LocalContext:
        return self

    def __exit__(self, *exc: object) -> None:
        _LOCAL.stop = _LOCAL.report = None


def decided_volume(out: Outcome) -> tuple[float, float]:
    """Inner and boundary volumes of an outcome."""
    return sum(box_volume(a) for a in out.inner), sum(box_volume(a) for a in out.boundary)

"""The first instant a pair comes closer than the margin, to within :data:`RESOLUTION` (docs/cell.md, "Branch and
bound over time").

The clearance search measures a pair where its bounds need it: near its least distance, coarsely elsewhere, so the
first of its instants measured below the margin lay 19-23 ms after the crossing on the cell example at a margin of
7 mm, and a whole dip later where the pair's least distance lies in a later approach. From that instant ``T``, every
interval of the pair before it is searched again with the margin as the target: an interval whose certificate (the
measured distances at its ends, the bodies' motion bounds between; :mod:`~gpr_kinematics.safety.clearance`) reaches
the margin holds no crossing; an end measured below the margin becomes ``T``, and the intervals after it go; the rest
are halved until shorter than :data:`RESOLUTION`. ``T`` is then the first instant measured below the margin, every
earlier interval shown the margin apart or shorter than :data:`RESOLUTION` between instants measured at least the
margin apart, the last of them ending at ``T``: the crossing to within :data:`RESOLUTION`. The distance is the
search's, the collision library's (python-fcl) refined to a certified lower bound, before its slack.
"""
from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from .distances import LIBRARY_SLACK, Exact, Store

Array = NDArray[np.float64]
Ints = NDArray[np.int64]
Bools = NDArray[np.bool_]


class Intervals:
    """Intervals ``[i0, i1]`` (instant indices) of pairs ``p``, from base interval ``base``, with the pair's motion
    bounds on them: ``mu`` (total), ``eps`` (beyond a translation) [m] and ``delta`` (the translation, NaN: none)."""

    def __init__(self, p: Ints, i0: Ints, i1: Ints, base: Ints) -> None:
        self.p, self.i0, self.i1, self.base = p, i0, i1, base
        self.mu, self.eps, self.delta = np.zeros(p.shape), np.zeros(p.shape), np.zeros(p.shape + (3,))

    def take(self, sel: NDArray[np.bool_]) -> Intervals:
        out = Intervals(self.p[sel], self.i0[sel], self.i1[sel], self.base[sel])
        out.mu, out.eps, out.delta = self.mu[sel], self.eps[sel], self.delta[sel]
        return out

    def join(self, other: Intervals) -> Intervals:
        out = Intervals(*(np.concatenate([getattr(self, k), getattr(other, k)]) for k in ('p', 'i0', 'i1', 'base')))
        out.mu, out.eps = np.concatenate([self.mu, other.mu]), np.concatenate([self.eps, other.eps])
        out.delta = np.concatenate([self.delta, other.delta])
        return out


class Search(Protocol):
    """What the refinement takes of the clearance search (:mod:`~gpr_kinematics.safety.clearance`'s ``_Search``):
    its instants, library distances, pairs, margin, lower bounds and its intervals' split, motion bounds and bound."""

    store: Store
    exact: Exact
    pa: Ints
    pb: Ints
    margin: float

    def lower(self, p: Ints, i: Ints) -> tuple[Array, Ints]: ...

    def _items(self, pairs: Ints) -> tuple[Intervals, Ints, Ints]: ...

    def _split(self, items: Intervals, split: Bools) -> Intervals: ...

    def _motion(self, items: Intervals) -> None: ...

    def _bound(self, items: Intervals, d0: Array, d1: Array, exact: Bools) -> Array: ...

#: The first instant below the margin is within this of the crossing [s].
RESOLUTION = 1e-6
#: Most halvings, most intervals at once, most instants added: beyond (a pair grazing the margin for a long time), the
#: refinement stops, the first instant measured below the margin so far kept (one measured below still).
ROUNDS = 80
MOST_ITEMS = 50_000
MOST_INSTANTS = 100_000


def first_below(search: Search, pairs: Ints, instants: Ints, refine: bool) -> dict[int, float]:
    """Per pair of ``pairs``, the first of ``instants`` (the search's, measured below the margin) [s]; where ``refine``,
    moved back to the crossing (module docstring)."""
    t = search.store.t(instants)
    order = np.lexsort((t, pairs))
    first = order[np.flatnonzero(np.r_[True, pairs[order][1:] != pairs[order][:-1]])] if pairs.size else order
    below = dict(zip(pairs[first].tolist(), instants[first].tolist(), strict=True))
    if refine and below:
        _refine(search, below)
    return {p: float(search.store.data['t'][i]) for p, i in below.items()}


def _refine(search: Search, below: dict[int, int]) -> None:
    """Move each pair's instant in ``below`` (pair -> instant index) back to its crossing, in place."""
    items, start = _before(search, below), search.store.n
    for _ in range(ROUNDS):
        if not items.p.size or items.p.size > MOST_ITEMS or search.store.n - start > MOST_INSTANTS:
            return
        bound, ends = _bounds(search, items)
        rough = (bound < search.margin) & ~(ends[0][1] & ends[1][1])
        if rough.any():   # ends known by their spheres or boxes only, not enough: the library's distance
            r = items.take(rough)
            search.exact.measure(np.concatenate([r.p, r.p]), np.concatenate([r.i0, r.i1]), search.pa, search.pb)
            bound, ends = _bounds(search, items)
        t = search.store.data['t']
        for (d, exact), i in zip(ends, (items.i0, items.i1), strict=True):
            low = exact & (d < search.margin)
            for p, k in zip(items.p[low].tolist(), i[low].tolist(), strict=True):
                if t[k] < t[below[p]]:
                    below[p] = k
        until = t[np.array([below[p] for p in items.p.tolist()], dtype=np.int64)]
        t0, t1 = t[items.i0], t[items.i1]
        keep = (t0 < until) & (bound < search.margin) & (t1 - t0 > RESOLUTION)
        if not keep.any():
            return
        items = search._split(items.take(keep), np.ones(int(keep.sum()), dtype=bool))


def _bounds(search: Search, items: Intervals) -> tuple[Array, tuple[tuple[Array, Bools], tuple[Array, Bools]]]:
    """The certificate of each interval and, at each end, the best lower bound known and whether it is the library's
    distance (then as measured: before the slack)."""
    ends = []
    for i in (items.i0, items.i1):
        d, level = search.lower(items.p, i)
        ends.append((np.where(level == 2, d + LIBRARY_SLACK, d), level == 2))
    (d0, e0), (d1, e1) = ends
    return search._bound(items, d0, d1, e0 & e1), (ends[0], ends[1])


def _before(search: Search, below: dict[int, int]) -> Intervals:
    """The pair's intervals of the search (its base intervals where both bodies exist and no contact is intended)
    before its instant in ``below``, the one holding it cut there, with their motion bounds."""
    items = search._items(np.array(sorted(below), dtype=np.int64))[0]
    at = np.array([below[p] for p in items.p.tolist()], dtype=np.int64)
    t = search.store.data['t']
    before = t[items.i0] < t[at]
    items, at = items.take(before), at[before]
    items.i1 = np.where(t[items.i1] > t[at], at, items.i1)
    search._motion(items)
    return items

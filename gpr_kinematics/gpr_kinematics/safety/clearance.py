"""Certified clearance: the smallest distance of every pair of bodies over a whole motion, no collision hidden
between samples (docs/cell.md, "The certificate").

**Certificate.** On an interval where every point of body ``a`` moves by at most ``mu_a`` and of ``b`` by at most
``mu_b`` (:mod:`~gpr_kinematics.safety.motion`), the distance ``d(t)`` of the pair is at least ``d(t0) - mu(t0, t)``
and at least ``d(t1) - mu(t, t1)`` with ``mu(t0, t) + mu(t, t1) <= mu = mu_a + mu_b``, hence

    ``min_[t0, t1] d >= min(d0, d1, (d0 + d1 - mu) / 2)``,

``d0``, ``d1`` any lower bounds at the ends: the collision library's distance less :data:`LIBRARY_SLACK`, or the
separating-axis bound of :func:`~gpr_kinematics.safety.bodies.box_lower_bound`. Two bodies both carried by the
platform keep their distance when it moves (a rigid motion), so only their arm motions count. Where the pair's
relative motion is a translation ``tau Delta`` (``tau`` in [0, 1]: the wafer and blade on a straight entry) plus a
motion of at most ``eps``, ``d(tau)`` of the translated bodies is **convex** (the distance of a point on a line
to the convex set ``B - A``), so it lies above its tangents at the ends: slopes ``Delta . (p_a - p_b) / d`` from the
library's nearest points; that bound less ``eps`` is used where larger.

**Branch and bound.** The motion is sampled at :data:`BASE_RATE` where it moves (not inside a hold, whose bounds are
0) and at every waypoint's arrival and departure.
For each pair, an interval whose bound lies below the pair's smallest measured distance ``U`` less its tolerance
``max(TOLERANCE, RELATIVE U)`` (or below the margin, for ``U`` at or above it) is refined: its ends are measured
exactly, then it is split at its midpoint (new instants, exact poses, shared by every pair), until no interval's
bound does. The reported distance is the smallest
bound: never above the true minimum, and at most the tolerance and :data:`~.distances.LIBRARY_SLACK` below it
(the measured distances keep it). The cheap bounds are vectorised over all pairs and intervals (numpy); the library
(FCL, through python-fcl: exact primitives, GJK/EPA) is called only where they do not prove the pair's minimum.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, brief
from ..inputs.validation import plain_number
from .bodies import Body, box_lower_bound
from .crossing import Intervals, first_below
from .distances import LIBRARY_SLACK, Exact, Store, Table, key
from .margin import MARGIN, MARGIN_RANGE
from .motion import BodyMotion, Levers, grid_within, levers, moving_intervals

Array = NDArray[np.float64]
Ints = NDArray[np.int64]
Pair = tuple[int, int, tuple[tuple[float, float], ...]]

#: Each pair's minimum ``d`` is certified to within ``max(TOLERANCE, RELATIVE * (|d| - NEAR))`` [m]: 50 um up to
#: 21 mm, 5 % of the excess beyond 20 mm (the margin: :mod:`~gpr_kinematics.safety.margin`).
TOLERANCE = 5e-5
#: Finest tolerance accepted [m]: 1 um takes a few seconds on the example cell program, 1 nm minutes.
MIN_TOLERANCE = 1e-6
RELATIVE = 0.05
NEAR = 0.02
#: Base sampling of the motion [Hz]; the shortest interval split [s]; most refinement rounds.
BASE_RATE = 1.0
MIN_INTERVAL = 1e-7
MAX_ROUNDS = 60
#: Most base instants within the moves: beyond :data:`BASE_RATE` times the moves' duration (10,000 s), the base is
#: sparser and the search splits the intervals it needs (a move of 1e6 s was a million instants).
BASE_MOST = 10_000
#: Most (pair, interval) items refined at once (pairs are taken in chunks), most instants computed: beyond, the
#: bounds reached are reported (lower bounds still, less tight than the tolerance).
CHUNK_ITEMS = 400_000
MAX_INSTANTS = 2_000_000


@dataclass(frozen=True)
class PairClearance:
    """The certified smallest distance of a pair over the motion [m] (negative: penetration), the instant of the
    smallest distance measured [s], ``first_below`` the first instant measured below the margin [s] (the library's
    distance before the slack; the crossing to within :data:`~.crossing.RESOLUTION`, deciding the search's first;
    NaN: none, a pair below the margin by its bounds only) and ``measured`` the smallest distance the library
    measured less :data:`~.distances.LIBRARY_SLACK` (at ``time``)."""

    bodies: tuple[str, str]
    distance: float
    time: float
    first_below: float = float('nan')
    measured: float = float('nan')


@dataclass(frozen=True)
class ClearanceReport:
    """Every checked pair, closest first; ``min_clearance`` the smallest distance [m]; ``margin``, ``tolerance``
    [m]; ``evaluations``: the library's distance calls; ``instants``: instants whose poses were computed;
    ``series``: the base instants [s] and the certified lower bound of every pair's distance from each to the next."""

    pairs: tuple[PairClearance, ...]
    min_clearance: float
    margin: float
    tolerance: float
    evaluations: int
    instants: int
    series: tuple[Array, Array] = field(default=(np.zeros(0), np.zeros(0)), repr=False, compare=False)

    @property
    def below_margin(self) -> tuple[PairClearance, ...]:
        return tuple(p for p in self.pairs if p.distance < self.margin)


def slack_note(measured: float, margin: float) -> str:
    """Why a pair ``measured`` below the ``margin`` [m] was not measured below it: the slack, in words, or ''."""
    return f" (the library's distance less its slack of {LIBRARY_SLACK:g} m)" if measured < margin else ''


def _windows_mask(windows: Sequence[tuple[float, float]], t0: Array, t1: Array, inside: bool) -> NDArray[np.bool_]:
    if not windows:
        return np.ones(t0.shape, dtype=bool)
    ok = np.zeros(t0.shape, dtype=bool) if inside else np.ones(t0.shape, dtype=bool)
    for lo, hi in windows:
        if inside:
            ok |= (t0 >= lo - 1e-12) & (t1 <= hi + 1e-12)
        else:
            ok &= (t1 <= lo + 1e-12) | (t0 >= hi - 1e-12)
    return ok


def check_length(name: str, value: Any, lo: float, hi: float, shown: str | None = None) -> None:
    """``value`` in [``lo``, ``hi``] m, else :class:`~gpr_kinematics.errors.InputError` naming ``name`` and the value
    (``shown``: as the user typed it, a command line's ``--margin = 5``; else :func:`~gpr_kinematics.errors.brief`),
    with the hint of millimetres typed as metres where they would be within it."""
    v = plain_number(value)
    if not lo <= v <= hi:
        mm = f' ({v:g} mm? give {v / 1000.0:g})' if hi < v <= 1000.0 * hi else ''  # --margin 5 for 5 mm
        raise InputError(f'{name} = {brief(value) if shown is None else shown} is invalid; allowed: metres, at least '
                         f'{lo:g} and at most {hi:g}{mm}')


def check_numbers(margin: float, tolerance: float, rate: float) -> None:
    """The margin in [0, 1] m, the tolerance in [:data:`MIN_TOLERANCE`, 1] m and the rate in (0, 1000] Hz; else
    :class:`~gpr_kinematics.errors.InputError` naming the value (a finer tolerance runs for minutes)."""
    check_length('margin', margin, *MARGIN_RANGE)
    check_length('tolerance', tolerance, MIN_TOLERANCE, 1.0)
    if not 0.0 < plain_number(rate) <= 1000.0:
        raise InputError(f'rate = {brief(rate)} is invalid; allowed: 0 < rate <= 1000 Hz')


def clearance(motion: BodyMotion, bodies: Sequence[Body], pairs: Sequence[Pair], margin: float = MARGIN,
              tolerance: float = TOLERANCE, rate: float = BASE_RATE, decide: bool = False,
              progress: Callable[[float], None] | None = None) -> ClearanceReport:
    """The certified smallest distance of every pair of ``bodies`` over ``motion`` (module docstring).

    Args:
        pairs: ``(i, j, skip)``: body indices and the time windows to leave out (intended contact).
        margin: below it a pair counts as a collision [m]; tolerance: accuracy of each pair's minimum [m].
        rate: base sampling [Hz] before refinement.
        decide: False (the default): every pair's minimum to the tolerance, and where it is measured below the
            margin its crossing (:mod:`~gpr_kinematics.safety.crossing`). True: only whether each pair keeps the
            margin: a pair is settled once every interval's bound reaches the margin (its ``distance`` then a lower
            bound of at least the margin), or as soon as the library measures it closer (``measured``, at ``time``;
            its ``distance`` the bounds reached, a lower bound still).
        progress: called after each round of the search with the share of the work done, in [0, 1]: the base
            intervals of every pair settled (an interval split in halves counts half for each), chunk by chunk.

    Raises:
        InputError: a margin that is not a number of metres in [0, 1], a tolerance outside [1e-6, 1] m, a rate outside
            (0, 1000] Hz.
    """
    check_numbers(margin, tolerance, rate)
    return _Search(motion, bodies, pairs, margin, tolerance, rate, decide, progress).run()


def _heights(motion: BodyMotion, bodies: Sequence[Body], platform: NDArray[np.bool_]) -> tuple[Array, Array]:
    """The range of heights along the platform normal ``(lo, hi)`` of every platform-carried body, in
    ``gpr_platform`` [m] (the same at every instant: every arm joint turns about the normal), less the rounding."""
    snap = motion.snapshot(np.zeros(1))
    pp, Rp = snap.frames['gpr_platform']
    lo, hi = np.full(len(bodies), -np.inf), np.full(len(bodies), np.inf)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    for k, b in enumerate(bodies):
        if platform[k] and b.frame is not None:
            p, R = snap.frames[b.frame]
            world = p[0] + (R[0] @ (b.position + (signs * b.half) @ b.rotation.T).T).T
            z = (world - pp[0]) @ Rp[0][:, 2]
            lo[k], hi[k] = float(np.min(z)) - 1e-12, float(np.max(z)) + 1e-12
    return lo, hi


class _Search:
    """The branch and bound of :func:`clearance` over all pairs at once."""

    def __init__(self, motion: BodyMotion, bodies: Sequence[Body], pairs: Sequence[Pair], margin: float,
                 tolerance: float, rate: float, decide: bool, progress: Callable[[float], None] | None = None
                 ) -> None:
        self.motion, self.bodies, self.margin, self.tol, self.decide = motion, bodies, margin, tolerance, decide
        self.progress = progress
        self.pa = np.array([p[0] for p in pairs], dtype=np.int64)
        self.pb = np.array([p[1] for p in pairs], dtype=np.int64)
        self.skip = [p[2] for p in pairs]
        self.lev: Levers = levers(motion.robot, bodies)
        # the motion bounds are computed for the robot's bodies only; a fixed body reads the zero column after them
        sub = np.array([k for k, b in enumerate(bodies) if b.frame is not None], dtype=np.int64)
        self.col = np.full(len(bodies), sub.size, dtype=np.int64)
        self.col[sub] = np.arange(sub.size)
        lv = self.lev
        self.robot_lev = Levers(lv.lever[:, sub], lv.reach[sub], lv.platform[sub], tuple(lv.arm[k] for k in sub),
                                lv.rides[sub])
        self.store = Store(motion, bodies)
        knots = np.asarray(motion.knots, dtype=float)
        moving = moving_intervals(motion, knots, self.robot_lev)   # a hold stands as at its ends: sampled there
        span = float(np.sum((knots[1:] - knots[:-1])[moving]))
        rate = min(rate, BASE_MOST / span) if span > 0.0 else rate   # a move of 1e6 s: not a million instants
        base = np.unique(np.concatenate([knots, grid_within(knots[:-1][moving], knots[1:][moving], knots[-1], rate)]))
        # a motion of one instant (a program of one waypoint, no dwell: 0 s) had no interval, so no pair was measured
        # ('minimum inf mm', safe, with the blade 73 mm into a pedestal): that instant is an interval of no length
        self.base = self.store.add(np.repeat(base, 2) if base.shape[0] == 1 else base)
        self.exact = Exact(bodies, self.store)
        self.half = np.stack([b.half for b in bodies])
        self.radius = np.array([b.radius for b in bodies])
        self.sat = Table(1)
        # both carried by the platform: its motion does not change their distance, and their heights along its
        # normal stay (the arms turn about it): the gap between the height ranges bounds the distance throughout
        self.rigid = self.lev.platform[self.pa] & self.lev.platform[self.pb]
        self.static = ~self.lev.platform[self.pa] & ~self.lev.platform[self.pb]
        lo, hi = _heights(motion, bodies, self.lev.platform)
        self.gap = np.where(self.rigid, np.maximum(lo[self.pb] - hi[self.pa], lo[self.pa] - hi[self.pb]), -np.inf)

    def sphere(self, p: Ints, i: Ints) -> Array:
        """Bounding-sphere lower bounds of pairs ``p`` at instants ``i``."""
        a, b = self.pa[p], self.pb[p]
        ca, cb = self.store.poses(a, i, False)[1], self.store.poses(b, i, False)[1]
        return np.asarray(np.linalg.norm(ca - cb, axis=1) - self.radius[a] - self.radius[b], dtype=np.float64)

    def boxes(self, p: Ints, i: Ints) -> None:
        """Separating-axis lower bounds of pairs ``p`` at instants ``i``, memoised."""
        keys = key(p, i)
        _, found = self.sat.get(keys)
        p, i, keys = p[~found], i[~found], keys[~found]
        if not p.size:
            return
        a, b = self.pa[p], self.pb[p]
        (Ra, ca), (Rb, cb) = self.store.poses(a, i), self.store.poses(b, i)
        self.sat.put(keys, box_lower_bound(Ra, ca, self.half[a], Rb, cb, self.half[b])[:, None])

    def lower(self, p: Ints, i: Ints) -> tuple[Array, Ints]:
        """The best lower bound known of pairs ``p`` at instants ``i`` and its level: 2 exact, 1 boxes, 0 spheres."""
        d, exact = self.exact.values(p, i)
        box, boxed = self.sat.get(key(p, i))
        out = np.where(exact, d, np.where(boxed, box[:, 0], np.nan))
        rough = np.isnan(out)
        if rough.any():
            out[rough] = self.sphere(p[rough], i[rough])
        return out, np.where(exact, 2, np.where(boxed, 1, 0)).astype(np.int64)

    def run(self) -> ClearanceReport:
        """Every pair, in chunks of at most :data:`CHUNK_ITEMS` base intervals (the instants are shared)."""
        P, K = self.pa.shape[0], self.base.shape[0] - 1
        upper, floor, series = np.full(P, np.inf), np.full(P, np.inf), np.full(K, np.inf)
        present = np.zeros(P, dtype=bool)
        static_p, static_k = [], []
        step = max(1, CHUNK_ITEMS // max(K, 1))
        starts = range(0, P, step)
        for chunk, start in enumerate(starts):
            items, sp, sk = self._items(np.arange(start, min(P, start + step)))
            present[items.p] = True
            static_p.append(sp)
            static_k.append(sk)
            self._refine(items, upper, floor, series, self._share(chunk, len(starts)))
        certified = np.minimum(floor, upper)
        if static_p:
            sp, sk = np.concatenate(static_p), np.concatenate(static_k)
            np.minimum.at(series, sk, certified[sp])
        return self._report(certified, present, self.store.t(self.base), series)

    def _items(self, pairs: Ints) -> tuple[Intervals, Ints, Ints]:
        """The base intervals of ``pairs`` on which both bodies exist and no contact is intended; a pair of bodies
        that never move keeps one (one instant stands for all); also those pairs' other intervals."""
        b0, b1 = self.base[:-1], self.base[1:]
        t0, t1 = self.store.t(b0), self.store.t(b1)
        ip, ik = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)]
        for p in pairs.tolist():
            A, B = self.bodies[int(self.pa[p])], self.bodies[int(self.pb[p])]
            ok = _windows_mask(A.windows, t0, t1, True) & _windows_mask(B.windows, t0, t1, True) & \
                _windows_mask(self.skip[p], t0, t1, False)
            sel = np.flatnonzero(ok)
            ip.append(np.full(sel.size, p, dtype=np.int64))
            ik.append(sel.astype(np.int64))
        item_p, item_k = np.concatenate(ip), np.concatenate(ik)
        static = self.static[item_p]
        keep = ~static | np.r_[True, item_p[1:] != item_p[:-1]]
        sp, sk = item_p[static], item_k[static]
        item_p, item_k = item_p[keep], item_k[keep]
        return Intervals(item_p, b0[item_k], np.where(self.static[item_p], b0[item_k], b1[item_k]), item_k), sp, sk

    def _share(self, chunk: int, chunks: int) -> Callable[[float], None]:
        """The ``progress`` of the run for a chunk's own share ``f`` of its work: ``(chunk + f) / chunks``."""
        report = self.progress
        if report is None:
            return lambda f: None
        return lambda f: report(min(1.0, (chunk + f) / chunks))

    def _settled(self, items: Intervals, sel: NDArray[np.bool_]) -> float:
        """The work of the items ``sel``: each one's share of its base interval (1 for a base interval and for a pair
        that never moves)."""
        i0, i1, k = items.i0[sel], items.i1[sel], items.base[sel]
        whole = self.store.t(self.base[k + 1]) - self.store.t(self.base[k])
        part = (self.store.t(i1) - self.store.t(i0)) / np.where(whole > 0.0, whole, 1.0)
        return float(np.where((i1 == i0) | (whole <= 0.0), 1.0, part).sum())

    def _refine(self, items: Intervals, upper: Array, floor: Array, series: Array,
                progress: Callable[[float], None]) -> None:
        """The branch and bound of the module docstring on ``items``, lowering ``upper`` (the smallest distance
        measured per pair), ``floor`` (the smallest bound settled per pair) and ``series`` (per base interval);
        ``progress`` gets the share of ``items`` settled after each round."""
        if not items.p.size:
            progress(1.0)
            return
        total, settled = float(items.p.size), 0.0
        # a first exact distance per pair, where its spheres come closest
        lb0, lb1 = self.sphere(items.p, items.i0), self.sphere(items.p, items.i1)
        order = np.lexsort((np.minimum(lb0, lb1), items.p))
        sel = order[np.flatnonzero(np.r_[True, items.p[order][1:] != items.p[order][:-1]])]
        self.exact.measure(items.p[sel], np.where(lb0[sel] <= lb1[sel], items.i0[sel], items.i1[sel]),
                           self.pa, self.pb)
        self._motion(items)
        for _ in range(MAX_ROUNDS):
            (d0, l0), (d1, l1) = self.lower(items.p, items.i0), self.lower(items.p, items.i1)
            for d, lv in ((d0, l0), (d1, l1)):
                np.minimum.at(upper, items.p[lv == 2], d[lv == 2])
            bound = self._bound(items, d0, d1, (l0 == 2) & (l1 == 2))
            nothing = _proves_nothing(bound)
            tol = np.maximum(self.tol, RELATIVE * (np.minimum(np.abs(upper), 1e3) - NEAR))
            short = self.store.t(items.i1) - self.store.t(items.i0) <= MIN_INTERVAL
            # measuring: to the tolerance, and a pair measured at or above the margin on to the margin (a bound
            # within the tolerance below it had read as a collision: 1.999 mm for 2.049 measured)
            target = np.full(upper.shape, self.margin) if self.decide else \
                np.where(upper >= self.margin, np.maximum(upper - tol, self.margin), upper - tol)
            decided = (upper < self.margin) if self.decide else np.zeros(upper.shape, dtype=bool)
            done = (bound >= target[items.p]) | (short & (l0 == 2) & (l1 == 2)) | decided[items.p] | nothing
            np.minimum.at(floor, items.p[done], bound[done])
            np.minimum.at(series, items.base[done], bound[done])
            settled += self._settled(items, done)
            items, l0, l1 = items.take(~done), l0[~done], l1[~done]
            progress(settled / total)
            if not items.p.size or self.store.n > MAX_INSTANTS:
                break
            # ends known by their spheres get the separating-axis bound; the intervals it does not settle get
            # exact distances at both ends; intervals with exact ends are split
            rough = (l0 == 0) | (l1 == 0)
            if rough.any():
                r = items.take(rough)
                self.boxes(np.concatenate([r.p, r.p]), np.concatenate([r.i0, r.i1]))
                (e0, m0), (e1, m1) = self.lower(r.p, r.i0), self.lower(r.p, r.i1)
                rb = self._bound(r, e0, e1, (m0 == 2) & (m1 == 2))
                ok = (rb >= target[r.p]) | _proves_nothing(rb)
                np.minimum.at(floor, r.p[ok], rb[ok])
                np.minimum.at(series, r.base[ok], rb[ok])
                settled += self._settled(r, ok)
                keep = np.ones(items.p.shape, dtype=bool)
                keep[np.flatnonzero(rough)[ok]] = False
                items, l0, l1 = items.take(keep), l0[keep], l1[keep]
            measure = (l0 < 2) | (l1 < 2)
            if measure.any():
                m = items.take(measure)
                self.exact.measure(np.concatenate([m.p, m.p]), np.concatenate([m.i0, m.i1]), self.pa, self.pb)
            if (~measure).any():
                items = self._split(items, ~measure)
        if items.p.size:   # out of rounds or instants: what is left keeps its bound (a lower bound still)
            (d0, l0), (d1, l1) = self.lower(items.p, items.i0), self.lower(items.p, items.i1)
            bound = self._bound(items, d0, d1, (l0 == 2) & (l1 == 2))
            _proves_nothing(bound)
            np.minimum.at(floor, items.p, bound)
            np.minimum.at(series, items.base, bound)
        progress(1.0)

    def _split(self, items: Intervals, split: NDArray[np.bool_]) -> Intervals:
        """Split the intervals ``split`` at their midpoints (one new instant per distinct interval)."""
        s = items.take(split)
        uniq, first, inv = np.unique(key(s.i0, s.i1), return_index=True, return_inverse=True)
        mid = self.store.add(0.5 * (self.store.t(s.i0[first]) + self.store.t(s.i1[first])))[inv.ravel()]
        left, right = Intervals(s.p, s.i0, mid, s.base), Intervals(s.p, mid, s.i1, s.base)
        self._motion(left)
        self._motion(right)
        return items.take(~split).join(left).join(right)

    def _motion(self, items: Intervals) -> None:
        """The pair's motion bounds on each interval (the motion's ``bounds``): ``mu``, ``eps``, ``delta``."""
        _, first, inv = np.unique(key(items.i0, items.i1), return_index=True, return_inverse=True)
        inv = inv.ravel()
        data = self.store.data
        ends = (items.i0[first], items.i1[first])
        mb = self.motion.bounds(self.store.t(ends[0]), self.store.t(ends[1]), self.robot_lev,
                                np.stack([data['sigma'][e] for e in ends], axis=1),
                                np.stack([data['gamma'][e] for e in ends], axis=1),
                                np.stack([data['disp'][e] for e in ends], axis=1))
        a, b = self.col[self.pa[items.p]], self.col[self.pb[items.p]]
        arm, plat = (np.pad(x, ((0, 0), (0, 1))) for x in (mb.arm, mb.platform))
        shift = np.pad(mb.shift, ((0, 0), (0, 1), (0, 0)))
        items.eps = np.where(self.rigid[items.p], 0.0, plat[inv, a] + plat[inv, b])
        items.mu = arm[inv, a] + arm[inv, b] + items.eps
        items.delta = shift[inv, a] - shift[inv, b]

    def _bound(self, items: Intervals, d0: Array, d1: Array, exact: NDArray[np.bool_]) -> Array:
        """The certificate of every interval (module docstring)."""
        bound = np.maximum(np.minimum(np.minimum(d0, d1), 0.5 * (d0 + d1 - items.mu)), self.gap[items.p])
        cvx = exact & np.all(np.isfinite(items.delta), axis=1) & (d0 > 0.0) & (d1 > 0.0)
        if cvx.any():
            c = items.take(cvx)
            bound[cvx] = np.maximum(bound[cvx], self._convex(c.p, c.i0, c.i1, d0[cvx], d1[cvx], c.delta) - c.eps)
        return bound

    def _convex(self, p: Ints, i0: Ints, i1: Ints, d0: Array, d1: Array, delta: Array) -> Array:
        """Tangent lower bound of a convex ``d(tau)`` on [0, 1] from the ends' values and slopes, less the slopes'
        error: a direction from nearest points ``w`` off the true ones is ``2 w / d`` off the unit normal
        (:meth:`~gpr_kinematics.safety.distances.Exact.gap_error`: the library's tolerance, or the refinement's)."""
        ga, gb = self.exact.gap(p, i0), self.exact.gap(p, i1)
        g0 = np.einsum('ki,ki->k', delta, ga) / np.linalg.norm(ga, axis=1)
        g1 = np.einsum('ki,ki->k', delta, gb) / np.linalg.norm(gb, axis=1)
        w = np.maximum(self.exact.gap_error(p, i0), self.exact.gap_error(p, i1))
        err = np.linalg.norm(delta, axis=1) * 2.0 * w / np.minimum(d0, d1)
        with np.errstate(invalid='ignore', divide='ignore'):
            tau = np.clip((d1 - g1 - d0) / (g0 - g1), 0.0, 1.0)
        low = np.where(g0 >= 0.0, d0, np.where(g1 <= 0.0, d1, d0 + g0 * tau))
        return np.asarray(low - err, dtype=np.float64)

    def _report(self, certified: Array, present: NDArray[np.bool_], base_t: Array, series: Array) -> ClearanceReport:
        results = []
        t = self.store.data['t']
        keys, vals = self.exact.memo.keys, self.exact.memo.vals[:, 0]
        kp, ki = keys >> 32, keys & ((1 << 32) - 1)
        best: dict[int, tuple[float, int]] = {}
        order = np.lexsort((vals, kp))
        for n in order[np.flatnonzero(np.r_[True, kp[order][1:] != kp[order][:-1]])] if keys.size else []:
            best[int(kp[n])] = (float(vals[n]), int(ki[n]))
        low = vals + LIBRARY_SLACK < self.margin   # the slack is the certificate's, not a measurement below
        below = first_below(self, kp[low], ki[low], not self.decide)
        for p in np.flatnonzero(present):
            A, B = self.bodies[int(self.pa[p])], self.bodies[int(self.pb[p])]
            d, i = best[int(p)]
            results.append(PairClearance((A.name, B.name), float(certified[p]), float(t[i]),
                                         below.get(int(p), float('nan')), float(d)))
        results.sort(key=lambda r: r.distance)
        lowest = results[0].distance if results else float('inf')
        return ClearanceReport(tuple(results), float(lowest), float(self.margin), float(self.tol), self.exact.calls,
                               self.store.n, (base_t, series))


def _proves_nothing(bound: Array) -> NDArray[np.bool_]:
    """The certificates of ``bound`` that are no number (a motion bound of NaN: inf x 0 of a rate bound and a zero
    lever), set to -inf in place: below any margin, settled, not split (compared with the margin, a NaN read as
    safe; split, it never settled and the search grew to 18 GB)."""
    nothing = np.isnan(bound)
    bound[nothing] = -np.inf
    return nothing


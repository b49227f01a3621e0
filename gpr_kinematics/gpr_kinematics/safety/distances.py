"""The instants of a clearance search and the collision library's distances at them (docs/cell.md, "The
certificate"): :class:`Store` keeps every body's world pose at a growing set of instants, :class:`Exact` the library's
signed distance and nearest points of pairs at instants (FCL through python-fcl, memoised), :class:`Table` the
memo (integer keys looked up in bulk).

**The library's distance is not exact.** FCL's GJK stops early with a cylinder (a wafer-sized disc 2 mm from a box
read up to 1.14 mm too far) and between boxes whose faces are nearly parallel (0.6 mm too far at 0.26 mm). For every
pair at a positive distance the library's nearest points only start :func:`refine` (:func:`certify`): exact
projections onto the two bodies (the nearest point of a box or of a solid cylinder in closed form) bring a point
pair ``p`` on ``a``, ``q = P_b(p)`` on ``b`` towards the nearest one. Every second round is extrapolated: from the
plain round's ``p1 = P_a(q)``, ``p' = P_a(p + s (p1 - p))`` is kept where ``(p' - P_b(p')) . (p' - p1) <= 0`` (to
rounding), i.e. ``|P_b(x) - x|``, convex along the segment, still falls at ``p'``, so ``p'`` is no worse than ``p1``;
``s`` then doubles, else it is quartered (at least 2): a box or a disc beside a nearly parallel face travels along it
in tens of rounds instead of thousands. For the unit direction ``n`` of ``q - p`` the gap between the bodies'
extents along ``n``,

    ``n . (c_b - c_a) - h_a(n) - h_b(n)``,   ``h(n) = sum_i e_i |R_i . n|`` (box, half-edges ``e_i``),
    ``h(n) = l |a . n| + r sqrt(1 - (a . n)^2)`` (cylinder, radius ``r``, half-length ``l``, axis ``a``),

is at most the signed distance whatever ``n`` (weak duality; the separating-axis argument), while ``|q - p|`` is at
least the distance; the distance kept is the best such lower bound, over ``n`` and ``n`` without its components
along the directions where ``h`` is kinked at the nearest features (a box's axes along which ``p`` is not clipped, a
cylinder's face plane or its axis on its side: there ``n`` is exact once the features are), and the two bounds agree
to 1e-10 m once converged.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError
from .bodies import Body, box_lower_bound
from .motion import BodyMotion

Array = NDArray[np.float64]
Ints = NDArray[np.int64]

#: Subtracted from every distance kept [m] (once the library's GJK tolerance; the refined bound below needs none,
#: and keeps it as a margin), and the nearest points' error of a pair not refined is twice it.
LIBRARY_SLACK = 1e-6
#: Projection rounds of :func:`refine`: at most this many, the bounds compared after the first and every :data:`CHECK`
#: rounds, stopped once the upper and lower bounds of every pair agree to :data:`REFINED` [m] or their gap did not
#: halve in :data:`STALL` rounds (the rounding of nearly parallel faces 1e-8 rad apart); the extrapolation factor at
#: most :data:`STRETCH`.
ROUNDS = 2000
REFINED = 1e-10
CHECK = 4
STRETCH = 2.0 ** 40
STALL = 100
EPS = float(np.finfo(np.float64).eps)


def _fcl() -> Any:
    import fcl  # the optional 'safety' extra (cli.main names it when missing)

    return fcl


def require_library(what: str) -> None:
    """Raise :class:`~gpr_kinematics.errors.ConfigError` naming ``what`` needs python-fcl when it is missing."""
    try:
        _fcl()
    except ImportError:
        raise ConfigError(f"{what} needs python-fcl, the collision library: pip install 'gpr_kinematics[safety]'") \
            from None


class Store:
    """Poses and platform data at a growing set of instants (arrays grown by doubling)."""

    def __init__(self, motion: BodyMotion, bodies: Sequence[Body]) -> None:
        self.motion, self.bodies, self.n = motion, bodies, 0
        self.data: dict[str, Array] = {}
        self.moving = [k for k, b in enumerate(bodies) if b.frame is not None]
        self.fixed_R = np.stack([b.rotation for b in bodies]) if bodies else np.zeros((0, 3, 3))
        self.fixed_c = np.stack([b.position for b in bodies]) if bodies else np.zeros((0, 3))

    def add(self, t: Array) -> Ints:
        snap = self.motion.snapshot(t)
        new = {'t': t, 'sigma': snap.sigma, 'gamma': snap.gamma, 'disp': snap.displacement}
        for n, b in enumerate(self.bodies):
            if b.frame is None:
                continue
            p, R = snap.frames[b.frame]
            new[f'R{n}'], new[f'c{n}'] = R @ b.rotation, p + R @ b.position
        start, m = self.n, t.shape[0]
        if not self.data or start + m > self.data['t'].shape[0]:
            cap = max(2 * start, start + m, 256)
            self.data = {k: np.concatenate([self.data[k][:start], np.zeros((cap - start,) + v.shape[1:])])
                         if self.data else np.zeros((cap,) + v.shape[1:]) for k, v in new.items()}
        for k, v in new.items():
            self.data[k][start:start + m] = v
        self.n = start + m
        return np.arange(start, start + m)

    def t(self, idx: Ints) -> Array:
        return self.data['t'][idx]

    def pose(self, k: int, idx: Ints) -> tuple[Array, Array]:
        """World rotations ``(n, 3, 3)`` and centres ``(n, 3)`` of body ``k`` at instants ``idx``."""
        b = self.bodies[k]
        if b.frame is None:
            return np.broadcast_to(b.rotation, (idx.shape[0], 3, 3)), np.broadcast_to(b.position, (idx.shape[0], 3))
        return self.data[f'R{k}'][idx], self.data[f'c{k}'][idx]

    def poses(self, body: Ints, idx: Ints, rotations: bool = True) -> tuple[Array, Array]:
        """World rotations ``(n, 3, 3)`` (if asked; else empty) and centres ``(n, 3)`` of bodies ``body`` at instants
        ``idx``: fixed bodies by indexing, each moving body by one mask."""
        R = self.fixed_R[body] if rotations else np.zeros((0, 3, 3))
        c = self.fixed_c[body]
        for k in self.moving:
            sel = body == k
            if sel.any():
                c[sel] = self.data[f'c{k}'][idx[sel]]
                if rotations:
                    R[sel] = self.data[f'R{k}'][idx[sel]]
        return R, c


class Table:
    """Rows of values ``(n, w)`` under integer keys, looked up in bulk (sorted keys, binary search)."""

    def __init__(self, width: int) -> None:
        self.keys, self.vals = np.zeros(0, dtype=np.int64), np.zeros((0, width))

    def get(self, keys: Ints) -> tuple[Array, NDArray[np.bool_]]:
        pos = np.minimum(np.searchsorted(self.keys, keys), max(self.keys.shape[0] - 1, 0))
        found = (self.keys[pos] == keys) if self.keys.size else np.zeros(keys.shape, dtype=bool)
        out = np.full((keys.shape[0], self.vals.shape[1]), np.nan)
        out[found] = self.vals[pos[found]]
        return out, found

    def put(self, keys: Ints, vals: Array) -> None:
        """Add rows under keys not present yet."""
        keys, first = np.unique(keys, return_index=True)
        pos = np.searchsorted(self.keys, keys)
        self.keys, self.vals = np.insert(self.keys, pos, keys), np.insert(self.vals, pos, vals[first], axis=0)


def key(p: Ints, i: Ints) -> Ints:
    """One integer per (pair, instant)."""
    return np.asarray(p, dtype=np.int64) * (1 << 32) + np.asarray(i, dtype=np.int64)


def _local(R: Array, v: Array) -> Array:
    """``R^T v`` row by row: ``v (n, 3)`` in the bodies' axes ``R (n, 3, 3)``."""
    return np.asarray(np.einsum('nji,nj->ni', R, v), dtype=np.float64)


def nearest_point(x: Array, R: Array, c: Array, half: Array, cylinder: NDArray[np.bool_]) -> Array:
    """The nearest point to ``x (n, 3)`` of each body (rotation ``R``, centre ``c``, :attr:`Body.half` ``half``): a
    box clips each local coordinate to its half-edge; a solid cylinder (the product of a disc and a segment) clips
    the radial part to the radius and the axial one to the half-length [m]."""
    loc = _local(R, x - c)
    box = np.clip(loc, -half, half)
    rho = np.hypot(loc[:, 0], loc[:, 1])
    scale = np.where(rho > half[:, 0], half[:, 0] / np.where(rho > 0.0, rho, 1.0), 1.0)
    disc = np.stack([loc[:, 0] * scale, loc[:, 1] * scale, box[:, 2]], axis=1)
    out = np.where(cylinder[:, None], disc, box)
    return c + np.asarray(np.einsum('nij,nj->ni', R, out), dtype=np.float64)


def extent(n: Array, R: Array, half: Array, cylinder: NDArray[np.bool_]) -> Array:
    """The half-width ``h(n)`` of each body along the unit direction ``n (n, 3)`` (module docstring) [m]."""
    a = np.abs(_local(R, n))
    box = np.sum(half * a, axis=1)
    cyl = half[:, 2] * a[:, 2] + half[:, 0] * np.hypot(a[:, 0], a[:, 1])
    return np.asarray(np.where(cylinder, cyl, box), dtype=np.float64)


def axis_gap(n: Array, a: tuple[Array, Array, Array, NDArray[np.bool_]],
             b: tuple[Array, Array, Array, NDArray[np.bool_]]) -> Array:
    """The gap between bodies ``a`` and ``b`` (each ``(R, c, half, cylinder)``) along the unit direction ``n`` from
    ``a`` to ``b``: a lower bound of their signed distance for every ``n`` [m]."""
    Ra, ca, ha, cya = a
    Rb, cb, hb, cyb = b
    return np.asarray(np.einsum('ni,ni->n', n, cb - ca) - extent(n, Ra, ha, cya) - extent(n, Rb, hb, cyb),
                      dtype=np.float64)


Pose = tuple[Array, Array, Array, NDArray[np.bool_]]


def contact_bound(a: Pose, b: Pose) -> Array:
    """A lower bound of the signed distance of bodies ``a`` and ``b`` in contact (the library's EPA is never asked:
    it aborted the process on touching bodies): the best :func:`axis_gap`
    along the line of centres and each body's axes, both ways (two boxes: the separating-axis test's 15 axes too,
    which give minus their penetration depth exactly). Bodies that touch along a face (a blade's paddle flat under a
    wafer) reach 0 on its normal [m]."""
    Ra, ca, ha, cya = a
    Rb, cb, hb, cyb = b
    d = cb - ca
    norm = np.linalg.norm(d, axis=1)
    line = np.where((norm > 0.0)[:, None], d / np.where(norm > 0.0, norm, 1.0)[:, None], np.array([1.0, 0.0, 0.0]))
    best = axis_gap(line, a, b)
    for n in [Ra[:, :, k] for k in range(3)] + [Rb[:, :, k] for k in range(3)]:
        best = np.maximum(best, np.maximum(axis_gap(n, a, b), axis_gap(-n, a, b)))
    boxes = ~(cya | cyb)
    if boxes.any():
        best[boxes] = np.maximum(best[boxes], box_lower_bound(Ra[boxes], ca[boxes], ha[boxes], Rb[boxes], cb[boxes],
                                                              hb[boxes]))
    return np.asarray(best, dtype=np.float64)


def _rows(body: Pose, keep: NDArray[np.bool_]) -> Pose:
    return body[0][keep], body[1][keep], body[2][keep], body[3][keep]


def _twice(body: Pose) -> Pose:
    return (np.concatenate([body[0], body[0]]), np.concatenate([body[1], body[1]]),
            np.concatenate([body[2], body[2]]), np.concatenate([body[3], body[3]]))


def _kinked(x: Array, body: Pose) -> NDArray[np.bool_]:
    """The body's axes ``(n, 3)`` along which its support function is kinked at its point nearest to ``x`` (outside
    it): a box's axes along which the point is not clipped; a cylinder's x and y on its face, z on its side."""
    R, c, half, cylinder = body
    loc = _local(R, x - c)
    face = np.hypot(loc[:, 0], loc[:, 1]) < half[:, 0]
    cyl = np.stack([face, face, np.abs(loc[:, 2]) < half[:, 2]], axis=1)
    return np.asarray(np.where(cylinder[:, None], cyl, np.abs(loc) < half), dtype=np.bool_)


def _without(n: Array, R: Array, axes: NDArray[np.bool_]) -> Array:
    """``n (n, 3)`` less its components along the body axes ``axes`` (columns of ``R``)."""
    return np.asarray(np.einsum('nij,nj->ni', R, _local(R, n) * ~axes), dtype=np.float64)


def _snapped_gap(n: Array, gap: Array, p: Array, q: Array, a: Pose, b: Pose) -> Array:
    """The best of ``gap`` and the gaps along ``n`` without its components along the kinked axes
    (:func:`_kinked`) of ``a``'s feature nearest to ``q``, of ``b``'s nearest to ``p``, and of both (alternately
    removed) [m]."""
    ka, kb = _kinked(q, a), _kinked(p, b)
    both = n
    for _ in range(4):
        both = _without(_without(both, a[0], ka), b[0], kb)
    for d in (_without(n, a[0], ka), _without(n, b[0], kb), both):
        norm = np.linalg.norm(d, axis=1)
        ok = norm > 1e-3
        gap = np.where(ok, np.maximum(gap, axis_gap(d / np.where(ok, norm, 1.0)[:, None], a, b)), gap)
    return gap


def refine(p: Array, q: Array, a: Pose, b: Pose, known: Array | None = None, rounds: Ints | None = None
           ) -> tuple[Array, Array, Array, Array]:
    """From points ``p`` near body ``a`` and ``q`` near ``b``, the lower bound of the pair's signed distance and the
    nearest points found, by extrapolated projections (module docstring); also how far ``q - p`` may be from the
    nearest points' difference [m]: ``sqrt(2 u e + e^2)`` with ``u = |q - p|`` and ``e`` the gap between the upper
    and the lower bound (for the minimum-norm ``v*`` of the convex set ``B - A``, ``|v - v*|^2 <= |v|^2 -
    |v*|^2``). ``known``: lower bounds known already (the separating-axis test of two boxes). ``rounds``: if given,
    set to the rounds each pair took."""
    start = q - p
    active = np.arange(p.shape[0])
    sa, sb, sb2 = a, b, _twice(b)      # the rows still refined (selected again only when they shrink)
    x = nearest_point(q, *sa)          # on a
    y = nearest_point(x, *sb)          # on b, the nearest to x
    s = np.full(p.shape[0], 2.0)
    best = np.full(p.shape[0], -np.inf)
    floor = np.full(p.shape[0], -np.inf) if known is None else known.copy()
    mark = np.full(p.shape[0], np.inf)   # the bounds' gap at the last look for a stall
    for k in range(ROUNDS):
        g = nearest_point(y, *sa)
        if k % 2 == 0:                 # a plain round (it damps what the extrapolation stirred up)
            x, y = g, nearest_point(g, *sb)
        else:                          # the plain round and the extrapolated one, the better kept
            c = nearest_point(x + s[:, None] * (g - x), *sa)
            m = x.shape[0]
            yy = nearest_point(np.concatenate([g, c]), *sb2)
            step, down = c - g, c - yy[m:]   # kept where |P_b(x) - x| still falls at c along the step (to rounding)
            round_off = 8.0 * EPS * np.linalg.norm(c, axis=1) * (np.linalg.norm(down, axis=1) +
                                                                 np.linalg.norm(step, axis=1))
            take = np.einsum('ni,ni->n', down, step) <= round_off
            x, y = np.where(take[:, None], c, g), np.where(take[:, None], yy[m:], yy[:m])
            s = np.where(take, np.minimum(2.0 * s, STRETCH), np.maximum(0.25 * s, 2.0))
        if k % CHECK == CHECK - 1 or k == 0 or k == ROUNDS - 1:   # many pairs are done after one round
            p[active], q[active] = x, y
            if rounds is not None:
                rounds[active] = k + 1
            v = y - x
            u = np.linalg.norm(v, axis=1)
            n = v / np.where(u > 0.0, u, 1.0)[:, None]
            gap = axis_gap(n, sa, sb)
            more = (u > REFINED) & (u - np.maximum(gap, floor) > REFINED)
            if more.any():
                gap[more] = _snapped_gap(n[more], gap[more], x[more], y[more], _rows(sa, more), _rows(sb, more))
                more &= u - np.maximum(gap, floor) > REFINED
            best[active] = gap
            if k % STALL == STALL - 1:   # stalled (not even halved in STALL rounds): rounding, nothing to gain
                more &= u - np.maximum(gap, floor) < 0.5 * mark
                mark = u - np.maximum(gap, floor)
            if not more.any():
                break
            if not more.all():
                active, x, y, s, floor, mark = active[more], x[more], y[more], s[more], floor[more], mark[more]
                sa, sb = _rows(sa, more), _rows(sb, more)
                sb2 = _twice(sb)
    v = q - p
    u = np.linalg.norm(v, axis=1)
    # the refined direction's gap is in ``best`` (set with ``p``, ``q`` at each pair's last look): the better of it
    # and the library's direction's
    norm = np.linalg.norm(start, axis=1)
    ok = norm > 0.0
    low = np.where(ok, np.maximum(best, axis_gap(start / np.where(ok, norm, 1.0)[:, None], a, b)), best)
    low = np.where(np.isfinite(low), low, 0.0)    # touching at a point: a distance of at most 0
    if known is not None:
        low = np.maximum(low, known)
    e = np.maximum(u - low, 0.0)
    return low, p, q, np.sqrt(2.0 * u * e + e * e)


def certify(p: Array, q: Array, a: Pose, b: Pose, rounds: Ints | None = None) -> tuple[Array, Array, Array, Array]:
    """:func:`refine` from the library's nearest points ``p``, ``q`` (not changed) of bodies ``a`` and ``b`` (each
    ``(R, c, half, cylinder)``), with the separating-axis bound of two boxes as a known lower bound."""
    (Ra, ca, ha, cya), (Rb, cb, hb, cyb) = a, b
    known = np.where(cya | cyb, -np.inf, box_lower_bound(Ra, ca, ha, Rb, cb, hb))
    return refine(p.copy(), q.copy(), a, b, known, rounds)


class Exact:
    """The library's signed distance and nearest points of pairs at instants (memoised), refined to a certified
    lower bound where positive (module docstring)."""

    def __init__(self, bodies: Sequence[Body], store: Store) -> None:
        fcl = _fcl()
        self.fcl, self.store, self.bodies = fcl, store, bodies
        self.objects = [fcl.CollisionObject(fcl.Box(*b.size) if b.kind == 'box' else fcl.Cylinder(*b.size),
                                            fcl.Transform(b.rotation, b.position)) for b in bodies]
        # GJK alone (the same distance and points as the signed request for bodies apart, -1 in contact), never the
        # signed request's EPA: on a touching pair (the paddle flat under a station's wafer, approach_height 0)
        # libccd's EPA throws a C++ exception that aborts the process; bodies in contact read contact_bound
        self.request = fcl.DistanceRequest(enable_nearest_points=True, enable_signed_distance=False)
        self.calls = 0
        self.memo = Table(5)   # distance less the slack, then p_a - p_b, then the error of p_a - p_b
        self.cylinder = np.array([b.kind == 'cylinder' for b in bodies], dtype=bool)
        self.half = np.stack([b.half for b in bodies]) if bodies else np.zeros((0, 3))

    def measure(self, p: Ints, i: Ints, pa: Ints, pb: Ints) -> None:
        """Measure pairs ``p`` (bodies ``pa[p]``, ``pb[p]``) at instants ``i`` not measured yet."""
        keys = key(p, i)
        _, found = self.memo.get(keys)
        keys, first = np.unique(keys[~found], return_index=True)
        if not keys.size:
            return
        p, i = p[~found][first], i[~found][first]
        a, b = pa[p], pb[p]
        order = np.lexsort((a, i))
        p, i, a, b, keys = p[order], i[order], a[order], b[order], keys[order]
        poses: dict[int, tuple[Array, Array]] = {}
        for k in np.unique(np.concatenate([a, b])):
            if self.bodies[int(k)].frame is not None:
                poses[int(k)] = (self.store.data[f'R{k}'], self.store.data[f'c{k}'])
        out = np.empty((keys.shape[0], 5))
        near = np.empty((keys.shape[0], 2, 3))
        fcl, objects, request = self.fcl, self.objects, self.request
        placed: dict[int, int] = {}
        for n, (ii, ka, kb) in enumerate(zip(i.tolist(), a.tolist(), b.tolist(), strict=True)):
            for k in (ka, kb):
                if k in poses and placed.get(k) != ii:   # each moving body placed once per instant
                    R, c = poses[k]
                    objects[k].setRotation(R[ii])
                    objects[k].setTranslation(c[ii])
                    placed[k] = ii
            res = fcl.DistanceResult()
            out[n, 0] = fcl.distance(objects[ka], objects[kb], request, res)
            if out[n, 0] <= 0.0:   # in contact: the best separating-axis gap (minus the depth for two boxes)
                touch = float(contact_bound(self._pose(ka, ii, poses), self._pose(kb, ii, poses))[0])
                out[n, 0], near[n] = min(touch, 0.0), 0.0
                continue
            near[n] = res.nearest_points
        out[:, 1:4] = near[:, 0] - near[:, 1]
        out[:, 4] = 2.0 * LIBRARY_SLACK
        apart = out[:, 0] > 0.0
        if apart.any():   # FCL's distance is not exact (cylinders; boxes with nearly parallel faces): a lower bound
            sa, sb = self.store.poses(a[apart], i[apart]), self.store.poses(b[apart], i[apart])
            A = (*sa, self.half[a[apart]], self.cylinder[a[apart]])
            B = (*sb, self.half[b[apart]], self.cylinder[b[apart]])
            low, on_a, on_b, err = certify(near[apart, 0], near[apart, 1], A, B)
            # Apart by the library yet bounded below 0: its nearest points (nearly) coincide, bodies touching along a
            # face (a blade flat under a wafer: 1.4e-15 m apart read -14 mm), and the bound along their direction is
            # noise; the separating axes bound it too (0 on the face's normal): the better of the two lower bounds.
            k = np.flatnonzero(low < 0.0)
            if k.size:
                axes = contact_bound((A[0][k], A[1][k], A[2][k], A[3][k]), (B[0][k], B[1][k], B[2][k], B[3][k]))
                low[k] = np.maximum(low[k], axes)
            out[apart, 0], out[apart, 1:4], out[apart, 4] = low, on_a - on_b, err
        out[:, 0] -= LIBRARY_SLACK
        self.memo.put(keys, out)
        self.calls += keys.shape[0]

    def _pose(self, k: int, ii: int, poses: dict[int, tuple[Array, Array]]) -> Pose:
        """Body ``k`` at instant ``ii`` as a :data:`Pose` of one row."""
        R, c = (poses[k][0][ii], poses[k][1][ii]) if k in poses else (self.bodies[k].rotation, self.bodies[k].position)
        return R[None], c[None], self.half[k][None], self.cylinder[k:k + 1]

    def values(self, p: Ints, i: Ints) -> tuple[Array, NDArray[np.bool_]]:
        """Known distances (NaN where not measured) and whether they are known."""
        v, found = self.memo.get(key(p, i))
        return v[:, 0], found

    def gap(self, p: Ints, i: Ints) -> Array:
        """``p_a - p_b`` (nearest points) of measured pairs ``(n, 3)``."""
        return self.memo.get(key(p, i))[0][:, 1:4]

    def gap_error(self, p: Ints, i: Ints) -> Array:
        """How far :meth:`gap` may be from the true nearest points' difference ``(n,)`` [m]."""
        return self.memo.get(key(p, i))[0][:, 4]

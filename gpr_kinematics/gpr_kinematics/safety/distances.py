"""The instants of a clearance search and the collision library's distances at them (docs/cell.md, "The
certificate"): :class:`Store` keeps every body's world pose at a growing set of instants, :class:`Exact` the library's
signed distance and nearest points of pairs at instants (FCL through python-fcl, memoised), :class:`Table` the
memo (integer keys looked up in bulk).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .bodies import Body
from .motion import PlanMotion

Array = NDArray[np.float64]
Ints = NDArray[np.int64]

#: What the library's distance may exceed the true one by (its GJK tolerance) [m]: subtracted from every distance.
LIBRARY_SLACK = 1e-6


def _fcl() -> Any:
    import fcl  # the optional 'safety' extra (cli.main names it when missing)

    return fcl


class Store:
    """Poses and platform data at a growing set of instants (arrays grown by doubling)."""

    def __init__(self, motion: PlanMotion, bodies: Sequence[Body]) -> None:
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


class Exact:
    """The library's signed distance and nearest points of pairs at instants (memoised)."""

    def __init__(self, bodies: Sequence[Body], store: Store) -> None:
        fcl = _fcl()
        self.fcl, self.store, self.bodies = fcl, store, bodies
        self.objects = [fcl.CollisionObject(fcl.Box(*b.size) if b.kind == 'box' else fcl.Cylinder(*b.size),
                                            fcl.Transform(b.rotation, b.position)) for b in bodies]
        self.request = fcl.DistanceRequest(enable_nearest_points=True, enable_signed_distance=True)
        self.calls = 0
        self.memo = Table(4)   # distance less the slack, then p_a - p_b

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
        out = np.empty((keys.shape[0], 4))
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
            out[n, 1:] = res.nearest_points[0] - res.nearest_points[1]
        out[:, 0] -= LIBRARY_SLACK
        self.memo.put(keys, out)
        self.calls += keys.shape[0]

    def values(self, p: Ints, i: Ints) -> tuple[Array, NDArray[np.bool_]]:
        """Known distances (NaN where not measured) and whether they are known."""
        v, found = self.memo.get(key(p, i))
        return v[:, 0], found

    def gap(self, p: Ints, i: Ints) -> Array:
        """``p_a - p_b`` (nearest points) of measured pairs ``(n, 3)``."""
        return self.memo.get(key(p, i))[0][:, 1:]

"""Certified clearance: the smallest distance of every pair of bodies over a whole motion, no collision hidden
between samples (docs/cell.md, "The certificate").

For a pair ``(a, b)`` and a time interval ``[t0, t1]`` on which every point of ``a`` moves by at most ``mu_a`` and
of ``b`` by at most ``mu_b`` (:mod:`~gpr_kinematics.safety.motion`: total variations of the joints times lever
arms), the distance at any ``t`` inside is at least ``d(t0) - mu(t0, t)`` and at least ``d(t1) - mu(t, t1)``, with
``mu(t0, t) + mu(t, t1) <= mu = mu_a + mu_b``; hence

    ``min_[t0, t1] d >= min(d0, d1, (d0 + d1 - mu) / 2)``

with ``d0``, ``d1`` any lower bounds of the distances at the ends (the exact distance of the collision library,
less :data:`LIBRARY_SLACK`, or the distance of the bodies' bounding spheres). Branch and bound over time: an interval
whose bound lies below the pair's best distance found so far less ``tolerance`` is split at its midpoint (a new
instant, exact poses), until every interval's bound is within ``tolerance`` of the best. The reported distance is
the smallest bound: never above the true minimum, and at most ``tolerance`` below it. Distances come from FCL
(python-fcl: boxes and cylinders as exact primitives, GJK/EPA; negative: penetration depth).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.rotations import rpy_matrix
from ..errors import InputError
from ..robot.collision import Shape
from ..robot.description import RobotDescription
from .cell import Cell
from .motion import Motion, frame_poses, lever_arms, platform_gains, robot_bodies, shape_pose

Array = NDArray[np.float64]

#: Default margin [m] below which a pair counts as a collision, and the accuracy of each pair's minimum [m].
MARGIN = 0.002
TOLERANCE = 5e-5
#: What the library's distance may exceed the true one by (GJK's tolerance) [m]: subtracted from every distance.
LIBRARY_SLACK = 1e-6
#: Base sampling of the motion [Hz] before refinement; the shortest interval refined [s]; most bisection rounds.
BASE_RATE = 20.0
MIN_INTERVAL = 1e-7
MAX_ROUNDS = 60


@dataclass(frozen=True)
class Body:
    """A body to check: a robot shape (moving with its frame) or a fixed one (an obstacle, a wafer in a station),
    and the time windows ``[(t0, t1), ...]`` during which it exists (empty: always)."""

    name: str
    kind: str
    size: tuple[float, ...]
    frame: str | None            # None: fixed at ``pose``
    rotation: Array
    position: Array
    windows: tuple[tuple[float, float], ...] = ()
    arm: str | None = None

    @property
    def radius(self) -> float:
        return Shape('', self.kind, self.size).radius


@dataclass(frozen=True)
class PairClearance:
    """The certified smallest distance of a pair over the motion [m] (negative: penetration) and when the closest
    sampled instant occurs [s]; ``first_below`` the first instant found below the margin (NaN: none)."""

    bodies: tuple[str, str]
    distance: float
    time: float
    first_below: float = float('nan')


@dataclass(frozen=True)
class ClearanceReport:
    """Every checked pair, closest first; ``min_clearance`` the smallest distance [m]; ``margin``, ``tolerance``
    [m]; ``evaluations``: distance calls made; ``instants``: distinct times at which poses were computed."""

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


def _fcl() -> Any:
    import fcl  # the optional 'safety' extra (cli.main names it when missing)

    return fcl


def robot_body_set(robot: RobotDescription, wafer_windows: dict[str, tuple[tuple[float, float], ...]] | None = None
                   ) -> tuple[list[Body], tuple[Shape, ...]]:
    """The robot's bodies; an arm's wafer exists only in ``wafer_windows[arm]`` (absent: never carried)."""
    shapes = robot_bodies(robot)
    out = []
    windows = wafer_windows or {}
    for sh in shapes:
        R, c = shape_pose(sh)
        arm = next((a.name for a in robot.arms if sh.frame.startswith(a.name + '_')), None)
        is_wafer = arm is not None and sh.frame == f'{arm}_wafer'
        w = windows.get(arm, ()) if is_wafer and arm is not None else ()
        if is_wafer and not w:
            w = ((np.inf, np.inf),)   # never: an empty window
        out.append(Body(sh.frame, sh.kind, sh.size, sh.frame, R, c, w, arm))
    return out, shapes


def cell_bodies(cell: Cell | None) -> list[Body]:
    return [] if cell is None else [Body(o.name, o.kind, o.size, None, o.rotation, o.position) for o in cell.obstacles]


def default_pairs(bodies: Sequence[Body]) -> list[tuple[int, int, tuple[tuple[float, float], ...]]]:
    """Pairs checked: every robot body against every fixed body; each arm's bodies against the other arm's; each
    wafer against the GPR's column and platform (docs/cell.md, "Pairs")."""
    pairs = []
    for i, a in enumerate(bodies):
        for j in range(i + 1, len(bodies)):
            b = bodies[j]
            if a.frame is None and b.frame is None:
                continue
            fa, fb = a.frame or '', b.frame or ''
            gpr_wafer = (fa in ('gpr_base', 'gpr_platform') and fb.endswith('_wafer')) or \
                (fb in ('gpr_base', 'gpr_platform') and fa.endswith('_wafer'))
            if a.frame is None or b.frame is None or (a.arm and b.arm and a.arm != b.arm) or gpr_wafer:
                pairs.append((i, j, ()))
    return pairs


def _inside(windows: tuple[tuple[float, float], ...], t0: Array, t1: Array) -> NDArray[np.bool_]:
    if not windows:
        return np.ones(t0.shape, dtype=bool)
    ok = np.zeros(t0.shape, dtype=bool)
    for lo, hi in windows:
        ok |= (t0 >= lo - 1e-12) & (t1 <= hi + 1e-12)
    return ok


def _minus(windows: tuple[tuple[float, float], ...], t0: Array, t1: Array) -> NDArray[np.bool_]:
    ok = np.ones(t0.shape, dtype=bool)
    for lo, hi in windows:
        ok &= (t1 <= lo + 1e-12) | (t0 >= hi - 1e-12)
    return ok


class _Poses:
    """World poses of every robot frame at a growing list of instants (arrays grown by doubling)."""

    def __init__(self, robot: RobotDescription, motion: Motion) -> None:
        self.robot, self.motion = robot, motion
        self.n = 0
        self._times = np.zeros(0)
        self._frames: dict[str, tuple[Array, Array]] = {}
        self.first_row = np.zeros(0)

    @property
    def times(self) -> Array:
        return self._times[:self.n]

    @property
    def frames(self) -> dict[str, tuple[Array, Array]]:
        return {k: (p[:self.n], R[:self.n]) for k, (p, R) in self._frames.items()}

    def add(self, t: Array) -> NDArray[np.int64]:
        start, m = self.n, t.shape[0]
        rows = self.motion.positions(t)
        if start == 0:
            self.first_row = rows[0]
        fr = frame_poses(self.robot, rows)
        if start + m > self._times.shape[0]:
            cap = max(2 * self._times.shape[0], start + m, 64)
            self._times = np.concatenate([self._times[:start], np.zeros(cap - start)])
            self._frames = {name: (np.concatenate([p[:start], np.zeros((cap - start, 3))]),
                                   np.concatenate([R[:start], np.zeros((cap - start, 3, 3))]))
                            for name, (p, R) in (self._frames or {k: (np.zeros((0, 3)), np.zeros((0, 3, 3)))
                                                                   for k in fr}).items()}
        self._times[start:start + m] = t
        for name, pose in fr.items():
            p, R = self._frames[name]
            p[start:start + m], R[start:start + m] = pose.position, pose.rotation
        self.n = start + m
        return np.arange(start, start + m)

    def body(self, b: Body, idx: NDArray[np.int64]) -> tuple[Array, Array]:
        """World rotations ``(n, 3, 3)`` and centres ``(n, 3)`` of body ``b`` at instants ``idx``."""
        if b.frame is None:
            n = idx.shape[0]
            return np.broadcast_to(b.rotation, (n, 3, 3)), np.broadcast_to(b.position, (n, 3))
        p, R = self._frames[b.frame]
        return R[idx] @ b.rotation, p[idx] + R[idx] @ b.position


class _Distance:
    """FCL objects of the bodies and their exact distance at instants (memoised per pair and instant)."""

    def __init__(self, bodies: Sequence[Body], poses: _Poses) -> None:
        fcl = _fcl()
        self.fcl, self.poses = fcl, poses
        geom = [fcl.Box(*b.size) if b.kind == 'box' else fcl.Cylinder(b.size[0], b.size[1]) for b in bodies]
        self.objects = [fcl.CollisionObject(g, fcl.Transform()) for g in geom]
        self.bodies = bodies
        self.request = fcl.DistanceRequest(enable_signed_distance=True)
        self.calls = 0

    def __call__(self, i: int, j: int, idx: NDArray[np.int64]) -> Array:
        Ra, pa = self.poses.body(self.bodies[i], idx)
        Rb, pb = self.poses.body(self.bodies[j], idx)
        out = np.empty(idx.shape[0])
        oa, ob, fcl = self.objects[i], self.objects[j], self.fcl
        for k in range(idx.shape[0]):
            oa.setTransform(fcl.Transform(Ra[k], pa[k]))
            ob.setTransform(fcl.Transform(Rb[k], pb[k]))
            out[k] = fcl.distance(oa, ob, self.request, fcl.DistanceResult())
        self.calls += idx.shape[0]
        return out - LIBRARY_SLACK


def clearance(robot: RobotDescription, cell: Cell | None, motion: Motion, margin: float = MARGIN,
              tolerance: float = TOLERANCE, bodies: Sequence[Body] | None = None,
              pairs: Sequence[tuple[int, int, tuple[tuple[float, float], ...]]] | None = None,
              rate: float = BASE_RATE) -> ClearanceReport:
    """The certified smallest distance of every pair of bodies over ``motion`` (module docstring).

    Args:
        cell: the obstacles (None: the robot's own bodies only).
        motion: a :class:`~gpr_kinematics.safety.motion.Motion` (a checked program, or sampled joint rows).
        margin: below it a pair counts as a collision [m]; tolerance: accuracy of each pair's minimum [m].
        bodies, pairs: the bodies (default: the robot's, no wafer carried, and the cell's) and the pairs with the
            time windows to leave out of each (default :func:`default_pairs`).
        rate: base sampling [Hz] before refinement.

    Raises:
        InputError: a margin or tolerance that is not a positive number of at most 1 m, a rate outside (0, 1000].
    """
    for name, value in (('margin', margin), ('tolerance', tolerance)):
        if not (isinstance(value, (int, float)) and np.isfinite(value) and 0.0 <= value <= 1.0) or \
                (name == 'tolerance' and value <= 0.0):
            raise InputError(f'{name} = {value!r} is invalid; allowed: metres, {">" if name == "tolerance" else ">="}'
                             f' 0 and at most 1')
    if not 0.0 < rate <= 1000.0:
        raise InputError(f'rate = {rate!r} is invalid; allowed: 0 < rate <= 1000 Hz')
    if bodies is None:
        robot_set, _ = robot_body_set(robot)
        bodies = robot_set + cell_bodies(cell)
    pairs = default_pairs(bodies) if pairs is None else pairs
    knots = np.asarray(motion.knots, dtype=float)
    t_end = float(knots[-1])
    grid = np.unique(np.concatenate([knots, np.arange(0.0, t_end, 1.0 / rate)]))
    poses = _Poses(robot, motion)
    poses.add(grid)
    dist = _Distance(bodies, poses)
    shapes = tuple(Shape(b.frame or '', b.kind, b.size) for b in bodies)
    moving = [k for k, b in enumerate(bodies) if b.frame is not None]
    L = np.zeros((len(poses.first_row), len(bodies)))
    robot_shapes_ = tuple(Shape(bodies[k].frame or '', bodies[k].kind, bodies[k].size,
                                tuple(bodies[k].position), _rpy(bodies[k].rotation)) for k in moving)
    L[:, moving] = lever_arms(robot, robot_shapes_, platform_gains(robot))
    del shapes
    state = _Search(poses, dist, bodies, L, motion, tolerance, margin)
    results = [state.pair(i, j, skip) for i, j, skip in pairs]
    results = [r for r in results if r is not None]
    results.sort(key=lambda r: r.distance)
    best = results[0].distance if results else np.inf
    return ClearanceReport(tuple(results), float(best), float(margin), float(tolerance), dist.calls,
                           int(poses.times.shape[0]), state.series(results))


def _height_range(poses: _Poses, b: Body) -> tuple[float, float] | None:
    """The range of heights of a platform-carried body along the platform normal, in ``gpr_platform`` (None for the
    column and fixed bodies): the arms turn about the normal, so it is the same at every instant."""
    if b.frame is None or b.frame == 'gpr_base':
        return None
    half = np.array(b.size) / 2 if b.kind == 'box' else np.array([b.size[0], b.size[0], b.size[1] / 2])
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    p, R = poses.frames[b.frame]
    pp, Rp = poses.frames['gpr_platform']
    local = Rp[0].T @ (R[0] @ (b.rotation @ corners.T + b.position[:, None]) + (p[0] - pp[0])[:, None])
    return float(np.min(local[2])), float(np.max(local[2]))


def _rpy(R: Array) -> tuple[float, float, float]:
    """URDF rpy of a rotation (for the lever arms, which need the shape's pose in its frame)."""
    pitch = float(np.arcsin(-np.clip(R[2, 0], -1.0, 1.0)))
    out = (float(np.arctan2(R[2, 1], R[2, 2])), pitch, float(np.arctan2(R[1, 0], R[0, 0])))
    assert np.allclose(rpy_matrix(*out), R, atol=1e-9)
    return out


class _Search:
    """The branch and bound of :func:`clearance` for one pair at a time, sharing the instants' poses."""

    def __init__(self, poses: _Poses, dist: _Distance, bodies: Sequence[Body], L: Array, motion: Motion,
                 tolerance: float, margin: float) -> None:
        self.poses, self.dist, self.bodies, self.L = poses, dist, bodies, L
        self.motion, self.tol, self.margin = motion, tolerance, margin
        self.base = poses.times.shape[0]
        self.closest: dict[int, float] = {}
        self.heights = [_height_range(poses, b) for b in bodies]

    def pair(self, i: int, j: int, skip: tuple[tuple[float, float], ...]) -> PairClearance | None:
        a, b = self.bodies[i], self.bodies[j]
        t = self.poses.times[:self.base]
        lo, hi = np.arange(self.base - 1), np.arange(1, self.base)
        keep = _inside(a.windows, t[lo], t[hi]) & _inside(b.windows, t[lo], t[hi]) & _minus(skip, t[lo], t[hi])
        lo, hi = lo[keep], hi[keep]
        if lo.size == 0:
            return None
        exact: dict[int, float] = {}
        sphere: dict[int, float] = {}
        for _ in range(MAX_ROUNDS):
            self._measure(i, j, np.unique(np.concatenate([lo, hi])), exact, sphere)
            best = min(exact.values()) if exact else np.inf
            bound = self._bound(i, j, lo, hi, exact, sphere)
            if best < self.margin:   # a collision found: its instant is known, its depth is not refined further
                break
            open_ = bound < best - self.tol
            if not open_.any():
                break
            # an end known only by its bounding spheres is measured first; else the interval is split
            rough = np.array([k not in exact for k in lo]) | np.array([k not in exact for k in hi])
            ends = np.concatenate([lo[open_ & rough], hi[open_ & rough]])
            ends = np.array([k for k in np.unique(ends) if k not in exact], dtype=np.int64)
            if ends.size:
                exact.update(zip(ends.tolist(), self.dist(i, j, ends).tolist(), strict=True))
            split = open_ & ~rough & ((self.poses.times[hi] - self.poses.times[lo]) > MIN_INTERVAL)
            if not (split.any() or ends.size):
                break
            if split.any():
                mid = self.poses.add(0.5 * (self.poses.times[lo[split]] + self.poses.times[hi[split]]))
                lo, hi = np.concatenate([lo[~split], lo[split], mid]), np.concatenate([hi[~split], mid, hi[split]])
        for k, v in exact.items():
            if k < self.base:
                self.closest[k] = min(self.closest.get(k, np.inf), v)
        if not exact:   # the bounding spheres alone keep the pair apart: measure its closest instant once
            k = min(sphere, key=lambda k: sphere[k])
            exact[k] = float(self.dist(i, j, np.array([k]))[0])
        k_best = min(exact, key=lambda k: exact[k])
        certified = float(min(np.min(self._bound(i, j, lo, hi, exact, sphere)), exact[k_best]))
        below = [float(self.poses.times[k]) for k, v in exact.items() if v < self.margin]
        return PairClearance((a.name, b.name), certified, float(self.poses.times[k_best]),
                             min(below) if below else float('nan'))

    def _measure(self, i: int, j: int, ends: NDArray[np.int64], exact: dict[int, float],
                 sphere: dict[int, float]) -> None:
        """Sphere bounds at new instants; the exact distance where the spheres come near the best so far."""
        new = np.array([k for k in ends if k not in sphere], dtype=np.int64)
        if not new.size:
            return
        lower = self._spheres(i, j, new)
        sphere.update(zip(new.tolist(), lower.tolist(), strict=True))
        if not exact:
            k = int(new[int(np.argmin(lower))])
            exact[k] = float(self.dist(i, j, np.array([k]))[0])
        near = new[lower < max(min(exact.values()), self.margin) + self.tol]
        near = np.array([k for k in near if k not in exact], dtype=np.int64)
        if near.size:
            exact.update(zip(near.tolist(), self.dist(i, j, near).tolist(), strict=True))

    def _bound(self, i: int, j: int, lo: NDArray[np.int64], hi: NDArray[np.int64], exact: dict[int, float],
               sphere: dict[int, float]) -> Array:
        d0 = np.array([exact.get(k, sphere[k]) for k in lo.tolist()])
        d1 = np.array([exact.get(k, sphere[k]) for k in hi.tolist()])
        bound = np.minimum(np.minimum(d0, d1), 0.5 * (d0 + d1 - self._mu(i, j, lo, hi)))
        return np.asarray(np.maximum(bound, self._gap(i, j)), dtype=np.float64)

    def _gap(self, i: int, j: int) -> float:
        """Two bodies carried by the platform keep their heights along its normal (the arms turn about it): the
        gap between their height ranges bounds their distance from below at every instant."""
        a, b = self.heights[i], self.heights[j]
        if a is None or b is None:
            return -np.inf
        return max(b[0] - a[1], a[0] - b[1], 0.0) - LIBRARY_SLACK

    def _spheres(self, i: int, j: int, idx: NDArray[np.int64]) -> Array:
        _, ca = self.poses.body(self.bodies[i], idx)
        _, cb = self.poses.body(self.bodies[j], idx)
        return np.asarray(np.linalg.norm(ca - cb, axis=1) - self.bodies[i].radius - self.bodies[j].radius,
                          dtype=np.float64)

    def _mu(self, i: int, j: int, lo: NDArray[np.int64], hi: NDArray[np.int64]) -> Array:
        t0, t1 = self.poses.times[lo], self.poses.times[hi]
        V = self.motion.variation(t0, t1)
        lever = self.L[:, i] + self.L[:, j]
        if self.heights[i] is not None and self.heights[j] is not None:
            lever = lever.copy()
            lever[:3] = 0.0   # both on the platform: its motion moves them together, their distance stays
        return np.asarray(V @ lever, dtype=np.float64)

    def series(self, results: Sequence[PairClearance]) -> tuple[Array, Array]:
        """The smallest exact distance found at each base instant (NaN where no pair was measured)."""
        t = self.poses.times[:self.base]
        d = np.array([self.closest.get(k, np.nan) for k in range(self.base)])
        order = np.argsort(t)
        return t[order], d[order]

"""The joint working area of the 6-DOF relative-manipulation robot: a 3-RPS tripod (holding the tool) over a
planar 3-RRR (holding the part), after the last section of Posypkin, Rybak, Malyshev and Gaponenko
("Approximation of the parallel robot working area using the method of nonuniform covering", docs/references.md).

Frames (right-handed, SI units):

* ``0``: the planar mechanism's base frame, origin at the centre of its base pivots, z up;
* ``1``: the tripod's base frame, placed in frame 0 by the **placement** ``t, R01 = Rz(yaw) Ry(pitch)
  Rx(roll)`` (fixed axes). The paper's Fig. 15, which shows it, is missing from its text: the placement is
  an assumption, explicit and configurable; by default the tripod hangs upside down (roll = pi, its z axis
  pointing down at the planar platform), its base centre 0.2 m above the planar base centre;
* ``2``: the moving frame of the planar platform, origin at its centre ``(x, y)`` (in frame 0), turned by
  ``phi`` about z: the "moving coordinate system of the lower platform" of the paper.

The tool point sits at ``tool`` in the tripod's platform frame: for a tripod pose ``(z, psi, theta)``
(parasitic motions included) it is ``P0 = t + R01 (c_t + Rp tool)`` in frame 0, and for a planar pose
``(x, y, phi)`` it is ``p = Rz(-phi) (P0 - (x, y, 0))`` in frame 2.

**The joint working area** is the set of tool-point positions ``p = (px, py, pz)`` in frame 2 that a pair of
feasible poses realises (tripod legs within their limits, planar legs closed with their inputs in range,
every pose variable in its range); the tool's orientation is free. Its projections on the xz, yz and xy
planes are the paper's Fig. 17.

Certified covering of ``p`` boxes ``X``, composing the two mechanisms' own certified coverings, as the
paper's algorithm composes their working-area lists:

* the tripod's outer boxes, mapped to enclosures of their tool points ``P0``, make an outer voxel set ``T``;
  the planar covering makes an outer and an inner voxel set over ``(x, y, phi)`` (:mod:`.voxels`);
* each ``X`` carries boxes ``Q`` of planar poses (bisected while larger than ``passive_ratio`` times ``X``,
  dropped when they miss the planar outer set); the pair is dropped when the enclosure of
  ``Rz(phi) p + (x, y)`` over ``X x Q`` misses ``T``; an ``X`` without pairs is **outside**;
* ``X`` is **inner** when one candidate ``(psi*, theta*, phi*)`` works for all of it: ``z`` solved from
  ``pz`` (exact, linear) over ``X``, the tripod's legs enclosed within their limits over that ``z`` interval,
  and the planar pose ``(P0_h - Rz(phi*) p_h, phi*)`` enclosed inside the union of the planar inner boxes.
  Candidates come from fixed grids of tilts and turns.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..core.rotations import rpy_matrix
from ..errors import ConfigError
from ..inputs.schema import check_keys, orientation_angle
from ..mechanisms import read_mechanism_file
from .boxes import box_from, number, scaled_diameter
from .builders import model_from_mapping
from .covering import CoveringTask, Step, SubCoveringStoppedError
from .equations import compiled
from .interval import Interval
from .planar import Rrr3PlanarModel
from .projection import GroupFrontier, split_groups
from .tripod import TripodModel
from .voxels import VoxelSet, grid, hull_of

OUTPUTS = ('px', 'py', 'pz')
DEFAULT_PLACEMENT = {'translation': [0.0, 0.0, 0.2], 'rpy': [math.pi, 0.0, 0.0]}
DEFAULT_TOOL = (0.0, 0.0, 0.03)
#: Inner-test candidates: a grid of tilts (psi, theta) and of turns phi; per output box, the TILTS tilts with
#: the largest certified leg margins are tried with every turn.
CANDIDATES = (8, 8, 16)
TILTS = 8
#: Most planar pose boxes an output box keeps refining (beyond, they stay as they are: still certified).
MAX_POSE_BOXES = 64
#: (output box, planar pose box) pairs per chunk of work.
CHUNK_PAIRS = 4096


def rotation_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """:func:`~..core.rotations.rpy_matrix` (``Rz(yaw) Ry(pitch) Rx(roll)``, fixed axes x, y, z), entries below
    1e-15 (the rounding of sin(pi), cos(pi/2)) set to exact zeros."""
    R = rpy_matrix(roll, pitch, yaw)
    R[np.abs(R) < 1e-15] = 0.0
    return R



def _column(v: Interval) -> Interval:
    """An interval vector ``(n,)`` as a column ``(n, 1)``."""
    return Interval(np.asarray(v.lo)[:, None], np.asarray(v.hi)[:, None])


class JointWorkingArea:
    """Tool-point positions in the planar platform's frame reachable by a tripod over a planar 3-RRR.

    Args:
        tripod, planar: the two mechanisms' workspace models (their boxes are the pose variables' ranges).
        translation, rpy: the placement of the tripod's base frame in the planar base frame (m, rad).
        tool: the tool point in the tripod platform frame (m).
        box: (3, 2) initial box of ``px, py, pz`` (default: a bound computed by interval arithmetic).
        passive_ratio: planar pose boxes are bisected while their scaled diameter exceeds this times X's.
        sub_delta: accuracy of the two mechanisms' coverings, as a fraction of ``delta``.
    """

    name = 'joint_working_area'
    variables = outputs = OUTPUTS
    units = ('m', 'm', 'm')

    def __init__(
        self,
        tripod: TripodModel,
        planar: Rrr3PlanarModel,
        translation: Sequence[float] = DEFAULT_PLACEMENT['translation'],
        rpy: Sequence[float] = DEFAULT_PLACEMENT['rpy'],
        tool: Sequence[float] = DEFAULT_TOOL,
        box: np.ndarray | None = None,
        passive_ratio: float = 1.0,
        sub_delta: float = 0.5,
        title: str = 'joint working area: tripod over planar 3-RRR',
    ) -> None:
        self.tripod, self.planar, self.title = tripod, planar, title
        self.translation = np.array(translation, dtype=float)
        self.rpy = np.array(rpy, dtype=float)
        self.tool = np.array(tool, dtype=float)
        for key, v in (('translation', self.translation), ('rpy', self.rpy), ('tool', self.tool)):
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise ConfigError(f'joint working area: {key} must be 3 finite numbers, got {v.tolist()}')
        self.R01 = rotation_rpy(*self.rpy)
        if abs(self.R01[2, 2]) < 1e-3:
            raise ConfigError('joint working area: the placement tilts the tripod axis by more than 89.9 deg from '
                              'the vertical; allowed: |R01 zz| >= 1e-3 (z is solved from the tool height)')
        if not (0 < passive_ratio <= 1e3 and 0 < sub_delta <= 1):
            raise ConfigError('joint working area: passive_ratio must be in (0, 1000] and sub_delta in (0, 1]')
        self.passive_ratio, self.sub_delta = float(passive_ratio), float(sub_delta)
        self.max_passive = MAX_POSE_BOXES
        self.given_box = self._default_box() if box is None else np.array(box, dtype=float)
        self.box = self.given_box.copy()
        self.scale = np.ones(3)
        self.pose_scale = np.array(planar.scale, dtype=float)
        self.output_index = [0, 1, 2]
        # the covering's box is narrowed to a bound proved from the two mechanisms' outer approximations
        self.box_contains_workspace = box is None
        self.tables: dict[str, Any] = {}

    # ----------------------------------------------------------------------------------------- geometry
    def tool_point(self, z: Any, psi: Any, theta: Any) -> list[Any]:
        """``P0 = t + R01 (c_t + Rp tool)`` in the planar base frame, for intervals (or floats via them)."""
        rot = self.tripod.rotation(psi, theta)
        centre = self.tripod.centre(z, rot)
        local = [centre[j] + sum(rot[j][k] * float(self.tool[k]) for k in range(3)) for j in range(3)]
        return [sum(local[j] * float(self.R01[i, j]) for j in range(3)) + float(self.translation[i])
                for i in range(3)]

    def _default_box(self) -> np.ndarray:
        """A box holding every reachable tool point: ``|p_h| <= max |P0_h - (x, y)|`` (the rotation keeps
        lengths) and ``pz`` in the range of ``P0_z``, by interval arithmetic over the pose ranges."""
        tb, pb = self.tripod.box, self.planar.box
        P0 = self.tool_point(*(Interval(np.array(b[0]), np.array(b[1])) for b in tb))
        ex = P0[0] - Interval(np.array(pb[0, 0]), np.array(pb[0, 1]))
        ey = P0[1] - Interval(np.array(pb[1, 0]), np.array(pb[1, 1]))
        reach = float(np.sqrt(max(ex.lo**2, ex.hi**2) + max(ey.lo**2, ey.hi**2))) * (1 + 1e-9)
        return np.array([[-reach, reach], [-reach, reach], [float(P0[2].lo), float(P0[2].hi)]])

    def tool_points(self, tripod_poses: np.ndarray, planar_poses: np.ndarray) -> np.ndarray:
        """Tool points ``p`` (N, 3) in frame 2 for tripod poses (N, 3) ``z, psi, theta`` and planar poses (N, 3)
        ``x, y, phi``, with the tripod's matrix formulas (:meth:`~.tripod.TripodModel.pose`, independent of
        the interval code)."""
        centre, Rp = self.tripod.pose(tripod_poses)
        P0 = self.translation + (centre + Rp @ self.tool) @ self.R01.T
        x, y, phi = np.asarray(planar_poses, dtype=float).T
        dx, dy = P0[:, 0] - x, P0[:, 1] - y
        c, s = np.cos(phi), np.sin(phi)
        return np.stack([c * dx + s * dy, -s * dx + c * dy, P0[:, 2]], axis=1)

    # ----------------------------------------------------------------------------------------- covering
    def covering_task(self, delta: float, approximate: Any) -> CoveringTask:
        """Cover the two mechanisms at ``sub_delta * delta`` (with ``approximate``, the caller's driver and
        scheduler), build the voxel sets and the candidates, and start from the output box with the planar
        box as its only pose box."""
        sub = self.sub_delta * delta
        step = np.array([sub, sub, sub]) / 2
        tri = approximate(self.tripod, sub)
        if tri.interrupted:   # the run stops for the same reason, at once (the planar one was covered to no use)
            raise SubCoveringStoppedError(tri.stopped)
        t_boxes = np.concatenate([tri.inner, tri.boundary])
        P0 = self.tool_point(*(Interval(t_boxes[:, i, 0], t_boxes[:, i, 1]) for i in range(3)))
        images = np.stack([np.stack([np.asarray(p.lo), np.asarray(p.hi)], axis=1) for p in P0], axis=1)
        grid(hull_of(images), step, delta)   # the tool points' grid refused before the planar covering runs
        pla = approximate(compiled(self.planar), sub, True)
        if pla.interrupted:
            raise SubCoveringStoppedError(pla.stopped)
        outer = np.concatenate([pla.inner, pla.boundary])
        hull = outer_hull = hull_of(outer)
        p_scale = self.planar.scale
        tilts, turns = self._candidates(tri.inner, pla.inner)
        self.tables = {
            'tool': VoxelSet.from_boxes(images, step, delta=delta),
            'planar_outer': VoxelSet.from_boxes(outer, step / p_scale, delta=delta),
            # the leaves that are not inner boxes: with the inner ones they tile the planar box, so a box inside
            # the outer hull that meets none of them lies in the union of the inner boxes
            'planar_hull': hull,
            'planar_not_inner': VoxelSet.from_boxes(np.concatenate([pla.boundary, pla.outside]), step / p_scale,
                                                    hull, delta),
            'candidates': (tilts, turns),
            'tilt_terms': self._tilt_terms(tilts),
            'turn_cos': Interval.point(turns).cos(),
            'turn_sin': Interval.point(turns).sin(),
            'sub_coverings': {'tripod': tri.summary(), 'planar': pla.summary()},
        }
        # |p_h| = |P0_h - (x, y)| <= max |P0_h| + max |(x, y)| and pz = P0_z, over the two outer sets: the initial
        # box is narrowed to that certified bound (self.box keeps the result, as the covering's initial box)
        reach = (np.hypot(np.abs(images[:, 0, :]).max(axis=1), np.abs(images[:, 1, :]).max(axis=1)).max()
                 + np.hypot(np.abs(outer[:, 0, :]).max(axis=1), np.abs(outer[:, 1, :]).max(axis=1)).max()) * (1 + 1e-12)
        bound = np.array([[-reach, reach], [-reach, reach], [images[:, 2, 0].min(), images[:, 2, 1].max()]])
        given = self.given_box
        box = np.stack([np.maximum(given[:, 0], bound[:, 0]), np.minimum(given[:, 1], bound[:, 1])], axis=1)
        empty = np.flatnonzero(~(box[:, 0] < box[:, 1]))
        if empty.size:
            k = int(empty[0])
            raise ConfigError(f'{self.name}: workspace.box {self.variables[k]} = [{given[k, 0]:g}, {given[k, 1]:g}] '
                             f'misses the reachable range [{bound[k, 0]:.6g}, {bound[k, 1]:.6g}]; allowed: a box that '
                             'meets it')
        # widened to delta (a hair less) times a power of two per axis, about its centre: the halvings then end on
        # boxes just below delta, the fewest boxes for the accuracy
        edge = delta * (1 - 1e-9) * 2.0 ** np.ceil(np.log2((box[:, 1] - box[:, 0]) / (delta * (1 - 1e-9))))
        self.box = 0.5 * (box[:, 0] + box[:, 1])[:, None] + 0.5 * edge[:, None] * np.array([-1.0, 1.0])
        # planar pose boxes are measured by the displacement they cause at the tool point: a turn dphi moves it
        # by up to |p_h| dphi, |p_h| at most the box's horizontal reach
        lever = float(np.hypot(np.abs(self.box[0]).max(), np.abs(self.box[1]).max()))
        self.pose_scale = np.array([1.0, 1.0, max(lever, float(self.planar.scale[2]))])
        first = GroupFrontier(self.box[None].copy(), outer_hull[None].copy(), np.zeros(1, dtype=np.int64))
        return CoveringTask(first, joint_step, (), self.box.copy(), self.scale, CHUNK_PAIRS)

    def _candidates(self, tripod_inner: np.ndarray, planar_inner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Fixed grids over the hulls of the two inner approximations: tilts ``(psi, theta)`` (K, 2) and turns
        ``phi`` (L,)."""
        def axis(boxes: np.ndarray, col: int, full: np.ndarray, n: int) -> np.ndarray:
            lo, hi = (boxes[:, col, 0].min(), boxes[:, col, 1].max()) if len(boxes) else tuple(full[col])
            return np.asarray(lo + (hi - lo) * (np.arange(n) + 0.5) / n)

        psi = axis(tripod_inner, 1, self.tripod.box, CANDIDATES[0])
        theta = axis(tripod_inner, 2, self.tripod.box, CANDIDATES[1])
        tilts = np.stack(np.meshgrid(psi, theta, indexing='ij'), axis=-1).reshape(-1, 2)
        return tilts, axis(planar_inner, 2, self.planar.box, CANDIDATES[2])

    def describe(self) -> dict[str, Any]:
        return {'type': self.name, 'title': self.title, 'variables': list(OUTPUTS), 'units': list(self.units),
                'box': self.box.tolist(), 'placement': {'translation': self.translation.tolist(),
                                                        'rpy': self.rpy.tolist()}, 'tool': self.tool.tolist()}

    # ----------------------------------------------------------------------------------------- inner test
    def _tilt_terms(self, tilts: np.ndarray) -> dict[str, Interval]:
        """Per tilt ``(psi, theta)`` (K, 2): enclosures of the tool point at ``z = 0``, ``P0(0)``; ``P0`` is affine
        in ``z`` (``P0(z) = P0(0) + R01[:, 2] z``: the platform centre's height is ``z``, the parasitic motions
        and the tool's offset depend on the tilts only)."""
        zero = Interval.point(np.zeros(tilts.shape[0]))
        P0 = self.tool_point(zero, Interval.point(tilts[:, 0]), Interval.point(tilts[:, 1]))
        return {'x': P0[0], 'y': P0[1], 'z': P0[2]}

    def heights(self, pz: Interval, base: Interval) -> Interval:
        """The tripod's ``z`` giving the tool height ``pz``: ``z = (pz - P0_z(0)) / R01 zz``, enclosed."""
        return (pz - base) / Interval.point(np.asarray(self.R01[2, 2]))

    def inner_test(self, X: np.ndarray) -> np.ndarray:
        """(G,) mask: for every tool point of the output box ``X`` (G, 3, 2), one candidate of the grids gives
        feasible poses (see the module docstring). Every step is certified: the tripod's legs over the ``z``
        interval for every tilt of the grid (once per distinct height interval), then, for the ``TILTS`` tilts
        with the largest certified leg margins, the planar pose boxes for every turn of the grid."""
        tilts, turns = self.tables['candidates']
        terms, turn_cos, turn_sin = self.tables['tilt_terms'], self.tables['turn_cos'], self.tables['turn_sin']
        G, K, L = X.shape[0], tilts.shape[0], turns.shape[0]
        out = np.zeros(G, dtype=bool)
        if G == 0:
            return out
        heights, which = np.unique(X[:, 2, :], axis=0, return_inverse=True)
        U = heights.shape[0]
        ui, ti = np.repeat(np.arange(U), K), np.tile(np.arange(K), U)
        margin = self._leg_margins(Interval(heights[ui, 0], heights[ui, 1]), terms['z'][ti], tilts[ti])
        margin = margin.reshape(U, K)[which.reshape(-1)]                       # (G, K)
        best = np.argsort(-margin, axis=1, kind='stable')[:, :TILTS]
        g2, b2 = np.nonzero(np.take_along_axis(margin, best, axis=1) > 0)
        if g2.size == 0:
            return out
        k2 = best[g2, b2]
        z = self.heights(Interval(X[g2, 2, 0], X[g2, 2, 1]), terms['z'][k2])
        # P0_h over z, then minus Rz(phi*) p_h for every turn: (pairs, L)
        P0x = terms['x'][k2] + z * float(self.R01[0, 2]) if self.R01[0, 2] else terms['x'][k2]
        P0y = terms['y'][k2] + z * float(self.R01[1, 2]) if self.R01[1, 2] else terms['y'][k2]
        px, py = _column(Interval(X[g2, 0, 0], X[g2, 0, 1])), _column(Interval(X[g2, 1, 0], X[g2, 1, 1]))
        dx = _column(P0x) - (px * turn_cos - py * turn_sin)
        dy = _column(P0y) - (px * turn_sin + py * turn_cos)
        phi = np.broadcast_to(turns, dx.lo.shape)
        lo = np.stack([dx.lo, dy.lo, phi], axis=-1).reshape(-1, 3)
        hi = np.stack([dx.hi, dy.hi, phi], axis=-1).reshape(-1, 3)
        ok = self.in_planar_inner(lo, hi).reshape(-1, L).any(axis=1)
        out[g2[ok]] = True
        return out

    def _leg_margins(self, pz: Interval, base: Interval, tilts: np.ndarray) -> np.ndarray:
        """Certified smallest leg margin (m) over the tool heights ``pz`` at ``tilts`` (N, 2) (-1 when ``z``
        leaves its range)."""
        z = self.heights(pz, base)
        legs = self.tripod.legs(z, Interval.point(tilts[:, 0]), Interval.point(tilts[:, 1]))
        margin = np.min([np.minimum(leg.lo - self.tripod.leg_min, self.tripod.leg_max - leg.hi) for leg in legs],
                        axis=0)
        zbox = self.tripod.box[0]
        return np.asarray(np.where((z.lo >= zbox[0]) & (z.hi <= zbox[1]), margin, -1.0))

    def in_planar_inner(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """(N,) mask: the planar pose boxes ``[lo, hi]`` (N, 3) lie in the union of the planar inner boxes."""
        hull = self.tables['planar_hull']
        inside = np.all((lo >= hull[:, 0]) & (hi <= hull[:, 1]), axis=1)
        return np.asarray(inside & ~self.tables['planar_not_inner'].any(lo, hi))

    # ------------------------------------------------------------------------------------------ pairs
    def pairs_alive(self, X: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """(M,) mask of the pairs (output box, planar pose box) that may hold a solution: ``Q`` meets the planar
        outer set and the enclosure of ``Rz(phi) p + (x, y)`` over them meets the tool-point set."""
        alive = self.tables['planar_outer'].any(Q[:, :, 0], Q[:, :, 1])
        ph = Interval(Q[:, 2, 0], Q[:, 2, 1])
        cs, sn = ph.cos(), ph.sin()
        px, py = Interval(X[:, 0, 0], X[:, 0, 1]), Interval(X[:, 1, 0], X[:, 1, 1])
        ex = cs * px - sn * py + Interval(Q[:, 0, 0], Q[:, 0, 1])
        ey = sn * px + cs * py + Interval(Q[:, 1, 0], Q[:, 1, 1])
        lo = np.stack([ex.lo, ey.lo, X[:, 2, 0]], axis=1)
        hi = np.stack([ex.hi, ey.hi, X[:, 2, 1]], axis=1)
        return np.asarray(alive & self.tables['tool'].any(lo, hi))


def joint_step(model: JointWorkingArea, frontier: GroupFrontier, delta: float) -> Step:
    """Classify one chunk of output boxes with their planar pose boxes (see the module docstring)."""
    G = frontier.x.shape[0]
    X = frontier.x[frontier.gid]
    alive = model.pairs_alive(X, frontier.q)
    has_box = np.bincount(frontier.gid[alive], minlength=G) > 0
    inner = np.zeros(G, dtype=bool)
    inner[has_box] = model.inner_test(frontier.x[has_box])
    rest = has_box & ~inner
    keep = alive & rest[frontier.gid]
    q, g = frontier.q[keep], frontier.gid[keep]
    xdiam = scaled_diameter(frontier.x, model.scale)
    need = scaled_diameter(q, model.pose_scale) > model.passive_ratio * xdiam[g]
    return split_groups(frontier.x, q, g, need, rest, delta, model.scale, model.pose_scale, inner, has_box,
                        model.max_passive)


def from_mapping(data: Mapping[str, Any], ws: Mapping[str, Any], source: str, angle_scale: float | None) -> Any:
    """``type: joint_working_area``: ``tripod`` and ``planar`` (a mechanism file name or an inline mapping),
    ``placement: {translation, rpy}``, ``tool``, ``passive_ratio``, ``sub_delta``; ``workspace.box`` over
    ``px, py, pz``."""
    check_keys(data, ('type', 'name', 'reference', 'tripod', 'planar', 'placement', 'tool', 'passive_ratio',
                      'sub_delta', 'workspace'), source)
    parts = {}
    for key, kind in (('tripod', TripodModel), ('planar', Rrr3PlanarModel)):
        spec, where = data.get(key), f'{source}: {key}'
        if isinstance(spec, str):
            spec, path = read_mechanism_file(spec)
            where = str(path)
        if not isinstance(spec, Mapping):
            raise ConfigError(f'{where}: {key} must be a mechanism file name or mapping, got {str(spec)[:60]}')
        if spec.get('type') != kind.name:                  # checked before building: no file includes itself
            raise ConfigError(f'{where}: {key} must be a {kind.name} mechanism, got type {str(spec.get("type"))[:40]}')
        parts[key] = model_from_mapping(spec, where)
    placement = data.get('placement', DEFAULT_PLACEMENT)
    if not isinstance(placement, Mapping):
        raise ConfigError(f'{source}: placement must be a mapping with translation (m) and rpy (rad)')
    check_keys(placement, ('translation', 'rpy'), f'{source}: placement')

    def triple(value: Any, where: str, unit: str) -> list[float]:
        if not isinstance(value, list) or len(value) != 3:
            raise ConfigError(f'{source}: {where} must be a list of 3 numbers ({unit}), got {str(value)[:60]}')
        if unit == 'rad':   # an orientation: within one turn (the file is in radians only)
            return [orientation_angle(x, f'{where}[{i}]', source) for i, x in enumerate(value)]
        return [number(x, f'{where}[{i}]', source, unit=unit) for i, x in enumerate(value)]

    tripod, planar = parts['tripod'], parts['planar']
    assert isinstance(tripod, TripodModel) and isinstance(planar, Rrr3PlanarModel)
    model = JointWorkingArea(
        tripod, planar,
        triple(placement.get('translation', DEFAULT_PLACEMENT['translation']), 'placement.translation', 'm'),
        triple(placement.get('rpy', DEFAULT_PLACEMENT['rpy']), 'placement.rpy', 'rad'),
        triple(data.get('tool', list(DEFAULT_TOOL)), 'tool', 'm'),
        passive_ratio=number(data.get('passive_ratio', 1.0), 'passive_ratio', source, positive=True, unit='(a ratio)'),
        sub_delta=number(data.get('sub_delta', 0.5), 'sub_delta', source, positive=True, unit='(a ratio)'),
        title=str(data.get('name', 'joint working area'))[:80],
    )
    if ws.get('box') is not None:
        model.given_box = model.box = box_from(ws, OUTPUTS, model.given_box, source)
        model.box_contains_workspace = False
    return model

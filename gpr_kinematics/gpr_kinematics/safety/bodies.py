"""The bodies of a clearance check and the pairs checked, with the cheap lower bound of a pair's distance that the
broad phase of :mod:`~gpr_kinematics.safety.clearance` uses (docs/cell.md, "Bodies and pairs").

A body is a box (full edges) or a cylinder (radius, length along its z) fixed in a robot frame (the robot
description's collision shapes, :mod:`gpr_kinematics.robot.collision`) or in the world (an obstacle, a wafer left
in a station), existing during time windows (a carried wafer from its pick to its place).

**Broad-phase bound.** Each body is enclosed in its oriented bounding box (a box is its own; a cylinder's has
half-extents ``(r, r, l/2)``). For two convex sets and any unit axis ``a``, the gap between their projections on
``a`` is at most their distance; for two boxes the largest gap over the 15 axes of the separating-axis test
(the 3 + 3 face normals, the 9 cross products of edges) and the line of centres is at most the distance when they
are apart, and minus the penetration depth when they overlap (that depth is the smallest overlap over the 15
axes). So :func:`box_lower_bound` is never above the signed distance of the enclosed bodies.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.rotations import rpy_matrix
from ..robot.description import RobotDescription
from ..robot.shapes import robot_shapes
from .cell import Cell

Array = NDArray[np.float64]
Windows = tuple[tuple[float, float], ...]
#: Rows per chunk of the vectorised separating-axis bound (bounds the temporary arrays to a few tens of MB).
CHUNK = 20_000


@dataclass(frozen=True)
class Body:
    """A body to check: ``kind`` box (full edges) or cylinder (radius, length) ``size`` [m], fixed in ``frame`` (None:
    in the world) at ``rotation`` (3, 3) / ``position`` (3,) in it, existing during ``windows`` (empty: always);
    ``arm`` the arm that carries it (None: the GPR or the cell)."""

    name: str
    kind: str
    size: tuple[float, ...]
    frame: str | None
    rotation: Array
    position: Array
    windows: Windows = ()
    arm: str | None = None

    @property
    def half(self) -> Array:
        """Half-extents of the oriented bounding box in the body's axes [m]."""
        if self.kind == 'box':
            return np.asarray(self.size, dtype=np.float64) / 2
        return np.array([self.size[0], self.size[0], self.size[1] / 2])

    @property
    def radius(self) -> float:
        """Distance from the centre to the farthest point [m]."""
        if self.kind == 'box':
            return float(np.linalg.norm(self.half))
        return float(np.hypot(self.size[0], self.size[1] / 2))


def robot_body_set(robot: RobotDescription, wafer_windows: dict[str, Windows] | None = None) -> list[Body]:
    """The robot's bodies (:func:`~gpr_kinematics.robot.shapes.robot_shapes`); an arm's wafer exists only in
    ``wafer_windows[arm]`` (absent: never carried)."""
    out = []
    windows = wafer_windows or {}
    for sh in robot_shapes(robot):
        arm = next((a.name for a in robot.arms if sh.frame.startswith(a.name + '_')), None)
        w: Windows = ()
        if arm is not None and sh.frame == f'{arm}_wafer':
            w = windows.get(arm, ()) or ((np.inf, np.inf),)   # never carried: an empty window
        out.append(Body(sh.frame, sh.kind, sh.size, sh.frame, np.asarray(rpy_matrix(*sh.rpy), dtype=np.float64),
                        np.asarray(sh.xyz, dtype=np.float64), w, arm))
    return out


def cell_bodies(cell: Cell | None) -> list[Body]:
    """The cell's obstacles as fixed bodies."""
    return [] if cell is None else [Body(o.name, o.kind, o.size, None, o.rotation, o.position) for o in cell.obstacles]


def on_gpr(body: Body) -> bool:
    """The body is the column or the platform."""
    return body.frame in ('gpr_base', 'gpr_platform')


def default_pairs(bodies: Sequence[Body]) -> list[tuple[int, int]]:
    """Pairs checked: every robot body against every fixed body; each arm's bodies against the other arm's and
    against the GPR's column and platform (docs/cell.md, "Bodies and pairs"; its wafer alone was: a link 29 mm into
    the column at a low stroke read safe)."""
    pairs = []
    for i, a in enumerate(bodies):
        for j in range(i + 1, len(bodies)):
            b = bodies[j]
            if a.frame is None and b.frame is None:
                continue
            arm_gpr = (on_gpr(a) and bool(b.arm)) or (on_gpr(b) and bool(a.arm))
            if a.frame is None or b.frame is None or (a.arm and b.arm and a.arm != b.arm) or arm_gpr:
                pairs.append((i, j))
    return pairs


def box_lower_bound(Ra: Array, ca: Array, ha: Array, Rb: Array, cb: Array, hb: Array) -> Array:
    """Lower bounds ``(N,)`` of the signed distance of oriented boxes (axes the columns of ``R (N, 3, 3)``, centres
    ``c (N, 3)``, half-extents ``h (N, 3)``) by the separating-axis test (module docstring), in chunks."""
    out = np.empty(ca.shape[0])
    for k in range(0, ca.shape[0], CHUNK):
        sl = slice(k, k + CHUNK)
        out[sl] = _sat(Ra[sl], ca[sl], ha[sl], Rb[sl], cb[sl], hb[sl])
    return out


def _sat(Ra: Array, ca: Array, ha: Array, Rb: Array, cb: Array, hb: Array) -> Array:
    """The separating-axis bound in ``a``'s frame (``R = Ra^T Rb``, ``t = Ra^T (cb - ca)``): the 15 axes of the test
    (the cross products ``a_i x b_j`` normalised by ``sqrt(R_i1j^2 + R_i2j^2)``) and the line of centres."""
    R = np.matmul(np.swapaxes(Ra, 1, 2), Rb)
    t = np.matmul((cb - ca)[:, None, :], Ra)[:, 0]
    A = np.abs(R)
    gaps = [np.abs(t) - ha - np.matmul(A, hb[:, :, None])[..., 0],
            np.abs(np.matmul(t[:, None, :], R)[:, 0]) - np.matmul(ha[:, None, :], A)[:, 0] - hb]
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            norm = np.sqrt(R[:, i1, j] ** 2 + R[:, i2, j] ** 2)
            gap = (np.abs(t[:, i2] * R[:, i1, j] - t[:, i1] * R[:, i2, j]) - ha[:, i1] * A[:, i2, j]
                   - ha[:, i2] * A[:, i1, j] - hb[:, j1] * A[:, i, j2] - hb[:, j2] * A[:, i, j1])
            with np.errstate(invalid='ignore', divide='ignore'):
                gaps.append(np.where(norm > 1e-9, gap / norm, -np.inf)[:, None])
    dist = np.linalg.norm(t, axis=1)
    with np.errstate(invalid='ignore', divide='ignore'):
        u = t / dist[:, None]
    line = dist - np.sum(ha * np.abs(u), axis=1) - np.sum(hb * np.abs(np.matmul(u[:, None, :], R)[:, 0]), axis=1)
    gaps.append(np.where(dist > 0.0, line, -np.inf)[:, None])
    return np.asarray(np.max(np.concatenate(gaps, axis=1), axis=1), dtype=np.float64)

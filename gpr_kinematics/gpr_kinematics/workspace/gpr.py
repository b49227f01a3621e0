"""The GPR as a workspace model: heights and tilts within the stroke and the virtual joints' imperfection budget."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..core.config import GprConfig
from ..core.virtual_joints import EDGES
from ..errors import ConfigError, InputError
from .base import WorkspaceModel, check_parameters
from .interval import Interval, monotone

_INF = np.inf
#: The default largest tilt [rad] of the workspace's box (its ``max_tilt``; the workspace section's default too).
MAX_TILT = 0.3


def _tan_over(u: np.ndarray) -> np.ndarray:
    """``tan(sqrt(u)) / sqrt(u)`` for ``0 <= u < (pi/2)^2``, increasing in u (series below 1e-8)."""
    u = np.asarray(u, dtype=float)
    small = u < 1e-8
    with np.errstate(invalid='ignore', divide='ignore'):
        s = np.sqrt(np.where(small, 1.0, u))
        big = np.tan(s) / s
    return np.where(small, 1.0 + u / 3.0 + 2.0 * u * u / 15.0, big)


class GprModel(WorkspaceModel):
    """GPR: heights and tilts reachable within the stroke and within the virtual joints' imperfection budget.

    Variables: ``z`` = height of the centroid of the three joint centres ``P_k = (R cos t_k, R sin t_k, q_k)``
    (``= mean(q)``) [m], and the tilt as a rotation vector ``(tilt_x, tilt_y) = alpha (cos g, sin g)`` [rad]
    (``Rot = exp(alpha [a]x)``, ``a = (cos g, sin g, 0)``, the tilt convention of docs/core.md). Every
    virtual-joint model keeps the joints in the platform plane, so the platform plane is the plane through
    the ``P_k``: with ``n = Rot e_z`` it gives exactly ``q_k = z + R tan(alpha)/alpha (tilt_x sin t_k -
    tilt_y cos t_k)``.

    Constraints: ``stroke_min <= q_k <= stroke_max`` and ``|dl_k| <= imperfection_budget`` where ``dl_k`` is
    the radial virtual-joint displacement (``radial`` model of docs/core.md: joint k at ``(R + dl_k)`` along its
    azimuth). Side lengths: ``L_ij^2 = 3 R^2 + d_ij^2``, ``d_ij = q_j - q_i``; with joints 120 deg apart
    ``|r_i - r_j|^2 = l_i^2 + l_j^2 + l_i l_j``, so ``3 R (dl_i + dl_j) + Q_ij = d_ij^2`` with
    ``Q_ij = dl_i^2 + dl_j^2 + dl_i dl_j``.

    Certified enclosure (derived in docs/workspace.md): write ``S dl = (D - Q)/(3R)`` with the pair matrix
    ``S`` (inverse ``S^-1 = 1/2 [[1,-1,1],[1,1,-1],[-1,1,1]]`` on pairs 12, 23, 31) and ``D_ij = d_ij^2``.
    The linear part ``dl_lin = S^-1 D / (3R)`` is enclosed by interval arithmetic; the remainder obeys
    ``|dl - dl_lin|_inf <= 1.5 e^2 / R`` where ``e = |dl|_inf``, and on the branch through ``dl = 0`` (the
    one Newton from the singular configuration follows) ``e <= e1 = 2 m / (1 + sqrt(1 - 6 m / R))`` with
    ``m = |dl_lin|_inf`` whenever ``6 m < R``. Where that fails, ``dl_max = |dl|_inf`` is bounded below, for any
    solution, by ``e + 1.5 e^2 / R >= M`` (``M`` the least ``|dl_lin|_inf`` over the box): boxes far beyond the
    budget are proved outside, the rest left undecided.
    """

    name = 'gpr'
    variables = ('z', 'tilt_x', 'tilt_y')
    units = ('m', 'rad', 'rad')

    def __init__(
        self,
        radius: float = GprConfig.radius,   # the core's defaults: config/gpr.yaml's geometry
        rod_azimuths: Sequence[float] = GprConfig.rod_azimuths,
        stroke_min: float = GprConfig.stroke_min,
        stroke_max: float = GprConfig.stroke_max,
        imperfection_budget: float = GprConfig.imperfection_budget,
        box: np.ndarray | None = None,
        angle_scale: float | None = None,
        max_tilt: float = MAX_TILT,
    ) -> None:
        check_parameters(self.name, {'radius': radius, 'angle_scale': angle_scale},
                         {'stroke_min': stroke_min, 'stroke_max': stroke_max},
                         {'imperfection_budget': imperfection_budget, 'max_tilt': max_tilt})
        if radius <= 0 or not stroke_min < stroke_max or imperfection_budget <= 0:
            raise ConfigError(
                'gpr workspace needs radius > 0, stroke_min < stroke_max, imperfection_budget > 0'
            )
        self.R = float(radius)
        self.az = np.asarray(rod_azimuths, dtype=float)
        # the side-length relations below hold for joints 120 deg apart only
        gaps = np.diff(np.sort(np.mod(self.az, 2 * math.pi)))
        if self.az.shape != (3,) or not np.allclose(gaps, 2 * math.pi / 3, rtol=0.0, atol=1e-9):
            off = ('' if self.az.shape != (3,) else
                   f', their gaps {(gaps - 2 * math.pi / 3).tolist()} rad off 120 deg')
            raise ConfigError(f'gpr workspace: rod_azimuths {self.az.tolist()} rad{off}; allowed: three azimuths '
                              '120 deg apart to 1e-09 rad (the certified enclosure assumes that spacing)')
        self.stroke_min, self.stroke_max = float(stroke_min), float(stroke_max)
        self.budget = float(imperfection_budget)
        self.box = np.array(
            box
            if box is not None
            else [[stroke_min, stroke_max], [-max_tilt, max_tilt], [-max_tilt, max_tilt]]
        )
        self.check_box(self.box)
        sc = self.R if angle_scale is None else float(angle_scale)
        self.scale = np.array([1.0, sc, sc])
        self.constraint_names = ('q1', 'q2', 'q3', 'dl1', 'dl2', 'dl3', 'dl_max')
        self.lower = np.array([self.stroke_min] * 3 + [-self.budget] * 3 + [-_INF])
        self.upper = np.array([self.stroke_max] * 3 + [self.budget] * 4)

    def check_box(self, box: np.ndarray) -> None:
        """The enclosure of tan(alpha)/alpha needs alpha < pi/2 on the whole box: |tilt| < 1.5 rad."""
        corner = float(np.hypot(np.max(np.abs(box[1])), np.max(np.abs(box[2]))))
        if not corner < 1.5:
            raise InputError(f'gpr workspace box: the tilt magnitude at the box corners is {corner:.4g} rad; '
                             'allowed: below 1.5 rad (tan(alpha)/alpha must stay monotone)')

    def closed_faces(self, box: np.ndarray) -> np.ndarray:
        """The faces of ``box`` beyond which no workspace lies: z's at or beyond the stroke (z, the mean of the rods,
        lies within it)."""
        closed = np.zeros((3, 2), dtype=bool)
        closed[0] = box[0, 0] <= self.stroke_min, box[0, 1] >= self.stroke_max
        return closed

    # point evaluation ---------------------------------------------------------------------------------------
    def actuators(self, points: np.ndarray) -> np.ndarray:
        """Rod lengths q (N, 3) [m] of (z, tilt_x, tilt_y) points (exact plane through the joint centres)."""
        z, wx, wy = np.asarray(points, dtype=float).T
        alpha = np.hypot(wx, wy)
        axis = np.stack(
            [
                np.where(alpha > 0, wx / np.where(alpha > 0, alpha, 1), 1.0),
                np.where(alpha > 0, wy / np.where(alpha > 0, alpha, 1), 0.0),
                np.zeros_like(z),
            ],
            axis=1,
        )
        # normal of the tilted platform n = Rot e_z = cos(alpha) e_z + sin(alpha) (a x e_z)
        n = np.cos(alpha)[:, None] * np.array([0.0, 0.0, 1.0]) + np.sin(alpha)[:, None] * np.cross(
            axis, np.array([0.0, 0.0, 1.0])
        )
        hx = self.R * np.cos(self.az)
        hy = self.R * np.sin(self.az)
        # plane through (0, 0, z) with normal n: n . (P - (0,0,z)) = 0
        return np.asarray(z[:, None] - (n[:, 0, None] * hx[None] + n[:, 1, None] * hy[None]) / n[:, 2, None])

    def radial_displacements(self, q: np.ndarray) -> np.ndarray:
        """Radial virtual-joint displacements dl (N, 3) [m] for rod lengths q (N, 3): Newton on
        ``l_i^2 + l_j^2 + l_i l_j = 3 R^2 + (q_j - q_i)^2`` from ``l = R`` (the radial model)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        D = np.stack([(q[:, j] - q[:, i]) ** 2 for i, j in EDGES], axis=1)
        dl = np.zeros_like(q)
        for _ in range(30):
            F = (
                np.stack(
                    [
                        3 * self.R * (dl[:, i] + dl[:, j])
                        + dl[:, i] ** 2
                        + dl[:, j] ** 2
                        + dl[:, i] * dl[:, j]
                        for i, j in EDGES
                    ],
                    axis=1,
                )
                - D
            )
            J = np.zeros((q.shape[0], 3, 3))
            for row, (i, j) in enumerate(EDGES):
                J[:, row, i] = 3 * self.R + 2 * dl[:, i] + dl[:, j]
                J[:, row, j] = 3 * self.R + 2 * dl[:, j] + dl[:, i]
            step = np.linalg.solve(J, F[..., None])[..., 0]
            dl = dl - step
            if np.max(np.abs(step)) < 1e-17:
                break
        return dl

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        q = self.actuators(points)
        dl = self.radial_displacements(q)
        return np.concatenate([q, dl, np.max(np.abs(dl), axis=1, keepdims=True)], axis=1)

    # interval enclosure ---------------------------------------------------------------------------------
    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        z, wx, wy = x
        R = self.R
        # tan(alpha)/alpha is increasing in u = alpha^2 on [0, (pi/2)^2): monotone enclosure, relative
        # float error of tan(sqrt(u))/sqrt(u) well below 2^-48 (sqrt, / correctly rounded; tan <= 4 ulp).
        u = wx.sqr() + wy.sqr()
        t = monotone(_tan_over, u, increasing=True)
        c = [Interval.point(1.0) if a == 0.0 else Interval.const(math.cos(a)) for a in self.az]
        s = [Interval.point(0.0) if a == 0.0 else Interval.const(math.sin(a)) for a in self.az]
        lin = [wx * s[k] - wy * c[k] for k in range(3)]
        q = [z + t * lin[k] * R for k in range(3)]
        # d_ij = q_j - q_i = R t (wx (s_j - s_i) - wy (c_j - c_i)): computed without z (no cancellation)
        D = [(t * (wx * (s[j] - s[i]) - wy * (c[j] - c[i])) * R).sqr() for i, j in EDGES]
        inv6R = Interval.point(1.0) / (Interval.point(R) * 6.0)
        lin_dl = [(D[0] - D[1] + D[2]) * inv6R, (D[0] + D[1] - D[2]) * inv6R, (D[1] + D[2] - D[0]) * inv6R]
        m = np.maximum.reduce([np.maximum(np.abs(v.lo), np.abs(v.hi)) for v in lin_dl])
        m = m * (1 + 1e-12)
        ok = 6.0 * m < R * (1 - 1e-9)
        with np.errstate(invalid='ignore'):
            e1 = 2.0 * m / (1.0 + np.sqrt(np.maximum(1.0 - 6.0 * m / R, 0.0)))
        rem = np.where(ok, 1.5 * e1 * e1 / R * (1 + 1e-9) + 1e-300, _INF)
        dl = [Interval(np.nextafter(v.lo - rem, -_INF), np.nextafter(v.hi + rem, _INF)) for v in lin_dl]
        # e = |dl|_inf: its upper bound the dl_k's (the same inside test), and where 6 m >= R (no upper bound) a
        # lower one that holds for any solution: e + 1.5 e^2 / R >= |dl_lin|_inf >= M (its least over the box), so
        # e >= R/3 (sqrt(1 + 6 M / R) - 1) = 2 M / (1 + sqrt(1 + 6 M / R)) (e1's form, no cancellation): boxes far
        # beyond the budget are proved outside (a tilt box of +-1 rad left 2.2 million boundary boxes whose outer
        # volume did not shrink with delta)
        big = np.maximum.reduce([v.abs().hi for v in dl])
        least = np.maximum.reduce([v.abs().lo for v in lin_dl]) * (1 - 1e-12)
        low = np.where(ok, 0.0, 2.0 * least / (1.0 + np.sqrt(1.0 + 6.0 * least / R)) * (1 - 1e-9))
        return [*q, *dl, Interval(low, big)]

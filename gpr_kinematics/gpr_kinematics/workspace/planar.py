"""The planar 3-RRR of Posypkin, Rybak, Malyshev and Gaponenko (Fig. 12, eqs. 8-12; docs/references.md) as a
workspace model.

Its constraint functions are written once, for intervals and symbolic expressions alike
(:meth:`Rrr3PlanarModel.constraints`); the joint working area builds on them."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import ConfigError, brief
from ..mechanisms.upu3 import AZIMUTH_GAP, azimuth_gaps
from .base import WorkspaceModel, check_parameters
from .interval import Interval, T

_INF = np.inf


def _check_legs_distinct(base: np.ndarray, platform: np.ndarray) -> None:
    """:class:`ConfigError` for two legs between the same base pivot and platform joint (their angles equal modulo
    2 pi, within :data:`~gpr_kinematics.mechanisms.upu3.AZIMUTH_GAP`): one leg given twice, three constraints two of
    them the same (``base_angles [0, 0, 0]`` was covered as a workspace). Legs that share a pivot alone are a design."""
    twice = np.triu((azimuth_gaps(base) < AZIMUTH_GAP) & (azimuth_gaps(platform) < AZIMUTH_GAP), 1)
    if twice.any():
        i, j = (int(v) + 1 for v in np.argwhere(twice)[0])
        raise ConfigError(f'rrr3_planar: legs {i} and {j} join the same base pivot and platform joint (base_angles '
                          f'{np.round(base, 9).tolist()}, platform_angles {np.round(platform, 9).tolist()} rad): one '
                          f'leg given twice; allowed: legs whose base or platform angles differ by at least '
                          f'{AZIMUTH_GAP:g} rad modulo 2 pi')


class Rrr3PlanarModel(WorkspaceModel):
    """Planar 3-RRR (Posypkin et al., Fig. 12, eqs. 8-12): reachable ``(x, y, phi)`` of the output link.

    Leg i: base pivot ``A_i = R (cos b_i, sin b_i)``, crank ``l1`` at input angle ``theta_i``, coupler ``l2``
    to ``C_i = (x, y) + l3 (cos(g_i + phi), sin(g_i + phi))``. With ``v = C_i - A_i`` the closure
    ``|v - l1 u(theta)| = l2`` reads ``v . u = k``, ``k = (|v|^2 + l1^2 - l2^2) / (2 l1)``; the paper's eq. (8)
    ``theta = arcsin(...) - phi_aux`` is the branch ``u = (k v + sqrt(|v|^2 - k^2) J v) / |v|^2`` (J: +90 deg
    rotation), the one used here (``branch: 1``; ``-1`` gives the other working mode). Constraints per leg:
    ``|v|^2 - k^2 >= 0`` (eq. 8's arcsin argument within [-1, 1]) and ``u . m_i >= cos(half range)`` where
    ``m_i`` is the crank direction at the middle of the allowed input range, which is measured from the
    crank's direction in the home pose ``x = y = phi = 0`` (the paper gives the range, -45..45 deg, but not
    its origin: this choice is ours). No angle wrap-around issues: the test is on unit vectors.
    """

    name = 'rrr3_planar'
    variables = ('x', 'y', 'phi')
    units = ('m', 'm', 'rad')

    def __init__(self, base_radius: float = 0.1, platform_radius: float = 0.05, crank: float = 0.05,
                 coupler: float = 0.05, theta_min: float = -math.pi / 4, theta_max: float = math.pi / 4,
                 base_angles: Sequence[float] = (math.pi / 2, 7 * math.pi / 6, 11 * math.pi / 6),
                 platform_angles: Sequence[float] | None = None, branch: int = 1, box: np.ndarray | None = None,
                 angle_scale: float | None = None) -> None:
        check_parameters(self.name, {'base_radius': base_radius, 'platform_radius': platform_radius, 'crank': crank,
                                     'coupler': coupler, 'angle_scale': angle_scale},
                         {'theta_min': theta_min, 'theta_max': theta_max,
                          **{f'base_angles[{i}]': a for i, a in enumerate(base_angles)},
                          **{f'platform_angles[{i}]': a for i, a in enumerate(platform_angles or ())}})
        if min(base_radius, platform_radius, crank, coupler) <= 0:
            raise ConfigError('rrr3_planar needs positive base_radius, platform_radius, crank, coupler')
        if not theta_min < theta_max < theta_min + 2 * math.pi:
            raise ConfigError(f'rrr3_planar: theta_min = {brief(theta_min)}, theta_max = {brief(theta_max)} rad; '
                              'allowed: theta_min < theta_max < theta_min + 2 pi (rad)')
        if branch not in (1, -1):
            raise ConfigError(f'rrr3_planar branch must be 1 or -1, got {brief(branch)}')
        self.R, self.r, self.l1, self.l2 = (
            float(base_radius),
            float(platform_radius),
            float(crank),
            float(coupler),
        )
        self.base_angles = np.asarray(base_angles, dtype=float)
        self.platform_angles = (
            self.base_angles.copy() if platform_angles is None else np.asarray(platform_angles, dtype=float)
        )
        _check_legs_distinct(self.base_angles, self.platform_angles)
        self.branch = int(branch)
        self.theta_min, self.theta_max = float(theta_min), float(theta_max)
        self.A = self.R * np.stack([np.cos(self.base_angles), np.sin(self.base_angles)], axis=1)
        home = self.crank_directions(np.zeros((1, 3)))[0]  # (3, 2)
        if not np.all(np.isfinite(home)):                   # the range's origin: NaN made every pose infeasible
            reach = np.linalg.norm(self._v(np.zeros((1, 3)))[0], axis=1)
            leg = int(np.flatnonzero(~np.all(np.isfinite(home), axis=1))[0])
            raise ConfigError(f'rrr3_planar: the home pose x = y = phi = 0 does not close leg {leg + 1} (|C - A| = '
                              f'{reach[leg]:.6g} m, outside [{abs(self.l1 - self.l2):.6g}, {self.l1 + self.l2:.6g}] '
                              'm), and the input range is measured from the cranks there; allowed: a geometry whose '
                              'three legs close at the home pose')
        mid = 0.5 * (self.theta_min + self.theta_max)
        c, s = math.cos(mid), math.sin(mid)
        self.m = np.stack([c * home[:, 0] - s * home[:, 1], s * home[:, 0] + c * home[:, 1]], axis=1)
        half = 0.5 * (self.theta_max - self.theta_min)
        reach = self.R + self.r + self.l1 + self.l2
        self.box = np.array(
            box if box is not None else [[-reach, reach], [-reach, reach], [-math.pi, math.pi]]
        )
        sc = self.r if angle_scale is None else float(angle_scale)
        self.scale = np.array([1.0, 1.0, sc])
        self.constraint_names = ('closure1', 'closure2', 'closure3', 'angle1', 'angle2', 'angle3')
        self.lower = np.array([0.0] * 3 + [math.cos(half)] * 3)
        self.upper = np.array([_INF] * 3 + [_INF] * 3)

    def _v(self, points: np.ndarray) -> np.ndarray:
        x, y, phi = np.asarray(points, dtype=float).T
        ang = self.platform_angles[None, :] + phi[:, None]
        cx = x[:, None] + self.r * np.cos(ang)
        cy = y[:, None] + self.r * np.sin(ang)
        return np.stack([cx - self.A[None, :, 0], cy - self.A[None, :, 1]], axis=2)  # (N, 3, 2)

    def crank_directions(self, points: np.ndarray) -> np.ndarray:
        """Unit crank directions u_i (N, 3, 2) on the model's branch (NaN where the leg cannot close)."""
        v = self._v(points)
        vv = np.sum(v * v, axis=2)
        k = (vv + self.l1**2 - self.l2**2) / (2 * self.l1)
        with np.errstate(invalid='ignore'):
            s = self.branch * np.sqrt(vv - k * k)
        jv = np.stack([-v[..., 1], v[..., 0]], axis=2)
        return np.asarray((k[..., None] * v + s[..., None] * jv) / vv[..., None])

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        v = self._v(points)
        vv = np.sum(v * v, axis=2)
        k = (vv + self.l1**2 - self.l2**2) / (2 * self.l1)
        u = self.crank_directions(points)
        cosang = np.sum(u * self.m[None], axis=2)
        return np.concatenate([vv - k * k, cosang], axis=1)

    def constraints(self, px: T, py: T, phi: T) -> list[T]:
        """The six constraint functions (closures, then input-angle cosines) over intervals or symbolic
        expressions alike."""
        closure, angle = [], []
        for i in range(3):
            ang = phi + float(self.platform_angles[i])
            vx = px + ang.cos() * self.r - float(self.A[i, 0])
            vy = py + ang.sin() * self.r - float(self.A[i, 1])
            vv = vx.sqr() + vy.sqr()
            k = (vv + (self.l1**2 - self.l2**2)) / (2 * self.l1)
            disc = vv - k.sqr()
            closure.append(disc)
            mx, my = float(self.m[i, 0]), float(self.m[i, 1])
            # u . m = (k (v . m) + s (Jv . m)) / |v|^2, Jv . m = -vy mx + vx my
            num = k * (vx * mx + vy * my) + disc.sqrt() * ((vx * my - vy * mx) * float(self.branch))
            angle.append(num / vv)
        return closure + angle

    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        return self.constraints(*x)

    def input_angles(self, points: np.ndarray) -> np.ndarray:
        """Input angles theta_i - theta_i(home) (N, 3) in (-pi, pi] [rad]."""
        u = self.crank_directions(points)
        home = self.crank_directions(np.zeros((1, 3)))[0]
        return np.asarray(np.arctan2(
            home[None, :, 0] * u[..., 1] - home[None, :, 1] * u[..., 0], np.sum(home[None] * u, axis=2))
        )

"""The 3-RPS tripod of Posypkin, Rybak, Malyshev and Gaponenko (Fig. 8, eqs. 2-7; docs/references.md) as a
workspace model.

Its pose formulas are written once, for intervals and symbolic expressions alike (:meth:`TripodModel.rotation`,
:meth:`TripodModel.centre`, :meth:`TripodModel.legs`); the joint working area builds on them."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import ConfigError, InputError
from .base import WorkspaceModel, check_parameters
from .interval import Interval, T, norm, sqrt3_over_2


class TripodModel(WorkspaceModel):
    """3-RPS tripod (Posypkin et al., Fig. 8): base and platform joints at azimuths 0, 120, 240 deg on radii R, r.

    Pose variables ``z`` [m], ``psi`` (about x) and ``theta`` (about y) [rad]. The parasitic motions as Posypkin et
    al. print them before their eq. (2), citing Rao and Rao (2013), whose paper the project does not hold
    (docs/references.md):
    ``phi = atan(sin psi sin theta / (cos psi + cos theta))``,
    ``y = -r cos psi sin phi``, ``x = r/2 (Rp11 - Rp22)``, with ``Rp = Ry(theta) Rx(psi) Rz(phi)`` (eq. 2, its entries
    eq. 3).
    Leg i joins ``a_i = R u_i`` to ``s_i = p + Rp r u_i``, ``u_i = (cos b_i, sin b_i, 0)``; the constraint is
    ``leg_min <= |s_i - a_i| <= leg_max`` (eq. 4; eqs. 5-7 are its components, eq. 6 as printed with
    the x term's signs of a leg at 60 deg). These formulas keep each spherical joint in its leg's radial plane
    (tested exactly).
    ``scale`` of the angles: the platform radius ``r`` (an angle step moves a joint by about ``r`` times it).
    """

    name = 'tripod_3rps'
    variables = ('z', 'psi', 'theta')
    units = ('m', 'rad', 'rad')

    def __init__(self, base_radius: float = 0.05, platform_radius: float = 0.05, leg_min: float = 0.07,
                 leg_max: float = 0.13, box: np.ndarray | None = None, angle_scale: float | None = None) -> None:
        check_parameters(self.name, {'base_radius': base_radius, 'platform_radius': platform_radius,
                                     'leg_min': leg_min, 'leg_max': leg_max, 'angle_scale': angle_scale})
        if not (0 < leg_min < leg_max) or base_radius <= 0 or platform_radius <= 0:
            raise ConfigError('tripod_3rps needs base_radius, platform_radius > 0 and 0 < leg_min < leg_max')
        self.R = float(base_radius)
        self.r = float(platform_radius)
        self.leg_min = float(leg_min)
        self.leg_max = float(leg_max)
        self.beta = np.array([0.0, 2 * np.pi / 3, 4 * np.pi / 3])
        # the directions u_i of the joints at 0, 120, 240 deg, from their exact coordinates (1, 0), (-1/2, +-sqrt(3)/2):
        # cos(2 pi / 3) of the float 2 pi / 3 is -0.4999999999999998, whose one-ulp enclosure missed the real -1/2
        h = sqrt3_over_2()
        self.unit_cos = [Interval.point(1.0), Interval.point(-0.5), Interval.point(-0.5)]
        self.unit_sin = [Interval.point(0.0), h, -h]
        self.units_xy = np.array([[1.0, 0.0], [-0.5, math.sqrt(3.0) / 2], [-0.5, -math.sqrt(3.0) / 2]])
        self.box = np.array(box if box is not None else [[0.0, leg_max + 0.01], [-1.3, 1.3], [-1.3, 1.3]])
        s = self.r if angle_scale is None else float(angle_scale)
        self.scale = np.array([1.0, s, s])
        self.constraint_names = ('L1', 'L2', 'L3')
        self.lower = np.full(3, self.leg_min)
        self.upper = np.full(3, self.leg_max)

    def check_box(self, box: np.ndarray) -> None:
        """The parasitic ``phi = atan(...)`` of the enclosure equals the points' ``arctan2`` only where
        ``cos psi + cos theta >= 0``: ``|psi|, |theta| <= pi/2`` on the whole box."""
        widest = float(np.max(np.abs(np.asarray(box, dtype=float)[1:3])))
        if not widest <= 0.5 * np.pi:
            raise InputError(f'{self.name} workspace box: |psi| or |theta| reaches {widest:.4g} rad; allowed: at most '
                             'pi/2 (the parasitic rotation Posypkin et al. give, after Rao & Rao, is defined there)')

    def rotation(self, psi: T, th: T) -> list[list[T]]:
        """Rows of ``Rp = Ry(theta) Rx(psi) Rz(phi)`` (eq. 2, its entries eq. 3) with the parasitic ``phi``;
        intervals or symbolic expressions (:mod:`.expressions`) alike."""
        sps, cps, sth, cth = psi.sin(), psi.cos(), th.sin(), th.cos()
        phi = ((sps * sth) / (cps + cth)).arctan()
        sph, cph = phi.sin(), phi.cos()
        return [
            [cth * cph + sps * sth * sph, -(cth * sph) + sps * sth * cph, sth * cps],
            [cps * sph, cps * cph, -sps],
            [-(sth * cph) + sps * cth * sph, sth * sph + sps * cth * cph, cth * cps],
        ]

    def centre(self, z: T, rot: list[list[T]]) -> list[T]:
        """Platform centre ``(x, y, z)`` with the parasitic ``x = r/2 (Rp11 - Rp22)``, ``y = -r Rp21``."""
        return [(rot[0][0] - rot[1][1]) * (0.5 * self.r), -(rot[1][0] * self.r), z]

    def legs(self, z: T, psi: T, th: T) -> list[T]:
        """Leg lengths ``|s_i - a_i|`` (eq. 4) over intervals or symbolic expressions."""
        rot = self.rotation(psi, th)
        p = self.centre(z, rot)
        r, R = self.r, self.R
        out = []
        for cb, sb in zip(self.unit_cos, self.unit_sin, strict=True):
            s = [p[k] + (rot[k][0] * cb + rot[k][1] * sb) * r for k in range(3)]
            out.append(norm(s[0] - cb * R, s[1] - sb * R, s[2]))
        return out

    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        return self.legs(*x)

    def pose(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Platform centre p (N, 3) and rotation Rp (N, 3, 3) for (z, psi, theta) points (eqs. 2-3)."""
        z, psi, th = np.asarray(points, dtype=float).T
        phi = np.arctan2(np.sin(psi) * np.sin(th), np.cos(psi) + np.cos(th))
        n = z.shape[0]

        def rot(axis: int, a: np.ndarray) -> np.ndarray:
            c, s = np.cos(a), np.sin(a)
            m = np.zeros((n, 3, 3))
            i, j = [(1, 2), (2, 0), (0, 1)][axis]
            m[:, axis, axis] = 1.0
            m[:, i, i] = c
            m[:, j, j] = c
            m[:, i, j] = -s
            m[:, j, i] = s
            return m

        Rp = rot(1, th) @ rot(0, psi) @ rot(2, phi)
        x = 0.5 * self.r * (Rp[:, 0, 0] - Rp[:, 1, 1])
        y = -self.r * np.cos(psi) * np.sin(phi)
        return np.stack([x, y, z], axis=1), Rp

    def joints(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Base joints a (3, 3) and platform joints s (N, 3, 3) (row i = joint i) in the base frame."""
        p, Rp = self.pose(points)
        u = np.column_stack([self.units_xy, np.zeros(3)])
        s = p[:, None, :] + self.r * np.einsum('nij,kj->nki', Rp, u)
        return self.R * u, s

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        a, s = self.joints(points)
        return np.asarray(np.linalg.norm(s - a[None], axis=2))

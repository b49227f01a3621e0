"""Workspace constraint models of the seeds' mechanisms, of the GPR and of a closed-form test mechanism.

Each model is a :class:`~gpr_kinematics.workspace.WorkspaceModel`: certified interval enclosures of its
constraint functions over boxes (:meth:`enclose`) and exact point values (:meth:`evaluate`, written separately
with matrices and norms so that tests compare two independent code paths). All values SI (m, rad).

Models (``type`` key of the YAML files under ``config/mechanisms/``):

* ``tripod_3rps``: the 3-RPS tripod of seed ``workspace-nonuniform-covering-posypkin.txt`` (Fig. 8, eqs. 2-7),
  variables ``z, psi, theta``; constraints: leg lengths in ``[leg_min, leg_max]``.
* ``rrr3_planar``: the planar 3-RRR of the same seed (eqs. 8-12), variables ``x, y, phi``; constraints: each
  leg's elbow closes (eq. 8's arcsin argument in [-1, 1]) and its input angle stays within its range.
* ``dextar``: DexTAR, the seed's eqs. (1) with the intermediate angles eliminated, variables ``x, y``.
* ``upu3``: the translational 3-UPU of seed ``3upu-aboulissane.txt``, variables ``x, y, z``.
* ``gpr``: the GPR: height and tilt (rotation vector ``tilt_x, tilt_y``) within the stroke and within the
  imperfection budget of the radial virtual joints (design.md §3).
* ``shell_arm``: a spherical-shoulder two-link arm above a floor: a shell cut by a plane, closed-form volume.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .errors import ConfigError, InputError
from .interval import Interval, monotone
from .workspace import WorkspaceModel

_INF = np.inf


# ---------------------------------------------------------------------------------------------- helpers
def _num(
    params: Mapping[str, Any],
    key: str,
    default: float | None = None,
    positive: bool = False,
    source: str = 'mechanism',
) -> float:
    if key not in params or params[key] is None:
        if default is None:
            raise ConfigError(f'{source}: missing key {key!r} (a number, SI units)')
        return float(default)
    try:
        value = float(params[key])
    except (TypeError, ValueError):
        raise ConfigError(f'{source}: {key!r} must be a number, got {params[key]!r}') from None
    if not math.isfinite(value) or (positive and value <= 0):
        raise ConfigError(
            f'{source}: {key!r} must be a finite{" positive" if positive else ""} number, got {params[key]!r}'
        )
    return value


def _box_from(
    ws: Mapping[str, Any], variables: Sequence[str], default: Sequence[Sequence[float]], source: str
) -> np.ndarray:
    spec = ws.get('box') if ws else None
    box = np.array(default, dtype=float)
    if spec is None:
        return box
    if not isinstance(spec, Mapping):
        raise ConfigError(
            f'{source}: workspace.box must map variable names {list(variables)} to [lower, upper]'
        )
    for name, bounds in spec.items():
        if name not in variables:
            raise ConfigError(
                f'{source}: workspace.box has unknown variable {name!r}; allowed: {list(variables)}'
            )
        try:
            lo, hi = (float(b) for b in bounds)
        except (TypeError, ValueError):
            raise ConfigError(
                f'{source}: workspace.box.{name} must be [lower, upper], got {bounds!r}'
            ) from None
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ConfigError(f'{source}: workspace.box.{name} needs finite lower < upper, got {bounds!r}')
        box[list(variables).index(name)] = (lo, hi)
    return box


def _azimuths(params: Mapping[str, Any], key: str, default: Sequence[float], source: str) -> np.ndarray:
    value = params.get(key, default)
    try:
        arr = np.array([float(v) for v in value])
    except (TypeError, ValueError):
        raise ConfigError(f'{source}: {key!r} must be a list of 3 angles in rad, got {value!r}') from None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ConfigError(f'{source}: {key!r} must be a list of 3 finite angles in rad, got {value!r}')
    return arr


def _norm_interval(*components: Interval) -> Interval:
    """Euclidean norm of a vector of intervals: sqrt(sum of squares), outward rounded."""
    total = components[0].sqr()
    for c in components[1:]:
        total = total + c.sqr()
    return total.sqrt()


# ----------------------------------------------------------------------------------------------- tripod
class TripodModel(WorkspaceModel):
    """3-RPS tripod (seed Fig. 8): base and platform joints at azimuths 0, 120, 240 deg on radii R, r.

    Pose variables ``z`` [m], ``psi`` (about x) and ``theta`` (about y) [rad]. The parasitic motions are the
    seed's formulas (Rao & Rao): ``phi = atan(sin psi sin theta / (cos psi + cos theta))``,
    ``y = -r cos psi sin phi``, ``x = r/2 (Rp11 - Rp22)``, with ``Rp = Ry(theta) Rx(psi) Rz(phi)`` (eq. 2).
    Leg i joins ``a_i = R u_i`` to ``s_i = p + Rp r u_i``, ``u_i = (cos b_i, sin b_i, 0)``; the constraint is
    ``leg_min <= |s_i - a_i| <= leg_max`` (eq. 4; eqs. 5-7 are its components, eq. 6-7 as printed carry
    sign typos). These formulas keep each spherical joint in its leg's radial plane (tested exactly).
    ``scale`` of the angles: the platform radius ``r`` (an angle step moves a joint by about ``r`` times it).
    """

    name = 'tripod_3rps'
    variables = ('z', 'psi', 'theta')
    units = ('m', 'rad', 'rad')

    def __init__(
        self,
        base_radius: float = 0.05,
        platform_radius: float = 0.05,
        leg_min: float = 0.07,
        leg_max: float = 0.13,
        box: np.ndarray | None = None,
        angle_scale: float | None = None,
    ) -> None:
        if not (0 < leg_min < leg_max) or base_radius <= 0 or platform_radius <= 0:
            raise ConfigError('tripod_3rps needs base_radius, platform_radius > 0 and 0 < leg_min < leg_max')
        self.R = float(base_radius)
        self.r = float(platform_radius)
        self.leg_min = float(leg_min)
        self.leg_max = float(leg_max)
        self.beta = np.array([0.0, 2 * np.pi / 3, 4 * np.pi / 3])
        self.box = np.array(box if box is not None else [[0.0, leg_max + 0.01], [-1.3, 1.3], [-1.3, 1.3]])
        s = self.r if angle_scale is None else float(angle_scale)
        self.scale = np.array([1.0, s, s])
        self.constraint_names = ('L1', 'L2', 'L3')
        self.lower = np.full(3, self.leg_min)
        self.upper = np.full(3, self.leg_max)

    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        z, psi, th = x
        sps, cps, sth, cth = psi.sin(), psi.cos(), th.sin(), th.cos()
        phi = ((sps * sth) / (cps + cth)).arctan()
        sph, cph = phi.sin(), phi.cos()
        r, R = self.r, self.R
        rp11 = cth * cph + sps * sth * sph
        rp12 = -(cth * sph) + sps * sth * cph
        rp21 = cps * sph
        rp22 = cps * cph
        rp31 = -(sth * cph) + sps * cth * sph
        rp32 = sth * sph + sps * cth * cph
        px = (rp11 - rp22) * (0.5 * r)
        py = -(rp21 * r)
        out = []
        for b in self.beta:
            cb, sb = Interval.const(math.cos(b)), Interval.const(math.sin(b))
            if b == 0.0:
                cb, sb = Interval.point(1.0), Interval.point(0.0)
            sx = px + (cb * rp11 + sb * rp12) * r - cb * R
            sy = py + (cb * rp21 + sb * rp22) * r - sb * R
            sz = z + (cb * rp31 + sb * rp32) * r
            out.append(_norm_interval(sx, sy, sz))
        return out

    def pose(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Platform centre p (N, 3) and rotation Rp (N, 3, 3) for (z, psi, theta) points, seed eqs. 2-3."""
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
        u = np.stack([np.cos(self.beta), np.sin(self.beta), np.zeros(3)], axis=1)
        s = p[:, None, :] + self.r * np.einsum('nij,kj->nki', Rp, u)
        return self.R * u, s

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        a, s = self.joints(points)
        return np.linalg.norm(s - a[None], axis=2)


# ------------------------------------------------------------------------------------------- planar 3-RRR
class Rrr3PlanarModel(WorkspaceModel):
    """Planar 3-RRR (seed Fig. 12, eqs. 8-12): reachable ``(x, y, phi)`` of the output link.

    Leg i: base pivot ``A_i = R (cos b_i, sin b_i)``, crank ``l1`` at input angle ``theta_i``, coupler ``l2``
    to ``C_i = (x, y) + l3 (cos(g_i + phi), sin(g_i + phi))``. With ``v = C_i - A_i`` the closure
    ``|v - l1 u(theta)| = l2`` reads ``v . u = k``, ``k = (|v|^2 + l1^2 - l2^2) / (2 l1)``; the seed's eq. (8)
    ``theta = arcsin(...) - phi_aux`` is the branch ``u = (k v + sqrt(|v|^2 - k^2) J v) / |v|^2`` (J: +90 deg
    rotation), the one used here (``branch: 1``; ``-1`` gives the other working mode). Constraints per leg:
    ``|v|^2 - k^2 >= 0`` (eq. 8's arcsin argument within [-1, 1]) and ``u . m_i >= cos(half range)`` where
    ``m_i`` is the crank direction at the middle of the allowed input range, which is measured from the
    crank's direction in the home pose ``x = y = phi = 0`` (the seed gives the range, -45..45 deg, but not
    its origin: this choice is ours). No angle wrap-around issues: the test is on unit vectors.
    """

    name = 'rrr3_planar'
    variables = ('x', 'y', 'phi')
    units = ('m', 'm', 'rad')

    def __init__(
        self,
        base_radius: float = 0.1,
        platform_radius: float = 0.05,
        crank: float = 0.05,
        coupler: float = 0.05,
        theta_min: float = -math.pi / 4,
        theta_max: float = math.pi / 4,
        base_angles: Sequence[float] = (math.pi / 2, 7 * math.pi / 6, 11 * math.pi / 6),
        platform_angles: Sequence[float] | None = None,
        branch: int = 1,
        box: np.ndarray | None = None,
        angle_scale: float | None = None,
    ) -> None:
        if min(base_radius, platform_radius, crank, coupler) <= 0:
            raise ConfigError('rrr3_planar needs positive base_radius, platform_radius, crank, coupler')
        if not theta_min < theta_max < theta_min + 2 * math.pi:
            raise ConfigError('rrr3_planar needs theta_min < theta_max < theta_min + 2 pi (rad)')
        if branch not in (1, -1):
            raise ConfigError(f'rrr3_planar branch must be 1 or -1, got {branch!r}')
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
        self.branch = int(branch)
        self.theta_min, self.theta_max = float(theta_min), float(theta_max)
        self.A = self.R * np.stack([np.cos(self.base_angles), np.sin(self.base_angles)], axis=1)
        home = self.crank_directions(np.zeros((1, 3)))[0]  # (3, 2)
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
        return (k[..., None] * v + s[..., None] * jv) / vv[..., None]

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        v = self._v(points)
        vv = np.sum(v * v, axis=2)
        k = (vv + self.l1**2 - self.l2**2) / (2 * self.l1)
        u = self.crank_directions(points)
        cosang = np.sum(u * self.m[None], axis=2)
        return np.concatenate([vv - k * k, cosang], axis=1)

    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        px, py, phi = x
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

    def input_angles(self, points: np.ndarray) -> np.ndarray:
        """Input angles theta_i - theta_i(home) (N, 3) in (-pi, pi] [rad]."""
        u = self.crank_directions(points)
        home = self.crank_directions(np.zeros((1, 3)))[0]
        return np.arctan2(
            home[None, :, 0] * u[..., 1] - home[None, :, 1] * u[..., 0], np.sum(home[None] * u, axis=2)
        )


# ----------------------------------------------------------------------------------------------- DexTAR
class DextarModel(WorkspaceModel):
    """DexTAR five-bar, seed eqs. (1): ``x = la cos q1 + lb cos q3 + d/2``, ``y = la sin q1 + lb sin q3`` and
    ``x = -d/2 + ld cos q2 + lc cos q4``, ``y = ld sin q2 + lc sin q4``.

    DexTAR's joints turn without limits (its arms pass each other), so eliminating the passive angles q3,
    q4 and the inputs q1, q2 leaves: ``(x, y)`` is reachable iff ``|la - lb| <= |P - A1| <= la + lb`` and
    ``|ld - lc| <= |P - A2| <= ld + lc`` with ``A1 = (d/2, 0)``, ``A2 = (-d/2, 0)``: the seed's "lowered
    dimension" form, 2-D instead of its 6-D boxes. Its area has a closed form (:meth:`exact_area`).
    The seed gives no DexTAR dimensions; the defaults are illustrative (see docs/workspace.md).
    """

    name = 'dextar'
    variables = ('x', 'y')
    units = ('m', 'm')

    def __init__(
        self,
        la: float = 0.2,
        lb: float = 0.2,
        lc: float = 0.2,
        ld: float = 0.2,
        d: float = 0.2,
        box: np.ndarray | None = None,
    ) -> None:
        if min(la, lb, lc, ld) <= 0 or d < 0:
            raise ConfigError('dextar needs positive link lengths la, lb, lc, ld and d >= 0 (m)')
        self.la, self.lb, self.lc, self.ld, self.d = (float(v) for v in (la, lb, lc, ld, d))
        reach = max(la + lb, lc + ld) + d / 2
        self.box = np.array(box if box is not None else [[-reach, reach], [-reach, reach]])
        self.scale = np.ones(2)
        self.constraint_names = ('arm1', 'arm2')
        self.lower = np.array([abs(la - lb), abs(ld - lc)])
        self.upper = np.array([la + lb, ld + lc])

    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        px, py = x
        return [_norm_interval(px - 0.5 * self.d, py), _norm_interval(px + 0.5 * self.d, py)]

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        return np.stack(
            [np.hypot(p[:, 0] - self.d / 2, p[:, 1]), np.hypot(p[:, 0] + self.d / 2, p[:, 1])], axis=1
        )

    def exact_area(self) -> float:
        """Closed-form area [m^2]: annulus ∩ annulus by inclusion-exclusion of disc-disc lens areas."""
        ro1, ri1 = self.la + self.lb, abs(self.la - self.lb)
        ro2, ri2 = self.ld + self.lc, abs(self.ld - self.lc)
        lens = _lens_area
        return (
            lens(ro1, ro2, self.d) - lens(ro1, ri2, self.d) - lens(ri1, ro2, self.d) + lens(ri1, ri2, self.d)
        )


def _lens_area(r1: float, r2: float, d: float) -> float:
    """Area of the intersection of two discs of radii r1, r2 whose centres are d apart."""
    if r1 <= 0 or r2 <= 0 or d >= r1 + r2:
        return 0.0
    if d <= abs(r1 - r2):
        return math.pi * min(r1, r2) ** 2
    a1 = r1 * r1 * math.acos((d * d + r1 * r1 - r2 * r2) / (2 * d * r1))
    a2 = r2 * r2 * math.acos((d * d + r2 * r2 - r1 * r1) / (2 * d * r2))
    a3 = 0.5 * math.sqrt((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2))
    return a1 + a2 - a3


# ------------------------------------------------------------------------------------------------- 3-UPU
class Upu3Model(WorkspaceModel):
    """Translational 3-UPU (seed ``3upu-aboulissane.txt``): base joints ``B_i = b u_i``, platform joints
    ``P + p u_i`` (same azimuths), limb ``l_i = |P + p u_i - b u_i|`` in ``[limb_min, limb_max]``.

    The seed places the base triangle in its yz plane (its x axis normal to the base); here the base is the
    xy plane with z up (REP 103), so the seed's x is our z. The shapes (an upper dome over a lower one,
    Figs. 7-9) are the same. Only the half-space above the base is kept (the box starts at z = 0).
    """

    name = 'upu3'
    variables = ('x', 'y', 'z')
    units = ('m', 'm', 'm')

    def __init__(
        self,
        b: float = 0.2,
        p: float = 0.17,
        limb_min: float = 0.17,
        limb_max: float = 0.27,
        azimuths: Sequence[float] = (math.pi / 2, 7 * math.pi / 6, 11 * math.pi / 6),
        box: np.ndarray | None = None,
    ) -> None:
        if b <= 0 or p <= 0 or not 0 < limb_min < limb_max:
            raise ConfigError('upu3 needs b > 0, p > 0 and 0 < limb_min < limb_max (m)')
        self.b, self.p, self.limb_min, self.limb_max = float(b), float(p), float(limb_min), float(limb_max)
        self.azimuths = np.asarray(azimuths, dtype=float)
        self.centres = (self.b - self.p) * np.stack(
            [np.cos(self.azimuths), np.sin(self.azimuths), np.zeros(3)], axis=1
        )
        reach = self.limb_max + abs(self.b - self.p)
        self.box = np.array(
            box if box is not None else [[-reach, reach], [-reach, reach], [0.0, self.limb_max]]
        )
        self.scale = np.ones(3)
        self.constraint_names = ('l1', 'l2', 'l3')
        self.lower = np.full(3, self.limb_min)
        self.upper = np.full(3, self.limb_max)

    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        px, py, pz = x
        return [_norm_interval(px - float(c[0]), py - float(c[1]), pz) for c in self.centres]

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        return np.linalg.norm(p[:, None, :] - self.centres[None], axis=2)


# ----------------------------------------------------------------------------------------------- GPR
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
    (``Rot = exp(alpha [a]x)``, ``a = (cos g, sin g, 0)``, design.md §2). Every virtual-joint model keeps the
    joints in the platform plane, so the platform plane is the plane through the ``P_k``: with ``n = Rot e_z``
    it gives exactly ``q_k = z + R tan(alpha)/alpha (tilt_x sin t_k - tilt_y cos t_k)``.

    Constraints: ``stroke_min <= q_k <= stroke_max`` and ``|dl_k| <= imperfection_budget`` where ``dl_k`` is
    the radial virtual-joint displacement (``radial`` model, design.md §3: joint k at ``(R + dl_k)`` along its
    azimuth). Side lengths: ``L_ij^2 = 3 R^2 + d_ij^2``, ``d_ij = q_j - q_i``; with joints 120 deg apart
    ``|r_i - r_j|^2 = l_i^2 + l_j^2 + l_i l_j``, so ``3 R (dl_i + dl_j) + Q_ij = d_ij^2`` with
    ``Q_ij = dl_i^2 + dl_j^2 + dl_i dl_j``.

    Certified enclosure (derived in docs/workspace.md): write ``S dl = (D - Q)/(3R)`` with the pair matrix
    ``S`` (inverse ``S^-1 = 1/2 [[1,-1,1],[1,1,-1],[-1,1,1]]`` on pairs 12, 23, 31) and ``D_ij = d_ij^2``.
    The linear part ``dl_lin = S^-1 D / (3R)`` is enclosed by interval arithmetic; the remainder obeys
    ``|dl - dl_lin|_inf <= 1.5 e^2 / R`` where ``e = |dl|_inf``, and on the branch through ``dl = 0`` (the
    one Newton from the singular configuration follows) ``e <= e1 = 2 m / (1 + sqrt(1 - 6 m / R))`` with
    ``m = |dl_lin|_inf`` whenever ``6 m < R``. Boxes where that fails are left undecided.
    """

    name = 'gpr'
    variables = ('z', 'tilt_x', 'tilt_y')
    units = ('m', 'rad', 'rad')

    def __init__(
        self,
        radius: float = 0.093218,
        rod_azimuths: Sequence[float] = (0.0, 2 * math.pi / 3, 4 * math.pi / 3),
        stroke_min: float = 0.0,
        stroke_max: float = 0.508,
        imperfection_budget: float = 0.0005,
        box: np.ndarray | None = None,
        angle_scale: float | None = None,
        max_tilt: float = 0.3,
    ) -> None:
        if radius <= 0 or not stroke_min < stroke_max or imperfection_budget <= 0:
            raise ConfigError(
                'gpr workspace needs radius > 0, stroke_min < stroke_max, imperfection_budget > 0'
            )
        self.R = float(radius)
        self.az = np.asarray(rod_azimuths, dtype=float)
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
        self.constraint_names = ('q1', 'q2', 'q3', 'dl1', 'dl2', 'dl3')
        self.lower = np.array([self.stroke_min] * 3 + [-self.budget] * 3)
        self.upper = np.array([self.stroke_max] * 3 + [self.budget] * 3)

    def check_box(self, box: np.ndarray) -> None:
        """The enclosure of tan(alpha)/alpha needs alpha < pi/2 on the whole box: |tilt| < 1.5 rad."""
        corner = float(np.hypot(np.max(np.abs(box[1])), np.max(np.abs(box[2]))))
        if not corner < 1.5:
            raise InputError(f'gpr workspace box: the tilt magnitude at the box corners is {corner:.4g} rad; '
                             'allowed: below 1.5 rad (tan(alpha)/alpha must stay monotone)')

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
        return z[:, None] - (n[:, 0, None] * hx[None] + n[:, 1, None] * hy[None]) / n[:, 2, None]

    def radial_displacements(self, q: np.ndarray) -> np.ndarray:
        """Radial virtual-joint displacements dl (N, 3) [m] for rod lengths q (N, 3): Newton on
        ``l_i^2 + l_j^2 + l_i l_j = 3 R^2 + (q_j - q_i)^2`` from ``l = R`` (the radial model)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        pairs = ((0, 1), (1, 2), (2, 0))
        D = np.stack([(q[:, j] - q[:, i]) ** 2 for i, j in pairs], axis=1)
        dl = np.zeros_like(q)
        for _ in range(30):
            F = (
                np.stack(
                    [
                        3 * self.R * (dl[:, i] + dl[:, j])
                        + dl[:, i] ** 2
                        + dl[:, j] ** 2
                        + dl[:, i] * dl[:, j]
                        for i, j in pairs
                    ],
                    axis=1,
                )
                - D
            )
            J = np.zeros((q.shape[0], 3, 3))
            for row, (i, j) in enumerate(pairs):
                J[:, row, i] = 3 * self.R + 2 * dl[:, i] + dl[:, j]
                J[:, row, j] = 3 * self.R + 2 * dl[:, j] + dl[:, i]
            step = np.linalg.solve(J, F[..., None])[..., 0]
            dl = dl - step
            if np.max(np.abs(step)) < 1e-17:
                break
        return dl

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        q = self.actuators(points)
        return np.concatenate([q, self.radial_displacements(q)], axis=1)

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
        pairs = ((0, 1), (1, 2), (2, 0))
        # d_ij = q_j - q_i = R t (wx (s_j - s_i) - wy (c_j - c_i)): computed without z (no cancellation)
        D = [(t * (wx * (s[j] - s[i]) - wy * (c[j] - c[i])) * R).sqr() for i, j in pairs]
        inv6R = Interval.point(1.0) / (Interval.point(R) * 6.0)
        lin_dl = [(D[0] - D[1] + D[2]) * inv6R, (D[0] + D[1] - D[2]) * inv6R, (D[1] + D[2] - D[0]) * inv6R]
        m = np.maximum.reduce([np.maximum(np.abs(v.lo), np.abs(v.hi)) for v in lin_dl])
        m = m * (1 + 1e-12)
        ok = 6.0 * m < R * (1 - 1e-9)
        with np.errstate(invalid='ignore'):
            e1 = 2.0 * m / (1.0 + np.sqrt(np.maximum(1.0 - 6.0 * m / R, 0.0)))
        rem = np.where(ok, 1.5 * e1 * e1 / R * (1 + 1e-9) + 1e-300, _INF)
        dl = [Interval(np.nextafter(v.lo - rem, -_INF), np.nextafter(v.hi + rem, _INF)) for v in lin_dl]
        return q + dl


# ------------------------------------------------------------------------------------------ shell arm (test)
class ShellArmModel(WorkspaceModel):
    """Test mechanism with a closed-form workspace: a two-link arm with a spherical shoulder at the origin
    (upper arm ``l1``, forearm ``l2``, elbow revolute, no joint limits) above a floor ``z >= floor``.

    The wrist reaches exactly the shell ``|l1 - l2| <= |P| <= l1 + l2``; with the floor the volume is
    ``cap(l1 + l2) - cap(|l1 - l2|)``, ``cap(rho) = pi (rho - h)^2 (2 rho + h) / 3`` for the part of a ball of
    radius ``rho`` above the plane ``z = h`` (``|h| <= rho``; 0 above, the whole ball below).
    """

    name = 'shell_arm'
    variables = ('x', 'y', 'z')
    units = ('m', 'm', 'm')

    def __init__(
        self, l1: float = 0.3, l2: float = 0.2, floor: float = -0.1, box: np.ndarray | None = None
    ) -> None:
        if l1 <= 0 or l2 <= 0:
            raise ConfigError('shell_arm needs positive l1, l2 (m)')
        self.l1, self.l2, self.floor = float(l1), float(l2), float(floor)
        reach = self.l1 + self.l2
        self.box = np.array(box if box is not None else [[-reach, reach]] * 3)
        self.scale = np.ones(3)
        self.constraint_names = ('reach', 'floor')
        self.lower = np.array([abs(self.l1 - self.l2), self.floor])
        self.upper = np.array([reach, _INF])

    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        px, py, pz = x
        return [_norm_interval(px, py, pz), pz]

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        return np.stack([np.linalg.norm(p, axis=1), p[:, 2]], axis=1)

    def exact_volume(self) -> float:
        def cap(rho: float, h: float) -> float:
            if h >= rho:
                return 0.0
            if h <= -rho:
                return 4.0 / 3.0 * math.pi * rho**3
            return math.pi * (rho - h) ** 2 * (2 * rho + h) / 3.0

        return cap(self.l1 + self.l2, self.floor) - cap(abs(self.l1 - self.l2), self.floor)


# ------------------------------------------------------------------------------------------ from YAML
MODEL_TYPES = ('tripod_3rps', 'rrr3_planar', 'dextar', 'upu3', 'gpr', 'shell_arm')


def model_from_mapping(
    data: Mapping[str, Any], source: str = 'mechanism', overrides: Mapping[str, Any] | None = None
) -> WorkspaceModel:
    """Build the workspace model of a mechanism description (the YAML's mapping; SI units).

    ``type`` selects the model; the mechanism keys are read at the top level; the ``workspace:`` section may
    give ``box`` (variable -> [lower, upper]) and ``angle_scale`` (m per rad for the diameter).
    ``overrides`` replace top-level keys (e.g. ``{'b': 0.25}`` for the 3-UPU studies).
    """
    if not isinstance(data, Mapping):
        raise ConfigError(f'{source}: a mechanism file must be a YAML mapping with a "type" key')
    data = dict(data)
    if overrides:
        data.update(overrides)
    kind = data.get('type')
    if kind not in MODEL_TYPES:
        raise ConfigError(
            f'{source}: unknown mechanism type {kind!r}; workspace models exist for {", ".join(MODEL_TYPES)}'
        )
    ws = data.get('workspace') or {}
    if not isinstance(ws, Mapping):
        raise ConfigError(f'{source}: the workspace section must be a mapping')
    src = f'{source} ({kind})'

    def n(key: str, default: float | None = None, positive: bool = False) -> float:
        return _num(data, key, default, positive, src)

    scale = ws.get('angle_scale')
    scale = None if scale is None else _num(ws, 'angle_scale', positive=True, source=src)
    mech = _mechanism(data, source) if kind in ('tripod_3rps', 'upu3') else None
    if kind == 'tripod_3rps':
        lo, hi = (float(v) for v in mech.joint_limits[0])
        model: WorkspaceModel = TripodModel(
            mech.base_radius,
            mech.platform_radius,
            lo,
            hi,
            angle_scale=scale if scale is not None else mech.characteristic_length,
        )
    elif kind == 'rrr3_planar':
        model = Rrr3PlanarModel(
            n('base_radius', positive=True),
            n('platform_radius', positive=True),
            n('crank', positive=True),
            n('coupler', positive=True),
            n('theta_min', -math.pi / 4),
            n('theta_max', math.pi / 4),
            _azimuths(data, 'base_angles', (math.pi / 2, 7 * math.pi / 6, 11 * math.pi / 6), src),
            None if 'platform_angles' not in data else _azimuths(data, 'platform_angles', (), src),
            int(n('branch', 1)),
            angle_scale=scale,
        )
    elif kind == 'dextar':
        model = DextarModel(
            n('la', positive=True),
            n('lb', positive=True),
            n('lc', positive=True),
            n('ld', positive=True),
            n('d'),
        )
    elif kind == 'upu3':
        lo, hi = (float(v) for v in mech.joint_limits[0])
        model = Upu3Model(mech.b, mech.p, lo, hi, np.asarray(mech.azimuths, dtype=float))
    elif kind == 'gpr':
        model = _gpr_model(data, ws, src, scale)
    else:
        model = ShellArmModel(n('l1', positive=True), n('l2', positive=True), n('floor', -_INF))
    model.box = _box_from(ws, model.variables, model.box, src)
    try:
        model.check_box(model.box)
    except InputError as exc:
        raise ConfigError(f'{src}: {exc}') from None
    return model


def _mechanism(data: Mapping[str, Any], source: str) -> Any:
    """The validated :class:`~gpr_kinematics.mechanisms.Mechanism` (the mechanisms issue's interface)."""
    from .mechanisms import mechanism_from_dict

    return mechanism_from_dict(data, source)


def _gpr_model(data: Mapping[str, Any], ws: Mapping[str, Any], src: str, scale: float | None) -> GprModel:
    """GPR parameters from the mechanisms interface (``type: gpr``, optional ``overrides`` of GprConfig)."""
    vj = ws.get('virtual_joint_model', 'radial')
    if vj != 'radial':
        raise ConfigError(f'{src}: workspace.virtual_joint_model {vj!r} has no certified enclosure; allowed: radial')
    cfg = _mechanism(data, src).config
    max_tilt = _num(ws, 'max_tilt', 0.3, True, src)
    return GprModel(
        cfg.radius,
        tuple(float(a) for a in cfg.rod_azimuths),
        cfg.stroke_min,
        cfg.stroke_max,
        cfg.imperfection_budget,
        angle_scale=scale,
        max_tilt=max_tilt,
    )


def load_workspace_model(path: str | Path, overrides: Mapping[str, Any] | None = None) -> WorkspaceModel:
    """Read a mechanism YAML file (``type`` key, SI parameters, optional ``workspace:`` section)."""
    from .mechanisms import read_mechanism_file

    data, p = read_mechanism_file(path)
    return model_from_mapping(data, str(p), overrides)

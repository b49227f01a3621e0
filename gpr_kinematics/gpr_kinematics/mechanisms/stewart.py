"""6-SPS Gough-Stewart platform: inverse and forward kinematics and the accuracy model of Alwan.

Alwan 2011 (``docs/references.md``). Leg ``i`` joins the base joint ``R_ai`` (base frame) to
the platform joint ``R_bi`` (platform frame); its length is ``s_i = |R_o + A_ol R_bi - R_ai|`` (eq. 1), and
the closure is ``G_i(s, u) = |R_o + A_ol R_bi - R_ai|^2 - s_i^2 = 0`` (eqs. 2-4) with the pose
``u = (x, y, z, psi, theta, phi)``: metres and **Z-X-Z intrinsic Euler angles** (rad),
``A_ol = Rz(psi) Rx(theta) Rz(phi)`` (scipy ``from_euler('ZXZ', [psi, theta, phi])``): under this convention
the paper's pose-1 leg lengths reproduce (its printed matrix entries ``a_11 ... a_33`` contain typos).

The platform is a GSP whose six constraints are all D1 (SPS legs), so the inverse Jacobian rows are
``[n_i, (A_ol R_bi) x n_i]`` with ``n_i`` the unit leg vector. Forward kinematics is Newton's method on the
six Euler coordinates (:meth:`Mechanism.forward_kinematics`). The accuracy analysis of eq. (7) is in
:mod:`gpr_kinematics.mechanisms.accuracy`; this class supplies the closed-form parameter derivatives
``d s_i / d R_ai = -n_i`` and ``d s_i / d R_bi = A_ol^T n_i``.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError, brief
from ..inputs.schema import check_keys, number_array, number_key, orientation_angle
from ..inputs.validation import MAX_COORDINATE
from .base import as_poses, check_euler_convention
from .conditioning import check_characteristic_length
from .gsp import Constraint, GeneralizedStewartPlatform


def _vector(data: Mapping[str, Any], key: str, source: str, length: int, unit: str) -> np.ndarray:
    val = data.get(key)
    arr = number_array(val, (length,))
    if arr is None:
        raise ConfigError(f'{source}: {key} must be a list of {length} finite numbers ({unit}, |value| <= '
                          f'{MAX_COORDINATE:g}); got {brief(val)}')
    return arr


def _points(data: Mapping[str, Any], prefix: str, source: str) -> np.ndarray:
    """Six joint points ``(6, 3)`` from ``<prefix>_points`` or ``<prefix>_radius`` + ``<prefix>_azimuths``."""
    if f'{prefix}_points' in data:
        val = data[f'{prefix}_points']
        arr = number_array(val, (6, 3))
        if arr is None:
            raise ConfigError(f'{source}: {prefix}_points must be 6 points [x, y, z] in m (|x| <= '
                              f'{MAX_COORDINATE:g}); got {brief(val)}')
        return arr
    r = number_key(data, f'{prefix}_radius', source)
    az = np.array([orientation_angle(float(v), f'{prefix}_azimuths[{i}]', source)   # 6 numbers, each within a turn
                   for i, v in enumerate(_vector(data, f'{prefix}_azimuths', source, 6, 'rad'))])
    h = number_key(data, f'{prefix}_height', source, default=0.0, positive=False)
    return np.column_stack([r * np.cos(az), r * np.sin(az), np.full(6, h)])


class StewartPlatform(GeneralizedStewartPlatform):
    """6-SPS Gough-Stewart platform (six D1 constraints), Z-X-Z Euler angles by default."""

    kind = 'stewart_6sps'

    def __init__(self, base_points: Any, platform_points: Any, name: str = 'Gough-Stewart platform',
                 characteristic_length: float = 1.0, euler_convention: str = 'ZXZ',
                 leg_limits: tuple[float, float] | None = None,
                 trajectory: np.ndarray | None = None, leg_deformations: np.ndarray | None = None,
                 source: str = '') -> None:
        a = np.asarray(base_points, dtype=float)
        b = np.asarray(platform_points, dtype=float)
        if a.shape != (6, 3) or b.shape != (6, 3):
            raise ConfigError(f'base and platform points must have shape (6, 3); got {a.shape} and {b.shape}')
        cons = [Constraint(type='D1', A_i=a[k], B_i=b[k], name=f's{k + 1}', limits=leg_limits)
                for k in range(6)]
        super().__init__(cons, name=name, characteristic_length=characteristic_length,
                         euler_convention=euler_convention, source=source)
        self.trajectory = None if trajectory is None else np.asarray(trajectory, dtype=float)
        self.leg_deformations = (None if leg_deformations is None
                                 else np.asarray(leg_deformations, dtype=float))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = '<dict>') -> StewartPlatform:
        """Build from YAML: ``base_radius``/``base_azimuths`` or ``base_points``, same for ``platform``."""
        allowed = {'type', 'name', 'characteristic_length', 'euler', 'base_radius', 'base_azimuths',
                   'base_height', 'base_points', 'platform_radius', 'platform_azimuths', 'platform_height',
                   'platform_points', 'leg_min', 'leg_max', 'trajectory', 'leg_deformations', 'reference',
                   'workspace'}
        check_keys(data, allowed, source)
        a = _points(data, 'base', source)
        b = _points(data, 'platform', source)
        given = 'characteristic_length' in data
        L = check_characteristic_length(
            data['characteristic_length'] if given else float(np.mean(np.linalg.norm(b, axis=1))),
            f'{source}: characteristic_length' + ('' if given else ' (the platform points\' mean radius when none '
                                                                   'is given)'))
        euler = data.get('euler', 'ZXZ')
        try:
            check_euler_convention(euler)
        except InputError as exc:
            raise ConfigError(f'{source}: euler: {exc}') from None
        limits = None
        if 'leg_min' in data or 'leg_max' in data:
            lo = number_key(data, 'leg_min', source, positive=False)
            hi = number_key(data, 'leg_max', source)
            if not lo < hi:
                raise ConfigError(f'{source}: leg_min = {lo} must be below leg_max = {hi} (m)')
            limits = (lo, hi)
        traj = None
        if 'trajectory' in data:
            raw = data['trajectory']
            traj = number_array(raw, (len(raw), 6)) if isinstance(raw, list) and raw else None
            if traj is None:
                raise ConfigError(f'{source}: trajectory must be a list of poses [x, y, z, psi, theta, phi] '
                                  f'(m, rad); got {brief(data["trajectory"])}')
        dq = _vector(data, 'leg_deformations', source, 6, 'm') if 'leg_deformations' in data else None
        return cls(a, b, name=str(data.get('name', 'Gough-Stewart platform')), characteristic_length=L,
                   euler_convention=euler, leg_limits=limits, trajectory=traj, leg_deformations=dq, source=source)

    # ------------------------------------------------------------------ parameters
    def parameters(self) -> dict[str, np.ndarray]:
        """``A_i`` (base joints R_ai, base frame) and ``B_i`` (platform joints R_bi, platform frame), m."""
        return {'A_i': self.A_i.copy(), 'B_i': self.B_i.copy()}

    def parameter_jacobian(self, poses: Any, name: str, step: float = 1e-7) -> np.ndarray:
        """Closed form ``d s / d A_i``, ``d s / d B_i`` ``(N, 6, 18)`` (block-diagonal, row-major points)."""
        arr, _ = as_poses(poses)
        if name not in ('A_i', 'B_i'):
            raise InputError(f'{self.name}: unknown parameter {brief(name)}; allowed: A_i, B_i')
        R, _, v, _ = self._terms(arr)
        n = v / np.linalg.norm(v, axis=-1, keepdims=True)
        blocks = -n if name == 'A_i' else np.einsum('nji,nkj->nki', R, n)  # R^T n
        out = np.zeros((arr.shape[0], 6, 6, 3))
        k = np.arange(6)
        out[:, k, k, :] = blocks
        return out.reshape(arr.shape[0], 6, 18)

    def leg_lengths(self, poses: Any) -> np.ndarray:
        """Leg lengths ``s (N, 6)`` (m), eq. (1)."""
        return self.inverse_kinematics(poses)

    def forward(self, lengths: Any, guess: Any | None = None, tol: float = 1e-12) -> np.ndarray:
        """Forward kinematics: poses ``(N, 6)`` with leg lengths ``(N, 6)``, Newton from ``guess``.

        Without ``guess`` the start is the platform centred above the base at the mean leg length, untilted.
        """
        s = np.atleast_2d(np.asarray(lengths, dtype=float))
        if s.shape[-1] != 6 or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise InputError(f'leg lengths must be 6 positive finite numbers (m) per pose; got {brief(lengths)}')
        if guess is None:
            dz = np.mean(self.B_i[:, 2] - self.A_i[:, 2])
            guess = np.zeros((s.shape[0], 6))
            guess[:, 2] = np.sqrt(np.maximum(np.mean(s, axis=1) ** 2 - np.mean(
                np.sum((self.A_i - self.B_i)[:, :2] ** 2, axis=1)), 1e-6)) - dz
        return self.forward_kinematics(s, guess, tol=tol)


def load_stewart(data: Mapping[str, Any], source: str) -> StewartPlatform:
    """YAML loader entry for ``type: stewart_6sps``."""
    return StewartPlatform.from_dict(data, source)

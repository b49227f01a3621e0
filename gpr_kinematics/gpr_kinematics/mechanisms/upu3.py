"""3-UPU translational parallel manipulator (Aboulissane & El Bakkali, ``docs/references.md``).

Base joints ``B_i = b (cos t_i, sin t_i, 0)`` and platform joints ``P_i = p (cos t_i, sin t_i, 0)`` (platform
frame) on equilateral triangles of circumradius ``b`` and ``p`` (m); the platform only translates, its
centre at ``h = (x, y, z)`` in the base frame (z up; the paper puts the base in its yz plane, which is the
same mechanism in rotated axes). Limb ``i`` is the vector ``l_i = h + P_i - B_i`` (eqs. 2-4) and its
length ``l_i = |h - u_i|`` with ``u_i = B_i - P_i`` (eq. 6, positive root).

Jacobian (eqs. 7-10): ``J v_h = l'`` with rows the unit limb vectors ``S_3i = l_i / l_i``. It is singular when
the three unit vectors are linearly dependent: all limbs parallel (only when ``b = p``: then ``u_i = 0`` and every limb
vector is ``h``, at every pose; Aboulissane & El Bakkali, sec. IV, Fig. 4) or coplanar (e.g. the platform in the base
plane, ``z = 0``). Dexterity is the inverse
condition number of ``J`` (dimensionless: the 3-UPU has only linear coordinates); at the centre line
``h = (0, 0, z)`` it is ``min(a, c) / max(a, c)`` with ``a = sqrt(3/2) |b - p|`` and ``c = sqrt(3) z``, so
it falls with height once ``c > a``, as the paper's Fig. 6 shows.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError, brief
from ..inputs.schema import check_keys, number_array, number_key, orientation_angle
from ..inputs.validation import bounded
from .base import Mechanism, as_poses, dexterity_index
from .conditioning import check_characteristic_length

SINGULARITY_TOLERANCE = 1e-9
#: Least angle between two limbs' azimuths [rad] (modulo 2 pi); closer, two limbs share one joint pair.
AZIMUTH_GAP = 1e-6


def azimuth_gaps(az: np.ndarray) -> np.ndarray:
    """The angles ``(n, n)`` [rad, 0 to pi] between azimuths ``az (n,)`` modulo 2 pi."""
    return np.asarray(np.abs(np.angle(np.exp(1j * (az[:, None] - az[None, :])))), dtype=np.float64)


def check_azimuths(azimuths: Any, name: str = 'base_azimuths') -> np.ndarray:
    """The limbs' azimuths as a ``(3,)`` array [rad], else :class:`ConfigError`: three finite angles, no two equal
    modulo 2 pi (two limbs on one joint pair: ``J`` has rank <= 2 everywhere, not a 3-UPU). The one check of
    :class:`UPU3`, its YAML loader and the workspace model
    :class:`~gpr_kinematics.workspace.upu3.Upu3Model`."""
    try:
        az = np.asarray(azimuths, dtype=float)
    except (TypeError, ValueError, OverflowError):
        az = np.full(0, np.nan)
    if az.shape != (3,) or not np.all(np.isfinite(az)):
        raise ConfigError(f'{name} must be 3 finite angles in rad; got {brief(azimuths)}')
    gaps = azimuth_gaps(az)
    for i, j in zip(*np.triu_indices(3, 1), strict=True):
        if gaps[i, j] < AZIMUTH_GAP:
            raise ConfigError(f'{name} {np.round(az, 9).tolist()} rad: limbs {i + 1} and {j + 1} share an azimuth '
                              f'(mod 2 pi), one joint pair for two limbs; allowed: three azimuths at least '
                              f'{AZIMUTH_GAP:g} rad apart modulo 2 pi (the paper: 120 deg apart)')
    return az


def leg_limits(lower: float, upper: float, names: tuple[str, str], where: str = '') -> np.ndarray:
    """The joint limits ``(3, 2)`` [m] of three legs of stroke ``[lower, upper]``, else :class:`ConfigError` naming
    ``where`` (a file's ``'name.yaml: '`` or nothing), both keys ``names`` and the rule."""
    if not lower < upper:
        raise ConfigError(f'{where}{names[0]} = {lower} must be below {names[1]} = {upper} (m); allowed: '
                          f'{names[0]} < {names[1]}')
    return np.array([[lower, upper]] * 3, dtype=float)


def symmetric_legs(lower: float, upper: float, base_radius: float, platform_radius: float, azimuths: np.ndarray,
                   characteristic_length: float | None, names: tuple[str, str, str], mechanism: str
                   ) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
    """What a mechanism of three legs on circles (the 3-UPU, the 3-RPS tripod) is built of: the joint limits of
    :func:`leg_limits` (``names[:2]``), the characteristic length [m] (``platform_radius``, called ``names[2]``, when
    none is given), and the base and platform joints ``(3, 3)`` [m] at ``azimuths`` [rad] on circles of the radii."""
    limits = leg_limits(lower, upper, (names[0], names[1]))
    given = characteristic_length is not None
    length = check_characteristic_length(
        characteristic_length if given else platform_radius,
        f'{mechanism}: characteristic_length' + ('' if given else f' ({names[2]}, when none is given)'))
    circle = np.column_stack([np.cos(azimuths), np.sin(azimuths), np.zeros(3)])
    return limits, length, float(base_radius) * circle, float(platform_radius) * circle


class UPU3(Mechanism):
    """3-UPU translational manipulator; pose variables ``x, y, z`` (m), the rotation is always zero."""

    kind = 'upu3'
    pose_variables = ('x', 'y', 'z')
    euler_convention = 'xyz'
    joint_types = ('prismatic',) * 3
    joint_names = ('l1', 'l2', 'l3')

    def __init__(self, b: float = 0.2, p: float = 0.17, limb_min: float = 0.17, limb_max: float = 0.27,
                 azimuths: Any = (np.pi / 2, 7 * np.pi / 6, 11 * np.pi / 6), name: str = '3-UPU',
                 characteristic_length: float | None = None) -> None:
        az = check_azimuths(azimuths)
        self.b, self.p = float(b), float(p)
        self.azimuths = az
        self.name = name
        self.joint_limits, self.characteristic_length, self.base_points, self.platform_points = symmetric_legs(
            limb_min, limb_max, b, p, az, characteristic_length, ('limb_min', 'limb_max', 'p'), name)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = '<dict>') -> UPU3:
        allowed = {'type', 'name', 'b', 'p', 'limb_min', 'limb_max', 'base_azimuths', 'characteristic_length',
                   'workspace', 'reference'}
        check_keys(data, allowed, source)
        b, p = number_key(data, 'b', source), number_key(data, 'p', source)
        lo, hi = number_key(data, 'limb_min', source), number_key(data, 'limb_max', source)
        leg_limits(lo, hi, ('limb_min', 'limb_max'), f'{source}: ')
        az = data.get('base_azimuths', [np.pi / 2, 7 * np.pi / 6, 11 * np.pi / 6])
        az_arr = number_array(az, (3,))   # the one rule for YAML numbers (a 400-digit integer has no float)
        if az_arr is None:
            raise ConfigError(f'{source}: base_azimuths must be 3 finite angles in rad; got {brief(az)}')
        az_arr = np.array([orientation_angle(float(v), f'base_azimuths[{i}]', source) for i, v in enumerate(az_arr)])
        check_azimuths(az_arr, f'{source}: base_azimuths')
        L = data.get('characteristic_length')
        if L is not None:
            L = check_characteristic_length(L, f'{source}: characteristic_length')
        return cls(b, p, lo, hi, az_arr, name=str(data.get('name', '3-UPU')), characteristic_length=L)

    def parameters(self) -> dict[str, np.ndarray]:
        """``base_points`` and ``platform_points`` ``(3, 3)`` (m)."""
        return {'base_points': self.base_points.copy(), 'platform_points': self.platform_points.copy()}

    def with_parameters(self, params: Mapping[str, Any]) -> UPU3:
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        for key, val in params.items():
            if key not in ('base_points', 'platform_points'):
                raise ConfigError(f'{self.name}: unknown parameter {brief(key)}; '
                                  'allowed: base_points, platform_points')
            points = bounded(val, f'{self.name}: parameter {key}')
            if points.size != 9:
                raise InputError(f'{self.name}: parameter {key} must be 9 numbers (3 points x, y, z) [m]; got '
                                 f'{points.size}')
            setattr(new, key, points.reshape(3, 3))
        return new

    def complete_pose(self, poses: Any) -> np.ndarray:
        """The 3-UPU only translates: the Euler angles of the reached pose are zero."""
        arr, single = as_poses(poses)
        out = arr.copy()
        out[:, 3:] = 0.0
        return out[0] if single else out

    def motion_basis(self, poses: Any) -> np.ndarray:
        arr, _ = as_poses(poses)
        basis = np.zeros((arr.shape[0], 6, 3))
        basis[:, :3, :3] = np.eye(3)
        return basis

    def limb_vectors(self, poses: Any) -> np.ndarray:
        """Limb vectors ``l_i = h + P_i - B_i`` ``(N, 3, 3)`` (m), eq. (4)."""
        arr, _ = as_poses(poses)
        return np.asarray(arr[:, None, :3] + self.platform_points - self.base_points)

    def inverse_kinematics(self, poses: Any) -> np.ndarray:
        """Limb lengths ``(N, 3)`` (m), eq. (6)."""
        arr, single = as_poses(poses)
        q = np.linalg.norm(self.limb_vectors(arr), axis=-1)
        return np.asarray(q[0] if single else q)

    def inverse_jacobian(self, poses: Any) -> np.ndarray:
        """``(N, 3, 6)``: rows ``[S_3i, P_i x S_3i]``; the first three columns are eq. (10)'s ``J``."""
        arr, single = as_poses(poses)
        lv = self.limb_vectors(arr)
        with np.errstate(divide='ignore', invalid='ignore'):
            S = lv / np.linalg.norm(lv, axis=-1, keepdims=True)
        J = np.concatenate([S, np.cross(np.broadcast_to(self.platform_points, S.shape), S)], axis=-1)
        return J[0] if single else J

    def unit_limb_jacobian(self, poses: Any) -> np.ndarray:
        """The paper's Jacobian ``J (N, 3, 3)`` of eq. (10): rows the unit limb vectors ``S_3i``."""
        arr, single = as_poses(poses)
        J = self.inverse_jacobian(arr)[:, :, :3]
        return J[0] if single else J

    def singularity(self, poses: Any, tol: float = SINGULARITY_TOLERANCE) -> np.ndarray:
        """Classify poses ``(N,)``: ``'parallel'`` (all limbs parallel), ``'coplanar'`` (limbs in one plane
        or otherwise linearly dependent) or ``''`` (regular), by the inverse condition number of ``J``."""
        arr, _ = as_poses(poses)
        S = self.unit_limb_jacobian(arr).reshape(-1, 3, 3)
        dex = dexterity_index(S)
        sv = np.linalg.svd(S, compute_uv=False)
        out = np.full(arr.shape[0], '', dtype=object)
        singular = dex < tol
        parallel = singular & (sv[:, 1] < tol * sv[:, 0])  # rank 1: all three directions equal (up to sign)
        out[singular] = 'coplanar'
        out[parallel] = 'parallel'
        return out


def load_upu3(data: Mapping[str, Any], source: str) -> UPU3:
    """YAML loader entry for ``type: upu3``."""
    return UPU3.from_dict(data, source)

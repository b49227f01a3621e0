"""3-RPS tripod with its parasitic motions (Posypkin et al., Fig. 8; ``docs/references.md``).

Leg ``i`` (azimuth ``a_i`` = 0, 120, 240 deg) has a revolute joint on the base at
``A_i = R (cos a_i, sin a_i, 0)`` whose axis is tangent to the base circle, so the leg moves in the vertical
plane through the z axis at azimuth ``a_i``; a prismatic joint (the actuated length ``L_i``); and a spherical
joint on the platform at ``B_i = r (cos a_i, sin a_i, 0)`` (platform frame). R and r in metres.

The tripod has three degrees of freedom, the height ``z`` and the tilts ``theta`` (about y) and ``psi``
(about x). The three other pose components are *parasitic motions* fixed by the planes of the legs
(paper's formulas, citing its ref. [4]):

- ``phi = arctan(sin(psi) sin(theta) / (cos(psi) + cos(theta)))`` (about z),
- ``y = -r cos(psi) sin(phi)``,
- ``x = r/2 (cos(theta) cos(phi) + sin(psi) sin(theta) sin(phi) - cos(psi) cos(phi))``,

the rotation (eqs. 2-3) ``R_p = Ry(theta) Rx(psi) Rz(phi)`` (scipy ``from_euler('YXZ', [theta, psi, phi])``)
and the link lengths (eqs. 4-7) ``L_i = |p + R_p B_i - A_i|``. (Eq. 7 as printed is the leg at 120 deg;
eq. 6 has the x term of a leg at 60 deg with the y and z terms of the leg at 240 deg. The lengths here use the
legs at 120 and 240 deg, for which the parasitic formulas put every spherical joint in its leg's plane, which
:meth:`Tripod3RPS.plane_residuals` checks.)

Poses are ``(x, y, z, theta, psi, phi)`` (m, rad); the pose variables are ``z, theta, psi``.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import SingularityError
from ..inputs.schema import check_keys, number_key
from .base import Mechanism, as_poses
from .conditioning import check_characteristic_length
from .upu3 import leg_limits, symmetric_legs

LEG_AZIMUTHS = np.array([0.0, 2 * np.pi / 3, 4 * np.pi / 3])
_CS_STEP = 1e-30  # complex-step size: derivatives exact to rounding, no subtraction error


def _rot(axis: str, a: np.ndarray) -> np.ndarray:
    """Elementary rotations ``(N, 3, 3)``; works on complex angles (for complex-step derivatives)."""
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    rows = {'x': [[o, z, z], [z, c, -s], [z, s, c]],
            'y': [[c, z, s], [z, o, z], [-s, z, c]],
            'z': [[c, -s, z], [s, c, z], [z, z, o]]}[axis]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def parasitic_motion(theta: Any, psi: Any, r: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(phi, x, y)`` of the platform for tilts ``theta`` (about y) and ``psi`` (about x), rad and m.

    Works on real or complex arrays (the latter for complex-step differentiation).
    """
    th, ps = np.asarray(theta), np.asarray(psi)
    with np.errstate(divide='ignore', invalid='ignore'):   # NaN where phi is not determined (undetermined_phi)
        phi = np.arctan(np.sin(ps) * np.sin(th) / (np.cos(ps) + np.cos(th)))
    y = -r * np.cos(ps) * np.sin(phi)
    x = r / 2 * (np.cos(th) * np.cos(phi) + np.sin(ps) * np.sin(th) * np.sin(phi) - np.cos(ps) * np.cos(phi))
    return phi, x, y


def undetermined_phi(theta: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """``(N,)`` True where :func:`parasitic_motion`'s ``phi`` is ``0 / 0``: ``sin(psi) sin(theta) = 0 = cos(psi) +
    cos(theta)`` (a tilt of half a turn about x or y alone; the legs' planes leave the turn about z free)."""
    return np.asarray((np.sin(psi) * np.sin(theta) == 0) & (np.cos(psi) + np.cos(theta) == 0))


def tripod_rotation(theta: Any, psi: Any, phi: Any) -> np.ndarray:
    """``R_p = Ry(theta) Rx(psi) Rz(phi)`` ``(N, 3, 3)``, eq. (2)."""
    th, ps, ph = (np.atleast_1d(np.asarray(v)) for v in (theta, psi, phi))
    return np.asarray(_rot('y', th) @ _rot('x', ps) @ _rot('z', ph))


class Tripod3RPS(Mechanism):
    """3-RPS tripod; pose ``(x, y, z, theta, psi, phi)``, variables ``z, theta, psi``."""

    kind = 'tripod_3rps'
    pose_names = ('x', 'y', 'z', 'theta', 'psi', 'phi')
    pose_variables = ('z', 'theta', 'psi')
    euler_convention = 'YXZ'
    joint_names = ('L1', 'L2', 'L3')
    joint_types = ('prismatic',) * 3

    def __init__(self, base_radius: float = 0.05, platform_radius: float = 0.05, leg_min: float = 0.07,
                 leg_max: float = 0.13, name: str = '3-RPS tripod', characteristic_length: float | None = None
                 ) -> None:
        self.base_radius, self.platform_radius = float(base_radius), float(platform_radius)
        self.name = name
        self.joint_limits, self.characteristic_length, self.base_points, self.platform_points = symmetric_legs(
            leg_min, leg_max, base_radius, platform_radius, LEG_AZIMUTHS, characteristic_length,
            ('leg_min', 'leg_max', 'platform_radius'), name)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = '<dict>') -> Tripod3RPS:
        allowed = {'type', 'name', 'base_radius', 'platform_radius', 'leg_min', 'leg_max',
                   'characteristic_length', 'workspace', 'reference'}
        check_keys(data, allowed, source)
        lo, hi = number_key(data, 'leg_min', source), number_key(data, 'leg_max', source)
        leg_limits(lo, hi, ('leg_min', 'leg_max'), f'{source}: ')
        L = data.get('characteristic_length')
        return cls(number_key(data, 'base_radius', source), number_key(data, 'platform_radius', source), lo, hi,
                   name=str(data.get('name', '3-RPS tripod')),
                   characteristic_length=None if L is None else check_characteristic_length(
                       L, f'{source}: characteristic_length'))

    # ------------------------------------------------------------------ pose
    def _complete(self, z: np.ndarray, theta: np.ndarray, psi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Position ``(N, 3)`` and rotation ``(N, 3, 3)`` for the coordinates (real or complex)."""
        phi, x, y = parasitic_motion(theta, psi, self.platform_radius)
        return np.stack([x, y, z], axis=-1), tripod_rotation(theta, psi, phi)

    def complete_pose(self, poses: Any) -> np.ndarray:
        """Fill in the parasitic ``x``, ``y`` and ``phi`` for the requested ``z``, ``theta``, ``psi``."""
        arr, single = as_poses(poses)
        free = self.undetermined(arr)
        if free.any():   # it went on as NaN to 'poses must be finite numbers', of tilts the caller gave finite
            k = int(np.argmax(free))
            raise SingularityError(
                f'{self.name}: at theta = {arr[k, 3]:.6g} rad, psi = {arr[k, 4]:.6g} rad'
                + (f' (pose {k + 1})' if arr.shape[0] > 1 else '') + ' the parasitic rotation phi is not determined '
                '(sin psi sin theta = 0 = cos psi + cos theta: half a turn about one axis, the turn about z is free); '
                'allowed: tilts where cos psi + cos theta or sin psi sin theta is not 0')
        phi, x, y = parasitic_motion(arr[:, 3], arr[:, 4], self.platform_radius)
        out = arr.copy()
        out[:, 0], out[:, 1], out[:, 5] = x, y, phi
        return out[0] if single else out

    def undetermined(self, poses: Any) -> np.ndarray:
        """``(N,)``: the tilts of which :meth:`complete_pose` cannot complete the pose (:func:`undetermined_phi`)."""
        arr, _ = as_poses(poses)
        return undetermined_phi(arr[:, 3], arr[:, 4])

    def rotation(self, poses: Any) -> np.ndarray:
        arr, _ = as_poses(poses)
        return tripod_rotation(arr[:, 3], arr[:, 4], arr[:, 5])

    def motion_basis(self, poses: Any) -> np.ndarray:
        """Twist per unit rate of ``(z, theta, psi)`` ``(N, 6, 3)``, parasitic motions included.

        Derivatives by the complex step ``f'(u) = Im f(u + i h) / h`` (exact to rounding); the angular
        velocity is ``vee(dR/du R^T)`` in the base frame.
        """
        arr, _ = as_poses(poses)
        z, th, ps = arr[:, 2], arr[:, 3], arr[:, 4]
        _, R = self._complete(z, th, ps)
        out = np.zeros((arr.shape[0], 6, 3))
        for k in range(3):
            c = [z.astype(complex), th.astype(complex), ps.astype(complex)]
            c[k] = c[k] + 1j * _CS_STEP
            pos, Rc = self._complete(*c)
            dpos, dR = pos.imag / _CS_STEP, Rc.imag / _CS_STEP
            W = dR @ np.swapaxes(R, -1, -2)
            out[:, :3, k] = dpos
            out[:, 3:, k] = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=-1)
        return out

    # ------------------------------------------------------------------ kinematics
    def joint_positions(self, poses: Any) -> np.ndarray:
        """Spherical-joint centres ``p + R_p B_i`` ``(N, 3, 3)`` in the base frame (m) of completed poses."""
        full = np.atleast_2d(self.complete_pose(poses))
        R = self.rotation(full)
        return np.asarray(full[:, None, :3] + self.platform_points @ np.swapaxes(R, -1, -2))

    def inverse_kinematics(self, poses: Any) -> np.ndarray:
        """Link lengths ``(N, 3)`` (m), eqs. (4)-(7), after completing the parasitic motions."""
        arr, single = as_poses(poses)
        q = np.linalg.norm(self.joint_positions(arr) - self.base_points, axis=-1)
        return np.asarray(q[0] if single else q)

    def inverse_jacobian(self, poses: Any) -> np.ndarray:
        """``(N, 3, 6)`` rows ``[n_i, (R_p B_i) x n_i]`` (``n_i`` unit leg vector) at the completed pose."""
        arr, single = as_poses(poses)
        full = np.atleast_2d(self.complete_pose(arr))
        R = self.rotation(full)
        Rb = self.platform_points @ np.swapaxes(R, -1, -2)
        v = full[:, None, :3] + Rb - self.base_points
        with np.errstate(divide='ignore', invalid='ignore'):  # a leg of zero length: NaN rows, dexterity 0
            n = v / np.linalg.norm(v, axis=-1, keepdims=True)
        J = np.concatenate([n, np.cross(Rb, n)], axis=-1)
        return J[0] if single else J

    def plane_residuals(self, poses: Any) -> np.ndarray:
        """Distance ``(N, 3)`` (m) of each spherical joint from its leg's vertical plane (zero by design)."""
        P = self.joint_positions(poses)
        normal = np.column_stack([-np.sin(LEG_AZIMUTHS), np.cos(LEG_AZIMUTHS), np.zeros(3)])
        return np.asarray(np.einsum('nki,ki->nk', P, normal))


def load_tripod(data: Mapping[str, Any], source: str) -> Tripod3RPS:
    """YAML loader entry for ``type: tripod_3rps``."""
    return Tripod3RPS.from_dict(data, source)

"""Parallel mechanisms' common interface; every analysis' helpers re-exported (:mod:`.rotations`, :mod:`.conditioning`).

A :class:`Mechanism` maps platform poses to actuated-joint values (inverse kinematics) and platform twists to joint
rates (inverse Jacobian). Conventions, shared by every mechanism of the package:

- A *pose* is a 6-vector ``(x, y, z, A, B, C)`` in SI units (m, rad): the position of the platform frame's origin in the
  base frame and three Euler angles whose convention each mechanism names in :attr:`Mechanism.euler_convention` (scipy
  notation: lower case = extrinsic, upper case = intrinsic). Batches are ``(N, 6)`` arrays.
- A *twist* is ``(v_x, v_y, v_z, w_x, w_y, w_z)``: the velocity of the platform origin and the angular velocity of the
  platform, **both in the base frame**. The inverse Jacobian ``(N, n, 6)`` maps twists to the rates of the ``n``
  actuated joints (m/s for prismatic/distance joints, rad/s for angular ones).
- A mechanism with fewer than six degrees of freedom (3-UPU, 3-RPS tripod, GPR) has ``m = len(pose_variables)``
  independent pose coordinates; the other pose components are outcomes (parasitic motions) that the mechanism computes:
  :meth:`Mechanism.complete_pose` returns the pose it actually reaches for the requested coordinates.
  :meth:`Mechanism.motion_basis` ``(N, 6, m)`` gives the twist produced by a unit rate of each coordinate, so
  ``inverse_jacobian @ motion_basis`` is the square Jacobian ``dq/du`` used for conditioning (for six-DOF mechanisms the
  coordinates' rates are the twist itself and the basis is the identity).

Homogenisation (Toz & Kucuk §4.3, ``docs/references.md``, characteristic length ``L``): the angular columns of an
inverse Jacobian are divided by ``L`` (an angular velocity ``w`` becomes the velocity ``L w``), and rows of angular
joints are multiplied by ``L`` (a joint rate ``theta'`` becomes ``L theta'``), so every entry is dimensionless and
singular values compare lengths with lengths.
"""
from __future__ import annotations

import abc
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.rotations import (
    check_euler_convention,
    euler_from_rotation,
    euler_rate_matrix,
    euler_rotation,
    rodrigues,
    rotation_from_vector,
    rotation_vector,
)
from ..core.stroke import within_as_millimetres
from ..errors import ConvergenceError, InputError, LimitError, SingularityError, brief
from ..inputs.validation import MAX_COORDINATE, bounded, difference_step, float_array, newton_settings, number_rows
from .conditioning import (
    ANGULAR_JOINTS,
    GRAM_CONDITION_LIMIT,
    LINEAR_JOINTS,
    SINGULAR_TOLERANCE,
    condition_number,
    dexterity_index,
    homogenize,
    is_singular,
    singular_values,
)

__all__ = ['ANGULAR_JOINTS', 'GRAM_CONDITION_LIMIT', 'LINEAR_JOINTS', 'MAX_STEP', 'POSE_COMPONENTS',
           'SINGULAR_TOLERANCE', 'JacobianReport', 'Mechanism', 'as_poses', 'check_euler_convention',
           'condition_number', 'dexterity_index', 'euler_from_rotation', 'euler_rate_matrix', 'euler_rotation',
           'homogenize', 'is_singular', 'rotation_from_vector', 'rotation_vector', 'singular_values']

POSE_COMPONENTS = ('x', 'y', 'z', 'A', 'B', 'C')

#: Largest Newton step of the rigid-motion forward kinematics (rad, or characteristic lengths).
MAX_STEP = 0.5


def as_poses(poses: Any, name: str = 'poses') -> tuple[np.ndarray, bool]:
    """Return ``poses`` as a float ``(N, 6)`` array and whether the input was a single ``(6,)`` pose."""
    arr = float_array(poses, name, 'numbers, shape (6,) or (N, 6) = (x, y, z, A, B, C) in m and rad')
    single = arr.ndim == 1
    if single:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise InputError(f'{name} must have shape (6,) or (N, 6) = (x, y, z, A, B, C) in m and rad; '
                         f'got shape {np.shape(poses)}')
    if not np.all(np.isfinite(arr)):
        raise InputError(f'{name} must be finite numbers; got {arr[~np.all(np.isfinite(arr), axis=1)][0]}')
    # angles too: beyond the bound a float angle keeps no digits modulo 2 pi
    big = np.abs(arr) > MAX_COORDINATE
    if big.any():
        i, j = np.argwhere(big)[0]
        raise InputError(f'{name}: {POSE_COMPONENTS[j]} = {arr[i, j]:.6g} {"m" if j < 3 else "rad"}; allowed: |x|, '
                         f'|y|, |z| <= {MAX_COORDINATE:g} m and |A|, |B|, |C| <= {MAX_COORDINATE:g} rad')
    return arr, single


def _solve(J: np.ndarray, res: np.ndarray, name: str) -> np.ndarray:
    """Newton step ``J^-1 res`` per batch item (pseudo-inverse for non-square ``J``)."""
    if J.shape[-1] != J.shape[-2]:
        return np.asarray(np.linalg.pinv(J) @ res[..., None])[..., 0]
    if not np.all(np.isfinite(J)):
        raise SingularityError(f'{name}: forward kinematics met a singular configuration (infinite Jacobian)')
    try:
        return np.linalg.solve(J, res[..., None])[..., 0]
    except np.linalg.LinAlgError:
        # Some item of the batch is exactly singular: least-squares steps for all (rare).
        return np.asarray(np.linalg.pinv(J) @ res[..., None])[..., 0]


@dataclass(frozen=True)
class JacobianReport:
    """Inverse Jacobian of one pose and its conditioning (the ``gpr mechanism`` output)."""

    pose: np.ndarray                          #: (6,) realised pose, m and rad
    joints: np.ndarray                        #: (n,) joint values, m or rad
    inverse_jacobian: np.ndarray              #: (n, 6) SI
    homogenized_inverse_jacobian: np.ndarray  #: (n, 6) dimensionless
    task_jacobian: np.ndarray                 #: (n, m) dq/du, homogenised
    condition_number: float                   #: of the homogenised task Jacobian
    dexterity: float                          #: inverse condition number
    singular: bool                            #: a singular Jacobian or a named singular configuration
    within_limits: bool
    singularity: str = ''                     #: the named singular configuration (:meth:`Mechanism.singularity`)


class Mechanism(abc.ABC):
    """A parallel mechanism: inverse kinematics and inverse Jacobian over batches of poses.

    Subclasses set :attr:`name`, :attr:`euler_convention`, :attr:`pose_variables`, :attr:`joint_names`,
    :attr:`joint_types`, :attr:`joint_limits` and :attr:`characteristic_length`, and implement
    :meth:`inverse_kinematics` and :meth:`inverse_jacobian`. Lower-mobility mechanisms also override
    :meth:`complete_pose` and :meth:`motion_basis`.
    """

    name: str = 'mechanism'
    kind: str = 'mechanism'
    euler_convention: str = 'xyz'
    #: Names of the six pose components (x, y, z and the three Euler angles).
    pose_names: tuple[str, ...] = POSE_COMPONENTS
    #: Names of the independent pose coordinates (a subset of :attr:`pose_names`).
    pose_variables: tuple[str, ...] = POSE_COMPONENTS
    joint_names: tuple[str, ...] = ()
    joint_types: tuple[str, ...] = ()
    joint_limits: np.ndarray = np.zeros((0, 2))
    characteristic_length: float = 1.0
    #: Base pose of dexterity maps when none is given (m, rad).
    home_pose: tuple[float, ...] = (0.0,) * 6
    #: Default dexterity sweep ``(variable, min, max)`` or None (then z over the range within the limits).
    default_sweep: tuple[str, float, float] | None = None

    # ------------------------------------------------------------------ interface
    @abc.abstractmethod
    def inverse_kinematics(self, poses: Any) -> np.ndarray:
        """Joint values ``(N, n)`` (m or rad) of poses ``(N, 6)``; a single pose ``(6,)`` gives ``(n,)``."""

    @abc.abstractmethod
    def inverse_jacobian(self, poses: Any) -> np.ndarray:
        """Inverse Jacobians ``(N, n, 6)``: joint rates per twist ``(v, w)``, ``w`` in the base frame."""

    def unlimited(self) -> Mechanism:
        """The mechanism whose kinematics compute beyond its limits, as a dexterity map needs (itself: its joint
        limits are checked apart, by :meth:`within_limits`; the GPR's core refuses poses beyond them)."""
        return self

    def pose_within_limits(self, poses: Any) -> np.ndarray:
        """``(N,)`` True where a completed pose is within the mechanism's limits on poses (none here)."""
        arr, _ = as_poses(poses)
        return np.ones(arr.shape[0], dtype=bool)

    def undetermined(self, poses: Any) -> np.ndarray:
        """``(N,)`` True where :meth:`complete_pose` cannot complete the pose (a configuration singular for its
        parasitic motions: the tripod's half turn about one axis); none here."""
        arr, _ = as_poses(poses)
        return np.zeros(arr.shape[0], dtype=bool)

    def complete_pose(self, poses: Any) -> np.ndarray:
        """The pose the mechanism reaches for the pose variables of ``poses`` (identity for 6 DOF)."""
        arr, single = as_poses(poses)
        return arr[0].copy() if single else arr.copy()

    def motion_basis(self, poses: Any) -> np.ndarray:
        """Twists ``(N, 6, m)`` per unit rate of each independent coordinate (identity for 6 DOF).

        For a six-DOF mechanism the coordinates' rates are taken as the twist itself, so conditioning
        is that of the inverse Jacobian (not of Euler-angle rates).
        """
        arr, _ = as_poses(poses)
        return np.broadcast_to(np.eye(6), (arr.shape[0], 6, 6)).copy()

    def coordinate_basis(self, poses: Any) -> np.ndarray:
        """Twists ``(N, 6, m)`` per unit rate of each pose coordinate (Euler-angle rates for 6 DOF)."""
        arr, _ = as_poses(poses)
        if len(self.pose_variables) != 6:
            return self.motion_basis(arr)
        out = np.zeros((arr.shape[0], 6, 6))
        out[:, :3, :3] = np.eye(3)
        out[:, 3:, 3:] = euler_rate_matrix(arr[:, 3:], self.euler_convention)
        return out

    # ------------------------------------------------------------------ derived
    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    @property
    def variable_indices(self) -> np.ndarray:
        """Indices of :attr:`pose_variables` in the 6-vector pose."""
        return np.array([self.pose_names.index(v) for v in self.pose_variables])

    @property
    def variable_kinds(self) -> tuple[str, ...]:
        """``'linear'`` or ``'angular'`` per pose variable (for homogenisation)."""
        return tuple('linear' if self.pose_names.index(v) < 3 else 'angular' for v in self.pose_variables)

    def coordinates(self, poses: Any) -> np.ndarray:
        """The independent coordinates ``(N, m)`` of poses ``(N, 6)``."""
        arr, single = as_poses(poses)
        out = arr[:, self.variable_indices]
        return out[0] if single else out

    def pose_from_coordinates(self, coords: Any) -> np.ndarray:
        """Complete poses ``(N, 6)`` from independent coordinates ``(N, m)``."""
        c = bounded(number_rows(coords, f'{self.name}: coordinates', len(self.variable_indices)),
                    f'{self.name}: coordinates')
        poses = np.zeros((c.shape[0], 6))
        poses[:, self.variable_indices] = c
        return self.complete_pose(poses)

    def rotation(self, poses: Any) -> np.ndarray:
        """Platform rotation matrices ``(N, 3, 3)`` of (completed) poses."""
        arr, _ = as_poses(poses)
        return euler_rotation(arr[:, 3:], self.euler_convention)

    def task_jacobian(self, poses: Any) -> np.ndarray:
        """``dq/du (N, n, m)`` per unit rate of the independent coordinates (twist rates for 6 DOF)."""
        arr, _ = as_poses(poses)
        arr = self.complete_pose(arr)
        if len(self.pose_variables) == 6 and type(self).motion_basis is Mechanism.motion_basis:
            return self.inverse_jacobian(arr)          # the basis is the identity
        return np.asarray(self.inverse_jacobian(arr) @ self.motion_basis(arr))

    def coordinate_jacobian(self, poses: Any) -> np.ndarray:
        """``dq/du (N, n, m)`` per unit rate of the pose coordinates (Euler angles for 6 DOF)."""
        arr, _ = as_poses(poses)
        arr = self.complete_pose(arr)
        return np.asarray(self.inverse_jacobian(arr) @ self.coordinate_basis(arr))

    def homogenized_inverse_jacobian(self, poses: Any) -> np.ndarray:
        """:func:`homogenize` applied to :meth:`inverse_jacobian` with :attr:`characteristic_length`."""
        return homogenize(self.inverse_jacobian(poses), self.joint_types, self.characteristic_length)

    def homogenized_task_jacobian(self, poses: Any) -> np.ndarray:
        """:func:`homogenize` applied to :meth:`task_jacobian` (angular coordinates scaled by L)."""
        return homogenize(self.task_jacobian(poses), self.joint_types, self.characteristic_length,
                          self.variable_kinds)

    def condition_number(self, poses: Any) -> np.ndarray:
        """Condition number ``(N,)`` of the homogenised task Jacobian."""
        return condition_number(self.homogenized_task_jacobian(poses))

    def dexterity(self, poses: Any) -> np.ndarray:
        """Dexterity ``(N,)`` = inverse condition number of the homogenised task Jacobian."""
        return dexterity_index(self.homogenized_task_jacobian(poses))

    def is_singular(self, poses: Any, tol: float = SINGULAR_TOLERANCE) -> np.ndarray:
        """``(N,)`` True where the homogenised task Jacobian's inverse condition number is below ``tol``."""
        return self.dexterity(poses) < tol

    def singularity(self, poses: Any) -> np.ndarray:
        """``(N,)`` strings naming a singular configuration of the mechanism itself at each pose (``''``: none),
        beyond the conditioning of its Jacobian; mechanisms that know their singular configurations override
        it (the 3-UPU's limb directions, the GPR's rigid constraints)."""
        arr, _ = as_poses(poses)
        return np.full(arr.shape[0], '', dtype=object)

    def jacobian_and_singularity(self, poses: Any) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`homogenized_task_jacobian` and :meth:`singularity` of completed poses, as a dexterity map takes
        them; a mechanism whose singularity reads the same Jacobian (the GSP) computes it once."""
        return self.homogenized_task_jacobian(poses), self.singularity(poses)

    def _outside(self, joints: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Joint values ``(N, n)`` (:func:`~gpr_kinematics.inputs.validation.number_rows`), where they are outside
        the limits (NaN included) and the limits."""
        q = number_rows(joints, f'{self.name}: joint values', self.n_joints)
        lim = np.asarray(self.joint_limits, dtype=float)
        return q, ~((q >= lim[:, 0] - 1e-12) & (q <= lim[:, 1] + 1e-12) & np.isfinite(q)), lim

    def within_limits(self, joints: Any) -> np.ndarray:
        """``(N,)`` True where every joint value lies within :attr:`joint_limits` (inclusive)."""
        return np.asarray(~np.any(self._outside(joints)[1], axis=-1))

    def check_limits(self, joints: Any) -> None:
        """Raise :class:`LimitError` naming the first joint outside its limits (within them as mm: hinted so)."""
        q, bad, lim = self._outside(joints)
        if np.any(bad):
            row, j = np.argwhere(bad)[0]
            (lo, hi), value = lim[j].tolist(), float(q[row, j])
            unit = 'rad' if self.joint_types[j] in ANGULAR_JOINTS else 'm'
            mm = ' (millimetres given as metres?)' if unit == 'm' and within_as_millimetres(value, lo, hi) else ''
            raise LimitError(f'{self.name}: joint {self.joint_names[j]} = {value:.6g} {unit} is outside '
                             f'its limits [{lo:.6g}, {hi:.6g}] {unit}{mm}')

    # ------------------------------------------------------------------ geometry parameters
    def parameters(self) -> dict[str, np.ndarray]:
        """Geometric parameters whose errors the accuracy analysis can propagate (name -> array, SI)."""
        return {}

    def with_parameters(self, params: Mapping[str, Any]) -> Mechanism:
        """A copy of the mechanism with some :meth:`parameters` replaced."""
        if params:
            raise InputError(f'{self.name} has no geometric parameters; got {sorted(params)}')
        return self

    def parameter_jacobian(self, poses: Any, name: str, step: float = 1e-7) -> np.ndarray:
        """``d q / d parameter (N, n, size)`` by central differences of :meth:`inverse_kinematics`.

        Step ``step`` in the parameter's SI unit; subclasses override with closed forms where they have them.
        """
        step = difference_step(self.name, step)
        arr, _ = as_poses(poses)
        arr = self.complete_pose(arr)
        base = self.parameters()
        if not isinstance(name, str) or name not in base:
            raise InputError(f'{self.name}: unknown parameter {brief(name)}; allowed: {sorted(base)}')
        p0 = np.asarray(base[name], dtype=float)
        out = np.zeros((arr.shape[0], self.n_joints, p0.size))
        for k in range(p0.size):
            d = np.zeros(p0.size)
            d[k] = step
            qp = self.with_parameters({name: (p0.ravel() + d).reshape(p0.shape)}).inverse_kinematics(arr)
            qm = self.with_parameters({name: (p0.ravel() - d).reshape(p0.shape)}).inverse_kinematics(arr)
            out[:, :, k] = (qp - qm) / (2 * step)
        return out

    # ------------------------------------------------------------------ forward kinematics
    def forward_kinematics(self, joints: Any, guess: Any, tol: float = 1e-12, max_iterations: int = 50
                           ) -> np.ndarray:
        """Poses ``(N, 6)`` reaching joint values ``(N, n)`` by Newton's method from poses ``guess``.

        Six-DOF mechanisms iterate on the rigid motion itself, free of Euler-angle singularities:
        ``(v, w) = J^-1 (q(P, R) - q)``, ``P <- P - v``, ``R <- exp(-[w]x) R`` (Rodrigues), then convert ``R``
        to the mechanism's Euler angles. Lower-mobility mechanisms iterate on their coordinates,
        ``u <- u - (dq/du)^+ (q(u) - q)``. Vectorised over the batch; converged when every joint residual is
        below ``tol`` (m or rad). Raises :class:`ConvergenceError` otherwise and :class:`SingularityError`
        when a Jacobian is singular on the way.
        """
        tol, max_iterations = newton_settings(self.name, tol, max_iterations)
        q = number_rows(joints, f'{self.name}: joint values', self.n_joints)
        if not np.all(np.isfinite(q)):
            raise InputError(f'{self.name}: joint values must be {self.n_joints} finite numbers per pose; '
                             f'got shape {np.shape(joints)}')
        bounded(q, f'{self.name}: joint values')
        g, _ = as_poses(guess, 'guess')
        if g.shape[0] == 1 and q.shape[0] > 1:
            g = np.repeat(g, q.shape[0], axis=0)
        if len(self.pose_variables) == 6:
            return self._forward_rigid(q, g, tol, max_iterations)
        u = self.coordinates(g)
        err = np.full(q.shape[0], np.inf)
        for _ in range(max_iterations):
            poses = self.pose_from_coordinates(u)
            res = self.inverse_kinematics(poses) - q
            err = np.max(np.abs(res), axis=-1)
            if np.all(err < tol):
                return poses
            u = u - _solve(self.coordinate_jacobian(poses), res, self.name)
            gone = ~np.all(np.isfinite(u) & (np.abs(u) <= MAX_COORDINATE), axis=-1)
            if gone.any():  # diverged: say so, not that the iterate is a bad input
                i = int(np.argmax(gone))
                raise ConvergenceError(f'{self.name}: forward kinematics diverged for pose {i}: the joint values '
                                       f'{brief(q[i].tolist())} are out of reach, or too far from the guess; allowed: '
                                       'joint values a pose reaches, with a guess near that pose')
        raise ConvergenceError(f'{self.name}: forward kinematics did not converge to {tol:g} in '
                               f'{max_iterations} iterations (max residual {np.max(err):.3g})')

    def joints_rt(self, pos: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Joint values ``(N, n)`` of positions ``(N, 3)`` and rotations ``(N, 3, 3)`` (via Euler angles)."""
        angles = euler_from_rotation(R, self.euler_convention)
        return self.inverse_kinematics(np.concatenate([pos, angles], -1))

    def inverse_jacobian_rt(self, pos: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Inverse Jacobians ``(N, n, 6)`` of positions and rotation matrices (via Euler angles)."""
        return self.inverse_jacobian(np.concatenate([pos, euler_from_rotation(R, self.euler_convention)], -1))

    def _forward_rigid(self, q: np.ndarray, g: np.ndarray, tol: float, max_iterations: int) -> np.ndarray:
        if q.shape[0] == 1 and getattr(self, '_scalar', None) is not None:
            return self._forward_rigid_one(q[0], g[0], tol, max_iterations)[None, :]
        pos = g[:, :3].copy()
        R = euler_rotation(g[:, 3:], self.euler_convention)
        err = np.full(q.shape[0], np.inf)
        active = np.arange(q.shape[0])
        for _ in range(max_iterations):
            res = self.joints_rt(pos[active], R[active]) - q[active]
            err[active] = np.max(np.abs(res), axis=-1)
            keep = ~(err[active] < tol)
            active, res = active[keep], res[keep]
            if active.size == 0:
                return np.concatenate([pos, euler_from_rotation(R, self.euler_convention)], axis=-1)
            step = _solve(self.inverse_jacobian_rt(pos[active], R[active]), res, self.name)
            # Damping: no step larger than MAX_STEP (homogenised: rotations times the characteristic length),
            # so a start far from the solution cannot jump across a singularity.
            size = np.maximum(np.linalg.norm(step[:, :3], axis=-1) / self.characteristic_length,
                              np.linalg.norm(step[:, 3:], axis=-1))
            step *= np.minimum(1.0, MAX_STEP / np.maximum(size, 1e-300))[:, None]
            pos[active] -= step[:, :3]
            R[active] = rotation_from_vector(-step[:, 3:]) @ R[active]
        raise ConvergenceError(f'{self.name}: forward kinematics did not converge to {tol:g} in '
                               f'{max_iterations} iterations (max residual {np.max(err):.3g})')

    def _forward_rigid_one(self, q: np.ndarray, g: np.ndarray, tol: float, max_iterations: int) -> np.ndarray:
        """:meth:`_forward_rigid` for one pose with the mechanism's float-arithmetic rows (same iteration)."""
        target = q.tolist()
        p = g[:3].tolist()
        R = euler_rotation(g[None, 3:], self.euler_convention)[0]
        err = math.inf
        for _ in range(max_iterations):
            joints, rows = getattr(self, '_scalar')(p, R.tolist(), True)  # noqa: B009 - defined by some subclasses
            res = [joints[k] - target[k] for k in range(len(target))]
            err = max(abs(r) for r in res)
            if err < tol:
                return np.concatenate([p, euler_from_rotation(R, self.euler_convention)])
            J = np.array(rows)
            if not np.all(np.isfinite(J)):
                raise SingularityError(f'{self.name}: forward kinematics met a singular configuration')
            try:
                step = np.linalg.solve(J, res)
            except np.linalg.LinAlgError:
                step = np.linalg.pinv(J) @ np.array(res)
            size = max(math.sqrt(step[0] ** 2 + step[1] ** 2 + step[2] ** 2) / self.characteristic_length,
                       math.sqrt(step[3] ** 2 + step[4] ** 2 + step[5] ** 2))
            if size > MAX_STEP:
                step = step * (MAX_STEP / size)
            p = [p[0] - step[0], p[1] - step[1], p[2] - step[2]]
            R = rodrigues(-step[3], -step[4], -step[5]) @ R
        raise ConvergenceError(f'{self.name}: forward kinematics did not converge to {tol:g} in '
                               f'{max_iterations} iterations (max residual {err:.3g})')

    # ------------------------------------------------------------------ report
    def report(self, pose: Any) -> JacobianReport:
        """Joint values, inverse Jacobian (plain and homogenised) and conditioning at one pose."""
        arr, _ = as_poses(pose, 'pose')
        if arr.shape[0] != 1:
            raise InputError(f'report() takes one pose; got {arr.shape[0]}')
        full = self.complete_pose(arr)
        q = self.inverse_kinematics(full)
        with np.errstate(divide='ignore', invalid='ignore'):
            J = self.inverse_jacobian(full)
            Jt = self.homogenized_task_jacobian(full)
        finite = bool(np.all(np.isfinite(J)) and np.all(np.isfinite(Jt)))
        dex = float(dexterity_index(Jt)[0]) if finite else 0.0
        cond = float(condition_number(Jt)[0]) if finite else float('inf')
        named = str(self.singularity(full)[0])
        return JacobianReport(pose=full[0], joints=q[0], inverse_jacobian=J[0],
                              homogenized_inverse_jacobian=homogenize(J, self.joint_types,
                                                                      self.characteristic_length)[0],
                              task_jacobian=Jt[0], condition_number=cond, dexterity=dex,
                              singular=bool((not finite) or dex < SINGULAR_TOLERANCE or named),
                              within_limits=bool(self.within_limits(q)[0]), singularity=named)

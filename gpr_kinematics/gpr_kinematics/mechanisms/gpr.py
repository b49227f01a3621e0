"""The GPR tilting Z axis as a :class:`~.base.Mechanism`, on top of the core kinematics.

Bratovanov & Sotirov (``docs/references.md``); frames and models in ``docs/core.md``. The GPR has three
degrees of freedom: the pose variables are the height ``z`` of the platform origin (m) and the tilt as a
rotation vector ``(tilt_x, tilt_y) = alpha (cos gamma, sin gamma)`` (rad; tilt ``alpha`` about the
horizontal axis at azimuth ``gamma``). A complete pose is ``(x, y, z, tilt_x, tilt_y, twist)`` with
rotation ``R = tilt_rotation(alpha, gamma) @ Rz(twist)`` (:mod:`gpr_kinematics.core.rotations`); ``x``, ``y`` and
``twist`` are outcomes of the virtual-joint model (the centre shift), reported, not requested.

- Inverse kinematics: :func:`gpr_kinematics.core.inverse_batch` (Newton under the virtual-joint
  model); the reached pose comes from :func:`~gpr_kinematics.core.forward_batch`.
- Jacobians: forward kinematics is a smooth, pure function of ``q`` (also at the singular configuration
  ``q1 = q2 = q3``, which the virtual joints regularise), so ``du/dq`` (3 x 3) and the twist per rod rate
  ``dT/dq`` (6 x 3) are taken by **central differences of the batch forward kinematics** (step 1e-6 m;
  truncation error ~1e-12 relative), and the inverse Jacobian of the pose variables is
  ``dq/du = (du/dq)^-1``. The 3 x 6 inverse Jacobian over twists is ``dq/du (W T)^+ W`` with ``T`` the
  twists the GPR can produce per unit rate of ``u`` and ``W = diag(1, 1, 1, L, L, L)``: exact on those
  twists; any other twist is first projected on them (least squares, rotations weighted by ``L``).
- Accuracy: rod-length errors ``dq`` and *virtual-joint imperfections* ``delta_k`` (3 x 3, m, platform
  frame): displacements of the joint centres beyond the virtual-joint model (play, wear) within the
  imperfection budget. With them the closure is solved again with each platform joint ``r_k(X) + delta_k`` on its
  rod tip ``P_k`` (the core's ``forward_batch`` with the joint centres displaced by ``-R delta_k``, ``R`` the
  platform's rotation, to a fixed point): the virtual joints take up what they can (a radial ``delta_k`` under the
  radial model entirely). It was the least-squares fit of ``r_k(X) + delta_k`` with ``X`` unchanged, which left
  each joint 33 um off its rod tip for a tangential 0.1 mm and moved the platform by half of the closure's answer.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np

from ..core.config import FLOAT_RANGES
from ..errors import ConfigError, InputError, LimitError, brief
from ..inputs.schema import check_keys
from ..inputs.validation import bounded, difference_step, newton_settings, rows_of
from .base import Mechanism, as_poses, rotation_vector

#: The largest tilt limit of a geometry [rad] (GprConfig's range): a dexterity map computes up to it.
TILT_DOMAIN = FLOAT_RANGES['tilt_limit'][1]

FD_STEP = 1e-6  # m, central-difference step on the rod lengths
#: The fixed point of joint imperfections (:meth:`GprMechanism.forward_poses`): each step moves the rotation by about
#: ``|delta| / R`` of the last (1e-3 for 0.1 mm), so 5 steps reach 1e-18 m; at most this many, to this change [m].
IMPERFECTION_STEPS, IMPERFECTION_TOLERANCE = 12, 1e-18


def _tilt_vector(R: np.ndarray) -> np.ndarray:
    """Tilt rotation vector ``(tilt_x, tilt_y)`` of the platform normal ``n = R e3`` (smooth through 0)."""
    n = R[..., :, 2]
    s = np.hypot(n[..., 0], n[..., 1])
    t = np.arctan2(s, n[..., 2])
    factor = np.where(s > 1e-300, t / np.where(s > 1e-300, s, 1.0), 1.0)
    return np.stack([-n[..., 1] * factor, n[..., 0] * factor], axis=-1)


class GprMechanism(Mechanism):
    """The GPR (three vertical rods, prismatic + spherical) under a virtual-joint model."""

    kind = 'gpr'
    pose_names = ('x', 'y', 'z', 'tilt_x', 'tilt_y', 'twist')
    pose_variables = ('z', 'tilt_x', 'tilt_y')
    euler_convention = 'tilt'  # R = tilt_rotation(hypot(tilt_x, tilt_y), atan2(tilt_y, tilt_x)) @ Rz(twist)
    joint_names = ('q1', 'q2', 'q3')
    joint_types = ('prismatic',) * 3

    def __init__(self, config: Any = None, name: str = 'GPR', imperfections: Any = None) -> None:
        from ..core.config import GprConfig, load_config
        self.config: GprConfig = config if config is not None else load_config()
        self.name = name
        self.joint_limits = np.array([[self.config.stroke_min, self.config.stroke_max]] * 3)
        self.characteristic_length = float(self.config.characteristic_length)
        c = self.config
        self.home_pose = (0.0, 0.0, 0.5 * (c.stroke_min + c.stroke_max), 0.0, 0.0, 0.0)
        self.default_sweep = ('tilt_x', -c.tilt_limit, c.tilt_limit)
        self.imperfections = (np.zeros((3, 3)) if imperfections is None else
                              bounded(imperfections, 'GPR joint imperfections (m)', (3, 3)))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = '<dict>') -> GprMechanism:
        """YAML: ``type: gpr``, optional ``name`` and ``overrides`` (fields of ``GprConfig``)."""
        from ..core.config import load_config
        allowed = {'type', 'name', 'overrides', 'workspace', 'reference'}
        check_keys(data, allowed, source)
        overrides = data.get('overrides') or {}
        if not isinstance(overrides, Mapping):
            raise ConfigError(f'{source}: overrides must be a mapping of GprConfig fields; got {brief(overrides)}')
        cfg = load_config(overrides=dict(overrides), overrides_source=f'{source}: overrides')
        return cls(cfg, name=str(data.get('name', 'GPR')))

    def unlimited(self) -> GprMechanism:
        """This GPR with its tilt limit at the model's 15 deg and its stroke widened by its span on either side: a
        dexterity map computes there and marks the poses beyond the limits (the core refused them, and the map)."""
        c = self.config
        span = c.stroke_max - c.stroke_min
        wide = dataclasses.replace(c, tilt_limit=TILT_DOMAIN, stroke_min=max(c.stroke_min - span,
                                                                             FLOAT_RANGES['stroke_min'][0]),
                                   stroke_max=min(c.stroke_max + span, FLOAT_RANGES['stroke_max'][1]))
        return GprMechanism(wide, self.name, self.imperfections)

    def pose_within_limits(self, poses: Any) -> np.ndarray:
        """``(N,)`` True where a pose's tilt is within the tilt limit."""
        from ..core.inverse import tilt_target_slack
        arr, _ = as_poses(poses)
        return np.asarray(np.hypot(arr[:, 3], arr[:, 4]) - self.config.tilt_limit <= tilt_target_slack(self.config))

    # ------------------------------------------------------------------ parameters
    def parameters(self) -> dict[str, np.ndarray]:
        """``joint_imperfections`` ``(3, 3)`` (m, platform frame): extra joint-centre displacements."""
        return {'joint_imperfections': self.imperfections.copy()}

    def with_parameters(self, params: Mapping[str, Any]) -> GprMechanism:
        for key in params:
            if key != 'joint_imperfections':
                raise InputError(f'{self.name}: unknown parameter {brief(key)}; allowed: joint_imperfections')
        return GprMechanism(self.config, self.name, params.get('joint_imperfections', self.imperfections))

    # ------------------------------------------------------------------ pose <-> rods
    def rotation(self, poses: Any) -> np.ndarray:
        from ..core.rotations import rotation_z, tilt_rotation
        arr, _ = as_poses(poses)
        tx, ty = arr[:, 3], arr[:, 4]
        return tilt_rotation(np.hypot(tx, ty), np.arctan2(ty, tx)) @ rotation_z(arr[:, 5])

    def forward_poses(self, joints: Any) -> np.ndarray:
        """Complete poses ``(N, 6)`` reached with rod lengths ``(N, 3)`` (m), imperfections included."""
        from ..core import forward_batch
        from ..core.rotations import tilt_from_matrix
        # NaN named as such (it read as farther than the stroke range)
        Q = rows_of(joints, 'q', 3, [f'{self.name}: q{k}' for k in (1, 2, 3)])
        span = self.config.stroke_max - self.config.stroke_min
        if not np.all(np.abs(Q - 0.5 * (self.config.stroke_min + self.config.stroke_max)) <= span):  # NaN too
            i, k = np.argwhere(~(np.abs(Q - 0.5 * (self.config.stroke_min + self.config.stroke_max)) <= span))[0]
            raise LimitError(f'{self.name}: q{k + 1} = {Q[i, k]:.6g} m is farther than the stroke range {span:g} m '
                             'from the middle of the stroke; allowed: rod lengths a GPR can approach')
        fb = forward_batch(Q, self.config, check_limits=False)
        D = np.zeros((Q.shape[0], 3, 3))
        for _ in range(IMPERFECTION_STEPS if np.any(self.imperfections) else 0):
            # the joint p_k + delta_k on the rod tip P_k: the model's p_k at P_k - R delta_k, R the pose's rotation
            D, before = -np.einsum('nij,kj->nki', fb.rotation, self.imperfections), D
            if np.max(np.abs(D - before)) <= IMPERFECTION_TOLERANCE:
                break
            fb = forward_batch(Q, self.config, check_limits=False, displacement=D)
        R, pos = fb.rotation, fb.position
        twist = tilt_from_matrix(R)[2]
        return np.concatenate([pos, _tilt_vector(R), twist[:, None]], axis=-1)

    def forward_kinematics(self, joints: Any, guess: Any = None, tol: float = 1e-12, max_iterations: int = 50
                           ) -> np.ndarray:
        """Forward kinematics by the core (a pure function of ``q``: ``guess`` is not needed; ``tol`` and
        ``max_iterations`` are checked as for every mechanism, the core's closure has its own)."""
        newton_settings(self.name, tol, max_iterations)
        if guess is not None:
            as_poses(guess, 'guess')   # checked as every mechanism's, then not needed
        return self.forward_poses(joints)

    def inverse_kinematics(self, poses: Any) -> np.ndarray:
        """Rod lengths ``(N, 3)`` (m) for the heights and tilts of ``poses`` (core inverse kinematics).

        Raises :class:`LimitError` beyond the tilt limit or the stroke. With joint imperfections the
        result is refined by Newton's method on the imperfect forward kinematics.
        """
        from ..core import inverse_batch
        arr, single = as_poses(poses)
        tx, ty = arr[:, 3], arr[:, 4]
        q = inverse_batch(arr[:, 2], np.hypot(tx, ty), np.arctan2(ty, tx), self.config).q
        if np.any(self.imperfections):
            u = self.coordinates(arr)
            for _ in range(20):
                res = self.coordinates(self.forward_poses(q)) - u
                if np.max(np.abs(res)) < 1e-14:
                    break
                q = q - np.linalg.solve(self._du_dq(q), res[..., None])[..., 0]
        return q[0] if single else q

    def complete_pose(self, poses: Any) -> np.ndarray:
        """The pose reached for the requested height and tilt: ``x``, ``y``, ``twist`` from the model."""
        arr, single = as_poses(poses)
        out = self.forward_poses(self.inverse_kinematics(arr))
        return out[0] if single else out

    # ------------------------------------------------------------------ Jacobians
    def _fd(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Central differences of FK: ``du/dq (N, 3, 3)`` and twist per rod rate ``(N, 6, 3)``."""
        Q = np.atleast_2d(q)
        n = Q.shape[0]
        steps = np.concatenate([np.eye(3), -np.eye(3)]) * FD_STEP
        Qs = (Q[:, None, :] + steps[None]).reshape(-1, 3)
        P = self.forward_poses(Qs).reshape(n, 6, 6)
        R = self.rotation(P.reshape(-1, 6)).reshape(n, 6, 3, 3)
        R0 = self.rotation(self.forward_poses(Q))
        du = (P[:, :3, 2:5] - P[:, 3:, 2:5]) / (2 * FD_STEP)          # (n, 3 steps, 3 coords)
        dpos = (P[:, :3, :3] - P[:, 3:, :3]) / (2 * FD_STEP)
        dR = (R[:, :3] - R[:, 3:]) / (2 * FD_STEP)                    # (n, 3, 3, 3)
        W = dR @ np.swapaxes(R0, -1, -2)[:, None]
        w = np.stack([W[..., 2, 1] - W[..., 1, 2], W[..., 0, 2] - W[..., 2, 0],
                      W[..., 1, 0] - W[..., 0, 1]], axis=-1) / 2.0
        twist = np.concatenate([dpos, w], axis=-1)                   # (n, 3 steps, 6)
        return np.swapaxes(du, -1, -2), np.swapaxes(twist, -1, -2)

    def _du_dq(self, q: np.ndarray) -> np.ndarray:
        return self._fd(q)[0]

    def task_jacobian(self, poses: Any) -> np.ndarray:
        """``dq/du (N, 3, 3)`` = ``(du/dq)^-1`` (rows q1..q3, columns z, tilt_x, tilt_y)."""
        arr, _ = as_poses(poses)
        return np.linalg.inv(self._du_dq(self.inverse_kinematics(arr)))

    def coordinate_jacobian(self, poses: Any) -> np.ndarray:
        return self.task_jacobian(poses)

    def singularity(self, poses: Any) -> np.ndarray:
        """``(N,)``: where the *rigid* mechanism is singular (:func:`gpr_kinematics.core.mobility.rigid_rank`, as
        ``gpr mobility`` reports it: q1 = q2 = q3 on the nominal machine), its rank and mobility; ``''`` elsewhere.
        The virtual joints keep the Jacobians regular there (:meth:`is_singular` is False): the singularity is of
        the rigid platform, which the paper's sweep crosses."""
        from ..core.mobility import rigid_rank
        arr, _ = as_poses(poses)
        rank = rigid_rank(self.inverse_kinematics(arr), self.config)
        out = np.full(arr.shape[0], '', dtype=object)
        for i in np.flatnonzero(12 - rank > 1):
            out[i] = (f'rigid mechanism: rank dPhi/dP = {rank[i]}, mobility {12 - rank[i]} (paper section IV-A); the '
                      'virtual joints keep the Jacobian regular')
        return out

    def motion_basis(self, poses: Any) -> np.ndarray:
        """Twists ``(N, 6, 3)`` per unit rate of ``(z, tilt_x, tilt_y)``: ``dT/dq dq/du``."""
        arr, _ = as_poses(poses)
        du, dT = self._fd(self.inverse_kinematics(arr))
        return dT @ np.linalg.inv(du)

    def inverse_jacobian(self, poses: Any) -> np.ndarray:
        """``(N, 3, 6)``: ``dq/du (W T)^+ W`` (see the module docstring); exact on the GPR's own twists."""
        arr, single = as_poses(poses)
        du, dT = self._fd(self.inverse_kinematics(arr))
        Jt = np.linalg.inv(du)
        T = dT @ Jt
        w = np.array([1.0, 1.0, 1.0] + [self.characteristic_length] * 3)
        J = Jt @ np.linalg.pinv(w[:, None] * T) * w
        return np.asarray(J[0] if single else J)

    def parameter_jacobian(self, poses: Any, name: str, step: float = 1e-7) -> np.ndarray:
        """``dq/d delta (N, 3, 9)`` = ``-(dq/du) du/d delta`` (central differences of the imperfect FK)."""
        if name != 'joint_imperfections':
            raise InputError(f'{self.name}: unknown parameter {brief(name)}; allowed: joint_imperfections')
        step = difference_step(self.name, step)
        arr, _ = as_poses(poses)
        q = self.inverse_kinematics(arr)
        dudp = self._pose_parameter_derivative(q, step)[:, 2:5]
        return np.asarray(-self.task_jacobian(arr) @ dudp)

    def _imperfection_steps(self, q: np.ndarray, step: float) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
        """For each of the 9 imperfection components ``k``: the poses ``(N, 6)`` at rods ``q`` with that
        component moved by ``+step`` and ``-step`` (central differences; a loop over parameters, not poses)."""
        for k in range(9):
            d = np.zeros(9)
            d[k] = step
            plus = self.with_parameters({'joint_imperfections': self.imperfections + d.reshape(3, 3)})
            minus = self.with_parameters({'joint_imperfections': self.imperfections - d.reshape(3, 3)})
            yield k, plus.forward_poses(q), minus.forward_poses(q)

    def _pose_parameter_derivative(self, q: np.ndarray, step: float) -> np.ndarray:
        """``d pose / d delta`` ``(N, 6, 9)`` at fixed rods: position, tilt vector, twist."""
        out = np.zeros((q.shape[0], 6, 9))
        for k, Pp, Pm in self._imperfection_steps(q, step):
            out[:, :, k] = (Pp - Pm) / (2 * step)
        return out

    def linearized_twist(self, poses: Any, joint_errors: np.ndarray,
                         parameter_errors: Mapping[str, np.ndarray]) -> np.ndarray:
        """First-order rigid-motion deviation ``(N, 6)``: ``dT/dq dq + dT/d delta delta``."""
        arr, _ = as_poses(poses)
        q = self.inverse_kinematics(arr)
        _, dT = self._fd(q)
        out = (dT @ np.asarray(joint_errors)[..., None])[..., 0]
        delta = parameter_errors.get('joint_imperfections')
        if delta is not None and np.any(delta):
            step = 1e-7
            R0 = self.rotation(self.forward_poses(q))
            cols = np.zeros((q.shape[0], 6, 9))
            for k, Pp, Pm in self._imperfection_steps(q, step):
                cols[:, :3, k] = (Pp[:, :3] - Pm[:, :3]) / (2 * step)
                rp = rotation_vector(self.rotation(Pp) @ np.swapaxes(R0, -1, -2))
                rm = rotation_vector(self.rotation(Pm) @ np.swapaxes(R0, -1, -2))
                cols[:, 3:, k] = (rp - rm) / (2 * step)
            out = out + (cols @ np.asarray(delta).ravel()[:, None])[..., 0]
        return np.asarray(out)


def load_gpr(data: Mapping[str, Any], source: str) -> GprMechanism:
    """YAML loader entry for ``type: gpr``."""
    return GprMechanism.from_dict(data, source)

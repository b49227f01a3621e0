"""Pose accuracy of a parallel mechanism: joint and geometry errors -> platform pose deviation.

Alwan, eqs. (5)-(7) (``docs/references.md``), generalised to any
:class:`~gpr_kinematics.mechanisms.base.Mechanism`. With the closure ``G(s, u, p) = q(u, p) - s = 0``
(joint values ``s``, pose coordinates ``u``, geometric parameters ``p`` such as the joint points ``R_ai``,
``R_bi``), errors ``Delta s`` (actuator errors, leg deformations) and ``Delta p`` (joint-position errors)
move the platform by ``du``:

- **linearised** (eq. 7, first-order Taylor expansion of eq. 5):
  ``du = -(dG/du)^-1 (dG/ds Delta s + dG/dp Delta p) = (dq/du)^-1 (Delta s - dq/dp Delta p)``
  (Alwan's squared closure ``|.|^2 - s^2`` gives the same ``du``: its derivatives are those of ``q - s``
  multiplied by ``2 s``). For a mechanism with more constraints than coordinates the inverse is the
  Moore-Penrose pseudo-inverse (least-squares deviation).
- **exact**: the perturbed closure ``q(u + du, p + Delta p) = s + Delta s`` solved by Newton's method, followed
  from the nominal pose as the errors grow (:mod:`.exact_path`: a solve from the nominal pose alone converged on
  another assembly mode) and refused where that path ends.

``du`` is in the mechanism's pose coordinates (m, and rad of its Euler angles: Z-X-Z for Alwan's
platform); the difference exact - linearised is second order in the errors. The deviation is also given
as a small rigid motion (position and rotation vector in the base frame), which stays meaningful where
the Euler angles are near their own singularity (Z-X-Z at ``theta -> 0``: there ``dpsi`` and ``dphi`` grow
large and opposite while the rotation itself barely changes). A rotation ``delta`` moves the first and third
angles by up to ``delta / sin(D)``, ``D`` the second angle's distance from its gimbal lock (``sin D = |det E|``,
``E`` the Euler-rate matrix: ``|sin theta|`` for Z-X-Z, ``|cos B|`` for roll-pitch-yaw); within
:data:`EULER_LOCK_WARNING` of it the result carries a warning (``warnings``) naming the pose. The rigid motion is
solved over twists (:func:`linearized_motion`), so it holds at the lock itself too, where the angles' deviations
are not defined (NaN; ``sin D`` below :data:`EULER_LOCK_UNDEFINED`): the first and third are not, and the second
moves by the size of the rotation, not linearly.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.rotations import wrap_angle
from ..errors import ConvergenceError, InputError, SingularityError, apart, brief
from ..inputs.validation import MAX_COORDINATE, float_array
from .base import (
    ANGULAR_JOINTS,
    SINGULAR_TOLERANCE,
    Mechanism,
    as_poses,
    dexterity_index,
    euler_rate_matrix,
    rotation_vector,
)
from .exact_path import PathEndedError, follow

#: Distance [rad] of the second Euler angle from its gimbal lock (Z-X-Z: theta = 0 or pi; roll-pitch-yaw: B = +-pi/2)
#: within which the Euler-angle deviations are flagged: there the first and third move by 1 / sin(0.1) = 10 times
#: the rotation or more (Alwan's trajectory point 1, theta = 2 deg: 29 times).
EULER_LOCK_WARNING = 0.1
#: ``sin D`` below which a pose is on the gimbal lock (module docstring): its angles' deviations are not defined (a
#: solve over the Euler coordinates there gave +-8.4e12 rad, and the rigid motion built from them).
EULER_LOCK_UNDEFINED = 1e-12


@dataclass(frozen=True)
class AccuracyResult:
    """Pose deviations for a batch of ``N`` nominal poses (``m`` pose coordinates)."""

    mechanism: str
    variables: tuple[str, ...]          #: names of the ``m`` pose coordinates
    poses: np.ndarray                   #: (N, 6) nominal poses, m and rad
    joints: np.ndarray                  #: (N, n) nominal joint values
    joint_errors: np.ndarray            #: (N, n) Delta s
    parameter_errors: dict[str, np.ndarray] = field(default_factory=dict)  #: Delta p by name
    linearized: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  #: (N, m) eq. (7)
    exact: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))       #: (N, m) perturbed closure
    exact_poses: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))  #: (N, 6) perturbed poses
    condition_number: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: (N,) homogenised dq/du
    #: (N, 6) linearised deviation as a small rigid motion: position (m) and rotation vector (rad, base frame)
    linearized_twist: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    #: (N, 6) exact deviation: position (m) and rotation vector of ``R_exact R_nominal^T`` (rad, base frame)
    exact_twist: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    #: poses whose Euler-angle deviations are not meaningful (:func:`euler_lock_warnings`)
    warnings: tuple[str, ...] = ()

    @property
    def difference(self) -> np.ndarray:
        """``exact - linearized`` (N, m): the linearisation error (second order in the errors)."""
        return np.asarray(self.exact - self.linearized)

    def record(self, index: int = 0) -> PoseDeviation:
        """The result of pose ``index`` (:class:`PoseDeviation`)."""
        names = self.variables
        return PoseDeviation(
            mechanism=self.mechanism, pose=self.poses[index], joints=self.joints[index],
            joint_errors=self.joint_errors[index], parameter_errors=dict(self.parameter_errors), variables=names,
            linearized=dict(zip(names, self.linearized[index].tolist(), strict=True)),
            exact=dict(zip(names, self.exact[index].tolist(), strict=True)),
            difference=dict(zip(names, self.difference[index].tolist(), strict=True)),
            exact_pose=self.exact_poses[index], linearized_twist=self.linearized_twist[index],
            exact_twist=self.exact_twist[index], condition_number=float(self.condition_number[index]))

    def report(self, kind: str) -> AccuracyReport:
        """Every pose's result (``gpr accuracy --json``); ``kind`` is the mechanism's type."""
        return AccuracyReport(self.mechanism, kind, self.variables,
                              tuple(self.record(i) for i in range(self.poses.shape[0])), self.warnings)


@dataclass(frozen=True)
class PoseDeviation:
    """The accuracy of one nominal ``pose`` (6,) [m, rad]: its ``joints``, the ``joint_errors`` and
    ``parameter_errors`` given, the deviation of the pose ``variables`` ``linearized`` (eq. (7)), ``exact`` and
    their ``difference``, the ``exact_pose`` reached, both deviations as a rigid motion (position [m] and rotation
    vector [rad], base frame) and the ``condition_number`` of the homogenised ``dq/du``."""

    mechanism: str
    pose: np.ndarray
    joints: np.ndarray
    joint_errors: np.ndarray
    parameter_errors: dict[str, np.ndarray]
    variables: tuple[str, ...]
    linearized: dict[str, float]
    exact: dict[str, float]
    difference: dict[str, float]
    exact_pose: np.ndarray
    linearized_twist: np.ndarray
    exact_twist: np.ndarray
    condition_number: float


@dataclass(frozen=True)
class AccuracyReport:
    """The accuracy of every pose of a mechanism (its name, ``type`` and pose ``variables``): ``results``, and the
    ``warnings`` of poses next to the Euler angles' gimbal lock (:func:`euler_lock_warnings`)."""

    mechanism: str
    type: str
    variables: tuple[str, ...]
    results: tuple[PoseDeviation, ...]
    warnings: tuple[str, ...] = ()


def euler_lock_distance(mech: Mechanism, poses: Any) -> np.ndarray:
    """``(N,)`` distance [rad] in ``[0, pi/2]`` of each pose's second Euler angle from the gimbal lock of the
    mechanism's convention, ``arcsin |det E|`` (module docstring); ``pi/2`` for a mechanism whose pose
    coordinates are not three Euler angles (no lock)."""
    arr, _ = as_poses(poses)
    if len(mech.pose_variables) != 6:
        return np.full(arr.shape[0], np.pi / 2)
    det = np.abs(np.linalg.det(euler_rate_matrix(arr[:, 3:], mech.euler_convention)))
    return np.asarray(np.arcsin(np.minimum(det, 1.0)))


def euler_lock_warnings(mech: Mechanism, poses: Any) -> tuple[str, ...]:
    """One warning per pose (numbered from 1) within :data:`EULER_LOCK_WARNING` of the gimbal lock: the deviations
    of the first and third Euler angles are magnified by up to ``1 / sin D`` there and not meaningful."""
    arr, _ = as_poses(poses)
    dist = euler_lock_distance(mech, arr)
    first, second, third = mech.pose_names[3:]
    out = []
    for i in np.flatnonzero(dist < EULER_LOCK_WARNING):
        effect = (f'of {first} and {third} are magnified up to about {1.0 / math.sin(dist[i]):.3g} times and are not '
                  'meaningful there' if math.sin(dist[i]) >= EULER_LOCK_UNDEFINED else
                  f'of {first}, {second} and {third} are not defined there (NaN)')
        out.append(f'pose {i + 1}: {second} = {arr[i, 4]:.6g} rad is {dist[i]:.3g} rad from the gimbal lock of the '
                   f'{mech.euler_convention} Euler angles (warned within {EULER_LOCK_WARNING:g} rad): the deviations '
                   f'{effect}; read the rotation vector of the rigid motion (rx ry rz, base frame) instead')
    return tuple(out)


def check_joint_errors(mech: Mechanism, errors: Any, n_poses: int, hints: tuple[str, str] = ('', '')) -> np.ndarray:
    """The joint errors ``(n_poses, n_joints)`` [m, rad for angular joints] of ``errors`` (one row for every pose, or
    one per pose; None: zeros), checked finite and within :data:`PARAMETER_ERROR_MOST` (m) and
    :data:`JOINT_ANGLE_ERROR_MOST` (rad); ``hints`` end the refusal of a linear, an angular error (a unit's)."""
    if errors is None:
        return np.zeros((n_poses, mech.n_joints))
    arr = float_array(errors, f'{mech.name}: joint errors', f'{mech.n_joints} numbers per pose (m, or rad for angular '
                      'joints)')
    if arr.ndim == 1:
        arr = np.broadcast_to(arr, (n_poses, arr.shape[0]))
    if arr.shape != (n_poses, mech.n_joints) or not np.all(np.isfinite(arr)):
        got = f'shape {np.shape(errors)}' if arr.shape != (n_poses, mech.n_joints) else f'{brief(errors)}'
        raise InputError(f'{mech.name}: joint errors must be {mech.n_joints} finite values (m, or rad for '
                         f'angular joints) for {", ".join(mech.joint_names)} per pose; got {got}')
    angular = np.array([t in ANGULAR_JOINTS for t in mech.joint_types])
    most = np.where(angular, JOINT_ANGLE_ERROR_MOST, PARAMETER_ERROR_MOST)
    big = np.argwhere(np.abs(arr) > most)
    if big.size:   # 0.3 m of a GPR's rod printed a tilt of 1.1 rad as its "exact" deviation, the rod off its stroke
        i, j = (int(v) for v in big[0])
        unit, hint = ('rad', hints[1]) if angular[j] else ('m', hints[0])
        shown, bound = apart(abs(float(arr[i, j])), float(most[j]))
        raise InputError(f'{mech.name}: joint error of {mech.joint_names[j]} = {"-" if arr[i, j] < 0 else ""}{shown} '
                         f'{unit}{f" (pose {i + 1})" if n_poses > 1 else ""} is beyond {bound} {unit}; allowed: '
                         f'errors of at most {PARAMETER_ERROR_MOST:g} m ({JOINT_ANGLE_ERROR_MOST:g} rad for angular '
                         f'joints), as a tolerance table\'s (the linearisation means nothing beyond){hint}')
    return np.array(arr)


#: The largest error [m] of a geometric parameter (a point's displacement), a tolerance table's largest length too
#: (:data:`gpr_kinematics.calibration.tolerances.MAX_TOLERANCE`).
PARAMETER_ERROR_MOST = 0.01
#: The largest error [rad] of an angular joint, a tolerance table's largest angle too.
JOINT_ANGLE_ERROR_MOST = 0.1


def _parameter_errors(mech: Mechanism, errors: Mapping[str, Any] | None) -> dict[str, np.ndarray]:
    if errors is None or (isinstance(errors, Mapping) and not errors):
        return {}
    if not isinstance(errors, Mapping):
        raise InputError(f'{mech.name}: parameter errors = {brief(errors)}; allowed: a mapping of parameter name '
                         f'({", ".join(sorted(mech.parameters())) or "none"}) to its error (SI)')
    nominal = mech.parameters()
    out: dict[str, np.ndarray] = {}
    for key, val in errors.items():
        if key not in nominal:
            raise InputError(f'{mech.name}: unknown geometric parameter {key!r}; allowed: '
                             + (', '.join(sorted(nominal)) or 'none'))
        shape = np.shape(nominal[key])
        allowed = f'allowed: {int(np.prod(shape))} finite values (shape {shape}, SI)'
        try:
            arr = np.asarray(val, dtype=float)
        except (TypeError, ValueError, OverflowError):   # OverflowError: an int of 400 digits
            raise InputError(f'{mech.name}: error of parameter {key} = {brief(val)}; {allowed}') from None
        if arr.size != int(np.prod(shape)):
            raise InputError(f'{mech.name}: error of parameter {key} has shape {arr.shape}; {allowed}')
        bad = ~np.isfinite(arr.ravel())
        if bad.any():   # the message said 'got shape (6, 3)', the shape it asked for, of 18 values with a NaN
            k = int(np.argmax(bad))
            raise InputError(f'{mech.name}: error of parameter {key}: value {k + 1} of {arr.size} is '
                             f'{arr.ravel()[k]}, not a finite number; {allowed}')
        big = np.flatnonzero(np.abs(arr.ravel()) > PARAMETER_ERROR_MOST)
        if big.size:   # 1e6 m moved the GPR's platform by 333 km, printed as a result
            k = int(big[0])
            shown, most = apart(abs(float(arr.ravel()[k])), PARAMETER_ERROR_MOST)
            raise InputError(f'{mech.name}: error of parameter {key}: value {k + 1} of {arr.size} is '
                             f'{"-" if arr.ravel()[k] < 0 else ""}{shown} m, beyond {most} m; allowed: errors of at '
                             f'most {most} m (the linearisation means nothing beyond)')
        arr = arr.reshape(shape)
        undefined = ~np.isfinite(np.asarray(nominal[key], dtype=float))  # e.g. a GSP's A_j of a D1 constraint
        if np.any(arr[undefined] != 0.0):
            k = int(np.argmax((arr != 0.0) & undefined))
            raise InputError(f'{mech.name}: error of parameter {key}: value {k + 1} of {arr.size} is {arr.flat[k]:g} '
                             f'for a point this mechanism does not have (NaN in its parameters); allowed: 0 there')
        out[key] = arr
    return out


def _closure_errors(mech: Mechanism, poses: Any, joint_errors: Any, parameter_errors: Mapping[str, Any] | None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The completed poses ``(N, 6)`` and eq. (7)'s right side (:func:`_right_side`), the poses checked regular."""
    arr, _ = as_poses(poses)
    arr = mech.complete_pose(arr)
    rhs = _right_side(mech, arr, check_joint_errors(mech, joint_errors, arr.shape[0]),
                      _parameter_errors(mech, parameter_errors))
    _check_regular(mech, arr)
    return arr, rhs


def _right_side(mech: Mechanism, arr: np.ndarray, ds: np.ndarray, dp: Mapping[str, np.ndarray]) -> np.ndarray:
    """Eq. (7)'s right side ``Delta s - dq/dp Delta p`` ``(N, n)`` at completed poses."""
    rhs = ds.copy()
    for key, val in dp.items():
        rhs -= mech.parameter_jacobian(arr, key) @ np.nan_to_num(val.ravel())
    return rhs


def _solve(mech: Mechanism, J: np.ndarray, rhs: np.ndarray, arr: np.ndarray) -> np.ndarray:
    """``J^-1 rhs`` per pose (the pseudo-inverse for more constraints than coordinates)."""
    try:
        if J.shape[1] == J.shape[2]:
            return np.linalg.solve(J, rhs[..., None])[..., 0]
        return np.asarray(np.linalg.pinv(J) @ rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:  # conditioned within the tolerance, yet singular to rounding (CPU-dependent)
        raise SingularityError(f'{mech.name}: dq/du is singular to rounding at a pose of {brief(arr.tolist())}; the '
                               'pose deviation is unbounded there') from None


def linearized_motion(mech: Mechanism, poses: Any, joint_errors: Any = None,
                      parameter_errors: Mapping[str, Any] | None = None) -> np.ndarray:
    """Eq. (7) as a small rigid motion ``(N, 6)``: position [m] and rotation vector [rad, base frame], solved over
    the mechanism's motion coordinates (twists for 6 DOF), so it holds wherever the mechanism is regular, the Euler
    angles' gimbal lock included. Raises :class:`SingularityError` at a singular pose."""
    return _motion(mech, *_closure_errors(mech, poses, joint_errors, parameter_errors))


def _motion(mech: Mechanism, arr: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    return np.asarray(mech.motion_basis(arr) @ _solve(mech, mech.task_jacobian(arr), rhs, arr)[..., None])[..., 0]


def linearized_deviation(mech: Mechanism, poses: Any, joint_errors: Any = None,
                         parameter_errors: Mapping[str, Any] | None = None) -> np.ndarray:
    """Eq. (7): ``du (N, m) = (dq/du)^-1 (Delta s - dq/dp Delta p)`` at nominal poses ``(N, 6)``; on the Euler
    angles' gimbal lock (module docstring) the angles' deviations are NaN (not defined: the first and third are
    not, and the second moves by the rotation's size, not linearly), the position's as :func:`linearized_motion`'s.

    Raises :class:`SingularityError` at a pose where ``dq/du`` is singular (the deviation is unbounded).
    """
    return _deviation(mech, *_closure_errors(mech, poses, joint_errors, parameter_errors))


def _deviation(mech: Mechanism, arr: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    lock = np.sin(euler_lock_distance(mech, arr)) < EULER_LOCK_UNDEFINED
    out = np.full((arr.shape[0], len(mech.pose_variables)), np.nan)
    if not lock.all():
        out[~lock] = _solve(mech, mech.coordinate_jacobian(arr[~lock]), rhs[~lock], arr[~lock])
    if lock.any():   # 6 DOF: the twist's position; no Euler angle moves linearly there (the second by |rotation|)
        out[lock, :3] = _solve(mech, mech.task_jacobian(arr[lock]), rhs[lock], arr[lock])[:, :3]
    return out


def _check_regular(mech: Mechanism, poses: np.ndarray) -> np.ndarray:
    with np.errstate(divide='ignore', invalid='ignore'):
        Jh = mech.homogenized_task_jacobian(poses)
    if not np.all(np.isfinite(Jh)):
        k = int(np.argmax(~np.all(np.isfinite(Jh), axis=(1, 2))))
        why = str(mech.singularity(poses[k])[0]) or 'singular configuration'
        raise SingularityError(f'{mech.name}: the inverse Jacobian is not finite at the pose {poses[k].tolist()} '
                               f'({why}); the pose deviation is not defined there')
    dex = dexterity_index(Jh)   # the singularity of `gpr mechanism` and `gpr dexterity`: one threshold, one formula
    if np.any(dex < SINGULAR_TOLERANCE):
        k = int(np.argmin(dex))
        raise SingularityError(f'{mech.name}: pose {poses[k].tolist()} is singular (inverse condition '
                               f'number {dex[k]:.3g}); the pose deviation is unbounded there')
    return 1.0 / dex


def _unsolved(mech: Mechanism, poses: np.ndarray, cond: np.ndarray, exc: PathEndedError) -> ConvergenceError:
    """The exact solve's failure at the first pose whose path to its errors ends (:func:`.exact_path.follow`), named
    with its pose, how far the errors got, why, its condition number and what is allowed (a mechanism without a
    reach check of its own: the pose lies likely outside the reach of the mechanism with the errors)."""
    k = exc.row
    pose = ', '.join(f'{v:.6g}' for v in poses[k].tolist())
    return ConvergenceError(f'{mech.name}: the exact deviation at pose {k + 1} ({", ".join(mech.pose_names)} = '
                            f'{pose}; m, rad) cannot be solved: followed from the nominal pose as its errors grow, '
                            f'forward kinematics at {100 * exc.t:.4g} % of them {exc.why}; allowed: poses the '
                            f'mechanism still reaches with the errors (this one, condition number {cond[k]:.3g}, is '
                            'likely outside its reach: a pose farther inside the workspace, or smaller errors)',
                            sample=k)


def accuracy_analysis(mech: Mechanism, poses: Any, joint_errors: Any = None,
                      parameter_errors: Mapping[str, Any] | None = None, tol: float = 1e-13
                      ) -> AccuracyResult:
    """Linearised (eq. 7) and exact pose deviations at nominal poses ``(N, 6)`` or ``(6,)``.

    ``joint_errors``: ``(n,)`` or ``(N, n)`` actuator errors / leg deformations (m or rad).
    ``parameter_errors``: mapping parameter name -> error array (see ``mech.parameters()``), SI.

    Raises:
        SingularityError: a singular pose. InputError: a pose whose joint values leave
            +-:data:`~gpr_kinematics.inputs.validation.MAX_COORDINATE` (no solve takes them); errors that take them
            beyond it (named by the exact solve).
    """
    arr, _ = as_poses(poses)
    arr = mech.complete_pose(arr)
    ds = check_joint_errors(mech, joint_errors, arr.shape[0])
    dp = _parameter_errors(mech, parameter_errors)
    cond = _check_regular(mech, arr)
    q = mech.inverse_kinematics(arr)
    reach = np.max(np.abs(q), axis=-1)
    if not np.all(reach <= MAX_COORDINATE):  # no solve takes them (too large errors are named by the exact solve)
        k = int(np.argmax(~(reach <= MAX_COORDINATE)))
        raise InputError(f'{mech.name}: the pose {brief(arr[k].tolist())} needs joint values of {reach[k]:.17g}; '
                         f'allowed: poses whose joint values stay within +-{MAX_COORDINATE:g} (SI)')
    rhs = _right_side(mech, arr, ds, dp)   # once for both deviations (its parameter Jacobians are differences)
    lin = _deviation(mech, arr, rhs)
    try:
        exact_poses = follow(mech, dp, arr, q, ds, tol,
                             lambda at, rows: _motion(mech, at, _right_side(mech, at, ds[rows], dp)))
    except PathEndedError as exc:   # it said only 'did not converge to 1e-13 in 50 iterations', not where
        raise _unsolved(mech, arr, cond, exc) from None
    exact = mech.coordinates(exact_poses) - mech.coordinates(arr)
    angular = np.array([mech.pose_names.index(v) >= 3 for v in mech.pose_variables])
    exact[:, angular] = wrap_angle(exact[:, angular])  # Euler angles wrap
    lock = np.sin(euler_lock_distance(mech, arr)) < EULER_LOCK_UNDEFINED
    exact[np.ix_(lock, angular)] = np.nan   # not defined there, as the linearised ones (the split of the first and
    # third angle at the lock printed -1.005 and +1.006 rad for a platform turned by 2 mrad)
    # mechanisms whose errors also move the outcome components have their own
    lin_twist = mech.linearized_twist(arr, ds, dp) if hasattr(mech, 'linearized_twist') else _motion(mech, arr, rhs)
    dR = mech.rotation(exact_poses) @ np.swapaxes(mech.rotation(arr), -1, -2)
    exact_twist = np.concatenate([exact_poses[:, :3] - arr[:, :3], rotation_vector(dR)], axis=-1)
    return AccuracyResult(mechanism=mech.name, variables=tuple(mech.pose_variables), poses=arr, joints=q,
                          joint_errors=ds, parameter_errors=dp, linearized=lin, exact=exact,
                          exact_poses=exact_poses, condition_number=cond, linearized_twist=lin_twist,
                          exact_twist=exact_twist, warnings=euler_lock_warnings(mech, arr))

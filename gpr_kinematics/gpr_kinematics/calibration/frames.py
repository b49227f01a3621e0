"""Registration: the measuring instrument's frame and the measured target, identified with the geometry.

A laser tracker measures the pose (a 6-DOF probe) or the position (a reflector) of a *target* fixed on the
platform, in its own frame. The measured pose of row ``i`` is

    ``T_i = B  P(theta, q_i)  G``

with ``P`` the pose of ``gpr_platform`` in ``gpr_base`` (the geometry's model), ``B`` the pose of ``gpr_base`` in
the measuring frame (the tf transform ``tracker -> gpr_base``) and ``G`` the pose of the target in
``gpr_platform``. :class:`FramedModel` adds the unknown ones to the geometry's parameters: ``base_x base_y base_z``
(the position of ``gpr_base``'s origin in the measuring frame [m]) and ``base_rx base_ry base_rz`` (a rotation
vector [rad] that turns the reference orientation ``R_B0`` in the measuring frame's axes, ``R_B = exp([r]x) R_B0``),
and ``target_x target_y target_z`` and ``target_rx target_ry target_rz`` (the target in ``gpr_platform``,
``R_G = exp([r]x) R_G0`` in the platform's axes; only the position for a measured point). Their a-priori
uncertainty (:data:`FRAME_SCALES`) is large against the geometry's: where a frame trades with the geometry (a
common shift of the three rods is a shift of ``gpr_base``), the identifiability analysis holds a geometric
parameter (that rod defines the frame) and fits the frame, and says so.

The reference values come from a closed-form registration against the nominal model (:func:`initial_frames`):
the base's orientation from the rotation axes of the measured relative rotations (Kabsch's alignment, *A solution
for the best rotation to relate two sets of vectors*, Acta Cryst. A32, 1976), the target's orientation as the
mean of the remaining rotations, the positions by linear least squares; for points, alternating Kabsch
alignments of the points and least squares of the target's position, from the heading found and from its half
turn about gpr_base's z axis, the one that leaves the smaller errors kept. A point ``t`` on a platform tilted by a
small rotation vector ``a`` (horizontal) moves by ``a x t``, which is unchanged when ``gpr_base`` turns by half a
turn about its z axis and the target's ``t_z`` changes sign: only the second order of the tilt (some 60 um for a
target 0.1 m out at 2 deg) tells the two apart, and the heading search alone picked the half-turned one for 5 of 40
seeded machines measured at 60 random configurations (their fits failed the gate: out of iterations, ``kappa`` at a
bound, reduced chi-square 18-36). The fit refines them.
"""
from __future__ import annotations

import copy
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.rotations import euler_from_rotation, kabsch, quaternion_from_matrix, rotation_from_vector, rotation_vector
from ..errors import InputError
from .fitting import levenberg_marquardt
from .measurements import Measurements
from .model import Parameter, ParameterSet, PoseModel, evaluate
from .plausibility import measured_errors

Array = NDArray[np.float64]

#: A-priori standard uncertainty of a frame's position [m] and rotation [rad] after the closed-form registration.
FRAME_SCALES = {'m': 1e-2, 'rad': 1e-2}
AXES = ('x', 'y', 'z', 'rx', 'ry', 'rz')
#: Alternations of the points' registration (:func:`initial_frames`).
POINT_ALTERNATIONS = 20


@dataclass(frozen=True)
class Transform:
    """A frame's pose in its parent: ``position (3,)`` [m] and ``rotation (3, 3)``."""

    position: Array
    rotation: Array

    @staticmethod
    def identity() -> Transform:
        return Transform(np.zeros(3), np.eye(3))

    @staticmethod
    def from_xyz_rpy(values: Sequence[float]) -> Transform:
        """From ``x y z [roll pitch yaw]`` (URDF ``rpy``: ``Rz(yaw) Ry(pitch) Rx(roll)``; 3 values: no rotation)."""
        from ..core.rotations import rpy_matrix
        v = [float(x) for x in values]
        if len(v) not in (3, 6) or not np.all(np.isfinite(v)):
            raise InputError(f'a pose is x y z [roll pitch yaw] (3 or 6 finite numbers), got {len(v)}')
        return Transform(np.array(v[:3]), rpy_matrix(*v[3:]) if len(v) == 6 else np.eye(3))

    @property
    def is_identity(self) -> bool:
        return not np.any(self.position) and bool(np.array_equal(self.rotation, np.eye(3)))

    @property
    def rpy(self) -> Array:
        """Roll, pitch, yaw [rad] (URDF ``rpy``)."""
        return np.asarray(euler_from_rotation(self.rotation[None], 'xyz')[0], dtype=np.float64)

    def as_dict(self) -> dict[str, list[float]]:
        return {'position': self.position.tolist(), 'rpy': self.rpy.tolist(),
                'quaternion': quaternion_from_matrix(self.rotation).tolist()}


TARGET_FITS = ('pose', 'position')


class FramedModel:
    """Poses of a target on the platform in a measuring frame (module docstring): ``inner``'s parameters (but those
    that follow from the frames' datum), then those of the unknown frames.

    Args:
        inner: the geometry's pose model (``gpr_platform`` in ``gpr_base``), with a ``datum(base, target)`` method
            when frames fitted with it trade with its parameters (:meth:`~.core_model.CoreModel.datum`).
        base, target: reference poses of ``gpr_base`` in the measuring frame and of the target in ``gpr_platform``.
        fit_base: ``gpr_base``'s pose is identified (else known). fit_target: ``None`` (known), ``pose`` or
            ``position`` (its orientation known; the only choice for measured points).
        points: the measurements are points (the target's orientation is then not a parameter).
        free: the inner parameters that will be fitted (names or keys; default all): the datum conditions apply to
            those only.
    """

    def __init__(self, inner: PoseModel, base: Transform, target: Transform, fit_base: bool,
                 fit_target: str | None, points: bool = False, free: Iterable[str] | None = None) -> None:
        if fit_target not in (None,) + TARGET_FITS:
            raise InputError(f'fit_target {fit_target!r}; allowed: None, {", ".join(TARGET_FITS)}')
        self.inner, self.base, self.target = inner, base, target
        self.fit_base, self.points = fit_base, points
        self.fit_target = 'position' if points and fit_target else fit_target
        self.supports_displacement = inner.supports_displacement
        datum = getattr(inner, 'datum', None)
        P = len(inner.parameters)
        found: tuple[Array, tuple[str, ...], str] = (
            datum(fit_base, 'points' if points and fit_target else self.fit_target, inner.parameters.select(free))
            if callable(datum) else (np.zeros((0, P)), (), ''))
        #: The datum's linear conditions on the inner coordinates, and in words (:meth:`CoreModel.datum`).
        self.conditions, dependent, self.datum_text = found
        self.dependent = np.array([inner.parameters.index(n) for n in dependent], dtype=np.int64)
        self.independent = np.flatnonzero(~np.isin(np.arange(P), self.dependent)).astype(np.int64)
        if self.dependent.size:   # theta_D = nominal_D - C_D^-1 C_I (theta_I - nominal_I)
            self.follow = -np.linalg.solve(self.conditions[:, self.dependent], self.conditions[:, self.independent])
        extra = []
        for frame, ref, n in (('base', base, 6 if fit_base else 0),
                              ('target', target, {'pose': 6, 'position': 3, None: 0}[self.fit_target])):
            for k, axis in enumerate(AXES[:n]):
                unit = 'm' if k < 3 else 'rad'
                extra.append(Parameter(f'{frame}_{axis}', float(ref.position[k]) if k < 3 else 0.0, unit,
                                       FRAME_SCALES[unit], f'{frame}_frame', (k,)))
        self._parameters = ParameterSet(tuple(inner.parameters[int(j)] for j in self.independent) + tuple(extra))
        self.n_inner = self.independent.size
        on_rods, mismatch = getattr(inner, 'joints_on_rods', None), getattr(inner, 'side_mismatch', None)
        self._inner_family: tuple[Callable[[Array, Array], Array], Callable[[Array], float]] | None = None
        if callable(on_rods) and callable(mismatch):
            self._inner_family = (on_rods, mismatch)
        #: The inner model's family of machines far off the nominal one (``joints_on_rods``, ``side_mismatch`` of
        #: :class:`~.core_model.CoreModel`) in these coordinates, ``None`` when it has none: :meth:`_joints_on_rods`,
        #: :meth:`_side_mismatch`.
        self.joints_on_rods: Callable[[Array], Array] | None = self._joints_on_rods if self._inner_family else None
        self.side_mismatch: Callable[[Array], float] | None = self._side_mismatch if self._inner_family else None

    @property
    def parameters(self) -> ParameterSet:
        return self._parameters

    def inner_theta(self, theta: Array) -> Array:
        """The inner model's coordinates ``(S, P_inner)`` of rows ``theta (S, P)``: the independent ones, and those
        that follow from the datum."""
        nominal = self.inner.parameters.nominal
        out = np.repeat(nominal[None], theta.shape[0], axis=0)
        out[:, self.independent] = theta[:, :self.n_inner]
        if self.dependent.size:
            out[:, self.dependent] += (theta[:, :self.n_inner] - nominal[self.independent]) @ self.follow.T
        return out

    def _joints_on_rods(self, theta: Array) -> Array:
        """Rows ``theta (S, P)`` with the inner model's joints on their rods
        (:meth:`~.core_model.CoreModel.joints_on_rods`, the datum's conditions on the joints kept: the frames do not
        move); the frames' coordinates unchanged."""
        assert self._inner_family is not None
        th = np.array(theta, dtype=float)
        rows = th.reshape(-1, th.shape[-1])
        on = self._inner_family[0](self.inner_theta(rows), self.conditions)
        rows[:, :self.n_inner] = on[:, self.independent]
        return rows.reshape(th.shape)

    def _side_mismatch(self, theta: Array) -> float:
        """The inner model's :meth:`~.core_model.CoreModel.side_mismatch` at coordinates ``theta (P,)``."""
        assert self._inner_family is not None
        return float(self._inner_family[1](self.inner_theta(np.asarray(theta, dtype=float)[None])[0]))

    def swapped_columns(self) -> list[tuple[str, FramedModel]]:
        """The inner model's other readings of its own columns (an arm's joints swapped:
        :meth:`~.arm.ArmModel.swapped_columns`), each about this model's frames: :func:`~.plausibility.other_reading`'s.
        """
        readings = getattr(self.inner, 'swapped_columns', None)
        out = []
        for words, inner in readings() if callable(readings) else []:
            other = copy.copy(self)
            other.inner = inner   # the same parameters, frames and datum: only the columns read differ
            out.append((words, other))
        return out

    def registered(self, meas: Measurements) -> Array:
        """Coordinates ``(P,)``: the geometry nominal, the frames fitted alone to ``meas`` (Levenberg-Marquardt from
        the closed-form registration; metres and radians weighted alike): the nominal model's best registration. The
        closed form's rotation axes of relative rotations turn by degrees for a machine whose rods lean by a few
        milliradians (its tilts are tens of milliradians), and its poses then lie centimetres from measurements that
        the fit explains."""
        params = self.parameters
        fit = np.arange(self.n_inner, len(params), dtype=np.int64)

        def residuals(theta: Array) -> Array:
            return measured_errors(self, meas, theta)

        return levenberg_marquardt(residuals, params, params.nominal, fit, params.scale, 'registered').theta

    def frames(self, theta: Array) -> tuple[Transform, Transform]:
        """The base and target poses at coordinates ``theta (P,)``."""
        pb, Rb, pt, Rt = self._frames(np.asarray(theta, dtype=float)[None])
        return Transform(pb[0], Rb[0]), Transform(pt[0], Rt[0])

    def _frames(self, theta: Array) -> tuple[Array, Array, Array, Array]:
        S, k = theta.shape[0], self.n_inner
        out = []
        for ref, n in ((self.base, 6 if self.fit_base else 0),
                       (self.target, {'pose': 6, 'position': 3, None: 0}[self.fit_target])):
            v = theta[:, k:k + n]
            k += n
            out.append(v[:, :3] if n else np.broadcast_to(ref.position, (S, 3)))
            out.append(rotation_from_vector(v[:, 3:]) @ ref.rotation if n == 6
                       else np.broadcast_to(ref.rotation, (S, 3, 3)))
        return out[0], out[1], out[2], out[3]

    def base_steps(self, theta: Array) -> Array:
        """``(6, P)``: what a step of the coordinates ``theta (P,)`` moves the identified ``gpr_base`` by, its position
        [m] and the small rotation ``d`` turning it about the frame's axes (``exp([r + dr]x) = exp([d]x) exp([r]x)``:
        ``d = J_l(r) dr``, the left Jacobian ``I + (1 - cos t) / t^2 [r]x + (t - sin t) / t^3 [r]x^2``, ``t = |r|``)."""
        k = self.n_inner
        r = np.asarray(theta, dtype=float)[k + 3:k + 6]
        t2 = float(r @ r)
        a, b = ((1.0 - math.cos(math.sqrt(t2))) / t2, (math.sqrt(t2) - math.sin(math.sqrt(t2))) / t2 ** 1.5) \
            if t2 > 1e-8 else (0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0)
        K = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
        out = np.zeros((6, len(self.parameters)))
        out[:3, k:k + 3] = np.eye(3)
        out[3:, k + 3:k + 6] = np.eye(3) + a * K + b * K @ K
        return out

    def poses(self, theta: Array, Q: Array, displacement: Array | None = None) -> tuple[Array, Array]:
        pos, rot = self.inner.poses(self.inner_theta(theta), Q, displacement)
        pb, Rb, pt, Rt = self._frames(theta)
        p = pos + np.einsum('snij,sj->sni', rot, pt)
        return (pb[:, None, :] + np.einsum('sij,snj->sni', Rb, p),
                np.einsum('sij,snjk,skl->snil', Rb, rot, Rt))


def _mean_rotation(R: Array) -> Array:
    """The rotation nearest the mean of rotation matrices ``(N, 3, 3)``."""
    return kabsch(np.eye(3), R.mean(axis=0).T)


def _positions(A: Array, p: Array, R: Array, m: Array, t: Array | None, c: Array | None) -> tuple[Array, Array]:
    """Least squares of ``m_i = A (p_i + R_i t) + c`` for the unknown ones of ``t`` (target) and ``c`` (base)."""
    rhs = m - p @ A.T
    cols, n = [], m.shape[0]
    if t is None:
        cols.append(np.einsum('ij,njk->nik', A, R))
    else:
        rhs = rhs - np.einsum('ij,njk,k->ni', A, R, t)
    if c is None:
        cols.append(np.broadcast_to(np.eye(3), (n, 3, 3)))
    else:
        rhs = rhs - c
    x = np.linalg.lstsq(np.concatenate(cols, axis=2).reshape(3 * n, -1), rhs.ravel(), rcond=None)[0]
    t_out = x[:3] if t is None else t
    c_out = (x[3:] if t is None else x[:3]) if c is None else c
    return np.asarray(t_out, dtype=np.float64), np.asarray(c_out, dtype=np.float64)


def initial_frames(inner: PoseModel, meas: Measurements, base: Transform | None, target_position: Array | None,
                   target_rotation: Array | None) -> tuple[Transform, Transform]:
    """Reference poses of ``gpr_base`` in the measuring frame and of the target in ``gpr_platform`` by the
    closed-form registration against the nominal model (module docstring); ``base``, the target's position and its
    rotation are the known ones (``None``: unknown; a measured point has no rotation)."""
    p, R = evaluate(inner, inner.parameters.nominal, meas.q)
    m = meas.position
    A = None if base is None else base.rotation
    c_known = None if base is None else base.position
    if meas.quaternion is not None:
        M = meas.rotation
        if A is None:
            if target_rotation is not None:
                A = _mean_rotation(M @ target_rotation.T @ np.swapaxes(R, 1, 2))
            else:   # rotation axes of the relative rotations: rv(M_i M_0^T) = A rv(R_i R_0^T)
                a = rotation_vector(R @ R[0].T)
                b = rotation_vector(M @ M[0].T)
                if np.linalg.matrix_rank(a, tol=1e-6 * max(float(np.abs(a).max()), 1e-300)) < 2:
                    raise InputError(f'{meas.source}: the measured poses do not tilt about two different axes: the '
                                     'orientation of the measuring frame cannot be registered (measure tilted poses '
                                     'at several azimuths, or give --base)')
                A = kabsch(a, b)
        G = target_rotation if target_rotation is not None else \
            _mean_rotation(np.swapaxes(R, 1, 2) @ A.T @ M)
        t, c = _positions(A, p, R, m, target_position, c_known)
        return Transform(c, A), Transform(t, G)
    if A is not None:
        t, c = _positions(A, p, R, m, target_position, c_known)
        return Transform(c, A), Transform(t, np.eye(3))
    A = _heading_search(p, R, m, target_position)
    return min((_aligned(A @ turn, p, R, m, target_position) for turn in (np.eye(3), HALF_TURN)),
               key=lambda frames: frames[0])[1:]


#: A half turn about gpr_base's z axis: a point's tilted positions do not tell it to first order (module docstring).
HALF_TURN = np.diag([-1.0, -1.0, 1.0])


def _aligned(A: Array, p: Array, R: Array, m: Array, target: Array | None) -> tuple[float, Transform, Transform]:
    """The frames of points after :data:`POINT_ALTERNATIONS` alternations from the orientation ``A``: Kabsch's
    alignment of the target where the nominal model puts it, then the least-squares target and origin; the sum of
    the squared position errors [m^2] they leave, and the base and target."""
    t, c = _positions(A, p, R, m, target, None)
    for _ in range(POINT_ALTERNATIONS):
        x = p + np.einsum('nij,j->ni', R, t)    # the target where the nominal model puts it, aligned with the points
        A = kabsch(x - x.mean(axis=0), m - m.mean(axis=0))
        t, c = _positions(A, p, R, m, target, None)
    cost = float(np.sum((m - c - (p + np.einsum('nij,j->ni', R, t)) @ A.T) ** 2))
    return cost, Transform(c, A), Transform(t, np.eye(3))


#: Headings tried by :func:`_heading_search` (every 5 degrees).
HEADINGS = 72


def _heading_search(p: Array, R: Array, m: Array, t: Array | None) -> Array:
    """The measuring frame's orientation from points: its z axis along the line the points move on as the rods
    lengthen (a regression on the nominal heights), its heading the best of :data:`HEADINGS` headings about it
    (each with the least-squares target and origin): the points of a vertical stroke alone do not tell it."""
    h = p[:, 2] - p[:, 2].mean()
    if float(h @ h) <= 0.0:
        raise InputError('the measured points do not move along the stroke: the measuring frame cannot be registered '
                         '(measure at several heights, or give --base)')
    a = (m - m.mean(axis=0)).T @ h / float(h @ h)
    z = a / np.linalg.norm(a)
    axis = np.cross([0.0, 0.0, 1.0], z)
    s = float(np.linalg.norm(axis))
    tilt = rotation_from_vector((axis / s * np.arctan2(s, z[2]))[None])[0] if s > 1e-15 else \
        (np.eye(3) if z[2] > 0 else np.diag([1.0, -1.0, -1.0]))
    best, best_cost = tilt, np.inf
    for psi in 2.0 * np.pi * np.arange(HEADINGS) / HEADINGS:
        A = tilt @ rotation_from_vector(np.array([[0.0, 0.0, psi]]))[0]
        tt, c = _positions(A, p, R, m, t, None)
        cost = float(np.sum((m - c - (p + np.einsum('nij,j->ni', R, tt)) @ A.T) ** 2))
        if cost < best_cost:
            best, best_cost = A, cost
    return np.asarray(best, dtype=np.float64)


def measuring_model(inner: PoseModel, meas: Measurements, frame: str = 'gpr_base', base: Transform | None = None,
                    target: Transform | None = None, fit_target: str | None = None,
                    free: Iterable[str] | None = None) -> PoseModel:
    """The pose model of measurements in ``frame``: ``inner`` itself for poses of ``gpr_platform`` in ``gpr_base``,
    else a :class:`FramedModel` from the closed-form registration (:func:`initial_frames`). ``base``: the pose of
    ``gpr_base`` in ``frame`` when known (``gpr_base``: the identity); ``target``: the target's known pose in
    ``gpr_platform`` (the start of its identification with ``fit_target`` ``pose`` or ``position``, which keeps its
    orientation); measured points or a ``frame`` other than ``gpr_base`` identify an unknown target by default.
    ``free``: the inner parameters to be fitted (their datum)."""
    points = meas.quaternion is None
    known_base = base if base is not None else (Transform.identity() if frame == 'gpr_base' else None)
    if fit_target is None and target is None and (points or frame != 'gpr_base'):
        fit_target = 'position' if points else 'pose'
    if known_base is not None and fit_target is None:     # nothing to identify
        given = target if target is not None else Transform.identity()
        if known_base.is_identity and given.is_identity and not points:
            return inner
        return FramedModel(inner, known_base, given, False, None, points, free)
    position = None if fit_target is not None or target is None else target.position
    rotation = None if fit_target == 'pose' or target is None else target.rotation
    ref_base, ref_target = initial_frames(inner, meas, known_base, position, rotation)
    return FramedModel(inner, ref_base, ref_target, known_base is None, fit_target, points, free)

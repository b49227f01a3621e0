"""Parameter models: named geometric parameters and a forward model of the measured platform pose.

Calibration, measurement planning and the accuracy budget all work on a *pose model*: a function

    poses(theta, Q, displacement) -> (positions, rotations)

from a parameter vector ``theta`` (``S`` rows of ``P`` named parameters, SI units) and commanded rod lengths
``Q`` (``S x N`` configurations, metres) to the pose of ``gpr_platform`` in ``gpr_base`` (positions ``(S, N, 3)``
in metres, rotation matrices ``(S, N, 3, 3)``). ``displacement`` ``(S, N, 3, 3)`` optionally displaces joint
centre ``k`` of each configuration by a vector in ``gpr_base`` (the play of a spherical joint); a model that
cannot do that says so with ``supports_displacement = False``. The engines take the model as an argument, so
any forward kinematics with named parameters (the core's, a test's reference model) plugs in.

The pose error of a pose ``(p, R)`` against a reference ``(p0, R0)`` is the 6-vector
``e = (p - p0, phi)`` with ``phi`` the rotation vector of ``R R0^T`` (radians, in ``gpr_base``): metres and
radians, zero exactly when the poses agree.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.rotations import rotation_vector
from ..errors import InputError, brief
from ..inputs.stacked import Stacked
from ..inputs.validation import finite_vector, rows_of

Array = NDArray[np.float64]

#: Units a parameter may have: metres, radians or a dimensionless ratio.
UNITS = ('m', 'rad', '1')
#: Coordinates a parameter may be identified in (:attr:`Parameter.transform`): the value itself, or for a stiffness
#: ratio ``kappa`` its anisotropy ``a = (kappa - 1) / (kappa + 1)``.
TRANSFORMS = ('', 'anisotropy')
#: Range of a stiffness ratio (the geometry file's ``kappa``), and of its anisotropy.
KAPPA_RANGE = (1e-6, 1e6)
#: Central finite-difference step as a fraction of a parameter's scale (its a-priori uncertainty): small
#: enough for a truncation error ~1e-4 relative on a scale-sized effect, large enough that a solver
#: tolerance of 1e-14 m costs < 1e-8 relative.
FD_STEP_FRACTION = 1e-2


def coordinate_of(transform: str, value: ArrayLike) -> Array:
    """The coordinate of values under ``transform`` (:data:`TRANSFORMS`): the value, or the anisotropy
    ``(kappa - 1) / (kappa + 1)`` of a stiffness ratio."""
    v = np.asarray(value, dtype=float)
    return (v - 1.0) / (v + 1.0) if transform == 'anisotropy' else v


@dataclass(frozen=True)
class Parameter:
    """One geometric parameter of a pose model.

    The engines work on its *coordinate* ``u``: the value itself, or, with ``transform = 'anisotropy'`` (a
    stiffness ratio ``kappa = k_t / k_r``), ``u = (kappa - 1) / (kappa + 1)`` in ``(-1, 1)``: ``-1`` tangentially
    free, ``0`` isotropic, ``+1`` tangentially rigid (the radial model). The compliant model's centre shift is about
    ``R alpha^2 / 4 * u`` (docs/core.md), linear in ``u`` where it saturates in ``kappa``, so a fit or a linearised
    budget in ``u`` is well behaved from ``kappa = 1000`` as from ``kappa = 1``. Reports show the value.

    Attributes:
        name: unique name, e.g. ``rod1_x``, ``rod2_offset``, ``kappa1``.
        nominal: nominal (design) coordinate (the value, unless transformed).
        unit: ``m``, ``rad`` or ``1`` (dimensionless), of the coordinate and of the value.
        scale: a-priori standard uncertainty of the coordinate (its tolerance), > 0. It scales the identification
            Jacobian (so that singular values compare the information of the measurements with what is known
            before measuring) and sets the finite-difference step.
        key: the configuration-file key the value is written to (``rod_offsets`` for ``rod2_offset``).
        index: the element of a list-valued ``key`` (0-based; a path into nested lists), ``()`` for a scalar key.
        transform: ``''`` or ``'anisotropy'`` (:data:`TRANSFORMS`).
        nominal_value: the value at the nominal coordinate, exactly (a transform's round trip loses the last
            digits: kappa 1000 would come back as 999.99999999998); ``None``: the transform of the nominal.
        limits: the range of an untransformed coordinate, what the file it is written to allows (an arm's link
            length at least 0: a fitted -1.7e-7 m was written and then refused by the loader).
    """

    name: str
    nominal: float
    unit: str
    scale: float
    key: str
    index: tuple[int, ...] = ()
    transform: str = ''
    nominal_value: float | None = None
    limits: tuple[float, float] = (-math.inf, math.inf)

    def __post_init__(self) -> None:
        if self.unit not in UNITS:
            raise InputError(f'parameter {self.name}: unit {self.unit!r}; allowed: {", ".join(UNITS)}')
        if self.transform not in TRANSFORMS:
            raise InputError(f'parameter {self.name}: transform {self.transform!r}; allowed: '
                             f'{", ".join(map(repr, TRANSFORMS))}')
        lo, hi = self.bounds
        if not (np.isfinite(self.nominal) and lo <= self.nominal <= hi and np.isfinite(self.scale)
                and self.scale > 0):
            raise InputError(f'parameter {self.name}: nominal {self.nominal!r} and scale {self.scale!r} must be '
                             f'finite, the nominal within [{lo:g}, {hi:g}], the scale > 0')

    @property
    def step(self) -> float:
        """Central finite-difference step of the coordinate [unit] (:meth:`ParameterSet.steps` keeps it inside
        :attr:`bounds`)."""
        return FD_STEP_FRACTION * self.scale

    @property
    def bounds(self) -> tuple[float, float]:
        """Range of the coordinate: :attr:`limits` (``(-inf, inf)`` by default), or for an anisotropy the image of
        :data:`KAPPA_RANGE`."""
        if self.transform == 'anisotropy':
            lo, hi = KAPPA_RANGE
            return (lo - 1.0) / (lo + 1.0), (hi - 1.0) / (hi + 1.0)
        return self.limits

    def value(self, u: ArrayLike) -> Array:
        """The value of coordinates ``u``: ``kappa = (1 + u) / (1 - u)`` for an anisotropy.

        >>> Parameter('kappa1', 0.5, '1', 0.5, 'kappa', (0,), 'anisotropy').value([0.0, 0.5, -0.5]).tolist()
        [1.0, 3.0, 0.3333333333333333]
        """
        a = np.asarray(u, dtype=float)
        if self.transform != 'anisotropy':
            return a
        v = np.clip((1.0 + a) / (1.0 - a), *KAPPA_RANGE)      # (at the bounds: not a rounding beyond them)
        return v if self.nominal_value is None else np.where(a == self.nominal, self.nominal_value, v)

    def coordinate(self, value: ArrayLike) -> Array:
        """The coordinate of values (the inverse of :meth:`value`)."""
        return coordinate_of(self.transform, value)

    def value_slope(self, u: ArrayLike) -> Array:
        """``d value / d u`` at ``u`` (for standard errors of the value: the delta method)."""
        a = np.asarray(u, dtype=float)
        return 2.0 / (1.0 - a) ** 2 if self.transform == 'anisotropy' else np.ones_like(a)


@dataclass(frozen=True)
class ParameterSet:
    """The ordered parameters of a model; ``theta`` vectors follow this order."""

    parameters: tuple[Parameter, ...]

    def __post_init__(self) -> None:
        names = [p.name for p in self.parameters]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputError(f'parameter names must be unique; repeated: {", ".join(dup)}')

    def __len__(self) -> int:
        return len(self.parameters)

    def __iter__(self) -> Iterator[Parameter]:
        return iter(self.parameters)

    def __getitem__(self, i: int) -> Parameter:
        return self.parameters[i]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    #: Per parameter, in order ``(P,)`` (:class:`Parameter`).
    nominal = Stacked('parameters')
    scale = Stacked('parameters')
    step = Stacked('parameters')

    @property
    def bounds(self) -> tuple[Array, Array]:
        """Lowest and highest coordinates ``(P,)`` (:attr:`Parameter.bounds`)."""
        b = np.array([p.bounds for p in self.parameters]).reshape(-1, 2)
        return b[:, 0], b[:, 1]

    def steps(self, theta: ArrayLike) -> tuple[Array, Array]:
        """Finite-difference steps up and down at coordinates ``theta``: :attr:`step`, shortened to half the
        distance to the nearer bound, so that ``theta +- step`` stays inside (an anisotropy near 1: a stiff joint)
        and the difference stays central; at a bound, where no central step fits, the step away from it alone
        (a one-sided difference)."""
        th = np.asarray(theta, dtype=float)
        lo, hi = self.bounds
        room_up, room_down = 0.5 * (hi - th), 0.5 * (th - lo)
        h = np.minimum(self.step, np.minimum(room_up, room_down))
        at = h <= 0.0
        return (np.asarray(np.where(at, np.minimum(self.step, room_up).clip(0.0), h), dtype=np.float64),
                np.asarray(np.where(at, np.minimum(self.step, room_down).clip(0.0), h), dtype=np.float64))

    def values(self, theta: ArrayLike) -> Array:
        """Values ``(..., P)`` of coordinate rows ``theta (..., P)`` (:meth:`Parameter.value` per column)."""
        return self._transformed(theta, to_value=True)

    def coordinates(self, values: ArrayLike) -> Array:
        """Coordinates ``(..., P)`` of value rows (the inverse of :meth:`values`)."""
        return self._transformed(values, to_value=False)

    def _transformed(self, rows: ArrayLike, to_value: bool) -> Array:
        out = np.array(rows, dtype=float)
        for j, p in enumerate(self.parameters):
            if p.transform:
                out[..., j] = p.value(out[..., j]) if to_value else p.coordinate(out[..., j])
        return out

    def value_slopes(self, theta: ArrayLike) -> Array:
        """``d value / d coordinate`` ``(P,)`` at ``theta``."""
        th = np.asarray(theta, dtype=float)
        return np.array([p.value_slope(th[j]) for j, p in enumerate(self.parameters)], dtype=float)

    @property
    def groups(self) -> tuple[str, ...]:
        """The configuration keys, in order of first appearance (``rod_offsets`` groups the three offsets)."""
        return tuple(dict.fromkeys(p.key for p in self.parameters))

    def index(self, name: str) -> int:
        """Position of the parameter ``name``; :class:`InputError` naming the allowed names otherwise."""
        for i, p in enumerate(self.parameters):
            if p.name == name:
                return i
        raise InputError(f'unknown parameter {name!r}; allowed: {", ".join(self.names)}')

    def select(self, names: Iterable[str] | None) -> NDArray[np.bool_]:
        """Mask of the parameters named by ``names`` (parameter names or configuration keys, which select every
        parameter of the key); ``None`` selects all. An unknown name raises :class:`InputError`."""
        if names is None:
            return np.ones(len(self), dtype=bool)
        if isinstance(names, (str, bytes)) or not isinstance(names, Iterable):   # 'rod1_offset' read letter by letter
            raise InputError(f'free = {brief(names)}; allowed: a list of parameter names or keys, or None (all)')
        mask = np.zeros(len(self), dtype=bool)
        for name in names:
            hit = np.array([p.name == name or p.key == name for p in self.parameters], dtype=bool)
            if not hit.any():
                raise InputError(f'unknown parameter {name!r}; allowed: {", ".join(self.names)} '
                                 f'(or a whole key: {", ".join(self.groups)})')
            mask |= hit
        return mask


def prior_scale(params: ParameterSet, prior: ArrayLike | None) -> Array:
    """A-priori standard deviations ``(P,)`` of the parameters: ``prior`` (e.g. from a tolerance table, ``nan`` for
    "use the parameter's scale") or the parameters' :attr:`Parameter.scale`."""
    scale = params.scale
    if prior is None:
        return scale
    a = np.asarray(prior, dtype=float)
    if a.shape != scale.shape or np.any(a <= 0) or np.any(np.isinf(a)):
        raise InputError(f'prior must be {scale.size} standard deviations > 0 (nan: the parameter\'s scale), '
                         f'got shape {a.shape}')
    return np.where(np.isnan(a), scale, a)


@runtime_checkable
class PoseModel(Protocol):
    """A forward model of the platform pose with named parameters (see the module docstring)."""

    @property
    def parameters(self) -> ParameterSet: ...

    @property
    def supports_displacement(self) -> bool: ...

    def poses(self, theta: Array, Q: Array, displacement: Array | None = None) -> tuple[Array, Array]:
        """``theta (S, P)``, ``Q (S, N, 3)`` [m], ``displacement (S, N, 3, 3)`` [m] or ``None`` ->
        positions ``(S, N, 3)`` [m] and rotations ``(S, N, 3, 3)``. The engines' inner call: it takes arrays of
        these shapes as given; :func:`evaluate` is the checked door (shapes, finite values, the model's answer)."""
        ...


def pose_model(model: object) -> PoseModel:
    """``model`` if it has the members of a :class:`PoseModel`, else :class:`InputError` naming what it is."""
    if not isinstance(model, PoseModel):   # a GprConfig given for its CoreModel raised a bare AttributeError
        raise InputError(f'model is a {type(model).__name__}; allowed: a pose model such as '
                         'gpr_kinematics.calibration.core_model.CoreModel(config) (a GprConfig goes in there)')
    return model


def as_configurations(Q: ArrayLike, name: str = 'rod lengths') -> Array:
    """Rod lengths as a finite ``(N, 3)`` array, ``N >= 1`` (a single ``(3,)`` becomes one row), with the core's
    checks and messages (``q2 = nan (sample 3) is not a finite number``)."""
    a = rows_of(Q, 'q', 3)
    if a.shape[0] == 0:
        raise InputError(f'{name}: no configurations given; allowed: rod lengths q1 q2 q3, shape (N, 3), N >= 1')
    return a


def evaluate(model: PoseModel, theta: ArrayLike, Q: ArrayLike,
             displacement: ArrayLike | None = None) -> tuple[Array, Array]:
    """Poses of ``model`` for parameter rows ``theta (S, P)`` (or one ``(P,)``) at rod lengths ``Q (N, 3)`` or
    ``(S, N, 3)``: positions ``(S, N, 3)`` and rotations ``(S, N, 3, 3)`` (``S`` axis dropped for one ``theta``).

    Checks the shapes the model returns and that every value is finite (:class:`InputError` otherwise), so an
    engine never carries a NaN from a model into a result.
    """
    th = np.asarray(theta, dtype=float)
    single = th.ndim == 1
    th = np.atleast_2d(th)
    P = len(pose_model(model).parameters)
    if th.ndim != 2 or th.shape[1] != P:
        raise InputError(f'theta must have {P} values per row (one per parameter), got shape {np.shape(theta)}')
    S = th.shape[0]
    Qa = np.asarray(Q, dtype=float)
    Qa = np.broadcast_to(Qa, (S,) + Qa.shape) if Qa.ndim == 2 else Qa
    if Qa.ndim != 3 or Qa.shape[0] != S or Qa.shape[2] != 3:
        raise InputError(f'rod lengths must have shape (N, 3) or ({S}, N, 3), got {np.shape(Q)}')
    disp = None
    if displacement is not None:
        if not model.supports_displacement:
            raise InputError(f'{type(model).__name__} cannot displace its joint centres (joint clearance); '
                             'it needs a model with per-joint geometry')
        disp = np.broadcast_to(np.asarray(displacement, dtype=float), Qa.shape[:2] + (3, 3))
    pos, rot = model.poses(th, np.ascontiguousarray(Qa), disp)
    n = Qa.shape[1]
    if np.shape(pos) != (S, n, 3) or np.shape(rot) != (S, n, 3, 3):
        raise InputError(f'{type(model).__name__}.poses returned shapes {np.shape(pos)}, {np.shape(rot)}; '
                         f'expected ({S}, {n}, 3) and ({S}, {n}, 3, 3)')
    if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(rot))):
        raise InputError(f'{type(model).__name__}.poses returned a non-finite pose')
    return (pos[0], rot[0]) if single else (pos, rot)


def pose_error(position: Array, rotation: Array, ref_position: Array, ref_rotation: Array) -> Array:
    """Pose errors ``(..., 6)``: ``position - ref_position`` [m] and the rotation vector of
    ``rotation ref_rotation^T`` [rad, ``gpr_base``]. Shapes broadcast over the leading axes.

    >>> import numpy as np
    >>> from gpr_kinematics.core.rotations import rotation_z
    >>> pose_error(np.zeros(3), rotation_z(1e-3), np.array([0, 0, 1e-6]), np.eye(3)).round(12).tolist()
    [0.0, 0.0, -1e-06, 0.0, 0.0, 0.001]
    """
    dp = np.asarray(position, dtype=float) - np.asarray(ref_position, dtype=float)
    phi = rotation_vector(np.asarray(rotation) @ np.swapaxes(np.asarray(ref_rotation), -1, -2))
    dp, phi = np.broadcast_arrays(dp, phi)
    return np.concatenate([dp, phi], axis=-1)


def pose_jacobian(model: PoseModel, theta: ArrayLike, Q: ArrayLike, columns: ArrayLike | None = None,
                  reference: tuple[Array, Array] | None = None) -> Array:
    """Derivatives ``(N, 6, C)`` of the pose error ``e(theta) = pose_error(poses(theta), reference)`` (position
    [m], rotation vector [rad]) by the parameters ``columns`` (indices or a mask; all by default), by central
    differences with each parameter's step (:meth:`ParameterSet.steps`):
    ``(e(theta + h_j) - e(theta - h_j)) / (2 h_j)``, error ``O(h^2)``; a parameter at a bound of its range gets
    the one-sided difference away from it (``(e(theta + u_j) - e(theta - d_j)) / (u_j + d_j)``, one step 0).
    ``reference`` (positions ``(N, 3)``, rotations ``(N, 3, 3)``; e.g. measured poses) defaults to the poses at
    ``theta`` itself (then the columns are the pose's sensitivities as small rigid motions).

    All ``2 C`` perturbed parameter rows go to the model in one call (one batch of ``2 C x N`` poses).
    """
    params = pose_model(model).parameters
    th = finite_vector(theta, 'theta', len(params))     # None was an IndexError deep in the steps
    cols = np.arange(len(params)) if columns is None else np.asarray(columns)
    if cols.dtype == bool:
        cols = np.flatnonzero(cols)
    Qa = as_configurations(Q)
    if cols.size == 0:
        return np.zeros((Qa.shape[0], 6, 0))
    up, down = (s[cols] for s in params.steps(th))
    rows = np.repeat(th[None, :], 2 * cols.size, axis=0)
    k = np.arange(cols.size)
    rows[2 * k, cols] += up
    rows[2 * k + 1, cols] -= down
    if reference is None:
        pos, rot = evaluate(model, np.vstack([th[None, :], rows]), Qa)
        pos, rot, reference = pos[1:], rot[1:], (pos[0], rot[0])
    else:
        pos, rot = evaluate(model, rows, Qa)
    e = pose_error(pos, rot, reference[0], reference[1])      # (2C, N, 6)
    d = (e[0::2] - e[1::2]) / (up + down)[:, None, None]      # (C, N, 6)
    return np.ascontiguousarray(d.transpose(1, 2, 0))


#: Central-difference step for rod lengths and joint displacements [m].
FD_STEP_LENGTH = 1e-6


def rod_jacobian(model: PoseModel, theta: ArrayLike, Q: ArrayLike) -> Array:
    """Derivatives ``(N, 6, 3)`` of the pose (as a small rigid motion: position [m], rotation vector [rad]) by the
    rod lengths ``q1 q2 q3``, by central differences of step :data:`FD_STEP_LENGTH`."""
    Qa = as_configurations(Q)
    h = FD_STEP_LENGTH
    Qs = np.repeat(Qa[None], 7, axis=0)
    for k in range(3):
        Qs[1 + 2 * k, :, k] += h
        Qs[2 + 2 * k, :, k] -= h
    pos, rot = evaluate(model, np.repeat(np.asarray(theta, dtype=float)[None], 7, axis=0), Qs)
    e = pose_error(pos[1:], rot[1:], pos[0], rot[0])
    return np.ascontiguousarray(((e[0::2] - e[1::2]) / (2.0 * h)).transpose(1, 2, 0))


def displacement_jacobian(model: PoseModel, theta: ArrayLike, Q: ArrayLike) -> Array:
    """Derivatives ``(N, 6, 3, 3)`` of the pose (position [m], rotation vector [rad]) by a displacement of joint
    centre ``k`` (axis 2) along the ``gpr_base`` axis ``i`` (axis 3), by central differences of step
    :data:`FD_STEP_LENGTH`; needs a model that supports displacements."""
    Qa = as_configurations(Q)
    h = FD_STEP_LENGTH
    n = Qa.shape[0]
    D = np.zeros((19, n, 3, 3))
    for j in range(9):
        D[1 + 2 * j, :, j // 3, j % 3] = h
        D[2 + 2 * j, :, j // 3, j % 3] = -h
    pos, rot = evaluate(model, np.repeat(np.asarray(theta, dtype=float)[None], 19, axis=0), Qa, D)
    e = pose_error(pos[1:], rot[1:], pos[0], rot[0])
    d = (e[0::2] - e[1::2]) / (2.0 * h)                       # (9, N, 6)
    return np.ascontiguousarray(d.transpose(1, 2, 0).reshape(n, 6, 3, 3))

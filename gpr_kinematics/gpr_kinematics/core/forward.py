"""Forward kinematics of the GPR under a virtual-joint model: rod lengths ``q`` -> platform pose.

Bratovanov & Sotirov §IV-V (``docs/references.md``); frames and conventions in ``docs/core.md``.

1. joint centres ``P_k = B_k + (q_k + o_k) u_k`` (:class:`~gpr_kinematics.core.machine.MachineGeometry`, the
   paper's eq. (1) on the nominal machine) and side lengths ``L_ij = |P_j - P_i|``;
2. virtual joints ``X`` from the closure (:func:`gpr_kinematics.core.virtual_joints.solve_closure`);
3. the rigid transform with ``P_k = Rot r_k(X) + t`` and the naive pose of the same rods
   (:func:`gpr_kinematics.core.platform_pose.platform_pose`); the *centre shift* is ``t - (0, 0, z_naive)``.

One driver, :func:`_forward`, serves a batch (vectorised over ``N``) and the same kernels on floats; :func:`forward`
takes the one-pose path (:mod:`gpr_kinematics.core.single`, :func:`one_result`), with the driver's floating-point
operations in the same order: results equal to the last bit, and to a batch row to rounding (~1e-16).

>>> import math
>>> fk = forward([0.5, 0.503, 0.498])
>>> fk.iterations, round(math.degrees(fk.tilt), 4), [round(v * 1e6, 3) for v in fk.centre_shift.tolist()]
(2, 1.7855, [22.045, -5.156, -0.239])
"""
from __future__ import annotations

import contextlib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any, Generic, NamedTuple, Self, TypeVar, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ConvergenceError, GprError, InputError, LimitError, NoPoseError, apart, brief
from ..inputs.validation import float_array, rows_of, switch, three_floats
from .closure import solve_closure
from .config import GprConfig, resolve_config
from .machine import MachineGeometry
from .naive import NaiveState, centres_tilt, leaning, naive_state
from .ops import ARRAY, SCALAR, Ops, Value
from .platform_pose import FitFloats, PlatformPose, platform_pose
from .rotations import tilt_of_normal
from .single import Centres, OnePose, one_pose
from .stroke import STROKE_SLACK, check_stroke, q_rows
from .unchecked import check_bound, check_turned_over, singular, singular_step, turned_over
from .virtual_joints import EDGES, Closure, VirtualJointModel, make_model

Array = NDArray[np.float64]
S = TypeVar('S')
I = TypeVar('I')  # noqa: E741 - the iteration counts' type, next to S and B
B = TypeVar('B')

#: Margin [rad] by which a solved tilt may exceed ``tilt_limit`` (rounding of targets at the limit).
TILT_LIMIT_SLACK = 1e-9


@dataclass(frozen=True)
class _Forward(Generic[S, I, B]):
    """The fields of a forward solution (SI units; quaternions x, y, z, w).

    Attributes:
        q: rod lengths [m]. model: virtual-joint model name.
        virtual_joints: ``X`` [m and rad], named by ``virtual_joint_names``.
        side_lengths: ``L12, L23, L31`` [m].
        position: platform origin in ``gpr_base`` [m]; rotation, quaternion: platform orientation.
        tilt: angle between platform normal and base z [rad], >= 0; tilt_azimuth: direction of the tilt
            axis ``e3 x n`` in (-pi, pi] [rad]; twist: remaining rotation about the normal [rad].
        nominal_position, nominal_rotation, nominal_quaternion: naive model for the same ``q``.
        centre_shift: ``position - nominal_position`` [m].
        joint_displacement: distance of each joint centre from its place ``p_k`` on the platform [m].
        within_budget: every ``joint_displacement`` <= the imperfection budget.
        iterations: Newton steps; residual: closure side-length error [m]; fit_residual: rigid fit [m].
    """

    q: Array
    model: str
    virtual_joints: Array
    virtual_joint_names: tuple[str, ...]
    side_lengths: Array
    position: Array
    rotation: Array
    quaternion: Array
    tilt: S
    tilt_azimuth: S
    twist: S
    nominal_position: Array
    nominal_rotation: Array
    nominal_quaternion: Array
    centre_shift: Array
    joint_displacement: Array
    within_budget: B
    iterations: I
    residual: S
    fit_residual: S

    @classmethod
    def from_fields(cls, values: Mapping[str, object]) -> Self:
        """The result with every field given in ``values`` (checked), without the frozen ``__init__``'s
        per-field ``object.__setattr__`` (4 us of a 40 us single forward call); the instance stays frozen."""
        if values.keys() != _FIELD_NAMES:
            raise TypeError(f'{cls.__name__} needs exactly the fields {sorted(_FIELD_NAMES)}')
        out = cls.__new__(cls)
        out.__dict__.update(values)
        return out


@dataclass(frozen=True)
class ForwardResult(_Forward[float, int, bool]):
    """One configuration: :class:`_Forward`'s fields, floats (angles, residuals, ``iterations``), arrays (vectors)."""

    @property
    def normal(self) -> Array:
        """Platform normal ``Rot e3`` in ``gpr_base``."""
        return self.rotation[:, 2]


@dataclass(frozen=True)
class ForwardBatch(_Forward[Array, NDArray[np.int64], NDArray[np.bool_]]):
    """``N`` configurations: :class:`ForwardResult`'s fields with a leading axis ``N`` (but ``_SHARED_FIELDS``)."""

    def __len__(self) -> int:
        return int(self.q.shape[0])

    def __getitem__(self, i: int) -> ForwardResult:
        out: dict[str, Any] = {name: getattr(self, name) for name in _SHARED_FIELDS}
        for name in _ROW_FIELDS:
            out[name] = getattr(self, name)[i]
        for name in _SCALAR_FIELDS:
            out[name] = getattr(self, name)[i].item()
        return ForwardResult(**out)

    @property
    def normal(self) -> Array:
        """Platform normals ``(N, 3)``."""
        return self.rotation[:, :, 2]

    @classmethod
    def of_one(cls, one: ForwardResult) -> ForwardBatch:
        """The batch of one row ``one`` (its arrays as views with a leading axis of length 1)."""
        out: dict[str, Any] = {name: getattr(one, name) for name in _SHARED_FIELDS}
        for name in _ROW_FIELDS:
            out[name] = getattr(one, name)[None]
        values = np.array([getattr(one, name) for name in _FLOAT_FIELDS])  # one array, a view per field
        for k, name in enumerate(_FLOAT_FIELDS):
            out[name] = values[k:k + 1]
        out['within_budget'], out['iterations'] = np.array([one.within_budget]), np.array([one.iterations])
        return cls.from_fields(out)


#: Fields of :class:`ForwardBatch` shared by all rows, with one array row per sample, and one scalar per sample.
_SHARED_FIELDS = ('model', 'virtual_joint_names')
_SCALAR_FIELDS = ('tilt', 'tilt_azimuth', 'twist', 'within_budget', 'iterations', 'residual', 'fit_residual')
#: The float ones among the scalar fields (``within_budget`` is a bool, ``iterations`` an int).
_FLOAT_FIELDS = tuple(name for name in _SCALAR_FIELDS if name not in ('within_budget', 'iterations'))
_ROW_FIELDS = tuple(f.name for f in fields(_Forward) if f.name not in _SHARED_FIELDS + _SCALAR_FIELDS)
_FIELD_NAMES = {f.name for f in fields(_Forward)}
#: The result of a driver: one pose's, or a batch's.
Result = TypeVar('Result', ForwardResult, ForwardBatch)


def side_lengths(ops: Ops, P: tuple[list[Value], list[Value], list[Value]]) -> list[Value]:
    """``L_ij = |P_j - P_i|`` of the joint centres ``P = (x, y, z)`` (component lists), edges 1-2, 2-3, 3-1."""
    x, y, z = P
    out = []
    for a, b in EDGES:
        dx, dy, dz = x[b] - x[a], y[b] - y[a], z[b] - z[a]
        out.append(ops.sqrt(dx * dx + dy * dy + dz * dz))
    return out


def tilt_words(tilt: float, limit: float, degrees: bool = False) -> tuple[str, str]:
    """``'<tilt> rad (<deg> deg)'`` and ``'<limit> rad (<deg> deg)'``, told apart (``degrees``: degrees first)."""
    (r, r_end), (d, d_end) = apart(tilt, limit, 9), apart(math.degrees(tilt), math.degrees(limit))
    w = (f'{r} rad', f'{d} deg', f'{r_end} rad', f'{d_end} deg')
    a, b, c, e = (w[1], w[0], w[3], w[2]) if degrees else w
    return f'{a} ({b})', f'{c} ({e})'


def beyond_tilt(tilt: float, limit: float, allowed: str = '|tilt|', degrees: bool = False) -> str:
    """``'<tilt> rad (<deg> deg) is beyond the tilt limit; allowed: <allowed> <= <limit> rad (<deg> deg)'``."""
    return '{0[0]} is beyond the tilt limit; allowed: {1} <= {0[1]}'.format(tilt_words(tilt, limit, degrees), allowed)


def _check_naive_tilt(ops: Ops, geo: MachineGeometry, q: Sequence[Value], config: GprConfig) -> NaiveState:
    """Refuse ``q`` whose naive tilt (leaning rods: :func:`~.naive.centres_tilt`) is 5 % beyond the limit (the real one
    differs by < 0.1 %; the margin keeps Newton in its basin; the exact check follows). Returns the naive state."""
    naive, lean = naive_state(ops, geo, q), leaning(geo)
    _, h2, _, _, nz = naive
    n_tilt = centres_tilt(ops, geo, q) if lean else ops.atan2(ops.sqrt(1.0 - ops.maximum(1.0 - h2, 0.0)), nz)
    too = (h2 >= 1.0) | (n_tilt > 1.05 * config.tilt_limit)
    if ops.any(too):
        i = int(np.argmax(np.where(np.atleast_1d(too), np.atleast_1d(n_tilt), -1.0)))
        limit = f'the tilt limit {config.tilt_limit:.4g} rad ({math.degrees(config.tilt_limit):.4g} deg)'
        if float(np.atleast_1d(h2)[i]) >= 1.0:  # the rods' differences exceed what any platform tilt makes
            raise NoPoseError(f'q = {q_rows(q)[i].tolist()} m{_sample(q, i)} imply no platform orientation (their '
                              f'differences are more than the joints\' spread can make at any tilt); allowed: rods '
                              f'within {limit}')
        t = float(np.atleast_1d(n_tilt)[i])   # the real tilt is not solved so far out (0.62 rad for 0.80 here)
        raise LimitError(f'q = {q_rows(q)[i].tolist()} m{_sample(q, i)} tilts the platform by about {t:.4g} rad '
                         f'({math.degrees(t):.4g} deg) {"as its joint centres" if lean else "in the naive model"}, '
                         f'beyond {limit}')
    return naive


def check_tilt(ops: Ops, q: Sequence[Value], tilt: Value, config: GprConfig) -> None:
    """Refuse the rods ``q`` whose platform ``tilt`` [rad] (one or a column) is beyond ``tilt_limit`` (+
    :data:`TILT_LIMIT_SLACK`): forward kinematics' rule, and inverse kinematics' for the rods it answers."""
    if ops.any(tilt > config.tilt_limit + TILT_LIMIT_SLACK):
        _refuse_tilt(q, tilt, config)


def _refuse_tilt(q: Sequence[Value], tilt: Value, config: GprConfig) -> None:
    t = np.atleast_1d(tilt)
    i = int(np.argmax(t))
    shown, limit = tilt_words(float(t[i]), config.tilt_limit)   # radians as the tilt_limit parameter, and degrees
    raise LimitError(f'q = {q_rows(q)[i].tolist()} m{_sample(q, i)} tilts the platform by {shown}, beyond the tilt '
                     f'limit {limit}')


def _rows(parameters: ArrayLike) -> int:
    """The rows of a two-dimensional ``parameters``, else 0 (its shape is refused by the per-row geometry)."""
    try:
        shape = np.shape(parameters)
    except ValueError:   # ragged
        return 0
    return shape[0] if len(shape) == 2 else 0


def _sample(q: Sequence[Value], i: int) -> str:
    """`` (sample i)`` where the rods ``q`` are a batch of more than one, as the stroke's refusal names it."""
    return f' (sample {i})' if q_rows(q).shape[0] > 1 else ''


def solve_pose(ops: Ops, geo: MachineGeometry, vjm: VirtualJointModel, q: Sequence[Value],
               config: GprConfig, naive: NaiveState | None = None) -> tuple[list[Value], Closure, PlatformPose]:
    """Side lengths, solved virtual joints and platform pose of rods ``q`` (floats or columns): the kernel
    chain of forward kinematics, without limit checks (``naive``: the naive state of ``q`` if known)."""
    P = geo.joint_centres(q)
    L = side_lengths(ops, P)
    closure = solve_closure(ops, vjm, L, config)
    return L, closure, platform_pose(ops, geo, q, P, closure.components, naive)


def assemble(ops: Ops, result: type[Result], q: Sequence[Value], vjm: VirtualJointModel, config: GprConfig,
             L: list[Value], closure: Closure, pose: PlatformPose) -> Result:
    """The result dataclass (``ForwardResult`` for floats, ``ForwardBatch`` for columns) of a solved pose."""
    position = ops.vector(pose.position)
    z = pose.nominal_z
    nominal_position = ops.vector([0.0 * z, 0.0 * z, z])
    jd = pose.joint_displacement
    return result.from_fields(dict(
        q=ops.vector(q), model=vjm.name, virtual_joints=ops.vector(closure.X), virtual_joint_names=vjm.names,
        side_lengths=ops.vector(L), position=position, rotation=ops.matrix(pose.rotation),
        quaternion=ops.vector(pose.quaternion), tilt=pose.tilt, tilt_azimuth=pose.tilt_azimuth, twist=pose.twist,
        nominal_position=nominal_position, nominal_rotation=ops.matrix(pose.nominal_rotation),
        nominal_quaternion=ops.vector(pose.nominal_quaternion), centre_shift=position - nominal_position,
        joint_displacement=ops.vector(jd),
        within_budget=ops.maximum(ops.maximum(jd[0], jd[1]), jd[2]) <= config.imperfection_budget,
        iterations=closure.iterations, residual=closure.residual, fit_residual=pose.fit_residual))


def _forward(ops: Ops, result: type[Result], q: Sequence[Value], config: GprConfig, vjm: VirtualJointModel,
             check_limits: bool, geometry: MachineGeometry | None = None, stroke: bool = True) -> Result:
    geo = MachineGeometry.of(config) if geometry is None else geometry
    naive = None
    if check_limits:
        if stroke:
            check_stroke(ops, q, config, typed=True)
        naive = _check_naive_tilt(ops, geo, q, config)
    L, closure, pose = solve_pose(ops, geo, vjm, q, config, naive)
    if check_limits:
        check_tilt(ops, q, pose.tilt, config)
    return assemble(ops, result, q, vjm, config, L, closure, pose)


def forward_batch(Q: ArrayLike, config: GprConfig | None = None, model: str | None = None,
                  check_limits: bool = True, parameters: ArrayLike | None = None,
                  names: Sequence[str] | None = None, displacement: ArrayLike | None = None,
                  stroke: bool = True) -> ForwardBatch:
    """Forward kinematics of rod lengths ``Q (N, 3)`` [m], vectorised over ``N``.

    ``parameters (N, P)``: one machine per sample, the geometry parameters ``names`` (default all of
    :data:`~gpr_kinematics.core.parameters.PARAMETER_NAMES`, ``P = 24``) of sample ``i`` in row ``i`` [SI], the rest of
    ``config`` shared (:meth:`~gpr_kinematics.core.machine.MachineGeometry.per_row`): the same kernels, one call for
    many machines (the perturbed machines of a Jacobian, the samples of a Monte Carlo budget). Row ``i`` gives
    what ``forward_batch(Q[i:i+1], config_with_parameters(config, parameters[i], names))`` gives (to rounding).
    ``parameters (M, P)`` with ``N = M k``: row ``j`` for the ``k`` consecutive samples ``j k .. j k + k - 1``
    (``M`` machines at the same ``k`` configurations each).

    ``displacement (N, 3, 3)``: the joint centre ``P_k`` of sample ``i`` moved by ``displacement[i, k]`` in
    ``gpr_base`` [m] (the play of a spherical joint; :meth:`~gpr_kinematics.core.machine.MachineGeometry.displaced`).
    ``stroke=False``: the limits but the stroke, which the caller checked naming its rods (the robot's paths).

    Raises:
        InputError: wrong shape, NaN, infinity, a rod beyond 1e6 m; unknown model; a parameter row out of its ranges.
        LimitError: a rod outside the stroke, or a tilt beyond ``tilt_limit`` (if ``check_limits``).
        ConvergenceError: the closure did not converge (cannot happen inside the limits).
    """
    cfg = resolve_config(config)
    A = rows_of(Q, 'q', 3)
    check_limits, stroke = switch(check_limits, 'check_limits'), switch(stroke, 'stroke')
    cols = [np.ascontiguousarray(A[:, k]) for k in range(3)]
    if not check_limits:
        check_bound(ARRAY, cols)
    geo = None
    if parameters is None and names is not None:
        raise InputError(f'names = {brief(names)} without parameters; allowed: names with their parameters, or neither')
    if parameters is not None:
        rows = _rows(parameters)   # counted before the rows' geometry is checked: the count is what is wrong then
        if rows and A.shape[0] % rows:
            raise InputError(f'{rows} parameter rows for {A.shape[0]} rod-length rows; allowed: one machine per '
                             'sample, or per block of samples (a number of rows that divides the samples)')
        geo = MachineGeometry.per_row(cfg, parameters, names)
        if geo.rows != A.shape[0]:
            geo = geo.repeat(A.shape[0] // geo.rows)
    vjm = make_model(cfg, model, geo)
    if displacement is not None:
        d = float_array(displacement, 'joint displacements', f'numbers [m], shape ({A.shape[0]}, 3, 3)')
        if d.shape[:1] != (A.shape[0],):
            raise InputError(f'joint displacements must have shape ({A.shape[0]}, 3, 3), one (3, 3) per sample; got '
                             f'shape {d.shape}')
        geo = (geo or MachineGeometry.of(cfg)).displaced(d)
    with np.errstate(divide='ignore', invalid='ignore') if not check_limits else contextlib.nullcontext():
        try:
            out: ForwardBatch = _forward(ARRAY, ForwardBatch, cols, cfg, vjm, check_limits, geo, stroke)  # (refused)
        except ConvergenceError as exc:   # a singular step (NaN) named as the one-pose path names it
            if exc.sample is None or not singular(exc):
                raise
            raise singular_step(vjm.name, cfg, A[exc.sample].tolist(), exc.sample if len(A) > 1 else None) from None
    if not check_limits:   # far outside the limits the closure may turn the platform over: NaN passed as a pose
        check_turned_over(vjm.name, cfg, A, out.rotation)
    return out


def forward(q: ArrayLike, config: GprConfig | None = None, model: str | None = None,
            check_limits: bool = True, stroke: bool = True) -> ForwardResult:
    """Forward kinematics of one configuration ``q = (q1, q2, q3)`` [m]; see :func:`forward_batch`.

    The one-pose path (:mod:`gpr_kinematics.core.single`): float arithmetic with the constants of the geometry and
    model computed once, the limits checked in float comparisons (the batch's messages when one fails), the result
    built from one array. Equal to the batch row to rounding (~1e-16). With ``check_limits=False`` rods far outside
    the stroke may have no closure: :class:`~gpr_kinematics.errors.ConvergenceError`, as in the batch.
    """
    return one_result(*forward_parts(q, resolve_config(config), model, check_limits, stroke))


class ForwardParts(NamedTuple):
    """One configuration solved by :func:`forward_parts`: its kernel, rods ``q`` [m], joint centres ``P``, side lengths
    ``L`` [m], the closure (virtual joints), the rigid fit of the platform and the naive state (None: not computed)."""

    kernel: OnePose
    q: list[float]
    P: Centres
    L: tuple[float, float, float]
    closure: Closure
    frame: FitFloats
    naive: NaiveState | None


def forward_parts(q: ArrayLike, config: GprConfig, model: str | None = None, check_limits: bool = True,
                  stroke: bool = True) -> ForwardParts:
    """:func:`forward` up to its result: the limits checked (the stroke, the naive tilt, then the tilt of the fit),
    the closure solved and the platform fitted, in floats. :func:`forward` builds its result from it; the mobility
    analysis takes the virtual joints and the joint centres."""
    check_limits, stroke = switch(check_limits, 'check_limits'), switch(stroke, 'stroke')
    kernel = one_pose(config, model)
    q3 = three_floats(q, 'q')
    q0, q1, q2 = q3
    naive = None
    if check_limits:
        if stroke:   # the caller's own check (its rods' names) otherwise
            lo, hi = config.stroke_min - STROKE_SLACK, config.stroke_max + STROKE_SLACK
            if not (lo <= q0 <= hi and lo <= q1 <= hi and lo <= q2 <= hi):
                check_stroke(SCALAR, q3, config, typed=True)
        naive = kernel.naive(q0, q1, q2)
        h2, rest = naive[1], 1.0 - naive[1]
        t = centres_tilt(SCALAR, kernel.geometry, q3) if kernel.leaning else \
            math.atan2(math.sqrt(1.0 - (rest if rest >= 0.0 else 0.0)), naive[4])
        if h2 >= 1.0 or t > 1.05 * config.tilt_limit:
            _check_naive_tilt(SCALAR, kernel.geometry, q3, config)
    P, L, closure, frame = solve_parts(kernel, q3 if check_limits else check_bound(SCALAR, q3))
    if check_limits:
        check_tilt(SCALAR, q3, cast('float', tilt_of_normal(SCALAR, frame[2], frame[5], frame[8])[0]), config)
    return ForwardParts(kernel, q3, P, L, closure, frame, naive)


def solve_parts(kernel: OnePose, q: list[float]) -> tuple[Centres, tuple[float, float, float], Closure, FitFloats]:
    """The joint centres, side lengths, closure and rigid fit of the rods ``q`` (three floats) [m], no limit checked:
    the solve of :func:`forward_parts` (a singular Newton step far outside the limits: ``ConvergenceError``)."""
    try:
        P = kernel.centres(q[0], q[1], q[2])
        L = kernel.lengths(P)
        closure = kernel.closure(*L)
        frame = kernel.fit(P, closure.components)
        trace = frame[0] + frame[4] + frame[8]
        if not 1.0 + trace > 0.0:   # its pose's quaternion divided by zero (or NaN)
            raise turned_over(kernel.model.name, kernel.config, list(q), trace)
        return P, L, closure, frame
    except (ArithmeticError, ValueError) as exc:  # far outside the limits (check_limits=False): a singular step
        if isinstance(exc, GprError) and not singular(exc):
            raise
        raise singular_step(kernel.model.name, kernel.config, list(q)) from None


def one_result(kernel: OnePose, q: Sequence[float], P: Centres, L: Sequence[float], closure: Closure,
               frame: FitFloats, naive: NaiveState | None = None) -> ForwardResult:
    """The :class:`ForwardResult` of one solved pose in floats: :func:`~gpr_kinematics.core.platform_pose.platform_pose`
    from the rigid fit ``frame`` on, with its operations, and :func:`assemble`, fused
    (:meth:`~gpr_kinematics.core.single.OnePose.pose_values`): the values go straight into one array, and every vector
    field is a view of it (no array and no ``__init__`` per field)."""
    values, tilt, az, twist, fit, within = kernel.pose_values(q, P, L, closure, frame, naive)
    a = np.array(values)
    out = ForwardResult.__new__(ForwardResult)
    out.__dict__.update(
        q=a[0:3], model=kernel.model.name, virtual_joints=a[44:], virtual_joint_names=kernel.names,
        side_lengths=a[3:6], position=a[6:9], rotation=a[9:18].reshape(3, 3), quaternion=a[18:22], tilt=tilt,
        tilt_azimuth=az, twist=twist, nominal_position=a[22:25], nominal_rotation=a[25:34].reshape(3, 3),
        nominal_quaternion=a[34:38], centre_shift=a[38:41], joint_displacement=a[41:44], within_budget=within,
        iterations=closure.iterations, residual=closure.residual, fit_residual=fit)
    return out


def one_row(kernel: OnePose, q: Sequence[float], P: Centres, L: Sequence[float], closure: Closure, frame: FitFloats,
            head: Sequence[float] = ()) -> tuple[ForwardBatch, Array]:
    """:func:`one_result` as the batch of one row (:meth:`ForwardBatch.of_one` of it, the same values), every float
    field a view of one array ``(1, K)``, and that array, which begins with the caller's values ``head`` (its own
    results in the same array)."""
    values, tilt, az, twist, fit, within = kernel.pose_values(q, P, L, closure, frame, None)
    o, n = len(head), len(head) + len(values)
    a = np.fromiter([*head, *values, tilt, az, twist, closure.residual, fit], float).reshape(1, -1)   # as np.array
    index = _ROW_INDEX.get((o, n))
    if index is None:   # built once per layout: an index made per call cost as much as its view
        index = _ROW_INDEX[o, n] = tuple((slice(None), k) for k in (
            slice(o, o + 3), slice(o + 44, n), slice(o + 3, o + 6), slice(o + 6, o + 9), slice(o + 9, o + 18),
            slice(o + 18, o + 22), n, n + 1, n + 2, slice(o + 22, o + 25), slice(o + 25, o + 34),
            slice(o + 34, o + 38), slice(o + 38, o + 41), slice(o + 41, o + 44), n + 3, n + 4))
    q_, x, sides, p, r, quat, tilt_, az_, twist_, nominal_p, nominal_r, nominal_quat, shift, d, e, f = index
    out = ForwardBatch.__new__(ForwardBatch)
    out.__dict__.update(
        q=a[q_], model=kernel.model.name, virtual_joints=a[x], virtual_joint_names=kernel.names, side_lengths=a[sides],
        position=a[p], rotation=a[r].reshape(1, 3, 3), quaternion=a[quat], tilt=a[tilt_], tilt_azimuth=a[az_],
        twist=a[twist_], nominal_position=a[nominal_p], nominal_rotation=a[nominal_r].reshape(1, 3, 3),
        nominal_quaternion=a[nominal_quat], centre_shift=a[shift], joint_displacement=a[d],
        within_budget=np.array([within]), iterations=np.array([closure.iterations]), residual=a[e], fit_residual=a[f])
    return out, a


_ROW_INDEX: dict[tuple[int, int], tuple[tuple[slice, slice | int], ...]] = {}   # one_row's per (o, n)


def base_points(Q: Array, config: GprConfig) -> Array:
    """Joint centres ``P_k = B_k + (q_k + o_k) u_k`` in ``gpr_base``, ``(N, 3, 3)`` (paper eq. (1))."""
    return MachineGeometry.of(config).base_points(Q)

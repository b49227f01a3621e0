"""Inverse kinematics of the GPR: height of a platform point and platform normal -> rod lengths.

The GPR has three degrees of freedom: the height of a platform point (its origin by default, or ``tool``,
given in ``gpr_platform``) and the platform normal ``n* = tilt_rotation(tilt, azimuth) e3`` are prescribed;
x, y and heading are outcomes of the virtual-joint model, reported in ``achieved``. With ``N(h, n)`` the naive
inverse (:func:`gpr_kinematics.core.naive.naive_rods`), the iteration

    q <- q + N(h*, n*) - N(h(q), n(q)),   from q = N(h*, n*),

where ``h(q), n(q)`` come from the virtual-joint forward kinematics, is Newton's method with the naive
model's Jacobian, which differs from the exact one only by the virtual-joint corrections (~1e-4) while the rods are
parallel, so each step gains about four digits: 3-4 steps reach :data:`IK_TOLERANCE` (rods that are not parallel
converge linearly: :func:`_not_converged`). One driver serves a batch (arrays) and
runs on floats; :func:`inverse` takes the one-pose path (:func:`inverse_one`: each step solves the closure and the
rigid fit only) with the same operations. The last forward solve of the loop is the reported ``achieved`` pose.

>>> import math
>>> ik = inverse(0.5, math.radians(2.0), 0.0)     # 2 deg about the x axis at 0.5 m
>>> round(float(ik.achieved.centre_shift[0]) * 1e6, 2), ik.iterations   # the centre shift along x [um]
(28.41, 4)
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ConvergenceError, InputError, LimitError, apart, norm_text
from ..inputs.validation import (
    MAX_COORDINATE,
    column_of,
    empty_beside_one,
    rows_of,
    single_number,
    switch,
    three_floats,
)
from .config import ITERATIONS, GprConfig, nominal_points, resolve_config
from .forward import (
    TILT_LIMIT_SLACK,
    ForwardBatch,
    ForwardResult,
    Result,
    assemble,
    beyond_tilt,
    check_tilt,
    one_result,
    solve_pose,
)
from .heights import HEIGHT_MARGIN, RodsAt, at_sample, check_height, check_solved_stroke
from .machine import MachineGeometry
from .naive import naive_rods
from .ops import ARRAY, SCALAR, Ops, Value
from .platform_pose import FitFloats
from .rotations import tilt_of_normal
from .single import Centres, OnePose, one_pose
from .virtual_joints import Closure, VirtualJointModel, make_model

Array = NDArray[np.float64]

#: Inverse kinematics stops when height [m] and normal errors are both below this (or below the rounding of a
#: machine whose rods are longer or joints closer than the shipped one's: :func:`ik_tolerances`).
IK_TOLERANCE = 1e-14
#: The rounding of a pose in ulps of the longest rod length: for the height, and per radius for the normal.
HEIGHT_ROUNDING_ULPS = 16
NORMAL_ROUNDING_ULPS = 8
#: Normal tolerances a target's tilt keeps below forward kinematics' slack (:func:`tilt_target_slack`).
TARGET_TOLERANCES = 4.0
#: Largest distance of the tool point from the platform origin [m]. No tool of a GPR is that long, and the
#: height of a point much farther away carries rounding errors of the order of :data:`IK_TOLERANCE` (at 300 m
#: Newton's method can no longer meet it).
TOOL_REACH = 10.0


@dataclass(frozen=True)
class InverseResult:
    """Inverse kinematics of one target: rod lengths ``q`` [m], the pose they give, Newton steps."""

    q: Array
    achieved: ForwardResult
    iterations: int


@dataclass(frozen=True)
class InverseBatch:
    """Inverse kinematics of ``N`` targets: ``q (N, 3)``, ``achieved`` and ``iterations (N,)``."""

    q: Array
    achieved: ForwardBatch
    iterations: NDArray[np.int64]

    def __len__(self) -> int:
        return int(self.q.shape[0])

    def __getitem__(self, i: int) -> InverseResult:
        return InverseResult(q=self.q[i], achieved=self.achieved[i], iterations=int(self.iterations[i]))


def tilt_target_slack(config: GprConfig) -> float:
    """How far beyond ``tilt_limit`` a target's tilt may lie [rad]: :data:`TILT_LIMIT_SLACK` less
    :data:`TARGET_TOLERANCES` times the normal tolerance the Newton loop stops at (:func:`ik_tolerances`; an answer's
    tilt is within sqrt(2) of them of its target), so that the rods answered tilt the platform within the slack
    forward kinematics allows (a target at the slack's edge was met a few ulps beyond it); never below 0. The rule
    of every target: inverse kinematics, compensation, station inverse kinematics, sweeps, the GPR mechanism."""
    cached: float | None = config.derived.get('tilt_target_slack')
    if cached is None:   # never below 0: a target at the limit is one (a 0.1 mm triangle on 10 m rods refused it)
        slack = TILT_LIMIT_SLACK - TARGET_TOLERANCES * ik_tolerances(config)[1]
        cached = config.derived['tilt_target_slack'] = max(0.0, slack)
    return cached


def _check_tilt_targets(ops: Ops, t: Value, config: GprConfig) -> None:
    if not ops.any(ops.fabs(t) - config.tilt_limit > tilt_target_slack(config)):
        return
    a = np.atleast_1d(t)
    i = int(np.argmax(np.abs(a)))
    raise LimitError(f'tilt = {beyond_tilt(float(a[i]), config.tilt_limit)}')


def tool_tolerances(config: GprConfig, tool: Sequence[Value]) -> tuple[Value, Value]:
    """The height and normal tolerances [m, 1] with a tool point ``tool`` [m] off the platform origin: the rods then
    carry terms of its length ``|tool|``, rounded to its ulps, so :func:`ik_tolerances`' rule takes ``|tool|`` for
    the longest rod where that is longer, and the tool point's height moves with the normal's tolerance times
    ``|tool|`` (a 9 m tool left the normal 1.2e-14 from its target, and every call was refused as not converged at
    1e-14). The tolerances unchanged without a tool."""
    tol_h, tol_n = ik_tolerances(config)
    x, y, z = tool
    if not (isinstance(x, np.ndarray) or isinstance(y, np.ndarray) or isinstance(z, np.ndarray)):   # one point
        length = math.sqrt(x * x + y * y + z * z)
        if length == 0.0:
            return tol_h, tol_n
        ulp = math.ulp(length)
        return (max(tol_h, HEIGHT_ROUNDING_ULPS * ulp) + tol_n * length,
                max(tol_n, NORMAL_ROUNDING_ULPS * ulp / _triangle_radius(config)))
    lengths = np.sqrt(x * x + y * y + z * z)
    ulps = np.spacing(lengths)
    return (np.maximum(tol_h, HEIGHT_ROUNDING_ULPS * ulps) + tol_n * lengths,
            np.maximum(tol_n, NORMAL_ROUNDING_ULPS * ulps / _triangle_radius(config)))


def _triangle_radius(config: GprConfig) -> float:
    """The joint triangle's radius [m] that the normal's rounding scales with (its shortest side over sqrt 3),
    cached per config."""
    cached: float | None = config.derived.get('ik_radius')
    if cached is None:
        joints = config.platform_joints or nominal_points(config)
        cached = config.derived['ik_radius'] = min(math.dist(joints[i], joints[i - 1]) for i in range(3)) / math.sqrt(3)
    return cached


def ik_tolerances(config: GprConfig) -> tuple[float, float]:
    """The height [m] and normal tolerances inverse kinematics stops at: :data:`IK_TOLERANCE`, or the rounding of the
    pose where that is larger, :data:`HEIGHT_ROUNDING_ULPS` ulps of the longest rod length for the height and
    :data:`NORMAL_ROUNDING_ULPS` ulps of it per radius of the joint triangle for the normal (at a radius of 1e-4 m the
    normal is known to about 5e-13, and 1e-14 was never met; rods of 8 m leave the height about 1e-14 m). The
    shipped machine's are :data:`IK_TOLERANCE` both. Cached per config."""
    cached: tuple[float, float] | None = config.derived.get('ik_tolerances')
    if cached is None:
        longest = max(abs(config.stroke_min), abs(config.stroke_max)) + max(abs(o) for o in config.rod_offsets)
        ulp = math.ulp(longest)
        cached = config.derived['ik_tolerances'] = (
            max(IK_TOLERANCE, HEIGHT_ROUNDING_ULPS * ulp),
            max(IK_TOLERANCE, NORMAL_ROUNDING_ULPS * ulp / _triangle_radius(config)))
    return cached


def check_tool(tools: ArrayLike, name: str = 'tool', typed: str | None = None) -> None:
    """Refuse tool points ``(3,)`` or ``(N, 3)`` [m] farther than :data:`TOOL_REACH` from the platform origin;
    ``typed``: the refused point as its user typed it, with its unit (``(20000, 0, 0) mm ((20, 0, 0) m)``)."""
    T = np.atleast_2d(np.asarray(tools, dtype=float))
    far = np.max(np.abs(T), axis=-1) > TOOL_REACH  # before the norm, which could overflow
    far |= np.sqrt(np.sum(np.where(far[:, None], 0.0, T) ** 2, axis=-1)) > TOOL_REACH
    if far.any():
        i = int(np.argmax(far))
        where = f' (target {i})' if T.shape[0] > 1 else ''
        distance, reach = norm_text(tuple(float(v) for v in T[i]), TOOL_REACH)
        shown = f'({T[i, 0]:.6g}, {T[i, 1]:.6g}, {T[i, 2]:.6g}) m' if typed is None else typed
        raise LimitError(f'{name} = {shown}{where} is beyond the reach of a '
                         f'tool point ({distance} m from the platform origin); allowed: at most {reach} m from the '
                         'platform origin (gpr_platform)')


def check_tool_point(tool: Sequence[float], name: str = 'tool', typed: str | None = None) -> None:
    """:func:`check_tool` of one point ``(x, y, z)`` [m] in floats: the exact check only when a coordinate lies beyond
    ``TOOL_REACH / 1.8`` (nearer, ``|tool| <= sqrt(3) / 1.8 TOOL_REACH < TOOL_REACH``)."""
    if max(abs(tool[0]), abs(tool[1]), abs(tool[2])) > TOOL_REACH / 1.8:
        check_tool(tool, name, typed)


def _not_converged(geo: MachineGeometry, most: int, where: str, err: float) -> ConvergenceError:
    """The error of a solve still outside its tolerance after ``most`` steps. The naive Jacobian of the iteration
    ignores how a rod that is not parallel to the others pushes the over-constrained platform sideways: there it
    gains a digit or less per step (one rod at 0.05 rad: 15 steps), so the message names ``max_iterations``."""
    slow = len(set(zip(geo.ux, geo.uy, strict=True))) > 1   # inclined alike, the rods are still parallel
    hint = (f'; rods that are not parallel converge more slowly: give a larger max_iterations (allowed: at most '
            f'{ITERATIONS[1]})' if slow else '')
    return ConvergenceError(f'inverse kinematics did not converge in {most} iterations{where}: error {err:.3e}{hint}')


def _solve(ops: Ops, result: type[Result], h: Value, t: Value, g: Value, tool: Sequence[Value], config: GprConfig,
           vjm: VirtualJointModel, stroke: bool = True) -> tuple[Result, Value]:
    """The Newton loop of inverse kinematics (module docstring): ``(achieved, iterations)``; ``stroke=False``
    answers rods outside the stroke (the caller judges them)."""
    _check_tilt_targets(ops, t, config)
    geo = MachineGeometry.of(config)
    s = ops.sin(t)
    n_target = [s * ops.sin(g), -s * ops.cos(g), ops.cos(t)]
    check_height(ops, geo, h, t, n_target, tool, config, _rods_at(config, vjm.name, t, g, tool))
    q_target = naive_rods(geo, h, n_target, tool)
    q = list(q_target)
    iterations: Any = 0 * (h == h)  # integer zeros: one, or one per target
    tol_h, tol_n = tool_tolerances(config, tool)
    for step in range(config.max_iterations + 1):
        L, closure, pose = solve_pose(ops, geo, vjm, q, config)
        R = pose.rotation
        h_now = pose.position[2] + R[2][0] * tool[0] + R[2][1] * tool[1] + R[2][2] * tool[2]
        n_now = [R[0][2], R[1][2], R[2][2]]
        err_n = ops.fabs(n_now[0] - n_target[0])
        for i in (1, 2):
            err_n = ops.maximum(err_n, ops.fabs(n_now[i] - n_target[i]))
        err_h = ops.fabs(h_now - h)
        err = ops.maximum(err_h, err_n)
        active = ops.not_((err_h <= tol_h) & (err_n <= tol_n))
        if not ops.any(active):
            break
        if step == config.max_iterations:
            e = np.where(active, err, -1.0)
            where = '' if np.ndim(err) == 0 else f' for target {int(np.argmax(e))}'
            raise _not_converged(geo, config.max_iterations, where, float(np.max(e)))
        q_now = naive_rods(geo, h_now, n_now, tool)
        q = [ops.where(active, q[k] + q_target[k] - q_now[k], q[k]) for k in range(3)]
        iterations = iterations + active
    if stroke:
        check_solved_stroke(ops, geo, q, h, t, n_target, tool, config, _rods_at(config, vjm.name, t, g, tool))
    check_tilt(ops, q, pose.tilt, config)   # a target within the slack may be answered a few ulps beyond it
    return assemble(ops, result, q, vjm, config, L, closure, pose), iterations


def _refuse_azimuth(value: float, where: str) -> None:
    shown, bound = apart(abs(value), MAX_COORDINATE)   # finite: both callers checked it
    raise InputError(f'azimuth = {"-" if value < 0 else ""}{shown} rad{where}; allowed: finite values within +-{bound} '
                     'rad (an angle is periodic, but beyond that a float keeps no digits modulo 2 pi)')


def inverse_batch(height: ArrayLike, tilt: ArrayLike, azimuth: ArrayLike, config: GprConfig | None = None,
                  model: str | None = None, tool: ArrayLike = (0.0, 0.0, 0.0), stroke: bool = True) -> InverseBatch:
    """Rod lengths that give platform tilts and heights under the virtual-joint model, vectorised.

    Args:
        height: z of the tool point (the platform origin by default) in ``gpr_base`` [m].
        tilt: tilt angle [rad]; a negative tilt is a tilt about ``azimuth + pi``.
        azimuth: direction of the tilt axis [rad]. The three broadcast to ``(N,)``.
        tool: point of the platform, in ``gpr_platform`` [m], whose height is prescribed: shape ``(3,)``
            (one point for every target) or ``(N, 3)`` (one point per target, e.g. per station).
        stroke: refuse an answer whose rods leave the stroke; ``False`` answers it (the iterates of a caller that
            judges its converged rods itself: station inverse kinematics on rods that are not parallel). A height
            beyond :func:`~.heights.solvable_heights` is refused either way.

    Raises:
        InputError: NaN, infinity, an azimuth beyond +-:data:`~gpr_kinematics.inputs.validation.MAX_COORDINATE`
            rad (periodic, but a float angle beyond it keeps no digits modulo 2 pi), shapes that do not broadcast
            (``tool`` rows included).
        LimitError: ``|tilt| > tilt_limit``, or the answer leaves the stroke (unless ``stroke=False``).
        ConvergenceError: no convergence within ``max_iterations`` (not seen inside the limits).
    """
    cfg = resolve_config(config)
    vjm = make_model(cfg, model)
    stroke = switch(stroke, 'stroke')   # None or 0 turned the stroke's check off without a word
    cols = [column_of(v, n) for v, n in ((height, 'height'), (tilt, 'tilt'), (azimuth, 'azimuth'))]
    big = np.abs(cols[2]) > MAX_COORDINATE
    if big.any():   # the target named where there are several (as the tool's check names it)
        i = int(np.argmax(big))
        _refuse_azimuth(float(cols[2][i]), f' (target {i})' if big.size > 1 else '')
    tools = rows_of(tool, 'tool', 3)
    check_tool(tools)
    try:   # an empty one beside ones of one value broadcast to no target at all (silently): refused as a mismatch
        empty_beside_one((height, tilt, azimuth, tools[:, 0] if np.ndim(tool) == 2 else None))   # tool rows
        h, t, g, _ = (np.ascontiguousarray(c) for c in np.broadcast_arrays(*cols, tools[:, 0]))
    except ValueError:
        raise InputError('height, tilt, azimuth and tool must have the same length (one value or tool row per '
                         'target, or one for all), got ' + ', '.join(str(c.shape[0]) for c in cols + [tools])
                         ) from None
    # One platform point for all targets (floats), or one per target (columns of length N).
    tool_v: Sequence[Value] = (tuple(float(v) for v in tools[0]) if tools.shape[0] == 1 else
                             [np.ascontiguousarray(np.broadcast_to(tools[:, i], h.shape)) for i in range(3)])
    achieved, iterations = _solve(ARRAY, ForwardBatch, h, t, g, tool_v, cfg, vjm, stroke)
    return InverseBatch(q=achieved.q, achieved=achieved, iterations=np.asarray(iterations, dtype=np.int64))


def inverse(height: float, tilt: float, azimuth: float, config: GprConfig | None = None,
            model: str | None = None, tool: ArrayLike = (0.0, 0.0, 0.0)) -> InverseResult:
    """Inverse kinematics of one target (the one-pose path of :mod:`gpr_kinematics.core.single`, the same steps as
    the batch in float arithmetic); see :func:`inverse_batch`."""
    h, t, g = (single_number(v, n) for v, n in ((height, 'height'), (tilt, 'tilt'), (azimuth, 'azimuth')))
    if abs(g) > MAX_COORDINATE:
        _refuse_azimuth(g, '')
    cfg = resolve_config(config)
    kernel = one_pose(cfg, model)
    tool3 = three_floats(tool, 'tool')
    check_tool_point(tool3)
    return inverse_one(kernel, h, t, g, tool3)


def inverse_one(kernel: OnePose, h: float, t: float, g: float, tool: Sequence[float]) -> InverseResult:
    """:func:`_solve` of one target ``(h, t, g)`` with the tool point ``tool`` (floats, checked) on the one-pose
    kernels (:func:`inverse_parts`), the pose of the last step completed."""
    parts = inverse_parts(kernel, h, t, g, tool)
    achieved = one_result(kernel, *parts[:5])
    return InverseResult(q=achieved.q, achieved=achieved, iterations=parts.iterations)


class InverseParts(NamedTuple):
    """One target solved by :func:`inverse_parts`: the rods ``q`` [m], and of the last step the joint centres ``P``,
    side lengths ``L`` [m], closure and rigid fit ``frame`` (:func:`~gpr_kinematics.core.forward.forward_parts`'s),
    the iterations taken, and the rigid fit of the first step (of the naive model's rods for the target)."""

    q: list[float]
    P: Centres
    L: tuple[float, float, float]
    closure: Closure
    frame: FitFloats
    iterations: int
    first: FitFloats


def inverse_parts(kernel: OnePose, h: float, t: float, g: float, tool: Sequence[float], stroke: bool = True
                  ) -> InverseParts:
    """:func:`_solve` of one target ``(h, t, g)`` up to its result: each step solves the closure and the rigid fit
    only (floats; the tool point ``tool`` checked by the caller; ``stroke`` as :func:`inverse_batch`'s)."""
    cfg, geo = kernel.config, kernel.geometry
    if abs(t) - cfg.tilt_limit > tilt_target_slack(cfg):
        _check_tilt_targets(SCALAR, t, cfg)
    s = math.sin(t)
    n_target = [s * math.sin(g), -s * math.cos(g), math.cos(t)]
    lo, hi = kernel.height_range(n_target, tool)
    if not (h >= lo - HEIGHT_MARGIN and h <= hi + HEIGHT_MARGIN):   # _check_height's decision, in floats
        check_height(SCALAR, geo, h, t, n_target, tool, cfg, _rods_at(cfg, kernel.model.name, t, g, tool))
    q_target = kernel.naive_rods(h, n_target, tool)
    most = cfg.max_iterations
    tol_h, tol_n = cast('tuple[float, float]', tool_tolerances(cfg, tool))
    q, P, L, closure, frame, iterations, first, err = (
        kernel.radial_rods(q_target, h, n_target, tool, tol_h, tol_n) if kernel.model.name == 'radial' else
        _steps(kernel, q_target, h, n_target, tool, tol_h, tol_n))
    if err is not None:
        raise _not_converged(geo, most, '', err)
    r02, r12, r22 = frame[2], frame[5], frame[8]
    if stroke:
        check_solved_stroke(SCALAR, geo, q, h, t, n_target, tool, cfg, _rods_at(cfg, kernel.model.name, t, g, tool))
    if abs(t) > cfg.tilt_limit - TILT_LIMIT_SLACK:   # the answer's tilt is the target's to the tolerance
        check_tilt(SCALAR, q, cast('float', tilt_of_normal(SCALAR, r02, r12, r22)[0]), cfg)   # as forward refuses
    return InverseParts(q, P, L, closure, frame, iterations, first)


def _rods_at(config: GprConfig, model: str, t: Value, g: Value, tool: Sequence[Value]) -> RodsAt:
    """The solved rods of target ``i`` at another height (stroke unchecked), for a refusal's allowed heights: with
    the most iterations allowed (leaning rods converge slowly: 12 left an end 'about' the naive model's)."""
    kernel: list[OnePose] = []

    def rods(i: int, h: float) -> Sequence[float]:
        if not kernel:   # built at the first refusal only
            kernel.append(one_pose(config.replace(max_iterations=ITERATIONS[1]), model))
        return inverse_parts(kernel[0], h, at_sample(t, i), at_sample(g, i), [at_sample(v, i) for v in tool],
                             stroke=False).q
    return rods


def _steps(kernel: OnePose, q_target: list[float], h: float, n: Sequence[float], tool: Sequence[float], tol_h: float,
           tol_n: float) -> tuple[list[float], Centres, tuple[float, float, float], Closure, FitFloats, int, FitFloats,
                                  float | None]:
    """The steps of :func:`inverse_parts` from the rods ``q_target`` [m] on (the ``radial`` model's fused:
    :meth:`~gpr_kinematics.core.single.OnePose.radial_rods`, which returns what this does)."""
    q = list(q_target)
    t0, t1, t2 = tool
    n0, n1, n2 = n
    most = kernel.config.max_iterations
    for iterations in range(most + 1):
        P = kernel.centres(q[0], q[1], q[2])
        L = kernel.lengths(P)
        closure = kernel.closure(*L)
        frame = kernel.fit(P, closure.components)
        if iterations == 0:
            first = frame
        r02, r12, r20, r21, r22, tz = frame[2], frame[5], frame[6], frame[7], frame[8], frame[11]
        h_now = tz + r20 * t0 + r21 * t1 + r22 * t2
        err_h, err_n = abs(h_now - h), max(max(abs(r02 - n0), abs(r12 - n1)), abs(r22 - n2))
        if err_h <= tol_h and err_n <= tol_n:
            break
        if iterations == most:
            return q, P, L, closure, frame, iterations, first, max(err_h, err_n)
        q_now = kernel.naive_rods(h_now, (r02, r12, r22), tool)
        q = [q[0] + q_target[0] - q_now[0], q[1] + q_target[1] - q_now[1], q[2] + q_target[2] - q_now[2]]
    return q, P, L, closure, frame, iterations, first, None

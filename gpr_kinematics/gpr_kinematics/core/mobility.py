"""Mobility and sensitivity analysis of the GPR with virtual joints (Bratovanov & Sotirov §IV-A, eqs. (1)-(5)).

With ``P = (q, P1, P2, P3)`` (``N = 12``) the constraints (eq. (1); rod ``i`` along its unit direction
``u_i``, ``e3`` on the nominal machine, from its base point ``B_i`` with zero offset ``o_i``) are

    Phi_{3i..3i+2} = B_i + (q_i + o_i) u_i - P_i = 0,                  i = 1, 2, 3
    Phi_{9+i}      = |P_{i%3+1} - P_i|^2 - L_{i,i%3+1}(X)^2 = 0,

where the side lengths ``L(X) = |r_{i%3+1}(X) - r_i(X)|`` are made variable by the virtual joints ``X``
(eq. (2)). The mobility of the rigid mechanism is ``h = 12 - rank(dPhi/dP)``; ``rank [dPhi/dP  dPhi/dX] = 12``
everywhere, so the augmented mechanism is never singular.

*Parallel rods* (the nominal machine, or rods tilted all alike): rank 9 where the joint triangle is
perpendicular to the rods, ``q1 = q2 = q3`` for vertical rods (h = 3, instantaneous), 11 elsewhere (h = 1: the
rigid platform can only move along the rods, the tilt is blocked).
*Rods that are not parallel*: equal extensions of the rods change the distances between the joint centres
(``d |P_b - P_a|^2 / dq (1, 1, 1) = 2 e . (u_b - u_a) != 0``), so even that motion is blocked: rank 12 (h = 0)
almost everywhere; the virtual joints then take up the vertical motion too, and the augmented rank stays 12. Where
the 3 x 3 matrix ``M`` of the sides' rows in ``dq`` (``dP_k = u_k dq_k``) is singular, a surface of rod lengths,
``ker M`` keeps every side: rank 11 (h = 1). No configuration is singular.

The configuration is *singular* where the rigid mechanism gains instantaneous freedoms, ``h > 1``
(:func:`rigid_rank`: the one test, shared by ``gpr mobility`` and ``gpr mechanism``).

Sensitivity: from ``dPhi/dP dP + dPhi/dX dX = 0`` (eq. (3)), ``dX = -(dPhi/dX)^+ dPhi/dP dP = dX/dP dP``; with
the eigen-decomposition ``dX/dP^T dX/dP = V D V^T`` (eigenvalues ascending, only ``d10..d12`` non-zero):

    sqrt(d10 sum_{k=10..12} (v_k^T dP)^2) <= |dX| <= sqrt(d12 sum_{k=10..12} (v_k^T dP)^2)        (4)
    sigma_min(dX/dP) sqrt(sum (v_k^T dP)^2) <= |dX| <= sigma_max(dX/dP) sqrt(sum (v_k^T dP)^2)      (5)

Since the eigenvalues of ``A^T A`` are the squared singular values of ``A``, (4) and (5) give the same
numbers; both are reported. The pseudo-inverse is taken in the metric of the forward solver
(:func:`gpr_kinematics.core.virtual_joints.coordinate_scale`: angular coordinates weighted by the characteristic
length; the elastic cost for ``compliant``); ``weighting='unweighted'`` gives the paper's plain Moore-Penrose
form. Units: ``dP`` in metres, ``dX`` in metres and radians. ``dX/dP dP`` is the *first-order* change: at the
singular configuration it vanishes for every change of the rod lengths (the tilt enters the side lengths
quadratically there), while the full solve :func:`exact_dx` gives ``X(q + dq) - X(q)`` (0.107 um for
``dq = (1e-4, -1e-4, 0)`` m at ``q = 0.5`` m, radial model). A ``dP`` must keep the rods within the stroke: a change
of the configuration of this machine, not a number that overflows.

>>> m = analyze_mobility([0.5, 0.5, 0.5])
>>> m.rank_dphi_dp, m.rank_augmented, m.mobility
(9, 12, 3)
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError, LimitError, brief
from ..inputs.validation import bounded, finite_vector, float_array, rows_of
from . import forward
from .config import GprConfig, resolve_config
from .forward import forward_parts
from .machine import MachineGeometry
from .ops import SCALAR
from .stroke import stroke_words
from .virtual_joints import EDGES, VirtualJointModel, coordinate_scale, joint_components

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SensitivityBounds:
    """Bounds ``(lower, upper)`` of eqs. (4) and (5) on ``|dX|`` for one ``dP``, and the actual ``|dX|``."""

    norm_dx: float
    eq4: tuple[float, float]
    eq5: tuple[float, float]

    lower_eq4 = property(lambda self: self.eq4[0], doc='Lower bound of eq. (4).')
    upper_eq4 = property(lambda self: self.eq4[1], doc='Upper bound of eq. (4).')
    lower_eq5 = property(lambda self: self.eq5[0], doc='Lower bound of eq. (5).')
    upper_eq5 = property(lambda self: self.eq5[1], doc='Upper bound of eq. (5).')


@dataclass(frozen=True)
class MobilityResult:
    """Mobility and sensitivity of the GPR at one configuration.

    Attributes:
        q: rod lengths [m]; model: virtual-joint model; virtual_joints: ``X`` at ``q``.
        dphi_dp: ``dPhi/dP`` (12 x 12); dphi_dx: ``dPhi/dX`` (12 x M); dx_dp: ``dX/dP`` (M x 12).
        rank_dphi_dp: rank of ``dPhi/dP`` (parallel rods: 9 where the joint triangle is perpendicular to them,
            at q1 = q2 = q3 for vertical rods, 11 elsewhere; rods not parallel: 12); mobility: ``12 - rank``.
        rank_augmented: rank of ``[dPhi/dP dPhi/dX]`` (12 everywhere).
        eigenvalues: of ``dX/dP^T dX/dP``, ascending (12); eigenvectors: columns ``v_1..v_12``.
        singular_values: non-zero singular values of ``dX/dP``, descending.
        bounds: the gains of eqs. (4), (5): ``|dX| / |P_V dP|`` lies in ``[lower, upper]``, where ``P_V dP``
            is the projection of ``dP`` on ``v_10..v_12``.
        rod_directions: unit directions ``u_k`` of the rods (3 x 3), for :meth:`rod_perturbation`.
        singular: the rigid mechanism is at a singular configuration, ``mobility > 1`` (:func:`rigid_rank`).
        stroke: ``(stroke_min, stroke_max)`` of the rods [m]: :meth:`dx_bounds` keeps ``q + dq`` within it.
    """

    q: Array
    model: str
    virtual_joints: Array
    dphi_dp: Array
    dphi_dx: Array
    dx_dp: Array
    rank_dphi_dp: int
    rank_augmented: int
    mobility: int
    eigenvalues: Array
    eigenvectors: Array
    singular_values: Array
    bounds: dict[str, tuple[float, float]]
    rod_directions: Array
    singular: bool
    stroke: tuple[float, float]

    def rod_perturbation(self, dq: ArrayLike) -> Array:
        """``dP`` of a change ``dq`` of the rod lengths on this machine (:func:`rod_perturbation`)."""
        return rod_perturbation(dq, self.rod_directions)

    def dx_bounds(self, dP: ArrayLike) -> SensitivityBounds:
        """Eqs. (4), (5) for a given ``dP`` (12 values: dq1..3, dP1, dP2, dP3), and the first-order ``|dX|``.

        Raises:
            InputError: not 12 finite numbers, or a component larger than the stroke range (so nothing overflows).
            LimitError: ``q + dq`` outside the stroke.
        """
        dp = float_array(dP, 'dP', '12 numbers (dq1..dq3, dP1, dP2, dP3) [m]')
        if dp.shape != (12,):
            raise InputError(f'dP must be 12 finite numbers (dq1..dq3, dP1, dP2, dP3), got shape {dp.shape}')
        dp = finite_vector(dp, 'dP', 12)   # a NaN named, not the shape that was right
        lo, hi = self.stroke
        moved = self.q + dp[:3]  # the rods first: what a --dq gives (it read as the dP vector the user never typed)
        out = (moved < lo) | (moved > hi)
        if out.any():
            k = int(np.argmax(out))
            shown, ends = stroke_words(float(moved[k]), lo, hi)
            raise LimitError(f'q{k + 1} + dq{k + 1} = {shown} m is outside the stroke {ends} m; allowed: a change that '
                             'keeps the rods within it')
        if np.max(np.abs(dp)) > hi - lo:
            raise InputError(f'dP = {brief(dp.tolist())}: a change larger than the stroke range {hi - lo:g} m; '
                             'allowed: a change of the configuration of this machine')
        proj = float(np.sqrt(np.sum((self.eigenvectors[:, -3:].T @ dp) ** 2)))
        d = self.eigenvalues
        s = self.singular_values
        return SensitivityBounds(
            norm_dx=float(np.linalg.norm(self.dx_dp @ dp)),
            eq4=(float(np.sqrt(max(d[-3], 0.0)) * proj), float(np.sqrt(d[-1]) * proj)),
            eq5=(float(s[-1] * proj) if s.size else 0.0, float(s[0] * proj) if s.size else 0.0))


@dataclass(frozen=True)
class RodChange(SensitivityBounds):
    """Eqs. (3)-(5) for a change ``dq`` of the rod lengths [m] (:func:`rod_change`): the first-order ``norm_dx`` and
    its bounds, and ``norm_dx_full = |X(q + dq) - X(q)|`` by the full solve (:func:`exact_dx`; ``None`` where
    ``q + dq`` tilts beyond the limit, ``full_solve_refused`` then says why)."""

    dq: tuple[float, float, float]
    norm_dx_full: float | None
    full_solve_refused: str = ''


def rod_change(result: MobilityResult, dq: ArrayLike, config: GprConfig | None = None) -> RodChange:
    """:class:`RodChange` of ``dq`` (3 values [m]) at the configuration of ``result`` on the machine ``config``.

    Raises:
        InputError: ``result`` not a :class:`MobilityResult`; as :meth:`MobilityResult.dx_bounds`.
        LimitError: as :meth:`MobilityResult.dx_bounds` (a ``dq`` that leaves the stroke).
    """
    if not isinstance(result, MobilityResult):
        raise InputError(f'result = {brief(result)}; allowed: a MobilityResult (analyze_mobility)')
    first = result.dx_bounds(result.rod_perturbation(dq))
    d = np.asarray(dq, dtype=float)
    full: float | None = None
    why = ''
    try:
        full = float(np.linalg.norm(exact_dx(result.q, d, config, result.model)))
    except LimitError as exc:  # q + dq tilts beyond the limit: the first order stands alone
        why = str(exc)
    return RodChange(norm_dx=first.norm_dx, eq4=first.eq4, eq5=first.eq5, dq=(float(d[0]), float(d[1]), float(d[2])),
                     norm_dx_full=full, full_solve_refused=why)


def rod_perturbation(dq: ArrayLike, directions: ArrayLike | None = None) -> Array:
    """``dP`` of a change ``dq`` of the rod lengths: ``(dq, dq1 u_1, dq2 u_2, dq3 u_3)`` (eq. (1), first rows);
    ``directions``: the unit rod directions ``u_k`` (3 x 3), default ``e3`` (parallel rods)."""
    d = finite_vector(dq, 'dq', 3)
    u = np.array([[0.0, 0.0, 1.0]] * 3) if directions is None else bounded(directions, 'directions', (3, 3))
    dp = np.zeros(12)
    dp[:3] = d
    dp[3:] = (d[:, None] * u).ravel()
    return dp


def numerical_rank(S: Array, columns: int) -> NDArray[np.int64]:
    """Ranks ``(...)`` from the singular values ``S (..., 12)`` of ``12 x columns`` matrices, with
    ``numpy.linalg.matrix_rank``'s threshold ``sigma_max max(12, columns) eps`` (the one rank test of this module)."""
    return np.asarray((S[..., :1] * (max(12, columns) * EPS) < S).sum(axis=-1), dtype=np.int64)


def rank_of(S: Sequence[float], columns: int) -> int:
    """:func:`numerical_rank` of one matrix's singular values ``S`` (descending), in floats."""
    threshold = S[0] * (max(12, columns) * EPS)
    return sum(1 for sigma in S if threshold < sigma)


def constraint_jacobian(P: ArrayLike, u: ArrayLike) -> Array:
    """``dPhi/dP`` ``(N, 12, 12)`` of eq. (1) at joint centres ``P (N, 3, 3)`` for unit rod directions ``u (3, 3)``."""
    P = np.asarray(P, dtype=float)
    u = np.asarray(u, dtype=float)
    J = np.zeros((P.shape[0], 12, 12))
    for i in range(3):
        J[:, 3 * i:3 * i + 3, i] = u[i]
        J[:, 3 * i:3 * i + 3, 3 + 3 * i:6 + 3 * i] = -np.eye(3)
    for i, (a, b) in enumerate(EDGES):
        e = P[:, b] - P[:, a]
        J[:, 9 + i, 3 + 3 * b:6 + 3 * b] = 2.0 * e
        J[:, 9 + i, 3 + 3 * a:6 + 3 * a] = -2.0 * e
    return J


def rigid_rank(q: ArrayLike, config: GprConfig | None = None) -> NDArray[np.int64]:
    """``rank dPhi/dP`` ``(N,)`` of the rigid mechanism at rod lengths ``q (N, 3)`` [m] (module docstring): 9 at the
    singular configuration of parallel rods, 11 elsewhere, 12 for rods that are not parallel. The configuration is
    singular where ``12 - rank > 1``.

    >>> rigid_rank([[0.5, 0.5, 0.5], [0.5, 0.501, 0.5]]).tolist()
    [9, 11]
    """
    geo = MachineGeometry.of(resolve_config(config))
    Q = rows_of(q, 'q', 3)
    u = np.array([geo.ux, geo.uy, geo.uz]).T
    S = np.asarray(np.linalg.svd(constraint_jacobian(geo.base_points(Q), u), compute_uv=False), dtype=np.float64)
    return np.asarray(numerical_rank(S, 12), dtype=np.int64)


def exact_dx(q: ArrayLike, dq: ArrayLike, config: GprConfig | None = None, model: str | None = None) -> Array:
    """``X(q + dq) - X(q)``: the change of the virtual joints by the full forward solve [m, rad], whose first order
    is ``dX/dP dP`` (eq. (3)); rods outside the stroke raise :class:`~gpr_kinematics.errors.LimitError`.

    >>> m = analyze_mobility([0.5, 0.5, 0.5])       # the singular configuration: the first order vanishes
    >>> m.dx_bounds(m.rod_perturbation([1e-4, -1e-4, 0.0])).norm_dx
    0.0
    >>> round(float(np.linalg.norm(exact_dx([0.5, 0.5, 0.5], [1e-4, -1e-4, 0.0]))) * 1e6, 3)   # [um]
    0.107
    """
    cfg = resolve_config(config)
    q0 = finite_vector(q, 'q', 3)
    return forward(q0 + finite_vector(dq, 'dq', 3), cfg, model).virtual_joints - forward(q0, cfg, model).virtual_joints


def analyze_mobility(q: ArrayLike, config: GprConfig | None = None, model: str | None = None) -> MobilityResult:
    """Mobility and sensitivity analysis at rod lengths ``q`` [m] (module docstring). One configuration: the joint
    centres and the closure's Jacobian from the one-pose kernels (:mod:`gpr_kinematics.core.single`), ``dPhi/dP``
    built once for the solve and the rank.

    The structure saves three of five decompositions: only the last three rows of ``dPhi/dX`` are non-zero, so
    ``(dPhi/dX)^+ = [0 | B^+]`` with ``B`` those rows and ``dX/dP = -B^+ dPhi_{9..11}/dP`` (in the solver's metric;
    ``B^+ = B^T (B B^T)^-1`` with a 3 x 3 inverse in floats, :func:`_pinv_rows`);
    the eigen-decomposition of ``dX/dP^T dX/dP`` is the singular value decomposition of ``dX/dP``
    (``d = sigma^2``, ``V`` its right singular vectors; the nine eigenvalues beyond its rank ``M <= 6`` are 0); the
    two ranks come from one batched SVD (``[dPhi/dP 0]`` has the singular values of ``dPhi/dP``) with
    ``numpy.linalg.matrix_rank``'s threshold. Equal to the separate decompositions to rounding (1e-13).
    """
    cfg = resolve_config(config)
    kernel, q3, P, _, closure, _, _ = forward_parts(q, cfg, model)  # forward kinematics' checks and closure
    vjm = kernel.model
    u, template = _rigid_part(kernel.geometry, cfg)
    M = vjm.size
    X = cast('list[float]', closure.X)  # one pose: floats
    dphi_dp = _constraint_jacobian_one(P, template)
    # Phi_{9+i} = |P_b - P_a|^2 - d_i(X)^2, so dPhi/dX = -dF/dX (F = d^2 - L^2 of virtual_joints).
    dphi_dx = np.zeros((12, M))
    dphi_dx[9:] = -np.array(_closure_jacobian(vjm, X))
    B = dphi_dx[9:]
    s = _scale(vjm, cfg)
    dx_dp = -(_pinv_rows(B / s) / s[:, None]) @ dphi_dp[9:]
    _, sv, vt = np.linalg.svd(dx_dp)
    evals = np.zeros(12)
    evals[12 - sv.size:] = sv[::-1] ** 2
    evecs = vt[::-1].T
    sv = sv[sv > sv[0] * max(dx_dp.shape) * EPS] if sv.size and sv[0] > 0 else sv[:0]
    both = np.zeros((2, 12, 12 + M))
    both[:, :, :12] = dphi_dp
    both[1, :, 12:] = dphi_dx
    S0, S1 = np.linalg.svd(both, compute_uv=False).tolist()
    rank_p, rank_a = rank_of(S0, 12), rank_of(S1, 12 + M)
    e9, e11 = evals[9:12:2].tolist()
    bounds = {'eq4': (math.sqrt(max(e9, 0.0)), math.sqrt(e11)), 'eq5': (float(sv[-1]), float(sv[0]))}
    out = MobilityResult.__new__(MobilityResult)  # every field, without the frozen __init__'s per-field setattr
    out.__dict__.update(
        q=np.array(q3), model=vjm.name, virtual_joints=np.array(X), dphi_dp=dphi_dp, dphi_dx=dphi_dx,
        dx_dp=dx_dp, rank_dphi_dp=rank_p, rank_augmented=rank_a, mobility=12 - rank_p, eigenvalues=evals,
        eigenvectors=evecs, singular_values=np.asarray(sv, dtype=float), bounds=bounds, rod_directions=u.copy(),
        singular=12 - rank_p > 1, stroke=(cfg.stroke_min, cfg.stroke_max))
    return out


#: Machine epsilon: ``numpy.linalg.matrix_rank``'s threshold is ``sigma_max max(rows, columns) EPS``.
EPS = float(np.finfo(float).eps)


def _scale(vjm: VirtualJointModel, config: GprConfig) -> Array:
    """:func:`~gpr_kinematics.core.virtual_joints.coordinate_scale`, computed once per configuration and model."""
    key = f'coordinate_scale:{vjm.name}'
    s: Array | None = config.derived.get(key)
    if s is None:
        s = config.derived[key] = coordinate_scale(vjm, config)
        s.flags.writeable = False
    return s


#: :func:`_pinv_rows` takes the normal equations where ``trace(G)^3 / det(G)`` (``G = A A^T``; a bound on the
#: condition number of ``G``) is at most this: ``A^+`` then has a relative error below ``1e-12``; else the SVD.
PINV_NORMAL_CONDITION = 1e4


def _pinv_rows(A: Array) -> Array:
    """The pseudo-inverse ``A^+ = A^T (A A^T)^-1`` (M x 3) of a 3 x M matrix ``A`` of full row rank (the closure's
    Jacobian, scaled), the 3 x 3 inverse in floats (its adjugate); :func:`_pinv` where ``A A^T`` is not well
    conditioned (:data:`PINV_NORMAL_CONDITION`). Equal to ``numpy.linalg.pinv`` to rounding (a test: 1e-12)."""
    (g00, g01, g02), (_, g11, g12), (_, _, g22) = (A @ A.T).tolist()
    k00, k11, k22 = g11 * g22 - g12 * g12, g00 * g22 - g02 * g02, g00 * g11 - g01 * g01
    k01, k02, k12 = g02 * g12 - g01 * g22, g01 * g12 - g02 * g11, g01 * g02 - g00 * g12
    det = g00 * k00 + g01 * k01 + g02 * k02
    trace = g00 + g11 + g22
    if not det * PINV_NORMAL_CONDITION >= trace * trace * trace:   # also NaN
        return _pinv(A)
    inv = 1.0 / det
    G_inv = np.array([[k00, k01, k02], [k01, k11, k12], [k02, k12, k22]]) * inv
    return np.asarray(A.T @ G_inv, dtype=np.float64)


def _pinv(A: Array) -> Array:
    """``numpy.linalg.pinv(A)`` of one matrix (its steps and default cutoff ``1e-15 sigma_max``, without the wrapper
    that costs three times the decomposition of a 3 x M matrix)."""
    u, s, vt = np.linalg.svd(A, full_matrices=False)
    if s[-1] > 1e-15 * s[0]:  # every singular value above the cutoff (the closure's Jacobian within the limits)
        s = 1.0 / s
    else:
        large = s > 1e-15 * s[0]
        s = np.divide(1.0, s, where=large, out=s)
        s[~large] = 0.0
    return np.asarray(vt.T @ (s[:, None] * u.T), dtype=np.float64)


def _rigid_part(geo: MachineGeometry, config: GprConfig) -> tuple[Array, Array]:
    """The unit rod directions ``u (3, 3)`` of ``geo`` (the machine of ``config``) and the rows of ``dPhi/dP`` that
    do not depend on the pose (rows 0-8: ``u_i`` in column ``i``, ``-I`` at ``P_i``; rows 9-11 zero), kept with the
    config (read-only)."""
    key = 'mobility_rigid_part'
    part: tuple[Array, Array] | None = config.derived.get(key)
    if part is None:
        u = np.array([geo.ux, geo.uy, geo.uz]).T
        J = np.zeros((12, 12))
        for i in range(3):
            J[3 * i:3 * i + 3, i] = u[i]
            J[3 * i, 3 + 3 * i] = J[3 * i + 1, 4 + 3 * i] = J[3 * i + 2, 5 + 3 * i] = -1.0
        u.flags.writeable = J.flags.writeable = False
        part = config.derived[key] = (u, J)
    return part


#: The flat indices in ``dPhi/dP`` of edge ``i``'s ``2 e`` (at ``P_b``) and ``-2 e`` (at ``P_a``): row ``9 + i``.
_EDGE_INDEX = np.array([12 * (9 + i) + 3 + 3 * k + c for i, (a, b) in enumerate(EDGES) for k in (b, a)
                        for c in range(3)])


def _constraint_jacobian_one(P: Sequence[Sequence[float]], template: Array) -> Array:
    """:func:`constraint_jacobian` ``(12, 12)`` of one configuration: joint centres ``P = (x, y, z)`` (lists over the
    rods) [m] written into a copy of the pose-independent rows ``template`` (:func:`_rigid_part`)."""
    x, y, z = P
    J = template.copy()
    values: list[float] = []
    for a, b in EDGES:
        ex, ey, ez = 2.0 * (x[b] - x[a]), 2.0 * (y[b] - y[a]), 2.0 * (z[b] - z[a])
        values += (ex, ey, ez, -ex, -ey, -ez)
    J.flat[_EDGE_INDEX] = values
    return J


def _closure_jacobian(vjm: VirtualJointModel, X: list[float]) -> list[list[float]]:
    """``dF/dX`` (3 x M) of the closure ``F_i = d_i(X)^2 - L_i^2`` at one ``X`` in floats: row ``i`` (edge
    ``a -> b``) is ``2 e_i . dr_b/dX - 2 e_i . dr_a/dX`` with ``e_i = r_b - r_a`` (the batch's
    :meth:`~gpr_kinematics.core.virtual_joints.VirtualJointModel.closure`)."""
    rx, ry, dlx, dly, dax, day = joint_components(SCALAR, vjm, X)
    rows = []
    for a, b in EDGES:
        ex, ey = cast('float', rx[b]) - cast('float', rx[a]), cast('float', ry[b]) - cast('float', ry[a])
        row = [0.0] * vjm.size
        row[b] = 2.0 * (ex * cast('float', dlx[b]) + ey * cast('float', dly[b]))
        row[a] = -2.0 * (ex * cast('float', dlx[a]) + ey * cast('float', dly[a]))
        if vjm.size == 6 and dax is not None and day is not None:
            row[3 + b] = 2.0 * (ex * cast('float', dax[b]) + ey * cast('float', day[b]))
            row[3 + a] = -2.0 * (ex * cast('float', dax[a]) + ey * cast('float', day[a]))
        rows.append(row)
    return rows

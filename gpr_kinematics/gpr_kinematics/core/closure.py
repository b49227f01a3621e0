"""The solution of the virtual-joint closure: Newton-Raphson from the rest ``X``, or the minimum elastic cost.

Bratovanov & Sotirov §IV-V, eq. (8) (``docs/references.md``): the closure equations of the models of
:mod:`gpr_kinematics.core.virtual_joints` are solved by Newton-Raphson with the weighted Moore-Penrose
pseudo-inverse, always from the rest ``X`` (radial, polar, offset); the compliant model takes the ``X`` of minimum
elastic cost (:mod:`gpr_kinematics.core.compliance`). One loop serves one pose (floats) and a batch (arrays).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import NDArray

from .compliance import minimum_cost_closure
from .config import GprConfig
from .ops import ARRAY, SCALAR, Ops, Value
from .virtual_joints import (
    Closure,
    Components,
    VirtualJointModel,
    angular_weight,
    joint_components,
    not_converged,
    side_errors,
    symmetric_solve3,
)

Array = NDArray[np.float64]


def newton_terms(ops: Ops, comps: Components, L: Sequence[Value], wa: float) -> list[Value]:
    """One Newton-Raphson step of the closure (paper eq. (8)), component-wise.

    ``J`` is sparse: row ``i`` (edge ``a -> b``: 1->2, 2->3, 3->1) depends only on the coordinates of
    joints ``a`` and ``b``: ``dF_i/dX_b = 2 e_i . dr_b/dX_b``, ``dF_i/dX_a = -2 e_i . dr_a/dX_a`` with
    ``e_i = r_b - r_a``. So the Gram matrix ``G = J W J^T`` has closed-form entries (joint ``i+1`` is
    shared by edges ``i`` and ``i+1``) and ``y = G^-1 F`` is solved by the adjugate of the symmetric
    3x3 ``G``; the step is ``dX = -W J^T y``. ``comps`` are the :func:`joint_components` at the current
    ``X``; returns the step ``dX`` (list of ``M`` components).
    """
    (x0, x1, x2), (y0, y1, y2), (ux0, ux1, ux2), (uy0, uy1, uy2), dax, day = comps
    e0x, e0y, e1x, e1y, e2x, e2y = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x0 - x2, y0 - y2
    F0 = e0x * e0x + e0y * e0y - L[0] * L[0]
    F1 = e1x * e1x + e1y * e1y - L[1] * L[1]
    F2 = e2x * e2x + e2y * e2y - L[2] * L[2]
    # gb_i: derivative of F_i by the coordinate of its end joint, ga_i: by that of its start joint.
    gb0, ga0 = 2.0 * (e0x * ux1 + e0y * uy1), -2.0 * (e0x * ux0 + e0y * uy0)
    gb1, ga1 = 2.0 * (e1x * ux2 + e1y * uy2), -2.0 * (e1x * ux1 + e1y * uy1)
    gb2, ga2 = 2.0 * (e2x * ux0 + e2y * uy0), -2.0 * (e2x * ux2 + e2y * uy2)
    g00, g11, g22 = gb0 * gb0 + ga0 * ga0, gb1 * gb1 + ga1 * ga1, gb2 * gb2 + ga2 * ga2
    g01, g12, g02 = gb0 * ga1, gb1 * ga2, gb2 * ga0
    if dax is not None and day is not None:
        (ax0, ax1, ax2), (ay0, ay1, ay2) = dax, day
        hb0, ha0 = 2.0 * (e0x * ax1 + e0y * ay1), -2.0 * (e0x * ax0 + e0y * ay0)
        hb1, ha1 = 2.0 * (e1x * ax2 + e1y * ay2), -2.0 * (e1x * ax1 + e1y * ay1)
        hb2, ha2 = 2.0 * (e2x * ax0 + e2y * ay0), -2.0 * (e2x * ax2 + e2y * ay2)
        g00 = g00 + wa * (hb0 * hb0 + ha0 * ha0)
        g11 = g11 + wa * (hb1 * hb1 + ha1 * ha1)
        g22 = g22 + wa * (hb2 * hb2 + ha2 * ha2)
        g01 = g01 + wa * hb0 * ha1
        g12 = g12 + wa * hb1 * ha2
        g02 = g02 + wa * hb2 * ha0
    y0, y1, y2 = symmetric_solve3(g00, g01, g02, g11, g12, g22, F0, F1, F2)
    # Joint k is the end b of edge k-1 and the start a of edge k.
    dX = [-(gb2 * y2 + ga0 * y0), -(gb0 * y0 + ga1 * y1), -(gb1 * y1 + ga2 * y2)]
    if dax is not None:
        dX += [-wa * (hb2 * y2 + ha0 * y0), -wa * (hb0 * y0 + ha1 * y1), -wa * (hb1 * y1 + ha2 * y2)]
    return dX


def newton_closure(ops: Ops, vjm: VirtualJointModel, L: Sequence[Value], config: GprConfig) -> Closure:
    """Solve ``F(X) = 0`` for side lengths ``L`` (three floats, or three arrays ``(N,)``) by Newton-Raphson
    from the rest ``X``: the one loop of the single and the batch solve.

    Step (paper eq. (8), in the weighted metric ``W = diag(s)^-2``): ``dX = -W J^T (J W J^T)^-1 F(X)``, the
    minimum-``|dX|_W`` solution of ``J dX = -F``. Each sample stops as soon as its side-length error
    ``max_i |d_i(X) - L_i|`` is at most ``config.tolerance`` [m] (so batch and single solves agree); at most
    ``config.max_iterations`` steps are taken.

    Raises:
        ConvergenceError: a sample did not reach the tolerance within ``max_iterations``.
    """
    X: list[Value]
    if ops is SCALAR:
        X, comps = list(vjm.singular_floats), vjm.singular_components
    else:
        X = [x + 0.0 * L[0] for x in vjm.singular_floats]  # arrays (N,)
        comps = joint_components(ops, vjm, X)
    wa, tol = angular_weight(config), config.tolerance
    where, not_, any_, all_ = ops.where, ops.not_, ops.any, ops.all
    d, err = side_errors(ops, comps, L)
    active = not_(err <= tol)
    iterations = 0 * active
    for _ in range(config.max_iterations):
        if not any_(active):
            break
        dX = newton_terms(ops, comps, L, wa)
        if all_(active):
            X = [x + dx for x, dx in zip(X, dX, strict=True)]
        else:
            X = [where(active, x + dx, x) for x, dx in zip(X, dX, strict=True)]
        iterations = iterations + active
        comps = joint_components(ops, vjm, X)
        d, err = side_errors(ops, comps, L)
        active = not_(err <= tol)
    else:
        if any_(active):
            raise not_converged(f'virtual-joint closure ({vjm.name})', config, err, active)
    return Closure(X, comps, d, iterations, err)


def solve_closure(ops: Ops, vjm: VirtualJointModel, L: Sequence[Value], config: GprConfig) -> Closure:
    """The virtual joints of side lengths ``L`` under ``vjm``: the closure Newton loop (radial, polar, offset)
    or the minimum-cost fit (compliant, :func:`gpr_kinematics.core.compliance.minimum_cost_closure`)."""
    if vjm.name == 'compliant':
        return minimum_cost_closure(ops, vjm, L, config)
    return newton_closure(ops, vjm, L, config)


@dataclass(frozen=True)
class VirtualJointSolution:
    """Solution of the closure for a batch: ``X (N, M)``, side lengths, iterations, residuals [m] and
    the :func:`joint_components` at the solution."""

    X: Array
    side_lengths: Array
    iterations: NDArray[np.int64]
    residual: Array
    components: Components


def solve_virtual_joints(L: Array, vjm: VirtualJointModel, config: GprConfig) -> VirtualJointSolution:
    """:func:`solve_closure` of side lengths ``L (N, 3)`` [m], as arrays."""
    n = L.shape[0]
    sol = solve_closure(ARRAY, vjm, [np.ascontiguousarray(L[:, i]) for i in range(3)], config)
    return VirtualJointSolution(X=np.stack(sol.X, axis=-1), side_lengths=np.stack(sol.side_lengths, axis=-1),
                                iterations=np.broadcast_to(sol.iterations, (n,)).astype(np.int64),
                                residual=cast('Array', sol.residual), components=sol.components)

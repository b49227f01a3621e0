"""The ``compliant`` virtual-joint model: the closure of minimum elastic cost.

Each spherical joint centre may be displaced on the platform by ``d_k`` (platform frame, in the platform
plane) at the elastic cost ``1/2 d_k^T W_k d_k`` with ``W_k = k_r e_r e_r^T + k_t e_t e_t^T`` (``e_r``,
``e_t``: the joint's radial and tangential directions, :mod:`gpr_kinematics.core.virtual_joints`). The platform
pose is the one that closes the mechanism at minimum total cost. Only ``kappa_k = k_t / k_r`` matters
(the radial stiffnesses of the three joints are taken equal, a common scale that drops out).

The constrained minimum is solved exactly, as an unconstrained problem in three unknowns. The closure says
that the displaced joints ``r_k = p_k + d_k`` are congruent with the joint centres ``P_k`` on the rods: the
platform plane is the plane of the ``P_k`` (its normal does not depend on the model), and in that plane the
triangle ``Q_k`` with the side lengths ``L`` of the ``P_k`` (built from ``L`` alone) is placed on the platform
by a rigid motion ``(tau, psi)``: ``r_k = R(psi) Q_k + tau``. So

    minimise  C(tau, psi) = 1/2 sum_k d_k^T W_k d_k,   d_k = R(psi) Q_k + tau - p_k,

with ``m_k = R(psi) Q_k`` and ``J = [[0, -1], [1, 0]]``: gradient ``g_tau = sum W_k d_k``,
``g_psi = sum (J m_k) . W_k d_k``; Hessian ``H_tau,tau = sum W_k``, ``H_tau,psi = sum W_k J m_k``,
``H_psi,psi = sum (J m_k) . W_k (J m_k) - m_k . W_k d_k``. Newton's method starts from the isotropic optimum
(the 2-D Kabsch fit, exact for ``kappa = 1``) and stops when a step is below the closure tolerance [m]
(angles scaled by the mean joint radius); 2-3 steps. The virtual joints are the radial and tangential
components ``X = (dr_k, dt_k)`` of ``d_k``, which then close the mechanism to rounding (~1e-17 m).

Limits: ``kappa -> infinity`` forbids tangential motion and gives the ``radial`` model; ``kappa = 1`` moves
the triangle's centroid onto that of the joints, so the platform centre does not shift (to rounding); the
centre shift at a tilt ``alpha`` is about ``R alpha^2 / 4 * (kappa - 1) / (kappa + 1)`` in the direction
``-2 gamma`` (``docs/core.md``, a figure there). At a height of 0.5 m, 2 deg about the x axis, rods set by
the naive model (the reference values of ``docs/core.md``):

>>> import math
>>> from gpr_kinematics.core.config import GprConfig
>>> from gpr_kinematics.core import forward, naive_inverse
>>> q = naive_inverse(0.5, math.radians(2.0), 0.0)
>>> for kappa in (1e-3, 1.0, 10.0, 1e6):
...     fk = forward(q, config=GprConfig(model='compliant', kappa=(kappa,) * 3))
...     print(f'{kappa:g}: {fk.centre_shift[0] * 1e6:+.2f} um')
0.001: -28.32 um
1: +0.00 um
10: +23.22 um
1e+06: +28.38 um
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple, cast

import numpy as np

from .config import GprConfig
from .ops import SCALAR, Ops, Value
from .virtual_joints import (
    Closure,
    VirtualJointModel,
    joint_components,
    not_converged,
    side_errors,
    symmetric_solve3,
)


def _triangle(ops: Ops, L: Sequence[Value], sign: Value) -> tuple[list[Value], list[Value]]:
    """In-plane points ``Q_k`` with side lengths ``L = (L12, L23, L31)``: ``Q_1`` at the origin, ``Q_2`` on the
    x axis, ``Q_3`` on the side ``sign`` (+1: counter-clockwise, like the platform joints)."""
    L0, L1, L2 = L[0], L[1], L[2]
    x2 = (L0 * L0 + L2 * L2 - L1 * L1) / (2.0 * L0)
    y2 = sign * ops.sqrt(ops.maximum(L2 * L2 - x2 * x2, 0.0))
    zero = 0.0 * L0
    return [zero, L0, x2], [zero, zero, y2]


class Stiffness(NamedTuple):
    """What the minimum-cost closure takes from the model (floats, or arrays ``(N,)`` for one machine per row):
    the platform joints ``p_k`` and their centroid [m], the side ``sign`` of the joint triangle, the stiffness
    terms ``W_k = e_r e_r^T + kappa_k e_t e_t^T`` (``wxx, wxy, wyy`` per joint), their constant sum
    ``H_tau,tau = (hxx, hxy, hyy)`` and the mean joint radius ``scale`` [m] that turns an angle into a length."""

    px: list[Value]
    py: list[Value]
    pcx: Value
    pcy: Value
    sign: Value
    wxx: list[Value]
    wxy: list[Value]
    wyy: list[Value]
    hxx: Value
    hxy: Value
    hyy: Value
    scale: Value


def stiffness(vjm: VirtualJointModel) -> Stiffness:
    """The :class:`Stiffness` of ``vjm`` (computed per solve for a batch; once per model for the one-pose path)."""
    cs, sn, kap = vjm.cos, vjm.sin, vjm.kappa
    px = [r * c for r, c in zip(vjm.rho, cs, strict=True)]
    py = [r * s for r, s in zip(vjm.rho, sn, strict=True)]
    turn = (px[1] - px[0]) * (py[2] - py[0]) - (py[1] - py[0]) * (px[2] - px[0])
    sign = np.where(turn > 0, 1.0, -1.0) if np.ndim(turn) else (1.0 if turn > 0 else -1.0)  # per row, or one
    wxx = [cs[k] * cs[k] + kap[k] * sn[k] * sn[k] for k in range(3)]
    wxy = [cs[k] * sn[k] * (1.0 - kap[k]) for k in range(3)]
    wyy = [sn[k] * sn[k] + kap[k] * cs[k] * cs[k] for k in range(3)]
    return Stiffness(px, py, sum(px) / 3.0, sum(py) / 3.0, sign, wxx, wxy, wyy, sum(wxx), sum(wxy), sum(wyy),
                     sum(vjm.rho) / 3.0)


def _start(ops: Ops, w: Stiffness, qx: list[Value], qy: list[Value], zero: Value) -> tuple[Value, Value, Value]:
    """The isotropic optimum (2-D Kabsch): the centroids on each other, the rotation ``psi`` of best fit;
    returns ``(tx, ty, psi)``."""
    qcx, qcy = (qx[0] + qx[1] + qx[2]) / 3.0, (qy[0] + qy[1] + qy[2]) / 3.0
    cross = dot = zero
    for k in range(3):
        ax, ay, bx, by = qx[k] - qcx, qy[k] - qcy, w.px[k] - w.pcx, w.py[k] - w.pcy
        cross, dot = cross + ax * by - ay * bx, dot + ax * bx + ay * by
    psi = ops.atan2(cross, dot)
    c, s = ops.cos(psi), ops.sin(psi)
    return w.pcx - (c * qcx - s * qcy), w.pcy - (s * qcx + c * qcy), psi


def _newton_step(w: Stiffness, c: Value, s: Value, qx: list[Value], qy: list[Value], tx: Value, ty: Value,
                 zero: Value) -> tuple[Value, Value, Value]:
    """The Newton step ``H^-1 g`` on ``(tau, psi)`` at ``(tx, ty, psi)`` (``c, s``: ``cos psi, sin psi``), from
    the gradient and Hessian of the module docstring (plain arithmetic: floats or arrays)."""
    gx = gy = gp = hxp = hyp = hpp = zero
    for k in range(3):
        wxx, wxy, wyy = w.wxx[k], w.wxy[k], w.wyy[k]
        mx, my = c * qx[k] - s * qy[k], s * qx[k] + c * qy[k]
        dx, dy = mx + tx - w.px[k], my + ty - w.py[k]
        wdx, wdy = wxx * dx + wxy * dy, wxy * dx + wyy * dy
        jwx, jwy = wxx * -my + wxy * mx, wxy * -my + wyy * mx  # W_k J m_k
        gx, gy, gp = gx + wdx, gy + wdy, gp + (-my * wdx + mx * wdy)
        hxp, hyp = hxp + jwx, hyp + jwy
        hpp = hpp + (-my * jwx + mx * jwy) - (mx * wdx + my * wdy)
    return symmetric_solve3(w.hxx, w.hxy, hxp, w.hyy, hyp, hpp, gx, gy, gp)


def _displacements(vjm: VirtualJointModel, w: Stiffness, c: Value, s: Value, qx: list[Value], qy: list[Value],
                   tx: Value, ty: Value) -> list[Value]:
    """``X = (dr_1..3, dt_1..3)``: the radial and tangential components of ``d_k = R(psi) Q_k + tau - p_k``."""
    cs, sn = vjm.cos, vjm.sin
    X: list[Value] = [0.0] * 6
    for k in range(3):
        dx = c * qx[k] - s * qy[k] + tx - w.px[k]
        dy = s * qx[k] + c * qy[k] + ty - w.py[k]
        X[k], X[k + 3] = cs[k] * dx + sn[k] * dy, -sn[k] * dx + cs[k] * dy
    return X


def minimum_cost_closure(ops: Ops, vjm: VirtualJointModel, L: Sequence[Value], config: GprConfig) -> Closure:
    """Virtual joints ``X = (dr_1..3, dt_1..3)`` [m] of minimum elastic cost for side lengths ``L`` (three
    floats, or three arrays ``(N,)``), by Newton's method on ``(tau, psi)`` (module docstring).

    A sample whose joints close the mechanism at rest (side-length error <= ``config.tolerance``, e.g. the
    singular configuration of the nominal machine) keeps ``X = 0`` with no iteration, as in the other models.

    Raises:
        ConvergenceError: a sample's step is still above the tolerance after ``max_iterations`` steps.
    """
    w = stiffness(vjm)
    rest = [0.0 * L[0]] * 6
    rest_comps = joint_components(ops, vjm, rest)
    _, err = side_errors(ops, rest_comps, L)
    active = ops.not_(err <= config.tolerance)
    if not ops.any(active):
        return Closure(rest, rest_comps, side_errors(ops, rest_comps, L)[0], 0 * active, err)
    moving = active
    zero = 0.0 * L[0]
    qx, qy = _triangle(ops, L, w.sign)
    tx, ty, psi = _start(ops, w, qx, qy, zero)
    iterations = 0 * active
    for _ in range(config.max_iterations):
        ex, ey, ep = _newton_step(w, ops.cos(psi), ops.sin(psi), qx, qy, tx, ty, zero)
        tx, ty, psi = ops.where(active, tx - ex, tx), ops.where(active, ty - ey, ty), ops.where(active, psi - ep, psi)
        iterations = iterations + active
        step = ops.maximum(ops.maximum(ops.fabs(ex), ops.fabs(ey)), w.scale * ops.fabs(ep))
        active = active & ops.not_(step <= config.tolerance)
        if not ops.any(active):
            break
    else:
        raise not_converged('compliant closure (minimum elastic cost)', config, step, active)
    X = _displacements(vjm, w, ops.cos(psi), ops.sin(psi), qx, qy, tx, ty)
    X = [ops.where(moving, x, r) for x, r in zip(X, rest, strict=True)]
    comps = joint_components(ops, vjm, X)
    d, err = side_errors(ops, comps, L)
    return Closure(X, comps, d, iterations, err)


def minimum_cost_floats(vjm: VirtualJointModel, w: Stiffness, rest: Closure, L0: float, L1: float, L2: float,
                        config: GprConfig) -> Closure:
    """:func:`minimum_cost_closure` of one pose in float arithmetic (the same steps, to the last bit), with the
    model's :func:`stiffness` ``w`` and the closure ``rest`` at rest (the side lengths of the joints ``p_k``)
    computed once per model."""
    L = (L0, L1, L2)
    d0, d1, d2 = cast('list[float]', rest.side_lengths)
    err = max(max(abs(d0 - L0), abs(d1 - L1)), abs(d2 - L2))
    if err <= config.tolerance:
        return Closure(rest.X, rest.components, rest.side_lengths, 0, err)
    cos, sin, tol = math.cos, math.sin, config.tolerance
    qx, qy = _triangle(SCALAR, L, w.sign)
    tx, ty, psi = cast('tuple[float, float, float]', _start(SCALAR, w, qx, qy, 0.0))
    iterations = 0
    while True:
        ex, ey, ep = cast('tuple[float, float, float]', _newton_step(w, cos(psi), sin(psi), qx, qy, tx, ty, 0.0))
        tx, ty, psi = tx - ex, ty - ey, psi - ep
        iterations += 1
        step = max(max(abs(ex), abs(ey)), w.scale * abs(ep))
        if step <= tol:
            break
        if iterations == config.max_iterations:
            raise not_converged('compliant closure (minimum elastic cost)', config, step, True)
    X = _displacements(vjm, w, cos(psi), sin(psi), qx, qy, tx, ty)
    comps = joint_components(SCALAR, vjm, X)
    d, residual = side_errors(SCALAR, comps, L)
    return Closure(X, comps, d, iterations, residual)

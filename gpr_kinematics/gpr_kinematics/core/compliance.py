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

from collections.abc import Sequence
from typing import Any

import numpy as np

from .config import GprConfig
from .ops import Ops
from .virtual_joints import Closure, VirtualJointModel, joint_components, not_converged, side_errors, symmetric_solve3


def _triangle(ops: Ops, L: Sequence[Any], sign: Any) -> tuple[list[Any], list[Any]]:
    """In-plane points ``Q_k`` with side lengths ``L = (L12, L23, L31)``: ``Q_1`` at the origin, ``Q_2`` on the
    x axis, ``Q_3`` on the side ``sign`` (+1: counter-clockwise, like the platform joints)."""
    L0, L1, L2 = L[0], L[1], L[2]
    x2 = (L0 * L0 + L2 * L2 - L1 * L1) / (2.0 * L0)
    y2 = sign * ops.sqrt(ops.maximum(L2 * L2 - x2 * x2, 0.0))
    zero = 0.0 * L0
    return [zero, L0, x2], [zero, zero, y2]


def minimum_cost_closure(ops: Ops, vjm: VirtualJointModel, L: Sequence[Any], config: GprConfig) -> Closure:
    """Virtual joints ``X = (dr_1..3, dt_1..3)`` [m] of minimum elastic cost for side lengths ``L`` (three
    floats, or three arrays ``(N,)``), by Newton's method on ``(tau, psi)`` (module docstring).

    A sample whose joints close the mechanism at rest (side-length error <= ``config.tolerance``, e.g. the
    singular configuration of the nominal machine) keeps ``X = 0`` with no iteration, as in the other models.

    Raises:
        ConvergenceError: a sample's step is still above the tolerance after ``max_iterations`` steps.
    """
    cs, sn, kap = vjm.cos, vjm.sin, vjm.kappa
    px = [r * c for r, c in zip(vjm.rho, cs, strict=True)]
    py = [r * s for r, s in zip(vjm.rho, sn, strict=True)]
    turn = (px[1] - px[0]) * (py[2] - py[0]) - (py[1] - py[0]) * (px[2] - px[0])
    sign = np.where(turn > 0, 1.0, -1.0) if np.ndim(turn) else (1.0 if turn > 0 else -1.0)  # per row, or one
    rest = [0.0 * L[0]] * 6
    rest_comps = joint_components(ops, vjm, rest)
    _, err = side_errors(ops, rest_comps, L)
    active = ops.not_(err <= config.tolerance)
    if not ops.any(active):
        return Closure(rest, rest_comps, side_errors(ops, rest_comps, L)[0], 0 * active, err)
    moving = active
    qx, qy = _triangle(ops, L, sign)
    # Start: the isotropic optimum (2-D Kabsch): centroids on each other, the rotation of best fit.
    qcx, qcy = (qx[0] + qx[1] + qx[2]) / 3.0, (qy[0] + qy[1] + qy[2]) / 3.0
    pcx, pcy = sum(px) / 3.0, sum(py) / 3.0
    cross = dot = 0.0 * L[0]
    for k in range(3):
        ax, ay, bx, by = qx[k] - qcx, qy[k] - qcy, px[k] - pcx, py[k] - pcy
        cross, dot = cross + ax * by - ay * bx, dot + ax * bx + ay * by
    psi = ops.atan2(cross, dot)
    c, s = ops.cos(psi), ops.sin(psi)
    tx, ty = pcx - (c * qcx - s * qcy), pcy - (s * qcx + c * qcy)
    # W_k = e_r e_r^T + kappa_k e_t e_t^T; H_tau,tau = sum W_k is constant.
    wxx = [cs[k] * cs[k] + kap[k] * sn[k] * sn[k] for k in range(3)]
    wxy = [cs[k] * sn[k] * (1.0 - kap[k]) for k in range(3)]
    wyy = [sn[k] * sn[k] + kap[k] * cs[k] * cs[k] for k in range(3)]
    hxx, hxy, hyy = sum(wxx), sum(wxy), sum(wyy)
    scale = sum(vjm.rho) / 3.0
    iterations = 0 * active
    for _ in range(config.max_iterations):
        c, s = ops.cos(psi), ops.sin(psi)
        gx = gy = gp = hxp = hyp = hpp = 0.0 * L[0]
        for k in range(3):
            mx, my = c * qx[k] - s * qy[k], s * qx[k] + c * qy[k]
            dx, dy = mx + tx - px[k], my + ty - py[k]
            wdx, wdy = wxx[k] * dx + wxy[k] * dy, wxy[k] * dx + wyy[k] * dy
            jwx, jwy = wxx[k] * -my + wxy[k] * mx, wxy[k] * -my + wyy[k] * mx  # W_k J m_k
            gx, gy, gp = gx + wdx, gy + wdy, gp + (-my * wdx + mx * wdy)
            hxp, hyp = hxp + jwx, hyp + jwy
            hpp = hpp + (-my * jwx + mx * jwy) - (mx * wdx + my * wdy)
        ex, ey, ep = symmetric_solve3(hxx, hxy, hxp, hyy, hyp, hpp, gx, gy, gp)
        tx, ty, psi = ops.where(active, tx - ex, tx), ops.where(active, ty - ey, ty), ops.where(active, psi - ep, psi)
        iterations = iterations + active
        step = ops.maximum(ops.maximum(ops.fabs(ex), ops.fabs(ey)), scale * ops.fabs(ep))
        active = active & ops.not_(step <= config.tolerance)
        if not ops.any(active):
            break
    else:
        raise not_converged('compliant closure (minimum elastic cost)', config, step, active)
    c, s = ops.cos(psi), ops.sin(psi)
    X: list[Any] = [0.0] * 6
    for k in range(3):
        dx = c * qx[k] - s * qy[k] + tx - px[k]
        dy = s * qx[k] + c * qy[k] + ty - py[k]
        X[k] = ops.where(moving, cs[k] * dx + sn[k] * dy, rest[k])
        X[k + 3] = ops.where(moving, -sn[k] * dx + cs[k] * dy, rest[k])
    comps = joint_components(ops, vjm, X)
    d, err = side_errors(ops, comps, L)
    return Closure(X, comps, d, iterations, err)


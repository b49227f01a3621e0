"""A serial planar arm in its mount frame: forward kinematics and closed-form inverse kinematics, vectorised.

All joint axes are parallel to the platform normal, so in the *mount frame* (the first joint axis, rotated by the
mount yaw) the arm is a planar chain. With ``Theta_k = theta_1 + ... + theta_k`` the direction of link ``k``,
``d_k = (length_k, 0)`` the link vectors and the blade folded into the last one,

    ``p = sum_k Rz(Theta_k) d_k``,  ``d_n = (length_n, 0) + b_xy + Rz(beta) w_xy``,  ``phi = Theta_n + beta``

(``b``, ``beta``: blade position and yaw in the flange frame; ``w``: wafer centre in the blade frame; ``p``,
``phi``: wafer centre and blade heading in the mount frame). A joint's ``zero_offset`` ``o_k`` (a calibration's) turns
it by ``theta_k + o_k``: the chain works on those angles, the joint values in and out are the ``theta_k``.
Inverse kinematics in closed form:

* **2 joints**: the wafer position alone; the heading ``phi`` is an *outcome* (one per branch).
* **3 joints**: ``Theta_3 = phi - beta``, the wrist axis ``p_3 = p - Rz(Theta_3) d_3``, then the two-link
  problem for the shoulder and elbow.
* **4 joints**: one joint ``j`` is held at a value ``v`` (rule ``fixed_joint``, or each candidate of the rule
  ``nearest``): it is folded into its neighbours (link ``j-1`` becomes ``d_{j-1} + Rz(v) d_j``; joint ``j+1``
  gains the offset ``v``), which leaves a 3-joint chain.

**Two-link problem** (cosine rule) for links ``D1, D2`` (lengths ``L1, L2``, directions ``delta1, delta2``) and
a target ``p`` at distance ``r``: the relative angle ``g`` of the two links has ``cos g = (r^2 - L1^2 - L2^2) /
(2 L1 L2)`` and ``sin g = s sqrt(((L1+L2)^2 - r^2)(r^2 - (L1-L2)^2)) / (2 L1 L2)`` (the product form keeps the
digits near full stretch); ``A1 = atan2(p) - atan2(L2 sin g, L1 + L2 cos g)``. The **branch** is the sign ``s``:
``right`` (``s = +1``) puts the elbow to the right of the line from the shoulder axis to the wrist axis, seen
from above the platform (the second link turns counterclockwise relative to the first), ``left`` (``s = -1``)
to its left. Reachable when ``|L1 - L2| <= r <= L1 + L2``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .arm_chain import (
    LIMIT_SLACK,
    REACH_SLACK,
    ArmFloats,
    arm_floats,
    chain_forward,
    fixed_one,
    link_vectors,
    reduced_one,
    solve3,
    solve_fixed,
    two_link,
    two_link_one,
    wrap_to_limits,
)
from .description import Arm
from .nearest import nearest_value

#: A held joint's solved value within this of the value it was held at [rad] is that value (the zero offset and the
#: wrap into its range round it: 0.2 came back as 0.20000000000000018); farther, another representative of it.
HELD_ROUNDING = 1e-12

Array = NDArray[np.float64]


def branch_sign(branch: str) -> float:
    """``+1`` for ``right``, ``-1`` for ``left`` (module docstring)."""
    return 1.0 if branch == 'right' else -1.0


@dataclass(frozen=True)
class ArmSolution:
    """Inverse kinematics of ``N`` wafer targets in the mount frame.

    Attributes:
        theta: joint values ``(N, n)`` [rad], each the representative nearest the middle of its range.
        heading: blade heading reached in the mount frame ``(N,)`` [rad] (an outcome for 2-joint arms).
        reachable: ``(N,)`` the two-link sub-chain reaches the target.
        reach, reach_min, reach_max: ``(N,)`` [m] distance shoulder-to-wrist and the reach interval.
        violation: ``(N, n)`` [rad] how far each joint lies beyond its limits (0 inside).
    """

    theta: Array
    heading: Array
    reachable: NDArray[np.bool_]
    reach: Array
    reach_min: Array
    reach_max: Array
    violation: Array


def solve_arm(arm: Arm, p: Array, phi: Array | None, sign: Array, value: Array | None = None) -> ArmSolution:
    """Joint values that put the wafer at ``p (N, 2)`` with heading ``phi (N,)`` in the mount frame.

    Args:
        phi: required for 3- and 4-joint arms; ignored (an outcome) for 2-joint arms.
        sign: branch sign per target (:func:`branch_sign`).
        value: for a 4-joint arm, the held joint's value per target whatever its rule (default: the rule's own;
            :func:`~gpr_kinematics.robot.inverse.solve_stations` takes one under ``fixed_joint`` only).
    """
    d, beta = link_vectors(arm)
    n = len(arm.joints)
    lower, upper, offset = arm.lower, arm.upper, arm.zero_offset
    if n == 2:
        tl = two_link(d[0], d[1], p, sign)
        theta = np.stack([tl.Theta1, tl.Theta2 - tl.Theta1], axis=-1)
    elif n == 3:
        assert phi is not None
        theta, tl = solve3(d, [0.0, 0.0, 0.0], beta, p, phi, sign)
    else:
        assert phi is not None and arm.redundancy is not None
        red = arm.redundancy
        if value is not None:   # the held values given (as solve_arm_one takes them), whatever the rule
            v = np.asarray(value, dtype=float)
        elif red.rule == 'fixed_joint':
            v = np.full(p.shape[0], red.value)
        else:
            v = nearest_value(arm, d, beta, p, phi, sign)
        theta, tl = solve_fixed(d, beta, red.joint, v + offset[red.joint], p, phi, sign)
    heading = np.sum(theta, axis=1) + beta
    theta, violation = wrap_to_limits(theta - offset, lower, upper)
    if n == 4:   # the held joint at its value as given, where the offset and the wrap only rounded it (0.2 read
        j = red.joint   # 0.20000000000000018); a range beyond a turn may give another representative: kept
        theta[:, j] = np.where(np.abs(theta[:, j] - v) <= HELD_ROUNDING, v, theta[:, j])
    return ArmSolution(theta=theta, heading=heading, reachable=tl.reachable, reach=tl.r, reach_min=tl.r_min,
                       reach_max=tl.r_max, violation=violation)


class OneArm(NamedTuple):
    """:class:`ArmSolution` of one target in floats: joint values (wrapped) [rad], heading [rad], reachable, the reach
    and its interval [m], each joint's violation of its limits [rad]."""

    theta: list[float]
    heading: float
    reachable: bool
    reach: float
    reach_min: float
    reach_max: float
    violation: list[float]


def solve_arm_one(arm: Arm, px: float, py: float, phi: float, sign: float, value: float | None = None,
                  floats: ArmFloats | None = None) -> OneArm:
    """:func:`solve_arm` of one target ``(px, py)`` [m], heading ``phi`` [rad] in floats (the same steps); ``value``:
    a 4-joint arm's held joint at this value [rad] whatever its rule (the ``nearest`` rule's answer found by the
    caller), by default the rule's own; ``floats``: :func:`~.arm_chain.arm_floats` of ``arm`` if the caller has it."""
    if floats is None:
        floats = arm_floats(arm)
    d, beta, offset = floats.links, floats.beta, floats.offsets
    given = math.nan   # a 4-joint arm's held value [rad] as given: kept where the wrap below only rounds it
    if len(offset) == 2:
        T1, T2, r, lo, hi = two_link_one(d[0], d[1], px, py, sign)
        theta = [T1, T2 - T1]
    elif floats.own is not None and (arm.redundancy is None or value is None):   # the rule's own chain, reduced once
        theta, r, lo, hi = reduced_one(floats.own, px, py, phi, sign)
        if arm.redundancy is not None:   # fixed_joint's
            given = arm.redundancy.value
    else:
        j, v, red = -1, 0.0, arm.redundancy
        if red is not None:
            j = red.joint
            if value is not None:
                v = value
            elif red.rule == 'fixed_joint':
                v = red.value
            else:
                v = float(nearest_value(arm, link_vectors(arm)[0], beta, np.array([[px, py]]), np.array([phi]),
                                        np.array([sign]))[0])
            given, v = v, v + offset[j]
        theta, r, lo, hi = fixed_one(d, beta, j, v, px, py, phi, sign)
    heading = sum(theta) + beta
    wrapped, violation = [], []   # wrap_one of theta - offset, inline (its operations)
    pi, turn = math.pi, 2.0 * math.pi
    held = arm.redundancy.joint if len(offset) == 4 and arm.redundancy is not None else -1
    for k, (t, o, (lower, upper, mid)) in enumerate(zip(theta, offset, floats.limits, strict=True)):
        t = mid + (t - o - mid + pi) % turn - pi
        if k == held and abs(t - given) <= HELD_ROUNDING:   # as solve_arm
            t = given
        beyond = max(lower - t, t - upper) - LIMIT_SLACK
        wrapped.append(t)
        violation.append(beyond if beyond >= 0.0 else 0.0)
    return OneArm(wrapped, heading, hi + REACH_SLACK >= r >= lo - REACH_SLACK, r, lo, hi, violation)


def two_link_axes(arm: Arm) -> list[int]:
    """The joints whose axes are the shoulder, elbow and wrist of the two-link sub-chain of a 3- or 4-joint arm: all
    but the held (or swept) joint of a 4-joint arm (module docstring)."""
    held = arm.redundancy.joint if arm.redundancy is not None else -1
    return [k for k in range(len(arm.joints)) if k != held][:3]


def branch_of(arm: Arm, theta: Array) -> tuple[str, ...]:
    """The branch of each posture ``theta (N, n)``: on which side of the line from the shoulder axis to the wrist
    axis (the wafer centre for 2 joints) the elbow lies, seen from above the platform (module docstring). For a
    4-joint arm the two-link sub-chain is the one left after folding the held (or swept) joint."""
    axes, wafer, _ = chain_forward(arm, theta)
    points = [axes[:, 0], axes[:, 1], wafer] if len(arm.joints) == 2 else [axes[:, k] for k in two_link_axes(arm)]
    u, v = points[1] - points[0], points[2] - points[1]
    cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    return tuple('right' if c >= 0.0 else 'left' for c in cross)

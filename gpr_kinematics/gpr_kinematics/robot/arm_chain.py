"""The planar chain of an arm in its mount frame: link vectors, forward kinematics, the two-link problem and the
three-joint and held-joint solves, on arrays and (the ``*_one`` functions) on the floats of one target. The
equations, the branches and how a held joint folds into its neighbours: :mod:`gpr_kinematics.robot.planar_arm`'s
docstring; the solvers that pick the held joint's value are there and in :mod:`gpr_kinematics.robot.nearest`.
SI units: metres, radians.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..core.rotations import rotate_z
from .description import Arm

Array = NDArray[np.float64]

#: Slack [m] on the reach interval (rounding of targets at full stretch).
REACH_SLACK = 1e-12
#: Slack [rad] on the joint limits (rounding of targets at a limit).
LIMIT_SLACK = 1e-12
#: A target this close [m] to full stretch or fold is solved as stretched or folded: there the elbow angle goes as
#: the square root of the distance, so rounding (1e-16 m) would move the joints by 1e-8 rad (the ``nearest`` rule's
#: answers often lie exactly there); the wafer then misses by this much at most.
STRETCH_SNAP = 1e-14


def link_vectors(arm: Arm) -> tuple[list[Array], float]:
    """The planar link vectors ``d_k`` (mount-frame units, blade folded into the last) and the blade yaw."""
    js = arm.joints
    b, beta, w = arm.blade.position, arm.blade.yaw, arm.blade.wafer_centre
    d = [np.array([j.length, 0.0]) for j in js]
    d[-1] = np.array([js[-1].length + b[0] + math.cos(beta) * w[0] - math.sin(beta) * w[1],
                      b[1] + math.sin(beta) * w[0] + math.cos(beta) * w[1]])
    return d, beta


def chain_forward(arm: Arm, theta: Array) -> tuple[Array, Array, Array]:
    """Forward kinematics in the mount frame of joint values ``theta (N, n)``.

    Returns ``(axes (N, n, 2), wafer (N, 2), heading (N,))``: every joint axis, the wafer centre, the blade heading.
    """
    d, beta = link_vectors(arm)
    Theta = np.cumsum(theta + arm.zero_offset, axis=1)
    n = theta.shape[1]
    axes = np.zeros(theta.shape + (2,))
    for k in range(1, n):
        axes[:, k] = axes[:, k - 1] + rotate_z(Theta[:, k - 1], d[k - 1])
    wafer = axes[:, n - 1] + rotate_z(Theta[:, n - 1], d[n - 1])
    return axes, wafer, Theta[:, n - 1] + beta


def representative(theta: Array, mid: Array | float) -> Array:
    """The representative ``theta + 2 pi k`` nearest ``mid`` [rad]: ``mid + ((theta - mid + pi) mod 2 pi) - pi``,
    the ``mod`` taken only where its argument lies outside ``[0, 2 pi)``, where it is the identity (the same bits,
    at a fraction of its cost)."""
    u = theta - mid + math.pi
    out = ~((u >= 0.0) & (u < 2.0 * math.pi))
    if out.any():
        u[out] = np.mod(u[out], 2.0 * math.pi)
    return np.asarray(mid + u - math.pi, dtype=np.float64)


def wrap_to_limits(theta: Array, lower: Array, upper: Array) -> tuple[Array, Array]:
    """The representative ``theta + 2 pi k`` nearest the middle of ``[lower, upper]`` and how far it lies beyond
    the range [rad] (0 inside). Joints of a planar arm are defined modulo ``2 pi``; a range wider than ``2 pi``
    always holds the representative."""
    t = representative(theta, 0.5 * (lower + upper))
    violation = np.maximum(np.maximum(lower - t, t - upper) - LIMIT_SLACK, 0.0)
    return t, violation


@dataclass(frozen=True)
class TwoLink:
    """Two-link solution: absolute link directions ``Theta1, Theta2`` [rad], the distance ``r`` of the target
    and the reach interval ``[r_min, r_max]`` [m]."""

    Theta1: Array
    Theta2: Array
    r: Array
    r_min: Array
    r_max: Array

    @property
    def reachable(self) -> NDArray[np.bool_]:
        return (self.r <= self.r_max + REACH_SLACK) & (self.r >= self.r_min - REACH_SLACK)


def two_link(D1: Array, D2: Array, p: Array, sign: Array | float) -> TwoLink:
    """Closed-form two-link inverse kinematics (module docstring); ``D1, D2, p`` broadcast as ``(..., 2)``.
    Out of reach, the nearest posture (stretched or folded) is returned and ``reachable`` is False."""
    L1, L2 = np.hypot(D1[..., 0], D1[..., 1]), np.hypot(D2[..., 0], D2[..., 1])
    r = np.hypot(p[..., 0], p[..., 1])
    lo, hi = np.abs(L1 - L2), L1 + L2
    inv = 1.0 / (2.0 * L1 * L2)
    cos_g = np.clip((r * r - L1 * L1 - L2 * L2) * inv, -1.0, 1.0)
    prod = (hi - r) * (hi + r) * (r - lo) * (r + lo)
    sin_g = sign * np.sqrt(np.where((hi - r > STRETCH_SNAP) & (r - lo > STRETCH_SNAP), prod, 0.0)) * inv
    g = np.arctan2(sin_g, cos_g)
    A1 = np.arctan2(p[..., 1], p[..., 0]) - np.arctan2(L2 * np.sin(g), L1 + L2 * np.cos(g))
    Theta1 = A1 - np.arctan2(D1[..., 1], D1[..., 0])
    Theta2 = A1 + g - np.arctan2(D2[..., 1], D2[..., 0])
    shape = np.broadcast_shapes(r.shape, lo.shape, Theta1.shape)
    return TwoLink(np.broadcast_to(Theta1, shape), np.broadcast_to(Theta2, shape), np.broadcast_to(r, shape),
                   np.broadcast_to(lo, shape), np.broadcast_to(hi, shape))


def solve3(d: list[Array], c: list[Array | float], beta: Array | float, p: Array, phi: Array,
            sign: Array | float) -> tuple[Array, TwoLink]:
    """Three-joint chain with offsets ``c`` (joint ``k`` turns link ``k`` by ``theta_k + c_k``): returns the joint
    values ``(..., 3)`` and the shoulder-elbow two-link solution."""
    Theta3 = phi - beta
    tl = two_link(d[0], d[1], p - rotate_z(Theta3, d[2]), sign)
    theta = np.stack([tl.Theta1 - c[0], tl.Theta2 - tl.Theta1 - c[1], Theta3 - tl.Theta2 - c[2]], axis=-1)
    return theta, tl


def solve_fixed(d: list[Array], beta: float, j: int, v: Array, p: Array, phi: Array,
                 sign: Array | float) -> tuple[Array, TwoLink]:
    """Four-joint chain with joint ``j`` held at ``v``: fold it into its neighbours, solve three joints, put it
    back. Returns the joint values ``(..., 4)`` and the two-link solution of the reduced chain."""
    zero = np.zeros_like(v)
    c: list[Array | float]
    b: Array | float
    if j == 0:
        p = p - rotate_z(v, d[0])
        dd, c, b = d[1:], [v, zero, zero], beta
    else:
        merged = d[j - 1] + rotate_z(v, d[j])
        dd = d[:j - 1] + [merged] + d[j + 1:]
        c = [zero, zero, zero]
        b = beta
        if j == 3:
            b = beta + v
        else:
            c[j] = v  # the joint after the held one turns from the held one's direction
    theta3, tl = solve3(dd, c, b, p, phi, sign)
    theta = np.concatenate([theta3[..., :j], v[..., None], theta3[..., j:]], axis=-1)
    return theta, tl


def turn(angle: float, x: float, y: float) -> tuple[float, float]:
    c, s = math.cos(angle), math.sin(angle)
    return c * x - s * y, s * x + c * y


def two_link_one(D1: tuple[float, float], D2: tuple[float, float], px: float, py: float, sign: float
                  ) -> tuple[float, float, float, float, float]:
    """:func:`two_link` of one target in floats: ``(Theta1, Theta2, r, r_min, r_max)``."""
    L1, L2, r = math.hypot(D1[0], D1[1]), math.hypot(D2[0], D2[1]), math.hypot(px, py)
    lo, hi = abs(L1 - L2), L1 + L2
    inv = 1.0 / (2.0 * L1 * L2)
    cos_g = min(max((r * r - L1 * L1 - L2 * L2) * inv, -1.0), 1.0)
    prod = (hi - r) * (hi + r) * (r - lo) * (r + lo)
    g = math.atan2(sign * math.sqrt(prod if hi - r > STRETCH_SNAP and r - lo > STRETCH_SNAP else 0.0) * inv, cos_g)
    A1 = math.atan2(py, px) - math.atan2(L2 * math.sin(g), L1 + L2 * math.cos(g))
    return A1 - math.atan2(D1[1], D1[0]), A1 + g - math.atan2(D2[1], D2[0]), r, lo, hi


def fixed_one(d: list[tuple[float, float]], beta: float, j: int, v: float, px: float, py: float, phi: float,
               sign: float) -> tuple[list[float], float, float, float]:
    """:func:`solve_fixed` (``j >= 0``) or :func:`solve3` (``j = -1``) of one target in floats: the joint values
    (not wrapped) and the two-link sub-chain's reach and interval ``(r, r_min, r_max)``; :func:`reduced_one` of
    :func:`reduce_one`'s chain, the same numbers (the ``nearest`` rule's search calls this per held value)."""
    c, b = [0.0, 0.0, 0.0], beta
    if j == 0:
        mx, my = turn(v, d[0][0], d[0][1])
        px, py, d, c[0] = px - mx, py - my, d[1:], v
    elif j > 0:
        mx, my = turn(v, d[j][0], d[j][1])
        d = d[:j - 1] + [(d[j - 1][0] + mx, d[j - 1][1] + my)] + d[j + 1:]
        if j == 3:
            b = beta + v
        else:
            c[j] = v
    Theta3 = phi - b
    wx, wy = turn(Theta3, d[2][0], d[2][1])
    T1, T2, r, lo, hi = two_link_one(d[0], d[1], px - wx, py - wy, sign)
    theta = [T1 - c[0], T2 - T1 - c[1], Theta3 - T2 - c[2]]
    if j >= 0:
        theta.insert(j, v)
    return theta, r, lo, hi


class Reduced(NamedTuple):
    """A chain of :func:`fixed_one` with its held joint ``j`` (-1: none) at ``v`` folded in: the target's shift
    ``(mx, my)``, the three links' offsets ``c``, the blade yaw ``b``, the wrist link ``wrist`` and the two-link
    constants of the first two links (:func:`two_link_one`'s: lengths, reach interval, ``1 / (2 L1 L2)``, squares,
    directions)."""

    j: int
    v: float
    shift: tuple[float, float] | None
    c: tuple[float, float, float]
    b: float
    wrist: tuple[float, float]
    link: tuple[float, float, float, float, float, float, float, float, float]


def reduce_one(d: list[tuple[float, float]], beta: float, j: int, v: float) -> Reduced:
    """The :class:`Reduced` chain of the links ``d`` and blade yaw ``beta`` with joint ``j`` held at ``v``."""
    c, b, shift = [0.0, 0.0, 0.0], beta, None
    if j == 0:
        shift, d, c[0] = turn(v, d[0][0], d[0][1]), d[1:], v
    elif j > 0:
        mx, my = turn(v, d[j][0], d[j][1])
        d = d[:j - 1] + [(d[j - 1][0] + mx, d[j - 1][1] + my)] + d[j + 1:]
        if j == 3:
            b = beta + v
        else:
            c[j] = v
    return Reduced(j, v, shift, (c[0], c[1], c[2]), b, d[2], link_constants(d[0], d[1]))


def link_constants(D1: tuple[float, float], D2: tuple[float, float]
                   ) -> tuple[float, float, float, float, float, float, float, float, float]:
    """What :func:`two_link_one` computes of its links alone: ``L1, L2, r_min, r_max, 1 / (2 L1 L2), L1^2, L2^2`` and
    the links' directions [m, rad] (its operations)."""
    L1, L2 = math.hypot(D1[0], D1[1]), math.hypot(D2[0], D2[1])
    return (L1, L2, abs(L1 - L2), L1 + L2, 1.0 / (2.0 * L1 * L2), L1 * L1, L2 * L2, math.atan2(D1[1], D1[0]),
            math.atan2(D2[1], D2[0]))


def reduced_one(chain: Reduced, px: float, py: float, phi: float, sign: float
                ) -> tuple[list[float], float, float, float]:
    """:func:`fixed_one` of a :class:`Reduced` chain, :func:`two_link_one` inline (their operations in their order)."""
    j, v, shift, (c0, c1, c2), b, (dx, dy), (L1, L2, lo, hi, inv, L1sq, L2sq, a1, a2) = chain
    if shift is not None:
        px, py = px - shift[0], py - shift[1]
    Theta3 = phi - b
    cs, sn = math.cos(Theta3), math.sin(Theta3)
    px, py = px - (cs * dx - sn * dy), py - (sn * dx + cs * dy)
    r = math.hypot(px, py)
    cos_g = min(max((r * r - L1sq - L2sq) * inv, -1.0), 1.0)
    prod = (hi - r) * (hi + r) * (r - lo) * (r + lo)
    g = math.atan2(sign * math.sqrt(prod if hi - r > STRETCH_SNAP and r - lo > STRETCH_SNAP else 0.0) * inv, cos_g)
    A1 = math.atan2(py, px) - math.atan2(L2 * math.sin(g), L1 + L2 * math.cos(g))
    T1, T2 = A1 - a1, A1 + g - a2
    theta = [T1 - c0, T2 - T1 - c1, Theta3 - T2 - c2]
    if j >= 0:
        theta.insert(j, v)
    return theta, r, lo, hi


def wrap_one(arm: Arm, theta: list[float]) -> tuple[list[float], list[float]]:
    """:func:`wrap_to_limits` of one posture in floats."""
    wrapped, violation = [], []
    pi, turn = math.pi, 2.0 * math.pi
    for t, (lower, upper, mid) in zip(theta, arm_floats(arm).limits, strict=True):
        t = mid + (t - mid + pi) % turn - pi
        beyond = max(lower - t, t - upper) - LIMIT_SLACK
        wrapped.append(t)
        violation.append(beyond if beyond >= 0.0 else 0.0)
    return wrapped, violation


def floats2(d: list[Array]) -> list[tuple[float, float]]:
    """The link vectors of :func:`link_vectors` as pairs of floats."""
    return [(float(v[0]), float(v[1])) for v in d]


class ArmFloats(NamedTuple):
    """What a one-target solve needs of an arm, as floats: :func:`link_vectors` (``links``, ``beta``), the joints'
    ``zero_offset`` and each joint's ``(lower, upper, middle)`` of its range [m, rad], and a 3-joint arm's chain or
    a ``fixed_joint`` arm's at its rule's value (``own``, :class:`Reduced`); ``mount``: ``cos`` and ``sin`` of
    ``-mount_yaw``, the mount's ``x``, ``y`` and ``mount_yaw``."""

    links: list[tuple[float, float]]
    beta: float
    offsets: tuple[float, ...]
    limits: tuple[tuple[float, float, float], ...]
    chain: ArmChain
    wafer_height: float
    own: Reduced | None
    mount: tuple[float, float, float, float, float]


class ArmChain(NamedTuple):
    """The constants of an arm's chain on the platform (:func:`~gpr_kinematics.robot.forward.platform_to_blade_one`):
    the mount's ``x``, ``y`` and the blade's height ``z`` (the mount, the links, the blade), the ``mount_yaw``, each
    joint's ``(length, zero_offset)``, the blade's ``(x, y)`` and ``yaw`` and the ``wafer_centre`` [m, rad]."""

    x: float
    y: float
    z: float
    mount_yaw: float
    links: tuple[tuple[float, float], ...]
    blade: tuple[float, float]
    blade_yaw: float
    wafer_centre: tuple[float, float, float]


#: :func:`arm_floats` per arm, keyed by ``id`` (the arm held with it, so the key is never reused while it is here).
_ARM_FLOATS: dict[int, tuple[Arm, ArmFloats]] = {}


def arm_floats(arm: Arm) -> ArmFloats:
    """The :class:`ArmFloats` of ``arm``, computed once per arm (an arm is immutable): the one-station paths call
    this per target, where converting the link vectors again cost a third of the arm's closed-form solve."""
    held = _ARM_FLOATS.get(id(arm))
    if held is not None and held[0] is arm:
        return held[1]
    d, beta = link_vectors(arm)
    m, b = arm.mount_position, arm.blade
    chain = ArmChain(m[0], m[1], m[2] + sum(j.height for j in arm.joints) + b.position[2], arm.mount_yaw,
                     tuple((j.length, j.zero_offset) for j in arm.joints), (b.position[0], b.position[1]), b.yaw,
                     (b.wafer_centre[0], b.wafer_centre[1], b.wafer_centre[2]))
    links, red, own = floats2(d), arm.redundancy, None
    if len(links) == 3 or red is not None and red.rule == 'fixed_joint':   # the rule's own held value
        own = reduce_one(links, beta, -1, 0.0) if red is None else reduce_one(
            links, beta, red.joint, red.value + arm.joints[red.joint].zero_offset)
    out = ArmFloats(links, beta, tuple(joint.zero_offset for joint in arm.joints),
                    tuple((j.lower, j.upper, 0.5 * (j.lower + j.upper)) for j in arm.joints), chain,
                    arm.wafer_height, own, (math.cos(-arm.mount_yaw), math.sin(-arm.mount_yaw), m[0], m[1],
                                            arm.mount_yaw))
    if len(_ARM_FLOATS) >= 256:  # robots loaded and dropped in a long process: start again
        _ARM_FLOATS.clear()
    _ARM_FLOATS[id(arm)] = (arm, out)
    return out

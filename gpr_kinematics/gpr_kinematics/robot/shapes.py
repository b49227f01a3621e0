"""The shapes of the robot model's links and their inertia (no ROS import).

A :class:`Visual` is a primitive (box, cylinder, sphere) placed in a link frame: what a URDF draws (``<visual>``) and
what it collides with (``<collision>``). :func:`default_inertial` gives a link the mass and inertia of its drawn shapes
filled with a material (:data:`DENSITY`), the URDF's ``<inertial>`` where the robot description gives no masses:
``m = rho V``; about the shape's centre, in its axes, per unit mass, a box ``(b^2 + c^2, a^2 + c^2, a^2 + b^2) / 12``,
a cylinder (radius r, length h along z) ``((3 r^2 + h^2) / 12, (3 r^2 + h^2) / 12, r^2 / 2)``, a sphere ``2 r^2 / 5``;
the shapes of a link combined about their common centre of mass by the parallel axis theorem
``I = sum_i (R_i I_i R_i^T + m_i (|d_i|^2 E - d_i d_i^T))``. SI units (m, kg).

:func:`robot_shapes` places the collision bodies that :mod:`gpr_kinematics.robot.collision` defines in their frames:
one source for the URDF's ``<collision>`` elements, the clearance check and the markers.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..core.rotations import rpy_matrix
from .collision import GprBodies, Shape, WaferShape

if TYPE_CHECKING:
    from .description import Arm, RobotDescription

#: Density [kg/m^3] of a link's drawn shapes for its default inertia (aluminium; the wafer has its own mass).
DENSITY = 2700.0


@dataclass(frozen=True)
class Visual:
    """A primitive shape of a link: ``box`` (size x y z), ``cylinder`` (radius, length along z), ``sphere``
    (radius) [m], placed at ``xyz`` [m] / ``rpy`` [rad] in the link frame, colour RGBA in [0, 1]."""

    shape: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    material: str = 'grey'
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.6, 1.0)


@dataclass(frozen=True)
class Inertial:
    """Mass [kg] and inertia tensor about the centre of mass ``xyz`` [m], in the link's axes [kg m^2]."""

    mass: float
    xyz: tuple[float, float, float]
    inertia: tuple[float, float, float, float, float, float]   # ixx, ixy, ixz, iyy, iyz, izz


def _solid(v: Visual) -> tuple[float, np.ndarray]:
    """Volume [m^3] and inertia per unit mass about the shape's centre, in its own axes (3 x 3) [m^2]."""
    if v.shape == 'box':
        a, b, c = v.size
        return a * b * c, np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) / 12.0
    if v.shape == 'cylinder':
        r, h = v.size[0], v.size[1]
        return math.pi * r * r * h, np.diag([(3 * r * r + h * h) / 12.0] * 2 + [r * r / 2.0])
    r = v.size[0]
    return 4.0 / 3.0 * math.pi * r ** 3, np.eye(3) * 0.4 * r * r


def default_inertial(visuals: Sequence[Visual]) -> Inertial | None:
    """The inertia of a link's drawn shapes filled with aluminium (:data:`DENSITY`),
    about their common centre of mass (parallel axis theorem): what the URDF gives a link when the robot description
    gives no masses. None for a link without shapes (the world)."""
    parts = []
    for v in visuals:
        volume, unit = _solid(v)
        mass = volume * DENSITY
        R = rpy_matrix(*v.rpy)
        parts.append((mass, np.asarray(v.xyz, dtype=float), mass * (R @ unit @ R.T)))
    total = sum(m for m, _, _ in parts)
    if not parts or total <= 0.0:
        return None
    centre = np.sum([mass * at for mass, at, _ in parts], axis=0) / total
    inertia = np.zeros((3, 3))
    for mass, at, own in parts:
        d = at - centre
        inertia += own + mass * (float(d @ d) * np.eye(3) - np.outer(d, d))
    x, y, z = (float(v) for v in centre)
    tensor = tuple(float(inertia[i, j]) for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)))
    return Inertial(float(total), (x, y, z), (tensor[0], tensor[1], tensor[2], tensor[3], tensor[4], tensor[5]))


def arm_shapes(arm: Arm, wafer: WaferShape) -> tuple[Shape, ...]:
    """The links', blade's and wafer's bodies of ``arm`` (:mod:`gpr_kinematics.robot.collision` describes them)."""
    b = arm.bodies
    out = []
    for frame, joint in zip(arm.link_frames, arm.joints, strict=True):
        out.append(Shape(frame, 'box', (joint.length + b.width, b.width, b.thickness),
                         (0.5 * joint.length, 0.0, 0.5 * joint.height)))
    c = arm.blade.wafer_centre
    length = b.paddle[0] if b.paddle[0] > 0.0 else math.hypot(c[0], c[1]) + 0.1
    top = c[2] - 0.5 * wafer.thickness
    yaw = math.atan2(c[1], c[0])
    out.append(Shape(arm.blade_frame, 'box', (length, b.paddle[1], b.paddle[2]),
                     (0.5 * length * math.cos(yaw), 0.5 * length * math.sin(yaw), top - 0.5 * b.paddle[2]),
                     (0.0, 0.0, yaw)))
    out.append(Shape(arm.wafer_frame, 'cylinder', (0.5 * wafer.diameter, wafer.thickness)))
    return tuple(out)


def gpr_shapes(bodies: GprBodies) -> tuple[Shape, ...]:
    """The column on ``gpr_base`` and the platform disc under ``gpr_platform``."""
    return (Shape('gpr_base', 'cylinder', (bodies.column_radius, bodies.column_height),
                  (0.0, 0.0, 0.5 * bodies.column_height)),
            Shape('gpr_platform', 'cylinder', (bodies.platform_radius, bodies.platform_thickness),
                  (0.0, 0.0, -0.5 * bodies.platform_thickness)))


def robot_shapes(robot: RobotDescription) -> tuple[Shape, ...]:
    """Every body of the robot: the GPR's, then each arm's (links, blade, wafer)."""
    out = list(gpr_shapes(robot.bodies))
    for arm in robot.arms:
        out += arm_shapes(arm, robot.wafer)
    return tuple(out)

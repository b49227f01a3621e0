"""The robot's collision geometry and the blade's grip, from the robot description: one source for the URDF's
``<collision>`` elements, the clearance check and the markers.

Every body is a primitive fixed in one frame of the robot (the URDF link of the same name; docs/robot.md,
"Collision geometry"): a **box** given by its full edge lengths ``(x, y, z)`` or a **cylinder** ``(radius, length)``
along its local z, placed at ``xyz`` / ``rpy`` (URDF convention) in that frame. SI units.

* ``gpr_base``: the GPR's column, a cylinder on ``gpr_base`` from ``z = 0`` up to its ``height``;
* ``gpr_platform``: the platform, a disc of ``radius`` and ``thickness`` under the platform plane;
* ``<arm>_link<k>``: a box along the link, from behind joint ``k``'s axis to beyond the next one (``length + width``
  long, ``width`` wide, ``thickness`` thick, centred half way up to the next link);
* ``<arm>_blade``: the paddle, a box from the blade frame's origin along its x axis (``paddle: [length, width,
  thickness]``), its top face under the wafer's bottom face;
* ``<arm>_wafer``: the wafer, a disc of ``diameter`` and ``thickness`` (a 300 mm wafer: 0.300 m, 0.775 mm) centred
  on the wafer frame, its axis that frame's z.

The blade holds the wafer by static friction (``friction``, the coefficient) and, for a vacuum blade, a holding
force ``vacuum`` [N] pressing it on the paddle (docs/cell.md, "Wafer slip").
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..errors import ConfigError
from ..inputs.schema import check_keys
from .fields import _mapping, _number, _positive_number, _vector

#: Defaults: a 300 mm wafer [m, m, kg], a passive blade's friction coefficient.
WAFER_DIAMETER, WAFER_THICKNESS, WAFER_MASS = 0.300, 0.000775, 0.128
FRICTION = 0.3
_SIZE = 5.0  # m: largest body dimension


@dataclass(frozen=True)
class Shape:
    """A collision primitive fixed in ``frame``: ``kind`` box (full edges x, y, z) or cylinder (radius, length along
    its z) [m], at ``xyz`` [m] / ``rpy`` [rad] in the frame."""

    frame: str
    kind: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def radius(self) -> float:
        """Distance from ``xyz`` to the farthest point of the shape [m]."""
        if self.kind == 'box':
            return 0.5 * math.sqrt(sum(v * v for v in self.size))
        return math.hypot(self.size[0], 0.5 * self.size[1])


@dataclass(frozen=True)
class WaferShape:
    """The wafer as a disc: ``diameter``, ``thickness`` [m], ``mass`` [kg] (for a vacuum blade's holding force)."""

    diameter: float = WAFER_DIAMETER
    thickness: float = WAFER_THICKNESS
    mass: float = WAFER_MASS


@dataclass(frozen=True)
class GprBodies:
    """The GPR's bodies: the column (``column_radius``, ``column_height``) and the platform (``platform_radius``,
    ``platform_thickness``) [m]."""

    column_radius: float = 0.14
    column_height: float = 0.12
    platform_radius: float = 0.13
    platform_thickness: float = 0.03


@dataclass(frozen=True)
class ArmBodies:
    """An arm's links (``width``, ``thickness``) and its blade's paddle ``(length, width, thickness)`` [m] (length
    0: up to 0.1 m beyond the wafer centre), with the grip: ``friction`` coefficient, ``vacuum`` force [N]."""

    width: float = 0.06
    thickness: float = 0.025
    paddle: tuple[float, float, float] = (0.0, 0.08, 0.003)
    friction: float = FRICTION
    vacuum: float = 0.0


def _positive(data: Mapping[str, Any], key: str, where: str, default: float, hi: float = _SIZE) -> float:
    return _positive_number(data, key, where, hi, 'm', 'metres', default)


def parse_wafer(raw: Any, where: str) -> WaferShape:
    data = _mapping(raw if raw is not None else {}, where, 'diameter, thickness, mass of the wafer')
    check_keys(data, ('diameter', 'thickness', 'mass'), where)
    return WaferShape(_positive(data, 'diameter', where, WAFER_DIAMETER, 1.0),
                      _positive(data, 'thickness', where, WAFER_THICKNESS, 0.01),
                      _positive_number(data, 'mass', where, 10.0, 'kg', 'kg', WAFER_MASS))


def parse_gpr_bodies(raw: Any, where: str) -> GprBodies:
    data = _mapping(raw if raw is not None else {}, where, 'column: {radius, height}, platform: {radius, thickness}')
    check_keys(data, ('column', 'platform'), where)
    d = GprBodies()
    column = _mapping(data.get('column', {}), f'{where}: column', 'radius and height')
    check_keys(column, ('radius', 'height'), f'{where}: column')
    platform = _mapping(data.get('platform', {}), f'{where}: platform', 'radius and thickness')
    check_keys(platform, ('radius', 'thickness'), f'{where}: platform')
    return GprBodies(_positive(column, 'radius', f'{where}: column', d.column_radius),
                     _positive(column, 'height', f'{where}: column', d.column_height),
                     _positive(platform, 'radius', f'{where}: platform', d.platform_radius),
                     _positive(platform, 'thickness', f'{where}: platform', d.platform_thickness))


def parse_arm_bodies(links: Any, blade: Mapping[str, Any], where: str) -> ArmBodies:
    """The ``links: {width, thickness}`` of an arm and its blade's ``paddle``, ``friction``, ``vacuum``."""
    lw = f'{where}: links'
    data = _mapping(links if links is not None else {}, lw, 'width and thickness of the link bodies')
    check_keys(data, ('width', 'thickness'), lw)
    d = ArmBodies()
    bw = f'{where}: blade'
    paddle = _vector(blade, 'paddle', bw, 3, 1.0, default=d.paddle)
    if paddle[0] < 0.0 or min(paddle[1:]) <= 0.0:
        raise ConfigError(f'{bw}: paddle = {list(paddle)!r} is invalid; allowed: [length >= 0 (0: to 0.1 m beyond '
                          'the wafer centre), width > 0, thickness > 0] in metres')
    return ArmBodies(_positive(data, 'width', lw, d.width, 1.0), _positive(data, 'thickness', lw, d.thickness, 1.0),
                     (paddle[0], paddle[1], paddle[2]),
                     _number(blade, 'friction', bw, 1e-3, 2.0, 'a static friction coefficient, 0.001 to 2',
                             default=FRICTION, unit=''),
                     _number(blade, 'vacuum', bw, 0.0, 1000.0, 'newtons, 0 (a passive blade) to 1000',
                             default=0.0, unit='N'))

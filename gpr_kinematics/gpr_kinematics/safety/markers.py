"""The process cell as a ``visualization_msgs/MarkerArray`` (``gpr/cell`` of ``state_publisher_node``), built
without ROS: :func:`cell_markers` describes one marker per obstacle, :func:`cell_marker_array` builds the message
with any message classes through a ``make(type, **fields)`` factory (as :mod:`gpr_kinematics.robot.markers`).

Each obstacle is a ``CUBE`` (a box: scale = its edges) or a ``CYLINDER`` (scale = diameter, diameter, length), in
the cell's frame, at the obstacle's centre and orientation (quaternion x, y, z, w); namespace the obstacle's name
up to its ``/`` (a chamber's walls share their chamber's), id its index in the cell. Chamber walls are grey and
translucent, the other obstacles blue.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.rotations import quaternion_from_matrix
from .cell import Cell

CUBE, CYLINDER, ADD = 1, 3, 0
WALL_COLOR = (0.6, 0.6, 0.65, 0.45)
OBSTACLE_COLOR = (0.25, 0.45, 0.85, 0.8)


@dataclass(frozen=True)
class CellMarker:
    """One obstacle's marker: namespace, id, type, position [m], quaternion (x, y, z, w), scale [m], RGBA."""

    ns: str
    id: int
    type: int
    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]
    scale: tuple[float, float, float]
    color: tuple[float, float, float, float]


def cell_markers(cell: Cell) -> tuple[CellMarker, ...]:
    """The markers of every obstacle of ``cell`` (module docstring)."""
    out = []
    for i, ob in enumerate(cell.obstacles):
        q = quaternion_from_matrix(np.asarray(ob.rotation)[None])[0]
        if ob.kind == 'box':
            kind, scale = CUBE, (ob.size[0], ob.size[1], ob.size[2])
        else:
            kind, scale = CYLINDER, (2 * ob.size[0], 2 * ob.size[0], ob.size[1])
        ns, _, part = ob.name.partition('/')
        out.append(CellMarker(ns, i, kind, (float(ob.position[0]), float(ob.position[1]), float(ob.position[2])),
                              (float(q[0]), float(q[1]), float(q[2]), float(q[3])),
                              tuple(float(s) for s in scale),  # type: ignore[arg-type]
                              WALL_COLOR if part else OBSTACLE_COLOR))
    return tuple(out)


def cell_marker_array(make: Callable[..., Any], header: Any, cell: Cell) -> Any:
    """``visualization_msgs/MarkerArray`` of ``cell`` with ``header`` (its frame: the cell's); ``make(type_name,
    **fields)`` builds a message of the given type."""
    markers = []
    for m in cell_markers(cell):
        r, g, b, a = m.color
        markers.append(make(
            'visualization_msgs/msg/Marker', header=header, ns=m.ns, id=m.id, type=m.type, action=ADD,
            pose=make('geometry_msgs/msg/Pose', position=make('geometry_msgs/msg/Point', x=m.position[0],
                                                              y=m.position[1], z=m.position[2]),
                      orientation=make('geometry_msgs/msg/Quaternion', x=m.orientation[0], y=m.orientation[1],
                                       z=m.orientation[2], w=m.orientation[3])),
            scale=make('geometry_msgs/msg/Vector3', x=m.scale[0], y=m.scale[1], z=m.scale[2]),
            color=make('std_msgs/msg/ColorRGBA', r=r, g=g, b=b, a=a),
            lifetime=make('builtin_interfaces/msg/Duration', sec=0, nanosec=0), frame_locked=False))
    return make('visualization_msgs/msg/MarkerArray', markers=markers)

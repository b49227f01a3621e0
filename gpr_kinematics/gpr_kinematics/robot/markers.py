"""The ``gpr/markers`` MarkerArray of one stream sample: what it draws, in one description for builder and check.

Four markers in the base frame (``header`` of the sample's PlatformState, identity marker pose), their points:

====  ====================  ==============  ========================================================
 id   ns                    type            points
====  ====================  ==============  ========================================================
 0    ``base``              LINE_STRIP      the rod feet ``P_k(q = 0)``, k = 1, 2, 3, 1
 1    ``rods``              LINE_LIST       foot and top of each rod: ``P_k(0), P_k(q)``, k = 1, 2, 3
 2    ``platform``          TRIANGLE_LIST   the joint centres ``P_k(q)`` (the platform triangle)
 3    ``nominal_platform``  LINE_STRIP      the naive model's outline ``p_n + R_n r_k``, k = 1, 2, 3, 1
====  ====================  ==============  ========================================================

``P_k(q) = B_k + (q_k + o_k) u_k`` are the joint centres of :func:`gpr_kinematics.core.base_points` on the
machine of the configuration (:class:`~gpr_kinematics.core.machine.MachineGeometry`: base points, zero offsets, rod
directions; ``P_k(0)`` is where rod ``k`` stands); ``r_k = p_k`` are the platform joints at their places on the
platform (``MachineGeometry.platform_points``: the nominal ``R (cos theta_k, sin theta_k, 0)``, or the
configuration's ``platform_joints``), ``p_n`` and ``R_n`` the naive pose: the outline is where the naive model puts
the platform's joints. :func:`marker_points` computes them for a
batch; :func:`marker_array` builds the message with any message classes (rclpy's or the ``rosbags``
typestore's, through a ``make(type, **fields)`` factory), and ``gpr verify`` checks recorded markers against
:func:`marker_points` of the PlatformState with the same stamp. A stream has markers for the samples :func:`marked`
says (``trajectory_node``'s ``markers_every``, within :data:`MARKERS_EVERY`).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import base_points
from ..core.config import GprConfig
from ..core.machine import MachineGeometry

LINE_STRIP, LINE_LIST, TRIANGLE_LIST, ADD = 4, 5, 11, 0
#: The cadences of the markers, ``markers_every`` (``trajectory_node``'s parameter, a stream's record).
MARKERS_EVERY = (1, 100000)


@dataclass(frozen=True)
class MarkerSpec:
    """One marker of the array: id, namespace, type, line width [m] (1 for triangles) and RGBA colour."""

    id: int
    ns: str
    type: int
    width: float
    color: tuple[float, float, float, float]


MARKERS: tuple[MarkerSpec, ...] = (
    MarkerSpec(0, 'base', LINE_STRIP, 0.004, (0.5, 0.5, 0.5, 1.0)),
    MarkerSpec(1, 'rods', LINE_LIST, 0.008, (0.2, 0.4, 0.9, 1.0)),
    MarkerSpec(2, 'platform', TRIANGLE_LIST, 1.0, (0.95, 0.55, 0.1, 0.8)),
    MarkerSpec(3, 'nominal_platform', LINE_STRIP, 0.002, (0.1, 0.8, 0.2, 1.0)),
)


def marked(sample: Any, every: Any) -> Any:
    """Whether the sample with counter ``sample`` has its markers in a stream with ``markers_every = every``:
    ``sample % every == 0`` (the counter runs on over loops and streams), for numbers or arrays.

    >>> marked(6, 3), marked(7, 3), marked(0, 1)
    (True, False, True)
    """
    return sample % every == 0


def marker_points(cfg: GprConfig, q: NDArray[np.float64], nominal_position: NDArray[np.float64],
                  nominal_rotation: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    """Points [m, base frame] of every marker, by namespace, ``(N, k, 3)``, for rod lengths ``q (N, 3)`` and the
    naive poses ``nominal_position (N, 3)``, ``nominal_rotation (N, 3, 3)``."""
    q = np.asarray(q, dtype=float).reshape(-1, 3)
    tops = base_points(q, cfg)
    feet = base_points(np.zeros_like(q), cfg)
    joints = MachineGeometry.of(cfg).platform_points()
    corners = np.asarray(nominal_position, dtype=float)[:, None, :] + np.einsum('kj,nij->nki', joints,
                                                                                 nominal_rotation)
    loop = [0, 1, 2, 0]
    return {
        'base': feet[:, loop],
        'rods': np.stack([feet, tops], axis=2).reshape(len(q), 6, 3),
        'platform': tops,
        'nominal_platform': corners[:, loop],
    }


def marker_array(make: Callable[..., Any], header: Any, points: dict[str, NDArray[np.float64]]) -> Any:
    """``visualization_msgs/MarkerArray`` of one sample: ``points[ns]`` ``(k, 3)`` per marker of :data:`MARKERS`;
    ``make(type_name, **fields)`` builds a message of the given type (fields not given keep their defaults)."""
    markers = []
    for spec in MARKERS:
        pts = [make('geometry_msgs/msg/Point', x=float(x), y=float(y), z=float(z)) for x, y, z in points[spec.ns]]
        scale = (1.0, 1.0, 1.0) if spec.type == TRIANGLE_LIST else (spec.width, 0.0, 0.0)
        r, g, b, a = spec.color
        markers.append(make(
            'visualization_msgs/msg/Marker', header=header, ns=spec.ns, id=spec.id, type=spec.type, action=ADD,
            pose=make('geometry_msgs/msg/Pose', position=make('geometry_msgs/msg/Point', x=0.0, y=0.0, z=0.0),
                      orientation=make('geometry_msgs/msg/Quaternion', x=0.0, y=0.0, z=0.0, w=1.0)),
            scale=make('geometry_msgs/msg/Vector3', x=scale[0], y=scale[1], z=scale[2]),
            color=make('std_msgs/msg/ColorRGBA', r=r, g=g, b=b, a=a),
            lifetime=make('builtin_interfaces/msg/Duration', sec=0, nanosec=0), points=pts))
    return make('visualization_msgs/msg/MarkerArray', markers=markers)

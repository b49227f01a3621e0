"""RViz markers of one sample of the platform stream (``gpr/markers``, visualization_msgs/MarkerArray).

All in the base frame ``gpr_base`` [m]: the ``base`` triangle through the rod feet
``(R cos theta_k, R sin theta_k, 0)``, the ``rods`` from foot to joint centre, the ``platform`` triangle through
the joint centres ``P_k = (R cos theta_k, R sin theta_k, q_k)`` and the naive platform's outline
``nominal_platform`` (the nominal joint triangle moved by the naive pose).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ..config import GprConfig


def rod_feet(cfg: GprConfig) -> np.ndarray:
    """(3, 3) rod feet in ``gpr_base`` [m] (the nominal joint triangle in ``gpr_platform`` has the same x, y)."""
    theta = np.asarray(cfg.rod_azimuths, dtype=float)
    return np.stack([cfg.radius * np.cos(theta), cfg.radius * np.sin(theta), np.zeros(3)], -1)


def _color(r: float, g: float, b: float, a: float = 1.0) -> ColorRGBA:
    return ColorRGBA(r=r, g=g, b=b, a=a)


def _marker(header: Any, mid: int, ns: str, mtype: int, width: float, color: ColorRGBA,
            points: Sequence[Sequence[float]]) -> Marker:
    m = Marker()
    m.header = header
    m.ns = ns
    m.id = mid
    m.type = mtype
    m.action = Marker.ADD
    m.pose.orientation.w = 1.0
    m.scale.x = width
    if mtype == Marker.TRIANGLE_LIST:
        m.scale.x = m.scale.y = m.scale.z = 1.0
    m.color = color
    m.lifetime = Duration(sec=0, nanosec=0)
    m.points = [Point(x=float(a), y=float(b), z=float(c)) for a, b, c in points]
    return m


def platform_markers(feet: np.ndarray, q: np.ndarray, nominal_position: np.ndarray, nominal_rotation: np.ndarray,
                     header: Any) -> MarkerArray:
    """The four markers of one sample: rod lengths ``q`` (3,) [m] and the naive pose (position, rotation)."""
    tops = feet.copy()
    tops[:, 2] = q
    nominal = (nominal_position + feet @ np.asarray(nominal_rotation).T).tolist()
    foot, top = feet.tolist(), tops.tolist()
    rods = [p for k in range(3) for p in (foot[k], top[k])]
    return MarkerArray(markers=[
        _marker(header, 0, 'base', Marker.LINE_STRIP, 0.004, _color(0.5, 0.5, 0.5), foot + foot[:1]),
        _marker(header, 1, 'rods', Marker.LINE_LIST, 0.008, _color(0.2, 0.4, 0.9), rods),
        _marker(header, 2, 'platform', Marker.TRIANGLE_LIST, 1.0, _color(0.95, 0.55, 0.1, 0.8), top),
        _marker(header, 3, 'nominal_platform', Marker.LINE_STRIP, 0.002, _color(0.1, 0.8, 0.2),
                nominal + nominal[:1]),
    ])

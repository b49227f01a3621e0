"""A test mechanism with a closed-form workspace volume: a two-link arm above a floor."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import ConfigError
from .base import WorkspaceModel, check_parameters
from .interval import Interval, norm

_INF = np.inf


class ShellArmModel(WorkspaceModel):
    """Test mechanism with a closed-form workspace: a two-link arm with a spherical shoulder at the origin
    (upper arm ``l1``, forearm ``l2``, elbow revolute, no joint limits) above a floor ``z >= floor``.

    The wrist reaches exactly the shell ``|l1 - l2| <= |P| <= l1 + l2``; with the floor the volume is
    ``cap(l1 + l2) - cap(|l1 - l2|)``, ``cap(rho) = pi (rho - h)^2 (2 rho + h) / 3`` for the part of a ball of
    radius ``rho`` above the plane ``z = h`` (``|h| <= rho``; 0 above, the whole ball below).
    """

    name = 'shell_arm'
    variables = ('x', 'y', 'z')
    units = ('m', 'm', 'm')

    def __init__(
        self, l1: float = 0.3, l2: float = 0.2, floor: float = -0.1, box: np.ndarray | None = None
    ) -> None:
        check_parameters(self.name, {'l1': l1, 'l2': l2}, None if floor == -math.inf else {'floor': floor})
        if l1 <= 0 or l2 <= 0:
            raise ConfigError('shell_arm needs positive l1, l2 (m)')
        self.l1, self.l2, self.floor = float(l1), float(l2), float(floor)
        reach = self.l1 + self.l2
        self.box = np.array(box if box is not None else [[-reach, reach]] * 3)
        self.scale = np.ones(3)
        self.constraint_names = ('reach', 'floor')
        self.lower = np.array([abs(self.l1 - self.l2), self.floor])
        self.upper = np.array([reach, _INF])

    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        px, py, pz = x
        return [norm(px, py, pz), pz]

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        return np.stack([np.linalg.norm(p, axis=1), p[:, 2]], axis=1)

    def exact_volume(self) -> float:
        def cap(rho: float, h: float) -> float:
            if h >= rho:
                return 0.0
            if h <= -rho:
                return 4.0 / 3.0 * math.pi * rho**3
            return math.pi * (rho - h) ** 2 * (2 * rho + h) / 3.0

        return cap(self.l1 + self.l2, self.floor) - cap(abs(self.l1 - self.l2), self.floor)

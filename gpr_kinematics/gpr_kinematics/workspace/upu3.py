"""The translational 3-UPU of Aboulissane and El Bakkali ("Modeling and Simulation of Spatial Mechanism", CPI 2015;
docs/references.md) as a workspace model."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import ConfigError
from ..mechanisms.upu3 import check_azimuths
from .base import WorkspaceModel, check_parameters
from .interval import Interval, norm

_INF = np.inf


class Upu3Model(WorkspaceModel):
    """Translational 3-UPU (Aboulissane and El Bakkali, "Modeling and Simulation of Spatial Mechanism", 2015):
    base joints ``B_i = b u_i``, platform joints ``P + p u_i`` (same azimuths), limb
    ``l_i = |P + p u_i - b u_i|`` in ``[limb_min, limb_max]``. The three azimuths must be distinct modulo 2 pi
    (:func:`~gpr_kinematics.mechanisms.upu3.check_azimuths`, the mechanism's check).

    The paper places the base triangle in its yz plane (its x axis normal to the base); here the base is the
    xy plane with z up (REP 103), so the paper's x is our z. The shapes (an upper dome over a lower one,
    Figs. 7-9) are the same. Only the half-space above the base is kept (the box starts at z = 0).
    """

    name = 'upu3'
    variables = ('x', 'y', 'z')
    units = ('m', 'm', 'm')

    def __init__(self, b: float = 0.2, p: float = 0.17, limb_min: float = 0.17, limb_max: float = 0.27,
                 azimuths: Sequence[float] = (math.pi / 2, 7 * math.pi / 6, 11 * math.pi / 6),
                 box: np.ndarray | None = None) -> None:
        check_parameters(self.name, {'b': b, 'p': p, 'limb_min': limb_min, 'limb_max': limb_max},
                         {f'azimuths[{i}]': a for i, a in enumerate(azimuths)})
        if b <= 0 or p <= 0 or not 0 < limb_min < limb_max:
            raise ConfigError('upu3 needs b > 0, p > 0 and 0 < limb_min < limb_max (m)')
        self.b, self.p, self.limb_min, self.limb_max = float(b), float(p), float(limb_min), float(limb_max)
        self.azimuths = check_azimuths(azimuths, 'upu3: azimuths')
        self.centres = (self.b - self.p) * np.stack(
            [np.cos(self.azimuths), np.sin(self.azimuths), np.zeros(3)], axis=1
        )
        reach = self.limb_max + abs(self.b - self.p)
        self.box = np.array(
            box if box is not None else [[-reach, reach], [-reach, reach], [0.0, self.limb_max]]
        )
        self.scale = np.ones(3)
        self.constraint_names = ('l1', 'l2', 'l3')
        self.lower = np.full(3, self.limb_min)
        self.upper = np.full(3, self.limb_max)

    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        px, py, pz = x
        return [norm(px - float(c[0]), py - float(c[1]), pz) for c in self.centres]

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        return np.asarray(np.linalg.norm(p[:, None, :] - self.centres[None], axis=2))

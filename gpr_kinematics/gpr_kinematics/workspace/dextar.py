"""DexTAR, the five-bar of Posypkin et al. (eqs. (1); docs/references.md), in its closed-form two-dimensional form."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import ConfigError
from .base import WorkspaceModel, check_parameters
from .interval import Interval, norm

_INF = np.inf


class DextarModel(WorkspaceModel):
    """DexTAR five-bar, eqs. (1) of Posypkin et al.: ``x = la cos q1 + lb cos q3 + d/2``,
    ``y = la sin q1 + lb sin q3`` and ``x = -d/2 + ld cos q2 + lc cos q4``, ``y = ld sin q2 + lc sin q4``.

    DexTAR's joints turn without limits (its arms pass each other), so eliminating the passive angles q3,
    q4 and the inputs q1, q2 leaves: ``(x, y)`` is reachable iff ``|la - lb| <= |P - A1| <= la + lb`` and
    ``|ld - lc| <= |P - A2| <= ld + lc`` with ``A1 = (d/2, 0)``, ``A2 = (-d/2, 0)``: the paper's "lowered
    dimension" form, 2-D instead of its 6-D boxes. Its area has a closed form (:meth:`exact_area`).
    The paper gives no DexTAR dimensions; the defaults are illustrative (see docs/workspace.md).
    """

    name = 'dextar'
    variables = ('x', 'y')
    units = ('m', 'm')

    def __init__(
        self,
        la: float = 0.2,
        lb: float = 0.2,
        lc: float = 0.2,
        ld: float = 0.2,
        d: float = 0.2,
        box: np.ndarray | None = None,
    ) -> None:
        check_parameters(self.name, {'la': la, 'lb': lb, 'lc': lc, 'ld': ld}, {'d': d})
        if min(la, lb, lc, ld) <= 0 or d < 0:
            raise ConfigError('dextar needs positive link lengths la, lb, lc, ld and d >= 0 (m)')
        self.la, self.lb, self.lc, self.ld, self.d = (float(v) for v in (la, lb, lc, ld, d))
        reach = max(la + lb, lc + ld) + d / 2
        self.box = np.array(box if box is not None else [[-reach, reach], [-reach, reach]])
        self.scale = np.ones(2)
        self.constraint_names = ('arm1', 'arm2')
        self.lower = np.array([abs(la - lb), abs(ld - lc)])
        self.upper = np.array([la + lb, ld + lc])

    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        px, py = x
        return [norm(px - 0.5 * self.d, py), norm(px + 0.5 * self.d, py)]

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        return np.stack(
            [np.hypot(p[:, 0] - self.d / 2, p[:, 1]), np.hypot(p[:, 0] + self.d / 2, p[:, 1])], axis=1
        )

    def exact_area(self) -> float:
        """Closed-form area [m^2]: annulus ∩ annulus by inclusion-exclusion of disc-disc lens areas."""
        ro1, ri1 = self.la + self.lb, abs(self.la - self.lb)
        ro2, ri2 = self.ld + self.lc, abs(self.ld - self.lc)
        lens = _lens_area
        return (
            lens(ro1, ro2, self.d) - lens(ro1, ri2, self.d) - lens(ri1, ro2, self.d) + lens(ri1, ri2, self.d)
        )


def _lens_area(r1: float, r2: float, d: float) -> float:
    """Area of the intersection of two discs of radii r1, r2 whose centres are d apart."""
    if r1 <= 0 or r2 <= 0 or d >= r1 + r2:
        return 0.0
    if d <= abs(r1 - r2):
        return math.pi * min(r1, r2) ** 2
    # next to a tangency (d within rounding of r1 + r2 or |r1 - r2|) the cosines round beyond +-1 and the product
    # below 0 (math.acos raised 'math domain error' for la, lb, lc, ld, d = 0.05, 0.1, 0.15, 0.4, 0.6): clamped
    c1 = min(max((d * d + r1 * r1 - r2 * r2) / (2 * d * r1), -1.0), 1.0)
    c2 = min(max((d * d + r2 * r2 - r1 * r1) / (2 * d * r2), -1.0), 1.0)
    a1 = r1 * r1 * math.acos(c1)
    a2 = r2 * r2 * math.acos(c2)
    a3 = 0.5 * math.sqrt(max((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2), 0.0))
    return a1 + a2 - a3

"""The data of ``gpr accuracy --plot`` (no matplotlib; :mod:`.plot` draws it): for the first stations of a budget
(at most :data:`MAX_STATIONS`) and each quantity drawn, the histogram of the Monte Carlo's error magnitudes ``|v|``
(the very samples the report's percentiles summarise, :attr:`~.budget.Budget.kept`) and the report's numbers as
lines: the linearised worst case and RSS and the Monte Carlo percentiles.

Lengths are drawn in um and angles in urad (the report's units); the data are in metres and radians. The
histogram has :data:`BINS` equal bins from 0 to the largest sample (the worst case, usually far beyond the samples,
is a line past them).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from .budget import QUANTITIES, Budget

Array = NDArray[np.float64]

#: Stations drawn, the first ones (a row of panels each).
MAX_STATIONS = 4
#: Bins of each histogram.
BINS = 40
#: The platform's quantities, always drawn; the tool point's are drawn where it is not the platform origin.
PLATFORM = ('platform_horizontal', 'platform_vertical', 'tilt', 'heading')
TOOL = ('tool_horizontal', 'tool_vertical')


@dataclass(frozen=True)
class Panel:
    """One quantity of one station: ``counts`` ``(BINS,)`` of the samples in the bins ``edges`` ``(BINS + 1,)``
    [m or rad], the ``samples`` it counts (sorted), and ``lines``: ``(name, value)`` of the worst case, the RSS and
    each percentile (``p95``), the values the report prints [m or rad]."""

    quantity: str
    unit: str
    counts: NDArray[np.int64]
    edges: Array
    samples: Array
    lines: tuple[tuple[str, float], ...]


@dataclass(frozen=True)
class BudgetPlot:
    """What ``gpr accuracy --plot`` draws: ``stations`` the labels of the stations drawn, ``panels`` per station
    one :class:`Panel` per quantity, ``total`` the budget's number of stations, ``samples`` and ``seed`` of the
    Monte Carlo, ``frame`` the axes of the errors."""

    stations: tuple[str, ...]
    panels: tuple[tuple[Panel, ...], ...]
    total: int
    samples: int
    seed: int
    frame: str


def budget_plot(b: Budget) -> BudgetPlot:
    """The plot's data of the budget ``b`` (module docstring), made with its samples kept for the first
    ``min(N, MAX_STATIONS)`` stations (``keep_samples``); the tool point's quantities where any station's tool point
    is not the platform origin.

    Raises:
        InputError: a budget without Monte Carlo samples, or without the samples kept.
    """
    if not b.samples:
        raise InputError('the accuracy budget\'s plot draws the Monte Carlo\'s samples, and this budget has none; '
                         'allowed: a budget with samples >= 1')
    shown = min(len(b.labels), MAX_STATIONS)
    names = PLATFORM + (TOOL if np.any(b.tool[:shown] != 0.0) else ())
    if any(name not in b.kept or b.kept[name].shape != (b.samples, shown) for name in names):
        raise InputError(f'the accuracy budget\'s plot needs the Monte Carlo\'s samples of the first {shown} '
                         f'station(s); allowed: a budget made with keep_samples >= {shown}')
    panels = []
    for i in range(shown):
        row = []
        for name in names:
            x = np.sort(b.kept[name][:, i])
            counts, edges = np.histogram(x, bins=BINS, range=(0.0, float(x[-1]) if x[-1] > 0 else 1e-12))
            lines = (('worst', float(b.worst[name][i])), ('RSS', float(b.rss[name][i])),
                     *((f'p{p:g}', float(b.mc[name][i, k])) for k, p in enumerate(b.percentiles)))
            row.append(Panel(name, QUANTITIES[name][1], counts.astype(np.int64), edges, x, lines))
        panels.append(tuple(row))
    return BudgetPlot(b.labels[:shown], tuple(panels), len(b.labels), b.samples, b.seed, b.frame)

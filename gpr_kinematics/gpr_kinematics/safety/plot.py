"""``gpr program check --plot``: the certified clearance and the slip ratio against time, the margin and the limit
drawn (matplotlib).

The clearance curve is, on each interval of the base sampling, the certified lower bound of every pair's distance
there (the smallest over all pairs of the branch and bound's final bounds): the true clearance is never below it,
and it is within the pairs' tolerance of the truth where a pair comes closest (far from that, the bound may lie
lower than the truth, as a proof needs no more). Values beyond the plot's top are drawn at the top.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .check import SafetyReport
from .clearance import ClearanceReport

#: Top of the clearance axis [mm].
TOP_MM = 60.0


def plot_check(path: str | Path, clear: ClearanceReport, slip: tuple[NDArray[np.float64], NDArray[np.float64]],
               report: SafetyReport) -> Path:
    """Write the figure to ``path`` (PNG, atomically) and return it."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from ..inputs.files import atomic_output

    t, bound = clear.series
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    if t.size > 1:
        shown = np.clip(np.where(np.isfinite(bound), bound * 1e3, TOP_MM), None, TOP_MM)
        ax1.stairs(shown, t, baseline=None, lw=1, label='certified clearance (lower bound over all pairs)')
    ax1.axhline(clear.margin * 1e3, color='r', lw=1, label=f'margin {clear.margin * 1e3:g} mm')
    ax1.axhline(clear.min_clearance * 1e3, color='k', ls=':', lw=1,
                label=f'minimum {clear.min_clearance * 1e3:.2f} mm')
    ax1.set_ylabel('clearance [mm]')
    ax1.set_ylim(min(0.0, clear.min_clearance * 1e3 - 1), TOP_MM * 1.02)
    ax1.legend(loc='upper right', fontsize=8)
    ax2.plot(slip[0], slip[1], lw=1, label='slip ratio of the carried wafer')
    ax2.axhline(1.0, color='r', lw=1, label='slips at 1')
    ax2.set_ylabel('slip ratio')
    ax2.set_ylim(0.0, max(1.1, float(np.max(slip[1], initial=0.0)) * 1.05))
    ax2.set_xlabel('time [s]')
    ax2.legend(loc='upper right', fontsize=8)
    where = Path(report.cell).name if report.cell else 'no cell'
    fig.suptitle(f'{where}: {"safe" if report.safe else "NOT safe"}', fontsize=10)
    with atomic_output(path, 'plot', binary=True) as out:
        fig.savefig(out, format='png', dpi=110)
    plt.close(fig)
    return Path(path)

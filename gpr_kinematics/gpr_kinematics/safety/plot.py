"""``gpr program check --plot``: clearance and slip ratio against time, the margin drawn (matplotlib)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .clearance import ClearanceReport


def plot_check(path: str | Path, clear: ClearanceReport, slip: tuple[NDArray[np.float64], NDArray[np.float64]],
               report: Any) -> Path:
    """Write the figure to ``path`` (PNG, atomically) and return it."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from ..inputs.files import atomic_output

    t, d = clear.series
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    ok = np.isfinite(d)
    ax1.plot(t[ok], d[ok] * 1e3, '.', ms=2, label='smallest distance measured (any pair)')
    ax1.axhline(clear.margin * 1e3, color='r', lw=1, label=f'margin {clear.margin * 1e3:g} mm')
    ax1.axhline(clear.min_clearance * 1e3, color='k', ls=':', lw=1,
                label=f'certified minimum {clear.min_clearance * 1e3:.2f} mm')
    ax1.set_ylabel('clearance [mm]')
    ax1.set_ylim(min(0.0, clear.min_clearance * 1e3 - 1), 60)
    ax1.legend(loc='upper right', fontsize=8)
    ax2.plot(slip[0], slip[1], lw=1, label='slip ratio of the carried wafer')
    ax2.axhline(1.0, color='r', lw=1, label='slips at 1')
    ax2.set_ylabel('slip ratio')
    ax2.set_xlabel('time [s]')
    ax2.legend(loc='upper right', fontsize=8)
    fig.suptitle(f'{Path(str(report.cell or "no cell")).name}: {"safe" if report.safe else "NOT safe"}', fontsize=10)
    with atomic_output(path, 'plot', binary=True) as out:
        fig.savefig(out, format='png', dpi=110)
    plt.close(fig)
    return Path(path)

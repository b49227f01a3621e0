"""``gpr calibrate --plot``: the residuals of every measurement before and after the calibration against the noise
the gate judges them by, and the fitted parameters' change in standard errors (matplotlib, imported lazily; the
data: :func:`~.residual_plot.residual_plot`)."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .residual_plot import Kind, ResidualPlot

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def _noise_label(k: Kind, unit: str) -> str:
    lo, hi = float(np.min(k.sigma)) * 1e6, float(np.max(k.sigma)) * 1e6
    sigma = f'{lo:.3g} {unit}' if np.isclose(lo, hi) else f'{lo:.3g}-{hi:.3g} {unit}'
    what = 'declared' if k.origin == 'declared' else k.origin if k.origin.startswith('the file') else \
        f'assumed, {k.origin}' if k.origin != 'assumed' else 'assumed (not declared)'
    return f'noise: sqrt(3) sigma, sigma {sigma} per coordinate\n({what})'


def _residual_panel(ax: Axes, data: ResidualPlot, k: Kind, what: str, unit: str) -> None:
    x = data.rows
    ax.plot(x, k.before * 1e6, 'o', ms=4, mfc='none', color='tab:red',
            label=f'nominal geometry (before): RMS {k.rms_before * 1e6:.3g} {unit}')
    ax.plot(x, k.after * 1e6, 's', ms=4, color='tab:blue',
            label=f'calibrated geometry (after): RMS {k.rms_after * 1e6:.3g} {unit}')
    ax.step(x, k.noise * 1e6, where='mid', color='k', lw=1, ls='--', label=_noise_label(k, unit))
    worst = int(np.argmax(k.after))
    ax.annotate(data.names[worst], (float(x[worst]), float(k.after[worst] * 1e6)), xytext=(4, 4),
                textcoords='offset points', fontsize=7, color='tab:blue')
    if k.log:
        ax.set_yscale('log')
    else:
        ax.set_ylim(0.0, None)
    ax.set_ylabel(f'{what} residual [{unit}]')
    ax.grid(True, lw=0.3)
    ax.legend(loc='upper left', bbox_to_anchor=(1.01, 1.0), fontsize=7)


def _parameter_panel(ax: Axes, data: ResidualPlot) -> None:
    ax.bar(np.arange(len(data.z)), data.z, color=np.where(np.abs(data.z) > 3, 'tab:orange', 'tab:gray'))
    for level in (-3.0, 3.0):
        ax.axhline(level, color='k', lw=0.8, ls=':')
    ax.axhline(0.0, color='k', lw=0.6)
    ax.set_xticks(np.arange(len(data.z)), data.parameters, rotation=90, fontsize=7)
    ax.set_xlim(-0.6, len(data.z) - 0.4)
    ax.set_ylabel('change from nominal\n/ standard error [1]')
    kappa = ' (a kappa in its anisotropy (kappa-1)/(kappa+1))' if any(n.startswith('kappa') for n in data.parameters) \
        else ''
    ax.set_title(f'{data.label + ": " if data.label else ""}fitted parameters{kappa}; dotted: +-3', fontsize=8)
    ax.grid(True, axis='y', lw=0.3)


def _heading(data: ResidualPlot) -> str:
    """``calibration from FILE: N rows, gate passed`` (``arm arm1 from ...`` for an arm)."""
    verdict = 'gate passed' if data.passed else f'gate FAILED ({", ".join(data.failed)})'
    files = ' + '.join(Path(s).name for s in data.source.split(' + '))
    return f'{data.label or "calibration"} from {files}: {len(data.rows)} rows, {verdict}'


def residual_figure(plots: ResidualPlot | Sequence[ResidualPlot]) -> Figure:
    """The figure (a matplotlib Figure, Agg) of one calibration or several (the arms'), for each: the position
    residual [um] per measurement row, the orientation residual [urad] (measured poses), the fitted parameters'
    change in standard errors; the gate's verdict in the title."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    plots = [plots] if isinstance(plots, ResidualPlot) else list(plots)
    panels: list[tuple[ResidualPlot, tuple[Kind, str, str] | None]] = []
    for data in plots:
        panels.append((data, (data.position, 'position', 'um')))
        if data.angle is not None:
            panels.append((data, (data.angle, 'orientation', 'urad')))
        if data.parameters:
            panels.append((data, None))
    fig, axes = plt.subplots(len(panels), 1, figsize=(10, 2.6 * len(panels) + 0.6), constrained_layout=True)
    for ax, (data, kind) in zip(np.atleast_1d(axes), panels, strict=True):
        if kind is None:
            _parameter_panel(ax, data)
            continue
        _residual_panel(ax, data, *kind)
        ax.set_xlabel('measurement row (the files\' rows one after the other, as given)' if data.merged
                      else "measurement row (1: the file's first measurement)")
        if data.label:
            ax.set_title(data.label, fontsize=8)
    fig.suptitle('\n'.join(_heading(data) for data in plots), fontsize=10)
    return fig


def plot_residuals(path: str | Path, plots: ResidualPlot | Sequence[ResidualPlot]) -> Path:
    """Write :func:`residual_figure` of ``plots`` to ``path`` (PNG, atomically) and return it."""
    import matplotlib.pyplot as plt

    from ..inputs.files import atomic_output

    fig = residual_figure(plots)
    try:
        with atomic_output(path, 'plot', binary=True) as out:
            fig.savefig(out, format='png', dpi=90, bbox_inches='tight')   # the parameters' names whole
    finally:
        plt.close(fig)
    return Path(path)

"""``gpr calibrate --plot``: the residuals of every measurement before and after the calibration against the noise
the gate judges them by, and the fitted parameters' change in standard errors (the data:
:func:`~.residual_plot.residual_plot`); ``gpr accuracy --plot``: the Monte Carlo's distribution of each error
against the budget's numbers (the data: :func:`~.budget_plot.budget_plot`). Matplotlib, imported lazily (Agg),
the PNG written atomically."""
from __future__ import annotations

import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .budget_plot import BudgetPlot, Panel
from .residual_plot import Kind, ResidualPlot

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def _noise_label(k: Kind, unit: str) -> str:
    lo, hi = float(np.min(k.sigma)) * 1e6, float(np.max(k.sigma)) * 1e6
    sigma = f'{lo:.3g} {unit}' if np.isclose(lo, hi) else f'{lo:.3g}-{hi:.3g} {unit}'
    what = 'declared' if k.origin == 'declared' else k.origin if k.origin.startswith('the file') else \
        f'assumed, {k.origin}' if k.origin != 'assumed' else 'assumed (not declared)'
    if k.gpr is None:
        return f'noise: sqrt(3) sigma, sigma {sigma} per coordinate\n({what})'
    lo, hi = float(np.min(k.gpr)) * 1e6, float(np.max(k.gpr)) * 1e6
    return (f"noise and the GPR's share, as the gate judges: sqrt(3 sigma^2 + g^2),\nsigma {sigma} per coordinate "
            f"({what}),\ng {lo:.3g}-{hi:.3g} {unit} (the GPR's calibration covariance, propagated)")


def _residual_panel(ax: Axes, data: ResidualPlot, k: Kind, what: str, unit: str) -> None:
    x = data.rows
    ax.plot(x, k.before * 1e6, 'o', ms=4, mfc='none', color='tab:red',
            label=f'nominal geometry (before): RMS {k.rms_before * 1e6:.3g} {unit}')
    ax.plot(x, k.after * 1e6, 's', ms=4, color='tab:blue',
            label=f'calibrated geometry (after): RMS {k.rms_after * 1e6:.3g} {unit}')
    ax.step(x, k.noise * 1e6, where='mid', color='k', lw=1, ls='--', label=_noise_label(k, unit))
    worst = int(np.argmax(k.after))
    right = x[worst] > x[0] + 0.8 * (x[-1] - x[0])   # in the last fifth its label goes left (it ran off the axes)
    ax.annotate(data.names[worst], (float(x[worst]), float(k.after[worst] * 1e6)), xytext=(-4 if right else 4, 4),
                textcoords='offset points', fontsize=7, color='tab:blue', ha='right' if right else 'left')
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


def _agg() -> None:
    """Draw on matplotlib's Agg backend (no display)."""
    import matplotlib

    matplotlib.use('Agg')


def residual_figure(plots: ResidualPlot | Sequence[ResidualPlot]) -> Figure:
    """The figure (a matplotlib Figure, Agg) of one calibration or several (the arms'), for each: the position
    residual [um] per measurement row, the orientation residual [urad] (measured poses), the fitted parameters'
    change in standard errors; the gate's verdict in the title."""
    _agg()
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


def _write(path: str | Path, fig: Figure) -> Path:
    """Write ``fig`` to ``path`` (PNG, atomically), close it and return the path."""
    import matplotlib.pyplot as plt

    from ..inputs.files import atomic_output

    try:
        with atomic_output(path, 'plot', binary=True) as out:
            fig.savefig(out, format='png', dpi=90, bbox_inches='tight')   # the parameters' names whole
    finally:
        plt.close(fig)
    return Path(path)


def plot_residuals(path: str | Path, plots: ResidualPlot | Sequence[ResidualPlot]) -> Path:
    """Write :func:`residual_figure` of ``plots`` to ``path`` (PNG, atomically) and return it."""
    return _write(path, residual_figure(plots))


#: The colours of the budget's lines: the worst case, the RSS, then the percentiles in turn.
_LINE_STYLES = {'worst': ('tab:red', '-'), 'RSS': ('k', '--')}
_PERCENTILE_COLOURS = ('tab:green', 'tab:orange', 'tab:purple', 'tab:brown', 'tab:pink')
#: A budget panel's height in its tallest bar's: the legend in the room above the bars (placed 'best', it sat on
#: them across the p50, RSS and p95 lines).
LEGEND_ROOM = 2.0


def _budget_panel(ax: Axes, p: Panel) -> None:
    unit = 'um' if p.unit == 'm' else 'urad'
    n = len(p.samples)
    ax.stairs(p.counts, p.edges * 1e6, fill=True, color='tab:blue', alpha=0.45,
              label=f'{n} sample{"s" if n != 1 else ""}')
    k = 0
    for name, value in p.lines:
        colour, style = _LINE_STYLES.get(name, (_PERCENTILE_COLOURS[k % len(_PERCENTILE_COLOURS)], ':'))
        k += name not in _LINE_STYLES
        ax.axvline(value * 1e6, color=colour, ls=style, lw=1.1,
                   label=f'{"worst case" if name == "worst" else name} {value * 1e6:.4g} {unit}')
    ax.set_xlim(0.0, 1.04 * max(float(p.edges[-1]), max(v for _, v in p.lines)) * 1e6)
    ax.set_xlabel(f'{p.quantity.replace("_", " ")} error [{unit}]', fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(True, lw=0.3)
    ax.set_ylim(0.0, LEGEND_ROOM * max(float(np.max(p.counts, initial=0.0)), 1.0))   # the legend above the bars
    ax.legend(loc='upper right', fontsize=6, framealpha=0.85)


def budget_figure(data: BudgetPlot) -> Figure:
    """The figure (a matplotlib Figure, Agg) of an accuracy budget: a row per station drawn (one station: its
    quantities in rows of 2 or 3), a histogram per quantity of the Monte Carlo's error magnitudes with the
    linearised worst case, the RSS and the percentiles as labelled lines; the title says how many of the stations
    are drawn."""
    _agg()
    import matplotlib.pyplot as plt
    n = len(data.panels[0])
    step = n if len(data.panels) > 1 else 3 if n % 3 == 0 else 2
    grid = [(label, panels[k:k + step]) for label, panels in zip(data.stations, data.panels, strict=True)
            for k in range(0, n, step)]
    rows, cols = len(grid), len(grid[0][1])
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 2.3 * rows + 0.7), constrained_layout=True,
                             squeeze=False)
    for r, (label, panels) in enumerate(grid):
        for c, p in enumerate(panels):
            _budget_panel(axes[r, c], p)
        axes[r, 0].set_ylabel(textwrap.fill(f'station {label}', 32) + '\nsamples per bin', fontsize=8)
    shown = len(data.stations)
    which = f'the first {shown} of {data.total} stations' if data.total > shown else \
        f'{shown} station{"s" if shown > 1 else ""}'
    plural = 's' if data.samples != 1 else ''
    fig.suptitle(textwrap.fill(f'accuracy budget, {which}: Monte Carlo of {data.samples} sample{plural} (seed '
                               f'{data.seed}) against the linearised worst case and RSS, errors in the axes of '
                               f'{data.frame}',
                               40 * cols), fontsize=9)
    return fig


def plot_budget(path: str | Path, data: BudgetPlot) -> Path:
    """Write :func:`budget_figure` of ``data`` to ``path`` (PNG, atomically) and return it."""
    return _write(path, budget_figure(data))

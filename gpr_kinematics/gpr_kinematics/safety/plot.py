"""``gpr program check --plot``: the certified clearance and the slip ratio against time, the margin and the limit
drawn, the closest pair and the largest slip marked and named, each pick's and place's hold at its station marked;
beside them the cell from above (:mod:`.plan_view`: the obstacles' outlines, the blades' paths, the stations, the
closest pair's obstacle and where its arm was) (matplotlib).

The clearance curve is, on each interval of the base sampling, the certified lower bound of every pair's distance
there (the smallest over all pairs of the branch and bound's final bounds): the true clearance is never below it,
and it is within the pairs' tolerance of the truth where a pair comes closest (far from that, the bound may lie
lower than the truth, as a proof needs no more). Values beyond the plot's top are drawn at the top. The closest
pair is marked at its least certified distance and the instant of its smallest measured distance (the text
output's ``min distance`` and ``min at``); in an unsafe program the first instant below the margin too, and the
legend says that the bound is refined to each pair's least distance only: a pair that collides somewhere settles
its other intervals at bounds near that least distance, so the curve may dip below the margin far from any
approach (the check of a safe program settles every bound near the margin or above).
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .budget import BudgetReport
from .check import STATION_WAFER, SafetyReport
from .clearance import ClearanceReport
from .plan_view import PlanView

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: Top of the clearance axis [mm] (raised to show a least clearance above it).
TOP_MM = 60.0


def check_figure(clear: ClearanceReport, slip: tuple[NDArray[np.float64], NDArray[np.float64]],
                 report: SafetyReport, program: str | Path | None = None, view: PlanView | None = None) -> Figure:
    """The figure (a matplotlib Figure, Agg): clearance [mm] above, slip ratio below, against time [s], and with
    ``view`` the cell from above beside them (:func:`draw_plan_view`); the title names the program, the cell and the
    verdict with its numbers as the text output prints them."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    least = report.min_clearance * 1e3
    top = TOP_MM if not np.isfinite(least) or least < 0.9 * TOP_MM else 1.2 * least
    t, bound = clear.series
    if view is None:
        fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(11, 6.5), constrained_layout=True)
    else:
        fig = plt.figure(figsize=(17, 6.5), constrained_layout=True)
        grid = fig.add_gridspec(2, 2, width_ratios=(11, 6))
        ax1 = fig.add_subplot(grid[0, 0])
        ax2 = fig.add_subplot(grid[1, 0], sharex=ax1)
        ax1.tick_params(labelbottom=False)
        draw_plan_view(fig.add_subplot(grid[:, 1]), view, clear, report)
    if t.size > 1:
        shown = np.clip(np.where(np.isfinite(bound), bound * 1e3, top), None, top)
        # the search stops refining once a pair is below the margin (or the slip fails): not for the budget alone
        loose = ('' if not report.collisions and report.max_slip_ratio < 1.0 else
                 '\nrefined to each pair\'s least\ndistance only: below the margin\nit may lie far under the truth'
                 + (';\nthe first approach is the x' if report.collisions else ''))   # an x only for a collision
        ax1.stairs(shown, t, baseline=None, lw=1,
                   label=f'{"certified" if report.proven else "first-order"} clearance\n(lower bound over all pairs;\n'
                         f'above {top:g} mm drawn at the top){loose}')
    ax1.axhline(report.margin * 1e3, color='r', lw=1, label=f'margin {report.margin * 1e3:g} mm')
    if clear.pairs:
        at, bodies = clear.pairs[0].time, ' / '.join(clear.pairs[0].bodies)
        ax1.axhline(least, color='k', ls=':', lw=1)
        ax1.plot([at], [least], 'v', color='k', ms=7, label=f'least {least:.3f} mm at {at:.3f} s:\n{bodies}')
    if report.collisions:
        c = report.collisions[0]
        what = ('first below the margin at' if c.measured_below else
                'not shown the margin apart\n(bounds only), closest at')
        ax1.plot([c.time], [report.margin * 1e3], 'x', color='r', ms=9, mew=2, label=f'{what} '
                 f'{c.time:.3f} s:\n{" / ".join(c.bodies)}\n(step {c.step}, {c.station})')
    ax1.set_ylabel('clearance [mm]')
    ax1.set_ylim(min(0.0, least - 1) if np.isfinite(least) else 0.0, top * 1.02)
    ax1.legend(loc='upper left', bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax2.plot(slip[0], slip[1], lw=1, label='slip ratio of the carried wafer')
    ax2.axhline(1.0, color='r', lw=1, label='slips at 1')
    if report.wafer_carried:
        ax2.plot([report.max_slip_at], [report.max_slip_evaluated], 'v', color='k', ms=7,
                 label=f'largest {report.max_slip_evaluated:.3f} at {report.max_slip_at:.3f} s:\n{report.slip_label}')
    else:
        ax2.text(0.5, 0.5, 'no wafer carried', ha='center', va='center', transform=ax2.transAxes)
    ax2.set_ylabel('slip ratio (1: the wafer slips)')
    ax2.set_ylim(0.0, max(1.1, float(np.max(slip[1], initial=0.0)) * 1.05))
    ax2.set_xlabel('time [s]')
    ax2.legend(loc='upper left', bbox_to_anchor=(1.01, 1.0), fontsize=8)
    _mark_stations(report, (ax1, ax2))
    what = Path(program).name if program is not None else 'program'
    where = f'in cell {Path(report.cell).name}' if report.cell else 'against itself (no cell)'
    slip_text = (f'max slip ratio {report.max_slip_ratio:.3f} ({report.bound}'
                 f'{"" if report.proven else ": " + report.model}; limit 1)' if report.wafer_carried
                 else 'no wafer carried')
    fig.suptitle(f'{what} {where}: {"safe" if report.safe else "NOT safe"}\nminimum clearance {least:.3f} mm '
                 f'(margin {report.margin * 1e3:g} mm), {slip_text}' + _beyond(report.budget), fontsize=10)
    return fig


def plot_check(path: str | Path, clear: ClearanceReport, slip: tuple[NDArray[np.float64], NDArray[np.float64]],
               report: SafetyReport, program: str | Path | None = None, view: PlanView | None = None) -> Path:
    """Write :func:`check_figure` to ``path`` (PNG, atomically) and return it."""
    import matplotlib.pyplot as plt

    from ..inputs.files import atomic_output

    fig = check_figure(clear, slip, report, program, view)
    try:
        with atomic_output(path, 'plot', binary=True) as out:
            fig.savefig(out, format='png', dpi=90)
    finally:
        plt.close(fig)
    return Path(path)


def draw_plan_view(ax: Axes, view: PlanView, clear: ClearanceReport, report: SafetyReport) -> None:
    """The cell from above on ``ax`` [mm]: the obstacles grey (the closest pair's red and named), each arm's blade
    path (thick: carrying a wafer), the stations, where the closest pair's arm was at its least distance (a
    triangle) and, in an unsafe program, at the first approach below the margin (an x)."""
    closest = clear.pairs[0] if clear.pairs else None
    for name, poly in view.outlines:
        near = closest is not None and name in closest.bodies   # drawn above the others (a level chamber's walls
        wafer = name.startswith(STATION_WAFER)                  # share one outline from above: it was hidden)
        ax.fill(*(poly * 1e3).T, facecolor='#f4c7c3' if near else 'none' if wafer else '0.88',
                edgecolor='r' if near else '0.6' if wafer else '0.45', lw=1.2 if near else 0.7,
                zorder=1.5 if near else 1)
        if near:
            ax.annotate(name, (float(poly[:, 0].mean()) * 1e3, float(poly[:, 1].min()) * 1e3), xytext=(0, -3),
                        textcoords='offset points', fontsize=7, color='r', ha='center', va='top', zorder=4)
    for arm, xy, _, held in view.paths:
        if len(xy) < 2:   # an arm only ever where it starts: no path (its one point drew nothing but a legend entry)
            continue
        color = _arm_colour(view, arm)
        ax.plot(*(xy * 1e3).T, color=color, lw=0.6, alpha=0.8, zorder=2, label=f'{arm}: its wafer centre (empty blade)')
        ax.plot(*(np.where(held[:, None], xy, np.nan) * 1e3).T, color=color, lw=2.0, alpha=0.6, zorder=2,
                label=f'{arm} carrying a wafer')
    ax.plot(*(view.stations * 1e3).T, '+', color='k', ms=7, zorder=3, label='stations')
    for name, xy in zip(view.station_names, view.stations, strict=True):
        ax.annotate(f' {name}', xy * 1e3, fontsize=6, color='0.3', zorder=3)
    if closest is not None:
        arm, at = _where_arm(view, closest.bodies, closest.time)
        if at is not None:
            ax.plot(*(at * 1e3), 'v', color='k', mec=_arm_colour(view, arm), mew=1.5, ms=8, zorder=5,
                    label=f"{arm}'s wafer centre at the least\nclearance ({' / '.join(closest.bodies)})")
    if report.collisions:
        c = report.collisions[0]
        arm, at = _where_arm(view, c.bodies, c.time)
        if at is not None:
            ax.plot(*(at * 1e3), 'x', color='r', ms=9, mew=2, zorder=5, label=f"{arm}'s, first below the margin")
    ax.set_aspect('equal', adjustable='datalim')
    ax.set_xlabel('x [mm] (world)')
    ax.set_ylabel('y [mm]')
    ax.set_title('from above: obstacles, wafers in stations (circles), blade paths, stations', fontsize=9)
    ax.legend(loc='upper center', bbox_to_anchor=(0.5, -0.1), fontsize=7, ncol=2)


def _where_arm(view: PlanView, bodies: tuple[str, str], time: float) -> tuple[str, NDArray[np.float64] | None]:
    """The arm owning one of ``bodies`` (``arm1_link2``, ``arm2_wafer``; not a fixed body, an obstacle ``arm2_rack``
    named like one) and its wafer centre [m] at the sample nearest ``time`` among those it is in use; ``('', None)``
    for a pair of no arm's body."""
    fixed = {name for name, _ in view.outlines}
    for arm, xy, t, _ in view.paths:
        if any((b == arm or b.startswith(f'{arm}_')) and b not in fixed for b in bodies) and t.size:
            return arm, np.asarray(xy[int(np.argmin(np.abs(t - time)))], dtype=float)
    return '', None


def _arm_colour(view: PlanView, arm: str) -> str:
    """The colour of ``arm``'s path (:func:`draw_plan_view`): by its place among the robot's arms, so that an arm
    keeps its colour whichever arm a program moves first (it took the colour of its first use)."""
    return f'C{view.arms.index(arm)}'


#: A waypoint where a pick or place holds at its station (:attr:`~.check.MoveSafety.label`).
_AT_STATION = re.compile(r'\((pick|place) (\S+), at\)$')


def _mark_stations(report: SafetyReport, axes: tuple[Axes, Axes]) -> None:
    """A thin vertical line at each pick's and place's hold at its station, named on the clearance axis (a dip could
    not be placed in the program without the text table)."""
    for m in report.moves:
        found = _AT_STATION.search(m.label)
        if found is None:
            continue
        for ax in axes:
            ax.axvline(m.start, color='0.75', lw=0.6, zorder=0)
        axes[0].text(m.start, 0.99, f' {found[1]} {found[2]}', transform=axes[0].get_xaxis_transform(), rotation=90,
                     va='top', ha='right', fontsize=6, color='0.45')


def _beyond(b: BudgetReport | None) -> str:
    """The title's line on the samples beyond the imperfection budget ('' when none)."""
    if b is None or not b.beyond:
        return ''
    return (f'\nBEYOND the imperfection budget: {sum(f.samples for f in b.beyond)} sample(s) at {b.rate:g} Hz, up to '
            f'{b.max_displacement * 1e6:.3f} um (budget {b.budget * 1e6:g} um)')

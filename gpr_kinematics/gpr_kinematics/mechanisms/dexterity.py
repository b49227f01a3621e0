"""Dexterity (inverse condition number) maps of any :class:`~gpr_kinematics.mechanisms.base.Mechanism`.

Dexterity is ``sigma_min / sigma_max`` of the homogenised square Jacobian ``dq/du`` (Toz & Kucuk
§4.3 for the homogenisation by a characteristic length; Aboulissane & El Bakkali §V-A for dexterity against
height, their Fig. 6; ``docs/references.md``): 1 for an isotropic
configuration, 0 at a singularity. A map varies one pose component (or two, for a grid) from a base
pose and records dexterity, condition number, singularity and whether the joints are within limits.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError, LimitError, brief
from ..inputs.validation import bounded, count_of
from .base import SINGULAR_TOLERANCE, Mechanism, as_poses, condition_number, dexterity_index

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Most poses of one map (a sweep, or a grid of two variables): about 5 kB of memory and 0.2 ms each for the GPR
#: (the costliest mechanism: its Jacobians are finite differences of the core), 0.3 GB and 10 s at the limit.
MAX_POINTS = 50_000


@dataclass(frozen=True)
class DexterityMap:
    """Dexterity along one pose component (``values`` (K,)) or on a grid of two (``values2`` (K2,))."""

    mechanism: str
    variable: str
    values: np.ndarray              #: (K,) values of ``variable`` (m or rad)
    poses: np.ndarray               #: (K, 6) or (K, K2, 6) realised poses
    dexterity: np.ndarray           #: (K,) or (K, K2)
    condition_number: np.ndarray    #: (K,) or (K, K2)
    singular: np.ndarray            #: bool, same shape
    within_limits: np.ndarray       #: bool, same shape
    variable2: str | None = None
    values2: np.ndarray | None = None
    units: tuple[str, str] = ('', '')  #: the unit of ``variable`` and of ``variable2`` (m or rad; '' unknown)

    def record(self, kind: str) -> DexterityRecord:
        """The map as ``gpr dexterity --json`` prints it (:class:`DexterityRecord`); ``kind`` is the mechanism's
        type."""
        return DexterityRecord(
            mechanism=self.mechanism, variable=self.variable, values=self.values, dexterity=self.dexterity,
            within_limits=self.within_limits, singular=self.singular, condition_number=self.condition_number,
            variable2=self.variable2, values2=self.values2, type=kind)


@dataclass(frozen=True)
class DexterityRecord:
    """A :class:`DexterityMap` without its poses: the ``values`` of ``variable`` (and ``values2`` of ``variable2``
    on a grid, else ``None``), the ``dexterity``, ``within_limits``, ``singular`` and ``condition_number`` (``inf``
    where infinite: JSON's ``"inf"``, as ``gpr mechanism``'s and every command's; it was -1, then null) at each, and
    the mechanism's name and ``type``."""

    mechanism: str
    variable: str
    values: np.ndarray
    dexterity: np.ndarray
    within_limits: np.ndarray
    singular: np.ndarray
    condition_number: np.ndarray
    variable2: str | None
    values2: np.ndarray | None
    type: str


def check_points(count: int, what: str) -> None:
    """Refuse a map of more than :data:`MAX_POINTS` poses before anything is allocated."""
    if count > MAX_POINTS:
        raise InputError(f'{what}: {count} poses; allowed: at most {MAX_POINTS} per map')


def _values(values: Any, variable: str) -> np.ndarray:
    """The values of a varied pose variable as finite floats ``(K,)`` (the callers count them first with
    :func:`~gpr_kinematics.inputs.validation.count_of`, so ``range(10**12)`` is refused, not allocated)."""
    return bounded(values, f'values of {variable}').ravel()


def _index(mech: Mechanism, variable: str) -> int:
    if variable not in mech.pose_variables:
        raise InputError(f'{mech.name}: cannot vary {brief(variable)}; its pose variables are '
                         + ', '.join(mech.pose_variables))
    return mech.pose_names.index(variable)


def _unit(mech: Mechanism, variable: str) -> str:
    return 'm' if mech.pose_names.index(variable) < 3 else 'rad'


def evaluate(mech: Mechanism, poses: Any
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(poses, dexterity, condition, singular, within_limits)`` for a batch of poses ``(N, 6)``; a pose the
    mechanism cannot complete (:meth:`~.base.Mechanism.undetermined`) is singular, dexterity 0, outside the limits,
    its completed components NaN."""
    arr, _ = as_poses(poses)
    free = mech.undetermined(arr)
    if free.any():   # the map was refused whole ('poses must be finite numbers') at theta = 180 deg of the tripod
        n = arr.shape[0]
        full, dex, cond = np.full((n, 6), np.nan), np.zeros(n), np.full(n, np.inf)
        sing, within = np.ones(n, dtype=bool), np.zeros(n, dtype=bool)
        full[:, mech.variable_indices] = arr[:, mech.variable_indices]
        if not free.all():
            ok = ~free
            full[ok], dex[ok], cond[ok], sing[ok], within[ok] = evaluate(mech, arr[ok])
        return full, dex, cond, sing, within
    calc = mech.unlimited()   # computes beyond the limits, which mark the poses (within)
    try:
        full = calc.complete_pose(arr)
    except LimitError as exc:   # it quoted the domain's stroke, [-0.508, 1.016] m, as the machine's
        raise LimitError(f'{mech.name}: the map reaches beyond even the domain it computes in (the limits widened, '
                         f'the poses beyond them computed there and marked; the numbers below are the domain\'s): '
                         f'{exc}') from None
    with np.errstate(divide='ignore', invalid='ignore'):
        # named: a singular configuration of the mechanism itself (the GPR's rigid one, a GSP's undefined rows)
        Jh, singularity = calc.jacobian_and_singularity(full)
    named = singularity != ''
    finite = np.all(np.isfinite(Jh), axis=(1, 2))
    Jh = np.where(finite[:, None, None], Jh, 0.0)
    dex = np.where(finite, dexterity_index(Jh), 0.0)
    cond = np.where(finite, condition_number(Jh), np.inf)
    within = mech.within_limits(calc.inverse_kinematics(full)) & mech.pose_within_limits(full)
    return full, dex, cond, (dex < SINGULAR_TOLERANCE) | named, within


def dexterity_sweep(mech: Mechanism, base_pose: Any, variable: str, values: Any) -> DexterityMap:
    """Dexterity along ``variable`` (a pose variable) taking ``values``; the rest from ``base_pose``.

    Example (3-UPU, the paper's Fig. 6): ``dexterity_sweep(upu, [0]*6, 'z', np.linspace(0.17, 0.27, 51))``.
    """
    base, _ = as_poses(base_pose, 'base pose')
    check_points(count_of(values), f'dexterity along {variable}')
    vals = _values(values, variable)
    if vals.size == 0:
        raise InputError(f'values of {variable} must be finite numbers; got none')
    poses = np.repeat(base, vals.size, axis=0)
    poses[:, _index(mech, variable)] = vals
    full, dex, cond, sing, within = evaluate(mech, poses)
    return DexterityMap(mech.name, variable, vals, full, dex, cond, sing, within, units=(_unit(mech, variable), ''))


def dexterity_grid(mech: Mechanism, base_pose: Any, variable: str, values: Any, variable2: str,
                   values2: Any) -> DexterityMap:
    """Dexterity on the grid ``values x values2`` of two pose variables (shape ``(K, K2)``)."""
    base, _ = as_poses(base_pose, 'base pose')
    n1, n2 = count_of(values), count_of(values2)
    check_points(n1 * n2, f'dexterity on a {n1} x {n2} grid')
    v1, v2 = _values(values, variable), _values(values2, variable2)
    check_points(v1.size * v2.size, f'dexterity on a {v1.size} x {v2.size} grid')
    i1, i2 = _index(mech, variable), _index(mech, variable2)
    if i1 == i2:
        raise InputError(f'the two varied pose variables must differ; got {variable} twice')
    poses = np.repeat(base, v1.size * v2.size, axis=0)
    g1, g2 = np.meshgrid(v1, v2, indexing='ij')
    poses[:, i1], poses[:, i2] = g1.ravel(), g2.ravel()
    full, dex, cond, sing, within = evaluate(mech, poses)
    shape = (v1.size, v2.size)
    return DexterityMap(mech.name, variable, v1, full.reshape(shape + (6,)), dex.reshape(shape),
                        cond.reshape(shape), sing.reshape(shape), within.reshape(shape), variable2, v2,
                        (_unit(mech, variable), _unit(mech, variable2)))


#: Plot file types (by extension) :func:`plot_dexterity` writes.
PLOT_FORMATS = ('png', 'pdf', 'svg')
#: A map's colours span at least this fraction of its largest dexterity: differences of rounding (1e-11 between
#: two columns) were drawn as the scale's two ends.
COLOUR_SPREAD = 1e-6


def check_plot_path(path: str | Path) -> Path:
    """The output ``path`` of a plot, checked before any work: a type of :data:`PLOT_FORMATS` by its extension,
    and writable (:func:`gpr_kinematics.inputs.files.check_output`)."""
    from ..inputs.files import check_output
    target = check_output(path, 'plot')
    if target.suffix.lower().lstrip('.') not in PLOT_FORMATS:
        raise InputError(f'plot {str(path)!r}: unknown type {target.suffix or "(no extension)"}; allowed: '
                         + ', '.join(f'.{f}' for f in PLOT_FORMATS))
    return target


def _axis(name: str, unit: str) -> str:
    return f'{name} [{unit}]' if unit else name


def _least(dmap: DexterityMap) -> tuple[float, tuple[int, ...]] | None:
    """The least dexterity within the joint limits and its index, or None when no pose is within them."""
    if not dmap.within_limits.any():
        return None
    inside = np.where(dmap.within_limits, dmap.dexterity, np.inf)
    k = np.unravel_index(int(np.argmin(inside)), inside.shape)
    return float(inside[k]), tuple(int(i) for i in k)


def dexterity_figure(dmap: DexterityMap) -> Figure:
    """The figure of :func:`plot_dexterity` (a matplotlib Figure, Agg): the least dexterity within the joint limits
    marked and named, singular poses marked, the axes in the variables' units (m, rad)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FormatStrFormatter

    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=100)
    least = _least(dmap)
    unit, unit2 = dmap.units
    if dmap.variable2 is None:
        x = dmap.values
        if not dmap.within_limits.all():
            ax.plot(x, dmap.dexterity, '--', color='0.6', label='outside the limits (joints or pose)')
        inside = np.where(dmap.within_limits, dmap.dexterity, np.nan)
        ax.plot(x, inside, '-', color='C0', lw=2, label='within joint limits')
        if dmap.singular.any():
            ax.plot(x[dmap.singular], dmap.dexterity[dmap.singular], 'x', color='r', ms=8, mew=2, label='singular')
        if least is not None:
            d, (k,) = least
            ax.plot([x[k]], [d], 'v', color='k', ms=8,
                    label=f'least within limits {d:.6f}\nat {dmap.variable} = {x[k]:.6g} {unit}'.rstrip())
        ax.set_xlabel(_axis(dmap.variable, unit))
        ax.set_ylabel('dexterity (inverse condition number)')
        ax.set_ylim(0.0, max(1e-3, 1.1 * float(np.max(dmap.dexterity, initial=0.0))))
        ax.legend(loc='lower left', fontsize=8)
    else:
        data = np.where(dmap.within_limits, dmap.dexterity, np.nan)
        v2 = np.asarray(dmap.values2)
        lo, hi = (float(np.nanmin(data)), float(np.nanmax(data))) if np.isfinite(data).any() else (0.0, 1.0)
        spread = max(hi - lo, COLOUR_SPREAD * max(abs(hi), 1e-300))   # rounding's differences one colour, not two
        im = ax.pcolormesh(v2, dmap.values, data, shading='auto', vmin=0.5 * (lo + hi - spread),
                           vmax=0.5 * (lo + hi + spread))
        bar = fig.colorbar(im, ax=ax, label='dexterity within the limits\n(white: outside them)')
        bar.formatter = FormatStrFormatter('%.8g')   # no offset or multiplier ('1e-7+7.071e-1') over the title
        bar.update_ticks()
        if least is not None:
            d, (i, j) = least
            ax.plot([v2[j]], [dmap.values[i]], 'v', color='r', mec='w', ms=9,
                    label=f'least within limits {d:.4f} at {dmap.variable2} = {v2[j]:.6g} {unit2}, '
                          f'{dmap.variable} = {dmap.values[i]:.6g} {unit}')
        if dmap.singular.any():   # over the least's marker, which hid a singular pose there
            rows, cols = np.nonzero(dmap.singular)
            ax.plot(v2[cols], dmap.values[rows], 'X', mfc='w', mec='k', ms=8, mew=1.0, label='singular', zorder=4)
        if ax.lines:
            ax.legend(loc='upper center', bbox_to_anchor=(0.5, -0.14), fontsize=8)
        ax.set_xlabel(_axis(dmap.variable2, unit2))
        ax.set_ylabel(_axis(dmap.variable, unit))
    ax.set_title(dmap.mechanism if least is not None else f'{dmap.mechanism}\nno pose within the joint limits',
                 fontsize=10)
    fig.tight_layout()
    return fig


def plot_dexterity(dmap: DexterityMap, path: str | Path) -> Path:
    """Write :func:`dexterity_figure` (PNG, PDF or SVG by the extension): dexterity against the variable (dashed
    where joints leave their limits), or a colour map for a grid. Returns the path written."""
    from ..inputs.files import atomic_output
    target = check_plot_path(path)
    import matplotlib.pyplot as plt

    fig = dexterity_figure(dmap)
    try:
        with atomic_output(target, 'plot', binary=True) as fh:
            fig.savefig(fh, format=target.suffix.lower().lstrip('.'))
    finally:
        plt.close(fig)
    return Path(path)

"""The heights a target of inverse kinematics may have: the stroke seen from the platform.

Rod ``k`` of the naive model (:func:`~gpr_kinematics.core.naive.naive_rods`) is
``N_k(h, n) = (h - c_k) / u_kz - o_k`` with ``c_k = n' . (p_k - tool)`` (:func:`tilt_term`), so the stroke
``[s_min, s_max]`` holds it for heights ``h`` within ``(s + o_k) u_kz + c_k`` (:func:`height_range`). The virtual
joints shift the solved rods by ``d_k = q_k - N_k(h, n)`` (micrometres at the shipped 2 deg limit, up to about 1.3 mm
at a tilt of 15 deg), so the solved rods stay within the stroke for ``h`` within ``(s + o_k - d_k) u_kz + c_k``
(:func:`solved_height_range`, first order: the shift is taken where the rods were solved). Leaning rods move their
joints sideways as they extend, so the shift changes with the height: :func:`allowed_heights` solves again at each
end, :data:`END_STEPS` times. A target beyond the naive range by more than :data:`HEIGHT_MARGIN` is refused before the
solve (:func:`check_height`), a solved one by its rods (:func:`check_solved_stroke`); both name the heights allowed at
the target's tilt, those of the solved rods, shown rounded inward so that either end is solved.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import ConvergenceError, LimitError
from .config import GprConfig
from .machine import MachineGeometry
from .naive import naive_rods
from .ops import ARRAY, Ops, Value
from .stroke import check_stroke, lengths_in_millimetres, within_as_millimetres

Array = NDArray[np.float64]
#: The solved rods of one sample ``i`` of a check, at the height ``h`` [m] of its tool point (stroke unchecked).
RodsAt = Callable[[int, float], Sequence[float]]

#: How far beyond the heights that keep the naive model's rods within the stroke a target may lie and still be
#: solved [m]: the virtual joints move the rods by at most ~1.3 mm against the naive model (at a tilt of 15 deg,
#: the largest tilt limit); the stroke itself is checked exactly after the solve.
HEIGHT_MARGIN = 0.01
#: Solves at each end of the allowed heights after the first order (each takes the shift where the end lies).
END_STEPS = 3


def tilt_term(geo: MachineGeometry, k: int, n: Sequence[Value], tool: Sequence[Value]) -> Value:
    """``c_k = n' . (p_k - tool)`` [m] with ``n' = (-n_x, -n_y, n_z)``: how far the platform's tilt to the normal
    ``n`` [-] lifts rod ``k``'s joint above the tool point ``tool`` [m] (module docstring)."""
    return n[0] * (geo.px[k] - tool[0]) + n[1] * (geo.py[k] - tool[1]) + n[2] * tool[2]


def height_range(ops: Ops, geo: MachineGeometry, n: Sequence[Value], tool: Sequence[Value], config: GprConfig
                 ) -> tuple[Value, Value]:
    """The heights of the tool point at which the naive model's rods stay within the stroke, for platform
    normals ``n``: rod ``k`` of :func:`~gpr_kinematics.core.naive.naive_rods` is within ``[stroke_min, stroke_max]``
    for ``h`` within ``(stroke + o_k) u_kz + n' . (p_k - tool)``."""
    lo: Value = 0.0
    hi: Value = 0.0
    for k in range(3):
        c = tilt_term(geo, k, n, tool)
        lo_k = (config.stroke_min + geo.offsets[k]) * geo.uz[k] + c
        hi_k = (config.stroke_max + geo.offsets[k]) * geo.uz[k] + c
        lo = lo_k if k == 0 else ops.maximum(lo, lo_k)
        hi = hi_k if k == 0 else -ops.maximum(-hi, -hi_k)
    return lo, hi


def solved_height_range(geo: MachineGeometry, q: Sequence[float], h: float, n: Sequence[float],
                        tool: Sequence[float], config: GprConfig) -> tuple[float, float]:
    """The tool point's heights [m] keeping rods within the stroke at the normal ``n`` [-], from the rods ``q`` [m]
    solved at the height ``h``: :func:`height_range` with each rod's virtual-joint shift ``d_k = q_k - N_k(h, n)``
    (module docstring; first order in the change of ``d_k`` with the height)."""
    naive = naive_rods(geo, h, n, tool)
    lo, hi = -math.inf, math.inf
    for k in range(3):
        c = tilt_term(geo, k, n, tool)
        d = float(q[k]) - float(naive[k])
        lo = max(lo, float((config.stroke_min + geo.offsets[k] - d) * geo.uz[k] + c))
        hi = min(hi, float((config.stroke_max + geo.offsets[k] - d) * geo.uz[k] + c))
    return lo, hi


def shown_inward(lo: float, hi: float) -> str:
    """``'lo .. hi'`` to six digits, rounded into the range (so either end, typed, lies within it)."""
    return f'{_rounded(lo, up=True)} .. {_rounded(hi, up=False)}'


def _rounded(x: float, up: bool) -> str:
    shown = f'{x:.6g}'
    if (float(shown) < x) if up else (float(shown) > x):   # one step of the sixth digit further in
        step = 10.0 ** (math.floor(math.log10(abs(x))) - 5)
        shown = f'{x + step if up else x - step:.6g}'
    return shown


def check_height(ops: Ops, geo: MachineGeometry, h: Value, t: Value, n: Sequence[Value], tool: Sequence[Value],
                 config: GprConfig, rods_at: RodsAt) -> None:
    """Refuse targets whose height needs rods outside the stroke (by more than :data:`HEIGHT_MARGIN`) before
    the solve, naming the heights allowed at that tilt (those of the rods ``rods_at`` solves at the nearest end of
    the naive range); a height of 1e308 m never reaches the arithmetic."""
    lo, hi = height_range(ops, geo, n, tool, config)
    if not ops.any(ops.not_((h >= lo - HEIGHT_MARGIN) & (h <= hi + HEIGHT_MARGIN))):
        return
    bad = np.atleast_1d(np.logical_not((h >= lo - HEIGHT_MARGIN) & (h <= hi + HEIGHT_MARGIN)))
    i = int(np.argmax(bad))
    hi_, lo_, ti = (float(np.atleast_1d(v)[i]) for v in (h, lo, t))
    hv = float(np.atleast_1d(hi)[i])
    heights = np.atleast_1d(h)   # a sweep's one height named no "target 0"; the tilt tells the target apart
    where = f' (target {i})' if bad.size > 1 and heights.size > 1 and np.ptp(heights) != 0 else ''
    at = f'at the tilt {ti:.6g} rad' + (' with this tool point' if any(np.any(np.asarray(v) != 0) for v in tool)
                                         else '')
    stroke = f'the stroke [{config.stroke_min:g}, {config.stroke_max:g}] m'
    if lo_ > hv:
        raise LimitError(f'height = {_height(hi_)}{where}: every height puts a rod outside {stroke} {at}')
    mm = '; as millimetres it would be within them: millimetres given as metres?' if within_as_millimetres(
        hi_, lo_, hv) else ''
    raise LimitError(f'height = {_height(hi_)}{where} puts a rod outside {stroke} {at}; allowed heights: '
                     f'{_allowed(geo, i, min(max(hi_, lo_), hv), n, tool, config, rods_at)}{mm}')


def _height(h: float) -> str:
    """A height ``h`` [m] as a refusal names it: in metres, and in millimetres beside where the lengths were typed in
    millimetres (:func:`~.stroke.typed_in_millimetres`: 300000 mm typed was named "300 m" alone)."""
    return f'{h:.9g} m ({h * 1000.0:.9g} mm)' if lengths_in_millimetres() else f'{h:.9g} m'


def _allowed(geo: MachineGeometry, i: int, h: float, n: Sequence[Value], tool: Sequence[Value], config: GprConfig,
             rods_at: RodsAt, q: Sequence[float] | None = None) -> str:
    """The heights allowed at sample ``i``'s tilt (:func:`allowed_heights`) from its rods ``q`` solved at the height
    ``h`` [m] (solved here where not given), as a refusal prints them (the naive range, as 'about', where a solve
    fails)."""
    ni, tool_i = ([at_sample(v, i) for v in w] for w in (n, tool))
    try:
        lo, hi = allowed_heights(geo, lambda x: rods_at(i, x), rods_at(i, h) if q is None else q, h, ni, tool_i,
                                 config)
    except (ConvergenceError, LimitError):   # not seen within the naive range: the naive range, as about
        lo_n, hi_n = height_range(ARRAY, geo, ni, tool_i, config)
        mm = f' (about {float(lo_n) * 1e3:.6g} .. {float(hi_n) * 1e3:.6g} mm)' if lengths_in_millimetres() else ''
        return f'about {float(lo_n):.6g} .. {float(hi_n):.6g} m{mm}'
    if not lo <= hi:
        return 'none'
    mm = f' ({shown_inward(lo * 1e3, hi * 1e3)} mm)' if lengths_in_millimetres() else ''
    return f'{shown_inward(lo, hi)} m{mm}'


def allowed_heights(geo: MachineGeometry, rods: Callable[[float], Sequence[float]], q: Sequence[float], h: float,
                    n: Sequence[float], tool: Sequence[float], config: GprConfig) -> tuple[float, float]:
    """The tool point's heights ``(lo, hi)`` [m] whose solved rods stay within the stroke at the normal ``n``:
    :func:`solved_height_range` of the rods ``q`` solved at ``h``, then of the rods ``rods(end)`` solved at each end,
    :data:`END_STEPS` times (leaning rods move their joints sideways as they extend, so the virtual joints' shift
    changes with the height: the first order named an end 1.5 um short at a tilt of 11 deg)."""
    lo, hi = solved_height_range(geo, q, h, n, tool, config)
    for _ in range(END_STEPS):
        if not lo <= hi:
            break
        lo, hi = solved_height_range(geo, rods(lo), lo, n, tool, config)[0], \
            solved_height_range(geo, rods(hi), hi, n, tool, config)[1]
    return lo, hi


def at_sample(value: Value, i: int) -> float:
    """Sample ``i`` of a value that is one float for every sample or one per sample."""
    return float(value) if np.ndim(value) == 0 else float(np.asarray(value)[i])


def solvable_heights(tilt: Array, azimuth: Array, config: GprConfig) -> tuple[Array, Array]:
    """The platform origin's heights ``(lo, hi)`` [m] at which :func:`~gpr_kinematics.core.inverse.inverse_batch`
    solves the tilts ``tilt`` about ``azimuth`` [rad]: those keeping the naive model's rods within the stroke,
    widened by :data:`HEIGHT_MARGIN` (beyond, it refuses before the solve; the answered rods decide within)."""
    s = np.sin(tilt)
    n = [s * np.sin(azimuth), -s * np.cos(azimuth), np.cos(tilt)]
    lo, hi = height_range(ARRAY, MachineGeometry.of(config), n, (0.0, 0.0, 0.0), config)
    return np.asarray(lo - HEIGHT_MARGIN), np.asarray(hi + HEIGHT_MARGIN)


def check_solved_stroke(ops: Ops, geo: MachineGeometry, q: Sequence[Value], h: Value, t: Value, n: Sequence[Value],
                        tool: Sequence[Value], config: GprConfig, rods_at: RodsAt) -> None:
    """:func:`~gpr_kinematics.core.stroke.check_stroke` of the solved rods ``q``; a refusal names the target's
    height and the heights allowed at its tilt too, those of the solved rods (:func:`allowed_heights`: the naive
    model's range named heights whose rods the virtual joints put micrometres outside)."""
    def heights(i: int, _k: int) -> str:   # of the sample check_stroke refuses
        hh, tt = at_sample(h, i), at_sample(t, i)
        allowed = _allowed(geo, i, hh, n, tool, config, rods_at, [at_sample(v, i) for v in q])
        return f': the height {_height(hh)} at the tilt {tt:.6g} rad needs it; allowed heights there: {allowed}'

    check_stroke(ops, q, config, what='q', detail=heights)

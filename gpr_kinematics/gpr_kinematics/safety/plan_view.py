"""The cell seen from above, the third panel of ``gpr program check --plot``: where the numbers of the other two are.

Each obstacle and each wafer lying in a station (``wafer@STATION:...``, a body the check pairs with the robot's) is
drawn as its outline in the world's x-y plane, the convex hull of its corners (a box's eight; a cylinder's rims,
:data:`RIM` points each) projected along z; a chamber is its walls (the boxes it is made of, its slit the gap between
them). The blade's path is the wafer centre of the arm in use at :data:`RATE` samples a second
(:func:`~gpr_kinematics.robot.plan.sample_plan`), drawn thick while that arm carries a wafer
(:func:`~.check.wafer_plan`'s windows) and thin while it is empty; the program's stations are their positions. Lengths
in metres here, millimetres in the figure.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull

from .bodies import Body
from .cell import Cell, Obstacle
from .check import program_bodies, wafer_plan

if TYPE_CHECKING:
    from ..robot.plan import ProgramPlan

Array = NDArray[np.float64]

#: Samples a second of the blade's path.
RATE = 50.0
#: Points on each rim of a cylinder.
RIM = 48


@dataclass(frozen=True)
class PlanView:
    """``outlines``: per obstacle (then per station wafer) its name and the counter-clockwise polygon ``(K, 2)`` [m] of
    its outline from above; ``paths``: per arm its name, the wafer centre ``(N, 2)`` [m] at the samples it is in use
    (``time (N,)`` [s]) and whether it carries a wafer there ``(N,)``, in the robot's order of its arms; ``stations``:
    the program's names and positions ``(S, 2)`` [m]; ``arms``: the robot's arm names, used or not (an arm's colour
    is its place there, the same in every program of the robot)."""

    outlines: tuple[tuple[str, Array], ...]
    paths: tuple[tuple[str, Array, Array, NDArray[np.bool_]], ...]
    station_names: tuple[str, ...]
    stations: Array
    arms: tuple[str, ...]


def corners(ob: Obstacle | Body) -> Array:
    """The points whose hull is ``ob`` ``(K, 3)`` [m, cell frame]: a box's 8 corners ``c + R (+-a/2, +-b/2, +-h/2)``,
    a cylinder's two rims of radius ``r`` at ``+-l/2`` along its z (:data:`RIM` points each)."""
    if ob.kind == 'box':
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        local = signs * (0.5 * np.asarray(ob.size, dtype=float))
    else:
        r, length = ob.size
        a = np.linspace(0.0, 2.0 * np.pi, RIM, endpoint=False)
        rim = np.column_stack([r * np.cos(a), r * np.sin(a)])
        local = np.vstack([np.column_stack([rim, np.full(RIM, z)]) for z in (-0.5 * length, 0.5 * length)])
    return np.asarray(ob.position + local @ ob.rotation.T, dtype=float)


def outline(ob: Obstacle | Body) -> Array:
    """``ob`` seen from above: the counter-clockwise convex hull ``(K, 2)`` [m] of its :func:`corners` in x-y (taken
    about its centre: a 1 mm box far from the origin keeps its digits). A body of at least 1 mm in each size
    (:mod:`.cell`) has an outline of positive area whatever its rotation."""
    xy = corners(ob)[:, :2] - ob.position[:2]
    return np.asarray(xy[ConvexHull(xy).vertices] + ob.position[:2], dtype=float)


def plan_view(plan: ProgramPlan, cell: Cell | None) -> PlanView:
    """The :class:`PlanView` of ``plan`` in ``cell`` (None: no obstacles)."""
    from ..robot.plan import sample_plan
    s = sample_plan(plan, RATE)
    t = s.samples.time
    arms = np.asarray(s.arm)
    wafers = wafer_plan(plan)
    carried = wafers.carried
    paths = []
    names, used_arms = tuple(a.name for a in plan.robot.arms), set(s.arm)
    for arm in (a for a in names if a in used_arms):
        used = arms == arm
        times = t[used]
        held = np.zeros(times.shape, dtype=bool)
        for a, b in carried.get(arm, ()):
            held |= (times >= a) & (times <= b)
        paths.append((arm, np.asarray(s.wafer.position[used, :2], dtype=float), times, held))
    fixed = [b for b in program_bodies(plan, cell, wafers)[0] if b.frame is None]   # the cell's, the station wafers
    st = plan.program.stations.stations
    return PlanView(tuple((b.name, outline(b)) for b in fixed), tuple(paths), st.names,
                    np.asarray(st.position[:, :2], dtype=float), names)

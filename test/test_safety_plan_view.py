"""The cell from above (``safety.plan_view``, ``gpr program check --plot``'s third panel): each obstacle's outline
is its projection along z (its area the one of a parallelepiped's shadow, a regular polygon's for a cylinder), the
blade paths are the sampled plan's wafer centres, and the figure draws them with the closest pair's obstacle and arm
marked."""
from __future__ import annotations

import math

import numpy as np
from gpr_kinematics.core.rotations import rotation_z, tilt_rotation
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import load_robot
from gpr_kinematics.robot.plan import plan_program, sample_plan
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.safety.cell import Obstacle, load_cell
from gpr_kinematics.safety.check import wafer_plan
from gpr_kinematics.safety.plan_view import RATE, RIM, PlanView, corners, outline, plan_view

PROGRAM = config_path('programs/example_cell_program.yaml')
CELL = config_path('cells/example_cell.yaml')


def _signed_area(poly: np.ndarray) -> float:
    x, y = poly.T
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def test_a_boxs_outline_is_its_shadow_whatever_its_rotation():
    """The shadow of a box of edges ``a u, b v, c w`` along z has the area ``|(a u x b v)_z| + |(b v x c w)_z| +
    |(c w x a u)_z|`` (half the sum of its faces' areas times their normals' |z|); the outline is counter-clockwise,
    made of projected corners, and holds every corner's projection."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        size = rng.uniform(0.001, 2.0, 3)
        R = tilt_rotation(rng.uniform(0, 1.5, 1), rng.uniform(-3, 3, 1))[0] @ rotation_z(rng.uniform(-3, 3, 1))[0]
        ob = Obstacle('b', 'box', tuple(size), rng.uniform(-100, 100, 3), R)
        poly = outline(ob)
        e = (R * size).T   # the edges a u, b v, c w as rows
        shadow = sum(abs(float(np.cross(e[i], e[(i + 1) % 3])[2])) for i in range(3))
        assert math.isclose(_signed_area(poly), shadow, rel_tol=1e-9), (_signed_area(poly), shadow)
        xy = corners(ob)[:, :2]
        assert all(np.min(np.linalg.norm(xy - p, axis=1)) < 1e-9 for p in poly)
        for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):   # every corner left of (or on) each edge
            assert np.all((b - a)[0] * (xy - a)[:, 1] - (b - a)[1] * (xy - a)[:, 0] >= -1e-9)
    upright = Obstacle('u', 'box', (0.4, 0.2, 1.0), np.array([1.0, 2.0, 0.5]), rotation_z(np.array([0.3]))[0])
    assert math.isclose(_signed_area(outline(upright)), 0.08, rel_tol=1e-12) and len(outline(upright)) == 4


def test_an_upright_cylinders_outline_is_its_rim_polygon():
    ob = Obstacle('c', 'cylinder', (0.05, 0.3), np.array([0.2, 0.5, 0.15]), np.eye(3))
    poly = outline(ob)
    assert len(poly) == RIM
    assert math.isclose(_signed_area(poly), RIM / 2 * 0.05 ** 2 * math.sin(2 * math.pi / RIM), rel_tol=1e-12)
    assert np.allclose(np.linalg.norm(poly - [0.2, 0.5], axis=1), 0.05, rtol=0, atol=1e-15)
    lying = Obstacle('l', 'cylinder', (0.05, 0.3), np.zeros(3), tilt_rotation(np.array([math.pi / 2]),
                                                                                np.array([0.0]))[0])
    assert math.isclose(_signed_area(outline(lying)), 0.1 * 0.3, rel_tol=1e-12)   # a rectangle 2 r by l


def test_the_plan_view_of_the_example_is_the_sampled_plan_and_the_cell():
    plan = plan_program(load_robot(), load_program(PROGRAM))
    cell = load_cell(CELL)
    view = plan_view(plan, cell)
    names = [n for n, _ in view.outlines]   # the cell's obstacles, then the wafers lying in stations
    assert names[:len(cell.names)] == list(cell.names)
    wafers = wafer_plan(plan).stations
    assert names[len(cell.names):] == [w for w, _, _ in wafers] and wafers
    k = plan.program.stations.index()[wafers[0][1]]   # a wafer's disc (150 mm) about its station
    disc = dict(view.outlines)[wafers[0][0]]
    assert np.allclose(np.linalg.norm(disc - plan.program.stations.stations.position[k, :2], axis=1), 0.15, atol=0.006)
    s = sample_plan(plan, RATE)
    arms = np.asarray(s.arm)
    carried = wafer_plan(plan).carried
    assert sorted(a for a, *_ in view.paths) == sorted(set(s.arm))
    # in the robot's order (an arm's colour is its place among the robot's arms, whichever a program moves first)
    assert view.arms == tuple(a.name for a in plan.robot.arms)
    assert [a for a, *_ in view.paths] == [a for a in view.arms if a in set(s.arm)]
    for arm, xy, t, held in view.paths:
        assert np.array_equal(xy, s.wafer.position[arms == arm, :2]) and np.array_equal(t, s.samples.time[arms == arm])
        inside = np.array([any(a <= x <= b for a, b in carried[arm]) for x in t])
        assert np.array_equal(held, inside) and held.any() and not held.all()
    st = plan.program.stations.stations
    assert view.station_names == st.names and np.array_equal(view.stations, st.position[:, :2])
    assert [n for n, _ in plan_view(plan, None).outlines] == names[len(cell.names):]


def test_the_figure_draws_the_plan_view_and_marks_the_closest_pair():
    """With the view, the figure has the time plots and the cell from above: one filled outline per obstacle (mm),
    the closest pair's obstacle red and named, the arm's wafer centre marked at the sample nearest the least
    distance's instant, and at a 7 mm margin the first approach below it."""
    import matplotlib.pyplot as plt
    from gpr_kinematics.safety.check import check_program
    from gpr_kinematics.safety.plot import check_figure
    plan = plan_program(load_robot(), load_program(PROGRAM))
    cell = load_cell(CELL)
    view = plan_view(plan, cell)
    report, clear, slip = check_program(plan, cell, 0.007)
    fig = check_figure(clear, slip, report, PROGRAM, view)
    try:
        ax1, ax2, ax3 = fig.axes
        assert ax3.get_xlabel() == 'x [mm] (world)' and ax3.get_aspect() == 1.0
        assert len(ax3.patches) == len(view.outlines)
        for patch, (name, poly) in zip(ax3.patches, view.outlines, strict=True):
            assert np.allclose(patch.get_xy()[:len(poly)], poly * 1e3, rtol=0, atol=1e-9)
            red = patch.get_edgecolor()[:3] == (1.0, 0.0, 0.0)
            assert red == (name in clear.pairs[0].bodies), name
            # above every other outline: a level chamber's walls share one outline from above (it was hidden)
            assert patch.get_zorder() == (1.5 if red else 1.0)
        assert [t.get_text() for t in ax3.texts if t.get_color() == 'r'] == ['pm1/front_bottom']
        arm_path = dict((a, (xy, t)) for a, xy, t, _ in view.paths)['arm2']
        marks = {line.get_marker(): line for line in ax3.lines if line.get_marker() in ('v', 'x')}
        # arm2's colour: the robot's second arm's (C1), though the program moves it first (it took C0 then)
        assert marks['v'].get_label().startswith("arm2's wafer centre") and marks['v'].get_markeredgecolor() == 'C1'
        paths = ('arm2:', 'arm2 carrying')
        assert {line.get_color() for line in ax3.lines if line.get_label().startswith(paths)} == {'C1'}
        for marker, at in (('v', clear.pairs[0].time), ('x', report.collisions[0].time)):
            k = int(np.argmin(np.abs(arm_path[1] - at)))
            assert np.array_equal(np.column_stack([marks[marker].get_xdata(), marks[marker].get_ydata()])[0],
                                  arm_path[0][k] * 1e3)
    finally:
        plt.close(fig)


def test_a_station_wafer_in_the_closest_pair_is_the_red_outline():
    """The example robot program in the example cell comes closest between arm2's blade and a wafer lying in
    chamber_b: the panel drew no wafer, so nothing was red; the wafer's disc is now, under the pair's name."""
    import matplotlib.pyplot as plt
    from gpr_kinematics.safety.check import check_program
    from gpr_kinematics.safety.plot import check_figure
    plan = plan_program(load_robot(), load_program(config_path('programs/example_robot_program.yaml')))
    cell = load_cell(CELL)
    report, clear, slip = check_program(plan, cell)
    wafer = [b for b in clear.pairs[0].bodies if b.startswith('wafer@')]
    assert wafer, clear.pairs[0].bodies
    fig = check_figure(clear, slip, report, None, plan_view(plan, cell))
    try:
        ax = fig.axes[2]
        red = [t.get_text() for t in ax.texts if t.get_color() == 'r']
        assert red == wafer
    finally:
        plt.close(fig)


def test_an_obstacle_named_like_an_arms_body_is_not_taken_for_the_arm():
    """The marker's arm was found by the body's name prefix: an obstacle ``arm2_rack`` (not a robot body's name, so
    allowed) closest to arm1 put the triangle on arm2's path."""
    from gpr_kinematics.safety.plot import _where_arm
    view = PlanView(outlines=(('arm2_rack', np.zeros((4, 2))),),
                    paths=(('arm1', np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([0.0, 1.0]), np.array([False, True])),
                           ('arm2', np.array([[5.0, 6.0]]), np.array([0.5]), np.array([False]))),
                    station_names=(), stations=np.zeros((0, 2)), arms=('arm1', 'arm2'))
    arm, at = _where_arm(view, ('arm1_link2', 'arm2_rack'), 0.9)
    assert arm == 'arm1' and at.tolist() == [3.0, 4.0]
    assert _where_arm(view, ('gpr_base', 'arm2_rack'), 0.5) == ('', None)


def test_an_arm_that_stays_where_it_starts_draws_no_path_and_no_legend_entry(tmp_path):
    """A program whose first step puts arm2 at its first waypoint and never moves it: arm2's path is that one sample,
    which drew nothing but two legend entries (its empty blade, carrying a wafer); arm1 keeps its colour (C0)."""
    import matplotlib.pyplot as plt
    from gpr_kinematics.safety.check import check_program
    from gpr_kinematics.safety.plot import check_figure
    program = tmp_path / 'stays.yaml'
    program.write_text(f'format: gpr_robot_program\nversion: 1\nrobot: {config_path("robots/example_robot.yaml")}\n'
                       'units: {length: mm, angle: deg}\ndefaults: {arm: arm1}\nstations:\n'
                       '  - {name: a, position: [750, 800, 420], heading: 90}\n'
                       '  - {name: b, position: [750, 850, 300], heading: 90}\n'
                       'steps:\n  - {move: a, arm: arm2, branch: right}\n  - {move: a}\n  - {move: b}\n')
    plan = plan_program(load_robot(), load_program(program))
    view = plan_view(plan, None)
    sizes = {a: len(xy) for a, xy, _, _ in view.paths}
    assert sizes['arm2'] == 1 and sizes['arm1'] > 1, sizes
    report, clear, slip = check_program(plan, None)
    fig = check_figure(clear, slip, report, program, view)
    try:
        labels = [line.get_label() for line in fig.axes[2].lines]
        assert not [x for x in labels if x.startswith('arm2')] and 'arm1: its wafer centre (empty blade)' in labels
        paths = ('arm1:', 'arm1 carrying')
        assert {line.get_color() for line in fig.axes[2].lines if line.get_label().startswith(paths)} == {'C0'}
    finally:
        plt.close(fig)

"""``gpr program check``'s "first below" is the pair's crossing of the margin to within ``crossing.RESOLUTION``
(1 us), against a dense sampling of the same distance (the collision library's, refined to a certified lower
bound, before its slack): every 1 ms over the whole program, then every 1 us over the millisecond where it first
reads below the margin. The cases: the cell example at a margin of 7 mm, arm2_link3 against pm1's front (the
search's own first instant below it read 16.114 s, 19.5 ms after the crossing), and at 20 mm arm1_blade against
arm2_link1, whose least distance (at 36.810 s) lies 2.5 s after its crossing (the search's first instant below the
margin was that of the least distance). The collision's step, station and label are those of the crossing; the
pair's certified least distance and its instant are the search's, unchanged."""
import json
import subprocess
import sys

import numpy as np
import pytest
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import load_robot
from gpr_kinematics.robot.plan import plan_program
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.safety import crossing
from gpr_kinematics.safety.cell import load_cell
from gpr_kinematics.safety.check import check_program, label_at, program_bodies
from gpr_kinematics.safety.distances import LIBRARY_SLACK, Exact, Store
from gpr_kinematics.safety.motion import PlanMotion

pytest.importorskip('fcl')

PROGRAM = config_path('programs/example_cell_program.yaml')
CELL = load_cell(config_path('cells/example_cell.yaml'))
PLAN = plan_program(load_robot(), load_program(PROGRAM))


def dense_crossing(bodies, margin, until):
    """The first instant of a 1 us sampling at which the pair ``bodies`` (never out of the program, no contact
    intended) is measured below ``margin``, within the first millisecond of a 1 ms sampling from 0 to ``until`` [s]
    that reads below it (the library's distance before its slack, as the check measures it) [s]."""
    every, pairs = program_bodies(PLAN, CELL)
    names = [b.name for b in every]
    a, b = names.index(bodies[0]), names.index(bodies[1])
    assert (a, b, ()) in pairs and not every[a].windows and not every[b].windows
    store = Store(PlanMotion(PLAN), every)
    exact = Exact(every, store)

    def distance(t):
        i = store.add(t)
        p = np.zeros(i.shape, dtype=np.int64)
        exact.measure(p, i, np.array([a]), np.array([b]))
        return exact.values(p, i)[0] + LIBRARY_SLACK

    coarse = np.arange(0.0, until, 1e-3)
    k = int(np.flatnonzero(distance(coarse) < margin)[0])
    fine = np.linspace(coarse[k - 1], coarse[k], 1001)
    below = fine[distance(fine) < margin]
    assert below.size and below[0] > fine[0]
    return float(below[0])


@pytest.mark.parametrize('margin, bodies, search', [
    (0.007, ('arm2_link3', 'pm1/front_bottom'), 16.1139),
    (0.02, ('arm1_blade', 'arm2_link1'), 36.8097),
], ids=['cell_example_7mm', 'least_distance_far_from_the_crossing'])
@pytest.mark.slow
def test_first_below_is_the_crossing_to_within_the_resolution(monkeypatch, margin, bodies, search):
    report, clear, _ = check_program(PLAN, CELL, margin)
    (c,) = [c for c in report.collisions if c.bodies == bodies]
    x = dense_crossing(bodies, margin, c.time + 0.002)   # an earlier crossing, or none there: a failure
    # the crossing lies in the microsecond before x; the check's instant is within RESOLUTION after it
    assert c.measured_below and x - 1e-6 - 1e-9 < c.time <= x + crossing.RESOLUTION + 1e-9, (c.time, x)
    assert crossing.RESOLUTION == 1e-6
    assert c.label == label_at(PLAN, x) and c.label.startswith(f'steps[{c.step}] (') and c.station in c.label
    pair = next(p for p in clear.pairs if p.bodies == bodies)
    assert pair.first_below == c.time
    # without the refinement (no rounds): the search's own first instant below the margin, far after the crossing;
    # the pair's certified least distance, its instant and what was measured there are the same either way
    monkeypatch.setattr(crossing, 'ROUNDS', 0)
    old, old_clear, _ = check_program(PLAN, CELL, margin)
    (o,) = [o for o in old.collisions if o.bodies == bodies]
    assert round(o.time, 4) == search and o.time - x > 0.019
    before = next(p for p in old_clear.pairs if p.bodies == bodies)
    assert (before.distance, before.time, before.measured) == (pair.distance, pair.time, pair.measured)
    assert (o.distance, o.measured) == (c.distance, c.measured)
    assert [p.bodies for p in old_clear.pairs] == [p.bodies for p in clear.pairs]
    assert old.pairs == report.pairs and old.min_clearance == report.min_clearance


@pytest.mark.slow
def test_the_json_collision_time_is_the_crossing():
    """``--json``'s collision ``time`` is the refined instant (16.0944 s), its step, station and label those of
    the crossing; the text table prints it to the millisecond."""
    report = check_program(PLAN, CELL, 0.007)[0]
    first = report.collisions[0]
    res = subprocess.run([sys.executable, '-m', 'gpr_kinematics', 'program', 'check', str(PROGRAM), '--margin',
                          '0.007', '--json'], capture_output=True, text=True, timeout=600)
    assert res.returncode == 1, res.stderr
    c = json.loads(res.stdout)['collisions'][0]
    assert (c['bodies'], c['time'], c['step'], c['station'], c['label'], c['measured_below']) == \
        (list(first.bodies), first.time, 5, 'pm1', first.label, True)
    assert round(c['time'], 4) == 16.0944 and first.label == label_at(PLAN, 16.0944)

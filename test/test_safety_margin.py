"""``gpr program check`` on pairs whose true minimum lies within the tolerance above the margin (a safety review's
cases): each is refined until its certified bound reaches the margin, so the check says safe, as the simulator's
goal check does on the same motion; a bound below the margin with nothing measured below it is "could not be shown
the margin apart", never a "first below" row."""
import json
import subprocess
import sys

import pytest
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import load_robot
from gpr_kinematics.robot.controller import ControllerJoints, Tolerances, plan_motion
from gpr_kinematics.robot.plan import plan_program
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.robot.trajectory import program_trajectory
from gpr_kinematics.safety.cell import load_cell
from gpr_kinematics.safety.check import check_program
from gpr_kinematics.safety.clearance import TOLERANCE
from gpr_kinematics.safety.goal import GoalClearance

pytest.importorskip('fcl')

ROBOT = load_robot()
HEAD = f'format: gpr_robot_program\nversion: 1\nrobot: {config_path("robots/example_robot.yaml")}\n'
#: A joint-space move past a post (true least distance 2.0500 mm, coal at 5 kHz: 1.999 mm "first below" before).
TURN = HEAD + """defaults: {arm: arm1, branch: right}
stations:
  - {name: A, position: [1.25, 0.5, 0.45], heading: 0.0}
  - {name: B, position: [0.75, 1.0, 0.55], heading: 1.5707963267948966, tilt: 0.0349, azimuth: 2.0}
steps:
  - {move: A}
  - {move: B}
"""
#: A pick, then a place through a straight entry of 0.3 m.
ENTRY = HEAD + """wafers: [S0]
defaults: {arm: arm1, branch: right, approach_height: 0.008, retract_height: 0.008}
stations:
  - {name: S0, position: [0.75, 1.05, 0.5], heading: 1.5707963267948966}
  - {name: S1, position: [1.5, 0.5, 0.5], heading: 0.0, entry: 0.30}
steps:
  - {pick: S0}
  - {place: S1}
"""
#: A joint-space move past a post 0.4 um from the blade's path.
PAST = HEAD + """defaults: {arm: arm1, branch: right}
stations:
  - {name: A, position: [1.25, 0.5, 0.5], heading: 0}
  - {name: B, position: [0.75, 1.0, 0.5], heading: 1.5707963267948966}
steps:
  - {move: A}
  - {move: B}
"""
CELL = 'format: gpr_cell\nversion: 1\nframe: world\nobstacles:\n'
POST_TURN = CELL + ('  - {name: post, cylinder: {radius: 0.002, length: 0.4}, position: [1.315447665, 0.718785968, '
                    '0.466107]}\n')
#: The post 2.040 mm from arm1_link2 on the place's move (1.989 mm "first below" before).
POST_LINK = CELL + ('  - {name: post, cylinder: {radius: 0.002, length: 0.02}, position: [1.150224525, 0.539349165, '
                    '0.4565]}\n')
#: A slit 0.1 mm wider than the wafer: 50 um each side (30 um "first below" at a margin of 40 um before).
POST_TOUCH = CELL + ('  - {name: post, cylinder: {radius: 0.002, length: 0.4}, position: [1.347698071, '
                     '0.582257788, 0.496613]}\n')
SLIT = CELL + """  - {name: left, box: [0.01, 0.24995, 0.3], position: [1.355, 0.224975, 0.5]}
  - {name: right, box: [0.01, 0.24995, 0.3], position: [1.355, 0.775025, 0.5]}
  - {name: bottom, box: [0.01, 0.3001, 0.128], position: [1.355, 0.5, 0.414]}
  - {name: top, box: [0.01, 0.3001, 0.132], position: [1.355, 0.5, 0.584]}
"""


def _files(tmp_path, program, cell):
    (tmp_path / 'p.yaml').write_text(program)
    (tmp_path / 'cell.yaml').write_text(cell)
    return tmp_path / 'p.yaml', tmp_path / 'cell.yaml'


def _goal(plan, cell, margin):
    """The simulator's goal check on the program as one goal (100 Hz points): None accepted, else its refusal."""
    traj = program_trajectory(plan, 100.0)
    joints = ControllerJoints.of(ROBOT)
    tol = Tolerances.uniform(len(joints.names), 0.0, 1e-3, 0.5)
    check = GoalClearance(ROBOT, cell, margin)
    return check(plan_motion(joints, traj, traj.positions[0], 100.0, ROBOT.config, tol, 1e-3))


@pytest.mark.parametrize('program, cell, margin, pair, truth', [
    (TURN, POST_TURN, 0.002, ('arm1_blade', 'post'), 2.0500e-3),
    (ENTRY, POST_LINK, 0.002, ('arm1_link2', 'post'), 2.0400e-3),
    (ENTRY, SLIT, 4e-5, ('arm1_wafer', 'right'), 5.0e-5),
], ids=['post_by_a_turn', 'post_by_a_link', 'slit'])
def test_a_pair_within_the_tolerance_above_the_margin_is_refined_to_it(tmp_path, program, cell, margin, pair,
                                                                          truth):
    """The certified bound reaches the margin and stays at most the tolerance below the true least distance; the
    goal check accepts the same motion."""
    path, cell_path = _files(tmp_path, program, cell)
    plan, cell = plan_program(ROBOT, load_program(path)), load_cell(cell_path)
    report, clear, _ = check_program(plan, cell, margin)
    assert report.safe and report.collisions == ()
    p = next(q for q in clear.pairs if q.bodies == pair)
    assert margin <= p.distance <= truth and truth - p.distance < TOLERANCE + 1e-6
    assert margin <= report.min_clearance
    assert _goal(plan, cell, margin) is None


def test_a_pair_below_the_margin_by_its_bounds_only_is_not_a_first_below(tmp_path):
    """At a margin of 0 the post 0.4 um from the blade cannot be certified (every measured distance keeps a 1 um
    slack): NOT safe, but nothing was measured below 0, so its row has no "first below" (it read 0.313 s, the first
    instant whose distance less the slack was negative) and says so; the JSON tells it; the goal check refuses the
    same motion with the same words."""
    path, cell_path = _files(tmp_path, PAST, POST_TOUCH)
    plan, cell = plan_program(ROBOT, load_program(path)), load_cell(cell_path)
    report, clear, _ = check_program(plan, cell, 0.0)
    (c,) = report.collisions
    assert not report.safe and (c.bodies, c.measured_below, c.time, c.step) == (('arm1_blade', 'post'), False, 0.5, 1)
    assert -TOLERANCE - 1e-6 < c.distance < c.measured < 0.0 < c.measured + 1e-6
    assert c.measured == clear.pairs[0].measured
    refusal = _goal(plan, cell, 0.0)
    assert refusal.startswith('arm1_blade and post could not be shown the margin apart: at least ')
    assert (f'{c.measured:.6g} m measured at t = 0.5 s (the library\'s distance less its slack of 1e-06 m) '
            '(time_from_start; cell ') in refusal
    res = subprocess.run([sys.executable, '-m', 'gpr_kinematics', 'program', 'check', str(path), '--cell',
                          str(cell_path), '--margin', '0'], capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert res.returncode == 1, res.stderr
    lines = res.stdout.splitlines()
    k = lines.index('  UNSAFE: 1 pair(s) below the margin:')
    assert lines[k + 2].split() == ['1', 'B', '-', 'arm1_blade', '/', 'post', f'{c.distance * 1e3:.3f}', '0.500']
    assert lines[k + 6] == (f'    arm1_blade / post could not be shown the margin apart: at least '
                            f'{c.distance * 1e3:.3f} mm by the bounds between samples, -0.001 mm measured at 0.500 s '
                            "(the library's distance less its slack of 1e-06 m)")
    assert lines[-1] == '  NOT safe (1 pair(s) could not be shown the margin apart, none measured closer)'
    res = subprocess.run([sys.executable, '-m', 'gpr_kinematics', 'program', 'check', str(path), '--cell',
                          str(cell_path), '--margin', '0', '--json'], capture_output=True, text=True, timeout=600)
    (row,) = json.loads(res.stdout)['collisions']
    assert (row['measured_below'], row['time'], row['measured'], row['distance']) == (False, 0.5, c.measured,
                                                                                        c.distance)

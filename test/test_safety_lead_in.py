"""``gpr program send``'s move from where the robot is to the program's start (``robot.trajectory.lead_in``), which
no program check sees: a program checked safe in its cell was sent from a robot standing elsewhere, and the move
drove arm2's blade 45 mm into a chamber's wall (the simulator with the cell refused it; a real controller has no
cell). The move is now checked in the program's cell, the wafers as they are at the program's start."""
import math
import re

import numpy as np
import pytest
from gpr_kinematics.errors import RobotStateError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import load_robot
from gpr_kinematics.robot.plan import plan_program
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.robot.trajectory import lead_in, program_trajectory
from gpr_kinematics.safety.check import at_the_start, wafer_plan

pytest.importorskip('fcl')

PROGRAM = config_path('programs/example_cell_program.yaml')
CELL_FILE = config_path('cells/example_cell.yaml')
PLAN = plan_program(load_robot(), load_program(PROGRAM))
RATE = 100.0
TRAJ = program_trajectory(PLAN, RATE)
#: An instant of the program with arm2's blade in pm1 (it places the wafer there at 16.6 s): a robot stopped there
#: and sent the program again moves straight in joint space down to the load port's height, through pm1's front.
IN_PM1 = 16.66


def _state_at(t: float) -> np.ndarray:
    return TRAJ.positions[int(np.searchsorted(TRAJ.time, t))].copy()


def test_the_move_to_the_start_through_a_chamber_is_refused_as_the_simulator_refuses_it():
    from gpr_kinematics.cli.program_trajectory import lead_in_keeps_clearance
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.goal import GoalClearance

    current = _state_at(IN_PM1)
    goal, start = lead_in(PLAN, TRAJ, current, RATE)
    assert start > 1.0
    with pytest.raises(RobotStateError) as exc:
        lead_in_keeps_clearance(PLAN, goal, start)
    m = re.fullmatch(r"the move from where the robot is to the program's start \((\d\.\d{3}) s, added by send\) is not "
                     r'safe in cell (\S+): arm2_blade and (pm1/\w+) come to (-?\d+\.\d{3}) mm at t = (\d\.\d{3}) s of '
                     r"the move, within the margin of 2 mm; allowed: a robot whose joint-space line to the program's "
                     r'first point keeps the margin \(move it clear first, or start the program where it is\)',
                     str(exc.value))
    assert m, exc.value
    assert float(m[1]) == pytest.approx(start, abs=5e-4) and m[2].endswith('example_cell.yaml')
    assert float(m[4]) < 2.0 and 0.0 <= float(m[5]) <= start
    # The simulator's own check of a goal (no wafers, the same joint-space line) finds the same pair below the margin
    simulator = GoalClearance(PLAN.robot, load_cell(CELL_FILE))
    below = {p.bodies for p in simulator.line(current, TRAJ.positions[0]).below_margin}
    assert ('arm2_blade', m[3]) in below or (m[3], 'arm2_blade') in below, below


@pytest.mark.parametrize('t', [0.0, 30.0])
def test_a_move_clear_of_the_cell_and_no_move_at_all_pass(t):
    """From the program's first point (no move) and from an instant with the arm retracted (the move keeps the
    margin: the simulator's check agrees)."""
    from gpr_kinematics.cli.program_trajectory import lead_in_keeps_clearance
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.goal import GoalClearance

    current = _state_at(t)
    goal, start = lead_in(PLAN, TRAJ, current, RATE)
    assert (start == 0.0) == (t == 0.0)
    lead_in_keeps_clearance(PLAN, goal, start)
    assert not GoalClearance(PLAN.robot, load_cell(CELL_FILE)).line(current, TRAJ.positions[0]).below_margin


def test_the_move_keeps_the_margin_it_is_given():
    """``send --margin``: the move from an instant with the arm retracted, whose least distance the refusal at 1 m
    names (a lower bound within its tolerance: 5 % of its excess over 20 mm), passes 10 um below it and is refused
    5 mm above it, naming the margin."""
    from gpr_kinematics.cli.program_trajectory import lead_in_keeps_clearance

    goal, start = lead_in(PLAN, TRAJ, _state_at(30.0), RATE)
    with pytest.raises(RobotStateError, match='within the margin of 1000 mm') as exc:
        lead_in_keeps_clearance(PLAN, goal, start, 1.0)
    least = float(re.search(r'come to ([\d.]+) mm', str(exc.value))[1]) / 1000.0
    assert 0.002 < least < 1.0
    lead_in_keeps_clearance(PLAN, goal, start, least - 1e-5)
    with pytest.raises(RobotStateError, match=rf'within the margin of {(least + 0.005) * 1000:g} mm'):
        lead_in_keeps_clearance(PLAN, goal, start, least + 0.005)

def test_the_wafers_are_taken_as_at_the_programs_start_throughout():
    """The example program starts with its wafer lying at load_port_1 and both blades empty: that wafer lies there
    for the whole move, the wafers the program places later are not there, and no arm carries one."""
    wafers = at_the_start(wafer_plan(PLAN))
    assert wafers.carried == {'arm1': (), 'arm2': ()}
    assert dict((name, w) for name, _, w in wafers.stations) == {
        'wafer@load_port_1:start': ((0.0, math.inf),), 'wafer@pm1:steps[5]': ((math.inf, math.inf),),
        'wafer@pm2:steps[9]': ((math.inf, math.inf),), 'wafer@load_port_1:steps[14]': ((math.inf, math.inf),)}
    assert wafers.contact == {}
    # a program starting with arm2's blade under the load port's wafer: carried from the start; its contact there is
    # not left out of the whole move (the blade could sweep through the wafer on the way)
    later = wafer_plan(PLAN)
    shifted = type(later)({'arm1': (), 'arm2': ((0.0, 5.0),)}, later.stations,
                          {('arm2', 'load_port_1'): ((0.0, 1.0),), ('arm2', 'pm1'): ((2.0, 3.0),)})
    start = at_the_start(shifted)
    assert start.carried == {'arm1': (), 'arm2': ((0.0, math.inf),)}
    assert start.contact == {}


def test_a_program_without_a_cell_has_its_move_checked_against_the_robot_itself():
    """The example robot program has no cell: the move to its start was not checked at all. A robot stopped with
    arm1's blade where the program starts with a wafer lying (load_port_1, picked at 4 s) sweeps through that wafer on
    the way; from an instant with both arms clear the move passes."""
    from gpr_kinematics.cli.program_trajectory import lead_in_keeps_clearance

    plan = plan_program(load_robot(), load_program(config_path('programs/example_robot_program.yaml')))
    assert plan.program.cell is None
    traj = program_trajectory(plan, RATE)
    for t, refused in ((4.0, True), (15.0, False)):
        current = traj.positions[int(np.searchsorted(traj.time, t))].copy()
        goal, start = lead_in(plan, traj, current, RATE)
        assert start > 1.0
        if not refused:
            lead_in_keeps_clearance(plan, goal, start)
            continue
        with pytest.raises(RobotStateError) as exc:
            lead_in_keeps_clearance(plan, goal, start)
        m = re.fullmatch(r"the move from where the robot is to the program's start \(\d\.\d{3} s, added by send\) is "
                         r'not safe against the robot itself \(no cell\): arm1_blade and wafer@load_port_1:start come '
                         r'to (-?\d+\.\d{3}) mm at t = \d\.\d{3} s of the move, within the margin of 2 mm; .*',
                         str(exc.value))
        assert m and float(m[1]) < 0.0, exc.value

"""docs/robot.md's quoted outputs and numbers are what the commands give: `gpr robot ik`'s sample output (its
rounding-level residual to 1e-15), `gpr program export --trajectory t.yaml --rate 5` (its output, 144 points, the file's
size to 1 %: the last digit of a number, and so the size by a few bytes, depends on the machine's rounding) and
`gpr program send`'s sample output, derived without ROS as send and robot_simulator_node build it: the program's
trajectory at send's default rate, the lead-in from the simulator's rest state, the simulator's samples at its rate
(test_ros_program_send.py runs send itself); docs/cell.md's table of S-curve and trapezoid durations."""
import math
import re
from pathlib import Path

import numpy as np
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.controller import ControllerJoints
from gpr_kinematics.robot.plan import plan_program
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.robot.trajectory import lead_in, program_trajectory
from robot_support import ROBOT
from test_core_cli import run

DOC = (Path(__file__).resolve().parents[1] / 'docs' / 'robot.md').read_text(encoding='utf-8')
#: The doc's text with its lines joined (a sentence may wrap).
TEXT = ' '.join(DOC.split())
PROGRAM = 'gpr_kinematics/config/programs/example_robot_program.yaml'
SEND_RATE = 100.0    # gpr program send --rate's default
SIM_RATE = 100.0     # robot_simulator_node's rate parameter's default


def _block(command):
    """The output lines the doc quotes under ``$ command`` (up to the next ``$`` line or the block's end)."""
    lines = DOC.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith(f'$ {command}'))
    out = []
    for ln in lines[k + 1:]:
        if ln.startswith(('$ ', '```')):
            break
        out.append(ln)
    return out


def _assert_quoted(quoted, output):
    """Every quoted line (``...``: lines left out) is a line of ``output``, in order."""
    lines = output.splitlines()
    at = 0
    for q in quoted:
        if q.strip() == '...':
            continue
        assert q in lines[at:], (q, output)
        at = lines.index(q, at) + 1


def _in_repo_layout(tmp_path, monkeypatch):
    """Run in ``tmp_path`` with the package's config folder where the doc's paths name it."""
    (tmp_path / 'gpr_kinematics').mkdir()
    (tmp_path / 'gpr_kinematics' / 'config').symlink_to(config_path('.'), target_is_directory=True)
    monkeypatch.chdir(tmp_path)


def test_robot_ik_output(capsys):
    command = 'gpr robot ik --position 1300 600 450 --tilt 1.2 --azimuth 30 --heading 20 --mm --deg'
    quoted = _block(command)
    status, out, err = run(capsys, *command.split()[1:])
    assert status == 0, err
    # the residuals of the last line are rounding: they may differ on another machine (the doc says so)
    residual = re.compile(r'reached to (\S+) m and (\S+) rad')
    m = residual.search(out)
    assert m and float(m[1]) < 1e-15 and float(m[2]) < 1e-14
    _assert_quoted([residual.sub('reached to R', q) for q in quoted], residual.sub('reached to R', out))
    assert 'reached to 2.2e-16 m and 1.0e-15 rad' in TEXT


def test_program_export_trajectory_at_5_hz(capsys, tmp_path, monkeypatch):
    _in_repo_layout(tmp_path, monkeypatch)
    command = f'gpr program export {PROGRAM} --trajectory t.yaml --rate 5'
    status, out, err = run(capsys, *command.split()[1:])
    assert status == 0, err
    _assert_quoted(_block(command), out)
    size = (tmp_path / 't.yaml').stat().st_size
    points = (tmp_path / 't.yaml').read_text().count('time_from_start')
    assert points == 144 and '(`--rate 5`: 144 points, 52 kB for the example program)' in TEXT
    assert round(size / 1000) == 52
    quoted = re.search(r'at `--rate 5` (\d+) points, ([\d,]+) bytes here', TEXT)
    assert quoted and int(quoted[1]) == points and abs(int(quoted[2].replace(',', '')) - size) <= 0.01 * size
    assert 'The program lasts 28.528 s (`check`, `export`)' in TEXT and ', 28.528 s; every waypoint' in out


def test_program_send_output_as_send_builds_its_goal():
    """The goal send makes on a simulator at rest, the progress lines it prints (one per 5 s of the feedback's times,
    and the last point's) and the simulator's result, against the doc's sample output and its numbers."""
    plan = plan_program(ROBOT, load_program(str(config_path('programs/example_robot_program.yaml'))))
    traj = program_trajectory(plan, SEND_RATE)
    joints = ControllerJoints.of(ROBOT)
    rest = np.array([joints.rest[joints.names.index(n)] for n in traj.joint_names])
    goal, start = lead_in(plan, traj, rest, SEND_RATE)
    expected = [f'sending {len(goal)} points over {len(goal.joint_names)} joints, {goal.duration:.3f} s ({start:.3f} '
                "s from where the robot is to the program's start) to "
                '/joint_trajectory_controller/follow_joint_trajectory']   # the full name, as send resolves it
    # robot_simulator_node's samples (robot.controller.plan_motion) of the goal it received, times in whole
    # nanoseconds; a feedback per sample, its desired time as send reads it
    ns = round(goal.duration * 1e9)
    duration = ns // 10**9 + (ns % 10**9) * 1e-9
    t = np.arange(int(math.floor(duration * SIM_RATE + 1e-9)) + 1, dtype=float) / SIM_RATE
    if duration - t[-1] > 1e-9:
        t = np.append(t, duration)
    following = 0.0
    for tk in t:
        k = round(float(tk) * 1e9)
        tf = k // 10**9 + (k % 10**9) * 1e-9
        if tf >= following or tf >= goal.duration:
            expected.append(f'  t = {tf:8.3f} s of {goal.duration:.3f} s, largest error 0')
            following = tf + 5.0
    expected.append(f'succeeded (error_code 0 SUCCESSFUL): reached the last point at t = {t[-1]:.6g} s ({len(t)} '
                    'samples)')
    assert _block(f'gpr program send {PROGRAM} --progress 5') == expected
    assert (len(traj), len(goal), round(start * SEND_RATE)) == (2854, 3006, 152)
    assert f'{SEND_RATE:g} Hz: {len(traj)} points' in TEXT.replace('(default 100 Hz:', '100 Hz:')
    assert f'to the program\'s start, {start:.2f} s ({round(start * SEND_RATE)} periods): {len(goal)} points over ' \
           f'{goal.duration:.3f} s' in TEXT


def test_the_s_curve_and_trapezoid_table_of_docs_cell_md():
    """Issue 19's "program duration compared with the trapezoid timing in the docs": docs/cell.md's table (each
    program's duration with S-curves, with trapezoids of the same limits and no jerk limit, and the ratio of their
    moving times) is what the planner gives, to its printed digits."""
    import dataclasses

    doc = (Path(__file__).resolve().parents[1] / 'docs' / 'cell.md').read_text(encoding='utf-8')
    trap = dataclasses.replace(ROBOT, rods=dataclasses.replace(ROBOT.rods, jerk=None), arms=tuple(
        dataclasses.replace(a, joints=tuple(dataclasses.replace(j, jerk=None) for j in a.joints)) for a in ROBOT.arms))
    for name in ('example_robot_program', 'example_cell_program'):
        row = re.search(rf'^\| `{name}\.yaml` \| ([\d.]+) s \| ([\d.]+) s \| ([\d.]+) \|$', doc, re.M)
        assert row, f'docs/cell.md: the row of {name}.yaml'
        program = load_program(config_path(f'programs/{name}.yaml'))
        s_curve, trapezoid = plan_program(ROBOT, program).timing, plan_program(trap, program).timing
        assert np.all(np.isinf(trapezoid.jerk)) and np.all(np.isfinite(s_curve.jerk))
        ratio = float(np.sum(s_curve.duration) / np.sum(trapezoid.duration))
        assert [float(v) for v in row.groups()] == [round(s_curve.total, 2), round(trapezoid.total, 2),
                                                     round(ratio, 3)], name

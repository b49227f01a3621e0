"""``gpr accuracy``: the accuracy budget of the GPR (a pose, a platform program) and of the whole robot at the wafer
(gpr_kinematics.calibration.stations, cli_accuracy), against independent computations through the core and the
robot's forward kinematics; the mechanism analysis printing the numbers of its JSON (the GPR's horizontal motion
included); every bad combination of options answered with exit 2 and one line."""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from gpr_kinematics.calibration.stations import BudgetOptions, platform_budget, robot_stations
from gpr_kinematics.calibration.tolerances import load_tolerances, parse_tolerances
from gpr_kinematics.cli.main import main
from gpr_kinematics.core import inverse_batch
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.machine import config_with_parameters, parameter_vector
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.inputs.safe_yaml import read_file
from gpr_kinematics.robot.description import load_robot
from gpr_kinematics.robot.forward import robot_forward
from gpr_kinematics.robot.program import load_program

TABLE = str(config_path('calibration/tolerances_example.yaml'))
ROBOT_PROGRAM = str(config_path('programs/example_robot_program.yaml'))
PLATFORM_PROGRAM = str(config_path('programs/example_stations.yaml'))


def run(capsys, *argv):
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def test_mechanism_analysis_prints_what_its_json_holds(capsys):
    """The GPR's joint imperfections move the platform sideways (an outcome, not a pose variable): the text prints
    the rigid motion -66.6 um in y of joint 1 moved 0.1 mm tangentially as the JSON has it, and every other number of
    the JSON; moved radially, the radial virtual joint takes it up whole (it read -33.3 um, a third of it)."""
    argv = ['accuracy', 'gpr.yaml', '--pose', '0', '0', '0.5', '0.0349', '0', '0', '--parameter-error',
            'joint_imperfections', '0', '1e-4', '0', '0', '0', '0', '0', '0', '0']
    for case in (argv, ['accuracy', 'stewart_alwan.yaml']):
        status, text, _ = run(capsys, *case)
        assert status == 0
        status, out, _ = run(capsys, *case, '--json')
        d = json.loads(out)
        rows = re.findall(r'^ *(\d*) +(linearized|exact|difference)((?: +-?\d\.\d{4}e[-+]\d\d)+)$', text, re.M)
        k = 0
        for r in d['results']:
            for label in ('linearized', 'exact', 'difference'):
                assert rows[k][1] == label
                np.testing.assert_allclose([float(x) for x in rows[k][2].split()],
                                           [r[label][v] for v in d['variables']], rtol=5e-5, atol=1e-300)
                k += 1
        for r in d['results']:
            for label in ('linearized', 'exact'):
                assert rows[k][1] == label
                np.testing.assert_allclose([float(x) for x in rows[k][2].split()], r[f'{label}_twist'], rtol=5e-5,
                                           atol=1e-300)
                k += 1
        assert k == len(rows)
    assert d['results'][0]['exact_twist'][0] != 0.0
    gpr = json.loads(run(capsys, *argv, '--json')[1])['results'][0]
    assert gpr['exact_twist'][1] == pytest.approx(-6.6646e-05, rel=1e-4)    # about two thirds of the 0.1 mm
    assert re.search(r'^ +1 +linearized +\S+ +-6\.6646e-05 ', run(capsys, *argv)[1], re.M)
    radial = argv[:-9] + ['1e-4'] + ['0'] * 8
    assert json.loads(run(capsys, *radial, '--json')[1])['results'][0]['exact_twist'][:3] == pytest.approx(
        [0, 0, 0], abs=1e-14)


def test_gpr_pose_budget(capsys):
    """The budget of one platform pose: the rods of the core's inverse kinematics (compliant model), the numbers of
    the library call, the printed numbers those of the JSON."""
    argv = ['accuracy', 'gpr.yaml', '--tolerances', TABLE, '--pose', '0', '0', '500', '2', '0', '0', '--mm', '--deg',
            '--tool', '300', '0', '100', '--samples', '500', '--seed', '3']
    status, out, err = run(capsys, *argv, '--json')
    assert status == 0, err
    d = json.loads(out)
    cfg = load_config()
    q = inverse_batch(0.5, math.radians(2.0), 0.0, cfg, 'compliant').q[0]
    (station,) = d['stations']
    np.testing.assert_allclose(station['q'], q, rtol=0, atol=1e-15)
    assert station['tool'] == pytest.approx([0.3, 0.0, 0.1], abs=1e-15) and d['model'] == 'compliant'
    b = platform_budget(cfg, load_tolerances(TABLE), 0.5, math.radians(2.0), 0.0, (0.3, 0.0, 0.1),
                        options=BudgetOptions(samples=500, seed=3))
    for name, qd in station['quantities'].items():
        assert qd['rss'] == pytest.approx(b.rss[name][0], rel=1e-12)
        assert qd['monte_carlo']['p95'] == pytest.approx(b.mc[name][0, 1], rel=1e-12)
    assert set(d['sources']) >= {'rod1_offset', 'kappa3', 'rod_length2', 'joint_clearance1'}
    status, text, _ = run(capsys, *argv)
    row = re.search(r'^  tool horizontal +um +(\d+\.\d{3}) +(\d+\.\d{3}) +(\d+\.\d{3}) +(\d+\.\d{3}) +(\d+\.\d{3})',
                    text, re.M)
    tool = station['quantities']['tool_horizontal']
    np.testing.assert_allclose([float(row.group(i)) for i in range(1, 6)],
                               np.array([tool['rss'], tool['worst'], *tool['monte_carlo'].values()][:5]) * 1e6,
                               atol=5.1e-4)
    assert 'height 0.5 m, tilt 0.0349066 rad' in text


def test_platform_program_and_a_calibration_plan(capsys, tmp_path):
    """A platform program gives one budget per station; a planned calibration (the table's measurement noise)
    replaces the calibrated parameters' tolerances by the plan's covariance: smaller errors."""
    status, out, err = run(capsys, 'accuracy', PLATFORM_PROGRAM, '--tolerances', TABLE, '--samples', '0', '--json')
    assert status == 0, err
    before = json.loads(out)
    assert [s['label'] for s in before['stations']] == ['load', 'station_a', 'station_b', 'unload']
    np.testing.assert_allclose([s['q'] for s in before['stations']],
                               inverse_batch([0.3, 0.45, 0.4, 0.3], [0.0, 0.02617993877991494, 0.017453292519943295,
                                                                     0.0], [0.0, 0.7853981633974483,
                                                                            -2.356194490192345, 0.0],
                                             load_config(), 'compliant').q, rtol=0, atol=1e-15)
    status, out, err = run(capsys, 'accuracy', PLATFORM_PROGRAM, '--tolerances', TABLE, '--samples', '0',
                           '--calibration-plan', '40', '--json')
    assert status == 0, err
    after = json.loads(out)
    assert 'calibration' in after['sources'] and 'rod1_offset' not in after['sources']
    for b, a in zip(before['stations'], after['stations'], strict=True):
        for name in ('platform_vertical', 'tilt', 'tool_vertical'):
            assert a['quantities'][name]['rss'] < 0.5 * b['quantities'][name]['rss']


def test_robot_program_budget_at_the_wafer(capsys):
    """Each station the example program visits, with its arm; the tool point is the wafer centre on the platform
    and the errors are in the world's axes: a zero offset's effect checked against central differences of the whole
    robot's forward kinematics on perturbed machines."""
    # the stations solved under the budget's model (compliant by default), as for a platform program
    robot, program = load_robot(model='compliant'), load_program(ROBOT_PROGRAM)
    st = robot_stations(robot, program)
    assert st.labels == ('home (arm1)', 'load_port_1 (arm1)', 'aligner (arm1)', 'chamber_a (arm1)',
                         'chamber_b (arm2)', 'load_port_1 (arm2)')
    status, out, err = run(capsys, 'accuracy', ROBOT_PROGRAM, '--tolerances', TABLE, '--samples', '300', '--json')
    assert status == 0, err
    d = json.loads(out)
    assert d['frame'] == robot.world_frame and [s['label'] for s in d['stations']] == list(st.labels)
    np.testing.assert_allclose([s['tool'] for s in d['stations']], st.wafer, rtol=0, atol=1e-15)
    # An independent path: the wafer in the world through robot_forward of machines with rod 2's offset moved.
    table = parse_tolerances({'parameters': {'rod2_offset': {'tolerance': 3e-5}}})
    from gpr_kinematics.calibration.stations import robot_budget
    b = robot_budget(robot, program, table, BudgetOptions(samples=0))
    way = [('home', 'arm1', [0]), ('chamber_b', 'arm2', [4])]
    for name, arm, (i,) in way:
        from gpr_kinematics.robot import solve_stations
        from gpr_kinematics.robot.program import expand
        w = expand(program, robot)
        j = [k for k in range(len(w)) if w.stations.names[k] == name and w.arm[k] == arm][0]
        sol = solve_stations(robot, w.stations.take([j]), arm=arm, branch=[w.branch[j]])
        h = 1e-7
        wafers = []
        for dh in (h, -h):
            cfg = config_with_parameters(robot.config.replace(model='compliant'),
                                         parameter_vector(robot.config, ['rod2_offset']) + dh, ['rod2_offset'])
            wafers.append(robot_forward(load_robot(geometry=cfg), sol.rods, sol.joints, arm,
                                        check_limits=False).wafer.position[0])
        dwafer = (wafers[0] - wafers[1]) / (2 * h)
        np.testing.assert_allclose(b.std[i, 6:9], np.abs(dwafer) * 3e-5 / math.sqrt(3), rtol=1e-5, atol=1e-12)


def test_bad_combinations_exit_2_with_one_line(capsys, tmp_path):
    pose = ['--pose', '0', '0', '0.3', '0.01', '0', '0']
    # a program whose pick finds no wafer: refused by every command that plans it, and budgeted before
    data = read_file(ROBOT_PROGRAM)
    disorder = tmp_path / 'no_wafer.yaml'
    robot_file = str(Path(ROBOT_PROGRAM).parent / data['robot'])
    disorder.write_text(yaml.safe_dump({**data, 'wafers': [], 'robot': robot_file}))
    cases = [
        (['accuracy', 'gpr.yaml', *pose, '--samples', '10'], r'--samples belongs to the accuracy budget: give '
                                                             r'--tolerances TABLE'),
        (['accuracy', 'gpr.yaml', *pose, '--tool', '0', '0', '0', '--config', 'x.yaml'],
         r'--tool, --config belong to the accuracy budget'),
        (['accuracy', 'gpr.yaml', *pose, '--tolerances', TABLE, '--errors', '0', '0', '0'],
         r'--errors and --parameter-error belong to the mechanism analysis'),
        (['accuracy', 'stewart_alwan.yaml', '--tolerances', TABLE], r'the accuracy budget is made for the GPR'),
        (['accuracy', 'gpr.yaml', '--tolerances', TABLE], r'give --pose X Y Z A B C'),
        (['accuracy', ROBOT_PROGRAM, '--tolerances', TABLE, '--tool', '0', '0', '0'], r"--tool: a robot program's tool "
                                                                                      r'point is the wafer centre'),
        (['accuracy', ROBOT_PROGRAM, '--tolerances', TABLE, *pose], r'a program gives its stations'),
        (['accuracy', str(disorder), '--tolerances', TABLE],
         r'no_wafer\.yaml: steps\[\d+\] \(pick \w+, at\): station \w+ holds no wafer \(the program declares '
         r'wafers: \[\]\)'),
        (['accuracy', ROBOT_PROGRAM, '--tolerances', TABLE, '--mm'], r'--mm with a program: it says its own units'),
        (['accuracy', 'example_stations.yaml', '--tolerances', TABLE, '--deg'], r'--deg with a program'),
        # without --tolerances a program read as 'mechanism file ... not found' (a packaged bare name) or 'type = None'
        (['accuracy', 'example_robot_program.yaml'], r'example_robot_program\.yaml: a whole-robot program: its '
                                                     r'accuracy budget needs --tolerances TABLE'),
        (['accuracy', ROBOT_PROGRAM], r'a whole-robot program: its accuracy budget needs --tolerances TABLE'),
        (['accuracy', 'example_stations.yaml'], r'a platform program: its accuracy budget needs --tolerances TABLE'),
        (['accuracy', 'gpr.yaml', *pose, '--tolerances', TABLE, '--robot', 'example_robot.yaml'],
         r'--robot goes with a robot program'),
        # the whole range, not '>= 0' (1000001 is refused as well)
        (['accuracy', 'gpr.yaml', *pose, '--tolerances', TABLE, '--samples', '-1'],
         r'--samples = -1; allowed: an integer from 0 to 1000000$'),
        (['accuracy', 'gpr.yaml', *pose, '--tolerances', TABLE, '--seed', '-1'],
         r'--seed = -1; allowed: an integer from 0 to 2\*\*63 - 1$'),
        (['accuracy', 'gpr.yaml', *pose, '--tolerances', TABLE, '--samples', '2000000'],
         r'samples = 2000000; allowed: an integer from 0 to 1000000'),
        (['accuracy', 'gpr.yaml', *pose, '--tolerances', TABLE, '--calibration-plan', '0'],
         r'--calibration-plan = 0; allowed: a positive number of configurations'),
        (['accuracy', 'gpr.yaml', *pose, '--tolerances', TABLE, '--calibration-plan', '5000'], r'plan size 5000'),
        (['accuracy', 'gpr.yaml', '--pose', '0', '0', '0.3', '0.1', '0', '0', '--tolerances', TABLE],
         r'beyond the tilt limit'),
        (['accuracy', 'gpr.yaml', *pose, '--tolerances', str(tmp_path / 'none.yaml')], r'none\.yaml'),
        (['accuracy', 'gpr.yaml', *pose, '--tolerances', TABLE, '--config', str(tmp_path / 'none.yaml')],
         r'none\.yaml'),
    ]
    bad_table = tmp_path / 'bad.yaml'
    bad_table.write_text('parameters: {radius: {tolerance: 1.0e-5}}\n')
    cases.append((['accuracy', 'gpr.yaml', *pose, '--tolerances', str(bad_table)], r"unknown parameter 'radius'"))
    for argv, pattern in cases:
        status, out, err = run(capsys, *argv)
        assert status == 2, (argv, out, err)
        assert err.count('\n') == 1 and 'Traceback' not in err, (argv, err)
        assert re.search(pattern, err), (argv, err)


def test_a_table_without_error_sources_is_refused(capsys, tmp_path):
    """parameters: {} (or only zero tolerances) and no rod_length or joint_clearance printed a budget of 0.000 um
    everywhere, exit 0; it is refused naming the file and what is allowed. The same table with a planned calibration
    (its measurement noise only, as gpr calibrate --tolerances takes it) is a budget: the calibration's."""
    pose = ['--pose', '0', '0', '0.3', '0.02', '0', '0']
    empty, zero = tmp_path / 'empty.yaml', tmp_path / 'zero.yaml'
    empty.write_text('parameters: {}\nmeasurement_noise: {position: 3.0e-6, angle: 2.0e-5}\n')
    zero.write_text('parameters: {rod_offsets: {tolerance: 0}}\n')
    allowed = (r"every error would be 0; allowed: a table with at least one of a parameter's tolerance > 0 or range "
               r'\(e\.g\. parameters: \{rod_offsets: \{tolerance: 5\.0e-5\}\}\), rod_length, joint_clearance, or a '
               r'calibration \(--calibration-plan N\)$')
    for table, what in ((empty, r'parameters: \{\}'), (zero, 'no tolerance above 0 in parameters')):
        status, out, err = run(capsys, 'accuracy', 'gpr.yaml', *pose, '--tolerances', str(table), '--samples', '10')
        assert status == 2 and not out and err.count('\n') == 1, err
        assert re.match(rf'gpr accuracy: error: {re.escape(str(table))}: no error source for the accuracy budget '
                        rf'\({what}, no rod_length, no joint_clearance\): {allowed}', err), err
    status, out, err = run(capsys, 'accuracy', 'gpr.yaml', *pose, '--tolerances', str(empty), '--samples', '0',
                           '--calibration-plan', '12', '--json')
    assert status == 0, err
    horizontal = json.loads(out)['stations'][0]['quantities']['platform_horizontal']
    assert horizontal['shares'] == {'calibration': 1.0}
    assert horizontal['rss'] == pytest.approx(1.3178e-6, rel=1e-3)     # the 12-pose plan's covariance alone


def test_a_calibrated_file_is_the_budgets_nominal(capsys, tmp_path):
    """--config replaces the geometry: the rods of a pose are then those of the calibrated machine."""
    cfg = config_with_parameters(load_config(), [4e-5, 3.0, 3.0, 3.0], ['rod1_offset', 'kappa1', 'kappa2', 'kappa3'])
    path = tmp_path / 'cal.yaml'
    from gpr_kinematics.calibration.core_model import write_calibrated_config
    write_calibrated_config(path, cfg.replace(model='compliant'))
    status, out, err = run(capsys, 'accuracy', 'gpr.yaml', '--pose', '0', '0', '0.3', '0.02', '0.01', '0',
                           '--tolerances', TABLE, '--config', str(path), '--samples', '0', '--json')
    assert status == 0, err
    q = json.loads(out)['stations'][0]['q']
    np.testing.assert_allclose(q, inverse_batch(0.3, math.hypot(0.02, 0.01), math.atan2(0.01, 0.02), cfg,
                                                'compliant').q[0], rtol=0, atol=1e-15)
    # the geometry is named (a budget before and one after a calibration could not be told apart), in the text too
    assert json.loads(out)['config'] == str(path)
    status, out, err = run(capsys, 'accuracy', 'gpr.yaml', '--pose', '0', '0', '0.3', '0.02', '0.01', '0',
                           '--tolerances', TABLE, '--config', str(path), '--samples', '0')
    assert status == 0 and f'; geometry {path}; tolerances ' in out.splitlines()[0], out
    # the calibrated file given as the mechanism: told where it goes
    status, out, err = run(capsys, 'accuracy', str(path), '--pose', '0', '0', '0.3', '0.02', '0.01', '0',
                           '--tolerances', TABLE)
    assert status == 2 and err.rstrip().endswith('(a GPR geometry file: give it as --config FILE, with the mechanism '
                                                 'gpr.yaml)'), err


def test_a_worst_case_of_zero_is_compared_in_absolute_numbers(capsys, tmp_path):
    """The zero offsets alone at zero tilt move the platform horizontally to second order only: its linearised worst
    case is 0, the samples' largest error 0.01 um. gpr accuracy printed numpy's RuntimeWarning (divide by zero) and
    warned it 'exceeds the linearised worst case 0 um by inf %'. Against a worst case of 0 the difference is judged
    absolutely (beyond 0.1 um: budget.NONLINEAR_FLOOR), no numpy warning escapes, and a warned difference (1 mm
    offsets: 4.17 um) is stated in micrometres. So is the linearised RSS of 0 against the samples' RMS: 0.0038 um
    was warned 'differ by 100 % (more than 10 %)', and is not; 1.528 um is, in micrometres."""
    import warnings

    argv = ['accuracy', 'gpr.yaml', '--pose', '0', '0', '0.3', '0', '0', '0', '--samples', '1000']
    for tolerance, warned, rms in (('5.0e-5', '', ''), ('1.0e-3', '4.17 um', '1.528 um')):
        table = tmp_path / f'{tolerance}.yaml'
        table.write_text(f'parameters:\n  rod_offsets: {{tolerance: {tolerance}}}\n')
        with warnings.catch_warnings():
            warnings.simplefilter('error')
            status, out, err = run(capsys, *argv, '--tolerances', str(table))
        assert status == 0 and 'inf %' not in out and 'RuntimeWarning' not in err, (out, err)
        beyond = [ln for ln in out.splitlines() if 'exceeds the linearised worst case' in ln]
        if not warned:
            assert 'warning' not in out + err, (out, err)
            continue
        differ = [ln for ln in out.splitlines() if 'differ by' in ln]
        assert len(differ) == 2 and all(f'the linearised RSS 0 um and the Monte Carlo RMS {rms} differ by {rms} (more '
                                        'than 0.1 um)' in ln for ln in differ), differ
        assert len(beyond) == 2 and all(f"bounds {warned} exceeds the linearised worst case 0 um by {warned} (more "
                                        'than 0.1 um): the model is not linear' in ln for ln in beyond), beyond

"""The ``gpr`` command line from a folder that is not the repository: a file argument of a kind the package ships
examples of (a robot description, a program, a cell, a tolerance table, a measurement file) may be the bare name of
a packaged file (:func:`gpr_kinematics.inputs.resources.packaged_file`, the rule of the mechanism files). The
commands the docs give with repository paths print the docs' numbers with the bare names; a path with a folder is
read as given (a mistyped folder is an error naming the packaged name, never silently the packaged file); a local
file of the same name wins; the nodes' inputs do not take the rule (a ``gpr/run_program`` goal names a file under
the folders its operator allowed, and nothing else)."""
from __future__ import annotations

import json
import re
from pathlib import Path
from types import SimpleNamespace

import pytest
from gpr_kinematics.cli.main import build_parser
from gpr_kinematics.cli.options import resolve_shipped
from gpr_kinematics.errors import FileError
from gpr_kinematics.inputs.resources import (
    CELLS,
    MEASUREMENTS,
    MECHANISMS,
    PROGRAMS,
    ROBOTS,
    TOLERANCES,
    config_path,
    packaged_file,
)
from gpr_kinematics.robot.description import load_robot
from gpr_kinematics.safety.cell import load_cell
from test_calibration_cli import _assert_quoted_output
from test_core_cli import run

ROOT = Path(__file__).resolve().parents[1]
ROD = ['--rods', '0.3', '0.3', '0.3', '--joints', '0', '0', '0']
#: (argv, the parsed argument, the packaged file its bare name names): every file option of the command line whose
#: kind the package ships.
OPTIONS = [
    (['robot', 'fk', *ROD, '--robot', 'example_robot.yaml'], 'robot', 'robots/example_robot.yaml'),
    (['robot', 'ik', '--position', '1', '0', '0.5', '--robot', 'example_robot.yaml'], 'robot',
     'robots/example_robot.yaml'),
    (['robot', 'teach', *ROD, '--robot', 'example_robot.yaml'], 'robot', 'robots/example_robot.yaml'),
    (['program', 'check', 'example_robot_program.yaml'], 'program', 'programs/example_robot_program.yaml'),
    (['program', 'check', 'example_cell_program.yaml', '--cell', 'example_cell.yaml'], 'cell',
     'cells/example_cell.yaml'),
    (['program', 'check', 'example_robot_program.yaml', '--robot', 'example_robot.yaml'], 'robot',
     'robots/example_robot.yaml'),
    (['program', 'export', 'example_robot_program.yaml', '--waypoints', 'w.csv'], 'program',
     'programs/example_robot_program.yaml'),
    (['program', 'send', 'example_robot_program.yaml'], 'program', 'programs/example_robot_program.yaml'),
    (['accuracy', 'gpr.yaml', '--tolerances', 'tolerances_example.yaml'], 'tolerances',
     'calibration/tolerances_example.yaml'),
    (['accuracy', 'example_robot_program.yaml', '--tolerances', 'tolerances_example.yaml', '--robot',
      'example_robot.yaml'], 'robot',
     'robots/example_robot.yaml'),
    (['calibrate', 'synthetic_measurements.csv', '--output', 'c.yaml'], 'measurements',
     'calibration/synthetic_measurements.csv'),
    (['calibrate', '--plan', '12', '--tolerances', 'tolerances_example.yaml'], 'tolerances',
     'calibration/tolerances_example.yaml'),
    (['calibrate', 'synthetic_measurements.csv', '--robot', 'example_robot.yaml'], 'robot',
     'robots/example_robot.yaml'),
    (['verify', 'bag', '--robot', 'example_robot.yaml'], 'robot', 'robots/example_robot.yaml'),
]


@pytest.fixture
def elsewhere(tmp_path, monkeypatch):
    """An empty folder, the one the commands run in."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _parsed(argv, dest):
    args = build_parser(argv[0]).parse_args(argv)
    resolve_shipped(args)    # as main does before the command runs
    value = getattr(args, dest)
    return value[0] if isinstance(value, list) else value


@pytest.mark.parametrize(('argv', 'dest', 'packaged'), OPTIONS)
def test_a_bare_name_is_the_packaged_file_and_a_local_file_wins(elsewhere, argv, dest, packaged):
    assert _parsed(argv, dest) == str(config_path(packaged))
    name = Path(packaged).name
    (elsewhere / name).write_text('local\n')
    assert _parsed(argv, dest) == name   # read as given: the local file


@pytest.mark.parametrize(('argv', 'dest', 'packaged'), OPTIONS)
def test_a_mistyped_folder_is_an_error_naming_the_packaged_name(capsys, elsewhere, argv, dest, packaged):
    name = Path(packaged).name
    typo = ['typo_dir/' + a if a == name else a for a in argv]
    status, out, err = run(capsys, *typo)
    assert status == 2 and out == '' and err.count('\n') == 1, err
    assert re.fullmatch(rf"gpr {' '.join(argv[:2]) if argv[0] in ('robot', 'program') else argv[0]}: error: "
                        rf"(--[a-z]+|[A-Z]+): [a-z ]+ file 'typo_dir/{re.escape(name)}' not found \(a path with a "
                        rf"folder is read as given; only a bare name such as {re.escape(name)} is also looked up among "
                        r'the packaged files\); allowed: a file that exists\n', err), err


@pytest.mark.parametrize(('argv', 'kind', 'name', 'names'), [
    (['program', 'check', 'nosuch.yaml'], 'program', 'nosuch.yaml',
     'example_cell_program.yaml, example_robot_program.yaml, example_stations.yaml'),
    (['program', 'check', 'example_cell_program.yaml', '--cell', 'example_robot.yaml'], 'cell', 'example_robot.yaml',
     'example_cell.yaml'),
    (['robot', 'fk', *ROD, '--robot', 'example_cell.yaml'], 'robot description', 'example_cell.yaml',
     'example_robot.yaml'),
    # a packaged file of another kind is not one of this kind's, though it lies in the same folder
    (['calibrate', '--plan', '3', '--tolerances', 'synthetic_measurements.csv'], 'tolerance table',
     'synthetic_measurements.csv', 'tolerances_example.yaml'),
    (['calibrate', 'tolerances_example.yaml', '--output', 'c.yaml'], 'measurements', 'tolerances_example.yaml',
     'synthetic_measurements.csv'),
    (['accuracy', 'nosuch.yaml', '--tolerances', 'tolerances_example.yaml'], 'mechanism or program', 'nosuch.yaml',
     'dextar.yaml, dextar_6d.yaml, example_cell_program.yaml, example_robot_program.yaml, example_stations.yaml, '
     'gpr.yaml, gsp_d1d2d3d4a1a1.yaml, gsp_d3_6.yaml, joint_working_area.yaml, rrr3_planar.yaml, shell_arm.yaml, '
     'stewart_alwan.yaml, tripod_3rps.yaml, upu3.yaml'),
])
def test_an_unknown_bare_name_is_an_error_naming_the_kind_and_its_packaged_files(capsys, elsewhere, argv, kind, name,
                                                                                names):
    status, out, err = run(capsys, *argv)
    assert status == 2 and out == '' and err.count('\n') == 1, err
    # named by the option or the argument typed, with what is allowed (it named neither)
    # (accuracy's FILE, a mechanism or a program, is looked up by the command itself: its first argument)
    where = next((f'{a}: ' for a in argv if a.startswith('--') and argv[argv.index(a) + 1] == name), None) or \
        {'calibrate': 'MEASUREMENTS: ', 'program': 'PROGRAM: '}.get(argv[0], '')
    assert err.endswith(f'error: {where}{kind} file {name!r} not found, here nor among the packaged files; allowed: '
                        f'a file that exists, or a packaged one: {names}\n'), err


def test_the_budget_takes_a_packaged_program_or_mechanism_by_its_bare_name(capsys, elsewhere):
    """docs/calibration.md: at 0.5 m and 2 deg, the tool point 0.3 m out, 44.3 um platform horizontal RSS (256.4 um
    worst case), the tool point 96 um horizontal and 78 um vertical; the example robot program at load_port_1
    (arm1): 127 um horizontal and 153 um vertical at the wafer. The same from an empty folder with bare names."""
    text = ' '.join((ROOT / 'docs' / 'calibration.md').read_text(encoding='utf-8').split())
    status, out, err = run(capsys, 'accuracy', 'gpr.yaml', '--tolerances', 'tolerances_example.yaml', '--pose', '0',
                           '0', '0.5', '0.0349', '0', '0', '--tool', '0.3', '0', '0.1', '--samples', '0', '--json')
    assert status == 0, err
    q = json.loads(out)['stations'][0]['quantities']
    um = {k: v['rss'] * 1e6 for k, v in q.items()}
    said = (f"the platform horizontal error {um['platform_horizontal']:.1f} um RSS "
            f"({q['platform_horizontal']['worst'] * 1e6:.1f} um worst case;")
    assert said == 'the platform horizontal error 44.3 um RSS (256.4 um worst case;' and said in text
    assert f"the tool point {um['tool_horizontal']:.0f} um horizontal, {um['tool_vertical']:.0f} um vertical" in text
    status, out, err = run(capsys, 'accuracy', 'example_robot_program.yaml', '--tolerances', 'tolerances_example.yaml',
                           '--samples', '0', '--json')
    assert status == 0, err
    (st,) = [s for s in json.loads(out)['stations'] if s['label'] == 'load_port_1 (arm1)']
    h, v = (st['quantities'][k]['rss'] * 1e6 for k in ('tool_horizontal', 'tool_vertical'))
    assert f'{h:.0f} um horizontal and {v:.0f} um vertical at the wafer' in text and f'{h:.0f}' == '127'


def test_the_cell_program_with_its_cell_by_bare_names(capsys, elsewhere):
    """docs/cell.md's sample output of gpr program check: 7 stations, 36 waypoints, 59.582 s, 6.090 mm."""
    doc = ' '.join((ROOT / 'docs' / 'cell.md').read_text(encoding='utf-8').split())
    status, out, err = run(capsys, 'program', 'check', 'example_cell_program.yaml', '--cell', 'example_cell.yaml',
                           '--no-progress', '--json')
    assert status == 0, err
    d = json.loads(out)
    assert (d['stations'], d['waypoints'], f"{d['duration']:.3f}", f"{d['min_clearance'] * 1e3:.3f}") == \
        (7, 36, '59.582', '6.090')
    assert f"{d['stations']} stations, {d['steps']} steps, {d['waypoints']} waypoints, 59.582 s" in doc
    assert 'minimum 6.090 mm' in doc and d['cell'] == str(config_path('cells/example_cell.yaml'))


def test_the_shipped_measurements_calibrate_by_their_bare_name(capsys, elsewhere):
    """docs/calibration.md's excerpt of the identification from synthetic_measurements.csv (kappa1 3.00928847858,
    residuals 35.523 um before and 4.723 um after) is what gpr calibrate prints from an empty folder (to the
    machine-dependent digits, as the demonstration's test compares it)."""
    doc = (ROOT / 'docs' / 'calibration.md').read_text(encoding='utf-8')
    section = doc[doc.index('## Demonstration'):doc.index('## A worked calibration of a cell')]
    excerpt = section[section.index('```text\n') + 8:]
    excerpt = excerpt[:excerpt.index('```')]
    status, out, err = run(capsys, 'calibrate', 'synthetic_measurements.csv', '--output', 'calibrated.yaml')
    assert status == 0, err
    assert out.startswith(f"calibration from {config_path('calibration/synthetic_measurements.csv')}: 40 rows")
    left = re.compile(r'step left (\S+) standard errors')
    _assert_quoted_output(left.sub('step left - standard errors', excerpt).splitlines(),
                          left.sub('step left - standard errors', out), rel=1e-5)
    assert (elsewhere / 'calibrated.yaml').is_file()


def test_the_rule_itself(elsewhere):
    """A local file or link wins, an empty name is left to the reader; the mechanisms keep their messages."""
    assert packaged_file('example_robot.yaml', ROBOTS) == str(config_path('robots/example_robot.yaml'))
    (elsewhere / 'upu3.yaml').symlink_to(elsewhere / 'dangling')   # there: its reader says what is wrong with it
    assert packaged_file('upu3.yaml', MECHANISMS) == 'upu3.yaml' and packaged_file('', CELLS) == ''
    with pytest.raises(FileError, match=r"^mechanism file 'typo_dir/upu3\.yaml' not found \(a path with a folder is "
                                        r'read as given; only a bare name such as upu3\.yaml is also looked up among '
                                        r'the packaged files\); allowed: a file that exists$'):
        packaged_file('typo_dir/upu3.yaml', MECHANISMS)
    with pytest.raises(FileError, match=r"^measurements file 'x\.csv' not found, here nor among the packaged files; "
                                        r'allowed: a file that exists, or a packaged one: '
                                        r'synthetic_measurements\.csv$'):
        packaged_file('x.csv', MEASUREMENTS)
    assert {PROGRAMS.kind, TOLERANCES.kind} == {'program', 'tolerance table'}


def test_the_nodes_inputs_do_not_take_the_rule(elsewhere):
    """The loaders the nodes call read a name as given (robot_file, cell_file: the operator's parameters), and a
    ``gpr/run_program`` goal's program_file is looked up in the package's config/programs and the operator's
    program_folders only (issue 18): a bare name of a packaged robot, cell, table or mechanism is still refused."""
    from gpr_kinematics.ros.streams import GoalFiles, goal_program
    with pytest.raises(FileError, match=r"^cannot read robot file 'example_robot\.yaml': No such file"):
        load_robot('example_robot.yaml')
    with pytest.raises(FileError, match=r"^cannot read cell file 'example_cell\.yaml': No such file"):
        load_cell('example_cell.yaml')
    robot, files = load_robot(None), GoalFiles.of([''])
    goal = SimpleNamespace(stations=[], move_time=0.0)
    for name in ('example_robot.yaml', 'example_cell.yaml', 'tolerances_example.yaml', 'upu3.yaml'):
        with pytest.raises(FileError, match=rf"^cannot read program file '.*/config/programs/{name}': No such file"):
            goal_program(SimpleNamespace(**vars(goal), program_file=name), robot, files)
    assert len(goal_program(SimpleNamespace(**vars(goal), program_file='example_stations.yaml'), robot,
                            files).stations) == 4

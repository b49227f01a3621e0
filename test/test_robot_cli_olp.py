"""What an OLP engineer writing a program of their own met (a trial of 2026-12-07): a program without a cell called
plain "safe", a misspelt station not matched to the one meant (and the list of names cut before the imported ones),
metres in a station file in millimetres blamed on the heights, a pair below the margin in two steps named by its
first alone."""
from __future__ import annotations

import json
import re

import pytest
from gpr_kinematics.cli.main import main
from gpr_kinematics.inputs.resources import config_path

PROGRAM = config_path('programs/example_robot_program.yaml')


def run(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def _program(tmp_path, old: str, new: str, name: str = 'program.yaml'):
    """The example robot program with ``old`` replaced by ``new`` (once), its robot named in full."""
    text = PROGRAM.read_text()
    assert text.count(old) >= 1, old
    text = text.replace(old, new, 1).replace('../robots/', f'{config_path("robots")}/')
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.slow
def test_a_program_without_a_cell_is_safe_against_itself_only(capsys):
    status, out, _ = run(capsys, 'program', 'check', str(PROGRAM), '--no-progress')
    assert status == 0 and 'clearance against itself (no cell)' in out
    assert out.splitlines()[-1] == ('  safe against itself only: no cell was checked (a cell: key in the program or '
                                    '--cell FILE checks one)')
    status, out, _ = run(capsys, 'program', 'check', str(PROGRAM), '--no-progress', '--cell', 'example_cell.yaml')
    assert out.splitlines()[-1] in ('  safe', '  NOT safe')   # with a cell: the plain verdict


def test_a_misspelt_station_is_matched_to_the_one_meant_and_the_names_counted(capsys, tmp_path):
    text = PROGRAM.read_text()
    station = re.search(r'\{place: (\w+)', text)[1]
    program = _program(tmp_path, f'{{place: {station}', f'{{place: {station[:-1]}_{station[-1]}')
    status, out, err = run(capsys, 'program', 'check', str(program), '--no-progress')
    assert (status, out) == (2, '')
    m = re.fullmatch(rf"gpr program check: error: .*: steps\[\d+\]: place '{station[:-1]}_{station[-1]}': no such "
                     rf'station \(did you mean {station}(?: or \w+)*\?\); allowed: one of the (\d+) stations of the '
                     rf'program and its imports: {station}, (.*)\n', err)
    assert m, err
    listed = m[2].split(', ')
    assert station not in listed and len(listed) <= 9   # the closest first, then the first eight
    # the wafers' list too; a name like none: no guess
    program = _program(tmp_path, '\nsteps:', '\nwafers: [zzzz_qqqq]\nsteps:', 'wafers.yaml')
    status, _, err = run(capsys, 'program', 'check', str(program), '--no-progress')
    assert status == 2 and "names no station 'zzzz_qqqq'; allowed: a list of station names" in err, err
    assert 'did you mean' not in err


def test_metres_in_a_station_file_in_millimetres_are_hinted(capsys, tmp_path):
    """A station at (0.45, 0.5, 0.65) in a file whose lengths are millimetres lies 0.94 mm from the world's origin:
    refused as too low (the rods' stroke), now with the hint of metres given as millimetres."""
    (tmp_path / 'st.yaml').write_text('units: {length: mm, angle: deg}\nstations:\n'
                                      '  - {name: near, position: [0.45, 0.5, 0.65], tilt: 0, azimuth: 0, '
                                      'heading: 90}\n')
    text = PROGRAM.read_text()
    first = re.search(r'- \{(pick|place|move): (\w+)', text)
    program = _program(tmp_path, first[0], '- {move: near}\n  ' + first[0])
    body = program.read_text()
    program.write_text(re.sub(r'^stations:', f'import: [{tmp_path / "st.yaml"}]\nstations:', body, count=1,
                              flags=re.M) if 'import:' not in body else body.replace('import: [',
                                                                                     f'import: [{tmp_path}/st.yaml, '))
    status, out, err = run(capsys, 'program', 'check', str(program), '--no-progress')
    assert (status, out) == (2, ''), err
    far = (0.45 ** 2 + 0.5 ** 2 + 0.65 ** 2) ** 0.5   # mm, independently
    assert f"; the station lies {far:.4g} mm from the world's origin: metres given as millimetres?" in err, err


@pytest.mark.parametrize(('old', 'new', 'waypoint', 'far'), [
    ('position: [1450, 500, 720], tilt: 1.5, azimuth: 120, heading: 0, entry: 330',
     'position: [1.45, 0.5, 0.72], tilt: 1.5, azimuth: 120, heading: 0, entry: 330', 'place pm1, entry',
     (1.45 ** 2 + 0.5 ** 2 + 0.72 ** 2) ** 0.5),
    ('position: [1450, 500, 720], tilt: 1.5, azimuth: 120, heading: 0, entry: 330',
     'position: [1.45, 0.5, 0.72], tilt: 1.5, azimuth: 120, heading: 0', 'place pm1, approach',
     (1.45 ** 2 + 0.5 ** 2 + 0.72 ** 2) ** 0.5),
    ('position: [750, -100, 400], heading: -90}', 'position: [0.75, -0.1, 0.4], heading: -90, approach_height: 12}',
     'pick load_port_1, approach', (0.75 ** 2 + 0.1 ** 2 + 0.4 ** 2) ** 0.5)], ids=('entry', 'approach', 'pick'))
def test_metres_hinted_by_the_station_not_by_its_first_refused_waypoint(capsys, tmp_path, old, new, waypoint, far):
    """The hint of metres given as millimetres was judged at the first refused waypoint: pm1 1.694 mm from the
    origin, its entry 330 mm back refused without it; without the entry, its approach 8 mm above named as 8.889 mm
    from the origin; load_port_1 0.856 mm from it, its approach 12 mm below, no hint. Now the station's own."""
    text = config_path('programs/example_cell_program.yaml').read_text()
    assert old in text
    program = tmp_path / 'metres.yaml'
    program.write_text(text.replace(old, new).replace('../robots/', f'{config_path("robots")}/')
                       .replace('../cells/', f'{config_path("cells")}/'))
    status, out, err = run(capsys, 'program', 'check', str(program), '--no-progress')
    assert (status, out) == (2, ''), err
    assert 'steps[' in err and f'({waypoint}): ' in err, err
    assert f"; the station lies {far:.4g} mm from the world's origin: metres given as millimetres?" in err, err


@pytest.mark.slow
def test_a_pair_below_the_margin_at_its_least_in_another_step_names_that_step(capsys, tmp_path):
    """pm1 25 mm to the side: arm2's wafer glides along pm1's front from the place into the pick; the table's row
    names the first step below the margin; where the least distance lies in another (the instant of the glide's
    least is any of it), a line names that step."""
    from gpr_kinematics.robot import load_robot
    from gpr_kinematics.robot.plan import plan_program
    from gpr_kinematics.robot.program import load_program
    from gpr_kinematics.safety.check import label_at
    text = config_path('programs/example_cell_program.yaml').read_text()
    old = 'position: [1450, 500, 720], tilt: 1.5, azimuth: 120, heading: 0, entry: 330'
    text = text.replace(old, old.replace('500', '525')).replace('../robots/', f'{config_path("robots")}/')
    program = tmp_path / 'moved.yaml'
    program.write_text(text.replace('../cells/', f'{config_path("cells")}/'))
    status, out, _ = run(capsys, 'program', 'check', str(program), '--no-progress')
    assert status == 1
    row = re.search(r'^ +(\d+)  pm1 +(\d+\.\d{3})  arm2_wafer / pm1/front_left +-5\.049 +(\d+\.\d{3})$', out, re.M)
    assert row, out
    plan = plan_program(load_robot(), load_program(program))
    first, least = label_at(plan, float(row[2])), label_at(plan, float(row[3]))
    line = (f'    arm2_wafer / pm1/front_left: least at {row[3]} s, {least} (another step than its first below the '
            f'margin, {first})')
    assert (line in out.splitlines()) == (least != first), out



@pytest.mark.slow
def test_the_budgets_tool_points_print_no_rounding_as_an_offset(capsys):
    """``tool (1.22465e-17, 0.35, 0.184) m`` read as a real offset: the tool point to 1 um, as the rods, no -0."""
    status, out, err = run(capsys, 'accuracy', str(PROGRAM), '--tolerances',
                           str(config_path('calibration/tolerances_example.yaml')), '--samples', '0')
    assert status == 0, err
    tools = re.findall(r'^station .*, tool \((.*)\) m in gpr_platform$', out, re.M)
    assert tools and all(re.fullmatch(r'-?\d+\.\d{6}, -?\d+\.\d{6}, -?\d+\.\d{6}', t) for t in tools), tools
    assert '0.000000, 0.350000, 0.184000' in tools and not any('-0.000000' in t for t in tools)


@pytest.mark.slow
def test_export_and_send_check_in_the_cell_given_as_check_does(capsys, tmp_path):
    """The engineer checks against a revised cell with ``check --cell``; ``export`` and ``send`` had no ``--cell`` and
    checked the program's own: a trajectory certified against the old cell was written. pm1's slit 250 mm wide (340
    shipped) puts the wafer (300 mm) into its jambs (check --cell says so): refused by both, status 1."""
    cell = config_path('cells/example_cell.yaml').read_text()
    old = '{name: pm1, chamber: {size: [500, 500, 250], wall: 10, slit: [340, 40]'
    assert old in cell
    (tmp_path / 'narrow.yaml').write_text(cell.replace(old, old.replace('340', '250')))
    program = str(config_path('programs/example_cell_program.yaml'))
    narrow = str(tmp_path / 'narrow.yaml')
    out_file = tmp_path / 't.yaml'
    status, out, err = run(capsys, 'program', 'export', program, '--trajectory', str(out_file), '--cell', narrow)
    assert (status, out) == (1, '') and not out_file.exists()
    assert err.startswith(f'gpr program export: error: the program itself is not safe in cell {narrow}: '), err
    assert ' and pm1/' in err   # the narrowed chamber
    status, out, err = run(capsys, 'program', 'send', program, '--cell', narrow, '--timeout', '0.1')
    assert (status, out) == (1, '') and err.startswith('gpr program send: error: the program itself is not safe in '
                                                       f'cell {narrow}: '), err
    status, _, err = run(capsys, 'program', 'export', program, '--samples', str(tmp_path / 's.csv'), '--cell',
                         str(tmp_path / 'none.yaml'))
    assert status == 2 and 'none.yaml' in err and not (tmp_path / 's.csv').exists()


@pytest.mark.slow
def test_export_and_send_keep_the_margin_given_as_check_does(capsys, tmp_path):
    """``--margin`` was check's alone: a program checked at 7 mm was exported and sent at the 2 mm default. The
    example cell program comes to 6.090 mm (arm2_link3 and pm1/front_bottom): export refuses it at 7 mm, naming the
    margin and the check that shows it, writes it at 6 mm; a margin typed in mm is refused before any work, by send
    too (before it looks for a robot)."""
    cell_program = config_path('programs/example_cell_program.yaml')
    status, out, _ = run(capsys, 'program', 'check', str(cell_program), '--no-progress', '--json')
    least = json.loads(out)['min_clearance']
    assert 0.006 < least < 0.007
    for option in ('--trajectory', '--waypoints'):
        path = tmp_path / ('t.yaml' if option == '--trajectory' else 'w.csv')
        status, _, err = run(capsys, 'program', 'export', str(cell_program), option, str(path), '--margin', '0.007')
        assert status == 1 and not path.exists(), err
        assert (f'arm2_link3 and pm1/front_bottom come to {least * 1000:.3f} mm' in err
                and 'within the margin of 7 mm' in err and 'a program gpr program check --margin 0.007 finds safe'
                in err), err
        status, _, err = run(capsys, 'program', 'export', str(cell_program), option, str(path), '--margin', '0.006')
        assert status == 0 and path.exists(), err
    # named as typed, every digit (1.0000000000000002 read '1 is invalid'); below the smallest float refused (1e-400
    # and -1e-400 passed as a margin of 0 and -0 mm)
    status, _, err = run(capsys, 'program', 'check', str(cell_program), '--margin', '1.0000000000000002')
    assert status == 2 and '--margin = 1.0000000000000002 is invalid' in err, err
    for tiny in ('1e-400', '-1e-400'):
        status, _, err = run(capsys, 'program', 'check', str(cell_program), '--margin', tiny)
        assert status == 2 and f"invalid float value: '{tiny}' (below the smallest float" in err, err
    for command in ('check', 'export', 'send'):   # named as typed ('margin = 5.0' before)
        extra = ('--waypoints', str(tmp_path / 'x.csv')) if command == 'export' else ()
        status, out, err = run(capsys, 'program', command, str(cell_program), *extra, '--margin', '5')
        assert (status, out) == (2, '') and err == (f'gpr program {command}: error: --margin = 5 is invalid; allowed: '
                                                    'metres, at least 0 and at most 1 (5 mm? give 0.005)\n'), err


def test_a_margin_of_decimetres_is_warned_of_as_millimetres_meant(capsys):
    """``--margin 0.5`` is 500 mm between every pair of bodies (allowed up to 1 m), where 0.5 mm was likely meant:
    check, export and send say so on stderr once, from LARGE_MARGIN (50 mm) on; below it, or asked without ``warn``
    (send's later reads of the option), nothing."""
    import argparse

    from gpr_kinematics.cli.program_trajectory import LARGE_MARGIN, margin_of
    for command in ('check', 'export', 'send'):
        assert margin_of(argparse.Namespace(margin=0.5, program_command=command), warn=True) == 0.5
        assert capsys.readouterr().err == (f'gpr program {command}: warning: --margin 0.5 m keeps every pair of bodies '
                                           '500 mm apart: millimetres meant? (--margin is in metres: 0.0005 for 0.5 '
                                           'mm; the default is 0.002)\n')
    margin_of(argparse.Namespace(margin=LARGE_MARGIN, program_command='check'), warn=True)
    assert 'warning: --margin 0.05 m keeps every pair of bodies 50 mm apart' in capsys.readouterr().err
    for margin, warn in ((0.049, True), (0.5, False)):
        margin_of(argparse.Namespace(margin=margin, program_command='check'), warn=warn)
        assert capsys.readouterr().err == ''


@pytest.mark.slow
def test_export_shows_its_checks_progress_unless_no_progress(capsys, tmp_path, monkeypatch):
    """``export`` checks the program as ``check`` does (seconds on a real program) without a word, and had no
    ``--no-progress``: with the line shown from the start (``AFTER`` 0 s) its stages and their ends go to stderr, for
    the tables as for the trajectory; ``--no-progress`` writes nothing there and the same stdout, which says what the
    outputs were checked against (``checked`` in JSON: check's numbers)."""
    monkeypatch.setattr('gpr_kinematics.cli.progress.AFTER', 0.0)
    for option, name in (('--waypoints', 'w.csv'), ('--trajectory', 't.yaml')):
        argv = ('program', 'export', str(PROGRAM), option, str(tmp_path / name))
        status, shown, err = run(capsys, *argv)
        lines = err.splitlines()
        assert status == 0 and lines and all(re.fullmatch(r'.+: +\d+\.\d % \(\d+\.\d s\)', line) for line in lines), err
        assert {line.split(':')[0] for line in lines} >= {'clearance', 'slip'}, lines
        assert all(any(line.startswith(f'{stage}: 100.0 %') for line in lines)
                   for stage in {line.split(':')[0] for line in lines}), lines
        status, quiet, err = run(capsys, *argv, '--no-progress')
        assert (status, quiet, err) == (0, shown, ''), err
        # what the outputs were checked against, said (an engineer had no record of the cell, margin and verdict)
        assert '  checked safe against itself (no cell): minimum clearance 3.879 mm (margin 2 mm), max slip ratio ' \
            in shown, shown
    status, out, _ = run(capsys, 'program', 'check', str(PROGRAM), '--json', '--no-progress')
    check = json.loads(out)
    status, out, _ = run(capsys, 'program', 'export', str(PROGRAM), '--waypoints', str(tmp_path / 'w2.csv'), '--json',
                         '--margin', '0.003', '--no-progress')
    assert status == 0 and json.loads(out)['checked'] == {
        'safe': True, 'cell': None, 'margin': 0.003, 'min_clearance': check['min_clearance'],
        'max_slip_ratio': check['max_slip_ratio'], 'wafer_carried': True}   # said as check says it (its JSON too)
    assert check['wafer_carried'] is True

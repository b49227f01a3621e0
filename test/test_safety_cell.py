"""The process cell file: shapes, units and the chamber shorthand (its walls leave exactly the slit open), and every
bad file refused with one line naming the file, the key and the value (the CLI exits 2)."""
import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest
from gpr_kinematics.core.rotations import rotation_z, tilt_rotation
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.safety.cell import MAX_OBSTACLES, load_cell, parse_cell
from gpr_kinematics.safety.markers import CUBE, CYLINDER, cell_markers

PROGRAM = config_path('programs/example_cell_program.yaml')


def cell(*obstacles, **extra):
    return {'format': 'gpr_cell', 'version': 1, 'obstacles': list(obstacles), **extra}


def test_boxes_and_cylinders_in_si_and_in_mm_deg():
    c = parse_cell(cell({'name': 'b', 'box': [0.4, 0.05, 0.3], 'position': [1.25, 1.05, 0.5], 'rpy': [0, 0, 0.52]},
                        {'name': 'c', 'cylinder': {'radius': 0.05, 'length': 1.0}, 'position': [0.2, 0.2, 0.5]}))
    b, cyl = c.obstacles
    assert b.kind == 'box' and b.size == (0.4, 0.05, 0.3) and cyl.kind == 'cylinder' and cyl.size == (0.05, 1.0)
    np.testing.assert_allclose(b.rotation, rotation_z(np.array([0.52]))[0], atol=1e-15)
    mm = parse_cell(cell({'name': 'b', 'box': [400, 50, 300], 'position': [1250, 1050, 500], 'rpy': [0, 0, 29.79]},
                         units={'length': 'mm', 'angle': 'deg'}))
    np.testing.assert_allclose(mm.obstacles[0].size, b.size, rtol=1e-15)
    np.testing.assert_allclose(mm.obstacles[0].position, b.position, rtol=1e-15)
    np.testing.assert_allclose(mm.obstacles[0].rotation, rotation_z(np.array([math.radians(29.79)]))[0], atol=1e-15)


def test_a_chamber_leaves_exactly_its_slit_open():
    """The nine walls of a chamber around a tilted station: in the station frame the front wall's four pieces
    bound an opening of the slit's width and height, centred slit_z above the station plane, front before it."""
    tilt, az, heading = math.radians(1.5), math.radians(120), math.radians(30)
    station = np.array([1.2, 1.0, 0.7])
    c = parse_cell(cell({'name': 'pm', 'chamber': {'size': [0.5, 0.5, 0.25], 'wall': 0.01, 'slit': [0.34, 0.04],
                                                  'slit_z': -0.002, 'front': 0.15},
                         'position': station.tolist(), 'tilt': tilt, 'azimuth': az, 'heading': heading}))
    R = tilt_rotation(np.array([tilt]), np.array([az]))[0] @ rotation_z(np.array([heading]))[0]
    walls = {o.name.split('/')[1]: o for o in c.obstacles}
    assert set(walls) == {'front_top', 'front_bottom', 'front_left', 'front_right', 'back', 'left', 'right',
                          'floor', 'roof'}

    def extent(name, axis):   # the wall's extent along a station axis, in the station frame
        o = walls[name]
        np.testing.assert_allclose(o.rotation, R, atol=1e-15)
        centre = R.T @ (o.position - station)
        return centre[axis] - o.size[axis] / 2, centre[axis] + o.size[axis] / 2

    assert extent('front_top', 2)[0] - extent('front_bottom', 2)[1] == pytest.approx(0.04, abs=1e-12)
    assert (extent('front_top', 2)[0] + extent('front_bottom', 2)[1]) / 2 == pytest.approx(-0.002, abs=1e-12)
    assert extent('front_left', 1)[0] - extent('front_right', 1)[1] == pytest.approx(0.34, abs=1e-12)
    for part in ('front_top', 'front_bottom', 'front_left', 'front_right'):
        assert extent(part, 0) == pytest.approx((-0.15, -0.14), abs=1e-12)
    assert extent('back', 0)[1] == pytest.approx(0.35, abs=1e-12)
    assert extent('floor', 2)[0] == pytest.approx(-0.125, abs=1e-12)


def test_markers_one_per_obstacle_at_its_pose():
    c = load_cell(config_path('cells/example_cell.yaml'))
    markers = cell_markers(c)
    assert len(markers) == len(c.obstacles) == 3 * 9 + 5
    for m, o in zip(markers, c.obstacles, strict=True):
        assert m.type == (CUBE if o.kind == 'box' else CYLINDER) and m.ns == o.name.split('/')[0]
        np.testing.assert_allclose(m.position, o.position, atol=0)
        x, y, z, w = m.orientation
        assert x * x + y * y + z * z + w * w == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize('obstacle, pattern', [
    ({'name': 'a', 'box': [float('nan'), 0.1, 0.1], 'position': [0, 0, 0]}, r'obstacles\[0\] \(a\): box\[0\] = nan'),
    ({'name': 'a', 'box': [-0.1, 0.1, 0.1], 'position': [0, 0, 0]}, r'obstacles\[0\] \(a\): box\[0\] = -0\.1 is '
                                                                     r'invalid; allowed: a finite number'),
    ({'name': 'a', 'sphere': {'radius': 0.1}, 'position': [0, 0, 0]}, r'^my_cell\.yaml: obstacles\[0\] \(a\): unknown '
                                                                      r'key\(s\) sphere; allowed keys: azimuth, box,'),
    ({'name': 'a', 'position': [0, 0, 0]}, r'shape = none is invalid; allowed: exactly one of box, cylinder'),
    ({'name': 'a', 'cylinder': {'radius': 0.1, 'length': 1e9}, 'position': [0, 0, 0]},
     r'obstacles\[0\] \(a\): length = 1000000000\.0 is invalid'),
    ({'name': 'a', 'cylinder': {'radius': 0.1}, 'position': [0, 0, 0]},   # it said "length = None is invalid"
     r'obstacles\[0\] \(a\): length is missing; allowed: a finite number in m, 0\.001 to 50 m after conversion$'),
    ({'name': 'a b', 'box': [1, 1, 1], 'position': [0, 0, 0]}, r"name = 'a b' is invalid"),
    # isalnum took any script's letters: a Cyrillic 'а' beside the Latin 'a' named two obstacles alike
    ({'name': '\u0430', 'box': [1, 1, 1], 'position': [0, 0, 0]}, r"name = '\u0430' is invalid; allowed: 1 to 64 "
                                                                     r"letters, digits, _ and - \(ASCII\)"),
    ({'name': 7, 'box': [1, 1, 1], 'position': [0, 0, 0]}, r'name = 7 is invalid \(YAML read it as a number: quote '),
    ({'name': 'a', 'box': [1, 1, 1], 'position': [0, 0]}, r'position = \[0, 0\] is invalid; allowed: a list of 3'),
    ({'name': 'a', 'box': [1, 1, 1], 'position': [0, 0, 0], 'rpy': [0, 0, 0], 'tilt': 0.1}, r'rpy or tilt'),
    ({'name': 'c', 'chamber': {'size': [0.5, 0.5, 0.25], 'slit': [0.6, 0.04]}, 'position': [0, 0, 0]},
     r'chamber: slit = \[0\.6, 0\.04\] is invalid; allowed: narrower and lower than the chamber inside its walls, '
     r'0\.46 x 0\.21 m$'),  # the inside in numbers (0.5 and 0.25 less two walls of 20 mm)
    # a wall of 0.2 mm passed, though a size below 1 mm is refused everywhere else (docs/cell.md)
    ({'name': 'c', 'chamber': {'size': [0.5, 0.5, 0.25], 'wall': 0.0002}, 'position': [0, 0, 0]},
     r'chamber: wall = 0\.0002 is invalid; allowed: .*0\.001 to 0\.125 m'),
], ids=['nan', 'negative', 'unknown-shape', 'no-shape', 'huge', 'no-length', 'name', 'cyrillic-name', 'number-name',
        'position', 'two-orientations', 'slit', 'thin-wall'])
def test_bad_obstacles_named(obstacle, pattern):
    with pytest.raises(ConfigError, match=r'^my_cell\.yaml: obstacles\[0\]') as err:
        parse_cell(cell(obstacle), 'my_cell.yaml')
    assert __import__('re').search(pattern, str(err.value)), str(err.value)


def test_obstacles_without_a_value_are_named_in_yamls_words():
    """'obstacles:' with nothing after it said 'obstacles = None is invalid' (Python's word for YAML's null)."""
    with pytest.raises(ConfigError, match=r'^my_cell\.yaml: obstacles has no value \(YAML null\); allowed: a list of '
                                          r'obstacles \(\[\] for none\)$'):
        parse_cell({'format': 'gpr_cell', 'version': 1, 'obstacles': None}, 'my_cell.yaml')
    assert parse_cell(cell(), 'my_cell.yaml').obstacles == ()
    # no obstacles key at all (a lost or misspelt list) was an empty cell: a program checked safe against nothing
    with pytest.raises(ConfigError, match=r'^my_cell\.yaml: obstacles is missing; allowed: a list of obstacles '
                                          r'\(\[\] for none\)$'):
        parse_cell({'format': 'gpr_cell', 'version': 1}, 'my_cell.yaml')


def test_metres_in_a_file_of_millimetres_are_named_so():
    """A box of 0.4 x 0.05 x 0.3 in a cell declaring mm: refused as below 1 mm, now with the metres it meant."""
    data = cell({'name': 'b', 'box': [0.4, 0.05, 0.3], 'position': [1250, 1050, 500]})
    data['units'] = {'length': 'mm'}
    with pytest.raises(ConfigError, match=r'^my_cell\.yaml: obstacles\[0\] \(b\): box\[0\] = 0\.4 is invalid; allowed: '
                                          r'a finite number in mm, 0\.001 to 50 m after conversion \(0\.4 mm is '
                                          r'0\.0004 m: metres in a file of mm\?\)$'):
        parse_cell(data, 'my_cell.yaml')
    data['obstacles'][0]['box'] = [0.0001, 0.05, 0.3]   # below the bound as metres too: no such hint
    with pytest.raises(ConfigError, match=r'box\[0\] = 0\.0001 is invalid; allowed: .* after conversion$'):
        parse_cell(data, 'my_cell.yaml')



def test_millimetres_in_a_file_of_metres_are_named_so():
    """A cell in mm without its units line: position 1200 was refused as beyond 100 m with no word of units (the
    slits of a file of mm and the stations had a hint); within the bound as millimetres, the hint names the line."""
    data = cell({'name': 'lid', 'box': [20, 20, 20], 'position': [1200, 1000, 470.3875]})
    with pytest.raises(ConfigError, match=r'^my_cell\.yaml: obstacles\[0\] \(lid\): position\[0\] = 1200 is invalid; '
                                          r'allowed: a finite number in m, -100 to 100 m after conversion \(1200 m: '
                                          r'millimetres\? declare them, units: \{length: mm\}\)$'):
        parse_cell(data, 'my_cell.yaml')
    data['obstacles'][0]['position'] = [1e6, 0, 0]   # beyond the bound as millimetres too: no such hint
    with pytest.raises(ConfigError, match=r'position\[0\] = 1000000\.0 is invalid; allowed: .* after conversion$'):
        parse_cell(data, 'my_cell.yaml')


def _chamber(**changes):
    """A cell of one chamber, its keys changed (a key given None left out)."""
    chamber = {'size': [0.5, 0.4, 0.3], 'wall': 0.02, 'slit': [0.34, 0.04]} | changes
    return parse_cell(cell({'name': 'c', 'position': [0, 0, 0],
                            'chamber': {k: v for k, v in chamber.items() if v is not None}}), 'my_cell.yaml')


@pytest.mark.parametrize('changes, allowed', [
    ({'slit': [0.38, 0.04]}, 'slit = [0.38, 0.04] is invalid; allowed: narrower and lower than the chamber inside its '
                             'walls, 0.36 x 0.26 m'),  # narrower than the chamber (0.4), wider than its inside
    ({'slit': [0.36, 0.04]}, 'slit = [0.36, 0.04] is invalid; allowed: narrower and lower than the chamber inside its '
                             'walls, 0.36 x 0.26 m'),  # as wide as the inside: passed, 0.4 - 2 * 0.02 rounding above
    ({'size': [0.5, 0.4, 0.4], 'slit': [0.34, 0.36]}, 'slit = [0.34, 0.36] is invalid; allowed: narrower and lower '
                                                      'than the chamber inside its walls, 0.36 x 0.36 m'),  # as high
    ({'slit_z': -0.125}, 'slit_z = -0.125 is invalid; allowed: a finite number in m, -0.11 to 0.11 m after '
                         'conversion'),  # the slit's lower edge 5 mm into the floor (20 mm)
    ({'slit_z': 0.125}, 'slit_z = 0.125 is invalid; allowed: a finite number in m, -0.11 to 0.11 m after conversion'),
    ({'size': [0.5, 0.3, 0.3], 'slit': None}, 'slit = (the default 340 x 40 mm) is invalid; allowed: narrower and '
                                              'lower than the chamber inside its walls, 0.26 x 0.26 m'),  # 'None'
    # walls filling the chamber: the slit's refusal allowed one of 0 x 0 m
    ({'size': [0.5, 0.4, 0.3], 'wall': 0.15}, 'wall = 0.15 m leaves the chamber of size 0.5 x 0.4 x 0.3 m an inside '
                                              '0.1 m wide and 0 m high: no room for a slit of 0.001 m or more; '
                                              'allowed: a wall thinner than 0.1495 m'),
    ({'size': [0.5, 0.4, 0.002], 'wall': 0.001}, 'wall = 0.001 m leaves the chamber of size 0.5 x 0.4 x 0.002 m an '
                                                 'inside 0.398 m wide and 0 m high: no room for a slit of 0.001 m or '
                                                 'more; allowed: a chamber wider and higher than 0.003 m'),
])
def test_a_slit_beyond_the_chambers_inside_is_refused(changes, allowed):
    """A chamber 0.4 m wide and 0.3 m high with 20 mm walls: its slit (40 mm high) within the inside, 0.36 m wide
    and its centre 0.11 m above or below the station plane at most (0.15 less the wall and half the slit)."""
    with pytest.raises(ConfigError) as refused:
        _chamber(**changes)
    assert str(refused.value) == f'my_cell.yaml: obstacles[0] (c): chamber: {allowed}'


def test_a_slit_at_the_chambers_inside_is_accepted():
    """The slit 1 mm (1 um) narrower than the inside leaves the front wall 20.5 mm (20.0005 mm) each side, 1 um lower
    20.0005 mm below and above; at slit_z -0.11 (0.11) the slit's edge lies on the floor (roof): the front wall below
    (above) it is the wall's 20 mm."""
    parts = {o.name: o for o in _chamber(slit=[0.359, 0.04]).obstacles}
    assert parts['c/front_left'].size == pytest.approx((0.02, 0.0205, 0.04), abs=1e-15)
    parts = {o.name: o for o in _chamber(slit=[0.359999, 0.04]).obstacles}   # 1 um narrower, 1 um lower
    assert parts['c/front_left'].size == pytest.approx((0.02, 0.0200005, 0.04), abs=1e-15)
    parts = {o.name: o for o in _chamber(size=[0.5, 0.4, 0.4], slit=[0.34, 0.359999]).obstacles}
    assert parts['c/front_left'].size == pytest.approx((0.02, 0.03, 0.359999), abs=1e-15)
    assert parts['c/front_bottom'].size == pytest.approx((0.02, 0.4, 0.0200005), abs=1e-15)
    for z, below, above in ((-0.11, 0.02, 0.24), (0.11, 0.24, 0.02)):
        parts = {o.name: o for o in _chamber(slit_z=z).obstacles}
        assert parts['c/front_bottom'].size == pytest.approx((0.02, 0.4, below), abs=1e-15)
        assert parts['c/front_top'].size == pytest.approx((0.02, 0.4, above), abs=1e-15)
        assert parts['c/front_left'].position[2] == z

def test_too_many_obstacles_refused_before_any_is_read():
    with pytest.raises(ConfigError, match=rf'^big\.yaml: obstacles: 10000000 obstacles; allowed: at most '
                                          rf'{MAX_OBSTACLES}$'):
        parse_cell({'format': 'gpr_cell', 'obstacles': [None] * 10_000_000}, 'big.yaml')
    with pytest.raises(ConfigError, match=r'obstacles: name .a. is used twice'):
        parse_cell(cell(*[{'name': 'a', 'box': [1, 1, 1], 'position': [0, 0, 0]}] * 2))
    # a box and a chamber of one name passed (the chamber's parts are NAME/front_top, ...)
    with pytest.raises(ConfigError, match=r"obstacles: name 'lp' is used twice; allowed: unique names"):
        parse_cell(cell({'name': 'lp', 'box': [1, 1, 1], 'position': [0, 0, 0]},
                        {'name': 'lp', 'chamber': {'size': [0.5, 0.5, 0.3]}, 'position': [2, 0, 0]}))


def test_obstacles_smaller_than_a_millimetre_are_refused():
    """A cell written in metres under `units: {length: mm}` made its boxes 40 um specks at the origin, checked safe:
    a box, a cylinder and a chamber are 1 mm at least."""
    specks = {'format': 'gpr_cell', 'units': {'length': 'mm'},
              'obstacles': [{'name': 'rail', 'box': [0.04, 0.3, 0.1], 'position': [0.38, -0.25, 0.396]}]}
    with pytest.raises(ConfigError, match=r'obstacles\[0\] \(rail\): box\[0\] = 0.04 is invalid; allowed: .*1 to '):
        parse_cell(specks, 'c.yaml')
    with pytest.raises(ConfigError, match=r'radius = 0.0005 is invalid'):
        parse_cell(cell({'name': 'post', 'cylinder': {'radius': 0.0005, 'length': 1}, 'position': [0, 0, 0]}))
    assert parse_cell(cell({'name': 'ok', 'box': [0.001, 0.001, 0.001], 'position': [0, 0, 0]})).obstacles


def _gpr(*argv, cwd):
    return subprocess.run([sys.executable, '-m', 'gpr_kinematics', *argv], capture_output=True, text=True,
                          timeout=300, cwd=cwd)


@pytest.mark.parametrize('name, text, pattern', [
    ('nan', 'obstacles:\n  - {name: a, box: [.nan, 0.1, 0.1], position: [0, 0, 0]}\n', r'box\[0\] = nan is invalid'),
    ('negative', 'obstacles:\n  - {name: a, box: [0.1, -0.1, 0.1], position: [0, 0, 0]}\n',
     r'box\[1\] = -0\.1 is invalid'),
    ('shape', 'obstacles:\n  - {name: a, cone: {radius: 0.1}, position: [0, 0, 0]}\n', r'unknown key\(s\) cone'),
    ('many', 'many', rf'obstacles: {MAX_OBSTACLES + 1} obstacles; allowed: at most {MAX_OBSTACLES}'),
    ('missing', None, r"cell file '.*missing\.yaml' not found \(a path with a folder is read as given"),
], ids=['nan', 'negative', 'shape', 'many', 'missing'])
def test_bad_cell_files_exit_2_with_one_line(tmp_path, name, text, pattern):
    path = tmp_path / f'{name}.yaml'
    if text == 'many':
        text = 'obstacles:\n' + '  - {name: a, box: [1, 1, 1], position: [0, 0, 0]}\n' * (MAX_OBSTACLES + 1)
    if text is not None:
        path.write_text('format: gpr_cell\nversion: 1\n' + text)
    res = _gpr('program', 'check', str(PROGRAM), '--cell', str(path), cwd=tmp_path)
    assert res.returncode == 2 and res.stdout == '' and res.stderr.count('\n') == 1, res.stderr
    assert 'Traceback' not in res.stderr and str(name) in res.stderr
    assert __import__('re').search(pattern, res.stderr), res.stderr


def test_ten_million_obstacles_refused_by_size_before_reading(tmp_path):
    path = tmp_path / 'huge.yaml'
    with path.open('w') as f:
        f.write('format: gpr_cell\nobstacles:\n')
        f.write('- {}\n' * 10_000_000)
    res = _gpr('program', 'check', str(PROGRAM), '--cell', str(path), cwd=tmp_path)
    assert res.returncode == 2 and res.stderr.count('\n') == 1 and 'huge.yaml' in res.stderr, res.stderr
    assert 'allowed: at most' in res.stderr


def test_program_names_its_cell_relative_to_itself(tmp_path):
    """The shipped cell program's ``cell:`` is resolved next to the program; a missing one is named."""
    text = PROGRAM.read_text().replace('robot: ../robots/example_robot.yaml',
                                       f'robot: {config_path("robots/example_robot.yaml")}')
    (tmp_path / 'p.yaml').write_text(text.replace('cell: ../cells/example_cell.yaml', 'cell: cells/none.yaml'))
    res = _gpr('program', 'check', 'p.yaml', '--json', cwd=tmp_path)
    assert res.returncode == 2 and 'cells/none.yaml' in res.stderr and res.stderr.count('\n') == 1, res.stderr
    with pytest.raises(json.JSONDecodeError):
        json.loads(res.stdout)


def test_a_cell_in_another_frame_than_the_robots_world_is_refused(tmp_path):
    """Obstacles are placed in the robot description's world frame; a cell given in another frame (``gpr_base``,
    0.75 m / 0.5 m off in the example) or a misspelt one would be checked off by that offset, so it is refused."""
    text = config_path('cells/example_cell.yaml').read_text()
    assert text.count('\nframe: world ') == 1
    for frame in ('gpr_base', 'wrld'):
        (tmp_path / f'{frame}.yaml').write_text(text.replace('\nframe: world ', f'\nframe: {frame} '))
        res = _gpr('program', 'check', str(PROGRAM), '--cell', f'{frame}.yaml', cwd=tmp_path)
        assert res.returncode == 2 and res.stdout == '' and res.stderr.count('\n') == 1, res.stderr
        assert f"frame = '{frame}'" in res.stderr and "allowed: 'world'" in res.stderr, res.stderr
    assert load_cell(config_path('cells/example_cell.yaml')).in_frame('world').frame == 'world'
    with pytest.raises(ConfigError, match=r"frame = 'world', but the robot description places the robot in 'map'"):
        load_cell(config_path('cells/example_cell.yaml')).in_frame('map')
    # a file without frame is in world, the default, and said so (the refusal quoted a value the file has not)
    lines = [line for line in text.splitlines() if not line.startswith('frame:')]
    (tmp_path / 'none.yaml').write_text('\n'.join(lines) + '\n')
    assert load_cell(tmp_path / 'none.yaml').in_frame('world').frame == 'world'
    with pytest.raises(ConfigError, match=r"frame = 'world' \(the default: the file names no frame\), but the robot "):
        load_cell(tmp_path / 'none.yaml').in_frame('fab')


@pytest.mark.slow
def test_program_export_does_not_replace_the_cell_its_program_names(tmp_path):
    """Export does not read the cell, but the program names it: writing the trajectory over it left a program that
    no longer checks (exit 0 before)."""
    import shutil

    for folder in ('programs', 'robots', 'cells'):
        shutil.copytree(config_path(folder), tmp_path / folder)
    cell = tmp_path / 'cells' / 'example_cell.yaml'
    before = cell.read_bytes()
    res = _gpr('program', 'export', 'programs/example_cell_program.yaml', '--trajectory', 'cells/example_cell.yaml',
               cwd=tmp_path)
    assert res.returncode == 2 and res.stderr.count('\n') == 1, res.stderr
    assert "trajectory output 'cells/example_cell.yaml' is a file this command reads" in res.stderr, res.stderr
    assert cell.read_bytes() == before


@pytest.mark.parametrize('probe, pair, truth', [
    ('{name: probe, box: [100, 100, 100], position: [691.889790209762, 704.925465354399, -7.275337568528], '
     'rpy: [131.530848276969, -30.767947603633, 86.576792889835]}', {'gpr_base', 'probe'}, 1.9000e-3),
    ('{name: probe, box: [18.536490972313743, 21.067582992789358, 19.400118581222053], position: [1109.725300877274, '
     '703.5343531136551, 621.761021021724], rpy: [4.287186334252175, -1.1561667906152089, 137.5843356922845]}',
     {'arm1_blade', 'probe'}, 1.9600e-3),
], ids=['column', 'blade'])
def test_reviewers_counterexamples_are_unsafe(tmp_path, probe, pair, truth):
    """Two reviewers' counterexamples: a box 1.900 mm from the column (a cylinder) read 2.035 mm in FCL, a 20 mm cube
    whose face is nearly parallel to the blade's 1.960 mm from it (two boxes) 2.042 mm: both programs checked safe
    at the 2 mm margin (truths by independent solvers). Every distance kept is a certified lower bound
    (safety.distances.certify): the check reports at most the truth, and unsafe."""
    import shutil

    for folder in ('programs', 'robots'):
        shutil.copytree(config_path(folder), tmp_path / folder)
    (tmp_path / 'cells').mkdir()
    (tmp_path / 'cells' / 'example_cell.yaml').write_text(config_path('cells/example_cell.yaml').read_text()
                                                          + f'  - {probe}\n')
    res = _gpr('program', 'check', 'programs/example_cell_program.yaml', '--json', '--no-progress', cwd=tmp_path)
    assert res.returncode == 1, res.stderr
    out = json.loads(res.stdout)
    least = min(p['distance'] for p in out['pairs'] if set(p['bodies']) == pair)
    assert truth - 1.5e-5 <= least <= truth + 1e-9 and not out['safe'], least



@pytest.mark.parametrize('key', ['rpy', 'azimuth', 'heading'])
def test_an_orientation_in_degrees_in_a_cell_in_radians_is_named(key):
    """A cell in radians with ``heading: 90`` (or an rpy angle, an azimuth: degrees meant) was refused as 'a finite
    number in rad, -6.28319 to 6.28319 rad after conversion', not saying how a cell declares degrees: now the key,
    the value and ``units: {angle: deg}``; in degrees it is pi/2, and 6.2 rad passes."""
    def obstacle(v, tilt=0.0):
        return {'name': 'b', 'box': [0.4, 0.05, 0.3], 'position': [1.25, 1.05, 0.5],
                **({'rpy': [0, 0, v]} if key == 'rpy' else {key: v, 'tilt': tilt})}

    def expected(v):   # R = tilt_rotation(tilt, azimuth) Rz(heading), or Rz(yaw)
        if key == 'rpy':
            return rotation_z(np.array([v]))[0]
        tilt = np.array([math.radians(1.0)])
        if key == 'azimuth':
            return tilt_rotation(tilt, np.array([v]))[0]
        return tilt_rotation(tilt, np.array([0.0]))[0] @ rotation_z(np.array([v]))[0]
    name = 'rpy[2]' if key == 'rpy' else key
    with pytest.raises(ConfigError, match=re.escape(f'obstacles[0] (b): {name} = 90 rad is beyond one turn; allowed: '
                                                    '[-2pi, 2pi] rad (degrees? a file in degrees declares them: '
                                                    'units: {angle: deg})')):
        parse_cell(cell(obstacle(90)))
    deg = parse_cell(cell(obstacle(90, 1.0), units={'angle': 'deg'})).obstacles[0].rotation
    rad = parse_cell(cell(obstacle(math.pi / 2, math.radians(1.0)))).obstacles[0].rotation
    np.testing.assert_allclose(deg, rad, atol=1e-15)
    np.testing.assert_allclose(deg, expected(math.pi / 2), atol=1e-15)
    R = parse_cell(cell(obstacle(6.2, math.radians(1.0)))).obstacles[0].rotation
    np.testing.assert_allclose(R, expected(6.2), atol=1e-15)


@pytest.mark.parametrize('option', ['--trajectory', '--samples', '--waypoints'])
def test_an_export_over_the_cell_is_refused_before_the_check(tmp_path, monkeypatch, capsys, option):
    """The trajectory written over the program's cell was refused only once the check (2 s and more) had read the
    cell; it is noted once the program is read, and the check is never started (counted)."""
    import shutil

    import gpr_kinematics.safety.check as check
    from gpr_kinematics.cli.main import main

    for folder in ('programs', 'robots', 'cells'):
        shutil.copytree(config_path(folder), tmp_path / folder)
    shutil.copy(tmp_path / 'cells' / 'example_cell.yaml', tmp_path / 'cells' / 'cell.csv')
    text = (tmp_path / 'programs' / 'example_cell_program.yaml').read_text()
    (tmp_path / 'programs' / 'p.yaml').write_text(text.replace('example_cell.yaml', 'cell.csv'))
    calls = []
    monkeypatch.setattr(check, 'check_program', lambda *a, **k: calls.append(a))
    monkeypatch.chdir(tmp_path)
    output = 'cells/cell.yaml' if option == '--trajectory' else 'cells/cell.csv'
    if option == '--trajectory':
        shutil.move('cells/cell.csv', output)
        (tmp_path / 'programs' / 'p.yaml').write_text(text.replace('example_cell.yaml', 'cell.yaml'))
    before = (tmp_path / output).read_bytes()
    assert main(['program', 'export', 'programs/p.yaml', option, output]) == 2
    what = 'trajectory' if option == '--trajectory' else 'joint table'
    assert capsys.readouterr().err == (f"gpr program export: error: {what} output '{output}' is a file this "
                                       'command reads; allowed: a file the command does not read (write the output '
                                       'elsewhere)\n')
    assert calls == [] and (tmp_path / output).read_bytes() == before

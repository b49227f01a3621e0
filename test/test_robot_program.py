"""Robot programs: the file format, units, imports, steps expanded into waypoints, today's platform programs named
and refused, every malformed program refused with its place."""
import math
import re

import numpy as np
import pytest
import yaml
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.program import expand, load_program, parse_program
from robot_support import ROBOT

EXAMPLE = config_path('programs/example_robot_program.yaml')


def _program(tmp_path, data, name='p.yaml'):
    f = tmp_path / name
    f.write_text(yaml.safe_dump(data))
    return load_program(f)


def _minimal(**changes):
    data = {'format': 'gpr_robot_program', 'version': 1,
            'stations': [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0},
                         {'name': 'b', 'position': [0.75, 1.1, 0.4], 'tilt': 0.01, 'azimuth': 0.5, 'heading': 1.5}],
            'steps': [{'move': 'a'}, {'pick': 'b'}]}
    data.update(changes)
    return data


def test_shipped_example():
    p = load_program(EXAMPLE)
    assert p.robot.resolve() == config_path('robots/example_robot.yaml').resolve()
    assert len(p.stations) == 5 and len(p.steps) == 10
    assert p.approach_height == pytest.approx(0.008) and p.dwell == 0.5
    st = p.stations.stations
    i = p.stations.index()['chamber_a']
    np.testing.assert_allclose(st.position[i], [1.2, 1.0, 0.44], atol=1e-15)
    assert st.tilt[i] == pytest.approx(math.radians(1.2), abs=1e-16)
    assert p.stations.branch[p.stations.index()['chamber_b']] == 'left'
    assert [s.kind for s in p.steps][:3] == ['move', 'pick', 'move']
    assert p.steps[3].dwell == 1.0 and p.steps[5].time == 4.0 and p.steps[6].arm == 'arm2'


def test_expansion_into_waypoints(tmp_path):
    p = _program(tmp_path, _minimal(defaults={'approach_height': 0.01, 'retract_height': 0.004, 'dwell': 0.3},
                                    steps=[{'move': 'a'}, {'pick': 'b', 'time': 3.0, 'dwell': 1.0},
                                           {'dwell': 0.7}, {'place': 'a', 'branch': 'left'}]))
    w = expand(p, ROBOT)
    assert w.phase == ('move', 'approach', 'at', 'retract', 'approach', 'at', 'retract')
    assert w.stations.names == ('a', 'b/approach', 'b', 'b/retract', 'a/approach', 'a', 'a/retract')
    np.testing.assert_allclose(w.dwell, [0.3, 0.0, 1.0, 0.7, 0.0, 0.3, 0.0])
    np.testing.assert_array_equal(w.time, [np.nan, 3.0, np.nan, np.nan, np.nan, np.nan, np.nan])
    assert w.branch == ('right',) * 4 + ('left',) * 3
    b = p.stations.stations.take([1])
    n = b.normal[0]
    # pick: below the wafer by the approach height, at it, above by the retract height, along the station normal
    np.testing.assert_allclose(w.stations.position[1] - b.position[0], -0.01 * n, atol=1e-15)
    np.testing.assert_allclose(w.stations.position[3] - b.position[0], 0.004 * n, atol=1e-15)
    np.testing.assert_allclose(w.stations.position[4] - [1.2, 0.5, 0.45], [0, 0, 0.01], atol=1e-15)  # place: above
    np.testing.assert_array_equal(w.stations.heading[1:4], 1.5)


def test_units_and_imports(tmp_path):
    (tmp_path / 'more.csv').write_text('name,x [mm],y [mm],z [mm],heading [deg]\nc,1200,500,450,90\n')
    (tmp_path / 'more.yaml').write_text('units: {length: mm}\nstations: [{name: d, position: [750, 1100, 400], '
                                        'heading: 0.5}]\n')
    p = _program(tmp_path, _minimal(units={'length': 'mm', 'angle': 'deg'},
                                    stations=[{'name': 'a', 'position': [1200, 500, 450], 'heading': 90}],
                                    defaults={'approach_height': 5},
                                    **{'import': ['more.csv', 'more.yaml']}, steps=[{'move': 'a'}, {'move': 'd'}]))
    st = p.stations.stations
    assert st.names == ('a', 'c', 'd')
    np.testing.assert_allclose(st.position, [[1.2, 0.5, 0.45], [1.2, 0.5, 0.45], [0.75, 1.1, 0.4]], atol=1e-15)
    np.testing.assert_allclose(st.heading, [math.pi / 2, math.pi / 2, 0.5], atol=1e-15)
    assert p.approach_height == pytest.approx(0.005)
    # a name given inline and in an import, or in two imports, is named with both places (it said 'stations 1 and 3')
    (tmp_path / 'again.csv').write_text('name,x,y,z,heading\na,1.2,0.5,0.45,0\n')
    for imports, where in ((['again.csv'], "in its stations and in import 'again.csv'"),
                           (['more.csv', 'more.csv'], "in import 'more.csv'")):
        with pytest.raises(ConfigError, match=rf"p\.yaml: station name '\w' is used twice, {where}; allowed: unique "
                                              r'names over the program and its imports'):
            _program(tmp_path, _minimal(stations=[{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0}],
                                        **{'import': imports}, steps=[{'move': 'a'}]))
    # an empty entry (or '.') was read as the program's folder: "station file '...' is a folder"
    for entry in ('', '.', ' '):
        with pytest.raises(ConfigError, match=r"p\.yaml: import entry '\.?\s?' names no file; allowed: a station "
                                              r'file path'):
            _program(tmp_path, _minimal(stations=[{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0}],
                                        **{'import': [entry]}, steps=[{'move': 'a'}]))


def test_platform_programs_are_named_and_refused():
    with pytest.raises(ConfigError, match=r'example_stations.yaml: this is a platform program \(stations with height, '
                                          r'tilt and azimuth of the platform\), the format trajectory_node runs'):
        load_program(config_path('programs/example_stations.yaml'))


@pytest.mark.parametrize('changes, pattern', [
    ({"format": None}, r"format = \(missing\) is invalid; allowed: gpr_robot_program"),  # the key removed
    ({'version': 2}, r'version = 2 is invalid; allowed: 1'),
    ({'colour': 1}, r'unknown key\(s\) colour'),
    ({'stations': []}, r'no stations; give "stations" or "import"'),
    ({'steps': []}, r'steps must be a non-empty list of steps \(move, pick, place, dwell\)'),
    ({'steps': [{'dwell': 1}]}, r'the steps only dwell; at least one move, pick or place is required'),
    ({'steps': [{'dwell': 1}, {'move': 'a'}]}, r'steps\[0\]: a dwell before any move has nowhere to hold'),
    ({'steps': [{'move': 'z'}]}, r"steps\[0\]: move 'z': no such station; allowed: one of the 2 stations of the "
                                  r'program and its imports: a, b$'),
    ({'steps': [{'move': 'a', 'pick': 'b'}]},
     r'steps\[0\]: give exactly one of move, pick, place, dwell, got move, pick'),
    # a misspelt kind is named with the keys allowed (it said "give exactly one of ..., got none")
    ({'steps': [{'jump': 'a'}]}, r'steps\[0\]: unknown key\(s\) jump; allowed keys: arm, branch, dwell, move, pick, '
                                 r'place, time \(a step gives exactly one of move, pick, place, dwell\)$'),
    ({'steps': [{'move': 'a'}, {'pik': 'a', 'dwell': 1}]}, r'steps\[1\]: unknown key\(s\) pik; allowed keys: arm, '),
    ({'steps': [{'move': 'a'}, {'dwel': 1}]}, r'steps\[1\]: unknown key\(s\) dwel; allowed keys: '),
    ({'steps': [{'arm': 'arm1'}]}, r'give exactly one of move, pick, place, dwell, got none'),
    ({'steps': [{'move': 'a'}, 'b']}, r'steps\[1\]: expected a mapping such as \{pick: STATION\}'),
    ({'steps': [{'move': 'a', 'speed': 1}]}, r'steps\[0\]: unknown key\(s\) speed'),
    ({'steps': [{'move': 'a', 'time': 0}]}, r'steps\[0\]: time = 0 is invalid; allowed: seconds, > 0'),
    # the first move's time: nothing moves into the first waypoint (it was dropped without a word)
    ({'steps': [{'dwell': 1.0}, {'move': 'a', 'time': 5}]}, r'steps\[1\]: time = 5 s on the first move: the program '
                                                             r'starts at its first waypoint, so no move leads into it'),
    ({'steps': [{'move': 'a', 'dwell': -1}]}, r'dwell = -1 is invalid; allowed: seconds, >= 0'),
    ({'steps': [{'move': 'a', 'dwell': float('nan')}]}, r'dwell = nan is invalid'),
    ({'steps': [{'move': 'a', 'arm': 3}]}, r'steps\[0\]: arm = 3 is invalid \(YAML read it as a number: quote the '
                                            r'name to keep it as written\); allowed: a name'),
    ({'steps': [{'move': True}]}, r'steps\[0\]: move True: no such station \(YAML reads true and false as booleans: '
                                  r'quote the name\); allowed: one of the 2 stations of the program and its imports: '
                                  r'a, b$'),
    ({'defaults': {'approach_height': 0.5}}, r'defaults: approach_height = 0.5 m is invalid; allowed: 0 to 0.1 m'),
    ({'defaults': {'speed': 1}}, r'defaults: unknown key\(s\) speed'),
    ({'defaults': [1]}, r'defaults must be a mapping'),
    ({'import': ['absent.csv']}, r"cannot read station file .*absent.csv"),
    ({'import': 7}, r'import = 7; allowed: a station file path \(\.csv, \.yaml\) or a list of at most 64 of them'),
    # a misspelt wafer station: named, the closest guessed, and the stations listed (the closest first)
    ({'wafers': ['bb']}, r"wafers = \['bb'\] names no station 'bb' \(did you mean b\?\); allowed: a list of station "
                         r'names \(the stations that hold a wafer at the start\): one of the 2 stations of the program '
                         r'and its imports: b, a$'),
    ({'robot': 5}, r'robot = 5 is invalid; allowed: a path to a robot description'),
    ({'stations': [{'name': 'a', 'position': [1, 2, 3]}, {'name': 'a', 'position': [1, 2, 3]}]},
     r"station name 'a' is used twice"),
])
def test_malformed_programs(tmp_path, changes, pattern):
    data = _minimal()
    for k, v in changes.items():
        if v is None:
            del data[k]
        else:
            data[k] = v
    with pytest.raises(ConfigError, match=pattern):
        p = _program(tmp_path, data)
        expand(p, ROBOT)


@pytest.mark.parametrize('key', ['approach_height', 'retract_height'])
def test_default_heights_are_bounded_at_a_tenth_of_a_metre_in_metres_and_in_mm(tmp_path, key):
    """The bound is station_files.MAX_APPROACH (0.1 m): the bound itself is a height, just above it is refused, and a
    program in mm reads the bound in mm (100 mm), the metres after it."""
    from gpr_kinematics.robot.station_files import MAX_APPROACH

    assert MAX_APPROACH == 0.1
    mm = {'units': {'length': 'mm'},
          'stations': [{'name': 'a', 'position': [1200, 500, 450], 'heading': 0.0},
                       {'name': 'b', 'position': [750, 1100, 400], 'heading': 1.5}]}
    for changes, ok, high, unit in (({}, (0.0999, 0.1), (0.1001, 0.15), 'm'), (mm, (99.9, 100), (100.1, 150), 'mm')):
        for value in ok:
            p = _program(tmp_path, _minimal(defaults={key: value}, **changes))
            assert getattr(p, key) == pytest.approx(value * (0.001 if unit == 'mm' else 1.0), rel=1e-15)
        for value in high:
            with pytest.raises(ConfigError) as info:
                _program(tmp_path, _minimal(defaults={key: value}, **changes))
            assert str(info.value) == (f'{tmp_path / "p.yaml"}: defaults: {key} = {value:g} {unit} is invalid; '
                                       f'allowed: 0 to {"100 mm (0.1 m)" if unit == "mm" else "0.1 m"}')
    # text, not a number: quoted, no hint (the float of 'abc' crashed the refusal once)
    for text in ('abc', '8'):
        with pytest.raises(ConfigError, match=rf"defaults: {key} = '{text}' m is invalid; allowed: 0 to 0\.1 m$"):
            _program(tmp_path, _minimal(defaults={key: text}))
    # 8 in metres: 8 mm was meant (it said "0 to 0.1 m (0.1 m)" and no more)
    with pytest.raises(ConfigError, match=rf'defaults: {key} = 8 m is invalid; allowed: 0 to 0\.1 m; 8 mm would be '
                                          r'within it: millimetres given as metres\?$'):
        _program(tmp_path, _minimal(defaults={key: 8}))


def test_steps_checked_against_the_robot(tmp_path):
    p = _program(tmp_path, _minimal(steps=[{'move': 'a', 'arm': 'arm9'}]))
    with pytest.raises(ConfigError, match=r"steps\[0\]: arm = 'arm9' is invalid; allowed: arm1, arm2"):
        expand(p, ROBOT)
    # a branch needs no robot: refused with the file (test_robot_program_17.py)
    with pytest.raises(ConfigError, match=r"steps\[0\]: branch = 'up' is invalid; allowed: left, right or empty"):
        _program(tmp_path, _minimal(steps=[{'move': 'a', 'branch': 'up'}]))


def test_not_a_mapping():
    with pytest.raises(ConfigError, match=r'expected a mapping \(format: gpr_robot_program'):
        parse_program([1, 2])


def test_a_program_of_more_steps_than_a_check_can_afford_is_refused_before_parsing(tmp_path):
    """20,000 alternating moves (a 290 kB file) took `gpr program check` past 4 GB; 2,000 take about a minute."""
    from gpr_kinematics.robot.program import MAX_STEPS, parse_program

    data = {'format': 'gpr_robot_program', 'version': 1, 'stations': [{'name': 'a', 'position': [0.75, 0.8, 0.4]}],
            'steps': [{'move': 'a'}] * (MAX_STEPS + 1)}
    with pytest.raises(ConfigError, match=r'2001 steps; allowed: at most 2000'):
        parse_program(data, tmp_path / 'p.yaml')


@pytest.mark.parametrize('version', [True, 1.0, '1', 2])
def test_a_version_that_is_not_the_integer_1_is_refused(version, tmp_path):
    """version: true and version: 1.0 were taken as version 1 (True == 1.0 == 1 in Python)."""
    data = {'format': 'gpr_robot_program', 'version': version,
            'stations': [{'name': 'a', 'position': [0.75, 0.8, 0.4]}], 'steps': [{'move': 'a'}]}
    with pytest.raises(ConfigError, match=r'version = .* is invalid; allowed: 1'):
        parse_program(data, str(tmp_path / 'p.yaml'))
    from gpr_kinematics.robot.platform_program import parse_platform_program
    from gpr_kinematics.safety.cell import parse_cell

    with pytest.raises(ConfigError, match=r'version = .* is invalid'):
        parse_platform_program({'version': version, 'stations': [{'height': 0.3}]})
    with pytest.raises(ConfigError, match=r'version = .* is invalid'):
        parse_cell({'format': 'gpr_cell', 'version': version, 'obstacles': []}, 'c.yaml')


def test_imports_stop_at_the_programs_bound_of_stations(tmp_path, monkeypatch):
    """Each station file was bounded alone: 64 imports of a 1.5 MB file of 99,999 stations read 6.4 million
    stations (3 minutes, 1.9 GB) before the bound or the names were checked. The count is checked after each import,
    and no file after the one that passes the bound is read (absent.csv)."""
    from gpr_kinematics.robot import program

    monkeypatch.setattr(program, 'MAX_STATIONS', 3)
    (tmp_path / 'two.csv').write_text('name,x,y,z\nc,1.2,0.5,0.45\nd,1.2,0.5,0.45\n')
    data = _minimal(**{'import': ['two.csv', 'two.csv', 'absent.csv']})
    with pytest.raises(ConfigError, match=r"p.yaml: import 'two.csv': 4 stations so far; allowed: at most 3 in a "
                                          r'program \(inline and imported\)$'):
        _program(tmp_path, data)


def test_a_move_is_a_line_out_of_an_entry_and_into_an_exit():
    """``Waypoints.is_line(m)``, the one test of a straight move (``line_moves``, ``move_rows``, the slip use it):
    the cell program's chambers are entered and left on lines, the move out of the ``entry`` waypoint and the one
    into the ``exit`` waypoint; every other move, and every move of waypoints without ``path``, is a joint line."""
    import dataclasses

    from gpr_kinematics.robot.description import load_robot
    from gpr_kinematics.robot.plan import line_moves

    program = load_program(config_path('programs/example_cell_program.yaml'))
    w = expand(program, load_robot(program.robot))
    expected = [w.phase[m] == 'entry' or w.phase[m + 1] == 'exit' for m in range(len(w) - 1)]
    assert [w.is_line(m) for m in range(len(w) - 1)] == expected
    assert 0 < sum(expected) < len(expected)
    assert line_moves(w) == [m for m, line in enumerate(expected) if line]
    bare = dataclasses.replace(w, path=())
    assert not any(bare.is_line(m) for m in range(len(w) - 1)) and line_moves(bare) == []


def test_a_heading_in_degrees_in_a_program_in_radians_is_refused(tmp_path):
    """A program's inline stations are read by the station files' rule: ``heading: 90`` without ``units`` was
    14.3 turns (a station at 2.04 rad); refused with the key, the value and ``units: {angle: deg}``; with it, pi/2."""
    stations = [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 90}, {'name': 'b', 'position': [0.75, 1.1, 0.4]}]
    with pytest.raises(ConfigError, match=r'p.yaml: stations\[0\] \(a\): heading = 90 rad is beyond one turn; '
                                          r'allowed: \[-2pi, 2pi\] rad \(degrees\? .*units: \{angle: deg\}\)'):
        _program(tmp_path, _minimal(stations=stations))
    p = _program(tmp_path, _minimal(stations=stations, units={'angle': 'deg'}))
    assert p.stations.stations.heading[0] == pytest.approx(math.pi / 2, abs=1e-15)
    stations[0]['heading'] = 6.2
    assert _program(tmp_path, _minimal(stations=stations)).stations.stations.heading[0] == 6.2


def test_a_straight_entry_needs_an_arm_that_holds_the_heading(tmp_path):
    """A straight entry keeps the wafer's orientation: the 3-joint arm1 and the fixed_joint arm2 expand it (with its
    entry and exit waypoints); a 2-joint arm and a 4-joint arm under the nearest rule are refused, named."""
    from robot_support import make_robot, robot_data

    stations = [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0, 'entry': 0.3}]
    for arm in ('arm1', 'arm2'):
        way = expand(_program(tmp_path, _minimal(stations=stations, steps=[{'place': 'a', 'arm': arm}])), ROBOT)
        assert way.phase == ('entry', 'approach', 'at', 'retract', 'exit')
    two = robot_data()
    two['arms'][0]['joints'] = two['arms'][0]['joints'][:2]
    two['arms'][0]['home'] = [0.0, 2.5]
    nearest = robot_data()
    nearest['arms'][1]['redundancy'] = {'rule': 'nearest'}
    for data, arm, why in ((two, 'arm1', r"arm arm1 has 2 joints and cannot hold the blade's heading"),
                           (nearest, 'arm2', r'arm arm2 chooses its posture by the rule nearest, not with a held')):
        program = _program(tmp_path, _minimal(stations=stations, steps=[{'place': 'a', 'arm': arm}]))
        with pytest.raises(ConfigError, match=rf'steps\[0\]: station a has a straight entry, but {why}'):
            expand(program, make_robot(data))


def test_a_file_of_the_wrong_kind_is_named_in_a_users_words():
    """An empty program file, a list, text: said as such (it read 'got NoneType', 'got list')."""
    for data, said in ((None, 'nothing (an empty file or null)'), ([1, 2], 'a list'), ('steps', 'text'),
                       (3, 'a number')):
        with pytest.raises(ConfigError, match=re.escape(f'p.yaml: expected a mapping (format: gpr_robot_program, '
                                                        f'stations, steps), got {said}')):
            parse_program(data, 'p.yaml')


def test_a_station_position_given_as_a_tuple_is_taken_as_a_list():
    """A code caller's tuple: the robot description's base.position took it, a program station's position refused
    it ('position = (750, 800, 400) is invalid; allowed: [x, y, z]'); both take it now."""
    data = yaml.safe_load(config_path('programs/example_cell_program.yaml').read_text(encoding='utf-8'))
    listed = parse_program(data, 'p.yaml', config_path('programs'))
    data['stations'][0]['position'] = tuple(data['stations'][0]['position'])
    tupled = parse_program(data, 'p.yaml', config_path('programs'))
    np.testing.assert_array_equal(tupled.stations.stations.position, listed.stations.stations.position)


def test_the_documented_program_is_accepted_and_planned(tmp_path):
    """docs/robot.md's program, written as shown (beside copies of the shipped robots/ and cells/ and a station file
    it imports): it placed with arm2 what arm1 had picked, refused as 'arm arm2 carries no wafer to place'."""
    import shutil
    from pathlib import Path

    from gpr_kinematics.robot.plan import plan_program

    doc = (Path(__file__).resolve().parents[1] / 'docs' / 'robot.md').read_text(encoding='utf-8')
    text = next(b for b in doc.split('```yaml\n')[1:] if b.startswith('format: gpr_robot_program')).split('```')[0]
    for folder in ('robots', 'cells'):
        shutil.copytree(config_path(folder), tmp_path / folder)
    (tmp_path / 'programs').mkdir()
    (tmp_path / 'programs' / 'more_stations.csv').write_text('name,x [mm],y [mm],z [mm]\nbuffer,900,-300,420\n')
    (tmp_path / 'programs' / 'p.yaml').write_text(text)
    program = load_program(tmp_path / 'programs' / 'p.yaml')
    assert program.stations.stations.names == ('low', 'high', 'load_port_1', 'pm1_front', 'pm1', 'buffer')
    assert [(s.kind, s.station, s.arm) for s in program.steps] == [
        ('move', 'low', None), ('pick', 'load_port_1', None), ('move', 'low', None), ('move', 'high', None),
        ('move', 'pm1_front', None), ('place', 'pm1', None), ('move', 'pm1_front', None), ('dwell', None, None)]
    assert program.cell is not None and program.wafers == ('load_port_1',)
    plan = plan_program(ROBOT, program)
    assert plan.timing.total > 0.0
    # and safe in its cell: its first step put the blade on the wafer lying at load_port_1, its pick's retract
    # into the pod's back (-16.4 mm), in the program the docs showed before
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.check import check_program
    assert check_program(plan, load_cell(program.cell))[0].safe

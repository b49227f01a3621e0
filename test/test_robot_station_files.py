"""Station files: CSV with units in the header, YAML with a units mapping, the same stations either way, and every
malformed or hostile file refused with the line and the field."""
import math
import os

import numpy as np
import pytest
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs.safe_yaml import MAX_BYTES
from gpr_kinematics.robot.station_files import load_stations

CSV_MM_DEG = """name,x [mm],y [mm],z [mm],tilt [deg],azimuth [deg],heading [deg],branch,approach_height [mm]
load_port_1,1100,250,420,0,0,90,,
chamber_a,400,900,455,1.2,30,180,left,5
"""
CSV_SI = f"""name, x ,y,z,tilt,azimuth,heading,branch,approach_height
load_port_1,1.1,0.25,0.42,0,0,{math.pi / 2!r},,
chamber_a,0.4,0.9,0.455,{math.radians(1.2)!r},{math.radians(30)!r},{math.pi!r},left,0.005
"""
YAML_MM_DEG = """units: {length: mm, angle: deg}
stations:
  - {name: load_port_1, position: [1100, 250, 420], heading: 90}
  - {name: chamber_a, position: [400, 900, 455], tilt: 1.2, azimuth: 30, heading: 180, branch: left,
     approach_height: 5}
"""


def _write(tmp_path, name, text):
    f = tmp_path / name
    f.write_text(text)
    return f


def test_the_same_stations_in_every_form(tmp_path):
    tables = [load_stations(_write(tmp_path, n, t)) for n, t in (('a.csv', CSV_MM_DEG), ('b.csv', CSV_SI),
                                                                 ('c.yaml', YAML_MM_DEG))]
    for t in tables:
        st = t.stations
        assert st.names == ('load_port_1', 'chamber_a')
        np.testing.assert_allclose(st.position, [[1.1, 0.25, 0.42], [0.4, 0.9, 0.455]], atol=1e-15)
        np.testing.assert_allclose(st.tilt, [0.0, math.radians(1.2)], atol=1e-16)
        np.testing.assert_allclose(st.heading, [math.pi / 2, math.pi], atol=1e-15)
        assert t.branch == (None, 'left')
        assert t.approach_height[0] is None and t.approach_height[1] == pytest.approx(0.005, abs=1e-16)
        assert t.retract_height == (None, None)


def test_an_empty_heading_is_free(tmp_path):
    t = load_stations(_write(tmp_path, 's.csv', 'name,x,y,z,heading\na,1,0,0.4,\nb,1,0,0.4,0.5\n'))
    assert t.stations.heading_free.tolist() == [True, False]
    # without tilt and azimuth columns, or with them empty, the station plane is level (module docstring: default 0)
    assert t.stations.tilt.tolist() == [0.0, 0.0] and t.stations.azimuth.tolist() == [0.0, 0.0]
    t = load_stations(_write(tmp_path, 's.csv', 'name,x,y,z,tilt,azimuth\na,1,0,0.4,,\nb,1,0,0.4,0.01,0.5\n'))
    assert t.stations.tilt.tolist() == [0.0, 0.01] and t.stations.azimuth.tolist() == [0.0, 0.5]


@pytest.mark.parametrize('name, text, pattern', [
    ('s.csv', '', r's.csv: empty; a header row \(name, x, y, z, ...\)'),
    # a height beyond a float's bound named the generic magnitude, the range one just inside it
    ('s.yaml', 'units: {length: mm}\nstations: [{name: a, position: [1000, 0, 400], entry: 1.0e+7}]\n',
     r'entry = 10000000\.0 is invalid; allowed: a finite number in mm \(0 to 2000 mm, 2 m\)'),
    # a header alone passed as no stations: a program importing it then missed each station it names
    ('s.csv', 'name,x,y,z\n', r's.csv: no rows after the header \(line 1\); one row per entry is required'),
    ('s.yaml', 'stations: []\n', r's.yaml: stations = \[\] has no station; allowed: a list of one or more stations'),
    ('s.csv', 'name,x,y\na,1,2\n', r'the header lacks the column\(s\) z; required: name, x, y, z'),
    ('s.csv', 'name,x,y,z,colour\n', r"header column 5 'colour' is invalid; allowed: name, branch, x, y, z"),
    ('s.csv', 'name,x [cm],y,z\n', r'column x: unit \[cm\] is invalid; allowed: m or mm'),
    ('s.csv', 'name,x,y,z,tilt [grad]\n', r'column tilt: unit \[grad\] is invalid; allowed: rad or deg'),
    ('s.csv', 'name [m],x,y,z\n', r'column name takes no unit, got \[m\]'),
    ('s.csv', 'name,x,x,y,z\n', r'column x appears twice in the header'),
    ('s.csv', 'name,x,y,z\na,1,2\n', r's.csv: line 2: 3 fields, the header has 4'),
    ('s.csv', 'name,x,y,z\na,1,nan,0.4\n', r"s.csv: line 2 \(a\): y = 'nan' is invalid; allowed: a finite number in m"),
    ('s.csv', 'name,x [mm],y,z\na,1e400,0,0.4\n', r"x = '1e400' is invalid; allowed: a finite number in mm"),
    ('s.csv', 'name,x,y,z\na,one,0,0.4\n', r"x = 'one' is invalid; allowed: a finite number in m$"),
    # a spreadsheet's export in a locale with decimal commas: semicolons or tabs between the columns, commas in numbers
    ('s.csv', 'name;x [mm];y [mm];z [mm]\ns1;1200,0;1000,0;440,0\n',
     r"header column 1 'name;x \[mm\];.*' is invalid; .* \(the columns are separated by semicolons: separate them by "
     r'commas, and write numbers with a decimal point\)$'),
    ('s.csv', 'name\tx\ty\tz\ns1\t1.2\t1\t0.44\n', r'\(the columns are separated by tabs: separate them by commas'),
    ('s.csv', 'name,x [mm],y,z\ns1,"1200,5",1,0.44\n',
     r"x = '1200,5' is invalid; allowed: a finite number in mm \(a decimal comma: write a decimal point, 1200.5\)$"),
    # float() read 1_0 as 10 and fullwidth digits as numbers
    ('s.csv', 'name,x,y,z\na,1_0,0,0.4\n', r"line 2 \(a\): x = '1_0' is invalid; allowed: a finite number in m"),
    ('s.csv', 'name,x,y,z\na,\uff11,0,0.4\n', r"line 2 \(a\): x = '\uff11' is invalid; allowed: a finite number"),
    ('s.csv', 'name,x,y,z\n,1,0,0.4\n', r"line 2: name = '' is invalid; allowed: 1 to 64 letters"),
    # a name an exported table would give a spreadsheet as a formula (=-A1-B1)
    ('s.csv', 'name,x,y,z\n-A1-B1,1,0,0.4\n', r"line 2: name = '-A1-B1' is invalid; allowed: 1 to 64 letters, digits, "
                                              r'_ \. - \(not - first: a spreadsheet reads such a cell as a formula\)$'),
    ('s.yaml', 'stations: [{name: -5, position: [1, 2, 0.4]}]\n', r"name = -5 is invalid \(YAML read it as a number: "
                                                                  r"quote the name to keep it as written\); allowed: "
                                                                  r"1 to 64 letters"),
    # 007 named the station 7 (a CSV file's 007 stays 007): a number is refused with the hint to quote it
    ('s.yaml', 'stations: [{name: 007, position: [1, 2, 0.4]}]\n', r"name = 7 is invalid \(YAML read it as a number"),
    ('s.yaml', 'stations: [{name: "a\\n", position: [1, 2, 3]}]\n', r"stations\[0\]: name = 'a\\n' is invalid"),
    ('s.csv', 'name,x,y,z\na,1,0,\n', r'line 2 \(a\): x, y and z are required'),
    ('s.csv', 'name,x,y,z\na,1,0,0.4\na,1,0,0.5\n', r"station name 'a' is used twice \(stations 0 and 1\)"),
    ('s.csv', 'name,x,y,z,branch\na,1,0,0.4,up\n', r"branch = 'up' is invalid; allowed: left, right or empty"),
    ('s.csv', 'name,x,y,z,retract_height\na,1,0,0.4,0.5\n',
     r"retract_height = 0.5 m is invalid; allowed: 0 to 0.1 m$"),
    ('s.csv', 'name,x,y,z\n"a,1,0,0.4\n', r'line 2: 1 fields, the header has 4|not valid CSV'),
    ('s.yaml', 'units: {length: inch}\nstations: []\n', r"units: length = 'inch' is invalid; allowed: m or mm"),
    ('s.yaml', 'units: {angle: grad}\n', r"units: angle = 'grad' is invalid; allowed: rad or deg"),
    # a misspelt top-level key was ignored: the stations read in m and rad, or none read at all
    ('s.yaml', 'unit: {length: mm}\nstations: []\n', r"s.yaml: unknown key\(s\) unit; allowed keys: stations, units$"),
    ('s.yaml', 'units: {length: mm}\nstation: []\n',
     r"s.yaml: unknown key\(s\) station; allowed keys: stations, units$"),
    ('s.yaml', 'units: {length: mm}\n', r's.yaml: no "stations" key; a station file is a mapping with "stations"'),
    ('s.yaml', 'units: {length: m, time: s}\n', r'units: unknown key\(s\) time'),
    ('s.yaml', 'stations: {a: 1}\n', r'stations must be a list of stations'),
    ('s.yaml', 'stations: [{name: a}]\n', r'stations\[0\]: name and position are required'),
    ('s.yaml', 'stations: [{name: a, position: [1, 2]}]\n', r"stations\[0\] \(a\): position = \[1, 2\] is invalid"),
    ('s.yaml', 'stations: [{name: a, position: [1, 2, .inf]}]\n', r'z = inf is invalid; allowed: a finite number in m'),
    ('s.yaml', 'stations: [{name: a, position: [1, 2, 3], tilt: "1"}]\n', r"tilt = '1' is invalid"),
    ('s.yaml', 'units: {length: mm}\nstations: [{name: a, position: [1, 2, 3], approach_height: 101}]\n',
     r"stations\[0\] \(a\): approach_height = 101 mm is invalid; allowed: 0 to 100 mm \(0.1 m\)"),
    ('s.yaml', 'stations: [{name: a, position: [1, 2, 3], retract_height: -0.001}]\n',
     r"stations\[0\] \(a\): retract_height = -0.001 m is invalid; allowed: 0 to 0.1 m$"),
    ('s.yaml', 'stations: [{name: a, position: [1, 2, 3], entry: 2.5}]\n',
     r"stations\[0\] \(a\): entry = 2.5 m is invalid; allowed: 0 to 2 m$"),
    ('s.yaml', 'stations: [{name: a, position: [1, 2, 3], speed: 1}]\n',
     r'stations\[0\] \(a\): unknown key\(s\) speed'),
    ('s.yaml', 'stations: [{name: [a], position: [1, 2, 3], speed: 1}]\n', r'stations\[0\]: unknown key\(s\) speed'),
    ('s.yaml', 'stations: [{name: true, position: [1, 2, 3]}]\n', r'stations\[0\]: name = True is invalid \(YAML reads '
                                                                 r'true and false as booleans: quote the name\)'),
    ('s.yaml', '- 1\n', r'expected a mapping with "stations"'),
    ('s.txt', 'x', r"is of unknown type .txt; allowed: a .csv, .yaml or .yml file"),
    # a units line misspelt was a comment: the headings' degrees were read as radians (57.3 deg for 1)
    ('s.csv', '# unit: deg\nname,x,y,z,tilt,azimuth,heading\na,1.2,0.5,0.6,0,0,1\n',
     r"line 1: '# unit: deg' speaks of units but is not a \"# units:\" line, so they would be ignored"),
    ('s.csv', '# angle Units = deg\nname,x,y,z,tilt,azimuth,heading\na,1.2,0.5,0.6,0,0,1\n', r'speaks of units'),
])
def test_malformed_files(tmp_path, name, text, pattern):
    with pytest.raises(ConfigError, match=pattern):
        load_stations(_write(tmp_path, name, text))


@pytest.mark.parametrize('key, bound', [('approach_height', 0.1), ('retract_height', 0.1), ('entry', 2.0)])
def test_csv_heights_are_bounded_in_metres_and_in_mm(tmp_path, key, bound):
    """A CSV's approach and retract heights (at most station_files.MAX_APPROACH, 0.1 m) and entry (MAX_ENTRY, 2 m):
    the bound itself is taken, just above it refused; a column in mm reads the bound in mm, the metres after it."""
    for unit, scale in (('m', 1.0), ('mm', 1000.0)):
        header = f'name,x,y,z,{key} [{unit}]\n'
        at = f'{bound * scale:g}'
        t = load_stations(_write(tmp_path, 's.csv', f'{header}a,1,0,0.4,{at}\nb,1,0,0.5,0\n'))
        got = getattr(t, key)
        assert got[0] == pytest.approx(bound, rel=1e-15) and got[1] == 0.0
        over = f'{bound * scale * 1.001:g}'
        path = _write(tmp_path, 's.csv', f'{header}a,1,0,0.4,{over}\n')
        with pytest.raises(ConfigError) as info:
            load_stations(path)
        assert str(info.value) == (f"{path}: line 2 (a): {key} = {over} {unit} is invalid; allowed: 0 to {at} {unit}"
                                   + (f' ({bound:g} m)' if unit == 'mm' else ''))   # not "0.1 m (0.1 m)"


def test_hostile_files(tmp_path):
    with pytest.raises(ConfigError, match=r"cannot read station file .*absent.csv"):
        load_stations(tmp_path / 'absent.csv')
    (tmp_path / 'dir.csv').mkdir()
    with pytest.raises(ConfigError, match=r'is not a regular file'):
        load_stations(tmp_path / 'dir.csv')
    (tmp_path / 'folder').mkdir()  # a folder named without a suffix read 'unknown type (none)'
    with pytest.raises(ConfigError, match=r"station file '.*folder' is a folder; allowed: a .csv, .yaml or .yml file"):
        load_stations(tmp_path / 'folder')
    # a name too long for the file system, without a suffix: a bare OSError (File name too long) of is_dir
    with pytest.raises(ConfigError, match=r"^station file 'x{50,}.* is of unknown type \(no suffix\)"):
        load_stations('x' * 300)
    fifo = tmp_path / 'fifo.csv'
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match=r'is not a regular file'):  # must not block on the FIFO
        load_stations(fifo)
    big = tmp_path / 'big.csv'
    with open(big, 'wb') as fh:
        fh.truncate(MAX_BYTES + 1)
    with pytest.raises(ConfigError, match=rf'has {MAX_BYTES + 1} bytes; allowed: at most {MAX_BYTES}'):
        load_stations(big)
    bad = tmp_path / 'latin.csv'
    bad.write_bytes('name,x,y,z\nstation_\xe9,1,0,0.4\n'.encode('latin-1'))
    with pytest.raises(ConfigError, match=r'is not UTF-8 text \(byte 19 is 0xe9\) on line 2'):
        load_stations(bad)


def test_csv_rows_are_counted_as_they_are_read(tmp_path, monkeypatch):
    """The rows were all parsed into one list before they were counted (10 MiB of blank lines held 0.8 GB for 17 s);
    the row after the bound is refused, naming its line, before the rest of the file is parsed (here a field
    beyond the csv module's limit, which refused the whole file before)."""
    from gpr_kinematics.robot import station_files

    monkeypatch.setattr(station_files, 'MAX_STATIONS', 2)
    text = 'name,x,y,z\n\na,1,0,0.4\nb,1,0,0.4\nc,1,0,0.4\n"' + 'x' * 200_000 + '",1,0,0.4\n'
    with pytest.raises(ConfigError, match=r's.csv: line 5: more than 2 rows; allowed: at most 2$'):
        load_stations(_write(tmp_path, 's.csv', text))
    blank_lines = load_stations(_write(tmp_path, 's.csv', 'name,x,y,z\na,1,0,0.4\n\n\nb,1,0,0.4\n'))
    assert blank_lines.stations.names == ('a', 'b')


@pytest.mark.parametrize('name, rad, deg, message', [
    ('s.yaml', 'stations:\n  - {{name: a, position: [1, 0.5, 0.4], {key}: {v}}}\n',
     'units: {{angle: deg}}\nstations:\n  - {{name: a, position: [1, 0.5, 0.4], {key}: {v}}}\n',
     r'stations\[0\] \(a\): {key} = 90 rad is beyond one turn; allowed: \[-2pi, 2pi\] rad \(degrees\? a file in '
     r'degrees declares them: units: \{{angle: deg\}}\)'),
    ('s.csv', 'name,x,y,z,{key}\na,1,0.5,0.4,{v}\n', 'name,x,y,z,{key} [deg]\na,1,0.5,0.4,{v}\n',
     r'line 2 \(a\): {key} = 90 rad is beyond one turn; allowed: \[-2pi, 2pi\] rad \(degrees\? a file in degrees '
     r'declares them: "{key} \[deg\]" in the header or a "# units: deg" line before it\)'),
    ('u.csv', '# units: rad\nname,x,y,z,{key}\na,1,0.5,0.4,{v}\n', '# units: deg\nname,x,y,z,{key}\na,1,0.5,0.4,{v}\n',
     r'line 3 \(a\): {key} = 90 rad is beyond one turn'),
])
@pytest.mark.parametrize('key', ['heading', 'azimuth', 'tilt'])   # tilt: 36001.2 deg passed as 1.2 deg
def test_an_orientation_beyond_a_turn_is_degrees_in_a_file_in_radians(tmp_path, name, rad, deg, message, key):
    """``heading: 90`` in a file in radians was 14.3 turns, taken modulo 2 pi as 2.04 rad: a wrong station
    silently. It is refused naming the key, the value and how the file declares degrees; in degrees it is pi/2, and
    6.2 rad (within a turn) passes as is."""
    with pytest.raises(ConfigError, match=message.format(key=key)):
        load_stations(_write(tmp_path, name, rad.format(key=key, v=90)))
    for text, v, want in ((deg, 90, math.pi / 2), (rad, 6.2, 6.2), (rad, -6.2, -6.2), (deg, -360, -2 * math.pi),
                          (rad, 2 * math.pi, 2 * math.pi)):
        got = getattr(load_stations(_write(tmp_path, name, text.format(key=key, v=repr(v)))).stations, key)
        assert got[0] == pytest.approx(want, abs=1e-15)
    with pytest.raises(ConfigError, match=f'{key} = 361 deg is beyond one turn; allowed: \\[-360, 360\\] deg$'):
        load_stations(_write(tmp_path, name, deg.format(key=key, v=361)))
    with pytest.raises(ConfigError, match=f'{key} = 6.2832 rad is beyond one turn'):   # 2 pi + 7e-6
        load_stations(_write(tmp_path, name, rad.format(key=key, v=6.2832)))


@pytest.mark.parametrize('name, text, message', [
    ('s.csv', 'name,x,y,z\nfar,2300,-900,800\n',
     r"s.csv: line 2 \(far\): position = \(2300, -900, 800\) m; allowed: each coordinate within \+-100 m of the "
     r'world origin; as millimetres it would be 2.3 m: millimetres given as metres\?'),
    ('s.yaml', 'stations:\n  - {name: far, position: [0.5, 0.2, 150]}\n',
     r"s.yaml: stations\[0\] \(far\): position = \(0.5, 0.2, 150\) m; allowed: each coordinate within \+-100 m of "
     r'the world origin; as millimetres'),
    ('m.csv', '# units: mm\nname,x,y,z\nfar,230000,0,800\n',
     r'position = \(230, 0, 0.8\) m; allowed: each coordinate within \+-100 m of the world origin$'),
    # beyond every number's bound (1e6 in the file's unit) it named that bound, not the positions' 100 m
    ('y.yaml', 'units: {length: mm}\nstations:\n  - {name: far, position: [2.3e7, 0, 800]}\n',
     r'x = 23000000.0 is invalid; allowed: a finite number in mm \(within \+-100 m of the world origin\)$')])
def test_a_station_beyond_the_world_bound_is_refused(tmp_path, name, text, message):
    """The cell's and the robot base's bound (``WORLD_BOUND``, 100 m): an imported station a program did not use,
    in millimetres read as metres, passed its check unmentioned; the hint only where millimetres would fit."""
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(ConfigError, match=message):
        load_stations(path)


def test_the_world_bound_takes_100_m_and_hints_millimetres_only_where_they_fit(tmp_path):
    """A station exactly 100 m from the world origin (``WORLD_BOUND``) is accepted, 100.000001 m refused; a file in
    metres with 2e4 m is told 'as millimetres it would be 20 m', one with 2e5 m (200 m as millimetres: beyond the
    bound still) gets no such hint."""
    for xyz in ('100,0,0.4', '0,-100,0.4', '1,2,100'):
        st = load_stations(_write(tmp_path, 'edge.csv', f'name,x,y,z\nedge,{xyz}\n')).stations
        assert np.max(np.abs(st.position)) == 100.0
    with pytest.raises(ConfigError, match=r'position = \(100, 0, 0.4\) m; allowed: each coordinate within \+-100 m '
                                          r'of the world origin; as millimetres it would be 0.1 m: millimetres given'):
        load_stations(_write(tmp_path, 'past.csv', 'name,x,y,z\npast,100.000001,0,0.4\n'))
    with pytest.raises(ConfigError, match=r'position = \(20000, 0, 0.4\) m; allowed: each coordinate within \+-100 m '
                                          r'of the world origin; as millimetres it would be 20 m: millimetres given'):
        load_stations(_write(tmp_path, 'mm.csv', 'name,x,y,z\nfar,20000,0,0.4\n'))
    with pytest.raises(ConfigError, match=r'position = \(0, 200000, 0.4\) m; allowed: each coordinate within \+-100 m '
                                          r'of the world origin$'):
        load_stations(_write(tmp_path, 'km.csv', 'name,x,y,z\nfar,0,200000,0.4\n'))


def test_check_world_position_bound_and_hint():
    """The public check itself: 100 m passes, 100 m + 1 um is refused; the hint ({mm}: the farthest coordinate as
    millimetres) where that fits the bound, 100 000 m exactly (100 m as millimetres) included, not at 2e5 m."""
    from gpr_kinematics.errors import InputError
    from gpr_kinematics.inputs.validation import WORLD_BOUND
    from gpr_kinematics.robot.fields import check_world_position

    assert WORLD_BOUND == 100.0
    for xyz in ([100.0, 0.0, 0.0], [-100.0, 100.0, -100.0]):
        assert check_world_position(xyz, 'p', ' [{mm} m as mm]') is None
    with pytest.raises(InputError, match=r'^p = \(0, 0, -100\) m; allowed: each coordinate within \+-100 m of the '
                                         r'world origin \[0.1 m as mm\]$'):
        check_world_position([0.0, 0.0, -100.000001], 'p', ' [{mm} m as mm]', InputError)
    with pytest.raises(ConfigError, match=r'\(20000, 0, 0\) m; .* world origin \[20 m as mm\]$'):
        check_world_position([2e4, 0.0, 0.0], 'p', ' [{mm} m as mm]')
    with pytest.raises(ConfigError, match=r'\(100000, 0, 0\) m; .* world origin \[100 m as mm\]$'):
        check_world_position([1e5, 0.0, 0.0], 'p', ' [{mm} m as mm]')
    with pytest.raises(ConfigError, match=r'\(200000, 0, 0\) m; allowed: each coordinate within \+-100 m of the world '
                                          r'origin$'):
        check_world_position([2e5, 0.0, 0.0], 'p', ' [{mm} m as mm]')

"""Units of CSV columns (gpr_kinematics.inputs.units): one rule for measurement files, station files and joint tables --
a column's own unit in brackets, else the file's ``# units:`` line, else SI -- the same values read either way."""
import math

import numpy as np
import pytest
from gpr_kinematics.calibration.measurements import parse_measurements
from gpr_kinematics.errors import ConfigError, FileError, InputError
from gpr_kinematics.inputs import units
from gpr_kinematics.robot.station_files import read_csv_table, stations_from_csv

ROW_MM = '300,301,299,0.01,-0.02,300,0.006,0.0001,0.0,0.999981999'
Q_SI = [0.3, 0.301, 0.299]


def test_column_cells_and_units_lines():
    assert units.column(' q1 [MM] ', 'l') == ('q1', 'mm') and units.column('name', 'l') == ('name', None)
    assert units.file_units('#units: rad, mm', 'l') == ('mm', 'rad')
    assert units.file_units('# UNITS: deg', 'l') == (None, 'deg')
    with pytest.raises(FileError, match=r"unit 'inch' in \"# units:\" is unknown or repeated"):
        units.file_units('# units: inch', 'l')
    for line in ('# units:', '# units: ,', '#units:   '):   # taken as SI before: a line meant to say something
        with pytest.raises(FileError, match=r'"# units:" names no unit; allowed: one of m, mm'):
            units.file_units(line, 'l')
    with pytest.raises(FileError, match=r'header column .* is not a name with an optional unit in brackets, e.g. '
                                        r'"x \[mm\]"$'):
        units.column('x [mm', 'l')
    # a spreadsheet's export with semicolons or tabs between the columns: said so
    for cell, name in (('q1;q2;q3', 'semicolons'), ('q1\tq2', 'tabs')):
        with pytest.raises(FileError, match=rf'\(the columns are separated by {name}: separate them by commas, and '
                                            r'write numbers with a decimal point\)$'):
            units.column(cell, 'l')
    # Own unit first, then the file's, then SI; a unit that does not fit the column is refused.
    assert units.scale('length', 'm', ('mm', 'deg'), 'l', 'x') == (1.0, 'm')
    assert units.scale('angle', None, ('mm', 'deg'), 'l', 'tilt') == (math.pi / 180, 'deg')
    assert units.scale('angle', None, (None, None), 'l', 'tilt') == (1.0, 'rad')
    with pytest.raises(FileError, match=r'column x: unit \[deg\] is invalid; allowed: m or mm \(a length\)'):
        units.scale('length', 'deg', (None, None), 'l', 'x')
    with pytest.raises(FileError, match=r'column tilt: unit \[degree\] is invalid; allowed: rad or deg \(an angle\)$'):
        units.scale('angle', 'degree', (None, None), 'l', 'tilt')   # it said "(a angle)"
    with pytest.raises(FileError, match=r'column qx takes no unit, got \[mm\]'):
        units.scale('number', 'mm', (None, None), 'l', 'qx')
    assert issubclass(FileError, ConfigError) and issubclass(FileError, InputError)


@pytest.mark.parametrize('pre, header', [
    (('# units: mm',), 'q1,q2,q3,x,y,z,qx,qy,qz,qw'),                                # the file's unit
    ((), 'q1 [mm],q2 [mm],q3 [mm],x [mm],y [mm],z [mm],qx,qy,qz,qw'),                # each column's own
    (('# units: m',), 'q1 [mm],q2 [mm],q3 [mm],x [mm],y [mm],z [mm],qx,qy,qz,qw'),   # own before the file's
])
def test_measurement_files_take_both_conventions(pre, header):
    m = parse_measurements('\n'.join([*pre, header, ROW_MM]) + '\n', 'm.csv')
    np.testing.assert_allclose(m.q[0], Q_SI, rtol=0, atol=1e-15)
    np.testing.assert_allclose(m.position[0], [1e-5, -2e-5, 0.3], rtol=0, atol=1e-15)


def test_measurement_sigma_units_in_brackets():
    header = 'q1,q2,q3,x,y,z,qx,qy,qz,qw,sigma_position [mm],sigma_angle [deg]'
    row = '0.3,0.301,0.299,1e-5,-2e-5,0.3,0.006,0.0001,0.0,0.999981999,0.005,0.001'
    m = parse_measurements(f'{header}\n{row}\n', 'm.csv')
    assert m.sigma_position[0] == pytest.approx(5e-6, rel=1e-15)
    assert m.sigma_angle[0] == pytest.approx(math.radians(0.001), rel=1e-15)
    with pytest.raises(InputError, match=r'column qw takes no unit'):
        parse_measurements('q1,q2,q3,x,y,z,qx,qy,qz,qw [deg]\n' + ROW_MM + '\n', 'm.csv')


@pytest.mark.parametrize('text', [
    'name,x [mm],y [mm],z [mm],tilt [deg],heading [deg]\na,1100,250,420,1.2,90\n',       # units in brackets
    '# units: mm deg\nname,x,y,z,tilt,heading\na,1100,250,420,1.2,90\n',               # a units line
    '# stations of the cell\n# units: deg\nname,x [mm],y [mm],z [mm],tilt,heading\na,1100,250,420,1.2,90\n',
    'name,x,y,z,tilt,heading\na,1.1,0.25,0.42,0.020943951023931952,1.5707963267948966\n',   # SI
])
def test_station_files_take_both_conventions(text):
    rows = stations_from_csv(text, 's.csv')
    np.testing.assert_allclose(rows.position[0], [1.1, 0.25, 0.42], rtol=0, atol=1e-15)
    assert rows.tilt[0] == pytest.approx(math.radians(1.2), abs=1e-17)
    assert rows.heading[0] == pytest.approx(math.pi / 2, abs=1e-15)


def test_a_units_line_after_the_header_or_twice_is_refused():
    kinds = {'name': 'text', 'x': 'length'}
    with pytest.raises(ConfigError, match=r'line 2: "# units:" must come once, before the header row'):
        read_csv_table('name,x\n# units: mm\na,1\n', 's.csv', kinds, ('name',))
    with pytest.raises(ConfigError, match=r'line 2: "# units:" must come once'):
        read_csv_table('# units: mm\n# units: m\nname,x\na,1\n', 's.csv', kinds, ('name',))
    table = read_csv_table('# units: mm\nname,x\na,1\n', 's.csv', kinds, ('name',))
    assert table.number(0, 'x', None) == pytest.approx(1e-3, rel=1e-15)

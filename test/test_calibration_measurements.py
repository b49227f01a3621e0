"""Measurement files (gpr_kinematics.calibration.measurements, .files): the format, units, exact round trips, and
every malformed file refused with the line and the column named; bounded reading; safe writing."""
from __future__ import annotations

import doctest
import math
import os
import threading

import numpy as np
import pytest
from gpr_kinematics.calibration import files, measurements
from gpr_kinematics.calibration.measurements import (
    Measurements,
    format_measurements,
    parse_measurements,
    read_measurements,
    write_measurements,
)
from gpr_kinematics.errors import InputError

HEADER = 'q1,q2,q3,x,y,z,qx,qy,qz,qw'
ROW = '0.3,0.301,0.299,1e-5,-2e-5,0.3,0.006,0.0001,0.0,0.999981999'   # |quat| = 1 within 1e-6


def text(*rows: str, header: str = HEADER, pre: tuple[str, ...] = ()) -> str:
    return '\n'.join([*pre, header, *rows]) + '\n'


def test_parse_si_file_with_comments_and_blank_lines():
    m = parse_measurements(text(ROW, '', '# a comment', ROW.replace('0.3,', '0.31,', 1), pre=('# run 1', '')), 'f.csv')
    assert len(m) == 2 and m.lines == (4, 7)   # lines: comment, blank, header, row, blank, comment, row
    np.testing.assert_array_equal(m.q[1], [0.31, 0.301, 0.299])
    np.testing.assert_array_equal(m.position[0], [1e-5, -2e-5, 0.3])
    assert m.sigma_position is None and m.sigma_angle is None and m.units == ('m', 'rad')
    assert abs(np.linalg.norm(m.quaternion[0]) - 1.0) < 1e-15
    R = m.rotation[0]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)


def test_columns_in_any_order_with_sigmas_and_declared_units():
    header = 'qw,qx,qy,qz,x,y,z,q3,q2,q1,sigma_angle,sigma_position'
    row = '0.999981999,0.006,0.0001,0.0,0.01,-0.02,300,299,301,300,0.001,0.005'
    m = parse_measurements(text(row, header=header, pre=('# units: mm deg',)), 'f.csv')
    np.testing.assert_allclose(m.q[0], [0.3, 0.301, 0.299], rtol=0, atol=1e-15)
    np.testing.assert_allclose(m.position[0], [1e-5, -2e-5, 0.3], rtol=0, atol=1e-15)
    assert m.sigma_position[0] == pytest.approx(5e-6, rel=1e-15)
    assert m.sigma_angle[0] == pytest.approx(math.radians(0.001), rel=1e-15)
    np.testing.assert_allclose(m.quaternion[0], np.array([0.006, 0.0001, 0.0, 0.999981999]) /
                               np.linalg.norm([0.006, 0.0001, 0.0, 0.999981999]), atol=0)
    assert m.units == ('mm', 'deg')
    # A length unit alone keeps radians for the angle sigma.
    assert parse_measurements(text(ROW, pre=('# Units: MM',))).units == ('mm', 'rad')


def test_write_read_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(0)
    n = 7
    quat = rng.normal(size=(n, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    m = Measurements('x', rng.uniform(0, 0.5, (n, 3)), rng.normal(0, 1e-3, (n, 3)), quat,
                     rng.uniform(1e-6, 1e-5, n), rng.uniform(1e-5, 1e-4, n), tuple(range(n)))
    path = write_measurements(tmp_path / 'm.csv', m, comments=('made by a test',))
    back = read_measurements(path)
    for name in ('q', 'position', 'sigma_position', 'sigma_angle'):
        np.testing.assert_array_equal(getattr(back, name), getattr(m, name))
    np.testing.assert_allclose(back.quaternion, m.quaternion, rtol=0, atol=2e-16)
    assert path.read_text().startswith('# made by a test\n# units: m rad\n')
    assert format_measurements(back).count('\n') == n + 2


@pytest.mark.parametrize('content, pattern', [
    (text(ROW, header='q1,q2,q3,x,y,z,qx,qy,qz'), r'f\.csv line 1: missing column\(s\) qw'),
    (text(ROW + ',1', header=HEADER + ',temperature'), r"line 1: unknown column 'temperature'; allowed: q1"),
    (text(ROW + ',1', header=HEADER + ',x'), r"line 1: column 'x' appears 2 times"),
    (text(ROW.replace('1e-5', 'nan')), r'line 2, column x: nan is not a finite number'),
    (text(ROW.replace('0.301', 'inf')), r'line 2, column q2: inf is not a finite number'),
    (text(ROW.replace('0.301', '0.3O1')), r"line 2, column q2: '0\.3O1' is not a number; allowed: a decimal "
                                          r"number such as 0\.25 or -1\.5e-3$"),
    # a spreadsheet's export in a locale with decimal commas: a quoted number with a comma, semicolons between columns
    (text(ROW.replace('0.301', '"0,301"')),
     r"line 2, column q2: '0,301' is not a number \(a decimal comma: write a decimal point, 0\.301\); allowed: "
     r"a decimal number"),
    (text(ROW.replace(',', ';'), header=HEADER.replace(',', ';')),
     r"line 1: header column 'q1;q2;.*' is not a name .* \(the columns are separated by semicolons: separate them "
     r'by commas, and write numbers with a decimal point\)$'),
    # float() read 1_0 as 10 and other scripts' digits as numbers (YAML files refuse them as text)
    (text(ROW.replace('0.301', '0.3_01')), r"line 2, column q2: '0\.3_01' is not a number"),
    (text(ROW.replace('0.301', '\u0660.\u0663\u0660\u0661')), r"line 2, column q2: '.*' is not a number"),
    (text(ROW.replace('0.999981999', '0.9')), r'line 2, columns qx qy qz qw: quaternion norm 0\.9000'),
    (text(ROW + ',0', header=HEADER + ',sigma_position'),
     r"line 2, column sigma_position: 0 m is outside \[1e-09, 0\.1\] m$"),
    (text(ROW + ',10', header=HEADER + ',sigma_angle', pre=('# units: mm deg',)),
     r"line 3, column sigma_angle: 0\.174532925 rad \(converted from deg\) is outside \[1e-09, 0\.1\] rad$"),
    (text(ROW.replace('1e-5', '-2e6')),
     r'line 2, column x: -2e\+06 is implausibly large; allowed: \|value\| <= 1e\+06'),
    (text(ROW, pre=('# units: inch',)), r"line 1: unit 'inch' in \"# units:\" is unknown or repeated"),
    (text(ROW, pre=('# units: mm mm',)), r"unit 'mm' in \"# units:\" is unknown or repeated"),
    (text(ROW, '# units: mm'), r'line 3: "# units:" must come once, before the header row'),
    # a units line misspelt was a comment: millimetres read as metres
    (text(ROW, pre=('# unit: mm',)), r"line 1: '# unit: mm' speaks of units but is not a \"# units:\" line"),
    (text(ROW, ROW), r'f\.csv line 3 repeats line 2 exactly'),
    (text(ROW + ',0.1'), r'line 2: 11 values, but the header names 10 columns'),
    ('# only comments\n\n', r'f\.csv: no header row'),
    ('', r'^f\.csv: the file is empty; the first line that is not a comment must name the columns'),
    ('q1,q2,q3,x,y,z,\n0.3,0.3,0.3,0,0,0.3,\n', r'^f\.csv line 1: a header column without a name \(a comma too many, '
                                              r'at the end of the line\?\)'),   # it said "header column ''
    (text(), r'f\.csv: no data rows after the header'),
    (text(ROW, header='q1,q2,"q3'), r'line 1: (not a CSV row|missing column)'),
])
def test_malformed_content_refused_with_line_and_column(content, pattern):
    with pytest.raises(InputError, match=pattern):
        parse_measurements(content, 'f.csv')


def test_bytes_are_refused_naming_what_to_give():
    """The bytes of a file raised a bare TypeError at the split into lines."""
    with pytest.raises(InputError, match=r"^f\.csv: the text given is a bytes; allowed: a str \(bytes: decode them "
                                         r"first, e\.g\. data\.decode\('utf-8'\)\)$"):
        parse_measurements(text(ROW).encode(), 'f.csv')   # type: ignore[arg-type]


def test_an_empty_unit_in_brackets_is_refused():
    """``q1 []`` read as metres, under ``# units: mm`` too (q1 = 300 m, refused as outside the stroke, or 0.3 read as
    0.3 m where 0.3 mm was meant); now refused naming the column and the units allowed, also for an angle column.
    Without brackets the file's unit applies (q1 0.3 mm = 3e-4 m)."""
    lines = {}
    for header, pre in (('q1 [],q2,q3,x,y,z,qx,qy,qz,qw', ()), ('q1,q2,q3,x [ ],y,z,qx,qy,qz,qw', ('# units: mm',))):
        with pytest.raises(InputError) as exc:
            parse_measurements(text(ROW, header=header, pre=pre), 'f.csv')
        lines[header[:6]] = str(exc.value)
    assert lines == {
        'q1 [],': 'f.csv line 1: column q1: the unit in brackets is empty; allowed: m or mm (a length), or no brackets '
                  "for the file's units",
        'q1,q2,': 'f.csv line 2: column x: the unit in brackets is empty; allowed: m or mm (a length), or no brackets '
                  "for the file's units"}
    from gpr_kinematics.inputs.units import scale
    with pytest.raises(InputError, match=r"^l: column tilt: the unit in brackets is empty; allowed: rad or deg \(an "
                                         r"angle\), or no brackets for the file's units$"):
        scale('angle', '', ('mm', 'deg'), 'l', 'tilt')
    m = parse_measurements(text(ROW, pre=('# units: mm',)), 'f.csv')
    assert m.q[0].tolist() == [3e-4, 0.301e-3, 0.299e-3]


def test_row_and_line_limits(monkeypatch):
    with pytest.raises(InputError, match=r'line 2: 2049 characters; allowed: at most 2048'):
        parse_measurements(text('0' * 2049), 'f.csv')
    monkeypatch.setattr(measurements, 'MAX_ROWS', 2)
    rows = [ROW.replace('0.3,', f'0.{i}1,', 1) for i in range(3)]
    with pytest.raises(InputError, match=r'line 4: more than 2 data rows'):
        parse_measurements(text(*rows), 'f.csv')


def test_too_many_rows_are_refused_before_any_is_parsed(tmp_path):
    """Bounds before work: 100,001 rows were refused only once every row had been parsed (7-12 s); now they are
    counted first. Row 50,000 is not a number and row 100,001 is fine: the row count is refused, not the number
    (which came first before the count), naming the line of the row too many (comments and blank lines are not
    rows); and a file of exactly MAX_ROWS rows reaches row 50,000's error."""
    n = measurements.MAX_ROWS
    assert n == 100_000
    rows = [ROW.replace('0.3,', f'0.3{i:06d},', 1) for i in range(n + 1)]
    rows[49_999] = rows[49_999].replace('0.301', 'x.301', 1)
    lines = ['# units: m rad', '', HEADER, '# a comment', ''] + rows
    path = tmp_path / 'many.csv'
    path.write_text('\n'.join(lines) + '\n')
    with pytest.raises(InputError) as refused:
        read_measurements(path)
    assert str(refused.value) == (f"{path} line {n + 6}: more than 100000 data rows; allowed: at most 100000")
    with pytest.raises(InputError, match=r"line 50005, column q2: 'x\.301' is not a number"):
        parse_measurements('\n'.join(lines[:-1]) + '\n', 'f.csv')


def test_file_kinds_size_and_encoding(tmp_path, monkeypatch):
    with pytest.raises(InputError, match=r"cannot read measurement file '.*missing\.csv': No such file"):
        read_measurements(tmp_path / 'missing.csv')
    with pytest.raises(InputError, match=r'is not a regular file \(a directory\)'):
        read_measurements(tmp_path)
    fifo = tmp_path / 'fifo'
    os.mkfifo(fifo)
    done = []
    t = threading.Thread(target=lambda: done.append(pytest.raises(InputError, read_measurements, fifo)))
    t.start()
    t.join(5.0)
    assert done and 'not a regular file' in str(done[0].value)   # answered at once: no writer was waited for
    bad = tmp_path / 'latin1.csv'
    bad.write_bytes((text(ROW) + '# caf\xe9\n').encode('latin-1'))
    with pytest.raises(InputError, match=r"latin1\.csv' is not UTF-8 text \(byte \d+ is 0xe9\) on line 3"):
        read_measurements(bad)
    bom = tmp_path / 'bom.csv'
    bom.write_bytes(b'\xef\xbb\xbf' + text(ROW).encode())
    assert len(read_measurements(bom)) == 1
    monkeypatch.setattr(measurements, 'MAX_FILE_BYTES', 50)
    with pytest.raises(InputError, match=r'has \d+ bytes; allowed: at most 50'):
        read_measurements(bom)


def test_doctests():
    assert doctest.testmod(files).failed == 0


def test_write_text_refuses_non_regular_targets_and_is_atomic(tmp_path):
    with pytest.raises(InputError, match=r'exists and is not a regular file'):
        files.write_text(tmp_path, 'x', 'plan')
    with pytest.raises(InputError, match=r'exists and is not a regular file'):
        files.write_text('/dev/null', 'x', 'plan')
    with pytest.raises(InputError, match=r'cannot write plan file .*No such file'):
        files.write_text(tmp_path / 'no' / 'dir.csv', 'x', 'plan')
    with pytest.raises(InputError, match=r'output path is empty'):
        files.write_text('', 'x', 'plan')
    target = tmp_path / 'out.csv'
    target.write_text('old')
    files.write_text(target, 'new\n', 'plan')
    assert target.read_text() == 'new\n' and sorted(p.name for p in tmp_path.iterdir()) == ['out.csv']


def test_measurements_built_by_a_caller_are_checked():
    """Measurements made in code (not read from a file) were taken as given: a NaN position ended in numpy's 'SVD did
    not converge', a zero sigma in a division by zero and the same, 5 positions for 8 rods in a broadcasting error,
    too few line numbers in an IndexError, and a quaternion of norm 2 passed the gate. Each is now an InputError
    naming the field and what is allowed; a valid set is unchanged."""
    rng = np.random.default_rng(0)
    q, p = rng.uniform(0.1, 0.4, (8, 3)), rng.normal(0.0, 1e-3, (8, 3))
    quat = rng.normal(size=(8, 4))
    quat /= np.linalg.norm(quat, axis=1)[:, None]
    lines = tuple(range(2, 10))
    nan = p.copy()
    nan[2, 0] = np.nan
    ok = measurements.Measurements('m', q, p, quat, np.full(8, 3e-6), np.full(8, 2e-5), lines)
    assert len(ok) == 8
    huge = p.copy()
    huge[3, 1] = 1e306   # reached scipy's cKDTree "data must be finite" in the repeated-rows check
    for args, pattern in (((q, nan, quat, None, None, lines), r'm: Measurements\.position of row 2 is not finite'),
                          ((q, huge, quat, None, None, lines), r'position of row 3 is not finite or beyond \+-1e\+06'),
                          ((q, p[:5], quat, None, None, lines), r'Measurements\.position has shape \(5, 3\) '
                                                                 r'\(float64\); allowed: numbers of shape \(8, 3\)'),
                          ((q[:, :2], p, quat, None, None, lines), r'Measurements\.q has shape \(8, 2\)'),
                          ((q, p, quat, None, None, lines[:2]), r'2 line numbers for 8 rows; allowed: one per row'),
                          ((q, p, 2 * quat, None, None, lines), r'quaternion of row 0 has norm 2; allowed: unit'),
                          ((q, p, quat, np.zeros(8), None, lines), r'sigma_position outside \[1e-09, 0\.1\]'),
                          ((q, p, quat.astype(str), None, None, lines), r'Measurements\.quaternion has shape'),
                          ((q[:0], p[:0], None, None, None, ()), r'Measurements\.q has shape \(0, 3\)'),
                          ((q, p, quat, None, None, lines, ('m', 'rad'), ('a.csv',) * 3),
                           r'3 file names for 8 rows; allowed: one per row, or none')):
        with pytest.raises(InputError, match=pattern):
            measurements.Measurements('m', *args)


@pytest.mark.parametrize('kwargs, pattern', [
    ({'sigma_position': -1e-6}, r'^sigma_position = -1e-06 m is outside \[1e-09, 0\.1\] m; allowed: a standard '
                                r'deviation in that range$'),
    ({'sigma_angle': 'a'}, r"^sigma_angle must be a number or an array of numbers, got 'a'$"),
    ({'sigma_position': [1e-6, 2e-6]}, r'^sigma_position must be a single number \[m\] \(one standard deviation for '
                                       r'every row\), got shape \(2,\)$'),
    ({'sigma_position': 0.5, 'with_sigmas': False}, r'^sigma_position = 0\.5 m is outside \[0, 0\.1\] m; allowed: a '
                                                    r'standard deviation in that range \(0: no noise\)$'),
    ({'seed': 'a'}, r"^seed = 'a' is invalid; allowed: an integer from 0 to 2\*\*63 - 1$"),
    ({'seed': -1}, r'^seed = -1 is invalid; allowed: an integer from 0 to 2\*\*63 - 1$'),
])
def test_synthetic_measurements_name_a_bad_sigma_or_seed(kwargs, pattern):
    """A negative sigma was numpy's 'scale < 0', a sigma of text or one per row a bare ValueError, seed='a' a
    TypeError and seed=-1 a ValueError; a noise-free set (sigma 0, not recorded) is still made."""
    from gpr_kinematics.calibration.core_model import CoreModel
    from gpr_kinematics.calibration.synthetic import synthetic_measurements
    from gpr_kinematics.core.config import load_config

    model = CoreModel(load_config())
    args = {'sigma_position': 1e-6, 'sigma_angle': 1e-5} | kwargs
    with pytest.raises(InputError, match=pattern):
        synthetic_measurements(model, model.parameters.nominal, [[0.3, 0.3, 0.3], [0.2, 0.2, 0.2]], **args)
    exact = synthetic_measurements(model, model.parameters.nominal, [[0.3, 0.3, 0.3]], 0.0, 0.0, with_sigmas=False)
    assert exact.sigma_position is None and np.all(np.isfinite(exact.position))


def test_synthetic_points_take_any_sigma_angle_and_a_sigma_at_the_top_of_its_range():
    """Points record no angle sigma, so sigma_angle=0 is taken (no noise drawn on an orientation not kept); a sigma
    of exactly 0.1 (the top of SIGMA_RANGE) is taken, recorded or not."""
    from gpr_kinematics.calibration.core_model import CoreModel
    from gpr_kinematics.calibration.synthetic import synthetic_measurements
    from gpr_kinematics.core.config import load_config

    model = CoreModel(load_config())
    Q = [[0.3, 0.3, 0.3], [0.2, 0.2, 0.2]]
    pts = synthetic_measurements(model, model.parameters.nominal, Q, 1e-6, 0.0, points=True)
    assert pts.quaternion is None and pts.sigma_angle is None and pts.sigma_position.tolist() == [1e-6, 1e-6]
    top = synthetic_measurements(model, model.parameters.nominal, Q, 0.1, 0.1)
    assert top.sigma_position.tolist() == [0.1, 0.1] and top.sigma_angle.tolist() == [0.1, 0.1]
    bare = synthetic_measurements(model, model.parameters.nominal, Q, 0.1, 0.1, with_sigmas=False)
    assert bare.sigma_position is None and np.all(np.isfinite(bare.position))


def test_measurements_built_from_lists_are_the_files_arrays():
    """Measurements built in code with lists passed the checks, then len() raised AttributeError (it reads
    q.shape); lines=None was a TypeError. Lists of numbers become float arrays, lines a tuple of integers."""
    m = Measurements('m', [[0.3, 0.3, 0.3], [0.2, 0.2, 0.2]], [[0.0, 0.0, 0.3], [0.0, 0.0, 0.2]], None, [1e-6, 2e-6],
                     None, [2, 3])
    assert len(m) == 2 and m.lines == (2, 3)
    assert all(isinstance(a, np.ndarray) and a.dtype == float for a in (m.q, m.position, m.sigma_position))
    for lines, shown in ((None, 'None'), ('ab', "'ab'"), ([2, 2.5], r'\[2, 2\.5\]'), ([-1, 2], r'\[-1, 2\]')):
        with pytest.raises(InputError, match=rf'^m: Measurements\.lines = {shown}; allowed: the line number of each '
                                             r'row, integers >= 0$'):
            Measurements('m', m.q, m.position, None, None, None, lines)


def test_the_documented_example_file_is_read():
    """docs/calibration.md's example measurement file (its quaternion's norm was 0.9999908: refused by the
    unit-quaternion rule, |norm - 1| <= 1e-6)."""
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / 'docs' / 'calibration.md').read_text(encoding='utf-8')
    block = doc.split('## Measurement files', 1)[1].split('```text\n', 1)[1].split('```', 1)[0]
    m = parse_measurements(block, 'doc.csv')
    assert len(m) == 1 and m.units == ('mm', 'deg')
    np.testing.assert_allclose(m.q[0], [0.25, 0.2521, 0.2483], rtol=0, atol=1e-15)
    np.testing.assert_allclose(m.position[0], [1.31e-5, -2.05e-5, 0.2501], rtol=0, atol=1e-15)
    assert m.sigma_position[0] == pytest.approx(5e-6, rel=1e-12)

"""``gpr calibrate`` end to end: the shipped synthetic file, the calibrated geometry used by other commands, the plan,
printed numbers equal to the JSON's, and every bad input answered with exit 2 and one line."""
from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gpr_kinematics.calibration import demo
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.measurements import read_measurements
from gpr_kinematics.cli.main import main
from gpr_kinematics.core import forward
from gpr_kinematics.core.config import load_config
from gpr_kinematics.inputs.resources import config_path
from scipy.special import erfcinv

SHIPPED = str(config_path('calibration/synthetic_measurements.csv'))


def run(capsys, *argv):
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def test_calibrate_shipped_file_json_and_config(capsys, tmp_path):
    out_yaml = tmp_path / 'cal.yaml'
    status, out, err = run(capsys, 'calibrate', SHIPPED, '--output', str(out_yaml), '--json')
    assert status == 0, err
    d = json.loads(out)
    assert d['rows'] == demo.ROWS and d['output'] == str(out_yaml) and d['absolute_sigma'] and d['model'] == 'compliant'
    params = {p['name']: p for p in d['parameters']}
    assert {n for n, p in params.items() if p['status'] == 'held'} == {'joint1_x', 'joint2_y', 'joint3_y'}
    truth = dict(zip(params, demo.true_values(CoreModel(load_config())).tolist(), strict=True))
    for name, p in params.items():
        if p['status'] == 'fitted' and not name.startswith('joint'):    # (the joints: up to the held combinations)
            assert abs(p['estimate'] - truth[name]) < 3 * p['standard_error'], name
    assert params['kappa2']['nominal'] == 1000.0 and abs(params['kappa2']['estimate'] - 3.0) < 0.6
    assert d['residuals']['after']['rms_position'] < d['residuals']['before']['rms_position'] / 5
    cal = load_config(out_yaml)
    assert cal.model == 'compliant' and cal.kappa[1] == params['kappa2']['estimate']
    assert cal.rod_offsets[0] == params['rod1_offset']['estimate'] and cal.rod_positions[1][0] == \
        params['rod2_x']['estimate']
    status, out, _ = run(capsys, 'fk', '0.3', '0.301', '0.299', '--config', str(out_yaml), '--json')
    fk = json.loads(out)
    assert status == 0 and fk['q'] == [0.3, 0.301, 0.299] and fk['model'] == 'compliant'
    np.testing.assert_allclose(fk['position'], forward([0.3, 0.301, 0.299], cal).position, rtol=0, atol=1e-15)
    # The configurations it was measured at, with the calibrated geometry (the real machine, held to its tilt limit):
    # planned 5 % inside the limit, every one passes, the largest tilt 1.9215 deg; planned at 99.5 %, 14 of the 40
    # tilted the calibrated machine 2.003-2.011 deg and gpr fk refused them.
    tilts = []
    for q in read_measurements(SHIPPED).q.tolist():
        status, out, err = run(capsys, 'fk', *map(repr, q), '--config', str(out_yaml), '--json')
        assert status == 0, err
        tilts.append(json.loads(out)['tilt'])
    assert len(tilts) == demo.ROWS and math.degrees(max(tilts)) == pytest.approx(1.92152, abs=1e-5)


def test_free_repeated_adds_up(capsys, tmp_path):
    """``--free kappa --free rod_offsets`` frees the six parameters of both (only the last option's three were)."""
    status, out, err = run(capsys, 'calibrate', SHIPPED, '--output', str(tmp_path / 'a.yaml'), '--free', 'kappa',
                           '--free', 'rod_offsets', '--json')
    fitted = [p['name'] for p in json.loads(out)['parameters'] if p['status'] == 'fitted']
    assert fitted == ['rod1_offset', 'kappa1', 'rod2_offset', 'kappa2', 'rod3_offset', 'kappa3'], err


def test_calibrate_text_matches_json(capsys, tmp_path):
    """With only the offsets and kappa free, the rods' places and tilts of the machine that made the file are left
    unexplained: the fit fails its chi-square gate (status 1; --force writes the file); the text and the JSON carry
    the same numbers either way."""
    free = ['--free', 'rod_offsets', 'kappa', '--force']
    status, text, err = run(capsys, 'calibrate', SHIPPED, '--output', str(tmp_path / 'a.yaml'), *free)
    assert status == 1 and (tmp_path / 'a.yaml').exists()
    assert re.fullmatch(r'gpr calibrate: the fit failed its gate: The model does not explain the measurements: '
                        r'reduced chi-square [\d.]+ above the gate 1\.\d+ .* written anyway \(--force\)\n', err)
    status, out, _ = run(capsys, 'calibrate', SHIPPED, '--output', str(tmp_path / 'b.yaml'), *free, '--json')
    d = json.loads(out)
    assert status == 1 and d['gate']['passed'] is False and d['output'] == str(tmp_path / 'b.yaml')
    for p in d['parameters']:
        row = re.search(rf'^  {p["name"]} +(\S+) +(\S+) +(\S+)(?: u\w+)? +(\S+)(?: u\w+)?  (\w+) \[', text, re.M)
        assert row, p['name']
        assert row.group(5) == p['status']
        assert float(row.group(1)) == pytest.approx(p['nominal'], rel=1e-11, abs=1e-300)     # 12 significant digits
        # Two runs agree to the fit's own resolution: Levenberg-Marquardt stops once a step is below 1e-4 of every
        # standard error, and a multithreaded BLAS may sum in another order from run to run (seen on numpy 1.26).
        resolution = 1e-4 * p['standard_error'] if p['status'] == 'fitted' else 0.0
        assert float(row.group(2)) == pytest.approx(p['estimate'], rel=1e-11, abs=max(resolution, 1e-300))
        if p['unit'] == 'm':
            assert float(row.group(3)) == pytest.approx(p['change'] * 1e6, abs=5e-4)
        if p['status'] == 'fitted':
            scale = 1e6 if p['unit'] == 'm' else 1.0
            assert float(row.group(4)) == pytest.approx(p['standard_error'] * scale, rel=1e-5, abs=5e-4)
        else:
            assert row.group(4) == '-'
    for when in ('before', 'after'):
        r = d['residuals'][when]
        m = re.search(rf'^  {when} +(\d+\.\d+) um +(\d+\.\d+) um \(line (\d+)\) +(\d+\.\d+) urad +(\d+\.\d+) urad '
                      r'\(line (\d+)\)', text, re.M)
        np.testing.assert_allclose([float(m.group(i)) for i in (1, 2, 4, 5)],
                                   np.array([r['rms_position'], r['max_position'], r['rms_angle'], r['max_angle']])
                                   * 1e6, atol=5e-4)
        assert (int(m.group(3)), int(m.group(6))) == (r['worst_position_line'], r['worst_angle_line'])
    statuses = {p['name']: p['status'] for p in d['parameters']}
    assert [n for n, st in statuses.items() if st == 'fitted'] == ['rod1_offset', 'kappa1', 'rod2_offset', 'kappa2',
                                                                    'rod3_offset', 'kappa3']
    assert f'reduced chi-square {d["chi2_reduced"]:.4g}' in text


def test_tolerance_table_sets_the_prior_and_the_sigmas(capsys, tmp_path):
    table = str(config_path('calibration/tolerances_example.yaml'))
    status, out, err = run(capsys, 'calibrate', SHIPPED, '--output', str(tmp_path / 'c.yaml'), '--tolerances', table,
                           '--json')
    assert status == 0, err
    d = json.loads(out)
    status, out, _ = run(capsys, 'calibrate', SHIPPED, '--output', str(tmp_path / 'd.yaml'), '--json')
    plain = json.loads(out)
    # the scaled singular values are in units of the table's standard deviations (rod positions: 30 um / sqrt(3)
    # against the model's 0.1 mm): the poses beat fewer of them, so more combinations are held
    assert d['identifiability']['singular_values'][0] < plain['identifiability']['singular_values'][0]
    assert len(d['identifiability']['held']) > len(plain['identifiability']['held'])
    status, out, _ = run(capsys, 'calibrate', '--plan', '5', '--tolerances', table)
    assert status == 0 and 'sigma_position 3 um, sigma_angle 20 urad' in out    # the table's measurement noise


def test_plan_json_and_csv(capsys, tmp_path):
    csv = tmp_path / 'plan.csv'
    status, out, err = run(capsys, 'calibrate', '--plan', '5', '--output', str(csv), '--json', '--index', 'smallest')
    assert status == 0, err
    d = json.loads(out)
    assert d['index_name'] == 'smallest' and len(d['configurations']) == 5 and d['index'] > d['random_index']
    lines = [ln for ln in csv.read_text().splitlines() if not ln.startswith('#')]
    assert lines[0] == 'q1,q2,q3'
    np.testing.assert_array_equal([[float(v) for v in ln.split(',')] for ln in lines[1:]],
                                  [c['q'] for c in d['configurations']])
    status, text, _ = run(capsys, 'calibrate', '--plan', '5', '--sigma-position', '0.005', '--mm')
    assert status == 0 and 'sigma_position 5 um' in text and 'observability index (product)' in text


def test_shipped_file_is_reproducible():
    """The shipped synthetic file is what the demo module makes (so its header tells the truth): the same header,
    configurations and poses; the poses to 1e-15 m and rad, the last bits of a float differ between numpy and
    LAPACK versions (the stock ROS install's numpy 1.26 among them)."""
    made = demo.shipped_measurements()
    shipped = read_measurements(SHIPPED)
    text = Path(SHIPPED).read_text(encoding='utf-8')
    comments = [ln for ln in text.splitlines() if ln.startswith('#')]
    assert comments[:len(demo.header())] == [f'# {c}' for c in demo.header()]
    np.testing.assert_array_equal(shipped.q, made.q)
    np.testing.assert_allclose(shipped.position, made.position, rtol=0, atol=1e-15)
    np.testing.assert_allclose(shipped.quaternion, made.quaternion, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(shipped.sigma_position, made.sigma_position)
    np.testing.assert_array_equal(shipped.sigma_angle, made.sigma_angle)


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def _exported(row: str, mm_decimals: int, quaternion_decimals: int) -> str:
    """A row of the shipped file (SI) as exported in mm with ``mm_decimals`` and quaternions with
    ``quaternion_decimals``."""
    v = [float(x) for x in row.split(',')]
    return ','.join([f'{x * 1000:.{mm_decimals}f}' for x in v[:6]] + [f'{x:.{quaternion_decimals}f}' for x in v[6:10]]
                    + [repr(v[10] * 1000), repr(v[11])])


def bad_inputs(tmp_path):
    lines = Path(SHIPPED).read_text(encoding='utf-8').splitlines()
    data = [ln for ln in lines if not ln.startswith('#')]
    header, rows = data[0], data[1:]
    mm_rows = []
    for r in rows:
        v = [float(x) for x in r.split(',')]
        mm_rows.append(','.join(repr(x * 1000) if i < 6 else repr(x) for i, x in enumerate(v[:10])))
    jitter = [','.join(repr(float(x) * (1 + 1e-14 * (-1) ** i)) for i, x in enumerate(r.split(','))) for r in rows]
    probe = [','.join(repr(float(x) + (0.05 if i == 5 else 0.0)) for i, x in enumerate(r.split(','))) for r in rows]
    return [
        # a probe 50 mm above the platform's origin, measured as gpr_platform: the target's options named too
        (['calibrate', write(tmp_path, 'probe.csv', '\n'.join([header] + probe)), '--output', 'x.yaml'],
         r'from the nominal model\'s .*; or a target \(a probe, a reflector\) away from the origin of gpr_platform: '
         r'give its place with --target X Y Z \[m\], or --fit-target$'),
        (['calibrate', write(tmp_path, 'probe.csv', '\n'.join([header] + probe)), '--output', 'x.yaml', '--mm'],
         r'give its place with --target X Y Z \[mm\], or --fit-target$'),   # --target in --mm's unit
        # options of a plan with a measurement file, an arm's files included: accepted, they did nothing
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--index', 'smallest'], r'--index goes with --plan'),
        (['calibrate', '--robot', 'example_robot.yaml', SHIPPED, '--output', 'x.yaml', '--points'],
         r'--points goes with --plan'),
        (['calibrate', write(tmp_path, 'twice.csv', '\n'.join([header] + rows + jitter)), '--output', 'x.yaml'],
         rf'twice\.csv line {len(rows) + 2} repeats line 2: the same rod lengths and measurement to within 0\.056 '
         r'of the standard deviation .*each measurement once'),
        # the file and its copy exported in mm with 4 decimals and quaternions with 8 (0.02 of the noise apart):
        # 1e-3 of the noise let it pass as 80 measurements, the standard errors sqrt 2 too small
        (['calibrate', write(tmp_path, 'rounded.csv', '# units: mm rad\n' + header + '\n' + '\n'.join(
            [_exported(r, 12, 12) for r in rows] + [_exported(r, 4, 8) for r in rows])), '--output', 'x.yaml'],
         rf'rounded\.csv line {len(rows) + 3} repeats line 3: the same rod lengths and measurement to within '
         r'0\.056 of the standard deviation'),
        (['calibrate', write(tmp_path, 'miss.csv', header.replace(',qw', '') + '\n' + '\n'.join(
            ','.join(r.split(',')[:9] + r.split(',')[10:]) for r in rows)), '--output', 'x.yaml'],
         r'miss\.csv line 1: missing column\(s\) qw'),
        (['calibrate', write(tmp_path, 'nan.csv', '\n'.join([header, rows[0].replace(rows[0].split(',')[3], 'nan', 1)]
                                                             + rows[1:])), '--output', 'x.yaml'],
         r'nan\.csv line 2, column x: nan is not a finite number'),
        (['calibrate', write(tmp_path, 'mm.csv', 'q1,q2,q3,x,y,z,qx,qy,qz,qw\n' + '\n'.join(mm_rows)),
          '--output', 'x.yaml'], r'mm\.csv line 2, column q1: [\d.]+ m is outside the stroke .*declare "# units: mm"'),
        # points (their target fitted) with x, y, z in mm and no units line: the target took up half the thousandfold
        # and the hint was lost ('another frame than gpr_base')
        (['calibrate', write(tmp_path, 'points_mm.csv', 'q1,q2,q3,x,y,z\n' + '\n'.join(
            ','.join(r.split(',')[:3] + [repr(float(v) * 1000) for v in r.split(',')[3:6]]) for r in rows)),
          '--output', 'x.yaml'], r'points_mm\.csv line 2: the measured point is [\d.]+ m .*\(millimetres\? declare '
                                 r'"# units: mm"\)$'),
        # the rods in mm under a "# units: mm" line, the positions left in metres: "in SI units" and no hint
        (['calibrate', write(tmp_path, 'mixed.csv', '# units: mm\n' + '\n'.join([header] + [','.join(
            [f'{float(v) * 1000!r}' for v in r.split(',')[:3]] + r.split(',')[3:10] + ['3e-3', r.split(',')[11]])
            for r in rows])), '--output', 'x.yaml'],
         r'mixed\.csv line 3: the measured pose is 0\.50\d+ m .* in gpr_base in millimetres, as the file declares '
         r'\(metres under the "# units: mm" line\? give them in mm\)$'),
        # millimetres as declared, a pose 3 m off: another frame, not "metres under the mm line"
        (['calibrate', write(tmp_path, 'far_mm.csv', '# units: mm\n' + '\n'.join([header] + [','.join(
            [f'{float(v) * 1000 + (3000.0 if k == 3 else 0.0)!r}' for k, v in enumerate(r.split(',')[:6])]
            + r.split(',')[6:10] + ['3e-3', r.split(',')[11]]) for r in rows])), '--output', 'x.yaml'],
         r'far_mm\.csv line 3: the measured pose is 3 m .* in gpr_base in millimetres, as the file declares \(another '
         r'frame than gpr_base'),
        # sigmas 30 to 60 times too small, kappa alone free: the parameters held were not named as a cause
        (['calibrate', write(tmp_path, 'tiny.csv', '\n'.join([header] + [r.replace(',3e-06,2e-05', ',1e-07,1e-06')
                                                                      for r in rows])),
          '--output', 'x.yaml', '--free', 'kappa'],
         r'tiny\.csv: the best fit leaves residuals .*or sigma columns far too small, or parameters held that are off '
         r'nominal \(21 held by --free or a tolerance of 0: rod1_x, rod1_y, rod1_offset, rod1_ux, \.\.\.\)\?$'),
        (['calibrate', write(tmp_path, 'empty.csv', header + '\n'), '--output', 'x.yaml'],
         r'empty\.csv: no data rows after the header'),
        (['calibrate', write(tmp_path, 'bare.csv', header.replace('q1', 'q1 []', 1) + '\n' + '\n'.join(rows)),
          '--output', 'x.yaml'], r'bare\.csv line 1: column q1: the unit in brackets is empty; allowed: m or mm \(a '
                                 r"length\), or no brackets for the file's units$"),
        (['calibrate', SHIPPED], r'--output FILE is required'),
        (['calibrate', SHIPPED, '--output', str(tmp_path)], r'exists and is not a regular file'),
        (['calibrate', SHIPPED, '--plan', '8'], r'give a MEASUREMENTS file to calibrate from, or --plan N for a '
                                                r'measurement plan \(not both\)$'),
        (['calibrate'], r'give a MEASUREMENTS file .* \(neither was given\)$'),
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--free', 'radius'], r"unknown parameter 'radius'; allowed: "
                                                                            r'rod1_x'),
        (['calibrate', write(tmp_path, 'one.csv', '\n'.join([header, rows[0]])), '--output', 'x.yaml'],
         r'one\.csv: 1 row\(s\) give 6 residuals, too few to identify 24 parameters; at least 5 rows'),
        (['calibrate', write(tmp_path, 'mm_declared.csv', '# units: mm rad\n' + header + '\n' + '\n'.join(rows)),
          '--output', 'x.yaml'], r'mm_declared\.csv: the (fit moved the geometry out of its allowed ranges|best fit '
                                 r'leaves residuals [\d.e+]+ times the standard deviations).*lengths in other '
                                 r'units than the file\'s "# units:" line says'),
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--sigma-angle', 'nan'], r'--sigma-angle = nan'),
        (['calibrate', str(tmp_path / 'none.csv'), '--output', 'x.yaml'], r'measurements file .*none\.csv\' not found'),
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--free', 'rod_offsets', 'rod_offsets'],
         r"--free names 'rod_offsets' twice; allowed: each parameter once"),
        # --free repeated adds up (the last one alone was kept): a name in two of them is still given twice
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--free', 'kappa', '--free', 'rod_offsets', 'kappa'],
         r"--free names 'kappa' twice; allowed: each parameter once"),
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--free', 'kappa', '--free', 'kappa1'],
         r'--free names kappa1 twice, on its own and in kappa; allowed: each parameter once'),
        # a key and one of its parameters: accepted, while a name given twice was refused
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--free', 'rod_offsets', 'rod1_offset'],
         r'--free names rod1_offset twice, on its own and in rod_offsets; allowed: each parameter once'),
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--frame', 'tracker', '--base', '1e308', '0', '0', '0', '0',
          '0'], r'--base \[1e\+308, 0.0, 0.0, 0.0, 0.0, 0.0\]: allowed: each value within \+-1e\+06'),
        (['calibrate', '--plan', '0'], r'plan size 0: .*; allowed: at least 5'),
        (['calibrate', '--plan', '500'], r'plan size 500; allowed: an integer from 5 to 222 \('),
        # --base in degrees without --deg: the file was blamed ("another frame"), not the option
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--frame', 'tracker', '--base', '0', '0', '0', '0', '0', '90'],
         r'line \d+: the measured pose is .* rad from the nominal model\'s .*; or --base in other units than m and rad '
         r'\(--mm for millimetres, --deg for degrees\)\?$'),
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--frame', 'tracker', '--base', '0', '0', '0', '0', '0', '90',
          '--mm', '--target', '0', '0', '0'], r'; or --base and --target in other units than m and rad \(--deg for '
                                              r'degrees\)\?$'),
        (['calibrate', '--plan', '8', '--config', ''], r'config'),
        (['calibrate', '--plan', 'many'], r"argument --plan: invalid int value: 'many'"),
        (['calibrate', SHIPPED, '--output', 'x.yaml', '--frame', 'tr\u0430cker'],   # a Cyrillic a passed isalnum
         r"--frame 'tr\u0430cker'; allowed: a frame name of 1 to 64 ASCII letters, digits and _"),
        (['calibrate', '--plan', '8', '--tolerances', SHIPPED], r'not valid YAML|expected a mapping'),
        (['calibrate', '--plan', '8', '--sigma-position', '1e300'],
         r'--sigma-position = 1e\+300 m; allowed: a standard deviation from 1e-09 to 0\.1 m\n$'),
        # as typed, the bounds in both units: it said '--sigma-angle = 0.3490658503988659 (SI); ... (m, rad)'
        (['calibrate', '--plan', '8', '--sigma-angle', '20', '--deg'], r'--sigma-angle = 20 deg \(0\.349066 rad\); '
         r'allowed: a standard deviation from 1e-09 to 0\.1 rad \(5\.73e-08 to 5\.729 deg\)\n$'),
        (['calibrate', '--plan', '8', '--sigma-position', '300', '--mm'], r'--sigma-position = 300 mm \(0\.3 m\); '
         r'allowed: a standard deviation from 1e-09 to 0\.1 m \(1e-06 to 100 mm\)\n$'),
    ]


def test_bad_input_exits_2_with_one_line(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # the one line is the error's: a fit refused after 2 s on a loaded machine wrote progress lines before it
    monkeypatch.setattr('gpr_kinematics.cli.progress.AFTER', float('inf'))
    for argv, pattern in bad_inputs(tmp_path):
        status, out, err = run(capsys, *argv)
        assert status == 2, (argv, out, err)
        assert err.count('\n') == 1 and 'Traceback' not in err, (argv, err)
        assert re.search(pattern, err), (argv, err)
    assert not (tmp_path / 'x.yaml').exists()


def test_an_output_named_unlike_what_is_written_is_refused_before_the_fit(capsys, tmp_path, monkeypatch):
    """``--output x.csv`` wrote the calibrated geometry's YAML under a CSV's name (after a fit of 40 rows); --plan's
    CSV went under any name too. The suffix, and a folder as the output, are refused before any fit: identify is
    never called."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr('gpr_kinematics.cli.progress.AFTER', float('inf'))

    def no_fit(*args, **kwargs):
        raise AssertionError('a fit ran before the output was checked')

    monkeypatch.setattr('gpr_kinematics.calibration.identification.identify', no_fit)
    arm = write(tmp_path, 'arm.csv', 'arm,x,y,z\n')
    for argv, line in [
            (['calibrate', SHIPPED, '--output', 'x.csv'],
             "--output 'x.csv' has another suffix; "
             "allowed: a .yaml or .yml file (the calibrated geometry is written as YAML)"),
            (['calibrate', SHIPPED, '--output', 'x.YAML.txt'],
             "--output 'x.YAML.txt' has another suffix; "
             "allowed: a .yaml or .yml file (the calibrated geometry is written as YAML)"),
            (['calibrate', '--robot', 'example_robot.yaml', arm, '--output', 'r.csv'],
             "--output 'r.csv' has another suffix; "
             "allowed: a .yaml or .yml file (the calibrated robot is written as YAML)"),
            (['calibrate', '--plan', '8', '--output', 'plan.yaml'],
             "--output 'plan.yaml' has another suffix; allowed: a .csv file (the plan is written as CSV)"),
            (['calibrate', SHIPPED, '--output', str(tmp_path)],
             f'calibrated geometry output {tmp_path} exists and is not a regular file (it is a directory); allowed: '
             'a new file or a regular file to replace, in an existing, writable folder')]:
        status, out, err = run(capsys, *argv)
        assert (status, out, err) == (2, '', f'gpr calibrate: error: {line}\n'), argv
    assert sorted(p.name for p in tmp_path.iterdir()) == ['arm.csv']
    status, out, err = run(capsys, 'calibrate', '--plan', '8', '--output', 'plan.CSV')   # any case
    assert status == 0 and (tmp_path / 'plan.CSV').read_text().splitlines()[3] == 'q1,q2,q3', err


def test_a_frame_of_the_machine_is_refused_as_the_measurements_frame_unless_its_pose_is_known(capsys, tmp_path,
                                                                                              monkeypatch):
    """``--frame gpr_platform`` passed as a tracker's name (its pose in gpr_base identified as if fixed). The frames
    that move are the URDF's below a joint that is not fixed: the rods' tops and both platforms of the GPR, with
    --robot also the arms' links, blades and wafers. Of the fixed ones the root and gpr_base have known poses and
    stay allowed, as any name not of the machine (the tracker's); a rod guide, placed by the geometry, is refused
    (its pose was fitted as a tracker's before)."""
    from gpr_kinematics.core.config import GprConfig
    from gpr_kinematics.robot import load_robot
    from gpr_kinematics.robot.urdf import gpr_urdf, robot_urdf
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr('gpr_kinematics.cli.progress.AFTER', float('inf'))
    gpr, robot = gpr_urdf(GprConfig()), robot_urdf(load_robot())
    guides = ('gpr_rod_guide_1', 'gpr_rod_guide_2', 'gpr_rod_guide_3')
    assert gpr.fixed_frames() == ('gpr_base', *guides)
    assert robot.fixed_frames() == ('world', 'gpr_base', *guides)
    moving = {j.child for j in robot.joints if j.kind != 'fixed'}   # and what hangs below them
    while True:
        more = moving | {j.child for j in robot.joints if j.parent in moving}
        if more == moving:
            break
        moving = more
    assert len(moving) == 16 and moving == {link.name for link in robot.links} - set(robot.fixed_frames())
    arm = write(tmp_path, 'arm.csv', 'arm,x,y,z\n')
    allowed = ("allowed: the frame the measurements are in: one whose pose is known ({}) or one of the tracker's own "
               'name')
    gpr_allowed, robot_allowed = allowed.format('gpr_base'), allowed.format('world, gpr_base')
    guide = ("--frame gpr_rod_guide_1 is a frame of {} placed by its geometry (a rod's guide, at the rod's foot and "
             "direction), not a known pose: it would be fitted as a tracker's, apart from that geometry; {}")
    for argv, line in [
            (['calibrate', SHIPPED, '--output', 'x.yaml', '--frame', 'gpr_platform'],
             f'--frame gpr_platform moves with the machine; {gpr_allowed} (not one of the 5 frames of gpr that move)'),
            (['calibrate', '--plan', '8', '--frame', 'gpr_rod_2'],
             f'--frame gpr_rod_2 moves with the machine; {gpr_allowed} (not one of the 5 frames of gpr that move)'),
            (['calibrate', '--robot', 'example_robot.yaml', arm, '--output', 'r.yaml', '--frame', 'arm1_wafer'],
             f'--frame arm1_wafer moves with the machine; {robot_allowed} (not one of the 16 frames of '
             'example_dual_arm that move)'),
            (['calibrate', '--plan', '8', '--frame', 'gpr_rod_guide_1'], guide.format('gpr', gpr_allowed)),
            (['calibrate', '--robot', 'example_robot.yaml', arm, '--output', 'r.yaml', '--frame', 'gpr_rod_guide_1'],
             guide.format('example_dual_arm', robot_allowed))]:
        status, out, err = run(capsys, *argv)
        assert (status, out, err) == (2, '', f'gpr calibrate: error: {line}\n'), argv
    for frame in ('gpr_base', 'tracker'):
        status, out, err = run(capsys, 'calibrate', '--plan', '8', '--frame', frame, '--json')
        assert status == 0 and len(json.loads(out)['configurations']) == 8, err
    # the docs' "world" for a robot whose world frame has another name: it was fitted as a tracker's frame without a
    # word (28 um RMS off in the world, its registration not written)
    text = config_path('robots/example_robot.yaml').read_text(encoding='utf-8')
    fab = write(tmp_path, 'fab.yaml', text.replace('  frame: world\n', '  frame: fab\n', 1))
    status, out, err = run(capsys, 'calibrate', '--robot', fab, arm, '--output', 'r.yaml', '--frame', 'world')
    assert (status, out) == (2, '') and err == (
        'gpr calibrate: error: --frame world: the world frame of robot example_dual_arm is fab (its description\'s '
        'base frame); allowed: --frame fab for measurements in it, gpr_base, or a tracker\'s frame under a name of '
        'its own (it would be fitted: world would read as a tracker here)\n')


def test_one_row_is_enough_for_three_offsets(capsys, tmp_path):
    """6 residuals for 3 parameters: allowed (too few rows for all 24: the refusals above); whether the row determines
    them is the identifiability report's to say, whether the three explain it the gate's: here they do not (the
    rods' places and tilts of the machine are off), status 1 and no file."""
    rows = [ln for ln in Path(SHIPPED).read_text(encoding='utf-8').splitlines() if not ln.startswith('#')]
    status, out, err = run(capsys, 'calibrate', write(tmp_path, 'one.csv', '\n'.join(rows[:2])), '--output',
                           str(tmp_path / 'one.yaml'), '--free', 'rod_offsets', '--json')
    assert status == 1 and 'reduced chi-square' in err and err.count('\n') == 1
    d = json.loads(out)
    assert d['rows'] == 1 and d['identifiability']['parameters'] == ['rod1_offset', 'rod2_offset', 'rod3_offset']
    assert d['output'] is None and not (tmp_path / 'one.yaml').exists()
    assert d['residuals']['cross_validated']['alone'] == [d['residuals']['after']['worst_position_line']]


def test_demo_prints_before_and_after():
    res = subprocess.run([sys.executable, '-m', 'gpr_kinematics.calibration.demo'], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr
    assert re.search(r'^  before +\d+\.\d+ um', res.stdout, re.M) and re.search(r'^  after +\d+\.\d+ um', res.stdout,
                                                                                re.M)
    # The zero offsets within a fraction of a micrometre, kappa 3 found from the file's 1000, the joints' radial places
    # held (and said so), and the calibrated model predicting the true machine far better than the nominal one.
    m = re.search(r'^  rod1_offset +true +\+40\.000 um +identified +\+(\d+\.\d+) \+- (\d\.\d+) um +\(([-+]\d\.\d+) '
                  r'standard errors\)$', res.stdout, re.M)
    assert m and abs(float(m.group(1)) - 40.0) < 3 * float(m.group(2)) and float(m.group(2)) < 1.0
    assert re.search(r'^  kappa2 +true +\+3\.000 +identified +\+[23]\.\d+ ', res.stdout, re.M)
    assert res.stdout.count('held at nominal (these poses cannot tell it from the other parameters)') == 3
    m = re.search(r'nominal model (\d+\.\d+) um RMS, .*; calibrated model (\d+\.\d+) um RMS', res.stdout)
    assert float(m.group(1)) > 20 * float(m.group(2))
    assert res.stdout.count('accuracy budget: 2 station(s)') == 2
    # the file it writes is a temporary one (it said "here calibrated.yaml", which a reader looked for)
    assert re.search(r'^calibrated geometry: written to a temporary calibrated\.yaml and read back \(model compliant, '
                     r'kappa 3\.009, 3\.189, 3\.161\), not kept: gpr calibrate MEASUREMENTS --output FILE writes one '
                     r'for --config$', res.stdout, re.M)
    # docs/calibration.md's excerpt of this output (its "Demonstration") is the output (it had kappa1 3.009280599
    # and a Gauss-Newton step of 1.9e-05 standard errors left where the demo prints 3.00928847858 and 1.5e-05). The
    # fit stops within SE_TOLERANCE (1e-4) of a standard error, where the machine's kernels decide: kappa1's 0.223
    # of 3.009 makes 7.4e-6 of its value (an AVX2 EPYC and the machine that wrote 3.009280599 differ by 2.6e-6)
    doc = (Path(__file__).resolve().parents[1] / 'docs' / 'calibration.md').read_text(encoding='utf-8')
    section = doc[doc.index('## Demonstration'):doc.index('## A worked calibration of a cell')]
    # and the step left is below that tolerance, its digits the kernels' too
    excerpt = section[section.index('```text\n') + 8:]
    left = re.compile(r'step left (\S+) standard errors')
    assert all(float(v) < 1e-4 for v in left.findall(res.stdout) + left.findall(excerpt))
    _assert_quoted_output(left.sub('step left - standard errors', excerpt[:excerpt.index('```')]).splitlines(),
                          left.sub('step left - standard errors', res.stdout), rel=1e-5)


def test_corrupted_measurement_files_never_crash(capsys, tmp_path):
    """Seeded corruptions of the shipped file (a changed character, a cut, a huge or odd value): every run ends
    with status 0 or 2 and, for 2, one line without a traceback."""
    text = Path(SHIPPED).read_text(encoding='utf-8')
    rng = np.random.default_rng(0)
    odd = ['nan', '-inf', '1e308', '1e-320', '', '"', ',', '\x00', 'é', '0x1p3', '--1', '1e6', '-0']
    statuses = set()
    for k in range(60):
        i = int(rng.integers(len(text)))
        kind = k % 3
        if kind == 0:
            bad = text[:i] + str(rng.choice(odd)) + text[i + 1:]
        elif kind == 1:
            bad = text[:i]
        else:
            j = text.find(',', i)
            bad = text if j < 0 else text[:j + 1] + str(rng.choice(odd)) + text[text.find(',', j + 1):]
        path = tmp_path / f'c{k}.csv'
        path.write_text(bad, encoding='utf-8')
        status, out, err = run(capsys, 'calibrate', str(path), '--output', str(tmp_path / f'c{k}.yaml'))
        assert status in (0, 1, 2), (k, err)
        assert 'Traceback' not in err and (status == 0 or err.count('\n') == 1), (k, err)
        assert (status == 0) == (tmp_path / f'c{k}.yaml').exists(), (k, err)   # a failed gate writes nothing
        statuses.add(status)
    assert {0, 2} <= statuses


def test_every_command_takes_the_calibrated_file(capsys, tmp_path):
    """The calibrated geometry file (model compliant, its kappa, the imperfect geometry) as --config of the core's
    commands, the robot's, the accuracy budget and calibrate itself: each answers with the calibrated machine."""
    cal = tmp_path / 'cal.yaml'
    status, _, err = run(capsys, 'calibrate', SHIPPED, '--output', str(cal))
    assert status == 0, err
    cfg = load_config(cal)
    for argv in (['ik', '--height', '0.3', '--tilt', '0.02', '--azimuth', '1.0'],
                 ['compensate', '--height', '0.3', '--tilt', '0.02', '--azimuth', '1.0', '--tool', '0.3', '0', '0.1'],
                 ['mobility', '0.3', '0.301', '0.299'],
                 ['sweep', '--azimuth-step', '90', '--deg'],
                 ['robot', 'ik', '--position', '1.3', '0.6', '0.45', '--heading', '0.3'],
                 ['accuracy', 'gpr.yaml', '--pose', '0', '0', '0.3', '0.02', '0', '0', '--tolerances',
                  str(config_path('calibration/tolerances_example.yaml')), '--samples', '0'],
                 ['calibrate', '--plan', '8']):
        status, out, err = run(capsys, *argv, '--config', str(cal), '--json')
        assert status == 0, (argv, err)
        d = json.loads(out)
        if argv[0] == 'ik':
            np.testing.assert_allclose(forward(d['q'], cfg).tilt, 0.02, rtol=0, atol=1e-12)
            assert d['achieved']['model'] == 'compliant'
        if argv[0] == 'robot':
            np.testing.assert_allclose(d['wafer']['position'], [1.3, 0.6, 0.45], rtol=0, atol=1e-12)



def test_the_readmes_python_example_runs_as_written(capsys, tmp_path, monkeypatch):
    """README.md's "From Python" block, run as written in a folder holding the calibrated.yaml it loads (`gpr
    calibrate`'s output): it named an array ``Q`` it never made (NameError). Its last forward kinematics is the
    calibrated machine's, as `gpr fk --config` gives it."""
    readme = (Path(__file__).resolve().parents[1] / 'README.md').read_text(encoding='utf-8')
    block = readme[readme.index('```python\n', readme.index('## From Python')) + 10:]
    block = block[:block.index('```')]
    monkeypatch.chdir(tmp_path)
    status, _, err = run(capsys, 'calibrate', SHIPPED, '--output', 'calibrated.yaml')
    assert status == 0, err
    names: dict[str, object] = {}
    exec(compile(block, 'README.md', 'exec'), names)
    capsys.readouterr()
    assert names['batch'].position.shape == (2, 3)
    np.testing.assert_array_equal(names['fk'].position, forward([0.5, 0.503, 0.498], load_config('calibrated.yaml'))
                                  .position)
    assert names['fk'].model == 'compliant' and names['real'].model == 'compliant'


#: A number as the calibration's text prints it (not a digit inside a name such as rod1_y).
_NUMBER = r'[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?'


def _literal(text: str) -> str:
    """``text`` as a regular expression, a run of spaces any run (a column's padding follows its numbers' widths)."""
    return ' +'.join(re.escape(chunk) for chunk in re.split(' +', text))


def _pattern(quoted: str) -> tuple[re.Pattern[str], list[str]]:
    """A quoted output line as a regular expression for a whole output line: ``...`` leaves out any text, runs of
    spaces are any run, every number is captured; and the quoted numbers."""
    parts, numbers = [], []
    for k, piece in enumerate(quoted.split('...')):
        if k:
            parts.append('.*?')
        at = 0
        for m in re.finditer(rf'(?<![\w.]){_NUMBER}(?![\w])', piece):
            parts.append(_literal(piece[at:m.start()]))
            parts.append(f'({_NUMBER})')
            numbers.append(m.group())
            at = m.end()
        parts.append(_literal(piece[at:]))
    return re.compile(''.join(parts)), numbers


def _same_number(quoted: str, printed: str, rel: float = 1e-7) -> bool:
    """Integers exactly; decimals to one unit of their last printed digit (a value on a rounding boundary may print
    either way), and the 12-digit estimates to ``rel`` of their value: their last digits vary with the floating-point
    kernels of the machine (docs/calibration.md)."""
    if re.fullmatch(r'[-+]?\d+', quoted):
        return quoted == printed
    mantissa, _, exponent = quoted.lower().partition('e')
    decimals = len(mantissa.partition('.')[2])
    unit = 10.0 ** (int(exponent or 0) - decimals)
    return abs(float(quoted) - float(printed)) <= max(1.001 * unit, rel * abs(float(printed)))


def _assert_quoted_output(block: list[str], output: str, rel: float = 1e-7) -> None:
    """Every line the doc quotes is an output line (in order; a line ``...`` leaves out any lines), every number in
    it the printed one (:func:`_same_number` to ``rel``)."""
    lines = output.splitlines()
    at = 0
    for quoted in block:
        if quoted.strip() == '...':
            continue
        pattern, numbers = _pattern(quoted)
        for k in range(at, len(lines)):
            m = pattern.fullmatch(lines[k])
            if m and all(_same_number(q, v, rel) for q, v in zip(numbers, m.groups(), strict=True)):
                at = k + 1
                break
        else:
            close = [ln for ln in lines if ln.split()[:1] == quoted.split()[:1]]
            raise AssertionError(f'docs/calibration.md quotes\n{quoted}\nthe output has\n' + '\n'.join(close))


def _console_blocks(section: str) -> list[list[str]]:
    """The output lines quoted under each ``$ gpr`` command of the section."""
    blocks: list[list[str]] = []
    inside = False
    for ln in section.splitlines():
        if ln.startswith('$ gpr '):
            blocks.append([])
            inside = True
        elif ln.startswith('```') or ln.startswith('$ '):
            inside = False
        elif inside:
            blocks[-1].append(ln)
    return blocks


def test_the_worked_calibration_of_a_cell(capsys, tmp_path, monkeypatch):
    """The commands of docs/calibration.md's worked example, as written there (run in a temporary folder with the
    package's files), and what the text says of their outcome: the plan is the tracker file's configurations, the
    registration within its standard errors of the tracker's and the probe's poses, the arm's gate passed and the
    calibrated robot usable with --robot."""
    from gpr_kinematics.calibration import cell
    doc = (Path(__file__).resolve().parents[1] / 'docs' / 'calibration.md').read_text(encoding='utf-8')
    section = doc[doc.index('## A worked calibration of a cell'):doc.index('## References')]
    commands = [ln[2:].split() for ln in section.splitlines() if ln.startswith('$ gpr ')]
    assert len(commands) == 3 and 'python -m gpr_kinematics.calibration.cell cell' in section
    monkeypatch.chdir(tmp_path)
    assert cell.main(['cell']) == 0
    config = str(config_path('.'))
    outs = []
    for argv in commands:
        argv = [a.replace('gpr_kinematics/config', config) for a in argv[1:]]
        status, out, err = run(capsys, *argv)
        assert status == 0, (argv, err)
        outs.append(out)
    plan = [ln for ln in Path('plan.csv').read_text().splitlines() if ln and not ln.startswith('#')][1:]
    np.testing.assert_array_equal(read_measurements('cell/tracker.csv').q, [[float(v) for v in ln.split(',')]
                                                                            for ln in plan])
    m = re.search(r'registration: gpr_base in tracker: position \(([-\d., ]+)\) m \+- \(([\d., ]+)\) um, rpy '
                  r'\(([-\d., ]+)\) rad \+- \(([\d., ]+)\) urad', outs[1])
    values = [np.array([float(v) for v in m.group(k).split(',')]) for k in (1, 2, 3, 4)]
    assert np.all(np.abs(values[0] - cell.TRACKER[:3]) < 3.5 * values[1] * 1e-6)
    assert np.all(np.abs(values[2] - cell.TRACKER[3:]) < 3.5 * values[3] * 1e-6 + 1e-9)
    assert 'gate: passed' in outs[1] and 'gate: passed' in outs[2] and Path('cell/robot.yaml').exists()
    # what the section quotes of the output is the output (the estimates to their machine-dependent last digits: the
    # fit stops within SE_TOLERANCE, 1e-4 of a standard error, as the demonstration's test says; a loaded CI run of
    # 2026-12-04 printed rod1_offset 1.4e-7 of its value (5e-6 of its standard error) from the doc's)
    blocks = _console_blocks(section)
    assert len(blocks) == 3 and all(len(b) >= 5 for b in blocks)
    for block, out in zip(blocks, outs, strict=True):
        _assert_quoted_output([ln.replace('gpr_kinematics/config', config) for ln in block], out, rel=1e-5)
    status, out, err = run(capsys, 'robot', 'ik', '--position', '1300', '600', '450', '--tilt', '1.2', '--azimuth',
                           '30', '--heading', '20', '--mm', '--deg', '--robot', 'cell/robot.yaml', '--json')
    assert status == 0, err
    np.testing.assert_allclose(json.loads(out)['wafer']['position'], [1.3, 0.6, 0.45], rtol=0, atol=1e-12)


def test_sigmas_given_on_the_command_line_are_the_noise_and_gate_an_outlier(capsys, tmp_path):
    """Rows without sigma columns and --sigma-position/--sigma-angle given: the options are the measurement noise,
    so the chi-square gate applies (one row 500 um off passed the gate as weights only and wrote a file 15 um off
    the machine); without them the gate judges the residuals against the assumed tracker noise and finds the row
    by the residuals' robust scale; a clean file passes either way."""
    import dataclasses

    from gpr_kinematics.calibration.measurements import write_measurements

    m = read_measurements(SHIPPED)
    sp, sa = float(m.sigma_position[0]), float(m.sigma_angle[0])
    bare = dataclasses.replace(m, sigma_position=None, sigma_angle=None)
    write_measurements(tmp_path / 'clean.csv', bare)
    position = bare.position.copy()
    position[5] += np.array([5e-4, -5e-4, 5e-4]) / np.sqrt(3)
    write_measurements(tmp_path / 'outlier.csv', dataclasses.replace(bare, position=position))
    noise = ('--sigma-position', repr(sp), '--sigma-angle', repr(sa), '--json', '--no-progress')
    status, out, err = run(capsys, 'calibrate', str(tmp_path / 'clean.csv'), '--output', str(tmp_path / 'c.yaml'),
                           *noise)
    assert status == 0 and json.loads(out)['absolute_sigma'], err
    status, out, err = run(capsys, 'calibrate', str(tmp_path / 'outlier.csv'), '--output', str(tmp_path / 'o.yaml'),
                           *noise)
    assert status == 1 and not (tmp_path / 'o.yaml').exists()
    assert 'reduced chi-square' in err and err.count('\n') == 1, err
    status, out, err = run(capsys, 'calibrate', str(tmp_path / 'outlier.csv'), '--output', str(tmp_path / 'w.yaml'),
                           '--json')
    d = json.loads(out)
    assert status == 1 and not d['absolute_sigma'] and not (tmp_path / 'w.yaml').exists()
    # the check's own words, also in stderr's line (912 characters with the chi-square's: whole)
    assert 'Line 8 is an outlier: its z residual is 21.2 robust standard deviations of its kind' in err, err
    outliers = {g['name']: g for g in d['gate']['checks']}['outliers']
    assert outliers['detail'].startswith('Line 8 is an outlier: its z residual is 21.2 robust standard deviations of '
                                         'its kind'), outliers
    assert err.startswith('gpr calibrate: the fit failed its gate: ') and err.count('\n') == 1, err
    status, out, err = run(capsys, 'calibrate', str(tmp_path / 'clean.csv'), '--output', str(tmp_path / 'w.yaml'),
                           '--json')
    assert status == 0 and not json.loads(out)['absolute_sigma'], err


def test_a_sigma_option_overstated_is_named_by_the_gate(capsys, tmp_path):
    """``--sigma-position 3 --mm`` for a file without sigma columns whose noise is 3 um: the sigmas check fails and
    names the option (it blamed 'a sigma column in other units than the file's', a column the file does not have)."""
    data = [ln for ln in Path(SHIPPED).read_text(encoding='utf-8').splitlines() if not ln.startswith('#')]
    path = write(tmp_path, 'ns.csv', '\n'.join(','.join(r.split(',')[:10]) for r in data))
    status, _, err = run(capsys, 'calibrate', path, '--output', str(tmp_path / 'x.yaml'), '--sigma-position', '3',
                         '--mm')
    assert status == 1 and ('the fit weights the positions too little: --sigma-position in other units than meant '
                            '(with or without --mm?), or the noise overstated; give the measurement noise.') in err, err
    assert 'sigma column' not in err


def test_sigma_columns_in_other_units_fail_the_gate(capsys, tmp_path):
    """sigma_position 0.003 (3 mm: the um value written in mm) in a file in metres passed the gate with a reduced
    chi-square of 0.44, the positions weighted 1e6 times too little and the zero offsets 14 um off the machine; the
    gate's sigmas check now fails it (the positions' own reduced chi-square 0.0012), and sigma_angle in degrees in
    a file in radians (the angles'); the shipped file passes it."""
    lines = Path(SHIPPED).read_text(encoding='utf-8').splitlines()
    data = [ln for ln in lines if not ln.startswith('#')]
    header = data[0].split(',')
    truth = demo.true_values(CoreModel(load_config()))
    for column, factor, kind in (('sigma_position', 1000.0, 'position'), ('sigma_angle', 180 / np.pi, 'angle')):
        c = header.index(column)
        rows = [r.split(',') for r in data[1:]]
        for r in rows:
            r[c] = repr(float(r[c]) * factor)
        path = write(tmp_path, f'{column}.csv', '\n'.join([data[0]] + [','.join(r) for r in rows]))
        status, out, err = run(capsys, 'calibrate', path, '--output', str(tmp_path / 'x.yaml'), '--json')
        d = json.loads(out)
        checks = {g['name']: g for g in d['gate']['checks']}
        assert status == 1 and d['output'] is None and not (tmp_path / 'x.yaml').exists(), err
        assert checks['chi_square']['passed'] and checks['cross_validation']['passed']   # what passed before
        assert not checks['sigmas']['passed'] and checks['sigmas']['at_least']
        assert checks['sigmas']['value'] < 0.01 < 0.6 < checks['sigmas']['limit'] < 0.7
        assert re.search(rf'The {kind} residuals are far smaller than the standard deviations given: their reduced '
                         r'chi-square [\d.e-]+ is below 0\.6\d+ .*a sigma column in other units', err), err
        if kind == 'position':   # the fit ignored the positions: the zero offsets 14 um off (0.56 um standard errors)
            p = {q['name']: q['estimate'] for q in d['parameters']}
            assert abs(p['rod1_offset'] - truth[2]) > 10e-6
    status, out, err = run(capsys, 'calibrate', SHIPPED, '--output', str(tmp_path / 'ok.yaml'), '--json')
    d = json.loads(out)
    g = {c['name']: c for c in d['gate']['checks']}['sigmas']
    assert status == 0 and g['passed'] and g['value'] == pytest.approx(0.891, abs=5e-4) and g['limit'] < 0.7


@pytest.mark.slow
def test_one_kind_of_sigma_declared_is_checked(capsys, tmp_path):
    """A sigma_position column (0.003: 3 um written in mm, in a file in metres) and no sigma_angle column, or only
    --sigma-position 0.003 given: the gate's sigmas check was skipped (it ran only with both kinds declared), the fit
    passed reporting "no noise declared" and wrote a geometry worse than the nominal one. The declared kind is
    checked now (exit 1, nothing written but with --force), the report names the kind declared and the one
    assumed, and a declared kind's residuals beyond 1e4 in reduced chi-square are refused (exit 2) as with both;
    the declared kind at its true 3 um passes."""
    lines = Path(SHIPPED).read_text(encoding='utf-8').splitlines()
    data = [ln for ln in lines if not ln.startswith('#')]
    header = data[0].split(',')
    jp, ja = header.index('sigma_position'), header.index('sigma_angle')

    def rows(value: str | None, keep_position: bool = True) -> str:
        out = []
        for i, ln in enumerate(data):
            v = ln.split(',')
            if i and value is not None:
                v[jp] = value
            out.append(','.join(c for j, c in enumerate(v) if j != ja and (keep_position or j != jp)))
        return '# units: m rad\n' + '\n'.join(out) + '\n'

    bare = write(tmp_path, 'bare.csv', rows(None, keep_position=False))
    cases = {'column': (write(tmp_path, 'mm.csv', rows('0.003')),),
             'option': (bare, '--sigma-position', '0.003')}
    for name, argv in cases.items():
        out_yaml = tmp_path / f'{name}.yaml'
        status, out, err = run(capsys, 'calibrate', *argv, '--output', str(out_yaml), '--json')
        d = json.loads(out)
        checks = {g['name']: g for g in d['gate']['checks']}
        assert status == 1 and not out_yaml.exists(), (name, err)
        assert d['noise_declared'] == ['position'] and not d['absolute_sigma']
        assert not checks['sigmas']['passed'] and checks['sigmas']['value'] < 1e-3 < 0.6 < checks['sigmas']['limit']
        assert 'The position residuals are far smaller than the standard deviations given' in err, err
        status, out, err = run(capsys, 'calibrate', *argv, '--output', str(out_yaml))
        assert status == 1 and "reduced chi-square 0.4499 (the positions' sigmas declared" in out, out
        assert "the angles' assumed" in out and 'no noise declared' not in out, out
        status, out, err = run(capsys, 'calibrate', *argv, '--output', str(out_yaml), '--force')
        assert status == 1 and out_yaml.exists() and "written anyway (--force)" in err, err
    status, out, err = run(capsys, 'calibrate', write(tmp_path, 'tiny.csv', rows('1e-8')), '--output',
                           str(tmp_path / 'tiny.yaml'))
    assert status == 2 and 'the best fit leaves position residuals 262 times the standard deviations' in err, err
    status, out, err = run(capsys, 'calibrate', write(tmp_path, 'um.csv', rows('3e-6')), '--output',
                           str(tmp_path / 'um.yaml'), '--json')
    d = json.loads(out)
    assert status == 0 and d['noise_declared'] == ['position'], err
    assert {g['name']: g for g in d['gate']['checks']}['sigmas']['passed']


def test_sigma_angle_declared_alone_is_checked(capsys, tmp_path):
    """--sigma-angle alone, of a file without sigma columns, declares the angles' noise as --sigma-position alone
    declares the positions': 0.002 (100 times the true 20 urad) fails the gate's sigmas check of the angles (exit
    1, nothing written), the report says the angles' sigmas declared and the positions' assumed, the JSON's
    noise_declared ['angle']; the true 2e-5 passes it."""
    lines = [ln for ln in Path(SHIPPED).read_text(encoding='utf-8').splitlines() if not ln.startswith('#')]
    header = lines[0].split(',')
    drop = {header.index('sigma_position'), header.index('sigma_angle')}
    bare = write(tmp_path, 'bare.csv', '# units: m rad\n' + '\n'.join(
        ','.join(c for j, c in enumerate(ln.split(',')) if j not in drop) for ln in lines) + '\n')
    out_yaml = tmp_path / 'angle.yaml'
    status, out, err = run(capsys, 'calibrate', bare, '--sigma-angle', '0.002', '--output', str(out_yaml), '--json')
    d = json.loads(out)
    checks = {g['name']: g for g in d['gate']['checks']}
    assert status == 1 and not out_yaml.exists() and d['noise_declared'] == ['angle'] and not d['absolute_sigma']
    assert not checks['sigmas']['passed'] and checks['sigmas']['value'] < 0.01 < 0.6 < checks['sigmas']['limit']
    assert 'The angle residuals are far smaller than the standard deviations given' in err, err
    status, out, err = run(capsys, 'calibrate', bare, '--sigma-angle', '0.002', '--output', str(out_yaml))
    assert status == 1 and "the angles' sigmas declared" in out and "the positions' assumed" in out, out
    status, out, err = run(capsys, 'calibrate', bare, '--sigma-angle', '2e-5', '--output', str(out_yaml), '--json')
    d = json.loads(out)
    assert status == 0 and d['noise_declared'] == ['angle'], err
    assert {g['name']: g for g in d['gate']['checks']}['sigmas']['passed']


def test_one_outlier_fails_the_gate(capsys, tmp_path):
    """One row's z 20 um off (6.6 standard deviations of 3 um, studentized) among the shipped file's 40 passed the
    gate: reduced chi-square 1.11 below 1.32, cross-validation 1.00, rod1_offset moved by 0.85 standard errors.
    The outliers check fails it, naming the line and the coordinate; the file as shipped passes it (2.89 <= 4.6, the
    point the largest of 240 normal residuals exceeds with probability 1e-3: two-sided 1e-3 / 240 / 2)."""
    lines = Path(SHIPPED).read_text(encoding='utf-8').splitlines()
    at = next(i for i, ln in enumerate(lines) if ln.startswith('q1')) + 8
    v = lines[at].split(',')
    v[5] = repr(float(v[5]) + 20e-6)
    lines[at] = ','.join(v)
    path = write(tmp_path, 'outlier.csv', '\n'.join(lines) + '\n')
    status, out, err = run(capsys, 'calibrate', path, '--output', str(tmp_path / 'x.yaml'), '--json')
    checks = {g['name']: g for g in json.loads(out)['gate']['checks']}
    assert status == 1 and not (tmp_path / 'x.yaml').exists()
    assert checks['chi_square']['passed'] and checks['cross_validation']['passed'] and checks['sigmas']['passed']
    assert not checks['outliers']['passed'] and checks['outliers']['value'] == pytest.approx(6.49, abs=0.01)
    assert checks['outliers']['limit'] == pytest.approx(math.sqrt(2) * erfcinv(1e-3 / 240), rel=1e-9)
    assert re.search(rf'Line {at + 1} is an outlier: its z residual is 6\.49 standard deviations \(studentized\), '
                     r'above 4\.6', err), err
    status, out, err = run(capsys, 'calibrate', SHIPPED, '--output', str(tmp_path / 'ok.yaml'), '--json')
    g = {c['name']: c for c in json.loads(out)['gate']['checks']}['outliers']
    assert status == 0 and g['passed'] and g['value'] == pytest.approx(2.89, abs=0.005)


def test_too_few_rows_beyond_the_fitted_parameters_name_no_outlier(capsys, tmp_path):
    """The worked example's first 5 tracker rows (30 residuals for 16 fitted parameters: mean leverage 0.53), the 5th
    30 um off in z: the gate had named the 2nd an outlier, 'a mismeasured row (remove it)', a row measured right (its
    residual mirrors the 5th's; 3 of the 5 rows moved so were misnamed). Now no row is named and the gate says why; the
    chi-square still fails the fit. With a 6th row (36 residuals) the outliers are judged again, and the row off is
    the one named (as in each of the 21 rows moved so of 6, 7 and 8)."""
    from gpr_kinematics.calibration import cell
    from gpr_kinematics.calibration.measurements import write_measurements

    lines = write_measurements(tmp_path / 'tracker.csv', cell.tracker_measurements()).read_text().splitlines()
    head = next(i for i, ln in enumerate(lines) if ln.startswith('q1')) + 1
    v = lines[head + 4].split(',')
    v[5] = repr(float(v[5]) + 30e-6)
    lines[head + 4] = ','.join(v)
    options = ('--frame', 'tracker', '--target', '0', '0', '0', '0.3', '0.1', '-1', '--fit-target', 'position',
               '--tolerances', str(config_path('calibration/tolerances_example.yaml')), '--output',
               str(tmp_path / 'x.yaml'), '--no-progress')
    bad = head + 4 + 1   # the file's line of the row moved
    five = write(tmp_path, 'five.csv', '\n'.join(lines[:head + 5]) + '\n')
    status, out, err = run(capsys, 'calibrate', five, *options, '--json')
    checks = {g['name']: g for g in json.loads(out)['gate']['checks']}
    assert status == 1 and not checks['chi_square']['passed'] and 'is an outlier' not in err, err
    assert checks['outliers'] == {
        'name': 'outliers', 'passed': True, 'value': None, 'limit': None, 'at_least': False, 'judged': False,
        'detail': 'Too few rows beyond the fitted parameters to judge outliers: 5 rows, 16 fitted parameters; at '
                  'least 6 rows needed (more residuals than twice the fitted parameters: with fewer a row\'s residual '
                  'shows the other rows\' errors more than its own), so no row is named an outlier.'}
    assert checks['outliers']['detail'] in err and err.count('\n') == 1
    status, out, err = run(capsys, 'calibrate', five, *options)
    assert status == 1 and 'gate: FAILED: ' in out and checks['outliers']['detail'] in out
    six = write(tmp_path, 'six.csv', '\n'.join(lines[:head + 6]) + '\n')
    status, out, err = run(capsys, 'calibrate', six, *options)
    assert status == 1 and f'Line {bad} is an outlier: its z residual is 8.69 standard deviations' in err, err
    clean = write(tmp_path, 'clean.csv', '\n'.join(lines[:head + 4] + lines[head + 5:head + 6]) + '\n')
    status, out, err = run(capsys, 'calibrate', clean, *options)
    assert status == 0, err
    assert ', outliers not judged, cross validation ' in out
    assert '\n  Too few rows beyond the fitted parameters to judge outliers: 5 rows, ' in out
    from gpr_kinematics.calibration.quality import outlier_rows
    assert (outlier_rows(16, 6), outlier_rows(17, 6), outlier_rows(18, 6), outlier_rows(11, 3)) == (6, 6, 7, 8)


@pytest.mark.slow
def test_a_column_unit_or_two_columns_swapped_are_hinted_in_the_refusal(capsys, tmp_path):
    """Positions in metres under ``x [mm]`` headers, or two of x, y, z swapped in the worked example's tracker file,
    were refused as 'not a measurement of this machine' with no word of the header. The refusal stays (exit 2, one
    line), and where the positions read another way fit the nominal model far better (10 times in RMS, every row
    within the plausible 10 mm) it says which, with both RMS errors; where none does (measurements in the tracker's
    frame given as gpr_base's) it says what it said."""
    from gpr_kinematics.calibration import cell
    from gpr_kinematics.calibration.measurements import write_measurements

    def header(text, columns):
        return re.sub(r'^q1,q2,q3,x,y,z,', f'q1,q2,q3,{columns},', text, flags=re.M)

    shipped = Path(SHIPPED).read_text(encoding='utf-8')
    status, out, err = run(capsys, 'calibrate', write(tmp_path, 'mm.csv', header(shipped, 'x [mm],y [mm],z [mm]')),
                           '--output', str(tmp_path / 'x.yaml'))
    assert status == 2 and err.count('\n') == 1 and 'not a measurement of this machine in gpr_base' in err
    assert err.endswith('correct the nominal model first; the positions fit this machine if their values were in '
                        'metres (x, y, z 1000 times what was read): RMS 35.5 um from the nominal model\'s against '
                        '333 mm as read; check their columns\' unit (the header\'s, or the "# units:" line))\n'), err
    tracker = write_measurements(tmp_path / 'tracker.csv', cell.tracker_measurements()).read_text()
    options = ('--frame', 'tracker', '--target', '0', '0', '0', '0.3', '0.1', '-1', '--fit-target', 'position',
               '--output', str(tmp_path / 'x.yaml'), '--no-progress')
    status, out, err = run(capsys, 'calibrate', write(tmp_path, 'xy.csv', header(tracker, 'y,x,z')), *options)
    assert status == 2 and err.count('\n') == 1 and 'the best fit leaves residuals 373 times' in err
    assert err.endswith('or sigma columns far too small; the positions fit this machine with columns x and y swapped: '
                        'RMS 75.6 um from the nominal model\'s against 3.19 mm as read; check the header\'s column '
                        'names\n'), err
    status, out, err = run(capsys, 'calibrate', write(tmp_path, 'yz.csv', header(tracker, 'x,z,y')), *options)
    assert status == 2 and err.count('\n') == 1 and 'not a measurement of this machine in tracker' in err
    assert '; the positions fit this machine with columns y and z swapped: RMS 75.6 um from the nominal model\'s ' \
        'against 302 mm as read; check the header\'s column names)' in err, err
    status, out, err = run(capsys, 'calibrate', str(tmp_path / 'tracker.csv'), '--output', str(tmp_path / 'x.yaml'))
    assert status == 2 and 'not a measurement of this machine in gpr_base' in err and 'positions fit' not in err


def test_without_declared_noise_the_gate_judges_against_a_trackers(capsys, tmp_path):
    """The shipped file without its sigma columns and without --sigma-*: its x and y columns swapped (residuals 7.6 um
    per coordinate against 3 um of noise) passed the gate with a reduced chi-square of 1.82 and so did a row 200 um
    off in z (7.41), since the default sigmas only weighted. Now the residuals are judged against the assumed noise
    (5 um, 20 urad: a laser tracker's, or a tolerance table's measurement_noise) and the outliers by the residuals'
    own robust scale; the clean file passes; a table's noise of 1 um is the one judged against."""
    lines = [ln.split(',')[:10] for ln in Path(SHIPPED).read_text(encoding='utf-8').splitlines()]
    at = next(i for i, v in enumerate(lines) if v[0] == 'q1')

    def variant(name, change):
        rows = [','.join(v) if v[0].startswith('#') or i == at else ','.join(change(i - at, v.copy()))
                for i, v in enumerate(lines)]
        return write(tmp_path, name, '\n'.join(rows) + '\n')

    def swap(k, v):
        v[3], v[4] = v[4], v[3]
        return v

    def outlier(k, v):
        v[5] = repr(float(v[5]) + 200e-6) if k == 8 else v[5]
        return v

    clean = variant('clean.csv', lambda k, v: v)
    out = str(tmp_path / 'x.yaml')
    status, text, err = run(capsys, 'calibrate', clean, '--output', out)
    assert status == 0, err
    assert 'gate: passed (chi square 0.629 <= 1.32, outliers 3.45 <= 5.34, cross validation 1.02 <= 2, minimum ' \
           'reached)' in text, text
    assert 'reduced chi-square 0.6291 (no noise declared: the sigmas used are the assumed noise' in text
    Path(out).unlink()
    status, text, err = run(capsys, 'calibrate', variant('swapped.csv', swap), '--output', out)
    assert status == 1 and not Path(out).exists() and err.count('\n') == 1
    assert ('gpr calibrate: the fit failed its gate: The residuals exceed the noise assumed without a declared one '
            "(a laser tracker's: positions 5 um, residuals 7.61 um RMS per coordinate; angles 20 urad, residuals 19.9 "
            'urad RMS per coordinate): reduced chi-square 1.815 above the gate 1.321 (the 99.9 % point for 219 degrees '
            'of freedom); largest residuals line ') in err, err
    assert ('Columns swapped or in other units, another frame, mismeasured rows? Or a noisier instrument: declare its '
            "noise (sigma_position and sigma_angle columns, --sigma-position and --sigma-angle; a table's "
            'measurement_noise is only assumed). no file written') in err, err
    status, text, err = run(capsys, 'calibrate', variant('outlier.csv', outlier), '--output', out, '--json')
    checks = {g['name']: g for g in json.loads(text)['gate']['checks']}
    assert status == 1 and not Path(out).exists() and 'sigmas' not in checks
    assert checks['chi_square']['value'] == pytest.approx(7.405, abs=5e-4) and not checks['chi_square']['passed']
    # Student's t's point for the robust scale's degrees of freedom (0.368 of the positions'), not the normal's 4.6
    assert checks['outliers']['value'] == pytest.approx(54.07, abs=0.005) and 5.2 < checks['outliers']['limit'] < 5.4
    assert (f'Line {at + 9} is an outlier: its z residual is 54.1 robust standard deviations of its kind (1.4826 '
            'times the median studentized residual: no noise declared), above 5.3') in err, err
    table = write(tmp_path, 'noise.yaml', 'measurement_noise: {position: 1.0e-6, angle: 2.0e-5}\n')
    status, text, err = run(capsys, 'calibrate', clean, '--output', out, '--tolerances', table)
    # the table's noise is assumed, not a laser tracker's; giving it again declares nothing (the message said both)
    assert status == 1 and ('exceed the noise assumed without a declared one (positions 1 um (assumed), residuals 2.68 '
                            "um RMS per coordinate; angles 20 urad (a laser tracker's)") in err, err
    assert 'laser tracker assumed' not in err and 'or measurement_noise in --tolerances' not in err, err


def test_a_calibrated_machine_beyond_its_imperfection_budget_is_warned(capsys, tmp_path):
    """A calibrated machine whose joints move farther than its imperfection_budget at the measured poses: its
    recordings then fail gpr verify's state.imperfection_budget, and nothing at calibration time said why. The
    shipped file's machine (0.1 to 0.3 mm) stays within the nominal 0.5 mm; with a budget of 0.05 mm it is warned,
    the largest displacement the calibrated geometry's own forward kinematics gives."""
    import yaml
    from gpr_kinematics.core import forward_batch

    status, out, err = run(capsys, 'calibrate', SHIPPED, '--output', str(tmp_path / 'a.yaml'), '--json')
    assert status == 0 and not [w for w in json.loads(out)['warnings'] if 'imperfection_budget' in w], err
    geometry = tmp_path / 'tight.yaml'
    geometry.write_text(yaml.safe_dump({**load_config().to_dict(), 'imperfection_budget': 5e-5}))
    status, out, err = run(capsys, 'calibrate', SHIPPED, '--config', str(geometry), '--output',
                           str(tmp_path / 'b.yaml'), '--json')
    warned = [w for w in json.loads(out)['warnings'] if 'imperfection_budget' in w]
    worst = np.max(np.abs(forward_batch(read_measurements(SHIPPED).q, load_config(tmp_path / 'b.yaml'),
                                        check_limits=False).joint_displacement))
    assert status == 0 and len(warned) == 1 and warned[0].startswith(
        f'the calibrated machine displaces its joints by up to {1e3 * worst:.4g} mm at the measured poses, beyond its '
        'imperfection_budget of 0.05 mm'), (warned, err)


def test_measured_rows_the_calibrated_machine_refuses_are_warned(capsys, tmp_path):
    """A trial's machine of large zero offsets, measured up to 2 deg of tilt: calibrate took every row (within its 5 %
    margin) and wrote a geometry that tilts 5 of the 40 rows 2.0003-2.0145 deg, beyond its tilt_limit of 2 deg, so
    `gpr fk --config` of the written file refused them. Here the shipped file's rows, which tilt the nominal machine
    0.0331 rad and the calibrated one 0.0327-0.0335 rad, under a tilt_limit of 0.0335 rad: the warning names the 7
    rows the written geometry's forward kinematics refuses, by their lines, how far, and what to do; the written
    tilt_limit is not changed."""
    import yaml
    from gpr_kinematics.core import forward_batch

    status, out, err = run(capsys, 'calibrate', SHIPPED, '--output', str(tmp_path / 'a.yaml'), '--json')
    assert status == 0 and not [w for w in json.loads(out)['warnings'] if 'tilt_limit' in w], err
    geometry = tmp_path / 'steep.yaml'
    geometry.write_text(yaml.safe_dump({**load_config().to_dict(), 'tilt_limit': 0.0335}))
    status, out, err = run(capsys, 'calibrate', SHIPPED, '--config', str(geometry), '--output',
                           str(tmp_path / 'b.yaml'), '--json')
    warned = [w for w in json.loads(out)['warnings'] if 'tilt_limit' in w]
    written = load_config(tmp_path / 'b.yaml')
    meas = read_measurements(SHIPPED)
    tilt = forward_batch(meas.q, written, check_limits=False).tilt
    beyond = np.flatnonzero(tilt > 0.0335)
    lines = ', '.join(f'line {meas.lines[i]}' for i in beyond[:5])    # lines 11, 13, 21, 23, 30
    assert written.tilt_limit == 0.0335 and beyond.size == 7 and 0.03353 < tilt.max() < 0.03354, (beyond, tilt.max())
    assert status == 0 and warned == [
        'the calibrated machine tilts its platform beyond its tilt_limit of 0.0335 rad (1.91941 deg) at 7 of the 40 '
        f'measured rows ({SHIPPED}: {lines} and 2 more; up to 0.0335369113 rad (1.92152 deg)), which calibrate took '
        '(it takes rows up to 5 % beyond the tilt limit of the given geometry): forward kinematics with the written '
        'file (gpr fk --config) refuses them (beyond the tilt limit); raise tilt_limit in the written file to at '
        'least 0.033537 rad if this machine is right and tilts so far, or measure within the limit'], (warned, err)
    status, text, err = run(capsys, 'calibrate', SHIPPED, '--config', str(geometry), '--output',
                            str(tmp_path / 'c.yaml'))
    assert status == 0 and f'warning: {warned[0]}' in text, text


@pytest.mark.parametrize('option', [['--sigma-position', '0.1'], ['--sigma-angle', '0.002']])
def test_a_sigma_option_for_a_file_with_that_column_is_refused(tmp_path, capsys, option):
    """--sigma-position 0.1 with a file of sigma columns exited 0 with the same fit (the column wins per row): the
    option did nothing, and said nothing."""
    from gpr_kinematics.cli.main import main
    from gpr_kinematics.inputs.resources import config_path

    out = tmp_path / 'g.yaml'
    status = main(['calibrate', str(config_path('calibration/synthetic_measurements.csv')), '--output', str(out),
                   '--no-progress', *option])
    err = capsys.readouterr().err
    column = option[0].lstrip('-').replace('-', '_')
    assert status == 2 and not out.exists() and err.count('\n') == 1
    assert f'have their own {column} column, which the fit takes; allowed: {option[0]} for a file without that ' \
        'column' in err, err


def test_measured_rows_without_a_pose_are_named_apart_from_the_tilted_ones(monkeypatch):
    """A review: rows whose closure finds no pose (NaN) were told to raise tilt_limit 'to at least' the limit itself;
    they are named apart, with what helps (checking them), the tilted ones as before."""
    import types

    from gpr_kinematics.calibration import core_model

    meas = read_measurements(SHIPPED)
    tilt = np.full(len(meas), 0.01)
    tilt[[0, 3]], tilt[5] = math.nan, 0.04
    monkeypatch.setattr(core_model, 'forward_batch', lambda *a, **k: types.SimpleNamespace(tilt=tilt))
    tilted, lost = core_model.refused_rows(load_config(), meas)
    assert tilted.startswith('the calibrated machine tilts its platform beyond its tilt_limit of 0.034906585 rad '
                             f'(2 deg) at 1 of the 40 measured rows ({SHIPPED}: line {meas.lines[5]}; up to 0.04 rad')
    assert 'raise tilt_limit in the written file to at least 0.04 rad' in tilted
    assert lost == (f'the calibrated machine has no platform pose at 2 of the 40 measured rows ({SHIPPED}: line '
                    f'{meas.lines[0]}, line {meas.lines[3]}): forward kinematics with the written file (gpr fk '
                    '--config) refuses them; check those rows (their rods) or measure again')

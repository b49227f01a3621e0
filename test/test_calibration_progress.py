"""The progress of the long calibration commands: ``gpr calibrate`` (70,000 rows took 94 s of CPU time with no word
on stderr) and ``gpr accuracy``'s Monte Carlo (5,000,000 poses, about 35 s) report each stage's share done as they go,
through the listener ``progress(stage, share)`` of ``gpr program check`` and its line on stderr
(:mod:`gpr_kinematics.cli.progress`); the results are the ones computed without a listener."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest
from gpr_kinematics.calibration import fitting, monte_carlo
from gpr_kinematics.calibration.budget import accuracy_budget
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.identification import identify
from gpr_kinematics.calibration.measurements import parse_measurements, read_measurements
from gpr_kinematics.calibration.tolerances import load_tolerances
from gpr_kinematics.cli.main import main
from gpr_kinematics.core.config import load_config
from gpr_kinematics.inputs.resources import config_path

SHIPPED = str(config_path('calibration/synthetic_measurements.csv'))
TABLE = str(config_path('calibration/tolerances_example.yaml'))
FIT = re.compile(r'fit from (.+): iteration (\d+), reduced chi-square (\S+)')


def test_identify_reports_every_jacobian_chunk_and_iteration(monkeypatch):
    """The shipped file (40 rows, 24 parameters) with Jacobians of 3 columns per call of the model: every Jacobian
    tells 1/8, 2/8, ... 8/8 of its columns; every start tells its iterations 0 .. n-1 (n its iterations in the
    report) with the reduced chi-square of the point linearised, the best start's last the fit's; the result is
    the one without a listener and without chunks, to the fit's convergence (the model evaluated in batches of other
    sizes rounds differently: 2e-11 m apart, 2e-9 relative, in a loaded run on numpy 1.26)."""
    meas = read_measurements(SHIPPED)
    model = CoreModel(load_config())
    quiet = identify(model, meas)
    monkeypatch.setattr(fitting, 'JACOBIAN_RESIDUALS', 3 * 2 * 40 * 6)   # 3 columns (6 perturbed rows) per call
    heard: list[tuple[str, float]] = []
    res = identify(model, meas, progress=lambda stage, share: heard.append((stage, share)))
    fitted = ~np.isnan(quiet.standard_error)
    assert np.all(np.abs(res.estimate - quiet.estimate)[fitted] <= 1e-4 * quiet.standard_error[fitted])  # SE_TOLERANCE
    np.testing.assert_array_equal(res.estimate[~fitted], quiet.estimate[~fitted])                          # held
    assert res.chi2_reduced == pytest.approx(quiet.chi2_reduced, rel=1e-9)
    assert (res.convergence.status, res.iterations) == (quiet.convergence.status, quiet.iterations)
    stages = list(dict.fromkeys(s for s, _ in heard))       # in the order first heard
    assert stages[0] == 'identifiability' and stages[-2:] == ['standard errors', 'cross-validation']
    shares = {s: [f for t, f in heard if t == s] for s in stages}
    assert shares['identifiability'] == [k / 8 for k in range(1, 9)]            # 24 free columns, 3 a call
    assert shares['standard errors'] == [k / 8 for k in range(1, 9)]            # all 24 parameters
    assert shares['cross-validation'] == [0.0, 1.0]
    fits = [FIT.fullmatch(s) for s in stages[1:-2]]
    assert all(fits)
    fitted = res.fitted.size                                                    # 21: each fit's Jacobian
    calls = math.ceil(fitted / 3)
    for m in fits:
        assert shares[m.group(0)] == [min(3 * k, fitted) / fitted for k in range(1, calls + 1)]
    for outcome in res.convergence.starts:
        told = [int(m.group(2)) for m in fits if m.group(1) == outcome.label]
        assert told == list(range(outcome.iterations)), outcome
    best = [m for m in fits if m.group(1) == res.convergence.starts[0].label][-1]
    assert best.group(3) == f'{res.chi2_reduced:.4g}' == '0.9207'


def test_reading_rows_reports_its_share_every_2000_lines():
    """A file of 4,500 rows (4,502 lines with the header and the final newline) tells 2000/4502, 4000/4502, 1."""
    rows = [f'0.3,0.301,0.299,{i}e-6,-2e-5,0.3' for i in range(4500)]
    heard: list[tuple[str, float]] = []
    meas = parse_measurements('q1,q2,q3,x,y,z\n' + '\n'.join(rows) + '\n', 'f.csv',
                              lambda stage, share: heard.append((stage, share)))
    assert len(meas) == 4500
    assert heard == [('reading rows', 2000 / 4502), ('reading rows', 4000 / 4502), ('reading rows', 1.0)]


def test_the_monte_carlo_reports_its_samples_drawn(monkeypatch):
    """1,000 samples at 2 stations in chunks of 300 poses (150 samples): the shares 150/1000, ..., 1; the budget is
    the one without a listener (to 1e-12 relative: two runs of one budget in one process differed by one unit in the
    last place, 2.2e-19 m, in a CI run of 2026-12-05, by BLAS threads and memory alignment; other draws differ by
    percents)."""
    model = CoreModel(load_config())
    table = load_tolerances(TABLE)
    Q = np.array([[0.3, 0.3, 0.3], [0.2, 0.203, 0.2]])   # within the tilt limit
    monkeypatch.setattr(monte_carlo, 'CHUNK_POSES', 300)   # the draws depend on the chunks
    quiet = accuracy_budget(model, Q, table, samples=1000, seed=3)
    heard: list[tuple[str, float]] = []
    budget = accuracy_budget(model, Q, table, samples=1000, seed=3,
                             progress=lambda stage, share: heard.append((stage, share)))
    assert heard == [('Monte Carlo', min(150 * k, 1000) / 1000) for k in range(1, 8)]
    for name in quiet.mc:
        np.testing.assert_allclose(budget.mc[name], quiet.mc[name], rtol=1e-12, atol=0)


def _run(capsys, *argv):
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


NUMBER = re.compile(r'[+-]?\d+(?:\.(\d+))?(?:e[+-]?\d+)?')


def _same_report(a: str, b: str) -> bool:
    """The same words, and the same numbers to the fit's rounding: two runs of one fit in one process differ in its
    ill-conditioned directions (kappa 1000 to 3 from 40 rows), by BLAS threads and memory alignment, up to 3e-5
    relative in a loaded CI run of 2026-12-04 (``rod2_ux`` 2.10177e-05 and 2.10183e-05 rad, standard error 4.0e-05
    rad). Integers agree exactly; a decimal within 1e-4 relative or one unit of its last printed digit (a value
    within the noise of a rounding boundary prints one unit apart: 148.461 and 148.460 um); the Gauss-Newton step
    left, the fit's convergence at its noise floor (1e-5 standard errors, tens of percent apart), is not compared."""
    words_a, words_b = (re.sub(r'step left \S+', 'step left _', t).split() for t in (a, b))
    if len(words_a) != len(words_b):
        return False
    for x, y in zip(words_a, words_b, strict=True):
        mx, my = NUMBER.fullmatch(x), NUMBER.fullmatch(y)
        if mx is None or my is None or ('.' not in x and 'e' not in x):   # words and integers: equal
            if x != y:
                return False
            continue
        unit = 10.0 ** -len(mx.group(1) or '') if 'e' not in x else 0.0
        if not math.isclose(float(x), float(y), rel_tol=1e-4, abs_tol=1.01 * unit):
            return False
    return True


def test_same_report_tells_the_rounding_from_a_change():
    """The comparison of the test below: rounding passes, a changed word or number fails."""
    assert _same_report('rod2_ux 0 2.10177137397e-05 +21.018 urad', 'rod2_ux 0 2.10183220513e-05 +21.018 urad')
    assert _same_report('bias <= 148.461 um', 'bias <= 148.460 um')
    assert not _same_report('bias <= 0.461 um', 'bias <= 0.459 um')
    assert not _same_report('rod2_ux 0 2.10177e-05', 'rod2_ux 0 2.10477e-05')
    assert not _same_report('fitted [m]', 'held [m]')
    assert not _same_report('a 1', 'a 1 b')
    assert not _same_report('rows 40 iterations 7', 'rows 41 iterations 7')
    assert not _same_report('kappa1 3', 'kappa1 4')
    assert _same_report('converged (Gauss-Newton step left 1.5e-05 standard', 'converged (Gauss-Newton step left '
                        '1.9e-05 standard')


def test_calibrate_and_accuracy_show_the_progress_line_unless_no_progress(capsys, tmp_path, monkeypatch):
    """With the line shown from the start (``AFTER`` 0 s; 2 s by default), into a pipe: ``gpr calibrate`` writes
    each stage and its end on stderr, ``gpr accuracy`` its Monte Carlo; stdout is the same as with
    ``--no-progress`` (to the fit's rounding: :func:`_same_report`), which writes nothing on stderr."""
    monkeypatch.setattr('gpr_kinematics.cli.progress.AFTER', 0.0)
    out_yaml = str(tmp_path / 'cal.yaml')
    status, shown, err = _run(capsys, 'calibrate', SHIPPED, '--output', out_yaml)
    assert status == 0
    lines = err.splitlines()
    assert lines[0].startswith('reading rows: 100.0 % (')
    assert lines[1].startswith('identifiability: 100.0 % (')
    assert FIT.match(lines[2]) and FIT.match(lines[2]).group(1, 2) == ('nominal', '0')
    assert lines[-3].startswith('standard errors: 100.0 %')
    assert lines[-2].startswith('cross-validation:   0.0 %') and lines[-1].startswith('cross-validation: 100.0 %')
    assert all(re.fullmatch(r'.+: +\d+\.\d % \(\d+\.\d s\)', line) for line in lines)
    status, quiet, err = _run(capsys, 'calibrate', SHIPPED, '--output', out_yaml, '--no-progress')
    assert status == 0 and _same_report(quiet, shown) and err == ''
    argv = ('accuracy', str(config_path('mechanisms/gpr.yaml')), '--tolerances', TABLE, '--pose', '0', '0', '0.5',
            '0.0349', '0', '0', '--samples', '1000')
    status, shown, err = _run(capsys, *argv)
    assert status == 0 and err.startswith('Monte Carlo: 100.0 % (') and err.count('\n') == 1
    status, quiet, err = _run(capsys, *argv, '--no-progress')
    assert status == 0 and quiet == shown and err == ''

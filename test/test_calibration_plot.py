"""``gpr calibrate --plot``: the plot's data against independent numbers (the JSON report's residuals, the core's
forward kinematics at the nominal and the calibrated geometry, the parameters' changes and standard errors), the PNG
written without changing the output or the status, and a bad ``--plot`` refused before any fit."""
from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from calibration_support import PNG, normalised, plus_plot, quiet_progress, rounded, run  # noqa: F401 - a fixture
from gpr_kinematics.calibration import demo
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.identification import identify
from gpr_kinematics.calibration.measurements import read_measurements
from gpr_kinematics.calibration.residual_plot import LOG_RATIO, residual_plot
from gpr_kinematics.calibration.synthetic import synthetic_measurements
from gpr_kinematics.core import forward_batch
from gpr_kinematics.core.config import load_config
from gpr_kinematics.inputs.resources import config_path
from scipy.spatial.transform import Rotation

SHIPPED = str(config_path('calibration/synthetic_measurements.csv'))




def _angles(rotation, quaternion_xyzw):
    """The angle [rad] of ``rotation (N, 3, 3)`` against the measured orientations (scipy's, not the package's)."""
    measured = Rotation.from_quat(quaternion_xyzw).as_matrix()
    return Rotation.from_matrix(rotation @ np.swapaxes(measured, 1, 2)).magnitude()


def _csv(path):
    """The shipped file's numeric columns by name (read here, not by the package)."""
    lines = [ln for ln in Path(path).read_text(encoding='utf-8').splitlines() if ln and not ln.startswith('#')]
    header = lines[0].split(',')
    data = np.array([[float(v) for v in ln.split(',')] for ln in lines[1:]])
    return {name: data[:, i] for i, name in enumerate(header)}


def test_plot_data_is_the_reports_residuals_and_the_cores_poses(capsys, tmp_path):
    """The shipped file: every row's residual before is |forward(q, nominal) - measured| and after |forward(q,
    calibrated file) - measured| (the core's forward kinematics, scipy's rotations) to 1e-12; their RMS and worst are
    the JSON report's; the noise line sqrt(3) times the file's sigma columns; the bars the JSON's change over standard
    error of each fitted parameter (a kappa's anisotropy coordinate); the verdict the gate's."""
    cal = tmp_path / 'cal.yaml'
    status, out, err = run(capsys, 'calibrate', SHIPPED, '--output', str(cal), '--json')
    assert status == 0, err
    report = json.loads(out)
    meas = read_measurements(SHIPPED)
    model = CoreModel(load_config())
    res = identify(model, meas)
    data = residual_plot(model, meas, res, 5e-6, 2e-5)
    col = _csv(SHIPPED)
    q = np.column_stack([col['q1'], col['q2'], col['q3']])
    p_meas = np.column_stack([col['x'], col['y'], col['z']])
    quat = np.column_stack([col['qx'], col['qy'], col['qz'], col['qw']])
    for config, pos, ang in ((load_config(overrides={'model': 'compliant'}), data.position.before,
                              data.angle.before),
                             (load_config(cal), data.position.after, data.angle.after)):
        fk = forward_batch(q, config=config, check_limits=False)
        np.testing.assert_allclose(pos, np.linalg.norm(fk.position - p_meas, axis=1), rtol=0, atol=1e-12)
        np.testing.assert_allclose(ang, _angles(fk.rotation, quat), rtol=0, atol=1e-11)
    assert data.rows.tolist() == list(range(1, demo.ROWS + 1))
    for when in ('before', 'after'):
        r = report['residuals'][when]
        pos, ang = getattr(data.position, when), getattr(data.angle, when)
        assert getattr(data.position, f'rms_{when}') == pytest.approx(r['rms_position'], rel=1e-9)
        assert getattr(data.angle, f'rms_{when}') == pytest.approx(r['rms_angle'], rel=1e-9)
        assert pos.max() == pytest.approx(r['max_position'], rel=1e-9)
        assert ang.max() == pytest.approx(r['max_angle'], rel=1e-9)
        assert data.names[int(np.argmax(pos))] == f'line {r["worst_position_line"]}'
        assert data.names[int(np.argmax(ang))] == f'line {r["worst_angle_line"]}'
    assert report['residuals']['before']['rms_position'] * 1e6 == pytest.approx(35.523, abs=5e-4)
    np.testing.assert_allclose(data.position.noise, math.sqrt(3) * col['sigma_position'], rtol=1e-15)
    np.testing.assert_allclose(data.angle.noise, math.sqrt(3) * col['sigma_angle'], rtol=1e-15)
    assert (data.position.origin, data.angle.origin) == ("the file's sigma_position", "the file's sigma_angle")
    # 35.5 um against 4.72 um and 411 urad against 32 urad: less than LOG_RATIO apart, drawn linear
    assert not data.position.log and not data.angle.log
    fitted = [p for p in report['parameters'] if p['status'] == 'fitted']
    assert data.parameters == tuple(p['name'] for p in fitted) and len(fitted) == 21
    z = [(p['coordinate']['estimate'] - p['coordinate']['nominal']) / p['coordinate']['standard_error']
         if 'coordinate' in p else p['change'] / p['standard_error'] for p in fitted]
    np.testing.assert_allclose(data.z, z, rtol=1e-9)
    assert data.passed and data.passed == report['gate']['passed'] and data.failed == ()
    # what docs/calibration.md says of its figure (docs/img/calibration_residuals.png, this calibration)
    assert (round(data.position.before.min() * 1e6, 1), round(data.angle.before.min() * 1e6)) == (12.3, 371)
    assert (round(data.position.noise[0] * 1e6, 2), round(data.angle.noise[0] * 1e6, 1)) == (5.20, 34.6)
    assert (np.sum(data.position.after > data.position.noise), np.sum(data.angle.after > data.angle.noise)) == (13, 13)
    zs = dict(zip(data.parameters, data.z.tolist(), strict=True))
    assert [round(zs[f'rod{k}_offset']) for k in (1, 2, 3)] == [71, -46, 26]
    assert all(-18 <= zs[f'kappa{k}'] <= -17 for k in (1, 2, 3))
    assert max(abs(v) for n, v in zs.items() if not n.endswith('offset') and not n.startswith('kappa')) < 3.1


def test_points_with_declared_noise_are_drawn_on_a_log_scale():
    """Points of the shipped file's machine with 0.1 um of noise declared: the residuals fall from 35 um to about
    0.17 um (sqrt(3) 0.1 um), more than LOG_RATIO apart, so the position panel is logarithmic; there is no
    orientation panel; the figure has the position and the parameter panels."""
    model = CoreModel(load_config())
    q = read_measurements(SHIPPED).q
    meas = synthetic_measurements(model, demo.true_values(model), q, 1e-7, 1e-6, seed=3, with_sigmas=False,
                                  points=True)
    res = identify(model, meas, sigma_position=1e-7, declared=(True, False))
    data = residual_plot(model, meas, res, 1e-7, 2e-5, (True, False))
    truth = forward_batch(q, config=load_config(overrides={'model': 'compliant'}), check_limits=False).position
    np.testing.assert_allclose(data.position.before, np.linalg.norm(truth - meas.position, axis=1), atol=1e-12)
    assert data.angle is None and data.position.origin == 'declared'
    np.testing.assert_allclose(data.position.noise, math.sqrt(3) * 1e-7, rtol=1e-12)
    ratio = data.position.rms_before / data.position.rms_after
    assert ratio > max(100.0, LOG_RATIO) and data.position.log
    assert 0.12e-6 < data.position.rms_after < 0.2e-6
    from gpr_kinematics.calibration.plot import residual_figure
    fig = residual_figure(data)
    try:
        axes = fig.get_axes()
        assert len(axes) == 2 and axes[0].get_yscale() == 'log' and axes[0].get_ylabel() == 'position residual [um]'
        assert [t.get_text() for t in axes[1].get_xticklabels()] == list(data.parameters)
        assert fig._suptitle.get_text().endswith(f'{len(q)} rows, gate passed')
    finally:
        import matplotlib.pyplot as plt
        plt.close(fig)
    # the worst row's label stays within its panel wherever the row is: the last one's ran off the axes' right
    for worst in (0, len(q) - 1):
        after = data.position.after.copy()
        after[worst] = 2.0 * after.max()
        fig = residual_figure(dataclasses.replace(data, position=dataclasses.replace(data.position, after=after)))
        try:
            fig.canvas.draw()
            ax = fig.get_axes()[0]
            label = next(t for t in ax.texts if t.get_text() == data.names[worst])
            box, inside = label.get_window_extent(), ax.get_window_extent()
            assert inside.x0 <= box.x0 and box.x1 <= inside.x1, (worst, box, inside)
        finally:
            plt.close(fig)


@pytest.mark.slow
def test_the_cli_writes_a_png_and_prints_what_it_prints_without(capsys, tmp_path):
    """With --plot the PNG is written (its magic bytes) and stdout and the status are those without it, text and
    JSON, plus the file's name (a line ``plot written to PATH``; the key ``plot_file``); a fit that fails its gate
    (one row 20 um off: the outliers check) still draws it, with and without --force, its title naming the failed
    check."""
    for extra in ([], ['--json']):
        outputs = []
        for plot in (None, tmp_path / 'r.png'):
            (tmp_path / 'cal.yaml').unlink(missing_ok=True)
            argv = ['calibrate', SHIPPED, '--output', str(tmp_path / 'cal.yaml'), *extra]
            outputs.append(run(capsys, *argv, *(['--plot', str(plot)] if plot else [])))
        assert rounded(normalised(outputs[1])) == rounded(plus_plot(outputs[0], tmp_path / 'r.png'))
        assert outputs[0][0] == 0
        assert (tmp_path / 'r.png').read_bytes()[:8] == PNG
        (tmp_path / 'r.png').unlink()
    lines = Path(SHIPPED).read_text(encoding='utf-8').splitlines()
    at = next(i for i, ln in enumerate(lines) if ln.startswith('q1')) + 8
    v = lines[at].split(',')
    v[5] = repr(float(v[5]) + 20e-6)
    lines[at] = ','.join(v)
    bad = tmp_path / 'outlier.csv'
    bad.write_text('\n'.join(lines) + '\n', encoding='utf-8')
    for force in ([], ['--force']):
        png = tmp_path / f'gate{len(force)}.png'
        status, out, err = run(capsys, 'calibrate', str(bad), '--output', str(tmp_path / 'x.yaml'), '--plot',
                               str(png), *force)
        assert status == 1 and err.count('\n') == 1 and 'outlier' in err
        assert png.read_bytes()[:8] == PNG and (tmp_path / 'x.yaml').exists() == bool(force)
    model = CoreModel(load_config())
    meas = read_measurements(str(bad))
    data = residual_plot(model, meas, identify(model, meas), 5e-6, 2e-5)
    assert not data.passed and data.failed == ('outliers',)
    assert data.names[int(np.argmax(data.position.after))] == f'line {at + 1}'


def test_a_bad_plot_is_refused_before_any_fit(capsys, tmp_path, monkeypatch):
    """A --plot not named .png (also with --robot), a folder, with --plan, or without matplotlib: exit 2 with one
    line, no fit run (identify replaced by a failure), nothing written."""
    monkeypatch.chdir(tmp_path)

    def no_fit(*args, **kwargs):
        raise AssertionError('a fit ran before --plot was checked')

    monkeypatch.setattr('gpr_kinematics.calibration.identification.identify', no_fit)
    arm = tmp_path / 'arm.csv'
    arm.write_text('arm,x,y,z\n', encoding='utf-8')
    (tmp_path / 'folder.png').mkdir()
    base = ['calibrate', SHIPPED, '--output', 'x.yaml']
    for argv, line in [
            ([*base, '--plot', 'r.pdf'], "--plot 'r.pdf' has another suffix; allowed: a .png file"),
            ([*base, '--plot', 'r.PNG.txt'], "--plot 'r.PNG.txt' has another suffix; allowed: a .png file"),
            ([*base, '--plot', 'folder.png'], 'plot output folder.png exists and is not a regular file (it is a '
             'directory); allowed: a new file or a regular file to replace, in an existing, writable folder'),
            (['calibrate', '--plan', '3', '--plot', 'r.png'], '--plot draws the residuals of a fit, and --plan fits '
             'nothing; allowed: --plot with MEASUREMENTS files (of the GPR, or with --robot of the arms)'),
            (['calibrate', '--robot', 'example_robot.yaml', str(arm), '--output', 'r.yaml', '--plot', 'r.svg'],
             "--plot 'r.svg' has another suffix; allowed: a .png file")]:
        status, out, err = run(capsys, *argv)
        assert (status, out, err) == (2, '', f'gpr calibrate: error: {line}\n'), argv
    monkeypatch.setitem(sys.modules, 'matplotlib', None)   # not installed
    status, out, err = run(capsys, *base, '--plot', 'r.png')
    assert (status, out) == (2, '') and err == ("gpr calibrate: error: this command needs the optional package "
                                                "'matplotlib', which is not installed; install it with pip install "
                                                "'gpr_kinematics[plot]'\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ['arm.csv', 'folder.png']
    status, out, err = run(capsys, *base, '--plot', 'x.yaml')   # the same file twice
    assert (status, err) == (2, "gpr calibrate: error: --output 'x.yaml' and --plot 'x.yaml' are the same file; "
                                "allowed: a file of its own for each output\n")


def test_the_arms_residuals_are_drawn_with_robot(capsys, tmp_path, monkeypatch):
    """docs/calibration.md's worked cell: the arm's two files calibrated with --robot and --plot: one panel of
    position residuals (points: no orientation) over the files' 80 rows and one of the parameters, whose numbers are
    the JSON report's (RMS and worst before and after, the worst row's file and line, change over standard error of
    each fitted arm parameter; the frame's left out); stdout and status as without --plot, plus the file's name."""
    from gpr_kinematics.calibration import cell, plot
    monkeypatch.chdir(tmp_path)
    assert cell.main(['cell']) == 0
    config = str(config_path('.'))
    status, out, err = run(capsys, 'calibrate', 'cell/tracker.csv', '--frame', 'tracker', '--target', '0', '0', '0',
                           '0.3', '0.1', '-1', '--fit-target', 'position', '--tolerances',
                           f'{config}/calibration/tolerances_example.yaml', '--output', 'gpr.yaml')
    assert status == 0, err
    drawn = []
    monkeypatch.setattr(plot, 'plot_residuals', lambda path, plots, draw=plot.plot_residuals: drawn.append(plots)
                        or draw(path, plots))
    argv = ['calibrate', '--robot', 'example_robot.yaml', 'cell/arm1_wafer.csv', 'cell/arm1_blade.csv', '--config',
            'gpr.yaml', '--frame', 'tracker', '--output', 'robot.yaml', '--json']
    without = run(capsys, *argv)
    assert rounded(normalised(run(capsys, *argv, '--plot', 'arms.png'))) == rounded(plus_plot(without, 'arms.png'))
    assert without[0] == 0
    assert Path('arms.png').read_bytes()[:8] == PNG
    (data,) = drawn[0]
    (arm,) = json.loads(without[1])['arms']
    assert data.label == 'arm arm1' and data.merged and data.angle is None and len(data.rows) == arm['rows'] == 80
    for when in ('before', 'after'):
        r = arm['residuals'][when]
        pos = getattr(data.position, when)
        assert getattr(data.position, f'rms_{when}') == pytest.approx(r['rms_position'], rel=1e-9)
        assert pos.max() == pytest.approx(r['max_position'], rel=1e-9)
        assert data.names[int(np.argmax(pos))] == f'line {r["worst_position_line"]} of {r["worst_position_file"]}'
    fitted = [p for p in arm['parameters'] if p['status'] == 'fitted' and not p['name'].startswith('base_')]
    assert data.parameters == tuple(p['name'] for p in fitted) and data.parameters[0] == 'arm1_shoulder_length'
    np.testing.assert_allclose(data.z, [p['change'] / p['standard_error'] for p in fitted], rtol=1e-9)
    assert data.passed and data.position.origin == "the file's sigma_position"
    from gpr_kinematics.calibration.plot import residual_figure
    fig = residual_figure(data)
    try:
        assert len(fig.get_axes()) == 2 and fig._suptitle.get_text() == ('arm arm1 from arm1_wafer.csv + '
                                                                         'arm1_blade.csv: 80 rows, gate passed')
    finally:
        import matplotlib.pyplot as plt
        plt.close(fig)

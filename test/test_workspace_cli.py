"""``gpr workspace``: JSON summary, npz boxes, PNG projections, one-line errors with exit status 2."""
import json
import math

import numpy as np
import pytest

from gpr_kinematics import cli
from gpr_kinematics.resources import config_path
from gpr_kinematics.workspace import contains_points
from gpr_kinematics.workspace_models import load_workspace_model


def _run(capsys, *argv):
    code = cli.main(['workspace', *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_json_and_npz_for_the_closed_form_mechanism(tmp_path, capsys):
    path = tmp_path / 'boxes.npz'
    code, out, err = _run(capsys, str(config_path('mechanisms/shell_arm.yaml')), '--delta', '40', '--mm',
                          '--json', '--boxes', str(path), '--no-progress')
    assert code == 0, err
    data = json.loads(out)
    for key in ('inner_boxes', 'boundary_boxes', 'inner_volume', 'outer_volume', 'seconds'):
        assert key in data
    exact = load_workspace_model(config_path('mechanisms/shell_arm.yaml')).exact_volume()
    assert data['inner_volume'] <= exact <= data['outer_volume']
    assert data['delta'] == pytest.approx(0.04) and data['certified'] and not data['interrupted']
    with np.load(path) as npz:
        assert npz['inner'].shape == (data['inner_boxes'], 3, 2)
        assert npz['boundary'].shape == (data['boundary_boxes'], 3, 2)
        assert list(npz['variables']) == ['x', 'y', 'z']
        vol = np.sum(np.prod(npz['inner'][..., 1] - npz['inner'][..., 0], axis=1))
        assert math.isclose(vol, data['inner_volume'], rel_tol=1e-12)


def test_tripod_variables_plots_and_text_output(tmp_path, capsys):
    code, out, err = _run(capsys, 'tripod_3rps.yaml', '--delta', '0.01', '--plot', str(tmp_path),
                          '--boxes', str(tmp_path / 't.npz'))
    assert code == 0, err
    assert 'inner and' in out and 'outer volume' in out
    pngs = sorted(p.name for p in tmp_path.glob('*.png'))
    assert pngs == ['workspace_tripod_3rps_psi_theta.png', 'workspace_tripod_3rps_z_psi.png',
                    'workspace_tripod_3rps_z_theta.png']
    assert all((tmp_path / p).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' for p in pngs)
    with np.load(tmp_path / 't.npz') as npz:
        assert list(npz['variables']) == ['z', 'psi', 'theta'] and list(npz['units']) == ['m', 'rad', 'rad']
        model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
        rng = np.random.default_rng(3)
        pts = model.box[:, 0] + (model.box[:, 1] - model.box[:, 0]) * rng.random((20000, 3))
        ok = model.feasible(pts)
        assert np.all(contains_points(np.concatenate([npz['inner'], npz['boundary']]), pts[ok]))


def test_overrides_grid_method_and_time_limit(capsys):
    code, out, _ = _run(capsys, 'upu3.yaml', '--delta', '0.02', '--json', '--set', 'b=0.25', '--method', 'grid')
    assert code == 0
    data = json.loads(out)
    assert data['overrides'] == {'b': 0.25} and data['method'] == 'grid' and not data['certified']
    code, out, err = _run(capsys, 'tripod_3rps.yaml', '--delta', '0.0003', '--json', '--max-seconds', '0.2')
    assert code == 0
    assert json.loads(out)['interrupted'] and 'interrupted' in err


@pytest.mark.parametrize('argv, match', [
    (['shell_arm.yaml', '--delta', '0'], '--delta must be a positive'),
    (['shell_arm.yaml', '--delta', '-1'], '--delta must be a positive'),
    (['shell_arm.yaml', '--delta', '1e-30'], 'too small'),
    (['no_such_file.yaml', '--delta', '0.1'], 'not found'),
    (['shell_arm.yaml', '--delta', '0.1', '--set', 'l1'], 'KEY=VALUE'),
    (['shell_arm.yaml', '--delta', '0.1', '--set', 'l1=-2'], 'positive'),
    (['shell_arm.yaml', '--delta', '0.1', '--method', 'sivia'], 'invalid choice'),
])
def test_bad_input_exits_2_with_one_line(argv, match, capsys):
    code, out, err = _run(capsys, *argv)
    assert code == 2
    assert match in err and err.count('\n') == 1 and 'Traceback' not in err


@pytest.mark.parametrize('text, match', [
    ('type: hexapod\n', 'unknown mechanism type'),
    ('type: dextar\nla: 0.2\n', 'missing key lb'),
    ('type: dextar\nla: 0.2\nlb: 0.2\nlc: 0.2\nld: 0.2\nd: 0.2\nbrnch: -1\n', 'unknown key(s) brnch'),
    ('[1, 2\n', 'not valid YAML'),
])
def test_bad_files_exit_2(tmp_path, capsys, text, match):
    f = tmp_path / 'm.yaml'
    f.write_text(text)
    code, out, err = _run(capsys, str(f), '--delta', '0.1')
    assert code == 2 and match in err and err.count('\n') == 1


def test_ctrl_c_stops_cleanly_and_keeps_the_boxes(tmp_path):
    """A real SIGINT to a running ``gpr workspace``: exit 0, result marked interrupted, boxes saved."""
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / 'partial.npz'
    env = dict(os.environ, PYTHONUNBUFFERED='1')
    proc = subprocess.Popen([sys.executable, '-m', 'gpr_kinematics.cli', 'workspace', 'tripod_3rps.yaml',
                             '--delta', '0.0001', '--json', '--boxes', str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    seen = ''
    deadline = time.monotonic() + 120
    while 'decided' not in seen and time.monotonic() < deadline:     # the progress bar: the run is going
        ch = proc.stderr.read(1)
        if not ch:
            break
        seen += ch
    assert 'decided' in seen, seen
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    stderr = seen + stderr
    assert proc.returncode == 0, stderr
    data = json.loads(stdout)
    assert data['interrupted'] and 'interrupted' in stderr
    with np.load(out) as npz:
        assert bool(npz['interrupted'])
        model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
        rng = np.random.default_rng(5)
        pts = model.box[:, 0] + (model.box[:, 1] - model.box[:, 0]) * rng.random((20000, 3))
        ok = model.feasible(pts)
        assert np.all(contains_points(np.concatenate([npz['inner'], npz['boundary']]), pts[ok]))
        if npz['inner'].shape[0]:
            assert np.all(model.feasible(npz['inner'][:, :, 0])) and np.all(model.feasible(npz['inner'][:, :, 1]))

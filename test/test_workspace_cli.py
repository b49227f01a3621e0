"""``gpr workspace``: JSON summary, npz boxes, PNG projections, one-line errors with exit status 2."""
import json
import math
import os
import re

import numpy as np
import pytest
from gpr_kinematics.cli import main as cli
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.workspace import contains_points
from gpr_kinematics.workspace.boxes import closed_faces, reached_faces
from gpr_kinematics.workspace.loader import load_workspace_model


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


def test_plots_never_write_through_a_link_or_over_the_model(tmp_path, capsys, monkeypatch):
    """A projection's name linked to the model file in the --plot folder: savefig wrote the PNG into the model
    (exit 0, "3 projections written"); linked to /dev/null it wrote into the device; a FIFO there gave "cannot
    write ...: None". Each is refused in one line naming it, the model untouched."""
    monkeypatch.chdir(tmp_path)
    model = tmp_path / 'sa.yaml'
    model.write_bytes(config_path('mechanisms/shell_arm.yaml').read_bytes())
    before = model.read_bytes()
    plots = tmp_path / 'pd'
    plots.mkdir()
    target = plots / 'workspace_sa_x_y.png'
    for make, words in ((lambda: target.symlink_to(model), 'is a symbolic link'),
                        (lambda: target.symlink_to('/dev/null'), 'is a symbolic link'),
                        (lambda: os.mkfifo(target), 'is a FIFO')):
        make()
        code, out, err = _run(capsys, 'sa.yaml', '--delta', '0.1', '--scheduler', 'none', '--plot', 'pd',
                              '--no-progress')
        assert code == 2 and err.count('\n') == 1 and 'workspace_sa_x_y.png' in err and words in err, err
        assert 'None' not in err and model.read_bytes() == before
        target.unlink()
    code, out, err = _run(capsys, 'sa.yaml', '--delta', '0.1', '--scheduler', 'none', '--plot', 'pd',
                          '--no-progress')
    assert code == 0 and target.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and model.read_bytes() == before


def test_the_options_are_named_and_a_plot_of_one_output_refused(tmp_path, capsys):
    """--max-seconds was named as the Python parameter (max_seconds = -1.0); --plot on a model of one output exited 0
    with "0 projections written"; contains_points of mismatched dimensions raised numpy's ValueError."""
    from gpr_kinematics.errors import InputError
    for value in ('-1', 'nan'):
        code, out, err = _run(capsys, 'tripod_3rps.yaml', '--delta', '0.01', '--max-seconds', value)
        assert code == 2 and err.count('\n') == 1 and '--max-seconds = ' in err and 'max_seconds =' not in err, err
    one = tmp_path / 'one.yaml'
    one.write_text("type: equations\nname: t\nvariables: {x: [-1, 1]}\noutputs: [x]\ninequalities: ['x <= 0.5']\n")
    code, out, err = _run(capsys, str(one), '--delta', '0.1', '--plot', str(tmp_path / 'pp'))
    assert code == 2 and err.count('\n') == 1 and 'has one (x); allowed: --plot for models of 2 or more' in err, err
    for boxes, points in ((np.zeros((3, 2, 2)), np.zeros((4, 3))), (np.zeros((3, 2)), np.zeros((4, 2)))):
        with pytest.raises(InputError, match=r'allowed: boxes \(n, d, 2\) and points \(N, d\) of the same d'):
            contains_points(boxes, points)


def test_overrides_grid_method_and_time_limit(capsys):
    code, out, _ = _run(capsys, 'upu3.yaml', '--delta', '0.02', '--json', '--set', 'b=0.25', '--method', 'grid')
    assert code == 0
    data = json.loads(out)
    assert data['overrides'] == {'b': 0.25} and data['method'] == 'grid' and not data['certified']
    code, out, _ = _run(capsys, 'upu3.yaml', '--delta', '0.02', '--set', 'b=0.25', '--method', 'grid')
    assert out.startswith(f"upu3: {data['inner_boxes']} inner and {data['boundary_boxes']} boundary boxes "
                          f"({data['outside_boxes']} outside), method grid (sampled, not certified), delta 0.02 m\n")
    code, out, err = _run(capsys, 'tripod_3rps.yaml', '--delta', '0.0003', '--json', '--max-seconds', '0.2')
    assert code == 0
    assert json.loads(out)['interrupted'] and 'interrupted' in err


@pytest.mark.parametrize('argv, match', [
    (['shell_arm.yaml', '--delta', '0'], '--delta = 0 is invalid; allowed: a positive number (m, or mm with --mm)\n'),
    (['shell_arm.yaml', '--delta', '-1'], '--delta = -1 is invalid; allowed: a positive number'),
    (['shell_arm.yaml', '--delta', '1e-30'], 'too small'),
    (['shell_arm.yaml', '--delta', '5e-324', '--mm'],   # positive, 0 m: it was said not to be positive
     '--delta = 4.94066e-324 mm is 0 m in floating point; allowed: a positive number of mm whose metres are a float '
     'above 0 (at least 4.94e-321 mm)\n'),
    (['no_such_file.yaml', '--delta', '0.1'], 'not found'),
    (['shell_arm.yaml', '--delta', '0.1', '--set', 'l1'], 'KEY=VALUE'),
    (['shell_arm.yaml', '--delta', '0.1', '--set', 'l1=-2'], 'positive'),
    (['shell_arm.yaml', '--delta', '0.1', '--set', 'l1=[&a [1, 1], &b [*a, *a], [*b, *b]]'],
     'is not valid YAML: line 1: YAML aliases (*name) are not accepted'),
    (['shell_arm.yaml', '--delta', '0.1', '--set', 'l1={a: [1,'],   # the reason, not "(no aliases)"
     "--set l1: value '{a: [1,' is not valid YAML: not valid YAML on line 2, column 1: did not find expected node"),
    (['shell_arm.yaml', '--delta', '0.1', '--set', 'l1=' + '[' * 5000], 'at most 2000'),
    (['shell_arm.yaml', '--delta', '0.1', '--method', 'sivia'], 'invalid choice'),
    (['shell_arm.yaml', '--delta', '0.1', '--set', 'l1=0.2', '--set', 'l1=0.3'], '--set l1 is given twice'),
    (['shell_arm.yaml', '--delta', '0.1', '--set', 'l1=0x10'], "l1 must be a positive finite length in m; got '0x10'"),
    (['shell_arm.yaml', '--delta', '0.1', '--boxes', 'victim.csv'],   # it overwrote a measurement CSV with a zip
     "--boxes 'victim.csv' has another suffix; allowed: a .npz file (or a name without a suffix, written as given)"),
])
def test_bad_input_exits_2_with_one_line(argv, match, capsys):
    code, out, err = _run(capsys, *argv)
    assert code == 2
    assert match in err and err.count('\n') == 1 and 'Traceback' not in err


def test_a_mechanism_type_without_a_workspace_model_is_named_so(capsys):
    """``stewart_alwan.yaml`` was refused as of an "unknown mechanism type 'stewart_6sps'": the type is known."""
    code, out, err = _run(capsys, 'stewart_alwan.yaml', '--delta', '0.1')
    assert code == 2 and err.count('\n') == 1
    assert err.endswith("stewart_alwan.yaml: mechanism type 'stewart_6sps' has no workspace model; allowed: the types "
                        'with a workspace model: tripod_3rps, rrr3_planar, dextar, upu3, gpr, shell_arm, equations, '
                        'joint_working_area\n')


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


@pytest.mark.slow
@pytest.mark.parametrize('signum, status', [(2, 130), (15, 143)])
def test_ctrl_c_stops_cleanly_and_keeps_the_boxes(tmp_path, signum, status):
    """A real SIGINT (SIGTERM) to a running ``gpr workspace``: result marked interrupted, boxes saved, and the
    status a stopped command has, 130 (143): it exited 0, so a script took it for a finished run."""
    import os
    import subprocess
    import sys
    import time

    out = tmp_path / 'partial.npz'
    env = dict(os.environ, PYTHONUNBUFFERED='1')
    proc = subprocess.Popen([sys.executable, '-m', 'gpr_kinematics.cli.main', 'workspace', 'tripod_3rps.yaml',
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
    proc.send_signal(signum)
    stdout, stderr = proc.communicate(timeout=60)
    stderr = seen + stderr
    assert proc.returncode == status, stderr
    data = json.loads(stdout)
    word = 'terminated' if signum == 15 else 'interrupted'   # SIGTERM's stop says so, as every command's (README)
    assert data['interrupted'] and word in data['stopped'].split('; ') and f'gpr workspace: {word}' in stderr, stderr
    # the default scheduler: the run was cut into parts on a Dask local cluster when it was stopped
    import importlib.util
    assert data['cluster_used'] == (importlib.util.find_spec('distributed') is not None)
    with np.load(out) as npz:
        assert bool(npz['interrupted'])
        model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
        rng = np.random.default_rng(5)
        pts = model.box[:, 0] + (model.box[:, 1] - model.box[:, 0]) * rng.random((20000, 3))
        ok = model.feasible(pts)
        assert np.all(contains_points(np.concatenate([npz['inner'], npz['boundary']]), pts[ok]))
        if npz['inner'].shape[0]:
            assert np.all(model.feasible(npz['inner'][:, :, 0])) and np.all(model.feasible(npz['inner'][:, :, 1]))


def test_equation_models_through_the_cli(tmp_path, capsys):
    """DexTAR in its 6-D form: JSON over its outputs, the boxes file exactly where asked, its plot."""
    path = tmp_path / 'dextar boxes'                                     # no .npz suffix: written as given
    code, out, err = _run(capsys, 'dextar_6d.yaml', '--delta', '30', '--mm', '--json', '--boxes', str(path),
                          '--plot', str(tmp_path / 'plots'), '--scheduler', 'none')
    assert code == 0, err
    data = json.loads(out)
    assert data['type'] == 'equations' and data['variables'] == ['x', 'y'] and data['certified']
    assert data['box'] == [[-0.52, 0.52], [-0.52, 0.52]] and data['boxes_file'] == str(path)
    exact = load_workspace_model(config_path('mechanisms/dextar.yaml')).exact_area()
    assert data['inner_volume'] <= exact <= data['outer_volume']
    with np.load(path) as npz:
        assert npz['inner'].shape == (data['inner_boxes'], 2, 2) and list(npz['variables']) == ['x', 'y']
    assert [p.name for p in (tmp_path / 'plots').iterdir()] == ['workspace_dextar_6d_x_y.png']
    assert not list(tmp_path.glob('*.npz')) and not list(tmp_path.glob('.boxes-*'))


def test_the_text_summary_is_headed_by_the_file_name_as_the_plots_are(tmp_path, capsys):
    """A model given by equations was headed by its type (``equations:``), every packaged model by its own name,
    which is its file's; all are now headed by the file's name, the name the plots carry. At ``delta`` 1 m the
    covering stops at the first bisection (0.15 s): the 4 boxes of the initial box (2 x 1.04 m wide), all boundary."""
    code, out, err = _run(capsys, 'dextar_6d.yaml', '--delta', '1000', '--mm', '--scheduler', 'none', '--no-progress')
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0] == 'dextar_6d: 0 inner and 4 boundary boxes (0 outside), method covering, delta 1 m'
    assert lines[1].startswith(f'inner volume 0 m*m, outer volume {1.04 ** 2:.6g} m*m, ')
    (tmp_path / 'my_shell.yaml').write_bytes(config_path('mechanisms/shell_arm.yaml').read_bytes())
    code, out, err = _run(capsys, str(tmp_path / 'my_shell.yaml'), '--delta', '1000', '--mm', '--no-progress')
    assert code == 0, err
    assert out.startswith('my_shell: ')


@pytest.mark.slow
def test_the_joint_working_area_through_the_cli(tmp_path, capsys):
    code, out, err = _run(capsys, 'joint_working_area.yaml', '--delta', '16', '--mm', '--plot', str(tmp_path),
                          '--scheduler', 'none')
    assert code == 0, err
    assert 'joint_working_area:' in out and 'outer volume' in out and '3 projections written to' in out
    assert sorted(p.name for p in tmp_path.glob('*.png')) == [
        'workspace_joint_working_area_px_py.png', 'workspace_joint_working_area_px_pz.png',
        'workspace_joint_working_area_py_pz.png']
    assert 'may extend beyond' not in out                 # its box holds a bound proved from both mechanisms


@pytest.mark.parametrize('text, match', [
    ('type: equations\nvariables: {q: [-1, 1], x: [-2, 2]}\noutputs: [x]\nequations: ["x = sin(q"]\n',
     "expected '\\)'"),
    ('type: equations\nvariables: {q: [-1, 1], x: [-2, 2]}\noutputs: [x]\nequations: ["x = sin(w)"]\n',
     "unknown name 'w' at column 9"),
    ('type: equations\nvariables: {q: [1, 1], x: [-2, 2]}\noutputs: [x]\nequations: ["x = sin(q)"]\n',
     'needs lower < upper'),
    ('type: equations\nvariables: {q: [-1, 1], x: [-2, 2]}\noutputs: [y]\nequations: ["x = sin(q)"]\n',
     'outputs must be distinct variables'),
    ('type: equations\nvariables: {q: [-1, 1], x: [-2, 2]}\noutputs: [x]\nequations: ["import os"]\n',
     "unknown name 'import'"),
])
def test_bad_equation_files_exit_2_with_one_line(tmp_path, capsys, text, match):
    f = tmp_path / 'eq.yaml'
    f.write_text(text)
    code, out, err = _run(capsys, str(f), '--delta', '0.1', '--scheduler', 'none')
    assert code == 2 and re.search(match, err) and err.count('\n') == 1 and 'Traceback' not in err


def test_output_paths_are_checked_before_the_run(tmp_path, capsys):
    fifo = tmp_path / 'fifo'
    os.mkfifo(fifo)
    (tmp_path / 'a_file').write_text('x')
    (tmp_path / 'link.npz').symlink_to(tmp_path / 'a_file')
    for argv, match in ((['--boxes', str(tmp_path)], 'is a directory'),
                        (['--boxes', str(fifo)], 'exists and is not a regular file'),
                        (['--boxes', str(tmp_path / 'no' / 'b.npz')], 'does not exist'),
                        (['--boxes', str(tmp_path / 'link.npz')], 'it is a symbolic link'),   # the package's rule
                        (['--boxes', ''], '--boxes output path is empty'),                  # was ignored
                        (['--plot', ''], '--plot: the folder path is empty'),               # wrote into .
                        (['--plot', str(tmp_path / 'a_file')], 'exists and is not a directory')):
        code, out, err = _run(capsys, 'shell_arm.yaml', '--delta', '0.1', *argv)
        assert code == 2 and match in err and err.count('\n') == 1, err
    assert fifo.exists() and (tmp_path / 'a_file').read_text() == 'x'


@pytest.mark.parametrize('argv, match', [
    (['--scheduler', 'cluster'], 'allowed: none, local or a Dask scheduler address'),
    (['--scheduler', 'tcp://127.0.0.1:8786\n'], 'allowed: none, local or a Dask scheduler address'),  # $ before \n
    (['--max-boxes', '1_0'], "argument --max-boxes: invalid int value: '1_0'"),   # int() read 10
    (['--scheduler', 'none', '--workers', '2'], '--workers = 2 with --scheduler none; allowed: --workers with '
                                                '--scheduler local only'),
    (['--workers', '0'], '--workers = 0; allowed: an integer from 1 to 256'),
    (['--max-boxes', '0'], '--max-boxes = 0; allowed: a whole number of boxes, at least 1'),
    (['--parts', '0'], '--parts = 0 is invalid; allowed: an integer from 1 to 100000\n'),
    (['--method', 'grid', '--grid-nodes', '1'], '--grid-nodes = 1 is invalid; allowed: an integer of at least 2 '
                                                '(nodes per box edge)\n'),
    # options of another method or scheduler ran without a word
    (['--grid-nodes', '5'], '--grid-nodes belongs to --method grid; allowed with --method covering: no --grid-nodes'),
    (['--scheduler', 'none', '--parts', '5'], '--parts cuts a run for the workers of a Dask scheduler'),
])
def test_bad_run_options_exit_2(argv, match, capsys):
    code, out, err = _run(capsys, 'shell_arm.yaml', '--delta', '0.1', *argv)
    assert code == 2 and match in err and err.count('\n') == 1, err


def test_a_delta_too_small_for_the_box_exits_2(capsys):
    """Given after ``--delta 0.1`` in the table above, it met the refusal of an option given twice instead."""
    code, out, err = _run(capsys, 'shell_arm.yaml', '--delta', '1e-300')
    assert code == 2 and 'too small' in err and err.count('\n') == 1, err


def test_a_box_of_volume_zero_exits_2_with_one_line(capsys):
    """Links of 1e-300 m: a traceback (ZeroDivisionError of the progress), after a warning that the box is not
    divided; now the one line naming the volume, before any warning (for a box given so; such links are refused as
    lengths since)."""
    code, out, err = _run(capsys, 'shell_arm.yaml', '--delta', '1e-115', '--set',
                          'workspace={box: {x: [0, 1e-110], y: [0, 1e-110], z: [0, 1e-110]}}')
    assert code == 2 and err.count('\n') == 1 and 'Traceback' not in err, err
    assert err.startswith('gpr workspace: error: the initial box has volume 0 (the product of its edges [1e-110, '), err
    code, out, err = _run(capsys, 'shell_arm.yaml', '--delta', '0.05', '--set', 'l1=1e-300', '--set', 'l2=1e-300',
                          '--set', 'workspace={}')   # the box of the links' reach, [-2e-300, 2e-300]^3
    assert code == 2 and err.startswith('gpr workspace: error: ') and err.endswith(
        'shell_arm.yaml (shell_arm): l1 = 1e-300; allowed: a length from 1e-06 to 1e+06 m\n'), err   # the file named

def test_the_box_limit_stops_a_run_and_keeps_a_valid_result(capsys):
    code, out, err = _run(capsys, 'tripod_3rps.yaml', '--delta', '0.001', '--json', '--max-boxes', '20000',
                          '--scheduler', 'none')
    data = json.loads(out)
    assert code == 0 and data['interrupted'] and data['stopped'] == 'box limit (20000 boxes)'
    assert data['inner_boxes'] + data['boundary_boxes'] <= 20000 and 'box limit' in err


def test_the_default_box_limit_of_a_run_is_of_its_models_bytes(capsys, monkeypatch, tmp_path):
    """Without --max-boxes a 16-variable model had the 10 million boxes of a 3-D one (4.3 GB at delta 0.2): its
    default is the boxes BOX_MEMORY holds at 256 bytes each (here shrunk to 25,600 bytes: 100 boxes)."""
    import yaml
    from gpr_kinematics.workspace import base
    names = [f'x{i}' for i in range(16)]
    path = tmp_path / 'ball16.yaml'
    path.write_text(yaml.safe_dump({'type': 'equations', 'variables': {v: [-1.0, 1.0] for v in names},
                                    'outputs': names, 'inequalities': [' + '.join(f'{v}^2' for v in names) + ' <= 1']}))
    monkeypatch.setattr(base, 'BOX_MEMORY', 25_600)
    code, out, err = _run(capsys, str(path), '--delta', '0.0001', '--json', '--scheduler', 'none', '--no-progress')
    data = json.loads(out)
    assert code == 0 and data['stopped'] == 'box limit (100 boxes)' and 'box limit (100 boxes)' in err
    code, out, _ = _run(capsys, '--help')
    assert code == 0 and '16 bytes per variable each: 10000000 up to 3 variables, 1875000 for 16' in ' '.join(
        out.split())


def test_a_box_limit_beyond_the_machines_memory_exits_2(capsys, monkeypatch):
    """--max-boxes was checked to be 1 to 1e9 whatever the model and the machine (1e9 boxes of 3 variables take
    48 GB): on a machine of 2.048 GB, 512 MB of boxes, 10,666,666 of the tripod's 3 variables."""
    from gpr_kinematics.workspace import base
    monkeypatch.setattr(base.os, 'sysconf', lambda name: {'SC_PAGE_SIZE': 4096, 'SC_PHYS_PAGES': 500_000}[name])
    monkeypatch.setattr(base, 'CGROUP_LIMITS', ())   # no container's limit, whatever this machine has
    code, out, err = _run(capsys, 'tripod_3rps.yaml', '--delta', '0.01', '--max-boxes', '1000000000',
                          '--scheduler', 'none')
    assert code == 2 and out == '' and err == (
        'gpr workspace: error: --max-boxes = 1000000000: that many boxes of 3 variables (48 bytes each) take 48 GB; '
        'allowed: at most 10666666 boxes for this model (0.512 GB, 25% of the 2.05 GB of physical memory)\n')


def test_the_progress_bar_never_stops_a_run_when_stderr_is_gone(monkeypatch):
    """``gpr workspace ... 2>&-`` (``sys.stderr`` None) or a stderr whose reader went away: the bar is dropped, the
    covering goes on (it ended the run with an AttributeError once the bar was due)."""
    import io

    from gpr_kinematics.workspace.progress import Progress
    monkeypatch.setattr('sys.stderr', None)
    bar = Progress(True, after=0.0)
    bar.update(1, 0.1, 0.01, 10, 0.5, 0.1, 0.5)
    bar.close()
    assert not bar.shown

    class Gone(io.StringIO):
        def write(self, text):
            raise BrokenPipeError(32, 'Broken pipe')

    bar = Progress(True, Gone(), after=0.0)
    bar.update(1, 0.1, 0.01, 10, 0.5, 0.1, 0.5)
    bar.refresh()
    bar.close()
    assert bar.stream is None and not bar.enabled and not bar.shown


def test_the_projection_says_when_the_boxes_reach_the_frame_or_the_run_stopped_early():
    """The 3-UPU with b = 0.25, limb_max = 0.3 reaches the top of its initial box (z = 0.28 m): the text said 'the
    workspace may extend beyond it', the figure, framed by that box, showed a dome cut flat with no word. Its title
    says so now, and a run stopped by --max-boxes says that its unexamined boxes are drawn as boundary; the boxes
    are drawn as the covering's (one rectangle per distinct projection), the axes in the variables' units."""
    import matplotlib.pyplot as plt
    from gpr_kinematics.cli.workspace import projection_figure
    from gpr_kinematics.workspace import approximate
    model = load_workspace_model(config_path('mechanisms/upu3.yaml'), {'b': 0.25, 'limb_max': 0.3})
    result = approximate(model, 0.02, progress=False)
    assert result.touches_initial_box and not result.interrupted
    fig = projection_figure(result, 0, 2, 'upu3', model.box)
    ax = fig.axes[0]
    assert ax.get_title() == _title('upu3: projection on x-z', 'inner (blue) and boundary (orange), delta = 0.02 m',
                                    'the boxes reach the frame (z): the workspace may extend beyond it')
    assert (ax.get_xlabel(), ax.get_ylabel()) == ('x [m]', 'z [m]') and ax.get_ylim() == tuple(model.box[2])
    assert ax.get_aspect() == 1.0   # a plane of lengths at its true shape (the dome had been 1.8x as tall)
    boundary, inner = ax.collections
    assert len(inner.get_paths()) == len(np.unique(result.inner[:, [0, 2]].reshape(-1, 4), axis=0))
    assert len(boundary.get_paths()) == len(np.unique(result.boundary[:, [0, 2]].reshape(-1, 4), axis=0))
    plt.close(fig)
    stopped = approximate(model, 0.02, progress=False, max_boxes=50)
    assert stopped.interrupted
    fig = projection_figure(stopped, 0, 2, 'upu3', model.box)
    assert fig.axes[0].get_title().endswith('\n' + _title(f'stopped early ({stopped.stopped}): unexamined boxes '
                                                          'drawn as boundary'))
    plt.close(fig)
    # the GPR's boxes reach the stroke's ends only: its tilt plane was titled as reaching a frame they stop well
    # inside (about +-0.11 of +-0.3 rad)
    gpr = load_workspace_model(config_path('mechanisms/gpr.yaml'))
    result = approximate(gpr, 0.004, progress=False)
    assert reached_faces(gpr.box, result.inner, result.boundary) == (0,) and result.variables[0] == 'z'
    assert np.max(np.abs(result.boundary[:, 1:, :])) < 0.2
    titles = []
    for i, j in ((0, 1), (1, 2)):
        fig = projection_figure(result, i, j, 'gpr', gpr.box)
        titles.append(fig.axes[0].get_title())
        fig.canvas.draw()   # the wrapped title inside the figure (the tripod's third line was cut at its edge)
        bb = fig.axes[0].title.get_window_extent()
        assert bb.x0 >= 0.0 and bb.x1 <= fig.bbox.x1 and bb.y1 <= fig.bbox.y1, (bb, fig.bbox)
        assert max(len(line) for line in titles[-1].splitlines()) <= 80, titles[-1]   # 89 here, 93 the tripod's
        plt.close(fig)
    # and those are closed faces (z, the rods' mean, lies within the stroke): no "may extend beyond it" in either
    assert not result.touches_initial_box and not any('may extend beyond' in t for t in titles), titles
    assert reached_faces(gpr.box, result.inner, result.boundary, closed=closed_faces(gpr, gpr.box)) == ()


def _title(*lines):
    """A projection's title of ``lines``, each wrapped at TITLE_WIDTH characters (the tripod's third line, of 93, had
    been cut at the figure's edge)."""
    import textwrap

    from gpr_kinematics.cli.workspace import TITLE_WIDTH
    assert TITLE_WIDTH <= 90
    return '\n'.join(textwrap.fill(line, TITLE_WIDTH) for line in lines)


def test_a_delta_as_large_as_the_box_is_warned_about(capsys):
    """--delta 1 (1 mm meant) ran one box without a word: allowed (docs/workspace.md), now with a warning that names
    the box's largest scaled edge and --mm; a delta that divides the box warns of nothing."""
    code, out, err = _run(capsys, 'gpr.yaml', '--delta', '1', '--scheduler', 'none')
    assert code == 0 and '0 inner and 1 boundary boxes' in out
    assert ("gpr workspace: warning: --delta 1 m is at least the initial box's largest scaled edge (0.508 m): the box "
            'is not divided; millimetres? give --mm\n') in err, err
    code, out, err = _run(capsys, 'gpr.yaml', '--delta', '1', '--mm', '--scheduler', 'none', '--max-seconds', '2')
    assert code == 0 and 'warning' not in err, err


def test_a_plot_folder_that_cannot_be_made_says_what_is_allowed(tmp_path, capsys):
    """--plot under a regular file: the refusal named the error only (every refusal names what is allowed)."""
    afile = tmp_path / 'afile'
    afile.write_text('')
    code, _, err = _run(capsys, 'tripod_3rps.yaml', '--delta', '0.02', '--scheduler', 'none', '--plot',
                        str(afile / 'sub'))
    assert code == 2 and err.count('\n') == 1 and err.endswith(
        'Not a directory; allowed: a directory that exists or can be created (its parent directories writable)\n'), err


@pytest.mark.parametrize('box, volumes', [
    ("{x: [-0.4, 0.4], y: [-0.4, 0.4], z: [0.0, 0.4]}", (2.97, 4.05)),   # docs/workspace.md's table (b = 0.25)
    (None, (2.77, 4.34)),                                                  # the shipped box cuts the upper dome
])
def test_the_3upu_study_volumes_of_the_docs_need_its_box(capsys, box, volumes):
    """docs/workspace.md's 3-UPU table (b = 0.25 m: 2.97 / 4.05 litres at delta 5 mm) holds in its box of
    +-0.4 m, z in [0, 0.4] m; the shipped file's smaller box reaches the dome and gives other volumes (the docs said
    the table was the command's, which printed 2.77 / 4.34)."""
    extra = () if box is None else ('--set', f'workspace={{box: {box}}}')
    status, out, _ = _run(capsys, 'upu3.yaml', '--delta', '0.005', '--set', 'b=0.25', *extra,
                          '--scheduler', 'none', '--no-progress')
    assert status == 0
    m = re.search(r'inner volume (\S+) m\*m\*m, outer volume (\S+) m\*m\*m', out)
    assert m is not None, out
    assert (round(float(m[1]) * 1000, 2), round(float(m[2]) * 1000, 2)) == volumes


@pytest.mark.parametrize('stopped, caught, status, said', [
    ('interrupted; box limit (100 boxes, shared among the parts)', None, 130,
     'interrupted; box limit (100 boxes, shared among the parts)'),   # the parts' reasons joined, the signal's first
    ('interrupted; box limit (100 boxes, shared among the parts)', 15, 143,
     'terminated; box limit (100 boxes, shared among the parts)'),
    ('interrupted', None, 130, 'interrupted'),
    ('interrupted', 15, 143, 'terminated'),
    ('interrupted', 2, 130, 'interrupted'),
    ('time limit (1 s)', None, 0, 'time limit (1 s)'),
    ('box limit (100 boxes)', None, 0, 'box limit (100 boxes)'),
])
def test_the_status_of_a_stop_by_a_signal_whatever_else_stopped_parts(capsys, monkeypatch, stopped, caught, status,
                                                                       said):
    """A signal exited 0 where the run's parts had stopped for several reasons ('...; interrupted'): 130 or 143 with
    the proved boxes written, as alone; a limit's stop exits 0. SIGTERM's stop says ``terminated`` (it said
    ``interrupted``, where every other command stopped by SIGTERM says ``terminated``)."""
    import dataclasses

    from gpr_kinematics.cli import workspace as ws
    from gpr_kinematics.workspace.progress import StopFlag
    real = ws.approximate

    def stopped_run(*args, **kwargs):
        result = real(*args, **kwargs)
        monkeypatch.setattr(StopFlag, 'caught', caught)   # as a flag's handler sets it (restored after the test)
        return dataclasses.replace(result, interrupted=True, stopped=stopped)

    monkeypatch.setattr(ws, 'approximate', stopped_run)
    code, out, err = _run(capsys, 'shell_arm.yaml', '--delta', '0.1', '--json')
    assert code == status and json.loads(out)['stopped'] == said
    word = 'terminated' if caught == 15 else 'interrupted'
    if status:   # the parts' own limits beside the signal ('interrupted (box limit (...); interrupted)' before)
        also = '' if said == word else f' (also stopped by: {said.removeprefix(f"{word}; ")})'
        assert err.startswith(f'gpr workspace: {word}{also} after '), err
    else:        # a limit alone: no signal, the limit named
        assert err.startswith(f'gpr workspace: interrupted ({said}) after '), err


def _children(pid):
    """The processes whose parent is ``pid`` (Linux's /proc)."""
    found = []
    for entry in os.listdir('/proc'):
        try:
            with open(f'/proc/{entry}/stat') as f:
                if entry.isdigit() and int(f.read().rsplit(')', 1)[1].split()[1]) == pid:
                    found.append(int(entry))
        except (OSError, ValueError, IndexError):
            continue
    return found


@pytest.mark.slow
@pytest.mark.skipif(not os.path.isdir('/proc'), reason='reads /proc')
def test_ctrl_c_to_the_process_group_as_the_local_cluster_starts_stops_cleanly(tmp_path):
    """A terminal's Ctrl-C goes to the whole process group: sent as the local cluster started (its first child
    process seen), the run ended in a long traceback, "RuntimeError: Nanny failed to start.", exit 1, no output.
    Now: exit 130, one line on stderr, the result so far printed, marked interrupted, no process left."""
    import signal
    import subprocess
    import sys
    import time
    pytest.importorskip('distributed')
    cmd = [sys.executable, '-m', 'gpr_kinematics', 'workspace', 'tripod_3rps.yaml', '--delta', '0.3', '--mm',
           '--workers', '2', '--max-boxes', '3000000', '--no-progress', '--json']
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                            start_new_session=True)   # a group of its own, as a terminal's job
    try:
        due = time.monotonic() + 60
        while not _children(proc.pid) and proc.poll() is None and time.monotonic() < due:
            time.sleep(0.02)
        os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130 and 'Traceback' not in err, err
    assert err.count('\n') == 1 and err.startswith('gpr workspace: interrupted'), err
    assert json.loads(out)['interrupted'] is True
    due = time.monotonic() + 30   # the cluster's processes (forkserver, resource tracker) follow it
    while any(_pgid(p) == proc.pid for p in os.listdir('/proc') if p.isdigit()) and time.monotonic() < due:
        time.sleep(0.2)
    assert not [p for p in os.listdir('/proc') if p.isdigit() and _pgid(p) == proc.pid]


def _pgid(pid):
    try:
        return os.getpgid(int(pid))
    except OSError:
        return None


def test_a_grid_that_finds_no_feasible_node_says_the_workspace_may_lie_between(capsys):
    """The shipped 3-UPU under --method grid (3 nodes an edge: none of the initial box's 27 is feasible) printed
    '0 inner and 0 boundary boxes ... volume 0', status 0, no word; 4 nodes give 0.0144 m^3 inner."""
    code, out, err = _run(capsys, 'upu3.yaml', '--delta', '0.01', '--method', 'grid', '--no-progress')
    assert code == 0 and out.startswith('upu3: 0 inner and 0 boundary boxes (1 outside)'), out
    assert err == ('gpr workspace: warning: no feasible point among the grid nodes of its boxes: the workspace may '
                   'lie between them (method grid, not certified; --grid-nodes, or --method covering)\n')
    code, out, err = _run(capsys, 'upu3.yaml', '--delta', '0.01', '--method', 'grid', '--grid-nodes', '4',
                          '--no-progress')
    assert code == 0 and 'inner volume 0.0144' in out and err == '', out + err


@pytest.mark.parametrize('method', ['grid', 'uniform'])
def test_a_sampled_method_is_not_certified_in_its_plots_and_boxes_file(method, tmp_path, capsys):
    """The plot of a grid run was titled as the covering's ("inner (blue) and boundary (orange)") and its boxes file
    had no word of certification: a picture and a file of guesses taken for certified ones. Both say so now; the
    covering's title and file say nothing of the kind, and its file says certified."""
    import matplotlib.pyplot as plt
    npz = tmp_path / 'b.npz'
    code, out, err = _run(capsys, 'dextar.yaml', '--delta', '0.05', '--method', method, '--boxes', str(npz),
                          '--plot', str(tmp_path / 'p'), '--no-progress')
    assert code == 0 and 'sampled, not certified' in out
    with np.load(npz) as f:
        assert str(f['method']) == method and not bool(f['certified'])
    from gpr_kinematics.cli.workspace import projection_figure
    from gpr_kinematics.workspace import approximate
    model = load_workspace_model(config_path('mechanisms/dextar.yaml'))
    for m in (method, 'covering'):
        result = approximate(model, 0.05, method=m, progress=False)
        fig = projection_figure(result, 0, 1, 'dextar', model.box)
        title = fig.axes[0].get_title().replace('\n', ' ')
        plt.close(fig)
        assert ('not certified' in title) == (m != 'covering') and result.certified == (m == 'covering'), title
    code, out, err = _run(capsys, 'dextar.yaml', '--delta', '0.05', '--boxes', str(npz), '--no-progress')
    with np.load(npz) as f:
        assert bool(f['certified'])

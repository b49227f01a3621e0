"""The gpr command line (core subcommands): JSON keys, units, and one-line errors with status 2."""
import argparse
import errno
import io
import json
import math
import os
import re
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gpr_kinematics.cli.main import main
from gpr_kinematics.core import forward, inverse


def run(capsys, *argv):
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def run_json(capsys, *argv):
    status, out, err = run(capsys, *argv, '--json')
    assert status == 0, err
    assert out.count('\n') == 1
    return json.loads(out)


def test_fk_json_matches_core_and_mm_convenience(capsys):
    d = run_json(capsys, 'fk', '0.5', '0.503', '0.498')
    for key in ('q', 'model', 'position', 'quaternion', 'tilt', 'tilt_azimuth', 'virtual_joints', 'side_lengths',
                'centre_shift', 'iterations', 'residual'):
        assert key in d
    fk = forward([0.5, 0.503, 0.498])
    np.testing.assert_allclose(d['position'], fk.position, atol=0)
    np.testing.assert_allclose(d['quaternion'], fk.quaternion, atol=0)
    assert d['model'] == 'radial' and len(d['virtual_joints']) == 3
    d_mm = run_json(capsys, 'fk', '500', '503', '498', '--mm', '--model', 'polar')
    assert d_mm['model'] == 'polar' and len(d_mm['virtual_joints']) == 6
    np.testing.assert_allclose(d_mm['q'], [0.5, 0.503, 0.498], atol=1e-15)


def test_ik_and_compensate_json(capsys):
    d = run_json(capsys, 'ik', '--height', '0.5', '--tilt', '2', '--azimuth', '0', '--deg')
    assert set(d['achieved']) >= {'position', 'quaternion', 'tilt', 'tilt_azimuth'}
    np.testing.assert_allclose(d['q'], inverse(0.5, math.radians(2), 0.0).q, atol=0)
    assert d['achieved']['tilt'] == pytest.approx(math.radians(2), abs=1e-12)
    c = run_json(capsys, 'compensate', '--height', '0.4', '--tilt', '0.02', '--azimuth', '1.0',
                 '--tool', '0.05', '0.0', '0.3')
    assert set(c) >= {'q', 'achieved', 'tool_shift', 'arm_correction'}
    assert set(c['arm_correction']) == {'translation', 'quaternion'}
    assert abs(c['tool_shift'][2]) < 1e-12


def test_mobility_and_sweep_json(capsys, tmp_path):
    m = run_json(capsys, 'mobility', '0.5', '0.5', '0.5')
    assert (m['rank_dphi_dp'], m['rank_augmented']) == (9, 12)
    assert len(m['singular_values']) == 3 and set(m['bounds']) >= {'eq4', 'eq5'}
    m = run_json(capsys, 'mobility', '0.5', '0.501', '0.4995', '--dq', '1e-4', '-2e-4', '5e-5')
    assert m['rank_dphi_dp'] == 11
    b = m['bounds']['for_dq']
    assert b['eq4'][0] <= b['norm_dx'] <= b['eq4'][1]
    csv = tmp_path / 'sweep.csv'
    s = run_json(capsys, 'sweep', '--csv', str(csv))
    assert s['samples'] == 756 and s['singular_crossings'] == 36
    assert s['max_centre_shift'] == pytest.approx(28.41e-6, abs=0.01e-6)
    rows = csv.read_text().splitlines()
    assert len(rows) == 757 and rows[0].startswith('sample,pass,gamma,alpha,q1,q2,q3')
    s = run_json(capsys, 'sweep', '--deg', '--max-tilt', '1', '--tilt-step', '0.5', '--azimuth-step', '90')
    assert s['samples'] == 4 * 5


def test_human_readable_output(capsys):
    status, out, _ = run(capsys, 'sweep')
    assert status == 0 and 'max centre shift' in out and '756 samples' in out
    # README.md's sample output is this output; the residuals' last digits are rounding (any below 1e-14 m)
    readme = (Path(__file__).resolve().parents[1] / 'README.md').read_text(encoding='utf-8').splitlines()
    k = next(i for i, ln in enumerate(readme) if ln.startswith('$ gpr sweep '))
    quoted = readme[k + 1:readme.index('```', k)]
    residuals = re.compile(r'residual +(\S+) m, rigid fit (\S+) m')
    assert all(float(v) < 1e-14 for v in residuals.search(out).groups())
    assert [residuals.sub('R', ln) for ln in quoted] == [residuals.sub('R', ln) for ln in out.splitlines()]
    status, out, _ = run(capsys, 'fk', '0.3', '0.3', '0.3')
    assert status == 0 and 'tilt          0 rad' in out


@pytest.mark.parametrize('argv, pattern', [
    (['fk', '0.5', 'nan', '0.5'], 'q2 = nan is not a finite number'),
    # it said "the following arguments are required: Q" for two rods, "unrecognized arguments" for four
    (['fk', '0.5', '0.503'],
     r"^gpr fk: error: three rod lengths q1 q2 q3 are needed \[m, or mm with --mm\]; got 2: '0.5 0.503'$"),
    (['fk'], r'^gpr fk: error: three rod lengths q1 q2 q3 are needed \[m, or mm with --mm\]; got 0$'),
    (['fk', '0.5', '0.5', '0.5', '0.5'], r"three rod lengths q1 q2 q3 are needed .*; got 4: '0.5 0.5 0.5 0.5'$"),
    (['mobility', '0.5', '0.5', '--dq', '0', '0', '0'], r'^gpr mobility: error: three rod lengths q1 q2 q3 are '
                                                        r'needed \[m, or mm with --mm\]; got 2'),
    (['fk', '0.5', '0.5', 'abc'], r"argument Q: invalid float value: 'abc'; allowed: a decimal number of ASCII "
                                  r'digits \(e\.g\. 0\.5, -2, 1e-3\)$'),
    (['fk', '0.5', '0.5', '\u0660.5'], r"invalid float value: '\u0660.5'; allowed: a decimal number of ASCII digits"),
    (['fk', '0.5', '0.5', 'x' * 5000], r"invalid float value: 'x{59}\.\.\. \(5000 characters\); allowed: a decimal "),
    (['sweep', '--passes', 'x'], r"argument --passes: invalid int value: 'x'; allowed: a whole number of ASCII "
                                 r'digits \(e\.g\. 10\)$'),
    # a decimal comma where the command converts the values itself: a traceback (argparse's error escaped)
    (['verify', 'BAG', '--tolerance', '0,5'], r"--tolerance '0,5': the value must be a finite number \(SI units\)"),
    (['dexterity', 'GSP', '--vary', 'z', '0,1', '0.2', '5'], r'--vary takes NAME MIN MAX COUNT'),
    (['accuracy', 'GSP', '--pose', '0', '0', '0.3', '0', '0', '0', '--parameter-error', 'A_i', '0,5'],
     r"--parameter-error A_i: values must be numbers; got \['0,5'\]$"),
    (['fk', '0,5', '0.5', '0.5'], r"argument Q: invalid float value: '0,5' \(a decimal comma: write a decimal point, "
                                  r'0.5\)$'),
    (['robot', 'ik', '--position', '1300,5', '600', '450', '--mm'],
     r"argument --position: invalid float value: '1300,5' \(a decimal comma: write a decimal point, 1300.5\)$"),
    # rods in millimetres given as metres: the hint where mm would fit, none for a metre value just beyond
    (['fk', '250', '251', '252'],
     r'^gpr fk: error: q1 = 250 m is outside the stroke \[0, 0.508\] m; 250 mm would be within it: millimetres given '
     r'as metres\?$'),
    (['fk', '0.6', '0.5', '0.5'], r'^gpr fk: error: q1 = 0.6 m is outside the stroke \[0, 0.508\] m$'),
    # an option the command does not take: argparse named the top parser ("gpr: error:") and nothing allowed
    (['fk', '0.5', '0.5', '0.5', '--deg'],
     r'^gpr fk: error: unrecognized arguments: --deg; allowed: the options of gpr fk --help$'),
    (['robot', 'ik', '--position', '1', '1', '1', '--bogus', 'x'],
     r'^gpr robot ik: error: unrecognized arguments: --bogus x; allowed: the options of gpr robot ik --help$'),
    # Python's float read 0.4_5 as 0.45 and other scripts' digits (fullwidth 0.５) as numbers; the files refuse them
    (['fk', '0.45', '0.45', '0.4_5'], r"argument Q: invalid float value: '0.4_5'"),
    (['fk', '0.45', '0.45', '0.\uff15'], "argument Q: invalid float value: '0.\uff15'"),
    (['sweep', '--passes', '1_0'], "argument --passes: invalid int value: '1_0'"),
    (['fk', '0.6', '0.5', '0.5'], r'q1 = 0.6 m is outside the stroke'),
    (['fk', '0.3', '0.3', '0.3', '--model', 'rigid'], "invalid choice: 'rigid'"),
    (['ik', '--height', '0.5', '--tilt', '3', '--azimuth', '0', '--deg'], 'beyond the tilt limit'),
    (['ik', '--height', 'abc', '--tilt', '0', '--azimuth', '0'], "invalid float value: 'abc'"),
    (['compensate', '--height', '0.6', '--tilt', '0', '--azimuth', '0'], 'outside the stroke'),
    (['compensate', '--height', '0.3', '--tilt', 'nan', '--azimuth', '0'], r'--tilt = nan is not a finite number'),
    (['compensate', '--height', '0.3', '--tilt', '0', '--azimuth', '0', '--heading', 'inf'], r'--heading = inf'),
    (['sweep', '--tilt-step', '0.3', '--deg'], 'whole number'),
    (['fk', '0.3', '0.3', '0.3', '--config', '/nonexistent.yaml'], 'cannot read config file'),
    (['fk', '0.3', '0.3', '0.3', '--config', ''], 'config file path is empty'),   # was silently ignored
    (['ik', '--height', '500', '--tilt', '0', '--azimuth', '0'], r'height = 500 m puts a rod outside the stroke'),
    (['compensate', '--height', '0.4', '--tilt', '0.01', '--azimuth', '0', '--tool', '300', '0', '100'],
     r'--tool = \(300, 0, 100\) m is beyond the reach of a tool point .*\(gpr_platform\) \(millimetres\? give --mm\)$'),
    (['mobility', '0.5', '0.5', '0.5', '--dq', '1e308', '0', '0', '--json'],
     r'q1 \+ dq1 = 1e\+308 m is outside the stroke'),
    (['sweep', '--height', '-1e308'], r'height = -1e\+308 m puts a rod outside the stroke'),
    (['sweep', '--tilt-step', '1e-12'], r'^gpr sweep: error: --tilt-step = 1e-12 rad; allowed: a step of at least '
                                        r'1e-07 rad$'),
    (['sweep', '--azimuth-step', '0.001', '--deg'], r'--azimuth-step = 0\.001 deg; allowed: a step of at least '
                                                    r'0\.00572958 deg$'),   # named as typed, in the unit typed
    # a value 1000 times too large typed in mm (--mm) is no millimetres given as metres: no such hint
    (['fk', '300000', '300', '300', '--mm'], r'^gpr fk: error: q1 = 300 m is outside the stroke \[0, 0\.508\] m '
                                             r'\(300000 mm as typed; the stroke is \[0, 508\] mm\)$'),   # as typed
    (['ik', '--height', '500000', '--tilt', '0', '--azimuth', '0', '--mm'],
     r'^gpr ik: error: height = 500 m \(500000 mm\) puts a rod .* at the tilt 0 rad; allowed heights: 0 \.\. 0\.508 m '
     r'\(0 \.\. 508 mm\)$'),   # in the unit typed too, the allowed heights in both
    (['fk', '300', '0.3', '0.3'], r'q1 = 300 m is outside the stroke \[0, 0\.508\] m; 300 mm would be within it: '
                                  r'millimetres given as metres\?$'),
    (['sweep', '--passes', '1001'], r'^gpr sweep: error: --passes = 1001; allowed: an integer from 1 to 1000$'),
    (['sweep', '--tilt-step', '1e-7'], r'allowed: a sweep of at most 200000 samples'),
    (['sweep', '--csv', ''], 'CSV output path is empty'),
    (['sweep', '--csv', 'victim.yaml'], r"^gpr sweep: error: --csv 'victim.yaml' has another suffix; allowed: a .csv "
                                        r'file$'),   # it overwrote a YAML file with the sweep's rows
])
def test_bad_input_exits_2_with_one_line(capsys, argv, pattern):
    from gpr_kinematics.inputs.resources import config_path
    files = {'BAG': str(Path(__file__).resolve().parents[1] / 'bags' / 'reference_sweep'),
             'GSP': str(config_path('mechanisms/gsp_d3_6.yaml'))}
    status, out, err = run(capsys, *(files.get(a, a) for a in argv))
    assert status == 2 and out == ''
    assert err.count('\n') == 1 and re.search(pattern, err.strip()), err
    assert 'Traceback' not in err


@pytest.mark.parametrize('argv, pattern', [
    # degrees typed as radians (40 deg meant) and a meaningless 1e300 used to run, wrapped
    (['ik', '--height', '0.5', '--tilt', '0.02', '--azimuth', '40'],
     r'^gpr ik: error: --azimuth = 40 rad is outside \[-2pi, 2pi\] rad; allowed: an angle in radians \(give --deg '
     r'for degrees\)$'),
    (['ik', '--height', '0.5', '--tilt', '0.02', '--azimuth', '1e300'], r'--azimuth = 1e\+300 rad is outside'),
    (['ik', '--height', '0.5', '--tilt', '0.02', '--azimuth', '-6.3'], r'--azimuth = -6.3 rad is outside'),
    (['ik', '--height', '0.5', '--tilt', '1', '--azimuth', '400', '--deg'],
     r'--azimuth = 400 deg is outside \[-360, 360\] deg; allowed: an angle of at most one turn'),
    (['compensate', '--height', '0.4', '--tilt', '0.02', '--azimuth', '40'], r'--azimuth = 40 rad is outside'),
    (['compensate', '--height', '0.4', '--tilt', '0.02', '--azimuth', '1', '--heading', '20'],
     r'--heading = 20 rad is outside \[-2pi, 2pi\] rad; allowed: an angle in radians \(give --deg'),
])
def test_directions_beyond_one_turn_are_refused(capsys, argv, pattern):
    status, out, err = run(capsys, *argv)
    assert status == 2 and out == ''
    assert err.count('\n') == 1 and re.search(pattern, err.strip()), err


def test_directions_within_one_turn_are_taken(capsys):
    a = run_json(capsys, 'ik', '--height', '0.5', '--tilt', '0.02', '--azimuth', '-6.2')
    b = run_json(capsys, 'ik', '--height', '0.5', '--tilt', '0.02', '--azimuth', str(2 * math.pi - 6.2))
    assert np.allclose(a['q'], b['q'], atol=1e-12)
    run_json(capsys, 'ik', '--height', '0.5', '--tilt', '1', '--azimuth', '-360', '--deg')
    run_json(capsys, 'compensate', '--height', '0.4', '--tilt', '1', '--azimuth', '350', '--heading', '-300', '--deg')


def test_malformed_config_file(capsys, tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('radius: -1\n')
    status, out, err = run(capsys, 'fk', '0.3', '0.3', '0.3', '--config', str(bad))
    assert status == 2 and 'radius = -1 is invalid' in err and err.count('\n') == 1


def test_console_script_runs_without_traceback():
    """The installed entry point and ``python -m`` behave like main(): status 2, one line, no traceback."""
    gpr = Path(sys.executable).with_name('gpr')
    cmd = [str(gpr)] if gpr.exists() else [sys.executable, '-m', 'gpr_kinematics.cli.main']
    ok = subprocess.run(cmd + ['fk', '0.3', '0.3', '0.3', '--json'], capture_output=True, text=True, timeout=60)
    assert ok.returncode == 0 and json.loads(ok.stdout)['tilt'] == 0.0
    bad = subprocess.run(cmd + ['fk', '0.3', 'inf', '0.3'], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and bad.stderr == ('gpr fk: error: q2 = inf is not a finite number; allowed: finite '
                                                  'values in SI units\n')


def test_a_closed_stderr_or_stdout_changes_nothing_but_what_is_seen():
    """``gpr ... 2>&-`` and ``>&-`` (Python then has no ``sys.stderr``/``sys.stdout``): a bad input still exits 2, a
    good one 0; the error line or the result is dropped, never an AttributeError's status 1."""
    cmd = [sys.executable, '-m', 'gpr_kinematics']
    for fd in (1, 2):
        for argv, status in ((['fk', '0.3', 'inf', '0.3'], 2), (['fk', '0.3', '0.3', '0.3'], 0)):
            res = subprocess.run(cmd + argv, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60,
                                 preexec_fn=lambda fd=fd: os.close(fd))
            assert res.returncode == status, (fd, argv, res.returncode)


def test_an_ascii_locale_writes_what_it_cannot_encode_as_escapes(tmp_path):
    """Under an ASCII locale (PYTHONIOENCODING=ascii as an ASCII LC_ALL gives it) ``gpr sweep``, ``gpr mobility``
    and their --help ended in a UnicodeEncodeError traceback on the section sign of the paper's reference, as did an
    output path with an umlaut echoed; now the sign is written as a backslash escape, the rest as before."""
    env = dict(os.environ, PYTHONIOENCODING='ascii')
    cmd = [sys.executable, '-m', 'gpr_kinematics']
    for argv in (['mobility', '0.5', '0.5', '0.5'], ['mobility', '--help'], ['sweep', '--help']):
        res = subprocess.run(cmd + argv, env=env, capture_output=True, text=True, timeout=60)
        assert res.returncode == 0 and 'Traceback' not in res.stderr, (argv, res.stderr)
        assert '\\xa7' in res.stdout, argv        # the section sign, escaped
    out = tmp_path / 'w\u00fc.csv'
    res = subprocess.run(cmd + ['program', 'export', 'example_robot_program.yaml', '--waypoints', str(out)], env=env,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and 'Traceback' not in res.stderr, res.stderr
    assert out.exists() and 'w\\xfc.csv' in res.stdout


def test_out_of_memory_is_one_line_and_status_2(capsys, monkeypatch):
    """numpy's MemoryError (a 20,000-row calibration under a 650 MB limit) was a traceback; now one line naming
    it, status 2."""
    import gpr_kinematics.core

    def exhausted(*args, **kwargs):
        raise MemoryError('Unable to allocate 7.45 GiB for an array with shape (1000000000,) and data type float64')
    monkeypatch.setattr(gpr_kinematics.core, 'forward', exhausted)
    status, out, err = run(capsys, 'fk', '0.3', '0.3', '0.3')
    assert status == 2 and out == ''
    assert err == ('gpr fk: error: out of memory: Unable to allocate 7.45 GiB for an array with shape (1000000000,) '
                   'and data type float64; allowed: inputs this machine has the memory for (fewer rows or samples, '
                   'coarser settings)\n')


@pytest.mark.parametrize('stop, status, word', [(KeyboardInterrupt, 130, 'interrupted'),
                                                 ('terminated', 143, 'terminated')])
def test_a_signal_raised_while_a_value_is_converted_is_a_stop_not_a_traceback(capsys, monkeypatch, stop, status,
                                                                             word):
    """The handler's KeyboardInterrupt (or SIGTERM's) raised while pybind11 converts a value (rclpy's messages, in
    `gpr program send`) reaches the command as a TypeError from it: a traceback, exit 1. It ends as the signal's
    stop; any other TypeError is no stop."""
    import gpr_kinematics.cli.main as cli_main
    signal_exc = cli_main._Terminated() if stop == 'terminated' else stop()

    def converting(args):
        raise TypeError('Unable to convert function return value to a Python type!') from signal_exc
    parser = cli_main.build_parser()
    fk = parser._subparsers._group_actions[0].choices['fk']
    monkeypatch.setattr(cli_main, 'build_parser', lambda *args, **kwargs: parser)
    monkeypatch.setattr(fk, '_defaults', {**fk._defaults, 'handler': converting})
    assert main(['fk', '0.3', '0.3', '0.3']) == status
    assert capsys.readouterr() == ('', f'gpr fk: {word}\n')

    def failing(args):
        raise TypeError('a bug')
    monkeypatch.setattr(fk, '_defaults', {**fk._defaults, 'handler': failing})
    with pytest.raises(TypeError, match='a bug'):
        main(['fk', '0.3', '0.3', '0.3'])


def test_ctrl_c_while_the_command_line_loads_is_interrupted_not_a_traceback(capsys, monkeypatch):
    """Ctrl-C in the first tenths of a second (numpy and the command's modules loading, before its own handler)
    printed a KeyboardInterrupt traceback through the imports; now ``gpr: interrupted``, status 130, from the console
    script's import of the command line and from the parser's import of a command's module."""
    import importlib.abc

    import gpr_kinematics.cli.main as cli_main
    from gpr_kinematics.cli import entry

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(cli_main, 'build_parser', interrupted)
    assert main(['fk', '0.3', '0.3', '0.3']) == 130
    assert capsys.readouterr() == ('', 'gpr: interrupted\n')

    class Interrupting(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name == 'gpr_kinematics.cli.main':
                raise KeyboardInterrupt
            return None
    monkeypatch.delitem(sys.modules, 'gpr_kinematics.cli.main')
    monkeypatch.setattr(sys, 'meta_path', [Interrupting(), *sys.meta_path])
    assert entry.main() == 130
    assert capsys.readouterr() == ('', 'gpr: interrupted\n')


def test_outputs_that_are_not_regular_files_are_refused_before_the_work(capsys, tmp_path):
    """``--csv PATH`` replaced whatever was at PATH through a rename, device nodes included (as root)."""
    link = tmp_path / 'null.csv'
    link.symlink_to('/dev/null')
    os.mkfifo(tmp_path / 'fifo.csv')
    (tmp_path / 'dir.csv').mkdir()
    for name, kind in (('null.csv', 'a symbolic link'), ('fifo.csv', 'a FIFO'), ('dir.csv', 'a directory')):
        status, out, err = run(capsys, 'sweep', '--csv', str(tmp_path / name))
        assert status == 2 and out == '' and f'{name} exists and is not a regular file (it is {kind})' in err
    assert link.is_symlink() and stat.S_ISCHR(os.stat('/dev/null').st_mode)
    status, out, err = run(capsys, 'sweep', '--csv', str(tmp_path / 'no' / 'x.csv'))
    assert status == 2 and "the folder" in err and 'does not exist' in err
    status, out, _ = run(capsys, 'sweep', '--csv', str(tmp_path / 'ok.csv'))
    assert status == 0 and f'samples written to {tmp_path / "ok.csv"}' in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ['dir.csv', 'fifo.csv', 'null.csv', 'ok.csv']


def test_mobility_names_the_first_order_and_gives_the_full_solve(capsys):
    status, out, err = run(capsys, 'mobility', '0.5', '0.5', '0.5', '--dq', '1e-4', '-1e-4', '0')
    assert status == 0 and err == ''
    assert 'singular configuration: yes' in out
    assert 'first order |dX/dP dP| = 0.000000e+00 m (eq. 3)' in out and 'full solve |X(q + dq) - X(q)| = 1.0727' in out
    assert re.search(r'eq\. 5 \[\S+, \S+\] m; full solve \|X\(q \+ dq\) - X\(q\)\| = 1\.072754e-07 m ', out)
    # the polar model's virtual joints are lengths and angles: the norm's unit says so
    status, out, _ = run(capsys, 'mobility', '0.5', '0.503', '0.498', '--dq', '1e-4', '0', '0', '--model', 'polar')
    assert status == 0 and re.search(r'first order \|dX/dP dP\| = 1\.371122e-05 m\|rad \(eq\. 3\), eq\. 4 \[\S+, '
                                     r'\S+\] m\|rad, eq\. 5 \[\S+, \S+\] m\|rad; full solve \|X\(q \+ dq\) - '
                                     r'X\(q\)\| = 1\.369147e-05 m\|rad$', out.strip())
    b = run_json(capsys, 'mobility', '0.5', '0.5', '0.5', '--dq', '1e-4', '-1e-4', '0')['bounds']['for_dq']
    assert b['norm_dx'] == 0.0 and b['norm_dx_full'] == pytest.approx(1.0727e-7, rel=1e-4)


def test_a_long_negative_number_is_decided_at_once(capsys):
    """argparse's rule for an argument that looks like a negative number split a run of digits n ways
    (``\\d+\\.?\\d*``): 20,000 digits and an x took seconds before its refusal; one reading now."""
    import time
    start = time.process_time()
    status, out, err = run(capsys, 'fk', '0.45', '0.45', '-' + '1' * 20000 + 'x')
    assert status == 2 and 'Traceback' not in err and err.count('\n') == 1
    assert time.process_time() - start < 1.0


@pytest.mark.parametrize('typed', ['1e400', '-' + '9' * 400])
def test_digits_beyond_the_largest_float_are_named_as_typed(capsys, typed):
    """A number typed beyond the largest float was refused as 'q1 = inf is not a finite number', which the user
    never typed; it is named as typed now (the word inf still reads as inf, refused by name later)."""
    status, _, err = run(capsys, 'fk', typed, '0.5', '0.5')
    assert status == 2 and err.count('\n') == 1 and '(beyond the largest float, 1.8e308)' in err, err
    assert ' inf ' not in err
    status, _, err = run(capsys, 'fk', 'inf', '0.5', '0.5')
    assert status == 2 and err.endswith('q1 = inf is not a finite number; allowed: finite values in SI units\n'), err


def test_a_long_error_line_loses_only_what_is_over_the_limit():
    """errors.one_line: a line of LONG_LINE + 12 characters keeps LONG_LINE - len(mark) of them, its start and its
    last quarter; a line at the limit is kept whole."""
    from gpr_kinematics.errors import LONG_LINE, one_line
    words = ' '.join(f'w{k:04d}' for k in range(400))  # 6 characters per word with its space
    exact = words[:LONG_LINE]
    assert one_line(exact) == exact
    longer = words[:LONG_LINE + 12]
    cut = one_line(longer)
    mark = f' ... ({LONG_LINE + 12} characters) ... '
    assert len(cut) == LONG_LINE and mark in cut
    head, tail = cut.split(mark)
    assert longer.startswith(head) and longer.endswith(tail) and len(tail) == LONG_LINE // 4
    assert len(head) + len(tail) == LONG_LINE - len(mark)


class _FullDisk(io.StringIO):
    """A standard output on a full disk: every write fails as a write to one does."""

    def write(self, text):
        raise OSError(errno.ENOSPC, 'No space left on device')

    def flush(self):
        raise OSError(errno.ENOSPC, 'No space left on device')


@pytest.mark.parametrize('argv', [['fk', '0.1', '0.1', '0.1', '--json'], ['fk', '0.1', '0.1', '0.1'], ['sweep']])
def test_a_standard_output_that_cannot_be_written_is_one_line_and_status_2(capsys, monkeypatch, argv):
    """`gpr fk --json > /dev/full` ended in a traceback (OSError from emit_json) with status 1; a command that
    prints without flushing would have failed at the interpreter's exit."""
    monkeypatch.setattr(sys, 'stdout', _FullDisk())
    assert main(argv) == 2
    assert capsys.readouterr().err == (f'gpr {argv[0]}: error: cannot write the standard output: No space left on '
                                       'device; allowed: an output with room for it\n')


class _FullDiskNamed(io.StringIO):
    """An output whose OSError names its file (exc.filename): a handler's write to 'out.csv' on a full disk."""

    def write(self, text):
        raise OSError(errno.ENOSPC, 'No space left on device', 'out.csv')


def test_a_write_that_fails_on_a_named_file_names_that_file(capsys, monkeypatch):
    """The OSError branch of main: with exc.filename set the message names the file, not the standard output."""
    monkeypatch.setattr(sys, 'stdout', _FullDiskNamed())
    assert main(['fk', '0.1', '0.1', '0.1']) == 2
    assert capsys.readouterr().err == ("gpr fk: error: cannot write 'out.csv': No space left on device; allowed: an "
                                       'output with room for it\n')


@pytest.mark.parametrize('err,name,words', [
    (errno.EACCES, 'secret.yaml', "cannot read 'secret.yaml': Permission denied; allowed: a file or folder this "
     'user can read'),
    (errno.EACCES, 'out.csv', "cannot write 'out.csv': Permission denied; allowed: an output with room for it"),
    (errno.EACCES, 'rep/verify.json', "cannot write 'rep/verify.json': Permission denied; allowed: an output with "
     'room for it'),                                       # in the --report folder: a write
    (errno.ENOSPC, 'elsewhere.db3', "cannot write 'elsewhere.db3': No space left on device; allowed: an output "
     'with room for it'),                                  # a write's error
])
def test_an_os_error_no_handler_named_is_a_read_unless_it_is_a_write(err, name, words):
    """main's last resort tells a read from a write: the error's kind, or the file one of the command's outputs."""
    from gpr_kinematics.cli.main import os_error

    args = argparse.Namespace(csv='out.csv', report='rep', output=None, config='secret.yaml')
    assert os_error(OSError(err, os.strerror(err), name), args) == words


def test_a_name_too_long_met_reading_is_named_a_read_cut(capsys, monkeypatch):
    """An OSError of a read no handler named (bags.reader.locate's Path.exists raised ENAMETOOLONG): it was
    "cannot write" the 300 characters whole."""
    from gpr_kinematics.core import config

    def stray(path, *args, **kwargs):
        if len(str(path)) > 255:
            raise OSError(errno.ENAMETOOLONG, 'File name too long', str(path))
        return read_yaml(path, *args, **kwargs)

    read_yaml = config.read_yaml
    monkeypatch.setattr(config, 'read_yaml', stray)
    assert main(['sweep', '--config', 'x' * 300]) == 2
    assert capsys.readouterr().err == (f"gpr sweep: error: cannot read '{'x' * 119}... (300 characters): File name too "
                                       'long; allowed: a path whose names have at most 255 bytes each, 4096 in all\n')


def test_a_files_millimetres_hint_stays_under_a_mm_that_converts_only_options(capsys, tmp_path):
    """gpr accuracy's --mm converts --tool only: a platform program's height of 300 (mm meant) keeps its hint under
    it (every command with --mm dropped it); gpr ik's --mm converts every length it takes: no hint there."""
    from gpr_kinematics.inputs.resources import config_path
    program = tmp_path / 'p.yaml'
    program.write_text(config_path('programs/example_stations.yaml').read_text().replace('height: 0.30', 'height: 300'))
    status, _, err = run(capsys, 'accuracy', str(program), '--tolerances', 'tolerances_example.yaml', '--tool', '0',
                         '0', '10', '--mm')
    assert status == 2 and err.rstrip().endswith('as millimetres it would be within them: millimetres given as '
                                                 'metres?'), err
    status, _, err = run(capsys, 'ik', '--height', '300000', '--tilt', '0', '--azimuth', '0', '--mm')
    assert status == 2 and 'millimetres given as metres' not in err, err


@pytest.mark.parametrize('argv, named', [
    (('ik', '--height', '0.5', '--tilt', '0', '--azimuth', '0', '--tool', '0', '0', '0.1', '--to', '0.3', '0', '0.1'),
     'gpr ik: error: --tool given 2 times (--tool, --to)'),
    (('ik', '--height', '0.5', '--height=0.4', '--tilt', '0', '--azimuth', '0'),
     'gpr ik: error: --height given 2 times (--height, --height)'),
    (('robot', 'ik', '--position', '1.3', '0.6', '0.6', '--heading', '0.3', '--heading', '0.2'),
     'gpr robot ik: error: --heading given 2 times (--heading, --heading)'),
])
def test_an_option_that_takes_values_given_twice_is_refused(capsys, argv, named):
    """argparse kept the last of a repeated option without a word (a second --tool replaced the first, an
    abbreviation too): refused now, naming both as typed; options that add up and flags may repeat."""
    status, out, err = run(capsys, *argv)
    assert (status, out) == (2, '') and err == f'{named}: the last would replace the others; allowed: each option ' \
                                               'that takes values once\n', err
    assert run_json(capsys, 'ik', '--height', '0.5', '--tilt', '0', '--azimuth', '0', '--json')['q'] == [0.5] * 3


def test_compensate_describes_its_own_height_and_tool(capsys):
    """compensate shared ik's help: '--height: height of the platform point', '--tool: ... whose height is
    prescribed', where its --height is the commanded origin's (a tool at z 0.1 m reaches 0.5 m for --height 0.4)."""
    helps = {}
    for command in ('ik', 'compensate'):
        assert main([command, '--help']) == 0
        helps[command] = ' '.join(capsys.readouterr().out.split())
    assert 'commanded height of the platform origin' in helps['compensate']
    assert 'whose height is prescribed' not in helps['compensate']
    assert 'height of the platform point' in helps['ik'] and 'whose height is prescribed' in helps['ik']
    assert main(['compensate', '--height', '0.4', '--tilt', '0', '--azimuth', '0', '--tool', '0', '0', '0.1',
                 '--json']) == 0
    out = json.loads(capsys.readouterr().out)
    assert out['tool_achieved'][2] == pytest.approx(0.5, abs=1e-12)


@pytest.mark.parametrize('argv', [['workspace', 'tripod_3rps.yaml', '--delta', '4', '--mm', '--boxes', 'b.npz',
                                   '--no-progress'],
                                  ['workspace', 'tripod_3rps.yaml', '--delta', '4', '--mm', '--boxes', 'b.npz',
                                   '--no-progress', '--json']])
def test_a_reader_that_leaves_early_leaves_the_commands_outputs(tmp_path, argv):
    """``gpr workspace ... --boxes b.npz | true``: the summary's BrokenPipeError took back the boxes already written,
    with status 0. The rest of the output goes nowhere, the outputs are kept, status 0, nothing on stderr."""
    proc = subprocess.Popen([sys.executable, '-m', 'gpr_kinematics', *argv], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    proc.stdout.close()   # the reader gone before the first line
    err = proc.stderr.read()
    assert proc.wait(120) == 0 and err == '', err
    assert (tmp_path / 'b.npz').stat().st_size > 1000


def test_a_warning_into_a_pipe_whose_reader_left_leaves_the_outputs(tmp_path):
    """``gpr workspace upu3.yaml --method grid ... --boxes b.npz 2>&1 | true``: the grid's warning on stderr met the
    closed pipe after the boxes were written and took them back, status 0. Both streams go nowhere then."""
    argv = ['workspace', 'upu3.yaml', '--delta', '0.02', '--method', 'grid', '--no-progress', '--boxes', 'b.npz']
    proc = subprocess.Popen([sys.executable, '-m', 'gpr_kinematics', *argv], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT)
    proc.stdout.close()
    assert proc.wait(120) == 0
    assert (tmp_path / 'b.npz').stat().st_size > 100

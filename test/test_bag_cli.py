"""``gpr verify`` arguments a user gets wrong: report paths, configurations the solver cannot use, JSON of values
that are not finite numbers."""
from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml
from bag_support import REFERENCE, STATE, rewritten, small_sweep, write_bag
from gpr_kinematics.bags.typestore import GPR_TOPICS
from gpr_kinematics.cli import main as cli


def run(*argv: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    status = cli.main(list(argv))
    out = capsys.readouterr()
    return status, out.out, out.err


def _one_line_error(status: int, out: str, err: str, *words: str) -> None:
    assert status == 2 and out == '' and err.count('\n') == 1 and err.startswith('gpr verify: error: '), err
    assert 'Traceback' not in err and all(w in err for w in words), err


def test_report_paths_that_cannot_be_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / 'a_file').write_text('x')
    cases = [('/proc/version', 'exists and is not a folder'), (str(tmp_path / 'a_file'), 'exists and is not a folder'),
             ('/proc/gpr_report/sub', '/proc/gpr_report'), ('', '--report is empty')]
    for path, words in cases:  # (as root, /proc passes the access check, and creating the folder fails)
        _one_line_error(*run('verify', str(REFERENCE), '--report', path, capsys=capsys), words)
    assert not Path('/proc/gpr_report').exists()
    # An existing report file that is not a regular file (a FIFO would block the write, a link write elsewhere).
    rep = tmp_path / 'rep'
    rep.mkdir()
    os.mkfifo(rep / 'verify.json')
    proc = subprocess.run([sys.executable, '-m', 'gpr_kinematics.cli.main', 'verify', str(REFERENCE), '--report',
                           str(rep)],
                          capture_output=True, text=True, timeout=120)
    _one_line_error(proc.returncode, proc.stdout, proc.stderr, 'verify.json exists and is not a regular file')
    (rep / 'verify.json').unlink()
    (rep / 'verify.txt').symlink_to(tmp_path / 'a_file')
    _one_line_error(*run('verify', str(REFERENCE), '--report', str(rep), capsys=capsys), 'verify.txt')
    assert (tmp_path / 'a_file').read_text() == 'x'


def test_a_config_the_solver_cannot_use_is_a_failed_check(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / 'one_step.yaml'
    cfg.write_text('max_iterations: 1\n')
    status, out, err = run('verify', str(REFERENCE), '--config', str(cfg), capsys=capsys)
    assert status == 1 and err == ''
    assert 'FAIL state.forward on /gpr/platform_state at sample 0' in out and 'ConvergenceError' in out
    forward = next(line for line in out.splitlines() if line.startswith('state.forward '))
    assert forward.split()[3] == '756' and forward.endswith('756 failed')  # each sample failed once, here
    # The reference bag's recorded geometry is compared with the given one: the difference named, the pose
    # difference not computable.
    assert ('differs from the recorded geometry in max_iterations (12 recorded, 1 given); pose difference not '
            'computable: ConvergenceError') in out
    _one_line_error(*run('verify', str(REFERENCE), '--config', '', capsys=capsys), '--config is empty')
    _one_line_error(*run('verify', '', capsys=capsys), 'BAG is empty; allowed: a rosbag2 folder')   # not '.'
    _one_line_error(*run('verify', str(REFERENCE), '--config', str(tmp_path / 'none.yaml'), capsys=capsys),
                    'none.yaml')


def _nan_q(topic: str, msg: Any) -> Any:
    if topic == STATE and msg.sample == 3:
        q = msg.q.copy()
        q[0] = math.nan
        msg.q = q
    return msg


def _reject(constant: str) -> float:
    raise AssertionError(f'{constant} in the JSON output')


@pytest.mark.slow
def test_json_of_values_that_are_not_finite(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    src = write_bag(tmp_path / 'src', small_sweep(), dict(GPR_TOPICS))
    bag = rewritten(src, tmp_path / 'nan', _nan_q)
    status, out, err = run('verify', str(bag), '--json', '--report', str(tmp_path / 'rep'), capsys=capsys)
    assert status == 1 and err == ''
    for text in (out, (tmp_path / 'rep' / 'verify.json').read_text()):
        data = json.loads(text, parse_constant=_reject)  # strict JSON: no NaN or Infinity tokens
        values = [f['value'] for c in data['checks'] for f in c['failures']]
        assert 'nan' in values or 'inf' in values
        jump = next(c for c in data['checks'] if c['name'] == 'stream.jump')
        assert jump['worst'] == 'inf' and [f['sample'] for f in jump['failures']] == [3, 4]


def test_metadata_fields_of_the_wrong_type(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for field, value, words in (('message_count', 'many', "message_count = 'many' is invalid; allowed: an integer"),
                                ('message_count', True, 'message_count = True is invalid; allowed: an integer'),
                                ('relative_file_paths', 'x.mcap', 'allowed: a list of file names'),
                                ('storage_identifier', 'rosbag1', 'allowed: mcap or sqlite3'),
                                ('ros_distro', [1, 2], 'ros_distro = [1, 2] is invalid; allowed: a string'),
                                ('ros_distro', 'rolling\x00', "ros_distro = 'rolling\\x00' is invalid; allowed: a ROS "
                                 'distribution name (lowercase letters, digits, _;')):
        bag = tmp_path / f'{field}_{type(value).__name__}'
        shutil.copytree(REFERENCE, bag)
        info = yaml.safe_load((bag / 'metadata.yaml').read_text())
        info['rosbag2_bagfile_information'][field] = value
        (bag / 'metadata.yaml').write_text(yaml.safe_dump(info))
        _one_line_error(*run('verify', str(bag), capsys=capsys), 'unreadable: ', 'metadata.yaml', words)


def test_a_storage_identifier_that_does_not_match_the_files_is_named(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / 'mismatch'
    shutil.copytree(REFERENCE, bag)
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())
    assert info['rosbag2_bagfile_information']['storage_identifier'] == 'mcap'
    info['rosbag2_bagfile_information']['storage_identifier'] = 'sqlite3'
    (bag / 'metadata.yaml').write_text(yaml.safe_dump(info))
    _one_line_error(*run('verify', str(bag), capsys=capsys), 'unreadable: ',
                    "metadata.yaml says storage_identifier sqlite3 but lists 'reference_sweep_0.mcap', an mcap file "
                    'name',
                    'allowed: the identifier of its files (sqlite3 files end in .db3)')


@pytest.mark.parametrize('option, value, allowed', [('--tilt-step-deg', '0', '5.72958e-06 to 15'),
                                                     ('--azimuth-step-deg', 'nan', '0.00572958 to 360')])
def test_the_offline_loop_names_a_sweep_step_in_degrees_before_any_node(capsys, tmp_path, monkeypatch, option, value,
                                                                       allowed):
    """--tilt-step-deg 0 was refused by the trajectory node in radians ('Parameter tilt_step out of range Min: 1e-07,
    Max: 0.2617993877991494') once its nodes had started: the option as typed, its range in degrees, no node."""
    from gpr_kinematics.ros import offline_loop

    started = []
    monkeypatch.setattr(offline_loop, 'NodeProcess', lambda *a, **k: started.append(a))   # would start a node
    status = offline_loop.main(['--output', str(tmp_path / 'bag'), option, value])
    err = capsys.readouterr().err
    assert status == 2 and not started and err == f'offline loop: {option} = {value} deg; allowed: {allowed} deg\n'


def test_the_offline_loop_refuses_zstd_on_sqlite3_before_any_node(capsys, tmp_path, monkeypatch):
    """`python -m gpr_kinematics.ros.offline_loop --storage sqlite3 --compression zstd`: the recorder refused the
    pair at once, and the loop streamed the whole sweep with nothing recording before it said so (about 10 s). Now
    one line, status 2, no node started (the writer's own rule)."""
    from gpr_kinematics.ros import offline_loop

    started = []
    monkeypatch.setattr(offline_loop, 'NodeProcess', lambda *a, **k: started.append(a))   # would start a node
    status = offline_loop.main(['--output', str(tmp_path / 'bag'), '--storage', 'sqlite3', '--compression', 'zstd'])
    err = capsys.readouterr().err
    assert status == 2 and not started and err == (
        "offline loop: compression = 'zstd' needs storage mcap (MCAP chunk compression); storage is 'sqlite3'\n")

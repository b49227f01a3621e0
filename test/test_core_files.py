"""The one bounded reader and the one checked, atomic writer of the package's files (gpr_kinematics.inputs.files), and
the one way a message quotes a user's value (errors.brief)."""
import doctest
import os
import re
import stat
import threading
from pathlib import Path

import pytest
from gpr_kinematics.errors import ConfigError, FileError, InputError, brief
from gpr_kinematics.inputs import files

from gpr_kinematics import errors


def test_doctests():
    assert doctest.testmod(files).failed == 0 and doctest.testmod(errors).failed == 0


def test_file_error_is_both_a_config_and_an_input_error():
    assert issubclass(FileError, ConfigError) and issubclass(FileError, InputError)


def test_read_text_refuses_what_is_not_a_regular_file(tmp_path):
    with pytest.raises(FileError, match=r"cannot read config file '.*missing\.yaml': No such file or directory; "
                                        r"allowed: an existing file this user can read$"):   # it named no rule
        files.read_text(tmp_path / 'missing.yaml', 'config')
    with pytest.raises(FileError, match=r'is not a regular file \(a directory\)'):
        files.read_text(tmp_path, 'config')
    with pytest.raises(FileError, match=r"'/dev/zero' is not a regular file \(a character device\)"):
        files.read_text('/dev/zero', 'config')
    with pytest.raises(FileError, match=r'config file path is empty'):
        files.read_text('', 'config')
    with pytest.raises(FileError, match=r'contains a NUL character'):
        files.read_text('a\0b', 'config')
    fifo = tmp_path / 'fifo'
    os.mkfifo(fifo)
    done: list[str] = []

    def read() -> None:
        try:
            files.read_text(fifo, 'config')
        except FileError as exc:
            done.append(str(exc))

    t = threading.Thread(target=read, daemon=True)
    t.start()
    t.join(5.0)   # no writer ever opens the FIFO: a blocking open would never return
    assert done and 'is not a regular file (a FIFO)' in done[0]


def test_read_text_size_limit_is_exact(tmp_path):
    f = tmp_path / 'f.txt'
    f.write_bytes(b'x' * 100)
    assert files.read_text(f, 'table', 100) == 'x' * 100
    with pytest.raises(FileError, match=r"table file '.*f\.txt' has 100 bytes; allowed: at most 99"):
        files.read_text(f, 'table', 99)


def test_read_text_utf8_names_the_first_bad_byte_and_its_line(tmp_path):
    f = tmp_path / 'latin.csv'
    f.write_bytes('a,b\n1,2\ncaf\xe9\n'.encode('latin-1'))
    with pytest.raises(FileError, match=r"latin\.csv' is not UTF-8 text \(byte 11 is 0xe9\) on line 3"):
        files.read_text(f, 'table')
    f.write_bytes(b'\xef\xbb\xbfa,b\n')  # a byte-order mark is dropped
    assert files.read_text(f, 'table') == 'a,b\n'


@pytest.mark.parametrize('kind', ['directory', 'FIFO', 'symbolic link'])
def test_outputs_that_exist_and_are_not_regular_files_are_refused(tmp_path, kind):
    target = tmp_path / 'out.csv'
    if kind == 'directory':
        target.mkdir()
    elif kind == 'FIFO':
        os.mkfifo(target)
    else:
        target.symlink_to('/dev/null')  # a rename would replace the link; a write would go to the device
    with pytest.raises(FileError, match=rf'out\.csv exists and is not a regular file \(it is a {kind}\)'):
        files.write_text(target, 'x', 'CSV')
    assert sorted(p.name for p in tmp_path.iterdir()) == ['out.csv']   # no temporary file left
    assert stat.S_ISCHR(os.stat('/dev/null').st_mode)


def test_outputs_in_missing_folders_and_empty_paths_are_refused(tmp_path):
    with pytest.raises(FileError, match=r"cannot write CSV file '.*nodir/x\.csv': No such file or directory \(the "
                                        r"folder '.*nodir' does not exist\)"):
        files.check_output(tmp_path / 'nodir' / 'x.csv', 'CSV')
    with pytest.raises(FileError, match=r'CSV output path is empty'):
        files.write_text('', 'x', 'CSV')
    assert files.writable_folder(tmp_path / 'a' / 'b' / 'bag', 'output') == tmp_path
    (tmp_path / 'file').write_text('x')
    with pytest.raises(FileError, match=r"'.*file' is not a folder"):
        files.writable_folder(tmp_path / 'file' / 'bag', 'output')


def test_atomic_output_replaces_a_regular_file_or_leaves_it(tmp_path):
    target = tmp_path / 'out.csv'
    target.write_text('old')
    assert files.write_text(target, 'new\n', 'CSV') == target
    assert target.read_text() == 'new\n' and sorted(p.name for p in tmp_path.iterdir()) == ['out.csv']
    with pytest.raises(RuntimeError), files.atomic_output(target, 'CSV') as fh:
        fh.write('half a file')
        raise RuntimeError('interrupted')
    assert target.read_text() == 'new\n' and sorted(p.name for p in tmp_path.iterdir()) == ['out.csv']
    with files.atomic_output(tmp_path / 'b.png', 'plot', binary=True) as fh:
        fh.write(b'\x89PNG')
    assert (tmp_path / 'b.png').read_bytes() == b'\x89PNG'


def test_a_command_that_fails_takes_back_every_output_it_wrote(tmp_path):
    """All of a command's outputs or none: within command_writes a file replaced gets its old content back, a file
    created is removed and a folder created is removed when the command raises; kept when it ends (no backup
    left behind either way)."""
    replaced, created, folder = tmp_path / 'w.csv', tmp_path / 'new.json', tmp_path / 'report' / 'figs'
    replaced.write_text('old')
    with pytest.raises(FileError, match='second output'), files.command_writes():
        files.write_text(replaced, 'new', 'CSV')
        files.write_text(created, '{}', 'JSON')
        files.write_text(replaced, 'newer', 'CSV')   # the same file twice: the first content comes back
        files.output_folder(folder)
        files.write_text(folder / 'a.png', 'png', 'plot')
        assert replaced.read_text() == 'newer'   # written at once: a later step may read it
        raise FileError('second output')
    assert replaced.read_text() == 'old' and sorted(p.name for p in tmp_path.iterdir()) == ['w.csv']
    with files.command_writes():
        files.write_text(replaced, 'new', 'CSV')
        files.output_folder(folder)
        files.write_text(folder / 'a.png', 'png', 'plot')
    assert replaced.read_text() == 'new' and sorted(p.name for p in tmp_path.iterdir()) == ['report', 'w.csv']
    assert [p.name for p in folder.iterdir()] == ['a.png']


def test_a_file_a_command_removes_comes_back_when_it_fails_and_is_gone_when_it_ends(tmp_path):
    """remove_output (an earlier report's figure the new one does not draw): renamed aside while the command runs,
    put back when it raises (Ctrl-C too), gone when it ends; a folder, a link or a missing file is left alone; a file
    another process wrote at the path meanwhile stays."""
    stale, link, folder = tmp_path / 'old.png', tmp_path / 'link.png', tmp_path / 'dir.png'
    stale.write_text('png of another bag')
    link.symlink_to(stale)
    folder.mkdir()
    for error in (FileError('later output'), KeyboardInterrupt()):
        with pytest.raises(type(error)), files.command_writes():
            for p in (stale, link, folder, tmp_path / 'missing.png'):
                files.remove_output(p)
            assert not stale.exists() and link.is_symlink() and folder.is_dir()
            raise error
        assert stale.read_text() == 'png of another bag'
        assert sorted(p.name for p in tmp_path.iterdir()) == ['dir.png', 'link.png', 'old.png']
    with pytest.raises(FileError, match='later'), files.command_writes():
        files.remove_output(stale)
        stale.write_text('another process')
        raise FileError('later output')
    assert stale.read_text() == 'another process'
    assert sorted(p.name for p in tmp_path.iterdir()) == ['dir.png', 'link.png', 'old.png']
    with files.command_writes():
        files.remove_output(stale)
    assert sorted(p.name for p in tmp_path.iterdir()) == ['dir.png', 'link.png']
    link.unlink()
    (tmp_path / 'outside.png').write_text('x')
    files.remove_output(tmp_path / 'outside.png')   # outside a command: removed at once
    assert sorted(p.name for p in tmp_path.iterdir()) == ['dir.png']


def test_export_that_fails_on_its_second_output_leaves_the_first_as_it_was(tmp_path, monkeypatch, capsys):
    """`gpr program export --waypoints W --samples S` left W written when S could not be (a full disk)."""
    from gpr_kinematics.cli.main import main
    waypoints = tmp_path / 'w.csv'
    waypoints.write_text('old')
    real = files._replace

    def full_on_samples(tmp: Path, target: Path) -> None:
        if target.name == 's.json':
            raise OSError(28, 'No space left on device')
        real(tmp, target)

    monkeypatch.setattr(files, '_replace', full_on_samples)
    assert main(['program', 'export', 'example_cell_program.yaml', '--waypoints', str(waypoints), '--samples',
                 str(tmp_path / 's.json')]) == 2
    assert "cannot write joint table file" in capsys.readouterr().err
    assert waypoints.read_text() == 'old' and sorted(p.name for p in tmp_path.iterdir()) == ['w.csv']


def test_a_full_disk_is_a_file_error_and_leaves_nothing(tmp_path, monkeypatch):
    def full(*args: object) -> None:
        raise OSError(28, 'No space left on device')

    monkeypatch.setattr(os, 'replace', full)
    with pytest.raises(FileError, match=r"cannot write CSV file '.*out\.csv': No space left on device"):
        files.write_text(tmp_path / 'out.csv', 'x', 'CSV')
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_inside_a_command_takes_back_the_outputs_it_wrote(tmp_path):
    """Ctrl-C (a KeyboardInterrupt, not an Exception) after a write: the outputs are taken back too."""
    replaced, created = tmp_path / 'w.csv', tmp_path / 'new.json'
    replaced.write_text('old')
    with pytest.raises(KeyboardInterrupt), files.command_writes():
        files.write_text(replaced, 'new', 'CSV')
        files.write_text(created, '{}', 'JSON')
        raise KeyboardInterrupt
    assert replaced.read_text() == 'old' and sorted(p.name for p in tmp_path.iterdir()) == ['w.csv']


def test_a_replace_that_fails_within_a_command_leaves_no_backup_and_the_old_content(tmp_path, monkeypatch):
    """os.replace failing (a full disk) inside command_writes: the hard link kept as a backup is removed, the target
    keeps its old content and nothing else is left in the folder."""
    target = tmp_path / 'w.csv'
    target.write_text('old')
    real = os.replace

    def full(src: object, dst: object) -> None:
        if str(src).endswith('.tmp'):
            raise OSError(28, 'No space left on device')
        real(src, dst)

    monkeypatch.setattr(os, 'replace', full)
    with pytest.raises(FileError, match=r"cannot write CSV file '.*w\.csv': No space left on device"), \
            files.command_writes():
        files.write_text(target, 'new', 'CSV')
    assert target.read_text() == 'old' and [p.name for p in tmp_path.iterdir()] == ['w.csv']


def test_brief_bounds_every_value():
    assert brief('y' * 10_000).endswith('(10000 characters)') and len(brief('y' * 10_000)) < 100
    assert brief(0.5) == '0.5' and brief(float('nan')) == 'nan'
    assert brief(list(range(10 ** 6))) == '[0, 1, 2, 3, 4, 5, 6, 7, ...]'
    assert brief(10 ** 5000) == '<an integer of about 5001 digits>'   # repr itself refuses > 4300 digits
    assert brief([[[[[1]]]]]) == '[[[[...]]]]'
    assert len(brief({str(i): [i] * 100 for i in range(100)})) < 100
    assert brief(Path('a')) == "PosixPath('a')"


def test_confined_reads_open_only_under_the_allowed_folders(tmp_path):
    """The rule of files a remote client names (issue 18): real paths only, links and .. resolved, refused before
    the file is opened, the path and the rule named, never the content."""
    from gpr_kinematics.inputs.files import confined_reads, read_text

    allowed, outside = tmp_path / 'allowed', tmp_path / 'outside'
    allowed.mkdir()
    outside.mkdir()
    (outside / 'secret.yaml').write_text('token: s3cr3t\n')
    (allowed / 'ok.yaml').write_text('a: 1\n')
    (allowed / 'link.yaml').symlink_to(outside / 'secret.yaml')
    with confined_reads([allowed], 'the folders of a test') as rule:
        assert read_text(allowed / 'ok.yaml', 'program') == 'a: 1\n'
        for name in (outside / 'secret.yaml', allowed / 'link.yaml', allowed / '..' / 'outside' / 'secret.yaml',
                     '/etc/passwd', tmp_path / 'missing.yaml'):
            with pytest.raises(FileError) as info:
                read_text(name, 'program')
            text = str(info.value)
            assert f"program file '{name}' is outside the folders this node reads files from; allowed: a file " \
                   f'under {rule.folders[0]} (the folders of a test)' == text and 's3cr3t' not in text
    assert read_text(outside / 'secret.yaml', 'program') == 'token: s3cr3t\n'   # the rule ends with the block


def test_an_output_may_not_be_a_file_the_command_read(tmp_path):
    from gpr_kinematics.inputs.files import command_reads, read_text, write_text

    src = tmp_path / 'in.yaml'
    src.write_text('a: 1\n')
    with command_reads():
        read_text(src, 'config')
        with pytest.raises(FileError, match="output '.*in.yaml' is a file this command reads; allowed: a file the "
                                            'command does not read'):
            write_text(src, 'b: 2\n', 'calibrated geometry')
        assert write_text(tmp_path / 'out.yaml', 'b: 2\n', 'calibrated geometry').read_text() == 'b: 2\n'
    assert src.read_text() == 'a: 1\n'
    write_text(src, 'c: 3\n', 'config')                     # outside a command: no reads are noted


def _another_process_writes(path: Path, text: str) -> None:
    """What a second command does to ``path``: a new file renamed over it (atomic_output's way)."""
    other = path.with_name(path.name + '.other')
    other.write_text(text)
    os.replace(other, path)


@pytest.mark.parametrize('existed', [False, True])
def test_a_failing_command_leaves_an_output_another_process_wrote_since(tmp_path, existed):
    """A command interrupted after another command replaced its output took that one back: the other's file was
    deleted (or the content before both put back) though the other had said it wrote it."""
    target, mine = tmp_path / 'w.csv', tmp_path / 'mine.json'
    if existed:
        target.write_text('old')
    with pytest.raises(FileError, match=rf"^{re.escape(str(target))} was replaced by another process while this "
                                        r'command ran; left as it is \(this command failed: disk full\); allowed: one '
                                        'command writing an output at a time$'), files.command_writes():
        files.write_text(target, 'A', 'CSV')
        files.write_text(mine, '{}', 'JSON')
        _another_process_writes(target, 'B')
        raise FileError('disk full')
    assert target.read_text() == 'B' and sorted(p.name for p in tmp_path.iterdir()) == ['w.csv']
    with pytest.raises(KeyboardInterrupt), files.command_writes():   # Ctrl-C: left the same way
        files.write_text(target, 'A', 'CSV')
        _another_process_writes(target, 'C')
        raise KeyboardInterrupt
    assert target.read_text() == 'C' and sorted(p.name for p in tmp_path.iterdir()) == ['w.csv']


def test_a_command_whose_output_another_process_replaced_fails_and_takes_back_the_rest(tmp_path):
    """Two commands writing the same pair of files both said they had written it, leaving each file of another
    command. The one that ends to find an output replaced fails naming it and takes back its other outputs."""
    waypoints, samples = tmp_path / 'w.csv', tmp_path / 's.csv'
    samples.write_text('s of B')
    with pytest.raises(FileError, match=rf"^{re.escape(str(waypoints))} was replaced by another process while this "
                                        r"command ran; left as the other process wrote it, this command's other "
                                        'outputs taken back; allowed: one command writing an output at a time$'), \
            files.command_writes():
        files.write_text(waypoints, 'w of A', 'CSV')
        _another_process_writes(waypoints, 'w of B')
        files.write_text(samples, 's of A', 'CSV')
    assert (waypoints.read_text(), samples.read_text()) == ('w of B', 's of B')
    assert sorted(p.name for p in tmp_path.iterdir()) == ['s.csv', 'w.csv']
    # removed rather than replaced: said so, and the command fails all the same (it took a deleted file for its own)
    for failed in (False, True):
        with pytest.raises(FileError) as caught, files.command_writes():
            files.write_text(waypoints, 'w of A', 'CSV')
            files.write_text(samples, 's of A', 'CSV')
            waypoints.unlink()
            if failed:
                raise FileError('disk full')
        assert str(caught.value) == f'{waypoints} was removed by another process while this command ran; ' + (
            'left as it is (this command failed: disk full)' if failed else
            "left as the other process left it, this command's other outputs taken back") + (
            '; allowed: one command writing an output at a time')
        assert not waypoints.exists() and samples.read_text() == 's of B'
    waypoints.write_text('w of B')
    with pytest.raises(FileError, match=rf"^{re.escape(str(samples))} was replaced and {re.escape(str(waypoints))} "
                                        r'was removed by another process while this command ran; left as the other '
                                        'process left it'), files.command_writes():
        files.write_text(waypoints, 'w of A', 'CSV')
        files.write_text(samples, 's of A', 'CSV')
        waypoints.unlink()
        _another_process_writes(samples, 's of C')
    assert samples.read_text() == 's of C'
    with files.command_writes():   # the same file written twice by one command is no clash
        files.write_text(waypoints, '1', 'CSV')
        files.write_text(waypoints, '2', 'CSV')
    assert waypoints.read_text() == '2'


def test_an_output_touched_while_the_command_runs_is_still_its_own(tmp_path):
    """The identity compared the modification time: a ``touch`` (a sync or backup tool) of an output made the command
    fail as if another process had replaced it, and took back its other outputs. The file is told by its inode,
    held open while the command runs (no replacement can reuse the number), and closed when it ends."""
    first, second = tmp_path / 'a.txt', tmp_path / 'b.txt'
    second.write_text('old')
    before = len(os.listdir('/proc/self/fd'))
    with files.command_writes():
        files.write_text(first, 'A', 'text')
        files.write_text(second, 'B', 'text')
        os.utime(first, ns=(0, 0))
        assert len(os.listdir('/proc/self/fd')) == before + 2
    assert (first.read_text(), second.read_text()) == ('A', 'B') and len(os.listdir('/proc/self/fd')) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ['a.txt', 'b.txt']


def _loaders():
    """Every public loader of a user's file, as a function of its path alone."""
    from gpr_kinematics.calibration.arm import read_arm_measurements
    from gpr_kinematics.calibration.measurements import read_measurements
    from gpr_kinematics.calibration.tolerances import load_tolerances
    from gpr_kinematics.core.geometry_covariance import load_covariance
    from gpr_kinematics.robot import load_robot
    from gpr_kinematics.robot.platform_program import load_platform_program
    from gpr_kinematics.robot.program import load_any_program, load_program
    from gpr_kinematics.robot.station_files import load_stations
    from gpr_kinematics.robot.teach import read_joint_table
    from gpr_kinematics.safety.cell import load_cell
    robot = load_robot()
    return {'program': load_program, 'any program': load_any_program, 'platform program': load_platform_program,
            'stations': load_stations, 'joint table': lambda p: read_joint_table(p, robot), 'cell': load_cell,
            'tolerances': load_tolerances, 'measurements': read_measurements,
            'arm measurements': lambda p: read_arm_measurements(p, robot), 'covariance': load_covariance}


@pytest.mark.parametrize('path', [5, None, b'/tmp/x', ''])
def test_every_loader_refuses_a_path_that_is_no_path_naming_it(path):
    """Ten loaders raised a bare TypeError for 5, None or bytes (os.fspath's), and load_stations('') called the
    empty path the folder '.': each names the path and what is allowed, as load_config does."""
    for name, load in _loaders().items():
        with pytest.raises(FileError) as got:
            load(path)
        words = str(got.value)
        assert ('path is empty; allowed: the path of a file' in words if path == '' else
                f'path = {brief(path)}; allowed: a file path (str or Path)' in words), (name, words)


def test_numpy_scalars_are_named_by_their_numbers():
    """numpy 2 writes np.float64(7.0): messages named 'azimuth_step = np.float64(7.0) rad' and 'radius =
    np.float64(-1.0)' where the docs say numpy scalars count as their numbers."""
    import numpy as np
    from gpr_kinematics.core.config import GprConfig
    from gpr_kinematics.core.sweep import paper_sweep

    assert [brief(v) for v in (np.float64(7.0), np.int64(3), np.bool_(True), [np.float32(1.5)])] == \
        ['7.0', '3', 'True', '[1.5]']
    assert brief(np.array([1.0, 2.0])) == 'array([1., 2.])'   # an array stays one
    for call, words in ((lambda: paper_sweep(azimuth_step=np.float64(7.0)), 'azimuth_step = 7.0 rad'),
                        (lambda: paper_sweep(passes=np.int64(0)), 'passes = 0 must be'),
                        (lambda: GprConfig(radius=np.float64(-1.0)), 'radius = -1.0 is invalid')):
        with pytest.raises((InputError, ConfigError)) as got:
            call()
        assert words in str(got.value) and 'np.' not in str(got.value), str(got.value)
    # and a numpy scalar of a right value is taken, not refused in words that print its number ("passes = 2 must be
    # an integer from 1 to 1000")
    from gpr_kinematics.core.sweep import sweep_grid
    for a, b in zip(sweep_grid(passes=np.int64(2), tilt_step=np.float32(0.0078125), max_tilt=np.float32(0.03125)),
                    sweep_grid(passes=2, tilt_step=0.0078125, max_tilt=0.03125), strict=True):
        np.testing.assert_array_equal(a, b)
    assert paper_sweep(height=np.float32(0.5)).height == 0.5


def test_a_folder_that_refuses_the_temporary_file_says_what_is_allowed(tmp_path):
    """An attacker's review: ``--waypoints /proc/self/fd/1.csv`` passed the output's checks (its folder exists) and
    was refused without an 'allowed:' when the temporary file could not be made there."""
    with pytest.raises(FileError, match=r"^cannot write joint table file '/proc/self/fd/1\.csv': .*; allowed: a new "
                       r'file or a regular file to replace, in a folder where files can be created and renamed$'):
        files.write_text('/proc/self/fd/1.csv', 'x', 'joint table')


def test_a_write_that_fails_says_what_would_help(tmp_path, monkeypatch):
    """A review: every failure after the checks read 'allowed: an output with room for it'; a full disk says so, a
    name the temporary file's suffix makes too long says that."""
    long = tmp_path / ('x' * (os.pathconf(tmp_path, 'PC_NAME_MAX') - 4) + '.csv')   # fits; its .PID.tmp does not
    with pytest.raises(FileError, match=r': File name too long; allowed: a shorter file name \(its temporary file adds '
                                        r'\.PID\.tmp\)$'):
        files.write_text(long, 'x', 'CSV')

    def full(*args: object) -> None:
        raise OSError(28, 'No space left on device')

    monkeypatch.setattr(os, 'replace', full)
    with pytest.raises(FileError, match=r'No space left on device; allowed: an output with room for it$'):
        files.write_text(tmp_path / 'out.csv', 'x', 'CSV')

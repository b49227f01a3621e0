"""Bounded YAML reading (gpr_kinematics.inputs.safe_yaml): aliases, nesting, size, encoding and file kinds refused
with a message naming the file; ordinary files read as before."""
from __future__ import annotations

import doctest
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import pytest
from gpr_kinematics.core.config import load_config
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs import safe_yaml
from gpr_kinematics.inputs.schema import read_yaml

BOMB = '\n'.join(['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
                 + [f'{c}: &{c} [{", ".join([f"*{p}"] * 9)}]' for p, c in zip('abcdefgh', 'bcdefghi', strict=True)])


def test_doctests() -> None:
    assert doctest.testmod(safe_yaml).failed == 0


def test_plain_yaml_reads(tmp_path) -> None:
    f = tmp_path / 'c.yaml'
    f.write_text('radius: 0.1\nrod_azimuths: [0.0, 2.0943951023931957, 4.1887902047863905]\nmodel: polar\n')
    assert read_yaml(f) == {'radius': 0.1, 'rod_azimuths': [0.0, 2.0943951023931957, 4.1887902047863905],
                            'model': 'polar'}
    cfg = load_config(f)
    assert cfg.radius == 0.1 and cfg.model == 'polar'


def test_alias_bomb_refused_at_once(tmp_path) -> None:
    f = tmp_path / 'bomb.yaml'
    f.write_text(BOMB)
    assert len(BOMB) < 600
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match=r'bomb\.yaml: line 2: YAML aliases'):
        read_yaml(f)
    assert time.perf_counter() - t0 < 1.0  # refused while composing, before any expansion


def test_alias_bomb_in_cli_is_bounded(tmp_path) -> None:
    """The whole `gpr fk --config bomb.yaml` under a 1 GiB address-space limit: exit 2, one line."""
    f = tmp_path / 'bomb.yaml'
    f.write_text(BOMB)

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))

    out = subprocess.run([sys.executable, '-m', 'gpr_kinematics.cli.main', 'fk', '0.5', '0.5', '0.5', '--config',
                          str(f)],
                         capture_output=True, text=True, timeout=60, preexec_fn=limit)
    assert out.returncode == 2
    assert out.stderr.count('\n') == 1 and 'YAML aliases' in out.stderr and 'Traceback' not in out.stderr


@pytest.mark.parametrize('text', ['a: ' + '[' * 20000 + ']' * 20000,
                                  'a:\n' + ''.join('  ' * i + 'k:\n' for i in range(1, 3000)),
                                  'a: ' + '{b: ' * 5000 + '1' + '}' * 5000])
def test_deep_nesting_refused(tmp_path, text: str) -> None:
    f = tmp_path / 'deep.yaml'
    f.write_text(text)
    with pytest.raises(ConfigError, match=r'deep\.yaml.*(nested deeper than 64|nested too deeply)'):
        read_yaml(f)


def test_depth_limit_is_exact() -> None:
    ok = 'a: ' + '[' * (safe_yaml.MAX_DEPTH - 1) + ']' * (safe_yaml.MAX_DEPTH - 1)  # mapping + 63 lists = 64
    assert safe_yaml.load_text(ok) is not None
    with pytest.raises(ConfigError, match='nested deeper than 64'):
        safe_yaml.load_text('a: ' + '[' * safe_yaml.MAX_DEPTH + ']' * safe_yaml.MAX_DEPTH)


def test_not_utf8_names_the_byte(tmp_path) -> None:
    f = tmp_path / 'bad.yaml'
    f.write_bytes(b'radius: 0.1\nmodel: \xff\n')
    with pytest.raises(ConfigError, match=r"bad\.yaml' is not UTF-8 text \(byte 19 is 0xff\)"):
        read_yaml(f)


def test_non_regular_files_refused_without_blocking(tmp_path) -> None:
    fifo = tmp_path / 'fifo.yaml'
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match='not a regular file'):
        read_yaml(fifo)  # would block forever if opened
    with pytest.raises(ConfigError, match='not a regular file'):
        read_yaml(tmp_path)


def test_size_limit(tmp_path) -> None:
    f = tmp_path / 'big.yaml'
    with open(f, 'wb') as fh:
        fh.truncate(safe_yaml.MAX_BYTES + 1)
    n = safe_yaml.MAX_BYTES
    with pytest.raises(ConfigError, match=f'has {n + 1} bytes; allowed: at most {n}'):
        read_yaml(f)


def test_missing_file_and_invalid_yaml(tmp_path) -> None:
    with pytest.raises(ConfigError, match="cannot read config file .*nope.yaml'.*No such file"):
        read_yaml(tmp_path / 'nope.yaml')
    f = tmp_path / 'x.yaml'
    f.write_text('a: [1, 2\n')
    with pytest.raises(ConfigError, match=r'x\.yaml: not valid YAML'):
        read_yaml(f)
    f.write_bytes(b'a: 1\x00\n')  # UTF-8, but a character YAML does not allow
    with pytest.raises(ConfigError, match=r'x\.yaml: not valid YAML \(unacceptable character #x0000'):
        read_yaml(f)


def test_brief_cuts_long_values() -> None:
    s = safe_yaml.brief('y' * 10_000)
    assert len(s) < 100 and s.endswith('(10002 characters)')
    assert safe_yaml.brief(0.5) == '0.5'


def test_the_number_of_values_is_bounded(monkeypatch) -> None:
    """Memory and time grow with the values composed (0.7 kB and 35 us each in PyYAML), not with the bytes:
    2 MiB of ``[1,1,1,...]`` took 0.7 GB. The count is checked as the values are composed."""
    assert safe_yaml.MAX_NODES == 200_000
    monkeypatch.setattr(safe_yaml, 'MAX_NODES', 1000)
    ok = 'a: [' + '1, ' * 997 + '1]'           # the mapping, its key, the list and 998 items: 1001 values
    with pytest.raises(ConfigError, match=r'x\.yaml: line 1: more than 1000 YAML values; allowed: at most 1000'):
        safe_yaml.load_text(ok, 'x.yaml')
    assert len(safe_yaml.load_text('a: [' + '1, ' * 996 + '1]')['a']) == 997   # exactly 1000 values


def test_exponent_numbers_without_a_point_are_floats(tmp_path) -> None:
    # YAML 1.2 reads 13e-2 as a number; PyYAML (YAML 1.1) as text, which the number rule refused with a puzzling
    # "got '13e-2'". The bound on every number still holds, and quoted text stays text.
    assert safe_yaml.load_text('a: [13e-2, -2E+6, +5e-1, 1.5e3, .5e1, "1e3", 1e, 12, 1.5]') == {
        'a': [0.13, -2e6, 0.5, 1500.0, 5.0, '1e3', '1e', 12, 1.5]}
    base = (Path(__file__).resolve().parents[1] / 'gpr_kinematics' / 'config' / 'gpr.yaml').read_text(encoding='utf-8')
    f = tmp_path / 'g.yaml'
    f.write_text(base.replace('radius: 0.093218', 'radius: 93218e-6'), encoding='utf-8')
    assert load_config(f).radius == pytest.approx(0.093218, abs=1e-15)
    f.write_text(base.replace('radius: 0.093218', 'radius: 1e300'), encoding='utf-8')
    with pytest.raises(ConfigError, match=r'radius = 1e\+300 is invalid; allowed: metres'):
        load_config(f)

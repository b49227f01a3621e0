"""Bounded YAML reading (gpr_kinematics.inputs.safe_yaml): aliases, nesting, size, encoding and file kinds refused
with a message naming the file; ordinary files read as before."""
from __future__ import annotations

import doctest
import math
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
        read_yaml(f, 'program')


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
        read_yaml(f, 'program')


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


@pytest.mark.parametrize('c_loader', [True, False])
def test_a_syntax_error_names_its_line_and_column(tmp_path, monkeypatch, c_loader) -> None:
    """A mis-indented key of a program (line 4, column 4), an unclosed list and a tab: PyYAML's place and words
    in one line, with the C parser and the Python one (their words differ; the message kept only PyYAML's first
    line, 'while parsing a block collection', and lost the place)."""
    if not c_loader:
        monkeypatch.setattr(safe_yaml, '_CLoader', None)
    f = tmp_path / 'x.yaml'
    for text, where in (('format: gpr_robot_program\nsteps:\n  - move: a\n   bad: 1\n',
                         r'on line 4, column 4: \S.* \(while parsing a block collection\)$'),
                        ('a: [1, 2\n', r'on line 2, column 1: \S.* \(while parsing a flow sequence\)$'),
                        ('a: 1\n\tb: 2\n', r'on line 2, column 1: \S')):
        f.write_text(text)
        with pytest.raises(ConfigError, match=r'x\.yaml: not valid YAML ' + where):
            read_yaml(f)


def test_brief_cuts_long_values() -> None:
    s = safe_yaml.brief('y' * 10_000)
    assert len(s) < 100 and s.endswith('(10000 characters)')
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


@pytest.mark.parametrize('libyaml', [True, False], ids=['libyaml', 'python'])
def test_duplicate_keys_are_refused_naming_the_key_and_both_lines(monkeypatch, libyaml: bool) -> None:
    """Issue 18: a key given twice was taken silently, the last one winning (robot, equation, tolerance files)."""
    if not libyaml:
        monkeypatch.setattr(safe_yaml, '_CLoader', None)
    with pytest.raises(ConfigError, match=r"g\.yaml: line 4: duplicate key 'radius' \(first on line 1\); allowed: "
                                          'each key once in a mapping'):
        safe_yaml.load_text('radius: 0.1\nmodel: polar\n# a comment\nradius: 0.2\n', 'g.yaml')
    with pytest.raises(ConfigError, match=r"line 2: duplicate key 'b' \(first on line 1\)"):   # nested, flow style
        safe_yaml.load_text('a: {b: 1,\n  b: 2}', 'x')
    with pytest.raises(ConfigError, match=r'line 2: duplicate key 1 \(first on line 1\)'):   # 1 and 01 are one key
        safe_yaml.load_text('1: a\n01: b', 'x')
    assert safe_yaml.load_text('a: {b: 1}\nc: {b: 2}\nd: [{b: 1}, {b: 2}]') == {
        'a': {'b': 1}, 'c': {'b': 2}, 'd': [{'b': 1}, {'b': 2}]}     # the same key in two mappings is no duplicate
    # YAML 1.1's merge key gave a key twice past the check (radius 0.2 dropped, the second merge winning)
    for text, line in (('radius: 0.093218\n<<: {radius: 0.2, stroke_max: 0.3}\n', 2),
                       ('<<: {stroke_max: 0.3}\n<<: {stroke_max: 0.4}\n', 1), ('a:\n  <<: [{b: 1}, {b: 2}]\n', 2),
                       ('<<: 5\n', 1)):
        with pytest.raises(ConfigError, match=rf'^x: line {line}: merge key <<; allowed: each key written out'):
            safe_yaml.load_text(text, 'x')
    assert safe_yaml.load_text("'<<': 1") == {'<<': 1}     # a key that is the text << (quoted) is a key like others


@pytest.mark.parametrize('libyaml', [True, False], ids=['libyaml', 'python'])
def test_both_parsers_give_the_same_data_and_refusals(monkeypatch, libyaml: bool) -> None:
    if not libyaml:
        monkeypatch.setattr(safe_yaml, '_CLoader', None)
    text = (Path(__file__).resolve().parents[1] / 'gpr_kinematics' / 'config' / 'robots' /
            'example_robot.yaml').read_text(encoding='utf-8')
    import yaml
    assert safe_yaml.load_text(text) == yaml.safe_load(text)
    monkeypatch.setattr(safe_yaml, 'MAX_NODES', 1000)
    with pytest.raises(ConfigError, match=r'x: line 3: more than 1000 YAML values'):
        safe_yaml.load_text('a: 1\nb: 2\nc: [' + '1, ' * 2000 + '1]', 'x')
    with pytest.raises(ConfigError, match='x: line 2: YAML aliases'):
        safe_yaml.load_text('a: &q 1\nb: *q', 'x')


def test_keys_that_are_not_names_are_never_quoted() -> None:
    """A file that is not of the package's formats (a password file read as YAML) is not repeated in messages."""
    assert safe_yaml.quoted_key('rod_positions') == "'rod_positions'"
    secret = 'root:$6$Xy.Zz9/abcdefgh:19000:0:99999:7::'
    assert secret not in safe_yaml.quoted_key(secret) and 'not quoted' in safe_yaml.quoted_key(secret)
    from gpr_kinematics.inputs.schema import check_keys
    with pytest.raises(ConfigError) as info:
        check_keys({secret: None, 'radiuss': 1}, ('radius',), 'f.yaml')
    text = str(info.value)
    assert secret not in text and 'root' not in text and 'unknown key(s) radiuss, 1 that is not a name' in text


def test_a_large_file_is_refused_by_its_size_before_it_is_read(tmp_path) -> None:
    """Issue 18: an 8 MB robot file of 2 million values was refused only after 7.6 s and 185 MB of parsing."""
    from gpr_kinematics.robot.description import load_robot
    f = tmp_path / 'robot.yaml'
    f.write_text('name: big\nx: [' + '1,' * 2_000_000 + '1]\n')
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match=r"robot file '.*robot\.yaml' has 4000017 bytes; allowed: at most 1048576"):
        load_robot(f)
    assert time.perf_counter() - t0 < 0.5
    # Within its kind's size, the values are counted on libyaml's events before any is composed.
    g = tmp_path / 'program.yaml'
    g.write_text('stations: [' + '1,' * 1_000_000 + '1]\n')
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match=r'program\.yaml: line 1: more than 200000 YAML values'):
        read_yaml(g, 'program')
    assert time.perf_counter() - t0 < 10.0


@pytest.mark.parametrize('libyaml', [True, False], ids=['libyaml', 'python'])
def test_numbers_and_booleans_are_those_of_yaml_1_2(monkeypatch, libyaml: bool) -> None:
    """YAML 1.1 read position: [0750, ...] as octal (x = 488 mm), heading: 1:31 as base 60 (91), --set leg_max=0x10
    as 16 and 1_0 as 10: all taken silently. They are text now, which every number check refuses by name."""
    if not libyaml:
        monkeypatch.setattr(safe_yaml, '_CLoader', None)
    got = safe_yaml.load_text('a: [0750, 1:31, 0x10, 0o17, 1_0, 1_000.5, 1:30.5, yes, on, no, off, true, FALSE, '
                              '007, -0, +3, 1.5, -.5, .5, 5., 1e3, 2.5e-1, .inf, -.inf, ~]')['a']
    assert got[:11] == [750, '1:31', '0x10', '0o17', '1_0', '1_000.5', '1:30.5', 'yes', 'on', 'no', 'off']
    assert got[11:] == [True, False, 7, 0, 3, 1.5, -0.5, 0.5, 5.0, 1000.0, 0.25, math.inf, -math.inf, None]
    assert all(type(v) is int for v in got[13:16]) and all(type(v) is float for v in got[16:24])
    assert math.isnan(safe_yaml.load_text('x: .nan')['x'])


@pytest.mark.parametrize('libyaml', [True, False], ids=['libyaml', 'python'])
def test_dates_and_over_long_integers_are_text(monkeypatch, libyaml: bool, tmp_path) -> None:
    """YAML 1.1's timestamps became Python dates: a station named 2024-01-15 was 'datetime.date(2024, 1, 15)', not
    a valid name, and 2026-13-45 'a value cannot be read' without its key; an integer of 5,001 digits (beyond Python's
    4,300) likewise. Both are text now (YAML 1.2's core schema has no dates), which the key's own check names."""
    if not libyaml:
        monkeypatch.setattr(safe_yaml, '_CLoader', None)
    got = safe_yaml.load_text('a: [2024-01-15, 2024-01-15T10:00:00, 2026-13-45, 2001-12-14 21:59:43.10 -5]')['a']
    assert got == ['2024-01-15', '2024-01-15T10:00:00', '2026-13-45', '2001-12-14 21:59:43.10 -5']
    edge = '9' * safe_yaml.MAX_INT_DIGITS
    big = safe_yaml.load_text(f'a: [-{edge}, {edge}, {edge}9, -{edge}9, 1{"0" * 5000}]')['a']
    assert big == [-int(edge), int(edge), edge + '9', f'-{edge}9', '1' + '0' * 5000]
    from gpr_kinematics.core.config import load_config
    geometry = tmp_path / 'g.yaml'
    geometry.write_text(f'radius: 1{"0" * 5000}\n')
    with pytest.raises(ConfigError, match=r"g\.yaml: radius = '1000.* is invalid; allowed: metres, 1e-4 <= radius"):
        load_config(geometry)

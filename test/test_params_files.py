"""The params files of a node's command line, read by the package's bounded YAML reader before rcl's quadratic parser
(gpr_kinematics.nodes.params_files, without ROS): which arguments are params files, and each bound refused in one
message naming the file and the limit; the shipped file, several documents and an empty file pass."""
from __future__ import annotations

import doctest
import time
from pathlib import Path

import pytest
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.nodes import params_files as pf

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / 'gpr_kinematics' / 'config' / 'gpr_params.yaml'


def _file(tmp_path: Path, text: str, name: str = 'p.yaml') -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def _refusal(*args: str) -> str:
    with pytest.raises(ConfigError) as info:
        pf.check_params_files(['node', '--ros-args', *args])
    return str(info.value)


@pytest.mark.parametrize('args,files', [
    (['n', '--ros-args', '--params-file', 'a'], ['a']),
    (['n', '--params-file', 'a'], []),                                         # not in a --ros-args section
    (['n', '--ros-args', '-p', 'x:=1', '--', '--params-file', 'a'], []),        # after the section's end
    (['n', '--ros-args', '--params-file', 'a', '--ros-args', '--params-file', 'b'], ['a', 'b']),
    (['n', '--ros-args', '-p', '--params-file', '--params-file', 'b'], ['b']),  # -p's value is no flag
    (['n', '--ros-args', '--params-file'], []),                                # no value: rcl names it
    (['n', '--ros-args', '__params:=a'], []),                                  # rcl refuses this form itself
])
def test_the_params_files_of_a_command_line(args, files):
    assert list(pf.params_files(args)) == files


def test_a_long_list_is_refused_at_once_naming_the_limit(tmp_path):
    """80,000 values (320 kB) took rcl 5 to 20 s; the bounded reader stops at the 20,001st."""
    path = _file(tmp_path, 'n:\n  ros__parameters:\n    kappa: [' + ','.join(['1.0'] * 80_000) + ']\n')
    began = time.monotonic()
    message = _refusal('--params-file', path)
    assert time.monotonic() - began < 1.0
    assert message.startswith(f"params file '{path}': line 3: more than {pf.MAX_PARAMS_VALUES} YAML values; allowed: "
                              f'at most {pf.MAX_PARAMS_VALUES}')


def test_many_node_sections_count_over_the_documents(tmp_path):
    text = ''.join(f'n{i}:\n  ros__parameters:\n    p: 1.0\n---\n' for i in range(5_001))
    assert 'YAML values' in _refusal('--params-file', _file(tmp_path, text))


def test_a_larger_file_is_refused_before_it_is_read(tmp_path):
    path = _file(tmp_path, 'n:\n  ros__parameters:\n    s: "' + 'x' * pf.MAX_PARAMS_BYTES + '"\n')
    assert f'allowed: at most {pf.MAX_PARAMS_BYTES}' in _refusal('--params-file', path)


def test_a_key_twice_is_refused_naming_both_lines(tmp_path):
    path = _file(tmp_path, 'kinematics_node:\n  ros__parameters:\n    radius: 0.09\n    radius: 0.1\n')
    assert _refusal('--params-file', path) == (f"params file '{path}': line 4: duplicate key 'radius' (first on line "
                                               '3); allowed: each key once in a mapping')


@pytest.mark.parametrize('text,words', [
    ('n:\n  ros__parameters:\n    a: &x 1.0\n    b: *x\n', 'line 4: YAML aliases'),
    ('n: {ros__parameters: [\n', 'not valid YAML'),
    ('n:\n  ros__parameters:\n    a: 1\n    <<: {b: 2}\n', 'merge key'),
])
def test_what_the_reader_refuses_is_named_with_the_file(tmp_path, text, words):
    path = _file(tmp_path, text)
    message = _refusal('--params-file', path)
    assert message.startswith(f"params file '{path}'") and words in message


def test_a_missing_or_unreadable_file_is_named_cut(tmp_path):
    assert _refusal('--params-file', str(tmp_path / 'none.yaml')).startswith(
        f"cannot read params file '{tmp_path / 'none.yaml'}': No such file")
    long = str(tmp_path / ('x' * 300))
    message = _refusal('--params-file', long)
    assert 'File name too long' in message and long not in message and f'({len(long)} characters)' in message
    assert 'not a regular file' in _refusal('--params-file', str(tmp_path))


def test_real_params_files_pass(tmp_path):
    """The shipped file, several documents (rcl merges them), an empty file, a second section's other keys."""
    pf.check_params_files(['n', '--ros-args', '--params-file', str(SHIPPED),
                           '--params-file', _file(tmp_path, 'n:\n  ros__parameters:\n    a: 1\n---\n'
                                                            'n:\n  ros__parameters:\n    a: 2\n', 'two.yaml'),
                           '--params-file', _file(tmp_path, '', 'empty.yaml')])


def test_docstring_examples():
    from gpr_kinematics.inputs import safe_yaml

    for module in (pf, safe_yaml):
        result = doctest.testmod(module)
        assert result.attempted > 0 and result.failed == 0

"""The launch files' argument check (gpr_kinematics.nodes.launch_arguments), without ROS and without ``launch``: each
argument accepted exactly as launch takes it where it is used (a condition, a bool parameter or the Node's respawn, a
number within the node parameter's range, a choice), ``params_file`` an existing file, ``rviz:=true`` only with rviz2;
every bad one named with its value and what is allowed, in one line; every launch file's defaults pass."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from gpr_kinematics.nodes.launch_arguments import (
    FILES,
    check_arguments,
    condition_bool,
    launch_file_name,
    refusal,
    yaml_bool,
)

ROOT = Path(__file__).resolve().parents[1]
LAUNCH = ROOT / 'gpr_kinematics' / 'launch'
PARAMS = str(ROOT / 'gpr_kinematics' / 'config' / 'gpr_params.yaml')
VARIANTS = [f'{name}.launch.{ext}' for name in FILES for ext in ('py', 'xml')]


def defaults(name: str) -> dict[str, str]:
    """The declared arguments of ``launch/<name>.launch.xml`` at their defaults (the shipped params file's path)."""
    root = ET.parse(LAUNCH / f'{name}.launch.xml').getroot()
    out = {a.get('name'): a.get('default') for a in root.findall('arg')}
    if 'params_file' in out:
        out['params_file'] = PARAMS
    return out


@pytest.mark.parametrize('launch_file', VARIANTS)
def test_every_launch_file_passes_at_its_defaults(launch_file):
    name, _xml = launch_file_name(launch_file)
    values = defaults(name)
    assert tuple(values) == FILES[name]
    assert check_arguments(launch_file, values) == []


@pytest.mark.parametrize('text, value', [('true', True), ('True', True), (' TRUE ', True), ('1', True), (' 1', True),
                                         ('false', False), ('FaLsE', False), ('0', False),
                                         ('yes', None), ('on', None), ('', None), ('maybe', None), ('2', None)])
def test_a_condition_is_read_as_launch_reads_it(text, value):
    """launch.conditions: strip().lower() is true, 1, false or 0, anything else raises."""
    assert condition_bool(text) is value


@pytest.mark.parametrize('text, value', [('true', True), ('True', True), ('TRUE', True), ('yes', True), ('On', True),
                                         ('1', True), ('false', False), ('no', False), ('OFF', False), ('0', False),
                                         ('tRUE', None), ('y', None), ('', None), ('maybe', None), ('2', None),
                                         ('1 ', None), ('[true]', None), ('{', None)])
def test_a_bool_is_read_as_launch_coerces_it(text, value):
    """launch's coerce_to_type(text, bool): 1 and 0, else YAML 1.1, whose result must be a bool."""
    assert yaml_bool(text) is value


@pytest.mark.parametrize('launch_file, args, words', [
    ('offline_loop.launch.py', {'rate': 'abc'},
     "rate:='abc' is not a number; allowed: a number, 0.1 <= rate <= 5000.0 (trajectory_node's rate)"),
    ('offline_loop.launch.xml', {'rate': 'nan'}, "rate:='nan' is out of range"),
    ('offline_loop.launch.py', {'rate': '1e400'}, "rate:='1e400' is out of range"),
    ('offline_loop.launch.py', {'rate': '5001'}, "rate:='5001' is out of range"),
    ('replay.launch.py', {'rate': '0'},
     "rate:='0' is out of range; allowed: a number, 0.001 <= rate <= 1000000.0 (replay_node's rate)"),
    ('offline_loop.launch.py', {'flush_interval': 'abc'}, "flush_interval:='abc' is not a number; allowed: a "
                                                          "number, 0.0 <= flush_interval <= 3600.0 (recorder_node's"),
    ('offline_loop.launch.py', {'flush_interval': '-1'}, "flush_interval:='-1' is out of range"),
    ('offline_loop.launch.py', {'record': 'maybe'},
     "record:='maybe' is not a condition; allowed: true or false (any case), 1 or 0"),
    ('offline_loop.launch.xml', {'record': 'yes'}, "record:='yes' is not a condition"),   # IfCondition: no YAML
    ('replay.launch.xml', {'rviz': ''}, "rviz:='' is not a condition"),
    ('kinematics.launch.py', {'use_sim_time': 'maybe'}, "use_sim_time:='maybe' is not a bool; allowed: true/false, "
                                                        'yes/no or on/off'),
    ('replay.launch.xml', {'loop': '2'}, "loop:='2' is not a bool"),
    ('kinematics.launch.py', {'respawn': 'maybe'}, "respawn:='maybe' is not a bool"),
    ('kinematics.launch.xml', {'respawn': 'yes'}, "respawn:='yes' is not a condition"),   # if/unless in XML
    ('two_robots.launch.xml', {'respawn': 'on'}, "respawn:='on' is not a condition"),
    ('offline_loop.launch.py', {'mode': 'sweeps'},
     "mode:='sweeps' is not among the choices; allowed: sweep, program, idle (trajectory_node's mode)"),
    ('two_robots.launch.py', {'mode': ''}, "mode:='' is not among the choices"),
    ('replay.launch.py', {'model': 'polr'},
     "model:='polr' is not among the choices; allowed: radial, polar, offset, compliant, ''"),
    ('kinematics.launch.xml', {'frame_prefix': '/r1/'}, "frame_prefix:='/r1/' is not a frame prefix; allowed: empty"),
    ('offline_loop.launch.py', {'frame_prefix': 'r1//'},   # r1//gpr_base breaks the frame-name rule
     "frame_prefix:='r1//' is not a frame prefix; allowed: empty, or letters, digits, _ and single / between parts, "
     'not starting with /, at most 80 characters (gpr_platform_nominal: a prefixed frame is a tf frame name of at '
     'most 100), e.g. r1/'),
    ('replay.launch.xml', {'frame_prefix': 'r' * 81}, 'is not a frame prefix; allowed: empty, or letters'),
    ('kinematics.launch.py', {'params_file': '/nonexistent/typo.yaml'},
     "params_file:='/nonexistent/typo.yaml' does not exist; allowed: an existing ROS parameters file"),
    ('replay.launch.xml', {'params_file': str(ROOT)}, 'is not a file; allowed: an existing ROS parameters file'),
    # launch_ros refused these with an object's repr (namespace=<...LaunchConfiguration object at 0x...>)
    ('offline_loop.launch.py', {'namespace': '1bad'}, "namespace:='1bad' is not a ROS namespace; allowed: empty, or "
     'names of letters, digits and underscores (none starting with a digit) separated by single slashes, e.g. /r1'),
    ('kinematics.launch.xml', {'namespace': '/r1/'}, "namespace:='/r1/' is not a ROS namespace"),
    ('replay.launch.py', {'namespace': 'r-1'}, "namespace:='r-1' is not a ROS namespace"),
])
def test_a_bad_argument_is_named_with_its_value_and_what_is_allowed(launch_file, args, words):
    name, _xml = launch_file_name(launch_file)
    errors = check_arguments(launch_file, {**defaults(name), **args})
    assert len(errors) == 1 and words in errors[0], errors
    assert refusal(errors) == 'invalid launch argument, no node started: ' + errors[0]


@pytest.mark.parametrize('launch_file, args', [
    ('offline_loop.launch.py', {'rate': ' 50 ', 'flush_interval': '0', 'record': ' False', 'rviz': '0'}),
    ('offline_loop.launch.py', {'rate': '1_000', 'mode': 'idle', 'model': 'compliant', 'frame_prefix': 'r1/'}),
    ('kinematics.launch.py', {'respawn': 'yes', 'use_sim_time': 'On'}),       # the Node's respawn: YAML 1.1
    ('kinematics.launch.xml', {'respawn': 'TRUE', 'use_sim_time': 'no'}),
    ('replay.launch.py', {'rate': '1e6', 'loop': '1', 'bag': '', 'joint_states': 'anything: left to the nodes'}),
    ('replay.launch.py', {'namespace': 'cell/r1'}), ('kinematics.launch.xml', {'namespace': '/r_1'}),
    ('offline_loop.launch.py', {'namespace': ''}), ('offline_loop.launch.xml', {'namespace': '/'}),
])
def test_what_launch_takes_passes(launch_file, args):
    name, _xml = launch_file_name(launch_file)
    assert check_arguments(launch_file, {**defaults(name), **args}) == []


def test_several_bad_arguments_in_one_line():
    errors = check_arguments('offline_loop.launch.xml', {'rate': 'abc', 'record': 'maybe', 'respawn': 'yes'})
    assert [e.split(':=')[0] for e in errors] == ['rate', 'record', 'respawn']
    line = refusal(errors)
    assert line.startswith('invalid launch arguments, no node started: ') and '\n' not in line
    assert line.count(' | ') == 2


def test_an_argument_the_file_does_not_take_is_not_checked():
    """kinematics.launch.py has no rate (an extra name on the command line is launch's business, not a value)."""
    assert check_arguments('kinematics.launch.py', {'rate': 'abc', 'record': 'maybe'}) == []


@pytest.mark.parametrize('launch_file', ['offline_loop.launch.py', 'replay.launch.xml', 'two_robots.launch.py'])
def test_rviz_true_needs_rviz2(launch_file):
    """The rviz2 node's package was looked up only when its action ran, after the other nodes had started."""
    missing = check_arguments(launch_file, {'rviz': 'true'}, installed=lambda package: package != 'rviz2')
    assert missing == ["rviz:='true' needs rviz2, which is not installed; allowed: false, or install rviz2 (apt "
                       'install ros-jazzy-rviz2)']
    assert check_arguments(launch_file, {'rviz': 'false'}, installed=lambda package: False) == []
    assert check_arguments(launch_file, {'rviz': 'True'}, installed=lambda package: True) == []


@pytest.mark.parametrize('launch_file', ['offline_loop', 'offline_loop.launch', 'other.launch.py', 'x.launch.yaml'])
def test_an_unknown_launch_file_is_refused(launch_file):
    with pytest.raises(ValueError, match=r'is not checked; allowed: kinematics\.launch\.py/\.xml, offline_loop'):
        check_arguments(launch_file, {})


def test_a_misspelt_argument_is_warned_about_with_the_one_meant():
    """``launch`` ignores an argument the file does not declare: ``rat:=400`` ran offline_loop at the default rate
    without a word. One close to a declared one is warned about, naming it; one far from all (an including launch
    file's own, which reach the included file's configurations too) says nothing; the checked file's name neither."""
    from gpr_kinematics.nodes.launch_arguments import misspelt_arguments

    given = {'rat': '400', 'recrod': 'true', 'rate': '100', 'my_parents_argument': 'x', 'checked_launch_file': 'x'}
    assert misspelt_arguments('offline_loop.launch.py', given) == [
        "launch argument rat:='400' is not an argument of offline_loop (did you mean rate?): ignored, as launch "
        'ignores an undeclared argument',
        "launch argument recrod:='true' is not an argument of offline_loop (did you mean record?): ignored, as launch "
        'ignores an undeclared argument']
    assert misspelt_arguments('kinematics.launch.xml', {'robto': 'x'})[0].startswith(
        "launch argument robto:='x' is not an argument of kinematics (did you mean robot?)")
    assert misspelt_arguments('replay.launch.py', {'rate': '2.0', 'bag': 'b'}) == []

"""The launch files, the RViz configurations and the parameters file, checked without ROS's launch packages (they
are not on the package registries): every Python launch file runs against a recording stand-in of ``launch`` and
``launch_ros``, every XML one is parsed; each names only executables of the package (or rviz2) and parameters the
node declares (and use_sim_time), each argument has a default and a description, the Python and XML variants agree,
the required nodes are respawned or end the launch, the two-robot example gives each robot its namespace and frame
prefix, and the shipped config/gpr_params.yaml is the one the parameter specs generate."""
from __future__ import annotations

import importlib.util
import logging
import re
import sys
import types
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml
from gpr_kinematics.ros.specs import KINDS, NODES, node_specs, params_file_text

ROOT = Path(__file__).resolve().parents[1]
LAUNCH = ROOT / 'gpr_kinematics' / 'launch'
NAMES = ('kinematics', 'offline_loop', 'replay')
#: Parameters every node gets besides its own (rclpy and rclcpp declare them).
BUILT_IN = {'use_sim_time'}


class Recorded:
    """Stand-in of a launch class: keeps its constructor arguments."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs

    def perform(self, context):
        """A LaunchConfiguration's value in a stand-in context."""
        return context.launch_configurations[self.args[0]]


def _stub_modules() -> dict[str, types.ModuleType]:
    classes = {
        'launch': ['LaunchDescription'],
        'launch.actions': ['DeclareLaunchArgument', 'OpaqueFunction', 'IncludeLaunchDescription'],
        'launch.conditions': ['IfCondition', 'UnlessCondition'], 'launch.launch_context': ['LaunchContext'],
        'launch.launch_description_sources': ['PythonLaunchDescriptionSource'],
        'launch.substitutions': ['LaunchConfiguration', 'PathJoinSubstitution', 'PythonExpression'],
        'launch_ros': [], 'launch_ros.actions': ['Node'], 'launch_ros.substitutions': ['FindPackageShare'],
        'launch_ros.parameter_descriptions': ['ParameterValue'],
    }
    out = {}
    for module, names in classes.items():
        mod = types.ModuleType(module)
        for name in names:
            setattr(mod, name, type(name, (Recorded,), {}))
        out[module] = mod
    return out


def _load(name: str, monkeypatch):
    """``launch/<name>.launch.py`` run against the stand-ins (launch_common imported afresh with them): its
    entities."""
    for module, stub in _stub_modules().items():
        monkeypatch.setitem(sys.modules, module, stub)
    monkeypatch.delitem(sys.modules, 'gpr_kinematics.nodes.launch_common', raising=False)
    spec = importlib.util.spec_from_file_location(f'launch_file_{name}', LAUNCH / f'{name}.launch.py')
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.generate_launch_description().args[0]


def python_launch(name: str, monkeypatch) -> dict:
    """Run ``launch/<name>.launch.py`` against the stand-ins; its arguments and nodes."""
    entities = _load(name, monkeypatch)
    args = {e.args[0]: e.kwargs for e in entities if type(e).__name__ == 'DeclareLaunchArgument'}
    nodes = []
    for e in entities:
        if type(e).__name__ != 'Node':
            continue
        names = set()
        for item in e.kwargs.get('parameters', []):
            if isinstance(item, dict):
                names |= set(item)
            else:
                assert type(item).__name__ == 'LaunchConfiguration' and item.args == ('params_file',)
        nodes.append((e.kwargs['package'], e.kwargs['executable'], names))
    return {'args': {k: (_text(v['default_value']), v['description']) for k, v in args.items()}, 'nodes': nodes,
            'used': _used_configurations(entities)}


def _text(value) -> str:
    """A default value as text: a string, or the file a PathJoinSubstitution names (share/<...>)."""
    if isinstance(value, str):
        return value
    parts = value.args[0]
    return '/'.join(p if isinstance(p, str) else f'share/{p.args[0]}' for p in parts)


def _used_configurations(obj, seen=None) -> set[str]:
    """Every LaunchConfiguration name used anywhere in the entities."""
    out: set[str] = set()
    if type(obj).__name__ == 'LaunchConfiguration':
        return {obj.args[0]}
    if isinstance(obj, Recorded):
        return _used_configurations(list(obj.args) + list(obj.kwargs.values()))
    if isinstance(obj, dict):
        return _used_configurations(list(obj.values()))
    if isinstance(obj, (list, tuple)):
        for item in obj:
            out |= _used_configurations(item)
    return out


def xml_launch(name: str) -> dict:
    """The arguments and nodes of ``launch/<name>.launch.xml`` (a required node, written twice with if/unless on
    respawn, once)."""
    root = ET.parse(LAUNCH / f'{name}.launch.xml').getroot()
    assert root.tag == 'launch'
    args = {a.get('name'): (a.get('default'), a.get('description')) for a in root.findall('arg')}
    nodes = []
    for n in root.iter('node'):
        entry = (n.get('pkg'), n.get('exec'), {p.get('name') for p in n.iter('param') if p.get('name')})
        if entry not in nodes:
            nodes.append(entry)
    text = (LAUNCH / f'{name}.launch.xml').read_text()
    return {'args': {k: (v[0].replace('$(find-pkg-share gpr_kinematics)', 'share/gpr_kinematics'), v[1])
                     for k, v in args.items()},
            'nodes': nodes, 'used': set(re.findall(r'\$\(var (\w+)\)', text))}


@pytest.mark.parametrize('name', NAMES)
def test_python_launch_file(name, monkeypatch):
    _check(python_launch(name, monkeypatch))


@pytest.mark.parametrize('name', NAMES)
def test_xml_launch_file(name):
    _check(xml_launch(name))


def _check(launch: dict) -> None:
    for arg, (default, description) in launch['args'].items():
        assert default is not None and description, arg
    assert launch['used'] == set(launch['args']), 'every argument is used and every used one is declared'
    assert launch['nodes']
    for package, exe, params in launch['nodes']:
        assert 'use_sim_time' in params, (exe, params)
        if package == 'rviz2':
            assert exe == 'rviz2' and params == BUILT_IN
            continue
        assert package == 'gpr_kinematics' and exe in NODES, exe
        declared = {s.name for s in node_specs(exe)} | BUILT_IN
        assert params <= declared, (exe, params - declared)


@pytest.mark.parametrize('name', NAMES)
def test_python_and_xml_variants_agree(name, monkeypatch):
    py, xml = python_launch(name, monkeypatch), xml_launch(name)
    assert py['args'] == xml['args']
    assert sorted(py['nodes']) == sorted(xml['nodes'])


def _sources_py(name: str, monkeypatch) -> list[tuple[str, dict[str, str]]]:
    """Per node of the Python variant: its executable and, per parameter set from a launch argument, that
    argument's name."""
    out = []
    for e in _load(name, monkeypatch):
        if type(e).__name__ == 'Node' and e.kwargs['package'] == 'gpr_kinematics':
            params = {k: _used_configurations(v) for item in e.kwargs['parameters'] if isinstance(item, dict)
                      for k, v in item.items()}
            out.append((e.kwargs['executable'], {k: next(iter(v)) for k, v in params.items() if len(v) == 1}))
    return out


def _sources_xml(name: str) -> list[tuple[str, dict[str, str]]]:
    out = []
    for n in ET.parse(LAUNCH / f'{name}.launch.xml').getroot().iter('node'):
        if n.get('pkg') == 'gpr_kinematics':
            entry = (n.get('exec'), {p.get('name'): m.group(1) for p in n.iter('param') if p.get('name')
                                     for m in [re.fullmatch(r'\$\(var (\w+)\)', p.get('value', ''))] if m})
            if entry not in out:
                out.append(entry)
    return out


def test_an_argument_that_sets_a_parameter_defaults_to_the_parameters_default(monkeypatch):
    """A launch argument passed to a node's parameter (``flush_interval``, ``rate``, ``loop``) overrides the params
    file, so its default is a second copy of the parameter's: it must equal the spec's (an empty default, a path or
    name left to the node, is not a value)."""
    read = {'double': float, 'integer': int, 'string': str, 'bool': lambda text: text.lower() == 'true'}
    checked = []
    for name in NAMES:
        args = python_launch(name, monkeypatch)['args']
        for e in _load(name, monkeypatch):
            if type(e).__name__ != 'Node' or e.kwargs['package'] != 'gpr_kinematics':
                continue
            specs = {s.name: s for s in node_specs(e.kwargs['executable'])}
            for item in e.kwargs['parameters']:
                for param, value in (item.items() if isinstance(item, dict) else ()):
                    source = value.args[0] if type(value).__name__ == 'ParameterValue' else None
                    if type(source).__name__ != 'LaunchConfiguration' or param not in specs:
                        continue                    # not the argument's value itself (an expression of it)
                    if source.args[0] == 'joint_states':    # a topic's name (the remapping's, the replay's wait):
                        continue                            # its default is the topic's, no parameter's
                    default, kind = args[source.args[0]][0], specs[param].kind
                    if default == '' or kind not in read:
                        continue
                    assert read[kind](default) == specs[param].default, (name, param, default)
                    checked.append((e.kwargs['executable'], param))
    assert {('recorder_node', 'flush_interval'), ('trajectory_node', 'rate'), ('replay_node', 'rate')} <= set(checked)


@pytest.mark.parametrize('name', NAMES)
def test_the_robot_argument_reaches_every_node_with_a_robot(name, monkeypatch):
    """``robot:=FILE`` sets ``robot_file`` of every node that declares it (kinematics, trajectory and state
    publisher: one robot for the services, the stream and the model), in both variants; ``config_file`` likewise."""
    for sources in (_sources_py(name, monkeypatch), _sources_xml(name)):
        with_robot = [(exe, params) for exe, params in sources if 'robot_file' in {s.name for s in node_specs(exe)}]
        assert with_robot, name
        for exe, params in with_robot:
            assert params.get('robot_file') == 'robot' and params.get('config_file') == 'config_file', (exe, params)
    assert 'robot' in python_launch(name, monkeypatch)['args']


def test_the_cell_argument_reaches_the_simulator_and_the_state_publisher(monkeypatch):
    """``cell:=FILE`` of the offline loop sets ``cell_file`` of robot_simulator_node (goals checked against the cell)
    and state_publisher_node (the cell's markers), in both variants; the two-robot example passes it to both loops."""
    for sources in (_sources_py('offline_loop', monkeypatch), _sources_xml('offline_loop')):
        with_cell = {exe: params.get('cell_file') for exe, params in sources
                     if 'cell_file' in {s.name for s in node_specs(exe)}}
        assert with_cell == {'robot_simulator_node': 'cell', 'state_publisher_node': 'cell'}
    assert python_launch('offline_loop', monkeypatch)['args']['cell'][0] == ''


def test_launch_files_use_the_shipped_files():
    common = ROOT / 'gpr_kinematics' / 'gpr_kinematics' / 'nodes' / 'launch_common.py'
    for path in [*LAUNCH.glob('*.launch.xml'), *LAUNCH.glob('two_robots.launch.py'), common]:
        text = path.read_text()
        refs = re.findall(r"'(config|rviz|launch)', '(\w+\.(?:yaml|rviz|launch\.py))'|/(config|rviz|launch)/"
                          r"(\w+\.(?:yaml|rviz|launch\.xml|launch\.py))", text)
        assert refs, path.name
        for ref in refs:
            folder, name = (ref[0], ref[1]) if ref[0] else (ref[2], ref[3])
            assert (ROOT / 'gpr_kinematics' / folder / name).is_file(), (path.name, folder, name)


def test_rviz_configuration():
    """Relative topics (they follow RViz's namespace); the fixed frame gpr_base, which the launch files give with
    the frame prefix on the command line."""
    cfg = yaml.safe_load((ROOT / 'gpr_kinematics' / 'rviz' / 'gpr.rviz').read_text())
    manager = cfg['Visualization Manager']
    assert manager['Global Options']['Fixed Frame'] == 'gpr_base'
    displays = {d['Class']: d for d in manager['Displays']}
    model = displays['rviz_default_plugins/RobotModel']
    assert model['Description Topic']['Value'] == 'robot_description'
    assert model['Description Topic']['Durability Policy'] == 'Transient Local'     # latched, as published
    assert model['TF Prefix'] == ''            # the URDF's links carry the frame prefix themselves
    assert 'rviz_default_plugins/TF' in displays
    topics = {d['Topic']['Value'] for d in manager['Displays'] if 'Topic' in d}
    assert topics == {'gpr/markers', 'gpr/platform_pose', 'gpr/nominal_pose', 'gpr/wafer_pose', 'gpr/cell'}
    # the process cell of state_publisher_node: a MarkerArray published once, latched
    cell = next(d for d in manager['Displays'] if d.get('Topic', {}).get('Value') == 'gpr/cell')
    assert cell['Class'] == 'rviz_default_plugins/MarkerArray'
    assert cell['Topic']['Durability Policy'] == 'Transient Local'
    # What the trajectory node publishes on the others (the stream's types).
    from gpr_kinematics.bags.typestore import GPR_TOPICS

    shown = {d['Topic']['Value']: d['Class'].rsplit('/', 1)[1] for d in manager['Displays']
             if 'Topic' in d and d['Topic']['Value'] != 'gpr/cell'}
    assert all(GPR_TOPICS['/' + t].endswith('/' + {'Pose': 'PoseStamped'}.get(c, c)) for t, c in shown.items()), shown
    for line in (LAUNCH / 'offline_loop.launch.xml').read_text().splitlines():
        if '/rviz/gpr.rviz' in line:
            assert '-f $(var frame_prefix)gpr_base' in line



def test_params_file_is_generated_from_the_specs():
    assert (ROOT / 'gpr_kinematics' / 'config' / 'gpr_params.yaml').read_text() == params_file_text()


def test_params_file_values_have_the_declared_types():
    """Every value reads back (YAML 1.1, as ros2 param load and launch read it) with the kind of its parameter;
    every key is a parameter the node declares; every node is in the file."""
    data = yaml.safe_load((ROOT / 'gpr_kinematics' / 'config' / 'gpr_params.yaml').read_text())
    assert set(data) == {f'/**/{n}' for n in NODES}
    for key, section in data.items():
        node = key.removeprefix('/**/')
        specs = {s.name: s for s in node_specs(node)}
        values = section['ros__parameters']
        assert set(values) <= set(specs)
        for name, value in values.items():
            assert isinstance(value, KINDS[specs[name].kind]) and isinstance(value, bool) == (specs[name].kind ==
                                                                                              'bool'), (name, value)
            specs[name].check(value)
            assert value == specs[name].default



@pytest.mark.parametrize('node, name, value, allowed', [
    ('trajectory_node', 'loop', 1, 'a bool'),                        # an int is no bool
    ('trajectory_node', 'loop', 'true', 'a bool'),
    ('trajectory_node', 'passes', True, '1 <= passes <= 1000'),     # a bool is no integer
    ('trajectory_node', 'passes', 1001, '1 <= passes <= 1000'),     # above the upper limit
    ('trajectory_node', 'passes', 0, '1 <= passes <= 1000'),
    ('trajectory_node', 'mode', 'sweeps', 'one of: sweep, program, idle'),
])
def test_a_parameter_of_another_kind_beyond_its_range_or_not_among_its_choices_is_refused(node, name, value, allowed):
    """The specs' own check (what each node runs on a parameter set), without ROS: the value, the parameter and
    what is allowed; the values at the limits and of the kind pass."""
    from gpr_kinematics.errors import ConfigError

    spec = {s.name: s for s in node_specs(node)}[name]
    with pytest.raises(ConfigError) as refused:
        spec.check(value)
    assert str(refused.value) == f'parameter {name} = {value!r} is invalid; allowed: {allowed}'
    for ok in {'loop': (True, False), 'passes': (1, 1000), 'mode': ('sweep', 'idle')}[name]:
        spec.check(ok)

REQUIRED = {'kinematics_node', 'robot_simulator_node', 'state_publisher_node'}


@pytest.mark.parametrize('name', [*NAMES, 'two_robots'])
def test_every_launch_file_checks_its_arguments_before_any_node(name, monkeypatch):
    """launch converts an argument when its action runs, after earlier nodes started, and an error then left them
    running (ros2/launch#747): the check of every argument (launch_arguments.FILES, the arguments declared in both
    variants) comes right after the declarations. Python: launch_common.checked; XML: an include of
    check_arguments.launch.py naming the file."""
    from gpr_kinematics.nodes.launch_arguments import CHECKED_FILE, FILES

    entities = _load(name, monkeypatch)
    kinds = [type(e).__name__ for e in entities]
    declared = kinds.count('DeclareLaunchArgument')
    assert kinds[:declared] == ['DeclareLaunchArgument'] * declared and kinds[declared] == 'OpaqueFunction'
    check = entities[declared]
    assert check.kwargs['function'].__name__ == '_check' and check.kwargs['args'] == [f'{name}.launch.py']
    assert tuple(e.args[0] for e in entities[:declared]) == FILES[name]
    root = ET.parse(LAUNCH / f'{name}.launch.xml').getroot()
    children = list(root)
    args = [c for c in children if c.tag == 'arg']
    assert tuple(a.get('name') for a in args) == FILES[name] and children[:len(args)] == args
    include = children[len(args)]
    assert include.tag == 'include' and include.get('file') == ('$(find-pkg-share gpr_kinematics)/launch/'
                                                               'check_arguments.launch.py')
    assert [(a.get('name'), a.get('value')) for a in include.findall('arg')] == [(CHECKED_FILE,
                                                                                 f'{name}.launch.xml')]


def test_the_check_ends_the_launch_with_one_line(monkeypatch, caplog):
    """A bad argument raises (ros2 launch: status 1, the message as the reason) before any node; the XML files'
    check reads the file's name from the launch configuration their include sets."""
    _load('check_arguments', monkeypatch)
    from gpr_kinematics.nodes import launch_common

    monkeypatch.setattr(launch_common, '_installed', lambda package: False)
    context = types.SimpleNamespace(launch_configurations={'rate': 'abc', 'record': 'true', 'rviz': 'false'})
    with pytest.raises(RuntimeError) as refused:
        launch_common._check(context, 'offline_loop.launch.py')
    assert str(refused.value) == ("invalid launch argument, no node started: rate:='abc' is not a number; allowed: "
                                  "a number, 0.1 <= rate <= 5000.0 (trajectory_node's rate)")
    context.launch_configurations.update(rate='50', rviz='true', checked_launch_file='replay.launch.xml')
    with pytest.raises(RuntimeError, match=r"^invalid launch argument, no node started: rviz:='true' needs rviz2"):
        launch_common._check(context, None)
    context.launch_configurations['rviz'] = '0'
    assert launch_common._check(context, None) is None
    # a misspelt argument, which launch ignores, warned about on launch's logger (rat:=400 ran at the default rate)
    context.launch_configurations.update(rat='400')
    with caplog.at_level(logging.WARNING, logger='launch'):
        assert launch_common._check(context, 'offline_loop.launch.py') is None
    assert [r.getMessage() for r in caplog.records if r.name == 'launch'] == [
        "launch argument rat:='400' is not an argument of offline_loop (did you mean rate?): ignored, as launch "
        'ignores an undeclared argument']
    with pytest.raises(RuntimeError, match='checks the arguments of a launch file named by the launch argument '
                                           'checked_launch_file'):
        launch_common._check(types.SimpleNamespace(launch_configurations={}), None)


@pytest.mark.parametrize('name', NAMES)
def test_required_nodes_respawn_or_end_the_launch(name, monkeypatch):
    """Python: a required node respawns with the argument; every node's exit goes to launch_common's rule. XML: a
    required node twice, respawned if respawn, else on_exit shutdown."""
    for e in _load(name, monkeypatch):
        if type(e).__name__ != 'Node' or e.kwargs['package'] != 'gpr_kinematics':
            continue
        exe = e.kwargs['executable']
        respawn = e.kwargs['respawn']
        assert (type(respawn).__name__ == 'LaunchConfiguration' and respawn.args == ('respawn',)) == (exe in REQUIRED)
        (watch,) = e.kwargs['on_exit']
        assert type(watch).__name__ == 'OpaqueFunction' and watch.kwargs['args'] == [exe, exe in REQUIRED]
    root = ET.parse(LAUNCH / f'{name}.launch.xml').getroot()
    for n in root.iter('node'):
        if n.get('exec') in REQUIRED:
            twins = [m for m in root.iter('node') if m.get('exec') == n.get('exec')]
            assert [(m.get('if'), m.get('respawn'), m.get('unless'), m.get('on_exit')) for m in twins] == [
                ('$(var respawn)', 'true', None, None), (None, None, '$(var respawn)', 'shutdown')]


class _Context:
    def __init__(self, code, shutdown=False, respawn='false'):
        self.locals = types.SimpleNamespace(event=types.SimpleNamespace(returncode=code))
        self.is_shutdown = shutdown
        self.launch_configurations = {'respawn': respawn}


def test_exit_rule_ends_the_launch_with_the_reason(monkeypatch):
    """A required node's end or any node's failure raises (ros2 launch then ends with status 1, the message as the
    reason); a node that finished its work, a stop of the launch, or a respawned node do not."""
    _load('offline_loop', monkeypatch)
    from gpr_kinematics.nodes.launch_common import _exited

    with pytest.raises(RuntimeError, match=r'kinematics_node is required and ended \(exit status 0\)'):
        _exited(_Context(0), 'kinematics_node', True)
    with pytest.raises(RuntimeError, match=r'trajectory_node refused to start \(exit status 2\): ending the launch'):
        _exited(_Context(2), 'trajectory_node', False)
    with pytest.raises(RuntimeError, match=r'kinematics_node died \(exit status 1\): ending the launch'):
        _exited(_Context(1), 'kinematics_node', True)
    # a start-up refusal is not respawned (robot:=typo.yaml restarted it every second, the launch never ended)
    with pytest.raises(RuntimeError, match=r'kinematics_node refused to start \(exit status 2\): ending the launch'):
        _exited(_Context(2, respawn='true'), 'kinematics_node', True)
    assert _exited(_Context(0), 'trajectory_node', False) is None              # a sweep that finished
    assert _exited(_Context(-2, shutdown=True), 'kinematics_node', True) is None  # Ctrl-C
    assert _exited(_Context(1, respawn='true'), 'robot_simulator_node', True) is None
    # launch reads respawn:=1 (and True) as true, as the XML's if= does: the Python file ended the launch instead
    assert _exited(_Context(-9, respawn='1'), 'kinematics_node', True) is None
    assert _exited(_Context(-9, respawn='True'), 'kinematics_node', True) is None
    # and yes/on as YAML 1.1 does, where the exit rule ended the launch that launch had respawned the node for
    assert _exited(_Context(-9, respawn='yes'), 'kinematics_node', True) is None
    with pytest.raises(RuntimeError, match='kinematics_node died'):
        _exited(_Context(-9, respawn='off'), 'kinematics_node', True)
    with pytest.raises(RuntimeError, match='recorder_node died'):
        _exited(_Context(1, respawn='true'), 'recorder_node', False)          # not respawned: not required


def test_two_robots_example(monkeypatch):
    """offline_loop twice, namespaces /r1 and /r2 with frame prefixes r1/ and r2/, without recorders (two default bag
    folders could meet); the arguments passed exist in offline_loop; the XML variant the same."""
    entities = _load('two_robots', monkeypatch)
    loop = python_launch('offline_loop', monkeypatch)['args']
    includes = [e for e in entities if type(e).__name__ == 'IncludeLaunchDescription']
    passed = [dict(e.kwargs['launch_arguments']) for e in includes]
    assert [(p['namespace'], p['frame_prefix'], p['record']) for p in passed] == [('/r1', 'r1/', 'false'),
                                                                               ('/r2', 'r2/', 'false')]
    assert all(set(p) <= set(loop) for p in passed)
    assert _text(includes[0].args[0].args[0]) == 'share/gpr_kinematics/launch/offline_loop.launch.py'
    root = ET.parse(LAUNCH / 'two_robots.launch.xml').getroot()
    xml = [{a.get('name'): a.get('value') for a in inc.findall('arg')} for inc in root.iter('include')
           if inc.get('file').endswith('/offline_loop.launch.xml')]
    assert [(p['namespace'], p['frame_prefix'], p['record']) for p in xml] == [('/r1', 'r1/', 'false'),
                                                                            ('/r2', 'r2/', 'false')]
    assert all(set(p) <= set(loop) for p in xml)
    declared = {e.args[0]: (e.kwargs['default_value'], e.kwargs['description']) for e in entities
                if type(e).__name__ == 'DeclareLaunchArgument'}
    assert {a.get('name'): (a.get('default'), a.get('description')) for a in root.findall('arg')} == declared
    assert {k: v for k, v in xml[0].items() if v.startswith('$(var')} == {k: f'$(var {k})' for k in
                                                                          ('mode', 'program_file', 'robot', 'rviz',
                                                                           'cell', 'use_sim_time', 'respawn')}


@pytest.mark.parametrize('prefix, ok', [('', True), ('r1/', True), ('cell_2/r1/', True), ('r1', True),
                                        ('/r1/', False), ('r 1/', False), ('r1/' * 40, False), ('r1/\n', False),
                                        ('r1//', False), ('r1//x/', False), ('x' * 80, True), ('x' * 79 + '/', True),
                                        ('x' * 81, False), ('x' * 99 + '/', False)])
def test_frame_prefix_rule(prefix, ok):
    """What frame_prefix accepts (state_publisher_node and trajectory_node refuse to start otherwise)."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.ros.specs import check_frame_prefix

    if ok:
        assert check_frame_prefix(prefix) == prefix
    else:
        with pytest.raises(ConfigError, match='parameter frame_prefix = .* is invalid; allowed: empty, or letters'):
            check_frame_prefix(prefix)


def test_a_prefixed_frame_obeys_the_frame_name_rule():
    """A prefix makes every frame it goes before a tf frame name (check_frame_names' rule): single slashes, at most
    100 characters with the longest frame (r1// and 100 characters passed: r1//gpr_base, 108 characters)."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.ros.specs import check_frame_names, check_frame_prefix

    for prefix, frames in (('x' * 91 + '/', ('b', 'gpr_base')), ('r1/', ('f' * 97,)), ('x' * 99, ('b',))):
        assert check_frame_prefix(prefix, frames) == prefix
        check_frame_names({f'frame{k}': prefix + f for k, f in enumerate(frames)}, ('frame0',))
    with pytest.raises(ConfigError) as e:
        check_frame_prefix('x' * 92 + '/', ('b', 'gpr_base'))
    assert str(e.value) == ("parameter frame_prefix = '" + 'x' * 59 + "... (93 characters) is invalid; allowed: empty, "
                            'or letters, digits, _ and single / between parts, not starting with /, at most 92 '
                            'characters (gpr_base: a prefixed frame is a tf frame name of at most 100), e.g. r1/')
    with pytest.raises(ConfigError, match=r"frame_prefix = 'r1//' is invalid; allowed: empty, or letters, digits, _ "
                                          r'and single / between parts, not starting with /, at most 80 '
                                          r'characters \(gpr_platform_nominal: '):
        check_frame_prefix('r1//')
    for bad in ('r1//', 'x' * 92 + '/'):    # what it refuses, the frame-name rule refuses prefixed
        with pytest.raises(ConfigError, match='is invalid; allowed: a tf frame name'):
            check_frame_names({'base_frame': bad + 'gpr_base'}, ('base_frame',))


@pytest.mark.parametrize('frames, words', [
    ({'base_frame': 'gpr_base', 'platform_frame': 'gpr_platform', 'nominal_frame': 'n'}, None),
    ({'base_frame': 'cell/gpr_base', 'platform_frame': 'base-link', 'nominal_frame': 'n.1'}, None),
    ({'base_frame': '/gpr_base', 'platform_frame': 'p', 'nominal_frame': 'n'}, "base_frame = '/gpr_base' is invalid"),
    ({'base_frame': 'b', 'platform_frame': 'a b', 'nominal_frame': 'n'}, "platform_frame = 'a b' is invalid"),
    ({'base_frame': 'b', 'platform_frame': 'p', 'nominal_frame': 'a"b<c'}, "nominal_frame = 'a\"b<c' is invalid"),
    ({'base_frame': 'b', 'platform_frame': 'p/', 'nominal_frame': 'n'}, "platform_frame = 'p/' is invalid"),
    ({'base_frame': 'b', 'platform_frame': 'b', 'nominal_frame': 'n'}, "platform_frame = 'b' names the frame of "
                                                                       'base_frame'),
])
def test_frame_name_rule(frames, words):
    """What the frame parameters accept (base_frame:=/gpr_base started and published a frame tf2 refuses)."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.ros.specs import check_frame_names

    names = tuple(frames)
    if words is None:
        check_frame_names(frames, names)
    else:
        with pytest.raises(ConfigError, match=re.escape(words)):
            check_frame_names(frames, names)


@pytest.mark.ros
def test_a_node_stopped_while_it_imports_leaves_quietly(ros_environment):
    """SIGINT while a node still imports (numpy mapped, rclpy to come: a Ctrl-C in a launch's first second): a
    KeyboardInterrupt traceback of some 50 lines and status 130 (-2 under launch); now status 0, no traceback. The
    signal waits for numpy's library in the process's maps: 0.2 s after the start, on a loaded machine, it came while
    the console script's own imports ran (``importlib.metadata``, before the package: the interpreter's traceback,
    Known limits)."""
    import signal
    import time

    from gpr_kinematics.nodes import EXECUTABLES
    from ros_support import start
    setup = (Path(__file__).resolve().parents[1] / 'gpr_kinematics' / 'setup.py').read_text()
    assert sorted(EXECUTABLES) == sorted(re.findall(r"'(\w+) = gpr_kinematics\.nodes\.", setup))   # one list
    proc = start('kinematics_node', namespace='/quiet_start')
    try:
        maps, deadline = Path(f'/proc/{proc.proc.pid}/maps'), time.monotonic() + 20.0

        def mapped() -> str:
            try:   # a node ending between poll() and the read: its output below says why, not a FileNotFoundError
                return maps.read_text()
            except OSError:
                return ''
        while time.monotonic() < deadline and proc.proc.poll() is None and 'numpy' not in mapped():
            time.sleep(0.005)
        proc.proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 0, proc.output()
        assert 'Traceback' not in proc.output() and 'KeyboardInterrupt' not in proc.output(), proc.output()
    finally:
        proc.stop()

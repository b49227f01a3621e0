"""Parameters over real DDS: the shipped params file works with --params-file for every node; descriptors carry
the specs' ranges, allowed values and constraints; a node's own dump (as ``ros2 param dump`` writes it) loads back
(as ``ros2 param load`` reads it, through rclpy's params-file reader) and starts a fresh node with the same values;
numbers sent as strings (``ros2 param set x 1e-13``) are accepted on double parameters, and a long string is refused
at once."""
from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml
from gpr_kinematics.ros.specs import NODES, node_specs
from ros_support import start, wait_for_log

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[1]
PARAMS = ROOT / 'gpr_kinematics' / 'config' / 'gpr_params.yaml'
#: Parameters each executable needs to stay up for the test (replay_node replays the reference bag in a loop).
KEEP_UP = {'trajectory_node': ['-p', 'mode:=idle'],
           'replay_node': ['-p', f'bag:={ROOT / "bags" / "reference_sweep"}', '-p', 'loop:=true',
                           '-p', 'rate:=0.01']}
RCL_OWN = {'use_sim_time', 'start_type_description_service'}


def _value(v):
    """A ParameterValue as ros2param's dump turns it into Python (ros2param.api.get_value)."""
    from rcl_interfaces.msg import ParameterType as T

    return {T.PARAMETER_BOOL: lambda: v.bool_value, T.PARAMETER_INTEGER: lambda: v.integer_value,
            T.PARAMETER_DOUBLE: lambda: v.double_value, T.PARAMETER_STRING: lambda: v.string_value,
            T.PARAMETER_DOUBLE_ARRAY: lambda: list(v.double_array_value),
            T.PARAMETER_STRING_ARRAY: lambda: list(v.string_array_value),
            T.PARAMETER_INTEGER_ARRAY: lambda: list(v.integer_array_value),
            T.PARAMETER_BOOL_ARRAY: lambda: list(v.bool_array_value)}[v.type]()


def _dump(client, node: str) -> dict:
    """{name: value} of every parameter of ``node`` (ListParameters + GetParameters, like ros2 param dump)."""
    from rcl_interfaces.srv import GetParameters, ListParameters

    names = client.call(ListParameters, f'{node}/list_parameters', ListParameters.Request()).result.names
    values = client.call(GetParameters, f'{node}/get_parameters', GetParameters.Request(names=names)).values
    return {n: _value(v) for n, v in zip(names, values, strict=True)}


@pytest.fixture(scope='module')
def client(ros_environment):
    from gpr_kinematics.nodes.client import GprClient

    with GprClient('gpr_test_params') as c:
        yield c


@pytest.mark.parametrize('exe', list(NODES))
def test_params_file_dump_load_round_trip(client, exe, tmp_path):
    from rcl_interfaces.srv import SetParameters
    from rclpy.parameter import parameter_dict_from_yaml_file

    ns = f'/params_{exe}'
    args = ['--params-file', str(PARAMS), *KEEP_UP.get(exe, [])]
    if exe == 'recorder_node':
        args += ['-p', f'output:={tmp_path / "bag"}']
    node = start(exe, *args, namespace=ns)
    fresh = None
    try:
        wait_for_log(node, r'serving|publishing|recording|replaying|idle')
        full = f'{ns}/{exe}'
        dumped = _dump(client, full)
        specs = {s.name: s for s in node_specs(exe)}
        assert set(dumped) - RCL_OWN == set(specs)
        shipped = yaml.safe_load(PARAMS.read_text())[f'/**/{exe}']['ros__parameters']
        overridden = {a.split(':=')[0] for a in args if ':=' in a}
        for name, value in shipped.items():
            assert dumped[name] == value or name in overridden, name
        # ros2 param dump writes yaml.dump({node: {ros__parameters: ...}}); ros2 param load reads it back with
        # rclpy's parameter_dict_from_yaml_file and sets every parameter.
        dump = tmp_path / 'dump.yaml'
        dump.write_text(yaml.dump({full: {'ros__parameters': dumped}}, default_flow_style=False))
        loaded = list(parameter_dict_from_yaml_file(str(dump)).values())
        results = client.call(SetParameters, f'{full}/set_parameters', SetParameters.Request(parameters=loaded)).results
        for param, result in zip(loaded, results, strict=True):
            read_only = param.name in RCL_OWN - {'use_sim_time'} or specs.get(param.name) is not None and \
                specs[param.name].read_only
            assert result.successful or (read_only and 'read-only' in result.reason), (param.name, result.reason)
            assert result.successful or read_only, (param.name, result.reason)
        assert _dump(client, full) == dumped
        # The dump as a params file starts a fresh node with the same values.
        if exe == 'recorder_node':
            dumped['output'] = str(tmp_path / 'bag2')      # a recorder never overwrites a bag
        dump.write_text(yaml.dump({f'{ns}_fresh/{exe}': {'ros__parameters': dumped}}))
        fresh = start(exe, '--params-file', str(dump), *KEEP_UP.get(exe, []), namespace=f'{ns}_fresh')
        wait_for_log(fresh, r'serving|publishing|recording|replaying|idle')
        assert _dump(client, f'{ns}_fresh/{exe}') == dumped
        # the shipped file and a dump name only the node's own parameters: no warning of an unknown one
        assert 'is not a parameter of' not in node.output() + fresh.output()
    finally:
        for p in (node, fresh):
            if p is not None:
                p.stop()


@pytest.mark.parametrize('exe', ['kinematics_node', 'trajectory_node'])
def test_descriptors_carry_the_specs(client, exe):
    from rcl_interfaces.srv import DescribeParameters

    node = start(exe, '-p', 'mode:=idle', namespace='/describe')
    try:
        wait_for_log(node, r'serving|idle')
        specs = node_specs(exe)
        req = DescribeParameters.Request(names=[s.name for s in specs])
        descriptors = client.call(DescribeParameters, f'/describe/{exe}/describe_parameters', req).descriptors
        for spec, d in zip(specs, descriptors, strict=True):
            assert d.name == spec.name and d.description == spec.description
            assert d.additional_constraints == spec.constraint_text()
            assert d.read_only == spec.read_only
            if spec.limits is not None and spec.kind == 'double':
                r = d.floating_point_range[0]
                assert (r.from_value, r.to_value) == spec.limits
            if spec.limits is not None and spec.kind == 'integer':
                r = d.integer_range[0]
                assert (r.from_value, r.to_value) == spec.limits
        by_name = {d.name: d for d in descriptors}
        assert 'at least 10 deg' in by_name['rod_azimuths'].additional_constraints
        assert by_name['model'].additional_constraints.startswith('one of: radial, polar, offset')
        # the keys a ROS parameter takes from the geometry's values carry the rule its check applies (they were bare)
        assert by_name['rod_offsets'].additional_constraints == 'a list of 3 lengths in metres, -0.1 <= o_k <= 0.1'
        assert '1e-6 <= kappa <= 1e6' in by_name['kappa'].additional_constraints
        bare = [s.name for s, d in zip(specs, descriptors, strict=True)
                if s.kind != 'bool' and not d.additional_constraints]   # a switch needs none: true or false
        assert not bare, bare
    finally:
        node.stop()


def test_an_unknown_parameter_at_start_is_named_with_the_closest_one():
    """rclpy ignores a start-up parameter that names none of the node's (a typo would leave the default in force
    unnoticed): the node warns, naming it, the closest parameter and what is allowed, and runs on its defaults."""
    node = start('state_publisher_node', '-p', 'idle_rat:=5.0', '-p', 'zzz:=1', namespace='/unknown_param')
    try:
        wait_for_log(node, r"parameter 'idle_rat' given at start is not a parameter of state_publisher_node and is "
                           r"ignored; did you mean 'idle_rate'\? allowed: .*idle_rate")
        wait_for_log(node, r"parameter 'zzz' given at start is not a parameter of state_publisher_node and is "
                           r"ignored; allowed: ")
        wait_for_log(node, r'held at 10.0 Hz while none arrive')
        assert node.alive()
    finally:
        node.stop()


@pytest.mark.parametrize('exe', ['robot_simulator_node', 'kinematics_node'])
def test_use_sim_time_is_fixed_once_a_node_runs(client, exe):
    """Any client could switch a running node to simulated time: with no /clock, the simulator's goals were accepted
    and never ended and its joint_states stopped. The change is refused, the same value set again is not."""
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    from sensor_msgs.msg import JointState

    node = start(exe, namespace='/clock_fixed')
    try:
        wait_for_log(node, 'serving')
        service = f'/clock_fixed/{exe}/set_parameters'

        def set_sim_time(value: bool):
            v = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
            req = SetParameters.Request(parameters=[Parameter(name='use_sim_time', value=v)])
            return client.call(SetParameters, service, req).results[0]

        refused = set_sim_time(True)
        assert not refused.successful
        assert refused.reason == ('use_sim_time = True: the clock is fixed once the node runs (now False); allowed: '
                                  'set it at start (-p use_sim_time:=true, or the launch argument use_sim_time)')
        assert set_sim_time(False).successful
        assert _dump(client, f'/clock_fixed/{exe}')['use_sim_time'] is False
        # a parameter without a name passed rclpy's check of undeclared names (created; a dump then did not load)
        v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=1.0)
        nameless = client.call(SetParameters, service, SetParameters.Request(parameters=[Parameter(name='', value=v)]))
        assert not nameless.results[0].successful
        assert nameless.results[0].reason == "a parameter named '' (empty); allowed: the node's parameters " \
                                             '(list_parameters)'
        assert '' not in _dump(client, f'/clock_fixed/{exe}')
        # an undeclared name is named (rclpy listed none: "Invalid access to undeclared parameter(s): []")
        unknown = client.call(SetParameters, service, SetParameters.Request(
            parameters=[Parameter(name='no_such_param', value=v)]))
        assert unknown.results[0].reason == ("Invalid access to undeclared parameter(s): 'no_such_param'; allowed: the "
                                             "node's parameters (list_parameters)")
        if exe == 'robot_simulator_node':   # its idle joint_states go on (they stopped under a /clock nobody sends)
            states = client.subscribe(JointState, '/clock_fixed/joint_states')
            assert client.spin_until(lambda: len(states) >= 3, 10)
    finally:
        node.stop()


def test_numbers_sent_as_strings(client):
    """ros2 param set /kinematics_node tolerance 1e-13 sends the string '1e-13' (YAML 1.1): accepted as 1e-13;
    a string that is no number is refused as before."""
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters

    node = start('kinematics_node', namespace='/strings')
    try:
        wait_for_log(node, 'serving')

        def set_text(name, text):
            value = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=text)
            req = SetParameters.Request(parameters=[Parameter(name=name, value=value)])
            return client.call(SetParameters, '/strings/kinematics_node/set_parameters', req).results[0]

        assert set_text('tolerance', '1e-13').successful
        assert _dump(client, '/strings/kinematics_node')['tolerance'] == 1e-13
        assert set_text('tilt_limit', ' 3.0e-2 ').successful
        assert math.isclose(_dump(client, '/strings/kinematics_node')['tilt_limit'], 0.03)
        assert not set_text('tolerance', 'small').successful
        assert not set_text('tolerance', '1e-3').successful          # a number, but outside the range
        assert not set_text('model', '1e-3').successful              # a string parameter keeps its check
        # the refusals in the parameters' terms: '' is a model (the geometry's), 0 the radius (null read as allowed)
        assert set_text('model', 'polarx').reason.endswith("allowed: radial or polar or offset or compliant or '' "
                                                            "(the geometry's model)")
        assert set_text('model', '').successful
        value = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=1e-7)
        req = SetParameters.Request(parameters=[Parameter(name='characteristic_length', value=value)])
        reason = client.call(SetParameters, '/strings/kinematics_node/set_parameters', req).results[0].reason
        assert reason.endswith('<= characteristic_length <= 100, or 0 for the radius'), reason
        # 100,000 digits and an 'x' held the pre-set callback (and every service of the node) for minutes
        assert not set_text('tolerance', '1' * 100_000 + 'x').successful
        assert set_text('tolerance', '1e-12').successful
    finally:
        node.stop()


def test_a_refused_value_is_quoted_briefly():
    """ParamSpec.check quoted the whole value: a 100,000-character mode made a message of 100,069 characters, a list
    of a million integers 7.9 MB; errors.brief shortens it as every other message does."""
    from gpr_kinematics.errors import BRIEF_LENGTH, ConfigError
    from gpr_kinematics.ros.specs import TRAJECTORY

    mode = next(s for s in TRAJECTORY if s.name == 'mode')
    for value in ('x' * 100_000, list(range(10**6))):
        with pytest.raises(ConfigError, match='mode = .* is invalid; allowed: ') as err:
            mode.check(value)
        assert len(str(err.value)) < BRIEF_LENGTH + 200, len(str(err.value))

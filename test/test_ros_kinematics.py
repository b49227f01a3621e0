"""kinematics_node over real DDS: the services answer the core's numbers, bad requests get their message,
parameters (descriptors, --params-file, namespace, validated then applied changes) work, SIGINT/SIGTERM end the
node with status 0."""
from __future__ import annotations

import math
import signal
import textwrap

import numpy as np
import pytest
from gpr_kinematics.core import forward, inverse
from gpr_kinematics.core.compensation import compensate
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.mobility import analyze_mobility
from gpr_kinematics.core.rotations import quaternion_from_matrix, tilt_rotation
from ros_support import client_session, imperfect_config_file, running, start
from ros_support import quat as _quat
from ros_support import vec as _vec

pytestmark = pytest.mark.ros

CFG = load_config()
TIGHT = dict(rtol=0.0, atol=1e-12)


@pytest.fixture(scope='module')
def node(ros_environment):
    yield from running(start('kinematics_node'))


@pytest.fixture(scope='module')
def client(node):
    yield from client_session('gpr_test_kinematics_client')


def _fk(client, q, model=''):
    return client.forward_kinematics(q, model)


SERVICES = {'fk': ('ForwardKinematics', 'gpr/forward_kinematics'),
            'ik': ('InverseKinematics', 'gpr/inverse_kinematics'),
            'comp': ('Compensate', 'gpr/compensate'),
            'mob': ('AnalyzeMobility', 'gpr/analyze_mobility')}


def _srv(kind):
    """(service type, name) of a service by its short name."""
    from gpr_interfaces import srv

    type_name, name = SERVICES[kind]
    return getattr(srv, type_name), name


def _call(client, kind, req):
    return client.call(*_srv(kind), req)


def _target(height, tilt, azimuth, twist=0.0, xy=(0.0, 0.0)):
    from gpr_kinematics.nodes.conversions import pose_msg

    R = tilt_rotation(tilt, azimuth) @ np.array([[math.cos(twist), -math.sin(twist), 0.0],
                                                   [math.sin(twist), math.cos(twist), 0.0], [0, 0, 1.0]])
    return pose_msg((xy[0], xy[1], height), quaternion_from_matrix(R))


@pytest.mark.parametrize('q,model', [
    ((0.5, 0.5, 0.5), ''),                 # singular configuration q1 = q2 = q3
    ((0.45, 0.448, 0.452), ''),
    ((0.2, 0.2015, 0.1990), 'radial'),
    ((0.3, 0.3021, 0.3042), 'offset'),
])
def test_forward_matches_core(client, q, model):
    res = _fk(client, q, model)
    assert res.success, res.message
    core = forward(q, CFG, model or None)
    assert res.model == core.model == (model or CFG.model)
    np.testing.assert_allclose(_vec(res.pose.position), core.position, **TIGHT)
    np.testing.assert_allclose(_quat(res.pose.orientation), core.quaternion, **TIGHT)
    np.testing.assert_allclose(_vec(res.nominal_pose.position), core.nominal_position, **TIGHT)
    np.testing.assert_allclose(res.virtual_joints, core.virtual_joints, **TIGHT)
    assert list(res.virtual_joint_names) == list(core.virtual_joint_names)
    np.testing.assert_allclose(res.side_lengths, core.side_lengths, **TIGHT)
    np.testing.assert_allclose(_vec(res.centre_shift), core.centre_shift, **TIGHT)
    np.testing.assert_allclose([res.tilt, res.tilt_azimuth, res.twist],
                               [core.tilt, core.tilt_azimuth, core.twist], **TIGHT)
    assert res.iterations == core.iterations
    assert res.residual == pytest.approx(core.residual, abs=1e-18)
    assert res.within_budget == core.within_budget
    # Side lengths are those of the rods: L_ij = sqrt(3 R^2 + (q_j - q_i)^2).
    qa = np.asarray(q)
    expect = np.sqrt(3 * CFG.radius ** 2 + (np.roll(qa, -1) - qa) ** 2)
    np.testing.assert_allclose(res.side_lengths, expect, rtol=1e-12)


def test_inverse_matches_core_and_reaches_target(client):
    height, tilt, azimuth = 0.45, math.radians(1.5), math.radians(35.0)
    srv, _ = _srv('ik')
    # x, y and the twist of the target are outcomes, not honoured: give odd values to show it.
    req = srv.Request(target=_target(height, tilt, azimuth, twist=0.3, xy=(0.01, -0.02)))
    res = _call(client, 'ik', req)
    assert res.success, res.message
    core = inverse(height, tilt, azimuth, CFG)
    np.testing.assert_allclose(res.q, core.q, **TIGHT)
    np.testing.assert_allclose(_vec(res.achieved.position), core.achieved.position, **TIGHT)
    np.testing.assert_allclose(_quat(res.achieved.orientation), core.achieved.quaternion, **TIGHT)
    assert res.achieved.position.z == pytest.approx(height, abs=1e-10)
    assert res.tilt == pytest.approx(tilt, abs=1e-10)
    assert res.tilt_azimuth == pytest.approx(azimuth, abs=1e-8)
    assert res.iterations == core.iterations
    assert res.message == (f'target x, y = (0.01, -0.02) m and heading 0.3 rad not honoured: x, y and the heading '
                           f'are outcomes (the height and the tilt are honoured); reached x, y = '
                           f'({core.achieved.position[0]:.9g}, {core.achieved.position[1]:.9g}) m, twist '
                           f'{core.achieved.twist:.9g} rad')   # success: true with them dropped without a word
    assert client.inverse_kinematics(height, tilt, azimuth).message == ''
    # Round trip through the forward service.
    fk = _fk(client, res.q)
    assert fk.success
    assert fk.tilt == pytest.approx(tilt, abs=1e-10)
    assert fk.pose.position.z == pytest.approx(height, abs=1e-10)
    # The client's convenience call builds the same request from height, tilt and azimuth.
    again = client.inverse_kinematics(height, tilt, azimuth)
    np.testing.assert_allclose(again.q, core.q, **TIGHT)


def test_compensate_matches_core(client):
    command = _target(0.4, math.radians(-1.2), math.radians(200.0))
    tool = (0.05, -0.02, 0.12)
    res = client.compensate(_vec(command.position), _quat(command.orientation), tool)
    assert res.success, res.message
    core = compensate(_vec(command.position), _quat(command.orientation), tool_offset=tool, config=CFG)
    np.testing.assert_allclose(res.q, core.q, **TIGHT)
    np.testing.assert_allclose(_vec(res.achieved.position), core.achieved.position, **TIGHT)
    np.testing.assert_allclose(_vec(res.tool_shift), core.tool_shift, **TIGHT)
    np.testing.assert_allclose(_vec(res.arm_correction.translation), core.arm_correction_translation, **TIGHT)
    np.testing.assert_allclose(_quat(res.arm_correction.rotation), core.arm_correction_quaternion, **TIGHT)
    # The tool point reaches the commanded height (the tilt is honoured, x/y shift is reported).
    assert np.linalg.norm(_vec(res.tool_shift)) > 1e-7
    assert abs(res.tool_shift.z) < 1e-9


@pytest.mark.parametrize('q,rank', [((0.5, 0.5, 0.5), 9), ((0.45, 0.448, 0.452), 11)])
def test_mobility_matches_core(client, q, rank):
    res = client.analyze_mobility(q)
    assert res.success, res.message
    core = analyze_mobility(q, CFG)
    assert res.rank_dphi_dp == rank == core.rank_dphi_dp
    assert res.rank_augmented == 12 == core.rank_augmented
    np.testing.assert_allclose(res.singular_values, core.singular_values, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.eigenvalues, core.eigenvalues, rtol=0, atol=1e-12)
    assert 0.0 < res.eq4_lower <= res.eq4_upper
    assert 0.0 < res.eq5_lower <= res.eq5_upper


NAN, INF = float('nan'), float('inf')

#: (id, service, request fields (a target/command as (height, tilt, azimuth) plus quaternion edits), words)
BAD_REQUESTS = [
    ('fk-nan', 'fk', {'q': [0.5, NAN, 0.5]}, ['q2 = nan', 'finite']),
    ('fk-inf', 'fk', {'q': [INF, 0.5, 0.5]}, ['q1 = inf', 'finite']),
    ('fk-above-stroke', 'fk', {'q': [0.5, 0.5, 0.6]}, ['stroke']),
    ('fk-below-stroke', 'fk', {'q': [-0.01, 0.0, 0.0]}, ['stroke']),
    ('fk-unknown-model', 'fk', {'q': [0.5, 0.5, 0.5], 'model': 'banana'}, ['banana', 'radial']),
    ('fk-tilt-beyond-limit', 'fk', {'q': [0.3, 0.3, 0.5]}, ['tilt']),    # about 50 deg
    ('ik-tilt-beyond-limit', 'ik', {'target': (0.4, math.radians(3.0), 0.0)}, ['tilt', 'limit']),
    ('ik-non-unit-quaternion', 'ik', {'target': (0.4, 0.0, 0.0), 'target.orientation.w': 2.0},
     ['target.orientation', 'unit quaternion']),
    ('ik-nan-height', 'ik', {'target': (NAN, 0.0, 0.0)}, ['target.position', 'finite']),
    ('ik-unknown-model', 'ik', {'target': (0.4, 0.01, 0.0), 'model': 'Polar '}, ['Polar', 'radial']),
    ('ik-height-outside-stroke', 'ik', {'target': (0.9, 0.0, 0.0)}, ['stroke']),
    ('comp-non-unit-quaternion', 'comp', {'command': (0.4, 0.0, 0.0), 'command.orientation.x': 0.5},
     ['command.orientation', 'unit quaternion']),
    ('comp-inf-tool', 'comp', {'command': (0.4, 0.0, 0.0), 'tool_offset.y': INF}, ['tool_offset', 'finite']),
    ('mob-nan', 'mob', {'q': [0.5, 0.5, NAN]}, ['q3 = nan', 'finite']),
    ('mob-unknown-model', 'mob', {'q': [0.5, 0.5, 0.5], 'model': 'unknown'}, ['unknown']),
]


def build_request(kind, fields):
    """A request of service ``kind`` with ``fields``: a pose field given as (height, tilt, azimuth), dotted
    names for single numbers inside a message."""
    srv, _ = _srv(kind)
    req = srv.Request()
    for name, value in fields.items():
        if isinstance(value, tuple):
            value = _target(*value)
        *path, last = name.split('.')
        target = req
        for part in path:
            target = getattr(target, part)
        setattr(target, last, value)
    return req


@pytest.mark.parametrize('kind,fields,words', [pytest.param(*b[1:], id=b[0]) for b in BAD_REQUESTS])
def test_bad_request_answered_and_node_stays_up(client, node, kind, fields, words):
    res = _call(client, kind, build_request(kind, fields))
    assert res.success is False
    for w in words:
        assert w.lower() in res.message.lower(), res.message
    assert node.alive()
    ok = _fk(client, (0.5, 0.5, 0.5))
    assert ok.success, ok.message


def test_bad_requests_logged_at_warning(client, node):
    res = _fk(client, [0.5, 0.5, 0.7])
    assert not res.success
    assert client.spin_until(lambda: 'forward_kinematics: rejected request' in node.output(), 10), node.output()
    lines = [line for line in node.output().splitlines() if 'forward_kinematics: rejected request' in line]
    assert lines and all('[WARN]' in line for line in lines), lines


def _set_params(client, node_name, **values):
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters

    req = SetParameters.Request()
    for name, value in values.items():
        if isinstance(value, str):
            pv = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
        else:
            pv = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))
        req.parameters.append(Parameter(name=name, value=pv))
    return client.call(SetParameters, f'{node_name}/set_parameters', req).results


def test_parameters_descriptors_and_runtime_change(client, node):
    assert CFG.model == 'radial'                 # the node starts with the package default
    q = (0.4, 0.401, 0.399)
    before = _fk(client, q)
    assert before.model == 'radial'
    (ro,) = _set_params(client, 'kinematics_node', radius=0.1)
    assert not ro.successful and 'read-only' in ro.reason.lower()
    (out,) = _set_params(client, 'kinematics_node', tilt_limit=1.0)     # beyond the descriptor's range
    assert not out.successful
    (bad,) = _set_params(client, 'kinematics_node', model='banana')
    assert not bad.successful and 'banana' in bad.reason
    # within the descriptor's 0 .. 100 but below the core's least: the reason names the least (it said '> 0')
    (small,) = _set_params(client, 'kinematics_node', characteristic_length=5e-7)
    assert not small.successful
    assert 'allowed: metres, 1e-06 <= characteristic_length <= 100, or 0 for the radius' in small.reason
    assert _fk(client, q).model == 'radial'      # a rejected change leaves the node as it was
    try:
        (good,) = _set_params(client, 'kinematics_node', model='polar')
        assert good.successful, good.reason
        res = _fk(client, q)
        assert res.model == 'polar'
        core = forward(q, CFG, 'polar')
        np.testing.assert_allclose(_vec(res.pose.position), core.position, **TIGHT)
        np.testing.assert_allclose(res.virtual_joints, core.virtual_joints, **TIGHT)
        assert len(res.virtual_joints) == 6 != len(before.virtual_joints)
        # The two models differ by more than the tolerance here: the change really took effect.
        assert np.max(np.abs(_vec(res.pose.position) - _vec(before.pose.position))) > 1e-9
    finally:
        (back,) = _set_params(client, 'kinematics_node', model=CFG.model)
        assert back.successful


def test_params_file_and_namespace(client, tmp_path):
    params = tmp_path / 'gpr_params.yaml'
    params.write_text(textwrap.dedent('''\
        /gpr_test/kinematics_node:
          ros__parameters:
            model: offset
            radius: 0.1
            stroke_max: 0.6
        '''))
    proc = start('kinematics_node', '--params-file', str(params), namespace='/gpr_test')
    try:
        from gpr_interfaces.srv import ForwardKinematics

        q = (0.55, 0.5501, 0.5498)         # above the default stroke (0.508), inside the file's
        res = client.call(ForwardKinematics, '/gpr_test/gpr/forward_kinematics', ForwardKinematics.Request(q=q))
        assert res.success, res.message
        cfg = CFG.replace(model='offset', radius=0.1, stroke_max=0.6)
        core = forward(q, cfg)
        assert res.model == 'offset'
        np.testing.assert_allclose(_vec(res.pose.position), core.position, **TIGHT)
        np.testing.assert_allclose(res.side_lengths, core.side_lengths, **TIGHT)
    finally:
        proc.stop()


def test_an_imperfect_machine_from_config_file(client, tmp_path):
    """A config_file with the keys no ROS parameter holds (rod positions, directions, platform joints): the node
    computes on that machine, its answers equal the core's on it and differ from the nominal machine's."""
    from gpr_interfaces.srv import AnalyzeMobility, ForwardKinematics

    path, cfg = imperfect_config_file(tmp_path)
    proc = start('kinematics_node', namespace='/gpr_imperfect', config_file=str(path))
    try:
        q = (0.41, 0.4125, 0.4093)
        res = client.call(ForwardKinematics, '/gpr_imperfect/gpr/forward_kinematics', ForwardKinematics.Request(q=q))
        assert res.success, res.message
        core = forward(q, cfg)
        assert res.model == 'compliant'
        np.testing.assert_allclose(_vec(res.pose.position), core.position, **TIGHT)
        np.testing.assert_allclose(_quat(res.pose.orientation), core.quaternion, **TIGHT)
        np.testing.assert_allclose(res.virtual_joints, core.virtual_joints, **TIGHT)
        np.testing.assert_allclose(res.side_lengths, core.side_lengths, **TIGHT)
        nominal = forward(q, CFG.replace(model='compliant', kappa=cfg.kappa))
        assert np.max(np.abs(_vec(res.pose.position) - nominal.position)) > 1e-6     # really another machine
        # Mobility with a rod-length change: dP along the machine's own rod directions u_k.
        dq = (1e-4, -2e-4, 5e-5)
        mob = client.call(AnalyzeMobility, '/gpr_imperfect/gpr/analyze_mobility',
                          AnalyzeMobility.Request(q=q, dq=dq))
        assert mob.success, mob.message
        m = analyze_mobility(q, cfg)
        b = m.dx_bounds(m.rod_perturbation(dq))
        u = np.array(cfg.rod_directions)
        assert np.allclose(m.rod_perturbation(dq)[3:5], np.asarray(dq)[0] * u[0])   # not e3: the tilted rod
        assert mob.dx_norm == pytest.approx(b.norm_dx, rel=1e-12)
        assert (mob.dx_lower_eq5, mob.dx_upper_eq5) == pytest.approx(b.eq5, rel=1e-12)
    finally:
        proc.stop()


def test_bad_parameter_exits_2_with_message():
    proc = start('kinematics_node', stroke_min=0.6)     # above stroke_max
    status = proc.wait(timeout=30)
    assert status == 2
    out = proc.output()
    assert 'cannot start' in out and 'stroke_min' in out and 'Traceback' not in out


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_signal_exits_0_quickly(sig):
    from gpr_kinematics.nodes.client import GprClient

    from gpr_interfaces.srv import ForwardKinematics

    ns = f'/gpr_sig_{int(sig)}'
    proc = start('kinematics_node', namespace=ns)
    with GprClient(f'gpr_test_sig_{int(sig)}') as c:
        c.client(ForwardKinematics, f'{ns}/gpr/forward_kinematics')     # up and serving
    status, took = proc.signal(sig, timeout=2.0)
    out = proc.output()
    proc.stop()
    assert status == 0, out
    assert took < 2.0
    assert 'Traceback' not in out and 'Exception' not in out


def test_executables_found_like_ros2_run():
    """ros2 run = ament_index_python.get_package_prefix(pkg) + lib/<pkg>/<exe>; ros_env.find_executable agrees
    and points into the colcon install tree."""
    from ament_index_python.packages import get_package_prefix
    from gpr_kinematics.ros import env as ros_env
    from gpr_kinematics.ros.specs import NODES

    prefix = get_package_prefix('gpr_kinematics')
    assert prefix == str(ros_env.install_dir() / 'gpr_kinematics')
    for exe in NODES:
        assert str(ros_env.find_executable('gpr_kinematics', exe)) == f'{prefix}/lib/gpr_kinematics/{exe}'
    with pytest.raises(FileNotFoundError, match='no executable'):
        ros_env.find_executable('gpr_kinematics', 'no_such_node')
    with pytest.raises(FileNotFoundError, match='not found in the ament index'):
        ros_env.find_executable('no_such_package', 'x')


def test_the_finiteness_check_of_a_response_names_the_field_the_walk_names(ros_environment):
    """kinematics_node refuses a result with a NaN or an infinity in it: the check by one getter per response type
    (conversions.first_non_finite) names the same field and value as the walk over every field, for a bad number
    in each float field and array of every response."""
    from gpr_kinematics.nodes.conversions import first_non_finite, non_finite_field

    from gpr_interfaces import srv

    for name in ('ForwardKinematics', 'InverseKinematics', 'Compensate', 'AnalyzeMobility', 'RobotForwardKinematics',
                 'StationInverseKinematics'):
        cls = getattr(srv, name).Response
        paths = [(path, kind) for path, kind in _float_fields(cls(), '')]
        assert paths and first_non_finite(cls()) is None
        for path, kind in paths:
            for bad in (math.nan, -math.inf):
                msg = cls()
                *parents, last = path.split('.')
                target = msg
                for part in parents:
                    target = getattr(target, part)
                setattr(target, last, bad if kind == 'double' else [0.5, bad, 0.25] if 'sequence' in kind
                        else np.array([0.5, bad, 0.25]))
                found = first_non_finite(msg)
                assert found == non_finite_field(msg) and found is not None and found.startswith(path), (path, found)


def _float_fields(msg, prefix):
    for name, kind in msg.get_fields_and_field_types().items():
        value = getattr(msg, name)
        if hasattr(value, 'get_fields_and_field_types'):
            yield from _float_fields(value, f'{prefix}{name}.')
        elif kind == 'double' or kind.startswith(('sequence<double', 'double[3]')):
            yield prefix + name, kind


def test_an_unknown_executor_is_refused_before_a_context_is_made(ros_environment):
    """GprClient(executor='x') raised a bare ValueError after rclpy.init and create_node: the context and the node
    were never shut down (close() unreachable). Refused first, as the package's InputError."""
    from gpr_kinematics.errors import InputError
    from gpr_kinematics.nodes.client import GprClient

    with pytest.raises(InputError, match=r"executor = 'x'; allowed: 'single' or 'events'"):
        GprClient('gpr_test_bad_executor', executor='x')


@pytest.mark.parametrize('call, words', [
    (lambda c: c.forward_kinematics([0.5, 0.5]), r'^q must be 3 numbers, got 2; allowed: 3 values in SI units$'),
    (lambda c: c.forward_kinematics([0.5, 0.5, 0.5, 0.3]), r'^q must be 3 numbers, got 4'),
    (lambda c: c.analyze_mobility([0.5] * 3, dq=[1e-4, -1e-4]), r'^dq must be 3 numbers'),
    (lambda c: c.analyze_mobility([0.5, 0.5]), r'^q must be 3 numbers, got 2'),
    (lambda c: c.inverse_kinematics(0.45, 2.0 * math.pi - 0.01, 0.0), r'allowed: \|tilt\| < pi'),   # 0.01 folded
    (lambda c: c.compensate([0.0, 0.0, 0.4], [0.0, 0.0, 1.0]), r'^quaternion must be 4 numbers, got 3'),
    (lambda c: c.compensate([0.0, 0.0, 0.4], [0.0, 0.0, 0.0, 1.0], [0.0, 0.0]), r'^tool_offset must be 3 numbers'),
    (lambda c: c.station_inverse_kinematics([1.0, 0.5, 0.4], tilt='0.1'), r'^tilt, azimuth must be numbers'),
    (lambda c: c.robot_forward_kinematics([0.3] * 3, 'abc'), r'^joints must be numbers'),
    (lambda c: c.robot_forward_kinematics([0.3] * 2, [0.0, 0.0, 0.0]), r'^rods must be 3 numbers, got 2'),
    (lambda c: c.inverse_kinematics(0.45, 0.01, 1e300), r'^azimuth = 1e\+300 rad is beyond one turn; allowed: '
                                                         r'\[-2pi, 2pi\] rad'),
    # a ROS trial: 90 (degrees) was read as 2.04 rad, where the station service and the files refuse it
    (lambda c: c.inverse_kinematics(0.45, 0.01, 90.0), r'^azimuth = 90 rad is beyond one turn; allowed: \[-2pi, 2pi\] '
                                                       r'rad \(radians only here: 90 deg is 1\.57079633 rad\)'),
    (lambda c: c.inverse_kinematics(0.45, 2.0 * math.pi + 0.01, 0.0), r'allowed: \|tilt\| < pi'),
    (lambda c: c.inverse_kinematics(0.45, float('nan'), 0.0), r'^height, tilt, azimuth = \[0.45, nan, 0.0\]'),
    (lambda c: c.compensate([0.0, 0.0], [0.0, 0.0, 0.0, 1.0]), r'^position must be 3 numbers'),
    (lambda c: c.station_inverse_kinematics([1.0, 0.5], tilt=0.0), r'^position must be 3 numbers, got 2'),
    # a string field of another type aborted the process in rclpy's C conversion (SIGABRT, no exception)
    (lambda c: c.station_inverse_kinematics([1.0, 0.5, 0.4], arm=1), r"^arm = 1 is invalid; allowed: a string"),
    (lambda c: c.robot_forward_kinematics([0.3] * 3, [0.0] * 3, arm=['arm1']), r'^arm = \[.arm1.\] is invalid'),
    (lambda c: c.forward_kinematics([0.5] * 3, model=b'radial'), r"^model = b'radial' is invalid; allowed: a string"),
    (lambda c: c.compensate([0.0, 0.0, 0.4], [0.0, 0.0, 0.0, 1.0], model='radial\x00x'), r'without NUL'),
    (lambda c: c.send_program(program_file=5), r'^program_file = 5 is invalid'),
    (lambda c: c.send_program(move_time='abc'), r'^move_time must be numbers'),
    # a station's int aborted it too; a misspelt key was dropped (the dwell sent as 0)
    (lambda c: c.send_program(stations=[{'name': 'a', 'height': 0.4, 'tilt': 0.01, 'azimuth': 0, 'dwel': 0.5}]),
     r'^stations\[0\]: unknown key\(s\) dwel; allowed keys: azimuth, dwell, height, move_time, name, tilt'),
    (lambda c: c.send_program(stations=[{'name': 'a', 'height': 0.4}]), r'^stations\[0\]: missing tilt, azimuth'),
    (lambda c: c.send_program(stations=[{'height': None, 'tilt': 0.0, 'azimuth': 0.0}]),   # sent as 0.0 m
     r'^stations\[0\]: missing height'),
    (lambda c: c.send_program(stations=[{'name': 7, 'height': 0.4, 'tilt': 0, 'azimuth': 0}]),
     r'^stations\[0\].name = 7 is invalid'),
    (lambda c: c.send_program(stations=[[0.4, 0.0, 0.0]]), r'^stations\[0\] = \[0.4, 0.0, 0.0\] is invalid'),
])
def test_the_client_refuses_what_its_requests_cannot_carry(client, call, words):
    """GprClient sent a q of 2 values with the memory past its end as q3 (6.9e-310), cut one of 4 silently, and an
    azimuth of 1e300 as a valid quaternion (answered success): refused before anything is sent, naming the value
    (a NaN the node refuses naming its field, but where the client computes with it: the target's quaternion)."""
    from gpr_kinematics.errors import InputError

    with pytest.raises(InputError, match=words):
        call(client)

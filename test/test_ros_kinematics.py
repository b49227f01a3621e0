"""kinematics_node over real DDS: the services answer the core's numbers, bad requests get their message,
parameters (descriptors, --params-file, namespace) work, SIGINT/SIGTERM end the node with status 0."""
from __future__ import annotations

import math
import signal
import textwrap

import numpy as np
import pytest
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from ros_support import Client, NodeProcess

from gpr_interfaces.srv import AnalyzeMobility, Compensate, ForwardKinematics, InverseKinematics
from gpr_kinematics.compensation import compensate
from gpr_kinematics.config import load_config
from gpr_kinematics.geometry import quaternion_from_matrix, tilt_rotation
from gpr_kinematics.kinematics import forward, inverse
from gpr_kinematics.mobility import analyze_mobility
from gpr_kinematics.nodes.conversions import pose_msg

CFG = load_config()
TIGHT = dict(rtol=0.0, atol=1e-12)


@pytest.fixture(scope='module')
def node():
    proc = NodeProcess('kinematics_node')
    yield proc
    proc.stop()


@pytest.fixture(scope='module')
def client(node):
    c = Client('gpr_test_kinematics_client')
    c.fk = c.service(ForwardKinematics, 'gpr/forward_kinematics')
    c.ik = c.service(InverseKinematics, 'gpr/inverse_kinematics')
    c.comp = c.service(Compensate, 'gpr/compensate')
    c.mob = c.service(AnalyzeMobility, 'gpr/analyze_mobility')
    yield c
    c.close()


def _vec(v):
    return np.array([v.x, v.y, v.z])


def _quat(q):
    return np.array([q.x, q.y, q.z, q.w])


def _fk(client, q, model=''):
    req = ForwardKinematics.Request()
    req.q = [float(x) for x in q]
    req.model = model
    return client.call(client.fk, req)


def _target(height, tilt, azimuth, twist=0.0, xy=(0.0, 0.0)):
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
    req = InverseKinematics.Request()
    # x, y and the twist of the target are outcomes, not honoured: give odd values to show it.
    req.target = _target(height, tilt, azimuth, twist=0.3, xy=(0.01, -0.02))
    res = client.call(client.ik, req)
    assert res.success, res.message
    core = inverse(height, tilt, azimuth, CFG)
    np.testing.assert_allclose(res.q, core.q, **TIGHT)
    np.testing.assert_allclose(_vec(res.achieved.position), core.achieved.position, **TIGHT)
    np.testing.assert_allclose(_quat(res.achieved.orientation), core.achieved.quaternion, **TIGHT)
    assert res.achieved.position.z == pytest.approx(height, abs=1e-10)
    assert res.tilt == pytest.approx(tilt, abs=1e-10)
    assert res.tilt_azimuth == pytest.approx(azimuth, abs=1e-8)
    assert res.iterations == core.iterations
    # Round trip through the forward service.
    fk = _fk(client, res.q)
    assert fk.success
    assert fk.tilt == pytest.approx(tilt, abs=1e-10)
    assert fk.pose.position.z == pytest.approx(height, abs=1e-10)


def test_compensate_matches_core(client):
    command = _target(0.4, math.radians(-1.2), math.radians(200.0))
    tool = (0.05, -0.02, 0.12)
    req = Compensate.Request()
    req.command = command
    req.tool_offset.x, req.tool_offset.y, req.tool_offset.z = tool
    res = client.call(client.comp, req)
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
    req = AnalyzeMobility.Request()
    req.q = list(q)
    res = client.call(client.mob, req)
    assert res.success, res.message
    core = analyze_mobility(q, CFG)
    assert res.rank_dphi_dp == rank == core.rank_dphi_dp
    assert res.rank_augmented == 12 == core.rank_augmented
    np.testing.assert_allclose(res.singular_values, core.singular_values, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.eigenvalues, core.eigenvalues, rtol=0, atol=1e-12)
    assert 0.0 < res.eq4_lower <= res.eq4_upper
    assert 0.0 < res.eq5_lower <= res.eq5_upper


def _bad_requests():
    nan, inf = float('nan'), float('inf')
    fk = ForwardKinematics.Request
    out = []

    def add(label, srv, req, *words):
        out.append(pytest.param(srv, req, words, id=label))

    r = fk()
    r.q = [0.5, nan, 0.5]
    add('fk-nan', 'fk', r, 'q[1]', 'finite')
    r = fk()
    r.q = [inf, 0.5, 0.5]
    add('fk-inf', 'fk', r, 'q[0]', 'finite')
    r = fk()
    r.q = [0.5, 0.5, 0.6]
    add('fk-above-stroke', 'fk', r, 'stroke')
    r = fk()
    r.q = [-0.01, 0.0, 0.0]
    add('fk-below-stroke', 'fk', r, 'stroke')
    r = fk()
    r.q = [0.5, 0.5, 0.5]
    r.model = 'banana'
    add('fk-unknown-model', 'fk', r, 'banana', 'radial')
    r = fk()
    r.q = [0.3, 0.3, 0.3 + 0.2]   # about 50 deg: far beyond the tilt limit
    add('fk-tilt-beyond-limit', 'fk', r, 'tilt')
    ik = InverseKinematics.Request()
    ik.target = _target(0.4, math.radians(3.0), 0.0)
    add('ik-tilt-beyond-limit', 'ik', ik, 'tilt', 'limit')
    ik = InverseKinematics.Request()
    ik.target = _target(0.4, 0.0, 0.0)
    ik.target.orientation.w = 2.0
    add('ik-non-unit-quaternion', 'ik', ik, 'target.orientation', 'unit quaternion')
    ik = InverseKinematics.Request()
    ik.target = _target(nan, 0.0, 0.0)
    add('ik-nan-height', 'ik', ik, 'target.position', 'finite')
    ik = InverseKinematics.Request()
    ik.target = _target(0.4, 0.01, 0.0)
    ik.model = 'Polar '
    add('ik-unknown-model', 'ik', ik, 'Polar', 'radial')
    ik = InverseKinematics.Request()
    ik.target = _target(0.9, 0.0, 0.0)
    add('ik-height-outside-stroke', 'ik', ik, 'stroke')
    cp = Compensate.Request()
    cp.command = _target(0.4, 0.0, 0.0)
    cp.command.orientation.x = 0.5
    add('comp-non-unit-quaternion', 'comp', cp, 'command.orientation', 'unit quaternion')
    cp = Compensate.Request()
    cp.command = _target(0.4, 0.0, 0.0)
    cp.tool_offset.y = inf
    add('comp-inf-tool', 'comp', cp, 'tool_offset', 'finite')
    mb = AnalyzeMobility.Request()
    mb.q = [0.5, 0.5, nan]
    add('mob-nan', 'mob', mb, 'q[2]', 'finite')
    mb = AnalyzeMobility.Request()
    mb.q = [0.5, 0.5, 0.5]
    mb.model = 'unknown'
    add('mob-unknown-model', 'mob', mb, 'unknown')
    return out


@pytest.mark.parametrize('srv,req,words', _bad_requests())
def test_bad_request_answered_and_node_stays_up(client, node, srv, req, words):
    res = client.call(getattr(client, srv), req)
    assert res.success is False
    for w in words:
        assert w.lower() in res.message.lower(), res.message
    assert node.alive()
    ok = _fk(client, (0.5, 0.5, 0.5))
    assert ok.success, ok.message


def test_bad_requests_logged_at_warning(client, node):
    req = ForwardKinematics.Request()
    req.q = [0.5, 0.5, 0.7]
    res = client.call(client.fk, req)
    assert not res.success
    client.spin_for(0.3)
    assert '[WARN]' in node.output() and 'forward_kinematics: rejected request' in node.output()


def _set_params(client, node_name, **values):
    cli = client.service(SetParameters, f'{node_name}/set_parameters')
    req = SetParameters.Request()
    for name, value in values.items():
        if isinstance(value, str):
            pv = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
        else:
            pv = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))
        req.parameters.append(Parameter(name=name, value=pv))
    return client.call(cli, req).results


def test_parameters_descriptors_and_runtime_change(client, node):
    (ro,) = _set_params(client, 'kinematics_node', radius=0.1)
    assert not ro.successful and 'read-only' in ro.reason.lower()
    (out,) = _set_params(client, 'kinematics_node', tilt_limit=1.0)     # beyond the descriptor's range
    assert not out.successful
    (bad,) = _set_params(client, 'kinematics_node', model='banana')
    assert not bad.successful and 'banana' in bad.reason
    try:
        (good,) = _set_params(client, 'kinematics_node', model='radial')
        assert good.successful, good.reason
        q = (0.4, 0.401, 0.399)
        res = _fk(client, q)
        assert res.model == 'radial'
        np.testing.assert_allclose(_vec(res.pose.position), forward(q, CFG, 'radial').position, **TIGHT)
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
    proc = NodeProcess('kinematics_node', ['-r', '__ns:=/gpr_test', '--params-file', str(params)])
    try:
        fk = client.service(ForwardKinematics, '/gpr_test/gpr/forward_kinematics')
        q = (0.55, 0.5501, 0.5498)         # above the default stroke (0.508), inside the file's
        req = ForwardKinematics.Request()
        req.q = list(q)
        res = client.call(fk, req)
        assert res.success, res.message
        cfg = CFG.replace(model='offset', radius=0.1, stroke_max=0.6)
        core = forward(q, cfg)
        assert res.model == 'offset'
        np.testing.assert_allclose(_vec(res.pose.position), core.position, **TIGHT)
        np.testing.assert_allclose(res.side_lengths, core.side_lengths, **TIGHT)
    finally:
        proc.stop()


def test_bad_parameter_exits_2_with_message():
    proc = NodeProcess('kinematics_node', ['-p', 'stroke_min:=0.6'])     # above stroke_max
    status = proc.wait(timeout=30)
    assert status == 2
    out = proc.output()
    assert 'cannot start' in out and 'stroke_min' in out and 'Traceback' not in out


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_signal_exits_0_quickly(sig):
    ns = f'/gpr_sig_{int(sig)}'
    proc = NodeProcess('kinematics_node', ['-r', f'__ns:={ns}'])
    c = Client(f'gpr_test_sig_{int(sig)}')
    try:
        c.service(ForwardKinematics, f'{ns}/gpr/forward_kinematics')     # up and serving
    finally:
        c.close()
    status, took = proc.signal(sig, timeout=2.0)
    out = proc.output()
    proc.stop()
    assert status == 0, out
    assert took < 2.0
    assert 'Traceback' not in out


def test_executables_found_like_ros2_run():
    """ros2 run = ament_index_python.get_package_prefix(pkg) + lib/<pkg>/<exe>; ros_env.find_executable agrees
    and points into the colcon install tree."""
    from ament_index_python.packages import get_package_prefix
    from ros_support import executable

    from gpr_kinematics import ros_env

    prefix = get_package_prefix('gpr_kinematics')
    assert prefix == str(ros_env.install_dir() / 'gpr_kinematics')
    for exe in ('kinematics_node', 'trajectory_node'):
        assert str(executable(exe)) == f'{prefix}/lib/gpr_kinematics/{exe}'
    with pytest.raises(FileNotFoundError, match='no executable'):
        ros_env.find_executable('gpr_kinematics', 'no_such_node')
    with pytest.raises(FileNotFoundError, match='not found in the ament index'):
        ros_env.find_executable('no_such_package', 'x')

"""A calibration whose measurements identify none of its free parameters is refused by the gate (exit 1, no file):
with ``--free kappa`` and untilted poses (``q1 = q2 = q3``, where ``kappa`` acts not at all: the compliant joints are
loaded only by a tilt) every ``kappa`` was held at nominal, the gate passed (reduced chi-square 0.85 on a machine whose
joints have ``kappa`` 3, not 1000) and the nominal geometry was written as ``calibrated`` with exit 0."""
from __future__ import annotations

import json

import numpy as np
from calibration_support import run
from gpr_kinematics.calibration.arm import arm_parameters
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.identification import identify
from gpr_kinematics.calibration.measurements import write_measurements
from gpr_kinematics.calibration.model import evaluate
from gpr_kinematics.calibration.synthetic import synthetic_measurements
from gpr_kinematics.core import naive_inverse
from gpr_kinematics.core.config import load_config
from gpr_kinematics.robot.description import load_robot


def machine():
    """The nominal machine with kappa 3 at every joint, its model and coordinates."""
    core = CoreModel(load_config())
    ps = core.parameters
    values = ps.values(ps.nominal)
    values[[ps.index(f'kappa{k}') for k in (1, 2, 3)]] = 3.0
    return core, ps.coordinates(values)


def test_untilted_poses_free_kappa_only_fail_the_gate(capsys, tmp_path):
    core, theta = machine()
    cfg = core.config
    level = naive_inverse(np.linspace(0.02, 0.48, 20), np.zeros(20), np.zeros(20), cfg)
    assert np.ptp(level, axis=1).max() < 1e-12                                   # q1 = q2 = q3: no tilt
    p3, _ = evaluate(core, theta, level)
    p1000, _ = evaluate(core, core.parameters.nominal, level)
    assert np.abs(p3 - p1000).max() < 1e-12                                      # kappa does not act there
    meas = synthetic_measurements(core, theta, level, 3e-6, 2e-5, seed=4)
    res = identify(core, meas, free=['kappa'])
    check = {c.name: c for c in res.gate.checks}['identified']
    assert not check.passed and check.value == 0.0 and not res.gate.passed
    assert 'kappa1' in check.detail and 'nothing was calibrated' in check.detail
    path = write_measurements(tmp_path / 'level.csv', meas)
    status, out, err = run(capsys, 'calibrate', str(path), '--free', 'kappa', '--output', str(tmp_path / 'k.yaml'),
                           '--no-progress')
    assert status == 1 and not (tmp_path / 'k.yaml').exists()
    assert err == ('gpr calibrate: the fit failed its gate: No free parameter of the machine is identifiable from '
                   'these measurements (kappa3, kappa2, kappa1 held at nominal): nothing was calibrated. Measure '
                   'configurations that move them (gpr calibrate --plan N), or free others (--free). no file written '
                   '(--force writes it anyway)\n'), err


def test_a_fit_that_identifies_parameters_passes_the_check(capsys, tmp_path):
    core, theta = machine()
    tilted = naive_inverse(np.linspace(0.02, 0.48, 20), np.full(20, 0.9 * core.config.tilt_limit),
                           np.linspace(0.0, 2.0 * np.pi, 20, endpoint=False), core.config)
    meas = synthetic_measurements(core, theta, tilted, 3e-6, 2e-5, seed=4)
    path = write_measurements(tmp_path / 'tilted.csv', meas)
    status, out, err = run(capsys, 'calibrate', str(path), '--free', 'kappa', '--output', str(tmp_path / 'k.yaml'),
                           '--no-progress', '--json')
    assert status == 0, err
    data = json.loads(out)
    check = {c['name']: c for c in data['gate']['checks']}['identified']
    assert check['passed'] and check['value'] == 3.0 and check['limit'] == 1.0 and check['at_least']
    kappas = [p['estimate'] for p in data['parameters'] if p['name'].startswith('kappa')]
    assert np.allclose(kappas, 3.0, rtol=0.2)                                   # the truth, not the nominal 1000


def test_every_parameter_fixed_on_purpose_passes_the_check():
    """``free=[]`` (every parameter of the machine fixed on purpose: a check of the nominal geometry) is no failure to
    identify: the check passes at a limit of 0 (it failed with 'No free parameter ... ( held at nominal)')."""
    core, theta = machine()
    tilted = naive_inverse(np.linspace(0.02, 0.48, 20), np.full(20, 0.9 * core.config.tilt_limit),
                           np.linspace(0.0, 2.0 * np.pi, 20, endpoint=False), core.config)
    meas = synthetic_measurements(core, core.parameters.nominal, tilted, 3e-6, 2e-5, seed=4)
    res = identify(core, meas, free=[])
    check = {c.name: c for c in res.gate.checks}['identified']
    assert (check.passed, check.value, check.limit, check.detail) == (True, 0.0, 0.0, '')
    assert set(res.status) == {'fixed'} and res.gate.passed


def test_robot_free_of_one_arm_passes_the_other_arm(capsys, tmp_path):
    """``gpr calibrate --robot`` with both arms' files and ``--free`` of arm1's elbow only: arm2, every parameter fixed
    on purpose, failed the gate ('No free parameter of the machine is identifiable from these measurements ( held at
    nominal)'), exit 1 and no file."""
    from test_calibration_arm import measured, rows, write
    robot = load_robot()
    files = []
    for k, name in enumerate(('arm1', 'arm2')):
        ps = arm_parameters(robot.arm(name))
        Q, J = rows(robot, robot.arm(name), 40, 1 + k)
        files.append(write(tmp_path / f'{name}.csv', robot,
                           measured(robot, name, ps.values(ps.nominal), Q, J, np.ones(40, dtype=bool), 2 + k)))
    out = tmp_path / 'robot.yaml'
    status, text, err = run(capsys, 'calibrate', '--robot', robot.source, *files, '--output', str(out),
                            '--free', 'arm1_elbow_length', '--no-progress', '--json')
    assert status == 0 and out.exists(), err
    checks = {a['arm']: {c['name']: c for c in a['gate']['checks']}['identified'] for a in json.loads(text)['arms']}
    assert {arm: (c['passed'], c['value'], c['limit']) for arm, c in checks.items()} == \
        {'arm1': (True, 1.0, 1.0), 'arm2': (True, 0.0, 0.0)}

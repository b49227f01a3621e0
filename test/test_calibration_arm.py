"""The arms' calibration (gpr_kinematics.calibration.arm, gpr calibrate --robot): link lengths off by 50 um and zero
offsets off by 100 urad identified to the noise level from measured wafer centres and blade points at several arm
configurations and platform poses; the calibrated robot file used with --robot (its forward and inverse kinematics,
the URDF) reproduces the identified arm; bad files refused in one line."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from gpr_kinematics.calibration.arm import ArmMeasurements, ArmModel, arm_parameters, arm_with, read_arm_measurements
from gpr_kinematics.calibration.identification import identify
from gpr_kinematics.calibration.measurements import Measurements
from gpr_kinematics.calibration.synthetic import synthetic_measurements
from gpr_kinematics.cli.main import main
from gpr_kinematics.core import naive_inverse
from gpr_kinematics.errors import InputError
from gpr_kinematics.robot import solve_stations
from gpr_kinematics.robot.description import load_robot
from gpr_kinematics.robot.forward import platform_to_blade, robot_forward
from gpr_kinematics.robot.stations import stations_from_poses
from gpr_kinematics.robot.urdf import robot_urdf

SIGMA = 5e-6
BLADE_POINT = (0.05, 0.03, 0.0)


def run(capsys, *argv):
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def rows(robot, arm, n, seed):
    """``n`` random rods (heights, tilts up to the limit) and arm joints within 80 % of their ranges."""
    rng = np.random.default_rng(seed)
    cfg = robot.config
    Q = naive_inverse(rng.uniform(0.05, 0.45, n), rng.uniform(0.0, 0.99, n) * cfg.tilt_limit,
                      rng.uniform(-np.pi, np.pi, n), cfg)
    return Q, rng.uniform(0.8 * arm.lower, 0.8 * arm.upper, (n, len(arm.joints)))


def measured(robot, name, truth, Q, J, on_blade, seed):
    """Points of the machine ``truth`` (the arm's parameter values) with tracker noise, as the file would give them."""
    n = len(Q)
    blade = np.where(on_blade[:, None], BLADE_POINT, 0.0)
    lines = tuple(range(2, n + 2))
    model = ArmModel(robot, ArmMeasurements(Measurements('x', Q, np.zeros((n, 3)), None, None, None, lines), name, J,
                                            blade, on_blade))
    points = synthetic_measurements(model, model.parameters.coordinates(truth), Q, SIGMA, 1e-5, seed=seed,
                                    points=True)
    return ArmMeasurements(points, name, J, blade, on_blade)


def write(path, robot, meas):
    arm = robot.arm(meas.arm)
    blade = bool(meas.on_blade.any())
    cols = ['q1', 'q2', 'q3', *arm.joint_names, 'x', 'y', 'z', 'sigma_position'] + (['bx', 'by', 'bz'] if blade else [])
    lines = [','.join(cols)]
    for i in range(len(meas.joints)):
        row = [*meas.points.q[i], *meas.joints[i], *meas.points.position[i], SIGMA] + (list(meas.blade[i]) if blade
                                                                                       else [])
        lines.append(','.join(repr(float(v)) for v in row))
    path.write_text('\n'.join(lines) + '\n')
    return str(path)


@pytest.fixture(scope='module')
def arm_case():
    robot = load_robot()
    arm = robot.arm('arm1')
    ps = arm_parameters(arm)
    truth = ps.values(ps.nominal).copy()
    rng = np.random.default_rng(4)
    for j, p in enumerate(ps):
        if p.key == 'length':
            truth[j] += 50e-6 * rng.choice([-1.0, 1.0])
        elif p.key == 'zero_offset':
            truth[j] += 100e-6 * rng.choice([-1.0, 1.0])
    Q, J = rows(robot, arm, 80, 1)
    on_blade = np.arange(80) % 2 == 1                        # half the rows a blade point, half the wafer centre
    return robot, ps, truth, measured(robot, 'arm1', truth, Q, J, on_blade, 2)


def test_every_parameter_row_is_the_arm_of_those_values_through_the_robot_core(arm_case):
    """``ArmModel.on_platform`` evaluates all rows of ``theta`` at once (blade_chain with per-row parameters); each
    row equals the robot core's chain of the arm with that row's values (``arm_with``, ``platform_to_blade``, one row
    at a time as before) to the last bit, blade points and wafer centres alike, on 4-joint arms too."""
    robot, ps, _, meas = arm_case
    cases = [(ArmModel(robot, meas), meas)]
    arm2 = robot.arm('arm2')
    Q, J = rows(robot, arm2, 12, 7)
    on = np.arange(12) % 3 == 0
    m2 = ArmMeasurements(Measurements('x', Q, np.zeros((12, 3)), None, None, None, tuple(range(2, 14))), 'arm2', J,
                         np.where(on[:, None], BLADE_POINT, np.nan), on)
    cases.append((ArmModel(robot, m2), m2))
    rng = np.random.default_rng(11)
    for model, m in cases:
        params = model.parameters
        theta = params.nominal + rng.normal(0.0, 3.0, (9, len(params)))   # a few a-priori sigmas off, every row
        pos, rot = model.poses(theta, np.broadcast_to(m.points.q, (9,) + m.points.q.shape))
        p0, R0 = model.platform(m.points.q)
        for s, values in enumerate(params.values(theta)):
            blade, wafer = platform_to_blade(arm_with(model.arm, values), m.joints)
            point = np.where(m.on_blade[:, None], blade.apply(np.nan_to_num(m.blade)), wafer.position)
            np.testing.assert_array_equal(pos[s], p0 + np.einsum('nij,nj->ni', R0, point))
            np.testing.assert_array_equal(rot[s], R0 @ blade.rotation)


def test_links_and_zero_offsets_identified_to_the_noise(arm_case):
    robot, ps, truth, meas = arm_case
    model = ArmModel(robot, meas)
    res = identify(model, meas.points)
    assert res.gate.passed and set(res.status) == {'fitted'}
    z = (res.values - truth) / res.value_standard_error
    assert np.all(np.abs(z) < 3.0), dict(zip(ps.names, z.round(2), strict=True))
    se = dict(zip(ps.names, res.value_standard_error, strict=True))
    assert max(se[f'{n}_length'] for n in robot.arm('arm1').joint_names) < 2e-6           # 50 um found to ~1 um
    assert max(se[f'{n}_zero_offset'] for n in robot.arm('arm1').joint_names[:2]) < 10e-6  # 100 urad to < 10 urad
    assert 1.4 * SIGMA < res.after.rms_position < 2.0 * SIGMA                               # sqrt(3) sigma
    assert res.before.rms_position > 10 * SIGMA
    # new arm configurations and platform poses: the identified arm predicts the wafer to the noise level
    Q, J = rows(robot, robot.arm('arm1'), 200, 9)
    new = measured(robot, 'arm1', truth, Q, J, np.zeros(200, dtype=bool), 0)
    held_out = ArmModel(robot, new)
    e = held_out.poses(res.estimate[None], Q[None])[0][0] - held_out.poses(ps.coordinates(truth)[None], Q[None])[0][0]
    assert np.sqrt(np.mean(np.sum(e ** 2, axis=1))) < SIGMA


def test_wafer_centres_alone_hold_what_they_cannot_separate(arm_case):
    """Without blade points, the last link, the last zero offset and the wafer centre are one planar vector: two of
    them held and said so; the wafer still predicted to the noise level at the measured rows."""
    robot, ps, truth, meas = arm_case
    keep = ~meas.on_blade
    p = meas.points
    only = ArmMeasurements(Measurements(p.source, p.q[keep], p.position[keep], None, p.sigma_position[keep], None,
                                        tuple(np.array(p.lines)[keep])), 'arm1', meas.joints[keep], meas.blade[keep],
                           meas.on_blade[keep])
    res = identify(ArmModel(robot, only), only.points)
    held = set(res.identifiability.held)
    assert len(held) == 2 and held <= {'arm1_wrist_length', 'arm1_wrist_zero_offset', 'arm1_wafer_x', 'arm1_wafer_y'}
    assert res.gate.passed and res.after.rms_position < 2.0 * SIGMA


def test_links_millimetres_off_converge_from_nominal(arm_case):
    """Links 2 mm off their drawing (the shoulder's longer, the elbow's shorter) and zero offsets 3 mrad: no held
    parameter of an arm bounds another (the GPR's joints held at nominal did, off its radius), so the fit from the
    nominal arm converges in 4 iterations; with blade points every value within 3 standard errors, from wafer centres
    alone (the last link and its zero offset held at nominal, the wafer centre takes them) the wafer predicted at new
    configurations within the noise (2.2 um, as for the drawing's arm). A millimetre more (3 mm with the 3 mrad) moves
    a wafer 1.009 cm off the nominal arm's: refused before any fit (the plausibility check's 1 cm)."""
    robot, ps, truth, meas = arm_case
    arm = robot.arm('arm1')
    off = truth.copy()
    for j, p in enumerate(ps):
        off[j] += {'length': 2e-3 * (1.0 if j % 4 == 0 else -1.0), 'zero_offset': 3e-3}.get(p.key, 0.0)
    moved = measured(robot, 'arm1', off, meas.points.q, meas.joints, meas.on_blade, 2)
    res = identify(ArmModel(robot, moved), moved.points)
    assert res.gate.passed and res.convergence.status == 'converged' and res.iterations == 4
    z = (res.values - off) / res.value_standard_error
    assert np.all(np.abs(z) < 3.0), dict(zip(ps.names, z.round(2), strict=True))
    wafer = ArmMeasurements(*_rows(moved, ~moved.on_blade))
    res = identify(ArmModel(robot, wafer), wafer.points)
    assert res.gate.passed and res.iterations == 4 and len(res.identifiability.held) == 2
    Q, J = rows(robot, arm, 200, 9)
    new = ArmModel(robot, measured(robot, 'arm1', off, Q, J, np.zeros(200, dtype=bool), 0))
    e = new.poses(res.estimate[None], Q[None])[0][0] - new.poses(ps.coordinates(off)[None], Q[None])[0][0]
    assert np.sqrt(np.mean(np.sum(e ** 2, axis=1))) < SIGMA
    for j, p in enumerate(ps):
        off[j] += 1e-3 * (1.0 if j % 4 == 0 else -1.0) if p.key == 'length' else 0.0
    far = measured(robot, 'arm1', off, meas.points.q, meas.joints, meas.on_blade, 2)
    refusal = r"synthetic line 41: the measured point is 0\.01009 m from the nominal model's \(allowed: 0\.01 m\)"
    with pytest.raises(InputError, match=refusal):
        identify(ArmModel(robot, far), far.points)


def test_calibrated_robot_file_with_robot(arm_case, capsys, tmp_path):
    robot, ps, truth, meas = arm_case
    wafer = meas.on_blade == 0
    files = [write(tmp_path / 'w.csv', robot, ArmMeasurements(*_rows(meas, wafer))),
             write(tmp_path / 'b.csv', robot, ArmMeasurements(*_rows(meas, ~wafer)))]
    out = tmp_path / 'robot.yaml'
    status, text, err = run(capsys, 'calibrate', '--robot', robot.source, *files, '--output', str(out), '--json')
    assert status == 0, err
    d = json.loads(text)
    (arm,) = d['arms']
    assert arm['arm'] == 'arm1' and arm['gate']['passed'] and arm['rows'] == 80
    # the standard errors take the GPR as exact, and say so (a calibrated GPR's heading, a few urad off, put a
    # shoulder's zero offset 4 of them off, without a word)
    assert "the arms' standard errors take the GPR's geometry (--config, else the robot's) as exact" in d['note']
    cal = load_robot(out)
    joints = cal.arm('arm1').joints
    est = {p['name']: p['estimate'] for p in arm['parameters']}
    assert [j.zero_offset for j in joints] == [est[f'{j.name}_zero_offset'] for j in joints]
    assert [j.length for j in joints] == [est[f'{j.name}_length'] for j in joints]
    assert cal.arm('arm2') == robot.arm('arm2') and cal.config == robot.config
    # the robot core with the calibrated file: the identified model's wafer (in gpr_base) at the measured rows
    model = ArmModel(robot, meas)
    ours = model.poses(model.parameters.coordinates(np.array([est[n] for n in ps.names]))[None],
                       meas.points.q[None])[0][0]
    fk = robot_forward(cal, meas.points.q, meas.joints, 'arm1', check_limits=False)
    base = fk.platform.compose(fk.wafer_on_platform)
    from gpr_kinematics.robot.forward import base_pose
    in_base = base_pose(cal, len(wafer)).inverse_apply(base.position)
    np.testing.assert_allclose(in_base[wafer], ours[wafer], rtol=0, atol=1e-12)
    # station inverse kinematics with the zero offsets: forward of its joints reproduces the station
    st = stations_from_poses(fk.wafer.position[:4], fk.wafer.rotation[:4])
    sol = solve_stations(cal, st, arm='arm1', check=False)
    again = robot_forward(cal, sol.rods, sol.joints, 'arm1', check_limits=False)
    np.testing.assert_allclose(again.wafer.position, st.position, rtol=0, atol=1e-11)
    # the URDF's joint origins carry the offsets: its chain is the core's
    urdf = robot_urdf(cal)
    elbow = urdf.joint('arm1_elbow')
    assert elbow.rpy[2] == pytest.approx(joints[1].zero_offset, abs=1e-15)
    status, text, err = run(capsys, 'robot', 'fk', '--rods', '0.25', '0.251', '0.252', '--joints', '0', '1', '-0.5',
                            '--robot', str(out), '--json')
    assert status == 0, err
    expected = robot_forward(cal, [[0.25, 0.251, 0.252]], [[0.0, 1.0, -0.5]], 'arm1').wafer.position[0]
    np.testing.assert_allclose(json.loads(text)['wafer']['position'], expected, rtol=0, atol=1e-12)


def _rows(meas, keep):
    p = meas.points
    pts = Measurements(p.source, p.q[keep], p.position[keep], None, p.sigma_position[keep], None,
                       tuple(np.array(p.lines)[keep]))
    return pts, meas.arm, meas.joints[keep], meas.blade[keep], meas.on_blade[keep]


def test_arm_refusals(arm_case, capsys, tmp_path):
    robot, ps, truth, meas = arm_case
    good = write(tmp_path / 'g.csv', robot, meas)
    text = Path(good).read_text().splitlines()
    both = tmp_path / 'both.csv'
    both.write_text(text[0].replace('arm1_wrist', 'arm2_wrist') + '\n' + '\n'.join(text[1:]) + '\n')
    deg = tmp_path / 'deg.csv'
    deg.write_text('\n'.join([text[0]] + [','.join(v if k not in (3, 4, 5) else repr(float(v) * 60)
                                                   for k, v in enumerate(ln.split(','))) for ln in text[1:]]) + '\n')
    cases = [
        (['--robot', robot.source, str(both), '--output', 'x.yaml'], r'the joint columns must be those of one arm'),
        (['--robot', robot.source, str(deg), '--output', 'x.yaml'], r'line \d+, column arm1_\w+: .* rad is outside its '
                                                                    r'limits .*declare "# units: deg"'),
        (['--robot', robot.source, good], r'--output FILE is required'),
        (['--robot', robot.source, good, '--output', 'x.yaml', '--target', '0', '0', '0'], r'--target and --fit-target '
                                                                                          r'are for the GPR'),
        (['--robot', robot.source, good, '--output', 'x.yaml', '--free', 'rod1_x'], r'--free: unknown parameter\(s\) '
                                                                                    r'rod1_x'),
        (['--robot', robot.source, '--plan', '4'], r'--plan is for the GPR'),
        # --base in the world frame replaced the description's base unsaid (and in gpr_base: not the identity)
        (['--robot', robot.source, good, '--output', 'x.yaml', '--frame', robot.world_frame, '--base',
          *map(str, robot.base_position), '0', '0', '0.1'], r'--base gives the pose of gpr_base in --frame, which is '
                                                             r'world, the world frame where the robot description'),
        (['--robot', robot.source, good, '--output', 'x.yaml', '--base', '0', '0', '0.001', '0', '0', '0'],
         r'--base gives the pose of gpr_base in --frame, which is gpr_base itself'),
    ]
    for argv, pattern in cases:
        status, _, err = run(capsys, 'calibrate', *argv)
        assert status == 2 and err.count('\n') == 1 and 'Traceback' not in err, (argv, err)
        assert re.search(pattern, err), (argv, err)
    with pytest.raises(Exception, match='joint columns'):
        read_arm_measurements(both, robot)
    # joints in radians under a '# units: m deg' line: the refusal names that line's angle unit among the causes
    wdeg = tmp_path / 'wdeg.csv'
    wdeg.write_text('# units: m deg\n' + '\n'.join(text) + '\n')
    status, _, err = run(capsys, 'calibrate', '--robot', robot.source, str(wdeg), '--output', 'x.yaml')
    assert status == 2 and err.count('\n') == 1, err
    assert re.fullmatch(r"gpr calibrate: error: .*wdeg\.csv line 3: the measured point is [\d.]+ m from the nominal "
                        r"model's \(allowed: 0\.01 m\): not a measurement of this machine in gpr_base in the units "
                        r"it declares \(m and rad where it names none\) "
                        r"\(another frame than gpr_base.*: correct the nominal model first\); or its '# units:' line's "
                        r"angle unit \(deg\) not the joints'\n", err), err
    # an empty file: the header's joint columns named too, as for a header without them (only q1,q2,q3,x,y,z were)
    empty = tmp_path / 'e.csv'
    empty.write_text('')
    wanted = '; '.join(f'{a.name}: {", ".join(a.joint_names)}' for a in robot.arms)
    status, _, err = run(capsys, 'calibrate', '--robot', robot.source, str(empty), '--output', 'x.yaml')
    assert status == 2 and err == (f'gpr calibrate: error: {empty}: the file is empty; the first line that is not a '
                                   'comment must name the columns (q1,q2,q3,x,y,z); the joint columns must be those '
                                   f'of one arm of {robot.name} ({wanted})\n'), err


def test_rows_of_merged_files_named_by_file_and_line(arm_case, capsys, tmp_path):
    """An arm's files merged both have a line 40: every message citing a row names its file (the outlier and the
    worst residuals of the gate, the report and the JSON; a pose implausibly far; a repeated row), not the line
    alone."""
    robot, ps, truth, meas = arm_case
    wafer = meas.on_blade == 0
    w = write(tmp_path / 'w.csv', robot, ArmMeasurements(*_rows(meas, wafer)))
    b = write(tmp_path / 'b.csv', robot, ArmMeasurements(*_rows(meas, ~wafer)))
    rows_b, rows_w = Path(b).read_text().splitlines(), Path(w).read_text().splitlines()

    def with_line_40(values):
        path = tmp_path / 'bad.csv'
        path.write_text('\n'.join(rows_b[:39] + [','.join(map(str, values))] + rows_b[40:]) + '\n')
        return str(path)

    row = [float(v) for v in rows_b[39].split(',')]
    z = 3 + 3 + 2                                                     # q1..q3, three joints, x y z
    bad = with_line_40(row[:z] + [row[z] + 100e-6] + row[z + 1:])     # 20 sigma in z
    status, text, err = run(capsys, 'calibrate', '--robot', robot.source, w, bad, '--output',
                            str(tmp_path / 'r.yaml'))
    assert status == 1 and not (tmp_path / 'r.yaml').exists()
    assert re.search(rf'Line 40 of {re.escape(bad)} is an outlier: its z residual is 21 standard', err), err
    assert f'largest residuals line 40 of {bad} (' in err
    assert re.search(rf'^  after +\d+\.\d+ um +\d+\.\d+ um \(line 40 of {re.escape(bad)}\)', text, re.M), text
    status, text, err = run(capsys, 'calibrate', '--robot', robot.source, w, bad, '--output',
                            str(tmp_path / 'r.yaml'), '--json')
    after = json.loads(text)['arms'][0]['residuals']['after']
    assert (after['worst_position_line'], after['worst_position_file']) == (40, bad)
    far = with_line_40(row[:z] + [row[z] + 0.02] + row[z + 1:])       # 2 cm: not a measurement of this machine
    status, _, err = run(capsys, 'calibrate', '--robot', robot.source, w, far, '--output', str(tmp_path / 'r.yaml'))
    assert status == 2, err
    assert re.match(rf'gpr calibrate: error: {re.escape(far)} line 40: the measured point is 0\.02', err), err
    copy = [float(v) for v in rows_w[39].split(',')]                  # w.csv's line 40 measured again, to 1e-15
    again = with_line_40(copy[:-1] + [copy[-1] * (1 + 1e-15)] + row[-3:])
    status, _, err = run(capsys, 'calibrate', '--robot', robot.source, w, again, '--output', str(tmp_path / 'r.yaml'))
    assert status == 2 and f'{w} + {again}: line 40 of {again} repeats line 40 of {w}: the same rod lengths' in err, err


def test_a_last_link_of_no_length_is_never_fitted_below_zero():
    """The shipped arm1's wrist has no length; with that truth the fit put it below 0 about half the time (-1.7e-7
    m), and the calibrated robot file it wrote was refused by the loader. The lengths are bounded by the
    description's rule now (>= 0 for the last link, >= 1e-6 m for the others): at 0 the parameter is reported at a
    bound, and the file loads."""
    robot = load_robot()
    arm = robot.arm('arm1')
    ps = arm_parameters(arm)
    wrist = ps.names.index('arm1_wrist_length')
    assert ps[wrist].bounds == (0.0, 5.0) and ps[ps.names.index('arm1_shoulder_length')].bounds == (1e-6, 5.0)
    truth = ps.values(ps.nominal).copy()
    truth[ps.names.index('arm1_elbow_length')] += 40e-6
    at_zero = 0
    for seed in range(6):
        Q, J = rows(robot, arm, 40, 20 + seed)
        meas = measured(robot, 'arm1', truth, Q, J, np.arange(40) % 2 == 1, 30 + seed)
        res = identify(ArmModel(robot, meas), meas.points)
        assert res.values[wrist] >= 0.0
        if res.values[wrist] == 0.0:
            at_zero += 1
            assert 'arm1_wrist_length' in res.convergence.at_bound
    assert 0 < at_zero < 6      # the unbounded fit's sign was a coin: some runs end at the bound, some above it


def test_two_joint_columns_swapped_in_one_file_are_hinted(arm_case, capsys, tmp_path):
    """A trial's arm file whose header named arm1_elbow before arm1_shoulder over columns written the other way got
    only 'another frame than gpr_base ...' (the GPR's files name swapped x, y, z or q columns): each pair of joint
    columns of each file is tried, the other files read as they are, and the swap that makes every row fit the
    nominal model is named with its file. Here the blade file's first two joint columns swapped, the wafer file
    right: read as written the points are 276 mm RMS off; swapped back, 145 um (the arm's 50 um and 100 urad: the
    nominal model's error at the file's points as measured)."""
    robot, ps, truth, meas = arm_case
    wafer = meas.on_blade == 0
    w = write(tmp_path / 'w.csv', robot, ArmMeasurements(*_rows(meas, wafer)))
    b = write(tmp_path / 'b.csv', robot, ArmMeasurements(*_rows(meas, ~wafer)))
    lines = Path(b).read_text().splitlines()
    assert lines[0].startswith('q1,q2,q3,arm1_shoulder,arm1_elbow,arm1_wrist,')
    swapped = tmp_path / 'swapped.csv'
    swapped.write_text('\n'.join([lines[0].replace('arm1_shoulder,arm1_elbow', 'arm1_elbow,arm1_shoulder')]
                                 + lines[1:]) + '\n')
    status, _, err = run(capsys, 'calibrate', '--robot', robot.source, w, str(swapped), '--output',
                         str(tmp_path / 'r.yaml'))
    nominal = ArmModel(robot, meas)
    error = nominal.poses(nominal.parameters.nominal[None], meas.points.q[None])[0][0] - meas.points.position
    assert np.sqrt(np.mean(np.sum(error ** 2, axis=1))) == pytest.approx(145e-6, abs=0.5e-6)
    assert status == 2 and err.count('\n') == 1, err
    assert err.endswith(f'; the points fit this machine with columns arm1_shoulder and arm1_elbow of {swapped} '
                        'swapped: RMS 145 um from the nominal model\'s against 276 mm as read; check the header\'s '
                        'column names)\n'), err
    status, _, err = run(capsys, 'calibrate', '--robot', robot.source, str(swapped), w, '--output',
                         str(tmp_path / 'r.yaml'))   # the swapped file first: named the same
    assert status == 2 and f'columns arm1_shoulder and arm1_elbow of {swapped} swapped: RMS 145 um' in err, err

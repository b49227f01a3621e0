"""The GPR's calibration uncertainty in the arms' standard errors (gpr_kinematics.calibration.arm_gpr, gpr calibrate
--robot --config FILE with its covariance block): the propagated covariance ``K Sigma_g K^T`` against a Monte Carlo
of GPR calibrations from noisy poses, the truth covered where the plain standard errors missed it by up to 8 of them,
the report and the note with and without the block."""
from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pytest
from gpr_kinematics.calibration import demo
from gpr_kinematics.calibration.arm import ArmModel, arm_parameters
from gpr_kinematics.calibration.arm_gpr import (
    ResidualShare,
    gain,
    gpr_gain,
    weighted_jacobians,
    weighted_residuals,
    with_gpr_covariance,
)
from gpr_kinematics.calibration.chi2_mixture import quantile
from gpr_kinematics.calibration.core_model import CoreModel, fitted_covariance, write_calibrated_config
from gpr_kinematics.calibration.frames import Transform, measuring_model
from gpr_kinematics.calibration.identification import identify, weights
from gpr_kinematics.calibration.measurements import Measurements
from gpr_kinematics.calibration.quality import CHI2_QUANTILE, Gate, GateCheck
from gpr_kinematics.calibration.synthetic import synthetic_measurements
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.geometry_covariance import GeometryCovariance
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs import safe_yaml
from gpr_kinematics.inputs.schema import read_yaml
from gpr_kinematics.robot.description import load_robot
from scipy.stats import chi2 as chi2_distribution
from test_calibration_arm import SIGMA, measured, rows, run, write

#: GPR calibrations of the Monte Carlo, from the first 15 rows of the shipped file's configurations at 5 um / 20 urad.
RUNS = 100
GPR_ROWS = 15


def arm_truth(robot):
    """arm1 with its links off by 50 um and its zero offsets by 100 urad (the arm tests' machine)."""
    ps = arm_parameters(robot.arm('arm1'))
    truth = ps.values(ps.nominal).copy()
    rng = np.random.default_rng(4)
    for j, p in enumerate(ps):
        if p.key in ('length', 'zero_offset'):
            truth[j] += (50e-6 if p.key == 'length' else 100e-6) * rng.choice([-1.0, 1.0])
    return ps, truth


def propagated(robot, meas, gpr_cov):
    """The arm's fit with ``robot``'s GPR and the fit with the GPR's covariance added (its gate judged with it)."""
    model = ArmModel(robot, meas)
    res = identify(model, meas.points)
    w = weights(meas.points, SIGMA, 1e-5)[0]
    A, B = weighted_jacobians(model, model, res, gpr_cov, w)
    K = gpr_gain(model, model, res, gpr_cov, w)
    assert np.array_equal(K, gain(A, B))
    share = ResidualShare.of(A, B, gpr_cov)
    gate = share.gate(res, weighted_residuals(model, model, res, w), meas.points.row_names)
    return res, with_gpr_covariance(res, K, gpr_cov, gate), share


@pytest.fixture(scope='module')
def monte_carlo():
    """Per GPR calibration: the arm fitted with the same measured points (its scatter is the GPR's alone) and with
    fresh ones; the estimates, plain and propagated standard errors."""
    core = CoreModel(load_config())
    true = core.parameters.coordinates(demo.true_values(core))
    robot_true = load_robot(geometry=core.config_for(true))
    ps, truth = arm_truth(robot_true)
    Qg = demo.shipped_measurements().q[:GPR_ROWS]
    Q, J = rows(robot_true, robot_true.arm('arm1'), 80, 1)
    on_blade = np.arange(80) % 2 == 1
    fixed = measured(robot_true, 'arm1', truth, Q, J, on_blade, 2)
    out = {k: {'est': [], 'plain': [], 'total': [], 'added': [], 'passed': [], 'judged': [], 'chi2': [], 'mean': [],
               'var': [], 'warned': [], 'chi_ok': []} for k in ('fixed', 'fresh')}
    for r in range(RUNS):
        gpr = identify(core, synthetic_measurements(core, true, Qg, 5e-6, 2e-5, seed=100 + r))
        cov = fitted_covariance(core, gpr)
        robot = load_robot(geometry=core.config_for(gpr.estimate))
        for kind, meas in (('fixed', fixed), ('fresh', measured(robot_true, 'arm1', truth, Q, J, on_blade, 1000 + r))):
            plain, total, share = propagated(robot, meas, cov)
            assert np.array_equal(plain.estimate, total.estimate)
            o = out[kind]
            o['passed'].append(plain.gate.passed)
            o['judged'].append(total.gate.passed)
            o['warned'].append(any("passes only with the GPR's calibration error" in w for w in total.warnings))
            o['chi_ok'].append(next(c for c in plain.gate.checks if c.name == 'chi_square').passed)
            o['chi2'].append(plain.chi2_reduced)
            o['mean'].append(share.mean)            # E chi2_red = tr C / dof
            o['var'].append(2.0 * (share.dof + np.sum((1.0 + share.excess) ** 2 - 1.0)) / share.dof ** 2)   # 2 tr C^2
            o['est'].append(plain.values)
            o['plain'].append(plain.standard_error)
            o['total'].append(total.standard_error)
            o['added'].append(total.standard_error ** 2 - plain.standard_error ** 2)
    return ps, truth, {k: {n: np.array(v) for n, v in o.items()} for k, o in out.items()}


@pytest.mark.slow   # 100 GPR and 200 arm calibrations (40-110 s); the stock run fits both in the others
def test_the_propagated_covariance_is_the_scatter_of_arms_fitted_with_gpr_calibrations(monte_carlo):
    """With the arm's points fixed, its estimate scatters over the GPR's calibrations as ``K Sigma_g K^T`` says
    (within 20 % where the GPR's share is at least the noise's: the shoulder's zero offset, the mount, the wafer's
    height); with fresh points too, every parameter as its propagated standard error says."""
    ps, _, mc = monte_carlo
    fixed, fresh = mc['fixed'], mc['fresh']
    ratio = fixed['est'].std(axis=0, ddof=1) / np.sqrt(fixed['added'].mean(axis=0))
    big = fixed['added'].mean(axis=0) >= (fixed['plain'] ** 2).mean(axis=0)
    names = [n for n, b in zip(ps.names, big, strict=True) if b]
    assert {'arm1_shoulder_zero_offset', 'arm1_mount_x', 'arm1_mount_y'} <= set(names), names
    assert np.all(np.abs(ratio[big] - 1.0) < 0.2), dict(zip(names, ratio[big].round(3), strict=True))
    total = fresh['est'].std(axis=0, ddof=1) / np.sqrt((fresh['total'] ** 2).mean(axis=0))
    assert np.all(np.abs(total - 1.0) < 0.2), dict(zip(ps.names, total.round(3), strict=True))
    plain = fresh['est'].std(axis=0, ddof=1) / np.sqrt((fresh['plain'] ** 2).mean(axis=0))
    assert plain[ps.index('arm1_shoulder_zero_offset')] > 1.5          # the plain ones: too small


@pytest.mark.slow   # 100 GPR and 200 arm calibrations (40-110 s); the stock run fits both in the others
def test_the_truth_within_three_propagated_standard_errors_where_the_plain_ones_missed(monte_carlo):
    ps, truth, mc = monte_carlo
    for kind in ('fixed', 'fresh'):
        o = mc[kind]
        z_plain = np.abs(o['est'] - truth) / o['plain']
        z = np.abs(o['est'] - truth) / o['total']
        k = ps.index('arm1_shoulder_zero_offset')
        missed = z_plain[:, k] > 3.0
        assert missed.mean() > 0.15 and z_plain[:, k].max() > 4.0, kind       # the docs' case: 4 of them off
        assert np.all(z[missed, k] < 3.0), kind
        assert np.all(z[:, k] < 3.0) and np.mean(z < 3.0) > 0.99, kind
        assert np.mean(z_plain < 3.0) < 0.96, kind


@pytest.mark.slow   # 100 GPR and 200 arm calibrations (40-110 s); the stock run fits both in the others
def test_the_gate_takes_the_gprs_error_in_the_residuals(monte_carlo):
    """The arms fitted to their noise failed their gate in 53 of 100 runs with a GPR calibrated from 15 poses (52 on
    the chi-square: the GPR's error is in the residuals too). Judged with it (``ResidualShare``: the chi-square
    against Satterthwaite's ``c chi^2_nu``, outliers studentized by the residuals' own variances) none fails; the
    reduced chi-square's mean and scatter over the runs are those the share predicts (``tr C / dof``, ``2 tr C^2 /
    dof^2``): 1.33 for 1.32, where an exact GPR's chi-square would be 1."""
    for kind in ('fixed', 'fresh'):
        o = monte_carlo[2][kind]
        assert o['passed'].sum() < 70 and o['judged'].all(), (kind, o['passed'].sum(), o['judged'].sum())
        # a fit that passes only with the GPR's error in its residuals says so (a trial's arms passed at reduced
        # chi-squares of 51 to 503 without a word)
        assert np.array_equal(o['warned'], o['judged'] & ~o['chi_ok']) and o['warned'].any(), kind
    o = monte_carlo[2]['fresh']
    assert o['chi2'].mean() == pytest.approx(o['mean'].mean(), rel=0.05) and o['mean'].mean() > 1.2
    assert o['chi2'].std(ddof=1) == pytest.approx(np.sqrt(o['var'].mean() + o['mean'].var()), rel=0.3)


def test_the_gate_with_the_gprs_error_still_finds_a_bad_row_and_a_wrong_model(files):
    """Judged with the GPR's error, a row 100 um off is still an outlier (named, studentized with the GPR's share),
    and points moved by up to 50 um row by row (another machine's) still fail the chi-square, naming the GPR's share."""
    robot_file, with_block, plain_file, arm_csv, cov, cfg, meas = files
    robot = load_robot(geometry=cfg)
    p = meas.points
    moved = p.position.copy()
    moved[7, 2] += 1e-4
    bad = type(meas)(Measurements(p.source, p.q, moved, None, p.sigma_position, None, p.lines), meas.arm,
                     meas.joints, meas.blade, meas.on_blade)
    _, total, _ = propagated(robot, bad, cov)
    check = next(c for c in total.gate.checks if c.name == 'outliers')
    assert not check.passed and f'Line {p.lines[7]} is an outlier' in check.detail
    assert "standard deviations (studentized with the GPR's share)" in check.detail
    off = p.position + 5e-5 * np.sin(np.arange(p.q.shape[0]))[:, None]
    shifted = type(meas)(Measurements(p.source, p.q, off, None, p.sigma_position, None, p.lines), meas.arm,
                         meas.joints, meas.blade, meas.on_blade)
    _, total, share = propagated(robot, shifted, cov)
    check = next(c for c in total.gate.checks if c.name == 'chi_square')
    assert not check.passed and check.limit == share.point(CHI2_QUANTILE)
    assert "with the GPR's calibration covariance in the residuals" in check.detail
    check = next(c for c in total.gate.checks if c.name == 'noise_chi_square')
    assert not check.passed and check.value > 10.0 * check.limit and check.detail.startswith(
        f"The residuals outside the {share.basis.shape[1]} direction(s) the GPR's calibration covariance occupies, "
        'which no error of the GPR or its registration reaches, exceed the noise: reduced chi-square')
    assert 'allowed: residuals within the declared noise (sigma columns, --sigma-position) there.' in check.detail


def test_the_noise_chi_square_is_the_residual_outside_the_shares_directions(files):
    """``noise_chi_square``: the residuals less their projection on the column space of ``P B Sigma_g^(1/2)`` built
    densely (its singular values above 1e-6 of the largest: the share's ``r`` directions, one per excess eigenvalue),
    over ``dof - r``, against the plain chi-square's 99.9 % point; the other checks' numbers as before. A share that
    fills every degree of freedom leaves it not judged (passed, NaN, saying why; JSON null)."""
    robot_file, with_block, plain_file, arm_csv, cov, cfg, meas = files
    model = ArmModel(load_robot(geometry=cfg), meas)
    res = identify(model, meas.points)
    w = weights(meas.points, SIGMA, 1e-5)[0]
    A, B = weighted_jacobians(model, model, res, cov, w)
    share = ResidualShare.of(A, B, cov)
    P = np.eye(A.shape[0]) - A @ np.linalg.pinv(A)
    lam, V = np.linalg.eigh(cov.matrix)
    U, s, _ = np.linalg.svd(P @ B @ (V * np.sqrt(np.clip(lam, 0.0, None))), full_matrices=False)
    Q = U[:, s > 1e-6 * s[0]]
    e = np.ravel(weighted_residuals(model, model, res, w))
    r = Q.shape[1]
    assert r == share.basis.shape[1] == share.excess.size and 0 < r < share.dof
    gate = share.gate(res, weighted_residuals(model, model, res, w), meas.points.row_names)
    names = [c.name for c in gate.checks]
    assert names[:4] == ['minimum', 'chi_square', 'gpr_covariance', 'noise_chi_square']
    check = gate.checks[3]
    assert check.passed and check.judged and check.detail == ''
    assert check.value == pytest.approx(float(np.sum((e - Q @ (Q.T @ e)) ** 2)) / (share.dof - r), rel=1e-9)
    assert check.limit == pytest.approx(chi2_distribution.ppf(CHI2_QUANTILE, share.dof - r) / (share.dof - r))
    assert check.value < gate.checks[1].value   # the share's directions carry the GPR's error
    full = dataclasses.replace(share, dof=3, basis=np.eye(e.size)[:, :3])
    alone = full.outside(weighted_residuals(model, model, res, w), '1')
    assert alone.passed and not alone.judged and math.isnan(alone.value) and math.isnan(alone.limit)
    assert alone.detail == ("noise chi square: the residuals have no degree of freedom outside the 3 direction(s) the "
                            "GPR's calibration covariance occupies (3 in all): only the mixture's chi-square judges "
                            'them; allowed: more rows.')
    assert Gate((alone,)).as_dict()['checks'][0]['value'] is None
    # a gate that failed names the failed check first, then the one not judged: a trial's 7 rows read "gate: FAILED:
    # noise chi square: ..." (which passed) with the failed cross-validation last
    failed = GateCheck('cross_validation', False, 3.0, 2.0, 'cross-validation: ratio 3 > 2.')
    gate = Gate((alone, failed))
    assert not gate.passed and gate.message() == f'{failed.detail} {alone.detail}'


@pytest.mark.parametrize('dof, within', [(1, 0.035), (2, 0.016), (10, 0.003), (229, 1e-4), (1000, 1e-5)])
def test_the_saddlepoints_points_of_one_chi_square(dof, within):
    """A plain chi-square's tail beyond the saddlepoint's 0.1 % points, by scipy: 0.097 % for 1 degree of freedom,
    within 1e-4 of 0.1 % from 229 on."""
    upper = quantile(CHI2_QUANTILE, np.array([1.0]), np.array([dof]))
    lower = quantile(1.0 - CHI2_QUANTILE, np.array([1.0]), np.array([dof]))
    assert abs(chi2_distribution.sf(upper, dof) / 1e-3 - 1.0) < within
    assert abs(chi2_distribution.cdf(lower, dof) / 1e-3 - 1.0) < 4.0 * within


@pytest.mark.slow
def test_the_points_of_a_mixture_hold_their_rates():
    """The reviewer's case (eigenvalues 1 + (25, 18, 6, 2, 0.5, 0.1) beyond 223 ones, a fit of 229 degrees of
    freedom): Satterthwaite's point let 0.48 % of honest fits fail where 0.1 % should; the saddlepoint's points are
    exceeded at 0.1 % above and below in 4 million draws (within 0.004 %, 2.5 standard deviations); a small mixture
    (3 + 2) and one with a weight a million times the others (a block in other units; Imhof's inversion failed on
    it) hold them within 10 % and 25 %, in milliseconds."""
    rng = np.random.default_rng(5)
    mu = np.array([25.0, 18.0, 6.0, 2.0, 0.5, 0.1])
    lam, h = np.concatenate([[1.0], 1.0 + mu]), np.concatenate([[223.0], np.ones(6)])
    draws = rng.chisquare(223, 4_000_000) + (rng.chisquare(1, (4_000_000, 6)) * (1.0 + mu)).sum(axis=1)
    assert abs(np.mean(draws > quantile(CHI2_QUANTILE, lam, h)) - 1e-3) < 4e-5
    assert abs(np.mean(draws < quantile(1.0 - CHI2_QUANTILE, lam, h)) - 1e-3) < 4e-5
    for weight, dofs, draws, within in (
            ((1.0, 5.0), (3.0, 2.0), rng.chisquare(3, 4_000_000) + 5.0 * rng.chisquare(2, 4_000_000), 0.1),
            ((1.0, 1e6 + 1), (100.0, 1.0), rng.chisquare(100, 4_000_000) + (1e6 + 1) * rng.chisquare(1, 4_000_000),
             0.25)):
        lam, h = np.array(weight), np.array(dofs)
        assert abs(np.mean(draws > quantile(CHI2_QUANTILE, lam, h)) / 1e-3 - 1.0) < within
        assert abs(np.mean(draws < quantile(1.0 - CHI2_QUANTILE, lam, h)) / 1e-3 - 1.0) < within


def test_the_share_is_the_dense_covariances_spectrum(files):
    """``C = P (I + B Sigma_g B^T) P`` built densely: its nonzero eigenvalues are ``dof - r`` ones and ``1 + mu_k``
    (to 1e-6), its diagonal the residuals' variances, and the gate's point at 99.9 % is exceeded by 0.1 % (within
    10 %) of a million draws of ``sum lambda_i chi^2_1`` over those eigenvalues."""
    robot_file, with_block, plain_file, arm_csv, cov, cfg, meas = files
    model = ArmModel(load_robot(geometry=cfg), meas)
    res = identify(model, meas.points)
    A, B = weighted_jacobians(model, model, res, cov, weights(meas.points, SIGMA, 1e-5)[0])
    share = ResidualShare.of(A, B, cov)
    P = np.eye(A.shape[0]) - A @ np.linalg.pinv(A)
    C = P @ (np.eye(A.shape[0]) + B @ cov.matrix @ B.T) @ P
    lam = np.sort(np.linalg.eigvalsh(0.5 * (C + C.T)))
    lam = lam[lam > 1e-6]
    expected = np.sort(np.concatenate([np.ones(share.dof - share.excess.size), 1.0 + share.excess]))
    assert lam.size == share.dof and share.excess.size > 0
    np.testing.assert_allclose(lam, expected, rtol=1e-6, atol=1e-9)   # Sigma_g clipped PSD: 4e-7 relative
    np.testing.assert_allclose(share.variance.ravel(), np.diag(C), rtol=1e-6, atol=1e-12)
    rng = np.random.default_rng(11)
    big = lam[lam > 1.0 + 1e-6]
    draws = rng.chisquare(lam.size - big.size, 1_000_000) + (rng.chisquare(1, (1_000_000, big.size)) * big).sum(axis=1)
    assert abs(np.mean(draws > share.point(CHI2_QUANTILE) * share.dof) / 1e-3 - 1.0) < 0.1


def test_a_covariance_block_in_other_units_fails_the_gate(files):
    """A reviewer's: the block in mm^2 (every entry 1e6 times) made the chi-square's limit 1e6 and another machine's
    points passed. Its residuals now lie far below what the block says: the gate fails on ``gpr_covariance``, naming
    the units; the block as written passes it, and a passed check says nothing. Without declared noise there is no
    such check (residuals below an assumed noise are no fault: a reviewer's quiet tracker failed it)."""
    robot_file, with_block, plain_file, arm_csv, cov, cfg, meas = files
    robot = load_robot(geometry=cfg)
    big = GeometryCovariance(cov.names, cov.matrix * 1e6, cov.source)
    _, total, share = propagated(robot, meas, big)
    check = next(c for c in total.gate.checks if c.name == 'gpr_covariance')
    assert not total.gate.passed and not check.passed and check.limit == share.point(1.0 - CHI2_QUANTILE)
    assert check.detail.startswith("The residuals are far smaller than the GPR's covariance block says: reduced "
                                   'chi-square') and 'a block in other units than SI (mm^2 for m^2?)' in check.detail
    plain, total, _ = propagated(robot, meas, cov)
    assert total.gate.passed and all(c.detail == '' for c in total.gate.checks)
    assert [c.name for c in total.gate.checks].count('gpr_covariance') == 1
    assumed = dataclasses.replace(plain, absolute_sigma=False)
    model = ArmModel(robot, meas)
    w = weights(meas.points, SIGMA, 1e-5)[0]
    share = ResidualShare.of(*weighted_jacobians(model, model, assumed, big, w), big)
    gate = share.gate(assumed, weighted_residuals(model, model, assumed, w), meas.points.row_names)
    assert 'gpr_covariance' not in [c.name for c in gate.checks]


def test_known_base_frame_rotates_the_gpr_jacobian():
    """Measured in the robot's world frame (the description's base: known), the GPR's share is as in gpr_base: the
    frame only turns the residuals."""
    core = CoreModel(load_config())
    robot = load_robot(geometry=core.config_for(core.parameters.coordinates(demo.true_values(core))))
    gpr = identify(core, synthetic_measurements(core, core.parameters.coordinates(demo.true_values(core)),
                                                demo.shipped_measurements().q[:GPR_ROWS], 5e-6, 2e-5, seed=7))
    cov = fitted_covariance(core, gpr)
    ps, truth = arm_truth(robot)
    Q, J = rows(robot, robot.arm('arm1'), 40, 3)
    meas = measured(robot, 'arm1', truth, Q, J, np.arange(40) % 2 == 1, 4)
    inner = ArmModel(robot, meas)
    base = Transform(np.asarray(robot.base_position, dtype=float), robot.base_rotation)
    assert not base.is_identity
    p = meas.points
    in_world = Measurements(p.source, p.q, p.position @ base.rotation.T + base.position, None, p.sigma_position, None,
                            p.lines)
    framed = measuring_model(inner, in_world, robot.world_frame, base, Transform.identity(), None)
    w = weights(p, SIGMA, 1e-5)[0]
    res_w = identify(framed, in_world)
    res_b = identify(inner, p)
    K_w = gpr_gain(framed, inner, res_w, cov, w)
    K_b = gpr_gain(inner, inner, res_b, cov, w)
    np.testing.assert_allclose(K_w, K_b, rtol=1e-3, atol=1e-6 * np.abs(K_b).max())


@pytest.fixture(scope='module')
def files(tmp_path_factory):
    """A GPR calibrated from 15 noisy poses (the file with and without its covariance block) and arm1's points."""
    tmp = tmp_path_factory.mktemp('arm_gpr')
    core = CoreModel(load_config())
    true = core.parameters.coordinates(demo.true_values(core))
    robot_true = load_robot(geometry=core.config_for(true))
    gpr = identify(core, synthetic_measurements(core, true, demo.shipped_measurements().q[:GPR_ROWS], 5e-6, 2e-5,
                                                seed=103))
    cfg = core.config_for(gpr.estimate)
    cov = fitted_covariance(core, gpr)
    with_block = write_calibrated_config(tmp / 'cal.yaml', cfg, ('test',), cov)
    plain = write_calibrated_config(tmp / 'plain.yaml', cfg, ('test',))
    ps, truth = arm_truth(robot_true)
    Q, J = rows(robot_true, robot_true.arm('arm1'), 40, 1)
    meas = measured(robot_true, 'arm1', truth, Q, J, np.ones(40, dtype=bool), 2)
    arm_csv = write(tmp / 'arm1.csv', robot_true, meas)
    return robot_true.source, str(with_block), str(plain), arm_csv, cov, cfg, meas


def test_the_report_says_which_standard_errors_include_the_gprs_covariance(files, capsys, tmp_path):
    robot_file, with_block, plain_file, arm_csv, cov, cfg, meas = files
    argv = ['calibrate', '--robot', robot_file, arm_csv, '--output', str(tmp_path / 'r.yaml')]
    status, out, err = run(capsys, *argv, '--config', with_block, '--json')
    assert status == 0, err
    d = json.loads(out)
    assert d['note'] == (f"the arms' standard errors include the GPR's calibration uncertainty: the covariance of its "
                         f"{len(cov.names)} calibrated parameters (fitted, or derived from them by a registration's "
                         f'datum) in {with_block}, propagated to first order (K Sigma_g K^T, docs/calibration.md)')
    (arm,) = d['arms']
    g = arm['gpr_covariance']
    assert g['file'] == with_block and g['parameters'] == list(cov.names)
    se = {p['name']: p['standard_error'] for p in arm['parameters'] if p['status'] == 'fitted'}
    plain, total, _ = propagated(load_robot(geometry=cfg), meas, cov)
    for j in plain.fitted:
        name = plain.parameters[int(j)].name
        assert g['standard_error_without'][name] == pytest.approx(plain.standard_error[j], rel=1e-9)
        assert se[name] == pytest.approx(total.standard_error[j], rel=1e-9)
    assert se['arm1_shoulder_zero_offset'] > 1.5 * g['standard_error_without']['arm1_shoulder_zero_offset']
    # the text: the same numbers, the standard errors without the GPR's covariance on their line, the note
    status, text, err = run(capsys, *argv, '--config', with_block)
    assert status == 0, err
    (line,) = [ln for ln in text.splitlines() if ln.startswith('gpr covariance: ')]
    assert "every standard error above includes the GPR's calibration covariance; without it: " in line
    without = dict(re.findall(r'(arm1_\w+) ([0-9.]+) u', line))
    assert without.keys() == se.keys()
    for name, v in without.items():
        assert float(v) == pytest.approx(1e6 * g['standard_error_without'][name], abs=6e-4)
    assert f'note: {d["note"]}' in text
    # without the block: as before, the GPR taken as exact and said so
    status, out, err = run(capsys, *argv, '--config', plain_file, '--json')
    assert status == 0, err
    d = json.loads(out)
    assert d['note'].startswith("the arms' standard errors take the GPR's geometry (--config, else the robot's) as "
                                'exact') and d['arms'][0]['gpr_covariance'] is None
    assert {p['name']: p['standard_error'] for p in d['arms'][0]['parameters'] if p['status'] == 'fitted'} == \
        pytest.approx(g['standard_error_without'], rel=1e-9)
    status, text, err = run(capsys, *argv, '--config', plain_file)
    assert status == 0 and 'gpr covariance:' not in text and "note: the arms' standard errors take" in text
    assert 'noise chi square' not in text   # the plain chi-square is the whole law: no second check


def test_the_arms_plot_draws_the_band_the_gate_judges_with(files, capsys, tmp_path, monkeypatch):
    """``--plot`` of an arm judged with the GPR's covariance: its noise line is ``sqrt(3 sigma^2 + g^2)``, ``g^2`` the
    row's three diagonal entries of the GPR's share ``P B Sigma_g B^T P`` (built densely here) times ``sigma^2``, as
    the gate's residual variances ``diag C`` carry it (it was ``sqrt(3) sigma``, the noise alone: 8.66 um for every
    row where the gate expects 8.92-11.29 um); labelled so. Without the block the line is the noise's, as before."""
    from gpr_kinematics.calibration import plot
    robot_file, with_block, plain_file, arm_csv, cov, cfg, meas = files
    drawn = []
    monkeypatch.setattr(plot, 'plot_residuals', lambda path, plots, draw=plot.plot_residuals: drawn.append(plots)
                        or draw(path, plots))
    argv = ['calibrate', '--robot', robot_file, arm_csv, '--output', str(tmp_path / 'r.yaml'), '--plot',
            str(tmp_path / 'arm.png')]
    status, out, err = run(capsys, *argv, '--config', with_block)
    assert status == 0, err
    (data,) = drawn[-1]
    model = ArmModel(load_robot(geometry=cfg), meas)
    res = identify(model, meas.points)
    A, B = weighted_jacobians(model, model, res, cov, weights(meas.points, SIGMA, 1e-5)[0])
    P = np.eye(A.shape[0]) - A @ np.linalg.pinv(A)
    g2 = np.diag(P @ B @ cov.matrix @ B.T @ P).reshape(-1, 3).sum(axis=1) * SIGMA ** 2
    np.testing.assert_allclose(data.position.noise, np.sqrt(3 * SIGMA ** 2 + g2), rtol=1e-6)
    np.testing.assert_allclose(data.position.gpr ** 2, g2, rtol=1e-5)
    assert data.position.noise.min() == pytest.approx(8.92e-6, abs=5e-9)
    assert data.position.noise.max() == pytest.approx(11.29e-6, abs=5e-9)
    assert plot._noise_label(data.position, 'um') == (
        "noise and the GPR's share, as the gate judges: sqrt(3 sigma^2 + g^2),\nsigma 5 um per coordinate (the file's "
        f"sigma_position),\ng {1e6 * data.position.gpr.min():.3g}-{1e6 * data.position.gpr.max():.3g} um (the GPR's "
        'calibration covariance, propagated)')
    status, out, err = run(capsys, *argv, '--config', plain_file)
    (data,) = drawn[-1]
    assert status == 0 and data.position.gpr is None
    np.testing.assert_array_equal(data.position.noise, np.sqrt(3.0) * SIGMA * np.ones(len(data.rows)))


def test_a_tracker_frame_with_the_gprs_covariance(files, capsys, tmp_path):
    """Measured in a tracker's frame (identified with the arm): the GPR's covariance adds to every standard error
    the frame leaves it (the frame's own absorb the GPR's common motions)."""
    robot_file, with_block, plain_file, arm_csv, cov, cfg, meas = files
    robot = load_robot(robot_file)
    tracker = Transform(np.array([1.2, -0.4, 0.3]), np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    p = meas.points
    moved = type(meas)(Measurements(p.source, p.q, p.position @ tracker.rotation.T + tracker.position, None,
                                    p.sigma_position, None, p.lines), meas.arm, meas.joints, meas.blade, meas.on_blade)
    csv = write(tmp_path / 'tracker.csv', robot, moved)
    argv = ['calibrate', '--robot', robot_file, csv, '--frame', 'tracker', '--output', str(tmp_path / 'r.yaml'),
            '--json']
    status, out, err = run(capsys, *argv, '--config', with_block)
    assert status == 0, err
    (arm,) = json.loads(out)['arms']
    se = {q['name']: q['standard_error'] for q in arm['parameters'] if q['status'] == 'fitted'}
    without = arm['gpr_covariance']['standard_error_without']
    assert all(se[n] >= without[n] * (1 - 1e-9) for n in without) and any(se[n] > 1.01 * without[n] for n in without)
    assert arm['registration']['base'] is not None


def _fitted(out: str) -> dict[str, float]:
    (arm,) = json.loads(out)['arms']
    return {p['name']: p['standard_error'] for p in arm['parameters'] if p['status'] == 'fitted'}


def test_the_robots_gpr_section_brings_the_covariance_and_the_calibrated_robot_keeps_it(files, capsys, tmp_path):
    """A reviewer's chain: a robot whose ``gpr`` section names the calibrated geometry file had its arms calibrated
    with the GPR taken as exact (only ``--config`` brought the block), and the calibrated robot written carried the
    geometry inline without it. Now the section brings the file's block (the standard errors of ``--config``, to
    1e-12), the calibrated robot carries it inline (the same matrix, and from it the same standard errors again), a
    section setting a geometry key on top of the file leaves it out (its values are no longer the file's), and a
    malformed inline block is refused naming the section."""
    robot_file, with_block, plain_file, arm_csv, cov, cfg, meas = files
    data = read_yaml(robot_file)
    data['gpr'] = {'config': with_block}
    robot_yaml = tmp_path / 'robot.yaml'
    robot_yaml.write_text(safe_yaml.dump(data, sort_keys=False))
    out1 = tmp_path / 'calibrated.yaml'
    status, out, err = run(capsys, 'calibrate', '--robot', str(robot_yaml), arm_csv, '--output', str(out1), '--json')
    assert status == 0, err
    d = json.loads(out)
    assert d['arms'][0]['gpr_covariance']['file'] == with_block
    assert f"registration's datum) in {with_block}," in d['note']
    status, given, err = run(capsys, 'calibrate', '--robot', robot_file, arm_csv, '--config', with_block, '--output',
                             str(tmp_path / 'given.yaml'), '--json')
    assert status == 0, err
    assert _fitted(out) == pytest.approx(_fitted(given), rel=1e-12)
    assert 'gpr_covariance' in [c['name'] for c in json.loads(given)['arms'][0]['gate']['checks']]   # judged with it
    kept = load_robot(tmp_path / 'given.yaml').gpr_covariance   # --config's block kept in the calibrated robot
    assert kept is not None and kept.names == cov.names and np.array_equal(kept.matrix, cov.matrix)
    written = load_robot(out1).gpr_covariance
    assert written is not None and written.names == cov.names and np.array_equal(written.matrix, cov.matrix)
    assert written.source == str(out1) and written.section == 'gpr'
    status, again, err = run(capsys, 'calibrate', '--robot', str(out1), arm_csv, '--output', str(tmp_path / 'r2.yaml'),
                             '--json')
    assert status == 0, err
    assert _fitted(again) == pytest.approx(_fitted(out), rel=1e-6)   # from the calibrated arms: the same fit
    d = json.loads(again)   # the file, and the section apart (a reviewer's 'out1.yaml: gpr' was no file to open)
    assert {k: d['arms'][0]['gpr_covariance'][k] for k in ('file', 'section')} == {'file': str(out1), 'section': 'gpr'}
    assert f"registration's datum) in {out1}'s gpr section, propagated" in d['note']
    for section, kept in (({'config': with_block, 'rod_offsets': [0.0, 0.0, 0.0]}, False),
                          ({'config': with_block, 'model': 'radial', 'tilt_limit': 0.03}, True),
                          ({'config': plain_file}, False)):
        data['gpr'] = section
        robot_yaml.write_text(safe_yaml.dump(data, sort_keys=False))
        assert (load_robot(robot_yaml).gpr_covariance is not None) == kept, section
    data['gpr'] = {'config': with_block, 'kappa': read_yaml(with_block)['kappa']}   # its own value: the block left out
    robot_yaml.write_text(safe_yaml.dump(data, sort_keys=False))
    status, out, err = run(capsys, 'calibrate', '--robot', str(robot_yaml), arm_csv, '--output', str(out1), '--json')
    assert status == 0, err
    assert json.loads(out)['note'].endswith(f'; the covariance block of {with_block} is left out: the robot\'s gpr '
                                            'section sets kappa on top of that file (the block describes its values)')
    for section, words in (({'config': None, 'covarianse': {}}, 'unknown key(s) covarianse; allowed keys: '
                            'characteristic_length, config, covariance, '),
                           ({'config': ''}, "config = '' is invalid; allowed: a path to a geometry YAML file or null")):
        data['gpr'] = section
        robot_yaml.write_text(safe_yaml.dump(data, sort_keys=False))
        with pytest.raises(ConfigError, match=re.escape(f'{robot_yaml}: gpr: {words}')):
            load_robot(robot_yaml)
    data['gpr'] = {'config': None, 'covariance': {'names': ['rod1_x'], 'matrix': [[-1.0]]}}
    robot_yaml.write_text(safe_yaml.dump(data, sort_keys=False))
    with pytest.raises(ConfigError, match=re.escape(f'{robot_yaml}: gpr: covariance: matrix: the variance of rod1_x '
                                                    'is -1.0; allowed: a covariance, every variance >= 0')):
        load_robot(robot_yaml)

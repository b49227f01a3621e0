"""Identification (gpr_kinematics.calibration.identification) on synthetic measurements of known machines: the
core's geometry and the tests' reference model of the imperfect GPR (offsets of tens of um, rod tilts of 0.1 mrad,
kappa = 3, tracker noise of a few um). Identified values within three standard errors of the truth, residuals at
the noise level, unidentifiable parameters reported and held, the calibrated geometry file round trip."""
from __future__ import annotations

import math

import numpy as np
import pytest
from calibration_reference import ReferenceModel

from gpr_kinematics.calibration.core_model import CoreModel, check_limits, write_calibrated_config
from gpr_kinematics.calibration.identification import identify
from gpr_kinematics.calibration.measurements import Measurements
from gpr_kinematics.calibration.plan import plan_measurements
from gpr_kinematics.calibration.synthetic import synthetic_measurements
from gpr_kinematics.config import load_config
from gpr_kinematics.errors import InputError
from gpr_kinematics.kinematics import forward_batch, inverse_batch

SP, SA = 3e-6, 2e-5


@pytest.fixture(scope='module')
def reference_case():
    """60 planned poses of a perturbed imperfect GPR, identified with every parameter free."""
    cfg = load_config()
    m = ReferenceModel()
    Q = plan_measurements(m, cfg, 60, sigma_position=SP, sigma_angle=SA).q
    ps = m.parameters
    # Which parameters the poses cannot identify depends only on the poses, the sigmas and the nominal model:
    # a noiseless run tells; the true machine keeps those at nominal, except base_z (its effect is taken up by
    # the offsets, which the test checks).
    dry = identify(m, synthetic_measurements(m, ps.nominal, Q, SP, SA, seed=0))
    rng = np.random.default_rng(7)
    truth = ps.nominal.copy()
    truth[0:6] += rng.normal(0, 30e-6, 6)                       # rod base positions
    truth[6:9] += [40e-6, -25e-6, 15e-6]                        # zero offsets of q
    truth[9:15] += rng.normal(0, 1e-4, 6)                       # rod tilts ~0.1 mrad
    truth[15:21] += rng.normal(0, 30e-6, 6)                     # platform joints
    truth[21] = 3.0                                             # kappa (nominal 1)
    for name in dry.identifiability.held:
        truth[ps.index(name)] = ps.nominal[ps.index(name)]
    truth[22] = 20e-6                                           # base_z
    meas = synthetic_measurements(m, truth, Q, SP, SA, seed=11)
    return m, truth, meas, identify(m, meas), dry


def test_reference_machine_identified_within_three_standard_errors(reference_case):
    m, truth, meas, res, dry = reference_case
    ps = m.parameters
    assert res.identifiability.held == dry.identifiability.held
    assert 'base_z' in res.identifiability.held and 'kappa' in res.identifiability.identified
    equivalent = truth.copy()
    u_z = 1.0 / np.sqrt(1.0 + truth[9:15:2] ** 2 + truth[10:15:2] ** 2)
    equivalent[6:9] += truth[22] / u_z                          # base_z held at 0: the offsets take it up
    equivalent[22] = 0.0
    fitted = res.fitted
    z = (res.estimate[fitted] - equivalent[fitted]) / res.standard_error[fitted]
    assert np.all(np.abs(z) < 3.0), dict(zip([ps[j].name for j in fitted], z.round(2), strict=True))
    assert res.estimate[ps.index('kappa')] == pytest.approx(3.0, abs=3 * res.standard_error[ps.index('kappa')])
    for name in res.identifiability.held:                       # held exactly at nominal, not fitted to noise
        j = ps.index(name)
        assert res.estimate[j] == ps.nominal[j] and res.status[j] == 'held' and np.isnan(res.standard_error[j])
    offsets = res.estimate[6:9] - ps.nominal[6:9]
    np.testing.assert_allclose(offsets, equivalent[6:9], atol=3 * res.standard_error[6:9].max())


def test_reference_residuals_drop_to_the_noise_level(reference_case):
    _, _, meas, res, _ = reference_case
    assert res.before.rms_position > 10 * SP
    assert 0.8 < res.chi2_reduced < 1.2 and res.absolute_sigma
    assert 1.5 * SP < res.after.rms_position < 1.95 * SP        # sqrt(3) sigma for three coordinates
    assert 1.5 * SA < res.after.rms_angle < 1.95 * SA
    assert res.after.max_position < 5 * SP
    assert res.after.worst_position_line in meas.lines


def test_base_height_and_offsets_named_not_separable(reference_case):
    _, _, _, res, _ = reference_case
    combo = next(c for c in res.identifiability.combinations if c.held == 'base_z')
    assert set(combo.coefficients) >= {'base_z', 'offset1', 'offset2', 'offset3'}
    for k in (1, 2, 3):
        assert combo.coefficients[f'offset{k}'] == pytest.approx(-1.0, abs=0.02)
    assert combo.singular_value < 1.0 and 'base_z held at nominal' in combo.describe()
    d = res.as_dict()
    assert {p['name']: p['status'] for p in d['parameters']}['base_z'] == 'held'
    assert {p['name']: p['standard_error'] for p in d['parameters']}['base_z'] is None


def test_kappa_not_identifiable_from_untilted_poses():
    m = ReferenceModel()
    h = np.linspace(0.02, 0.48, 12)
    Q = np.column_stack([h, h, h])
    truth = m.parameters.nominal.copy()
    truth[21] = 4.0
    truth[6:9] += [30e-6, -10e-6, 5e-6]
    res = identify(m, synthetic_measurements(m, truth, Q, SP, SA, seed=3), free=['kappa', 'rod_offsets'])
    assert res.identifiability.held == ('kappa',)
    assert res.estimate[21] == 1.0 and res.status[21] == 'held'
    assert 'kappa is not identifiable from these poses' in res.identifiability.combinations[0].describe()
    assert res.status[0] == 'fixed'
    np.testing.assert_allclose(res.estimate[6:9], truth[6:9], atol=3 * res.standard_error[6:9].max())


def test_core_geometry_identified_and_written_as_a_config_file(tmp_path):
    cfg = load_config()
    m = CoreModel(cfg)
    Q = plan_measurements(m, cfg, 40, sigma_position=SP, sigma_angle=SA).q
    truth = m.parameters.nominal + np.array([60e-6, 4e-4, -3e-4, 2e-4])
    res = identify(m, synthetic_measurements(m, truth, Q, SP, SA, seed=5))
    z = (res.estimate - truth) / res.standard_error
    assert np.all(np.abs(z) < 3.0) and res.status == ('fitted',) * 4
    assert res.after.rms_angle < res.before.rms_angle
    cal = m.config_for(res.estimate)
    path = write_calibrated_config(tmp_path / 'cal.yaml', cal, ('a test', 'from x\nradius: 5\r.csv'))
    back = load_config(path)                                   # (a newline in a comment cannot inject a key)
    assert back == cal and back.radius == res.estimate[0] and list(back.rod_azimuths) == res.estimate[1:].tolist()
    assert path.read_text().startswith('# a test\n') and 'characteristic_length: null' in path.read_text()
    # The calibrated file reproduces the identified model exactly, and inverse -> forward round trips in it.
    pos, rot = m.poses(res.estimate[None], Q[None])
    fk = forward_batch(Q, back, check_limits=False)
    assert np.max(np.abs(fk.position - pos[0])) < 1e-15 and np.max(np.abs(fk.rotation - rot[0])) < 1e-15
    ik = inverse_batch([0.1, 0.3, 0.45], [0.0, 0.02, -0.03], [0.0, 1.0, 2.5], back)
    again = forward_batch(ik.q, back)
    np.testing.assert_allclose(again.position[:, 2], [0.1, 0.3, 0.45], rtol=0, atol=1e-12)
    np.testing.assert_allclose(again.tilt, [0.0, 0.02, 0.03], rtol=0, atol=1e-12)


def test_default_sigmas_scale_the_covariance_by_chi_square():
    cfg = load_config()
    m = CoreModel(cfg)
    Q = plan_measurements(m, cfg, 30).q
    truth = m.parameters.nominal + np.array([40e-6, 2e-4, 0.0, -2e-4])
    noisy = synthetic_measurements(m, truth, Q, 2 * SP, 2 * SA, seed=9, with_sigmas=False)
    absolute = identify(m, synthetic_measurements(m, truth, Q, 2 * SP, 2 * SA, seed=9))
    relative = identify(m, noisy, sigma_position=SP, sigma_angle=SA)   # defaults half the true noise
    assert not relative.absolute_sigma and relative.chi2_reduced == pytest.approx(4 * absolute.chi2_reduced)
    np.testing.assert_allclose(relative.estimate, absolute.estimate, rtol=0, atol=1e-12)
    np.testing.assert_allclose(relative.standard_error, absolute.standard_error * math.sqrt(absolute.chi2_reduced),
                               rtol=1e-6)


def test_refusals():
    cfg = load_config()
    m = CoreModel(cfg)
    Q = plan_measurements(m, cfg, 5).q
    meas = synthetic_measurements(m, m.parameters.nominal, Q, SP, SA)
    one = Measurements('one.csv', meas.q[:1], meas.position[:1], meas.quaternion[:1], None, None, (3,))
    assert identify(m, one, free=['radius']).fitted.tolist() == [0]     # 6 residuals, 1 parameter: allowed
    with pytest.raises(InputError, match=r'one\.csv: 1 row\(s\) give 6 residuals, too few to identify 6 '
                                         r'parameters; at least 2 rows'):
        identify(ReferenceModel(), one, free=['rod_bases'])
    mm = Measurements('mm.csv', meas.q, meas.position * 1000, meas.quaternion, None, None, tuple(range(4, 9)))
    with pytest.raises(InputError, match=r'mm\.csv line 4: the measured pose is .* m and .* rad from the '
                                         r'nominal model.*millimetres\? declare "# units: mm"'):
        identify(m, mm)
    with pytest.raises(InputError, match=r'mm\.csv line \d, column q\d: \d+\.?\d* m is outside the stroke '
                                         r'\[0, 0\.508\] m'):
        check_limits(Measurements('mm.csv', meas.q * 1000, meas.position, meas.quaternion, None, None,
                                  tuple(range(4, 9))), cfg)
    tilted = meas.q.copy()
    tilted[2] = [0.1, 0.1, 0.11]
    with pytest.raises(InputError, match=r'mm\.csv line 6, columns q1 q2 q3: the rod lengths tilt the platform by '
                                         r'4\.\d+ deg, beyond the tilt limit 2 deg'):
        check_limits(Measurements('mm.csv', tilted, meas.position, meas.quaternion, None, None, tuple(range(4, 9))),
                     cfg)
    check_limits(meas, cfg)
    with pytest.raises(InputError, match=r'sigma_position = -1.0; allowed: a standard deviation from 1e-09 to 0\.1'):
        identify(m, meas, sigma_position=-1.0)

"""Measurement planning (gpr_kinematics.calibration.plan): configurations within the limits, the observability
indices against direct computations, better than random designs, and predicted standard errors that match the
scatter of repeated identifications."""
from __future__ import annotations

import math

import numpy as np
import pytest
from calibration_reference import ReferenceModel
from gpr_kinematics.calibration.core_model import TILT_MARGIN, CoreModel
from gpr_kinematics.calibration.identification import identify
from gpr_kinematics.calibration.model import pose_jacobian
from gpr_kinematics.calibration.plan import (
    TILT_FRACTION,
    candidate_configurations,
    observability_index,
    plan_measurements,
)
from gpr_kinematics.calibration.synthetic import synthetic_measurements
from gpr_kinematics.core import forward_batch
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.machine import config_with_parameters
from gpr_kinematics.errors import InputError

SP, SA = 5e-6, 2e-5


def scaled_singular_values(model, Q, cols=None):
    """Direct computation: the weighted, scaled Jacobian of the configurations Q and its singular values."""
    ps = model.parameters
    cols = np.arange(len(ps)) if cols is None else np.asarray(cols)
    J = pose_jacobian(model, ps.nominal, Q, cols) * np.array([1 / SP] * 3 + [1 / SA] * 3)[None, :, None]
    return np.linalg.svd((J * ps.scale[cols]).reshape(-1, cols.size), compute_uv=False)


def test_candidates_lie_within_stroke_and_tilt_limits():
    """The candidates tilt up to 5 % inside the limit (a measured configuration may lie 5 % beyond it): 1.899 deg of
    2 (they tilted 1.9888 deg, 99.44 %, and a calibrated machine 2.003-2.011 deg at 14 of the shipped plan's 40)."""
    cfg = load_config()
    c = candidate_configurations(cfg, heights=5, tilts=2, azimuths=8)
    assert c.q.shape == (5 * 17, 3)
    fk = forward_batch(c.q, cfg)                 # with the limit checks: raises if any is outside
    assert TILT_FRACTION == 2.0 - TILT_MARGIN == 0.95
    assert fk.tilt.max() / cfg.tilt_limit == pytest.approx(0.949478, abs=1e-6)   # the naive targets' 0.95, 0.06 % in
    assert c.q.min() >= cfg.stroke_min and c.q.max() <= cfg.stroke_max
    with pytest.raises(InputError, match=r'heights = 0; allowed: an integer from 1 to 1000'):
        candidate_configurations(cfg, heights=0)


def test_a_machine_off_the_nominal_one_stays_within_the_tilt_limit_at_every_candidate():
    """The margin for the machine's own deviation: the zero offsets tilt the plane of the joint centres most (up to
    4 / (3 R) rad per metre, 14.3 mrad/mm): offsets of +-120 um, in every sign pattern, keep the tilt within the limit
    at every candidate (1.9972 deg), +-130 um exceed it (2.0054 deg); the example table's 50 um is well inside."""
    cfg = load_config()
    q = candidate_configurations(cfg).q
    names = ['rod1_offset', 'rod2_offset', 'rod3_offset']
    signs = [(1, -1, -1), (-1, 1, -1), (-1, -1, 1), (1, 1, -1), (1, -1, 1), (-1, 1, 1)]
    tilt = {o: max(forward_batch(q, config_with_parameters(cfg, [o * s for s in sign], names),
                                 check_limits=False).tilt.max() for sign in signs) for o in (120e-6, 130e-6)}
    assert math.degrees(tilt[120e-6]) == pytest.approx(1.99719, abs=1e-5) and tilt[120e-6] < cfg.tilt_limit
    assert math.degrees(tilt[130e-6]) == pytest.approx(2.00537, abs=1e-5)
    for sign in signs:                           # with the limit checks: raises if any is beyond
        forward_batch(q, config_with_parameters(cfg, [120e-6 * s for s in sign], names))


@pytest.mark.parametrize('index', ['product', 'smallest'])
def test_plan_beats_random_designs_and_reports_its_index(index):
    """All 24 parameters of the core's geometry, 12 configurations: the index of the identified ones (the plan holds
    what no design can see, the joints' radial places) against a direct SVD, random designs and single exchanges."""
    cfg = load_config()
    m = CoreModel(cfg)
    plan = plan_measurements(m, cfg, 12, index=index, sigma_position=SP, sigma_angle=SA)
    assert plan.q.shape == (12, 3) and len({tuple(q) for q in plan.q.tolist()}) == 12
    forward_batch(plan.q, cfg)                   # within the stroke and the tilt limit: raises otherwise
    # Held: the joints' radial places; with 12 poses a joint or a kappa more. A rod's horizontal base position and
    # its platform joint move the pose almost alike (parallel rods), so which of the two is held depends on the
    # LAPACK's pivoting; never a zero offset or a rod direction, which the plan makes visible.
    held = set(plan.identifiability.held)
    allowed = ('joint', 'kappa') + tuple(f'rod{k}_{c}' for k in (1, 2, 3) for c in 'xy')
    assert 3 <= len(held) <= 6 and all(n.startswith(allowed) for n in held), held
    s = scaled_singular_values(m, plan.q, plan.fitted)
    expected = np.exp(np.mean(np.log(s))) / np.sqrt(12) if index == 'product' else s.min()
    assert plan.index == pytest.approx(expected, rel=1e-9)
    assert plan.index == pytest.approx(observability_index(s, 12, index), rel=1e-12)
    assert plan.index > 1.2 * plan.random_index
    # No single exchange with a candidate improves the plan (it is a local optimum of the exchange algorithm).
    cand = candidate_configurations(cfg)
    rng = np.random.default_rng(0)
    unused = [c for c in cand.q if not any(np.array_equal(c, q) for q in plan.q)]  # a design uses each once
    for _ in range(30):
        trial = plan.q.copy()
        trial[rng.integers(12)] = unused[rng.integers(len(unused))]
        trial_s = scaled_singular_values(m, trial, plan.fitted)
        assert observability_index(trial_s, 12, index) <= plan.index * (1 + 1e-9)


def test_index_scales_with_the_noise():
    cfg = load_config()
    m = CoreModel(cfg)
    # (a low threshold, so that the same parameters count in both: with twice the noise a direction of the small
    # plan falls below the default bound 1 and would be held)
    a = plan_measurements(m, cfg, 6, sigma_position=SP, sigma_angle=SA, threshold=0.01)
    b = plan_measurements(m, cfg, 6, sigma_position=2 * SP, sigma_angle=2 * SA, threshold=0.01)
    np.testing.assert_array_equal(a.q, b.q)
    assert b.index == pytest.approx(a.index / 2, rel=1e-9)


@pytest.mark.slow
def test_predicted_standard_errors_match_repeated_identifications():
    """On a machine near its nominal geometry (here kappa = 3: a nominal at the radial end, kappa 1000, puts the
    anisotropy's estimates against its bound 1, which no covariance describes)."""
    cfg = load_config(overrides={'kappa': 3.0})
    m = CoreModel(cfg)
    free = ['rod_offsets', 'rod_directions', 'kappa']
    plan = plan_measurements(m, cfg, 12, sigma_position=SP, sigma_angle=SA, free=free)
    assert plan.fitted.tolist() == np.flatnonzero(m.parameters.select(free)).tolist()
    values = m.parameters.values(m.parameters.nominal)
    values[m.parameters.select(['rod_offsets'])] += [30e-6, -10e-6, 20e-6]
    values[m.parameters.select(['rod_directions'])] += [1e-4, -1e-4, 5e-5, 0.0, -5e-5, 1e-4]
    values[m.parameters.select(['kappa'])] = [2.8, 3.0, 3.3]
    truth = m.parameters.coordinates(values)
    est = np.array([identify(m, synthetic_measurements(m, truth, plan.q, SP, SA, seed=s), free=free).estimate
                    for s in range(40)])[:, plan.fitted]
    predicted = np.sqrt(np.diag(plan.covariance))            # of the coordinates (an anisotropy for kappa)
    np.testing.assert_allclose(est.std(axis=0, ddof=1), predicted, rtol=0.3)
    np.testing.assert_allclose(est.mean(axis=0), truth[plan.fitted], atol=(3 * predicted / np.sqrt(40)).max())
    slope = m.parameters.value_slopes(m.parameters.nominal)[plan.fitted]
    np.testing.assert_allclose(plan.standard_errors, slope * predicted, rtol=1e-12)   # the values' (kappa: 8 x)


def test_reference_plan_holds_what_no_candidate_identifies():
    cfg = load_config()
    m = ReferenceModel()
    plan = plan_measurements(m, cfg, 30, sigma_position=SP, sigma_angle=SA)
    assert 'base_z' in plan.identifiability.held and 'kappa' in plan.identifiability.identified
    assert plan.index > plan.random_index
    d = plan.as_dict()
    assert len(d['configurations']) == 30 and set(d['standard_errors']) == set(plan.identifiability.identified)


def test_refusals():
    cfg = load_config()
    m = CoreModel(cfg)
    with pytest.raises(InputError, match=r'plan size 0: 0 configuration\(s\) measured as poses give 0 residuals, too '
                                         r'few to identify 24 parameters .*; allowed: at least 5$'):
        plan_measurements(m, cfg, 0)
    with pytest.raises(InputError, match=r'plan size 1000; allowed: an integer from 5 to 222 \(the fewest that '
                                         r'identify 24 parameters, the number of candidate configurations'):
        plan_measurements(m, cfg, 1000)
    # a plan whose file gpr calibrate refuses (k rows give k residuals per row, no more than the parameters): the
    # plan and the budget after it were given, the calibration refused
    with pytest.raises(InputError, match=r'plan size 4: 4 configuration\(s\) measured as poses give 24 residuals, too '
                                         r'few to identify 24 parameters \(gpr calibrate refuses a file of so few '
                                         r'rows\); allowed: at least 5$'):
        plan_measurements(m, cfg, 4)
    with pytest.raises(InputError, match=r'plan size 8: 8 configuration\(s\) measured as points give 24 residuals, '
                                         r'.*allowed: at least 9$'):
        plan_measurements(m, cfg, 8, points=True)
    assert plan_measurements(m, cfg, 5).q.shape == (5, 3)
    assert plan_measurements(m, cfg, 9, points=True).q.shape == (9, 3)
    with pytest.raises(InputError, match=r"observability index 'volume'; allowed: product, smallest"):
        plan_measurements(m, cfg, 3, index='volume')
    with pytest.raises(InputError, match=r'sigma_angle = 0; allowed'):
        plan_measurements(m, cfg, 3, sigma_angle=0)


def test_a_threshold_no_parameter_reaches_is_refused():
    """A threshold above what any parameter reaches left nothing to design for (a ValueError from numpy): refused,
    saying whether a larger plan could help (5 configurations, threshold 300) or not (every candidate, 1e308)."""
    cfg = load_config()
    m = CoreModel(cfg)
    with pytest.raises(InputError, match=r'threshold 1e\+308 even from all 222 candidate configurations; allowed: '
                                         r'a lower threshold$'):
        plan_measurements(m, cfg, 5, threshold=1e308)
    with pytest.raises(InputError, match=r'threshold 300 from the 5 configurations chosen; allowed: a lower '
                                         r'threshold or a larger plan$'):
        plan_measurements(m, cfg, 5, threshold=300)
    assert plan_measurements(m, cfg, 5, threshold=100).q.shape == (5, 3)      # still possible below


def test_a_seed_that_is_not_an_integer_is_named():
    from gpr_kinematics.core.config import load_config
    from gpr_kinematics.errors import InputError

    cfg = load_config()
    with pytest.raises(InputError, match=r'seed = nan is invalid; allowed: an integer from 0'):
        plan_measurements(CoreModel(cfg), cfg, 6, seed=float('nan'))

"""Accuracy budget (gpr_kinematics.calibration.budget, .report): linearised against Monte Carlo, closed-form cases,
the worst case against an exact zonotope, calibrated covariances, and the printed numbers against the JSON."""
from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from calibration_reference import ReferenceModel
from gpr_kinematics.calibration.budget import QUANTITIES, accuracy_budget
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.model import pose_jacobian
from gpr_kinematics.calibration.report import format_budget
from gpr_kinematics.calibration.tolerances import parse_tolerances
from gpr_kinematics.core import naive_inverse
from gpr_kinematics.core.config import load_config
from gpr_kinematics.errors import ConfigError, InputError, LimitError

TOOL = (0.3, 0.0, 0.1)


@pytest.fixture(scope='module')
def reference_budget():
    rng = np.random.default_rng(1)
    Q = naive_inverse(rng.uniform(0.1, 0.4, 4), rng.uniform(-0.0349, 0.0349, 4), rng.uniform(-3, 3, 4))
    table = parse_tolerances({'parameters': {'rod_bases': {'tolerance': 3e-5}, 'rod_offsets': {'tolerance': 5e-5},
                                             'rod_directions': {'tolerance': 2e-4, 'distribution': 'normal'},
                                             'platform_joints': {'tolerance': 3e-5},
                                             'kappa': {'tolerance': 0.05}},
                              'rod_length': {'tolerance': 2e-6}, 'joint_clearance': [3e-6, 0.0, 5e-6]})
    m = ReferenceModel(kappa=2.0, base_z=False)
    return m, Q, accuracy_budget(m, Q, table, tool=TOOL, samples=6000, seed=4)


def test_linearised_matches_monte_carlo(reference_budget):
    _, _, b = reference_budget
    assert b.sources[-2:] == ('joint_clearance1', 'joint_clearance3') and 'rod_length2' in b.sources
    np.testing.assert_allclose(b.mc_std, b.std, rtol=0.05)               # 6000 samples: ~1 % scatter
    assert np.all(np.abs(b.mc_mean - b.mean) < 0.06 * b.std)
    for name in QUANTITIES:
        np.testing.assert_allclose(b.mc_rms[name], b.rss[name], rtol=0.05)
        np.testing.assert_allclose(b.shares[name].sum(axis=1), 1.0, atol=1e-12)
        assert np.all(b.mc[name][:, -1] <= b.worst[name] * 1.001)        # no sample beyond the worst case
        assert np.all(b.mc[name][:, 0] <= b.mc[name][:, 1]) and np.all(b.mc[name][:, 1] <= b.mc[name][:, 2])
    assert np.all(b.rss['tool_horizontal'] > b.rss['platform_horizontal'])   # the lever of the tool


def test_rod_length_errors_in_closed_form():
    """At q1 = q2 = q3 a rod lifts the platform centre by a third of its error: the vertical worst case is t, the
    RSS t / 3 (three uniform errors of standard deviation t / sqrt(3), each weighted 1/3)."""
    cfg = load_config()
    t = 4e-6
    table = parse_tolerances({'rod_length': {'tolerance': t}})
    b = accuracy_budget(CoreModel(cfg), [[0.3, 0.3, 0.3]], table, samples=20_000, seed=2)
    assert b.worst['platform_vertical'][0] == pytest.approx(t, rel=1e-6)
    assert b.rss['platform_vertical'][0] == pytest.approx(t / 3, rel=1e-6)
    assert b.mc_rms['platform_vertical'][0] == pytest.approx(t / 3, rel=0.02)
    assert b.sources == ('rod_length1', 'rod_length2', 'rod_length3')
    np.testing.assert_allclose(b.shares['platform_vertical'][0], [1 / 3] * 3, atol=1e-6)


def zonotope_max_norm(centre, generators):
    """Exact largest |v| over the 2-D zonotope centre + sum_j s_j g_j, |s_j| <= 1: at a vertex, and the vertices are
    the sums of the generators' signs along every direction between their normals."""
    angles = np.arctan2(generators[:, 1], generators[:, 0])
    normals = np.concatenate([angles + np.pi / 2, angles - np.pi / 2])
    best = 0.0
    for a in np.concatenate([normals + 1e-9, normals - 1e-9]):
        d = np.array([math.cos(a), math.sin(a)])
        v = centre + np.sign(generators @ d) @ generators
        best = max(best, float(np.linalg.norm(v)))
    return best


def test_horizontal_worst_case_against_the_exact_zonotope():
    cfg = load_config()
    m = CoreModel(cfg)
    Q = naive_inverse([0.2, 0.45], [0.03, 0.02], [0.4, -2.0], cfg)
    table = parse_tolerances({'parameters': {'rod_positions': {'tolerance': 5e-5}, 'rod_offsets': {'tolerance': 2e-5},
                                             'rod1_ux': {'tolerance': 5e-4}},
                              'rod_length': {'tolerance': 2e-6}})
    b = accuracy_budget(m, Q, table, tool=TOOL, samples=0)
    cols = np.flatnonzero(m.parameters.select(['rod_positions', 'rod_offsets', 'rod1_ux']))
    J = pose_jacobian(m, m.parameters.nominal, Q, cols)               # (N, 6, 10): independent of the engine's rows
    from gpr_kinematics.calibration.model import evaluate, rod_jacobian
    _, rot = evaluate(m, m.parameters.nominal, Q)
    Jq = rod_jacobian(m, m.parameters.nominal, Q)
    half = np.array([5e-5 if m.parameters[j].key == 'rod_positions' else 2e-5 if m.parameters[j].key == 'rod_offsets'
                     else 5e-4 for j in cols] + [2e-6] * 3)
    for i in range(2):
        G = np.concatenate([J[i], Jq[i]], axis=1)                       # (6, 13)
        a = rot[i] @ np.array(TOOL)
        tool = G[:3] + np.cross(G[3:].T, a).T
        for name, rows in (('platform_horizontal', G[:2]), ('tool_horizontal', tool[:2])):
            exact = zonotope_max_norm(np.zeros(2), (rows * half).T)
            assert exact <= b.worst[name][i] <= exact / math.cos(math.pi / 512) * (1 + 1e-12)
        assert b.worst['tool_vertical'][i] == pytest.approx(np.abs(tool[2]) @ half, rel=1e-12)
    assert 'monte_carlo' not in b.as_dict()['stations'][0]['quantities']['tilt']


def test_calibrated_covariance_replaces_the_tolerances():
    cfg = load_config(overrides={'kappa': 2.0})
    m = CoreModel(cfg)
    Q = naive_inverse([0.3], [0.03], [1.0], cfg)
    rng = np.random.default_rng(0)
    idx = np.array([m.parameters.index(n) for n in ('rod1_offset', 'rod2_ux', 'joint3_y', 'kappa1')])
    A = np.array([1e-6, 1e-5, 1e-6, 1e-2])[:, None] * rng.normal(size=(4, 4)) / 2     # rows: each parameter's scale
    cov = A @ A.T
    table = parse_tolerances({'parameters': {'rod_offsets': {'tolerance': 5e-5}}})
    b = accuracy_budget(m, Q, table, samples=2000, seed=1, calibrated=(idx, cov))
    assert b.sources == ('rod2_offset', 'rod3_offset', 'calibration')
    J = pose_jacobian(m, m.parameters.nominal, Q, idx)[0]
    J_off = pose_jacobian(m, m.parameters.nominal, Q, [10, 18])[0]
    var = np.diag(J @ cov @ J.T) + np.diag(J_off @ J_off.T) * (1e-4 ** 2 / 12)
    np.testing.assert_allclose(b.std[0, :6], np.sqrt(var), rtol=1e-9)
    b = accuracy_budget(m, Q, parse_tolerances({}), samples=2000, seed=1, calibrated=(idx, cov))
    assert b.sources == ('calibration',)
    np.testing.assert_allclose(b.mc_std[0, :6], b.std[0, :6], rtol=0.08)   # 2000 samples: ~1.6 % scatter
    g = J[2]
    assert b.worst['platform_vertical'][0] == pytest.approx(3 * math.sqrt(g @ cov @ g), rel=1e-9)


def test_printed_numbers_are_the_json_numbers(reference_budget):
    _, _, b = reference_budget
    data = json.loads(json.dumps(b.as_dict(), allow_nan=False))
    text = format_budget(b)
    rows = re.findall(r'^  ([a-z]+ [a-z]+|tilt|heading) +(um|urad)((?: +-?\d+\.\d{3})+)  (.*)$', text, re.M)
    assert len(rows) == len(QUANTITIES) * len(b.labels)
    for k, (label, unit, numbers, shares) in enumerate(rows):
        station = data['stations'][k // len(QUANTITIES)]
        q = station['quantities'][label.replace(' ', '_')]
        assert unit == ('um' if q['unit'] == 'm' else 'urad')
        expected = [q['rss'], q['worst']] + [q['monte_carlo'][f'p{p:g}'] for p in data['percentiles']]
        printed = [float(x) for x in numbers.split()]
        np.testing.assert_allclose(np.array(printed) * 1e-6, expected, rtol=0, atol=0.51e-9)
        printed_shares = re.findall(r'(\w+) (\d+\.\d) %', shares)
        assert len(printed_shares) == 3
        for name, value in printed_shares:
            assert float(value) == pytest.approx(100 * q['shares'][name], abs=0.051)
        assert min(float(v) for _, v in printed_shares) >= sorted(q['shares'].values())[-3] * 100 - 0.051
        # the three named as the shares rank them, ties (equal to 1e-9) by name: one list on every numpy (rounding
        # noise chose among six equal shares: rod3_x, rod2_y, joint1_y on one stack, rod1_y, joint1_y, rod3_x on
        # another)
        ranked = sorted(q['shares'], key=lambda n: (-round(q['shares'][n], 9), n))[:3]
        assert [name for name, _ in printed_shares] == [n for n in ranked if q['shares'][n] > 0][:3]


class NoPlay:
    """A pose model that cannot displace its joints (the budget must refuse joint play for it)."""

    supports_displacement = False

    def __init__(self, model):
        self.model, self.parameters = model, model.parameters

    def poses(self, theta, Q, displacement=None):
        return self.model.poses(theta, Q)


def test_refusals():
    cfg = load_config()
    m = CoreModel(cfg)
    Q = [[0.3, 0.3, 0.3]]
    table = parse_tolerances({'rod_length': {'tolerance': 1e-6}})
    with pytest.raises(InputError, match=r'joint_clearance needs a model with per-joint geometry; NoPlay'):
        accuracy_budget(NoPlay(m), Q, parse_tolerances({'joint_clearance': 1e-6}, 't.yaml'))
    with pytest.raises(ConfigError, match=r"unknown parameter 'offset1'"):
        accuracy_budget(m, Q, parse_tolerances({'parameters': {'offset1': {'tolerance': 1e-6}}}))
    for empty in ({}, {'parameters': {}}, {'parameters': {'rod_offsets': {'tolerance': 0.0}}, 'rod_length': None}):
        with pytest.raises(InputError, match=r'^e\.yaml: no error source for the accuracy budget .*: every error would '
                                             r'be 0; allowed: '):
            accuracy_budget(m, Q, parse_tolerances(empty, 'e.yaml'))
    with pytest.raises(InputError, match=r'10000 samples x 1000 stations = 10000000 poses; allowed: at most 5000000'):
        accuracy_budget(m, np.full((1000, 3), 0.3), table)
    with pytest.raises(InputError, match=r'tool must be 3 finite coordinates \[m\] \(one point, or one per station: '
                                         r'shape \(1, 3\)\)'):
        accuracy_budget(m, Q, table, tool=np.zeros((2, 3)))
    with pytest.raises(InputError, match=r'frame_rotation = .* is not a rotation matrix'):
        accuracy_budget(m, Q, table, frame_rotation=2 * np.eye(3))
    with pytest.raises(InputError, match=r'determinant \+1 \(not a mirror image\)'):
        accuracy_budget(m, Q, table, frame_rotation=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(InputError, match=r'samples = 2000000; allowed: an integer from 0 to 1000000'):
        accuracy_budget(m, Q, table, samples=2_000_000)
    # The reach of a tool point is the core's (core.inverse.TOOL_REACH, 10 m from the platform origin): (8, 8, 0),
    # 11.3 m away, passed when each coordinate was bounded alone.
    for far, rods, said in (((1e300, 0, 0), Q, r'\(1e\+300, 0, 0\) m'), ((8, 8, 0), Q, r'\(8, 8, 0\) m'),
                            ([[0.1, 0, 0], [8, -8, 0]], np.vstack([Q, Q]), r'\(8, -8, 0\) m \(target 1\)')):
        with pytest.raises(LimitError, match=rf'^tool = {said} is beyond the reach of a tool point \([\d.e+]+ m from '
                                             r'the platform origin\); allowed: at most 10 m from the platform origin '
                                             r'\(gpr_platform\)$'):
            accuracy_budget(m, rods, table, tool=far)
    with pytest.raises(InputError, match=r'percentiles'):
        accuracy_budget(m, Q, table, percentiles=(50, 101))
    with pytest.raises(InputError, match=r'2 labels for 1 stations'):
        accuracy_budget(m, Q, table, labels=['a', 'b'])
    with pytest.raises(InputError, match=r'theta must be 24 numbers, got shape \(2,\)'):
        accuracy_budget(m, Q, table, theta=[0.1, 0.2])
    with pytest.raises(InputError, match=r'theta\[3\] = nan is not a finite number'):   # it said "got shape (24,)"
        accuracy_budget(m, Q, table, theta=[0.0] * 3 + [math.nan] + [0.0] * 20)
    with pytest.raises(InputError, match=r'indices must be distinct integers from 0 to 23'):
        accuracy_budget(m, Q, table, calibrated=([0, 0], np.eye(2)))
    with pytest.raises(InputError, match=r'not positive semi-definite'):
        accuracy_budget(m, Q, table, calibrated=([0, 1], np.array([[1e-10, 0], [0, -1e-10]])))
    singular = np.array([[1e-10, 1e-10], [1e-10, 1e-10]])            # rank 1: sampled without failure
    b = accuracy_budget(m, [[0.3, 0.303, 0.3]], table, calibrated=([0, 1], singular), samples=100)
    assert np.all(np.isfinite(b.mc_std))
    with pytest.raises(InputError, match=r'q2 = nan is not a finite number'):
        accuracy_budget(m, [[0.3, np.nan, 0.3]], table)


@pytest.fixture(scope='module')
def core_budget():
    """The core's whole geometry: every parameter toleranced, a kappa range, rod-length errors and joint play."""
    cfg = load_config(overrides={'kappa': 1.0})
    rng = np.random.default_rng(6)
    Q = naive_inverse(rng.uniform(0.1, 0.4, 3), rng.uniform(-0.0349, 0.0349, 3), rng.uniform(-3, 3, 3), cfg)
    table = parse_tolerances({'parameters': {'rod_positions': {'tolerance': 3e-5}, 'rod_offsets': {'tolerance': 5e-5},
                                             'rod_directions': {'tolerance': 2e-4, 'distribution': 'normal'},
                                             'platform_joints': {'tolerance': 3e-5},
                                             'kappa': {'range': [0.5, 2.0], 'distribution': 'log-uniform'}},
                              'rod_length': {'tolerance': 2e-6}, 'joint_clearance': 3e-6})
    m = CoreModel(cfg)
    return m, Q, table, accuracy_budget(m, Q, table, tool=TOOL, samples=6000, seed=4)


def test_core_linearised_matches_monte_carlo(core_budget):
    """With the joints' play through per-row geometry and kappa varied as its anisotropy (in which the centre shift is
    linear), the linearised budget and the exact Monte Carlo agree."""
    m, _, _, b = core_budget
    assert len(b.sources) == 24 + 3 + 3 and b.sources[-3:] == ('joint_clearance1', 'joint_clearance2',
                                                               'joint_clearance3')
    np.testing.assert_allclose(b.mc_std, b.std, rtol=0.05)
    assert np.all(np.abs(b.mc_mean - b.mean) < 0.06 * b.std)
    for name in QUANTITIES:
        np.testing.assert_allclose(b.mc_rms[name], b.rss[name], rtol=0.05)
        assert np.all(b.mc[name][:, -1] <= b.worst[name] * 1.001)
    kappa = [b.sources.index(f'kappa{k}') for k in (1, 2, 3)]
    assert np.max(b.shares['platform_horizontal'][:, kappa].sum(axis=1)) > 0.01   # the range matters when tilted


def test_kappa_range_as_anisotropy():
    """kappa log-uniform in [0.5, 2] about a nominal 1: its anisotropy (kappa - 1) / (kappa + 1) is symmetric about 0
    (mean 0), in [-1/3, 1/3]: the linearised centre shift has no spurious mean, and its worst case is the interval's
    end, R alpha^2 / 4 / 3 at the tilt alpha (docs/core.md), within the law's accuracy."""
    cfg = load_config(overrides={'kappa': 1.0})
    m = CoreModel(cfg)
    table = parse_tolerances({'parameters': {'kappa': {'range': [0.5, 2.0], 'distribution': 'log-uniform'}}})
    tol = table.bind(m.parameters)[7]
    assert tol.bounds == pytest.approx((-1 / 3, 1 / 3), rel=1e-12) and abs(tol.mean) < 1e-15
    alpha = 0.0349
    q = naive_inverse(0.3, alpha, 0.0, cfg)
    b = accuracy_budget(m, [q], table, samples=4000, seed=3)
    shift = cfg.radius * alpha ** 2 / 4
    assert b.worst['platform_horizontal'][0] == pytest.approx(shift / 3, rel=0.02)   # every joint at its end
    assert np.all(np.abs(b.mean[0, :3]) < 1e-12)
    np.testing.assert_allclose(b.mc_rms['platform_horizontal'], b.rss['platform_horizontal'], rtol=0.05)


def test_tool_per_station_and_the_frame_of_the_errors(core_budget):
    """One tool point per station gives each station's own budget; a frame rotation turns every error vector."""
    m, Q, table, _ = core_budget
    tools = np.array([[0.3, 0.0, 0.1], [0.0, 0.5, 0.05], [-0.2, -0.2, 0.0]])
    b = accuracy_budget(m, Q, table, tool=tools, samples=0)
    for i in range(3):
        one = accuracy_budget(m, Q[i:i + 1], table, tool=tools[i], samples=0)
        np.testing.assert_allclose(b.std[i], one.std[0], rtol=1e-12)
        assert b.worst['tool_horizontal'][i] == pytest.approx(one.worst['tool_horizontal'][0], rel=1e-12)
    Rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])   # gpr_base turned 90 deg in the world
    w = accuracy_budget(m, Q, table, tool=tools, samples=500, seed=2, frame='world', frame_rotation=Rz)
    perm = [1, 0, 2, 4, 3, 5, 7, 6, 8]                                     # world x = -base y, world y = base x
    np.testing.assert_allclose(w.std, b.std[:, perm], rtol=1e-12)
    for name in QUANTITIES:                                              # norms of horizontal and vertical parts
        np.testing.assert_allclose(w.rss[name], b.rss[name], rtol=1e-12)
    assert w.frame == 'world' and w.as_dict()['frame'] == 'world'
    assert w.as_dict()['stations'][1]['tool'] == [0.0, 0.5, 0.05]
    tilted = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # 90 deg about x: base y is world z
    t = accuracy_budget(m, Q, table, tool=tools, samples=0, frame_rotation=tilted)
    np.testing.assert_allclose(t.std[:, 2], b.std[:, 1], rtol=1e-12)


@pytest.mark.parametrize('kwargs, words', [
    ({'seed': float('nan')}, r'seed = nan is invalid; allowed: an integer from 0 to 2\*\*63 - 1'),
    ({'seed': -1}, r'seed = -1 is invalid'),
    ({'percentiles': ('a',)}, r"percentiles \('a',\); allowed: numbers from 0 to 100"),
    ({'percentiles': 95.0}, r'percentiles 95.0; allowed: numbers from 0 to 100'),
    ({'tool': 'a'}, r'tool must be 3 finite coordinates'),
])
def test_monte_carlo_settings_that_are_not_numbers_are_named(kwargs, words):
    """A NaN seed was a TypeError from numpy, a string percentile or tool a bare ValueError."""
    cfg = load_config()
    with pytest.raises(InputError, match=words):
        accuracy_budget(CoreModel(cfg), [[0.3, 0.3, 0.3]], parse_tolerances({'rod_length': {'tolerance': 1e-6}}),
                        samples=10, **kwargs)


@pytest.mark.parametrize('Q, words', [
    ([[5, 5, 5]], r'^station 1: q1 = 5 m is outside the stroke \[0, 0\.508\] m$'),
    ([[-2, -2, -2]], r'^station 1: q1 = -2 m is outside the stroke \[0, 0\.508\] m$'),
    ([[0.3, 0.3, 0.3], [0.3, 0.3, 300]], r'^station 2: q3 = 300 m is outside the stroke .*millimetres given as metres'),
    ([[0.3, 0.3, 0.3], [0.3, 0.4, 0.3]], r'^station 2: q = \[0\.3, 0\.4, 0\.3\] m tilt the platform by 0\.6208 rad '
                                         r'\(35\.57 deg\), beyond the tilt limit 0\.03491 rad \(2 deg\); allowed: at '
                                         r'most 5 % beyond it, 0\.03665 rad$'),
])
def test_stations_beyond_the_machines_limits_are_refused(Q, words):
    """Rods outside the stroke or tilting the platform far beyond its limit returned numbers: the core's stroke rule
    and the measurements' tilt rule (5 % beyond the limit) now refuse them, naming the station."""
    table = parse_tolerances({'rod_length': {'tolerance': 1e-6}})
    with pytest.raises(LimitError, match=words):
        accuracy_budget(CoreModel(load_config()), Q, table, samples=10)


@pytest.mark.parametrize('kwargs, words', [
    ({'theta': ['a'] * 24}, r"^theta must be 24 finite parameter values, got \['a', 'a'"),
    ({'calibrated': 'x'}, r"^calibrated = 'x'; allowed: a pair \(indices, covariance\) of the calibrated parameters"),
    ({'calibrated': ([0], 'a')}, r"^calibrated covariance must be a finite symmetric matrix, got 'a'$"),
    ({'keep_samples': 'x'}, r"^keep_samples = 'x'; allowed: an integer >= 0"),
    ({'keep_samples': -1}, r'^keep_samples = -1; allowed: an integer >= 0 \(the samples of that many first stations '
                           r'are kept\)$'),
    ({'keep_samples': 1.5}, r'^keep_samples = 1\.5; allowed: an integer >= 0'),
    ({'keep_samples': True}, r'^keep_samples = True; allowed: an integer >= 0'),
    # a third element is now the calibration's alias (held_indices, A): a string there is named as the alias
    ({'calibrated': ([0], np.eye(1), 'x')}, r"^calibrated alias = 'x'; allowed: None or a pair \(held_indices, A\) "
                                            r'with A of shape \(1, number of held parameters\)'),
    ({'calibrated': ([0], np.eye(1), None, 1)}, r'^calibrated = .*; allowed: a pair \(indices, covariance\)'),
])
def test_budget_options_of_the_wrong_kind_are_named(kwargs, words):
    """theta as text was a ValueError, calibrated='x' an IndexError, keep_samples='x' a ValueError and -1 silently
    0."""
    table = parse_tolerances({'rod_length': {'tolerance': 1e-6}})
    with pytest.raises(InputError, match=words):
        accuracy_budget(CoreModel(load_config()), [[0.3, 0.3, 0.3]], table, samples=10, **kwargs)


def test_too_few_samples_for_the_highest_percentile_are_warned_of():
    """A p99 of 10 samples is their largest or between their largest two: warned of, with how many resolve it
    (100: one sample beyond it); from that many on, and for lower percentiles at fewer, not."""
    cfg = load_config()
    table = parse_tolerances({'rod_length': {'tolerance': 1e-6}})
    few = 'Monte Carlo sample'
    cases = ((10, (50.0, 95.0, 99.0), '10 Monte Carlo samples leave none beyond their p99 (it is their largest or '
              'between their largest two); at least 100 resolve it'),
             (1, (99.0,), '1 Monte Carlo sample leaves none beyond its p99 (it is that sample); at least 100 resolve '
              'it'), (19, (95.0,), '19 Monte Carlo samples leave none beyond their p95 (it is their largest or between '
                      'their largest two); at least 20 resolve it'),
             (20, (95.0,), None), (100, (50.0, 95.0, 99.0), None), (3, (50.0,), None))
    for samples, percentiles, warning in cases:
        budget = accuracy_budget(CoreModel(cfg), [[0.3, 0.3, 0.3]], table, samples=samples, seed=1,
                                 percentiles=percentiles)
        said = [w for w in budget.warnings if few in w]
        assert said == ([] if warning is None else [warning]), (samples, said)


def test_percentiles_may_be_any_sequence_of_numbers():
    """A numpy array of percentiles is a sequence of numbers (the check of strings must not refuse it)."""
    cfg = load_config()
    table = parse_tolerances({'rod_length': {'tolerance': 1e-6}})
    budget = accuracy_budget(CoreModel(cfg), [[0.3, 0.3, 0.3]], table, samples=10, percentiles=np.array([50.0, 95.0]))
    assert budget.percentiles == (50.0, 95.0)
    with pytest.raises(InputError, match=r'percentiles \[101, 101, .*; allowed: numbers from 0 to 100'):
        accuracy_budget(CoreModel(cfg), [[0.3, 0.3, 0.3]], table, samples=10, percentiles=[101] * 100_000)


def test_core_model_of_something_else_than_a_config_names_it():
    with pytest.raises(InputError, match=r"config = None; allowed: a GprConfig \(load_config, default_config\)"):
        CoreModel(None)  # type: ignore[arg-type]


def test_joint_play_alone_is_a_uniform_ball():
    """Joint play only (30 um at joint 1): its displacement is uniform in the ball, each component of variance
    ``c^2 / 5`` (``E |d|^2 = 3 c^2 / 5``), so the linearised standard deviations are the Monte Carlo's (20,000 draws:
    within 2 %) and a 1-D quantity's worst case, the ball's support ``c |g|``, is ``sqrt(5)`` of its standard
    deviation."""
    rng = np.random.default_rng(3)
    Q = naive_inverse(rng.uniform(0.1, 0.4, 3), rng.uniform(-0.0349, 0.0349, 3), rng.uniform(-3, 3, 3))
    table = parse_tolerances({'parameters': {}, 'joint_clearance': [3e-5, 0.0, 0.0]})
    b = accuracy_budget(ReferenceModel(kappa=2.0, base_z=False), Q, table, tool=TOOL, samples=20_000, seed=5)
    assert b.sources == ('joint_clearance1',)
    moved = b.std > 1e-3 * np.max(b.std)
    np.testing.assert_allclose(b.mc_std[moved], b.std[moved], rtol=0.02)
    for name, comp in (('platform_vertical', 2), ('heading', 5), ('tool_vertical', 8)):
        np.testing.assert_allclose(b.worst[name], math.sqrt(5.0) * b.std[:, comp], rtol=1e-12)
        assert np.all(b.mc[name][:, -1] <= b.worst[name])


def test_a_range_off_centre_is_linearised_at_its_mean_and_bounded_at_its_ends():
    """rod1_offset known to lie in [0, 0.1] mm (nominal 0, mean 0.05 mm): linearised at its mean (the systematic
    0.05 mm taken exactly), the worst case spans the deviations [-0.05, 0.05] mm about it, so it is the error of the
    offset at 0.1 mm: the Monte Carlo's largest of 4,000 draws within 0.2 % (nearly linear over 0.1 mm)."""
    cfg = load_config()
    rng = np.random.default_rng(6)
    Q = naive_inverse(rng.uniform(0.1, 0.4, 3), rng.uniform(-0.0349, 0.0349, 3), rng.uniform(-3, 3, 3), cfg)
    table = parse_tolerances({'parameters': {'rod1_offset': {'range': [0.0, 1e-4]}}})
    b = accuracy_budget(CoreModel(cfg), Q, table, tool=TOOL, samples=4000, seed=4, percentiles=(100.0,))
    assert b.sources == ('rod1_offset', 'systematic')
    for name in ('platform_vertical', 'tool_horizontal', 'tilt'):
        np.testing.assert_allclose(b.mc[name][:, 0], b.worst[name], rtol=2e-3)


def test_a_draw_taken_at_a_limit_is_not_counted_within_the_worst_case():
    """A calibrated direction ``v`` of (rod1_ux, rod1_offset) the platform's height cannot see (``g . v = 0``): its
    linearised worst case is 0, and every draw's height error is below 1 nm (second order). With rod1_ux one sigma
    (1e-5) inside its limit (0.05) the draws past it are taken at the limit, their offset kept: a height error of
    ``g_ux (d_ux - 1e-5)``, up to 10 nm.
    Such a draw is not the one drawn: it is not counted within the worst case's bounds, so no warning says the
    worst case was exceeded (one did, by 0.11 um). The Monte Carlo's RMS, exact for the machine at its limit, is
    0.012 um against a linearised RSS of 0: compared in the absolute difference, below budget.NONLINEAR_FLOOR
    (0.1 um), it is not warned either (it was, 'differ by 100 %')."""
    m = CoreModel(load_config(overrides={'kappa': 2.0}))
    idx = np.array([m.parameters.index(n) for n in ('rod1_ux', 'rod1_offset')])
    th = m.parameters.nominal.copy()
    th[idx[0]] = 0.05 - 1e-5
    Q = naive_inverse([0.3], [0.02], [1.0])
    g = pose_jacobian(m, th, Q, idx)[0][2]
    v = np.array([g[1], -g[0]]) / math.hypot(*g) * 1e-5          # g . v = 0; rod1_ux moves by up to 3e-5
    b = accuracy_budget(m, Q, parse_tolerances({}), samples=4000, seed=2, theta=th,
                        calibrated=(idx, np.outer(v, v)))
    assert b.worst['platform_vertical'][0] < 1e-12                       # rounding
    assert 1e-9 < b.mc_max['platform_vertical'][0] < 4 * abs(g[0] * v[0])    # the clipped draws': 3 sigma of d_ux
    assert b.rss['platform_vertical'][0] < 1e-12 and 1e-9 < b.mc_rms['platform_vertical'][0] < 1e-7
    assert not [w for w in b.warnings if 'platform vertical' in w], b.warnings


def test_an_rss_or_an_rms_of_zero_is_compared_in_absolute_numbers():
    """Against a linearised RSS or a Monte Carlo RMS of 0 (at most budget.SHARE_FLOOR) the other is warned about
    beyond budget.NONLINEAR_FLOOR (0.1 um), in micrometres: an RSS of 0 against an RMS of 0.05 um was warned 'differ
    by 100 %'. Either way round, 0.05 um is not warned and 0.2 um is; two non-zero numbers still in per cent."""
    from gpr_kinematics.calibration.budget import _warnings

    rss = np.array([0.0, 0.0, 5e-8, 2e-7, 1e-6, 1e-6])
    rms = np.array([5e-8, 2e-7, 0.0, 0.0, 1.05e-6, 1.2e-6])
    labels = ('a', 'b', 'c', 'd', 'e', 'f')
    worst = {name: np.full(6, 1e-6) for name in QUANTITIES}
    warned = _warnings(labels, {name: rss for name in QUANTITIES}, {name: rms for name in QUANTITIES}, worst, worst,
                       10_000)
    vertical = [w for w in warned if 'platform vertical' in w]
    assert [w.split(',')[0] for w in vertical] == ['station b', 'station d', 'station f'], warned
    assert 'RSS 0 um and the Monte Carlo RMS 0.2 um differ by 0.2 um (more than 0.1 um)' in vertical[0]
    assert 'RSS 0.2 um and the Monte Carlo RMS 0 um differ by 0.2 um (more than 0.1 um)' in vertical[1]
    assert 'differ by 17 % (more than 10 %)' in vertical[2]
    assert len(warned) == 3 * len(QUANTITIES) and not [w for w in warned if 'exceeds' in w], warned


def test_a_few_samples_do_not_call_the_model_not_linear():
    """A Monte Carlo RMS of n samples scatters by about 1 / sqrt(2 n) of the true RMS (the RSS, where the model is
    linear): one sample read 'differ by 52 %: the model is not linear' (ten, four warnings), and an RMS drawn low
    by a single sample 'differ by 245 %' (in 5 of 12 seeds). RSS and RMS must now differ by more than
    budget.SCATTERS of those, about the RSS, as well: an RMS 0.34 of the RSS away (52 % of the RMS) is warned from
    39 samples on (3 / sqrt(2 n) < 0.34), one at 0.29 of it (an RSS 3.45 times the RMS: 245 %) from 9 on."""
    from gpr_kinematics.calibration.budget import SCATTERS, _warnings

    rss, rms = np.array([1.52e-6, 3.45e-6, 1.17e-6]), np.array([1e-6, 1e-6, 1e-6])
    worst = {name: np.full(3, 1e-5) for name in QUANTITIES}

    def warned(n):
        return [w.split(',')[0] for w in _warnings(('a', 'b', 'c'), {q: rss for q in QUANTITIES},
                                                  {q: rms for q in QUANTITIES}, worst, worst, n)
                if 'platform vertical' in w]
    assert warned(1) == [] and warned(5) == []
    # a: |a - b| = 0.52 um against 3 / sqrt(2 n) of 1.52 um; b: 2.45 um against that of 3.45 um
    assert SCATTERS / np.sqrt(2 * 38) * 1.52 > 0.52 > SCATTERS / np.sqrt(2 * 39) * 1.52
    first = {n for n in range(1, 400) if 'station a' in warned(n)}
    assert min(first) == 39 and first == set(range(39, 400))
    b = {n for n in range(1, 100) if 'station b' in warned(n)}
    assert min(b) == 9 and SCATTERS / np.sqrt(2 * 8) * 3.45 > 2.45 > SCATTERS / np.sqrt(2 * 9) * 3.45
    assert [w for w in _warnings(('a', 'b', 'c'), {q: rss for q in QUANTITIES}, {q: rms for q in QUANTITIES},
                                 worst, worst, 10_000) if 'platform vertical' in w and 'station c' in w][0].count(
        'differ by 17 % (more than 10 %)') == 1


def test_calibrated_draws_do_not_depend_on_the_eigenvectors_numpy_chooses(monkeypatch):
    """The plan's covariance was drawn through V sqrt(lam): eigh's eigenvectors are fixed up to sign and, for
    near-equal eigenvalues, mixing, which numpy 1.26 and 2.4 chose differently (the same seed gave percentiles 3 %
    apart). The symmetric root draws the same samples whatever eigh returns, and the 3-sigma test is its own."""
    from gpr_kinematics.calibration import monte_carlo
    from gpr_kinematics.calibration.tolerances import load_tolerances
    from gpr_kinematics.inputs.resources import config_path

    table = load_tolerances(config_path('calibration/tolerances_example.yaml'))
    rng = np.random.default_rng(4)
    A = rng.normal(size=(4, 4))
    C = A @ A.T * 1e-10
    C[:2, :2] = np.diag([1.166316e-10, 1.166316e-10])   # two equal eigenvalues (the plan's: to 1.5e-5 of each other)
    C[:2, 2:] = C[2:, :2] = 0.0
    cal = (np.arange(4), C)
    first = monte_carlo.sample([], cal, table, np.random.default_rng(0), 500, 2, 4)
    eigh = np.linalg.eigh

    def turned(M):
        lam, V = eigh(M)
        c, s = math.cos(0.7), math.sin(0.7)
        V = V.copy()
        V[:, :2] = V[:, :2] @ np.array([[c, -s], [s, c]])   # another basis of the near-equal pair ...
        return lam, -V                                        # ... and every sign flipped

    monkeypatch.setattr(np.linalg, 'eigh', turned)
    second = monte_carlo.sample([], cal, table, np.random.default_rng(0), 500, 2, 4)
    np.testing.assert_allclose(second[0], first[0], rtol=1e-9, atol=1e-20)   # the same root, to rounding
    assert np.array_equal(second[3], first[3]) and 0 < first[3].sum() < first[3].size


def test_stations_at_the_edges_the_core_allows_are_budgeted():
    """The budget's limits are the core's: a rod 1e-12 m beyond the stroke (its rounding slack) and a platform 3 %
    beyond the tilt limit (the measurements' 5 % margin) are budgeted; 6 % beyond is refused."""
    from gpr_kinematics.core import naive_inverse

    cfg = load_config()
    table = parse_tolerances({'rod_length': {'tolerance': 1e-6}})
    accuracy_budget(CoreModel(cfg), [[cfg.stroke_max + 1e-12, cfg.stroke_max, cfg.stroke_max]], table, samples=10)
    for factor, refused in ((1.03, False), (1.06, True)):
        q = naive_inverse(0.25, factor * cfg.tilt_limit, 0.3, cfg)
        if refused:
            with pytest.raises(LimitError, match=r'station 1: .*beyond the tilt limit'):
                accuracy_budget(CoreModel(cfg), [q], table, samples=10)
        else:
            accuracy_budget(CoreModel(cfg), [q], table, samples=10)


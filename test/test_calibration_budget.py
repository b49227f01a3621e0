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
from gpr_kinematics.config import load_config
from gpr_kinematics.errors import ConfigError, InputError
from gpr_kinematics.kinematics import naive_inverse

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
    table = parse_tolerances({'parameters': {'radius': {'tolerance': 5e-5}, 'rod_azimuths': {'tolerance': 5e-4}},
                              'rod_length': {'tolerance': 2e-6}})
    b = accuracy_budget(m, Q, table, tool=TOOL, samples=0)
    J = pose_jacobian(m, m.parameters.nominal, Q)                     # (N, 6, 4): independent of the engine's rows
    from gpr_kinematics.calibration.model import evaluate, rod_jacobian
    _, rot = evaluate(m, m.parameters.nominal, Q)
    Jq = rod_jacobian(m, m.parameters.nominal, Q)
    half = np.array([5e-5, 5e-4, 5e-4, 5e-4, 2e-6, 2e-6, 2e-6])
    for i in range(2):
        G = np.concatenate([J[i], Jq[i]], axis=1)                       # (6, 7)
        a = rot[i] @ np.array(TOOL)
        tool = G[:3] + np.cross(G[3:].T, a).T
        for name, rows in (('platform_horizontal', G[:2]), ('tool_horizontal', tool[:2])):
            exact = zonotope_max_norm(np.zeros(2), (rows * half).T)
            assert exact <= b.worst[name][i] <= exact / math.cos(math.pi / 512) * (1 + 1e-12)
        assert b.worst['tool_vertical'][i] == pytest.approx(np.abs(tool[2]) @ half, rel=1e-12)
    assert 'monte_carlo' not in b.as_dict()['stations'][0]['quantities']['tilt']


def test_calibrated_covariance_replaces_the_tolerances():
    cfg = load_config()
    m = CoreModel(cfg)
    Q = naive_inverse([0.3], [0.03], [1.0], cfg)
    rng = np.random.default_rng(0)
    A = rng.normal(size=(4, 4)) * np.array([1e-6, 1e-5, 1e-5, 1e-5])
    cov = A @ A.T
    table = parse_tolerances({'parameters': {'radius': {'tolerance': 5e-5}}})
    b = accuracy_budget(m, Q, table, samples=2000, seed=1, calibrated=(np.arange(4), cov))
    assert b.sources == ('calibration',)
    J = pose_jacobian(m, m.parameters.nominal, Q)[0]
    np.testing.assert_allclose(b.std[0, :6], np.sqrt(np.diag(J @ cov @ J.T)), rtol=1e-9)
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


def test_refusals():
    cfg = load_config()
    m = CoreModel(cfg)
    Q = [[0.3, 0.3, 0.3]]
    table = parse_tolerances({'rod_length': {'tolerance': 1e-6}})
    with pytest.raises(InputError, match=r'joint_clearance needs a model with per-joint geometry; CoreModel'):
        accuracy_budget(m, Q, parse_tolerances({'joint_clearance': 1e-6}, 't.yaml'))
    with pytest.raises(ConfigError, match=r"unknown parameter 'offset1'"):
        accuracy_budget(m, Q, parse_tolerances({'parameters': {'offset1': {'tolerance': 1e-6}}}))
    with pytest.raises(InputError, match=r'samples = 2000000; allowed: an integer from 0 to 1000000'):
        accuracy_budget(m, Q, table, samples=2_000_000)
    with pytest.raises(InputError, match=r'tool must be 3 finite coordinates'):
        accuracy_budget(m, Q, table, tool=(1e300, 0, 0))
    with pytest.raises(InputError, match=r'percentiles'):
        accuracy_budget(m, Q, table, percentiles=(50, 101))
    with pytest.raises(InputError, match=r'2 labels for 1 stations'):
        accuracy_budget(m, Q, table, labels=['a', 'b'])
    with pytest.raises(InputError, match=r'theta must be 4 finite parameter values'):
        accuracy_budget(m, Q, table, theta=[0.1, 0.2])
    with pytest.raises(InputError, match=r'indices must be distinct integers from 0 to 3'):
        accuracy_budget(m, Q, table, calibrated=([0, 0], np.eye(2)))
    with pytest.raises(InputError, match=r'not positive semi-definite'):
        accuracy_budget(m, Q, table, calibrated=([0, 1], np.array([[1e-10, 0], [0, -1e-10]])))
    singular = np.array([[1e-10, 1e-10], [1e-10, 1e-10]])            # rank 1: sampled without failure
    b = accuracy_budget(m, [[0.3, 0.31, 0.3]], table, calibrated=([0, 1], singular), samples=100)
    assert np.all(np.isfinite(b.mc_std))
    with pytest.raises(InputError, match=r'q2 = nan is not a finite number'):
        accuracy_budget(m, [[0.3, np.nan, 0.3]], table)

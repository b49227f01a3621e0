"""Self-describing bags: ``gpr verify`` uses the geometry recorded on ``/gpr/geometry``; ``--config`` overrides
it and the difference is reported (keys, and the largest pose difference over the bag's samples, checked
against per-sample forward kinematics in the test); a bag without it falls back to the package's."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from bag_support import REFERENCE, STATE, rewritten, small_sweep, write_bag
from gpr_kinematics.bags.reader import read_bag
from gpr_kinematics.bags.typestore import GEOMETRY_TOPIC, GPR_TOPICS
from gpr_kinematics.bags.verify import verify_bag
from gpr_kinematics.cli import main as cli
from gpr_kinematics.core import forward
from gpr_kinematics.core.config import GprConfig, load_config

#: A different machine: 0.1 mm more radius, rods not at 120 deg, the polar model.
OTHER = {'radius': 0.093318, 'rod_azimuths': [0.0, 2.1, 4.19], 'model': 'polar'}


@pytest.fixture(scope='module')
def other(tmp_path_factory: pytest.TempPathFactory) -> Path:
    cfg = load_config(overrides=OTHER)
    return write_bag(tmp_path_factory.mktemp('other') / 'other', small_sweep(config=cfg), dict(GPR_TOPICS))


def test_the_recorded_geometry_is_used_and_round_trips(other: Path) -> None:
    text = read_bag(other).topic(GEOMETRY_TOPIC).columns()['data'][0]
    assert GprConfig.from_mapping(yaml.safe_load(text)) == load_config(overrides=OTHER)
    result = verify_bag(other)
    assert result.passed, [f.line() for f in result.failures]
    assert result.notes[0] == f'verified against the geometry recorded on {GEOMETRY_TOPIC}'
    assert result.config['radius'] == 0.093318 and result.geometry == {'source': 'recorded'}


def test_a_given_config_is_compared_with_the_recorded_one(tmp_path: Path, other: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    package = tmp_path / 'package.yaml'
    package.write_text('{}\n')  # the package's configuration, given explicitly
    assert cli.main(['verify', str(other), '--config', str(package), '--json']) == 1
    data = json.loads(capsys.readouterr().out)
    geo = data['geometry']
    assert geo['source'] == f'--config {package}' and geo['samples'] == 30
    assert set(geo['differing_keys']) == {'radius', 'rod_azimuths', 'model', 'characteristic_length'}
    assert geo['differing_keys']['radius'] == {'recorded': 0.093318, 'given': 0.093218}
    # The largest pose difference, recomputed sample by sample with the scalar forward kinematics.
    q = read_bag(other).topic(STATE).columns()['q']
    given, recorded = load_config(), load_config(overrides=OTHER)
    dp = [np.linalg.norm(forward(r, recorded, check_limits=False).position
                         - forward(r, given, check_limits=False).position) for r in q]
    assert geo['max_position_difference'] == pytest.approx(max(dp), rel=1e-9)
    assert 1e-6 < geo['max_position_difference'] < 1e-2
    assert 0 < geo['max_orientation_difference'] < 0.1
    failed = {c['name'] for c in data['checks'] if c['status'] == 'FAIL'}
    assert 'state.side_lengths' in failed and 'topic.geometry' not in failed
    assert any('differs from the recorded geometry in' in n and 'radius (0.093318 recorded, 0.093218 given)' in n
               for n in data['notes'])
    # The table says it in words before the failures.
    assert cli.main(['verify', str(other), '--config', str(package)]) == 1
    out = capsys.readouterr().out
    assert out.index('differs from the recorded geometry') < out.index('FAIL ')


def test_a_given_config_equal_to_the_recorded_one(tmp_path: Path, other: Path) -> None:
    same = tmp_path / 'same.yaml'
    same.write_text(yaml.safe_dump(OTHER))
    result = verify_bag(other, config=load_config(same), config_source=str(same))
    assert result.passed and f'{same} equals the recorded geometry' in result.notes


def test_a_bag_without_geometry_falls_back_and_says_so(tmp_path: Path) -> None:
    bag = rewritten(REFERENCE, tmp_path / 'no_geometry', lambda topic, msg: None if topic == GEOMETRY_TOPIC else msg)
    result = verify_bag(bag)
    assert result.passed and result.geometry == {'source': 'package'}
    assert result.notes == ['no geometry recorded in the bag: verified against the package configuration',
                            'robot example_dual_arm recorded on /gpr/robot; no robot states (a platform stream, '
                            'or a recording of fewer topics): no wafer pose verified']
    assert next(c for c in result.checks if c.name == 'topic.geometry').skipped == 'no geometry recorded in the bag'


def _geometry(text: str) -> Any:
    def edit(topic: str, msg: Any) -> Any:
        if topic == GEOMETRY_TOPIC:
            msg.data = text
        return msg
    return edit


@pytest.mark.parametrize('text,words', [
    ('radius: [0.1\n', 'not valid YAML'),
    ('radius: &r 0.1\nstroke_max: *r\n', 'YAML aliases (*name) are not accepted'),
    ('- 1\n- 2\n', 'not a mapping'),
    ('radius: 0.093218\nradious: 1\n', 'unknown key(s) radious'),
    ('radius: -1\n', 'radius = -1 is invalid'),
])
def test_an_unusable_recorded_geometry_fails_its_check(tmp_path: Path, text: str, words: str) -> None:
    src = write_bag(tmp_path / 'src', small_sweep(), dict(GPR_TOPICS))
    bag = rewritten(src, tmp_path / 'b', _geometry(text))
    result = verify_bag(bag)
    failed = [(f.check, f.detail) for f in result.failures]
    assert len(failed) == 1 and failed[0][0] == 'topic.geometry' and words in failed[0][1], failed
    assert 'the recorded geometry is unusable: verified against the package configuration' in result.notes


def test_two_different_geometries_in_one_bag_fail(tmp_path: Path) -> None:
    msgs = small_sweep()
    other = [m for m in small_sweep(config=load_config(overrides={'radius': 0.0933})) if m[0] == GEOMETRY_TOPIC]
    bag = write_bag(tmp_path / 'b', msgs + [(GEOMETRY_TOPIC, msgs[-1][1], other[0][2])], dict(GPR_TOPICS))
    failed = [(f.check, f.detail) for f in verify_bag(bag).failures]
    assert failed == [('topic.geometry', 'the geometry messages differ')]


#: An imperfect machine as a calibration writes it: rods off their circle, zero offsets, tilted rods, the platform
#: joints moved, the compliant model with its kappa.
IMPERFECT = {'rod_offsets': [3e-5, -2e-5, 1e-5], 'rod_directions': [[1e-4, -5e-5], [-8e-5, 1e-4], [5e-5, 6e-5]],
             'rod_positions': [[0.09324, -1e-5], [-0.04664, 0.080745], [-0.046599, -0.080704]],
             'platform_joints': [[0.093208, 2e-5], [-0.046589, 0.080739], [-0.046624, -0.080749]],
             'kappa': [3.0, 2.5, 4.0], 'model': 'compliant'}


def test_an_imperfect_machines_bag_verifies_and_draws_its_own_geometry(tmp_path: Path) -> None:
    """A bag of an imperfect machine (the synthetic writer, its geometry recorded) verifies, the markers included;
    they draw the machine's rods (feet P_k(0) = B_k + o_k u_k, tops the joint centres) and the naive model's
    outline of its platform joints p_k (computed here from the config's values)."""
    cfg = load_config(overrides=IMPERFECT)
    bag = write_bag(tmp_path / 'imperfect', small_sweep(config=cfg), dict(GPR_TOPICS))
    result = verify_bag(bag)
    assert result.passed, [f.line() for f in result.failures]
    assert any(c.name == 'topic.markers' and not c.skipped for c in result.checks)
    from gpr_kinematics.bags.typestore import typestore
    topics = read_bag(bag).topics
    ts = typestore()
    state = ts.deserialize_cdr(topics[STATE].raw[7], GPR_TOPICS[STATE])
    markers = ts.deserialize_cdr(topics['/gpr/markers'].raw[7], GPR_TOPICS['/gpr/markers'])
    pts = {m.ns: np.array([[p.x, p.y, p.z] for p in m.points]) for m in markers.markers}
    d = np.asarray(cfg.rod_directions)
    u = np.column_stack([d, np.sqrt(1 - np.sum(d * d, axis=1))])
    B = np.column_stack([np.asarray(cfg.rod_positions), np.zeros(3)])
    feet = B + np.asarray(cfg.rod_offsets)[:, None] * u
    np.testing.assert_allclose(pts['base'], feet[[0, 1, 2, 0]], rtol=0, atol=1e-15)
    q = np.asarray(state.q)
    np.testing.assert_allclose(pts['platform'], B + (q + np.asarray(cfg.rod_offsets))[:, None] * u, rtol=0, atol=1e-15)
    p = state.nominal_pose
    from scipy.spatial.transform import Rotation
    Rn = Rotation.from_quat([p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w]).as_matrix()
    joints = np.column_stack([np.asarray(cfg.platform_joints), np.zeros(3)])
    outline = np.array([p.position.x, p.position.y, p.position.z]) + joints @ Rn.T
    np.testing.assert_allclose(pts['nominal_platform'], outline[[0, 1, 2, 0]], rtol=0, atol=1e-12)

"""The state checks follow ``messages.STATE_FROM_RESULT``: every field of the table is compared, a field added
to it is compared without an edit of the checks (a default rule), and the comparisons measure what they say
(a rotation of a known angle, an azimuth ignored without tilt)."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bag_support import STATE, rewritten, small_sweep, write_bag
from gpr_kinematics.bags import checks_state
from gpr_kinematics.bags.checks_state import INPUTS, RULES, rule_for
from gpr_kinematics.bags.reader import read_bag
from gpr_kinematics.bags.typestore import GPR_TOPICS
from gpr_kinematics.bags.verify import verify_bag
from gpr_kinematics.core import forward_batch
from gpr_kinematics.core.messages import STATE_FROM_RESULT


@pytest.fixture(scope='module')
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_bag(tmp_path_factory.mktemp('state') / 'b', small_sweep(), dict(GPR_TOPICS))


def test_every_field_of_the_table_is_checked(bag: Path) -> None:
    result = verify_bag(bag)
    assert result.passed
    c = read_bag(bag).topic(STATE).columns()
    names = {ch.name: ch for ch in result.checks}
    for field, _attr in STATE_FROM_RESULT:
        if field in INPUTS:
            continue
        check = rule_for(field, c).check
        assert check in names and names[check].checked == 30, field
    assert set(RULES) <= {f for f, _ in STATE_FROM_RESULT}  # no rule for a field that is not in the table


def test_a_field_added_to_the_table_is_checked_without_an_edit(bag: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Map two message fields that the table does not hold to result attributes: the number gets agreement
    within Tolerances.agreement, the string equality; both fail where they differ."""
    extended = (*STATE_FROM_RESULT, ('commanded_tilt', 'tilt'), ('header.frame_id', 'model'))
    monkeypatch.setattr(checks_state, 'STATE_FROM_RESULT', extended)
    result = verify_bag(bag)
    checks = {c.name: c for c in result.checks}
    tilt = checks['state.commanded_tilt']
    # The sweep commands alpha from -2 to 2 deg; the result's tilt is its magnitude: they differ by 2|alpha|.
    alpha = read_bag(bag).topic(STATE).columns()['commanded_tilt']
    assert tilt.failed == int(np.count_nonzero(alpha < 0)) and tilt.limit == 1e-9
    assert tilt.worst == pytest.approx(2 * math.radians(2.0), rel=1e-6)
    frame = checks['state.header_frame_id']
    assert frame.failed == 30 and frame.failures[0].value == 1.0 and frame.limit == 0.0


def _rotate(topic: str, msg: Any, angle: float = 1e-6) -> Any:
    if topic == STATE and msg.sample == 5:
        o = msg.pose.orientation
        # q * (rotation of `angle` about z): the stored orientation turned by exactly `angle`.
        s, c = math.sin(angle / 2), math.cos(angle / 2)
        o.x, o.y, o.z, o.w = o.x * c + o.y * s, o.y * c - o.x * s, o.z * c + o.w * s, o.w * c - o.z * s
    return msg


def test_an_orientation_turned_by_a_known_angle(tmp_path: Path, bag: Path) -> None:
    turned = rewritten(bag, tmp_path / 't', _rotate)
    checks = {c.name: c for c in verify_bag(turned).checks}
    assert checks['state.pose_orientation'].failures[0].sample == 5
    assert checks['state.pose_orientation'].worst == pytest.approx(1e-6, rel=1e-6)


def test_the_azimuth_is_compared_by_the_tilt_vectors() -> None:
    """The azimuth's difference times the tilt: nothing without tilt, the tilt vectors' distance (for a small
    difference) with it; a NaN azimuth fails even without tilt."""
    q = np.array([[0.5, 0.5, 0.5], [0.499, 0.5, 0.501]])
    fk = forward_batch(q)
    stored = np.array([[fk.tilt_azimuth[0] + 1.0], [fk.tilt_azimuth[1] + 1e-6]])
    err = checks_state._error('azimuth', stored, fk.tilt_azimuth, fk)
    assert fk.tilt[0] < 1e-12 < fk.tilt[1]
    assert err[0] == 0.0 and err[1] == pytest.approx(1e-6 * fk.tilt[1], rel=1e-6)
    a, b = fk.tilt[1] * np.array([np.cos(stored[1, 0]), np.sin(stored[1, 0])]), \
        fk.tilt[1] * np.array([np.cos(fk.tilt_azimuth[1]), np.sin(fk.tilt_azimuth[1])])
    assert err[1] == pytest.approx(np.linalg.norm(a - b), rel=1e-6)   # the vectors' distance
    assert np.isnan(checks_state._error('azimuth', np.array([[np.nan], [0.0]]), fk.tilt_azimuth, fk)[0])
    # Wrapped: a full turn is no difference.
    assert checks_state._error('angle', fk.twist + 2 * math.pi, fk.twist, fk) == pytest.approx([0, 0], abs=1e-12)


def test_a_stream_through_tiny_tilts_verifies_and_a_turned_azimuth_fails(tmp_path: Path) -> None:
    """An honest platform program (a tilted station, a 1 ms dwell, then a level one, at 50 Hz: a sample passes a tilt
    of 1.5e-8 rad) failed ``state.commanded``: the achieved azimuth of so short a tilt rounds by 7.9e-9 rad against
    the 1e-9 rad bound. The commanded and achieved tilt vectors are compared now (1e-16 apart there); an azimuth
    turned by 1e-7 rad at a tilt of 0.02 rad (2e-9 rad of tilt vector) still fails."""
    from gpr_kinematics.bags.synthetic import platform_program_messages
    from gpr_kinematics.bags.typestore import PLATFORM_STATE_TOPIC, typestore
    from gpr_kinematics.robot.platform_program import parse_platform_program

    program = parse_platform_program({'move_time': 2.0, 'stations': [
        {'name': 's1', 'height': 0.35, 'tilt': 0.02, 'azimuth': 2.634894976671063, 'dwell': 0.001},
        {'name': 's0', 'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0}]})
    msgs = platform_program_messages(program, rate=50.0)
    store = typestore()
    states = [store.deserialize_cdr(raw, GPR_TOPICS[t]) for t, _, raw in msgs if t == PLATFORM_STATE_TOPIC]
    tilts = np.array([s.commanded_tilt for s in states])
    assert np.any((tilts > 0.0) & (tilts < 1e-7))   # the stream passes a tiny tilt
    types = {t: GPR_TOPICS[t] for t in {m[0] for m in msgs}}
    assert verify_bag(write_bag(tmp_path / 'honest', msgs, types)).passed
    k = int(np.argmax(tilts))   # at 0.02 rad: the azimuth turned by 1e-7 rad

    def turn(topic: str, msg: Any) -> Any:
        if topic == PLATFORM_STATE_TOPIC and msg.sample == states[k].sample:
            msg.commanded_azimuth += 1e-7
        return msg

    result = verify_bag(rewritten(tmp_path / 'honest', tmp_path / 'turned', turn))
    assert {c.name for c in result.checks if not c.passed} >= {'state.commanded'}

"""Forward, naive and inverse kinematics: numbers, round trips, batch = single, conventions, errors."""
import math
import re

import numpy as np
import pytest
from gpr_kinematics.core import (
    ForwardResult,
    forward,
    forward_batch,
    inverse,
    inverse_batch,
    naive_forward,
    naive_inverse,
    naive_pose,
)
from gpr_kinematics.core.config import MODELS, GprConfig, load_config
from gpr_kinematics.core.rotations import (
    matrix_from_quaternion,
    quaternion_from_matrix,
    quaternion_multiply,
    rotation_z,
    tilt_from_matrix,
    tilt_normal,
    tilt_rotation,
)
from gpr_kinematics.errors import ConvergenceError, InputError, LimitError
from scipy.spatial.transform import Rotation

CFG = load_config()
R = CFG.radius


def _random_targets(n, seed=0, limit=1.0):
    rng = np.random.default_rng(seed)
    return (rng.uniform(0.05, 0.45, n), rng.uniform(-limit, limit, n) * CFG.tilt_limit,
            rng.uniform(-np.pi, np.pi, n))


# --- geometry conventions ---------------------------------------------------------------------------------

def test_quaternions_match_scipy():
    rot = Rotation.random(500, random_state=7)
    q = quaternion_from_matrix(rot.as_matrix())
    ref = rot.as_quat()
    ref = np.where(ref[:, 3:] < 0, -ref, ref)
    np.testing.assert_allclose(q, ref, atol=1e-14)
    np.testing.assert_allclose(matrix_from_quaternion(q), rot.as_matrix(), atol=1e-14)
    a, b = Rotation.random(2, random_state=8)
    np.testing.assert_allclose(matrix_from_quaternion(quaternion_multiply(a.as_quat(), b.as_quat())),
                               (a * b).as_matrix(), atol=1e-14)


def test_tilt_is_rotation_about_horizontal_axis():
    rng = np.random.default_rng(1)
    t, g, tw = rng.uniform(-0.1, 0.1, 200), rng.uniform(-4, 4, 200), rng.uniform(-0.2, 0.2, 200)
    axis = np.stack([np.cos(g), np.sin(g), np.zeros_like(g)], -1)
    np.testing.assert_allclose(tilt_rotation(t, g), Rotation.from_rotvec(axis * t[:, None]).as_matrix(), atol=1e-15)
    np.testing.assert_allclose(tilt_normal(t, g), tilt_rotation(t, g)[:, :, 2], atol=1e-16)
    tilt, az, twist = tilt_from_matrix(tilt_rotation(t, g) @ rotation_z(tw))
    assert np.all(tilt >= 0) and np.all(az > -np.pi) and np.all(az <= np.pi)
    np.testing.assert_allclose(tilt, np.abs(t), atol=1e-15)
    np.testing.assert_allclose(twist, tw, atol=1e-14)
    # a negative tilt is a positive one about the opposite axis
    expected = np.angle(np.exp(1j * np.where(t < 0, g + np.pi, g)))
    np.testing.assert_allclose(np.angle(np.exp(1j * (az - expected))), 0.0, atol=1e-13)


# --- forward kinematics -------------------------------------------------------------------------------------

@pytest.mark.parametrize('model', MODELS)
def test_forward_numbers_and_invariants(model):
    q = np.array([0.5, 0.503, 0.498])
    fk = forward(q, model=model)
    L = [math.sqrt(3 * R * R + (q[j] - q[i]) ** 2) for i, j in ((0, 1), (1, 2), (2, 0))]
    np.testing.assert_allclose(fk.side_lengths, L, rtol=0, atol=1e-16)
    assert fk.fit_residual < 1e-12 and fk.residual <= CFG.tolerance
    assert fk.iterations <= 4
    # The joint centres P_k lie on their rods: the pose maps the virtual joint points onto them.
    th = np.asarray(CFG.rod_azimuths)
    P = np.stack([R * np.cos(th), R * np.sin(th), q], -1)
    assert np.linalg.norm(fk.quaternion) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(matrix_from_quaternion(fk.quaternion), fk.rotation, atol=1e-15)
    np.testing.assert_allclose(fk.rotation @ fk.rotation.T, np.eye(3), atol=1e-15)
    # the platform normal is the normal of the plane of the three joint centres (model-independent)
    n = np.cross(P[1] - P[0], P[2] - P[0])
    np.testing.assert_allclose(fk.normal, n / np.linalg.norm(n), atol=1e-15)
    assert fk.tilt == pytest.approx(math.acos(fk.normal[2]), abs=1e-12)
    np.testing.assert_allclose(fk.centre_shift, fk.position - fk.nominal_position, atol=0)
    assert fk.within_budget and np.all(fk.joint_displacement < CFG.imperfection_budget)


def test_centre_shift_of_radial_model_for_2_deg_about_x():
    """Radial model, tilt 2 deg about the x axis at 0.5 m: the centre shift is 28.41 um along x (docs/core.md)."""
    ik = inverse(0.5, math.radians(2.0), 0.0, model='radial')
    shift = ik.achieved.centre_shift
    assert shift[0] == pytest.approx(28.41e-6, abs=0.01e-6)
    assert abs(shift[1]) < 1e-15


def test_polar_model_weighted_keeps_centre_unweighted_shifts_it():
    """Finding recorded in docs/core.md: the unit-free weighting moves joints tangentially."""
    weighted = inverse(0.5, math.radians(2.0), 0.0, model='polar').achieved
    plain = inverse(0.5, math.radians(2.0), 0.0, model='polar',
                    config=CFG.replace(weighting='unweighted')).achieved
    assert np.linalg.norm(weighted.centre_shift[:2]) < 1e-8
    assert plain.centre_shift[0] == pytest.approx(27.92e-6, abs=0.05e-6)
    assert np.max(np.abs(plain.virtual_joints[3:])) < 1e-5  # "phi negligibly small" (paper Fig. 7)


@pytest.mark.parametrize('model', MODELS)
def test_batch_equals_single(model):
    Q = naive_inverse(*_random_targets(64, seed=5))
    Q[::7] = Q[::7, :1]  # some singular rows
    fb = forward_batch(Q, model=model)
    for i in range(0, 64, 3):
        one = forward(Q[i], model=model)
        for name in ('virtual_joints', 'side_lengths', 'position', 'rotation', 'quaternion', 'centre_shift',
                     'nominal_position', 'nominal_quaternion', 'joint_displacement'):
            np.testing.assert_allclose(getattr(fb[i], name), getattr(one, name), rtol=0, atol=1e-14,
                                       err_msg=name)
        for name in ('tilt', 'tilt_azimuth', 'twist', 'residual', 'fit_residual'):
            assert getattr(fb[i], name) == pytest.approx(getattr(one, name), abs=1e-14), name
        assert fb[i].iterations == one.iterations and fb[i].within_budget == one.within_budget


def test_naive_model_round_trip():
    h, t, g = _random_targets(300, seed=6)
    q = naive_inverse(h, t, g)
    pos, rot = naive_forward(q)
    np.testing.assert_allclose(pos[:, 2], h, atol=1e-15)
    np.testing.assert_allclose(rot, tilt_rotation(t, g), atol=1e-14)
    p2, r2 = naive_pose(h, t, g)
    np.testing.assert_allclose(p2, pos, atol=1e-15)
    # q_k = z + (Rot r_k)_z  (the naive model, Bratovanov & Sotirov Fig. 2)
    th = np.asarray(CFG.rod_azimuths)
    r = np.stack([R * np.cos(th), R * np.sin(th), np.zeros(3)], -1)
    np.testing.assert_allclose(q, h[:, None] + np.einsum('nj,kj->nk', rot[:, 2, :], r), atol=1e-15)


# --- inverse kinematics -------------------------------------------------------------------------------------

@pytest.mark.parametrize('model', MODELS)
def test_inverse_round_trip_random_targets(model):
    h, t, g = _random_targets(400, seed=11)
    ib = inverse_batch(h, t, g, model=model)
    fb = forward_batch(ib.q, model=model)  # an independent forward call on the answer
    n_target = tilt_normal(t, g)
    assert np.max(np.abs(fb.position[:, 2] - h)) < 1e-12
    assert np.max(np.abs(fb.tilt - np.abs(t))) < 1e-12
    assert np.max(np.arctan2(np.linalg.norm(np.cross(fb.normal, n_target), axis=-1),
                             np.einsum('ni,ni->n', fb.normal, n_target))) < 1e-12
    # the tilt axis: the target azimuth, or the opposite one for a negative tilt (where the tilt is defined)
    expected = np.where(t < 0, g + np.pi, g)
    tilted = np.abs(t) > 1e-6
    assert np.max(np.abs(np.angle(np.exp(1j * (fb.tilt_azimuth - expected)))[tilted])) < 1e-9
    assert ib.iterations.max() <= 6
    for i in range(0, 400, 50):
        one = inverse(h[i], t[i], g[i], model=model)
        np.testing.assert_allclose(one.q, ib.q[i], rtol=0, atol=1e-14)


def test_inverse_with_tool_point_prescribes_its_height():
    tool = np.array([0.12, -0.05, 0.25])
    ik = inverse(0.3, math.radians(1.2), 2.0, tool=tool)
    fk = forward(ik.q)
    assert (fk.position + fk.rotation @ tool)[2] == pytest.approx(0.3, abs=1e-12)
    assert fk.tilt == pytest.approx(math.radians(1.2), abs=1e-12)
    assert fk.tilt_azimuth == pytest.approx(2.0, abs=1e-9)


def test_inverse_batch_with_one_tool_point_per_target_equals_single_calls():
    h, t, g = _random_targets(40, seed=12)
    rng = np.random.default_rng(13)
    tools = np.column_stack([rng.uniform(-0.3, 0.3, 40), rng.uniform(-0.3, 0.3, 40), rng.uniform(0.0, 0.2, 40)])
    h = 0.2 + 0.5 * h  # the rods (about h - tool z) stay inside the stroke
    ib = inverse_batch(h, t, g, tool=tools)
    for i in range(40):
        one = inverse(h[i], t[i], g[i], tool=tools[i])
        np.testing.assert_allclose(ib.q[i], one.q, rtol=0, atol=1e-14)
        fk = ib.achieved[i]
        assert (fk.position + fk.rotation @ tools[i])[2] == pytest.approx(h[i], abs=1e-12)
    # a scalar height with per-target tools broadcasts; a count that differs is refused by name
    two = inverse_batch(0.3, 0.01, 0.5, tool=tools[:2])
    np.testing.assert_allclose(two.q[1], inverse(0.3, 0.01, 0.5, tool=tools[1]).q, rtol=0, atol=1e-14)
    with pytest.raises(InputError, match='height, tilt, azimuth and tool must have the same length'):
        inverse_batch(h[:3], t[:3], g[:3], tool=tools[:2])
    # an empty one beside one value stretched that value to no target: an empty answer, not a refusal
    for args, tool, got in ((([0.5], [], [0.0]), None, '1, 0, 1, 1'), (([0.5], 0.01, 0.0), np.zeros((0, 3)),
                                                                      '1, 1, 1, 0')):
        with pytest.raises(InputError, match=f'must have the same length .*, got {got}$'):
            inverse_batch(*args, tool=tool) if tool is not None else inverse_batch(*args)
    assert inverse_batch([], [], []).q.shape == (0, 3) == inverse_batch([], [], [], tool=np.zeros((0, 3))).q.shape
    assert inverse_batch(0.5, [], []).q.shape == (0, 3)   # a scalar stretches over an empty batch, as over any
    with pytest.raises(InputError, match=r'must broadcast together .*, got shapes \(1,\), \(0,\), \(1,\)'):
        naive_inverse([0.5], [], [0.0])   # the naive model's twin of the rule
    assert naive_inverse(0.5, [], []).shape == (0, 3)


def test_inverse_at_the_singular_configuration():
    ik = inverse(0.25, 0.0, 1.0)
    np.testing.assert_allclose(ik.q, 0.25, atol=1e-16)
    assert ik.achieved.tilt == 0.0 and ik.iterations == 0


# --- errors --------------------------------------------------------------------------------------------------

@pytest.mark.parametrize('q, exc, pattern', [
    ([0.5, float('nan'), 0.5], InputError, r'q2 = nan is not a finite number'),
    ([0.5, 0.5, float('inf')], InputError, r'q3 = inf is not a finite number'),
    ([0.5, 0.5], InputError, r'3 values'),
    (['a', 0.5, 0.5], InputError, r'numbers'),
    ([0.6, 0.5, 0.5], LimitError, r'q1 = 0.6 m is outside the stroke \[0, 0.508\] m'),
    ([0.5, 0.5, -0.01], LimitError, r'q3 = -0.01 m is outside the stroke'),
    ([0.2, 0.3, 0.25], LimitError, r'beyond the tilt limit 0.03491 rad \(2 deg\)'),
])
def test_forward_rejects_bad_input(q, exc, pattern):
    with pytest.raises(exc, match=pattern):
        forward(q)


def test_forward_batch_names_the_sample():
    Q = np.full((4, 3), 0.3)
    Q[2, 1] = 0.9
    with pytest.raises(LimitError, match=r'q2 = 0.9 m \(sample 2\)'):
        forward_batch(Q)
    with pytest.raises(InputError, match=r'shape \(N, 3\)'):
        forward_batch(np.zeros((4, 2)))


def test_unknown_model_and_limits_of_inverse():
    # the refusal lists all the argument takes: the models, and None or '' for the configuration's (it omitted these)
    with pytest.raises(InputError) as err:
        forward([0.3, 0.3, 0.3], GprConfig(model='offset'), model='rigid')
    assert str(err.value) == ("unknown virtual-joint model 'rigid'; allowed: radial, polar, offset, compliant, or None "
                              "or '' for the configuration's model (offset)")
    assert forward([0.3, 0.301, 0.3], GprConfig(model='offset'), model='').model == 'offset'
    # the tilt in radians (as the tilt_limit parameter) and degrees: it said degrees only
    with pytest.raises(LimitError) as err:
        forward([0.1, 0.105, 0.1])
    assert str(err.value) == ('q = [0.1, 0.105, 0.1] m tilts the platform by 0.0357432436 rad (2.04794 deg), beyond '
                              'the tilt limit 0.034906585 rad (2 deg)')
    # a name of 700 characters was quoted whole: a service's message, cut at 600, lost what is allowed
    with pytest.raises(InputError) as err:
        forward([0.3, 0.3, 0.3], model='x' * 700)
    assert str(err.value) == (f"unknown virtual-joint model '{'x' * 59}... (700 characters); allowed: radial, polar, "
                              "offset, compliant, or None or '' for the configuration's model (radial)")
    with pytest.raises(LimitError, match=r'tilt = .* \(3 deg\) is beyond the tilt limit; allowed: '
                                         r'\|tilt\| <= .* \(2 deg\)$'):
        inverse(0.3, math.radians(3.0), 0.0)
    with pytest.raises(LimitError, match='outside the stroke'):
        inverse(0.507, math.radians(2.0), 0.3)
    with pytest.raises(InputError, match=r'height\[1\] = nan'):
        inverse_batch([0.3, float('nan')], 0.0, 0.0)
    with pytest.raises(InputError, match='same length'):
        inverse_batch([0.3, 0.2], [0.0, 0.0, 0.0], 0.0)


def test_budget_flag():
    cfg = CFG.replace(imperfection_budget=2e-5)
    fk = forward(naive_inverse(0.3, math.radians(2.0), 0.3), config=cfg)
    assert not fk.within_budget and fk.joint_displacement.max() > 2e-5
    assert forward([0.3, 0.3, 0.3], config=cfg).within_budget


def test_results_are_frozen_and_built_from_every_field():
    import dataclasses
    fk = forward([0.5, 0.503, 0.498])
    with pytest.raises(dataclasses.FrozenInstanceError):
        fk.tilt = 0.0
    values = {f.name: getattr(fk, f.name) for f in dataclasses.fields(fk)}
    assert ForwardResult.from_fields(values) == ForwardResult(**values)
    del values['tilt']
    with pytest.raises(TypeError, match='needs exactly the fields'):
        ForwardResult.from_fields(values)


def test_heights_the_stroke_cannot_reach_are_named_with_the_heights_it_can():
    """A target whose rods would leave the stroke is refused before Newton's method, whatever the number (the
    issue's "did not converge" and "side-length error nan"), with the heights that the tilt allows."""
    import re
    import warnings

    for h in (500.0, -1e308, 1e308):
        with warnings.catch_warnings():
            warnings.simplefilter('error')   # and without an overflow warning on the way
            expected = f'height = {h:.9g} m puts a rod outside the stroke [0, 0.508] m at the tilt 0 rad; allowed '
            with pytest.raises(LimitError, match=re.escape(expected + 'heights: 0 .. 0.508 m')):
                inverse(h, 0.0, 0.0)
    # The allowed heights are the naive rods' moved by the virtual joints' micrometres: either end is solved (the
    # naive model's were refused: q3 = -1.7e-6 m at 2 deg), a height 1 mm inside them too.
    q = naive_inverse(0.0, math.radians(1.5), 0.7)
    lo, hi = CFG.stroke_min - q.min(), CFG.stroke_max - q.max()
    with pytest.raises(LimitError) as err:
        inverse(hi + 0.05, math.radians(1.5), 0.7)
    _allowed_ends(str(err.value), math.radians(1.5), 0.7, (lo, hi))
    assert inverse(hi - 0.001, math.radians(1.5), 0.7).q.max() <= CFG.stroke_max
    with pytest.raises(LimitError, match=r'\(target 1\) puts a rod outside the stroke'):
        inverse_batch([0.3, 2.0], 0.0, 0.0)
    # a height typed in mm is told so, as a rod is (the rule: beyond 10 times the top, within as mm); one height for
    # every target (a sweep's) names no "target 0": the tilt tells which
    with pytest.raises(LimitError, match=r'0\.508 m; as millimetres it would be within them: millimetres given as '
                                         r'metres\?$'):
        inverse(450.0, 0.0, 0.0)
    for h in (0.6, 600.0):
        with pytest.raises(LimitError, match=r'allowed heights: 0 \.\. 0\.508 m$'):
            inverse(h, 0.0, 0.0)
    with pytest.raises(LimitError, match=r'^height = 0\.6 m puts a rod outside the stroke \[0, 0\.508\] m at the '
                                         r'tilt 0 rad'):
        inverse_batch([0.6, 0.6], 0.0, 0.0)
    # Within the margin past them (the virtual joints' millimetre) the solve runs and the rods decide: the refusal
    # names the height and the heights allowed too (0.5 mm, with --mm meant 0.5 m, said only 'q3 = -0.0023 m ...')
    for one in (True, False):
        with pytest.raises(LimitError) as err:
            if one:
                inverse(0.0005, math.radians(2.0), 0.0)
            else:
                inverse_batch([0.3, 0.0005], math.radians(2.0), 0.0)
        lo, hi = CFG.stroke_min - naive_inverse(0.0, math.radians(2.0), 0.0).min(), \
            CFG.stroke_max - naive_inverse(0.0, math.radians(2.0), 0.0).max()
        assert re.fullmatch(r'q3 = -0.00231912\d* m' + ("" if one else " [(]sample 1[)]") + r' is outside the stroke '
                            r'\[0, 0.508\] m: the height 0.0005 m at the tilt 0.0349066 rad needs it; allowed heights '
                            r'there: 0.00281913 \.\. 0.50518 m', str(err.value)), str(err.value)
        _allowed_ends(str(err.value), math.radians(2.0), 0.0, (lo, hi))


def _allowed_ends(text, t, g, naive, **kw):
    """The heights a refusal allows: within 5 um of the naive model's ``naive`` (the virtual joints shift the rods by
    about 1.7 um at 2 deg), both ends solved by ``inverse`` and a step of the sixth digit beyond either refused."""
    lo, hi = (float(v) for v in re.search(r'allowed heights(?: there)?: (\S+) \.\. (\S+) m', text).groups())
    assert abs(lo - naive[0]) < 5e-6 and abs(hi - naive[1]) < 5e-6, (lo, hi, naive)
    for end, out in ((lo, lo - 10.0 ** (math.floor(math.log10(abs(lo))) - 5) if lo else -1e-6),
                     (hi, hi + 10.0 ** (math.floor(math.log10(abs(hi))) - 5))):
        inverse(end, t, g, **kw)
        with pytest.raises(LimitError, match='outside the stroke'):
            inverse(out, t, g, **kw)
    return lo, hi


def test_azimuth_beyond_its_bound_is_refused():
    # Periodic: any turn within +-1e6 rad is the same direction; beyond it a float keeps no digits modulo 2 pi
    # (an azimuth of 1e300 used to pass as some direction).
    a, b = inverse(0.5, 0.02, 0.7), inverse(0.5, 0.02, 0.7 + 2 * math.pi * 1000)
    assert np.allclose(a.q, b.q, atol=1e-12)
    for g in (1e300, -1e7, 1e6 + 1):
        with pytest.raises(InputError, match=r'azimuth = .* rad; allowed: finite values within \+-(1e\+06|1000000) '
                                             r'rad'):
            inverse(0.5, 0.02, g)
    # the value and its bound printed apart ('1e+06 rad; allowed: ... within +-1e+06 rad'), one text on both paths
    with pytest.raises(InputError) as one:
        inverse(0.3, 0.01, 1000000.0000000001)
    with pytest.raises(InputError) as batch:
        inverse_batch([0.3], [0.01], [1000000.0000000001])
    assert str(one.value) == str(batch.value) and str(one.value).startswith(
        'azimuth = 1000000.0000000001 rad; allowed: finite values within +-1000000 rad')
    with pytest.raises(InputError, match=r'azimuth = 1e\+300 rad \(target 1\); allowed: finite values within'):
        inverse_batch([0.5, 0.5], 0.02, [0.0, 1e300])


def test_tool_points_beyond_the_reach_are_refused():
    for tool in ([300.0, 0.0, 100.0], [1e308, 0.0, 0.0], [0.0, 0.0, -1e300], [6.0, 6.0, 6.0]):
        with pytest.raises(LimitError, match=r'tool = .* is beyond the reach of a tool point \(.* m from the platform '
                                             r'origin\); allowed: at most 10 m'):
            inverse(0.3, 0.01, 0.0, tool=tool)
    with pytest.raises(LimitError, match=r'\(target 1\) is beyond the reach'):
        inverse_batch([0.3, 0.3], 0.01, 0.0, tool=[[0.1, 0, 0], [0, 11.0, 0]])
    # Within the reach Newton's method still meets its tolerance: the height of the tool point is exact.
    tool = np.array([5.7, 5.7, 0.5])   # 8.1 m from the origin
    ik = inverse(0.3, math.radians(1.9), 2.1, tool=tool)
    assert abs((ik.achieved.position + ik.achieved.rotation @ tool)[2] - 0.3) < 1e-13


def _middle_heights(t, g, tools, model=None):
    """The middle of the heights each tool point allows at its tilt (from the refusal of a height of 1 km)."""
    h = np.empty(len(t))
    for i in range(len(t)):
        with pytest.raises(LimitError) as err:
            inverse(1e3, t[i], g[i], model=model, tool=tools[i])
        lo, hi = (float(v) for v in err.value.args[0].split('allowed heights: ')[1].split(' m')[0].split(' .. '))
        h[i] = 0.5 * (lo + hi)
    return h


@pytest.mark.parametrize('model', MODELS)
def test_long_tool_points_within_the_reach_converge(model):
    """A tool point 9 m off the platform origin (within the 10 m reach) left the normal 1.2e-14 from its target, and
    inverse kinematics refused as not converged at 1e-14 (gpr compensate --tool 0 0 9; 51 of 300 random commands):
    the tolerances take the tool's length's rounding. The tool point's height and the normal are met to them (1.2e-13
    m and 1.5e-13 at 9 m), one at a time and in batch, and the tolerances without a tool are unchanged."""
    from gpr_kinematics.core.inverse import ik_tolerances, tool_tolerances

    rng = np.random.default_rng(11)
    n = 60
    d = rng.normal(size=(n, 3))
    tools = d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(5.0, 9.99, (n, 1))
    t, g = rng.uniform(0.0, 0.95 * CFG.tilt_limit, n), rng.uniform(-np.pi, np.pi, n)
    h = _middle_heights(t, g, tools, model)
    batch = inverse_batch(h, t, g, model=model, tool=tools)
    for i in range(n):
        ik = inverse(h[i], t[i], g[i], model=model, tool=tools[i])
        tol_h, tol_n = tool_tolerances(CFG, tuple(tools[i].tolist()))
        assert tol_h < 1.3e-13 and tol_n < 1.6e-13
        for pose in (ik.achieved, batch.achieved[i]):
            assert abs((pose.position + pose.rotation @ tools[i])[2] - h[i]) <= tol_h
            assert np.max(np.abs(pose.rotation[:, 2] - tilt_rotation(t[i], g[i])[:, 2])) <= tol_n + 1e-16
    assert tool_tolerances(CFG, (0.0, 0.0, 0.0)) == ik_tolerances(CFG)


def test_long_tool_points_converge_in_batches_too():
    """The batch path's tolerances per tool row (a mutant keeping the tools' rows at the shipped tolerances left 2 of
    30 batches of 10 unconverged, at 1.2e-13): 300 tools of 5 to 10 m, every batch converges, each row as alone."""
    from gpr_kinematics.core.inverse import tool_tolerances

    rng = np.random.default_rng(5)
    n = 300
    d = rng.normal(size=(n, 3))
    tools = d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(5.0, 9.99, (n, 1))
    t, g = rng.uniform(0.0, 0.95 * CFG.tilt_limit, n), rng.uniform(-np.pi, np.pi, n)
    h = _middle_heights(t, g, tools)
    for k in range(0, n, 10):
        batch = inverse_batch(h[k:k + 10], t[k:k + 10], g[k:k + 10], tool=tools[k:k + 10])
        tol_h, tol_n = tool_tolerances(CFG, tuple(tools[k:k + 10].T))
        for i in range(10):
            pose = batch.achieved[i]
            assert abs((pose.position + pose.rotation @ tools[k + i])[2] - h[k + i]) <= tol_h[i]


def test_heights_allowed_with_a_tool_point_are_those_of_the_rigid_platform():
    """With a tool point the allowed heights are where the lowest and highest joint meet the stroke on a rigid
    tilted platform: joint k lies ``(T (p_k - tool))_z`` above the tool point (T the tilt rotation), worked out here
    from the rotation; the tool's x and y enter separately (a tool on a diagonal would hide a swap)."""
    tool = np.array([0.12, -0.05, 0.25])
    t, g = math.radians(1.5), 0.7
    th = np.asarray(CFG.rod_azimuths)
    p = np.column_stack([R * np.cos(th), R * np.sin(th), np.zeros(3)])
    above = ((p - tool) @ tilt_rotation(t, g).T)[:, 2]
    lo, hi = CFG.stroke_min - above.min(), CFG.stroke_max - above.max()
    for h in (hi + 0.05, lo - 0.05):
        with pytest.raises(LimitError, match=r'with this tool point; allowed heights: ') as err:
            inverse(h, t, g, tool=tool)
        _allowed_ends(str(err.value), t, g, (lo, hi), tool=tool)
    q = inverse(hi - 0.0001, t, g, tool=tool).q
    assert CFG.stroke_max - 0.0002 < q.max() <= CFG.stroke_max


def test_a_target_within_the_height_margin_is_not_the_one_named():
    """Before the solve a height may exceed the naive model's range by HEIGHT_MARGIN (10 mm): a batch whose first
    target lies 5 mm inside the range and second 50 mm beyond it names the second target and its height."""
    q = naive_inverse(0.0, math.radians(1.5), 0.7)
    hi = CFG.stroke_max - q.max()
    with pytest.raises(LimitError, match=rf'height = {hi + 0.05:.9g} m \(target 1\) puts a rod outside the stroke'):
        inverse_batch([hi - 0.005, hi + 0.05], math.radians(1.5), 0.7)


@pytest.mark.parametrize('model', ['radial', 'polar', 'offset', 'compliant'])
@pytest.mark.parametrize('batch', [False, True])
def test_inverse_takes_exactly_max_iterations_steps_and_no_more(batch, model):
    """The paper's target (0.5 m, 2 deg about x) takes 4 Newton steps (the doctest of core/inverse.py): with
    max_iterations = 4 it is solved to IK_TOLERANCE, with 3 it is refused (not returned half solved)."""
    def solve(most):   # every model (the one-pose path's fused radial steps and the others' steps alike)
        cfg = CFG.replace(max_iterations=most, model=model)
        if batch:
            ib = inverse_batch([0.5], math.radians(2.0), 0.0, config=cfg)
            return int(ib.iterations[0]), float(ib.achieved.position[0, 2]), float(ib.achieved.tilt[0])
        ik = inverse(0.5, math.radians(2.0), 0.0, config=cfg)
        return ik.iterations, float(ik.achieved.position[2]), ik.achieved.tilt

    steps, z, tilt = solve(4)
    assert steps == 4 and abs(z - 0.5) <= 1e-14 and abs(tilt - math.radians(2.0)) <= 1e-14
    with pytest.raises(ConvergenceError, match='inverse kinematics did not converge in 3 iterations'):
        solve(3)


@pytest.mark.parametrize('batch', [False, True])
def test_a_rod_not_parallel_to_the_others_slows_inverse_and_its_error_says_what_to_give(batch):
    """One rod at 0.05 (allowed): the naive Jacobian ignores how it pushes the platform sideways, so the iteration
    gains a digit or less per step. A pose forward kinematics reaches (rods 0.505, 0.507, 0.508 m) took more than the
    default 12 steps and was refused without a cause; the error now names max_iterations, and with 40 the solve
    returns the rods to 1e-12 m."""
    cfg = CFG.replace(rod_directions=[[0.05, 0.0], [0.0, 0.0], [0.0, 0.0]])
    q = [0.505, 0.507, 0.508]
    fk = forward(q, cfg)
    h, t, g = float(fk.position[2]), fk.tilt, fk.tilt_azimuth

    def solve(c):
        if batch:
            ib = inverse_batch([h], t, g, config=c)
            return ib.q[0], int(ib.iterations[0])
        ik = inverse(h, t, g, config=c)
        return ik.q, ik.iterations

    with pytest.raises(ConvergenceError, match=r'did not converge in 12 iterations.*: error \S+; rods that are not '
                       r'parallel converge more slowly: give a larger max_iterations \(allowed: at most 100\)$'):
        solve(cfg)
    back, steps = solve(cfg.replace(max_iterations=40))
    assert 12 < steps < 40
    np.testing.assert_allclose(back, q, rtol=0, atol=1e-12)
    with pytest.raises(ConvergenceError, match=r'in 3 iterations.*: error \S+$'):   # parallel rods: no hint
        inverse_batch([0.5], math.radians(2.0), 0.0, config=CFG.replace(max_iterations=3))
    inclined = CFG.replace(rod_directions=[[0.05, 0.0]] * 3, max_iterations=2)   # inclined alike: still parallel
    with pytest.raises(ConvergenceError, match=r'in 2 iterations.*: error \S+$'):
        inverse(0.3, 0.02, 0.5, config=inclined)


def test_a_batch_has_one_row_per_target():
    """``len`` and indexing of the batches count targets (rows), not the three rods."""
    h, t, g = _random_targets(5, seed=9)
    ib = inverse_batch(h, t, g)
    assert len(ib) == 5 and len(ib.achieved) == 5 and len(forward_batch(ib.q)) == 5
    assert ib[4].achieved.position[2] == pytest.approx(h[4], abs=1e-14) and ib[4].iterations == ib.iterations[4]


def test_the_naive_pose_reported_is_the_pure_tilt_whose_joint_heights_are_the_rods():
    """The naive model's pose of the result (paper Fig. 2): the pure tilt ``T`` about the centre ``(0, 0, z)`` whose
    joints ``p_k = R (cos theta_k, sin theta_k, 0)`` stand at the rod heights, ``q_k = z + (T p_k)_z``: three linear
    equations in ``z`` and ``n' = T^T e3`` solved here by numpy; batch and one pose."""
    h, t, g = _random_targets(12, seed=11)
    Q = naive_inverse(h, t, g)
    fb = forward_batch(Q)
    th = np.asarray(CFG.rod_azimuths)
    A = np.column_stack([np.ones(3), R * np.cos(th), R * np.sin(th)])
    for i in range(12):
        z, nx_, ny_ = np.linalg.solve(A, Q[i])
        n = np.array([-nx_, -ny_, math.sqrt(1.0 - nx_ ** 2 - ny_ ** 2)])
        expect = tilt_rotation(math.atan2(math.hypot(n[0], n[1]), n[2]), math.atan2(n[0], -n[1]))
        np.testing.assert_allclose(expect[:, 2], n, rtol=0, atol=4e-16)
        np.testing.assert_allclose(expect[2], [-n[0], -n[1], n[2]], rtol=0, atol=4e-16)   # n' = T^T e3
        for f in (fb[i], forward(Q[i])):
            np.testing.assert_allclose(f.nominal_rotation, expect, rtol=0, atol=1e-15)
            np.testing.assert_allclose(f.nominal_quaternion, quaternion_from_matrix(expect), rtol=0, atol=1e-15)
            np.testing.assert_allclose(f.nominal_position, [0.0, 0.0, z], rtol=0, atol=1e-15)


def test_heights_allowed_on_a_machine_with_rod_offsets():
    """With zero offsets ``o_k`` a joint stands at ``q_k + o_k`` (P_k = B_k + (q_k + o_k) e3), so the heights allowed
    at a tilt shift rod by rod: worked out here from the rigid tilted platform, each rod's stroke moved by its
    offset."""
    offsets = np.array([0.01, -0.02, 0.005])
    cfg = CFG.replace(rod_offsets=offsets.tolist())
    t, g = math.radians(1.2), -2.0
    th = np.asarray(CFG.rod_azimuths)
    p = np.column_stack([R * np.cos(th), R * np.sin(th), np.zeros(3)])
    above = (p @ tilt_rotation(t, g).T)[:, 2]
    lo, hi = np.max(CFG.stroke_min + offsets - above), np.min(CFG.stroke_max + offsets - above)
    with pytest.raises(LimitError, match=r'allowed heights: ') as err:
        inverse(hi + 0.05, t, g, config=cfg)
    _allowed_ends(str(err.value), t, g, (lo, hi), config=cfg)
    q = inverse(hi - 0.0001, t, g, config=cfg).q
    assert CFG.stroke_max - 0.0002 < q.max() <= CFG.stroke_max


def test_naive_rods_of_a_tool_point_are_the_joint_heights_of_the_tilted_platform():
    """The naive rods for a tool point at height h: joint k stands ``(T (p_k - tool))_z`` above the tool point (T the
    pure tilt), worked out here from the rotation, with a tool off both axes; the result's base points are the
    joint centres ``B_k + q_k e3``."""
    from gpr_kinematics.core.forward import base_points
    from gpr_kinematics.core.machine import MachineGeometry
    from gpr_kinematics.core.naive import naive_rods

    tool = np.array([0.12, -0.05, 0.25])
    t, g, h = math.radians(1.5), 0.7, 0.4
    th = np.asarray(CFG.rod_azimuths)
    p = np.column_stack([R * np.cos(th), R * np.sin(th), np.zeros(3)])
    expect = h + ((p - tool) @ tilt_rotation(t, g).T)[:, 2]
    n = tilt_normal(t, g)
    np.testing.assert_allclose(naive_rods(MachineGeometry.of(CFG), h, list(n), tuple(tool)), expect, rtol=0,
                               atol=1e-16)
    Q = np.array([expect, expect + 0.01])
    B = base_points(Q, CFG)
    assert B.shape == (2, 3, 3)
    np.testing.assert_allclose(B[1], p + (expect + 0.01)[:, None] * [0.0, 0.0, 1.0], rtol=0, atol=1e-16)


def test_a_batch_of_one_result_is_that_result():
    """``ForwardBatch.of_one`` turns one result into a batch of one row that gives it back field by field."""
    from gpr_kinematics.core.forward import ForwardBatch

    one = forward([0.5, 0.503, 0.498])
    batch = ForwardBatch.of_one(one)
    assert len(batch) == 1
    back = batch[0]
    for name in ('q', 'position', 'rotation', 'quaternion', 'centre_shift', 'virtual_joints', 'joint_displacement'):
        np.testing.assert_array_equal(getattr(back, name), getattr(one, name), err_msg=name)
    for name in ('tilt', 'tilt_azimuth', 'twist', 'residual', 'fit_residual', 'iterations', 'within_budget'):
        assert getattr(back, name) == getattr(one, name), name


def test_the_one_pose_inverses_closure_is_bounded_by_max_iterations():
    """The one-pose inverse kinematics' fused radial steps run the closure's Newton loop inline: its own bound of
    max_iterations (a mutation audit: without it the loop was bounded by nothing, a closure that never converges a
    hung process) refuses naming the closure, as the batch does."""
    for call in (lambda cfg: inverse(0.3, math.radians(0.5), 0.4, config=cfg),
                 lambda cfg: inverse_batch([0.3], math.radians(0.5), 0.4, config=cfg)):
        with pytest.raises(ConvergenceError, match=r'^virtual-joint closure \(radial\) did not converge in 1 '
                                                   r'iterations( for sample 0)?: side-length error'):
            call(CFG.replace(max_iterations=1, model='radial'))


@pytest.mark.parametrize('over, t, g, tool', [
    ({'rod_directions': [[0.02, 0.0], [0.0, -0.03], [0.01, 0.01]], 'max_iterations': 60, 'model': 'compliant'},
     -0.0332233, -0.712783, (0.05, 0.05, 0.0)),
    ({'tilt_limit': math.radians(15), 'rod_directions': [[0.01, 0.0], [0.0, -0.01], [0.0, 0.0]], 'max_iterations': 60,
      'model': 'offset'}, -0.199199, -1.41522, (0.05, 0.05, 0.0)),
    ({'tilt_limit': math.radians(15), 'rod_directions': [[0.05, 0.0], [0.0, -0.05], [0.03, 0.02]],
      'rod_offsets': [0.01, 0, -0.01], 'max_iterations': 60, 'model': 'compliant'}, 0.240441, 1.21047, (0, 0, 0)),
])
def test_the_heights_allowed_with_leaning_rods_are_solved_at_both_ends(over, t, g, tool):
    """Leaning rods move their joints sideways as they extend, so the virtual joints' shift changes with the height:
    the first order named ends 1.5 um (11 deg) and 10 um (14 deg) outside, or the naive range as 'about' where 12
    iterations did not converge; each end is solved again where it lies now, with the most iterations."""
    cfg = load_config(overrides=over)
    for h in (-5.0, 5.0):
        with pytest.raises(LimitError) as err:
            inverse(h, t, g, cfg, tool=tool)
        lo, hi = (float(v) for v in re.search(r'allowed heights: (\S+) \.\. (\S+) m', str(err.value)).groups())
        for end, out in ((lo, lo - 10.0 ** (math.floor(math.log10(abs(lo))) - 5)),
                         (hi, hi + 10.0 ** (math.floor(math.log10(abs(hi))) - 5))):
            inverse(end, t, g, cfg, tool=tool)
            with pytest.raises(LimitError, match='outside the stroke'):
                inverse(out, t, g, cfg, tool=tool)


LEANING = {'rod_positions': [[0.09325, 0.00002], [-0.04660, 0.08075], [-0.04662, -0.08071]],
           'rod_offsets': [0.0003, -0.0002, 0.0001], 'rod_directions': [[0.01, 0.002], [-0.003, 0.02], [0.0, -0.01]],
           'platform_joints': [[0.0932, 0.00003], [-0.04665, 0.08070], [-0.04658, -0.08076]]}


@pytest.mark.parametrize('model', ['radial', 'compliant'])
def test_forward_takes_the_rods_inverse_answers_on_leaning_rods(model):
    """Forward kinematics refused rods its inverse answered at 1.995 deg (a trial's machine, leans of 0.01-0.02 rad):
    its first check took the naive model's tilt, 2.125 deg (beyond 1.05 times the limit), which leaves the joints'
    sideways travel out; on leaning rods it takes the plane of the joint centres, within 0.2 % of the real tilt
    here, and still refuses rods beyond 1.05 times the limit in one pose and in a batch alike."""
    from gpr_kinematics.core.machine import MachineGeometry
    from gpr_kinematics.core.naive import centres_tilt, naive_state
    from gpr_kinematics.core.ops import SCALAR

    cfg = load_config(overrides={**LEANING, 'model': model, 'max_iterations': 60})
    geo = MachineGeometry.of(cfg)
    ik = inverse(0.3122486702011532, -0.03482274648975273, 0.021136418940642887, cfg,
                 tool=(-0.012666589564869463, -0.05934943277708704, -0.03501147108487879))
    fk = forward(ik.q, cfg)
    assert fk.tilt == pytest.approx(abs(ik.achieved.tilt), abs=1e-12) and fk.tilt <= cfg.tilt_limit
    np.testing.assert_allclose(forward_batch([ik.q], cfg).tilt, [fk.tilt], rtol=0, atol=1e-12)
    _, h2, _, _, nz = naive_state(SCALAR, geo, list(ik.q))
    assert math.atan2(math.sqrt(h2), nz) > 1.05 * cfg.tilt_limit                        # what refused it
    assert centres_tilt(SCALAR, geo, list(ik.q)) == pytest.approx(fk.tilt, rel=2e-3)   # what takes it now
    g = 0.3   # rods far beyond: refused, by one pose and by a batch alike, naming the joint centres' tilt
    q = list(inverse(0.3, 0.045, g, cfg.replace(tilt_limit=0.1)).q)
    for call in (lambda: forward(q, cfg), lambda: forward_batch([q], cfg)):
        with pytest.raises(LimitError, match=r'tilts the platform by about 0\.04\d* rad \(2\.\d+ deg\) as its joint '
                                             r'centres, beyond the tilt limit') as err:
            call()
    assert 'naive' not in str(err.value)

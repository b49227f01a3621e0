"""The one-pose path of forward and inverse kinematics (core/single.py): the same numbers as the drivers on floats
to the last bit, the batch rows to 1e-12, the same refusals, over random, singular and limit poses, every model, on
the nominal and an imperfect machine."""
import contextlib
import dataclasses
import math
import re

import numpy as np
import pytest
from gpr_kinematics.core import ForwardResult, forward, forward_batch, inverse, inverse_batch, naive_inverse
from gpr_kinematics.core.config import MODELS, GprConfig, load_config
from gpr_kinematics.core.forward import _forward
from gpr_kinematics.core.inverse import InverseResult, _solve
from gpr_kinematics.core.ops import SCALAR
from gpr_kinematics.core.single import one_pose
from gpr_kinematics.core.virtual_joints import make_model
from gpr_kinematics.errors import ConvergenceError, InputError, LimitError

NOMINAL = load_config()
#: A real machine: rods off their places and tilted, zero offsets, joints off the circle, a kappa per joint.
IMPERFECT = GprConfig(rod_positions=((0.0933, 0.0002), (-0.0465, 0.0806), (-0.0467, -0.0808)),
                      rod_offsets=(1e-4, -2e-4, 3e-5), rod_directions=((0.001, -0.002), (0.0, 0.003), (-0.001, 0.0)),
                      platform_joints=((0.0932, 0.0001), (-0.0466, 0.0808), (-0.0467, -0.0807)), kappa=(3.0, 0.5, 10.0))
#: Rods numbered clockwise (the rigid fit's mirror sign) and a budget some poses exceed by one joint alone (a mutation
#: audit: neither was seen by the float path's tests).
CLOCKWISE = GprConfig(rod_azimuths=(math.pi / 2, -math.pi / 6, 7 * math.pi / 6))
TIGHT_BUDGET = GprConfig(imperfection_budget=2.5e-5)
CONFIGS = {'nominal': NOMINAL, 'imperfect': IMPERFECT, 'clockwise': CLOCKWISE, 'tight budget': TIGHT_BUDGET}
FIELDS = [f.name for f in dataclasses.fields(ForwardResult)]


def _reference_forward(q, cfg, model, check=True):
    """The batch driver run on floats (what a single call computed before the one-pose path)."""
    return _forward(SCALAR, ForwardResult, [float(v) for v in q], cfg, make_model(cfg, model), check)


def _reference_inverse(h, t, g, cfg, model, tool):
    achieved, iterations = _solve(SCALAR, ForwardResult, h, t, g, [float(v) for v in tool], cfg,
                                  make_model(cfg, model))
    return InverseResult(q=achieved.q, achieved=achieved, iterations=int(iterations))


def _assert_same_bits(a, b):
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(y, np.ndarray):
            assert isinstance(x, np.ndarray) and x.dtype == y.dtype and x.shape == y.shape, name
            assert x.tobytes() == y.tobytes(), (name, x - y)
        else:
            assert type(x) is type(y) and x == y, (name, x, y)


def _assert_close_to_row(one, batch, i, atol=1e-12):
    row = batch[i]
    for name in FIELDS:
        x, y = getattr(one, name), getattr(row, name)
        if name in ('model', 'virtual_joint_names', 'iterations', 'within_budget'):
            assert x == y, name
        else:
            np.testing.assert_allclose(x, y, rtol=0, atol=atol, err_msg=name)


def _random_rods(cfg, n, seed, beyond=1.1):
    """Rods of random targets (tilts up to ``beyond`` times the limit: some refused), every 7th singular, some at
    the ends of the stroke and beyond them."""
    rng = np.random.default_rng(seed)
    Q = naive_inverse(rng.uniform(0.02, 0.49, n), rng.uniform(-beyond, beyond, n) * cfg.tilt_limit,
                      rng.uniform(-np.pi, np.pi, n), cfg)
    Q[::7] = Q[::7, :1]
    Q[3::11] += cfg.stroke_max - np.max(Q[3::11], axis=1, keepdims=True)  # a rod at the top of the stroke
    Q[5::13] += cfg.stroke_min - 1e-3 - np.min(Q[5::13], axis=1, keepdims=True)  # one 1 mm below it
    return Q


@pytest.mark.parametrize('geometry', CONFIGS)
@pytest.mark.parametrize('model', MODELS)
def test_forward_equals_the_driver_on_floats_to_the_last_bit_and_refuses_alike(geometry, model):
    cfg = CONFIGS[geometry]
    refused = 0
    for q in _random_rods(cfg, 150, seed=MODELS.index(model)):
        for check in (True, False):
            try:
                ref = _reference_forward(q, cfg, model, check)
            except LimitError as exc:
                with pytest.raises(LimitError) as got:
                    forward(q, cfg, model, check)
                assert str(got.value) == str(exc)
                refused += 1
                continue
            _assert_same_bits(forward(q, cfg, model, check), ref)
    assert 10 < refused < 150


@pytest.mark.parametrize('model', MODELS)
def test_rods_far_outside_the_stroke_unchecked_end_in_the_packages_error_as_in_the_batch(model):
    # A joint_states publisher may send any rods to the state publisher, which skips the limits: a singular Newton
    # step (one radial case: rods -1769, 1303 and -0.0085 m) was a bare ZeroDivisionError.
    rng = np.random.default_rng(7)
    failed = 0
    for _ in range(400):
        q = rng.normal(0.0, 1.0, 3) * 10.0 ** rng.integers(-3, 4, 3)
        try:
            out = forward(q, model=model, check_limits=False)
        except ConvergenceError as exc:
            assert re.match(rf'(virtual-joint closure \({model}\)|{model} closure).* did not converge', str(exc))
            with pytest.raises(ConvergenceError) as batch, np.errstate(all='ignore'):
                forward_batch(q[None, :], model=model, check_limits=False)
            # one wording (the batch said "side-length error nan m"); the error's last digits are the machine's (its
            # BLAS: 2.022e-14 against 2.024e-14 m on one machine, equal on another)
            number = r'[-+]?\d+\.?\d*(?:e[-+]?\d+)?'
            assert re.sub(number, '#', str(batch.value)) == re.sub(number, '#', str(exc))
            np.testing.assert_allclose([float(v) for v in re.findall(number, str(batch.value))],
                                       [float(v) for v in re.findall(number, str(exc))], rtol=0.01)
            failed += 1
            continue
        assert np.all(np.isfinite(out.position)) and np.isfinite(out.tilt)
    assert failed > 0
    with pytest.raises(ConvergenceError, match=r'did not converge for q = \[-1769\.0.*a Newton step was singular'):
        forward([-1769.0291745130303, 1303.4307942578168, -0.008524297508037591], model='radial',
                check_limits=False)


@pytest.mark.parametrize('q', [[1e308] * 3, [0.5, 0.5, -2e6], [1e7, 0.5, 0.5], [1000000.1, 0.5, 0.5]])
def test_rods_beyond_any_joint_value_unchecked_are_refused_not_solved_to_infinity(q):
    """Rods of 1e308 m with the limits unchecked gave a position of z = inf and a fit residual of inf (the robot's
    wafer NaN): the bound of every joint value (1e6) holds for the rods too, one pose, a batch and the robot alike."""
    from gpr_kinematics.robot import load_robot, robot_forward
    k = int(np.argmax(np.abs(q)))
    shown, bound = ('1000000.1', '1000000') if q[k] == 1000000.1 else (f'{q[k]:g}', '1e+06')   # told apart
    words = (rf'^q{k + 1} = {re.escape(shown)} m%s is beyond the bound of any joint value; allowed: '
             rf'\|q\| <= {re.escape(bound)} m')
    for model in MODELS:
        with pytest.raises(InputError, match=words % ''):
            forward(q, model=model, check_limits=False)
        with pytest.raises(InputError, match=words % re.escape(' (sample 1)')):
            forward_batch([[0.5, 0.5, 0.5], q], model=model, check_limits=False)
    with pytest.raises(InputError, match=words % ''):
        robot_forward(load_robot(), [q], [[0.0, 1.0, 0.0]], 'arm1', check_limits=False)
    with contextlib.suppress(ConvergenceError):   # at the bound: solved, or refused by the closure, not the bound
        forward([0.5, 0.5, 1e6], check_limits=False)


@pytest.mark.parametrize('geometry', CONFIGS)
@pytest.mark.parametrize('model', MODELS)
def test_forward_equals_the_batch_row(geometry, model):
    cfg = CONFIGS[geometry]
    Q = _random_rods(cfg, 120, seed=10 + MODELS.index(model), beyond=1.0)
    batch = forward_batch(Q, cfg, model, check_limits=False)
    for i in range(Q.shape[0]):
        _assert_close_to_row(forward(Q[i], cfg, model, check_limits=False), batch, i)


def test_forward_result_is_a_frozen_dataclass_of_independent_arrays():
    fk = forward([0.5, 0.503, 0.498])
    with pytest.raises(dataclasses.FrozenInstanceError):
        fk.tilt = 0.0
    assert set(vars(fk)) == set(FIELDS)
    assert ForwardResult.from_fields(dict(vars(fk))) == fk
    arrays = [v for v in vars(fk).values() if isinstance(v, np.ndarray)]
    assert all(not np.shares_memory(a, b) for i, a in enumerate(arrays) for b in arrays[i + 1:])
    assert fk.rotation.shape == (3, 3) and fk.quaternion.shape == (4,) and fk.virtual_joints.shape == (3,)
    assert isinstance(fk.iterations, int) and isinstance(fk.within_budget, bool) and isinstance(fk.tilt, float)


@pytest.mark.parametrize('geometry', CONFIGS)
@pytest.mark.parametrize('model', MODELS)
def test_inverse_equals_the_driver_on_floats_to_the_last_bit_and_refuses_alike(geometry, model):
    cfg = CONFIGS[geometry]
    rng = np.random.default_rng(20 + MODELS.index(model))
    refused = 0
    for i in range(120):
        h, t, g = rng.uniform(-0.03, 0.54), rng.uniform(-1.1, 1.1) * cfg.tilt_limit, rng.uniform(-4.0, 4.0)
        tool = (0.0, 0.0, 0.0) if i % 3 else tuple(rng.uniform(-0.3, 0.3, 3))
        if i % 17 == 0:
            t = 0.0  # the singular configuration
        try:
            ref = _reference_inverse(h, t, g, cfg, model, tool)
        except (LimitError, ConvergenceError) as exc:
            with pytest.raises(type(exc)) as got:
                inverse(h, t, g, cfg, model, tool)
            assert str(got.value) == str(exc)
            refused += 1
            continue
        one = inverse(h, t, g, cfg, model, tool)
        _assert_same_bits(one.achieved, ref.achieved)
        assert one.iterations == ref.iterations and type(one.iterations) is int
        assert one.q is one.achieved.q
    assert 10 < refused < 100


@pytest.mark.parametrize('model', MODELS)
def test_inverse_equals_the_batch_row(model):
    rng = np.random.default_rng(30)
    h, t, g = rng.uniform(0.1, 0.4, 80), rng.uniform(-1.0, 1.0, 80) * NOMINAL.tilt_limit, rng.uniform(-4, 4, 80)
    t[::9] = 0.0
    tools = rng.uniform(-0.05, 0.05, (80, 3))
    batch = inverse_batch(h, t, g, NOMINAL, model, tool=tools)
    for i in range(80):
        one = inverse(float(h[i]), float(t[i]), float(g[i]), NOMINAL, model, tool=tools[i])
        np.testing.assert_allclose(one.q, batch.q[i], rtol=0, atol=1e-12)
        assert one.iterations == batch.iterations[i]
        _assert_close_to_row(one.achieved, batch.achieved, i)


def test_the_kernels_are_built_once_per_config_and_model():
    cfg = GprConfig()
    assert one_pose(cfg) is one_pose(cfg, 'radial') is one_pose(cfg, '')
    assert one_pose(cfg, 'compliant') is not one_pose(cfg)
    assert one_pose(cfg, 'compliant').model.name == 'compliant'
    with pytest.raises(InputError, match='unknown virtual-joint model'):
        forward([0.3, 0.3, 0.3], cfg, 'elastic')


@pytest.mark.parametrize('value, pattern', [
    (float('nan'), r'height = nan is not a finite number'),
    (float('inf'), r'height = inf is not a finite number'),
    (np.float64(0.3), None),
    (0, None),
    ('0.3', "height must be a number or an array of numbers, got '0.3'"),   # text is no number (was taken)
    ([0.3], 'height must be a single number'),
    ('high', 'height must be a number'),
])
def test_inverse_checks_its_numbers_once_in_a_cheap_form(value, pattern):
    if pattern is None:
        assert inverse(value, 0.0, 0.2).achieved.position[2] == pytest.approx(float(value), abs=1e-13)
    else:
        with pytest.raises(InputError, match=pattern):
            inverse(value, 0.01, 0.2)


def test_compliant_rest_is_kept_without_iteration():
    """At the singular configuration of the nominal machine every model keeps X at rest, with no step."""
    for model in MODELS:
        fk = forward([0.25, 0.25, 0.25], model=model)
        assert fk.iterations == 0 and fk.residual < 1e-15
        assert fk.tilt == 0.0 and math.isclose(fk.position[2], 0.25, abs_tol=1e-15)


def test_the_azimuth_of_a_tilt_below_rounding_is_the_batchs():
    """A tilt of 7e-16 rad has no azimuth: the float path answers 0 as the batch does (it must not read one from the
    rounding of the normal)."""
    q = [0.1, 0.1, 0.1 + 1e-16]
    one, batch = forward(q), forward_batch([q])
    assert one.tilt < 1e-15 and one.tilt_azimuth == batch.tilt_azimuth[0] == 0.0


def test_the_budget_flag_of_one_pose_sees_each_joint():
    """Poses of TIGHT_BUDGET over its budget by one joint alone (each of the three in turn) are flagged by the float
    path as by the batch."""
    rng = np.random.default_rng(9)
    rods = naive_inverse(rng.uniform(0.05, 0.45, 400), rng.uniform(-1.0, 1.0, 400) * TIGHT_BUDGET.tilt_limit,
                         rng.uniform(-np.pi, np.pi, 400), TIGHT_BUDGET)
    batch = forward_batch(rods, TIGHT_BUDGET)
    d = batch.joint_displacement   # (N, 3) [m]
    for k in range(3):
        alone = np.flatnonzero((d[:, k] > TIGHT_BUDGET.imperfection_budget)
                               & (np.delete(d, k, axis=1) <= TIGHT_BUDGET.imperfection_budget).all(axis=1))
        assert alone.size, k
        for i in alone[:3]:
            assert not forward(rods[i], TIGHT_BUDGET).within_budget and not batch.within_budget[i]


@pytest.mark.parametrize('name', CONFIGS)
def test_the_one_pose_height_range_is_the_generic_one_to_the_last_bit(name):
    """OnePose.height_range (inverse_parts' check of the height before the solve) takes height_range's operations."""
    from gpr_kinematics.core.heights import height_range
    config = CONFIGS[name]
    kernel = one_pose(config)
    rng = np.random.default_rng(3)
    for _ in range(200):
        t, g = rng.uniform(0.0, 1.2 * config.tilt_limit), rng.uniform(-math.pi, math.pi)
        n = [math.sin(t) * math.sin(g), -math.sin(t) * math.cos(g), math.cos(t)]
        tool = [float(v) for v in rng.normal(0.0, 0.2, 3)] if rng.uniform() < 0.5 else [0.0, 0.0, 0.0]
        assert kernel.height_range(n, tool) == height_range(SCALAR, kernel.geometry, n, tool, config)


@pytest.mark.parametrize('q, model', [([0.0, 0.5, 0.0], 'polar'), ([0.0, -1.0, -0.5], 'polar'),
                                      ([0.0, -0.6, 0.6], 'offset')])
def test_rods_whose_closure_turns_the_platform_over_are_refused_alike_on_both_paths(q, model):
    """Far outside the limits (``check_limits=False``) the polar and offset closures can turn the platform over (its
    rotation's trace -1): the one-pose path raised ZeroDivisionError or a math domain error from its quaternion, the
    batch returned a NaN quaternion as a pose. Both refuse it now with one message (the batch of one without a
    sample's index, as its stroke refusal)."""
    from gpr_kinematics.errors import ConvergenceError
    with pytest.raises(ConvergenceError) as one:
        forward(q, model=model, check_limits=False)
    with pytest.raises(ConvergenceError) as batch:
        forward_batch([q], model=model, check_limits=False)
    assert str(one.value) == str(batch.value)
    assert re.fullmatch(rf'virtual-joint closure \({model}\) did not converge for q = \[.*\] m: it turned the platform '
                        r"over \(its rotation's trace -1 <= -1: no pose; the limits were not checked; the stroke is "
                        r'\[0, 0.508\] m\)', str(one.value)), str(one.value)
    with pytest.raises(ConvergenceError, match=r' m \(sample 1\): it turned the platform over'), \
            np.errstate(all='ignore'):
        forward_batch([[0.3, 0.3, 0.3], q], model=model, check_limits=False)

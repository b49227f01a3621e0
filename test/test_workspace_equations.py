"""Mechanisms given by closure equations: DexTAR in its 6-D form brackets the closed-form area, its inner boxes
are reachable (inverse kinematics solved here in closed form), reachable points lie in its outer boxes; a
joint-limited arm brackets its annulus; malformed descriptions are refused."""
import math

import numpy as np
import pytest
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.workspace import approximate, contains_points, load_workspace_model, model_from_mapping
from gpr_kinematics.workspace.equations import EquationModel

RNG = np.random.default_rng(11)


@pytest.fixture(scope='module')
def dextar():
    model = load_workspace_model(config_path('mechanisms/dextar_6d.yaml'))
    return model, approximate(model, 0.012)


def _elbow(P, pivot, proximal, distal):
    """Both closed-form solutions of a two-link arm from ``pivot`` reaching ``P`` (N, 2): ``(q_prox, q_dist)``
    angles from the x axis, or NaN where P is out of reach."""
    d = P - pivot
    r = np.hypot(d[:, 0], d[:, 1])
    c = (proximal ** 2 + r ** 2 - distal ** 2) / (2 * proximal * r)
    out = []
    for sign in (1.0, -1.0):
        q = np.arctan2(d[:, 1], d[:, 0]) + sign * np.arccos(np.where(np.abs(c) <= 1, c, np.nan))
        elbow = pivot + proximal * np.stack([np.cos(q), np.sin(q)], axis=1)
        e = P - elbow
        out.append((q, np.arctan2(e[:, 1], e[:, 0])))
    return out


@pytest.mark.slow
def test_dextar_6d_brackets_the_closed_form_area(dextar):
    model, res = dextar
    exact = load_workspace_model(config_path('mechanisms/dextar.yaml')).exact_area()
    assert res.variables == ('x', 'y') and res.certified and not res.interrupted
    assert 0.5 * exact < res.inner_volume <= exact <= res.outer_volume < 1.2 * exact
    assert np.all(np.max(res.boundary[:, :, 1] - res.boundary[:, :, 0], axis=1) < 0.012)
    # the two-annuli 2-D form at the same delta brackets it too, and more tightly (no singularity in it)
    flat = approximate(load_workspace_model(config_path('mechanisms/dextar.yaml')), 0.012)
    assert flat.inner_volume >= res.inner_volume and flat.outer_volume <= res.outer_volume


def test_dextar_6d_inner_points_are_reachable_by_both_arms(dextar):
    model, res = dextar
    idx = RNG.integers(0, res.inner_boxes, 3000)
    b = res.inner[idx]
    P = b[:, :, 0] + (b[:, :, 1] - b[:, :, 0]) * RNG.random((3000, 2))
    la = lb = lc = ld = 0.2
    arm1 = _elbow(P, np.array([0.1, 0.0]), la, lb)[0]
    arm2 = _elbow(P, np.array([-0.1, 0.0]), ld, lc)[0]
    q1, q3 = arm1
    q2, q4 = arm2
    assert np.all(np.isfinite(q1) & np.isfinite(q2))
    # the paper's eqs. (1), evaluated here directly
    assert np.allclose(la * np.cos(q1) + lb * np.cos(q3) + 0.1, P[:, 0], atol=1e-12)
    assert np.allclose(la * np.sin(q1) + lb * np.sin(q3), P[:, 1], atol=1e-12)
    assert np.allclose(-0.1 + ld * np.cos(q2) + lc * np.cos(q4), P[:, 0], atol=1e-12)
    assert np.allclose(ld * np.sin(q2) + lc * np.sin(q4), P[:, 1], atol=1e-12)
    wrap = np.angle(np.exp(1j * np.stack([q1, q2, q3, q4], axis=1)))          # the ranges are (-pi, pi]
    assert np.all(model.feasible(np.concatenate([wrap, P], axis=1)))


def test_dextar_6d_reachable_points_lie_in_the_outer_boxes(dextar):
    model, res = dextar
    q = RNG.uniform(-np.pi, np.pi, (40000, 2))
    P = np.stack([0.2 * np.cos(q[:, 0]) + 0.2 * np.cos(q[:, 1]) + 0.1,
                  0.2 * np.sin(q[:, 0]) + 0.2 * np.sin(q[:, 1])], axis=1)
    r2 = np.hypot(P[:, 0] + 0.1, P[:, 1])
    P = P[r2 <= 0.4]                                             # arm 2 reaches them too
    assert P.shape[0] > 10000
    assert np.all(contains_points(np.concatenate([res.inner, res.boundary]), P))


@pytest.mark.slow
def test_a_joint_limited_arm_brackets_its_annulus():
    """x = l1 cos q1 + l2 cos(q1 + q2) ...: with q1 free and q2 in [0, pi/2] the arm reaches the annulus
    sqrt(l1^2 + l2^2) <= r <= l1 + l2, of area 2 pi l1 l2."""
    data = {'type': 'equations', 'parameters': {'l1': 0.3, 'l2': 0.2},
            'variables': {'q1': [-math.pi, math.pi], 'q2': [0.0, math.pi / 2], 'x': [-0.6, 0.6], 'y': [-0.6, 0.6]},
            'units': {'q1': 'rad', 'q2': 'rad'}, 'outputs': ['x', 'y'], 'periodic': ['q1'],
            'equations': ['x = l1*cos(q1) + l2*cos(q1 + q2)', 'y = l1*sin(q1) + l2*sin(q1 + q2)'],
            'workspace': {'angle_scale': 0.3}}
    model = model_from_mapping(data, 'arm')
    assert isinstance(model, EquationModel) and model.solve_for == ('q1', 'q2')
    exact = 2 * math.pi * 0.3 * 0.2
    res = approximate(model, 0.01)
    assert res.inner_volume <= exact <= res.outer_volume
    assert res.inner_volume > 0.4 * exact and res.outer_volume < 1.3 * exact      # 0.54 and 1.14 measured
    b = res.inner[RNG.integers(0, res.inner_boxes, 2000)]
    r = np.hypot(*(b[:, :, 0] + (b[:, :, 1] - b[:, :, 0]) * RNG.random((2000, 2))).T)
    assert np.all((r >= math.hypot(0.3, 0.2)) & (r <= 0.5))


def test_a_periodic_angle_over_a_full_turn_is_widened_to_cover_the_circle():
    """[-3.141592653589793, 3.141592653589793] and [0, 6.283185307179586] are full turns whose floats fall short of
    the real 2 pi by 2.4e-16: a periodic angle over them is a full turn, widened by 1e-15 rad at both ends so that
    no seam is left; over [-3, 3] it is not (0.28 rad short of a turn), nor is a full-turn range of an angle that is
    not declared periodic."""
    def arm(q1, periodic):
        return model_from_mapping({
            'type': 'equations', 'parameters': {'l1': 0.3, 'l2': 0.2},
            'variables': {'q1': q1, 'q2': [0.0, math.pi / 2], 'x': [-0.6, 0.6], 'y': [-0.6, 0.6]},
            'units': {'q1': 'rad', 'q2': 'rad'}, 'outputs': ['x', 'y'], 'periodic': periodic,
            'equations': ['x = l1*cos(q1) + l2*cos(q1 + q2)', 'y = l1*sin(q1) + l2*sin(q1 + q2)']}, 'arm')
    for q1 in ([-math.pi, math.pi], [0.0, 2 * math.pi]):
        model = arm(q1, ['q1'])
        assert model.full_turn.tolist() == [True, False, False, False]
        assert model.box[0].tolist() == [q1[0] - 1e-15, q1[1] + 1e-15]
    for q1, periodic in (([-3.0, 3.0], ['q1']), ([-math.pi, math.pi], [])):
        model = arm(q1, periodic)
        assert not model.full_turn.any() and model.box[0].tolist() == q1


def test_feasible_points_lie_in_every_variable_range():
    """``feasible`` (the test of a solved configuration) holds only inside the variables' box: x = sin(q) with q in
    [-1, 1] and x in [-2, 2] holds at q = 0.5 and at the end q = -1, not at q = 1.5 or -1.2 (x inside, q not)."""
    model = model_from_mapping(BASE, 'b')
    q = np.array([0.5, -1.0, 1.5, -1.2])
    assert model.feasible(np.column_stack([q, np.sin(q)])).tolist() == [True, True, False, False]


BASE = {'type': 'equations', 'parameters': {'a': 1.0}, 'variables': {'q': [-1.0, 1.0], 'x': [-2.0, 2.0]},
        'units': {'q': 'rad'}, 'outputs': ['x'], 'equations': ['x = a*sin(q)']}


@pytest.mark.parametrize('change, match', [
    ({'equations': ['x = a*sin(q']}, "expected '\\)'"),
    ({'equations': ['x = b*sin(q)']}, "unknown name 'b'"),
    ({'equations': ['x = a*sinh(q)']}, "unknown function 'sinh'"),
    ({'equations': ['x <= a*sin(q)']}, 'not an equation; put it under inequalities'),
    ({'inequalities': ['x = q']}, 'is an equation; put it under equations'),
    ({'equations': 'x = q'}, 'must be a list'),
    ({'outputs': ['z']}, 'outputs must be distinct variables'),
    ({'outputs': 'x'}, 'outputs must be a list'),
    ({'variables': {'q': [1.0, -1.0], 'x': [-2.0, 2.0]}}, 'needs lower < upper'),
    ({'variables': {'q': [-1.0, 'one'], 'x': [-2.0, 2.0]}}, 'must be a finite number'),
    ({'variables': {'sin': [-1.0, 1.0], 'x': [-2.0, 2.0]}}, 'reserved'),
    # isidentifier took alpha, which the tokenizer cannot read: refused later, at the equation, not at the name
    ({'variables': {'\u03b1': [-1.0, 1.0], 'x': [-2.0, 2.0]}}, "variable '\u03b1' is not a name \\(ASCII letters"),
    ({'variables': {f'v{i}': [0, 1] for i in range(17)}}, '1 to 16'),
    ({'units': {'q': 'deg'}}, 'a unit must be m or rad'),
    ({'solve_for': ['x']}, 'solve_for must name 1 distinct passive'),
    # no passive variable: it said "name the 1 the proof solves for in solve_for", where none could be named
    ({'outputs': ['q', 'x']}, r'1 equations and 0 passive variables \[\]: an equation needs a passive variable of '
                              r'its own to solve for; allowed: at most as many equations as passive variables'),
    ({'periodic': ['q'], 'equations': ['x = a*sin(q) + q']}, 'used by a constraint itself'),
    # a length and a name that is no variable: "it is used by a non-angle unit", "it is used by nothing"
    ({'periodic': ['q'], 'units': {}}, r"'q' must be an angle .*; its unit is m \(units: \{q: rad\} makes it an "
                                       r'angle\)$'),
    ({'periodic': ['w']}, r"'w' must be an angle .*; it is not a variable \(the variables: q, x\)$"),
    ({'parameters': {'a': True}}, 'a must be a finite number'),
    ({'parameters': {'a': 1.0}, 'a': '2'}, 'a must be a finite number'),
    ({'equatoins': ['x = q']}, 'unknown key.*equatoins'),
    ({'equations': [], 'inequalities': []}, 'constraints; allowed: 1 to 64'),
])
def test_malformed_equation_models_are_refused(change, match):
    with pytest.raises(ConfigError, match=match) as err:
        model_from_mapping({**BASE, **change}, 'm.yaml')
    assert str(err.value).startswith('m.yaml'), str(err.value)   # the file: the model's own checks named its title


def test_parameters_are_overridden_by_top_level_keys():
    model = model_from_mapping(BASE, 'eq', {'a': 0.5})
    res = approximate(model, 0.01)
    # x = 0.5 sin(q), q in [-1, 1]: x in [-0.5 sin 1, 0.5 sin 1]
    hull = np.concatenate([res.inner, res.boundary])
    assert hull[:, 0, 0].min() <= -0.5 * math.sin(1) <= hull[:, 0, 0].min() + 0.01
    assert res.inner_volume <= math.sin(1) <= res.outer_volume


def test_tan_next_to_its_pole_is_covered():
    """An interval starting at the float pi/2 (below the real pole) crosses it: its tan enclosure came out
    inverted and the contractor called the whole box outside, though ``tan(x) <= 0`` holds on (pi/2, 2]."""
    data = {'type': 'equations', 'variables': {'x': [math.pi / 2, 2.0]}, 'units': {'x': 'rad'}, 'outputs': ['x'],
            'inequalities': ['tan(x) <= 0']}
    model = model_from_mapping(data)
    res = approximate(model, 0.01, progress=False)
    x = np.linspace(1.58, 2.0, 50)[:, None]
    assert model.feasible(x).all()
    assert contains_points(np.concatenate([res.inner, res.boundary]), x).all()
    assert 0.40 < res.inner_volume <= 2.0 - math.pi / 2
    inner_pts = res.inner[:, 0, :].ravel()[:, None]
    assert model.feasible(inner_pts).all()


@pytest.mark.parametrize('equation', ['x = 1/q', 'x = log(q)', 'x = tan(10*q)'])
def test_unbounded_enclosures_warn_nothing_and_prove_nothing_false(equation):
    """A successful covering of ``x = 1/q`` printed numpy's RuntimeWarnings (0 * inf in an interval product, the
    middle of an unbounded Krawczyk image) with source lines on stderr; the NaN they make proves nothing, and no
    warning is raised now. Every inner box holds only feasible points (checked at its corners and centre)."""
    import warnings
    data = {'type': 'equations', 'name': 'inv', 'variables': {'q': [-1, 1], 'x': [-2, 2]}, 'outputs': ['x'],
            'equations': [equation]}
    model = model_from_mapping(data)
    with warnings.catch_warnings():
        warnings.simplefilter('error', RuntimeWarning)
        res = approximate(model, 0.01, progress=False)
    assert res.inner.shape[0] > 0
    lo, hi = res.inner[:, 0, 0], res.inner[:, 0, 1]
    q = {'x = 1/q': lambda x: 1 / x, 'x = log(q)': np.exp}.get(equation)
    if q is not None:  # the output x is feasible where some q in [-1, 1] gives it
        for x in np.concatenate([lo, hi, 0.5 * (lo + hi)]):
            assert -1 - 1e-9 <= q(x) <= 1 + 1e-9, (equation, x)

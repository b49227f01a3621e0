"""Expressions of closure equations: the parser (no eval; bad text refused with its column), the DAG, point and
interval evaluation, derivatives against finite differences, and the mean-value enclosure."""
import math
import re

import numpy as np
import pytest
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.workspace.expressions import MAX_DEPTH, Expr, ExpressionError, Graph, parse_constraint
from gpr_kinematics.workspace.interval import Interval
from gpr_kinematics.workspace.tape import Tape

RNG = np.random.default_rng(31)


def _symbols(graph, **params):
    names = {v: graph.var(v) for v in graph.variables}
    names.update({k: graph.constant(x) for k, x in params.items()})
    names['pi'] = graph.constant(math.nextafter(math.pi, 0.0), math.nextafter(math.pi, 4.0))
    return names


def _parse(text, variables=('x', 'y', 'q'), **params):
    g = Graph(variables)
    return g, parse_constraint(text, g, _symbols(g, **params), 'test')


def _tape(texts, **params):
    """The tape of constraints ``texts`` over ``x, y, q`` with the constants ``params``."""
    g = Graph(('x', 'y', 'q'))
    names = _symbols(g, **params)
    return Tape.compile(g, [parse_constraint(t, g, names, 't').root for t in texts])


@pytest.mark.parametrize('text, lower, upper', [
    ('x = la*cos(q) + 0.5', (0.0, 0.0), (0.0, 0.0)),
    ('x^2 + y**2 <= 1', (-math.inf, -math.inf), (1.0, 1.0)),
    ('0.1 <= sqrt(x^2 + y^2) <= 0.4', (0.1, 0.1), (0.4, 0.4)),
    ('0.4 >= abs(x) >= 0.1', (0.1, 0.1), (0.4, 0.4)),
    ('x >= y', (-math.inf, -math.inf), (0.0, 0.0)),               # as y - x <= 0
    ('2 == x', (2.0, 2.0), (2.0, 2.0)),
])
def test_constraint_forms_and_bounds(text, lower, upper):
    _, c = _parse(text, la=0.2)
    assert c.lower == lower and c.upper == upper
    assert c.equality == (lower == upper)


@pytest.mark.parametrize('text, lower, upper', [
    ('1 <= x <= 1', (1.0, 1.0), (1.0, 1.0)),
    ('1 >= x >= 1', (1.0, 1.0), (1.0, 1.0)),
    # 0.1 + 0.2 folds outwards to [0.3, 0.3000000000000001]: it may be 0.3, so the range is not empty
    ('0.1+0.2 <= x <= 0.3', (0.3, math.nextafter(0.1 + 0.2, 1.0)), (0.3, 0.3)),
    ('0.3 >= x >= 0.1 + 0.2', (0.3, math.nextafter(0.1 + 0.2, 1.0)), (0.3, 0.3)),
])
def test_a_range_of_one_value_is_not_empty(text, lower, upper):
    """a <= f <= b is refused as empty only when a surely exceeds b: a == b, or constants whose enclosures overlap at
    one value, are a range (an equality when exact)."""
    _, c = _parse(text)
    assert (c.lower, c.upper) == (lower, upper)
    assert c.equality == (lower == upper)


def test_points_match_numpy_and_equal_subexpressions_are_shared():
    g = Graph(('x', 'y', 'q'))
    names = _symbols(g, la=0.2, lb=0.3)
    texts = ['la*cos(q) + lb*sin(q)^3 - x = 0', 'atan(x/(1 + y^2)) + exp(-x) - log(2 + y) <= 0.5',
             'asin(x/2) + acos(y/2) - tan(q/3) + sqrt(x^2 + y^2) + abs(x - y) >= -3', 'la*cos(q) <= 1']
    cons = [parse_constraint(t, g, names, f'c{i}') for i, t in enumerate(texts)]
    assert cons[3].root.id == g.apply('mul', names['la'], g.apply('cos', names['q'])).id   # la*cos(q) shared
    tape = Tape.compile(g, [c.root for c in cons])
    p = RNG.uniform(-1, 1, (500, 3))
    x, y, q = p.T
    ref = np.stack([0.2 * np.cos(q) + 0.3 * np.sin(q) ** 3 - x,
                    np.arctan(x / (1 + y ** 2)) + np.exp(-x) - np.log(2 + y),
                    np.arcsin(x / 2) + np.arccos(y / 2) - np.tan(q / 3) + np.hypot(x, y) + np.abs(x - y),
                    0.2 * np.cos(q)], axis=1)
    assert np.allclose(tape.points(p), ref, rtol=1e-14, atol=1e-15)
    # undefined points are NaN (they satisfy no constraint): log of a negative, sqrt of a negative, 1/0
    g2 = Graph(('x',))
    t2 = Tape.compile(g2, [parse_constraint(s, g2, {'x': g2.var('x')}, 't').root
                           for s in ('log(x) <= 1', 'sqrt(x) <= 1', '1/x <= 1')])
    assert np.all(np.isnan(t2.points(np.array([[-1.0]]))[0, :2])) and np.isnan(t2.points(np.zeros((1, 1)))[0, 2])


def test_interval_enclosures_contain_sampled_values_and_flag_undefined_boxes():
    tape = _tape(['la*cos(q) - x*sin(q)^2 + atan(x*y) = 0', 'sqrt(x + 2) - exp(y)/(3 + q) + asin(x/3) <= 0'],
                 la=0.2)
    lo = RNG.uniform(-1, 0.5, (300, 3))
    hi = lo + RNG.uniform(0, 0.5, (300, 3))
    enc, maybe, surely = tape.root_boxes(lo, hi)
    assert not maybe.any() and not surely.any()
    pts = lo[None] + (hi - lo)[None] * RNG.random((200, 300, 3))
    vals = tape.points(pts.reshape(-1, 3)).reshape(200, 300, 2)
    assert np.all(enc.lo[None] <= vals) and np.all(vals <= enc.hi[None])
    # sqrt of a box reaching below 0: maybe undefined; entirely below 0: undefined everywhere
    g2 = Graph(('x',))
    t2 = Tape.compile(g2, [parse_constraint('sqrt(x) <= 1', g2, {'x': g2.var('x')}, 't').root])
    _, maybe, surely = t2.root_boxes(np.array([[-1.0], [-3.0], [1.0]]), np.array([[1.0], [-2.0], [2.0]]))
    assert maybe.tolist() == [True, True, False] and surely.tolist() == [False, True, False]


def _check_against_differences(tape: Tape, p: np.ndarray) -> None:
    """The tape's values and forward-mode derivatives at points ``p (N, 3)`` against its values and central
    differences (step 1e-6, error of order 1e-12 plus rounding 1e-10)."""
    val, jac = tape.jacobian_points(p, [0, 1, 2])
    assert np.allclose(val, tape.points(p))
    h = 1e-6
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        fd = (tape.points(p + e) - tape.points(p - e)) / (2 * h)
        assert np.allclose(jac[:, :, j], fd, atol=1e-7), j


def test_derivatives_match_finite_differences_and_interval_slopes_contain_them():
    tape = _tape(['la*cos(q)*x - y^3/(2 + x^2) + atan(x*y)*sin(q) = 0', 'exp(x*y) - sqrt(3 + q^2) + asin(x/3) = 0'],
                 la=0.2)
    p = RNG.uniform(-1, 1, (200, 3))
    _check_against_differences(tape, p)
    lo, hi = p - 0.05, p + 0.05
    J, maybe = tape.jacobian_boxes(lo, hi, [0, 2])
    assert not maybe.any()
    for t in RNG.random((50, 3)):
        _, jp = tape.jacobian_points(lo + (hi - lo) * t, [0, 2])
        assert np.all(J.lo <= jp) and np.all(jp <= J.hi)


def test_mean_value_enclosure_is_certified_and_tighter_on_small_boxes():
    g = Graph(('x', 'y'))
    names = _symbols(g)
    # (x - y)^2 expanded: the variables occur several times, the natural extension overestimates a lot
    c = parse_constraint('x*x - 2*x*y + y*y + x*sin(y) <= 1', g, names, 't')
    tape = Tape.compile(g, [c.root])
    lo = RNG.uniform(-1, 1, (400, 2))
    hi = lo + 1e-3
    natural, _, _ = tape.root_boxes(lo, hi)
    tight, maybe = tape.root_boxes_tight(lo, hi, [0, 1])
    assert not maybe.any()
    pts = lo[None] + (hi - lo)[None] * RNG.random((100, 400, 2))
    vals = tape.points(pts.reshape(-1, 2)).reshape(100, 400)
    assert np.all(tight.lo[:, 0] <= vals) and np.all(vals <= tight.hi[:, 0])
    assert np.all(tight.lo >= natural.lo) and np.all(tight.hi <= natural.hi)
    spread = vals.max(axis=0) - vals.min(axis=0)
    assert np.median((natural.hi - natural.lo)[:, 0] / spread) > 1.6          # about 2: the dependency effect
    assert np.median((tight.hi - tight.lo)[:, 0] / spread) < 1.3              # about 1.13: second order only


@pytest.mark.parametrize('text, match', [
    ('x + ', 'unexpected end'),
    ('x + * y', "unexpected '\\*' at column 5"),
    ('x $ y', "unexpected character '\\$' at column 3"),
    ('foo(x) = 1', "unknown function 'foo' at column 1"),
    ('x + z = 1', "unknown name 'z' at column 5"),
    ('x < 1', 'use <= or >='),
    ('x + 1', 'needs =, <= or >='),
    ('x <= y <= 1', 'outer terms of a <= f <= b must be constants'),
    ('0 <= x >= 1', 'a chain must read'),
    ('x^0.5 = 1', 'integer constant'),
    ('x^y = 1', 'integer constant'),
    ('x^999 = 1', 'integer constant'),
    ('sqrt(-1) + x = 0', 'sqrt of the constant'),
    ('x = 1e999', 'not finite'),
    ('x.real = 1', "unexpected character '\\.'"),
    ('x = \u0661', "unexpected character '\u0661' at column 5"),     # Arabic-Indic 1: \\d read it as 1
    ('x = 0.\uff15', "unexpected character '\uff15' at column 7"),   # fullwidth 5: 0.5 (files refuse both)
    ('x = 1e\u0663', "unexpected character '\u0663' at column 7"),   # 1e3 with an Arabic-Indic 3
    ('__import__("os") = 1', 'unexpected character'),
    ('(' * (MAX_DEPTH + 2) + 'x' + ')' * (MAX_DEPTH + 2) + ' = 1', 'nested deeper than'),
    ('-' * (MAX_DEPTH + 2) + 'x = 1', 'nested deeper than'),
    ('x' + ' + x' * 800 + ' = 1', 'characters; allowed: at most'),
    ('', 'non-empty text'),
    (3, 'non-empty text'),
    # an empty range: an empty workspace was reported, exit 0
    ('2 <= x <= 1', r'the range \[2, 1\] of a <= f <= b is empty; allowed: a <= b'),
    ('1 >= x >= 2', r'the range \[2, 1\] of a <= f <= b is empty; allowed: a <= b'),
])
def test_malformed_constraints_are_refused_with_what_is_wrong(text, match):
    with pytest.raises(ExpressionError, match=match):
        _parse(text)
    assert issubclass(ExpressionError, ConfigError)


@pytest.mark.parametrize('text, match', [
    ('1e308*1e308*x <= 1', r'mul of the constants \[1e\+308, 1e\+308\] and \[1e\+308, 1e\+308\] is not a finite '
                           r'number \(by column 7\)'),
    ('exp(1000) <= x', r'exp of the constant \[1000, 1000\] is not a finite number \(by column 9\)'),
    ('1/0 <= x', r'division by the constant \[0, 0\], which holds 0, is undefined \(by column 3\)'),   # it named 1
    # a variable over a constant 0 (or an enclosure holding 0): an empty workspace, exit 0
    ('x/0 <= 1', r'division by the constant \[0, 0\], which holds 0, is undefined \(by column 3\)'),
    ('x/(1-1) <= 1', r'division by the constant \[-4.94066e-324, 4.94066e-324\], which holds 0, is undefined '
                     r'\(by column 7\)'),
    ('sqrt(-1) <= x', r'sqrt of the constant \[-1, -1\] is undefined \(by column 8\)'),
])
def test_a_constant_part_off_its_domain_is_located_in_one_line(text, match, recwarn):
    """Constant parts are computed once, first: off their domain or beyond floats they printed numpy's warnings
    and a message naming neither the constraint nor where in it (nor, for a division by zero, the zero)."""
    with pytest.raises(ExpressionError, match=rf"^test \({re.escape(repr(text))}\): {match}; allowed: constant "
                                              r'parts of finite value'):
        _parse(text)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


def test_python_formulas_build_the_same_graph_and_mix_with_interval_constants():
    """A formula written for intervals gives expressions when handed Expr variables (the models' formulas)."""
    def formula(u, v):
        return (u * Interval.const(0.1) + v.sin() * 2.0).sqr() - u / (v.cos() + 3.0)

    g = Graph(('u', 'v'))
    e = formula(g.var('u'), g.var('v'))
    assert isinstance(e, Expr)
    tape = Tape.compile(g, [e])
    lo = RNG.uniform(-1, 1, (100, 2))
    hi = lo + 0.1
    enc, _, _ = tape.root_boxes(lo, hi)
    direct = formula(Interval(lo[:, 0], hi[:, 0]), Interval(lo[:, 1], hi[:, 1]))
    # the same operations on enclosures: the expression's enclosure equals the interval formula's, up to the
    # outward rounding of the constant 0.1 (one ulp either side in both)
    assert np.allclose(enc.lo[:, 0], direct.lo, rtol=1e-14) and np.allclose(enc.hi[:, 0], direct.hi, rtol=1e-14)
    with pytest.raises(ExpressionError, match='different models'):
        Graph(('u',)).var('u') + g.var('u')
    with pytest.raises(ExpressionError, match='integer exponent'):
        g.var('u') ** 1.5


def test_derivatives_of_the_remaining_operations_match_finite_differences():
    """tan, log, acos, abs, negation, a constant over a variable, a constant minus a variable, sqr and a quotient of
    two variable terms: forward-mode derivatives against central differences at points off abs's kink, and the
    interval slopes over boxes around them contain the point derivatives."""
    tape = _tape(['tan(x/2) + log(2 + y) - acos(q/2) + abs(x - 0.5*y) = 0',
                  '-(x*q) + 1/(2 + y^2) - (3 - sqr(q)) + (x + 2)/(y + 3) = 0'])
    p = RNG.uniform(-1, 1, (300, 3))
    p = p[np.abs(p[:, 0] - 0.5 * p[:, 1]) > 0.01]
    _check_against_differences(tape, p)
    lo, hi = p - 0.05, p + 0.05                               # some boxes straddle the kink of abs
    J, maybe = tape.jacobian_boxes(lo, hi, [0, 1, 2])
    assert not maybe.any()
    kink = (lo[:, 0] - 0.5 * hi[:, 1] < 0) & (hi[:, 0] - 0.5 * lo[:, 1] > 0)
    assert 10 < kink.sum() < kink.size
    for t in RNG.random((30, 3)):
        _, jp = tape.jacobian_points(lo + (hi - lo) * t, [0, 1, 2])
        assert np.all(J.lo <= jp) and np.all(jp <= J.hi)


@pytest.mark.parametrize('fn, boxes, maybe_expected, surely_expected', [
    # the domain's ends are in it: [-1, 1] for asin and acos, [0, inf) for sqrt; log needs x > 0, 1/x needs x != 0
    ('asin(x)', [(-1.0, 1.0), (1.0, 2.0), (-2.0, -1.0), (1.5, 2.0), (-3.0, -1.5), (-2.0, 2.0)],
     [False, True, True, True, True, True], [False, False, False, True, True, False]),
    ('acos(x)', [(-1.0, 1.0), (1.0, 2.0), (-2.0, -1.0), (1.5, 2.0), (-3.0, -1.5), (-2.0, 2.0)],
     [False, True, True, True, True, True], [False, False, False, True, True, False]),
    ('sqrt(x)', [(0.0, 1.0), (-1.0, 0.0), (-2.0, -1.0), (0.0, 0.0)], [False, True, True, False],
     [False, False, True, False]),
    ('log(x)', [(1e-300, 1.0), (0.0, 1.0), (-1.0, 0.0), (-2.0, -1.0)], [False, True, True, True],
     [False, False, True, True]),
    ('1/x', [(0.5, 1.0), (0.0, 1.0), (-1.0, 0.0), (-1.0, 1.0), (0.0, 0.0), (-2.0, -1.0)],
     [False, True, True, True, True, False], [False, False, False, False, True, False]),
])
def test_boxes_touching_the_end_of_a_domain_are_flagged_exactly(fn, boxes, maybe_expected, surely_expected):
    """The undefinedness masks of one operation over boxes at the ends of its domain: *maybe* when some point of
    the box is outside the domain, *surely* when every point is (a box whose end is a domain end holds a point
    where the function is defined: asin(1), sqrt(0))."""
    g = Graph(('x',))
    tape = Tape.compile(g, [parse_constraint(f'{fn} <= 1', g, {'x': g.var('x')}, 't').root])
    lo = np.array([[b[0]] for b in boxes])
    hi = np.array([[b[1]] for b in boxes])
    _, maybe, surely = tape.root_boxes(lo, hi)
    assert maybe.tolist() == maybe_expected and surely.tolist() == surely_expected


def test_the_slope_of_abs_is_its_sign_over_boxes_off_zero():
    """d|x|/dx over a box: 1 where the box is positive, -1 where negative, [-1, 1] where it holds 0, an end at 0
    included (the point derivative there is sign(0) = 0, which the enclosure must hold)."""
    g = Graph(('x',))
    tape = Tape.compile(g, [g.var('x').abs()])
    J, _ = tape.jacobian_boxes(np.array([[0.5], [-2.0], [-1.0], [0.0]]), np.array([[2.0], [-0.5], [1.0], [1.0]]), [0])
    assert np.allclose(J.lo[:, 0, 0], [1.0, -1.0, -1.0, -1.0], rtol=1e-15, atol=0.0)     # to the outward ulp
    assert np.allclose(J.hi[:, 0, 0], [1.0, -1.0, 1.0, 1.0], rtol=1e-15, atol=0.0)


def test_the_operation_limit_is_named_as_itself(monkeypatch):
    """The operation limit's error, raised while a constraint is parsed, was relabelled as a constant part's (two
    'allowed:', the second wrong): only a constant part's own error is."""
    from gpr_kinematics.workspace import expressions

    monkeypatch.setattr(expressions, 'MAX_NODES', 12)
    with pytest.raises(ExpressionError) as err:
        _parse('x + y + q + x*y + x*q + y*q + x*y*q <= 1')
    text = str(err.value)
    assert 'the equations need more than 12 operations; allowed: at most 12' in text, text
    assert 'constant parts' not in text and text.count('allowed:') == 1, text

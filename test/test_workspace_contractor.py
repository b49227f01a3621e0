"""Forward-backward contraction: never loses a solution (random systems with known solutions, every
operation), proves empty boxes empty, and narrows as far as the exact preimages on simple cases."""
import math

import numpy as np
import pytest
from gpr_kinematics.workspace.contractor import _BACKWARD_RULES, contract
from gpr_kinematics.workspace.expressions import BINARY, UNARY, Graph, parse_constraint
from gpr_kinematics.workspace.tape import Tape

RNG = np.random.default_rng(77)
# one expression per operation family; each becomes an equality at sampled points (so they are solutions)
FAMILIES = [
    '2*cos(a) + sin(b)*c - a*b',
    'sqrt(1 + a^2) - exp(b/3) + log(2 + c)',
    'atan(a*b) + tan(c/2) - abs(a - b)',
    'asin(a/3) * acos(b/3) + c^3 - a/(2 + b^2)',
    'sqr(a - c) + (b + 1)^2 - 1/(3 + cos(c))',
]


def _system(text):
    """``f(a, b, c) - t = 0``: with ``t`` a variable, every sampled point ``(a, b, c, f(a, b, c))`` solves it."""
    g = Graph(('a', 'b', 'c', 't'))
    names = {v: g.var(v) for v in g.variables}
    c = parse_constraint(f'{text} - t = 0', g, names, 't')
    return Tape.compile(g, [c.root])


@pytest.mark.parametrize('text', FAMILIES)
def test_contraction_keeps_every_solution_point(text):
    tape = _system(text)
    n = 4000
    s = RNG.uniform(-1.2, 1.2, (n, 4))
    s[:, 3] = 0.0
    s[:, 3] = tape.points(s)[:, 0]                        # f(a, b, c) - t = 0 at s (up to rounding)
    half = RNG.uniform(0.0, 1.5, (n, 4)) * (RNG.random((n, 4)) < 0.8)
    half[:, 3] = 1e-12 * (1 + np.abs(s[:, 3])) + half[:, 3] * 0.1      # t's box always holds the exact value
    lo = s - half * RNG.random((n, 4)) - 1e-12 * (1 + np.abs(s)) * (np.arange(4) == 3)
    hi = s + half * RNG.random((n, 4)) + 1e-12 * (1 + np.abs(s)) * (np.arange(4) == 3)
    clo, chi, empty = contract(tape, lo, hi, np.zeros(1), np.zeros(1), sweeps=3)
    assert not empty.any()
    assert np.all(clo[:, :3] <= s[:, :3]) and np.all(s[:, :3] <= chi[:, :3])
    assert np.all(clo >= lo) and np.all(chi <= hi)
    assert np.mean(np.any(chi - clo < hi - lo, axis=1)) > 0.2                   # and it narrows


def test_boxes_without_solutions_are_proved_empty():
    g = Graph(('x', 'y'))
    names = {v: g.var(v) for v in g.variables}
    cons = [parse_constraint(t, g, names, 't') for t in ('x^2 + y^2 = 1', 'x - y >= 0')]
    tape = Tape.compile(g, [c.root for c in cons])
    lower = np.array([c.lower[0] for c in cons])
    upper = np.array([c.upper[1] for c in cons])
    lo = np.array([[2.0, 2.0], [0.0, 0.0], [-0.2, 0.5], [0.6, -0.9]])
    hi = np.array([[3.0, 3.0], [0.5, 0.5], [0.2, 1.0], [1.2, 0.9]])
    clo, chi, empty = contract(tape, lo, hi, lower, upper)
    # far away; inside the circle; above the diagonal (x - y < 0 everywhere); holds solutions
    assert empty.tolist() == [True, True, True, False]
    # the last one narrows to the arc's hull: x >= max(0.6, ...) and |y| <= sqrt(1 - 0.36) = 0.8
    assert clo[3, 1] >= -0.8 - 1e-9 and chi[3, 1] <= 0.8 + 1e-9 and chi[3, 0] <= 1.0 + 1e-9


def test_periodic_preimages_are_the_exact_arcs():
    g = Graph(('q',))
    q = g.var('q')
    tape = Tape.compile(g, [q.cos(), q.sin()])
    # cos q in [0.5, 1] within [-4, 4]: only the arc [-pi/3, pi/3]
    clo, chi, empty = contract(tape, np.array([[-4.0]]), np.array([[4.0]]), np.array([0.5, -1.0]),
                               np.array([1.0, 1.0]))
    assert not empty[0] and abs(clo[0, 0] + math.pi / 3) < 1e-12 and abs(chi[0, 0] - math.pi / 3) < 1e-12
    # and sin q in [0.5, 1] within [-7, 0]: the arc [pi/6, 5 pi/6] - 2 pi
    clo, chi, empty = contract(tape, np.array([[-7.0]]), np.array([[0.0]]), np.array([-1.0, 0.5]),
                               np.array([1.0, 1.0]))
    assert abs(clo[0, 0] - (math.pi / 6 - 2 * math.pi)) < 1e-12
    assert abs(chi[0, 0] - (5 * math.pi / 6 - 2 * math.pi)) < 1e-12
    # no preimage at all: cos q = 2
    _, _, empty = contract(tape, np.array([[-1.0]]), np.array([[1.0]]), np.array([2.0, -1.0]),
                           np.array([2.0, 1.0]))
    assert empty[0]


def test_every_operation_of_the_graphs_has_a_backward_rule():
    # a graph can hold any of these operations; the backward pass must narrow through each of them
    assert set(_BACKWARD_RULES) == set(UNARY) | set(BINARY)


def test_tan_preimage_keeps_solutions_next_to_a_pole():
    """``tan(x) = tan(x0)`` for x0 the float nearest a pole (either side): the contraction of boxes that start or
    end at x0 keeps x0 (the branch test rounded x0 = 1.5707963267948966, below the real pi/2, into the next
    branch and narrowed the box to atan(.) + pi, far from x0: no solution left)."""
    g = Graph(('x',))
    tape = Tape.compile(g, [g.var('x').tan()])
    for k in range(-20, 21):
        pole = np.pi / 2 + k * np.pi
        for x0 in (pole, np.nextafter(pole, -np.inf), np.nextafter(pole, np.inf)):
            t0 = np.tan(x0)
            for lo, hi in ((x0, x0 + 0.3), (x0 - 0.3, x0), (x0, x0)):
                clo, chi, empty = contract(tape, np.array([[lo]]), np.array([[hi]]), np.array([t0]), np.array([t0]))
                assert not empty[0] and clo[0, 0] <= x0 <= chi[0, 0], (k, x0, lo, hi)


def test_inverse_trigonometric_constraints_narrow_their_argument_to_the_exact_preimage():
    """``arccos x`` in [0, pi/3] holds exactly for x in [1/2, 1], in [pi/2, pi] for x in [-1, 0]; ``arcsin x`` in
    [-pi/2, pi/6] for x in [-1, 1/2], in [-pi/6, pi/2] for x in [-1/2, 1]; ``atan x`` in [pi/4, pi/2] for x >= 1, in
    [-pi/3, pi/4] for x in [-sqrt(3), 1]: the backward pass narrows x in [-5, 5] to those intervals, to rounding."""
    cases = [('arccos', 0.0, math.pi / 3, 0.5, 1.0), ('arccos', math.pi / 2, math.pi, -1.0, 0.0),
             ('arcsin', -math.pi / 2, math.pi / 6, -1.0, 0.5), ('arcsin', -math.pi / 6, math.pi / 2, -0.5, 1.0),
             ('arctan', math.pi / 4, math.pi / 2, 1.0, 5.0), ('arctan', -math.pi / 3, math.pi / 4, -math.sqrt(3), 1.0)]
    for fn, ylo, yhi, xlo, xhi in cases:
        g = Graph(('x',))
        tape = Tape.compile(g, [getattr(g.var('x'), fn)()])
        clo, chi, empty = contract(tape, np.array([[-5.0]]), np.array([[5.0]]), np.array([ylo]), np.array([yhi]))
        assert not empty[0]
        assert xlo - 1e-12 <= clo[0, 0] <= xlo and xhi <= chi[0, 0] <= xhi + 1e-12, (fn, ylo, yhi, clo, chi)


@pytest.mark.parametrize('fn', ['cos', 'sin'])
def test_periodic_preimages_keep_solutions_many_turns_from_zero(fn):
    """``f(q) = t`` with ``t`` the one-ulp enclosure of ``f(q0)`` and ``q0`` thousands of turns either side of 0: the
    arcs ``+-acos(t) + 2 pi k`` are computed with the float 2 pi (2.4e-16 short of the real one, so 1e-13 off after
    a thousand turns, far beyond the width of the arc of t), and the contraction must still keep q0 (a box
    0.6 rad wide holds one of the two arcs unless q0 is next to a multiple of pi)."""
    g = Graph(('q', 't'))
    q = g.var('q')
    tape = Tape.compile(g, [getattr(q, fn)() - g.var('t')])
    rng = np.random.default_rng(8)
    q0 = np.concatenate([rng.uniform(1e3, 1e5, 200), -rng.uniform(1e3, 1e5, 200)])
    value = getattr(np, fn)(q0)
    t_lo, t_hi = np.nextafter(value, -np.inf), np.nextafter(value, np.inf)        # libm: within one ulp
    for width in (0.3, 4.0):
        lo = np.stack([q0 - width * rng.random(q0.size), t_lo], axis=1)
        hi = np.stack([q0 + width * rng.random(q0.size), t_hi], axis=1)
        clo, chi, empty = contract(tape, lo, hi, np.zeros(1), np.zeros(1))
        assert not empty.any() and np.all(clo[:, 0] <= q0) and np.all(q0 <= chi[:, 0])
        if width < 1.0:                                          # and mostly narrowed to the one arc holding q0
            assert np.mean(chi[:, 0] - clo[:, 0] < 1e-6) > 0.9


@pytest.mark.parametrize('text, box, bounds, expected', [
    ('x^2', (-5.0, 5.0), (1.0, 4.0), (-2.0, 2.0)),                 # both branches of the square root
    ('x^2', (-5.0, 0.0), (1.0, 4.0), (-2.0, -1.0)),
    ('x^2', (-1.5, 5.0), (1.0, 4.0), (-1.5, 2.0)),                 # the hull of [-1.5, -1] and [1, 2]
    ('abs(x)', (-5.0, 0.5), (1.0, 2.0), (-2.0, -1.0)),
    ('abs(x)', (-0.5, 5.0), (1.0, 2.0), (1.0, 2.0)),
    ('sqrt(x)', (-5.0, 50.0), (1.0, 2.0), (1.0, 4.0)),
    ('sqrt(x)', (-5.0, 50.0), (0.5, 0.75), (0.25, 0.5625)),
    ('sqrt(x)', (-5.0, 50.0), (-1.0, 2.0), (0.0, 4.0)),
    ('exp(x)', (-5.0, 5.0), (1.0, math.e), (0.0, 1.0)),
    ('log(x)', (-5.0, 50.0), (0.0, 1.0), (1.0, math.e)),
    ('tan(x)', (-1.0, 1.0), (0.0, 1.0), (0.0, math.pi / 4)),
    ('-x', (-5.0, 5.0), (1.0, 2.0), (-2.0, -1.0)),
    ('3*x', (-5.0, 5.0), (1.0, 2.0), (1.0 / 3.0, 2.0 / 3.0)),
    ('x/4', (-5.0, 5.0), (-1.0, 0.5), (-4.0, 2.0)),
    ('2/x', (0.1, 5.0), (1.0, 4.0), (0.5, 2.0)),
    ('x - 3', (-5.0, 5.0), (-1.0, 1.0), (2.0, 4.0)),
    ('3 - x', (-5.0, 5.0), (-1.0, 1.0), (2.0, 4.0)),
    ('x + 3', (-5.0, 5.0), (-1.0, 1.0), (-4.0, -2.0)),
])
def test_one_operation_narrows_its_argument_to_the_exact_preimage(text, box, bounds, expected):
    """``f(x)`` in [a, b] over x in a box: the backward rule of each operation narrows x to the part of the box where
    f takes values in [a, b] (worked out by hand: the branches of the square and of abs, the inverse functions,
    the linear ones solved for x), to rounding."""
    g = Graph(('x',))
    c = parse_constraint(f'{text} = 0', g, {'x': g.var('x')}, 't')
    tape = Tape.compile(g, [c.root])
    clo, chi, empty = contract(tape, np.array([[box[0]]]), np.array([[box[1]]]), np.array([bounds[0]]),
                               np.array([bounds[1]]))
    assert not empty[0]
    assert expected[0] - 1e-12 <= clo[0, 0] <= expected[0] and expected[1] <= chi[0, 0] <= expected[1] + 1e-12, (
        clo[0, 0], chi[0, 0])

"""Krawczyk's existence test over a box of parameters: what it proves is true (every parameter point of the box
has its solution inside K, found independently in closed form), and it proves nothing where solutions are
missing for part of the box."""
import numpy as np
from gpr_kinematics.workspace.expressions import Graph, parse_constraint
from gpr_kinematics.workspace.interval import Interval
from gpr_kinematics.workspace.krawczyk import krawczyk, newton
from gpr_kinematics.workspace.tape import Tape

RNG = np.random.default_rng(5)
L1, L2 = 1.0, 0.8


def _arm():
    """Two-link arm: x = l1 cos q1 + l2 cos(q1 + q2), y = l1 sin q1 + l2 sin(q1 + q2); variables x, y, q1, q2."""
    g = Graph(('x', 'y', 'q1', 'q2'))
    names = {v: g.var(v) for v in g.variables}
    names.update(l1=g.constant(L1), l2=g.constant(L2))
    texts = ('l1*cos(q1) + l2*cos(q1 + q2) - x = 0', 'l1*sin(q1) + l2*sin(q1 + q2) - y = 0')
    return Tape.compile(g, [parse_constraint(t, g, names, 't').root for t in texts])


def _ik(x, y, elbow):
    """Closed-form inverse kinematics of the arm (law of cosines), elbow +1 / -1."""
    c2 = (x ** 2 + y ** 2 - L1 ** 2 - L2 ** 2) / (2 * L1 * L2)
    q2 = elbow * np.arccos(np.clip(c2, -1, 1))
    q1 = np.arctan2(y, x) - np.arctan2(L2 * np.sin(q2), L1 + L2 * np.cos(q2))
    return q1, q2


def test_proved_boxes_hold_the_independent_solution_of_every_point():
    tape = _arm()
    n = 400
    q = np.stack([RNG.uniform(-3, 3, n), RNG.uniform(0.3, 2.8, n)], axis=1)          # elbow up, regular
    xy = np.stack([L1 * np.cos(q[:, 0]) + L2 * np.cos(q.sum(1)), L1 * np.sin(q[:, 0]) + L2 * np.sin(q.sum(1))], 1)
    half = RNG.uniform(1e-4, 2e-2, (n, 1))
    lo = np.concatenate([xy - half, q + 0.01], axis=1)           # solved coordinates: any start (Newton fixes it)
    hi = np.concatenate([xy + half, q + 0.01], axis=1)
    centre = 0.5 * (lo + hi)
    p, ok = newton(tape, centre, [2, 3], np.zeros(2))
    assert ok.all() and np.allclose(p[:, 2:], q, atol=1e-12)
    proved, K = krawczyk(tape, lo, hi, p, [2, 3], [0, 1], Interval(np.zeros((n, 2)), np.zeros((n, 2))))
    assert proved.mean() > 0.6             # boxes up to 4 cm on a 1.8 m arm: most are proved (78 %)
    for t in RNG.random((30, 2)):
        pts = lo[:, :2] + (hi[:, :2] - lo[:, :2]) * t
        q1, q2 = _ik(pts[:, 0], pts[:, 1], 1.0)
        q1 = q1 + 2 * np.pi * np.round((q[:, 0] - q1) / (2 * np.pi))           # the branch near the centre's
        sol = np.stack([q1, q2], axis=1)
        inside = np.all((K.lo <= sol) & (sol <= K.hi), axis=1)
        assert inside[proved].all()


def test_boxes_reaching_beyond_the_workspace_are_never_proved():
    tape = _arm()
    n = 300
    ang = RNG.uniform(-np.pi, np.pi, n)
    r = L1 + L2 - RNG.uniform(0.0, 0.02, n)                      # just inside the outer rim (arm stretched)
    xy = np.stack([r * np.cos(ang), r * np.sin(ang)], axis=1)
    half = np.full((n, 1), 0.03)                                  # every box pokes out of the reachable disc
    q1, q2 = _ik(xy[:, 0], xy[:, 1], 1.0)
    lo = np.concatenate([xy - half, np.stack([q1, q2], 1)], axis=1)
    hi = np.concatenate([xy + half, np.stack([q1, q2], 1)], axis=1)
    p, ok = newton(tape, 0.5 * (lo + hi), [2, 3], np.zeros(2))
    proved, _ = krawczyk(tape, lo[ok], hi[ok], p[ok], [2, 3], [0, 1], Interval(np.zeros((ok.sum(), 2)),
                                                                             np.zeros((ok.sum(), 2))))
    assert not proved.any()


def test_newton_reports_singular_and_divergent_points():
    tape = _arm()
    # x = y = 0 with l1 != l2 has no solution: Newton must not report convergence
    p, ok = newton(tape, np.array([[0.0, 0.0, 0.3, 1.0]]), [2, 3], np.zeros(2))
    assert not ok[0]


def test_point_matrix_times_interval_vector_encloses_every_product():
    """``C v`` for point matrices and interval vectors (the ``C F`` term of K): the exact products of C with the
    corners of v, in rationals, lie inside, and the enclosure is the hull of those corners to rounding (the
    range of a linear map over a box is attained at its corners)."""
    from fractions import Fraction
    from itertools import product

    from gpr_kinematics.workspace.krawczyk import _matvec
    rng = np.random.default_rng(9)
    C = rng.normal(size=(20, 3, 3))
    lo = rng.normal(size=(20, 3))
    hi = lo + rng.random((20, 3))
    out = _matvec(C, Interval(lo, hi))
    for n in range(20):
        corners = [[sum(Fraction(C[n, i, j]) * Fraction([lo, hi][c[j]][n, j]) for j in range(3)) for i in range(3)]
                   for c in product((0, 1), repeat=3)]
        for i in range(3):
            vals = [row[i] for row in corners]
            assert Fraction(out.lo[n, i]) <= min(vals) and max(vals) <= Fraction(out.hi[n, i])
            assert float(min(vals)) - out.lo[n, i] < 1e-14 and out.hi[n, i] - float(max(vals)) < 1e-14


def test_newton_diverging_to_huge_points_is_quiet_and_not_converged():
    """``t^2 = x`` at x = -1 has no real root; Newton from t = 1e200 has J = 2e200, whose norm overflowed in numpy
    with a RuntimeWarning that ``gpr workspace`` printed on stderr (an equations file of ``t^2 = x`` over t, x in
    [-1, 1]). No warning now, and no point reported converged; t = 1 at x = 1 still converges to its root 1."""
    import warnings
    g = Graph(('x', 't'))
    names = {v: g.var(v) for v in g.variables}
    tape = Tape.compile(g, [parse_constraint('t^2 - x = 0', g, names, 't').root])
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        p, ok = newton(tape, np.array([[-1.0, 1e200], [-1.0, 1e154], [1.0, 1.2]]), [1], np.zeros(1))
    assert ok.tolist() == [False, False, True] and abs(p[2, 1] - 1.0) < 1e-15

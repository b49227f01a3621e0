"""Interval arithmetic of gpr_kinematics.workspace.interval: enclosures contain sampled values, known exact ranges,
outward rounding checked with exact rational arithmetic."""
from fractions import Fraction

import numpy as np
import pytest
from gpr_kinematics.workspace.interval import Interval, monotone, sqrt3_over_2

RNG = np.random.default_rng(12345)


def _random_intervals(n, scale=3.0):
    a = RNG.normal(0.0, scale, n)
    b = a + RNG.exponential(scale, n) * (RNG.random(n) < 0.9)   # some degenerate intervals
    return Interval(a, b)


def _samples(x, k=200):
    t = RNG.random((k, x.lo.shape[0]))
    t[0], t[1] = 0.0, 1.0                     # the endpoints themselves
    return np.clip(x.lo + (x.hi - x.lo) * t, x.lo, x.hi)    # rounding must not leave the interval


def _assert_encloses(result, values):
    assert np.all(result.lo <= values), (values - result.lo).min()
    assert np.all(values <= result.hi), (result.hi - values).min()


@pytest.mark.parametrize('name', ['add', 'sub', 'mul', 'div'])
def test_binary_operations_enclose_samples(name):
    x, y = _random_intervals(500), _random_intervals(500)
    if name == 'div':
        y = Interval(np.abs(y.lo) + 0.1, np.abs(y.lo) + 0.1 + y.width)
    op = {'add': np.add, 'sub': np.subtract, 'mul': np.multiply, 'div': np.divide}[name]
    res = op(x, y) if name != 'div' else x / y
    xs, ys = _samples(x), _samples(y)
    _assert_encloses(res, op(xs, ys))
    # the extreme combinations of endpoints are attained: the enclosure is tight to a few ulps
    corners = np.stack([op(a, b) for a in (x.lo, x.hi) for b in (y.lo, y.hi)])
    assert np.allclose(res.lo, corners.min(0), rtol=1e-14, atol=1e-300)
    assert np.allclose(res.hi, corners.max(0), rtol=1e-14, atol=1e-300)


@pytest.mark.parametrize('fn', ['sin', 'cos', 'sqr', 'sqrt', 'arctan', 'exp', 'abs'])
def test_unary_functions_enclose_samples(fn):
    x = _random_intervals(400, scale=4.0)
    if fn == 'sqrt':
        x = Interval(np.abs(x.lo), np.abs(x.lo) + x.width)
    res = getattr(x, fn)()
    ref = {'sin': np.sin, 'cos': np.cos, 'sqr': np.square, 'sqrt': np.sqrt, 'arctan': np.arctan,
           'exp': np.exp, 'abs': np.abs}[fn]
    xs = _samples(x, 2000)
    vals = ref(xs)
    _assert_encloses(res, vals)
    # not grossly wider than the sampled range (sampling dense enough for these widths)
    assert np.all(res.hi - res.lo <= vals.max(0) - vals.min(0) + 0.05 * (1 + np.abs(vals).max(0)))


def test_tan_and_arcsin_on_their_domains():
    x = Interval(RNG.uniform(-1.5, 0.0, 300), RNG.uniform(0.0, 1.5, 300))
    _assert_encloses(x.tan(), np.tan(_samples(x)))
    y = Interval(RNG.uniform(-1, 0, 300), RNG.uniform(0, 1, 300))
    _assert_encloses(y.arcsin(), np.arcsin(_samples(y)))
    # across a pole of tan the enclosure is the whole line
    assert np.isinf(Interval(1.0, 2.0).tan().hi) and np.isinf(Interval(1.0, 2.0).tan().lo)


def test_tan_across_a_pole_next_to_an_end_is_the_whole_line():
    """The float pi/2 (and k pi + pi/2 rounded) may lie on either side of the real pole: ``floor(t / pi + 1/2)``
    of both ends agreed for [1.5707963267948966, 2] (both 1), and the enclosure came out inverted, [1.6e16,
    -1.83], though tan takes every real value there."""
    half_pi = np.pi / 2                                     # 6.1e-17 below the real pole: tan = +1.6e16
    for k in range(-40, 41):
        pole = half_pi + k * np.pi
        for end in (pole, np.nextafter(pole, -np.inf), np.nextafter(pole, np.inf)):
            for lo, hi in ((end, end + 0.5), (end - 0.5, end)):
                t = Interval(np.array([lo]), np.array([hi])).tan()
                assert t.lo[0] <= t.hi[0], (lo, hi)
                assert t.lo[0] <= min(np.tan(lo), np.tan(hi)) and max(np.tan(lo), np.tan(hi)) <= t.hi[0], (lo, hi)
    t = Interval(np.array([half_pi]), np.array([2.0])).tan()
    assert np.isinf(t.lo[0]) and np.isinf(t.hi[0])
    # inside one branch it stays tight, up to the last float before the pole
    t = Interval(np.array([1.0]), np.array([half_pi])).tan()
    assert t.lo[0] <= np.tan(1.0) < t.hi[0] and t.hi[0] < 1.7e16


def test_known_exact_ranges():
    s = Interval(np.array([0.0]), np.array([np.pi])).sin()
    assert s.hi[0] == 1.0 and -1e-15 < s.lo[0] <= 0.0
    c = Interval(np.array([-1.0]), np.array([1.0])).cos()
    assert c.hi[0] == 1.0 and np.cos(1.0) - 1e-14 < c.lo[0] < np.cos(1.0)
    c2 = Interval(np.array([3.0]), np.array([3.3])).cos()          # contains the minimum at pi
    assert c2.lo[0] == -1.0
    c3 = Interval(np.array([0.5]), np.array([0.5 + 7.0])).cos()     # wider than 2 pi
    assert c3.lo[0] == -1.0 and c3.hi[0] == 1.0
    sq = Interval(np.array([-2.0]), np.array([3.0])).sqr()
    assert sq.lo[0] == 0.0 and 9.0 <= sq.hi[0] < 9.0 + 1e-14
    prod = Interval(np.array([-2.0]), np.array([3.0])) * Interval(np.array([-5.0]), np.array([4.0]))
    assert -15.0 - 1e-13 < prod.lo[0] <= -15.0 and 12.0 <= prod.hi[0] < 12.0 + 1e-13
    # the dependency effect: x - x is not 0 but [lo - hi, hi - lo]
    x = Interval(np.array([1.0]), np.array([2.0]))
    d = x - x
    assert d.lo[0] <= -1.0 and d.hi[0] >= 1.0
    inv = Interval(np.array([-1.0]), np.array([1.0])).reciprocal()
    assert np.isinf(inv.lo[0]) and np.isinf(inv.hi[0])


def test_outward_rounding_contains_the_exact_rational_result():
    a = RNG.normal(0, 1, 200)
    b = RNG.normal(0, 1, 200)
    for op, exact in ((np.add, lambda p, q: p + q), (np.multiply, lambda p, q: p * q),
                      (np.subtract, lambda p, q: p - q)):
        res = op(Interval.point(a), Interval.point(b))
        for i in range(a.size):
            e = exact(Fraction(a[i]), Fraction(b[i]))
            assert Fraction(res.lo[i]) <= e <= Fraction(res.hi[i])
            assert res.lo[i] < res.hi[i]          # strictly widened: rounding can never be missed
    r = Interval.point([3.0]).sqrt()
    assert Fraction(r.lo[0]) ** 2 <= 3 <= Fraction(r.hi[0]) ** 2
    q = Interval.point([1.0]) / Interval.point([3.0])
    assert Fraction(q.lo[0]) <= Fraction(1, 3) <= Fraction(q.hi[0])


def test_monotone_enclosure_and_scalar_multiplication():
    x = Interval(np.array([0.1, 0.5]), np.array([0.2, 0.9]))
    m = monotone(np.exp, x)
    assert np.all(m.lo <= np.exp(x.lo)) and np.all(m.hi >= np.exp(x.hi))
    md = monotone(lambda v: -v, x, increasing=False)
    assert np.all(md.lo <= -x.hi) and np.all(md.hi >= -x.lo)
    neg = x * -2.0
    assert np.all(neg.lo <= -2 * x.hi) and np.all(neg.hi >= -2 * x.lo)
    zero = Interval(np.array([-np.inf]), np.array([np.inf])) * 0.0
    assert zero.lo[0] == 0.0 and zero.hi[0] == 0.0


# --- the transcendental enclosures against a correctly rounded reference (mpmath at 200 bits), not libm ---
mpmath = pytest.importorskip('mpmath')
MP = mpmath.mp.clone() if hasattr(mpmath.mp, 'clone') else mpmath.mp
MP.prec = 200
REFERENCE = {'sin': MP.sin, 'cos': MP.cos, 'tan': MP.tan, 'arcsin': MP.asin, 'arccos': MP.acos, 'arctan': MP.atan,
             'exp': MP.exp, 'log': MP.log, 'sqrt': MP.sqrt}


def _hard_points(fn):
    """Arguments where libm is most likely to be off: near the multiples of pi/2 (tan's poles and the zeros
    of sin and cos), huge arguments (argument reduction), tiny ones, and the ends of each domain."""
    rng = np.random.default_rng(99)
    k = np.concatenate([np.arange(1, 40), rng.integers(1, 10 ** 6, 60)])
    m = k * (np.pi / 2)
    near_half_pi = np.concatenate([m, np.nextafter(m, 0), np.nextafter(m, 9e9)])
    if fn in ('sin', 'cos'):
        return np.concatenate([near_half_pi, -near_half_pi, [1e-300, 5e-324, 1e5, 1e10, 1e15, 1e22, 2.0 ** 60],
                               rng.uniform(-50, 50, 200)])
    if fn == 'tan':
        return np.concatenate([np.nextafter(np.pi / 2, 0) - np.arange(5) * 1e-15, [1e-300, 0.7853981633974483, 1.5],
                               rng.uniform(-1.57, 1.57, 200), near_half_pi[:60] % np.pi - np.pi / 2])
    if fn in ('arcsin', 'arccos'):
        return np.concatenate([[-1.0, 1.0, np.nextafter(1.0, 0), np.nextafter(-1.0, 0), 0.5, -0.5, 1e-300, 0.0],
                               1 - 10.0 ** -rng.uniform(1, 16, 50), rng.uniform(-1, 1, 200)])
    if fn == 'arctan':
        return np.concatenate([[0.0, 1e-300, 1.0, -1.0, 1e300, -1e300, 1e16], rng.normal(0, 10, 200)])
    if fn == 'exp':
        return np.concatenate([[0.0, 1e-300, -745.0, 709.0, 709.78, -708.0, 1e-16], rng.uniform(-700, 700, 200)])
    if fn == 'log':
        return np.concatenate([[1.0, np.nextafter(1.0, 2), np.nextafter(1.0, 0), 5e-324, 1e-300, 1e300, 2.0],
                               1 + rng.uniform(-1e-12, 1e-12, 50), 10.0 ** rng.uniform(-300, 300, 200)])
    return np.concatenate([[0.0, 5e-324, 1e-300, 1e300, 2.0, 3.0], 10.0 ** rng.uniform(-300, 300, 200)])


@pytest.mark.parametrize('fn', sorted(REFERENCE))
def test_point_enclosures_contain_the_correctly_rounded_value(fn):
    x = _hard_points(fn)
    res = getattr(Interval.point(x), fn)()
    for xi, lo, hi in zip(x, res.lo, res.hi, strict=True):
        exact = REFERENCE[fn](MP.mpf(float(xi)))            # the float argument converts exactly
        assert MP.mpf(float(lo)) <= exact <= MP.mpf(float(hi)), (fn, float(xi), float(lo), float(hi), exact)
        # and the enclosure is tight: a few ulp (the 2^-48 relative margin), not a vacuous bound
        if fn not in ('sin', 'cos') or abs(xi) < 1e8:
            assert float(hi) - float(lo) <= 2.0 ** -46 * abs(float(exact)) + 1e-320, (fn, float(xi))


@pytest.mark.parametrize('fn', ['sin', 'cos'])
def test_periodic_enclosures_contain_the_true_extrema(fn):
    """Wide intervals: the true range, computed with mpmath's pi (the float pi is 1.2e-16 below it), is inside
    the enclosure; intervals that end just short of an extremum are not widened to +-1."""
    rng = np.random.default_rng(5)
    a = rng.uniform(-20, 20, 300)
    b = a + rng.exponential(1.5, 300)
    res = getattr(Interval(a, b), fn)()
    f = REFERENCE[fn]
    shift = MP.pi / 2 if fn == 'sin' else MP.mpf(0)
    for lo_x, hi_x, lo, hi in zip(a, b, res.lo, res.hi, strict=True):
        A, B = MP.mpf(float(lo_x)), MP.mpf(float(hi_x))
        vals = [f(A), f(B)]
        k0 = int(MP.floor((A - shift) / MP.pi))
        for k in range(k0, k0 + 20):                         # extrema at shift + k pi inside [A, B]
            t = shift + k * MP.pi
            if A <= t <= B:
                vals.append(f(t))
        assert MP.mpf(float(lo)) <= min(vals) and max(vals) <= MP.mpf(float(hi))
    # an interval ending 1e-6 before the maximum of cos at 2 pi is not widened to the maximum
    two_pi = float(2 * MP.pi)
    near = Interval(np.array([two_pi - 0.5]), np.array([two_pi - 1e-6])).cos()
    assert near.hi[0] < 1.0 and near.hi[0] >= float(MP.cos(MP.mpf(two_pi - 1e-6)))


@pytest.mark.parametrize('fn', ['tan', 'arcsin', 'arccos', 'arctan', 'exp', 'log', 'sqrt'])
def test_monotone_enclosures_of_wide_intervals_contain_the_true_range(fn):
    pts = np.sort(_hard_points(fn))
    pts = pts[np.isfinite(pts)]
    if fn == 'tan':
        pts = pts[np.abs(pts) < 1.57]
    a, b = pts[:-1], pts[1:]
    res = getattr(Interval(a, b), fn)()
    f = REFERENCE[fn]
    for lo_x, hi_x, lo, hi in zip(a, b, res.lo, res.hi, strict=True):
        ends = [f(MP.mpf(float(lo_x))), f(MP.mpf(float(hi_x)))]
        assert MP.mpf(float(lo)) <= min(ends) and max(ends) <= MP.mpf(float(hi)), (fn, lo_x, hi_x)


def test_outward_rounding_steps_are_nextafter_bit_for_bit():
    """down/up step on the integer view of the floats; they must equal np.nextafter everywhere, the special
    values (signed zeros, infinities, NaN, subnormals, the largest float) and any array layout included."""
    from gpr_kinematics.workspace.interval import down, up
    rng = np.random.default_rng(17)
    x = rng.normal(size=50000) * 10.0 ** rng.integers(-320, 308, 50000)
    special = [0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -5e-324, 1.0, -1.0, np.finfo(float).max,
               -np.finfo(float).max, np.finfo(float).tiny, -np.finfo(float).tiny]
    x[:len(special)] = special
    with np.errstate(all='ignore'):
        for step, towards in ((down, -np.inf), (up, np.inf)):
            ref = np.nextafter(x, towards)
            assert np.array_equal(step(x), ref, equal_nan=True)
            assert np.array_equal(step(x.reshape(250, 200).T), ref.reshape(250, 200).T, equal_nan=True)
            assert np.array_equal(step(x[::7]), ref[::7], equal_nan=True)
            for v in special:
                assert np.array_equal(step(np.float64(v)), np.nextafter(v, towards), equal_nan=True)


@pytest.mark.parametrize('fn', ['sin', 'cos'])
def test_extrema_next_to_large_arguments_are_not_missed(fn):
    """Intervals two ulp wide around the maxima and minima of sin and cos at |t| from 1e4 to 1e15, found with
    mpmath's pi: the reduction ``(t - shift) / 2 pi`` in floats is off by about |t| 1e-16 there (the float pi/2 and
    2 pi are not the real ones), far more than a fixed 1e-12 pad, so only a pad that grows with |t| keeps the
    extremum; the true range (the extremum, +-1, included) must lie in the enclosure."""
    f = REFERENCE[fn]
    shift = MP.pi / 2 if fn == 'sin' else MP.mpf(0)
    ks = np.unique(np.concatenate([np.logspace(3, 14, 300).astype(np.int64), [837677640068, 888623816274]]))
    lows, highs, extrema = [], [], []
    for k in ks:
        for sign in (1, -1):
            for half in (0, MP.mpf(1) / 2):                     # cos(t - shift): max at 2 pi k, min at + pi
                t = sign * (shift + (k + half) * 2 * MP.pi)     # an extremum, +-1
                below = float(t)
                if MP.mpf(below) > t:
                    below = np.nextafter(below, -np.inf)
                lows.append(below)
                highs.append(np.nextafter(np.nextafter(below, np.inf), np.inf))
                extrema.append(f(t))
    res = getattr(Interval(np.array(lows), np.array(highs)), fn)()
    for a, b, e, lo, hi in zip(lows, highs, extrema, res.lo, res.hi, strict=True):
        vals = [f(MP.mpf(a)), f(MP.mpf(b)), e]
        assert MP.mpf(float(lo)) <= min(vals) and max(vals) <= MP.mpf(float(hi)), (fn, a, b, e, lo, hi)


def test_integer_powers_enclose_the_exact_rational_powers():
    """``x ** n`` for n other than 2 multiplies n times: the exact range of t^n over [lo, hi] (endpoints, and 0 for
    an even n when the interval holds 0), in exact rationals, lies in the enclosure; ``x ** 0`` is exactly 1, and
    only an integer n >= 0 is accepted."""
    from gpr_kinematics.errors import InputError
    lo = np.array([-1.5, 0.5, -2.0, 0.1, -0.3, 1.0 / 3.0])
    hi = np.array([0.7, 3.0, -0.25, 0.1, -0.3, 2.0 / 3.0])
    x = Interval(lo, hi)
    for n in (1, 3, 4, 5):
        p = x ** n
        for a, b, plo, phi in zip(lo, hi, p.lo, p.hi, strict=True):
            vals = [Fraction(a) ** n, Fraction(b) ** n] + ([Fraction(0)] if n % 2 == 0 and a <= 0 <= b else [])
            assert Fraction(plo) <= min(vals) and max(vals) <= Fraction(phi), (n, a, b)
            assert phi - plo <= 4 * (max(abs(a), abs(b)) + 1) ** n    # a bound, not the whole line
    one = x ** 0
    assert np.all(one.lo == 1.0) and np.all(one.hi == 1.0)
    for bad in (-1, 2.5):
        with pytest.raises(InputError, match='integer n >= 0'):
            x ** bad


def test_reciprocals_of_one_signed_intervals_are_tight_and_straddling_ones_the_whole_line():
    """``1/x`` is decreasing on each side of 0: over a negative or a positive interval its range is
    ``[1/hi, 1/lo]``, checked in exact rationals and to a few ulp; over an interval that reaches 0 (at an end or
    inside) the range is unbounded on the side(s) where 0 is approached."""
    lo = np.array([-2.0, -4.0, 0.5, 3.0, -1e-3, 1e-300])
    hi = np.array([-1.0, -0.5, 2.0, 7.0, -1e-6, 3.0])
    r = Interval(lo, hi).reciprocal()
    for a, b, rlo, rhi in zip(lo, hi, r.lo, r.hi, strict=True):
        exact_lo, exact_hi = 1 / Fraction(b), 1 / Fraction(a)
        assert Fraction(rlo) <= exact_lo and exact_hi <= Fraction(rhi), (a, b)
        assert float(exact_lo) - rlo <= 4e-16 * abs(float(exact_lo)), (a, b)
        assert rhi - float(exact_hi) <= 4e-16 * abs(float(exact_hi)), (a, b)
    q = Interval.point(np.array([1.0])) / Interval(np.array([-3.0]), np.array([-1.5]))     # [-2/3, -1/3]
    assert Fraction(q.lo[0]) <= Fraction(-2, 3) < Fraction(-1, 3) <= Fraction(q.hi[0]) and q.hi[0] < 0.0
    # ranges reaching 0: [1/2, inf) over (0, 2], (-inf, -1/2] over [-2, 0), both over [-1, 1] without 0
    for a, b, need_lo, need_hi in ((0.0, 2.0, 0.5, np.inf), (-2.0, 0.0, -np.inf, -0.5), (-1.0, 1.0, -np.inf, np.inf)):
        w = Interval(np.array([a]), np.array([b])).reciprocal()
        assert w.lo[0] <= need_lo and need_hi <= w.hi[0], (a, b)


def test_midpoint_membership_and_hull():
    """The interval helpers: the midpoint of [lo, hi], closed membership (both ends in, the next floats out), the
    hull of two intervals (the smallest interval holding both)."""
    x = Interval(np.array([1.0, -3.0, -1.0]), np.array([3.0, -1.0, 2.0]))
    assert x.mid.tolist() == [2.0, -2.0, 0.5] and x.width.tolist() == [2.0, 2.0, 3.0]
    assert x.contains(x.lo).all() and x.contains(x.hi).all() and x.contains(x.mid).all()
    assert not x.contains(np.nextafter(x.lo, -np.inf)).any() and not x.contains(np.nextafter(x.hi, np.inf)).any()
    h = x.hull(Interval(np.array([2.0, -5.0, -0.5]), np.array([4.0, -4.0, 0.5])))
    assert h.lo.tolist() == [1.0, -5.0, -1.0] and h.hi.tolist() == [4.0, -1.0, 2.0]


def test_constants_given_as_rounded_floats_are_enclosed():
    """``Interval.const`` encloses the real number a float was rounded from (one ulp either side): the decimals
    0.1, 0.2, 1/3 written as 0.3333333333333333 and 2.675 in exact rationals; pi, sqrt(3)/2 and the cosines and
    sines of the float azimuths 2 pi/3 and 4 pi/3 (as the GPR model takes them from libm) against mpmath; the
    enclosure is two ulp wide, not wider."""
    for text in ('0.1', '0.2', '0.3333333333333333', '2.675', '-7.1', '1e-5'):
        c = Interval.const(float(text))
        assert Fraction(float(c.lo)) < Fraction(text) < Fraction(float(c.hi)), text
        assert float(c.hi) == np.nextafter(np.nextafter(float(c.lo), np.inf), np.inf)
    pairs = [(np.pi, MP.pi), (np.sqrt(3.0) / 2, MP.sqrt(3) / 2)]
    for a in (2 * np.pi / 3, 4 * np.pi / 3):
        pairs += [(np.cos(a), MP.cos(MP.mpf(a))), (np.sin(a), MP.sin(MP.mpf(a)))]
    for value, exact in pairs:
        c = Interval.const(value)
        assert MP.mpf(float(c.lo)) < exact < MP.mpf(float(c.hi)), value
    h = sqrt3_over_2()                                     # the float sqrt(3) is correctly rounded: halved exactly
    assert MP.mpf(float(h.lo)) < MP.sqrt(3) / 2 < MP.mpf(float(h.hi))
    assert float(h.hi) == np.nextafter(np.nextafter(float(h.lo), 1.0), 1.0)


def test_inverse_trigonometric_ranges_are_clipped_to_the_first_float_beyond_the_real_ends():
    """arctan over the whole line and arcsin over [-1, 1] reach +-pi/2, arccos over [-1, 1] reaches pi; the floats
    pi/2 and pi lie below the real ones, so the tightest certified ends are the next floats up (down for -pi/2),
    and the enclosures clip to exactly those."""
    half = np.nextafter(np.pi / 2, np.inf)
    assert MP.mpf(float(np.pi / 2)) < MP.pi / 2 < MP.mpf(float(half))       # the tightest float above
    whole = Interval(np.array([-np.inf, -1e300]), np.array([np.inf, 1e300])).arctan()
    assert whole.lo.tolist() == [-half, -half] and whole.hi.tolist() == [half, half]
    s = Interval(np.array([-1.0]), np.array([1.0])).arcsin()
    assert s.lo[0] == -half and s.hi[0] == half
    c = Interval(np.array([-1.0]), np.array([1.0])).arccos()
    assert c.lo[0] == 0.0 and c.hi[0] == np.nextafter(np.pi, np.inf) and MP.mpf(float(c.hi[0])) > MP.pi

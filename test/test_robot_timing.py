"""Time parameterisation: the synchronised trapezoid against an independent integration, the limits held by
finite differences of the samples, requested durations, refusals; on a curved path the shortest profile within the
chain-rule bounds, never longer for higher limits."""
import numpy as np
import pytest
from gpr_kinematics.errors import InputError, LimitError
from gpr_kinematics.robot.timing import evaluate, parameterise, profile, sample, shortest, unit_profiles

V_LIM = np.array([0.15, 3.0, 4.0])
A_LIM = np.array([0.6, 12.0, 16.0])
NAMES = ('rod', 'shoulder', 'elbow')


def _brute_force_time(D, v, a, dt=2e-5):
    """Integrate s'' = +A / 0 / -A with |D_k s'| <= v_k, |D_k s''| <= a_k until s reaches 1 (independent): brake as
    soon as braking from the speed after one more step would overshoot."""
    aD = np.abs(D)
    m = aD > 0
    V, A = np.min(v[m] / aD[m]), np.min(a[m] / aD[m])
    s, ds, t = 0.0, 0.0, 0.0
    while s < 1.0 - 1e-12 and t < 100.0:
        up = min(ds + A * dt, V)
        if s + 0.5 * (ds + up) * dt + up * up / (2 * A) <= 1.0:
            new = up
        else:  # brake so as to stop at s = 1
            new = max(np.sqrt(max(2 * A * (1.0 - s), 0.0)) - A * dt, 0.0) if ds > 0 else 0.0
            new = min(new, ds)
        s += 0.5 * (ds + new) * dt
        ds = new
        t += dt
        if ds == 0.0 and s < 1.0 - 1e-12 and t > dt:
            ds = min(A * dt, np.sqrt(2 * A * (1.0 - s)))
    return t


@pytest.mark.parametrize('D', [[0.01, 0.0, 0.0], [0.0, 2.0, -1.0], [0.3, 0.2, 0.1], [0.001, 1e-3, 0.0]])
def test_shortest_time_matches_an_integration(D):
    D = np.array([D])
    V, A, T = shortest(D, V_LIM, A_LIM)
    assert T[0] == pytest.approx(_brute_force_time(D[0], V_LIM, A_LIM), rel=1e-3)


def test_samples_respect_the_limits_and_hit_the_waypoints():
    P = np.array([[0.2, 0.0, 0.0], [0.3, 1.5, -2.0], [0.3, 1.5, -2.0], [0.29, -1.0, 0.5]])
    dwell = np.array([0.2, 0.5, 0.0, 0.3])
    t = parameterise(P, V_LIM, A_LIM, np.array([np.nan, np.nan, np.nan, 5.0]), dwell, NAMES, ('a', 'b', 'c', 'd'))
    np.testing.assert_allclose(t.depart - t.arrive, dwell, atol=1e-15)
    np.testing.assert_allclose(t.arrive[1:] - t.depart[:-1], t.duration, atol=1e-15)
    assert t.duration[1] == 0.0 and t.duration[2] == pytest.approx(5.0)
    rate = 2000.0
    s = sample(t, rate)
    assert s.time[-1] == pytest.approx(t.total)
    for i in range(4):  # at the arrival instants the joints are at the waypoints
        k = np.argmin(np.abs(s.time - t.arrive[i]))
        if abs(s.time[k] - t.arrive[i]) < 1e-12:
            np.testing.assert_allclose(s.positions[k], P[i], atol=1e-12)
    dt = np.diff(s.time)
    v = np.diff(s.positions, axis=0) / dt[:, None]
    acc = np.diff(v, axis=0) / dt[1:, None]
    assert np.all(np.abs(v) <= V_LIM * (1 + 1e-9))
    assert np.all(np.abs(acc[np.abs(dt[1:] - 1 / rate) < 1e-9]) <= A_LIM * (1 + 2e-3) + 1e-6)
    vu, au = t.usage()
    assert vu.max() == pytest.approx(1.0) and au.max() == pytest.approx(1.0)
    assert np.all(vu <= 1 + 1e-12) and np.all(au <= 1 + 1e-12)
    assert set(s.held[(s.time > t.depart[0] + 1e-9) & (s.time < t.arrive[1] - 1e-9)]) == {-1}
    np.testing.assert_array_equal(np.unique(s.target), [0, 1, 3])  # waypoint 2 is reached in no time


def test_profile_is_a_trapezoid():
    T, V, A = np.array([3.0]), np.array([0.5]), np.array([0.5])  # ta = 1 s, cruise 1 s: 0.25 + 0.5 + 0.25 = 1
    tau = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
    np.testing.assert_allclose(profile(tau, T, V, A), [0, 0.0625, 0.25, 0.5, 0.75, 0.9375, 1.0], atol=1e-15)


def test_a_requested_time_longer_than_needed_slows_the_move():
    P = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]])
    _, _, T_min = shortest(np.diff(P, axis=0), V_LIM, A_LIM)
    t = parameterise(P, V_LIM, A_LIM, np.array([np.nan, 2 * T_min[0]]), np.zeros(2), NAMES, ('a', 'b'))
    assert t.total == pytest.approx(2 * T_min[0])
    assert t.speed[0] * 0.1 < V_LIM[0]
    s = sample(t, 1000.0)
    assert s.positions[-1, 0] == pytest.approx(0.1, abs=1e-15)


def test_too_short_a_time_is_refused_naming_the_joint():
    P = np.array([[0.0, 0.0, 0.0], [0.1, 0.5, 0.0]])
    need = 0.1 / 0.15 + 0.15 / 0.6  # the rod: accelerate, cruise, brake
    with pytest.raises(LimitError, match=rf'^the move into b needs at least {need:.4g} s within the limits, time = '
                                         rf'0.5 s is too short \(rod alone needs {need:.4g} s at 0.15 m/s and 0.6 '
                                         r'm/s\^2\)$'):
        parameterise(P, V_LIM, A_LIM, np.array([np.nan, 0.5]), np.zeros(2), NAMES, ('a', 'b'))


def test_the_joint_named_in_a_too_short_time_is_timed_with_its_jerk():
    """A joint of 3.29342 rad at 1.2 rad/s, 2 rad/s^2 and 20 rad/s^3 needs d/v + v/a + a/j = 3.4445 s (an S-curve
    reaching both); 3.4 s was refused naming its trapezoid's 3.345 s, shorter than the time refused."""
    d = 3.29342
    need = d / 1.2 + 1.2 / 2.0 + 2.0 / 20.0
    P = np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, d]])
    v, a, j = np.array([1.0, 1.0, 1.0, 1.2]), np.array([1.0, 1.0, 1.0, 2.0]), np.array([10.0, 10.0, 10.0, 20.0])
    names = ('r1', 'r2', 'r3', 'fa_j1')
    with pytest.raises(LimitError, match=rf'needs at least {need:.4g} s within the limits, time = 3.4 s is too '
                                         rf'short \(fa_j1 alone needs {need:.4g} s at 1.2 rad/s, 2 rad/s\^2 and 20 '
                                         r'rad/s\^3\)$'):
        parameterise(P, v, a, np.array([np.nan, 3.4]), np.zeros(2), names, ('a', 'b'), jerk=j)
    # one joint limited by its speed, one by its acceleration: together they need more than either alone
    P = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
    v, a = np.array([0.8, 100.0, 1.0]), np.array([100.0, 2.0, 1.0])
    alone, together = 2.0 * np.sqrt(1.0 / 2.0), 1.0 / 0.8 + 0.8 / 2.0   # the second joint's triangle; V 0.8, A 2
    with pytest.raises(LimitError, match=rf'needs at least {together:.4g} s within the limits, time = 1.5 s is too '
                                         rf'short \(no joint alone needs as long, the slowest: shoulder alone needs '
                                         rf'{alone:.4g} s at 100 m/s and 2 m/s\^2; their limits together, on this '
                                         r'path, need more\)$'):
        parameterise(P, v, a, np.array([np.nan, 1.5]), np.zeros(2), NAMES, ('a', 'b'))


@pytest.mark.parametrize('rate, pattern', [(0.0, r'rate = 0.0 is invalid'), (float('nan'), 'rate = nan is invalid'),
                                           (1e5, r'rate = 100000.0 is invalid; allowed: 0.1 <= rate <= 5000 Hz'),
                                           (1e-300, r'rate = 1e-300 is invalid'), (5001, 'rate = 5001 is invalid')])
def test_bad_rates(rate, pattern):
    t = parameterise(np.zeros((2, 3)), V_LIM, A_LIM, np.array([np.nan, np.nan]), np.ones(2), NAMES, ('a', 'b'))
    with pytest.raises(InputError, match=pattern):
        sample(t, rate)


def test_too_many_samples_are_refused():
    t = parameterise(np.zeros((2, 3)), V_LIM, A_LIM, np.array([np.nan, np.nan]), np.array([0.0, 1e6]), NAMES,
                     ('a', 'b'))
    with pytest.raises(InputError, match=r'the program lasts 1e\+06 s: at 5000 Hz that is 5000000001 samples; '
                                         r'allowed: at most 200000; lower the rate'):
        sample(t, 5000.0)
    long = parameterise(np.zeros((2, 3)), V_LIM, A_LIM, np.array([np.nan, np.nan]), np.array([0.0, 3e6]), NAMES,
                        ('a', 'b'))
    with pytest.raises(InputError, match=r'at 0\.1 Hz that is 300001 samples; allowed: at most 200000; 0\.1 Hz is the '
                                         r'lowest rate: split the program into shorter ones$'):   # not "lower the rate"
        sample(long, 0.1)


# The cell program's straight entry into pm1 (arm2's shoulder, elbow and hand): G1, G2, G3 = the bounds of
# max |dP/ds|, |d^2P/ds^2|, |d^3P/ds^3| over the line (robot/line_bounds.py), and the arm's limits.
LINE = np.array([[2.0764, 2.2932, 1.938], [2.3281, 4.5967, 2.2686], [15.9411, 30.7332, 14.7921]])
ARM = {'velocity': np.array([1.5, 2.0, 2.5]), 'acceleration': np.array([2.0, 2.5, 3.0]),
       'jerk': np.array([20.0, 24.0, 30.0])}


def _entry(velocity, acceleration, jerk):
    """A joint-space move, then the straight entry (its gains given), timed within the limits; the limits kept."""
    P = np.array([[0.0, 0.0, 0.0], [3.0, -2.0, 1.5], [3.1, -1.9, 1.4]])
    gains = (np.vstack([np.abs(P[1] - P[0]), LINE[0]]), np.vstack([np.zeros(3), LINE[1]]),
             np.vstack([np.zeros(3), LINE[2]]))
    t = parameterise(P, velocity, acceleration, np.full(3, np.nan), np.zeros(3), NAMES, ('a', 'b', 'c'), jerk, gains)
    v, a, j = t.peaks()
    assert np.all(v <= velocity * (1 + 1e-12)) and np.all(a <= acceleration * (1 + 1e-12))
    assert np.all(j <= jerk * (1 + 1e-12))
    return t


@pytest.mark.parametrize('limit', list(ARM))
def test_higher_limits_never_lengthen_a_move(limit):
    """The shortest profile's duration is non-increasing in each limit; scaling time until the chain-rule bounds held
    (``V c``, ``A c^2``, ``J c^3``) made the entry longer for higher accelerations (2.55 s at x2, 3.39 s at x10) and
    speeds (21 s at x10)."""
    durations = []
    for factor in (1.0, 1.5, 2.0, 3.0, 5.0, 10.0, 30.0):
        limits = dict(ARM, **{limit: ARM[limit] * factor})
        durations.append(_entry(**limits).duration)
    d = np.array(durations)
    assert np.all(d[1:] <= d[:-1] * (1 + 1e-12)), d
    assert d[-1].sum() < d[0].sum()


@pytest.mark.parametrize('scale', [(1.0, 1.0, 1.0), (1.0, 10.0, 1.0), (10.0, 1.0, 1.0), (1.0, 1.0, 10.0),
                                   (0.3, 3.0, 0.5)])
def test_a_curved_move_takes_the_shortest_profile_within_the_bounds(scale):
    """No cruise speed, acceleration and jerk (a 300 x 300 grid, the largest jerk the bounds leave) that keeps
    ``G1 V <= v``, ``G1 A + G2 V^2 <= a``, ``G1 J + 3 G2 V A + G3 V^3 <= j`` gives a shorter unit move."""
    v, a, j = (ARM[k] * f for k, f in zip(ARM, scale, strict=True))
    took = _entry(v, a, j).duration[1]
    G1, G2, G3 = LINE
    V = np.linspace(1e-3, 1.0, 300)[:, None, None] * np.min(v / G1)
    A = np.linspace(1e-3, 1.0, 300)[None, :, None] * np.min((a - G2 * V ** 2) / G1, axis=2, keepdims=True)
    J = np.min((j - 3 * G2 * V * A - G3 * V ** 3) / G1, axis=2)
    ok = (A[..., 0] > 0) & (J > 0)
    Vg, Ag = np.broadcast_to(V[..., 0], J.shape)[ok], np.broadcast_to(A[..., 0], J.shape)[ok]
    grid = unit_profiles(Vg, Ag, J[ok]).T
    assert took <= grid.min() * (1 + 1e-12)
    assert took > 0.98 * grid.min()


@pytest.mark.parametrize('scale', [(1.0, 1.0, 1.0), (1.0, 10.0, 1.0), (0.3, 3.0, 0.5)])
def test_a_curved_moves_jerk_bound_reaches_the_limit_it_was_timed_to(scale):
    """The straight entry's jerk, ``G1 J + 3 G2 V A + G3 V^3`` (chain rule of ``P(s(t))'''``:
    ``P' s''' + 3 P'' s' s'' + P''' s'^3``), is what its profile was timed to: one joint's bound is its jerk limit
    exactly (the shortest move takes the largest jerk the bounds leave), none above."""
    v, a, j = (ARM[k] * f for k, f in zip(ARM, scale, strict=True))
    jerk = _entry(v, a, j).peaks()[2][1]
    assert float(np.max(jerk / j)) == pytest.approx(1.0, rel=1e-12)


def test_a_time_a_millionth_short_is_refused_and_the_least_time_is_kept():
    """The rod's move of 0.1 m needs ``0.1 / 0.15 + 0.15 / 0.6 = 0.91667`` s: asked in 1e-6 less it is refused (the
    move would take its least time, not the one asked), asked in exactly that it takes it."""
    P = np.array([[0.0, 0.0, 0.0], [0.1, 0.5, 0.0]])
    need = 0.1 / 0.15 + 0.15 / 0.6
    with pytest.raises(LimitError, match=r'^the move into b needs at least 0.9167 s within the limits, time = '):
        parameterise(P, V_LIM, A_LIM, np.array([np.nan, need * (1.0 - 1e-6)]), np.zeros(2), NAMES, ('a', 'b'))
    t = parameterise(P, V_LIM, A_LIM, np.array([np.nan, need]), np.zeros(2), NAMES, ('a', 'b'))
    assert t.total == pytest.approx(need, rel=1e-12)


def test_the_corners_are_where_the_jerk_changes():
    """An S-curve move of the arm (its jerk limits, after a dwell of 0.3 s) has six corners, where ``s'''`` changes
    between ``+-J`` and 0: found at 10 us from the third differences of ``s`` sampled densely (independent of the
    profile's phases), they are :meth:`Timing.corners` but the waypoints' instants (the move's ends), to 20 us."""
    P = np.array([[0.0, 0.0, 0.0], [0.0, 2.0, -1.0]])
    t = parameterise(P, ARM['velocity'], ARM['acceleration'], np.full(2, np.nan), np.array([0.3, 0.0]), NAMES,
                     ('a', 'b'), ARM['jerk'])
    dt = 1e-5
    times = np.arange(t.depart[0] - 0.01, t.total + 0.01, dt)
    _, _, dds = evaluate(t.profiles, np.zeros(times.size, dtype=np.int64), times - t.depart[0])
    jerk = np.diff(dds) / dt
    J = float(t.profiles.j[0])
    steps = np.flatnonzero(np.abs(np.diff(jerk)) > 0.5 * J)
    found = times[steps + 1]
    found = found[np.r_[True, np.diff(found) > 10 * dt]]          # one per corner
    corners = t.corners()
    inner = corners[(corners > t.depart[0] + 1e-9) & (corners < t.total - 1e-9)]
    assert found.size == 8 and inner.size == 6       # the move's start and end too, where s''' jumps from 0 to J
    assert np.allclose(found[1:-1], inner, rtol=0.0, atol=2e-5)
    assert found[0] == pytest.approx(t.depart[0], abs=2e-5) and found[-1] == pytest.approx(t.total, abs=2e-5)


def test_a_rate_or_margin_given_as_a_0d_array_is_its_number():
    """rate=np.array(100.) and margin=np.array(0.002) were refused as out of range ('rate = array(100.) is
    invalid'): a 0-d array of a number counts as that number (plain_number), and one out of range is still named."""
    from gpr_kinematics.robot.grid import check_rate
    from gpr_kinematics.safety.clearance import check_numbers

    assert check_rate(np.array(100.0)) == 100.0 and check_rate(np.array(100)) == 100.0
    check_numbers(np.array(0.002), np.array(1e-4), np.array(50.0))
    with pytest.raises(InputError, match=r'^rate = array\(1000000\.\) is invalid; allowed: 0\.1 <= rate <= 5000 Hz'):
        check_rate(np.array(1e6))
    with pytest.raises(InputError, match=r"^rate = array\('100', dtype='<U3'\) is invalid"):
        check_rate(np.array('100'))
    with pytest.raises(InputError, match=r'^margin = array\(5\.\) is invalid; allowed: metres, at least 0 and at '
                                         r'most 1 \(5 mm\? give 0\.005\)$'):
        check_numbers(np.array(5.0), 1e-4, 50.0)

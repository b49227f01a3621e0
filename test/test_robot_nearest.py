"""The nearest rule's parts (robot/nearest.py) against independent computations: the slope and curvature of its
cost against central differences of the cost, the float evaluation of a few points against the numpy one, and the
reach's edges in closed form against the two-link solver (stretched or folded there). Its answers against a dense
sweep of the self-motion: test_robot_inverse.py."""
import numpy as np
import pytest
from gpr_kinematics.robot import nearest
from gpr_kinematics.robot.arm_chain import chain_forward, link_vectors, solve_fixed, wrap_to_limits
from gpr_kinematics.robot.planar_arm import branch_of, branch_sign
from robot_support import make_robot, random_stations, robot_data

JOINTS = ['arm2_shoulder', 'arm2_elbow', 'arm2_wrist', 'arm2_hand']


def _case(joint, n=30, widen=None):
    data = robot_data()
    data['arms'][1]['redundancy'] = {'rule': 'nearest', 'joint': joint, 'reference': [0.3, -1.0, 0.5, 0.2],
                                     'weights': [1.0, 1.0, 2.0, 1.0]}
    for k, j in enumerate(data['arms'][1]['joints']):
        j['zero_offset'] = 0.01 * (k - 1.5)
        if j['name'] == widen:  # a range of more than a turn
            j['lower'], j['upper'] = -5.0, 5.5
    robot = make_robot(data)
    arm = robot.arm('arm2')
    _, _, J = random_stations(robot, 'arm2', n, seed=8)
    _, wafer, heading = chain_forward(arm, J)
    sign = np.array([branch_sign(b) for b in branch_of(arm, J)])
    d, beta = link_vectors(arm)
    return arm, d, beta, wafer, heading, sign


@pytest.mark.parametrize('joint', JOINTS)
def test_slope_and_curvature_are_the_derivatives_of_the_cost(joint):
    arm, d, beta, p, phi, sign = _case(joint)
    k = arm.redundancy.joint
    rows = np.repeat(np.arange(len(p)), 40)
    x = np.tile(np.linspace(arm.joints[k].lower + 0.01, arm.joints[k].upper - 0.01, 40), len(p))
    h = 1e-5
    ev, plus, minus = (nearest._evaluate(arm, d, beta, p, phi, sign, rows, x + e, curvature=True)
                       for e in (0.0, h, -h))
    ok = np.isfinite(ev.cost) & np.isfinite(plus.cost) & np.isfinite(minus.cost)
    assert ok.sum() > 100
    np.testing.assert_allclose(ev.slope[ok], (plus.cost[ok] - minus.cost[ok]) / (2 * h), rtol=1e-4, atol=1e-7)
    np.testing.assert_allclose(ev.curvature[ok], (plus.slope[ok] - minus.slope[ok]) / (2 * h), rtol=1e-3, atol=1e-5)


@pytest.mark.parametrize('joint', JOINTS)
def test_a_few_points_in_floats_equal_the_numpy_evaluation(joint, monkeypatch):
    arm, d, beta, p, phi, sign = _case(joint, 10)
    rows = np.repeat(np.arange(10), 30)
    x = np.tile(np.linspace(-3.0, 3.0, 30), 10)
    monkeypatch.setattr(nearest, 'NEAREST_FLOATS', 0)
    batch = nearest._evaluate(arm, d, beta, p, phi, sign, rows, x, curvature=True)
    monkeypatch.setattr(nearest, 'NEAREST_FLOATS', x.size)
    floats = nearest._evaluate(arm, d, beta, p, phi, sign, rows, x, curvature=True)
    np.testing.assert_array_equal(np.isfinite(floats.cost), np.isfinite(batch.cost))
    ok = np.isfinite(batch.cost)
    np.testing.assert_allclose(floats.cost[ok], batch.cost[ok], rtol=1e-14, atol=0)
    np.testing.assert_allclose(floats.slope[ok], batch.slope[ok], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(floats.curvature[ok], batch.curvature[ok], rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize('joint', JOINTS)
def test_the_reach_edges_stretch_or_fold_the_two_link_sub_chain(joint):
    arm, d, beta, p, phi, sign = _case(joint)
    k = arm.redundancy.joint
    edges = nearest.reach_edges(arm, d, beta, p, phi)
    rows, cols = np.nonzero(np.isfinite(edges))
    assert rows.size > len(p) // 2
    v = edges[rows, cols] + arm.zero_offset[k]
    _, tl = solve_fixed(d, beta, k, v, p[rows], phi[rows], sign[rows])
    gap = np.minimum(np.abs(tl.r - tl.r_max), np.abs(tl.r - tl.r_min))
    assert np.max(gap) < 1e-12


def _sweep_costs(arm, d, beta, p, phi, sign, x, rows):
    """The rule's cost (Redundancy's docstring) of the postures with the held joint at ``x`` for targets ``rows``,
    solved here with the fixed_joint chain (``inf`` where out of reach or beyond a limit)."""
    k, o = arm.redundancy.joint, arm.zero_offset
    chain, tl = solve_fixed(d, beta, k, x + o[k], p[rows], phi[rows], sign[rows])
    theta, violation = wrap_to_limits(chain - o, arm.lower, arm.upper)
    ref, w = np.array(arm.redundancy.reference), np.array(arm.redundancy.weights)
    cost = np.sum(w * ((theta - ref) / (arm.upper - arm.lower)) ** 2, axis=1)
    return np.where(tl.reachable & (np.max(violation, axis=1) <= 0.0), cost, np.inf)


@pytest.mark.parametrize('wide', [None, 'held', 'next'])
@pytest.mark.parametrize('joint', JOINTS)
def test_the_answer_is_the_least_cost_of_a_dense_sweep(joint, wide):
    """The rule's held value against 4001 values of the held joint's range (the fast sibling of test_robot_inverse's
    sweep, on the mount-frame targets): none has a lower cost. Also where a range exceeds a turn ([-5, 5.5] rad for
    the held joint or the next one): its representative jumps from the middle + pi to the middle - pi there, and so
    does the cost; the rule missed such a jump (the elbow held: 0.273 where 0.181 is reached at the jump)."""
    k = JOINTS.index(joint)
    widen = None if wide is None else JOINTS[k] if wide == 'held' else JOINTS[(k + 1) % 4]
    arm, d, beta, p, phi, sign = _case(joint, 12, widen)
    v = nearest.nearest_value(arm, d, beta, p, phi, sign)
    rows = np.arange(len(p))
    best = _sweep_costs(arm, d, beta, p, phi, sign, v, rows)
    lo, hi = arm.joints[k].lower, arm.joints[k].upper
    assert np.all((v >= lo) & (v <= hi)) and np.all(np.isfinite(best))
    grid = np.linspace(lo, hi, 4001)
    sweep = _sweep_costs(arm, d, beta, p, phi, sign, np.tile(grid, len(p)), np.repeat(rows, grid.size))
    assert np.all(best <= sweep.reshape(len(p), grid.size).min(axis=1) + 1e-9)


@pytest.mark.parametrize('joint, posture, pair', [
    ('arm2_shoulder', [0.28973066, -0.55593014, 1.16453349, 1.68586623], (0.0, 0.38125)),
    ('arm2_wrist', [2.060879390724037, -0.15485527034210422, -1.0812513914381368, 2.7902993452066474],
     (0.9375, 1.25)),
])
def test_a_minimum_between_two_slopes_of_one_sign_is_found(joint, posture, pair):
    """The posture's target with ``joint`` held under the rule: the slope of the cost has one sign at the two
    neighbouring samples ``pair`` of the range (positive for the shoulder, negative for the wrist), yet the cost dips
    between them (the cubic through the two ends' costs and slopes says so): the rule's answer lies there, no worse
    than any of 4001 values of the range. The wrist's minimum (1.01682 rad) lies off the cubic's: the slope at the
    cubic's minimum (0.971 rad) is still negative, and the rule answered the sample 0.9375 rad (cost 5.3e-4 above the
    minimum); the cubic's inflection (1.097 rad) brackets it."""
    data = robot_data()
    data['arms'][1]['redundancy'] = {'rule': 'nearest', 'joint': joint,
                                     'reference': [0.3, -1.0, 0.5, 0.2], 'weights': [1.0, 1.0, 2.0, 1.0]}
    arm = make_robot(data).arm('arm2')
    k = arm.redundancy.joint
    J = np.array([posture])
    _, p, phi = chain_forward(arm, J)
    sign = np.array([branch_sign(b) for b in branch_of(arm, J)])
    d, beta = link_vectors(arm)
    ends = nearest._evaluate(arm, d, beta, p, phi, sign, np.zeros(2, dtype=np.intp), np.array(pair))
    assert abs(np.sum(np.sign(ends.slope))) == 2 and np.all(np.isfinite(ends.cost))
    v = nearest.nearest_value(arm, d, beta, p, phi, sign)
    assert pair[0] < v[0] < pair[1]
    grid = np.linspace(arm.joints[k].lower, arm.joints[k].upper, 4001)
    sweep = _sweep_costs(arm, d, beta, p, phi, sign, grid, np.zeros(grid.size, dtype=np.intp))
    assert _sweep_costs(arm, d, beta, p, phi, sign, v, np.zeros(1, dtype=np.intp))[0] <= sweep.min() + 1e-12



def test_a_minimum_within_a_grid_step_of_the_reach_edge_is_found():
    """The wrist held: its run of feasible postures ends at the sub-chain's reach edge 0.7591 rad, where the slope is
    infinite; the least cost (0.158048 at 0.683935 rad) lies between it and the grid's sample 0.625 rad, 0.075 rad
    inside the edge (a grid step is 0.3125 rad). The scan from the edge finds that minimum, not the edge's cost
    (0.158345): the rule's answer is the best of 200001 values of the range, to their spacing."""
    data = robot_data()
    data['arms'][1]['redundancy'] = {'rule': 'nearest', 'joint': 'arm2_wrist', 'reference': [0.3, -1.0, 0.5, 0.2],
                                     'weights': [1.0, 1.0, 2.0, 1.0]}
    for k, j in enumerate(data['arms'][1]['joints']):
        j['zero_offset'] = 0.01 * (k - 1.5)
    arm = make_robot(data).arm('arm2')
    J = np.array([[2.696874748357666, -0.3123696257541866, -0.35454204581100957, 1.0748874296179887]])
    _, p, phi = chain_forward(arm, J)
    sign = np.array([branch_sign(b) for b in branch_of(arm, J)])
    d, beta = link_vectors(arm)
    edges = nearest.reach_edges(arm, d, beta, p, phi)[0]
    assert edges[0] == pytest.approx(0.7591016, abs=1e-7)
    v = nearest.nearest_value(arm, d, beta, p, phi, sign)
    assert edges[0] - 0.3125 < 0.625 < v[0] < edges[0]
    grid = np.linspace(-2.5, 2.5, 200001)
    sweep = _sweep_costs(arm, d, beta, p, phi, sign, grid, np.zeros(grid.size, dtype=np.intp))
    assert np.max(grid[np.isfinite(sweep)]) == pytest.approx(edges[0], abs=2.5e-5)   # the run ends at the edge
    cost = _sweep_costs(arm, d, beta, p, phi, sign, v, np.zeros(1, dtype=np.intp))[0]
    assert cost == pytest.approx(0.158048, abs=1e-6) and cost <= sweep.min() + 1e-12
    assert v[0] == pytest.approx(grid[np.argmin(sweep)], abs=2.5e-5) and v[0] == pytest.approx(0.683935, abs=1e-6)
    edge_cost = _sweep_costs(arm, d, beta, p, phi, sign, np.array([edges[0] - 1e-9]), np.zeros(1, dtype=np.intp))
    assert edge_cost[0] == pytest.approx(0.158345, abs=1e-6)

@pytest.mark.parametrize('posture', [
    [1.978576678861983, -0.02525122262367483, -7.205778412996619e-05, -2.1386085802174324],
    [1.6221960174541863, 0.003073179331577863, -0.014972321740847394, -1.7099685225576948]])   # after bisections
def test_a_minimum_beside_a_stretched_sub_chain_is_found_to_its_last_digits(posture):
    """A reviewer's station (the wrist held, elbow and wrist within 0.03 rad of straight): the minimum lies 5.5e-7 rad
    inside the reach's edge, where the cost goes like a square root and Newton's method converges linearly; its stop
    after a step of 1e-7 rad (taken for quadratic convergence) left the held joint 1e-8 rad off, the elbow 1.2e-6 rad,
    the cost 4.1e-12 above a sweep's best. The search goes on until its steps shrink quadratically (the first step
    after bisections too: it stopped 1.3e-8 rad off in the second posture, a mutation audit's)."""
    data = robot_data()
    data['arms'][1]['redundancy'] = {'rule': 'nearest', 'joint': 'arm2_wrist'}
    arm = make_robot(data).arm('arm2')
    J = np.array([posture])
    _, p, phi = chain_forward(arm, J)
    sign = np.array([branch_sign(b) for b in branch_of(arm, J)])
    d, beta = link_vectors(arm)
    v = nearest.nearest_value(arm, d, beta, p, phi, sign)
    grid = v[0] + np.linspace(-3e-8, 3e-8, 6001)
    sweep = _sweep_costs(arm, d, beta, p, phi, sign, grid, np.zeros(grid.size, dtype=np.intp))
    cost = _sweep_costs(arm, d, beta, p, phi, sign, v, np.zeros(1, dtype=np.intp))[0]
    # the cost's rounding near a stretch (acos of nearly 1) is some 1e-15 to 1e-14: the sweep's least value to that
    # (the early stops: 4.1e-12 and 2.4e-11), and its place to a few 1e-10 rad (they: 1e-8 and 1.3e-8)
    assert np.isfinite(cost) and cost <= sweep.min() + 5e-14, (cost - sweep.min(), grid[np.argmin(sweep)] - v[0])
    assert abs(grid[np.argmin(sweep)] - v[0]) <= 1e-9


def _olp_robot():
    """An OLP engineer's arm as arm2 (links 0.32, 0.27, 0.07 m, the wrist and hand ranges cut), and a posture of it."""
    data = robot_data()
    arm_data = data['arms'][1]
    for j, (length, lo, hi) in zip(arm_data['joints'], ((0.32, -3.0, 3.0), (0.27, -2.8, 2.8), (0.07, -1.2, 1.0),
                                                        (0.0, -1.5, 2.0)), strict=True):
        j.update(length=length, lower=lo, upper=hi)
    arm_data['blade'] = {'position': [0.0, 0.0, 0.008], 'yaw': 0.0, 'wafer_centre': [0.14, 0.0, 0.004]}
    arm_data['home'] = [0.0, -2.4, 0.0, 1.5]
    arm_data['redundancy'] = {'rule': 'nearest', 'joint': 'arm2_shoulder', 'reference': [0.5, 1.0, -0.5, -1.0],
                              'weights': [1.0, 0.1, 5.0, 1.0]}
    return make_robot(data), np.array([[-0.819898233, -0.199936284, -0.500690594, -1.189328951]])


def test_two_minima_in_a_run_narrower_than_the_grid_spacing_are_both_tried():
    """On :func:`_olp_robot`'s arm the station is reached for the held shoulder in [-1.13, -0.755] rad only, narrower
    than the range's grid spacing (0.375 rad), where the cost has two minima (at -1.110 and -0.819, a maximum
    between): one bracket held both, its Newton search found the worse (cost 0.0910 against 0.0559). A run of so few
    points gets a grid of its own: the better one, no worse than any of 40,001 values of the range."""
    robot, J = _olp_robot()
    arm = robot.arm('arm2')
    _, p, phi = chain_forward(arm, J)
    sign = np.array([branch_sign(b) for b in branch_of(arm, J)])
    d, beta = link_vectors(arm)
    grid = np.linspace(-3.0, 3.0, 40_001)
    sweep = _sweep_costs(arm, d, beta, p, phi, sign, grid, np.zeros(grid.size, dtype=np.intp))
    run = grid[np.isfinite(sweep)]
    assert -1.14 < run[0] < -1.12 and -0.76 < run[-1] < -0.75 and run[-1] - run[0] < 6.0 / 16
    inside = np.isfinite(sweep[1:-1]) & np.isfinite(sweep[:-2]) & np.isfinite(sweep[2:])
    minima = grid[1:-1][inside & (sweep[1:-1] < sweep[:-2]) & (sweep[1:-1] < sweep[2:])]
    np.testing.assert_allclose(minima, [-1.110, -0.819], atol=2e-3)
    v = nearest.nearest_value(arm, d, beta, p, phi, sign)
    cost = _sweep_costs(arm, d, beta, p, phi, sign, v, np.zeros(1, dtype=np.intp))[0]
    assert abs(v[0] + 0.8199) < 1e-3 and cost <= sweep.min() + 1e-12 and abs(cost - 0.0559) < 1e-4, (v, cost)


def test_no_posture_within_the_limits_is_named_as_such_not_as_out_of_reach():
    """The same station on the other branch: in reach for the held shoulder within [-1.19, -0.76] rad, where the
    hand stays below its lower limit. The refusal said "out of reach ... 0.536 m from the shoulder axis, the arm spans
    [0.2, 0.34] m" (the elbow's sub-chain at the middle of the shoulder's range, the rule's answer where none fits);
    it names the self-motion, the joint, its limit and the branch that fits. Out of reach at every held value: the
    closest miss."""
    import re

    from gpr_kinematics.errors import LimitError
    from gpr_kinematics.robot import robot_forward, solve_stations
    from gpr_kinematics.robot.stations import stations_from_poses

    robot, J = _olp_robot()
    fk = robot_forward(robot, np.array([[0.2, 0.2, 0.2]]), J, 'arm2')
    st = stations_from_poses(fk.wafer.position, fk.wafer.rotation)
    assert np.allclose(solve_stations(robot, st, 'arm2', branch='left').joints, J, atol=1e-8)
    with pytest.raises(LimitError) as err:
        solve_stations(robot, st, 'arm2', branch='right')
    m = re.fullmatch(r'station 0: no posture of arm arm2 within its joint limits reaches the station: it is in reach '
                     r'for its held joint arm2_shoulder within \[(-[\d.]+), (-[\d.]+)\] rad, where arm2_hand stays '
                     r'beyond its lower limit -1.5 rad, by ([\d.]+) rad at the least \(arm2_shoulder = (-[\d.]+) rad; '
                     r'branch right; the other branch stays within the limits\)', str(err.value))
    assert m, str(err.value)
    lo, hi, by, at = (float(g) for g in m.groups())
    assert -1.2 < lo < -1.17 and -0.77 < hi < -0.75 and lo <= at <= hi and 0.0 < by < 1.0
    # independently: the hand over the branch's self-motion, where the sub-chain reaches, never within its limit
    arm = robot.arm('arm2')
    _, p, phi = chain_forward(arm, J)
    d, beta = link_vectors(arm)
    v = np.linspace(lo, hi, 2001)
    chain, tl = solve_fixed(d, beta, 0, v + arm.zero_offset[0], np.repeat(p, v.size, axis=0), np.repeat(phi, v.size),
                            -np.asarray(branch_sign('left')))
    hand, _ = wrap_to_limits(chain - arm.zero_offset, arm.lower, arm.upper)
    assert tl.reachable.all() and np.all(hand[:, 3] < -1.5) and np.min(-1.5 - hand[:, 3]) > by - 2e-3
    far = stations_from_poses(fk.wafer.position + np.array([[1.0, 0.0, 0.0]]), fk.wafer.rotation)
    with pytest.raises(LimitError, match=r'out of reach of arm arm2: at no value of its held joint arm2_shoulder '
                                         r'within \[-3, 3\] rad does it reach the station, the closest misses by '
                                         r'[\d.]+ mm \(branch left'):
        solve_stations(robot, far, 'arm2', branch='left')


def test_a_station_in_reach_only_beyond_a_limit_is_refused_alike_by_both_rules():
    """The example robot's arm2 with its elbow's upper limit narrowed to -1 rad, at the station of the posture
    (0.3, -0.4, 0, 0.4) rad: in reach, but no posture of the self-motion bends the elbow enough. fixed_joint (the
    wrist held at 0) refuses it naming arm2_elbow = -0.4 rad, 0.6 rad beyond its upper limit; nearest named the same
    joint and limit but 'by 0.604 rad at the least' (arm2_shoulder = 0.2999 rad), more than the fixed_joint posture,
    one of its self-motion's, shows: its 3,601 held values miss the edge of the reach at 0.3 rad, where the elbow's
    sub-chain is stretched (the wrist at 0) and the excess least. Both refuse with the same words in a batch and one
    station per call, and both mark it infeasible with check=False (beside a station within the limits, solved)."""
    import re

    from gpr_kinematics.errors import LimitError
    from gpr_kinematics.robot import robot_forward, solve_stations
    from gpr_kinematics.robot.stations import stations_from_poses

    J = np.array([[0.3, -0.4, 0.0, 0.4], [0.3, -1.5, 0.0, 0.4]])
    rods = np.array([[0.2, 0.2, 0.2]] * 2)
    fk = robot_forward(make_robot(robot_data()), rods, J, 'arm2')
    both = stations_from_poses(fk.wafer.position, fk.wafer.rotation)
    robots = {}
    for rule in ('fixed_joint', 'nearest'):
        data = robot_data()
        data['arms'][1]['joints'][1]['upper'] = -1.0
        if rule == 'nearest':
            data['arms'][1]['redundancy'] = {'rule': 'nearest'}   # as benchmarks/bench_robot.py: the shoulder held
        robots[rule] = make_robot(data)
    said = {}
    for rule, robot in robots.items():
        for stations in (both.take([0]), both):
            with pytest.raises(LimitError) as err:
                solve_stations(robot, stations, 'arm2', branch='left')
            said.setdefault(rule, str(err.value).removesuffix(' (and 1 more station)'))
            assert str(err.value).removesuffix(' (and 1 more station)') == said[rule]
        batch = solve_stations(robot, both, 'arm2', branch='left', check=False)
        assert batch.feasible.tolist() == [False, True]
        assert batch.position_error[1] < 1e-9
    assert said['fixed_joint'] == 'station 0: arm2_elbow = -0.4 rad is beyond its upper limit -1 rad by 0.6 rad ' \
                                  '(branch left)'
    m = re.fullmatch(r'station 0: no posture of arm arm2 within its joint limits reaches the station: it is in reach '
                     r'for its held joint arm2_shoulder within \[(-[\d.]+), ([\d.]+)\] rad, where arm2_elbow stays '
                     r'beyond its upper limit -1 rad, by ([\d.]+) rad at the least \(arm2_shoulder = ([\d.]+) rad; '
                     r'branch left\)', said['nearest'])
    assert m, said['nearest']
    lo, hi, by, at = (float(g) for g in m.groups())
    assert (by, at, hi) == (0.6, 0.3, 0.3) and -0.12 < lo < -0.11
    # independently: the elbow over the self-motion (200,001 held shoulders up to 0.3 rad, where the elbow's
    # sub-chain, 0.24 + 0.06 m, is stretched; none beyond reaches): never less than 0.6 rad beyond -1, 0.6 at 0.3
    arm = robots['nearest'].arm('arm2')
    _, p, phi = chain_forward(arm, J[:1])
    d, beta = link_vectors(arm)

    def elbow(v):
        chain, tl = solve_fixed(d, beta, 0, v, np.repeat(p, v.size, axis=0), np.repeat(phi, v.size),
                                np.asarray(branch_sign('left')))
        return chain[tl.reachable, 1], tl.reachable

    assert not elbow(np.linspace(0.3 + 1e-6, 0.4, 1001))[1].any()
    theta, reachable = elbow(np.linspace(-0.2, 0.3, 200_001))
    assert reachable[-1] and -0.12 < np.linspace(-0.2, 0.3, 200_001)[np.argmax(reachable)] < -0.11
    excess = theta + 1.0
    assert excess.min() == pytest.approx(0.6, abs=1e-9) and excess[-1] == pytest.approx(0.6, abs=1e-9)


def test_a_run_of_three_points_is_merged_around_its_middle():
    """A run of three evaluated points gets its 7 points on both sides of the middle one, in order, and none on the
    middle itself where the run is equally spaced (it was evaluated twice, a pair of no width)."""
    arm, d, beta, p, phi, sign = _case('arm2_shoulder', 2)
    rows = np.array([0, 0, 0, 0, 0, 1, 1], dtype=np.intp)
    x = np.array([-3.0, -1.0, 0.0, 1.0, 3.0, -1.0, 1.0])
    cost = np.array([np.inf, 1.0, 1.0, 1.0, np.inf, 1.0, 1.0])
    ev = nearest.Evaluation(cost, np.zeros(7), np.full(7, np.nan))
    R, X, _, E = nearest._narrow_runs(arm, d, beta, p, phi, sign, rows, x, np.zeros(7, dtype=bool), ev)
    first = X[R == 0]
    assert first.tolist() == [-3.0, -1.0, -0.75, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75, 1.0, 3.0]   # 0 once
    assert X[R == 1].tolist() == [-1.0] + [-1.0 + 2.0 * j / 8 for j in range(1, 8)] + [1.0]
    assert E.cost[R == 0][5] == 1.0   # the middle point's own evaluation kept


def test_a_narrow_runs_grid_is_merged_in_order():
    """:func:`nearest._narrow_runs` keeps the points sorted by target, then held value, each with its own
    evaluation (the same as evaluating the merged points afresh)."""
    arm, d, beta, p, phi, sign = _case('arm2_shoulder', 40)
    rows = np.repeat(np.arange(40), 9)
    x = np.tile(np.linspace(-3.0, 3.0, 9), 40)
    ev = nearest._evaluate(arm, d, beta, p, phi, sign, rows, x)
    R, X, reach, E = nearest._narrow_runs(arm, d, beta, p, phi, sign, rows, x, np.zeros(x.size, dtype=bool), ev)
    assert R.size > x.size and not reach.any()
    assert np.all((R[1:] > R[:-1]) | ((R[1:] == R[:-1]) & (X[1:] > X[:-1])))
    again = nearest._evaluate(arm, d, beta, p, phi, sign, R, X)
    np.testing.assert_array_equal(E.cost, again.cost)
    np.testing.assert_array_equal(E.slope, again.slope)


@pytest.mark.parametrize('joint', JOINTS)
def test_at_the_reach_edges_floats_and_numpy_agree_on_feasibility(joint, monkeypatch):
    """At an edge of the reach the sub-chain is stretched or folded to rounding (1e-16 m): both evaluations take it
    within the reach (REACH_SLACK, 1e-12 m), so a posture there within the joint limits has a finite cost either way
    (the rule's answer often lies exactly there)."""
    arm, d, beta, p, phi, sign = _case(joint)
    k = arm.redundancy.joint
    edges = nearest.reach_edges(arm, d, beta, p, phi)
    rows, cols = np.nonzero(np.isfinite(edges))
    x = edges[rows, cols]
    monkeypatch.setattr(nearest, 'NEAREST_FLOATS', 0)
    batch = nearest._evaluate(arm, d, beta, p, phi, sign, rows, x)
    monkeypatch.setattr(nearest, 'NEAREST_FLOATS', x.size)
    floats = nearest._evaluate(arm, d, beta, p, phi, sign, rows, x)
    within = np.max(wrap_to_limits(solve_fixed(d, beta, k, x + arm.zero_offset[k], p[rows], phi[rows],
                                               sign[rows])[0] - arm.zero_offset, arm.lower, arm.upper)[1], axis=1) <= 0
    assert within.sum() > 5
    np.testing.assert_array_equal(np.isfinite(batch.cost), within)
    np.testing.assert_array_equal(np.isfinite(floats.cost), within)

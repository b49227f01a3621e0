"""The bounds the clearance certificate stands on, checked against the exact motion: no body travels farther than
its bound over random intervals (arm joints, platform, straight entries), the closed-form joint-rate bound of a
straight entry, the platform's bound for tilting rods, the separating-axis bound under the library's distance,
and the timing that keeps every joint within its velocity limit between samples."""
import math
from types import SimpleNamespace

import numpy as np
import pytest
from gpr_kinematics.core import forward_batch, inverse_batch
from gpr_kinematics.core.machine import MachineGeometry
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import load_robot
from gpr_kinematics.robot.line_bounds import line_rate_bounds
from gpr_kinematics.robot.plan import joint_limits, line_moves, move_rows, plan_program
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.robot.timing import evaluate
from gpr_kinematics.safety import motion as motion_module
from gpr_kinematics.safety.bodies import box_lower_bound, default_pairs, robot_body_set
from gpr_kinematics.safety.check import wafer_plan
from gpr_kinematics.safety.clearance import TOLERANCE, _Search
from gpr_kinematics.safety.crossing import Intervals
from gpr_kinematics.safety.margin import MARGIN
from gpr_kinematics.safety.motion import (
    LIPSCHITZ,
    PlanMotion,
    drift_bound,
    levers,
    platform_motion,
    platform_state,
    shortest_edge,
)

ROBOT = load_robot()
PLANS = {name: plan_program(ROBOT, load_program(config_path(f'programs/{name}.yaml')))
         for name in ('example_cell_program', 'example_robot_program')}
SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


def _points(body, frames):
    """The corners of a body's bounding box and its centre in the world ``(N, 9, 3)``."""
    p, R = frames[body.frame]
    local = np.vstack([body.position + (SIGNS * body.half) @ body.rotation.T, body.position])
    return p[:, None, :] + np.einsum('nij,kj->nki', R, local)


def _intervals(plan, rng, n):
    """Random intervals within one move or hold (between consecutive knots), some short, some whole."""
    knots = PlanMotion(plan).knots
    k = rng.integers(0, len(knots) - 1, n)
    a, b = knots[k], knots[k + 1]
    u = np.sort(rng.uniform(0, 1, (n, 2)), axis=1)
    u[: n // 4] = [0.0, 1.0]
    return a + u[:, 0] * (b - a), a + u[:, 1] * (b - a)


@pytest.mark.parametrize('name', list(PLANS))
def test_no_body_travels_farther_than_its_bound(name):
    """On 120 random intervals, every corner of every body stays within ``arm + platform`` of where it was at the
    interval's start (41 instants inside), and a body the bounds say translates moves by exactly that vector."""
    plan = PLANS[name]
    motion = PlanMotion(plan)
    bodies = robot_body_set(ROBOT, {a.name: ((0.0, math.inf),) for a in ROBOT.arms})
    lev = levers(ROBOT, bodies)
    t0, t1 = _intervals(plan, np.random.default_rng(19), 120)
    tau = np.linspace(0.0, 1.0, 41)
    times = (t0[:, None] + tau[None] * (t1 - t0)[:, None]).ravel()
    snap = motion.snapshot(times)
    ends = motion.snapshot(np.concatenate([t0, t1]))
    K = t0.shape[0]
    pair = lambda v: np.stack([v[:K], v[K:]], axis=1)   # noqa: E731
    b = motion.bounds(t0, t1, lev, pair(ends.sigma), pair(ends.gamma), pair(ends.displacement))
    checked = 0
    for k, body in enumerate(bodies):
        pts = _points(body, snap.frames).reshape(K, len(tau), 9, 3)
        moved = np.max(np.linalg.norm(pts - pts[:, :1], axis=3), axis=(1, 2))
        bound = b.arm[:, k] + b.platform[:, k]
        assert np.all(moved <= bound + 1e-12), (body.name, np.max(moved - bound))
        shift = b.shift[:, k]
        pure = np.all(np.isfinite(shift), axis=1)
        exact = pts[pure, -1] - pts[pure, 0]
        np.testing.assert_allclose(exact, np.broadcast_to(shift[pure, None, :], exact.shape),
                                   atol=1e-12 + float(np.max(b.platform[pure, k], initial=0.0)))
        checked += int(np.count_nonzero(moved > 0.0))
    assert checked > 200


def test_straight_entry_rate_bound_holds_and_is_tight():
    """The closed-form ``max |dtheta/ds|`` on 400 pieces of each straight line is above the finite-difference
    rate everywhere and within 20 % of it for the joint that moves most."""
    plan = PLANS['example_cell_program']
    _, _, _, slices = joint_limits(ROBOT)
    lines = line_moves(plan.waypoints)
    assert len(lines) == 8
    s = np.linspace(0.0, 1.0, 4001)
    for m in lines:
        arm = plan.waypoints.arm[m + 1]
        cols = slices[ROBOT.arm_names.index(arm)]
        rows = move_rows(ROBOT, plan.waypoints, plan.positions, m, s)[:, cols]
        fd = np.abs(np.diff(rows, axis=0)) / np.diff(s)[:, None]
        edges = np.linspace(0.0, 1.0, 401)
        bound = line_rate_bounds(ROBOT.arm(arm), rows[0], rows[-1], edges[:-1], edges[1:])
        piece = np.minimum((s[:-1] * 400).astype(int), 399)
        assert np.all(fd <= bound[piece] * (1 + 1e-9) + 1e-12)
        j = int(np.argmax(np.max(fd, axis=0)))
        assert np.max(fd[:, j]) > 0.8 * np.max(bound[:, j])


@pytest.mark.parametrize('tilt0, az0, tilt1, az1', [(2.0, 0.0, 2.0, 180.0), (0.0, 0.0, 1.5, 45.0),
                                                    (1.0, 90.0, 0.5, -30.0)])
def test_platform_bound_for_tilting_rods(tilt0, az0, tilt1, az1):
    """Rods moving on a line between two tilts (through the singular configuration for the first): no point of a
    disc of radius 0.8 m about the platform origin, 0.3 m above it, moves farther than ``A + Omega (rho + rbar)``
    over random pieces of the line."""
    cfg = ROBOT.config
    q = inverse_batch(np.array([0.30, 0.32]), np.radians([tilt0, tilt1]), np.radians([az0, az1]), cfg).q
    rng = np.random.default_rng(5)
    s = np.sort(rng.uniform(0, 1, (40, 2)), axis=1)
    s[0] = [0.0, 1.0]
    tau = np.linspace(0, 1, 33)
    S = s[:, :1] + tau[None] * (s[:, 1:] - s[:, :1])
    Q = q[0] + S.reshape(-1, 1) * (q[1] - q[0])
    fk = forward_batch(Q, cfg)
    ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    pts = np.stack([0.8 * np.cos(ang), 0.8 * np.sin(ang), np.full(24, 0.3)], axis=1)
    world = (fk.position[:, None, :] + np.einsum('nij,kj->nki', fk.rotation, pts)).reshape(40, 33, 24, 3)
    moved = np.max(np.linalg.norm(world - world[:, :1], axis=3), axis=(1, 2))
    ends = forward_batch(np.concatenate([q[0] + s[:, :1] * (q[1] - q[0]), q[0] + s[:, 1:] * (q[1] - q[0])]), cfg)
    sigma, gamma, disp = (np.stack([v[:40], v[40:]], axis=1) for v in platform_state(cfg, ends))
    geo = MachineGeometry.of(cfg)
    A, omega, drift = platform_motion(geo, np.tile(q[0], (40, 1)), np.tile(q[1] - q[0], (40, 1)), s[:, 0], s[:, 1],
                                      sigma, gamma, LIPSCHITZ)
    rbar = np.max(disp, axis=1) + drift
    bound = A + omega * (np.linalg.norm(pts, axis=1).max() + rbar)
    assert np.all(moved <= bound), np.max(moved / bound)
    assert np.all(bound < 3.0 * moved + 1e-9)    # and not loose by much


def test_the_platform_origin_drifts_with_the_joints_in_the_body():
    """Rods ``(h - 2.5 mm, h, h + 2.5 mm)`` from level tilt the platform 1.77 deg about the joint centres' centroid,
    which stays where it was (``A``'s rod part is 0): the platform origin (the body's point over the centroid at rest)
    moves 22.3 um, as the joints drift in the body (up to 269 um, the drift bound). ``A`` holds that drift: the bound
    ``A + Omega rbar`` reads 280 um, its rotation part alone 11.2 um."""
    cfg = ROBOT.config
    q0, q1 = np.full(3, 0.3), np.array([0.2975, 0.3, 0.3025])
    fk = forward_batch(q0 + np.linspace(0.0, 1.0, 201)[:, None] * (q1 - q0), cfg)
    assert math.degrees(math.acos(fk.rotation[-1, 2, 2])) == pytest.approx(1.774, abs=1e-3)
    moved = float(np.max(np.linalg.norm(fk.position - fk.position[0], axis=1)))
    sigma, gamma, disp = (v[None] for v in platform_state(cfg, forward_batch(np.stack([q0, q1]), cfg)))
    geo = MachineGeometry.of(cfg)
    A, omega, drift = platform_motion(geo, q0[None], (q1 - q0)[None], np.zeros(1), np.ones(1), sigma, gamma,
                                      LIPSCHITZ)
    turned = float(omega[0] * (np.linalg.norm(geo.platform_points().mean(axis=0)) + np.max(disp) + drift[0]))
    assert moved == pytest.approx(2.234e-5, rel=1e-3) and float(drift[0]) == pytest.approx(2.689e-4, rel=1e-3)
    assert turned == pytest.approx(1.121e-5, rel=1e-3) and turned < moved <= float(A[0]) + turned



def test_the_shortest_edge_over_an_interval_is_taken_inside_it():
    """An edge of 0.3162 m (0.3, 0.1, 0) shrinking along x at 0.2 m per unit: over [0, 3] it is shortest, 0.1 m, at
    1.5 inside the interval (the start's 0.3162 m would bound the platform's turn 3.2 times too tight); over
    [0, 1] at the end (0.1414 m); growing (the opposite rate) at the start. Each against 30001 samples."""
    E0 = np.array([[0.3, 0.1, 0.0]] * 4)
    Ep = np.array([[-0.2, 0.0, 0.0], [-0.2, 0.0, 0.0], [0.2, 0.0, 0.0], [-0.1, 0.05, 0.02]])
    ds = np.array([3.0, 1.0, 3.0, 2.5])
    least = shortest_edge(E0, Ep, ds)
    t = np.linspace(0.0, 1.0, 30001)[None, :, None] * ds[:, None, None]
    sampled = np.min(np.linalg.norm(E0[:, None] + t * Ep[:, None], axis=2), axis=1)
    np.testing.assert_allclose(least[:3], [0.1, math.sqrt(0.02), math.sqrt(0.1)], rtol=1e-15, atol=0)
    assert np.all(least <= sampled) and np.all(sampled - least < 1e-9)

def test_the_platform_s_turn_is_bounded_by_each_edge_s_shortest_length_inside_the_motion(monkeypatch):
    """Rods (h - 2.5 mm, h, h + 2.5 mm) to (h + 2.5 mm, h, h - 2.5 mm): every joint-centre edge is shortest half way,
    19.4 um to 77.4 um below its ends (20001 samples); the turn's bound Omega is that of those shortest edges (the
    start's edge, as a mutant took, bounds it 1.6e-5 tighter), and no less than the turn sampled."""
    cfg = ROBOT.config
    geo = MachineGeometry.of(cfg)
    q0, q1 = np.array([0.2975, 0.3, 0.3025]), np.array([0.3025, 0.3, 0.2975])
    Q = q0 + np.linspace(0.0, 1.0, 20001)[:, None] * (q1 - q0)
    P = geo.base_points(Q)
    L = np.stack([np.linalg.norm(P[:, b] - P[:, a], axis=1) for a, b in ((0, 1), (1, 2), (2, 0))], axis=1)
    assert np.argmin(L, axis=0).tolist() == [10000] * 3
    np.testing.assert_allclose(L[0] - L.min(axis=0), [1.935e-5, 1.935e-5, 7.740e-5], rtol=1e-3)
    fk = forward_batch(Q, cfg)
    turned = float(np.max(np.arccos(np.clip((np.einsum('ij,nij->n', fk.rotation[0], fk.rotation) - 1) / 2, -1, 1))))
    sigma, gamma, _ = (v[None] for v in platform_state(cfg, forward_batch(np.stack([q0, q1]), cfg)))
    args = (geo, q0[None], (q1 - q0)[None], np.zeros(1), np.ones(1), sigma, gamma, LIPSCHITZ)
    omega = float(platform_motion(*args)[1][0])
    seen = []

    def sampled(E0, Ep, ds):   # the least |E0 + t Ep| of 20001 samples of [0, ds]
        seen.append(E0)
        t = np.linspace(0.0, 1.0, 20001)[None, :, None] * ds[:, None, None]
        return np.min(np.linalg.norm(E0[:, None] + t * Ep[:, None], axis=2), axis=1)

    monkeypatch.setattr(motion_module, 'shortest_edge', sampled)
    assert float(platform_motion(*args)[1][0]) == pytest.approx(omega, rel=1e-9) and len(seen) == 3
    assert omega == pytest.approx(0.0734990, rel=1e-6) and turned == pytest.approx(0.0619157, rel=1e-6)


def test_separating_axis_bound_never_above_the_library():
    fcl = pytest.importorskip('fcl')
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(7)
    n = 400
    Ra, Rb = Rotation.random(n, random_state=1).as_matrix(), Rotation.random(n, random_state=2).as_matrix()
    ha, hb = rng.uniform(0.001, 0.3, (n, 3)), rng.uniform(0.001, 0.3, (n, 3))
    ca, cb = rng.uniform(-0.5, 0.5, (n, 3)), rng.uniform(-0.5, 0.5, (n, 3))
    lb = box_lower_bound(Ra, ca, ha, Rb, cb, hb)
    req = fcl.DistanceRequest(enable_signed_distance=True)
    exact = np.array([fcl.distance(fcl.CollisionObject(fcl.Box(*(2 * ha[k])), fcl.Transform(Ra[k], ca[k])),
                                   fcl.CollisionObject(fcl.Box(*(2 * hb[k])), fcl.Transform(Rb[k], cb[k])), req,
                                   fcl.DistanceResult()) for k in range(n)])
    assert np.all(lb <= exact + 1e-9)
    apart = exact > 0.01
    assert np.median(lb[apart] / exact[apart]) > 0.95


@pytest.mark.parametrize('depth', [1e-6, 1e-4, 5e-4, 9.99e-4])
def test_boxes_overlapping_by_less_than_a_millimetre_read_minus_their_depth(depth):
    """Two boxes (half-edges 50, 40, 30 mm) ``depth`` into each other, less than 1 mm: face to face, and a corner of
    one turned 0.4 rad about z into the other's +x face. The separating-axis bound is minus the depth (the library's
    signed distance, its EPA, gives the same), never 0 (touching, as if clear of the margin by the depth), and so is
    the bound of bodies in contact (contact_bound) and the measured distance of the pair, less the library's slack.
    No test had bodies this close: a bound clamped to 0 above -1 mm passed them all."""
    fcl = pytest.importorskip('fcl')
    from gpr_kinematics.safety.bodies import Body
    from gpr_kinematics.safety.distances import LIBRARY_SLACK, Exact, Store, contact_bound
    from scipy.spatial.transform import Rotation

    h = np.array([0.05, 0.04, 0.03])
    turn = Rotation.from_euler('z', 0.4).as_matrix()
    lowest_x = np.min((SIGNS * h) @ turn.T, axis=0)[0]   # the turned box's corner nearest -x, from its centre
    cases = [(np.eye(3), np.array([2 * h[0] - depth, 0.01, -0.005])),     # face into face
             (turn, np.array([h[0] - depth - lowest_x, 0.0, 0.0]))]       # a corner into the +x face
    req = fcl.DistanceRequest(enable_signed_distance=True)
    for R, c in cases:
        signed = fcl.distance(fcl.CollisionObject(fcl.Box(*(2 * h)), fcl.Transform(np.eye(3), np.zeros(3))),
                              fcl.CollisionObject(fcl.Box(*(2 * h)), fcl.Transform(R, c)), req, fcl.DistanceResult())
        assert signed == pytest.approx(-depth, abs=1e-12)
        lb = box_lower_bound(np.eye(3)[None], np.zeros((1, 3)), h[None], R[None], c[None], h[None])[0]
        assert lb == pytest.approx(-depth, abs=1e-12)
        no = np.array([False])
        touch = contact_bound((np.eye(3)[None], np.zeros((1, 3)), h[None], no), (R[None], c[None], h[None], no))[0]
        assert touch == pytest.approx(-depth, abs=1e-12)
        bodies = [Body('a', 'box', tuple(2 * h), None, np.eye(3), np.zeros(3)),
                  Body('b', 'box', tuple(2 * h), None, R, c)]
        exact = Exact(bodies, Store(None, bodies))
        one = np.array([0])
        exact.measure(one, one, one, one + 1)
        assert exact.values(one, one)[0][0] == pytest.approx(-depth - LIBRARY_SLACK, abs=1e-12)


@pytest.mark.parametrize('name', list(PLANS))
def test_timing_keeps_every_joint_within_its_velocity_limit(name):
    """The profile's speed never exceeds its cruise speed, and the joints' finite-difference speeds (1 kHz, the
    straight entries included) stay within the limits everywhere."""
    plan = PLANS[name]
    t = plan.timing
    _, velocity, _, _ = joint_limits(ROBOT)
    for m in range(len(t.duration)):
        if not np.isfinite(t.profiles.v[m]):
            continue
        tau = np.linspace(0.0, t.duration[m], 2001)
        _, ds, _ = evaluate(t.profiles, np.full(tau.shape, m), tau)
        assert np.max(ds) <= t.profiles.v[m] * (1 + 1e-12)
        s = np.linspace(0.0, 1.0, 2001)
        rows = move_rows(ROBOT, plan.waypoints, plan.positions, m, s)
        speed = np.max(np.abs(np.diff(rows, axis=0)) / np.diff(s)[:, None], axis=0) * t.profiles.v[m]
        assert np.all(speed <= velocity * (1 + 1e-9)), (plan.labels[m + 1], speed / velocity)


def test_wafer_windows_follow_the_program():
    """The carried wafer of the cell program: from the pick at the load port to the place in pm1, from the pick in
    pm1 to the place in pm2, and from pm2 back to the load port."""
    plan = PLANS['example_cell_program']
    w = wafer_plan(plan)
    at = [i for i, ph in enumerate(plan.waypoints.phase) if ph == 'at']
    arrive = plan.timing.arrive[at]
    np.testing.assert_allclose(np.ravel(w.carried['arm2']), np.ravel(list(zip(arrive[::2], arrive[1::2],
                                                                              strict=True))))
    assert w.carried['arm1'] == () and [s for _, s, _ in w.stations] == ['load_port_1', 'pm1', 'pm2', 'load_port_1']
    # each its own name: the wafer there from the start, or the place that left it (both were wafer@load_port_1)
    assert [n for n, _, _ in w.stations] == ['wafer@load_port_1:start', 'wafer@pm1:steps[5]', 'wafer@pm2:steps[9]',
                                             'wafer@load_port_1:steps[14]']


def test_trapezoids_and_s_curves_of_the_cell_program():
    """Without jerk limits the moves are trapezoids: straight entries take time too (not zero), each move is no
    longer than its S-curve, and the joints stay within their velocity limits on the lines."""
    import dataclasses

    trap = dataclasses.replace(ROBOT, rods=dataclasses.replace(ROBOT.rods, jerk=None), arms=tuple(
        dataclasses.replace(a, joints=tuple(dataclasses.replace(j, jerk=None) for j in a.joints)) for a in ROBOT.arms))
    s_curve = PLANS['example_cell_program']
    plan = plan_program(trap, load_program(config_path('programs/example_cell_program.yaml')))
    assert np.all(np.isinf(plan.timing.jerk)) and np.all(np.isfinite(s_curve.timing.jerk))
    moving = np.any(np.abs(np.diff(plan.positions, axis=0)) > 1e-12, axis=1)
    assert np.all(plan.timing.duration[moving] > 0.0)
    assert np.all(plan.timing.duration <= s_curve.timing.duration + 1e-12)
    _, velocity, _, _ = joint_limits(ROBOT)
    s = np.linspace(0.0, 1.0, 2001)
    for m in line_moves(plan.waypoints):
        rows = move_rows(trap, plan.waypoints, plan.positions, m, s)
        speed = np.max(np.abs(np.diff(rows, axis=0)) / np.diff(s)[:, None], axis=0) * plan.timing.profiles.v[m]
        assert np.all(speed <= velocity * (1 + 1e-9))
    assert 1.0 < s_curve.timing.total / plan.timing.total < 1.2


def test_a_bound_that_is_not_a_number_bounds_nothing():
    """``0 * inf``: a drift bound infinite (``sigma^2 <= 2 lip flux``) times a point that does not move with X
    (``gamma = 0``) was NaN, and a NaN motion bound compared false with every target and entered the pair's floor as
    NaN, which no margin check sees (a verifier's reading of the code). The drift of such a point is 0, and a motion
    bound that is not a number is infinite (it settles no interval)."""
    from types import SimpleNamespace

    from gpr_kinematics.core.config import GprConfig
    from gpr_kinematics.core.machine import MachineGeometry
    from gpr_kinematics.safety.motion import drift_bound, platform_bound

    flux = np.array([1.0, 1.0, 0.0])
    sigma = np.array([[0.1, 0.1], [1e3, 1e3], [0.1, 0.1]])
    gamma = np.array([[0.0, 0.0], [2.0, 2.0], [0.0, 0.0]])
    drift = drift_bound(flux, sigma, gamma, 1.0)
    assert drift[0] == 0.0 and drift[2] == 0.0 and 0.0 < drift[1] < np.inf
    geo = MachineGeometry.of(GprConfig())
    lev = SimpleNamespace(platform=np.array([True, False]), reach=np.array([0.5, 0.5]))
    b = platform_bound(geo, lev, np.array([0.0, 0.001]), np.array([0.0, np.inf]), np.array([np.inf, 0.0]),
                       np.zeros((2, 2)))
    assert b[0, 0] == np.inf and b[0, 1] == 0.0 and b[1, 0] == np.inf


def test_a_pairs_motion_bound_holds_what_both_bodies_travel():
    """The clearance search's bound ``mu`` of a pair (its arm and platform bounds of both bodies, the certificate's
    ``d(t) >= d(t0) - mu``) is at least what the two travel together: on 120 random intervals of the example cell
    program, for every pair not both carried by the platform (each arm's bodies against the column: the column still,
    the bodies moved by the rods alone on the vertical moves), the largest travel of a corner of each body (41 instants
    inside) summed stays within it."""
    plan = PLANS['example_cell_program']
    motion = PlanMotion(plan)
    bodies = robot_body_set(ROBOT, {a.name: ((0.0, math.inf),) for a in ROBOT.arms})
    search = _Search(motion, bodies, [(i, j, ()) for i, j in default_pairs(bodies)], MARGIN, TOLERANCE, 1.0, False)
    t0, t1 = _intervals(plan, np.random.default_rng(23), 120)
    tau = np.linspace(0.0, 1.0, 41)
    frames = motion.snapshot((t0[:, None] + tau[None] * (t1 - t0)[:, None]).ravel()).frames
    K = t0.shape[0]
    travel = np.zeros((K, len(bodies)))
    for k, body in enumerate(bodies):
        if body.frame is not None:
            pts = _points(body, frames).reshape(K, len(tau), 9, 3)
            travel[:, k] = np.max(np.linalg.norm(pts - pts[:, :1], axis=3), axis=(1, 2))
    pairs = np.flatnonzero(~search.rigid)
    assert {(bodies[int(search.pa[p])].name, bodies[int(search.pb[p])].name) for p in pairs} == {
        ('gpr_base', b.name) for b in bodies if b.arm}   # links, blades and wafers (the wafers' alone before)
    p, k = np.repeat(pairs, K), np.tile(np.arange(K), pairs.size)
    i0, i1 = search.store.add(t0)[k], search.store.add(t1)[k]
    items = Intervals(p, i0, i1, np.zeros(p.size, dtype=np.int64))
    search._motion(items)
    together = travel[k, search.pa[p]] + travel[k, search.pb[p]]
    assert np.all(together <= items.mu + 1e-12), float(np.max(together - items.mu))
    assert float(np.max(together)) > 0.1


def test_the_tangent_bound_takes_off_what_the_nearest_points_error_can_turn_its_slopes():
    """The convex (translating) pair's tangent bound, with nearest points that are off by their error ``w``: a point
    passing 1 mm from another, ``x(tau) = (-1, 1000, 0) um + tau (2, 0, 0) um`` (``d`` at most 0.5 nm above its 1 mm
    minimum at the ends, slopes of -+2e-9), whose nearest points' differences are off by ``w = 1 um`` across the
    motion, which tilts the slopes' directions by 1e-3 rad, 2e-9 m of slope, to 0: the tangents alone read the ends,
    1 mm + 0.5 nm, above the minimum. Less the error ``2 w |Delta| / d = 4e-9`` m it is below."""
    x0, delta = np.array([-1e-6, 1e-3, 0.0]), np.array([2e-6, 0.0, 0.0])
    x1 = x0 + delta
    d0, d1 = np.linalg.norm(x0), np.linalg.norm(x1)
    w = 1e-6
    off = {0: x0 + np.array([w, 0.0, 0.0]), 1: x1 - np.array([w, 0.0, 0.0])}   # both (0, 1 mm, 0): slopes 0

    class Exact:
        def gap(self, p, i):
            return np.array([off[int(k)] for k in i])

        def gap_error(self, p, i):
            return np.full(i.shape, w)

    one = np.zeros(1, dtype=np.int64)
    low = _Search._convex(SimpleNamespace(exact=Exact()), one, one, one + 1, np.array([d0]), np.array([d1]),
                          delta[None])
    tau = np.linspace(0.0, 1.0, 10_001)
    least = float(np.min(np.linalg.norm(x0 + tau[:, None] * delta, axis=1)))
    assert least == pytest.approx(1e-3, abs=1e-15) and d0 - least == pytest.approx(5e-10, rel=1e-3)
    assert float(low[0]) <= least and float(low[0]) == pytest.approx(d0 - 4e-9, abs=1e-11)


def test_the_drift_bound_is_the_solution_of_its_differential_inequality():
    """The joint centres' drift while the rods' squared sides change by ``I``: ``|Xdot| <= |d(L^2)/dt| / sigma(t)``
    with ``sigma >= sigma_0 - Lip x`` gives ``dx/dI = 1 / (sigma_0 - Lip x)``, integrated here (RK4, 20,000 steps)
    from 0: ends of ``sigma_0`` 1 and 1.3 (from either end: the larger's, 1.3, bounds less), ``Lip = 4 sqrt(2)``, the
    larger ``gamma`` (0.7); ``I / sigma_0`` to first order; no bound (inf) from ``I = 1.3^2 / (2 Lip) = 0.149`` on,
    where the solution's slope is infinite."""
    flux = np.array([1e-6, 0.01, 0.14, 0.15])
    sigma, gamma = np.array([[1.0, 1.3]] * 4), np.array([[0.7, 0.2]] * 4)
    got = drift_bound(flux, sigma, gamma, LIPSCHITZ)
    for total, value in zip(flux[:3], got[:3], strict=True):
        x, h = 0.0, total / 20_000
        for _ in range(20_000):
            k1 = 1.0 / (1.3 - LIPSCHITZ * x)
            k2 = 1.0 / (1.3 - LIPSCHITZ * (x + 0.5 * h * k1))
            k3 = 1.0 / (1.3 - LIPSCHITZ * (x + 0.5 * h * k2))
            k4 = 1.0 / (1.3 - LIPSCHITZ * (x + h * k3))
            x += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        assert value == pytest.approx(0.7 * x, rel=1e-9)
    assert got[0] == pytest.approx(0.7e-6 / 1.3, rel=1e-5) and got[3] == math.inf
    assert drift_bound(np.zeros(1), sigma[:1], gamma[:1], LIPSCHITZ)[0] == 0.0


def test_the_rods_flux_bounds_the_change_of_the_squared_sides(monkeypatch):
    """``I = int |d(L^2)/dt|`` that the drift is bounded from (``2 ds max(|E . E'|)`` at the ends per side; ``E . E'``
    is linear in ``s``) is at least the squared sides' total variation, summed over 1,001 points of each of 40
    pieces of lines tilting the rods: at most twice it where ``E . E'`` keeps its sign (from level, 0 at ``s = 0``:
    the larger end's value over the mean), 1.3 times on the pieces from ``s = 0.5`` on."""
    cfg = ROBOT.config
    q = inverse_batch(np.array([0.30, 0.32]), np.radians([0.0, 2.0]), np.radians([0.0, 30.0]), cfg).q
    s = np.sort(np.random.default_rng(7).uniform(0, 1, (40, 2)), axis=1)
    seen = []
    monkeypatch.setattr(motion_module, 'drift_bound', lambda flux, *rest: seen.append(flux) or np.zeros(flux.shape))
    geo = MachineGeometry.of(cfg)
    platform_motion(geo, np.tile(q[0], (40, 1)), np.tile(q[1] - q[0], (40, 1)), s[:, 0], s[:, 1],
                    np.ones((40, 2)), np.ones((40, 2)), LIPSCHITZ)
    S = s[:, :1] + np.linspace(0.0, 1.0, 1001)[None] * (s[:, 1:] - s[:, :1])
    P = geo.base_points(q[0] + S.reshape(-1, 1) * (q[1] - q[0])).reshape(40, 1001, 3, 3)
    variation = sum(np.sum(np.abs(np.diff(np.sum((P[:, :, b] - P[:, :, a]) ** 2, axis=2), axis=1)), axis=1)
                    for a, b in ((0, 1), (1, 2), (2, 0)))
    assert np.all(variation <= seen[0]) and np.all(seen[0] <= 2.0 * variation)
    late = s[:, 0] >= 0.5
    assert np.all(seen[0][late] <= 1.3 * variation[late]) and late.sum() > 5


def test_a_joint_triangle_that_turns_over_has_no_bound_on_its_turn():
    """Three joint centres, the third moving along ``-y`` through the line of the other two (``P_3 = (0, 1 - 2 s,
    0)``): the triangle's normal ``N = E12 x E13`` (length 1 at both ends) passes through 0 and turns over, pi rad.
    ``|N| >= (n0 + n1 - ds max |N'|) / 2 = 0`` leaves no bound on the turn (inf); the ends' lengths alone read 2 rad,
    and the body's path about the centroid 2/3 m."""
    B = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    u = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    geo = SimpleNamespace(ux=tuple(u[:, 0]), uy=tuple(u[:, 1]), uz=tuple(u[:, 2]),
                          base_points=lambda Q: B[None] + Q[:, :, None] * u[None])
    with np.errstate(invalid='ignore'):
        A, omega, drift = platform_motion(geo, np.zeros((1, 3)), np.array([[0.0, 0.0, 2.0]]), np.zeros(1), np.ones(1),
                                          np.full((1, 2), 1e9), np.zeros((1, 2)), LIPSCHITZ)
    assert omega[0] == math.inf and A[0] == pytest.approx(2.0 / 3.0, rel=1e-15) and drift[0] == 0.0


def test_a_motion_bound_that_is_no_number_proves_nothing(monkeypatch):
    """A motion bound of NaN (inf x 0 of a rate bound and a zero lever) made the interval's certificate NaN, and a NaN
    distance compared below the margin as False: the pair read as safe. Such a bound is -inf: the pair is not shown
    the margin apart, the program not safe."""
    import dataclasses

    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot import load_robot
    from gpr_kinematics.robot.plan import plan_program
    from gpr_kinematics.robot.program import load_program
    from gpr_kinematics.safety.check import check_program
    from gpr_kinematics.safety.motion import PlanMotion

    plan = plan_program(load_robot(), load_program(config_path('programs/example_robot_program.yaml')))
    original = PlanMotion.bounds

    def nan_bounds(self, *args):
        b = original(self, *args)
        return dataclasses.replace(b, arm=np.full(b.arm.shape, np.nan))

    monkeypatch.setattr(PlanMotion, 'bounds', nan_bounds)
    report = check_program(plan, None)[0]
    assert not report.safe and report.collisions and report.min_clearance == -np.inf
    assert all(not c.measured_below for c in report.collisions)   # bounds only: not shown the margin apart

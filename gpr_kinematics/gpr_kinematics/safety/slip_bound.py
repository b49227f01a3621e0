"""A certified upper bound of the slip ratio between the instants of the slip check on joint-space moves (docs/cell.md,
"Wafer slip"): on each interval ``[t0, t1]`` between two instants, from the ratio's terms at an anchor (each end for
the half next to it, then the midpoints of halved intervals) and bounds on how fast they change.

On a joint-space move every joint is ``q(s) = q_0 + s D`` and the wafer's position in ``gpr_base`` is

    ``p(s) = Pbar(s) + Rot(s) (w(s) - rbar(s))``

with ``Pbar`` the joint centres' centroid (affine in ``s``), ``Rot = F_P F_r^T`` the platform's rotation (``F_P`` the
frame of the joint-centre triangle: the direction of ``E12``, affine in ``s``, and the normal ``N = E12 x E13``,
quadratic; ``F_r`` the in-plane frame of the platform joints ``r_k(X)``: the direction of ``r_2 - r_1``), ``w`` the
wafer in ``gpr_platform`` (link vectors ``r_i u(phi_i)``, ``phi_i`` affine in ``s``: ``|w^(k)| <= sum_i r_i |b_i|^k``)
and ``rbar`` the joints' centroid. The virtual joints close ``F(X(s)) = G(s) = L(s)^2`` (``G`` quadratic in ``s``;
Bratovanov & Sotirov, eq. (6), differentiated as their eq. (3)): ``J X' = G'``, ``J X'' = G'' - H[X', X']``,
``J X''' = -3 H[X', X'']`` with
``|H[x, y]| <= Lip |x| |y|`` and ``J``'s smallest singular value at least ``(sigma_m + sqrt(sigma_m^2 - 4 Lip
|G'| ds))/2`` within ``ds`` of the anchor; ``|r_k^(j)| <= gamma |X^(j)|``. This is exact for the ``radial`` model
(``F`` quadratic in ``X``, ``gamma = 1``), first order for the others (as the clearance's platform bound). A unit
vector ``e/|e|`` with ``|e^(k)| <= m rho_k`` and ``|e| >= m`` has derivatives at most ``rho_1``, ``rho_2 + 3 rho_1^2``,
``rho_3 + 9 rho_1 rho_2 + 21 rho_1^3``. So ``|d^k p/ds^k| <= F_k`` and the wafer's jerk ``da/dt = p''' s'^3 + 3 p''
s' s'' + p' s'''`` is at most ``F_3 S_1^3 + 3 F_2 S_1 S_2 + F_1 S_3`` (``S_k`` bounds of the S-curve's ``|s^(k)|``
on the interval, which holds no corner: the corners are instants; ``S_3 = 0`` off the jerk ramps), the normal
``n = N/|N|`` turns at most ``|n'| S_1``. Within ``h`` of the anchor ``|f - f_m| <= df`` (with the central
differences' error over the move's step ``d`` (:func:`~gpr_kinematics.safety.slip.difference_step`),
``d/3 F_3 + 4 POSITION_ERROR / d^2`` in ``p''``, ``d^2/6 F_3 + POSITION_ERROR / d`` in ``p'``) and
``angle(n, n_m) <= dn``, so

    ``ratio <= (|f_t,m| + (|f_m| + df) dn + df) / (mu (f_n,m - (|f_m| + df) dn - df + F_vac / m))``.

Intervals whose bound exceeds the largest ratio evaluated on their move by more than :data:`SLIP_TOLERANCE` are
halved (their midpoints become instants) until none does or lies more than half of it above its floor (the bound that
the differences' error alone leaves: no halving lowers it), down to :data:`SHORTEST` and at most
:data:`MAX_REFINEMENTS` instants more (the loosest intervals first when they do not all fit; beyond, the bound stays,
looser, and is not closed).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core import forward_batch
from ..core.machine import MachineGeometry
from ..core.virtual_joints import make_model
from ..robot.forward import robot_forward
from ..robot.plan import ProgramPlan, joint_limits, line_moves
from ..robot.timing import evaluate, locate
from .motion import LIPSCHITZ, platform_state, rod_directions
from .slip import CLOSURE_TOLERANCE, GRAVITY, closure_exact, difference_step

Array = NDArray[np.float64]

#: An interval's bound is settled once it is within this of the largest ratio evaluated on its move.
SLIP_TOLERANCE = 1e-3
#: At most this many instants are added to settle the bound (beyond it the bound stays as it is, an upper bound).
MAX_REFINEMENTS = 100_000
#: The forward kinematics' rounding assumed in the central differences [m]: the closure's tolerance the slip check
#: solves to (its noise from one ``s`` to the next is at the doubles' spacing, 2e-16 m: a test measures it).
POSITION_ERROR = CLOSURE_TOLERANCE
#: How many of the doubles' spacings a computed corner may lie from the profile's (:func:`_jerk`).
CORNER_SLACK = 8.0
#: An interval this short [s] is not halved again (its bound stays, an upper bound, and the bound is not closed).
SHORTEST = 1e-7


@dataclass(frozen=True)
class SlipBound:
    """The settled intervals ``[start, end]`` ``(K,)`` [s] of the joint-space moves carrying a wafer, their ``move``,
    ``bound`` on the slip ratio and its ``floor`` (what the central differences' error leaves of it); the midpoints
    evaluated (``time``, ``ratio``); ``closed``: every interval within :data:`SLIP_TOLERANCE` of its move's largest
    evaluated ratio, or within half of it of its floor."""

    start: Array
    end: Array
    move: NDArray[np.int64]
    bound: Array
    floor: Array
    time: Array
    ratio: Array
    closed: bool


@dataclass(frozen=True)
class Anchors:
    """The wafer at profile values of joint-space moves ``(K,)``: its path's first and second derivatives in ``s``
    ``d1``, ``d2`` (central differences of the exact forward kinematics over the step ``h`` in ``s``), the paddle's
    normal ``n`` (world), its position ``x`` in ``gpr_platform`` less the platform joints' centroid, their side
    ``r12 = |r_2 - r_1|``, ``sigma``, ``gamma`` (:func:`~gpr_kinematics.safety.motion.platform_state`) and the joint
    ``rows``."""

    d1: Array
    d2: Array
    n: Array
    x: Array
    r12: Array
    sigma: Array
    gamma: Array
    rows: Array
    h: Array


def unit_rates(r1: Array, r2: Array, r3: Array) -> tuple[Array, Array, Array]:
    """Bounds of the first three derivatives of ``e/|e|`` given ``|e^(k)| <= rho_k min |e|`` (module docstring)."""
    return r1, r2 + 3.0 * r1 ** 2, r3 + 9.0 * r1 * r2 + 21.0 * r1 ** 3


def _leibniz(a: list[Array], b: list[Array], k: int) -> Array:
    """``sum_j C(k, j) a_j b_(k-j)``: a bound of the ``k``-th derivative of a product."""
    return np.asarray(sum((1, k, k * (k - 1) // 2, 1)[j] * a[j] * b[k - j] for j in range(k + 1)), dtype=np.float64)


def anchors(plan: ProgramPlan, m: NDArray[np.int64], s: Array, arms: Array) -> Anchors:
    """:class:`Anchors` at ``s`` on the joint-space moves ``m`` of the arms ``arms`` (a forward solve of ``3 K`` rows
    and one of ``K``)."""
    robot = plan.robot
    P = plan.positions
    rows = P[m] + s[:, None] * (P[m + 1] - P[m])
    K = s.shape[0]
    d1, d2, n, x = (np.zeros((K, 3)) for _ in range(4))
    r12, sigma, gamma, h = np.zeros(K), np.zeros(K), np.zeros(K), np.zeros(K)
    _, _, _, slices = joint_limits(robot)
    model = make_model(robot.config)
    for arm, cols in zip(robot.arm_names, slices, strict=True):
        sel = np.flatnonzero(arms == arm)
        if not sel.size:
            continue
        D, k = P[m[sel] + 1] - P[m[sel]], sel.size
        h[sel] = difference_step(plan, arm, m[sel])
        step = h[sel, None]
        around = np.concatenate([rows[sel] - step * D, rows[sel], rows[sel] + step * D])
        fk = robot_forward(robot, around[:, :3], around[:, cols], arm, check_limits=False)
        p = fk.wafer.position
        d1[sel] = (p[2 * k:] - p[:k]) / (2 * step)
        d2[sel] = (p[2 * k:] - 2 * p[k:2 * k] + p[:k]) / step ** 2
        n[sel] = fk.wafer.rotation[k:2 * k, :, 2]
        gpr = forward_batch(rows[sel, :3], robot.config, check_limits=False)
        sigma[sel], gamma[sel], _ = platform_state(robot.config, gpr)
        r = model.points_and_partials(gpr.virtual_joints)[0]
        r12[sel] = np.linalg.norm(r[:, 1] - r[:, 0], axis=1)
        x[sel] = fk.wafer_on_platform.position[k:2 * k]
        x[sel, :2] -= r.mean(axis=1)
    return Anchors(d1, d2, n, x, r12, sigma, gamma, rows, h)


def _frames(plan: ProgramPlan, D: Array, at: Anchors, ws: Array) -> tuple[list[Array], list[Array], Array]:
    """Bounds of the platform rotation's derivatives in ``s`` (``Rot``, orders 0-3), of the joints' centroid's
    (orders 1-3) and of the normal's turn rate ``|n'|``, within ``ws`` of the anchors (module docstring)."""
    geo = MachineGeometry.of(plan.robot.config)
    u = rod_directions(geo)
    C = geo.base_points(at.rows[:, :3])
    vel = D[:, :3, None] * u[None]
    E12, E13, E12p, E13p = C[:, 1] - C[:, 0], C[:, 2] - C[:, 0], vel[:, 1] - vel[:, 0], vel[:, 2] - vel[:, 0]
    N, Np, Npp = (np.cross(E12, E13), np.cross(E12p, E13) + np.cross(E12, E13p), 2.0 * np.cross(E12p, E13p))
    nNp, nNpp = np.linalg.norm(Np, axis=1), np.linalg.norm(Npp, axis=1)
    zero = np.zeros_like(ws)
    one = zero + 1.0
    G1, G2 = zero.copy(), zero.copy()
    for a, b in ((0, 1), (1, 2), (2, 0)):
        E, Ep = C[:, b] - C[:, a], vel[:, b] - vel[:, a]
        G1 += (2.0 * np.abs(np.einsum('ki,ki->k', E, Ep)) + 2.0 * np.einsum('ki,ki->k', Ep, Ep) * ws) ** 2
        G2 += (2.0 * np.einsum('ki,ki->k', Ep, Ep)) ** 2
    G1, G2 = np.sqrt(G1), np.sqrt(G2)
    disc = at.sigma ** 2 - 4.0 * LIPSCHITZ * G1 * ws
    g = at.gamma
    with np.errstate(divide='ignore', invalid='ignore'):
        nmin = np.linalg.norm(N, axis=1) - nNp * ws - 0.5 * nNpp * ws ** 2
        e3 = unit_rates(np.where(nmin > 0, (nNp + nNpp * ws) / nmin, np.inf), nNpp / nmin, zero)
        emin = np.linalg.norm(E12, axis=1) - np.linalg.norm(E12p, axis=1) * ws
        e1 = unit_rates(np.where(emin > 0, np.linalg.norm(E12p, axis=1) / emin, np.inf), zero, zero)
        smin = np.where(disc > 0, 0.5 * (at.sigma + np.sqrt(np.maximum(disc, 0.0))), 0.0)
        X1 = np.where(smin > 0, G1 / smin, np.inf)
        X2 = (G2 + LIPSCHITZ * X1 ** 2) / smin
        X = [X1, X2, 3.0 * LIPSCHITZ * X1 * X2 / smin]
        rmin = at.r12 - 2.0 * g * X1 * ws
        f1 = unit_rates(*(np.where(rmin > 0, np.where(x > 0, 2.0 * g * x / rmin, 0.0), np.inf) for x in X))
    e2 = [_leibniz([one, *e3], [one, *e1], k) for k in (1, 2, 3)]
    FP = [one] + [np.sqrt(e1[k] ** 2 + e2[k - 1] ** 2 + e3[k] ** 2) for k in range(3)]
    FR = [one] + [np.sqrt(2.0) * f for f in f1]
    return [one] + [_leibniz(FP, FR, k) for k in (1, 2, 3)], [g * x for x in X], e3[0]


def bound_about(plan: ProgramPlan, m: NDArray[np.int64], at: Anchors, arms: Array, s1: Array, s2: Array,
                half: Array, S: tuple[Array, Array, Array]) -> tuple[Array, Array, Array]:
    """The ratio at anchors ``at`` (there ``s' = s1`` and ``s'' = s2``, on the interval's side), its bound within
    ``half`` [s] of them and that bound's floor, what the central differences' error alone leaves of it (no halving
    lowers it); ``S``: the first three derivatives of ``s`` at most there (module docstring)."""
    robot = plan.robot
    S1, S2, S3 = S
    d = at.h
    ws = S1 * half + d                          # the s-range about the anchor, the differences' points in it
    D = plan.positions[m + 1] - plan.positions[m]
    Rot, R, turn = _frames(plan, D, at, ws)
    _, _, _, slices = joint_limits(robot)
    W = np.zeros((4, ws.shape[0]))
    mu, hold = np.zeros_like(ws), np.zeros_like(ws)
    for arm, cols in zip(robot.arms, slices, strict=True):
        sel = arms == arm.name
        last, blade = arm.joints[-1], arm.blade
        c, sn = np.cos(blade.yaw), np.sin(blade.yaw)
        tip = (last.length + blade.position[0] + c * blade.wafer_centre[0] - sn * blade.wafer_centre[1],
               blade.position[1] + sn * blade.wafer_centre[0] + c * blade.wafer_centre[1])
        lever = np.array([j.length for j in arm.joints[:-1]] + [float(np.hypot(*tip))])
        b = np.abs(np.cumsum(D[np.ix_(sel, range(cols.start, cols.stop))], axis=1))   # the links' turn rates
        for k in range(1, 4):
            W[k, sel] = (b ** k) @ lever
        mu[sel], hold[sel] = arm.bodies.friction, arm.bodies.friction * arm.bodies.vacuum / robot.wafer.mass
    centroid = np.linalg.norm(np.mean(D[:, :3, None] * rod_directions(MachineGeometry.of(robot.config))[None],
                                      axis=1), axis=1)
    with np.errstate(invalid='ignore'):
        V = [np.linalg.norm(at.x, axis=1) + (W[1] + R[0]) * ws] + [W[k] + R[k - 1] for k in (1, 2, 3)]
        F3 = _leibniz(Rot, V, 3)
        # near the anchor the differences bound |p''| and |p'| better than the sums (their error from F3)
        e1, e2 = d ** 2 / 6.0 * F3 + POSITION_ERROR / d, d / 3.0 * F3 + 4.0 * POSITION_ERROR / d ** 2
        F2 = np.minimum(_leibniz(Rot, V, 2), np.linalg.norm(at.d2, axis=1) + e2 + F3 * ws)
        F1 = np.minimum(centroid + _leibniz(Rot, V, 1), np.linalg.norm(at.d1, axis=1) + e1 + F2 * ws)
        f = at.d1 * s2[:, None] + at.d2 * (s1 ** 2)[:, None] + np.array([0.0, 0.0, GRAVITY])
        error = e2 * s1 ** 2 + e1 * np.abs(s2)
        df = (F3 * S1 ** 3 + 3.0 * F2 * S1 * S2 + F1 * S3) * half + error
        dn = turn * S1 * half
    fn = np.einsum('ni,ni->n', f, at.n)
    ft = np.linalg.norm(f - fn[:, None] * at.n, axis=1)

    def within(spread: Array) -> Array:
        below = mu * (fn - spread) + hold
        with np.errstate(divide='ignore', invalid='ignore'):
            b = np.where(below > 0, (ft + spread) / below, np.inf)
        return np.asarray(np.where(np.isnan(b), np.inf, b), dtype=np.float64)

    with np.errstate(divide='ignore', invalid='ignore'):
        ratio = np.where(mu * fn + hold > 0, ft / (mu * fn + hold), np.inf)
    return ratio, within((np.linalg.norm(f, axis=1) + df) * dn + df), within(error)


def _jerk(plan: ProgramPlan, m: NDArray[np.int64], t0: Array, t1: Array) -> Array:
    """The S-curve's ``|s'''|`` on ``[t0, t1]`` of move ``m``: ``J`` on a jerk ramp, 0 on a constant acceleration or
    the cruise (and on a trapezoid's pieces: its jumps are on the instants). The corners are instants to within
    :data:`CORNER_SLACK` of the doubles' spacing: off a ramp ``s'''`` is taken as ``J`` over that much of the interval
    (``J`` times its share of the half; a cruise of 1e5 s between 200,000 instants took ``J`` throughout: its bound was
    infinite)."""
    p = plan.timing.profiles
    j = np.where(np.isfinite(p.j[m]), p.j[m], 0.0)
    tau = 0.5 * (t0 + t1) - plan.timing.depart[m]
    u = np.minimum(tau, p.T[m] - tau)               # the braking half mirrors the start
    ramp = (u < p.tj[m]) | ((u >= p.tj[m] + p.tc[m]) & (u < p.ta[m]))
    sliver = np.minimum(CORNER_SLACK * np.spacing(np.maximum(np.abs(t0), np.abs(t1))), t1 - t0)
    return np.asarray(np.where(ramp, j, j * sliver / np.maximum(0.5 * (t1 - t0), sliver)), dtype=np.float64)


def _halves(plan: ProgramPlan, t0: Array, t1: Array, m: NDArray[np.int64], arms: Array
            ) -> tuple[Array, Array, Array]:
    """The ratio at the midpoints of ``[t0, t1]``, its bound over the intervals about the midpoints and its floor."""
    timing = plan.timing
    tm, half = 0.5 * (t0 + t1), 0.5 * (t1 - t0) + 4.0 * np.spacing(t1)
    s, s1, s2 = evaluate(timing.profiles, m, tm - timing.depart[m])
    S3 = _jerk(plan, m, t0, t1)
    S = (s1 + np.abs(s2) * half + 0.5 * S3 * half ** 2, np.abs(s2) + S3 * half, S3)
    return bound_about(plan, m, anchors(plan, m, s, arms), arms, s1, s2, half, S)


def _ends(plan: ProgramPlan, t0: Array, t1: Array, m: NDArray[np.int64], arms: Array) -> tuple[Array, Array]:
    """The bound over ``[t0, t1]`` and its floor from its ends, each covering the half next to it (``s''`` is linear
    in between, or constant on a trapezoid's piece: the midpoint's, whichever side of a jump an end took)."""
    timing = plan.timing
    K = m.shape[0]
    t, mm, aa = np.concatenate([t0, t1]), np.concatenate([m, m]), np.concatenate([arms, arms])
    # an instant is shared by the intervals on either side, on one move (a move's end is the next one's start too)
    _, first, back = np.unique(np.stack([t, mm.astype(float)], axis=1), axis=0, return_index=True,
                               return_inverse=True)
    s, s1, s2 = evaluate(timing.profiles, mm, t - timing.depart[mm])
    at = anchors(plan, mm[first], s[first], aa[first])
    at = Anchors(*(getattr(at, name)[back.ravel()] for name in Anchors.__dataclass_fields__))
    mid = evaluate(timing.profiles, m, 0.5 * (t0 + t1) - timing.depart[m])[2]
    side = np.where(np.isfinite(timing.profiles.j[mm]), s2, np.concatenate([mid, mid]))
    S3 = _jerk(plan, m, t0, t1)
    S1 = np.maximum(s1[:K], s1[K:]) + S3 * (t1 - t0) ** 2 / 8.0
    S2 = np.maximum(np.abs(side[:K]), np.abs(side[K:]))
    half = 0.5 * (t1 - t0) + 4.0 * np.spacing(t1)
    twice = (np.concatenate([S1, S1]), np.concatenate([S2, S2]), np.concatenate([S3, S3]))
    _, bound, floor = bound_about(plan, mm, at, aa, s1, side, np.concatenate([half, half]), twice)
    return np.maximum(bound[:K], bound[K:]), np.maximum(floor[:K], floor[K:])


def slip_bound(plan: ProgramPlan, times: Array, ratio: Array, carrying: Array,
               progress: Callable[[float], None] | None = None) -> SlipBound:
    """The bound on every interval between consecutive ``times`` (the slip check's instants, sorted; ``ratio`` there,
    NaN where no wafer is carried) that lies in a joint-space move with the wafer on one arm throughout (module
    docstring); ``carrying`` the arm at each instant ('' none). The forward kinematics to
    :data:`~gpr_kinematics.safety.slip.CLOSURE_TOLERANCE`. ``progress``: the share done after the intervals' first
    bounds (a half) and after each round of refinement (the share of their time settled)."""
    plan = closure_exact(plan)
    timing = plan.timing
    empty = np.zeros(0)
    if times.shape[0] < 2 or not len(timing.duration):
        return SlipBound(empty, empty, np.zeros(0, dtype=np.int64), empty, empty, empty, empty, True)
    t0, t1 = times[:-1], times[1:]
    _, held, m, _ = locate(timing, 0.5 * (t0 + t1))
    joint_space = ~np.isin(m, line_moves(plan.waypoints)) & np.isfinite(timing.profiles.v[m])
    keep = ~held & joint_space & (carrying[:-1] != '') & (carrying[:-1] == carrying[1:])
    best = np.zeros(len(timing.duration))
    _, held_i, m_i, _ = locate(timing, times)
    on = ~np.isnan(ratio) & ~held_i
    np.maximum.at(best, m_i[on], ratio[on])
    a, b, mv, arm = t0[keep], t1[keep], m[keep], carrying[:-1][keep]
    bound, floor = _ends(plan, a, b, mv, arm)
    tell = progress if progress is not None else (lambda share: None)
    tell(0.5)
    out, mids = [], []
    added, closed, settled, total = 0, True, 0.0, float(np.sum(b - a))
    while a.size:
        loose = ~((bound <= best[mv] + SLIP_TOLERANCE) | (bound <= floor + 0.5 * SLIP_TOLERANCE))
        short = loose & (b - a < SHORTEST)
        closed &= not np.any(short)
        loose &= ~short
        room = max(MAX_REFINEMENTS - added, 0) // 2
        if int(np.sum(loose)) > room:   # the loosest first, as many as the budget allows (none were, before)
            closed = False
            idx = np.flatnonzero(loose)
            loose[:] = False
            loose[idx[np.argsort(best[mv[idx]] - bound[idx], kind='stable')[:room]]] = True
        out.append((a[~loose], b[~loose], mv[~loose], bound[~loose], floor[~loose]))
        settled += float(np.sum(b[~loose] - a[~loose]))
        tell(0.5 + 0.5 * min(settled / total, 1.0) if total > 0.0 else 1.0)   # the share of the time settled
        c = 0.5 * (a[loose] + b[loose])
        a, b = np.concatenate([a[loose], c]), np.concatenate([c, b[loose]])
        mv, arm = np.tile(mv[loose], 2), np.tile(arm[loose], 2)
        if a.size:
            r, bound, floor = _halves(plan, a, b, mv, arm)
            mids.append((0.5 * (a + b), r))
            added += a.size
            np.maximum.at(best, mv, np.where(np.isfinite(r), r, 0.0))
    start, end, move, bnd, low = (np.concatenate(x) for x in zip(*out, strict=True)) if out else (empty,) * 5
    time, mid = (np.concatenate(x) for x in zip(*mids, strict=True)) if mids else (empty, empty)
    return SlipBound(start, end, np.asarray(move, dtype=np.int64), bnd, low, time, mid, closed)

"""A joint trajectory as the controller interpolates it: piecewise polynomials, their values, and how far each joint
travels between two instants, exactly (no ROS import).

:class:`Spline` holds, for every segment ``[t_i, t_{i+1}]`` and joint, the polynomial ``p(tau) = c0 + c1 tau + ... +
c5 tau^5`` in ``tau = t - t_i`` (linear, cubic or quintic: the coefficients of :mod:`.trajectory`'s docstring); after
the last knot the joints hold the last point.

**Travel** (:meth:`Spline.travel`). A joint's path length over ``[t0, t1]``, its total variation ``int |p'(t)| dt``,
is exact: on a segment the polynomial is monotone between consecutive real roots of ``p'`` (degree at most 4), so on
``[a, b]`` its variation is ``sum_k |p(x_{k+1}) - p(x_k)|`` over ``a``, the roots inside, ``b``; over several
segments the variations add (prefix sums). The roots are the eigenvalues of the companion matrix of ``p'(h x)``,
``x`` in ``[0, 1]`` (batched over segments and joints). No partition's sum exceeds the variation, so extra points (an
eigenvalue with a small imaginary part taken as real) never overstate it; a root rounded by ``delta = eps h`` loses
at most ``2 delta max|p'|`` near it, with ``|p'| <= delta max|p''| <= delta 32 max|p'| / h`` there (Markov's
inequality, degree 4 on an interval of length ``h``): at most ``64 eps^2 h max|p'|``. :data:`TRAVEL_SLACK` times
``h sum_k k |c_k| h^(k-1)`` (at least ``h max|p'|``) is added per segment touched: it covers ``eps`` up to 1e-5, a
thousand times the companion eigenvalues' rounding of a double root (about 1e-8). Between the ends ``q0``, ``q1`` a
joint stays within ``[(q0 + q1 - L) / 2, (q0 + q1 + L) / 2]`` (``L`` its travel: ``|q(t) - q0| + |q1 - q(t)| <= L``).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: Travel added per segment touched, relative to ``h sum_k k |c_k| h^(k-1)`` (module docstring).
TRAVEL_SLACK = 1e-8
#: An eigenvalue of ``p'(h x)`` whose imaginary part is at most this is taken as a root (an extra point is harmless).
IMAGINARY = 1e-6
#: Coefficients of ``p'(h x)`` below this fraction of the largest are taken as zero (the degree drops).
DEGREE_CUT = 1e-14
#: Intervals per chunk of :meth:`Spline.travel` (bounds its temporary arrays).
CHUNK = 20_000


def coefficients(p0: Array, v0: Array, a0: Array, p1: Array, v1: Array, a1: Array, h: Array,
                 degree: int) -> list[Array]:
    """``c0 .. c5`` of segments from their end points' positions, velocities and accelerations (:mod:`.trajectory`'s
    docstring); ``h`` broadcasts against the joints. Values near the float range overflow to inf or NaN, without a
    warning: a goal's check refuses such a spline (:func:`~gpr_kinematics.robot.controller.plan_motion`)."""
    D = p1 - p0
    zero = np.zeros_like(D)
    with np.errstate(over='ignore', invalid='ignore'):
        if degree == 1:
            return [p0, D / h, zero, zero, zero, zero]
        if degree == 3:
            return [p0, v0, (3.0 * D / h - 2.0 * v0 - v1) / h, (-2.0 * D / h + v0 + v1) / h ** 2, zero, zero]
        h2 = h * h
        return [p0, v0, 0.5 * a0,
                (20.0 * D - (8.0 * v1 + 12.0 * v0) * h - (3.0 * a0 - a1) * h2) / (2.0 * h2 * h),
                (-30.0 * D + (14.0 * v1 + 16.0 * v0) * h + (3.0 * a0 - 2.0 * a1) * h2) / (2.0 * h2 * h2),
                (12.0 * D - 6.0 * (v1 + v0) * h + (a1 - a0) * h2) / (2.0 * h2 * h2 * h)]


def unit_roots(b: Array) -> Array:
    """The real roots in ``[0, 1]`` of the polynomials ``sum_j b_j x^j`` (rows of ``b (M, 5)``), sorted, padded with
    ``inf`` ``(M, 4)`` (module docstring: near-real eigenvalues count as roots)."""
    M = b.shape[0]
    out = np.full((M, 4), np.inf)
    scale = np.max(np.abs(b), axis=1, initial=0.0)
    big = np.abs(b) > DEGREE_CUT * scale[:, None]
    degree = np.where(big.any(axis=1), 4 - np.argmax(big[:, ::-1], axis=1), 0)
    for d in range(1, 5):
        rows = np.flatnonzero(degree == d)
        if not rows.size:
            continue
        companion = np.zeros((rows.size, d, d))
        companion[:, 0, :] = -b[rows, d - 1::-1] / b[rows, d:d + 1]
        companion[:, np.arange(1, d), np.arange(d - 1)] = 1.0
        eig = np.linalg.eigvals(companion)
        x = np.real(eig)
        keep = (np.abs(np.imag(eig)) <= IMAGINARY) & (x >= 0.0) & (x <= 1.0)
        out[rows, :d] = np.where(keep, x, np.inf)
    return np.sort(out, axis=1)


def _horner(c: Array, x: Array) -> Array:
    """``sum_k c_k x^k`` for ``c (K, 6, J)`` at ``x (K, J, P)``: ``(K, J, P)``."""
    out = c[:, 5, :, None] * x
    for k in range(4, 0, -1):
        out = (out + c[:, k, :, None]) * x
    return np.asarray(out + c[:, 0, :, None], dtype=np.float64)


@dataclass(frozen=True)
class Spline:
    """Segments ``S = n - 1`` over joints ``J``: ``knots (n,)`` [s], ``coefficients (S, 6, J)`` in ``tau = t - t_i``,
    ``last (3, J)`` the last point's position, velocity and acceleration (module docstring)."""

    knots: Array
    coefficients: Array
    last: Array

    @classmethod
    def of(cls, time: Array, P: Array, V: Array, A: Array, degree: int) -> Spline:
        """The spline through points ``time (n,)``, positions, velocities, accelerations ``(n, J)`` of ``degree`` 1, 3
        or 5."""
        h = np.diff(time)[:, None]
        c = coefficients(P[:-1], V[:-1], A[:-1], P[1:], V[1:], A[1:], h, degree)
        return cls(np.asarray(time, dtype=np.float64), np.stack(c, axis=1), np.stack([P[-1], V[-1], A[-1]]))

    def evaluate(self, t: Array) -> tuple[Array, Array, Array]:
        """Positions, velocities and accelerations ``(K, J)`` at times ``t (K,)`` [s]; at and after the last knot the
        last point (its own velocity and acceleration at its instant, zero after)."""
        t = np.asarray(t, dtype=float)
        n = self.knots.shape[0]
        i = np.clip(np.searchsorted(self.knots, t, side='right') - 1, 0, n - 1)
        J = self.last.shape[1]
        if n > 1:
            c = self.coefficients[np.minimum(i, n - 2)]
            c = [c[:, k] for k in range(6)]
            tau = np.maximum(t - self.knots[i], 0.0)[:, None]
            pos = c[0] + tau * (c[1] + tau * (c[2] + tau * (c[3] + tau * (c[4] + tau * c[5]))))
            vel = c[1] + tau * (2.0 * c[2] + tau * (3.0 * c[3] + tau * (4.0 * c[4] + tau * 5.0 * c[5])))
            acc = 2.0 * c[2] + tau * (6.0 * c[3] + tau * (12.0 * c[4] + tau * 20.0 * c[5]))
        else:
            pos = vel = acc = np.zeros((t.shape[0], J))
        after = (i == n - 1)[:, None]
        exact = (t == self.knots[-1])[:, None]
        pos = np.where(after, self.last[0], pos)
        vel = np.where(after, np.where(exact, self.last[1], 0.0), vel)
        acc = np.where(after, np.where(exact, self.last[2], 0.0), acc)
        return pos, vel, acc

    @cached_property
    def _segments(self) -> tuple[Array | None, Array, Array]:
        """Per segment and joint: the turning points ``(S, J, 4)`` [s from the segment's start] (``inf``: none; None
        for a linear spline, which has none), the slack ``(S, J)`` and the prefix sums of the whole segments' travel
        ``(S + 1, J)``."""
        S, _, J = self.coefficients.shape
        h = np.diff(self.knots)
        if not np.any(self.coefficients[:, 2:]):   # linear (a lagging motion's 200,000 corners: 3 s -> 0.1 s)
            slack = TRAVEL_SLACK * h[:, None] * np.abs(self.coefficients[:, 1])
            whole = self._partial(np.arange(S), np.zeros(S), h, None, slack)
            return None, slack, np.vstack([np.zeros((1, J)), np.cumsum(whole, axis=0)])
        powers = h[:, None] ** np.arange(5)[None, :]                                             # (S, 5)
        b = np.arange(1, 6)[None, :, None] * self.coefficients[:, 1:, :] * powers[:, :, None]    # (S, 5, J)
        roots = unit_roots(np.swapaxes(b, 1, 2).reshape(S * J, 5)).reshape(S, J, 4) * h[:, None, None]
        slack = TRAVEL_SLACK * h[:, None] * np.sum(np.abs(b), axis=1)
        seg = np.arange(S)
        whole = self._partial(seg, np.zeros(S), h, roots, slack)
        return roots, slack, np.vstack([np.zeros((1, J)), np.cumsum(whole, axis=0)])

    def _partial(self, seg: NDArray[np.intp], a: Array, b: Array, roots: Array | None, slack: Array) -> Array:
        """The travel ``(K, J)`` of segments ``seg`` on ``[a, b]`` (``tau``, ``a <= b``; ``roots`` None: linear)."""
        if roots is None:
            return np.asarray(np.abs(self.coefficients[seg, 1]) * (b - a)[:, None] + slack[seg] * (b > a)[:, None],
                              dtype=np.float64)
        lo, hi = a[:, None, None], b[:, None, None]
        x = np.concatenate([np.broadcast_to(lo, roots[seg].shape[:2] + (1,)), np.clip(roots[seg], lo, hi),
                            np.broadcast_to(hi, roots[seg].shape[:2] + (1,))], axis=2)
        p = _horner(self.coefficients[seg], x)
        return np.asarray(np.sum(np.abs(np.diff(p, axis=2)), axis=2) + slack[seg] * (b > a)[:, None],
                          dtype=np.float64)

    def travel(self, t0: Array, t1: Array) -> Array:
        """Every joint's path length ``(K, J)`` over ``[t0, t1]`` (``t0 <= t1``, ``(K,)`` [s]; module docstring), never
        below the true one."""
        t0, t1 = np.asarray(t0, dtype=float), np.asarray(t1, dtype=float)
        n, J = self.knots.shape[0], self.last.shape[1]
        out = np.zeros((t0.shape[0], J))
        if n < 2:
            return out
        roots, slack, prefix = self._segments
        h = np.diff(self.knots)
        for k in range(0, t0.shape[0], CHUNK):
            a = np.clip(t0[k:k + CHUNK], self.knots[0], self.knots[-1])
            b = np.clip(t1[k:k + CHUNK], self.knots[0], self.knots[-1])
            s0 = np.clip(np.searchsorted(self.knots, a, side='right') - 1, 0, n - 2)
            s1 = np.maximum(np.clip(np.searchsorted(self.knots, b, side='left') - 1, 0, n - 2), s0)
            tau0, tau1 = a - self.knots[s0], b - self.knots[s1]
            same = s0 == s1
            first = self._partial(s0, tau0, np.where(same, np.maximum(tau1, tau0), h[s0]), roots, slack)
            rest = np.where(same[:, None], 0.0, prefix[s1] - prefix[np.minimum(s0 + 1, n - 1)]
                            + self._partial(s1, np.zeros(s1.shape), np.where(same, 0.0, tau1), roots, slack))
            out[k:k + CHUNK] = first + rest
        return out

"""Bounds of a straight line's joint derivatives: the rates (what the clearance certificate and the velocity limits
need) and the second and third derivatives (the acceleration and jerk limits of a straight entry), over the whole
line rather than sampled.

On a line the wafer's heading is fixed, so the reduced two-link chain's target ``w(s) = w_0 + s w'`` moves on a line
(:func:`line_rate_bounds`: links of lengths ``L1``, ``L2`` at the angles ``A1``,
``A2``, ``g = A2 - A1``, ``u(A) = (cos A, sin A)``; the shoulder turns by ``A1``, the elbow by ``g``, the wrist by
``-A2``; a held joint not at all). Crossing ``L1 u(A1) + L2 u(A2) = w`` and its derivatives with the links' normals:

    ``L1 A1' sin g = w' . u(A2)``,  ``-L2 A2' sin g = w' . u(A1)``
    ``A1'' = (L1 A1'^2 cos g + L2 A2'^2) / (L1 sin g)``,  ``A2'' = -(L1 A1'^2 + L2 A2'^2 cos g) / (L2 sin g)``

and their derivative for ``A'''`` give the exact derivatives wherever the angles are known: in closed form (the
two-link problem of ``w(s)``) at :data:`REFINE` points per piece of the caller's grid. Between two points ``a``,
``b`` a derivative ``f`` is at most ``max(|f(a)|, |f(b)|) + (b - a) / 2 max |f'|`` (the mean value
theorem from either end), and ``max |f'|`` on the piece is bounded from the piece's least ``|sin g|`` and the rate
bounds by the Leibniz rule on the first identity, ``sum_i C(k, i) A1^(1+i) (sin g)^(k-i) = w' . u(A2)^(k) / L1``,
with ``|u(A)^(k)|`` and ``|(sin g)^(k)|`` at most the complete Bell polynomial ``Y_k`` of the bounds of the angle's
derivatives (Faa di Bruno for ``exp(i A)``). Near a stretched or folded posture that bound is loose: a piece whose
bound is well above the line's exact values is split and its parts bounded the same way (:data:`TIGHT`). SI units:
rad per unit of the line parameter ``s`` and its powers.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .arm_chain import chain_forward
from .description import Arm
from .planar_arm import two_link_axes

Array = NDArray[np.float64]


def bell(x: list[Array], k: int) -> Array:
    """The complete Bell polynomial ``Y_k(x_1, .., x_k)`` (``x[i - 1]`` is ``x_i``; ``k <= 4``): with ``x_i`` bounds of
    ``|A^(i)|``, a bound of ``|d^k exp(i A) / ds^k|``."""
    x1 = x[0]
    if k == 1:
        return x1
    x2 = x[1]
    if k == 2:
        return x1 * x1 + x2
    x3 = x[2]
    if k == 3:
        return x1 ** 3 + 3.0 * x1 * x2 + x3
    return x1 ** 4 + 6.0 * x1 * x1 * x2 + 4.0 * x1 * x3 + 3.0 * x2 * x2 + x[3]


def line_rate_bounds(arm: Arm, theta0: Array, theta1: Array, s0: Array, s1: Array) -> Array:
    """Upper bounds ``(K, n)`` of ``|d theta_k / ds|`` over ``[s0_i, s1_i]`` on the straight line that translates the
    wafer, its heading fixed, from the posture ``theta0 (n,)`` (``s = 0``) to ``theta1 (n,)`` (``s = 1``).

    The heading is fixed, so the reduced chain's wrist axis (:func:`sub_chain`: shoulder, elbow, wrist after folding a
    held joint) moves on a line too, ``w(s) = w_0 + s (w_1 - w_0)`` from the shoulder axis, and only the two-link
    problem changes along it. With ``a_1``, ``a_2`` the two links (lengths ``L1``, ``L2``, relative angle ``g``),
    ``w' = A1' a_1^perp + A2' a_2^perp`` for the links' directions ``A1``, ``A2``; crossing with ``a_2``, ``a_1`` and
    ``a_1 + a_2 = w``:

        ``|A1'| <= |w'| / (L1 |sin g|)``, ``|A2' - A1'| <= |w'| r / (L1 L2 |sin g|)``, ``|A2'| <= |w'| / (L2 |sin g|)``

    for the shoulder, the elbow and the wrist (which turns by ``-A2'``: the heading is fixed); a held joint does not
    move. On ``[s0, s1]`` :func:`reach_range` gives the largest ``r`` and the least ``|sin g|``. A line through a
    stretched or folded posture (``sin g = 0``) has an infinite bound.
    """
    keep, sh, el, wr, L1, L2 = sub_chain(arm, np.stack([theta0, theta1]))
    w0, dw = wr[0] - sh[0], (wr[1] - sh[1]) - (wr[0] - sh[0])
    s0, s1 = np.minimum(s0, s1), np.maximum(s0, s1)
    speed = float(np.hypot(*dw))
    hi, sg = reach_range(w0, dw, s0, s1, L1, L2)
    with np.errstate(divide='ignore', invalid='ignore'):
        rates = [speed / (L1 * sg), speed * np.sqrt(hi) / (L1 * L2 * sg), speed / (L2 * sg)]
    out = np.zeros((s0.shape[0], len(arm.joints)))
    for k, rate in zip(keep, rates, strict=True):
        out[:, k] = np.where(speed > 0.0, rate, 0.0)
    return out


def sub_chain(arm: Arm, rows: Array) -> tuple[list[int], Array, Array, Array, float, float]:
    """The reduced two-link chain of postures ``rows (P, n)``: the joints that move on a line (shoulder, elbow, wrist
    after folding a held joint), their axes ``(P, 2)`` in the mount frame and the two links' lengths [m]."""
    axes, _, _ = chain_forward(arm, rows)
    keep = two_link_axes(arm)
    sh, el, wr = (axes[:, k] for k in keep)
    return keep, sh, el, wr, float(np.hypot(*(el[0] - sh[0]))), float(np.hypot(*(wr[0] - el[0])))


def reach_range(w0: Array, dw: Array, s0: Array, s1: Array, L1: float, L2: float) -> tuple[Array, Array]:
    """On the pieces ``[s0, s1]`` of the line ``w(s) = w0 + s dw``: the largest ``r^2 = |w|^2`` and the least
    ``|sin g|`` of the two-link chain of links ``L1``, ``L2`` reaching it. ``r^2(s)`` is a convex quadratic, so its
    range is exact, and ``sin^2 g = ((L1 + L2)^2 - r^2)(r^2 - (L1 - L2)^2) / (2 L1 L2)^2`` is concave in ``r^2``: its
    minimum is at an end of that range."""
    sq = float(dw @ dw)
    star = np.clip(-float(w0 @ dw) / sq, s0, s1) if sq > 0.0 else s0
    lo, hi = _r2(w0, dw, star), np.maximum(_r2(w0, dw, s0), _r2(w0, dw, s1))
    sin2 = np.minimum(*(((L1 + L2) ** 2 - x) * (x - (L1 - L2) ** 2) for x in (lo, hi))) / (2.0 * L1 * L2) ** 2
    return hi, np.sqrt(np.maximum(sin2, 0.0))


#: The derivatives are evaluated exactly at this many points per piece of the caller's grid (the pieces' bounds of
#: the next derivative then count for 1/32 of the width).
REFINE = 32
#: A piece whose bound exceeds the largest exact value of the line by more than ``TIGHT`` is split into ``FINER``
#: parts, each bounded as the pieces are (its own least ``|sin g|``) from ``PARTS`` points, at most ``ROUNDS`` times:
#: near a stretched or folded posture a piece's bound of the next derivative is loose.
TIGHT, FINER, ROUNDS, PARTS = 0.05, 8, 2, 8


def _exact(t: Array, w0: Array, dw: Array, L1: float, L2: float, branch: float) -> tuple[Array, Array]:
    """The exact ``|d^2/ds^2|`` and ``|d^3/ds^3|`` ``(len(t), 3)`` of the shoulder, elbow and wrist at ``t``: the
    angles of the two-link problem of ``w(t) = w0 + t dw`` in closed form on the ``branch`` (sign of ``sin g``), then
    the identities of the module docstring (NaN or infinite at a stretched or folded posture)."""
    wx, wy = w0[0] + t * dw[0], w0[1] + t * dw[1]
    r2 = wx * wx + wy * wy
    cg = np.clip((r2 - L1 * L1 - L2 * L2) / (2.0 * L1 * L2), -1.0, 1.0)
    sg = branch * np.sqrt(np.maximum(1.0 - cg * cg, 0.0))
    A1 = np.arctan2(wy, wx) - np.arctan2(L2 * sg, L1 + L2 * cg)
    A2 = A1 + np.arctan2(sg, cg)
    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
        a1 = (dw[0] * np.cos(A2) + dw[1] * np.sin(A2)) / (L1 * sg)
        a2 = -(dw[0] * np.cos(A1) + dw[1] * np.sin(A1)) / (L2 * sg)
        b1 = (L1 * a1 * a1 * cg + L2 * a2 * a2) / (L1 * sg)
        b2 = -(L1 * a1 * a1 + L2 * a2 * a2 * cg) / (L2 * sg)
        gp = a2 - a1
        c1 = (2.0 * L1 * a1 * b1 * cg - L1 * a1 * a1 * sg * gp + 2.0 * L2 * a2 * b2 - b1 * L1 * cg * gp) / (L1 * sg)
        c2 = -(2.0 * L1 * a1 * b1 + 2.0 * L2 * a2 * b2 * cg - L2 * a2 * a2 * sg * gp + b2 * L2 * cg * gp) / (L2 * sg)
    # the shoulder turns by A1, the elbow by g, the wrist by -A2
    return np.abs(np.column_stack([b1, b2 - b1, -b2])), np.abs(np.column_stack([c1, c2 - c1, -c2]))


def _piece_bounds(w0: Array, dw: Array, L1: float, L2: float, branch: float, a: Array, b: Array, points: int
                  ) -> tuple[Array, Array, Array, Array]:
    """On the pieces ``[a, b]`` of the line: bounds ``(K, 3)`` of ``|d^2/ds^2|`` and ``|d^3/ds^3|`` of the shoulder,
    elbow and wrist (the largest exact value at a piece's ``points + 1`` evenly spaced points plus half a part times
    the bound of the next derivative on the piece), and the exact values ``(K (points + 1), 3)`` at those points."""
    K = a.shape[0]
    t = np.column_stack([a[:, None] + (b - a)[:, None] * (np.arange(points) / points), b]).ravel()
    exact2, exact3 = _exact(t, w0, dw, L1, L2, branch)
    speed = float(np.hypot(*dw))
    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
        # The least |sin g| and the rates on each piece (line_rate_bounds'), then A^(2..4).
        hi, S = reach_range(w0, dw, a, b, L1, L2)
        d1, d2 = [speed / (L1 * S)], [speed / (L2 * S)]  # bounds of |A1^(k)|, |A2^(k)|, k = 1, 2, ...
        dg = [speed * np.sqrt(hi) / (L1 * L2 * S)]  # of |g^(k)|
        for k in range(1, 4):  # A^(k+1) from the k-th derivative of L1 A1' sin g = w' . u(A2) (and of A2's)
            sink = [bell(dg, i) for i in range(1, k + 1)]  # |(sin g)^(i)|, i = 1..k
            rest1 = sum(math.comb(k, i) * d1[i] * sink[k - i - 1] for i in range(k))
            rest2 = sum(math.comb(k, i) * d2[i] * sink[k - i - 1] for i in range(k))
            d1.append((speed * bell(d2, k) / L1 + rest1) / S)
            d2.append((speed * bell(d1[:k], k) / L2 + rest2) / S)
            dg.append(d1[k] + d2[k])
        half = 0.5 * (b - a)[:, None] / points
        piece2 = exact2.reshape(K, points + 1, 3).max(axis=1) + half * np.column_stack([d1[2], dg[2], d2[2]])
        piece3 = exact3.reshape(K, points + 1, 3).max(axis=1) + half * np.column_stack([d1[3], dg[3], d2[3]])
    return piece2, piece3, exact2, exact3


def line_derivative_bounds(arm: Arm, rows: Array, s: Array) -> tuple[Array, Array]:
    """Bounds ``(G2, G3)`` ``(n,)`` of ``max |d^2 theta_k / ds^2|`` and ``max |d^3 theta_k / ds^3|`` over the line
    whose joint rows ``rows (P, n)`` (``arm``'s joints, solved on the line) are taken at the increasing ``s (P,)``
    spanning it (module docstring): the two-link sub-chain's angles in closed form at :data:`REFINE` points per piece
    of ``s``, their exact derivatives there, and each piece's bound of the next one for its parts; the pieces whose
    bound is loose (:data:`TIGHT`) split and bounded again. Infinite where the line passes through a stretched or
    folded posture."""
    keep, sh, el, wr, L1, L2 = sub_chain(arm, rows)
    n = len(arm.joints)
    w = wr - sh
    dw = (w[-1] - w[0]) / (s[-1] - s[0])
    w0 = w[0] - s[0] * dw
    if float(np.hypot(*dw)) == 0.0:  # the sub-chain does not move (a line of no length): nor do its joints
        return np.zeros(n), np.zeros(n)
    g_rows = np.arctan2(wr[:, 1] - el[:, 1], wr[:, 0] - el[:, 0]) - np.arctan2(el[:, 1] - sh[:, 1],
                                                                               el[:, 0] - sh[:, 0])
    branch = 1.0 if np.median(np.sin(g_rows)) >= 0.0 else -1.0
    a, b = s[:-1], s[1:]
    piece2, piece3, exact2, exact3 = _piece_bounds(w0, dw, L1, L2, branch, a, b, REFINE)
    low2, low3 = np.fmax.reduce(exact2), np.fmax.reduce(exact3)  # values of the line (NaN left out): below its maxima
    for _ in range(ROUNDS):
        with np.errstate(invalid='ignore'):
            loose = np.isfinite(piece2).all(axis=1) & np.isfinite(piece3).all(axis=1) & (
                (piece2 > (1.0 + TIGHT) * low2).any(axis=1) | (piece3 > (1.0 + TIGHT) * low3).any(axis=1))
        if not loose.any():
            break
        edges = a[loose, None] + (b - a)[loose, None] * (np.arange(FINER + 1) / FINER)
        sub_a, sub_b = edges[:, :-1].ravel(), edges[:, 1:].ravel()
        sub2, sub3, e2, e3 = _piece_bounds(w0, dw, L1, L2, branch, sub_a, sub_b, PARTS)
        low2, low3 = np.fmax(low2, np.fmax.reduce(e2)), np.fmax(low3, np.fmax.reduce(e3))
        # A part keeps the lesser of its own bound and its piece's (both bound it); the tight pieces stay as they are.
        sub2 = np.fmin(sub2, np.repeat(piece2[loose], FINER, axis=0))
        sub3 = np.fmin(sub3, np.repeat(piece3[loose], FINER, axis=0))
        a, b = np.concatenate([a[~loose], sub_a]), np.concatenate([b[~loose], sub_b])
        piece2, piece3 = np.vstack([piece2[~loose], sub2]), np.vstack([piece3[~loose], sub3])
    G2, G3 = np.zeros(n), np.zeros(n)
    G2[keep] = np.max(np.where(np.isnan(piece2), np.inf, piece2), axis=0)
    G3[keep] = np.max(np.where(np.isnan(piece3), np.inf, piece3), axis=0)
    return G2, G3


def _r2(w0: Array, dw: Array, t: Array) -> Array:
    """``|w(t)|^2`` of the target ``w(t) = w0 + t dw`` [m^2]."""
    return np.asarray((w0[0] + t * dw[0]) ** 2 + (w0[1] + t * dw[1]) ** 2, dtype=np.float64)

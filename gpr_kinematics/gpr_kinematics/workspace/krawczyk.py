"""Existence proofs for the solutions of closure equations over a whole box of outputs (Krawczyk's test).

Parametric Krawczyk test (R. Krawczyk, "Newton-Algorithmen zur Bestimmung von Nullstellen mit
Fehlerschranken", Computing 4, 1969; with interval parameters: A. Neumaier, "Interval Methods for Systems
of Equations", Cambridge University Press, 1990, section 5.1). For equations ``F(x, s) = 0`` (m equations,
m unknowns ``s``, parameters ``x`` in a box ``X``), a box ``S``, its midpoint-like point ``s~``, and *any*
real matrix ``C``::

    K(X, S) = s~ - C F(X, s~) + (I - C F_s(X, S)) (S - s~)

If ``K(X, S)`` lies in the interior of ``S`` then, for **every** ``x`` in ``X``, ``F(x, .)`` has exactly one
zero in ``S``, and it lies in ``K(X, S)``. (For a fixed ``x``, ``K(x, S)`` is inside ``K(X, S)``, and the
classical theorem applies: the map ``s -> s - C F(x, s)`` sends ``S`` into itself and is a contraction.)

Here everything is vectorised over boxes: a float Newton iteration at the box's midpoint finds ``s~``, ``C``
is the inverse of the Jacobian there, ``S`` is ``s~`` widened by the predicted motion of the solution over
``X`` (``|C F_x| rad X``, doubled) and, when the test fails, once more by epsilon-inflation of ``K``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .interval import Interval
from .tape import Tape

NEWTON_STEPS = 8
INFLATIONS = 2


def _solve(J: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Batched ``J^-1 F`` and the mask of (numerically) regular ``J``; singular ones give a zero step."""
    m = J.shape[-1]
    with np.errstate(all='ignore'):   # a diverging Newton's huge J: numpy's overflow warning was printed on stderr
        rows = np.linalg.norm(J, axis=2)
        det = np.abs(np.linalg.det(J)) / np.prod(np.maximum(rows, 1e-300), axis=1)
    ok = np.isfinite(det) & (det > 1e-12) & np.all(np.isfinite(F), axis=1)
    safe = np.where(ok[:, None, None], J, np.eye(m))
    step = np.linalg.solve(safe, np.where(ok[:, None], F, 0.0)[..., None])[..., 0]
    return step, ok


def _matvec(C: np.ndarray, v: Interval) -> Interval:
    """``C v`` for point matrices C (M, m, m) and interval vectors v (M, m), outward rounded."""
    prod = Interval(v.lo[:, None, :], v.hi[:, None, :]) * C
    out = Interval(prod.lo[:, :, 0], prod.hi[:, :, 0])
    for j in range(1, C.shape[2]):
        out = out + Interval(prod.lo[:, :, j], prod.hi[:, :, j])
    return out


def _imatvec(B: Interval, v: Interval) -> Interval:
    """``B v`` for interval matrices B (M, m, m) and interval vectors v (M, m)."""
    prod = B * Interval(v.lo[:, None, :], v.hi[:, None, :])
    out = Interval(prod.lo[:, :, 0], prod.hi[:, :, 0])
    for j in range(1, B.lo.shape[2]):
        out = out + Interval(prod.lo[:, :, j], prod.hi[:, :, j])
    return out


def newton(
    tape: Tape, point: np.ndarray, solved: Sequence[int], target: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Float Newton on ``roots(point) = target`` over the ``solved`` coordinates of ``point`` (N, n).

    Returns the improved points and the mask of converged ones (finite, regular, last step below 1e-12 of
    the coordinates' size).
    """
    p = point.copy()
    idx = list(solved)
    ok = np.ones(p.shape[0], dtype=bool)
    done = np.zeros(p.shape[0], dtype=bool)
    for _ in range(NEWTON_STEPS):
        rows = np.flatnonzero(ok & ~done)              # a converged point is left as it is: per-point results
        if rows.size == 0:
            break
        F, J = tape.jacobian_points(p[rows], idx)
        step, regular = _solve(J, F - target)
        ok[rows] &= regular
        with np.errstate(all='ignore'):                # a diverging point may overflow: not converged, no warning
            p[rows[:, None], np.array(idx)] -= step
            done[rows] = np.all(np.abs(step) <= 1e-12 * (1.0 + np.abs(p[rows][:, idx])), axis=1)
    return p, ok & done & np.all(np.isfinite(p), axis=1)


def krawczyk(
    tape: Tape,
    lo: np.ndarray,
    hi: np.ndarray,
    centre: np.ndarray,
    solved: Sequence[int],
    params: Sequence[int],
    target: Interval,
) -> tuple[np.ndarray, Interval]:
    """Prove, for every box, that ``roots = target`` has a unique solution in the ``solved`` coordinates for
    every value of the other coordinates in ``[lo, hi]`` (the parameters ``params`` vary over their
    intervals; the remaining coordinates are points ``lo == hi``).

    ``centre`` (M, n) holds a converged Newton point (its ``solved`` coordinates are ``s~``); ``target``
    encloses the right-hand sides (M, m). Returns the (M,) mask of proofs and the boxes ``K`` (M, m) that
    hold the solutions.
    """
    idx = list(solved)
    m = len(idx)
    s = centre[:, idx]
    _, J = tape.jacobian_points(centre, idx)
    _, regular = _solve(J, np.zeros((J.shape[0], m)))
    C = np.linalg.inv(np.where(regular[:, None, None], J, np.eye(m)))
    _, Jx = tape.jacobian_points(centre, list(params))
    rad_x = 0.5 * (hi[:, list(params)] - lo[:, list(params)])
    move = np.einsum('nij,nj->ni', np.abs(np.einsum('nij,njk->nik', C, Jx)), rad_x)
    r = 2.0 * move + 1e-12 * (1.0 + np.abs(s)) + 0.5 * np.einsum('nij,nj->ni', np.abs(C), target.hi - target.lo)
    # F(X, s~): the solved coordinates at the point s~, the parameters over their intervals
    flo, fhi = lo.copy(), hi.copy()
    flo[:, idx] = s
    fhi[:, idx] = s
    F, f_maybe, _ = tape.root_boxes(flo, fhi)
    CF = _matvec(C, F - target)
    proved = np.zeros(lo.shape[0], dtype=bool)
    K = Interval(s, s)
    S = Interval(s - r, s + r)
    for _ in range(INFLATIONS + 1):
        blo, bhi = lo.copy(), hi.copy()
        blo[:, idx] = S.lo
        bhi[:, idx] = S.hi
        Js, j_maybe = tape.jacobian_boxes(blo, bhi, idx)
        CJ = Interval(np.zeros_like(Js.lo), np.zeros_like(Js.hi))
        for j in range(m):                              # (C Js)_ik = sum_j C_ij Js_jk
            CJ = CJ + Interval(Js.lo[:, None, j, :], Js.hi[:, None, j, :]) * C[:, :, j, None]
        B = Interval(np.eye(m), np.eye(m)) - CJ
        K = _imatvec(B, S - s) - CF + s
        inside = np.all((K.lo > S.lo) & (K.hi < S.hi), axis=1) & ~j_maybe & ~f_maybe
        proved |= inside & regular & np.all(np.isfinite(K.lo) & np.isfinite(K.hi), axis=1)
        if proved.all():
            break
        # epsilon-inflation of the failed ones around K, keeping s~ inside S (the mean-value form needs the
        # segment from s~ to any point of S inside S); the proved keep their S, whose K is inside it
        with np.errstate(invalid='ignore'):  # an unbounded K's middle is NaN: so is its S, which no test proves
            mid = 0.5 * (K.lo + K.hi)
            rad = 0.5 * (K.hi - K.lo)
        grow = np.where(np.isfinite(rad), 1.5 * rad + 1e-12 * (1.0 + np.abs(mid)), 0.0)
        keep = proved[:, None]
        S = Interval(np.where(keep, S.lo, np.minimum(mid - grow, s)),
                     np.where(keep, S.hi, np.maximum(mid + grow, s)))
    return proved, K

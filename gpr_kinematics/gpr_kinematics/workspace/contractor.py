"""Forward-backward contraction of boxes on a system of constraints (HC4, vectorised over boxes).

HC4-revise (Benhamou, Goualard, Granvilliers and Puget, "Revising hull and box consistency", ICLP 1999),
here on the whole expression graph at once: a **forward** pass encloses every node over the box (interval
arithmetic, :func:`~.tape.interval_op`); each root is intersected with its bounds ``[lower, upper]``; a
**backward** pass, in reverse evaluation order, narrows the arguments of every node to the values that can
produce its (narrowed) range, down to the variables: e.g. ``y = u + v`` gives ``u in y - v``, ``y = cos u``
gives ``u in`` the preimage of ``y`` by cosine within ``u``. Every step is an outward-rounded enclosure
(a NaN bound, from ``inf - inf``, narrows nothing), so no point of the box that satisfies all constraints is
ever removed: a box contracted to nothing holds no solution (certified), and the contracted box holds all
the solutions the box held. The passes are repeated a fixed number of times (``sweeps``), so each box's
result depends on that box only.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .interval import Interval, tan_branch
from .tape import Tape, interval_op

_HALF_PI_BELOW = 1.5707963267948  # below the real pi/2 by ~1.7e-14: tan is finite and increasing up to it
_TWO_PI = 2.0 * np.pi
_TURNS = 4  # the preimage of cos is looked for over at most this many turns


def contract(
    tape: Tape, lo: np.ndarray, hi: np.ndarray, lower: np.ndarray, upper: np.ndarray, sweeps: int = 2
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contract boxes ``[lo, hi]`` (M, nvars) on ``lower <= root_j <= upper_j`` (bounds (roots,), +-inf allowed).

    Returns the contracted ``(lo, hi)`` and the (M,) mask of boxes proved to hold no solution (also those
    where some constraint is undefined at every point).
    """
    lo = lo.copy()
    hi = hi.copy()
    m = lo.shape[0]
    empty = np.zeros(m, dtype=bool)
    with np.errstate(all='ignore'):
        for _ in range(sweeps):
            dom_lo: list[np.ndarray] = [lo[:, i] for i in range(tape.nvars)]
            dom_hi: list[np.ndarray] = [hi[:, i] for i in range(tape.nvars)]
            for k in range(tape.nvars, tape.size):
                args = [Interval(dom_lo[j], dom_hi[j]) for j in tape.args[k]]
                v, _, surely = interval_op(tape.ops[k], args, tape.consts.get(k))
                empty |= surely
                # inf - inf (a bound at infinity) gives NaN: the whole line, never a false 'empty'
                dom_lo.append(np.where(np.isnan(v.lo), -np.inf, np.broadcast_to(v.lo, (m,))))
                dom_hi.append(np.where(np.isnan(v.hi), np.inf, np.broadcast_to(v.hi, (m,))))
            for j, r in enumerate(tape.roots):
                dom_lo[r] = np.maximum(dom_lo[r], lower[j])
                dom_hi[r] = np.minimum(dom_hi[r], upper[j])
            for k in range(tape.size - 1, tape.nvars - 1, -1):
                op = tape.ops[k]
                if op == 'const':
                    continue
                y = Interval(dom_lo[k], dom_hi[k])
                a = tape.args[k]
                narrowed = _backward(op, y, [Interval(dom_lo[j], dom_hi[j]) for j in a])
                for j, new in zip(a, narrowed, strict=True):
                    if new is not None:                 # fmax/fmin: a NaN bound narrows nothing
                        dom_lo[j] = np.fmax(dom_lo[j], new.lo)
                        dom_hi[j] = np.fmin(dom_hi[j], new.hi)
            for k in range(tape.size):
                empty |= ~(dom_lo[k] <= dom_hi[k])
            lo = np.stack(dom_lo[: tape.nvars], axis=1)
            hi = np.stack(dom_hi[: tape.nvars], axis=1)
            ok = ~empty
            lo[~ok], hi[~ok] = 0.0, 0.0                        # keep dead rows finite for the next sweep
    return lo, hi, empty


def _backward(op: str, y: Interval, a: list[Interval]) -> list[Interval | None]:
    """The narrowed arguments of ``y = op(a)`` (None: no narrowing)."""
    rule = _BACKWARD_RULES.get(op)
    if rule is None:  # pragma: no cover - every operation has one
        raise ValueError(f'no backward rule for {op}')
    return rule(y, a)


# -- arithmetic: solve y = u op v for u, then for v within the narrowed u ------------------------------------------
def _add_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    nu = y - a[1]
    return [nu, y - _cap(a[0], nu)]


def _sub_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    nu = y + a[1]
    return [nu, _cap(a[0], nu) - y]


def _mul_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    nu = y / a[1]
    return [nu, y / _cap(a[0], nu)]


def _div_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    nu = y * a[1]
    return [nu, _cap(a[0], nu) / y]


def _neg_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    return [-y]


# -- algebraic and exponential: the preimage over the function's domain ------------------------------------------
def _sqr_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    """``u^2 in y``: ``u in +-sqrt(y)``, the two branches hulled within ``u``."""
    root = Interval(np.maximum(y.lo, 0.0), np.maximum(y.hi, 0.0)).sqrt()
    return [_hull_of_pieces(a[0], [(root.lo, root.hi), (-root.hi, -root.lo)], y.hi < 0)]


def _sqrt_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    sq = Interval(np.maximum(y.lo, 0.0), np.maximum(y.hi, 0.0)).sqr()
    return [Interval(np.where(y.hi < 0, np.inf, np.maximum(sq.lo, 0.0)), sq.hi)]


def _exp_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    ln = Interval(np.maximum(y.lo, 0.0), y.hi).log()
    return [Interval(np.where(y.hi <= 0, np.inf, ln.lo), ln.hi)]


def _log_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    ex = y.exp()
    return [Interval(np.maximum(ex.lo, 0.0), ex.hi)]


def _abs_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    """``|u| in y``: ``u in +-y`` (its non-negative part), the two branches hulled within ``u``."""
    ylo = np.maximum(y.lo, 0.0)
    return [_hull_of_pieces(a[0], [(ylo, y.hi), (-y.hi, -ylo)], y.hi < 0)]


# -- inverse trigonometric: the range of the function bounds y, then the direct function --------------------------
def _arctan_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    t = Interval(np.maximum(y.lo, -_HALF_PI_BELOW), np.minimum(y.hi, _HALF_PI_BELOW)).tan()
    return [Interval(np.where(y.lo <= -_HALF_PI_BELOW, -np.inf, t.lo),
                     np.where(y.hi >= _HALF_PI_BELOW, np.inf, t.hi))]


def _arcsin_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    s = Interval(np.maximum(y.lo, -0.5 * np.pi), np.minimum(y.hi, 0.5 * np.pi)).sin()
    return [Interval(np.maximum(s.lo, -1.0), np.minimum(s.hi, 1.0))]


def _arccos_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    c = Interval(np.maximum(y.lo, 0.0), np.minimum(y.hi, np.pi)).cos()
    return [Interval(np.maximum(c.lo, -1.0), np.minimum(c.hi, 1.0))]


# -- trigonometric: periodic preimages within u ------------------------------------------------------------------
def _cos_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    return [_cos_preimage(a[0], y, 0.0)]


def _sin_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    return [_cos_preimage(a[0], y, 0.5 * np.pi)]                # sin u = cos(u - pi/2)


def _tan_inverse(y: Interval, a: list[Interval]) -> list[Interval | None]:
    return [_tan_preimage(a[0], y)]


_BACKWARD_RULES: dict[str, Callable[[Interval, list[Interval]], list[Interval | None]]] = {
    'add': _add_inverse, 'sub': _sub_inverse, 'mul': _mul_inverse, 'div': _div_inverse, 'neg': _neg_inverse,
    'sqr': _sqr_inverse, 'sqrt': _sqrt_inverse, 'exp': _exp_inverse, 'log': _log_inverse, 'abs': _abs_inverse,
    'arctan': _arctan_inverse, 'arcsin': _arcsin_inverse, 'arccos': _arccos_inverse,
    'cos': _cos_inverse, 'sin': _sin_inverse, 'tan': _tan_inverse,
}


def _cap(x: Interval, new: Interval) -> Interval:
    return Interval(np.maximum(x.lo, new.lo), np.minimum(x.hi, new.hi))


def _hull_of_pieces(u: Interval, pieces: list[tuple[np.ndarray, np.ndarray]], empty: np.ndarray) -> Interval:
    """Hull of the parts of ``u`` inside the pieces ``[lo, hi]``; an empty interval where none or ``empty``."""
    lo = np.full(np.shape(u.lo), np.inf)
    hi = np.full(np.shape(u.lo), -np.inf)
    for plo, phi in pieces:
        a = np.maximum(u.lo, plo)
        b = np.minimum(u.hi, phi)
        ok = a <= b
        lo = np.where(ok, np.minimum(lo, a), lo)
        hi = np.where(ok, np.maximum(hi, b), hi)
    return Interval(np.where(empty, np.inf, lo), np.where(empty, -np.inf, hi))


def _cos_preimage(u: Interval, y: Interval, shift: float) -> Interval:
    """Hull of ``{t in u : cos(t - shift) in y}``: the arcs ``+-[acos(y)] + 2 pi k`` (padded outward by more
    than the rounding of ``2 pi k``, ``shift`` and acos) that meet ``u``. ``u`` wider than ``_TURNS`` turns (or
    unbounded): no narrowing."""
    wide = ~((u.hi - u.lo) < (_TURNS - 1) * _TWO_PI)
    outside = (y.lo > 1.0) | (y.hi < -1.0)
    t = Interval(np.clip(y.lo, -1.0, 1.0), np.clip(y.hi, -1.0, 1.0)).arccos()     # [t1, t2] in [0, pi]
    k0 = np.floor(np.where(wide, 0.0, u.lo - shift) / _TWO_PI)
    pieces = []
    for dk in range(-1, _TURNS + 1):
        base = (k0 + dk) * _TWO_PI + shift
        pad = 1e-15 * (np.abs(base) + 8.0)
        pieces.append((base + t.lo - pad, base + t.hi + pad))
        pieces.append((base - t.hi - pad, base - t.lo + pad))
    out = _hull_of_pieces(u, pieces, outside & ~wide)
    return Interval(np.where(wide & ~outside, u.lo, out.lo), np.where(wide & ~outside, u.hi, out.hi))


def _tan_preimage(u: Interval, y: Interval) -> Interval:
    """Within one branch of tan (``u`` inside ``(-pi/2, pi/2) + k pi``): ``atan(y) + k pi``, the hull of the pieces
    of the branches ``k - 1 .. k + 1`` within ``u`` (the branch index of an end next to a pole may be one off by
    rounding); else no narrowing."""
    k_lo, one = tan_branch(u.lo, u.hi)
    at = y.arctan()
    pieces = []
    for dk in (-1, 0, 1):
        base = (k_lo + dk) * np.pi
        pad = 1e-15 * (np.abs(base) + 8.0)
        pieces.append((base + at.lo - pad, base + at.hi + pad))
    out = _hull_of_pieces(u, pieces, np.zeros(np.shape(u.lo), dtype=bool))
    return Interval(np.where(one, out.lo, -np.inf), np.where(one, out.hi, np.inf))

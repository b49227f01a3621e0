"""One pose of a generalized Stewart platform in float arithmetic (numpy's per-call overhead dominates a single
pose): each constraint type's joint value and inverse-Jacobian row, the formulas of :mod:`.gsp` (eqs. 2-6 and
12-16 of Toz & Kucuk 2016, as corrected there). Lengths in m, angles in rad.
"""
from __future__ import annotations

import math

Vec = tuple[float, ...]
Row = list[float] | None


def mul3(M: list[list[float]], x: Vec) -> tuple[float, float, float]:
    """``M x`` of a 3 x 3 matrix (nested lists) and a 3-vector."""
    return (M[0][0] * x[0] + M[0][1] * x[1] + M[0][2] * x[2],
            M[1][0] * x[0] + M[1][1] * x[1] + M[1][2] * x[2],
            M[2][0] * x[0] + M[2][1] * x[1] + M[2][2] * x[2])


def _cross3(a: Vec, b: Vec) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot3(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _scale3(a: Vec, f: float) -> tuple[float, float, float]:
    return (a[0] * f, a[1] * f, a[2] * f)


def _row_d1(R: list[list[float]], Rb: Vec, v: Vec, s: Vec, t: Vec, ct: str, jacobian: bool) -> tuple[float, Row]:
    """D1 (distance of two points): value and inverse-Jacobian row (float arithmetic)."""
    d = math.sqrt(_dot3(v, v))
    if not jacobian:
        return d, None
    f = 1.0 / d if d > 0 else math.inf
    return d, [*_scale3(v, f), *_scale3(_cross3(Rb, v), f)]


def _row_d23(R: list[list[float]], Rb: Vec, v: Vec, s: Vec, t: Vec, ct: str, jacobian: bool) -> tuple[float, Row]:
    """D2 (point to a platform line) and D3 (point to a base line)."""
    axis = mul3(R, t) if ct == 'D2' else s
    c = _cross3(v, axis)
    d = math.sqrt(_dot3(c, c))
    if not jacobian:
        return d, None
    f = 1.0 / d if d > 0 else math.inf
    w = _cross3(axis, c)
    ang = _cross3(Rb, w)
    if ct == 'D2':
        k = _dot3(v, axis)
        ang = (ang[0] + k * c[0], ang[1] + k * c[1], ang[2] + k * c[2])
    return d, [*_scale3(w, f), *_scale3(ang, f)]


def _row_d4(R: list[list[float]], Rb: Vec, v: Vec, s: Vec, t: Vec, ct: str, jacobian: bool) -> tuple[float, Row]:
    """D4 (distance of two lines)."""
    Rt = mul3(R, t)
    n = _cross3(Rt, s)
    g = math.sqrt(_dot3(n, n))
    fv = _dot3(v, n)
    if g > 0:
        value = abs(fv) / g
    else:                                   # parallel lines: their distance |v x s| (the row is not defined)
        c = _cross3(v, s)
        value = math.sqrt(_dot3(c, c))
    if not jacobian:
        return value, None
    sg = math.copysign(1.0, fv) if fv != 0 else 0.0
    gi = 1.0 / g if g > 0 else math.inf
    a1, a2 = _cross3(Rb, n), _cross3(Rt, _cross3(s, v))
    a3 = _cross3(Rt, _cross3(s, n))
    return value, [*_scale3(n, sg * gi)] + [sg * ((a1[i] + a2[i]) * gi - fv * a3[i] * gi ** 3) for i in range(3)]


def _row_a1(R: list[list[float]], Rb: Vec, v: Vec, s: Vec, t: Vec, ct: str, jacobian: bool) -> tuple[float, Row]:
    """A1 (angle of two lines): ``theta = atan2(|R t x s|, R t . s)`` and its row ``-(R t x s) / sin(theta)``,
    ``sin(theta) = |R t x s|`` (``acos(R t . s)`` lost the angle's digits below 1e-4 rad: 0 at 1e-8)."""
    Rt = mul3(R, t)
    c = _cross3(Rt, s)
    sin = math.hypot(*c)   # not sqrt(c . c): its square underflowed below 1e-154 rad
    value = math.atan2(sin, _dot3(Rt, s))
    if not jacobian:
        return value, None
    f = -1.0 / sin if sin > 0 else -math.inf
    return value, [0.0, 0.0, 0.0, *_scale3(c, f)]


#: Constraint type -> its value and row function (arguments ``R, R B_i, v, s, t, type, jacobian``).
SCALAR_ROWS = {'D1': _row_d1, 'D2': _row_d23, 'D3': _row_d23, 'D4': _row_d4, 'A1': _row_a1}

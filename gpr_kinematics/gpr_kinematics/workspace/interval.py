"""Vectorised interval arithmetic with outward rounding, for certified workspace covering.

An :class:`Interval` holds two float64 numpy arrays ``lo`` and ``hi`` of the same shape: one interval per
element, so one call bounds a function over thousands of boxes at once (the nonuniform covering method of
Posypkin, Rybak, Malyshev and Gaponenko, "Approximation of the parallel robot working area using the method
of nonuniform covering" (docs/references.md), evaluates "interval estimates" of the constraint functions over boxes; the
authors used the C++ library Snowgoose, this is the numpy equivalent).

Certification (outward rounding). Every operation returns an enclosure of the exact real range:

* ``+``, ``-``, ``*``, ``/`` and ``sqrt`` are correctly rounded in IEEE 754 (error <= 1/2 ulp), so moving the
  lower bound one float down and the upper bound one float up with ``np.nextafter`` encloses the exact
  result.
* ``sin``, ``cos``, ``tan``, ``arcsin``, ``arccos``, ``arctan``, ``exp`` and ``log`` come from libm / numpy
  SIMD kernels, which are not correctly rounded; their documented errors are a few ulp at most (glibc <= 2
  ulp, numpy's SIMD kernels <= 4 ulp). These results are widened by a relative ``2**-48`` (16 ulp) plus one
  ``nextafter``, a deliberate margin over the documented bounds; the tests check the enclosures against
  values correctly rounded by ``mpmath`` at 200 bits.
* Extrema inside an argument interval (``sin``, ``cos``, ``sqr`` across 0) are detected conservatively: when
  the test is uncertain by rounding, the extremum is assumed inside, which only widens the result.

The arithmetic is the natural interval extension, so an expression in which a variable occurs once gives
its exact range (up to rounding); repeated occurrences overestimate (the dependency effect the paper mentions),
which bisection reduces.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import numpy as np

from ..errors import InputError

if TYPE_CHECKING:
    from typing import Self  # Python 3.11; annotations only (postponed), so 3.10 imports this module too

_INF = np.inf
_REL_TRANSCENDENTAL = 2.0**-48
_TWO_PI = 2.0 * np.pi

Number = float | int | np.ndarray


class Arithmetic(Protocol):
    """What the workspace models' formulas use: :class:`Interval` and the symbolic expressions of
    :mod:`gpr_kinematics.workspace.expressions` both provide it, so one formula serves both."""

    def __add__(self, other: Any) -> Self: ...
    def __radd__(self, other: Any) -> Self: ...
    def __sub__(self, other: Any) -> Self: ...
    def __rsub__(self, other: Any) -> Self: ...
    def __mul__(self, other: Any) -> Self: ...
    def __rmul__(self, other: Any) -> Self: ...
    def __truediv__(self, other: Any) -> Self: ...
    def __neg__(self) -> Self: ...
    def sqr(self) -> Self: ...
    def sqrt(self) -> Self: ...
    def sin(self) -> Self: ...
    def cos(self) -> Self: ...
    def arctan(self) -> Self: ...


#: A value of the models' formulas: an Interval array or a symbolic expression.
T = TypeVar('T', bound=Arithmetic)


def down(x: np.ndarray) -> np.ndarray:
    """Next float towards -inf (one ulp down): outward rounding of a correctly rounded lower bound.

    Bit for bit ``np.nextafter(x, -inf)``, computed on the integer view of the floats (several times faster
    than ``nextafter``, which dominates the cost of interval arithmetic): a positive float's predecessor is
    its bit pattern minus one, a negative float's is its bit pattern plus one; 0 and -inf are special.
    """
    return _step(x, -1)


def up(x: np.ndarray) -> np.ndarray:
    """Next float towards +inf (one ulp up): outward rounding of a correctly rounded upper bound."""
    return _step(x, 1)


def _step(x: np.ndarray, direction: int) -> np.ndarray:
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim == 0:
        return np.asarray(np.nextafter(arr, direction * _INF))
    bits = np.ascontiguousarray(arr).view(np.int64)
    # sign bit set -> (bits >> 63) | 1 == -1, else 1: moves the magnitude down (direction -1) or up (+1)
    out = (bits + direction * ((bits >> 63) | 1)).view(np.float64)
    zero = arr == 0.0
    if zero.any():
        np.copyto(out, direction * 5e-324, where=zero)
    stuck = arr == direction * _INF
    if stuck.any():
        np.copyto(out, arr, where=stuck)
    return out


def _down_t(x: np.ndarray) -> np.ndarray:
    """Lower bound of a libm (not correctly rounded) result: 16 ulp relative margin plus one ulp."""
    return np.asarray(np.nextafter(x - np.abs(x) * _REL_TRANSCENDENTAL, -_INF))


def _up_t(x: np.ndarray) -> np.ndarray:
    return np.asarray(np.nextafter(x + np.abs(x) * _REL_TRANSCENDENTAL, _INF))


@dataclass(frozen=True, eq=False)
class Interval:
    """Array of closed intervals ``[lo, hi]`` (float64, any broadcastable shape).

    Build from bounds ``Interval(lo, hi)``, from exact points ``Interval.point(x)`` or from a decimal
    constant that is not a float, ``Interval.const(0.1)`` (one ulp either side). Arithmetic with plain
    numbers treats them as exact floats.
    """

    lo: np.ndarray
    hi: np.ndarray

    def __post_init__(self) -> None:
        lo = np.asarray(self.lo, dtype=float)
        hi = np.asarray(self.hi, dtype=float)
        object.__setattr__(self, 'lo', lo)
        object.__setattr__(self, 'hi', hi)

    # -- construction ------------------------------------------------------------------------------------
    @classmethod
    def point(cls, x: Number) -> Interval:
        """Degenerate interval(s) ``[x, x]`` of exactly representable floats."""
        arr = np.asarray(x, dtype=float)
        return cls(arr, arr)

    @classmethod
    def const(cls, x: float) -> Interval:
        """Enclosure of a real constant given as a float that may be rounded (e.g. pi, sqrt(3)/2, 0.1)."""
        arr = np.asarray(x, dtype=float)
        return cls(down(arr), up(arr))

    # -- properties ----------------------------------------------------------------------------------------
    @property
    def width(self) -> np.ndarray:
        return np.asarray(self.hi - self.lo)

    @property
    def mid(self) -> np.ndarray:
        return np.asarray(0.5 * (self.lo + self.hi))

    @property
    def shape(self) -> tuple[int, ...]:
        return np.broadcast_shapes(self.lo.shape, self.hi.shape)

    def contains(self, x: Number) -> np.ndarray:
        """Elementwise ``lo <= x <= hi``."""
        return np.asarray((self.lo <= x) & (x <= self.hi))

    def __getitem__(self, idx: Any) -> Interval:
        return Interval(np.broadcast_to(self.lo, self.shape)[idx], np.broadcast_to(self.hi, self.shape)[idx])

    def __repr__(self) -> str:
        return f'Interval(lo={self.lo!r}, hi={self.hi!r})'

    # -- arithmetic ----------------------------------------------------------------------------------------
    def __neg__(self) -> Interval:
        return Interval(-self.hi, -self.lo)

    # An operand that is neither an Interval nor a number (e.g. a symbolic expression of
    # gpr_kinematics.workspace.expressions) gets NotImplemented, so Python asks the operand instead.
    def __add__(self, other: Any) -> Interval:
        o = _as_interval(other)
        if o is None:
            return NotImplemented
        return Interval(down(self.lo + o.lo), up(self.hi + o.hi))

    __radd__ = __add__

    def __sub__(self, other: Any) -> Interval:
        o = _as_interval(other)
        if o is None:
            return NotImplemented
        return Interval(down(self.lo - o.hi), up(self.hi - o.lo))

    def __rsub__(self, other: Any) -> Interval:
        o = _as_interval(other)
        if o is None:
            return NotImplemented
        return o - self

    def __mul__(self, other: Any) -> Interval:
        if isinstance(other, (float, int)) and not isinstance(other, bool):
            a = float(other)
            if a == 0.0:
                zero = np.zeros(np.broadcast_shapes(self.lo.shape, self.hi.shape))
                return Interval(zero, zero)
            if a > 0.0:
                return Interval(down(self.lo * a), up(self.hi * a))
            return Interval(down(self.hi * a), up(self.lo * a))
        if isinstance(other, (np.ndarray, np.number)) and not isinstance(other, np.bool_):
            # exact points (e.g. a preconditioning matrix): two products chosen by sign instead of four
            c = np.asarray(other, dtype=float)
            pos = c >= 0.0
            with np.errstate(invalid='ignore'):
                a_lo, a_hi = self.lo * c, self.hi * c
            lo = np.where(pos, a_lo, a_hi)
            hi = np.where(pos, a_hi, a_lo)
            zero = c == 0.0                       # 0 times any real is exactly 0 (no 0 * inf)
            lo = np.where(zero, 0.0, np.where(np.isnan(lo), -_INF, down(lo)))
            hi = np.where(zero, 0.0, np.where(np.isnan(hi), _INF, up(hi)))
            return Interval(lo, hi)
        o = _as_interval(other)
        if o is None:
            return NotImplemented
        with np.errstate(invalid='ignore'):  # 0 * inf: NaN, taken as the whole line below
            p = (self.lo * o.lo, self.lo * o.hi, self.hi * o.lo, self.hi * o.hi)
        lo = np.minimum(np.minimum(p[0], p[1]), np.minimum(p[2], p[3]))
        hi = np.maximum(np.maximum(p[0], p[1]), np.maximum(p[2], p[3]))
        # 0 * inf never occurs in bounded boxes; guard NaN anyway (nan -> whole line).
        lo = np.where(np.isnan(lo), -_INF, lo)
        hi = np.where(np.isnan(hi), _INF, hi)
        return Interval(down(lo), up(hi))

    __rmul__ = __mul__

    def __truediv__(self, other: Any) -> Interval:
        o = _as_interval(other)
        if o is None:
            return NotImplemented
        return self * o.reciprocal()

    def __rtruediv__(self, other: Any) -> Interval:
        o = _as_interval(other)
        if o is None:
            return NotImplemented
        return o * self.reciprocal()

    def reciprocal(self) -> Interval:
        """``1/x``; an interval containing 0 gives ``[-inf, inf]``."""
        straddles = (self.lo <= 0.0) & (self.hi >= 0.0)
        with np.errstate(divide='ignore', over='ignore'):
            lo = np.where(straddles, -_INF, down(1.0 / self.hi))
            hi = np.where(straddles, _INF, up(1.0 / self.lo))
        return Interval(lo, hi)

    def sqr(self) -> Interval:
        """``x**2`` with the minimum 0 when the interval contains 0 (tighter than ``x*x``)."""
        a = self.lo * self.lo
        b = self.hi * self.hi
        hi = up(np.maximum(a, b))
        lo = np.where((self.lo <= 0.0) & (self.hi >= 0.0), 0.0, down(np.minimum(a, b)))
        return Interval(np.maximum(lo, 0.0), hi)

    def __pow__(self, n: int) -> Interval:
        if n == 2:
            return self.sqr()
        if not isinstance(n, (int, np.integer)) or n < 0:
            raise InputError(f'Interval ** n needs an integer n >= 0, got {n!r}')
        out = Interval.point(np.ones(self.shape))
        for _ in range(int(n)):
            out = out * self
        return out

    def abs(self) -> Interval:
        lo = np.where(self.lo >= 0, self.lo, np.where(self.hi <= 0, -self.hi, 0.0))
        hi = np.maximum(np.abs(self.lo), np.abs(self.hi))
        return Interval(lo, hi)

    def sqrt(self) -> Interval:
        """``sqrt(x)`` over the part of ``x`` that is >= 0 (the caller checks feasibility separately)."""
        lo = np.maximum(self.lo, 0.0)
        hi = np.maximum(self.hi, 0.0)
        return Interval(np.maximum(down(np.sqrt(lo)), 0.0), up(np.sqrt(hi)))

    # -- elementary functions --------------------------------------------------------------------------------
    def cos(self) -> Interval:
        """``cos`` with its maxima at ``2 pi k`` and minima at ``pi + 2 pi k`` detected conservatively."""
        return _periodic(self, np.cos, 0.0)

    def sin(self) -> Interval:
        """``sin`` (maxima at ``pi/2 + 2 pi k``, minima at ``-pi/2 + 2 pi k``)."""
        return _periodic(self, np.sin, 0.5 * np.pi)

    def tan(self) -> Interval:
        """``tan`` on intervals inside one branch ``(-pi/2, pi/2) + k pi``; otherwise the whole line.

        The branch test (:func:`tan_branch`) is conservative: an interval that may reach a pole by rounding
        gets the whole line (the float pi/2 lies below the real pole, so ``[1.5707963267948966, 2]`` crosses it).
        """
        ok = tan_branch(self.lo, self.hi)[1]
        with np.errstate(invalid='ignore', over='ignore'):
            lo = np.where(ok, _down_t(np.tan(self.lo)), -_INF)
            hi = np.where(ok, _up_t(np.tan(self.hi)), _INF)
        return Interval(lo, hi)

    def arcsin(self) -> Interval:
        """``arcsin`` over the part inside ``[-1, 1]``."""
        lo = np.clip(self.lo, -1.0, 1.0)
        hi = np.clip(self.hi, -1.0, 1.0)
        return _monotone_inc(np.arcsin, lo, hi, -0.5 * np.pi, 0.5 * np.pi)

    def arccos(self) -> Interval:
        """``arccos`` (decreasing) over the part inside ``[-1, 1]``."""
        lo = np.clip(self.lo, -1.0, 1.0)
        hi = np.clip(self.hi, -1.0, 1.0)
        top = up(np.asarray(np.pi))  # the float pi is below the real pi: one ulp up encloses it
        return Interval(np.maximum(_down_t(np.arccos(hi)), 0.0), np.minimum(_up_t(np.arccos(lo)), top))

    def arctan(self) -> Interval:
        return _monotone_inc(np.arctan, self.lo, self.hi, -0.5 * np.pi, 0.5 * np.pi)

    def log(self) -> Interval:
        """Natural logarithm over the part that is > 0 (``-inf`` as the lower bound when 0 is reached)."""
        with np.errstate(divide='ignore', invalid='ignore'):
            lo = np.where(self.lo > 0.0, _down_t(np.log(np.maximum(self.lo, 0.0))), -_INF)
            hi = np.where(self.hi > 0.0, _up_t(np.log(np.maximum(self.hi, 0.0))), -_INF)
        return Interval(lo, hi)

    def exp(self) -> Interval:
        with np.errstate(over='ignore'):
            return Interval(np.maximum(_down_t(np.exp(self.lo)), 0.0), _up_t(np.exp(self.hi)))

    def hull(self, other: Interval) -> Interval:
        return Interval(np.minimum(self.lo, other.lo), np.maximum(self.hi, other.hi))


def _as_interval(x: object) -> Interval | None:
    """An Interval as is, a number or array as a point interval, anything else None."""
    if isinstance(x, Interval):
        return x
    if isinstance(x, (int, float, np.ndarray, np.number)) and not isinstance(x, bool):
        return Interval.point(np.asarray(x, dtype=float))
    return None


def norm(*components: T) -> T:
    """Euclidean norm of a vector of intervals: ``sqrt(sum of squares)``, outward rounded."""
    total = components[0].sqr()
    for c in components[1:]:
        total = total + c.sqr()
    return total.sqrt()


def _monotone_inc(
    f: Callable[[np.ndarray], np.ndarray],
    lo: np.ndarray,
    hi: np.ndarray,
    fmin: float = -_INF,
    fmax: float = _INF,
) -> Interval:
    """Enclosure of an increasing libm function ``f`` on ``[lo, hi]`` (clipped to its known range)."""
    flo = _down_t(f(lo))
    fhi = _up_t(f(hi))
    return Interval(np.maximum(flo, down(np.asarray(fmin))), np.minimum(fhi, up(np.asarray(fmax))))


def monotone(
    f: Callable[[np.ndarray], np.ndarray],
    x: Interval,
    increasing: bool = True,
    rel_error: float = _REL_TRANSCENDENTAL,
) -> Interval:
    """Enclosure of a monotone function evaluated in floating point at the bounds.

    ``f`` must be monotone on the whole of every interval of ``x`` and computed with a relative error below
    ``rel_error`` (the caller's responsibility, stated where it is used).
    """
    a = f(x.lo)
    b = f(x.hi)
    if not increasing:
        a, b = b, a
    return Interval(
        np.nextafter(a - np.abs(a) * rel_error, -_INF), np.nextafter(b + np.abs(b) * rel_error, _INF)
    )


def _periodic(x: Interval, f: Callable[[np.ndarray], np.ndarray], shift: float) -> Interval:
    """Range of ``f`` = cos(t - shift) over ``x``: endpoint values plus +-1 where an extremum may lie inside.

    Maxima sit at ``t = shift + 2 pi k``, minima at ``t = shift + pi + 2 pi k``. The membership test
    ``ceil(u_lo) <= floor(u_hi)`` with ``u = (t - shift) / 2 pi`` is evaluated on bounds widened by a relative
    1e-12, so rounding can only add an extremum, never miss one.
    """
    lo, hi = x.lo, x.hi
    a = f(lo)
    b = f(hi)
    vlo = np.minimum(a, b)
    vhi = np.maximum(a, b)
    pad = 1e-12 * (1.0 + np.maximum(np.abs(lo), np.abs(hi)))
    u_lo = (lo - shift) / _TWO_PI - pad
    u_hi = (hi - shift) / _TWO_PI + pad
    has_max = np.ceil(u_lo) <= np.floor(u_hi)
    has_min = np.ceil(u_lo - 0.5) <= np.floor(u_hi - 0.5)
    whole = (hi - lo) >= _TWO_PI
    out_lo = np.where(has_min | whole, -1.0, np.maximum(_down_t(vlo), -1.0))
    out_hi = np.where(has_max | whole, 1.0, np.minimum(_up_t(vhi), 1.0))
    # nan (infinite argument) -> [-1, 1]
    out_lo = np.where(np.isnan(out_lo), -1.0, out_lo)
    out_hi = np.where(np.isnan(out_hi), 1.0, out_hi)
    return Interval(out_lo, out_hi)


def tan_branch(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The branch ``k`` of ``tan`` (``(-pi/2 + k pi, pi/2 + k pi)``) nearest ``[lo, hi]`` (``floor(t / pi + 1/2)``
    of ``lo``, which rounding may put one branch off next to a pole) and the mask of the intervals proved inside
    one branch: narrower than pi, and ``tan(lo) <= tan(hi)``. An interval narrower than pi meets a pole exactly
    when ``tan(lo) > tan(hi)``, by a margin far beyond libm's few ulp (the floor test alone missed poles: the float
    pi/2 lies below the real one, so ``[1.5707963267948966, 2]`` crosses it while both ends floor to 1)."""
    with np.errstate(invalid='ignore', over='ignore'):
        k_lo = np.floor(lo / np.pi + 0.5)
        one = (hi - lo < np.pi * (1 - 1e-9)) & (np.tan(lo) <= np.tan(hi))
    return k_lo, np.asarray(one)


def sqrt3_over_2() -> Interval:
    """Certified enclosure of sqrt(3)/2 (the float is correctly rounded sqrt(3) halved: exact halving)."""
    s = np.sqrt(3.0)
    return Interval(down(s) * 0.5, up(s) * 0.5)

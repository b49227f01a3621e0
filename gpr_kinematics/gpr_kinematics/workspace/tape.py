"""A compiled expression graph: the operations in evaluation order, evaluated over many points or boxes at
once (numpy), with forward-mode derivatives for points and for boxes.

* :meth:`Tape.points`: exact float values at points (NaN where a subexpression is undefined);
* :meth:`Tape.boxes`: interval enclosures over boxes, with the boxes where some subexpression may be (or is
  certainly) undefined;
* :meth:`Tape.jacobian_points` / :meth:`Tape.jacobian_boxes`: values and derivatives of the roots with
  respect to chosen variables, at points (floats) or over boxes (intervals, the slopes the Krawczyk test
  needs). The derivative rules are written once for both (:func:`_derivative`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .expressions import Expr, Graph
from .interval import Interval

_NAN = np.nan


@dataclass(frozen=True)
class Tape:
    """Operations of the nodes reachable from ``roots``; variables are nodes ``0 .. nvars - 1``."""

    nvars: int
    ops: tuple[str, ...]
    args: tuple[tuple[int, ...], ...]
    consts: dict[int, tuple[float, float]]
    roots: tuple[int, ...]

    @classmethod
    def compile(cls, graph: Graph, roots: Sequence[Expr]) -> Tape:
        n = len(graph.variables)
        keep = set(range(n))
        stack = [r.id for r in roots]
        while stack:
            i = stack.pop()
            if i not in keep:
                keep.add(i)
                stack.extend(graph.args[i])
        order = sorted(keep)                        # creation order is an evaluation order
        new = {old: k for k, old in enumerate(order)}
        return cls(
            n,
            tuple(graph.ops[i] for i in order),
            tuple(tuple(new[a] for a in graph.args[i]) for i in order),
            {new[i]: c for i, c in graph.consts.items() if i in new},
            tuple(new[r.id] for r in roots),
        )

    @property
    def size(self) -> int:
        return len(self.ops)

    # ------------------------------------------------------------------------------------------ points
    def points(self, x: np.ndarray) -> np.ndarray:
        """Root values (N, roots) at points ``x`` (N, nvars); NaN where a subexpression is undefined."""
        x = np.asarray(x, dtype=float)
        vals: list[Any] = [x[:, i] for i in range(self.nvars)]
        with np.errstate(all='ignore'):
            for k in range(self.nvars, self.size):
                vals.append(_point_op(self.ops[k], [vals[a] for a in self.args[k]], self.consts.get(k)))
        n = x.shape[0]
        return np.stack([np.broadcast_to(vals[r], (n,)) for r in self.roots], axis=1)

    # ------------------------------------------------------------------------------------------- boxes
    def boxes(self, lo: np.ndarray, hi: np.ndarray) -> tuple[list[Interval], np.ndarray, np.ndarray]:
        """Enclosures of every node over boxes ``[lo, hi]`` (M, nvars), and two (M,) masks: some
        subexpression *may* be undefined somewhere in the box / *is* undefined everywhere in it."""
        m = lo.shape[0]
        vals: list[Interval] = [Interval(lo[:, i], hi[:, i]) for i in range(self.nvars)]
        maybe = np.zeros(m, dtype=bool)
        surely = np.zeros(m, dtype=bool)
        with np.errstate(all='ignore'):
            for k in range(self.nvars, self.size):
                a = [vals[j] for j in self.args[k]]
                v, may, sure = interval_op(self.ops[k], a, self.consts.get(k))
                maybe |= may
                surely |= sure
                vals.append(v)
        return vals, maybe, surely

    def root_boxes(self, lo: np.ndarray, hi: np.ndarray) -> tuple[Interval, np.ndarray, np.ndarray]:
        """Root enclosures as one Interval of shape (M, roots), and the two undefinedness masks."""
        vals, maybe, surely = self.boxes(lo, hi)
        m = lo.shape[0]
        return (Interval(np.stack([np.broadcast_to(vals[r].lo, (m,)) for r in self.roots], axis=1),
                         np.stack([np.broadcast_to(vals[r].hi, (m,)) for r in self.roots], axis=1)),
                maybe, surely)

    def root_boxes_tight(self, lo: np.ndarray, hi: np.ndarray, vary: Sequence[int]) -> tuple[Interval, np.ndarray]:
        """Root enclosures over small boxes: the natural enclosure intersected with the mean-value form
        ``g(c) + g'(B) (B - c)`` (``c`` the centre, ``vary`` the coordinates where ``lo < hi``), which is
        much tighter when a variable occurs many times; with the (M,) mask of possibly undefined boxes."""
        g, maybe, _ = self.root_boxes(lo, hi)
        idx = list(vary)
        c = 0.5 * (lo + hi)
        gc, c_maybe, _ = self.root_boxes(c, c)
        J, j_maybe = self.jacobian_boxes(lo, hi, idx)
        dev = Interval(lo[:, idx], hi[:, idx]) - c[:, idx]                  # B - c, outward rounded
        mv = gc
        for j in range(len(idx)):
            mv = mv + Interval(J.lo[:, :, j], J.hi[:, :, j]) * Interval(dev.lo[:, None, j], dev.hi[:, None, j])
        lo_t = np.where(j_maybe[:, None] | c_maybe[:, None], g.lo, np.fmax(g.lo, mv.lo))
        hi_t = np.where(j_maybe[:, None] | c_maybe[:, None], g.hi, np.fmin(g.hi, mv.hi))
        return Interval(lo_t, hi_t), maybe

    # ------------------------------------------------------------------------------------- derivatives
    def jacobian_points(self, x: np.ndarray, wrt: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """Root values (N, r) and their derivatives (N, r, len(wrt)) at points ``x`` (N, nvars)."""
        x = np.asarray(x, dtype=float)
        n, p = x.shape[0], len(wrt)
        vals: list[Any] = [x[:, i] for i in range(self.nvars)]
        ders: list[Any] = [None] * self.nvars
        for j, i in enumerate(wrt):
            ders[i] = np.zeros((n, p))
            ders[i][:, j] = 1.0
        with np.errstate(all='ignore'):
            for k in range(self.nvars, self.size):
                a = [vals[j] for j in self.args[k]]
                y = _point_op(self.ops[k], a, self.consts.get(k))
                vals.append(y)
                ders.append(_derivative(self.ops[k], a, y, [ders[j] for j in self.args[k]], _FLOAT))
        value = np.stack([np.broadcast_to(vals[r], (n,)) for r in self.roots], axis=1)
        jac = np.stack([np.zeros((n, p)) if ders[r] is None else ders[r] for r in self.roots], axis=1)
        return value, jac

    def jacobian_boxes(self, lo: np.ndarray, hi: np.ndarray, wrt: Sequence[int]) -> tuple[Interval, np.ndarray]:
        """Enclosures of the roots' derivatives (an Interval (M, r, len(wrt))) over boxes, and the (M,) mask of
        boxes where some subexpression may be undefined (there the enclosure proves nothing)."""
        m, p = lo.shape[0], len(wrt)
        vals: list[Interval] = [Interval(lo[:, i], hi[:, i]) for i in range(self.nvars)]
        ders: list[Any] = [None] * self.nvars
        for j, i in enumerate(wrt):
            unit = np.zeros((m, p))
            unit[:, j] = 1.0
            ders[i] = Interval.point(unit)
        maybe = np.zeros(m, dtype=bool)
        with np.errstate(all='ignore'):
            for k in range(self.nvars, self.size):
                a = [vals[j] for j in self.args[k]]
                y, may, _ = interval_op(self.ops[k], a, self.consts.get(k))
                maybe |= may
                vals.append(y)
                ders.append(_derivative(self.ops[k], a, y, [ders[j] for j in self.args[k]], _INTERVAL))
        zero = Interval.point(np.zeros((m, p)))
        out = [zero if ders[r] is None else ders[r] for r in self.roots]
        return Interval(np.stack([d.lo for d in out], axis=1), np.stack([d.hi for d in out], axis=1)), maybe


# ------------------------------------------------------------------------------------------- point ops
def _point_op(op: str, a: list[Any], const: tuple[float, float] | None) -> Any:
    if op == 'const':
        assert const is not None
        return 0.5 * (const[0] + const[1])
    u = a[0]
    if op in ('add', 'sub', 'mul', 'div'):
        v = a[1]
        if op == 'add':
            return u + v
        if op == 'sub':
            return u - v
        if op == 'mul':
            return u * v
        return np.where(v != 0, u / np.where(v != 0, v, 1.0), _NAN)
    if op == 'neg':
        return -u
    if op == 'sqr':
        return u * u
    if op == 'log':
        return np.where(u > 0, np.log(np.where(u > 0, u, 1.0)), _NAN)
    return _NUMPY[op](u)


_NUMPY = {'sqrt': np.sqrt, 'sin': np.sin, 'cos': np.cos, 'tan': np.tan, 'arcsin': np.arcsin, 'arccos': np.arccos,
          'arctan': np.arctan, 'exp': np.exp, 'abs': np.abs}


# ---------------------------------------------------------------------------------------- interval ops
def interval_op(op: str, a: list[Interval], const: tuple[float, float] | None) -> tuple[Interval, Any, Any]:
    """Enclosure of one operation over intervals, with the (may be, is) undefined masks (or False)."""
    if op == 'const':
        assert const is not None
        return Interval(np.asarray(const[0]), np.asarray(const[1])), False, False
    u = a[0]
    if op == 'add':
        return u + a[1], False, False
    if op == 'sub':
        return u - a[1], False, False
    if op == 'mul':
        return u * a[1], False, False
    if op == 'div':
        v = a[1]
        return u / v, (v.lo <= 0) & (v.hi >= 0), (v.lo == 0) & (v.hi == 0)
    if op == 'neg':
        return -u, False, False
    if op == 'sqrt':
        return u.sqrt(), u.lo < 0, u.hi < 0
    if op == 'log':
        return u.log(), u.lo <= 0, u.hi <= 0
    if op in ('arcsin', 'arccos'):
        return getattr(u, op)(), (u.lo < -1) | (u.hi > 1), (u.lo > 1) | (u.hi < -1)
    if op == 'tan':
        t = u.tan()
        return t, np.isinf(t.lo) | np.isinf(t.hi), False
    return getattr(u, op)(), False, False


# ------------------------------------------------------------------------------------------ derivatives
class _Float:
    """Point arithmetic for the derivative rules (numpy arrays)."""

    @staticmethod
    def col(x: Any) -> Any:
        return np.asarray(x)[..., None]

    sin, cos, sqrt = staticmethod(np.sin), staticmethod(np.cos), staticmethod(np.sqrt)

    @staticmethod
    def sign(x: Any) -> Any:
        return np.sign(x)


class _Intervals:
    """Interval arithmetic for the derivative rules: the same formulas give slope enclosures."""

    @staticmethod
    def col(x: Interval) -> Interval:
        return Interval(np.asarray(x.lo)[..., None], np.asarray(x.hi)[..., None])

    @staticmethod
    def sin(x: Interval) -> Interval:
        return x.sin()

    @staticmethod
    def cos(x: Interval) -> Interval:
        return x.cos()

    @staticmethod
    def sqrt(x: Interval) -> Interval:
        return x.sqrt()

    @staticmethod
    def sign(x: Interval) -> Interval:
        return Interval(np.where(x.lo > 0, 1.0, -1.0), np.where(x.hi < 0, -1.0, 1.0))


_FLOAT, _INTERVAL = _Float(), _Intervals()


def _derivative(op: str, a: list[Any], y: Any, da: list[Any], K: Any) -> Any:
    """Forward-mode rule of one operation: the derivative of ``y = op(a)`` from those of its arguments
    (None = zero). Arguments and values are float arrays (``K = _FLOAT``) or Intervals (``K = _INTERVAL``)."""
    if op == 'const' or all(d is None for d in da):
        return None
    d0 = da[0]
    if op in ('add', 'sub'):
        d1 = da[1]
        if d1 is None:
            return d0
        if d0 is None:
            return -d1 if op == 'sub' else d1
        return d0 + d1 if op == 'add' else d0 - d1
    if op == 'mul':
        d1 = da[1]
        terms = [t for t in (None if d0 is None else d0 * K.col(a[1]), None if d1 is None else K.col(a[0]) * d1)
                 if t is not None]
        return terms[0] if len(terms) == 1 else terms[0] + terms[1]
    if op == 'div':                                  # (du - y dv) / v
        d1 = da[1]
        num = d0 if d1 is None else (-(K.col(y) * d1) if d0 is None else d0 - K.col(y) * d1)
        return num / K.col(a[1])
    u = a[0]
    factors: dict[str, Callable[[], Any]] = {
        'neg': lambda: -1.0,
        'sqr': lambda: u * 2.0,
        'sqrt': lambda: 0.5 / y,
        'sin': lambda: K.cos(u),
        'cos': lambda: -K.sin(u),
        'tan': lambda: 1.0 + y * y,
        'arcsin': lambda: 1.0 / K.sqrt(1.0 - u * u),
        'arccos': lambda: -1.0 / K.sqrt(1.0 - u * u),
        'arctan': lambda: 1.0 / (1.0 + u * u),
        'exp': lambda: y,
        'log': lambda: 1.0 / u,
        'abs': lambda: K.sign(u),
    }
    factor = factors[op]()
    if isinstance(factor, float):
        return d0 * factor
    return d0 * K.col(factor)

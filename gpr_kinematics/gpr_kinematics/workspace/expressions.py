"""Symbolic expressions of a mechanism's closure equations and inequalities, without ``eval``.

Text such as ``la*cos(q1) + lb*cos(q3) + d/2 = x`` is read by a small tokenizer and recursive-descent
parser written here (no Python ``eval``, ``exec`` or ``ast`` of user text): it accepts numbers, the names it
is given (variables, numeric parameters, the constant ``pi``), ``+ - * /``, integer powers ``x^2`` (or
``x**2``), parentheses and the functions of :data:`FUNCTIONS`, and nothing else; every other input is
refused with the column and what is allowed. Sizes are bounded (:data:`MAX_TEXT`, :data:`MAX_DEPTH`,
:data:`MAX_NODES`).

Expressions are nodes of one directed acyclic graph per model (:class:`Graph`, equal subexpressions
shared). The same graph is built from Python: :class:`Expr` has the arithmetic and the method names of
:class:`~gpr_kinematics.workspace.interval.Interval` (``sin``, ``sqr``, ``arctan`` ...), so a model's formula written
for intervals builds expressions when given :class:`Expr` variables.

A point where some subexpression is undefined (``sqrt`` of a negative number, ``log`` of a non-positive
one, ``arcsin`` outside [-1, 1], division by 0) satisfies no constraint.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..inputs.safe_yaml import UNSIGNED_DECIMAL
from .interval import Interval

#: Function names of the expression language -> node operation.
FUNCTIONS = {
    'sin': 'sin', 'cos': 'cos', 'tan': 'tan', 'asin': 'arcsin', 'arcsin': 'arcsin', 'acos': 'arccos',
    'arccos': 'arccos', 'atan': 'arctan', 'arctan': 'arctan', 'sqrt': 'sqrt', 'sqr': 'sqr', 'exp': 'exp',
    'log': 'log', 'abs': 'abs',
}
UNARY = ('neg', 'sqr', 'sqrt', 'sin', 'cos', 'tan', 'arcsin', 'arccos', 'arctan', 'exp', 'log', 'abs')
BINARY = ('add', 'sub', 'mul', 'div')
CONSTANTS = {'pi': math.pi}
#: Longest constraint text, deepest nesting (parentheses, signs, powers), most nodes of one model's graph.
MAX_TEXT = 2000
MAX_DEPTH = 48
MAX_NODES = 20000
MAX_POWER = 64


class ExpressionError(ConfigError):
    """A constraint that does not parse or names something unknown (a configuration error, exit 2)."""


class FoldError(ExpressionError):
    """A constant part of a constraint off its function's domain or beyond floats (located by the parser; the
    operation limit's error was relabelled as one)."""


class Graph:
    """The expression DAG of one model: nodes ``(op, args)``, variables first, constants as intervals."""

    def __init__(self, variables: Sequence[str]) -> None:
        self.variables = tuple(variables)
        self.ops: list[str] = []
        self.args: list[tuple[int, ...]] = []
        self.consts: dict[int, tuple[float, float]] = {}
        self._index: dict[tuple[Any, ...], int] = {}
        for i in range(len(self.variables)):
            self._add(('var', i), 'var', ())

    def _add(self, key: tuple[Any, ...], op: str, args: tuple[int, ...]) -> int:
        found = self._index.get(key)
        if found is not None:
            return found
        if len(self.ops) >= MAX_NODES:
            raise ExpressionError(f'the equations need more than {MAX_NODES} operations; allowed: at most {MAX_NODES}')
        self.ops.append(op)
        self.args.append(args)
        self._index[key] = len(self.ops) - 1
        return len(self.ops) - 1

    def var(self, name: str) -> Expr:
        return Expr(self, self.variables.index(name))

    def constant(self, lo: float, hi: float | None = None) -> Expr:
        """An exact float ``[lo, lo]`` or an enclosure ``[lo, hi]`` of a real constant."""
        hi = lo if hi is None else hi
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ExpressionError(f'a constant must be a finite number, got [{lo}, {hi}]')
        i = self._add(('const', float(lo), float(hi)), 'const', ())
        self.consts[i] = (float(lo), float(hi))
        return Expr(self, i)

    def apply(self, op: str, *operands: Expr) -> Expr:
        ids = tuple(e.id for e in operands)
        divisor = self.consts.get(ids[1]) if op == 'div' else None   # x / 0: undefined wherever x is
        if divisor is not None and divisor[0] <= 0.0 <= divisor[1]:
            raise FoldError(f'division by the constant [{divisor[0]:g}, {divisor[1]:g}], which holds 0, is undefined')
        if all(i in self.consts for i in ids):
            return self._fold(op, ids)
        return Expr(self, self._add((op, ids), op, ids))

    def _fold(self, op: str, ids: tuple[int, ...]) -> Expr:
        """Constant operands: the operation on their enclosures (outward rounded), refused off its domain."""
        a = Interval(*(np.asarray(v) for v in self.consts[ids[0]]))
        b = Interval(*(np.asarray(v) for v in self.consts[ids[1]])) if len(ids) > 1 else a
        domain = {'sqrt': a.hi >= 0, 'log': a.hi > 0, 'arcsin': (a.lo <= 1) & (a.hi >= -1),
                  'arccos': (a.lo <= 1) & (a.hi >= -1)}   # a divisor holding 0: refused by apply
        if not bool(domain.get(op, True)):
            raise FoldError(f'{op} of the constant [{a.lo:g}, {a.hi:g}] is undefined')
        with np.errstate(all='ignore'):   # an overflow is refused below, in one line (numpy warned on stderr)
            if op in BINARY:
                r = {'add': a + b, 'sub': a - b, 'mul': a * b, 'div': a / b}[op]
            else:
                r = -a if op == 'neg' else getattr(a, op)()
        if not (np.isfinite(r.lo) and np.isfinite(r.hi)):
            of = f'the constants [{a.lo:g}, {a.hi:g}] and [{b.lo:g}, {b.hi:g}]' if op in BINARY else \
                f'the constant [{a.lo:g}, {a.hi:g}]'
            raise FoldError(f'{op} of {of} is not a finite number')
        return self.constant(float(r.lo), float(r.hi))


def _binary(op: str, reflected: bool = False) -> Callable[[Expr, object], Expr]:
    """The method ``self op other`` (or ``other op self``) of :class:`Expr`: a new node of its graph."""

    def method(self: Expr, other: object) -> Expr:
        o = self._other(other)
        return self.graph.apply(op, o, self) if reflected else self.graph.apply(op, self, o)

    return method


def _unary(op: str) -> Callable[[Expr], Expr]:
    """The method ``op(self)`` of :class:`Expr` (the name of the Interval method that does the same)."""

    def method(self: Expr) -> Expr:
        return self.graph.apply(op, self)

    return method


class Expr:
    """A node of a :class:`Graph`, with the arithmetic of :class:`~gpr_kinematics.workspace.interval.Interval`."""

    __slots__ = ('graph', 'id')

    def __init__(self, graph: Graph, node: int) -> None:
        self.graph = graph
        self.id = node

    def _other(self, x: object) -> Expr:
        if isinstance(x, Expr):
            if x.graph is not self.graph:
                raise ExpressionError('expressions of two different models cannot be combined')
            return x
        if isinstance(x, Interval):
            if np.shape(x.lo) != () or np.shape(x.hi) != ():
                raise ExpressionError('only a single interval can enter an expression as a constant')
            return self.graph.constant(float(x.lo), float(x.hi))
        if isinstance(x, (int, float, np.floating, np.integer)) and not isinstance(x, bool):
            return self.graph.constant(float(x))
        raise ExpressionError(f'cannot combine an expression with {type(x).__name__}')

    __add__ = _binary('add')
    __radd__ = _binary('add', reflected=True)
    __sub__ = _binary('sub')
    __rsub__ = _binary('sub', reflected=True)
    __mul__ = _binary('mul')
    __rmul__ = _binary('mul', reflected=True)
    __truediv__ = _binary('div')
    __rtruediv__ = _binary('div', reflected=True)
    __neg__ = _unary('neg')

    def __pow__(self, n: int) -> Expr:
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or abs(n) > MAX_POWER:
            raise ExpressionError(f'a power needs an integer exponent from -{MAX_POWER} to {MAX_POWER}, got {n!r}')
        if n < 0:
            return 1.0 / self ** (-int(n))
        if n == 0:
            return self.graph.constant(1.0)
        if n == 1:
            return self
        half = self ** (int(n) // 2)
        sq = half.sqr()
        return sq * self if n % 2 else sq

    def __repr__(self) -> str:
        return f'Expr(node {self.id}: {self.graph.ops[self.id]})'

    sqr, sqrt, abs = _unary('sqr'), _unary('sqrt'), _unary('abs')
    sin, cos, tan = _unary('sin'), _unary('cos'), _unary('tan')
    arcsin, arccos, arctan = _unary('arcsin'), _unary('arccos'), _unary('arctan')
    exp, log = _unary('exp'), _unary('log')

    @property
    def constant(self) -> tuple[float, float] | None:
        """The enclosure ``(lo, hi)`` when the expression is a constant, else None."""
        return self.graph.consts.get(self.id)


@dataclass(frozen=True)
class Constraint:
    """``lower <= root <= upper``; the bounds are enclosures ``(lo, hi)`` of real constants (+-inf allowed)."""

    root: Expr
    lower: tuple[float, float]
    upper: tuple[float, float]
    text: str

    @property
    def equality(self) -> bool:
        return self.lower == self.upper


# ------------------------------------------------------------------------------------------- parsing
#: A number is of ASCII digits (``\d`` read the digits of other scripts: ``x^2 + y^2 <= \u0661`` as ``<= 1``, as
#: the files' numbers no longer are, :func:`~gpr_kinematics.inputs.validation.decimal`).
_TOKEN = re.compile(
    r'\s*(?:(?P<num>' + UNSIGNED_DECIMAL + r')|(?P<name>[A-Za-z_][A-Za-z0-9_]*)'
    r'|(?P<op>\*\*|<=|>=|==|[-+*/^(),=<>]))'
)
_RELATIONS = ('=', '==', '<=', '>=')


class _Parser:
    def __init__(self, text: str, graph: Graph, names: Mapping[str, Expr], where: str) -> None:
        self.text, self.graph, self.names, self.where = text, graph, names, where
        self.tokens: list[tuple[str, str, int]] = []
        pos = 0
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if m is None or m.end() == pos:
                if text[pos:].strip() == '':
                    break
                col = pos + len(text[pos:]) - len(text[pos:].lstrip()) + 1
                self.fail(f'unexpected character {text[col - 1]!r} at column {col}')
                raise AssertionError  # unreachable: fail raises
            kind = m.lastgroup or 'op'
            self.tokens.append((kind, m.group(kind), m.start(kind) + 1))
            pos = m.end()
        self.i = 0
        self.depth = 0

    def fail(self, message: str) -> None:
        raise ExpressionError(f'{self.where}: {message}')

    def peek(self) -> tuple[str, str, int] | None:
        return self.tokens[self.i] if self.i < len(self.tokens) else None

    def take(self, value: str | None = None) -> tuple[str, str, int]:
        tok = self.peek()
        if tok is None:
            self.fail(f'unexpected end of the text (expected {repr(value) if value else "a number, a name or ("})')
            raise AssertionError  # unreachable: fail raises
        if value is not None and tok[1] != value:
            self.fail(f'expected {value!r} at column {tok[2]}, found {tok[1]!r}')
        self.i += 1
        return tok

    def nest(self) -> None:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            self.fail(f'nested deeper than {MAX_DEPTH} levels; allowed: at most {MAX_DEPTH}')

    def expr(self) -> Expr:
        self.nest()
        out = self.term()
        while (tok := self.peek()) is not None and tok[1] in '+-' and tok[0] == 'op':
            self.take()
            out = out + self.term() if tok[1] == '+' else out - self.term()
        self.depth -= 1
        return out

    def term(self) -> Expr:
        out = self.unary()
        while (tok := self.peek()) is not None and tok[1] in ('*', '/'):
            self.take()
            out = out * self.unary() if tok[1] == '*' else out / self.unary()
        return out

    def unary(self) -> Expr:
        tok = self.peek()
        if tok is not None and tok[1] in ('-', '+'):
            self.take()
            self.nest()
            inner = self.unary()
            self.depth -= 1
            return -inner if tok[1] == '-' else inner
        base = self.atom()
        tok = self.peek()
        if tok is not None and tok[1] in ('^', '**'):
            self.take()
            self.nest()
            exponent = self.unary()
            self.depth -= 1
            c = exponent.constant
            if c is None or c[0] != c[1] or not float(c[0]).is_integer() or abs(c[0]) > MAX_POWER:
                self.fail(f'the exponent after column {tok[2]} must be an integer constant from -{MAX_POWER} '
                          f'to {MAX_POWER}')
                raise AssertionError
            return base ** int(c[0])
        return base

    def atom(self) -> Expr:
        kind, value, col = self.take()
        if kind == 'num':
            x = float(value)
            if not math.isfinite(x):
                self.fail(f'the number {value[:30]!r} at column {col} is not finite')
            return self.graph.constant(x)
        if kind == 'name':
            nxt = self.peek()
            if nxt is not None and nxt[1] == '(':
                if value not in FUNCTIONS:
                    self.fail(f'unknown function {value!r} at column {col}; allowed: {", ".join(sorted(FUNCTIONS))}')
                self.take('(')
                arg = self.expr()
                self.take(')')
                return self.graph.apply(FUNCTIONS[value], arg)
            if value in self.names:
                return self.names[value]
            self.fail(f'unknown name {value!r} at column {col}; allowed: {", ".join(self.names)}')
        if value == '(':
            inner = self.expr()
            self.take(')')
            return inner
        self.fail(f'unexpected {value!r} at column {col}')
        raise AssertionError

    def relation(self) -> str | None:
        tok = self.peek()
        if tok is None:
            return None
        if tok[1] in ('<', '>'):
            self.fail(f'use <= or >= at column {tok[2]} (the sets are closed)')
        if tok[1] not in _RELATIONS:
            self.fail(f'unexpected {tok[1]!r} at column {tok[2]}; expected an operator or =, <=, >=')
        self.take()
        return tok[1]


def parse_constraint(text: Any, graph: Graph, names: Mapping[str, Expr], where: str) -> Constraint:
    """One constraint: ``f = g``, ``f <= g``, ``f >= g``, or ``a <= f <= b`` / ``a >= f >= b`` (a, b constant)."""
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError(f'{where}: a constraint must be a non-empty text such as "x^2 + y^2 <= 1"')
    if len(text) > MAX_TEXT:
        raise ExpressionError(f'{where}: the text has {len(text)} characters; allowed: at most {MAX_TEXT}')
    p = _Parser(text, graph, names, f'{where} ({text[:60]!r})')
    try:
        parts, rels = _relation_chain(p)
    except FoldError as exc:   # a constant part folded off its domain or beyond floats: located here
        col = p.tokens[max(p.i - 1, 0)][2] if p.tokens else 1
        p.fail(f'{exc} (by column {col}); allowed: constant parts of finite value (they are computed once, first)')
        raise AssertionError from None  # unreachable: fail raises
    if len(rels) == 2:
        lo, f, hi = parts if rels[0] == '<=' else parts[::-1]
        if lo.constant is None or hi.constant is None:
            p.fail('the outer terms of a <= f <= b must be constants')
        elif lo.constant[0] > hi.constant[1]:   # no value of f lies in it: the workspace would be empty by typing
            p.fail(f'the range [{lo.constant[0]:g}, {hi.constant[1]:g}] of a <= f <= b is empty; allowed: a <= b')
        return Constraint(f, lo.constant or (0.0, 0.0), hi.constant or (0.0, 0.0), text)
    return _one_relation(parts[0], rels[0], parts[1], text)


def _relation_chain(p: _Parser) -> tuple[list[Expr], list[str]]:
    """The terms and relations of ``f rel g`` or ``a rel f rel b`` (the same ``<=`` or ``>=`` twice)."""
    parts = [p.expr()]
    rels: list[str] = []
    while (rel := p.relation()) is not None:
        rels.append(rel)
        parts.append(p.expr())
    if not rels:
        p.fail('a constraint needs =, <= or >=')
    if len(rels) > 2 or (len(rels) == 2 and (rels[0] != rels[1] or rels[0] in ('=', '=='))):
        p.fail('a chain must read a <= f <= b or a >= f >= b')
    return parts, rels


def _one_relation(lhs: Expr, rel: str, rhs: Expr, text: str) -> Constraint:
    """``lhs rel rhs`` as bounds on one expression: a constant side becomes the bound, else ``lhs - rhs``."""
    inf = (math.inf, math.inf)
    ninf = (-math.inf, -math.inf)
    if rel in ('=', '=='):
        if rhs.constant is not None:
            return Constraint(lhs, rhs.constant, rhs.constant, text)
        if lhs.constant is not None:
            return Constraint(rhs, lhs.constant, lhs.constant, text)
        return Constraint(lhs - rhs, (0.0, 0.0), (0.0, 0.0), text)
    if rel == '>=':
        lhs, rhs = rhs, lhs                                # now lhs <= rhs
    if rhs.constant is not None:
        return Constraint(lhs, ninf, rhs.constant, text)
    if lhs.constant is not None:
        return Constraint(rhs, lhs.constant, inf, text)
    return Constraint(lhs - rhs, ninf, (0.0, 0.0), text)

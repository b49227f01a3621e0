"""Mechanisms given by their closure equations: a workspace model over all their variables, projected onto
its outputs (the method: :mod:`.projection`).

From YAML (``type: equations``)::

    type: equations
    parameters: {la: 0.2, lb: 0.2}          # numbers the texts may name; --set la=0.25 overrides one
    variables:                              # every variable with its range (SI units)
      q1: [-3.141592653589793, 3.141592653589793]
      x: [-0.5, 0.5]
    units: {q1: rad}                        # m unless given (rad variables get workspace.angle_scale)
    outputs: [x, y]                         # the working area's variables
    equations: ["x = la*cos(q1) + lb*cos(q3)", ...]
    inequalities: ["x^2 + y^2 >= 0.01", ...]
    solve_for: [q1, q3]                     # passive variables the existence proof solves for (default:
                                            # all passive ones, when there are as many as equations)
    periodic: [q1, q3]                      # angles used through sin/cos only: solutions count modulo 2 pi
    workspace: {angle_scale: 0.2}

The texts are parsed by :mod:`.expressions` (no ``eval``). From Python, subclass :class:`EquationModel`
or build constraints with :class:`~.expressions.Expr` arithmetic and pass them in.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError
from ..inputs.schema import check_keys, number_key
from .boxes import bounds_pair, box_from
from .covering import CoveringTask
from .expressions import CONSTANTS, FUNCTIONS, Constraint, ExpressionError, Graph, parse_constraint
from .interval import Interval
from .krawczyk import krawczyk, newton
from .projection import GroupFrontier, projection_step
from .tape import Tape

MAX_VARIABLES = 16
MAX_CONSTRAINTS = 64
_KEYS = ('type', 'name', 'reference', 'parameters', 'variables', 'units', 'outputs', 'equations', 'inequalities',
         'solve_for', 'periodic', 'workspace')
#: A float array (N, n) of variable values whose equalities hold to this (relative) residual counts as feasible.
EQUALITY_TOLERANCE = 1e-9
#: Most passive boxes an output box keeps refining (beyond, they stay as they are: still certified).
MAX_PASSIVE_BOXES = 512


def _check_box(name: str, n: int, box: np.ndarray, units: tuple[str, ...], scale: np.ndarray) -> None:
    """ConfigError unless every one of the ``n`` variables has a finite range lower < upper, a unit and a
    positive finite scale."""
    if box.shape != (n, 2) or len(units) != n or scale.shape != (n,):
        raise ConfigError(f'{name}: box, units and scale need one entry per variable ({n})')
    if not (np.all(np.isfinite(box)) and np.all(box[:, 0] < box[:, 1])):
        raise ConfigError(f'{name}: every variable range needs finite lower < upper')
    if not (np.all(np.isfinite(scale)) and np.all(scale > 0)):
        raise ConfigError(f'{name}: every scale must be a positive length (m per unit)')


def _solve_for(name: str, equalities: int, passive: list[str], solve_for: Sequence[str] | None) -> tuple[str, ...]:
    """The passive variables the existence proof solves for: as many as equalities, distinct (default: all the
    passive ones, when their count matches)."""
    if solve_for is None:
        if equalities > len(passive):   # none to name: "name the 1 the proof solves for" could not be followed
            raise ConfigError(f'{name}: {equalities} equations and {len(passive)} passive variables {passive}: an '
                              'equation needs a passive variable of its own to solve for; allowed: at most as many '
                              'equations as passive variables (the variables that are not outputs)')
        if equalities != len(passive):
            raise ConfigError(f'{name}: {equalities} equations and {len(passive)} passive variables '
                              f'{passive}: name the {equalities} the proof solves for in solve_for')
        solve_for = passive
    if sorted(set(solve_for)) != sorted(solve_for) or not set(solve_for) <= set(passive) or len(
            solve_for) != equalities:
        raise ConfigError(f'{name}: solve_for must name {equalities} distinct passive variables among '
                          f'{passive}; got {list(solve_for)}')
    return tuple(solve_for)


def _check_periodic(name: str, graph: Graph, units: tuple[str, ...], periodic: Sequence[str],
                    constraints: Sequence[Constraint]) -> None:
    """ConfigError unless every periodic variable is an angle that the constraints use through sin/cos only."""
    variables = graph.variables
    for v in periodic:
        i = variables.index(v) if v in variables else -1
        bad = _non_periodic_use(graph, i, {c.root.id for c in constraints}) if i >= 0 else 'nothing'
        if i < 0 or units[i] != 'rad' or bad:
            # it said "it is used by a non-angle unit" of a variable in m, "used by nothing" of no variable
            why = (f'it is not a variable (the variables: {", ".join(variables)})' if i < 0 else
                   f'its unit is {units[i]} (units: {{{v}: rad}} makes it an angle)' if units[i] != 'rad' else
                   f'it is used by {bad}')
            raise ConfigError(f'{name}: periodic variable {v!r} must be an angle (rad) that every constraint uses '
                              f'through sin or cos of an integer multiple of it plus other terms; {why}')


class EquationModel:
    """Equalities and inequalities over named variables, with the outputs to project onto.

    Args:
        title: a human-readable name (the YAML ``name``); :attr:`name` is the type, ``equations``.
        graph: the expression graph over ``variables`` (in that order).
        constraints: the constraints (roots of ``graph``); equalities have ``lower == upper``.
        box: (n, 2) range of every variable (passive ranges are part of the model, e.g. joint limits).
        units, scale: per variable (scale: metres per unit, for diameters).
        outputs: the variables of the working area.
        solve_for: passive variables solved by the existence proof, as many as equalities.
        periodic: angle variables (rad) that enter every constraint through ``sin``/``cos`` only (checked):
            the existence proof accepts their solutions modulo 2 pi, and a range of a full turn (to 1e-12, e.g.
            ``[-3.141592653589793, 3.141592653589793]``, whose floats fall 2.4e-16 short of the real 2 pi) is
            widened by 1e-15 rad at both ends to cover the whole circle: a joint that turns without limits
            has no seam.
        passive_ratio: passive boxes are bisected while their scaled diameter exceeds this times the output
            box's (1: all variables refined alike; larger: coarser passive boxes, faster, looser outer boxes).
        sweeps: forward-backward passes of the contractor per box.
    """

    name = 'equations'

    def __init__(
        self,
        title: str,
        graph: Graph,
        constraints: Sequence[Constraint],
        box: np.ndarray,
        units: Sequence[str],
        scale: Sequence[float],
        outputs: Sequence[str],
        solve_for: Sequence[str] | None = None,
        periodic: Sequence[str] = (),
        passive_ratio: float = 4.0,
        sweeps: int = 2,
    ) -> None:
        self.title = name = title
        self.variables = graph.variables
        n = len(self.variables)
        if not 1 <= n <= MAX_VARIABLES:
            raise ConfigError(f'{name}: {n} variables; allowed: 1 to {MAX_VARIABLES}')
        if not constraints or len(constraints) > MAX_CONSTRAINTS:
            raise ConfigError(f'{name}: {len(constraints)} constraints; allowed: 1 to {MAX_CONSTRAINTS}')
        self.box = np.array(box, dtype=float)
        self.units = tuple(units)
        self.scale = np.asarray(scale, dtype=float)
        _check_box(name, n, self.box, self.units, self.scale)
        unknown = [o for o in outputs if o not in self.variables]
        if not outputs or unknown or len(set(outputs)) != len(outputs):
            raise ConfigError(f'{name}: outputs must be distinct variables among {list(self.variables)}; got '
                              f'{list(outputs)}')
        self.outputs = tuple(outputs)
        self.output_index = [self.variables.index(o) for o in self.outputs]
        self.passive_index = [i for i in range(n) if i not in self.output_index]
        equalities = [c for c in constraints if c.equality]
        self.constraints = tuple(constraints)
        passive = [self.variables[i] for i in self.passive_index]
        self.solve_for = _solve_for(name, len(equalities), passive, solve_for)
        self.solved_index = [self.variables.index(v) for v in self.solve_for]
        self.periodic = np.array([v in periodic for v in self.variables])
        _check_periodic(name, graph, self.units, periodic, constraints)
        turn = self.periodic & (self.box[:, 1] - self.box[:, 0] >= 2 * math.pi * (1 - 1e-12))
        self.full_turn = turn
        self.box[turn] += np.array([-1e-15, 1e-15])
        if not (isinstance(sweeps, int) and 1 <= sweeps <= 8) or not 0 < passive_ratio <= 1e6:
            raise ConfigError(f'{name}: sweeps must be 1..8 and passive_ratio positive')
        self.sweeps = sweeps
        self.passive_ratio = float(passive_ratio)
        self.max_passive = MAX_PASSIVE_BOXES
        self.output_scale = self.scale[self.output_index]
        self.passive_scale = self.scale[self.passive_index]
        self.tape = Tape.compile(graph, [c.root for c in self.constraints])
        self.contract_lower = np.array([c.lower[0] for c in self.constraints])
        self.contract_upper = np.array([c.upper[1] for c in self.constraints])
        self.inner_lower = np.array([c.lower[1] for c in self.constraints])
        self.inner_upper = np.array([c.upper[0] for c in self.constraints])
        self.is_equality = np.array([c.equality for c in self.constraints])
        self.eq_tape = Tape.compile(graph, [c.root for c in equalities])
        self.eq_target = Interval(np.array([c.lower[0] for c in equalities]),
                                  np.array([c.upper[1] for c in equalities]))
        # pairs (output box, passive box) per chunk: small enough that a level splits into chunks for a cluster,
        # large enough that numpy's per-call cost stays small (node arrays of the contractor: ~8 MB)
        self.chunk = int(max(512, min(4096, 2**20 // max(self.tape.size, 1))))

    # ------------------------------------------------------------------------------------------ points
    def evaluate(self, points: np.ndarray) -> np.ndarray:
        """Constraint values (N, m) at points (N, n) of all variables (NaN where undefined)."""
        return self.tape.points(np.atleast_2d(np.asarray(points, dtype=float)))

    def feasible(self, points: np.ndarray, tolerance: float = EQUALITY_TOLERANCE) -> np.ndarray:
        """Points (N, n) within the ranges, inequalities holding and equalities to ``tolerance`` (relative to
        1 + |target|): the test of a numerically solved configuration."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        g = self.evaluate(p)
        tol = np.where(self.is_equality, tolerance * (1.0 + np.abs(self.contract_lower)), 0.0)
        ok = (g >= self.contract_lower - tol) & (g <= self.contract_upper + tol)
        inside = np.all((p >= self.box[:, 0]) & (p <= self.box[:, 1]), axis=1)
        return np.asarray(np.all(ok, axis=1) & inside)

    # ---------------------------------------------------------------------------------------- covering
    def covering_task(self, delta: float, approximate: Any) -> CoveringTask:
        """The covering of :mod:`.projection` from the variable box (``delta``, ``approximate``: unused)."""
        first = GroupFrontier(self.box[self.output_index][None].copy(), self.box[self.passive_index][None].copy(),
                              np.zeros(1, dtype=np.int64))
        return CoveringTask(first, projection_step, (), self.box[self.output_index].copy(), self.output_scale,
                            self.chunk)

    def inner_test(self, lo: np.ndarray, hi: np.ndarray, group: np.ndarray) -> np.ndarray:
        """(M,) mask: for every output point of the box, a configuration exists (the existence proof of
        :mod:`.projection`); ``lo, hi`` (M, n) hold the output box and the passive box of each pair, ``group``
        (M,) which output box each pair belongs to. One candidate per output box is tried: the converged
        Newton point with the largest inequality slack (the most interior configuration found)."""
        m = lo.shape[0]
        centre = 0.5 * (lo + hi)
        out = np.zeros(m, dtype=bool)
        blo, bhi = centre.copy(), centre.copy()
        blo[:, self.output_index], bhi[:, self.output_index] = lo[:, self.output_index], hi[:, self.output_index]
        p, ok = centre, np.ones(m, dtype=bool)
        if self.solved_index:
            target = 0.5 * (self.eq_target.lo + self.eq_target.hi)
            p, ok = newton(self.eq_tape, centre, self.solved_index, target)
            sv = p[:, self.solved_index]
            ok &= self._in_range(sv, sv)
        rows = np.flatnonzero(ok)
        with np.errstate(invalid='ignore'):
            g = self.evaluate(p[rows])
            margin = np.minimum(g - self.inner_lower, self.inner_upper - g)
            slack = np.min(np.where(self.is_equality, np.inf, margin), axis=1)
        slack = np.where(np.isnan(slack), -np.inf, slack)
        rows, slack = rows[slack >= 0], slack[slack >= 0]
        order = np.lexsort((-slack, group[rows]))
        _, first = np.unique(group[rows][order], return_index=True)
        rows = rows[order][first]
        if rows.size == 0:
            return out
        if self.solved_index:
            t = Interval(np.broadcast_to(self.eq_target.lo, (rows.size, len(self.solved_index))),
                         np.broadcast_to(self.eq_target.hi, (rows.size, len(self.solved_index))))
            proved, K = krawczyk(self.eq_tape, blo[rows], bhi[rows], p[rows], self.solved_index, self.output_index,
                                 t)
            inside = self._in_range(K.lo, K.hi)
            rows, K = rows[proved & inside], K[proved & inside]
            blo, bhi = blo[rows], bhi[rows]
            blo[:, self.solved_index], bhi[:, self.solved_index] = K.lo, K.hi
        else:
            blo, bhi = blo[rows], bhi[rows]
        vary = [*self.output_index, *self.solved_index]
        enc, maybe = self.tape.root_boxes_tight(blo, bhi, vary)
        holds = (enc.lo >= self.inner_lower) & (enc.hi <= self.inner_upper)
        out[rows] = np.all(holds | self.is_equality, axis=1) & ~maybe
        return out

    def _in_range(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """(M,) mask: the solved variables' ``[lo, hi]`` (M, m) lie within their ranges, a periodic one after
        a shift by a whole number of turns (padded for the rounding of ``2 pi k``)."""
        a, b = self.box[self.solved_index, 0], self.box[self.solved_index, 1]
        per = self.periodic[self.solved_index]
        with np.errstate(invalid='ignore'):
            shift = np.where(per, np.ceil((a - lo) / (2 * math.pi)), 0.0) * (2 * math.pi)
        pad = np.where(per, 1e-15 * (np.abs(lo) + np.abs(shift) + 8.0), 0.0)
        ok = (lo + shift - pad >= a) & (hi + shift + pad <= b)
        return np.asarray(np.all(ok | self.full_turn[self.solved_index], axis=1))

    def describe(self) -> dict[str, Any]:
        return {'type': self.name, 'title': self.title, 'variables': list(self.variables),
                'outputs': list(self.outputs), 'units': list(self.units), 'scale': self.scale.tolist(),
                'box': self.box.tolist(), 'constraints': [c.text for c in self.constraints],
                'solve_for': list(self.solve_for)}


def _non_periodic_use(graph: Graph, var: int, roots: set[int]) -> str:
    """'' when every constraint depends on variable ``var`` through ``sin``/``cos`` of ``k var + rest`` only
    (``k`` an integer): then it is 2 pi periodic in it; else the operation that breaks this."""
    affine, stack = {var}, [var]
    while stack:
        node = stack.pop()
        if node in roots:
            return 'a constraint itself (not through sin or cos)'
        for k, args in enumerate(graph.args):
            if node not in args or k in affine:
                continue
            op = graph.ops[k]
            if op in ('sin', 'cos'):
                continue
            other = [a for a in args if a != node]
            integer = op == 'mul' and len(other) == 1 and other[0] in graph.consts and graph.consts[other[0]][0] == \
                graph.consts[other[0]][1] and float(graph.consts[other[0]][0]).is_integer()
            if op in ('add', 'sub', 'neg') or integer:
                affine.add(k)
                stack.append(k)
            else:
                return op
    return ''


def compiled(model: Any, title: str = '') -> EquationModel:
    """A constraint model whose :meth:`enclose` is written for intervals and expressions alike (e.g. the
    tripod's, the planar 3-RRR's), as an equation model over the same variables (all outputs): covered with
    the contractor and inner boxes proved with the mean-value form, tighter than plain interval bounds."""
    graph = Graph(model.variables)
    roots = model.enclose([graph.var(v) for v in model.variables])
    cons = [Constraint(e, (float(lo), float(lo)), (float(hi), float(hi)), name)
            for e, lo, hi, name in zip(roots, model.lower, model.upper, model.constraint_names, strict=True)]
    return EquationModel(title or model.name, graph, cons, model.box, model.units, model.scale, model.variables)


# ---------------------------------------------------------------------------------------------- YAML
#: A variable's, parameter's or constraint's name: what the equations' tokenizer reads as a name.
_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]{0,31}')


def _name(value: Any, what: str, source: str) -> str:
    if not isinstance(value, str) or not _NAME.fullmatch(value):   # isidentifier took any script's letters
        raise ConfigError(f'{source}: {what} {str(value)[:40]!r} is not a name (ASCII letters, digits, _, not '
                          'starting with a digit; at most 32)')
    if value in FUNCTIONS or value in CONSTANTS:
        raise ConfigError(f'{source}: {what} {value!r} is reserved (a function or constant of the equations)')
    return value


def _texts(data: Mapping[str, Any], key: str, source: str) -> list[str]:
    value = data.get(key) or []
    if not isinstance(value, list) or len(value) > MAX_CONSTRAINTS:
        raise ConfigError(f'{source}: {key} must be a list of at most {MAX_CONSTRAINTS} texts')
    return value


def from_mapping(data: Mapping[str, Any], ws: Mapping[str, Any], source: str, angle_scale: float | None) -> Any:
    """``type: equations`` (see the module docstring); top-level keys named like a parameter override it."""
    params = _parameters(data, source)
    names, box, units, scale = _variables(data, ws, params, source, angle_scale)
    outputs = data.get('outputs')
    if not isinstance(outputs, list) or not all(isinstance(o, str) for o in outputs):
        raise ConfigError(f'{source}: outputs must be a list of variable names among {names}')
    graph = Graph(names)
    symbols = {v: graph.var(v) for v in names}
    symbols.update({k: graph.constant(x) for k, x in params.items()})
    symbols['pi'] = graph.constant(math.nextafter(math.pi, 0.0), math.nextafter(math.pi, 4.0))
    constraints = _constraints(data, graph, symbols, source)
    solve_for, periodic = (_variable_list(data, key, source) for key in ('solve_for', 'periodic'))
    try:
        return EquationModel(str(data.get('name', 'equations'))[:80], graph, constraints, box, units, scale,
                             outputs, solve_for, periodic or ())
    except (InputError, ConfigError) as exc:   # the model's own checks name its title only, not the file
        raise ConfigError(f'{source}: {exc}') from None


def _parameters(data: Mapping[str, Any], source: str) -> dict[str, float]:
    """The ``parameters`` (names to numbers), each overridden by a top-level key of its name; the file's keys
    checked (the known ones and the parameters' names)."""
    params_in = data.get('parameters') or {}
    if not isinstance(params_in, Mapping) or len(params_in) > 64:
        raise ConfigError(f'{source}: parameters must be a mapping of at most 64 names to numbers')
    params = {_name(k, 'parameter', source): number_key(params_in, k, source, positive=False, unit='SI units')
              for k in params_in}
    check_keys(data, (*_KEYS, *params), source)
    for k in params:
        if k in data:
            params[k] = number_key(data, k, source, positive=False, unit='SI units')
    return params


def _variables(data: Mapping[str, Any], ws: Mapping[str, Any], params: Mapping[str, float], source: str,
               angle_scale: float | None) -> tuple[list[str], np.ndarray, list[str], list[float]]:
    """The variables' names, box (n, 2) (the workspace section may narrow it), units (m or rad) and scales
    (angles: ``angle_scale`` metres per radian, default 1)."""
    variables = data.get('variables')
    if not isinstance(variables, Mapping) or not 1 <= len(variables) <= MAX_VARIABLES:
        raise ConfigError(f'{source}: variables must map 1 to {MAX_VARIABLES} names to [lower, upper]')
    names = [_name(v, 'variable', source) for v in variables]
    clash = sorted(set(names) & set(params))
    if clash:
        raise ConfigError(f'{source}: {clash} are both variables and parameters')
    box = np.array([bounds_pair(variables[v], f'variables.{v}', source) for v in names])
    box = box_from(ws, names, box, source)
    units_in = data.get('units') or {}
    if not isinstance(units_in, Mapping) or any(u not in names for u in units_in):
        raise ConfigError(f'{source}: units must map variable names {names} to m or rad')
    units = [units_in.get(v, 'm') for v in names]
    if any(u not in ('m', 'rad') for u in units):
        raise ConfigError(f'{source}: a unit must be m or rad; got {units}')
    scale = [1.0 if u == 'm' else (1.0 if angle_scale is None else angle_scale) for u in units]
    return names, box, units, scale


def _constraints(data: Mapping[str, Any], graph: Graph, symbols: Mapping[str, Any], source: str) -> list[Constraint]:
    """The texts under ``equations`` (equalities only) and ``inequalities`` (no equality), parsed."""
    constraints = []
    for key in ('equations', 'inequalities'):
        for i, text in enumerate(_texts(data, key, source)):
            c = parse_constraint(text, graph, symbols, f'{source}: {key}[{i}]')
            if (key == 'equations') != c.equality:
                raise ExpressionError(f'{source}: {key}[{i}] ({str(text)[:60]!r}) is '
                                      f'{"not " if key == "equations" else ""}an equation; put it under '
                                      f'{"inequalities" if key == "equations" else "equations"}')
            constraints.append(c)
    return constraints


def _variable_list(data: Mapping[str, Any], key: str, source: str) -> list[str] | None:
    """``solve_for`` or ``periodic``: a list of variable names, or None when absent."""
    value = data.get(key)
    if value is not None and not (isinstance(value, list) and all(isinstance(s, str) for s in value)):
        raise ConfigError(f'{source}: {key} must be a list of variable names')
    return value

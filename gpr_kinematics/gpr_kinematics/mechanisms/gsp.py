"""Generalized Stewart platforms (GSP): six distance/angle constraints between base and platform.

Toz & Kucuk 2016 (``docs/references.md``). Each constraint joins geometric
primitives on the base (points ``A_i``, ``A_j`` in the base frame) and on the platform (points ``B_i``,
``B_j`` in the platform frame); lines are ``K_i`` through ``A_i`` with unit direction
``s = (A_j - A_i)/|A_j - A_i|`` and ``L_i`` through ``B_i`` with unit direction ``t = (B_j - B_i)/|.|``.
With ``v = P + R B_i - A_i`` (m) the five constraint types and their inverse kinematics are:

========  ====================  ========================  ========================================
type      leg                   primitives                joint value (eqs. 2-6)
========  ====================  ========================  ========================================
``D1``    SPS                   point A_i - point B_i     ``d = |v|``
``D2``    SPC                   point A_i - line L_i      ``d = |v x R t|``
``D3``    CPS                   line K_i - point B_i      ``d = |v x s|``
``D4``    CCC (prismatic)       line K_i - line L_i       ``d = |v . (R t x s)| / |R t x s|``, parallel: |v x s|
``A1``    CCC (revolute)        line K_i - line L_i       ``cos(theta) = R t . s``
========  ====================  ========================  ========================================

Inverse-Jacobian rows (joint rate per twist ``(v_p, w)``, ``w`` the angular velocity in the base frame),
obtained by differentiating the inverse kinematics with ``dP/dt = v_p`` and ``d(R x)/dt = w x R x``;
with ``w_perp`` the component of ``v`` perpendicular to the line, ``c`` the cross product of the IK:

- D1 (eq. 12): ``[v, R B_i x v] / d``.
- D2 (eq. 13): ``[w_perp, R B_i x w_perp + (v . R t) c] / d`` with ``c = v x R t``, ``w_perp = R t x c``.
- D3 (eq. 14): ``[w_perp, R B_i x w_perp] / d`` with ``w_perp = s x (v x s)``. The angular term printed
  in eq. (14), ``((v x s) x R B_i) / d``, does not match finite differences; this form does.
- D4 (eq. 15): with ``n = R t x s``, ``f = v . n``, ``g = |n|``:
  ``sign(f) [n / g, (R B_i x n + R t x (s x v)) / g - f (R t x (s x n)) / g^3]``.
- A1 (eq. 16): ``[0, -(R t x s) / sin(theta)]``, ``theta = atan2(|R t x s|, R t . s)`` (eq. (6)'s ``acos`` loses
  the angle's digits near 0 and pi).

The rotation is ``R = Rz(C) Ry(B) Rx(A)`` (roll-pitch-yaw, scipy ``from_euler('xyz', [A, B, C])``), the
convention under which the paper's numerical examples reproduce; another convention can be named in
the YAML key ``euler``. All lengths in metres, angles in radians.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError, brief
from ..inputs.schema import check_keys, number_array
from ..inputs.validation import MAX_COORDINATE, bounded, float_array
from .base import Mechanism, as_poses, check_euler_convention, euler_rotation
from .conditioning import check_characteristic_length, homogenize
from .gsp_rows import SCALAR_ROWS, mul3

CONSTRAINT_TYPES = ('D1', 'D2', 'D3', 'D4', 'A1')

#: Which points each constraint type takes (besides ``A_i`` and ``B_i``, which all take).
_POINTS = {
    'D1': ('A_i', 'B_i'),
    'D2': ('A_i', 'B_i', 'B_j'),
    'D3': ('A_i', 'A_j', 'B_i'),
    'D4': ('A_i', 'A_j', 'B_i', 'B_j'),
    'A1': ('A_i', 'A_j', 'B_i', 'B_j'),
}
_LEGS = {'D1': 'SPS', 'D2': 'SPC', 'D3': 'CPS', 'D4': 'CCC', 'A1': 'CCC'}
_ALL_POINTS = ('A_i', 'A_j', 'B_i', 'B_j')
_DEGENERATE = 1e-12  # m: shortest line segment accepted
#: Where each constraint type's inverse-Jacobian row is not defined (it divides by zero there), named by
#: :meth:`GeneralizedStewartPlatform.singularity`.
UNDEFINED_ROW = {
    'D1': 'the points A_i and B_i coincide (d = 0)',
    'D2': 'the point A_i lies on the platform line L (d = 0)',
    'D3': 'the point B_i lies on the base line K (d = 0)',
    'D4': 'the lines K and L are parallel (R t x s = 0): their distance d = |v x s| is defined, their common normal, '
          'and so d\'s rate, is not',
    'A1': 'the lines K and L are parallel (theta = 0 or pi)',
}
#: A row that is exactly zero (D4 of crossing lines, ``f = 0``: d = |f| / g has a corner there), named so too.
ZERO_ROW = 'the lines K and L cross (d = 0): its row is zero, the rate of d = |f| / g is not defined'


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (faster than ``np.cross`` on small trailing axes)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.asarray(a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2])


def _length(a: np.ndarray) -> np.ndarray:
    """``|a|`` over the last axis by ``hypot``: ``sqrt(a . a)`` underflows below 1e-154 (the A1 angle's sine)."""
    return np.asarray(np.hypot(np.hypot(a[..., 0], a[..., 1]), a[..., 2]))


@dataclass(frozen=True)
class Constraint:
    """One GSP constraint: type, its points (base frame ``A_*``, platform frame ``B_*``, m) and limits."""

    type: str
    A_i: np.ndarray
    B_i: np.ndarray
    A_j: np.ndarray | None = None
    B_j: np.ndarray | None = None
    name: str = ''
    limits: tuple[float, float] | None = None

    @property
    def joint_type(self) -> str:
        return 'revolute' if self.type == 'A1' else 'prismatic'

    @property
    def leg(self) -> str:
        return _LEGS[self.type]


def _point(value: Any, where: str) -> np.ndarray:
    arr = number_array(list(value) if isinstance(value, np.ndarray) else value, (3,))
    if arr is None:
        raise ConfigError(f'{where} must be a point [x, y, z] of three finite numbers in m (|x| <= '
                          f'{MAX_COORDINATE:g}); got {brief(value)}')
    return arr


#: Two constraints whose points all lie this close [m] are one constraint given twice.
SAME_POINT = 1e-9


def _check_distinct(constraints: list[Constraint], name: str) -> None:
    """:class:`ConfigError` where two constraints are one: the same type between the same points (a leg given
    twice leaves the platform singular at every pose)."""
    def same(a: Constraint, b: Constraint) -> bool:
        pairs = [(getattr(a, k), getattr(b, k)) for k in ('A_i', 'B_i', 'A_j', 'B_j')]
        return a.type == b.type and all((u is None) == (v is None) and (
            u is None or float(np.max(np.abs(np.asarray(u) - np.asarray(v)))) <= SAME_POINT) for u, v in pairs)
    for i, a in enumerate(constraints):
        for j in range(i + 1, len(constraints)):
            if same(a, constraints[j]):
                names = f' ({a.name}, {constraints[j].name})' if a.name and constraints[j].name else ''
                raise ConfigError(f'{name}: constraints {i + 1} and {j + 1}{names} are one {a.type} between the same '
                                  f'points (within {SAME_POINT:g} m): the platform would be singular at every pose; '
                                  'allowed: six distinct constraints')


def parse_constraint(entry: Any, where: str) -> Constraint:
    """Validate one YAML constraint mapping (``type``, points, optional ``name`` and ``limits``)."""
    if not isinstance(entry, Mapping):
        raise ConfigError(f'{where} must be a mapping with keys type, A_i, B_i (and A_j, B_j for lines); '
                          f'got {brief(entry)}')
    ctype = entry.get('type')
    if ctype not in CONSTRAINT_TYPES:
        raise ConfigError(f'{where}.type = {brief(ctype)} is not a constraint type; allowed: '
                          + ', '.join(CONSTRAINT_TYPES))
    needed = _POINTS[ctype]
    allowed = set(needed) | {'type', 'name', 'limits'}
    extra = sorted(k for k in entry if k in _ALL_POINTS and k not in allowed)
    if extra:
        raise ConfigError(f'{where}: a {ctype} constraint takes the points {", ".join(needed)}; '
                          f'got the extra point(s) {", ".join(extra)}')
    check_keys(entry, allowed, where)
    missing = [k for k in needed if k not in entry]
    if missing:
        raise ConfigError(f'{where}: a {ctype} constraint needs the points {", ".join(needed)}; '
                          f'missing {", ".join(missing)}')
    pts = {k: _point(entry[k], f'{where}.{k}') for k in needed}
    for first, second, label in (('A_i', 'A_j', 'base line K'), ('B_i', 'B_j', 'platform line L')):
        if second in pts and np.linalg.norm(pts[second] - pts[first]) < _DEGENERATE:
            raise ConfigError(f'{where}: degenerate {label}: {second} = {pts[second].tolist()} coincides '
                              f'with {first}, so the line has no direction')
    limits = entry.get('limits')
    if limits is not None:
        ends = isinstance(limits, (list, tuple)) and len(limits) == 2 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in limits)   # +-inf: no limit
        if not ends or not limits[0] < limits[1]:
            raise ConfigError(f'{where}.limits must be [min, max] with min < max (m, or rad for A1); '
                              f'got {brief(limits)}')
        limits = (float(limits[0]), float(limits[1]))
    name = entry.get('name', '')
    return Constraint(type=ctype, A_i=pts['A_i'], B_i=pts['B_i'], A_j=pts.get('A_j'), B_j=pts.get('B_j'),
                      name=str(name), limits=limits)


class GeneralizedStewartPlatform(Mechanism):
    """A six-DOF GSP from six constraints (any of the 195 combinations of D1, D2, D3, D4, A1)."""

    kind = 'gsp'

    def __init__(self, constraints: list[Constraint], name: str = 'GSP', characteristic_length: float = 0.1,
                 euler_convention: str = 'xyz', source: str = '') -> None:
        if len(constraints) != 6:
            raise ConfigError(f'a six-DOF GSP needs exactly 6 constraints; got {len(constraints)}')
        length = check_characteristic_length(characteristic_length, f'{name}: characteristic_length')
        self.constraints = list(constraints)
        _check_distinct(self.constraints, f'{source}: {name}' if source else name)  # source: the file read
        self.name = name
        self.characteristic_length = length
        self.euler_convention = check_euler_convention(euler_convention)
        self.types = np.array([c.type for c in constraints])
        self.joint_types = tuple(c.joint_type for c in constraints)
        self.joint_names = tuple(c.name or f'{c.type.lower()}_{k + 1}' for k, c in enumerate(constraints))
        self.joint_limits = np.array([
            c.limits if c.limits is not None else ((0.0, np.pi) if c.type == 'A1' else (0.0, np.inf))
            for c in constraints], dtype=float)
        nan = np.full(3, np.nan)
        self.A_i = np.array([c.A_i for c in constraints])
        self.B_i = np.array([c.B_i for c in constraints])
        self.A_j = np.array([c.A_j if c.A_j is not None else nan for c in constraints])
        self.B_j = np.array([c.B_j if c.B_j is not None else nan for c in constraints])
        self._prepare()

    def _prepare(self) -> None:
        with np.errstate(invalid='ignore'):
            s = self.A_j - self.A_i
            t = self.B_j - self.B_i
            self.s = s / np.linalg.norm(s, axis=1, keepdims=True)
            self.t = t / np.linalg.norm(t, axis=1, keepdims=True)
        self._t0 = np.nan_to_num(self.t)
        self._floats = [(str(self.types[k]), tuple(self.A_i[k].tolist()), tuple(self.B_i[k].tolist()),
                         tuple(np.nan_to_num(self.s[k]).tolist()), tuple(self._t0[k].tolist())) for k in range(6)]
        self.groups = {ct: np.flatnonzero(self.types == ct) for ct in CONSTRAINT_TYPES}
        self.groups = {k: v for k, v in self.groups.items() if v.size}

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = '<dict>') -> GeneralizedStewartPlatform:
        """Build from YAML (keys ``constraints``, ``characteristic_length``, ``euler``, ``name``)."""
        allowed = {'type', 'name', 'characteristic_length', 'euler', 'constraints', 'poses', 'workspace',
                   'reference'}
        check_keys(data, allowed, source)
        cons = data.get('constraints')
        if not isinstance(cons, list):
            raise ConfigError(f'{source}: key constraints must be a list of 6 constraint mappings; '
                              f'got {brief(cons)}')
        if len(cons) != 6:
            raise ConfigError(f'{source}: key constraints must list exactly 6 constraints; got {len(cons)}')
        parsed = [parse_constraint(c, f'{source}: constraints[{k}]') for k, c in enumerate(cons)]
        L = check_characteristic_length(data.get('characteristic_length', 0.1), f'{source}: characteristic_length')
        euler = data.get('euler', 'xyz')
        try:
            check_euler_convention(euler)
        except InputError as exc:
            raise ConfigError(f'{source}: euler: {exc}') from None
        return cls(parsed, name=str(data.get('name', 'GSP')), characteristic_length=float(L),
                   euler_convention=euler, source=source)

    def parameters(self) -> dict[str, np.ndarray]:
        """The points ``A_i``, ``A_j``, ``B_i``, ``B_j`` ``(6, 3)`` (m; NaN where a constraint has none)."""
        return {'A_i': self.A_i.copy(), 'A_j': self.A_j.copy(), 'B_i': self.B_i.copy(),
                'B_j': self.B_j.copy()}

    def with_parameters(self, params: Mapping[str, Any]) -> GeneralizedStewartPlatform:
        """A copy with the points ``params`` (name -> ``(6, 3)`` [m]); the rows of constraints without that point
        (NaN in :meth:`parameters`) are ignored. Two constraints made one are refused (:class:`InputError`)."""
        p = {'A_i': self.A_i, 'A_j': self.A_j, 'B_i': self.B_i, 'B_j': self.B_j}
        allowed = self.parameters()
        for key, val in params.items():
            if key not in allowed:
                raise InputError(f'{self.name}: unknown parameter {brief(key)}; allowed: {sorted(allowed)}')
            absent = np.isnan(allowed[key][:, 0])  # constraints without this point: their rows are ignored
            arr = float_array(val, f'{self.name}: parameter {key}')
            if arr.shape == (6, 3) and absent.any():
                arr = arr.copy()
                arr[absent] = 0.0
            p[key] = bounded(arr, f'{self.name}: parameter {key}', (6, 3))
            p[key][absent] = np.nan
        for first, second, label in (('A_i', 'A_j', 'base line K'), ('B_i', 'B_j', 'platform line L')):
            gap = np.linalg.norm(p[second] - p[first], axis=1)      # NaN where a constraint has no line
            if np.any(gap < _DEGENERATE):                            # (the file's check: a line needs a direction)
                k = int(np.argmax(gap < _DEGENERATE))
                raise InputError(f'{self.name}: constraint {k + 1}: degenerate {label}: {second} = '
                                 f'{brief(p[second][k].tolist())} coincides with {first}, so the line has no direction')
        def point(key: str, i: int, ctype: str) -> np.ndarray | None:
            return p[key][i].copy() if key in _POINTS[ctype] else None
        constraints = [replace(c, A_i=p['A_i'][i].copy(), B_i=p['B_i'][i].copy(), A_j=point('A_j', i, c.type),
                               B_j=point('B_j', i, c.type)) for i, c in enumerate(self.constraints)]
        try:
            _check_distinct(constraints, self.name)
        except ConfigError as exc:  # the parameters given, not a file, made two constraints one
            raise InputError(str(exc)) from None
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.constraints = constraints
        new.A_i, new.A_j, new.B_i, new.B_j = p['A_i'], p['A_j'], p['B_i'], p['B_j']
        new._prepare()
        return new

    # ------------------------------------------------------------------ kinematics
    def _terms(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        R = euler_rotation(poses[:, 3:], self.euler_convention)
        return self._terms_rt(poses[:, :3], R)

    def _terms_rt(self, pos: np.ndarray, R: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        Rt_ = np.swapaxes(R, -1, -2)
        Rb = self.B_i @ Rt_                                    # (N, 6, 3): R B_k
        v = pos[:, None, :] + Rb - self.A_i
        Rt = self._t0 @ Rt_
        return R, Rb, v, Rt

    def inverse_kinematics(self, poses: Any) -> np.ndarray:
        """Joint values ``(N, 6)`` (m for D1-D4, rad for A1) of poses ``(N, 6)``, eqs. (2)-(6)."""
        arr, single = as_poses(poses)
        q = self.joints_rt(arr[:, :3], euler_rotation(arr[:, 3:], self.euler_convention))
        return q[0] if single else q

    def joints_rt(self, pos: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Joint values ``(N, 6)`` of platform positions ``(N, 3)`` and rotation matrices ``(N, 3, 3)``."""
        if pos.shape[0] == 1:
            return np.array([self._scalar(pos[0].tolist(), R[0].tolist(), False)[0]])
        _, _, v, Rt = self._terms_rt(pos, R)
        q = np.empty(v.shape[:2])
        s = self.s
        for ct, idx in self.groups.items():
            vi = v[:, idx]
            if ct == 'D1':
                q[:, idx] = np.linalg.norm(vi, axis=-1)
            elif ct == 'D2':
                q[:, idx] = np.linalg.norm(_cross(vi, Rt[:, idx]), axis=-1)
            elif ct == 'D3':
                q[:, idx] = np.linalg.norm(_cross(vi, s[idx]), axis=-1)
            elif ct == 'D4':
                n = _cross(Rt[:, idx], s[idx])
                g = np.linalg.norm(n, axis=-1)
                with np.errstate(divide='ignore', invalid='ignore'):   # parallel lines: the distance |v x s|
                    q[:, idx] = np.where(g > 0, np.abs(_dot(vi, n)) / g,
                                         np.linalg.norm(_cross(vi, np.broadcast_to(s[idx], vi.shape)), axis=-1))
            else:  # A1: atan2(|R t x s|, R t . s), every digit near 0 and pi (arccos lost them)
                c = _cross(Rt[:, idx], np.broadcast_to(s[idx], Rt[:, idx].shape))
                q[:, idx] = np.arctan2(_length(c), _dot(Rt[:, idx], s[idx]))
        return q

    def inverse_jacobian(self, poses: Any) -> np.ndarray:
        """Inverse Jacobians ``(N, 6, 6)``, rows eqs. (12)-(16) as corrected in the module docstring.

        Rows are infinite where a row's denominator vanishes (``d = 0``, parallel CCC lines,
        ``sin(theta) = 0``).
        """
        arr, single = as_poses(poses)
        J = self.inverse_jacobian_rt(arr[:, :3], euler_rotation(arr[:, 3:], self.euler_convention))
        return J[0] if single else J

    def inverse_jacobian_rt(self, pos: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Inverse Jacobians ``(N, 6, 6)`` of positions ``(N, 3)`` and rotation matrices ``(N, 3, 3)``."""
        if pos.shape[0] == 1:
            return np.array([self._scalar(pos[0].tolist(), R[0].tolist(), True)[1]])
        _, Rb, v, Rt = self._terms_rt(pos, R)
        J = np.empty(v.shape[:2] + (6,))
        s = self.s
        with np.errstate(divide='ignore', invalid='ignore'):
            for ct, idx in self.groups.items():
                vi, Rbi = v[:, idx], Rb[:, idx]
                if ct == 'D1':
                    inv = (1.0 / np.sqrt(_dot(vi, vi)))[..., None]
                    J[:, idx, :3] = vi * inv
                    J[:, idx, 3:] = _cross(Rbi, vi) * inv
                elif ct == 'D2':
                    Rti = Rt[:, idx]
                    c = _cross(vi, Rti)
                    inv = (1.0 / np.sqrt(_dot(c, c)))[..., None]
                    w = _cross(Rti, c)
                    J[:, idx, :3] = w * inv
                    J[:, idx, 3:] = (_cross(Rbi, w) + _dot(vi, Rti)[..., None] * c) * inv
                elif ct == 'D3':
                    si = s[idx]
                    c = _cross(vi, si)
                    inv = (1.0 / np.sqrt(_dot(c, c)))[..., None]
                    w = _cross(si, c)
                    J[:, idx, :3] = w * inv
                    J[:, idx, 3:] = _cross(Rbi, w) * inv
                elif ct == 'D4':
                    Rti, si = Rt[:, idx], np.broadcast_to(s[idx], vi.shape)
                    n = _cross(Rti, si)
                    gi = (1.0 / np.sqrt(_dot(n, n)))[..., None]
                    f = _dot(vi, n)[..., None]
                    sgi = np.sign(f) * gi
                    J[:, idx, :3] = sgi * n
                    J[:, idx, 3:] = sgi * ((_cross(Rbi, n) + _cross(Rti, _cross(si, vi)))
                                           - (f * gi * gi) * _cross(Rti, _cross(si, n)))
                else:  # A1: -(R t x s) / sin(theta), sin(theta) = |R t x s| (not sqrt(1 - cos^2): no digits near 0)
                    c = _cross(Rt[:, idx], np.broadcast_to(s[idx], Rt[:, idx].shape))
                    J[:, idx, :3] = 0.0
                    J[:, idx, 3:] = c * (-1.0 / _length(c))[..., None]
        return J

    def _scalar(self, p: list[float], R: list[list[float]], jacobian: bool
                ) -> tuple[list[float], list[list[float]]]:
        """One pose in float arithmetic (same formulas as the batch path; numpy's per-call overhead
        dominates a single pose): joint values and, if ``jacobian``, the inverse-Jacobian rows."""
        q: list[float] = []
        rows: list[list[float]] = []
        for ct, a, b, s, t in self._floats:
            Rb = mul3(R, b)
            v = (p[0] + Rb[0] - a[0], p[1] + Rb[1] - a[1], p[2] + Rb[2] - a[2])
            value, row = SCALAR_ROWS[ct](R, Rb, v, s, t, ct, jacobian)
            q.append(value)
            if row is not None:
                rows.append(row)
        return q, rows

    def singularity(self, poses: Any) -> np.ndarray:
        """``(N,)``: the constraints whose inverse-Jacobian row is not defined at each pose and why
        (:data:`UNDEFINED_ROW`, e.g. a D4 constraint's parallel lines); ``''`` where every row is."""
        return self._undefined_rows(self._inverse_jacobian(poses))

    def jacobian_and_singularity(self, poses: Any) -> tuple[np.ndarray, np.ndarray]:
        """The homogenised task Jacobian and :meth:`singularity` from one inverse Jacobian (a six-DOF GSP's task
        Jacobian is its inverse Jacobian: twist rates); a dexterity map computed it twice per pose."""
        J = self._inverse_jacobian(poses)
        return homogenize(J, self.joint_types, self.characteristic_length, self.variable_kinds), self._undefined_rows(J)

    def _inverse_jacobian(self, poses: Any) -> np.ndarray:
        """Inverse Jacobians ``(N, 6, 6)`` of poses, infinite or NaN rows where undefined (no warnings)."""
        arr, _ = as_poses(poses)
        with np.errstate(divide='ignore', invalid='ignore'):
            return self.inverse_jacobian_rt(arr[:, :3], euler_rotation(arr[:, 3:], self.euler_convention))

    def _undefined_rows(self, J: np.ndarray) -> np.ndarray:
        """``(N,)`` strings naming the rows of inverse Jacobians ``J`` (N, 6, 6) that are not finite or all zero."""
        bad = ~np.all(np.isfinite(J), axis=-1)
        zero = np.all(J == 0, axis=-1)
        out = np.full(J.shape[0], '', dtype=object)
        for i in np.flatnonzero(np.any(bad | zero, axis=1)):
            out[i] = '; '.join(f'{self.joint_names[k]} ({self.types[k]}): '
                               + (UNDEFINED_ROW[str(self.types[k])] if bad[i, k] else ZERO_ROW)
                               for k in np.flatnonzero(bad[i] | zero[i]))
        return out

    def describe(self) -> list[dict[str, Any]]:
        """The constraints as plain dicts (type, leg, joint name and type, points in m)."""
        out = []
        for k, c in enumerate(self.constraints):
            item: dict[str, Any] = {'name': self.joint_names[k], 'type': c.type, 'leg': c.leg,
                                    'joint_type': c.joint_type}
            for key in _POINTS[c.type]:
                item[key] = getattr(c, key).tolist()
            out.append(item)
        return out


def load_gsp(data: Mapping[str, Any], source: str) -> GeneralizedStewartPlatform:
    """YAML loader entry for ``type: gsp``."""
    return GeneralizedStewartPlatform.from_dict(data, source)

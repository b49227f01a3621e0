"""Tolerance tables: what is known about a machine before (or after) calibration, for the accuracy budget.

A tolerance table is a YAML file (docs/calibration.md; example ``config/calibration/tolerances_example.yaml``)::

    units: {length: mm, angle: deg}        # optional; SI (m, rad) by default
    parameters:                            # the model's parameters, by name or by configuration key
      rod_positions: {tolerance: 0.03}     # deviation uniform in [-0.03, 0.03] mm about the nominal
      rod_directions: {tolerance: 0.01, distribution: normal} # normal, tolerance = 3 sigma (deg here)
      rod2_offset: {tolerance: 0.01}       # one parameter's own entry wins over its key's
      kappa: {range: [0.5, 2.0], distribution: log-uniform}   # the value itself lies in the range
    rod_length: {tolerance: 0.002}         # actuator positioning error, each rod at each pose
    joint_clearance: 0.003                 # play of each spherical joint (radius of a ball), or [c1, c2, c3]
    measurement_noise: {position: 0.005, angle: 0.001}        # tracker sigmas, for a planned calibration

Distributions: ``uniform`` (default) on ``[-t, t]`` or on the range; ``normal`` with ``sigma = t / 3`` (the
tolerance is the 3-sigma bound, and the worst case of the linearised budget); ``log-uniform`` on a range of
positive values (a stiffness ratio known within a factor). A stiffness ratio takes uniform or log-uniform within
``1e-6 .. 1e6`` and is varied as its anisotropy ``(kappa - 1) / (kappa + 1)`` (the coordinate of
:class:`~.model.Parameter`). A joint's play displaces its centre uniformly within a ball of radius ``c`` (each
component: ``sigma = c / sqrt(5)``), anew at every pose.

Every value is checked (:class:`~gpr_kinematics.errors.ConfigError` naming the file, key and what is allowed),
and tolerances are bounded (:data:`MAX_TOLERANCE`): beyond them the budget's linearisation is meaningless and
the kinematics leaves its domain.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.machine import parameter_range
from ..core.parameters import PARAMETERS
from ..errors import ConfigError, apart
from ..inputs import safe_yaml
from ..inputs.schema import check_keys, is_number
from ..inputs.units import ANGLE_UNITS, LENGTH_UNITS, as_typed, both_units, to_si
from ..inputs.validation import decimal_number
from ..mechanisms.accuracy import JOINT_ANGLE_ERROR_MOST, PARAMETER_ERROR_MOST
from .frames import AXES
from .measurements import SIGMA_RANGE
from .model import KAPPA_RANGE, Parameter, ParameterSet, coordinate_of

Array = NDArray[np.float64]

DISTRIBUTIONS = ('uniform', 'normal', 'log-uniform')
#: Largest tolerance (half-width or range) accepted per unit, SI.
MAX_TOLERANCE = {'m': PARAMETER_ERROR_MOST, 'rad': JOINT_ANGLE_ERROR_MOST, '1': 1e6}
#: Relative slack of those bounds for a range's ends, whose deviations from the nominal are differences of rounded
#: numbers: ``rod2_x: {range: [-56.609, -36.609]}`` (mm, the nominal -46.609 mm plus 10 mm) reaches 0.01 m and 1e-17.
BOUND_SLACK = 1e-9
_LENGTH = LENGTH_UNITS
_ANGLE = ANGLE_UNITS


#: Gauss-Legendre nodes and weights on [0, 1] for the moments of a transformed deviation (the integrand is
#: analytic in the distribution's quantile: 48 nodes give them to rounding).
_X, _W = np.polynomial.legendre.leggauss(48)
_NODES, _WEIGHTS = 0.5 * (_X + 1.0), 0.5 * _W


@dataclass(frozen=True)
class Tolerance:
    """The deviation ``x`` of a value from its nominal: ``x`` in ``[low, high]`` (SI) with a distribution.

    For ``normal``, ``[low, high] = [-t, t]`` and ``sigma = t / 3``; ``log-uniform`` is on the *value*
    ``nominal + x``, which must stay > 0 (set by :meth:`ToleranceTable.bind`).

    With a ``transform`` (:data:`~.model.TRANSFORMS`: a stiffness ratio identified by its anisotropy), the
    statistics below are those of the *coordinate's* deviation ``c(nominal + x) - c(nominal)``, which is what the
    budget varies: :attr:`bounds` map the interval's ends, :attr:`mean` and :attr:`std` are integrated over the
    distribution (Gauss-Legendre on its quantile function), :meth:`sample` maps the drawn values.
    """

    low: float
    high: float
    distribution: str = 'uniform'
    nominal: float = 0.0
    transform: str = ''

    def _coordinate(self, x: Any) -> Any:
        """The coordinate's deviation of value deviations ``x``."""
        if not self.transform:
            return x
        return coordinate_of(self.transform, self.nominal + np.asarray(x)) - coordinate_of(self.transform,
                                                                                           self.nominal)

    def _quantile(self, t: Array) -> Array:
        """Value deviations at probabilities ``t`` (uniform and log-uniform: what a transform takes)."""
        if self.distribution == 'log-uniform':
            a, b = self.nominal + self.low, self.nominal + self.high
            return np.asarray(a * (b / a) ** t - self.nominal, dtype=np.float64)
        return self.low + (self.high - self.low) * t

    @property
    def bounds(self) -> tuple[float, float]:
        """The ends of the deviation's interval (of the coordinate's, with a transform)."""
        return float(self._coordinate(self.low)), float(self._coordinate(self.high))

    @property
    def centre(self) -> float:
        """Middle of :attr:`bounds` (the centre of the interval a worst case spans)."""
        lo, hi = self.bounds
        return 0.5 * (lo + hi)

    @property
    def mean(self) -> float:
        """Mean deviation."""
        if self.transform:
            return float(_WEIGHTS @ self._coordinate(self._quantile(_NODES)))
        if self.distribution == 'log-uniform':
            a, b = self.nominal + self.low, self.nominal + self.high
            return (b - a) / math.log(b / a) - self.nominal
        return 0.5 * (self.low + self.high)

    @property
    def std(self) -> float:
        """Standard deviation."""
        if self.transform:
            u = self._coordinate(self._quantile(_NODES))
            return math.sqrt(max(float(_WEIGHTS @ u ** 2) - self.mean ** 2, 0.0))
        if self.distribution == 'normal':
            return 0.5 * (self.high - self.low) / 3.0
        if self.distribution == 'log-uniform':
            a, b = self.nominal + self.low, self.nominal + self.high
            m2 = (b * b - a * a) / (2.0 * math.log(b / a))
            m1 = self.mean + self.nominal
            return math.sqrt(max(m2 - m1 * m1, 0.0))
        return (self.high - self.low) / math.sqrt(12.0)

    def sample(self, rng: np.random.Generator, shape: tuple[int, ...]) -> Array:
        """Deviations drawn from the distribution (the coordinate's, with a transform)."""
        if self.distribution == 'normal':
            return rng.normal(0.5 * (self.low + self.high), 0.5 * (self.high - self.low) / 3.0, shape)
        return np.asarray(self._coordinate(self._quantile(rng.uniform(0.0, 1.0, shape))), dtype=np.float64)


@dataclass(frozen=True)
class ToleranceTable:
    """A parsed tolerance table (module docstring); values in the file's units until :meth:`bind` (SI after).

    Attributes:
        entries: parameter name or key -> ``(kind, values, distribution)`` as written (kind ``tolerance`` or
            ``range``), converted to SI per the parameter's unit at :meth:`bind`.
        rod_length: actuator error of each rod at each pose (SI), or ``None``.
        joint_clearance: radius of each joint's play [m] (zeros: none).
        sigma_position, sigma_angle: tracker standard deviations [m], [rad], or ``None``.
        units: the declared ``(length, angle)`` units; source: file name for messages.
    """

    entries: dict[str, tuple[str, tuple[float, ...], str]]
    rod_length: Tolerance | None
    joint_clearance: tuple[float, float, float]
    sigma_position: float | None
    sigma_angle: float | None
    units: tuple[str, str] = ('m', 'rad')
    source: str = 'tolerances'

    def bind(self, params: ParameterSet) -> list[Tolerance | None]:
        """Per parameter of ``params`` its :class:`Tolerance` in SI (``None``: exact). A parameter's own name
        wins over its configuration key.

        Raises:
            ConfigError: an entry names no parameter, or is out of range for the parameter's unit and nominal.
        """
        out: list[Tolerance | None] = [None] * len(params)
        for key in self.entries:
            if key not in params.names and key not in params.groups:
                raise ConfigError(f'{self.source}: parameters: unknown parameter {safe_yaml.brief(key)}; this model '
                                  f'has {", ".join(params.names)} (or whole keys: {", ".join(params.groups)})')
        for j, p in enumerate(params):
            if p.name in self.entries:
                key = p.name
            elif p.key in self.entries:
                key = p.key
            else:
                continue
            out[j] = self._tolerance(p, key)
        return out

    def _tolerance(self, p: Parameter, key: str) -> Tolerance | None:
        """The entry ``key`` as the :class:`Tolerance` of parameter ``p`` (SI), checked."""
        kind, vals, dist = self.entries[key]
        f = {'m': _LENGTH[self.units[0]], 'rad': _ANGLE[self.units[1]], '1': 1.0}[p.unit]
        where = f'{self.source}: parameters: {key}'
        limit = MAX_TOLERANCE[p.unit]
        own = {'m': self.units[0], 'rad': self.units[1]}.get(p.unit, p.unit)   # the file's unit: named as well
        nominal = float(p.value(p.nominal))
        if kind == 'tolerance':
            t = to_si(vals[0], f)
            if t > limit:
                raise ConfigError(f'{where}: tolerance {as_typed(vals[0], t, p.unit, own)}; allowed: '
                                  f'{_most(limit, p.unit, own)}')
            if t == 0:
                return None
            lo, hi, low, high = nominal - t, nominal + t, -t, t
        else:
            lo, hi = to_si(vals[0], f), to_si(vals[1], f)
            if hi - lo > 2 * limit * (1.0 + BOUND_SLACK):
                raise ConfigError(f'{where}: range [{lo:.6g}, {hi:.6g}] {p.unit} is {hi - lo:.9g} {p.unit} wide; '
                                  f'allowed: {_most(2 * limit, p.unit, own)}')
            low, high = lo - nominal, hi - nominal
            reach = max(abs(low), abs(high))
            if not p.transform and reach > limit * (1.0 + BOUND_SLACK):  # it bypassed the tolerance's bound
                raise ConfigError(f'{where}: range [{lo:.6g}, {hi:.6g}] {p.unit} reaches {reach:.9g} {p.unit} from '
                                  f'the nominal {nominal:.6g} {p.unit}; allowed: {_within(limit, p.unit)}')
        self._within_geometry(p, where, kind, to_si(vals[0], f) if kind == 'tolerance' else None, lo, hi)
        if dist == 'log-uniform' and lo <= 0:
            raise ConfigError(f'{where}: a log-uniform range must be positive; got [{lo:.6g}, {hi:.6g}]')
        if p.transform:
            if dist == 'normal':
                raise ConfigError(f'{where}: a stiffness ratio takes uniform or log-uniform (it must stay positive); '
                                  'normal has no bound')
            if not KAPPA_RANGE[0] <= lo < hi <= KAPPA_RANGE[1]:
                raise ConfigError(f'{where}: [{lo:.6g}, {hi:.6g}] leaves the range of a stiffness ratio; allowed: '
                                  f'{_stiffness()}')
        return Tolerance(low, high, dist, nominal, p.transform)


    @staticmethod
    def _within_geometry(p: Parameter, where: str, kind: str, t: float | None, lo: float, hi: float) -> None:
        """Refuse values ``[lo, hi]`` of ``p`` beyond its geometry's range (:func:`~..core.machine.parameter_range`):
        ``rod_directions: {tolerance: 0.1}``, within :data:`MAX_TOLERANCE`, drew rods of 0.09 and the Monte Carlo was
        refused as 'per-row geometry, row 0', naming no table entry."""
        limits = None if p.transform else parameter_range(p.name)
        if limits is None or limits[0] <= lo and hi <= limits[1]:
            return
        given = f'tolerance {t:.6g} {p.unit}' if kind == 'tolerance' else f'range [{lo:.6g}, {hi:.6g}] {p.unit}'
        raise ConfigError(f'{where}: {given} takes {p.name} to [{lo:.6g}, {hi:.6g}] (nominal {p.value(p.nominal):.6g})'
                          f'; allowed: within the geometry\'s limits [{limits[0]:g}, {limits[1]:g}] of {p.name} '
                          f'({p.key}: {limits[2]})')


def centre_of(table: ToleranceTable, params: ParameterSet) -> Array:
    """Where the table's tolerances are: each parameter's coordinate at its nominal plus its tolerance's mean
    deviation (a ``kappa`` range's centre, not the geometry file's ``kappa``), within its range. Budgets and
    plans are linearised there."""
    shift = np.array([t.mean if t is not None else 0.0 for t in table.bind(params)])
    lo, hi = params.bounds
    return np.asarray(np.clip(params.nominal + shift, lo, hi), dtype=np.float64)


def bound_of(table: ToleranceTable, params: ParameterSet) -> Array:
    """The table's worst-case deviation of each parameter's coordinate from its nominal (the farther end of its
    interval; ``nan`` where the table has none): the a-priori bound of a held parameter's bias."""
    out = np.full(len(params), np.nan)
    for j, t in enumerate(table.bind(params)):
        if t is not None:
            out[j] = max(abs(v) for v in t.bounds)
    return out


#: The prior of a parameter whose tolerance is 0 (exact), as a fraction of its scale: identification and planning
#: hold it at its nominal value, as the budget takes it (a zero cannot be a prior; it was read as no entry, and the
#: parameter fitted with the model's default scale).
EXACT_PRIOR = 1e-12


def free_of(params: ParameterSet, free: Iterable[str] | None, prior: ArrayLike | None) -> NDArray[np.bool_]:
    """The parameters ``free`` (names or keys; all by default) but those a tolerance of 0 knows exactly (a ``prior``
    of :data:`EXACT_PRIOR` of the scale): identification and planning fix them at nominal (free, they were held as
    directions 'the poses cannot see', the best determined parameters named as the worst)."""
    mask = params.select(free)
    if prior is not None:
        mask &= ~(np.asarray(prior, dtype=float) <= EXACT_PRIOR * params.scale)
    return mask


def prior_of(table: ToleranceTable, params: ParameterSet) -> Array:
    """The table's standard deviation of each parameter (``nan`` where the table has none; :data:`EXACT_PRIOR` of
    its scale where its tolerance is 0), as the ``prior`` of identification and planning."""
    bound = table.bind(params)
    listed = [p.name in table.entries or p.key in table.entries for p in params]
    return np.array([t.std if t is not None else EXACT_PRIOR * s if given else np.nan
                     for t, given, s in zip(bound, listed, params.scale, strict=True)])


def _most(limit: float, unit: str, own: str = '') -> str:
    """What a tolerance of ``unit`` may be (:data:`MAX_TOLERANCE`), as every refusal of one names it; also in the
    file's unit ``own`` when another (``at most 0.01 m (10 mm)``)."""
    return f'at most {limit:g}' if unit == '1' else f'at most {both_units(limit, None, unit, own or unit)}'


def _allowed(key: str) -> tuple[str, str]:
    """What a tolerance and a range's ends of the ``parameters`` entry ``key`` may be, as :meth:`ToleranceTable.bind`
    refuses a number beyond them: by the unit of the geometry parameter or frame coordinate of that name or key,
    known before the model (both units' bounds for a key of none: it is refused as unknown at ``bind``)."""
    unit = next((gp.unit for gp in PARAMETERS if key in (gp.name, gp.key)), None)
    frame, _, axis = key.partition('_')
    if unit is None and frame in ('base', 'target') and axis in AXES:
        unit = 'm' if axis in AXES[:3] else 'rad'
    if unit == '1':
        return _most(MAX_TOLERANCE['1'], '1'), _stiffness()
    if unit is not None:
        return _most(MAX_TOLERANCE[unit], unit), _within(MAX_TOLERANCE[unit], unit)
    m, r = MAX_TOLERANCE['m'], MAX_TOLERANCE['rad']
    return (f'at most {m:g} m for a length, {r:g} rad for an angle (the parameter\'s unit)',
            f'values within {m:g} m (a length) or {r:g} rad (an angle) of the nominal')


def _within(limit: float, unit: str) -> str:
    """What a range's ends of ``unit`` may be."""
    return f"values within {limit:g} {unit} of the nominal (a key's range applies to each of its parameters)"


def _stiffness() -> str:
    """What a stiffness ratio's range may be."""
    return f'{KAPPA_RANGE[0]:g} to {KAPPA_RANGE[1]:g}'


def _finite(value: Any, where: str, allowed: str) -> float:
    """``value`` as a float, refused naming ``allowed`` (its quantity's bound) unless a number."""
    if not is_number(value):  # the package's one rule: no bool or text, finite, |x| <= 1e6 (a 401-digit integer too)
        text = isinstance(value, str) and decimal_number(value) is not None   # '3.0e-5' was told 'at most 0.01 m'
        kind = ' (YAML read it as text: write the number without quotes)' if text else \
            '' if isinstance(value, (int, float)) and not isinstance(value, bool) else ' (no number)'
        raise ConfigError(f'{where} = {safe_yaml.brief(value)}{kind}; allowed: {allowed}')
    return float(value)


def _number(value: Any, where: str, allowed: str, positive: bool = False) -> float:
    v = _finite(value, where, allowed)
    if v < 0 or (positive and v == 0):
        bound = '> 0' if positive else '>= 0'
        raise ConfigError(f'{where} = {safe_yaml.brief(value)}; allowed: a finite number {bound}')
    return v


def _entry(where: str, spec: Any, allowed: tuple[str, str]) -> tuple[str, tuple[float, ...], str]:
    """An entry as ``(kind, values, distribution)``; a value that is no number (NaN, text, beyond 1e6) is refused
    naming ``allowed`` (for a tolerance, for a range's ends): the bound a number beyond it meets."""
    if not isinstance(spec, Mapping):
        raise ConfigError(f'{where}: expected a mapping such as {{tolerance: 2.0e-5}} or {{range: [0.5, 2.0]}}')
    check_keys(spec, ('tolerance', 'range', 'distribution'), where)
    dist = spec.get('distribution', 'uniform')
    if dist not in DISTRIBUTIONS:
        raise ConfigError(f'{where}: distribution {safe_yaml.brief(dist)}; allowed: {", ".join(DISTRIBUTIONS)}')
    if ('tolerance' in spec) == ('range' in spec):
        raise ConfigError(f'{where}: give exactly one of tolerance (a half-width) or range ([low, high])')
    if 'tolerance' in spec:
        if dist == 'log-uniform':
            raise ConfigError(f'{where}: log-uniform needs a range; allowed with a tolerance: uniform, normal')
        return 'tolerance', (_number(spec['tolerance'], f'{where}: tolerance', allowed[0]),), dist
    rng = spec['range']
    if not isinstance(rng, list) or len(rng) != 2:
        raise ConfigError(f'{where}: range = {safe_yaml.brief(rng)}; allowed: [low, high]')
    if dist == 'normal':
        raise ConfigError(f'{where}: a range takes uniform or log-uniform; normal needs a tolerance')
    if not all(is_number(v) for v in rng):
        raise ConfigError(f'{where}: range = {safe_yaml.brief(rng)}; allowed: {allowed[1]}')
    lo, hi = float(rng[0]), float(rng[1])
    if not lo < hi:
        raise ConfigError(f'{where}: range [{lo:g}, {hi:g}]; allowed: low < high')
    return 'range', (lo, hi), dist


def _noise(noise: Any, source: str, length: str, angle: str) -> tuple[float | None, float | None]:
    """The table's ``measurement_noise`` (SI): the sigmas a measurement file's rows may have
    (:data:`~.measurements.SIGMA_RANGE`; 1e6 m passed gpr accuracy's plan, and gpr calibrate named no file)."""
    if noise is None:
        return None, None
    if not isinstance(noise, Mapping):
        raise ConfigError(f'{source}: measurement_noise: expected {{position: sigma, angle: sigma}}')
    check_keys(noise, ('position', 'angle'), f'{source}: measurement_noise')
    lo, hi = SIGMA_RANGE
    si = []
    for key, unit, own in (('position', 'm', length), ('angle', 'rad', angle)):
        allowed = f'a standard deviation from {both_units(lo, hi, unit, own)}'
        typed = _number(noise.get(key), f'{source}: measurement_noise: {key}', allowed, positive=True)
        value = to_si(typed, {**_LENGTH, **_ANGLE}[own])
        if not lo <= value <= hi:
            shown = as_typed(typed, value, unit, own) if own != unit else \
                f'{apart(value, hi if value > hi else lo)[0]} {unit}'   # 0.1000001 read 0.1, the bound
            raise ConfigError(f'{source}: measurement_noise: {key} = {shown}; allowed: {allowed}')
        si.append(value)
    return si[0], si[1]


def parse_tolerances(data: Any, source: str = 'tolerances') -> ToleranceTable:
    """Check and convert a parsed tolerance table (module docstring)."""
    if not isinstance(data, Mapping):
        raise ConfigError(f'{source}: expected a mapping with keys parameters, rod_length, joint_clearance, '
                          'measurement_noise, units')
    check_keys(data, ('units', 'parameters', 'rod_length', 'joint_clearance', 'measurement_noise'), source)
    units = {} if data.get('units') is None else data['units']   # units: [] passed as no units
    if not isinstance(units, Mapping):
        raise ConfigError(f'{source}: units: expected {{length: m|mm, angle: rad|deg}}')
    check_keys(units, ('length', 'angle'), f'{source}: units')
    length, angle = units.get('length', 'm'), units.get('angle', 'rad')
    if not isinstance(length, str) or not isinstance(angle, str) or length not in _LENGTH or angle not in _ANGLE:
        raise ConfigError(f'{source}: units: length {safe_yaml.brief(length)}, angle {safe_yaml.brief(angle)}; '
                          'allowed: length m or mm, angle rad or deg')
    lf = _LENGTH[length]
    params = {} if data.get('parameters') is None else data['parameters']
    if not isinstance(params, Mapping):
        raise ConfigError(f'{source}: parameters: expected a mapping of parameter names to tolerances')
    entries = {str(k): _entry(f'{source}: parameters: {str(k)[:60]}', v, _allowed(str(k))) for k, v in params.items()}
    rod = None
    most = _most(MAX_TOLERANCE['m'], 'm', length)
    if data.get('rod_length') is not None:
        kind, vals, dist = _entry(f'{source}: rod_length', data['rod_length'],
                                  (most, f'a tolerance (a half-width) {most}, not a range'))
        if kind != 'tolerance':
            raise ConfigError(f'{source}: rod_length: give a tolerance (a half-width), not a range')
        t = to_si(vals[0], lf)
        if t > MAX_TOLERANCE['m']:
            raise ConfigError(f'{source}: rod_length: tolerance {as_typed(vals[0], t, "m", length)}; allowed: {most}')
        rod = Tolerance(-t, t, dist) if t > 0 else None
    clear = data.get('joint_clearance', 0.0)
    clear_list = clear if isinstance(clear, list) else [clear] * 3
    if len(clear_list) != 3:
        raise ConfigError(f'{source}: joint_clearance: one value or a list of 3 (one per joint), in {length}')
    typed = [_number(c, f'{source}: joint_clearance', most) for c in clear_list]
    clearance = tuple(to_si(c, lf) for c in typed)
    if max(clearance) > MAX_TOLERANCE['m']:
        k = clearance.index(max(clearance))
        raise ConfigError(f'{source}: joint_clearance: {as_typed(typed[k], clearance[k], "m", length)}; allowed: '
                          f'{most}')
    sp, sa = _noise(data.get('measurement_noise'), source, length, angle)
    return ToleranceTable(entries=entries, rod_length=rod, joint_clearance=clearance,  # type: ignore[arg-type]
                          sigma_position=sp, sigma_angle=sa, units=(length, angle), source=source)


def load_tolerances(path: str | Path) -> ToleranceTable:
    """Read a tolerance table (bounded YAML reader: no aliases, regular UTF-8 files of limited size)."""
    return parse_tolerances(safe_yaml.read_file(path, 'tolerance table'), str(path))

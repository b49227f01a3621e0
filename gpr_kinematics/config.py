"""Geometry and model configuration of the GPR, loaded from YAML and validated.

The package's embedded default is ``config/gpr.yaml``; a user's file overrides any subset of its keys.
All values are SI (metres, radians). Every value is checked on load; a bad one raises
:class:`~gpr_kinematics.errors.ConfigError` naming the key, the value and what is allowed.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import safe_yaml
from .errors import ConfigError
from .resources import config_path

MODELS = ('radial', 'polar', 'offset')
WEIGHTINGS = ('characteristic', 'unweighted')


@dataclass(frozen=True)
class GprConfig:
    """Geometry, limits and solver settings of one GPR (SI units).

    Attributes:
        radius: radius ``R`` of the circle of rod axes [m].
        rod_azimuths: azimuths ``theta_k`` of rods 1, 2, 3 in the base frame [rad].
        stroke_min, stroke_max: range of the rod lengths ``q_k`` [m].
        tilt_limit: largest platform tilt accepted by inverse kinematics and compensation [rad].
        imperfection_budget: largest virtual-joint displacement of a joint centre the real joints
            can absorb [m]; forward kinematics reports whether a pose stays inside it.
        model: virtual-joint model, ``radial``, ``polar`` or ``offset`` (design.md §3).
        characteristic_length: length that weights angular virtual joints in the minimum-norm Newton
            step [m]; ``None`` in a file means ``radius``.
        weighting: ``characteristic`` (unit-free norm: joint-centre displacement) or ``unweighted``
            (paper eq. 8 as printed, mixing metres and radians).
        max_iterations: bound on Newton iterations per solve.
        tolerance: closure tolerance on the side lengths [m].
    """

    radius: float = 0.093218
    rod_azimuths: tuple[float, float, float] = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)
    stroke_min: float = 0.0
    stroke_max: float = 0.508
    tilt_limit: float = math.radians(2.0)
    imperfection_budget: float = 0.0005
    model: str = 'radial'
    characteristic_length: float = field(default=0.0)
    weighting: str = 'characteristic'
    max_iterations: int = 12
    tolerance: float = 1e-14

    def __post_init__(self) -> None:
        if self.characteristic_length in (None, 0.0):
            object.__setattr__(self, 'characteristic_length', self.radius)
        _validate(self)

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], source: str = 'config') -> GprConfig:
        """Build a config from a mapping, starting from the dataclass defaults."""
        return _build(cls(), values, source)

    def replace(self, **changes: Any) -> GprConfig:
        """Return a validated copy with ``changes`` applied (same keys as the YAML file)."""
        return _build(self, changes, 'replace()')

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of the values (lists instead of tuples), as written in YAML."""
        out = dataclasses.asdict(self)
        out['rod_azimuths'] = list(self.rod_azimuths)
        return out


_FLOAT_RANGES: dict[str, tuple[float, float, str]] = {
    'radius': (1e-4, 10.0, 'metres, 1e-4 < radius <= 10'),
    'stroke_min': (-10.0, 10.0, 'metres, -10 <= stroke_min < stroke_max'),
    'stroke_max': (-10.0, 10.0, 'metres, stroke_min < stroke_max <= 10'),
    'tilt_limit': (1e-6, math.radians(15.0), 'radians, 0 < tilt_limit <= 0.2618 (15 deg)'),
    'imperfection_budget': (1e-9, 0.01, 'metres, 0 < imperfection_budget <= 0.01'),
    'characteristic_length': (1e-6, 100.0, 'metres, > 0, or null for the radius'),
    'tolerance': (1e-16, 1e-6, 'metres, 1e-16 <= tolerance <= 1e-6'),
}


def check_keys(data: Mapping[Any, Any], allowed: Iterable[str], where: str) -> None:
    """Refuse keys of a YAML mapping outside ``allowed``: :class:`ConfigError` names them and the allowed ones."""
    allowed = set(allowed)
    unknown = sorted(str(k) for k in data if k not in allowed)
    if unknown:
        raise ConfigError(f'{where}: unknown key(s) {", ".join(unknown)}; allowed keys: ' + ', '.join(sorted(allowed)))


def number_key(data: Mapping[Any, Any], key: str, source: str, default: float | None = None,
               positive: bool = True, unit: str = 'm') -> float:
    """A finite number (not a bool, not a string) under ``key`` of a YAML mapping, positive unless
    ``positive=False``; ``default`` when absent; else :class:`ConfigError` naming file, key and value."""
    val = data.get(key, default)
    what = f'{"positive " if positive else ""}finite {"length" if unit == "m" else "number"} in {unit}'
    if val is None:
        raise ConfigError(f'{source}: missing key {key} (a {what})')
    if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val) or (positive and val <= 0):
        raise ConfigError(f'{source}: {key} must be a {what}; got {val!r}')
    return float(val)


def _fail(source: str, key: str, value: Any, allowed: str) -> ConfigError:
    return ConfigError(f'{source}: {key} = {value!r} is invalid; allowed: {allowed}')


def _as_float(source: str, key: str, value: Any, allowed: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(source, key, value, allowed)
    out = float(value)
    if not math.isfinite(out):
        raise _fail(source, key, value, allowed)
    return out


def _build(base: GprConfig, values: Mapping[str, Any], source: str) -> GprConfig:
    if not isinstance(values, Mapping):
        raise ConfigError(f'{source}: expected a mapping of keys to values, got {type(values).__name__}')
    check_keys(values, (f.name for f in dataclasses.fields(GprConfig)), source)
    merged: dict[str, Any] = base.to_dict()
    if base.characteristic_length == base.radius and 'characteristic_length' not in values:
        merged['characteristic_length'] = None  # it followed the radius: keep following it
    merged.update(values)
    conv: dict[str, Any] = {}
    for key, (lo, hi, allowed) in _FLOAT_RANGES.items():
        value = merged[key]
        if key == 'characteristic_length' and value is None:
            conv[key] = 0.0
            continue
        val = _as_float(source, key, value, allowed)
        if not lo <= val <= hi:
            raise _fail(source, key, value, allowed)
        conv[key] = val
    az = merged['rod_azimuths']
    allowed_az = 'a list of 3 finite, distinct angles in radians within [-2pi, 2pi]'
    if not isinstance(az, (list, tuple)) or len(az) != 3:
        raise _fail(source, 'rod_azimuths', az, allowed_az)
    conv['rod_azimuths'] = tuple(_as_float(source, 'rod_azimuths', a, allowed_az) for a in az)
    if any(abs(a) > 2 * math.pi + 1e-12 for a in conv['rod_azimuths']):
        raise _fail(source, 'rod_azimuths', az, allowed_az)
    for key, choices in (('model', MODELS), ('weighting', WEIGHTINGS)):
        if merged[key] not in choices:
            raise _fail(source, key, merged[key], ' or '.join(choices))
        conv[key] = merged[key]
    iters = merged['max_iterations']
    if isinstance(iters, bool) or not isinstance(iters, int) or not 1 <= iters <= 100:
        raise _fail(source, 'max_iterations', iters, 'an integer from 1 to 100')
    conv['max_iterations'] = iters
    try:
        return GprConfig(**conv)
    except ConfigError as exc:
        raise ConfigError(f'{source}: {exc}') from None


def _validate(cfg: GprConfig) -> None:
    if not cfg.stroke_min < cfg.stroke_max:
        raise ConfigError(f'stroke_min = {cfg.stroke_min!r} must be below stroke_max = {cfg.stroke_max!r}')
    a = [math.remainder(x, 2 * math.pi) for x in cfg.rod_azimuths]
    gaps = [abs(math.remainder(a[i] - a[j], 2 * math.pi)) for i, j in ((0, 1), (1, 2), (2, 0))]
    if min(gaps) < math.radians(10.0):
        raise ConfigError(f'rod_azimuths = {list(cfg.rod_azimuths)!r}: rods must be at least 10 deg apart '
                          'so that the joint triangle is not degenerate')


def default_config() -> GprConfig:
    """The package's embedded configuration (``config/gpr.yaml``)."""
    return load_config()


def read_yaml(path: str | Path, what: str = 'config') -> Any:
    """Parse a YAML file with the package's bounds (:func:`gpr_kinematics.safe_yaml.read_file`: no aliases,
    bounded nesting and size, UTF-8, regular files only); any problem raises :class:`ConfigError` naming the file
    (``what`` says which kind of file it is in the message: config, program, mechanism)."""
    return safe_yaml.read_file(path, what)


def _read_yaml(path: Path) -> Mapping[str, Any]:
    data = read_yaml(path)
    if data is None:
        return {}
    if not isinstance(data, Mapping):
        raise ConfigError(f'{path}: expected a mapping of keys to values, got {type(data).__name__}')
    return data


def load_config(path: str | Path | None = None,
                overrides: Mapping[str, Any] | None = None) -> GprConfig:
    """Load the embedded default, then a user's file ``path`` and ``overrides`` on top of it.

    Raises:
        ConfigError: unreadable file, invalid YAML, unknown key or a value outside its range.
    """
    default_path = config_path('gpr.yaml')
    cfg = _build(GprConfig(), _read_yaml(default_path), str(default_path))
    if path is not None:
        user = Path(path)
        cfg = _build(cfg, _read_yaml(user), str(user))
    if overrides:
        cfg = _build(cfg, overrides, 'overrides')
    return cfg

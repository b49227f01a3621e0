"""Geometry and model configuration of the GPR, loaded from YAML and validated.

The package's embedded default is ``config/gpr.yaml``; a user's file overrides any subset of its keys.
All values are SI (metres, radians). Every value is checked on load; a bad one raises
:class:`~gpr_kinematics.errors.ConfigError` naming the key, the value and what is allowed.

The geometry keys describe either the nominal machine (``radius``, ``rod_azimuths``: three parallel rods on
a circle and the platform joints above them) or a real, imperfect one (``rod_positions``, ``rod_offsets``,
``rod_directions``, ``platform_joints``, ``kappa``; see ``docs/core.md``): nominal values are the defaults,
so a file that gives none of them describes the nominal machine exactly. The geometry the kernels use is
built from a config by :class:`gpr_kinematics.core.machine.MachineGeometry`.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError, brief, kind_of
from ..inputs.resources import config_path
from ..inputs.safe_yaml import YamlValue
from ..inputs.schema import check_keys, is_number, read_yaml
from ..inputs.validation import beyond_turn
from .geometry_covariance import split_covariance

#: The virtual-joint models (one definition; the CLI, the nodes and the tests take it from here).
MODELS = ('radial', 'polar', 'offset', 'compliant')
WEIGHTINGS = ('characteristic', 'unweighted')

Point2 = tuple[float, float]
Triple = tuple[float, float, float]
#: A constant the kernels derive from a config (:attr:`GprConfig.derived`), typed where it is made and read: a
#: ``MachineGeometry`` (:mod:`.machine`), a ``VirtualJointModel`` or a float (:mod:`.virtual_joints`), modules above
#: this one that this one cannot name.
Derived = Any


@dataclass(frozen=True)
class GprConfig:
    """Geometry, limits and solver settings of one GPR (SI units).

    Attributes:
        radius: radius ``R`` of the circle of rod axes [m] (the nominal geometry).
        rod_azimuths: azimuths ``theta_k`` of rods 1, 2, 3 in the base frame [rad] (the nominal geometry).
        stroke_min, stroke_max: range of the rod lengths ``q_k`` [m].
        tilt_limit: largest platform tilt accepted by inverse kinematics and compensation [rad].
        imperfection_budget: largest virtual-joint displacement of a joint centre the real joints
            can absorb [m]; forward kinematics reports whether a pose stays inside it.
        model: virtual-joint model, one of :data:`MODELS` (``docs/core.md``).
        characteristic_length: length that weights angular virtual joints in the minimum-norm Newton
            step [m]; ``None`` in a file means ``radius``.
        weighting: ``characteristic`` (unit-free norm: joint-centre displacement) or ``unweighted``
            (Bratovanov & Sotirov's eq. (8) as printed, mixing metres and radians).
        max_iterations: bound on Newton iterations per solve.
        tolerance: closure tolerance on the side lengths [m].
        rod_positions: base points ``B_k = (x, y)`` of the rod axes at ``q = 0`` in ``gpr_base`` [m];
            ``None``: ``R (cos theta_k, sin theta_k)``.
        rod_offsets: zero offsets ``o_k`` of the rod lengths [m]: joint centre ``P_k = B_k + (q_k + o_k) u_k``.
        rod_directions: horizontal components ``(u_x, u_y)`` of the unit rod directions ``u_k``
            (``u_z = sqrt(1 - u_x^2 - u_y^2)``); ``(0, 0)``: parallel to the base z axis. For a small
            tilt they are the rod's tilt angles [rad] towards +x and +y.
        platform_joints: joint centres ``p_k = (x, y)`` in the platform plane of ``gpr_platform`` [m];
            ``None``: ``R (cos theta_k, sin theta_k)``.
        kappa: ``k_t / k_r`` of each joint, the ratio of its tangential to its radial stiffness in the
            platform plane (the ``compliant`` model); one value in a file stands for all three.
    """

    radius: float = 0.093218
    rod_azimuths: Triple = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)
    stroke_min: float = 0.0
    stroke_max: float = 0.508
    tilt_limit: float = math.radians(2.0)
    imperfection_budget: float = 0.0005
    model: str = 'radial'
    characteristic_length: float = field(default=0.0)
    weighting: str = 'characteristic'
    max_iterations: int = 12
    tolerance: float = 1e-14
    rod_positions: tuple[Point2, Point2, Point2] | None = None
    rod_offsets: Triple = (0.0, 0.0, 0.0)
    rod_directions: tuple[Point2, Point2, Point2] = ((0.0, 0.0), (0.0, 0.0), (0.0, 0.0))
    platform_joints: tuple[Point2, Point2, Point2] | None = None
    kappa: Triple = (1000.0, 1000.0, 1000.0)

    def __post_init__(self) -> None:
        # every field checked and converted as a file's (a config built in code skipped the ranges: a tolerance of
        # 1 m returned the naive pose without a word, a scalar kappa raised TypeError)
        values = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        for key, value in _convert(values, type(self).__name__, length_follows_radius=True).items():
            object.__setattr__(self, key, value)
        if self.characteristic_length == 0.0:
            object.__setattr__(self, 'characteristic_length', self.radius)
        _validate(self)

    @classmethod
    def from_mapping(cls, values: Mapping[str, YamlValue], source: str = 'config') -> GprConfig:
        """Build a config from a mapping, starting from the dataclass defaults."""
        return _build(cls(), values, source)

    def replace(self, **changes: YamlValue) -> GprConfig:
        """Return a validated copy with ``changes`` applied (same keys as the YAML file)."""
        return _build(self, changes, 'replace()')

    def to_dict(self) -> dict[str, YamlValue]:
        """Plain dict of the values (lists instead of tuples, ``None`` kept), as written in YAML."""
        out = dataclasses.asdict(self)
        for key, value in out.items():
            if isinstance(value, tuple):
                out[key] = [list(v) if isinstance(v, tuple) else v for v in value]
        return out

    @functools.cached_property
    def derived(self) -> dict[str, Derived]:
        """Per-config cache of the constants the kernels derive from it (the machine geometry, the
        virtual-joint models): computed once per config object, not part of its value."""
        return {}


#: The least characteristic length [m] (``characteristic_length``; the mechanisms' least too).
LEAST_LENGTH = 1e-6
#: The numbers' ranges (lowest, highest, what is allowed): the one source of the nodes' parameter ranges too.
FLOAT_RANGES: dict[str, tuple[float, float, str]] = {
    'radius': (1e-4, 10.0, 'metres, 1e-4 <= radius <= 10'),
    'stroke_min': (-10.0, 10.0, 'metres, -10 <= stroke_min < stroke_max'),
    'stroke_max': (-10.0, 10.0, 'metres, stroke_min < stroke_max <= 10'),
    'tilt_limit': (1e-6, math.radians(15.0), 'radians, 1e-6 <= tilt_limit <= 0.261799387 (15 deg)'),
    'imperfection_budget': (1e-9, 0.01, 'metres, 1e-9 <= imperfection_budget <= 0.01'),
    'characteristic_length': (LEAST_LENGTH, 100.0, f'metres, {LEAST_LENGTH:g} <= characteristic_length <= 100, or '
                              'null for the radius'),
    'tolerance': (1e-16, 1e-6, 'metres, 1e-16 <= tolerance <= 1e-6'),
}

#: ``max_iterations``' range.
ITERATIONS = (1, 100)
#: The least angle [rad] between two rods' azimuths (a joint triangle not degenerate).
ROD_GAP = math.radians(10.0)

#: Per-rod and per-joint keys: (number of values per rod, lowest, highest, what is allowed).
_TRIPLE_RANGES: dict[str, tuple[int, float, float, str]] = {
    'rod_positions': (2, -10.0, 10.0, 'null, or 3 points [x, y] in metres, |x|, |y| <= 10'),
    'platform_joints': (2, -10.0, 10.0, 'null, or 3 points [x, y] in metres, |x|, |y| <= 10'),
    'rod_offsets': (1, -0.1, 0.1, 'a list of 3 lengths in metres, -0.1 <= o_k <= 0.1'),
    'rod_directions': (2, -0.05, 0.05, 'a list of 3 pairs [u_x, u_y], |u_x|, |u_y| <= 0.05 (rods within '
                                       'about 4 deg of the base z axis)'),
    'kappa': (1, 1e-6, 1e6, 'one number or a list of 3, 1e-6 <= kappa <= 1e6 (k_t / k_r)'),
}


#: A ROS parameter's rule where it differs from the file's: an array parameter takes no single number (rclpy refuses
#: a DOUBLE for a DOUBLE_ARRAY before any check of the package).
_PARAMETER_RULES = {'kappa': 'a list of 3 (one value k for all: [k, k, k]), 1e-6 <= kappa <= 1e6 (k_t / k_r)'}


def allowed_values(key: str) -> str:
    """What the ROS parameter of the per-rod or per-joint ``key`` allows, in words (``''`` for another key): its
    ``additional_constraints``, the rule its check names (:func:`parameter_rules`)."""
    rule = _TRIPLE_RANGES.get(key)
    return _PARAMETER_RULES.get(key, rule[3]) if rule is not None else ''


def parameter_rules(message: str) -> str:
    """A configuration's refusal with each file rule a ROS parameter words otherwise in the parameter's words."""
    for key, rule in _PARAMETER_RULES.items():
        message = message.replace(_TRIPLE_RANGES[key][3], rule)
    return message


#: The smallest interior angle of the rod and joint triangles [rad] (a flatter triangle is degenerate).
MIN_TRIANGLE_ANGLE = math.radians(5.0)
#: Largest relative difference between a side of the platform-joint triangle and the same side of the rod
#: triangle: the virtual joints absorb small mismatches, not a different machine.
MAX_SIDE_MISMATCH = 0.01


def _fail(source: str, key: str, value: YamlValue, allowed: str) -> ConfigError:
    return ConfigError(f'{source}: {key} = {brief(value)} is invalid; allowed: {allowed}')


def _as_float(source: str, key: str, value: YamlValue, allowed: str) -> float:
    if not is_number(value):
        raise _fail(source, key, value, allowed)
    return float(value)


def _triple(source: str, key: str, value: YamlValue) -> tuple[float | tuple[float, ...], ...]:
    """Three values (or three pairs) of a per-rod key, checked against :data:`_TRIPLE_RANGES`."""
    width, lo, hi, allowed = _TRIPLE_RANGES[key]
    given = value
    if isinstance(value, np.ndarray):   # a config built in code
        value = value.tolist()
    if key == 'kappa' and is_number(value):
        value = [value] * 3
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise _fail(source, key, given, allowed)
    out: list[float | tuple[float, ...]] = []
    for item in value:
        parts = [item] if width == 1 else item
        if not isinstance(parts, (list, tuple)) or len(parts) != width:
            raise _fail(source, key, given, allowed)
        if not all(is_number(v) and lo <= v <= hi for v in parts):
            raise _fail(source, key, given, allowed)
        out.append(float(parts[0]) if width == 1 else tuple(float(v) for v in parts))
    return tuple(out)


def _build(base: GprConfig, values: Mapping[str, YamlValue], source: str) -> GprConfig:
    if not isinstance(values, Mapping):
        raise ConfigError(f'{source}: expected a mapping of keys to values, got {kind_of(values)}')
    check_keys(values, (f.name for f in dataclasses.fields(GprConfig)), source)
    merged: dict[str, YamlValue] = base.to_dict()
    if base.characteristic_length == base.radius and 'characteristic_length' not in values:
        merged['characteristic_length'] = None  # it followed the radius: keep following it
    merged.update(values)
    conv = _convert(merged, source)
    try:
        return GprConfig(**conv)
    except ConfigError as exc:
        raise ConfigError(f'{source}: {exc}') from None


def _convert(merged: Mapping[str, YamlValue], source: str, length_follows_radius: bool = False
             ) -> dict[str, YamlValue]:
    """Every field of ``merged`` checked against its range and converted (floats, tuples; a scalar ``kappa`` for all
    three); ``characteristic_length`` None (and 0.0 where ``length_follows_radius``: the dataclass default) is 0.0,
    the radius. :class:`ConfigError` naming the key, the value and what is allowed."""
    conv: dict[str, YamlValue] = {}
    for key, (lo, hi, allowed) in FLOAT_RANGES.items():
        follows = length_follows_radius and isinstance(merged[key], (int, float)) and merged[key] == 0.0
        if key == 'characteristic_length' and (merged[key] is None or follows):
            conv[key] = 0.0
            continue
        val = _as_float(source, key, merged[key], allowed)
        if not lo <= val <= hi:
            raise _fail(source, key, merged[key], allowed)
        conv[key] = val
    conv['rod_azimuths'] = _azimuths(source, merged['rod_azimuths'])
    for key, choices in (('model', MODELS), ('weighting', WEIGHTINGS)):
        if not isinstance(merged[key], str) or merged[key] not in choices:   # an array's `in` raised numpy's error
            raise _fail(source, key, merged[key], ' or '.join(choices))
        conv[key] = merged[key]
    iters = merged['max_iterations']
    if isinstance(iters, (bool, np.bool_)) or not isinstance(iters, (int, np.integer)) or \
            not ITERATIONS[0] <= iters <= ITERATIONS[1]:
        raise _fail(source, 'max_iterations', iters, f'an integer from {ITERATIONS[0]} to {ITERATIONS[1]}')
    conv['max_iterations'] = int(iters)
    for key in _TRIPLE_RANGES:
        optional = key in ('rod_positions', 'platform_joints')
        conv[key] = None if optional and merged[key] is None else _triple(source, key, merged[key])
    return conv


def _azimuths(source: str, az: YamlValue) -> Triple:
    allowed = 'a list of 3 finite, distinct angles in radians within [-2pi, 2pi]'
    if not isinstance(az, (list, tuple)) or len(az) != 3:
        raise _fail(source, 'rod_azimuths', az, allowed)
    out = tuple(_as_float(source, 'rod_azimuths', a, allowed) for a in az)
    if any(beyond_turn(a) for a in out):   # the one rule of a turn (1e-9 rad of slack, as files and typed angles)
        raise _fail(source, 'rod_azimuths', az, allowed)
    return (out[0], out[1], out[2])


def nominal_points(cfg: GprConfig) -> tuple[Point2, Point2, Point2]:
    """``R (cos theta_k, sin theta_k)``: the nominal rod base points and platform joints [m]."""
    p = [(cfg.radius * math.cos(t), cfg.radius * math.sin(t)) for t in cfg.rod_azimuths]
    return (p[0], p[1], p[2])


def measured_points(cfg: GprConfig) -> tuple[str, ...]:
    """The point sets of ``cfg`` given as measured, not on the drawing's circle of ``radius``: ``'rods'``
    (``rod_positions``) and ``'platform joints'`` (``platform_joints``); none for the drawing's machine."""
    return tuple(w for w, v in (('rods', cfg.rod_positions), ('platform joints', cfg.platform_joints)) if v is not None)


#: The least closure ``tolerance``, in ulps of the longest side length (the side lengths' own rounding).
SIDE_ROUNDING_ULPS = 2


def _triangle(points: tuple[Point2, ...]) -> tuple[float, list[float], float]:
    """Signed area, side lengths (1-2, 2-3, 3-1) and smallest interior angle of a triangle."""
    (ax, ay), (bx, by), (cx, cy) = points
    area = 0.5 * ((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))
    sides = [math.hypot(bx - ax, by - ay), math.hypot(cx - bx, cy - by), math.hypot(ax - cx, ay - cy)]
    if min(sides) == 0.0:
        return area, sides, 0.0
    angles = []
    for i in range(3):
        a, b, c = sides[(i + 1) % 3], sides[(i + 2) % 3], sides[i]  # angle opposite side c
        angles.append(math.acos(max(-1.0, min(1.0, (a * a + b * b - c * c) / (2 * a * b)))))
    return area, sides, min(angles)


def _validate(cfg: GprConfig) -> None:
    if not cfg.stroke_min < cfg.stroke_max:
        raise ConfigError(f'stroke_min = {brief(cfg.stroke_min)} must be below stroke_max = {brief(cfg.stroke_max)}')
    a = [math.remainder(x, 2 * math.pi) for x in cfg.rod_azimuths]
    gaps = [abs(math.remainder(a[i] - a[j], 2 * math.pi)) for i, j in ((0, 1), (1, 2), (2, 0))]
    if min(gaps) < ROD_GAP:
        raise ConfigError(f'rod_azimuths = {list(cfg.rod_azimuths)!r}: rods must be at least 10 deg apart '
                          'so that the joint triangle is not degenerate')
    nominal = nominal_points(cfg)
    base = cfg.rod_positions or nominal
    joints = cfg.platform_joints or nominal
    tri = {}
    for key, pts in (('rod_positions', base), ('platform_joints', joints)):
        tri[key] = _triangle(pts)
        if tri[key][2] < MIN_TRIANGLE_ANGLE:
            raise ConfigError(f'{key} = {[list(p) for p in pts]!r}: the triangle of the three points has an '
                              f'angle of {math.degrees(tri[key][2]):.3g} deg; allowed: every angle >= '
                              f'{math.degrees(MIN_TRIANGLE_ANGLE):g} deg (a non-degenerate triangle)')
    if (tri['rod_positions'][0] > 0) != (tri['platform_joints'][0] > 0):
        raise ConfigError('rod_positions and platform_joints must list rods 1, 2, 3 in the same order around '
                          'the triangle (both counter-clockwise or both clockwise seen from +z)')
    for i, (sb, sp) in enumerate(zip(tri['rod_positions'][1], tri['platform_joints'][1], strict=True)):
        if abs(sp - sb) > MAX_SIDE_MISMATCH * sb:
            edge = ('1-2', '2-3', '3-1')[i]
            raise ConfigError(f'platform_joints: side {edge} of the joint triangle is {sp:.6g} m, the rods are '
                              f'{sb:.6g} m apart; allowed: within {MAX_SIDE_MISMATCH:.0%} of each other')
    longest = max(*tri['rod_positions'][1], *tri['platform_joints'][1]) / math.cos(cfg.tilt_limit)
    least = SIDE_ROUNDING_ULPS * math.ulp(longest)
    if cfg.tolerance < least:   # 1e-16 m at a radius of 10 m: the closure could not converge
        raise ConfigError(f'tolerance = {cfg.tolerance:g} m is below the rounding of the side lengths the closure '
                          f'solves ({longest:.6g} m at most: {SIDE_ROUNDING_ULPS} ulps are {least:.3g} m); allowed: '
                          f'at least {least:.3g} m for this geometry')


def default_config() -> GprConfig:
    """The package's embedded configuration (``config/gpr.yaml``)."""
    return load_config()


_DEFAULT_CONFIG: GprConfig | None = None


def resolve_config(config: GprConfig | None) -> GprConfig:
    """``config``, or the package default (loaded once)."""
    global _DEFAULT_CONFIG
    if config is not None:
        if not isinstance(config, GprConfig):
            raise InputError(f'config = {brief(config)} is not a GprConfig; allowed: a configuration of '
                             'load_config(...) or None (the package default)')
        return config
    if _DEFAULT_CONFIG is None:
        _DEFAULT_CONFIG = load_config()
    return _DEFAULT_CONFIG


def _read_yaml(path: str | Path, empty: bool = True) -> Mapping[str, YamlValue]:
    """The mapping of a geometry file; with ``empty`` False, a file without a YAML document is refused (an empty or
    truncated file would quietly be the defaults; ``{}`` says so)."""
    data = read_yaml(path)
    if data is None and not empty:
        raise ConfigError(f'{path}: the geometry file is empty (no YAML document); allowed: a mapping of geometry '
                          'keys (e.g. radius: 0.25), {} for the defaults as they are, or no file')
    if data is None:
        return {}
    if not isinstance(data, Mapping):
        raise ConfigError(f'{path}: expected a mapping of keys to values, got {kind_of(data)}')
    return data


def load_config(path: str | Path | None = None,
                overrides: Mapping[str, YamlValue] | None = None, overrides_source: str = 'overrides') -> GprConfig:
    """Load the embedded default, then a user's file ``path`` and ``overrides`` on top of it; ``overrides_source``
    names where the overrides came from in messages (a robot description's ``gpr`` section names itself).

    Raises:
        ConfigError: unreadable file, invalid YAML, unknown key or a value outside its range, a malformed
            ``covariance`` block (:mod:`.geometry_covariance`).
    """
    default_path = config_path('gpr.yaml')
    cfg = _build(GprConfig(), _read_yaml(default_path), str(default_path))
    if path is not None and not isinstance(path, (str, os.PathLike)):   # 3 raised a bare TypeError
        raise ConfigError(f'geometry file path = {brief(path)}; allowed: a file path (str or Path) or None (the '
                          "package's gpr.yaml)")
    if path is not None:  # the name as given: an empty one is refused, not read as '.'
        # a calibrated file's covariance of its fitted parameters: checked here, read by load_covariance
        data, _ = split_covariance(_read_yaml(path, empty=False), str(path))
        cfg = _build(cfg, data, str(path))
    if overrides is not None and (not isinstance(overrides, Mapping) or overrides):   # _build names a non-mapping
        cfg = _build(cfg, overrides, overrides_source)
    return cfg

"""The covariance of a calibrated geometry's fitted parameters: the ``covariance`` block of a geometry file.

``gpr calibrate`` writes it; ``gpr calibrate --robot`` adds it to the arms' standard errors (docs/calibration.md)::

    covariance:
      names: [rod1_x, rod1_y, ...]    # the fitted geometry parameters (core.parameters.PARAMETER_NAMES)
      matrix: [[...], ...]            # their covariance, SI: m^2, rad^2, m rad; kappaK as its anisotropy
                                      # (kappa - 1) / (kappa + 1), dimensionless
      base: {frame: tracker, position: [x, y, z], rpy: [roll, pitch, yaw]}   # with a registration (m, rad)

With ``base``, the names end with :data:`BASE_NAMES`: the registration's pose of ``gpr_base`` in ``frame``
(identified with the geometry, so correlated with it), ``base_x base_y base_z`` its position [m] and ``base_rx base_ry
base_rz`` a small rotation ``d`` [rad] turning it about the frame's axes, ``R = exp([d]x) R(rpy)``.

Checked on load (:func:`parse_covariance`): known, distinct names (the base's six last, with ``base`` only); one row
of as many numbers per name; every entry finite and at most :data:`MAX_ENTRY` in magnitude; symmetric within
:data:`ROUNDING` of ``sqrt(C_ii C_kk)`` entry by entry; a variance of 0 without covariances; positive semi-definite
within rounding (every eigenvalue of its correlation matrix at least ``-ROUNDING``).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import cast

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError, brief, kind_of
from ..inputs.safe_yaml import YamlValue
from ..inputs.schema import check_keys, is_number, orientation_angle, read_yaml
from ..inputs.validation import WORLD_BOUND
from .parameters import PARAMETER_NAMES

#: The key of the block in a geometry file.
KEY = 'covariance'
#: Largest magnitude of an entry (m^2, rad^2, m rad, or none for a kappa's anisotropy): the package's bound of a
#: number (a fit written with ``--force`` may be that poor: its file loads).
MAX_ENTRY = 1e6
#: Relative rounding allowed in the symmetry and the eigenvalues of the correlation matrix.
ROUNDING = 1e-9
_ALLOWED = ('a mapping of names (the fitted geometry parameters, e.g. rod1_x, kappa2) and matrix (their covariance, '
            'one row of numbers per name, SI), and base with a registration')
#: The registration's parameters of ``gpr_base`` in the measuring frame (module docstring), after the geometry's.
BASE_NAMES = ('base_x', 'base_y', 'base_z', 'base_rx', 'base_ry', 'base_rz')
_BASE = 'base: {frame: NAME, position: [x, y, z] (m), rpy: [roll, pitch, yaw] (rad)}'


@dataclass(frozen=True)
class RegisteredBase:
    """The pose of ``gpr_base`` in ``frame`` a calibration identified: ``pose`` x y z [m], roll pitch yaw [rad]."""

    frame: str
    pose: tuple[float, ...]

    def as_block(self) -> dict[str, YamlValue]:
        return {'frame': self.frame, 'position': list(self.pose[:3]), 'rpy': list(self.pose[3:])}


@dataclass(frozen=True, eq=False)
class GeometryCovariance:
    """Covariance ``matrix (n, n)`` of the geometry parameters ``names`` (coordinates of
    :mod:`gpr_kinematics.calibration.core_model`: SI, a ``kappaK`` as its anisotropy), read from the file ``source``
    (in its ``section``, a robot description's ``gpr``; ``''``: a geometry file's own block), with the registration's
    ``base`` (its six :data:`BASE_NAMES` last in ``names``) or ``None``."""

    names: tuple[str, ...]
    matrix: NDArray[np.float64]
    source: str = ''
    section: str = ''
    base: RegisteredBase | None = None

    @property
    def origin(self) -> str:
        """Where it was read, in words: the file, or the file's section."""
        return f"{self.source}'s {self.section} section" if self.section else self.source

    def as_block(self) -> dict[str, YamlValue]:
        """The file's block (floats at full precision)."""
        block: dict[str, YamlValue] = {'names': list(self.names),
                                       'matrix': [[float(v) for v in row] for row in self.matrix]}
        return block | ({'base': self.base.as_block()} if self.base is not None else {})

    def geometry(self) -> GeometryCovariance:
        """The geometry's parameters alone (the base's rows and columns left out: their marginal covariance)."""
        if self.base is None:
            return self
        keep = [i for i, n in enumerate(self.names) if n not in BASE_NAMES]
        return GeometryCovariance(tuple(self.names[i] for i in keep), self.matrix[np.ix_(keep, keep)], self.source,
                                  self.section)


def _names(value: YamlValue, where: str, base: bool) -> tuple[str, ...]:
    known = PARAMETER_NAMES + BASE_NAMES if base else PARAMETER_NAMES
    allowed = f'allowed: a list of distinct geometry parameter names ({", ".join(known)})'
    if base:
        allowed += ', the last six those of the base'
    if not isinstance(value, list) or not value or len(value) > len(known):
        raise ConfigError(f'{where}: names = {brief(value)} is invalid; {allowed}')
    if not base and any(n in BASE_NAMES for n in value):   # a registration's parameters without its pose
        raise ConfigError(f'{where}: names: {brief(next(n for n in value if n in BASE_NAMES))} without base, the pose '
                          f'they are about; allowed: {_BASE} with them, or the geometry\'s names alone')
    bad = [n for n in value if not isinstance(n, str) or n not in known]
    if bad:
        raise ConfigError(f'{where}: names: unknown parameter {brief(bad[0])}; {allowed}')
    twice = sorted({n for n in value if value.count(n) > 1})
    if twice:
        raise ConfigError(f'{where}: names: {", ".join(map(str, twice))} named twice; {allowed}')
    if base and tuple(value[-len(BASE_NAMES):]) != BASE_NAMES:
        raise ConfigError(f'{where}: names: with base, the last six are {", ".join(BASE_NAMES)}; {allowed}')
    return tuple(str(n) for n in value)


def _base(value: YamlValue, where: str) -> RegisteredBase:
    """The registration's ``base``: a frame's name, a position within :data:`WORLD_BOUND` of the frame's origin (a
    tracker stands in the cell) and rpy angles within one turn (:func:`orientation_angle`): millimetres or degrees
    passed and were blamed on the measurements later."""
    allowed = f'allowed: {_BASE}, each coordinate within +-{WORLD_BOUND:g} m, each angle within [-2pi, 2pi] rad'
    if not isinstance(value, Mapping):
        raise ConfigError(f'{where}: base = {brief(value)} is invalid; {allowed}')
    check_keys(value, ('frame', 'position', 'rpy'), f'{where}: base')
    frame = value.get('frame')
    if not isinstance(frame, str) or not frame:
        raise ConfigError(f'{where}: base: frame = {brief(frame)} is invalid; {allowed}')
    pose: list[float] = []
    for key in ('position', 'rpy'):
        v = value.get(key)
        if not isinstance(v, list) or len(v) != 3 or not all(is_number(x) for x in v):
            raise ConfigError(f'{where}: base: {key} = {brief(v)} is invalid; {allowed}')
        pose += [float(x) for x in v]
    far = max(abs(x) for x in pose[:3])
    if far > WORLD_BOUND:
        hint = (f'; as millimetres it would be {far / 1000.0:g} m: millimetres given as metres? (SI: m)'
                if far / 1000.0 <= WORLD_BOUND else '')
        raise ConfigError(f'{where}: base: position = {brief(value.get("position"))} m is beyond the cell; '
                          f'allowed: each coordinate within +-{WORLD_BOUND:g} m of the frame\'s origin{hint}')
    rpy = cast('list[YamlValue]', value.get('rpy'))
    pose[3:] = [orientation_angle(x, f'rpy[{i}]', f'{where}: base') for i, x in enumerate(rpy)]
    return RegisteredBase(frame, tuple(pose))


def _matrix(value: YamlValue, names: tuple[str, ...], where: str) -> NDArray[np.float64]:
    """The matrix of ``names``, a row and an entry named by index from 0 (as ``stations[0]``) and parameter."""
    n = len(names)
    allowed = (f'allowed: {n} rows (one per name) of {n} finite numbers each, of magnitude at most {MAX_ENTRY:g} '
               "(SI: m^2, rad^2, m rad; a kappa's anisotropy none)")
    if not isinstance(value, list) or len(value) != n:
        raise ConfigError(f'{where}: matrix = {brief(value)} is invalid ({n} names); {allowed}')
    for i, row in enumerate(value):
        if not isinstance(row, list) or len(row) != n:
            raise ConfigError(f'{where}: matrix[{i}] ({names[i]}) = {brief(row)} is invalid; {allowed}')
        for k, v in enumerate(row):
            if not is_number(v) or abs(float(v)) > MAX_ENTRY:
                raise ConfigError(f'{where}: matrix[{i}][{k}] ({names[i]}, {names[k]}) = {brief(v)} is invalid; '
                                  f'{allowed}')
    return np.array(value, dtype=float)


def _check(C: NDArray[np.float64], names: tuple[str, ...], where: str) -> None:
    """Symmetric and positive semi-definite within :data:`ROUNDING` (module docstring)."""
    d = np.diag(C)
    j = int(np.argmin(d))
    if d[j] < 0.0:
        raise ConfigError(f'{where}: matrix: the variance of {names[j]} is {float(d[j])!r}; allowed: a covariance, '
                          'every variance >= 0')
    root = np.sqrt(d)
    scale = np.outer(root, root)   # each entry's own scale: the variances' sizes differ by many orders (the roots'
    # product: the product of two variances of 1e-160 underflowed to 0 and refused a valid block)
    asym = np.abs(C - C.T) - ROUNDING * scale
    i, k = np.unravel_index(int(np.argmax(asym)), C.shape)
    if asym[i, k] > 0.0:
        raise ConfigError(f'{where}: matrix is not symmetric: ({names[i]}, {names[k]}) = {float(C[i, k])!r} but '
                          f'({names[k]}, {names[i]}) = {float(C[k, i])!r}; allowed: a symmetric matrix (within '
                          f'{ROUNDING:g} times the square root of the two variances)')
    loose = np.abs(C) > scale * (1.0 + ROUNDING)   # |correlation| > 1: a zero variance's too
    if loose.any():
        i, k = np.argwhere(loose)[0]
        raise ConfigError(f'{where}: matrix: the covariance of {names[i]} and {names[k]} is {float(C[i, k])!r}, '
                          f'beyond the square root of their variances {float(d[i])!r} and {float(d[k])!r}; allowed: '
                          'a covariance, every correlation within [-1, 1] (a variance of 0 has no covariance)')
    s = np.sqrt(np.where(d > 0.0, d, 1.0))
    least = float(np.min(np.linalg.eigvalsh(0.5 * (C + C.T) / np.outer(s, s))))
    if least < -ROUNDING:
        raise ConfigError(f'{where}: matrix is not positive semi-definite (its correlation matrix has the eigenvalue '
                          f'{least:.3g}); allowed: a covariance, every eigenvalue of its correlation >= -{ROUNDING:g}')


def parse_covariance(block: YamlValue, source: str) -> GeometryCovariance:
    """The ``covariance`` block of the geometry file ``source``, checked (module docstring); else
    :class:`ConfigError` naming what is wrong and what is allowed."""
    where = f'{source}: {KEY}'
    if not isinstance(block, Mapping):
        raise ConfigError(f'{where} = {brief(block)} ({kind_of(block)}) is invalid; allowed: {_ALLOWED}')
    check_keys(block, ('names', 'matrix', 'base'), where)
    for key in ('names', 'matrix'):
        if key not in block:
            raise ConfigError(f'{where}: missing key {key}; allowed: {_ALLOWED}')
    names = _names(block['names'], where, 'base' in block)
    C = _matrix(block['matrix'], names, where)
    _check(C, names, where)
    return GeometryCovariance(names, C, source, base=_base(block['base'], where) if 'base' in block else None)


def split_covariance(data: Mapping[str, YamlValue], source: str
                     ) -> tuple[Mapping[str, YamlValue], GeometryCovariance | None]:
    """A geometry file's mapping without its ``covariance`` block, and the block checked (``None`` without one)."""
    if KEY not in data:
        return data, None
    rest = {k: v for k, v in data.items() if k != KEY}
    return rest, parse_covariance(data[KEY], source)


def load_covariance(path: str | Path) -> GeometryCovariance | None:
    """The checked ``covariance`` block of the geometry file ``path``; ``None`` for a file without one."""
    data = read_yaml(path)
    if not isinstance(data, Mapping):
        return None
    return split_covariance(data, str(path))[1]

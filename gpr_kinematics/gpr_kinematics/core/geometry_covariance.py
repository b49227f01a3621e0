"""The covariance of a calibrated geometry's fitted parameters: the ``covariance`` block of a geometry file.

``gpr calibrate`` writes it; ``gpr calibrate --robot`` adds it to the arms' standard errors (docs/calibration.md)::

    covariance:
      names: [rod1_x, rod1_y, ...]    # the fitted geometry parameters (core.parameters.PARAMETER_NAMES)
      matrix: [[...], ...]            # their covariance, SI: m^2, rad^2, m rad; kappaK as its anisotropy
                                      # (kappa - 1) / (kappa + 1), dimensionless

Checked on load (:func:`parse_covariance`): known, distinct names; one row of as many numbers per name; every entry
finite and at most :data:`MAX_ENTRY` in magnitude; symmetric within :data:`ROUNDING` of ``sqrt(C_ii C_kk)`` entry by
entry; a variance of 0 without covariances; positive semi-definite within rounding (every eigenvalue of its
correlation matrix at least ``-ROUNDING``).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import ConfigError, brief, kind_of
from ..inputs.safe_yaml import YamlValue
from ..inputs.schema import check_keys, is_number, read_yaml
from .parameters import PARAMETER_NAMES

#: The key of the block in a geometry file.
KEY = 'covariance'
#: Largest magnitude of an entry (m^2, rad^2, m rad, or none for a kappa's anisotropy): the package's bound of a
#: number (a fit written with ``--force`` may be that poor: its file loads).
MAX_ENTRY = 1e6
#: Relative rounding allowed in the symmetry and the eigenvalues of the correlation matrix.
ROUNDING = 1e-9
_ALLOWED = ('a mapping of names (the fitted geometry parameters, e.g. rod1_x, kappa2) and matrix (their covariance, '
            'one row of numbers per name, SI)')


@dataclass(frozen=True, eq=False)
class GeometryCovariance:
    """Covariance ``matrix (n, n)`` of the geometry parameters ``names`` (coordinates of
    :mod:`gpr_kinematics.calibration.core_model`: SI, a ``kappaK`` as its anisotropy), read from the file ``source``
    (in its ``section``, a robot description's ``gpr``; ``''``: a geometry file's own block)."""

    names: tuple[str, ...]
    matrix: NDArray[np.float64]
    source: str = ''
    section: str = ''

    @property
    def origin(self) -> str:
        """Where it was read, in words: the file, or the file's section."""
        return f"{self.source}'s {self.section} section" if self.section else self.source

    def as_block(self) -> dict[str, YamlValue]:
        """The file's block (floats at full precision)."""
        return {'names': list(self.names), 'matrix': [[float(v) for v in row] for row in self.matrix]}


def _names(value: YamlValue, where: str) -> tuple[str, ...]:
    known = PARAMETER_NAMES
    allowed = f'allowed: a list of distinct geometry parameter names ({", ".join(known)})'
    if not isinstance(value, list) or not value or len(value) > len(known):
        raise ConfigError(f'{where}: names = {brief(value)} is invalid; {allowed}')
    bad = [n for n in value if not isinstance(n, str) or n not in known]
    if bad:
        raise ConfigError(f'{where}: names: unknown parameter {brief(bad[0])}; {allowed}')
    twice = sorted({n for n in value if value.count(n) > 1})
    if twice:
        raise ConfigError(f'{where}: names: {", ".join(map(str, twice))} named twice; {allowed}')
    return tuple(str(n) for n in value)


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
    check_keys(block, ('names', 'matrix'), where)
    for key in ('names', 'matrix'):
        if key not in block:
            raise ConfigError(f'{where}: missing key {key}; allowed: {_ALLOWED}')
    names = _names(block['names'], where)
    C = _matrix(block['matrix'], names, where)
    _check(C, names, where)
    return GeometryCovariance(names, C, source)


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

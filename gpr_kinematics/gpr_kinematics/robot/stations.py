"""Stations: wafer poses in the world, the offline programmer's targets.

A station is the pose of the wafer frame (origin at the wafer centre) in the world frame, given as its position
and three angles [rad]: the station plane's ``tilt`` about the horizontal axis at ``azimuth`` (as ``gpr ik``
gives a platform tilt: the rotation ``exp(tilt [a]x)``, ``a = (cos azimuth, sin azimuth, 0)``, a negative tilt
is a tilt about ``azimuth + pi``) and the blade's ``heading`` in that plane:

    ``R_station = tilt_rotation(tilt, azimuth) @ Rz(heading)``

(the decomposition of :func:`gpr_kinematics.core.rotations.tilt_from_matrix`; no Euler angles). A 2-joint arm cannot
choose the heading: its stations may leave it *free* (``heading_free``).
"""
from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.rotations import rotation_z, tilt_from_matrix, tilt_rotation
from ..errors import InputError, brief
from ..inputs.validation import (
    MAX_COORDINATE,
    QUATERNION_NORM_TOLERANCE,
    bounded,
    float_array,
    rotation_matrices,
    rows_of,
)

Array = NDArray[np.float64]
#: A station's name; not starting with ``-``: the exported tables' cells are read by spreadsheets, which take
#: ``-A1-B1`` for a formula.
_NAME = re.compile(r'[A-Za-z0-9_.][A-Za-z0-9_.\-]{0,63}')
#: What :data:`_NAME` allows, in words.
NAME_RULE = '1 to 64 letters, digits, _ . - (not - first: a spreadsheet reads such a cell as a formula)'


def per_station(values: ArrayLike, name: str, n: int) -> Array:
    """One finite number [rad] or one per station, as an array ``(n,)``, within +-:data:`MAX_COORDINATE` (angles are
    periodic, but beyond that bound a float angle modulo 2 pi has no digits left); InputError names the value."""
    a = float_array(values, name)
    if a.ndim > 1 or (a.ndim == 1 and a.shape[0] != n):
        raise InputError(f'{name} must be one number or {n} numbers (one per station), got shape {a.shape}')
    a = np.broadcast_to(a, (n,)).astype(float)
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f'{name} = {a[i]} (station {i}) is not a finite number; allowed: finite values in radians')
    big = np.abs(a) > MAX_COORDINATE
    if big.any():
        i = int(np.argmax(big))
        raise InputError(f'{name} = {a[i]:g} rad (station {i}); allowed: finite values within +-{MAX_COORDINATE:g} rad')
    return a


def name_refusal(value: Any, label: str, hint: str = '') -> str:
    """The refusal of a station name ``value`` ('' for a valid one: text of 1 to 64 letters, digits, ``_ . -``, not
    ``-`` first), ``label`` naming it and ``hint`` after "is invalid": the station files' rule and the API's."""
    if isinstance(value, str) and _NAME.fullmatch(value):
        return ''
    return f'{label} = {brief(value)} is invalid{hint}; allowed: {NAME_RULE}'


def station_names(names: Sequence[str] | None, n: int) -> tuple[str, ...]:
    """The names of ``n`` stations: a list (or tuple, array) of ``n`` names, each as :func:`name_refusal` allows;
    ``None`` names them by index. Else InputError (a text is no list of names: ``'abc'`` made stations a, b and c;
    None was named 'None'; a name given twice)."""
    if names is None:
        return tuple(str(i) for i in range(n))
    if isinstance(names, (str, bytes)) or not isinstance(names, Sequence | np.ndarray) or \
            (isinstance(names, np.ndarray) and names.ndim == 0):   # a 0-d array has no len()
        raise InputError(f'names must be a list of station names, got {brief(names)}')
    if len(names) != n:
        raise InputError(f'names must name the {n} stations, got {len(names)} names')
    first: dict[str, int] = {}   # a name given twice made its errors ambiguous (station files refuse it too)
    for i, name in enumerate(names):
        refusal = name_refusal(name, f'names[{i}]')
        if refusal:
            raise InputError(refusal)
        if str(name) in first:
            raise InputError(f'names[{i}] = {brief(name)} names station {first[str(name)]} again; allowed: each '
                             f'station named once')
        first[str(name)] = i
    return tuple(str(v) for v in names)   # numpy's str_ as str


def batch_index(i: object, n: int, what: str) -> int:
    """Index ``i`` of a batch of ``n`` (``what``: stations, configurations), from ``-n`` to ``n - 1`` as Python's
    (the record's), else :class:`InputError` naming it."""
    if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not -n <= i < n:
        raise InputError(f'{what} index {brief(i)}; allowed: an integer from {-n} to {n - 1} ({n} {what}s)')
    return int(i) % n


@dataclass(frozen=True)
class StationRecord:
    """One station (module docstring) as the command line gives it: ``position`` [m, world], ``tilt``, ``azimuth``
    and ``heading`` [rad]; ``heading`` is ``None`` where it is left free to a 2-joint arm."""

    position: Array
    tilt: float
    azimuth: float
    heading: float | None


@dataclass(frozen=True)
class Stations:
    """``N`` stations (module docstring): ``position (N, 3)`` [m, world], ``tilt``, ``azimuth``, ``heading``
    ``(N,)`` [rad], ``heading_free (N,)`` (the heading is left to a 2-joint arm; ``heading`` is then 0 and
    unused) and ``names``."""

    position: Array
    tilt: Array
    azimuth: Array
    heading: Array
    heading_free: NDArray[np.bool_]
    names: tuple[str, ...]

    def __len__(self) -> int:
        return int(self.position.shape[0])

    @staticmethod
    def of(position: ArrayLike, tilt: ArrayLike = 0.0, azimuth: ArrayLike = 0.0, heading: ArrayLike | None = None,
           names: Sequence[str] | None = None, heading_free: ArrayLike | None = None) -> Stations:
        """Validated stations; ``heading=None`` leaves every heading free, ``heading_free`` marks some free.

        >>> s = Stations.of([[0.4, 0.1, 0.5]], tilt=0.01, azimuth=0.3, heading=1.2)
        >>> len(s), s.names
        (1, ('0',))
        """
        P = np.array(rows_of(position, 'position', 3, ('x', 'y', 'z')))   # a copy: the caller's array may change
        bounded(P, 'station position [m]')
        n = P.shape[0]
        free = np.ones(n, dtype=bool) if heading is None else np.zeros(n, dtype=bool)
        if heading_free is not None:
            marks = np.asarray(heading_free)
            if marks.dtype != bool or marks.shape not in ((), (n,)):
                raise InputError(f'heading_free must be one bool or one per station ({n}), got {brief(heading_free)}')
            free = free | np.broadcast_to(marks, (n,))
        head = np.zeros(n) if heading is None else per_station(heading, 'heading', n)
        return Stations(P, per_station(tilt, 'tilt', n), per_station(azimuth, 'azimuth', n), np.where(free, 0.0, head),
                        free, station_names(names, n))

    @cached_property
    def rotation(self) -> Array:
        """Orientations ``tilt_rotation(tilt, azimuth) @ Rz(heading)`` ``(N, 3, 3)`` (heading 0 where free)."""
        return tilt_rotation(self.tilt, self.azimuth) @ rotation_z(self.heading)

    @cached_property
    def normal(self) -> Array:
        """Station-plane normals in the world ``(N, 3)``."""
        return tilt_rotation(self.tilt, self.azimuth)[:, :, 2]

    def record(self, i: int) -> StationRecord:
        """Station ``i`` as a :class:`StationRecord` (its own copy of the position)."""
        i = batch_index(i, len(self), 'station')
        return StationRecord(np.array(self.position[i]), float(self.tilt[i]), float(self.azimuth[i]),
                             None if self.heading_free[i] else float(self.heading[i]))

    def label(self, i: int) -> str:
        """How messages name station ``i``: by its name, or by its index when the stations are not named."""
        return f'station {self.names[i]}'

    def take(self, index: ArrayLike) -> Stations:
        """The stations at ``index`` (an integer array)."""
        n = len(self)
        if isinstance(index, list) and len(index) == 1 and type(index[0]) is int and -n <= index[0] < n:
            i = index[0] % n   # one station (a caller's loop over them): its rows copied, no index array, and
            one = Stations.__new__(Stations)   # the rows of valid stations: no __init__ (a setattr per field)
            one.__dict__.update(position=self.position[i:i + 1].copy(), tilt=self.tilt[i:i + 1].copy(),
                                azimuth=self.azimuth[i:i + 1].copy(), heading=self.heading[i:i + 1].copy(),
                                heading_free=self.heading_free[i:i + 1].copy(), names=(self.names[i],))
            return one
        try:
            idx = np.atleast_1d(np.asarray(index))
        except (TypeError, ValueError):
            idx = np.array([np.nan])
        if idx.ndim != 1 or (idx.size and (idx.dtype.kind not in 'iu' or idx.min() < -n or idx.max() >= n)):
            raise InputError(f'station index {brief(np.asarray(index, dtype=object).tolist())}; allowed: integers '
                             f'from {-n} to {n - 1} ({n} stations)')
        idx = idx.astype(np.int64)
        return Stations(self.position[idx], self.tilt[idx], self.azimuth[idx], self.heading[idx],
                        self.heading_free[idx], tuple(self.names[i] for i in idx))

    def offset(self, distance: ArrayLike) -> Stations:
        """The same stations moved by ``distance (N,)`` [m] along their plane's normal (approach heights)."""
        d = np.broadcast_to(bounded(distance, 'distance [m]'), (len(self),)) if np.ndim(distance) == 0 else \
            bounded(distance, 'distance [m]', (len(self),))
        return Stations(self.position + d[:, None] * self.normal, self.tilt, self.azimuth, self.heading,
                        self.heading_free, self.names)


def stations_from_poses(position: ArrayLike, rotation: ArrayLike, names: Sequence[str] | None = None) -> Stations:
    """Stations of wafer poses ``position (N, 3)`` [m] and ``rotation (N, 3, 3)`` (rotation matrices within 1e-6, as
    a unit quaternion's norm): ``tilt >= 0``, ``azimuth`` in (-pi, pi], ``heading`` = the twist about the station
    normal (:func:`gpr_kinematics.core.rotations.tilt_from_matrix`).

    Raises:
        InputError: positions not finite or beyond +-1e6 m, a matrix that is not a rotation, counts that differ.
    """
    P = np.array(rows_of(position, 'position', 3, ('x', 'y', 'z')))   # a copy: the caller's array may change
    bounded(P, 'station position [m]')
    R = rotation_matrices(rotation, 'rotation', QUATERNION_NORM_TOLERANCE)
    n = P.shape[0]
    if R.shape[0] != n:
        raise InputError(f'{n} positions and {R.shape[0]} rotations; allowed: one rotation per position')
    tilt, azimuth, heading = tilt_from_matrix(R)
    return Stations(P, tilt, azimuth, heading, np.zeros(n, dtype=bool), station_names(names, n))

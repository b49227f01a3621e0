"""Checks of user input shared by the core, the CLI and the ROS nodes.

Each raises :class:`~gpr_kinematics.errors.InputError` with a message naming the field, its value and what
is allowed, so a caller (CLI: exit 2; node: ``success: false``) can pass it on as is.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import InputError

#: Largest accepted deviation of a quaternion's norm from 1 (messages and commands carry unit quaternions).
QUATERNION_NORM_TOLERANCE = 1e-6


def finite_number(value: Any, name: str) -> float:
    """``value`` as a finite float; else :class:`InputError` naming ``name``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f'{name} must be a number, got {value!r}') from None
    if not np.isfinite(v):
        raise InputError(f'{name} = {v} is not a finite number; allowed: finite values in SI units')
    return v


def finite_vector(values: Any, name: str, size: int) -> NDArray[np.float64]:
    """``values`` as a float array of shape ``(size,)``, all finite; else :class:`InputError`."""
    try:
        a = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f'{name} must be {size} numbers, got {values!r}') from None
    if a.shape != (size,):
        raise InputError(f'{name} must be {size} numbers, got shape {a.shape}')
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f'{name} = {a.tolist()} contains NaN or infinity: {name}[{i}] = {a[i]} is not a finite '
                         'number; allowed: finite values in SI units')
    return a


def unit_quaternion(values: Any, name: str) -> NDArray[np.float64]:
    """A quaternion (x, y, z, w), finite and of unit norm within :data:`QUATERNION_NORM_TOLERANCE`;
    returned normalised."""
    a = finite_vector(values, name, 4)
    norm = float(np.linalg.norm(a))
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise InputError(f'{name} = ({a[0]:.9g}, {a[1]:.9g}, {a[2]:.9g}, {a[3]:.9g}) has norm {norm:.9g}; '
                         f'a unit quaternion (x, y, z, w) is required, |norm - 1| <= {QUATERNION_NORM_TOLERANCE:g}')
    return a / norm

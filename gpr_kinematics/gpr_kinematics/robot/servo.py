"""The simulated controller at run time (no ROS import): :func:`servo`, the actuators' first-order response, and
:func:`violation`, the check of a tolerance (``PATH_TOLERANCE_VIOLATED``, ``GOAL_TOLERANCE_VIOLATED``). SI units."""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from .controller import ControllerJoints

Array = NDArray[np.float64]


def servo(actual: Array, desired: Array, dt: float, tau: float) -> Array:
    """The joints after ``dt`` [s] of a first-order response with time constant ``tau`` [s] to ``desired`` held over
    the step: ``desired + (actual - desired) exp(-dt / tau)``; ``tau = 0``: ``desired`` exactly."""
    return np.array(desired if tau <= 0.0 else desired + (actual - desired) * math.exp(-dt / tau), dtype=np.float64)


def violation(joints: ControllerJoints, cols: NDArray[np.int64], error_position: Array, error_velocity: Array,
              position: Array, velocity: Array, what: str) -> str | None:
    """The first joint of ``cols`` whose position or velocity error ``(N,)`` exceeds its tolerance ``(N,)``, named with
    the tolerance and the error (``what``: path or goal), or None."""
    for err, tol, kind, suffix in ((error_position, position, 'position', ''), (error_velocity, velocity, 'velocity',
                                                                                '/s')):
        bad = np.abs(err[cols]) > tol[cols]
        if bad.any():
            j = int(cols[int(np.argmax(bad))])
            return (f'{joints.names[j]}: {kind} error {abs(err[j]):.6g} {joints.units[j]}{suffix} exceeds the {what} '
                    f'tolerance {tol[j]:.6g} {joints.units[j]}{suffix}')
    return None

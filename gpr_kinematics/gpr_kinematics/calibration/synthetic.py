"""Synthetic measurements: the poses a known (perturbed) machine would give, with tracker noise.

For tests, the demonstration and measurement planning: the true poses come from a pose model at parameter
values ``theta``; each position coordinate gets independent normal noise of standard deviation
``sigma_position`` and each orientation a small rotation ``exp([eps]x)``, ``eps`` normal with standard deviation
``sigma_angle`` per component (the residual convention of :func:`~.model.pose_error`).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from ..core.rotations import quaternion_from_matrix
from ..errors import InputError
from ..inputs.validation import random_seed, single_number
from .measurements import SIGMA_RANGE, Measurements
from .model import PoseModel, as_configurations, evaluate


def synthetic_measurements(model: PoseModel, theta: ArrayLike, Q: ArrayLike, sigma_position: float,
                           sigma_angle: float, seed: int = 0, source: str = 'synthetic',
                           with_sigmas: bool = True, points: bool = False) -> Measurements:
    """Measurements of ``model`` at ``theta`` for rod lengths ``Q (N, 3)`` with tracker noise (module docstring).

    ``with_sigmas`` records the standard deviations in the result (the file's sigma columns); ``points`` makes
    measured points (no orientation: a reflector); the generator is ``numpy.random.default_rng(seed)``, so equal
    arguments give equal measurements. ``sigma_position`` [m] and ``sigma_angle`` [rad] are one standard deviation
    each, for every row, within :data:`~.measurements.SIGMA_RANGE` where recorded, else from 0 (no noise) to its top.

    Raises:
        InputError: a sigma that is not one number in its range, a seed that is not an integer from 0 to 2**63 - 1,
            bad rods or parameters.
    """
    sp = _sigma(sigma_position, 'sigma_position', 'm', with_sigmas)
    sa = _sigma(sigma_angle, 'sigma_angle', 'rad', with_sigmas and not points)
    seed = random_seed(seed)
    Qa = as_configurations(Q)
    pos, rot = evaluate(model, theta, Qa)
    rng = np.random.default_rng(seed)
    n = Qa.shape[0]
    noisy_pos = pos + rng.normal(0.0, sp, (n, 3))
    noisy_rot = Rotation.from_rotvec(rng.normal(0.0, sa, (n, 3))).as_matrix() @ rot
    sig_p = np.full(n, sp) if with_sigmas else None
    sig_a = np.full(n, sa) if with_sigmas and not points else None
    return Measurements(source=source, q=Qa.copy(), position=noisy_pos,
                        quaternion=None if points else quaternion_from_matrix(noisy_rot),
                        sigma_position=sig_p, sigma_angle=sig_a, lines=tuple(range(1, n + 1)))


def _sigma(value: float, name: str, unit: str, recorded: bool) -> float:
    """One standard deviation of the noise [``unit``]: a single number within :data:`~.measurements.SIGMA_RANGE`
    where the measurements record it (``recorded``), else from 0 (no noise) to its top; else :class:`InputError`."""
    if np.ndim(value) != 0:   # a sigma per row is what the measurements record, not what the noise is drawn with
        raise InputError(f'{name} must be a single number [{unit}] (one standard deviation for every row), got shape '
                         f'{np.shape(value)}')
    v = single_number(value, name)
    lo, hi = SIGMA_RANGE[0] if recorded else 0.0, SIGMA_RANGE[1]
    if not lo <= v <= hi:
        zero = '' if recorded else ' (0: no noise)'
        raise InputError(f'{name} = {v:g} {unit} is outside [{lo:g}, {hi:g}] {unit}; allowed: a standard deviation in '
                         f'that range{zero}')
    return v

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
from .measurements import Measurements
from .model import PoseModel, as_configurations, evaluate


def synthetic_measurements(model: PoseModel, theta: ArrayLike, Q: ArrayLike, sigma_position: float,
                           sigma_angle: float, seed: int = 0, source: str = 'synthetic',
                           with_sigmas: bool = True, points: bool = False) -> Measurements:
    """Measurements of ``model`` at ``theta`` for rod lengths ``Q (N, 3)`` with tracker noise (module docstring).

    ``with_sigmas`` records the standard deviations in the result (the file's sigma columns); ``points`` makes
    measured points (no orientation: a reflector); the generator is ``numpy.random.default_rng(seed)``, so equal
    arguments give equal measurements.
    """
    Qa = as_configurations(Q)
    pos, rot = evaluate(model, theta, Qa)
    rng = np.random.default_rng(seed)
    n = Qa.shape[0]
    noisy_pos = pos + rng.normal(0.0, sigma_position, (n, 3))
    noisy_rot = Rotation.from_rotvec(rng.normal(0.0, sigma_angle, (n, 3))).as_matrix() @ rot
    sig_p = np.full(n, float(sigma_position)) if with_sigmas else None
    sig_a = np.full(n, float(sigma_angle)) if with_sigmas and not points else None
    return Measurements(source=source, q=Qa.copy(), position=noisy_pos,
                        quaternion=None if points else quaternion_from_matrix(noisy_rot),
                        sigma_position=sig_p, sigma_angle=sig_a, lines=tuple(range(1, n + 1)))

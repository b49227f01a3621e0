"""``stream.*`` checks: the PlatformState stream as a whole (gaps, order, jumps at singular crossings).

- ``counter``: sample counters step by exactly 1 in log order (lost, repeated, reordered samples are named);
- ``stamps``: header stamps strictly increasing;
- ``jump``: between consecutive samples, with ``dq = ||q_i - q_(i-1)||_2`` [m]: rotation angle
  <= ``K_rot dq + eps``, ``||dp||`` <= ``K_pos dq + eps``, ``max |dX|`` <= ``K_x dq + eps``, ``max |dL|`` <=
  ``K_L dq + eps``, as a ratio to the bound (<= 1); ``dX`` between samples of one model and as many virtual
  joints. ``K_rot = 1.01 G`` [rad/m], ``G`` the plane's slope gain
  (:func:`~gpr_kinematics.core.machine.slope_gain`): on the drawing the plane through the three joint centres at
  ``R u_k`` has slope ``2/(3R) sum q_k u_k`` and ``|sum dq_k u_k| <= sqrt(3/2) ||dq||``, ``G = sqrt(2/3) / R``; a
  calibrated machine's rods 1.8 mm inside the drawing turn the plane faster (the drawing's ``R`` failed every sample
  of its correct recording); the 1 % covers the virtual joints' displacement of the centres (the paper sweep reaches
  0.9901 of the bound). ``K_pos = 1/sqrt(3) + 0.05`` (the height is the mean of ``q``; the centre shift adds a slope of
  0.014 on the sweep). ``K_L = sqrt(2)`` (from ``L_ij = sqrt(3 R^2 + (q_j - q_i)^2)``). ``K_x = 0.5`` (m or
  rad per m) is empirical: 3x the largest ratio over the paper sweep for all models and weightings (0.15).
  ``eps = 1e-12``. A solver that switched branches, or a stream that jumped, at a crossing of the singular
  configuration breaks these bounds; the result reports the crossings (:func:`singular_crossings`) and the
  largest ratio at them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .cdr import Columns
from .columns import quaternion_angle, stamp_ns, vec
from .results import Check, Series, value_check
from .tolerances import Tolerances

#: ``q1 = q2 = q3`` within this spread [m] is the singular configuration.
SINGULAR_SPREAD = 1e-12
#: Consecutive commanded tilt vectors at an angle within this [rad] of pi reverse: a move through the singular
#: configuration (the node turns the azimuth by pi there, in floats).
REVERSAL = 1e-9


def singular_crossings(commanded_tilt: NDArray[np.float64], q: NDArray[np.float64],
                       commanded_azimuth: NDArray[np.float64]) -> NDArray[np.int64]:
    """Indices of the samples where the stream reaches or crosses the singular configuration, once per passage: the
    first sample of each run at it (commanded tilt exactly 0, or ``q1 = q2 = q3`` within :data:`SINGULAR_SPREAD`),
    and a sample whose commanded tilt vector ``tilt (cos azimuth, sin azimuth)`` reverses the previous one's (a tilt
    that changes sign, or an azimuth turned by pi: a program's move through it). A dwell of 21 samples at tilt 0 is
    one passage (it counted 21), the step between a sweep's rows (turned by less than pi) none."""
    t = np.asarray(commanded_tilt, dtype=float)
    spread = np.ptp(q, axis=1) <= SINGULAR_SPREAD if len(q) else np.zeros(0, dtype=bool)
    at = (t == 0.0) | spread
    first = at.copy()
    first[1:] &= ~at[:-1]
    across = np.zeros_like(at)
    if t.size > 1:
        g = np.asarray(commanded_azimuth, dtype=float)
        v = t[:, None] * np.column_stack([np.cos(g), np.sin(g)])
        dot = np.sum(v[1:] * v[:-1], axis=1)
        cross = v[:-1, 0] * v[1:, 1] - v[:-1, 1] * v[1:, 0]
        across[1:] = (dot < 0) & (np.abs(cross) <= REVERSAL * np.abs(dot)) & ~at[1:] & ~at[:-1]
    return np.flatnonzero(first | across)


@dataclass
class StreamOutcome:
    checks: list[Check]
    crossings: int
    crossing_ratio: float


def stream_checks(c: Columns, samples: NDArray[np.int64], topic: str, series: Series, gain: float,
                  tol: Tolerances) -> StreamOutcome:
    """The ``stream.*`` checks of the PlatformState columns ``c`` (see the module docstring)."""
    checks = [value_check('stream.counter', topic, np.abs(np.diff(samples) - 1).astype(float), 0.0, 'samples',
                          samples[1:], '|counter step - 1|: lost, repeated or reordered samples')]
    stamps = stamp_ns(c)
    checks.append(value_check('stream.stamps', topic, np.maximum(stamps[:-1] - stamps[1:] + 1, 0).astype(float),
                              0.0, 'ns', samples[1:],
                              'header stamp not after the previous one (value = previous - this + 1 ns)'))
    n = len(samples)
    if n < 2:
        return StreamOutcome(checks, int(series.crossings.size), 0.0)
    dq = np.linalg.norm(np.diff(series.q, axis=0), axis=1)
    quat = vec(c, 'pose.orientation', 'xyzw')
    rot = quaternion_angle(quat[:-1], quat[1:])
    dp = np.linalg.norm(np.diff(vec(c, 'pose.position'), axis=0), axis=1)
    dL = np.max(np.abs(np.diff(series.side_lengths, axis=0)), axis=1)
    X, counts = series.virtual_joints, series.virtual_counts
    within = np.arange(X.shape[1])[None, :] < counts[1:, None]     # not the NaN padding of a shorter row
    dX = np.max(np.where(within, np.abs(np.diff(X, axis=0)), 0.0), axis=1) if X.shape[1] else np.zeros(n - 1)
    models = c['model']
    # Virtual joints of different models, or as many as a different number of them (state.virtual_joints names
    # the sample), are not comparable.
    dX[(models[1:] != models[:-1]) | (counts[1:] != counts[:-1])] = 0.0
    k_rot = tol.jump_rot_factor * gain
    eps = tol.jump_eps
    ratio = np.max(np.stack([rot / (k_rot * dq + eps), dp / (tol.jump_pos * dq + eps),
                             dX / (tol.jump_x * dq + eps), dL / (tol.jump_length * dq + eps)], axis=1), axis=1)
    checks.append(value_check('stream.jump', topic, ratio, 1.0, 'x bound', samples[1:],
                              'change between samples over its bound K*|dq|+eps (rotation, position, X, L)'))
    cross = series.crossings[series.crossings >= 1]
    return StreamOutcome(checks, int(series.crossings.size), float(np.max(ratio[cross - 1])) if cross.size else 0.0)

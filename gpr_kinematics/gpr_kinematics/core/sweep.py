"""The paper's singular-tilt sweep (Bratovanov & Sotirov §VI, ``docs/references.md``).

"For each gamma [0 .. 360 deg] the alpha changes in the interval [-2 .. 2 deg] by a step of 0.2 deg"
at ``q1 = q2 = q3 = 500 mm``: every pass crosses the singular configuration ``alpha = 0``. Here a sample
is the tilt ``alpha`` (signed) about the horizontal axis at azimuth ``gamma`` (``docs/core.md``), at the
platform height ``height``; all samples are solved by one batch inverse kinematics (which includes the
forward kinematics of the answer). Passes alternate direction (serpentine: -2..2 deg, then 2..-2 deg
at the next azimuth) so that the stream of samples is continuous, as the trajectory node needs;
``serpentine=False`` gives the paper's plain order.

>>> s = paper_sweep()  # radial model, 0.5 m
>>> s.summary.samples, s.summary.singular_crossings, round(s.summary.max_centre_shift * 1e6, 2)
(756, 36, 28.41)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, LimitError, brief
from ..inputs.validation import plain_number, switch
from . import ForwardBatch, inverse_batch, resolve_config
from .config import GprConfig
from .forward import beyond_tilt
from .inverse import tilt_target_slack

Array = NDArray[np.float64]

#: Defaults from the paper: 500 mm, +-2 deg in 0.2 deg steps; azimuth step 10 deg (not given there).
DEFAULT_HEIGHT = 0.5
DEFAULT_MAX_TILT = math.radians(2.0)
DEFAULT_TILT_STEP = math.radians(0.2)
DEFAULT_AZIMUTH_STEP = math.radians(10.0)
#: Most samples of one sweep (about 1.4 kB of memory each: 0.3 GB at the limit; the paper's sweep has 756).
MAX_SAMPLES = 200_000
#: The least steps [rad] of alpha and of the azimuth (``gpr sweep``, :func:`sweep_grid` and ``trajectory_node``'s
#: parameters alike: the command line took 5e-8 rad, which the node refused).
LEAST_STEPS = {'tilt_step': 1e-7, 'azimuth_step': 1e-4}
#: A step's count of a turn within this share of a whole number is that number (a step typed to 12 digits).
TURN_TOLERANCE = 1e-9
#: Most passes of one sweep.
MAX_PASSES = 1000


class TiltStepsError(InputError):
    """``max_tilt`` is not a whole number (>= 1) of ``tilt_step``: a caller names them as its user typed them."""


@dataclass(frozen=True)
class SweepResult:
    """Samples of the sweep: ``gamma`` (azimuth), ``alpha`` (signed tilt) [rad], ``pass_index``, ``q (N, 3)``
    [m], the forward kinematics ``forward`` of every ``q``, the inverse-kinematics steps and a summary."""

    gamma: Array
    alpha: Array
    pass_index: NDArray[np.int64]
    height: float
    q: Array
    forward: ForwardBatch
    inverse_iterations: NDArray[np.int64]

    def __len__(self) -> int:
        return int(self.q.shape[0])

    @property
    def singular(self) -> NDArray[np.bool_]:
        """Samples at the singular configuration (``alpha = 0``, ``q1 = q2 = q3``)."""
        return np.asarray(self.alpha == 0.0)

    @property
    def summary(self) -> SweepSummary:
        """Samples, crossings and the largest centre shift, joint displacement, residual, iterations."""
        fk = self.forward
        shift = np.linalg.norm(fk.centre_shift[:, :2], axis=-1)
        i = int(np.argmax(shift))
        return SweepSummary(
            samples=len(self),
            passes=int(self.pass_index.max()) + 1 if len(self) else 0,
            singular_crossings=int(np.count_nonzero(self.singular)),
            model=fk.model,
            height=self.height,
            max_tilt=float(np.max(fk.tilt)),
            max_centre_shift=float(shift[i]),
            max_centre_shift_at=SweepSample(alpha=float(self.alpha[i]), gamma=float(self.gamma[i])),
            max_joint_displacement=float(np.max(fk.joint_displacement)),
            within_budget=bool(np.all(fk.within_budget)),
            max_residual=float(np.max(fk.residual)),
            max_fit_residual=float(np.max(fk.fit_residual)),
            max_fk_iterations=int(np.max(fk.iterations)),
            max_ik_iterations=int(np.max(self.inverse_iterations)),
            max_height_error=float(np.max(np.abs(fk.position[:, 2] - self.height))),
        )


@dataclass(frozen=True)
class SweepSample:
    """Where in the sweep: the signed tilt ``alpha`` and its azimuth ``gamma`` [rad]."""

    alpha: float
    gamma: float


@dataclass(frozen=True)
class SweepSummary:
    """The sweep in numbers (``gpr sweep``, SI units): ``samples``, ``passes``, ``singular_crossings``; the model
    and the platform ``height`` [m]; the largest tilt [rad], centre shift in the base plane [m] (and where),
    joint displacement [m] (``within_budget``), closure and rigid-fit residuals [m], Newton iterations of the
    forward and inverse solves, and the largest height error [m]."""

    samples: int
    passes: int
    singular_crossings: int
    model: str
    height: float
    max_tilt: float
    max_centre_shift: float
    max_centre_shift_at: SweepSample
    max_joint_displacement: float
    within_budget: bool
    max_residual: float
    max_fit_residual: float
    max_fk_iterations: int
    max_ik_iterations: int
    max_height_error: float


def azimuth_count(turns: float) -> int | None:
    """The azimuths of a step that makes ``turns`` steps a turn: the whole number within :data:`TURN_TOLERANCE` of it
    (of the count; 401 rows for 2 pi / 400 typed to 12 digits, the last a repeat of the first), else None."""
    n = round(turns)
    return max(n, 1) if abs(turns - n) <= TURN_TOLERANCE * max(1.0, turns) else None


def sweep_grid(max_tilt: float = DEFAULT_MAX_TILT, tilt_step: float = DEFAULT_TILT_STEP,
               azimuth_step: float = DEFAULT_AZIMUTH_STEP, passes: int = 1,
               serpentine: bool = True) -> tuple[Array, Array, NDArray[np.int64]]:
    """The ``(gamma, alpha, pass_index)`` samples of the sweep [rad].

    ``alpha`` runs over ``-max_tilt .. max_tilt`` in ``tilt_step`` (``max_tilt`` must be a whole number
    of steps so that ``alpha = 0`` is a sample); ``gamma`` over ``[0, 2 pi)`` in ``azimuth_step``; at most
    :data:`MAX_SAMPLES` samples in all, counted before any array is made.
    """
    for name, value in (('max_tilt', max_tilt), ('tilt_step', tilt_step), ('azimuth_step', azimuth_step)):
        v = plain_number(value)   # numpy scalars as their numbers; a truth value or text NaN
        if not (math.isfinite(v) and v > 0):
            raise InputError(f'{name} = {brief(value)} must be a positive finite angle in radians')
        if v < LEAST_STEPS.get(name, 0.0):
            raise InputError(f'{name} = {brief(value)} rad; allowed: a step of at least {LEAST_STEPS[name]:g} rad')
    max_tilt, tilt_step, azimuth_step = (plain_number(v) for v in (max_tilt, tilt_step, azimuth_step))
    if isinstance(passes, (bool, np.bool_)) or not isinstance(passes, (int, np.integer)) or \
            not 1 <= passes <= MAX_PASSES:   # np.int64(2) was refused as 'passes = 2 must be an integer'
        raise InputError(f'passes = {brief(passes)} must be an integer from 1 to {MAX_PASSES}')
    passes = int(passes)
    serpentine = switch(serpentine, 'serpentine')   # 'no' alternated the passes
    half = max_tilt / tilt_step
    if not half <= MAX_SAMPLES:  # counted before anything is allocated (an inf or huge count included)
        raise InputError(f'the sweep would have {half:.6g} tilt steps from level to its largest tilt; allowed: a '
                         f'sweep of at most {MAX_SAMPLES} samples (a larger tilt step)')
    if tilt_step > max_tilt:   # not 'max_tilt must be a whole number of steps': the step is what is wrong
        raise InputError(f'tilt_step = {brief(tilt_step)} rad is more than max_tilt = {brief(max_tilt)} rad; allowed: '
                         'a step that divides max_tilt a whole number (>= 1) of times')
    n_half = round(half)
    if abs(half - n_half) > 1e-9 * max(1.0, half) or n_half < 1:
        raise TiltStepsError(f'max_tilt = {brief(max_tilt)} rad is not a whole number (>= 1) of tilt steps '
                             f'({brief(tilt_step)} rad); allowed: a tilt_step that divides max_tilt a whole number of '
                             'times (every pass then crosses alpha = 0)')
    if azimuth_step > 2 * math.pi * (1.0 + TURN_TOLERANCE):   # a turn typed to 12 digits is one
        raise InputError(f'azimuth_step = {brief(azimuth_step)} rad ({math.degrees(azimuth_step):.6g} deg) is more '
                         'than a turn; allowed: at most 2 pi rad (360 deg)')
    turns = 2 * math.pi / azimuth_step   # at most 62,832 (LEAST_STEPS)
    n_gamma = azimuth_count(turns) or math.ceil(turns)
    samples = (2 * n_half + 1) * n_gamma * passes
    if samples > MAX_SAMPLES:
        raise InputError(f'the sweep would have {samples} samples ({2 * n_half + 1} tilts x {n_gamma} azimuths x '
                         f'{passes} passes); allowed: at most {MAX_SAMPLES}')
    alpha = np.arange(-n_half, n_half + 1) * tilt_step
    gammas = np.arange(n_gamma) * azimuth_step
    rows = np.arange(n_gamma * passes)
    flip = (rows % 2 == 1) if serpentine else np.zeros(rows.size, dtype=bool)
    A = np.where(flip[:, None], alpha[::-1], alpha)
    G = np.repeat(np.tile(gammas, passes), alpha.size)
    P = np.repeat(rows // n_gamma, alpha.size)
    return G, A.ravel(), P


def paper_sweep(height: float = DEFAULT_HEIGHT, max_tilt: float = DEFAULT_MAX_TILT,
                tilt_step: float = DEFAULT_TILT_STEP, azimuth_step: float = DEFAULT_AZIMUTH_STEP,
                passes: int = 1, config: GprConfig | None = None, model: str | None = None,
                serpentine: bool = True) -> SweepResult:
    """Inverse and forward kinematics of every sample of the paper's sweep, in one batch call.

    Raises:
        InputError: non-positive steps, ``max_tilt`` not a whole number of steps (:class:`TiltStepsError`), more
            than :data:`MAX_SAMPLES`; a truth value for a number, or anything else for ``serpentine``.
        LimitError: ``max_tilt`` beyond the tilt limit, or a height that leaves the stroke.
    """
    cfg = resolve_config(config)
    if not math.isfinite(plain_number(height)):   # True (1 m) and text refused, numpy scalars as their numbers
        raise InputError(f'height = {brief(height)} must be a finite number of metres')
    if plain_number(max_tilt) - cfg.tilt_limit > tilt_target_slack(cfg):  # before counting (NaN: sweep_grid names it)
        raise LimitError(f'max_tilt = {beyond_tilt(plain_number(max_tilt), cfg.tilt_limit, "max_tilt")}')
    gamma, alpha, pass_index = sweep_grid(max_tilt, tilt_step, azimuth_step, passes, serpentine)
    ik = inverse_batch(np.full(alpha.shape, float(height)), alpha, gamma, config=cfg, model=model)
    return SweepResult(gamma=gamma, alpha=alpha, pass_index=pass_index, height=float(height), q=ik.q,
                       forward=ik.achieved, inverse_iterations=ik.iterations)

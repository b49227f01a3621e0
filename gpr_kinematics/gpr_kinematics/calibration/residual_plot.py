"""The data of ``gpr calibrate --plot`` (no matplotlib; :mod:`.plot` draws it): per measurement the residual's
magnitude with the nominal and with the calibrated geometry, the noise the gate judges them against, and the fitted
parameters' change from nominal in standard errors.

For row ``i`` the position residual is ``|p(theta, q_i) - p_i|`` [m] and the orientation residual the angle
``|phi(R(theta, q_i) R_i^T)|`` [rad] (:func:`~.plausibility.measured_errors`), at the nominal ``theta_0``
(before) and at the estimate (after): the RMS and the worst of each are the report's ``residuals.before`` and
``residuals.after``. The noise line is ``sqrt(3) sigma_i``, the RMS of the magnitude of a 3-vector of independent
zero-mean coordinates of standard deviation ``sigma_i`` (``E |e_i|^2 = 3 sigma_i^2``; ``sigma_i`` the row's sigma
per coordinate, which the gate's chi-square divides the residuals by): residuals at the noise scatter about it. An
arm's fit judged with the GPR's calibration covariance (:class:`~.arm_gpr.ResidualShare`) has the GPR's share in its
residuals too: the line is then ``sqrt(3 sigma_i^2 + g_i^2)``, ``g_i^2 = sigma_i^2 sum_c (G G^T)_cc`` over the row's
three coordinates, the expected spread the gate adds.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .identification import noise_origin, weights
from .measurements import Measurements
from .model import PoseModel
from .plausibility import measured_errors
from .results import CalibrationResult

Array = NDArray[np.float64]

#: A panel is drawn on a log scale when the larger RMS of before and after is at least this many times the smaller
#: (1.5 orders of magnitude: a machine millimetres off its drawing, measured to micrometres).
LOG_RATIO = 30.0
#: Parameters of the frames (:mod:`.frames`), left out of the parameter panel: their nominal is only the fit's start.
FRAME_PREFIXES = ('base_', 'target_')


@dataclass(frozen=True)
class Kind:
    """One kind of residual (position [m] or orientation [rad]) of every row: ``before`` and ``after`` ``(N,)``,
    ``noise`` ``(N,)`` the line ``sqrt(3) sigma_i`` (with ``gpr``: ``sqrt(3 sigma_i^2 + gpr_i^2)``), ``sigma`` the
    sigmas ``(N,)`` per coordinate, ``origin`` what they are (:func:`~.identification.noise_origin`), ``log``: draw on
    a log scale (:data:`LOG_RATIO`); ``gpr`` ``(N,)`` the GPR's share (module docstring), ``None`` without."""

    before: Array
    after: Array
    noise: Array
    sigma: Array
    origin: str
    log: bool
    gpr: Array | None = None

    @property
    def rms_before(self) -> float:
        return float(np.sqrt(np.mean(self.before ** 2)))

    @property
    def rms_after(self) -> float:
        return float(np.sqrt(np.mean(self.after ** 2)))


@dataclass(frozen=True)
class ResidualPlot:
    """What ``gpr calibrate --plot`` draws: ``rows`` ``(N,)`` the measurements' row numbers (1 the file's first
    row), ``names`` the rows' names in the report (``line 14``), ``position`` and ``angle`` (``None`` for measured
    points) the residuals (:class:`Kind`), ``parameters`` and ``z`` the fitted geometry parameters and their change
    from nominal in standard errors (in the fitted coordinate: a ``kappa``'s anisotropy), the gate's verdict
    (``passed``, the names of the ``failed`` checks) and the measurements' ``source``."""

    rows: NDArray[np.int64]
    names: tuple[str, ...]
    position: Kind
    angle: Kind | None
    parameters: tuple[str, ...]
    z: Array
    passed: bool
    failed: tuple[str, ...]
    source: str
    #: What is calibrated, for the figure's titles: ``''`` the GPR, ``'arm arm1'`` an arm.
    label: str = ''
    #: The rows are of several files, one after the other (an arm's merged files).
    merged: bool = False


def _kind(errors0: Array, errors1: Array, sigma: Array, origin: str, gpr: Array | None = None) -> Kind:
    before, after = np.linalg.norm(errors0, axis=1), np.linalg.norm(errors1, axis=1)
    rms = sorted(float(np.sqrt(np.mean(x ** 2))) for x in (before, after))
    noise = math.sqrt(3.0) * sigma if gpr is None else np.sqrt(3.0 * sigma ** 2 + gpr ** 2)
    return Kind(before, after, noise, sigma, origin, rms[1] >= LOG_RATIO * rms[0], gpr)


def residual_plot(model: PoseModel, meas: Measurements, res: CalibrationResult, sigma_position: float,
                  sigma_angle: float, declared: tuple[bool, bool] = (False, False), label: str = '',
                  gpr_share: Array | None = None) -> ResidualPlot:
    """The data of the plot of ``res``, the identification of ``model`` from ``meas`` with the sigmas and
    ``declared`` it was made with (:func:`~.identification.identify`'s arguments): the model evaluated at the
    nominal parameters and at the estimate (module docstring); ``label`` names what is calibrated (an arm);
    ``gpr_share`` ``(N, 3)``: the GPR's share of each position residual's variance in units of its sigma squared
    (:attr:`~.arm_gpr.ResidualShare.gpr`), drawn in the noise line as the gate judges it."""
    e0 = measured_errors(model, meas, model.parameters.nominal)
    e1 = measured_errors(model, meas, res.estimate)
    w, _ = weights(meas, sigma_position, sigma_angle, declared)
    sigma = 1.0 / w
    gpr = None if gpr_share is None else sigma[:, 0] * np.sqrt(np.sum(gpr_share, axis=1))
    position = _kind(e0[:, :3], e1[:, :3], sigma[:, 0],
                     noise_origin('position', meas.sigma_position, declared[0], float(sigma[0, 0])), gpr)
    angle = None if e0.shape[1] == 3 else _kind(
        e0[:, 3:], e1[:, 3:], sigma[:, 3], noise_origin('angle', meas.sigma_angle, declared[1], float(sigma[0, 3])))
    shown = [int(j) for j in res.fitted if not res.parameters[int(j)].name.startswith(FRAME_PREFIXES)]
    nominal = res.parameters.nominal
    z = np.array([(res.estimate[j] - nominal[j]) / res.standard_error[j] for j in shown], dtype=np.float64)
    return ResidualPlot(np.arange(1, len(meas) + 1, dtype=np.int64), meas.row_names, position, angle,
                        tuple(res.parameters[j].name for j in shown), z, res.gate.passed,
                        tuple(c.name for c in res.gate.checks if not c.passed), meas.source, label,
                        bool(meas.files))

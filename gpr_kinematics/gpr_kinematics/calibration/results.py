"""The result of an identification (:func:`~.identification.identify`): the estimate, its standard errors and the
bias the held parameters can cause, residuals before and after and cross-validated, how the fit converged, and
the gate (:mod:`.quality`); as plain data for JSON (:meth:`CalibrationResult.as_dict`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .fitting import StartOutcome
from .identifiability import Identifiability
from .model import ParameterSet
from .quality import CrossValidation, Gate, HeldBias

Array = NDArray[np.float64]


def _finite(x: float) -> float | None:
    """``x``, or ``None`` where it is not finite (JSON has no NaN)."""
    return float(x) if math.isfinite(x) else None


@dataclass(frozen=True)
class ResidualStats:
    """Residuals of a set of measurements: RMS and worst of ``|p - p_meas|`` [m] and of the rotation angle between
    predicted and measured orientation [rad] (``nan`` for measured points, which have none), with the file lines
    of the worst, and their files where files are merged (else ``None``)."""

    rms_position: float
    max_position: float
    rms_angle: float
    max_angle: float
    worst_position_line: int
    worst_angle_line: int
    worst_position_file: str | None = None
    worst_angle_file: str | None = None

    @staticmethod
    def of(errors: Array, lines: tuple[int, ...], files: tuple[str, ...] = ()) -> ResidualStats:
        """From errors ``(N, 6)`` (:func:`~.model.pose_error`) or ``(N, 3)`` (points) of the rows at ``lines`` (of
        ``files``, merged files only); rows with a ``nan`` are left out (a row no other row predicts, in a
        cross-validation)."""
        ok = np.all(np.isfinite(errors), axis=1)
        rows = np.flatnonzero(ok)
        if not rows.size:
            return ResidualStats(math.nan, math.nan, math.nan, math.nan, 0, 0)
        e = errors[ok]
        dp = np.linalg.norm(e[:, :3], axis=1)
        angle = e.shape[1] == 6
        da = np.linalg.norm(e[:, 3:], axis=1) if angle else np.full(rows.size, math.nan)
        ip, ia = int(rows[int(np.argmax(dp))]), int(rows[int(np.argmax(da))]) if angle else -1
        return ResidualStats(float(np.sqrt(np.mean(dp ** 2))), float(dp.max()),
                             float(np.sqrt(np.mean(da ** 2))) if angle else math.nan,
                             float(da.max()) if angle else math.nan, lines[ip], lines[ia] if angle else 0,
                             files[ip] if files else None, files[ia] if files and angle else None)

    def as_dict(self) -> dict[str, Any]:
        return {k: _finite(v) if isinstance(v, float) else v for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class Convergence:
    """How the fit ended: its ``status`` (:data:`~.fitting.STATUSES`), the Gauss-Newton step left in standard
    errors (``step_se``), the parameters that ended at a bound of their range, and every start's outcome."""

    status: str
    step_se: float
    at_bound: tuple[str, ...]
    starts: tuple[StartOutcome, ...]

    def as_dict(self) -> dict[str, Any]:
        return {'status': self.status, 'step_se': _finite(self.step_se), 'at_bound': list(self.at_bound),
                'starts': [{'label': s.label, 'chi2_reduced': _finite(s.chi2_reduced), 'status': s.status,
                            'iterations': s.iterations} for s in self.starts]}


@dataclass(frozen=True)
class CalibrationResult:
    """Identified parameters with standard errors, residuals before and after, identifiability, and the checks.

    Attributes:
        parameters: the model's parameters (order of every array here).
        estimate: identified coordinates (nominal for held and fixed parameters), SI: the values, except a
            transformed parameter's coordinate (a stiffness ratio's anisotropy, :class:`~.model.Parameter`);
            :attr:`values` has the values.
        standard_error: standard errors of the fitted coordinates (``nan`` for held and fixed ones);
            :attr:`value_standard_error` those of the values.
        status: per parameter ``fitted``, ``held`` (free, but the poses cannot identify it) or ``fixed``
            (not asked for).
        fitted: indices of the fitted parameters; covariance: their covariance ``(F, F)``, SI.
        before, after: residuals with the nominal and with the identified parameters.
        identifiability: the analysis that chose what to fit.
        chi2_reduced: ``sum |r|^2 / (k N - F)`` at the solution (about 1 when the sigmas are right).
        absolute_sigma: the file gave the standard deviations (the covariance is not rescaled).
        iterations: Levenberg-Marquardt iterations of the best start; rows: number of measurements; source: file.
        convergence, cross_validation, bias, gate: :class:`Convergence`, :class:`~.quality.CrossValidation`,
            :class:`~.quality.HeldBias`, :class:`~.quality.Gate`.
    """

    parameters: ParameterSet
    estimate: Array
    standard_error: Array
    status: tuple[str, ...]
    fitted: NDArray[np.int64]
    covariance: Array
    before: ResidualStats
    after: ResidualStats
    identifiability: Identifiability
    chi2_reduced: float
    absolute_sigma: bool
    iterations: int
    rows: int
    source: str
    convergence: Convergence
    cross_validation: CrossValidation
    bias: HeldBias
    gate: Gate
    lines: tuple[int, ...] = ()
    #: The file of each row where files are merged (:attr:`~.measurements.Measurements.files`; else empty).
    files: tuple[str, ...] = ()
    #: What the fit found that the gate does not judge (a parameter moved far beyond its a-priori uncertainty).
    warnings: tuple[str, ...] = ()
    #: The kinds (``position``, ``angle``) whose sigmas are the measurement noise (the file's or the options'); the
    #: others' are assumed (all given: :attr:`absolute_sigma`).
    declared: tuple[str, ...] = ()

    @property
    def values(self) -> Array:
        """Identified values (the estimate's coordinates turned into values: ``kappa`` from its anisotropy)."""
        return self.parameters.values(self.estimate)

    @property
    def value_standard_error(self) -> Array:
        """Standard errors of the values (the delta method, ``|d value / d coordinate|`` times the coordinate's)."""
        return np.abs(self.parameters.value_slopes(self.estimate)) * self.standard_error

    @property
    def value_bias(self) -> Array:
        """Worst-case bias from the held parameters of each fitted value (the delta method, as the standard error)."""
        return np.abs(self.parameters.value_slopes(self.estimate)) * self.bias.worst

    @property
    def correlation(self) -> Array:
        """Correlation matrix of the fitted parameters."""
        d = np.sqrt(np.diag(self.covariance))
        return np.asarray(self.covariance / np.outer(d, d), dtype=np.float64)

    @property
    def cross_validated(self) -> ResidualStats:
        """The leave-one-out prediction errors as residual statistics (:class:`~.quality.CrossValidation`)."""
        return ResidualStats.of(self.cross_validation.errors, self.lines or tuple(range(1, self.rows + 1)),
                                self.files)

    def as_dict(self) -> dict[str, Any]:
        """Plain data for JSON: per parameter its value (``nominal``, ``estimate``, ``change``, ``standard_error``,
        ``bias`` (worst case from the held parameters), ``bias_std``, ``bias_from``; ``None`` where not fitted) and,
        for a transformed one, the same of its ``coordinate``; residuals, cross-validation, convergence, gate."""
        params = []
        nominal, values, se_v = self.parameters.values(self.parameters.nominal), self.values, self.value_standard_error
        slope = np.abs(self.parameters.value_slopes(self.estimate))
        for j, p in enumerate(self.parameters):
            se = self.standard_error[j]
            entry = {'name': p.name, 'unit': p.unit, 'nominal': float(nominal[j]), 'estimate': float(values[j]),
                     'change': float(values[j] - nominal[j]), 'standard_error': _finite(se_v[j]),
                     'bias': _finite(self.bias.worst[j] * slope[j]), 'bias_std': _finite(self.bias.std[j] * slope[j]),
                     'bias_from': self.bias.source[j] or None, 'status': self.status[j]}
            if p.transform:
                entry['coordinate'] = {'name': p.transform, 'nominal': p.nominal, 'estimate': float(self.estimate[j]),
                                       'standard_error': _finite(se), 'bias': _finite(self.bias.worst[j])}
            params.append(entry)
        cv = self.cross_validation
        return {'source': self.source, 'rows': self.rows, 'parameters': params,
                'residuals': {'before': self.before.as_dict(), 'after': self.after.as_dict(),
                              'cross_validated': self.cross_validated.as_dict() | {
                                  'ratio': _finite(cv.ratio), 'alone': list(cv.alone),
                                  'alone_files': list(cv.alone_files)}},
                'identifiability': self.identifiability.as_dict(), 'chi2_reduced': self.chi2_reduced,
                'absolute_sigma': self.absolute_sigma, 'noise_declared': list(self.declared),
                'iterations': self.iterations,
                'convergence': self.convergence.as_dict(), 'gate': self.gate.as_dict(),
                'fitted': [self.parameters[j].name for j in self.fitted],
                'correlation': self.correlation.tolist(), 'warnings': list(self.warnings)}

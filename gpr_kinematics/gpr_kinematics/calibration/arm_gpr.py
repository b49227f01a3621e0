"""The GPR's calibration uncertainty in the arms' standard errors (``gpr calibrate --robot ROBOT --config FILE``, the
file's ``covariance`` block: :mod:`gpr_kinematics.core.geometry_covariance`).

The arms' fit takes the GPR's geometry ``g`` as exact. Off by ``dg`` (its calibration's error) it moves the arms'
estimate by ``-K dg``, ``K = (J_a^T W J_a)^-1 J_a^T W J_g``, with ``J_a`` the measured points by the fitted arm
parameters, ``J_g`` by the GPR's fitted parameters and ``W = diag(1 / sigma_i^2)`` the rows' weights; the arms'
covariance gains ``K Sigma_g K^T``. Both Jacobians by central differences (:func:`~.model.pose_jacobian`, each
parameter's step: the core has no analytic derivative by its geometry).

The error is in the residuals too: the weighted residuals ``r = P (e + B dg)`` (``A``, ``B`` the weighted ``J_a``,
``J_g``; ``P = I - A A^+`` the projection on the residuals' space; ``e`` unit noise) have the covariance
``C = P (I + B Sigma_g B^T) P``, so ``|r|^2`` is a sum of ``lambda_i chi^2_1`` over the eigenvalues of ``C``, not the
``chi^2`` of ``tr P`` degrees of freedom the gate takes for an exact GPR. :class:`ResidualShare` judges the
chi-square against the :data:`~.quality.CHI2_QUANTILE` point of that sum by Satterthwaite's approximation, ``c
chi^2_nu`` with ``c = tr C^2 / tr C`` and ``nu = (tr C)^2 / tr C^2`` (the mean and variance matched; Satterthwaite,
"An approximate distribution of estimates of variance components", 1946), and the outliers studentized by
``sqrt(C_ii)``. Measured on 100 GPRs calibrated from 15 noisy poses: a gate taking the GPR as exact failed 53 arms
fitted to their noise, this one none (``test_calibration_arm_gpr.py``).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2 as chi2_distribution

from ..core.geometry_covariance import GeometryCovariance
from .arm import ArmModel
from .core_model import CoreModel
from .model import ParameterSet, PoseModel, pose_jacobian
from .plausibility import measured_errors
from .quality import CHI2_QUANTILE, Gate, outlier_check
from .results import CalibrationResult

Array = NDArray[np.float64]


class ArmOnGpr:
    """The points of :class:`~.arm.ArmModel` with the GPR's geometry parameters ``names`` as parameters too (after the
    arm's, at the robot's geometry): the platform from :class:`~.core_model.CoreModel`, one machine per row."""

    supports_displacement = False

    def __init__(self, arm: ArmModel, names: Sequence[str]) -> None:
        config = arm.robot.config
        self.arm = arm
        self.core = CoreModel(config, config.model)
        self.columns = np.array([self.core.parameters.index(n) for n in names], dtype=np.int64)
        self._parameters = ParameterSet(arm.parameters.parameters
                                        + tuple(self.core.parameters[int(j)] for j in self.columns))

    @property
    def parameters(self) -> ParameterSet:
        return self._parameters

    def poses(self, theta: Array, Q: Array, displacement: Array | None = None) -> tuple[Array, Array]:
        n = len(self.arm.parameters)
        g = np.repeat(self.core.parameters.nominal[None], theta.shape[0], axis=0)
        g[:, self.columns] = theta[:, n:]
        p0, R0 = self.core.poses(g, Q)
        return self.arm.on_platform(theta[:, :n], p0, R0)


def gpr_gain(model: PoseModel, arm: ArmModel, res: CalibrationResult, cov: GeometryCovariance,
             w: Array) -> Array:
    """``K`` ``(F, G)`` (module docstring) of the fit ``res`` of ``model`` (``arm``'s points in the measurements'
    frame) by the GPR's parameters of ``cov``; ``w (N, 3)`` the residuals' ``1 / sigma`` [1/m]."""
    return gain(*weighted_jacobians(model, arm, res, cov, w))


def gain(A: Array, B: Array) -> Array:
    """``K = A^+ B`` ``(F, G)`` of the weighted Jacobians (:func:`weighted_jacobians`)."""
    return np.asarray(np.linalg.lstsq(A, B, rcond=None)[0], dtype=np.float64)


def weighted_jacobians(model: PoseModel, arm: ArmModel, res: CalibrationResult, cov: GeometryCovariance,
                       w: Array) -> tuple[Array, Array]:
    """``A (3N, F)`` and ``B (3N, G)``: the measured points by the fitted arm parameters and by the GPR's parameters
    of ``cov``, each row over its ``sigma`` (:func:`gpr_gain`'s arguments)."""
    Q = arm.meas.points.q
    Ja = pose_jacobian(model, res.estimate, Q, res.fitted)[:, :3, :]             # (N, 3, F) in the frame
    inner_theta = getattr(model, 'inner_theta', None)
    a = inner_theta(res.estimate[None])[0] if callable(inner_theta) else res.estimate
    both = ArmOnGpr(arm, cov.names)
    theta = np.concatenate([a, both.core.parameters.nominal[both.columns]])
    Jg = pose_jacobian(both, theta, Q, np.arange(a.size, theta.size))[:, :3, :]  # (N, 3, G) in gpr_base
    frames = getattr(model, 'frames', None)
    if callable(frames):                                                          # a point's motion in the frame
        Jg = np.einsum('ij,njg->nig', frames(res.estimate)[0].rotation, Jg)
    A = (Ja * w[:, :3, None]).reshape(-1, Ja.shape[2])
    B = (Jg * w[:, :3, None]).reshape(-1, Jg.shape[2])
    return A, B


@dataclass(frozen=True)
class ResidualShare:
    """The weighted residuals' covariance ``C = P + G G^T`` with the GPR's error (module docstring), as the gate needs
    it: Satterthwaite's ``c`` and ``nu``, the fit's degrees of freedom ``tr P = 3N - F`` and every residual's variance
    ``diag C`` ``(N, 3)`` (in units of its sigma squared)."""

    c: float
    nu: float
    dof: int
    variance: Array

    @classmethod
    def of(cls, A: Array, B: Array, cov: GeometryCovariance) -> ResidualShare:
        """From the weighted Jacobians (:func:`weighted_jacobians`) and the GPR's covariance."""
        Qa = np.linalg.qr(A)[0]
        PB = B - Qa @ (Qa.T @ B)                         # P B, without the (3N, 3N) projection
        lam, V = np.linalg.eigh(0.5 * (cov.matrix + cov.matrix.T))
        G = PB @ (V * np.sqrt(np.clip(lam, 0.0, None)))   # C = P + G G^T (Sigma_g = V lam V^T, PSD within rounding)
        g = G.T @ G
        dof = A.shape[0] - A.shape[1]
        trace = dof + float(np.trace(g))
        square = dof + 2.0 * float(np.trace(g)) + float(np.sum(g * g))   # tr C^2: P G = G
        variance = 1.0 - np.sum(Qa * Qa, axis=1) + np.sum(G * G, axis=1)
        return cls(square / trace, trace * trace / square, dof, variance.reshape(-1, 3))

    def gate(self, res: CalibrationResult, residual: Array, names: Sequence[str]) -> Gate:
        """The gate of ``res`` with the GPR's error in its weighted ``residual (N, 3)`` blocks (rows ``names``): the
        chi-square against ``c chi^2_nu``'s :data:`~.quality.CHI2_QUANTILE` point, and with declared noise the
        outliers studentized by ``sqrt(diag C)`` (without, by their robust scale as the fit judged them)."""
        limit = self.c * float(chi2_distribution.ppf(CHI2_QUANTILE, self.nu)) / self.dof
        point = f'the {100 * CHI2_QUANTILE:g} % point for {self.dof} degrees of freedom'
        text = (f"the gate {limit:.4g} ({point} with the GPR's calibration covariance in the residuals, "
                f"{self.c * self.nu / self.dof - 1.0:.3g} of the noise's share: calibration.arm_gpr)")
        checks = []
        for check in res.gate.checks:
            if check.name == 'chi_square':
                old = f'the gate {check.limit:.4g} ({point})'
                passed = check.value <= limit
                detail = '' if passed else check.detail.replace(old, text) if old in check.detail else \
                    f'The model does not explain the measurements: reduced chi-square {check.value:.4g} above {text}.'
                check = dataclasses.replace(check, passed=passed, limit=limit, detail=detail)
            elif check.name == 'outliers' and res.absolute_sigma:
                judged = outlier_check(1.0 - self.variance, residual, names)
                check = check if judged is None else dataclasses.replace(
                    judged, detail=judged.detail.replace('(studentized)', "(studentized with the GPR's share)"))
            checks.append(check)
        return Gate(tuple(checks))


def weighted_residuals(model: PoseModel, arm: ArmModel, res: CalibrationResult, w: Array) -> Array:
    """The fit's residual blocks ``(N, 3)`` of ``arm``'s points, each over its ``sigma`` (``w``: ``1 / sigma``)."""
    return np.asarray(measured_errors(model, arm.meas.points, res.estimate)[:, :3] * w[:, :3], dtype=np.float64)


def with_gpr_covariance(res: CalibrationResult, K: Array, cov: GeometryCovariance,
                        gate: Gate | None = None) -> CalibrationResult:
    """``res`` with ``K Sigma_g K^T`` added to its covariance and its standard errors, and ``gate`` (None: its own;
    :meth:`ResidualShare.gate`: judged with the GPR's error in the residuals)."""
    total = res.covariance + K @ cov.matrix @ K.T
    total = 0.5 * (total + total.T)
    se = res.standard_error.copy()
    se[res.fitted] = np.sqrt(np.diag(total))
    return dataclasses.replace(res, covariance=total, standard_error=se, gate=res.gate if gate is None else gate)

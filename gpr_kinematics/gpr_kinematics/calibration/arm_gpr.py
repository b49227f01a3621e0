"""The GPR's calibration uncertainty in the arms' standard errors (``gpr calibrate --robot ROBOT --config FILE``, the
file's ``covariance`` block: :mod:`gpr_kinematics.core.geometry_covariance`).

The arms' fit takes the GPR's geometry ``g`` as exact. Off by ``dg`` (its calibration's error) it moves the arms'
estimate by ``-K dg``, ``K = (J_a^T W J_a)^-1 J_a^T W J_g``, with ``J_a`` the measured points by the fitted arm
parameters, ``J_g`` by the GPR's fitted parameters and ``W = diag(1 / sigma_i^2)`` the rows' weights; the arms'
covariance gains ``K Sigma_g K^T``. Both Jacobians by central differences (:func:`~.model.pose_jacobian`, each
parameter's step: the core has no analytic derivative by its geometry).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..core.geometry_covariance import GeometryCovariance
from .arm import ArmModel
from .core_model import CoreModel
from .model import ParameterSet, PoseModel, pose_jacobian
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
    return np.asarray(np.linalg.lstsq(A, B, rcond=None)[0], dtype=np.float64)


def with_gpr_covariance(res: CalibrationResult, K: Array, cov: GeometryCovariance) -> CalibrationResult:
    """``res`` with ``K Sigma_g K^T`` added to its covariance and its standard errors."""
    total = res.covariance + K @ cov.matrix @ K.T
    total = 0.5 * (total + total.T)
    se = res.standard_error.copy()
    se[res.fitted] = np.sqrt(np.diag(total))
    return dataclasses.replace(res, covariance=total, standard_error=se)

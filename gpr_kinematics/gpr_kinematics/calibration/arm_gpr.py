"""The GPR's calibration uncertainty in the arms' standard errors (``gpr calibrate --robot ROBOT --config FILE``, the
file's ``covariance`` block: :mod:`gpr_kinematics.core.geometry_covariance`).

The arms' fit takes the GPR's geometry ``g`` as exact. Off by ``dg`` (its calibration's error) it moves the arms'
estimate by ``-K dg``, ``K = (J_a^T W J_a)^-1 J_a^T W J_g``, with ``J_a`` the measured points by the fitted arm
parameters, ``J_g`` by the GPR's fitted parameters and ``W = diag(1 / sigma_i^2)`` the rows' weights; the arms'
covariance gains ``K Sigma_g K^T``. Both Jacobians by central differences (:func:`~.model.pose_jacobian`, each
parameter's step: the core has no analytic derivative by its geometry).

The error is in the residuals too: the weighted residuals ``r = P (e + B dg)`` (``A``, ``B`` the weighted ``J_a``,
``J_g``; ``P = I - A A^+`` the projection on the residuals' space; ``e`` unit noise) have the covariance
``C = P (I + B Sigma_g B^T) P = P + G G^T`` (``G = P B Sigma_g^(1/2)``), so ``|r|^2 = chi^2_(dof - r) + sum_k (1 + mu_k)
chi^2_1`` over the eigenvalues ``mu_k`` of ``G^T G``, not the ``chi^2`` of ``dof = tr P`` degrees of freedom the gate
takes for an exact GPR. :class:`ResidualShare` judges the chi-square against that sum's
:data:`~.quality.CHI2_QUANTILE` point (:mod:`.chi2_mixture`, the saddlepoint approximation) and, with declared
noise, checks it is not below its ``1 - CHI2_QUANTILE`` point (``gpr_covariance``: a block in other units) and
studentizes the outliers by ``sqrt(C_ii)``. The few directions ``Q`` of ``G`` (:data:`SHARE_RANK`) can dominate
that sum's tail, so a second check, ``noise_chi_square``, judges the residuals outside them, ``|(I - Q Q^T) r|^2 =
chi^2_(dof - r)`` whatever ``dg`` is, against the plain chi-square's point: only more noise than declared or
outliers raise it. Measured on 100 GPRs calibrated from 15 noisy poses: a gate taking the
GPR as exact failed 53 arms fitted to their noise, this one none (``test_calibration_arm_gpr.py``).
"""
from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core.geometry_covariance import GeometryCovariance
from ..errors import InputError
from .arm import ArmModel
from .chi2_mixture import quantile
from .core_model import CoreModel
from .distributions import chi2_ppf
from .model import ParameterSet, PoseModel, evaluate, pose_jacobian
from .plausibility import measured_errors
from .quality import CHI2_QUANTILE, Gate, GateCheck, outlier_check, spread
from .results import CalibrationResult

Array = NDArray[np.float64]

#: The GPR's share occupies a direction of the residuals where ``G``'s singular value ``s_k`` (the share's standard
#: deviation along it, in units of the noise's) exceeds this times ``max(s_1, 1)``: ``s_k^2 = mu_k``, the excess.
SHARE_RANK = 1e-6


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
    of ``cov``, each row over its ``sigma`` (:func:`gpr_gain`'s arguments). With a registered base (``cov.base``:
    ``model`` measures in its frame at that pose) ``B``'s last six columns are the points' motion ``m = b + R_b p``
    with the base, exact: ``dm/db = I``, and ``-[m - b]x`` by its turn ``d`` about the frame's axes."""
    Q = arm.meas.points.q
    Ja = pose_jacobian(model, res.estimate, Q, res.fitted)[:, :3, :]             # (N, 3, F) in the frame
    inner_theta = getattr(model, 'inner_theta', None)
    a = inner_theta(res.estimate[None])[0] if callable(inner_theta) else res.estimate
    geometry = cov.geometry().names
    both = ArmOnGpr(arm, geometry)
    theta = np.concatenate([a, both.core.parameters.nominal[both.columns]])
    Jg = pose_jacobian(both, theta, Q, np.arange(a.size, theta.size))[:, :3, :]  # (N, 3, G) in gpr_base
    frames = getattr(model, 'frames', None)
    if callable(frames):                                                          # a point's motion in the frame
        Jg = np.einsum('ij,njg->nig', frames(res.estimate)[0].rotation, Jg)
    if cov.base is not None:
        if not callable(frames) or getattr(model, 'fit_base', True):
            raise InputError(f"the covariance of {cov.origin} has the registration of gpr_base in {cov.base.frame}; "
                             'allowed with measurements in that frame at that pose only (--base FILE)')
        m = evaluate(model, res.estimate, Q)[0] - frames(res.estimate)[0].position   # (N, 3): R_b p
        turn = np.zeros((m.shape[0], 3, 3))
        turn[:, 0, 1], turn[:, 0, 2], turn[:, 1, 2] = m[:, 2], -m[:, 1], m[:, 0]     # -[m]x
        turn -= np.swapaxes(turn, 1, 2)
        Jg = np.concatenate([Jg, np.broadcast_to(np.eye(3), turn.shape), turn], axis=2)
    A = (Ja * w[:, :3, None]).reshape(-1, Ja.shape[2])
    B = (Jg * w[:, :3, None]).reshape(-1, Jg.shape[2])
    return A, B


@dataclass(frozen=True)
class ResidualShare:
    """The weighted residuals' covariance ``C = P + G G^T`` with the GPR's error (module docstring), as the gate needs
    it: the fit's degrees of freedom ``tr P = 3N - F``, the eigenvalues ``excess`` of ``G^T G`` above 0 (``C`` has
    ``1 + excess_k`` where it differs from ``P``'s ones), every residual's variance ``diag C`` ``(N, 3)`` and the GPR's
    share of it, ``gpr = diag G G^T`` ``(N, 3)`` (both in units of its sigma squared), and the orthonormal basis
    ``basis`` ``(3N, r)`` of the directions it occupies (``G``'s left singular vectors, :data:`SHARE_RANK`)."""

    dof: int
    excess: Array
    variance: Array
    gpr: Array
    basis: Array

    @classmethod
    def of(cls, A: Array, B: Array, cov: GeometryCovariance) -> ResidualShare:
        """From the weighted Jacobians (:func:`weighted_jacobians`) and the GPR's covariance."""
        Qa = np.linalg.qr(A)[0]
        PB = B - Qa @ (Qa.T @ B)                         # P B, without the (3N, 3N) projection
        lam, V = np.linalg.eigh(0.5 * (cov.matrix + cov.matrix.T))
        G = PB @ (V * np.sqrt(np.clip(lam, 0.0, None)))   # C = P + G G^T (Sigma_g = V lam V^T, PSD within rounding)
        U, s = np.linalg.svd(G, full_matrices=False)[:2]
        mu = s[::-1] ** 2                                # G^T G's eigenvalues, ascending
        gpr = np.sum(G * G, axis=1)
        variance = 1.0 - np.sum(Qa * Qa, axis=1) + gpr
        dof = A.shape[0] - A.shape[1]
        excess = mu[mu > SHARE_RANK ** 2 * max(float(mu.max(initial=0.0)), 1.0)][-dof:] if dof > 0 else mu[:0]
        basis = U[:, s > SHARE_RANK * max(float(s.max(initial=0.0)), 1.0)][:, :max(dof, 0)]
        return cls(dof, excess, variance.reshape(-1, 3), gpr.reshape(-1, 3), basis)

    @property
    def mean(self) -> float:
        """The reduced chi-square's expectation ``tr C / dof``."""
        return 1.0 + float(np.sum(self.excess)) / self.dof

    def point(self, p: float) -> float:
        """The reduced chi-square's ``p`` point: ``|r|^2 = chi^2_(dof - r) + sum_k (1 + excess_k) chi^2_1``
        (:func:`~.chi2_mixture.quantile`, the saddlepoint approximation)."""
        lam = np.concatenate([[1.0], 1.0 + self.excess])
        h = np.concatenate([[self.dof - self.excess.size], np.ones(self.excess.size)])
        return quantile(p, lam[h > 0], h[h > 0]) / self.dof

    def gate(self, res: CalibrationResult, residual: Array, names: Sequence[str]) -> Gate:
        """The gate of ``res`` with the GPR's error in its weighted ``residual (N, 3)`` blocks (rows ``names``): the
        chi-square against its :data:`~.quality.CHI2_QUANTILE` point and, with declared noise, a ``gpr_covariance``
        check that it is not below its ``1 - CHI2_QUANTILE`` point (a block in other units, mm^2 for m^2, let every
        fit pass) and the outliers studentized by ``sqrt(diag C)`` (without, by their robust scale as the fit judged
        them)."""
        h = 1.0 - self.variance
        checks = []
        for check in res.gate.checks:
            if check.name == 'chi_square':
                checks += self._chi_square(check, spread(h, residual), res.absolute_sigma)
                checks.append(self.outside(residual, spread(h, residual)))
                continue
            if check.name == 'outliers' and res.absolute_sigma:
                judged = outlier_check(h, residual, names, fitted=res.fitted.size)
                if judged is not None:
                    said = judged.detail.replace('(studentized)', "(studentized with the GPR's share)")
                    check = dataclasses.replace(judged, detail='' if judged.passed and judged.judged else said)
            checks.append(check)
        return Gate(tuple(checks))

    def _chi_square(self, check: GateCheck, scale: str, declared: bool) -> list[GateCheck]:
        """The fit's chi-square ``check`` judged with the GPR's share (its words: the limit, the residuals' robust
        ``scale``), and with ``declared`` noise the ``gpr_covariance`` check below it (residuals below an assumed
        noise are no fault, as the gate's ``sigmas`` check says)."""
        limit, low = self.point(CHI2_QUANTILE), self.point(1.0 - CHI2_QUANTILE) if declared else None
        value, point = check.value, f'the {100 * CHI2_QUANTILE:g} % point for {self.dof} degrees of freedom'
        share = (f"with the GPR's calibration covariance in the residuals, {self.mean - 1.0:.3g} of the noise's "
                 'share: calibration.arm_gpr')
        old, text = f'the gate {check.limit:.4g} ({point})', f'the gate {limit:.4g} ({point} {share})'
        detail = re.sub(r'\(robust scale: [^)]*\)', f'(robust scale: {scale} sigma)', check.detail.replace(old, text))
        if old not in check.detail:
            detail = f'The model does not explain the measurements: reduced chi-square {value:.4g} above {text}.'
        out = [dataclasses.replace(check, passed=value <= limit, limit=limit, detail='' if value <= limit else detail)]
        if low is not None:
            out.append(GateCheck('gpr_covariance', value >= low, value, low, '' if value >= low else
                                 f"The residuals are far smaller than the GPR's covariance block says: reduced "
                                 f'chi-square {value:.4g} below {low:.4g} (the {100 * (1 - CHI2_QUANTILE):g} % point '
                                 f'for {self.dof} degrees of freedom {share}): a block in other units than SI (mm^2 '
                                 "for m^2?), or another GPR's; allowed: the covariance gpr calibrate wrote with the "
                                 'geometry.', at_least=True))
        return out

    def outside(self, residual: Array, scale: str) -> GateCheck:
        """The ``noise_chi_square`` check of the weighted ``residual (N, 3)`` blocks: ``|(I - Q Q^T) r|^2 / (dof - r)``
        (``Q`` :attr:`basis`, ``r`` its columns) at most the :data:`~.quality.CHI2_QUANTILE` point of a chi-square of
        ``dof - r`` degrees of freedom over them (``scale``: the residuals' robust scale); not judged below 1."""
        r = np.ravel(residual)
        free, n = self.dof - self.basis.shape[1], self.basis.shape[1]
        where = f"outside the {n} direction(s) the GPR's calibration covariance occupies"
        if free < 1:
            return GateCheck('noise_chi_square', True, math.nan, math.nan,
                             f'noise chi square: the residuals have no degree of freedom {where} ({self.dof} in all): '
                             "only the mixture's chi-square judges them; allowed: more rows.", judged=False)
        value = float(r @ r - np.sum((self.basis.T @ r) ** 2)) / free
        limit = chi2_ppf(CHI2_QUANTILE, free) / free
        return GateCheck('noise_chi_square', value <= limit, value, limit, '' if value <= limit else
                         f'The residuals {where}, which no error of the GPR or its registration reaches, exceed the '
                         f'noise: reduced chi-square {value:.4g} above the gate {limit:.4g} (the '
                         f'{100 * CHI2_QUANTILE:g} % point for {free} degrees of freedom; robust scale: {scale} '
                         'sigma): more noise than declared or outlying rows; allowed: residuals within the declared '
                         'noise (sigma columns, --sigma-position) there.')


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
    return dataclasses.replace(res, covariance=total, standard_error=se, gate=res.gate if gate is None else gate,
                               warnings=res.warnings + _carried_by_the_gpr(res, gate))


def _carried_by_the_gpr(res: CalibrationResult, gate: Gate | None) -> tuple[str, ...]:
    """The warning of a fit that passes ``gate`` only with the GPR's error in its residuals (its chi-square beyond
    the noise's own limit in ``res.gate``): a trial's arms passed at reduced chi-squares of 51 to 503, missing their
    own points by up to 0.3 mm, without a word."""
    plain = next((c for c in res.gate.checks if c.name == 'chi_square'), None)
    if gate is None or not gate.passed or plain is None or plain.passed or not plain.judged:
        return ()
    a = res.after
    return (f"the fit passes only with the GPR's calibration error in its residuals: reduced chi-square "
            f'{plain.value:.4g}, above the {plain.limit:.4g} its noise alone allows; the arm misses its own points by '
            f'{a.rms_position * 1e6:.4g} um RMS, {a.max_position * 1e6:.4g} um at worst (line '
            f'{a.worst_position_line}): the GPR\'s calibration sets that, not the arm\'s (a GPR calibrated with more '
            'poses or less noise lowers it)',)

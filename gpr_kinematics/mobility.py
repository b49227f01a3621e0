"""Mobility and sensitivity analysis of the GPR with virtual joints (paper §IV-A, eqs. 1-5).

Seed: Bratovanov & Sotirov, ``gpr-virtual-joints-bratovanov-sotirov.txt`` §IV-A. With
``P = (q, P1, P2, P3)`` (``N = 12``) the constraints (eq. 1) are

    Phi_{3i..3i+2} = B_i + q_i e3 - P_i = 0,                   i = 1, 2, 3
    Phi_{9+i}      = |P_{i%3+1} - P_i|^2 - L_{i,i%3+1}(X)^2 = 0,

where the side lengths ``L(X) = |r_{i%3+1}(X) - r_i(X)|`` are made variable by the virtual joints ``X``
(eq. 2). The mobility of the rigid mechanism is ``h = 12 - rank(dPhi/dP)``: rank 9 at ``q1 = q2 = q3``
(h = 3, instantaneous), 11 elsewhere (h = 1: the tilt is blocked); ``rank [dPhi/dP  dPhi/dX] = 12``
everywhere, so the augmented mechanism is never singular. Sensitivity: from ``dPhi/dP dP + dPhi/dX dX = 0``
(eq. 3), ``dX = -(dPhi/dX)^+ dPhi/dP dP = dX/dP dP``; with the eigen-decomposition
``dX/dP^T dX/dP = V D V^T`` (eigenvalues ascending, only ``d10..d12`` non-zero):

    sqrt(d10 sum_{k=10..12} (v_k^T dP)^2) <= |dX| <= sqrt(d12 sum_{k=10..12} (v_k^T dP)^2)        (4)
    sigma_min(dX/dP) sqrt(sum (v_k^T dP)^2) <= |dX| <= sigma_max(dX/dP) sqrt(sum (v_k^T dP)^2)      (5)

Since the eigenvalues of ``A^T A`` are the squared singular values of ``A``, (4) and (5) give the same
numbers; both are reported. The pseudo-inverse is taken in the metric of the forward solver (angular
coordinates weighted by the characteristic length, design.md §3); ``weighting='unweighted'`` gives the
paper's plain Moore-Penrose form. Units: ``dP`` in metres, ``dX`` in metres and radians.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .config import GprConfig
from .errors import InputError
from .kinematics import base_points, forward, resolve_config
from .virtual_joints import EDGES, coordinate_scale, make_model

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SensitivityBounds:
    """Bounds of paper eqs. (4) and (5) on ``|dX|`` for one ``dP``, and the actual ``|dX|``."""

    norm_dx: float
    lower_eq4: float
    upper_eq4: float
    lower_eq5: float
    upper_eq5: float


@dataclass(frozen=True)
class MobilityResult:
    """Mobility and sensitivity of the GPR at one configuration.

    Attributes:
        q: rod lengths [m]; model: virtual-joint model; virtual_joints: ``X`` at ``q``.
        dphi_dp: ``dPhi/dP`` (12 x 12); dphi_dx: ``dPhi/dX`` (12 x M); dx_dp: ``dX/dP`` (M x 12).
        rank_dphi_dp: rank of ``dPhi/dP`` (9 at q1 = q2 = q3, 11 elsewhere); mobility: ``12 - rank``.
        rank_augmented: rank of ``[dPhi/dP dPhi/dX]`` (12 everywhere).
        eigenvalues: of ``dX/dP^T dX/dP``, ascending (12); eigenvectors: columns ``v_1..v_12``.
        singular_values: non-zero singular values of ``dX/dP``, descending.
        bounds: the gains of eqs. (4), (5): ``|dX| / |P_V dP|`` lies in ``[lower, upper]``, where ``P_V dP``
            is the projection of ``dP`` on ``v_10..v_12``.
    """

    q: Array
    model: str
    virtual_joints: Array
    dphi_dp: Array
    dphi_dx: Array
    dx_dp: Array
    rank_dphi_dp: int
    rank_augmented: int
    mobility: int
    eigenvalues: Array
    eigenvectors: Array
    singular_values: Array
    bounds: dict[str, tuple[float, float]]

    def dx_bounds(self, dP: ArrayLike) -> SensitivityBounds:
        """Paper eqs. (4), (5) for a given ``dP`` (12 values: dq1..3, dP1, dP2, dP3)."""
        dp = np.asarray(dP, dtype=float)
        if dp.shape != (12,) or not np.all(np.isfinite(dp)):
            raise InputError(f'dP must be 12 finite numbers (dq1..dq3, dP1, dP2, dP3), got shape {dp.shape}')
        proj = float(np.sqrt(np.sum((self.eigenvectors[:, -3:].T @ dp) ** 2)))
        d = self.eigenvalues
        s = self.singular_values
        return SensitivityBounds(
            norm_dx=float(np.linalg.norm(self.dx_dp @ dp)),
            lower_eq4=float(np.sqrt(max(d[-3], 0.0)) * proj), upper_eq4=float(np.sqrt(d[-1]) * proj),
            lower_eq5=float(s[-1] * proj) if s.size else 0.0, upper_eq5=float(s[0] * proj) if s.size else 0.0)


def rod_perturbation(dq: ArrayLike) -> Array:
    """``dP`` of a change ``dq`` of the rod lengths: ``(dq, dq1 e3, dq2 e3, dq3 e3)`` (eq. 1, first rows)."""
    d = np.asarray(dq, dtype=float)
    if d.shape != (3,) or not np.all(np.isfinite(d)):
        raise InputError(f'dq must be 3 finite numbers [m], got {np.asarray(dq).tolist()!r}')
    dp = np.zeros(12)
    dp[:3] = d
    dp[5::3] = d
    return dp


def _rank(A: Array) -> int:
    return int(np.linalg.matrix_rank(A))


def analyze_mobility(q: ArrayLike, config: GprConfig | None = None, model: str | None = None) -> MobilityResult:
    """Mobility and sensitivity analysis at rod lengths ``q`` [m] (module docstring)."""
    cfg = resolve_config(config)
    vjm = make_model(cfg, model)
    fk = forward(q, config=cfg, model=vjm.name)
    P = base_points(fk.q[None, :], cfg)[0]
    M = vjm.size
    dphi_dp = np.zeros((12, 12))
    for i in range(3):
        dphi_dp[3 * i + 2, i] = 1.0
        dphi_dp[3 * i:3 * i + 3, 3 + 3 * i:6 + 3 * i] = -np.eye(3)
    for i, (a, b) in enumerate(EDGES):
        e = P[b] - P[a]
        dphi_dp[9 + i, 3 + 3 * b:6 + 3 * b] = 2.0 * e
        dphi_dp[9 + i, 3 + 3 * a:6 + 3 * a] = -2.0 * e
    # Phi_{9+i} = |P_b - P_a|^2 - d_i(X)^2, so dPhi/dX = -dF/dX (F = d^2 - L^2 of virtual_joints).
    _, J, _ = vjm.closure(fk.virtual_joints[None, :], np.zeros((1, 3)))
    dphi_dx = np.zeros((12, M))
    dphi_dx[9:, :] = -J[0]
    s = coordinate_scale(vjm, cfg)
    dx_dp = -(np.linalg.pinv(dphi_dx / s) / s[:, None]) @ dphi_dp
    evals, evecs = np.linalg.eigh(dx_dp.T @ dx_dp)
    sv = np.linalg.svd(dx_dp, compute_uv=False)
    sv = sv[sv > sv[0] * max(dx_dp.shape) * np.finfo(float).eps] if sv.size and sv[0] > 0 else sv[:0]
    rank_p = _rank(dphi_dp)
    bounds = {'eq4': (float(np.sqrt(max(evals[-3], 0.0))), float(np.sqrt(evals[-1]))),
              'eq5': (float(sv[-1]), float(sv[0]))}
    return MobilityResult(
        q=fk.q, model=vjm.name, virtual_joints=fk.virtual_joints, dphi_dp=dphi_dp, dphi_dx=dphi_dx,
        dx_dp=dx_dp, rank_dphi_dp=rank_p, rank_augmented=_rank(np.hstack([dphi_dp, dphi_dx])),
        mobility=12 - rank_p, eigenvalues=evals, eigenvectors=evecs, singular_values=sv, bounds=bounds)

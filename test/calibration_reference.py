"""An independent reference model of the imperfect GPR for the calibration tests (not the core's kernels).

Geometry, SI units. Rod ``k`` stands at the base point ``B_k = (bx_k, by_k, z_b)`` (``z_b``: height of the
``q = 0`` plane, 0 nominally) with unit direction ``u_k ~ (tx_k, ty_k, 1)`` (a small tilt from the base z axis);
its joint centre is ``P_k = B_k + (q_k + o_k) u_k`` (``o_k``: zero offset of ``q_k``), displaced by the
optional joint play. Platform joint ``k`` sits nominally at ``p_k`` in ``gpr_platform`` (z = 0) and may move by
``d_k`` in the platform plane at the elastic cost ``1/2 d_k^T W_k d_k``, ``W_k = e_r e_r^T + kappa e_t e_t^T``
(``e_r = p_k / |p_k|``, ``e_t`` the tangential direction; ``kappa = k_t / k_r``).

Closure: the platform plane is the plane of the three ``P_k``. With ``s_k`` the 2-D coordinates of ``P_k`` in
an orthonormal frame ``F`` of that plane (origin at their centroid), the joint centres in platform coordinates
are ``r_k = A(psi) s_k + c`` for an in-plane rotation ``A(psi)`` and shift ``c``, and the pose minimises
``sum_k 1/2 |S_k (A s_k + c - p_k)|^2`` (``S_k = W_k^(1/2)``) over ``(c, psi)``: a 3-unknown nonlinear least
squares per pose, solved by Gauss-Newton from the isotropic (Kabsch) solution, vectorised over all poses
(``test_calibration_reference.py`` checks it against ``scipy.optimize.least_squares`` pose by pose). The pose
of ``gpr_platform`` is then exactly ``Rot = F diag(A^T, 1)``, ``t = O - F_2 A^T c``, so that
``Rot r_k + t = P_k`` (the rigid fit, with zero residual by construction).
"""
from __future__ import annotations

import math

import numpy as np
from gpr_kinematics.calibration.model import Parameter, ParameterSet

R_NOMINAL = 0.093218
AZIMUTHS = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)


def reference_parameters(kappa: float = 1.0, base_z: bool = True) -> ParameterSet:
    """The 22 (23 with ``base_z``) parameters of the reference model, nominal geometry, ``kappa`` nominal."""
    out = []
    for k, th in enumerate(AZIMUTHS, 1):
        out += [Parameter(f'base_x{k}', R_NOMINAL * math.cos(th), 'm', 1e-4, 'rod_bases', (k - 1, 0)),
                Parameter(f'base_y{k}', R_NOMINAL * math.sin(th), 'm', 1e-4, 'rod_bases', (k - 1, 1))]
    out += [Parameter(f'offset{k}', 0.0, 'm', 1e-4, 'rod_offsets', (k - 1,)) for k in (1, 2, 3)]
    for k in (1, 2, 3):
        out += [Parameter(f'rod_tilt_x{k}', 0.0, 'rad', 1e-3, 'rod_directions', (k - 1, 0)),
                Parameter(f'rod_tilt_y{k}', 0.0, 'rad', 1e-3, 'rod_directions', (k - 1, 1))]
    for k, th in enumerate(AZIMUTHS, 1):
        out += [Parameter(f'joint_x{k}', R_NOMINAL * math.cos(th), 'm', 1e-4, 'platform_joints', (k - 1, 0)),
                Parameter(f'joint_y{k}', R_NOMINAL * math.sin(th), 'm', 1e-4, 'platform_joints', (k - 1, 1))]
    out.append(Parameter('kappa', kappa, '1', 1.0, 'kappa'))
    if base_z:
        out.append(Parameter('base_z', 0.0, 'm', 1e-4, 'base_z'))
    return ParameterSet(tuple(out))


class ReferenceModel:
    """The model of the module docstring as a :class:`~gpr_kinematics.calibration.model.PoseModel`."""

    supports_displacement = True

    def __init__(self, kappa: float = 1.0, base_z: bool = True) -> None:
        self._parameters = reference_parameters(kappa, base_z)
        self.has_base_z = base_z
        self.last_iterations = 0

    @property
    def parameters(self) -> ParameterSet:
        return self._parameters

    def joint_centres(self, theta: np.ndarray, Q: np.ndarray, displacement=None) -> np.ndarray:
        """``P_k`` in gpr_base, ``(S, N, 3, 3)`` (axis 2: the joint)."""
        S = theta.shape[0]
        B = np.zeros((S, 1, 3, 3))
        B[:, 0, :, :2] = theta[:, 0:6].reshape(S, 3, 2)
        if self.has_base_z:
            B[:, 0, :, 2] = theta[:, 22:23]
        o = theta[:, 6:9][:, None, :]
        u = np.ones((S, 1, 3, 3))
        u[:, 0, :, :2] = theta[:, 9:15].reshape(S, 3, 2)
        u /= np.linalg.norm(u, axis=-1, keepdims=True)
        P = B + (Q + o)[..., None] * u
        return P if displacement is None else P + displacement

    def poses(self, theta, Q, displacement=None):
        S, N = Q.shape[:2]
        P = self.joint_centres(theta, Q, displacement)
        p = np.broadcast_to(theta[:, 15:21].reshape(S, 1, 3, 2), (S, N, 3, 2))
        kappa = np.broadcast_to(theta[:, 21][:, None], (S, N))
        centre = P.mean(axis=2)
        n = np.cross(P[:, :, 1] - P[:, :, 0], P[:, :, 2] - P[:, :, 0])
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        e1 = np.zeros_like(n)
        e1[..., 0] = 1.0
        e1 -= np.sum(e1 * n, axis=-1, keepdims=True) * n
        e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
        e2 = np.cross(n, e1)
        F2 = np.stack([e1, e2], axis=-1)                                    # (S, N, 3, 2)
        s = np.einsum('snkj,snji->snki', P - centre[:, :, None, :], F2)          # (S, N, 3, 2)
        c, psi = self.solve_closure(s, p, kappa)
        A = _rot2(psi)                                                      # (S, N, 2, 2)
        At = np.swapaxes(A, -1, -2)
        rot = np.empty((S, N, 3, 3))
        rot[..., :2] = F2 @ At
        rot[..., 2] = n
        t = centre - np.einsum('snij,snj->sni', F2 @ At, c)
        return t, rot

    def solve_closure(self, s, p, kappa, tol=1e-15, max_iter=30):
        """``(c, psi)`` minimising the elastic cost for 2-D joint coordinates ``s`` and nominal joints ``p``.

        The residual of joint k, ``S_k d_k``, is written in the orthonormal basis ``(e_r, e_t)``: its components are
        ``e_r . d_k`` and ``sqrt(kappa) e_t . d_k`` (same norm), and Gauss-Newton works on those, component-wise.
        """
        er = p / np.linalg.norm(p, axis=-1, keepdims=True)
        erx, ery = er[..., 0], er[..., 1]
        etx, ety = -ery, erx
        sq = np.sqrt(kappa)[..., None]
        sx, sy = s[..., 0], s[..., 1]
        px, py = p[..., 0], p[..., 1]
        psi = np.arctan2((sx * py - sy * px).sum(-1), (sx * px + sy * py).sum(-1))   # Kabsch (s is centred)
        cs, sn = np.cos(psi)[..., None], np.sin(psi)[..., None]
        cx = (px - (cs * sx - sn * sy)).mean(-1)
        cy = (py - (sn * sx + cs * sy)).mean(-1)
        # Jacobian rows of joint k: radial (erx, ery, er . da), tangential sq (etx, ety, et . da).
        for it in range(1, max_iter + 1):
            cs, sn = np.cos(psi)[..., None], np.sin(psi)[..., None]
            ax, ay = cs * sx - sn * sy, sn * sx + cs * sy
            dx, dy = ax + cx[..., None] - px, ay + cy[..., None] - py
            rr, rt = erx * dx + ery * dy, sq * (etx * dx + ety * dy)
            jr3, jt3 = erx * -ay + ery * ax, sq * (etx * -ay + ety * ax)
            jrx, jry, jtx, jty = erx, ery, sq * etx, sq * ety
            a, b, c = (jrx * jrx + jtx * jtx).sum(-1), (jry * jry + jty * jty).sum(-1), (jr3 * jr3 + jt3 * jt3).sum(-1)
            d, e, f = (jrx * jry + jtx * jty).sum(-1), (jrx * jr3 + jtx * jt3).sum(-1), (jry * jr3 + jty * jt3).sum(-1)
            g0, g1, g2 = (jrx * rr + jtx * rt).sum(-1), (jry * rr + jty * rt).sum(-1), (jr3 * rr + jt3 * rt).sum(-1)
            # Gauss-Newton step -H^-1 g for the symmetric H = [[a, d, e], [d, b, f], [e, f, c]] by its adjugate.
            A00, A11, A22 = b * c - f * f, a * c - e * e, a * b - d * d
            A01, A02, A12 = e * f - d * c, d * f - b * e, d * e - a * f
            det = a * A00 + d * A01 + e * A02
            s0 = -(A00 * g0 + A01 * g1 + A02 * g2) / det
            s1 = -(A01 * g0 + A11 * g1 + A12 * g2) / det
            s2 = -(A02 * g0 + A12 * g1 + A22 * g2) / det
            cx, cy, psi = cx + s0, cy + s1, psi + s2
            self.last_iterations = it
            if max(np.max(np.abs(s0)), np.max(np.abs(s1))) < tol and np.max(np.abs(s2)) < tol * 10:
                break
        return np.stack([cx, cy], axis=-1), psi


def _rot2(psi):
    cs, sn = np.cos(psi), np.sin(psi)
    return np.stack([np.stack([cs, -sn], -1), np.stack([sn, cs], -1)], -2)

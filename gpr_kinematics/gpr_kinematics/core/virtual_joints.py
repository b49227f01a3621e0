"""Virtual-joint models of the GPR platform: the joints as functions of ``X``, the closure equations and their terms.

Bratovanov & Sotirov, *Virtualization for the purposes of modeling and computer simulation of a class of
overconstrained robots*, §IV-V (``docs/references.md``). The platform-frame joint centres ``r_k(X)`` (in the
platform plane, z = 0) become functions of virtual-joint coordinates ``X``, ordered as in the paper: the three
linear coordinates, then the three others. With the platform joint ``p_k = rho_k u(theta_k)`` of the machine
(:class:`~gpr_kinematics.core.machine.MachineGeometry`; ``rho_k = R`` on the nominal machine), ``u(a) = (cos a,
sin a)``, ``e_r = u(theta_k)`` and ``e_t = u(theta_k + pi/2)``:

==========  =====================  ===========================================  ===============  ==========
model       X                      r_k(X)                                       X at rest         paper
==========  =====================  ===========================================  ===============  ==========
radial      l1 l2 l3               l_k u(theta_k)                               l = rho           [11], §IV
polar       l1..3 phi1..3          l_k u(theta_k + phi_k)                       l = rho, phi = 0  §V-A
offset      dr1..3 dphi1..3        p_k + dr_k u(theta_k + dphi_k)               0                 §V-B
compliant   dr1..3 dt1..3          p_k + dr_k e_r + dt_k e_t                    0                 (this package)
==========  =====================  ===========================================  ===============  ==========

*At rest* (the start of every solve) the joints sit at their places ``p_k``; on the nominal machine that is
the singular configuration ``q1 = q2 = q3``. (The paper's §V-B formula for ``r_3`` has ``dphi_2`` where
``dphi_3`` is meant, and its §V-A ``dF/dX`` swaps ``l1`` and ``l3`` in the third equation's column and reverses its
``phi`` signs: the Jacobians here are ``F``'s own, checked against finite differences.) The closure equations (the
paper's eq. (6) in the form of §V-B) are

    F_i(X) = |r_{i%3+1}(X) - r_i(X)|^2 - L_{i,i%3+1}^2 = 0,   i = 1, 2, 3,

with the side lengths ``L`` of the joint centres ``P_k`` fixed by the rod lengths ``q``. ``radial`` is square;
``polar`` and ``offset`` are underdetermined (3 equations, 6 unknowns) and are solved by Newton-Raphson with
the Moore-Penrose pseudo-inverse of ``dF/dX`` (eq. (8)), always from the rest ``X``, so that the solution is a
pure function of ``q``. The pseudo-inverse is taken in the metric ``|dX|_W^2 = sum dl^2 + c^2 sum dphi^2``,
``c`` a characteristic length (Toz & Kucuk, the homogenisation of §4.3; default ``R``), so the minimum-norm
step is the smallest displacement of the joint centres and does not depend on the units;
``weighting='unweighted'`` uses ``c = 1`` in SI units, the paper's eq. (8) as printed.

The ``offset`` model as printed is degenerate where Newton starts: at ``dr = 0`` its angular coordinates have
zero derivative (``d r_k / d dphi_k = dr_k u'``), so the minimum-norm step barely moves them and the model
stays on the radial solution: within the tilt limit the platform pose equals ``radial``'s to 1e-14 m and the
angular coordinates stay below 1e-9 rad (a test checks it). ``compliant`` is the physical model that lets the
joints move tangentially: its ``X`` is the one of minimum elastic cost among all that close the mechanism
(:mod:`gpr_kinematics.core.compliance`). The solvers are in :mod:`gpr_kinematics.core.closure`.
"""
from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..errors import ConvergenceError, InputError, brief
from .config import MODELS, GprConfig
from .machine import MachineGeometry, Values3
from .ops import ARRAY, SCALAR, Count, Mask, Ops, Value

Array = NDArray[np.float64]
#: ``(rx, ry, dlx, dly, dax, day)``: lists over the joints ``k``; see :func:`joint_components`.
Components = tuple[Sequence[Value], Sequence[Value], Sequence[Value], Sequence[Value], Sequence[Value] | None,
                   Sequence[Value] | None]

#: Edges of the joint triangle: (i, i % 3 + 1) in the paper's 1-based numbering.
EDGES = ((0, 1), (1, 2), (2, 0))
#: The side lengths of :data:`EDGES` as the paper names them (``L = (L12, L23, L31)``).
EDGE_NAMES = ('L12', 'L23', 'L31')
#: The paper's models, solved by the closure Newton-Raphson (:func:`newton_closure`); ``compliant`` is solved as
#: a minimum of elastic cost (:mod:`gpr_kinematics.core.compliance`).
CLOSURE_MODELS = tuple(m for m in MODELS if m != 'compliant')

_NAMES = {'radial': ('l1', 'l2', 'l3'), 'polar': ('l1', 'l2', 'l3', 'phi1', 'phi2', 'phi3'),
          'offset': ('dr1', 'dr2', 'dr3', 'dphi1', 'dphi2', 'dphi3'),
          'compliant': ('dr1', 'dr2', 'dr3', 'dt1', 'dt2', 'dt3')}


@dataclass(frozen=True)
class VirtualJointModel:
    """One virtual-joint parameterisation ``r_k(X)`` of the platform joint centres.

    Attributes:
        name: one of :data:`~gpr_kinematics.core.config.MODELS`.
        rho, theta: polar form of the platform joints ``p_k = rho_k u(theta_k)`` [m, rad].
        cos, sin: ``cos theta_k``, ``sin theta_k``. kappa: ``k_t / k_r`` per joint (``compliant``).

    Each is a float per joint, or an array ``(N,)`` per joint for one machine per sample
    (:meth:`MachineGeometry.per_row <gpr_kinematics.core.machine.MachineGeometry.per_row>`; batch kernels only).
    """

    name: str
    rho: Values3
    theta: Values3
    cos: Values3
    sin: Values3
    kappa: Values3

    @property
    def size(self) -> int:
        """Number ``M`` of virtual-joint coordinates."""
        return 3 if self.name == 'radial' else 6

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the coordinates, in the order of ``X``."""
        return _NAMES[self.name]

    @property
    def angular(self) -> NDArray[np.bool_]:
        """Mask of the angular coordinates (radians) in ``X``."""
        return np.arange(self.size) >= (3 if self.name in ('polar', 'offset') else self.size)

    @functools.cached_property
    def singular_floats(self) -> tuple[Value, ...]:
        """``X`` at rest (every joint at its place ``p_k``): the start of every solve (floats for one machine)."""
        lengths = self.rho if self.name in ('radial', 'polar') else (0.0, 0.0, 0.0)
        return tuple(lengths) + (0.0, 0.0, 0.0)[:self.size - 3]

    @functools.cached_property
    def singular_components(self) -> Components:
        """:func:`joint_components` (float arithmetic) at rest: the start of every single solve."""
        return joint_components(SCALAR, self, list(self.singular_floats))

    def singular(self, n: int = 1) -> Array:
        """``X`` at rest, shape ``(n, M)`` (on the nominal machine: at the singular configuration)."""
        return np.tile(np.array(self.singular_floats), (n, 1))

    def points_and_partials(self, X: Array) -> tuple[Array, Array, Array]:
        """Joint centres ``r_k(X)`` ``(N, 3, 2)`` and their partials, as arrays (from :func:`joint_components`).

        Returns ``(r, dr_dlin, dr_dang)``: ``dr_dlin[:, k]`` is ``d r_k / d X_k`` (the linear coordinate
        of joint ``k``), ``dr_dang[:, k]`` is ``d r_k / d X_{k+3}`` (zero for ``radial``).
        """
        X = np.asarray(X, dtype=float)
        rx, ry, dlx, dly, dax, day = joint_components(ARRAY, self, list(X.T))

        def stack(cx: Sequence[Value], cy: Sequence[Value]) -> Array:
            return np.broadcast_to(np.stack([np.stack(cx, -1), np.stack(cy, -1)], -1), (X.shape[0], 3, 2))

        r, dlin = stack(rx, ry), stack(dlx, dly)
        return r, dlin, np.zeros_like(dlin) if dax is None or day is None else stack(dax, day)

    def closure(self, X: Array, L2: Array) -> tuple[Array, Array, Array]:
        """Residuals ``F (N, 3)``, Jacobian ``dF/dX (N, 3, M)`` and current side lengths ``(N, 3)``.

        ``dF_i/dX = 2 (r_b - r_a) . (d r_b/dX - d r_a/dX)`` for edge ``i = (a, b)`` (paper §V-B).
        """
        r, dlin, dang = self.points_and_partials(X)
        n = X.shape[0]
        J = np.zeros((n, 3, self.size))
        d2 = np.empty((n, 3))
        for i, (a, b) in enumerate(EDGES):  # three edges: a fixed, tiny loop, vectorised over N
            e = r[:, b] - r[:, a]
            d2[:, i] = np.einsum('nj,nj->n', e, e)
            J[:, i, b] = 2.0 * np.einsum('nj,nj->n', e, dlin[:, b])
            J[:, i, a] = -2.0 * np.einsum('nj,nj->n', e, dlin[:, a])
            if self.size == 6:
                J[:, i, 3 + b] = 2.0 * np.einsum('nj,nj->n', e, dang[:, b])
                J[:, i, 3 + a] = -2.0 * np.einsum('nj,nj->n', e, dang[:, a])
        return d2 - L2, J, np.sqrt(d2)


def model_name(config: GprConfig, model: str | None) -> str:
    """The name of the virtual-joint model ``model`` (None or '': ``config.model``), or :class:`InputError` naming
    what was given and what is allowed."""
    name = config.model if model is None or isinstance(model, str) and not model else model
    if not isinstance(name, str) or name not in MODELS:
        raise InputError(f"unknown virtual-joint model {brief(name)}; allowed: {', '.join(MODELS)}, or None or '' for "
                         f"the configuration's model ({config.model})")
    return name


def make_model(config: GprConfig, model: str | None = None,
               geometry: MachineGeometry | None = None) -> VirtualJointModel:
    """The virtual-joint model named ``model`` (default: ``config.model``) for ``config``'s geometry, or for
    ``geometry`` (one machine per row, :meth:`MachineGeometry.per_row`) when it is given."""
    name = model_name(config, model)
    if geometry is not None:
        angles = [np.arctan2(s, c) for s, c in zip(geometry.sin, geometry.cos, strict=True)]
        return VirtualJointModel(str(name), geometry.rho, (angles[0], angles[1], angles[2]), geometry.cos,
                                 geometry.sin, geometry.kappa)
    key = f'model:{name}'
    vjm: VirtualJointModel | None = config.derived.get(key)
    if vjm is None:
        geo = MachineGeometry.of(config)
        theta = (config.rod_azimuths if config.platform_joints is None
                 else tuple(float(np.arctan2(s, c)) for c, s in zip(geo.cos, geo.sin, strict=True)))
        vjm = config.derived[key] = VirtualJointModel(str(name), geo.rho, (theta[0], theta[1], theta[2]),
                                                      geo.cos, geo.sin, geo.kappa)
    return vjm


def angle_scale(config: GprConfig) -> float:
    """Length ``c`` that turns an angular virtual joint into a displacement in the step's metric:
    the characteristic length, or 1 (SI units) for the paper's ``unweighted`` form."""
    return config.characteristic_length if config.weighting == 'characteristic' else 1.0


def coordinate_scale(vjm: VirtualJointModel, config: GprConfig) -> Array:
    """Metric scales ``s`` of the coordinates (``|dX|^2 = sum (s_m dX_m)^2``): 1 for lengths,
    :func:`angle_scale` for angles; for ``compliant`` the square roots of the stiffnesses ``(1, kappa_k)``,
    so the norm is the elastic cost (``k_r = 1``)."""
    s = np.ones(vjm.size)
    if vjm.name == 'compliant':
        s[3:] = np.sqrt(np.asarray(vjm.kappa, dtype=float))
    else:
        s[vjm.angular] = angle_scale(config)
    return s


def angular_weight(config: GprConfig) -> float:
    """Weight ``w = s^-2`` of the angular coordinates in the step ``dX = -W J^T (J W J^T)^-1 F``."""
    w: float | None = config.derived.get('angular_weight')
    if w is None:
        w = config.derived['angular_weight'] = float(angle_scale(config) ** -2.0)
    return w


def joint_components(ops: Ops, vjm: VirtualJointModel, X: Sequence[Value]) -> Components:
    """Components of ``r_k(X)`` and of its partials, for kernels (arrays of shape ``(N,)`` or floats).

    Returns ``(rx, ry, dlx, dly, dax, day)``, lists over ``k``: ``(dlx, dly)[k] = d r_k / d X_k`` and
    ``(dax, day)[k] = d r_k / d X_{k+3}`` (``None`` for ``radial``).
    """
    c0, c1, c2 = vjm.cos
    s0, s1, s2 = vjm.sin
    l0, l1, l2 = X[0], X[1], X[2]
    if vjm.name == 'radial':
        return ([l0 * c0, l1 * c1, l2 * c2], [l0 * s0, l1 * s1, l2 * s2], [c0, c1, c2], [s0, s1, s2],
                None, None)
    if vjm.name == 'compliant':
        px = [r * c for r, c in zip(vjm.rho, vjm.cos, strict=True)]
        py = [r * s for r, s in zip(vjm.rho, vjm.sin, strict=True)]
        t0, t1, t2 = X[3], X[4], X[5]
        return ([px[0] + l0 * c0 - t0 * s0, px[1] + l1 * c1 - t1 * s1, px[2] + l2 * c2 - t2 * s2],
                [py[0] + l0 * s0 + t0 * c0, py[1] + l1 * s1 + t1 * c1, py[2] + l2 * s2 + t2 * c2],
                [c0, c1, c2], [s0, s1, s2], [-s0, -s1, -s2], [c0, c1, c2])
    th0, th1, th2 = vjm.theta
    cos, sin = ops.cos, ops.sin
    a0, a1, a2 = th0 + X[3], th1 + X[4], th2 + X[5]
    u0, u1, u2, v0, v1, v2 = cos(a0), cos(a1), cos(a2), sin(a0), sin(a1), sin(a2)
    rx = [l0 * u0, l1 * u1, l2 * u2]
    ry = [l0 * v0, l1 * v1, l2 * v2]
    if vjm.name == 'offset':
        R0, R1, R2 = vjm.rho
        rx = [rx[0] + R0 * c0, rx[1] + R1 * c1, rx[2] + R2 * c2]
        ry = [ry[0] + R0 * s0, ry[1] + R1 * s1, ry[2] + R2 * s2]
    return rx, ry, [u0, u1, u2], [v0, v1, v2], [-l0 * v0, -l1 * v1, -l2 * v2], [l0 * u0, l1 * u1, l2 * u2]


def side_errors(ops: Ops, comps: Components, L: Sequence[Value]) -> tuple[list[Value], Value]:
    """Side lengths ``d_i(X)`` and the closure error ``max_i |d_i - L_i|`` [m] from
    :func:`joint_components` (no Jacobian)."""
    (x0, x1, x2), (y0, y1, y2) = comps[0], comps[1]
    sqrt, fabs, maximum = ops.sqrt, ops.fabs, ops.maximum
    e0x, e0y, e1x, e1y, e2x, e2y = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x0 - x2, y0 - y2
    d = [sqrt(e0x * e0x + e0y * e0y), sqrt(e1x * e1x + e1y * e1y), sqrt(e2x * e2x + e2y * e2y)]
    return d, maximum(maximum(fabs(d[0] - L[0]), fabs(d[1] - L[1])), fabs(d[2] - L[2]))


def symmetric_solve3(g00: Value, g01: Value, g02: Value, g11: Value, g12: Value, g22: Value,
                     b0: Value, b1: Value, b2: Value) -> tuple[Value, Value, Value]:
    """``G^-1 b`` for the symmetric 3x3 ``G`` of the entries ``g_ij`` (i <= j), by its adjugate
    (component-wise: floats or arrays)."""
    c00, c11, c22 = g11 * g22 - g12 * g12, g00 * g22 - g02 * g02, g00 * g11 - g01 * g01
    c01, c02, c12 = g12 * g02 - g01 * g22, g01 * g12 - g11 * g02, g01 * g02 - g00 * g12
    inv_det = 1.0 / (g00 * c00 + g01 * c01 + g02 * c02)
    return ((c00 * b0 + c01 * b1 + c02 * b2) * inv_det, (c01 * b0 + c11 * b1 + c12 * b2) * inv_det,
            (c02 * b0 + c12 * b1 + c22 * b2) * inv_det)


class Closure(NamedTuple):
    """The solved virtual joints of one pose (floats) or of a batch (arrays ``(N,)``): ``X`` (list of ``M``
    components), their :func:`joint_components`, the side lengths ``d_i(X)`` [m], the iterations taken and
    the closure error ``max_i |d_i - L_i|`` [m]."""

    X: list[Value]
    components: Components
    side_lengths: list[Value]
    iterations: Count
    residual: Value


def not_converged(what: str, config: GprConfig, err: Value, active: Mask) -> ConvergenceError:
    """The error of a Newton loop that used up ``max_iterations``: the worst sample's error [m]
    (``err``, ``active``: a float and a bool for one pose, arrays for a batch, which name the sample)."""
    e = np.where(active, err, -1.0)
    i = int(np.argmax(e))   # NaN first: a step that was not finite
    where = '' if np.size(err) == 1 else f' for sample {i}'   # a batch of one as one pose
    return ConvergenceError(f'{what} did not converge in {config.max_iterations} iterations{where}: '
                            f'side-length error {float(np.max(e)):.3e} m > tolerance {config.tolerance:.1e} m',
                            i if isinstance(err, np.ndarray) else None, float(np.max(e)))

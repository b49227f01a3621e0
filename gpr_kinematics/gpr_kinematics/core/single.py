"""The one-pose kernels: forward kinematics of one configuration in plain float arithmetic, constants precomputed.

The batch kernels (:mod:`gpr_kinematics.core.closure`, :mod:`gpr_kinematics.core.platform_pose`, ...) run on arrays
or on floats through :class:`~gpr_kinematics.core.ops.Ops`; a single call through them pays for the generality (the
operations namespace, per-call constants, component lists). :class:`OnePose` holds what one call of
:func:`gpr_kinematics.core.forward` or :func:`gpr_kinematics.core.inverse` needs of a geometry and a virtual-joint
model, built once per ``(config, model)`` (:func:`one_pose`, cached on the config), and evaluates

1. the naive state of the rods (Bratovanov & Sotirov, Fig. 2; :func:`gpr_kinematics.core.naive.naive_state`),
2. the joint centres ``P_k = B_k + (q_k + o_k) u_k`` (eq. (1)) and the side lengths ``L_ij``,
3. the closure: the ``radial`` model's Newton loop (eq. (8)) with the side errors inline and the shared step
   :func:`~gpr_kinematics.core.closure.newton_terms`; the ``compliant`` model's minimum elastic cost
   (:func:`~gpr_kinematics.core.compliance.minimum_cost_floats`); ``polar`` and ``offset`` through the shared loop
   :func:`~gpr_kinematics.core.closure.newton_closure` on floats,

with the same floating-point operations in the same order as the batch drivers run them on floats, so a one-pose
result equals the old single call to the last bit (a test compares them over random, singular and limit poses);
against a batch row it differs only where numpy's ``sin``, ``cos``, ``atan2`` and ``hypot`` round differently from
the C library's (<= 1e-15 here, 1e-12 in the tests). Units: metres and radians.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import cast

from .closure import newton_closure
from .compliance import Stiffness, minimum_cost_floats, stiffness
from .config import GprConfig
from .floats import tilt_matrix_of_normal_one, tilt_of_normal_one
from .machine import Floats3, MachineGeometry
from .naive import NaiveState, leaning
from .ops import SCALAR
from .platform_pose import FitFloats
from .virtual_joints import Closure, Components, VirtualJointModel, make_model, model_name, not_converged, side_errors

#: Joint centres ``(x, y, z)``, each a list over the rods ``k`` [m].
Centres = tuple[list[float], list[float], list[float]]


class OnePose:
    """The constants of one ``(config, model)`` for one-pose kinematics (module docstring), and its kernels.

    Attributes:
        config, geometry, model: the configuration, its :class:`~gpr_kinematics.core.machine.MachineGeometry` and
            its :class:`~gpr_kinematics.core.virtual_joints.VirtualJointModel`.
        names: the names of the virtual joints. rod_direction: the first rod's direction ``u_1`` (floats).
        leaning: whether a rod leans (:func:`~gpr_kinematics.core.naive.leaning`).
    """

    __slots__ = ('config', 'geometry', 'model', 'names', '_rest', '_stiffness', '_directions', '_rest_xy', '_base',
                 '_radial_constants', '_naive_rods', 'rod_direction',
                 '_strokes', 'leaning')

    def __init__(self, config: GprConfig, vjm: VirtualJointModel) -> None:
        self.config, self.model, self.names = config, vjm, vjm.names
        geo = self.geometry = MachineGeometry.of(config)
        rho, cos, sin = cast('tuple[Floats3, Floats3, Floats3]', (vjm.rho, vjm.cos, vjm.sin))  # one machine
        self._directions = (list(cos), list(sin))
        self._rest_xy = tuple(r * c for r, c in zip(rho, cos, strict=True)) + tuple(
            r * s for r, s in zip(rho, sin, strict=True))
        # what each radial closure unpacks: directions, start, tolerance and iterations (one tuple, one unpacking)
        self._radial_constants = (*cos, *sin, *cast('Floats3', vjm.singular_floats), *self._rest_xy, config.tolerance,
                                  config.max_iterations)
        self._base = None if geo.upright else cast('tuple[Floats3, ...]', (geo.bx, geo.by, geo.ux, geo.uy, geo.uz,
                                                                          geo.offsets))
        self._strokes = tuple((s + o) * u for s in (config.stroke_min, config.stroke_max)   # height_range's
                              for o, u in zip(cast('Floats3', geo.offsets), cast('Floats3', geo.uz), strict=True))
        self.rod_direction = cast('Floats3', (geo.ux[0], geo.uy[0], geo.uz[0]))
        self.leaning = leaning(geo)   # forward_parts' naive tilt check: the plane of the joint centres
        self._naive_rods = cast('tuple[Floats3, Floats3, Floats3, Floats3]', (geo.px, geo.py, geo.uz, geo.offsets))
        self._stiffness: Stiffness | None = None
        self._rest: Closure | None = None
        if vjm.name == 'compliant':
            # every joint at its place p_k: the closure of every L within the tolerance of its side lengths
            self._stiffness, comps = stiffness(vjm), vjm.singular_components
            self._rest = Closure(list(vjm.singular_floats), comps, side_errors(SCALAR, comps, (0.0, 0.0, 0.0))[0], 0,
                                 0.0)

    def naive(self, q0: float, q1: float, q2: float) -> tuple[float, float, float, float, float]:
        """:func:`~gpr_kinematics.core.naive.naive_state` of the rods: ``(z, h2, nx, ny, nz)``."""
        geo = self.geometry  # one machine: float triples
        (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = cast('tuple[Floats3, Floats3, Floats3]', geo.naive_inv)
        (o0, o1, o2), (u0, u1, u2) = cast('tuple[Floats3, Floats3]', (geo.offsets, geo.uz))
        h0, h1, h2_ = (q0 + o0) * u0, (q1 + o1) * u1, (q2 + o2) * u2
        px = m10 * h0 + m11 * h1 + m12 * h2_
        py = m20 * h0 + m21 * h1 + m22 * h2_
        h2 = px * px + py * py
        a = 1.0 - h2
        return m00 * h0 + m01 * h1 + m02 * h2_, h2, -px, -py, math.sqrt(a if a >= 0.0 else 0.0)

    def naive_rods(self, h: float, n: Sequence[float], tool: Sequence[float]) -> list[float]:
        """:func:`~gpr_kinematics.core.naive.naive_rods` in floats (its operations): the naive model's rods for the
        tool point ``tool`` at the height ``h`` and the platform normal ``n``."""
        (px0, px1, px2), (py0, py1, py2), (u0, u1, u2), (o0, o1, o2) = self._naive_rods
        n0, n1, n2 = n
        t0, t1, t2 = tool
        return [(h - n0 * (px0 - t0) - n1 * (py0 - t1) - n2 * t2) / u0 - o0,
                (h - n0 * (px1 - t0) - n1 * (py1 - t1) - n2 * t2) / u1 - o1,
                (h - n0 * (px2 - t0) - n1 * (py2 - t1) - n2 * t2) / u2 - o2]

    def height_range(self, n: Sequence[float], tool: Sequence[float]) -> tuple[float, float]:
        """:func:`~gpr_kinematics.core.heights.height_range` in floats (its operations, its ``max`` a comparison): the
        tool point's heights [m] keeping the naive model's rods within the stroke for the platform normal ``n``."""
        (px0, px1, px2), (py0, py1, py2) = self._naive_rods[0], self._naive_rods[1]
        a0, a1, a2, b0, b1, b2 = self._strokes
        n0, n1, n2 = n
        t0, t1, t2 = tool
        c0 = n0 * (px0 - t0) + n1 * (py0 - t1) + n2 * t2
        c1 = n0 * (px1 - t0) + n1 * (py1 - t1) + n2 * t2
        c2 = n0 * (px2 - t0) + n1 * (py2 - t1) + n2 * t2
        lo, v = a0 + c0, a1 + c1
        lo = v if v > lo else lo
        v = a2 + c2
        lo = v if v > lo else lo
        hi, v = -(b0 + c0), -(b1 + c1)
        hi = v if v > hi else hi
        v = -(b2 + c2)
        return lo, -(v if v > hi else hi)

    def centres(self, q0: float, q1: float, q2: float) -> Centres:
        """Joint centres ``P_k = B_k + (q_k + o_k) u_k`` (eq. (1); on parallel rods without offsets ``(B_k, q_k)``)."""
        if self._base is None:
            geo = self.geometry
            return cast('list[float]', list(geo.bx)), cast('list[float]', list(geo.by)), [q0, q1, q2]
        (bx0, bx1, bx2), (by0, by1, by2), (ux0, ux1, ux2), (uy0, uy1, uy2), (uz0, uz1, uz2), off = self._base
        s0, s1, s2 = q0 + off[0], q1 + off[1], q2 + off[2]
        return ([bx0 + s0 * ux0, bx1 + s1 * ux1, bx2 + s2 * ux2], [by0 + s0 * uy0, by1 + s1 * uy1, by2 + s2 * uy2],
                [s0 * uz0, s1 * uz1, s2 * uz2])

    @staticmethod
    def lengths(P: Centres) -> tuple[float, float, float]:
        """Side lengths ``L12, L23, L31`` of the joint centres [m]."""
        (x0, x1, x2), (y0, y1, y2), (z0, z1, z2) = P
        ax, ay, az, bx, by, bz = x1 - x0, y1 - y0, z1 - z0, x2 - x1, y2 - y1, z2 - z1
        cx, cy, cz = x0 - x2, y0 - y2, z0 - z2
        return (math.sqrt(ax * ax + ay * ay + az * az), math.sqrt(bx * bx + by * by + bz * bz),
                math.sqrt(cx * cx + cy * cy + cz * cz))

    def closure(self, L0: float, L1: float, L2: float) -> Closure:
        """The solved virtual joints of side lengths ``L`` (module docstring, step 3)."""
        vjm = self.model
        if vjm.name == 'radial':
            return self._radial(L0, L1, L2)
        if self._stiffness is not None and self._rest is not None:
            return minimum_cost_floats(vjm, self._stiffness, self._rest, L0, L1, L2, self.config)
        return newton_closure(SCALAR, vjm, [L0, L1, L2], self.config)

    def _radial(self, L0: float, L1: float, L2: float) -> Closure:
        """:func:`~gpr_kinematics.core.closure.newton_closure` of the ``radial`` model: ``X = (l1, l2, l3)``, the
        joints ``r_k = l_k (cos theta_k, sin theta_k)``, from ``l = rho``; stops at a side error <= tolerance."""
        sqrt = math.sqrt
        c0, c1, c2, s0, s1, s2, l0, l1, l2, x0, x1, x2, y0, y1, y2, tol, most = self._radial_constants
        iterations = 0
        while True:
            e0x, e0y, e1x, e1y, e2x, e2y = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x0 - x2, y0 - y2
            f0, f1, f2 = e0x * e0x + e0y * e0y, e1x * e1x + e1y * e1y, e2x * e2x + e2y * e2y
            d0, d1, d2 = sqrt(f0), sqrt(f1), sqrt(f2)
            err = max(max(abs(d0 - L0), abs(d1 - L1)), abs(d2 - L2))
            if err <= tol:
                C, S = self._directions
                return Closure([l0, l1, l2], ([x0, x1, x2], [y0, y1, y2], C, S, None, None), [d0, d1, d2], iterations,
                               err)
            if iterations == most:
                raise not_converged('virtual-joint closure (radial)', self.config, err, True)
            # newton_terms with the radial partials d r_k / d l_k = (cos theta_k, sin theta_k), inline:
            # b (a): the derivative of edge i's residual by the coordinate of its end (start) joint
            b0, a0 = 2.0 * (e0x * c1 + e0y * s1), -2.0 * (e0x * c0 + e0y * s0)
            b1, a1 = 2.0 * (e1x * c2 + e1y * s2), -2.0 * (e1x * c1 + e1y * s1)
            b2, a2 = 2.0 * (e2x * c0 + e2y * s0), -2.0 * (e2x * c2 + e2y * s2)
            # symmetric_solve3 of the normal equations, inline (its operations in its order)
            g00, g01, g02, g11, g12 = b0 * b0 + a0 * a0, b0 * a1, b2 * a0, b1 * b1 + a1 * a1, b1 * a2
            g22 = b2 * b2 + a2 * a2
            r0, r1, r2 = f0 - L0 * L0, f1 - L1 * L1, f2 - L2 * L2
            k00, k11, k22 = g11 * g22 - g12 * g12, g00 * g22 - g02 * g02, g00 * g11 - g01 * g01
            k01, k02, k12 = g12 * g02 - g01 * g22, g01 * g12 - g11 * g02, g01 * g02 - g00 * g12
            inv_det = 1.0 / (g00 * k00 + g01 * k01 + g02 * k02)
            w0, w1, w2 = ((k00 * r0 + k01 * r1 + k02 * r2) * inv_det, (k01 * r0 + k11 * r1 + k12 * r2) * inv_det,
                          (k02 * r0 + k12 * r1 + k22 * r2) * inv_det)
            l0, l1, l2 = l0 - (b2 * w2 + a0 * w0), l1 - (b0 * w0 + a1 * w1), l2 - (b1 * w1 + a2 * w2)
            iterations += 1
            x0, x1, x2, y0, y1, y2 = l0 * c0, l1 * c1, l2 * c2, l0 * s0, l1 * s1, l2 * s2

    def radial_rods(self, q_target: list[float], h: float, n: Sequence[float], tool: Sequence[float], tol_h: float,
                    tol_n: float) -> tuple[list[float], Centres, tuple[float, float, float], Closure, FitFloats, int,
                                           FitFloats, float | None]:
        """The loop of :func:`~gpr_kinematics.core.inverse.inverse_parts` under the ``radial`` model, fused: each step
        :meth:`centres`, :meth:`lengths`, :meth:`_radial`, :meth:`fit` and :meth:`naive_rods` with their operations
        in their order (the same numbers), their objects built for the last step only. From the rods ``q_target``
        [m] on, towards the tool point ``tool``'s height ``h`` [m] and normal ``n`` within ``tol_h``, ``tol_n``.
        Returns the rods, of the last step the centres, side lengths, closure and fit and its index, the first step's
        fit, and where the last step did not converge its error (else ``None``)."""
        sqrt = math.sqrt
        c0, c1, c2, s0, s1, s2, r0_, r1_, r2_, a0_, a1_, a2_, b0_, b1_, b2_, tol, most = self._radial_constants
        ntol = -tol
        (px0, px1, px2), (py0, py1, py2), (u0, u1, u2), (o0, o1, o2) = self._naive_rods
        upright = self._base is None
        if upright:
            geo = self.geometry
            X0, X1, X2 = cast('Floats3', geo.bx)
            Y0, Y1, Y2 = cast('Floats3', geo.by)
        else:
            (bx0, bx1, bx2), (by0, by1, by2), (ux0, ux1, ux2), (uy0, uy1, uy2), (uz0, uz1, uz2), off = \
                cast('tuple[Floats3, ...]', self._base)
        t0, t1, t2 = tool
        n0, n1, n2 = n
        q0, q1, q2 = q_target
        first: FitFloats | None = None
        steps = self.config.max_iterations
        for step in range(steps + 1):
            if upright:
                Z0, Z1, Z2 = q0, q1, q2
            else:
                w0, w1, w2 = q0 + off[0], q1 + off[1], q2 + off[2]
                X0, X1, X2 = bx0 + w0 * ux0, bx1 + w1 * ux1, bx2 + w2 * ux2
                Y0, Y1, Y2 = by0 + w0 * uy0, by1 + w1 * uy1, by2 + w2 * uy2
                Z0, Z1, Z2 = w0 * uz0, w1 * uz1, w2 * uz2
            ax, ay, az = X1 - X0, Y1 - Y0, Z1 - Z0   # at most three names an assignment: no tuple built
            bx, by, bz = X2 - X1, Y2 - Y1, Z2 - Z1
            cx, cy, cz = X0 - X2, Y0 - Y2, Z0 - Z2
            L0, L1, L2 = (sqrt(ax * ax + ay * ay + az * az), sqrt(bx * bx + by * by + bz * bz),
                          sqrt(cx * cx + cy * cy + cz * cz))
            LL0, LL1, LL2 = L0 * L0, L1 * L1, L2 * L2   # each pass's, once
            l0, l1, l2 = r0_, r1_, r2_
            x0, x1, x2 = a0_, a1_, a2_
            y0, y1, y2 = b0_, b1_, b2_
            iterations = 0
            while True:   # _radial
                e0x, e0y, e1x = x1 - x0, y1 - y0, x2 - x1
                e1y, e2x, e2y = y2 - y1, x0 - x2, y0 - y2
                f0, f1, f2 = e0x * e0x + e0y * e0y, e1x * e1x + e1y * e1y, e2x * e2x + e2y * e2y
                d0, d1, d2 = sqrt(f0), sqrt(f1), sqrt(f2)
                m0, m1, m2 = d0 - L0, d1 - L1, d2 - L2
                # a side beyond the tolerance: the error (their largest) is too (no abs and max per pass); else, or
                # where they are NaN, the error as _radial takes it
                if not (m0 > tol or m0 < ntol or m1 > tol or m1 < ntol or m2 > tol or m2 < ntol) or iterations == most:
                    err, e = abs(m0), abs(m1)
                    err = e if e > err else err
                    e = abs(m2)
                    err = e if e > err else err
                    if err <= tol:
                        break
                    if iterations == most:
                        raise not_converged('virtual-joint closure (radial)', self.config, err, True)
                b0, a0 = 2.0 * (e0x * c1 + e0y * s1), -2.0 * (e0x * c0 + e0y * s0)
                b1, a1 = 2.0 * (e1x * c2 + e1y * s2), -2.0 * (e1x * c1 + e1y * s1)
                b2, a2 = 2.0 * (e2x * c0 + e2y * s0), -2.0 * (e2x * c2 + e2y * s2)
                g00, g01, g02 = b0 * b0 + a0 * a0, b0 * a1, b2 * a0
                g11, g12, g22 = b1 * b1 + a1 * a1, b1 * a2, b2 * b2 + a2 * a2
                h0, h1, h2 = f0 - LL0, f1 - LL1, f2 - LL2
                k00, k11, k22 = g11 * g22 - g12 * g12, g00 * g22 - g02 * g02, g00 * g11 - g01 * g01
                k01, k02, k12 = g12 * g02 - g01 * g22, g01 * g12 - g11 * g02, g01 * g02 - g00 * g12
                inv_det = 1.0 / (g00 * k00 + g01 * k01 + g02 * k02)
                v0, v1, v2 = ((k00 * h0 + k01 * h1 + k02 * h2) * inv_det, (k01 * h0 + k11 * h1 + k12 * h2) * inv_det,
                              (k02 * h0 + k12 * h1 + k22 * h2) * inv_det)
                l0, l1, l2 = l0 - (b2 * v2 + a0 * v0), l1 - (b0 * v0 + a1 * v1), l2 - (b1 * v1 + a2 * v2)
                iterations += 1
                x0, x1, x2 = l0 * c0, l1 * c1, l2 * c2
                y0, y1, y2 = l0 * s0, l1 * s1, l2 * s2
            # fit, its operations (P the centres, the components x, y)
            ux, uy, uz = X1 - X0, Y1 - Y0, Z1 - Z0
            vx, vy, vz = X2 - X0, Y2 - Y0, Z2 - Z0
            inv = 1.0 / sqrt(ux * ux + uy * uy + uz * uz)
            e1x, e1y, e1z = ux * inv, uy * inv, uz * inv
            cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            inv = 1.0 / sqrt(cx * cx + cy * cy + cz * cz)
            e3x, e3y, e3z = cx * inv, cy * inv, cz * inv
            e2x, e2y, e2z = e3y * e1z - e3z * e1y, e3z * e1x - e3x * e1z, e3x * e1y - e3y * e1x
            wx, wy = x1 - x0, y1 - y0
            inv = 1.0 / sqrt(wx * wx + wy * wy)
            fx, fy = wx * inv, wy * inv
            sg = 1.0 if wx * (y2 - y0) - wy * (x2 - x0) >= 0.0 else -1.0
            sfx, sfy = sg * fx, sg * fy
            r00, r01, r02 = e1x * fx - e2x * sfy, e1x * fy + e2x * sfx, sg * e3x
            r10, r11, r12 = e1y * fx - e2y * sfy, e1y * fy + e2y * sfx, sg * e3y
            r20, r21, r22 = e1z * fx - e2z * sfy, e1z * fy + e2z * sfx, sg * e3z
            rcx, rcy = (x0 + x1 + x2) / 3.0, (y0 + y1 + y2) / 3.0
            tz = (Z0 + Z1 + Z2) / 3.0 - (r20 * rcx + r21 * rcy)
            frame = (r00, r01, r02, r10, r11, r12, r20, r21, r22, (X0 + X1 + X2) / 3.0 - (r00 * rcx + r01 * rcy),
                     (Y0 + Y1 + Y2) / 3.0 - (r10 * rcx + r11 * rcy), tz)
            if first is None:
                first = frame
            h_now = tz + r20 * t0 + r21 * t1 + r22 * t2
            m0, m1, m2, m3 = h_now - h, r02 - n0, r12 - n1, r22 - n2
            if not (m0 > tol_h or m0 < -tol_h or m1 > tol_n or m1 < -tol_n or m2 > tol_n or m2 < -tol_n or m3 > tol_n
                    or m3 < -tol_n) or step == steps:   # converged or the last step, else surely not (as above)
                err_h, err_n = abs(m0), abs(m1)
                e = abs(m2)
                err_n = e if e > err_n else err_n
                e = abs(m3)
                err_n = e if e > err_n else err_n
                last = not (err_h <= tol_h and err_n <= tol_n)
                if not last or step == steps:
                    break
            q0, q1, q2 = (q0 + q_target[0] - ((h_now - r02 * (px0 - t0) - r12 * (py0 - t1) - r22 * t2) / u0 - o0),
                          q1 + q_target[1] - ((h_now - r02 * (px1 - t0) - r12 * (py1 - t1) - r22 * t2) / u1 - o1),
                          q2 + q_target[2] - ((h_now - r02 * (px2 - t0) - r12 * (py2 - t1) - r22 * t2) / u2 - o2))
        C, S = self._directions
        closure = Closure([l0, l1, l2], ([x0, x1, x2], [y0, y1, y2], C, S, None, None), [d0, d1, d2], iterations, err)
        return ([q0, q1, q2], ([X0, X1, X2], [Y0, Y1, Y2], [Z0, Z1, Z2]), (L0, L1, L2), closure, frame, step,
                cast('FitFloats', first), (err_n if err_n > err_h else err_h) if last else None)

    @staticmethod
    def fit(P: Centres, comps: Components) -> FitFloats:
        """:func:`~gpr_kinematics.core.platform_pose.rigid_fit` of one pose in floats, its operations in its order
        (``ops.where`` a conditional, without the generic kernel's calls): the rigid transform of the platform joints
        ``comps`` onto the joint centres ``P``, ``(r00, r01, .., r22, tx, ty, tz)``."""
        sqrt = math.sqrt
        (rx0, rx1, rx2), (ry0, ry1, ry2) = cast('tuple[Floats3, Floats3]', (comps[0], comps[1]))
        (bx0, bx1, bx2), (by0, by1, by2), (bz0, bz1, bz2) = P
        ux, uy, uz = bx1 - bx0, by1 - by0, bz1 - bz0
        vx, vy, vz = bx2 - bx0, by2 - by0, bz2 - bz0
        inv = 1.0 / sqrt(ux * ux + uy * uy + uz * uz)
        e1x, e1y, e1z = ux * inv, uy * inv, uz * inv
        cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        inv = 1.0 / sqrt(cx * cx + cy * cy + cz * cz)
        e3x, e3y, e3z = cx * inv, cy * inv, cz * inv
        e2x, e2y, e2z = e3y * e1z - e3z * e1y, e3z * e1x - e3x * e1z, e3x * e1y - e3y * e1x
        wx, wy = rx1 - rx0, ry1 - ry0
        inv = 1.0 / sqrt(wx * wx + wy * wy)
        fx, fy = wx * inv, wy * inv
        sg = 1.0 if wx * (ry2 - ry0) - wy * (rx2 - rx0) >= 0.0 else -1.0
        sfx, sfy = sg * fx, sg * fy
        r00, r01, r02 = e1x * fx - e2x * sfy, e1x * fy + e2x * sfx, sg * e3x
        r10, r11, r12 = e1y * fx - e2y * sfy, e1y * fy + e2y * sfx, sg * e3y
        r20, r21, r22 = e1z * fx - e2z * sfy, e1z * fy + e2z * sfx, sg * e3z
        rcx, rcy = (rx0 + rx1 + rx2) / 3.0, (ry0 + ry1 + ry2) / 3.0
        return (r00, r01, r02, r10, r11, r12, r20, r21, r22, (bx0 + bx1 + bx2) / 3.0 - (r00 * rcx + r01 * rcy),
                (by0 + by1 + by2) / 3.0 - (r10 * rcx + r11 * rcy), (bz0 + bz1 + bz2) / 3.0 - (r20 * rcx + r21 * rcy))

    def pose_values(self, q: Sequence[float], P: Centres, L: Sequence[float], closure: Closure, frame: FitFloats,
                    naive: NaiveState | None) -> tuple[list[float], float, float, float, float, bool]:
        """The pose of one solved configuration (:func:`~gpr_kinematics.core.forward.one_result`'s values):
        :func:`~gpr_kinematics.core.platform_pose.platform_pose` from the rigid fit ``frame`` on, with its operations,
        and :func:`~gpr_kinematics.core.forward.assemble`, fused. Returns the vector fields' values in one list (``q``,
        the side lengths, position, rotation, quaternion, the nominal position, rotation and quaternion, the centre
        shift, the joint displacements, the virtual joints), the tilt, azimuth and twist [rad], the fit residual [m]
        and whether the joints are within the imperfection budget. ``naive``: the naive state of ``q`` if known."""
        sqrt = math.sqrt
        r00, r01, r02, r10, r11, r12, r20, r21, r22, tx, ty, tz = frame
        (x0, x1, x2), (y0, y1, y2) = closure.components[0], closure.components[1]
        (X0, X1, X2), (Y0, Y1, Y2), (Z0, Z1, Z2) = P
        dx, dy, dz = r00 * x0 + r01 * y0 + tx - X0, r10 * x0 + r11 * y0 + ty - Y0, r20 * x0 + r21 * y0 + tz - Z0
        fit = sqrt(dx * dx + dy * dy + dz * dz)
        dx, dy, dz = r00 * x1 + r01 * y1 + tx - X1, r10 * x1 + r11 * y1 + ty - Y1, r20 * x1 + r21 * y1 + tz - Z1
        fit = max(fit, sqrt(dx * dx + dy * dy + dz * dz))
        dx, dy, dz = r00 * x2 + r01 * y2 + tx - X2, r10 * x2 + r11 * y2 + ty - Y2, r20 * x2 + r21 * y2 + tz - Z2
        fit = max(fit, sqrt(dx * dx + dy * dy + dz * dz))
        tilt, az = tilt_of_normal_one(r02, r12, r22)
        (t00, t01, _), (t10, t11, _), (t20, t21, _) = tilt_matrix_of_normal_one(r02, r12, r22)
        w4 = 2.0 * sqrt(1.0 + r00 + r11 + r22)
        qx, qy, qz, qw = (r21 - r12) / w4, (r02 - r20) / w4, (r10 - r01) / w4, 0.25 * w4
        inv = 1.0 / sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
        z, _, nx, ny, nz = cast('tuple[float, ...]', self.naive(q[0], q[1], q[2]) if naive is None else naive)
        (n00, n01, n02), (n10, n11, n12), (n20, n21, n22) = tilt_matrix_of_normal_one(nx, ny, nz)
        cw = sqrt(0.5 * (1.0 + nz))  # the naive tilt's quaternion (a sin(t/2), 0, cos(t/2))
        half, zero = 0.5 / cw, 0.0 * z
        geo = self.geometry
        px, py = geo.px, geo.py
        jd0, jd1, jd2 = (sqrt((x0 - px[0]) * (x0 - px[0]) + (y0 - py[0]) * (y0 - py[0])),
                         sqrt((x1 - px[1]) * (x1 - px[1]) + (y1 - py[1]) * (y1 - py[1])),
                         sqrt((x2 - px[2]) * (x2 - px[2]) + (y2 - py[2]) * (y2 - py[2])))
        return ([*q, *L, tx, ty, tz, r00, r01, r02, r10, r11, r12, r20, r21, r22, qx * inv, qy * inv, qz * inv,
                 qw * inv, zero, zero, z, n00, n01, n02, n10, n11, n12, n20, n21, n22, -n12 * half, n02 * half,
                 0.0 * cw, cw, tx - zero, ty - zero, tz - z, jd0, jd1, jd2, *cast('list[float]', closure.X)], tilt, az,
                math.atan2(t01 * r00 + t11 * r10 + t21 * r20, t00 * r00 + t10 * r10 + t20 * r20), fit,
                max(max(jd0, jd1), jd2) <= self.config.imperfection_budget)


def one_pose(config: GprConfig, model: str | None = None) -> OnePose:
    """The :class:`OnePose` of ``config`` under ``model`` (default: ``config.model``), built once and kept with the
    config."""
    key = f'one_pose:{model_name(config, model)}'
    kernel: OnePose | None = config.derived.get(key)
    if kernel is None:
        kernel = config.derived[key] = OnePose(config, make_model(config, model))
    return kernel


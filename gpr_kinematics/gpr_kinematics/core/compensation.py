"""Compensation for offline programming: from a naively commanded platform pose to what to command.

The old offline tool (Bratovanov & Sotirov, Fig. 2) commands the platform as if it rotated about its
centre ``(0, 0, z)``. The real GPR cannot do that: its platform centre shifts when it tilts (paper §III)
and its heading and horizontal position are outcomes, not inputs; the arm on the platform, whose joint axes
are parallel to the platform normal, makes up for them by a *planar* motion (in the platform plane and about
its normal), never along the normal. Given the naive command ``T_c = (p_c, R_c)`` with
``R_c = tilt_rotation(tilt, azimuth) Rz(heading)`` and a tool point ``x_tool`` of the platform
(``gpr_platform`` frame), compensation returns

* the rod lengths ``q`` that give the commanded *tilt* (the tilt part of ``R_c``, ``docs/core.md``) and put
  **the platform point the command puts at the commanded place** at the commanded height
  ``(p_c + R_c x_tool)_z``, solved under the virtual-joint model (:func:`gpr_kinematics.core.inverse`).
  That point is ``platform_point = Rz(heading) x_tool``: the command turns the platform by the heading, which
  the GPR cannot do, so the arm makes that turn, and the tool must be at the commanded height on the platform
  as it really is, untwisted. Without a heading it is ``x_tool``: a user without an arm gets the tool point at
  the commanded height. (Solving for ``x_tool`` whatever the heading left the arm a correction along the
  platform normal that a planar arm cannot make, -106 um for 0.4 m, 1.5 deg about the axis at 40 deg, tool
  (0.3, 0, 0.1) m, heading 1 deg.) What remains along the normal is the tilt times the centre shift, which the
  naive command ignores: ``-n . (t_xy, 0)``, at most ``sin(tilt) |centre shift|``, 1 um at 2 deg
  (0.36 um in that example), for a command at the naive centre's ``x = y = 0``; a command off it adds
  ``n . (p_c,x, p_c,y, 0)`` (0.35 mm for 10 mm at 2 deg), which no planar arm makes either; ``x``, ``y`` beyond
  :data:`~gpr_kinematics.core.inverse.TOOL_REACH` are refused;
* the pose ``T_a = (t, R)`` actually reached (forward kinematics of ``q``);
* the tool point's residual shift ``T_a x_tool - T_c x_tool`` in ``gpr_base`` (the centre shift plus the
  commanded heading, which the arm makes; horizontal when the heading is zero);
* the *arm correction* ``C = T_a^-1 T_c``, a transform in ``gpr_platform``: a target the program gave in
  the platform frame of the naive model, ``x``, is reached by commanding the arm on the real platform to
  ``C x`` (so that ``T_a C x = T_c x``): a rotation about the platform normal by the heading and a translation
  in the platform plane up to the normal part above.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import LimitError, norm_text
from ..inputs.validation import finite_vector, rows_of, unit_quaternion
from . import ForwardResult, inverse
from .config import GprConfig, resolve_config
from .floats import Mat3, Quat, Vec3, mat_tmul, mat_tvec, mat_vec, matrix_of, quaternion_of, tilt_matrix
from .forward import beyond_tilt
from .inverse import TOOL_REACH, check_tool_point, tilt_target_slack
from .ops import SCALAR
from .rotations import RigidTransform, tilt_of_normal

Array = NDArray[np.float64]


@dataclass(frozen=True)
class CompensationResult:
    """Result of :func:`compensate` (SI units, quaternions x, y, z, w).

    Attributes:
        q: rod lengths to command [m].
        achieved: forward kinematics of ``q``: the pose the platform really takes.
        command_tilt, command_azimuth, command_twist: decomposition of the commanded orientation [rad];
            the twist (heading) cannot be realised by the GPR and is left to ``arm_correction``.
        tool_offset: the tool point in ``gpr_platform`` [m].
        tool_commanded, tool_achieved: the tool point in ``gpr_base`` under the command and in reality [m].
        tool_shift: ``tool_achieved - tool_commanded`` [m].
        platform_point: the platform point put at the commanded height, ``Rz(heading) x_tool`` (``gpr_platform``)
            [m]: the point the command puts at the commanded place.
        arm_correction: ``C = T_a^-1 T_c`` (translation [m] and quaternion, in ``gpr_platform``).
        iterations: inverse-kinematics Newton steps.
    """

    q: Array
    achieved: ForwardResult
    command_tilt: float
    command_azimuth: float
    command_twist: float
    tool_offset: Array
    tool_commanded: Array
    tool_achieved: Array
    tool_shift: Array
    platform_point: Array
    arm_correction: RigidTransform
    iterations: int

    @property
    def arm_correction_rotation(self) -> Array:
        """Rotation of :attr:`arm_correction` (3 x 3)."""
        return self.arm_correction.rotation

    @property
    def arm_correction_quaternion(self) -> Array:
        """Quaternion (x, y, z, w) of :attr:`arm_correction`."""
        return self.arm_correction.quaternion

    @property
    def arm_correction_translation(self) -> Array:
        """Translation of :attr:`arm_correction` [m]."""
        return self.arm_correction.translation

    def correct(self, points: ArrayLike) -> Array:
        """Apply the arm correction to targets ``(N, 3)`` or one ``(3,)`` [m] given in the naive platform frame
        (finite numbers, else :class:`~gpr_kinematics.errors.InputError`)."""
        rows = rows_of(points, 'points', 3)
        out: Array = self.arm_correction.apply(rows)
        return out[0] if np.ndim(points) == 1 else out


class CompensationFloats(NamedTuple):
    """:func:`compensate` of one command in floats (the fields of :class:`CompensationResult`, the arm correction as
    its ``translation`` [m] and ``quaternion`` (x, y, z, w))."""

    q: list[float]
    achieved: ForwardResult
    command_tilt: float
    command_azimuth: float
    command_twist: float
    tool_commanded: Vec3
    tool_achieved: Vec3
    tool_shift: Vec3
    platform_point: Vec3
    translation: Vec3
    quaternion: Quat
    iterations: int


def compensate(position: ArrayLike, quaternion: ArrayLike, tool_offset: ArrayLike = (0.0, 0.0, 0.0),
               config: GprConfig | None = None, model: str | None = None) -> CompensationResult:
    """Actuator commands and arm correction for a naively commanded platform pose (module docstring).

    Args:
        position: commanded platform origin in ``gpr_base`` [m] (only the tool point's height is honoured).
        quaternion: commanded platform orientation (x, y, z, w), unit norm (within 1e-6).
        tool_offset: tool point in ``gpr_platform`` [m].

    Raises:
        InputError: NaN, infinity, wrong sizes, a non-unit quaternion.
        LimitError: a commanded tilt beyond the tilt limit, a tool point beyond
            :data:`~gpr_kinematics.core.inverse.TOOL_REACH`, or rod lengths outside the stroke.
    """
    p_c = finite_vector(position, 'position', 3)
    quat = unit_quaternion(quaternion, 'quaternion')
    tool = finite_vector(tool_offset, 'tool_offset', 3)
    x, y, z, w = quat.tolist()
    one = compensate_one(cast('Vec3', tuple(p_c.tolist())), (x, y, z, w), cast('Vec3', tuple(tool.tolist())),
                         resolve_config(config), model)
    return CompensationResult(
        q=np.array(one.q), achieved=one.achieved, command_tilt=one.command_tilt,
        command_azimuth=one.command_azimuth, command_twist=one.command_twist, tool_offset=tool,
        tool_commanded=np.array(one.tool_commanded), tool_achieved=np.array(one.tool_achieved),
        tool_shift=np.array(one.tool_shift), platform_point=np.array(one.platform_point),
        arm_correction=RigidTransform(translation=np.array(one.translation), quaternion=np.array(one.quaternion)),
        iterations=one.iterations)


def compensate_one(p_c: Vec3, quat: Quat, tool: Vec3, cfg: GprConfig, model: str | None = None) -> CompensationFloats:
    """:func:`compensate` in float arithmetic for a finite command position ``p_c`` [m], a unit quaternion ``quat``
    and a finite tool point ``tool`` [m] (the caller checks them; the limits are checked here)."""
    check_tool_point(tool, 'tool_offset')
    if math.hypot(p_c[0], p_c[1]) > TOOL_REACH:   # 1.7e308 m came back as an arm correction, success
        far, reach = norm_text((p_c[0], p_c[1]), TOOL_REACH)
        raise LimitError(f'commanded position x, y = ({p_c[0]:.6g}, {p_c[1]:.6g}) m, {far} m from the GPR axis: the '
                         'platform does not move horizontally (the naive model\'s centre is at x = y = 0) and the arm '
                         f'makes up the rest; allowed: within {reach} m of the GPR axis')
    R_c = matrix_of(quat)
    tilt, az = cast('tuple[float, float]', tilt_of_normal(SCALAR, R_c[0][2], R_c[1][2], R_c[2][2]))
    M = mat_tmul(tilt_matrix(tilt, az), R_c)
    twist = math.atan2(M[1][0], M[0][0])
    if tilt - cfg.tilt_limit > tilt_target_slack(cfg):   # inverse kinematics' rule: 2 deg at 45 deg is a few ulps over
        raise LimitError(f'commanded tilt {beyond_tilt(tilt, cfg.tilt_limit, "a commanded tilt")}')
    a = mat_vec(R_c, tool)
    commanded = (p_c[0] + a[0], p_c[1] + a[1], p_c[2] + a[2])
    c, sn = math.cos(twist), math.sin(twist)
    point = (c * tool[0] - sn * tool[1], sn * tool[0] + c * tool[1], tool[2])
    ik = inverse(commanded[2], tilt, az, cfg, model, point)
    fk = ik.achieved
    (r0, r1, r2), (t0, t1, t2) = fk.rotation.tolist(), fk.position.tolist()
    R: Mat3 = ((r0[0], r0[1], r0[2]), (r1[0], r1[1], r1[2]), (r2[0], r2[1], r2[2]))
    b = mat_vec(R, tool)
    achieved = (t0 + b[0], t1 + b[1], t2 + b[2])
    return CompensationFloats(
        ik.q.tolist(), fk, tilt, az, twist, commanded, achieved,
        (achieved[0] - commanded[0], achieved[1] - commanded[1], achieved[2] - commanded[2]), point,
        mat_tvec(R, (p_c[0] - t0, p_c[1] - t1, p_c[2] - t2)), quaternion_of(mat_tmul(R, R_c)), ik.iterations)

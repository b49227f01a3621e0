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
  (0.36 um in that example);
* the pose ``T_a = (t, R)`` actually reached (forward kinematics of ``q``);
* the tool point's residual shift ``T_a x_tool - T_c x_tool`` in ``gpr_base`` (the centre shift plus the
  commanded heading, which the arm makes; horizontal when the heading is zero);
* the *arm correction* ``C = T_a^-1 T_c``, a transform in ``gpr_platform``: a target the program gave in
  the platform frame of the naive model, ``x``, is reached by commanding the arm on the real platform to
  ``C x`` (so that ``T_a C x = T_c x``): a rotation about the platform normal by the heading and a translation
  in the platform plane up to the normal part above.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import LimitError
from ..inputs.validation import finite_vector, unit_quaternion
from . import ForwardResult, inverse
from .config import GprConfig, resolve_config
from .inverse import check_tool
from .rotations import RigidTransform, matrix_from_quaternion, quaternion_from_matrix, tilt_from_matrix

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
        """Apply the arm correction to targets ``(..., 3)`` given in the naive platform frame."""
        return self.arm_correction.apply(points)


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
    cfg = resolve_config(config)
    p_c = finite_vector(position, 'position', 3)
    quat = unit_quaternion(quaternion, 'quaternion')
    tool = finite_vector(tool_offset, 'tool_offset', 3)
    check_tool(tool, 'tool_offset')
    R_c = matrix_from_quaternion(quat)
    tilt, az, twist = (float(v) for v in tilt_from_matrix(R_c))
    if tilt > cfg.tilt_limit:
        raise LimitError(f'commanded tilt {tilt:.9g} rad ({np.degrees(tilt):.6g} deg) is beyond the tilt '
                         f'limit {cfg.tilt_limit:.9g} rad ({np.degrees(cfg.tilt_limit):.6g} deg)')
    tool_commanded = p_c + R_c @ tool
    c, sn = np.cos(twist), np.sin(twist)
    point = np.array([c * tool[0] - sn * tool[1], sn * tool[0] + c * tool[1], tool[2]])
    ik = inverse(float(tool_commanded[2]), tilt, az, config=cfg, model=model, tool=point)
    fk = ik.achieved
    tool_achieved = fk.position + fk.rotation @ tool
    C = fk.rotation.T @ R_c
    return CompensationResult(
        q=ik.q, achieved=fk, command_tilt=tilt, command_azimuth=az, command_twist=twist,
        tool_offset=tool, tool_commanded=tool_commanded, tool_achieved=tool_achieved,
        tool_shift=tool_achieved - tool_commanded, platform_point=point,
        arm_correction=RigidTransform(translation=fk.rotation.T @ (p_c - fk.position),
                                      quaternion=quaternion_from_matrix(C)),
        iterations=ik.iterations)

"""The platform services of ``kinematics_node``: request -> the core's one-pose path -> response (docs/ros.md).

- ``gpr/forward_kinematics`` (ForwardKinematics): rod lengths -> platform pose (core
  :func:`~gpr_kinematics.core.forward`);
- ``gpr/inverse_kinematics`` (InverseKinematics): height and tilt of ``target`` -> rod lengths (core
  :func:`~gpr_kinematics.core.inverse`; the tilt and tilt azimuth come from ``target.orientation`` through
  ``R = tilt_rotation(tilt, azimuth) Rz(twist)``, the twist is an outcome);
- ``gpr/compensate`` (Compensate): naive command pose + tool offset -> rod lengths, reached pose, tool shift and arm
  correction (core :func:`~gpr_kinematics.core.compensation.compensate_one`);
- ``gpr/analyze_mobility`` (AnalyzeMobility): ranks, singular values and the bounds of paper eq. (4), (5)
  (core :func:`~gpr_kinematics.core.mobility.analyze_mobility`).

A request's numbers are read as floats and checked in a cheap form (finite, a unit quaternion); where one is not,
the package's validators name it. The response is filled in place (its own Pose, Point and Quaternion messages, no
message built per field) from the core's result. SI units (metres, radians), quaternions (x, y, z, w).
"""
from __future__ import annotations

import math
from typing import Any, cast

import numpy as np

from ..core import forward, inverse
from ..core.compensation import compensate_one
from ..core.config import GprConfig
from ..core.floats import matrix_of
from ..core.mobility import MobilityResult, analyze_mobility
from ..core.ops import SCALAR
from ..core.rotations import tilt_of_normal
from .conversions import fill_forward, floats_of, point_floats, quaternion_floats, set_vector


def model_name(name: str) -> str | None:
    """Empty model string: the node's default (``None`` for the core); any other is taken exactly as sent (the core
    refuses a name that is not a model: ``"radial\\n"`` and ``" radial"`` are not)."""
    return name or None


def answer_forward(config: GprConfig, request: Any, response: Any) -> None:
    """A ForwardKinematics response (module docstring)."""
    fill_forward(response, forward(floats_of(request.q, 'q', 3), config, model_name(request.model)))


def _set_achieved(response: Any, position: np.ndarray, quaternion: np.ndarray) -> None:
    p, o = response.achieved.position, response.achieved.orientation
    p.x, p.y, p.z = position.tolist()
    o.x, o.y, o.z, o.w = quaternion.tolist()


def answer_inverse(config: GprConfig, request: Any, response: Any) -> None:
    """An InverseKinematics response (module docstring); its ``message`` names a target's ``x``, ``y`` or heading,
    which are outcomes, not requested (answered ``success: true`` without a word: a target 5 m off the axis)."""
    target = request.target
    x, y, height = point_floats(target.position, 'target.position')
    quaternion = quaternion_floats(target.orientation, 'target.orientation')
    R = matrix_of(quaternion)
    tilt, azimuth = cast('tuple[float, float]', tilt_of_normal(SCALAR, R[0][2], R[1][2], R[2][2]))
    ik = inverse(height, tilt, azimuth, config, model_name(request.model))
    fk = ik.achieved
    response.q = ik.q
    _set_achieved(response, fk.position, fk.quaternion)
    response.tilt = fk.tilt
    response.tilt_azimuth = fk.tilt_azimuth
    response.twist = fk.twist
    response.iterations = ik.iterations
    if x or y or quaternion[2]:   # a heading: the twist of R = tilt_rotation Rz(heading) is 2 atan2(q_z, q_w)
        heading = 2.0 * math.atan2(quaternion[2], quaternion[3])
        given = ([f'x, y = ({x:.9g}, {y:.9g}) m'] if x or y else []) + \
            ([f'heading {math.remainder(heading, math.tau):.9g} rad'] if quaternion[2] else [])
        response.message = (f'target {" and ".join(given)} not honoured: x, y and the heading are outcomes (the height '
                            f'and the tilt are honoured); reached x, y = ({fk.position[0]:.9g}, {fk.position[1]:.9g}) '
                            f'm, twist {fk.twist:.9g} rad')


def answer_compensate(config: GprConfig, request: Any, response: Any) -> None:
    """A Compensate response (module docstring)."""
    command = request.command
    res = compensate_one(point_floats(command.position, 'command.position'),
                         quaternion_floats(command.orientation, 'command.orientation'),
                         point_floats(request.tool_offset, 'tool_offset'), config, model_name(request.model))
    fk = res.achieved
    response.q = res.q
    _set_achieved(response, fk.position, fk.quaternion)
    set_vector(response.tool_shift, res.tool_shift)
    correction = response.arm_correction
    set_vector(correction.translation, res.translation)
    r = correction.rotation
    r.x, r.y, r.z, r.w = res.quaternion


def answer_mobility(config: GprConfig, request: Any, response: Any) -> None:
    """An AnalyzeMobility response (module docstring)."""
    q = floats_of(request.q, 'q', 3)
    dq = floats_of(request.dq, 'dq', 3)
    fill_mobility(response, analyze_mobility(q, config, model_name(request.model)), np.array(dq))


def fill_mobility(response: Any, res: MobilityResult, dq: np.ndarray | None = None) -> Any:
    """Copy a core ``MobilityResult`` into an AnalyzeMobility response; with a non-zero ``dq`` [m] also
    ``|dX|`` and the bounds (4), (5) for ``dP = res.rod_perturbation(dq)`` (along the machine's own rod directions
    ``u_k``: rods that are not parallel move their joint centres off the base z axis)."""
    response.rank_dphi_dp = int(res.rank_dphi_dp)
    response.rank_augmented = int(res.rank_augmented)
    response.mobility = int(res.mobility)
    response.singular_values = res.singular_values.tolist()
    response.eigenvalues = res.eigenvalues.tolist()
    response.eq4_lower, response.eq4_upper = res.bounds['eq4']
    response.eq5_lower, response.eq5_upper = res.bounds['eq5']
    if dq is not None and np.any(dq != 0.0):
        b = res.dx_bounds(res.rod_perturbation(dq))
        response.dx_norm = b.norm_dx
        response.dx_lower_eq4, response.dx_upper_eq4 = b.lower_eq4, b.upper_eq4
        response.dx_lower_eq5, response.dx_upper_eq5 = b.lower_eq5, b.upper_eq5
    return response

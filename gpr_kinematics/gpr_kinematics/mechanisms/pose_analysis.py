"""One pose of a mechanism analysed (``gpr mechanism``): joint values, inverse Jacobians and their conditioning.

The inverse kinematics and the inverse Jacobian of any :class:`~gpr_kinematics.mechanisms.base.Mechanism`
(:meth:`~gpr_kinematics.mechanisms.base.Mechanism.report`), homogenised by the characteristic length (Toz & Kucuk
§4.3, ``docs/references.md``), with the condition number and the dexterity of the homogenised task Jacobian.
SI units: joint values in m or rad, Jacobian columns ``v_x v_y v_z w_x w_y w_z`` with ``w`` in the base frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import SingularityError
from .base import Mechanism
from .conditioning import ANGULAR_JOINTS

Array = NDArray[np.float64]


@dataclass(frozen=True)
class JointValue:
    """One joint at the pose: its ``name``, its ``type`` as the file names it (a generalized Stewart platform's
    constraint type, D1..A1; else the joint type), the ``joint_type`` (prismatic, revolute, ...), the ``value`` and
    its ``unit`` (m or rad)."""

    name: str
    type: str
    joint_type: str
    value: float
    unit: str


@dataclass(frozen=True)
class PoseAnalysis:
    """The analysis of one pose (module docstring): the ``mechanism``'s name and ``type``, its Euler convention, the
    realised ``pose`` by component (m, rad) and which components are ``pose_variables``, the ``joints``, the inverse
    Jacobian plain and homogenised, the ``characteristic_length`` [m], the homogenised task Jacobian, its
    ``condition_number`` (``inf`` where singular: JSON's ``"inf"``, the package's rule) and ``dexterity``, whether
    the pose is ``singular`` (and the named ``singularity``, ``None`` when there is none), whether the joints are
    ``within_limits``, and for the tripod the ``plane_residuals`` of its legs [m] (``None`` for the other
    mechanisms)."""

    mechanism: str
    type: str
    euler_convention: str
    pose: dict[str, float]
    pose_variables: tuple[str, ...]
    joints: tuple[JointValue, ...]
    inverse_jacobian: Array
    homogenized_inverse_jacobian: Array
    characteristic_length: float
    homogenized_task_jacobian: Array
    condition_number: float
    dexterity: float
    singular: bool
    singularity: str | None
    within_limits: bool
    plane_residuals: Array | None


def _joints(mech: Mechanism, q: Array) -> tuple[JointValue, ...]:
    labels = getattr(mech, 'types', None)
    return tuple(JointValue(name, str(labels[k]) if labels is not None else mech.joint_types[k], mech.joint_types[k],
                            float(q[k]), 'rad' if mech.joint_types[k] in ANGULAR_JOINTS else 'm')
                 for k, name in enumerate(mech.joint_names))


def analyse_pose(mech: Mechanism, pose: ArrayLike) -> PoseAnalysis:
    """:class:`PoseAnalysis` of ``mech`` at ``pose`` (6 values X Y Z A B C in its convention, SI).

    Raises:
        LimitError: the joints are outside their limits.
        SingularityError: the inverse Jacobian is not defined at the pose (a constraint row divides by zero).
    """
    full = mech.complete_pose(pose)
    q = mech.inverse_kinematics(full)
    mech.check_limits(q)
    rep = mech.report(full)
    if not (np.all(np.isfinite(rep.inverse_jacobian)) and np.all(np.isfinite(rep.task_jacobian))):
        why = rep.singularity or 'a constraint row divides by zero: zero distance, parallel lines, theta = 0'
        raise SingularityError(f'{mech.name}: the inverse Jacobian is not defined at pose {full.tolist()} ({why}); '
                               'allowed: poses where every row is defined')
    residuals = getattr(mech, 'plane_residuals', None)
    return PoseAnalysis(
        mechanism=mech.name, type=mech.kind, euler_convention=mech.euler_convention,
        pose=dict(zip(mech.pose_names, full.tolist(), strict=True)), pose_variables=tuple(mech.pose_variables),
        joints=_joints(mech, q), inverse_jacobian=rep.inverse_jacobian,
        homogenized_inverse_jacobian=rep.homogenized_inverse_jacobian,
        characteristic_length=mech.characteristic_length, homogenized_task_jacobian=rep.task_jacobian,
        condition_number=float(rep.condition_number),
        dexterity=rep.dexterity, singular=rep.singular, singularity=rep.singularity or None,
        within_limits=rep.within_limits, plane_residuals=None if residuals is None else residuals(full)[0])

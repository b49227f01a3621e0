"""Forward and inverse kinematics of the GPR under a virtual-joint model, and the naive model.

Bratovanov & Sotirov §IV-VI (``docs/references.md``); frames, units and conventions in ``docs/core.md``.
This module is the public face of the kinematics core; the implementation lives in one module per concept:

- :mod:`gpr_kinematics.core.machine`: the machine's geometry (rods, offsets, directions, platform joints);
- :mod:`gpr_kinematics.core.virtual_joints`, :mod:`gpr_kinematics.core.compliance`: the virtual-joint models and the
  solution of the closure;
- :mod:`gpr_kinematics.core.platform_pose`: the rigid fit of the joints onto the rods, and the naive pose;
- :mod:`gpr_kinematics.core.forward`: ``forward``, ``forward_batch`` and their results;
- :mod:`gpr_kinematics.core.inverse`: ``inverse``, ``inverse_batch`` and their results;
- :mod:`gpr_kinematics.core.naive`: the naive model (the old offline tool);
- :mod:`gpr_kinematics.core.stroke`: the one check of rod lengths against the stroke.
"""
from __future__ import annotations

from .config import resolve_config
from .forward import TILT_LIMIT_SLACK, ForwardBatch, ForwardResult, base_points, forward, forward_batch
from .inverse import IK_TOLERANCE, InverseBatch, InverseResult, inverse, inverse_batch
from .naive import naive_forward, naive_inverse, naive_pose
from .stroke import STROKE_SLACK

__all__ = ['IK_TOLERANCE', 'STROKE_SLACK', 'TILT_LIMIT_SLACK', 'ForwardBatch', 'ForwardResult', 'InverseBatch',
           'InverseResult', 'base_points', 'forward', 'forward_batch', 'inverse', 'inverse_batch', 'naive_forward',
           'naive_inverse', 'naive_pose', 'resolve_config']

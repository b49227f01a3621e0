"""The exact pose deviation's path: Alwan's perturbed closure (eq. (5), ``docs/references.md``) solved where the
mechanism goes as its errors grow from 0, not wherever Newton's method lands.

A six-DOF mechanism has several assembly modes, and a solve started at the nominal pose converged on another one:
the paper's GSP (Toz & Kucuk) under an A1 error of 0.5 deg read 45 mm and 21 deg off, exit 0, where its own branch
ends near 0.23-0.36 deg (0.4 deg was refused); with 8 equal steps an error of 0.5 deg on another joint still jumped
to a branch of the same ``det`` sign. :func:`follow` takes steps of the errors' share ``t`` (the first the whole, the
next twice the last one taken, halved on a refusal), each solved from the last pose and accepted only where it lands
within :data:`OFF_PREDICTION` of its first-order prediction ``h * tangent`` (the linearised motion there, eq. (7)) and
on the nominal pose's side of every singularity (the sign of ``det(dq/d twist)``); a path whose step falls below
:data:`LEAST_STEP` ends there (a fold: no pose of the branch reaches the errors), :class:`PathEndedError` naming the
first pose, found by halving the batch (a refusal of one pose among 20,000 took 116 s solving them one by one). The
other mechanisms (one branch near their poses) are solved in one step from the nominal pose, as before.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import ConvergenceError, SingularityError
from .base import Mechanism, rotation_vector

#: The least step of the errors' share before the path is said to end (module docstring).
LEAST_STEP = 1.0 / 4096
#: How far a step may land from its first-order prediction: a share of the predicted motion, plus :data:`SLACK`.
OFF_PREDICTION = 0.25
#: Newton's tolerance carried to the pose [m, homogenised]: below it a step is never refused.
SLACK = 1e-9

Array = np.ndarray


class PathEndedError(ConvergenceError):
    """The path ended at the share ``t`` of the errors for the pose ``row`` of the batch (``why``: what ended it)."""

    def __init__(self, t: float, why: str, row: int) -> None:
        super().__init__(why, sample=row)
        self.t, self.why, self.row = t, why, row


def branch(mech: Mechanism, poses: Array) -> Array:
    """``(N,)`` the sign of ``det(dq/d twist)``: constant along a path that crosses no singularity."""
    return np.asarray(np.sign(np.linalg.det(mech.task_jacobian(poses))))


def rigid_motion(mech: Mechanism, a: Array, b: Array) -> Array:
    """The motion from poses ``a`` to ``b`` ``(N, 6)``: position [m] and rotation vector [rad, base frame]."""
    dR = mech.rotation(b) @ np.swapaxes(mech.rotation(a), -1, -2)
    return np.concatenate([b[:, :3] - a[:, :3], rotation_vector(dR)], axis=-1)


def follow(mech: Mechanism, dp: dict[str, Array], poses: Array, joints: Array, ds: Array, tol: float,
           tangent: Callable[[Array, Array], Array]) -> Array:
    """The poses ``(N, 6)`` reaching ``joints + ds`` with the parameters off by ``dp``, followed from the nominal
    ``poses`` (module docstring); ``tangent(at, rows)``: the motion ``(len(rows), 6)`` per unit share of the errors
    at the poses ``at`` of those rows. :class:`PathEndedError` where the path ends."""
    nominal = mech.parameters() if dp else {}
    six = len(mech.pose_variables) == 6
    scale = np.r_[np.ones(3), np.full(3, mech.characteristic_length)]   # rotations as lengths, homogenised
    start = branch(mech, poses) if six else np.zeros(poses.shape[0])
    every = np.arange(poses.shape[0])

    def step(rows: Array, t: float, h: float, at: Array) -> tuple[Array | None, str]:
        """Solve ``rows`` at ``t + h`` from their poses ``at``: the poses (None: refused) and why it was refused."""
        m = mech.with_parameters({n: nominal[n] + (t + h) * v for n, v in dp.items()}) if dp else mech
        try:
            new = m.forward_kinematics(joints[rows] + (t + h) * ds[rows], at, tol=tol)
        except (ConvergenceError, SingularityError) as exc:   # no pose near the last one, or a fold's singular step
            return None, str(exc).removeprefix(f'{m.name}: forward kinematics ').split('; allowed: ')[0]
        if not six:
            return new, ''
        predicted = h * tangent(at, rows)
        off = np.linalg.norm((rigid_motion(m, at, new) - predicted) * scale, axis=-1)
        if np.any(off > OFF_PREDICTION * np.linalg.norm(predicted * scale, axis=-1) + SLACK) or \
                np.any(branch(m, new) != start[rows]):
            return None, 'left the path it followed (another assembly mode: the pose jumped or crossed a singular ' \
                         'configuration)'
        return new, ''

    t, h, at = 0.0, 1.0, poses
    while t < 1.0:
        h = min(h, 1.0 - t)
        new, why = step(every, t, h, at)
        if new is not None:
            t, at, h = t + h, new, 2.0 * h
        elif not six or h / 2.0 < LEAST_STEP:
            rows = every
            while rows.size > 1:   # the first pose refused alone: halves of the batch
                half = rows[:rows.size // 2]
                rows = half if step(half, t, h, at[half])[0] is None else rows[rows.size // 2:]
            row = int(rows[0])
            raise PathEndedError(t + h, step(rows, t, h, at[rows])[1] or why, row)
        else:
            h /= 2.0
    return at

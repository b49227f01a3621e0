"""What ``trajectory_node`` checks of a precomputed stream against the robot's joint limits at its rate (no ROS
import): a sweep's steps between samples against the rods' velocity limit (:func:`sweep_beyond_rod_limits`, a
warning, as a platform program's moves beyond the limits are), and, for ``loop``, the step from a program's last
sample back to its first (:func:`loop_refusal`: a program that does not end where it starts is refused; a sweep's
step back is one of its steps, judged with them). SI units (m, rad, s, Hz).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.messages import ROD_JOINT_NAMES
from ..robot.description import RobotDescription, Rods
from .streams import LIMIT_ROUNDING, Trajectory


def _joints(traj: Trajectory, robot: RobotDescription) -> tuple[list[str], np.ndarray, np.ndarray, list[str]]:
    """The joints ``joint_states`` carries for ``traj``: names, positions ``(S, J)``, velocity limits ``(J,)`` and
    units (rods [m], arm joints [rad])."""
    names, units = list(ROD_JOINT_NAMES), ['m'] * 3
    q, limits = np.asarray(traj.fk.q, dtype=float), [robot.rods.velocity] * 3
    if traj.robot is not None:
        velocity = {j.name: j.velocity for arm in robot.arms for j in arm.joints}
        names += list(traj.robot.joint_names)
        units += ['rad'] * len(traj.robot.joint_names)
        limits += [velocity[n] for n in traj.robot.joint_names]
        q = np.concatenate([q, np.asarray(traj.robot.joints, dtype=float)], axis=1)
    return names, q, np.asarray(limits, dtype=float), units


def loop_refusal(traj: Trajectory, robot: RobotDescription, rate: float) -> str:
    """Why ``traj`` (a program) cannot loop at ``rate`` [Hz], '' if it can: from its last sample to its first, the
    stream moves every joint in one sample, so each must end within one sample's move at its velocity limit of where
    it starts (beyond rounding, :data:`~.streams.LIMIT_ROUNDING`); the joint with the largest excess is named."""
    names, q, limits, units = _joints(traj, robot)
    jump = np.abs(q[-1] - q[0])
    allowed = limits / rate
    over = jump > allowed * (1.0 + LIMIT_ROUNDING)
    if not over.any():
        return ''
    k = int(np.argmax(np.where(over, jump / allowed, -1.0)))
    u = units[k]
    return (f'loop = true: the program ends {jump[k]:.6g} {u} from where it starts in {names[k]} ({q[-1, k]:.6g} '
            f'{u} at its last sample, {q[0, k]:.6g} {u} at its first): looping moves it in one sample, '
            f'{jump[k] * rate:.3g} {u}/s at {rate:g} Hz, beyond its velocity limit {limits[k]:g} {u}/s'
            f'{f" ({int(over.sum())} joints beyond theirs)" if over.sum() > 1 else ""}; allowed: a program whose '
            f'last state equals its first (each joint within one sample at its velocity limit: {allowed[k]:.3g} {u} '
            f'for {names[k]} at {rate:g} Hz), or loop false')


def _down(x: float) -> str:
    """``x`` > 0 rounded down to 4 significant digits (a rate named as allowed must be allowed)."""
    scale = 10.0 ** (3 - math.floor(math.log10(x)))
    return f'{math.floor(x * scale) / scale:g}'


def sweep_beyond_rod_limits(traj: Trajectory, rods: Rods, rate: float, loop: bool) -> Trajectory:
    """``traj`` (a sweep) with a warning (``Trajectory.warning``, on its description too) where a step between two
    samples at ``rate`` [Hz] needs the rods faster than ``rods.velocity`` (beyond rounding), with ``loop`` the step
    from its last sample back to its first too; unchanged otherwise. A sweep is timed by its rate: the warning names
    the highest rate its largest step allows."""
    q = np.asarray(traj.fk.q, dtype=float)
    if loop:
        q = np.concatenate([q, q[:1]])
    step = np.max(np.abs(np.diff(q, axis=0)), axis=1) if len(q) > 1 else np.zeros(0)
    over = np.flatnonzero(step * rate > rods.velocity * (1.0 + LIMIT_ROUNDING))
    if not over.size:
        return traj
    k = int(over[np.argmax(step[over])])
    n = len(traj)
    where = f'samples {k} and {k + 1}' if k + 1 < n else f'sample {n - 1} and sample 0, the loop\'s step back'
    warning = (f'{"a step needs" if over.size == 1 else f"{over.size} steps need"} the rods beyond their velocity '
               f'limit {rods.velocity:g} m/s (rods.velocity): at {rate:g} Hz about {step[k] * rate:.3g} m/s '
               f'({step[k]:.3g} m between {where}); a robot cannot follow {"it" if over.size == 1 else "them"} as '
               f'timed (a sweep is timed by its rate: at most {_down(rods.velocity / step[k])} Hz for this grid, or a '
               'smaller tilt_step)')
    return dataclasses.replace(traj, warning=warning, description=f'{traj.description}; warning: {warning}')

"""A picture of the GPR robot model at a pose, as RViz shows it with rviz/gpr.rviz (matplotlib, imported lazily).

:func:`robot_figure` draws, in ``gpr_base`` [m]: the base and the rod guides, the rods from their feet to the
joint centres ``P_k`` (the prismatic joints of the robot model at ``q``), the exact platform (the virtual-joint
model) and the naive platform as a ghost, with their frames. The centre shift between the two is micrometres, too
small to see at the robot's scale: the exact platform is drawn displaced from the naive one by ``exaggeration``
times the shift, and the figure says so and prints the true value.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .config import GprConfig
from .geometry import matrix_from_quaternion
from .kinematics import forward
from .robot_model import gpr_model


@dataclass(frozen=True)
class RobotFigure:
    """What :func:`robot_figure` drew: the rod lengths [m], the true centre shift [m] (base frame), the factor it
    was drawn with, and the file written."""

    q: np.ndarray
    centre_shift: np.ndarray
    exaggeration: float
    path: Path


def _disk(centre: np.ndarray, rotation: np.ndarray, radius: float, n: int = 48) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    local = np.stack([radius * np.cos(t), radius * np.sin(t), np.zeros(n)], axis=-1)
    out: np.ndarray = centre + local @ rotation.T
    return out


def _frame(ax: Any, origin: np.ndarray, rotation: np.ndarray, length: float, alpha: float = 1.0) -> None:
    for k, colour in enumerate(('tab:red', 'tab:green', 'tab:blue')):
        tip = origin + length * rotation[:, k]
        ax.plot(*np.stack([origin, tip]).T, color=colour, lw=2, alpha=alpha)


def robot_figure(config: GprConfig, q: np.ndarray, path: str | Path, exaggeration: float = 1000.0,
                 model: str | None = None) -> RobotFigure:
    """Draw the robot at rod lengths ``q`` [m] (forward kinematics of ``model``) into ``path`` (PNG)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    q = np.asarray(q, dtype=float).reshape(3)
    fk = forward(q, config, model)
    robot = gpr_model(config)
    R = config.radius
    rot = matrix_from_quaternion(fk.quaternion)
    nominal_rot = matrix_from_quaternion(fk.nominal_quaternion)
    shift = np.asarray(fk.centre_shift, dtype=float)
    drawn_centre = np.asarray(fk.nominal_position) + exaggeration * shift

    fig = plt.figure(figsize=(8.0, 7.0))
    ax = fig.add_subplot(projection='3d')
    zc = float(np.mean(q))
    low, high, span = zc - 1.2 * R, zc + 0.6 * R, 1.5 * R     # the platform's neighbourhood, equal scales
    for k in (1, 2, 3):
        foot, _ = robot.transform(f'gpr_rod_guide_{k}_mount')
        top = np.asarray(foot) + np.asarray(robot.transform(f'rod_{k}', q[k - 1])[0])
        ax.plot(*np.stack([[top[0], top[1], low], top]).T, color='tab:blue', lw=4)     # the rod, down to the base
        ax.scatter(*top, color='0.2', s=25)
        outward = 0.25 * R * np.array([top[0], top[1], 0.0]) / R
        ax.text(*(top + outward), f'rod_{k}\nq = {q[k - 1]:.4f} m', fontsize=8)
    ax.add_collection3d(Poly3DCollection([_disk(np.asarray(fk.nominal_position), nominal_rot, 1.2 * R)],
                                         color='tab:green', alpha=0.25))
    ax.add_collection3d(Poly3DCollection([_disk(drawn_centre, rot, 1.2 * R)], color='tab:orange', alpha=0.6))
    _frame(ax, np.asarray(fk.nominal_position), nominal_rot, 0.5 * R, alpha=0.5)
    _frame(ax, drawn_centre, rot, 0.7 * R)
    ax.quiver(*fk.nominal_position, *(exaggeration * shift), color='k', lw=2, arrow_length_ratio=0.25)
    um = 1e6 * shift
    ax.text2D(0.02, 0.02, f'centre shift (exact - naive) = ({um[0]:+.2f}, {um[1]:+.2f}, {um[2]:+.2f}) um,\n'
              f'drawn {exaggeration:g} times larger (black arrow)', transform=ax.transAxes, fontsize=9)
    ax.set_title(f'gpr_platform (orange: exact, virtual-joint model {fk.model}) and gpr_platform_nominal (green:\n'
                 f'naive model) at a tilt of {math.degrees(fk.tilt):.2f} deg about azimuth '
                 f'{math.degrees(fk.tilt_azimuth):.1f} deg, frames in gpr_base', fontsize=10)
    ax.set_xlim(-span, span)
    ax.set_ylim(-span, span)
    ax.set_zlim(low, high)
    ax.set_box_aspect((2 * span, 2 * span, high - low))
    ax.set_xlabel('x [m]')
    ax.set_ylabel('y [m]')
    ax.set_zlabel('z [m]')
    ax.view_init(elev=20, azim=-65)
    out = Path(path)
    fig.savefig(out, dpi=110, bbox_inches='tight')
    plt.close(fig)
    return RobotFigure(q=q, centre_shift=shift, exaggeration=float(exaggeration), path=out)

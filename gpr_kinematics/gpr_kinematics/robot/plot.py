"""A picture of the whole robot at a pose, as RViz shows it with rviz/gpr.rviz (matplotlib, imported lazily).

:func:`robot_figure` draws, in the robot's world frame [m]: the rods from their feet to the joint centres ``P_k``
(the prismatic joints of the robot model at the rod lengths), the exact platform (the virtual-joint model) and the
naive platform as a ghost, each arm's links, blade and wafer on the exact platform, and the wafer where the naive
model places it as a ghost. The exact and the naive platform differ by micrometres and microradians, too little to
see at the robot's scale: the exact platform, and the arms on it, are drawn displaced from the naive one by
``exaggeration`` times their true difference (its translation and its rotation vector), so every point on the
platform moves about ``exaggeration`` times its true error; the figure says so and prints the true centre shift
and wafer errors. Every frame comes from the robot model (:func:`gpr_kinematics.robot.urdf.robot_urdf`, the URDF
RViz draws) and the poses from the kinematics core.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..inputs.files import atomic_output
from . import robot_forward
from .description import RobotDescription
from .urdf import RobotUrdf, robot_urdf


@dataclass(frozen=True)
class RobotFigure:
    """What :func:`robot_figure` drew: the rod lengths [m], the arms' joints [rad], the true centre shift [m]
    (``gpr_base``), each arm's true naive-model wafer error [m] (world), the factor the difference between the
    exact and the naive platform was drawn with, and the file written."""

    rods: np.ndarray
    joints: dict[str, np.ndarray]
    centre_shift: np.ndarray
    wafer_error: dict[str, np.ndarray]
    exaggeration: float
    path: Path


def _homogeneous(position: Sequence[float] | np.ndarray, rotation: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = rotation
    T[:3, 3] = position
    return T


def _joint(model: RobotUrdf, name: str, value: float = 0.0) -> np.ndarray:
    from ..core.rotations import matrix_from_quaternion

    t, q = model.transform(name, value)
    return _homogeneous(t, matrix_from_quaternion(q))


def exaggerated(naive: np.ndarray, exact: np.ndarray, factor: float) -> np.ndarray:
    """``naive * D^factor`` with ``D = naive^-1 exact`` (its translation and rotation vector scaled): the exact
    pose as drawn, ``factor`` times as far from the naive one as it is.

    >>> T = np.eye(4); T[0, 3] = 1e-6
    >>> float(exaggerated(np.eye(4), T, 1000.0)[0, 3])
    0.001
    """
    from scipy.spatial.transform import Rotation

    D = np.linalg.solve(naive, exact)
    drawn = _homogeneous(factor * D[:3, 3], Rotation.from_rotvec(factor * Rotation.from_matrix(D[:3, :3])
                                                                  .as_rotvec()).as_matrix())
    out: np.ndarray = naive @ drawn
    return out


def _disk(T: np.ndarray, radius: float, n: int = 48) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    local = np.stack([radius * np.cos(t), radius * np.sin(t), np.zeros(n), np.ones(n)], axis=-1)
    out: np.ndarray = (local @ T.T)[:, :3]
    return out


def _arm_frames(model: RobotUrdf, robot: RobotDescription, platform: np.ndarray, arm: str,
                joints: np.ndarray) -> list[np.ndarray]:
    """The world poses of the arm's link frames, blade and wafer on ``platform`` (the model's joints)."""
    a = robot.arm(arm)
    T, out = platform, []
    for name, value in zip(a.joint_names, joints, strict=True):
        T = T @ _joint(model, name, float(value))
        out.append(T)
    T = T @ _joint(model, f'{a.name}_blade_mount')
    out.append(T)
    out.append(T @ _joint(model, f'{a.name}_wafer_mount'))
    return out


def robot_figure(robot: RobotDescription, rods: Sequence[float], joints: Mapping[str, Sequence[float]],
                 path: str | Path, exaggeration: float = 1000.0) -> RobotFigure:
    """Draw ``robot`` at rod lengths ``rods`` [m] and the joints [rad] of each arm (by arm name; an arm not given
    at its home posture) into ``path`` (PNG); see the module docstring."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    model = robot_urdf(robot)
    q = np.asarray(rods, dtype=float).reshape(3)
    postures = {a.name: np.asarray(joints.get(a.name, a.home), dtype=float) for a in robot.arms}
    fks = {name: robot_forward(robot, q, J, name) for name, J in postures.items()}
    fk = next(iter(fks.values()))
    world_base = _joint(model, f'{model.joints[0].child}_mount')
    exact = _homogeneous(fk.platform.position[0], fk.platform.rotation[0])
    naive = _homogeneous(fk.naive_platform.position[0], fk.naive_platform.rotation[0])
    drawn = exaggerated(naive, exact, exaggeration)
    R = robot.config.radius

    fig = plt.figure(figsize=(9.0, 7.5))
    ax = fig.add_subplot(projection='3d')
    points = [drawn[:3, 3]]
    for k in range(3):
        foot = world_base @ _joint(model, f'gpr_rod_guide_{k + 1}_mount')
        top = foot @ _joint(model, f'rod_{k + 1}', q[k])
        ax.plot(*np.stack([foot[:3, 3], top[:3, 3]]).T, color='tab:blue', lw=3)
        points.append(foot[:3, 3])
    ax.add_collection3d(Poly3DCollection([_disk(naive, 1.2 * R)], color='tab:green', alpha=0.3))
    ax.add_collection3d(Poly3DCollection([_disk(drawn, 1.2 * R)], color='tab:orange', alpha=0.7))
    colours = ('tab:purple', 'tab:brown', 'tab:cyan', 'tab:olive')
    errors = {}
    for (name, J), colour in zip(postures.items(), colours, strict=False):
        frames = _arm_frames(model, robot, drawn, name, J)
        chain = np.array([drawn[:3, 3], *(T[:3, 3] for T in frames)])
        ax.plot(*chain.T, color=colour, lw=4, solid_capstyle='round', label=f'{name} {np.round(J, 3).tolist()} rad')
        ax.add_collection3d(Poly3DCollection([_disk(frames[-1], 0.5 * robot.wafer.diameter)], color=colour, alpha=0.45))
        ghost = _arm_frames(model, robot, naive, name, J)[-1]
        # A transparent face, not 'none': matplotlib 3.6/3.7 (a stock Jazzy install) fail to depth-sort a 3-D
        # polygon collection that has no face colours.
        ax.add_collection3d(Poly3DCollection([_disk(ghost, 0.5 * robot.wafer.diameter)], facecolor=(0.0, 0.0, 0.0, 0.0),
                                             edgecolor=colour, linestyle='--', lw=1))
        points += [T[:3, 3] for T in frames]
        errors[name] = fks[name].naive_wafer_error[0]
    shift = np.asarray(fk.gpr.centre_shift[0], dtype=float)
    lines = [f'centre shift (exact - naive) = ({", ".join(f"{1e6 * v:+.2f}" for v in shift)}) um in gpr_base']
    lines += [f'{name} wafer: real - where the naive model places it = {1e6 * np.linalg.norm(e):.2f} um '
              f'({", ".join(f"{1e6 * v:+.2f}" for v in e)})' for name, e in errors.items()]
    lines.append(f'exact platform and arms drawn {exaggeration:g} times as far from the naive ones (dashed '
                 'wafers, green platform) as they are')
    ax.text2D(0.0, -0.02, '\n'.join(lines), transform=ax.transAxes, fontsize=8, va='top')
    gpr = fk.gpr
    ax.set_title(f'robot {robot.name} in {robot.world_frame}: gpr_platform (orange, exact, model {gpr.model}) tilted '
                 f'{math.degrees(gpr.tilt[0]):.2f} deg about azimuth {math.degrees(gpr.tilt_azimuth[0]):.1f} deg,\n'
                 'gpr_platform_nominal (green, naive model), the arms, blades and wafers on the exact platform',
                 fontsize=9)
    P = np.array(points)
    centre, half = 0.5 * (P.max(axis=0) + P.min(axis=0)), 0.5 * np.max(P.max(axis=0) - P.min(axis=0)) + 0.15
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(0.0, 2 * half)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    for axis in 'xyz':
        getattr(ax, f'set_{axis}label')(f'{axis} [m]')
    ax.legend(loc='upper left', fontsize=8)
    ax.view_init(elev=28, azim=-60)
    out = Path(path)
    try:
        with atomic_output(out, 'plot', binary=True) as fh:
            fig.savefig(fh, format=out.suffix.lower().lstrip('.') or 'png', dpi=100, bbox_inches='tight')
    finally:
        plt.close(fig)
    return RobotFigure(rods=q, joints=postures, centre_shift=shift, wafer_error=errors,
                       exaggeration=float(exaggeration), path=out)

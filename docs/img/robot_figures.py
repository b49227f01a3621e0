"""Regenerate the figure of docs/robot.md: ``python docs/img/robot_figures.py`` (from the repo root).

The old offline tool's wafer error (the naive model's joints run on the real GPR) against the station plane's
tilt, for the shipped example robot's lower arm, at three reaches, with the wafer across the tilt axis (solid) and
along it (dashed).
"""
from pathlib import Path

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt
import numpy as np
from gpr_kinematics.robot import Stations, load_robot, solve_stations

OUT = Path(__file__).resolve().parent


def wafer_error_vs_tilt():
    robot = load_robot()
    base = np.array(robot.base_position)
    tilts = np.radians(np.linspace(0.0, 2.0, 41))
    azimuth = 0.0  # tilt axis along x: the plane rises towards -y
    fig, ax = plt.subplots(figsize=(6.0, 4.0), dpi=100)
    for reach, colour in ((0.35, '#1b9e77'), (0.55, '#d95f02'), (0.75, '#7570b3')):
        for direction, style, label in ((azimuth + np.pi / 2, '-', 'across the tilt axis'),
                                        (azimuth, '--', 'along the tilt axis')):
            pos = base + [reach * np.cos(direction), reach * np.sin(direction), 0.45]
            st = Stations.of(np.tile(pos, (tilts.size, 1)), tilts, azimuth, direction)
            sol = solve_stations(robot, st, 'arm1')
            ax.plot(np.degrees(tilts), sol.naive_wafer_error_norm * 1e6, style, color=colour,
                    label=f'reach {reach:.2f} m, {label}')
    ax.set_xlabel('station plane tilt [deg]')
    ax.set_ylabel('wafer position error of the naive model [um]')
    ax.set_title('Old offline tool (naive GPR model): wafer error at the station\n'
                 'example robot, arm1, radial virtual-joint model', fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(OUT / 'robot_wafer_error_vs_tilt.png')
    plt.close(fig)


if __name__ == '__main__':
    wafer_error_vs_tilt()

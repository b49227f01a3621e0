"""Make the picture of docs/ros.md ("In RViz"): the robot model at a tilted pose, the centre shift exaggerated.

Run: ``.venv/bin/python docs/img/ros_figures.py`` (writes docs/img/ros_robot_tilted.png).
"""
from __future__ import annotations

import math
from pathlib import Path

from gpr_kinematics.config import load_config
from gpr_kinematics.kinematics import inverse
from gpr_kinematics.robot_plot import robot_figure

OUT = Path(__file__).resolve().parent / 'ros_robot_tilted.png'


def main() -> None:
    cfg = load_config()
    ik = inverse(0.4, math.radians(2.0), math.radians(30.0), cfg)   # 2 deg about the axis at azimuth 30 deg
    fig = robot_figure(cfg, ik.q, OUT, exaggeration=1500.0)
    print(f'{fig.path}: q = {fig.q} m, centre shift {1e6 * fig.centre_shift} um (drawn x{fig.exaggeration:g})')


if __name__ == '__main__':
    main()

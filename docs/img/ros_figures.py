"""Make the picture of docs/ros.md ("In RViz"): the whole robot at a tilted station, the difference between the
exact and the naive platform exaggerated and labelled.

Run: ``.venv/bin/python docs/img/ros_figures.py`` (writes docs/img/ros_robot_tilted.png).
"""
from __future__ import annotations

import math
from pathlib import Path

from gpr_kinematics.robot import Stations, load_robot, solve_stations
from gpr_kinematics.robot.plot import robot_figure

OUT = Path(__file__).resolve().parent / 'ros_robot_tilted.png'


def main() -> None:
    robot = load_robot()
    # arm1 places a wafer at a station plane tilted 2 deg about the axis at azimuth 30 deg; arm2 stays at home.
    station = Stations.of([[1.2, 0.95, 0.45]], math.radians(2.0), math.radians(30.0), math.radians(45.0))
    sol = solve_stations(robot, station, 'arm1')
    fig = robot_figure(robot, sol.rods[0], {'arm1': sol.joints[0]}, OUT, exaggeration=1500.0)
    print(f'{fig.path}: rods {fig.rods} m, centre shift {1e6 * fig.centre_shift} um, wafer errors '
          + ', '.join(f'{k} {1e6 * v} um' for k, v in fig.wafer_error.items()) + f' (drawn x{fig.exaggeration:g})')


if __name__ == '__main__':
    main()

"""Demo: program the example robot through a few stations at tilted heights (``python -m gpr_kinematics.robot.demo``).

For each station (a wafer pose in the process tool's frame) it prints the rods and arm joints solved under the
virtual-joint model, how closely forward kinematics reaches the station, and the wafer error the naive model (the
old offline tool: the platform rotated about its centre) would have made with its own joints; then it checks and
times the shipped example program. Needs only numpy, scipy and PyYAML.
"""
from __future__ import annotations

import math
import sys

import numpy as np

from ..errors import GprError
from ..inputs.resources import config_path
from .description import load_robot
from .inverse import solve_stations
from .plan import plan_program
from .program import load_program
from .stations import Stations

#: (name, arm, offset from the robot base [m], tilt [deg], azimuth [deg], heading [deg])
STATIONS = (
    ('load_port', 'arm1', (0.0, -0.6, 0.40), 0.0, 0.0, -90.0),
    ('chamber_a', 'arm1', (0.45, 0.5, 0.455), 1.2, 30.0, 45.0),
    ('chamber_b', 'arm1', (-0.45, 0.55, 0.48), 2.0, -60.0, 130.0),
    ('buffer_high', 'arm2', (0.55, -0.2, 0.75), 1.5, 120.0, -20.0),
    ('cooler_low', 'arm2', (-0.5, -0.3, 0.35), 0.8, 200.0, -150.0),
)


def main() -> int:
    robot = load_robot()
    base = np.array(robot.base_position)
    print(f'robot {robot.name} ({", ".join(robot.arm_names)}), GPR model {robot.config.model}, base at '
          f'{base.tolist()} m in the world')
    print(f'{"station":<12} {"arm":<5} {"tilt":>6} {"rods [mm]":>24}  {"arm joints [deg]":<30} {"reached":>9} '
          f'{"naive model error":>18}')
    for name, arm, offset, tilt, azimuth, heading in STATIONS:
        st = Stations.of([base + offset], math.radians(tilt), math.radians(azimuth), math.radians(heading), [name])
        sol = solve_stations(robot, st, arm)
        joints = ' '.join(f'{v:7.2f}' for v in np.degrees(sol.joints[0]))
        print(f'{name:<12} {arm:<5} {tilt:5.1f}d {" ".join(f"{v:7.3f}" for v in sol.rods[0] * 1e3):>24}  '
              f'{joints:<30} {sol.position_error[0]:8.1e}m {sol.naive_wafer_error_norm[0] * 1e6:14.3f} um')
    program = load_program(config_path('programs/example_robot_program.yaml'))
    plan = plan_program(robot, program)
    err = np.linalg.norm(plan.naive_wafer_error, axis=1)
    print(f'example program: {len(plan.waypoints)} waypoints in {plan.timing.total:.2f} s within the velocity and '
          f'acceleration limits; the naive model would miss the wafer by up to {err.max() * 1e6:.3f} um')
    return 0


if __name__ == '__main__':
    try:
        sys.exit(main())
    except GprError as exc:
        sys.stderr.write(f'robot demo: error: {exc}\n')
        sys.exit(2)

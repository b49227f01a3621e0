"""The robot demo runs with the core alone and prints, per station, the joints and the naive model's wafer error."""
import math
import re

import numpy as np
from gpr_kinematics.robot import demo
from gpr_kinematics.robot.inverse import solve_stations
from gpr_kinematics.robot.stations import Stations
from robot_support import ROBOT


def test_demo_prints_every_station(capsys):
    assert demo.main() == 0
    out = capsys.readouterr().out.splitlines()
    base = np.array(ROBOT.base_position)
    for name, arm, offset, tilt, azimuth, heading in demo.STATIONS:
        line = next(row for row in out if row.startswith(name + ' '))
        st = Stations.of([base + offset], math.radians(tilt), math.radians(azimuth), math.radians(heading))
        sol = solve_stations(ROBOT, st, arm)
        assert re.search(rf'{sol.naive_wafer_error_norm[0] * 1e6:.3f} um$', line), line
        assert f'{sol.rods[0, 0] * 1e3:.3f}' in line
    assert out[-1].startswith('example program: 21 waypoints')

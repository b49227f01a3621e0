"""Sampling a platform program (``robot.platform_program.sample_program``): the stream starts at the first station
and ends at the last one, at the program's end, whatever the moves' durations."""
from __future__ import annotations

import math

import numpy as np
import pytest
from gpr_kinematics.robot.platform_program import parse_platform_program, sample_program


@pytest.mark.parametrize('move_time, dwell', [(1e-12, 0.0), (0.5, 0.0), (0.5, 0.0105), (0.25 + 5e-10, 0.0),
                                              (1e-12, 0.3)])
def test_the_last_sample_is_the_last_station_at_the_programs_end(move_time, dwell):
    stations = [{'name': 'a', 'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0, 'dwell': dwell},
                {'name': 'b', 'height': 0.4, 'tilt': math.radians(1.0), 'azimuth': 0.5, 'dwell': 0.0,
                 'move_time': move_time}]
    s = sample_program(parse_platform_program({'stations': stations}), 100.0)
    total = dwell + move_time
    assert s.time[0] == 0.0 and s.time[-1] == pytest.approx(total, abs=1e-15)
    assert np.all(np.diff(s.time) > 0)
    assert s.station[-1] == 1 and s.height[-1] == 0.4
    assert s.tilt[-1] == pytest.approx(math.radians(1.0), abs=1e-15)
    n = math.floor(total * 100.0 + 1e-9)
    assert len(s) == n + 1 + (total - n / 100.0 > 1e-9 or n == 0)

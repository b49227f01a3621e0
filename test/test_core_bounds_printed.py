"""One rule and one printing for a bound reached at several doors: a refused value is printed with the digits that
tell it from its bound (``360.0000001 deg`` read ``360 deg`` beside ``allowed: [-360, 360] deg``), and one turn's
slack (``validation.TURN_SLACK``, 1e-9 rad) is the same for typed directions, files, requests, the held joint's
value of a station and a geometry's rod azimuths."""
from __future__ import annotations

import math

import numpy as np
import pytest
from gpr_kinematics.calibration.tolerances import parse_tolerances
from gpr_kinematics.cli.options import sample_rate
from gpr_kinematics.core.config import load_config
from gpr_kinematics.errors import ConfigError, InputError
from gpr_kinematics.inputs.schema import orientation_angle
from gpr_kinematics.inputs.validation import TURN, within_turn
from gpr_kinematics.robot.inverse import solve_stations
from robot_support import ROBOT, random_stations

JUST_INSIDE = TURN + 5e-10   # within the slack
JUST_BEYOND = TURN + 2e-9


def test_a_refused_value_is_printed_apart_from_its_bound():
    with pytest.raises(ConfigError, match=r'f: heading = 360.0000001 deg is beyond one turn; allowed: \[-360, 360\] '
                                          r'deg$'):
        orientation_angle(360.0000001, 'heading', 'f', 'deg')
    with pytest.raises(ConfigError, match=r'f: azimuth = -6.283185309 rad is beyond one turn'):
        orientation_angle(-6.283185309, 'azimuth', 'f')
    with pytest.raises(InputError, match=r'^tilt = 6.283185309 rad is beyond one turn; allowed: \[-2pi, 2pi\] rad'):
        within_turn(6.283185309, 'tilt')
    with pytest.raises(InputError, match=r'^--rate = 5000.0001 Hz is invalid; allowed: '):
        sample_rate(5000.0001)
    with pytest.raises(InputError, match=r'^--rate = nan Hz is invalid'):
        sample_rate(math.nan)
    with pytest.raises(ConfigError, match=r't.yaml: measurement_noise: position = 0.1000001 m \(SI\); allowed: a '
                                          r'standard deviation from 1e-09 to 0.1 m$'):
        parse_tolerances({'measurement_noise': {'position': 0.1000001, 'angle': 1e-5}}, 't.yaml')


def test_one_turn_and_its_slack_at_every_door():
    assert orientation_angle(JUST_INSIDE, 'heading', 'f') == JUST_INSIDE
    assert within_turn(JUST_INSIDE, 'heading') == JUST_INSIDE
    for beyond in (JUST_BEYOND, -JUST_BEYOND):
        with pytest.raises(ConfigError):
            orientation_angle(beyond, 'heading', 'f')
        with pytest.raises(InputError):
            within_turn(beyond, 'heading')
    # a geometry's rod azimuths refused 2pi + 5e-10 (a slack of 1e-12)
    az = load_config(overrides={'rod_azimuths': [2.0943951023931953, 4.1887902047863905, JUST_INSIDE]}).rod_azimuths
    assert az[2] == JUST_INSIDE
    with pytest.raises(ConfigError, match='rod_azimuths'):
        load_config(overrides={'rod_azimuths': [2.0943951023931953, 4.1887902047863905, JUST_BEYOND]})
    # the held joint's value: gpr robot ik took 2pi + 5e-10 as typed, and the solve refused it as 6.28319 rad
    st, _, _ = random_stations(ROBOT, 'arm2', 3, seed=5)
    held = solve_stations(ROBOT, st, 'arm2', redundancy_value=JUST_INSIDE, check=False)
    np.testing.assert_allclose(held.joints[:, 2], JUST_INSIDE - 2.0 * math.pi, atol=1e-15)
    with pytest.raises(InputError, match=r'redundancy value = 6.283185309 rad \(station 0\) is beyond one turn'):
        solve_stations(ROBOT, st, 'arm2', redundancy_value=JUST_BEYOND, check=False)

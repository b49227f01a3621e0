"""One rule and one printing for a bound reached at several doors: a refused value is printed with the digits that
tell it from its bound (``360.0000001 deg`` read ``360 deg`` beside ``allowed: [-360, 360] deg``), and one turn's
slack (``validation.TURN_SLACK``, 1e-9 rad) is the same for typed directions, files, requests, the held joint's
value of a station and a geometry's rod azimuths."""
from __future__ import annotations

import math

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
    with pytest.raises(ConfigError, match=r't.yaml: measurement_noise: position = 0.1000001 m; allowed: a '
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
    # the held joint's value: gpr robot ik took 2pi + 5e-10 as typed, and the solve refused it as 6.28319 rad; within
    # the turn's slack it is judged by the joint's limits (as the robot file's value), beyond it as a slip of degrees
    st, _, _ = random_stations(ROBOT, 'arm2', 3, seed=5)
    with pytest.raises(InputError, match=r'redundancy value = 6\.28319 rad \(station 0\) is outside the limits of '
                                         r'arm2_wrist, \[-2\.5, 2\.5\] rad; allowed: a value within them; '
                                         r'6\.28319 rad is 5e-10 rad modulo a turn$'):
        solve_stations(ROBOT, st, 'arm2', redundancy_value=JUST_INSIDE, check=False)
    with pytest.raises(InputError, match=r'redundancy value = 6.283185309 rad \(station 0\) is beyond one turn'):
        solve_stations(ROBOT, st, 'arm2', redundancy_value=JUST_BEYOND, check=False)


def test_one_turn_in_a_robot_file_and_a_cell_file(tmp_path):
    """A robot file's angles (a joint's limits, a held value) and a cell obstacle's tilt (360.00000005 deg) were
    refused within the slack typed values and the azimuths take."""
    import yaml
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.description import load_robot
    from gpr_kinematics.safety.cell import parse_cell

    text = config_path('robots/example_robot.yaml').read_text()
    robot = tmp_path / 'r.yaml'
    old = 'name: arm1_wrist, length: 0.0, height: 0.02, lower: -3.05, upper: 3.05'
    robot.write_text(text.replace(old, old.replace('upper: 3.05', f'upper: {JUST_INSIDE!r}')))
    assert load_robot(robot).arm('arm1').joints[2].upper == JUST_INSIDE
    robot.write_text(text.replace(old, old.replace('upper: 3.05', f'upper: {JUST_BEYOND!r}')))
    with pytest.raises(ConfigError, match=r'upper = 6.28318530\d+ is invalid; allowed: radians within \[-2pi, 2pi\]'):
        load_robot(robot)
    box = {'name': 'b', 'box': [0.1, 0.1, 0.1], 'position': [1.0, 0.0, 0.5]}
    for tilt, ok in ((360.00000005, True), (360.0000002, False)):
        data = {'format': 'gpr_cell', 'version': 1, 'units': {'angle': 'deg'}, 'obstacles': [box | {'tilt': tilt}]}
        if ok:
            parse_cell(yaml.safe_load(yaml.safe_dump(data)), 'c')
        else:
            with pytest.raises(ConfigError, match='tilt'):
                parse_cell(data, 'c')

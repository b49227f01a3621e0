"""What the nodes decide, tested without ROS: the text a double parameter takes as a number
(:func:`gpr_kinematics.inputs.validation.decimal_number`, the nodes' pre-set callback: ``ros2 param set x 1e-13``
sends the string '1e-13'); the program file a ``gpr/run_program`` goal names
(:func:`gpr_kinematics.ros.streams.goal_program`)."""
from __future__ import annotations

import time
from types import SimpleNamespace

import pytest
from gpr_kinematics.errors import ConfigError, FileError
from gpr_kinematics.inputs.validation import MAX_NUMBER_TEXT, decimal_number
from gpr_kinematics.robot.description import load_robot
from gpr_kinematics.ros.streams import MAX_PATH, GoalFiles, goal_program


@pytest.mark.parametrize(('text', 'value'), [('1e-13', 1e-13), (' 3.0e-2 ', 0.03), ('1.', 1.0), ('.5', 0.5),
                                             ('-1', -1.0), ('+2E5', 2e5), ('1.0e-14', 1e-14)])
def test_decimal_text_is_a_number(text, value):
    assert decimal_number(text) == value


@pytest.mark.parametrize('text', ['nan', 'inf', '-inf', '1e', '.', '', 'small', '1.2.3', '0x10', '1_000', '1e-13 m'])
def test_other_text_is_none(text):
    assert decimal_number(text) is None


def test_long_text_is_refused_at_once():
    """A parameter service's pre-set callback reads every string set on a double: a run of 30,000 digits and an 'x'
    took 22 s (the digits could be split between ``\\d+`` and ``\\d*`` n ways) and held every callback of the node;
    a text longer than a double's is no number, decided in microseconds."""
    assert decimal_number('1' * MAX_NUMBER_TEXT) == float('1' * MAX_NUMBER_TEXT)
    for text in ('1' * (MAX_NUMBER_TEXT + 1), '1' * 1_000_000 + 'x', ' ' * 1_000_000 + '1', '1' * 1_000_000):
        t0 = time.perf_counter()
        assert decimal_number(text) is None
        assert time.perf_counter() - t0 < 0.05


def _goal(program_file: str) -> SimpleNamespace:
    return SimpleNamespace(program_file=program_file, stations=[], move_time=0.0)


def test_a_goal_file_name_too_long_is_refused_naming_the_rule():
    """A name too long for the file system (a component of 300 characters, a path of 5,000) was an OSError of the
    look-up: the goal ended as 'internal error: OSError: [Errno 36] File name too long: ...' quoting the whole path."""
    robot, files = load_robot(None), GoalFiles.of([''])
    with pytest.raises(FileError, match=r"^cannot read program file '.*/config/programs/x{300}': File name too long; "
                                        r'allowed: a path whose names have at most 255 bytes each, 4096 in all$'):
        goal_program(_goal('x' * 300), robot, files)
    with pytest.raises(ConfigError, match=f'^goal: program_file has 5000 bytes \\(UTF-8\\); allowed: a path of at '
                                          f'most {MAX_PATH}$'):
        goal_program(_goal('x' * 5000), robot, files)
    # the file system counts bytes: 2,000 characters of three bytes each passed a count of characters
    with pytest.raises(ConfigError, match=r'^goal: program_file has 6000 bytes \(UTF-8\)'):
        goal_program(_goal('\u20ac' * 2000), robot, files)
    assert len(goal_program(_goal('example_stations.yaml'), robot, files).stations) > 1


def test_a_relative_goal_file_that_is_no_regular_file_is_refused_as_such(tmp_path):
    """A FIFO or a folder named relative to an operator's program folder was looked for in the package's folder
    instead ('cannot read ... config/programs/fifo.yaml: No such file or directory'); it is refused as the absolute
    path is: not a regular file."""
    import os
    robot, files = load_robot(None), GoalFiles.of([str(tmp_path)])
    os.mkfifo(tmp_path / 'fifo.yaml')
    (tmp_path / 'dir.yaml').mkdir()
    for name, kind in (('fifo.yaml', 'a FIFO'), ('dir.yaml', 'a directory')):
        assert files.path(name) == tmp_path / name
        with pytest.raises(FileError, match=rf"'{tmp_path / name}' is not a regular file \({kind}\)"):
            goal_program(_goal(name), robot, files)
        with pytest.raises(FileError, match=rf"is not a regular file \({kind}\)"):
            goal_program(_goal(str(tmp_path / name)), robot, files)


def test_a_calibrated_robot_runs_its_robots_programs_and_another_robot_does_not(tmp_path):
    """trajectory_node refused the example program on the example robot's calibration (``gpr calibrate --robot``
    keeps the name and moves lengths and offsets) and advised the uncalibrated file, 128 um off at the wafer; the
    command line's ``--robot`` takes it. The node now refuses another structure only: a renamed arm or joint."""
    import yaml
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.program import load_program, program_robot

    program = load_program(config_path('programs/example_robot_program.yaml'))
    data = yaml.safe_load(config_path('robots/example_robot.yaml').read_text())
    data['gpr'] = {'config': str(config_path('gpr.yaml'))}
    data['arms'][0]['joints'][1]['length'] += 60e-6       # a calibration
    data['arms'][0]['joints'][0]['zero_offset'] = 1e-4
    calibrated = tmp_path / 'calibrated.yaml'
    calibrated.write_text(yaml.safe_dump(data))
    program_robot(program, load_robot(calibrated))
    data['arms'][1]['joints'][0]['name'] = 'arm2_base'    # another robot under the same name
    other = tmp_path / 'other.yaml'
    other.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=r'is a program for robot example_dual_arm \(.*example_robot.yaml; arms '
                                          r'arm1: arm1_shoulder, .*\); this node runs robot example_dual_arm '
                                          r'\(.*other.yaml; arms .*arm2: arm2_base, .*\): start trajectory_node with '
                                          r"robot_file:= that robot's description or its calibration"):
        program_robot(program, load_robot(other))

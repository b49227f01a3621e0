"""``gpr robot fk|ik|teach`` and ``gpr program check|export|send``: JSON keys, units, the trajectory file, and one-line
errors with status 2 (``send`` over ROS: test_ros_program_send.py)."""
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.forward import robot_forward
from gpr_kinematics.robot.inverse import solve_stations
from gpr_kinematics.robot.stations import Stations
from robot_support import ROBOT, ClientStandIn, NoServerStandInError
from test_core_cli import run, run_json  # the core CLI tests' helpers: main() in-process, one JSON line

PROGRAM = str(config_path('programs/example_robot_program.yaml'))


def test_ik_json_has_the_documented_keys_and_the_core_numbers(capsys):
    d = run_json(capsys, 'robot', 'ik', '--position', '1300', '600', '450', '--tilt', '1.2', '--azimuth', '30',
                 '--heading', '20', '--mm', '--deg')
    assert set(d) >= {'rods', 'arm', 'wafer', 'platform', 'naive_wafer_error'}
    assert len(d['rods']) == 3 and list(d['arm']) == ['arm1_shoulder', 'arm1_elbow', 'arm1_wrist']
    for key in ('wafer', 'platform'):
        assert set(d[key]) == {'position', 'quaternion'} and len(d[key]['quaternion']) == 4
    st = Stations.of([[1.3, 0.6, 0.45]], math.radians(1.2), math.radians(30), math.radians(20))
    sol = solve_stations(ROBOT, st)
    np.testing.assert_allclose(d['rods'], sol.rods[0], atol=1e-15)
    np.testing.assert_allclose(list(d['arm'].values()), sol.joints[0], atol=1e-15)
    np.testing.assert_allclose(d['wafer']['position'], [1.3, 0.6, 0.45], atol=1e-12)
    assert d['naive_wafer_error'] == pytest.approx(sol.naive_wafer_error_norm[0], abs=1e-18)
    assert 1e-6 < d['naive_wafer_error'] < 1e-4 and d['branch'] == 'right'
    left = run_json(capsys, 'robot', 'ik', '--position', '1.3', '0.6', '0.45', '--heading', '0.3', '--branch', 'left')
    right = run_json(capsys, 'robot', 'ik', '--position', '1.3', '0.6', '0.45', '--heading', '0.3', '--branch', 'right')
    assert left['arm']['arm1_elbow'] == pytest.approx(-right['arm']['arm1_elbow'], abs=1e-12)
    d2 = run_json(capsys, 'robot', 'ik', '--position', '1.3', '0.6', '0.6', '--heading', '0.3', '--arm', 'arm2',
                  '--redundancy', '0.2')
    assert d2['arm']['arm2_wrist'] == pytest.approx(0.2, abs=1e-15)


def test_fk_json_matches_the_core(capsys):
    d = run_json(capsys, 'robot', 'fk', '--rods', '250', '251', '252', '--joints', '0', '60', '-30', '--mm', '--deg')
    fk = robot_forward(ROBOT, [[0.25, 0.251, 0.252]], [[0.0, math.radians(60), math.radians(-30)]])
    np.testing.assert_allclose(d['wafer']['position'], fk.wafer.position[0], atol=1e-15)
    np.testing.assert_allclose(d['platform']['quaternion'], fk.platform.quaternion[0], atol=1e-15)
    assert d['naive_wafer_error'] == pytest.approx(fk.naive_wafer_error_norm[0], abs=1e-18)
    assert set(d['station']) == {'position', 'tilt', 'azimuth', 'heading'}
    # fk then ik comes back
    st = d['station']
    back = run_json(capsys, 'robot', 'ik', '--position', *map(str, st['position']), '--tilt', str(st['tilt']),
                    '--azimuth', str(st['azimuth']), '--heading', str(st['heading']))
    np.testing.assert_allclose(back['rods'], [0.25, 0.251, 0.252], atol=1e-12)
    np.testing.assert_allclose(list(back['arm'].values()), [0.0, math.radians(60), math.radians(-30)], atol=1e-9)


def test_a_misspelt_step_kind_is_named(capsys, tmp_path):
    text = Path(PROGRAM).read_text().replace('{pick: load_port_1}', '{pik: load_port_1}', 1)
    program = tmp_path / 'typo.yaml'
    program.write_text(text.replace('robot: ../robots/', f'robot: {Path(PROGRAM).parent.parent}/robots/'))
    status, out, err = run(capsys, 'program', 'check', str(program))
    assert status == 2 and out == '' and err.count('\n') == 1, err
    assert re.search(r'typo.yaml: steps\[1\]: unknown key\(s\) pik; allowed keys: arm, branch, dwell, move, pick, '
                     r'place, time \(a step gives exactly one of move, pick, place, dwell\)$', err.strip()), err


def test_teach_and_reteach(capsys, tmp_path):
    d = run_json(capsys, 'robot', 'teach', '--rods', '0.25', '0.251', '0.252', '--joints', '0', '1', '-0.5')
    assert d['reteach'] is False and len(d['stations']) == 1 and d['stations'][0]['naive_error'] > 1e-6
    table = tmp_path / 'old.csv'
    table.write_text('name,rod_1 [mm],rod_2 [mm],rod_3 [mm],arm1_shoulder [deg],arm1_elbow [deg],'
                     'arm1_wrist [deg]\na,250,251,252,0,57.29577951308232,-28.64788975654116\n'
                     'b,300,299,301,20,40,-10\n')
    r = run_json(capsys, 'robot', 'teach', '--table', str(table), '--naive')
    assert [s['name'] for s in r['stations']] == ['a', 'b']
    first = r['stations'][0]
    assert first['avoided_error'] == pytest.approx(d['stations'][0]['naive_error'], rel=1e-6)
    status, out, _ = run(capsys, 'robot', 'teach', '--table', str(table))
    assert status == 0 and out.startswith('a: station (') and '\nb: station (' in out


@pytest.mark.parametrize('naive', [(), ('--naive',)])
def test_a_bad_row_of_a_joint_table_is_located(capsys, tmp_path, naive):
    # It said "q2 = 0.6 m (sample 1) is outside the stroke" (0-based, no file, no name), and rod_2 with --naive.
    header = 'name,rod_1,rod_2,rod_3,arm1_shoulder,arm1_elbow,arm1_wrist\n'
    table = tmp_path / 'old.csv'
    table.write_text(header + 's1,0.25,0.251,0.252,0,1,-0.5\ns2,0.25,0.6,0.252,0,1,-0.5\n')
    status, out, err = run(capsys, 'robot', 'teach', '--table', str(table), *naive)
    assert status == 2 and out == '' and err.count('\n') == 1, err
    assert re.search(r"old.csv: line 3 \(row 2, station 's2'\): rod_2 = 0.6 m is outside the stroke "
                     r'\[0, 0.508\] m$', err.strip()), err
    table.write_text(header.replace('name,', '') + '0.25,0.251,0.252,0,1,-0.5\n# a comment\n0.25,0.6,0.252,0,1,-0.5\n')
    status, out, err = run(capsys, 'robot', 'teach', '--table', str(table), *naive)
    assert status == 2 and re.search(r'old.csv: line 4 \(row 2\): rod_2 = 0.6 m is outside', err), err


def test_degrees_in_a_joint_table_without_units_get_a_hint(capsys, tmp_path):
    table = tmp_path / 'deg.csv'
    table.write_text('name,rod_1,rod_2,rod_3,arm1_shoulder,arm1_elbow,arm1_wrist\n'
                     's1,0.25,0.251,0.252,0,57.2957795,-0.5\n')
    status, out, err = run(capsys, 'robot', 'teach', '--table', str(table))
    assert status == 2 and out == '' and err.count('\n') == 1, err
    assert re.search(r"deg.csv: line 2 \(row 1, station 's1'\): arm1_elbow = 57.2957795 rad is beyond its upper "
                     r'limit 2.9 rad by 54.4 rad; allowed: \[-2.9, 2.9\] rad; in degrees it would be within: give the '
                     r'column its unit, "arm1_elbow \[deg\]", or a "# units: deg" line before the header$',
                     err.strip()), err
    table.write_text('rod_1,rod_2,rod_3,arm1_shoulder,arm1_elbow,arm1_wrist\n0.25,0.251,0.252,0,500,0\n')
    status, out, err = run(capsys, 'robot', 'teach', '--table', str(table))  # beyond as degrees too: no hint
    assert status == 2 and err.rstrip().endswith('arm1_elbow = 500 rad is beyond its upper limit 2.9 rad by 497 rad; '
                                                 'allowed: [-2.9, 2.9] rad'), err
    # rods in millimetres, likewise (it had no hint)
    table.write_text('rod_1,rod_2,rod_3,arm1_shoulder,arm1_elbow,arm1_wrist\n250,251,252,0,1,-0.5\n')
    status, out, err = run(capsys, 'robot', 'teach', '--table', str(table))
    assert status == 2 and err.rstrip().endswith('rod_1 = 250 m is outside the stroke [0, 0.508] m; in millimetres '
                                                 'it would be within: give the column its unit, "rod_1 [mm]", or a '
                                                 '"# units: mm" line before the header'), err
    # --deg and --mm convert --rods and --joints; they were ignored with a table
    status, out, err = run(capsys, 'robot', 'teach', '--table', str(table), '--deg')
    assert status == 2 and err.count('\n') == 1 and re.search(r'--deg converts --rods and --joints; a --table gives '
                                                                r'its units in its header', err), err
    # ... in this robot's names (the example's were printed for every robot)
    import yaml
    from gpr_kinematics.robot import load_robot
    data = yaml.safe_load(Path(load_robot().source).read_text(encoding='utf-8'))
    data['rods']['names'] = ['r1', 'r2', 'r3']
    mine = tmp_path / 'mine.yaml'
    mine.write_text(yaml.safe_dump(data), encoding='utf-8')
    status, out, err = run(capsys, 'robot', 'teach', '--robot', str(mine), '--arm', 'arm2', '--table', str(table),
                           '--mm')
    assert status == 2 and 'units in its header ("r1 [mm]", "arm2_hand [deg]")' in err, err


def test_degrees_in_a_column_without_unit_are_refused_with_naive(capsys, tmp_path):
    """--naive held the old joints to +-1e6 rad only: arm1_elbow 57.2957795 (1 rad in degrees) was re-taught as 57
    rad. More than a turn beyond its limits it is refused, naming the column, line, row and value, and the unit."""
    table = tmp_path / 'deg.csv'
    table.write_text('name,rod_1,rod_2,rod_3,arm1_shoulder,arm1_elbow,arm1_wrist\n'
                     's1,0.25,0.251,0.252,0,1,-0.5\ns2,0.25,0.251,0.252,0,57.2957795,-0.5\n')
    status, out, err = run(capsys, 'robot', 'teach', '--table', str(table), '--naive')
    assert status == 2 and out == '' and err.count('\n') == 1, err
    assert err.strip().endswith("deg.csv: line 3 (row 2, station 's2'): arm1_elbow = 57.2957795 rad is more than a "
                                'turn (2 pi) beyond its upper limit 2.9 rad, no posture of it (another unit?); allowed '
                                'for old joints: [-9.18318531, 9.18318531] rad; in degrees? give the column its unit, '
                                '"arm1_elbow [deg]", or a "# units: deg" line before the header'), err
    table.write_text(table.read_text().replace('arm1_elbow,', 'arm1_elbow [deg],').replace(',1,', ',57.2957795,'))
    r = run_json(capsys, 'robot', 'teach', '--table', str(table), '--naive')   # with its unit: re-taught
    assert [s['arm']['arm1_elbow'] for s in r['stations']] == [pytest.approx(1.0, abs=1e-5)] * 2
    status, out, err = run(capsys, 'robot', 'teach', '--rods', '0.25', '0.251', '0.252', '--joints', '0', '57.3', '0',
                           '--naive')
    assert status == 2 and 'old joints: arm1_elbow = 57.3 rad is more than a turn' in err, err


def test_program_check_and_export(capsys, tmp_path):
    s = run_json(capsys, 'program', 'check', PROGRAM)
    assert (s['stations'], s['steps'], s['waypoints']) == (5, 10, 21)
    assert max(s['velocity_usage']) == pytest.approx(1.0) and s['duration'] > 10
    assert s['max_naive_wafer_error_at'].startswith('steps[')
    e = run_json(capsys, 'program', 'export', PROGRAM, '--waypoints', str(tmp_path / 'w.csv'), '--samples',
                 str(tmp_path / 's.json'), '--rate', '20')
    assert (tmp_path / 'w.csv').read_text().count('\n') == 22
    doc = json.loads((tmp_path / 's.json').read_text())
    assert len(doc['rows']) == e['sample_count'] and doc['rate'] == 20.0
    # The paths written have keys of their own: 'waypoints' stays the count of check.
    assert (e['waypoints'], e['waypoints_file'], e['samples_file']) == (21, str(tmp_path / 'w.csv'),
                                                                        str(tmp_path / 's.json'))
    status, out, _ = run(capsys, 'program', 'check', PROGRAM)
    assert status == 0 and 'every waypoint reachable, every move within the limits' in out


@pytest.mark.parametrize('argv, pattern', [
    (['robot', 'ik', '--position', '3', '0.5', '0.45', '--heading', '0'],
     r'^gpr robot ik: error: station 0: out of reach of arm arm1: the wrist axis would be 2.05 m'),
    (['robot', 'ik', '--position', '1.2', '0.5', '0.45'],
     r'^gpr robot ik: error: --heading is missing: arm arm1 has 3 joints and needs the blade heading; allowed: '
     r'--heading H \[rad, or deg with --deg\] \(free only for a 2-joint arm\)$'),
    # a position in mm typed as m (it said only how far above the stroke the rods would be)
    (['robot', 'ik', '--position', '1300', '600', '450', '--heading', '0.3'],
     r'--position = \(1300, 600, 450\) m; allowed: each coordinate within \+-100 m of the world origin \(millimetres\? '
     r'give --mm\)$'),
    (['robot', 'ik', '--position', '1.2', '0.5', '0.45', '--heading', 'nan'],
     r'^gpr robot ik: error: --heading = nan'),
    (['robot', 'ik', '--position', '1.2', '0.5', '0.45', '--heading', '0', '--tilt', '3', '--deg'],
     r'beyond the tilt limit 2 deg by 1 deg'),
    # a tilt in degrees typed as radians: the hint (none for 0.05 rad just beyond the limit)
    (['robot', 'ik', '--position', '1.2', '0.5', '0.6', '--heading', '0', '--tilt', '1'],
     r'tilts 57.2958 deg in gpr_base, beyond the tilt limit 2 deg by 55.3 deg \(0.965 rad\); a tilt of 1 deg would be '
     r'within it: degrees given as radians\?$'),
    (['robot', 'ik', '--position', '1.2', '0.5', '0.6', '--heading', '0', '--tilt', '0.05'],
     r'tilts 2.86479 deg in gpr_base, beyond the tilt limit 2 deg by 0.865 deg \(0.0151 rad\)$'),
    (['robot', 'ik', '--position', '1.2', '0.5', '0.45', '--heading', '0', '--arm', 'arm7'],
     r"^gpr robot ik: error: .*no arm 'arm7'; allowed: arm1, arm2"),
    (['robot', 'ik', '--position', '1.2', '0.5', '0.45', '--heading', '0', '--redundancy', '0.1'],
     r'a redundancy value applies to 4-joint arms under the fixed_joint rule'),
    (['robot', 'ik', '--position', '1.2', '0.5'], r'^gpr robot ik: error: argument --position: expected 3'),
    # degrees typed as radians used to run, wrapped
    (['robot', 'ik', '--position', '1.3', '0.6', '0.45', '--tilt', '0.02', '--azimuth', '30', '--heading', '20'],
     r'^gpr robot ik: error: --azimuth = 30 rad is outside \[-2pi, 2pi\] rad; allowed: an angle in radians \(give '
     r'--deg for degrees\)$'),
    (['robot', 'ik', '--position', '1.3', '0.6', '0.45', '--heading', '20'],
     r'^gpr robot ik: error: --heading = 20 rad is outside \[-2pi, 2pi\] rad'),
    (['robot', 'ik', '--position', '1.3', '0.6', '0.45', '--heading', '-361', '--deg'],
     r'^gpr robot ik: error: --heading = -361 deg is outside \[-360, 360\] deg'),
    # a held joint's value in degrees typed as radians: 30 rad ran as 30 - 10 pi = -1.416 rad, silently
    (['robot', 'ik', '--position', '1.3', '0.6', '0.45', '--heading', '0.3', '--arm', 'arm2', '--redundancy', '30'],
     r'^gpr robot ik: error: --redundancy = 30 rad is outside \[-2pi, 2pi\] rad; allowed: an angle in radians '
     r'\(give --deg for degrees\)$'),
    # beyond the held joint's limits, named as typed in the unit typed (it said "redundancy value = 5.23599 rad
    # (station 0)" of --redundancy 300 --deg)
    (['robot', 'ik', '--position', '1.3', '0.6', '0.6', '--heading', '17', '--deg', '--arm', 'arm2', '--redundancy',
      '300'], r'^gpr robot ik: error: --redundancy = 300 deg is outside the limits of arm2_wrist, \[-143\.239, '
              r'143\.239\] deg; allowed: a value within them; 300 deg is -60 deg modulo a turn$'),
    (['robot', 'fk', '--rods', '0.3', '0.3', '0.3', '--joints', '0', '0'],
     r'^gpr robot fk: error: --joints: 2 values for arm arm1, which has 3 joints \(arm1_shoulder, arm1_elbow, '
     r'arm1_wrist\); allowed: one value per joint, shoulder first$'),
    (['robot', 'fk', '--rods', '0.3', '0.3', '0.9', '--joints', '0', '0', '0'], r'rod_3 = 0.9 m is outside the '
                                                                                  r'stroke'),
    (['robot', 'teach'], r'give the joints: --rods Q1 Q2 Q3 and --joints J1 J2 \[J3 J4\], or --table FILE'),
    (['robot', 'fk', '--rods', '0.3', '0.3', '0.3', '--joints', '0', '0', '0', '--robot', '/nonexistent.yaml'],
     r"robot description file '/nonexistent.yaml' not found \(a path with a folder is read as given"),
    (['program', 'check', str(config_path('programs/example_stations.yaml'))], r'this is a platform program'),
    (['program', 'check', '/'], r"program file '/'"),  # a directory, not a program
    (['program', 'check', PROGRAM, '--plot', '/tmp'], r"--plot '/tmp' is a folder; allowed: a .png file"),
    (['program', 'export', PROGRAM], r'nothing to export: give --waypoints FILE and/or --samples FILE'),
    (['program', 'export', PROGRAM, '--trajectory', '/tmp/t.csv'],
     r"--trajectory '/tmp/t.csv' has another suffix; allowed: a .yaml"),
    (['program', 'export', PROGRAM, '--trajectory', '/proc/t.yaml'], r'trajectory'),
    (['program', 'export', PROGRAM, '--trajectory', '/tmp/t.yaml', '--lead-in', '-1'], r'--lead-in = -1 s'),
    (['program', 'send', PROGRAM, '--timeout', '0'], r'--timeout = 0 s; allowed: 0 < timeout'),
    (['program', 'send', str(config_path('programs/example_stations.yaml'))], r'this is a platform program'),
    (['program', 'export', PROGRAM, '--samples', '/tmp/x.csv', '--rate', '0'], r'--rate = 0 Hz is invalid'),
    (['program', 'export', PROGRAM, '--waypoints', '/tmp/x.csv', '--rate', '99999'], r'--rate = 99999 Hz is invalid'),
    (['program', 'send', PROGRAM, '--rate', '5001'], r'--rate = 5001 Hz is invalid'),
    (['program', 'export', PROGRAM, '--waypoints', '/proc'], r'/proc exists and is not a regular file'),
    (['program', 'export', PROGRAM, '--waypoints', ''], r'joint table output path is empty'),
    (['program', 'check', ''], r'program file path is empty'),
    (['program', 'export', PROGRAM, '--waypoints', '/tmp/gpr_w.csv', '--samples', '/tmp/gpr_w.csv'],
     r"--waypoints '/tmp/gpr_w.csv' and --samples '/tmp/gpr_w.csv' are the same file"),  # one table was lost
    (['program', 'export', PROGRAM, '--waypoints', '/tmp/gpr_w.csv', '--samples', '/tmp/../tmp/gpr_w.csv'],
     r'are the same file; allowed: a file of its own for each output'),
    (['program', 'export', PROGRAM, '--samples', '/tmp/gpr_s.csv', '--lead-in', '5'],
     r'--lead-in applies to --trajectory FILE.yaml, which is not given'),  # was ignored
    (['robot', 'fk', '--rods', '0.3', '0.3', '0.3', '--joints', '0', '0', '0', '--robot', ''],
     r'robot file path is empty'),
])
def test_errors_exit_2_with_one_line(capsys, argv, pattern):
    status, out, err = run(capsys, *argv)
    assert status == 2 and out == ''
    assert err.count('\n') == 1 and 'Traceback' not in err
    assert re.search(pattern, err), err


def test_an_error_names_the_whole_command(capsys):
    """The errors of a subcommand of a group were prefixed by the group (`gpr robot: error:` for `gpr robot teach`)
    while argparse's usage errors named the whole command: both name it, for every command of every group."""
    import argparse

    from gpr_kinematics.cli import main as cli

    def commands(parser, typed, dests):
        sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
        if sub is None:
            return [(typed, dests)]
        return [c for name, p in sub.choices.items() for c in commands(p, [*typed, name], {**dests, sub.dest: name})]

    parser = cli.build_parser()
    found = commands(parser, ['gpr'], {})
    assert {'gpr robot teach', 'gpr program send', 'gpr fk', 'gpr verify'} <= {' '.join(t) for t, _ in found}
    for typed, dests in found:
        assert cli.command_path(parser, argparse.Namespace(**dests)) == ' '.join(typed)
    assert cli.command_path(parser, argparse.Namespace(command='robot', robot_command=None)) == 'gpr robot'
    for argv, line in ((['robot', 'teach'], 'gpr robot teach: error: give the joints: --rods Q1 Q2 Q3 and --joints '
                                            'J1 J2 [J3 J4], or --table FILE\n'),
                       (['program', 'check', ''], 'gpr program check: error: program file path is empty; allowed: the '
                                                  'path of a file\n')):
        assert run(capsys, *argv) == (2, '', line)


@pytest.mark.parametrize('options, topic, action, where', [
    (['--namespace', 'r3'], '/r3/joint_states', '/r3/joint_trajectory_controller/follow_joint_trajectory',
     ('--joint-states and --namespace', '--action and --namespace')),
    (['--namespace', '/r3', '--joint-states', '~/js', '--action', '/arm/follow'], '/r3/gpr_program_send/js',
     '/arm/follow', ('--joint-states and --namespace', '--action')),
])
@pytest.mark.slow
def test_send_names_the_full_name_it_waited_on_and_how_to_change_it(capsys, monkeypatch, options, topic, action, where):
    """`gpr program send --namespace r3` without a server said 'no FollowJointTrajectory server on
    joint_trajectory_controller/follow_joint_trajectory within 10 s' (no joint_states: 'no joint_states with the
    joints ...'): not the names waited on (/r3/...), nor how to change them. The ROS client is stood in for here
    (test_ros_program_send runs the real one); the names are expanded by rclpy's rules."""
    pytest.importorskip('rclpy')
    from gpr_kinematics.cli import program_send as cli_program
    from gpr_kinematics.robot.controller import ControllerJoints

    seen = {}
    rest = ControllerJoints.of(ROBOT).rest

    def positions(client, names, topic, timeout):
        seen.update(client=(client.name, client.namespace), topic=topic, names=tuple(names))
        return seen.get('current')

    def follow(client, goal, action, timeout, progress, found):
        seen['action'] = action
        raise NoServerStandInError(action)

    fake = type('tc', (), {'GprClient': ClientStandIn, 'current_positions': staticmethod(positions),
                           'other_robot_there': staticmethod(lambda client, robot: None),   # no description there
                           'follow_trajectory': staticmethod(follow), 'NoServerError': NoServerStandInError,
                           'ServiceTimeoutError': TimeoutError})
    monkeypatch.setattr(cli_program, '_ros_modules', lambda: fake)
    argv = ['program', 'send', PROGRAM, '--rate', '10', '--timeout', '0.5', *options]
    status, out, err = run(capsys, *argv)
    joints = ', '.join(seen['names'])
    assert (status, out, seen['topic'], seen['client']) == (1, '', topic, ('gpr_program_send', options[1]))
    assert err == (f'gpr program send: no joint states with the joints {joints} on {topic} within 0.5 s: cannot tell '
                   f'where the robot is (change the name with {where[0]}, the wait with --timeout)\n')
    assert joints.startswith('rod_1, rod_2, rod_3, ')
    seen['current'] = rest
    status, out, err = run(capsys, *argv)
    assert (status, seen['action'], out) == (1, action, '')   # not 'sending ...' before a server was found
    assert err == (f'gpr program send: no FollowJointTrajectory server on {action} within 0.5 s (change the name with '
                   f'{where[1]}, the wait with --timeout)\n')
    # the JSON result names the action as resolved, as the text line does (it gave the name as typed)
    outcome = type('Outcome', (), dict(status='succeeded', error_code=0, error_name='SUCCESSFUL', error_string='',
                                       feedback=3))
    monkeypatch.setattr(fake, 'follow_trajectory', staticmethod(lambda *a: outcome), raising=False)
    status, out, err = run(capsys, *argv, '--json')
    assert (status, json.loads(out)['action']) == (0, action)
    # the goal's line once the server is found (follow_trajectory's ``found``), then the result
    monkeypatch.setattr(fake, 'follow_trajectory', staticmethod(lambda *a: (a[-1](), outcome)[1]), raising=False)
    status, out, err = run(capsys, *argv)
    lines = out.splitlines()
    assert status == 0 and len(lines) == 2 and lines[0].startswith('sending ') and lines[0].endswith(f' to {action}')
    assert lines[1] == 'succeeded (error_code 0 SUCCESSFUL)'


def test_console_script_without_traceback(tmp_path):
    bad = tmp_path / 'robot.yaml'
    bad.write_text('rods: {velocity: 0.1, acceleration: 0.5}\narms: [{name: arm1, joints: 5}]\n')
    res = subprocess.run([sys.executable, '-m', 'gpr_kinematics.cli.main', 'robot', 'fk', '--rods', '0.3', '0.3', '0.3',
                          '--joints', '0', '0', '--robot', str(bad)], capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and res.stdout == ''
    assert res.stderr.startswith('gpr robot fk: error: ') and 'joints must be a list of 2 to 4' in res.stderr
    assert res.stderr.count('\n') == 1


def test_export_refuses_too_many_samples_before_writing(capsys, tmp_path):
    """The waypoint table was written, then the samples refused (the cell program at 4000 Hz: 238,328 samples); the
    count is checked once the moves are timed, before any output."""
    cell = str(config_path('programs/example_cell_program.yaml'))
    status, out, err = run(capsys, 'program', 'export', cell, '--waypoints', str(tmp_path / 'w.csv'), '--samples',
                           str(tmp_path / 's.csv'), '--rate', '4000')
    assert status == 2 and out == '' and err.count('\n') == 1
    assert 'the program lasts 59.582 s: at 4000 Hz that is 238329 samples; allowed: at most 200000' in err
    assert list(tmp_path.iterdir()) == []


def test_program_export_trajectory(capsys, tmp_path):
    """--trajectory: the program's samples at the rate as trajectory_msgs/JointTrajectory YAML (the rods as the
    robot model names them), the same times and joint values as --samples; --lead-in shifts every point."""
    import yaml

    e = run_json(capsys, 'program', 'export', PROGRAM, '--samples', str(tmp_path / 's.json'), '--trajectory',
                 str(tmp_path / 't.yaml'), '--rate', '5')
    doc = json.loads((tmp_path / 's.json').read_text())
    traj = yaml.safe_load((tmp_path / 't.yaml').read_text())
    assert e['trajectory_file'] == str(tmp_path / 't.yaml') and e['trajectory_points'] == len(doc['rows'])
    names = doc['columns'][3:3 + 10]
    assert traj['joint_names'] == ['rod_1', 'rod_2', 'rod_3', *names[3:]]
    rows = np.array([r[3:13] for r in doc['rows']])
    assert np.array_equal(np.array([p['positions'] for p in traj['points']]), rows)
    t = np.array([p['time_from_start']['sec'] + p['time_from_start']['nanosec'] / 1e9 for p in traj['points']])
    np.testing.assert_allclose(t, [r[0] for r in doc['rows']], rtol=0, atol=5e-10)
    assert e['trajectory_duration'] == pytest.approx(doc['rows'][-1][0])
    later = run_json(capsys, 'program', 'export', PROGRAM, '--trajectory', str(tmp_path / 'l.yaml'), '--rate', '5',
                     '--lead-in', '2.5')
    shifted = yaml.safe_load((tmp_path / 'l.yaml').read_text())['points']
    assert later['trajectory_duration'] == pytest.approx(e['trajectory_duration'] + 2.5)
    assert shifted[0]['time_from_start'] == {'sec': 2, 'nanosec': 500_000_000}
    assert [p['positions'] for p in shifted] == [p['positions'] for p in traj['points']]


@pytest.mark.slow
def test_a_trajectory_the_controller_refuses_is_neither_written_nor_sent(capsys, tmp_path):
    """At 5 Hz the cubic between the cell program's points overshoots rod_1's velocity limit by 1.05 % (the controller
    allows 1 %): the file was written and robot_simulator_node refused it. It is refused before anything is written,
    with the controller's words; at 10 Hz the trajectory is written and the controller's check takes it."""
    import yaml
    from gpr_kinematics.robot.controller import ControllerJoints, Tolerances, plan_motion, trajectory_from_points
    from gpr_kinematics.robot.description import load_robot

    cell = str(config_path('programs/example_cell_program.yaml'))
    status, out, err = run(capsys, 'program', 'export', cell, '--trajectory', str(tmp_path / 't.yaml'), '--waypoints',
                           str(tmp_path / 'w.csv'), '--rate', '5')
    assert status == 2 and out == '' and err.count('\n') == 1 and list(tmp_path.iterdir()) == []
    assert err.startswith('gpr program export: error: at --rate 5 Hz a controller refuses the trajectory: sample 753 '
                          '(t = 7.53 s): rod_1 moves at 0.151568 m/s (the spline between the points overshoots)'), err
    assert err.endswith('(a higher --rate gives it more points)\n')
    status, _, err = run(capsys, 'program', 'export', cell, '--trajectory', str(tmp_path / 't.yaml'), '--rate', '10')
    assert status == 0, err
    doc = yaml.safe_load((tmp_path / 't.yaml').read_text())
    robot = load_robot(config_path('robots/example_robot.yaml'))
    joints = ControllerJoints.of(robot)
    points = doc['points']
    times = [p['time_from_start']['sec'] + p['time_from_start']['nanosec'] * 1e-9 for p in points]
    traj = trajectory_from_points(joints, doc['joint_names'], times, [p['positions'] for p in points],
                                  [p['velocities'] for p in points], [[]] * len(points))
    current = joints.rest.copy()
    current[joints.indices(traj.joint_names)] = traj.positions[0]
    plan_motion(joints, traj, current, 100.0, robot.config, Tolerances.uniform(len(joints.names), 0.0, 0.0, 0.0),
                0.0)   # taken


def test_program_send_refuses_what_the_controller_would_before_it_looks_for_ros(capsys):
    """gpr program send checks its trajectory as export does, before it needs ROS: the cell program at 5 Hz."""
    cell = str(config_path('programs/example_cell_program.yaml'))
    status, out, err = run(capsys, 'program', 'send', cell, '--rate', '5', '--timeout', '0.1')
    assert status == 2 and out == '' and err.count('\n') == 1
    assert err.startswith('gpr program send: error: at --rate 5 Hz a controller refuses the trajectory: sample '
                          '753 '), err


@pytest.mark.slow
def test_a_trajectory_whose_spline_leaves_the_checked_program_is_refused_with_a_cell_and_without(capsys, tmp_path):
    """At 0.3 Hz the cell program's 19 points pass the controller's checks, but their spline put arm2's blade 8.7 mm
    into pm2's wall (the program checks safe, 6.09 mm): refused in the program's cell with the pair, its least
    distance and the instant (it quoted a bound of the search, -685 mm).
    Without a cell, the example program at 0.1 Hz (4 points, 3.5 rad from the program, none of its stations) was
    written without a word, then with a warning: refused, as is its spline at 0.2 Hz, which puts arm2's link into a
    wafer the program places (no self-clearance of the spline was checked without a cell)."""
    cell = str(config_path('programs/example_cell_program.yaml'))
    status, out, err = run(capsys, 'program', 'export', cell, '--trajectory', str(tmp_path / 't.yaml'), '--rate', '0.3')
    assert status == 2 and out == '' and list(tmp_path.iterdir()) == []
    assert err.startswith("gpr program export: error: at --rate 0.3 Hz the spline between the trajectory's points "
                          'leaves the checked program: arm2_blade and pm2/front_bottom come to -8.670 mm at t = '
                          '37.820 s, steps[9] (place pm2, exit), within the margin of 2 mm in cell '), err
    assert '(the program itself keeps it)' in err
    assert err.endswith('; allowed: a higher --rate (points closer together follow the program)\n')
    status, out, err = run(capsys, 'program', 'export', PROGRAM, '--trajectory', str(tmp_path / 't.yaml'), '--rate',
                           '0.1')
    assert status == 2 and out == '' and list(tmp_path.iterdir()) == []
    assert err == ("gpr program export: error: at --rate 0.1 Hz the spline between the trajectory's points leaves "
                   'the program by up to 3.47 rad (arm1_shoulder at t = 4.520 s), not the program checked; allowed: at '
                   "most 0.001 m or rad (a robot simulator's goal tolerance), at a higher --rate (points closer "
                   'together follow the program)\n'), err
    status, out, err = run(capsys, 'program', 'export', PROGRAM, '--trajectory', str(tmp_path / 't.yaml'), '--rate',
                           '0.2')
    assert status == 2 and out == '' and list(tmp_path.iterdir()) == []
    assert err.startswith("gpr program export: error: at --rate 0.2 Hz the spline between the trajectory's points "
                          'leaves the checked program: arm2_link4 and wafer@chamber_a:steps[5] come to -6.672 mm at '
                          't = 22.479 s, steps[7] (place load_port_1, approach), within the margin of 2 mm against '
                          'the robot itself (no cell) (the program itself keeps it); allowed: a higher --rate'), err
    status, _, err = run(capsys, 'program', 'export', PROGRAM, '--trajectory', str(tmp_path / 't.yaml'), '--rate', '5')
    assert status == 0 and err == ''   # within 1e-3 of the program at 5 Hz


def _moved_cell_program(tmp_path):
    """The example cell program with its chamber pm1 25 mm to the side, as a user might edit it: arm2's wafer hits
    pm1's front (gpr program check: -5.049 mm at 26.607 s)."""
    text = config_path('programs/example_cell_program.yaml').read_text()
    old = 'position: [1450, 500, 720], tilt: 1.5, azimuth: 120, heading: 0, entry: 330'
    assert old in text
    text = text.replace(old, old.replace('500', '525')).replace('../robots/', f'{config_path("robots")}/')
    program = tmp_path / 'moved.yaml'
    program.write_text(text.replace('../cells/', f'{config_path("cells")}/'))
    return program


@pytest.mark.parametrize('rate', ['1000', '0.3'])
@pytest.mark.slow
def test_a_program_unsafe_in_its_cell_is_named_so_not_its_rate(capsys, tmp_path, rate):
    """A program whose own motion collides was refused for --trajectory as 'the spline ... leaves the checked
    program' at every rate, with the advice of a higher --rate and a bound of -582.560 mm: the program is named, with
    the least distance gpr program check gives, and check's status 1 (it was 2, bad input, at every rate)."""
    program = _moved_cell_program(tmp_path)
    status, out, err = run(capsys, 'program', 'export', str(program), '--trajectory', str(tmp_path / 't.yaml'),
                           '--rate', rate)
    assert status == 1 and out == '' and not (tmp_path / 't.yaml').exists()
    # the wafer glides along the wall at that distance: the instant is any of the glide's (15.047 s on the stock
    # versions, 26.607 s on the pinned ones)
    # with the step there and the first pair below the margin, when and where (the refusal named the deepest
    # contact's instant alone)
    assert re.fullmatch(r'gpr program export: error: the program itself is not safe in cell '
                        + re.escape(f'{config_path("cells")}/example_cell.yaml') + r': arm2_wafer and pm1/front_left '
                        r'come to -5\.049 mm at t = (1[5-9]|2[0-6])\.\d{3} s, steps\[\d+\] \([a-z_ 0-9,]+\), '
                        r'within the margin of 2 mm \(\d pair\(s\) below it, the first \S+ and \S+ at t = '
                        r'\d+\.\d{3} s, steps\[\d+\] \([a-z_ 0-9,]+\)\) \(no --rate helps\); allowed: a program gpr '
                        r'program check finds safe \(it names every pair and move\)\n', err), err
    status, out, _ = run(capsys, 'program', 'check', str(program), '--no-progress')
    assert status == 1 and re.search(r'arm2_wafer / pm1/front_left +-5\.049 +(1[5-9]|2[0-6])\.\d{3}', out), out
    if rate == '1000':   # the joint tables drive a controller too: written with exit 0 for this program before
        status, out, err2 = run(capsys, 'program', 'export', str(program), '--samples', str(tmp_path / 's.csv'),
                                '--waypoints', str(tmp_path / 'w.csv'), '--rate', '10')
        assert (status, out) == (1, '') and err2.startswith('gpr program export: error: the program itself is not '
                                                            'safe in cell '), err2
        assert not (tmp_path / 's.csv').exists() and not (tmp_path / 'w.csv').exists()


def _variant(tmp_path, robot_edit=None, gpr_line='', cell=True):
    """The example cell program (or, ``cell=False``, the example robot program) on a copy of the example robot with
    ``robot_edit`` (old, new) applied and ``gpr_line`` (``key: value``) added to its ``gpr`` section."""
    robot = config_path('robots/example_robot.yaml').read_text()
    if robot_edit is not None:
        assert robot.count(robot_edit[0]) == 2
        robot = robot.replace(*robot_edit)
    robot = robot.replace('  model: radial ', f'  {gpr_line}\n  model: radial ' if gpr_line else '  model: radial ')
    (tmp_path / 'robot.yaml').write_text(robot)
    name = 'example_cell_program' if cell else 'example_robot_program'
    text = config_path(f'programs/{name}.yaml').read_text()
    text = text.replace('../robots/example_robot.yaml', str(tmp_path / 'robot.yaml'))
    program = tmp_path / 'program.yaml'
    program.write_text(text.replace('../cells/', f'{config_path("cells")}/'))
    return program


@pytest.mark.slow
def test_a_program_whose_wafer_slips_is_not_written_or_sent_as_a_trajectory(capsys, tmp_path):
    """The example cell program on blades of friction 0.1 (0.3 shipped): gpr program check finds it NOT safe (the
    wafer slips, ratio 2.259 = 3 x 0.753), yet --trajectory wrote it and send sent it (5,960 points) without a word:
    refused now as a collision was, naming the slip where check does, with check's status 1 for an unsafe program
    (it was 2, bad input): one line, no output written (the tables neither: all or none), nothing on stdout."""
    program = _variant(tmp_path, ('friction: 0.3', 'friction: 0.1'))
    status, out, _ = run(capsys, 'program', 'check', str(program), '--no-progress')
    assert status == 1 and ('  UNSAFE: the wafer slips on the blade (ratio 2.259 >= 1) at 54.683 s, steps[14] (place '
                            "load_port_1, approach); the ratio is lowered by lower acceleration limits of the arm's "
                            "joints or blades of more friction (a longer 'time' on a move lowers its cruise speed, not "
                            "its accelerations; a straight entry takes none)") in out.splitlines(), out
    status, out, err = run(capsys, 'program', 'export', str(program), '--samples', str(tmp_path / 's.csv'))
    assert (status, out) == (1, '') and not (tmp_path / 's.csv').exists()   # the table alone: exit 0 before
    why = ('the program itself is not safe: the wafer slips on the blade (ratio 2.259 >= 1) at 54.683 s, steps[14] '
           "(place load_port_1, approach); the ratio is lowered by lower acceleration limits of the arm's joints or "
           "blades of more friction (a longer 'time' on a move lowers its cruise speed, not its accelerations; a "
           "straight entry takes none) (no --rate helps); allowed: a program gpr program "
           'check finds safe (it names every pair and move)\n')
    status, out, err = run(capsys, 'program', 'export', str(program), '--waypoints', str(tmp_path / 'w.csv'),
                           '--samples', str(tmp_path / 's.csv'), '--trajectory', str(tmp_path / 't.yaml'))
    assert (status, out, err) == (1, '', f'gpr program export: error: {why}')
    assert sorted(p.name for p in tmp_path.iterdir()) == ['program.yaml', 'robot.yaml']
    status, out, err = run(capsys, 'program', 'send', str(program), '--timeout', '0.1')
    assert (status, out, err) == (1, '', f'gpr program send: error: {why}')
    # with --json its SendResult too (it printed nothing): status unsafe, the reason, the program's trajectory
    status, out, err = run(capsys, 'program', 'send', str(program), '--timeout', '0.1', '--json', '--namespace', 'r7')
    result = json.loads(out)
    assert (status, err, out.count('\n')) == (1, f'gpr program send: error: {why}', 1)
    assert (result['status'], result['failure'], result['lead_in'], result['error_code'], result['feedback']) == (
        'unsafe', why.rstrip('\n'), None, 0, 0)
    assert result['action'] in ('/r7/joint_trajectory_controller/follow_joint_trajectory',   # resolved under ROS
                                'joint_trajectory_controller/follow_joint_trajectory')   # as given without
    assert (result['points'], len(result['joint_names'])) == (5960, 10) and result['duration'] > 54.683


@pytest.mark.slow
def test_a_trajectory_whose_spline_makes_the_wafer_slip_is_refused_at_its_rate(capsys, tmp_path):
    """Blades of friction 0.2285: the example cell program's slip ratio is 0.989 (safe), but at 10 Hz the cubic
    between the trajectory's points overshoots its accelerations and the wafer slips (1.005 at 54.70 s; the trial
    found it by second differences of the wafer along the spline), written without a word: refused now at 10 Hz,
    written at 20 Hz. Independently: the wafer's positions along the 10 Hz spline at 10 kHz, their second
    differences, the slip ratio of docs/cell.md."""
    from gpr_kinematics.robot.description import load_robot
    from gpr_kinematics.robot.plan import plan_program
    from gpr_kinematics.robot.program import load_program
    from gpr_kinematics.robot.trajectory import evaluate, program_trajectory
    program = _variant(tmp_path, ('friction: 0.3', 'friction: 0.2285'))
    status, out, _ = run(capsys, 'program', 'check', str(program), '--no-progress')
    assert status == 0 and '  safe' in out.splitlines(), out
    status, out, err = run(capsys, 'program', 'export', str(program), '--trajectory', str(tmp_path / 't.yaml'),
                           '--rate', '10')
    assert (status, out) == (2, '') and not (tmp_path / 't.yaml').exists()
    assert err == ("gpr program export: error: at --rate 10 Hz the spline between the trajectory's points makes the "
                   'wafer slip on the blade (ratio 1.005 >= 1 at t = 54.700 s, steps[14] (place load_port_1, '
                   'approach); the program itself stays below 1); allowed: a higher --rate (points closer together '
                   'follow the program)\n'), err
    status, out, _ = run(capsys, 'program', 'export', str(program), '--trajectory', str(tmp_path / 't.yaml'),
                         '--rate', '20')
    assert status == 0 and (tmp_path / 't.yaml').exists()
    plan = plan_program(load_robot(str(tmp_path / 'robot.yaml')), load_program(program), 10.0)
    traj = program_trajectory(plan, 10.0)
    t = np.arange(54.6, 54.8, 1e-4)
    q = evaluate(traj, traj.positions[0], t)[0]
    fk = robot_forward(plan.robot, q[:, :3], q[:, 6:], 'arm2', check_limits=False)
    a = (fk.wafer.position[2:] - 2 * fk.wafer.position[1:-1] + fk.wafer.position[:-2]) / 1e-8
    f = a + np.array([0.0, 0.0, 9.80665])
    n = fk.wafer.rotation[1:-1, :, 2]
    fn = np.einsum('ij,ij->i', f, n)
    ratio = np.linalg.norm(f - fn[:, None] * n, axis=1) / (0.2285 * fn)
    assert ratio.max() == pytest.approx(1.005, abs=1e-3)


def test_a_program_beyond_the_imperfection_budget_is_not_written_as_a_trajectory(capsys, tmp_path):
    """The example robot program (no cell: the robot against itself) under an imperfection budget of 30 um: check
    finds 17 samples beyond it at 10 Hz (test_safety_check), --trajectory wrote it; now refused naming them, with
    check's status 1 at that rate (it was 2)."""
    program = _variant(tmp_path, gpr_line='imperfection_budget: 3.0e-5', cell=False)
    status, out, _ = run(capsys, 'program', 'check', str(program), '--no-progress', '--rate', '10')
    assert status == 1 and '  NOT safe' in out.splitlines(), out
    status, out, err = run(capsys, 'program', 'export', str(program), '--trajectory', str(tmp_path / 't.yaml'),
                           '--rate', '10')
    assert (status, out) == (1, '') and not (tmp_path / 't.yaml').exists(), out
    assert err == ('gpr program export: error: the program itself is not safe: 17 sample(s) at 10 Hz beyond the '
                   'imperfection budget of 30 um (the largest joint displacement 30.673 um at 16.500 s, steps[5] '
                   '(place chamber_a, at)) (no --rate helps); allowed: a program gpr program check finds safe (it '
                   'names every pair and move)\n'), err


def test_the_refusal_quotes_the_closest_of_several_pairs_below_the_margin():
    """What a refusal of --trajectory in a cell quotes (program_trajectory._least): of several pairs below the 2 mm
    margin, the closest, at its least distance. Four fixed 100 mm cubes, a clear of d by 283 mm, of b by 1.5 mm
    along x and of c by 0.5 mm along y, b and c corner to corner hypot(1.5, 0.5) = 1.581 mm apart (less the library's
    1 um slack, the certificate's). The closest pair is the third checked: the first below the margin in that order,
    a and b, is 1 mm farther. The report lists the pairs closest first; the refusals only ever had one pair below
    the margin."""
    pytest.importorskip('fcl')
    from gpr_kinematics.cli.program_trajectory import _least, _pair
    from gpr_kinematics.robot.controller import ControllerJoints
    from gpr_kinematics.robot.description import load_robot
    from gpr_kinematics.robot.trajectory import JointTrajectory
    from gpr_kinematics.safety.bodies import Body
    from gpr_kinematics.safety.clearance import clearance
    from gpr_kinematics.safety.joint_motion import TrajectoryMotion
    from gpr_kinematics.safety.margin import MARGIN

    robot = load_robot(config_path('robots/example_robot.yaml'))
    joints = ControllerJoints.of(robot)
    turn = JointTrajectory(('arm1_shoulder',), np.array([0.0, 2.0]), np.array([[0.0], [1.2]]))
    motion = TrajectoryMotion.of(robot, turn, np.array([joints.names.index('arm1_shoulder')]), joints.rest)

    def cube(name, x, y):
        return Body(name, 'box', (0.1, 0.1, 0.1), None, np.eye(3), np.array([x, y, 3.0]))

    bodies = [cube('a', 5.0, 5.0), cube('b', 5.1015, 5.0), cube('c', 5.0, 5.1005), cube('d', 5.3, 5.3)]
    report = clearance(motion, bodies, [(0, 1, ()), (0, 3, ()), (0, 2, ()), (1, 2, ())], MARGIN)
    slack = 1e-6
    least = _least(report)
    assert least.bodies == ('a', 'c') and least.distance == pytest.approx(0.0005 - slack, abs=1e-12)
    assert _pair(least) == 'a and c come to 0.499 mm at t = 0.000 s'
    truth = {('a', 'c'): 0.0005, ('a', 'b'): 0.0015, ('b', 'c'): math.hypot(0.0015, 0.0005),
             ('a', 'd'): math.hypot(0.2, 0.2)}
    assert [p.bodies for p in report.pairs] == list(truth)   # closest first
    for p in report.pairs:
        assert p.distance == pytest.approx(truth[p.bodies] - slack, abs=1e-9), p
    assert [p.bodies for p in report.below_margin] == [('a', 'c'), ('a', 'b'), ('b', 'c')]


def test_a_cell_program_exports_without_python_fcl_with_a_warning(capsys, tmp_path, monkeypatch):
    """`program export` needs only numpy, scipy and PyYAML (README), but its new clearance check of a program in a
    cell made it need python-fcl: without it the trajectory is written, with a warning that names what was not
    checked and the extra that checks it."""
    import sys
    monkeypatch.setitem(sys.modules, 'fcl', None)
    cell = str(config_path('programs/example_cell_program.yaml'))
    status, out, err = run(capsys, 'program', 'export', cell, '--trajectory', str(tmp_path / 't.yaml'), '--rate', '10')
    assert status == 0 and 'trajectory written to' in out and (tmp_path / 't.yaml').exists()
    assert err == ('gpr program export: warning: the program and its trajectory are not checked for clearance in '
                   f'cell {config_path("programs")}/../cells/example_cell.yaml: that needs the optional package '
                   "'fcl' (pip install 'gpr_kinematics[safety]')\n"), err


@pytest.mark.slow
def test_a_trajectory_longer_than_the_simulators_samples_is_exported(capsys, tmp_path):
    """A 2,500 s program was refused for --trajectory at every --rate ('250001 samples at 100 Hz', the simulator's
    count at its default rate, with the hint of a higher --rate that could not help): the trajectory is checked at
    fewer samples per second there, and a day is its limit, as documented; a warning says robot_simulator_node at
    its default rate refuses it (2,000 s at most; it had been written and sent without a word) and the rate it
    needs."""
    program = tmp_path / 'long.yaml'
    program.write_text('format: gpr_robot_program\nversion: 1\nunits: {length: mm, angle: deg}\n'
                       f'robot: {config_path("robots/example_robot.yaml")}\nstations:\n'
                       '  - {name: h, position: [750, 850, 260], heading: 90}\n'
                       '  - {name: lp, position: [750, -100, 400], heading: -90}\n'
                       'steps:\n  - {move: h}\n  - {move: lp, time: 2500}\n')
    status, out, err = run(capsys, 'program', 'export', str(program), '--trajectory', str(tmp_path / 't.yaml'),
                           '--rate', '50')
    assert status == 0 and 'trajectory written to' in out, err
    assert err == ('gpr program export: warning: the trajectory lasts 2500 s: robot_simulator_node samples a goal '
                   'at its rate into at most 200000 samples and refuses it at its default rate of 100 Hz (at most '
                   '1999.99 s); give the node a lower rate (at most 79.9996 Hz)\n'), err


def test_help_names_every_program_subcommand_and_the_lead_in_unit(capsys):
    """`gpr --help` said programs were checked and exported (no send, no robot or calibration in its description),
    and --lead-in gave no unit."""
    code, out, _ = run(capsys, '--help')
    text = ' '.join(out.split())
    assert code == 0 and 'the whole robot and its programs, calibration and accuracy budgets' in text
    assert 'program offline programs of the whole robot: check, export the joint tables and trajectory, send to a ' \
           'controller' in text
    code, out, _ = run(capsys, 'program', 'export', '--help')
    text = ' '.join(out.split())
    assert code == 0 and '--lead-in SECONDS --trajectory: the first point this much after the start [s]' in text
    assert 'sample rate [Hz] (default 100; 0.1 to 5000)' in text



@pytest.mark.parametrize('command, says', [
    ('fk', 'Forward kinematics of the whole robot'), ('ik', 'Station inverse kinematics'),
    ('teach', 'Teach stations from joints read on the robot')])
def test_robot_subcommands_describe_themselves(capsys, command, says):
    """`gpr robot fk/ik/teach --help` had usage and options only, no paragraph saying what the command does."""
    code, out, _ = run(capsys, 'robot', command, '--help')
    text = ' '.join(out.split())
    assert code == 0 and says in text and '(docs/robot.md)' in text

@pytest.mark.slow
def test_a_file_the_program_names_that_is_missing_is_refused_naming_the_program(capsys, tmp_path):
    """A program copied away from its robot and cell was refused as `cannot read robot file
    '../robots/example_robot.yaml'`: neither the program that named it nor the folder it is relative to was said."""
    import shutil

    (tmp_path / 'programs').mkdir()
    program = tmp_path / 'programs' / 'p.yaml'
    shutil.copy(config_path('programs/example_cell_program.yaml'), program)
    robot, cell = config_path('robots/example_robot.yaml'), config_path('cells/example_cell.yaml')
    status, out, err = run(capsys, 'program', 'export', str(program), '--waypoints', str(tmp_path / 'w.csv'))
    assert (status, out) == (2, '') and err.count('\n') == 1 and not (tmp_path / 'w.csv').exists()
    robot_named = tmp_path / 'programs/../robots/example_robot.yaml'
    assert err == (f"gpr program export: error: {program}: robot file '{robot_named}' (named by the program, relative "
                   "to its folder) does not exist; allowed: an existing file, or --robot FILE\n")
    status, out, err = run(capsys, 'program', 'check', str(program), '--robot', str(robot))
    assert status == 2 and f"{program}: cell file '{tmp_path / 'programs/../cells/example_cell.yaml'}'" in err
    assert err.endswith('allowed: an existing file, or --cell FILE\n')
    status, out, err = run(capsys, 'accuracy', str(program), '--tolerances',
                           str(config_path('calibration/tolerances_example.yaml')))
    assert status == 2 and f"{program}: robot file '{robot_named}'" in err
    (tmp_path / 'cells').mkdir()
    dangling = tmp_path / 'cells' / 'example_cell.yaml'
    dangling.symlink_to(tmp_path / 'nowhere.yaml')   # a link to nothing is as missing as no file
    status, out, err = run(capsys, 'program', 'check', str(program), '--robot', str(robot))
    assert status == 2 and f"{program}: cell file '{tmp_path / 'programs/../cells/example_cell.yaml'}'" in err
    dangling.unlink()
    dangling.symlink_to(dangling)   # a loop was called missing: "does not exist"
    status, out, err = run(capsys, 'program', 'check', str(program), '--robot', str(robot))
    assert status == 2 and 'folder) cannot be read (Too many levels of symbolic links); allowed' in err, err
    dangling.unlink()
    dangling.symlink_to(tmp_path / 'nowhere.yaml')
    # export does not read the cell, and passed a program whose cell was missing or a folder
    status, out, err = run(capsys, 'program', 'export', str(program), '--robot', str(robot), '--waypoints',
                           str(tmp_path / 'w.csv'))
    assert status == 2 and err.endswith("(named by the program, relative to its folder) does not exist; allowed: an "
                                        "existing cell file, or no cell key\n") and not (tmp_path / 'w.csv').exists()
    dangling.unlink()
    dangling.mkdir()
    status, out, err = run(capsys, 'program', 'export', str(program), '--robot', str(robot), '--waypoints',
                           str(tmp_path / 'w.csv'))
    assert status == 2 and 'is not a regular file; allowed: an existing cell file' in err
    dangling.rmdir()
    status, out, err = run(capsys, 'program', 'check', str(program), '--robot', str(robot), '--cell', str(cell),
                           '--no-progress')
    assert status == 0 and out.rstrip().endswith('safe')


def test_an_infinite_slip_ratio_is_the_text_inf_in_the_json(capsys, tmp_path):
    """A robot whose rods accelerate at 40 m/s^2 lowers a wafer faster than it falls (the ratio is infinite: lifted
    off the blade): `gpr program check --json` printed half an object and ended in a ValueError traceback (JSON has
    no infinity). A number that is not finite is the text 'inf', as gpr verify's JSON writes it; the verdict is
    unsafe, exit 1."""
    import yaml

    robot = yaml.safe_load(config_path('robots/example_robot.yaml').read_text())
    robot['rods'].update(velocity=2.0, acceleration=40.0, jerk=4000.0)
    (tmp_path / 'r.yaml').write_text(yaml.safe_dump(robot))
    program = yaml.safe_load(Path(PROGRAM).read_text())
    program['robot'] = 'r.yaml'
    (tmp_path / 'p.yaml').write_text(yaml.safe_dump(program))
    status, out, err = run(capsys, 'program', 'check', str(tmp_path / 'p.yaml'), '--json', '--no-progress')
    assert status == 1 and out.count('\n') == 1, err
    d = json.loads(out)
    assert d['safe'] is False and d['max_slip_ratio'] == 'inf'
    assert 'inf' in [m['max_slip_ratio'] for m in d['moves']]
    status, out, _ = run(capsys, 'program', 'check', str(tmp_path / 'p.yaml'), '--no-progress')
    # lift-off said as such (it read 'slips ... (ratio inf >= 1)')
    assert status == 1 and 'UNSAFE: the wafer lifts off the blade (ratio inf: the paddle accelerates away from it ' \
        'faster than gravity and the vacuum hold it down) at ' in out, out


def test_a_station_position_beyond_the_world_bound_is_refused_with_the_hint_its_units_allow(capsys):
    """--position 2300000 0 400 --mm (2.3 km) was answered 'millimetres given as metres?' though --mm was given:
    beyond the station files' 100 m it is refused, the millimetres hint only for numbers given as metres; named as
    typed, in mm, the metres beside (it said '--position = (2300, 0, 0.4) m')."""
    status, _, err = run(capsys, 'robot', 'ik', '--position', '2300000', '0', '400', '--heading', '0', '--mm')
    assert status == 2 and err == ('gpr robot ik: error: --position = (2300000, 0, 400) mm ((2300, 0, 0.4) m); '
                                   'allowed: each coordinate within +-100 m of the world origin\n')
    status, _, err = run(capsys, 'robot', 'ik', '--position', '2300', '0', '0.4', '--heading', '0')
    assert status == 2 and err.endswith('of the world origin (millimetres? give --mm)\n')


def test_a_program_given_another_robot_than_its_own_is_refused_naming_both(capsys, tmp_path):
    """``--robot`` of another robot (robot 2's description for robot 1's program) was refused only as its stations
    out of reach (2550 mm too far), naming neither; now both, as trajectory_node does; a calibration (the same name,
    arms and joints) is taken."""
    import yaml
    data = yaml.safe_load(config_path('robots/example_robot.yaml').read_text())
    data['gpr'] = {'config': str(config_path('gpr.yaml'))}
    data['name'] = 'example_dual_arm_r2'
    other = tmp_path / 'r2.yaml'
    other.write_text(yaml.safe_dump(data))
    status, out, err = run(capsys, 'program', 'check', PROGRAM, '--robot', str(other))
    assert (status, out) == (2, '')
    assert re.fullmatch(r'gpr program check: error: .*example_robot_program.yaml is a program for robot '
                        r'example_dual_arm \(.*example_robot.yaml; arms arm1: .*\); --robot is robot '
                        r'example_dual_arm_r2 \(.*r2.yaml; arms .*\): give --robot that robot\'s description or its '
                        r'calibration, or leave it out\n', err), err
    data['name'] = 'example_dual_arm'
    other.write_text(yaml.safe_dump(data))
    assert run(capsys, 'program', 'check', PROGRAM, '--robot', str(other))[0] == 0


def test_teach_names_a_wrong_joint_count_as_fk_does(capsys):
    """--joints 0 1 for a 3-joint arm: teach answered in array shapes ('must have 3 values per sample (shape (N, 3)),
    got shape (1, 2)'), fk named the option, the arm and its joints; both now as fk."""
    for command in ('fk', 'teach'):
        status, _, err = run(capsys, 'robot', command, '--rods', '0.25', '0.251', '0.252', '--joints', '0', '1')
        assert status == 2 and err == (f'gpr robot {command}: error: --joints: 2 values for arm arm1, which has 3 '
                                       'joints (arm1_shoulder, arm1_elbow, arm1_wrist); allowed: one value per joint, '
                                       'shoulder first\n'), err


@pytest.mark.parametrize('sig, status, word', [('SIGTERM', 143, 'terminated'), ('SIGINT', 130, 'interrupted')])
def test_a_command_killed_takes_its_outputs_back(tmp_path, sig, status, word):
    """SIGTERM (a kill, `timeout`) left a 17 MB hidden .tmp file and the outputs written before it, where Ctrl-C took
    them back: both end the same way now, one line on stderr, nothing left in the folder. A signal that lands once the
    outputs are being kept waits for the end of it: both outputs whole, and the line says the signal came after the
    command had finished (it left them and said 'terminated' once under load); killed once gpr had returned, the
    process ends by the signal."""
    import signal
    import time

    import gpr_kinematics

    env = {'PYTHONPATH': str(Path(gpr_kinematics.__file__).parents[1]), 'PATH': '/usr/bin:/bin'}
    proc = subprocess.Popen([sys.executable, '-m', 'gpr_kinematics', 'program', 'export', str(PROGRAM), '--samples',
                             's.json', '--waypoints', 'w.csv', '--rate', '5000', '--no-progress'], cwd=tmp_path,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        end = time.monotonic() + 60.0
        while not any(tmp_path.iterdir()) and proc.poll() is None and time.monotonic() < end:
            time.sleep(0.01)   # writing its outputs now
        assert proc.poll() is None, proc.communicate()
        proc.send_signal(getattr(signal, sig))
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    names = sorted(p.name for p in tmp_path.iterdir())
    if names:   # the signal came during or after the outputs' commit: both whole (or killed once gpr was done)
        assert (proc.returncode, err) in ((status, f'gpr program export: {word} after it had finished\n'),
                                          (-getattr(signal, sig), '')), (proc.returncode, err)
        assert names == ['s.json', 'w.csv'] and json.loads((tmp_path / 's.json').read_text())['rows']
    else:
        assert proc.returncode == status and err == f'gpr program export: {word}\n', (proc.returncode, err)


@pytest.mark.parametrize('sig, status, word', [('SIGTERM', 143, 'terminated'), ('SIGINT', 130, 'interrupted')])
def test_a_signal_between_outputs_or_after_their_commit(tmp_path, monkeypatch, capsys, sig, status, word):
    """The two sides of the commit, in-process, each certain: a signal after the first output's write takes it back
    (status 128 + the signal), one while the outputs are kept waits for the end of it and leaves both whole (the
    status and a line say so; it had left them and said 'terminated' as if taken back)."""
    import os
    import signal

    from gpr_kinematics.inputs import files

    signum = getattr(signal, sig)
    before = [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)]
    replace, keep = files._replace, files._Writes.keep

    def replace_then_signal(tmp, target):
        replace(tmp, target)
        os.kill(os.getpid(), signum)

    def signal_then_keep(self):
        os.kill(os.getpid(), signum)
        keep(self)

    args = ('program', 'export', PROGRAM, '--samples', str(tmp_path / 's.json'), '--waypoints',
            str(tmp_path / 'w.csv'), '--rate', '50')
    with monkeypatch.context() as m:
        m.setattr(files, '_replace', replace_then_signal)
        got, _, err = run(capsys, *args)
    assert (got, err, list(tmp_path.iterdir())) == (status, f'gpr program export: {word}\n', [])
    with monkeypatch.context() as m:
        m.setattr(files._Writes, 'keep', signal_then_keep)
        got, _, err = run(capsys, *args)
    assert (got, err, sorted(p.name for p in tmp_path.iterdir())) == (
        status, f'gpr program export: {word} after it had finished\n', ['s.json', 'w.csv'])
    assert json.loads((tmp_path / 's.json').read_text())['rows']
    assert [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)] == before   # the handlers given back


@pytest.mark.parametrize('command', ['fk', 'teach'])
def test_a_joint_typed_in_degrees_beyond_its_limit_is_named_as_typed(capsys, command):
    """`--joints 0 170 0 0 --deg` on arm2 (elbow within +-2.9 rad) said 'arm2_elbow = 2.96705973 rad is beyond its
    upper limit 2.9 rad': the docs promise a value typed under --deg named as typed, the SI beside. The numbers
    independently: 170 deg is 2.96705973 rad, 2.9 rad is 166.157761 deg, 3.84 deg apart."""
    assert (f'{math.radians(170):.9g}', f'{math.degrees(2.9):.9g}', f'{170 - math.degrees(2.9):.3g}') == (
        '2.96705973', '166.157761', '3.84')
    status, out, err = run(capsys, 'robot', command, '--rods', '250', '250', '250', '--joints', '0', '170', '0', '0',
                           '--arm', 'arm2', '--mm', '--deg')
    assert (status, out) == (2, '')
    assert err == (f'gpr robot {command}: error: --joints: arm2_elbow = 170 deg (2.96705973 rad) is beyond its upper '
                   'limit 166.157761 deg (2.9 rad) by 3.84 deg; allowed: [-166.157761, 166.157761] deg\n')
    status, out, err = run(capsys, 'robot', command, '--rods', '0.25', '0.25', '0.25', '--joints', '0', '2.967', '0',
                           '0', '--arm', 'arm2')   # radians typed: named in radians, as typed
    assert status == 2 and 'arm2_elbow = 2.967 rad is beyond its upper limit 2.9 rad' in err, err


def test_metres_typed_under_mm_are_hinted_where_no_arm_reaches_the_station(capsys):
    """`gpr robot ik --position 1.4 0.5 0.7 --mm` (metres typed) said only that rod 1 lies below its stroke; the
    tilt's and the +-100 m check's refusals hint at the other unit, so does this one now, for a station within 10 mm of
    the world's origin; a station out of reach far from it gets no such hint."""
    status, out, err = run(capsys, 'robot', 'ik', '--position', '1.4', '0.5', '0.7', '--tilt', '1', '--heading', '0',
                           '--arm', 'arm2', '--mm', '--deg')
    assert (status, out, err.count('\n')) == (2, '', 1)
    assert err.endswith(' (metres typed under --mm? --position (1.4, 0.5, 0.7) mm ((0.0014, 0.0005, 0.0007) m) lies '
                        "within 10 mm of the world's origin)\n"), err
    assert err.count('metres given as millimetres') + err.count('metres typed under --mm') == 1, err   # one hint
    status, out, err = run(capsys, 'robot', 'ik', '--position', '1400', '500', '5000', '--tilt', '1', '--heading', '0',
                           '--arm', 'arm2', '--mm', '--deg')
    assert status == 2 and 'metres typed' not in err, err

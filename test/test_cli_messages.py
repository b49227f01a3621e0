"""The `gpr` messages and help a user trial found wanting (trial 17): help that promised what the command did not do,
refusals without what is allowed, a hint of degrees typed as radians that only `gpr robot ik` gave, the library's
names where the option was typed, an azimuth step that left a gap without a word, `program send --json` silent on
stdout when it failed, and a forward-kinematics failure that named no pose."""
import json
import math
import re

import numpy as np
import pytest
from gpr_kinematics.core import inverse
from gpr_kinematics.core.compensation import compensate
from gpr_kinematics.core.sweep import paper_sweep
from gpr_kinematics.errors import LimitError
from gpr_kinematics.inputs.resources import config_path
from robot_support import ClientStandIn, NoServerStandInError
from test_core_cli import run

PROGRAM = str(config_path('programs/example_robot_program.yaml'))
#: The refusal of a tilt beyond the default tilt limit, 2 deg, after `--tilt 2` (2 deg meant).
BEYOND = '= 2 rad (114.592 deg) is beyond the tilt limit; allowed: {} <= 0.034906585 rad (2 deg)'
DEGREES = ' (degrees given as radians? give --deg)'


def _error(capsys, *argv):
    """The one line of a refusal (status 2, nothing on stdout), without its ending."""
    status, out, err = run(capsys, *argv)
    assert (status, out, err.count('\n')) == (2, '', 1), err
    return err.rstrip('\n')


# -- 1, 2: gpr accuracy's help says what --errors and --samples do ---------------------------------------------------
def test_the_help_of_errors_and_samples_says_what_they_do(capsys):
    """`--errors` said "repeatable, the values add up" (read: summed), and a second `--errors` of 6 values was refused
    with "takes 6 values; got 12": the values are joined, as `--free`'s names are, and the help says so now, as the
    refusal does; `--samples` said "at most 1000000", and a program refused 1,000,000 samples of its 6 stations."""
    status, out, _ = run(capsys, 'accuracy', '--help')
    text = ' '.join(out.split())
    assert status == 0 and 'add up' not in text
    assert 'repeatable: the values of every --errors are joined in order (--errors E1 E2 E3 --errors E4 E5 E6), ' \
           'one per joint in all' in text
    assert 'at most 1000000, and samples x stations at most 5000000 for a program' in text
    pose = ['--pose', '0', '0', '1', '0', '0', '0']
    assert _error(capsys, 'accuracy', 'stewart_alwan.yaml', *pose, '--errors', '0.001', '0', '0', '0', '0', '0',
                  '--errors', '0.001', '0', '0', '0', '0', '0') == (
        'gpr accuracy: error: --errors has 12 values in all; allowed: 6 (s1, s2, s3, s4, s5, s6), one per joint (the '
        'values of every --errors joined in order)')
    status, out, err = run(capsys, 'accuracy', 'stewart_alwan.yaml', *pose, '--errors', '0.001', '0', '0',
                           '--errors', '0', '0', '0', '--json')
    assert status == 0, err
    assert json.loads(out)['results'][0]['joint_errors'] == [0.001, 0, 0, 0, 0, 0]


# -- 3: a tilt typed in degrees without --deg -------------------------------------------------------------------------
@pytest.mark.parametrize('argv, option, allowed', [
    (['ik', '--height', '0.5', '--tilt', '2', '--azimuth', '0'], '--tilt', '|tilt|'),
    (['compensate', '--height', '0.4', '--tilt', '2', '--azimuth', '0'], '--tilt', '|tilt|'),
    (['mechanism', 'gpr.yaml', '--pose', '0', '0', '0.5', '2', '0', '0'], '--pose tilt |(A, B)|', '|(A, B)|'),
    (['accuracy', 'gpr.yaml', '--tolerances', 'tolerances_example.yaml', '--pose', '0', '0', '0.5', '2', '0', '0'],
     '--pose tilt |(A, B)|', '|(A, B)|'),
    (['accuracy', 'gpr.yaml', '--pose', '0', '0', '0.5', '2', '0', '0'], '--pose tilt |(A, B)|', '|(A, B)|'),
    (['sweep', '--max-tilt', '2'], '--max-tilt', '--max-tilt'),   # it named the library's max_tilt
])
def test_a_tilt_of_degrees_typed_as_radians_is_named_as_typed_with_the_hint(capsys, argv, option, allowed):
    """`gpr robot ik --tilt 2` said "degrees given as radians?"; these said "tilt = 2 rad ... is beyond the tilt
    limit ..." with neither the hint nor what is allowed."""
    assert _error(capsys, *argv) == f'gpr {argv[0]}: error: {option} {BEYOND.format(allowed)}{DEGREES}'


@pytest.mark.parametrize('argv, message', [
    # in degrees, or radians no degrees explain: no hint
    # under --deg in degrees as typed, the radians beside (as --mm's points are named; radians came first)
    (['ik', '--height', '0.5', '--tilt', '3', '--azimuth', '0', '--deg'],
     '--tilt = 3 deg (0.0523598776 rad) is beyond the tilt limit; allowed: |tilt| <= 2 deg (0.034906585 rad)'),
    (['ik', '--height', '0.5', '--tilt', '0.05', '--azimuth', '0'],
     '--tilt = 0.05 rad (2.86479 deg) is beyond the tilt limit; allowed: |tilt| <= 0.034906585 rad (2 deg)'),
    (['sweep', '--max-tilt', '3', '--deg'],
     '--max-tilt = 3 deg (0.0523598776 rad) is beyond the tilt limit; allowed: --max-tilt <= 2 deg (0.034906585 rad)'),
    (['ik', '--height', '0.5', '--tilt', '-2', '--azimuth', '0'],
     '--tilt = -2 rad (-114.592 deg) is beyond the tilt limit; allowed: |tilt| <= 0.034906585 rad (2 deg)' + DEGREES),
    (['dexterity', 'gpr.yaml', '--pose', '0', '0', '0.5', '1.2', '1.6', '0'],
     '--pose tilt |(A, B)| = 2 rad (114.592 deg) is beyond the tilt limit; allowed: |(A, B)| <= 0.034906585 rad '
     '(2 deg)' + DEGREES),
])
def test_a_tilt_beyond_the_limit_says_what_is_allowed(capsys, argv, message):
    assert _error(capsys, *argv) == f'gpr {argv[0]}: error: {message}'


def test_a_tilt_within_the_limit_once_a_rotation_is_still_taken(capsys):
    """`gpr compensate --tilt 6.263` (2pi - 0.02) tilts the command's normal 0.02 rad: compensation takes it, and the
    command line's check of the typed tilt does too."""
    status, out, err = run(capsys, 'compensate', '--height', '0.4', '--tilt', '6.263', '--azimuth', '0', '--json')
    assert status == 0 and json.loads(out)['achieved']['tilt'] == pytest.approx(2 * math.pi - 6.263, abs=1e-9), err


def test_the_librarys_tilt_refusals_say_what_is_allowed_without_the_command_lines_hint():
    """The Python API has no --deg: its messages say what is allowed, the hint is the command line's."""
    for call, message in (
            (lambda: inverse(0.5, 2.0, 0.0), 'tilt ' + BEYOND.format('|tilt|')),
            (lambda: paper_sweep(max_tilt=2.0), 'max_tilt ' + BEYOND.format('max_tilt')),
            (lambda: compensate([0, 0, 0.4], [math.sin(1.0), 0, 0, math.cos(1.0)]),
             'commanded tilt 2 rad (114.592 deg) is beyond the tilt limit; allowed: a commanded tilt <= 0.034906585 '
             'rad (2 deg)')):
        with pytest.raises(LimitError) as err:
            call()
        assert str(err.value) == message


# -- 4: --tool named as typed, with the hint of millimetres ---------------------------------------------------------
@pytest.mark.parametrize('command', ['compensate', 'ik'])
def test_a_tool_point_beyond_its_reach_is_named_as_the_option_with_the_hint_of_millimetres(capsys, command):
    """`gpr compensate --tool 50 20 300` said `tool_offset = (50, 20, 300) m ...` (the library's name) and `gpr ik`
    `tool = ...`, neither with the hint the rods, --position and heights give."""
    argv = [command, '--height', '0.4', '--tilt', '0.01', '--azimuth', '0', '--tool', '50', '20', '300']
    reach = ('is beyond the reach of a tool point (304.795 m from the platform origin); allowed: at most 10 m from the '
             'platform origin (gpr_platform)')
    assert _error(capsys, *argv) == f'gpr {command}: error: --tool = (50, 20, 300) m {reach} (millimetres? give --mm)'
    # in millimetres: no hint, and the point as typed, in mm, the metres beside (it said "--tool = (50, 0.02, 0.3) m")
    far = reach.replace('304.795', '50.0009')
    assert _error(capsys, *argv[:-3], '50000', '20', '300', '--mm') == \
        f'gpr {command}: error: --tool = (50000, 20, 300) mm ((50, 0.02, 0.3) m) {far}'


@pytest.mark.parametrize('argv, option, typed', [
    (['ik', '--height', '300', '--tilt', '0.1', '--azimuth', '0', '--deg', '--mm', '--tool', '20000', '0', '0'],
     '--tool', '(20000, 0, 0) mm ((20, 0, 0) m) is beyond the reach of a tool point (20 m from the platform origin); '
               'allowed: at most 10 m from the platform origin (gpr_platform)'),
    (['compensate', '--height', '300', '--tilt', '0.1', '--azimuth', '0', '--deg', '--mm', '--tool', '0', '-12.5e3',
      '1'], '--tool', '(0, -12500, 1) mm ((0, -12.5, 0.001) m) is beyond the reach of a tool point (12.5 m from the '
                      'platform origin); allowed: at most 10 m from the platform origin (gpr_platform)'),
    # gpr accuracy named the library's `tool` in metres
    (['accuracy', 'gpr.yaml', '--tolerances', 'tolerances_example.yaml', '--pose', '0', '0', '500', '0.1', '0', '0',
      '--mm', '--deg', '--samples', '0', '--tool', '20000', '0', '0'],
     '--tool', '(20000, 0, 0) mm ((20, 0, 0) m) is beyond the reach of a tool point (20 m from the platform origin); '
               'allowed: at most 10 m from the platform origin (gpr_platform)'),
    (['accuracy', 'gpr.yaml', '--tolerances', 'tolerances_example.yaml', '--pose', '0', '0', '0.5', '0.001', '0', '0',
      '--samples', '0', '--tool', '20', '0', '0'],
     '--tool', '(20, 0, 0) m is beyond the reach of a tool point (20 m from the platform origin); allowed: at most '
               '10 m from the platform origin (gpr_platform) (millimetres? give --mm)'),
    (['robot', 'ik', '--position', '1300', '600', '450000', '--tilt', '1.2', '--azimuth', '30', '--heading', '20',
      '--mm', '--deg'],
     '--position', '(1300, 600, 450000) mm ((1.3, 0.6, 450) m); allowed: each coordinate within +-100 m of the world '
                   'origin'),
], ids=['ik', 'compensate', 'accuracy', 'accuracy-metres', 'robot-ik'])
def test_a_point_typed_in_millimetres_is_named_as_typed(capsys, argv, option, typed):
    """A point refused under `--mm` was named in the metres it became (`--tool = (20, 0, 0) m` for 20000 mm typed):
    now as typed, in mm, the metres beside (`inputs.units.as_typed`, as a standard deviation's refusal names them)."""
    command = ' '.join(argv[:2] if argv[0] == 'robot' else argv[:1])
    assert _error(capsys, *argv) == f'gpr {command}: error: {option} = {typed}'


# -- a height typed in mm 1000 times too large: in mm too, never "millimetres given as metres?" -------------------
GPR_POSE = ['gpr.yaml', '--pose', '0', '0', '300000', '0.001', '0', '0', '--mm']
AT_POSE = ('height = 300 m (300000 mm) puts a rod outside the stroke [0, 0.508] m at the tilt 0.001 rad; allowed '
           'heights: 8.07292e-05 .. 0.507919 m (0.0807292 .. 507.919 mm)')


@pytest.mark.parametrize('argv, message', [
    (['ik', '--mm', '--height', '300000', '--tilt', '0', '--azimuth', '0'],
     'height = 300 m (300000 mm) puts a rod outside the stroke [0, 0.508] m at the tilt 0 rad; allowed heights: 0 .. '
     '0.508 m (0 .. 508 mm)'),
    # within 10 mm of the range: the solved rods refuse it, naming the height in mm too
    (['ik', '--mm', '--height', '512', '--tilt', '0', '--azimuth', '0'],
     'q1 = 0.512 m is outside the stroke [0, 0.508] m: the height 0.512 m (512 mm) at the tilt 0 rad needs it; '
     'allowed heights there: 0 .. 0.508 m (0 .. 508 mm)'),
    # compensate's height is its tool point's: in mm, not said to be as typed
    (['compensate', '--mm', '--height', '300000', '--tilt', '1', '--azimuth', '0', '--deg', '--tool', '100', '0',
      '50'],
     'height = 300.049992 m (300049.992 mm) puts a rod outside the stroke [0, 0.508] m at the tilt 0.0174533 rad with '
     'this tool point; allowed heights: 0.0514016 .. 0.556583 m (51.4016 .. 556.583 mm)'),
    (['sweep', '--mm', '--height', '300000'],
     'height = 300 m (300000 mm) puts a rod outside the stroke [0, 0.508] m at the tilt -0.0349066 rad; allowed '
     'heights: 0.00281913 .. 0.50518 m (2.81913 .. 505.18 mm)'),
    # --pose under --mm: the hint was offered though the height was typed in mm
    (['mechanism', *GPR_POSE], AT_POSE),
    (['accuracy', *GPR_POSE], AT_POSE),
    (['accuracy', *GPR_POSE, '--tolerances', 'tolerances_example.yaml', '--samples', '0'], AT_POSE),
    # rods: as typed, as before
    (['fk', '--mm', '300000', '300000', '300000'],
     'q1 = 300 m is outside the stroke [0, 0.508] m (300000 mm as typed; the stroke is [0, 508] mm)'),
], ids=['ik', 'ik-solved', 'compensate', 'sweep', 'mechanism', 'accuracy', 'accuracy-budget', 'fk'])
def test_a_height_typed_in_millimetres_is_named_in_millimetres_without_the_hint(capsys, argv, message):
    """`gpr ik --mm --height 300000` said `height = 300 m ...; allowed heights: 0 .. 0.508 m`, in metres only, and
    `gpr mechanism`/`gpr accuracy` with `--pose ... --mm` added "millimetres given as metres?" to a height typed in
    mm: the height and the heights allowed are named in mm beside the metres, and no such hint under `--mm`."""
    assert _error(capsys, *argv) == f'gpr {argv[0]}: error: {message}'
    # the same numbers in metres keep the hint
    if argv[0] in ('mechanism', 'accuracy'):
        metres = [a for a in argv if a != '--mm']
        metres[metres.index('300000')] = '300'
        assert _error(capsys, *metres).endswith('; as millimetres it would be within them: millimetres given as '
                                                'metres?')


# -- an integer option refused is named as typed --------------------------------------------------------------------
BUDGET = ['accuracy', 'gpr.yaml', '--tolerances', 'tolerances_example.yaml', '--pose', '0', '0', '0.5', '0.001', '0',
          '0']
WORKSPACE = ['workspace', 'gpr.yaml', '--delta', '0.01']


@pytest.mark.parametrize('argv, message', [
    (['sweep', '--passes', '00'], '--passes = 00; allowed: an integer from 1 to 1000'),
    (['sweep', '--passes', '01001'], '--passes = 01001; allowed: an integer from 1 to 1000'),
    ([*BUDGET, '--samples', '-01'], '--samples = -01; allowed: an integer from 0 to 1000000'),
    ([*BUDGET, '--seed', '-0001'], '--seed = -0001; allowed: an integer from 0 to 2**63 - 1'),
    # not 'an integer >= 1', where 1 is then refused as too few to identify the parameters ('at least 5')
    ([*BUDGET, '--calibration-plan', '+0'], '--calibration-plan = +0; allowed: a positive number of configurations, '
                                            'enough to identify the parameters (the plan names the least)'),
    (['calibrate', '--plan', '00', '--tolerances', 'tolerances_example.yaml'],
     'plan size 00: 0 configuration(s) measured as poses give 0 residuals, too few to identify 24 parameters (gpr '
     'calibrate refuses a file of so few rows); allowed: at least 5'),
    ([*WORKSPACE, '--method', 'grid', '--grid-nodes', '01'],
     '--grid-nodes = 01 is invalid; allowed: an integer of at least 2 (nodes per box edge)'),
    ([*WORKSPACE, '--max-boxes', '00'], '--max-boxes = 00; allowed: a whole number of boxes, at least 1'),
    ([*WORKSPACE, '--scheduler', 'local', '--workers', '000'], '--workers = 000; allowed: an integer from 1 to 256'),
    (['dexterity', 'upu3.yaml', '--vary', 'z', '0.1', '0.2', '01'],
     "--vary 'z': COUNT = 01; allowed: an integer from 2 to 50000 (poses per map)"),
], ids=['passes', 'passes-beyond', 'samples', 'seed', 'calibration-plan', 'plan', 'grid-nodes', 'max-boxes',
        'workers', 'vary-count'])
def test_an_integer_option_refused_is_named_as_typed(capsys, argv, message):
    """`gpr sweep --passes 00` said `--passes = 0`, the int it became: every integer option (`cli.options.whole`,
    a `Whole` whose repr is its text) is named as typed, by the command line's checks and the library's alike."""
    assert _error(capsys, *argv) == f'gpr {argv[0]}: error: {message}'


def test_an_integer_option_taken_prints_its_number(capsys):
    """As typed in refusals only: the output and the JSON print the number (`--passes 02` is 2 passes)."""
    from gpr_kinematics.cli.options import whole
    passes = whole(' 02')
    assert (passes, repr(passes), str(passes), f'{passes}', json.dumps(passes), passes + 1) == (2, '02', '2', '2', '2',
                                                                                              3)
    import copy
    import pickle
    for copied in (pickle.loads(pickle.dumps(passes)), copy.deepcopy(passes)):   # a Dask worker's: int's reduction
        assert (copied, repr(copied)) == (2, '02')                                # gave __new__ an int: AttributeError
    status, out, _ = run(capsys, 'sweep', '--passes', '02', '--json')
    assert status == 0 and json.loads(out)['passes'] == 2


# -- 7: an azimuth step that does not divide a turn --------------------------------------------------------------------
@pytest.mark.parametrize('argv, message', [
    (['--azimuth-step', '7', '--deg'],
     '--azimuth-step = 7 deg does not divide a turn: its 52 azimuths from 0 to 357 deg leave 3 deg before 360 deg; '
     'allowed: a step that divides a turn a whole number of times, the nearest 6.92307692308 deg (52 azimuths) or '
     '7.05882352941 deg (51 azimuths)'),
    (['--azimuth-step', '0.1'],
     '--azimuth-step = 0.1 rad does not divide a turn: its 63 azimuths from 0 to 6.2 rad leave 0.0831853 rad before '
     '2pi rad; allowed: a step that divides a turn a whole number of times, the nearest 0.099733100114 rad (63 '
     'azimuths) or 0.101341698503 rad (62 azimuths)'),
    # the least step: 0.0001 rad is 62831.85 steps a turn, and 2 pi / 62832 below the least (it was offered)
    (['--azimuth-step', '0.0001'],
     '--azimuth-step = 0.0001 rad does not divide a turn: its 62832 azimuths from 0 to 6.2831 rad leave 8.53072e-05 '
     'rad before 2pi rad; allowed: a step that divides a turn a whole number of times, the nearest 0.000100001357724 '
     'rad (62831 azimuths)'),
])
def test_an_azimuth_step_that_leaves_a_gap_before_a_turn_is_refused_naming_the_nearest(capsys, argv, message):
    """`gpr sweep --azimuth-step 7 --deg` swept 0 .. 357 deg without a word (a gap of 3 deg), while a --tilt-step
    must divide --max-tilt; the steps it names are taken."""
    assert _error(capsys, 'sweep', *argv) == f'gpr sweep: error: {message}'


@pytest.mark.parametrize('argv, azimuths', [
    (['--azimuth-step', '6.92307692308', '--deg'], 52), (['--azimuth-step', '7.05882352941', '--deg'], 51),
    (['--azimuth-step', '0.099733100114'], 63), (['--azimuth-step', '0.101341698503'], 62),
    (['--azimuth-step', '7.0588235294', '--deg'], 51), (['--azimuth-step', '10', '--deg'], 36),
    (['--azimuth-step', '360', '--deg'], 1), (['--azimuth-step', repr(2 * math.pi / 7)], 7),
    # the steps a refusal offers, to 12 digits, are taken at every count (one in two was refused: an absolute margin
    # on the count beside a relative one), and as many azimuths as their count (0.0157079632679 made 401)
    (['--azimuth-step', '0.0157079632679'], 400), (['--azimuth-step', '0.0999722299361', '--deg'], 3601),
    (['--azimuth-step', '1.24567474048', '--deg'], 289), (['--azimuth-step', '6.28318530718'], 1),
    (['--azimuth-step', '51.42857141', '--deg'], 7), (['--azimuth-step', '51.42857145', '--deg'], 7),
])
def test_a_step_that_divides_a_turn_is_taken(capsys, argv, azimuths):
    tilt = ['--max-tilt', '1', '--tilt-step', '1'] if '--deg' in argv else ['--max-tilt', '0.01', '--tilt-step', '0.01']
    status, out, err = run(capsys, 'sweep', *tilt, *argv, '--json')
    assert status == 0, err
    assert json.loads(out)['samples'] == 3 * azimuths


# -- 8: gpr program send --json prints its object when it fails ----------------------------------------------------
@pytest.mark.parametrize('failure', ['no joint states', 'no server', 'no result', 'lead-in unsafe'])
def test_send_json_prints_its_object_with_the_failure(capsys, monkeypatch, failure):
    """`gpr program send ... --action nope --timeout 1 --json` exited 1 with nothing on stdout, where `program check
    --json` and `verify --json` print their object on status 1: the SendResult, its status and the failure's line. The
    ROS client is stood in for (test_ros_program_send runs the real one)."""
    pytest.importorskip('rclpy')
    from gpr_kinematics.cli import program_send
    from gpr_kinematics.robot.controller import ControllerJoints
    from robot_support import ROBOT

    def positions(client, names, topic, timeout):
        if failure == 'lead-in unsafe':   # arm1's blade where the program starts with a wafer lying (no cell)
            from gpr_kinematics.robot.plan import plan_program
            from gpr_kinematics.robot.program import load_program
            from gpr_kinematics.robot.trajectory import program_trajectory
            traj = program_trajectory(plan_program(ROBOT, load_program(PROGRAM)), 100.0)
            return traj.positions[int(np.searchsorted(traj.time, 4.0))]
        return None if failure == 'no joint states' else ControllerJoints.of(ROBOT).rest

    def follow(client, goal, action, timeout, progress, found):
        raise NoServerStandInError(action) if failure == 'no server' else TimeoutError('/nope: no result 1 s after the '
                                                                                 "trajectory's end; the goal was "
                                                                                 'cancelled')

    fake = type('tc', (), {'GprClient': ClientStandIn, 'current_positions': staticmethod(positions),
                           'other_robot_there': staticmethod(lambda client, robot: None),
                           'MissingJointsError': LookupError, 'follow_trajectory': staticmethod(follow),
                           'NoServerError': NoServerStandInError, 'ServiceTimeoutError': TimeoutError})
    monkeypatch.setattr(program_send, '_ros_modules', lambda: fake)
    status, out, err = run(capsys, 'program', 'send', PROGRAM, '--action', '/nope', '--timeout', '1', '--json')
    line = err.rstrip('\n').removeprefix('gpr program send: ')
    result = json.loads(out)
    assert (status, out.count('\n'), err.count('\n')) == (1, 1, 1)
    assert (result['status'], result['failure'], result['action']) == (
        'no_result' if failure == 'no result' else 'not_sent', line, '/nope')
    assert (result['error_code'], result['feedback'], result['robot']) == (0, 0, ROBOT.name)
    assert result['points'] > 0 and result['duration'] > 0
    if failure == 'no joint states':
        assert result['lead_in'] is None and line.startswith('no joint states with the joints rod_1, rod_2, rod_3, ')
    elif failure == 'lead-in unsafe':   # the lead-in is known: its --json said null while the line named it
        m = re.match(r"the move from where the robot is to the program's start \((\d+\.\d{3}) s, added by send\) is "
                     r'not safe against the robot itself \(no cell\)', line)
        assert m and result['lead_in'] == pytest.approx(float(m[1]), abs=5e-4), line
        assert result['duration'] - result['lead_in'] == pytest.approx(28.528, abs=0.02)   # the goal with its lead-in
    else:
        assert result['lead_in'] >= 0
        assert line == ('no FollowJointTrajectory server on /nope within 1 s (change the name with --action, the wait '
                        'with --timeout)' if failure == 'no server' else
                        "/nope: no result 1 s after the trajectory's end; the goal was cancelled")


# -- 9: a pose where the exact deviation cannot be solved ----------------------------------------------------------
def test_a_pose_the_perturbed_mechanism_does_not_reach_is_named_with_what_is_allowed(capsys):
    """A pose 1 mm above the base (`--pose 0 0 1 0 0 0 --mm`) said only "forward kinematics did not converge to 1e-13
    in 50 iterations (max residual 0.0759)": no pose, nothing allowed."""
    # the residual after 50 iterations that do not converge is the machine's (0.0759 on one, 0.0145 on another)
    assert re.fullmatch(re.escape(
        'gpr accuracy: error: Gough-Stewart platform (Alwan 2011): the exact deviation at pose 1 (x, y, z, A, B, C = '
        '0, 0, 0.001, 0, 0, 0; m, rad) cannot be solved: followed from the nominal pose as its errors grow, forward '
        'kinematics at 0.02441 % of them left the path it followed (another assembly mode: the pose jumped or crossed '
        'a singular configuration); allowed: poses the mechanism still reaches with the '
        'errors (this one, condition number 1.05e+04, is likely outside its reach: a pose farther inside the '
        'workspace, or smaller errors)').replace('\\#', r'\d[0-9.e+-]*'), _error(
            capsys, 'accuracy', 'stewart_alwan.yaml', '--pose', '0', '0', '1', '0', '0', '0', '--errors', '1', '0', '0',
            '0', '0', '0', '--mm'))

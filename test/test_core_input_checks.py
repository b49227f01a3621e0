"""The shared input checks (``inputs.validation``) as the public functions meet them: a value of the wrong shape or
a non-finite one is an :class:`InputError` naming it, never a silent answer for part of it. The shape, finiteness
and bound cases are guards whose removal no test noticed (a mutation audit): without them, two rod triples gave the
forward kinematics of the first, two heights the inverse kinematics of the first, NaN a NaN answer. Numbers given as
text or as complex numbers were taken (below)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from gpr_kinematics.core import inverse_batch, naive_forward
from gpr_kinematics.errors import InputError
from gpr_kinematics.mechanisms import load_mechanism
from gpr_kinematics.robot import load_robot, robot_forward, stations_from_poses

from gpr_kinematics import compensate, forward, forward_batch, inverse

QUAT = (0.0, 0.0, 0.0, 1.0)


@pytest.mark.parametrize('call, message', [
    (lambda: forward([[0.5, 0.5, 0.5], [0.4, 0.4, 0.4]]), 'q must be 3 values, got shape (2, 3)'),
    (lambda: inverse([0.5, 0.4], 0.0, 0.0), 'height must be a single number, got shape (2,)'),
    (lambda: inverse(0.5, [0.01, 0.02], 0.0), 'tilt must be a single number, got shape (2,)'),
    (lambda: compensate((0.0, 0.0), QUAT), 'position must be 3 numbers, got shape (2,)'),
    (lambda: compensate((0.0, 0.0, 0.4), QUAT, (0.0, 0.0, 0.1, 0.0)), 'tool_offset must be 3 numbers, got shape (4,)'),
    (lambda: compensate((0.0, math.nan, 0.4), QUAT),
     'position = [0.0, nan, 0.4] contains NaN or infinity: position[1] = nan is not a finite number'),
    (lambda: compensate((0.0, 0.0, 0.4), QUAT, (0.0, 0.0, math.inf)), 'tool_offset[2] = inf is not a finite number'),
    # the naive model's refusal as forward kinematics says it, with the millimetres' hint (it had neither)
    (lambda: naive_forward([500.0, 503.0, 498.0]), "q = [500.0, 503.0, 498.0] m imply no platform orientation (their "
                                                    "differences are more than the joints' spread can make at any "
                                                    'tilt); allowed: rods whose differences a tilt makes; millimetres '
                                                    'given as metres?'),
    # one value given: no index (it read "height[0] = nan"); one of many: its index
    (lambda: inverse_batch(math.nan, 0.0, 0.0), 'height = nan is not a finite number'),
    (lambda: inverse_batch([0.3, math.nan], 0.0, 0.0), 'height[1] = nan is not a finite number'),
])
def test_a_value_of_the_wrong_shape_or_not_finite_is_refused_by_name(call, message):
    with pytest.raises(InputError) as err:
        call()
    assert message in str(err.value)


@pytest.mark.parametrize('call, message', [
    (lambda: forward([0.5, 0.5]), 'q must be 3 values, got shape (2,)'),
    (lambda: forward([[0.5, 0.5]]), 'q must be 3 values, got shape (1, 2)'),
    (lambda: inverse(0.5, 0.0, 0.0, tool=(0.0, 0.1)), 'tool must be 3 values, got shape (2,)'),
])
def test_one_configuration_of_the_wrong_length_is_told_3_values(call, message):
    """forward([0.5, 0.5]) said 'q must have 3 values per sample (shape (N, 3))', the batch's words, though forward
    takes one configuration and (2, 3) was refused as 'q must be 3 values'."""
    with pytest.raises(InputError) as err:
        call()
    assert str(err.value) == message


@pytest.mark.parametrize('call, message', [
    (lambda: inverse_batch('0.5', 0.0, 0.0), "height must be a number or an array of numbers, got '0.5'"),
    (lambda: inverse_batch([0.5, '0.4'], 0.0, 0.0), 'height must be a number or an array of numbers'),
    (lambda: inverse('0.5', 0.0, 0.0), "height must be a number or an array of numbers, got '0.5'"),
    (lambda: forward(['0.5', '0.5', '0.5']), "q must be numbers, got ['0.5', '0.5', '0.5']"),
    (lambda: forward_batch(np.array([['0.5', '0.5', '0.5']])), 'q must be numbers'),
    (lambda: inverse(0.5, 0.0, 0.0, tool=(0.0, 0.0, b'0.1')), 'tool must be numbers'),
    (lambda: compensate(np.array(['0', '0', '0.4']), QUAT), 'position must be 3 numbers'),
    (lambda: forward_batch(np.array([[0.5 + 1e-3j, 0.5, 0.5]])), 'q must be numbers'),   # was cast to its real part
])
def test_numbers_given_as_text_or_complex_are_refused(call, message):
    """numpy converts the text '0.5' to 0.5 and float() does too: the batch inverse kinematics solved a string height
    while the sweep refused one. Text is no number in the Python API either (the command line and the files read
    their own decimals). A numpy array of complex numbers was cast to its real parts with a warning."""
    with pytest.raises(InputError) as err:
        call()
    assert message in str(err.value)


def test_the_checked_forms_still_answer():
    """The same calls with valid values: the guards above refuse only what they name (one triple, one height). Equal
    rods hold the platform level at their length (the singular configuration of the nominal machine), a level command
    at 0.4 m needs rods of 0.4 m, and the inverse kinematics' rods give back its pose."""
    np.testing.assert_allclose(forward([0.5, 0.5, 0.5]).position, [0.0, 0.0, 0.5], rtol=0, atol=1e-15)
    h = inverse(0.5, 0.01, 0.0)
    assert h.q.shape == (3,) and np.allclose(forward(h.q).position, h.achieved.position, atol=1e-12)
    np.testing.assert_allclose(compensate((0.0, 0.0, 0.4), QUAT).q, [0.4, 0.4, 0.4], rtol=0, atol=1e-15)


def test_robot_joints_and_station_positions_are_bounded_to_a_million():
    """Joint values and station positions beyond +-1e6 (rad, m) are refused before any trigonometry (``bounded``);
    1e6 itself is taken."""
    robot = load_robot()
    n = len(robot.arm('arm1').joints)
    with pytest.raises(InputError, match=r'joints of arm1 \[rad\] = .*allowed: finite values within \+-1e\+06'):
        robot_forward(robot, [[0.3, 0.3, 0.3]], [[0.0] * (n - 1) + [1.0000001e6]], 'arm1', check_limits=False)
    robot_forward(robot, [[0.3, 0.3, 0.3]], [[0.0] * (n - 1) + [1e6]], 'arm1', check_limits=False)
    with pytest.raises(InputError, match=r'station position \[m\] = .*allowed: finite values within'):
        stations_from_poses([[2e6, 0.0, 0.0]], [np.eye(3)])
    st = stations_from_poses([[0.1, 0.0, 0.2], [0.2, 0.0, 0.2]], [np.eye(3), np.eye(3)])
    with pytest.raises(InputError, match=r'distance \[m\] must have shape \(2,\); got \(3,\)'):
        st.offset([0.01, 0.02, 0.03])
    np.testing.assert_allclose(st.offset([0.01, 0.02]).position[:, 2], [0.21, 0.22], rtol=0, atol=1e-15)


def test_a_mechanisms_newton_iterations_are_bounded_by_a_thousand():
    """``max_iterations`` 1000 is the largest count taken (the documented limit), 1001 is refused."""
    mech = load_mechanism('upu3.yaml')
    pose = np.array([[0.01, -0.02, 0.2, 0.0, 0.0, 0.0]])
    joints = mech.inverse_kinematics(pose)
    np.testing.assert_allclose(mech.forward_kinematics(joints, pose + 0.001, max_iterations=1000), pose, atol=1e-12)
    with pytest.raises(InputError, match='max_iterations = 1001 is invalid; allowed: an integer from 1 to 1000'):
        mech.forward_kinematics(joints, pose, max_iterations=1001)


def _refused(call, words):
    with pytest.raises(InputError, match=words):
        call()


def test_what_a_python_caller_passes_is_checked_where_numpy_raised_or_guessed():
    """An API user's review: numpy's own ValueError, IndexError, AttributeError or TypeError, a masked value read
    from under its mask, a truth value taken as 0 m, text taken as numbers, a shape returned unrefused; now the
    package's InputError naming what was wrong and what is allowed."""
    from gpr_kinematics.core.mobility import analyze_mobility
    from gpr_kinematics.mechanisms.accuracy import accuracy_analysis
    from gpr_kinematics.workspace import load_workspace_model

    tripod = load_workspace_model('tripod_3rps.yaml')
    _refused(lambda: tripod.feasible([]), r'points of z, psi, theta must have 3 values per sample \(shape \(N, 3\)\), '
             r'got shape \(0,\)')
    _refused(lambda: tripod.feasible([['a', 0, 0]]), 'points of z, psi, theta must be numbers')
    _refused(lambda: load_workspace_model('upu3.yaml').feasible([[[0.1, 0.1, 0.1]]]), r'got shape \(1, 1, 3\)')
    assert tripod.feasible([0.1, 0.0, 0.0]).shape == (1,)
    c = compensate([0, 0, 0.4], [0.01, 0, 0, 0.99995])
    _refused(lambda: c.correct([0.1, 0]), r'points must have 3 values per sample')
    _refused(lambda: c.correct([0.1, 0, np.nan]), r'points\[2\] = nan is not a finite number')
    _refused(lambda: c.correct(['0.1', '0', '0']), 'points must be numbers')
    np.testing.assert_array_equal(c.correct([0.1, 0.0, 0.0]), c.correct([[0.1, 0.0, 0.0]])[0])
    np.testing.assert_allclose(c.correct([0.1, 0.0, 0.0]), c.arm_correction.apply([0.1, 0.0, 0.0]), rtol=0, atol=0)
    m = analyze_mobility([0.5, 0.503, 0.498])
    _refused(lambda: m.dx_bounds('abc'), r'dP must be 12 numbers')
    _refused(lambda: m.dx_bounds(['0.0001'] + ['0'] * 11), r'dP must be 12 numbers')
    _refused(lambda: m.dx_bounds([0.0] * 11 + [math.nan]), r'dP\[11\] = nan is not a finite number')   # not "shape"
    alwan, pose = load_mechanism('stewart_alwan.yaml'), [0, 0, 0.9, 0.05, 0.05, 0.05]
    _refused(lambda: accuracy_analysis(alwan, pose, joint_errors='abc'), 'joint errors must be 6 numbers per pose')
    _refused(lambda: accuracy_analysis(alwan, pose, parameter_errors=[1, 2]),
             r'parameter errors = \[1, 2\]; allowed: a mapping of parameter name \(')
    _refused(lambda: accuracy_analysis(alwan, pose, joint_errors=[np.nan] * 6), r'per pose; got \[nan')
    gpr = load_mechanism('gpr.yaml')
    _refused(lambda: gpr.forward_kinematics([np.nan, 0.254, 0.254]), r'q1 = nan is not a finite number')
    _refused(lambda: gpr.forward_kinematics([0.25, 0.254, 0.254], np.zeros(5)), r'guess must have shape \(6,\)')
    # truth values and masked values are not numbers; one pose and its batch agree
    _refused(lambda: forward([False] * 3), r'q must be numbers, got \[False, False, False\]')
    # one truth value among numbers: numpy made the list floats (False 0 m, True 1 m "outside the stroke")
    _refused(lambda: forward([0.0, 0.0, False]), r'q must be numbers, got \[0.0, 0.0, False\]')
    _refused(lambda: forward([True, 0.1, 0.1]), r'q must be numbers, got \[True, 0.1, 0.1\]')
    _refused(lambda: forward_batch([[0.3, 0.3, 0.3], (0.3, 0.3, np.True_)]), 'q must be numbers')
    _refused(lambda: inverse(False, False, False), 'height must be a number')
    masked = np.ma.array([0.5, 0.503, 0.498], mask=[0, 1, 0])
    _refused(lambda: forward_batch(masked[None]), 'a masked array with masked values')
    _refused(lambda: forward(masked), 'a masked array with masked values')
    assert forward(np.ma.array([0.5, 0.503, 0.498])).tilt == forward([0.5, 0.503, 0.498]).tilt
    for call in (lambda: forward(masked), lambda: forward_batch(np.ones((2, 3), bool))):   # an array's repr spans lines
        with pytest.raises(InputError) as err:
            call()
        assert '\n' not in str(err.value), str(err.value)
        assert '[ True,  True,  True], [ True' in str(err.value) or 'masked_array(data=[0.5, --, 0.498], mask' in \
            str(err.value), str(err.value)


def test_a_zero_dimensional_array_counts_as_one_value():
    """``len()`` of a 0-d array raises: ``dexterity_sweep(..., np.array(0.2))`` and ``sample_plan(plan,
    times=np.array(1.0))`` failed with TypeError where the float worked."""
    import yaml
    from gpr_kinematics.inputs.validation import count_of
    from gpr_kinematics.robot.plan import plan_program, sample_plan
    from gpr_kinematics.robot.program import parse_program
    from robot_support import ROBOT, SHORT_PROGRAM

    assert count_of(np.array(0.2)) == 1 and count_of(np.zeros(3)) == 3 and count_of(0.2) == 1
    plan = plan_program(ROBOT, parse_program(yaml.safe_load(SHORT_PROGRAM), 'short'))
    a, b = sample_plan(plan, times=np.array(1.0)), sample_plan(plan, times=1.0)
    np.testing.assert_array_equal(a.samples.time, b.samples.time)
    np.testing.assert_array_equal(a.samples.positions, b.samples.positions)


def test_per_row_geometry_names_and_joint_play_are_bounded():
    Q = [[0.5, 0.503, 0.498]] * 2
    _refused(lambda: forward_batch(Q, parameters=[[1e-3, 2e-3], [0.0, 0.0]], names=['rod1_offset', 'rod1_offset']),
             r'geometry parameter\(s\) rod1_offset named twice; allowed: each name once')
    _refused(lambda: forward_batch(Q, names=['rod1_offset']), r"names = \['rod1_offset'\] without parameters")
    _refused(lambda: forward_batch(Q, displacement=np.full((2, 3, 3), 1e3)),
             r'joint displacement \[0, 0, 0\] = 1000.0 m; allowed: finite, within \+-0.01 m')
    _refused(lambda: forward_batch(Q, displacement=np.full((2, 3, 3), np.nan)), r'= nan m; allowed: finite')
    assert forward_batch(Q, displacement=np.full((2, 3, 3), 1e-5)).tilt.shape == (2,)


def test_none_is_no_number():
    """numpy reads None as NaN: robot_forward(robot, [None] * 3, ...) said 'rod_1 = nan is not a finite number',
    Stations.of(P, tilt=None) 'tilt = nan', forward([0.5, None, 0.5]) 'q2 = nan': None is named as given."""
    from gpr_kinematics.robot.stations import Stations

    robot = load_robot()
    for call, message in ((lambda: robot_forward(robot, [None] * 3, [0.0, 0.0, 0.0]),
                           'rods must be numbers, got [None, None, None]'),
                          (lambda: Stations.of([[1.0, 0.5, 0.4]], tilt=None), 'tilt must be numbers, got None'),
                          (lambda: forward([0.5, None, 0.5]), 'q must be numbers, got [0.5, None, 0.5]'),
                          (lambda: inverse_batch([0.5, None], 0.0, 0.0),
                           'height must be a number or an array of numbers, got [0.5, None]')):
        with pytest.raises(InputError) as err:
            call()
        assert str(err.value) == message


def test_joint_play_of_exactly_its_bound_is_taken():
    Q = [[0.5, 0.503, 0.498]]
    D = np.zeros((1, 3, 3))
    D[0, 1, 0] = 0.01
    assert forward_batch(Q, displacement=D).tilt.shape == (1,)
    D[0, 1, 0] = 0.01 + 1e-12
    _refused(lambda: forward_batch(Q, displacement=D), r'joint displacement \[0, 1, 0\] = 0.010000000001 m')



def test_plain_number_reads_what_a_range_check_names():
    """A bound names the value as given: Python and numpy numbers and a 0-d array of one are that number; a bool,
    a 0-d bool or text array, a 1-element list and None are no number (NaN); an int beyond a float is infinite."""
    from gpr_kinematics.inputs.validation import plain_number

    for value in (2.5, 3, np.float32(0.5), np.int64(-4), np.array(100.0), np.array(7, dtype=np.uint8)):
        got = plain_number(value)
        assert type(got) is float and got == float(np.asarray(value))
    for value in (True, np.bool_(False), np.array(True), np.array('1.0'), [1.0], None, '2.0', 1j):
        assert math.isnan(plain_number(value)), value
    assert plain_number(10 ** 400) == math.inf and plain_number(-10 ** 400) == -math.inf


@pytest.mark.parametrize('kwargs, message', [
    ({'check_limits': 'False'}, r"^check_limits = 'False'; allowed: True or False$"),   # true: the checks stayed on
    ({'check_limits': None}, r'^check_limits = None; allowed: True or False$'),          # false: the checks went off
    ({'check_limits': 0}, r'^check_limits = 0; allowed: True or False$'),
    ({'stroke': 'no'}, r"^stroke = 'no'; allowed: True or False$"),
])
def test_the_checks_switches_are_truth_values(kwargs, message):
    for call in (lambda: forward([0.1, 0.2, 0.15], **kwargs), lambda: forward_batch([[0.1, 0.2, 0.15]], **kwargs)):
        with pytest.raises(InputError, match=message):
            call()
    assert forward([0.3, 0.3, 0.3], check_limits=np.bool_(False)).tilt == 0.0   # numpy's truth values are taken


@pytest.mark.parametrize('value', [None, 0, 'no'])
def test_inverse_kinematics_stroke_switch_is_a_truth_value(value):
    """inverse_batch(stroke=0 or None) answered rods beyond the stroke (0.5088 m at 0.5072 m, tilt 0.01)."""
    from gpr_kinematics.errors import LimitError
    with pytest.raises(LimitError, match='stroke'):
        inverse_batch([0.5072], [0.01], [0.0])
    with pytest.raises(InputError, match=rf'^stroke = {value!r}; allowed: True or False$'):
        inverse_batch([0.5072], [0.01], [0.0], stroke=value)
    assert inverse_batch([0.5072], [0.01], [0.0], stroke=False).q.max() > 0.508   # False answers it, as documented


def test_a_wrong_count_of_machines_is_named_before_their_rows():
    """Three machines for two rod rows, each row of one parameter left at 0: it named row 0's joint triangle."""
    with pytest.raises(InputError, match=r'^3 parameter rows for 2 rod-length rows; allowed: one machine per sample'):
        forward_batch(np.full((2, 3), 0.1), parameters=np.zeros((3, 1)), names=['rod1_x'])


def test_an_array_where_a_name_is_asked_is_refused_by_name():
    """An attacker's review: an array given as the model's or the weighting's name, as the overrides or as the
    parameters' names raised numpy's "truth value of an array is ambiguous" or "iteration over a 0-d array"; now
    the package's errors naming the argument and what is allowed."""
    from gpr_kinematics.core.config import GprConfig, load_config
    from gpr_kinematics.errors import ConfigError

    array = np.zeros(3)
    for call in (lambda: forward([0.3] * 3, model=array), lambda: compensate([0, 0, 0.3], QUAT, model=array)):
        with pytest.raises(InputError, match=r'unknown virtual-joint model array\(\[0., 0., 0.\]\); allowed: radial, '):
            call()
    with pytest.raises(ConfigError, match=r'model = array\(\[0., 0., 0.\]\) is invalid; allowed: radial or polar'):
        GprConfig(model=array)
    with pytest.raises(ConfigError, match=r'weighting = array\(\[\], dtype=float64\) is invalid; allowed: '):
        GprConfig(weighting=np.zeros(0))
    with pytest.raises(ConfigError, match=r'^overrides: model = array\('):
        load_config(overrides={'model': array})
    with pytest.raises(ConfigError, match=r'^overrides: expected a mapping of keys to values, got ndarray'):
        load_config(overrides=array)
    with pytest.raises(InputError, match=r"geometry parameter names must be a list of names, got array\('x'"):
        forward_batch([[0.3] * 3], parameters=np.zeros(1), names=np.array('x'))
    assert forward([0.3] * 3, model='').tilt == forward([0.3] * 3, model=None).tilt == 0.0
    assert load_config(overrides={}) == load_config()

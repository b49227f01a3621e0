"""The robot description: the shipped example, the geometry by reference or inline, and every bad value refused
with the file, the key, the value and what is allowed."""
import doctest
import math

import pytest
import yaml
from gpr_kinematics.core import rotations
from gpr_kinematics.core.config import load_config
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.robot import description, planar_arm, stations, transforms
from gpr_kinematics.robot.description import load_robot
from robot_support import EXAMPLE, ROBOT, make_robot, robot_data


def test_shipped_example():
    r = ROBOT
    assert r.name == 'example_dual_arm' and r.arm_names == ('arm1', 'arm2')
    assert r.config == load_config()
    assert r.rods.names == ('rod_1', 'rod_2', 'rod_3')
    a1, a2 = r.arm('arm1'), r.arm('arm2')
    assert a1.joint_names == ('arm1_shoulder', 'arm1_elbow', 'arm1_wrist') and len(a2.joints) == 4
    assert a1.wafer_height == pytest.approx(0.08 + 0.035 + 0.035 + 0.02 + 0.01 + 0.004, abs=1e-15)
    assert a2.redundancy.rule == 'fixed_joint' and a2.redundancy.joint == 2
    assert r.arm() is a1
    assert a1.link_frames == ('arm1_link1', 'arm1_link2', 'arm1_link3')
    assert (a1.blade_frame, a1.wafer_frame) == ('arm1_blade', 'arm1_wafer')


def test_an_arm_without_a_mount_or_a_blade_position_sits_at_the_platform_centre():
    """mount and blade position are optional: the first joint axis at the platform's centre, yaw 0, the blade at
    the flange; the wafer height is then the joints' and the wafer centre's heights alone."""
    data = robot_data()
    del data['arms'][0]['mount']
    del data['arms'][0]['blade']['position']
    a = make_robot(data).arm('arm1')
    assert a.mount_position == (0.0, 0.0, 0.0) and a.mount_yaw == 0.0 and a.blade.position == (0.0, 0.0, 0.0)
    heights = sum(j['height'] for j in data['arms'][0]['joints']) + data['arms'][0]['blade']['wafer_centre'][2]
    assert a.wafer_height == pytest.approx(heights, abs=1e-15)


def test_home_defaults_to_zero_clipped_into_each_range():
    """Without home, each joint starts at 0 rad, or at the nearer limit of a range that excludes 0."""
    data = robot_data()
    del data['arms'][0]['home']
    data['arms'][0]['joints'][1]['lower'] = 0.5
    data['arms'][0]['joints'][2]['upper'] = -0.25
    data['arms'][0]['joints'][2]['lower'] = -1.0
    assert make_robot(data).arm('arm1').home == (0.0, 0.5, -0.25)


def test_geometry_by_reference_inline_and_overridden(tmp_path):
    (tmp_path / 'geo.yaml').write_text('radius: 0.1\nmodel: polar\n')
    data = robot_data()
    data['gpr'] = {'config': 'geo.yaml', 'tilt_limit': 0.03}
    (tmp_path / 'robot.yaml').write_text(yaml.safe_dump(data))
    r = load_robot(tmp_path / 'robot.yaml')
    assert (r.config.radius, r.config.model, r.config.tilt_limit) == (0.1, 'polar', 0.03)
    r = load_robot(tmp_path / 'robot.yaml', geometry=tmp_path / 'geo.yaml', model='offset')
    assert (r.config.radius, r.config.model) == (0.1, 'offset')
    assert r.config.tilt_limit == load_config().tilt_limit  # --config replaces the whole gpr section
    with pytest.raises(ConfigError, match="^model = 'wobbly' is invalid; allowed: radial or polar or offset or "
                                          r"compliant \(the model overriding the geometry's: model, or --model\)$"):
        load_robot(model='wobbly')


def _set(data, path, value):
    node = data
    for key in path[:-1]:
        node = node[key]
    if value is _DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value


_DELETE = object()


@pytest.mark.parametrize('path, value, pattern', [
    (('colour',), 'red',
     r'test_robot.yaml: unknown key\(s\) colour; allowed keys: arms, base, collision, gpr, name, rods, wafer'),
    (('name',), 'my robot', r"name = 'my robot' is invalid; allowed: a name of letters, digits and _"),
    (('name',), 'robot\n', r"name = 'robot\\n' is invalid; allowed: a name of letters, digits and _"),  # $ before \n
    (('name',), False, r"name = False is invalid \(YAML reads true and false as booleans: quote the name\); allowed: "),
    (('arms', 0, 'joints', 1, 'name'), 'arm1_elbow\n',   # '$' matched before a final newline: passed into the URDF
     r"joints\[1\]: name = 'arm1_elbow\\n' is invalid; allowed: a name of letters, digits and _"),
    (('gpr', 'radius'), -1, r'test_robot.yaml: gpr: radius = -1 is invalid; allowed: metres'),
    (('gpr', 'config'), 'missing.yaml', r"gpr: cannot read config file .*missing.yaml"),
    (('base', 'position'), [0, 0], r'base: position = \[0, 0\] is invalid; allowed: a list of 3 finite numbers in m'),
    (('base', 'position'), [0, 0, 1e3], r'base: position\[2\] = 1000.0 is invalid; allowed: a list of 3 finite'),
    (('base', 'rpy'), [0, '1', 0], r"base: rpy\[1\] = '1' is invalid; allowed: a finite angle in rad within one turn"),
    # Orientations in radians beyond one turn are degrees (the format has none): 90 was 14.3 turns, 2.04 rad.
    (('base', 'rpy'), [0, 0, 90], r'test_robot.yaml: base: rpy\[2\] = 90 rad is beyond one turn; allowed: '
                                  r'\[-2pi, 2pi\] rad \(radians only here: 90 deg is 1.57079633 rad\)$'),
    (('arms', 0, 'mount', 'yaw'), 90, r'arms\[0\] \(arm1\): mount: yaw = 90 rad is beyond one turn; allowed: '
                                      r'\[-2pi, 2pi\] rad \(radians only here'),
    (('arms', 1, 'blade', 'yaw'), -180, r'arms\[1\] \(arm2\): blade: yaw = -180 rad is beyond one turn; allowed: '
                                        r'\[-2pi, 2pi\] rad \(radians only here: -180 deg is -3.14159265 rad\)$'),
    # a joint limit in degrees was refused without the hint the mount's yaw and the base's rpy give
    (('arms', 0, 'joints', 1, 'lower'), -155, r'joints\[1\] \(arm1_elbow\): lower = -155.0 is invalid; allowed: '
                                              r'radians within \[-2pi, 2pi\] \(radians only here: -155 deg is '
                                              r'-2.70526034 rad\)$'),
    (('rods', 'velocity'), 0, r'rods: velocity = 0.0 is invalid; allowed: m/s, 1e-06 <= velocity <= 10$'),
    # beyond every number's bound the message named that bound, not the key's range
    (('arms', 0, 'joints', 0, 'velocity'), 1e300, r'velocity = 1e\+300 is invalid; allowed: rad/s, 1e-06 <= velocity '
                                                  r'<= 100$'),
    (('wafer', 'diameter'), 10 ** 400, r'diameter = <an integer of about 401 digits> is invalid; allowed: metres'),
    # The least positive values were said as 0 <, which 1e-7 is: the message names the bound the check applies.
    (('rods', 'jerk'), 1e-7, r'rods: jerk = 1e-07 is invalid; allowed: m/s\^3, 1e-06 <= jerk <= 10000, or null'),
    (('arms', 0, 'joints', 1, 'acceleration'), 1e-7,
     r'acceleration = 1e-07 is invalid; allowed: rad/s\^2, 1e-06 <= acceleration <= 1000$'),
    (('wafer', 'mass'), 1e-7, r'wafer: mass = 1e-07 is invalid; allowed: kg, 1e-06 <= mass <= 10$'),
    (('arms', 0, 'links', 'width'), 1e-7, r'links: width = 1e-07 is invalid; allowed: metres, 1e-06 <= width <= 1$'),
    (('rods', 'names'), ['a', 'b'], r'rods: names = \[.a., .b.\] is invalid; allowed: a list of 3 names'),
    (('arms',), [], r'arms must be a list of one or two arms'),
    (('arms',), [EXAMPLE['arms'][0]] * 3, r'arms must be a list of one or two arms'),
    (('arms', 0, 'joints'), [], r'arms\[0\] \(arm1\): joints must be a list of 2 to 4 revolute joints'),
    (('arms', 0, 'joints', 1, 'length'), -0.3,
     r'arms\[0\] \(arm1\): joints\[1\] \(arm1_elbow\): length = -0.3 is invalid; allowed: metres, 0 <= length <= 5 '
     r'\(at least 1e-06 but on the last joint\)'),
    (('arms', 0, 'joints', 0, 'length'), 0.0, r'arm1_shoulder: length = 0.0 is invalid; allowed: >= 1e-06 m for every'),
    (('arms', 1, 'joints', 0, 'length'), 5e-324,   # passed, and overflowed (RuntimeWarning) in the inverse kinematics
     r'arm2_shoulder: length = 5e-324 is invalid; allowed: >= 1e-06 m for every joint but the last'),
    (('arms', 0, 'joints', 1, 'lower'), 3.0, r'arm1_elbow\): lower = 3.0 must be below upper = 2.9'),
    (('arms', 0, 'joints', 1, 'upper'), 7.0, r'upper = 7.0 is invalid; allowed: radians within \[-2pi, 2pi\]'),
    (('arms', 0, 'joints', 1, 'velocity'), float('nan'),
     r'velocity = nan is invalid; allowed: rad/s, 1e-06 <= velocity <= 100'),
    (('arms', 0, 'joints', 1, 'speed'), 1, r'arms\[0\] \(arm1\): joints\[1\] \(arm1_elbow\): unknown key\(s\) speed; '
                                           r'allowed keys: acceleration, height, jerk, length'),
    (('arms', 0, 'brnch'), 'left', r'arms\[0\] \(arm1\): unknown key\(s\) brnch; allowed keys: blade, branch, home'),
    (('arms', 0, 'blade', 'wafer_centre'), _DELETE, r'blade: wafer_centre = None is invalid'),
    # not finite: the key's own range (a unitless coefficient was told "a finite number in ; got inf")
    (('arms', 0, 'blade', 'friction'), float('inf'), r'blade: friction = inf is invalid; allowed: a static friction '
                                                     r'coefficient, 0.001 to 2$'),
    (('arms', 0, 'blade', 'vacuum'), float('nan'), r'blade: vacuum = nan is invalid; allowed: newtons, 0'),
    (('arms', 0, 'branch'), 'up', r"branch = 'up' is invalid; allowed: left or right"),
    (('arms', 0, 'home'), [0, 3.0, 0], r'home: arm1_elbow = 3.0 is invalid; allowed: within \[-2.9, 2.9\] rad'),
    (('arms', 0, 'redundancy'), {'rule': 'nearest'}, r'redundancy applies to 4-joint arms only; this arm has 3'),
    (('arms', 1, 'redundancy'), _DELETE, r'a 4-joint arm needs redundancy: \{rule: fixed_joint, joint: NAME, '
     r'value: RAD\} or \{rule: nearest, joint: NAME, reference: \[\.\.\.\], weights: \[\.\.\.\]\}$'),
    (('arms', 1, 'redundancy', 'rule'), 'random', r"rule = 'random' is invalid; allowed: fixed_joint or nearest"),
    (('arms', 1, 'redundancy', 'joint'), 'arm1_elbow', r"joint = 'arm1_elbow' is invalid; allowed: one of arm2_"),
    (('arms', 1, 'redundancy', 'value'), 2.6, r'value = 2.6 is invalid; allowed: within the limits of arm2_wrist'),
    (('arms', 1, 'redundancy', 'reference'), [0, 0, 0, 0], r'unknown key\(s\) reference; allowed keys: joint, rule'),
    (('arms', 1, 'name'), 'arm1', r'names must be unique across rods, arms and joints; repeated: arm1'),
    (('arms', 1, 'joints', 0, 'name'), 'rod_1', r'repeated: rod_1'),
    # the rods' joint names on joint_states: an arm joint rod_1 made a trajectory name rod_1 twice, rods named
    # [rod_2, rod_1, rod_3] a table's rod_2 column hold q1 (both were accepted; the URDF refused the first)
    (('rods', 'names'), ['rod_2', 'rod_1', 'rod_3'], r"rods: names\[0\] = 'rod_2' is rod 2's joint name on "
     r"joint_states and in trajectories; allowed: 'rod_1' for rod 1, or a name other than rod_1, rod_2, rod_3"),
])
def test_bad_values_are_named(path, value, pattern):
    data = robot_data()
    _set(data, path, value)
    with pytest.raises(ConfigError, match=pattern):
        make_robot(data)


def test_an_arm_joint_named_as_a_rods_joint_on_joint_states_is_refused():
    """The rods named otherwise (the example's are rod_1 .. rod_3 themselves): an arm joint rod_1 made a trajectory
    name rod_1 twice (accepted; the URDF refused it)."""
    data = robot_data()
    _set(data, ('rods', 'names'), ['z1', 'z2', 'z3'])
    _set(data, ('arms', 1, 'joints', 0, 'name'), 'rod_1')
    with pytest.raises(ConfigError, match=r"arm joint name\(s\) rod_1 are the rods' joint names on joint_states and "
                                          r'in trajectories; allowed: other names than rod_1, rod_2, rod_3'):
        make_robot(data)


def test_nearest_rule_values_checked():
    data = robot_data()
    data['arms'][1]['redundancy'] = {'rule': 'nearest', 'weights': [0, 0, 0, 0]}
    with pytest.raises(ConfigError, match=r'weights = \[0.0, 0.0, 0.0, 0.0\] is invalid; allowed: numbers >= 0, '
                                          r'not all 0'):
        make_robot(data)
    data['arms'][1]['redundancy'] = {'rule': 'nearest'}
    red = make_robot(data).arm('arm2').redundancy
    assert red.joint == 0 and red.weights == (1.0,) * 4
    assert red.reference == pytest.approx((0.0, 0.0, 0.0, 0.0))  # the middle of symmetric ranges


def test_two_joint_arm_needs_the_wafer_off_the_last_axis():
    data = robot_data()
    arm = data['arms'][0]
    arm['joints'] = arm['joints'][:2]
    arm['joints'][1]['length'] = 0.0
    arm['blade'] = {'position': [0, 0, 0.01], 'wafer_centre': [0, 0, 0.004]}
    arm['home'] = [0, 0]
    with pytest.raises(ConfigError, match='the wafer centre lies on the last joint axis'):
        make_robot(data)


@pytest.mark.parametrize('text, pattern', [
    ('- 1\n- 2\n', r'expected a mapping \(a robot description'),
    ('name: [unclosed\n', r'not valid YAML'),
    ('', r'expected a mapping'),
])
def test_hostile_files(tmp_path, text, pattern):
    f = tmp_path / 'r.yaml'
    f.write_text(text)
    with pytest.raises(ConfigError, match=pattern):
        load_robot(f)
    with pytest.raises(ConfigError, match=r"cannot read robot file"):
        load_robot(tmp_path / 'absent.yaml')


def test_doctests_of_the_robot_modules():
    for module in (description, planar_arm, stations, transforms, rotations):
        result = doctest.testmod(module)
        assert result.failed == 0, module.__name__
    assert math.isclose(rotations.rpy_matrix(0.1, 0.2, 0.3)[2, 0], -math.sin(0.2))


@pytest.mark.parametrize('rule', ['fixed_joint', 'nearest'])
def test_to_dict_reads_back_through_yaml_into_an_equal_description(rule, tmp_path):
    """What a recording stores (gpr/robot): the description as YAML, read back equal, a calibrated-looking
    geometry and a 2-joint arm included."""
    data = robot_data()
    data['gpr'] = {'config': None, 'model': 'compliant', 'kappa': [4.0, 5.0, 6.0], 'rod_offsets': [1e-5, 0.0, -2e-5],
                   'rod_directions': [[1e-4, 0.0], [0.0, 0.0], [0.0, -1e-4]]}
    data['base']['rpy'] = [0.001, -0.002, 0.3]
    data['arms'][0]['joints'] = data['arms'][0]['joints'][:2]
    data['arms'][0]['home'] = [0.0, 2.5]
    if rule == 'nearest':
        data['arms'][1]['redundancy'] = {'rule': 'nearest', 'joint': 'arm2_elbow', 'reference': [0.1, -1.0, 0.2, 1.0],
                                         'weights': [1.0, 2.0, 0.5, 1.0]}
    robot = make_robot(data)
    text = yaml.safe_dump(robot.to_dict(), sort_keys=False)
    again = description.parse_robot(yaml.safe_load(text), robot.source)
    assert again == robot
    assert again.config.rod_directions == ((1e-4, 0.0), (0.0, 0.0), (0.0, -1e-4))
    assert again.arms[1].redundancy is not None and again.arms[1].redundancy.rule == rule


def test_a_path_that_is_not_one_is_named():
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.robot import load_robot

    with pytest.raises(ConfigError, match=r'robot description path = 5; allowed: a file path'):
        load_robot(5)


def test_orientations_within_a_turn_pass_as_written():
    """Base rpy, mount and blade yaw up to one turn (+1e-9 rad) are taken as written: 6.2 rad is no slip."""
    data = robot_data()
    data['base']['rpy'] = [6.2, -6.2, 2 * math.pi]
    data['arms'][0]['mount']['yaw'] = 6.2
    data['arms'][0]['blade']['yaw'] = -2 * math.pi - 1e-10
    robot = make_robot(data)
    assert robot.base_rpy == (6.2, -6.2, 2 * math.pi)
    assert robot.arms[0].mount_yaw == 6.2 and robot.arms[0].blade.yaw == -2 * math.pi - 1e-10


@pytest.mark.parametrize('frame', ['gpr_base', 'gpr_platform', 'arm2_link1', 'arm1_wafer'])
def test_the_world_is_none_of_the_robots_own_frames(frame):
    """``base.frame: gpr_base`` passed, and a cell given in ``gpr_base`` then read safe with its obstacles 2 m from
    where they stood; the URDF named it "link names must be unique". Refused at load, naming the key."""
    data = robot_data()
    data.setdefault('base', {})['frame'] = frame
    with pytest.raises(ConfigError, match=rf"base: frame = '{frame}' is one of the robot's own frames; allowed: a "
                                          r'name for the world the robot stands in \(default world\), not '
                                          r'arm1_blade, '):
        make_robot(data)


def test_a_nearest_reference_lies_within_the_joint_limits():
    """``reference: [0, 1, 5, 0]`` on a joint of [-2.2, 2.2] rad measured the posture -1.28 rad (the same angle) as
    3.5 rad away, so one posture written two ways gave two answers; refused with the angle modulo a turn. Negative
    weights are refused by the range the message names."""
    data = robot_data()
    arm = data['arms'][1]
    lower, upper = arm['joints'][2]['lower'], arm['joints'][2]['upper']
    reference = [0.5 * (j['lower'] + j['upper']) for j in arm['joints']]
    reference[2] = upper + 2 * math.pi - 0.1 - 4.0   # within one turn, outside the limits
    arm['redundancy'] = {'rule': 'nearest', 'reference': reference}
    with pytest.raises(ConfigError, match=rf'reference\[2\] = {reference[2]:g} rad is outside the limits of '
                                          rf'{arm["joints"][2]["name"]}, \[{lower:g}, {upper:g}\] rad; allowed: a '
                                          rf"posture within the joints' limits \({reference[2]:g} rad is "
                                          rf'{upper - 4.1:g} rad modulo a turn\)'):
        make_robot(data)
    arm['redundancy'] = {'rule': 'nearest', 'weights': [1.0, -1.0, 1.0, 1.0]}
    with pytest.raises(ConfigError, match=r'weights\[1\] = -1.0 is invalid; allowed: a list of 4 finite numbers in '
                                          r'\(no unit\), each within \[0, 1e\+06\]'):
        make_robot(data)


@pytest.mark.parametrize('geometry, shown', [({'model': 'radial'}, r"\{'model': 'radial'\}"), (5, '5')])
def test_a_geometry_that_is_no_file_or_config_is_named(geometry, shown):
    """load_robot(geometry={'model': 'radial'}) or geometry=5 made a robot whose config was that value: an
    AttributeError at its first use."""
    with pytest.raises(ConfigError, match=rf'^geometry = {shown}; allowed: a GPR geometry file path \(str or Path\), '
                                          r"a GprConfig \(load_config\) or None \(the description's gpr section\)$"):
        load_robot(geometry=geometry)


def test_tuples_are_named_as_tuples_and_joints_may_be_one():
    """kind_of called a tuple 'a list': joints as a tuple read 'joints must be a list ..., got a list'. A tuple of
    joints is taken as the list; a tuple where a mapping belongs is named a tuple."""
    data = robot_data()
    data['arms'][0]['joints'] = tuple(data['arms'][0]['joints'])
    assert make_robot(data).arms[0].joint_names == ROBOT.arms[0].joint_names
    data['base'] = (1.0, 2.0)
    with pytest.raises(ConfigError, match=r'^test_robot\.yaml: base: expected a mapping \(frame, position, rpy of '
                                          r'gpr_base in the world\), got a tuple$'):
        make_robot(data)


def test_rods_may_take_their_own_joint_names():
    """A rod may be named its own ``rod_k`` (rods named in the trajectory's order); only another rod's is refused."""
    data = robot_data()
    data['rods']['names'] = ['rod_1', 'rod_2', 'rod_3']
    assert make_robot(data).rods.names == ('rod_1', 'rod_2', 'rod_3')



def test_a_geometry_given_as_any_path_like_is_read_as_that_file(tmp_path):
    """os.PathLike is the documented kind of a path: one that is no ``pathlib.Path`` reads the same file."""
    import os

    class Where(os.PathLike):   # a caller's own path type
        def __init__(self, path):
            self.path = str(path)

        def __fspath__(self):
            return self.path

    source = tmp_path / 'geo.yaml'
    source.write_text('radius: 0.1\n')
    robot = load_robot(geometry=Where(source))
    assert robot.config.radius == 0.1 and robot.config == load_robot(geometry=source).config

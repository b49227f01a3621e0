"""Teach (joints -> stations) and re-teach (naive joints -> the joints that put the wafer where the old tool meant)."""
import numpy as np
import pytest
from gpr_kinematics.core.rotations import rotation_angle
from gpr_kinematics.errors import InputError, LimitError
from gpr_kinematics.robot.forward import robot_forward
from gpr_kinematics.robot.inverse import solve_stations
from gpr_kinematics.robot.planar_arm import branch_of
from gpr_kinematics.robot.teach import reteach, teach
from robot_support import ROBOT, elbow_angle, make_robot, random_postures, robot_data


@pytest.mark.parametrize('arm', ['arm1', 'arm2'])
def test_teach_then_solve_gives_the_joints_back(arm):
    Q, J = random_postures(ROBOT, arm, 500, seed=21)
    taught = teach(ROBOT, Q, J, arm)
    assert (taught.stations.tilt >= 0).all()
    np.testing.assert_allclose(taught.stations.rotation, taught.forward.wafer.rotation, atol=1e-15)
    np.testing.assert_allclose(taught.naive_stations.position, taught.forward.naive_wafer.position, atol=0)
    np.testing.assert_allclose(taught.naive_error, taught.stations.position - taught.naive_stations.position,
                               atol=0)
    sol = solve_stations(ROBOT, taught.stations, arm, branch=branch_of(ROBOT.arm(arm), J))
    np.testing.assert_allclose(sol.rods, Q, atol=1e-12)
    assert np.max(np.linalg.norm(sol.forward.wafer.position - taught.forward.wafer.position, axis=1)) < 1e-12


@pytest.mark.parametrize('arm', ['arm1', 'arm2'])
def test_reteach_puts_the_wafer_where_the_old_tool_meant(arm):
    """Old joints from the naive model: the old tool believed the wafer at the naive forward kinematics of them."""
    Q, J = random_postures(ROBOT, arm, 400, seed=22)
    # away from full stretch: there the corrected station can lie micrometres beyond the reach (refused)
    keep = np.abs(np.sin(elbow_angle(ROBOT, arm, J))) > 0.01
    Q, J = Q[keep], J[keep]
    old_fk = robot_forward(ROBOT, Q, J, arm)
    rt = reteach(ROBOT, Q, J, arm)
    ok = rt.solution.feasible
    assert ok.all()
    new_fk = robot_forward(ROBOT, rt.solution.rods, rt.solution.joints, arm)
    # the new joints put the wafer (really) where the old joints were meant to (naively)
    assert np.max(np.linalg.norm(new_fk.wafer.position - old_fk.naive_wafer.position, axis=1)) < 1e-9
    assert np.max(rotation_angle(new_fk.wafer.rotation, old_fk.naive_wafer.rotation)) < 1e-9
    # the avoided error is where the old joints really put the wafer minus where they meant to
    np.testing.assert_allclose(rt.avoided_error, old_fk.wafer.position - old_fk.naive_wafer.position, atol=1e-15)
    assert rt.avoided_error_norm.max() > 1e-6
    # the old joints are the naive model's answer for the intended station, so the two errors agree
    np.testing.assert_allclose(rt.solution.naive_wafer_error, rt.avoided_error, atol=1e-9)
    np.testing.assert_allclose(rt.solution.naive_rods, Q, atol=1e-12)
    assert rt.solution.branch == branch_of(ROBOT.arm(arm), J)
    if arm == 'arm2':
        np.testing.assert_allclose(rt.solution.joints[:, 2], J[:, 2], atol=0)


def test_reteach_keeps_a_joint_whose_range_exceeds_a_turn_near_its_old_value():
    """A shoulder of [-3.6, 3.6] rad at 200 deg (3.49 rad, within its limits) was re-taught at -160 deg, the
    representative nearest the range's middle: a turn the other way round for a correction of micrometres. The
    new joint lies near the old one now (within the correction), the wafer where the old tool meant it."""
    data = robot_data()
    data['arms'][0]['joints'][0].update(lower=-3.6, upper=3.6)
    robot = make_robot(data)
    Q = np.array([[0.2, 0.201, 0.199]] * 3)
    J = np.radians([[200.0, -60.0, 20.0], [-200.0, 60.0, 20.0], [100.0, 60.0, 20.0]])
    rt = reteach(robot, Q, J, 'arm1')
    assert np.max(np.abs(rt.solution.joints - J)) < 1e-3, rt.solution.joints
    assert np.array_equal(rt.solution.forward.joints, rt.solution.joints)
    new_fk = robot_forward(robot, rt.solution.rods, rt.solution.joints, 'arm1')
    old_fk = robot_forward(robot, Q, J, 'arm1', check_limits=False)
    assert np.max(np.linalg.norm(new_fk.wafer.position - old_fk.naive_wafer.position, axis=1)) < 1e-9
    # the inverse kinematics alone takes the representatives nearest the middle: a turn away from the old ones
    plain = solve_stations(robot, rt.intended, 'arm1', branch=branch_of(robot.arm('arm1'), J))
    assert np.allclose(plain.joints[:2, 0] - rt.solution.joints[:2, 0], [-2.0 * np.pi, 2.0 * np.pi])


def test_reteach_refuses_names_that_are_no_list():
    """reteach(names='ab') named two stations a and b; names=5 raised TypeError."""
    Q, J = random_postures(ROBOT, 'arm1', 2, seed=24)
    for names in ('ab', 5):
        with pytest.raises(InputError, match='names must be a list of station names, got '):
            reteach(ROBOT, Q, J, 'arm1', names=names)


def test_reteach_two_joint_arm_leaves_the_heading_to_the_arm():
    data = robot_data()
    data['arms'][0]['joints'] = data['arms'][0]['joints'][:2]
    data['arms'][0]['home'] = [0.0, 2.5]
    robot = make_robot(data)
    Q, J = random_postures(robot, 'arm1', 200, seed=23)
    keep = np.abs(np.sin(elbow_angle(robot, 'arm1', J))) > 0.01
    Q, J = Q[keep], J[keep]
    rt = reteach(robot, Q, J, 'arm1', names=[f's{i}' for i in range(len(Q))])
    assert rt.intended.heading_free.all() and rt.intended.names[3] == 's3'
    new_fk = robot_forward(robot, rt.solution.rods, rt.solution.joints, 'arm1')
    assert np.max(np.linalg.norm(new_fk.wafer.position - rt.intended.position, axis=1)) < 1e-9


def test_reteach_refuses_a_meant_station_beyond_the_reach():
    """Old joints at full stretch: the station the old tool meant lies micrometres beyond the real reach."""
    from gpr_kinematics.core import inverse
    q = inverse(0.3, 0.025, 0.5).q
    with pytest.raises(LimitError, match=r'station 0: out of reach of arm arm1: the wrist axis would be 0.6000\d+ m '
                                         r'from the shoulder axis, the arm spans \[0, 0.6\] m \(0.01\d+ mm too far\)'):
        reteach(ROBOT, [q], [[np.pi / 2, 0.0, 0.0]], 'arm1')


def test_reteach_refuses_old_joints_more_than_a_turn_beyond_their_limits():
    """The old joints were only held to +-1e6 rad: degrees read as radians (57.3 for 1 rad) were re-taught. Just
    within a turn beyond a limit is re-taught (the old tool need not keep the new limits); beyond it, refused."""
    import math

    from gpr_kinematics.errors import InputError
    q = [0.25, 0.251, 0.252]
    edge = 2.9 + 2 * math.pi
    rt = reteach(ROBOT, [q, q], [[0.0, 1.0, -0.5], [0.0, 1.0 + 2 * math.pi, -0.5]], 'arm1')   # a turn on: taken
    np.testing.assert_allclose(rt.solution.joints[1], rt.solution.joints[0], atol=1e-12)
    assert rt.solution.joints[0, 1] == pytest.approx(1.0, abs=1e-5)
    for value, side, limit in ((57.2957795, 'upper', 2.9), (-edge - 1e-6, 'lower', -2.9)):
        message = (rf'^old joints \(row 2\): arm1_elbow = {value:.9g} rad is more than a turn \(2 pi\) beyond its '
                   rf'{side} limit {limit:g} rad, no posture of it \(another unit\?\); allowed for old joints: '
                   r'\[-9.18318531, 9.18318531\] rad; in degrees\? give them in radians \(or --deg to gpr robot '
                   r'teach\)$')
        with pytest.raises(InputError, match=message):
            reteach(ROBOT, [q, q], [[0.0, 1.0, -0.5], [0.0, value, -0.5]], 'arm1')


def test_old_joints_exactly_a_turn_beyond_their_limits_are_re_taught():
    """The bound is inclusive ("more than a turn" is refused): the elbow at 2.9 + 2 pi and -2.9 - 2 pi rad on a level
    platform (no naive error) is the posture at its limit, re-taught as +-2.9 rad."""
    import math

    edge = 2.9 + 2 * math.pi
    q = [0.3, 0.3, 0.3]
    rt = reteach(ROBOT, [q, q], [[0.0, edge, -0.5], [0.0, -edge, 0.5]], 'arm1')
    np.testing.assert_allclose(rt.solution.joints, [[0.0, 2.9, -0.5], [0.0, -2.9, 0.5]], atol=1e-12)


def test_a_table_of_old_joints_takes_them_within_a_turn_of_either_limit(tmp_path):
    """read_joint_table without the limits (reteach's old joints): the elbow 6 rad below its lower limit -2.9 and
    above its upper 2.9 is read as written; a turn and a micro-radian beyond either is refused with the file's line
    and the allowed interval [-2.9 - 2 pi, 2.9 + 2 pi] = [-9.18318531, 9.18318531] rad."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.robot.teach import read_joint_table

    a = ROBOT.arm('arm1')
    header = ','.join(['name', *ROBOT.rods.names, *a.joint_names])
    table = tmp_path / 'old.csv'
    table.write_text(f'{header}\np1,0.3,0.3,0.3,0.0,-8.9,0.1\np2,0.3,0.3,0.3,0.0,8.9,0.1\n')
    names, rods, joints = read_joint_table(table, ROBOT, 'arm1', check_limits=False)
    assert names == ('p1', 'p2')
    np.testing.assert_array_equal(joints[:, 1], [-8.9, 8.9])
    for value, side in (('-9.183186', 'lower'), ('9.183186', 'upper')):
        table.write_text(f'{header}\np1,0.3,0.3,0.3,0.0,{value},0.1\n')
        with pytest.raises(ConfigError, match=rf'old.csv: line 2 \(row 1, station .p1.\): arm1_elbow = {value} rad is '
                                              rf'more than a turn \(2 pi\) beyond its {side} limit .*allowed for old '
                                              r'joints: \[-9.18318531, 9.18318531\] rad'):
            read_joint_table(table, ROBOT, 'arm1', check_limits=False)


def test_a_table_takes_a_joint_at_its_limit_to_rounding_as_teach_does(tmp_path):
    """A joint read back 5e-13 rad beyond its limit (a joint at the limit, rounded) is within LIMIT_SLACK (1e-12 rad),
    a rod 5e-13 m beyond the stroke within STROKE_SLACK: read_joint_table takes them, as teach's forward kinematics
    does; 2e-12 rad beyond is refused by both."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.robot.teach import read_joint_table

    a = ROBOT.arm('arm1')
    header = ','.join(['name', *ROBOT.rods.names, *a.joint_names])
    table = tmp_path / 'at_limit.csv'
    for value in (2.9 + 5e-13, -2.9 - 5e-13):
        table.write_text(f'{header}\np1,0.3,0.3,0.3,0.0,{value!r},0.1\n')
        _, rods, joints = read_joint_table(table, ROBOT, 'arm1')
        assert joints[0, 1] == value
        teach(ROBOT, rods, joints, 'arm1')
    for rods in ([0.508 + 5e-13] * 3, [-5e-13] * 3):   # within STROKE_SLACK (1e-12 m) of the stroke [0, 0.508] m
        table.write_text(f'{header}\np1,{",".join(map(repr, rods))},0.0,1.0,0.1\n')
        np.testing.assert_array_equal(read_joint_table(table, ROBOT, 'arm1')[1], [rods])
        teach(ROBOT, [rods], [[0.0, 1.0, 0.1]], 'arm1')
    table.write_text(f'{header}\np1,0.3,0.3,0.3,0.0,{2.9 + 2e-12!r},0.1\n')
    beyond = r'arm1_elbow = 2.900000000002 rad is beyond its upper limit 2.9 rad by 2e-12 rad'
    with pytest.raises(ConfigError, match=beyond):
        read_joint_table(table, ROBOT, 'arm1')
    with pytest.raises(LimitError, match=beyond):
        teach(ROBOT, [[0.3, 0.3, 0.3]], [[0.0, 2.9 + 2e-12, 0.1]], 'arm1')


@pytest.mark.parametrize('k', [0, 1, 2])
def test_reteach_refuses_each_old_rod_outside_the_stroke(k):
    """The old tool's rods were executed, so they lie within the stroke [0, 0.508] m: any one of them at 0.52 m is
    refused, named."""
    q = [0.3, 0.3, 0.3]
    q[k] = 0.52
    words = rf'^rod_{k + 1} = 0.52 m \(sample 1\) is outside the stroke \[0, 0.508\] m'
    with pytest.raises(LimitError, match=words):
        reteach(ROBOT, [[0.3, 0.3, 0.3], q], [[0.0, 1.0, 0.1]] * 2, 'arm1')


def test_a_joint_table_needs_every_rod_and_joint_column(tmp_path):
    """The header must name the three rods and every joint of the arm (a missing column is named, not read as empty
    cells); the name column is optional."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.robot.teach import read_joint_table

    a = ROBOT.arm('arm1')
    table = tmp_path / 'j.csv'
    table.write_text(','.join([*ROBOT.rods.names, *a.joint_names[:2]]) + '\n0.3,0.3,0.3,0.0,1.0\n')
    with pytest.raises(ConfigError, match=r'j.csv: the header lacks the column\(s\) arm1_wrist; required: rod_1, '
                                          r'rod_2, rod_3, arm1_shoulder, arm1_elbow, arm1_wrist$'):
        read_joint_table(table, ROBOT, 'arm1')
    table.write_text(','.join([*ROBOT.rods.names, *a.joint_names]) + '\n0.3,0.3,0.3,0.0,1.0,0.1\n')
    names, rods, joints = read_joint_table(table, ROBOT, 'arm1')
    assert names == ('0',) and rods.tolist() == [[0.3] * 3] and joints.tolist() == [[0.0, 1.0, 0.1]]
    for row in ('0.3,,0.3,0.0,1.0,0.1', '0.3,0.3,0.3,0.0,1.0,'):   # an empty cell is no value
        table.write_text(','.join([*ROBOT.rods.names, *a.joint_names]) + f'\n{row}\n')
        with pytest.raises(ConfigError, match=r'j.csv: line 2: every rod and joint needs a value$'):
            read_joint_table(table, ROBOT, 'arm1')
    table.write_text('# units: m rad\n' + ','.join([*ROBOT.rods.names, *a.joint_names]) + '\n')
    with pytest.raises(ConfigError, match=r'j.csv: no rows after the header \(line 2\); one row per entry is '
                                          r'required$'):
        read_joint_table(table, ROBOT, 'arm1')


def test_reteach_keeps_the_held_joint_of_a_fixed_joint_arm():
    """arm2 holds its wrist (fixed_joint, value 0): old joints with the wrist at 0.3 rad and -0.2 rad are re-taught
    with the wrist where it was (the branch kept too), not moved to the rule's 0, and the new joints put the wafer
    where the old tool meant it."""
    from gpr_kinematics.core import inverse
    q = inverse(0.3, 0.03, 0.5).q
    old = [[0.4, -1.2, 0.3, 0.5], [-0.3, 1.1, -0.2, -0.4]]
    rt = reteach(ROBOT, [q, q], old, 'arm2')
    np.testing.assert_allclose(rt.solution.joints[:, 2], [0.3, -0.2], rtol=0, atol=1e-15)
    assert rt.solution.branch == branch_of(ROBOT.arm('arm2'), np.array(old))
    fk = robot_forward(ROBOT, rt.solution.rods, rt.solution.joints, 'arm2')
    assert np.max(np.linalg.norm(fk.wafer.position - rt.intended.position, axis=1)) < 1e-9
    np.testing.assert_allclose(rt.solution.joints, old, atol=1e-3)   # the naive error is micrometres


def test_reteach_under_nearest_says_the_posture_changed(tmp_path, capsys):
    """arm2 under ``nearest`` takes the posture nearest its reference, not the old one: its wrist was re-taught
    0.0995 rad away (the hand 0.0817 rad) for an error of 17.7 um, and neither the text nor --json said so. The
    joints moved more than MOVED_JOINT are named with how far (new minus old), in the record and a warning line; under
    fixed_joint (the wrist held) nothing moves that far and nothing is named."""
    import json

    import yaml
    from gpr_kinematics.cli.main import main
    from gpr_kinematics.core import inverse
    from gpr_kinematics.robot.teach import MOVED_JOINT
    q = inverse(0.3, 0.03, 0.5).q
    old = np.array([[0.4, -1.2, 0.3, 0.5], [-0.3, 1.1, -0.2, -0.4]])
    data = robot_data()
    next(a for a in data['arms'] if a['name'] == 'arm2')['redundancy'] = {'rule': 'nearest', 'joint': 'arm2_wrist'}
    rt = reteach(make_robot(data), [q, q], old, 'arm2')
    change = rt.solution.joints - old
    np.testing.assert_array_equal(rt.joint_change, change)
    names = ('arm2_shoulder', 'arm2_elbow', 'arm2_wrist', 'arm2_hand')
    records = rt.records()
    for i, rec in enumerate(records):
        assert rec.moved == {n: float(change[i, k]) for k, n in enumerate(names) if abs(change[i, k]) > MOVED_JOINT}
    assert set(records[0].moved) == {'arm2_elbow', 'arm2_wrist', 'arm2_hand'}   # the shoulder 0.0047 rad: kept
    assert records[0].moved['arm2_wrist'] == pytest.approx(-0.0995, abs=1e-4)
    assert records[0].moved['arm2_hand'] == pytest.approx(0.0817, abs=1e-4)
    assert records[0].avoided_error < 2e-5   # micrometres to correct
    held = reteach(ROBOT, [q, q], old, 'arm2')   # fixed_joint: the old posture kept
    assert [r.moved for r in held.records()] == [{}, {}] and np.max(np.abs(held.joint_change)) < 1e-4
    # the CLI: a warning line naming the joints and how far, and the JSON field
    robot = tmp_path / 'nearest.yaml'
    robot.write_text(yaml.safe_dump(data | {'gpr': {'config': None, 'model': 'radial'}}))
    typed = ['--rods', *(repr(float(v)) for v in q), '--joints', *(repr(float(v)) for v in old[0]), '--naive']
    argv = ['robot', 'teach', '--robot', str(robot), '--arm', 'arm2', *typed]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert len(out.splitlines()) == 1 and out.startswith('0: meant '), out   # the station's line; the warning apart
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0] == (
        f'gpr robot teach: warning: 0: the posture changed: arm2_elbow moved {change[0, 1]:+.3f} rad, arm2_wrist moved '
        f'{change[0, 2]:+.3f} rad, arm2_hand moved {change[0, 3]:+.3f} rad from the old joints (more than 0.01 rad); '
        'arm arm2 takes the posture nearest its reference (redundancy rule nearest), not the old one: under the rule '
        "fixed_joint re-teach keeps its held joint's old value"), lines
    assert main([*argv, '--json']) == 0
    row = json.loads(capsys.readouterr().out)['stations'][0]
    assert row['moved'] == pytest.approx(records[0].moved, rel=1e-12)
    assert main(['robot', 'teach', '--arm', 'arm2', *typed, '--json']) == 0   # the example's arm2, fixed_joint
    assert json.loads(capsys.readouterr().out)['stations'][0]['moved'] == {}


def test_reteach_refuses_a_held_joint_beyond_its_limits_naming_the_row(tmp_path, capsys):
    """Old joints may lie beyond their limits, but arm2's held wrist (fixed_joint) keeps its old value in the new
    posture: 2.6 rad of [-2.5, 2.5] was refused as 'redundancy value = 2.6 rad (station s1)', a value the user never
    gave, without the file or the row; now named as the table's other rows are."""
    from gpr_kinematics.cli.main import main
    table = tmp_path / 'old.csv'
    table.write_text('name,rod_1,rod_2,rod_3,arm2_shoulder,arm2_elbow,arm2_wrist,arm2_hand\n'
                     's0,0.25,0.251,0.252,0,1,0.3,-0.5\ns1,0.25,0.251,0.252,0,1,2.6,-0.5\n')
    assert main(['robot', 'teach', '--table', str(table), '--naive', '--arm', 'arm2']) == 2
    assert capsys.readouterr().err == (
        f"gpr robot teach: error: {table}: old joints of row 2 (station 's1'): the held joint arm2_wrist = 2.6 rad is "
        'outside the limits of arm2_wrist, [-2.5, 2.5] rad; allowed: a value within them (re-teach keeps the held '
        "joint's old value)\n")
    with pytest.raises(LimitError, match=r'^old joints: the held joint arm2_wrist = -2\.6 rad is outside the limits'):
        reteach(ROBOT, [[0.25] * 3], [[0.0, 1.0, -2.6, 0.1]], 'arm2')
    reteach(ROBOT, [[0.25] * 3], [[0.0, 1.0, 2.5, 0.1]], 'arm2')   # at its limit: held there


def test_teach_refuses_joints_beyond_limits():
    with pytest.raises(LimitError, match=r'arm1_elbow = 3 rad is beyond its upper limit 2.9 rad'):
        teach(ROBOT, [[0.3, 0.3, 0.3]], [[0.0, 3.0, 0.0]], 'arm1')


def _joint_table(tmp_path, *names):
    """A joint table of arm1 with one row per name (the same joints), and its header."""
    a = ROBOT.arm('arm1')
    header = ','.join(['name', *ROBOT.rods.names, *a.joint_names])
    row = ','.join(['0.3'] * 3 + ['0.1'] * len(a.joints))
    table = tmp_path / 't.csv'
    table.write_text(header + '\n' + ''.join(f'{n},{row}\n' for n in names))
    return table


def test_a_joint_table_naming_a_station_twice_is_refused(tmp_path):
    """Two rows named p1 were taught silently (which one a program meant by p1 was then a guess)."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.robot.teach import read_joint_table

    table = _joint_table(tmp_path, 'p1', 'p2', 'p1')
    with pytest.raises(ConfigError, match=r't.csv: line 4: name .p1. is also the name of line 2; allowed: each name'):
        read_joint_table(table, ROBOT, 'arm1')
    assert read_joint_table(_joint_table(tmp_path, 'p1', 'p2'), ROBOT, 'arm1')[0] == ('p1', 'p2')


@pytest.mark.parametrize('name', ['"A\nB: station (9, 9, 9) m, FAKE"', 'x' * 65, '"a,b"', '=cmd|calc'])
def test_a_joint_table_name_follows_the_station_rule(tmp_path, name):
    """A taught name is printed and written into station tables: a quoted newline forged an output line."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.robot.teach import read_joint_table

    with pytest.raises(ConfigError, match=r't.csv: line 2.*name = .* is invalid; allowed: 1 to 64 letters, digits'):
        read_joint_table(_joint_table(tmp_path, name), ROBOT, 'arm1')


def test_a_joint_table_row_beyond_the_tilt_limit_is_named(tmp_path):
    """A row whose rods tilt the platform 12 deg was refused by forward kinematics naming the rods alone, no file, line
    or row (the stroke and the joints' limits were named): now as they are; the old rods of reteach stay unchecked."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.robot.teach import read_joint_table

    a = ROBOT.arm('arm1')
    table = tmp_path / 't.csv'
    table.write_text(','.join(['name', *ROBOT.rods.names, *a.joint_names]) + '\na,0.25,0.251,0.252,0,1,-0.5\n'
                     'b,0.25,0.28,0.252,0,1,-0.4\n')
    with pytest.raises(ConfigError, match=r"t\.csv: line 3 \(row 2, station 'b'\): q = \[0\.25, 0\.28, 0\.252\] m "
                                          r'tilts the platform by about 0\.2093 rad \(11\.99 deg\) in the naive model, '
                                          r'beyond the tilt limit'):
        read_joint_table(table, ROBOT, 'arm1')
    assert read_joint_table(table, ROBOT, 'arm1', check_limits=False)[0] == ('a', 'b')


def test_refusals_name_the_robots_own_rods():
    """A robot whose rods are named lift_a .. lift_c: robot_forward and teach said q1, reteach rod_1 (a name this
    robot does not have), where its NaN, robot ik and the joint tables said lift_a (docs/robot.md: the names of the
    refusals)."""
    data = robot_data()
    data['rods']['names'] = ['lift_a', 'lift_b', 'lift_c']
    robot = make_robot(data)
    for call in (lambda: robot_forward(robot, [[0.6, 0.25, 0.25]], [[0.0, 1.0, -0.5]], 'arm1'),
                 lambda: teach(robot, [[0.6, 0.25, 0.25]], [[0.0, 1.0, -0.5]], 'arm1'),
                 lambda: reteach(robot, [[0.25, 0.25, 0.25], [0.25, 0.6, 0.25]], [[0.0, 1.0, -0.5]] * 2, 'arm1')):
        with pytest.raises(LimitError, match=r'^lift_[ab] = 0.6 m( \(sample 1\))? is outside the stroke \[0, '
                                             r'0.508\] m'):
            call()


def test_old_rods_tilting_far_beyond_the_limit_are_named_not_their_station():
    """Old rods of 0.05, 0, 0 m (20.95 deg of tilt) were refused as a station plane tilted beyond the limit, with the
    hint of degrees given as radians the user had not typed: the old rods are named, as without --naive."""
    with pytest.raises(LimitError, match=r'^old rods: q = \[0.05, 0.0, 0.0\] m tilts the platform by about 0.3657 rad '
                                         r'\(20.95 deg\) in the naive model, beyond the tilt limit'):
        reteach(ROBOT, [[0.05, 0.0, 0.0]], [[0.0, 1.0, -0.5]], 'arm1')


def test_a_naive_tables_old_rods_are_named_by_file_row_and_station(tmp_path, capsys):
    """gpr robot teach --table --naive named the row's old rods by '(sample 1)', counted from 0, without the file
    or the station: now the file, the row from 1 and the station, as the table without --naive names them."""
    from gpr_kinematics.cli.main import main
    table = tmp_path / 't.csv'
    table.write_text('name,rod_1,rod_2,rod_3,arm1_shoulder,arm1_elbow,arm1_wrist\n'
                     's0,0.25,0.25,0.25,0,1,0\ns1,0.10,0.16,0.10,0,2.0,0\n')
    assert main(['robot', 'teach', '--table', str(table), '--naive']) == 2
    err = capsys.readouterr().err
    assert err == (f"gpr robot teach: error: {table}: old rods of row 2 (station 's1'): q = [0.1, 0.16, 0.1] m tilts "
                   'the platform by about 0.4435 rad (25.41 deg) in the naive model, beyond the tilt limit 0.03491 rad '
                   '(2 deg)\n')
    with pytest.raises(LimitError, match=r"^old rods of row 2 \(station 'b'\): q = \[0\.1, 0\.16, 0\.1\] m tilts"):
        reteach(ROBOT, [[0.25] * 3, [0.1, 0.16, 0.1]], [[0.0, 1.0, 0.0], [0.0, 2.0, 0.0]], 'arm1', names=['a', 'b'])
    # rods with no pose at all (the naive wafer's, computed on first use): named by their row too
    with pytest.raises(LimitError, match=r"^old rods of row 2 \(station 'b'\): q = \[0\.1, 0\.3, 0\.3\] m imply no "):
        reteach(ROBOT, [[0.25] * 3, [0.1, 0.3, 0.3]], [[0.0, 1.0, 0.0]] * 2, 'arm1', names=['a', 'b'])
    # rods typed on the command line: no table, no row to name
    assert main(['robot', 'teach', '--rods', '0.28', '0.3', '0.3', '--joints', '0.1', '0.2', '0.1', '--naive']) == 2
    assert capsys.readouterr().err.startswith('gpr robot teach: error: old rods: q = [0.28, 0.3, 0.3] m tilts')


def test_a_joint_table_of_another_arm_says_which_arm(tmp_path):
    """A table whose header names arm2's joints, read for the default arm1: 'header column 4 'arm2_shoulder' is
    invalid; allowed: ... arm1_wrist ...' and nothing more; it names the arm to give now."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.robot.teach import read_joint_table

    table = tmp_path / 't2.csv'
    table.write_text('rod_1,rod_2,rod_3,arm2_shoulder [deg],arm2_elbow,arm2_wrist,arm2_hand\n'
                     '0.3,0.301,0.302,1,-1.8,0.2,0.8\n')
    with pytest.raises(ConfigError, match=r"header column 4 'arm2_shoulder \[deg\]' is invalid; .* \(the header "
                                          r"names arm arm2's joints: give that arm, --arm arm2\)$"):
        read_joint_table(table, ROBOT)
    assert read_joint_table(table, ROBOT, 'arm2')[1].shape == (1, 3)
    for header in ('"rod_1","rod_2","rod_3","arm2_shoulder","arm2_elbow","arm2_wrist","arm2_hand"',   # quoted
                   'rod_1,rod_2,rod_3,arm2_shoulder [rad],arm2_elbow [rad],arm2_wrist [rad],arm2_hand [rad]'):
        for comment in ('', '# taught on the old tool\n'):
            table.write_text(f'{comment}{header}\n0.3,0.301,0.302,1,-1.8,0.2,0.8\n')
            with pytest.raises(ConfigError, match=r"--arm arm2\)$"):
                read_joint_table(table, ROBOT)
    table.write_text('rod_1,rod_2,rod_3,elbow\n0.3,0.3,0.3,1\n')   # no arm's: as before
    with pytest.raises(ConfigError, match=r"header column 4 'elbow' is invalid; allowed: [^(]*$"):
        read_joint_table(table, ROBOT)


@pytest.fixture
def stroke_checks(monkeypatch):
    """The rods the core's check_stroke sees, by the names it is given, wherever the robot's paths and forward
    kinematics call it; and the ``stroke`` argument the robot's paths pass to forward kinematics."""
    import importlib

    core_forward, robot_forward_module, teach_module = (importlib.import_module(f'gpr_kinematics.{name}') for name in
                                                        ('core.forward', 'robot.forward', 'robot.teach'))
    real = core_forward.check_stroke
    seen: dict[str, list] = {'checked': [], 'stroke': []}

    def check(ops, q, config, *args, **kwargs):
        seen['checked'].append((kwargs.get('names'), np.atleast_2d(np.stack([np.asarray(v) for v in q], -1)).shape[0]))
        return real(ops, q, config, *args, **kwargs)

    for module in (core_forward, robot_forward_module, teach_module):
        monkeypatch.setattr(module, 'check_stroke', check, raising=False)
    for module in (robot_forward_module, teach_module):
        for name in ('forward', 'forward_batch'):
            fn = getattr(module, name, None)
            if fn is not None:
                def spy(*args, _fn=fn, **kwargs):
                    seen['stroke'].append(kwargs.get('stroke', True))
                    return _fn(*args, **kwargs)
                monkeypatch.setattr(module, name, spy)
    return seen


@pytest.mark.parametrize('rows', [1, 3])
def test_robot_forward_checks_each_rod_once_by_the_cores_check(stroke_checks, rows):
    """robot_forward checked the rods (its check_rods) and forward kinematics checked them again (the core's own, as
    q1 .. q3): now the core's check once, with the robot's names, and forward kinematics skips the stroke."""
    robot_forward(ROBOT, [[0.3, 0.3, 0.3]] * rows, [[0.0, 1.0, 0.1]] * rows, 'arm1')
    assert stroke_checks == {'checked': [(ROBOT.rods.names, rows)], 'stroke': [False]}


def test_a_joint_tables_rows_are_checked_once_each_by_the_cores_check(stroke_checks, tmp_path):
    """read_joint_table checked each row's rods in a copy of the stroke rule (_check_row), then forward kinematics
    checked them all again: now the core's check per row, with the robot's names, and the solve skips the stroke."""
    from gpr_kinematics.robot.teach import read_joint_table

    read_joint_table(_joint_table(tmp_path, 'p1', 'p2'), ROBOT, 'arm1')
    assert stroke_checks == {'checked': [(ROBOT.rods.names, 1)] * 2, 'stroke': [False]}


def test_reteach_checks_the_old_rods_once(stroke_checks):
    reteach(ROBOT, [[0.3, 0.3, 0.3]] * 2, [[0.0, 1.0, 0.1]] * 2, 'arm1')
    assert stroke_checks['checked'] == [(ROBOT.rods.names, 2)]


def test_the_one_configuration_path_of_the_nodes_names_the_robots_rods():
    """forward_floats (the robot forward kinematics service's path) left the stroke to the core, which named the rods
    q1 .. q3 where robot_forward names the robot's: 'rod_3 = 0.6 m is outside the stroke'."""
    from gpr_kinematics.robot.forward import forward_floats

    with pytest.raises(LimitError, match=r'^rod_3 = 0.6 m is outside the stroke \[0, 0.508\] m$'):
        forward_floats(ROBOT, ROBOT.arm('arm1'), [0.3, 0.3, 0.6], [0.0, 1.0, 0.1])
    with pytest.raises(LimitError, match=r'^rod_1 = 250 m is outside the stroke .* millimetres given as metres\?$'):
        forward_floats(ROBOT, ROBOT.arm('arm1'), [250.0, 0.3, 0.3], [0.0, 1.0, 0.1])

"""Checking programs: every waypoint reached by forward kinematics, idle arms holding, the limits met by the
samples, requested times honoured, and unreachable or too fast programs refused with the step."""
import numpy as np
import pytest
import yaml
from gpr_kinematics.core.rotations import rotation_angle
from gpr_kinematics.errors import InputError, LimitError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.forward import robot_forward
from gpr_kinematics.robot.plan import joint_limits, plan_program, sample_plan
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.robot.stations import stations_from_poses
from robot_support import ROBOT, tilted_rods_robot

PLAN = plan_program(ROBOT, load_program(config_path('programs/example_robot_program.yaml')))


def test_every_waypoint_is_reached():
    names, _, _, slices = joint_limits(ROBOT)
    assert PLAN.joint_names == names and len(names) == 3 + 3 + 4
    w = PLAN.waypoints
    for a, cols in zip(ROBOT.arms, slices, strict=True):
        idx = np.flatnonzero(np.array(w.arm) == a.name)
        fk = robot_forward(ROBOT, PLAN.positions[idx, :3], PLAN.positions[idx, cols], a.name)
        st = w.stations.take(idx)
        assert np.max(np.linalg.norm(fk.wafer.position - st.position, axis=1)) < 1e-9
        assert np.max(rotation_angle(fk.wafer.rotation, st.rotation)) < 1e-9
        np.testing.assert_allclose(PLAN.wafer.position[idx], fk.wafer.position, atol=1e-15)


def test_an_idle_arm_holds_its_joints():
    _, _, _, slices = joint_limits(ROBOT)
    first_arm2 = PLAN.waypoints.arm.index('arm2')
    np.testing.assert_array_equal(PLAN.positions[:first_arm2, slices[1]], np.tile(ROBOT.arm('arm2').home,
                                                                                  (first_arm2, 1)))
    last_arm1 = max(i for i, a in enumerate(PLAN.waypoints.arm) if a == 'arm1' and i < first_arm2)
    np.testing.assert_array_equal(PLAN.positions[first_arm2:first_arm2 + 6, slices[0]],
                                  np.tile(PLAN.positions[last_arm1, slices[0]], (6, 1)))


def test_times_and_samples_meet_the_limits():
    t = PLAN.timing
    i = PLAN.labels.index('steps[5] (place chamber_a, approach)')
    assert t.duration[i - 1] == pytest.approx(4.0)  # the step's requested time
    v, a = t.usage()
    assert np.all(v <= 1 + 1e-12) and np.all(a <= 1 + 1e-12) and v.max() == pytest.approx(1.0)
    rate = 500.0
    s = sample_plan(PLAN, rate)
    dt = np.diff(s.samples.time)
    vel = np.diff(s.samples.positions, axis=0) / dt[:, None]
    _, vmax, _, _ = joint_limits(ROBOT)
    assert np.all(np.abs(vel) <= vmax * (1 + 1e-9))
    held = s.samples.held >= 0
    k = s.samples.held[held]
    np.testing.assert_allclose(s.wafer.position[held], PLAN.wafer.position[k], atol=1e-12)
    assert set(s.arm) == {'arm1', 'arm2'}



def test_a_plan_is_sampled_at_a_rate_or_at_times_and_outside_it_rests_at_its_ends():
    """A rate beside times was ignored whatever it was ('junk'); neither or both is refused. A time outside the plan
    is the robot at rest at that end (documented now), at the time given."""
    from gpr_kinematics.errors import InputError
    for kwargs, words in (({}, 'neither a rate nor'), ({'rate': 'junk', 'times': [1.0]}, 'both a rate and'),
                          ({'rate': 10.0, 'times': [1.0]}, 'both a rate and')):
        with pytest.raises(InputError, match=rf'^sample_plan got {words} times; allowed: one of them$'):
            sample_plan(PLAN, **kwargs)
    end = PLAN.timing.total
    s = sample_plan(PLAN, times=[-5.0, 0.0, end, end + 1000.0]).samples
    np.testing.assert_array_equal(s.time, [-5.0, 0.0, end, end + 1000.0])
    np.testing.assert_array_equal(s.positions[0], s.positions[1])
    np.testing.assert_array_equal(s.positions[3], s.positions[2])

def _program_file(tmp_path, stations, steps):
    data = {'format': 'gpr_robot_program', 'stations': stations, 'steps': steps}
    f = tmp_path / 'p.yaml'
    f.write_text(yaml.safe_dump(data))
    return load_program(f)


def test_unreachable_waypoint_refused_with_its_step(tmp_path):
    p = _program_file(tmp_path, [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0},
                                 {'name': 'far', 'position': [2.5, 0.5, 0.45], 'heading': 0.0}],
                      [{'move': 'a'}, {'pick': 'far'}, {'place': 'far'}])
    with pytest.raises(LimitError, match=r"p.yaml: steps\[1\] \(pick far, approach\): station far/approach: out of "
                                         r"reach of arm arm1: .* \(and 5 more waypoints\)$"):
        plan_program(ROBOT, p)


def test_a_station_beyond_the_tilt_limit_refused_with_its_step(tmp_path):
    """The tilt refusal came out of the arm's batch without the program and the step (`station b: the station plane
    tilts 68.7549 deg ... (and 2 more stations)`: a program's degrees read as radians); now it is the first such
    waypoint's, as the other refusals."""
    p = _program_file(tmp_path, [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0},
                                 {'name': 'b', 'position': [1.2, 0.5, 0.45], 'tilt': 1.2, 'heading': 0.0}],
                      [{'move': 'a'}, {'pick': 'b'}, {'move': 'a'}])
    with pytest.raises(LimitError, match=r"/p.yaml: steps\[1\] \(pick b, approach\): station b/approach: the "
                                         r"station plane tilts 68.7549 deg in gpr_base, beyond the tilt limit 2 deg by "
                                         r"66.8 deg \(1.17 rad\); a tilt of 1.2 deg would be within it: degrees "
                                         r"given as radians\? \(and 2 more waypoints\)$"):
        plan_program(ROBOT, p)


def test_a_station_without_heading_for_a_3_joint_arm_refused_with_its_step(tmp_path):
    """The only waypoint refusal without the program and the step (an InputError of the arm's batch)."""
    p = _program_file(tmp_path, [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0},
                                 {'name': 'b', 'position': [1.0, 0.6, 0.45]}],
                      [{'move': 'a'}, {'pick': 'b'}])
    with pytest.raises(InputError, match=r"/p.yaml: steps\[1\] \(pick b, approach\): station b/approach: arm arm1 has "
                                         r"3 joints and needs the blade heading; only a 2-joint arm leaves it free$"):
        plan_program(ROBOT, p)


def test_a_refusal_of_the_batch_names_the_waypoint_it_is_about(tmp_path, monkeypatch):
    """The planner gave an InputError of an arm's batch to its first waypoint (or first without heading): an
    error about the third step was said of the first. It solves each waypoint alone to find it."""
    import gpr_kinematics.robot.plan as plan
    real = plan.solve_stations

    def refusing(robot, stations, *args, **kwargs):
        if any(name.startswith('b') for name in stations.names):
            raise LimitError('station b is refused')
        return real(robot, stations, *args, **kwargs)

    monkeypatch.setattr(plan, 'solve_stations', refusing)
    p = _program_file(tmp_path, [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0},
                                 {'name': 'b', 'position': [1.0, 0.6, 0.45], 'heading': 0.3}],
                      [{'move': 'a'}, {'dwell': 1.0}, {'move': 'b'}])
    with pytest.raises(LimitError, match=r"/p.yaml: steps\[2\] \(move b, move\): station b is refused$"):
        plan_program(ROBOT, p)


def test_a_refusal_of_the_batch_no_waypoint_alone_makes_names_the_program_and_the_arm(tmp_path, monkeypatch):
    """A batch refused though each waypoint alone is solved: the batch's message, with the program and the arm."""
    import gpr_kinematics.robot.plan as plan
    real = plan.solve_stations

    def refusing(robot, stations, *args, **kwargs):
        if len(stations.names) > 1:
            raise LimitError('the batch is refused')
        return real(robot, stations, *args, **kwargs)

    monkeypatch.setattr(plan, 'solve_stations', refusing)
    p = _program_file(tmp_path, [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0},
                                 {'name': 'b', 'position': [1.0, 0.6, 0.45], 'heading': 0.3}],
                      [{'move': 'a'}, {'dwell': 1.0}, {'move': 'b'}])
    with pytest.raises(LimitError) as caught:
        plan_program(ROBOT, p)
    assert str(caught.value) == f'{p.source}: arm {ROBOT.arms[0].name}: the batch is refused'


def test_a_station_below_the_stroke_on_rods_that_are_not_parallel_is_named_with_its_step(tmp_path):
    """Rods that are not parallel: a station 1 cm below the stroke after two moves to a reachable one was said of
    steps[0] in the core's words (q1 = -0.00999381229 m (sample 2) is outside the stroke); the robot's refusal of
    its own step now, as on parallel rods."""
    robot = tilted_rods_robot()
    fk = robot_forward(robot, [[0.25, 0.2504, 0.2497], [0.0, 0.0005, 0.0002]], [[0.4, 1.0, 0.5], [0.1, 0.2, 0.3]],
                       'arm1')
    st = stations_from_poses(fk.wafer.position - [[0.0, 0.0, 0.0], [0.0, 0.0, 0.01]], fk.wafer.rotation)
    rows = [{'name': name, 'position': st.position[i].tolist(), 'tilt': float(st.tilt[i]),
             'azimuth': float(st.azimuth[i]), 'heading': float(st.heading[i])} for i, name in enumerate(['s1', 'low'])]
    p = _program_file(tmp_path, rows, [{'move': 's1'}, {'dwell': 1.0}, {'move': 's1'}, {'move': 'low'}])
    with pytest.raises(LimitError, match=r"/p.yaml: steps\[3\] \(move low, move\): station low: rod_1 = "
                                         r"-0.0099\d+ m is below the stroke \[0, 0.508\] m by 0\.0099\d+ m "
                                         r"\(9.99\d mm\): the station is too low for arm arm1$"):
        plan_program(robot, p)


def test_too_fast_a_move_refused_with_its_step(tmp_path):
    p = _program_file(tmp_path, [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0},
                                 {'name': 'b', 'position': [0.75, 1.1, 0.3], 'heading': 1.5}],
                      [{'move': 'a'}, {'move': 'b', 'time': 0.2}])
    with pytest.raises(LimitError, match=r"p.yaml: the move into steps\[1\] \(move b, move\) needs at least \d\.\d+ s "
                                         r"within the limits, time = 0.2 s is too short \(\w+ alone needs"):
        plan_program(ROBOT, p)


def test_too_fast_a_move_is_named_before_the_sample_count(tmp_path):
    """A rate whose samples the program would exceed once its too-short move is lengthened: the move is what is
    wrong, named as without a rate (it read "more than 200000 samples" first: the least times take the longer of
    the requested and the least time)."""
    p = _program_file(tmp_path, [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0},
                                 {'name': 'b', 'position': [0.75, 1.1, 0.3], 'heading': 1.5}],
                      [{'move': 'a'}, {'move': 'b', 'time': 0.2}, {'move': 'a', 'time': 60.0}])
    with pytest.raises(LimitError) as plain:
        plan_program(ROBOT, p)
    with pytest.raises(LimitError) as rated:
        plan_program(ROBOT, p, rate=4000.0)
    assert str(rated.value) == str(plain.value)
    assert 'steps[1] (move b, move) needs at least' in str(rated.value) and 'time = 0.2 s is too short' in str(
        rated.value)


@pytest.mark.slow
def test_a_thousand_station_program(tmp_path):
    rng = np.random.default_rng(3)
    r = rng.uniform(0.4, 0.7, 1000)
    ang = rng.uniform(-2.5, 2.5, 1000)  # the shoulder cannot turn to face backwards (limits 3.05 rad)
    base = np.array(ROBOT.base_position)
    stations = [{'name': f's{i}', 'position': [float(base[0] + r[i] * np.cos(ang[i])),
                                               float(base[1] + r[i] * np.sin(ang[i])), float(rng.uniform(0.3, 0.6))],
                 'tilt': float(rng.uniform(0, 0.03)), 'azimuth': float(rng.uniform(-3, 3)), 'heading': float(ang[i]),
                 'branch': 'left' if ang[i] < 0 else 'right'}  # the elbow on the side that keeps the shoulder in range
                for i in range(1000)]
    p = _program_file(tmp_path, stations, [{'pick' if i % 2 else 'place': f's{i}'} for i in range(1000)])
    plan = plan_program(ROBOT, p)
    assert len(plan.waypoints) == 3000
    assert np.max(np.linalg.norm(plan.wafer.position - plan.waypoints.stations.position, axis=1)) < 1e-9


def test_a_program_too_long_to_sample_is_refused_before_it_is_planned(monkeypatch):
    """Issue 18: the sample count was known only after the plan (91 s for a goal of 100,000 stations). The dwells
    and requested move times bound the duration from below, before any station is solved."""
    import dataclasses

    from gpr_kinematics.robot import plan as plan_module
    program = load_program(config_path('programs/example_robot_program.yaml'))
    least = plan_module.shortest_duration(program)
    total = plan_program(ROBOT, program).timing.total
    assert 0 < least <= total      # a lower bound: 5 dwells of 0.5 s, one of 1 s, the dwell step, a 4 s move
    assert least == pytest.approx(0.5 * 8 + 1.0 + 0.5 + 4.0)
    plan_module.check_sample_count(program, 100.0)
    long = dataclasses.replace(program, dwell=1e4)
    monkeypatch.setattr(plan_module, 'solve_stations', lambda *a, **k: pytest.fail('planned'))
    with pytest.raises(InputError, match=r'lasts at least 80005\.5 s \(its dwells and move times\): at 100 Hz '
                                         r'more than 200000 samples; allowed: at most 200000'):
        plan_module.check_sample_count(long, 100.0)


def test_moves_too_long_to_sample_are_refused_before_they_are_timed(monkeypatch):
    """The moves as fast as the limits allow counted 0 s before planning: a program whose moves alone pass the
    samples allowed was refused only once planned (2,000 steps of the cell program at 100 Hz: 4.0 s, most of it the
    straight lines' gains and the curved moves' timing). Its moves' least times on the joint-space lines bound it
    from below once the waypoints are solved (cheap), before the lines and the timing."""
    from gpr_kinematics.robot import plan as plan_module
    cell = load_program(config_path('programs/example_cell_program.yaml'))
    plan_module.check_sample_count(cell, 5000.0)   # the dwells alone, 9 s, pass
    monkeypatch.setattr(plan_module, 'line_gains', lambda *a, **k: pytest.fail('the lines were bounded'))
    monkeypatch.setattr(plan_module, 'parameterise', lambda *a, **k: pytest.fail('the moves were timed'))
    with pytest.raises(InputError, match=r"example_cell_program.yaml: the program lasts at least 48\.9416 s \(its "
                                         r"dwells and its moves' least times within the joints' limits\): at 5000 Hz "
                                         r'more than 200000 samples; allowed: at most 200000; lower the rate'):
        plan_program(ROBOT, cell, rate=5000.0)


def test_a_program_too_long_to_sample_is_refused_once_timed():
    """Between the bound and the duration (the cell program's straight entries take longer than the joint-space
    lines: 48.94 s against 59.58 s): refused by its duration once its moves are timed, before it is sampled."""
    cell = load_program(config_path('programs/example_cell_program.yaml'))
    with pytest.raises(InputError, match=r'example_cell_program.yaml: the program lasts 59\.582 s: at 4000 Hz that is '
                                         r'238329 samples; allowed: at most 200000; lower the rate'):
        plan_program(ROBOT, cell, rate=4000.0)


def test_a_timed_move_of_no_length_holds_for_its_time(tmp_path):
    """A step's time sets its move's duration, also for a move that moves nothing: the robot stays at its waypoint for
    that time (it took 0 s whatever it asked for, while the bounds before planning counted the time: 'move a' twice,
    the second with time 50 s, was refused at 5000 Hz by the least times and planned in 0 s without a rate)."""
    from gpr_kinematics.robot.plan import jerk_limits
    from gpr_kinematics.robot.timing import least_total
    p = _program_file(tmp_path, [{'name': 'a', 'position': [1.2, 0.5, 0.45], 'heading': 0.0}],
                      [{'move': 'a'}, {'move': 'a', 'time': 50.0}])
    with pytest.raises(InputError, match='more than 200000 samples'):
        plan_program(ROBOT, p, rate=5000.0)
    plan = plan_program(ROBOT, p, rate=1000.0)
    assert plan.timing.total == 50.0 and list(plan.timing.duration) == [50.0]
    _, velocity, acceleration, _ = joint_limits(ROBOT)
    bound = least_total(plan.positions, velocity, acceleration, jerk_limits(ROBOT), plan.waypoints.time,
                        plan.waypoints.dwell, plan.joint_names, plan.labels)
    assert bound == pytest.approx(50.0, rel=2e-9) and bound <= 50.0
    samples = sample_plan(plan, 10.0)
    assert len(samples) == 501 and np.array_equal(samples.samples.positions, np.repeat(plan.positions[:1], 501, axis=0))
    untimed = plan_program(ROBOT, _program_file(tmp_path, [{'name': 'a', 'position': [1.2, 0.5, 0.45],
                                                            'heading': 0.0}], [{'move': 'a'}, {'move': 'a'}]))
    assert untimed.timing.total == 0.0


@pytest.mark.parametrize('name, least', [('example_robot_program', 28.52769181819494),
                                         ('example_cell_program', 48.941574447374975)])
def test_the_least_duration_bounds_the_example_programs(name, least):
    """The moves' least times: the duration itself on joint-space lines (to 1e-9), below it on straight entries; the
    example programs are planned as before at an allowed rate."""
    from gpr_kinematics.robot.plan import jerk_limits
    from gpr_kinematics.robot.timing import least_total
    program = load_program(config_path(f'programs/{name}.yaml'))
    plan = plan_program(ROBOT, program)
    _, velocity, acceleration, _ = joint_limits(ROBOT)
    bound = least_total(plan.positions, velocity, acceleration, jerk_limits(ROBOT), plan.waypoints.time,
                        plan.waypoints.dwell, plan.joint_names, plan.labels)
    assert bound == pytest.approx(least, rel=2e-9) and bound < plan.timing.total
    assert plan.timing.total == {'example_robot_program': pytest.approx(least, rel=1e-12),
                                 'example_cell_program': pytest.approx(59.58197148682389, rel=1e-9)}[name]
    again = plan_program(ROBOT, program, rate=100.0)
    np.testing.assert_array_equal(again.timing.arrive, plan.timing.arrive)
    np.testing.assert_array_equal(again.positions, plan.positions)


@pytest.mark.parametrize('limit', ['acceleration', 'jerk', 'velocity'])
def test_higher_arm_limits_never_slow_the_cell_program(limit):
    """The example cell program with its arm joints' limits raised: no move lengthens (its straight entries were
    3.03 s at x1, 2.55 s at x2 and 3.39 s at x10 of the acceleration limits; 60.55, 54.37, 61.11 s in all)."""
    import dataclasses

    program = load_program(config_path('programs/example_cell_program.yaml'))
    durations = []
    for factor in (1.0, 2.0, 3.0, 5.0, 10.0):
        arms = tuple(dataclasses.replace(a, joints=tuple(
            dataclasses.replace(j, **{limit: getattr(j, limit) * factor}) for j in a.joints)) for a in ROBOT.arms)
        plan = plan_program(dataclasses.replace(ROBOT, arms=arms), program)
        v, a = plan.timing.usage()
        assert np.all(v <= 1 + 1e-12) and np.all(a <= 1 + 1e-12) and np.all(plan.timing.jerk_usage() <= 1 + 1e-12)
        durations.append(plan.timing.duration)
    d = np.array(durations)
    assert np.all(d[1:] <= d[:-1] * (1 + 1e-12)), d.sum(axis=1)


def test_the_summary_gives_the_peaks_the_joints_reach():
    """``gpr program check`` printed the timing's chain-rule bounds as the joints' peak speed and acceleration: on the
    cell program's straight entries they lie well above what the joints reach (arm2_elbow 0.565 of its speed limit
    for 0.422, arm2_hand 0.576 of its acceleration limit for 0.239). The summary now gives the peaks, which central
    differences of the samples (2 kHz on the lines, where the bounds differ) find to 2e-3 (their truncation at the
    acceleration's corners), and the bounds stay within the limits."""
    from gpr_kinematics.robot.plan import line_moves, program_summary

    plan = plan_program(ROBOT, load_program(config_path('programs/example_cell_program.yaml')))
    s = program_summary(plan)
    bound_v, bound_a = plan.timing.usage()
    k_elbow, k_hand = plan.joint_names.index('arm2_elbow'), plan.joint_names.index('arm2_hand')
    assert (bound_v[k_elbow], bound_a[k_hand]) == pytest.approx((0.5648, 0.5756), abs=1e-4)
    assert (s.velocity_usage[k_elbow], s.acceleration_usage[k_hand]) == pytest.approx((0.4220, 0.2385), abs=1e-3)
    assert np.all(s.velocity_usage <= bound_v + 1e-9) and np.all(s.acceleration_usage <= bound_a + 1e-9)
    t, h = plan.timing, 1 / 2000
    v_fd, a_fd = np.zeros(len(plan.joint_names)), np.zeros(len(plan.joint_names))
    for m in line_moves(plan.waypoints):
        times = np.arange(t.depart[m] - h, t.arrive[m + 1] + h, h)
        x = sample_plan(plan, times=times).samples.positions
        v_fd = np.maximum(v_fd, np.max(np.abs(x[2:] - x[:-2]) / (2 * h), axis=0))
        a_fd = np.maximum(a_fd, np.max(np.abs(x[2:] - 2 * x[1:-1] + x[:-2]) / h ** 2, axis=0))
    joint_space = np.setdiff1d(np.arange(len(t.duration)), line_moves(plan.waypoints))
    v_js, a_js, _ = (x[joint_space].max(axis=0) for x in t.peaks())    # exact on joint-space lines
    np.testing.assert_allclose(s.velocity_usage, np.maximum(v_js, v_fd) / t.velocity, atol=2e-3, rtol=0)
    np.testing.assert_allclose(s.acceleration_usage, np.maximum(a_js, a_fd) / t.acceleration, atol=2e-3, rtol=0)


def _entry_program(first_arm, first_branch='right'):
    """Move an arm somewhere, then place into a chamber with a straight entry with arm2 on its right branch (the
    cell's pm1)."""
    from gpr_kinematics.robot.program import parse_program

    first = {'move': 'front_a1' if first_arm == 'arm1' else 'front', 'arm': first_arm, 'branch': first_branch}
    data = {'format': 'gpr_robot_program', 'units': {'length': 'mm', 'angle': 'deg'},
            'defaults': {'arm': 'arm2', 'branch': 'right', 'approach_height': 8, 'retract_height': 8, 'dwell': 0.5},
            'stations': [{'name': 'front', 'position': [750, 800, 720], 'heading': 90},
                         {'name': 'front_a1', 'position': [750, 800, 450], 'heading': 90},
                         {'name': 'pm1', 'position': [1450, 500, 720], 'tilt': 1.5, 'azimuth': 120, 'heading': 0,
                          'entry': 330}],
            'steps': [first, {'place': 'pm1'}]}
    return plan_program(ROBOT, parse_program(data, 'entry.yaml'))


def test_a_straight_line_is_timed_by_its_own_arm_whatever_arm_moved_before():
    """The moves of a place through a straight entry (into the approach and the exit lines) take the same time
    whether arm1 (on either branch) or arm2 made the move before: the line is solved and bounded for the arm and
    branch on the line (arm2, right), the rods stay put along it and the idle arm holds still. The line's joints
    start and end at its waypoints' (a line solved on the other branch is timed alike, its elbow mirrored)."""
    from gpr_kinematics.robot.plan import line_moves, move_rows

    after_arm2 = _entry_program('arm2')
    for branch in ('right', 'left'):
        after_arm1 = _entry_program('arm1', branch)
        assert after_arm1.waypoints.arm[:2] == ('arm1', 'arm2') and after_arm1.waypoints.branch[:2] == (branch, 'right')
        assert line_moves(after_arm1.waypoints) == [1, 4]
        np.testing.assert_allclose(after_arm1.timing.duration[1:], after_arm2.timing.duration[1:], rtol=1e-12, atol=0)
        assert after_arm1.timing.duration[0] != pytest.approx(after_arm2.timing.duration[0])
        for m in (1, 4):
            ends = move_rows(ROBOT, after_arm1.waypoints, after_arm1.positions, m, np.array([0.0, 1.0]))
            np.testing.assert_allclose(ends, after_arm1.positions[m:m + 2], rtol=0, atol=1e-9)


def test_a_program_of_one_move_reports_its_peaks():
    """One move between two stations (two waypoints, one joint-space line): the summary's peak speed and acceleration
    are those central differences of the samples (2 kHz) find, to 2e-3; the idle arm's are 0."""
    from gpr_kinematics.robot.plan import program_summary
    from gpr_kinematics.robot.program import parse_program

    data = {'format': 'gpr_robot_program', 'units': {'length': 'mm', 'angle': 'deg'},
            'stations': [{'name': 'a', 'position': [1100, 500, 450], 'heading': 0},
                         {'name': 'b', 'position': [750, 850, 420], 'heading': 90}],
            'steps': [{'move': 'a', 'arm': 'arm1'}, {'move': 'b', 'arm': 'arm1'}]}
    plan = plan_program(ROBOT, parse_program(data, 'one_move.yaml'))
    assert plan.timing.duration.shape == (1,)
    s = program_summary(plan)
    h = 1 / 2000
    x = sample_plan(plan, times=np.arange(plan.timing.depart[0] - h, plan.timing.arrive[1] + h, h)).samples.positions
    v_fd = np.max(np.abs(x[2:] - x[:-2]) / (2 * h), axis=0) / plan.timing.velocity
    a_fd = np.max(np.abs(x[2:] - 2 * x[1:-1] + x[:-2]) / h ** 2, axis=0) / plan.timing.acceleration
    assert np.max(v_fd) > 0.1
    np.testing.assert_allclose(s.velocity_usage, v_fd, atol=2e-3, rtol=0)
    np.testing.assert_allclose(s.acceleration_usage, a_fd, atol=2e-3, rtol=0)
    np.testing.assert_array_equal(s.velocity_usage[6:], 0.0)


def test_a_straight_entry_beyond_a_joint_limit_is_named_once_with_its_program(tmp_path):
    """The example cell program with pm1's entry 600 mm long: the line into it bends arm2's elbow past its limit. The
    refusal names the program once, the step, where on the line and the joint (it read 'x.yaml: x.yaml: steps[5]')."""
    from pathlib import Path

    from gpr_kinematics.robot import load_robot
    from gpr_kinematics.robot.program import parse_program
    source = Path(config_path('programs/example_cell_program.yaml'))
    data = yaml.safe_load(source.read_text())
    data['stations'] = [dict(s, entry=600) if s.get('name') == 'pm1' else s for s in data['stations']]
    data['robot'] = str((source.parent / data['robot']).resolve())
    del data['cell']
    program = parse_program(data, 'x.yaml', source.parent)
    with pytest.raises(LimitError) as err:
        plan_program(load_robot(data['robot']), program)
    assert str(err.value).startswith('x.yaml: steps[5] (place pm1, approach): the straight line into it, at 0.043 of '
                                     'its length: station pm1/approach: arm2_elbow = 2.9063 rad is beyond its upper '
                                     'limit 2.9 rad by 0.006304 rad'), str(err.value)


def test_a_plan_of_something_else_than_a_robot_and_a_program_is_named():
    """plan_program(robot, a_dict) raised AttributeError ('dict' object has no attribute 'stations')."""
    program = load_program(config_path('programs/example_cell_program.yaml'))
    with pytest.raises(InputError, match=r"^program = \{'format': 'gpr_program'\}; allowed: a RobotProgram "
                                         r'\(load_program or parse_program\)$'):
        plan_program(ROBOT, {'format': 'gpr_program'})
    with pytest.raises(InputError, match=r'^robot = None; allowed: a RobotDescription \(load_robot or parse_robot\)$'):
        plan_program(None, program)

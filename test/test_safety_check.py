"""``gpr program check`` in a cell, issue 19's "Done when": the cell example is safe with a positive clearance; a box
on the carried wafer's path makes it unsafe (exit 1) naming the wafer and the box at the time the wafer reaches it;
a box a known distance from the wafer's path is reported at that distance (to 0.1 mm, never more); straight-entry
samples lie on their line (1 um) and a controller's interpolation between them within the certificate's bound;
tenfold arm accelerations make the wafer slip, and the slip ratio agrees with finite differences of the exported
wafer poses."""
import csv
import dataclasses
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gpr_kinematics.core.rotations import matrix_from_quaternion, rotation_z, tilt_rotation
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import load_robot, robot_forward
from gpr_kinematics.robot.line_bounds import line_rate_bounds
from gpr_kinematics.robot.plan import joint_limits, line_moves, plan_program, sample_plan
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.safety.bodies import robot_body_set
from gpr_kinematics.safety.check import wafer_plan
from gpr_kinematics.safety.clearance import TOLERANCE
from gpr_kinematics.safety.motion import levers

pytest.importorskip('fcl')

PROGRAM = config_path('programs/example_cell_program.yaml')
CELL = config_path('cells/example_cell.yaml')
ROBOT = load_robot()
PLAN = plan_program(ROBOT, load_program(PROGRAM))
#: pm1's station (mm, deg), as in the cell and the program.
PM1 = (np.array([1450.0, 500.0, 720.0]), 1.5, 120.0, 0.0)
#: The carried wafer enters pm1 on the plane 8 mm above its station (the place's approach height).
LIFT = 8.0


def gpr(*argv, cwd):
    return subprocess.run([sys.executable, '-m', 'gpr_kinematics', *argv], capture_output=True, text=True,
                          timeout=600, cwd=cwd)


def cell_with_box(tmp_path, centre_local_mm, size_mm, name='box'):
    """The example cell and a box given in pm1's station frame (mm), oriented as the station."""
    position, tilt, az, heading = PM1
    R = tilt_rotation(np.radians([tilt]), np.radians([az]))[0] @ rotation_z(np.radians([heading]))[0]
    centre = position + R @ np.asarray(centre_local_mm, dtype=float)
    line = (f'  - {{name: {name}, box: [{size_mm[0]}, {size_mm[1]}, {size_mm[2]}], position: '
            f'[{float(centre[0])!r}, {float(centre[1])!r}, {float(centre[2])!r}], tilt: {tilt}, azimuth: {az}, '
            f'heading: {heading}}}\n')
    path = tmp_path / 'cell.yaml'
    path.write_text(CELL.read_text() + line)
    return path


@pytest.mark.slow
def test_the_cell_example_is_safe(tmp_path):
    res = gpr('program', 'check', str(PROGRAM), '--json', '--plot', str(tmp_path / 'check.png'), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    d = json.loads(res.stdout)
    assert d['safe'] is True and d['collisions'] == [] and 0.002 < d['min_clearance'] < 0.02
    assert d['min_clearance'] == min(p['distance'] for p in d['pairs']) and d['max_slip_ratio'] < 1.0
    assert d['cell'].endswith('example_cell.yaml') and d['margin'] == 0.002
    assert (d['model'], d['proven']) == ('radial', True)   # the example robot's model: its bounds are proofs
    names = {n for p in d['pairs'] for n in p['bodies']}
    assert {'arm2_wafer', 'arm2_blade', 'arm2_link1', 'gpr_base', 'pm1/front_top', 'wafer@pm1:steps[5]'} <= names
    # a pair once: the wafer at the load port before its pick and the one placed back were both wafer@load_port_1
    assert len({tuple(p['bodies']) for p in d['pairs']}) == len(d['pairs'])
    assert {'wafer@load_port_1:start', 'wafer@load_port_1:steps[14]'} <= names
    assert (tmp_path / 'check.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and d['plot_file'].endswith('.png')
    # what docs/cell.md's sample output and README.md say of this check are its numbers
    root = Path(__file__).resolve().parents[1]
    doc = ' '.join((root / 'docs' / 'cell.md').read_text(encoding='utf-8').split())
    m = re.search(r'program \.\.\. (\d+) stations, (\d+) steps, (\d+) waypoints, ([\d.]+) s; .*? minimum ([\d.]+) mm '
                  r'\(margin 2 mm, certified between samples; (\d+) distance calls\); max slip ratio ([\d.]+) '
                  r'\(a bound over the motion; ([\d.]+) evaluated at ([\d.]+) s, (steps\[\d+\] \([^)]*\))\)', doc)
    assert m, 'docs/cell.md: the sample output of gpr program check'
    assert m.groups() == (str(d['stations']), str(d['steps']), str(d['waypoints']), f"{d['duration']:.3f}",
                          f"{d['min_clearance'] * 1e3:.3f}", str(d['evaluations']), f"{d['max_slip_ratio']:.3f}",
                          f"{d['max_slip_evaluated']:.3f}", f"{d['max_slip_at']:.3f}", d['slip_label'])
    readme = ' '.join((root / 'README.md').read_text(encoding='utf-8').split())
    assert f"The example cell program checks safe with {d['min_clearance'] * 1e3:.2f} mm of clearance" in readme
    assert (f"({d['min_clearance'] * 1e3:.2f} mm against a 2 mm margin) and the wafer's slip ratio "
            f"({d['max_slip_ratio']:.3f} at most" in readme)    # the caption of its picture
    # under a model whose virtual joints enter the bounds to first order, the output says so, not "certified"
    res = gpr('program', 'check', str(PROGRAM), '--model', 'polar', cwd=tmp_path)
    assert res.returncode == 0 and 'certified' not in res.stdout, res.stdout
    assert ("bounded between samples to first order in the polar model's virtual joints (proven for radial only)"
            in res.stdout and 'max slip ratio 0.754 (a first-order bound over the motion;' in res.stdout), res.stdout
    # the same program with a margin above its clearance: unsafe, a table names each pair below it
    res = gpr('program', 'check', str(PROGRAM), '--margin', '0.01', cwd=tmp_path)
    assert res.returncode == 1 and 'UNSAFE' in res.stdout and 'NOT safe' in res.stdout, res.stdout


@pytest.mark.slow
def test_the_collision_table_says_which_time_is_which(tmp_path):
    """A margin of 7 mm makes the cell example unsafe: arm2_link3 first comes closer than 7 mm to pm1's front at
    16.09 s, while its least distance, 6.09 mm, is reached at 17.93 s. The table gives both times in their own
    columns, named (the row read as the distance at 16.11 s before), and they are the JSON's: the collision's time
    and distance, and the time of the same pair's entry in ``pairs``."""
    res = gpr('program', 'check', str(PROGRAM), '--margin', '0.007', '--json', cwd=tmp_path)
    assert res.returncode == 1, res.stderr
    d = json.loads(res.stdout)
    first = d['collisions'][0]
    least = next(p for p in d['pairs'] if p['bodies'] == first['bodies'] and p['distance'] == first['distance'])
    assert least['time'] - first['time'] > 1.0     # the case: the minimum comes well after the first instant below
    res = gpr('program', 'check', str(PROGRAM), '--margin', '0.007', cwd=tmp_path)
    assert res.returncode == 1
    lines = res.stdout.splitlines()
    k = lines.index('  UNSAFE: 2 pair(s) below the margin:')
    assert lines[k + 1].split() == ['step', 'station', 'first', 'below', '[s]', 'bodies', 'min', 'distance', '[mm]',
                                    'min', 'at', '[s]']
    assert len(d['collisions']) == 2   # a row each (docs/cell.md: the table names each pair), in the JSON's order
    for row, c in zip(lines[k + 2:k + 4], d['collisions'], strict=True):
        step, station, below, a, _, b, distance, at = row.split()
        least = next(p for p in d['pairs'] if p['bodies'] == c['bodies'] and p['distance'] == c['distance'])
        assert (int(step), station, f'{a} / {b}') == (c['step'], c['station'], ' / '.join(c['bodies']))
        assert (below, distance, at) == (f"{c['time']:.3f}", f"{c['distance'] * 1e3:.3f}", f"{least['time']:.3f}")
    assert 'first below: when the pair first comes closer than the margin, to 1 us, in that step at that station; ' \
        '-: none,' in lines[k + 4]
    assert "between samples could not show the pair the margin apart; min distance: the pair's least certified" \
        in lines[k + 5]
    assert 'the whole program; min at: the instant of its smallest measured distance)' in lines[k + 6]
    # then, for a pair whose least distance lies in another step than its first below the margin, that step
    extra = [line for line in lines[k + 7:] if ': least at ' in line]
    for c, line in zip([c for c in d['collisions'] if f"{' / '.join(c['bodies'])}: least at " in res.stdout], extra,
                       strict=True):
        least = next(p for p in d['pairs'] if p['bodies'] == c['bodies'] and p['distance'] == c['distance'])
        assert line.startswith(f"    {' / '.join(c['bodies'])}: least at {least['time']:.3f} s, steps[")
        assert line.endswith(f"(another step than its first below the margin, {c['label']})")
    assert lines[k + 7 + len(extra)].startswith('  largest joint displacement') and lines[-1] == '  NOT safe'
    least = next(p for p in d['pairs'] if p['bodies'] == first['bodies'] and p['distance'] == first['distance'])
    # docs/robot.md quotes this case (to the last printed digit: a rounding's flip at the boundary is allowed)
    doc = ' '.join((Path(__file__).resolve().parents[1] / 'docs' / 'robot.md').read_text(encoding='utf-8').split())
    m = re.search(r"arm2_link3 comes within 7 mm of pm1's front at ([\d.]+) s, ([\d.]+) mm at ([\d.]+) s", doc)
    assert m, 'docs/robot.md: the --margin 0.007 example'
    quoted = [float(v) for v in m.groups()]
    np.testing.assert_allclose(quoted, [first['time'], first['distance'] * 1e3, least['time']], rtol=0, atol=1.001e-3)


@pytest.mark.slow
def test_a_box_on_the_wafers_path_is_a_collision_at_the_right_time(tmp_path):
    """A 20 mm cube on the line the wafer enters pm1 by, just before the slit: exit 1; the first collision is
    the wafer against the box, found while the wafer's disc covers the box (independently: the exported wafer
    centre within 150 mm + the cube's half diagonal of its centre), in the step placing into pm1."""
    cell = cell_with_box(tmp_path, [-163.0, 0.0, LIFT], [20, 20, 20])
    res = gpr('program', 'check', str(PROGRAM), '--cell', str(cell), '--json', cwd=tmp_path)
    assert res.returncode == 1, res.stderr
    d = json.loads(res.stdout)
    assert d['safe'] is False
    first = d['collisions'][0]
    assert set(first['bodies']) == {'arm2_wafer', 'box'} and first['distance'] < 0.0
    assert first['station'] == 'pm1' and first['label'].endswith('(place pm1, approach)')
    position, tilt, az, heading = PM1
    R = tilt_rotation(np.radians([tilt]), np.radians([az]))[0] @ rotation_z(np.radians([heading]))[0]
    box = (position + R @ np.array([-163.0, 0.0, LIFT])) / 1000
    s = sample_plan(PLAN, 1000.0)
    near = np.linalg.norm(s.wafer.position - box, axis=1) < 0.15 + 0.01 * math.sqrt(2)
    carried = np.any([(s.samples.time >= a) & (s.samples.time <= b) for a, b in wafer_plan(PLAN).carried['arm2']],
                     axis=0)
    times = s.samples.time[near & carried]
    assert times.size and times[0] - 0.05 <= first['time'] <= times[-1]
    res = gpr('program', 'check', str(PROGRAM), '--cell', str(cell), cwd=tmp_path)
    assert res.returncode == 1
    row = re.search(r'^\s+(\d+)\s+pm1\s+([\d.]+)\s+(\S+) / (\S+)\s+(-?[\d.]+)\s+([\d.]+)$', res.stdout, re.M)
    assert row and {row[3], row[4]} == {'arm2_wafer', 'box'}, res.stdout


def test_an_arm_link_inside_the_gprs_column_is_a_collision(tmp_path):
    """Only the wafers were checked against the GPR's column and platform: arm1 taking its wafer down to 190 mm put
    the rods at 6 mm and its first link 29 mm into the column, and the program read safe. The overlap by hand, from
    the example robot's numbers: the column's top at 0.12 m, the link's bottom at q + 0.08 (mount) + 0.035 / 2
    (half its height) - 0.025 / 2 (half its thickness)."""
    from gpr_kinematics.robot.inverse import solve_stations
    from gpr_kinematics.robot.stations import Stations
    program = tmp_path / 'low.yaml'
    program.write_text('format: gpr_robot_program\nversion: 1\nunits: {length: mm, angle: deg}\n'
                       f'robot: {config_path("robots/example_robot.yaml")}\ndefaults: {{arm: arm1, dwell: 0.5}}\n'
                       'stations:\n  - {name: home, position: [750, 850, 260], heading: 90}\n'
                       '  - {name: low, position: [750, 850, 190], heading: 90}\n'
                       'steps:\n  - {move: home}\n  - {move: low}\n  - {move: home}\n')
    res = gpr('program', 'check', str(program), '--json', cwd=tmp_path)
    assert res.returncode == 1, res.stderr
    d = json.loads(res.stdout)
    (first,) = [c for c in d['collisions'] if set(c['bodies']) == {'gpr_base', 'arm1_link1'}]
    q = solve_stations(ROBOT, Stations.of([[0.75, 0.85, 0.19]], heading=math.pi / 2), 'arm1').rods[0]
    assert np.ptp(q) < 1e-12 and q[0] == pytest.approx(0.006, abs=1e-4)   # level, 6 mm up
    overlap = 0.12 - (q[0] + 0.08 + 0.035 / 2 - 0.025 / 2)
    assert first['station'] == 'low' and first['measured'] == pytest.approx(-overlap - 1e-6, abs=1e-9)
    assert first['distance'] <= first['measured']
    assert d['min_clearance'] <= -overlap


@pytest.mark.parametrize('gap_mm', [3.0, 7.5])
def test_a_box_a_known_distance_from_the_wafers_path(tmp_path, gap_mm):
    """A plate parallel to pm1's plane over the wafer's straight entry, ``gap`` above the carried wafer's top face:
    the pair's certified distance is that gap to 0.1 mm and never larger."""
    top = LIFT + 0.775 / 2
    cell = cell_with_box(tmp_path, [-250.0, 0.0, top + gap_mm + 5.0], [100, 60, 10], name='plate')
    res = gpr('program', 'check', str(PROGRAM), '--cell', str(cell), '--json', cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    d = json.loads(res.stdout)
    pair = next(p for p in d['pairs'] if set(p['bodies']) == {'arm2_wafer', 'plate'})
    gap = gap_mm / 1000
    assert gap - 1e-4 <= pair['distance'] <= gap + 1e-12
    assert gap - pair['distance'] <= TOLERANCE + 1e-6
    others = [p['distance'] for p in d['pairs'] if 'plate' in p['bodies'] and 'arm2_wafer' not in p['bodies']]
    assert min(others) > gap


def test_straight_entry_samples_lie_on_the_line():
    """Every sample (100 Hz) of a straight entry is on its line to 1 um with the station's orientation; a controller
    interpolating the joints linearly between two samples keeps the wafer within the certificate's bound of
    the joints' motion (sum of lever arms times the joints' path lengths) from the line."""
    s = sample_plan(PLAN, 100.0)
    way = PLAN.waypoints
    _, _, _, slices = joint_limits(ROBOT)
    bodies = robot_body_set(ROBOT)
    wafer = next(k for k, b in enumerate(bodies) if b.name == 'arm2_wafer')
    lever = levers(ROBOT, bodies).lever[:, wafer]
    count = 0
    for m in line_moves(way):
        sel = np.flatnonzero((s.samples.held < 0) & (s.samples.target == m + 1))
        p0, p1 = way.stations.position[m], way.stations.position[m + 1]
        u = (p1 - p0) / np.linalg.norm(p1 - p0)

        def off_line(p, p0=p0, u=u):
            d = p - p0
            return np.linalg.norm(d - (d @ u)[:, None] * u, axis=1)

        assert np.max(off_line(s.wafer.position[sel])) < 1e-6
        np.testing.assert_allclose(s.wafer.rotation[sel], np.broadcast_to(way.stations.rotation[m + 1],
                                                                          (sel.size, 3, 3)), atol=1e-12)
        arm = way.arm[m + 1]
        cols = slices[ROBOT.arm_names.index(arm)]
        rows = s.samples.positions[sel]
        mid = 0.5 * (rows[:-1] + rows[1:])
        fk = robot_forward(ROBOT, mid[:, :3], mid[:, cols], arm)
        V = np.zeros(rows[:-1].shape)
        V[:, cols] = (np.diff(s.samples.s[sel])[:, None]
                      * line_rate_bounds(ROBOT.arm(arm), PLAN.positions[m, cols], PLAN.positions[m + 1, cols],
                                         s.samples.s[sel][:-1], s.samples.s[sel][1:]))
        assert np.all(off_line(fk.wafer.position) <= V @ lever + 1e-12)
        count += sel.size
    assert count > 100


@pytest.fixture(scope='module')
def fast_robot(tmp_path_factory):
    """A copy of the example robot with every arm joint's acceleration limit raised tenfold."""
    path = tmp_path_factory.mktemp('robot') / 'fast_robot.yaml'
    text = config_path('robots/example_robot.yaml').read_text()
    text = text.replace('config: null', f'config: {config_path("gpr.yaml")}')
    lines = [re.sub(r'acceleration: ([\d.]+)', lambda m: f'acceleration: {10 * float(m[1]):g}', line)
             if 'name: arm' in line else line for line in text.splitlines()]
    path.write_text('\n'.join(lines) + '\n')
    return path


@pytest.mark.slow
def test_tenfold_arm_accelerations_make_the_wafer_slip(tmp_path, fast_robot):
    """The check fails on slip (exit 1, max_slip_ratio >= 1, where named), and the slip ratio agrees with the one
    computed here from second differences of the exported wafer poses (1 kHz) while the wafer is carried."""
    res = gpr('program', 'check', str(PROGRAM), '--robot', str(fast_robot), '--json', cwd=tmp_path)
    assert res.returncode == 1, res.stderr
    d = json.loads(res.stdout)
    assert d['safe'] is False and d['collisions'] == [] and d['max_slip_ratio'] > 1.0
    csv_path = tmp_path / 'samples.csv'
    res = gpr('program', 'export', str(PROGRAM), '--robot', str(fast_robot), '--samples', str(csv_path), '--rate',
              '1000', '--no-progress', cwd=tmp_path)   # refused: the tables drive a controller as a trajectory does
    assert res.returncode == 1 and not csv_path.exists() and res.stderr.endswith(
        '; --force writes the tables anyway, for analysis (status 1)\n'), res.stderr
    res = gpr('program', 'export', str(PROGRAM), '--robot', str(fast_robot), '--samples', str(csv_path), '--rate',
              '1000', '--force', '--no-progress', cwd=tmp_path)   # for analysis: status 1, the reason on stderr
    assert res.returncode == 1 and res.stderr.startswith('gpr program export: warning: the program itself is not '
                                                         'safe: the wafer slips on the blade'), res.stderr
    assert 'allowed:' not in res.stderr and res.stderr.endswith(   # the refusal's 'allowed:' is no warning's
        ' (no --rate helps); the tables were written as --force asks, for analysis, not for a controller\n'), res.stderr
    with csv_path.open() as f:
        rows = [r for r in csv.DictReader(f)]
    t = np.array([float(r['time']) for r in rows])
    p = np.array([[float(r[f'wafer_{k}']) for k in 'xyz'] for r in rows])
    q = np.array([[float(r[f'wafer_q{k}']) for k in 'xyzw'] for r in rows])
    h = t[1] - t[0]
    a = (p[2:] - 2 * p[1:-1] + p[:-2]) / h ** 2
    f = a + np.array([0.0, 0.0, 9.80665])
    n = matrix_from_quaternion(q[1:-1])[:, :, 2]
    fn = np.einsum('ni,ni->n', f, n)
    ratio = np.linalg.norm(f - fn[:, None] * n, axis=1) / (0.3 * fn)
    plan = plan_program(load_robot(fast_robot), load_program(PROGRAM))
    carried = np.any([(t[1:-1] > a0 + h) & (t[1:-1] < b0 - h) for a0, b0 in wafer_plan(plan).carried['arm2']],
                     axis=0)
    fd_max = float(np.max(ratio[carried]))
    assert d['max_slip_ratio'] == pytest.approx(fd_max, rel=5e-3)
    k = int(np.argmin(np.abs(t[1:-1] - d['max_slip_at'])))
    assert ratio[k] == pytest.approx(d['max_slip_ratio'], rel=5e-3)
    # the shipped limits keep the wafer on its blade
    res = gpr('program', 'check', str(PROGRAM), '--json', cwd=tmp_path)
    assert json.loads(res.stdout)['max_slip_ratio'] < 0.8


@pytest.mark.parametrize('kwargs, words', [
    ({'tolerance': 1e-9}, r'tolerance = 1e-09 is invalid; allowed: metres, at least 1e-06 and at most 1'),
    ({'tolerance': 5e-324}, r'tolerance = 5e-324 is invalid'),
    ({'tolerance': 0.0}, r'tolerance = 0.0 is invalid'),
    ({'margin': -0.001}, r'margin = -0.001 is invalid; allowed: metres, at least 0 and at most 1'),
    ({'margin': 5.0}, r'margin = 5.0 is invalid; allowed: metres, at least 0 and at most 1 \(5 mm\? give 0.005\)$'),
    ({'margin': 10 ** 400}, r'margin = <an integer of about 401 digits> is invalid'),
    ({'margin': float('nan')}, r'margin = nan is invalid'),
    ({'margin': True}, r'margin = True is invalid'),
])
def test_check_refuses_a_tolerance_that_would_run_for_minutes_and_other_bad_numbers(kwargs, words):
    """A tolerance of 1 nm took 104 s on this program (1 um: about 3 s); it is refused before any work."""
    from gpr_kinematics.errors import InputError
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.check import check_program

    with pytest.raises(InputError, match=words):
        check_program(PLAN, load_cell(CELL), **kwargs)
    with pytest.raises(InputError, match=words):   # without the clearance too: its report echoed '0.002' and -1
        check_program(PLAN, None, with_clearance=False, **kwargs)


@pytest.mark.parametrize('switch', ['no', 0, None, 'False'])
def test_the_clearance_switch_is_a_truth_value(switch):
    """``with_clearance='no'`` ran the clearance (any text is true): refused, as ``check_limits='no'`` is."""
    from gpr_kinematics.errors import InputError
    from gpr_kinematics.safety.check import check_program

    with pytest.raises(InputError, match=r'^with_clearance = .*; allowed: True or False$'):
        check_program(PLAN, None, with_clearance=switch)


def _cell_program(**changes):
    """The example cell program with keys replaced (a key set to None is removed), planned."""
    from gpr_kinematics.inputs.safe_yaml import read_file
    from gpr_kinematics.robot.program import parse_program

    data = dict(read_file(PROGRAM))
    for key, value in changes.items():
        if value is None:
            data.pop(key, None)
        else:
            data[key] = value
    return plan_program(ROBOT, parse_program(data, str(PROGRAM), PROGRAM.parent))


def test_the_wafers_are_followed_through_the_program():
    """wafers: [] turned every wafer check off (an empty list counted as "not declared"); it declares no wafer."""
    from gpr_kinematics.errors import ConfigError

    wafers = wafer_plan(_cell_program())               # wafers: [load_port_1]: taken to pm1, pm2 and back
    assert wafers.carried['arm2'] and not wafers.carried['arm1']
    with pytest.raises(ConfigError, match=r'steps\[1\] \(pick load_port_1, at\): station load_port_1 holds no wafer '
                                          r'\(the program declares wafers: \[\]\); allowed: a pick where a wafer lies'):
        wafer_plan(_cell_program(wafers=[]))
    with pytest.raises(ConfigError, match=r'station pm1 holds no wafer \(the program declares wafers: \[load_port_1\]'):
        wafer_plan(_cell_program(wafers=['load_port_1'], steps=[{'move': 'high'}, {'move': 'pm1_front'},
                                                                {'pick': 'pm1'}]))
    with pytest.raises(ConfigError, match=r'station pm1 already holds a wafer; allowed: a place onto an empty station'):
        wafer_plan(_cell_program(wafers=['load_port_1', 'pm1'], steps=[
            {'pick': 'load_port_1'}, {'move': 'low'}, {'move': 'high'}, {'move': 'pm1_front'}, {'place': 'pm1'}]))
    with pytest.raises(ConfigError, match=r'steps\[4\] \(pick pm1, at\): arm arm2 already carries a wafer; allowed: a '
                                          r'pick with an empty blade \(place the wafer first\)'):
        _cell_program(wafers=['load_port_1', 'pm1'], steps=[
            {'pick': 'load_port_1'}, {'move': 'low'}, {'move': 'high'}, {'move': 'pm1_front'}, {'pick': 'pm1'}])
    with pytest.raises(ConfigError, match=r'steps\[2\] \(place pm1, at\): arm arm2 carries no wafer to place; allowed: '
                                          r"a place after the arm's pick"):
        _cell_program(wafers=['load_port_1'], steps=[{'move': 'high'}, {'move': 'pm1_front'}, {'place': 'pm1'}])
    undeclared = wafer_plan(_cell_program(wafers=None))    # no key: picks find a wafer where they pick
    assert undeclared.carried['arm2'] == wafers.carried['arm2']



def test_without_declared_wafers_a_second_pick_or_a_place_onto_a_filled_station_is_refused():
    """No ``wafers:`` key: a pick finds a wafer and a place has one, but the wafers picked and placed are still
    followed (docs/cell.md): a pick with the blade full and a place onto a station an earlier place filled are
    refused, naming the step."""
    from gpr_kinematics.errors import ConfigError

    for steps, message in (
            ([{'pick': 'load_port_1'}, {'move': 'low'}, {'move': 'high'}, {'move': 'pm1_front'}, {'pick': 'pm1'}],
             'steps[4] (pick pm1, at): arm arm2 already carries a wafer; allowed: a pick with an empty blade (place '
             'the wafer first)'),
            ([{'move': 'high'}, {'move': 'pm1_front'}, {'place': 'pm1'}, {'move': 'pm1_front'}, {'place': 'pm1'}],
             'steps[4] (place pm1, at): station pm1 already holds a wafer; allowed: a place onto an empty station '
             '(pick its wafer first)')):
        with pytest.raises(ConfigError) as refused:
            _cell_program(wafers=None, steps=steps)
        assert str(refused.value) == f'{PROGRAM}: {message}'
    plan = _cell_program(wafers=None, steps=[{'move': 'high'}, {'move': 'pm1_front'}, {'place': 'pm1'},
                                             {'pick': 'pm1'}, {'place': 'pm1'}])   # emptied between the places
    assert [s.kind for s in plan.program.steps] == ['move', 'move', 'place', 'pick', 'place']

def test_the_check_reports_its_progress_without_changing_its_verdict():
    """Issue 19's check runs a minute for a long program: its stages report their share done as they go, never
    backwards, each to its end; the report is the one computed without a listener."""
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.check import check_program
    heard = []
    report = check_program(PLAN, load_cell(CELL), progress=lambda stage, share: heard.append((stage, share)))[0]
    assert report == check_program(PLAN, load_cell(CELL))[0]
    stages = [s for s, _ in heard]
    assert stages == sorted(stages, key=['clearance', 'slip'].index) and set(stages) == {'clearance', 'slip'}
    for stage in ('clearance', 'slip'):
        shares = [f for s, f in heard if s == stage]
        assert shares == sorted(shares) and shares[-1] == 1.0 and shares[0] >= 0.0
    assert len([s for s in stages if s == 'clearance']) > 5   # one per round of the search, not one at the end
    # the slip too: each carrying arm's ratios and each round of its bound (a 2,000-step program's 13 s of slip had
    # said 0 % and then nothing until 100 %)
    between = sorted({f for s, f in heard if s == 'slip' and 0.0 < f < 1.0})
    assert len(between) >= 3, between


def test_the_progress_line_waits_then_writes_each_stage_and_its_end():
    """Into a pipe: nothing before ``after`` seconds, then a line at each new stage, at each stage's end and at
    most every ``every`` seconds between; on a terminal one line redrawn in place and ended."""
    import io

    from gpr_kinematics.cli.progress import ProgressLine
    times = iter([0.0, 1.0, 2.5, 3.0, 9.0, 9.5, 9.6, 9.65, 9.7])
    out = io.StringIO()
    line = ProgressLine(out, after=2.0, every=5.0, clock=lambda: next(times))
    # the end told twice (the clearance search does) is written once: it printed 'clearance: 100.0 % (3.1 s)' twice
    for stage, share in [('clearance', 0.1), ('clearance', 0.2), ('clearance', 0.3), ('clearance', 0.9),
                         ('clearance', 0.95), ('clearance', 1.0), ('clearance', 1.0), ('slip', 0.0)]:
        line(stage, share)
    line.close()
    assert out.getvalue().splitlines() == ['clearance:  20.0 % (2.5 s)', 'clearance:  90.0 % (9.0 s)',
                                           'clearance: 100.0 % (9.6 s)', 'slip:   0.0 % (9.7 s)']

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    tty = Terminal()
    line = ProgressLine(tty, after=0.0, clock=iter([0.0, 1.0, 2.0]).__next__)
    line('clearance', 0.5)
    line('clearance', 1.0)
    line.close()
    text = tty.getvalue()
    assert text.startswith('\rclearance:  50.0 % (1.0 s)') and text.count('\r') == 2 and text.endswith('\n')
    assert '100.0 % (2.0 s)' in text


def test_the_progress_line_never_stops_the_check_when_stderr_is_gone(monkeypatch):
    """``gpr program check ... 2>&-`` (no stderr: ``sys.stderr`` is None), a closed stream or one whose reader went
    away: the progress is dropped, the check goes on."""
    import io

    from gpr_kinematics.cli.progress import ProgressLine
    monkeypatch.setattr('sys.stderr', None)
    line = ProgressLine(after=0.0)
    line('clearance', 0.5)
    line.close()
    closed = io.StringIO()
    closed.close()
    line = ProgressLine(closed, after=0.0)
    line('clearance', 0.5)
    line.close()

    class Gone(io.StringIO):
        def write(self, text):
            raise BrokenPipeError(32, 'Broken pipe')

    gone = Gone()
    line = ProgressLine(gone, after=0.0)
    line('clearance', 0.5)
    line('slip', 1.0)
    line.close()
    assert line.stream is None and not line.shown


def test_the_slip_peak_is_among_the_instants_checked():
    """A move's acceleration peaks on its S-curve's corners (the ends of its jerk ramps and plateaus): the check
    evaluates the slip there too, so its peak is above 2 kHz sampling's (0.75266) and the one 100 kHz sampling about
    it finds to 1e-9 (0.75288: the path's own curvature moves the true peak off the corner by a hair); the 200 Hz
    grid and the waypoints alone read it 0.2 % low (0.7512)."""
    from gpr_kinematics.robot.timing import evaluate, locate
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.check import check_program
    from gpr_kinematics.safety.slip import slip_series
    from gpr_kinematics.safety.slip_bound import SLIP_TOLERANCE

    timing = PLAN.timing
    corners = timing.corners()
    _, held, m, tau = locate(timing, corners)
    _, _, dds = evaluate(timing.profiles, m, tau)
    peak = np.where(np.isfinite(timing.profiles.a), timing.profiles.a, 0.0)
    for k in np.flatnonzero(np.isfinite(timing.profiles.v) & (timing.profiles.T > 0.0)):
        on_move = (m == k) & ~held
        assert np.max(np.abs(dds[on_move])) == pytest.approx(peak[k], rel=1e-9)   # the plateau's ends are corners

    report = check_program(PLAN, load_cell(CELL))[0]

    def slip_max(times):
        carrying = np.full(times.shape, '', dtype=object)
        for arm, windows in wafer_plan(PLAN).carried.items():
            for t0, t1 in windows:
                carrying[(times >= t0) & (times <= t1)] = arm
        r = slip_series(PLAN, times, carrying).ratio
        return float(np.max(np.where(np.isnan(r), 0.0, r)))

    dense = slip_max(np.unique(np.concatenate([np.arange(0.0, timing.total, 1 / 2000), [timing.total]])))
    at = report.max_slip_at
    fine = slip_max(np.arange(at - 0.01, at + 0.01, 1e-5))     # 100 kHz about the peak: it converges to it
    assert dense < report.max_slip_evaluated and report.max_slip_evaluated == pytest.approx(fine, rel=1e-9)
    coarse = slip_max(np.unique(np.concatenate([np.arange(0.0, timing.total, 1 / 200), timing.arrive, timing.depart])))
    assert coarse < report.max_slip_evaluated - 1e-3
    # the verdict's value bounds the peak, within the bound's tolerance of it (0.75382 for 0.75288)
    assert report.slip_certified and fine < report.max_slip_ratio < fine + SLIP_TOLERANCE


def test_on_a_straight_entry_the_slip_ratio_peaks_at_the_corners():
    """A straight entry translates the wafer with its orientation fixed and ``a = (p_1 - p_0) s''``: the slip ratio is
    a quasi-convex function of ``s''`` alone, whose extremes lie on the S-curve's corners, so the largest ratio among
    the corners (evaluated by the check) is the move's largest: 2 kHz sampling finds no more (the plateau's value to
    the central differences' rounding), ordered by ``s''`` the samples peak at its smallest or largest value, and the
    wafer's acceleration is along the line."""
    from gpr_kinematics.robot.timing import evaluate, locate
    from gpr_kinematics.safety.check import _slip_times
    from gpr_kinematics.safety.slip import slip_series, wafer_path

    timing = PLAN.timing
    corners = timing.corners()
    assert np.all(np.isin(corners, _slip_times(PLAN)))  # the check evaluates every corner
    carried = wafer_plan(PLAN).carried
    entries = 0
    for k in np.flatnonzero(timing.duration > 0.0):
        t0, t1 = timing.depart[k], timing.arrive[k + 1]
        arm = next((a for a, windows in carried.items() if any(w0 <= t0 and t1 <= w1 for w0, w1 in windows)), None)
        if not PLAN.waypoints.is_line(k) or arm is None:
            continue
        entries += 1
        at = corners[(corners >= t0) & (corners <= t1)]
        dense = np.linspace(t0, t1, int((t1 - t0) * 2000))

        def ratio(times, arm=arm):
            return slip_series(PLAN, times, np.full(times.shape, arm, dtype=object))

        at_corners, sampled = ratio(at), ratio(dense)
        assert np.max(sampled.ratio) <= np.max(at_corners.ratio) * (1.0 + 1e-9)
        # the ratio depends on s'' only, and its largest value lies at the smallest or the largest s''
        _, _, m, tau = locate(timing, dense)
        r = sampled.ratio[np.argsort(evaluate(timing.profiles, m, tau)[2])]
        assert np.max(r) <= max(r[0], r[-1]) * (1.0 + 1e-9)
        ends = wafer_path(PLAN, arm, int(k), np.array([0.0, 1.0]))
        d, a = ends[1] - ends[0], sampled.acceleration   # a = d s'': along the line
        across = np.linalg.norm(np.cross(a, d), axis=1)
        assert np.max(across) <= 1e-9 * np.linalg.norm(d) * np.max(np.linalg.norm(a, axis=1))
    assert entries == 4  # into and out of pm1 and pm2 with a wafer


def test_without_jerk_limits_the_slip_is_evaluated_on_both_sides_of_each_corner():
    """A trapezoid's acceleration jumps at its corners and the corner instant takes one side only (the cruise's 0 at
    the start of the braking): the check also evaluates 1 ns before and after each corner, so on the example robot
    without jerk limits the move into steps[14] (place load_port_1, approach) peaks at 0.81761, what 20 kHz sampling
    of the move finds, not the 0.81263 of the instants before (0.6 % low); the move into steps[8] read 0.33362 for
    0.33540."""
    from gpr_kinematics.safety.check import _slip_times
    from gpr_kinematics.safety.slip import slip_series
    from robot_support import make_robot, robot_data

    data = robot_data()
    data['rods'].pop('jerk')
    for arm in data['arms']:
        for joint in arm['joints']:
            joint.pop('jerk', None)
    plan = plan_program(make_robot(data), load_program(PROGRAM))
    assert np.all(np.isinf(plan.timing.jerk))
    carried = wafer_plan(plan).carried['arm2']
    checked = _slip_times(plan)
    timing = plan.timing
    for label, dense_peak in (('steps[14] (place load_port_1, approach)', 0.81761), ('steps[8] (move pm2_front, move)',
                                                                                    0.33540)):
        k = plan.labels.index(label) - 1
        t0, t1 = timing.depart[k], timing.arrive[k + 1]
        assert any(w0 <= t0 and t1 <= w1 for w0, w1 in carried)

        def peak(times):
            return float(np.max(slip_series(plan, times, np.full(times.shape, 'arm2', dtype=object)).ratio))

        dense = peak(np.linspace(t0, t1, int((t1 - t0) * 20000)))
        assert dense == pytest.approx(dense_peak, abs=1e-5)
        assert peak(checked[(checked >= t0) & (checked <= t1)]) >= dense * (1.0 - 1e-9)


def test_the_least_clearance_is_within_the_tolerance_and_the_librarys_slack_of_the_truth():
    """The cell example's least clearance (arm2_link3 in front of pm1's wall under the slit) is 6.0896 mm; the true
    minimum, sampled about its instant at 0.25 us with the exact distance of the two boxes (scipy's bounded least
    squares, not the collision library), is 6.1405 mm: never below the report, and 50.9 um above it, within the
    tolerance and the 1 um slack kept below every measured distance (docs/cell.md), not within the tolerance alone."""
    from gpr_kinematics.safety.bodies import cell_bodies
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.check import check_program
    from gpr_kinematics.safety.distances import LIBRARY_SLACK
    from gpr_kinematics.safety.motion import PlanMotion
    from scipy.optimize import lsq_linear

    report = check_program(PLAN, load_cell(CELL))[0]
    least = report.pairs[0]
    assert least['bodies'] == ['arm2_link3', 'pm1/front_bottom'] and report.min_clearance == least['distance']
    link = next(b for b in robot_body_set(ROBOT) if b.name == 'arm2_link3')
    wall = next(b for b in cell_bodies(load_cell(CELL)) if b.name == 'pm1/front_bottom')

    def distance(times):
        position, rotation = PlanMotion(PLAN).snapshot(times).frames[link.frame]
        out = []
        for p, R in zip(position, rotation, strict=True):
            A = np.hstack([R @ link.rotation, -wall.rotation])
            b = wall.position - (p + R @ link.position)
            half = np.concatenate([link.half, wall.half])
            out.append(np.linalg.norm(A @ lsq_linear(A, b, bounds=(-half, half), method='bvls', tol=1e-15).x - b))
        return np.array(out)

    times = least['time'] + np.linspace(-2e-3, 2e-3, 81)
    d = distance(times)
    times = times[np.argmin(d)] + np.linspace(-5e-5, 5e-5, 401)
    truth = float(np.min(distance(times)))
    assert truth == pytest.approx(6.1405e-3, abs=1e-7) and least['distance'] == pytest.approx(6.0896e-3, abs=1e-7)
    assert 0.0 < truth - least['distance'] <= TOLERANCE + LIBRARY_SLACK


@pytest.mark.slow
def test_the_instants_of_a_hold_are_its_ends():
    """The slip check sampled the whole program at 200 Hz and the clearance search at 1 Hz, holds included: the cell
    program with dwell 1000 s (14,053 s) took 23 s and 2.9 GB, with dwell 1e6 s more than 5 minutes and all the
    memory. A hold stands as at its ends: its inside gets no instant, the moves keep np.arange's; the verdict,
    the least clearance and the slip are those of the program with short dwells."""
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.check import _slip_times, check_program
    from gpr_kinematics.safety.motion import grid_within

    grid = np.arange(0.0, 10.0, 0.005)
    kept = grid_within(np.array([0.0, 3.0]), np.array([1.0, 9.5]), 10.0, 200.0)
    np.testing.assert_array_equal(kept, grid[(grid <= 1.0) | ((grid >= 3.0) & (grid <= 9.5))])
    short = _cell_program(defaults={'arm': 'arm2', 'branch': 'right', 'approach_height': 8, 'retract_height': 8,
                                    'dwell': 0.0})
    long = _cell_program(defaults={'arm': 'arm2', 'branch': 'right', 'approach_height': 8, 'retract_height': 8,
                                   'dwell': 1e6})
    assert long.timing.total > 1.4e7   # one more instant per hold's departure (the dwell 0's coincides)
    assert _slip_times(long).shape[0] == _slip_times(short).shape[0] + 12
    cell = load_cell(CELL)
    a, b = check_program(short, cell)[0], check_program(long, cell)[0]
    assert a.safe and b.safe and b.instants < 2 * a.instants
    assert b.min_clearance == pytest.approx(a.min_clearance, abs=1e-9)
    assert b.max_slip_evaluated == pytest.approx(a.max_slip_evaluated, abs=1e-8)   # times of 1e7 s: 2e-9 s apart
    assert b.max_slip_ratio == pytest.approx(a.max_slip_ratio, abs=1e-6)   # the bounds' halving can differ there


def test_a_move_of_a_million_seconds_is_sampled_within_bounds():
    """A step's time may be 1e6 s: the slip check sampled it at 200 Hz (2e8 instants) and the search at 1 Hz (a
    million). The moves get at most MAX_SAMPLES slip instants and BASE_MOST base instants in all."""
    from gpr_kinematics.robot.timing import MAX_SAMPLES
    from gpr_kinematics.safety.check import _slip_times

    slow = _cell_program(steps=[{'move': 'low'}, {'move': 'high', 'time': 1e6}])
    assert slow.timing.total == pytest.approx(1e6 + 1.0)
    times = _slip_times(slow)
    assert MAX_SAMPLES <= times.shape[0] <= MAX_SAMPLES + 20
    first = int(np.sum(times <= slow.timing.depart[0]))       # the move into 'low' at 200 Hz, the slow one the rest
    np.testing.assert_allclose(np.diff(times[(times > 10.0) & (times < 9e5)]), 1e6 / (MAX_SAMPLES - first + 1),
                               rtol=1e-3)
    from gpr_kinematics.safety.clearance import BASE_MOST, _Search
    from gpr_kinematics.safety.margin import MARGIN
    from gpr_kinematics.safety.motion import PlanMotion

    bodies = robot_body_set(ROBOT, {})
    search = _Search(PlanMotion(slow), bodies, [(0, len(bodies) - 1, ())], MARGIN, TOLERANCE, 1.0, False)
    assert BASE_MOST <= search.base.shape[0] <= BASE_MOST + 4    # 100 s apart on the move


@pytest.mark.slow
def test_a_slow_move_leaves_the_fast_ones_their_slip_instants(tmp_path):
    """The slip instants were bounded with one rate for every move, MAX_SAMPLES over the moves' total: a move of 1e5
    s appended after the wafer is placed sampled arm1's swing with it (speeds and accelerations 1.947 times, jerks 10
    times: its ratio
    1.0002 mid-move, 20 kHz) at 2 Hz, which read 0.99995 at the corners: safe. Water filling: the short moves keep
    200 Hz, the slow one takes the rest (evaluated 1.00019 either way; the bound over the motion 1.00119)."""
    from gpr_kinematics.safety.check import check_program, move_counts

    np.testing.assert_allclose(move_counts(np.array([2.0, 1e5, 3.0]), 200.0, 200_000), [400.0, 199_000.0, 600.0])
    np.testing.assert_allclose(move_counts(np.array([1e3, 2e3, 4.0]), 200.0, 200_000), [99_600.0, 99_600.0, 800.0])
    np.testing.assert_allclose(move_counts(np.array([2.0, 3.0]), 200.0, 200_000), [400.0, 600.0])
    text = config_path('robots/example_robot.yaml').read_text().replace('config: null',
                                                                         f'config: {config_path("gpr.yaml")}')
    scale = {'velocity': 1.947, 'acceleration': 1.947, 'jerk': 10.0}
    lines = [re.sub(r'(velocity|acceleration|jerk): ([\d.]+)', lambda m: f'{m[1]}: {scale[m[1]] * float(m[2]):.6f}',
                    line) if 'name: arm1' in line else line for line in text.splitlines()]
    (tmp_path / 'robot.yaml').write_text('\n'.join(lines) + '\n')
    program = {'format': 'gpr_robot_program', 'version': 1, 'wafers': ['A'], 'units': {'length': 'mm', 'angle': 'deg'},
               'defaults': {'arm': 'arm1', 'branch': 'right', 'approach_height': 8, 'retract_height': 8,
                            'dwell': 0.2},
               'stations': [{'name': 'A', 'position': [1150, 500, 400], 'heading': 0},
                            {'name': 'B', 'position': [750, 900, 400], 'heading': 90, 'branch': 'left'}],
               'steps': [{'pick': 'A'}, {'move': 'B'}, {'move': 'A'}, {'place': 'A'}]}
    from gpr_kinematics.robot.program import parse_program

    robot = load_robot(tmp_path / 'robot.yaml')
    ratios = []
    for steps in (program['steps'], program['steps'] + [{'move': 'B', 'time': 1e5}]):
        plan = plan_program(robot, parse_program({**program, 'steps': steps}, str(tmp_path / 'p.yaml'), tmp_path))
        report = check_program(plan, None)[0]
        ratios.append((report.max_slip_evaluated, report.max_slip_ratio))
        # the swings to B and back are mirror images: their peaks (1.9742 s and 4.3248 s) tie to the rounding, which
        # the CPU's decides (AVX-512 machines reported the second, an AVX2 EPYC the first)
        assert not report.safe and min(abs(report.max_slip_at - 1.9742), abs(report.max_slip_at - 4.3248)) < 5e-3
        swing = {m.label: m.max_slip_ratio for m in report.moves}
        assert swing['steps[1] (move B, move)'] == pytest.approx(swing['steps[2] (move A, move)'], abs=1e-6)
    assert ratios[0][0] == pytest.approx(1.00019, abs=2e-5) and ratios[1][0] == pytest.approx(ratios[0][0], abs=1e-5)
    assert ratios[0][1] == pytest.approx(1.00119, abs=2e-5) and ratios[1][1] == pytest.approx(ratios[0][1], abs=1e-5)


def test_a_corner_after_21_dwells_of_a_million_seconds_is_evaluated_on_both_sides(tmp_path):
    """The slip ratio was evaluated 1 ns either side of each corner, but at 2.1e7 s the doubles are 3.7e-9 s apart:
    both sides were the corner, which takes one side of a trapezoid's jump. After 21 dwells of 1e6 s a 1 um move of
    the blade (1.17 ms, no 200 Hz instant within; no jerk limits, arm accelerations 3.5 times the example's) on a
    station tilted 1.5 deg read 0.898, safe, for the 1.084 of its decelerating half (20 kHz). The sides are at least
    4 spacings of the doubles away."""
    from gpr_kinematics.robot.program import parse_program
    from gpr_kinematics.safety.check import check_program, corner_sides

    sides = corner_sides(np.array([1.0, 2.1e7]))
    assert sides[0] == 1.0 - 1e-9 and sides[2] == 1.0 + 1e-9
    assert 2.1e7 - sides[1] == 4 * np.spacing(2.1e7) and sides[3] - 2.1e7 == 4 * np.spacing(2.1e7)
    text = config_path('robots/example_robot.yaml').read_text().replace('config: null',
                                                                         f'config: {config_path("gpr.yaml")}')
    lines = [re.sub(r'acceleration: ([\d.]+)', lambda m: f'acceleration: {3.5 * float(m[1]):g}', line)
             if 'name: arm' in line else line for line in text.splitlines() if not line.lstrip().startswith('jerk:')]
    (tmp_path / 'robot.yaml').write_text(re.sub(r', jerk: [\d.]+', '', '\n'.join(lines)) + '\n')
    robot = load_robot(tmp_path / 'robot.yaml')
    R = tilt_rotation(np.radians(1.5), np.radians(90.0))
    A = np.array([750.0, -100.0, 400.0])
    B = A + 8.0 * R[:, 2] + 0.001 * R[:, 0]           # the retract pose moved 1 um in the station plane
    station = {'heading': -90, 'tilt': 1.5, 'azimuth': 90}
    data = {'format': 'gpr_robot_program', 'version': 1, 'wafers': ['A'], 'units': {'length': 'mm', 'angle': 'deg'},
            'defaults': {'arm': 'arm2', 'branch': 'right', 'approach_height': 8, 'retract_height': 8, 'dwell': 0.5},
            'stations': [{'name': 'A', 'position': A.tolist(), **station},
                         {'name': 'B', 'position': B.tolist(), **station}]}
    for dwells, at in ((0, 0.962), (21, 2.1e7 + 0.962)):
        steps = [{'pick': 'A'}] + [{'dwell': 1e6}] * dwells + [{'move': 'B'}]
        plan = plan_program(robot, parse_program({**data, 'steps': steps}, str(tmp_path / 'p.yaml'), tmp_path))
        report = check_program(plan, None)[0]
        assert not report.safe and report.max_slip_ratio >= 1.08 and report.max_slip_at == pytest.approx(at, abs=2e-3)


def test_the_plot_marks_and_names_the_closest_pair_the_first_collision_and_the_largest_slip():
    """``--plot`` with a 7 mm margin (unsafe): the title names the program, the cell and the verdict with the text
    output's numbers; the closest pair is marked at its least distance and instant and named, the first instant
    below the margin too, the largest slip at its time with its waypoint; the legends lie beside the axes, not on
    the curves (the no-cell program's legend covered its clearance at 57 mm)."""
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.check import check_program
    from gpr_kinematics.safety.plot import check_figure
    report, clear, slip = check_program(PLAN, load_cell(CELL), 0.007)
    fig = check_figure(clear, slip, report, PROGRAM)
    ax1, ax2 = fig.axes
    assert fig._suptitle.get_text() == ('example_cell_program.yaml in cell example_cell.yaml: NOT safe\nminimum '
                                        'clearance 6.090 mm (margin 7 mm), max slip ratio 0.754 (a bound; limit 1)')
    assert (ax1.get_ylabel(), ax2.get_ylabel(), ax2.get_xlabel()) == ('clearance [mm]', 'slip ratio (1: the wafer '
                                                                       'slips)', 'time [s]')
    marks = {line.get_label().split(' at')[0]: line for line in ax1.lines + ax2.lines if line.get_marker() != 'None'}
    closest, first = report.pairs[0], report.collisions[0]
    least = marks['least 6.090 mm']
    assert (least.get_xdata()[0], least.get_ydata()[0]) == (closest['time'], report.min_clearance * 1e3)
    assert least.get_label() == f"least 6.090 mm at {closest['time']:.3f} s:\narm2_link3 / pm1/front_bottom"
    below = marks['first below the margin']
    assert (below.get_xdata()[0], below.get_ydata()[0]) == (first.time, 7.0)
    assert below.get_label().endswith(f'{" / ".join(first.bodies)}\n(step {first.step}, {first.station})')
    peak = marks['largest 0.753']
    assert (peak.get_xdata()[0], peak.get_ydata()[0]) == (report.max_slip_at, report.max_slip_evaluated)
    assert peak.get_label().endswith('steps[14] (place load_port_1, approach)')
    limits = [(line.get_label(), line.get_ydata()[0]) for ax in (ax1, ax2) for line in ax.lines
              if line.get_color() == 'r' and line.get_marker() == 'None']
    assert limits == [('margin 7 mm', 7.0), ('slips at 1', 1.0)]
    # unsafe: the curve's label says the bound is refined to each pair's least distance only (a colliding pair's other
    # intervals dip below the margin far from any approach: read as collisions)
    curve = [p.get_label() for p in ax1.patches]
    assert curve and curve[0].endswith('refined to each pair\'s least\ndistance only: below the margin\nit may lie '
                                       'far under the truth;\nthe first approach is the x'), curve
    fig.canvas.draw()
    for ax in (ax1, ax2):
        assert ax.get_legend().get_window_extent().x0 > ax.get_window_extent().x1
    # each pick's and place's hold at its station marked on both axes and named above (a dip could not be placed in
    # the program without the text table), at the instants the report's rows give
    holds = [(m.start, m.label.split('(')[1].split(',')[0]) for m in report.moves if m.label.endswith(', at)')
             and ('(pick ' in m.label or '(place ' in m.label)]
    assert len(holds) == 6   # the program's 3 picks and 3 places
    assert sorted((t.get_position()[0], t.get_text().strip()) for t in ax1.texts) == sorted(holds)
    for ax in (ax1, ax2):
        assert sorted(line.get_xdata()[0] for line in ax.lines if line.get_color() == '0.75') == sorted(
            t for t, _ in holds)
    import matplotlib.pyplot as plt
    plt.close(fig)


def test_the_plot_raises_its_top_to_a_least_clearance_above_it_and_says_when_no_wafer_is_carried():
    """A least clearance of 80 mm was drawn above the 60 mm top, its line and mark outside the axes: the top is
    raised to 1.2 times it; a program carrying no wafer says so on the empty slip panel."""
    from gpr_kinematics.safety.check import SafetyReport
    from gpr_kinematics.safety.clearance import ClearanceReport, PairClearance
    from gpr_kinematics.safety.plot import check_figure
    report = SafetyReport(True, 0.08, 0.002, 5e-5, ({'bodies': ['a', 'b'], 'distance': 0.08, 'time': 1.5},), (), 0.0,
                          0.0, math.nan, '', True, False, (), None, 10, 4, 'radial', True)   # no wafer carried
    clear = ClearanceReport((PairClearance(('a', 'b'), 0.08, 1.5),), 0.08, 0.002, 5e-5, 10, 4,
                            (np.array([0.0, 1.0, 2.0]), np.array([0.09, 0.08])))
    fig = check_figure(clear, (np.array([0.0, 2.0]), np.zeros(2)), report)
    ax1, ax2 = fig.axes
    assert ax1.get_ylim()[1] == pytest.approx(96.0 * 1.02) and ax1.patches[0].get_data()[0].tolist() == [90.0, 80.0]
    assert [t.get_text() for t in ax2.texts] == ['no wafer carried']
    # the title says so too (it read 'max slip ratio 0.000 (a bound; limit 1)'), and a wafer carried without a slip
    # ratio (held still) is no 'no wafer carried' (the panel was chosen by the ratio above 0)
    title = fig._suptitle.get_text()
    assert title.endswith('(margin 2 mm), no wafer carried') and 'slip ratio' not in title, title
    import dataclasses
    still = dataclasses.replace(report, wafer_carried=True, max_slip_at=1.0, slip_label='steps[0] (move a, move)')
    fig3 = check_figure(clear, (np.array([0.0, 2.0]), np.zeros(2)), still)
    assert len(fig3.axes[1].texts) == 0 and 'max slip ratio 0.000 (' in fig3._suptitle.get_text()
    # unsafe by the slip alone: the curve is refined to each pair's least distance (said), but no x is drawn, so none
    # is named (the legend named "the first approach is the x" with no x and no pair below the margin)
    slipping = dataclasses.replace(report, safe=False, max_slip_ratio=1.025)
    fig2 = check_figure(clear, (np.array([0.0, 2.0]), np.array([0.5, 1.025])), slipping)
    curve = fig2.axes[0].patches[0].get_label()
    assert curve.endswith("refined to each pair's least\ndistance only: below the margin\nit may lie far under the "
                          'truth') and not any(line.get_marker() == 'x' for line in fig2.axes[0].lines), curve
    (least,) = [line for line in ax1.lines if line.get_marker() == 'v']
    assert (least.get_xdata()[0], least.get_ydata()[0], least.get_label()) == (1.5, 80.0, 'least 80.000 mm at 1.500 s:'
                                                                               '\na / b')
    assert fig._suptitle.get_text().startswith('program against itself (no cell): safe\nminimum clearance 80.000 mm')
    assert fig3._suptitle.get_text().endswith('(a bound; limit 1)')
    assert ax1.patches[0].get_label().startswith('certified')
    import matplotlib.pyplot as plt
    plt.close(fig)
    # a model whose bounds between samples are first order: the figure does not call them certified
    fig = check_figure(clear, (np.array([0.0, 2.0]), np.zeros(2)), dataclasses.replace(still, model='polar',
                                                                                     proven=False))
    assert fig._suptitle.get_text().endswith('(a first-order bound: polar; limit 1)')
    assert fig.axes[0].patches[0].get_label().startswith('first-order clearance')
    plt.close(fig)


def test_a_program_carrying_no_wafer_says_no_slip_was_checked(tmp_path, capsys):
    """Moves alone carry no wafer: gpr program check printed 'max slip ratio 0.000 (a bound over the motion; 0.000
    evaluated at 0.000 s, steps[0] (move a, move))', an instant and a step of no slip. Now the line says 'no wafer
    carried: no slip checked', and the JSON keeps its keys: wafer_carried false, the ratios 0 (nothing slips), no
    instant ("nan") and no step (''); a program carrying one names its instant and step as before."""
    from gpr_kinematics.cli.main import main
    from gpr_kinematics.safety.check import check_program
    program = tmp_path / 'moves.yaml'
    program.write_text(
        f'format: gpr_robot_program\nversion: 1\nrobot: {config_path("robots/example_robot.yaml")}\n'
        'units: {length: mm, angle: deg}\ndefaults: {arm: arm1}\nstations:\n'
        '  - {name: a, position: [750, 850, 260], heading: 90}\n  - {name: b, position: [750, 850, 300], heading: 90}\n'
        'steps:\n  - {move: a}\n  - {move: b}\n  - {move: a}\n')
    assert main(['program', 'check', str(program), '--no-progress']) == 0
    out = capsys.readouterr().out
    assert re.search(r'^  clearance against itself \(no cell\): minimum [\d.]+ mm \(margin 2 mm, certified between '
                     r'samples; \d+ distance calls\); no wafer carried: no slip checked$', out, re.M), out
    assert 'slip ratio' not in out and 'evaluated at' not in out, out
    assert main(['program', 'check', str(program), '--no-progress', '--json']) == 0
    d = json.loads(capsys.readouterr().out)
    assert (d['wafer_carried'], d['max_slip_ratio'], d['max_slip_evaluated'], d['max_slip_at'], d['slip_label'],
            d['slip_certified']) == (False, 0.0, 0.0, 'nan', '', True)
    assert [m['max_slip_ratio'] for m in d['moves']] == [0.0, 0.0, 0.0]
    carried = check_program(PLAN, None, with_clearance=False)[0]   # the cell program carries its wafer
    assert carried.wafer_carried and carried.max_slip_at > 0.0 and carried.slip_label.startswith('steps[')


def test_a_program_of_one_instant_is_checked_at_it():
    """A program of one waypoint and no dwell lasts 0 s: its motion had one base instant and no interval between
    two, so no pair was measured and gpr program check read 'minimum inf mm', safe, with arm1's blade 73.389 mm
    into the load port's pedestal (the same waypoint held for a second: NOT safe). That instant is an interval of no
    length: both programs read the same pair at the same distance, and a free pose its clearance: 41 mm of arm1's
    first link above the column since links are checked against it (by hand: the rods at 76 mm for the wafer at
    260 mm, the link's bottom 85 mm above them, the column's top at 120 mm; less the library's 1 um), 60.826 mm to
    the cell."""
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.check import check_program

    cell = load_cell(CELL)
    arm1 = {'arm': 'arm1', 'approach_height': 8, 'retract_height': 8, 'dwell': 0.0}
    into = [{'name': 'a', 'position': [750, -100, 300], 'heading': -90}]
    free = [{'name': 'a', 'position': [750, 850, 260], 'heading': 90}]
    one = _cell_program(wafers=[], defaults=arm1, stations=into, steps=[{'move': 'a'}])
    held = _cell_program(wafers=[], defaults=arm1, stations=into, steps=[{'move': 'a'}, {'move': 'a', 'time': 1.0}])
    assert (len(one.waypoints), one.timing.total, held.timing.total) == (1, 0.0, 1.0)
    a, b = check_program(one, cell)[0], check_program(held, cell)[0]
    assert not a.safe and not b.safe
    assert a.pairs[0]['bodies'] == b.pairs[0]['bodies'] == ['arm1_blade', 'load_port_1_pedestal']
    assert a.min_clearance == pytest.approx(-73.389e-3, abs=1e-6) and a.min_clearance == b.min_clearance
    ok = check_program(_cell_program(wafers=[], defaults=arm1, stations=free, steps=[{'move': 'a'}]), cell)[0]
    assert ok.safe and ok.pairs[0]['bodies'] == ['gpr_base', 'arm1_link1']
    assert ok.min_clearance == pytest.approx(0.076 + 0.085 - 0.12 - 1e-6, abs=1e-9)
    assert min(p['distance'] for p in ok.pairs if p['bodies'][0] != 'gpr_base') == pytest.approx(60.826e-3, abs=1e-6)


def test_a_bad_plot_is_refused_before_the_check(tmp_path, capsys, monkeypatch):
    """``--plot`` goes through the command line's one rule of a PNG plot (``cli.options.png_plot``, as ``gpr
    calibrate`` and ``gpr accuracy``): a name not ``.png``, and without matplotlib the missing package's one line,
    before any check runs (the check replaced by a failure: it is never reached); no file written."""
    from gpr_kinematics.cli.main import main

    def never(*_args, **_kwargs):
        raise AssertionError('the program was checked before its --plot was')

    monkeypatch.setattr('gpr_kinematics.safety.check.check_program', never)
    monkeypatch.chdir(tmp_path)
    argv = ['program', 'check', str(PROGRAM), '--plot']
    assert main([*argv, 'c.svg']) == 2
    assert capsys.readouterr().err == ("gpr program check: error: --plot 'c.svg' has another suffix; allowed: a .png "
                                       "file\n")
    monkeypatch.setitem(sys.modules, 'matplotlib', None)   # not installed
    assert main([*argv, 'c.png']) == 2
    assert capsys.readouterr().err == ("gpr program check: error: this command needs the optional package "
                                       "'matplotlib', which is not installed; install it with pip install "
                                       "'gpr_kinematics[plot]'\n")
    assert list(tmp_path.iterdir()) == []


def test_two_wafers_carried_at_once_are_each_checked_for_slip():
    """arm2 holds one wafer while arm1 carries another, on a blade of friction 0.15: the check evaluated one arm per
    instant (the later arm's where both carried), read arm2's standing wafer (0.001) and called the program safe
    while arm1's wafer slips. Each arm's wafer is checked: the largest ratio agrees with second differences of
    arm1's wafer poses at 1 kHz, and the program is not safe."""
    from gpr_kinematics.robot.program import parse_program
    from gpr_kinematics.safety.check import check_program
    from robot_support import make_robot, robot_data

    data = robot_data()
    data['arms'][0]['blade']['friction'] = 0.15
    robot = make_robot(data)
    stations = [{'name': 'home', 'position': [750, 850, 260], 'heading': 90},
                {'name': 'home2', 'position': [750, 850, 400], 'heading': 90},
                {'name': 'load_port_1', 'position': [750, -100, 400], 'heading': -90},
                {'name': 'chamber_b', 'position': [300, 1050, 480], 'tilt': 0.8, 'azimuth': -60, 'heading': 130,
                 'branch': 'left'}]
    steps = [{'pick': 'chamber_b', 'arm': 'arm2'}, {'move': 'home2', 'arm': 'arm2'}, {'pick': 'load_port_1'},
             {'move': 'home'}, {'place': 'chamber_b'}, {'move': 'home'}, {'place': 'load_port_1', 'arm': 'arm2'},
             {'move': 'home2', 'arm': 'arm2'}]
    program = {'format': 'gpr_robot_program', 'version': 1, 'units': {'length': 'mm', 'angle': 'deg'},
               'defaults': {'arm': 'arm1', 'approach_height': 8, 'retract_height': 8, 'dwell': 0.5},
               'stations': stations, 'steps': steps, 'wafers': ['load_port_1', 'chamber_b']}
    plan = plan_program(robot, parse_program(program, 'dual.yaml', PROGRAM.parent))
    wafers = wafer_plan(plan)
    assert wafers.carried['arm1'] and wafers.carried['arm2']
    report, _, _ = check_program(plan, None)
    # arm1's wafer, by second differences of its world poses at 1 kHz while it carries
    rate = 1000.0
    s = sample_plan(plan, rate)
    t = s.samples.time
    h = 1.0 / rate
    p, R = s.wafer.position, s.wafer.rotation
    a = (p[2:] - 2 * p[1:-1] + p[:-2]) / h ** 2 + np.array([0.0, 0.0, 9.80665])
    n = R[1:-1, :, 2]
    fn = np.einsum('ni,ni->n', a, n)
    ratio = np.linalg.norm(a - fn[:, None] * n, axis=1) / (0.15 * fn)
    mid = t[1:-1]
    own = np.array(s.arm[1:-1]) == 'arm1'
    carried = own & np.any([(mid > a0 + h) & (mid < b0 - h) for a0, b0 in wafers.carried['arm1']], axis=0)
    fd_max = float(np.max(ratio[carried]))
    assert fd_max > 1.3
    assert not report.safe and report.max_slip_ratio == pytest.approx(fd_max, rel=5e-3)
    row = next(m for m in report.moves if m.label == 'steps[3] (move home, move)')
    assert row.max_slip_ratio == pytest.approx(fd_max, rel=5e-3)


@pytest.mark.parametrize('command', [['program', 'export', '--samples', 'out.csv'], ['program', 'check'],
                                     ['program', 'send', '--timeout', '0.1']])
def test_every_command_that_plans_a_program_refuses_its_wafers_out_of_order(tmp_path, capsys, monkeypatch, command):
    """``wafers: []`` and then a pick: ``gpr program check`` refused it, ``gpr program export`` wrote the tables (and
    ``send`` and the trajectory node took it): the order of picks and places is checked where every one of them
    plans the program, before anything is solved (``send`` before it looks for the robot); nothing written.
    (``gpr accuracy PROGRAM --tolerances`` budgets the program's stations, not its motion: it plans nothing.)"""
    from gpr_kinematics.cli.main import main
    text = PROGRAM.read_text().replace('wafers: [load_port_1]', 'wafers: []').replace(
        '../robots/', f'{PROGRAM.parent.parent}/robots/').replace('../cells/', f'{PROGRAM.parent.parent}/cells/')
    (tmp_path / 'p.yaml').write_text(text)
    monkeypatch.chdir(tmp_path)
    assert main([command[0], command[1], 'p.yaml', *command[2:]]) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and err.endswith('p.yaml: steps[1] (pick load_port_1, at): station load_port_1 holds '
                                                 'no wafer (the program declares wafers: []); allowed: a pick where a '
                                                 'wafer lies\n'), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ['p.yaml']


def test_a_program_longer_than_a_goal_may_last_is_not_exported_or_sent_as_one(tmp_path, capsys, monkeypatch):
    """A dwell of 90,000 s: the program checks (and exports as samples), but its trajectory lasts beyond the day a
    FollowJointTrajectory goal of the controller may (86,400 s): exported and sent, it was refused by the robot only
    once connected. Refused where the trajectory is made, before any file is written; a lead-in counts."""
    from gpr_kinematics.cli.main import main
    from gpr_kinematics.robot.trajectory import MAX_DURATION, program_trajectory
    source = config_path('programs/example_robot_program.yaml')
    text = source.read_text().replace('../robots/', f'{source.parent.parent}/robots/')
    (tmp_path / 'long.yaml').write_text(text.rstrip('\n') + '\n  - {dwell: 90000}\n')
    (tmp_path / 'edge.yaml').write_text(text.rstrip('\n') + f'\n  - {{dwell: {MAX_DURATION - 40:g}}}\n')
    monkeypatch.chdir(tmp_path)
    assert main(['program', 'check', 'long.yaml']) == 0
    capsys.readouterr()
    for argv in (['export', 'long.yaml', '--waypoints', 'w.csv', '--trajectory', 't.yaml', '--rate', '0.1'],
                 ['send', 'long.yaml', '--rate', '0.1', '--timeout', '0.1'],
                 ['export', 'edge.yaml', '--trajectory', 't.yaml', '--rate', '0.1', '--lead-in', '20']):
        assert main(['program', *argv]) == 2
        err = capsys.readouterr().err
        assert err.count('\n') == 1 and re.search(r'lasts (86|90)\d{3}(\.\d+)? s', err), err
        assert 'allowed: at most 86400 s (a day, the longest a FollowJointTrajectory goal of the controller ' \
               'lasts): split the program' in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ['edge.yaml', 'long.yaml']
    plan = plan_program(ROBOT, load_program(tmp_path / 'edge.yaml'), 0.1)
    assert program_trajectory(plan, 0.1).duration <= MAX_DURATION   # within the day without a lead-in: made


def test_margin_help_prints_the_default_the_check_uses(tmp_path):
    """``--margin``'s help printed a literal "(default 0.002)" beside the check's own default: now both are
    ``safety.margin.MARGIN``, and building the command line does not import the clearance search (70 ms)."""
    code = ('import sys\nfrom gpr_kinematics.cli.main import build_parser\nbuild_parser()\n'
            'print("gpr_kinematics.safety.clearance" in sys.modules)')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == 'False'
    import inspect

    from gpr_kinematics.safety import check, clearance, margin
    for function in (clearance.clearance, check.check_program):
        assert inspect.signature(function).parameters['margin'].default == margin.MARGIN
    for command in ('check', 'export', 'send'):   # export's and send's too (theirs was fixed at the default)
        res = gpr('program', command, '--help', cwd=tmp_path)
        assert f'(default {margin.MARGIN:g}; 0 to 1)' in ' '.join(res.stdout.split()), command


def test_a_check_of_something_else_than_a_plan_and_a_cell_is_named():
    """check_program(plan, {'format': 'gpr_cell'}) raised AttributeError; so did a mapping as the plan."""
    from gpr_kinematics.errors import InputError
    from gpr_kinematics.safety.check import check_program

    with pytest.raises(InputError, match=r"^cell = \{'format': 'gpr_cell'\}; allowed: a Cell \(load_cell or "
                                         r'parse_cell\) or None \(no cell\)$'):
        check_program(PLAN, {'format': 'gpr_cell'})
    with pytest.raises(InputError, match=r"^plan = \{'x': 1\}; allowed: a ProgramPlan \(plan_program\)$"):
        check_program({'x': 1}, None)


@pytest.mark.slow
def test_samples_beyond_the_imperfection_budget_are_a_finding_verify_agrees_with(tmp_path):
    """The review's program on a compliant geometry of tilted rods read 'safe' (exit 0) while its recording failed
    gpr verify's state.imperfection_budget at 267 of 606 samples. The check judges the same quantity at the samples
    of the stream at --rate against the same limit: the example robot program under a budget of 30 um, at 10 Hz, is
    NOT safe (exit 1) naming the 17 samples in 4 waypoints that its synthetic recording fails verify at."""
    from bag_support import write_bag
    from gpr_kinematics.bags.synthetic import robot_program_messages
    from gpr_kinematics.bags.typestore import GPR_TOPICS
    from gpr_kinematics.bags.verify import verify_bag
    from gpr_kinematics.safety.budget import judge_budget

    text = config_path('gpr.yaml').read_text()
    assert 'imperfection_budget: 0.0005 ' in text
    (tmp_path / 'tight.yaml').write_text(text.replace('imperfection_budget: 0.0005 ', 'imperfection_budget: 0.00003'))
    program = config_path('programs/example_robot_program.yaml')
    res = gpr('program', 'check', str(program), '--config', 'tight.yaml', '--rate', '10', cwd=tmp_path)
    assert res.returncode == 1, res.stderr
    tail = res.stdout.splitlines()[-8:]
    assert tail == [
        '  largest joint displacement 30.673 um at 16.500 s, steps[5] (place chamber_a, at) (imperfection budget 30 '
        'um; the samples of a stream at 10 Hz)',
        "  BEYOND the imperfection budget: 17 sample(s) in 4 waypoint(s) (gpr verify fails the recording's "
        'state.imperfection_budget there):',
        '    waypoint (the move into it and its hold)         first [s]  samples   max [um]    at [s]',
        '    steps[5] (place chamber_a, approach)                16.300        2     30.590    16.400',
        '    steps[5] (place chamber_a, at)                      16.500        9     30.673    16.500',
        '    steps[5] (place chamber_a, retract)                 17.400        3     30.673    17.400',
        '    steps[6] (pick chamber_b, approach)                 17.700        3     30.673    17.700',
        '  NOT safe'], res.stdout
    # docs/cell.md shows this output
    doc = (Path(__file__).resolve().parents[1] / 'docs' / 'cell.md').read_text(encoding='utf-8')
    assert '\n'.join(tail) in doc
    # the synthetic recording at 10 Hz fails verify at exactly those samples, by the same values
    robot = load_robot(geometry=tmp_path / 'tight.yaml')
    plan = plan_program(robot, load_program(program))
    budget = judge_budget(plan, 10.0)
    bag = write_bag(tmp_path / 'bag', robot_program_messages(robot, load_program(program), 10.0), dict(GPR_TOPICS))
    result = verify_bag(bag)
    (check,) = [c for c in result.checks if c.name == 'state.imperfection_budget']
    assert (check.failed, check.limit) == (17, 3e-5) and [c.name for c in result.checks if not c.passed] == [
        'state.imperfection_budget']
    assert check.worst == budget.max_displacement == pytest.approx(30.673e-6, abs=1e-9)
    failed = {f.sample: f.value for f in check.failures}
    assert sorted(failed) == [163, 164, 165, 166, 167, 168, 169, 170, 171, 172, 173, 174, 175, 176, 177, 178, 179]
    firsts = [round(f.first * 10) for f in budget.beyond]
    assert firsts == [163, 165, 174, 177] and [f.samples for f in budget.beyond] == [2, 9, 3, 3]
    assert [failed[round(f.at * 10)] for f in budget.beyond] == [f.displacement for f in budget.beyond]
    # the plot's title names them; the clearance curve is not called cut short (only a collision or a slip does so)
    from gpr_kinematics.safety.check import check_program
    from gpr_kinematics.safety.plot import check_figure
    report, clear, slip = check_program(plan, None, rate=10.0)
    assert not report.safe and report.budget == budget and not report.collisions and report.max_slip_ratio < 1.0
    fig = check_figure(clear, slip, report)
    assert fig._suptitle.get_text().endswith('\nBEYOND the imperfection budget: 17 sample(s) at 10 Hz, up to 30.673 um '
                                             '(budget 30 um)')
    assert 'refined' not in fig.axes[0].patches[0].get_label()
    import matplotlib.pyplot as plt
    plt.close(fig)
    # within the budget of the shipped geometry: safe, the largest displacement reported
    res = gpr('program', 'check', str(program), '--json', cwd=tmp_path)
    d = json.loads(res.stdout)
    assert res.returncode == 0 and d['safe'] and d['budget']['beyond'] == [] and d['budget']['rate'] == 100.0
    assert d['budget']['max_displacement'] == budget.max_displacement and d['budget']['budget'] == 5e-4


def _random_timings(seed: int, trials: int):
    """Holds and moves of random timings (chk_held2's generator): whole samples, 1e-10 and 5e-13 off them, holds of
    0 s; ``(rate, total, holds, moves)``."""
    import random
    rnd = random.Random(seed)
    for _ in range(trials):
        rate = rnd.choice([0.1, 1, 3, 7, 10, 30, 100, 1000])
        pts = [0.0]
        for i in range(2 * rnd.randint(1, 4) - 1):
            move = i % 2 == 0
            step = rnd.choice([rnd.uniform(0, 3), round(rnd.uniform(0, 3) * rate) / rate] + ([] if move else [0.0]))
            v = pts[-1] + (max(step, 1e-3) if move else step)
            if rnd.random() < 0.3:
                v += rnd.choice([1e-10, -1e-10, 5e-13, -5e-13])
            pts.append(max(v, pts[-1] + (1e-3 if move else 0)))
        if len(pts) % 2:
            pts.append(pts[-1] + rnd.choice([0.0, 1.0, 1.0 + 1e-10, 1.0 - 1e-10, 1 - 5e-13]))
        holds = [(pts[i], pts[i + 1]) for i in range(0, len(pts), 2)]
        moves = [(pts[i], pts[i + 1]) for i in range(1, len(pts) - 1, 2)]
        if all(b - a >= 1e-3 for a, b in moves):
            yield rate, pts[-1], holds, moves


def test_the_budget_s_holds_and_moves_hold_exactly_the_stream_s_samples():
    """_held estimated its count from floor and ceil of a * rate and b * rate, one correction each: where k / rate
    rounds it counted 9 samples from 3.6666666666666665 s in a hold [3.666666666666667, 6.333333333433334] at 3 Hz
    whose stream (grid_times) has 8 from 4.0 s, and 1 in the hold [0, 0.9999999999995] at 1 Hz whose stream has 2
    (0 and the end); 600 of 30000 random timings were wrong. Now corrected until exact, against grid_times."""
    from gpr_kinematics.robot.grid import grid_between, grid_count, grid_times
    from gpr_kinematics.safety.budget import _grid, _held

    assert _held(3.666666666666667, 6.333333333433334, 3.0, 10.0) == (4.0, 8)
    assert _held(0.0, 0.9999999999995, 1.0, 0.9999999999995) == (0.0, 2)
    assert _held(0.5, 0.9999999999995, 1.0, 0.9999999999995) == (0.9999999999995, 1)
    assert _held(0.2, 0.3, 1.0, 5.0) == (0.2, 0) and _held(0.0, 1e-12, 10.0, 1e-12) == (0.0, 2)
    assert _grid(0.0, 0.25, 10.0, 0.25).tolist() == [0.1, 0.2] and _grid(0.0, 1.0, 10.0, 0.25).tolist() == [
        0.1, 0.2, 0.25] and grid_between(1.0, 10.0, 0.5, 0.5, False) == (6, 6, False)
    checked = 0
    for rate, total, holds, moves in _random_timings(2, 9000):
        g = grid_times(total, rate)
        for a, b in holds:
            inside = g[(g >= a) & (g <= b)]
            assert _held(a, b, rate, total) == ((float(inside[0]) if len(inside) else a), len(inside)), (a, b, rate)
        for a, b in moves:
            assert _grid(a, b, rate, total).tolist() == g[(g > a) & (g < b)].tolist(), (a, b, rate, total)
        checked += 1
    assert checked > 5000
    # a hold longer than any stream, counted without its samples: the whole of it holds all of grid_times'
    for total, rate in ((1e6, 5000.0), (1e6 + 1e-10, 3.0), (86400.3 - 5e-13, 7.0), (3e7, 0.1)):
        assert _held(0.0, total, rate, total) == (0.0, grid_count(total, rate))
    assert _held(1.0 / 3.0, 1e6, 3.0, 1e6) == (1.0 / 3.0, 3 * 10 ** 6)


@pytest.mark.parametrize('name', ['example_robot_program.yaml', 'example_cell_program.yaml'])
def test_the_budget_s_instants_are_the_stream_s_samples_and_weigh_all_of_them(name):
    """The instants judge_budget evaluates are samples of the stream at the rate (grid_times), their weights sum to
    its sample count; moves beyond MAX_SAMPLES at the rate get at most MAX_SAMPLES instants (and one per hold)."""
    import gpr_kinematics.safety.budget as budget
    from gpr_kinematics.robot.grid import grid_times

    plan = plan_program(load_robot(), load_program(config_path(f'programs/{name}')))
    for rate in (0.1, 1.0, 7.0, 100.0, 5000.0):
        times, w = budget.budget_instants(plan, rate)
        g = grid_times(plan.timing.total, rate)
        if len(g) > budget.MAX_SAMPLES:      # the cell program at 5000 Hz: 297911 samples, no such stream
            assert len(times) <= budget.MAX_SAMPLES + 2 * len(plan.timing.arrive), rate
            continue
        assert int(w.sum()) == len(g) and np.isin(times, g).all() and len(np.unique(times)) == len(times), rate
    holds = len(plan.timing.arrive)
    moves = len(grid_times(plan.timing.total, 100.0)) - holds
    old, budget.MAX_SAMPLES = budget.MAX_SAMPLES, 500
    try:
        times, w = budget.budget_instants(plan, 100.0)
    finally:
        budget.MAX_SAMPLES = old
    assert moves > 2000 and len(times[w == 1]) <= 500 + holds and len(times) <= 500 + 2 * holds


def test_program_check_refuses_a_rate_outside_its_range_in_one_line(tmp_path):
    """Named as typed ('rate = 5001.0' named the float it became) and before the program is planned."""
    program = config_path('programs/example_robot_program.yaml')
    for rate, shown in (('0', '0'), ('nan', 'nan'), ('5001', '5001'), ('-1', '-1')):
        res = gpr('program', 'check', str(program), '--rate', rate, cwd=tmp_path)
        assert res.returncode == 2 and res.stderr == (
            f'gpr program check: error: --rate = {shown} Hz is invalid; allowed: 0.1 <= rate <= 5000 Hz (a sample '
            'every 0.2 ms to every 10 s)\n'), res.stderr


def test_two_holds_joined_by_a_move_of_no_time_count_their_shared_sample_once(tmp_path):
    """A station repeated in a row (or a pick with approach_height 0) joins two holds at one instant: both closed
    intervals counted the stream's sample there, so a finding read 3 samples where the stream has 2 (at 2 Hz; 4 of
    3 at 4 Hz, 7 of 6 at 10 Hz), and the weights no longer summed to the stream's count."""
    import gpr_kinematics.safety.budget as budget
    from gpr_kinematics.robot.grid import grid_times

    program = tmp_path / 'p.yaml'
    program.write_text('format: gpr_robot_program\nversion: 1\nunits: {length: mm, angle: deg}\n'
                       'defaults: {arm: arm1, approach_height: 8, retract_height: 8, dwell: 0.5}\nstations:\n'
                       '  - {name: home, position: [750, 850, 260], heading: 90}\n'
                       '  - {name: chamber_a, position: [1200, 1000, 440], tilt: 1.2, azimuth: 30, heading: 45}\n'
                       'steps:\n  - {move: home}\n  - {move: chamber_a, time: 2.0, dwell: 0}\n  - {move: chamber_a}\n'
                       '  - {move: home, time: 2.0}\n')
    plan = plan_program(load_robot(), load_program(program))
    assert plan.timing.arrive[2] == plan.timing.depart[1] == 2.5   # the move of no time
    for rate in (2.0, 4.0, 10.0, 3.0, 100.0):
        times, w = budget.budget_instants(plan, rate)
        g = grid_times(plan.timing.total, rate)
        assert int(w.sum()) == len(g) and np.isin(times, g).all() and len(np.unique(times)) == len(times), rate


def test_the_splines_slip_samples_each_segment_not_at_the_shortest_segments_rate(monkeypatch):
    """trajectory_slip sampled every carry at twice the rate of the trajectory's shortest segment: at --rate
    10.003025834 Hz the example cell program's last segment is 3 ns long, and each carry took the 200,000 samples'
    cap (7 s for the example, hours for a long program). Now each segment's thirds, the knots' sides and 200 Hz:
    about as many instants as at 10 Hz (its spline, through other points, near the program's 0.753)."""
    from gpr_kinematics.robot.trajectory import program_trajectory
    from gpr_kinematics.safety import slip

    seen = []
    ratio_at = slip._ratio_at
    monkeypatch.setattr(slip, '_ratio_at', lambda plan, arm, R, acc: seen.append(R.shape[0]) or ratio_at(plan, arm,
                                                                                                          R, acc))
    carried = wafer_plan(PLAN).carried
    slip.trajectory_slip(PLAN, program_trajectory(PLAN, 10.0), carried)
    at_ten, seen[:] = sum(seen), []
    odd = program_trajectory(PLAN, 10.003025834)
    assert np.min(np.diff(odd.time)) < 1e-8   # the 3 ns segment
    ratio, _ = slip.trajectory_slip(PLAN, odd, carried)
    assert sum(seen) < 1.1 * at_ten and ratio == pytest.approx(0.753, abs=0.02)


def test_a_place_without_a_pick_carries_its_wafer_from_the_start():
    """Without ``wafers`` a place has one to place (docs/cell.md), but that wafer went unchecked on its way there: no
    body until the place and a slip ratio of 0 (a box 1 mm into its path and a slipping wafer passed as safe). It is
    on the blade from the start, and from an arm's last place on for a place after it."""
    from gpr_kinematics.inputs.safe_yaml import read_file
    from gpr_kinematics.safety.check import check_program, wafer_plan

    steps = list(read_file(PROGRAM)['steps'])
    plan = _cell_program(wafers=None, steps=steps[3:6] + steps[7:10])   # places at pm1, then pm2: no pick
    way, timing = plan.waypoints, plan.timing
    at = [i for i, phase in enumerate(way.phase) if phase == 'at']
    carried = wafer_plan(plan).carried['arm2']
    assert carried == ((0.0, float(timing.arrive[at[0]])),   # the second from the arm's next waypoint after the
                       (float(timing.arrive[at[0] + 2]), float(timing.arrive[at[1]])))   # first place's retract
    moves = check_program(plan, None, with_clearance=False)[0].moves
    assert max(m.max_slip_ratio for m in moves if m.end <= carried[0][1]) > 0.01   # was 0: no wafer
    # with a retract of 2.6 mm the second wafer, put on the blade at the retract, lay 0.8 mm under it beside the
    # wafer just placed: 'UNSAFE ... arm2_wafer / wafer@pm1' where the program with its picks is safe
    from gpr_kinematics.safety.cell import load_cell
    defaults = dict(read_file(PROGRAM)['defaults']) | {'retract_height': 2.6}
    low = _cell_program(wafers=None, steps=steps[3:6] + steps[7:10], defaults=defaults)
    assert check_program(low, load_cell(CELL))[0].safe


def test_a_pick_without_declared_wafers_finds_its_wafer_there_from_the_start():
    """Without ``wafers`` a pick finds a wafer where it picks (docs/cell.md), but that wafer was no body until the pick:
    the shipped example robot program's arm2 swung its blade in 0.22 mm from the wafer it picks at chamber_b and
    passed as safe (with ``wafers`` declared it failed). It lies at its station from the start (or from when the last
    pick there left it) until its pick; the example now approaches chamber_b 12 mm under it (3.879 mm least)."""
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.program import load_program
    from gpr_kinematics.safety.check import check_program, wafer_plan

    program = load_program(config_path('programs/example_robot_program.yaml'))
    plan = plan_program(ROBOT, program)
    way, timing = plan.waypoints, plan.timing
    picks = {str(program.steps[int(way.step[i])].station): float(timing.arrive[i]) for i, phase in enumerate(way.phase)
             if phase == 'at' and program.steps[int(way.step[i])].kind == 'pick'}
    lying: dict[str, list] = {}
    for _, station, windows in wafer_plan(plan).stations:
        lying.setdefault(station, []).extend(windows)
    assert lying['chamber_b'] == [(0.0, picks['chamber_b'])]
    assert lying['load_port_1'][0] == (0.0, picks['load_port_1'])   # then the wafer placed there at the end
    # with the old approach of 8 mm the blade passes 0.22 mm from it: NOT safe now, as with the wafers declared
    eight = dataclasses.replace(program, stations=dataclasses.replace(
        program.stations, approach_height=tuple(None for _ in program.stations.approach_height)))
    report = check_program(plan_program(ROBOT, eight), None)[0]
    assert not report.safe and 0.0002 < report.min_clearance < 0.00024
    report = check_program(plan, None)[0]
    assert report.safe and report.min_clearance == pytest.approx(0.003879, abs=1e-6)


@pytest.mark.parametrize('name', ['gpr_base', 'arm1_wafer', 'arm2_blade', 'wafer@pm1:start'])
def test_an_obstacle_named_as_a_robot_body_is_refused(name):
    """A pin named ``gpr_base`` read as the column colliding with a wafer (``arm1_wafer / gpr_base -1.049``), one
    named ``arm1_wafer`` as ``arm1_wafer / arm1_wafer``: refused naming the robot's bodies."""
    import dataclasses as dc

    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.safety.cell import load_cell
    from gpr_kinematics.safety.check import check_program

    cell = load_cell(CELL)
    renamed = dc.replace(cell, obstacles=(dc.replace(cell.obstacles[0], name=name), *cell.obstacles[1:]))
    with pytest.raises(ConfigError, match=rf"obstacle '{re.escape(name)}' has the name of a body of robot "
                                          r'example_dual_arm; allowed: a name no robot body has .*gpr_platform\)$'):
        check_program(PLAN, renamed)

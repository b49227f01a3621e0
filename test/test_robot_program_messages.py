"""Robot programs after a user trial: the defaults' arm and branch checked as the other defaults keys (blamed on
the first step that took them, and passed when none did), a place's heights as the code and the docs give them, an
imported station file that cannot be read named with the program, a teach table's header example one of its own
columns, and every refused branch saying that empty is allowed too."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from gpr_kinematics.errors import ConfigError, FileError
from gpr_kinematics.robot.program import expand, load_program
from gpr_kinematics.robot.teach import read_joint_table
from robot_support import ROBOT

DOCS = Path(__file__).resolve().parents[1] / 'docs' / 'robot.md'


def _write(tmp_path, steps, defaults=None, name='p.yaml', **more):
    data = {'format': 'gpr_robot_program', 'version': 1, 'units': {'length': 'mm', 'angle': 'deg'},
            'stations': [{'name': 'a', 'position': [1250, 500, 350], 'tilt': 0.5, 'azimuth': 0, 'heading': 0},
                         {'name': 'b', 'position': [350, 300, 380], 'tilt': 1.5, 'azimuth': -45, 'heading': -150}],
            'steps': steps, **more}
    if defaults is not None:
        data['defaults'] = defaults
    f = tmp_path / name
    f.write_text(yaml.safe_dump(data))
    return f


STEPS = [{'pick': 'a'}, {'place': 'b', 'dwell': 0.8}, {'dwell': 0.3}]
EXPLICIT = [{'pick': 'a', 'arm': 'arm1'}, {'place': 'b', 'arm': 'arm1', 'branch': 'left'}]


@pytest.mark.parametrize('steps', [STEPS, EXPLICIT], ids=['taken', 'unused'])
def test_a_bad_default_arm_is_named_as_the_defaults_whether_a_step_takes_it_or_not(tmp_path, steps):
    """It said `steps[0]: arm = 'arm7'` (steps[0] gave no arm), and passed when every step named its arm."""
    f = _write(tmp_path, steps, {'arm': 'arm7', 'approach_height': 6, 'retract_height': 7})
    with pytest.raises(ConfigError) as info:
        expand(load_program(f), ROBOT)
    assert str(info.value) == f"{f}: defaults: arm = 'arm7' is invalid; allowed: arm1, arm2"


@pytest.mark.parametrize('steps', [STEPS, EXPLICIT], ids=['taken', 'unused'])
@pytest.mark.parametrize('value', ['centre', 5])
def test_a_bad_default_branch_is_refused_with_the_file_whether_a_step_takes_it_or_not(tmp_path, steps, value):
    """It said `steps[0]: branch = 'centre'`, and passed when no step took it (a station or step gave its own)."""
    f = _write(tmp_path, steps, {'arm': 'arm1', 'branch': value})
    with pytest.raises(ConfigError) as info:
        load_program(f)
    shown = repr(value)
    assert str(info.value) == (f"{f}: defaults: branch = {shown} is invalid; allowed: left, right or empty (the "
                               "arm's own)")


def test_a_bad_step_branch_says_what_empty_stands_for_and_empty_is_taken(tmp_path):
    f = _write(tmp_path, [{'pick': 'a', 'branch': 'middle'}, {'place': 'b'}])
    with pytest.raises(ConfigError) as info:
        load_program(f)
    assert str(info.value) == (f"{f}: steps[0]: branch = 'middle' is invalid; allowed: left, right or empty (the "
                               "station's, else the defaults', else the arm's own)")
    empty = load_program(_write(tmp_path, [{'pick': 'a', 'branch': ''}, {'place': 'b', 'branch': None}],
                                {'branch': ''}, name='q.yaml'))
    assert expand(empty, ROBOT).branch == ('right',) * 6   # arm1's own


def test_a_place_rises_by_the_approach_height_and_lowers_by_the_retract_height_as_documented(tmp_path):
    """A user read the docs' "place S -> raised, at (dwell), lowered" the other way round: 1 mm off at every place
    waypoint with approach 6 mm and retract 7 mm. The code: a pick or place comes in by its approach height and
    leaves by its retract height; the docs say so next to the pick's description."""
    p = load_program(_write(tmp_path, STEPS, {'approach_height': 6, 'retract_height': 7}))
    w = expand(p, ROBOT)
    st = p.stations.stations
    along = [float((w.stations.position[k] - st.position[p.stations.index()[n.split('/')[0]]])
                   @ st.normal[p.stations.index()[n.split('/')[0]]]) for k, n in enumerate(w.stations.names)]
    assert w.phase == ('approach', 'at', 'retract') * 2
    np.testing.assert_allclose(np.array(along) * 1000, [-6, 0, 7, 6, 0, -7], rtol=0, atol=1e-9)
    docs = ' '.join(DOCS.read_text().split())
    assert ('`place S` -> `S` **raised by the approach height** (the wafer above its place), `S` itself (held for '
            '`dwell`: the wafer is set down), `S` **lowered by the retract height** (the blade under it)') in docs
    assert "a place's first waypoint is 6 mm above the station, its last 7 mm below" in docs


def test_an_imported_station_file_that_cannot_be_read_is_named_with_the_program(tmp_path):
    """It said `cannot read station file 'imp/st_typo.csv': No such file or directory`, naming neither the program
    nor its import key (a mistyped robot: file is named "(named by the program, relative to its folder)")."""
    folder = tmp_path / 'imp'
    folder.mkdir()
    f = _write(folder, [{'move': 'a'}], **{'import': 'st_typo.csv'})
    with pytest.raises(FileError) as info:
        load_program(f)
    assert str(info.value) == (f"{f}: import 'st_typo.csv' (named by the program, relative to its folder): cannot "
                               f"read station file '{folder / 'st_typo.csv'}': No such file or directory; allowed: "
                               'an existing file this user can read')
    absolute = folder / 'gone.csv'   # an absolute path is relative to nothing
    with pytest.raises(FileError) as info:
        load_program(_write(folder, [{'move': 'a'}], name='q.yaml', **{'import': [str(absolute)]}))
    message = str(info.value)
    assert message.startswith(f"{folder / 'q.yaml'}: import '") and 'relative to its folder' not in message
    assert message.endswith("gone.csv': No such file or directory; allowed: an existing file this user can read")


def test_a_teach_tables_header_example_is_one_of_its_own_columns(tmp_path):
    """A mistyped teach table header listed the allowed columns, then `e.g. "x [mm]"`: a teach table has no x."""
    t = tmp_path / 'old.csv'
    t.write_text('name,rod_1 [mm],rod_2 [mm],rod_3 [mm],arm1_shoulder [deg],arm1_elbw [deg],arm1_wrist [deg]\n'
                 's1,166,166.7,165.3,-59.7,120,-60.3\n')
    with pytest.raises(ConfigError) as info:
        read_joint_table(t, ROBOT, 'arm1')
    assert str(info.value) == (f"{t}: header column 6 'arm1_elbw [deg]' is invalid; allowed: name, rod_1, rod_2, "
                               'rod_3, arm1_shoulder, arm1_elbow, arm1_wrist, each with an optional unit in '
                               'brackets, e.g. "rod_1 [mm]"')
    s = tmp_path / 'st.csv'   # a station file keeps its x
    s.write_text('name,x [mm],y [mm],z [mm],hight [mm]\na,1250,500,350,1\n')
    with pytest.raises(ConfigError, match=r'each with an optional unit in brackets, e\.g\. "x \[mm\]"$'):
        load_program(_write(tmp_path, [{'move': 'a'}], name='s.yaml', **{'import': 'st.csv'}))

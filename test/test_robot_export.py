"""Joint tables: CSV and JSON hold the plan's numbers exactly, with the columns documented."""
import csv
import json

import numpy as np
import pytest
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.export import sample_table, waypoint_table, write_table
from gpr_kinematics.robot.plan import plan_program, sample_plan
from gpr_kinematics.robot.program import load_program
from robot_support import ROBOT

PLAN = plan_program(ROBOT, load_program(config_path('programs/example_robot_program.yaml')))


def test_waypoint_table_round_trips_in_csv_and_json(tmp_path):
    columns, rows = waypoint_table(PLAN)
    assert columns[:9] == ['waypoint', 'step', 'kind', 'station', 'phase', 'arm', 'branch', 'arrive', 'depart']
    assert columns[9:19] == list(PLAN.joint_names) and columns[-1] == 'naive_wafer_error'
    write_table(tmp_path / 'w.csv', columns, rows, {})
    with open(tmp_path / 'w.csv', newline='') as fh:
        back = list(csv.reader(fh))
    assert back[0] == columns and len(back) == len(PLAN.waypoints) + 1
    joints = np.array([[float(v) for v in row[9:19]] for row in back[1:]])
    np.testing.assert_array_equal(joints, PLAN.positions)  # exact: shortest round-trip repr
    np.testing.assert_array_equal([float(r[7]) for r in back[1:]], PLAN.timing.arrive)
    write_table(tmp_path / 'w.json', columns, rows, {'robot': ROBOT.name})
    doc = json.loads((tmp_path / 'w.json').read_text())
    assert doc['format'] == 'gpr_joint_table' and doc['version'] == 1
    assert doc['units'] == {'length': 'm', 'angle': 'rad', 'time': 's'}
    assert doc['robot'] == ROBOT.name and doc['columns'] == columns
    np.testing.assert_array_equal(np.array([r[9:19] for r in doc['rows']]), PLAN.positions)
    i = columns.index('wafer_x')
    np.testing.assert_array_equal(np.array([r[i:i + 3] for r in doc['rows']]), PLAN.wafer.position)


def test_sample_table(tmp_path):
    sampled = sample_plan(PLAN, 10.0)
    columns, rows = sample_table(PLAN, sampled)
    assert columns[:3] == ['time', 'waypoint', 'arm'] and len(rows) == len(sampled)
    write_table(tmp_path / 's.csv', columns, rows, {})
    back = list(csv.reader((tmp_path / 's.csv').read_text().splitlines()))
    np.testing.assert_array_equal(np.array([[float(v) for v in r[3:13]] for r in back[1:]]), sampled.samples.positions)
    assert {r[2] for r in back[1:]} == {'arm1', 'arm2'}


def test_bad_output_files(tmp_path):
    columns, rows = waypoint_table(PLAN)
    with pytest.raises(ConfigError, match=r"unknown type .txt; allowed: .csv or .json"):
        write_table(tmp_path / 'w.txt', columns, rows, {})
    with pytest.raises(ConfigError, match=r"cannot write .*missing/w.csv"):
        write_table(tmp_path / 'missing' / 'w.csv', columns, rows, {})

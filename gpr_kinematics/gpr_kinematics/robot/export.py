"""Joint tables for a controller: a checked program's waypoints and samples, as CSV or JSON (SI units).

Waypoint table, one row per waypoint: ``waypoint, step, kind, station, phase, arm, branch, arrive, depart``, then
every joint (the three rods, then each arm's joints, by name), then the wafer pose reached in the world
(``wafer_x, wafer_y, wafer_z, wafer_qx, wafer_qy, wafer_qz, wafer_qw``) and ``naive_wafer_error`` (the distance
by which the naive model's joints would miss the waypoint) [m].

Sample table, one row per sample: ``time, waypoint`` (the waypoint held, -1 while moving), ``arm``, every joint,
the wafer pose.

CSV: one header row, then the rows; numbers printed to round-trip exactly (Python's shortest ``repr``). JSON: one
object ``{"format": "gpr_joint_table", "version": 1, "robot": ..., "program": ..., "units": {...}, "columns":
[...], "rows": [[...], ...]}``. The file type follows the extension (``.csv``, ``.json``).
"""
from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..inputs.files import atomic_output, check_output
from .plan import PlanSamples, ProgramPlan

TABLE_FORMAT = 'gpr_joint_table'
_WAFER = ('wafer_x', 'wafer_y', 'wafer_z', 'wafer_qx', 'wafer_qy', 'wafer_qz', 'wafer_qw')


def waypoint_table(plan: ProgramPlan) -> tuple[list[str], list[list[Any]]]:
    """Columns and rows of the waypoint table (module docstring)."""
    w = plan.waypoints
    steps = plan.program.steps
    columns = ['waypoint', 'step', 'kind', 'station', 'phase', 'arm', 'branch', 'arrive', 'depart',
               *plan.joint_names, *_WAFER, 'naive_wafer_error']
    numbers = np.column_stack([plan.timing.arrive, plan.timing.depart, plan.positions, plan.wafer.position,
                               plan.wafer.quaternion, np.linalg.norm(plan.naive_wafer_error, axis=1)]).tolist()
    rows = []
    for i, values in enumerate(numbers):
        s = int(w.step[i])
        rows.append([i, s, steps[s].kind, steps[s].station, w.phase[i], w.arm[i], w.branch[i], *values])
    return columns, rows


def sample_table(plan: ProgramPlan, sampled: PlanSamples) -> tuple[list[str], list[list[Any]]]:
    """Columns and rows of the sample table (module docstring)."""
    s = sampled.samples
    columns = ['time', 'waypoint', 'arm', *plan.joint_names, *_WAFER]
    numbers = np.column_stack([s.positions, sampled.wafer.position, sampled.wafer.quaternion]).tolist()
    rows = [[t, h, a, *v] for t, h, a, v in zip(s.time.tolist(), s.held.tolist(), sampled.arm, numbers,
                                                strict=True)]
    return columns, rows


def check_table_path(path: str | Path, what: str = 'output file') -> Path:
    """The output ``path`` of a table, checked before any work: ``.csv`` or ``.json``, and writable
    (:func:`gpr_kinematics.inputs.files.check_output`); ``what`` names it (the command line: its option)."""
    target = check_output(path, 'joint table')
    suffix = target.suffix.lower()
    if suffix not in ('.csv', '.json'):
        raise ConfigError(f'{what} {str(path)!r}: unknown type {suffix or "(none)"}; allowed: .csv or .json')
    return target


def write_table(path: str | Path, columns: list[str], rows: list[list[Any]], meta: dict[str, Any]) -> Path:
    """Write a table to ``path`` (``.csv`` or ``.json``, module docstring) atomically; returns the path written.

    Raises:
        ConfigError: an unknown file type; FileError (a ConfigError): the file cannot be written.
    """
    check_table_path(path)
    with atomic_output(path, 'joint table') as fh:
        if Path(path).suffix.lower() == '.csv':
            writer = csv.writer(fh, lineterminator='\n')
            writer.writerow(columns)
            writer.writerows(rows)
        else:
            json.dump({'format': TABLE_FORMAT, 'version': 1, **meta,
                       'units': {'length': 'm', 'angle': 'rad', 'time': 's'}, 'columns': columns, 'rows': rows},
                      fh, allow_nan=False)
            fh.write('\n')
    return Path(path)

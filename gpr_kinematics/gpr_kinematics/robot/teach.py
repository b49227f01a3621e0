"""Teach and re-teach: from joints to stations, and migrating what the old offline tool computed.

* :func:`teach`: joints measured on the real robot (rods and arm joints, e.g. after jogging the wafer to a
  station) -> the station, through the exact platform pose; also the station the naive model would have recorded
  for the same joints (what the old tool stored) and the difference.
* :func:`reteach`: joints that the old tool computed or stored with the naive model (the platform rotated about
  its centre, Bratovanov & Sotirov Fig. 2) -> the station the old tool *intended* (the naive forward kinematics
  of those joints), the joints that really put the wafer there (:func:`solve_stations`, keeping each station's
  branch and, for a 4-joint arm under ``fixed_joint``, its held joint value), and the wafer error the old joints
  make, which the new ones avoid.
"""
from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.forward import forward, forward_batch
from ..core.ops import SCALAR
from ..core.stroke import check_stroke, millimetres_within
from ..errors import ConfigError, InputError, LimitError, apart, brief
from ..inputs.files import read_text
from ..inputs.safe_yaml import MAX_BYTES
from ..inputs.validation import rows_of
from .arm_chain import LIMIT_SLACK, representative
from .description import Arm, RobotDescription
from .forward import RobotForward, check_rods, robot_forward
from .inverse import StationSolution, held_refusal, solve_stations
from .planar_arm import branch_of
from .station_files import CsvTable, read_csv_table, station_name
from .stations import StationRecord, Stations, stations_from_poses

Array = NDArray[np.float64]


@dataclass(frozen=True)
class TaughtRecord:
    """One taught station: its ``name``, the ``station`` and the ``naive_station`` the naive model records for the
    same joints, and the real minus the naive wafer position (``naive_error`` [m] and its vector [m, world])."""

    name: str
    station: StationRecord
    naive_station: StationRecord
    naive_error: float
    naive_error_vector: Array


#: How far a re-taught joint may move from its old value [rad] before re-teach says the posture changed: correcting
#: the naive model's micrometres moves a joint by far less; a 4-joint arm under ``nearest`` takes the posture nearest
#: its reference, not the old one (hi_j3 moved 0.89 rad and hi_j4 0.66 rad for a 3.6 um error, without a word).
MOVED_JOINT = 0.01


@dataclass(frozen=True)
class RetaughtRecord:
    """One re-taught station: its ``name``, the station the old tool ``intended``, the new ``rods`` [m] and arm
    joints by name [rad], the wafer error the old joints made (``avoided_error`` [m] and its vector), and the joints
    moved more than :data:`MOVED_JOINT` from their old values (``moved``: new minus old [rad] by name; empty where
    the old posture is kept)."""

    name: str
    intended: StationRecord
    rods: Array
    arm: dict[str, float]
    avoided_error: float
    avoided_error_vector: Array
    moved: dict[str, float]


@dataclass(frozen=True)
class TeachReport:
    """``gpr robot teach --json``: the ``robot``, whether the joints were re-taught (``reteach``) and a record per
    station (:class:`TaughtRecord`, or :class:`RetaughtRecord` when re-taught)."""

    robot: str
    reteach: bool
    stations: tuple[TaughtRecord, ...] | tuple[RetaughtRecord, ...]


@dataclass(frozen=True)
class Taught:
    """Stations of measured joints: ``stations`` (exact), ``naive_stations`` (what the naive model records for the
    same joints) and ``forward`` (the whole-robot forward kinematics)."""

    forward: RobotForward
    stations: Stations
    naive_stations: Stations

    @property
    def naive_error(self) -> Array:
        """Real minus naive wafer position ``(N, 3)`` [m, world]."""
        return self.forward.naive_wafer_error

    def records(self) -> tuple[TaughtRecord, ...]:
        """Every station as a :class:`TaughtRecord` (each error array computed once, each record its own copy)."""
        error = self.naive_error
        norm = np.linalg.norm(error, axis=1)
        return tuple(TaughtRecord(name, self.stations.record(i), self.naive_stations.record(i), float(norm[i]),
                                  np.array(error[i])) for i, name in enumerate(self.stations.names))


def teach(robot: RobotDescription, rods: ArrayLike, joints: ArrayLike, arm: str | None = None,
          names: Sequence[str] | None = None) -> Taught:
    """Stations of the wafer for measured rods ``(N, 3)`` and joints ``(N, n)`` (limits checked)."""
    fk = robot_forward(robot, rods, joints, arm)
    return Taught(forward=fk, stations=stations_from_poses(fk.wafer.position, fk.wafer.rotation, names),
                  naive_stations=stations_from_poses(fk.naive_wafer.position, fk.naive_wafer.rotation, names))


@dataclass(frozen=True)
class Retaught:
    """Re-teach of joints computed with the naive model.

    Attributes:
        old: forward kinematics of the old joints (``old.wafer``: where they really put the wafer).
        intended: the stations the old tool intended (naive forward kinematics of the old joints).
        solution: the new joints for those stations (:class:`StationSolution`).
    """

    old: RobotForward
    intended: Stations
    solution: StationSolution

    @property
    def avoided_error(self) -> Array:
        """Where the old joints really put the wafer minus where they were meant to ``(N, 3)`` [m, world]."""
        return self.old.wafer.position - self.intended.position

    @property
    def avoided_error_norm(self) -> Array:
        return np.asarray(np.linalg.norm(self.avoided_error, axis=1), dtype=np.float64)

    @property
    def joint_change(self) -> Array:
        """The new arm joints minus the old ``(N, n)`` [rad]."""
        return np.asarray(self.solution.joints - self.old.joints, dtype=np.float64)

    def records(self) -> tuple[RetaughtRecord, ...]:
        """Every station as a :class:`RetaughtRecord` (each error array computed once, each record its own copy)."""
        sol = self.solution
        names = sol.forward.robot.arm(sol.arm).joint_names
        avoided, norm, change = self.avoided_error, self.avoided_error_norm, self.joint_change
        return tuple(RetaughtRecord(name, self.intended.record(i), np.array(sol.rods[i]),
                                    dict(zip(names, sol.joints[i].tolist(), strict=True)), float(norm[i]),
                                    np.array(avoided[i]), {n: float(d) for n, d in zip(names, change[i], strict=True)
                                                           if abs(d) > MOVED_JOINT})
                     for i, name in enumerate(self.intended.names))


#: How far beyond its limits an old joint of :func:`reteach` may lie [rad]: a turn. The old tool's joints need not
#: keep the new limits, but one more than a turn beyond is no posture of the joint (a turn back it is still beyond):
#: a value in another unit (degrees in a column without one).
OLD_JOINT_SLACK = 2.0 * math.pi


def _beyond_a_turn(a: Arm, value: float, k: int) -> str | None:
    """How an old joint value [rad] more than :data:`OLD_JOINT_SLACK` beyond joint ``k``'s limits is refused
    (None within)."""
    j = a.joints[k]
    if j.lower - OLD_JOINT_SLACK <= value <= j.upper + OLD_JOINT_SLACK:
        return None
    side, limit = ('lower', j.lower) if value < j.lower else ('upper', j.upper)
    return (f'{j.name} = {value:.9g} rad is more than a turn (2 pi) beyond its {side} limit {limit:.9g} rad, no '
            f'posture of it (another unit?); allowed for old joints: [{j.lower - OLD_JOINT_SLACK:.9g}, '
            f'{j.upper + OLD_JOINT_SLACK:.9g}] rad')


def reteach(robot: RobotDescription, rods: ArrayLike, joints: ArrayLike, arm: str | None = None,
            names: Sequence[str] | None = None) -> Retaught:
    """New joints for old joints ``(N, 3)``, ``(N, n)`` that the naive model computed (module docstring).

    Raises:
        LimitError: an old rod outside the stroke (the old tool's rods were executed: they lie within it; a tilt
            or an arm joint just beyond its limit is accepted, not a held joint's, which the new posture keeps), or
            an intended station the real robot cannot reach.
        InputError: an old joint more than a turn beyond its limits (:data:`OLD_JOINT_SLACK`: degrees, not radians).
    """
    a = robot.arm(arm)
    Q = rows_of(rods, 'rods', 3, robot.rods.names)
    check_rods(robot, Q)   # once: robot_forward below checks no limit, _old_tilt the tilt alone
    theta = rows_of(joints, f'joints of {a.name}', len(a.joints), a.joint_names)
    beyond = (theta < a.lower - OLD_JOINT_SLACK) | (theta > a.upper + OLD_JOINT_SLACK)
    if beyond.any():   # the first such value, by row then joint
        i, k = (int(x) for x in np.argwhere(beyond)[0])
        row_of = f' (row {i + 1})' if theta.shape[0] > 1 else ''
        raise InputError(f'old joints{row_of}: {_beyond_a_turn(a, float(theta[i, k]), k)}; in degrees? give them in '
                         'radians (or --deg to gpr robot teach)')
    try:   # the naive wafer is computed on first use
        old = robot_forward(robot, Q, theta, a.name, check_limits=False)
        intended = stations_from_poses(old.naive_wafer.position, old.naive_wafer.rotation, names)
    except LimitError:   # rods with no platform pose (the naive model's): named by their row, as beyond the tilt
        _old_tilt(robot, Q, names)
        raise
    if len(a.joints) == 2:  # the heading of a 2-joint arm is an outcome
        intended = Stations(intended.position, intended.tilt, intended.azimuth, np.zeros(len(intended)),
                            np.ones(len(intended), dtype=bool), intended.names)
    value = None
    if a.redundancy is not None and a.redundancy.rule == 'fixed_joint':
        value = old.joints[:, a.redundancy.joint]
        _held_within(a, value, names)
    try:
        solution = solve_stations(robot, intended, a.name, branch=branch_of(a, old.joints), redundancy_value=value)
    except LimitError:   # old rods tilting the platform far beyond its limit are named, not their station's tilt
        _old_tilt(robot, Q, names)   # (with the hint of degrees given as radians, which the user typed in metres)
        raise
    return Retaught(old=old, intended=intended, solution=_near_the_old(a, solution, old.joints))


def _near_the_old(a: Arm, solution: StationSolution, old: Array) -> StationSolution:
    """``solution`` with each joint whose range exceeds a turn at the value nearest its ``old`` one [rad] where that
    lies within its limits, a whole number of turns from the inverse kinematics' (which takes the one nearest the
    range's middle): a shoulder of [-3.6, 3.6] rad at 200 deg was re-taught at -160 deg, a turn the other way round
    for a correction of 165 um (its cables, its path)."""
    wide = [k for k, j in enumerate(a.joints) if j.upper - j.lower > 2.0 * math.pi]
    if not wide:
        return solution
    joints = solution.joints.copy()
    for k in wide:
        near = representative(joints[:, k], old[:, k])
        within = (near >= a.joints[k].lower - LIMIT_SLACK) & (near <= a.joints[k].upper + LIMIT_SLACK)
        joints[:, k] = np.where(within, near, joints[:, k])
    return replace(solution, joints=joints, forward=replace(solution.forward, joints=joints))


def _held_within(a: Arm, value: Array, names: Sequence[str] | None) -> None:
    """Refuse an old held joint's value ``(N,)`` [rad] beyond its limits (re-teach holds it: the new posture keeps
    it), naming the row from 1 and its station as :func:`_old_tilt` does (it was named a ``redundancy value``, which
    the user had not given)."""
    assert a.redundancy is not None
    joint = a.joints[a.redundancy.joint]
    for i, v in enumerate(value.tolist()):
        name = f' (station {brief(names[i])})' if names is not None else ''
        row = f' of row {i + 1}{name}' if value.shape[0] > 1 or names is not None else ''
        refusal = held_refusal(joint, v, f'old joints{row}: the held joint {joint.name} = {{}}')
        if refusal:
            raise LimitError(f'{refusal} (re-teach keeps the held joint\'s old value)')


def _old_tilt(robot: RobotDescription, Q: Array, names: Sequence[str] | None) -> None:
    """Refuse old rods ``(N, 3)`` [m] that tilt the platform beyond its limit, as :func:`robot_forward` does, naming
    the first such row from 1 and its station (it said ``(sample 1)`` of row 2)."""
    try:
        forward_batch(Q, robot.config, stroke=False)   # reteach checked the stroke
    except LimitError:
        for i in range(Q.shape[0]):
            try:
                forward(Q[i], robot.config, stroke=False)
            except LimitError as exc:
                name = f' (station {brief(names[i])})' if names is not None else ''
                row = f' of row {i + 1}{name}' if Q.shape[0] > 1 or names is not None else ''
                raise LimitError(f'old rods{row}: {exc}') from None
        raise


def _row_where(table: CsvTable, r: int) -> str:
    """``FILE: line L (row R, station 'NAME')``: a row of a joint table, counted from 1."""
    name = table.text(r, 'name')
    return f'{table.row_where(r)} (row {r + 1}' + (f', station {brief(name)})' if name else ')')


def _check_row(table: CsvTable, r: int, robot: RobotDescription, a: Arm, rods: Array, joints: Array,
               check_limits: bool) -> None:
    """Refuse a row's rod outside the stroke or (``check_limits``) joint beyond its limits, naming the file, the line
    and the row's name, before the batch would name it by a 0-based sample alone."""
    cfg = robot.config
    where = _row_where(table, r)

    def unit_hint(_i: int, k: int) -> str:   # of the rod the core's check refuses, as degrees below
        rod = robot.rods.names[k]
        return (f'; in millimetres it would be within: give the column its unit, "{rod} [mm]", or a "# units: mm" '
                'line before the header' if table.columns[rod][2] == 'm' and millimetres_within(float(rods[k]), cfg)
                else '')
    try:   # the core's check of the stroke, the robot's rod names, once (read_joint_table's solve skips it)
        check_stroke(SCALAR, rods.tolist(), cfg, detail=unit_hint, names=robot.rods.names)
    except LimitError as exc:
        raise ConfigError(f'{where}: {exc}') from None
    if not check_limits:   # the old joints of reteach: within a turn of their limits
        for k, j in enumerate(a.joints):
            why = _beyond_a_turn(a, joints[k], k)
            if why is not None:
                hint = (f'; in degrees? give the column its unit, "{j.name} [deg]", or a "# units: deg" line before '
                        'the header' if table.columns[j.name][2] == 'rad' else '')
                raise ConfigError(f'{where}: {why}{hint}')
        return
    for k, j in enumerate(a.joints):
        value = joints[k]
        if j.lower - LIMIT_SLACK <= value <= j.upper + LIMIT_SLACK:
            continue
        side, limit = ('lower', j.lower) if value < j.lower else ('upper', j.upper)
        hint = ''
        if table.columns[j.name][2] == 'rad' and j.lower <= math.radians(value) <= j.upper:
            hint = (f'; in degrees it would be within: give the column its unit, "{j.name} [deg]", or a '
                    '"# units: deg" line before the header')
        shown, end = apart(value, limit, 9)
        raise ConfigError(f'{where}: {j.name} = {shown} rad is beyond its {side} limit {end} rad by '
                          f'{abs(value - limit):.3g} rad; allowed: [{j.lower:g}, {j.upper:g}] rad{hint}')


def _read_table(path: str | Path, robot: RobotDescription, a: Arm) -> CsvTable:
    """The joint table of arm ``a`` at ``path``, its header's columns checked; a header naming another arm's joints
    says which arm to give."""
    kinds = {'name': 'text', **{r: 'length' for r in robot.rods.names}, **{j: 'angle' for j in a.joint_names}}
    text = read_text(path, 'joint table', MAX_BYTES)
    try:
        return read_csv_table(text, str(path), kinds, robot.rods.names + a.joint_names)
    except ConfigError as exc:
        other = _other_arm(robot, a, text)
        if other is None:
            raise
        raise ConfigError(f"{exc} (the header names arm {other}'s joints: give that arm, --arm {other})") from None


def _other_arm(robot: RobotDescription, a: Arm, text: str) -> str | None:
    """The robot's other arm whose joints the header of a joint table ``text`` names (its first line that is not a
    comment; a column's unit in brackets left out), or None."""
    header = next((line for line in text.splitlines() if line.strip() and not line.lstrip().startswith('#')), '')
    columns = {c.split('[')[0].strip() for c in next(csv.reader([header]), [])}   # quoted names too
    return next((b.name for b in robot.arms if b is not a and columns & set(b.joint_names)), None)


def read_joint_table(path: str | Path, robot: RobotDescription, arm: str | None = None,
                     check_limits: bool = True) -> tuple[tuple[str, ...], Array, Array]:
    """Joints from a CSV file: a header naming the rods and the arm's joints (units in brackets: ``[m]``/``[mm]``
    for rods, ``[rad]``/``[deg]`` for joints; SI when none) and an optional ``name`` column; returns
    ``(names, rods (N, 3), joints (N, n))``. ConfigError names the file, the line, the row's name (when the table
    has a name column: 1 to 64 letters, digits, ``_ . -``, not ``-`` first, as in station files) and the field: a
    value that is not a number, a rod outside the stroke and, with ``check_limits`` (:func:`teach`; not the old joints
    of :func:`reteach`), a joint beyond its limits, with a hint when the value read as degrees would lie within them
    (a column without a unit is in radians)."""
    a = robot.arm(arm)
    table = _read_table(path, robot, a)
    rods = np.empty((len(table), 3))
    joints = np.empty((len(table), len(a.joints)))
    names: list[str] = []
    first: dict[str, int] = {}
    for r in range(len(table)):
        given = table.text(r, 'name')  # a name is printed and written: the station files' rule, not any text
        names.append(station_name(given, table.row_where(r)) if given else str(r))
        if first.setdefault(names[-1], r) != r:  # two stations of one name: the taught table would be ambiguous
            raise ConfigError(f'{table.row_where(r)}: name {brief(names[-1])} is also the name of line '
                              f'{table.lines[first[names[-1]]]}; allowed: each name once')
        for k, rod in enumerate(robot.rods.names):
            rods[r, k] = table.number(r, rod, math.nan)
        for k, joint in enumerate(a.joint_names):
            joints[r, k] = table.number(r, joint, math.nan)
        if np.isnan(rods[r]).any() or np.isnan(joints[r]).any():
            raise ConfigError(f'{table.row_where(r)}: every rod and joint needs a value')
        _check_row(table, r, robot, a, rods[r], joints[r], check_limits)
    try:   # the tilt limit, as forward kinematics refuses the rods (it named no row; reteach's old rods: unchecked)
        if check_limits:
            forward_batch(rods, robot.config, stroke=False)   # the rows' stroke: checked above
    except LimitError:
        for r in range(len(table)):   # the first refused row, named (only when one is)
            try:
                forward(rods[r], robot.config, stroke=False)
            except LimitError as exc:
                raise ConfigError(f'{_row_where(table, r)}: {exc}') from None
        raise
    return tuple(names), rods, joints

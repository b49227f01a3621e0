"""Calibration of the arms on the platform: link lengths, joint zero offsets and the blade's wafer centre.

A tracker measures a target on the blade (the wafer centre of a fixture wafer, or a known point of the blade) at
several arm configurations and platform poses. :class:`ArmModel` is a pose model (:mod:`.model`) of that point:
the platform's pose from the robot's GPR (its geometry file, a calibrated one when there is one: not fitted
here), the arm's chain (:func:`gpr_kinematics.robot.forward.blade_chain`, the one the robot core uses) with
the parameters of each row of ``theta``:

* ``<joint>_length`` [m]: the link after each joint (the last: to the flange), a-priori 0.1 mm;
* ``<joint>_zero_offset`` [rad]: the joint turns by its value plus this (:class:`~gpr_kinematics.robot.description.
  ArmJoint`), a-priori 1 mrad;
* ``<arm>_wafer_x``, ``_y``, ``_z`` [m]: the wafer centre in the blade frame, a-priori 1 mm;
* ``<arm>_mount_x``, ``_y`` [m]: the first joint's axis on the platform, a-priori 0.1 mm (the platform frame of a
  calibration with an identified target is the joints' datum: the arm's mount is measured in it).

The measured point of a row is the wafer centre, or, for a row that gives ``bx by bz``, that point of the blade
(in the blade frame). From wafer centres alone the last link, the last zero offset and the wafer centre are one
planar vector: the identifiability analysis holds what they cannot separate and says so; rows of a blade target
separate them. :func:`identify` fits them (the same engine, report and gate as the GPR's), and
:func:`calibrated_robot` writes them into a robot description every command takes with ``--robot``.

Measurement files (CSV, the rules of :mod:`.measurements`): ``q1 q2 q3`` (rods), one column per joint of one arm
named as the joint (``arm1_shoulder``, ...; rad, or deg with ``# units: deg``), ``x y z`` (the measured point),
optional ``sigma_position`` and ``bx by bz``.
"""
from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..core import forward_batch
from ..core.geometry_covariance import KEY
from ..errors import InputError, apart
from ..inputs import safe_yaml
from ..robot.arm_chain import LIMIT_SLACK
from ..robot.description import LENGTH_BOUND, Arm, RobotDescription
from ..robot.fields import LEAST
from ..robot.forward import blade_chain
from .core_model import check_limits
from .files import comment_lines, read_text, write_text
from .measurements import MAX_FILE_BYTES, REQUIRED_COLUMNS, Columns, Measurements, read_table
from .model import Parameter, ParameterSet

Array = NDArray[np.float64]

#: A-priori standard uncertainty per kind of arm parameter (the key of :class:`~.model.Parameter`).
ARM_SCALES = {'length': 1e-4, 'zero_offset': 1e-3, 'wafer_centre': 1e-3, 'mount': 1e-4}
BLADE_COLUMNS = ('bx', 'by', 'bz')


@dataclass(frozen=True)
class ArmMeasurements:
    """Measured points of one arm: the rows (rods, points, sigmas, lines: :class:`~.measurements.Measurements`
    without orientations), the arm's joint values ``(N, n)`` [rad], and the blade point each row measures
    (``blade (N, 3)`` in the blade frame [m], where ``on_blade``; else the wafer centre)."""

    points: Measurements
    arm: str
    joints: Array
    blade: Array
    on_blade: NDArray[np.bool_]


def arm_parameters(arm: Arm) -> ParameterSet:
    """The parameters of ``arm`` (module docstring) at its description's values."""
    out = []
    last = len(arm.joints) - 1
    for k, j in enumerate(arm.joints):
        limits = (0.0 if k == last else LEAST, LENGTH_BOUND)   # the robot description's rule (a file it reads back)
        out += [Parameter(f'{j.name}_length', j.length, 'm', ARM_SCALES['length'], 'length', (k,), limits=limits),
                Parameter(f'{j.name}_zero_offset', j.zero_offset, 'rad', ARM_SCALES['zero_offset'], 'zero_offset',
                          (k,))]
    out += [Parameter(f'{arm.name}_wafer_{c}', arm.blade.wafer_centre[i], 'm', ARM_SCALES['wafer_centre'],
                      'wafer_centre', (i,)) for i, c in enumerate('xyz')]
    out += [Parameter(f'{arm.name}_mount_{c}', arm.mount_position[i], 'm', ARM_SCALES['mount'], 'mount', (i,))
            for i, c in enumerate('xy')]
    return ParameterSet(tuple(out))


def arm_with(arm: Arm, values: Array) -> Arm:
    """``arm`` with the parameter values ``values (P,)`` of :func:`arm_parameters`."""
    n = len(arm.joints)
    joints = tuple(dataclasses.replace(j, length=float(values[2 * k]), zero_offset=float(values[2 * k + 1]))
                   for k, j in enumerate(arm.joints))
    blade = dataclasses.replace(arm.blade, wafer_centre=(float(values[2 * n]), float(values[2 * n + 1]),
                                                         float(values[2 * n + 2])))
    mount = (float(values[2 * n + 3]), float(values[2 * n + 4]), arm.mount_position[2])
    return dataclasses.replace(arm, joints=joints, blade=blade, mount_position=mount)


class ArmModel:
    """Positions (and blade orientations) in ``gpr_base`` of the measured points of ``meas`` (module docstring):
    a pose model whose rows are those of the measurements (its ``Q`` must be their rods)."""

    supports_displacement = False

    def __init__(self, robot: RobotDescription, meas: ArmMeasurements) -> None:
        self.robot, self.meas = robot, meas
        self.arm = robot.arm(meas.arm)
        self._parameters = arm_parameters(self.arm)
        self._platform: tuple[Array, Array, Array] | None = None

    @property
    def parameters(self) -> ParameterSet:
        return self._parameters

    def platform(self, Q: Array) -> tuple[Array, Array]:
        """The platform's poses ``(N, 3)``, ``(N, 3, 3)`` at rods ``Q (N, 3)`` (the robot's GPR; cached)."""
        if self._platform is None or not np.array_equal(self._platform[0], Q):
            fk = forward_batch(Q, self.robot.config, check_limits=False)
            self._platform = (Q.copy(), fk.position, fk.rotation)
        return self._platform[1], self._platform[2]

    def poses(self, theta: Array, Q: Array, displacement: Array | None = None) -> tuple[Array, Array]:
        N = Q.shape[1]
        if self.meas.joints.shape[0] != N or not np.all(Q[:1] == Q):
            raise InputError(f'{type(self).__name__} poses: the rods must be those of its {self.meas.joints.shape[0]} '
                             'measured rows')
        p0, R0 = self.platform(Q[0])
        return self.on_platform(theta, p0, R0)

    def on_platform(self, theta: Array, position: Array, rotation: Array) -> tuple[Array, Array]:
        """The measured points ``(S, N, 3)`` and blade rotations ``(S, N, 3, 3)`` in ``gpr_base`` at coordinates
        ``theta (S, P)`` on the platform poses ``position (N, 3)``, ``rotation (N, 3, 3)`` (or one set per row of
        ``theta``: ``(S, N, 3)``, ``(S, N, 3, 3)``): ``p = p0 + R0 x``, ``x`` the blade's point or wafer centre by
        :func:`~gpr_kinematics.robot.forward.blade_chain`, every row of ``theta`` at once."""
        S, N, n = theta.shape[0], self.meas.joints.shape[0], len(self.arm.joints)
        p0, R0 = np.broadcast_to(position, (S, N, 3)), np.broadcast_to(rotation, (S, N, 3, 3))
        v = self._parameters.values(theta)[:, None, :]   # arm_parameters' order: (length, offset) per joint, ...
        blade, R = blade_chain(self.arm, self.meas.joints, v[..., 0:2 * n:2], v[..., 1:2 * n:2],
                               v[..., 2 * n + 3:2 * n + 5])
        local = np.where(self.meas.on_blade[:, None], self.meas.blade, v[..., 2 * n:2 * n + 3])   # else the wafer
        point = blade + np.einsum('snij,snj->sni', R, local)
        return p0 + np.einsum('snij,snj->sni', R0, point), R0 @ R

    def swapped_columns(self) -> list[tuple[str, ArmModel]]:
        """This model with two joint columns of one of its files swapped, for each pair of joints and each file (a
        header that names the joints in another order; the other files are read as they are):
        :func:`~.plausibility.other_reading`'s readings."""
        pts, names = self.meas.points, self.arm.joint_names
        files = np.array(pts.files or (pts.source,) * len(pts))
        out = []
        for f in dict.fromkeys(files.tolist()):
            for a, b in itertools.combinations(range(len(names)), 2):
                J = self.meas.joints.copy()
                J[np.ix_(files == f, [a, b])] = J[np.ix_(files == f, [b, a])]
                out.append((f'the points fit this machine with columns {names[a]} and {names[b]} of {f} swapped',
                            ArmModel(self.robot, dataclasses.replace(self.meas, joints=J))))
        return out


def _arm_of(robot: RobotDescription, cols: Sequence[str], source: str) -> Arm:
    """The one arm all of whose joints, and only those, name columns."""
    present = [a for a in robot.arms if any(j.name.lower() in cols for j in a.joints)]
    if len(present) != 1 or not all(j.name.lower() in cols for j in present[0].joints):
        raise InputError(f'{source}: {_joint_columns(robot)}')
    return present[0]


def _joint_columns(robot: RobotDescription) -> str:
    """The joint columns a file of one arm of ``robot`` must have, as its refusals name them."""
    wanted = '; '.join(f'{a.name}: {", ".join(a.joint_names)}' for a in robot.arms)
    return f'the joint columns must be those of one arm of {robot.name} ({wanted})'


def read_arm_measurements(path: str | Path, robot: RobotDescription) -> ArmMeasurements:
    """Read a file of measured points of one arm of ``robot`` (module docstring), checked: columns, numbers,
    units, rods within the stroke and the tilt limit, joints within their limits."""
    joints = tuple(j.name.lower() for a in robot.arms for j in a.joints)
    lengths = frozenset(REQUIRED_COLUMNS + ('sigma_position',) + BLADE_COLUMNS)
    spec = Columns(REQUIRED_COLUMNS, (BLADE_COLUMNS,), joints + ('sigma_position',), lengths, frozenset(joints),
                   also=f'; {_joint_columns(robot)}')   # an empty file named only the GPR's
    source = str(path)
    table = read_table(read_text(path, 'measurement', MAX_FILE_BYTES), source, spec)
    col = table.columns
    arm = _arm_of(robot, list(col), source)
    J = np.column_stack([col[j.name.lower()] for j in arm.joints])
    lo, hi = arm.lower - LIMIT_SLACK, arm.upper + LIMIT_SLACK
    bad = np.argwhere((lo > J) | (hi < J))
    if bad.size:
        i, k = bad[0]
        j = arm.joints[k]
        hint = f' (degrees? declare "# units: deg" or write "{j.name} [deg]")' if table.scales[j.name.lower()] == 1.0 \
            else ''
        low = J[i, k] < lo[k]
        shown, end = apart(float(J[i, k]), j.lower if low else j.upper, 9)
        ends = f'[{end}, {j.upper:g}]' if low else f'[{j.lower:g}, {end}]'
        raise InputError(f'{source} line {table.lines[i]}, column {j.name}: {shown} rad is outside its limits {ends} '
                         f'rad{hint}')
    n = J.shape[0]
    points = Measurements(source, np.column_stack([col['q1'], col['q2'], col['q3']]),
                          np.column_stack([col['x'], col['y'], col['z']]), None,
                          table.sigma('sigma_position', source), None, tuple(table.lines), table.units)
    check_limits(points, robot.config)
    on_blade = np.full(n, 'bx' in col)
    blade = np.column_stack([col[c] for c in BLADE_COLUMNS]) if 'bx' in col else np.zeros((n, 3))
    return ArmMeasurements(points, arm.name, J, blade, on_blade)


def merge(parts: Sequence[ArmMeasurements]) -> ArmMeasurements:
    """The rows of several files of one arm as one set (sources joined, each row's line and file kept: two files
    may both have a line 40)."""
    if len({p.arm for p in parts}) != 1:
        raise InputError('merge: the files are of different arms')
    pts = [p.points for p in parts]
    sig = None if any(p.sigma_position is None for p in pts) else np.concatenate([p.sigma_position for p in pts
                                                                                  if p.sigma_position is not None])
    files = tuple(f for p in pts for f in (p.files or (p.source,) * len(p))) if len(pts) > 1 else pts[0].files
    joined = Measurements(' + '.join(p.source for p in pts), np.vstack([p.q for p in pts]),
                          np.vstack([p.position for p in pts]), None, sig, None,
                          tuple(x for p in pts for x in p.lines), pts[0].units, files)
    return ArmMeasurements(joined, parts[0].arm, np.vstack([p.joints for p in parts]),
                           np.vstack([p.blade for p in parts]), np.concatenate([p.on_blade for p in parts]))


def calibrated_robot(robot: RobotDescription, arms: dict[str, Array]) -> RobotDescription:
    """``robot`` with the identified parameter values (:func:`arm_parameters` order) of the arms named in
    ``arms``."""
    return dataclasses.replace(robot, arms=tuple(arm_with(a, arms[a.name]) if a.name in arms else a
                                                 for a in robot.arms))


def write_robot(path: str | Path, robot: RobotDescription, comments: Sequence[str] = ()) -> Path:
    """Write ``robot`` as a robot description file (its GPR geometry inline, with the covariance of its calibrated
    parameters where it has one: :mod:`~gpr_kinematics.robot.gpr_section`), atomically."""
    data = robot.to_dict()
    if robot.gpr_covariance is not None:
        data['gpr'][KEY] = robot.gpr_covariance.as_block()
    text = comment_lines(list(comments)) + safe_yaml.dump(data, sort_keys=False, default_flow_style=None)
    return write_text(path, text, 'calibrated robot')


def write_arm_measurements(path: str | Path, robot: RobotDescription, meas: ArmMeasurements,
                           comments: Sequence[str] = ()) -> Path:
    """Write ``meas`` as a file of measured points of its arm (module docstring; SI, full precision): the blade
    columns when its rows measure blade points (all of them, or none: a file is of one kind)."""
    arm = robot.arm(meas.arm)
    blade = bool(meas.on_blade.any())
    if blade and not meas.on_blade.all():
        raise InputError('write_arm_measurements: rows of the wafer centre and of the blade go to separate files')
    cols = ['q1', 'q2', 'q3', *arm.joint_names, 'x', 'y', 'z']
    parts = [meas.points.q, meas.joints, meas.points.position]
    if meas.points.sigma_position is not None:
        cols.append('sigma_position')
        parts.append(meas.points.sigma_position[:, None])
    if blade:
        cols += list(BLADE_COLUMNS)
        parts.append(meas.blade)
    rows = [','.join(repr(float(v)) for v in row) for row in np.hstack(parts)]
    return write_text(path, comment_lines(list(comments) + ['units: m rad']) + ','.join(cols) + '\n'
                      + '\n'.join(rows) + '\n', 'arm measurement')

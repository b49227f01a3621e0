"""The robot description: a GPR carrying one or two serial planar arms with a blade and a wafer, from YAML.

Frames (REP 103/105 style, SI units): ``world`` (the process tool) -> ``gpr_base`` (fixed: ``base``) ->
``gpr_platform`` (the GPR's exact pose, from the kinematics) -> ``<arm>_link1`` .. ``<arm>_link<n>`` (one per
revolute joint, origin on the joint's axis, z along the platform normal, x along the link) -> ``<arm>_blade``
-> ``<arm>_wafer`` (origin at the wafer centre, axes of the blade). The joint axes are parallel to the platform
normal, so the arm moves the wafer in the platform's plane only.

File format (``config/robots/example_robot.yaml`` is a commented example)::

    name: example_dual_arm
    gpr: {config: null, model: radial}  # geometry file (relative to this file; null: the package's gpr.yaml),
                                        # and keys of that file inline on top of it
    base: {frame: world, position: [0, 0, 0], rpy: [0, 0, 0]}   # gpr_base in the world, URDF rpy [rad]
    rods: {names: [rod1, rod2, rod3], velocity: 0.1, acceleration: 0.5}  # m/s, m/s^2
    arms:
      - name: arm1
        mount: {position: [0, 0, 0.05], yaw: 0}   # first joint axis on gpr_platform [m, rad]
        joints:                                    # 2 to 4 revolute joints, shoulder first
          - {name: arm1_shoulder, length: 0.3, height: 0.03, lower: -3, upper: 3, velocity: 2, acceleration: 8}
          # optional zero_offset [rad]: the joint turns by its value plus this (a calibration's; default 0)
          - ...
        blade: {position: [0, 0, 0.01], yaw: 0, wafer_centre: [0.18, 0, 0.005]}
        branch: right                              # default elbow branch: left or right
        home: [0, 0, 0]                            # joint values a program starts from [rad]
        redundancy: {rule: fixed_joint, joint: arm2_wrist, value: 0}   # 4-joint arms only

A joint's ``length`` is the distance in the platform plane from its axis to the next joint's axis (for the last
joint, to the flange), ``height`` the offset along the normal to the next link. Every value is validated on load;
an error names the file, the key, the value and what is allowed.
"""
from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.config import GprConfig, load_config
from ..core.geometry_covariance import GeometryCovariance
from ..core.rotations import rpy_matrix
from ..errors import ConfigError, brief, kind_of
from ..inputs.resources import config_path
from ..inputs.schema import check_keys, read_yaml
from ..inputs.stacked import Stacked
from ..inputs.validation import WORLD_BOUND
from .collision import ArmBodies, GprBodies, WaferShape, parse_arm_bodies, parse_gpr_bodies, parse_wafer
from .fields import (
    LEAST,
    _angle,
    _mapping,
    _name,
    _named,
    _number,
    _positive_number,
    _rpy,
    _vector,
    _xyz,
    _yaw,
    check_names,
)
from .fields import NAME_RULE as _NAME_RULE
from .gpr_section import GprSection, load_gpr_section

Array = NDArray[np.float64]

BRANCHES = ('left', 'right')
REDUNDANCY_RULES = ('fixed_joint', 'nearest')
#: The shipped example robot, under the package's ``config/``.
DEFAULT_ROBOT = 'robots/example_robot.yaml'

LENGTH_BOUND = 5.0  # m: arm and mount dimensions
#: The GPR's own frames in the robot model (:mod:`.urdf`, the state publisher's defaults), which the world is not.
GPR_FRAMES = ('gpr_base', 'gpr_platform', 'gpr_platform_nominal', *(f'gpr_rod_{k}' for k in (1, 2, 3)),
              *(f'gpr_rod_guide_{k}' for k in (1, 2, 3)))


@dataclass(frozen=True)
class ArmJoint:
    """One revolute joint of a planar arm and the link after it (SI units). ``zero_offset`` [rad]: the joint's
    angle is its value (commanded, limited, published) plus this (a calibration's, ``gpr calibrate --robot``)."""

    name: str
    length: float
    height: float
    lower: float
    upper: float
    velocity: float
    acceleration: float
    zero_offset: float = 0.0
    #: Jerk limit [rad/s^3] (None: unbounded, the moves' velocity profile is then a trapezoid).
    jerk: float | None = None


@dataclass(frozen=True)
class Blade:
    """The end effector: its frame in the flange frame (``position`` [m], ``yaw`` [rad]) and the wafer centre
    in the blade frame [m]."""

    position: tuple[float, float, float]
    yaw: float
    wafer_centre: tuple[float, float, float]


@dataclass(frozen=True)
class Redundancy:
    """How a 4-joint arm picks one posture of its one-parameter self-motion (docs/robot.md).

    ``fixed_joint``: joint ``joint`` (index) is held at ``value`` [rad] (or a value given per station) and the
    other three are solved in closed form. ``nearest``: the posture nearest to ``reference`` [rad] in the
    metric ``sum_i weights_i ((theta_i - reference_i) / (upper_i - lower_i))^2`` over the self-motion of joint
    ``joint``: the best of the edges of its feasible runs and the minima inside them (:mod:`.nearest`).
    """

    rule: str
    joint: int
    value: float = 0.0
    reference: tuple[float, ...] = ()
    weights: tuple[float, ...] = ()


@dataclass(frozen=True)
class Arm:
    """A serial planar arm on the platform: mount, joints (shoulder first), blade, defaults."""

    name: str
    mount_position: tuple[float, float, float]
    mount_yaw: float
    joints: tuple[ArmJoint, ...]
    blade: Blade
    branch: str
    home: tuple[float, ...]
    redundancy: Redundancy | None = None
    #: Collision bodies of the links and blade, and the blade's grip (robot.collision).
    bodies: ArmBodies = ArmBodies()

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    #: The joints' limits, shoulder first ``(n,)`` [rad, rad/s, rad/s^2].
    lower = Stacked('joints')
    upper = Stacked('joints')
    velocity = Stacked('joints')
    acceleration = Stacked('joints')
    zero_offset = Stacked('joints')

    @property
    def jerk(self) -> Array:
        """The joints' jerk limits ``(n,)`` [rad/s^3], ``inf`` where none is given."""
        return np.array([math.inf if j.jerk is None else j.jerk for j in self.joints])

    @property
    def wafer_height(self) -> float:
        """Height of the wafer centre above the platform plane, along its normal [m]: the mount, every link,
        the blade and the wafer offset. The arm cannot change it."""
        return (self.mount_position[2] + sum(j.height for j in self.joints) + self.blade.position[2]
                + self.blade.wafer_centre[2])

    @property
    def link_frames(self) -> tuple[str, ...]:
        return tuple(f'{self.name}_link{k + 1}' for k in range(len(self.joints)))

    @property
    def blade_frame(self) -> str:
        return f'{self.name}_blade'

    @property
    def wafer_frame(self) -> str:
        return f'{self.name}_wafer'


@dataclass(frozen=True)
class Rods:
    """The GPR's actuated rods as joints: names and velocity/acceleration limits (m/s, m/s^2)."""

    names: tuple[str, str, str]
    velocity: float
    acceleration: float
    jerk: float | None = None


@dataclass(frozen=True)
class RobotDescription:
    """A whole robot: the GPR (geometry and virtual-joint model), its base in the world, rods, arms."""

    name: str
    config: GprConfig
    world_frame: str
    base_position: tuple[float, float, float]
    base_rpy: tuple[float, float, float]
    rods: Rods
    arms: tuple[Arm, ...]
    source: str = 'robot'
    #: The GPR's collision bodies and the wafer's disc (robot.collision).
    bodies: GprBodies = GprBodies()
    wafer: WaferShape = WaferShape()
    #: Its ``gpr`` section as read (:mod:`.gpr_section`: the covariance of the GPR's calibrated parameters).
    gpr: GprSection = field(default=GprSection(), compare=False, repr=False)

    @property
    def gpr_covariance(self) -> GeometryCovariance | None:
        """The covariance of the GPR's calibrated parameters (None: the GPR taken as exact)."""
        return self.gpr.covariance

    @property
    def base_rotation(self) -> Array:
        """Orientation of ``gpr_base`` in the world."""
        return rpy_matrix(*self.base_rpy)

    @property
    def arm_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.arms)

    def to_dict(self) -> dict[str, Any]:
        """The description as a mapping in the file format (SI units, the GPR geometry inline under ``gpr``) that
        :func:`parse_robot` reads back into an equal description: what a recording stores to name its robot.

        >>> robot = load_robot()
        >>> parse_robot(robot.to_dict(), robot.source) == robot
        True
        """
        return {'name': self.name, 'gpr': {'config': None, **self.config.to_dict()},
                'base': {'frame': self.world_frame, 'position': list(self.base_position), 'rpy': list(self.base_rpy)},
                'rods': {'names': list(self.rods.names), 'velocity': self.rods.velocity,
                         'acceleration': self.rods.acceleration, 'jerk': self.rods.jerk},
                'arms': [_arm_dict(a) for a in self.arms],
                'collision': {'column': {'radius': self.bodies.column_radius, 'height': self.bodies.column_height},
                              'platform': {'radius': self.bodies.platform_radius,
                                           'thickness': self.bodies.platform_thickness}},
                'wafer': dataclasses.asdict(self.wafer)}

    def arm(self, name: str | None = None) -> Arm:
        """The arm called ``name`` (the first arm when ``None``); ConfigError names the arms there are."""
        if name is None:
            return self.arms[0]
        for a in self.arms:
            if isinstance(name, str) and a.name == name:   # an array compared elementwise
                return a
        raise ConfigError(f'{self.source}: no arm {brief(name)}; allowed: {", ".join(self.arm_names)}')


def _arm_dict(arm: Arm) -> dict[str, Any]:
    """An arm in the file format (:meth:`RobotDescription.to_dict`)."""
    out: dict[str, Any] = {
        'name': arm.name, 'mount': {'position': list(arm.mount_position), 'yaw': arm.mount_yaw},
        'joints': [{k: v for k, v in dataclasses.asdict(j).items() if k != 'zero_offset' or v} for j in arm.joints],
        'blade': {'position': list(arm.blade.position), 'yaw': arm.blade.yaw,
                  'wafer_centre': list(arm.blade.wafer_centre), 'paddle': list(arm.bodies.paddle),
                  'friction': arm.bodies.friction, 'vacuum': arm.bodies.vacuum},
        'links': {'width': arm.bodies.width, 'thickness': arm.bodies.thickness},
        'branch': arm.branch, 'home': list(arm.home)}
    r = arm.redundancy
    if r is not None:
        joint = arm.joints[r.joint].name
        out['redundancy'] = ({'rule': r.rule, 'joint': joint, 'value': r.value} if r.rule == 'fixed_joint' else
                             {'rule': r.rule, 'joint': joint, 'reference': list(r.reference),
                              'weights': list(r.weights)})
    return out


def _joint(raw: Any, where: str) -> ArmJoint:
    data = _mapping(raw, where, 'a joint: name, length, height, lower, upper, velocity, acceleration')
    check_keys(data, ('name', 'length', 'height', 'lower', 'upper', 'velocity', 'acceleration', 'zero_offset',
                      'jerk'), _named(data, where))
    name = _name(data, 'name', where)
    where = f'{where} ({name})'
    lower = _angle(data, 'lower', where)
    upper = _angle(data, 'upper', where)
    if not lower < upper:
        raise ConfigError(f'{where}: lower = {lower!r} must be below upper = {upper!r} (radians)')
    return ArmJoint(
        name=name,
        length=_number(data, 'length', where, 0.0, LENGTH_BOUND, f'metres, 0 <= length <= {LENGTH_BOUND:g} (at least '
                       f'{LEAST:g} but on the last joint)'),
        height=_number(data, 'height', where, -1.0, 1.0, 'metres, -1 <= height <= 1', default=0.0),
        lower=lower, upper=upper,
        velocity=_positive_number(data, 'velocity', where, 100.0, 'rad/s', 'rad/s'),
        acceleration=_positive_number(data, 'acceleration', where, 1000.0, 'rad/s^2', 'rad/s^2'),
        zero_offset=_number(data, 'zero_offset', where, -0.1, 0.1, 'radians within [-0.1, 0.1]', 0.0, 'rad'),
        jerk=_jerk(data, where, 'rad/s^3', 1e5))


def _jerk(data: Mapping[str, Any], where: str, unit: str, hi: float) -> float | None:
    if data.get('jerk') is None:
        return None
    return _positive_number(data, 'jerk', where, hi, unit, unit, note=', or null (unbounded)')


def _redundancy(raw: Any, joints: tuple[ArmJoint, ...], where: str) -> Redundancy:
    data = _mapping(raw, where, 'rule, joint and value, reference or weights')
    check_keys(data, ('rule', 'joint', 'value', 'reference', 'weights'), where)
    rule = data.get('rule')
    if rule not in REDUNDANCY_RULES:
        raise ConfigError(f'{where}: rule = {brief(rule)} is invalid; allowed: {" or ".join(REDUNDANCY_RULES)}')
    names = [j.name for j in joints]
    joint = data.get('joint', names[0] if rule == 'nearest' else None)
    if joint not in names:
        raise ConfigError(f'{where}: joint = {brief(joint)} is invalid; allowed: one of {", ".join(names)}')
    k = names.index(joint)
    if rule == 'fixed_joint':
        check_keys(data, ('rule', 'joint', 'value'), f'{where} (rule fixed_joint)')
        value = _angle(data, 'value', where, default=0.0)
        if not joints[k].lower <= value <= joints[k].upper:
            raise ConfigError(f'{where}: value = {value!r} is invalid; allowed: within the limits of {joint}, '
                              f'[{joints[k].lower:g}, {joints[k].upper:g}] rad')
        return Redundancy(rule, k, value=value)
    check_keys(data, ('rule', 'joint', 'reference', 'weights'), f'{where} (rule nearest)')
    mid = [0.5 * (j.lower + j.upper) for j in joints]
    reference = _vector(data, 'reference', where, len(joints), 2 * math.pi, 'rad', default=mid)
    for i, (r, j) in enumerate(zip(reference, joints, strict=True)):
        if not j.lower <= r <= j.upper:   # 5 rad on a joint of [-2.2, 2.2]: the cost measured it as 3.5 rad from -1.28
            turned = math.remainder(r - 0.5 * (j.lower + j.upper), 2 * math.pi) + 0.5 * (j.lower + j.upper)
            hint = f' ({r:g} rad is {turned:.6g} rad modulo a turn)' if j.lower <= turned <= j.upper else ''
            raise ConfigError(f'{where}: reference[{i}] = {r:g} rad is outside the limits of {j.name}, '
                              f'[{j.lower:g}, {j.upper:g}] rad; allowed: a posture within the joints\' limits{hint}')
    weights = _vector(data, 'weights', where, len(joints), 1e6, '(no unit)', default=[1.0] * len(joints), lowest=0.0)
    if max(weights) <= 0.0:
        raise ConfigError(f'{where}: weights = {brief(list(weights))} is invalid; allowed: numbers >= 0, not all 0')
    return Redundancy(rule, k, reference=reference, weights=weights)


def _arm(raw: Any, where: str) -> Arm:
    data = _mapping(raw, where, 'an arm: name, mount, joints, blade, branch, home, redundancy')
    check_keys(data, ('name', 'mount', 'joints', 'blade', 'branch', 'home', 'redundancy', 'links'), _named(data, where))
    name = _name(data, 'name', where)
    where = f'{where} ({name})'
    mount = _mapping(data.get('mount', {}), f'{where}: mount', 'position and yaw of the first joint axis')
    check_keys(mount, ('position', 'yaw'), f'{where}: mount')
    raw_joints = data.get('joints')
    if not isinstance(raw_joints, (list, tuple)) or not 2 <= len(raw_joints) <= 4:
        raise ConfigError(f'{where}: joints must be a list of 2 to 4 revolute joints (shoulder first), got '
                          f'{len(raw_joints) if isinstance(raw_joints, (list, tuple)) else kind_of(raw_joints)}')
    joints = tuple(_joint(j, f'{where}: joints[{i}]') for i, j in enumerate(raw_joints))
    for j in joints[:-1]:
        if j.length < LEAST:   # 5e-324 passed: 1 / (2 L1 L2) overflowed in the arm's inverse kinematics
            raise ConfigError(f'{where}: {j.name}: length = {j.length!r} is invalid; allowed: >= {LEAST:g} m '
                              'for every joint but the last (a zero-length link makes two joints coaxial)')
    bwhere = f'{where}: blade'
    blade_data = _mapping(data.get('blade'), bwhere, 'position, yaw, wafer_centre')
    check_keys(blade_data, ('position', 'yaw', 'wafer_centre', 'paddle', 'friction', 'vacuum'), bwhere)
    blade = Blade(position=_xyz(blade_data, 'position', bwhere, LENGTH_BOUND, default=(0.0, 0.0, 0.0)),
                  yaw=_yaw(blade_data, bwhere),
                  wafer_centre=_xyz(blade_data, 'wafer_centre', bwhere, LENGTH_BOUND))
    branch = data.get('branch', 'right')
    if branch not in BRANCHES:
        raise ConfigError(f'{where}: branch = {brief(branch)} is invalid; allowed: left or right')
    home_default = [min(max(0.0, j.lower), j.upper) for j in joints]
    home = _vector(data, 'home', where, len(joints), 2 * math.pi, 'rad', default=home_default)
    for j, v in zip(joints, home, strict=True):
        if not j.lower <= v <= j.upper:
            raise ConfigError(f'{where}: home: {j.name} = {v!r} is invalid; allowed: within [{j.lower:g}, '
                              f'{j.upper:g}] rad')
    redundancy = None
    if len(joints) == 4:
        if 'redundancy' not in data:
            raise ConfigError(f'{where}: a 4-joint arm needs redundancy: {{rule: fixed_joint, joint: NAME, value: '
                              'RAD} or {rule: nearest, joint: NAME, reference: [...], weights: [...]}')
        redundancy = _redundancy(data['redundancy'], joints, f'{where}: redundancy')
    elif 'redundancy' in data:
        raise ConfigError(f'{where}: redundancy applies to 4-joint arms only; this arm has {len(joints)} joints')
    arm = Arm(name=name, mount_position=_xyz(mount, 'position', f'{where}: mount', LENGTH_BOUND,
                                              default=(0.0, 0.0, 0.0)),
              mount_yaw=_yaw(mount, f'{where}: mount'), joints=joints, blade=blade,
              branch=branch, home=home, redundancy=redundancy,
              bodies=parse_arm_bodies(data.get('links'), blade_data, where))
    if len(joints) == 2 and joints[1].length + blade.position[0] == 0.0 and blade.position[1] == 0.0 \
            and blade.wafer_centre[0] == 0.0 and blade.wafer_centre[1] == 0.0:
        raise ConfigError(f'{where}: the wafer centre lies on the last joint axis: a 2-joint arm cannot then reach '
                          'an area; allowed: a blade or last link that moves the wafer off that axis')
    return arm


def parse_robot(data: Any, source: str = 'robot', base_dir: str | Path = '.',
                geometry: GprConfig | None = None) -> RobotDescription:
    """Validate a robot mapping (as loaded from YAML). ``geometry`` replaces the file's ``gpr`` section."""
    data = _mapping(data, source, 'a robot description: name, gpr, base, rods, arms')
    check_keys(data, ('name', 'gpr', 'base', 'rods', 'arms', 'collision', 'wafer'), source)
    name = _name(data, 'name', source, default='robot')
    config, section = (geometry, GprSection()) if geometry is not None else \
        load_gpr_section(data.get('gpr'), source, Path(base_dir))
    base = _mapping(data.get('base', {}), f'{source}: base', 'frame, position, rpy of gpr_base in the world')
    check_keys(base, ('frame', 'position', 'rpy'), f'{source}: base')
    rods_data = _mapping(data.get('rods', {}), f'{source}: rods', 'names, velocity, acceleration')
    check_keys(rods_data, ('names', 'velocity', 'acceleration', 'jerk'), f'{source}: rods')
    rwhere = f'{source}: rods'
    raw_names = rods_data.get('names', ['rod1', 'rod2', 'rod3'])
    if not isinstance(raw_names, list) or len(raw_names) != 3:
        raise ConfigError(f'{rwhere}: names = {brief(raw_names)} is invalid; allowed: a list of 3 names ({_NAME_RULE})')
    rod_names = tuple(_name({'names': n}, 'names', rwhere) for n in raw_names)
    rods = Rods(names=(rod_names[0], rod_names[1], rod_names[2]),
                velocity=_positive_number(rods_data, 'velocity', rwhere, 10.0, 'm/s', 'm/s'),
                acceleration=_positive_number(rods_data, 'acceleration', rwhere, 100.0, 'm/s^2', 'm/s^2'),
                jerk=_jerk(rods_data, rwhere, 'm/s^3', 1e4))
    raw_arms = data.get('arms')
    if not isinstance(raw_arms, list) or not 1 <= len(raw_arms) <= 2:
        raise ConfigError(f'{source}: arms must be a list of one or two arms')
    arms = tuple(_arm(a, f'{source}: arms[{i}]') for i, a in enumerate(raw_arms))
    check_names(rod_names, [j for a in arms for j in a.joint_names], [a.name for a in arms], source)
    world = _name(base, 'frame', f'{source}: base', default='world')
    own = {*GPR_FRAMES, *(f for a in arms for f in (*a.link_frames, a.blade_frame, a.wafer_frame))}
    if world in own:   # gpr_base as the world: a cell given "in gpr_base" passed, 2 m from where its obstacles stand
        raise ConfigError(f'{source}: base: frame = {world!r} is one of the robot\'s own frames; allowed: a name '
                          f'for the world the robot stands in (default world), not {", ".join(sorted(own))}')
    return RobotDescription(
        name=name, config=config, world_frame=world,
        base_position=_xyz(base, 'position', f'{source}: base', WORLD_BOUND, default=(0.0, 0.0, 0.0)),
        base_rpy=_rpy(base, f'{source}: base'),
        rods=rods, arms=arms, source=source, bodies=parse_gpr_bodies(data.get('collision'), f'{source}: collision'),
        wafer=parse_wafer(data.get('wafer'), f'{source}: wafer'), gpr=section)


def load_robot(path: str | Path | None = None, geometry: str | Path | GprConfig | None = None,
               model: str | None = None) -> RobotDescription:
    """Read and validate a robot description (default: the shipped example ``config/robots/example_robot.yaml``).

    Args:
        geometry: a GPR geometry file (or config) used instead of the description's ``gpr`` section.
        model: a virtual-joint model overriding the one of the geometry.

    Raises:
        ConfigError: unreadable file, invalid YAML, unknown key, a value outside its range.
    """
    if path is not None and not isinstance(path, (str, os.PathLike)):
        raise ConfigError(f'robot description path = {brief(path)}; allowed: a file path (str or Path) or None')
    if geometry is not None and not isinstance(geometry, (str, os.PathLike, GprConfig)):
        raise ConfigError(f'geometry = {brief(geometry)}; allowed: a GPR geometry file path (str or Path), a GprConfig '
                          '(load_config) or None (the description\'s gpr section)')
    file = config_path(DEFAULT_ROBOT) if path is None else path
    cfg = load_config(geometry) if isinstance(geometry, (str, os.PathLike)) else geometry
    robot = parse_robot(read_yaml(file, 'robot'), str(file), Path(file).parent, cfg)
    if model is not None:
        try:
            robot = dataclasses.replace(robot, config=robot.config.replace(model=model))
        except ConfigError as exc:   # the API's argument and the CLI's --model (it named --model and replace())
            raise ConfigError(f"{str(exc).removeprefix('replace(): ')} (the model overriding the geometry's: model, "
                              'or --model)') from None
    return robot


"""The robot model of the GPR for ROS tools (URDF, tf), generated from the geometry configuration (no ROS import).

One source of truth: :func:`gpr_urdf` builds the model from a :class:`~gpr_kinematics.core.config.GprConfig`, so the
URDF, the transforms and the plots always show the geometry the kinematics uses. Frames (REP 103/105 style, SI):

- ``gpr_base``: origin at the centre of the rod axes on the plane ``q = 0``, z up along the rods;
- ``gpr_rod_guide_k`` (k = 1, 2, 3): the rod's prismatic guide, fixed on the base at its foot ``P_k(0)``
  (a fixed joint: ``/tf_static``);
- ``gpr_rod_k``: the top of rod k, at the spherical joint centre ``P_k = B_k + (q_k + o_k) u_k``
  (:class:`~gpr_kinematics.core.machine.MachineGeometry`: base point, zero offset and direction of the rod; the nominal
  machine's ``(R cos theta_k, R sin theta_k, q_k)``); joint ``rod_k`` (prismatic along ``u_k``, ``q_k`` in the
  stroke): the joint names of ``joint_states``;
- ``gpr_platform``: the platform (origin at the centre of the nominal joint triangle, z normal to it); joint
  ``gpr_platform_pose`` is *floating*: its pose comes from the kinematics (the virtual-joint model), not from a
  chain of joints (the GPR is a closed, overconstrained loop that a URDF tree cannot express);
- ``gpr_platform_nominal``: the platform under the naive model (floating joint ``gpr_platform_nominal_pose``),
  drawn as a translucent ghost, so the centre shift shows as the offset between the two; a ghost only (the old tool's
  pose of the platform, not a body): no ``<inertial>`` and no ``<collision>``, so a dynamics or collision stack does
  not count the platform twice.

The whole robot (:func:`robot_urdf`, from a robot description, docs/robot.md) adds the world and the arms:

- ``world`` (the description's ``base.frame``): the root; ``gpr_base`` fixed in it at ``base.position`` /
  ``base.rpy`` (joint ``gpr_base_mount``, ``/tf_static``);
- ``<arm>_link<k>``: one frame per revolute joint (joint names: the description's, e.g. ``arm1_elbow``, the names of
  ``joint_states``), ``<arm>_link1`` on ``gpr_platform``, axes along the platform normal;
- ``<arm>_blade`` and ``<arm>_wafer``: fixed on the last link (joints ``<arm>_blade_mount``, ``<arm>_wafer_mount``);
- ``<collision>``: the description's collision bodies (:mod:`gpr_kinematics.robot.collision`: the column on
  ``gpr_base``, the platform disc, the links, the paddles, the wafers as discs), exactly the shapes the clearance
  check (:mod:`gpr_kinematics.safety.clearance`) measures.

For a motion stack: the joints' limits carry the description's velocities (rods: ``rods.velocity``; arm joints: their
``velocity``) and effort 0 (the description gives none: not modelled); every link with a shape but the ghost
``gpr_platform_nominal`` has an ``<inertial>``, by default (the description gives no masses) that of its drawn shapes
filled with aluminium (:data:`DENSITY`), about its centre of mass; the wafer's is of its description's mass (a disc
of its diameter and thickness: :func:`wafer_link`); a link's collision shapes (``Link.collisions``) are written as
``<collision>`` elements. ``frame_prefix`` prefixes every link (frame) name, not the joint names, as
``robot_state_publisher``'s ``frame_prefix`` prefixes the tf frames: the URDF and ``/tf`` name the same frames.

The arm's joint origins are its frames at zero joint values as the robot core chains them
(:func:`gpr_kinematics.robot.forward.arm_transforms`): the URDF, the transforms and the kinematics have one source.

>>> from gpr_kinematics.core.config import GprConfig
>>> model = gpr_urdf(GprConfig())
>>> [j.name for j in model.joints if j.kind == 'prismatic']
['rod_1', 'rod_2', 'rod_3']
>>> xyz, quat = model.transform('rod_1', 0.5)       # gpr_rod_guide_1 -> gpr_rod_1 at q1 = 0.5 m
>>> [round(v, 12) for v in xyz], [round(v, 12) for v in quat]
([0.0, 0.0, 0.5], [0.0, 0.0, 0.0, 1.0])
>>> from gpr_kinematics.robot import load_robot
>>> arm = robot_urdf(load_robot()).joint('arm1_elbow')    # the example robot: elbow 0.30 m out, 35 mm up
>>> arm.kind, arm.parent, arm.child, arm.xyz
('revolute', 'arm1_link1', 'arm1_link2', (0.3, 0.0, 0.035))
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.config import GprConfig
from ..core.machine import MachineGeometry
from ..core.messages import ROD_JOINT_NAMES
from ..core.rotations import quaternion_from_matrix, rodrigues, rpy_matrix
from ..errors import InputError
from .shapes import DENSITY, Inertial, Visual, default_inertial, robot_shapes

if TYPE_CHECKING:
    from .collision import WaferShape
    from .description import Arm, RobotDescription

def wafer_link(name: str, wafer: WaferShape, rgba: tuple[float, float, float, float]) -> Link:
    """The wafer's link: the description's disc (``wafer``: diameter, thickness [m]) drawn, and its ``mass`` [kg] as
    a solid cylinder's inertia about its centre (``m (3 r^2 + t^2) / 12`` about x and y, ``m r^2 / 2`` about z); a
    300 mm wafer of 127.6 g had been drawn and weighed whatever the description said."""
    r, t, m = 0.5 * wafer.diameter, wafer.thickness, wafer.mass
    side = m * (3.0 * r * r + t * t) / 12.0
    return Link(name, (Visual('cylinder', (r, t), material='wafer', rgba=rgba),),
                inertial=Inertial(m, (0.0, 0.0, 0.0), (side, 0.0, 0.0, side, 0.0, 0.5 * m * r * r)))


#: The platform's closed chain, as the URDF explains it next to the floating joint.
CLOSED_CHAIN_NOTE = (
    'The platform closes an overconstrained loop: rods 1 to 3 (prismatic joints rod_k along their axes) end in '
    'spherical joints on the platform, three chains meeting one body, which a URDF tree cannot express. The platform '
    'hangs on this floating joint instead; its pose is the virtual-joint model\'s forward kinematics of the rods '
    '(gpr_kinematics), published on /tf by state_publisher_node. robot_state_publisher alone cannot compute it (it '
    'publishes no floating joint).')

JOINT_KINDS = ('fixed', 'prismatic', 'revolute', 'floating')


@dataclass(frozen=True)
class Link:
    """A frame with its drawn shapes, its collision shapes (the robot description's bodies, :mod:`.collision`; none:
    no ``<collision>``) and its inertia (None: :func:`default_inertial` of the shapes); a ``ghost`` is drawn only (no
    ``<inertial>``, no ``<collision>``: not a body, as the naive model's platform)."""

    name: str
    visuals: tuple[Visual, ...] = ()
    collisions: tuple[Visual, ...] = ()
    inertial: Inertial | None = None
    ghost: bool = False


@dataclass(frozen=True)
class Joint:
    """A joint from ``parent`` to ``child``: the fixed ``origin`` (``xyz`` [m], ``rpy`` [rad], URDF's fixed-axis
    roll-pitch-yaw), then the motion along/about ``axis`` (prismatic [m], revolute [rad]) within
    [``lower``, ``upper``]; a floating joint's pose is given whole (its origin is the identity)."""

    name: str
    kind: str
    parent: str
    child: str
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    lower: float = 0.0
    upper: float = 0.0
    velocity: float = 0.0
    effort: float = 0.0
    note: str = ''


def axis_angle_matrix(axis: Sequence[float] | np.ndarray, angle: float) -> np.ndarray:
    """Rotation by ``angle`` [rad] about ``axis`` (normalised): :func:`~..core.rotations.rodrigues`."""
    a = np.asarray(axis, dtype=float)
    x, y, z = (a / np.linalg.norm(a) * angle).tolist()
    return rodrigues(x, y, z)


@dataclass(frozen=True)
class RobotUrdf:
    """Links and joints of a robot (a tree rooted at ``root``)."""

    name: str
    root: str
    links: tuple[Link, ...] = field(default_factory=tuple)
    joints: tuple[Joint, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        names = [link.name for link in self.links]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice or self.root not in names:
            what = f'{twice[0]!r} is the name of two links' if twice else f'no link is the root {self.root!r}'
            raise InputError(f'robot model {self.name}: {what}; allowed: unique link names, the root {self.root!r} '
                             'among them')
        joints = [j.name for j in self.joints]
        twice = sorted({n for n in joints if joints.count(n) > 1})
        if twice:
            raise InputError(f'robot model {self.name}: joint name(s) {", ".join(twice)} used twice; allowed: unique '
                             'joint names (an arm joint may not take a rod joint\'s name, rod_1 .. rod_3)')
        children = [j.child for j in self.joints]
        for j in self.joints:
            if j.kind not in JOINT_KINDS or j.parent not in names or j.child not in names or j.child == self.root:
                raise InputError(f'robot model {self.name}: joint {j.name} ({j.kind}, {j.parent} -> {j.child}) is '
                                 f'invalid; allowed: kinds {", ".join(JOINT_KINDS)} between links of the model')
        if len(set(children)) != len(children) or len(children) != len(names) - 1:
            raise InputError(f'robot model {self.name}: every link but the root needs exactly one parent joint')

    def fixed_frames(self) -> tuple[str, ...]:
        """The frames (links) fixed in the root: joined to it by fixed joints only, in the links' order; every other
        frame moves with the machine (a rod, the platforms, an arm's links, blade and wafer)."""
        fixed = {self.root}
        parents = {j.child: j for j in self.joints}
        for link in self.links:
            chain, name = [], link.name
            while name not in fixed and name in parents and parents[name].kind == 'fixed':
                chain.append(name)
                name = parents[name].parent
            if name in fixed:
                fixed.update(chain)
        return tuple(link.name for link in self.links if link.name in fixed)

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise InputError(f'robot model {self.name} has no joint {name!r}; it has: '
                         + ', '.join(j.name for j in self.joints))

    def prefixed(self, prefix: str) -> RobotUrdf:
        """This model with every link (frame) name prefixed by ``prefix``; the joint names stay."""
        if not prefix:
            return self
        links = tuple(replace(link, name=prefix + link.name) for link in self.links)
        joints = tuple(replace(j, parent=prefix + j.parent, child=prefix + j.child) for j in self.joints)
        return replace(self, root=prefix + self.root, links=links, joints=joints)

    def extended(self, links: Iterable[Link], joints: Iterable[Joint]) -> RobotUrdf:
        """This model with more links and joints (e.g. an arm on ``gpr_platform``)."""
        return replace(self, links=(*self.links, *links), joints=(*self.joints, *joints))

    def transform(self, joint: str, value: float = 0.0) -> tuple[list[float], list[float]]:
        """Translation [m] and quaternion (x, y, z, w) from the joint's parent to its child at ``value``."""
        return joint_transform(self.joint(joint), value)

    def to_urdf(self) -> str:
        """The URDF (XML text) of the model."""
        return urdf_text(self)


def joint_transform(joint: Joint, value: float = 0.0) -> tuple[list[float], list[float]]:
    """Parent -> child transform of a fixed, prismatic or revolute joint at ``value`` [m or rad]:
    ``T = T_origin * T_motion`` (URDF); translation [m] and quaternion (x, y, z, w)."""
    if joint.kind == 'floating':
        raise InputError(f'joint {joint.name} is floating: its pose comes from the kinematics, not from a value')
    R = rpy_matrix(*joint.rpy)  # URDF's rpy: Rz(yaw) Ry(pitch) Rx(roll)
    t = np.asarray(joint.xyz, dtype=float)
    axis = np.asarray(joint.axis, dtype=float)
    if joint.kind == 'prismatic':
        t = t + R @ (float(value) * axis / np.linalg.norm(axis))
    elif joint.kind == 'revolute':
        R = R @ axis_angle_matrix(axis, float(value))
    return t.tolist(), [float(v) for v in quaternion_from_matrix(R)]


def gpr_urdf(cfg: GprConfig, base_frame: str = 'gpr_base', platform_frame: str = 'gpr_platform',
             nominal_frame: str = 'gpr_platform_nominal', rod_velocity: float = 0.0) -> RobotUrdf:
    """The GPR (base, three rods, exact and nominal platform) with the geometry of ``cfg``, the rods' velocity limit
    ``rod_velocity`` [m/s] (0: not known)."""
    R = cfg.radius
    stroke = cfg.stroke_max - cfg.stroke_min
    rod_r, ball_r, plate = 0.06 * R, 0.1 * R, 0.1 * R
    links = [Link(base_frame, (Visual('cylinder', (1.3 * R, 0.2 * plate), (0.0, 0.0, -0.1 * plate), material='base',
                                      rgba=(0.45, 0.45, 0.45, 1.0)),))]
    joints = []
    geo = MachineGeometry.of(cfg)
    feet = geo.base_points(np.zeros((1, 3)))[0]        # P_k(0) = B_k + o_k u_k: where rod k stands
    for k in range(3):
        guide, rod = f'gpr_rod_guide_{k + 1}', f'gpr_rod_{k + 1}'
        axis = (float(geo.ux[k]), float(geo.uy[k]), float(geo.uz[k]))   # the rod's direction u_k
        links.append(Link(guide, (Visual('cylinder', (1.8 * rod_r, 2 * plate), (0.0, 0.0, -plate), material='guide',
                                         rgba=(0.3, 0.3, 0.3, 1.0)),)))
        links.append(Link(rod, (Visual('cylinder', (rod_r, stroke), (0.0, 0.0, -0.5 * stroke), material='rod',
                                       rgba=(0.2, 0.4, 0.9, 1.0)),
                                Visual('sphere', (ball_r,), material='joint', rgba=(0.9, 0.9, 0.9, 1.0)))))
        joints.append(Joint(f'{guide}_mount', 'fixed', base_frame, guide, xyz=_xyz(feet[k])))
        joints.append(Joint(ROD_JOINT_NAMES[k], 'prismatic', guide, rod, axis=axis, lower=cfg.stroke_min,
                            upper=cfg.stroke_max, velocity=rod_velocity))
    disk = ('cylinder', (1.2 * R, plate), (0.0, 0.0, 0.5 * plate + ball_r))
    links.append(Link(platform_frame, (Visual(*disk, material='platform', rgba=(0.95, 0.55, 0.1, 1.0)),)))
    links.append(Link(nominal_frame, (Visual(*disk, material='nominal', rgba=(0.1, 0.8, 0.2, 0.35)),), ghost=True))
    joints.append(Joint(f'{platform_frame}_pose', 'floating', base_frame, platform_frame, note=CLOSED_CHAIN_NOTE))
    joints.append(Joint(f'{nominal_frame}_pose', 'floating', base_frame, nominal_frame))
    return RobotUrdf('gpr', base_frame, tuple(links), tuple(joints))


def robot_urdf(robot: RobotDescription, base_frame: str = 'gpr_base', platform_frame: str = 'gpr_platform',
               nominal_frame: str = 'gpr_platform_nominal', frame_prefix: str = '') -> RobotUrdf:
    """The whole robot: the world, the GPR of the description's geometry (:func:`gpr_urdf`) and every arm with
    its blade and wafer, every frame prefixed with ``frame_prefix`` (module docstring)."""
    gpr = gpr_urdf(robot.config, base_frame, platform_frame, nominal_frame, robot.rods.velocity)
    world = Link(robot.world_frame)
    mount = Joint(f'{base_frame}_mount', 'fixed', robot.world_frame, base_frame, xyz=robot.base_position,
                  rpy=robot.base_rpy)
    links, joints = [world, *gpr.links], [mount, *gpr.joints]
    for arm in robot.arms:
        arm_links, arm_joints = _arm_parts(arm, platform_frame, robot.wafer)
        links += arm_links
        joints += arm_joints
    every = [link.name for link in links]
    frames = {'base_frame': base_frame, 'platform_frame': platform_frame, 'nominal_frame': nominal_frame}
    for key, value in frames.items():
        if every.count(value) > 1:   # "link names must be unique" named neither the frame nor the parameter
            raise InputError(f'{key} = {value!r} is the name of another frame of robot {robot.name} (its world, '
                             'rods, arms, blades and wafers); allowed: a frame of its own')
    names = {'gpr_base': base_frame, 'gpr_platform': platform_frame}
    shapes: dict[str, list[Visual]] = {}
    for sh in robot_shapes(robot):
        shapes.setdefault(names.get(sh.frame, sh.frame), []).append(Visual(sh.kind, sh.size, sh.xyz, sh.rpy))
    links = [replace(link, collisions=tuple(shapes.get(link.name, ()))) for link in links]
    return RobotUrdf(robot.name, robot.world_frame, tuple(links), tuple(joints)).prefixed(frame_prefix)


def _yaw(R: np.ndarray) -> float:
    """The angle of a rotation about z (the arms turn about the platform normal only)."""
    return math.atan2(float(R[1, 0]), float(R[0, 0]))


def _xyz(v: Any) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])


def _arm_parts(arm: Arm, platform_frame: str, wafer: WaferShape) -> tuple[list[Link], list[Joint]]:
    """Links and joints of one arm: its frames at zero joint values (``arm_transforms``), revolute about z for the
    links, fixed for the blade and the wafer; boxes along the links, a thin blade, the description's wafer."""
    from .forward import arm_transforms

    frames = arm_transforms(arm, np.zeros((1, len(arm.joints))))
    links, joints = [], []
    grey, blade_rgba, wafer_rgba = (0.75, 0.75, 0.78, 1.0), (0.35, 0.35, 0.4, 1.0), (0.55, 0.6, 0.9, 0.9)
    for k, (frame, parent, pose) in enumerate(frames):
        xyz = _xyz(pose.position[0])
        rpy = (0.0, 0.0, _yaw(pose.rotation[0]))
        parent = platform_frame if parent == 'gpr_platform' else parent
        if k < len(arm.joints):
            j = arm.joints[k]
            visuals = [Visual('cylinder', (0.03, 0.03), material='arm_axis', rgba=(0.5, 0.5, 0.55, 1.0))]
            if j.length > 0.0:
                visuals.append(Visual('box', (j.length, 0.05, 0.02), (0.5 * j.length, 0.0, 0.0), material='arm',
                                      rgba=grey))
            links.append(Link(frame, tuple(visuals)))
            joints.append(Joint(j.name, 'revolute', parent, frame, xyz=xyz, rpy=rpy, lower=j.lower, upper=j.upper,
                                velocity=j.velocity))
        elif frame == arm.blade_frame:
            c = arm.blade.wafer_centre
            reach = math.hypot(c[0], c[1])
            links.append(Link(frame, (Visual('box', (reach + 0.05, 0.06, 0.003), (0.5 * c[0], 0.5 * c[1], 0.0),
                                             rpy=(0.0, 0.0, math.atan2(c[1], c[0])), material='blade',
                                             rgba=blade_rgba),)))
            joints.append(Joint(f'{arm.name}_blade_mount', 'fixed', parent, frame, xyz=xyz, rpy=rpy))
        else:
            links.append(wafer_link(frame, wafer, wafer_rgba))
            joints.append(Joint(f'{arm.name}_wafer_mount', 'fixed', parent, frame, xyz=xyz, rpy=rpy))
    return links, joints


def _f(x: float, exact: bool = True) -> str:
    """A number for the URDF: exact (``repr``) for joints, 6 significant digits for the visuals' sizes."""
    return repr(float(x)) if exact else format(float(x), '.6g')


def _v(values: Iterable[float], exact: bool = True) -> str:
    return ' '.join(_f(v, exact) for v in values)


def quoteattr(text: str) -> str:
    """``text`` as an XML attribute value with its quotes, as :func:`xml.sax.saxutils.quoteattr` writes it (that
    module imports urllib and http: about 65 ms at the start of every node that builds a URDF)."""
    for char, entity in (('&', '&amp;'), ('<', '&lt;'), ('>', '&gt;'), ('\n', '&#10;'), ('\r', '&#13;'),
                         ('\t', '&#9;')):
        text = text.replace(char, entity)
    if '"' not in text:
        return f'"{text}"'
    return f"'{text}'" if "'" not in text else '"' + text.replace('"', '&quot;') + '"'


def _geometry(v: Visual, exact: bool = False) -> str:
    if v.shape == 'box':
        return f'<box size="{_v(v.size, exact)}"/>'
    if v.shape == 'cylinder':
        return f'<cylinder radius="{_f(v.size[0], exact)}" length="{_f(v.size[1], exact)}"/>'
    return f'<sphere radius="{_f(v.size[0], exact)}"/>'


def _inertial_xml(i: Inertial) -> str:
    names = ('ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz')
    tensor = ' '.join(f'{n}="{_f(x, False)}"' for n, x in zip(names, i.inertia, strict=True))
    return (f'    <inertial><origin xyz="{_v(i.xyz, False)}" rpy="0 0 0"/><mass value="{_f(i.mass, False)}"/>'
            f'<inertia {tensor}/></inertial>')


def _link_xml(link: Link) -> list[str]:
    inertial = None if link.ghost else link.inertial or default_inertial(link.visuals)
    if not link.visuals and not link.collisions and inertial is None:
        return [f'  <link name={quoteattr(link.name)}/>']
    out = [f'  <link name={quoteattr(link.name)}>']
    if inertial is not None:
        out.append(_inertial_xml(inertial))
    for v in link.visuals:
        out.append(f'    <visual><origin xyz="{_v(v.xyz, False)}" rpy="{_v(v.rpy, False)}"/><geometry>'
                   f'{_geometry(v)}</geometry><material name={quoteattr(v.material)}/></visual>')
    for c in () if link.ghost else link.collisions:  # exact numbers: the clearance check uses these very shapes
        out.append(f'    <collision><origin xyz="{_v(c.xyz)}" rpy="{_v(c.rpy)}"/><geometry>{_geometry(c, True)}'
                   '</geometry></collision>')
    return [*out, '  </link>']


def urdf_text(model: RobotUrdf) -> str:
    """URDF 1.0 XML of ``model``: one ``<material>`` per colour; links with visuals, collisions and inertia;
    joints with origin, axis, limits (velocity, effort) and their notes as comments."""
    out = ['<?xml version="1.0"?>',
           '<!-- Generated by gpr_kinematics.robot.urdf from the geometry configuration: do not edit. '
           'SI units (m, rad, kg). Effort limits 0: not given by the robot description (not modelled); inertia: '
           f'of the drawn shapes in aluminium ({DENSITY:g} kg/m^3) where the description gives no masses (the wafer: '
           'its mass). -->',
           f'<robot name={quoteattr(model.name)}>']
    materials: dict[str, tuple[float, ...]] = {}
    for link in model.links:
        for v in link.visuals:
            materials.setdefault(v.material, v.rgba)
    for name, rgba in materials.items():
        out.append(f'  <material name={quoteattr(name)}><color rgba="{_v(rgba, False)}"/></material>')
    for link in model.links:
        out += _link_xml(link)
    for j in model.joints:
        if j.note:
            out.append(f'  <!-- {j.note} -->')
        out.append(f'  <joint name={quoteattr(j.name)} type="{j.kind}">')
        out.append(f'    <parent link={quoteattr(j.parent)}/><child link={quoteattr(j.child)}/>')
        if j.kind != 'floating':
            out.append(f'    <origin xyz="{_v(j.xyz)}" rpy="{_v(j.rpy)}"/>')
        if j.kind in ('prismatic', 'revolute'):
            out.append(f'    <axis xyz="{_v(j.axis)}"/><limit lower="{_f(j.lower)}" upper="{_f(j.upper)}" '
                       f'effort="{_f(j.effort)}" velocity="{_f(j.velocity)}"/>')
        out.append('  </joint>')
    out.append('</robot>')
    return '\n'.join(out) + '\n'


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m gpr_kinematics.robot.urdf [ROBOT_FILE]``: the URDF of the package's GPR, or with a robot
    description (``example`` for the shipped one) of that whole robot, on stdout."""
    import sys

    from ..errors import EXIT_BAD_INPUT, GprError, brief, one_line

    args = list(sys.argv[1:] if argv is None else argv)
    if args[:1] in (['-h'], ['--help']):
        print('usage: python -m gpr_kinematics.robot.urdf [ROBOT_FILE | example]')
        return 0
    if len(args) > 1:
        sys.stderr.write(f'robot_urdf: error: {len(args)} arguments {brief(args)}; allowed: at most one, a robot '
                         'file or example\n')
        return EXIT_BAD_INPUT
    try:
        from .description import load_robot

        if not args:   # the GPR alone: the package geometry, the shipped example robot's rod velocity
            from ..core.config import load_config

            print(gpr_urdf(load_config(), rod_velocity=load_robot().rods.velocity).to_urdf(), end='')
            return 0

        print(robot_urdf(load_robot(None if args[0] == 'example' else args[0])).to_urdf(), end='')
    except GprError as exc:
        sys.stderr.write(f'robot_urdf: error: {one_line(str(exc))}\n')
        return EXIT_BAD_INPUT
    return 0


if __name__ == '__main__':
    raise SystemExit(main())

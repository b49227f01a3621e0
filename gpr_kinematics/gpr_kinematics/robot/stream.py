"""A whole-robot program sampled for streaming, and the messages of each sample (no ROS import).

:func:`robot_stream` checks a robot program on a robot (:func:`gpr_kinematics.robot.plan.plan_program`: every
waypoint solved, every move timed within the joints' limits), samples it at a rate
(:func:`~gpr_kinematics.robot.plan.sample_plan`) and computes, per sample, the platform's forward kinematics
(what ``gpr/platform_state`` carries) and the whole robot's (:func:`gpr_kinematics.robot.robot_forward` of the
arm in use: its blade and wafer in the world, and where the naive model places the wafer). ``trajectory_node``
streams it; ``gpr verify`` recomputes the same numbers from a recording (:mod:`gpr_kinematics.bags.checks_robot`).

The messages of one sample (:meth:`RobotStream.messages`), besides the platform's
(:func:`gpr_kinematics.core.messages.stream_messages`), by topic:

- ``gpr/robot_state`` (``gpr_interfaces/RobotState``, frame: the robot's world frame): every arm's joints, the arm in
  use, its wafer and blade poses, the naive model's wafer error, the waypoint held;
- ``gpr/wafer_pose`` (``geometry_msgs/PoseStamped``, world frame): the wafer of the arm in use;
- ``joint_states`` (``sensor_msgs/JointState``): the physical joints only, the rods ``rod_1..rod_3`` [m] then
  every arm's joints [rad], as ``robot_state_publisher`` expects (the virtual joints stay on
  ``gpr/virtual_joints``).

The robot programs command joints (straight lines in joint space, docs/robot.md), not platform tilts: the
``commanded_tilt`` and ``commanded_azimuth`` of their platform states are the platform's own tilt and tilt
azimuth. SI units (m, rad, s); quaternions (x, y, z, w).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..core import ForwardBatch, forward_batch
from ..core.messages import ROD_JOINT_NAMES, MessageTypes, RosMessage, Topic, header, pose
from . import robot_forward
from .description import RobotDescription
from .plan import ProgramPlan, joint_limits, plan_program, sample_plan
from .program import RobotProgram
from .transforms import PoseBatch

Array = NDArray[np.float64]

@dataclass(frozen=True)
class RobotStream:
    """A robot program sampled at a rate (``S`` samples; SI units, world frame unless named).

    Attributes:
        robot, plan: the robot and the checked program. time ``(S,)`` [s]: the samples' times in the program.
        gpr: the platform's forward kinematics of the sampled rods, in ``gpr_base``.
        joint_names: every arm's joints (arm after arm); joints ``(S, J)`` [rad].
        arm ``(S,)``: the arm in use; wafer, blade: its wafer and blade poses in the world;
        naive_wafer_error ``(S, 3)`` [m]: the wafer minus where the naive model places it.
        waypoint ``(S,)``: the waypoint held (-1 while moving); waypoint_names: every waypoint's name; target
        ``(S,)``: the waypoint moved to or held.
    """

    robot: RobotDescription
    plan: ProgramPlan
    time: Array
    gpr: ForwardBatch
    joint_names: tuple[str, ...]
    joints: Array
    arm: tuple[str, ...]
    wafer: PoseBatch
    blade: PoseBatch
    naive_wafer_error: Array
    waypoint: NDArray[np.int64]
    waypoint_names: tuple[str, ...]
    target: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __len__(self) -> int:
        return int(self.time.shape[0])

    @property
    def rods(self) -> Array:
        """Rod lengths ``(S, 3)`` [m]."""
        return self.gpr.q

    def station(self, i: int) -> str:
        """The name of the waypoint held at sample ``i`` (empty while moving)."""
        k = int(self.waypoint[i])
        return self.waypoint_names[k] if k >= 0 else ''

    def messages(self, types: MessageTypes, i: int, *, stamp_ns: int, sample: int, base_frame: str,
                 frame_prefix: str = '') -> dict[str, RosMessage]:
        """The robot's messages of sample ``i`` by topic (module docstring), stamped ``stamp_ns`` [ns]; the
        ``sample`` counter is the stream's and ``joint_states`` is in ``base_frame``, as the sample's
        PlatformState (``gpr verify`` matches them by stamp and frame); the world frame with ``frame_prefix``."""
        h = header(types, stamp_ns, frame_prefix + self.robot.world_frame)
        wafer = pose(types, self.wafer.position[i], self.wafer.quaternion[i])
        e = [float(v) for v in self.naive_wafer_error[i]]
        state = types.RobotState(
            header=h, sample=int(sample), arm=self.arm[i], joint_names=list(self.joint_names),
            joints=types.float_sequence(self.joints[i]), wafer=wafer,
            blade=pose(types, self.blade.position[i], self.blade.quaternion[i]),
            naive_wafer_error=types.Vector3(x=e[0], y=e[1], z=e[2]), waypoint=int(self.waypoint[i]),
            station=self.station(i))
        empty = types.float_sequence(np.zeros(0))
        rods_header = header(types, stamp_ns, base_frame)
        return {
            Topic.ROBOT_STATE: state,
            Topic.WAFER_POSE: types.PoseStamped(header=h, pose=wafer),
            Topic.JOINT_STATES: types.JointState(
                header=rods_header, name=[*ROD_JOINT_NAMES, *self.joint_names],
                position=types.float_sequence(np.concatenate([self.gpr.q[i], self.joints[i]])), velocity=empty,
                effort=empty),
        }


def robot_stream(robot: RobotDescription, program: RobotProgram, rate: float) -> RobotStream:
    """Check ``program`` on ``robot``, sample it at ``rate`` [Hz] and compute every sample (module docstring).

    Raises:
        ConfigError, LimitError: the program does not fit the robot (a waypoint out of reach, a move too fast for
            the limits), naming the step; InputError: a rate outside :data:`~gpr_kinematics.robot.grid.RATES` or too
            many samples.
    """
    plan = plan_program(robot, program, rate)
    sampled = sample_plan(plan, rate)
    s = sampled.samples
    names, _, _, slices = joint_limits(robot)
    Q = s.positions[:, :3]
    gpr = forward_batch(Q, robot.config)
    S = len(s)
    arm = np.array(sampled.arm)
    blade_p, blade_R = np.empty((S, 3)), np.empty((S, 3, 3))
    naive = np.empty((S, 3))
    for a, cols in zip(robot.arms, slices, strict=True):
        idx = np.flatnonzero(arm == a.name)
        if idx.size:
            fk = robot_forward(robot, Q[idx], s.positions[idx, cols], a.name)
            blade_p[idx], blade_R[idx] = fk.blade.position, fk.blade.rotation
            naive[idx] = fk.naive_wafer_error
    return RobotStream(robot=robot, plan=plan, time=s.time, gpr=gpr, joint_names=names[3:], joints=s.positions[:, 3:],
                       arm=sampled.arm, wafer=sampled.wafer, blade=PoseBatch(blade_p, blade_R),
                       naive_wafer_error=naive, waypoint=np.asarray(s.held, dtype=np.int64),
                       waypoint_names=plan.waypoints.stations.names, target=np.asarray(s.target, dtype=np.int64))

"""Helpers of the robot tests: the shipped example robot as data, variants of it, random reachable postures."""
from __future__ import annotations

import copy
from typing import Any

import numpy as np
import yaml
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.description import RobotDescription, load_robot, parse_robot
from gpr_kinematics.robot.forward import robot_forward
from gpr_kinematics.robot.stations import Stations, stations_from_poses

ROBOT = load_robot()
EXAMPLE = yaml.safe_load(config_path('robots/example_robot.yaml').read_text())

#: A short whole-robot program for the stream, tf and bag tests: arm1 places a wafer at a tilted station, arm2
#: picks one from another (both arms in use, both branches).
SHORT_PROGRAM = """\
format: gpr_robot_program
units: {length: mm, angle: deg}
defaults: {approach_height: 8, retract_height: 8, dwell: 0.1}
stations:
  - {name: home, position: [750, 850, 420], heading: 90}
  - {name: chamber_a, position: [1200, 1000, 455], tilt: 1.2, azimuth: 30, heading: 45}
  - {name: chamber_b, position: [300, 1050, 480], tilt: 0.8, azimuth: -60, heading: 130, branch: left}
steps:
  - {move: home}
  - {place: chamber_a}
  - {pick: chamber_b, arm: arm2}
"""


def robot_data() -> dict[str, Any]:
    """A deep copy of the example robot's YAML data, to modify."""
    return copy.deepcopy(EXAMPLE)


def make_robot(data: dict[str, Any]) -> RobotDescription:
    return parse_robot(data, 'test_robot.yaml', config_path('robots/example_robot.yaml').parent)


def random_postures(robot: RobotDescription, arm: str, n: int, seed: int = 0,
                    tilt_fraction: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Random rods (heights within the stroke, tilts up to ``tilt_fraction`` of the limit) and random arm joints
    within their limits, keeping the held joint of a fixed_joint arm at its rule's value."""
    from gpr_kinematics.core import inverse_batch
    rng = np.random.default_rng(seed)
    cfg = robot.config
    ik = inverse_batch(rng.uniform(0.08, 0.42, n), rng.uniform(0.0, tilt_fraction, n) * cfg.tilt_limit,
                       rng.uniform(-np.pi, np.pi, n), cfg)
    a = robot.arm(arm)
    J = rng.uniform(a.lower + 1e-6, a.upper - 1e-6, (n, len(a.joints)))
    if a.redundancy is not None and a.redundancy.rule == 'fixed_joint':
        J[:, a.redundancy.joint] = a.redundancy.value
    return ik.q, J


def elbow_angle(robot: RobotDescription, arm: str, J: np.ndarray) -> np.ndarray:
    """Relative angle of the two-link sub-chain of each posture (0: stretched, the reach's edge)."""
    from gpr_kinematics.robot.arm_chain import chain_forward
    a = robot.arm(arm)
    axes, wafer, _ = chain_forward(a, J)
    keep = [k for k in range(len(a.joints)) if a.redundancy is None or k != a.redundancy.joint][:3]
    points = [axes[:, k] for k in keep] + [wafer]
    u, v = points[1] - points[0], points[2] - points[1]
    return np.arctan2(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0], np.sum(u * v, axis=1))


def random_stations(robot: RobotDescription, arm: str, n: int, seed: int = 0) -> tuple[Stations, np.ndarray,
                                                                                         np.ndarray]:
    """Stations reached by random postures (so they are reachable), with those postures."""
    Q, J = random_postures(robot, arm, n, seed)
    fk = robot_forward(robot, Q, J, arm)
    return stations_from_poses(fk.wafer.position, fk.wafer.rotation), Q, J


#: A calibrated GPR whose rods are not parallel (a review's geometry): rod positions, offsets and directions,
#: platform joints, the compliant model.
TILTED_RODS = {'model': 'compliant', 'kappa': 2.0,
               'rod_positions': [[0.0934, 0.0003], [-0.0465, 0.0809], [-0.0468, -0.0806]],
               'rod_offsets': [0.0002, -0.0001, 0.00015],
               'rod_directions': [[0.001, -0.0005], [0.0, 0.0008], [-0.0007, 0.0002]],
               'platform_joints': [[0.0931, 0.0001], [-0.0467, 0.0806], [-0.0465, -0.0808]]}

#: Rods at the stroke's ends and inside it, arm1's joints near their limits (both branches).
TAUGHT_RODS = [[0.0, 0.0005, 0.0002], [0.0, 0.0005, 0.0002], [0.0, 0.0, 0.0], [0.508, 0.508, 0.508],
               [0.508, 0.5075, 0.5078], [0.2, 0.2004, 0.1997]]
TAUGHT_JOINTS = [[0.4, 1.0, 0.5], [3.0, -2.9, -3.0], [0.1, 0.2, 0.3], [-3.04, 2.89, 3.04], [-2.99, -2.89, 2.99],
                 [3.04, -0.5, -3.04]]


def tilted_rods_robot() -> RobotDescription:
    """The example robot on :data:`TILTED_RODS`, its base moved, rolled and yawed."""
    data = robot_data()
    data['gpr'] = {'config': None, **TILTED_RODS}
    data['base'] = {'frame': 'world', 'position': [1.2, -0.4, 0.3], 'rpy': [0.02, -0.03, 2.1]}
    return make_robot(data)


class NoServerStandInError(Exception):
    """``trajectory_client.NoServerError`` of a stand-in client module (``gpr program send`` without ROS)."""


class ClientStandIn:
    """``trajectory_client.GprClient`` as a context manager that connects to nothing (``gpr program send`` without
    ROS: the functions it calls are replaced too)."""

    def __init__(self, name, namespace):
        self.name, self.namespace = name, namespace

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

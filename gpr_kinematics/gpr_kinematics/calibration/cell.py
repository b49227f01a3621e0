"""The synthetic raw data of the worked calibration of a cell (docs/calibration.md, "A worked calibration"):
``python -m gpr_kinematics.calibration.cell FOLDER`` writes what a laser tracker standing somewhere in the cell would
give, made by the package's own kinematics (SYNTHETIC, said so in every file's header, not a real machine):

* ``tracker.csv``: the pose of a 6-DOF probe on the platform (at :data:`TARGET`, not known to the calibration) in
  the tracker's frame (``gpr_base`` at :data:`TRACKER` in it: turned by 30 deg, metres away), at the 40
  configurations of ``gpr calibrate --plan 40 --frame tracker --target 0 0 0 0.3 0.1 -1 --fit-target position
  --tolerances TABLE`` (the example table; the probe's fixture gives its orientation, not its place), for the
  machine of the demonstration
  (:func:`~.demo.true_values`, its frames its datum's: :meth:`~.core_model.CoreModel.datum`), tracker noise 3 um and
  20 urad;
* ``arm1_wafer.csv``, ``arm1_blade.csv``: the wafer centre and a point of the blade (:data:`BLADE_POINT`) of the
  example robot's ``arm1`` on that machine, whose links are off by :data:`ARM_LENGTHS` and whose joints by
  :data:`ARM_OFFSETS`, at 40 random arm configurations and platform poses each, in the same tracker's frame,
  noise 5 um.
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

from ..core import naive_inverse
from ..core.config import load_config
from ..core.rotations import rpy_matrix
from ..errors import GprError, one_line
from ..inputs.resources import config_path
from ..robot.description import load_robot
from .arm import ArmMeasurements, ArmModel, write_arm_measurements
from .core_model import CoreModel
from .demo import ROWS, SIGMA_ANGLE, SIGMA_POSITION, TOLERANCES, true_values
from .frames import FramedModel, Transform
from .measurements import Measurements, write_measurements
from .plan import plan_measurements
from .synthetic import synthetic_measurements
from .tolerances import centre_of, load_tolerances, prior_of

#: The pose of gpr_base in the tracker's frame: x y z [m], roll pitch yaw [rad].
TRACKER = (1.8, -2.4, 0.7, 0.01, -0.02, 0.5235987755982988)
#: The probe's pose on the platform (in gpr_platform).
TARGET = (0.12, -0.05, 0.08, 0.3, 0.1, -1.0)
#: The arm's deviations: each link's length [m] and each joint's zero offset [rad], shoulder first.
ARM_LENGTHS = (5e-5, -5e-5, 5e-5)
ARM_OFFSETS = (1e-4, -1e-4, 1e-4)
BLADE_POINT = (0.05, 0.03, 0.0)
ARM_SIGMA = 5e-6
SEED = 21
HEADER = 'SYNTHETIC data of the worked calibration of a cell (gpr_kinematics.calibration.cell), not a real machine:'


def _transform(v: tuple[float, ...]) -> Transform:
    return Transform(np.array(v[:3]), rpy_matrix(*v[3:]))


def tracker_measurements(seed: int = SEED, q: np.ndarray | None = None) -> Measurements:
    """``tracker.csv`` (module docstring); another ``seed`` draws other noise, ``q (N, 3)`` [m] replaces the plan."""
    core, inner = machine()
    plan_model = FramedModel(core, Transform.identity(), Transform(np.zeros(3), _transform(TARGET).rotation), True,
                             'position')
    table = load_tolerances(config_path(TOLERANCES))
    Q = plan_measurements(plan_model, core.config, ROWS, sigma_position=SIGMA_POSITION, sigma_angle=SIGMA_ANGLE,
                          prior=prior_of(table, plan_model.parameters),
                          theta=centre_of(table, plan_model.parameters)).q if q is None else q
    model = FramedModel(core, _transform(TRACKER), _transform(TARGET), True, 'pose')
    theta = np.concatenate([inner[model.independent], TRACKER[:3], np.zeros(3), TARGET[:3], np.zeros(3)])
    return synthetic_measurements(model, theta, Q, SIGMA_POSITION, SIGMA_ANGLE, seed=seed, source='tracker.csv')


def machine() -> tuple[CoreModel, np.ndarray]:
    """The demonstration's machine with its frames at its datum: the core model and its coordinates."""
    core = CoreModel(load_config())
    model = FramedModel(core, _transform(TRACKER), _transform(TARGET), True, 'pose')
    values = core.parameters.coordinates(true_values(core))
    return core, model.inner_theta(values[model.independent][None])[0]


def arm_measurements(on_blade: bool, seed: int = SEED, noise: float = ARM_SIGMA) -> ArmMeasurements:
    """``arm1_blade.csv`` (``on_blade``) or ``arm1_wafer.csv`` (module docstring); another ``seed`` draws other
    configurations and noise, ``noise`` [m] the noise drawn (the rows' sigma stays :data:`ARM_SIGMA`)."""
    core, inner = machine()
    robot = dataclasses.replace(load_robot(), config=core.config_for(inner))
    arm = robot.arm('arm1')
    rng = np.random.default_rng(seed + on_blade)
    cfg = robot.config
    Q = naive_inverse(rng.uniform(0.05, 0.45, ROWS), rng.uniform(0.0, 0.99, ROWS) * cfg.tilt_limit,
                      rng.uniform(-np.pi, np.pi, ROWS), cfg)
    J = rng.uniform(0.8 * arm.lower, 0.8 * arm.upper, (ROWS, len(arm.joints)))
    on = np.full(ROWS, on_blade)
    blade = np.where(on[:, None], BLADE_POINT, 0.0)
    lines = tuple(range(1, ROWS + 1))
    model = ArmModel(robot, ArmMeasurements(Measurements('arm1', Q, np.zeros((ROWS, 3)), None, None, None, lines),
                                            'arm1', J, blade, on))
    truth = model.parameters.nominal + np.concatenate([np.ravel(np.column_stack([ARM_LENGTHS, ARM_OFFSETS])),
                                                       np.zeros(5)])
    framed = FramedModel(model, _transform(TRACKER), Transform.identity(), False, None, points=True)
    points = synthetic_measurements(framed, truth, Q, noise, SIGMA_ANGLE, seed=seed + 2 + on_blade, points=True)
    points = dataclasses.replace(points, sigma_position=np.full(ROWS, ARM_SIGMA))
    return ArmMeasurements(points, 'arm1', J, blade, on)


def write_cell(folder: str | Path) -> list[Path]:
    """Write the three files (module docstring) into ``folder``; their paths."""
    out = Path(folder)
    tracker = ', '.join(f'{v:g}' for v in TRACKER)
    target = ', '.join(f'{v:g}' for v in TARGET)
    paths = [write_measurements(out / 'tracker.csv', tracker_measurements(), (
        HEADER, f'the pose of a 6-DOF probe on the platform (x y z roll pitch yaw {target} in gpr_platform) in the '
        f'tracker\'s frame (gpr_base at {tracker} in it), the demonstration\'s machine, noise {SIGMA_POSITION:g} m '
        f'and {SIGMA_ANGLE:g} rad'))]
    robot = load_robot()
    for name, on in (('arm1_wafer.csv', False), ('arm1_blade.csv', True)):
        what = f'the blade point {BLADE_POINT}' if on else 'the wafer centre'
        paths.append(write_arm_measurements(out / name, robot, arm_measurements(on), (
            HEADER, f'{what} of arm1 of the example robot on that GPR, in the same tracker\'s frame, links off by '
            f'{ARM_LENGTHS} m, zero offsets {ARM_OFFSETS} rad, noise {ARM_SIGMA:g} m')))
    return paths


def main(argv: list[str] | None = None) -> int:
    """Write the cell's files into the folder named (made if missing); status 2 and one line on a bad argument."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1 or args[0].startswith('-'):
        print('usage: python -m gpr_kinematics.calibration.cell FOLDER', file=sys.stderr)
        return 2
    try:
        Path(args[0]).mkdir(parents=True, exist_ok=True)
        for path in write_cell(args[0]):
            print(f'wrote {path}')
    except (GprError, OSError) as exc:
        print(f'calibration cell: error: {one_line(str(exc))}', file=sys.stderr)
        return 2
    return 0


if __name__ == '__main__':
    sys.exit(main())

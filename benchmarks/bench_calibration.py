"""Benchmark of the calibration engines (issue: calibration and accuracy budget), all in one run.

Measures, with medians of repeated runs:

* **identification of all parameters from 40 and 200 poses** (target < 1 s): ``identify`` (the bounded
  Levenberg-Marquardt from two starts with the batched central-difference Jacobian, identifiability analysis,
  covariance, cross-validation, the held parameters' bias, the gate) on the core's 24 geometry parameters
  (``CoreModel``, the compliant model, every Jacobian one call of the per-row batch ``forward_batch(...,
  parameters=...)``), against the peer a user would write, ``scipy.optimize.least_squares`` (trf, its own
  finite-difference Jacobian, ``x_scale`` = the parameters' scales) on the same weighted residuals, at equal
  accuracy (estimates checked to agree within 1 % of a standard error); the same with the tracker's frame and an
  unknown target identified too (40 poses, 12 more parameters);
* **the arm**: link lengths, zero offsets, wafer centre and mount of a 3-joint arm from 80 measured points (half on the
  blade), against ``least_squares`` on the same residuals;
* **Monte Carlo budget, 10,000 samples for a 20-station program** (target < 2 s): ``accuracy_budget`` with the core
  model, every parameter toleranced (a kappa range included), rod-length errors and joint play (one machine per
  pose), and without joint play (one machine per sample, at its 20 stations); the model's own share of that time;
  the peer: the same samples one model call per sample (what the core binding did before the per-row batch).

Usage: ``.venv/bin/python benchmarks/bench_calibration.py [--quick]``.
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_core
from gpr_kinematics.calibration.arm import ArmMeasurements, ArmModel
from gpr_kinematics.calibration.budget import accuracy_budget
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.frames import FramedModel, Transform, measuring_model
from gpr_kinematics.calibration.identification import identify, weights
from gpr_kinematics.calibration.measurements import Measurements
from gpr_kinematics.calibration.model import evaluate
from gpr_kinematics.calibration.plan import plan_measurements
from gpr_kinematics.calibration.plausibility import measured_errors
from gpr_kinematics.calibration.synthetic import synthetic_measurements
from gpr_kinematics.calibration.tolerances import parse_tolerances
from gpr_kinematics.core import naive_inverse
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.rotations import rpy_matrix
from gpr_kinematics.robot.description import load_robot

SP, SA = 3e-6, 2e-5


def timed(fn, repeat: int) -> tuple[list[float], object]:
    """Seconds of ``repeat`` calls of ``fn`` (bench_core's timer) and the result of one more call."""
    return bench_core.timed(fn, repeat), fn()


class TimedModel:
    """A pose model that adds the time spent in the wrapped model's ``poses`` to :attr:`seconds`."""

    def __init__(self, model) -> None:
        self.model, self.seconds = model, 0.0
        self.parameters, self.supports_displacement = model.parameters, model.supports_displacement

    def poses(self, theta, Q, displacement=None):
        t0 = time.perf_counter()
        try:
            return self.model.poses(theta, Q, displacement)
        finally:
            self.seconds += time.perf_counter() - t0


def poses(cfg, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return naive_inverse(rng.uniform(0.02, 0.48, n), rng.uniform(-0.99, 0.99, n) * cfg.tilt_limit,
                         rng.uniform(-np.pi, np.pi, n), cfg)


def scipy_peer(model, meas, free: np.ndarray):
    """least_squares on the same weighted residuals (position / sigma_p, rotation vector / sigma_a; positions only for
    points), within the coordinates' bounds."""
    th0 = model.parameters.nominal
    w, _ = weights(meas, SP, SA)
    lo, hi = (b[free] for b in model.parameters.bounds)

    def residuals(x):
        th = th0.copy()
        th[free] = x
        return (measured_errors(model, meas, th) * w).ravel()

    return least_squares(residuals, np.clip(th0[free], lo + 1e-12, hi - 1e-12), method='trf', bounds=(lo, hi),
                         x_scale=model.parameters.scale[free], xtol=1e-12, ftol=1e-12, gtol=1e-12)


def identification_rows(rows: list, label: str, model, meas, rep: int) -> None:
    """Our identification and the peer's on ``meas``, their agreement checked."""
    times, res = timed(lambda: identify(model, meas), rep)
    fitted = res.fitted
    ptimes, peer = timed(lambda: scipy_peer(model, meas, fitted), max(2, rep // 2))
    diff = np.max(np.abs(peer.x - res.estimate[fitted]) / res.standard_error[fitted])
    assert diff < 0.01, f'{label}: peer and ours disagree by {diff:.3g} standard errors'
    held = len(model.parameters) - len(fitted)
    rows.append((f'identify, {label}', statistics.median(times), 's', '< 1',
                 f'{res.iterations} iterations, {len(fitted)} fitted, {held} held; gate '
                 f'{"passed" if res.gate.passed else "failed"}'))
    rows.append(('  peer: scipy least_squares (trf, 2-point Jacobian, bounds), same residuals',
                 statistics.median(ptimes), 's', '', f'{peer.nfev} evaluations; agrees within {diff:.1e} standard '
                                                     'errors'))


def arm_case(seed: int = 1):
    """80 measured points of the example robot's arm1 (half on the blade) with its links off by 50 um and its zero
    offsets by 100 urad."""
    robot = load_robot()
    arm = robot.arm('arm1')
    rng = np.random.default_rng(seed)
    n = 80
    Q = poses(robot.config, n, seed)
    J = rng.uniform(0.8 * arm.lower, 0.8 * arm.upper, (n, len(arm.joints)))
    on = np.arange(n) % 2 == 1
    blade = np.where(on[:, None], (0.05, 0.03, 0.0), 0.0)
    dummy = Measurements('arm', Q, np.zeros((n, 3)), None, None, None, tuple(range(1, n + 1)))
    model = ArmModel(robot, ArmMeasurements(dummy, 'arm1', J, blade, on))
    truth = model.parameters.nominal + np.concatenate([np.tile([50e-6, 100e-6], 3), np.zeros(5)])
    meas = synthetic_measurements(model, truth, Q, SP, SA, seed=seed, points=True)
    return ArmModel(robot, ArmMeasurements(meas, 'arm1', J, blade, on)), meas


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--quick', action='store_true', help='fewer repetitions (smoke run)')
    args = ap.parse_args()
    rep = 2 if args.quick else 5
    load_before = os.getloadavg()[0]
    cfg = load_config()
    rows = []

    # Identification of all 24 parameters from 40 planned and 200 random poses, and with the tracker's frame.
    core = CoreModel(cfg)
    ps = core.parameters
    rng = np.random.default_rng(2)
    values = ps.values(ps.nominal) + rng.normal(size=len(ps)) * np.tile([3e-5, 3e-5, 3e-5, 1e-4, 1e-4, 3e-5, 3e-5,
                                                                           0.0], 3)
    values[7::8] = 3.0
    truth = ps.coordinates(values)
    Q40 = plan_measurements(core, cfg, 40, sigma_position=SP, sigma_angle=SA).q
    for label, Q in (('40 planned poses', Q40), ('200 random poses', poses(cfg, 200, 1))):
        meas = synthetic_measurements(core, truth, Q, SP, SA, seed=3)
        identification_rows(rows, f'{label}, all 24 parameters of the core (compliant)', core, meas, rep)
    tracker = Transform(np.array([1.8, -2.4, 0.7]), rpy_matrix(0.01, -0.02, np.radians(30.0)))
    target = Transform(np.array([0.12, -0.05, 0.08]), rpy_matrix(0.3, 0.1, -1.0))
    framed = FramedModel(core, tracker, target, True, 'pose')
    inner = framed.inner_theta(truth[framed.independent][None])[0]
    meas = synthetic_measurements(framed, np.concatenate([inner[framed.independent], tracker.position, np.zeros(3),
                                                          target.position, np.zeros(3)]), Q40, SP, SA, seed=4)
    registered = measuring_model(core, meas, 'tracker')
    identification_rows(rows, f'40 planned poses in a tracker\'s frame, the geometry and both frames '
                              f'({len(registered.parameters)} parameters)', registered, meas, rep)
    arm, meas = arm_case()
    identification_rows(rows, 'an arm from 80 measured points (links, zero offsets, wafer centre, mount: 11 '
                              'parameters)', arm, meas, rep)

    # Monte Carlo budget, 10,000 samples x 20 stations.
    S, N = 10_000, 20
    Qs = poses(cfg, N, 4)
    entries = {'rod_positions': {'tolerance': 3e-5}, 'rod_offsets': {'tolerance': 5e-5},
               'rod_directions': {'tolerance': 2e-4}, 'platform_joints': {'tolerance': 3e-5},
               'kappa': {'range': [0.5, 2.0], 'distribution': 'log-uniform'}}
    table = parse_tolerances({'parameters': entries, 'rod_length': {'tolerance': 2e-6}, 'joint_clearance': 3e-6})
    no_play = parse_tolerances({'parameters': entries, 'rod_length': {'tolerance': 2e-6}})
    for label, tab in (('joint play: one machine per pose', table), ('no joint play: one machine per sample', no_play)):
        times, b = timed(lambda t=tab: accuracy_budget(core, Qs, t, samples=S, seed=0), rep)
        rows.append((f'budget, 10,000 samples x 20 stations, core (24 parameters, rod lengths; {label})',
                     statistics.median(times), 's', '< 2', f'{len(b.sources)} sources'))
        spent = []
        for _ in range(rep):
            proxy = TimedModel(core)
            accuracy_budget(proxy, Qs, tab, samples=S, seed=0)
            spent.append(proxy.seconds)
        rows.append(('  of which in the model (its poses calls)', statistics.median(spent), 's', '', ''))
    th = np.repeat(ps.nominal[None], S, axis=0)
    th[:, :] += rng.normal(0, 1, (S, len(ps))) * np.where(ps.select(['kappa']), 0.0, 2e-5)
    th[:, ps.select(['kappa'])] = rng.uniform(-1 / 3, 1 / 3, (S, 3))    # kappa 0.5 .. 2 as anisotropy
    n_peer = 1000 if not args.quick else 200
    ptimes, _ = timed(lambda: [evaluate(core, th[s], Qs) for s in range(n_peer)], max(2, rep // 2))
    rows.append((f'peer: one model call per sample ({n_peer} samples, scaled to 10,000; no joint play)',
                 statistics.median(ptimes) * S / n_peer, 's', '', ''))

    print(f'machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, '
          f'numpy {np.__version__}; load average {load_before:.2f} at the start, {os.getloadavg()[0]:.2f} at the end')
    print()
    print('| measurement | median | unit | target | note |')
    print('|---|---:|---|---|---|')
    for name, value, unit, target, note in rows:
        print(f'| {name} | {value:.3g} | {unit} | {target} | {note} |')


if __name__ == '__main__':
    main()

"""Benchmark of the calibration engines (issue: calibration and accuracy budget), all in one run.

Measures, with medians of repeated runs:

* **identification of all parameters from 200 poses** (target < 1 s): ``identify`` (Levenberg-Marquardt with the
  batched central-difference Jacobian, identifiability analysis, covariance) on the core's 24 geometry parameters
  (``CoreModel``, the compliant model, every Jacobian one call of the per-row batch ``forward_batch(...,
  parameters=...)``), against the peer a user would write, ``scipy.optimize.least_squares`` (trf, its own
  finite-difference Jacobian, ``x_scale`` = the parameters' scales) on the same weighted residuals, at equal
  accuracy (estimates checked to agree within 1 % of a standard error);
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
from gpr_kinematics.calibration.budget import accuracy_budget
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.identification import identify
from gpr_kinematics.calibration.model import evaluate, pose_error
from gpr_kinematics.calibration.synthetic import synthetic_measurements
from gpr_kinematics.calibration.tolerances import parse_tolerances
from gpr_kinematics.core import naive_inverse
from gpr_kinematics.core.config import load_config

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
    """least_squares on the same weighted residuals (position / sigma_p, rotation vector / sigma_a)."""
    th0 = model.parameters.nominal
    rot = meas.rotation

    def residuals(x):
        th = th0.copy()
        th[free] = x
        pos, r = evaluate(model, th, meas.q)
        e = pose_error(pos, r, meas.position, rot)
        return np.concatenate([e[:, :3].ravel() / SP, e[:, 3:].ravel() / SA])

    return least_squares(residuals, th0[free], method='trf', x_scale=model.parameters.scale[free],
                         xtol=1e-12, ftol=1e-12, gtol=1e-12)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--quick', action='store_true', help='fewer repetitions (smoke run)')
    args = ap.parse_args()
    rep = 2 if args.quick else 5
    load_before = os.getloadavg()[0]
    cfg = load_config()
    rows = []

    # Identification of all 24 parameters from 200 poses.
    Q = poses(cfg, 200, 1)
    core = CoreModel(cfg)
    ps = core.parameters
    rng = np.random.default_rng(2)
    values = ps.values(ps.nominal) + rng.normal(size=len(ps)) * np.tile([3e-5, 3e-5, 3e-5, 1e-4, 1e-4, 3e-5, 3e-5,
                                                                           0.0], 3)
    values[7::8] = 3.0
    meas = synthetic_measurements(core, ps.coordinates(values), Q, SP, SA, seed=3)
    times, res = timed(lambda: identify(core, meas), rep)
    fitted = res.fitted
    ptimes, peer = timed(lambda: scipy_peer(core, meas, fitted), max(2, rep // 2))
    diff = np.max(np.abs(peer.x - res.estimate[fitted]) / res.standard_error[fitted])
    assert diff < 0.01, f'peer and ours disagree by {diff:.3g} standard errors'
    rows.append(('identify, 200 poses, all 24 parameters of the core (compliant)', statistics.median(times), 's',
                 '< 1', f'{res.iterations} iterations, {len(fitted)} fitted, {len(ps) - len(fitted)} held'))
    rows.append(('peer: scipy least_squares (trf, 2-point Jacobian), same residuals', statistics.median(ptimes), 's',
                 '', f'{peer.nfev} evaluations; agrees within {diff:.1e} standard errors'))

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

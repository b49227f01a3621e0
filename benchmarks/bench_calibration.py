"""Benchmark of the calibration engines (issue: calibration and accuracy budget), all in one run.

Measures, with medians of repeated runs:

* **identification from 200 poses** (target < 1 s): ``identify`` (Levenberg-Marquardt with the batched central
  difference Jacobian, identifiability analysis, covariance) against the peer a user would write,
  ``scipy.optimize.least_squares`` (trf, its own finite-difference Jacobian, ``x_scale`` = the parameters' scales)
  on the same weighted residuals, at equal accuracy (estimates checked to agree within 1 % of a standard error).
  Two models: the core's geometry (``CoreModel``: radius and rod azimuths through ``forward_batch``, 4 parameters)
  and all 23 parameters of the imperfect GPR (the tests' reference model ``test/calibration_reference.py``,
  vectorised, with the compliance closure), until the core has the imperfect geometry;
* **Monte Carlo budget, 10,000 samples for a 20-station program** (target < 2 s): ``accuracy_budget`` with the
  reference model (every parameter of the imperfect geometry, rod-length errors, joint play), and the model's own
  share of that time; the peer: the same samples evaluated one model call per sample; and the core binding, whose
  batch kernel takes one geometry per call (a loop over the samples).

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

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_core
from calibration_reference import ReferenceModel

from gpr_kinematics.calibration.budget import accuracy_budget
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.identification import identify
from gpr_kinematics.calibration.model import evaluate, pose_error
from gpr_kinematics.calibration.synthetic import synthetic_measurements
from gpr_kinematics.calibration.tolerances import parse_tolerances
from gpr_kinematics.config import load_config
from gpr_kinematics.kinematics import naive_inverse

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
    cfg = load_config()
    rows = []

    # Identification from 200 poses.
    Q = poses(cfg, 200, 1)
    core = CoreModel(cfg)
    ref = ReferenceModel(base_z=False)
    rng = np.random.default_rng(2)
    for label, model, truth in (
            ('core geometry, 4 parameters', core, core.parameters.nominal + [60e-6, 4e-4, -3e-4, 2e-4]),
            ('imperfect GPR (reference model), 22 parameters', ref,
             ref.parameters.nominal + np.concatenate([rng.normal(0, 30e-6, 9), rng.normal(0, 1e-4, 6),
                                                      rng.normal(0, 30e-6, 6), [2.0]]))):
        meas = synthetic_measurements(model, truth, Q, SP, SA, seed=3)
        times, res = timed(lambda m=model, me=meas: identify(m, me), rep)
        fitted = res.fitted
        ptimes, peer = timed(lambda m=model, me=meas, f=fitted: scipy_peer(m, me, f), max(2, rep // 2))
        diff = np.max(np.abs(peer.x - res.estimate[fitted]) / res.standard_error[fitted])
        assert diff < 0.01, f'peer and ours disagree by {diff:.3g} standard errors'
        rows.append((f'identify, 200 poses, {label}', statistics.median(times), 's', '< 1',
                     f'{res.iterations} iterations, {len(fitted)} fitted'))
        rows.append((f'peer: scipy least_squares (trf, 2-point Jacobian), {label}', statistics.median(ptimes), 's',
                     '', f'{peer.nfev} evaluations; agrees within {diff:.1e} standard errors'))

    # Monte Carlo budget, 10,000 samples x 20 stations.
    S, N = 10_000, 20
    Qs = poses(cfg, N, 4)
    table = parse_tolerances({'parameters': {'rod_bases': {'tolerance': 3e-5}, 'rod_offsets': {'tolerance': 5e-5},
                                             'rod_directions': {'tolerance': 2e-4}, 'platform_joints':
                                             {'tolerance': 3e-5}, 'kappa': {'range': [0.5, 2.0],
                                                                             'distribution': 'log-uniform'}},
                              'rod_length': {'tolerance': 2e-6}, 'joint_clearance': 3e-6})
    times, b = timed(lambda: accuracy_budget(ref, Qs, table, samples=S, seed=0), rep)
    rows.append(('budget, 10,000 samples x 20 stations, reference model (22 parameters, rod lengths, joint play)',
                 statistics.median(times), 's', '< 2', f'{len(b.sources)} sources'))
    spent = []
    for _ in range(rep):
        proxy = TimedModel(ref)
        accuracy_budget(proxy, Qs, table, samples=S, seed=0)
        spent.append(proxy.seconds)
    rows.append(('  of which in the model (its poses calls)', statistics.median(spent), 's', '', ''))
    th = np.repeat(ref.parameters.nominal[None], S, axis=0) + rng.normal(0, 3e-5, (S, len(ref.parameters)))
    th[:, 21] = np.exp(rng.uniform(np.log(0.5), np.log(2.0), S))       # kappa as in the table
    n_peer = 1000 if not args.quick else 200
    ptimes, _ = timed(lambda: [evaluate(ref, th[s], Qs) for s in range(n_peer)], max(2, rep // 2))
    rows.append((f'peer: one model call per sample ({n_peer} samples, scaled to 10,000)',
                 statistics.median(ptimes) * S / n_peer, 's', '', ''))
    core_table = parse_tolerances({'parameters': {'radius': {'tolerance': 5e-5}, 'rod_azimuths': {'tolerance': 5e-4}},
                                   'rod_length': {'tolerance': 2e-6}})
    n_core = S if not args.quick else 500
    ctimes, _ = timed(lambda: accuracy_budget(core, Qs, core_table, samples=n_core, seed=0), max(2, rep // 2))
    rows.append((f'budget, core binding (4 parameters): {n_core:,} samples x 20 stations, scaled to 10,000',
                 statistics.median(ctimes) * S / n_core, 's', '< 2', 'one forward_batch per sample'))

    print(f'machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, '
          f'numpy {np.__version__}; load average {os.getloadavg()[0]:.2f} at the end')
    print()
    print('| measurement | median | unit | target | note |')
    print('|---|---:|---|---|---|')
    for name, value, unit, target, note in rows:
        print(f'| {name} | {value:.3g} | {unit} | {target} | {note} |')


if __name__ == '__main__':
    main()

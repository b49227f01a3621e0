"""Benchmark of the kinematics core, all in one run.

Measures: a single forward call, batch forward of 100,000 poses (radial, polar and the compliant model, whose
target is at most 3 us per pose; the compliant model also with one machine per pose, and per block of 100 poses:
the per-row geometry of the calibration), single and batch inverse, the full paper sweep, and the generic baseline a
user would otherwise write: ``scipy.optimize.least_squares`` on the same closure equations (radial model, the
square system, so the solution is unique and both must agree), followed by a rigid fit of the three joint
centres (``scipy.spatial.transform.Rotation.align_vectors``), one pose at a time, at equal accuracy (checked:
same virtual joints and position to 1e-12).

Prints a Markdown table (medians of repeated runs). Usage:
``python benchmarks/bench_core.py [--quick] [--cpu] [--before TREE]``. ``--cpu`` times with the process's CPU time
instead of the wall clock (on a shared machine other processes then cost less noise); ``--before TREE`` also
compares one-pose forward and inverse calls of another checkout (``TREE/gpr_kinematics``, e.g. the commit before
a change) with this one, alternating the two in fresh processes, CPU time, best of each round, median of rounds.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from gpr_kinematics.core import forward, forward_batch, inverse, inverse_batch, naive_inverse
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.machine import parameter_vector
from gpr_kinematics.core.sweep import paper_sweep
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

CLOCK = time.perf_counter


def timed(fn, repeat: int, number: int = 1, clock=None) -> list[float]:
    """Seconds per call of ``fn``, ``repeat`` samples of ``number`` calls each (``clock``, default :data:`CLOCK`)."""
    clock = clock or CLOCK
    out = []
    for _ in range(repeat):
        t0 = clock()
        for _ in range(number):
            fn()
        out.append((clock() - t0) / number)
    return out


#: One-pose calls and batches timed in a fresh process for ``--before`` (CPU time: one-pose calls best of 9 repeats,
#: batches best of 3), printed as JSON [us per call or per pose].
SINGLE_CALLS = """
import json, time, timeit
import numpy as np
from gpr_kinematics.core import forward, forward_batch, inverse, inverse_batch, naive_inverse
q = [0.5, 0.503, 0.498]
rng = np.random.default_rng(0)
n = 100_000
h, t, g = rng.uniform(0.05, 0.45, n), rng.uniform(-1, 1, n) * 0.0349, rng.uniform(-np.pi, np.pi, n)
Q = naive_inverse(h, t, g)
def best(fn, number, repeat=9):
    fn()
    return min(timeit.repeat(fn, number=number, repeat=repeat, timer=time.process_time)) / number * 1e6
out = {f'forward, single call ({m})': best(lambda m=m: forward(q, model=m), 2000) for m in ('radial', 'polar',
                                                                                              'compliant')}
out.update({f'inverse, single call ({m})': best(lambda m=m: inverse(0.3, 0.02, 1.0, model=m), 300)
            for m in ('radial', 'compliant')})
out.update({f'forward, batch of 100,000 ({m}), per pose': best(lambda m=m: forward_batch(Q, model=m), 1, 3) / n
            for m in ('radial', 'compliant')})
out['inverse, batch of 20,000 (radial), per pose'] = best(
    lambda: inverse_batch(h[:20_000], t[:20_000], g[:20_000]), 1, 3) / 20_000
print(json.dumps(out))
"""


def before_after(before: Path, rounds: int, script: str = SINGLE_CALLS) -> list[tuple[str, float, float]]:
    """``(call, before, after)`` [us]: ``script`` (it prints a JSON mapping of call to time) in ``before`` and in
    this tree, alternating, in fresh processes; the medians of the rounds."""
    trees = {'before': before.resolve(), 'after': Path(__file__).resolve().parents[1]}
    runs: dict[str, list[dict[str, float]]] = {'before': [], 'after': []}
    for _ in range(rounds):
        for name, tree in trees.items():
            env = dict(os.environ, PYTHONPATH=str(tree / 'gpr_kinematics'))
            out = subprocess.run([sys.executable, '-c', script], env=env, cwd=tree, capture_output=True,
                                 text=True, check=True)
            runs[name].append(json.loads(out.stdout))
    calls = list(runs['after'][0])
    return [(c, statistics.median(r[c] for r in runs['before']), statistics.median(r[c] for r in runs['after']))
            for c in calls]


def print_before_after(before: Path, rounds: int, script: str = SINGLE_CALLS) -> None:
    """The table of :func:`before_after`."""
    print()
    print(f'{before} (before) and this tree (after), {rounds} alternating rounds in fresh processes, CPU time, best '
          'of the repeats per round, median of the rounds:')
    print()
    print('| call | before [us] | after [us] | after / before |')
    print('|---|---:|---:|---:|')
    for call, b, a in before_after(before, rounds, script):
        print(f'| {call} | {b:.3g} | {a:.3g} | {a / b:.2f} |')


def baseline_forward(q: np.ndarray, cfg) -> tuple[np.ndarray, np.ndarray]:
    """What a user would write: least_squares on F(l) = |r_j - r_i|^2 - L_ij^2, then a rigid fit."""
    th = np.asarray(cfg.rod_azimuths)
    u = np.stack([np.cos(th), np.sin(th), np.zeros(3)], -1)
    P = np.column_stack([cfg.radius * np.cos(th), cfg.radius * np.sin(th), q])
    edges = ((0, 1), (1, 2), (2, 0))
    L2 = np.array([np.sum((P[j] - P[i]) ** 2) for i, j in edges])

    def F(lv: np.ndarray) -> np.ndarray:
        r = lv[:, None] * u
        return np.array([np.sum((r[j] - r[i]) ** 2) for i, j in edges]) - L2

    sol = least_squares(F, np.full(3, cfg.radius), xtol=1e-15, ftol=1e-15, gtol=1e-15, method='lm')
    r = sol.x[:, None] * u
    rot, _ = Rotation.align_vectors(P - P.mean(0), r - r.mean(0))
    t = P.mean(0) - rot.apply(r.mean(0))
    return sol.x, t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--quick', action='store_true', help='fewer repetitions (smoke run)')
    ap.add_argument('--cpu', action='store_true', help='time with the CPU time of this process, not the wall clock')
    ap.add_argument('--before', type=Path, metavar='TREE',
                    help='also compare one-pose calls with the checkout TREE (its gpr_kinematics), alternating')
    args = ap.parse_args()
    global CLOCK
    if args.cpu:
        CLOCK = time.process_time
    rep = 3 if args.quick else 7
    load_before = os.getloadavg()[0]
    cfg = load_config()
    rng = np.random.default_rng(0)
    n = 100_000
    h, t, g = rng.uniform(0.05, 0.45, n), rng.uniform(-1, 1, n) * cfg.tilt_limit, rng.uniform(-np.pi, np.pi, n)
    Q = naive_inverse(h, t, g, cfg)
    rows = []

    for model in ('radial', 'polar', 'compliant'):
        forward(Q[0], model=model)
        single = timed(lambda m=model: forward(Q[1], model=m), rep, 2000 if not args.quick else 200)
        batch = timed(lambda m=model: forward_batch(Q, model=m), rep)
        rows.append((f'forward, single call ({model})', statistics.median(single) * 1e6, 'us/call',
                     '>= 200x the baseline' if model != 'polar' else ''))
        rows.append((f'forward, batch of 100,000 ({model})', statistics.median(batch) / n * 1e6, 'us/pose',
                     '<= 3' if model == 'compliant' else '<= 2'))
    # One machine per row (the calibration's Jacobians and Monte Carlo budgets): every sample its own geometry (24
    # parameters perturbed by tens of um, 0.1 mrad, kappa 0.1 .. 10), and 1,000 machines at 100 poses each; no limit
    # checks (a perturbed machine may tilt a pose at the limit a little beyond it, as in the calibration).
    machines = parameter_vector(cfg) + rng.normal(size=(n, 24)) * np.tile([3e-5, 3e-5, 4e-5, 1e-4, 1e-4, 3e-5, 3e-5,
                                                                           0.0], 3)
    machines[:, 7::8] = np.exp(rng.uniform(-2.3, 2.3, (n, 3)))
    per_row = timed(lambda: forward_batch(Q, cfg, 'compliant', False, parameters=machines), rep)
    blocks = timed(lambda: forward_batch(Q, cfg, 'compliant', False, parameters=machines[:n // 100]), rep)
    rows.append(('forward, batch of 100,000 (compliant), one machine per pose', statistics.median(per_row) / n * 1e6,
                 'us/pose', '<= 3'))
    rows.append(('forward, batch of 100,000 (compliant), 1,000 machines x 100 poses',
                 statistics.median(blocks) / n * 1e6, 'us/pose', '<= 3'))
    m_inv = 20_000
    for model in ('radial', 'compliant'):
        isingle = timed(lambda m=model: inverse(h[0], t[0], g[0], model=m), rep, 300 if not args.quick else 30)
        rows.append((f'inverse, single call ({model})', statistics.median(isingle) * 1e6, 'us/call',
                     '<= 4x forward'))
    ibatch = timed(lambda: inverse_batch(h[:m_inv], t[:m_inv], g[:m_inv]), rep)
    rows.append((f'inverse, batch of {m_inv:,} (radial)', statistics.median(ibatch) / m_inv * 1e6, 'us/pose', '<= 20'))
    for model in ('polar', 'compliant'):
        other = timed(lambda m=model: inverse_batch(h[:m_inv], t[:m_inv], g[:m_inv], model=m), rep)
        rows.append((f'inverse, batch of {m_inv:,} ({model})', statistics.median(other) / m_inv * 1e6, 'us/pose',
                     '<= 20'))
    sweep = timed(lambda: paper_sweep(), rep)
    rows.append(('paper sweep, 756 samples (IK + FK)', statistics.median(sweep) * 1e3, 'ms', ''))

    # Generic baseline at equal accuracy (radial model: unique solution).
    nb = 300 if not args.quick else 50
    fb = forward_batch(Q[:nb], model='radial')
    for i in range(nb):
        X, pos = baseline_forward(Q[i], cfg)
        assert np.max(np.abs(X - fb.virtual_joints[i])) < 1e-12, 'baseline disagrees on X'
        assert np.max(np.abs(pos - fb.position[i])) < 1e-12, 'baseline disagrees on the position'
    base = timed(lambda: [baseline_forward(Q[i], cfg) for i in range(nb)], max(3, rep // 2))
    base_per_pose = statistics.median(base) / nb * 1e6
    ours_batch = [r for r in rows if r[0] == 'forward, batch of 100,000 (radial)'][0][1]
    ours_single = [r for r in rows if r[0] == 'forward, single call (radial)'][0][1]
    rows.append(('baseline: least_squares + align_vectors, per pose (radial)', base_per_pose, 'us/pose', ''))

    print(f'machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, '
          f'numpy {np.__version__}; load average {load_before:.2f} at the start, {os.getloadavg()[0]:.2f} at '
          f'the end; clock: {"CPU time of the process" if args.cpu else "wall clock"}')
    print()
    print('| measurement | median | unit | target |')
    print('|---|---:|---|---|')
    for name, value, unit, target in rows:
        print(f'| {name} | {value:.3g} | {unit} | {target} |')
    print()
    value = {r[0]: r[1] for r in rows}
    compliant = value['forward, single call (compliant)']
    print(f'speed-up over the baseline: batch forward {base_per_pose / ours_batch:.0f}x, '
          f'single forward call {base_per_pose / ours_single:.1f}x (radial), {base_per_pose / compliant:.1f}x '
          f'(compliant) (target >= 200x); compliant / radial single call {compliant / ours_single:.2f} (target <= 2); '
          f'inverse / forward single call {value["inverse, single call (radial)"] / ours_single:.2f} (target <= 4)')
    if args.before is not None:
        print_before_after(args.before, 3 if args.quick else 7)

if __name__ == '__main__':
    main()

"""Benchmark of the issue-13 workspaces, all in one run: DexTAR in its 6-D form and the joint working area of the
tripod over the planar 3-RRR at delta = 6 mm, in one process and on a Dask local cluster of 1 and 2 workers,
and codac's paver with a contractor on the DexTAR 6-D equalities at the same delta (the peer).

* ``none``: gpr_kinematics.workspace in this process (no Dask);
* ``dask-1``, ``dask-2``: the same run on a ``distributed.LocalCluster`` of 1 and 2 single-threaded worker
  processes (started and warmed up before the timing; the start-up time is reported apart). The boxes must
  be identical to ``none`` (checked);
* ``codac pave``: ``codac.pave(X0, CtcInverse(f, 0), eps)`` (PyPI ``codac``): the outer paving of the 6-D
  solution set of the four closure equations, with forward-backward contraction, on the same scaled
  variables (angles times the link length 0.2 m, so ``eps = delta`` is the same accuracy) in a child
  process stopped after ``--codac-timeout`` s. It gives outer boxes only (an equality's solution set has no
  interior); their projection on (x, y) is measured on a 0.5 mm raster.

Reported: median wall time, the parallel speed-up (1 worker over 2), inner/outer volumes and box counts, the
closed-form DexTAR area, and the machine's load. Usage: ``python benchmarks/bench_workspace_6d.py [--quick]``.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import math
import multiprocessing as mp
import os
import platform
import statistics
import sys
import time

import numpy as np
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.workspace import approximate, load_workspace_model
from gpr_kinematics.workspace.scheduler import Executor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_workspace import in_child


def _codac_worker(delta: float, queue: mp.Queue) -> None:
    import codac
    from codac import AnalyticFunction, CtcInverse, IntervalVector, VectorVar, cos, pave, sin, vec

    s = 0.2                                    # the angle scale of dextar_6d.yaml: q = variable / s
    x = VectorVar(6)
    q1, q2, q3, q4, px, py = x[0] / s, x[1] / s, x[2] / s, x[3] / s, x[4], x[5]
    f = AnalyticFunction([x], vec(0.2 * cos(q1) + 0.2 * cos(q3) + 0.1 - px,
                                  -0.1 + 0.2 * cos(q2) + 0.2 * cos(q4) - px,
                                  0.2 * sin(q1) + 0.2 * sin(q3) - py,
                                  0.2 * sin(q2) + 0.2 * sin(q4) - py))
    ctc = CtcInverse(f, IntervalVector([[0.0, 0.0]] * 4))
    X0 = IntervalVector([[-math.pi * s, math.pi * s]] * 4 + [[-0.52, 0.52]] * 2)
    t0 = time.perf_counter()
    paving = pave(X0, ctc, delta)
    seconds = time.perf_counter() - t0
    boxes = paving.boxes(codac.PavingOut.outer)
    xy = np.array([[[b[i].lb(), b[i].ub()] for i in (4, 5)] for b in boxes])
    queue.put((seconds, len(boxes), xy))


def run_codac(delta: float, timeout: float) -> tuple[float, int, np.ndarray] | None:
    return in_child(_codac_worker, (delta,), timeout)


def union_area(rects: np.ndarray, pixel: float = 5e-4) -> float:
    """Area of the union of (n, 2, 2) rectangles on a raster (every pixel a rectangle touches counts)."""
    lo = rects[:, :, 0].min(axis=0)
    hi = rects[:, :, 1].max(axis=0)
    shape = np.ceil((hi - lo) / pixel).astype(int) + 1
    diff = np.zeros(shape + 1, dtype=np.int32)
    i0 = np.floor((rects[:, :, 0] - lo) / pixel).astype(int)
    i1 = np.floor((rects[:, :, 1] - lo) / pixel).astype(int) + 1
    np.add.at(diff, (i0[:, 0], i0[:, 1]), 1)
    np.add.at(diff, (i1[:, 0], i0[:, 1]), -1)
    np.add.at(diff, (i0[:, 0], i1[:, 1]), -1)
    np.add.at(diff, (i1[:, 0], i1[:, 1]), 1)
    covered = np.cumsum(np.cumsum(diff, axis=0), axis=1) > 0
    return float(np.count_nonzero(covered) * pixel * pixel)


def load() -> str:
    return ', '.join(f'{v:.2f}' for v in os.getloadavg())


def time_runs(model, delta: float, repeat: int, scheduler) -> tuple[float, object]:
    times, res = [], None
    for _ in range(repeat):
        res = approximate(model, delta, progress=False, scheduler=scheduler)
        times.append(res.seconds)
    return statistics.median(times), res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--quick', action='store_true', help='one run each, delta 12 mm')
    ap.add_argument('--repeat', type=int, default=3, help='runs per configuration (median)')
    ap.add_argument('--codac-timeout', type=float, default=1200.0, help='seconds allowed to codac')
    ap.add_argument('--only', help='run only the cases whose name contains this text')
    args = ap.parse_args()
    # codac runs in a child process only: importing it switches a process's FPU to upward rounding
    import dask
    import distributed

    repeat = 1 if args.quick else args.repeat
    delta = 0.012 if args.quick else 0.006
    print(f'Machine: {platform.machine()}, {os.cpu_count()} cores (shared), Python {platform.python_version()}, '
          f'numpy {np.__version__}, dask {dask.__version__}, distributed {distributed.__version__}, '
          f'codac {importlib.metadata.version("codac")}; load average at the start: {load()}\n')
    exact = load_workspace_model(config_path('mechanisms/dextar.yaml')).exact_area()
    cases = [('DexTAR 6-D', 'dextar_6d'), ('joint working area', 'joint_working_area')]
    print('| case | delta | run | median s | speed-up | inner boxes | boundary boxes | inner volume | '
          'outer volume | same boxes |')
    print('|---|---:|---|---:|---:|---:|---:|---:|---:|---:|')
    notes = []
    for name, file in cases:
        if args.only and args.only not in name:
            continue
        model = load_workspace_model(config_path(f'mechanisms/{file}.yaml'))
        t_none, ref = time_runs(model, delta, repeat, 'none')
        rows = [('none (one process)', t_none, ref, True)]
        for workers in (1, 2):
            t0 = time.perf_counter()
            with Executor('local', workers) as ex:
                approximate(load_workspace_model(config_path('mechanisms/shell_arm.yaml')), 0.05, scheduler=ex,
                            chunk_size=64, progress=False)                       # starts and warms the cluster
                start = time.perf_counter() - t0
                t, res = time_runs(model, delta, repeat, ex)
            same = np.array_equal(res.inner, ref.inner) and np.array_equal(res.boundary, ref.boundary)
            rows.append((f'dask-{workers} (cluster start {start:.1f} s apart)', t, res, same))
            print(f'  {name} dask-{workers}: {t:.2f} s', file=sys.stderr, flush=True)
        speed = rows[1][1] / rows[2][1]
        for label, t, res, same in rows:
            gain = f'{speed:.2f}' if label.startswith('dask-2') else '-'
            print(f'| {name} | {delta * 1e3:g} mm | {label} | {t:.2f} | {gain} | {res.inner_boxes} | '
                  f'{res.boundary_boxes} | {res.inner_volume:.5g} | {res.outer_volume:.5g} | '
                  f'{"yes" if same else "NO"} |')
        units = '*'.join(ref.units)
        notes.append(f'{name}: volumes in {units}; {ref.levels} levels, {ref.evaluations} pairs (output box, '
                     'passive box) processed')
        if file == 'dextar_6d':
            notes.append(f'DexTAR closed-form area {exact:.5g} m^2: inner <= exact <= outer '
                         f'({ref.inner_volume <= exact <= ref.outer_volume})')
            out = run_codac(delta, args.codac_timeout)
            if out is None:
                print(f'| {name} | {delta * 1e3:g} mm | codac pave (contractor) | > {args.codac_timeout:.0f} '
                      '(stopped) | - | - | - | - | - | - |')
            else:
                sec, n, xy = out
                print(f'| {name} | {delta * 1e3:g} mm | codac pave (contractor), 1 run | {sec:.2f} | - | - | '
                      f'{n} (6-D) | - | {union_area(xy):.5g} (projected, raster) | - |')
                notes.append(f'codac: {n} outer 6-D boxes; ours / codac time: {t_none / sec:.3g} (one process), '
                             f'{rows[2][1] / sec:.3g} (2 workers)')
    print()
    for n in notes:
        print(f'- {n}')
    print(f'- load average at the end: {load()}')


if __name__ == '__main__':
    main()

"""Benchmark of the workspace approximation (issue 6), all in one run.

Cases: the 3-RPS tripod at delta = 1 mm and the GPR at delta = 1 mm (and the closed-form shell arm as an
accuracy check). For each, in the same process:

* ``covering``: gpr_kinematics.workspace, certified nonuniform covering (interval bounds, outward rounding);
* ``codac``: codac's SIVIA paver (``codac.sivia``, PyPI ``codac``), the peer a user would pick for set
  inversion, on the same constraints and the same scaled variables: angles are multiplied by the angle
  scale (tripod: platform radius r = 0.05 m, GPR: R = 0.093218 m) so that both pavers stop bisecting at
  the same scaled max-diameter ``eps = delta``;
* ``grid``: the grid method of Posypkin et al. (docs/references.md; node sampling per box, 3 nodes per edge, not
  certified);
* ``uniform``: the plain grid (cells of edge < delta classified by their corner nodes, not certified).

Reported: median wall time of the runs, inner/boundary box counts, inner/outer volumes, and a soundness
check of every result against 200,000 random points (feasible points outside the outer approximation,
infeasible points inside the inner one). Usage: ``python benchmarks/bench_workspace.py [--quick]``.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import math
import multiprocessing as mp
import os
import platform
import queue as queue_mod
import statistics
import sys
import time

import numpy as np
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.workspace import approximate, box_volume, contains_points
from gpr_kinematics.workspace.gpr import GprModel
from gpr_kinematics.workspace.loader import load_workspace_model
from gpr_kinematics.workspace.tripod import TripodModel

# Remainder of the series tan(a)/a = 1 + u/3 + 2u^2/15 + 17u^3/315 + sum_{k>=4} c_k u^k (u = a^2, all c_k > 0,
# c_4 = 62/2835, c_{k+1}/c_k < 0.41): for u <= 0.2 the tail lies in [0, 0.0240 u^4].
_TAN_TAIL = 0.0240


def codac_tripod(model: TripodModel, delta: float):
    from codac import AnalyticFunction, IntervalVector, VectorVar, atan, cos, sin, sqr, sqrt, vec

    s = float(model.scale[1])
    x = VectorVar(3)
    z, psi, th = x[0], x[1] / s, x[2] / s
    sps, cps, sth, cth = sin(psi), cos(psi), sin(th), cos(th)
    phi = atan(sps * sth / (cps + cth))
    sph, cph = sin(phi), cos(phi)
    r, R = model.r, model.R
    rp11 = cth * cph + sps * sth * sph
    rp12 = -cth * sph + sps * sth * cph
    rp21 = cps * sph
    rp22 = cps * cph
    rp31 = -sth * cph + sps * cth * sph
    rp32 = sth * sph + sps * cth * cph
    px = 0.5 * r * (rp11 - rp22)
    py = -r * rp21
    legs = []
    for b in model.beta:
        cb, sb = math.cos(b), math.sin(b)
        sx = px + r * (cb * rp11 + sb * rp12) - R * cb
        sy = py + r * (cb * rp21 + sb * rp22) - R * sb
        sz = z + r * (cb * rp31 + sb * rp32)
        legs.append(sqrt(sqr(sx) + sqr(sy) + sqr(sz)))
    f = AnalyticFunction([x], vec(*legs))
    box = model.box * model.scale[:, None]
    X0 = IntervalVector([list(b) for b in box])
    Y = IntervalVector([[model.leg_min, model.leg_max]] * 3)
    return f, X0, Y


def codac_gpr(model: GprModel, delta: float):
    import codac
    from codac import AnalyticFunction, Interval, IntervalVector, VectorVar, sqr, sqrt, vec

    s = float(model.scale[1])
    R = model.R
    x = VectorVar(3)
    z, wx, wy = x[0], x[1] / s, x[2] / s
    u = sqr(wx) + sqr(wy)
    t = 1 + u / 3 + 2 * sqr(u) / 15 + 17 * u * sqr(u) / 315 + Interval(0, _TAN_TAIL) * sqr(sqr(u))
    c = [math.cos(a) for a in model.az]
    sn = [math.sin(a) for a in model.az]
    q = [z + R * t * (wx * sn[k] - wy * c[k]) for k in range(3)]
    pairs = ((0, 1), (1, 2), (2, 0))
    D = [sqr(R * t * (wx * (sn[j] - sn[i]) - wy * (c[j] - c[i]))) for i, j in pairs]
    lin = [(D[0] - D[1] + D[2]) / (6 * R), (D[0] + D[1] - D[2]) / (6 * R), (D[1] + D[2] - D[0]) / (6 * R)]
    m = codac.max(codac.max(codac.abs(lin[0]), codac.abs(lin[1])), codac.abs(lin[2]))
    e1 = 2 * m / (1 + sqrt(1 - 6 * m / R))
    rem = 1.5 * sqr(e1) / R
    dl = [lin_k + Interval(-1, 1) * rem for lin_k in lin]
    f = AnalyticFunction([x], vec(*q, *dl))
    box = model.box * model.scale[:, None]
    X0 = IntervalVector([list(b) for b in box])
    Y = IntervalVector([[model.stroke_min, model.stroke_max]] * 3 + [[-model.budget, model.budget]] * 3)
    return f, X0, Y


def codac_shell(model, delta: float):
    from codac import AnalyticFunction, IntervalVector, VectorVar, oo, sqr, sqrt, vec

    x = VectorVar(3)
    f = AnalyticFunction([x], vec(sqrt(sqr(x[0]) + sqr(x[1]) + sqr(x[2])), x[2]))
    X0 = IntervalVector([list(b) for b in model.box])
    Y = IntervalVector([[abs(model.l1 - model.l2), model.l1 + model.l2], [model.floor, oo]])
    return f, X0, Y


def _codac_worker(builder, model, delta: float, queue) -> None:
    import codac

    f, X0, Y = builder(model, delta)
    t0 = time.perf_counter()
    paving = codac.sivia(X0, f, Y, delta)
    seconds = time.perf_counter() - t0

    def arr(node_value) -> np.ndarray:
        boxes = paving.boxes(node_value)
        out = np.array([[[b[i].lb(), b[i].ub()] for i in range(len(model.variables))] for b in boxes])
        out = out.reshape(-1, len(model.variables), 2)
        return out / model.scale[None, :, None]

    queue.put((seconds, arr(codac.PavingInOut.inner), arr(codac.PavingInOut.bound)))


def run_codac(builder, model, delta: float, timeout: float):
    """SIVIA of codac on the scaled variables, in a child process stopped after ``timeout`` seconds.

    Returns (seconds, inner, boundary) with boxes in the model's own units, or None on timeout.
    """
    return in_child(_codac_worker, (builder, model, delta), timeout)


def in_child(target, args: tuple, timeout: float):
    """``target(*args, queue)`` in a forked child process (codac never runs in this one: importing it sets
    upward rounding); what it puts on the queue, or None after ``timeout`` seconds."""
    ctx = mp.get_context('fork')
    queue = ctx.Queue()
    proc = ctx.Process(target=target, args=(*args, queue))
    proc.start()
    try:
        result = queue.get(timeout=timeout)
    except queue_mod.Empty:
        result = None
    if proc.is_alive():
        proc.terminate()
    proc.join()
    return result


def soundness(model, inner: np.ndarray, boundary: np.ndarray, pts: np.ndarray, ok: np.ndarray) -> str:
    outer = np.concatenate([inner, boundary])
    missed = int(np.count_nonzero(~contains_points(outer, pts[ok])))
    wrong = int(np.count_nonzero(contains_points(inner, pts[~ok])))
    return f'{missed}/{wrong}'


def bench_case(name: str, model, delta: float, builder, repeat: int, rng, codac_timeout: float,
               methods: tuple[str, ...] = ('covering', 'codac', 'grid', 'uniform')):
    rows = []
    pts = model.box[:, 0] + (model.box[:, 1] - model.box[:, 0]) * rng.random((200_000, len(model.variables)))
    ok = model.feasible(pts)
    mc = float(ok.mean() * np.prod(model.box[:, 1] - model.box[:, 0]))
    for method in methods:
        times = []
        runs = 1 if method in ('uniform', 'codac') else repeat
        inner = boundary = None
        for _ in range(runs):
            if method == 'codac':
                out = run_codac(builder, model, delta, codac_timeout)
                if out is None:
                    break
                sec, inner, boundary = out
            else:
                res = approximate(model, delta, method=method, progress=False)
                sec, inner, boundary = res.seconds, res.inner, res.boundary
            times.append(sec)
        if not times:
            rows.append({'case': name, 'method': method, 'seconds': None, 'runs': 0, 'timeout': codac_timeout})
            print(f'  {name} {method}: no result within {codac_timeout:.0f} s', file=sys.stderr, flush=True)
            continue
        rows.append({'case': name, 'method': method, 'seconds': statistics.median(times), 'runs': len(times),
                     'inner': inner.shape[0], 'boundary': boundary.shape[0], 'inner_volume': box_volume(inner),
                     'outer_volume': box_volume(inner) + box_volume(boundary),
                     'check': soundness(model, inner, boundary, pts, ok)})
        print(f'  {name} {method}: {rows[-1]["seconds"]:.3f} s', file=sys.stderr, flush=True)
    ref = next((r['seconds'] for r in rows if r['method'] == 'codac' and r['seconds']), None)
    for r in rows:
        r['ratio'] = None if (ref is None or r['seconds'] is None) else r['seconds'] / ref
    return rows, mc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--quick', action='store_true', help='one run per method, deltas 4 times coarser')
    ap.add_argument('--codac-timeout', type=float, default=1200.0, help='seconds allowed to one codac run')
    ap.add_argument('--only', help='run only the cases whose name contains this text (e.g. GPR)')
    ap.add_argument('--delta-mm', type=float, help='override the cases\' delta (mm)')
    ap.add_argument('--methods', default='covering,codac,grid,uniform', help='comma-separated methods to run')
    args = ap.parse_args()
    # not `import codac` here: importing it switches this process's FPU to upward rounding (float('1.2') then
    # reads 1.2000000000000002); codac runs in child processes only, our covering in round-to-nearest
    codac_version = importlib.metadata.version('codac')

    rng = np.random.default_rng(0)
    repeat = 1 if args.quick else 3
    scale = 4.0 if args.quick else 1.0
    tripod = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    gpr = load_workspace_model(config_path('mechanisms/gpr.yaml'))
    shell = load_workspace_model(config_path('mechanisms/shell_arm.yaml'))
    cases = [('tripod 3-RPS', tripod, 0.001 * scale, codac_tripod, None),
             ('GPR', gpr, 0.001 * scale, codac_gpr, None),
             ('shell arm', shell, 0.005 * scale, codac_shell, shell.exact_volume())]
    print(f'Machine: {platform.machine()}, {os.cpu_count()} cores (shared), Python {platform.python_version()}, '
          f'numpy {np.__version__}, codac {codac_version}\n')
    print('| case | delta | method | runs | median s | ratio to codac | inner boxes | boundary boxes | '
          'inner volume | outer volume | missed/wrong |')
    print('|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|')
    notes = []
    methods = tuple(m.strip() for m in args.methods.split(','))
    for name, model, delta, builder, exact in cases:
        if args.only and args.only not in name:
            continue
        if args.delta_mm:
            delta = args.delta_mm * 1e-3
        rows, mc = bench_case(name, model, delta, builder, repeat, rng, args.codac_timeout, methods)
        for r in rows:
            if r['seconds'] is None:
                print(f'| {name} | {delta * 1e3:g} mm | {r["method"]} | 0 | > {r["timeout"]:.0f} (stopped) | '
                      '- | - | - | - | - | - |')
                continue
            ratio = '-' if r['ratio'] is None else f'{r["ratio"]:.3g}'
            print(f'| {name} | {delta * 1e3:g} mm | {r["method"]} | {r["runs"]} | {r["seconds"]:.3f} | {ratio} | '
                  f'{r["inner"]} | {r["boundary"]} | {r["inner_volume"]:.5g} | {r["outer_volume"]:.5g} | '
                  f'{r["check"]} |')
        units = '*'.join(model.units)
        notes.append(f'{name}: Monte-Carlo volume {mc:.5g} {units} (200,000 points)'
                     + (f', exact {exact:.5g} {units}' if exact is not None else ''))
    print()
    for n in notes:
        print(f'- {n}')


if __name__ == '__main__':
    main()

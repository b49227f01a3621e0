"""Does compiled code earn its weight for one pose at a time? An experiment for issue 22, not a path of the package.

The shipped one-pose forward kinematics (``gpr_kinematics.core.forward``) is plain float arithmetic. This script
compiles the same arithmetic of the ``radial`` model (Bratovanov & Sotirov, eq. (1) and the closure eq. (8) by
Newton's method; the rigid fit, tilt, twist, quaternions and centre shift of the platform pose) for an upright machine
(the shipped configuration) with numba, and measures, in one run:

* the generic baseline (``bench_core.baseline_forward``: least_squares and a rigid fit), the shipped ``forward``, the
  compiled ``forward`` returning the same :class:`~gpr_kinematics.core.forward.ForwardResult` (the same checks), the
  compiled arithmetic alone, and the checks and result alone (the arithmetic's values given: what any path that
  returns a ``ForwardResult`` pays) - CPU time, best of the repeats, median of alternating rounds;
* in fresh processes: numba's import, the first call compiling (an empty cache) and the first call loading the
  compiled code from the cache.

Before timing it checks that the compiled ``forward`` equals the shipped one over 2,000 random poses (the worst
difference is printed; the script stops if it exceeds 1e-14). Needs numba (``pip install numba==0.68.1``, in the
``[bench]`` extra; not a dependency of the package). Usage: ``python benchmarks/bench_compiled.py [--quick]``.
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_core import baseline_forward, timed
from gpr_kinematics.core import ForwardResult, forward, naive_inverse
from gpr_kinematics.core.config import GprConfig, load_config
from gpr_kinematics.core.rotations import AZIMUTH_UNDEFINED_BELOW
from gpr_kinematics.core.single import one_pose
from gpr_kinematics.inputs.validation import three_floats

#: Slots of the constants array ``K`` of :func:`radial_forward_kernel`.
K_NAIVE, K_OFFSETS, K_UZ, K_BX, K_BY, K_COS, K_SIN, K_REST, K_PX, K_PY, K_TOL, K_ITER, K_FLAT = (
    0, 9, 12, 15, 18, 21, 24, 27, 30, 33, 36, 37, 38)
#: Slots of the output array: the 47 values of one_result's array, then tilt, azimuth, twist, fit and closure error.
OUT = 52


def radial_forward_kernel(q0: float, q1: float, q2: float, K: np.ndarray, out: np.ndarray) -> int:
    """The radial one-pose forward arithmetic of an upright machine (joint centres ``(B_k, q_k)``) into ``out``;
    returns the Newton iterations, -1 where the closure did not converge. Compiled by numba in :func:`main`."""
    n = K_NAIVE
    h0, h1, h2 = (q0 + K[K_OFFSETS]) * K[K_UZ], (q1 + K[K_OFFSETS + 1]) * K[K_UZ + 1], (q2 + K[K_OFFSETS + 2]) * K[
        K_UZ + 2]
    npx = K[n + 3] * h0 + K[n + 4] * h1 + K[n + 5] * h2
    npy = K[n + 6] * h0 + K[n + 7] * h1 + K[n + 8] * h2
    rest = 1.0 - (npx * npx + npy * npy)
    zn, nnx, nny, nnz = K[n] * h0 + K[n + 1] * h1 + K[n + 2] * h2, -npx, -npy, math.sqrt(rest if rest >= 0.0 else 0.0)
    X0, X1, X2, Y0, Y1, Y2 = K[K_BX], K[K_BX + 1], K[K_BX + 2], K[K_BY], K[K_BY + 1], K[K_BY + 2]
    Z0, Z1, Z2 = q0, q1, q2
    L0 = math.sqrt((X1 - X0) ** 2 + (Y1 - Y0) ** 2 + (Z1 - Z0) ** 2)
    L1 = math.sqrt((X2 - X1) ** 2 + (Y2 - Y1) ** 2 + (Z2 - Z1) ** 2)
    L2 = math.sqrt((X0 - X2) ** 2 + (Y0 - Y2) ** 2 + (Z0 - Z2) ** 2)
    c0, c1, c2, s0, s1, s2 = K[K_COS], K[K_COS + 1], K[K_COS + 2], K[K_SIN], K[K_SIN + 1], K[K_SIN + 2]
    l0, l1, l2 = K[K_REST], K[K_REST + 1], K[K_REST + 2]
    x0, x1, x2, y0, y1, y2 = l0 * c0, l1 * c1, l2 * c2, l0 * s0, l1 * s1, l2 * s2
    tol, most, flat_below = K[K_TOL], int(K[K_ITER]), K[K_FLAT]
    iterations = 0
    while True:
        e0x, e0y, e1x, e1y, e2x, e2y = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x0 - x2, y0 - y2
        f0, f1, f2 = e0x * e0x + e0y * e0y, e1x * e1x + e1y * e1y, e2x * e2x + e2y * e2y
        err = max(max(abs(math.sqrt(f0) - L0), abs(math.sqrt(f1) - L1)), abs(math.sqrt(f2) - L2))
        if err <= tol:
            break
        if iterations == most:
            return -1
        b0, a0 = 2.0 * (e0x * c1 + e0y * s1), -2.0 * (e0x * c0 + e0y * s0)
        b1, a1 = 2.0 * (e1x * c2 + e1y * s2), -2.0 * (e1x * c1 + e1y * s1)
        b2, a2 = 2.0 * (e2x * c0 + e2y * s0), -2.0 * (e2x * c2 + e2y * s2)
        g00, g01, g02 = b0 * b0 + a0 * a0, b0 * a1, b2 * a0
        g11, g12, g22 = b1 * b1 + a1 * a1, b1 * a2, b2 * b2 + a2 * a2
        r0, r1, r2 = f0 - L0 * L0, f1 - L1 * L1, f2 - L2 * L2
        k00, k11, k22 = g11 * g22 - g12 * g12, g00 * g22 - g02 * g02, g00 * g11 - g01 * g01
        k01, k02, k12 = g12 * g02 - g01 * g22, g01 * g12 - g11 * g02, g01 * g02 - g00 * g12
        inv_det = 1.0 / (g00 * k00 + g01 * k01 + g02 * k02)
        w0 = (k00 * r0 + k01 * r1 + k02 * r2) * inv_det
        w1 = (k01 * r0 + k11 * r1 + k12 * r2) * inv_det
        w2 = (k02 * r0 + k12 * r1 + k22 * r2) * inv_det
        l0, l1, l2 = l0 - (b2 * w2 + a0 * w0), l1 - (b0 * w0 + a1 * w1), l2 - (b1 * w1 + a2 * w2)
        iterations += 1
        x0, x1, x2, y0, y1, y2 = l0 * c0, l1 * c1, l2 * c2, l0 * s0, l1 * s1, l2 * s2
    # The rigid fit P_k = Rot r_k + t from the frames of the two triangles.
    ux, uy, uz, vx, vy, vz = X1 - X0, Y1 - Y0, Z1 - Z0, X2 - X0, Y2 - Y0, Z2 - Z0
    inv = 1.0 / math.sqrt(ux * ux + uy * uy + uz * uz)
    e1x, e1y, e1z = ux * inv, uy * inv, uz * inv
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    inv = 1.0 / math.sqrt(cx * cx + cy * cy + cz * cz)
    e3x, e3y, e3z = cx * inv, cy * inv, cz * inv
    e2x, e2y, e2z = e3y * e1z - e3z * e1y, e3z * e1x - e3x * e1z, e3x * e1y - e3y * e1x
    wx, wy = x1 - x0, y1 - y0
    inv = 1.0 / math.sqrt(wx * wx + wy * wy)
    fx, fy = wx * inv, wy * inv
    sg = 1.0 if wx * (y2 - y0) - wy * (x2 - x0) >= 0.0 else -1.0
    sfx, sfy = sg * fx, sg * fy
    r00, r01, r02 = e1x * fx - e2x * sfy, e1x * fy + e2x * sfx, sg * e3x
    r10, r11, r12 = e1y * fx - e2y * sfy, e1y * fy + e2y * sfx, sg * e3y
    r20, r21, r22 = e1z * fx - e2z * sfy, e1z * fy + e2z * sfx, sg * e3z
    rcx, rcy = (x0 + x1 + x2) / 3.0, (y0 + y1 + y2) / 3.0
    tx = (X0 + X1 + X2) / 3.0 - (r00 * rcx + r01 * rcy)
    ty = (Y0 + Y1 + Y2) / 3.0 - (r10 * rcx + r11 * rcy)
    tz = (Z0 + Z1 + Z2) / 3.0 - (r20 * rcx + r21 * rcy)
    fit = 0.0
    for k in range(3):
        rx, ry = (x0, y0) if k == 0 else ((x1, y1) if k == 1 else (x2, y2))
        bx, by, bz = (X0, Y0, Z0) if k == 0 else ((X1, Y1, Z1) if k == 1 else (X2, Y2, Z2))
        dx, dy, dz = r00 * rx + r01 * ry + tx - bx, r10 * rx + r11 * ry + ty - by, r20 * rx + r21 * ry + tz - bz
        fit = max(fit, math.sqrt(dx * dx + dy * dy + dz * dz))
    # Tilt, azimuth and twist of the platform; its quaternion (trace formula).
    s = math.hypot(r02, r12)
    tilt, azimuth = math.atan2(s, r22), math.atan2(r02, -r12)
    if azimuth <= -math.pi:
        azimuth = math.pi
    if tilt < flat_below:
        azimuth = 0.0
    inv_s = 1.0 / (1.0 if s < flat_below else s)
    ax, ay = (1.0, 0.0) if s < flat_below else (-r12 * inv_s, r02 * inv_s)
    v = 1.0 - r22
    t00, t01, t10, t11, t20, t21 = r22 + v * ax * ax, v * ax * ay, v * ax * ay, r22 + v * ay * ay, -s * ay, s * ax
    twist = math.atan2(t01 * r00 + t11 * r10 + t21 * r20, t00 * r00 + t10 * r10 + t20 * r20)
    w4 = 2.0 * math.sqrt(1.0 + r00 + r11 + r22)
    qx, qy, qz, qw = (r21 - r12) / w4, (r02 - r20) / w4, (r10 - r01) / w4, 0.25 * w4
    inv = 1.0 / math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    # The naive model's tilt (Fig. 2) and the centre shift.
    s = math.hypot(nnx, nny)
    inv_s = 1.0 / (1.0 if s < flat_below else s)
    ax, ay = (1.0, 0.0) if s < flat_below else (-nny * inv_s, nnx * inv_s)
    v = 1.0 - nnz
    cw = math.sqrt(0.5 * (1.0 + nnz))
    half = 0.5 / cw
    values = (q0, q1, q2, L0, L1, L2, tx, ty, tz, r00, r01, r02, r10, r11, r12, r20, r21, r22, qx * inv, qy * inv,
              qz * inv, qw * inv, 0.0, 0.0, zn, nnz + v * ax * ax, v * ax * ay, s * ay, v * ax * ay, nnz + v * ay * ay,
              -s * ax, -s * ay, s * ax, nnz, s * ax * half, s * ay * half, 0.0, cw, tx, ty, tz - zn,
              math.sqrt((x0 - K[K_PX]) ** 2 + (y0 - K[K_PY]) ** 2),
              math.sqrt((x1 - K[K_PX + 1]) ** 2 + (y1 - K[K_PY + 1]) ** 2),
              math.sqrt((x2 - K[K_PX + 2]) ** 2 + (y2 - K[K_PY + 2]) ** 2), l0, l1, l2, tilt, azimuth, twist, fit, err)
    for i in range(OUT):
        out[i] = values[i]
    return iterations


def constants(cfg: GprConfig) -> np.ndarray:
    """The array ``K`` of :func:`radial_forward_kernel` for ``cfg`` (an upright machine)."""
    kernel = one_pose(cfg, 'radial')
    geo, model = kernel.geometry, kernel.model
    if not geo.upright:
        raise SystemExit('bench_compiled: the experiment covers upright machines only')
    return np.array([*np.ravel(geo.naive_inv), *geo.offsets, *geo.uz, *geo.bx, *geo.by, *model.cos, *model.sin,
                     *model.singular_floats, *geo.px, *geo.py, cfg.tolerance, cfg.max_iterations,
                     AZIMUTH_UNDEFINED_BELOW])


def result(a: np.ndarray, iterations: int, names: tuple[str, ...], cfg: GprConfig) -> ForwardResult:
    """The :class:`ForwardResult` of the kernel's output, built as the shipped one-pose path builds it."""
    out = ForwardResult.__new__(ForwardResult)
    out.__dict__.update(
        q=a[0:3], model='radial', virtual_joints=a[44:47], virtual_joint_names=names, side_lengths=a[3:6],
        position=a[6:9], rotation=a[9:18].reshape(3, 3), quaternion=a[18:22], tilt=float(a[47]),
        tilt_azimuth=float(a[48]), twist=float(a[49]), nominal_position=a[22:25],
        nominal_rotation=a[25:34].reshape(3, 3), nominal_quaternion=a[34:38], centre_shift=a[38:41],
        joint_displacement=a[41:44], within_budget=max(a[41], a[42], a[43]) <= cfg.imperfection_budget,
        iterations=iterations, residual=float(a[51]), fit_residual=float(a[50]))
    return out


def compiled_forward(kernel, K: np.ndarray, names: tuple[str, ...], cfg: GprConfig):
    """``forward(q)`` with the compiled kernel: the shipped checks' fast form (the stroke and the naive tilt; the
    messages of a refusal are left to the shipped path), then the kernel and :func:`result`."""
    lo, hi, limit = cfg.stroke_min, cfg.stroke_max, cfg.tilt_limit

    def call(q):
        q0, q1, q2 = three_floats(q, 'q')
        if not (lo <= q0 <= hi and lo <= q1 <= hi and lo <= q2 <= hi):
            return forward(q, cfg, 'radial')
        a = np.empty(OUT)
        iterations = kernel(q0, q1, q2, K, a)
        if iterations < 0 or a[47] > limit:
            return forward(q, cfg, 'radial')
        return result(a, iterations, names, cfg)
    return call


FIELDS = ('q', 'side_lengths', 'position', 'rotation', 'quaternion', 'tilt', 'tilt_azimuth', 'twist',
          'nominal_position', 'nominal_rotation', 'nominal_quaternion', 'centre_shift', 'joint_displacement',
          'virtual_joints', 'residual', 'fit_residual')


def worst_difference(fast, cfg: GprConfig, n: int) -> float:
    """The largest difference of any field between ``fast`` and the shipped ``forward`` over ``n`` random poses."""
    rng = np.random.default_rng(1)
    Q = naive_inverse(rng.uniform(0.02, 0.49, n), rng.uniform(-1, 1, n) * cfg.tilt_limit,
                      rng.uniform(-np.pi, np.pi, n), cfg)
    Q[::7] = Q[::7, :1]  # singular: all rods equal
    worst = 0.0
    for q in Q:
        a, b = forward(q, cfg, 'radial'), fast(q)
        assert a.iterations == b.iterations and a.within_budget == b.within_budget
        worst = max(worst, *(float(np.max(np.abs(np.subtract(getattr(a, f), getattr(b, f))))) for f in FIELDS))
    return worst


#: A fresh process's first call: numba's import, then the kernel's first call (compiled, or loaded from the cache).
FIRST_CALL = """
import sys, time
t0 = time.perf_counter()
import numba
t1 = time.perf_counter()
sys.path.insert(0, {benchmarks!r})
import bench_compiled as b
from gpr_kinematics.core.config import load_config
import numpy as np
kernel = numba.njit(cache=True)(b.radial_forward_kernel)
K = b.constants(load_config())
t2 = time.perf_counter()
kernel(0.3, 0.3, 0.3, K, np.empty(b.OUT))
print(t1 - t0, time.perf_counter() - t2)
"""


def fresh_process_costs(cache: Path) -> tuple[float, float, float]:
    """Seconds of numba's import, of a first call that compiles and of one that loads from the cache in ``cache``
    (each in a fresh process; the median import of three, the later of the two loads)."""
    script = FIRST_CALL.format(benchmarks=str(Path(__file__).resolve().parent))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    runs = [subprocess.run([sys.executable, '-c', script], env=env, capture_output=True, text=True, check=True)
            for _ in range(3)]
    (imp0, compiled), (imp1, loaded), (imp2, loaded2) = (map(float, r.stdout.split()) for r in runs)
    return statistics.median([imp0, imp1, imp2]), compiled, min(loaded, loaded2)

def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--quick', action='store_true', help='fewer repetitions (smoke run)')
    args = ap.parse_args()
    try:
        import numba
    except ImportError:
        print("bench_compiled: needs numba (pip install numba==0.68.1, or the package's [bench] extra); the package "
              'itself does not', file=sys.stderr)
        raise SystemExit(2) from None
    cfg = load_config()
    K = constants(cfg)
    kernel = numba.njit(radial_forward_kernel)
    names = one_pose(cfg, 'radial').names
    fast = compiled_forward(kernel, K, names, cfg)
    worst = worst_difference(fast, cfg, 200 if args.quick else 2000)
    if worst > 1e-14:
        raise SystemExit(f'bench_compiled: the compiled forward differs from the shipped one by {worst:.3g}')
    q = [0.5, 0.503, 0.498]
    a = np.empty(OUT)
    filled = a.copy()
    iterations = kernel(*q, K, filled)

    def values_given(q0: float, q1: float, q2: float, K: np.ndarray, out: np.ndarray) -> int:
        """In place of the kernel: the values of ``q`` copied in (the floor of a path that returns a result)."""
        out[:] = filled
        return iterations

    floor = compiled_forward(values_given, K, names, cfg)

    calls = {
        'least_squares baseline (bench_core), one pose': (lambda: baseline_forward(np.asarray(q), cfg), 50),
        'shipped forward, one pose': (lambda: forward(q, cfg, 'radial'), 2000),
        'compiled forward, one pose (the same ForwardResult)': (lambda: fast(q), 5000),
        'compiled arithmetic alone': (lambda: kernel(0.5, 0.503, 0.498, K, a), 50000),
        'checks and ForwardResult alone (values given)': (lambda: floor(q), 5000),
    }
    rounds, repeat = (3, 3) if args.quick else (7, 7)
    load = os.getloadavg()[0]
    times: dict[str, list[float]] = {name: [] for name in calls}
    for _ in range(rounds):
        for name, (fn, number) in calls.items():
            number = max(1, number // 10) if args.quick else number
            fn()
            best = min(timed(fn, repeat, number, clock=time.process_time))
            times[name].append(best * 1e6)
    with tempfile.TemporaryDirectory() as tmp:
        imp, compiled, loaded = fresh_process_costs(Path(tmp))
    base = statistics.median(times['least_squares baseline (bench_core), one pose'])
    print(f'Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, numpy '
          f'{np.__version__}, numba {numba.__version__}; load average {load:.2f} -> {os.getloadavg()[0]:.2f}')
    print(f'Compiled forward against the shipped one over {200 if args.quick else 2000} poses: worst difference '
          f'{worst:.3g}')
    print()
    print(f'CPU time, best of {repeat} repeats, median of {rounds} alternating rounds:')
    print()
    print('| call | us | baseline / call |')
    print('|---|---:|---:|')
    for name, values in times.items():
        m = statistics.median(values)
        print(f'| {name} | {m:.3g} | {base / m:.0f}x |')
    print()
    print(f'Fresh process: numba import {imp:.2f} s; first call compiling {compiled:.2f} s; first call from the '
          f'cache {loaded:.2f} s')


if __name__ == '__main__':
    main()

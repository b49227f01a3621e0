"""The Monte Carlo of the accuracy budget (:mod:`.budget`): every source drawn from its distribution, the model
evaluated exactly, and whether each draw lies within the bounds the linearised worst case takes (a normal draw may
not: its worst case is its 3 sigma)."""
from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..callbacks import StageProgress
from ..core.machine import GeometryRowError, parameter_range
from ..errors import ConfigError
from .model import ParameterSet, PoseModel, evaluate, pose_error
from .tolerances import Tolerance, ToleranceTable

Array = NDArray[np.float64]
#: The alias of held parameters on calibrated ones: the held parameters' indices ``(H,)`` and ``A (F, H)``, the fitted
#: estimates ``f_true + A dh`` of a calibration that held them ``dh`` off (:attr:`~.plan.MeasurementPlan.alias`).
Alias = tuple[NDArray[np.int64], Array]
#: Calibrated parameters: their indices, the covariance of their estimates and the alias of the held ones on them
#: (``None``: the held parameters independent of the calibrated ones).
Calibrated = tuple[NDArray[np.int64], Array, Alias | None]

#: Poses evaluated per Monte Carlo chunk (bounds memory).
CHUNK_POSES = 200_000


def limits(params: ParameterSet) -> tuple[Array, Array]:
    """The lowest and highest coordinate of each parameter: its range (:attr:`~.model.Parameter.bounds`) within its
    geometry's limits (:func:`~gpr_kinematics.core.machine.parameter_range`; none for an arm's or a frame's)."""
    lower, upper = params.bounds
    for j, p in enumerate(params):
        r = None if p.transform else parameter_range(p.name)
        if r is not None:
            lower[j], upper[j] = max(lower[j], r[0]), min(upper[j], r[1])
    return lower, upper


@contextlib.contextmanager
def drawn_from(table: ToleranceTable, first: int | None = None) -> Iterator[None]:
    """Name ``table`` when a machine drawn from it (Monte Carlo sample ``first + row``; ``None``: the tolerances'
    centre) is one the geometry refuses (:class:`~gpr_kinematics.core.machine.GeometryRowError`, which names only a
    row): ``rod_positions: {tolerance: 0.0008}``, within every parameter's limits, moved two rods 1.7 mm farther apart
    than their joints at sample 116 (1 % of a side allowed)."""
    try:
        yield
    except GeometryRowError as exc:
        what = (f'Monte Carlo sample {first + exc.row} of these tolerances' if first is not None else
                'the centre of these tolerances (each parameter at its mean)')
        raise ConfigError(f'{table.source}: {what} is a machine the geometry refuses ({exc.reason}); allowed: '
                          'tolerances whose every draw is a valid geometry (smaller ones of rod_positions and '
                          'platform_joints: the rods and the joints keep triangles alike)') from exc


def within(x: Array, t: Tolerance) -> NDArray[np.bool_]:
    """Whether deviations ``x`` drawn from ``t`` lie in the interval its worst case takes (a normal draw may not)."""
    lo, hi = t.bounds
    return np.asarray((x >= lo) & (x <= hi), dtype=bool)


def sample(src_tols: list[tuple[int, Tolerance]], cal: Calibrated | None, table: ToleranceTable,
           rng: np.random.Generator, S: int, N: int, P: int
           ) -> tuple[Array, Array, Array | None, NDArray[np.bool_]]:
    """Parameter deviations ``(S, P)``, rod-length errors ``(S, N, 3)``, joint displacements or ``None``, and per
    sample and station ``(S, N)`` whether every draw lies within the bounds the worst case takes (a normal one
    within its 3 sigma, the calibration's within its 3-sigma ellipsoid). With the calibration's alias
    ``(held, A)`` a calibrated parameter deviates by ``n - A dh`` (``n`` its estimate's noise, ``dh`` the held ones'
    deviations: the calibration that held them at the model's values absorbed ``A dh`` into its estimates)."""
    dtheta = np.zeros((S, P))
    inside = np.ones((S, N), dtype=bool)
    for j, t in src_tols:
        dtheta[:, j] = t.sample(rng, (S,))
        inside &= within(dtheta[:, j], t)[:, None]
    if cal is not None and len(cal[0]):
        # The symmetric square root V sqrt(lam) V' (it also takes a singular covariance): eigh's eigenvectors are
        # fixed up to sign and, for near-equal eigenvalues, mixing, which numpy 1.26 and 2.4 chose differently, so
        # V sqrt(lam) drew other samples from the same seed; the symmetric root is the same matrix either way.
        lam, V = np.linalg.eigh(cal[1])
        root = np.sqrt(np.maximum(lam, 0.0))
        L = (V * root) @ V.T
        z = rng.standard_normal((S, len(cal[0])))
        dtheta[:, cal[0]] = z @ L.T
        w = (z @ V)[:, lam > 0.0]                    # the draw in the eigenbasis: x' C^+ x = |w|^2 where lam > 0
        inside &= (np.sum(w ** 2, axis=1) <= 9.0)[:, None]   # x' C^+ x <= 3^2
        alias = cal[2] if len(cal) > 2 else None     # a pair (indices, covariance): no alias
        if alias is not None and len(alias[0]):
            dtheta[:, cal[0]] -= dtheta[:, alias[0]] @ alias[1].T
    dq = table.rod_length.sample(rng, (S, N, 3)) if table.rod_length is not None else np.zeros((S, N, 3))
    if table.rod_length is not None:
        inside &= np.all(within(dq, table.rod_length), axis=-1)
    disp = None
    if max(table.joint_clearance) > 0:
        d = rng.standard_normal((S, N, 3, 3))
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        r = np.asarray(table.joint_clearance)[None, None, :, None] * rng.uniform(0.0, 1.0, (S, N, 3, 1)) ** (1 / 3)
        disp = d * r
    return dtheta, dq, disp, inside


def monte_carlo(model: PoseModel, th: Array, Q: Array, pose0: tuple[Array, Array], tool: Array, frame: Array,
                tols: list[Tolerance | None], cal: Calibrated | None, table: ToleranceTable,
                samples: int, seed: int,
                pct: tuple[float, ...], quantities: dict[str, tuple[tuple[int, ...], str]],
                progress: StageProgress | None = None, keep: int = 0
                ) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any], dict[str, Any], Array, Array,
                           dict[str, Array]]:
    """``samples`` draws of every source (the tolerated parameters ``tols`` but the calibrated ones, which ``cal``
    draws), the model evaluated exactly at the stations ``Q``, the errors ``v`` against the poses ``pose0`` (and the
    tool points, in the axes ``frame``): per quantity the percentiles ``pct`` of ``|v|``, its RMS, its largest value
    and the largest of the samples whose every draw lies within the worst case's bounds (:func:`sample`; ``-inf``
    where none does); the mean and standard deviation of ``v`` ``(N, 9)``; and per quantity the samples ``|v|``
    ``(samples, keep)`` of the first ``keep`` stations, the ones the percentiles summarise (for a plot; none when
    ``keep`` is 0). ``progress`` hears the share of the samples drawn after each chunk (stage ``Monte Carlo``:
    5,000,000 poses take about 35 s of CPU time)."""
    N = Q.shape[0]
    if samples == 0:
        nan = np.full((N, len(pct)), np.nan)
        return ({k: nan for k in quantities}, {k: np.full(N, np.nan) for k in quantities},
                {k: np.full(N, np.nan) for k in quantities}, {k: np.full(N, np.nan) for k in quantities},
                np.full((N, 9), np.nan), np.full((N, 9), np.nan), {})
    rng = np.random.default_rng(seed)
    cal_set = set(cal[0].tolist()) if cal is not None else set()
    src_tols = [(j, t) for j, t in enumerate(tols) if t is not None and j not in cal_set]
    chunk = max(1, CHUNK_POSES // N)
    v = np.empty((samples, N, 9))
    inside = np.empty((samples, N), dtype=bool)
    pos0, rot0 = pose0
    lower, upper = limits(model.parameters)
    a0 = np.einsum('nij,nj->ni', rot0, tool)
    for start in range(0, samples, chunk):
        S = min(chunk, samples - start)
        dtheta, dq, disp, inside[start:start + S] = sample(src_tols, cal, table, rng, S, N, th.size)
        # A coordinate with a range stays in it: a normal draw of a calibrated covariance beyond kappa = 1e6 is taken
        # at the bound (a tangentially rigid joint), and a normal draw beyond a geometry parameter's limit (a rod
        # direction's 0.05: the tail past 3 sigma of rod_directions: {tolerance: 0.045, distribution: normal} was
        # refused as 'per-row geometry, row 303') at the limit. Such a sample is not the one drawn: it is not counted
        # within the worst case's bounds (a calibrated draw within 3 sigma of a limit was).
        drawn = th[None, :] + dtheta
        taken = np.clip(drawn, lower, upper)
        inside[start:start + S] &= np.all(taken == drawn, axis=1)[:, None]
        with drawn_from(table, start):
            pos, rot = evaluate(model, taken, Q[None] + dq, disp)
        e = pose_error(pos, rot, pos0[None], rot0[None])
        e_tool = pos + np.einsum('snij,nj->sni', rot, tool) - (pos0 + a0)[None]
        blocks = np.stack([e[..., :3], e[..., 3:], e_tool], axis=2)          # (S, N, 3 vectors, 3)
        v[start:start + S] = np.einsum('ij,snbj->snbi', frame, blocks).reshape(S, N, 9)
        if progress is not None:
            progress('Monte Carlo', (start + S) / samples)
    mc, rms, top, top_inside, kept = {}, {}, {}, {}, {}
    for name, (comps, _) in quantities.items():
        mag = np.linalg.norm(v[:, :, comps], axis=-1)                # (S, N)
        mc[name] = np.percentile(mag, pct, axis=0).T
        rms[name] = np.sqrt(np.mean(mag ** 2, axis=0))
        top[name] = np.max(mag, axis=0)
        top_inside[name] = np.max(np.where(inside, mag, -np.inf), axis=0)
        if keep:
            kept[name] = np.ascontiguousarray(mag[:, :keep])
    return mc, rms, top, top_inside, v.mean(axis=0), v.std(axis=0), kept

"""Accuracy budget: platform and tool-point error per station from a tolerance table, linearised and Monte Carlo.

The error of a station is the deviation of the real pose from the one the model predicts, as a small rigid
motion in ``gpr_base``: ``v = (dx, dy, dz, rx, ry, rz, tool dx, dy, dz)`` (metres, radians; ``(rx, ry)`` is the
tilt error, ``rz`` the heading error; the tool point ``t`` is given in ``gpr_platform``). Reported per station,
for the quantities of :data:`QUANTITIES` (horizontal and vertical position of platform and tool, tilt and
heading):

* **linearised**: ``v = sum_j G_j x_j`` with the sensitivities ``G_j`` (central differences, :mod:`.model`) and
  the sources ``x_j``: each tolerated parameter, the rod-length error of each rod, the play of each joint and,
  after a calibration, the covariance of the calibrated parameters (and, with the calibration's alias, each held
  parameter's effect net of what the calibration absorbs of it into the calibrated ones). ``rss = sqrt(E |v|^2)``
  (the mean and the variances of all sources, root-sum-square), each source's **share** of ``E |v|^2`` (shares sum
  to 1), and the **worst case** ``max |v|`` over every source at its bound at once (interval ends; the ball of a joint's
  play; the 3-sigma ellipsoid of a covariance): for a 2-D quantity the support function
  ``h(u) = u . v_0 + sum_j |u . g_j| w_j + ...`` maximised over :data:`DIRECTIONS` directions ``u`` and divided
  by ``cos(pi / DIRECTIONS)``, a guaranteed bound of the linearised error within 0.002 % (not of the model's: a
  source whose range the model is not linear over, e.g. a stiffness ratio from 0.5 to 2 drawn uniformly, can exceed
  it by 17 %, which the Monte Carlo's largest error shows and a warning names, of the samples whose every draw lies
  within the bounds the worst case takes: a normal draw beyond its 3 sigma lies beyond them whatever the model);
* **Monte Carlo**: ``samples`` draws of every source, the model evaluated exactly (no linearisation), and the
  percentiles of ``|v|`` and its RMS.

The two agree to first order (tests compare them); where they differ, the nonlinearity of the model matters.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..callbacks import StageProgress
from ..core.inverse import check_tool
from ..errors import InputError, brief
from ..inputs.validation import finite_vector, float_array, plain_number, random_seed, rotation_matrices
from .budget_inputs import check_calibrated, check_sources, check_stations
from .model import (
    PoseModel,
    as_configurations,
    displacement_jacobian,
    evaluate,
    pose_error,
    pose_jacobian,
    pose_model,
    rod_jacobian,
)
from .monte_carlo import Calibrated, drawn_from, monte_carlo
from .tolerances import Tolerance, ToleranceTable

Array = NDArray[np.float64]

#: The reported quantities: name -> (components of v, unit).
QUANTITIES: dict[str, tuple[tuple[int, ...], str]] = {
    'platform_horizontal': ((0, 1), 'm'), 'platform_vertical': ((2,), 'm'),
    'tilt': ((3, 4), 'rad'), 'heading': ((5,), 'rad'),
    'tool_horizontal': ((6, 7), 'm'), 'tool_vertical': ((8,), 'm'),
}
DIRECTIONS = 512
MAX_SAMPLES = 1_000_000
MAX_STATIONS = 10_000
#: An RSS below this [m or rad] is rounding: no shares are given for it.
SHARE_FLOOR = 1e-12
#: The linearised RSS and the Monte Carlo RMS of a quantity should agree within this fraction (a warning names
#: every station and quantity where they do not).
AGREEMENT = 0.10
#: A Monte Carlo RMS of ``n`` samples scatters by about ``1 / sqrt(2 n)`` of the true RMS, the RSS where the model is
#: linear (a normal quantity's): RSS and RMS must differ by more than this many of those as well before a warning
#: calls the model not linear (one sample read "differ by 52 %"; the default 10,000 samples scatter by 0.7 %).
SCATTERS = 3.0
#: A Monte Carlo error above the linearised worst case by more than this fraction of it (its rounding and the
#: 0.002 % of the directions' polygon) is named in a warning.
BEYOND_WORST = 1e-6
#: Against a linearised worst case, RSS or Monte Carlo RMS of 0 (at most :data:`SHARE_FLOOR`) a difference beyond
#: this [m or rad] is warned about, in its absolute value: the samples' second-order 0.01 um of horizontal error under
#: the zero offsets alone at zero tilt was warned "by inf %" of the worst case 0, "by 100 %" of the RSS 0.
NONLINEAR_FLOOR = 1e-7
#: The most poses of a budget (samples x stations: each keeps its 9 error components for the percentiles, 72 bytes;
#: evaluated in chunks of :data:`~.monte_carlo.CHUNK_POSES`).
MAX_POSES = 5_000_000


@dataclass(frozen=True)
class Budget:
    """Accuracy budget of ``N`` stations (SI units; module docstring).

    Attributes:
        q: rod lengths of the stations ``(N, 3)``; labels: their names; tool: the tool point of each station in
            ``gpr_platform`` ``(N, 3)``; frame: the frame whose axes the errors are given in.
        sources: names of the error sources, in the order of the share arrays.
        rss, worst: per quantity ``(N,)``, linearised; shares: per quantity ``(N, len(sources))``.
        samples, seed, percentiles: the Monte Carlo settings; mc: per quantity ``(N, len(percentiles))`` percentiles
            of ``|v|``; mc_rms, mc_max: per quantity ``(N,)``, the RMS and the largest ``|v|`` of the samples.
        mean, std: linearised mean and standard deviation of each component of ``v`` ``(N, 9)``;
            mc_mean, mc_std: the same from the samples.
        warnings: where the linearised RSS and the Monte Carlo RMS differ by more than :data:`AGREEMENT` and the
            samples' scatter (:data:`SCATTERS`), and where a sample's error exceeds the linearised worst case.
        kept: per quantity the Monte Carlo's ``|v|`` ``(samples, K)`` of the first ``K`` stations (``keep_samples``
            of :func:`accuracy_budget`; empty without): the samples ``mc`` summarises, for a plot.
        compensated: the tolerated parameters a calibration held and compensated through the calibrated ones (its
            alias: their sources are their effects net of it); empty without an alias.
    """

    q: Array
    labels: tuple[str, ...]
    tool: Array
    frame: str
    sources: tuple[str, ...]
    rss: dict[str, Array]
    worst: dict[str, Array]
    shares: dict[str, Array]
    samples: int
    seed: int
    percentiles: tuple[float, ...]
    mc: dict[str, Array]
    mc_rms: dict[str, Array]
    mc_max: dict[str, Array]
    mean: Array
    std: Array
    mc_mean: Array
    mc_std: Array
    warnings: tuple[str, ...] = ()
    kept: dict[str, Array] = field(default_factory=dict)
    compensated: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        """Plain data for JSON: per station, per quantity ``rss``, ``worst``, ``shares`` (by source) and, with
        samples, ``monte_carlo`` (``p<percentile>``, ``rms`` and ``max``), with the unit; with a calibration's alias
        ``compensated``, the held parameters it compensates."""
        stations = []
        for i, label in enumerate(self.labels):
            quantities = {}
            for name, (_, unit) in QUANTITIES.items():
                quantities[name] = {'unit': unit, 'rss': float(self.rss[name][i]),
                                    'worst': float(self.worst[name][i]),
                                    'shares': dict(zip(self.sources, self.shares[name][i].tolist(), strict=True))}
                if self.samples:
                    mc = {f'p{p:g}': float(self.mc[name][i, k]) for k, p in enumerate(self.percentiles)}
                    quantities[name]['monte_carlo'] = mc | {'rms': float(self.mc_rms[name][i]),
                                                            'max': float(self.mc_max[name][i])}
            stations.append({'label': label, 'q': self.q[i].tolist(), 'tool': self.tool[i].tolist(),
                             'quantities': quantities})
        out = {'frame': self.frame, 'samples': self.samples, 'seed': self.seed, 'percentiles': list(self.percentiles),
               'sources': list(self.sources), 'stations': stations, 'warnings': list(self.warnings)}
        return out | ({'compensated': list(self.compensated)} if self.compensated else {})


@dataclass(frozen=True)
class _Source:
    """One error source: its sensitivities ``G (N, 9, k)`` and what is known about ``x`` (length ``k``)."""

    name: str
    G: Array
    mean: Array                    # (k,)
    cov: Array                     # (k, k)
    kind: str                      # 'interval', 'ellipsoid' (3 sigma) or 'ball'
    half: Array                    # interval half-widths (k,) or the ball radius (1,)
    centre: Array                  # interval centres (k,) (zeros for the other kinds)


def _with_tool(J: Array, rot: Array, tool: Array, frame: Array) -> Array:
    """Rows ``(N, 9, k)``: pose sensitivities ``(N, 6, k)`` and the tool point's ``dp + phi x (R t)`` (tool points
    ``(N, 3)``), each 3-vector turned into the report's frame (``frame``, a rotation ``(3, 3)``)."""
    a = np.einsum('nij,nj->ni', rot, tool)                            # (N, 3)
    cross = np.cross(J[:, 3:, :].transpose(0, 2, 1), a[:, None, :]).transpose(0, 2, 1)  # phi x a
    G = np.concatenate([J, J[:, :3, :] + cross], axis=1).reshape(J.shape[0], 3, 3, -1)
    return np.asarray(np.einsum('ij,nbjk->nbik', frame, G).reshape(J.shape[0], 9, -1), dtype=np.float64)


def _interval(name: str, G: Array, t: Tolerance, about: float = 0.0) -> _Source:
    """The source of a :class:`Tolerance` (one scalar deviation) with sensitivities ``G (N, 9, 1)`` taken at the
    deviation ``about`` (its mean: the point the budget is linearised at)."""
    lo, hi = t.bounds
    return _Source(name, G, np.array([t.mean - about]), np.array([[t.std ** 2]]), 'interval',
                   np.array([0.5 * (hi - lo)]), np.array([0.5 * (lo + hi) - about]))


def _systematic(pose0: tuple[Array, Array], pose_c: tuple[Array, Array], tool: Array, frame: Array) -> _Source:
    """The exact difference ``(N, 9)`` of the poses (and tool points) at the linearisation point and at the
    prediction's parameters: a fixed deviation (an interval of zero width about it)."""
    e = pose_error(pose_c[0], pose_c[1], pose0[0], pose0[1])
    e_tool = pose_c[0] + np.einsum('nij,nj->ni', pose_c[1], tool) - pose0[0] - np.einsum('nij,nj->ni', pose0[1], tool)
    v = np.einsum('ij,nbj->nbi', frame, np.stack([e[:, :3], e[:, 3:], e_tool], axis=1)).reshape(-1, 9, 1)
    return _Source('systematic', v, np.ones(1), np.zeros((1, 1)), 'interval', np.zeros(1), np.ones(1))


def _sources(model: PoseModel, theta: Array, Q: Array, rot: Array, tool: Array, frame: Array,
             tols: list[Tolerance | None], table: ToleranceTable, calibrated: Calibrated | None) -> list[_Source]:
    """The sources, their sensitivities taken at ``theta`` (the linearisation point: each tolerated parameter at
    its mean). A held parameter of the calibration's alias ``(held, A)`` moves the pose by ``G_h - G_f A[:, h]``:
    the calibration that held it absorbed ``A dh`` into the fitted parameters (``G_f`` their sensitivities)."""
    params = model.parameters
    cal_idx = calibrated[0] if calibrated is not None else np.zeros(0, dtype=np.int64)
    cols = [j for j, t in enumerate(tols) if t is not None and j not in set(cal_idx.tolist())]
    alias = {int(h): k for k, h in enumerate(calibrated[2][0])} if calibrated is not None and \
        calibrated[2] is not None else {}
    out: list[_Source] = []
    if cols or cal_idx.size:
        J = _with_tool(pose_jacobian(model, theta, Q, np.array(cols + cal_idx.tolist(), dtype=int)), rot, tool,
                       frame)
        G_f = J[:, :, len(cols):]
        for c, j in enumerate(cols):
            t = tols[j]
            assert t is not None
            G = J[:, :, c:c + 1]
            if j in alias:
                assert calibrated is not None and calibrated[2] is not None
                G = G - G_f @ calibrated[2][1][:, alias[j]:alias[j] + 1]
            out.append(_interval(params[j].name, G, t, t.mean if abs(t.mean) > 1e-9 * t.std else 0.0))
        if cal_idx.size:
            assert calibrated is not None
            out.append(_Source('calibration', G_f, np.zeros(cal_idx.size), calibrated[1], 'ellipsoid',
                               np.zeros(0), np.zeros(cal_idx.size)))
    if table.rod_length is not None:
        Jq = _with_tool(rod_jacobian(model, theta, Q), rot, tool, frame)
        out += [_interval(f'rod_length{k + 1}', Jq[:, :, k:k + 1], table.rod_length) for k in range(3)]
    if max(table.joint_clearance) > 0:
        Jd = displacement_jacobian(model, theta, Q)                 # (N, 6, 3, 3)
        for k, radius in enumerate(table.joint_clearance):
            if radius > 0:
                Gk = _with_tool(np.ascontiguousarray(Jd[:, :, k, :]), rot, tool, frame)
                out.append(_Source(f'joint_clearance{k + 1}', Gk, np.zeros(3), np.eye(3) * radius ** 2 / 5.0, 'ball',
                                   np.array([radius]), np.zeros(3)))
    return out


def _worst(src: list[_Source], comps: tuple[int, ...]) -> Array:
    """``max |v|`` over the sources' bounds for the components ``comps`` (1-D exactly, 2-D by the support
    function on :data:`DIRECTIONS` directions, made a bound by ``1 / cos(pi / DIRECTIONS)``)."""
    if len(comps) == 1:
        U = np.array([[1.0], [-1.0]])
    else:
        a = 2.0 * np.pi * np.arange(DIRECTIONS) / DIRECTIONS
        U = np.stack([np.cos(a), np.sin(a)], axis=-1)
    h: Any = 0.0
    for s in src:
        g = s.G[:, list(comps), :]                                   # (N, d, k)
        ug = np.einsum('ud,ndk->nuk', U, g)                          # (N, U, k)
        if s.kind == 'interval':
            h = h + ug @ s.centre + np.abs(ug) @ s.half
        elif s.kind == 'ball':
            h = h + s.half[0] * np.linalg.norm(ug, axis=-1)
        else:
            h = h + 3.0 * np.sqrt(np.maximum(np.einsum('nuk,kl,nul->nu', ug, s.cov, ug), 0.0))
    best = np.max(h, axis=1)
    return np.asarray(best if len(comps) == 1 else best / math.cos(math.pi / DIRECTIONS), dtype=np.float64)


def _check_options(N: int, samples: int, tool: ArrayLike, frame_rotation: ArrayLike | None,
                   percentiles: Sequence[float], labels: Sequence[str] | None
                   ) -> tuple[Array, Array, tuple[float, ...], tuple[str, ...]]:
    """The checked tool points ``(N, 3)``, frame rotation, percentiles and station labels of
    :func:`accuracy_budget`."""
    if N > MAX_STATIONS:
        raise InputError(f'{N} stations; allowed: at most {MAX_STATIONS}')
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 0 <= samples <= MAX_SAMPLES:
        raise InputError(f'samples = {samples!r}; allowed: an integer from 0 to {MAX_SAMPLES}')
    if samples * N > MAX_POSES:
        raise InputError(f'{samples} samples x {N} stations = {samples * N} poses; allowed: at most {MAX_POSES} '
                         '(fewer samples)')
    try:
        tool_v = np.asarray(tool, dtype=float)
    except (TypeError, ValueError, OverflowError):
        tool_v = np.full(1, np.nan)
    if tool_v.shape not in ((3,), (N, 3)) or not np.all(np.isfinite(tool_v)):
        raise InputError(f'tool must be 3 finite coordinates [m] (one point, or one per station: shape ({N}, 3)); '
                         f'got shape {tool_v.shape}, {tool_v.ravel()[:3].tolist()}')
    check_tool(tool_v)   # the reach of a tool point (core.inverse.TOOL_REACH from the platform origin)
    R = np.eye(3) if frame_rotation is None else rotation_matrices(frame_rotation, 'frame_rotation')[0]
    if frame_rotation is not None and np.shape(frame_rotation) != (3, 3):   # converted above: a shape it has
        raise InputError(f'frame_rotation must be one rotation matrix (3, 3); got shape {np.shape(frame_rotation)}')
    pct = tuple(plain_number(p) for p in percentiles) if isinstance(percentiles, Sequence | np.ndarray) and not \
        isinstance(percentiles, str) else ()
    if not pct or not all(0.0 <= p <= 100.0 for p in pct):
        raise InputError(f'percentiles {brief(percentiles)}; allowed: numbers from 0 to 100')
    labels_t = tuple(str(x) for x in labels) if labels is not None else tuple(str(i + 1) for i in range(N))
    if len(labels_t) != N:
        raise InputError(f'{len(labels_t)} labels for {N} stations')
    return np.array(np.broadcast_to(tool_v, (N, 3))), R, pct, labels_t


def accuracy_budget(model: PoseModel, Q: ArrayLike, table: ToleranceTable, tool: ArrayLike = (0.0, 0.0, 0.0),
                    samples: int = 10_000, seed: int = 0, theta: ArrayLike | None = None,
                    calibrated: tuple[ArrayLike, ...] | None = None, labels: Sequence[str] | None = None,
                    percentiles: Sequence[float] = (50.0, 95.0, 99.0), frame: str = 'gpr_base',
                    frame_rotation: ArrayLike | None = None, progress: StageProgress | None = None,
                    keep_samples: int = 0) -> Budget:
    """The accuracy budget of ``model`` at the stations ``Q (N, 3)`` [m] (module docstring).

    Args:
        table: the tolerance table (:func:`~.tolerances.load_tolerances`).
        tool: tool point in ``gpr_platform`` [m]: one ``(3,)``, or one per station ``(N, 3)`` (a wafer centre).
        frame, frame_rotation: the errors' 3-vectors are given in the axes of ``frame``, ``v = R v_base`` with
            ``R = frame_rotation`` (``gpr_base`` in that frame, e.g. the world's; default: ``gpr_base`` itself).
        samples: Monte Carlo samples (0: linearised only); seed: of ``numpy.random.default_rng``.
        theta: the model's parameter values the machine is predicted with (default nominal; after a
            calibration, its estimate).
        calibrated: ``(indices, covariance)`` of calibrated parameters (e.g. ``CalibrationResult.fitted`` and
            ``.covariance``, or a plan's): their deviation is normal with that covariance, in place of the table;
            or ``(indices, covariance, (held_indices, A))`` with the alias of the parameters the calibration held
            (a plan's ``held_indices`` and ``alias``): a held parameter keeps its table tolerance, and the
            calibration absorbs its deviation ``dh`` into the calibrated ones, which deviate by ``n - A dh``
            (``n`` normal with the covariance); without the alias the held ones are independent of them.
        labels: station names (default ``1..N``).
        progress: hears the share of the Monte Carlo's samples done (:func:`~.monte_carlo.monte_carlo`).
        keep_samples: keep the Monte Carlo's samples of the first ``keep_samples`` stations (``Budget.kept``).

    Raises:
        InputError: bad shapes or values, too many samples or stations, joint play for a model without it, no error
            source at all (:func:`~.budget_inputs.check_sources`: every error would be 0).
        LimitError: a station outside the machine's limits, for a model with a ``config``
            (:func:`~.budget_inputs.check_stations`).
        ConfigError: the table names a parameter the model does not have.
    """
    Qa = as_configurations(Q, 'stations')
    N = Qa.shape[0]
    tool_v, R, pct, labels_t = _check_options(N, samples, tool, frame_rotation, percentiles, labels)
    seed = random_seed(seed)
    params = pose_model(model).parameters
    P = len(params)
    th = params.nominal if theta is None else float_array(theta, 'theta', f'{P} finite parameter values')
    th = finite_vector(th, 'theta', P)   # a NaN named, not the shape that was right
    tols = table.bind(params)
    cal = None if calibrated is None else check_calibrated(calibrated, P)
    if isinstance(keep_samples, (bool, np.bool_)) or not isinstance(keep_samples, (int, np.integer)) or \
            keep_samples < 0:
        raise InputError(f'keep_samples = {brief(keep_samples)}; allowed: an integer >= 0 (the samples of that many '
                         'first stations are kept)')
    check_stations(model, Qa, labels_t)
    if max(table.joint_clearance) > 0 and not model.supports_displacement:
        raise InputError(f'{table.source}: joint_clearance needs a model with per-joint geometry; '
                         f'{type(model).__name__} cannot displace its joints (set joint_clearance: 0)')
    check_sources(table, tols, cal)
    pos0, rot0 = evaluate(model, th, Qa)
    # Linearised where the tolerances are: each tolerated parameter at its mean (a kappa range's centre, not the
    # file's kappa), the difference to the prediction's parameters taken exactly ('systematic').
    cal_set = set(cal[0].tolist()) if cal is not None else set()
    shift = np.array([t.mean if t is not None and j not in cal_set and abs(t.mean) > 1e-9 * t.std else 0.0
                      for j, t in enumerate(tols)])     # (a symmetric range's mean is its rounding: none)
    if cal is not None and cal[2] is not None:   # where the calibration puts the fitted ones: -A (held means)
        shift[cal[0]] -= cal[2][1] @ shift[cal[2][0]]
    lower, upper = params.bounds
    th_c = np.clip(th + shift, lower, upper)
    with drawn_from(table):      # a range's centre may break the triangles that each end keeps
        pos_c, rot_c = (pos0, rot0) if not np.any(shift) else evaluate(model, th_c, Qa)
        src = _sources(model, th_c, Qa, rot_c, tool_v, R, tols, table, cal)
    if np.any(shift):
        src.append(_systematic((pos0, rot0), (pos_c, rot_c), tool_v, R))
    names = tuple(s.name for s in src)
    mean = np.zeros((N, 9))
    var = np.zeros((N, 9))
    contrib = np.zeros((N, 9, len(src)))      # each source's E-contribution per component
    for i, s in enumerate(src):
        m_i = s.G @ s.mean
        mean += m_i
        c = np.einsum('nak,kl,nal->na', s.G, s.cov, s.G)
        var += c
        contrib[:, :, i] = c
    for i, s in enumerate(src):                # cross terms of the means, so that shares sum to 1
        contrib[:, :, i] += (s.G @ s.mean) * mean
    rss, worst, shares = {}, {}, {}
    for name, (comps, _) in QUANTITIES.items():
        total = np.sum(mean[:, comps] ** 2 + var[:, comps], axis=1)
        rss[name] = np.sqrt(total)
        worst[name] = _worst(src, comps) if src else np.zeros(N)
        with np.errstate(invalid='ignore', divide='ignore'):  # no shares of an error that is rounding only
            shares[name] = np.where(total[:, None] > SHARE_FLOOR ** 2,
                                    contrib[:, comps, :].sum(1) / total[:, None], 0.0)
    mc, mc_rms, mc_max, max_inside, mc_mean, mc_std, kept = monte_carlo(
        model, th, Qa, (pos0, rot0), tool_v, R, tols, cal, table, samples, seed, pct, QUANTITIES, progress,
        min(int(keep_samples), N))
    return Budget(q=Qa, labels=labels_t, tool=tool_v, frame=str(frame), sources=names, rss=rss, worst=worst,
                  shares=shares, samples=int(samples), seed=seed, percentiles=pct, mc=mc, mc_rms=mc_rms,
                  mc_max=mc_max, mean=mean, std=np.sqrt(var), mc_mean=mc_mean, mc_std=mc_std,
                  warnings=(_few(samples, pct) + _warnings(labels_t, rss, mc_rms, worst, max_inside, samples)
                            if samples else ()),
                  kept=kept, compensated=_compensated(params.names, tols, cal))


def _compensated(names: Sequence[str], tols: list[Tolerance | None], cal: Calibrated | None) -> tuple[str, ...]:
    """The names of the tolerated parameters held by a calibration with an alias (:attr:`Budget.compensated`)."""
    held = [] if cal is None or cal[2] is None else cal[2][0].tolist()
    return tuple(names[j] for j in sorted(held) if tols[j] is not None)


def _few(samples: int, percentiles: tuple[float, ...]) -> tuple[str, ...]:
    """A warning where the Monte Carlo's highest percentile ``p`` has fewer than one sample beyond it (``samples (1 -
    p / 100) < 1``): it is then the largest sample or an interpolation between the largest two, not the percentile."""
    top = max(percentiles, default=0.0)
    need = math.ceil(100.0 / (100.0 - top) - 1e-9) if top < 100.0 else None
    if need is None or samples >= need:
        return ()
    many = samples != 1
    return (f'{samples} Monte Carlo sample{"s leave" if many else " leaves"} none beyond {"their" if many else "its"} '
            f'p{top:g} (it is {"their largest or between their largest two" if many else "that sample"}); at least '
            f'{need} resolve it',)


def _warnings(labels: tuple[str, ...], rss: dict[str, Array], mc_rms: dict[str, Array], worst: dict[str, Array],
              top_inside: dict[str, Array], samples: int) -> tuple[str, ...]:
    """A warning for each station and quantity whose linearised RSS and Monte Carlo RMS differ by more than
    :data:`AGREEMENT` of the Monte Carlo's and by more than :data:`SCATTERS` times its scatter over ``samples`` about
    the RSS, then for each where the error of a sample whose every draw lies within the worst case's bounds
    (``top_inside``, the largest) exceeds the linearised worst case by more than :data:`BEYOND_WORST` of it (the
    worst case then bounds the linearised error only; a normal draw beyond its 3 sigma lies beyond what the worst
    case covers, whatever the model); each where either number is above :data:`SHARE_FLOOR` times 1000; against a
    worst case, an RSS or an RMS of 0, each where the other number differs by more than :data:`NONLINEAR_FLOOR`
    (stated in the absolute difference)."""
    disagree, beyond = [], []
    scatter = SCATTERS / math.sqrt(2.0 * samples)
    for name, (_, unit) in QUANTITIES.items():
        a, b, w, top = rss[name], mc_rms[name], worst[name], top_inside[name]
        off = np.where(np.minimum(a, b) <= SHARE_FLOOR, np.abs(a - b) > NONLINEAR_FLOOR,
                       (np.abs(a - b) > np.maximum(AGREEMENT * b, scatter * a))   # the RMS scatters about the RSS
                       & (np.maximum(a, b) > 1e3 * SHARE_FLOOR))
        over = np.where(w <= SHARE_FLOOR, top - w > NONLINEAR_FLOOR,
                        (top > w * (1.0 + BEYOND_WORST)) & (np.maximum(w, top) > 1e3 * SHARE_FLOOR))
        u, at = 'um' if unit == 'm' else 'urad', f'{name.replace("_", " ")}: '
        disagree += [f'station {labels[i]}, {at}the linearised RSS {a[i] * 1e6:.4g} {u} and the Monte Carlo RMS '
                     f'{b[i] * 1e6:.4g} {u} differ by '
                     + (f'{100 * abs(a[i] - b[i]) / b[i]:.0f} % (more than '
                           f'{100 * max(AGREEMENT, scatter * a[i] / b[i]):.3g} %)'
                        if min(a[i], b[i]) > SHARE_FLOOR else
                        f'{abs(a[i] - b[i]) * 1e6:.4g} {u} (more than {NONLINEAR_FLOOR * 1e6:g} {u})')
                     + ': the model is not linear over these tolerances; the Monte Carlo is exact'
                     for i in np.flatnonzero(off)]
        beyond += [f'station {labels[i]}, {at}the Monte Carlo\'s largest error within the tolerances\' bounds '
                   f'{top[i] * 1e6:.4g} {u} exceeds the linearised worst case {w[i] * 1e6:.4g} {u} by '
                   + (f'{100 * (top[i] / w[i] - 1):.1f} %' if w[i] > SHARE_FLOOR else
                      f'{(top[i] - w[i]) * 1e6:.4g} {u} (more than {NONLINEAR_FLOOR * 1e6:g} {u})')
                   + ': the model is not linear over these tolerances, the worst case bounds the linearised error only'
                   for i in np.flatnonzero(over)]
    return tuple(disagree + beyond)

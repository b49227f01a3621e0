"""The imperfection budget of a checked program, judged as ``gpr verify`` judges its recording.

A stream of the program at ``rate`` (``trajectory_node``, :func:`~gpr_kinematics.robot.stream.robot_stream`) carries
per sample the platform's forward kinematics of its rods, and ``gpr verify``'s ``state.imperfection_budget`` fails a
sample whose largest joint displacement ``max_k |dl_k|`` [m] (the virtual joints' displacement of a joint centre,
Bratovanov & Sotirov) is not ``<= imperfection_budget``. :func:`judge_budget` computes that quantity at the stream's
samples ``t_k = k / rate`` (:func:`~gpr_kinematics.robot.grid.grid_times`) inside the moves and once per hold (every
sample of a hold has its waypoint's rods; a waypoint reached between two samples is not one), with the same forward
kinematics and the same limit. A program whose
samples in its moves exceed :data:`~gpr_kinematics.robot.timing.MAX_SAMPLES` (no stream at that rate exists) is
judged at at most that many instants, shared out as the slip check's (:func:`~.motion.move_counts`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..core import forward_batch
from ..robot.grid import check_rate, grid_between
from ..robot.plan import ProgramPlan, plan_samples
from ..robot.timing import MAX_SAMPLES, sample_at
from .margin import STREAM_RATE
from .motion import grid_within, move_counts

Array = NDArray[np.float64]


@dataclass(frozen=True)
class BudgetFinding:
    """The samples of one waypoint (the move into it and its hold) beyond the budget: the waypoint and its label, the
    first such instant [s], how many, the largest joint displacement [m] and its instant [s]."""

    waypoint: int
    label: str
    first: float
    samples: int
    displacement: float
    at: float


@dataclass(frozen=True)
class BudgetReport:
    """The budget [m], the rate [Hz], the instants judged, the largest joint displacement [m], its instant [s] and
    waypoint label, and the waypoints with samples beyond the budget (first first)."""

    budget: float
    rate: float
    instants: int
    max_displacement: float
    max_at: float
    max_label: str
    beyond: tuple[BudgetFinding, ...]


def _grid(a: float, b: float, rate: float, total: float) -> Array:
    """The stream's samples strictly inside ``(a, b)`` [s], as :func:`~gpr_kinematics.robot.grid.grid_times`
    ``(total, rate)`` makes them."""
    lo, hi, end = grid_between(total, rate, a, b, closed=False)
    k = np.arange(lo, hi, dtype=float) / rate
    return np.append(k, total) if end else k


def _held(a: float, b: float, rate: float, total: float, after: bool = False) -> tuple[float, int]:
    """The first of the stream's samples in the hold ``[a, b]`` [s] (``(a, b]`` ``after`` a hold that ended at
    ``a``: a move of no time between them, whose sample at ``a`` is that hold's) and how many fall in it, exactly
    those of :func:`~gpr_kinematics.robot.grid.grid_times` ``(total, rate)``, counted without making them (a hold of
    1e6 s); ``(a, 0)`` where none does."""
    lo, hi, end = grid_between(total, rate, a, b, closed=True)
    if after:
        lo = max(lo, grid_between(total, rate, a, b, closed=False)[0])
        hi, end = max(hi, lo), end and total > a
    return (lo / rate if hi > lo else total if end else a), hi - lo + int(end)


def budget_instants(plan: ProgramPlan, rate: float) -> tuple[Array, NDArray[np.int64]]:
    """The instants [s] :func:`judge_budget` evaluates (module docstring) and how many of the stream's samples each
    stands for: the stream's samples inside the moves (1 each), and the first sample of each hold (all of its
    samples; a waypoint reached between two samples has none)."""
    rate = check_rate(rate)
    t = plan.timing
    starts, ends = t.depart[:-1], t.arrive[1:]
    durations = np.maximum(ends - starts, 0.0)
    counts = move_counts(durations, rate, MAX_SAMPLES)
    after = np.r_[False, t.arrive[1:] <= t.depart[:-1]]   # two holds joined by a move of no time share a sample
    held = [_held(float(a), float(b), rate, t.total, bool(f))
            for a, b, f in zip(t.arrive.tolist(), t.depart.tolist(), after.tolist(), strict=True)]
    parts = [np.array([h[0] for h in held if h[1]])]
    weights = [np.array([h[1] for h in held if h[1]], dtype=np.int64)]
    for m in range(starts.shape[0]):
        if counts[m] >= rate * durations[m]:
            inside = _grid(float(starts[m]), float(ends[m]), rate, t.total)
        else:
            inside = grid_within(starts[m:m + 1], ends[m:m + 1], t.total, counts[m] / durations[m])
            inside = inside[(inside > starts[m]) & (inside < ends[m])]
        parts.append(inside)
        weights.append(np.ones(inside.shape, dtype=np.int64))
    times, w = np.concatenate(parts), np.concatenate(weights)
    order = np.argsort(times, kind='stable')
    return times[order], w[order]


def judge_budget(plan: ProgramPlan, rate: float = STREAM_RATE) -> BudgetReport:
    """The largest joint displacement at :func:`budget_instants` against the geometry's ``imperfection_budget``
    (one batch of forward kinematics of the rods; module docstring)."""
    times, weight = budget_instants(plan, rate)
    s = plan_samples(plan, sample_at(plan.timing, times))
    cfg = plan.robot.config
    disp = np.max(forward_batch(s.positions[:, :3], cfg, check_limits=False).joint_displacement, axis=1)
    seen = np.where(np.isnan(disp), np.inf, disp)
    k = int(np.argmax(seen))
    beyond = ~(disp <= cfg.imperfection_budget)       # NaN fails, as verify's value_check
    findings = []
    for w in np.unique(s.target[beyond]).tolist():
        sel = np.flatnonzero(beyond & (s.target == w))
        j = sel[int(np.argmax(seen[sel]))]
        findings.append(BudgetFinding(int(w), plan.labels[w], float(times[sel[0]]), int(weight[sel].sum()),
                                      float(disp[j]), float(times[j])))
    findings.sort(key=lambda f: f.first)
    return BudgetReport(cfg.imperfection_budget, float(rate), int(times.shape[0]), float(disp[k]), float(times[k]),
                        plan.labels[int(s.target[k])], tuple(findings))

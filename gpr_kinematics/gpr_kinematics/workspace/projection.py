"""Covering of a set given by equations, projected onto its output variables.

The set is ``S = {v in B : f_i(v) = c_i, lower_j <= g_j(v) <= upper_j}`` over all the mechanism's variables
(inputs, passive joints, outputs); its working area is the projection ``W`` of ``S`` onto the outputs.
The covering runs over the **output** boxes ``X`` (bisected down to ``delta`` as for any workspace), and each
``X`` carries the boxes ``Q`` of the other (passive) variables in which solutions may still lie:

1. every ``X x Q`` is contracted (:func:`~.contractor.contract`); a ``Q`` contracted to nothing is dropped,
   and an ``X`` left with no ``Q`` is **outside** ``W`` (proved: no solution has its outputs in ``X``);
2. an ``X`` is **inner** when, for one of its ``Q``, Newton at the midpoint finds a solution and the
   Krawczyk test (:func:`~.krawczyk.krawczyk`) proves that for *every* output point of ``X`` the equations
   have a solution in a box ``K`` of the solved variables (the other passive variables fixed at ``Q``'s
   midpoint), inside their ranges, on which every inequality certainly holds;
3. otherwise each ``Q`` whose scaled diameter exceeds ``passive_ratio`` times that of ``X`` is bisected
   (longest scaled edge); when none does, ``X`` is bisected (its ``Q`` go to both halves), or, below
   ``delta``, ``X`` is a **boundary** box.

So the outer approximation (inner plus boundary ``X``) contains ``W``, inner ``X`` lie in ``W``, and the
boundary boxes are thinner than ``delta``; the ``X`` form a partition of the initial output box, so volumes
add up.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .boxes import bisect, scaled_diameter
from .contractor import contract
from .covering import Step


@dataclass
class GroupFrontier:
    """Pending output boxes ``x`` (G, k, 2), each with its passive boxes: ``q`` (M, p, 2), ``gid`` (M,)
    the index of each passive box's output box (non-decreasing)."""

    x: np.ndarray
    q: np.ndarray
    gid: np.ndarray

    @property
    def size(self) -> int:
        return int(self.q.shape[0])

    def split(self, chunk: int) -> list[GroupFrontier]:
        """Chunks of whole groups holding about ``chunk`` passive boxes each."""
        if self.x.shape[0] == 0:
            return []
        counts = np.bincount(self.gid, minlength=self.x.shape[0])
        ends = np.cumsum(counts)
        parts = []
        g0 = 0
        while g0 < self.x.shape[0]:
            start = ends[g0] - counts[g0]
            g1 = int(np.searchsorted(ends, start + chunk, side='left')) + 1
            g1 = min(max(g1, g0 + 1), self.x.shape[0])
            b0, b1 = start, ends[g1 - 1]
            parts.append(GroupFrontier(self.x[g0:g1], self.q[b0:b1], self.gid[b0:b1] - g0))
            g0 = g1
        return parts

    def parts(self, n: int) -> list[GroupFrontier]:
        """``n`` contiguous parts of whole groups with about equal numbers of passive boxes."""
        return self.split(max(1, -(-self.size // n)))

    def join(self, parts: list[GroupFrontier]) -> GroupFrontier:
        xs, qs, gids = [self.x[:0]], [self.q[:0]], [self.gid[:0]]
        offset = 0
        for part in parts:
            xs.append(part.x)
            qs.append(part.q)
            gids.append(part.gid + offset)
            offset += part.x.shape[0]
        return GroupFrontier(np.concatenate(xs), np.concatenate(qs), np.concatenate(gids))

    def output_boxes(self) -> np.ndarray:
        return self.x

    def diameter(self, scale: np.ndarray) -> float:
        return float(scaled_diameter(self.x, scale).max()) if self.x.shape[0] else 0.0


def projection_step(model: Any, frontier: GroupFrontier, delta: float) -> Step:
    """Classify one chunk of output boxes with their passive boxes (see the module docstring)."""
    out, pas = model.output_index, model.passive_index
    G = frontier.x.shape[0]
    X = frontier.x[frontier.gid]
    n = len(model.variables)
    lo = np.empty((X.shape[0], n))
    hi = np.empty((X.shape[0], n))
    lo[:, out], hi[:, out] = X[:, :, 0], X[:, :, 1]
    lo[:, pas], hi[:, pas] = frontier.q[:, :, 0], frontier.q[:, :, 1]
    clo, chi, empty = contract(model.tape, lo, hi, model.contract_lower, model.contract_upper, model.sweeps)
    alive = ~empty
    has_box = np.bincount(frontier.gid[alive], minlength=G) > 0
    inner_g = np.zeros(G, dtype=bool)
    if np.any(alive):
        # the inner test keeps the whole output box X (the contracted X part is for this Q only)
        tlo, thi = clo[alive].copy(), chi[alive].copy()
        tlo[:, out], thi[:, out] = lo[alive][:, out], hi[alive][:, out]
        proved = model.inner_test(tlo, thi, frontier.gid[alive])
        inner_g[frontier.gid[alive][proved]] = True
    rest = has_box & ~inner_g
    keep = alive & rest[frontier.gid]
    q = np.stack([clo[keep][:, pas], chi[keep][:, pas]], axis=2)
    g = frontier.gid[keep]
    xdiam = scaled_diameter(frontier.x, model.output_scale)
    need = (scaled_diameter(q, model.passive_scale) > model.passive_ratio * xdiam[g] if q.shape[1]
            else np.zeros(q.shape[0], dtype=bool))
    return split_groups(frontier.x, q, g, need, rest, delta, model.output_scale, model.passive_scale, inner_g,
                        has_box, model.max_passive)


def split_groups(
    x: np.ndarray,
    q: np.ndarray,
    g: np.ndarray,
    need: np.ndarray,
    rest: np.ndarray,
    delta: float,
    x_scale: np.ndarray,
    q_scale: np.ndarray,
    inner: np.ndarray,
    has_box: np.ndarray,
    cap: int,
) -> Step:
    """The outcome of one level for groups ``x`` (G, k, 2) whose undecided (``rest``) groups keep the passive
    boxes ``q`` (of group ``g``): groups with a passive box to refine (``need``) refine it and keep their X,
    unless that would give them more than ``cap`` passive boxes (then they keep them as they are: coarser
    boxes still hold every solution); the others bisect X, or, below ``delta``, are boundary boxes. ``inner``
    groups and those without any passive box (``~has_box``: outside) are decided."""
    G = x.shape[0]
    xdiam = scaled_diameter(x, x_scale)
    growth = np.bincount(g, minlength=G) + np.bincount(g[need], minlength=G)
    need = need & (growth <= cap)[g]
    refine = np.zeros(G, dtype=bool)
    refine[g[need]] = True
    split_x = rest & ~refine & (xdiam >= delta)
    boundary = rest & ~refine & ~split_x
    return Step(x[inner], x[boundary], x[~has_box],
                _children(x, q, g, need, refine, split_x, x_scale, q_scale), int(g.size))


def _children(
    x: np.ndarray, q: np.ndarray, g: np.ndarray, need: np.ndarray, refine: np.ndarray, split_x: np.ndarray,
    x_scale: np.ndarray, q_scale: np.ndarray,
) -> GroupFrontier:
    """The next level: refined groups keep their X and bisect their large Q; split groups become two X
    halves, each with all the group's Q. Groups stay in order, and the Q of a group in their order."""
    inc = np.where(split_x, 2, np.where(refine, 1, 0))
    new_start = np.cumsum(inc) - inc
    xs = bisect(x[split_x], x_scale)                        # [left, right] per split group
    new_x = np.empty((int(np.count_nonzero(refine) + 2 * np.count_nonzero(split_x)), x.shape[1], 2))
    new_x[new_start[refine]] = x[refine]
    new_x[new_start[split_x]] = xs[0::2]
    new_x[new_start[split_x] + 1] = xs[1::2]
    # Q of refined groups: the large ones bisected in place
    in_ref = refine[g]
    qa, ga, na = q[in_ref], g[in_ref], need[in_ref]
    halves = bisect(qa[na], q_scale) if qa.shape[1] else qa[na]
    reps = np.where(na, 2, 1)
    q_ref = np.repeat(qa, reps, axis=0)
    first = np.cumsum(reps) - reps
    q_ref[first[na]] = halves[0::2]
    q_ref[first[na] + 1] = halves[1::2]
    g_ref = np.repeat(new_start[ga], reps)
    # Q of split groups: to both halves
    in_split = split_x[g]
    qs, gs = q[in_split], g[in_split]
    all_q = np.concatenate([q_ref, qs, qs])
    all_g = np.concatenate([g_ref, new_start[gs], new_start[gs] + 1])
    order = np.argsort(all_g, kind='stable')
    return GroupFrontier(new_x, all_q[order], all_g[order].astype(np.int64))

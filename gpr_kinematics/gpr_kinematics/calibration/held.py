"""The parameters an identification holds: the a-priori bound of their bias (:func:`prior_bound`), and those a
tolerance table held (:func:`table_held`), which the gate's chi-square refusal names (:func:`with_table_held`).

A table's tolerances are the a-priori uncertainties the measurements must beat (:mod:`.identifiability`): a
parameter the poses see, but less well than its tolerance, is held at nominal, and so is one of tolerance 0. Within
its tolerance it may still be off nominal by as much, which the chi-square counts: a trial's 40 planned poses of
machines drawn from a table (rods 40 um, joints 25 um) failed the gate at 1.38 against 1.32 with 9 parameters held,
and the refusal named columns, frames and noise but not those parameters.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .identifiability import Identifiability, analyse
from .model import ParameterSet
from .quality import Gate

Array = NDArray[np.float64]

#: The held parameters a refusal names before ``and N more``.
HELD_SHOWN = 4


def prior_bound(params: ParameterSet, scale: Array, bound: ArrayLike | None) -> Array:
    """Each parameter's a-priori worst-case deviation (coordinates): ``bound`` where given (a tolerance table's;
    ``nan``: none), else 3 a-priori standard deviations; within the coordinate's range."""
    b = 3.0 * scale if bound is None else np.where(np.isnan(np.asarray(bound, dtype=float)), 3.0 * scale, bound)
    lo, hi = params.bounds
    return np.asarray(np.minimum(b, np.maximum(params.nominal - lo, hi - params.nominal)), dtype=np.float64)


@dataclass(frozen=True)
class TableHeld:
    """What a tolerance table held at nominal of the parameters the user left free: ``seen`` those the poses
    determine less well than their tolerances (held by the threshold; without the table they are fitted), with
    the scaled singular values of their combinations ``values``; ``exact`` those of tolerance 0."""

    seen: tuple[str, ...] = ()
    values: tuple[float, ...] = ()
    exact: tuple[str, ...] = ()
    threshold: float = 1.0

    def words(self) -> str:
        """The sentence the chi-square refusal adds ('' when the table held nothing)."""
        if not self.seen and not self.exact:
            return ''
        seen = (f'{_names(self.seen)} (the poses see them less well than their tolerances: scaled singular values '
                f'{min(self.values):.3g} to {max(self.values):.3g}, under the threshold {self.threshold:g}; within '
                'their tolerances they may still be off nominal by as much, which the chi-square counts)'
                if self.seen else '')
        exact = (f'{_names(self.exact)} (a tolerance of 0: held exactly at nominal, which the chi-square counts if '
                 'they are not there)' if self.exact else '')
        todo = ' or '.join(w for w in ('lower --threshold below their scaled singular values' if self.seen else '',
                                       'widen their tolerances in the table') if w)
        which = '; '.join(w for w in (seen, exact) if w)
        return f'Held at nominal by the --tolerances table, not by --free: {which}. To fit them, {todo}.'


def _names(names: tuple[str, ...]) -> str:
    """``a, b, c, d and 3 more`` (:data:`HELD_SHOWN`)."""
    more = f' and {len(names) - HELD_SHOWN} more' if len(names) > HELD_SHOWN else ''
    return ', '.join(names[:HELD_SHOWN]) + more


def table_held(params: ParameterSet, J_scaled: Array, free_idx: NDArray[np.int64], scale: Array,
               ident: Identifiability, chosen: NDArray[np.bool_], mask: NDArray[np.bool_]) -> TableHeld:
    """The parameters a table held (:class:`TableHeld`): ``ident``'s held ones that the analysis of the same
    Jacobian ``J_scaled`` of the columns ``free_idx``, scaled by the model's own a-priori uncertainties instead of
    the table's ``scale``, fits; and those the user's ``chosen`` (``--free``) left free that ``mask`` (what is
    free after the table's tolerances of 0) fixes. Nothing without a table (``scale`` the model's)."""
    exact = tuple(params[int(j)].name for j in np.flatnonzero(chosen & ~mask))
    own = params.scale[free_idx] / scale[free_idx]
    if np.all(own == 1.0) or not ident.held:
        return TableHeld(exact=exact, threshold=ident.threshold)
    names = [params[int(j)].name for j in free_idx]
    without = set(analyse(J_scaled * own, names, ident.threshold).held)
    combos = [c for c in ident.combinations if c.held not in without]
    return TableHeld(tuple(c.held for c in combos), tuple(c.singular_value for c in combos), exact, ident.threshold)


def with_table_held(gate: Gate, held: Callable[[], TableHeld]) -> Gate:
    """``gate`` with :meth:`TableHeld.words` of ``held()`` after its chi-square's where that failed (the analysis it
    takes is made only then)."""
    check = next((c for c in gate.checks if c.name == 'chi_square'), None)
    if check is None or check.passed:
        return gate
    words = held().words()
    if not words:
        return gate
    said = replace(check, detail=f'{check.detail} {words}')
    return Gate(tuple(said if c is check else c for c in gate.checks))

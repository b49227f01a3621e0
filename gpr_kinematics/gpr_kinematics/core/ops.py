"""Elementary operations for kernels that run on numpy arrays (batches) or on Python floats.

The kinematics kernels are written component by component with these operations only, so the same
formulas evaluate a batch of ``N`` poses in a few dozen vectorised numpy calls and a single pose in
plain float arithmetic (no per-call numpy overhead): one implementation, two drivers. The drivers
themselves (the Newton loops, the limit checks, the assembly of results) are written once too, with
:attr:`Ops.any` for "is any sample still active" and :attr:`Ops.vector` / :attr:`Ops.matrix` to turn
components into the result's arrays (``(3,)`` for one pose, ``(N, 3)`` for a batch).
"""
from __future__ import annotations

import math
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: A value of the kernels: a float (one pose) or an array ``(N,)`` of one value per sample (a batch) [SI units].
Value = float | NDArray[np.float64]
#: A condition of the kernels: a bool (one pose) or an array ``(N,)`` of them (a batch).
Mask = bool | NDArray[np.bool_]
#: An iteration count: an int (one pose) or an array ``(N,)`` of them (a batch).
Count = int | NDArray[np.int64]


@dataclass(frozen=True)
class Ops:
    """A namespace of element-wise functions and of the two ways of stacking components."""

    sqrt: Callable[[Value], Value]
    sin: Callable[[Value], Value]
    cos: Callable[[Value], Value]
    atan2: Callable[[Value, Value], Value]
    hypot: Callable[[Value, Value], Value]
    fabs: Callable[[Value], Value]
    maximum: Callable[[Value, Value], Value]
    where: Callable[[Mask, Value, Value], Value]
    #: Logical not of a bool or of an array of them.
    not_: Callable[[Mask], Mask]
    #: True when any element is true (a float bool, or an array of them).
    any: Callable[[Mask], bool]
    #: True when every element is true.
    all: Callable[[Mask], bool]
    #: Components ``[c_0, .., c_k-1]`` -> an array ``(k,)`` (floats) or ``(N, k)`` (arrays of length N).
    vector: Callable[[Sequence[Value]], NDArray[np.float64]]
    #: Rows of components -> ``(k, m)`` or ``(N, k, m)``.
    matrix: Callable[[Sequence[Sequence[Value]]], NDArray[np.float64]]


def _where(cond: Mask, a: Value, b: Value) -> Value:
    return a if cond else b


def _stack(components: Sequence[Value]) -> NDArray[np.float64]:
    return np.stack(components, axis=-1)


def _stack_rows(rows: Sequence[Sequence[Value]]) -> NDArray[np.float64]:
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def _any(a: Mask) -> bool:
    return bool(np.any(a))


def _all(a: Mask) -> bool:
    return bool(np.all(a))


SCALAR = Ops(math.sqrt, math.sin, math.cos, math.atan2, math.hypot, math.fabs, max, _where, operator.not_, bool,
             bool, np.array, np.array)
ARRAY = Ops(np.sqrt, np.sin, np.cos, np.arctan2, np.hypot, np.abs, np.maximum, np.where, np.logical_not, _any,
            _all, _stack, _stack_rows)

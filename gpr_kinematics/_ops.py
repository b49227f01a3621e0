"""Elementary operations for kernels that run on numpy arrays (batches) or on Python floats.

The kinematics kernels are written component by component with these operations only, so the same
formulas evaluate a batch of ``N`` poses in a few dozen vectorised numpy calls and a single pose in
plain float arithmetic (no per-call numpy overhead): one implementation, two drivers.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Ops:
    """A namespace of element-wise functions."""

    sqrt: Callable[[Any], Any]
    sin: Callable[[Any], Any]
    cos: Callable[[Any], Any]
    atan2: Callable[[Any, Any], Any]
    hypot: Callable[[Any, Any], Any]
    fabs: Callable[[Any], Any]
    maximum: Callable[[Any, Any], Any]
    where: Callable[[Any, Any, Any], Any]


def _where(cond: Any, a: Any, b: Any) -> Any:
    return a if cond else b


SCALAR = Ops(math.sqrt, math.sin, math.cos, math.atan2, math.hypot, abs, max, _where)
ARRAY = Ops(np.sqrt, np.sin, np.cos, np.arctan2, np.hypot, np.abs, np.maximum, np.where)

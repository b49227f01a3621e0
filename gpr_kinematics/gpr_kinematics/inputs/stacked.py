"""A read-only attribute that stacks one field of every item of a sequence attribute into an array.

``Arm.lower`` is the ``lower`` limit of each of the arm's joints, ``ParameterSet.nominal`` the nominal value of
each parameter: one descriptor instead of a property per field.

>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Joint:
...     lower: float
>>> @dataclass(frozen=True)
... class Chain:
...     joints: tuple[Joint, ...]
...     lower = Stacked('joints')
>>> Chain((Joint(-1.0), Joint(-2.5))).lower
array([-1. , -2.5])
"""
from __future__ import annotations

from typing import Any, overload

import numpy as np
from numpy.typing import NDArray


class Stacked:
    """``np.array([item.<name> for item in obj.<items>])`` as a read-only attribute named ``<name>`` (float64)."""

    def __init__(self, items: str) -> None:
        self.items = items
        self.field = ''

    def __set_name__(self, owner: type, name: str) -> None:
        self.field = name
        self.__doc__ = f'``{name}`` of every item of ``{self.items}``, stacked ``(n, ...)``.'

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> Stacked: ...

    @overload
    def __get__(self, obj: object, owner: type | None = None) -> NDArray[np.float64]: ...

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        return np.array([getattr(item, self.field) for item in getattr(obj, self.items)], dtype=float)

"""gpr_kinematics: kinematics of the GPR tilting Z axis with virtual joints, as a ROS 2 node suite.

The public entry points, in SI units (metres, radians)::

    from gpr_kinematics import forward, forward_batch, inverse, inverse_batch, compensate, load_config

They are the functions of :mod:`gpr_kinematics.core` (imported on first use, so that ``import gpr_kinematics.ros.env``
or a ROS node does not load what it does not need). The subpackages, from the bottom layer up (each imports only
the layers below it; ``docs/architecture.md``): :mod:`.inputs` (files, YAML, checks, units), :mod:`.core` (the
kinematics of the GPR), :mod:`.robot` and :mod:`.mechanisms`, :mod:`.workspace` and :mod:`.calibration`,
:mod:`.bags`, :mod:`.ros` (the ROS side without a ROS import), :mod:`.nodes` (the ROS 2 nodes), :mod:`.cli` (the
``gpr`` command). The papers are listed in ``docs/references.md``.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = '0.1.0'

#: The names this package exports (all from :mod:`gpr_kinematics.core`).
__all__ = ['GprConfig', 'compensate', 'forward', 'forward_batch', 'inverse', 'inverse_batch', 'load_config',
           'naive_forward', 'naive_inverse']

if TYPE_CHECKING:
    from .core import forward, forward_batch, inverse, inverse_batch, naive_forward, naive_inverse
    from .core.compensation import compensate
    from .core.config import GprConfig, load_config


def __getattr__(name: str) -> Any:
    """The public names of :data:`__all__`, imported from :mod:`gpr_kinematics.core` on first use (PEP 562)."""
    if name not in __all__:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    from . import core
    from .core import compensation, config
    value = getattr(core, name, None) or getattr(compensation, name, None) or getattr(config, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])

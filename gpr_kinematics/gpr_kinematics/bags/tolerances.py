"""Limits of the checks of ``gpr verify`` (SI units)."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

from ..errors import InputError, brief
from ..inputs.validation import plain_number


@dataclass(frozen=True)
class Tolerances:
    """Limits of the checks (SI units): agreement with the core (``position`` [m], ``angle`` [rad],
    ``virtual_joint`` [m or rad], ``length`` [m], ``residual`` [m], ``agreement`` for a state field without a
    rule of its own), agreement of the companion topics with the state (``consistency``), and the constants of
    ``stream.jump`` (see :mod:`.checks_stream`)."""

    position: float = 1e-9
    angle: float = 1e-9
    virtual_joint: float = 1e-9
    length: float = 1e-9
    residual: float = 1e-9
    agreement: float = 1e-9
    consistency: float = 1e-12
    jump_rot_factor: float = 1.01
    jump_pos: float = 1.0 / math.sqrt(3.0) + 0.05
    jump_x: float = 0.5
    jump_length: float = math.sqrt(2.0)
    jump_eps: float = 1e-12

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    def __post_init__(self) -> None:
        for name in self.names():
            value, most = getattr(self, name), LARGEST[name]
            if not 0.0 <= plain_number(value) <= most:  # 1e308 passed every recording
                raise InputError(f'tolerance {name} = {brief(value)} is invalid; allowed: a number from 0 to {most:g} '
                                 '(SI units: beyond it the check would pass anything)')

    def replace(self, **kw: float) -> Tolerances:
        values = {k: getattr(self, k) for k in self.names()}
        values.update(kw)
        return Tolerances(**values)


#: The largest value of each tolerance: 1 mm (1 mrad) for the agreement with the core, 10 for the constants of the
#: jump test (its factors are about 1), 1e-3 for its epsilon.
LARGEST: dict[str, float] = {**dict.fromkeys(('position', 'angle', 'virtual_joint', 'length', 'residual', 'agreement',
                                              'consistency', 'jump_eps'), 1e-3),
                             **dict.fromkeys(('jump_rot_factor', 'jump_pos', 'jump_x', 'jump_length'), 10.0)}

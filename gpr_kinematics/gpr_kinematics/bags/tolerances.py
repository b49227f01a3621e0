"""Limits of the checks of ``gpr verify`` (SI units)."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields


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

    def replace(self, **kw: float) -> Tolerances:
        values = {k: getattr(self, k) for k in self.names()}
        values.update(kw)
        return Tolerances(**values)

"""The clearance margin [m]: its default and the range allowed, and the rate the imperfection budget is judged at by
default, in a module of its own so that a command's help can print them without importing the clearance search
(docs/cell.md)."""
from __future__ import annotations

#: Default margin [m] below which a pair of bodies counts as a collision.
MARGIN = 0.002
#: The margins allowed [m] (:func:`~gpr_kinematics.safety.clearance.check_numbers`, the simulator's
#: ``clearance_margin``).
MARGIN_RANGE = (0.0, 1.0)
#: The rate [Hz] :func:`~gpr_kinematics.safety.budget.judge_budget` takes the samples of a stream at by default:
#: ``trajectory_node``'s default ``rate`` (and ``gpr program export``'s).
STREAM_RATE = 100.0

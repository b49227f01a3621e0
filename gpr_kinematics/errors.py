"""Exception classes of gpr_kinematics, and the exit status for unusable input.

Every error the package raises on purpose derives from :class:`GprError`, so a caller
(a ROS node, the CLI) can catch the package's errors without catching programming bugs.
"""

#: Exit status of the ``gpr`` command and of the nodes for input they cannot use (one line on stderr).
EXIT_BAD_INPUT = 2


class GprError(Exception):
    """Base class of the package's errors."""


class ConfigError(GprError, ValueError):
    """A configuration value is missing, malformed or out of its allowed range."""


class InputError(GprError, ValueError):
    """An argument is malformed: wrong shape, NaN or infinity, unknown name."""


class LimitError(InputError):
    """A request lies outside the machine's limits (stroke, tilt, joint ranges)."""


class ConvergenceError(GprError, ArithmeticError):
    """An iterative solver did not reach its tolerance within its iteration bound."""


class SingularityError(GprError, ArithmeticError):
    """A quantity was asked for at a configuration where it is not defined."""

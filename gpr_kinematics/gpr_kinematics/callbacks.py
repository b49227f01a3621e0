"""The callback a long computation reports its progress through (:data:`StageProgress`), below every layer that
reports (``safety``: a program's check; ``calibration``: reading measurements, a fit, an accuracy budget's Monte
Carlo) so that none imports it sideways from another; ``cli/progress.py``'s progress line is the one the ``gpr``
command passes."""
from __future__ import annotations

from collections.abc import Callable

#: A progress report: the stage (``'clearance'``, ``'slip'``, ``'reading rows'``, ...) and the share of it done,
#: in [0, 1].
StageProgress = Callable[[str, float], None]


def silent(stage: str, share: float) -> None:
    """The :data:`StageProgress` that reports nothing: a computation's own when its caller passes ``None``."""


def reporter(progress: StageProgress | None) -> StageProgress:
    """``progress``, or :func:`silent` when it is ``None``."""
    return progress if progress is not None else silent

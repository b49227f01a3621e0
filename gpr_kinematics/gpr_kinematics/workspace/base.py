"""The two things every workspace computation shares: the constraint model and the result.

A working area is ``W = {x in Q : lower_j <= g_j(x) <= upper_j for all j}`` (Posypkin, Rybak, Malyshev,
Gaponenko, "Approximation of the parallel robot working area using the method of nonuniform covering",
docs/references.md), approximated by two unions of boxes: the **inner** boxes (every constraint certainly holds on
them) and the **boundary** boxes (undecided, diameter below ``delta``); inner plus boundary is the
**outer** approximation, which contains ``W``.
"""

from __future__ import annotations

import math
import os
import re
import sys
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from ..core.config import LEAST_LENGTH
from ..errors import ConfigError, InputError, brief
from ..inputs.validation import MAX_COORDINATE, float_array, number_rows, plain_number
from .boxes import box_volume
from .interval import Interval

#: Most boxes a run keeps (the covering: inner + boundary + pending, counted before a level doubles them, beyond
#: which it stops like an interruption, ``stopped = 'box limit'``; the uniform grid: cells, refused beyond it):
#: about 0.5 GB of boxes in 3-D, instead of exhausting memory. The default limit of a model of more variables is
#: lower (:func:`default_max_boxes`).
MAX_BOXES = 10_000_000
#: Bytes a box takes per variable it carries: its lower and upper bounds (two float64).
BOX_BYTES_PER_VARIABLE = 16
#: Bytes the default box limit gives the boxes: :data:`MAX_BOXES` boxes of 3 variables (0.48 GB).
BOX_MEMORY = MAX_BOXES * 3 * BOX_BYTES_PER_VARIABLE
#: Share of the machine's physical memory the boxes of a run may take at most, whatever limit is given: a run's
#: peak is up to about twice its boxes' bytes (the level being bisected and its children; docs/workspace.md,
#: *Limits*), so a quarter leaves the machine at least half its memory.
BOX_MEMORY_SHARE = 0.25
#: Wall time [s] after which every method stops like an interruption when the caller gives no limit of its own
#: (``stopped = 'time limit (600 s)'``): a run never goes on without end (a grid run at a tenth of a millimetre did).
DEFAULT_MAX_SECONDS = 600.0
#: Longest time limit a caller may give [s] (a week).
MAX_SECONDS = 7 * 24 * 3600.0


def box_bytes(model: Any) -> int:
    """Bytes of one box a run on ``model`` counts against its limit: 16 per variable of the model (an equation
    model's pending boxes carry all its variables, outputs and passive ones; index arrays and a level's
    temporaries come on top, alike in every dimension)."""
    return BOX_BYTES_PER_VARIABLE * len(model.variables)


def physical_memory() -> int | None:
    """The machine's physical memory [bytes] (``SC_PAGE_SIZE * SC_PHYS_PAGES``), ``None`` where sysconf does not
    give it."""
    try:
        size, pages = os.sysconf('SC_PAGE_SIZE'), os.sysconf('SC_PHYS_PAGES')
    except (AttributeError, ValueError, OSError):   # no os.sysconf (Windows), or a name this system lacks
        return None
    return size * pages if size > 0 and pages > 0 else None


#: Where a container's memory limit is read (cgroup v2, then v1): a number of bytes, or ``max`` for none.
CGROUP_LIMITS = ('/sys/fs/cgroup/memory.max', '/sys/fs/cgroup/memory/memory.limit_in_bytes')


def container_memory() -> int | None:
    """The memory limit of this process's container [bytes] (:data:`CGROUP_LIMITS`), ``None`` where none is set."""
    for path in CGROUP_LIMITS:
        try:
            with open(path, encoding='ascii') as f:
                text = f.read(64).strip()
        except (OSError, UnicodeDecodeError):
            continue
        if re.fullmatch(r'[0-9]{1,20}', text) and int(text) > 0:
            return int(text)
    return None


def usable_memory() -> tuple[int | None, str]:
    """The memory a run may count on [bytes] and what it is, for messages: the smaller of :func:`physical_memory`
    and :func:`container_memory` (a container's limit is what the process gets); ``None`` where neither is known."""
    physical, limit = physical_memory(), container_memory()
    if limit is not None and (physical is None or limit < physical):
        return limit, f'the {_gigabytes(limit)} of the container\'s memory limit'
    if physical is None:
        return None, ''
    return physical, f'the {_gigabytes(physical)} of physical memory'


def box_memory_limit() -> int:
    """Most bytes the boxes of a run may take: :data:`BOX_MEMORY_SHARE` of :func:`usable_memory`, or
    :data:`BOX_MEMORY` (the default limit's) where the machine does not say how much it has."""
    memory = usable_memory()[0]
    return BOX_MEMORY if memory is None else int(memory * BOX_MEMORY_SHARE)


def most_boxes(model: Any) -> int:
    """The largest box limit a run on ``model`` may be given: the boxes :func:`box_memory_limit` holds (at least
    one)."""
    return max(1, box_memory_limit() // box_bytes(model))


def default_max_boxes(model: Any) -> int:
    """The default box limit of a run on ``model``: the boxes :data:`BOX_MEMORY` holds, at most :data:`MAX_BOXES`
    (10 million up to 3 variables, as always; 1,875,000 for 16: the count alone let 16 variables take 5 times the
    memory, 4.3 GB at delta 0.2), and at most :func:`most_boxes` (a machine of less than 2 GB)."""
    return min(MAX_BOXES, BOX_MEMORY // box_bytes(model), most_boxes(model))


def check_max_boxes(max_boxes: int | None, model: Any, name: str = 'max_boxes') -> int:
    """The box limit of a run on ``model``: :func:`default_max_boxes` for ``None``, else an integer from 1 to
    :func:`most_boxes` (a count whose boxes need more memory than the machine can give is refused, naming their
    bytes; ``name`` is the option's name in the message)."""
    if max_boxes is None:
        return default_max_boxes(model)
    if isinstance(max_boxes, bool) or not isinstance(max_boxes, int) or max_boxes < 1:
        raise InputError(f'{name} = {brief(max_boxes)}; allowed: a whole number of boxes, at least 1')
    most = most_boxes(model)
    if max_boxes > most:
        each = box_bytes(model)
        raise InputError(
            f'{name} = {brief(max_boxes)}: that many boxes of {len(model.variables)} variables ({each} bytes each) '
            f'take {_gigabytes(max_boxes * each)}; allowed: at most {most} boxes for this model '
            f'({_gigabytes(most * each)}, {_memory_source()})')
    return max_boxes


def _gigabytes(n: int) -> str:
    """``n`` bytes in GB, for a message (an integer too large for a float is named by its digits)."""
    return f'{n / 1e9:.3g} GB' if n < 10**300 else f'{brief(n)} bytes'


def _memory_source() -> str:
    """Where :func:`box_memory_limit` comes from, for a message."""
    memory, what = usable_memory()
    if memory is None:
        return 'the default limit\'s memory: this system does not give its physical memory'
    return f'{BOX_MEMORY_SHARE:.0%} of {what}'


def check_max_seconds(max_seconds: float | None, name: str = 'max_seconds') -> float:
    """The time limit of a run [s]: :data:`DEFAULT_MAX_SECONDS` for ``None``, else a number in (0, MAX_SECONDS]
    (``name``: the option's name in the message)."""
    if max_seconds is None:
        return DEFAULT_MAX_SECONDS
    if isinstance(max_seconds, bool) or not isinstance(max_seconds, (int, float)) or not 0 < max_seconds <= MAX_SECONDS:
        raise InputError(f'{name} = {max_seconds!r}; allowed: a time limit in seconds, > 0 and at most '
                         f'{MAX_SECONDS:g} (a week)')
    return float(max_seconds)


class WorkspaceModel(ABC):
    """Constraint model of a mechanism's working area: ``lower_j <= g_j(x) <= upper_j``.

    Subclasses set :attr:`variables`, :attr:`units`, :attr:`scale` (metres per unit of each variable),
    :attr:`box` ((d, 2) initial box that contains the workspace), :attr:`constraint_names`, :attr:`lower`,
    :attr:`upper` (bounds, may be +-inf) and implement :meth:`enclose` (certified interval bounds over boxes)
    and :meth:`evaluate` (exact point values, used by tests and by the grid methods).
    """

    name: str = 'model'
    variables: tuple[str, ...] = ()
    units: tuple[str, ...] = ()
    scale: np.ndarray
    box: np.ndarray
    constraint_names: tuple[str, ...] = ()
    lower: np.ndarray
    upper: np.ndarray

    @abstractmethod
    def enclose(self, x: Sequence[Interval]) -> list[Interval]:
        """Interval enclosures of every ``g_j`` over boxes; ``x[i]`` holds variable i over n boxes."""

    @abstractmethod
    def evaluate(self, points: np.ndarray) -> np.ndarray:
        """Point values ``g(x)`` for ``points`` (N, d) -> (N, m) (NaN where undefined = infeasible)."""

    def feasible(self, points: np.ndarray) -> np.ndarray:
        """Boolean (N,): every constraint satisfied at the point (NaN counts as violated); ``points (N, d)`` or one
        ``(d,)``, else :class:`~gpr_kinematics.errors.InputError` naming the shape allowed."""
        d = len(self.variables)
        g = self.evaluate(number_rows(points, f'points of {", ".join(self.variables)}', d))
        return np.asarray(np.all((g >= self.lower) & (g <= self.upper), axis=1))

    def bounds(self, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Interval bounds of all constraints over ``boxes`` (n, d, 2) -> (lo, hi), each (n, m)."""
        xs = [Interval(boxes[:, i, 0], boxes[:, i, 1]) for i in range(boxes.shape[1])]
        g = self.enclose(xs)
        n = boxes.shape[0]
        lo = np.stack([np.broadcast_to(gi.lo, (n,)) for gi in g], axis=1)
        hi = np.stack([np.broadcast_to(gi.hi, (n,)) for gi in g], axis=1)
        return lo, hi

    def check_box(self, box: np.ndarray) -> None:  # noqa: B027 - optional hook, valid everywhere by default
        """Raise :class:`InputError` if the model's enclosures are not valid on ``box``."""

    @property
    def outputs(self) -> tuple[str, ...]:
        """The variables the result's boxes are over (all of them here; a subset for projections)."""
        return self.variables

    def describe(self) -> dict[str, Any]:
        return {
            'type': self.name,
            'variables': list(self.variables),
            'units': list(self.units),
            'scale': self.scale.tolist(),
            'box': self.box.tolist(),
            'constraints': list(self.constraint_names),
        }


@dataclass
class WorkspaceResult:
    """Inner and boundary boxes of a workspace approximation.

    ``inner`` and ``boundary`` are (n, d, 2) arrays of lower/upper bounds over ``variables``; the outer
    approximation is their union. After an interruption (Ctrl-C, ``max_seconds``, ``max_boxes``) the boxes
    not yet examined are appended to ``boundary``, so the outer approximation still contains the workspace
    and ``inner`` is still inside it; ``stopped`` says why the run ended early ('' when it did not).
    """

    method: str
    variables: tuple[str, ...]
    units: tuple[str, ...]
    delta: float
    inner: np.ndarray
    boundary: np.ndarray
    outside_boxes: int
    seconds: float
    evaluations: int
    levels: int
    interrupted: bool = False
    certified: bool = True
    touches_initial_box: bool = False
    stopped: str = ''
    extra: dict[str, Any] = field(default_factory=dict)
    outside: np.ndarray | None = None

    @property
    def inner_boxes(self) -> int:
        return int(self.inner.shape[0])

    @property
    def boundary_boxes(self) -> int:
        return int(self.boundary.shape[0])

    @property
    def inner_volume(self) -> float:
        return box_volume(self.inner)

    @property
    def outer_volume(self) -> float:
        return self.inner_volume + box_volume(self.boundary)

    def summary(self) -> WorkspaceSummary:
        """The run in numbers (:class:`WorkspaceSummary`)."""
        return WorkspaceSummary(
            method=self.method, variables=self.variables, units=self.units, delta=self.delta,
            inner_boxes=self.inner_boxes, boundary_boxes=self.boundary_boxes, outside_boxes=self.outside_boxes,
            inner_volume=self.inner_volume, outer_volume=self.outer_volume, seconds=self.seconds,
            evaluations=self.evaluations, levels=self.levels, interrupted=self.interrupted, stopped=self.stopped,
            certified=self.certified, touches_initial_box=self.touches_initial_box, details=dict(self.extra))


#: The metadata of a dataclass field whose mapping gives its keys to the JSON object of the dataclass
#: (:func:`gpr_kinematics.cli.output.jsonable`) instead of a key of its own.
INLINE = {'json': 'inline'}


@dataclass(frozen=True)
class WorkspaceSummary:
    """A :class:`WorkspaceResult` without its boxes: their counts and volumes (in the variables' units), the run's
    ``seconds``, ``evaluations`` and ``levels``, whether and why it stopped early, whether the boxes are
    ``certified`` and touch the initial box; ``details`` (its keys inline in JSON): what ran the covering
    (``scheduler``, ``cluster_used``, ``workers``) or the grid's ``grid_cells``."""

    method: str
    variables: tuple[str, ...]
    units: tuple[str, ...]
    delta: float
    inner_boxes: int
    boundary_boxes: int
    outside_boxes: int
    inner_volume: float
    outer_volume: float
    seconds: float
    evaluations: int
    levels: int
    interrupted: bool
    stopped: str
    certified: bool
    touches_initial_box: bool
    details: dict[str, object] = field(metadata=INLINE)


@dataclass(frozen=True)
class WorkspaceReport(WorkspaceSummary):
    """``gpr workspace --json``: the :class:`WorkspaceSummary` of a run with the model's ``type`` and, over the
    result's variables, its initial ``box`` and ``scale`` [m per unit], and the ``volume_units``; a model made of two
    coverings (the joint working area) adds their summaries to ``details`` (``sub_coverings``)."""

    type: str
    box: np.ndarray
    scale: np.ndarray
    volume_units: str


def workspace_report(model: WorkspaceModel, result: WorkspaceResult) -> WorkspaceReport:
    """The :class:`WorkspaceReport` of ``result``, a run of ``model``."""
    out = [list(model.variables).index(v) for v in result.variables]
    summary = result.summary()
    values = {f.name: getattr(summary, f.name) for f in fields(summary)}
    tables = getattr(model, 'tables', None)
    if tables:
        values['details'] = summary.details | {'sub_coverings': tables.get('sub_coverings')}
    return WorkspaceReport(**values, type=model.name, box=np.asarray(model.box)[out],
                           scale=np.asarray(model.scale)[out], volume_units='*'.join(result.units))


#: Range of a model's lengths [m] and of its ``angle_scale`` [m per rad]: the GPR core's least length to every
#: coordinate's bound (a radius of 5e-324 m passed, and an ``angle_scale`` of 1e-300 never bisected the angles).
LENGTHS = (LEAST_LENGTH, MAX_COORDINATE)


def check_parameters(model: str, lengths: Mapping[str, float | None] | None = None,
                     finite: Mapping[str, float | None] | None = None,
                     positive: Mapping[str, float | None] | None = None) -> None:
    """:class:`ConfigError` naming the first parameter of a model's constructor that is not a finite number (NaN and
    infinite radii were accepted by the Python API and gave coverings of nothing), among ``lengths`` not within
    :data:`LENGTHS`, or among ``positive`` not above 0 (an ``angle_scale`` of 0 or below never bisected the angles).
    ``None`` values (defaults) are skipped."""
    lo, hi = LENGTHS
    for kind, values in ((f'a length from {lo:g} to {hi:g} m', lengths or {}), ('a finite number', finite or {}),
                         ('a positive finite number', positive or {})):
        for name, value in values.items():
            if value is None:
                continue
            v = plain_number(value)
            if not math.isfinite(v) or (kind.startswith('a positive') and v <= 0) or (
                    kind.startswith('a length') and not lo <= v <= hi):
                unit = ' (m per rad: the angles\' weight in a box\'s diameter)' if name == 'angle_scale' else ''
                raise ConfigError(f'{model}: {name} = {brief(value)}; allowed: {kind}{unit}'
                                  + ('' if kind.startswith('a length') else ' (SI units)'))


def check_delta(delta: float, box: np.ndarray, scale: np.ndarray) -> None:
    """``delta`` must be a positive length no smaller than 2^-40 of the box's scaled extent: the larger of its scaled
    diameter and its largest scaled bound magnitude ``max_i scale_i max(|lo_i|, |hi_i|)`` (an edge near a large
    bound, at 1e6 m say, cannot be halved below a few of its floats' spacing, ulp = 2^-52 times the bound: a box of
    three consecutive floats at 0.5 m bisected without end until the time limit). 2^-40 of the bound is 2^12 ulp, so
    every edge above ``delta`` halves into two strictly smaller ones. The initial box's volume (the product of its
    edges, in the variables' units) must be a normal float: one that underflows to 0 (edges of 1e-200 m) divided the
    progress by zero."""
    if not 0.0 < plain_number(delta) < math.inf:   # 'a' was a TypeError
        raise InputError(f'delta must be a positive length in metres, got {brief(delta)}')
    edges = box[:, 1] - box[:, 0]
    diam = float(np.max(edges * scale))
    extent = max(diam, float(np.max(np.max(np.abs(box), axis=1) * scale)))
    if delta < extent * 2.0**-40:
        raise InputError(
            f'delta {delta:g} m is too small for the initial box (diameter {diam:g} m'
            + ('' if extent == diam else f', bounds up to {extent:g} m scaled') +
            f'): allowed delta >= {extent * 2.0**-40:.3g} m (2^-40 of '
            + ('its diameter)' if extent == diam else 'its largest scaled bound)')
        )
    volume = float(np.prod(edges))
    if not volume >= sys.float_info.min:
        raise InputError(f'the initial box has volume {volume:g} (the product of its edges {edges.tolist()}); '
                         f'allowed: a box of volume at least {sys.float_info.min:.3g} in its variables\' units')


def check_initial_box(box: Any, names: Sequence[str]) -> np.ndarray:
    """The initial box as a finite (d, 2) float array with lower < upper, else :class:`InputError`."""
    arr = float_array(box, 'initial box', f'numbers of shape ({len(names)}, 2)').copy()
    if arr.ndim != 2 or arr.shape != (len(names), 2):
        raise InputError(f'initial box must have shape ({len(names)}, 2), got {arr.shape}')
    if not np.all(np.isfinite(arr)) or np.any(arr[:, 1] <= arr[:, 0]):
        raise InputError(f'initial box needs finite bounds with lower < upper, got {arr.tolist()}')
    return arr

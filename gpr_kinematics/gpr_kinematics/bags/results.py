"""Results of ``gpr verify``: checks, their failures, the stream series for the report, the table and JSON.

A :class:`Check` is one named property over ``checked`` items with its worst value against a limit; its
:class:`Failure` entries name the sample (the message's counter) where it failed. In JSON a value that is not
a finite number (an infinite error: "missing" or "names differ"; NaN: "not computable") is written as the
string ``"inf"``, ``"-inf"`` or ``"nan"``, since JSON has no such numbers.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.messages import Topic

#: How many failures per check are kept with their details (all are counted).
MAX_DETAILS = 20


def json_number(value: float) -> float | str:
    """``value`` itself when finite, else ``"inf"``, ``"-inf"`` or ``"nan"`` (JSON has no such numbers).

    >>> json_number(1e-9), json_number(float('inf')), json_number(float('nan'))
    (1e-09, 'inf', 'nan')
    """
    return value if math.isfinite(value) else str(value)


def json_safe(value: Any) -> Any:
    """``value`` with every float inside it (dicts, lists, tuples) through :func:`json_number`."""
    if isinstance(value, float):
        return json_number(value)
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


@dataclass
class Failure:
    """One failed check: ``check`` on ``topic`` at ``sample`` (the message's counter, or its index in the
    topic when it has none), the offending ``value`` and the ``limit``."""

    check: str
    topic: str
    sample: int | None
    value: float
    limit: float
    detail: str = ''

    def line(self) -> str:
        where = f'sample {self.sample}' if self.sample is not None else 'bag'
        extra = f' ({self.detail})' if self.detail else ''
        return f'FAIL {self.check} on {self.topic} at {where}: value {self.value:.6g} > limit {self.limit:.6g}{extra}'

    def record(self) -> FailureRecord:
        """This failure for JSON (:class:`FailureRecord`)."""
        return FailureRecord(self.check, self.topic, self.sample, json_number(self.value), json_number(self.limit),
                             self.detail)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self.record())


@dataclass(frozen=True)
class FailureRecord:
    """A :class:`Failure` for JSON: ``value`` and ``limit`` as :func:`json_number` gives them."""

    check: str
    topic: str
    sample: int | None
    value: float | str
    limit: float | str
    detail: str


@dataclass
class Check:
    """Outcome of one check over ``checked`` items: ``worst`` value against ``limit`` [``unit``]."""

    name: str
    topic: str
    checked: int
    worst: float
    limit: float
    unit: str
    failed: int = 0
    failures: list[Failure] = field(default_factory=list)
    skipped: str = ''

    @property
    def passed(self) -> bool:
        return self.failed == 0

    @property
    def status(self) -> str:
        if self.skipped:
            return 'skip'
        return 'ok' if self.passed else 'FAIL'

    def record(self) -> CheckRecord:
        """This check for JSON (:class:`CheckRecord`)."""
        return CheckRecord(self.name, self.topic, self.status, self.checked, json_number(self.worst),
                           json_number(self.limit), self.unit, self.failed, self.skipped,
                           [f.record() for f in self.failures])

    def to_dict(self) -> dict[str, Any]:
        return asdict(self.record())


@dataclass(frozen=True)
class CheckRecord:
    """A :class:`Check` for JSON: its ``status`` (ok, FAIL, skip) and the non-finite numbers as strings."""

    name: str
    topic: str
    status: str
    checked: int
    worst: float | str
    limit: float | str
    unit: str
    failed: int
    skipped: str
    failures: list[FailureRecord]


def finite_max(a: NDArray[np.float64]) -> float:
    """Largest value, ``inf`` if any is NaN, 0 for none."""
    if a.size == 0:
        return 0.0
    if np.isnan(a).any():
        return math.inf
    return float(np.max(a))


def value_check(name: str, topic: str, values: NDArray[np.float64], limit: float, unit: str,
                samples: NDArray[np.int64], detail: str = '') -> Check:
    """A check over per-item ``values`` (NaN counts as a failure) against ``limit``."""
    v = np.asarray(values, dtype=float)
    idx = np.flatnonzero(~(v <= limit))
    c = Check(name, topic, int(v.size), finite_max(v), limit, unit, int(idx.size))
    for i in idx[:MAX_DETAILS]:
        c.failures.append(Failure(name, topic, int(samples[i]), float(v[i]), limit, detail))
    return c


def bool_check(name: str, topic: str, ok: NDArray[np.bool_], samples: NDArray[np.int64], detail: str) -> Check:
    """A check whose items hold or not (value 1 = failed, limit 0)."""
    return value_check(name, topic, (~np.asarray(ok, dtype=bool)).astype(float), 0.0, '', samples, detail)


def bag_check(name: str, topic: str, problems: list[tuple[str, float, float, str]], checked: int, unit: str,
              limit: float = 0.0) -> Check:
    """A check of the bag as a whole: ``problems`` are ``(topic, value, limit, detail)`` of each failed item."""
    c = Check(name, topic, checked, max((p[1] for p in problems), default=0.0), limit, unit, len(problems))
    c.failures = [Failure(name, t, None, v, lim, d) for t, v, lim, d in problems[:MAX_DETAILS]]
    return c


def skipped(name: str, topic: str, unit: str, why: str, limit: float = 0.0) -> Check:
    return Check(name, topic, 0, 0.0, limit, unit, skipped=why)


@dataclass
class Series:
    """Per-sample data of the PlatformState stream for the report (SI units)."""

    sample: NDArray[np.int64]
    q: NDArray[np.float64]
    model: str
    virtual_joints: NDArray[np.float64]
    side_lengths: NDArray[np.float64]
    centre_shift: NDArray[np.float64]
    tilt: NDArray[np.float64]
    commanded_tilt: NDArray[np.float64]
    crossings: NDArray[np.int64]
    #: Each sample's number of virtual joints: its row of :attr:`virtual_joints` beyond is NaN padding.
    virtual_counts: NDArray[np.int64]

    def virtual(self, r: int) -> NDArray[np.float64]:
        """The virtual joints of sample row ``r`` (without the padding)."""
        return self.virtual_joints[r, :self.virtual_counts[r]]


@dataclass
class VerifyResult:
    """All checks of one bag, the topic counts, the stream series, the geometry and robot used and timing."""

    path: str
    storage: str
    files: list[str]
    counts: dict[str, int]
    checks: list[Check]
    series: Series | None
    crossings: int
    crossing_ratio: float
    elapsed: float
    read_time: float
    unfinished: list[str]
    config: dict[str, Any]
    notes: list[str] = field(default_factory=list)
    geometry: dict[str, Any] = field(default_factory=dict)
    robot: dict[str, Any] = field(default_factory=dict)
    #: Per topic, the numeric fields no check covers, with why (:mod:`.coverage`).
    unchecked: dict[str, list[str]] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def failures(self) -> list[Failure]:
        return [f for c in self.checks for f in c.failures]

    @property
    def states(self) -> int:
        return self.counts.get('/' + Topic.PLATFORM_STATE, 0)

    def record(self) -> VerifyRecord:
        """The result for JSON (:class:`VerifyRecord`; non-finite numbers as strings, see the module docstring)."""
        return VerifyRecord(
            bag=self.path, storage=self.storage, files=list(self.files), passed=self.passed, counts=dict(self.counts),
            unfinished_segments=list(self.unfinished), notes=list(self.notes), singular_crossings=self.crossings,
            max_jump_ratio_at_crossings=json_number(self.crossing_ratio), elapsed_s=self.elapsed,
            read_s=self.read_time, checks=[c.record() for c in self.checks], config=json_safe(self.config),
            geometry=json_safe(self.geometry), robot=self.robot,
            unchecked_fields={k: list(v) for k, v in self.unchecked.items()})

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (:meth:`record` as plain data): ``verify.json`` of the report."""
        return asdict(self.record())


@dataclass(frozen=True)
class VerifyRecord:
    """``gpr verify --json`` and the report's ``verify.json``: the ``bag`` read (its ``storage``, ``files``, message
    ``counts`` by topic and ``unfinished_segments``), whether it ``passed``, the ``notes``, the singular crossings and
    the largest jump ratio at one, the time taken (``elapsed_s``, ``read_s``), every check, the geometry
    (``config``, ``geometry``) and ``robot`` verified against, and the recorded fields no check covers
    (``unchecked_fields``, by topic, with the reason)."""

    bag: str
    storage: str
    files: list[str]
    passed: bool
    counts: dict[str, int]
    unfinished_segments: list[str]
    notes: list[str]
    singular_crossings: int
    max_jump_ratio_at_crossings: float | str
    elapsed_s: float
    read_s: float
    checks: list[CheckRecord]
    config: dict[str, Any]
    geometry: dict[str, Any]
    robot: dict[str, Any]
    unchecked_fields: dict[str, list[str]]


def format_table(result: VerifyResult) -> str:
    """The verification table for stdout: one line per check, the failures, and a verdict."""
    lines = [f'bag {result.path} ({result.storage}, {len(result.files)} file(s)): '
             + ', '.join(f'{k} {v}' for k, v in result.counts.items())]
    if result.unfinished:
        lines.append('note: unfinished segment(s) not read (a recording still running, or a recorder killed): '
                     + ', '.join(result.unfinished))
    lines += [f'note: {n}' for n in result.notes]
    lines += [f'note: not checked on {topic}: {"; ".join(fields)}' for topic, fields in result.unchecked.items()]
    lines.append(f'{"check":28s} {"topic":22s} {"status":6s} {"checked":>8s} {"worst":>12s} {"limit":>12s} unit')
    for c in result.checks:
        worst = '-' if c.skipped else f'{c.worst:.3e}'
        lines.append(f'{c.name:28s} {c.topic:22s} {c.status:6s} {c.checked:8d} {worst:>12s} {c.limit:12.3e} '
                     f'{c.unit}{"  (" + c.skipped + ")" if c.skipped else ""}'
                     f'{f"  {c.failed} failed" if c.failed else ""}')
    lines.append(f'singular crossings: {result.crossings}, largest jump ratio at a crossing: '
                 f'{result.crossing_ratio:.3f} (bound 1)')
    for f in result.failures:
        lines.append(f.line())
    n = sum(result.counts.values())
    rate = n / result.elapsed if result.elapsed > 0 else float('inf')
    verdict = 'PASSED' if result.passed else f'FAILED ({sum(c.failed for c in result.checks)} failure(s))'
    lines.append(f'verification {verdict}: {n} messages in {result.elapsed:.3f} s ({rate:,.0f} messages/s)')
    return '\n'.join(lines)

"""The ends of a recording: which companion messages of a PlatformState an honest recording may lack there, or hold
without their state, and the ``*_extra`` and ``*_order`` failures (the topic checks' shared rules).

The ends of a recording: a companion message of a state is not counted as missing (:func:`missing`) before the
companion topic's first message, since the recorder subscribes to each topic on its own and discovery matches each
topic on its own (a recorder started while the node streams may miss any number of a topic's first samples; before
it subscribed to the state topic last, those of the joint states and the markers were lost in a test run), and at
the recording's last sample after the topic's last message: the node publishes every message of a sample in one
tick and a cut (SIGKILL) stops every topic at once, so a recording cut in the middle of a sample lacks that
sample's only. Every other state after a topic's last message is missing, its tail removed (500 poses deleted from
the end and the metadata recounted passed before): the failures name the topic, the samples and how many
(:func:`cut_detail`). A topic recorded without a message: every state but the first and the last. Companion
messages without a PlatformState of the same stamp are ``*_extra`` failures: inside the states' span, and after the
last state all but those of one stamp (a cut in the middle of a sample may have lost its state only: the states'
tail removed and the metadata recounted passed before); before the first state they are a late subscriber's. Where
the recorded states begin with the first sample the node's records describe, or end with their last (a stream that
does not loop: :func:`whole_stream`), no sample precedes or follows them and every companion there is extra. A
companion topic's header stamps that go back in log-time order are a ``*_order`` failure (:func:`unordered`).

A recording cut by a SIGKILL of a recorder that closes segments (:func:`cut_recording`: the bag notes an unfinished
segment): the recorder takes each topic on its own, so at a segment's close the companion topics lag the states by
the delivery's delay (12-70 ms at 400 Hz on a loaded machine), and the unfinished segment that held the rest is not
read. Then a companion may be missing for the samples within :data:`CUT_LAG` of the bag's last one (an intact bag
killed so failed ``gpr verify``); a tail cut from a finished bag is still missing. Companions after the last state
are not let through for it: no state checks them (a tampered tail passed so in review).
"""
from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Iterator

import numpy as np
from numpy.typing import NDArray

from .results import Check, Failure, value_check

#: How far before the bag's last sample [ns of stamps] a cut recording (:func:`cut_recording`) may lack companion
#: messages (about three times the 70 ms measured; not companions beyond the last state: nothing checks those).
CUT_LAG = 200_000_000
_CUT: contextvars.ContextVar[bool] = contextvars.ContextVar('gpr_cut_recording', default=False)
#: Whether the recorded states begin with the first sample of the node's records and end with the last (a stream that
#: does not loop): then no sample precedes or follows them, and no companion either (:func:`whole_stream`).
_WHOLE: contextvars.ContextVar[tuple[bool, bool]] = contextvars.ContextVar('gpr_whole_stream', default=(False, False))


@contextlib.contextmanager
def cut_recording(cut: bool) -> Iterator[None]:
    """Within the block, the checks read a recording that a SIGKILL cut (``cut``: the bag notes an unfinished
    segment; module docstring)."""
    token = _CUT.set(cut)
    try:
        yield
    finally:
        _CUT.reset(token)


@contextlib.contextmanager
def whole_stream(head: bool, tail: bool) -> Iterator[None]:
    """Within the block, the recorded states hold the first sample of every stream the records describe (``head``)
    and the last (``tail``): companion messages before the first state or after the last are then no late
    subscriber's nor a cut sample's, but extra (:func:`extra`)."""
    token = _WHOLE.set((head, tail))
    try:
        yield
    finally:
        _WHOLE.reset(token)


def stream_ends(first_samples: list[tuple[int, int, bool]], samples: NDArray[np.int64]) -> tuple[bool, bool]:
    """``(head, tail)`` of :func:`whole_stream` for the records' ``(first_sample, samples, loop)`` and the recorded
    states' sample counters: the first state is the first record's first sample, the last state the last record's
    last; neither where a stream loops (its counters start over) or no record was read."""
    if not first_samples or not len(samples) or any(loop for _, _, loop in first_samples):
        return False, False
    first, last = min(f for f, _, _ in first_samples), max(f + n - 1 for f, n, _ in first_samples)
    return int(samples.min()) == first, int(samples.max()) == last


def missing(stamps: NDArray[np.int64], companion: NDArray[np.int64], end: int | None = None) -> NDArray[np.float64]:
    """Initial error per PlatformState (per RobotState for the wafer poses): inf (missing), 0 where the companion
    message may be missing from an honest recording (module docstring, *the ends*): before the companion topic's
    first message, and at the recording's last sample (``end``: its stamp, default the last of ``stamps``) after its
    last message; a topic without a message: the first and the last."""
    e = np.full(len(stamps), np.inf)
    if len(stamps) == 0:
        return e
    end = int(stamps.max()) if end is None else end
    if len(companion):
        e[(stamps < companion.min()) | ((stamps == end) & (stamps > companion.max()))] = 0.0
    else:
        e[(stamps == stamps.min()) | (stamps == end)] = 0.0
    e[lagging(stamps, int(companion.max()) if len(companion) else int(stamps.min()), end)] = 0.0
    return e


def lagging(stamps: NDArray[np.int64], last: int, end: int | None = None) -> NDArray[np.bool_]:
    """The states after a companion topic's ``last`` stamp within :data:`CUT_LAG` of the recording's last sample
    (``end``, default the last of ``stamps``) in a cut recording (none in another): their companions were in the
    unfinished segment (module docstring)."""
    if not _CUT.get() or not len(stamps):
        return np.zeros(len(stamps), dtype=bool)
    end = int(stamps.max()) if end is None else end
    return np.asarray((stamps > last) & (stamps >= end - CUT_LAG), dtype=bool)


def cut_detail(stamps: NDArray[np.int64], companion: NDArray[np.int64], samples: NDArray[np.int64],
               e: NDArray[np.float64], where: str = '') -> str:
    """How many of the missing (``e`` inf) are after the companion topic's last message, from which sample to which
    (empty when none): a tail removed, not a recording cut in the middle of its last sample (``where``: how the
    message names them, default by the topic's last message)."""
    gone = np.isinf(e) & (stamps > companion.max() if len(companion) else np.ones(len(stamps), dtype=bool))
    if not np.any(gone):
        return ''
    where = where or ("missing after the topic's last message" if len(companion) else
                      'missing of a topic without a message')
    return (f'; {int(np.count_nonzero(gone))} {where} (samples {int(samples[gone].min())} to '
            f"{int(samples[gone].max())}; a recording cut in the middle of a sample lacks only the last sample's)")


def without_messages(check: str, topic: str, stamps: NDArray[np.int64], samples: NDArray[np.int64], tol: float,
                     unit: str, detail: str, end: int | None = None) -> Check:
    """``check`` of a companion topic recorded (listed) without a message: every state missing but at the ends
    (:func:`missing`; such a topic has no columns to match)."""
    e = missing(stamps, np.zeros(0, np.int64), end)
    return value_check(check, topic, e, tol, unit, samples, detail + cut_detail(stamps, np.zeros(0, np.int64),
                                                                                 samples, e))


def extra(check: str, topic: str, companion: NDArray[np.int64], stamps: NDArray[np.int64],
          matched: int, of_states: bool = True) -> Check | None:
    """A failed ``<check>_extra`` if the companion topic has messages without a PlatformState of their stamp: inside
    the states' span, or after the last state beyond those of its first stamp there (a recording cut in the middle
    of a sample may hold that sample's companions without its state; more is the states' tail removed). Those before
    the first state are a late subscriber's to the state topic (module docstring, *the ends*). Where the states hold
    the streams' first or last sample (:func:`whole_stream`) no sample precedes or follows them: every companion
    before or after them is extra (a pose 5 cm off and rods beyond the stroke after the last one passed);
    ``of_states`` False: ``stamps`` are another topic's (the RobotStates of the wafer poses), whose ends that rule
    does not know."""
    if not len(stamps):
        return None
    head, tail = _WHOLE.get() if of_states else (False, False)
    inside = int(np.count_nonzero((companion >= stamps.min()) & (companion <= stamps.max())))
    after = companion[companion > stamps.max()]
    before = int(np.count_nonzero(companion < stamps.min())) if head else 0
    beyond = after.size if tail else int(np.count_nonzero(after > after.min())) if after.size else 0
    if inside <= matched and not beyond and not before:
        return None
    n = float(inside - matched + beyond + before)
    why = 'messages without a PlatformState of the same stamp'
    if beyond and tail:
        why += (f"; {beyond} of them after the last PlatformState, the last sample of the recorded streams (nothing "
                "follows it)")
    elif beyond:
        why += (f"; {beyond} of them after the last PlatformState's next sample (a recording cut in the middle of a "
                "sample holds at most that sample's)")
    if before:
        why += (f'; {before} of them before the first PlatformState, the first sample of the recorded streams '
                '(nothing precedes it)')
    return Check(f'{check}_extra', topic, inside + after.size + before, n, 0.0, 'messages', 1,
                 [Failure(f'{check}_extra', topic, None, n, 0.0, why)])


def unordered(check: str, topic: str, companion: NDArray[np.int64],
              numbers: NDArray[np.int64] | None = None) -> Check | None:
    """A failed ``<check>_order`` if the companion topic's header stamps, in the recorder's log-time order, go back:
    the node publishes a topic's samples in order and the recorder receives and logs them so (the PlatformState
    topic's own order is ``stream.stamps``); log times edited out of step with the stamps passed before.
    ``numbers``: each stamp's message number in the topic, when ``companion`` is a part of it (the stream's)."""
    back = np.flatnonzero(np.diff(companion) < 0)
    if not back.size:
        return None
    k = int(back[0]) + 1
    number = k if numbers is None else int(numbers[k])
    return Check(f'{check}_order', topic, len(companion), float(back.size), 0.0, 'messages', 1, [
        Failure(f'{check}_order', topic, None, float(back.size), 0.0,
                f'header stamps that go back in log-time order (the first: message {number} of the topic, stamped '
                f'{int(companion[k])} ns, logged after one stamped {int(companion[k - 1])} ns)')])

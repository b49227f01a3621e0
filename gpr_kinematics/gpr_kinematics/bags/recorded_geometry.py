"""Which geometry a bag is verified against: the one it recorded (``/gpr/geometry``), a given one, or the package's.

The trajectory node publishes its ``GprConfig.to_dict()`` as YAML once at start on
:data:`.typestore.GEOMETRY_TOPIC`; the bag is *self-describing*. ``gpr verify`` uses that geometry by default.
``--config FILE`` overrides it, and then the result also says how the two differ: the keys with both values,
and the largest difference of the platform pose (position [m], rotation angle [rad]) over the bag's samples
between forward kinematics under the recorded and under the given geometry, so that the failed ``state.*``
checks come with their cause. A bag without the topic (recorded before it existed) is verified against the
package's configuration, and the result says so.

The check ``topic.geometry``: every message on the topic is the same text, at most
:data:`MAX_GEOMETRY_BYTES`, YAML (parsed by :func:`gpr_kinematics.inputs.safe_yaml.load_text`, with its limits) of a
mapping that :meth:`GprConfig.from_mapping` accepts. The keys are never listed here: whatever ``GprConfig`` holds is
compared.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import forward_batch
from ..core.config import GprConfig
from ..errors import GprError, kind_of
from ..inputs import safe_yaml
from .columns import quaternion_angle
from .reader import Bag
from .results import Check, bag_check, skipped
from .typestore import GEOMETRY_TOPIC, GPR_TOPICS, suite_topic

#: Largest geometry message read.
MAX_GEOMETRY_BYTES = 1 << 20


@dataclass
class Geometry:
    """The configuration verified against, where it came from, the check of the recorded one and notes."""

    config: GprConfig
    source: str
    check: Check
    notes: list[str] = field(default_factory=list)
    report: dict[str, Any] = field(default_factory=dict)


def _parse(text: str, topic: str) -> GprConfig:
    if len(text.encode('utf-8', errors='replace')) > MAX_GEOMETRY_BYTES:
        raise GprError(f'{len(text)} characters; allowed: at most {MAX_GEOMETRY_BYTES} bytes')
    # Through the package's one YAML parser (its limits on aliases, nesting and size apply to messages too).
    data = safe_yaml.load_text(text, f'{topic} (recorded geometry)')
    if not isinstance(data, dict):
        raise GprError(f'not a mapping of keys to values ({kind_of(data)})')
    return GprConfig.from_mapping(data, source=topic)


def recorded_geometry(bag: Bag) -> tuple[GprConfig | None, Check]:
    """The configuration recorded in the bag (None when absent or unusable) and the ``topic.geometry`` check."""
    t = bag.topic(GEOMETRY_TOPIC)
    if t is None or len(t) == 0:
        return None, skipped('topic.geometry', GEOMETRY_TOPIC, '', 'no geometry recorded in the bag')
    if t.msgtype != GPR_TOPICS[GEOMETRY_TOPIC]:
        return None, bag_check('topic.geometry', GEOMETRY_TOPIC, [(GEOMETRY_TOPIC, 1.0, 0.0,
                                                                   f'type {t.msgtype}, not a std_msgs/msg/String')],
                               len(t), '')
    texts = list(dict.fromkeys(str(v) for v in t.columns()['data']))
    if len(texts) > 1:
        return None, bag_check('topic.geometry', GEOMETRY_TOPIC, [(GEOMETRY_TOPIC, float(len(texts)), 1.0,
                                                                   'the geometry messages differ')], len(t), '', 1.0)
    try:
        cfg = _parse(texts[0], t.name)
    except GprError as exc:
        return None, bag_check('topic.geometry', GEOMETRY_TOPIC, [(GEOMETRY_TOPIC, 1.0, 0.0,
                                                                   f'not a usable geometry: {exc}')], len(t), '')
    return cfg, bag_check('topic.geometry', GEOMETRY_TOPIC, [], len(t), '')


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + '...'


def difference(recorded: GprConfig, given: GprConfig, q: NDArray[np.float64], model: str | None = None
               ) -> dict[str, Any]:
    """How ``given`` differs from ``recorded``: the keys with both values, and the largest platform pose
    difference over the rod lengths ``q (N, 3)`` (forward kinematics under each, ``model`` or each config's)."""
    a, b = recorded.to_dict(), given.to_dict()
    keys = {k: {'recorded': a.get(k), 'given': b.get(k)} for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)}
    out: dict[str, Any] = {'differing_keys': keys, 'samples': int(len(q))}
    q = q[np.all(np.isfinite(q), axis=1)]
    if not keys or not len(q):
        out.update(max_position_difference=0.0, max_orientation_difference=0.0)
        return out
    try:
        fa = forward_batch(q, recorded, model or recorded.model, check_limits=False)
        fb = forward_batch(q, given, model or given.model, check_limits=False)
    except GprError as exc:
        out['pose_difference_error'] = f'{type(exc).__name__}: {exc}'
        return out
    out['max_position_difference'] = float(np.max(np.linalg.norm(fa.position - fb.position, axis=1)))
    out['max_orientation_difference'] = float(np.max(quaternion_angle(fa.quaternion, fb.quaternion)))
    return out


def choose(bag: Bag, given: GprConfig | None, given_source: str, q: NDArray[np.float64],
           default: GprConfig) -> Geometry:
    """The geometry to verify ``bag`` against (see the module docstring); ``q`` are its states' rod lengths."""
    recorded, check = recorded_geometry(bag)
    if given is None:
        if recorded is not None:
            return Geometry(recorded, 'recorded', check,
                            [f'verified against the geometry recorded on {suite_topic(bag.namespace, GEOMETRY_TOPIC)}'],
                            {'source': 'recorded'})
        why = 'no geometry recorded in the bag' if check.skipped else 'the recorded geometry is unusable'
        return Geometry(default, 'package', check, [f'{why}: verified against the package configuration'],
                        {'source': 'package'})
    report: dict[str, Any] = {'source': given_source}
    notes = [f'verified against {given_source} (given)']
    if recorded is None:
        notes.append('no usable geometry recorded in the bag to compare it with')
        return Geometry(given, 'given', check, notes, report)
    diff = difference(recorded, given, q)
    report.update(diff)
    if not diff['differing_keys']:
        notes.append(f'{given_source} equals the recorded geometry')
    else:
        keys = ', '.join(f'{k} ({_short(v["recorded"])} recorded, {_short(v["given"])} given)'
                         for k, v in diff['differing_keys'].items())
        pose = (f'the platform pose differs by up to {diff["max_position_difference"]:.3e} m and '
                f'{diff["max_orientation_difference"]:.3e} rad over the bag\'s {diff["samples"]} samples'
                if 'max_position_difference' in diff else f'pose difference not computable: '
                f'{diff.get("pose_difference_error", "")}')
        notes.append(f'{given_source} differs from the recorded geometry in {keys}; {pose} (the state checks '
                     f'use the given geometry)')
    return Geometry(given, 'given', check, notes, report)

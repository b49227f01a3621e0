"""Write the trajectory node's stream straight into a bag, without ROS (benchmarks, tests of reader and verify).

The messages are the ones ``trajectory_node`` publishes for a sweep or a whole-robot program, built by the same
functions (:func:`gpr_kinematics.core.messages.stream_messages` for the platform's topics,
:meth:`gpr_kinematics.robot.stream.RobotStream.messages` for the robot's, :func:`.markers.marker_array` for the
markers, :func:`gpr_kinematics.core.messages.geometry_text`, ``robot_text`` and
:func:`.program_record.record_text` for the latched :data:`.typestore.GEOMETRY_TOPIC`, :data:`.typestore.ROBOT_TOPIC`
and :data:`.typestore.PROGRAM_TOPIC`), serialized with the ``rosbags`` typestore
instead of rclpy; recorded bags come from the real nodes over DDS. The markers are those of the samples
:func:`~gpr_kinematics.robot.markers.marked` by ``markers_every``, which the record carries (``markers_every=None``:
markers at every sample and a record without it, as the node wrote before).
"""
from __future__ import annotations

import dataclasses
import functools
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import ForwardBatch, inverse_batch, resolve_config
from ..core.config import GprConfig
from ..core.messages import Topic, geometry_text, robot_text, stream_messages
from ..core.sweep import DEFAULT_AZIMUTH_STEP, DEFAULT_HEIGHT, DEFAULT_MAX_TILT, DEFAULT_TILT_STEP, paper_sweep
from ..robot.description import RobotDescription
from ..robot.markers import marked, marker_array, marker_points
from ..robot.platform_program import PlatformProgram, sample_program
from ..robot.program import RobotProgram
from ..robot.stream import RobotStream, robot_stream
from .program_record import record_text
from .typestore import (
    ARRAY,
    BASE,
    GEOMETRY_TOPIC,
    GPR_TOPICS,
    MARKERS_TOPIC,
    NAME,
    PLATFORM_STREAM_TOPICS,
    PROGRAM_TOPIC,
    ROBOT_TOPIC,
    fields_of,
    message_types,
    typestore,
)
from .writer import SegmentedBagWriter

_DTYPES: dict[str, type[np.generic]] = {
    'bool': np.bool_, 'byte': np.uint8, 'char': np.uint8, 'octet': np.uint8, 'float32': np.float32,
    'float64': np.float64, **{f'{s}int{b}': np.dtype(f'{s}int{b}').type for s in ('', 'u') for b in (8, 16, 32, 64)}}


@functools.cache
def _default(msgtype: str) -> Any:
    """A ``rosbags`` message of ``msgtype`` with every field at its ROS default (0, '', empty, nested defaults)."""
    fields: dict[str, Any] = {}
    for name, (kind, detail) in fields_of(msgtype):
        if kind == BASE:
            fields[name] = '' if detail[0] in ('string', 'wstring') else _DTYPES[detail[0]](0).item()
        elif kind == NAME:
            fields[name] = _default(detail)
        else:
            (sub_kind, sub), count = detail
            n = int(count) if kind == ARRAY else 0
            if sub_kind == NAME:
                fields[name] = [_default(sub) for _ in range(n)]
            elif sub[0] in ('string', 'wstring'):
                fields[name] = [''] * n
            else:
                fields[name] = np.zeros(n, dtype=_DTYPES[sub[0]])
    return typestore().types[msgtype](**fields)


def make_message(msgtype: str, **fields: Any) -> Any:
    """A ``rosbags`` message of ``msgtype`` with ``fields`` set and every other field at its default."""
    return dataclasses.replace(_default(msgtype), **fields)


def sweep_messages(height: float = DEFAULT_HEIGHT, max_tilt: float = DEFAULT_MAX_TILT,
                   tilt_step: float = DEFAULT_TILT_STEP, azimuth_step: float = DEFAULT_AZIMUTH_STEP, passes: int = 1,
                   config: GprConfig | None = None,
                   start_ns: int = 1_700_000_000_000_000_000, period_ns: int = 1_000_000,
                   topics: tuple[str, ...] = (*PLATFORM_STREAM_TOPICS, GEOMETRY_TOPIC, PROGRAM_TOPIC),
                   markers_every: int | None = 1, loop: int = 0) -> list[tuple[str, int, bytes]]:
    """(topic, log time [ns], CDR bytes) of every message of the sweep, in publishing order: the geometry and the
    record of the sweep once (if in ``topics``) at ``start_ns``, then every sample's messages, one sample per
    ``period_ns`` (the markers every ``markers_every``-th: module docstring). ``loop`` > 0: the node's ``loop``, the
    sweep streamed over and over (the counters going on) until ``loop`` samples are out, the record saying so."""
    cfg = resolve_config(config)
    sw = paper_sweep(height=height, max_tilt=max_tilt, tilt_step=tilt_step, azimuth_step=azimuth_step,
                     passes=passes, config=cfg, model=cfg.model)
    spec = {'height': height, 'max_tilt': max_tilt, 'tilt_step': tilt_step, 'azimuth_step': azimuth_step,
            'passes': passes}
    latched = {GEOMETRY_TOPIC: geometry_text(cfg),
               PROGRAM_TOPIC: record_text('sweep', 0, len(sw.forward), 1e9 / period_ns, loop > 0, 2.0, sweep=spec,
                                          markers_every=markers_every, frame_prefix='')}
    return _stream(cfg, sw.forward, np.asarray(sw.alpha, float), np.asarray(sw.gamma, float), latched, None,
                   start_ns, period_ns, topics, markers_every or 1, loop or len(sw.forward))


def robot_program_messages(robot: RobotDescription, program: RobotProgram, rate: float = 100.0,
                           start_ns: int = 1_700_000_000_000_000_000,
                           topics: tuple[str, ...] = tuple(GPR_TOPICS),
                           markers_every: int | None = 1) -> list[tuple[str, int, bytes]]:
    """(topic, log time [ns], CDR bytes) of every message ``trajectory_node`` publishes for a whole-robot program
    (:func:`gpr_kinematics.robot.stream.robot_stream` at ``rate``): the geometry, the robot description and the
    record of the program once, then every sample's platform and robot messages, one sample per ``1 / rate`` (the
    markers every ``markers_every``-th: module docstring)."""
    rs = robot_stream(robot, program, rate)
    latched = {GEOMETRY_TOPIC: geometry_text(robot.config), ROBOT_TOPIC: robot_text(robot),
               PROGRAM_TOPIC: record_text('robot_program', 0, len(rs), rate, False, 2.0, program=program,
                                          markers_every=markers_every, frame_prefix='')}
    return _stream(robot.config, rs.gpr, rs.gpr.tilt, rs.gpr.tilt_azimuth, latched, rs, start_ns,
                   int(round(1e9 / rate)), topics, markers_every or 1)


def platform_program_messages(program: PlatformProgram, config: GprConfig | None = None, rate: float = 100.0,
                              start_ns: int = 1_700_000_000_000_000_000,
                              topics: tuple[str, ...] = (*PLATFORM_STREAM_TOPICS, GEOMETRY_TOPIC, PROGRAM_TOPIC),
                              markers_every: int | None = 1) -> list[tuple[str, int, bytes]]:
    """(topic, log time [ns], CDR bytes) of every message ``trajectory_node`` publishes for a platform program
    (its stations interpolated at ``rate``, solved by the inverse kinematics under ``config``'s model): the geometry
    and the record once, then every sample's platform messages, one sample per ``1 / rate``."""
    cfg = resolve_config(config)
    samples = sample_program(program, rate)
    ik = inverse_batch(samples.height, samples.tilt, samples.azimuth, cfg, cfg.model)
    latched = {GEOMETRY_TOPIC: geometry_text(cfg),
               PROGRAM_TOPIC: record_text('platform_program', 0, len(ik.achieved), rate, False, 2.0, program=program,
                                          markers_every=markers_every, frame_prefix='')}
    return _stream(cfg, ik.achieved, samples.tilt, samples.azimuth, latched, None, start_ns, int(round(1e9 / rate)),
                   topics, markers_every or 1)


def _stream(cfg: GprConfig, fk: ForwardBatch, cmd_tilt: NDArray[np.float64], cmd_azimuth: NDArray[np.float64],
            latched: dict[str, str], robot: RobotStream | None, start_ns: int, period_ns: int,
            topics: tuple[str, ...], markers_every: int, count: int | None = None) -> list[tuple[str, int, bytes]]:
    """The messages of a stream, as the trajectory node publishes them (the module docstring): ``count`` samples
    (default: the stream's), the stream starting over after its last one as a looping node's."""
    ts = typestore()
    types = message_types()
    out: list[tuple[str, int, bytes]] = []
    for topic, text in latched.items():
        if topic in topics:
            out.append((topic, start_ns, bytes(ts.serialize_cdr(make_message(GPR_TOPICS[topic], data=text),
                                                                GPR_TOPICS[topic]))))
    points = marker_points(cfg, fk.q, fk.nominal_position, fk.nominal_rotation) if MARKERS_TOPIC in topics else {}
    for n in range(len(fk) if count is None else count):
        t, i = start_ns + n * period_ns, n % len(fk)
        msgs = stream_messages(types, fk[i], stamp_ns=t, frame_id='gpr_base', sample=n,
                               commanded_tilt=float(cmd_tilt[i]), commanded_azimuth=float(cmd_azimuth[i]))
        if robot is not None:
            msgs.update(robot.messages(types, i, stamp_ns=t, sample=n, base_frame='gpr_base'))
        if points and marked(n, markers_every):
            msgs[Topic.MARKERS] = marker_array(make_message, msgs[Topic.PLATFORM_STATE].header,
                                               {ns: p[i] for ns, p in points.items()})
        for topic in topics:
            key = topic.lstrip('/')
            if key in msgs:
                out.append((topic, t, bytes(ts.serialize_cdr(msgs[key], GPR_TOPICS[topic]))))
    return out


def write_messages(path: str | Path, messages: list[tuple[str, int, bytes]], storage: str = 'mcap',
                   compression: str = 'none', flush_interval: float = 0.0) -> Path:
    """Write ``messages`` into a new bag at ``path`` with :class:`SegmentedBagWriter`."""
    topics = {t: GPR_TOPICS[t] for t in dict.fromkeys(m[0] for m in messages)}
    with SegmentedBagWriter(path, topics, storage=storage, compression=compression,
                            flush_interval=flush_interval, fsync=False) as w:
        for topic, t, data in messages:
            w.write(topic, t, data)
    return Path(path)

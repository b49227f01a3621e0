"""Write the trajectory node's stream straight into a bag, without ROS (benchmarks, tests of the reader).

The messages are the ones ``trajectory_node`` publishes for a sweep (same fields, same companion topics,
serialized with the ``rosbags`` typestore instead of rclpy); recorded bags come from the real nodes over DDS.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..config import GprConfig
from ..kinematics import resolve_config
from ..messages import stream_messages
from ..sweep import paper_sweep
from .typestore import GPR_TOPICS, message_types, typestore
from .writer import SegmentedBagWriter


def sweep_messages(height: float = 0.5, max_tilt: float = np.radians(2.0), tilt_step: float = np.radians(0.2),
                   azimuth_step: float = np.radians(10.0), passes: int = 1, config: GprConfig | None = None,
                   start_ns: int = 1_700_000_000_000_000_000, period_ns: int = 1_000_000,
                   topics: tuple[str, ...] = ('/gpr/platform_state', '/gpr/platform_pose', '/gpr/nominal_pose',
                                              '/gpr/joint_states'),
                   ) -> list[tuple[str, int, bytes]]:
    """(topic, log time [ns], CDR bytes) of every message of the sweep, in publishing order, built by
    :func:`gpr_kinematics.messages.stream_messages` as the trajectory node builds them."""
    cfg = resolve_config(config)
    sw = paper_sweep(height=height, max_tilt=max_tilt, tilt_step=tilt_step, azimuth_step=azimuth_step,
                     passes=passes, config=cfg, model=cfg.model)
    fk = sw.forward
    ts = typestore()
    types = message_types()
    out: list[tuple[str, int, bytes]] = []
    for i in range(len(fk)):
        t = start_ns + i * period_ns
        msgs = stream_messages(types, fk[i], stamp_ns=t, frame_id='gpr_base', sample=i,
                               commanded_tilt=float(sw.alpha[i]), commanded_azimuth=float(sw.gamma[i]))
        for topic in topics:
            out.append((topic, t, bytes(ts.serialize_cdr(msgs[topic.lstrip('/')], GPR_TOPICS[topic]))))
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

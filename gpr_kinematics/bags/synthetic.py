"""Write the trajectory node's stream straight into a bag, without ROS (benchmarks, tests of the reader).

The messages are the ones ``trajectory_node`` publishes for a sweep (same fields, same companion topics,
serialized with the ``rosbags`` typestore instead of rclpy); recorded bags come from the real nodes over DDS.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..config import GprConfig
from ..kinematics import resolve_config
from ..sweep import paper_sweep
from .typestore import GPR_TOPICS, typestore
from .writer import SegmentedBagWriter

ROD_NAMES = ('rod_1', 'rod_2', 'rod_3')


def sweep_messages(height: float = 0.5, max_tilt: float = np.radians(2.0), tilt_step: float = np.radians(0.2),
                   azimuth_step: float = np.radians(10.0), passes: int = 1, config: GprConfig | None = None,
                   start_ns: int = 1_700_000_000_000_000_000, period_ns: int = 1_000_000,
                   topics: tuple[str, ...] = ('/gpr/platform_state', '/gpr/platform_pose', '/gpr/nominal_pose',
                                              '/gpr/joint_states'),
                   ) -> list[tuple[str, int, bytes]]:
    """(topic, log time [ns], CDR bytes) of every message of the sweep, in publishing order."""
    cfg = resolve_config(config)
    sw = paper_sweep(height=height, max_tilt=max_tilt, tilt_step=tilt_step, azimuth_step=azimuth_step,
                     passes=passes, config=cfg, model=cfg.model)
    fk = sw.forward
    ts = typestore()
    T = ts.types
    Header, Time = T['std_msgs/msg/Header'], T['builtin_interfaces/msg/Time']
    Pose, Point, Quat = T['geometry_msgs/msg/Pose'], T['geometry_msgs/msg/Point'], T['geometry_msgs/msg/Quaternion']
    Vec, PS = T['geometry_msgs/msg/Vector3'], T['gpr_interfaces/msg/PlatformState']
    PoseStamped, JointState = T['geometry_msgs/msg/PoseStamped'], T['sensor_msgs/msg/JointState']
    names = list(fk.virtual_joint_names)
    out: list[tuple[str, int, bytes]] = []
    X = np.asarray(fk.virtual_joints).reshape(len(fk), -1)

    def pose(p: np.ndarray, q: np.ndarray) -> object:
        return Pose(position=Point(x=float(p[0]), y=float(p[1]), z=float(p[2])),
                    orientation=Quat(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])))

    for i in range(len(fk)):
        t = start_ns + i * period_ns
        header = Header(stamp=Time(sec=t // 1_000_000_000, nanosec=t % 1_000_000_000), frame_id='gpr_base')
        p, n = pose(fk.position[i], fk.quaternion[i]), pose(fk.nominal_position[i], fk.nominal_quaternion[i])
        cs = fk.centre_shift[i]
        st = PS(header=header, sample=i, q=np.array(fk.q[i], dtype=float), model=fk.model, pose=p, nominal_pose=n,
                centre_shift=Vec(x=float(cs[0]), y=float(cs[1]), z=float(cs[2])), virtual_joints=X[i].copy(),
                virtual_joint_names=names, side_lengths=np.array(fk.side_lengths[i], dtype=float),
                tilt=float(fk.tilt[i]), tilt_azimuth=float(fk.tilt_azimuth[i]), twist=float(fk.twist[i]),
                commanded_tilt=float(sw.alpha[i]), commanded_azimuth=float(sw.gamma[i]),
                joint_displacement=np.array(fk.joint_displacement[i], dtype=float),
                within_budget=bool(fk.within_budget[i]), iterations=int(fk.iterations[i]),
                residual=float(fk.residual[i]))
        msgs = {
            '/gpr/platform_state': (st, 'gpr_interfaces/msg/PlatformState'),
            '/gpr/platform_pose': (PoseStamped(header=header, pose=p), 'geometry_msgs/msg/PoseStamped'),
            '/gpr/nominal_pose': (PoseStamped(header=header, pose=n), 'geometry_msgs/msg/PoseStamped'),
            '/gpr/joint_states': (JointState(header=header, name=list(ROD_NAMES) + names,
                                             position=np.concatenate([fk.q[i], X[i]]), velocity=np.zeros(0),
                                             effort=np.zeros(0)), 'sensor_msgs/msg/JointState'),
        }
        for topic in topics:
            msg, msgtype = msgs[topic]
            out.append((topic, t, bytes(ts.serialize_cdr(msg, msgtype))))
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

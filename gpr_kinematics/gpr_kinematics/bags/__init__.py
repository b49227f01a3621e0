"""rosbag2 bags of the GPR node suite: typestore, crash-safe segmented writer, reader, offline verification.

No ROS import: everything here runs on the ``rosbags`` and ``mcap`` libraries (pure Python) and numpy, so that
a CI job can read and verify a bag without a ROS installation. The recorder and replay nodes
(:mod:`gpr_kinematics.nodes.recorder_node`, :mod:`gpr_kinematics.nodes.replay_node`) build on it.
"""
from __future__ import annotations

from .errors import BagError

__all__ = ['BagError']

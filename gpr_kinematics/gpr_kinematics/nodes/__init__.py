"""ROS 2 nodes of gpr_kinematics: thin adapters between ``gpr_interfaces`` messages and the numpy core.

Executables (``ros2 run gpr_kinematics ...``): ``kinematics_node`` (services) and ``trajectory_node``
(streams of compensated platform poses). Only this subpackage imports ROS.

Started as one of :data:`EXECUTABLES`, a process stopped by SIGINT while it still imports (before
:func:`~gpr_kinematics.nodes.runtime.run` takes the signals) leaves at once with status 0: it printed a
``KeyboardInterrupt`` traceback of some 50 lines and ended with status 130 (a Ctrl-C in a launch's first second).
"""
from __future__ import annotations

import os
import signal
import sys
from types import FrameType

#: The nodes' executables (``setup.py``'s console scripts, ``ros2 run gpr_kinematics <name>``).
EXECUTABLES = ('kinematics_node', 'trajectory_node', 'recorder_node', 'replay_node', 'state_publisher_node',
               'robot_simulator_node')


def _leave_quietly(_signum: int, _frame: FrameType | None) -> None:
    os._exit(0)   # nothing started yet: nothing to close


if os.path.basename(sys.argv[0]) in EXECUTABLES and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
    signal.signal(signal.SIGINT, _leave_quietly)

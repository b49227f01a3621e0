"""Helpers of the ROS integration tests: environment, node processes started as ``ros2 run`` would, clients.

Importing this module puts the test process into the ROS environment of the repository
(:func:`gpr_kinematics.ros_env.activate`: the variables ``source install/setup.bash`` would set, plus the
interface libraries preloaded). It also sets, for this run and every node it starts,
``ROS_PYTHON_CHECK_FIELDS=1`` (message field type checks, off by default in Jazzy), an own ``ROS_DOMAIN_ID``
and ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``. Nothing is skipped: if ROS cannot be imported the tests
fail with the import error.
"""
from __future__ import annotations

import os
import signal
import subprocess
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from gpr_kinematics import ros_env


def _ensure_environment() -> None:
    os.environ['ROS_DOMAIN_ID'] = os.environ.get('GPR_TEST_ROS_DOMAIN_ID', str(10 + os.getpid() % 90))
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ['ROS_PYTHON_CHECK_FIELDS'] = '1'
    os.environ['PYTHONUNBUFFERED'] = '1'
    ros_env.activate()


_ensure_environment()

import rclpy  # noqa: E402 - after the environment is in place
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402

PACKAGE = 'gpr_kinematics'
DOMAIN_ID = int(os.environ['ROS_DOMAIN_ID'])


def node_env() -> dict[str, str]:
    """Environment of a node process: this run's ROS environment."""
    return dict(os.environ)


def executable(name: str) -> Path:
    """``<prefix>/lib/gpr_kinematics/<name>``, the prefix from the ament index, as ``ros2 run`` finds it."""
    return ros_env.find_executable(PACKAGE, name, os.environ)


class NodeProcess:
    """A node started as a separate process: ``ros2 run gpr_kinematics <exe> --ros-args ...``."""

    def __init__(self, exe: str, ros_args: Sequence[str] = (), name: str | None = None) -> None:
        self.exe = exe
        self.path = executable(exe)
        self.log_dir = Path(tempfile.mkdtemp(prefix=f'gpr_{exe}_'))
        self.out_path = self.log_dir / 'stdout.txt'
        self.err_path = self.log_dir / 'stderr.txt'
        args = [str(self.path)]
        if ros_args:
            args += ['--ros-args', *ros_args]
        self.args = args
        self._out = open(self.out_path, 'wb')  # noqa: SIM115 - closed in wait()/stop()
        self._err = open(self.err_path, 'wb')  # noqa: SIM115
        self.proc = subprocess.Popen(args, stdout=self._out, stderr=self._err, stdin=subprocess.DEVNULL,
                                     env=node_env())

    def alive(self) -> bool:
        return self.proc.poll() is None

    def output(self) -> str:
        for f in (self._out, self._err):
            if not f.closed:
                f.flush()
        return self.out_path.read_text(errors='replace') + self.err_path.read_text(errors='replace')

    def wait(self, timeout: float) -> int:
        try:
            return self.proc.wait(timeout=timeout)
        finally:
            self._close()

    def signal(self, sig: int = signal.SIGINT, timeout: float = 2.0) -> tuple[int | None, float]:
        """Send ``sig``; return (exit status or None if still running after ``timeout``, seconds taken)."""
        t0 = time.monotonic()
        self.proc.send_signal(sig)
        try:
            status: int | None = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            status = None
        return status, time.monotonic() - t0

    def stop(self) -> None:
        if self.alive():
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=5)
        self._close()

    def _close(self) -> None:
        for f in (self._out, self._err):
            if not f.closed:
                f.close()


class Client:
    """rclpy context + node + executor of the test process (the client side)."""

    def __init__(self, name: str = 'gpr_test_client') -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = Node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.lost = 0

    def service(self, srv_type: Any, name: str, timeout: float = 20.0) -> Any:
        cli = self.node.create_client(srv_type, name)
        if not cli.wait_for_service(timeout_sec=timeout):
            raise TimeoutError(f'service {name} not available after {timeout} s')
        return cli

    def call(self, client: Any, request: Any, timeout: float = 5.0, tries: int = 3) -> Any:
        """Call a service and return its response.

        A response that never arrives is sent again (up to ``tries`` times, ``timeout`` seconds each):
        Fast DDS can lose the response to a client whose response reader was not matched yet (the first
        call right after ``wait_for_service``) or when several clients call at full speed
        (docs/benchmarks.md). A node that stopped answering fails all tries.
        """
        for _ in range(tries):
            future = client.call_async(request)
            self.executor.spin_until_future_complete(future, timeout_sec=timeout)
            if future.done():
                return future.result()
            client.remove_pending_request(future)
            self.lost += 1
        raise TimeoutError(f'no answer from {client.srv_name} in {tries} tries of {timeout} s')

    def spin_for(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=min(0.05, max(0.0, end - time.monotonic())))

    def spin_until(self, predicate: Any, timeout: float) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return True
            self.executor.spin_once(timeout_sec=0.05)
        return bool(predicate())

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

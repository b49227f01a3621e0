"""``GprClient``: a client of the GPR node suite (services, topics, the ``gpr/run_program`` action) for scripts,
tests, the demo and the benchmarks.

It owns an rclpy context, a node and an executor, so it works next to other rclpy code in the same process.
Service calls time out and re-send a lost response: Fast DDS can drop the response to a client whose response
reader was not matched yet (the first call right after ``wait_for_service``) or, rarely, under several clients
calling at full speed; the services are idempotent, so sending the request again is safe (``lost`` counts the
re-sends). Units SI (m, rad); quaternions (x, y, z, w).

Example (in the ROS environment, with ``kinematics_node`` running)::

    with GprClient() as c:
        fk = c.forward_kinematics([0.5, 0.498, 0.502])
        print(fk.success, fk.pose.position.x, fk.centre_shift.x)
        ik = c.inverse_kinematics(height=0.45, tilt=0.02, azimuth=0.5)
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from types import TracebackType
from typing import Any

import numpy as np
import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.action import ActionClient
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.task import Future

from gpr_interfaces.action import RunProgram
from gpr_interfaces.msg import ProgramStation
from gpr_interfaces.srv import (
    AnalyzeMobility,
    Compensate,
    ForwardKinematics,
    InverseKinematics,
    RobotForwardKinematics,
    StationInverseKinematics,
)

from ..core.messages import Service
from ..core.rotations import quaternion_from_matrix, tilt_rotation
from ..errors import GprError, InputError, brief
from ..inputs.validation import float_array, within_turn
from ..robot.platform_program import REQUIRED_STATION_KEYS, STATION_KEYS
from .conversions import Vector, pose_msg
from .qos import action_client_options, latched_qos, service_qos, stream_qos
from .runtime import init_refusal
from .stderr_hold import stderr_held


def _floats(values: Any, name: str, size: int | None = None, finite: bool = False) -> list[float]:
    """``values`` as floats, ``size`` of them where given (a request's fixed-size array of another length was sent
    with the memory past its end, rclpy without ROS_PYTHON_CHECK_FIELDS, or cut silently), ``finite`` where the
    client computes with them (NaN and infinity are the node's to refuse, naming the field, otherwise)."""
    a = float_array(values, name, 'numbers').reshape(-1)
    if size is not None and a.shape != (size,):
        raise InputError(f'{name} must be {size} numbers, got {a.shape[0]}; allowed: {size} values in SI units')
    if finite and not np.isfinite(a).all():
        raise InputError(f'{name} = {a.tolist()} is not finite; allowed: finite values in SI units')
    return [float(v) for v in a]


def _text(value: Any, name: str) -> str:
    """A request's string field: ``value``, None as empty (the node's default); another type aborted the whole
    process in rclpy's conversion to C (an assertion, no exception), a NUL cut the string there."""
    if value is None:
        return ''
    if not isinstance(value, str) or '\x00' in value:
        raise InputError(f'{name} = {brief(value)} is invalid; allowed: a string without NUL (empty or None: the '
                         "node's default)")
    return value


def _station(st: Any, i: int) -> ProgramStation:
    """A ``gpr/run_program`` goal's station from a mapping with the keys of the program format (a misspelt
    ``dwel`` was dropped, the dwell sent as 0; an int aborted the process as a string field's wrong type did)."""
    where = f'stations[{i}]'
    if not isinstance(st, Mapping):
        raise InputError(f'{where} = {brief(st)} is invalid; allowed: a mapping with height, tilt, azimuth (and name, '
                         'dwell, move_time)')
    unknown = sorted(str(k) for k in st if k not in STATION_KEYS)
    missing = [k for k in REQUIRED_STATION_KEYS if st.get(k) is None]   # None was sent as 0.0
    if unknown or missing:
        what = f'unknown key(s) {", ".join(unknown)}' if unknown else f'missing {", ".join(missing)}'
        raise InputError(f'{where}: {what}; allowed keys: {", ".join(sorted(STATION_KEYS))} (height, tilt, azimuth '
                         'required; SI units)')
    values = {k: _floats([st[k]], f'{where}.{k}', 1)[0] for k in ('height', 'tilt', 'azimuth', 'dwell', 'move_time')
              if st.get(k) is not None}
    return ProgramStation(name=_text(st.get('name'), f'{where}.name'), **values)


class ServiceTimeoutError(GprError, TimeoutError):
    """A service, action or message did not arrive in time."""


class GprClient:
    """Client side of the suite in its own rclpy context.

    Args:
        name: node name of the client.
        namespace: namespace of the client node; relative service and topic names resolve in it (``/robot1``
            talks to nodes started with ``-r __ns:=/robot1``).
        executor: ``'single'`` (rclpy's SingleThreadedExecutor) or ``'events'`` (rclpy.experimental's
            EventsExecutor: a round trip of ~0.3 ms instead of ~6-12 ms here; docs/benchmarks.md).
        args: ROS arguments for the context (e.g. ``['--ros-args', '-r', '__ns:=/x']``).
    """

    def __init__(self, name: str = 'gpr_client', *, namespace: str = '', executor: str = 'single',
                 args: Sequence[str] | None = None) -> None:
        if executor not in ('single', 'events'):   # before rclpy.init: a context and node refused here were never shut
            raise InputError(f"executor = {brief(executor)}; allowed: 'single' or 'events'")
        self.context = rclpy.Context()
        try:
            with stderr_held():   # rcutils' "error state is being overwritten" block before a refusal
                rclpy.init(args=None if args is None else list(args), context=self.context)
        except RCLError as exc:   # a traceback of gpr program send where HOME was unset
            self.context.try_shutdown()   # made before its logging refused
            raise GprError(f'cannot start a ROS client: {init_refusal(exc)}') from None
        self.node = rclpy.create_node(name, namespace=namespace, context=self.context)
        self.executor: Executor
        if executor == 'events':
            from rclpy.experimental import EventsExecutor

            self.executor = EventsExecutor(context=self.context)
        else:
            self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.lost = 0
        self._clients: dict[tuple[Any, str], Any] = {}

    # -- services ------------------------------------------------------------------------------------------------
    def client(self, srv_type: Any, name: str, timeout: float = 20.0) -> Any:
        """The (cached) service client of ``name``, once the service is available (:class:`ServiceTimeoutError`)."""
        key = (srv_type, name)
        if key not in self._clients:
            cli = self.node.create_client(srv_type, name, qos_profile=service_qos())
            if not cli.wait_for_service(timeout_sec=timeout):
                self.node.destroy_client(cli)
                raise ServiceTimeoutError(f'service {name} not available after {timeout} s')
            self._clients[key] = cli
        return self._clients[key]

    def call(self, srv_type: Any, name: str, request: Any, timeout: float = 5.0, tries: int = 3) -> Any:
        """Call service ``name`` and return its response; a response that does not come within ``timeout`` s is
        asked for again, up to ``tries`` times (then :class:`ServiceTimeoutError`)."""
        cli = self.client(srv_type, name)
        for _ in range(tries):
            future = cli.call_async(request)
            self.executor.spin_until_future_complete(future, timeout_sec=timeout)
            if future.done():
                return future.result()
            cli.remove_pending_request(future)
            self.lost += 1
        raise ServiceTimeoutError(f'no answer from {name} in {tries} tries of {timeout} s')

    def forward_kinematics(self, q: Vector, model: str = '') -> Any:
        """``gpr/forward_kinematics``: rod lengths ``q`` [m] -> ForwardKinematics.Response."""
        req = ForwardKinematics.Request(q=_floats(q, 'q', 3), model=_text(model, 'model'))
        return self.call(ForwardKinematics, Service.FORWARD_KINEMATICS, req)

    def inverse_kinematics(self, height: float, tilt: float, azimuth: float, model: str = '') -> Any:
        """``gpr/inverse_kinematics``: platform height [m], tilt and tilt azimuth [rad] -> the response."""
        height, tilt, azimuth = _floats((height, tilt, azimuth), 'height, tilt, azimuth', 3, finite=True)
        if not abs(tilt) < math.pi:   # a quaternion would fold it
            raise InputError(f'tilt = {tilt:g} rad; allowed: |tilt| < pi (the node judges its tilt limit)')
        within_turn(azimuth, 'azimuth')   # as the station service's: 90 (degrees) read as 2.04 rad
        quat = quaternion_from_matrix(tilt_rotation(tilt, azimuth))
        req = InverseKinematics.Request(target=pose_msg((0.0, 0.0, height), quat), model=_text(model, 'model'))
        return self.call(InverseKinematics, Service.INVERSE_KINEMATICS, req)

    def compensate(self, position: Vector, quaternion: Vector, tool_offset: Vector = (0.0, 0.0, 0.0),
                   model: str = '') -> Any:
        """``gpr/compensate``: naive command pose and tool offset (platform frame) [m] -> the response."""
        req = Compensate.Request(command=pose_msg(_floats(position, 'position', 3), _floats(quaternion, 'quaternion',
                                                                                             4)),
                               model=_text(model, 'model'))
        req.tool_offset.x, req.tool_offset.y, req.tool_offset.z = _floats(tool_offset, 'tool_offset', 3)
        return self.call(Compensate, Service.COMPENSATE, req)

    def analyze_mobility(self, q: Vector, dq: Vector = (0.0, 0.0, 0.0), model: str = '') -> Any:
        """``gpr/analyze_mobility``: ranks, singular values and bounds at ``q``, ``|dX|`` for ``dq`` [m]."""
        req = AnalyzeMobility.Request(q=_floats(q, 'q', 3), dq=_floats(dq, 'dq', 3), model=_text(model, 'model'))
        return self.call(AnalyzeMobility, Service.ANALYZE_MOBILITY, req)

    def robot_forward_kinematics(self, rods: Vector, joints: Vector, arm: str = '', model: str = '') -> Any:
        """``gpr/robot_forward_kinematics``: rod lengths [m] and the arm's joints [rad] -> the response (wafer,
        blade, platform in the world, exact and naive)."""
        req = RobotForwardKinematics.Request(rods=_floats(rods, 'rods', 3), joints=_floats(joints, 'joints'),
                                             arm=_text(arm, 'arm'), model=_text(model, 'model'))
        return self.call(RobotForwardKinematics, Service.ROBOT_FORWARD_KINEMATICS, req)

    def station_inverse_kinematics(self, position: Vector, tilt: float = 0.0, azimuth: float = 0.0,
                                   heading: float | None = 0.0, arm: str = '', branch: str = '',
                                   redundancy_value: float | None = None, model: str = '') -> Any:
        """``gpr/station_inverse_kinematics``: a station (wafer position in the world [m], the station plane's
        tilt and azimuth, the blade heading [rad]; ``heading=None`` leaves it free for a 2-joint arm) -> the
        response (rods, the arm's joints, the wafer reached, the naive model's wafer error)."""
        tilt, azimuth = _floats((tilt, azimuth), 'tilt, azimuth', 2)
        req = StationInverseKinematics.Request(tilt=tilt, azimuth=azimuth,
                                               heading=0.0 if heading is None else _floats([heading], 'heading')[0],
                                               heading_free=heading is None, arm=_text(arm, 'arm'),
                                               branch=_text(branch, 'branch'), model=_text(model, 'model'),
                                               use_redundancy_value=redundancy_value is not None,
                                               redundancy_value=_floats([redundancy_value or 0.0],
                                                                        'redundancy_value')[0])
        req.position.x, req.position.y, req.position.z = _floats(position, 'position', 3)
        return self.call(StationInverseKinematics, Service.STATION_INVERSE_KINEMATICS, req)

    # -- topics --------------------------------------------------------------------------------------------------
    def subscribe(self, msg_type: Any, topic: str, depth: int = 100_000, latched: bool = False) -> list[Any]:
        """Keep every message of ``topic`` in the returned list (reliable, keep last ``depth``; ``latched``:
        transient local, for ``gpr/geometry``, ``robot_description`` or ``/tf_static``)."""
        received: list[Any] = []
        self.node.create_subscription(msg_type, topic, received.append,
                                      latched_qos(depth) if latched else stream_qos(depth))
        return received

    def spin_for(self, seconds: float) -> None:
        """Run callbacks for ``seconds``."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=min(0.05, max(0.0, end - time.monotonic())))

    def spin_until(self, predicate: Callable[[], bool], timeout: float) -> bool:
        """Run callbacks until ``predicate()`` is true (True) or ``timeout`` s passed (``predicate()``)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return True
            self.executor.spin_once(timeout_sec=0.05)
        return bool(predicate())

    def wait(self, future: Future, timeout: float, what: str) -> Any:
        """Spin until ``future`` is done; its result, or :class:`ServiceTimeoutError` naming ``what``."""
        self.executor.spin_until_future_complete(future, timeout_sec=timeout)
        if not future.done():
            raise ServiceTimeoutError(f'{what}: no answer within {timeout} s')
        return future.result()

    # -- the gpr/run_program action ----------------------------------------------------------------------------------
    def send_program(self, program_file: str = '', stations: Iterable[dict[str, Any]] = (), move_time: float = 0.0,
                     feedback: Callable[[Any], None] | None = None, timeout: float = 20.0) -> Any:
        """Send a ``gpr/run_program`` goal (a program file or inline stations given as mappings with the keys
        of the program format) and return its goal handle once the node answered (``accepted`` tells)."""
        goal = RunProgram.Goal(program_file=_text(program_file, 'program_file'),   # refused before any wait
                               move_time=_floats([move_time], 'move_time', 1)[0],
                               stations=[_station(st, i) for i, st in enumerate(stations)])
        key = (RunProgram, Service.RUN_PROGRAM)
        if key not in self._clients:
            cli = ActionClient(self.node, RunProgram, Service.RUN_PROGRAM, **action_client_options(10000))
            if not cli.wait_for_server(timeout_sec=timeout):
                cli.destroy()
                raise ServiceTimeoutError(f'action gpr/run_program not available after {timeout} s')
            self._clients[key] = cli
        callback = (lambda msg: feedback(msg.feedback)) if feedback is not None else None
        return self.wait(self._clients[key].send_goal_async(goal, feedback_callback=callback), timeout,
                         'gpr/run_program goal')

    def run_program(self, program_file: str = '', stations: Iterable[dict[str, Any]] = (), move_time: float = 0.0,
                    feedback: Callable[[Any], None] | None = None, timeout: float = 600.0) -> Any:
        """Run a program to its end through ``gpr/run_program``; return the ``RunProgram.Result``
        (:class:`ServiceTimeoutError` after ``timeout`` s, :class:`GprError` if the goal was rejected)."""
        handle = self.send_program(program_file, stations, move_time, feedback)
        if not handle.accepted:
            raise GprError('gpr/run_program rejected the goal: another program or stream is running')
        return self.wait(handle.get_result_async(), timeout, 'gpr/run_program result').result

    def close(self) -> None:
        """Destroy the node and shut the context down."""
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    def __enter__(self) -> GprClient:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

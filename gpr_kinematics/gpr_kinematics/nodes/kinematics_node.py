"""``kinematics_node``: GPR forward/inverse kinematics, compensation and mobility analysis as ROS 2 services.

Services (relative names, so ``__ns`` and remapping apply), types from ``gpr_interfaces``: the platform's
(``gpr/forward_kinematics``, ``gpr/inverse_kinematics``, ``gpr/compensate``, ``gpr/analyze_mobility``:
:mod:`.platform_services`) and the whole robot's (``gpr/robot_forward_kinematics``,
``gpr/station_inverse_kinematics``: :mod:`.robot_services`). Each callback is request -> the core's one-pose or
one-station path -> the response, filled in place; this module adds what every service shares (:func:`guarded`).

Parameters: ``robot_file`` (the robot description, default the shipped example; its ``gpr`` section is the geometry
unless ``config_file`` is given) and the GprConfig keys (see :mod:`.params`). Units SI (m, rad). A bad request
(NaN, infinity, ``q`` outside the stroke, a tilt beyond ``tilt_limit``, an unknown model, a non-unit quaternion, an
unknown arm, a station out of reach) is answered with
``success: false`` and a message naming the problem, logged at warning level; the node goes on serving.
No exception escapes a callback (one would end the spin and leave the client waiting).

No request is dropped: the services keep every request and response (reliable, keep all: :func:`.qos.service_qos`;
with a queue of 100, a burst of 600 requests from one client got 208 answers). A request that waited longer than
the parameter ``max_queue_time`` (default 5 s) in the node's queue is answered at once with ``success: false`` and
a message starting ``saturated:`` (not computed), so that a node that cannot keep up tells its clients so, and
drains its queue, instead of answering requests their clients gave up on; its log says so at most every second,
with the count so answered.
"""
from __future__ import annotations

import functools
import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from rclpy.executors import Executor

from gpr_interfaces.srv import (
    AnalyzeMobility,
    Compensate,
    ForwardKinematics,
    InverseKinematics,
    RobotForwardKinematics,
    StationInverseKinematics,
)

from ..core.config import GprConfig, measured_points
from ..core.messages import DEFAULT_FRAMES, Service
from ..errors import GprError, InputError
from ..ros.specs import KINEMATICS, check_frame_prefix
from .conversions import first_non_finite
from .params import ConfigParameters, declare_parameters, declare_robot
from .platform_services import answer_compensate, answer_forward, answer_inverse, answer_mobility
from .qos import service_qos
from .robot_services import RobotModels, fill_robot_forward, fill_station_inverse
from .runtime import GprNode, QueueTimedExecutor, one_line, run

NODE_NAME = 'kinematics_node'


def guarded(service: str) -> Callable[..., Any]:
    """Wrap a service callback: a request the core refuses, a result that is not finite and any other exception
    become ``success: false`` with a message (logged at warning); nothing escapes (an escaping exception would
    end the spin and leave the client waiting)."""

    def wrap(fn: Callable[..., None]) -> Callable[..., Any]:
        @functools.wraps(fn)
        def inner(self: KinematicsNode, request: Any, response: Any) -> Any:
            age = self.request_age()
            if age > self.max_queue_time:   # logged too, at most every second: an operator saw no sign of it
                self.saturated += 1
                self.get_logger().warning(f'{service}: saturated: a request waited {age:.3g} s in the queue '
                                          f'(max_queue_time {self.max_queue_time:g} s), answered success: false; '
                                          f'{self.saturated} so answered since the start', throttle_duration_sec=1.0)
                return _failed(response, f'saturated: the request waited {age:.3g} s in the queue of '
                               f'{self.get_name()} (allowed: max_queue_time = {self.max_queue_time:g} s); not '
                               'computed: retry later, or send fewer requests at once')
            try:
                # Hostile numbers (1e308) overflow on the way: the result is then refused as not finite, below.
                with np.errstate(all='ignore'):
                    fn(self, request, response)
                bad = first_non_finite(response)
                if bad is not None:
                    raise InputError(f'the result is not finite ({bad}): the request is beyond what the model '
                                     'can represent')
            except GprError as exc:
                message = one_line(exc)
                self.get_logger().warning(f'{service}: rejected request: {message}')
                return _failed(response, message)
            except Exception as exc:  # noqa: BLE001 - nothing may escape a service callback
                message = f'internal error: {type(exc).__name__}: {one_line(exc)}'
                self.get_logger().warning(f'{service}: {message}')
                return _failed(response, message)
            response.success = True   # its message: '' or what a handler said (a fresh response each request)
            return response

        return inner

    return wrap


def _failed(response: Any, message: str) -> Any:
    """A fresh response of the same type (no half-filled numbers) with ``success: false`` and ``message``."""
    out = type(response)()
    out.success = False
    out.message = message
    return out


class KinematicsNode(GprNode):
    """Thin adapter: messages -> core calls -> messages."""

    NODE_NAME = NODE_NAME

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.params = ConfigParameters(self, robot=declare_robot(self))
        p = declare_parameters(self, KINEMATICS)
        self.max_queue_time = float(p['max_queue_time'])
        self.saturated = 0   # requests answered 'saturated:' (logged at most every second)
        self.frame_prefix = check_frame_prefix(p['frame_prefix'], (*DEFAULT_FRAMES, self.params.robot.world_frame))
        self._executor: QueueTimedExecutor | None = None
        self.robot_models = RobotModels()
        qos = service_qos()  # keep all: no request is dropped by a full queue (nodes/qos.py)
        self.create_service(ForwardKinematics, Service.FORWARD_KINEMATICS, self.on_forward, qos_profile=qos)
        self.create_service(InverseKinematics, Service.INVERSE_KINEMATICS, self.on_inverse, qos_profile=qos)
        self.create_service(Compensate, Service.COMPENSATE, self.on_compensate, qos_profile=qos)
        self.create_service(AnalyzeMobility, Service.ANALYZE_MOBILITY, self.on_mobility, qos_profile=qos)
        self.create_service(RobotForwardKinematics, Service.ROBOT_FORWARD_KINEMATICS, self.on_robot_forward,
                            qos_profile=qos)
        self.create_service(StationInverseKinematics, Service.STATION_INVERSE_KINEMATICS, self.on_station_inverse,
                            qos_profile=qos)
        cfg, robot = self.params.config, self.params.robot
        measured = measured_points(cfg)
        geometry = ' and '.join(measured) + ' at their measured positions' if measured else f'R = {cfg.radius} m'
        self.get_logger().info(f'serving gpr/forward_kinematics, gpr/inverse_kinematics, gpr/compensate, '
                               f'gpr/analyze_mobility (model {cfg.model}, {geometry}, stroke '
                               f'[{cfg.stroke_min}, {cfg.stroke_max}] m, tilt limit {cfg.tilt_limit} rad), '
                               f'gpr/robot_forward_kinematics, gpr/station_inverse_kinematics (robot {robot.name} '
                               f'from {robot.source}: arms {", ".join(robot.arm_names)})')

    def make_executor(self) -> Executor:
        """rclpy's single-threaded executor that also notes when each request arrived (for ``max_queue_time``)."""
        self._executor = QueueTimedExecutor()
        return self._executor

    def request_age(self) -> float:
        """Seconds the request being answered waited in the node's queue (0 when not known)."""
        return self._executor.request_age() if self._executor is not None else 0.0

    @property
    def config(self) -> GprConfig:
        return self.params.config

    @guarded('forward_kinematics')
    def on_forward(self, request: ForwardKinematics.Request, response: ForwardKinematics.Response) -> None:
        answer_forward(self.config, request, response)

    @guarded('inverse_kinematics')
    def on_inverse(self, request: InverseKinematics.Request, response: InverseKinematics.Response) -> None:
        answer_inverse(self.config, request, response)

    @guarded('compensate')
    def on_compensate(self, request: Compensate.Request, response: Compensate.Response) -> None:
        answer_compensate(self.config, request, response)

    @guarded('analyze_mobility')
    def on_mobility(self, request: AnalyzeMobility.Request, response: AnalyzeMobility.Response) -> None:
        answer_mobility(self.config, request, response)

    @guarded('robot_forward_kinematics')
    def on_robot_forward(self, request: RobotForwardKinematics.Request,
                         response: RobotForwardKinematics.Response) -> None:
        fill_robot_forward(self.robot_models.get(self.params.robot, request.model), request, response,
                           self.frame_prefix)

    @guarded('station_inverse_kinematics')
    def on_station_inverse(self, request: StationInverseKinematics.Request,
                           response: StationInverseKinematics.Response) -> None:
        fill_station_inverse(self.robot_models.get(self.params.robot, request.model), request, response,
                             self.frame_prefix)


def main(args: Sequence[str] | None = None) -> int:
    return run(KinematicsNode, args)


if __name__ == '__main__':
    sys.exit(main())


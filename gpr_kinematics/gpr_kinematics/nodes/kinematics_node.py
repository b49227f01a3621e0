"""``kinematics_node``: GPR forward/inverse kinematics, compensation and mobility analysis as ROS 2 services.

Services (relative names, so ``__ns`` and remapping apply), types from ``gpr_interfaces``:

- ``gpr/forward_kinematics`` (ForwardKinematics): rod lengths -> platform pose (core ``kinematics.forward``);
- ``gpr/inverse_kinematics`` (InverseKinematics): height and tilt of ``target`` -> rod lengths
  (core ``kinematics.inverse``; the tilt and tilt azimuth come from ``target.orientation`` through
  ``R = tilt_rotation(tilt, azimuth) Rz(twist)``, the twist is an outcome);
- ``gpr/compensate`` (Compensate): naive command pose + tool offset -> rod lengths, reached pose, tool shift
  and arm correction (core ``compensation.compensate``);
- ``gpr/analyze_mobility`` (AnalyzeMobility): ranks, singular values and the bounds of paper eq. (4), (5)
  (core ``mobility.analyze_mobility``);
- ``gpr/robot_forward_kinematics`` (RobotForwardKinematics) and ``gpr/station_inverse_kinematics``
  (StationInverseKinematics): the whole robot, its arms and wafers in the world (:mod:`.robot_services`).

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
drains its queue, instead of answering requests their clients gave up on.
"""
from __future__ import annotations

import array
import functools
import math
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

from ..core import forward, inverse
from ..core.compensation import compensate
from ..core.config import GprConfig
from ..core.mobility import analyze_mobility
from ..errors import GprError, InputError
from ..inputs.validation import finite_vector
from ..ros.specs import KINEMATICS
from .conversions import fill_forward, point_array, pose_arrays, pose_msg, tilt_of_quaternion, transform_msg, vector_msg
from .params import ConfigParameters, declare_parameters, declare_robot
from .qos import service_qos
from .robot_services import RobotModels, fill_robot_forward, fill_station_inverse
from .runtime import GprNode, QueueTimedExecutor, one_line, run

NODE_NAME = 'kinematics_node'


def _model(name: str) -> str | None:
    """Empty model string: the node's default (``None`` for the core); any other is taken exactly as sent (the core
    refuses a name that is not a model: ``"radial\\n"`` and ``" radial"`` are not)."""
    return name or None


def non_finite_field(msg: Any, prefix: str = '') -> str | None:
    """Path and value of the first non-finite number in a message (nested messages and arrays included), or
    None: a response never reports success with an infinite or NaN number in it."""
    for name in msg.get_fields_and_field_types():
        value = getattr(msg, name)
        path = f'{prefix}{name}'
        if hasattr(value, 'get_fields_and_field_types'):
            found = non_finite_field(value, path + '.')
            if found:
                return found
        elif isinstance(value, float):
            if not math.isfinite(value):
                return f'{path} = {value!r}'
        elif isinstance(value, (list, tuple, np.ndarray, array.array)) and len(value) and \
                isinstance(value[0], (float, np.floating)):
            bad = [i for i, v in enumerate(value) if not math.isfinite(float(v))]
            if bad:
                return f'{path}[{bad[0]}] = {float(value[bad[0]])!r}'
    return None


def guarded(service: str) -> Callable[..., Any]:
    """Wrap a service callback: a request the core refuses, a result that is not finite and any other exception
    become ``success: false`` with a message (logged at warning); nothing escapes (an escaping exception would
    end the spin and leave the client waiting)."""

    def wrap(fn: Callable[..., None]) -> Callable[..., Any]:
        @functools.wraps(fn)
        def inner(self: KinematicsNode, request: Any, response: Any) -> Any:
            age = self.request_age()
            if age > self.max_queue_time:
                return _failed(response, f'saturated: the request waited {age:.3g} s in the queue of '
                               f'{self.get_name()} (allowed: max_queue_time = {self.max_queue_time:g} s); not '
                               'computed: retry later, or send fewer requests at once')
            try:
                # Hostile numbers (1e308) overflow on the way: the result is then refused as not finite, below.
                with np.errstate(all='ignore'):
                    fn(self, request, response)
                bad = non_finite_field(response)
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
            response.success = True
            response.message = ''
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
        self.max_queue_time = float(declare_parameters(self, KINEMATICS)['max_queue_time'])
        self._executor: QueueTimedExecutor | None = None
        self.robot_models = RobotModels()
        qos = service_qos()  # keep all: no request is dropped by a full queue (nodes/qos.py)
        self.create_service(ForwardKinematics, 'gpr/forward_kinematics', self.on_forward, qos_profile=qos)
        self.create_service(InverseKinematics, 'gpr/inverse_kinematics', self.on_inverse, qos_profile=qos)
        self.create_service(Compensate, 'gpr/compensate', self.on_compensate, qos_profile=qos)
        self.create_service(AnalyzeMobility, 'gpr/analyze_mobility', self.on_mobility, qos_profile=qos)
        self.create_service(RobotForwardKinematics, 'gpr/robot_forward_kinematics', self.on_robot_forward,
                            qos_profile=qos)
        self.create_service(StationInverseKinematics, 'gpr/station_inverse_kinematics', self.on_station_inverse,
                            qos_profile=qos)
        cfg, robot = self.params.config, self.params.robot
        self.get_logger().info(f'serving gpr/forward_kinematics, gpr/inverse_kinematics, gpr/compensate, '
                               f'gpr/analyze_mobility (model {cfg.model}, R = {cfg.radius} m, stroke '
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
        q = finite_vector(request.q, 'q', 3)
        fk = forward(q, self.config, _model(request.model))
        fill_forward(response, fk)

    @guarded('inverse_kinematics')
    def on_inverse(self, request: InverseKinematics.Request, response: InverseKinematics.Response) -> None:
        position, quat = pose_arrays(request.target, 'target')
        tilt, azimuth, _twist = tilt_of_quaternion(quat)
        ik = inverse(float(position[2]), tilt, azimuth, self.config, _model(request.model))
        fk = ik.achieved
        response.q = np.asarray(ik.q, dtype=float).reshape(3)
        response.achieved = pose_msg(fk.position, fk.quaternion)
        response.tilt = float(fk.tilt)
        response.tilt_azimuth = float(fk.tilt_azimuth)
        response.twist = float(fk.twist)
        response.iterations = int(ik.iterations)

    @guarded('compensate')
    def on_compensate(self, request: Compensate.Request, response: Compensate.Response) -> None:
        position, quat = pose_arrays(request.command, 'command')
        tool = point_array(request.tool_offset, 'tool_offset')
        res = compensate(position, quat, tool_offset=tool, config=self.config, model=_model(request.model))
        fk = res.achieved
        response.q = np.asarray(res.q, dtype=float).reshape(3)
        response.achieved = pose_msg(fk.position, fk.quaternion)
        response.tool_shift = vector_msg(res.tool_shift)
        response.arm_correction = transform_msg(res.arm_correction_translation, res.arm_correction_quaternion)

    @guarded('analyze_mobility')
    def on_mobility(self, request: AnalyzeMobility.Request, response: AnalyzeMobility.Response) -> None:
        q = finite_vector(request.q, 'q', 3)
        dq = finite_vector(request.dq, 'dq', 3)
        res = analyze_mobility(q, self.config, _model(request.model))
        fill_mobility(response, res, dq)

    @guarded('robot_forward_kinematics')
    def on_robot_forward(self, request: RobotForwardKinematics.Request,
                         response: RobotForwardKinematics.Response) -> None:
        fill_robot_forward(self.robot_models.get(self.params.robot, request.model), request, response)

    @guarded('station_inverse_kinematics')
    def on_station_inverse(self, request: StationInverseKinematics.Request,
                           response: StationInverseKinematics.Response) -> None:
        fill_station_inverse(self.robot_models.get(self.params.robot, request.model), request, response)


def fill_mobility(response: Any, res: Any, dq: np.ndarray | None = None) -> Any:
    """Copy a core ``MobilityResult`` into an AnalyzeMobility response; with a non-zero ``dq`` [m] also
    ``|dX|`` and the bounds (4), (5) for ``dP = res.rod_perturbation(dq)`` (along the machine's own rod directions
    ``u_k``: rods that are not parallel move their joint centres off the base z axis)."""
    response.rank_dphi_dp = int(res.rank_dphi_dp)
    response.rank_augmented = int(res.rank_augmented)
    response.mobility = int(res.mobility)
    response.singular_values = [float(v) for v in np.asarray(res.singular_values).reshape(-1)]
    response.eigenvalues = [float(v) for v in np.asarray(res.eigenvalues).reshape(-1)]
    response.eq4_lower, response.eq4_upper = (float(v) for v in res.bounds['eq4'])
    response.eq5_lower, response.eq5_upper = (float(v) for v in res.bounds['eq5'])
    if dq is not None and np.any(dq != 0.0):
        b = res.dx_bounds(res.rod_perturbation(dq))
        response.dx_norm = b.norm_dx
        response.dx_lower_eq4, response.dx_upper_eq4 = b.lower_eq4, b.upper_eq4
        response.dx_lower_eq5, response.dx_upper_eq5 = b.lower_eq5, b.upper_eq5
    return response


def main(args: Sequence[str] | None = None) -> int:
    return run(KinematicsNode, args)


if __name__ == '__main__':
    sys.exit(main())


"""The accuracy budget at the stations of the GPR and of the whole robot (what ``gpr accuracy`` prints).

* :func:`platform_budget`: platform poses given as height, tilt and azimuth (a ``--pose``, or the stations of a
  platform program of ``trajectory_node``): the rod lengths from the core's inverse kinematics
  (:func:`gpr_kinematics.core.inverse_batch`, under the budget's model), the tool point on the platform, the
  errors in ``gpr_base``;
* :func:`robot_budget`: the stations of a whole-robot program (``config/programs/``, docs/robot.md): each station
  the program visits (a ``move`` to it or the wafer handed over there: the ``at`` waypoint of a pick or place), with
  the arm and the branch of its first visit, solved by :func:`gpr_kinematics.robot.solve_stations`; the tool point
  is then that arm's **wafer centre** on the platform at the station's joints, the errors are given in the axes of
  the world (the robot's base frame), and the arm is taken as exact (its joint and link errors are not in the
  tolerance table).

Both return a :class:`~.budget.Budget` of the core model (:class:`~.core_model.CoreModel`: every parameter of the
geometry file, ``compliant`` unless a model is named), optionally after a planned calibration
(:func:`planned_calibration`: ``N`` configurations of ``gpr calibrate --plan N`` measured with the table's
``measurement_noise``; the calibrated parameters are then known to the plan's covariance instead of the table, and
the parameters the plan holds keep their tolerance, compensated through the calibrated ones by the plan's alias).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..callbacks import StageProgress
from ..core.config import GprConfig
from ..errors import InputError
from .budget import Budget, accuracy_budget
from .core_model import CoreModel
from .identification import DEFAULT_SIGMA_ANGLE, DEFAULT_SIGMA_POSITION
from .monte_carlo import drawn_from
from .tolerances import ToleranceTable, centre_of, prior_of

Array = NDArray[np.float64]


@dataclass(frozen=True)
class BudgetOptions:
    """What a budget is computed with: Monte Carlo ``samples`` and ``seed``, the virtual-joint ``model`` (None: the
    core model's default, compliant), ``plan``: the size of a planned calibration (0: none), ``progress``: the
    Monte Carlo's listener (:func:`~.monte_carlo.monte_carlo`), and ``keep_samples``: keep the Monte Carlo's samples
    of that many first stations (``Budget.kept``, for a plot)."""

    samples: int = 10_000
    seed: int = 0
    model: str | None = None
    plan: int = 0
    progress: StageProgress | None = None
    keep_samples: int = 0


def planned_calibration(model: CoreModel, table: ToleranceTable, n: int
                        ) -> tuple[NDArray[np.int64], Array, tuple[NDArray[np.int64], Array]]:
    """``(indices, covariance, (held_indices, alias))`` of the parameters a calibration from the ``n`` configurations
    of :func:`~.plan.plan_measurements` determines, measured with the table's ``measurement_noise`` (the default
    tracker sigmas where it gives none), its standard deviations as the prior, made where its tolerances are
    (:func:`~.tolerances.centre_of`: a ``kappa`` range's centre); the alias of the parameters it holds on them: the
    calibration absorbs their deviations into the fitted ones (:attr:`~.plan.MeasurementPlan.alias`)."""
    from .plan import plan_measurements
    sp = table.sigma_position if table.sigma_position is not None else DEFAULT_SIGMA_POSITION
    sa = table.sigma_angle if table.sigma_angle is not None else DEFAULT_SIGMA_ANGLE
    with drawn_from(table):
        plan = plan_measurements(model, model.config, n, sigma_position=sp, sigma_angle=sa,
                                 prior=prior_of(table, model.parameters), theta=centre_of(table, model.parameters))
    return plan.fitted, plan.covariance, (plan.held_indices, plan.alias)


def _budget(config: GprConfig, Q: Array, table: ToleranceTable, tool: ArrayLike, labels: Sequence[str],
            options: BudgetOptions, frame: str = 'gpr_base', rotation: Array | None = None) -> Budget:
    model = CoreModel(config, options.model)
    calibrated = planned_calibration(model, table, options.plan) if options.plan else None
    theta = model.parameters.nominal.copy()
    if calibrated is not None:   # the calibration finds the machine: its parameters where the tolerances are
        theta[calibrated[0]] = centre_of(table, model.parameters)[calibrated[0]]
    return accuracy_budget(model, Q, table, tool=tool, samples=options.samples, seed=options.seed, labels=labels,
                           theta=theta, calibrated=calibrated, frame=frame, frame_rotation=rotation,
                           progress=options.progress, keep_samples=options.keep_samples)


def platform_budget(config: GprConfig, table: ToleranceTable, height: ArrayLike, tilt: ArrayLike,
                    azimuth: ArrayLike, tool: ArrayLike = (0.0, 0.0, 0.0), labels: Sequence[str] | None = None,
                    options: BudgetOptions = BudgetOptions()) -> Budget:
    """The budget of platform poses (heights [m], tilts and azimuths [rad], broadcast together) with a tool point
    in ``gpr_platform`` (module docstring).

    Raises:
        LimitError: a pose beyond the tilt limit or the stroke (named by the inverse kinematics).
        InputError, ConfigError: a bad option or table (:func:`~.budget.accuracy_budget`).
    """
    from ..core import inverse_batch
    from .core_model import MODEL
    h, t, g = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float)) for v in (height, tilt, azimuth)))
    Q = inverse_batch(h, t, g, config, options.model or MODEL).q
    names = labels if labels is not None else [f'h {a:g} m, tilt {b:.6g} rad, azimuth {c:.6g} rad'
                                               for a, b, c in zip(h, t, g, strict=True)]
    return _budget(config, Q, table, tool, names, options)


@dataclass(frozen=True)
class RobotStations:
    """The stations of a robot program a budget is made for: ``labels`` (``station (arm)``), rod lengths ``q``
    ``(N, 3)`` [m] and the wafer centre of each station's arm in ``gpr_platform`` ``(N, 3)`` [m]."""

    labels: tuple[str, ...]
    q: Array
    wafer: Array


def robot_stations(robot: Any, program: Any) -> RobotStations:
    """Each station ``program`` visits (a move to it, or the wafer handed over there), with the arm and branch of its
    first visit, solved for the robot (module docstring)."""
    from ..robot import solve_stations
    from ..robot.plan import check_wafers
    from ..robot.program import expand
    way = expand(program, robot)
    check_wafers(program, way)   # a program every other command refuses is not budgeted either
    seen: dict[tuple[str, str], int] = {}
    for i, phase in enumerate(way.phase):
        key = (way.stations.names[i], way.arm[i])
        if phase in ('move', 'at') and key not in seen:
            seen[key] = i
    if not seen:
        raise InputError(f'{program.source}: no station is visited (the steps are dwells only)')
    order = list(seen.values())
    q, wafer = np.zeros((len(order), 3)), np.zeros((len(order), 3))
    for arm in dict.fromkeys(way.arm[i] for i in order):
        rows = [k for k, i in enumerate(order) if way.arm[i] == arm]
        idx = [order[k] for k in rows]
        sol = solve_stations(robot, way.stations.take(idx), arm=arm, branch=[way.branch[i] for i in idx])
        q[rows], wafer[rows] = sol.rods, sol.forward.wafer_on_platform.position
    labels = tuple(f'{way.stations.names[i]} ({way.arm[i]})' for i in order)
    return RobotStations(labels, q, wafer)


def robot_budget(robot: Any, program: Any, table: ToleranceTable, options: BudgetOptions = BudgetOptions()
                 ) -> Budget:
    """The budget at the stations of a robot program, the tool point being each station's wafer centre, the errors
    in the world's axes (module docstring)."""
    st = robot_stations(robot, program)
    return _budget(robot.config, st.q, table, st.wafer, st.labels, options, frame=robot.world_frame,
                   rotation=robot.base_rotation)

"""``gpr program check``'s safety verdict: the certified clearance of the program in its cell and against itself,
wafer slip, with the wafers where the program puts them (docs/cell.md), and the imperfection budget at the samples
of a stream of the program (:mod:`.budget`: what ``gpr verify`` judges of its recording).

Wafers: a station listed in the program's ``wafers`` holds one from the start (a program that declares none has
its picks find a wafer there, which is not modelled before the pick); a pick takes the station's wafer
onto the arm's blade when the blade reaches it (arrival at the ``at`` waypoint), a place leaves it in the station
(the same instant of its ``at``); a place with an empty blade in a program without ``wafers`` carries its wafer from
the start, or from the arm's next waypoint after its last place. A wafer in a station is a fixed disc at the station
pose. The blade touches the
wafer it picks or places, on purpose: that pair is not checked from the departure from the ``approach`` waypoint
to the arrival at the ``retract`` one.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Collection
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..callbacks import StageProgress, reporter
from ..errors import ConfigError, InputError, brief
from ..inputs.validation import switch
from ..robot.plan import ProgramPlan, joint_limits
from ..robot.timing import MAX_SAMPLES
from ..robot.trajectory import JointTrajectory
from .bodies import Body, Windows, cell_bodies, default_pairs, robot_body_set
from .budget import BudgetReport, judge_budget
from .cell import Cell
from .clearance import BASE_RATE, TOLERANCE, ClearanceReport, PairClearance, check_numbers, clearance, slack_note
from .joint_motion import TrajectoryMotion
from .margin import MARGIN, STREAM_RATE
from .motion import PROVEN_MODELS, PlanMotion, grid_within, move_counts
from .slip import slip_series
from .slip_bound import SlipBound, slip_bound

Array = NDArray[np.float64]
#: Rate [Hz] at which the slip ratio is evaluated (plus every waypoint's instants).
SLIP_RATE = 200.0
#: How far on each side of an S-curve's corner the slip ratio is evaluated too [s]: without a jerk limit (a
#: trapezoid) the acceleration jumps there, and the corner itself takes one side only. At least 4 spacings of the
#: doubles at the corner (:func:`corner_sides`): beyond 1.7e7 s they are 3.7e-9 s apart and 1 ns was none.
CORNER_SIDE = 1e-9


@dataclass(frozen=True)
class Collision:
    """A pair below the margin: the bodies, its crossing of the margin (:mod:`.crossing`: to 1 us) [s], the pair's
    least certified distance [m], the step, station and waypoint label of that instant; ``measured_below`` False: none
    measured below the margin, only the bounds between samples could not show the pair the margin apart (``time``
    then the instant of ``measured``, the smallest distance measured [m], less the library's slack)."""

    bodies: tuple[str, str]
    time: float
    distance: float
    step: int
    station: str
    label: str
    measured_below: bool = True
    measured: float = float('nan')

    def not_shown(self, margin: float) -> str:
        """A pair below the ``margin`` by its bounds only, in words (the goal check's refusal's)."""
        return (f'{" / ".join(self.bodies)} could not be shown the margin apart: at least {self.distance * 1e3:.3f} mm '
                f'by the bounds between samples, {self.measured * 1e3:.3f} mm measured at {self.time:.3f} s'
                f'{slack_note(self.measured, margin)}')


@dataclass(frozen=True)
class MoveSafety:
    """One row per waypoint (the move into it and its hold): the times, the bound on its slip ratio."""

    waypoint: int
    label: str
    start: float
    end: float
    max_slip_ratio: float


@dataclass(frozen=True)
class SafetyReport:
    """The verdict. ``safe``: every pair at least ``margin`` apart, every slip ratio below 1 and every sample within
    the imperfection budget.

    Attributes:
        min_clearance: the smallest certified distance of any pair [m]; pairs: every pair, closest first
            (``bodies``, ``distance`` [m], ``time`` [s]); collisions: the pairs below the margin, first first.
        max_slip_ratio: an upper bound of the slip ratio of a carried wafer over the whole motion (0: none carried,
            wafer_carried false, max_slip_at NaN and slip_label ''; :mod:`~gpr_kinematics.safety.slip_bound`);
            max_slip_evaluated: the largest ratio evaluated, at max_slip_at [s] in the waypoint slip_label;
            slip_certified: the bound is within :data:`~gpr_kinematics.safety.slip_bound.SLIP_TOLERANCE` of the
            evaluated ratios on every move, or of its floor (else its refinement ran out of instants and the bound is
            looser, still a bound); moves: the bound per waypoint.
        cell: the cell file (None: the robot against itself); evaluations: distance calls; instants: poses computed.
        model: the GPR's virtual-joint model; proven: the bounds between samples (clearance and slip) are proofs,
            as for ``radial`` (:data:`~gpr_kinematics.safety.motion.PROVEN_MODELS`); else the virtual joints' motion
            enters them to first order (docs/cell.md, "The certificate").
    """

    safe: bool
    min_clearance: float
    margin: float
    tolerance: float
    pairs: tuple[dict[str, object], ...]
    collisions: tuple[Collision, ...]
    max_slip_ratio: float
    max_slip_evaluated: float
    max_slip_at: float
    slip_label: str
    slip_certified: bool
    wafer_carried: bool
    moves: tuple[MoveSafety, ...]
    cell: str | None
    evaluations: int
    instants: int
    model: str
    proven: bool
    budget: BudgetReport | None = None

    @property
    def bound(self) -> str:
        """What the slip bound is, in words: ``a bound``, or ``a first-order bound`` where not :attr:`proven`."""
        return 'a bound' if self.proven else 'a first-order bound'

    @property
    def between_samples(self) -> str:
        """How the clearance holds between the samples, in words."""
        if self.proven:
            return 'certified between samples'
        return (f'bounded between samples to first order in the {self.model} model\'s virtual joints (proven for '
                f'{" and ".join(PROVEN_MODELS)} only)')


@dataclass(frozen=True)
class WaferPlan:
    """Where the wafers are: each arm's carrying windows, the wafers left in stations (their body names,
    :func:`station_wafer`, stations and windows), and per (arm, station) the windows of intended contact."""

    carried: dict[str, Windows]
    stations: tuple[tuple[str, str, Windows], ...]
    contact: dict[tuple[str, str], Windows]


#: The prefix of the body names of wafers lying in stations (:func:`station_wafer`), which no obstacle may take.
STATION_WAFER = 'wafer@'


def station_wafer(station: str, origin: str) -> str:
    """The body name of a wafer lying in ``station``: ``wafer@STATION:start`` for one there from the start (the
    program's ``wafers``), ``wafer@STATION:steps[K]`` for one the place ``steps[K]`` left there (a station may hold
    several in turn: ``wafer@STATION`` named them alike)."""
    return f'{STATION_WAFER}{station}:{origin}'


def wafer_plan(plan: ProgramPlan) -> WaferPlan:
    """Follow the wafers through the planned program (module docstring): their windows in time. The order of picks
    and places was checked when the program was planned (:func:`~gpr_kinematics.robot.plan.check_wafers`)."""
    way, timing, program = plan.waypoints, plan.timing, plan.program
    end = timing.total
    present: dict[str, tuple[float, str]] = {name: (0.0, 'start') for name in program.wafers or ()}
    stations: list[tuple[str, str, Windows]] = []
    carrying: dict[str, float] = {}
    emptied: dict[str, float] = {}   # when each arm's blade had left the station of its last place
    cleared: dict[str, tuple[float, str]] = {}   # when the blade of each station's last pick had left it, and which
    carried: dict[str, list[tuple[float, float]]] = {a.name: [] for a in plan.robot.arms}
    contact: dict[tuple[str, str], list[tuple[float, float]]] = {}
    for i, phase in enumerate(way.phase):
        if phase != 'at':
            continue
        step = program.steps[int(way.step[i])]
        arm, station = way.arm[i], str(step.station)
        t = float(timing.arrive[i])
        approach = max(k for k in range(i) if way.phase[k] in ('approach',) and int(way.step[k]) == int(way.step[i]))
        retract = i + 1
        contact.setdefault((arm, station), []).append((float(timing.depart[approach]), float(timing.arrive[retract])))
        if step.kind == 'pick':   # the order of picks and places: refused by plan_program where wrong
            lying = present.pop(station, None)
            if lying is None and program.wafers is None:   # without the key a pick finds one where it picks: there
                lying = cleared.get(station, (0.0, 'start'))   # since the start, or since the last pick there left
            if lying is not None and lying[0] < t:
                stations.append((station_wafer(station, lying[1]), station, ((lying[0], t),)))
            carrying[arm] = t
            after = next((k for k in range(retract + 1, len(way.arm)) if way.arm[k] == arm), None)
            cleared[station] = (end if after is None else float(timing.arrive[after]), f'steps[{int(way.step[i])}]')
        else:
            if arm in carrying:
                carried[arm].append((carrying.pop(arm), t))
            elif program.wafers is None:   # without the key a place has one to place: on the blade since the start,
                carried[arm].append((emptied.get(arm, 0.0), t))   # or since the arm's last place (it went unchecked)
            # from the arm's next waypoint on: not while the emptied blade backs out past the wafer it left (a wafer
            # put there at the retract lay 0.8 mm under the blade, beside the one just placed: a false collision)
            after = next((k for k in range(retract + 1, len(way.arm)) if way.arm[k] == arm), None)
            emptied[arm] = end if after is None else float(timing.arrive[after])
            present[station] = (t, f'steps[{int(way.step[i])}]')
    for arm, t0 in carrying.items():
        carried[arm].append((t0, end))
    stations += [(station_wafer(name, origin), name, ((t0, end),)) for name, (t0, origin) in present.items()]
    return WaferPlan({a: tuple(w) for a, w in carried.items()}, tuple(stations),
                     {k: tuple(w) for k, w in contact.items()})


def program_bodies(plan: ProgramPlan, cell: Cell | None, wafers: WaferPlan | None = None
                   ) -> tuple[list[Body], list[tuple[int, int, Windows]]]:
    """The bodies of ``plan`` in ``cell`` (the robot's, each carried wafer in its windows, the wafers lying in the
    stations, the cell's) and the pairs to check, each with the windows it is not (a blade in contact with the wafer
    it picks or places): what :func:`check_program` and :func:`trajectory_clearance` check."""
    wafers = wafer_plan(plan) if wafers is None else wafers
    robot = plan.robot
    bodies = robot_body_set(robot, wafers.carried)
    _own_names(cell, bodies, robot.name)
    bodies += cell_bodies(None if cell is None else cell.in_frame(robot.world_frame))
    index = plan.program.stations.index()
    st = plan.program.stations.stations
    station_of: dict[str, str] = {}
    for name, station, windows in wafers.stations:
        k = index[station]
        R = st.take([k]).rotation[0]
        wafer = next(b for b in bodies if b.frame and b.frame.endswith('_wafer'))
        bodies.append(Body(name, 'cylinder', wafer.size, None, R, st.position[k], windows))
        station_of[name] = station
    pairs = []
    for i, j in default_pairs(bodies):
        skip: Windows = ()
        for a, b in ((bodies[i], bodies[j]), (bodies[j], bodies[i])):
            if a.frame and a.arm and a.frame == f'{a.arm}_blade' and b.name in station_of:
                skip = wafers.contact.get((a.arm, station_of[b.name]), ())
        pairs.append((i, j, skip))
    return bodies, pairs


def _own_names(cell: Cell | None, robot_bodies: list[Body], robot: str) -> None:
    """Refuse an obstacle named as a body of the robot or a station's wafer (``wafer@...``): a pin called
    ``gpr_base`` read as the column colliding with a wafer, one called ``arm1_wafer`` as ``arm1_wafer / arm1_wafer``."""
    taken = {b.name for b in robot_bodies}
    for name in () if cell is None else cell.names:
        if name in taken or name.startswith(STATION_WAFER):
            raise ConfigError(f'{cell.source if cell else "cell"}: obstacle {name!r} has the name of a body of robot '
                              f"{robot}; allowed: a name no robot body has and not starting '{STATION_WAFER}' "
                              f'(its bodies: {", ".join(sorted(taken))})')


def trajectory_clearance(plan: ProgramPlan, cell: Cell | None, traj: JointTrajectory, margin: float = MARGIN,
                         tolerance: float = TOLERANCE, decide: bool = True,
                         only: Collection[tuple[str, str]] | None = None, wafers: WaferPlan | None = None
                         ) -> ClearanceReport:
    """The certified clearance of the program's bodies (:func:`program_bodies`) over ``traj``, the program as a
    controller interpolates its points (:func:`~gpr_kinematics.robot.trajectory.program_trajectory`, times from the
    program's start): between points a few per second apart the spline leaves the checked motion (the example cell
    program at 0.3 Hz put arm2's blade 8.7 mm into a chamber's wall). ``decide``: as
    :func:`~gpr_kinematics.safety.clearance.clearance`'s; ``only``: just these pairs of body names; ``wafers``: where
    the wafers are (default the program's, :func:`wafer_plan`)."""
    names = joint_limits(plan.robot)[0]
    columns = np.arange(len(names))
    if len(traj.joint_names) != len(names):
        raise InputError(f'the trajectory has {len(traj.joint_names)} joints; allowed: every joint of the robot '
                         f'({len(names)}), as program_trajectory and lead_in make it')
    moving = TrajectoryMotion.of(plan.robot, traj, columns, traj.positions[0])
    bodies, pairs = _pairs_of(*program_bodies(plan, cell, wafers), only)
    return clearance(moving, bodies, pairs, margin, tolerance, decide=decide)


def at_the_start(wafers: WaferPlan) -> WaferPlan:
    """``wafers`` as they are at the program's start, for all time: an arm carrying one then carries it throughout,
    a wafer lying in a station then lies there throughout; the rest never (the bodies of the move to the program's
    first point, :func:`lead_in_clearance`). No contact is intended on that move: a blade in contact with a station's
    wafer at the start would have the pair left out of the whole move (it could sweep through the wafer), so such a
    start is judged by the margin, conservatively."""
    always, never = ((0.0, np.inf),), ((np.inf, np.inf),)

    def now(windows: Windows) -> bool:
        return any(lo <= 0.0 <= hi for lo, hi in windows)

    return WaferPlan({arm: always if now(w) else () for arm, w in wafers.carried.items()},
                     tuple((name, station, always if now(w) else never) for name, station, w in wafers.stations), {})


def lead_in_clearance(plan: ProgramPlan, cell: Cell | None, lead: JointTrajectory, margin: float = MARGIN,
                      tolerance: float = TOLERANCE, decide: bool = True,
                      only: Collection[tuple[str, str]] | None = None) -> ClearanceReport:
    """The certified clearance over ``lead``, the move of every joint from where the robot is to the program's first
    point (:func:`~gpr_kinematics.robot.trajectory.lead_in`, times from the move's start) as a controller interpolates
    its points: :func:`trajectory_clearance` with the wafers as they are at the program's start (:func:`at_the_start`).
    ``gpr program send`` adds the move, which no program check sees (a program checked safe drove arm2's blade 45 mm
    into a chamber's wall)."""
    return trajectory_clearance(plan, cell, lead, margin, tolerance, decide, only, at_the_start(wafer_plan(plan)))


def program_clearance(plan: ProgramPlan, cell: Cell | None, margin: float = MARGIN, decide: bool = True,
                      only: Collection[tuple[str, str]] | None = None) -> ClearanceReport:
    """The clearance :func:`check_program` certifies (the program's bodies over the planned motion), each pair
    searched only until its verdict is decided (``decide``, a pair below the margin then quoting bounds) or to its
    minimum; ``only``: just these pairs of body names."""
    bodies, pairs = _pairs_of(*program_bodies(plan, cell), only)
    return clearance(PlanMotion(plan), bodies, pairs, margin, TOLERANCE, decide=decide)


def _pairs_of(bodies: list[Body], pairs: list[tuple[int, int, Windows]], only: Collection[tuple[str, str]] | None
              ) -> tuple[list[Body], list[tuple[int, int, Windows]]]:
    """``bodies`` and those of ``pairs`` whose names are among ``only`` (all where None)."""
    if only is None:
        return bodies, pairs
    return bodies, [(i, j, w) for i, j, w in pairs if (bodies[i].name, bodies[j].name) in only]


def check_program(plan: ProgramPlan, cell: Cell | None, margin: float = MARGIN, tolerance: float = TOLERANCE,
                  progress: StageProgress | None = None, rate: float = STREAM_RATE, with_clearance: bool = True
                  ) -> tuple[SafetyReport, ClearanceReport, tuple[Array, Array]]:
    """The safety verdict of a checked program in ``cell`` (module docstring); also the clearance report and the
    slip ratio against time (for the plot). ``progress``: told the share of each stage done as it goes (the
    clearance after each round of its search; the slip after each carrying arm's ratios and each round of its
    bound). ``rate`` [Hz]: the stream whose samples
    the imperfection budget is judged at. ``with_clearance=False``: the slip and the budget only (no python-fcl
    needed; no pair, a minimum clearance of ``inf``).

    Raises:
        InputError: a plan that is no ProgramPlan, a cell that is neither a Cell nor None, a rate outside
            :data:`~gpr_kinematics.robot.grid.RATES`, a margin or tolerance outside their ranges (with the clearance
            or without), a switch that is no truth value.
    """
    if not isinstance(plan, ProgramPlan):
        raise InputError(f'plan = {brief(plan)}; allowed: a ProgramPlan (plan_program)')
    if cell is not None and not isinstance(cell, Cell):
        raise InputError(f'cell = {brief(cell)}; allowed: a Cell (load_cell or parse_cell) or None (no cell)')
    check_numbers(margin, tolerance, BASE_RATE)   # reported without the clearance too ('0.002' was echoed as text)
    with_clearance = switch(with_clearance, 'with_clearance')   # 'no' ran the clearance
    tell = reporter(progress)
    budget = judge_budget(plan, rate)
    wafers = wafer_plan(plan)
    robot = plan.robot
    if with_clearance:
        bodies, pairs = program_bodies(plan, cell, wafers)
        report = clearance(PlanMotion(plan), bodies, pairs, margin, tolerance,
                           progress=lambda share: tell('clearance', share))
    else:
        report = ClearanceReport((), math.inf, margin, tolerance, 0, 0)
    tell('slip', 0.0)
    times = _slip_times(plan)
    ratio, bound = _slip(plan, times, wafers.carried, lambda share: tell('slip', share))
    tell('slip', 1.0)
    every = np.concatenate([times, bound.time])
    seen = np.concatenate([ratio, np.where(np.isnan(bound.ratio), 0.0, bound.ratio)])
    k = int(np.argmax(seen))
    moves = _moves(plan, times, ratio, bound)
    most = max(float(seen[k]), max((m.max_slip_ratio for m in moves), default=0.0))
    collisions = tuple(sorted((_collision(plan, p) for p in report.below_margin), key=lambda c: c.time))
    safe = not collisions and most < 1.0 and not budget.beyond
    pairs_out = tuple({'bodies': list(p.bodies), 'distance': p.distance, 'time': p.time} for p in report.pairs)
    carried = any(wafers.carried.values())   # none: no instant or step to name (0.000 s, steps[0] were named)
    at, label = (float(every[k]), label_at(plan, float(every[k]))) if carried else (math.nan, '')
    return (SafetyReport(safe, report.min_clearance, margin, tolerance, pairs_out, collisions, most, float(seen[k]),
                         at, label, bound.closed, carried, moves,
                         None if cell is None else cell.source, report.evaluations, report.instants,
                         robot.config.model, robot.config.model in PROVEN_MODELS, budget),
            report, (times, ratio))


def _slip(plan: ProgramPlan, times: Array, carried: dict[str, Windows], progress: Callable[[float], None]
          ) -> tuple[Array, SlipBound]:
    """The slip ratio at ``times`` (0 where no wafer is carried) and its bound between them, each arm's wafer on its
    own and the larger ratio where two arms carry at once (one array of the carrying arm had kept the later arm's:
    the other wafer's slip went unchecked). ``progress``: the share done after each arm's ratios (half of its
    share) and each round of its bound (a 2,000-step program's 13 s had said nothing between 0 and 100 %)."""
    ratio = np.zeros(times.shape)
    bounds = []
    arms = [(arm, windows) for arm, windows in carried.items() if windows]
    for k, (arm, windows) in enumerate(arms):
        carrying = np.full(times.shape, '', dtype=object)
        for t0, t1 in windows:
            carrying[(times >= t0) & (times <= t1)] = arm
        own = slip_series(plan, times, carrying).ratio
        progress((k + 0.5) / len(arms))
        ratio = np.fmax(ratio, np.where(np.isnan(own), 0.0, own))

        def bound_share(share: float, k: int = k) -> None:
            progress((k + 0.5 + 0.5 * share) / len(arms))
        bounds.append(slip_bound(plan, times, own, carrying, bound_share))
    if not bounds:
        bounds.append(slip_bound(plan, times, np.full(times.shape, np.nan), np.full(times.shape, '', dtype=object)))
    def join(field: str) -> Array:
        return np.concatenate([getattr(b, field) for b in bounds])
    return ratio, SlipBound(join('start'), join('end'), join('move').astype(np.int64), join('bound'), join('floor'),
                            join('time'), join('ratio'), all(b.closed for b in bounds))


def _slip_times(plan: ProgramPlan) -> Array:
    """The instants of the slip check: :data:`SLIP_RATE` within the moves (a hold stands as at its ends: a dwell of
    1e6 s was 2e8 instants and gigabytes), at most :data:`~gpr_kinematics.robot.timing.MAX_SAMPLES` of them
    (:func:`move_counts`: a slow move is sampled more sparsely, the others keep the rate), the waypoints' and the
    S-curves' corners (where a move's acceleration peaks: without them the example cell program's peak read 0.7512
    for the 0.7529 that 100 kHz sampling about it finds), and :data:`CORNER_SIDE` before and after each corner (a
    trapezoid's acceleration jumps at its corners: the corner alone read the cell program's move into steps[14]
    0.8126 for 0.8176 on the example robot without jerk limits)."""
    t = plan.timing
    corners = t.corners()
    sides = np.clip(corner_sides(corners), 0.0, t.total)
    starts, ends = np.concatenate([[0.0], t.depart]), np.concatenate([t.arrive, [t.total]])   # and the last hold
    durations = ends - starts
    counts = move_counts(durations, SLIP_RATE, MAX_SAMPLES)
    fast = counts >= SLIP_RATE * durations          # at the full rate: one grid, np.arange's instants
    grids = [grid_within(starts[fast], ends[fast], t.total, SLIP_RATE)]
    grids += [grid_within(starts[k:k + 1], ends[k:k + 1], t.total, counts[k] / durations[k])
              for k in np.flatnonzero(~fast)]
    return np.unique(np.concatenate(grids + [t.arrive, t.depart, corners, sides, [t.total]]))


def corner_sides(corners: Array) -> Array:
    """The instants :data:`CORNER_SIDE` before and after each corner [s], or 4 spacings of the doubles there where
    they are wider (a corner at 2.1e7 s, after 21 dwells of 1e6 s, is 3.7e-9 s from the next double: corner +- 1 ns
    was the corner, which took one side of a trapezoid's jump, and a 1 um move of 1.2 ms between 200 Hz instants
    read 0.898 for its ratio of 1.084 on the other side). The corner is off by at most half a spacing, so each side
    lies beyond it."""
    side = np.maximum(CORNER_SIDE, 4.0 * np.spacing(np.abs(corners)))
    return np.asarray(np.concatenate([corners - side, corners + side]), dtype=np.float64)


def _waypoint_at(plan: ProgramPlan, t: float) -> int:
    """The waypoint held at ``t`` or moved to."""
    return min(int(np.searchsorted(plan.timing.depart, t - 1e-12)), len(plan.timing.arrive) - 1)


def label_at(plan: ProgramPlan, t: float) -> str:
    return plan.labels[_waypoint_at(plan, t)]


def _collision(plan: ProgramPlan, p: PairClearance) -> Collision:
    """The pair ``p`` below the margin, at its first instant measured below it, else (by its bounds only: a row of
    "first below" the instant of its smallest distance had read as a collision found there) at that instant."""
    found = bool(np.isfinite(p.first_below))
    t = p.first_below if found else p.time
    w = _waypoint_at(plan, t)
    step = int(plan.waypoints.step[w])
    return Collision(p.bodies, t, p.distance, step, str(plan.program.steps[step].station), plan.labels[w], found,
                     p.measured)


def _moves(plan: ProgramPlan, times: Array, ratio: Array, bound: SlipBound) -> tuple[MoveSafety, ...]:
    """Per waypoint the largest of the ratios at the instants (exact on straight entries and holds) and of the
    bounds between them on joint-space moves."""
    t = plan.timing
    out = []
    for w in range(len(t.arrive)):
        start = float(t.depart[w - 1]) if w else 0.0
        sel = (times >= start) & (times <= t.depart[w])
        within = (bound.start >= start) & (bound.end <= t.depart[w])
        out.append(MoveSafety(w, plan.labels[w], start, float(t.depart[w]),
                              max(float(np.max(ratio[sel], initial=0.0)), float(np.max(bound.bound[within],
                                                                                         initial=0.0)))))
    return tuple(out)

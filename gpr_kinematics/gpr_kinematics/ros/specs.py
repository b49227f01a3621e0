"""The ROS parameters of every node, as plain data (no ROS import): one table per node, one source of truth.

A :class:`ParamSpec` names a parameter's type, default, description, range or allowed strings, any further
constraint (as text) and whether it is read-only. :func:`gpr_kinematics.nodes.params.declare_parameters` turns
the specs into declared parameters with descriptors (``floating_point_range``/``integer_range``,
``additional_constraints`` with the constraint text, ``read_only``); the shipped parameters file
``config/gpr_params.yaml``, the launch files' tests and ``docs/ros.md`` derive from the same tables
(:func:`params_file_text` writes the file, a test checks that the committed one equals it).

Units are SI (metres, radians, seconds, hertz), as in the core (REP 103).
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from ..core import sweep as _sweep
from ..core.config import FLOAT_RANGES as _F
from ..core.config import ITERATIONS, LEAST_LENGTH, MODELS, ROD_GAP, WEIGHTINGS, GprConfig, allowed_values, load_config
from ..core.messages import FRAME_PREFIX_WORDS, Topic, frame_prefix_refusal, is_frame_name
from ..core.sweep import DEFAULT_AZIMUTH_STEP, DEFAULT_HEIGHT, DEFAULT_MAX_TILT, DEFAULT_TILT_STEP, LEAST_STEPS
from ..errors import ConfigError, brief
from ..robot.grid import RATES
from ..robot.markers import MARKERS_EVERY
from ..robot.platform_program import MOVE_TIMES
from ..safety.margin import MARGIN, MARGIN_RANGE

#: Parameter kinds and the Python type of their values (``int`` is accepted where a double is declared).
KINDS: dict[str, tuple[type, ...]] = {'double': (float, int), 'integer': (int,), 'string': (str,), 'bool': (bool,),
                                      'double_array': (list, tuple), 'string_array': (list, tuple)}


@dataclass(frozen=True)
class ParamSpec:
    """One ROS parameter: name, kind (a key of :data:`KINDS`), default, description [with unit], inclusive
    range ``limits`` (double/integer), allowed strings ``choices``, a further ``constraint`` in words, and
    ``read_only`` (fixed once the node runs)."""

    name: str
    kind: str
    default: Any
    description: str
    limits: tuple[float, float] | None = None
    choices: tuple[str, ...] | None = None
    constraint: str = ''
    read_only: bool = False

    def constraint_text(self) -> str:
        """The ``additional_constraints`` text: range or choices, then the further constraint."""
        parts = []
        if self.limits is not None:
            lo, hi = self.limits
            parts.append(f'{_num(lo)} <= {self.name} <= {_num(hi)}')
        if self.choices is not None:
            parts.append('one of: ' + ', '.join(c or "''" for c in self.choices))
        if self.constraint:
            parts.append(self.constraint)
        return '; '.join(parts)

    def check(self, value: Any, where: str = 'parameter') -> None:
        """Raise :class:`ConfigError` naming the parameter, the value and what is allowed when ``value`` is not
        of the kind, outside the range or not one of the choices."""
        allowed = self.constraint_text() or f'a {self.kind.replace("_", " ")}'
        types = KINDS[self.kind]
        bad = isinstance(value, bool) != (self.kind == 'bool') or not isinstance(value, types)
        if not bad and self.kind in ('double', 'integer'):
            bad = not math.isfinite(value) or (self.limits is not None
                                               and not self.limits[0] <= value <= self.limits[1])
        if not bad and self.kind == 'string' and self.choices is not None:
            bad = value not in self.choices
        if not bad and self.kind.endswith('_array'):
            item = (float, int) if self.kind == 'double_array' else (str,)
            bad = any(isinstance(v, bool) or not isinstance(v, item) for v in value)
        if bad:
            raise ConfigError(f'{where} {self.name} = {brief(value)} is invalid; allowed: {allowed}')


def _num(x: float) -> str:
    """A number as YAML 1.1 and the ``ros2`` CLI read it back as a float (``1.0e-14``, never ``1e-14``)."""
    if isinstance(x, (bool, int)):
        return str(x)
    text = repr(float(x))
    mantissa, e, exponent = text.partition('e')
    if e and '.' not in mantissa:
        mantissa += '.0'
    if e and exponent[0] not in '+-':
        exponent = '+' + exponent
    return mantissa + (('e' + exponent) if e else '')


# ---- the GPR geometry and model (GprConfig): every node that computes kinematics declares these -----------------

_D, _I, _S, _B, _DA, _SA = 'double', 'integer', 'string', 'bool', 'double_array', 'string_array'

#: ``GprConfig`` keys with their parameter kind, description, range and constraint; the geometry is read-only.
#: Defaults come from the geometry configuration (the package's ``config/gpr.yaml`` or ``config_file``).
_CONFIG_TABLE: tuple[tuple[str, str, str, tuple[float, float] | None, tuple[str, ...] | None, str, bool], ...] = (
    ('radius', _D, 'radius R of the circle of rod axes [m]', _F['radius'][:2], None, '', True),
    ('rod_azimuths', _DA, 'azimuths of rods 1, 2, 3 in gpr_base [rad]', None, None,
     f'3 angles in [-2 pi, 2 pi] rad, pairwise at least {math.degrees(ROD_GAP):g} deg ({ROD_GAP:.4g} rad) apart', True),
    ('stroke_min', _D, 'lowest rod length q [m]', _F['stroke_min'][:2], None, 'stroke_min < stroke_max', True),
    ('stroke_max', _D, 'highest rod length q [m]', _F['stroke_max'][:2], None, 'stroke_min < stroke_max', True),
    ('tilt_limit', _D, 'largest platform tilt [rad]', _F['tilt_limit'][:2], None, '', False),
    ('imperfection_budget', _D, 'largest virtual-joint displacement of a joint centre [m]',
     _F['imperfection_budget'][:2], None, '', False),
    ('model', _S, 'default virtual-joint model', None, (*MODELS, ''), "'' means the geometry's model", False),
    ('characteristic_length', _D, 'weight of angular virtual joints in the Newton step [m]',
     (0.0, _F['characteristic_length'][1]), None, f'0 means the radius, else at least {LEAST_LENGTH:g}', False),
    ('weighting', _S, 'Newton step norm', None, WEIGHTINGS, '', False),
    ('max_iterations', _I, 'bound of Newton iterations per solve', ITERATIONS, None, '', False),
    ('tolerance', _D, 'closure tolerance on the side lengths [m]', _F['tolerance'][:2], None, '', False),
)

CONFIG_FILE = ParamSpec('config_file', _S, '', 'geometry YAML (GprConfig keys over the package\'s config/gpr.yaml), '
                        'replacing the robot description\'s gpr section; empty: that section', constraint='a readable '
                        'geometry YAML file or empty', read_only=True)

#: The robot description (docs/robot.md) of the nodes that know the whole robot; its ``gpr`` section is their
#: geometry unless ``config_file`` is given (as ``gpr robot --robot FILE --config FILE`` on the command line).
ROBOT_FILE = ParamSpec('robot_file', _S, '', 'robot description YAML: the GPR, its base in the world, the arms, '
                       'blades and wafers; empty: the shipped example config/robots/example_robot.yaml (for '
                       'trajectory_node: the start-up robot program\'s robot, if it names one)',
                       constraint='a readable robot description file or empty', read_only=True)


def config_values(cfg: GprConfig) -> dict[str, Any]:
    """The parameter values of a configuration: ``GprConfig.to_dict()`` with ``characteristic_length`` 0 when
    it follows the radius (a parameter cannot be null)."""
    values = cfg.to_dict()
    if cfg.characteristic_length == cfg.radius:
        values['characteristic_length'] = 0.0
    return values


def config_mapping(values: Mapping[str, Any]) -> dict[str, Any]:
    """Parameter values back to ``GprConfig`` keys: a characteristic length of 0 is null (the radius), an empty
    model is left out (the configuration file's model stays)."""
    out = dict(values)
    if 'rod_azimuths' in out:
        out['rod_azimuths'] = list(out['rod_azimuths'])
    if out.get('characteristic_length') == 0.0:
        out['characteristic_length'] = None
    if out.get('model') == '':
        del out['model']
    return out


def _inferred_kind(value: Any) -> str | None:
    """Parameter kind of a configuration value that has no row in the table (a key added to ``GprConfig``
    later); None when ROS parameters cannot hold it (it is then set through ``config_file`` only)."""
    if isinstance(value, bool):
        return _B
    if isinstance(value, int):
        return _I
    if isinstance(value, float):
        return _D
    if isinstance(value, str):
        return _S
    if isinstance(value, (list, tuple)) and value and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return _DA
    return None


def config_specs(cfg: GprConfig | None = None, read_only: bool = False) -> tuple[ParamSpec, ...]:
    """The ``GprConfig`` parameters with the values of ``cfg`` (default: the package configuration) as defaults.

    Every key of ``cfg.to_dict()`` gets a parameter: the keys of the table with their range and constraint,
    any other key that a ROS parameter can hold as a read-only parameter of the value's kind. ``read_only``
    makes them all read-only (a node that precomputes with the configuration)."""
    cfg = cfg if cfg is not None else load_config()
    values = config_values(cfg)
    out = []
    known = {row[0] for row in _CONFIG_TABLE}
    for name, kind, text, limits, choices, constraint, ro in _CONFIG_TABLE:
        if name in values:
            default = [float(v) for v in values[name]] if kind == _DA else values[name]
            out.append(ParamSpec(name, kind, default, text, limits, choices, constraint, ro or read_only))
    for name, value in values.items():
        inferred = _inferred_kind(value)
        if name not in known and inferred is not None:
            default = [float(v) for v in value] if inferred == _DA else value
            out.append(ParamSpec(name, inferred, default, f'geometry configuration key {name} (see config/gpr.yaml)',
                                 constraint=allowed_values(name), read_only=True))
    return tuple(out)


# ---- node tables ------------------------------------------------------------------------------------------------

#: The prefix of every tf frame a node publishes, as ``robot_state_publisher``'s ``frame_prefix``: two robots with
#: ``r1/`` and ``r2/`` publish ``r1/gpr_base`` and ``r2/gpr_base`` on one ``/tf``.
FRAME_PREFIX = ParamSpec('frame_prefix', 'string', '', 'prefix of every tf frame the node publishes or names (as '
                         "robot_state_publisher's frame_prefix), e.g. r1/", constraint=FRAME_PREFIX_WORDS,
                         read_only=True)
JOINT_STATES_RELIABILITY = ParamSpec('joint_states_reliability', 'string', 'reliable', 'QoS reliability of the '
                                     'joint_states subscription: reliable (every sample) or best_effort (hears a '
                                     'best-effort publisher too, as robot_state_publisher\'s SensorDataQoS)',
                                     choices=('reliable', 'best_effort'), read_only=True)


def check_frame_names(p: dict[str, Any], names: tuple[str, ...]) -> None:
    """:class:`ConfigError` naming the first parameter of ``names`` in ``p`` that is not a tf frame name, or the
    second of two that name one frame (``base_frame:=/gpr_base`` started and published a frame tf2 refuses)."""
    seen: dict[str, str] = {}
    for name in names:
        value = p[name]
        if not is_frame_name(value):
            raise ConfigError(f'parameter {name} = {value!r} is invalid; allowed: a tf frame name (letters, digits, '
                              '_ - . and single / between parts, not at the start or the end; at most 100 characters)')
        if value in seen:
            raise ConfigError(f'parameter {name} = {value!r} names the frame of {seen[value]}; allowed: a frame of '
                              'its own')
        seen[value] = name


def check_frame_prefix(prefix: str, frames: Iterable[str] | None = None) -> str:
    """``prefix`` when each of ``frames`` (the node's frame names; by default the suite's) prefixed is a tf frame name
    (:func:`~..core.messages.frame_prefix_refusal`), else :class:`ConfigError` naming it and what is allowed."""
    allowed = frame_prefix_refusal(prefix, None if frames is None else tuple(frames))
    if allowed is not None:
        raise ConfigError(f'parameter frame_prefix = {brief(prefix)} is invalid; allowed: {allowed}')
    return prefix


#: Modes of trajectory_node: ``sweep`` and ``program`` stream at start (and exit when done unless ``loop``);
#: ``idle`` streams nothing at start and serves programs through the ``gpr/run_program`` action.
TRAJECTORY_MODES = ('sweep', 'program', 'idle')

TRAJECTORY: tuple[ParamSpec, ...] = (
    ParamSpec('mode', _S, 'sweep', 'sweep (the paper grid), program (an offline program file) or idle (no stream '
              'at start: programs come through the gpr/run_program action)', choices=TRAJECTORY_MODES,
              read_only=True),
    ParamSpec('rate', _D, 100.0, 'publishing rate [Hz]', RATES, read_only=True),
    ParamSpec('height', _D, DEFAULT_HEIGHT, 'sweep: height of the platform centre [m]', _F['stroke_min'][:2],
              constraint='within the stroke', read_only=True),
    ParamSpec('max_tilt', _D, DEFAULT_MAX_TILT, 'sweep: largest |alpha| [rad]', _F['tilt_limit'][:2],
              constraint='max_tilt <= tilt_limit', read_only=True),
    ParamSpec('tilt_step', _D, DEFAULT_TILT_STEP, 'sweep: step of alpha [rad]',
              (LEAST_STEPS['tilt_step'], _F['tilt_limit'][1]), read_only=True),
    ParamSpec('azimuth_step', _D, DEFAULT_AZIMUTH_STEP, 'sweep: step of the azimuth gamma [rad]',
              (LEAST_STEPS['azimuth_step'], 2 * math.pi), read_only=True),
    ParamSpec('passes', _I, 1, 'sweep: number of passes over the grid', (1, _sweep.MAX_PASSES), read_only=True),
    ParamSpec('program_file', _S, '', 'program: path of the offline program YAML', constraint='required in mode '
              'program', read_only=True),
    ParamSpec('program_folders', _SA, [''], 'folders, besides the package\'s config, whose files a '
              'gpr/run_program goal may read (its program_file and the files it names: robot, geometry, stations); '
              'any other path is refused', constraint='existing folders, or [\'\'] for none', read_only=True),
    ParamSpec('move_time', _D, 2.0, 'program: default duration of a move between stations [s]', MOVE_TIMES,
              read_only=True),
    ParamSpec('loop', _B, False, 'start over after the last sample instead of exiting', read_only=True),
    ParamSpec('base_frame', _S, 'gpr_base', 'frame of the base (header.frame_id)', constraint='a tf frame name',
              read_only=True),
    FRAME_PREFIX,
    ParamSpec('markers_every', _I, 1, 'publish gpr/markers every n-th sample', MARKERS_EVERY, read_only=True),
    ParamSpec('wait_for_subscribers', _I, 0, 'before the first sample, wait until this many nodes (e.g. recorders) '
              'subscribe to the stream', (0, 1000), read_only=True),
    ParamSpec('wait_all_topics', _B, True, 'wait_for_subscribers counts nodes subscribed to every stream topic '
              '(true) or to gpr/platform_state (false)', read_only=True),
    ParamSpec('wait_timeout', _D, 10.0, 'longest wait for subscribers [s]; then start anyway', (0.0, 3600.0),
              read_only=True),
    ParamSpec('queue_depth', _I, 1000, 'publisher history depth (reliable, keep last)', (1, 100000), read_only=True),
)


KINEMATICS: tuple[ParamSpec, ...] = (
    ParamSpec('max_queue_time', _D, 5.0, 'a request that waited longer than this [s] in the node\'s queue is answered '
              'at once with success: false, "saturated" (not computed; the queues keep every request)',
              (0.001, 3600.0), read_only=True),
    FRAME_PREFIX,  # the robot services' world_frame: r1/world beside a state publisher with r1/
)

#: Topics of trajectory_node besides the bag library's default list (typestore.GPR_TOPICS), with their types.
STREAM_EXTRA_TOPICS: dict[str, str] = {'/' + Topic.VIRTUAL_JOINTS: 'sensor_msgs/msg/JointState',
                                       '/' + Topic.GEOMETRY: 'std_msgs/msg/String'}


def recorded_topics() -> dict[str, str]:
    """The recorder's default topics and their types: every topic trajectory_node publishes."""
    from ..bags.typestore import GPR_TOPICS

    return {**GPR_TOPICS, **{t: ty for t, ty in STREAM_EXTRA_TOPICS.items() if t not in GPR_TOPICS}}


def _recorder_table() -> tuple[ParamSpec, ...]:
    from ..bags.writer import COMPRESSIONS, STORAGES

    topics = [f'{t.lstrip("/")}:{ty}' for t, ty in recorded_topics().items()]
    return (
        ParamSpec('output', _S, '', 'bag folder to create (default bags/gpr_<date>-<time>)',
                  constraint='a path that does not exist yet, in a writable folder', read_only=True),
        ParamSpec('storage', _S, 'mcap', 'storage format', choices=tuple(STORAGES), read_only=True),
        ParamSpec('topics', _SA, topics, 'topics to record: name or name:pkg/msg/Type',
                  constraint='at least one valid topic name; a type is needed for a topic not yet published',
                  read_only=True),
        ParamSpec('flush_interval', _D, 1.0, 'longest time [s] a received message stays outside a closed segment '
                  '(0 = off)', (0.0, 3600.0), read_only=True),
        ParamSpec('max_bag_size', _I, 0, 'split when a segment holds this many bytes (0 = off)', (0, 2 ** 62),
                  read_only=True),
        ParamSpec('max_bag_duration', _D, 0.0, 'split when a segment spans this many seconds (0 = off)', (0.0, 1e9),
                  read_only=True),
        ParamSpec('compression', _S, 'none', 'MCAP chunk compression', choices=COMPRESSIONS, read_only=True),
        ParamSpec('fsync', _B, True, 'fsync every closed segment and the bag folder', read_only=True),
        ParamSpec('queue_depth', _I, 10000, 'subscription history depth (reliable, keep last)', (1, 10_000_000),
                  read_only=True),
        ParamSpec('discovery_timeout', _D, 5.0, 'wait this long [s] for the type of a topic given without one',
                  (0.0, 3600.0), read_only=True),
        ParamSpec('drain_timeout', _D, 5.0, 'at a stop, write what DDS delivered for at most this long [s] (less once '
                  'three spins in a row take no message; 0 = none)', (0.0, 3600.0), read_only=True),
    )


REPLAY: tuple[ParamSpec, ...] = (
    ParamSpec('bag', _S, '', 'bag folder or .mcap/.db3 file to replay', constraint='required; a readable bag',
              read_only=True),
    ParamSpec('rate', _D, 1.0, 'replay speed factor', (1e-3, 1e6), read_only=True),
    ParamSpec('loop', _B, False, 'start over after the last message', read_only=True),
    ParamSpec('clock_rate', _D, 0.0, "publish /clock at this rate [Hz] while replaying, the bag's time (as ros2 bag "
              'play --clock; for nodes with use_sim_time); 0 = none', (0.0, 1000.0), read_only=True),
    ParamSpec('topics', _SA, [''], 'topics to replay (empty or [\'\']: all)',
              constraint='topic names present in the bag', read_only=True),
    ParamSpec('wait_for_subscribers', _I, 0, 'wait for this many subscriptions on every topic first', (0, 1000),
              read_only=True),
    ParamSpec('wait_topic', _S, '', "the one topic (as published) whose subscriptions wait_for_subscribers counts; '': "
              'every topic', constraint='a topic the replay publishes', read_only=True),
    ParamSpec('wait_timeout', _D, 10.0, 'longest wait for subscribers [s]', (0.0, 3600.0), read_only=True),
    ParamSpec('queue_depth', _I, 10000, 'publisher history depth (reliable, keep last)', (1, 10_000_000),
              read_only=True),
)

STATE_PUBLISHER: tuple[ParamSpec, ...] = (
    ParamSpec('base_frame', _S, 'gpr_base', 'tf frame of the base (root of the robot model)',
              constraint='a tf frame name', read_only=True),
    ParamSpec('platform_frame', _S, 'gpr_platform', 'tf frame of the platform (exact pose, virtual-joint model)',
              constraint='a tf frame name', read_only=True),
    ParamSpec('nominal_frame', _S, 'gpr_platform_nominal', 'tf frame of the platform under the naive model',
              constraint='a tf frame name', read_only=True),
    FRAME_PREFIX,
    ParamSpec('idle_rate', _D, 10.0, 'rate of /tf [Hz] while no joint_states arrive: the last state held, so tf is '
              'always there', (0.1, 1000.0), read_only=True),
    ParamSpec('queue_depth', _I, 1000, 'joint_states subscription and /tf publisher depth',
              (1, 100000), read_only=True),
    JOINT_STATES_RELIABILITY,
    ParamSpec('cell_file', _S, '', 'process cell YAML (format gpr_cell): its obstacles published latched on gpr/cell '
              '(visualization_msgs/MarkerArray); empty: none', constraint='a readable cell file or empty',
              read_only=True),
)

#: The robot simulator: a FollowJointTrajectory server on the robot's joints (docs/ros.md).
SIMULATOR: tuple[ParamSpec, ...] = (
    ParamSpec('rate', _D, 100.0, 'sample rate of a motion and of joint_states while a goal runs [Hz]', (1.0, 1000.0),
              read_only=True),
    ParamSpec('idle_rate', _D, 10.0, 'rate of joint_states while no goal runs and nobody else publishes them [Hz]: '
              'the state held', (0.1, 1000.0), read_only=True),
    ParamSpec('start_tolerance', _D, 1e-3, 'largest distance [m or rad] of a first point at time_from_start 0 from '
              'where the joint is', (0.0, 1.0), read_only=True),
    ParamSpec('path_tolerance', _D, 0.0, 'default path position tolerance [m or rad] of every joint; 0: not checked',
              (0.0, 10.0), read_only=True),
    ParamSpec('goal_tolerance', _D, 1e-3, 'default goal position tolerance [m or rad] of every joint; 0: not '
              'checked', (0.0, 10.0), read_only=True),
    ParamSpec('goal_time', _D, 0.5, 'default goal_time_tolerance [s]: how long after the last point the goal '
              'tolerance may still be reached', (1e-3, 3600.0), read_only=True),
    ParamSpec('servo_time_constant', _D, 0.0, 'time constant [s] of the joints\' first-order response to the '
              'trajectory; 0: they follow it exactly', (0.0, 10.0), read_only=True),
    ParamSpec('queue_depth', _I, 1000, 'joint_states publisher and subscription depth', (1, 100000),
              read_only=True),
    ParamSpec('allow_nonzero_velocity_at_trajectory_end', _B, False, "accept a goal whose last point moves a joint "
              "(joint_trajectory_controller's parameter; false, its default since Jazzy: refused)", read_only=True),
    JOINT_STATES_RELIABILITY,
    ParamSpec('cell_file', _S, '', 'process cell YAML (format gpr_cell): every goal\'s motion is checked against it '
              'before anything moves (certified clearance between samples; python-fcl); empty: no clearance check',
              constraint='a readable cell file or empty', read_only=True),
    ParamSpec('clearance_margin', _D, MARGIN, 'smallest distance [m] every pair of bodies must keep over a goal\'s '
              'motion when cell_file is given', MARGIN_RANGE, read_only=True),
    ParamSpec('wafer_arms', _SA, [''], 'arms that carry a wafer during every goal (their wafer discs are checked '
              'against the cell); [\'\']: none', constraint='names of the robot\'s arms', read_only=True),
)

#: Executables and the parameters they declare, besides ``robot_file``, ``config_file`` and the ``GprConfig`` keys
#: for those marked True (these are read-only in every node but ``kinematics_node``).
NODES: dict[str, tuple[bool, str]] = {
    'kinematics_node': (True, 'kinematics'),
    'trajectory_node': (True, 'trajectory'),
    'state_publisher_node': (True, 'state'),
    'robot_simulator_node': (True, 'simulator'),
    'recorder_node': (False, 'recorder'),
    'replay_node': (False, 'replay'),
}


def node_specs(node: str, cfg: GprConfig | None = None) -> tuple[ParamSpec, ...]:
    """Every parameter ``node`` declares (``robot_file``, ``config_file`` and the ``GprConfig`` keys where it computes
    kinematics, then its own), with the defaults of ``cfg`` (default: the package configuration)."""
    if node not in NODES:
        raise ConfigError(f'unknown node {node!r}; allowed: ' + ', '.join(NODES))
    with_config, table = NODES[node]
    own = _recorder_table() if table == 'recorder' else \
        {'kinematics': KINEMATICS, 'trajectory': TRAJECTORY, 'state': STATE_PUBLISHER, 'simulator': SIMULATOR,
         'replay': REPLAY}[table]
    if not with_config:
        return tuple(own)
    return (ROBOT_FILE, CONFIG_FILE, *config_specs(cfg, read_only=node != 'kinematics_node'), *own)


def _yaml_value(spec: ParamSpec, value: Any) -> str:
    if spec.kind == 'double':
        return _num(float(value))
    if spec.kind == 'bool':
        return 'true' if value else 'false'
    if spec.kind == 'integer':
        return str(int(value))
    if spec.kind == 'double_array':
        return '[' + ', '.join(_num(float(v)) for v in value) + ']'
    if spec.kind == 'string_array':
        return '[' + ', '.join(_quote(str(v)) for v in value) + ']'
    return _quote(str(value))


def _quote(text: str) -> str:
    return "'" + text.replace("'", "''") + "'"


def params_file_text(nodes: Iterable[str] | None = None, cfg: GprConfig | None = None) -> str:
    """A ROS 2 parameters file (``ros__parameters`` form) with the parameters of ``nodes`` (default: all) at their
    defaults, a comment line per parameter (description, constraint). Keys are ``/**/<node>``, so it applies in
    any namespace. The geometry and model (the ``GprConfig`` keys) are commented out: they come from
    ``config_file`` (empty: the ``gpr`` section of the node's ``robot_file``, else the package's
    ``config/gpr.yaml``), and a key uncommented here overrides that file.
    Doubles are written with a decimal point and a signed exponent (``1.0e-14``), the form YAML 1.1 readers
    (PyYAML: ``ros2 param load``, launch) read back as floats."""
    lines = ['# ROS 2 parameters of the gpr_kinematics nodes at their defaults (SI units: m, rad, s, Hz).',
             '# Use: ros2 run gpr_kinematics <node> --ros-args --params-file gpr_params.yaml, or parameters=[file]',
             '# in a launch file. The geometry and model come from config_file (empty: the gpr section of the',
             '# node\'s robot_file, else the package\'s config/gpr.yaml); a commented geometry key, uncommented,',
             '# overrides that file. Edit a copy.',
             '# Generated by: python -m gpr_kinematics.ros.specs > config/gpr_params.yaml']
    geometry = {s.name for s in config_specs(cfg)}
    for node in nodes or NODES:
        lines += ['', f'/**/{node}:', '  ros__parameters:']
        for spec in node_specs(node, cfg):
            note = spec.description + (f' ({spec.constraint_text()})' if spec.constraint_text() else '')
            note += '; read-only' if spec.read_only else ''
            lines.append(f'    # {note}')
            lines.append(f'    {"# " if spec.name in geometry else ""}{spec.name}: {_yaml_value(spec, spec.default)}')
    return '\n'.join(lines) + '\n'


if __name__ == '__main__':
    print(params_file_text(), end='')

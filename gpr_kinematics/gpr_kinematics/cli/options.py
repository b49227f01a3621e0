"""Options shared by the ``gpr`` subcommands: finite numbers, the robot and its model, input units."""
from __future__ import annotations

import argparse
import errno
import math
import os
import re
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..core.config import MODELS, GprConfig
from ..errors import FileError, InputError, LimitError, apart, brief
from ..inputs.resources import CELLS, ROBOTS, Packaged, packaged_file
from ..inputs.units import as_typed, metres
from ..inputs.validation import TURN, beyond_turn, decimal, finite_number, number_hint
from ..mechanisms.base import Mechanism, as_poses

if TYPE_CHECKING:
    from ..robot.description import RobotDescription
    from ..robot.plan import ProgramPlan
    from ..robot.program import RobotProgram

#: The pose convention of ``gpr mechanism``, ``accuracy`` and ``dexterity`` (their help epilog).
CONVENTIONS = """pose convention (X Y Z A B C, m and rad unless --mm/--deg):
  gsp           R = Rz(C) Ry(B) Rx(A) = scipy from_euler('xyz', [A, B, C]) (or the file's 'euler')
  stewart_6sps  Z-X-Z intrinsic Euler angles (psi, theta, phi) = scipy from_euler('ZXZ', [A, B, C])
  upu3          translation only: A B C must be 0
  tripod_3rps   A = theta (about y), B = psi (about x); R = Ry(theta) Rx(psi) Rz(phi); X, Y, C = phi are
                parasitic motions computed by the mechanism (give 0 or their values)
  gpr           A, B = tilt rotation vector (tilt_x, tilt_y) = tilt (cos azimuth, sin azimuth); X, Y and
                C = twist are outcomes of the virtual-joint model (give 0 or their values)
angular velocities and inverse-Jacobian columns: v_x v_y v_z w_x w_y w_z, w in the base frame"""


class NumberTextError(argparse.ArgumentTypeError, ValueError):
    """A text :func:`number` or :func:`whole` does not read: argparse prints it as the option's error; a caller
    that converts values itself (``--vary``, ``--tolerance``, ``--parameter-error``) catches it as a ValueError."""


#: What :func:`number` reads, said where it refuses a text without a more particular hint.
NUMBER_ALLOWED = '; allowed: a decimal number of ASCII digits (e.g. 0.5, -2, 1e-3)'


def number(text: str) -> float:
    """An argparse type: a number as the files write it (:func:`~gpr_kinematics.inputs.validation.decimal`: ASCII
    digits with a sign, point and exponent, or inf and nan; Python's float also read ``1_0`` as 10 and the digits of
    other scripts). Named ``float`` for argparse's message (``invalid float value: '1_0'``), with a hint for a
    decimal comma."""
    try:
        value = decimal(text)
    except ValueError:
        hint = number_hint(text) or NUMBER_ALLOWED
        raise NumberTextError(f'invalid float value: {brief(text)}{hint}') from None
    if math.isinf(value) and 'inf' not in text.lower():   # digits beyond a float: named as typed, not as 'inf'
        raise NumberTextError(f'invalid float value: {brief(text)} (beyond the largest float, 1.8e308)')
    if value == 0.0 and any(c in '123456789' for c in text.lower().split('e')[0]):   # 1e-400 read as 0 (or -0)
        raise NumberTextError(f'invalid float value: {brief(text)} (below the smallest float, 4.9e-324: it reads as 0)')
    return value


class Whole(int):
    """An integer as :func:`whole` read it, its ``repr`` the text as typed: :func:`~..errors.brief` and every refusal
    that quotes it name ``--passes = 00``, not the 0 it became; ``str``, formats and arithmetic are the int's."""

    typed: str

    def __new__(cls, text: str) -> Whole:
        """The integer of ``text`` (checked by :func:`whole`), remembering it."""
        obj = super().__new__(cls, text)
        obj.typed = text.strip(' \t')
        return obj

    def __repr__(self) -> str:
        return self.typed

    def __str__(self) -> str:
        return int.__repr__(self)

    def __reduce__(self) -> tuple[type[Whole], tuple[str]]:
        """Pickled (a Dask worker's copy) and copied as its text: int's own reduction gave ``__new__`` the int."""
        return Whole, (self.typed,)


def whole(text: str) -> int:
    """An argparse type: an integer of ASCII digits with an optional sign (Python's int also read ``1_000`` and the
    digits of other scripts), a :class:`Whole` (refusals quote it as typed). Named ``int`` for argparse's message
    (``invalid int value: '1_0'``)."""
    if not _WHOLE.fullmatch(text.strip(' \t')):
        raise NumberTextError(f'invalid int value: {brief(text)}; allowed: a whole number of ASCII digits (e.g. 10)')
    return Whole(text)


number.__name__ = 'float'
whole.__name__ = 'int'
#: The integers :func:`whole` reads.
_WHOLE = re.compile(r'[-+]?[0-9]+')


def finite(text: str) -> float:
    """An argparse type: a finite number (:func:`number`; the option's error names the text otherwise)."""
    try:
        val = decimal(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'{brief(text)} is not a number{number_hint(text)}') from None
    if not np.isfinite(val):
        beyond = ' (beyond the largest float, 1.8e308)' if np.isinf(val) and 'inf' not in text.lower() else ''
        raise argparse.ArgumentTypeError(f'{brief(text)} is not a finite number{beyond}')
    return val


class ShippedName(str):
    """A file argument of a kind the package ships (:attr:`kind`), as typed; :func:`resolve_shipped` makes it the
    file to read before the command runs."""

    kind: Packaged

    def __new__(cls, text: str, kind: Packaged) -> ShippedName:
        """``text`` marked as a file of ``kind``."""
        obj = super().__new__(cls, text)
        obj.kind = kind
        return obj


def png_plot(path: str) -> None:
    """Refuse, before any work, a ``--plot`` not named ``.png`` or that cannot be written; without matplotlib, the
    one-line error of a missing optional package (:func:`~gpr_kinematics.cli.main.missing_dependency`) before the
    work rather than after it."""
    from ..inputs.files import check_output, check_suffix
    check_suffix(path, '--plot', ('.png',))
    check_output(path, 'plot')
    import matplotlib  # noqa: F401 - missing: main's one line


def shipped(kind: Packaged) -> Callable[[str], ShippedName]:
    """An argparse type: a file of ``kind``, or the bare name of one the package ships, looked up by
    :func:`resolve_shipped` (an error then is the command's one line, the whole path quoted, not argparse's with
    its quoted values cut)."""
    def path(text: str) -> ShippedName:
        return ShippedName(text, kind)

    path.__name__ = kind.kind
    return path


def resolve_shipped(args: argparse.Namespace, parser: argparse.ArgumentParser | None = None) -> None:
    """Replace every :class:`ShippedName` of ``args`` (alone or in a list) by the path to read
    (:func:`~gpr_kinematics.inputs.resources.packaged_file`: a local file, else a packaged one of its kind);
    :class:`FileError` for a name that is neither, named as the command's ``parser`` names it (``--cell: ...``)."""
    def resolved(value: object) -> object:
        return packaged_file(str(value), value.kind) if isinstance(value, ShippedName) else value

    for dest, value in vars(args).items():
        try:
            setattr(args, dest, [resolved(v) for v in value] if isinstance(value, list) else resolved(value))
        except FileError as exc:
            from .output import typed_name
            raise FileError(f'{typed_name(parser, dest)}: {exc}') from None


class RodLengths(argparse.Action):
    """The positional ``Q Q Q`` of ``gpr fk`` and ``gpr mobility`` (``nargs='*'``): three rod lengths, else one line
    saying so (with ``nargs=3`` two of them gave argparse's "the following arguments are required: Q")."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:
        got = list(values) if isinstance(values, list) else []
        if len(got) != 3:
            typed = f': {brief(" ".join(f"{v:g}" for v in got))}' if got else ''
            raise argparse.ArgumentError(None, f'three rod lengths q1 q2 q3 are needed [m, or mm with --mm]; got '
                                               f'{len(got)}{typed}')
        setattr(namespace, self.dest, got)


def rod_lengths(p: argparse.ArgumentParser) -> None:
    """The positional rod lengths ``Q Q Q`` (:class:`RodLengths`)."""
    p.add_argument('q', type=number, nargs='*', action=RodLengths, metavar='Q',
                   help='three rod lengths q1 q2 q3 [m, or mm with --mm]')


def mechanism_of(path: str) -> Mechanism:
    """The mechanism of a file, its ``workspace:`` section checked as ``gpr workspace`` checks it, whether the
    command uses it or not (``gpr dexterity`` took a box of ``"x"``; :func:`~..workspace.builders.check_section`)."""
    from ..mechanisms import mechanism_from_dict, read_mechanism_file
    from ..workspace.builders import BUILDERS, check_section
    data, p = read_mechanism_file(path)
    mech = mechanism_from_dict(data, str(p))
    if isinstance(data, dict) and data.get('workspace') is not None and data.get('type') in BUILDERS:
        check_section(data, str(p))
    return mech


def mechanism_pose(args: argparse.Namespace, mech: Mechanism) -> np.ndarray:
    """``--pose X Y Z A B C`` in SI units (``--mm``, ``--deg`` converted), checked for ``mech``."""
    pose = np.array(args.pose, dtype=float)
    if args.mm:
        pose[:3] = metres(pose[:3], True)
    if args.deg:
        pose[3:] = np.radians(pose[3:])
    as_poses(pose, '--pose')  # the position's bound, named as the option
    if mech.kind == 'upu3' and np.any(pose[3:] != 0):
        raise InputError(f'{mech.name} only translates: the angles A B C must be 0; got {pose[3:].tolist()}')
    from ..mechanisms.gpr import GprMechanism
    if isinstance(mech, GprMechanism):   # the tilt the core refuses, with the hint of degrees typed as radians
        pose_tilt(args, float(pose[3]), float(pose[4]), mech.config)
    elif mech.kind != 'upu3':
        _platform_tilt(args, mech, pose)
    _parasitic_given(args, mech, pose)
    return pose


#: A platform tilted this far [rad] from its base (45 deg) by angles typed as radians that read as degrees would tilt
#: it less: warned as degrees given as radians (Alwan's and Toz & Kucuk's poses are printed in degrees).
TILT_WARNED = math.pi / 4


def _platform_tilt(args: argparse.Namespace, mech: Mechanism, pose: np.ndarray) -> None:
    """Refuse a ``--pose`` whose angles turn the platform over (its normal 90 deg or more from the base's: no
    platform on legs gets there, and the joint values computed are meaningless), warn where they tilt it beyond
    :data:`TILT_WARNED` and would not read as degrees; each with :data:`DEGREES_HINT` where the angles read as degrees
    would tilt it less (``--pose 0.66 -0.35 1.8 -5 2 1.4``: Alwan's first pose in degrees, upside down in radians)."""
    def tilt(p: np.ndarray) -> float:
        full = mech.complete_pose(p) if not mech.undetermined(p[None])[0] else p
        return math.acos(min(1.0, max(-1.0, float(mech.rotation(full[None])[0, 2, 2]))))

    angle = tilt(pose)
    if angle <= TILT_WARNED:
        return
    degrees = pose.copy()
    degrees[3:] = np.radians(np.asarray(args.pose[3:], dtype=float))
    hint = DEGREES_HINT if not args.deg and tilt(degrees) < min(angle, TILT_WARNED) else ''
    typed = ' '.join(f'{v:g}' for v in args.pose[3:])
    unit = 'deg' if args.deg else 'rad'
    if angle >= math.pi / 2:
        raise InputError(f'{mech.name}: --pose A B C = {typed} {unit} turn the platform over (its normal '
                         f'{math.degrees(angle):.4g} deg from the base\'s z axis); allowed: a platform tilted less '
                         f'than 90 deg{hint}')
    if hint:
        import sys
        print(f'gpr {getattr(args, "command", "mechanism")}: warning: --pose A B C = {typed} rad tilt the platform '
              f'{math.degrees(angle):.4g} deg from its base{hint}', file=sys.stderr)


#: How far a typed parasitic pose value may be from the one the mechanism sets, relative (its nine digits as printed
#: and typed back, with room for six), before it is refused; and absolutely [m or rad].
PARASITIC_TOLERANCE = (1e-6, 1e-12)


def _parasitic_given(args: argparse.Namespace, mech: Mechanism, pose: np.ndarray) -> None:
    """Refuse a ``--pose`` whose values the mechanism sets itself (the tripod's X, Y, C, the GPR's outcomes of its
    virtual joints) given other than 0 (ignored) or the value it sets: ``--pose 5 5 0.1 0.2 0.3 1`` of the tripod was
    analysed at x = 0.00066 m without a word (the 3-UPU refuses its angles likewise)."""
    set_by = [i for i in range(6) if i not in set(int(k) for k in mech.variable_indices)]
    given = [i for i in set_by if pose[i] != 0.0]
    if not given or mech.kind == 'upu3' or mech.undetermined(pose[None])[0]:
        return
    full = mech.complete_pose(pose)
    rel, tol = PARASITIC_TOLERANCE
    wrong = [i for i in given if abs(pose[i] - full[i]) > rel * abs(full[i]) + tol]
    if not wrong:
        return
    names = ' '.join('XYZABC'[i] for i in wrong)
    typed = ', '.join(f'{args.pose[i]:g}' for i in wrong)
    sets = ', '.join(f'{"XYZABC"[i]} = {full[i]:.9g} {"m" if i < 3 else "rad"}' for i in wrong)
    free = ' '.join('XYZABC'[int(i)] for i in mech.variable_indices)
    raise InputError(f'{mech.name}: --pose {names} = {typed} are set by the mechanism from {free} ({sets} at this '
                     f'pose); allowed: 0 (ignored) or those values')


def pose_tilt(args: argparse.Namespace, a: float, b: float, config: GprConfig) -> None:
    """The GPR's ``--pose X Y Z A B C``'s tilt vector ``A B`` [rad] (``--deg`` converted): its norm refused beyond the
    tilt limit by :func:`typed_tilt`, named ``--pose tilt |(A, B)|``."""
    typed_a, typed_b = args.pose[3], args.pose[4]
    typed_tilt(args, '--pose tilt |(A, B)|', math.hypot(a, b), math.hypot(typed_a, typed_b), config, allowed='|(A, B)|')


def robot_of(args: argparse.Namespace, default: Path | None = None) -> RobotDescription:
    """The robot of ``--robot`` (else ``default``, else the shipped example) with ``--config`` and ``--model``."""
    from ..robot.description import load_robot
    path = default if args.robot is None else args.robot
    return load_robot(path, geometry=args.config, model=args.model)


def named_file(program: RobotProgram, key: str, given: Path | None) -> Path | None:
    """The file the program names as ``key`` (``robot``, ``cell``) unless the option ``given`` replaces it;
    :class:`FileError` naming the program when that file does not exist (a refusal that named the file alone left
    the reader to guess who named it and relative to what)."""
    path: Path | None = getattr(program, key)
    if given is not None or path is None:
        return given if given is not None else path
    try:
        os.stat(path)   # a dangling link does not exist either
        return path
    except OSError as exc:   # a symbolic link loop or a name too long was called missing
        why = 'does not exist' if exc.errno == errno.ENOENT else f'cannot be read ({os.strerror(exc.errno or 0)})'
    raise FileError(f'{program.source}: {key} file {str(path)!r} (named by the program, relative to its folder) '
                    f'{why}; allowed: an existing file, or --{key} FILE')


def program_plan(args: argparse.Namespace, rate: float | None = None
                 ) -> tuple[RobotProgram, ProgramPlan]:
    """The program of ``gpr program``'s PROGRAM (with ``--robot``, ``--config``, ``--model``) and its plan; with
    ``rate``, its samples at that rate bounded before it is planned and again, by its moves' least times, before its
    moves are timed (:func:`~gpr_kinematics.robot.plan.plan_program`). The cell the program names is an input too,
    read or not: no output may replace it."""
    from ..inputs.files import note_input
    from ..robot.plan import check_sample_count, plan_program
    from ..robot.program import GIVEN_ROBOT, load_program, program_robot
    program = load_program(args.program)
    robot = named_file(program, 'robot', args.robot)
    override = getattr(args, 'cell_override', None)   # export's and send's --cell (check's is args.cell)
    if override is not None:   # the cell a program was checked in with --cell: export used its own without a word
        import dataclasses
        program = dataclasses.replace(program, cell=Path(override))
    if program.cell is not None:
        note_input(program.cell)
        if not hasattr(args, 'cell') and not os.path.isfile(program.cell):   # unread (check reads it): not dangling
            what = 'is not a regular file' if os.path.exists(program.cell) else 'does not exist'
            whose = 'given as --cell' if override is not None else 'named by the program, relative to its folder'
            raise FileError(f'{program.source}: cell file {str(program.cell)!r} ({whose}) {what}; allowed: an '
                            'existing cell file' + ('' if override is not None else ', or no cell key'))
    if rate is not None:
        check_sample_count(program, rate)
    described = robot_of(args, robot)
    if args.robot is not None and program.robot is not None and os.path.isfile(program.robot):   # another robot:
        program_robot(program, described, GIVEN_ROBOT)   # named, not as its stations out of reach
    return program, plan_program(described, program, rate)


def lengths(args: argparse.Namespace, values: Iterable[float]) -> list[float]:
    """Input lengths in metres (``--mm`` converted)."""
    return [metres(v, args.mm) for v in values]


def typed_point(args: argparse.Namespace, typed: Sequence[float], si: Sequence[float]) -> str | None:
    """A point typed in millimetres (``--mm``) as typed, metres beside (:func:`~..inputs.units.as_typed`), for a
    refusal to name instead of the metres it became; None without ``--mm`` (the metres are as typed)."""
    return as_typed(list(typed), list(si), 'm', 'mm') if getattr(args, 'mm', False) else None


def tool_point(args: argparse.Namespace) -> list[float]:
    """``--tool X Y Z`` in metres (``--mm`` converted; the origin if not given), refused beyond a tool point's reach
    named as the option and as typed, with the hint of millimetres typed as metres where they would be within it."""
    from ..core.inverse import TOOL_REACH, check_tool_point
    if args.tool is None:
        return [0.0, 0.0, 0.0]
    tool = lengths(args, args.tool)
    try:
        check_tool_point(tool, '--tool', typed_point(args, args.tool, tool))
    except LimitError as exc:
        mm = not args.mm and math.hypot(*tool) / 1000.0 <= TOOL_REACH
        raise LimitError(f'{exc}{" (millimetres? give --mm)" if mm else ""}') from None
    return tool


def angles(args: argparse.Namespace, values: Iterable[float]) -> list[float]:
    """Input angles in radians (``--deg`` converted)."""
    return [math.radians(v) if args.deg else v for v in values]



def sample_rate(value: float) -> float:
    """A typed ``--rate`` [Hz] within :data:`~gpr_kinematics.robot.grid.RATES`, else :class:`InputError` naming it
    as typed (``--rate = 5001 Hz``, not the float it became), checked before any work."""
    from ..robot.grid import RATES, RATES_ALLOWED
    if not RATES[0] <= value <= RATES[1]:   # 5000.0001 read 5000, the bound
        shown = apart(value, RATES[1] if value > RATES[1] else RATES[0])[0] if math.isfinite(value) else f'{value:g}'
        raise InputError(f'--rate = {shown} Hz is invalid; allowed: {RATES_ALLOWED}')
    return value


def direction(args: argparse.Namespace, value: float, option: str) -> float:
    """A direction or joint angle typed as ``option`` (``--azimuth``, ``--heading``, ``--redundancy``, a station's
    or a command's ``--tilt``) in radians
    (``--deg`` converted): finite and within one turn, [-2 pi, 2 pi] rad or [-360, 360] deg, else
    :class:`InputError` naming it. The core takes any angle up to +-1e6 rad (periodic); a typed angle beyond one
    turn is a slip, mostly degrees given as radians (``--azimuth 40`` meant 40 deg), never an angle meant."""
    deg = bool(getattr(args, 'deg', False))
    v = finite_number(value, option)
    if beyond_turn(math.radians(v) if deg else v):   # the files' and the requests' rule
        if deg:
            shown, turn = apart(abs(v), 360.0)
            raise InputError(f'{option} = {"-" if v < 0 else ""}{shown} deg is outside [-{turn}, {turn}] deg; '
                             'allowed: an angle of at most one turn')
        shown, turn = apart(abs(v), TURN)
        near = f' (2pi = {turn})' if f'{abs(v):g}' == f'{TURN:g}' else ''   # 6.28318530818 read as 6.28319
        raise InputError(f'{option} = {"-" if v < 0 else ""}{shown} rad is outside [-2pi, 2pi] rad{near}; allowed: an '
                         'angle in radians (give --deg for degrees)')
    return math.radians(v) if deg else v


#: The hint of a typed tilt beyond the tilt limit that would be within it read as degrees (:func:`typed_tilt`).
DEGREES_HINT = ' (degrees given as radians? give --deg)'


def typed_tilt(args: argparse.Namespace, option: str, value: float, typed: float, config: GprConfig,
               tilt: float | None = None, allowed: str = '|tilt|') -> None:
    """Refuse a tilt typed as ``option`` (``value`` [rad], ``--deg`` converted; ``typed`` as typed) whose ``tilt``
    (default ``|value|``: what the core checks) is beyond ``config``'s tilt limit by the core's rule
    (:func:`~gpr_kinematics.core.inverse.tilt_target_slack`), in the core's words with ``allowed`` (``--max-tilt``
    for the sweep's) and, where ``typed`` read as degrees would be within the limit and more than ten times it as
    radians, :data:`DEGREES_HINT` (``gpr robot ik``'s rule: ``--tilt 2`` meant 2 deg); under ``--deg`` the degrees
    first, as typed. A tilt that is not finite is left to the core."""
    from ..core.forward import beyond_tilt
    from ..core.inverse import tilt_target_slack
    checked = abs(value) if tilt is None else tilt
    slack = tilt_target_slack(config)
    if not math.isfinite(checked) or checked - config.tilt_limit <= slack:
        return
    typed_deg = bool(getattr(args, 'deg', False))   # named in the unit typed, the radians beside
    degrees = not typed_deg and abs(typed) > 10.0 * config.tilt_limit and \
        math.radians(abs(typed)) - config.tilt_limit <= slack
    raise LimitError(f'{option} = {beyond_tilt(value, config.tilt_limit, allowed, typed_deg)}'
                     f'{DEGREES_HINT if degrees else ""}')


def robot_options(p: argparse.ArgumentParser, program: bool = False, cell: bool = False) -> None:
    """``--robot``, ``--config``, ``--model`` and ``--json``; ``program``: of a program's command, whose robot is the
    program's own by default (the help said the packaged example's); ``cell``: ``export``'s and ``send``'s ``--cell``
    (``check`` has its own)."""
    if cell:
        p.add_argument('--cell', metavar='FILE', type=shipped(CELLS), dest='cell_override',
                       help="the process cell the program is checked in (default: the program's cell, else none), as "
                       "gpr program check --cell")
    p.add_argument('--robot', metavar='FILE', type=shipped(ROBOTS),
                   help="robot description (default: the program's robot: file, else the packaged example_robot.yaml; "
                        "another robot than the program's is refused, its calibration taken)" if program else
                   'robot description (default: the packaged example_robot.yaml)')
    p.add_argument('--config', metavar='FILE', help="GPR geometry file replacing the description's gpr section")
    p.add_argument('--model', choices=MODELS, help='virtual-joint model (default: from the geometry)')
    p.add_argument('--json', action='store_true', help='print one JSON object on stdout')


def unit_options(p: argparse.ArgumentParser) -> None:
    """``--mm`` and ``--deg`` (``--mm`` converting every length typed: no mm hint under it, ``cli.main``)."""
    p.add_argument('--mm', action='store_true', help='input lengths are in millimetres (output stays SI)')
    p.set_defaults(mm_converts_all=True)
    p.add_argument('--deg', action='store_true', help='input angles are in degrees (output stays SI)')


def vec(v: ArrayLike, scale: float = 1.0, fmt: str = '{:.9f}') -> str:
    """A vector as ``(x, y, z)`` for the text output."""
    return '(' + ', '.join(fmt.format(x * scale) for x in np.ravel(v)) + ')'

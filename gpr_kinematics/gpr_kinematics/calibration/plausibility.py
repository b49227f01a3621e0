"""Whether measurements are of this machine at all: a measured pose implausibly far from the nominal model's (wrong
units, another frame, a wrong row) is refused before any fit, with the likely cause named (millimetres read as
metres, or metres under a ``# units: mm`` line, tested by rescaling the file and fitting its frames again; else,
where the measurements fit far better read another way, a column's unit or two columns swapped, positions or rod
lengths: :func:`other_reading`).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GprError, InputError
from .measurements import Measurements
from .model import PoseModel, evaluate, pose_error
from .quality import Gate

Array = NDArray[np.float64]

#: A measured pose farther than this from the nominal model's is not a measurement of this machine in
#: the measured frame (wrong units, wrong frame, wrong row): [m] and [rad].
PLAUSIBLE_POSITION = 0.01
PLAUSIBLE_ANGLE = 0.05
#: Another reading of the positions is hinted at when it puts every row within the plausible errors and its RMS
#: position error (the nominal model, its frames fitted again) is at most this share of the file's as read.
BETTER_READING = 0.1
#: Implausible rows are named as wrong rows where they are a minority and the others' RMS error is at most this share
#: of the plausible limits (:func:`_isolated`).
ISOLATED = 0.1


class ImplausiblePoseError(InputError):
    """A measured pose implausibly far from the nominal model's (:data:`PLAUSIBLE_POSITION`,
    :data:`PLAUSIBLE_ANGLE`): wrong units, another frame, or a frame given wrongly (the command line says which).
    ``units``: the lengths' units explain it (the message says which), not a frame or a target; ``angle``: the
    file's angle unit (deg only where its ``# units:`` line declares it); ``target_fitted``: the target's place on
    the platform is identified from the rows (a target off the origin is then no cause)."""

    units = False
    angle = 'rad'
    target_fitted = False


def measured_errors(model: PoseModel, meas: Measurements, theta: ArrayLike) -> Array:
    """Errors of the model's poses at ``theta`` (rows ``(S, P)`` or one ``(P,)``) against the measurements: pose
    errors ``(..., N, 6)``, or position errors ``(..., N, 3)`` for measured points."""
    pos, rot = evaluate(model, theta, meas.q)
    if meas.quaternion is None:
        return np.asarray(pos - meas.position, dtype=np.float64)
    return pose_error(pos, rot, meas.position, meas.rotation)


def implausible(errors: Array) -> tuple[NDArray[np.int64], Array, Array]:
    """The rows whose errors ``(N, 3 or 6)`` lie beyond :data:`PLAUSIBLE_POSITION` or :data:`PLAUSIBLE_ANGLE`, and
    every row's position and angle error."""
    dp = np.linalg.norm(errors[:, :3], axis=1)
    da = np.linalg.norm(errors[:, 3:], axis=1) if errors.shape[1] == 6 else np.zeros(len(dp))
    return np.flatnonzero((dp > PLAUSIBLE_POSITION) | (da > PLAUSIBLE_ANGLE)).astype(np.int64), dp, da


def _check_plausible(meas: Measurements, errors: Array, frame: str,
                     rescaled: Callable[[float], bool] = lambda factor: False,
                     reading: Callable[[], str] = lambda: '', fitted_frame: bool = False,
                     target_fitted: bool = False) -> None:
    """ImplausiblePoseError for the first row beyond the plausible errors; ``rescaled(factor)``: the positions
    times ``factor`` fit the model (its frames fitted again), for the hint on units; ``reading()``: else
    :func:`other_reading`'s hint ('' for none). ``fitted_frame``, ``target_fitted``: ``frame``'s pose, the target's
    place are identified from the rows (another frame is then no cause); a minority of the rows so far off is named
    as wrong or mismeasured rows."""
    bad, dp, da = implausible(errors)
    if bad.size:
        i = int(bad[0])
        what = (f'pose is {dp[i]:.4g} m and {da[i]:.4g} rad' if errors.shape[1] == 6 else f'point is {dp[i]:.4g} m')
        limits = f'{PLAUSIBLE_POSITION} m' + (f', {PLAUSIBLE_ANGLE} rad' if errors.shape[1] == 6 else '')
        declared_mm = meas.units[0] == 'mm'
        mm = not declared_mm and _units_explain(meas, errors, i, 1e-3, rescaled)
        metres = declared_mm and _units_explain(meas, errors, i, 1e3, rescaled)
        elsewhere = ('; a tracker\'s frame is identified with the machine with --frame NAME (docs/calibration.md)'
                     if frame == 'gpr_base' else '')
        hint = '' if mm or metres else reading()
        few = (('the only row' if bad.size == 1 else f'{bad.size} of {len(errors)} rows') + ' so far off: a wrong or '
               'mismeasured row? remove it or measure it again; else ') if _isolated(bad, dp, da) else ''
        other = '' if fitted_frame else f'another frame than {frame}{elsewhere}, or '
        why = ('millimetres? declare "# units: mm"' if mm else
               'metres under the "# units: mm" line? give them in mm' if metres else
               f'{few}{other}a machine that far from its nominal model (an arm\'s zero offset of a degree moves its '
               'wafer some centimetres): correct the nominal model first' + (f'; {hint}' if hint else ''))
        unit = ('millimetres, as the file declares' if declared_mm else   # a column's own [mm] is no "SI units"
                'the units it declares (m and rad where it names none)')
        exc = ImplausiblePoseError(f'{meas.where(i)}: the measured {what} from the nominal model\'s (allowed: '
                                   f'{limits}): not a measurement of this machine in {frame} in {unit} ({why})')
        exc.units, exc.angle, exc.target_fitted = mm or metres or bool(hint), meas.units[1], target_fitted
        raise exc


def _isolated(bad: NDArray[np.int64], dp: Array, da: Array) -> bool:
    """Whether the implausible rows ``bad`` are a minority and the others lie well within the limits (their RMS
    error, each kind over its limit, at most :data:`ISOLATED`): wrong rows, not a systematic error (two rod columns
    swapped put 4 of 40 rows beyond 0.05 rad and the rest up to it)."""
    rest = np.setdiff1d(np.arange(len(dp)), bad)
    spread = np.hypot(dp[rest] / PLAUSIBLE_POSITION, da[rest] / PLAUSIBLE_ANGLE)
    return 2 * bad.size < len(dp) and float(np.sqrt(np.mean(spread ** 2))) <= ISOLATED


def _units_explain(meas: Measurements, errors: Array, i: int, factor: float,
                   rescaled: Callable[[float], bool]) -> bool:
    """Whether the lengths times ``factor`` (1e-3: millimetres read as metres; 1e3: metres under a ``# units: mm``
    line) explain row ``i``'s implausible error: the row alone where it can tell (its position what failed, its
    angle within :data:`PLAUSIBLE_ANGLE`, its rescaled position where the model puts it and more than
    :data:`PLAUSIBLE_POSITION` from the origin: a row a few millimetres above the base matched any thousandth of
    itself, an angle off or a point moved sideways got the hint), else the whole file rescaled with its frames
    fitted again (a fitted target took up half of the thousandfold)."""
    e = errors[i]
    scaled = factor * meas.position[i]
    if np.linalg.norm(e[:3]) > PLAUSIBLE_POSITION and np.linalg.norm(e[3:]) <= PLAUSIBLE_ANGLE and \
            np.linalg.norm(scaled) > PLAUSIBLE_POSITION and \
            np.linalg.norm(meas.position[i] + e[:3] - scaled) <= PLAUSIBLE_POSITION:
        return True
    return rescaled(factor)


def plausible_start(model: PoseModel, meas: Measurements, theta0: Array, frame: str) -> Array | None:
    """Refuse measurements implausibly far from the model at ``theta0`` (:class:`ImplausiblePoseError`), its frames
    fitted alone (the model's ``registered``) where the closed-form registration misses; that start, else None."""
    refine = getattr(model, 'registered', None)   # a registration: the frames refined where its closed form misses

    def errors(m: Measurements) -> tuple[Array, Array | None]:
        e = measured_errors(model, m, theta0)
        start = refine(m) if callable(refine) and implausible(e)[0].size else None
        return (e, start) if start is None else (measured_errors(model, m, start), start)

    def rescaled(factor: float) -> bool:
        try:
            return not implausible(errors(replace(meas, position=meas.position * factor))[0])[0].size
        except GprError:
            return False

    e, start = errors(meas)
    _check_plausible(meas, e, frame, rescaled, lambda: other_reading(model, meas, theta0),
                     bool(getattr(model, 'fit_base', False)), getattr(model, 'fit_target', None) is not None)
    return start


def other_reading(model: PoseModel, meas: Measurements, theta0: Array) -> str:
    """A hint ('' for none) where the measurements fit the model at ``theta0`` (its frames fitted again) far better
    read another way (:data:`BETTER_READING`): the positions 1000 times or a thousandth of their values (a column's
    unit: ``x [mm]`` over metres) or two of the columns x, y, z swapped, judged by the RMS position error; or two of
    the rod lengths q1, q2, q3 swapped, judged by the RMS angle error of measured poses (a swap tilts the platform
    the other way; its origin hardly moves) or the RMS position error of points; or the model's own columns read
    another way (its ``swapped_columns()``: an arm's joint columns of one file swapped, :class:`~.arm.ArmModel`),
    judged by the RMS position error; the best such reading."""
    poses = meas.quaternion is not None

    def rms(position: Array, q: Array, quaternion: Array | None = meas.quaternion,
            read: PoseModel = model) -> tuple[float, float, bool]:
        refine = getattr(read, 'registered', None)
        try:   # a reading beyond the coordinates' bound is refused (InputError) as a file of it would be
            m = replace(meas, position=position, q=q, quaternion=quaternion)
            e = measured_errors(read, m, refine(m) if callable(refine) else theta0)
        except GprError:
            return math.inf, math.inf, False
        return (float(np.sqrt(np.mean(np.sum(e[:, :3] ** 2, axis=1)))),
                float(np.sqrt(np.mean(np.sum(e[:, 3:] ** 2, axis=1)))) if poses else math.inf,
                not implausible(e)[0].size)

    def swapped(a: int, b: int) -> list[int]:
        return [b if c == a else a if c == b else c for c in range(3)]

    p, q = meas.position, meas.q
    pairs = ((0, 1), (0, 2), (1, 2))
    units = (('metres', 1e3), ('millimetres', 1e-3))
    readings = [(f'the positions fit this machine if their values were in {unit} (x, y, z {factor:g} times what was '
                 'read)', p * factor, q, 0) for unit, factor in units]
    readings += [(f'the positions fit this machine with columns {"xyz"[a]} and {"xyz"[b]} swapped',
                  p[:, swapped(a, b)], q, 0) for a, b in pairs]
    readings += [(f'the {"poses" if poses else "points"} fit this machine with columns q{a + 1} and q{b + 1} swapped',
                  p, q[:, swapped(a, b)], int(poses)) for a, b in pairs]
    quaternions = []
    if meas.quaternion is not None:   # a w-first or inverse rotation was blamed on the lengths' unit
        o = meas.quaternion
        quaternions = [('the poses fit this machine if their quaternions were written w first (w, x, y, z in the '
                        'columns qx, qy, qz, qw)', o[:, [1, 2, 3, 0]]),
                       ('the poses fit this machine if their quaternions were the inverse rotations (x, y, z negated: '
                        'the frame in the target\'s, not the target in the frame)', o * [-1.0, -1.0, -1.0, 1.0])]
    read = rms(p, q)
    found = [(r[kind] / max(read[kind], 1e-300), r[kind], kind, words)
             for words, pr, qr, kind in readings for r in [rms(pr, qr)]
             if r[2] and r[kind] <= BETTER_READING * read[kind]]
    found += [(r[1] / max(read[1], 1e-300), r[1], 1, words) for words, quaternion in quaternions
              for r in [rms(p, q, quaternion)] if r[2] and r[1] <= BETTER_READING * read[1]]
    columns = getattr(model, 'swapped_columns', None)   # the model's own columns: an arm's joints
    found += [(r[0] / max(read[0], 1e-300), r[0], 0, words) for words, other in (columns() if callable(columns) else [])
              for r in [rms(p, q, read=other)] if r[2] and r[0] <= BETTER_READING * read[0]]
    if not found:
        return ''
    _, r, kind, words = min(found)
    # in a frame the fit registers, a turn of 120 deg relabels the rods: any two swapped read alike (a trial's q1 and
    # q3 were named q1 and q2); every swap within twice the best's error is named
    alike = sorted(w.rsplit(' columns ', 1)[1].removesuffix(' swapped') for _, e, _, w in found
                   if ' columns q' in w and e <= 2.0 * r)
    if ' columns q' in words and len(alike) > 1:
        words = (f'{words.split(" with ")[0]} with columns {", or ".join(alike)} swapped (they read alike where the '
                 'fit registers the frame: a turn of 120 deg about the rods relabels them)')
    check = 'their columns\' unit (the header\'s, or the "# units:" line)' if 'times' in words else \
        'the quaternion columns\' order and convention (x, y, z, w: the target\'s rotation in the frame)' \
        if 'quaternions' in words else 'the header\'s column names'
    error = f'RMS angle {_angle(r)}' if kind else f'RMS {_length(r)}'
    return f'{words}: {error} from the nominal model\'s against {(_angle if kind else _length)(read[kind])} as ' \
        f'read; check {check}'


#: A failed chi-square beyond this (residuals ten times the noise) looks for another reading of the file.
FAR_CHI2 = 100.0


def with_reading(gate: Gate, model: PoseModel, meas: Measurements, theta0: Array) -> Gate:
    """``gate`` with :func:`other_reading`'s hint after its chi-square's words where that failed beyond
    :data:`FAR_CHI2`: conjugated quaternions failed it at 3566 with no word of them."""
    check = next((c for c in gate.checks if c.name == 'chi_square'), None)
    if check is None or check.passed or not check.value > FAR_CHI2:
        return gate
    hint = other_reading(model, meas, theta0)
    if not hint:
        return gate
    said = replace(check, detail=f'{check.detail} {hint[0].upper()}{hint[1:]}.')
    return Gate(tuple(said if c is check else c for c in gate.checks))


def _angle(v: float) -> str:
    """``882 urad``, ``12 mrad`` [rad in]."""
    return f'{1e6 * v:.3g} urad' if v < 1e-3 else f'{1e3 * v:.3g} mrad'


def _length(v: float) -> str:
    """``75.6 um``, ``214 mm`` [m in]."""
    return f'{1e6 * v:.3g} um' if v < 1e-3 else f'{1e3 * v:.3g} mm'

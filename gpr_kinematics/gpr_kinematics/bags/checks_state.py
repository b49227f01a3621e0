"""``state.*`` checks: every PlatformState against forward kinematics of its own ``q`` (one batch per model).

The fields compared, and the :class:`~gpr_kinematics.core.ForwardBatch` attribute each holds, are
:data:`gpr_kinematics.core.messages.STATE_FROM_RESULT`, the table the nodes and the synthetic writer build their
messages from: a field added there is checked here without another edit. :data:`RULES` only says *how* a
field is compared where plain agreement is not the right test (quaternions, wrapped angles, a tilt azimuth
undefined without tilt, a bound instead of equality); any other field gets :func:`rule_for`'s default, a check
``state.<field>`` of agreement within ``Tolerances.agreement`` (numbers) or equality (flags, strings).

Kinds of comparison, per sample, of the stored value ``s`` with the recomputed ``f``:

- ``value``: ``max_k |s_k - f_k|`` (a different count of values: inf);
- ``quaternion``: rotation angle ``2 atan2(|v|, |w|)`` of ``conj(f) s`` plus ``| |s| - 1 |``;
- ``angle``: ``|s - f|`` wrapped to [0, pi]; ``azimuth``: the same times the tilt (the distance of the two tilt
  vectors of one tilt: an azimuth of a tilt of 1e-8 rad is rounded to about 1e-9 rad, another machine's differs);
- ``equal``: 0 when equal, else 1 (limit 0); ``names``: 0 when the tuples are equal, else inf;
- ``bound``: ``s`` itself against a configuration limit; ``small``: ``max(s, f)`` against the tolerance.

Besides the table: ``state.model`` (a model of :data:`gpr_kinematics.core.config.MODELS`), ``state.forward`` (``q``
finite and the core solves it: a solver error is a failed check, not a crash), ``state.imperfection_budget`` (every
stored joint displacement <= ``imperfection_budget``), ``state.limits`` (``q`` inside the stroke and the tilt <=
``tilt_limit``, 1e-9 of slack) and ``state.commanded``: the commanded tilt and azimuth (inputs of the stream, never
recomputed from ``q``) are what the platform achieves: the commanded tilt vector ``tilt (cos azimuth, sin azimuth)`` (a
negative tilt points along azimuth + pi) is the achieved one within ``Tolerances.angle`` (every stream of the node
commands its platform exactly: the inverse kinematics of a sweep and a platform program, the platform's own tilt in a
robot program; a changed, NaN or infinite commanded value fails).
A sample that cannot be recomputed (unknown model, ``q`` not finite, the solver fails) fails ``state.model`` or
``state.forward`` and is left out of the comparisons.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import STROKE_SLACK, TILT_LIMIT_SLACK, ForwardBatch, forward_batch
from ..core.config import MODELS, GprConfig
from ..core.messages import STATE_FROM_RESULT, is_frame_name
from ..errors import GprError
from .cdr import Columns
from .columns import field_matrix, matrix, quaternion_angle, row_sizes, wrapped
from .results import Check, Series, bool_check, value_check
from .tolerances import Tolerances


@dataclass(frozen=True)
class Rule:
    """How one message field is compared: check name, kind, the limit's name (a tolerance, or a configuration
    value for ``bound``), unit and the text of a failure."""

    check: str
    kind: str
    limit: str
    unit: str
    detail: str = ''


#: Fields that are not compared: the input of the forward solution, and the key that selects the model.
INPUTS = frozenset({'q', 'model'})

RULES: dict[str, Rule] = {
    'pose.position': Rule('state.pose_position', 'value', 'position', 'm'),
    'pose.orientation': Rule('state.pose_orientation', 'quaternion', 'angle', 'rad'),
    'nominal_pose.position': Rule('state.nominal_position', 'value', 'position', 'm'),
    'nominal_pose.orientation': Rule('state.nominal_orientation', 'quaternion', 'angle', 'rad'),
    'centre_shift': Rule('state.centre_shift', 'value', 'position', 'm'),
    'virtual_joints': Rule('state.virtual_joints', 'value', 'virtual_joint', 'm|rad',
                           'inf = names or count differ from the model'),
    'virtual_joint_names': Rule('state.virtual_joints', 'names', 'virtual_joint', 'm|rad'),
    'side_lengths': Rule('state.side_lengths', 'value', 'length', 'm'),
    'tilt': Rule('state.tilt', 'angle', 'angle', 'rad', 'tilt, tilt_azimuth or twist'),
    'tilt_azimuth': Rule('state.tilt', 'azimuth', 'angle', 'rad'),
    'twist': Rule('state.tilt', 'angle', 'angle', 'rad'),
    'joint_displacement': Rule('state.joint_displacement', 'value', 'length', 'm'),
    'within_budget': Rule('state.within_budget', 'equal', 'zero', '', 'flag differs from the core'),
    'iterations': Rule('state.iterations', 'bound', 'max_iterations', ''),
    'residual': Rule('state.residual', 'small', 'residual', 'm', 'stored or recomputed'),
}


def rule_for(field: str, c: Columns) -> Rule:
    """The rule of ``field``: from :data:`RULES`, else agreement (numbers) or equality (strings)."""
    if field in RULES:
        return RULES[field]
    name = 'state.' + field.replace('.', '_')
    if field in c.strings:
        return Rule(name, 'equal', 'zero', '', 'differs from the core')
    return Rule(name, 'value', 'agreement', '')


def _limit(rule: Rule, tol: Tolerances, cfg: GprConfig) -> float:
    if rule.limit == 'zero':
        return 0.0
    return float(getattr(tol, rule.limit)) if hasattr(tol, rule.limit) else float(getattr(cfg, rule.limit))


def _stored(c: Columns, field: str, rows: NDArray[np.int64], width: int | None
            ) -> tuple[NDArray[Any], NDArray[np.bool_]]:
    """The stored values of ``field`` in ``rows`` and whether each row has ``width`` values (sequences)."""
    if field in c.strings:
        return c.strings[field][rows], np.ones(rows.size, dtype=bool)
    col = c.numeric.get(field)
    if col is not None and col.dtype == object and width is not None:
        sizes = np.array([np.size(v) for v in col[rows]])
        return matrix(col[rows], width), sizes == width
    return field_matrix(c, field)[rows], np.ones(rows.size, dtype=bool)


def _error(kind: str, stored: NDArray[Any], value: Any, fk: ForwardBatch) -> NDArray[np.float64]:
    """Per-sample error of the ``stored`` values against the recomputed ``value`` (see the module docstring)."""
    n = len(fk)
    out: NDArray[np.float64]
    if kind == 'names':
        return np.array([0.0 if tuple(v) == tuple(value) else np.inf for v in stored])
    if kind == 'equal':
        if isinstance(value, str):
            return np.array([0.0 if v == value else 1.0 for v in stored])
        out = (np.asarray(stored).reshape(n) != np.asarray(value).reshape(n)).astype(float)
        return out
    s: NDArray[np.float64] = np.asarray(stored, dtype=float).reshape(n, -1)
    f: NDArray[np.float64] = np.asarray(value, dtype=float).reshape(n, -1)
    if kind == 'bound':
        out = s[:, 0]
    elif kind == 'small':
        out = np.maximum(s[:, 0], f[:, 0])
    elif s.shape[1] != f.shape[1]:
        out = np.full(n, np.inf)
    elif kind == 'quaternion':
        out = quaternion_angle(f, s) + np.abs(np.linalg.norm(s, axis=1) - 1.0)
    elif kind in ('angle', 'azimuth'):
        out = np.max(wrapped(s - f), axis=1)
        if kind == 'azimuth':
            out = out * fk.tilt
    else:
        out = np.max(np.abs(s - f), axis=1) if s.shape[1] else np.zeros(n)
    return out


def commanded_error(tilt: NDArray[np.float64], azimuth: NDArray[np.float64], fk: ForwardBatch) -> NDArray[np.float64]:
    """Per sample: the distance [rad] of the commanded tilt vector ``tilt (cos azimuth, sin azimuth)`` (a negative
    tilt: the azimuth + pi) from the achieved one (the module docstring); NaN for a commanded value that is not
    finite. The vectors, not the azimuths: at a tilt of 1.5e-8 rad the azimuths of an honest stream differed by
    7.9e-9 rad (the rounding of a direction that short), the vectors by 1e-16."""
    with np.errstate(invalid='ignore'):
        dx = tilt * np.cos(azimuth) - fk.tilt * np.cos(fk.tilt_azimuth)
        dy = tilt * np.sin(azimuth) - fk.tilt * np.sin(fk.tilt_azimuth)
        out: NDArray[np.float64] = np.where(np.isfinite(tilt) & np.isfinite(azimuth), np.hypot(dx, dy), np.nan)
    return out


@dataclass
class StateOutcome:
    checks: list[Check]
    series: Series
    solved: NDArray[np.bool_]


def state_checks(c: Columns, samples: NDArray[np.int64], topic: str, cfg: GprConfig, tol: Tolerances,
                 crossings: NDArray[np.int64]) -> StateOutcome:
    """The ``state.*`` checks of the PlatformState columns ``c`` (see the module docstring)."""
    n = len(samples)
    q = matrix(c['q'], 3)
    models = c['model']
    model_ok = np.isin(models, MODELS)
    solved = model_ok & np.all(np.isfinite(q), axis=1)
    rules = [(field, attr, rule_for(field, c)) for field, attr in STATE_FROM_RESULT if field not in INPUTS]
    errors = {rule.check: np.full(n, np.nan) for _, _, rule in rules}
    limits = np.full(n, np.inf)
    commanded = np.full(n, np.inf)
    fk_error = ''
    for model in sorted({str(m) for m in models[model_ok]}):
        rows = np.flatnonzero((models == model) & solved)
        if rows.size == 0:
            continue
        try:
            fk = forward_batch(q[rows], cfg, model, check_limits=False)
        except GprError as exc:  # e.g. no convergence far outside the workspace: a failed check
            solved[rows] = False
            fk_error = f' ({type(exc).__name__}: {exc})'
            continue
        touched: set[str] = set()
        for field, attr, rule in rules:
            value = getattr(fk, attr)
            width = np.shape(value)[1] if np.ndim(value) == 2 else None
            stored, complete = _stored(c, field, rows, width)
            err = np.where(complete, _error(rule.kind, stored, value, fk), np.inf)
            acc = errors[rule.check]
            acc[rows] = np.maximum(acc[rows], err) if rule.check in touched else err
            touched.add(rule.check)
        stroke = np.maximum(cfg.stroke_min - q[rows], q[rows] - cfg.stroke_max).max(axis=1)
        # beyond the core's own slacks (forward kinematics' rule): by how much, 0 within
        limits[rows] = np.maximum(np.maximum(stroke - STROKE_SLACK, fk.tilt - cfg.tilt_limit - TILT_LIMIT_SLACK), 0.0)
        commanded[rows] = commanded_error(np.asarray(c['commanded_tilt'], float)[rows],
                                          np.asarray(c['commanded_azimuth'], float)[rows], fk)
    disp = field_matrix(c, 'joint_displacement')
    checks = [bool_check('state.model', topic, model_ok, samples, 'model is not ' + ', '.join(MODELS)),
              bool_check('state.forward', topic, solved | ~model_ok, samples,
                         'q not finite, or forward kinematics failed' + fk_error)]
    # A sample that is not recomputed fails state.model or state.forward, once; the comparisons cover the rest.
    ok = samples[solved]
    seen: set[str] = set()
    for _, _, rule in rules:
        if rule.check not in seen:
            seen.add(rule.check)
            detail = next((r.detail for _, _, r in rules if r.check == rule.check and r.detail), '')
            checks.append(value_check(rule.check, topic, errors[rule.check][solved], _limit(rule, tol, cfg),
                                      rule.unit, ok, detail))
    checks.append(value_check('state.imperfection_budget', topic, np.max(disp, axis=1), cfg.imperfection_budget,
                              'm', samples))
    checks.append(value_check('state.limits', topic, limits[solved], 0.0, 'm|rad', ok,
                              'q outside the stroke or tilt beyond tilt_limit'))
    checks.append(value_check('state.commanded', topic, commanded[solved], tol.angle, 'rad', ok,
                              'commanded tilt vector (tilt, azimuth) is not what the platform achieves (NaN: a '
                              'commanded value not a number)'))
    series = Series(sample=samples, q=q, model=min((str(m) for m in models), default=''),
                    virtual_joints=matrix(c['virtual_joints']),
                    side_lengths=field_matrix(c, 'side_lengths'), centre_shift=field_matrix(c, 'centre_shift'),
                    tilt=np.asarray(c['tilt'], dtype=float),
                    commanded_tilt=np.asarray(c['commanded_tilt'], dtype=float), crossings=crossings,
                    virtual_counts=row_sizes(c['virtual_joints']))
    return StateOutcome(checks, series, solved)


def frame_check(c: Columns, samples: NDArray[np.int64], topic: str, prefix: str | None, world: str | None) -> Check:
    """``state.frame``: every PlatformState's ``header.frame_id`` a tf frame name (trajectory_node's ``base_frame``
    with its ``frame_prefix``), starting with the ``prefix`` the records name (None: not recorded, any) and longer than
    it, and not the robot's ``world`` frame with it (None: no robot known; the node refuses such a ``base_frame``).
    A re-signed bag with every frame set to ``''``, ``world`` or ``evil/gpr_base`` beside a record's prefix ``r1/``
    passed: the other topics' frames are only matched to the states' own."""
    p = prefix or ''
    ok = np.array([is_frame_name(f) and (prefix is None or (f.startswith(p) and len(f) > len(p)))
                   and (world is None or f != p + world) for f in (str(v) for v in c['header.frame_id'])], dtype=bool)
    after = f" after the records' frame_prefix {prefix!r}" if prefix is not None else ''
    other = f", other than the robot's world frame {world!r}" if world is not None else ''
    return bool_check('state.frame', topic, ok, samples, f'header.frame_id is not a tf frame name{after}{other} '
                      "(trajectory_node's base_frame)")

"""Offline verification of a recorded GPR stream against the current kinematics core.

Every ``gpr_interfaces/PlatformState`` of the bag is checked against
:func:`gpr_kinematics.kinematics.forward_batch` of its own ``q`` (one vectorised call per model), and the
stream as a whole is checked for gaps, order, jumps and the consistency of the companion topics. All checks,
their limits (SI units) and their meaning:

``state.*`` (per message, limits from :class:`Tolerances`)
    ``pose_position`` / ``nominal_position`` / ``centre_shift``: ``max_k |stored_k - fk_k|`` <= 1e-9 m;
    ``pose_orientation`` / ``nominal_orientation``: rotation angle ``2 atan2(|v|, |w|)`` of
    ``conj(q_fk) * q_stored`` (quaternions x, y, z, w) plus ``| |q_stored| - 1 |`` <= 1e-9 rad;
    ``tilt``: tilt, twist and (where tilt > 1e-12 rad, else undefined) tilt azimuth, wrapped, <= 1e-9 rad;
    ``virtual_joints``: names equal, ``max |X - X_fk|`` <= 1e-9 (m or rad); ``side_lengths``,
    ``joint_displacement``: <= 1e-9 m; ``within_budget``: the flag equals the core's;
    ``imperfection_budget``: every joint displacement <= ``config.imperfection_budget`` (0.5 mm);
    ``residual``: the stored and the recomputed closure residual <= 1e-9 m;
    ``limits``: ``q`` inside the stroke, tilt <= ``config.tilt_limit`` (+1e-9 rad).
``stream.*``
    ``counter``: sample counters step by exactly 1 in log order; ``stamps``: header stamps strictly
    increasing; ``jump``: between consecutive samples, with ``dq = ||q_i - q_(i-1)||_2`` [m],
    rotation angle <= ``K_rot dq + eps``, ``||dp||`` <= ``K_pos dq + eps``, ``max |dX|`` <= ``K_x dq + eps``,
    ``max |dL|`` <= ``K_L dq + eps``. ``K_rot = 1.01 sqrt(2/3) / R`` [rad/m] is the slope of the plane
    through the three joint centres (``2/(3R) |sum dq_k u_k|`` <= ``sqrt(2/3)/R ||dq||``; the paper sweep
    reaches 0.99999 of it) with 1 % for the virtual joints; ``K_pos = 1/sqrt(3) + 0.05`` (height = mean of
    ``q``, plus the centre shift's slope, 0.014 on the paper sweep); ``K_L = sqrt(2)`` (from
    ``L_ij = sqrt(3 R^2 + (q_j - q_i)^2)``); ``K_x = 0.5`` (m or rad per m; 3x the largest ratio over the paper
    sweep for all models and weightings, 0.15); ``eps = 1e-12``. A jump at a crossing of the singular
    configuration (a branch switch of the solver) breaks these bounds; the report lists the crossings
    (commanded tilt 0 or changing sign) and the largest ratio there.
``topic.*`` (companion topics of the same sample, matched by header stamp)
    ``platform_pose`` / ``nominal_pose``: a PoseStamped with the stamp and frame of every PlatformState and
    the same pose (<= 1e-12); ``joint_states``: names ``rod_1..rod_3``, positions ``q`` (or, in bags recorded
    before the virtual joints got their own topic, ``rod_1..rod_3`` + the virtual-joint names, ``q`` then ``X``)
    (<= 1e-12). A sample before the first or after the last message of a companion topic
    is not counted as missing: a recording started, or cut by SIGKILL, in the middle of a sample holds only
    part of that sample's messages. Companion messages without a PlatformState are ``*_extra`` failures.
``bag.*``
    ``type_hash``: the stored type hash of every known type equals the current definition's (a changed
    ``PlatformState.msg`` is named); ``message_count``: ``metadata.yaml`` counts equal the messages read.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..config import GprConfig
from ..errors import GprError
from ..kinematics import ForwardBatch, forward_batch, resolve_config
from .cdr import Columns
from .reader import Bag, TopicData, read_bag
from .typestore import GPR_TOPICS, PLATFORM_STATE, definition, typestore

#: How many failures per check are kept with their details (all are counted).
MAX_DETAILS = 20
ROD_NAMES = ('rod_1', 'rod_2', 'rod_3')


@dataclass(frozen=True)
class Tolerances:
    """Limits of the checks (SI units); see the module docstring."""

    position: float = 1e-9
    angle: float = 1e-9
    virtual_joint: float = 1e-9
    length: float = 1e-9
    residual: float = 1e-9
    consistency: float = 1e-12
    jump_rot_factor: float = 1.01
    jump_pos: float = 1.0 / math.sqrt(3.0) + 0.05
    jump_x: float = 0.5
    jump_length: float = math.sqrt(2.0)
    jump_eps: float = 1e-12

    def replace(self, **kw: float) -> Tolerances:
        values = {k: getattr(self, k) for k in self.__dataclass_fields__}
        values.update(kw)
        return Tolerances(**values)


@dataclass
class Failure:
    """One failed check: ``check`` on ``topic`` at ``sample`` (the message's counter, or its index in the
    topic when it has none), the offending ``value`` and the ``limit``."""

    check: str
    topic: str
    sample: int | None
    value: float
    limit: float
    detail: str = ''

    def line(self) -> str:
        where = f'sample {self.sample}' if self.sample is not None else 'bag'
        extra = f' ({self.detail})' if self.detail else ''
        return f'FAIL {self.check} on {self.topic} at {where}: value {self.value:.6g} > limit {self.limit:.6g}{extra}'


@dataclass
class Check:
    """Outcome of one check over ``checked`` items: ``worst`` value against ``limit`` [``unit``]."""

    name: str
    topic: str
    checked: int
    worst: float
    limit: float
    unit: str
    failed: int = 0
    failures: list[Failure] = field(default_factory=list)
    skipped: str = ''

    @property
    def passed(self) -> bool:
        return self.failed == 0

    @property
    def status(self) -> str:
        if self.skipped:
            return 'skip'
        return 'ok' if self.passed else 'FAIL'


@dataclass
class Series:
    """Per-sample data of the PlatformState stream for the report (SI units)."""

    sample: NDArray[np.int64]
    q: NDArray[np.float64]
    model: str
    virtual_joints: NDArray[np.float64]
    virtual_joint_names: tuple[str, ...]
    side_lengths: NDArray[np.float64]
    centre_shift: NDArray[np.float64]
    tilt: NDArray[np.float64]
    commanded_tilt: NDArray[np.float64]
    crossings: NDArray[np.int64]


@dataclass
class VerifyResult:
    """All checks of one bag, the topic counts, the stream series and timing."""

    path: str
    storage: str
    files: list[str]
    counts: dict[str, int]
    checks: list[Check]
    series: Series | None
    crossings: int
    crossing_ratio: float
    elapsed: float
    read_time: float
    unfinished: list[str]
    config: dict[str, Any]

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def failures(self) -> list[Failure]:
        return [f for c in self.checks for f in c.failures]

    @property
    def states(self) -> int:
        return self.counts.get('/gpr/platform_state', 0)

    def to_dict(self) -> dict[str, Any]:
        return {
            'bag': self.path, 'storage': self.storage, 'files': self.files, 'passed': self.passed,
            'counts': self.counts, 'unfinished_segments': self.unfinished,
            'singular_crossings': self.crossings, 'max_jump_ratio_at_crossings': self.crossing_ratio,
            'elapsed_s': self.elapsed, 'read_s': self.read_time,
            'checks': [{'name': c.name, 'topic': c.topic, 'status': c.status, 'checked': c.checked,
                        'worst': c.worst, 'limit': c.limit, 'unit': c.unit, 'failed': c.failed,
                        'skipped': c.skipped,
                        'failures': [{'check': f.check, 'topic': f.topic, 'sample': f.sample, 'value': f.value,
                                      'limit': f.limit, 'detail': f.detail} for f in c.failures]}
                       for c in self.checks],
            'config': self.config,
        }


def _finite_max(a: NDArray[np.float64]) -> float:
    if a.size == 0:
        return 0.0
    if np.isnan(a).any():
        return math.inf
    return float(np.max(a))


def _check(name: str, topic: str, values: NDArray[np.float64], limit: float, unit: str,
           samples: NDArray[np.int64], detail: str = '') -> Check:
    """A check over per-item ``values`` (NaN counts as a failure) against ``limit``."""
    v = np.asarray(values, dtype=float)
    bad = ~(v <= limit)
    idx = np.flatnonzero(bad)
    c = Check(name, topic, int(v.size), _finite_max(v), limit, unit, int(idx.size))
    for i in idx[:MAX_DETAILS]:
        c.failures.append(Failure(name, topic, int(samples[i]), float(v[i]), limit, detail))
    return c


def _bool_check(name: str, topic: str, ok: NDArray[np.bool_], samples: NDArray[np.int64], detail: str) -> Check:
    """A check whose items hold or not (value 1 = failed, limit 0)."""
    return _check(name, topic, (~np.asarray(ok, dtype=bool)).astype(float), 0.0, '', samples, detail)


def quaternion_angle(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation angle [rad] between unit quaternions ``a`` and ``b`` (x, y, z, w; ``(N, 4)``), computed as
    ``2 atan2(|v|, |w|)`` of ``conj(a) b`` (accurate for small angles)."""
    ax, ay, az, aw = a.T
    bx, by, bz, bw = b.T
    w = aw * bw + ax * bx + ay * by + az * bz
    x = aw * bx - ax * bw - (ay * bz - az * by)
    y = aw * by - ay * bw - (az * bx - ax * bz)
    z = aw * bz - az * bw - (ax * by - ay * bx)
    return 2.0 * np.arctan2(np.sqrt(x * x + y * y + z * z), np.abs(w))


def _vec(c: Columns, prefix: str, keys: str = 'xyz') -> NDArray[np.float64]:
    return np.stack([np.asarray(c[f'{prefix}.{k}'], dtype=float) for k in keys], axis=-1)


def _stamp_ns(c: Columns) -> NDArray[np.int64]:
    return np.asarray(c['header.stamp.sec'], dtype=np.int64) * 1_000_000_000 + np.asarray(
        c['header.stamp.nanosec'], dtype=np.int64)


def _matrix(col: NDArray[Any], width: int | None = None) -> NDArray[np.float64]:
    """A numeric column as a float matrix (ragged object columns padded with NaN)."""
    if col.dtype != object:
        return np.asarray(col, dtype=float).reshape(len(col), -1)
    w = width if width is not None else max((len(r) for r in col), default=0)
    out = np.full((len(col), w), np.nan)
    for i, r in enumerate(col):
        r = np.asarray(r, dtype=float)[:w]
        out[i, :r.size] = r
    return out


def _wrap(a: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.abs((a + np.pi) % (2 * np.pi) - np.pi)


def singular_crossings(commanded_tilt: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.int64]:
    """Indices of samples at or across the singular configuration: commanded tilt exactly 0, a change of sign
    of the commanded tilt, or ``q1 = q2 = q3`` (spread <= 1e-12 m)."""
    t = np.asarray(commanded_tilt, dtype=float)
    at = t == 0.0
    sign = np.sign(t)
    across = np.zeros_like(at)
    across[1:] = (sign[1:] * sign[:-1]) < 0
    spread = np.ptp(q, axis=1) <= 1e-12 if len(q) else np.zeros(0, dtype=bool)
    return np.flatnonzero(at | across | spread)


class _Verifier:
    def __init__(self, bag: Bag, cfg: GprConfig, tol: Tolerances) -> None:
        self.bag = bag
        self.cfg = cfg
        self.tol = tol
        self.checks: list[Check] = []
        self.series: Series | None = None
        self.crossings = 0
        self.crossing_ratio = 0.0
        self.fk_error = ''

    def run(self) -> None:
        self.bag_checks()
        st = self.bag.topic('/gpr/platform_state')
        if st is None or len(st) == 0 or st.msgtype != PLATFORM_STATE:
            self.checks.append(Check('state.present', '/gpr/platform_state', 1, 1.0, 0.0, 'messages', 1, [
                Failure('state.present', '/gpr/platform_state', None, 0.0, 1.0,
                        'no gpr_interfaces/msg/PlatformState messages on /gpr/platform_state: nothing to verify')]))
            return
        c = st.columns()
        samples = np.asarray(c['sample'], dtype=np.int64)
        self.state_checks(st, c, samples)
        self.stream_checks(st, c, samples)
        self.topic_checks(c, samples)

    # -- bag ----------------------------------------------------------------------------------------------
    def bag_checks(self) -> None:
        store = typestore()
        names, ok, counts_ok = [], [], []
        for topic in self.bag.topics.values():
            if topic.msgtype in store.fielddefs and topic.digest:
                names.append(topic.name)
                ok.append(topic.digest == definition(topic.msgtype)[1])
            counts_ok.append(topic.metadata_count is None or topic.metadata_count == len(topic))
        idx = np.arange(len(ok))
        chk = _bool_check('bag.type_hash', 'bag', np.array(ok, dtype=bool), idx,
                          'stored type hash differs from the current message definition')
        for f, n in zip(chk.failures, [names[i] for i in np.flatnonzero(~np.array(ok, dtype=bool))], strict=False):
            f.topic, f.sample = n, None
        self.checks.append(chk)
        topics = list(self.bag.topics.values())
        vals = np.array([abs((t.metadata_count if t.metadata_count is not None else len(t)) - len(t))
                         for t in topics], dtype=float)
        chk = _check('bag.message_count', 'bag', vals, 0.0, 'messages', np.arange(len(topics)),
                     'metadata.yaml count differs from the messages read')
        for f in chk.failures:
            f.topic, f.sample = topics[int(f.sample or 0)].name, None
        self.checks.append(chk)

    # -- states ---------------------------------------------------------------------------------------------
    def state_checks(self, st: TopicData, c: Columns, samples: NDArray[np.int64]) -> None:
        tol, cfg, topic = self.tol, self.cfg, st.name
        n = len(st)
        q = _matrix(c['q'], 3)
        models = c['model']
        model_names = sorted({str(m) for m in models})
        pos = _vec(c, 'pose.position')
        quat = _vec(c, 'pose.orientation', 'xyzw')
        npos = _vec(c, 'nominal_pose.position')
        nquat = _vec(c, 'nominal_pose.orientation', 'xyzw')
        shift = _vec(c, 'centre_shift')
        L = _matrix(c['side_lengths'], 3)
        disp = _matrix(c['joint_displacement'], 3)
        tilt = np.asarray(c['tilt'], dtype=float)
        az = np.asarray(c['tilt_azimuth'], dtype=float)
        twist = np.asarray(c['twist'], dtype=float)
        within = np.asarray(c['within_budget']).astype(bool)
        residual = np.asarray(c['residual'], dtype=float)
        iterations = np.asarray(c['iterations'], dtype=np.int64)
        vj_col = c['virtual_joints']
        names_col = c['virtual_joint_names']

        e_pos = np.full(n, np.nan)
        e_rot = np.full(n, np.nan)
        e_npos = np.full(n, np.nan)
        e_nrot = np.full(n, np.nan)
        e_shift = np.full(n, np.nan)
        e_L = np.full(n, np.nan)
        e_disp = np.full(n, np.nan)
        e_tilt = np.full(n, np.nan)
        e_vj = np.full(n, np.nan)
        e_res = np.full(n, np.nan)
        flag_ok = np.zeros(n, dtype=bool)
        model_ok = np.ones(n, dtype=bool)
        finite = np.all(np.isfinite(q), axis=1)
        solved = finite.copy()
        lim = np.full(n, np.nan)
        X_all: NDArray[np.float64] | None = None
        vj_names: tuple[str, ...] = ()
        for model in model_names:
            rows = np.flatnonzero((models == model) & finite)
            if model not in ('radial', 'polar', 'offset'):
                model_ok[models == model] = False
                continue
            if rows.size == 0:
                continue
            try:
                fk: ForwardBatch = forward_batch(q[rows], cfg, model, check_limits=False)
            except GprError as exc:  # e.g. no convergence far outside the workspace: a failed check
                solved[rows] = False
                self.fk_error = f'{type(exc).__name__}: {exc}'
                continue
            M = fk.virtual_joints.shape[1]
            e_pos[rows] = np.max(np.abs(pos[rows] - fk.position), axis=1)
            e_npos[rows] = np.max(np.abs(npos[rows] - fk.nominal_position), axis=1)
            e_shift[rows] = np.max(np.abs(shift[rows] - fk.centre_shift), axis=1)
            e_rot[rows] = quaternion_angle(fk.quaternion, quat[rows]) + np.abs(np.linalg.norm(quat[rows], axis=1) - 1)
            e_nrot[rows] = (quaternion_angle(fk.nominal_quaternion, nquat[rows])
                            + np.abs(np.linalg.norm(nquat[rows], axis=1) - 1))
            e_L[rows] = np.max(np.abs(L[rows] - fk.side_lengths), axis=1)
            e_disp[rows] = np.max(np.abs(disp[rows] - fk.joint_displacement), axis=1)
            has_tilt = fk.tilt > 1e-12
            e_az = np.where(has_tilt, _wrap(az[rows] - fk.tilt_azimuth), 0.0)
            e_tilt[rows] = np.maximum.reduce([np.abs(tilt[rows] - fk.tilt), e_az, _wrap(twist[rows] - fk.twist)])
            X = _matrix(vj_col[rows] if vj_col.dtype == object else vj_col[rows], M)
            if X.shape[1] != M:
                e_vj[rows] = np.inf
            else:
                e_vj[rows] = np.max(np.abs(X - fk.virtual_joints), axis=1) if M else 0.0
            names_ok = np.array([tuple(names_col[i]) == tuple(fk.virtual_joint_names) for i in rows], dtype=bool)
            e_vj[rows[~names_ok]] = np.inf
            flag_ok[rows] = within[rows] == fk.within_budget
            e_res[rows] = np.maximum(residual[rows], fk.residual)
            stroke = np.maximum(cfg.stroke_min - q[rows], q[rows] - cfg.stroke_max).max(axis=1)
            lim[rows] = np.maximum(stroke / 1.0, fk.tilt - cfg.tilt_limit)
            if self.series is None or len(model_names) == 1:
                X_all = np.full((n, M), np.nan)
                X_all[rows] = fk.virtual_joints
                vj_names = tuple(fk.virtual_joint_names)
        add = self.checks.append
        add(_bool_check('state.model', topic, model_ok, samples, 'model is not radial, polar or offset'))
        why = f' ({self.fk_error})' if self.fk_error else ''
        add(_bool_check('state.forward', topic, solved | ~model_ok, samples,
                        'q not finite, or forward kinematics failed' + why))
        add(_check('state.pose_position', topic, e_pos, tol.position, 'm', samples))
        add(_check('state.pose_orientation', topic, e_rot, tol.angle, 'rad', samples))
        add(_check('state.nominal_position', topic, e_npos, tol.position, 'm', samples))
        add(_check('state.nominal_orientation', topic, e_nrot, tol.angle, 'rad', samples))
        add(_check('state.centre_shift', topic, e_shift, tol.position, 'm', samples))
        add(_check('state.tilt', topic, e_tilt, tol.angle, 'rad', samples, 'tilt, tilt_azimuth or twist'))
        add(_check('state.virtual_joints', topic, e_vj, tol.virtual_joint, 'm|rad', samples,
                   'inf = names or count differ from the model'))
        add(_check('state.side_lengths', topic, e_L, tol.length, 'm', samples))
        add(_check('state.joint_displacement', topic, e_disp, tol.length, 'm', samples))
        add(_bool_check('state.within_budget', topic, flag_ok, samples, 'flag differs from the core'))
        add(_check('state.imperfection_budget', topic, np.max(disp, axis=1), cfg.imperfection_budget, 'm', samples))
        add(_check('state.residual', topic, e_res, tol.residual, 'm', samples, 'stored or recomputed'))
        add(_check('state.iterations', topic, iterations.astype(float), float(cfg.max_iterations), '', samples))
        add(_check('state.limits', topic, np.where(np.isnan(lim), np.inf, np.maximum(lim, 0.0)), 1e-9, 'm|rad',
                   samples, 'q outside the stroke or tilt beyond tilt_limit'))
        commanded = np.asarray(c['commanded_tilt'], dtype=float)
        vj = X_all if X_all is not None else np.zeros((n, 0))
        stored_vj = _matrix(vj_col, vj.shape[1]) if vj.shape[1] else vj
        self.series = Series(sample=samples, q=q, model=model_names[0] if model_names else '',
                             virtual_joints=stored_vj, virtual_joint_names=vj_names, side_lengths=L,
                             centre_shift=shift, tilt=tilt, commanded_tilt=commanded,
                             crossings=singular_crossings(commanded, q))

    # -- stream ---------------------------------------------------------------------------------------------
    def stream_checks(self, st: TopicData, c: Columns, samples: NDArray[np.int64]) -> None:
        tol, topic = self.tol, st.name
        add = self.checks.append
        n = len(st)
        d = np.diff(samples)
        gap = np.abs(d - 1).astype(float)
        chk = _check('stream.counter', topic, gap, 0.0, 'samples', samples[1:],
                     '|counter step - 1|: lost, repeated or reordered samples')
        add(chk)
        stamps = _stamp_ns(c)
        add(_check('stream.stamps', topic, np.maximum(stamps[:-1] - stamps[1:] + 1, 0).astype(float), 0.0, 'ns',
                   samples[1:], 'header stamp not after the previous one (value = previous - this + 1 ns)'))
        s = self.series
        assert s is not None
        if n < 2:
            return
        q = s.q
        dq = np.linalg.norm(np.diff(q, axis=0), axis=1)
        quat = _vec(c, 'pose.orientation', 'xyzw')
        pos = _vec(c, 'pose.position')
        rot = quaternion_angle(quat[:-1], quat[1:])
        dp = np.linalg.norm(np.diff(pos, axis=0), axis=1)
        dL = np.max(np.abs(np.diff(s.side_lengths, axis=0)), axis=1)
        X = s.virtual_joints
        dX = np.max(np.abs(np.diff(X, axis=0)), axis=1) if X.shape[1] else np.zeros(n - 1)
        models = c['model']
        dX[models[1:] != models[:-1]] = 0.0  # virtual joints of different models are not comparable
        k_rot = tol.jump_rot_factor * math.sqrt(2.0 / 3.0) / self.cfg.radius
        eps = tol.jump_eps
        # Excess over the bound, as a ratio: value / (K dq + eps), must be <= 1.
        ratios = np.stack([rot / (k_rot * dq + eps), dp / (tol.jump_pos * dq + eps),
                           dX / (tol.jump_x * dq + eps), dL / (tol.jump_length * dq + eps)], axis=1)
        ratio = np.max(ratios, axis=1)
        add(_check('stream.jump', topic, ratio, 1.0, 'x bound', samples[1:],
                   'change between samples over its bound K*|dq|+eps (rotation, position, X, L)'))
        cross = s.crossings
        cross = cross[cross >= 1]
        self.crossings = int(s.crossings.size)
        self.crossing_ratio = float(np.max(ratio[cross - 1])) if cross.size else 0.0

    # -- companion topics -------------------------------------------------------------------------------------
    def topic_checks(self, c: Columns, samples: NDArray[np.int64]) -> None:
        tol = self.tol
        stamps = _stamp_ns(c)
        frames = c['header.frame_id']
        pos = _vec(c, 'pose.position')
        quat = _vec(c, 'pose.orientation', 'xyzw')
        npos = _vec(c, 'nominal_pose.position')
        nquat = _vec(c, 'nominal_pose.orientation', 'xyzw')
        for name, p, qq in (('/gpr/platform_pose', pos, quat), ('/gpr/nominal_pose', npos, nquat)):
            t = self.bag.topic(name)
            check = f'topic.{name.rsplit("/", 1)[-1]}'
            if t is None or t.msgtype != GPR_TOPICS[name]:
                self.checks.append(Check(check, name, 0, 0.0, tol.consistency, 'm|rad',
                                         skipped='topic not in the bag'))
                continue
            pc = t.columns()
            err = self._match(pc, stamps, frames)
            ok = err >= 0
            j = err[ok]
            e = self._missing(stamps, _stamp_ns(pc))
            e[ok] = np.maximum(np.max(np.abs(_vec(pc, 'pose.position')[j] - p[ok]), axis=1),
                               np.max(np.abs(_vec(pc, 'pose.orientation', 'xyzw')[j] - qq[ok]), axis=1))
            self.checks.append(_check(check, name, e, tol.consistency, 'm|rad', samples,
                                      'inf = no message with the stamp and frame of this PlatformState'))
            self._extra(check, name, _stamp_ns(pc), stamps, ok)
        name = '/gpr/joint_states'
        t = self.bag.topic(name)
        if t is None or t.msgtype != GPR_TOPICS[name]:
            self.checks.append(Check('topic.joint_states', name, 0, 0.0, tol.consistency, 'm|rad',
                                     skipped='topic not in the bag'))
            return
        jc = t.columns()
        idx = self._match(jc, stamps, frames)
        ok = idx >= 0
        s = self.series
        assert s is not None
        vj = _matrix(c['virtual_joints'], s.virtual_joints.shape[1]) if s.virtual_joints.shape[1] else np.zeros(
            (len(stamps), 0))
        full = np.concatenate([s.q, vj], axis=1)
        got = _matrix(jc['position'])
        e = self._missing(stamps, _stamp_ns(jc))
        names = jc['name']
        vnames = c['virtual_joint_names']
        for r in np.flatnonzero(ok):
            # The physical joints only (rod_1..rod_3, the stream since the virtual joints got their own topic), or
            # rods + virtual joints (bags recorded before).
            n, width = tuple(names[idx[r]]), len(ROD_NAMES)
            if n != ROD_NAMES:
                width = full.shape[1] if n == ROD_NAMES + tuple(vnames[r]) else -1
            row = got[idx[r]]
            e[r] = (np.max(np.abs(row[:width] - full[r, :width]), initial=0.0)
                    if width >= 0 and np.count_nonzero(~np.isnan(row)) == width else np.inf)
        self.checks.append(_check('topic.joint_states', name, e, tol.consistency, 'm|rad', samples,
                                  'inf = missing, or names not rod_1..rod_3 (+ the virtual joints)'))
        self._extra('topic.joint_states', name, _stamp_ns(jc), stamps, ok)

    @staticmethod
    def _match(pc: Columns, stamps: NDArray[np.int64], frames: NDArray[np.object_]) -> NDArray[np.int64]:
        """Index of the companion message with each PlatformState's stamp and frame, -1 if none."""
        ps = _stamp_ns(pc)
        order = np.argsort(ps, kind='stable')
        sorted_ps = ps[order]
        pos = np.searchsorted(sorted_ps, stamps)
        pos = np.clip(pos, 0, max(len(ps) - 1, 0))
        out = np.full(len(stamps), -1, dtype=np.int64)
        if len(ps) == 0:
            return out
        hit = sorted_ps[pos] == stamps
        cand = order[pos]
        pframes = pc['header.frame_id']
        same = np.array([pframes[j] == frames[i] for i, j in enumerate(cand)], dtype=bool) if len(cand) else hit
        out[hit & same] = cand[hit & same]
        return out

    @staticmethod
    def _missing(stamps: NDArray[np.int64], companion: NDArray[np.int64]) -> NDArray[np.float64]:
        """Initial error per PlatformState: inf (missing) inside the companion topic's span of stamps, 0 before
        its first or after its last message: a recording started or cut (SIGKILL) in the middle of a sample
        holds part of that sample's messages only."""
        e = np.full(len(stamps), np.inf)
        if len(companion):
            e[(stamps < companion.min()) | (stamps > companion.max())] = 0.0
        return e

    def _extra(self, check: str, topic: str, companion: NDArray[np.int64], stamps: NDArray[np.int64],
               matched: NDArray[np.bool_]) -> None:
        """Companion messages without a PlatformState of the same stamp (inside the states' span)."""
        inside = (companion >= stamps.min()) & (companion <= stamps.max()) if len(stamps) else companion < 0
        total = int(np.count_nonzero(inside))
        if total > int(matched.sum()):
            extra = total - int(matched.sum())
            self.checks.append(Check(f'{check}_extra', topic, total, float(extra), 0.0, 'messages', 1, [
                Failure(f'{check}_extra', topic, None, float(extra), 0.0,
                        'messages without a PlatformState of the same stamp')]))


def verify_bag(bag: Bag | str | Path, config: GprConfig | None = None,
               tolerances: Tolerances | None = None) -> VerifyResult:
    """Verify a bag (a path or an already read :class:`Bag`); see the module docstring for the checks.

    Raises:
        BagError: the bag cannot be read.
    """
    t0 = time.perf_counter()
    if not isinstance(bag, Bag):
        bag = read_bag(bag)
    t_read = time.perf_counter() - t0
    cfg = resolve_config(config)
    v = _Verifier(bag, cfg, tolerances or Tolerances())
    try:
        v.run()
    except GprError:
        raise
    elapsed = time.perf_counter() - t0
    return VerifyResult(path=str(bag.path), storage=bag.storage, files=bag.files,
                        counts={k: len(t) for k, t in bag.topics.items()}, checks=v.checks, series=v.series,
                        crossings=v.crossings, crossing_ratio=v.crossing_ratio, elapsed=elapsed, read_time=t_read,
                        unfinished=bag.unfinished, config=cfg.to_dict())


def format_table(result: VerifyResult) -> str:
    """The verification table for stdout: one line per check, the failures, and a verdict."""
    lines = [f'bag {result.path} ({result.storage}, {len(result.files)} file(s)): '
             + ', '.join(f'{k} {v}' for k, v in result.counts.items())]
    if result.unfinished:
        lines.append(f'note: unfinished segment(s) of a killed recorder, not read: {", ".join(result.unfinished)}')
    lines.append(f'{"check":28s} {"topic":22s} {"status":6s} {"checked":>8s} {"worst":>12s} {"limit":>12s} unit')
    for c in result.checks:
        worst = '-' if c.skipped else f'{c.worst:.3e}'
        lines.append(f'{c.name:28s} {c.topic:22s} {c.status:6s} {c.checked:8d} {worst:>12s} {c.limit:12.3e} '
                     f'{c.unit}{"  (" + c.skipped + ")" if c.skipped else ""}'
                     f'{f"  {c.failed} failed" if c.failed else ""}')
    lines.append(f'singular crossings: {result.crossings}, largest jump ratio at a crossing: '
                 f'{result.crossing_ratio:.3f} (bound 1)')
    for f in result.failures:
        lines.append(f.line())
    n = sum(result.counts.values())
    rate = n / result.elapsed if result.elapsed > 0 else float('inf')
    verdict = 'PASSED' if result.passed else f'FAILED ({sum(c.failed for c in result.checks)} failure(s))'
    lines.append(f'verification {verdict}: {n} messages in {result.elapsed:.3f} s ({rate:,.0f} messages/s)')
    return '\n'.join(lines)

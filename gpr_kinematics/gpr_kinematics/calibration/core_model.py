"""The binding of the calibration engines to the kinematics core: a :class:`~.model.PoseModel` whose poses are
:func:`gpr_kinematics.core.forward_batch` with the geometry parameters of each row, and the calibrated
geometry file.

The parameters are the 24 scalars of the geometry file, :data:`gpr_kinematics.core.parameters.PARAMETERS`: per rod its
base point ``rodK_x``, ``rodK_y`` [m], zero offset ``rodK_offset`` [m] and direction ``rodK_ux``, ``rodK_uy`` [rad], per
joint its place on the platform ``jointK_x``, ``jointK_y`` [m] and stiffness ratio ``kappaK``, identified as its
anisotropy ``(kappa - 1) / (kappa + 1)`` (:class:`~.model.Parameter`). Every parameter row of a call is one machine of
the core's per-row batch (``forward_batch(..., parameters=...)``): the ``2 P`` perturbed machines of a Jacobian and the
samples of a Monte Carlo budget are one call. A joint's play (a displacement ``d`` of its centre ``P_k`` in
``gpr_base``) goes to the core as well (``forward_batch(..., displacement=...)``).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import ForwardBatch, forward_batch
from ..core.config import GprConfig
from ..core.forward import TILT_LIMIT_SLACK, tilt_words
from ..core.geometry_covariance import BASE_NAMES, KEY, GeometryCovariance, RegisteredBase, parse_covariance
from ..core.machine import MachineGeometry, config_with_parameters, parameter_vector
from ..core.naive import centres_tilt
from ..core.ops import ARRAY
from ..core.parameters import PARAMETER_NAMES, PARAMETERS
from ..core.stroke import stroke_words
from ..core.virtual_joints import model_name
from ..errors import ConfigError, InputError, brief
from ..inputs import safe_yaml
from .files import comment_lines, write_text
from .measurements import Measurements
from .model import Parameter, ParameterSet, PoseModel, coordinate_of
from .results import CalibrationResult

Array = NDArray[np.float64]

#: A measured configuration may tilt the platform this factor beyond the tilt limit (a pose measured at the
#: limit, rounding of the commanded rod lengths).
TILT_MARGIN = 1.05

#: A-priori standard uncertainty of the parameters of each configuration key (the scale of
#: :class:`~.model.Parameter`): 0.1 mm for lengths, 1 mrad for the rod directions, 0.5 for a joint's anisotropy
#: (of its range -1 .. 1: the stiffness ratio is not known before measuring).
SCALES: dict[str, float] = {'rod_positions': 1e-4, 'rod_offsets': 1e-4, 'rod_directions': 1e-3,
                            'platform_joints': 1e-4, 'kappa': 0.5}

#: The virtual-joint model of calibration and budgets unless one is named.
MODEL = 'compliant'

def geometry_parameters(config: GprConfig, scales: Mapping[str, float] | None = None) -> ParameterSet:
    """The parameters of :data:`~gpr_kinematics.core.parameters.PARAMETERS` at ``config``'s values; ``scales`` overrides
    the scale of a configuration key (:data:`SCALES`) or of one parameter by its name."""
    scales = dict(scales or {})
    unknown = sorted(set(scales) - set(SCALES) - set(PARAMETER_NAMES))
    if unknown:
        raise InputError(f'scales: unknown key(s) {", ".join(unknown)}; allowed: {", ".join(SCALES)} or a '
                         'parameter name')
    out = []
    for gp, value in zip(PARAMETERS, parameter_vector(config).tolist(), strict=True):
        scale = float(scales.get(gp.name, scales.get(gp.key, SCALES[gp.key])))
        index = (gp.rod,) if gp.key in ('rod_offsets', 'kappa') else (gp.rod, gp.component)
        transform = 'anisotropy' if gp.key == 'kappa' else ''
        out.append(Parameter(gp.name, float(coordinate_of(transform, value)), gp.unit, scale, gp.key, index,
                             transform, value if transform else None))
    return ParameterSet(tuple(out))


class CoreModel:
    """Poses of the core's forward kinematics with the geometry parameters of :func:`geometry_parameters`.

    Args:
        config: the nominal geometry and every other setting (stroke, solver).
        model: virtual-joint model (default :data:`MODEL`, ``compliant``: the physical model, in which ``kappa``
            acts; with the default ``kappa`` 1000 it is the ``radial`` model within 0.2 %).
        scales: a-priori uncertainties (:func:`geometry_parameters`).

    No limit checks (a measured pose may sit at the tilt limit); a parameter row outside the geometry's ranges
    raises :class:`InputError` (:meth:`~gpr_kinematics.core.machine.MachineGeometry.per_row`).
    """

    supports_displacement = True

    def __init__(self, config: GprConfig, model: str | None = None,
                 scales: Mapping[str, float] | None = None) -> None:
        if not isinstance(config, GprConfig):
            raise InputError(f'config = {brief(config)}; allowed: a GprConfig (load_config, default_config)')
        self.config = config
        self.model = MODEL if model is None or isinstance(model, str) and not model else model_name(config, model)
        self._parameters = geometry_parameters(config, scales)

    @property
    def parameters(self) -> ParameterSet:
        return self._parameters

    def datum(self, base: bool, target: str | None, free: NDArray[np.bool_] | None = None
              ) -> tuple[Array, tuple[str, ...], str]:
        """The conditions that define ``gpr_base`` and ``gpr_platform`` when a registration identifies those frames
        too (:mod:`.frames`): a common shift, turn or tilt of the rods is a motion of ``gpr_base``, a common shift
        or turn of the joints one of the target on the platform, so the frames are fixed by the machine itself.
        ``gpr_base`` (``base``): its origin at the rods' mean base point, its height at their mean zero offset,
        its z axis along their mean direction, its heading at their mean angular place; ``gpr_platform``: its origin
        at the joints' centroid (an identified ``target``: ``pose``, ``position`` or ``points``) and its heading at
        their mean angular place (a common turn of the joints turns the platform: it trades with the heading of an
        identified base or target pose; a target of known orientation measured in a known ``gpr_base`` sees it).

        Only conditions on parameters that are all ``free`` (a mask; default all) apply: fixed rods or joints fix
        the frame themselves. Returns ``(C, dependent, text)``: the linear conditions ``C (theta - nominal) = 0``
        on the coordinates ``(m, P)``, the ``m`` parameters that follow from the others, and the conditions in
        words."""
        ps = self._parameters
        is_free = np.ones(len(ps), dtype=bool) if free is None else np.asarray(free, dtype=bool)
        values = ps.values(ps.nominal)
        rows: list[Array] = []
        dependent: list[str] = []
        words: list[str] = []

        def condition(coef: dict[str, float], follows: str) -> None:
            if not all(is_free[ps.index(name)] for name in coef):
                return
            row = np.zeros(len(ps))
            for name, c in coef.items():
                row[ps.index(name)] = c
            rows.append(row)
            dependent.append(follows)

        def groups(stem: str, what: str, turn: bool, shift: bool = True) -> None:
            for c in 'xy' if shift else '':
                condition({f'{stem}{k}_{c}': 1.0 for k in (1, 2, 3)}, f'{stem}3_{c}')
            if turn:   # sum of x dy - y dx: no common turn about the centre
                xy = {k: (values[ps.index(f'{stem}{k}_x')], values[ps.index(f'{stem}{k}_y')]) for k in (1, 2, 3)}
                d = np.subtract(xy[2], xy[3])
                condition({f'{stem}{k}_{c}': (-xy[k][1] if c == 'x' else xy[k][0]) for k in (1, 2, 3) for c in 'xy'},
                          f'{stem}2_x' if abs(d[1]) >= abs(d[0]) else f'{stem}2_y')
            if dependent and dependent[-1].startswith(stem):
                words.append(what)

        if base:
            groups('rod', 'gpr_base at the rods\' mean base point and mean angular place', True)
            condition({f'rod{k}_offset': 1.0 for k in (1, 2, 3)}, 'rod3_offset')
            for c in ('ux', 'uy'):
                condition({f'rod{k}_{c}': 1.0 for k in (1, 2, 3)}, f'rod3_{c}')
            if any(d.startswith('rod3_o') or d.startswith('rod3_u') for d in dependent):
                words.append('its height at the rods\' mean zero offset, its z axis along their mean direction')
        turn = base or target in ('pose', 'points')
        if target is not None or turn:
            groups('joint', 'gpr_platform' + (' at the joints\' centroid' if target is not None else '')
                   + (' and' if target is not None and turn else '') + (' at their mean angular place' if turn else ''),
                   turn, target is not None)
        return np.array(rows).reshape(-1, len(ps)), tuple(dependent), '; '.join(words)

    def joints_on_rods(self, theta: Array, conditions: Array | None = None) -> Array:
        """Coordinate rows ``theta (S, P)`` with every platform joint where the design puts it relative to its rod,
        ``p_k = p_k0 + (B_k - B_k0)`` (the nominal machine has ``p_k = B_k``): the joint triangle congruent with the
        rods' (a machine millimetres off its drawing, e.g. of another radius, keeps it so).

        ``conditions``: a registration's datum ``C (m, P)`` (:meth:`datum`, ``C (theta - nominal) = 0``); its rows
        on the joints (their centroid, their mean angular place) then hold too: the triangle moved in the platform's
        plane by the least rigid motion ``T a`` (shifts in x and y, the turn ``(-y_k0, x_k0)`` to first order) that
        makes them hold, ``a = -(C_J T)^+ C_J dp``; its sides change by ``a_turn^2 / 2`` of themselves."""
        ps = self._parameters
        out = np.array(theta, dtype=float)
        joints = [ps.index(f'joint{k}_{c}') for k in (1, 2, 3) for c in 'xy']
        for j in joints:
            r = ps.index('rod' + ps[j].name[5:])
            out[..., j] = ps.nominal[j] + (out[..., r] - ps.nominal[r])
        C = np.zeros((0, len(ps))) if conditions is None else np.asarray(conditions, dtype=float)
        C = C[np.any(C[:, joints] != 0.0, axis=1)][:, joints]
        if C.size:
            x0, y0 = ps.nominal[joints[0::2]], ps.nominal[joints[1::2]]
            T = np.zeros((6, 3))
            T[0::2, 0], T[1::2, 1], T[0::2, 2], T[1::2, 2] = 1.0, 1.0, -y0, x0
            dp = out[..., joints] - ps.nominal[joints]
            a = -np.einsum('ij,...j->...i', np.linalg.pinv(C @ T), dp @ C.T)
            out[..., joints] += np.einsum('ij,...j->...i', T, a)
        return out

    def side_mismatch(self, theta: Array) -> float:
        """The largest difference of a side of the joint triangle from the rods' at coordinates ``theta (P,)``,
        as a fraction of the rods' (a geometry allows :data:`~gpr_kinematics.core.config.MAX_SIDE_MISMATCH`)."""
        ps = self._parameters
        th = np.asarray(theta, dtype=float)

        def sides(stem: str) -> Array:
            xy = np.array([[th[ps.index(f'{stem}{k}_{c}')] for c in 'xy'] for k in (1, 2, 3)])
            return np.asarray(np.linalg.norm(xy - np.roll(xy, -1, axis=0), axis=1), dtype=np.float64)

        rods = sides('rod')
        return float(np.max(np.abs(sides('joint') - rods) / rods))

    def config_for(self, theta: Any) -> GprConfig:
        """The configuration of the parameter coordinates ``theta (P,)``, with this model (validated): the
        calibrated geometry file's content."""
        values = self._parameters.values(np.asarray(theta, dtype=float))
        return config_with_parameters(self.config.replace(model=self.model), values)

    def poses(self, theta: Array, Q: Array, displacement: Array | None = None) -> tuple[Array, Array]:
        S, N = Q.shape[0], Q.shape[1]
        values = self._parameters.values(theta)                      # (S, 24), one machine per row
        d = None if displacement is None else displacement.reshape(S * N, 3, 3)
        fk = forward_batch(Q.reshape(-1, 3), self.config, self.model, check_limits=False, parameters=values,
                           displacement=d)
        return fk.position.reshape(S, N, 3), fk.rotation.reshape(S, N, 3, 3)


def platform_tilts(q: Array, config: GprConfig) -> Array:
    """The tilts [rad] of the plane of the joint centres ``P_k`` at the rods ``q (N, 3)`` [m], which every
    virtual-joint model shares: what :func:`check_limits` and the accuracy budget bound by :data:`TILT_MARGIN` times
    the tilt limit (:func:`~gpr_kinematics.core.naive.centres_tilt`, forward kinematics' check on leaning rods)."""
    Q = np.asarray(q, dtype=float)
    return np.asarray(centres_tilt(ARRAY, MachineGeometry.of(config), [Q[:, 0], Q[:, 1], Q[:, 2]]), dtype=float)


def check_limits(meas: Measurements, config: GprConfig) -> None:
    """Refuse measured configurations outside the machine's limits, naming the line and the column: a rod length
    outside the stroke, or rod lengths that tilt the platform beyond the tilt limit (the tilt of the plane of the
    joint centres ``P_k``, which every virtual-joint model shares) by more than :data:`TILT_MARGIN`."""
    lo, hi = config.stroke_min, config.stroke_max
    outside = np.argwhere((meas.q < lo) | (meas.q > hi))
    if outside.size:
        i, k = outside[0]
        mm = meas.units[0] == 'm' and meas.q[i, k] > hi   # above the stroke: in mm? (not below: -1e-9 m was told)
        hint = f' (millimetres? declare "# units: mm" or write "q{k + 1} [mm]")' if mm else ''
        shown, ends = stroke_words(float(meas.q[i, k]), lo, hi)
        raise InputError(f'{meas.where(int(i))}, column q{k + 1}: {shown} m is outside the stroke {ends} m{hint}')
    tilt = platform_tilts(meas.q, config)
    bad = np.flatnonzero(tilt > TILT_MARGIN * config.tilt_limit)
    if bad.size:
        i = int(bad[0])
        raise InputError(f'{meas.where(i)}, columns q1 q2 q3: the rod lengths tilt the platform by '
                         f'{tilt[i]:.4g} rad ({np.degrees(tilt[i]):.4g} deg), beyond the tilt limit '
                         f'{config.tilt_limit:.4g} rad ({np.degrees(config.tilt_limit):.4g} deg); allowed: at most '
                         f'{100 * (TILT_MARGIN - 1):.0f} % beyond it, {TILT_MARGIN * config.tilt_limit:.4g} rad (a '
                         'pose measured at the limit of a machine that tilts a little more than its nominal one)')


def measured_forward(config: GprConfig, q: Array) -> ForwardBatch:
    """The forward kinematics of the calibrated machine ``config`` at the measured rods ``q (N, 3)`` [m], the limits
    unchecked: what :func:`beyond_budget` and :func:`refused_rows` judge (computed once for both)."""
    return forward_batch(q, config, check_limits=False)


def beyond_budget(config: GprConfig, q: Array, fk: ForwardBatch | None = None) -> tuple[str, ...]:
    """A warning where the calibrated machine ``config`` displaces its joints at the measured rods ``q (N, 3)`` [m]
    beyond its ``imperfection_budget`` (the largest |joint displacement| of its forward kinematics ``fk``, computed
    when not given: :func:`measured_forward`): its recordings then fail ``gpr verify``'s ``state.imperfection_budget``
    and ``forward`` says ``within_budget: false``, with nothing at calibration time to say why."""
    fk = measured_forward(config, q) if fk is None else fk
    worst = float(np.max(np.abs(fk.joint_displacement), initial=0.0))
    if not worst > config.imperfection_budget:
        return ()
    return (f'the calibrated machine displaces its joints by up to {1e3 * worst:.4g} mm at the measured poses, beyond '
            f'its imperfection_budget of {1e3 * config.imperfection_budget:.4g} mm: its recordings fail gpr verify\'s '
            'state.imperfection_budget and forward reports within_budget: false there; raise imperfection_budget in '
            'the written file if this machine is right',)


#: The measured rows a warning names before ``and N more``.
ROWS_SHOWN = 5


def refused_rows(config: GprConfig, meas: Measurements, fk: ForwardBatch | None = None) -> tuple[str, ...]:
    """A warning where the forward kinematics of the calibrated machine ``config`` refuses measured rows: the rods
    ``meas.q`` tilt it beyond its ``tilt_limit`` (:func:`check_limits` let them be up to :data:`TILT_MARGIN` beyond
    the limit, and a machine of larger zero offsets tilts more than its nominal one), or its closure finds no pose
    there. ``gpr fk --config`` of the written file then exits 2 at configurations the machine was measured at. The
    stroke is the one :func:`check_limits` held the rows to (a calibration does not change it). The rows are named by
    their file lines (the first :data:`ROWS_SHOWN`, then how many more), with what to do; ``tilt_limit`` is not
    changed here: it is the machine's limit, not the fit's. ``fk``: :func:`measured_forward`, computed when not given.
    (Forward kinematics without the limits raises where its closure fails, rather than giving NaN: the rows without a
    pose are named apart should a NaN tilt come, a guard.)"""
    fk = measured_forward(config, meas.q) if fk is None else fk
    tilt = np.asarray(fk.tilt, dtype=float)
    bad = np.flatnonzero(~(tilt <= config.tilt_limit + TILT_LIMIT_SLACK))    # NaN too: no pose
    if not bad.size:
        return ()
    def rows(which: np.ndarray) -> str:
        more = f' and {which.size - ROWS_SHOWN} more' if which.size > ROWS_SHOWN else ''
        return f'{meas.source}: {", ".join(meas.row_names[int(i)] for i in which[:ROWS_SHOWN])}{more}'
    tilted, lost = bad[np.isfinite(tilt[bad])], bad[~np.isfinite(tilt[bad])]
    out = []
    if tilted.size:
        worst = float(np.max(tilt[tilted]))
        shown, limit = tilt_words(worst, config.tilt_limit)
        out.append(f'the calibrated machine tilts its platform beyond its tilt_limit of {limit} at {tilted.size} of '
                   f'the {len(meas)} measured rows ({rows(tilted)}; up to {shown}), which calibrate took (it takes '
                   f'rows up to {100 * (TILT_MARGIN - 1):.0f} % beyond the tilt limit of the given geometry): forward '
                   'kinematics with the written file (gpr fk --config) refuses them (beyond the tilt limit); raise '
                   f'tilt_limit in the written file to at least {math.ceil(worst * 1e6) / 1e6:g} rad if this machine '
                   'is right and tilts so far, or measure within the limit')
    if lost.size:   # no tilt_limit helps these: the written geometry has no pose there
        out.append(f'the calibrated machine has no platform pose at {lost.size} of the {len(meas)} measured rows '
                   f'({rows(lost)}): forward kinematics with the written file (gpr fk --config) refuses them; check '
                   'those rows (their rods) or measure again')
    return tuple(out)


def fitted_covariance(model: PoseModel, res: CalibrationResult, frame: str = '') -> GeometryCovariance | None:
    """The covariance of the geometry parameters the fit ``res`` of ``model`` (a :class:`CoreModel`, or one in a
    measuring frame) determined, in their coordinates (SI, a ``kappaK`` as its anisotropy): ``M C M^T`` with ``M``
    the linear map from the fitted coordinates to the geometry's (``inner_theta``: a datum's dependent parameters
    follow the fitted ones); with ``gpr_base`` identified in ``frame`` (its six coordinates fitted), its pose
    and its :data:`~gpr_kinematics.core.geometry_covariance.BASE_NAMES` after them (``base_steps``: the rotation as a
    turn about the frame's axes), the target's left out. ``None`` without a finite one, or one the file's loader
    would refuse."""
    C = np.asarray(res.covariance, dtype=float)
    if res.fitted.size == 0 or C.shape != (res.fitted.size,) * 2 or not np.all(np.isfinite(C)):
        return None
    inner_theta = getattr(model, 'inner_theta', None)
    inner: PoseModel = getattr(model, 'inner', model)
    theta = np.asarray(res.estimate, dtype=float)
    rows = np.repeat(theta[None], res.fitted.size + 1, axis=0)
    rows[np.arange(1, res.fitted.size + 1), res.fitted] += 1.0      # unit steps of a linear map: exact
    geometry = inner_theta(rows) if callable(inner_theta) else rows
    M = (geometry[1:] - geometry[0]).T                               # (P_inner, F)
    keep = np.flatnonzero(np.any(M != 0.0, axis=1))
    if keep.size == 0:
        return None
    names, M, base = tuple(inner.parameters[int(j)].name for j in keep), M[keep], None
    steps, frames = getattr(model, 'base_steps', None), getattr(model, 'frames', None)
    if frame and getattr(model, 'fit_base', False) and callable(steps) and callable(frames):
        S = steps(theta)[:, res.fitted]
        if np.all(np.any(S != 0.0, axis=1)):   # all six fitted: a held one has no covariance to give
            pose = frames(theta)[0]
            names, M = names + BASE_NAMES, np.vstack([M, S])
            base = RegisteredBase(frame, tuple(float(v) for v in (*pose.position, *pose.rpy)))
    out = M @ C @ M.T
    cov = GeometryCovariance(names, 0.5 * (out + out.T), base=base)
    try:   # only a block every loader takes is written (a fit forced through its gate may be that poor)
        return parse_covariance(cov.as_block(), 'the fit')
    except ConfigError:
        return None


def calibrated_config_text(config: GprConfig, comments: tuple[str, ...] = (),
                           covariance: GeometryCovariance | None = None) -> str:
    """YAML text of every key of ``config`` (the schema of ``config/gpr.yaml``), floats at full precision;
    ``characteristic_length`` is written ``null`` when it follows the radius; ``covariance`` the block of the fitted
    parameters' covariance (:mod:`gpr_kinematics.core.geometry_covariance`). ``comments`` head the file."""
    values = config.to_dict()
    if config.characteristic_length == config.radius:
        values['characteristic_length'] = None
    if covariance is not None:
        values[KEY] = covariance.as_block()
    body = safe_yaml.dump(values, sort_keys=False, default_flow_style=None)
    return comment_lines(comments) + body


def write_calibrated_config(path: str | Path, config: GprConfig, comments: tuple[str, ...] = (),
                            covariance: GeometryCovariance | None = None) -> Path:
    """Write :func:`calibrated_config_text` to ``path`` atomically (a file every command takes with ``--config``)."""
    return write_text(path, calibrated_config_text(config, comments, covariance), 'calibrated geometry')

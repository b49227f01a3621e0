"""The binding of the calibration engines to the kinematics core: a :class:`~.model.PoseModel` whose poses are
:func:`gpr_kinematics.kinematics.forward_batch` of a :class:`~gpr_kinematics.config.GprConfig` with the
parameters written in, and the calibrated geometry file.

The parameters are the geometric keys of the configuration file: today ``radius`` and the three
``rod_azimuths`` (``rod_azimuth1..3``); the platform's joints share them (the core's geometry is one circle).
Each key the core gains (per-rod base positions, zero offsets, rod directions, platform joints, ``kappa``)
becomes parameters here by a line in :data:`GEOMETRY_KEYS`, and the engines need nothing else.
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from ..config import GprConfig
from ..errors import InputError
from ..kinematics import base_points, forward_batch
from .files import comment_lines, write_text
from .measurements import Measurements
from .model import Parameter, ParameterSet, config_values

Array = NDArray[np.float64]

#: A measured configuration may tilt the platform this factor beyond the tilt limit (a pose measured at the
#: limit, rounding of the commanded rod lengths).
TILT_MARGIN = 1.05

#: Configuration keys calibrated, with unit and a-priori uncertainty (the scale of :class:`~.model.Parameter`):
#: 0.1 mm for lengths, 1 mrad for angles. Per-element names for list-valued keys.
GEOMETRY_KEYS: dict[str, tuple[str, float, tuple[str, ...]]] = {
    'radius': ('m', 1e-4, ()),
    'rod_azimuths': ('rad', 1e-3, ('rod_azimuth1', 'rod_azimuth2', 'rod_azimuth3')),
}


def geometry_parameters(config: GprConfig, scales: Mapping[str, float] | None = None) -> ParameterSet:
    """The parameters of :data:`GEOMETRY_KEYS` at ``config``'s values (``scales`` overrides a key's scale)."""
    values = config.to_dict()
    out = []
    for key, (unit, scale, names) in GEOMETRY_KEYS.items():
        scale = float((scales or {}).get(key, scale))
        if not names:
            out.append(Parameter(key, float(values[key]), unit, scale, key))
        for i, name in enumerate(names):
            out.append(Parameter(name, float(values[key][i]), unit, scale, key, (i,)))
    return ParameterSet(tuple(out))


class CoreModel:
    """Poses of the core's forward kinematics with the geometry parameters of :func:`geometry_parameters`.

    Args:
        config: the nominal geometry and every other setting (virtual-joint model, solver).
        model: virtual-joint model name (default: ``config.model``).

    Each parameter row is a validated :class:`GprConfig` (``config.replace``) and one ``forward_batch`` call
    over its configurations (no limit checks: a measured pose may sit at the tilt limit). Distinct rows are
    evaluated one after another: the core's batch kernels take one geometry per call.
    """

    supports_displacement = False

    def __init__(self, config: GprConfig, model: str | None = None,
                 scales: Mapping[str, float] | None = None) -> None:
        self.config = config
        self.model = model
        self._parameters = geometry_parameters(config, scales)

    @property
    def parameters(self) -> ParameterSet:
        return self._parameters

    def config_for(self, theta: Any) -> GprConfig:
        """The configuration with the parameter values ``theta`` (P,) written in (validated)."""
        return self.config.replace(**config_values(self._parameters, theta, self.config.to_dict()))

    def poses(self, theta: Array, Q: Array, displacement: Array | None = None) -> tuple[Array, Array]:
        S, N = Q.shape[0], Q.shape[1]
        pos = np.empty((S, N, 3))
        rot = np.empty((S, N, 3, 3))
        # One forward_batch per distinct parameter row, over all its configurations (rod-length errors alone
        # leave theta equal in every row: then one call does everything).
        rows, inverse = np.unique(theta, axis=0, return_inverse=True)
        for r in range(rows.shape[0]):
            sel = np.flatnonzero(inverse.ravel() == r)
            fk = forward_batch(Q[sel].reshape(-1, 3), self.config_for(rows[r]), self.model, check_limits=False)
            pos[sel] = fk.position.reshape(sel.size, N, 3)
            rot[sel] = fk.rotation.reshape(sel.size, N, 3, 3)
        return pos, rot


def check_limits(meas: Measurements, config: GprConfig) -> None:
    """Refuse measured configurations outside the machine's limits, naming the line and the column: a rod length
    outside the stroke, or rod lengths that tilt the platform beyond the tilt limit (the tilt of the plane of the
    joint centres ``P_k``, which every virtual-joint model shares) by more than :data:`TILT_MARGIN`."""
    lo, hi = config.stroke_min, config.stroke_max
    outside = np.argwhere((meas.q < lo) | (meas.q > hi))
    if outside.size:
        i, k = outside[0]
        raise InputError(f'{meas.where(int(i))}, column q{k + 1}: {meas.q[i, k]:.9g} m is outside the stroke '
                         f'[{lo:g}, {hi:g}] m (millimetres? declare "# units: mm")')
    P = base_points(meas.q, config)
    n = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    tilt = np.arctan2(np.hypot(n[:, 0], n[:, 1]), n[:, 2])
    bad = np.flatnonzero(tilt > TILT_MARGIN * config.tilt_limit)
    if bad.size:
        i = int(bad[0])
        raise InputError(f'{meas.where(i)}, columns q1 q2 q3: the rod lengths tilt the platform by '
                         f'{np.degrees(tilt[i]):.4g} deg, beyond the tilt limit '
                         f'{np.degrees(config.tilt_limit):.4g} deg')


def calibrated_config_text(config: GprConfig, comments: tuple[str, ...] = ()) -> str:
    """YAML text of every key of ``config`` (the schema of ``config/gpr.yaml``), floats at full precision;
    ``characteristic_length`` is written ``null`` when it follows the radius. ``comments`` head the file."""
    values = config.to_dict()
    if config.characteristic_length == config.radius:
        values['characteristic_length'] = None
    body = yaml.safe_dump(values, sort_keys=False, default_flow_style=None)
    return comment_lines(comments) + body


def write_calibrated_config(path: str | Path, config: GprConfig, comments: tuple[str, ...] = ()) -> Path:
    """Write :func:`calibrated_config_text` to ``path`` atomically (a file every command takes with ``--config``)."""
    return write_text(path, calibrated_config_text(config, comments), 'calibrated geometry')

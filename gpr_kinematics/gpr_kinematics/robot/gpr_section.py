"""A robot description's ``gpr`` section: the GPR's geometry (a geometry file, keys of that file inline on top of it)
and the covariance of its calibrated parameters where it has one (docs/calibration.md, "The arms")::

    gpr: {config: cell/gpr.yaml, model: radial}   # a file gpr calibrate wrote: its covariance block comes along
    gpr: {config: null, rod_offsets: [...], ..., covariance: {names: [...], matrix: [...]}}   # inline, as gpr
                                                  # calibrate --robot writes a calibrated robot

A file's covariance describes that file's values: a section setting one of the keys they are made of
(:data:`~gpr_kinematics.core.parameters.PARAMETER_KEYS`) on top of it leaves the covariance out (the arms' standard
errors then take the GPR as exact); an inline ``covariance`` describes the section's geometry as written.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..core.config import GprConfig, load_config
from ..core.geometry_covariance import KEY, GeometryCovariance, load_covariance, parse_covariance
from ..core.parameters import PARAMETER_KEYS
from ..errors import ConfigError, brief
from ..inputs.schema import check_keys
from .fields import _mapping


@dataclass(frozen=True)
class GprSection:
    """What a ``gpr`` section says of its geometry's calibration: the covariance of its calibrated parameters (None:
    none, or ``left``), and why a covariance block of the file it names was left out (``''``: none was)."""

    covariance: GeometryCovariance | None = None
    left: str = ''


def load_gpr_section(raw: Any, source: str, base_dir: Path) -> tuple[GprConfig, GprSection]:
    """The ``gpr`` section ``raw`` of the description ``source`` (a file named relative to ``base_dir``): its
    geometry and the covariance that goes with it (module docstring), or :class:`ConfigError` naming the section's
    key."""
    where = f'{source}: gpr'
    data = _mapping(raw if raw is not None else {}, where, 'config (a geometry file), geometry keys and covariance')
    check_keys(data, ('config', KEY, *(f.name for f in dataclasses.fields(GprConfig))), where)
    path = data.get('config')
    if path is not None and not (isinstance(path, str) and path):   # '' would name the robot's own folder
        raise ConfigError(f'{where}: config = {brief(path)} is invalid; allowed: a path to a geometry YAML file or '
                          'null (the package\'s)')
    overrides = {k: v for k, v in data.items() if k not in ('config', KEY)}
    file = None if path is None else (base_dir / path if not Path(path).is_absolute() else Path(path))
    try:  # the section's keys named by the section ('rt.yaml: gpr: unknown key(s) modle', not 'gpr: overrides:')
        config = load_config(file, overrides or None, where)
        if KEY in data:
            return config, GprSection(dataclasses.replace(parse_covariance(data[KEY], where), source=source,
                                                          section='gpr'))
        cov = None if file is None else load_covariance(file)
        keys = sorted(PARAMETER_KEYS & overrides.keys())
        if cov is not None and keys:
            return config, GprSection(None, f'the covariance block of {file} is left out: the robot\'s gpr section '
                                            f'sets {", ".join(keys)} on top of that file (the block describes its '
                                            'values)')
        return config, GprSection(cov)
    except ConfigError as exc:
        message = str(exc)
        raise ConfigError(message if message.startswith(where) else f'{where}: {message}') from None

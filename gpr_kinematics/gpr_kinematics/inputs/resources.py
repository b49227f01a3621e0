"""Locate the package's data files (``config/``) in a source tree or an installed prefix.

The YAML files live in ``config/`` of the ROS package folder (``gpr_kinematics/config`` in the repository), beside
the Python package, and are installed by ``setup.py`` to
``share/gpr_kinematics/config`` (the ament layout). The lookup order is: ``GPR_KINEMATICS_CONFIG_DIR``,
the ament index (``AMENT_PREFIX_PATH``), the source tree next to this package, and the install prefix
relative to this file (``<prefix>/lib/pythonX.Y/site-packages/gpr_kinematics``).
"""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import ConfigError

PACKAGE = 'gpr_kinematics'


def _candidates() -> list[Path]:
    here = Path(__file__).resolve().parents[1]  # the folder of the Python package gpr_kinematics
    out: list[Path] = []
    env = os.environ.get('GPR_KINEMATICS_CONFIG_DIR')
    if env:
        out.append(Path(env))
    # A source checkout (pip install -e, pytest from the repository) wins over an install tree so that
    # edits to config/ are seen without rebuilding.
    out.append(here.parent / 'config')
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix:
            out.append(Path(prefix) / 'share' / PACKAGE / 'config')
    if len(here.parents) >= 4:
        out.append(here.parents[3] / 'share' / PACKAGE / 'config')
    return out


def config_dir() -> Path:
    """Return the directory holding ``gpr.yaml`` and ``mechanisms/``."""
    for cand in _candidates():
        if (cand / 'gpr.yaml').is_file():
            return cand
    raise ConfigError('cannot find the package config directory (gpr.yaml); looked in '
                      + ', '.join(str(c) for c in _candidates()))


def config_path(relative: str) -> Path:
    """Return the path of a packaged config file, e.g. ``config_path('mechanisms/upu3.yaml')``."""
    path = config_dir() / relative
    if not path.exists():
        raise ConfigError(f'packaged config file {relative!r} not found in {config_dir()}')
    return path

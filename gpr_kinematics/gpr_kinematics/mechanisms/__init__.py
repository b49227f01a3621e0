"""Parallel mechanisms of the papers (``docs/references.md``) behind one interface (:class:`~.base.Mechanism`).

``load_mechanism(path)`` reads a YAML file (SI units) and dispatches on its key ``type``:

============== ==================================================== =====================================
``type``       mechanism                                            module
============== ==================================================== =====================================
``gsp``        generalized Stewart platform, six D1-D4/A1 constraints :mod:`.gsp`
``stewart_6sps`` 6-SPS Gough-Stewart platform (Alwan)               :mod:`.stewart`
``upu3``       3-UPU translational manipulator                      :mod:`.upu3`
``tripod_3rps`` 3-RPS tripod with parasitic motions                 :mod:`.tripod`
``gpr``        the GPR tilting Z axis on the core kinematics        :mod:`.gpr`
============== ==================================================== =====================================

A top-level ``workspace`` mapping (read by the workspace analysis) is ignored here.
"""
from __future__ import annotations

import importlib
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..errors import ConfigError, brief, key_value, kind_of
from ..inputs.schema import read_yaml
from .base import Mechanism

__all__ = ['Mechanism', 'MECHANISM_TYPES', 'load_mechanism', 'mechanism_from_dict', 'read_mechanism_file']

#: ``type`` key -> (module, loader function name).
MECHANISM_TYPES: dict[str, tuple[str, str]] = {
    'gsp': ('.gsp', 'load_gsp'),
    'stewart_6sps': ('.stewart', 'load_stewart'),
    'upu3': ('.upu3', 'load_upu3'),
    'tripod_3rps': ('.tripod', 'load_tripod'),
    'gpr': ('.gpr', 'load_gpr'),
}


#: Keys only a GPR geometry file has (``--config``), told apart from a mechanism file.
GPR_GEOMETRY_KEYS = ('radius', 'rod_azimuths', 'stroke_min', 'stroke_max', 'tilt_limit')


def mechanism_from_dict(data: Mapping[str, Any], source: str = '<dict>') -> Mechanism:
    """Build a mechanism from a parsed YAML mapping; ``source`` names it in error messages."""
    if not isinstance(data, Mapping):
        raise ConfigError(f'{source}: a mechanism file must be a YAML mapping with a key type; got '
                          f'{kind_of(data)}')
    mtype = data.get('type')
    if not isinstance(mtype, str) or mtype not in MECHANISM_TYPES:
        geometry = mtype is None and any(key in data for key in GPR_GEOMETRY_KEYS)   # a calibrated gpr.yaml
        hint = ' (a GPR geometry file: give it as --config FILE, with the mechanism gpr.yaml)' if geometry else ''
        raise ConfigError(f'{source}: type = {key_value(data, "type")} is not a mechanism type; allowed: '
                          + ', '.join(MECHANISM_TYPES) + hint)
    module, func = MECHANISM_TYPES[mtype]
    loader = getattr(importlib.import_module(module, __name__), func)
    mechanism: Mechanism = loader(data, source)
    return mechanism


def read_mechanism_file(path: str | Path) -> tuple[Any, Path]:
    """Parse a mechanism YAML file; returns ``(data, resolved path)``.

    A path is read as given. Only a *bare name* (no folder in it) that does not exist here is also looked up
    among the packaged files (``config/mechanisms/``), so ``'upu3.yaml'`` works from anywhere while a mistyped
    ``'typo_dir/upu3.yaml'`` is an error, never silently the packaged file
    (:func:`~gpr_kinematics.inputs.resources.packaged_file`, the command line's rule for every shipped kind).
    """
    from ..inputs.resources import MECHANISMS, packaged_file
    if not isinstance(path, (str, os.PathLike)):   # None or 3 raised a bare TypeError
        raise ConfigError(f'mechanism file path = {brief(path)}; allowed: a file path (str or Path) of a mechanism '
                          'YAML file, or the name of a packaged one such as upu3.yaml')
    name = os.fspath(path)
    if name == '':
        raise ConfigError('mechanism file path is empty; allowed: a mechanism YAML file, or the name of a packaged '
                          'one such as upu3.yaml')
    p = Path(packaged_file(name, MECHANISMS))
    return read_yaml(p, 'mechanism'), p


def load_mechanism(path: str | Path) -> Mechanism:
    """Read a mechanism YAML file (see the module docstring) and return the :class:`Mechanism`."""
    data, p = read_mechanism_file(path)
    return mechanism_from_dict(data, str(p))

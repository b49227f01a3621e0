"""Locate the package's data files (``config/``) in a source tree or an installed prefix.

The YAML files live in ``config/`` of the ROS package folder (``gpr_kinematics/config`` in the repository), beside
the Python package, and are installed by ``setup.py`` to
``share/gpr_kinematics/config`` (the ament layout). The lookup order is: ``GPR_KINEMATICS_CONFIG_DIR``,
the ament index (``AMENT_PREFIX_PATH``), the source tree next to this package, and the install prefix
relative to this file (``<prefix>/lib/pythonX.Y/site-packages/gpr_kinematics``).

:func:`packaged_file` is the command line's one rule for a file argument of a kind the package ships examples of
(:class:`Packaged`): a path is read as given; only a *bare name* (no folder in it) that is no file here is also
looked up among the packaged files of that kind, so ``gpr program check example_robot_program.yaml`` works from any
folder while a mistyped ``typo_dir/x.yaml`` is an error, never silently the packaged file. The nodes never use it:
what a remote client may name is the business of ``gpr_kinematics.ros.streams.GoalFiles``.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError, FileError, brief

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


@dataclass(frozen=True)
class Packaged:
    """A kind of file the package ships examples of: ``kind`` names it in messages (``'robot description'``), its
    packaged files are those of ``pattern`` in the ``folders`` of ``config/``, and ``example`` is one of them."""

    kind: str
    folders: tuple[str, ...]
    pattern: str
    example: str

    def names(self) -> dict[str, Path]:
        """The packaged files of this kind by name (the first folder's wins a name two folders hold)."""
        found: dict[str, Path] = {}
        for folder in self.folders:
            for path in sorted((config_dir() / folder).glob(self.pattern)):
                if path.is_file():
                    found.setdefault(path.name, path)
        return found


#: Longest file name a message quotes whole [characters] (any path one types; a longer one is cut, its length named).
QUOTED = 256

MECHANISMS = Packaged('mechanism', ('mechanisms',), '*.yaml', 'upu3.yaml')
ROBOTS = Packaged('robot description', ('robots',), '*.yaml', 'example_robot.yaml')
PROGRAMS = Packaged('program', ('programs',), '*.yaml', 'example_robot_program.yaml')
CELLS = Packaged('cell', ('cells',), '*.yaml', 'example_cell.yaml')
TOLERANCES = Packaged('tolerance table', ('calibration',), '*.yaml', 'tolerances_example.yaml')
MEASUREMENTS = Packaged('measurements', ('calibration',), '*.csv', 'synthetic_measurements.csv')
#: ``gpr accuracy FILE --tolerances``: a mechanism file of type gpr, a platform or a robot program.
MECHANISMS_AND_PROGRAMS = Packaged('mechanism or program', ('mechanisms', 'programs'), '*.yaml', 'gpr.yaml')


def packaged_file(path: str | os.PathLike[str], kind: Packaged) -> str:
    """The file a command-line argument names (module docstring): ``path`` itself when something of that name
    exists here (a local file wins), or an empty name or one with a NUL (left to the reader, which refuses it);
    else, for a bare name, the packaged file of ``kind`` of that name. :class:`FileError` for a path with a folder
    that does not exist, and for a bare name that is no packaged file of ``kind`` (naming the packaged ones)."""
    name = os.fspath(path)
    if name == '' or '\0' in name:
        return name
    try:
        os.lstat(name)
        return name
    except PermissionError:   # there, perhaps: the reader names what stops it
        return name
    except OSError:
        pass
    packaged = kind.names()
    if os.sep in name or (os.altsep is not None and os.altsep in name):
        base = os.path.basename(name)   # the example the message gives: the packaged file meant, if it is one
        raise FileError(f'{kind.kind} file {brief(name, QUOTED)} not found (a path with a folder is read as given; '
                        f'only a bare name such as {base if base in packaged else kind.example} is also looked up '
                        'among the packaged files); allowed: a file that exists')
    if name not in packaged:
        raise FileError(f'{kind.kind} file {brief(name, QUOTED)} not found, here nor among the packaged files; '
                        'allowed: a file that exists, or a packaged one: ' + ', '.join(sorted(packaged)))
    return str(packaged[name])

"""Bounded YAML parsing: the one way the package reads YAML a user or a file hands it.

PyYAML's ``safe_load`` builds only plain data, but it still expands aliases without bound (a few hundred bytes of
nested ``&a [*b, *b, ...]`` anchors become gigabytes: the "billion laughs"), recurses once per nesting level (a
document nested 20,000 deep raises ``RecursionError``), and reads whatever file it is given (a FIFO blocks
forever). This module refuses each of those with a :class:`~gpr_kinematics.errors.ConfigError` that names the
file and the limit:

* aliases (``*name``) are refused: configuration, mechanism, program and robot files never need them;
* nesting deeper than :data:`MAX_DEPTH` levels is refused;
* more than :data:`MAX_NODES` values (scalars, lists and mappings) are refused as they are composed: each costs
  about 0.7 kB and 35 us in PyYAML, so 2 MiB of ``[1,1,1,...]`` took 0.7 GB and 34 s, and 10 MiB would take 3.6 GB;
* a file larger than :data:`MAX_BYTES` or not a regular file is refused before it is read;
* text that is not UTF-8 is refused with the byte offset of the first bad byte.

Numbers in exponent form are floats as in YAML 1.2 (``1e-3``, ``1.5e3``, ``-2E+6``): PyYAML follows YAML 1.1,
which needs a decimal point and a signed exponent (``1.5e+3``) and reads the others as text, so ``leg_max: 13e-2``
was refused as "not a number, got '13e-2'". The ROS nodes read ``ros2 param set ... 1e-13`` the same way.

Values are never formatted whole into a message: :func:`gpr_kinematics.errors.brief` shortens them.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml
from yaml.events import AliasEvent
from yaml.nodes import Node

from ..errors import BRIEF_LENGTH, ConfigError, brief
from .files import read_text

__all__ = ['BRIEF_LENGTH', 'MAX_BYTES', 'MAX_DEPTH', 'MAX_NODES', 'YamlValue', 'brief', 'load_text', 'read_file']

#: A value read from YAML before its file format has checked it: a dict, list, str, int, float, bool or None, nested
#: in any way a user wrote. Honestly ``Any``: each format's checks (:mod:`gpr_kinematics.inputs.schema`) narrow it.
YamlValue = Any

#: Largest YAML file the package reads [bytes] (10 MiB: configuration files are a few kB; a program of 10,000
#: stations is about 1 MB; the node count below bounds memory and time, this bound the text).
MAX_BYTES = 10 * 1024 * 1024
#: Deepest nesting of mappings and sequences accepted (the package's files use fewer than 8 levels).
MAX_DEPTH = 64
#: Most values (nodes) in one YAML document: about 0.15 GB and 7 s at the limit; a program of 10,000 stations and
#: steps has about 150,000 (larger station lists go in CSV station files).
MAX_NODES = 200_000


class _BoundedLoader(yaml.SafeLoader):
    """SafeLoader that refuses aliases and bounds the nesting depth and the number of nodes while composing the
    node graph."""

    def __init__(self, stream: str, source: str) -> None:
        super().__init__(stream)
        self._source = source
        self._depth = 0
        self._nodes = 0

    def _line(self) -> int:
        """The line (from 1) of the next event."""
        event: Any = yaml.SafeLoader.peek_event(self)
        return int(event.start_mark.line) + 1

    def compose_node(self, parent: Node | None, index: Any) -> Node | None:
        if self.check_event(AliasEvent):
            raise ConfigError(f'{self._source}: line {self._line()}: YAML aliases (*name) are not accepted '
                              '(they can expand without bound); write the values out')
        self._nodes += 1
        if self._nodes > MAX_NODES:
            raise ConfigError(f'{self._source}: line {self._line()}: more than {MAX_NODES} YAML values; allowed: at '
                              f'most {MAX_NODES} (large station lists belong in CSV station files)')
        self._depth += 1
        if self._depth > MAX_DEPTH:
            raise ConfigError(f'{self._source}: line {self._line()}: nested deeper than {MAX_DEPTH} levels; '
                              f'allowed: at most {MAX_DEPTH}')
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


# YAML 1.2's exponent floats (PyYAML's YAML 1.1 resolver, tried first, keeps every form it knows).
_BoundedLoader.add_implicit_resolver('tag:yaml.org,2002:float',
                                     re.compile(r'^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$'),
                                     list('-+.0123456789'))


def load_text(text: str, source: str = 'YAML text') -> YamlValue:
    """Parse YAML ``text`` into plain data (dicts, lists, str, int, float, bool, None) under the bounds above.

    Raises:
        ConfigError: an alias, nesting beyond :data:`MAX_DEPTH`, or invalid YAML (first line of PyYAML's message).

    >>> load_text('a: [1, 2.5, x, 13e-2, 1.5e3]')
    {'a': [1, 2.5, 'x', 0.13, 1500.0]}
    >>> load_text('a: &x [1]\\nb: *x', 'demo.yaml')  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    gpr_kinematics.errors.ConfigError: demo.yaml: line 2: YAML aliases (*name) are not accepted ...
    """
    if len(text) > MAX_BYTES:
        raise ConfigError(f'{source}: {len(text)} characters of YAML; allowed: at most {MAX_BYTES}')
    loader: _BoundedLoader | None = None
    try:
        loader = _BoundedLoader(text, source)  # the reader checks the characters here already
        return loader.get_single_data()
    except yaml.YAMLError as exc:
        raise ConfigError(f'{source}: not valid YAML ({str(exc).splitlines()[0]})') from None
    except RecursionError:  # flow collections recurse in the parser, before compose_node can count
        raise ConfigError(f'{source}: nested too deeply; allowed: at most {MAX_DEPTH} levels') from None
    except ConfigError:  # the loader's own refusals (an alias, the depth) are ValueErrors too: as they are
        raise
    except ValueError as exc:  # a constructor refused a scalar: an integer of > 4300 digits, a date 2026-13-45
        raise ConfigError(f'{source}: a value cannot be read: {str(exc).split(";")[0][:100]}') from None
    finally:
        if loader is not None:
            loader.dispose()


def read_file(path: str | Path, what: str = 'YAML') -> YamlValue:
    """Parse the YAML file ``path``: a regular file of at most :data:`MAX_BYTES`, UTF-8
    (:func:`gpr_kinematics.inputs.files.read_text`), within the bounds of :func:`load_text`. ``what`` names the kind of
    file in messages (config, program, mechanism, ...).

    Raises:
        ConfigError: the file is missing, unreadable, not a regular file, too large, not UTF-8 or not valid YAML.
    """
    return load_text(read_text(path, what, MAX_BYTES), str(path))

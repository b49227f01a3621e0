"""Bounded YAML parsing: the one way the package reads YAML a user or a file hands it.

PyYAML's ``safe_load`` builds only plain data, but it still expands aliases without bound (a few hundred bytes of
nested ``&a [*b, *b, ...]`` anchors become gigabytes: the "billion laughs"), recurses once per nesting level (a
document nested 20,000 deep raises ``RecursionError``), and reads whatever file it is given (a FIFO blocks
forever). This module refuses each of those with a :class:`~gpr_kinematics.errors.ConfigError` that names the
file and the limit:

* aliases (``*name``) are refused: configuration, mechanism, program and robot files never need them;
* nesting deeper than :data:`MAX_DEPTH` levels is refused;
* a file larger than :data:`MAX_BYTES` or not a regular file is refused before it is read;
* text that is not UTF-8 is refused with the byte offset of the first bad byte.

Values are never formatted whole into a message: :func:`brief` shortens them.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Any

import yaml
from yaml.events import AliasEvent
from yaml.nodes import Node

from .errors import ConfigError

#: Largest YAML file the package reads [bytes] (10 MiB: configuration files are a few kB, a 10,000-station
#: program about 2 MB; PyYAML parses ~1-2 MB/s, so the bound also bounds the time).
MAX_BYTES = 10 * 1024 * 1024
#: Deepest nesting of mappings and sequences accepted (the package's files use fewer than 8 levels).
MAX_DEPTH = 64
#: Longest text of a value quoted in an error message [characters].
BRIEF_LENGTH = 60


def brief(value: Any, limit: int = BRIEF_LENGTH) -> str:
    """``repr(value)``, cut to ``limit`` characters with the total length named: for messages about values a
    user supplied, which may be arbitrarily large.

    >>> brief('x' * 1000)
    "'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx... (1002 characters)"
    >>> brief([1, 2])
    '[1, 2]'
    """
    text = repr(value)
    if len(text) <= limit:
        return text
    return f'{text[:limit]}... ({len(text)} characters)'


class _BoundedLoader(yaml.SafeLoader):
    """SafeLoader that refuses aliases and bounds the nesting depth while composing the node graph."""

    def __init__(self, stream: str, source: str) -> None:
        super().__init__(stream)
        self._source = source
        self._depth = 0

    def compose_node(self, parent: Node | None, index: Any) -> Node | None:
        if self.check_event(AliasEvent):
            mark = self.peek_event().start_mark
            raise ConfigError(f'{self._source}: line {mark.line + 1}: YAML aliases (*name) are not accepted '
                              '(they can expand without bound); write the values out')
        self._depth += 1
        if self._depth > MAX_DEPTH:
            mark = self.peek_event().start_mark
            raise ConfigError(f'{self._source}: line {mark.line + 1}: nested deeper than {MAX_DEPTH} levels; '
                              f'allowed: at most {MAX_DEPTH}')
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def load_text(text: str, source: str = 'YAML text') -> Any:
    """Parse YAML ``text`` into plain data (dicts, lists, str, int, float, bool, None) under the bounds above.

    Raises:
        ConfigError: an alias, nesting beyond :data:`MAX_DEPTH`, or invalid YAML (first line of PyYAML's message).

    >>> load_text('a: [1, 2.5, x]')
    {'a': [1, 2.5, 'x']}
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
    finally:
        if loader is not None:
            loader.dispose()


def read_file(path: str | Path, what: str = 'YAML') -> Any:
    """Parse the YAML file ``path``: a regular file of at most :data:`MAX_BYTES`, UTF-8, within the bounds of
    :func:`load_text`. ``what`` names the kind of file in messages (config, program, mechanism, ...).

    Raises:
        ConfigError: the file is missing, unreadable, not a regular file, too large, not UTF-8 or not valid YAML.
    """
    path = Path(path)
    try:
        info = os.stat(path)
    except OSError as exc:
        raise ConfigError(f'cannot read {what} file {str(path)!r}: {exc.strerror or exc}') from None
    if not stat.S_ISREG(info.st_mode):
        raise ConfigError(f'{what} file {str(path)!r} is not a regular file (a directory, FIFO or device); '
                          'allowed: a regular YAML file')
    if info.st_size > MAX_BYTES:
        raise ConfigError(f'{what} file {str(path)!r} has {info.st_size} bytes; allowed: at most {MAX_BYTES}')
    try:
        with open(path, 'rb') as fh:
            data = fh.read(MAX_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f'cannot read {what} file {str(path)!r}: {exc.strerror or exc}') from None
    if len(data) > MAX_BYTES:  # grew since stat
        raise ConfigError(f'{what} file {str(path)!r} has more than {MAX_BYTES} bytes; allowed: at most {MAX_BYTES}')
    try:
        text = data.decode('utf-8')
    except UnicodeDecodeError as exc:
        raise ConfigError(f'{what} file {str(path)!r} is not UTF-8 text (byte {exc.start} is {data[exc.start]:#04x});'
                          ' allowed: a UTF-8 YAML file') from None
    return load_text(text, str(path))

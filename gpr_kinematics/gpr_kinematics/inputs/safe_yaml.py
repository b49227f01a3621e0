"""Bounded YAML parsing: the one way the package reads YAML a user or a file hands it.

PyYAML's ``safe_load`` builds only plain data, but it still expands aliases without bound (a few hundred bytes of
nested ``&a [*b, *b, ...]`` anchors become gigabytes: the "billion laughs"), recurses once per nesting level (a
document nested 20,000 deep raises ``RecursionError``), and reads whatever file it is given (a FIFO blocks
forever). This module refuses each of those with a :class:`~gpr_kinematics.errors.ConfigError` that names the
file and the limit:

* aliases (``*name``) are refused: configuration, mechanism, program and robot files never need them;
* nesting deeper than :data:`MAX_DEPTH` levels is refused;
* more than :data:`MAX_NODES` values (scalars, lists and mappings) are refused before a node is built: libyaml's
  events are counted first (a few microseconds each), and only a document within the bounds is composed (each value
  then costs about 0.7 kB and 35 us in PyYAML's Python composer, 10 times less through libyaml's; 2 MiB of
  ``[1,1,1,...]`` took 0.7 GB and 34 s with the Python composer alone). Without libyaml the values are counted as
  they are composed;
* a key given twice in one mapping is refused, naming the key and both lines (PyYAML keeps the last silently), and
  so is YAML 1.1's merge key ``<<`` (it gave a key twice past that check);
* a file larger than its kind's bound (:data:`KIND_BYTES`; :data:`MAX_BYTES` for the others) or not a regular
  file is refused before a byte is read (so an 8 MB robot file costs nothing but a ``stat``);
* text that is not UTF-8 is refused with the byte offset of the first bad byte.

Numbers and booleans are those of YAML 1.2's core schema. Exponent forms are floats (``1e-3``, ``1.5e3``,
``-2E+6``): PyYAML follows YAML 1.1, which needs a decimal point and a signed exponent (``1.5e+3``) and reads the
others as text, so ``leg_max: 13e-2`` was refused as "not a number, got '13e-2'". The ROS nodes read ``ros2 param
set ... 1e-13`` the same way. YAML 1.1's other forms are text, which a number check then refuses by name: ``0750``
is 750 (YAML 1.1: octal, 488), ``1:31`` is not 91 (base 60), ``0x10``, ``0o17`` and ``1_000`` are not numbers, and
``yes``, ``no``, ``on``, ``off`` are not booleans (only ``true`` and ``false``); a date such as ``2024-01-15`` (a
station's name) is text, as is an integer of more than :data:`MAX_INT_DIGITS` digits.

Values are never formatted whole into a message: :func:`gpr_kinematics.errors.brief` shortens them, and a key is
quoted only when it is a name (:func:`quoted_key`): the lines of a file that is not of the package's formats are
never repeated in a message.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml
from yaml.events import AliasEvent, CollectionEndEvent, CollectionStartEvent, ScalarEvent
from yaml.nodes import MappingNode, Node, ScalarNode

from ..errors import BRIEF_LENGTH, ConfigError, brief
from .files import read_text

__all__ = ['BRIEF_LENGTH', 'KIND_BYTES', 'MAX_BYTES', 'MAX_DEPTH', 'MAX_NODES', 'YamlValue', 'brief', 'dump',
           'is_name', 'load_documents', 'load_text', 'quoted_key', 'read_file']

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
#: Largest file of each kind (the ``what`` of :func:`read_file`) [bytes], refused before it is read: a geometry, a
#: robot description, a tolerance table is a few kB (1 MiB holds a hundred times that); a mechanism with closure
#: equations some 10 kB; programs and station files go up to :data:`MAX_BYTES` (10,000 stations are about 1 MB).
KIND_BYTES: dict[str, int] = {'config': 1 << 20, 'robot': 1 << 20, 'tolerance table': 1 << 20, 'mechanism': 4 << 20}
#: What a refusal of too many values advises by default.
STATIONS_HINT = 'large station lists belong in CSV station files'


class _Bounds:
    """The bounds of one document, checked per event or node: no alias, at most ``max_nodes`` values, nesting at
    most :data:`MAX_DEPTH` deep, each refusal naming the line."""

    def __init__(self, source: str, max_nodes: int, hint: str = STATIONS_HINT) -> None:
        self.source, self.max_nodes, self.hint = source, max_nodes, hint
        self.depth = self.nodes = 0

    def node(self, line: int) -> None:
        """One more value (a scalar, list or mapping) at ``line``, one level below the open collections."""
        self.nodes += 1
        if self.nodes > self.max_nodes:
            raise ConfigError(f'{self.source}: line {line}: more than {self.max_nodes} YAML values; allowed: at '
                              f'most {self.max_nodes} ({self.hint})')
        if self.depth + 1 > MAX_DEPTH:
            raise ConfigError(f'{self.source}: line {line}: nested deeper than {MAX_DEPTH} levels; '
                              f'allowed: at most {MAX_DEPTH}')

    def alias(self, line: int) -> None:
        raise ConfigError(f'{self.source}: line {line}: YAML aliases (*name) are not accepted '
                          '(they can expand without bound); write the values out')


def _prescan(text: str, bounds: _Bounds) -> None:
    """The bounds checked on libyaml's events, before a node is built: a refusal costs a few microseconds per value
    read up to it (composing costs ten times as much)."""
    for event in yaml.parse(text, Loader=yaml.CSafeLoader):
        if isinstance(event, (ScalarEvent, CollectionStartEvent)):
            bounds.node(_line(event.start_mark))
            if isinstance(event, CollectionStartEvent):
                bounds.depth += 1
        elif isinstance(event, CollectionEndEvent):
            bounds.depth -= 1
        elif isinstance(event, AliasEvent):
            bounds.alias(_line(event.start_mark))


def _line(mark: Any) -> int:
    """The line (from 1) of a PyYAML mark (0 without one)."""
    return int(mark.line) + 1 if mark is not None else 0


class _UniqueKeys:
    """A constructor mixin: a mapping that names a key twice is refused, naming the key and both lines (PyYAML keeps
    the last value silently)."""

    _source: str

    def construct_mapping(self, node: MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            line = _line(key_node.start_mark)
            if key_node.tag == 'tag:yaml.org,2002:merge':  # PyYAML merged them past the check, the last one winning
                raise ConfigError(f'{self._source}: line {line}: merge key <<; allowed: each key written out (YAML '
                                  '1.2, which the package reads, has no merge keys)')
            if not isinstance(key_node, ScalarNode):
                continue
            key = self.construct_object(key_node)  # type: ignore[attr-defined]  # SafeConstructor's
            if key in seen:
                raise ConfigError(f'{self._source}: line {line}: duplicate key {quoted_key(key)} (first on line '
                                  f'{seen[key]}); allowed: each key once in a mapping')
            seen[key] = line
        out: dict[Any, Any] = super().construct_mapping(node, deep=deep)  # type: ignore[misc]
        return out


class _BoundedLoader(_UniqueKeys, yaml.SafeLoader):
    """The pure-Python loader (where PyYAML has no libyaml): the bounds are checked while composing the nodes."""

    def __init__(self, stream: str, source: str, max_nodes: int, hint: str = STATIONS_HINT) -> None:
        super().__init__(stream)
        self._source = source
        self._bounds = _Bounds(source, max_nodes, hint)

    def compose_node(self, parent: Node | None, index: Any) -> Node | None:
        event: Any = yaml.SafeLoader.peek_event(self)
        line = _line(event.start_mark)
        if self.check_event(AliasEvent):
            self._bounds.alias(line)
        self._bounds.node(line)
        self._bounds.depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self._bounds.depth -= 1


#: libyaml's loader (PyYAML's C extension), when PyYAML was built with it: the bounds are checked by
#: :func:`_prescan` first.
_CLoader: Any = None
if getattr(yaml, '__with_libyaml__', False):
    class _CBoundedLoader(_UniqueKeys, yaml.CSafeLoader):
        def __init__(self, stream: str, source: str) -> None:
            super().__init__(stream)
            self._source = source

    _CLoader = _CBoundedLoader


# YAML 1.2's exponent floats and signed ``-.5`` (PyYAML's YAML 1.1 resolver, tried first, reads them as text).
_FLOAT_1_2 = re.compile(r'^(?:[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+|[-+]?\.[0-9]+)$')
# The scalars YAML 1.2's core schema reads as numbers and booleans. YAML 1.1's other forms stay text, so a number
# check names them: ``0750`` was octal (488), ``1:31`` base 60 (91), ``0x10`` 16, ``1_0`` 10, ``yes`` and ``on`` true.
_INT_CORE = re.compile(r'[-+]?[0-9]+')
#: A decimal number: ASCII digits with an optional sign, point and exponent, one way to read each text (the files'
#: and the command line's numbers too, :func:`~gpr_kinematics.inputs.validation.decimal`; unsigned, the workspace
#: equations' numbers and argparse's negative-number rule).
UNSIGNED_DECIMAL = r'(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?'
DECIMAL = r'[-+]?' + UNSIGNED_DECIMAL
_FLOAT_CORE = re.compile(DECIMAL + r'|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)')
_BOOL_CORE = {'true': True, 'True': True, 'TRUE': True, 'false': False, 'False': False, 'FALSE': False}


#: Digits of the longest integer read as one (Python's ``int`` refuses more than 4,300 by default): a longer one is
#: kept as text, so the number check names its key and the range allowed.
MAX_INT_DIGITS = 4000


def _core_int(loader: Any, node: ScalarNode) -> int | str:
    """An int of YAML 1.2's core schema (decimal, a leading zero included), or the text as written (also an integer
    of more than :data:`MAX_INT_DIGITS` digits)."""
    text = str(node.value)
    return int(text, 10) if _INT_CORE.fullmatch(text) and len(text.lstrip('+-')) <= MAX_INT_DIGITS else text


def _as_text(loader: Any, node: ScalarNode) -> str:
    """A date or time (``2024-01-15``, a YAML 1.1 timestamp; YAML 1.2's core schema has none) as the text written:
    a station named ``2024-01-15`` is that name."""
    return str(node.value)


def _core_float(loader: Any, node: ScalarNode) -> float | str:
    """A float of YAML 1.2's core schema, or the text as written (a base-60 ``1:30.5``, ``1_000.5``)."""
    text = str(node.value)
    if not _FLOAT_CORE.fullmatch(text):
        return text
    value: float = loader.construct_yaml_float(node)
    return value


def _core_bool(loader: Any, node: ScalarNode) -> bool | str:
    """``true``/``false`` (YAML 1.2's core schema); ``yes``, ``no``, ``on``, ``off`` stay text."""
    text = str(node.value)
    return _BOOL_CORE.get(text, text)


for _loader in (_BoundedLoader, _CLoader):
    if _loader is not None:
        _loader.add_implicit_resolver('tag:yaml.org,2002:float', _FLOAT_1_2, list('-+.0123456789'))
        _loader.add_constructor('tag:yaml.org,2002:int', _core_int)
        _loader.add_constructor('tag:yaml.org,2002:float', _core_float)
        _loader.add_constructor('tag:yaml.org,2002:bool', _core_bool)
        _loader.add_constructor('tag:yaml.org,2002:timestamp', _as_text)


class _Dumper(yaml.SafeDumper):
    """PyYAML's safe dumper that quotes a text the package's loader would read as a number: YAML 1.2's floats
    without a dot (``1e5``), which PyYAML's YAML 1.1 resolver leaves plain."""


_Dumper.add_implicit_resolver('tag:yaml.org,2002:float', _FLOAT_1_2, list('-+.0123456789'))


def dump(data: YamlValue, **options: Any) -> str:
    """``data`` as YAML text (``yaml.safe_dump``'s ``options``) that :func:`load_text` reads back as written: a
    station named ``1e5`` is quoted."""
    text: str = yaml.dump(data, Dumper=_Dumper, **options)
    return text


def is_name(key: YamlValue) -> bool:
    """A key that a message may quote: a name (letters, digits, ``_``, ``-``, ``.``, ``/``, starting with a letter
    or ``_``: how every key of the package's formats looks, typos included), a number, a bool or null."""
    return (isinstance(key, str) and _NAME.fullmatch(key) is not None) or key is None or (
        isinstance(key, (int, float, bool)))


def quoted_key(key: YamlValue) -> str:
    """A key of a file as a message names it: quoted (:func:`brief`) when :func:`is_name`, else only described. A
    file that is not of the package's formats (``/etc/shadow`` read as YAML has keys such as
    ``root:*:19000:0:99999:7::``) is never quoted back to the user, or to a remote client, by its keys.

    >>> quoted_key('radius'), quoted_key('root:*:19000:0:99999:7::'), quoted_key(3)
    ("'radius'", 'a key that is not a name (24 characters, not quoted)', '3')
    """
    if is_name(key):
        return brief(key, 40)
    size = f'{len(key)} characters' if isinstance(key, str) else type(key).__name__
    return f'a key that is not a name ({size}, not quoted)'


_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_.\-/]{0,79}')
_NON_PRINTABLE = yaml.reader.Reader.NON_PRINTABLE


def load_text(text: str, source: str = 'YAML text', max_nodes: int | None = None, max_chars: int = MAX_BYTES
              ) -> YamlValue:
    """Parse YAML ``text`` into plain data (dicts, lists, str, int, float, bool, None) under the bounds above
    (``max_nodes``: the values allowed, default :data:`MAX_NODES`; ``max_chars`` the characters, default
    :data:`MAX_BYTES`).

    Raises:
        ConfigError: an alias, nesting beyond :data:`MAX_DEPTH`, too many values, a key twice in a mapping, or
            invalid YAML (first line of PyYAML's message).

    >>> load_text('a: [1, 2.5, x, 13e-2, 1.5e3]')
    {'a': [1, 2.5, 'x', 0.13, 1500.0]}
    >>> load_text('a: &x [1]\\nb: *x', 'demo.yaml')  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    gpr_kinematics.errors.ConfigError: demo.yaml: line 2: YAML aliases (*name) are not accepted ...
    >>> load_text('radius: 0.1\\nmodel: polar\\nradius: 0.2', 'g.yaml')  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    gpr_kinematics.errors.ConfigError: g.yaml: line 3: duplicate key 'radius' (first on line 1); allowed: ...
    """
    return _load(text, source, MAX_NODES if max_nodes is None else max_nodes, max_chars)[0]


def load_documents(text: str, source: str, max_nodes: int, max_chars: int, hint: str) -> list[YamlValue]:
    """Every document of the YAML stream ``text`` (``---`` between them; none in an empty text), under the bounds of
    :func:`load_text` counted over the whole stream: at most ``max_nodes`` values, ``max_chars`` characters;
    ``hint`` is what a refusal of too many values advises. A ROS params file may hold several documents (rcl
    merges them).

    >>> load_documents('a: 1\\n---\\na: 2', 'p.yaml', 10, 100, 'fewer')
    [{'a': 1}, {'a': 2}]
    """
    return _load(text, source, max_nodes, max_chars, hint, every=True)


def _load(text: str, source: str, limit: int, max_chars: int, hint: str = STATIONS_HINT, every: bool = False
          ) -> list[YamlValue]:
    """The documents of ``text`` (``every``), or its single one (a list of one), under the bounds."""
    if len(text) > max_chars:
        raise ConfigError(f'{source}: {len(text)} characters of YAML; allowed: at most {max_chars}')
    bad = _NON_PRINTABLE.search(text)
    if bad:  # PyYAML's own words, whichever parser runs
        raise ConfigError(f'{source}: not valid YAML (unacceptable character #x{ord(bad.group()):04x}: special '
                          f'characters are not allowed, on line {text.count(chr(10), 0, bad.start()) + 1})')
    loader: Any = None
    try:
        if _CLoader is not None:
            _prescan(text, _Bounds(source, limit, hint))
            loader = _CLoader(text, source)
        else:
            loader = _BoundedLoader(text, source, limit, hint)  # the reader checks the characters here already
        if not every:
            return [loader.get_single_data()]
        out = []
        while loader.check_data():
            out.append(loader.get_data())
        return out
    except yaml.YAMLError as exc:
        raise ConfigError(f'{source}: not valid YAML{_where(exc)}') from None
    except RecursionError:  # flow collections recurse in the Python parser, before compose_node can count
        raise ConfigError(f'{source}: nested too deeply; allowed: at most {MAX_DEPTH} levels') from None
    except ConfigError:  # the loader's own refusals (an alias, the depth) are ValueErrors too: as they are
        raise
    except ValueError as exc:  # a constructor refused a scalar: an integer of > 4300 digits, a date 2026-13-45
        raise ConfigError(f'{source}: a value cannot be read: {str(exc).split(";")[0][:100]}') from None
    finally:
        if loader is not None:
            loader.dispose()


def _where(exc: yaml.YAMLError) -> str:
    """PyYAML's complaint in one line with the place it names (``on line 24, column 3: expected <block end>, but
    found '<block mapping start>' (while parsing a block mapping)``), its first line where it names none."""
    mark, problem = getattr(exc, 'problem_mark', None), getattr(exc, 'problem', None)
    if mark is None or not problem:
        return f' ({str(exc).splitlines()[0]})'
    context = getattr(exc, 'context', None)
    return f' on line {mark.line + 1}, column {mark.column + 1}: {problem}' + (f' ({context})' if context else '')


def read_file(path: str | Path, what: str = 'YAML', max_bytes: int | None = None) -> YamlValue:
    """Parse the YAML file ``path``: a regular file of at most ``max_bytes`` (default: :data:`KIND_BYTES` of
    ``what``, else :data:`MAX_BYTES`), judged by its size before a byte is read, UTF-8
    (:func:`gpr_kinematics.inputs.files.read_text`), within the bounds of :func:`load_text`. ``what`` names the kind
    of file in messages (config, program, mechanism, ...).

    Raises:
        ConfigError: the file is missing, unreadable, not a regular file, too large, not UTF-8 or not valid YAML.
    """
    limit = max_bytes if max_bytes is not None else KIND_BYTES.get(what, MAX_BYTES)
    return load_text(read_text(path, what, limit), str(path))

"""Vectorised decoding of many CDR messages of one type into numpy columns.

A stream of messages of one type usually has one *layout*: the same strings (frame id, model, joint names)
and the same sequence lengths, only the numbers differ. Then every numeric field sits at the same byte
offset in every message, and a whole column is one strided numpy view over the concatenated messages.

:func:`decode_columns` walks one message (the template) along the type's field definitions (XCDR1, little
endian: a 4-byte encapsulation header, then every primitive aligned to its size counted from byte 4,
strings and sequences prefixed by a ``uint32`` count) and records where each numeric field lies and which
bytes carry the structure (counts, string bytes, the end's padding: at most 3 zero bytes, anything more after the
last field is refused). Messages of the same length whose structure bytes equal
the template's are decoded by views; the others start a new template. After :data:`MAX_LAYOUTS` templates
the rest is deserialised one by one with ``rosbags`` (correct, slower). Strings come back as Python objects.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import BagError
from .typestore import ARRAY, BASE, NAME, SEQUENCE, fields_of, typestore

#: Layouts tried per type before falling back to per-message deserialisation.
MAX_LAYOUTS = 32
#: Suffix of the column holding a sequence's element count (``markers#``, ``markers[1].points#``).
COUNT = '#'

_PRIMITIVES: dict[str, tuple[str, int]] = {
    'bool': ('u1', 1), 'byte': ('u1', 1), 'char': ('u1', 1), 'octet': ('u1', 1),
    'int8': ('i1', 1), 'uint8': ('u1', 1), 'int16': ('<i2', 2), 'uint16': ('<u2', 2),
    'int32': ('<i4', 4), 'uint32': ('<u4', 4), 'int64': ('<i8', 8), 'uint64': ('<u8', 8),
    'float32': ('<f4', 4), 'float64': ('<f8', 8),
}


@dataclass
class _Layout:
    length: int
    #: (name, offset, dtype, size, count, scalar)
    numeric: list[tuple[str, int, str, int, int, bool]] = field(default_factory=list)
    strings: dict[str, Any] = field(default_factory=dict)  # name -> str or tuple[str, ...]
    structure: list[tuple[int, int]] = field(default_factory=list)  # byte ranges that must match


class _Walker:
    def __init__(self, buf: bytes) -> None:
        self.buf = buf
        self.pos = 4
        self.layout = _Layout(len(buf))

    def align(self, n: int) -> None:
        self.pos += (-(self.pos - 4)) % n

    def u32(self) -> int:
        self.align(4)
        (v,) = struct.unpack_from('<I', self.buf, self.pos)
        self.layout.structure.append((self.pos, self.pos + 4))
        self.pos += 4
        return int(v)

    def string(self) -> str:
        n = self.u32()
        start = self.pos
        self.pos += n
        if self.pos > len(self.buf):
            raise ValueError('string beyond the end of the message')
        text = self.buf[start:self.pos]
        if n == 0 or text[-1] != 0 or 0 in text[:-1]:   # CDR: the count includes one terminating NUL, the only one
            raise ValueError(f'string at byte {start} is not NUL-terminated text of {n} bytes')
        self.layout.structure.append((start, self.pos))
        return bytes(text[:-1]).decode('utf-8')   # UnicodeDecodeError, a ValueError, for bytes that are not text

    def primitive(self, name: str, tname: str, count: int, scalar: bool) -> None:
        dtype, size = _PRIMITIVES[tname]
        if count == 0:
            self.layout.numeric.append((name, self.pos, dtype, size, 0, False))
            return
        self.align(size)
        if self.pos + size * count > len(self.buf):
            raise ValueError('field beyond the end of the message')
        self.layout.numeric.append((name, self.pos, dtype, size, count, scalar))
        self.pos += size * count

    def element(self, name: str, node: tuple[int, Any], count: int | None) -> None:
        """``count`` None: a scalar; otherwise ``count`` elements of the node."""
        kind, detail = node
        if kind == BASE:
            tname = detail[0]
            if tname in ('string', 'wstring'):
                if count is None:
                    self.layout.strings[name] = self.string()
                else:
                    self.layout.strings[name] = tuple(self.string() for _ in range(count))
            elif tname in _PRIMITIVES:
                self.primitive(name, tname, 1 if count is None else count, count is None)
            else:
                raise ValueError(f'unsupported primitive {tname}')
        elif kind == NAME:
            if count is None:
                self.message(detail, name + '.')
            else:
                for i in range(count):
                    self.message(detail, f'{name}[{i}].')
        else:
            raise ValueError(f'unsupported nesting at {name}')

    def message(self, msgtype: str, prefix: str = '') -> None:
        for fname, (kind, detail) in fields_of(msgtype):
            name = prefix + fname
            if kind in (BASE, NAME):
                self.element(name, (kind, detail), None)
            elif kind == ARRAY:
                sub, n = detail
                self.element(name, sub, int(n))
            elif kind == SEQUENCE:
                sub, _bound = detail
                n = self.u32()
                self.layout.numeric.append((name + COUNT, self.pos - 4, '<u4', 4, 1, True))
                self.element(name, sub, n)
            else:
                raise ValueError(f'unsupported field kind at {name}')


def layout_of(msgtype: str, buf: bytes) -> _Layout:
    """Field offsets of one little-endian CDR message; ValueError when it does not parse."""
    if len(buf) < 4 or buf[0] != 0 or buf[1] not in (1, 3):
        raise ValueError('not a little-endian CDR message')
    w = _Walker(buf)
    w.message(msgtype)
    if w.pos > len(buf):
        raise ValueError('message shorter than its fields')
    tail = buf[w.pos:]
    if len(tail) > 3 or any(tail):   # the serializer pads the end to 4 bytes with zeros, nothing else
        raise ValueError(f'{len(tail)} byte(s) after its last field; allowed: at most 3 zero bytes of padding')
    if tail:   # the padding is structure: a message of the same length with other bytes there is not this layout
        w.layout.structure.append((w.pos, len(buf)))
    return w.layout


@dataclass
class Columns:
    """Decoded fields of ``n`` messages: ``numeric[name]`` is ``(n,)`` or ``(n, count)``; ``strings[name]`` an
    object array ``(n,)`` of ``str`` or tuples of ``str``; ``layouts`` how many templates were used."""

    n: int
    numeric: dict[str, NDArray[Any]]
    strings: dict[str, NDArray[np.object_]]
    layouts: int
    fallback: int

    def __getitem__(self, name: str) -> NDArray[Any]:
        if name in self.numeric:
            return self.numeric[name]
        return self.strings[name]

    def __contains__(self, name: str) -> bool:
        return name in self.numeric or name in self.strings

    def get(self, name: str) -> NDArray[Any] | None:
        """The column ``name``, or None when the messages have no such field."""
        if name in self.numeric:
            return self.numeric[name]
        return self.strings.get(name)


def _flatten(obj: Any, prefix: str, out_num: dict[str, Any], out_str: dict[str, Any]) -> None:
    """The fields of a deserialised message ``obj`` into flat columns named like :class:`_Walker` names them."""
    fields = getattr(obj, '__dataclass_fields__', None)
    if fields is None:
        return
    sequences = {f for f, (kind, _) in fields_of(obj.__msgtype__) if kind == SEQUENCE}
    for fname in fields:
        if fname == '__msgtype__':
            continue
        v = getattr(obj, fname)
        name = prefix + fname
        if isinstance(v, str):
            out_str[name] = v
        elif isinstance(v, np.ndarray):
            out_num[name] = v
            if fname in sequences:
                out_num[name + COUNT] = np.uint32(len(v))
        elif isinstance(v, (list, tuple)):
            if fname in sequences:
                out_num[name + COUNT] = np.uint32(len(v))
            _flatten_items(v, name, out_num, out_str)
        elif hasattr(v, '__dataclass_fields__'):
            _flatten(v, name + '.', out_num, out_str)
        else:
            out_num[name] = v


def _flatten_items(v: list[Any] | tuple[Any, ...], name: str, out_num: dict[str, Any], out_str: dict[str, Any]) -> None:
    """A list field: strings as one tuple, messages one by one, numbers as one column."""
    if v and isinstance(v[0], str):
        out_str[name] = tuple(v)
    elif v and hasattr(v[0], '__dataclass_fields__'):
        for i, item in enumerate(v):
            _flatten(item, f'{name}[{i}].', out_num, out_str)
    else:
        out_num[name] = np.asarray(v)


class _ColumnStore:
    """The columns of ``n`` messages being filled, template by template (see :class:`Columns`)."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.numeric: dict[str, NDArray[Any]] = {}
        self.strings: dict[str, NDArray[np.object_]] = {}

    def _column(self, name: str, values: NDArray[Any], scalar: bool) -> NDArray[Any]:
        """The column ``name`` able to take ``values``: created on first use; an object column of 1-D arrays
        once a sequence's length differs between templates."""
        col = self.numeric.get(name)
        if col is None:
            col = np.zeros((self.n,) if scalar else (self.n, values.shape[1]), dtype=values.dtype)
            self.numeric[name] = col
        if col.dtype != object and col.ndim == 2 and col.shape[1] != values.shape[1]:
            obj = np.empty(self.n, dtype=object)
            for i in range(self.n):
                obj[i] = col[i]
            self.numeric[name] = col = obj
        return col

    def store_numeric(self, name: str, idx: NDArray[np.int64], values: NDArray[Any], scalar: bool) -> None:
        """``values`` is ``(len(idx), count)``."""
        col = self._column(name, values, scalar)
        if col.dtype == object:
            for j, i in enumerate(idx):
                col[i] = values[j]
        elif scalar:
            col[idx] = values[:, 0]
        else:
            col[idx] = values

    def store_string(self, name: str, idx: NDArray[np.int64], value: Any) -> None:
        if name not in self.strings:
            self.strings[name] = np.empty(self.n, dtype=object)
        col = self.strings[name]
        for i in idx:
            col[i] = value


def _decode_template(msgtype: str, raw: list[bytes], lengths: NDArray[np.int64], pending: NDArray[np.int64],
                     out: _ColumnStore) -> NDArray[np.int64]:
    """Decode, by strided views, the pending messages that share the layout of the first pending one (same
    length, same structure bytes); returns their indices."""
    t = int(pending[0])
    try:
        lay = layout_of(msgtype, raw[t])
    except (ValueError, struct.error) as exc:  # what a message shorter or longer than its fields raises
        raise BagError(f'message {t} of type {msgtype} cannot be decoded: {exc}') from None
    same_len = pending[lengths[pending] == lay.length]
    block = np.frombuffer(b''.join([raw[i] for i in same_len]), dtype=np.uint8)
    block = block.reshape(same_len.size, lay.length)
    if lay.structure:
        cols = np.concatenate([np.arange(a, b) for a, b in lay.structure])
        ok = np.all(block[:, cols] == block[0, cols], axis=1)
    else:
        ok = np.ones(same_len.size, dtype=bool)
    members: NDArray[np.int64] = same_len[ok]
    buf = block if ok.all() else np.ascontiguousarray(block[ok])
    for name, off, dtype, size, count, scalar in lay.numeric:
        if count == 0:
            out.store_numeric(name, members, np.zeros((members.size, 0), dtype=dtype), scalar)
            continue
        view = np.ndarray((members.size, count), dtype=dtype, buffer=buf, offset=off, strides=(lay.length, size))
        out.store_numeric(name, members, view.astype(np.dtype(dtype).newbyteorder('=')), scalar)
    for name, value in lay.strings.items():
        out.store_string(name, members, value)
    return members


def _decode_one_by_one(msgtype: str, raw: list[bytes], pending: NDArray[np.int64], out: _ColumnStore) -> None:
    """Deserialise the messages left after :data:`MAX_LAYOUTS` templates with ``rosbags``, one at a time."""
    store = typestore()
    for i in pending:
        try:
            layout_of(msgtype, raw[int(i)])   # the bytes after the last field, which rosbags does not look at
            msg = store.deserialize_cdr(raw[int(i)], msgtype)
        except (ValueError, IndexError, struct.error) as exc:  # what rosbags raises for bytes that do not fit
            raise BagError(f'message {int(i)} of type {msgtype} cannot be decoded: {exc}') from None
        num: dict[str, Any] = {}
        strs: dict[str, Any] = {}
        _flatten(msg, '', num, strs)
        idx = np.array([int(i)])
        for name, v in num.items():
            a = np.asarray(v)
            out.store_numeric(name, idx, a.reshape(1, -1), a.ndim == 0)
        for name, v in strs.items():
            out.store_string(name, idx, v)


def decode_columns(msgtype: str, raw: list[bytes]) -> Columns:
    """Decode every message of ``raw`` (CDR bytes of ``msgtype``) into columns; see the module docstring.

    Scalars give ``(n,)`` columns, arrays and sequences ``(n, count)`` (an object column of 1-D arrays if the
    length varies). Raises :class:`BagError` when a message cannot be decoded as ``msgtype``.
    """
    n = len(raw)
    out = _ColumnStore(n)
    if n == 0:
        return Columns(0, out.numeric, out.strings, 0, 0)
    lengths = np.fromiter((len(b) for b in raw), dtype=np.int64, count=n)
    pending = np.arange(n)
    layouts = 0
    while pending.size and layouts < MAX_LAYOUTS:
        members = _decode_template(msgtype, raw, lengths, pending, out)
        layouts += 1
        pending = np.setdiff1d(pending, members, assume_unique=True)
    if pending.size:
        _decode_one_by_one(msgtype, raw, pending, out)
    return Columns(n, out.numeric, out.strings, layouts, int(pending.size))

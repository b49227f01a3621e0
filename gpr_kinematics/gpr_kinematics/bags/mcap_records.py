"""The MCAP record layer (https://mcap.dev/spec): a record body's little-endian fields, each read bounded by the
body, and a chunk's decompression, bounded by the size it declares; :class:`FormatError` names what is wrong at a
byte offset (:mod:`.mcap_file` turns it into a :class:`~gpr_kinematics.bags.errors.BagError` naming the file)."""
from __future__ import annotations

import struct

_U16, _U32, _U64 = struct.Struct('<H'), struct.Struct('<I'), struct.Struct('<Q')


class FormatError(Exception):
    """A structural error at a byte offset (turned into BagError with the file name by read_mcap)."""


class Fields:
    """Little-endian fields of one record body; every read is bounded by the body."""

    def __init__(self, body: memoryview) -> None:
        self.b = body
        self.pos = 0

    def take(self, n: int, what: str) -> memoryview:
        if n > len(self.b) - self.pos:
            left = len(self.b) - self.pos
            raise FormatError(f'{what}: length {n} beyond the end of its record ({left} bytes left)')
        out = self.b[self.pos:self.pos + n]
        self.pos += n
        return out

    def u16(self) -> int:
        return int(_U16.unpack(self.take(2, 'u16'))[0])

    def u32(self) -> int:
        return int(_U32.unpack(self.take(4, 'u32'))[0])

    def u64(self) -> int:
        return int(_U64.unpack(self.take(8, 'u64'))[0])

    def string(self, what: str) -> str:
        raw = self.take(self.u32(), what)
        try:
            return bytes(raw).decode('utf-8')
        except UnicodeDecodeError:
            raise FormatError(f'{what} is not UTF-8') from None

    def string_map(self, what: str) -> tuple[tuple[str, str], ...]:
        sub = Fields(self.take(self.u32(), what))
        out = []
        while sub.pos < len(sub.b):
            out.append((sub.string(f'{what} key'), sub.string(f'{what} value')))
        return tuple(out)


def decompress(payload: memoryview, compression: str, size: int) -> bytes:
    """Decompress a chunk to exactly ``size`` bytes, never producing more."""
    if compression == '':
        if len(payload) != size:
            raise FormatError(f'uncompressed chunk of {len(payload)} bytes declares {size}')
        return bytes(payload)
    if compression == 'zstd':
        from backports import zstd  # the zstd of rosbags; compression.zstd from Python 3.14 has the same API

        dec = zstd.ZstdDecompressor()
        try:
            raw = dec.decompress(payload, max_length=size)
        except zstd.ZstdError as exc:
            raise FormatError(f'zstd chunk does not decompress ({exc})') from None
    elif compression == 'lz4':
        import lz4.frame

        dec = lz4.frame.LZ4FrameDecompressor()
        try:
            raw = dec.decompress(bytes(payload), max_length=size)
        except RuntimeError as exc:  # what lz4 raises for a corrupt frame
            raise FormatError(f'lz4 chunk does not decompress ({exc})') from None
    else:
        raise FormatError(f'chunk compression {compression!r}; allowed: none, zstd or lz4')
    if len(raw) != size or not dec.eof or dec.unused_data:
        got = f'{len(raw)} bytes' if dec.eof else f'{len(raw)} bytes without reaching the end of its frame'
        extra = f' and {len(dec.unused_data)} bytes after its frame' if dec.unused_data else ''
        raise FormatError(f'{compression} chunk decompresses to {got}{extra}; it declares {size}')
    return bytes(raw)

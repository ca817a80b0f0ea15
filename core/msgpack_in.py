"""msgpack read by compiled kernels: the counterpart of ``core.msgpack_out`` for the values a percept
holds (nil, ints, doubles, strings, array and map headers), so a client can take a percept it receives
every cycle straight into its buffers (``agents.frames``) instead of through the unpacker, a dict,
lists and a message object.

Each reader looks at ``buf[n:end]`` and returns the position after the value it read, or :data:`BAD`
when the bytes there are not a value of its kind or run past ``end``. A kernel built on them only takes
the values it knows how to read; anything else it leaves to the full decoder (``protocol.codec``), which
accepts every msgpack form and reports what is wrong. Every int form is read (the packer writes the
smallest, other packers may not), doubles only: a float32 is refused here, not misread.

``buf`` is the frame as it came, a ``bytes`` object (numba takes it as a read-only uint8 buffer, without
a copy; a kernel that takes a frame is called with it as it is), or any uint8 array.
"""

from __future__ import annotations

import numpy as np

from keepaway.core.jit import borrowing
from keepaway.core.msgpack_out import FLOAT64, NIL

BAD = -1
"""The position a reader returns for bytes it does not take."""

_FLOAT32 = 0xCA
_UINT8, _UINT64 = 0xCC, 0xCF
_INT8, _INT64 = 0xD0, 0xD3
_STR8, _STR32 = 0xD9, 0xDB
_ARRAY16, _ARRAY32 = 0xDC, 0xDD
_MAP16, _MAP32 = 0xDE, 0xDF


@borrowing
def _big_endian(buf: np.ndarray, n: int, size: int) -> np.uint64:
    """``size`` bytes at ``buf[n:]`` as an unsigned big-endian number."""
    value = np.uint64(0)
    for i in range(size):
        value = (value << np.uint64(8)) | np.uint64(buf[n + i])
    return value


@borrowing
def is_nil(buf: np.ndarray, n: int, end: int) -> bool:
    return n < end and buf[n] == NIL


@borrowing
def read_int(buf: np.ndarray, n: int, end: int) -> tuple:
    """(value, next) of an int in any of msgpack's forms; (0, BAD) for anything else, and for a uint 64
    above the int64 range (no percept holds one)."""
    if n >= end:
        return 0, BAD
    tag = buf[n]
    if tag < 0x80:  # positive fixint
        return np.int64(tag), n + 1
    if tag >= 0xE0:  # negative fixint
        return np.int64(tag) - 256, n + 1
    if _UINT8 <= tag <= _UINT64:
        size = 1 << (tag - _UINT8)
        if n + 1 + size > end:
            return 0, BAD
        value = _big_endian(buf, n + 1, size)
        if value >= np.uint64(1 << 63):
            return 0, BAD
        return np.int64(value), n + 1 + size
    if _INT8 <= tag <= _INT64:
        size = 1 << (tag - _INT8)
        if n + 1 + size > end:
            return 0, BAD
        value = np.int64(_big_endian(buf, n + 1, size))
        bits = 8 * size
        if bits < 64 and value >= (1 << (bits - 1)):  # sign-extend
            value -= 1 << bits
        return value, n + 1 + size
    return 0, BAD


@borrowing
def read_double(buf: np.ndarray, n: int, end: int) -> tuple:
    """(value, next) of a double (0xcb), NaN and infinities included; (0.0, BAD) for anything else."""
    if n + 9 > end or buf[n] != FLOAT64:
        return 0.0, BAD
    return np.uint64(_big_endian(buf, n + 1, 8)).view(np.float64), n + 9


@borrowing
def read_str(buf: np.ndarray, n: int, end: int) -> tuple:
    """(start, length, next) of a str's bytes (fixstr, str 8/16/32); (0, 0, BAD) for anything else."""
    if n >= end:
        return 0, 0, BAD
    tag = buf[n]
    if 0xA0 <= tag <= 0xBF:
        length, start = np.int64(tag & 0x1F), n + 1
    elif _STR8 <= tag <= _STR32:
        size = 1 << (tag - _STR8)
        if n + 1 + size > end:
            return 0, 0, BAD
        length, start = np.int64(_big_endian(buf, n + 1, size)), n + 1 + size
    else:
        return 0, 0, BAD
    if start + length > end:
        return 0, 0, BAD
    return start, length, start + length


@borrowing
def str_equals(buf: np.ndarray, start: int, length: int, text: np.ndarray) -> bool:
    """Whether the str bytes at ``buf[start:start + length]`` are ``text`` (uint8, e.g. :func:`ascii`)."""
    if length != text.shape[0]:
        return False
    for i in range(length):
        if buf[start + i] != text[i]:
            return False
    return True


@borrowing
def _header(buf: np.ndarray, n: int, end: int, fix: int, tag16: int) -> tuple:
    """(size, next) of an array (``fix`` 0x90, ``tag16`` 0xdc) or map (0x80, 0xde) header."""
    if n >= end:
        return 0, BAD
    tag = buf[n]
    if fix <= tag < fix + 16:
        return np.int64(tag - fix), n + 1
    if tag == tag16 or tag == tag16 + 1:
        size = 2 if tag == tag16 else 4
        if n + 1 + size > end:
            return 0, BAD
        return np.int64(_big_endian(buf, n + 1, size)), n + 1 + size
    return 0, BAD


@borrowing
def read_array(buf: np.ndarray, n: int, end: int) -> tuple:
    """(size, next) of an array header (fixarray, array 16/32); (0, BAD) for anything else."""
    return _header(buf, n, end, 0x90, _ARRAY16)


@borrowing
def read_map(buf: np.ndarray, n: int, end: int) -> tuple:
    """(size, next) of a map header (fixmap, map 16/32); (0, BAD) for anything else."""
    return _header(buf, n, end, 0x80, _MAP16)


def ascii(text: str) -> np.ndarray:
    """``text``'s bytes as the uint8 array :func:`str_equals` compares with."""
    return np.frombuffer(text.encode("ascii"), dtype=np.uint8).copy()


__all__ = ["BAD", "ascii", "is_nil", "read_array", "read_double", "read_int", "read_map", "read_str",
           "str_equals"]

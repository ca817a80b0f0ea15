"""msgpack written by compiled kernels, byte for byte as ``msgpack.packb(value, use_bin_type=True)``
writes it, for the values a percept holds: nil, ints, doubles, array headers and constant fragments.

The server writes each cycle's ``see`` and ``sense_body`` straight from the perception buffers with these
(``server/percept_wire.py``), instead of building Python lists, a message object and a map for the packer
every time: the message path that cost most of the server's time per cycle. Because the bytes are the
packer's own (the smallest int form, every float a double, tested against ``msgpack.packb``), the wire
and what the players decode stay exactly what they were (docs/protocol.md §1).

Each writer puts one value at ``buf[n:]`` and returns the position after it; the caller sizes ``buf``
for its largest message. Strings and other constant parts are packed once, in Python, by
:func:`packed` (so they are the packer's bytes too) and copied in with :func:`put_raw`.
"""

from __future__ import annotations

from typing import Any

import msgpack
import numpy as np

from keepaway.core.jit import borrowing

NIL = 0xC0
FLOAT64 = 0xCB
# Largest encoding of each kind, for sizing buffers.
MAX_INT_BYTES = 9
FLOAT_BYTES = 9
MAX_ARRAY_HEADER_BYTES = 5
MAX_STR_HEADER_BYTES = 5


def packed(value: Any) -> np.ndarray:
    """``value`` as the packer writes it, as uint8 array (a constant part of a message)."""
    return np.frombuffer(msgpack.packb(value, use_bin_type=True), dtype=np.uint8).copy()


@borrowing
def put_raw(buf: np.ndarray, n: int, data: np.ndarray) -> int:
    """Already packed bytes (:func:`packed`)."""
    for i in range(data.shape[0]):
        buf[n + i] = data[i]
    return n + data.shape[0]


@borrowing
def put_nil(buf: np.ndarray, n: int) -> int:
    buf[n] = NIL
    return n + 1


@borrowing
def _put_tagged(buf: np.ndarray, n: int, tag: int, value: int, size: int) -> int:
    """``tag`` then the low ``size`` bytes of ``value``, big-endian (two's complement for negatives)."""
    buf[n] = tag
    for i in range(size):
        buf[n + 1 + i] = (value >> (8 * (size - 1 - i))) & 0xFF
    return n + 1 + size


@borrowing
def put_int(buf: np.ndarray, n: int, value: int) -> int:
    """An int in its smallest form, as the packer chooses it: fixint, then (u)int8/16/32/64."""
    if value >= 0:
        if value < 0x80:
            buf[n] = value
            return n + 1
        if value < 0x100:
            return _put_tagged(buf, n, 0xCC, value, 1)
        if value < 0x10000:
            return _put_tagged(buf, n, 0xCD, value, 2)
        if value < 0x100000000:
            return _put_tagged(buf, n, 0xCE, value, 4)
        return _put_tagged(buf, n, 0xCF, value, 8)
    if value >= -32:
        buf[n] = value & 0xFF
        return n + 1
    if value >= -0x80:
        return _put_tagged(buf, n, 0xD0, value, 1)
    if value >= -0x8000:
        return _put_tagged(buf, n, 0xD1, value, 2)
    if value >= -0x80000000:
        return _put_tagged(buf, n, 0xD2, value, 4)
    return _put_tagged(buf, n, 0xD3, value, 8)


@borrowing
def put_float(buf: np.ndarray, n: int, value: float) -> int:
    """A Python float: always a double (0xcb), NaN and infinities bit for bit."""
    return _put_tagged(buf, n, FLOAT64, np.float64(value).view(np.int64), 8)


@borrowing
def put_str(buf: np.ndarray, n: int, text: np.ndarray) -> int:
    """A str of the UTF-8 bytes ``text`` (fixstr, str 8, str 16 or str 32, as the packer chooses with
    ``use_bin_type``)."""
    size = text.shape[0]
    if size < 32:
        buf[n] = 0xA0 | size
        n += 1
    elif size < 0x100:
        n = _put_tagged(buf, n, 0xD9, size, 1)
    elif size < 0x10000:
        n = _put_tagged(buf, n, 0xDA, size, 2)
    else:
        n = _put_tagged(buf, n, 0xDB, size, 4)
    return put_raw(buf, n, text)


@borrowing
def put_array(buf: np.ndarray, n: int, size: int) -> int:
    """The header of an array of ``size`` elements (fixarray, array 16 or array 32)."""
    if size < 16:
        buf[n] = 0x90 | size
        return n + 1
    if size < 0x10000:
        return _put_tagged(buf, n, 0xDC, size, 2)
    return _put_tagged(buf, n, 0xDD, size, 4)


__all__ = ["FLOAT_BYTES", "MAX_ARRAY_HEADER_BYTES", "MAX_INT_BYTES", "MAX_STR_HEADER_BYTES", "packed", "put_array",
           "put_float", "put_int", "put_nil", "put_raw", "put_str"]

"""The compiled msgpack writers (core/msgpack_out.py) write what ``msgpack.packb`` writes."""

from __future__ import annotations

import math

import msgpack
import numpy as np

from keepaway.core.msgpack_out import packed, put_array, put_float, put_int, put_nil, put_raw

BUF = np.zeros(64, dtype=np.uint8)


def written(put, *args) -> bytes:
    return BUF[: put(BUF, 0, *args)].tobytes()


def test_ints_take_the_packers_smallest_form_at_every_boundary():
    edges = [0, 2**7, 2**8, 2**16, 2**32, 2**63 - 1, -32, -(2**7), -(2**15), -(2**31), -(2**63)]
    values = sorted({v + d for v in edges for d in (-1, 0, 1) if -(2**63) <= v + d < 2**63})
    for value in values:
        assert written(put_int, value) == msgpack.packb(value), value


def test_floats_are_doubles_bit_for_bit():
    for value in (0.0, -0.0, 1.5, -3.25e-300, 1e308, math.inf, -math.inf, math.nan, 0.1, 4000.0):
        assert written(put_float, value) == msgpack.packb(value), value


def test_array_headers_nil_and_constant_fragments():
    for size in (0, 15, 16, 2**16 - 1, 2**16):
        assert written(put_array, size) == msgpack.Packer().pack_array_header(size), size
    assert written(put_nil) == msgpack.packb(None)
    assert written(put_raw, packed("players")) == msgpack.packb("players")

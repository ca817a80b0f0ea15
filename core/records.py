"""Parameter tables in the form numba kernels take: numpy records, passed to a kernel as one pointer.

numba passes a NamedTuple by value, each of its fields a separate argument: every call of a kernel that
takes the server's 78 parameters and the players' 71 copied 149 numbers, and the players' call chains
make thousands of such calls per cycle. A record with the same fields is passed as one pointer and read
the same way (``kp.ball_decay``), holding the same numbers (docs/design.md, "Compiled kernels").

Every kernel caller (server, player processes, batched mode, tests) gets its tables from here, through
``ServerParams.kernel()`` and ``AgentConfig.kernel()``: kernels are then compiled for one form of each
table only, so the batched mode loads the players' and the server's kernels from the cache instead of
compiling them again for another argument type. numpy only: the command line imports this without numba.
"""

from __future__ import annotations

import numpy as np

_GENERIC_DATA = np.generic.__dict__["data"]  # numpy's own ``data``: a memoryview made at each call


class KernelTable(np.record):
    """A parameter record that a kernel called from Python unboxes in well under a microsecond.

    numba unboxes a record argument from its ``data`` attribute, and a plain record's is a memoryview
    that numpy builds afresh at every call with the format string of all its fields: about 8 us per
    table and call, paid twice (``kp`` and ``cfg``) by each of the dozen kernel calls a player makes
    per cycle from Python. A table made by :func:`kernel_record` answers with the raw bytes it lives in
    (the same memory, so the kernel reads the very numbers the record holds), kept in a slot when it is
    made. Attributes are looked up as any object's, in C: numpy's ``record.__getattribute__`` is a
    Python function, which cost 0.5 us of every table's unboxing when it answered ``data`` (0.25 us now).
    A field read by name from Python (``kp.ball_decay``, never per cycle) falls back on numpy's lookup
    (:meth:`__getattr__`), and so does ``data`` on a numpy copy or unpickled twin, which has no slot set:
    it answers as numpy does."""

    __slots__ = ("data",)
    __getattribute__ = object.__getattribute__

    def __getattr__(self, attr: str):
        if attr == "data":
            return _GENERIC_DATA.__get__(self, type(self))
        return np.record.__getattribute__(self, attr)


def kernel_record(values: tuple) -> KernelTable:
    """A NamedTuple of floats as a numpy record with the same fields and the same numbers."""
    dtype = np.dtype([(name, np.float64) for name in values._fields])
    raw = np.zeros(dtype.itemsize, dtype=np.uint8)
    table = raw.view(np.dtype((KernelTable, dtype)))
    table[0] = tuple(values)
    record = table[0]
    KernelTable.data.__set__(record, raw)
    return record


__all__ = ["KernelTable", "kernel_record"]

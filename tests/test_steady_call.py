"""core.jit.SteadyCall: a kernel called from Python with the same arrays, records and tuples every time
skips numba's typing of its arguments, and still runs the same code on the same values; any other call
goes through numba's dispatcher."""

from __future__ import annotations

import pickle
from copy import deepcopy
from typing import NamedTuple

import numba
import numpy as np
import pytest

from keepaway.agents.config import AgentConfig
from keepaway.core.jit import SteadyCall, borrowing
from keepaway.core.records import KernelTable
from keepaway.protocol.params import parameter_set


class Pair(NamedTuple):
    a: np.ndarray
    b: np.ndarray


@numba.njit
def scaled_sum(pair, factor, kp, out):
    """Writes into ``out`` and returns a value of the scalar's type: both show which code ran."""
    out[0] = (pair.a.sum() + pair.b.sum()) * kp.ball_decay
    return factor * 3


KP = parameter_set("classic").kernel()


def refuse(*_args):
    raise AssertionError("the dispatcher was called")


def test_a_repeated_call_runs_the_bound_code_without_the_dispatcher():
    pair, out = Pair(np.arange(3.0), np.ones(2)), np.zeros(1)
    call = SteadyCall(scaled_sum)
    assert call(pair, 2, KP, out) == 6 and out[0] == pytest.approx(5.0 * 0.94)
    call.kernel = refuse  # from here on only the bound entry point may run
    pair.a[:] = 10.0
    assert call(pair, 5, KP, out) == 15
    assert out[0] == 32.0 * 0.94  # the same arrays, read afresh
    with pytest.raises(AssertionError, match="dispatcher"):
        call(Pair(pair.a, pair.b), 5, KP, out)  # an equal but other tuple is not the bound one


def test_other_objects_or_scalar_types_go_through_the_dispatcher_and_give_its_results():
    pair, out = Pair(np.arange(3.0), np.ones(2)), np.zeros(1)
    call = SteadyCall(scaled_sum)
    assert call(pair, 2, KP, out) == 6
    assert call(pair, 1.5, KP, out) == 4.5  # a float where an int was bound: typed afresh
    assert type(call(pair, 2, KP, out)) is int
    other = Pair(np.arange(6, dtype=np.float64).reshape(2, 3), np.ones((2, 2)))  # 2-d arrays: another type
    assert call(other, 1, KP, out) == 3 and out[0] == pytest.approx(19.0 * 0.94)
    assert call(pair, True, KP, out) == 3  # a bool is typed as a bool, not as the int it subclasses
    assert out[0] == pytest.approx(5.0 * 0.94)


@borrowing
def byte_sum(data, n) -> int:
    total = 0
    for i in range(n):
        total += data[i]
    return total


def test_bytes_are_bound_by_type_and_read_where_they_lie():
    """Any bytes object calls the bound entry point (numba types them all alike: a read-only uint8
    buffer), and the kernel reads each one's own bytes."""
    call = SteadyCall(byte_sum)
    assert call(b"\x01\x02\x03", 3) == 6
    entry = call._entry
    for data in (bytes(range(200)), b"", b"\xff" * 5000):
        assert call(data, len(data)) == sum(data)
        assert call._entry is entry


def test_kernel_tables_hand_numba_their_own_bytes():
    """A parameter table's ``data`` (what numba unboxes a record from) is the memory the record lives in,
    byte for byte what numpy's own buffer of the record holds; a copy answers as numpy does."""
    for table in (KP, AgentConfig().kernel()):
        assert isinstance(table, KernelTable)
        own = bytes(np.record.data.__get__(table))
        assert bytes(table.data) == own and len(own) == table.dtype.itemsize
        assert np.shares_memory(table.data, np.asarray(table.base))
    for copy in (np.array([KP], dtype=KP.dtype)[0], pickle.loads(pickle.dumps(KP)), deepcopy(KP)):
        assert isinstance(copy.data, memoryview)  # numpy's own buffer, not the original's bytes
        assert bytes(copy.data) == bytes(np.record.data.__get__(KP))
    assert numba.njit(lambda kp: kp.player_decay)(KP) == 0.4


@numba.njit
def constant():
    return 7


@numba.njit
def plus_one(x=1.0):
    return x + 1.0


def test_calls_of_no_or_one_argument_or_of_another_count_bind_and_fall_back_alike():
    """The bound test is written out for the number of arguments bound: none and one work, and a call
    with another number of them goes through the dispatcher (which knows the kernel's defaults)."""
    call = SteadyCall(constant)
    assert call() == 7 and call() == 7 and call._entry is not None
    call = SteadyCall(plus_one)
    assert call(2.0) == 3.0
    entry = call._entry
    assert call(5.0) == 6.0 and call._entry is entry
    call.kernel = refuse
    with pytest.raises(AssertionError, match="dispatcher"):
        call()  # no argument where one was bound
    call.kernel = plus_one
    assert call() == 2.0 and call(3.0) == 4.0

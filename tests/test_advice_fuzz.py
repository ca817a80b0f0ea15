"""Property tests of the advice codec (protocol/advice.py): every valid advice and report survives the wire
unchanged, and whatever payload arrives, decoding gives a typed value or a ProtocolError, never another
exception (docs/advice.md; the ports' codec is fuzzed the same way in tests/test_protocol_fuzz.py)."""

from __future__ import annotations

import msgpack
import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from test_protocol_fuzz import FUZZ, HOSTILE, MSGPACK_VALUES, paths, plain, replace_at

from keepaway.protocol import ProtocolError, encode
from keepaway.protocol.advice import (
    ADVICE_KINDS,
    ARRAY_DTYPES,
    GETOPEN_POLICY_NAMES,
    PASS_MODES,
    PASS_POLICY_NAMES,
    REPORT_KINDS,
    REPORTS,
    PassLoadAdvice,
    PassModeAdvice,
    PassSnapshotReport,
    PassTransitionsReport,
    PolicyAdvice,
    ReportRequest,
    SeedAdvice,
    decode_advice,
    decode_report,
)
from keepaway.protocol.arena import RunEpisodes, decode_from_trainer

FINITE = st.floats(allow_nan=False, allow_infinity=False)
CHUNK = st.integers(1, 4).flatmap(lambda chunks: st.tuples(st.integers(0, chunks - 1), st.just(chunks)))


def arrays(name: str, size: int, elements=None):
    dtype = np.dtype(ARRAY_DTYPES[name])
    if elements is None:
        info = np.iinfo(dtype) if dtype.kind in "iu" else None
        elements = st.integers(int(info.min), int(info.max)) if info is not None else FINITE
    return st.lists(elements, min_size=size, max_size=size).map(lambda values: np.array(values, dtype=dtype))


@st.composite
def sparse_chunks(draw, cls, **head):
    chunk, chunks = draw(CHUNK)
    table_size = 2 ** draw(st.integers(1, 32))
    count = draw(st.integers(0, 6))
    index = st.integers(0, min(table_size, 2**32) - 1)
    config = draw(st.dictionaries(st.text(max_size=8), st.booleans() | st.integers(-(2**63), 2**63 - 1) | FINITE,
                                  max_size=4))
    return cls(**head, chunk=chunk, chunks=chunks, first=draw(st.integers(0, 2**32)), count=count,
               config={**config, "table_size": table_size}, table_size=table_size,
               hash_counts=draw(arrays("hash_counts", 3)), index=draw(arrays("index", count, index)),
               check=draw(arrays("check", count)), value=draw(arrays("value", count)))


@st.composite
def transitions_reports(draw):
    chunk, chunks = draw(CHUNK)
    count, n_vars = draw(st.integers(0, 5)), draw(st.integers(1, 4))
    return PassTransitionsReport(
        learner=True, episode=draw(st.integers(0, 2**31 - 1)), chunk=chunk, chunks=chunks,
        first=draw(st.integers(0, 2**32)), count=count, dropped=draw(st.integers(0, 2**32)), n_vars=n_vars,
        state=draw(arrays("state", count * n_vars, st.floats())).reshape(count, n_vars),
        action=draw(arrays("action", count, st.integers(0, 127))), reward=draw(arrays("reward", count, st.floats())),
        next_action=draw(arrays("next_action", count, st.integers(-1, 127))),
        terminal=draw(arrays("terminal", count, st.integers(0, 1))))


def empty_report(cls):
    return st.builds(cls, learner=st.just(False), episode=st.integers(0, 2**31 - 1), chunk=st.just(0),
                     chunks=st.just(1), first=st.just(0), count=st.just(0))


ADVICE = (
    st.builds(PolicyAdvice, getopen_theta=st.none() | arrays("getopen_theta", 91) | st.lists(FINITE, max_size=8),
              pass_policy=st.none() | st.sampled_from(PASS_POLICY_NAMES),
              getopen_policy=st.none() | st.sampled_from(GETOPEN_POLICY_NAMES))
    | st.builds(PassModeAdvice, mode=st.sampled_from(PASS_MODES))
    | st.builds(SeedAdvice, seed=st.integers(0, 2**64 - 1))
    | st.builds(ReportRequest, what=st.sampled_from(REPORTS))
    | sparse_chunks(PassLoadAdvice)
)
REPORT = (
    transitions_reports() | empty_report(PassTransitionsReport) | empty_report(PassSnapshotReport)
    | sparse_chunks(PassSnapshotReport, learner=True, episode=3)
)
KIND_NAMES = sorted({*ADVICE_KINDS, *REPORT_KINDS, "x"})
FIELD_NAMES = sorted({"kind", "pass", "getopen", "getopen_theta", "mode", "seed", "what", "chunk", "chunks", "first",
                      "count", "config", "table_size", "learner", "episode", "dropped", "n_vars", *ARRAY_DTYPES})


def decode_or_reject(decode, payload):
    """``decode``, with ProtocolError turned into None; any other exception fails the test. What is
    accepted re-encodes to the same value."""
    try:
        value = decode(payload)
    except ProtocolError as exc:
        assert exc.code and exc.message and "\n" not in exc.message
        return None
    assert decode(plain(value.to_wire())) == value
    return value


@FUZZ
@given(ADVICE)
def test_valid_advice_round_trips(advice):
    wire = plain(advice.to_wire())
    assert decode_advice(wire) == advice
    assert decode_advice(plain(decode_advice(wire).to_wire())) == advice


@FUZZ
@given(REPORT)
def test_valid_reports_round_trip(report):
    assert decode_report(plain(report.to_wire())) == report


@FUZZ
@given(MSGPACK_VALUES | HOSTILE)
def test_arbitrary_payloads_are_typed_or_refused(value):
    for decode in (decode_advice, decode_report):
        decode_or_reject(decode, plain(value))


@FUZZ
@given(st.sampled_from(KIND_NAMES), st.dictionaries(st.sampled_from(FIELD_NAMES), MSGPACK_VALUES | HOSTILE, max_size=8))
def test_arbitrary_fields_under_a_known_kind_are_typed_or_refused(kind, fields):
    payload = plain({**fields, "kind": kind})
    for decode in (decode_advice, decode_report):
        decode_or_reject(decode, payload)


@FUZZ
@given(ADVICE | REPORT, st.data())
def test_mutated_valid_payloads_are_refused_cleanly_or_stay_stable(message, data):
    wire = plain(message.to_wire())
    path = data.draw(st.sampled_from(list(paths(wire))))
    operation = data.draw(st.sampled_from(["replace", "hostile", "remove", "add", "bytes"]))
    if operation in ("replace", "hostile", "bytes"):
        new = data.draw({"replace": MSGPACK_VALUES, "hostile": HOSTILE, "bytes": st.binary(max_size=40)}[operation])
        wire = replace_at(wire, path, new)
    elif operation == "remove" and len(path) == 1:
        wire = {k: v for k, v in wire.items() if k != path[0]}
    elif operation == "add":
        wire = {**wire, data.draw(st.sampled_from(FIELD_NAMES)): data.draw(MSGPACK_VALUES)}
    decode = decode_advice if message.TYPE in ADVICE_KINDS else decode_report
    decode_or_reject(decode, plain(wire))


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(["keepers", "all"]), ADVICE), max_size=3), st.data())
def test_run_episodes_frames_with_advice_decode_or_fail_cleanly(advice, data):
    request = RunEpisodes(episodes=1, advice=tuple(advice))
    assert decode_from_trainer(encode(request)) == request
    frame = msgpack.unpackb(encode(request), raw=False)
    if frame["advice"]:
        target = data.draw(st.sampled_from(list(paths(frame["advice"]))))
        frame["advice"] = replace_at(frame["advice"], target, data.draw(MSGPACK_VALUES | HOSTILE))
    try:
        decode_from_trainer(msgpack.packb(frame, use_bin_type=True))
    except ProtocolError as exc:
        assert "\n" not in exc.message

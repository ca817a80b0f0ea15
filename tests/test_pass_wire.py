"""The sparse wire form of a keeper's Pass policy (agents/pass_wire.py, docs/advice.md): snapshot reports
and ``pass_load`` advice carry the Sarsa collision table's occupied slots, in chunks. Each chunk on its
own is checked by the protocol (tests/test_advice.py); here, cutting and putting together again.
"""

from __future__ import annotations

from dataclasses import asdict, replace

import numpy as np
import pytest

import keepaway.agents.pass_wire as pass_wire
from keepaway.agents.pass_wire import pass_arrays_from_chunks, sparse_pass_chunks
from keepaway.agents.sarsa import SarsaConfig
from keepaway.protocol import encode
from keepaway.protocol import messages as m
from keepaway.protocol.advice import PassLoadAdvice, PassSnapshotReport, decode_report
from keepaway.protocol.messages import decode_from_player

CONFIG = SarsaConfig(table_size=16, alpha=0.25)
HEAD = {"episode": 7, "learner": True}


def policy_arrays():
    """A 16-slot table: slots 2, 5, 9 and 14 occupied (check values), slot 11 empty with a weight of its
    own (a hand-made file), slot 5 occupied with weight 0."""
    weights = np.zeros(16)
    check = np.full(16, -1, dtype=np.int32)
    check[[2, 5, 9, 14]] = [70, 2**31 - 1, 0, 12345]
    weights[[2, 9, 11, 14]] = [1.5, -0.25, 3.0, 1e-300]
    return {"pass_weights": weights, "pass_hash_check": check,
            "pass_hash_counts": np.array([40, 36, 9], dtype=np.int64)}


def assert_same(arrays, expected):
    assert sorted(arrays) == sorted(expected)
    for name, value in expected.items():
        np.testing.assert_array_equal(arrays[name], value, err_msg=name)
        assert arrays[name].dtype == value.dtype, name


def snapshot(monkeypatch=None, report_bytes=None):
    if report_bytes is not None:
        monkeypatch.setattr(pass_wire, "REPORT_BYTES", report_bytes)
    return sparse_pass_chunks(policy_arrays(), CONFIG, PassSnapshotReport, **HEAD)


def test_one_chunk_holds_the_occupied_slots_in_order_and_round_trips():
    (p,) = snapshot()
    # slots occupied (2, 5, 9, 14) or with a weight (11), in slot order
    wire = decode_from_player(encode(m.Report(cycle=3, payload=p.to_wire()))).payload
    decoded = decode_report(wire)  # through the protocol's rules and back (a report as the server relays it)
    assert decoded == p
    assert decoded.index.tolist() == [2, 5, 9, 11, 14]
    assert decoded.check.tolist() == [70, 2**31 - 1, 0, -1, 12345]
    assert decoded.value.tolist() == [1.5, 0.0, -0.25, 3.0, 1e-300]
    assert decoded.hash_counts.tolist() == [40, 36, 9]
    assert (p.chunk, p.chunks, p.first, p.count, p.table_size) == (0, 1, 0, 5, 16)
    assert p.config == asdict(CONFIG) and wire["kind"] == "pass_snapshot" and p.episode == 7
    config, arrays = pass_arrays_from_chunks([decoded])
    assert config == CONFIG
    assert_same(arrays, policy_arrays())


def test_chunks_hold_at_most_report_bytes_and_reassemble_in_any_order(monkeypatch):
    # 16 B per slot (4 index + 4 check + 8 value): 40 B per chunk allows 40 // 16 = 2 slots, so the 5
    # slots travel as chunks of 2, 2, 1 starting at entries 0, 2, 4.
    chunks = sparse_pass_chunks(policy_arrays(), CONFIG, PassLoadAdvice)
    assert len(chunks) == 1
    monkeypatch.setattr(pass_wire, "REPORT_BYTES", 40)
    chunks = sparse_pass_chunks(policy_arrays(), CONFIG, PassLoadAdvice)
    assert [(p.chunk, p.chunks, p.first, p.count) for p in chunks] == [(0, 3, 0, 2), (1, 3, 2, 2), (2, 3, 4, 1)]
    for p in chunks:
        wire = p.to_wire()
        assert wire["kind"] == "pass_load"
        assert len(wire["index"]) + len(wire["check"]) + len(wire["value"]) <= 40
    config, arrays = pass_arrays_from_chunks(chunks[::-1])
    assert config == CONFIG
    assert_same(arrays, policy_arrays())


def test_an_empty_table_is_one_chunk_of_no_slots():
    empty = {"pass_weights": np.zeros(16), "pass_hash_check": np.full(16, -1, dtype=np.int32),
             "pass_hash_counts": np.zeros(3, dtype=np.int64)}
    (p,) = sparse_pass_chunks(empty, CONFIG, PassLoadAdvice)
    wire = p.to_wire()
    assert (p.count, wire["index"], wire["check"], wire["value"]) == (0, b"", b"", b"")
    assert_same(pass_arrays_from_chunks([p])[1], empty)


def test_arrays_that_do_not_fit_the_config_are_refused():
    with pytest.raises(ValueError, match="do not fit table_size 32"):
        sparse_pass_chunks(policy_arrays(), SarsaConfig(table_size=32), PassLoadAdvice)


NO_LEARNER = PassSnapshotReport(learner=False, episode=1, chunk=0, chunks=1, first=0, count=0)


@pytest.mark.parametrize("damage, problem", [
    (lambda c: [], "no Pass chunks"),
    (lambda c: [c[0], c[2]], r"missing chunks \[1\] of 3"),
    (lambda c: [c[0], c[1], c[1], c[2]], "duplicate chunk 1"),
    (lambda c: [c[0], c[1], replace(c[2], chunks=4)], "disagree on their number"),
    (lambda c: [NO_LEARNER], "chunk 0 holds no Pass policy"),
    (lambda c: [c[0], replace(c[1], config={**c[1].config, "alpha": 0.5}), c[2]], "chunk 1's config differs"),
    (lambda c: [c[0], replace(c[1], hash_counts=np.zeros(3, "<i8")), c[2]], "chunk 1's hash_counts differ"),
    (lambda c: [replace(p, config={**p.config, "gamma": 0.5}) for p in c], "bad config: the SMDP update"),
    (lambda c: [replace(p, config={**p.config, "colour": 1}) for p in c], "bad config: .*colour"),
    (lambda c: [c[0], replace(c[1], first=1), c[2]], "chunk 1 holds entries first=1 count=2; expected first=2"),
    (lambda c: [c[0], c[1], replace(c[2], index=np.array([2], "<u4"))], "repeated slot indices"),
])
def test_bad_chunks_are_one_line_errors(monkeypatch, damage, problem):
    with pytest.raises(ValueError, match=problem) as info:
        pass_arrays_from_chunks(damage(snapshot(monkeypatch, 40)))
    assert "\n" not in str(info.value)

"""The sparse wire form of a keeper's Pass policy (agents/pass_wire.py, docs/advice.md): snapshot reports
and ``pass_load`` advice carry the Sarsa collision table's occupied slots, in chunks.
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pytest

import agents.pass_wire as pass_wire
from agents.pass_wire import chunk_position, pass_arrays_from_payloads, report_arrays, sparse_pass_payloads
from agents.sarsa import SarsaConfig
from protocol import encode
from protocol import messages as m
from protocol.messages import decode_from_player

CONFIG = SarsaConfig(table_size=16, alpha=0.25)
HEAD = {"kind": "pass_snapshot", "episode": 7, "learner": True}


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


def test_one_chunk_holds_the_occupied_slots_in_order_and_round_trips():
    payloads = sparse_pass_payloads(policy_arrays(), CONFIG, HEAD)
    (p,) = payloads
    # slots occupied (2, 5, 9, 14) or with a weight (11), in slot order
    decoded = report_arrays(p)
    assert decoded["index"].tolist() == [2, 5, 9, 11, 14]
    assert decoded["check"].tolist() == [70, 2**31 - 1, 0, -1, 12345]
    assert decoded["value"].tolist() == [1.5, 0.0, -0.25, 3.0, 1e-300]
    assert decoded["hash_counts"].tolist() == [40, 36, 9]
    assert (p["chunk"], p["chunks"], p["first"], p["count"], p["table_size"]) == (0, 1, 0, 5, 16)
    assert p["config"] == asdict(CONFIG) and p["kind"] == "pass_snapshot" and p["episode"] == 7
    # through the protocol's payload rules and back (a report as the server decodes it)
    wire = decode_from_player(encode(m.Report(cycle=3, payload=p))).payload
    config, arrays = pass_arrays_from_payloads([wire])
    assert config == CONFIG
    assert_same(arrays, policy_arrays())


def test_chunks_hold_at_most_report_bytes_and_reassemble_in_any_order(monkeypatch):
    # 16 B per slot (4 index + 4 check + 8 value): 40 B per chunk allows 40 // 16 = 2 slots, so the 5
    # slots travel as chunks of 2, 2, 1 starting at entries 0, 2, 4.
    monkeypatch.setattr(pass_wire, "REPORT_BYTES", 40)
    payloads = sparse_pass_payloads(policy_arrays(), CONFIG, HEAD)
    assert [(p["chunk"], p["chunks"], p["first"], p["count"]) for p in payloads] == [
        (0, 3, 0, 2), (1, 3, 2, 2), (2, 3, 4, 1)]
    for p in payloads:
        assert len(p["index"]) + len(p["check"]) + len(p["value"]) <= 40
    config, arrays = pass_arrays_from_payloads(payloads[::-1])
    assert config == CONFIG
    assert_same(arrays, policy_arrays())


def test_an_empty_table_is_one_chunk_of_no_slots():
    empty = {"pass_weights": np.zeros(16), "pass_hash_check": np.full(16, -1, dtype=np.int32),
             "pass_hash_counts": np.zeros(3, dtype=np.int64)}
    (p,) = sparse_pass_payloads(empty, CONFIG, {})
    assert (p["count"], p["index"], p["check"], p["value"]) == (0, b"", b"", b"")
    assert_same(pass_arrays_from_payloads([p])[1], empty)


def test_arrays_that_do_not_fit_the_config_are_refused():
    with pytest.raises(ValueError, match="do not fit table_size 32"):
        sparse_pass_payloads(policy_arrays(), SarsaConfig(table_size=32), HEAD)


def chunks(monkeypatch):
    monkeypatch.setattr(pass_wire, "REPORT_BYTES", 40)
    return sparse_pass_payloads(policy_arrays(), CONFIG, HEAD)


def edited(payload, **fields):
    return {**payload, **fields}


@pytest.mark.parametrize("damage, problem", [
    (lambda c: [], "no Pass payloads"),
    (lambda c: [c[0], c[2]], r"missing chunks \[1\] of 3"),
    (lambda c: [c[0], c[1], c[1], c[2]], "duplicate chunk 1"),
    (lambda c: [c[0], c[1], edited(c[2], chunks=4)], "disagree on their number"),
    (lambda c: [c[0], c[1], edited(c[2], chunk=3)], "chunk 3 of 3 is not an integer 0 <= chunk < chunks"),
    (lambda c: [c[0], c[1], edited(c[2], chunk="2")], "chunk '2' of 3"),
    (lambda c: [c[0], c[1], [1, 2]], "a chunk must be a map, not list"),
    (lambda c: [c[0], edited(c[1], table_size=32), c[2]], "chunk 1's table_size differs from chunk 0's"),
    (lambda c: [c[0], edited(c[1], config={}), c[2]], "chunk 1's config differs"),
    (lambda c: [c[0], {k: v for k, v in c[1].items() if k != "hash_counts"}, c[2]], "chunk 1 lacks hash_counts"),
    (lambda c: [edited(p, config={**p["config"], "table_size": 15}) for p in c], "bad config: table_size must be"),
    (lambda c: [edited(p, config={**p["config"], "colour": 1}) for p in c], "bad config: .*colour"),
    (lambda c: [edited(p, config=[1]) for p in c], "config must be a map"),
    (lambda c: [edited(p, table_size=32) for p in c], "table_size 32 is not the config's 16"),
    (lambda c: [edited(p, hash_counts=b"\0" * 16) for p in c], "hash_counts is 16 bytes, expected 24"),
    (lambda c: [c[0], edited(c[1], first=1), c[2]], "chunk 1 holds entries first=1 count=2; expected first=2"),
    (lambda c: [c[0], edited(c[1], count=3), c[2]], "chunk 1: index is 8 bytes, expected 12"),
    (lambda c: [c[0], edited(c[1], value=[0.0, 1.0]), c[2]], "chunk 1: value is list"),
    (lambda c: [c[0], c[1], edited(c[2], index=np.array([16], "<u4").tobytes())], "slot index 16 is outside"),
    (lambda c: [c[0], c[1], edited(c[2], index=np.array([2], "<u4").tobytes())], "repeated slot indices"),
    (lambda c: [c[0], c[1], edited(c[2], value=np.array([np.nan], "<f8").tobytes())], "1 non-finite weights"),
])
def test_bad_chunks_are_one_line_errors(monkeypatch, damage, problem):
    with pytest.raises(ValueError, match=problem) as info:
        pass_arrays_from_payloads(damage(chunks(monkeypatch)))
    assert "\n" not in str(info.value)


def test_chunk_position_reads_a_chunks_place():
    assert chunk_position({"chunk": 2, "chunks": 3}) == (2, 3)
    for bad in ({"chunk": True, "chunks": 3}, {"chunk": -1, "chunks": 3}, {"chunks": 3}):
        with pytest.raises(ValueError):
            chunk_position(bad)

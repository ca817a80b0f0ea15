"""The coach's advice and the keepers' reports as protocol messages (protocol/advice.py, docs/advice.md):
their wire forms, their validation, and the arena port's messages that carry them."""

from __future__ import annotations

import msgpack
import numpy as np
import pytest

from keepaway.protocol import ProtocolError, encode
from keepaway.protocol.advice import (
    PassLoadAdvice,
    PassModeAdvice,
    PassSnapshotReport,
    PolicyAdvice,
    ReportRequest,
    SeedAdvice,
    advice_kind,
    decode_advice,
    decode_report,
)
from keepaway.protocol.arena import EpisodesDone, RunEpisodes, decode_for_trainer, decode_from_trainer

F8 = np.dtype("<f8")
CONFIG = {"table_size": 16, "alpha": 0.25, "code_widths": False}


def plain(value):
    """As msgpack delivers it."""
    return msgpack.unpackb(msgpack.packb(value, use_bin_type=True), raw=False)


def load_chunk(**changes) -> dict:
    """A valid pass_load chunk of two slots (3 and 9) on the wire."""
    wire = {"kind": "pass_load", "chunk": 0, "chunks": 1, "first": 0, "count": 2, "config": CONFIG,
            "table_size": 16, "hash_counts": np.array([5, 1, 0], "<i8").tobytes(),
            "index": np.array([3, 9], "<u4").tobytes(), "check": np.array([7, -1], "<i4").tobytes(),
            "value": np.array([0.5, -2.0], "<f8").tobytes()}
    return {**wire, **changes}


def transitions(**changes) -> dict:
    """A valid pass_transitions report of two transitions of 2 state variables on the wire."""
    wire = {"kind": "pass_transitions", "learner": True, "episode": 4, "chunk": 0, "chunks": 1, "first": 10,
            "count": 2, "dropped": 0, "n_vars": 2, "state": np.arange(4.0).tobytes(),
            "action": bytes([0, 2]), "reward": np.array([3.0, 5.0]).tobytes(), "next_action": bytes([2, 255]),
            "terminal": bytes([0, 1])}
    return {**wire, **changes}


def test_the_advice_kinds_have_the_documented_wire_forms():
    theta = np.array([0.5, -1.0, 2.0])
    assert PolicyAdvice(getopen_theta=theta, pass_policy="hold").to_wire() == {
        "kind": "policy", "getopen_theta": theta.astype(F8).tobytes(), "pass": "hold"}
    assert PolicyAdvice(getopen_policy="handcoded-cone").to_wire() == {"kind": "policy", "getopen": "handcoded-cone"}
    assert PassModeAdvice(mode="explore").to_wire() == {"kind": "pass_mode", "mode": "explore"}
    assert SeedAdvice(seed=2**64 - 1).to_wire() == {"kind": "seed", "seed": 2**64 - 1}
    assert ReportRequest(what="transitions").to_wire() == {"kind": "report", "what": "transitions"}
    assert PassSnapshotReport(learner=False, episode=3, chunk=0, chunks=1, first=0, count=0).to_wire() == {
        "kind": "pass_snapshot", "learner": False, "episode": 3, "chunk": 0, "chunks": 1, "first": 0, "count": 0}


def test_decoded_advice_holds_typed_values_and_read_only_arrays():
    from_list = decode_advice({"kind": "policy", "getopen_theta": [1, 2.5, -3], "pass": None})
    from_bin = decode_advice(plain({"kind": "policy", "getopen_theta": np.array([1.0, 2.5, -3.0]).tobytes()}))
    assert from_list == from_bin and from_list.pass_policy is None
    for advice in (from_list, from_bin):
        assert advice.getopen_theta.dtype == F8 and not advice.getopen_theta.flags.writeable
        assert advice.getopen_theta.tolist() == [1.0, 2.5, -3.0]
    chunk = decode_advice(plain(load_chunk()))
    assert isinstance(chunk, PassLoadAdvice) and chunk.index.tolist() == [3, 9] and chunk.check.tolist() == [7, -1]
    assert chunk.value.tolist() == [0.5, -2.0] and chunk.hash_counts.tolist() == [5, 1, 0]
    assert decode_advice(chunk.to_wire()) == chunk
    report = decode_report(plain(transitions()))
    arrays = report.arrays()
    assert arrays["state"].tolist() == [[0.0, 1.0], [2.0, 3.0]] and arrays["next_action"].tolist() == [2, -1]
    assert arrays["terminal"].tolist() == [False, True] and arrays["reward"].tolist() == [3.0, 5.0]


@pytest.mark.parametrize("payload, code, problem", [
    ({"kind": "seed"}, "missing_field", "seed: missing field 'seed'"),
    ({"kind": "seed", "seed": -1}, "bad_value", "seed.seed: -1 is outside"),
    ({"kind": "seed", "seed": True}, "bad_type", "seed.seed: expected an int, got bool"),
    ({"kind": "seed", "seed": 1, "colour": 2}, "unknown_field", "seed: unknown field 'colour'"),
    ({"kind": "pass_mode", "mode": "sleep"}, "bad_value", "pass_mode.mode: 'sleep' is not one of"),
    ({"kind": "report", "what": ["snapshot"]}, "bad_type", "report.what: expected a str"),
    ({"kind": "policy", "pass": "telepathy"}, "bad_value", "policy.pass: 'telepathy' is not one of"),
    ({"kind": "policy", "getopen_theta": [0.5, float("nan")]}, "bad_value", r"policy.getopen_theta\[1\]: nan"),
    ({"kind": "policy", "getopen_theta": np.array([np.inf]).tobytes()}, "bad_value", "1 non-finite values"),
    ({"kind": "policy", "getopen_theta": b"\0" * 12}, "bad_value", "12 bytes are not a whole number of <f8"),
    (load_chunk(chunk=1), "bad_value", "chunk 1 of 1: chunks are numbered 0 .. chunks - 1"),
    (load_chunk(count=3), "bad_value", "index holds 2 values, expected 3"),
    (load_chunk(index=np.array([3, 16], "<u4").tobytes()), "bad_value", "slot index 16 is outside the table of 16"),
    (load_chunk(value=np.array([0.5, np.nan]).tobytes()), "bad_value", "pass_load.value: 1 non-finite values"),
    (load_chunk(value=[0.5, -2.0]), "bad_type", "pass_load.value: expected bin of <f8 values, got array"),
    (load_chunk(hash_counts=b"\0" * 16), "bad_value", "hash_counts holds 2 values, expected 3"),
    (load_chunk(table_size=32), "bad_value", "table_size 32 is not the config's 16"),
    (load_chunk(table_size=24), "bad_value", "pass_load.table_size: 24 is not a power of 2"),
    (load_chunk(config=[1]), "bad_type", "pass_load.config: expected a map, got array"),
    (load_chunk(config={**CONFIG, "alpha": "fast"}), "bad_type", "pass_load.config: 'alpha' is a str"),
    ({k: v for k, v in load_chunk().items() if k != "check"}, "missing_field", "missing field 'check' in a pass_load"),
    (load_chunk(episode=3), "unknown_field", "pass_load: unknown field 'episode'"),
])
def test_bad_advice_is_one_protocol_error_in_one_line(payload, code, problem):
    with pytest.raises(ProtocolError, match=problem) as info:
        decode_advice(plain(payload))
    assert info.value.code == code and "\n" not in str(info.value)


@pytest.mark.parametrize("payload, problem", [
    (transitions(count=3), "action holds 2 values, expected 3"),
    (transitions(n_vars=3), "state holds 4 values, expected 6"),
    (transitions(action=bytes([0, 255])), "actions must be >= 0"),
    (transitions(terminal=bytes([0, 2])), "terminal 0 or 1"),
    ({**transitions(), "learner": False}, "unexpected field 'dropped' with learner false"),
    ({"kind": "pass_snapshot", "learner": False, "episode": 1, "chunk": 0, "chunks": 2, "first": 0, "count": 0},
     "a report without a learner is one chunk of no entries"),
    ({"kind": "pass_snapshot", "learner": True, "episode": 1, "chunk": 0, "chunks": 1, "first": 0, "count": 0},
     "missing field 'config' with learner true"),
])
def test_bad_reports_are_one_protocol_error(payload, problem):
    with pytest.raises(ProtocolError, match=problem):
        decode_report(plain(payload))


def test_only_payloads_of_a_known_kind_are_advice():
    assert advice_kind({"kind": "seed", "seed": "bad"}) is SeedAdvice  # known: decoded, then refused
    for unknown in ("seed", [1], {}, {"kind": 3}, {"kind": "pass_snapshot"}, {"kind": "telepathy"}):
        assert advice_kind(unknown) is None
    with pytest.raises(ProtocolError, match="'pass_snapshot' is not accepted here"):
        decode_advice({"kind": "pass_snapshot"})


def test_the_arena_port_carries_typed_advice_and_reports_and_refuses_bad_advice():
    request = RunEpisodes(episodes=2, seed=5, advice=(("keepers", PassModeAdvice(mode="learn")),
                                                      (("l", 2), decode_advice(plain(load_chunk())))),
                          reports=("transitions",))
    again = decode_from_trainer(encode(request))
    assert again.advice == request.advice and again.seed == 5
    assert type(again.advice[1][1]) is PassLoadAdvice and again.advice[1][0] == ("l", 2)
    done = EpisodesDone(cycle=9, episodes=([1, 0, 9, "out"],), reports=(("l", 1, decode_report(plain(transitions()))),))
    assert decode_for_trainer(encode(done)).reports == done.reports
    bad = msgpack.packb({"type": "run_episodes", "episodes": 1, "advice": [["keepers", {"kind": "seed", "seed": -2}]]})
    with pytest.raises(ProtocolError, match=r"run_episodes.advice\[0\]\[1\]: seed.seed: -2 is outside") as info:
        decode_from_trainer(bad)
    assert info.value.code == "bad_value"

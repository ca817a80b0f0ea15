"""Pass learning in a player process (agents/player.py, ``--pass learned``): the coach's ``pass_mode``
advice, taken up at the next episode boundary, and the learner's reports to the coach.

Spec `keepaway-agents.md` 5 (modes, per-keeper learners), `architecture.md` (coach advice, reports). The
game is the embedded one of ``tests/test_player.py`` (Arena + PlayerAgents, no sockets).
"""

from __future__ import annotations

import numpy as np
import pytest

from agents.player import REPORT_BYTES, PlayerAgent, report_arrays, sarsa_pass_factory
from agents.policy_file import load_policy, save_policy
from agents.sarsa import MODE_GREEDY, MODE_LEARN, SarsaConfig, SarsaLearner
from protocol import encode
from protocol import messages as m
from protocol.endpoints import DEFAULT_MAX_MESSAGE_BYTES
from protocol.messages import decode_from_player
from test_player import K, Game

SMALL = SarsaConfig(table_size=1 << 15)
LEARNED = {"pass_policy": "learned", "pass_learner": sarsa_pass_factory(None, MODE_GREEDY, SMALL)}


def play_episodes(game: Game, n: int) -> None:
    """Play until ``n`` episodes have ended and the keepers have heard the last boundary."""
    ended = 0
    while ended < n:
        _, record = game.cycle()
        ended += record is not None
    game.percepts()


def keepers(game: Game) -> list[PlayerAgent]:
    return [game.agent(obj) for obj in range(1, K + 1)]


def test_without_a_policy_file_the_learner_starts_from_zeros_in_greedy_mode():
    game = Game(keeper_kw={"pass_policy": "learned"})
    for agent in keepers(game):
        assert isinstance(agent.learner, SarsaLearner) and agent.learner.mode == MODE_GREEDY
        assert agent.learner.config.table_size == SarsaConfig().table_size
        assert not agent.learner.memory.weights.any()


def test_learn_advice_applies_at_the_boundary_and_the_weights_change():
    game = Game(keeper_kw=LEARNED)
    for _ in range(5):
        game.cycle()
    game.arena.advise([1, 2, 3], {"kind": "pass_mode", "mode": "learn"})
    game.percepts()  # heard mid-episode: kept for the boundary
    assert [a.learner.mode for a in keepers(game)] == [MODE_GREEDY] * K
    play_episodes(game, 1)
    assert [a.learner.mode for a in keepers(game)] == [MODE_LEARN] * K
    np.testing.assert_array_equal(np.concatenate([a.learner.memory.weights[0] for a in keepers(game)]), 0.0)
    play_episodes(game, 3)
    changed = [bool(a.learner.memory.weights.any()) for a in keepers(game)]
    assert sum(changed) >= 2  # the keepers that had the ball learned


def test_greedy_advice_freezes_the_weights_from_the_next_episode():
    game = Game(keeper_kw={"pass_policy": "learned",
                           "pass_learner": sarsa_pass_factory(None, MODE_LEARN, SMALL)})
    play_episodes(game, 2)
    game.arena.advise([1, 2, 3], {"kind": "pass_mode", "mode": "greedy"})
    game.percepts()
    learning = [a.learner.mode for a in keepers(game)]
    play_episodes(game, 1)  # the episode under way still learns; its terminal update comes at the boundary
    frozen = [a.learner.memory.weights.copy() for a in keepers(game)]
    play_episodes(game, 2)
    assert learning == [MODE_LEARN] * K
    assert [a.learner.mode for a in keepers(game)] == [MODE_GREEDY] * K
    for agent, weights in zip(keepers(game), frozen):
        np.testing.assert_array_equal(agent.learner.memory.weights, weights)


def test_bad_advice_is_ignored_with_a_warning(caplog):
    game = Game(keeper_kw=LEARNED)
    game.arena.advise([1], {"kind": "pass_mode", "mode": "sleep"})
    game.arena.advise([2], {"kind": "report", "what": "everything"})
    game.percepts()
    assert game.agent(1).learner.mode == MODE_GREEDY and game.agent(2).pending_reports() == []
    text = " ".join(r.getMessage() for r in caplog.records)
    assert "mode 'sleep' is not one of" in text and "'everything' is not" in text
    # takers, and keepers with a built-in Pass policy, have no learner: advice is not for them
    plain = Game()
    plain.arena.advise([1], {"kind": "report", "what": "snapshot"})
    plain.percepts()
    assert plain.agent(1).pending_reports() == []


def test_transition_reports_carry_the_transitions_since_the_last_report():
    game = Game(keeper_kw={"pass_policy": "learned",
                           "pass_learner": sarsa_pass_factory(None, MODE_LEARN, SMALL)})
    play_episodes(game, 2)
    agent = max(keepers(game), key=lambda a: int(a.learner.memory.log_count[0]))
    logged = int(agent.learner.memory.log_count[0])
    assert logged > 0
    game.arena.advise([agent.unum], {"kind": "report", "what": "transitions"})
    game.percepts()
    (report,) = agent.pending_reports()
    assert agent.pending_reports() == []  # handed out once
    payload = report_arrays(report.payload)
    assert payload["kind"] == "pass_transitions" and payload["first"] == 0 and payload["count"] == logged
    assert payload["dropped"] == 0 and payload["chunks"] == 1
    expected = agent.learner.transitions()
    np.testing.assert_array_equal(payload["state"], expected["state"])
    np.testing.assert_array_equal(payload["reward"], expected["reward"])
    np.testing.assert_array_equal(payload["action"], expected["action"])
    np.testing.assert_array_equal(payload["terminal"], expected["terminal"])
    # the next report starts where this one ended
    play_episodes(game, 1)
    game.arena.advise([agent.unum], {"kind": "report", "what": "transitions"})
    game.percepts()
    (again,) = agent.pending_reports()
    assert again.payload["first"] == logged
    assert again.payload["count"] == int(agent.learner.memory.log_count[0]) - logged
    # the message passes the server's decoder
    assert decode_from_player(encode(report)).payload == report.payload


def test_a_snapshot_of_a_full_table_is_chunked_below_the_message_limit(tmp_path):
    # 2^20 non-zero weights = 12 MiB of (uint32 index, float64 value) pairs, 12 B each: chunks of
    # 2^20 // 12 = 87,381 pairs (< 1 MiB); 12 of them hold 1,048,572, a 13th the last 4.
    teacher = SarsaLearner(K, 2, SarsaConfig())
    arrays = teacher.save()
    arrays["pass_weights"][:] = np.arange(1, 2**20 + 1) / 7.0
    path = save_policy(tmp_path / "full.npz", pass_arrays=arrays, config={"keepers": K, "takers": 2})
    game = Game(keeper_kw={"pass_policy": "learned", "policy": load_policy(path)})
    agent = game.agent(1)
    game.arena.advise([1], {"kind": "report", "what": "snapshot"})
    game.percepts()
    reports = agent.pending_reports()
    assert [r.payload["count"] for r in reports] == [87_381] * 12 + [4]
    assert [r.payload["chunk"] for r in reports] == list(range(13)) and reports[0].payload["chunks"] == 13
    for r in reports:
        assert len(encode(r)) < DEFAULT_MAX_MESSAGE_BYTES and len(r.payload["value"]) <= REPORT_BYTES
    parts = [report_arrays(r.payload) for r in reports]
    index = np.concatenate([p["index"] for p in parts])
    value = np.concatenate([p["value"] for p in parts])
    np.testing.assert_array_equal(index, np.arange(2**20))
    np.testing.assert_array_equal(value, arrays["pass_weights"])
    assert {p["nonzero"] for p in parts} == {2**20} and {p["table_size"] for p in parts} == {2**20}


def test_an_empty_snapshot_is_one_small_report():
    game = Game(keeper_kw=LEARNED)
    game.arena.advise([1], {"kind": "report", "what": "snapshot"})
    game.percepts()
    (report,) = game.agent(1).pending_reports()
    assert report.payload["count"] == 0 and report.payload["nonzero"] == 0 and len(encode(report)) < 1024


@pytest.mark.parametrize("what", ["snapshot", "transitions"])
def test_a_learner_that_is_not_sarsa_cannot_report(what, caplog):
    class Hold:
        def start(self, state):
            return 0

        def step(self, reward, state):
            return 0

        def end(self, reward):
            pass

    game = Game(keeper_kw={"pass_policy": "learned", "pass_learner": lambda seq: Hold()})
    game.arena.advise([1], {"kind": "report", "what": what})
    game.percepts()
    assert game.agent(1).pending_reports() == []
    assert "not a Sarsa learner" in caplog.text


def test_transitions_lost_from_the_ring_buffer_are_counted_as_dropped():
    # A 4-transition log: a report after more than 4 transitions carries the last 4 and drops the rest.
    config = SarsaConfig(table_size=1 << 15, transition_log_size=4)
    game = Game(keeper_kw={"pass_policy": "learned", "pass_learner": sarsa_pass_factory(None, MODE_LEARN, config)})
    play_episodes(game, 3)
    agent = max(keepers(game), key=lambda a: int(a.learner.memory.log_count[0]))
    logged = int(agent.learner.memory.log_count[0])
    assert logged > 4
    game.arena.advise([agent.unum], {"kind": "report", "what": "transitions"})
    game.percepts()
    (report,) = agent.pending_reports()
    assert (report.payload["first"], report.payload["count"], report.payload["dropped"]) == (logged - 4, 4, logged - 4)

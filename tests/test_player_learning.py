"""Pass learning in a player process (agents/player.py, ``--pass learned``): the coach's ``pass_mode``
advice, taken up at the next episode boundary, and the learner's reports to the coach.

Spec `keepaway-agents.md` 5 (modes, per-keeper learners), `architecture.md` (coach advice, reports). The
game is the embedded one of ``tests/test_player.py`` (Arena + PlayerAgents, no sockets).
"""

from __future__ import annotations

import numpy as np
import pytest

import keepaway.agents.pass_wire as pass_wire
from keepaway.agents.pass_wire import pass_arrays_from_chunks, sparse_pass_chunks
from keepaway.agents.player import (
    EPISODE_MESSAGE,
    PASS_POLICIES,
    REPORT_BYTES,
    PlayerAgent,
    agent_seed_sequence,
    learner_seed,
    sarsa_pass_factory,
)
from keepaway.agents.policy_file import load_policy, save_policy
from keepaway.agents.sarsa import MODE_EXPLORE, MODE_GREEDY, MODE_LEARN, NO_ACTION, SarsaConfig, SarsaLearner
from keepaway.protocol import encode
from keepaway.protocol import messages as m
from keepaway.protocol.advice import PassLoadAdvice, decode_report
from keepaway.protocol.endpoints import DEFAULT_MAX_MESSAGE_BYTES
from keepaway.protocol.messages import decode_from_player
from keepaway.core.rng import seed_streams
from test_player import K, Game, wire

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


def busiest_learner(game: Game) -> tuple[PlayerAgent, int]:
    """The keeper whose learner logged the most transitions, and how many."""
    agent = max(keepers(game), key=lambda a: int(a.learner.memory.log_count[0]))
    return agent, int(agent.learner.memory.log_count[0])


def transitions_report(game: Game, agent: PlayerAgent):
    """``agent``'s one answer to the coach's transitions report request."""
    game.arena.advise([agent.unum], {"kind": "report", "what": "transitions"})
    game.percepts()
    (report,) = agent.pending_reports()
    return report


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
    game.arena.advise([3], {"kind": "pass_mode", "mode": ["learn"]})  # unhashable: still one line
    game.percepts()
    play_episodes(game, 1)
    assert [a.learner.mode for a in keepers(game)] == [MODE_GREEDY] * K and game.agent(2).pending_reports() == []
    text = " ".join(r.getMessage() for r in caplog.records)
    assert "pass_mode.mode: 'sleep' is not one of" in text and "report.what: 'everything' is not" in text
    assert "pass_mode.mode: expected a str" in text


def test_transition_reports_carry_the_transitions_since_the_last_report():
    game = Game(keeper_kw={"pass_policy": "learned",
                           "pass_learner": sarsa_pass_factory(None, MODE_LEARN, SMALL)})
    play_episodes(game, 2)
    agent, logged = busiest_learner(game)
    assert logged > 0
    report = transitions_report(game, agent)
    assert agent.pending_reports() == []  # handed out once
    assert report.payload["kind"] == "pass_transitions"
    decoded = decode_report(report.payload)
    assert decoded.first == 0 and decoded.count == logged
    assert decoded.dropped == 0 and decoded.chunks == 1 and decoded.learner is True
    payload = decoded.arrays()
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
    # 2^20 non-zero weights (empty collision table, so every slot travels because of its weight) =
    # 16 MiB of (uint32 index, int32 check, float64 value) triples, 16 B each: chunks of 2^20 // 16 =
    # 65,536 triples (exactly 1 MiB), 16 of them.
    teacher = SarsaLearner(K, 2, SarsaConfig())
    arrays = teacher.save()
    arrays["pass_weights"][:] = np.arange(1, 2**20 + 1) / 7.0
    path = save_policy(tmp_path / "full.npz", pass_arrays=arrays, config={"keepers": K, "takers": 2})
    game = Game(keeper_kw={"pass_policy": "learned", "policy": load_policy(path)})
    agent = game.agent(1)
    game.arena.advise([1], {"kind": "report", "what": "snapshot"})
    game.percepts()
    reports = agent.pending_reports()
    assert [r.payload["count"] for r in reports] == [65_536] * 16
    assert [r.payload["chunk"] for r in reports] == list(range(16)) and reports[0].payload["chunks"] == 16
    for r in reports:
        assert len(encode(r)) < DEFAULT_MAX_MESSAGE_BYTES
        assert sum(len(r.payload[f]) for f in ("index", "check", "value")) <= REPORT_BYTES
        assert r.payload["kind"] == "pass_snapshot" and r.payload["learner"] is True
    config, back = pass_arrays_from_chunks([decode_report(decode_from_player(encode(r)).payload) for r in reports])
    assert config == SarsaConfig()
    for name, value in arrays.items():
        np.testing.assert_array_equal(back[name], value, err_msg=name)


def test_an_empty_snapshot_is_one_small_report():
    game = Game(keeper_kw=LEARNED)
    game.arena.advise([1], {"kind": "report", "what": "snapshot"})
    game.percepts()
    (report,) = game.agent(1).pending_reports()
    assert report.payload["count"] == 0 and report.payload["table_size"] == SMALL.table_size
    assert len(encode(report)) < 1024


def test_a_snapshot_rebuilds_the_exact_learner():
    # Weights AND collision table: a learner loaded from the snapshot maps every tile of a state to the
    # same slot and has the same Q values; the hash counters come along.
    game = Game(keeper_kw={"pass_policy": "learned", "pass_learner": sarsa_pass_factory(None, MODE_LEARN, SMALL)})
    play_episodes(game, 3)
    agent = max(keepers(game), key=lambda a: int(np.count_nonzero(a.learner.memory.weights)))
    game.arena.advise([agent.unum], {"kind": "report", "what": "snapshot"})
    game.percepts()
    config, arrays = pass_arrays_from_chunks([decode_report(r.payload) for r in agent.pending_reports()])
    saved = agent.learner.save()
    assert config == SMALL and np.count_nonzero(saved["pass_weights"]) > 0
    for name in saved:
        np.testing.assert_array_equal(arrays[name], saved[name], err_msg=name)
    copy = SarsaLearner(K, 2, config, mode=MODE_GREEDY)
    copy.load(arrays)
    state = agent.learner.memory.last_state[0].copy()
    agent.learner.mode = MODE_GREEDY
    agent.learner.start(state)
    copy.start(state)
    np.testing.assert_array_equal(copy.memory.tiles, agent.learner.memory.tiles)
    np.testing.assert_array_equal(copy.q_values(), agent.learner.q_values())


@pytest.mark.parametrize("what", ["snapshot", "transitions"])
def test_every_keeper_answers_a_report_request_even_without_a_sarsa_learner(what):
    class Hold:
        def start(self, state):
            return 0

        def step(self, reward, state):
            return 0

        def end(self, reward):
            pass

    other = Game(keeper_kw={"pass_policy": "learned", "pass_learner": lambda seq, unum: Hold()})
    plain = Game()  # hand-coded Pass: no learner at all
    for game in (other, plain):
        play_episodes(game, 1)
        game.arena.advise([1, 2, 3, 4, 5], {"kind": "report", "what": what})
        game.percepts()
        for agent in keepers(game):
            (report,) = agent.pending_reports()
            assert report.payload == {"kind": f"pass_{what}", "learner": False, "episode": 1, "chunk": 0,
                                      "chunks": 1, "first": 0, "count": 0}
        assert [game.agent(obj).pending_reports() for obj in (4, 5)] == [[], []]  # takers are not asked


def test_transitions_lost_from_the_ring_buffer_are_counted_as_dropped():
    # A 4-transition log: a report after more than 4 transitions carries the last 4 and drops the rest.
    config = SarsaConfig(table_size=1 << 15, transition_log_size=4)
    game = Game(keeper_kw={"pass_policy": "learned", "pass_learner": sarsa_pass_factory(None, MODE_LEARN, config)})
    play_episodes(game, 3)
    agent, logged = busiest_learner(game)
    assert logged > 4
    report = transitions_report(game, agent)
    assert (report.payload["first"], report.payload["count"], report.payload["dropped"]) == (logged - 4, 4, logged - 4)


def referee_boundary(cycle):
    return wire(m.Hear(cycle=cycle, sender="referee", direction=None, unum=None, message=EPISODE_MESSAGE))


def own_learner_stream(seed, unum):
    """The exploration stream of keeper ``unum``'s learner in a player started with ``--seed seed``."""
    return seed_streams(learner_seed(agent_seed_sequence(seed, 0, unum).spawn(1)[0]), 1)[0]


def taught_policy(config):
    """A Sarsa policy with occupied slots and non-zero weights: one learning episode of 3 decisions."""
    teacher = SarsaLearner(K, 2, config, seed=4, mode=MODE_LEARN)
    states = np.linspace(1.0, 20.0, 13), np.linspace(3.0, 9.0, 13), np.linspace(12.0, 2.0, 13)
    teacher.start(states[0])
    teacher.step(2.0, states[1])
    teacher.step(3.0, states[2])
    teacher.end(4.0)
    return teacher.save()


def test_pass_load_advice_in_chunks_makes_the_keepers_learner_that_policy_at_the_boundary(monkeypatch, caplog):
    # Hand-coded keepers (no learner) get a 2^12-slot policy in chunks of 64 slots (1 KiB / 16 B); keeper 2
    # first hears a stray chunk 1 and a broken start, which chunk 0 starts over. A pass_mode advice in
    # the same batch applies after the load.
    config = SarsaConfig(table_size=1 << 12, alpha=0.5)
    policy = taught_policy(config)
    monkeypatch.setattr(pass_wire, "REPORT_BYTES", 1024)
    chunks = [c.to_wire() for c in sparse_pass_chunks(policy, config, PassLoadAdvice)]
    assert len(chunks) >= 3 and np.count_nonzero(policy["pass_weights"]) > 0
    game = Game(seed=6)
    game.cycle()
    game.arena.advise([2], chunks[1])
    game.arena.advise([2], chunks[0])
    game.arena.advise([2], chunks[2])  # chunk 1 missing: the collection cannot be complete ...
    for chunk in chunks:  # ... and chunk 0 starts it over
        game.arena.advise([1, 2], chunk)
    game.arena.advise([1], {"kind": "pass_mode", "mode": "learn"})
    game.percepts()
    assert [a.learner for a in keepers(game)] == [None] * K
    game.arena.reset_episode()
    game.percepts()
    for unum in (1, 2):
        learner = game.agent(unum).learner
        assert isinstance(learner, SarsaLearner) and learner.config == config
        for name, value in learner.save().items():
            np.testing.assert_array_equal(value, policy[name], err_msg=name)
        assert learner.memory.rng[0] == own_learner_stream(6, unum)
    assert game.agent(1).learner.mode == MODE_LEARN and game.agent(2).learner.mode == MODE_GREEDY
    assert game.agent(3).learner is None
    assert "chunk 1 of" in caplog.text and "came without chunk 0" in caplog.text
    # the loaded learner reports transitions from its own sequence number 0
    game.arena.advise([1], {"kind": "report", "what": "transitions"})
    game.percepts()
    (report,) = game.agent(1).pending_reports()
    assert (report.payload["first"], report.payload["dropped"], report.payload["learner"]) == (0, 0, True)


def test_a_switch_to_learned_pass_without_a_learner_brings_a_fresh_greedy_sarsa_learner():
    game = Game(seed=2)
    assert [a.learner for a in keepers(game)] == [None] * K
    game.arena.advise([1, 2, 3], {"kind": "policy", "pass": "learned"})
    game.arena.reset_episode()
    game.percepts()
    for agent in keepers(game):
        learner = agent.learner
        assert isinstance(learner, SarsaLearner) and learner.mode == MODE_GREEDY
        assert learner.config == SarsaConfig() and not learner.memory.weights.any()
        assert learner.memory.rng[0] == own_learner_stream(2, agent.unum)
        assert agent.cfg.pass_policy == PASS_POLICIES["learned"]
    play_episodes(game, 2)  # the Pass decisions now go to the learners
    assert sum(int(a.learner.memory.log_count[0]) for a in keepers(game)) > 0


def test_boundaries_in_a_row_end_the_learners_episode_once():
    # A paused server delivers hears while the clock stands still: three boundaries in one cycle, with
    # advice in between, give one terminal transition and one terminal update.
    game = Game(keeper_kw={"pass_policy": "learned", "pass_learner": sarsa_pass_factory(None, MODE_LEARN, SMALL)})
    while not any(a.learner.memory.last_action[0] != NO_ACTION for a in keepers(game)):
        game.cycle()
    agent = next(a for a in keepers(game) if a.learner.memory.last_action[0] != NO_ACTION)
    logged = int(agent.learner.memory.log_count[0])
    cycle = game.arena.cycle
    agent.on_message(referee_boundary(cycle))
    weights = agent.learner.memory.weights.copy()
    assert agent.learner.memory.log_count[0] == logged + 1 and agent.learner.memory.log_terminal[0, logged]
    for payload in ({"kind": "seed", "seed": 4}, {"kind": "pass_mode", "mode": "explore"}):
        agent.on_message(wire(m.Hear(cycle=cycle, sender="coach", direction=None, unum=None, message=payload)))
        agent.on_message(referee_boundary(cycle))
    assert agent.learner.memory.log_count[0] == logged + 1 and agent.learner.mode == MODE_EXPLORE
    np.testing.assert_array_equal(agent.learner.memory.weights, weights)
    assert agent.learner.memory.rng[0] == own_learner_stream(4, agent.unum) and agent.episodes == 3

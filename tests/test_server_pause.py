"""Reseeding resets and pausing at episode boundaries (docs/protocol.md 7 `episode_control`, 12 "Coach").

The arena-level test pins what a reset with a seed restores against a fresh ``server.arena.Arena``; the
others drive the real ``keepaway server`` process with scripted players (the deterministic
``chase_and_kick_out`` policy) and a scripted coach over ZeroMQ, as the trainer's coach does: pause after n
episodes, then advice, ``reset`` with a seed, ``pause`` with episodes_left, ``resume``.
"""

from __future__ import annotations

import time

import msgpack
import numpy as np
import pytest

from keepaway.protocol import encode
from keepaway.protocol import messages as m
from keepaway.protocol.messages import decode_for_player, decode_from_coach
from keepaway.protocol.errors import ProtocolError
from keepaway.protocol.params import parameter_set
from scripted import ScriptedCoach, ScriptedPlayer, chase_and_kick_out
from keepaway.server.arena import Arena
from keepaway.server.world import World

TEAMS = ["keepers"] * 3 + ["takers"] * 2
EPISODE_MESSAGE = "training Keepaway 1"
QUIET_S = 0.4  # how long a paused server is watched for messages it must not send
QUIET_ROUND_S = 0.1  # how often each player checks, within QUIET_S, that nothing came before its barrier
ADVICE = {"kind": "report", "what": "snapshot"}


# ------------------------------------------------------------------------------------------- protocol


def episode_control(**fields) -> bytes:
    return msgpack.packb({"type": "episode_control", **fields})


@pytest.mark.parametrize("fields", [
    {"action": "reset", "seed": 0},
    {"action": "reset", "seed": 2**63 - 1},
    {"action": "pause", "episodes_left": 0},
    {"action": "pause", "episodes_left": 7},
    {"action": "stop", "episodes_left": 3},
])
def test_seed_with_reset_and_episodes_left_with_stop_or_pause_are_accepted(fields):
    msg = m.EpisodeControl(**fields)
    assert decode_from_coach(episode_control(**fields)) == msg
    assert decode_from_coach(encode(msg)) == msg


@pytest.mark.parametrize("fields, code", [
    ({"action": "pause", "seed": 1}, "bad_value"),
    ({"action": "stop", "seed": 1}, "bad_value"),
    ({"action": "resume", "seed": 1}, "bad_value"),
    ({"action": "reset", "seed": -1}, "bad_value"),
    ({"action": "reset", "seed": 2**63}, "bad_value"),
    ({"action": "reset", "seed": True}, "bad_type"),
    ({"action": "reset", "seed": 1.0}, "bad_type"),
    ({"action": "reset", "episodes_left": 1}, "bad_value"),
    ({"action": "resume", "episodes_left": 1}, "bad_value"),
    ({"action": "pause", "episodes_left": -1}, "bad_value"),
])
def test_misplaced_or_out_of_range_seed_and_episodes_left_are_refused(fields, code):
    with pytest.raises(ProtocolError) as info:
        decode_from_coach(episode_control(**fields))
    assert info.value.code == code


# ------------------------------------------------------------------------------- arena (no sockets)


def started_arena(seed: int) -> Arena:
    arena = Arena(parameter_set("classic"), 3, 2, seed)
    for team in TEAMS:
        arena.connect(team)
    arena.start()
    return arena


def test_a_reset_with_a_seed_restores_what_a_fresh_arena_has_at_its_kick_off():
    step_ms = parameter_set("classic").simulator_step_ms
    played = started_arena(seed=1)
    for _ in range(23):  # every player dashes at an angle (stamina, positions, bodies change), one
        for obj in range(1, 6):  # looks wide, the keeper 1 says something
            played.submit(obj, [m.AtomicCommand("dash", (100.0, 30.0)), m.AtomicCommand("turn_neck", (20.0,))])
        played.submit(2, [m.AtomicCommand("change_view", ("wide",))])
        played.submit(1, [m.AtomicCommand("say", ("hi",))])
        played.step()
    played.submit(1, [m.AtomicCommand("dash", (100.0,))])  # pending when the reset comes
    played.advise([1], {"kind": "policy"})
    counts_before = played.world.counts.copy()
    episode, cycle = int(played.referee.episode[0]), played.cycle
    played.reset_episode(seed=9, now_ms=cycle * step_ms)

    fresh = started_arena(seed=9)
    for name, value, want in zip(World._fields, played.world, fresh.world):
        if name in ("time", "counts") or not isinstance(value, np.ndarray):
            continue
        np.testing.assert_array_equal(value, want, err_msg=name)
    np.testing.assert_array_equal(played.world.counts, counts_before)  # counters never go back
    assert played.cycle == cycle and int(played.referee.episode[0]) == episode  # both counters go on
    r, f = played.referee, fresh.referee
    assert r.start_cycle[0] == cycle and r.stuck_cycle[0] == cycle and r.take_count[0] == 0
    np.testing.assert_array_equal(r.stuck_anchor, f.stuck_anchor)  # (0, 0): a fresh ball's place
    assert not played.commands.main.any() and not played.pending_says
    for s, t in zip(played.slots, fresh.slots):
        assert s.view_width == t.view_width == "normal"
        # the see timer restarted: normal width 150 ms against 100 ms cycles sees at offsets 0, 2, 3, 5
        assert [played.see_due(s, cycle + k) for k in range(7)] == [fresh.see_due(t, k) for k in range(7)] \
            == [True, False, True, True, False, True, True]
    heard = [(h.sender, h.message) for h in map(decode_for_player, played.take_hears(played.slot(1)))]
    assert heard[-2:] == [("coach", {"kind": "policy"}), ("referee", EPISODE_MESSAGE)]
    # and it goes on identically: the same commands give the same world
    for arena in (played, fresh):
        arena.submit(3, [m.AtomicCommand("dash", (100.0,))])
        arena.step()
    np.testing.assert_array_equal(played.world.pos, fresh.world.pos)
    np.testing.assert_array_equal(played.world.rng, fresh.world.rng)


# ------------------------------------------------------------------------------ the real server process


class Table:
    """A real server, a scripted coach and five scripted chasers that the test drives in lock-step.

    ``trace`` keeps what keeper 1 received per cycle (sense_body, fullstate, see), ``looks`` the coach's
    look states taken at chosen cycles while the server waits for the players' answers.
    """

    def __init__(self, processes, tmp_path, seed: int, *extra: str) -> None:
        self.srv = processes.start_server(tmp_path, "--seed", str(seed), *extra)
        self.coach = ScriptedCoach(self.srv.coach_endpoint)
        self.coach.init()
        self.players: list[ScriptedPlayer] = []
        self.state: dict[int, m.Fullstate] = {}
        self.heard = [0] * len(TEAMS)  # referee episode messages heard, per player
        self.trace: dict[int, dict[str, object]] = {}
        self.looks: dict[int, dict] = {}

    def control(self, **fields) -> None:
        self.coach.send(m.EpisodeControl(**fields))

    def look(self) -> m.LookOk:
        """The coach's look; its answer also proves every earlier coach message was handled."""
        self.coach.send(m.Look())
        return self.coach.recv_until(m.LookOk)

    def connect(self) -> None:
        for team in TEAMS:  # the `waiting`s of a pause are set aside (assert_quiet checks them)
            p = ScriptedPlayer(self.srv.players_endpoint, ignore=(m.Waiting,))
            assert isinstance(p.init(team, fullstate=True), m.InitOk)
            self.players.append(p)

    def episode_ends(self) -> list[m.EpisodeEnd]:
        """Every episode_end so far (a look first: those sent before its answer have arrived)."""
        self.look()
        return [x for x in self.coach.received if isinstance(x, m.EpisodeEnd)]

    def play_until_heard(self, n: int, look_at: tuple[int, ...] = ()) -> None:
        """Answer every think with :func:`chase_and_kick_out` until every player has heard the
        referee's episode message ``n`` times in all; the messages after that one stay unread."""
        while any(h < n for h in self.heard):
            for i, p in enumerate(self.players):
                while self.heard[i] < n:
                    msg = p.recv()
                    if isinstance(msg, m.Hear) and msg.sender == "referee" and msg.message == EPISODE_MESSAGE:
                        self.heard[i] += 1
                    elif isinstance(msg, m.Fullstate):
                        self.state[i] = msg
                    if i == 0 and isinstance(msg, (m.SenseBody, m.Fullstate, m.See)):
                        self.trace.setdefault(msg.cycle, {})[msg.TYPE] = msg
                    if isinstance(msg, m.Think):
                        if i == 0 and msg.cycle in look_at:
                            self.looks[msg.cycle] = self.look().state
                        p.answer(msg.cycle, chase_and_kick_out(p.me, self.state[i]))
                        break

    def bare_messages(self, players: list[int] | None = None, expect: int = 1) -> list[list]:
        """While paused: the next ``expect`` messages of each player (they must come unasked)."""
        return [[p.recv(10) for _ in range(expect)] for i, p in enumerate(self.players)
                if players is None or i in players]

    def assert_quiet(self) -> None:
        """Nothing but `waiting`s reaches any player while the server stands still: for QUIET_S, round after
        round, each player's barrier is answered with nothing before it (a barrier's answer follows all
        the server sent that player before, so nothing is in flight when a round ends)."""
        deadline = time.monotonic() + QUIET_S
        before = [len(p.ignored) for p in self.players]
        while True:
            for p, n in zip(self.players, before):
                sent = p.until_barrier()
                assert not sent, f"a paused server sent {sent}"
                assert all(w.reason == "paused" for w in p.ignored[n:]), p.ignored[n:]
            if time.monotonic() >= deadline:
                return
            time.sleep(QUIET_ROUND_S)

    def stop(self) -> None:
        self.control(action="stop")
        assert self.srv.wait(30) == 0


def test_pause_after_n_episodes_stops_exactly_at_the_boundary_and_still_delivers_hears(processes, tmp_path):
    table = Table(processes, tmp_path, 3)
    table.control(action="pause", episodes_left=2)
    assert not table.look().paused  # not started: not standing still between cycles
    table.connect()
    table.play_until_heard(2)  # the second episode message came bare: no sense_body before it

    ends = table.episode_ends()
    assert [e.episode for e in ends] == [1, 2]
    boundary = ends[-1].end_cycle
    looked = table.look()
    assert looked.cycle == boundary and looked.state["episode"] == 3  # the new episode's first cycle
    assert looked.paused
    assert max(table.trace) == boundary - 1  # no percept of the boundary cycle went out
    table.assert_quiet()
    assert table.look().cycle == boundary  # the clock stands still

    table.coach.send(m.Advice(target="keepers", payload=ADVICE))
    for got in table.bare_messages(players=[0, 1, 2]):
        assert [(type(x), x.sender, x.message, x.cycle) for x in got] == [(m.Hear, "coach", ADVICE, boundary)]
    table.coach.send(m.EpisodeControl(action="pause", seed=5))  # refused, and nothing changes
    assert table.coach.recv_until(m.Error).code == "bad_value"
    table.assert_quiet()

    table.control(action="pause", episodes_left=1)
    marks = [len(p.received) for p in table.players]
    table.control(action="resume")
    for i, (p, mark) in enumerate(zip(table.players, marks)):
        assert p.recv_until(m.Think).cycle == boundary
        since_resume = p.received[mark:]  # the percepts repeat neither the episode message nor the advice
        assert [x.TYPE for x in since_resume][:2] == ["sense_body", "fullstate"]
        assert since_resume[0].cycle == boundary
        assert not any(isinstance(x, m.Hear) for x in since_resume)
        table.state[i] = since_resume[1]
        p.answer(boundary, chase_and_kick_out(p.me, since_resume[1]))
    table.play_until_heard(3)  # resume went on: the third episode ends, then the server pauses again
    assert [e.episode for e in table.episode_ends()] == [1, 2, 3]
    assert table.look().cycle == table.episode_ends()[-1].end_cycle
    table.assert_quiet()
    table.stop()


def play_reseeded(processes, tmp_path, server_seed: int, before: int, reset_seed: int) -> dict:
    """A server started with ``server_seed`` plays ``before`` episodes and pauses; the coach advises,
    resets with ``reset_seed``, and the server plays 3 episodes (``before`` = 0: a fresh server plays
    its first 3 episodes). Returns, relative to the cycle the 3 episodes start: their durations and end
    causes, keeper 1's percepts per cycle offset (but their cycle, sense_body counters and fullstate
    episode number) and the coach's look states (but the episode number) at offsets 0, 1 and 6.
    """
    table = Table(processes, tmp_path, server_seed)
    table.control(action="pause", episodes_left=before or 3)
    table.look()
    table.connect()
    start = 0
    if before:
        table.play_until_heard(before)
        start = table.look().cycle
        table.coach.send(m.Advice(target="all", payload=ADVICE))
        table.control(action="reset", seed=reset_seed)
        for got in table.bare_messages(expect=2):
            assert [(x.sender, x.message) for x in got] == [("coach", ADVICE), ("referee", EPISODE_MESSAGE)]
        table.control(action="pause", episodes_left=3)
        table.control(action="resume")
    offsets = (0, 1, 6)
    table.play_until_heard(table.heard[0] + 3, look_at=tuple(start + k for k in offsets))
    ends = [e for e in table.episode_ends() if e.end_cycle > start]
    assert len(ends) == 3 and ends[0].start_cycle == start
    assert table.look().cycle == ends[-1].end_cycle
    table.assert_quiet()
    table.stop()

    def without(fields: dict, *names: str) -> dict:
        return {k: v for k, v in fields.items() if k not in names}

    return {
        "episodes": [(e.end_cycle - e.start_cycle, e.end) for e in ends],
        "episode_numbers": [e.episode for e in ends],
        "trace": {cycle - start: {kind: without(msg.to_wire(), "cycle", "counts", "episode")
                                  for kind, msg in got.items()}
                  for cycle, got in table.trace.items() if cycle >= start},
        "looks": {cycle - start: {**without(state, "episode"), "episode_start": state["episode_start"] - start}
                  for cycle, state in table.looks.items()},
    }


def test_a_reset_with_a_seed_plays_the_same_whatever_was_played_before(processes, tmp_path):
    one = play_reseeded(processes, tmp_path / "one", server_seed=1, before=1, reset_seed=77)
    three = play_reseeded(processes, tmp_path / "three", server_seed=2, before=3, reset_seed=77)
    assert one["episode_numbers"] == [2, 3, 4] and three["episode_numbers"] == [4, 5, 6]
    assert one["episodes"] == three["episodes"]
    assert one["looks"] == three["looks"] and set(one["looks"]) == {0, 1, 6}
    assert one["looks"][0]["take_count"] == 0 and one["looks"][0]["ball"][2:] == (0.0, 0.0)
    assert one["looks"][0]["episode_start"] == 0  # the look at the reset cycle sees its episode begin
    assert one["trace"] == three["trace"]
    assert sorted(one["trace"]) == list(range(sum(d for d, _ in one["episodes"])))
    assert sum("see" in got for got in one["trace"].values()) > 0

    fresh = play_reseeded(processes, tmp_path / "fresh", server_seed=77, before=0, reset_seed=0)
    assert fresh["episode_numbers"] == [1, 2, 3]
    assert fresh["episodes"] == one["episodes"]
    assert fresh["trace"] == one["trace"]  # sense_body (but its counters), fullstate, see
    assert fresh["looks"] == one["looks"]


def test_realtime_pause_holds_the_clock_and_delivers_hears_at_once(processes, tmp_path):
    table = Table(processes, tmp_path, 4, "--mode", "realtime")
    table.connect()
    table.players[0].recv_until(m.SenseBody)
    table.control(action="pause")
    paused_at = table.look().cycle
    for p in table.players:  # percepts sent before the pause was read: their barrier says all are in
        p.until_barrier()
    table.assert_quiet()
    assert table.look().cycle == paused_at
    table.coach.send(m.Advice(target="all", payload=ADVICE))
    table.control(action="reset", seed=3)
    for got in table.bare_messages(expect=2):
        assert [(x.sender, x.message) for x in got] == [("coach", ADVICE), ("referee", EPISODE_MESSAGE)]
    table.assert_quiet()
    table.control(action="resume")
    keeper = table.players[0]
    mark = len(keeper.received)
    assert keeper.recv_until(m.SenseBody).cycle == paused_at + 1  # the clock goes on where it stood
    # before it, at most the restarted see timer's first see, of the reset field
    assert all(isinstance(x, m.See) and x.cycle == paused_at for x in keeper.received[mark:-1])
    table.stop()

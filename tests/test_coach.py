"""The coach process: its arena endpoint runs episodes for a trainer, relays advice, and stops the arena."""

from __future__ import annotations

import re
import signal
import subprocess
import time

import pytest
import zmq

from conftest import keepaway_command, read_until_match
from protocol import encode
from protocol import messages as m
from protocol.arena import EpisodesDone, RunEpisodes, StopArena, decode_for_trainer
from scripted import ScriptedCoach

ARENA_RE = re.compile(r"arena=(tcp://\S+)\n")


def start_arena(processes, tmp_path, *player_args: str, coach_args: tuple[str, ...] = ()):
    srv = processes.start_server(tmp_path)
    coach = processes.popen(keepaway_command("coach", "--server", srv.coach_endpoint, "--arena-port", "0",
                                             *coach_args), stdout=subprocess.PIPE)
    arena = read_until_match(coach.stdout, ARENA_RE, 60).group(1)
    players = [processes.popen(keepaway_command("player", "--team", team, "--server", srv.players_endpoint,
                                                *player_args))
               for team in ["keepers"] * 3 + ["takers"] * 2]
    return srv, coach, arena, players


def test_trainer_runs_episodes_through_the_arena_endpoint_and_stops_the_arena(processes, tmp_path):
    srv, coach, arena, players = start_arena(processes, tmp_path, "--getopen", "learned")
    trainer = zmq.Context.instance().socket(zmq.DEALER)
    trainer.setsockopt(zmq.LINGER, 0)
    trainer.connect(arena)
    try:
        trainer.send(encode(RunEpisodes(episodes=3, advice=(("keepers", {"kind": "policy", "getopen_theta": [0.1] * 91}),))))
        assert trainer.poll(180_000), "no answer from the arena"
        done = decode_for_trainer(trainer.recv())
        assert isinstance(done, EpisodesDone)
        assert [e[0] for e in done.episodes] == [1, 2, 3]
        for episode, start, end, cause in done.episodes:
            assert end > start and cause in ("out", "taken")
        trainer.send(encode(RunEpisodes(episodes=2)))
        assert trainer.poll(180_000)
        assert [e[0] for e in decode_for_trainer(trainer.recv()).episodes] == [4, 5]
        trainer.send(encode(StopArena()))
        assert srv.wait(60) == 0
        assert coach.wait(60) == 0
        assert all(p.wait(60) == 0 for p in players)
    finally:
        trainer.close(linger=0)
    kwy = [l for l in (srv.log_dir / "keepaway.kwy").read_text().splitlines() if l and l[0] != "#"]
    assert len(kwy) >= 5


def test_a_second_request_while_busy_is_refused(processes, tmp_path):
    srv, coach, arena, players = start_arena(processes, tmp_path)
    ctx = zmq.Context.instance()
    first, second = ctx.socket(zmq.DEALER), ctx.socket(zmq.DEALER)
    for sock in (first, second):
        sock.setsockopt(zmq.LINGER, 0)
        sock.connect(arena)
    try:
        first.send(encode(RunEpisodes(episodes=1000)))
        first.send(b"\x93garbage")  # answered once the coach has read the request before it
        assert first.poll(60_000)
        assert decode_for_trainer(first.recv()).code == "malformed"
        second.send(encode(RunEpisodes(episodes=1)))
        assert second.poll(60_000)
        refused = decode_for_trainer(second.recv())
        assert isinstance(refused, m.Error) and refused.code == "busy"
        second.send(b"\x93garbage")
        assert second.poll(60_000)
        assert decode_for_trainer(second.recv()).code == "malformed"
        srv.proc.send_signal(signal.SIGTERM)
        assert srv.wait(60) == 0
        assert first.poll(60_000)  # the pending run is answered when the arena stops
        stopped = decode_for_trainer(first.recv())
        assert isinstance(stopped, m.Error) and stopped.code == "arena_stopped"
        assert coach.wait(60) == 0
    finally:
        first.close(linger=0)
        second.close(linger=0)


@pytest.mark.slow
def test_an_idle_arena_waits_paused_for_its_first_request(processes, tmp_path):
    srv, coach, arena, players = start_arena(processes, tmp_path, coach_args=("--idle",))
    watcher = ScriptedCoach(srv.coach_endpoint)
    watcher.init()

    def look() -> m.LookOk:
        watcher.send(m.Look())
        return watcher.recv_until(m.LookOk)

    deadline = time.monotonic() + 180
    while not (looked := look()).paused:  # standing still once every player has connected
        assert time.monotonic() < deadline, "the idle arena never stood still"
        time.sleep(0.2)
    assert looked.cycle == 0 and looked.state["episode"] == 1  # paused before its first cycle
    trainer = zmq.Context.instance().socket(zmq.DEALER)
    trainer.setsockopt(zmq.LINGER, 0)
    trainer.connect(arena)
    try:
        trainer.send(encode(RunEpisodes(episodes=1, seed=4)))
        assert trainer.poll(180_000), "no answer from the arena"
        done = decode_for_trainer(trainer.recv())
        assert isinstance(done, EpisodesDone) and [e[0] for e in done.episodes] == [1]
        assert done.episodes[0][1] == looked.cycle  # it stood still until the request: not one cycle played
    finally:
        trainer.close(linger=0)
        watcher.close()

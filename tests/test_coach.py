"""The coach process: its arena endpoint runs episodes for a trainer, relays advice, and stops the arena."""

from __future__ import annotations

import re
import signal
import subprocess
import threading
import time

import numpy as np
import pytest
import zmq

from conftest import keepaway_command, read_until_match
from keepaway.coach.coach import Coach
from keepaway.protocol import PROTOCOL_VERSION, encode, parameter_set
from keepaway.protocol import messages as m
from keepaway.protocol.advice import PolicyAdvice
from keepaway.protocol.arena import EpisodesDone, RunEpisodes, StopArena, decode_for_trainer
from keepaway.protocol.landmarks import to_wire as landmarks_to_wire
from keepaway.protocol.messages import decode_from_coach
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
        trainer.send(encode(RunEpisodes(episodes=3, advice=(("keepers", PolicyAdvice(getopen_theta=[0.1] * 91)),))))
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


def test_after_a_20_mb_advice_the_arena_still_answers_a_normal_request(processes, tmp_path):
    """A run_episodes carrying a 20 MB advice must not leave the arena busy for good."""
    srv, coach, arena, players = start_arena(processes, tmp_path)
    trainer = zmq.Context.instance().socket(zmq.DEALER)
    trainer.setsockopt(zmq.LINGER, 0)
    trainer.connect(arena)
    try:
        huge = encode(RunEpisodes(episodes=1, advice=(("keepers", PolicyAdvice(getopen_theta=np.zeros(2_600_000))),)))
        assert len(huge) > 20_000_000
        trainer.send(huge)
        assert trainer.poll(180_000), "no answer to the oversized request"
        refused = decode_for_trainer(trainer.recv())
        assert isinstance(refused, m.Error) and refused.code == "too_large" and "\n" not in refused.message
        trainer.send(encode(RunEpisodes(episodes=2)))
        assert trainer.poll(180_000), "no answer to the normal request after the oversized one"
        done = decode_for_trainer(trainer.recv())
        assert isinstance(done, EpisodesDone) and [e[0] for e in done.episodes] == [1, 2]
        trainer.send(encode(StopArena()))
        assert srv.wait(60) == 0 and coach.wait(60) == 0
    finally:
        trainer.close(linger=0)


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


class FakeServer:
    """The server's coach port played by the test (a ROUTER), to drive the coach through a lost session."""

    def __init__(self) -> None:
        self.sock = zmq.Context.instance().socket(zmq.ROUTER)
        self.sock.setsockopt(zmq.LINGER, 0)
        self.endpoint = f"tcp://127.0.0.1:{self.sock.bind_to_random_port('tcp://127.0.0.1')}"
        self.coach: bytes | None = None

    def take(self, kind: type, timeout_s: float = 20.0):
        """The coach's next message of ``kind`` (others, e.g. repeated looks, are passed over)."""
        deadline = time.monotonic() + timeout_s
        while True:
            assert self.sock.poll(max(1, int((deadline - time.monotonic()) * 1000))), f"no {kind.__name__}"
            self.coach, data = self.sock.recv_multipart()
            msg = decode_from_coach(data)
            if isinstance(msg, kind):
                return msg

    def send(self, msg) -> None:
        self.sock.send_multipart([self.coach, encode(msg)])

    def welcome(self) -> None:
        self.take(m.CoachInit)
        self.send(m.CoachInitOk(cycle=0, version=PROTOCOL_VERSION, params=parameter_set("classic").to_dict(),
                                landmarks=landmarks_to_wire(), play_mode="play_on",
                                config={"keepers": 3, "takers": 2, "max_message_bytes": 1 << 20}))

    def forget(self, kind: type) -> None:
        """Answer the coach's next ``kind`` as a server that no longer knows the connection."""
        self.take(kind)
        self.send(m.Error(cycle=0, code="not_initialised", message="send init first"))

    def stand_still(self) -> None:
        self.take(m.Look)
        self.send(m.LookOk(cycle=7, paused=True, state={"ball": [0.0, 0.0, 0.0, 0.0], "players": [],
                                                        "play_mode": "play_on", "episode": 1, "episode_start": 0,
                                                        "take_count": 0}))

    def actions(self, n: int) -> list[str]:
        return [self.take(m.EpisodeControl).action for _ in range(n)]


def test_the_coach_refuses_what_it_cannot_forward_and_rejoins_a_server_that_lost_its_session():
    server = FakeServer()
    coach = Coach(server.endpoint, arena_port=0)
    runner = threading.Thread(target=lambda: (coach.connect(), coach.run()), daemon=True)
    runner.start()
    server.welcome()
    deadline = time.monotonic() + 20
    while coach.bound_arena_port is None:
        assert time.monotonic() < deadline
        time.sleep(0.01)
    trainer = zmq.Context.instance().socket(zmq.DEALER)
    trainer.setsockopt(zmq.LINGER, 0)
    trainer.connect(f"tcp://127.0.0.1:{coach.bound_arena_port}")

    def answer() -> object:
        assert trainer.poll(20_000), "no answer from the coach"
        return decode_for_trainer(trainer.recv())

    try:
        # an advice above the server's limit (1 MiB here) is refused at once, in one line; nothing jams
        huge = PolicyAdvice(getopen_theta=np.zeros(1 << 17))
        trainer.send(encode(RunEpisodes(episodes=1, advice=(("keepers", huge),))))
        refused = answer()
        assert isinstance(refused, m.Error) and refused.code == "too_large" and "1048576" in refused.message
        # the session is lost before the run begins: the coach joins again and serves the run
        trainer.send(encode(RunEpisodes(episodes=1)))
        assert server.take(m.EpisodeControl).action == "pause"
        server.forget(m.Look)
        server.welcome()
        assert server.take(m.EpisodeControl).action == "pause"  # step 1 starts over
        server.stand_still()
        assert server.actions(3) == ["reset", "pause", "resume"]
        server.send(m.EpisodeEnd(cycle=40, episode=1, start_cycle=7, end_cycle=40, end="out"))
        done = answer()
        assert isinstance(done, EpisodesDone) and [list(e) for e in done.episodes] == [[1, 7, 40, "out"]]
        # lost while the run is under way: its episodes may be gone, so the trainer is told
        trainer.send(encode(RunEpisodes(episodes=1)))
        assert server.actions(3) == ["reset", "pause", "resume"]  # it stood still since the last run
        server.forget(m.Look)  # the heartbeat
        server.welcome()
        lost = answer()
        assert isinstance(lost, m.Error) and lost.code == "session_lost"
        # a stop lost with the session is sent again once the coach has joined again
        trainer.send(encode(StopArena()))
        server.forget(m.EpisodeControl)
        server.welcome()
        assert server.take(m.EpisodeControl).action == "stop"
        server.send(m.Shutdown(cycle=41, reason="coach asked to stop"))
        runner.join(20)
        assert not runner.is_alive()
    finally:
        trainer.close(linger=0)
        server.sock.close(linger=0)

"""No client can crash or stall the server: a coach that vanishes without ``coach_bye`` (closed, killed,
one of a thousand), a coach flooding its port, a player frozen longer than its silence limit, huge frames
on the coach's arena port, and a trainer's ``stop_arena``. Real server, coach and player processes,
scripted clients over real ZeroMQ on free loopback ports."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest
import zmq
from zmq.utils.monitor import recv_monitor_message

from conftest import keepaway_command, process_tree, read_until_match
from keepaway.coach.core import STOPPING
from keepaway.core.exits import EXIT_INTERRUPTED
from keepaway.protocol import PROTOCOL_VERSION, encode
from keepaway.protocol import messages as m
from keepaway.protocol.arena import ARENA_REQUEST_MAX_BYTES, StopArena, decode_for_trainer
from keepaway.protocol.messages import SERVER_SILENCE_S
from keepaway.server.episode_log import read_jsonl
from scripted import ScriptedCoach, connect_all, play_chasers
from test_server_hardening import DROPPED_RE, answer_cycle, flood_while_playing, wait_logged

GONE = "is gone without coach_bye; the game goes on without it"
ARENA_RE = re.compile(r"keepaway coach arena=(tcp://[\d.]+:\d+)")


class Game(threading.Thread):
    """Scripted chasers (``scripted.play_chasers``) playing until the server shuts down, beside the test."""

    def __init__(self, endpoint: str) -> None:
        super().__init__(daemon=True)
        self.players = connect_all(endpoint, fullstate=True)
        self.error: BaseException | None = None

    def run(self) -> None:
        try:
            play_chasers(self.players)
        except BaseException as exc:  # noqa: BLE001 - reported by finish()
            self.error = exc

    def finish(self, timeout_s: float = 120.0) -> None:
        self.join(timeout_s)
        assert not self.is_alive(), "the game did not end"
        assert self.error is None, self.error


def episodes_logged(srv) -> int:
    path = srv.log_dir / "keepaway.jsonl"
    return len(read_jsonl(path)[1]) if path.exists() else 0


def wait_episodes(srv, n: int, timeout_s: float = 120.0) -> None:
    deadline = time.monotonic() + timeout_s
    while episodes_logged(srv) < n:
        assert time.monotonic() < deadline and srv.proc.poll() is None, srv.stderr_text()[-2000:]
        time.sleep(0.01)


def gone_lines(srv) -> list[str]:
    return [line for line in srv.stderr_text().splitlines() if GONE in line]


def test_a_coach_that_closes_without_bye_is_forgotten_in_one_line_and_every_episode_is_played(processes,
                                                                                              tmp_path):
    srv = processes.start_server(tmp_path, "--episodes", "4", "--seed", "3")
    coach = ScriptedCoach(srv.coach_endpoint)
    coach.init()
    coach.close()  # no coach_bye: the next episode_end finds it gone
    game = Game(srv.players_endpoint)
    game.start()
    game.finish()
    assert srv.wait(30) == 0
    assert episodes_logged(srv) == 4
    (line,) = gone_lines(srv)
    assert "coach 'test-coach'" in line


def test_a_thousand_coaches_that_vanish_cost_the_game_nothing(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--seed", "4")  # stopped below, once the coaches are done
    game = Game(srv.players_endpoint)
    game.start()
    before = episodes_logged(srv)
    ctx = zmq.Context()
    hello = encode(m.CoachInit(version=PROTOCOL_VERSION, client="test-coach"))
    try:
        for _ in range(10):  # 100 at a time: a process has a limited number of file descriptors
            batch = [ctx.socket(zmq.DEALER) for _ in range(100)]
            for sock in batch:
                sock.setsockopt(zmq.LINGER, 0)
                sock.connect(srv.coach_endpoint)
                sock.send(hello)
            for sock in batch:
                assert sock.poll(60_000), "a coach was not answered"
                sock.close()
    finally:
        ctx.destroy(linger=0)
    during = episodes_logged(srv)
    assert during > before, "no episode ended while the coaches came and went"
    wait_episodes(srv, during + 2)  # and the game goes on after them
    srv.proc.send_signal(signal.SIGTERM)
    game.finish()
    started = time.monotonic()
    assert srv.wait(30) == 0
    lines = gone_lines(srv)
    assert lines and len(lines) <= time.monotonic() - started + 30  # at most one a second, the rest counted
    assert re.search(r"and \d+ more like this", srv.stderr_text())


def test_a_keepaway_coach_killed_mid_episode_leaves_the_server_playing(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--seed", "5")  # stopped below
    coach = processes.popen(keepaway_command("coach", "--server", srv.coach_endpoint))
    wait_logged(srv, "coach 'keepaway-coach' connected")
    game = Game(srv.players_endpoint)
    game.start()
    wait_episodes(srv, 2)
    processes.kill(coach)  # SIGKILL: no coach_bye
    wait_episodes(srv, episodes_logged(srv) + 3)  # the episodes after it end as any other
    srv.proc.send_signal(signal.SIGTERM)
    game.finish()
    assert srv.wait(30) == 0
    (line,) = gone_lines(srv)
    assert "coach 'keepaway-coach'" in line


def test_a_coach_flooding_looks_is_held_to_its_budget_and_leaves_no_backlog(processes, tmp_path):
    flood_cycles, per_cycle, budget = 20, 300, 8
    srv = processes.start_server(tmp_path, "--cycle-timeout", "60")
    coach = ScriptedCoach(srv.coach_endpoint)
    coach.init()
    players = connect_all(srv.players_endpoint)
    sent = flood_while_playing(coach, encode(m.Look()), per_cycle, players, range(flood_cycles))
    for cycle in range(flood_cycles, flood_cycles + 10):  # the backlog (at most 64) is served in 8 cycles
        answer_cycle(players, cycle, ("dash", 100.0))
    bodies = [p.recv_until(m.SenseBody) for p in players]
    assert [b.counts["dash"] for b in bodies] == [flood_cycles + 10] * 5  # every seated command acted
    # every look is answered or dropped and counted by now: nothing is left for later
    answered = dropped = 0
    for msg in coach.until_barrier():
        answered += isinstance(msg, m.LookOk)
        if isinstance(msg, m.Error) and msg.code == "over_budget":
            dropped += int(DROPPED_RE.search(msg.message).group(1))
    assert answered + dropped == sent and dropped > 0
    assert answered <= (flood_cycles + 10) * budget + 64
    srv.proc.send_signal(signal.SIGTERM)
    assert srv.wait(30) == 0
    assert re.search(r"coach 'test-coach': over_budget: dropped \d+ messages beyond its budget of 8 per cycle",
                     srv.stderr_text())


@pytest.mark.slow
@pytest.mark.timeout(900)  # about a minute on a quiet machine; far longer when other jobs share its cores
def test_a_keeper_frozen_longer_than_its_silence_limit_plays_on_once_awake(processes, tmp_path):
    """A keeper frozen beyond its silence limit: the others play on without it meanwhile (its episodes are
    marked), it plays again once awake rather than giving the server up, and the run then ends as asked
    (here by SIGINT, some episodes after the wake: the episodes played while it is frozen depend on the
    machine's speed)."""
    episodes = 100_000
    proc = processes.popen(keepaway_command("run", "--episodes", str(episodes), "--seed", "0", "--no-progress",
                                            "--no-game-log", "--out", str(tmp_path)), stdout=subprocess.PIPE)
    jsonl = tmp_path / "keepaway.jsonl"
    logged = lambda: len(read_jsonl(jsonl)[1]) if jsonl.exists() else 0
    deadline = time.monotonic() + 180
    victim = None
    while time.monotonic() < deadline and victim is None:
        keepers = sorted(pid for pid, name in process_tree(proc.pid).items() if name.startswith("keeper "))
        if len(keepers) == 3 and logged() >= 1:
            victim = keepers[0]
        time.sleep(0.1)
    assert victim is not None, "the arena did not start"
    os.kill(victim, signal.SIGSTOP)
    time.sleep(SERVER_SILENCE_S + 3)  # longer than the keeper's silence limit
    os.kill(victim, signal.SIGCONT)
    woke_at = logged()
    deadline = time.monotonic() + 600
    while logged() < woke_at + 40 and time.monotonic() < deadline:
        time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=120)
    assert proc.returncode == EXIT_INTERRUPTED, processes.stderr_tail(proc)
    _, records = read_jsonl(jsonl)
    assert len(records) >= woke_at + 40
    short = [r for r in records if r.missed]
    assert short and all(len(r.missed) == 1 for r in short)  # the frozen keeper's episodes are marked
    (frozen,) = {r.missed[0][0] for r in short}
    assert not records[-1].missed  # it played again once awake
    assert "has sent nothing" not in processes.stderr_tail(proc)
    assert f"{frozen} " in processes.stderr_tail(proc)


def vm_kib(pid: int, field: str) -> int:
    """A ``/proc/PID/status`` memory figure (VmRSS, VmHWM) in KiB."""
    text = Path(f"/proc/{pid}/status").read_text()
    return int(re.search(rf"^{field}:\s+(\d+) kB", text, re.MULTILINE).group(1))


def test_huge_frames_on_the_arena_port_cost_the_coach_no_memory_and_stop_arena_is_acknowledged(processes,
                                                                                              tmp_path):
    srv = processes.start_server(tmp_path, "--start-on", "coach")
    coach = processes.popen(keepaway_command("coach", "--server", srv.coach_endpoint, "--arena-port", "0"),
                            stdout=subprocess.PIPE)
    arena = read_until_match(coach.stdout, ARENA_RE, 120).group(1)
    time.sleep(1.0)  # settled after its start
    baseline = vm_kib(coach.pid, "VmRSS")
    Path(f"/proc/{coach.pid}/clear_refs").write_text("5")  # the peak (VmHWM) starts again from now
    frames, size = 4, 200 * 1024 * 1024
    assert size > ARENA_REQUEST_MAX_BYTES
    ctx = zmq.Context()
    try:
        sender = ctx.socket(zmq.DEALER)
        sender.setsockopt(zmq.LINGER, 0)
        events = sender.get_monitor_socket(zmq.EVENT_DISCONNECTED)
        sender.connect(arena)
        huge = bytes(size)
        for _ in range(frames):
            sender.send(huge, copy=False)
        # each frame ends either in the coach's error reply (read whole) or in ZeroMQ closing the
        # connection (refused unread); the sender reconnects by itself and sends the next
        ends, deadline = 0, time.monotonic() + 120
        while ends < frames:
            assert time.monotonic() < deadline, f"{ends} of {frames} frames were refused"
            if events.poll(50):
                ends += recv_monitor_message(events)["event"] == zmq.EVENT_DISCONNECTED
            if sender.poll(0):
                sender.recv()
                ends += 1
        peak = vm_kib(coach.pid, "VmHWM")
        assert peak - baseline < 100 * 1024, f"the coach's RSS peaked {(peak - baseline) / 1024:.0f} MiB above"
        events.close()
        sender.close()
        trainer = ctx.socket(zmq.DEALER)
        trainer.setsockopt(zmq.LINGER, 0)
        trainer.connect(arena)
        trainer.send(encode(StopArena()))
        assert trainer.poll(30_000), "stop_arena was not answered"
        assert decode_for_trainer(trainer.recv()) == m.Shutdown(cycle=0, reason=STOPPING)
        trainer.close()
    finally:
        ctx.term()
    assert coach.wait(60) == 0
    assert srv.wait(60) == 0
    assert "coach asked to stop" in srv.stderr_text()

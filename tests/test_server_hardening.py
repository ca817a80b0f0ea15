"""A hardened arena: floods are dropped and counted while the game goes on, a player that is
gone takes its seat back with ``reconnect``, short-handed episodes are marked in the episode log, and a
second server on a log directory keeps the earlier logs. Real server, scripted clients, real ZeroMQ."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import time

import msgpack
import zmq

from conftest import keepaway_command
from keepaway.protocol import DEFAULT_MAX_MESSAGE_BYTES, PROTOCOL_VERSION, encode
from keepaway.protocol import messages as m
from keepaway.protocol.messages import advice_hear
from keepaway.server.episode_log import read_jsonl
from scripted import ScriptedClient, ScriptedCoach, ScriptedPlayer, chase_and_kick_out, connect_all, play_chasers

DROPPED_RE = re.compile(r"dropped (\d+) messages beyond your budget")
JUNK = msgpack.packb({"type": "command", "cycle": 0, "commands": [["dash", 100.0]]})


def answer_cycle(players: list[ScriptedPlayer], cycle: int, *commands: tuple) -> list[m.SenseBody]:
    """Every player answers the think of ``cycle`` with ``commands`` (an earlier think, which a player
    that has just joined may get, without any); their sense_bodies of ``cycle``."""
    bodies = []
    for p in players:
        while True:
            msg = p.recv()
            if isinstance(msg, m.SenseBody) and msg.cycle == cycle:
                bodies.append(msg)
            if isinstance(msg, m.Think) and msg.cycle < cycle:
                p.answer(msg.cycle)
            elif isinstance(msg, m.Think):
                assert msg.cycle == cycle, (p.me, msg.cycle, cycle)
                p.answer(cycle, *commands)
                break
    return bodies


def flood_while_playing(flooder: ScriptedClient, data: bytes, per_cycle: int, players: list[ScriptedPlayer],
                        cycles: range) -> int:
    """Before each cycle of ``cycles``, ``flooder`` sends ``data`` ``per_cycle`` times (fewer once its queue
    is full: the server reads it no faster than it serves the game); then ``players`` answer the cycle with
    a dash. Returns how many were sent."""
    sent = 0
    for cycle in cycles:
        for _ in range(per_cycle):
            try:
                flooder.sock.send(data, zmq.NOBLOCK)
                sent += 1
            except zmq.Again:
                break
        answer_cycle(players, cycle, ("dash", 100.0))
    return sent


def wait_logged(srv, text: str, timeout_s: float = 120.0) -> None:
    deadline = time.monotonic() + timeout_s
    while text not in srv.stderr_text():
        assert time.monotonic() < deadline, f"the server never logged {text!r}"
        time.sleep(0.05)


def collect_errors(client: ScriptedClient, done, timeout_s: float = 60.0) -> list[m.Error]:
    """The errors ``client`` receives until ``done(errors)`` holds."""
    errors: list[m.Error] = []
    deadline = time.monotonic() + timeout_s
    while not done(errors):
        msg = client.recv(max(0.01, deadline - time.monotonic()))
        if isinstance(msg, m.Error):
            errors.append(msg)
    return errors


def dropped_in(errors: list[m.Error]) -> int:
    return sum(int(DROPPED_RE.search(e.message).group(1)) for e in errors if e.code == "over_budget")


def test_an_unseated_flood_is_dropped_and_counted_while_every_seated_command_is_applied(processes, tmp_path):
    cycles, per_cycle = 30, 300
    srv = processes.start_server(tmp_path, "--cycle-timeout", "60")
    players = connect_all(srv.players_endpoint)
    flooder = ScriptedClient(srv.players_endpoint)
    started = time.monotonic()
    sent = flood_while_playing(flooder, JUNK, per_cycle, players, range(cycles))
    bodies = [p.recv_until(m.SenseBody) for p in players]
    assert [b.cycle for b in bodies] == [cycles] * 5  # the game went on through the flood
    assert [b.counts["dash"] for b in bodies] == [cycles] * 5  # every seated command was applied
    # every flood message is answered (within the budget) or dropped and counted, in one error a window
    errors = collect_errors(flooder, lambda errs: sum(e.code == "not_initialised" for e in errs)
                            + dropped_in(errs) >= sent)
    answered = sum(e.code == "not_initialised" for e in errors)
    assert {e.code for e in errors} == {"not_initialised", "over_budget"}
    assert answered + dropped_in(errors) == sent and answered < sent / 5
    srv.proc.send_signal(signal.SIGTERM)
    assert srv.wait(30) == 0
    elapsed_s = time.monotonic() - started
    flood_lines = [line for line in srv.stderr_text().splitlines() if "client " in line]
    assert any(re.search(r"over_budget: dropped \d+ messages beyond its budget of 16 per 0.1 s", line)
               for line in flood_lines)
    assert len(flood_lines) <= 2 * (elapsed_s + 2)  # one line a second per kind (flood, refusals)


def test_a_seated_player_flooding_loses_its_extra_messages_and_cannot_hold_the_game(processes, tmp_path):
    cycles, extra = 20, 40
    srv = processes.start_server(tmp_path, "--cycle-timeout", "60")  # a wait for it would stall the test
    players = connect_all(srv.players_endpoint)
    others, flooder = players[:4], players[4]
    answer_cycle(players, 0, ("dash", 100.0))
    for cycle in range(1, cycles):
        answer_cycle(others, cycle, ("dash", 100.0))
        flooder.recv_until(m.Think)
        for _ in range(extra):  # stale commands before its answer: the answer is beyond its budget of 8
            flooder.answer(cycle - 1, ("turn", 1.0))
        flooder.answer(cycle, ("dash", 100.0))
    bodies = [p.recv_until(m.SenseBody) for p in others]
    assert [b.counts["dash"] for b in bodies] == [cycles] * 4  # the others' commands all acted
    srv.proc.send_signal(signal.SIGTERM)  # budget windows still open are reported before the shutdown
    assert srv.wait(30) == 0
    flooder.recv_until(m.Shutdown)
    dropped = dropped_in([e for e in flooder.received if isinstance(e, m.Error)])
    assert 0 < dropped <= (cycles - 1) * (extra + 1 - 8)  # 8 a cycle served, 64 may wait, the rest dropped
    log = srv.stderr_text()
    assert re.search(r"taker 2: over_budget: dropped \d+ messages beyond its budget of 8 per cycle", log)
    assert "missed cycle" not in log  # never waited for: it had spent its budget


def test_a_burst_of_reports_beyond_the_budget_waits_and_arrives_whole_and_in_order(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--start-on", "coach")
    keeper = ScriptedPlayer(srv.players_endpoint)
    keeper.init("keepers")
    coach = ScriptedCoach(srv.coach_endpoint)
    coach.init()
    for chunk in range(40):  # five budgets' worth at once, as a keeper sends a big snapshot's chunks
        keeper.send(m.Report(cycle=0, payload={"chunk": chunk, "data": b"x" * 1000}))
    relayed = [coach.recv_until(m.PlayerReport).payload["chunk"] for _ in range(40)]
    assert relayed == list(range(40))
    assert not any(isinstance(msg, m.Error) for msg in keeper.until_barrier())  # none dropped


def test_oversized_frames_get_an_error_each_and_one_counted_log_line(processes, tmp_path):
    frames = 10
    srv = processes.start_server(tmp_path, "--start-on", "coach")
    rogue = ScriptedClient(srv.players_endpoint)
    for _ in range(frames):
        rogue.send_raw(b"\x80" * (5 * 1024 * 1024))  # above the decoder's 4 MiB, below ZeroMQ's 16 MiB
        reply = rogue.recv()
        assert isinstance(reply, m.Error) and reply.code == "too_large" and "\n" not in reply.message
    srv.proc.send_signal(signal.SIGTERM)
    assert srv.wait(30) == 0
    lines = [line for line in srv.stderr_text().splitlines() if "too_large" in line]
    held = [int(n) for line in lines for n in re.findall(r"and (\d+) more like this", line)]
    assert len(lines) < frames and len(lines) + sum(held) == frames  # one a second, the others counted


def test_a_seated_players_command_frame_above_the_limit_is_too_large_however_readable(processes, tmp_path):
    """The server's kernel could read a command frame of this size (``server.command_frame``), but the
    server's ``max_message_bytes`` comes first, for a seated player's frames as for any."""
    config = tmp_path / "server.toml"
    config.write_text("max_message_bytes = 1024\n")
    srv = processes.start_server(tmp_path, "--config", str(config), "--max-cycles", "2")
    players = connect_all(srv.players_endpoint)
    says = [m.AtomicCommand("say", ("x" * 200,))] * 6
    for p in players:
        p.recv_until(m.Think)
    over = encode(m.Command(cycle=0, commands=(m.AtomicCommand("dash", (100.0,)), *says)))
    under = encode(m.Command(cycle=0, commands=(m.AtomicCommand("dash", (100.0,)), *says[:4])))
    assert len(under) <= 1024 < len(over)
    players[0].send_raw(over)
    refused = players[0].recv_until(m.Error)
    assert refused.code == "too_large" and "1024" in refused.message
    players[0].send_raw(under)  # taken: its says are dropped by the size rule, each with a warning
    assert [players[0].recv_until(m.Error).code for _ in range(4)] == ["dropped"] * 4
    for p in players[1:]:
        p.answer(0)
    body = players[0].recv_until(m.SenseBody)
    assert body.cycle == 1 and body.speed[0] > 0  # the dash of the frame under the limit
    answer_cycle(players, 1)
    assert srv.wait(30) == 0


def play_until_logged(srv, players: list[ScriptedPlayer], text: str, first_cycle: int,
                      timeout_s: float = 60.0) -> int:
    """Play cycles from ``first_cycle`` (at most 50 a second) until the server's log says ``text``;
    return the next cycle."""
    cycle = first_cycle
    deadline = time.monotonic() + timeout_s
    while text not in srv.stderr_text():
        assert time.monotonic() < deadline, f"the server never logged {text!r}"
        answer_cycle(players, cycle)
        cycle += 1
        time.sleep(0.02)
    return cycle


def test_a_vanished_player_takes_its_seat_back_with_reconnect(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--cycle-timeout", "0.2")
    players = connect_all(srv.players_endpoint)
    for cycle in range(3):
        answer_cycle(players, cycle)
    players[0].close()  # gone without a bye (a crash)
    cycle = play_until_logged(srv, players[1:], "keeper 1 is unreachable", 3)
    back = ScriptedPlayer(srv.players_endpoint)
    back.send(m.Reconnect(version=PROTOCOL_VERSION, team="keepers", unum=1))
    ok = back.recv_until(m.InitOk)
    assert (ok.side, ok.unum, ok.play_mode) == ("l", 1, "play_on")
    back.me = (ok.side, ok.unum)
    answer_cycle(players[1:], cycle)  # the cycle the reconnect came in
    players = [back, *players[1:]]
    for cycle in range(cycle + 1, cycle + 6):  # it is waited for again, and its commands act
        bodies = answer_cycle(players, cycle, ("dash", 100.0))
    assert bodies[0].counts["dash"] == 4
    srv.proc.send_signal(signal.SIGTERM)
    assert srv.wait(30) == 0
    log = srv.stderr_text()
    assert "keeper 1: its seat is taken back by a reconnect" in log and "keeper 1 connected (reconnect)" in log


def test_reconnect_to_a_player_that_still_answers_is_refused_and_the_player_is_told(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--start-on", "coach")
    holder = ScriptedPlayer(srv.players_endpoint)
    assert holder.init("takers").unum == 1
    thief = ScriptedPlayer(srv.players_endpoint)
    thief.send(m.Reconnect(version=PROTOCOL_VERSION, team="takers", unum=1))
    refused = thief.recv_until(m.Error)
    assert refused.code == "cannot_reconnect" and "still connected" in refused.message
    told = holder.recv_until(m.Error)
    assert told.code == "cannot_reconnect" and "another client asked to reconnect as taker 1" in told.message


def test_reconnect_before_the_kick_off_frees_the_seat_of_a_client_that_is_gone(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--start-on", "coach")
    gone = ScriptedPlayer(srv.players_endpoint)
    assert gone.init("takers").unum == 1
    gone.close()  # nothing is sent before the kick-off: only the reconnect's probe can find it gone
    deadline = time.monotonic() + 20
    while True:  # ZeroMQ notices the closed connection within moments; until then the seat is held
        back = ScriptedPlayer(srv.players_endpoint)
        back.send(m.Reconnect(version=PROTOCOL_VERSION, team="takers", unum=1))
        reply = back.recv()
        if isinstance(reply, m.InitOk):
            break
        assert reply.code == "cannot_reconnect" and time.monotonic() < deadline
        back.close()
        time.sleep(0.1)
    assert (reply.side, reply.unum) == ("r", 1)
    assert "taker 1 is unreachable" in srv.stderr_text()


def chase(players: list[ScriptedPlayer], state: dict, cycle: int) -> list[str]:
    """One cycle of :func:`chase_and_kick_out` for ``players`` (exact state kept in ``state``); the
    referee's messages heard by the first of them."""
    heard = []
    for i, p in enumerate(players):
        while True:
            msg = p.recv()
            if isinstance(msg, m.Fullstate):
                state[p.me] = msg
            elif isinstance(msg, m.Hear) and msg.sender == "referee" and i == 0:
                heard.append(msg.message)
            elif isinstance(msg, m.Think):
                assert msg.cycle == cycle
                p.answer(cycle, chase_and_kick_out(p.me, state[p.me]))
                break
    return heard


def test_a_hung_player_is_reported_once_its_episodes_are_marked_and_it_loses_its_seat(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--cycle-timeout", "0.5", "--max-missed", "3", "--episodes", "3",
                                 "--seed", "2")
    players = connect_all(srv.players_endpoint, fullstate=True)
    hung, playing = players[0], players[1:]  # keeper 1 never answers (stopped, say, with SIGSTOP)
    state: dict = {}
    cycle = 0
    while "training Keepaway 1" not in chase(playing, state, cycle):  # the first episode ends
        cycle += 1
    cycle += 1
    back = ScriptedPlayer(srv.players_endpoint)
    back.send(m.Reconnect(version=PROTOCOL_VERSION, team="keepers", unum=1))
    back.me = (back.recv_until(m.InitOk).side, 1)
    hung.answer(cycle)  # its seat is gone: it is a stranger now
    collect_errors(hung, lambda errs: any(e.code == "not_initialised" for e in errs))
    chase(playing, state, cycle)  # the cycle the reconnect came in
    play_chasers([back, *playing])
    assert srv.wait(30) == 0
    log = srv.stderr_text()
    assert log.count("keeper 1 missed 3 cycles in a row; no longer waiting for it") == 1
    assert "keeper 1: its seat is taken back by a reconnect" in log
    header, episodes = read_jsonl(srv.log_dir / "keepaway.jsonl")
    first, *_, last = episodes
    assert dict(first.missed) == {"keeper 1": first.duration}  # short-handed from start to end
    assert last.missed == ()  # keeper 1 played the whole last episode
    lines = [json.loads(line) for line in (srv.log_dir / "keepaway.jsonl").read_text().splitlines()]
    assert lines[1]["missed"] == {"keeper 1": first.duration} and lines[-1]["missed"] == {}


def test_keepaway_player_reconnect_takes_back_the_seat_of_a_killed_player(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--cycle-timeout", "2")
    scripted = [ScriptedPlayer(srv.players_endpoint) for _ in range(4)]
    for p, (team, unum) in zip(scripted, [("keepers", 2), ("keepers", 3), ("takers", 1), ("takers", 2)]):
        assert p.init(team, unum=unum).unum == unum
    first = processes.popen(keepaway_command("player", "--team", "keepers", "--server", srv.players_endpoint))
    wait_logged(srv, "game started")
    for cycle in range(10):
        answer_cycle(scripted, cycle)
    processes.kill(first)  # SIGKILL: no bye
    cycle = play_until_logged(srv, scripted, "keeper 1 is unreachable", 10)
    again = processes.popen(keepaway_command("player", "--team", "keepers", "--server", srv.players_endpoint,
                                             "--reconnect", "1", "-v"))
    cycle = play_until_logged(srv, scripted, "keeper 1 connected (reconnect)", cycle, timeout_s=180)
    for c in range(cycle, cycle + 20):
        answer_cycle(scripted, c)
    srv.proc.send_signal(signal.SIGTERM)
    assert srv.wait(30) == 0
    assert again.wait(30) == 0
    assert "joined as keepers 1" in processes.stderr_tail(again)
    after = srv.stderr_text().split("keeper 1 connected (reconnect)")[1]
    assert "keeper 1 missed" not in after  # the new process answers every cycle


def test_a_second_server_on_a_log_directory_keeps_the_first_ones_logs(processes, tmp_path):
    kwys = []
    for seed in (5, 6):
        srv = processes.start_server(tmp_path, "--episodes", "2", "--seed", str(seed))
        play_chasers(connect_all(srv.players_endpoint, fullstate=True))
        assert srv.wait() == 0
        kwys.append((srv.log_dir / "keepaway.kwy").read_text())
    assert (srv.log_dir / "keepaway.1.kwy").read_text() == kwys[0]  # set aside, whole
    assert read_jsonl(srv.log_dir / "keepaway.1.jsonl")[0]["seed"] == 5
    assert read_jsonl(srv.log_dir / "keepaway.jsonl")[0]["seed"] == 6
    assert (len(read_jsonl(srv.log_dir / "keepaway.1.jsonl")[1]) == len(read_jsonl(srv.log_dir / "keepaway.jsonl")[1])
            == 2)


def test_a_player_that_cannot_take_a_seat_back_asks_again_then_exits_with_one_line(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--start-on", "coach")
    holder = ScriptedPlayer(srv.players_endpoint)
    assert holder.init("keepers").unum == 1
    proc = processes.popen(keepaway_command("player", "--team", "keepers", "--server", srv.players_endpoint,
                                            "--reconnect", "1", "--connect-timeout", "3"), stderr=subprocess.PIPE)
    assert proc.wait(120) == 2
    err = proc.stderr.read().decode()
    assert "the server refused reconnect for 3 s: cannot_reconnect" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    probes = collect_errors(holder, lambda errors: len(errors) >= 2, timeout_s=10)
    assert all(e.code == "cannot_reconnect" for e in probes)  # asked more than once, told every time


def test_keepaway_player_reconnect_waits_for_the_server_to_give_a_hung_player_up(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--cycle-timeout", "0.2", "--max-missed", "5")
    players = connect_all(srv.players_endpoint)
    holder = players[0]  # keeper 1
    told: list[m.Error] = []
    plain_recv = holder.recv

    def recv(timeout: float = 20.0):
        msg = plain_recv(timeout)
        if isinstance(msg, m.Error) and msg.code == "cannot_reconnect":
            told.append(msg)
        return msg

    holder.recv = recv
    again = processes.popen(keepaway_command("player", "--team", "keepers", "--server", srv.players_endpoint,
                                             "--reconnect", "1", "-v"))
    cycle = 0
    deadline = time.monotonic() + 180
    while not told:  # keeper 1 still answers: its seat is refused to the newcomer
        assert time.monotonic() < deadline and again.poll() is None
        answer_cycle(players, cycle)
        cycle += 1
        time.sleep(0.02)
    # keeper 1 hangs from here; the server gives it up after 5 missed cycles and the newcomer asks again
    cycle = play_until_logged(srv, players[1:], "keeper 1 connected (reconnect)", cycle, timeout_s=60)
    for c in range(cycle, cycle + 20):
        answer_cycle(players[1:], c)
    srv.proc.send_signal(signal.SIGTERM)
    assert srv.wait(30) == 0
    assert again.wait(30) == 0
    log = srv.stderr_text()
    assert log.index("keeper 1 missed 5 cycles in a row") < log.index("keeper 1: its seat is taken back")
    err = processes.stderr_tail(again)
    assert "the server refused reconnect" in err and "asking again" in err and "joined as keepers 1" in err


def test_an_advice_whose_hear_would_be_over_the_limit_is_refused_not_sent(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--start-on", "coach", "--max-cycles", "2")
    keeper = ScriptedPlayer(srv.players_endpoint)
    keeper.init("keepers")
    coach = ScriptedCoach(srv.coach_endpoint)
    coach.init()
    limit = DEFAULT_MAX_MESSAGE_BYTES
    probe = limit - 1000
    overhead = len(encode(m.Advice(target="keepers", payload=b"x" * probe))) - probe
    payload = b"x" * (limit - overhead)  # the advice just fits; the hear it becomes does not
    assert len(encode(m.Advice(target="keepers", payload=payload))) == limit
    assert len(encode(advice_hear(payload))) > limit
    coach.send(m.Advice(target="keepers", payload=payload))
    refused = coach.recv_until(m.Error)
    assert refused.code == "too_large" and str(limit) in refused.message
    coach.send(m.Advice(target="keepers", payload={"kind": "small"}))
    coach.send(m.Start())
    heard = [msg.message for msg in keeper.play_cycles(2) if isinstance(msg, m.Hear) and msg.sender == "coach"]
    assert heard == [{"kind": "small"}]  # and the keeper's connection lives on

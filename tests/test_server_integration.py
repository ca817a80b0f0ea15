"""The real ``keepaway server`` process driven by scripted clients over real ZeroMQ on free loopback ports."""

from __future__ import annotations

import json
import signal
from pathlib import Path

import msgpack
import pytest

from keepaway.protocol import PROTOCOL_VERSION, ServerParams
from keepaway.protocol import messages as m
from keepaway.protocol.landmarks import FLAGS
from scripted import ScriptedCoach, ScriptedPlayer, connect_all, play_chasers, play_together


def test_init_handshake_assigns_numbers_and_sends_the_parameter_table(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--params", "current", "--max-cycles", "5")
    first = ScriptedPlayer(srv.players_endpoint)
    ok = first.init("keepers")
    assert (ok.side, ok.unum, ok.play_mode) == ("l", 1, "before_kick_off")
    params = ServerParams.from_dict(ok.params)
    assert params.name == "current" and params.player_speed_max == 1.05
    assert params.visible_angle == 360.0 and params.stamina_inc_max == 3500.0  # keepaway.sh launch
    assert len(ok.landmarks["flags"]) == len(FLAGS) == 55
    requested = ScriptedPlayer(srv.players_endpoint).init("keepers", unum=3)
    assert requested.unum == 3
    assert ScriptedPlayer(srv.players_endpoint).init("keepers").unum == 2
    full = ScriptedPlayer(srv.players_endpoint).init("keepers")
    assert isinstance(full, m.Error) and full.code == "no_more_player"
    bad_team = ScriptedPlayer(srv.players_endpoint).init("goalies")
    assert isinstance(bad_team, m.Error)
    old = ScriptedPlayer(srv.players_endpoint).init("takers", version=PROTOCOL_VERSION + 1)
    assert isinstance(old, m.Error) and old.code == "bad_version"


def test_sync_mode_steps_each_cycle_once_everyone_answered(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--max-cycles", "31", "--param", "player_rand=0")
    players = connect_all(srv.players_endpoint)
    thinks: list[int] = []
    speeds: list[float] = []
    sees = 0
    for _ in range(30):
        for i, p in enumerate(players):
            while True:
                msg = p.recv()
                if i == 0 and isinstance(msg, m.SenseBody):
                    speeds.append(msg.speed[0])
                if i == 0 and isinstance(msg, m.See):
                    sees += 1
                if isinstance(msg, m.Think):
                    if i == 0:
                        thinks.append(msg.cycle)
                    p.answer(msg.cycle, ("dash", 100.0))
                    break
    assert thinks == list(range(30))
    # dash 100 from rest: stored speed 0.6 * 0.4 = 0.24 after the first step (docs/rules.md §1), quantised to 0.01
    assert speeds[0] == 0.0 and speeds[1] == pytest.approx(0.24)
    # send_step 150 ms against 100 ms cycles: 2 sees per 3 cycles at normal width
    assert sees == 20
    assert srv.wait() == 0


def test_realtime_mode_sends_two_sees_per_three_cycles(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--mode", "realtime", "--max-cycles", "16")
    players = connect_all(srv.players_endpoint)
    counts = {"sense_body": 0, "see": 0}
    done = False
    while not done:
        msg = players[0].recv(10)
        if isinstance(msg, m.SenseBody):
            counts["sense_body"] += 1
        elif isinstance(msg, m.See):
            counts["see"] += 1
        elif isinstance(msg, m.Shutdown):
            done = True
    assert counts["sense_body"] >= 15
    # asynchronous see timer: 150 ms period -> 2/3 of the cycle count, +-1 for the phase
    assert abs(counts["see"] - counts["sense_body"] * 2 / 3) <= 1.5
    assert srv.wait() == 0


def test_realtime_think_ends_each_cycle_after_its_percepts(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--mode", "realtime", "--max-cycles", "16")
    players = connect_all(srv.players_endpoint)
    seen: list[tuple[str, int]] = []
    while True:
        msg = players[0].recv(10)
        if isinstance(msg, m.Shutdown):
            break
        if isinstance(msg, (m.SenseBody, m.See, m.Think)):
            seen.append((msg.TYPE, msg.cycle))
    cycles = sorted({c for _, c in seen if _ == "sense_body"})
    assert len(cycles) >= 15
    for cycle in cycles[:-1]:  # the last cycle may be cut by the shutdown
        kinds = [kind for kind, c in seen if c == cycle]
        assert kinds[0] == "sense_body" and kinds.count("think") == 1, (cycle, kinds)
        # every percept of the cycle comes before its think, and the think before the next cycle's
        assert kinds.index("think") == len(kinds) - 1, (cycle, kinds)
        assert seen.index(("think", cycle)) < seen.index(("sense_body", cycle + 1))
    assert srv.wait() == 0


def test_waiting_tells_joined_players_why_no_cycle_is_played(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--start-on", "coach", "--max-cycles", "200")
    keeper = ScriptedPlayer(srv.players_endpoint)
    keeper.init("keepers")
    first, second = keeper.recv_until(m.Waiting, 5), keeper.recv_until(m.Waiting, 5)  # about 1 s apart
    assert (first.reason, first.connected, first.expected, first.cycle) == ("coach", 1, 5, 0)
    assert second.reason == "coach"
    taker = ScriptedPlayer(srv.players_endpoint)
    taker.init("takers")
    while keeper.recv_until(m.Waiting, 5).connected != 2:
        pass
    coach = ScriptedCoach(srv.coach_endpoint)
    coach.init()
    coach.send(m.Start())
    for p in (keeper, taker):
        p.play_cycles(2)
    coach.send(m.EpisodeControl(action="pause"))
    paused = None
    while paused is None:  # answer the cycles played until the pause takes effect
        for p in (keeper, taker):
            msg = p.recv(5)
            if isinstance(msg, m.Think):
                p.answer(msg.cycle)
            elif isinstance(msg, m.Waiting) and p is keeper:
                paused = msg
    assert (paused.reason, paused.connected, paused.expected) == ("paused", 2, 5) and paused.cycle >= 2
    assert isinstance(keeper.recv_until(m.Waiting, 5), m.Waiting)  # again while it lasts


def test_pre_kick_off_percepts_come_as_rcssserver_sends_them_and_their_answers_do_not_act(processes, tmp_path):
    """A player that asked for ``pre_kick_off`` gets sense_body + think of cycle 0 while the server waits
    for the kick-off (another player gets only ``waiting``); its answers then are dropped: a turn sent
    before the kick-off has not turned it when the game is played."""
    srv = processes.start_server(tmp_path, "--start-on", "coach", "--max-cycles", "200", "--param", "player_rand=0")
    early = ScriptedPlayer(srv.players_endpoint)
    early.init("keepers", pre_kick_off=True)
    plain = ScriptedPlayer(srv.players_endpoint)
    plain.init("takers")
    thinks = 0
    while thinks < 5:
        msg = early.recv(5)
        if isinstance(msg, m.SenseBody):
            assert msg.cycle == 0
        elif isinstance(msg, m.Think):
            assert msg.cycle == 0 and isinstance(early.received[-2], m.SenseBody)
            early.answer(0, ("turn", 90.0))
            thinks += 1
    assert all(isinstance(msg, m.Waiting) for msg in plain.until_barrier())
    coach = ScriptedCoach(srv.coach_endpoint)
    coach.init()
    coach.send(m.Start())
    while not (isinstance(heard := early.recv_until(m.Hear, 5), m.Hear) and heard.message == "play_on"):
        pass
    coach.send(m.Look())
    body_at_kick_off = next(p for p in coach.recv_until(m.LookOk).state["players"] if tuple(p[:2]) == ("l", 1))[6]
    for p in (early, plain):
        p.play_cycles(1)  # no command in cycle 0
    early.recv_until(m.SenseBody, 5)
    coach.send(m.Look())
    look = coach.recv_until(m.LookOk)
    assert look.cycle == 1
    assert next(p for p in look.state["players"] if tuple(p[:2]) == ("l", 1))[6] == body_at_kick_off


def test_reconnect_takes_back_the_uniform_number(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--start-on", "coach", "--max-cycles", "3")
    p = ScriptedPlayer(srv.players_endpoint)
    assert p.init("takers").unum == 1
    q = ScriptedPlayer(srv.players_endpoint)
    refused = q.init("takers", unum=1)
    assert isinstance(refused, m.Error) and refused.code == "no_more_player"
    p.send(m.Bye())
    p.until_barrier()  # the server has read the bye
    q.send(m.Reconnect(version=PROTOCOL_VERSION, team="takers", unum=1))
    ok = q.recv_until(m.InitOk)
    assert (ok.side, ok.unum) == ("r", 1)


def test_episode_logs_are_written_and_flushed(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--episodes", "4", "--seed", "11")
    coach = ScriptedCoach(srv.coach_endpoint)
    coach.init()
    players = connect_all(srv.players_endpoint, fullstate=True)
    play_chasers(players)
    assert srv.wait() == 0
    kwy = (srv.log_dir / "keepaway.kwy").read_text().splitlines()
    assert kwy[0] == "# Keepers: 3" and kwy[1] == "# Takers:  2" and kwy[2] == "# Region:  20 x 20"
    episodes = [line.split("\t") for line in kwy if line and not line.startswith("#")]
    assert [e[0] for e in episodes] == ["1", "2", "3", "4"]
    assert episodes[0][1] == "0"
    for prev, cur in zip(episodes, episodes[1:]):
        assert cur[1] == prev[2]  # the next episode starts at the end cycle
    for number, start, end, duration, cause in episodes:
        assert int(end) - int(start) == int(duration) and cause in ("o", "t")
    lines = (srv.log_dir / "keepaway.jsonl").read_text().splitlines()
    header = json.loads(lines[0])
    assert header["seed"] == 11 and header["config"]["keepers"] == 3
    assert len(lines) == 5
    ends = []
    while len(ends) < 4:
        msg = coach.recv(10)
        if isinstance(msg, m.EpisodeEnd):
            ends.append((msg.episode, msg.start_cycle, msg.end_cycle, msg.end))
    assert [e[0] for e in ends] == [1, 2, 3, 4]


def run_scripted_game(processes, tmp_path: Path, seed: int) -> bytes:
    srv = processes.start_server(tmp_path, "--episodes", "6", "--seed", str(seed))
    players = connect_all(srv.players_endpoint, fullstate=True)
    play_chasers(players)
    assert srv.wait() == 0
    return (srv.log_dir / "keepaway.kwy").read_bytes()


def test_same_seed_and_commands_give_byte_identical_logs(processes, tmp_path):
    first = run_scripted_game(processes, tmp_path / "a", seed=5)
    second = run_scripted_game(processes, tmp_path / "b", seed=5)
    other = run_scripted_game(processes, tmp_path / "c", seed=6)
    assert first == second
    assert first != other


def test_bad_input_gets_one_line_errors_and_the_game_goes_on(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--max-cycles", "6", "--param", "player_rand=0")
    rogue = ScriptedPlayer(srv.players_endpoint)
    cases = [
        (b"\xc1\xff\x00garbage", "malformed"),
        (msgpack.packb([1, 2, 3]), "not_a_map"),
        (msgpack.packb({"type": "warp", "cycle": 0}), "unknown_type"),
        (msgpack.packb({"type": "command", "cycle": 0, "commands": [["dash", 1.0]]}), "not_initialised"),
        (b"\x80" * (4 * 1024 * 1024 + 10), "too_large"),
    ]
    for data, code in cases:
        rogue.send_raw(data)
        reply = rogue.recv()
        assert isinstance(reply, m.Error) and reply.code == code, (reply, code)
        assert "\n" not in reply.message
    players = connect_all(srv.players_endpoint)
    bad_commands = [
        ({"type": "command", "cycle": 0, "commands": [["dash", float("nan")]]}, "bad_value"),
        ({"type": "command", "cycle": 0, "commands": [["fly", 1.0]]}, "unknown_command"),
        ({"type": "command", "cycle": 0, "commands": [["kick", 1.0]]}, None),
        ({"type": "command", "cycle": 0, "commands": [], "unum": 2}, "unknown_field"),
        ({"type": "command", "cycle": 99, "commands": []}, "bad_cycle"),
    ]
    victim = players[0]
    victim.recv_until(m.Think)
    for wire, code in bad_commands:
        victim.send_raw(msgpack.packb(wire))
        reply = victim.recv_until(m.Error)
        if code is not None:
            assert reply.code == code, (reply, code)
    # out-of-range values are clamped as rcssserver clamps them, not rejected
    victim.answer(0, ("dash", 1e9), ("turn_neck", -500.0))
    for p in players[1:]:
        p.recv_until(m.Think)
        p.answer(0)
    assert isinstance(victim.recv_until(m.SenseBody), m.SenseBody)
    body = victim.received[-1]
    assert body.cycle == 1 and body.speed[0] == pytest.approx(0.24) and body.head_angle in (-90, -89)
    assert srv.wait(30) == 0
    log = srv.stderr_text()
    assert "malformed" in log and "bad_value" in log


def test_a_player_that_disconnects_is_noticed_and_the_others_keep_playing(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--max-cycles", "12", "--cycle-timeout", "0.1")
    players = connect_all(srv.players_endpoint)
    players[0].close()  # gone mid-game without a bye
    assert play_together(players[1:], 12) == list(range(12))
    assert srv.wait(30) == 0
    assert "keeper 1 is unreachable (disconnected?); no longer waiting for it" in srv.stderr_text()


def test_a_player_that_never_answers_is_logged_and_the_others_keep_playing(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--max-cycles", "12", "--cycle-timeout", "0.1", "--max-missed", "3")
    players = connect_all(srv.players_endpoint)  # players[0] stays connected but silent
    assert play_together(players[1:], 12) == list(range(12))
    assert srv.wait(30) == 0
    log = srv.stderr_text()
    assert "keeper 1 missed cycle 0 (1 in a row)" in log
    assert "keeper 1 missed 3 cycles in a row; no longer waiting for it" in log
    assert "keeper 1 missed cycle 3" not in log
    assert "keeper 2 missed" not in log


def test_on_hang_stop_ends_the_server_with_a_clear_message(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--cycle-timeout", "0.1", "--max-missed", "2", "--on-hang", "stop")
    players = connect_all(srv.players_endpoint)  # connected, but nobody ever answers
    assert srv.wait(30) == 3
    assert all(isinstance(p.recv_until(m.Shutdown), m.Shutdown) for p in players)
    assert "missed 2 cycles in a row; stopping" in srv.stderr_text()


def test_sigterm_flushes_logs_and_exits_cleanly(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--seed", "2")
    players = connect_all(srv.players_endpoint, fullstate=True)
    coach = ScriptedCoach(srv.coach_endpoint)
    coach.init()
    # play until two episodes have ended, then interrupt the server
    state: dict[int, m.Fullstate] = {}
    ended = 0
    from scripted import chase_and_kick_out

    while ended < 2:
        for i, p in enumerate(players):
            while True:
                msg = p.recv()
                if isinstance(msg, m.Fullstate):
                    state[i] = msg
                if isinstance(msg, m.Hear) and msg.message == "training Keepaway 1" and i == 0:
                    ended += 1
                if isinstance(msg, m.Think):
                    p.answer(msg.cycle, chase_and_kick_out(p.me, state[i]))
                    break
    srv.proc.send_signal(signal.SIGTERM)
    assert srv.wait() == 0
    shutdown = players[0].recv_until(m.Shutdown)
    assert "SIGTERM" in shutdown.reason
    episodes = [l for l in (srv.log_dir / "keepaway.kwy").read_text().splitlines() if l and l[0] != "#"]
    assert len(episodes) >= 2


def test_coach_look_advice_and_start(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--start-on", "coach", "--max-cycles", "4")
    coach = ScriptedCoach(srv.coach_endpoint)
    ok = coach.init()
    assert ok.play_mode == "before_kick_off"
    keeper = ScriptedPlayer(srv.players_endpoint)
    keeper.init("keepers")
    coach.send(m.Start())
    coach.send(m.Advice(target="keepers", payload={"kind": "policy", "getopen_theta": [0.5] * 91}))
    coach.send(m.Look())
    look = coach.recv_until(m.LookOk)
    assert look.state["play_mode"] == "play_on"
    heard = []
    for _ in range(3):
        while True:
            msg = keeper.recv()
            if isinstance(msg, m.Hear):
                heard.append((msg.sender, msg.message))
            if isinstance(msg, m.Think):
                keeper.answer(msg.cycle)
                break
    assert ("referee", "play_on") in heard
    assert ("coach", {"kind": "policy", "getopen_theta": [0.5] * 91}) in heard


def test_change_view_narrows_the_cone_and_refuses_low_quality(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--keepers", "1", "--takers", "1", "--max-cycles", "8",
                                 "--param", "visible_angle=90")
    keeper = ScriptedPlayer(srv.players_endpoint)
    keeper.init("keepers")
    taker = ScriptedPlayer(srv.players_endpoint)
    taker.init("takers")
    flags_seen = {}
    for _ in range(7):
        for p in (keeper, taker):
            while True:
                msg = p.recv()
                if p is keeper and isinstance(msg, m.See):
                    flags_seen[msg.cycle] = sum(f[0] is not None for f in msg.flags)
                if isinstance(msg, m.Think):
                    if p is keeper and msg.cycle == 0:
                        p.answer(0, ("change_view", "narrow", "low"))
                    else:
                        p.answer(msg.cycle)
                    break
    assert any(isinstance(x, m.Error) and x.code == "dropped" and "low quality" in x.message
               for x in keeper.received)
    # narrow (45 deg) sees fewer named flags than normal (90 deg); narrow also sees twice as often
    assert flags_seen[0] > max(flags_seen[c] for c in flags_seen if c > 0)
    assert len([c for c in flags_seen if c > 0]) >= 5


def test_a_server_that_does_not_announce_its_ports_fails_fast_with_its_stderr(processes, tmp_path):
    with pytest.raises(RuntimeError, match="(?s)server did not start.*Invalid value for '--mode'"):
        processes.start_server(tmp_path / "exits", "--mode", "bogus")
    with pytest.raises(RuntimeError, match="server did not start: no .* after 0.05 s"):
        processes.start_server(tmp_path / "silent", start_timeout_s=0.05)  # still importing
    exited, silent = processes.procs
    assert exited.returncode == 2 and silent.returncode == -signal.SIGKILL

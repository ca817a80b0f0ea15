"""``keepaway player`` processes against a real ``keepaway server`` (docs/protocol.md; issue: the player
connects, waits for the game, plays and exits cleanly when the server ends or on SIGTERM)."""

from __future__ import annotations

import re
import signal
import socket
import subprocess

import numpy as np
import pytest

from conftest import keepaway_command, read_until_match
from keepaway.protocol import messages as m
from scripted import ScriptedPlayer

TEAMS = ["keepers"] * 3 + ["takers"] * 2
PROCESS_TIMEOUT_S = 300  # generous: five players load numba caches on two shared cores


def start_players(processes, server, *extra, fullstate_takers=False):
    players = []
    for i, team in enumerate(TEAMS):
        args = ["player", "--team", team, "--server", server.players_endpoint, "--seed", "5", *extra]
        if fullstate_takers and team == "takers":
            args.append("--fullstate")
        players.append(processes.popen(keepaway_command(*args), stdout=subprocess.PIPE, stderr=subprocess.PIPE))
    return players


def episodes_in_kwy(log_dir):
    (kwy,) = log_dir.glob("*.kwy")
    return [line.split() for line in kwy.read_text().splitlines() if line and not line.startswith("#")]


def assert_game_played(server, players, episodes):
    assert server.wait(PROCESS_TIMEOUT_S) == 0, server.stderr_text()[-3000:]
    for proc in players:
        code = proc.wait(PROCESS_TIMEOUT_S)
        err = proc.stderr.read().decode()
        assert code == 0, err[-3000:]
        assert "Traceback" not in err
    rows = episodes_in_kwy(server.log_dir)
    assert [int(r[0]) for r in rows] == list(range(1, episodes + 1))
    assert all(r[4] in ("o", "t") for r in rows)


def test_five_players_play_a_synchronous_game_to_its_end(processes, tmp_path):
    server = processes.start_server(tmp_path, "--episodes", "5", "--mode", "sync")
    players = start_players(processes, server, fullstate_takers=True)
    assert_game_played(server, players, 5)


@pytest.mark.slow
def test_five_players_play_a_real_time_game_to_its_end(processes, tmp_path):
    server = processes.start_server(tmp_path, "--episodes", "2", "--mode", "realtime")
    players = start_players(processes, server)
    assert_game_played(server, players, 2)


def test_sigterm_makes_a_player_say_bye_and_exit_0(processes, tmp_path):
    server = processes.start_server(tmp_path, "--mode", "sync")
    player = processes.popen(keepaway_command("player", "--team", "keepers", "--server", server.players_endpoint,
                                              "-v"), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    read_until_match(player.stderr, re.compile("joined as keepers 1"), PROCESS_TIMEOUT_S)
    player.send_signal(signal.SIGTERM)
    assert player.wait(PROCESS_TIMEOUT_S) == 0
    assert "Traceback" not in player.stderr.read().decode()
    read_until_match(server.proc.stderr, re.compile("keeper 1 said bye"), 30)
    server.proc.send_signal(signal.SIGTERM)
    assert server.wait(PROCESS_TIMEOUT_S) == 0


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_player_without_a_server_exits_2_after_the_connect_timeout(processes):
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    proc = processes.popen(keepaway_command("player", "--team", "takers", "--server", endpoint,
                                            "--connect-timeout", "2"),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.wait(PROCESS_TIMEOUT_S) == 2
    err = proc.stderr.read().decode()
    assert err.strip() == (f"keepaway player: no answer from the server at {endpoint} within 2 s: is it running, "
                           f"and do you have an authorised key (--keys)?")


def test_a_player_waits_through_a_slow_start_and_gives_a_frozen_server_up(processes, tmp_path):
    # Before the coach's start the server sends only `waiting`, every second: a player with a 3 s
    # silence limit stays for 5 s; once the server is frozen (SIGSTOP) it exits 4 with one line.
    server = processes.start_server(tmp_path, "--start-on", "coach")
    proc = processes.popen(keepaway_command("player", "--team", "takers", "--server", server.players_endpoint,
                                            "--server-silence", "3", "-v"),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    read_until_match(proc.stderr, re.compile("joined as takers 1"), PROCESS_TIMEOUT_S)
    with pytest.raises(subprocess.TimeoutExpired):
        proc.wait(5)
    server.proc.send_signal(signal.SIGSTOP)
    try:
        assert proc.wait(PROCESS_TIMEOUT_S) == 4
    finally:
        server.proc.send_signal(signal.SIGCONT)
    err = proc.stderr.read().decode()
    assert err.strip().splitlines()[-1] == (f"keepaway player: the server at {server.players_endpoint} has "
                                            f"sent nothing for 3 s; giving it up")


def test_a_bad_policy_file_stops_the_player_with_one_line(processes, tmp_path):
    policy = tmp_path / "broken.npz"
    np.save(tmp_path / "broken.npy", np.zeros(3))
    policy.write_bytes((tmp_path / "broken.npy").read_bytes()[:20])
    proc = processes.popen(keepaway_command("player", "--team", "keepers", "--getopen", "learned",
                                            "--policy", str(policy), "--connect-timeout", "1"),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.wait(PROCESS_TIMEOUT_S) == 2
    err = proc.stderr.read().decode()
    assert len(err.strip().splitlines()) == 1
    assert err.startswith(f"keepaway player: {policy}: not a readable policy archive")


def test_a_refused_init_exits_2_with_the_servers_message(processes, tmp_path):
    server = processes.start_server(tmp_path, "--mode", "sync")
    keepers = [ScriptedPlayer(server.players_endpoint) for _ in range(3)]
    try:
        assert all(isinstance(k.init("keepers"), m.InitOk) for k in keepers)
        proc = processes.popen(keepaway_command("player", "--team", "keepers", "--server", server.players_endpoint),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        assert proc.wait(PROCESS_TIMEOUT_S) == 2
    finally:
        for k in keepers:
            k.close()
    err = proc.stderr.read().decode()
    assert err.strip() == "keepaway player: the server refused init: no_more_player: all keepers are connected"

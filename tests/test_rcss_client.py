"""``keepaway player --rcss``: our players on rcssserver (agents/rcss_client.py).

Without rcssserver: the options our server's players take alone are refused with --rcss, a player with no
rcssserver to answer ends with exit code 2, and a player plays against a stand-in that answers with the
datagrams rcssserver 19 sent a player (``tests/data/rcss-messages.json``): it joins on the port the answer
came from, answers every ``(think)`` with its commands and ``(done)``, says ``(bye)`` on SIGTERM and ends
with exit code 0; seated on the wrong side, it says so and ends with exit code 2.

With rcssserver (``$KEEPAWAY_REFERENCE_STACK``, the prefix ``tools/build-reference-stack.sh`` builds into;
without it these tests say so and are skipped): our 3 keepers and 2 takers play Keepaway on it with
keepaway.sh's settings (synchronous, CURRENT parameters) through ``benchmarks/reference_stack.py``, and
so do our keepers against the keepaway-0.6 C++ takers and the C++ keepers against ours: the episodes end
with sensible durations, no player logs a warning, an error or a traceback, and every process ends
cleanly (ours with exit code 0, rcssserver with 0, keepaway-0.6's players by the SIGTERM they do not catch).
"""

from __future__ import annotations

import json
import select
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import keepaway_command

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # benchmarks/

from benchmarks.reference_stack import (  # noqa: E402
    KEEPERS,
    LOG_NAME,
    TAKERS,
    Cell,
    ReferenceStack,
    free_udp_ports,
    play_campaign,
)
from keepaway.server.episode_log import read_kwy  # noqa: E402

RECORDED = json.loads((REPO / "tests" / "data" / "rcss-messages.json").read_text())
START_S = 120.0  # a player loads (or compiles) its kernels before it sends init
QUICK_S = 60.0
SIGTERM_EXIT = -signal.SIGTERM  # keepaway-0.6's players do not catch SIGTERM


def one_line(proc: subprocess.Popen, code: int) -> str:
    """The one stderr line of a player that ended with ``code``."""
    _, err = proc.communicate(timeout=START_S)
    assert proc.returncode == code, err
    lines = [line for line in err.decode().splitlines() if line.strip() and not line.startswith(("Usage:", "Try '"))]
    assert len(lines) == 1 and "Traceback" not in err.decode(), err
    return lines[0]


@pytest.mark.parametrize("extra", [["--keys", "."], ["--server", "tcp://127.0.0.1:6000"], ["--fullstate"]],
                         ids=lambda extra: extra[0])
def test_the_options_of_our_servers_players_are_refused_with_rcss(processes, extra):
    proc = processes.popen(keepaway_command("player", "--team", "keepers", "--rcss", "127.0.0.1:6000", *extra),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert f"{extra[0]} is for our server" in one_line(proc, 2)


def test_an_rcss_address_is_host_and_port(processes):
    proc = processes.popen(keepaway_command("player", "--team", "keepers", "--rcss", "6000"),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert one_line(proc, 2).endswith("Invalid value for --rcss: '6000' is not HOST:PORT")


def test_a_player_without_an_rcssserver_ends_with_exit_code_2(processes):
    port = free_udp_ports(1)
    proc = processes.popen(keepaway_command("player", "--team", "keepers", "--rcss", f"127.0.0.1:{port}",
                                            "--connect-timeout", "1"), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert one_line(proc, 2) == (f"keepaway player: no answer from rcssserver at 127.0.0.1:{port} within 1 s: "
                                 f"is it running?")


class StandIn:
    """rcssserver's side of one player: the init port, and the player's own port it answers from."""

    def __init__(self) -> None:
        self.init = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.init.bind(("127.0.0.1", 0))
        self.own = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.own.bind(("127.0.0.1", 0))
        self.port = self.init.getsockname()[1]
        self.player: tuple[str, int] | None = None

    def receive(self, sock: socket.socket, timeout_s: float) -> str:
        if not select.select([sock], [], [], timeout_s)[0]:
            raise TimeoutError(f"the player sent nothing in {timeout_s:g} s")
        data, self.player = sock.recvfrom(65536)
        assert data.endswith(b"\0"), data  # rcssserver warns of a message without its NUL from version 8 on
        return data[:-1].decode()

    def send(self, text: str) -> None:
        self.own.sendto(text.encode() + b"\0", self.player)

    def close(self) -> None:
        self.init.close()
        self.own.close()


@pytest.fixture
def stand_in():
    server = StandIn()
    yield server
    server.close()


def test_a_player_answers_rcssservers_datagrams_and_says_bye(processes, stand_in):
    recorded = next(p for p in RECORDED["players"] if (p["team"], p["version"]) == ("keepers", 15))
    proc = processes.popen(keepaway_command("player", "--team", "keepers", "--rcss", f"127.0.0.1:{stand_in.port}",
                                            "-v"), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert stand_in.receive(stand_in.init, START_S) == "(init keepers (version 15))"
    answers = []
    for text in recorded["received"]:
        stand_in.send(text)
        if text == "(think)":
            answers.append(stand_in.receive(stand_in.own, QUICK_S))  # from the port the answer went to
    assert len(answers) == recorded["received"].count("(think)") and all(a.endswith("(done)") for a in answers)
    assert any(a.startswith(("(dash ", "(turn ", "(kick ")) for a in answers)  # it played once it had joined
    proc.send_signal(signal.SIGTERM)
    assert stand_in.receive(stand_in.own, QUICK_S) == "(bye)"
    _, err = proc.communicate(timeout=QUICK_S)
    assert proc.returncode == 0, err
    assert "joined as keepers 2 (sync mode, protocol version 15)" in err.decode()
    assert "WARNING" not in err.decode() and "Traceback" not in err.decode()


def test_a_player_seated_on_the_wrong_side_says_bye_and_ends(processes, stand_in):
    proc = processes.popen(keepaway_command("player", "--team", "takers", "--rcss", f"127.0.0.1:{stand_in.port}"),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    stand_in.receive(stand_in.init, START_S)
    stand_in.send("(init l 1 before_kick_off)")
    assert stand_in.receive(stand_in.own, QUICK_S) == "(bye)"
    assert one_line(proc, 2) == (f"keepaway player: rcssserver at 127.0.0.1:{stand_in.port} seated the takers on "
                                 f"side l: it seats the team that joins first on the left, and the keepers must be "
                                 f"on the left: start them first")


# ------------------------------------------------------------------------------------------ rcssserver


def campaign(stack: ReferenceStack, log_dir: Path, policy: str, episodes: int, ours: tuple[str, ...]) -> list[float]:
    """Play the campaign; check how every process ended and what our players logged; return the asked-for
    episodes' hold times in seconds."""
    cell = Cell("rcssserver", *("ours" if team in ours else "cpp" for team in ("keepers", "takers")))
    members = play_campaign(stack, cell, policy, episodes, seed=3, log_dir=log_dir)
    expected = {"server": 0}
    for team, count in (("keepers", KEEPERS), ("takers", TAKERS)):
        expected |= {f"{team[:-1]} {i}": 0 if team in ours else SIGTERM_EXIT for i in range(1, count + 1)}
    assert {m.name: m.proc.returncode for m in members} == expected
    for member in members[1:]:
        log = (log_dir / f"{member.name.replace(' ', '_')}.log").read_text()
        if member.proc.returncode == 0:  # one of ours (its uniform number: the order it joined in)
            assert f"joined as {member.name.split()[0]}s " in log and "(sync mode, protocol version 15)" in log, log
            assert not any(word in log for word in ("WARNING", "ERROR", "Traceback")), log
    kwy = read_kwy(log_dir / f"{LOG_NAME}.kwy")
    assert len(kwy) > episodes
    return [record.duration / 10 for record in kwy[:episodes]]


@pytest.mark.slow
def test_our_players_play_keepaway_on_rcssserver(reference_stack, tmp_path):
    stack = reference_stack
    hold = campaign(stack, tmp_path / "hold", "hold", 20, ("keepers", "takers"))
    # always hold: 2.77-2.98 s on the reference stack (docs/results.md), standard deviation about 0.9 s
    assert 2.0 < sum(hold) / len(hold) < 4.0 and min(hold) >= 0.5, hold
    handcoded = campaign(stack, tmp_path / "handcoded", "handcoded", 5, ("keepers", "takers"))
    assert min(handcoded) >= 0.5 and max(handcoded) < 300, handcoded


@pytest.mark.slow
@pytest.mark.parametrize("ours", [("keepers",), ("takers",)], ids=lambda ours: f"ours-{ours[0]}")
def test_our_players_play_beside_keepaway_0_6s(reference_stack, tmp_path, ours):
    stack = reference_stack
    hold = campaign(stack, tmp_path, "hold", 10, ours)
    assert 1.5 < sum(hold) / len(hold) < 5.0 and min(hold) >= 0.5, hold

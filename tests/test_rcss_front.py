"""The rcssserver-protocol front (``keepaway server --rcss-port``) with real processes over real UDP and
ZeroMQ: a text client written from rcssserver's protocol alone plays beside our players; hostile text
on the UDP ports gets rcssserver's error replies and never stops the game; and the unmodified keepaway-0.6
C++ players play their Keepaway on our server (where the reference stack is built,
``KEEPAWAY_REFERENCE_STACK``; tools/build-reference-stack.sh)."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import zmq

from keepaway.protocol import messages as m
from keepaway.protocol.codec import encode
from keepaway.server.app import LOCAL_PREFIX
from scripted import ScriptedPlayer, play_together

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
from benchmarks.reference_stack import Cell, campaign_logs, play_campaign  # noqa: E402


class TextClient:
    """A bare UDP client of the front: datagrams out, NUL-terminated text in."""

    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(20.0)
        self.server = ("127.0.0.1", port)

    def send(self, text: str | bytes) -> None:
        self.sock.sendto(text if isinstance(text, bytes) else text.encode() + b"\0", self.server)

    def recv(self) -> str:
        data, self.server = self.sock.recvfrom(65536)
        assert data.endswith(b"\0"), data[-20:]
        return data[:-1].decode()

    def recv_until(self, prefix: str) -> str:
        while not (text := self.recv()).startswith(prefix):
            pass
        return text

    def close(self) -> None:
        self.sock.close()


def game_with_text_seat(processes, tmp_path, *extra: str):
    """A server with the front, taker 1 left free for a text client, our scripted players in the other
    seats (keepers 1-3 and taker 2)."""
    srv = processes.start_server(tmp_path, "--rcss-port", "0", "--max-cycles", "60", *extra)
    assert srv.rcss_port is not None
    ours = [ScriptedPlayer(srv.players_endpoint) for _ in range(4)]
    for player, team in zip(ours, ("keepers", "keepers", "keepers", "takers")):
        assert isinstance(player.init(team), m.InitOk)
    return srv, ours


@pytest.mark.parametrize("version", [8, 12, 19])
def test_a_text_client_of_rcssserver_protocol_plays_beside_our_players(processes, tmp_path, version):
    """examples/rcss_text_taker.py, written from rcssserver's protocol alone, joins through the front as
    taker 2 and plays its cycles in synchronous mode beside scripted ZeroMQ players: the game runs to its
    end and the text taker dashed (our server counted its dashes in the game log)."""
    srv = processes.start_server(tmp_path, "--rcss-port", "0", "--max-cycles", "40", "--takers", "2")
    ours = [ScriptedPlayer(srv.players_endpoint) for _ in range(4)]
    for player, team in zip(ours, ("keepers", "keepers", "keepers", "takers")):
        assert isinstance(player.init(team), m.InitOk)
    taker = processes.popen([sys.executable, str(REPO / "examples" / "rcss_text_taker.py"), "--port",
                             str(srv.rcss_port), "--version", str(version), "--cycles", "30"])
    play_together(ours, 39)
    assert taker.wait(timeout=60) == 0, processes.stderr_tail(taker)
    assert srv.proc.wait(timeout=60) == 0
    shows = [line for line in (srv.log_dir / "keepaway.rcg").read_text().splitlines() if line.startswith("(show 39 ")]
    assert shows, "no show of cycle 39"
    text_taker = shows[0].split("((r 2)")[1]
    dashes = int(text_taker.split("(c ")[1].split()[1])
    assert dashes > 0
    assert "Traceback" not in srv.stderr_path.read_text()


def test_hostile_text_gets_rcssserver_errors_and_the_game_goes_on(processes, tmp_path):
    """Garbage, unknown commands, oversized and deep datagrams, NUL bytes, a flood on the init port and on
    a seated client's own port: the senders get rcssserver's error texts (or nothing), the front and the
    server stay up, and the other players' cycles keep coming."""
    srv, ours = game_with_text_seat(processes, tmp_path, "--cycle-timeout", "0.05")
    stranger = TextClient(srv.rcss_port)
    for bad in ["(init)", "init keepers", "(init a b c d e f)", "((((((((((((((((((((x))))))))))))))))))))",
                "(reconnect takers 99)", "\x00\x01\x02", "(init " + "x" * 9000 + ")", ")("]:
        stranger.send(bad)
        assert stranger.recv().startswith("(error ")
    seated = TextClient(srv.rcss_port)
    seated.send("(init takers (version 12))")
    assert seated.recv().startswith("(init r 2 ")
    for bad in ["(dash)", "(dash abc)", "(fly 3)", "(dash 100", "(turn nan)", "(say " + "y" * 9000 + ")"]:
        seated.send(bad)
        assert seated.recv_until("(error ").startswith("(error ")
    for _ in range(3000):  # a flood: the others still play every cycle
        seated.send("(dash 100)(turn 30)(kick 100 0)")
        stranger.send("(init flooders (version 12))")
    play_together(ours, 20)
    seated.send("(bye)")
    play_together(ours, 30)
    assert srv.proc.wait(timeout=60) == 0
    stranger.close()
    seated.close()


def test_synch_see_switches_an_older_clients_see(processes, tmp_path):
    """A version-12 client that sends ``(synch_see)`` gets ``(ok synch_see)`` and from then on its see
    every second cycle at normal width, as rcssserver's synch_see mode sends it (before: two cycles of
    three, on send_step's 150 ms)."""
    srv, ours = game_with_text_seat(processes, tmp_path)
    seated = TextClient(srv.rcss_port)
    seated.send("(init takers (version 12))")
    assert seated.recv().startswith("(init r 2 ")
    ours_play = threading.Thread(target=play_together, args=(ours, 40))
    ours_play.start()
    seen: list[int] = []
    switched_at = None
    while len(seen) < 24:
        text = seated.recv()
        if text.startswith("(see "):
            seen.append(int(text.split()[1]))
        elif text.startswith("(sense_body "):
            cycle = int(text.split()[1])
            if cycle == 12 and switched_at is None:
                seated.send("(synch_see)")
                switched_at = cycle
        elif text == "(think)":
            seated.send("(done)")
        elif text.startswith("(ok "):
            assert text == "(ok synch_see)"
    before = [c for c in seen if 0 < c <= 12]
    after = [c for c in seen if c > 13]
    assert len(before) >= 6 and any(c % 2 for c in before), before  # the 150 ms schedule
    assert after and all(c % 2 == 0 for c in after) and len(after) >= (after[-1] - after[0]) // 2, after
    seated.send("(bye)")
    ours_play.join()
    seated.close()


def test_no_zeromq_peer_can_speak_for_a_text_client(processes, tmp_path):
    """A ZeroMQ peer that takes the routing id the server gives its text client (a peer may set any) is
    not heard: its ``bye`` does not unseat the text client, which goes on getting its cycles."""
    srv, ours = game_with_text_seat(processes, tmp_path)
    seated = TextClient(srv.rcss_port)
    seated.send("(init takers (version 12))")
    assert seated.recv().startswith("(init r 2 ")
    impostor = zmq.Context.instance().socket(zmq.DEALER)
    impostor.setsockopt(zmq.ROUTING_ID, LOCAL_PREFIX + (1).to_bytes(4, "big"))
    impostor.connect(srv.players_endpoint)
    impostor.send(encode(m.Bye()))
    assert not impostor.poll(300)
    impostor.close(linger=0)
    play_together(ours, 3)
    assert seated.recv_until("(sense_body 2 ")
    seated.send("(bye)")
    play_together(ours, 57)  # to the 60th cycle: the server stops
    assert srv.proc.wait(timeout=60) == 0
    seated.close()


# -------------------------------------------------------------------------------- the C++ players


@pytest.mark.parametrize("cell", [Cell("ours", "cpp", "cpp"), Cell("ours", "cpp", "ours"),
                                  Cell("ours", "cpp", "cpp", "classic")], ids=lambda c: c.name)
def test_the_keepaway_0_6_cpp_players_play_on_our_server(reference_stack, tmp_path, cell):
    """The unmodified C++ players (keepers with hand-coded Pass; their takers or ours) play three episodes
    on our server through the front, under CURRENT parameters and CLASSIC: every episode ends, no cycle is
    missed, no process fails, and the C++ players print nothing on stderr, as on rcssserver."""
    stack = reference_stack
    play_campaign(stack, cell, "handcoded", 3, seed=5, log_dir=tmp_path)
    _, episodes = campaign_logs(tmp_path, 3)
    assert [e.episode for e in episodes] == [1, 2, 3]
    assert all(e.end_cycle > e.start_cycle for e in episodes)
    lines = [json.loads(line) for line in (tmp_path / "game.jsonl").read_text().splitlines()[1:]]
    assert all(line["missed"] == {} for line in lines[:3]), lines
    for name in ("keeper_1", "keeper_2", "keeper_3", *(("taker_1", "taker_2") if cell.takers == "cpp" else ())):
        assert (tmp_path / f"{name}.log").read_text() == "", name
    server_log = (tmp_path / "server.log").read_text()
    assert " ERROR " not in server_log and "Traceback" not in server_log, server_log[-2000:]


def test_classic_cells_are_on_our_server_only():
    """rcssserver 19 has no parameters for CLASSIC's rules: the harness says so rather than play a wrong game."""
    with pytest.raises(ValueError, match="cannot play CLASSIC"):
        Cell("rcssserver", "cpp", "cpp", "classic")
    assert Cell("ours", "cpp", "cpp", "classic").name == "cpp on ours, CLASSIC"


def test_cpp_players_leave_no_process_behind(reference_stack, tmp_path):
    """After a campaign every process it started is gone (the harness stops the C++ players, which never
    stop by themselves)."""
    stack = reference_stack
    before = set(subprocess.run(["pgrep", "-f", "keepaway_player"], capture_output=True, text=True).stdout.split())
    play_campaign(stack, Cell("ours", "cpp", "cpp"), "hold", 1, seed=1, log_dir=tmp_path)
    time.sleep(0.5)
    after = set(subprocess.run(["pgrep", "-f", "keepaway_player"], capture_output=True, text=True).stdout.split())
    assert after <= before


def test_the_front_as_a_process_of_its_own_seats_a_text_client(processes, tmp_path):
    """``keepaway rcss-front`` in front of a server started without it: the text taker plays through it."""
    srv = processes.start_server(tmp_path, "--max-cycles", "40")
    front = processes.popen([sys.executable, "-m", "keepaway", "rcss-front", "--server", srv.players_endpoint,
                             "--port", "0"], stdout=subprocess.PIPE)
    line = front.stdout.readline().decode()
    assert line.startswith("keepaway rcss-front listening rcss=udp://127.0.0.1:"), line
    port = int(line.split("rcss=udp://127.0.0.1:")[1].split()[0])
    ours = [ScriptedPlayer(srv.players_endpoint) for _ in range(4)]
    for player, team in zip(ours, ("keepers", "keepers", "keepers", "takers")):
        assert isinstance(player.init(team), m.InitOk)
    taker = processes.popen([sys.executable, str(REPO / "examples" / "rcss_text_taker.py"), "--port", str(port),
                             "--version", "12", "--cycles", "30"])
    play_together(ours, 39)
    assert taker.wait(timeout=60) == 0, processes.stderr_tail(taker)
    assert srv.proc.wait(timeout=60) == 0
    front.terminate()
    assert front.wait(timeout=10) == 0
    assert "Traceback" not in processes.stderr_tail(front)


@pytest.mark.parametrize("args, says", [
    (["--server", "tcp://127.0.0.1:"], "Invalid value for --server"),
    (["--port", "70000"], "Invalid value for '--port'"),
])
def test_rcss_front_refuses_bad_options_in_one_line(args, says):
    run = subprocess.run([sys.executable, "-m", "keepaway", "rcss-front", *args], capture_output=True, text=True,
                         timeout=60)
    assert run.returncode == 2 and says in run.stderr, run.stderr


def test_rcss_front_says_when_its_port_is_taken():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        run = subprocess.run([sys.executable, "-m", "keepaway", "rcss-front", "--port", str(taken.getsockname()[1])],
                             capture_output=True, text=True, timeout=60)
    assert run.returncode == 1 and "cannot bind udp://127.0.0.1:" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr

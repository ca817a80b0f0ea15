"""Record what rcssserver sends a player, for ``tests/test_rcss_read.py``: the answers to joining (and to
refused attempts), the parameter messages, and every percept of the first cycles of a Keepaway game.

Usage: python tools/record_rcss_messages.py RCSSSERVER [OUT]   (OUT: tests/data/rcss-messages.json)

RCSSSERVER is the binary ``tools/build-reference-stack.sh`` builds (``PREFIX/rcssserver/build/rcssserver``).
The server runs in a temporary directory with the settings of ``benchmarks/reference_stack.py``
(keepaway.sh's, synchronous, CURRENT parameters, ``random_seed`` 1). Five players join, each with its own
protocol version: keepers 1 to 4 with versions 19, 15, 12 and 8, then takers 1 with version 19; keepers 4
leaves (``(bye)``) and takes its seat back with ``(reconnect keepers 4)``. A monitor kicks off, and the
players act for ``CYCLES`` cycles (turns, dashes, says, a change of view: the scripts below), answering every
``(think)`` with ``(done)``. The file holds, per player, what it sent and every datagram it received but the
repetitions of the cycle before the kick-off (rcssserver sends cycle 0 again in every loop until then): of
those, the first sense_body and see are kept.
"""

from __future__ import annotations

import json
import select
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # the repository, before tools/

from benchmarks.reference_stack import KICK_OFF_SETTINGS, SERVER_SETTINGS, Monitor, free_udp_ports  # noqa: E402

CYCLES = 6
SEED = 1
PLAYERS = (("keepers", 19), ("keepers", 15), ("keepers", 12), ("keepers", 8), ("takers", 19))
# what a player says in a cycle after the kick-off, by its place in PLAYERS
SCRIPTS = {
    0: {1: "(turn 60)", 2: "(dash 100)", 3: '(say "hello")(turn_neck 30)', 4: "(change_view wide)"},
    4: {1: "(dash 100)", 2: '(say "abc")(dash 100)', 3: "(dash 100 -90)", 4: "(kick 50 0)"},
}
REFUSED = ("(init others (version 19))", "(reconnect keepers 9)", "(init keepers (version x))")
TIMEOUT_S = 30.0


class Client:
    """One UDP client of rcssserver's player port and what it exchanged."""

    def __init__(self, port: int, team: str, version: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.server: tuple[str, int] = ("127.0.0.1", port)
        self.record = {"team": team, "version": version, "sent": [], "received": []}
        self.cycle = -1  # of the last sense_body
        self.kept_before_kick_off: set[str] = set()

    def send(self, text: str) -> None:
        self.record["sent"].append(text)
        self.sock.sendto(text.encode() + b"\0", self.server)

    def receive(self, kicked_off: bool) -> str:
        data, self.server = self.sock.recvfrom(65536)
        text = data.decode("latin-1").rstrip("\0")
        head = text[1:text.find(" ")] if " " in text else text.strip("()")
        if head == "sense_body":
            self.cycle = int(text.split()[1])
        repeated = head in ("sense_body", "see", "think") and not kicked_off
        if not repeated or head not in self.kept_before_kick_off:
            self.record["received"].append(text)
            if repeated:
                self.kept_before_kick_off.add(head)
        return text


def exchange(clients: list[Client], until, kicked_off: bool, act=None) -> None:
    """Receive and answer every (think) with (done) (and a script's commands) until ``until()``."""
    deadline = time.monotonic() + TIMEOUT_S
    while not until():
        if time.monotonic() > deadline:
            raise SystemExit("record_rcss_messages: rcssserver stopped answering")
        ready, _, _ = select.select([c.sock for c in clients], [], [], 0.1)
        for client in clients:
            if client.sock in ready and client.receive(kicked_off) == "(think)":
                client.send(f"{act(client) if act else ''}(done)")


def main() -> None:
    if len(sys.argv) not in (2, 3):
        raise SystemExit(__doc__.split("\n\n")[1])
    binary = Path(sys.argv[1]).resolve()
    out = Path(sys.argv[2]) if len(sys.argv) == 3 else REPO / "tests" / "data" / "rcss-messages.json"
    port = free_udp_ports()
    settings = {**SERVER_SETTINGS, **KICK_OFF_SETTINGS, "port": port, "coach_port": port + 1,
                "olcoach_port": port + 2, "keepaway_log_dir": ".", "game_log_dir": ".", "random_seed": SEED}
    with tempfile.TemporaryDirectory() as cwd:
        server = subprocess.Popen([str(binary), *(f"server::{k}={v}" for k, v in settings.items())], cwd=cwd,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            time.sleep(1.0)
            monitor = Monitor(port)
            refusals = []
            for text in REFUSED[1:]:  # the third team's refusal needs two teams seated: below
                probe = Client(port, "", 0)
                probe.send(text)
                refusals.append({"sent": text, "received": probe.receive(False)})
            clients: list[Client] = []
            for team, version in PLAYERS:
                client = Client(port, team, version)
                client.send(f"(init {team} (version {version}))")
                clients.append(client)
                exchange(clients, lambda: client.cycle >= 0, False)
            probe = Client(port, "", 0)
            probe.send(REFUSED[0])
            refusals.insert(0, {"sent": REFUSED[0], "received": probe.receive(False)})
            leaving = clients[3]
            leaving.send("(bye)")
            back = Client(port, leaving.record["team"], leaving.record["version"])
            back.record = leaving.record
            back.send("(reconnect keepers 4)")
            clients[3] = back
            exchange(clients, lambda: back.cycle >= 0 and monitor.look(0.05) == {"l": 4, "r": 1}, False)
            monitor.kick_off()
            scripts = {clients[i]: script for i, script in SCRIPTS.items()}
            exchange(clients, lambda: min(c.cycle for c in clients) >= CYCLES, True,
                     lambda c: scripts.get(c, {}).get(c.cycle, ""))
        finally:
            server.terminate()
            server.wait()
    record = {
        "description": "What rcssserver 19.0.0 sends a player (tools/record_rcss_messages.py): per player, what it "
                       "sent and the datagrams it received, without their NUL byte; the refused attempts to join.",
        "server": "rcssserver 19.0.0",
        "settings": {k: v for k, v in settings.items() if k not in ("port", "coach_port", "olcoach_port")},
        "players": [c.record for c in clients],
        "refusals": refusals,
    }
    out.write_text(json.dumps(record, indent=1) + "\n")
    print(f"{out}: {sum(len(c.record['received']) for c in clients)} messages of {len(clients)} players")


if __name__ == "__main__":
    main()

"""Record what a real rcssserver answers to tricky text datagrams, for tests/test_rcss_commands.py.

    python tools/record_rcss_commands.py RCSSSERVER [-o tests/data/rcss-command-replies.json]

RCSSSERVER is the rcssserver 19.0.0 binary ``tools/build-reference-stack.sh`` builds (it binds loopback).
Each init-port case goes to a fresh server; each player case goes from a freshly seated player (version
``version``, team ``keepers``, with one ``takers`` player seated too) to its own port, the server
restarted when its keepers run out or a case ends it. The server's periodic percepts are made rare
(sense_body_step and send_step 100 s) and the sees and hears that still come are left out, as are the
parameters that follow an init. Left out by design, because our front answers them otherwise:
``(compression N)`` (this rcssserver has zlib and compresses from then on) and ``(dispinit)`` (it seats
a monitor). A case after which the server process is gone is recorded with ``"crashed": true``. A
datagram ending in byte 0x80 is not recorded: it hangs rcssserver's 7-bit scanner.
"""

from __future__ import annotations

import argparse
import json
import socket
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository, before tools/

from benchmarks.reference_stack import free_udp_ports, wait_until_bound  # noqa: E402
from keepaway.runner.launch import ArenaProcesses, Member  # noqa: E402

QUIET_S = 0.3  # a server that sends nothing for this long has answered
KEEPERS_PER_SERVER = 10  # the eleventh seat of the keepers is left free
SETTINGS = ("sense_body_step=100000", "send_step=100000", "game_logging=0", "text_logging=0")
PERIODIC = tuple(f"({name} ".encode() for name in ("see", "hear", "server_param", "player_param", "player_type"))
SAY_301 = "a" * 301
INIT_CASES = [
    b"(init keepers (version 12.000000))\0", b"(init takers)", b"(init takers (goalie) (version 19))",
    b"(init takers(version 7)(goalie))\n", b"(init a>?@[\\]^_,./:; )", b"(init keepers) x (version 5))",
    b"(init keepers (version 1e1))", b"(init keepers (version 0x13))", b"(init keepers (version 19.99))",
    b"(init keepers (version 12)(version 8))", b"(init )", b"(init !x)", b"(init (version 8))", b"(init keepers",
    b"(init keepers x)", b"(init keepers!)", b"(init 1234567890123456)", b"(init keepers (version 12)",
    b"(init keepers (version x))", b"(init keepers (version 12 x))", b"(init keepers (goalie) x)",
    b"(init keepers (fullstate))", b"(init keepers (version 20))", b"(init keepers (version 0.9))",
    b"(init keepers (version nan))", b"(init keepers (version -inf))", b"(dispinit version x)",
    b" (init keepers)", b"(dash 100)", b"\n", b"", b"(reconnect keepers 3)", b"(reconnect keepers)",
    b"(reconnect keepers x)", b"(reconnect )", b"(init keepers\0 (version 12))",
]
PLAYER_CASES = [(12.0, datagram) for datagram in (
    b'(kick 80 -30)(turn_neck -19)(say "6 8 kbb")\0', b"(change_view normal high)(done)\0",
    b"(dash 100)(foo)(turn 5)", b"(score)(turn", b"(turn 1 2)(score)\0", b"(dash nan)(score)\0", b"\0",
    b" \n\0", b"(dash 1)\0(score)\0", b"(say hello)(score)\0", b'(say "hello")(score)\0', b"(say\thello)(score)\0",
    b"(score)(bye)(dash 1)\0", b"(score)(bye)(score)\0", b"(sense_body)\0", b"(synch_see)\0", b"(gaussian_see)\0",
    b"(clang (ver 7 8))(clang (ver -1 4294967297))\0",
    b"(pointto 10 -30)(pointto off)(change_focus 1.5 -20)(attentionto our 3)(attentionto left 3)"
    b"(attentionto keepers 2)(attentionto off)(score)\0",
    b'(ear (on))(ear (off opp))(ear (on r complete))(ear (on p))(ear (on keepers))(ear (on "takers" c))'
    b"(ear (off nobody))\0",
    b"(long_kick 100 30)(dash (l 100 0))(dash (r 100 0) (l 50 10))(score)\0",
    b"(dash 1e999 -1e999)(kick 4294967396 .5)(turn 1e2)(turn_neck +5)(move -10 20)(catch 45)(tackle 50 on)"
    b"(tackle 50 false)(change_view wide)(change_view narrow low)(score)\0",
    b"(dash 1.5.3)(score)\0", b"(dash 5.)(score)\0", b"(dash 1e)(score)\0", b"(dash 100 -90)(dash -.5)(score)\0",
    b'(say "' + SAY_301.encode() + b'")(score)\0', b"(done)" * 2000 + b"\0", b"(score)\r\0", b"(score)(say \xe9)\0",
    b"(dash 1\xb10)\0", b"\xe9\0", b"(say )\0", b"(say ))(score)\0", b'(say "")\0',
    *(text.encode() + b"\0" for text in (
        "(dash)", "(dash 1 2 3)", "(dash (l 1 2) (l 1 2))", "(turn x)", "(compression 1.5)", "(attentionto on 3)",
        "(pointto on)", "(change_view high)", "(clang (ver 1))", "(ear on)", "(ear (on our keepers))", "(say)",
        "(say 'x')", "dash 100", "((dash 100))", "(DASH 100)", "(dash 100", "(init keepers)", "(done x)")),
)] + [(8.0, b"(score)"), (7.0, b"(score)"), (19.0, b"(score)(synch_see)")]


def received(sock: socket.socket) -> list[tuple[bytes, tuple]]:
    """Every datagram that arrives until QUIET_S pass without one that is not a periodic percept (a
    synch see comes every cycle or two)."""
    found = []
    quiet_from = time.monotonic()
    while (wait := quiet_from + QUIET_S - time.monotonic()) > 0:
        sock.settimeout(wait)
        try:
            found.append(sock.recvfrom(65536))
        except TimeoutError:
            break
        if not found[-1][0].startswith(PERIODIC):
            quiet_from = time.monotonic()
    return found


def replies(datagrams: list[tuple[bytes, tuple]]) -> list[str]:
    """The answers in them, without their NUL, the periodic percepts and an init's parameters left out."""
    return [data.rstrip(b"\0").decode("latin-1") for data, _ in datagrams if not data.startswith(PERIODIC)]


class Reference:
    """A running rcssserver on free loopback ports, restarted as the cases need."""

    def __init__(self, binary: Path, work: Path) -> None:
        self.binary, self.work = binary, work
        self.arena: ArenaProcesses | None = None
        self.server: Member | None = None
        self.taker: socket.socket | None = None  # seated, so that both teams have a name
        self.keepers = KEEPERS_PER_SERVER

    def restart(self) -> None:
        self.stop()
        self.port = free_udp_ports()
        ports = (f"port={self.port}", f"coach_port={self.port + 1}", f"olcoach_port={self.port + 2}")
        self.arena = ArenaProcesses(self.work)
        self.server = self.arena.start("rcssserver", [str(self.binary), *(f"server::{s}" for s in ports + SETTINGS)],
                                       cwd=self.work)
        wait_until_bound(self.port, self.server)
        self.keepers = 0

    def stop(self) -> None:
        if self.arena is not None:
            self.arena.stop()
            self.arena = None
        if self.taker is not None:
            self.taker.close()
            self.taker = None

    def client(self) -> socket.socket:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.bind(("127.0.0.1", 0))
        return sock

    def seat(self, team: str, version: float) -> tuple[socket.socket, tuple]:
        """A player of ``team`` seated; its socket and its port's address."""
        sock = self.client()
        sock.sendto(f"(init {team} (version {version}))\0".encode(), ("127.0.0.1", self.port))
        answers = received(sock)
        if not answers or not answers[0][0].startswith(b"(init "):
            raise RuntimeError(f"rcssserver did not seat a player of {team}: {answers[:1]}")
        return sock, answers[0][1]

    def init_case(self, datagram: bytes) -> dict:
        self.restart()
        with self.client() as sock:
            sock.sendto(datagram, ("127.0.0.1", self.port))
            answers = replies(received(sock))
        self.keepers = KEEPERS_PER_SERVER  # whatever it seated, the next case has a fresh server
        return {"port": "init", "datagram": datagram.decode("latin-1"), "replies": answers}

    def player_case(self, version: float, datagram: bytes) -> dict:
        if self.keepers >= KEEPERS_PER_SERVER:
            self.restart()
            self.taker = self.seat("takers", 12.0)[0]
        sock, address = self.seat("keepers", version)
        self.keepers += 1
        with sock:
            sock.sendto(datagram, address)
            answers = replies(received(sock))
        case = {"port": "player", "version": version, "datagram": datagram.decode("latin-1"), "replies": answers}
        if self.server.proc.poll() is not None:
            case["crashed"] = True
        if self.server.proc.poll() is not None or b"(bye)" in datagram:
            self.keepers = KEEPERS_PER_SERVER
        return case


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("rcssserver", type=Path, help="the rcssserver 19.0.0 binary")
    parser.add_argument("-o", "--output", type=Path, default=Path("tests/data/rcss-command-replies.json"))
    args = parser.parse_args()
    started = time.monotonic()
    with tempfile.TemporaryDirectory() as work:
        reference = Reference(args.rcssserver.resolve(), Path(work))
        try:
            cases = [reference.init_case(datagram) for datagram in INIT_CASES]
            cases += [reference.player_case(version, datagram) for version, datagram in PLAYER_CASES]
        finally:
            reference.stop()
    record = {
        "about": "rcssserver 19.0.0's answers to text datagrams, by tools/record_rcss_commands.py: each datagram "
                 "as latin-1 text, the init port's (to a fresh server) or a player's (version given, team keepers) "
                 "and the replies, in order, without their NUL, periodic percepts and init parameters",
        "cases": cases,
    }
    args.output.write_text(json.dumps(record, indent=1) + "\n")
    print(f"{len(cases)} cases recorded in {time.monotonic() - started:.0f} s to {args.output}")


if __name__ == "__main__":
    main()

"""Record what rcssserver sends a player, for the golden tests of ``rcss/render.py``
(``tests/test_rcss_render.py``).

Usage::

    python tools/record_rcss_text.py RCSSSERVER [-o tests/data/rcss-text-samples.json]

RCSSSERVER is the built rcssserver 19.0.0 binary (``tools/build-reference-stack.sh`` builds it at
``PREFIX/rcssserver/build/rcssserver``). Every run starts it on free loopback ports, in a fresh temporary
working directory (it writes its ``~/.rcssserver`` files there), in synchronous mode with the trainer alone
changing play modes, and stops it at the end. The output's ``description`` is this text.

* ``init_runs``: one player (team ``keepers``) connects with protocol version V, 8 to 19, under one of our
  parameter sets written out in rcssserver's names with keepaway.sh's launch settings and one player type
  (``PARAMETER_SETS``); ``messages`` is all it gets before its first ``sense_body`` (the init reply,
  ``server_param``, ``player_param``, ``player_type``, and for 18 and later ``(ok synch_see)``), and
  ``sense_body`` that first sense_body (of a player at rest, as it joined, before the kick-off). It then
  says ``(bye)`` and reconnects: ``reconnect_reply`` is rcssserver's reply, followed by the parameter
  messages of the init again (the recorder checks they are the same). ``settings`` are the server's.
* ``errors``: rcssserver's answers to an init of version 20, an init with an illegal team name and a
  reconnect to a team that does not exist, by the code our server refuses them with.
* ``play_runs``: an observer (``keepers`` 1, version V: 8, 12, 13, 14, 19), a teammate (``keepers`` 2) and
  an opponent (``takers`` 1, with ``fullstate_r`` on), the trainer and, in the first scenario, the keepers'
  online coach play one of the ``SCENARIOS`` with the noise off (``PLAY_SETTINGS``). In every cycle T each
  client waits for ``(think)``; ``windows[T]`` then keeps what the observer received since the previous
  window (``observer``) and the exact state of cycle T from the opponent's fullstate (``world``: the ball
  ``[x, y, vx, vy]``, each player ``[x, y, vx, vy, body, neck, stamina, effort, recovery, capacity]``,
  global frame, degrees); then the online coach's and the trainer's commands of T are sent, each answered
  (``answers``), then the players' (``commands``, by cycle), then every client's ``(done)``, and the
  server steps to T + 1. ``changed_in_window`` marks a window whose commands changed the state at once
  (a trainer's move or change of play mode, the observer's change_view): a see stamped T that arrives after
  them (in a later window) may show them. Before the kick-off rcssserver steps without advancing its time,
  so messages stamped 0 may come from several states.
"""

from __future__ import annotations

import argparse
import json
import select
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # the repository, before tools/

from benchmarks.reference_stack import free_udp_ports  # noqa: E402
from keepaway.rcss.sexp import parse_one  # noqa: E402

HOST = "127.0.0.1"
REPLY_TIMEOUT_S = 10.0
START_ATTEMPTS = 3
ANSWERS = ("(ok", "(error", "(warning")  # how the server answers a trainer's or a coach's command
TEAMS = ("keepers", "takers")
VERSIONS = tuple(range(8, 20))
PLAY_VERSIONS = (8, 12, 13, 14, 19)

# Settings every run shares: synchronous mode, a trainer that alone changes play modes, no logs.
COMMON_SETTINGS = {
    "synch_mode": 1, "coach": 1, "coach_w_referee": 0, "use_offside": 0, "half_time": -1, "game_logging": 0,
    "text_logging": 0, "keepaway_logging": 0,
}
# Play runs also turn the noise off (every state is the one the commands give) and let the online coach's
# messages through at once.
PLAY_SETTINGS = {"player_rand": 0, "ball_rand": 0, "kick_rand": 0, "clang_mess_delay": 0}
# Our parameter sets (protocol/params.py) in rcssserver's names, with keepaway.sh's launch settings
# (stamina_inc_max 3500, visible_angle 360) and one player type (type 0, every player's).
ONE_PLAYER_TYPE = {"player::player_types": 1, "player::pt_max": 1, "player::subs_max": 0}
KEEPAWAY_LAUNCH = {"stamina_inc_max": 3500, "visible_angle": 360, "keepaway": 1, "forbid_kick_off_offside": 0}
PARAMETER_SETS = {
    # rcssserver 19.0.0's defaults are the CURRENT set
    "current": {},
    # rcssserver 11.1.1's values where 19.0.0 differs (its NEWS), as the CLASSIC set
    "classic": {"player_speed_max": 1.2, "ball_speed_max": 2.7, "stamina_max": 4000, "extra_stamina": 0,
                "stamina_capacity": -1, "min_dash_power": -100, "min_dash_angle": 0, "max_dash_angle": 0,
                "kick_rand": 0, "drop_ball_time": 200},
}


@dataclass
class Client:
    """One UDP client of the server; ``inbox`` holds what it received, NUL terminators stripped."""

    name: str
    port: int
    sock: socket.socket = field(default_factory=lambda: socket.socket(socket.AF_INET, socket.SOCK_DGRAM))
    inbox: list[str] = field(default_factory=list)
    answered: bool = False  # the server has answered from the address it wants this client to use

    def __post_init__(self) -> None:
        self.sock.bind((HOST, 0))
        self.address = (HOST, self.port)

    def send(self, text: str) -> None:
        self.sock.sendto(text.encode() + b"\0", self.address)

    def receive(self) -> None:
        data, address = self.sock.recvfrom(65536)
        if not self.answered:  # rcssserver answers a player from the port it serves it on
            self.address, self.answered = address, True
        self.inbox.append(data.rstrip(b"\0").decode("latin-1"))


class Harness:
    """The clients of one server and the loop that reads them."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.clients: list[Client] = []

    def connect(self, name: str, port_offset: int, init: str) -> Client:
        client = Client(name, self.port + port_offset)
        self.clients.append(client)
        client.send(init)
        self.wait(lambda: bool(client.inbox), f"{name}'s init reply")
        return client

    def pump(self, timeout_s: float) -> None:
        ready, _, _ = select.select([c.sock for c in self.clients], [], [], timeout_s)
        for client in self.clients:
            if client.sock in ready:
                client.receive()

    def wait(self, done: Callable[[], bool], what: str) -> None:
        deadline = time.monotonic() + REPLY_TIMEOUT_S
        while not done():
            if time.monotonic() > deadline:
                raise RuntimeError(f"no {what} within {REPLY_TIMEOUT_S:.0f} s")
            self.pump(0.05)

    def ask(self, client: Client, command: str) -> str:
        """Send a command that the server answers (a trainer's, a coach's) and return the answer."""
        seen = len(client.inbox)
        client.send(command)
        self.wait(lambda: any(m.startswith(ANSWERS) for m in client.inbox[seen:]), f"answer to {command}")
        return next(m for m in client.inbox[seen:] if m.startswith(ANSWERS))

    def close(self) -> None:
        for client in self.clients:
            client.sock.close()


def server_argv(binary: Path, port: int, settings: dict) -> list[str]:
    values = {**COMMON_SETTINGS, **settings, "port": port, "coach_port": port + 1, "olcoach_port": port + 2}
    return [str(binary), *(f"{name if '::' in name else 'server::' + name}={value}" for name, value in values.items())]


class Server:
    """rcssserver on free ports in a temporary directory; stopped (and waited for) on exit. A start that
    fails (another program took a port first) is tried again on other ports."""

    def __init__(self, binary: Path, settings: dict) -> None:
        self.binary, self.settings = binary, settings

    def __enter__(self) -> Harness:
        for _ in range(START_ATTEMPTS):
            self.directory = tempfile.TemporaryDirectory()
            self.port = free_udp_ports()
            self.process = subprocess.Popen(server_argv(self.binary, self.port, self.settings),
                                            cwd=self.directory.name, stdout=subprocess.DEVNULL,
                                            stderr=subprocess.DEVNULL)
            self.harness = Harness(self.port)
            deadline = time.monotonic() + REPLY_TIMEOUT_S
            while self.process.poll() is None and not bound(self.port) and time.monotonic() < deadline:
                time.sleep(0.05)
            if self.process.poll() is None and bound(self.port):
                return self.harness
            self.__exit__()
        raise RuntimeError(f"rcssserver did not start in {START_ATTEMPTS} attempts")

    def __exit__(self, *exc: object) -> None:
        self.harness.close()
        self.process.terminate()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.directory.cleanup()


def bound(port: int) -> bool:
    """Whether a UDP socket is bound to ``port`` on loopback (Linux's /proc/net/udp: looking does not bind
    the port, which could make the server's own bind fail)."""
    local = f"0100007F:{port:04X}"
    with open("/proc/net/udp") as table:
        return any(line.split()[1] == local for line in table.readlines()[1:])


# -- init runs ----------------------------------------------------------------------------------------------


def record_init(binary: Path, version: int, set_name: str) -> dict:
    """The messages a player of ``version`` gets at its init under parameter set ``set_name``, then the
    answer to a reconnect after a bye."""
    settings = {**KEEPAWAY_LAUNCH, **PARAMETER_SETS[set_name], **ONE_PLAYER_TYPE}
    with Server(binary, settings) as harness:
        player = harness.connect("player", 0, f"(init {TEAMS[0]} (version {version}))")
        harness.wait(lambda: any(m.startswith("(sense_body") for m in player.inbox), "first sense_body")
        first_sense_body = next(m for m in player.inbox if m.startswith("(sense_body"))
        init = player.inbox[:player.inbox.index(first_sense_body)]
        player.send("(bye)")
        again = harness.connect("again", 0, f"(reconnect {TEAMS[0]} 1)")
        harness.wait(lambda: any(m.startswith("(sense_body") for m in again.inbox), "sense_body after the reconnect")
        reconnect = again.inbox[:again.inbox.index(next(m for m in again.inbox if m.startswith("(sense_body")))]
    if reconnect[1:] != init[1:4]:
        raise RuntimeError(f"version {version}: the parameter messages at the reconnect are not those at the init")
    return {"version": version, "parameter_set": set_name,
            "settings": {**COMMON_SETTINGS, **settings, "port": harness.port, "coach_port": harness.port + 1,
                         "olcoach_port": harness.port + 2},
            "messages": init, "sense_body": first_sense_body, "reconnect_reply": reconnect[0]}


def record_errors(binary: Path) -> dict[str, str]:
    """rcssserver's answers to refused inits and reconnects, by the code of our refusal they answer."""
    attempts = {"bad_version": "(init keepers (version 20))", "illegal_teamname": "(init !x (version 12))",
                "no_such_player": "(reconnect nobody 1)"}
    with Server(binary, {}) as harness:
        harness.connect("player", 0, "(init keepers (version 12))")
        return {code: harness.connect(code, 0, attempt).inbox[0] for code, attempt in attempts.items()}


# -- play runs ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Scenario:
    """A play run: settings, the trainer's setup at cycle 0 and the clients' commands by cycle."""

    name: str
    description: str
    settings: dict
    cycles: int
    trainer: dict[int, list[str]]
    observer: dict[int, list[str]] = field(default_factory=dict)
    teammate: dict[int, list[str]] = field(default_factory=dict)
    opponent: dict[int, list[str]] = field(default_factory=dict)
    coach: dict[int, list[str]] = field(default_factory=dict)


SETUP = ["(move (ball) 5 3 0 0 0)", "(move (player keepers 1) 0 0 0 0 0)", "(move (player keepers 2) -8 4 0 0 0)",
         "(move (player takers 1) 12 -9 180 0 0)"]
SCENARIOS = (
    Scenario(
        "play", "360 degree vision; the observer dashes, turns, turns its neck and says; the teammate and the "
        "opponent say; the online coach says a freeform message before the kick-off; the trainer starts play "
        "and later sends the ball far away",
        {"visible_angle": 360, "fullstate_r": 1}, 24,
        trainer={0: [*SETUP, "(change_mode play_on)"], 18: ["(move (ball) -40 20 0 0 0)"]},
        observer={0: ["(clang (ver 7 16))"], 1: ["(dash 60)"], 2: ["(turn_neck 30)"], 3: ["(turn 40)"],
                  4: ["(dash 100)", "(say me too)"], 6: ["(turn_neck -70)", "(dash 80)"], 8: ["(turn -120)"],
                  10: ["(dash 100)"], 11: ["(dash 100)"], 12: ["(turn_neck 50)"], 14: ["(turn 30)"],
                  16: ["(dash 70)", "(say hold 2)"]},
        teammate={3: ["(say pass 3)"], 9: ["(say 12 abc+-)"], 15: ["(dash 100)"], 16: ["(turn 90)"]},
        opponent={5: ["(say take)"], 9: ["(say mine)"], 13: ["(dash 100)"]},
        coach={0: ['(say (freeform "hold the ball"))']},
    ),
    Scenario(
        "close", "90 degree vision; a flag, the ball and the teammate close behind the observer, later a goal; "
        "then a narrow view",
        {"fullstate_r": 1}, 16,
        trainer={0: ["(move (ball) 0 1.5 0 0 0)", "(move (player keepers 1) 1.5 0.5 0 0 0)",
                     "(move (player keepers 2) -0.2 -0.6 0 0 0)", "(move (player takers 1) 40 20 180 0 0)",
                     "(change_mode play_on)"],
                 8: ["(move (player keepers 1) 50.5 1 180 0 0)", "(move (ball) 51 -1 0 0 0)"]},
        observer={3: ["(turn_neck 20)"], 11: ["(turn_neck -40)"], 12: ["(change_view narrow)"]},
    ),
    Scenario(
        "keepaway", "rcssserver's Keepaway referee: the trainer kicks off and moves the ball out of the region",
        {"keepaway": 1, "coach_w_referee": 1, "visible_angle": 360, "fullstate_r": 1}, 8,
        trainer={0: ["(change_mode play_on)"], 4: ["(move (ball) 15 0 0 0 0)"]},
    ),
)


def fullstate_world(text: str) -> dict:
    """The exact state a (v19) fullstate gives: ball [x, y, vx, vy]; players by "side unum":
    [x, y, vx, vy, body, neck, stamina, effort, recovery, capacity]."""
    expression = parse_one(text)
    world: dict = {"cycle": int(expression[1]), "players": {}}
    for item in expression[2:]:
        if not (isinstance(item, list) and item and isinstance(item[0], list)):
            continue
        name = item[0]
        if name == ["b"]:
            world["ball"] = [float(v) for v in item[1:5]]
        elif name[0] == "p":
            stamina = next(part for part in item if isinstance(part, list) and part[0] == "stamina")
            world["players"][f"{name[1]} {name[2]}"] = [float(v) for v in item[1:7]] + [float(v) for v in stamina[1:]]
    return world


def record_play(binary: Path, scenario: Scenario, version: int) -> dict:
    settings = {**PLAY_SETTINGS, **scenario.settings}
    with Server(binary, settings) as harness:
        observer = harness.connect("observer", 0, f"(init {TEAMS[0]} (version {version}))")
        teammate = harness.connect("teammate", 0, f"(init {TEAMS[0]} (version 19))")
        opponent = harness.connect("opponent", 0, f"(init {TEAMS[1]} (version 19))")
        trainer = harness.connect("trainer", 1, "(init (version 19))")
        harness.ask(trainer, "(eye on)")
        coach = harness.connect("coach", 2, f"(init {TEAMS[0]} (version 19))") if scenario.coach else None
        synch = [observer, teammate, opponent, trainer]  # an online coach without (eye on) is not waited for
        scripts = ((observer, scenario.observer), (teammate, scenario.teammate), (opponent, scenario.opponent))
        done_at = {id(c): len(c.inbox) for c in synch}
        windows, observer_from = [], len(observer.inbox)
        for cycle in range(scenario.cycles):
            harness.wait(lambda: all("(think)" in c.inbox[done_at[id(c)]:] for c in synch), f"think of cycle {cycle}")
            fullstate = next(m for m in opponent.inbox[done_at[id(opponent)]:] if m.startswith("(fullstate"))
            received, observer_from = observer.inbox[observer_from:], len(observer.inbox)
            answers = []
            if coach is not None:
                answers += [harness.ask(coach, command) for command in scenario.coach.get(cycle, [])]
            answers += [harness.ask(trainer, command) for command in scenario.trainer.get(cycle, [])]
            for client, script in scripts:
                for command in script.get(cycle, []):
                    client.send(command)
            immediate = bool(scenario.trainer.get(cycle)) or any(
                command.startswith("(change_view") for command in scenario.observer.get(cycle, []))
            windows.append({"cycle": cycle, "observer": received, "world": fullstate_world(fullstate),
                            "changed_in_window": immediate, "answers": answers})
            for client in synch:
                done_at[id(client)] = len(client.inbox)
                client.send("(done)")
    commands = {name: {str(cycle): list(commands) for cycle, commands in script.items()}
                for name, script in (("observer", scenario.observer), ("teammate", scenario.teammate),
                                     ("opponent", scenario.opponent), ("trainer", scenario.trainer),
                                     ("coach", scenario.coach))}
    return {"scenario": scenario.name, "description": scenario.description, "version": version,
            "settings": {**COMMON_SETTINGS, **settings}, "commands": commands, "windows": windows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("rcssserver", type=Path, help="the rcssserver 19.0.0 binary")
    parser.add_argument("-o", "--output", type=Path, default=REPO / "tests" / "data" / "rcss-text-samples.json")
    args = parser.parse_args(argv)
    if not args.rcssserver.is_file():
        parser.error(f"no rcssserver at {args.rcssserver}")
    inits = [record_init(args.rcssserver, version, set_name)
             for set_name in PARAMETER_SETS for version in VERSIONS]
    plays = [record_play(args.rcssserver, scenario, version)
             for scenario in SCENARIOS for version in PLAY_VERSIONS]
    data = {"description": " ".join(__doc__.split()),
            "server_version": "rcssserver-19.0.0", "init_runs": inits, "errors": record_errors(args.rcssserver),
            "play_runs": plays}
    args.output.write_text(json.dumps(data, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The reference stack (rcssserver 19.0.0 + the keepaway-0.6 C++ players) played from Python, for the
side-by-side harness (``benchmarks/side_by_side.py --reference BUILD``), for our players on rcssserver
(``benchmarks/rcss_players.py``, ``tests/test_rcss_client.py``) and for the C++ players on our server
(:class:`Cell`, ``benchmarks/players_servers.py``, ``tests/test_rcss_front.py``).

``BUILD`` is the directory ``tools/build-reference-stack.sh`` builds into (its ``PREFIX``):
``BUILD/rcssserver/build/rcssserver`` and ``BUILD/keepaway/player/keepaway_player``. One campaign is the
server and five players (3 keepers with the given Pass policy, 2 hand-coded takers, hand-coded GetOpen)
in synchronous mode with the launch settings of keepaway-0.6's ``keepaway.sh``, CURRENT parameters
(rcssserver 19's defaults), 3v2 on 20 m, 360 deg vision, the server's ``random_seed`` (which the build
script's patch makes settable) set, game log version 5 and the episode log written to the log directory.
The keepaway-0.6 players join at once and play kicks off after keepaway.sh's ``keepaway_start``.

Either team may be ours instead (``keepaway player --rcss``, docs/cli.md), the same team names and
policies. The keepers must join first (rcssserver seats the first team on the left, the keepers' side),
and ours load their compiled kernels before they join, which may overrun ``keepaway_start``: so a
monitor (``(dispinit version 3)`` on the player port, as rcssmonitor connects) watches the keepers take
their seats before the takers start, and kicks off with ``(dispstart)`` once all five have, which in
Keepaway mode starts play at once (``Stadium::kickOff``). rcssserver then logs no show of cycle 0, so
``trainer.behaviour.game_log_episodes`` leaves the first episode out. keepaway-0.6 parses the players'
``-x EPISODES`` but never stops, so the campaign stops when the ``.kwy`` lists one episode more than asked
for (then every asked-for episode's last show, which carries its last step's kicks, is in the game log).
The processes run through ``runner.launch.ArenaProcesses``: each in its own session, SIGTERM when this
process dies, all stopped (SIGTERM, then SIGKILL) on the way out whatever happens, Ctrl-C included;
rcssserver closes its logs on SIGTERM (:func:`stop_server_idle`), our players say ``(bye)``.
"""

from __future__ import annotations

import re
import signal
import socket
import time
from dataclasses import dataclass
from pathlib import Path

from keepaway.agents.rcss_client import DEFAULT_VERSION
from keepaway.runner.launch import ArenaFailure, ArenaProcesses, Member
from keepaway.server.episode_log import EpisodeRecord, read_kwy
from keepaway.server.game_log import GameRecord, read_rcg

# Our Pass policy names -> keepaway_player's ``-q`` names.
CPP_POLICY = {"hold": "hold", "random": "rand", "handcoded": "hand"}
LOG_NAME = "game"  # game.rcg, game.kwy (keepaway_log_fixed_name / game_log_fixed_name)
# The keepaway.sh launch settings and the measurement's logging (rcssserver's names); the ports and
# directories are added per campaign.
SERVER_SETTINGS = {
    "half_time": -1, "forbid_kick_off_offside": 0, "use_offside": 0, "stamina_inc_max": 3500,
    "synch_mode": 1, "synch_offset": 80, "keepaway": 1, "keepaway_start": 3, "keepaway_width": 20,
    "keepaway_length": 20, "keepaway_logging": 1, "keepaway_log_fixed": 1,
    "keepaway_log_fixed_name": LOG_NAME, "game_logging": 1, "game_log_compression": 0,
    "game_log_version": 5, "game_log_fixed": 1, "game_log_fixed_name": LOG_NAME, "text_logging": 0,
    "visible_angle": 360, "coach": 0,
}
KICK_OFF_SETTINGS = {"keepaway_start": -1}  # no kick-off on a timer where a monitor kicks off (module docstring)
KEEPERS, TAKERS = 3, 2
TEAMS = (("keepers", "l", KEEPERS), ("takers", "r", TAKERS))  # in the order they join
STALL_S = 120.0  # no new episode for this long: the campaign is stuck (a player gone, the server hung)
SEATED_S = 120.0  # longest wait for a team to take its seats (our players load their kernels first)
# A player in a monitor's show (serializermonitor.cpp, v3): ((side unum) type state ...); state 0: no seat
SHOW_PLAYER = re.compile(r"\(\(([lr]) \d+\) \d+ (0x[0-9a-f]+|0) ")


@dataclass(frozen=True)
class ReferenceStack:
    """Where the built reference stack is."""

    build: Path

    @property
    def server(self) -> Path:
        return self.build / "rcssserver" / "build" / "rcssserver"

    @property
    def player(self) -> Path:
        return self.build / "keepaway" / "player" / "keepaway_player"

    def check(self) -> None:
        """ValueError in one line if a binary is missing."""
        for binary in (self.server, self.player):
            if not binary.is_file():
                raise ValueError(f"no reference stack at {self.build}: {binary} is missing "
                                 "(build it with tools/build-reference-stack.sh)")


def free_udp_ports(count: int = 3, host: str = "127.0.0.1") -> int:
    """A port P such that P .. P+count-1 are free for UDP on ``host`` (rcssserver binds its player,
    offline-coach and online-coach ports there): the OS's pick for port 0, tried until a run is free."""
    for _ in range(100):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.bind((host, 0))
            port = probe.getsockname()[1]
        if port + count > 65536:
            continue
        sockets = []
        try:
            for p in range(port, port + count):
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                sockets.append(s)
                s.bind((host, p))
            return port
        except OSError:
            continue
        finally:
            for s in sockets:
                s.close()
    raise RuntimeError("no free run of UDP ports on loopback")


def server_argv(stack: ReferenceStack, port: int, log_dir: Path, seed: int, monitor_kicks_off: bool = False
                ) -> list[str]:
    settings = {**SERVER_SETTINGS, **(KICK_OFF_SETTINGS if monitor_kicks_off else {}), "port": port,
                "coach_port": port + 1, "olcoach_port": port + 2, "keepaway_log_dir": log_dir,
                "game_log_dir": log_dir, "random_seed": seed}
    return [str(stack.server), *(f"server::{name}={value}" for name, value in settings.items())]


def player_argv(stack: ReferenceStack, port: int, team: str, policy: str, episodes: int) -> list[str]:
    return [str(stack.player), "-p", str(port), "-k", str(KEEPERS), "-j", str(TAKERS), "-x", str(episodes),
            "-y", "-1", "-t", team, "-e", "0", "-q", policy]


def our_player_args(port: int, team: str, policy: str, seed: int, version: int) -> list[str]:
    """``keepaway player`` on rcssserver (docs/cli.md): the same team, the same policy."""
    return ["--team", team, "--rcss", f"127.0.0.1:{port}", "--rcss-version", str(version), "--pass", policy,
            "--seed", str(seed), "-v"]


class Monitor:
    """A monitor on rcssserver's player port (module docstring): the seats taken, and the kick-off."""

    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(0.1)
        self.address: tuple[str, int] | None = None  # the monitor's own port on rcssserver, once it answers
        self.seats = {"l": 0, "r": 0}
        self.sock.sendto(b"(dispinit version 3)\0", ("127.0.0.1", port))

    def look(self, wait_s: float = 0.2) -> dict[str, int]:
        """The seats taken on each side, from the shows that come within ``wait_s``."""
        until = time.monotonic() + wait_s
        while time.monotonic() < until:
            try:
                data, self.address = self.sock.recvfrom(65536)
            except TimeoutError:
                continue
            if data.startswith(b"(show "):
                states = SHOW_PLAYER.findall(data.decode("latin-1"))
                self.seats = {side: sum(s == side and state != "0" for s, state in states) for side in "lr"}
        return self.seats

    def kick_off(self) -> None:
        """Start the game, and leave (a monitor slows a synchronous rcssserver down a little)."""
        for message in (b"(dispstart)\0", b"(dispbye)\0"):
            self.sock.sendto(message, self.address)
        self.sock.close()


def wait_seated(monitor: Monitor, side: str, count: int, arena: ArenaProcesses, log_dir: Path) -> None:
    """Until ``count`` players sit on ``side``; ArenaFailure if a process dies or it takes too long."""
    deadline = time.monotonic() + SEATED_S
    while monitor.look()[side] < count:
        dead = next((m for m in arena.members if m.proc.poll() is not None), None)
        if dead is not None:
            raise ArenaFailure(f"reference stack: {dead.describe_exit()}; logs in {log_dir}")
        if time.monotonic() > deadline:
            raise ArenaFailure(f"reference stack: {count} players did not take their seats on side {side} in "
                               f"{SEATED_S:.0f} s; logs in {log_dir}")


def finished_episodes(kwy: Path) -> int:
    """The finished episodes the ``.kwy`` lists so far (0 before the server has written it)."""
    try:
        return len(read_kwy(kwy))
    except ValueError:
        return 0


@dataclass(frozen=True)
class Cell:
    """One cell of the players x servers table: which server plays the game (``"rcssserver"`` or ``"ours"``,
    our server with its rcssserver-protocol front) and whose players keep and take (``"cpp"``,
    keepaway-0.6's ``keepaway_player``, or ``"ours"``, ``keepaway player``, which on rcssserver speaks its
    text protocol with ``--rcss``), with which parameter set (``"current"``, or ``"classic"`` on our server
    only: rcssserver 19 has no parameters for what CLASSIC changes in its rules, :data:`CLASSIC_ON_RCSSSERVER`)."""

    server: str = "rcssserver"
    keepers: str = "cpp"
    takers: str = "cpp"
    params: str = "current"

    def __post_init__(self) -> None:
        if self.params not in ("current", "classic"):
            raise ValueError(f"parameter set {self.params!r}: current or classic")
        if self.params == "classic" and self.server == "rcssserver":
            raise ValueError(CLASSIC_ON_RCSSSERVER)

    @property
    def ours(self) -> tuple[str, ...]:
        """The teams our players play."""
        return tuple(team for team, kind in (("keepers", self.keepers), ("takers", self.takers)) if kind == "ours")

    @property
    def name(self) -> str:
        players = self.keepers if self.keepers == self.takers else f"{self.keepers} keepers, {self.takers} takers"
        return f"{players} on {self.server}" + (", CLASSIC" if self.params == "classic" else "")


REFERENCE = Cell()
CLASSIC_ON_RCSSSERVER = ("rcssserver 19 cannot play CLASSIC: rcssserver 11's noise models, effort rule, failed "
                         "kick, team loss and stamina reset (protocol.params) are its code, not its parameters")


def play_campaign(stack: ReferenceStack, cell: Cell, pass_policy: str, episodes: int, seed: int, log_dir: Path,
                  version: int = DEFAULT_VERSION) -> list[Member]:
    """Play ``episodes`` episodes of ``cell`` with the keepers' ``pass_policy`` ("hold", "random",
    "handcoded") and server seed ``seed``, logs in ``log_dir`` (an earlier ``game.rcg`` there is
    overwritten, each process's stderr appended to ``log_dir/NAME.log``); our players on rcssserver ask for
    protocol ``version``. Returns the processes, stopped. :class:`runner.launch.ArenaFailure` if a process
    dies or the game stalls."""
    stack.check()
    log_dir = log_dir.resolve()
    kwy = log_dir / f"{LOG_NAME}.kwy"
    on_rcssserver = cell.server == "rcssserver"
    with ArenaProcesses(log_dir) as arena:
        kwy.unlink(missing_ok=True)
        monitor = None
        if on_rcssserver:
            port = free_udp_ports()
            # rcssserver writes its configuration to "~/.rcssserver" without expanding the tilde: in log_dir
            server = arena.start("server", server_argv(stack, port, log_dir, seed, bool(cell.ours)), cwd=log_dir)
            wait_until_bound(port, server)
            monitor = Monitor(port) if cell.ours else None
        else:
            port = free_udp_ports(1)
            server, endpoint, _, _ = arena.start_server(our_server_args(port, log_dir, seed, episodes, cell.params))
        for team, side, count in TEAMS:
            policy = pass_policy if team == "keepers" else "handcoded"
            for i in range(1, count + 1):
                name = f"{team[:-1]} {i}"
                if team not in cell.ours:
                    arena.start(name, player_argv(stack, port, team, CPP_POLICY[policy], episodes), cwd=log_dir)
                elif on_rcssserver:
                    arena.start_player(name, our_player_args(port, team, policy, seed, version))
                else:
                    arena.start_player(name, ["--team", team, "--server", endpoint, "--pass", policy, "--seed",
                                              str(seed)])
            if monitor is not None:
                wait_seated(monitor, side, count, arena, log_dir)
        if monitor is not None:
            monitor.kick_off()
        done, progress_at = 0, time.monotonic()
        while done <= episodes:
            time.sleep(1.0)
            now_done = finished_episodes(kwy)
            if now_done > episodes:  # our server then ends the run by itself
                break
            dead = next((m for m in arena.members if m.proc.poll() is not None), None)
            if dead is not None:
                raise ArenaFailure(f"{cell.name}: {dead.describe_exit()}; logs in {log_dir}")
            if now_done > done:
                done, progress_at = now_done, time.monotonic()
            elif time.monotonic() - progress_at > STALL_S:
                raise ArenaFailure(f"{cell.name}: no episode finished in {STALL_S:.0f} s (after {done}); "
                                   f"logs in {log_dir}")
        if on_rcssserver:
            stop_server_idle(server, [m for m in arena.members if m is not server])
    return arena.members


def our_server_args(rcss_port: int, log_dir: Path, seed: int, episodes: int, params: str = "current") -> list[str]:
    """``keepaway server`` as the reference's rcssserver is launched: CURRENT parameters (or ``params``) with
    keepaway.sh's settings (our server's defaults), synchronous, 3v2 on 20 m, the front on ``rcss_port``; it
    plays one episode beyond ``episodes``, as the C++ players never stop."""
    return ["--params", params, "--keepers", str(KEEPERS), "--takers", str(TAKERS), "--seed", str(seed),
            "--rcss-port", str(rcss_port), "--log-dir", str(log_dir), "--kwy-name", LOG_NAME,
            "--episodes", str(episodes + 1)]


def campaign_logs(log_dir: Path, episodes: int) -> tuple[GameRecord, list[EpisodeRecord]]:
    """A campaign's game log and the first ``episodes`` episodes of its ``.kwy``."""
    kwy = log_dir / f"{LOG_NAME}.kwy"
    return read_rcg(log_dir / f"{LOG_NAME}.rcg", kwy), read_kwy(kwy)[:episodes]


def stop_server_idle(server: Member, players: list[Member]) -> None:
    """Stop rcssserver while it waits for its players' ``(done)``: its SIGTERM handler closes the logs at
    once (``src/main.cpp``, ``Stadium::finalize``), and a server caught writing a show then crashes
    (SIGSEGV). So the players are frozen first (SIGSTOP), the server, its cycle's ``(think)`` unanswered,
    is stopped and waited for, then the players are let go and stopped (ours say ``(bye)``)."""
    for player in players:
        player.proc.send_signal(signal.SIGSTOP)
    time.sleep(0.2)  # the server finishes its cycle and waits for the players' (done)
    server.proc.terminate()
    server.proc.wait(timeout=30)
    for player in players:
        player.proc.send_signal(signal.SIGCONT)
        player.proc.terminate()


def play_reference(stack: ReferenceStack, pass_policy: str, episodes: int, seed: int,
                   log_dir: Path) -> tuple[GameRecord, list[EpisodeRecord]]:
    """:func:`play_campaign` of the C++ players on rcssserver; return its logs (:func:`campaign_logs`)."""
    play_campaign(stack, REFERENCE, pass_policy, episodes, seed, log_dir)
    return campaign_logs(log_dir.resolve(), episodes)


def wait_until_bound(port: int, server: Member, timeout_s: float = 30.0) -> None:
    """Wait until rcssserver has bound its player port (ours to bind fails then)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if server.proc.poll() is not None:
            raise ArenaFailure(f"reference stack: {server.describe_exit()}")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind(("127.0.0.1", port))
            except OSError:
                return
        time.sleep(0.05)
    raise ArenaFailure(f"reference stack: rcssserver did not bind port {port} in {timeout_s:.0f} s")

"""The reference stack (rcssserver 19.0.0 + the keepaway-0.6 C++ players) played from Python, for the
side-by-side harness (``benchmarks/side_by_side.py --reference BUILD``); not run in CI.

``BUILD`` is the directory ``tools/build-reference-stack.sh`` builds into (its ``PREFIX``):
``BUILD/rcssserver/build/rcssserver`` and ``BUILD/keepaway/player/keepaway_player``. One campaign is the
server and five players (3 keepers with the given Pass policy, 2 hand-coded takers, hand-coded GetOpen)
in synchronous mode with the launch settings of keepaway-0.6's ``keepaway.sh``, CURRENT parameters
(rcssserver 19's defaults), 3v2 on 20 m, 360 deg vision, the server's ``random_seed`` (which the build
script's patch makes settable) set, game log version 5 and the episode log written to the log directory.
keepaway-0.6 parses the players' ``-x EPISODES`` but never stops, so the campaign stops when the
``.kwy`` lists one episode more than asked for (then every asked-for episode's last show, which carries
its last step's kicks, is in the game log). The processes run through ``runner.launch.ArenaProcesses``:
each in its own session, SIGTERM when this process dies, all stopped (SIGTERM, then SIGKILL) on the way
out whatever happens, Ctrl-C included; rcssserver closes its logs on SIGTERM.
"""

from __future__ import annotations

import socket
import time
from dataclasses import dataclass
from pathlib import Path

from keepaway.runner.launch import ArenaFailure, ArenaProcesses, Member, keepaway_argv
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
KEEPERS, TAKERS = 3, 2
STALL_S = 120.0  # no new episode for this long: the campaign is stuck (a player gone, the server hung)


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


def server_argv(stack: ReferenceStack, port: int, log_dir: Path, seed: int) -> list[str]:
    settings = {**SERVER_SETTINGS, "port": port, "coach_port": port + 1, "olcoach_port": port + 2,
                "keepaway_log_dir": log_dir, "game_log_dir": log_dir, "random_seed": seed}
    return [str(stack.server), *(f"server::{name}={value}" for name, value in settings.items())]


def player_argv(stack: ReferenceStack, port: int, team: str, policy: str, episodes: int) -> list[str]:
    return [str(stack.player), "-p", str(port), "-k", str(KEEPERS), "-j", str(TAKERS), "-x", str(episodes),
            "-y", "-1", "-t", team, "-e", "0", "-q", policy]


def finished_episodes(kwy: Path) -> int:
    """The finished episodes the ``.kwy`` lists so far (0 before the server has written it)."""
    try:
        return len(read_kwy(kwy))
    except ValueError:
        return 0


@dataclass(frozen=True)
class Cell:
    """One cell of the players x server table: which server plays the game (``"rcssserver"`` or
    ``"ours"``, our server with its rcssserver-protocol front) and whose players keep and take
    (``"cpp"``, keepaway-0.6's ``keepaway_player``, or ``"ours"``, ``keepaway player``; on rcssserver
    ours speak its text protocol with ``--rcss``)."""

    server: str = "rcssserver"
    keepers: str = "cpp"
    takers: str = "cpp"

    @property
    def name(self) -> str:
        players = self.keepers if self.keepers == self.takers else f"{self.keepers} keepers, {self.takers} takers"
        return f"{players} on {self.server}"


REFERENCE = Cell()


def play_campaign(stack: ReferenceStack, cell: Cell, pass_policy: str, episodes: int, seed: int,
                  log_dir: Path) -> tuple[GameRecord, list[EpisodeRecord]]:
    """Play ``episodes`` episodes of ``cell`` with the keepers' ``pass_policy`` ("hold", "random",
    "handcoded") and server seed ``seed``, logs in ``log_dir`` (an earlier ``game.rcg`` there is
    overwritten); return the game log and the first ``episodes`` episodes of the ``.kwy``.
    :class:`runner.launch.ArenaFailure` if a process dies or the game stalls."""
    stack.check()
    log_dir = log_dir.resolve()
    kwy = log_dir / f"{LOG_NAME}.kwy"
    with ArenaProcesses(log_dir) as arena:
        kwy.unlink(missing_ok=True)
        if cell.server == "rcssserver":
            port = free_udp_ports()
            # rcssserver writes its configuration to "~/.rcssserver" without expanding the tilde: in log_dir
            server = arena.start("server", server_argv(stack, port, log_dir, seed), cwd=log_dir)
            wait_until_bound(port, server)
            players = None
        else:
            port = free_udp_ports(1)
            server, players, _, _ = arena.start_server(our_server_args(port, log_dir, seed, episodes))
        for team, count in (("keepers", KEEPERS), ("takers", TAKERS)):
            kind = cell.keepers if team == "keepers" else cell.takers
            policy = pass_policy if team == "keepers" else "handcoded"
            for i in range(1, count + 1):
                name = f"{team[:-1]} {i}"
                if kind == "cpp":
                    arena.start(name, player_argv(stack, port, team, CPP_POLICY[policy], episodes), cwd=log_dir)
                else:
                    where = ["--server", players] if players else ["--rcss", f"127.0.0.1:{port}"]
                    arena.start(name, keepaway_argv("player", "--team", team, "--pass", policy, *where))
        done, progress_at = 0, time.monotonic()
        while done <= episodes:
            time.sleep(1.0)
            now_done = finished_episodes(kwy)
            if now_done > episodes:
                break
            dead = next((m for m in arena.members if m.proc.poll() is not None), None)
            if dead is not None:
                raise ArenaFailure(f"{cell.name}: {dead.describe_exit()}; logs in {log_dir}")
            if now_done > done:
                done, progress_at = now_done, time.monotonic()
            elif time.monotonic() - progress_at > STALL_S:
                raise ArenaFailure(f"{cell.name}: no episode finished in {STALL_S:.0f} s (after {done}); "
                                   f"logs in {log_dir}")
    return read_rcg(log_dir / f"{LOG_NAME}.rcg", kwy), read_kwy(kwy)[:episodes]


def play_reference(stack: ReferenceStack, pass_policy: str, episodes: int, seed: int,
                   log_dir: Path) -> tuple[GameRecord, list[EpisodeRecord]]:
    """The reference cell, the C++ players on rcssserver (:func:`play_campaign`)."""
    return play_campaign(stack, REFERENCE, pass_policy, episodes, seed, log_dir)


def our_server_args(rcss_port: int, log_dir: Path, seed: int, episodes: int) -> list[str]:
    """``keepaway server`` as the reference's rcssserver is launched: CURRENT parameters with keepaway.sh's
    settings (our server's defaults for ``--params current``), synchronous, 3v2 on 20 m, the front on
    ``rcss_port``; it plays one episode beyond ``episodes``, as the C++ players never stop."""
    return ["--params", "current", "--keepers", str(KEEPERS), "--takers", str(TAKERS), "--seed", str(seed),
            "--rcss-port", str(rcss_port), "--log-dir", str(log_dir), "--kwy-name", LOG_NAME,
            "--episodes", str(episodes + 1)]


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

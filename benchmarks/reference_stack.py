"""The reference stack (rcssserver 19.0.0 + the keepaway-0.6 C++ players) played from Python, for the
side-by-side harness (``benchmarks/side_by_side.py --reference BUILD``); not run in CI.

``BUILD`` is the directory ``../shared/tools/build-rcss.sh`` builds into: ``BUILD/rcssserver/build/
rcssserver`` and ``BUILD/keepaway/player/keepaway_player``. One campaign is the server and five players
(3 keepers with the given Pass policy, 2 hand-coded takers, hand-coded GetOpen) in synchronous mode with
the launch settings of keepaway-0.6's ``keepaway.sh`` (that script's header in build-rcss.sh), CURRENT
parameters (rcssserver 19's defaults), 3v2 on 20 m, 360 deg vision, the server's ``random_seed`` (a
patch of build-rcss.sh) set, game log version 5 and the episode log written to the log directory.
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
                                 "(build it with ../shared/tools/build-rcss.sh)")


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


def play_reference(stack: ReferenceStack, pass_policy: str, episodes: int, seed: int,
                   log_dir: Path) -> tuple[GameRecord, list[EpisodeRecord]]:
    """Play ``episodes`` episodes on the reference stack with the keepers' ``pass_policy`` ("hold",
    "random", "handcoded") and server seed ``seed``, logs in ``log_dir`` (an earlier ``game.rcg`` there
    is overwritten); return the game log and the first ``episodes`` episodes of the ``.kwy``.
    :class:`runner.launch.ArenaFailure` if a process dies or the game stalls."""
    stack.check()
    log_dir = log_dir.resolve()
    kwy = log_dir / f"{LOG_NAME}.kwy"
    port = free_udp_ports()
    with ArenaProcesses(log_dir) as arena:
        kwy.unlink(missing_ok=True)
        # rcssserver writes its configuration to "~/.rcssserver" without expanding the tilde: in log_dir
        server = arena.start("server", server_argv(stack, port, log_dir, seed), cwd=log_dir)
        wait_until_bound(port, server)
        for team, count, policy in (("keepers", KEEPERS, CPP_POLICY[pass_policy]), ("takers", TAKERS, "hand")):
            for i in range(1, count + 1):
                arena.start(f"{team[:-1]} {i}", player_argv(stack, port, team, policy, episodes), cwd=log_dir)
        done, progress_at = 0, time.monotonic()
        while done <= episodes:
            time.sleep(1.0)
            dead = next((m for m in arena.members if m.proc.poll() is not None), None)
            if dead is not None:
                raise ArenaFailure(f"reference stack: {dead.describe_exit()}; logs in {log_dir}")
            now_done = finished_episodes(kwy)
            if now_done > done:
                done, progress_at = now_done, time.monotonic()
            elif time.monotonic() - progress_at > STALL_S:
                raise ArenaFailure(f"reference stack: no episode finished in {STALL_S:.0f} s (after {done}); "
                                   f"logs in {log_dir}")
    return read_rcg(log_dir / f"{LOG_NAME}.rcg", kwy), read_kwy(kwy)[:episodes]


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

"""The keepaway-0.6 C++ players' speed on rcssserver 19 and on our server through the rcssserver-protocol
front, side by side in one invocation, with the CPU each process spends per cycle.

    python benchmarks/rcss_front.py BUILD [--seconds 15] [--repeats 3] [--policy handcoded]

``BUILD`` is the reference stack's build directory (tools/build-reference-stack.sh). Each setting plays the
five C++ players (3 keepers with ``--policy``, 2 hand-coded takers) in synchronous mode with the settings of
``benchmarks/reference_stack.py`` and, once the first episode has ended, measures for ``--seconds`` the
cycles played (from the ``.kwy``) and each process's CPU time (``/proc``): rcssserver; our server with the
front in its process (``--rcss-port``); our server with the front as a process of its own (``keepaway
rcss-front``). Prints, per setting, the median over ``--repeats`` of the cycles per second, its ratio to
rcssserver's, and the CPU milliseconds per cycle of the server, the front and the players.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from benchmarks.reference_stack import (  # noqa: E402
    CPP_POLICY,
    KEEPERS,
    LOG_NAME,
    TAKERS,
    ReferenceStack,
    free_udp_ports,
    our_server_args,
    player_argv,
    server_argv,
    wait_until_bound,
)
from keepaway.runner.launch import ArenaProcesses, Member, keepaway_argv  # noqa: E402
from keepaway.server.episode_log import read_kwy  # noqa: E402

SETTINGS = ("rcssserver", "ours, front in the server", "ours, front a process")
TICKS = os.sysconf("SC_CLK_TCK")


def cpu_s(member: Member) -> float:
    """User + system CPU seconds of a running process (``/proc/PID/stat``)."""
    fields = Path(f"/proc/{member.proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def cycles_logged(kwy: Path) -> int:
    """The end cycle of the last episode the ``.kwy`` lists (0 before the first)."""
    try:
        records = read_kwy(kwy)
    except (OSError, ValueError):
        return 0
    return records[-1].end_cycle if records else 0


def measure(stack: ReferenceStack, setting: str, policy: str, seconds: float, log_dir: Path) -> dict:
    """One run of ``setting``: cycles per second and CPU ms per cycle by role."""
    kwy = log_dir / f"{LOG_NAME}.kwy"
    kwy.unlink(missing_ok=True)
    with ArenaProcesses(log_dir) as arena:
        roles: dict[str, list[Member]] = {"server": [], "front": [], "players": []}
        if setting == "rcssserver":
            port = free_udp_ports()
            server = arena.start("server", server_argv(stack, port, log_dir, seed=5), cwd=log_dir)
            wait_until_bound(port, server)
        else:
            port = free_udp_ports(1)
            args = our_server_args(port, log_dir, seed=5, episodes=100_000)
            if setting == SETTINGS[2]:
                args = [a for a in args if a not in ("--rcss-port", str(port))]
            server, players, _, _ = arena.start_server(args)
            if setting == SETTINGS[2]:
                front = arena.start("front", keepaway_argv("rcss-front", "--server", players, "--port", str(port)),
                                    capture_stdout=True)
                front.proc.stdout.readline()
                roles["front"].append(front)
        roles["server"].append(server)
        for team, count in (("keepers", KEEPERS), ("takers", TAKERS)):
            kind = CPP_POLICY[policy] if team == "keepers" else "hand"
            for i in range(1, count + 1):
                roles["players"].append(arena.start(f"{team[:-1]} {i}", player_argv(stack, port, team, kind, 100_000),
                                                    cwd=log_dir))
        deadline = time.monotonic() + 120.0
        while cycles_logged(kwy) == 0:
            if time.monotonic() > deadline:
                raise RuntimeError(f"{setting}: no episode ended in 120 s; logs in {log_dir}")
            time.sleep(0.02)
        start, c0 = time.perf_counter(), cycles_logged(kwy)
        cpu0 = {role: sum(map(cpu_s, members)) for role, members in roles.items()}
        time.sleep(seconds)
        elapsed, c1 = time.perf_counter() - start, cycles_logged(kwy)
        cpu1 = {role: sum(map(cpu_s, members)) for role, members in roles.items()}
    n = c1 - c0
    return {"rate": n / elapsed, **{role: (cpu1[role] - cpu0[role]) * 1000 / n for role in roles}}


def speed_table(stack: ReferenceStack, policy: str, seconds: float, repeats: int,
                settings: tuple[str, ...] = SETTINGS) -> list[str]:
    """Measure ``settings`` (rcssserver first), interleaved so that a slow minute of the machine hits every
    setting; the table's lines."""
    results: dict[str, list[dict]] = {setting: [] for setting in settings}
    with tempfile.TemporaryDirectory(prefix="rcss-front-") as scratch:
        for repeat in range(repeats):
            for setting in settings:
                where = Path(scratch) / f"{repeat}-{SETTINGS.index(setting)}"
                where.mkdir()
                results[setting].append(measure(stack, setting, policy, seconds, where))
    base = statistics.median(r["rate"] for r in results["rcssserver"])
    lines = [f"C++ players, {policy} Pass, synchronous; median of {repeats} runs of {seconds:g} s",
             "| setting | cycles/s | / rcssserver | server CPU ms/cycle | front | 5 players |",
             "|---|---:|---:|---:|---:|---:|"]
    for setting, runs in results.items():
        med = {key: statistics.median(r[key] for r in runs) for key in runs[0]}
        front = f"{med['front']:.2f}" if setting == SETTINGS[2] else "(in the server)" if "front" in setting else "-"
        lines.append(f"| {setting} | {med['rate']:.0f} | {med['rate'] / base:.2f} | {med['server']:.2f} | {front} | "
                     f"{med['players']:.2f} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("build", type=Path, help="the reference stack's build directory")
    parser.add_argument("--seconds", type=float, default=15.0, help="measured seconds per run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--policy", choices=sorted(CPP_POLICY), default="handcoded", help="the keepers' Pass")
    args = parser.parse_args()
    stack = ReferenceStack(args.build)
    try:
        stack.check()
    except ValueError as exc:
        parser.error(str(exc))
    print("\n".join(speed_table(stack, args.policy, args.seconds, args.repeats)))


if __name__ == "__main__":
    main()

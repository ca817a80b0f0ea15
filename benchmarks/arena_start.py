"""How long a distributed arena takes to start: the players forked from a fork server that has loaded
their kernels (the default on Linux, ``runner/launch.py``) against started player processes
(``KEEPAWAY_FORK_PLAYERS=0``), in one invocation.

Each measurement is the wall-clock time of a fresh ``keepaway run --mode distributed --episodes 1``
process (start-up, one short episode, shut-down; the game is the same in both), run in turn with the
players forked and started, ``--repeat`` rounds; prints each round and the medians. The kernels are
compiled (or found compiled) first, outside the clocks. Prints figures; asserts nothing.

Run: ``python benchmarks/arena_start.py [--repeat N] [--episodes E]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from keepaway.runner.launch import keepaway_argv  # noqa: E402

WAYS = {"forked": "1", "started": "0"}  # KEEPAWAY_FORK_PLAYERS


def run_seconds(fork: str, episodes: int) -> float:
    """Wall seconds of one ``keepaway run --mode distributed`` process."""
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        subprocess.run(keepaway_argv("run", "--mode", "distributed", "--episodes", str(episodes), "--seed", "0",
                                     "--out", out, "--no-progress", "--no-game-log"),
                       env={**os.environ, "KEEPAWAY_FORK_PLAYERS": fork}, check=True, stdout=subprocess.DEVNULL)
        return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="rounds, each running both ways once")
    parser.add_argument("--episodes", type=int, default=1)
    opts = parser.parse_args()
    subprocess.run(keepaway_argv("compile"), check=True, stdout=subprocess.DEVNULL)
    seconds: dict[str, list[float]] = {way: [] for way in WAYS}
    for i in range(opts.repeat):
        for way, fork in WAYS.items():
            seconds[way].append(run_seconds(fork, opts.episodes))
        print(f"round {i + 1}: " + ", ".join(f"{way} {seconds[way][-1]:.2f} s" for way in WAYS), flush=True)
    forked, started = (statistics.median(seconds[way]) for way in WAYS)
    print(f"keepaway run --mode distributed --episodes {opts.episodes}, wall, medians of {opts.repeat}: "
          f"players forked {forked:.2f} s, started {started:.2f} s ({forked / started:.2f}x)")


if __name__ == "__main__":
    main()

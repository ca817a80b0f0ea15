"""What the players cost in the batched mode: per arena-cycle, beside the server.

In one invocation, one thread, at batch 1 (the single arena Pass learning plays) and batch 1024:

* physics + perception alone (``benchmarks/server.py``'s measurement: every player dashes or turns, a
  see on 2 of 3 cycles), arena-cycles/s, with the aural sensor too: every player says 10 characters every
  cycle, as the hand-coded players do, and the server delivers the hears (``deliver_says``);
* the full game, P:HC-GO:HC with five noisy players (``benchmarks/arena_batched.py``'s game),
  arena-cycles/s;
* the players' cost per arena-cycle, 1/full - 1/(physics + perception), in microseconds, and its ratio to
  the cost of physics + perception (the target: at most 2). That figure counts the hears' delivery as
  the server's work, which it is (rcssserver's aural sensor); the figure that counts it as the players'
  follows in the last column.

The three are measured in ``--rounds`` rounds of short runs, one right after the other (the full game's
runs go on with the same arenas: the games' steady state, not their kick-offs). On this shared machine a
process runs for seconds at a time up to 1.8 times slower than at others (the host's load, whatever the
core), so the rates are the best of their runs, as ``timeit`` takes its minimum time (a slowdown only ever
lowers a rate), and the players' cost and its ratio come from them; the median and range of the rounds'
own ratios follow, to show the spread. Compilation (or loading numba's cache) is done before any clock
starts. Prints figures; asserts nothing.

Run: ``python benchmarks/players.py [--rounds N] [--seconds S] [--cycles-1 C] [--cycles-1024 C]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository, before benchmarks/

from sibling import load  # noqa: E402


def _players_ratio(base: float, full: float) -> float:
    """The players' cost per arena-cycle over that of physics + perception: (1/full - 1/base) / (1/base)."""
    return base / full - 1.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=12, help="rounds of runs per batch size")
    parser.add_argument("--seconds", type=float, default=0.5, help="seconds per physics + perception run")
    parser.add_argument("--cycles-1", type=int, default=12000, help="full-game cycles per run at batch 1")
    parser.add_argument("--cycles-1024", type=int, default=15, help="full-game cycles per arena per run at batch 1024")
    parser.add_argument("--seed", type=int, default=0)
    opts = parser.parse_args()
    server, game = load("server"), load("arena_batched")
    cycles = {1: opts.cycles_1, 1024: opts.cycles_1024}
    print(f"batched mode, one thread, P:HC-GO:HC 3v2, classic parameters; {opts.rounds} rounds of runs per batch")
    print(f"{'batch':>6} {'physics+perception':>20} {'full game':>12} {'players per arena-cycle':>24} {'ratio':>6} "
          f"{'rounds: median (range)':>23} {'hears as the players:':>22}")
    for batch, n in cycles.items():
        arenas = game.hand_coded(batch, threads=1, seed=opts.seed)
        game.timed_run(arenas, n)  # past the kick-offs
        bases, hearing, fulls = [], [], []
        for _ in range(opts.rounds):  # a fresh world for each physics + perception run, as always
            bases.append(server.batched_throughput(batch, opts.seconds))
            hearing.append(server.batched_throughput(batch, opts.seconds, hear=True))
            table, seconds = game.timed_run(arenas, n)
            fulls.append(table.cycles / seconds)
        base, heard, full = max(bases), max(hearing), max(fulls)
        players_us = (1.0 / full - 1.0 / heard) * 1e6
        ratios = [_players_ratio(h, f) for h, f in zip(hearing, fulls)]
        spread = f"{statistics.median(ratios):10.2f}x ({min(ratios):.2f}-{max(ratios):.2f})"
        print(f"{batch:6d} {heard:14,.0f} a-c/s {full:8,.0f} a-c/s {players_us:18.1f} us "
              f"{_players_ratio(heard, full):5.2f}x {spread} {_players_ratio(base, full):8.2f}x ({base:,.0f} a-c/s)")
    print("(rates: the best of the runs; ratio: the players' cost per arena-cycle over that of physics + perception "
          "with the hears, target <= 2; last: over physics + perception without the hears, which then count as the "
          "players')")


if __name__ == "__main__":
    main()

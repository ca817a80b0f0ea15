"""What the players cost in the batched mode (issue 11, item 3): per arena-cycle, beside the server.

In one invocation, one thread, at batch 1 (the single arena Pass learning plays) and batch 1024:

* physics + perception alone (``benchmarks/server.py``'s measurement: every player dashes or turns, a
  see on 2 of 3 cycles), arena-cycles/s;
* the full game, P:HC-GO:HC with five noisy players (``benchmarks/arena_batched.py``), arena-cycles/s;
* the players' cost per arena-cycle, 1/full - 1/(physics + perception), in microseconds, and its ratio to
  the cost of physics + perception (the issue's target: at most 2).

Each figure is the median of ``--repeat`` interleaved measurements (the machine is shared). Compilation
(or loading numba's cache) is done before any clock starts. Prints figures; asserts nothing.

Run: ``python benchmarks/players.py [--repeat N] [--seconds S] [--cycles-1 C] [--cycles-1024 C]``.
"""

from __future__ import annotations

import argparse
import os
import statistics

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

from sibling import load  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="interleaved measurements per figure (median)")
    parser.add_argument("--seconds", type=float, default=3.0, help="seconds per physics + perception measurement")
    parser.add_argument("--cycles-1", type=int, default=3000, help="full-game cycles at batch 1")
    parser.add_argument("--cycles-1024", type=int, default=100, help="full-game cycles per arena at batch 1024")
    parser.add_argument("--seed", type=int, default=0)
    opts = parser.parse_args()
    server = load("server")
    game = load("arena_batched")
    cycles = {1: opts.cycles_1, 1024: opts.cycles_1024}
    rates: dict[tuple[str, int], list[float]] = {}
    for _ in range(opts.repeat):
        for batch in cycles:
            rates.setdefault(("server", batch), []).append(server.batched_throughput(batch, opts.seconds))
            full = game.measure(batch, cycles[batch], threads=1, seed=opts.seed)["cycles_per_s"]
            rates.setdefault(("game", batch), []).append(full)
    print(f"batched mode, one thread, P:HC-GO:HC 3v2, classic parameters; medians of {opts.repeat} interleaved runs")
    print(f"{'batch':>6} {'physics+perception':>20} {'full game':>12} {'players per arena-cycle':>24} {'ratio':>7}")
    for batch in cycles:
        base = statistics.median(rates[("server", batch)])
        full = statistics.median(rates[("game", batch)])
        players_us = (1.0 / full - 1.0 / base) * 1e6
        print(f"{batch:6d} {base:14,.0f} a-c/s {full:8,.0f} a-c/s {players_us:18.1f} us {players_us * base / 1e6:6.1f}x")
    print("(ratio: the players' cost per arena-cycle over that of physics + perception; target <= 2)")


if __name__ == "__main__":
    main()

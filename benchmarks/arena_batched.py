"""Throughput of the batched mode (runner/batched.py): episodes/s and arena-cycles/s of P:HC-GO:HC.

Called by ``benchmarks/arena.py``; also runs alone: ``python benchmarks/arena_batched.py [--threads N]``.
Compilation (or loading numba's cache) is done before the clock starts; each measurement plays
``cycles`` cycles in every arena from the kick-off, so episodes/s includes the first episodes' start.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository, before benchmarks/

from keepaway.protocol.params import parameter_set  # noqa: E402
from keepaway.runner.batched import BatchedArenas  # noqa: E402
from keepaway.runner.job import EpisodeTable  # noqa: E402

# (batch, cycles per arena): about 3000 arena-cycles at batch 1, 300k at batch 1024.
DEFAULT_RUNS = ((1, 3000), (1024, 300))


def hand_coded(batch: int, threads: int | None = None, seed: int = 0, params_name: str = "classic") -> BatchedArenas:
    """``batch`` P:HC-GO:HC arenas, their kernels compiled or loaded (one cycle played)."""
    arenas = BatchedArenas(parameter_set(params_name), batch, seed, pass_policy="handcoded",
                           getopen_policy="handcoded", threads=threads)
    arenas.run(max_cycles=1)
    return arenas


def timed_run(arenas: BatchedArenas, cycles: int) -> tuple[EpisodeTable, float]:
    """The episodes of ``cycles`` more cycles of every arena, and the seconds they took."""
    start = time.perf_counter()
    table = arenas.run(max_cycles=cycles)
    return table, time.perf_counter() - start


def measure(batch: int, cycles: int, threads: int | None = None, seed: int = 0,
            params_name: str = "classic") -> dict:
    """Play ``cycles`` cycles in each of ``batch`` hand-coded arenas; return the rates and hold time."""
    arenas = hand_coded(batch, threads, seed, params_name)
    table, seconds = timed_run(arenas, cycles)
    step_s = parameter_set(params_name).simulator_step_ms / 1000.0
    hold_s = table.hold_cycles.mean() * step_s if len(table) else float("nan")
    return {"batch": batch, "threads": arenas.threads, "seconds": seconds, "episodes": len(table),
            "episodes_per_s": len(table) / seconds, "cycles_per_s": table.cycles / seconds,
            "mean_hold_s": hold_s}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=None, help="threads (default: numba's thread count)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    for batch, cycles in DEFAULT_RUNS:
        r = measure(batch, cycles, args.threads, args.seed)
        print(f"batched P:HC-GO:HC batch {r['batch']:5d} threads {r['threads']}: "
              f"{r['episodes_per_s']:8.1f} episodes/s {r['cycles_per_s']:10.0f} arena-cycles/s "
              f"({r['episodes']} episodes in {r['seconds']:.1f} s, mean hold {r['mean_hold_s']:.2f} s)")


if __name__ == "__main__":
    main()

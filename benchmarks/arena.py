"""Arena benchmarks (issue: keepers, takers and the coach as processes): episodes per second of
P:HC-GO:HC in the distributed mode (server, coach and five player processes over ZeroMQ), the embedded
mode (one process, no sockets; the baseline) and the batched mode (many arenas in one process), and the
cycles per second of a bare ZeroMQ loop that exchanges a cycle's messages with five minimal client
processes and simulates nothing (``benchmarks/server.py``'s baseline), all in one invocation. The bare
loop runs first, just before the embedded mode, and is also printed as a multiple of it: no distributed
run whose server and players handle their messages in Python can beat the exchange of its own messages,
so that multiple bounds the distributed mode's. The same loop in C (``benchmarks/bare_loop.c``, libzmq
alone; if a C compiler is there) shows how much of it is Python's per-message path rather than ZeroMQ.

Run: ``python benchmarks/arena.py [--episodes N] [--batch B] [--batched-episodes M]``. Rates exclude
start-up and compilation where the mode allows (distributed: between the first and last episode end).
Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from keepaway.protocol.params import parameter_set  # noqa: E402
from keepaway.runner.embedded import ArenaSpec  # noqa: E402
from keepaway.runner.run import RunOptions, run  # noqa: E402
from sibling import load  # noqa: E402


def measure(mode: str, episodes: int, batch: int, seed: int) -> dict:
    spec = ArenaSpec(parameter_set("classic"), seed=seed)
    with tempfile.TemporaryDirectory() as out:
        return run(RunOptions(spec, episodes, mode, batch, out=Path(out)), progress=False).summary()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=40, help="episodes for distributed and embedded")
    parser.add_argument("--batch", type=int, default=1024)
    parser.add_argument("--batched-episodes", type=int, default=4096)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--bare-cycles", type=int, default=3000, help="cycles of the bare ZeroMQ loop")
    opts = parser.parse_args()
    measure("batched", opts.batch, opts.batch, opts.seed)  # compile / load every kernel once
    print(f"P:HC-GO:HC, 3v2 on 20 m, classic parameters, seed {opts.seed}")
    server = load("server")  # the bare loop first, beside the modes it bounds: the machine's speed swings by the hour
    bare = server.sync_cycles_per_second([sys.executable, "-c", server.NULL_SERVER, "5", str(opts.bare_cycles)])
    in_c = server.c_loop(opts.bare_cycles)
    rows = [
        ("embedded (baseline)", measure("embedded", opts.episodes, 1, opts.seed)),
        ("distributed, 7 processes", measure("distributed", opts.episodes, 1, opts.seed)),
        (f"batched, batch {opts.batch}", measure("batched", opts.batched_episodes, opts.batch, opts.seed)),
    ]
    base = rows[0][1]["episodes_per_s"]
    for name, s in rows:
        print(f"  {name:<26} {s['episodes_per_s']:9.2f} episodes/s {s['cycles_per_s']:11,.0f} cycles/s "
              f"({s['episodes_per_s'] / base:6.1f}x)  mean hold {s['mean_hold_time_s']:.2f} s over "
              f"{len(s['episodes'])} episodes")
    embedded, distributed = rows[0][1]["cycles_per_s"], rows[1][1]["cycles_per_s"]
    # the transport alone, beside the embedded mode: the distributed mode, its processes in Python, cannot run
    # faster than its messages can be exchanged; the C loop is libzmq's own ceiling
    print(f"  bare ZeroMQ loop, no simulation {bare:21,.0f} cycles/s  (distributed: {distributed / bare:.2f}x of it; "
          f"it: {bare / embedded:.2f}x embedded)")
    print(f"  the same loop in C (libzmq)     {server.c_loop_line(in_c, bare, embedded)}")
    print("  targets (issue 11): batched >= 300 episodes/s and >= 150x embedded; distributed >= 0.9x embedded and "
          ">= 5 episodes/s (>= 750 cycles/s)")


if __name__ == "__main__":
    main()

"""Training throughput of `keepaway train` in its two modes, and what one 30,000-episode trial costs.

Measures, on the same behaviours and seeds, simulated cycles per second of wall time of
(a) a Pass block (Sarsa learning, P:L-GO:HC: one arena, its chunks in order) and
(b) frozen play (an evaluation or CEM candidates, P:HC-GO:HC: spread over the arenas),
in the batched mode (the baseline) and in the distributed mode (arenas of server, coach and five player
processes, started once; start-up excluded). A trial's wall clock is its simulated cycles divided by
these rates: the cycles of a finished training (``--from-training DIR``, e.g. a batched P:L-GO:HC run;
its trace and curve give every block's mean hold time) or, without one, 30,000 training episodes of 14 s
plus 13 evaluations of 500 episodes of 14 s (the P:L-GO:HC hold times measured over a trial).

Run: ``python benchmarks/train_modes.py [--episodes N] [--arenas A] [--from-training DIR]``. Prints
figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from keepaway.runner.batched_backend import BatchedBackend  # noqa: E402
from keepaway.runner.distributed import DistributedBackend  # noqa: E402
from keepaway.runner.job import Backend, Behaviours  # noqa: E402
from keepaway.trainer.schedule import PASS, Phase  # noqa: E402
from keepaway.trainer.train import TrainConfig  # noqa: E402

DEFAULT_HOLD_S = 14.0
TRIAL_EPISODES = 30_000
EVALUATIONS = 13
EVAL_EPISODES = 500


def rate(backend: Backend, behaviours: Behaviours, episodes: int, mode: str) -> float:
    """Simulated cycles per second of wall time."""
    start = time.perf_counter()
    result = backend.play(behaviours, 7, episodes, mode).result
    elapsed = time.perf_counter() - start
    return sum(e.end_cycle - e.start_cycle for e in result.episodes) / elapsed


def trial_cycles(training: Path | None) -> tuple[float, float, str]:
    """(learning cycles, frozen cycles) of one trial, and where they come from."""
    if training is None:
        cycles_per_episode = DEFAULT_HOLD_S * 10
        return (TRIAL_EPISODES * cycles_per_episode, EVALUATIONS * EVAL_EPISODES * cycles_per_episode,
                f"{TRIAL_EPISODES} episodes + {EVALUATIONS} x {EVAL_EPISODES} evaluation episodes"
                f" of {DEFAULT_HOLD_S} s")
    summary = json.loads((training / "summary.json").read_text())
    config = summary["config"]
    trial = training / "trial_000"
    trace = [json.loads(line) for line in (trial / "trace.jsonl").read_text().splitlines()]
    learning = sum(t["block_episodes"] * t["mean_hold_time_s"] * 10 for t in trace if t["phase"] == "pass")
    frozen = sum(sum(t["fitness"]) * config["cem"]["episodes_per_candidate"] * 10
                 for t in trace if t["phase"] == "getopen")
    frozen += sum(p["mean_hold_time_s"] * config["eval_episodes"] * 10 for p in summary["trials"][0]["curve"])
    return learning, frozen, f"trial 0 of {training} ({summary['name']})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=50, help="episodes per measurement")
    parser.add_argument("--arenas", type=int, default=2, help="distributed arenas (batched: an arena per chunk)")
    parser.add_argument("--from-training", type=Path, default=None)
    opts = parser.parse_args()
    config = TrainConfig(pass_policy="learned", getopen_policy="handcoded", schedule=(Phase(PASS, TRIAL_EPISODES),),
                         mode="distributed", arenas=opts.arenas)
    learn = Behaviours("learned", "handcoded")
    frozen = Behaviours("handcoded", "handcoded")
    rows = {}
    # the distributed mode first: numba's worker threads of the batched mode may keep spinning afterwards
    with tempfile.TemporaryDirectory() as logs:
        with DistributedBackend.start_local(config.game(), opts.arenas, Path(logs), "classic") as distributed:
            rate(distributed, frozen, opts.arenas, "greedy")  # processes up and warm
            distributed_rates = (rate(distributed, learn, opts.episodes, "learn"),
                                 rate(distributed, frozen, opts.episodes, "greedy"))
    batched = BatchedBackend(config.game(), threads=None)
    rate(batched, frozen, 25, "greedy")  # compile / load every kernel once
    rows["batched (baseline)"] = (rate(batched, learn, opts.episodes, "learn"),
                                  rate(batched, frozen, opts.episodes * 4, "greedy"))
    rows[f"distributed, {opts.arenas} arenas"] = distributed_rates
    learning, frozen_cycles, source = trial_cycles(opts.from_training)
    print(f"3v2 on 20 m, classic parameters; one trial = {source}: "
          f"{learning:,.0f} learning + {frozen_cycles:,.0f} frozen cycles")
    base = rows["batched (baseline)"]
    for name, (learn_rate, frozen_rate) in rows.items():
        hours = (learning / learn_rate + frozen_cycles / frozen_rate) / 3600
        print(f"  {name:<24} Pass learning {learn_rate:9,.0f} cycles/s ({learn_rate / base[0]:5.2f}x)   "
              f"frozen play {frozen_rate:9,.0f} cycles/s ({frozen_rate / base[1]:5.2f}x)   one trial ~{hours:6.2f} h")


if __name__ == "__main__":
    main()

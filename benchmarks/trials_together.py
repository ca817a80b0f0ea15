"""Trials trained together against one after another (issue 11, item 2), batched, in one invocation.

The same short trainings (same seeds, so the same results: ``tests/test_train.py``) played two ways on
a batched backend of ``--threads`` threads: each trial alone, one after another (the baseline: a Pass
block then plays one arena on one thread), and all trials together (``trainer.train.advance``: the same
step of every trial in shared batches). Prints the wall clock of both and their ratio, for a P:L-GO:HC
training (Pass blocks) and a P:HC-GO:L training (CEM generations).

Run: ``python benchmarks/trials_together.py [--trials 4] [--threads 2] [--episodes 1000]``. Prints
figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from keepaway.runner.batched_backend import BatchedBackend  # noqa: E402
from keepaway.runner.job import LEARN  # noqa: E402
from keepaway.trainer.cem import CEMConfig  # noqa: E402
from keepaway.trainer.schedule import GETOPEN, PASS, Phase  # noqa: E402
from keepaway.trainer.train import TrainConfig, TrialState, advance, initial_behaviours  # noqa: E402


def wall(config: TrainConfig, backend: BatchedBackend, together: bool) -> float:
    """Seconds to train every trial of ``config`` to its end, together or one after another."""
    states = [TrialState(t, initial_behaviours(config, t)) for t in range(config.trials)]
    groups = [states] if together else [[s] for s in states]
    start = time.perf_counter()
    for group in groups:
        while running := [s for s in group if not s.finished(config)]:
            advance(config, running, backend)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=4)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--episodes", type=int, default=1000, help="training episodes per trial")
    args = parser.parse_args()
    common = dict(trials=args.trials, eval_every=args.episodes, eval_episodes=100, seed=1)
    configs = {
        "P:L-GO:HC (Pass blocks)": TrainConfig(pass_policy="learned", getopen_policy="handcoded",
                                               schedule=(Phase(PASS, args.episodes),), **common),
        "P:HC-GO:L (CEM generations)": TrainConfig(
            pass_policy="handcoded", getopen_policy="learned", schedule=(Phase(GETOPEN, args.episodes),),
            cem=CEMConfig(population=20, elite=5, episodes_per_candidate=args.episodes // 20), **common),
    }
    print(f"{args.trials} trials of {args.episodes} training episodes + 2 evaluations of 100, batched, "
          f"{args.threads} threads\n")
    print("| training | one after another (s) | together (s) | speed-up |")
    print("|---|---|---|---|")
    for name, config in configs.items():
        backend = BatchedBackend(config.game(), threads=args.threads)
        backend.play(initial_behaviours(config, 0), 0, 2, LEARN)  # load the kernels
        alone, together = wall(config, backend, False), wall(config, backend, True)
        print(f"| {name} | {alone:.1f} | {together:.1f} | {alone / together:.2f}x |")


if __name__ == "__main__":
    main()

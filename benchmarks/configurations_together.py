"""An experiment's learning configurations three ways, batched, in one invocation.

The five learning configurations of Figure 3 (short trainings of the same seeds, so the same results
whichever way they run: ``tests/test_train.py``, ``tests/test_backends.py``) trained

* one after another in one process of ``--threads`` threads (``keepaway experiment`` with one worker),
  each configuration's trials together (``trainer.train.advance``);
* all together in one process of ``--threads`` threads (``trainer.train.advance_trainings``: a round is
  one step of every configuration's trials, their jobs in shared batches of arenas of different
  policies, ``runner.batched.ArenaPolicies``);
* in ``--threads`` worker processes of one thread each, the longest first (``keepaway experiment
  --workers``, ``trainer.experiments.run_in_workers``), kernels loaded in each.

Prints the wall clock of each and its ratio to the first. Run: ``python
benchmarks/configurations_together.py [--trials 4] [--episodes 1200] [--threads 2]``. Prints figures;
asserts nothing.
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from keepaway.runner.batched_backend import BatchedBackend  # noqa: E402
from keepaway.runner.job import LEARN, LEARNED  # noqa: E402
from keepaway.trainer.cem import CEMConfig  # noqa: E402
from keepaway.trainer.configurations import LONGEST_FIRST, ExperimentConfig, configuration_name  # noqa: E402
from keepaway.trainer.train import TrainConfig, TrialState, advance, advance_trainings, initial_behaviours  # noqa: E402

LEARNING = [c for c in LONGEST_FIRST if LEARNED in c]


def trials(config: TrainConfig) -> list[tuple[TrainConfig, TrialState]]:
    return [(config, TrialState(t, initial_behaviours(config, t))) for t in range(config.trials)]


def backend(config: TrainConfig, threads: int) -> BatchedBackend:
    """A batched backend with its kernels loaded."""
    played = BatchedBackend(config.game(), threads=threads)
    played.play(initial_behaviours(config, 0), 0, 2, LEARN)
    return played


def one_after_another(configs: list[TrainConfig], threads: int) -> float:
    played = backend(configs[0], threads)
    start = time.perf_counter()
    for config in configs:
        states = [state for _, state in trials(config)]
        while running := [s for s in states if not s.finished(config)]:
            advance(config, running, played)
    return time.perf_counter() - start


def together(configs: list[TrainConfig], threads: int) -> float:
    played = backend(configs[0], threads)
    pairs = [pair for config in configs for pair in trials(config)]
    start = time.perf_counter()
    while running := [(c, s) for c, s in pairs if not s.finished(c)]:
        advance_trainings(running, played)
    return time.perf_counter() - start


def _worker(config: TrainConfig) -> None:
    one_after_another([config], 1)


def in_workers(configs: list[TrainConfig], workers: int) -> float:
    start = time.perf_counter()
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        for done in [pool.submit(_worker, config) for config in configs]:
            done.result()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=4)
    parser.add_argument("--episodes", type=int, default=1200,
                        help="training episodes per trial, a multiple of 240 (the paper's proportions: a CEM "
                             "generation of 20 candidates is 1/12 of them)")
    parser.add_argument("--threads", type=int, default=2, help="threads, or worker processes")
    args = parser.parse_args()
    exp = ExperimentConfig(trials=args.trials, episodes=args.episodes, eval_every=args.episodes, eval_episodes=50,
                           seed=1, cem=CEMConfig(population=20, elite=5, episodes_per_candidate=args.episodes // 240))
    configs = [exp.train_config(p, g) for p, g in LEARNING]
    print(f"{', '.join(configuration_name(p, g) for p, g in LEARNING)}: {args.trials} trials of {args.episodes} "
          f"training episodes + 2 evaluations of 50 each, batched\n")
    print("| how | wall clock (s) | ratio to one after another |")
    print("|---|---|---|")
    base = one_after_another(configs, args.threads)
    print(f"| one after another, {args.threads} threads | {base:.1f} | 1.00x |", flush=True)
    mixed = together(configs, args.threads)
    print(f"| together, {args.threads} threads | {mixed:.1f} | {base / mixed:.2f}x |", flush=True)
    workers = in_workers(configs, args.threads)
    print(f"| {args.threads} worker processes, longest first | {workers:.1f} | {base / workers:.2f}x |")


if __name__ == "__main__":
    main()

"""Short P:HC-GO:L trainings that compare GO:L input variants (docs/design.md, "Learning options").

``python benchmarks/getopen_variants.py [--trials 4 --generations 2 --variants scaled,raw,predicted-ball]``

Each trial runs ``--generations`` CEM generations (the paper's 20 candidates x 125 episodes unless told
otherwise; batched mode, classic parameters, 3v2 on 20 m) from the trial's CEM seed, then plays the best
candidate frozen for ``--eval-episodes`` episodes. The variants of one trial share every seed: the CEM's
draws (so generation 0 is the same parameter vectors), the candidates' arenas and the evaluation's arenas;
they differ only in what the net sees. Variants:

* ``scaled``: the default, ``GetOpenScaling()`` inputs, variables 9-10 from K1 (the paper's definition);
* ``raw``: the paper's literal net on metres and degrees;
* ``predicted-ball``: scaled, variables 9-10 from predictedBallPos
  (``AgentConfig.getopen_lane_from_predicted_ball``).

Prints one line per trial and variant (population mean fitness of each generation, best fitness, final
evaluation) and, per variant, the final evaluation's mean +- standard error over trials, with Welch's
t-test against the first variant. ``--json`` writes everything.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository, before benchmarks/

from keepaway.agents.config import AgentConfig  # noqa: E402
from keepaway.agents.getopen import RAW_INPUTS, SCALED_INPUTS  # noqa: E402
from keepaway.runner.batched_backend import BatchedBackend  # noqa: E402
from keepaway.trainer.cem import CEMConfig  # noqa: E402
from keepaway.trainer.curves import CurvePoint, welch_p_value  # noqa: E402
from keepaway.trainer.schedule import GETOPEN, Phase  # noqa: E402
from keepaway.trainer.train import TrainConfig, TrialState, evaluate, initial_behaviours, step  # noqa: E402

VARIANTS = {
    "scaled": (SCALED_INPUTS, AgentConfig()),
    "raw": (RAW_INPUTS, AgentConfig()),
    "predicted-ball": (SCALED_INPUTS, AgentConfig(getopen_lane_from_predicted_ball=True)),
}
EVAL_SEED = 1_000_003  # + trial: the evaluation arenas, shared by the variants


def run_trial(variant: str, seed: int, generations: int, cem: CEMConfig, eval_episodes: int,
              threads: int | None) -> dict:
    """One trial of ``variant`` (module docstring): its trace and final evaluation."""
    inputs, agent = VARIANTS[variant]
    episodes = generations * cem.population * cem.episodes_per_candidate
    config = TrainConfig(pass_policy="handcoded", getopen_policy="learned", schedule=(Phase(GETOPEN, episodes),),
                         eval_every=episodes, eval_episodes=eval_episodes, seed=seed, cem=cem,
                         getopen_inputs=inputs)
    backend = BatchedBackend(replace(config.game(), agent=agent), threads)
    state = TrialState(0, initial_behaviours(config, 0), curve=[CurvePoint(0, 0.0, 0.0)])  # no evaluation at 0
    while state.episodes < episodes:
        step(config, state, backend)
    result = evaluate(backend, state.behaviours, EVAL_SEED + seed, eval_episodes)
    summary = result.summary()
    return {"variant": variant, "seed": seed, "population_mean": [float(np.mean(t["fitness"])) for t in state.trace],
            "best_fitness": state.cem.best_fitness, "eval_mean_s": summary["mean_hold_time_s"],
            "eval_stderr_s": summary["stderr_hold_time_s"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", default="scaled,raw,predicted-ball")
    parser.add_argument("--trials", type=int, default=4)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--generations", type=int, default=2)
    parser.add_argument("--population", type=int, default=20)
    parser.add_argument("--elite", type=int, default=5)
    parser.add_argument("--candidate-episodes", type=int, default=125)
    parser.add_argument("--eval-episodes", type=int, default=500)
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--json", type=Path, default=None, help="write every trial's results here")
    args = parser.parse_args()
    variants = args.variants.split(",")
    unknown = set(variants) - set(VARIANTS)
    if unknown:
        parser.error(f"unknown variants {sorted(unknown)}; choose from {', '.join(VARIANTS)}")
    cem = CEMConfig(population=args.population, elite=args.elite, episodes_per_candidate=args.candidate_episodes)
    rows = []
    for seed in range(args.first_seed, args.first_seed + args.trials):
        for variant in variants:
            row = run_trial(variant, seed, args.generations, cem, args.eval_episodes, args.threads)
            rows.append(row)
            print(f"{variant:15s} seed {seed}: population mean by generation "
                  f"{' '.join(f'{m:5.2f}' for m in row['population_mean'])} s, best {row['best_fitness']:5.2f} s, "
                  f"evaluation {row['eval_mean_s']:5.2f} +- {row['eval_stderr_s']:.2f} s", flush=True)
            if args.json is not None:
                args.json.write_text(json.dumps(rows, indent=1))
    print(f"\n{args.generations} generations of {args.population} x {args.candidate_episodes} episodes, "
          f"{args.eval_episodes}-episode evaluation of the best candidate; mean +- s.e. over trials:")
    finals = {v: np.array([r["eval_mean_s"] for r in rows if r["variant"] == v]) for v in variants}
    for v in variants:
        x = finals[v]
        line = f"  {v:15s} {x.mean():5.2f} +- {x.std(ddof=1) / np.sqrt(len(x)):.2f} s ({len(x)} trials)"
        p = welch_p_value(x, finals[variants[0]]) if v != variants[0] else None
        if p is not None:
            line += f"; Welch p = {p:.3f} vs {variants[0]}"
        print(line)


if __name__ == "__main__":
    main()

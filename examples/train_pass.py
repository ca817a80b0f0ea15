"""Train the keepers' Pass through ``keepaway.env``: each keeper an SMDP Sarsa learner over tile-coded state
variables (the paper's learner, ``agents.sarsa``) fed by the environment's observations and rewards.

    python examples/train_pass.py --episodes 1000 --trials 3

prints the mean hold time of every block of episodes, per trial and over the trials (+- standard error).
A keeper's SMDP reward is the sum of the environment's rewards between two of its decisions.
"""

from __future__ import annotations

import argparse

import numpy as np

from keepaway.agents.sarsa import SarsaConfig, SarsaLearner
from keepaway.env import parallel_env


def train(episodes: int, seed: int) -> list[float]:
    """Hold times (s) of ``episodes`` learning episodes from ``seed``."""
    env = parallel_env()
    learners = {a: SarsaLearner(env.n_keepers, env.n_takers, SarsaConfig(), seed + k)
                for k, a in enumerate(env.possible_agents)}
    holds = []
    obs, _ = env.reset(seed=seed)
    while len(holds) < episodes:
        since = dict.fromkeys(env.agents, None)  # cycles since each keeper's last decision (None: none yet)
        hold, done = 0.0, False
        while not done:
            actions = {}
            for agent, o in obs.items():
                if o["action_mask"][-1]:  # no decision for this keeper now
                    actions[agent] = env.noop
                    continue
                state = o["observation"]
                learner = learners[agent]
                actions[agent] = learner.start(state) if since[agent] is None else learner.step(since[agent], state)
                since[agent] = 0.0
            obs, rewards, terminations, _, _ = env.step(actions)
            for agent, r in rewards.items():
                if since[agent] is not None:
                    since[agent] += r / env.step_s  # the learner counts cycles
            hold += rewards["keeper_1"]
            done = all(terminations.values())
        for agent, elapsed in since.items():
            if elapsed is not None:
                learners[agent].end(elapsed)
        holds.append(hold)
        obs, _ = env.reset()
    return holds


def main(train=train, doc: str = __doc__) -> None:
    """Parse the command line, train ``--trials`` trials with ``train(episodes, seed)`` and print the mean
    hold time of each block of episodes (the other examples reuse it)."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--trials", type=int, default=3)
    parser.add_argument("--block", type=int, default=200, help="episodes per reported mean")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    curves = np.array([train(args.episodes, args.seed + 1000 * t) for t in range(args.trials)])
    blocks = curves[:, : args.episodes // args.block * args.block].reshape(args.trials, -1, args.block).mean(axis=2)
    for b, column in enumerate(blocks.T):
        se = column.std(ddof=1) / np.sqrt(len(column)) if len(column) > 1 else float("nan")
        trials = " ".join(f"{v:5.2f}" for v in column)
        print(f"episodes {b * args.block + 1:5d}-{(b + 1) * args.block:5d}: "
              f"{column.mean():5.2f} +- {se:.2f} s  ({trials})")


if __name__ == "__main__":
    main()

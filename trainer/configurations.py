"""The paper's nine configurations (docs/players.md §8.3): Pass in {R, HC, L} x GetOpen in {R, HC, L},
each named ``P:HC-GO:L`` and kept in its own directory of an experiment's output; the settings every
configuration of an experiment shares (:class:`ExperimentConfig`) and what a configuration's run gives
(:class:`ConfigurationRun`).

Every configuration has its own seed, derived from the experiment's and the configuration's place in
the 3 x 3 grid, so configurations are independent samples as the significance tests assume (with one
shared seed, P:R-GO:L and P:L-GO:L would play identical first CEM generations).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from keepaway.runner.job import CHUNK_EPISODES, derive_seed
from keepaway.trainer.cem import CEMConfig
from keepaway.trainer.curves import CurvePoint, mean_curve, stderr_basis
from keepaway.trainer.schedule import (
    ALGORITHM_3,
    LEARNED,
    PASS,
    TRAINING_EPISODES,
    Phase,
    evaluation_points,
    training_schedule,
)
from keepaway.trainer.timing import Timing
from keepaway.trainer.train import TrainConfig, hive_mind_sarsa

POLICIES = ("random", "handcoded", LEARNED)  # the paper's R, HC, L, in its order
SHORT = {"random": "R", "handcoded": "HC", LEARNED: "L"}
INTERVALS = 12  # docs/players.md §8.3: an evaluation every 2,500 of 30,000 episodes
CONFIGURATIONS = tuple((p, g) for p in POLICIES for g in POLICIES)  # Figure 3's order: P:R-GO:R, P:R-GO:HC, ...
# The configurations from the longest to the shortest to train, as measured in a run of Figure 3 at 20
# trials: workers that take them in this order finish at about the same time.
LONGEST_FIRST = ((LEARNED, "handcoded"), ("handcoded", LEARNED), (LEARNED, LEARNED), (LEARNED, "random"),
                 ("random", LEARNED), ("handcoded", "handcoded"), ("random", "handcoded"), ("handcoded", "random"),
                 ("random", "random"))


def configuration_name(pass_policy: str, getopen_policy: str) -> str:
    """``P:HC-GO:L`` (docs/players.md §8.3)."""
    return f"P:{SHORT[pass_policy]}-GO:{SHORT[getopen_policy]}"


def configuration_dir(out: Path, pass_policy: str, getopen_policy: str) -> Path:
    """The configuration's directory: its name without colons (``P_HC-GO_L``), which some file systems refuse."""
    return out / configuration_name(pass_policy, getopen_policy).replace(":", "_")


def parse_configurations(names: Sequence[str]) -> list[tuple[str, str]]:
    """The (Pass, GetOpen) pairs named ``P:HC-GO:L`` (or as their directories, ``P_HC-GO_L``), in Figure 3's
    order; ValueError (one line) for a name that is none of the nine."""
    known = {configuration_name(p, g): (p, g) for p, g in CONFIGURATIONS}
    chosen = set()
    for name in names:
        pair = known.get(name.strip().replace("_", ":"))
        if pair is None:
            raise ValueError(f"unknown configuration {name!r}; choose from {', '.join(known)}")
        chosen.add(pair)
    return [c for c in CONFIGURATIONS if c in chosen]


def default_eval_every(episodes: int) -> int:
    """The paper's evaluation interval scaled to a training of ``episodes``: 12 intervals (at least one episode)."""
    return max(1, episodes // INTERVALS)


@dataclass(frozen=True)
class ExperimentConfig:
    """What every configuration of an experiment shares (docs/players.md §8.3 unless noted)."""

    trials: int = 20  # "at least 20 independent trials"
    episodes: int = TRAINING_EPISODES
    eval_every: int = 2_500
    eval_episodes: int = 500
    arenas: int = 2  # ours: distributed, arenas of processes (where the chunks play, no part of any result)
    seed: int = 0
    cem: CEMConfig = CEMConfig()
    pass_alpha_halflife: int = 0  # ours, off by default (trainer.train.TrainConfig.pass_alpha)
    mode: str = "batched"  # the backend (runner.job.MODES): every one plays the same games
    pass_hive_mind: bool = False  # ours, off by default (agents.sarsa.SarsaConfig.hive_mind)
    chunk_episodes: int = CHUNK_EPISODES  # every job cut into chunks of this many (runner.job)

    def schedule(self, pass_policy: str, getopen_policy: str) -> tuple[Phase, ...]:
        """The phases of a learning configuration: one phase of ``episodes``, or with both behaviours
        learned Algorithm 3 (docs/players.md §8.2) scaled to ``episodes``, which must keep its proportions
        exact (a multiple of 6)."""
        schedule = None
        if pass_policy == LEARNED and getopen_policy == LEARNED:
            if any(self.episodes * p.episodes % TRAINING_EPISODES for p in ALGORITHM_3):
                raise ValueError(f"Algorithm 3 scaled to {self.episodes} episodes has fractional phases; "
                                 f"choose --episodes a multiple of 6")
            schedule = tuple(Phase(p.behaviour, self.episodes * p.episodes // TRAINING_EPISODES) for p in ALGORITHM_3)
        return training_schedule(pass_policy, getopen_policy, self.episodes, schedule)

    def configuration_seed(self, pass_policy: str, getopen_policy: str) -> int:
        """The seed of one configuration (module docstring)."""
        return derive_seed(self.seed, POLICIES.index(pass_policy), POLICIES.index(getopen_policy))

    def train_config(self, pass_policy: str, getopen_policy: str) -> TrainConfig:
        """The training of a configuration in which at least one behaviour learns."""
        return TrainConfig(pass_policy, getopen_policy, self.schedule(pass_policy, getopen_policy), self.trials,
                           self.eval_every, self.eval_episodes, self.arenas,
                           self.configuration_seed(pass_policy, getopen_policy), cem=self.cem, mode=self.mode,
                           pass_alpha_halflife=self.pass_alpha_halflife if pass_policy == LEARNED else 0,
                           sarsa=hive_mind_sarsa(self.pass_hive_mind and pass_policy == LEARNED),
                           chunk_episodes=self.chunk_episodes)

    def points(self) -> list[int]:
        """Episodes trained at each evaluation: the same for every configuration."""
        return evaluation_points((Phase(PASS, self.episodes),), self.eval_every)

    def fixed_record(self, pass_policy: str, getopen_policy: str) -> dict[str, Any]:
        """What the curve of a configuration that learns nothing depends on (its ``fixed.json``)."""
        return {"name": configuration_name(pass_policy, getopen_policy), "pass_policy": pass_policy,
                "getopen_policy": getopen_policy, "trials": self.trials, "points": self.points(),
                "eval_episodes": self.eval_episodes, "arenas": self.arenas,
                "seed": self.configuration_seed(pass_policy, getopen_policy), "mode": self.mode,
                "chunk_episodes": self.chunk_episodes}

    def check(self) -> None:
        """ValueError (one line) unless every configuration of Figure 3 can be built."""
        for p in POLICIES:
            for g in POLICIES:
                if LEARNED in (p, g):
                    self.train_config(p, g)
        if min(self.trials, self.episodes, self.eval_every, self.eval_episodes, self.arenas,
               self.chunk_episodes) < 1:
            raise ValueError("trials, episodes, eval_every, eval_episodes, arenas and chunk_episodes must be "
                             "at least 1")


@dataclass(frozen=True)
class ConfigurationRun:
    """A configuration's learning curves, one per trial, whether this run found it already finished, the
    episodes of each evaluation (what a single trial's standard errors are over), and what it cost."""

    name: str
    pass_policy: str
    getopen_policy: str
    curves: list[list[CurvePoint]]
    skipped: bool
    eval_episodes: int
    timing: Timing = Timing()

    def mean_curve(self) -> list[CurvePoint]:
        return mean_curve(self.curves)

    def final(self) -> CurvePoint:
        """The last evaluation: mean over trials and its standard error (:meth:`stderr_basis`)."""
        return self.mean_curve()[-1]

    def stderr_basis(self) -> str:
        """What the standard errors of :meth:`mean_curve` are over, in words."""
        return stderr_basis(len(self.curves), self.eval_episodes)

    def reference_level(self) -> float:
        """The mean of its mean curve over all evaluation points: the level of a configuration that
        learns nothing (its curve is flat but measured at every point)."""
        curve = self.mean_curve()
        return sum(p.mean_hold_time_s for p in curve) / len(curve)


__all__ = [
    "CONFIGURATIONS",
    "ConfigurationRun",
    "ExperimentConfig",
    "INTERVALS",
    "LONGEST_FIRST",
    "POLICIES",
    "SHORT",
    "configuration_dir",
    "configuration_name",
    "default_eval_every",
    "parse_configurations",
]

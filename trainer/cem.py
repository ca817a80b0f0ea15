"""The cross-entropy method for GetOpen policy search (spec `keepaway-task.md` 6).

A diagonal Gaussian over the 91 parameters of the GetOpen net (`agents.getopen.net_value`; the net on
scaled inputs, `agents.getopen.GetOpenScaling`, unless the training says raw), N(0, I) at the
start. Each generation ``ask()`` draws 20 candidates; the trainer evaluates each by its mean hold time
over 125 episodes (all keepers share the candidate, Pass fixed) and hands the 20 numbers to ``tell``,
which keeps the best 5 and refits the mean and the per-parameter variance to them (with the noisy
variant, :attr:`CEMConfig.extra_noise`, plus a decreasing amount of extra variance). One generation is
20 x 125 = 2,500 episodes. The best candidate evaluated so far is what Algorithm 3's Pass phases use
(`keepaway-task.md` 7).

Generation g draws its standard normals from ``numpy.random.default_rng([seed, g])``, so the search is a
function of the seed alone and ``state_dict()`` needs no generator state: a restored search, even one
restored between ``ask`` and ``tell``, continues exactly as the original would have.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from keepaway.agents.getopen import net_size

BEST, MEAN = "best", "mean"
PLAYS = (BEST, MEAN)  # CEMConfig.play: the best candidate so far (the paper) or the distribution's mean


@dataclass(frozen=True)
class CEMConfig:
    """The search's constants (keepaway-task.md 6 unless noted)."""

    n_params: int = net_size()  # 91: the 10-5-5-1 GetOpen net (keepaway-task.md 4)
    population: int = 20  # candidates per generation
    elite: int = 5  # best candidates the distribution is refitted to
    episodes_per_candidate: int = 125  # evaluation episodes per candidate (read by the trainer)
    initial_mean: float = 0.0  # N(0, I) start
    initial_variance: float = 1.0
    min_variance: float = 0.0  # ours, off by default: a floor on each refitted variance against collapse
    # Ours, off by default: the noisy cross-entropy method (Szita & Lorincz 2006, "Learning Tetris using the
    # noisy cross-entropy method"): extra_noise is added to every refitted variance after generation 0 and
    # decreases linearly to zero at generation extra_noise_generations (0: it never decreases).
    extra_noise: float = 0.0
    extra_noise_generations: int = 0
    # Which net the trainer plays after each generation (evaluations, Pass phases, the policy file): the
    # best candidate evaluated so far (keepaway-task.md 7, the paper) or, ours, the distribution's mean.
    play: str = "best"

    def __post_init__(self) -> None:
        if not 0 < self.elite <= self.population:
            raise ValueError(f"need 0 < elite <= population, got {self.elite} of {self.population}")
        if self.n_params < 1 or self.episodes_per_candidate < 1:
            raise ValueError("n_params and episodes_per_candidate must be positive")
        if self.initial_variance <= 0.0 or self.min_variance < 0.0:
            raise ValueError("need initial_variance > 0 and min_variance >= 0")
        if self.extra_noise < 0.0 or self.extra_noise_generations < 0:
            raise ValueError("need extra_noise >= 0 and extra_noise_generations >= 0")
        if self.play not in PLAYS:
            raise ValueError(f"play must be one of {', '.join(PLAYS)}, not {self.play!r}")

    def extra_variance(self, generation: int) -> float:
        """The noise added to the variance refitted after ``generation`` (0-based; ``extra_noise`` above)."""
        if self.extra_noise_generations == 0:
            return self.extra_noise
        return self.extra_noise * max(0.0, 1.0 - generation / self.extra_noise_generations)


def fit_elite(
    candidates: np.ndarray, fitness: np.ndarray, elite: int, min_variance: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and per-parameter variance (maximum likelihood, divide by ``elite``) of the ``elite`` fittest
    rows of ``candidates``, the variance floored at ``min_variance``. Equal fitness: the earlier row wins."""
    best = np.argsort(-fitness, kind="stable")[:elite]
    chosen = candidates[best]
    return chosen.mean(axis=0), np.maximum(chosen.var(axis=0), min_variance)


class CEM:
    """The cross-entropy method as an ask/tell loop (module docstring)."""

    def __init__(self, config: CEMConfig = CEMConfig(), seed: int = 0) -> None:
        self.config = config
        self.seed = int(seed)
        self.generation = 0
        self.mean = np.full(config.n_params, config.initial_mean)
        self.variance = np.full(config.n_params, config.initial_variance)
        self.best_params: np.ndarray | None = None
        self.best_fitness = -np.inf

    def ask(self) -> np.ndarray:
        """This generation's candidates, (population, n_params): mean + sqrt(variance) * N(0, I). Asking
        again before ``tell`` returns the same candidates."""
        normals = np.random.default_rng([self.seed, self.generation]).standard_normal(
            (self.config.population, self.config.n_params)
        )
        return self.mean + np.sqrt(self.variance) * normals

    def tell(self, fitness: np.ndarray) -> None:
        """Report the candidates' fitness (mean hold time; higher is better) in ``ask()`` order: update the
        best so far, refit the distribution to the elite and move to the next generation."""
        fitness = np.asarray(fitness, dtype=np.float64)
        if fitness.shape != (self.config.population,) or not np.all(np.isfinite(fitness)):
            raise ValueError(f"need {self.config.population} finite fitness values, got {fitness!r}")
        candidates = self.ask()
        top = int(np.argmax(fitness))
        if fitness[top] > self.best_fitness:
            self.best_fitness = float(fitness[top])
            self.best_params = candidates[top].copy()
        self.mean, self.variance = fit_elite(candidates, fitness, self.config.elite, self.config.min_variance)
        self.variance += self.config.extra_variance(self.generation)
        self.generation += 1

    def played(self) -> np.ndarray:
        """The net the trainer plays (:attr:`CEMConfig.play`): a copy of the best candidate so far or of the
        mean. Only after a ``tell``."""
        chosen = self.mean if self.config.play == MEAN else self.best_params
        assert chosen is not None and self.generation > 0
        return chosen.copy()

    def state_dict(self) -> dict[str, Any]:
        """Everything needed to resume: plain Python values and numpy arrays."""
        return {
            "config": asdict(self.config),
            "seed": self.seed,
            "generation": self.generation,
            "mean": self.mean.copy(),
            "variance": self.variance.copy(),
            "best_params": None if self.best_params is None else self.best_params.copy(),
            "best_fitness": self.best_fitness,
        }

    @classmethod
    def from_state_dict(cls, state: dict[str, Any]) -> CEM:
        """The search ``state_dict()`` described, continuing where it stopped."""
        cem = cls(CEMConfig(**state["config"]), seed=state["seed"])
        cem.generation = int(state["generation"])
        cem.mean = np.array(state["mean"], dtype=np.float64)
        cem.variance = np.array(state["variance"], dtype=np.float64)
        if cem.mean.shape != (cem.config.n_params,) or cem.variance.shape != cem.mean.shape:
            raise ValueError("mean and variance must have n_params entries")
        best = state["best_params"]
        cem.best_params = None if best is None else np.array(best, dtype=np.float64)
        cem.best_fitness = float(state["best_fitness"])
        return cem


__all__ = ["BEST", "CEM", "MEAN", "PLAYS", "CEMConfig", "fit_elite"]

"""The cross-entropy method (spec `keepaway-task.md` 6)."""

from __future__ import annotations

import numpy as np
import pytest

from keepaway.trainer.cem import CEM, CEMConfig, fit_elite

TARGET = np.array([1.0, -0.5, 0.3, 0.8, -1.2])


def quadratic(x: np.ndarray) -> np.ndarray:
    """Fitness to maximise: -||x - TARGET||^2 (0 at TARGET)."""
    return -((x - TARGET) ** 2).sum(axis=-1)


def test_defaults_are_the_papers():
    cfg = CEMConfig()
    assert (cfg.n_params, cfg.population, cfg.elite, cfg.episodes_per_candidate) == (91, 20, 5, 125)
    assert (cfg.initial_mean, cfg.initial_variance, cfg.min_variance) == (0.0, 1.0, 0.0)


def test_first_generation_draws_from_standard_normal():
    # N(0, I): mean 0 + sqrt(1) * z, with z from generation 0's stream.
    cem = CEM(seed=7)
    candidates = cem.ask()
    assert candidates.shape == (20, 91)
    expected = np.random.default_rng([7, 0]).standard_normal((20, 91))
    np.testing.assert_array_equal(candidates, expected)
    np.testing.assert_array_equal(cem.ask(), candidates)
    assert not np.array_equal(CEM(seed=8).ask(), candidates)


def test_fit_elite_by_hand():
    # Row i = (i, (-1)^i i), fitness -|i - 10|: the best 5 are i = 8..12.
    # Parameter 0: 8, 9, 10, 11, 12 -> mean 10, variance (4 + 1 + 0 + 1 + 4) / 5 = 2.
    # Parameter 1: 8, -9, 10, -11, 12 -> mean 10 / 5 = 2; deviations 6, -11, 8, -13, 10;
    # variance (36 + 121 + 64 + 169 + 100) / 5 = 490 / 5 = 98.
    i = np.arange(20.0)
    candidates = np.stack([i, (-1.0) ** i * i], axis=1)
    mean, variance = fit_elite(candidates, -np.abs(i - 10.0), 5)
    np.testing.assert_allclose(mean, [10.0, 2.0])
    np.testing.assert_allclose(variance, [2.0, 98.0])


def test_fit_elite_ties_keep_earlier_rows_and_floor_variance():
    # All fitness equal -> rows 0..4: values 0..4 (mean 2, variance (4+1+0+1+4)/5 = 2); a constant
    # column has variance 0, raised to the floor 0.25.
    candidates = np.stack([np.arange(20.0), np.ones(20)], axis=1)
    mean, variance = fit_elite(candidates, np.zeros(20), 5, min_variance=0.25)
    np.testing.assert_allclose(mean, [2.0, 1.0])
    np.testing.assert_allclose(variance, [2.0, 0.25])


def test_tell_refits_to_best_five_and_tracks_best():
    cem = CEM(seed=3)
    candidates = cem.ask()
    fitness = candidates[:, 0] - candidates[:, 1]
    cem.tell(fitness)
    elite = candidates[sorted(range(20), key=lambda k: -fitness[k])[:5]]
    np.testing.assert_allclose(cem.mean, elite.mean(axis=0))
    np.testing.assert_allclose(cem.variance, ((elite - elite.mean(axis=0)) ** 2).sum(axis=0) / 5)
    np.testing.assert_array_equal(cem.best_params, candidates[np.argmax(fitness)])
    assert cem.best_fitness == fitness.max()
    assert cem.generation == 1


def test_best_so_far_survives_a_worse_generation():
    cem = CEM(CEMConfig(n_params=5), seed=1)
    first = cem.ask()
    cem.tell(np.arange(20.0))
    cem.ask()
    cem.tell(np.full(20, -100.0))
    assert cem.best_fitness == 19.0
    np.testing.assert_array_equal(cem.best_params, first[19])


@pytest.mark.parametrize("seed", range(5))
def test_cem_improves_a_quadratic(seed):
    # f(initial mean 0) = -(1 + 0.25 + 0.09 + 0.64 + 1.44) = -3.42; ten generations cut it five-fold.
    cem = CEM(CEMConfig(n_params=5), seed=seed)
    assert quadratic(cem.mean) == pytest.approx(-3.42)
    bests = []
    for _ in range(10):
        x = cem.ask()
        cem.tell(quadratic(x))
        bests.append(cem.best_fitness)
    assert quadratic(cem.mean) > -3.42 / 5
    assert bests == sorted(bests)


def test_variance_floor_keeps_searching():
    cem = CEM(CEMConfig(n_params=5, min_variance=0.01), seed=0)
    for _ in range(30):
        cem.tell(quadratic(cem.ask()))
    assert np.all(cem.variance >= 0.01)


@pytest.mark.parametrize("asked_before_saving", [False, True])
def test_resume_continues_identically(asked_before_saving):
    original = CEM(CEMConfig(n_params=7), seed=11)
    for _ in range(3):
        original.tell(quadratic(original.ask()[:, :5]))
    if asked_before_saving:
        original.ask()
    resumed = CEM.from_state_dict(original.state_dict())
    for _ in range(3):
        a, b = original.ask(), resumed.ask()
        np.testing.assert_array_equal(a, b)
        original.tell(quadratic(a[:, :5]))
        resumed.tell(quadratic(b[:, :5]))
    np.testing.assert_array_equal(original.mean, resumed.mean)
    np.testing.assert_array_equal(original.variance, resumed.variance)
    np.testing.assert_array_equal(original.best_params, resumed.best_params)
    assert resumed.best_fitness == original.best_fitness
    assert resumed.generation == original.generation == 6


def test_tell_rejects_bad_fitness():
    cem = CEM()
    with pytest.raises(ValueError):
        cem.tell(np.zeros(19))
    with pytest.raises(ValueError):
        cem.tell(np.full(20, np.nan))
    with pytest.raises(ValueError):
        CEMConfig(elite=21)


def test_noisy_cem_adds_extra_variance_that_falls_linearly_to_zero():
    # Szita & Lorincz's noisy CE: extra noise 0.5 over 4 generations adds 0.5, 0.375, 0.25, 0.125, 0, 0, ...
    cfg = CEMConfig(extra_noise=0.5, extra_noise_generations=4)
    assert [cfg.extra_variance(g) for g in range(6)] == [0.5, 0.375, 0.25, 0.125, 0.0, 0.0]
    assert CEMConfig(extra_noise=0.5).extra_variance(100) == 0.5  # 0 generations: it stays
    assert CEMConfig().extra_variance(0) == 0.0  # the paper's CEM
    with pytest.raises(ValueError, match="extra_noise"):
        CEMConfig(extra_noise=-1.0)


def test_tell_adds_the_extra_variance_to_the_elites_fit():
    cem = CEM(CEMConfig(extra_noise=0.5, extra_noise_generations=4), seed=3)
    for extra in (0.5, 0.375):  # generations 0 and 1
        candidates = cem.ask()
        fitness = candidates[:, 0] - candidates[:, 1]
        mean, variance = fit_elite(candidates, fitness, 5)
        cem.tell(fitness)
        np.testing.assert_allclose(cem.mean, mean)
        np.testing.assert_allclose(cem.variance, variance + extra)
    assert cem.generation == 2


def test_the_played_net_is_the_best_so_far_by_default_or_the_mean():
    best, mean = CEM(CEMConfig(n_params=3, population=4, elite=2)), CEM(CEMConfig(n_params=3, population=4,
                                                                                  elite=2, play="mean"))
    fitness = np.array([1.0, 4.0, 3.0, 2.0])
    for cem in (best, mean):
        candidates = cem.ask()
        cem.tell(fitness)
    np.testing.assert_array_equal(best.played(), candidates[1])  # the fittest candidate
    np.testing.assert_array_equal(mean.played(), (candidates[1] + candidates[2]) / 2)  # the elite's mean
    played = mean.played()
    played[:] = 0.0  # a copy: the search is not touched
    assert np.all(mean.mean != 0.0)


def test_an_unknown_play_is_refused():
    with pytest.raises(ValueError, match="play must be one of best, mean"):
        CEMConfig(play="median")

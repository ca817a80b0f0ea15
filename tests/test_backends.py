"""Every mode behind the one interface (``runner.job.Backend``): the same jobs through the batched, the
embedded and the distributed backend, directly and through ``keepaway evaluate`` and ``keepaway
experiment``. Every backend plays a job's chunks (``runner.job.chunk_seeds``) as fresh arenas of their
seeds, so all three play the same episodes and learn the same weights; the embedded and the distributed
backend, which serve the same coach requests (``runner.coached``), also report the same transitions."""

from __future__ import annotations

import json
import subprocess
from dataclasses import asdict, replace

import numpy as np
import pytest

from keepaway.agents.policy_file import getopen_theta_size, load_policy, pack_pass_arrays, save_policy
from conftest import keepaway_command
from keepaway.protocol.params import parameter_set
from keepaway.runner.backends import Placement, open_backend
from keepaway.runner.distributed import DistributedBackend
from keepaway.runner.embedded import EmbeddedBackend
from keepaway.runner.job import GREEDY, LEARN, MODES, Backend, Behaviours, Game, Job, Played, RunResult

GAME = Game(parameter_set("classic"))
CHUNK = 2  # episodes per request: jobs of a few episodes still span several chunks
FROZEN = Behaviours("random", "random")  # draws from the players' own streams: their reseeding counts
LEARNING = Behaviours("learned", "handcoded")
FROZEN_HC = Behaviours("handcoded", "handcoded")


def durations(result: RunResult) -> list[tuple[int, str]]:
    """Each episode's length in cycles and how it ended (the cycles it started at depend on what the arena
    played before; its length does not)."""
    return [(e.end_cycle - e.start_cycle, e.end) for e in result.episodes]


@pytest.fixture(scope="module")
def backends(tmp_path_factory) -> dict[str, Backend]:
    """A backend of every mode; the distributed one on one arena of processes started here."""
    distributed = DistributedBackend.start_local(GAME, 1, tmp_path_factory.mktemp("arenas"), "classic",
                                                 chunk_episodes=CHUNK)
    opened = {"batched": open_backend("batched", GAME, "classic", 1, tmp_path_factory.mktemp("unused"),
                                      Placement(threads=1), chunk_episodes=CHUNK),
              "embedded": EmbeddedBackend(GAME, chunk_episodes=CHUNK), "distributed": distributed}
    yield opened
    for backend in opened.values():
        backend.close()


@pytest.mark.parametrize("mode", MODES)
def test_every_backend_plays_jobs_that_depend_only_on_their_arguments(backends, mode):
    backend = backends[mode]
    learned = backend.play(LEARNING, 5, 3, LEARN)
    assert learned.result.mode == mode and [e.episode for e in learned.result.episodes] == [1, 2, 3]
    assert len(learned.pass_arrays) == GAME.keepers
    assert any(np.any(arrays["pass_weights"] != 0.0) for arrays in learned.pass_arrays)
    trained = replace(LEARNING, pass_arrays=learned.pass_arrays)
    first = backend.play(trained, 6, 3, GREEDY)
    assert first.pass_arrays is None and first.transitions is None  # frozen: nothing learned
    backend.play(FROZEN, 7, 2, GREEDY)
    assert durations(backend.play(trained, 6, 3, GREEDY).result) == durations(first.result)
    candidates = [FROZEN, replace(FROZEN, getopen_policy="handcoded"), FROZEN]
    same, other, again = backend.play_all([Job(c, 8, 3, GREEDY) for c in candidates])
    assert durations(same.result) == durations(again.result) != durations(other.result)  # common random numbers


def assert_same_played(a: Played, b: Played) -> None:
    assert durations(a.result) == durations(b.result) and a.result.cycles == b.result.cycles
    assert (a.pass_arrays is None) == (b.pass_arrays is None)
    for mine, theirs in zip(a.pass_arrays or [], b.pass_arrays or [], strict=True):
        for name in mine:
            np.testing.assert_array_equal(mine[name], theirs[name], err_msg=name)


@pytest.mark.parametrize("mode", MODES)
def test_every_backend_plays_independent_jobs_together_as_each_alone(backends, mode):
    # Jobs of the same step of several trials: two learning jobs (fresh and trained learners), frozen
    # jobs of the same and of other policies, more arenas than episodes; together (the batched backend:
    # in shared batches) each plays as it does alone.
    # The batched backend plays the learning jobs in one batch and the frozen ones in another, whatever
    # their policies, modes and step sizes (runner/batched_backend.py).
    backend = backends[mode]
    trained = replace(LEARNING, pass_arrays=backend.play(LEARNING, 21, 2, LEARN).pass_arrays)
    net = np.random.default_rng(3).uniform(-0.5, 0.5, getopen_theta_size())
    jobs = [Job(LEARNING, 22, 3, LEARN), Job(trained, 23, 2, LEARN), Job(trained, 24, 3, GREEDY),
            Job(FROZEN, 25, 2, GREEDY), Job(trained, 26, 3, GREEDY, alpha=0.5), Job(LEARNING, 27, 2, GREEDY),
            Job(replace(trained, getopen_policy="learned", getopen_theta=net), 28, 3, LEARN, alpha=0.03),
            Job(Behaviours("random", "learned", net), 29, 2, GREEDY), Job(FROZEN_HC, 30, 3, GREEDY)]
    if mode == "batched":
        assert backend._batches(jobs) == [[0, 1, 6], [2, 3, 4, 5, 7, 8]]
    for together, job in zip(backend.play_all(jobs), jobs, strict=True):
        assert_same_played(together, backend.play_all([job])[0])


def test_every_backend_plays_the_same_frozen_jobs(backends):
    frozen = {mode: durations(backend.play(FROZEN, 11, 5, GREEDY).result) for mode, backend in backends.items()}
    assert frozen["batched"] == frozen["embedded"] == frozen["distributed"]
    assert len(frozen["batched"]) == 5  # three chunks of at most 2
    candidates = [FROZEN, replace(FROZEN, getopen_policy="handcoded")]
    jobs = [Job(c, 12, 3, GREEDY) for c in candidates]
    together = {mode: [durations(p.result) for p in backend.play_all(jobs)] for mode, backend in backends.items()}
    assert together["batched"] == together["embedded"] == together["distributed"]


def test_every_backend_learns_the_same_weights_and_the_coached_ones_from_the_same_transitions(backends):
    # 5 episodes in chunks of 2: the batched backend carries the weights over two restarts, as the
    # coached arenas' keepers do
    played = {mode: backend.play(LEARNING, 3, 5, LEARN) for mode, backend in backends.items()}
    embedded, distributed = played["embedded"], played["distributed"]
    for other in (played["batched"], distributed):
        assert durations(embedded.result) == durations(other.result)
        for mine, theirs in zip(embedded.pass_arrays, other.pass_arrays, strict=True):
            assert mine.keys() == theirs.keys()
            for name in mine:
                np.testing.assert_array_equal(mine[name], theirs[name], err_msg=name)
    assert embedded.transitions.keys() == distributed.transitions.keys() == {1, 2, 3}
    for unum, arrays in embedded.transitions.items():
        for name, values in arrays.items():
            np.testing.assert_array_equal(values, distributed.transitions[unum][name], err_msg=f"keeper {unum} {name}")


def test_a_coached_arena_that_learned_plays_a_fixed_pass_policy_as_a_fresh_one():
    # Its keepers keep their learners (docs/advice.md), which must not play while Pass is hand-coded.
    fresh = EmbeddedBackend(GAME, chunk_episodes=CHUNK).play(FROZEN_HC, 11, 3, GREEDY)
    used = EmbeddedBackend(GAME, chunk_episodes=CHUNK)
    used.play(LEARNING, 5, 3, LEARN)
    assert durations(used.play(FROZEN_HC, 11, 3, GREEDY).result) == durations(fresh.result)


def test_a_step_size_reaches_the_learners_of_every_backend(backends):
    for backend in backends.values():
        constant = backend.play(LEARNING, 9, 3, LEARN).pass_arrays
        smaller = backend.play(LEARNING, 9, 3, LEARN, alpha=GAME.sarsa.alpha / 4).pass_arrays
        assert any(not np.array_equal(a["pass_weights"], b["pass_weights"]) for a, b in zip(constant, smaller))


def test_running_arenas_and_ray_are_only_for_the_distributed_mode(tmp_path):
    for mode in ("batched", "embedded"):
        with pytest.raises(ValueError, match=f"are for the distributed mode, not {mode}"):
            open_backend(mode, GAME, "classic", 1, tmp_path, Placement(attach=("tcp://127.0.0.1:1",)))
    with pytest.raises(ValueError, match="mode must be one of batched, embedded, distributed"):
        open_backend("threads", GAME, "classic", 1, tmp_path)


def run_keepaway(processes, *args: str) -> str:
    """The standard output of a ``keepaway`` command that must succeed."""
    proc = processes.popen(keepaway_command(*args), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err.decode()[-2000:]
    return out.decode()


def episode_durations(summary: dict) -> list[tuple[int, str]]:
    return [(e["end_cycle"] - e["start_cycle"], e["end"]) for e in summary["episodes"]]


def test_evaluate_plays_a_policy_file_the_same_in_every_mode(processes, tmp_path, backends):
    learned = backends["embedded"].play(LEARNING, 4, 3, LEARN).pass_arrays
    theta = np.random.default_rng(2).uniform(-0.5, 0.5, getopen_theta_size())
    policy = save_policy(tmp_path / "policy.npz", getopen_theta=theta, pass_arrays=pack_pass_arrays(learned),
                         config={"keepers": 3, "takers": 2, "pass": "learned", "getopen": "learned",
                                 "sarsa": asdict(GAME.sarsa)})
    summaries = {mode: json.loads(run_keepaway(processes, "evaluate", "--policy", str(policy), "--mode", mode,
                                               "--episodes", "30", "--json", "--no-progress",
                                               *(["--arenas", "2"] if mode == "distributed" else [])))
                 for mode in MODES}
    assert {mode: (s["mode"], s["pass"], s["getopen"], len(s["episodes"])) for mode, s in summaries.items()} == \
        {mode: (mode, "learned", "learned", 30) for mode in MODES}
    assert episode_durations(summaries["batched"]) == episode_durations(summaries["embedded"]) == \
        episode_durations(summaries["distributed"])


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_an_experiment_learns_the_same_in_every_mode(processes, tmp_path):
    # P:L-GO:HC learns Pass in three blocks of 8 episodes (evaluations of 2 at 0, 8, 16 and 24); P:HC-GO:HC
    # is only evaluated. Every curve and every learned weight must agree, and every reported transition of
    # the two modes that report them. (The CEM's generations of 4 episodes fit the schedules of the
    # configurations not run.)
    settings = ["--only", "P:L-GO:HC", "--only", "P:HC-GO:HC", "--trials", "1", "--episodes", "24", "--eval-every",
                "8", "--eval-episodes", "2", "--population", "2", "--elite", "1", "--candidate-episodes", "2",
                "--seed", "2", "--no-progress"]
    outs = {mode: tmp_path / mode for mode in MODES}
    for mode, out in outs.items():
        run_keepaway(processes, "experiment", "figure3", *settings, "--mode", mode, "--out", str(out),
                     *(["--arenas", "1"] if mode == "distributed" else []))
    for configuration in ("P_L-GO_HC", "P_HC-GO_HC"):
        curves = [(out / configuration / "trial_000" / "curve.csv").read_text() for out in outs.values()]
        assert curves[0] == curves[1] == curves[2] and len(curves[0].splitlines()) == 5, configuration
    learned = [load_policy(out / "P_L-GO_HC" / "trial_000" / "policy.npz").pass_arrays for out in outs.values()]
    assert learned[0].keys() == learned[1].keys() == learned[2].keys()
    for name in learned[0]:
        for other in learned[1:]:
            np.testing.assert_array_equal(learned[0][name], other[name], err_msg=name)
    coached = [outs["embedded"], outs["distributed"]]
    transitions = [sorted((out / "P_L-GO_HC" / "trial_000" / "transitions").iterdir()) for out in coached]
    assert [p.name for p in transitions[0]] == [p.name for p in transitions[1]] == \
        [f"pass_to_{episodes:06d}.npz" for episodes in range(8, 25, 8)]
    for mine, theirs in zip(*transitions):
        with np.load(mine) as a, np.load(theirs) as b:
            assert a.files == b.files
            for name in a.files:
                np.testing.assert_array_equal(a[name], b[name], err_msg=f"{mine.name} {name}")

"""The paper's experiments (docs/players.md §8.3): Figure 3's nine configurations and Table 2's
specialisation cross-tests, built on :mod:`trainer.train`.

Figure 3: Pass in {R, HC, L} x GetOpen in {R, HC, L}, each configuration (``P:HC-GO:L``) in its own
directory of the experiment's output. A configuration that learns is a :func:`trainer.train.train`
training (one learned behaviour: one phase; both: Algorithm 3, scaled to the experiment's length); one
that learns nothing is evaluated at the same evaluation points with the same arena seeds, so its curve is
flat but measured. Every directory records its configuration; running the experiment again skips the
finished configurations, continues the unfinished ones from their checkpoints and refuses a directory
that holds a different configuration.

Table 2: a Pass policy learned with GetOpen X (``P:L-GO:X``) is tested with GetOpen Y, and a GetOpen
policy learned with Pass X (``P:X-GO:L``) with Pass Y, for X, Y in {R, HC, L}. A learned counterpart Y is
the one learned in ``P:L-GO:L``'s trial of the same number. Each entry is the mean over trials of the
trials' mean hold times with its standard error; an entry marked ``*`` differs from its column's best
(Welch's t-test over trials, ``trainer.curves.welch_p_value``, p < 0.05). The paper expects each
column's best on the diagonal.

Every configuration has its own seed, derived from the experiment's and the configuration's place in
the 3 x 3 grid, so configurations are independent samples as the significance tests assume (with one
shared seed, P:R-GO:L and P:L-GO:L would play identical first CEM generations). Table 2's tests of a
trial all play the same arena seeds (common random numbers).

With one trial a standard error over trials does not exist: curves and finals carry the standard error
over each evaluation's episodes (``trainer.curves.mean_curve``, named by ``stderr_over``), Table 2's
entries none (``null``, printed ``n/a``). Every JSON written here is strict JSON (``runner.report.dump_json``).
"""

from __future__ import annotations

import csv
import io
import json
import logging
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager, nullcontext
from dataclasses import asdict, dataclass, replace
from datetime import datetime, timezone
from multiprocessing.connection import Connection
from multiprocessing.connection import wait as ready_connections
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import Any

import llvmlite
import numba

from keepaway.runner.backends import Placement, open_backend
from keepaway.runner.job import (
    CHUNK_EPISODES,
    STREAM_CROSS_TEST,
    STREAM_EVALUATION,
    Backend,
    Behaviours,
    Game,
    Progress,
    derive_seed,
)
from keepaway.runner.report import dump_json, finite_or_none
from keepaway.trainer.cem import CEMConfig
from keepaway.trainer.curves import (
    CurvePoint,
    curve_summary,
    draw_curve,
    draw_references,
    mean_curve,
    ratio_of_means,
    read_curve_csv,
    stderr_basis,
    stderr_over,
    welch_p_value,
    write_atomic,
    write_curve_csv,
)
from keepaway.trainer.schedule import (
    ALGORITHM_3,
    GETOPEN,
    LEARNED,
    PASS,
    TRAINING_EPISODES,
    Phase,
    evaluation_points,
    training_schedule,
)
from keepaway.trainer.train import (
    TrainConfig,
    TrialState,
    advance_trainings,
    evaluation_job,
    hive_mind_sarsa,
    load_checkpoint,
    load_trials,
    planned_episodes,
    played_episodes,
    read_config,
    record_step,
    train,
    trial_dir,
    write_config,
    write_summary,
    write_trial_outputs,
)

log = logging.getLogger("keepaway.experiment")

POLICIES = ("random", "handcoded", LEARNED)  # the paper's R, HC, L, in its order
SHORT = {"random": "R", "handcoded": "HC", LEARNED: "L"}
SIGNIFICANCE = 0.05  # docs/players.md §8.3: Welch's t-test, p < 0.05
INTERVALS = 12  # docs/players.md §8.3: an evaluation every 2,500 of 30,000 episodes
FIXED_RECORD = "fixed.json"  # a configuration that learns nothing records itself here (a training: config.json)
TIMING = "timing.json"  # each sitting's wall and CPU time in a configuration's directory (Table 2's tests too)
# Figure 3's measured reference levels: the configurations that learn nothing at the paper's two extremes.
REFERENCES = {("handcoded", "handcoded"): "hand-coded", ("random", "random"): "random"}


def configuration_name(pass_policy: str, getopen_policy: str) -> str:
    """``P:HC-GO:L`` (docs/players.md §8.3)."""
    return f"P:{SHORT[pass_policy]}-GO:{SHORT[getopen_policy]}"


def configuration_dir(out: Path, pass_policy: str, getopen_policy: str) -> Path:
    """The configuration's directory: its name without colons (``P_HC-GO_L``), which some file systems refuse."""
    return out / configuration_name(pass_policy, getopen_policy).replace(":", "_")


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


def experiment_game() -> Game:
    """The game every configuration plays: :class:`TrainConfig`'s default (3v2 on 20 m x 20 m, classic
    parameters), which the experiments do not change."""
    return TrainConfig().game()


def experiment_backend(exp: ExperimentConfig, where: Path, placement: Placement) -> Backend:
    """A backend of the experiment's mode for :func:`experiment_game`, for the evaluations that are not
    a training's (arenas of processes started here log under ``where/arenas``)."""
    return open_backend(exp.mode, experiment_game(), TrainConfig().parameter_set, exp.arenas, where / "arenas",
                        placement, exp.chunk_episodes)


def with_modes(record: dict[str, Any]) -> dict[str, Any]:
    """A stored record as it reads since experiments run on every backend: one written before played in
    the batched mode."""
    return {"mode": "batched", **record}


def stored_settings(settings: dict[str, Any]) -> dict[str, Any]:
    """Stored experiment settings (``asdict(ExperimentConfig)``) as they read today: written before an
    option existed, with it off."""
    return {"pass_hive_mind": False, **with_modes(settings)}


def cpu_seconds() -> float:
    """User + system CPU time of this process and of its children that have ended (the distributed and
    Ray backends' players and servers are children, the batched backend's threads this process)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


@dataclass(frozen=True)
class Timing:
    """Wall-clock and CPU seconds spent on a piece of an experiment over all its sittings (a sitting: one
    run of the command that did some of its work; an interrupted one counts what it did)."""

    wall_s: float = 0.0
    cpu_s: float = 0.0
    sittings: int = 0

    @classmethod
    def read(cls, where: Path) -> Timing:
        sittings = (_read_json(where / TIMING) or {"sittings": []})["sittings"]
        return cls(sum(s["wall_s"] for s in sittings), sum(s["cpu_s"] for s in sittings), len(sittings))

    def text(self) -> str:
        return f"{self.wall_s:.0f} s wall, {self.cpu_s:.0f} s CPU over {self.sittings} sitting(s)"


TIMING_REFRESH_S = 30.0  # how often a sitting under way rewrites its record: what a SIGKILL can lose


@contextmanager
def timed_sitting(where: Path, refresh_s: float = TIMING_REFRESH_S) -> Iterator[None]:
    """Record this sitting's wall and CPU seconds in ``where/timing.json``: when the work inside ends, also
    when it is interrupted or fails, and every ``refresh_s`` while it runs (a sitting killed by SIGKILL or
    the machine's end then keeps what it did up to its last refresh, marked ``"running": true``). A study
    resumed across sittings still knows what it cost."""
    wall, cpu = time.perf_counter(), cpu_seconds()
    where.mkdir(parents=True, exist_ok=True)
    record = _read_json(where / TIMING) or {"sittings": []}
    record["sittings"].append({})
    lock, done = threading.Lock(), threading.Event()
    ended = False  # the final record is written: a refresh still under way must not replace it

    def write(running: bool) -> None:
        nonlocal ended
        with lock:
            if ended:
                return
            record["sittings"][-1] = {"ended": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                                      "wall_s": round(time.perf_counter() - wall, 3),
                                      "cpu_s": round(cpu_seconds() - cpu, 3), **({"running": True} if running else {})}
            write_atomic(where / TIMING, json.dumps(record, indent=1).encode())
            ended = not running

    def refresh() -> None:
        while not done.wait(refresh_s):
            write(running=True)

    try:  # from the first write on: an interruption right after it still ends the sitting's record
        write(running=True)
        # An interruption inside start() can leave the thread neither unstarted nor joinable (join raises
        # RuntimeError between its ident and its start flag): the end below does not wait for it.
        threading.Thread(target=refresh, name="timing", daemon=True).start()
        yield
    finally:
        done.set()
        write(running=False)


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


def _read_json(path: Path) -> Any:
    return json.loads(path.read_text()) if path.is_file() else None


def _trial_curves(summary: dict[str, Any]) -> list[list[CurvePoint]]:
    return [[CurvePoint(**p) for p in t["curve"]] for t in summary["trials"]]


def _finished(summary: dict[str, Any] | None, trials: int) -> bool:
    return summary is not None and len(summary["trials"]) == trials and all(t["finished"] for t in summary["trials"])


def run_configuration(exp: ExperimentConfig, pass_policy: str, getopen_policy: str, out: Path,
                      placement: Placement = Placement(), progress: bool = True) -> ConfigurationRun:
    """Train (or evaluate) one configuration in its directory of ``out``, its arenas placed by
    ``placement``, skipping it when finished and continuing it when not; ValueError if the directory holds
    a different configuration."""
    where = configuration_dir(out, pass_policy, getopen_policy)
    name = configuration_name(pass_policy, getopen_policy)
    if LEARNED not in (pass_policy, getopen_policy):
        run = _run_fixed(exp, pass_policy, getopen_policy, where, placement, progress)
        return replace(run, timing=Timing.read(where))
    config, started, summary = _training(exp, pass_policy, getopen_policy, where)
    skipped = _finished(summary, config.trials)
    if not skipped:
        with timed_sitting(where):
            summary = train(config, where, resume=started, progress=progress, placement=placement)
    return ConfigurationRun(name, pass_policy, getopen_policy, _trial_curves(summary), skipped,
                            config.eval_episodes, Timing.read(where))


def _training(exp: ExperimentConfig, pass_policy: str, getopen_policy: str,
              where: Path) -> tuple[TrainConfig, bool, dict[str, Any] | None]:
    """A learning configuration's training, whether ``where`` holds it begun, and its summary if any;
    ValueError if ``where`` holds a different one."""
    config = exp.train_config(pass_policy, getopen_policy)
    started = (where / "config.json").is_file()
    if started and read_config(where) != config:
        raise ValueError(f"{where} holds a different training of {configuration_name(pass_policy, getopen_policy)}; "
                         f"use another --out or the same settings")
    return config, started, _read_json(where / "summary.json") if started else None


def _run_fixed(exp: ExperimentConfig, pass_policy: str, getopen_policy: str, where: Path, placement: Placement,
               progress: bool) -> ConfigurationRun:
    """A configuration that learns nothing: its policies evaluated at every evaluation point of the
    trainings, with the seeds a training of its seed would evaluate with; a trial's ``curve.csv`` grows
    point by point, so a killed run continues where it stopped."""
    record = exp.fixed_record(pass_policy, getopen_policy)
    name = record["name"]
    where.mkdir(parents=True, exist_ok=True)
    stored = _read_json(where / FIXED_RECORD)
    if stored is not None and with_modes(stored) != record:
        raise ValueError(f"{where} holds a different evaluation of {name}; use another --out or the same settings")
    write_atomic(where / FIXED_RECORD, json.dumps(record, indent=1).encode())
    points = record["points"]
    curves = []
    for trial in range(exp.trials):
        path = trial_dir(where, trial) / "curve.csv"
        curves.append(read_curve_csv(path) if path.is_file() else [])
    skipped = all(len(c) == len(points) for c in curves)
    if not skipped:
        with timed_sitting(where):
            _evaluate_fixed(exp, Behaviours(pass_policy, getopen_policy), where, record["seed"], curves,
                            experiment_backend(exp, where, placement), progress)
    trials = [{"trial": t, "episodes": exp.episodes, "finished": True, "curve": [asdict(p) for p in c]}
              for t, c in enumerate(curves)]
    write_atomic(where / "summary.json", dump_json(
        {"name": name, "config": record, "trials": trials, **curve_summary(curves)}, indent=1).encode())
    return ConfigurationRun(name, pass_policy, getopen_policy, curves, skipped, exp.eval_episodes)


def _evaluate_fixed(exp: ExperimentConfig, behaviours: Behaviours, where: Path, seed: int,
                    curves: list[list[CurvePoint]], backend: Backend, progress: bool) -> None:
    """The evaluations of ``behaviours`` that ``curves`` lack (:func:`_run_fixed`) on ``backend``, which is
    closed after: point by point, the trials' evaluations of a point side by side (``Backend.play_all``),
    each written to its trial's ``curve.csv`` as the point is measured."""
    from tqdm import tqdm

    points = exp.points()
    try:
        with tqdm(total=exp.trials * len(points) * exp.eval_episodes, unit="ep", dynamic_ncols=True,
                  desc=configuration_name(behaviours.pass_policy, behaviours.getopen_policy),
                  initial=sum(len(c) for c in curves) * exp.eval_episodes, disable=not progress) as bar:
            for trial in range(len(curves)):
                trial_dir(where, trial).mkdir(exist_ok=True)
            for at, episodes in enumerate(points):
                trials = [trial for trial, curve in enumerate(curves) if len(curve) == at]
                if not trials:
                    continue
                jobs = [evaluation_job(behaviours, derive_seed(seed, trial, STREAM_EVALUATION, episodes),
                                       exp.eval_episodes) for trial in trials]
                for trial, played in zip(trials, backend.play_all(jobs, bar.update)):
                    summary = played.result.summary()
                    curves[trial].append(CurvePoint(episodes, summary["mean_hold_time_s"],
                                                    summary["stderr_hold_time_s"]))
                    write_curve_csv(trial_dir(where, trial) / "curve.csv", curves[trial])
    finally:
        backend.close()


# -- Figure 3 ----------------------------------------------------------------------------------------
CONFIGURATIONS = tuple((p, g) for p in POLICIES for g in POLICIES)  # Figure 3's order: P:R-GO:R, P:R-GO:HC, ...


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


def figure3(exp: ExperimentConfig, out: Path, placement: Placement = Placement(), progress: bool = True,
            on_configuration: Callable[[ConfigurationRun], None] | None = None,
            only: Sequence[tuple[str, str]] | None = None, workers: int = 1,
            together: bool = False) -> list[ConfigurationRun]:
    """Run the nine configurations in ``out`` (each skipped when finished), then write ``figure3.png``
    (:func:`plot_figure3`), ``figure3.csv`` and ``figure3.json`` (final evaluations); returns the runs
    in the order P:R-GO:R, P:R-GO:HC, ..., P:L-GO:L. With ``only`` (pairs from :func:`parse_configurations`)
    just those configurations run and nothing experiment-wide is written: processes or machines sharing
    ``out`` can each take some, and a last run without ``only`` finds them all finished and draws the figure.
    With ``workers`` > 1 the configurations run in that many worker processes at once
    (:func:`run_in_workers`), with ``together`` the learning ones side by side in this process
    (:func:`train_together`); the results are the same."""
    exp.check()
    out.mkdir(parents=True, exist_ok=True)
    runs = run_configurations(exp, CONFIGURATIONS if only is None else only, out, placement, progress,
                              on_configuration, workers, together)
    if only is None:
        plot_figure3(out / "figure3.png", runs)
        write_final_evaluations(out, exp, runs)
    return runs


def run_configurations(exp: ExperimentConfig, configurations: Sequence[tuple[str, str]], out: Path,
                       placement: Placement, progress: bool,
                       on_configuration: Callable[[ConfigurationRun], None] | None,
                       workers: int, together: bool = False) -> list[ConfigurationRun]:
    """:func:`run_configuration` of each of ``configurations``, one after another, in ``workers``
    processes at once (:func:`run_in_workers`; no progress bars there) or, ``together``, the learning
    ones side by side in this process (:func:`train_together`) and then the others; each reported to
    ``on_configuration`` as it ends; the runs in the order of ``configurations``."""
    report = on_configuration or (lambda run: None)
    if workers > 1 and together:
        raise ValueError("choose worker processes or configurations trained together, not both")
    if workers > 1:
        done = run_in_workers(exp, configurations, out, placement, workers, report)
        return [done[config] for config in configurations]
    done = train_together(exp, [c for c in configurations if LEARNED in c], out, placement, progress,
                          report) if together else {}
    for pass_policy, getopen_policy in configurations:
        if (pass_policy, getopen_policy) not in done:
            done[pass_policy, getopen_policy] = run_configuration(exp, pass_policy, getopen_policy, out, placement,
                                                                  progress)
            report(done[pass_policy, getopen_policy])
    return [done[config] for config in configurations]


TOGETHER = "together"  # the directory of the sittings of configurations trained together (its timing.json)


def train_together(exp: ExperimentConfig, configurations: Sequence[tuple[str, str]], out: Path,
                   placement: Placement, progress: bool,
                   on_configuration: Callable[[ConfigurationRun], None]) -> dict[tuple[str, str], ConfigurationRun]:
    """Train the learning ``configurations`` side by side on one backend: a round is one step of every
    unfinished trial of every configuration (``trainer.train.advance_trainings``), so the batched
    backend plays their jobs in shared batches of arenas of different policies. Each configuration's
    directory, checkpoints and outputs are those of :func:`run_configuration`, and so are its results
    (its trials play as they would alone); each is reported as its last trial ends. The sittings' wall
    and CPU time are recorded for the configurations together, in ``out/together/timing.json``;
    configurations of different games (``--pass-hive-mind`` gives the Pass learners theirs) train in
    groups, one group after another."""
    from tqdm import tqdm

    runs: dict[tuple[str, str], ConfigurationRun] = {}
    training: dict[tuple[str, str], tuple[TrainConfig, Path, list[TrialState]]] = {}
    for pass_policy, getopen_policy in configurations:
        where = configuration_dir(out, pass_policy, getopen_policy)
        config, started, summary = _training(exp, pass_policy, getopen_policy, where)
        if _finished(summary, config.trials):
            runs[pass_policy, getopen_policy] = ConfigurationRun(
                configuration_name(pass_policy, getopen_policy), pass_policy, getopen_policy,
                _trial_curves(summary), True, config.eval_episodes, Timing.read(where))
            on_configuration(runs[pass_policy, getopen_policy])
            continue
        if not started:
            write_config(config, where)
        training[pass_policy, getopen_policy] = (config, where, load_trials(config, where))
    if not training:
        return runs

    def finish(pair: tuple[str, str]) -> None:
        config, where, states = training.pop(pair)
        for state in states:
            write_trial_outputs(config, where, state)
        summary = write_summary(config, where, states)
        runs[pair] = ConfigurationRun(configuration_name(*pair), *pair, _trial_curves(summary), False,
                                      config.eval_episodes, Timing.read(where))
        on_configuration(runs[pair])

    groups: dict[Any, list[tuple[str, str]]] = {}
    for pair, (config, _, _) in training.items():
        groups.setdefault(config.game(), []).append(pair)
    with timed_sitting(out / TOGETHER), tqdm(
            total=sum(planned_episodes(c) * c.trials for c, _, _ in training.values()), unit="ep",
            dynamic_ncols=True, desc=f"{len(training)} configurations together", disable=not progress,
            initial=sum(played_episodes(c, s) for c, _, states in training.values() for s in states)) as bar:
        for game, pairs in groups.items():
            backend = open_backend(exp.mode, game, TrainConfig().parameter_set, exp.arenas, out / TOGETHER / "arenas",
                                   placement, exp.chunk_episodes)
            try:
                while running := [(pair, state) for pair in pairs if pair in training
                                  for state in training[pair][2] if not state.finished(training[pair][0])]:
                    start = time.perf_counter()
                    advance_trainings([(training[pair][0], state) for pair, state in running], backend, bar.update)
                    share = (time.perf_counter() - start) / len(running)
                    for pair, state in running:
                        record_step(training[pair][0], training[pair][1], state, share)
                    for pair in dict.fromkeys(pair for pair, _ in running):
                        config, _, states = training[pair]
                        if all(state.finished(config) for state in states):
                            finish(pair)
            finally:
                backend.close()
    return runs


# The configurations from the longest to the shortest to train, as measured in a run of Figure 3 at 20
# trials: workers that take them in this order finish at about the same time.
LONGEST_FIRST = ((LEARNED, "handcoded"), ("handcoded", LEARNED), (LEARNED, LEARNED), (LEARNED, "random"),
                 ("random", LEARNED), ("handcoded", "handcoded"), ("random", "handcoded"), ("handcoded", "random"),
                 ("random", "random"))


def run_in_workers(exp: ExperimentConfig, configurations: Sequence[tuple[str, str]], out: Path,
                   placement: Placement, workers: int,
                   on_configuration: Callable[[ConfigurationRun], None]) -> dict[tuple[str, str], ConfigurationRun]:
    """Run ``configurations`` (:func:`run_configuration`) in up to ``workers`` processes at once, each on
    one thread unless ``placement`` names the threads, the longest first (:data:`LONGEST_FIRST`), and
    report each as it ends. A process per core beats one process stepping arenas on every core (Python's
    share of the work runs in parallel too), and the order keeps every core busy to the end; every
    configuration's results depend only on the seed, so they are the same as one after another.

    Workers are spawned (numba's threads do not survive a fork). A worker's error is raised here after
    the others have been interrupted (SIGINT: they keep their checkpoints, as Ctrl-C does); so is an
    interruption of this process. An interrupted worker that ends otherwise than interrupted (its own
    error, or no result: killed, crashed) is named in a warning, with its exit code, since its last
    checkpoint or timing record may then be missing."""
    if placement.attach or placement.launcher is not None:
        raise ValueError("worker processes start their own arenas: not with --arena or --backend ray")
    placement = replace(placement, threads=placement.threads or 1)
    waiting = sorted(configurations, key=LONGEST_FIRST.index)
    context = multiprocessing.get_context("spawn")
    # a worker's end of its pipe -> (the worker, its configuration)
    running: dict[Connection, tuple[BaseProcess, tuple[str, str]]] = {}
    done: dict[tuple[str, str], ConfigurationRun] = {}
    try:
        while waiting or running:
            while waiting and len(running) < workers:
                config = waiting.pop(0)
                receive, send = context.Pipe(duplex=False)
                process = context.Process(target=_configuration_worker, args=(send, exp, config, out, placement),
                                          name=configuration_name(*config))
                process.start()
                send.close()
                running[receive] = (process, config)
            for receive in ready_connections(list(running)):
                process, config = running.pop(receive)
                try:
                    outcome = receive.recv()
                except EOFError:  # it died without a word (killed, out of memory)
                    process.join()
                    outcome = RuntimeError(f"the worker process of {configuration_name(*config)} ended with exit "
                                           f"code {process.exitcode} and no result")
                process.join()
                if isinstance(outcome, BaseException):
                    raise outcome
                done[config] = outcome
                on_configuration(outcome)
    finally:
        for process, _ in running.values():
            if process.is_alive():
                os.kill(process.pid, signal.SIGINT)
        for receive, (process, config) in running.items():
            _join_interrupted(receive, process, config)
    return done


def _join_interrupted(receive: Connection, process: BaseProcess, config: tuple[str, str]) -> None:
    """Wait for a worker of :func:`run_in_workers` that was told to stop (its result read first, so a
    worker never waits on a full pipe), and warn if it did not end as interrupted or finished. A worker
    that SIGINT ended before it set its handler (exit code -SIGINT, no result) had not begun its work."""
    try:
        outcome: Any = receive.recv()
    except EOFError:
        outcome = None
    process.join()
    if (outcome is None and process.exitcode != -signal.SIGINT) or (
            isinstance(outcome, BaseException) and not isinstance(outcome, KeyboardInterrupt)):
        ending = "no result" if outcome is None else f"{type(outcome).__name__}: {outcome}"
        log.warning("keepaway experiment: the interrupted worker of %s ended with exit code %s and %s",
                    configuration_name(*config), process.exitcode, ending)


def _configuration_worker(send: Connection, exp: ExperimentConfig, config: tuple[str, str], out: Path,
                          placement: Placement) -> None:
    """A worker process of :func:`run_in_workers`: one configuration, its run or its exception sent back.
    The first SIGINT or SIGTERM interrupts it (Ctrl-C reaches it from the terminal and from the parent);
    later ones are ignored, so it still writes its checkpoint and timing.

    tqdm's bars (hidden here) share a lock across processes by default, a semaphore that an interruption
    can leave to multiprocessing's resource tracker, which then warns after our last line; a worker
    draws nothing, so a thread lock does.

    A parent that dies without interrupting it (killed, out of memory) sends it SIGTERM through Linux's
    parent-death signal, so no worker goes on training alone (a CI run left two doing so for minutes)."""
    from tqdm import tqdm

    from keepaway.runner.launch import die_with_parent

    tqdm.set_lock(threading.RLock())
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _interrupt_once)
    die_with_parent()
    parent = multiprocessing.parent_process()
    try:
        if parent is not None and os.getppid() != parent.pid:  # the parent died before the request
            raise KeyboardInterrupt
        outcome: Any = run_configuration(exp, *config, out, placement, progress=False)
    except BaseException as exc:  # noqa: BLE001 - every ending, Ctrl-C included, is reported to the parent
        outcome = exc
    send.send(outcome)
    send.close()


def _interrupt_once(signum: int, frame: Any) -> None:
    if _in_unsafe_code(frame):  # raised there, it would be dropped or break numba: deliver it again soon
        threading.Timer(0.05, os.kill, (os.getpid(), signum)).start()
        return
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    raise KeyboardInterrupt


# numba's and llvmlite's code (their package directories)
_NUMBA_CODE = tuple(os.path.dirname(module.__file__) + os.sep for module in (numba, llvmlite))


def _in_unsafe_code(frame: Any) -> bool:
    """Whether ``frame`` runs where an interrupt must not be raised:
    - inside numba or llvmlite, which a worker's first calls of its kernels go through (loading them
      from the cache; numba's own registries on its first load). Interrupted there, numba keeps half-made
      state: a later kernel call failed with "duplicate registration" in a test, and in a CI run a
      worker died of SIGSEGV at its next kernel's first call and never wrote its timing. This also
      covers llvmlite's object-cache hooks, ctypes callbacks that print an exception raised in them and
      go on;
    - in any finalizer (``__del__``; Python prints "Exception ignored in" and goes on: a CI run lost a
      worker's interrupt in llvmlite's ``ObjectRef.__del__``, and the worker trained on).
    The worker's kernels are compiled before it starts (``prepare_kernels``), so loading them is a
    matter of seconds, and so is the interrupt's delay."""
    while frame is not None:
        code = frame.f_code
        if code.co_name == "__del__" or code.co_filename.startswith(_NUMBA_CODE):
            return True
        frame = frame.f_back
    return False


def plot_figure3(path: Path, runs: Sequence[ConfigurationRun]) -> None:
    """The paper's two-column layout as one PNG, written atomically: left, one panel per Pass policy with
    its three GetOpen curves; right, one panel per GetOpen policy with its three Pass curves. All panels
    share the axes, so heights compare across them, and every panel marks the :func:`reference_levels`
    (labelled once, below the panels)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11.0, 10.0), dpi=100, layout="constrained")
    axes = fig.subplots(len(POLICIES), 2, sharex=True, sharey=True)
    bases = sorted({r.stderr_basis() for r in runs})
    fig.suptitle(f"Keepaway 3v2: mean hold time (band: {'; '.join(bases)})")
    references = reference_levels(runs)
    for row, policy in enumerate(POLICIES):
        for column, (panel, grouped_by, other) in enumerate((("Pass", "pass_policy", "GO"),
                                                            ("GetOpen", "getopen_policy", "P"))):
            ax = axes[row, column]
            for run in runs:
                if getattr(run, grouped_by) == policy:
                    counterpart = run.getopen_policy if grouped_by == "pass_policy" else run.pass_policy
                    draw_curve(ax, f"{other}:{SHORT[counterpart]}", run.mean_curve())
            ax.set_title(f"{panel}: {SHORT[policy]}")
            ax.grid(True, alpha=0.3)
            ax.legend(loc="best", fontsize="small")
            draw_references(ax, references)  # after the panel's legend: the figure's legend names them once
            if row == len(POLICIES) - 1:
                ax.set_xlabel("training episodes")
            if column == 0:
                ax.set_ylabel("mean hold time (s)")
    if references:
        handles, labels = axes[0, 0].get_legend_handles_labels()
        fig.legend(handles[-len(references):], labels[-len(references):], loc="outside lower center",
                   ncols=len(references))
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    write_atomic(path, buffer.getvalue())


def reference_levels(runs: Sequence[ConfigurationRun]) -> dict[str, float]:
    """The levels of the hand-coded (P:HC-GO:HC) and random (P:R-GO:R) keepers (:data:`REFERENCES`) among
    ``runs``, by label, from their measured curves (:meth:`ConfigurationRun.reference_level`)."""
    measured = {(r.pass_policy, r.getopen_policy): r for r in runs}
    return {f"{configuration_name(*config)} ({label})": measured[config].reference_level()
            for config, label in REFERENCES.items() if config in measured}


FINAL_HEADER = ("name", "pass", "getopen", "trials", "episodes", "final_mean_hold_time_s", "final_stderr_hold_time_s",
                "stderr_over")


# Figure 3's table: its columns as shares of the training (at 30,000 episodes: 0, 2,500, 5,000, 10,000,
# 20,000 and 30,000), each the nearest evaluation point.
TABLE_FRACTIONS = (0.0, 1 / 12, 1 / 6, 1 / 3, 2 / 3, 1.0)
LABELS = {("handcoded", "handcoded"): "hand-coded pair", ("random", "random"): "random pair",
          ("handcoded", LEARNED): "CEM GetOpen, hand-coded Pass", ("random", LEARNED): "CEM GetOpen, random Pass",
          (LEARNED, "handcoded"): "Sarsa Pass, hand-coded GetOpen", (LEARNED, "random"): "Sarsa Pass, random GetOpen",
          (LEARNED, LEARNED): "Algorithm 3"}


def table_columns(episodes: Sequence[int]) -> list[int]:
    """The evaluation points (``episodes``, ascending) nearest to :data:`TABLE_FRACTIONS` of the last."""
    return sorted({min(episodes, key=lambda e: abs(e - f * episodes[-1])) for f in TABLE_FRACTIONS})


def format_estimate(value: float, se: float | None) -> str:
    se = finite_or_none(se)
    return f"{value:.2f}" if se is None else f"{value:.2f} +- {se:.2f}"


def ratio_text(a: Sequence[float], b: Sequence[float]) -> str:
    """mean(a) / mean(b) with its delta-method standard error over the two independent samples' means
    (``trainer.curves.ratio_of_means``) and Welch's p (each only with two or more values per sample)."""
    ratio, se = ratio_of_means(a, b)
    if se is None:
        return f"{ratio:.2f}"
    p = welch_p_value(a, b)
    return f"{ratio:.2f} +- {se:.2f}" + ("" if p is None else f" (p = {p:.2g})")


def figure3_markdown(runs: Sequence[ConfigurationRun]) -> str:
    """Figure 3 as a table (``figure3.md``): a row per configuration, the two reference pairs first; its
    trials, the mean curve +- its standard error at :func:`table_columns`, the last in bold, and the final
    evaluation beside the hand-coded pair's (:func:`ratio_text` over the trials' finals)."""
    first = [run for config in REFERENCES for run in runs if (run.pass_policy, run.getopen_policy) == config]
    ordered = first + [run for run in runs if run not in first]
    columns = table_columns([p.episodes for p in ordered[0].mean_curve()])
    hand = next((run for run in runs if (run.pass_policy, run.getopen_policy) == ("handcoded", "handcoded")), None)
    lines = ["| configuration | trials | " + " | ".join(f"{e:,}" for e in columns)
             + f" episodes | / P:HC-GO:HC at {columns[-1]:,} (Welch p) |", "|---" * (len(columns) + 3) + "|"]
    for run in ordered:
        curve = {p.episodes: p for p in run.mean_curve()}
        cells = [format_estimate(curve[e].mean_hold_time_s, curve[e].stderr_hold_time_s) for e in columns]
        cells[-1] = f"**{cells[-1]}**"
        finals = [trial[-1].mean_hold_time_s for trial in run.curves]
        versus = "-" if hand is None else "1" if run is hand else ratio_text(
            finals, [trial[-1].mean_hold_time_s for trial in hand.curves])
        label = LABELS.get((run.pass_policy, run.getopen_policy))
        name = f"{run.name} ({label})" if label else run.name
        lines.append(f"| {name} | {len(run.curves)} | {' | '.join(cells)} | {versus} |")
    return "\n".join(lines) + "\n"


def write_final_evaluations(out: Path, exp: ExperimentConfig, runs: Sequence[ConfigurationRun]) -> None:
    """``figure3.csv`` (one row per configuration: its last evaluation, mean over trials and standard
    error, and what that is over; an undefined one is an empty field), ``figure3.json`` (the same with
    the experiment's settings and every mean curve; ``null`` where undefined) and ``figure3.md``
    (:func:`figure3_markdown`)."""
    rows = []
    for run in runs:
        final = run.final()
        rows.append({"name": run.name, "pass": SHORT[run.pass_policy], "getopen": SHORT[run.getopen_policy],
                     "trials": len(run.curves), "episodes": final.episodes,
                     "final_mean_hold_time_s": final.mean_hold_time_s,
                     "final_stderr_hold_time_s": final.stderr_hold_time_s,
                     "stderr_over": stderr_over(len(run.curves))})
    text = io.StringIO()
    writer = csv.DictWriter(text, FINAL_HEADER, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(out / "figure3.csv", text.getvalue().encode())
    configurations = [{**row, "timing": asdict(run.timing), "curve": [asdict(p) for p in run.mean_curve()]}
                      for row, run in zip(rows, runs)]
    # the sums over the configurations (processes sharing the work with --only overlap in time) and the
    # most sittings any configuration took
    total = Timing(sum(r.timing.wall_s for r in runs), sum(r.timing.cpu_s for r in runs),
                   max((r.timing.sittings for r in runs), default=0))
    write_atomic(out / "figure3.json", dump_json({"experiment": asdict(exp), "timing": asdict(total),
                                                  "configurations": configurations}, indent=1).encode())
    write_atomic(out / "figure3.md", figure3_markdown(runs).encode())


# -- Table 2 -----------------------------------------------------------------------------------------
STUDIES = (PASS, GETOPEN)  # the learned behaviour under test


def trained_configuration(study: str, counterpart: str) -> tuple[str, str]:
    """(Pass, GetOpen) of the configuration in which ``study`` learned with ``counterpart``."""
    return (LEARNED, counterpart) if study == PASS else (counterpart, LEARNED)


def with_counterpart(trained: Behaviours, study: str, counterpart: str, partner: Behaviours) -> Behaviours:
    """``trained``'s learned ``study`` behaviour played with the other behaviour ``counterpart``; a learned
    counterpart is ``partner``'s (the same trial of P:L-GO:L)."""
    if study == PASS:
        learned = counterpart == LEARNED
        return replace(trained, getopen_policy=counterpart, getopen_theta=partner.getopen_theta if learned else None,
                       getopen_inputs=partner.getopen_inputs if learned else None)
    return replace(trained, pass_policy=counterpart,
                   pass_arrays=partner.pass_arrays if counterpart == LEARNED else None)


def _behaviours(out: Path, pass_policy: str, getopen_policy: str, trial: int) -> Behaviours:
    state = load_checkpoint(configuration_dir(out, pass_policy, getopen_policy), trial)
    if state is None:
        raise ValueError(f"{configuration_name(pass_policy, getopen_policy)} has no trial {trial} in {out}")
    return state.behaviours


def cross_test_trial(exp: ExperimentConfig, out: Path, trial: int, backend: Backend,
                     progress: Progress | None = None) -> dict[str, list[list[float]]]:
    """Trial ``trial``'s mean hold times of Table 2 on ``backend``: for each study, [trained with X][tested
    with Y]. Every test plays the same arena seeds (common random numbers); the 18 tests play side by side
    (``Backend.play_all``), each as it would alone."""
    partner = _behaviours(out, LEARNED, LEARNED, trial)
    seed = derive_seed(exp.seed, trial, STREAM_CROSS_TEST)
    cells = [(study, trained_with, tested_with) for study in STUDIES for trained_with in POLICIES
             for tested_with in POLICIES]
    trained = {(study, with_): _behaviours(out, *trained_configuration(study, with_), trial)
               for study in STUDIES for with_ in POLICIES}
    played = backend.play_all([evaluation_job(with_counterpart(trained[study, trained_with], study, tested_with,
                                                               partner), seed, exp.eval_episodes)
                               for study, trained_with, tested_with in cells], progress)
    means = iter(p.result.summary()["mean_hold_time_s"] for p in played)
    return {study: [[next(means) for _ in POLICIES] for _ in POLICIES] for study in STUDIES}


@dataclass(frozen=True)
class Cell:
    """One entry of Table 2: the trials' mean hold times, whether it is its column's best, and the p-value
    of Welch's test against that best (None for the best itself and where the test is undefined)."""

    values: tuple[float, ...]
    best: bool
    p_value: float | None

    @property
    def mean(self) -> float:
        return self._over_trials().mean_hold_time_s

    @property
    def stderr(self) -> float | None:
        """Over trials; None with one trial (a cross-test keeps only each trial's mean)."""
        return self._over_trials().stderr_hold_time_s

    def _over_trials(self) -> CurvePoint:
        """Mean and standard error over trials, the statistic of a learning curve's point (trainer.curves)."""
        return mean_curve([[CurvePoint(0, v, None)] for v in self.values])[0]

    @property
    def significant(self) -> bool:
        """Differs from the column's best at p < 0.05."""
        return self.p_value is not None and self.p_value < SIGNIFICANCE

    def text(self) -> str:
        se = "n/a" if self.stderr is None else f"{self.stderr:.2f}"
        entry = f"{self.mean:.2f} +- {se}{'*' if self.significant else ''}"
        return f"**{entry}**" if self.best else entry


def table_cells(values: Sequence[Sequence[Sequence[float]]]) -> list[list[Cell]]:
    """Cells of a table from its values [row][column][trial]: each column's best is the highest mean,
    every entry tested against it."""
    rows, columns = len(values), len(values[0])
    cells: list[list[Cell | None]] = [[None] * columns for _ in range(rows)]
    for c in range(columns):
        column = [values[r][c] for r in range(rows)]
        best = max(range(rows), key=lambda r: sum(column[r]) / len(column[r]))
        for r in range(rows):
            p = None if r == best else welch_p_value(column[r], column[best])
            cells[r][c] = Cell(tuple(column[r]), r == best, p)
    return cells  # type: ignore[return-value]


@dataclass(frozen=True)
class CrossTable:
    """Table 2's half for one study: the policy learned with counterpart X (row) tested with Y (column)."""

    study: str
    cells: list[list[Cell]]

    @property
    def counterpart_prefix(self) -> str:
        return "GO" if self.study == PASS else "P"

    def best_on_diagonal(self) -> list[bool]:
        """Per column: is its best the policy trained with that very counterpart (the paper's expectation)?"""
        return [self.cells[c][c].best for c in range(len(POLICIES))]

    def markdown(self) -> str:
        learned = "Pass" if self.study == PASS else "GetOpen"
        other = "GetOpen" if self.study == PASS else "Pass"
        prefix = self.counterpart_prefix
        trials = len(self.cells[0][0].values)
        lines = [f"### {learned} learned with {other} X (rows), tested with {other} Y (columns)", "",
                 f"Mean hold time (s) +- standard error over {trials} trial{'s' if trials > 1 else ''}"
                 f"{' (n/a: one trial has none, and no test)' if trials == 1 else ''}; bold: the column's best; "
                 f"`*`: differs from it (Welch's t-test, p < {SIGNIFICANCE}).", "",
                 f"| {learned} trained with | " + " | ".join(f"tested with {prefix}:{SHORT[p]}" for p in POLICIES)
                 + " |",
                 "|---|" + "---:|" * len(POLICIES)]
        for policy, row in zip(POLICIES, self.cells):
            lines.append(f"| {prefix}:{SHORT[policy]} | " + " | ".join(cell.text() for cell in row) + " |")
        return "\n".join(lines) + "\n"

    def to_dict(self) -> dict[str, Any]:
        return {"study": self.study, "rows": [f"{self.counterpart_prefix}:{SHORT[p]}" for p in POLICIES],
                "columns": [f"{self.counterpart_prefix}:{SHORT[p]}" for p in POLICIES],
                "best_on_diagonal": self.best_on_diagonal(),
                "cells": [[{"mean_hold_time_s": c.mean, "stderr_hold_time_s": c.stderr, "trials": len(c.values),
                            "best": c.best, "p_value": c.p_value, "significant": c.significant,
                            "values": list(c.values)} for c in row] for row in self.cells]}


def table2(exp: ExperimentConfig, out: Path, placement: Placement = Placement(), progress: bool = True,
           on_configuration: Callable[[ConfigurationRun], None] | None = None, workers: int = 1,
           together: bool = False) -> list[CrossTable]:
    """Train the five configurations Table 2 needs (as :func:`figure3` would, in the same directories, in
    ``workers`` processes or ``together``), cross-test every trial's learned policies (cached per trial in
    ``table2_tests/``, so a re-run only plays what is missing), and write ``table2.json`` and
    ``table2.md``; returns the Pass and GetOpen tables."""
    from tqdm import tqdm

    exp.check()
    out.mkdir(parents=True, exist_ok=True)
    needed = {trained_configuration(s, p) for s in STUDIES for p in POLICIES}
    run_configurations(exp, [c for c in CONFIGURATIONS if c in needed], out, placement, progress, on_configuration,
                       workers, together)
    tests = out / "table2_tests"
    tests.mkdir(exist_ok=True)
    settings = asdict(exp)
    per_trial = []
    cells_per_trial = len(STUDIES) * len(POLICIES) ** 2
    backend: Backend | None = None  # opened when a trial's tests are missing
    cached = [_read_json(tests / f"trial_{trial:03d}.json") for trial in range(exp.trials)]
    cached = [c if c is not None and stored_settings(c["experiment"]) == settings else None for c in cached]
    try:
        with timed_sitting(tests) if None in cached else nullcontext(), \
                tqdm(total=exp.trials * cells_per_trial * exp.eval_episodes, unit="ep", dynamic_ncols=True,
                     desc="Table 2 tests", disable=not progress) as bar:
            for trial, stored in enumerate(cached):
                if stored is None:
                    backend = backend or experiment_backend(exp, tests, placement)
                    stored = {"experiment": settings, "trial": trial,
                              "values": cross_test_trial(exp, out, trial, backend, bar.update)}
                    write_atomic(tests / f"trial_{trial:03d}.json", dump_json(stored).encode())
                else:
                    bar.update(cells_per_trial * exp.eval_episodes)
                per_trial.append(stored["values"])
    finally:
        if backend is not None:
            backend.close()
    tables = [CrossTable(study, table_cells([[[v[study][r][c] for v in per_trial] for c in range(len(POLICIES))]
                                             for r in range(len(POLICIES))]))
              for study in STUDIES]
    write_atomic(out / "table2.json", dump_json({"experiment": settings, "tests_timing": asdict(Timing.read(tests)),
                                                 "tables": [t.to_dict() for t in tables]}, indent=1).encode())
    write_atomic(out / "table2.md", "\n".join(t.markdown() for t in tables).encode())
    return tables


__all__ = [
    "CONFIGURATIONS",
    "Cell",
    "ConfigurationRun",
    "CrossTable",
    "ExperimentConfig",
    "POLICIES",
    "Timing",
    "configuration_dir",
    "configuration_name",
    "cross_test_trial",
    "default_eval_every",
    "experiment_game",
    "figure3",
    "figure3_markdown",
    "parse_configurations",
    "plot_figure3",
    "reference_levels",
    "run_configuration",
    "table2",
    "table_cells",
    "trained_configuration",
    "with_counterpart",
    "write_final_evaluations",
]

"""The paper's experiments (docs/players.md §8.3): Figure 3's nine configurations and Table 2's
specialisation cross-tests, built on :mod:`trainer.train`.

Figure 3: each configuration (``trainer.configurations``) in its own directory of the experiment's
output. A configuration that learns is a :func:`trainer.train.train` training (one learned behaviour: one
phase; both: Algorithm 3, scaled to the experiment's length); one that learns nothing is evaluated at the
same evaluation points with the same arena seeds, so its curve is flat but measured. Every directory
records its configuration; running the experiment again skips the finished configurations, continues the
unfinished ones from their checkpoints and refuses a directory that holds a different configuration. The
configurations run one after another, in worker processes (``trainer.worker_pool``) or the learning ones
together in this process; the results are the same.

Table 2: a Pass policy learned with GetOpen X (``P:L-GO:X``) is tested with GetOpen Y, and a GetOpen
policy learned with Pass X (``P:X-GO:L``) with Pass Y, for X, Y in {R, HC, L}. A learned counterpart Y is
the one learned in ``P:L-GO:L``'s trial of the same number. Table 2's tests of a trial all play the same
arena seeds (common random numbers).

The figure, the tables and their files are written by ``trainer.experiment_report``; what each part cost,
by ``trainer.timing``.
"""

from __future__ import annotations

import functools
import json
import time
from collections.abc import Callable, Sequence
from contextlib import nullcontext
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

from keepaway.runner.backends import Placement, open_backend
from keepaway.runner.job import STREAM_CROSS_TEST, STREAM_EVALUATION, Backend, Behaviours, Game, Progress, derive_seed
from keepaway.runner.report import dump_json
from keepaway.trainer.configurations import (
    CONFIGURATIONS,
    LONGEST_FIRST,
    POLICIES,
    ConfigurationRun,
    ExperimentConfig,
    configuration_dir,
    configuration_name,
)
from keepaway.trainer.curves import CurvePoint, curve_summary, read_curve_csv, read_json, write_atomic, write_curve_csv
from keepaway.trainer.experiment_report import (
    CrossTable,
    plot_figure3,
    table_cells,
    write_final_evaluations,
    write_table2,
)
from keepaway.trainer.schedule import GETOPEN, LEARNED, PASS
from keepaway.trainer.timing import Timing, timed_sitting
from keepaway.trainer.train import (
    TrainConfig,
    TrialState,
    advance_trainings,
    evaluation_job,
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
from keepaway.trainer.worker_pool import run_in_processes

FIXED_RECORD = "fixed.json"  # a configuration that learns nothing records itself here (a training: config.json)
TOGETHER = "together"  # the directory of the sittings of configurations trained together (its timing.json)


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
    return config, started, read_json(where / "summary.json") if started else None


def _run_fixed(exp: ExperimentConfig, pass_policy: str, getopen_policy: str, where: Path, placement: Placement,
               progress: bool) -> ConfigurationRun:
    """A configuration that learns nothing: its policies evaluated at every evaluation point of the
    trainings, with the seeds a training of its seed would evaluate with; a trial's ``curve.csv`` grows
    point by point, so a killed run continues where it stopped."""
    record = exp.fixed_record(pass_policy, getopen_policy)
    name = record["name"]
    where.mkdir(parents=True, exist_ok=True)
    stored = read_json(where / FIXED_RECORD)
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
def figure3(exp: ExperimentConfig, out: Path, placement: Placement = Placement(), progress: bool = True,
            on_configuration: Callable[[ConfigurationRun], None] | None = None,
            only: Sequence[tuple[str, str]] | None = None, workers: int = 1,
            together: bool = False) -> list[ConfigurationRun]:
    """Run the nine configurations in ``out`` (each skipped when finished), then write ``figure3.png``
    (:func:`plot_figure3`), ``figure3.csv`` and ``figure3.json`` (final evaluations); returns the runs
    in the order P:R-GO:R, P:R-GO:HC, ..., P:L-GO:L. With ``only`` (pairs from
    ``trainer.configurations.parse_configurations``)
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


def run_in_workers(exp: ExperimentConfig, configurations: Sequence[tuple[str, str]], out: Path,
                   placement: Placement, workers: int,
                   on_configuration: Callable[[ConfigurationRun], None]) -> dict[tuple[str, str], ConfigurationRun]:
    """Run ``configurations`` (:func:`run_configuration`) in up to ``workers`` processes at once
    (``trainer.worker_pool.run_in_processes``: an error or an interruption stops them all), each on one
    thread unless ``placement`` names the threads, the longest first (``LONGEST_FIRST``), and report each
    as it ends. A process per core beats one process stepping arenas on every core (Python's share of the
    work runs in parallel too), and the order keeps every core busy to the end; every configuration's
    results depend only on the seed, so they are the same as one after another."""
    if placement.attach or placement.launcher is not None:
        raise ValueError("worker processes start their own arenas: not with --arena or --backend ray")
    placement = replace(placement, threads=placement.threads or 1)
    tasks = [(configuration_name(*config),
              functools.partial(run_configuration, exp, *config, out, placement, progress=False))
             for config in sorted(configurations, key=LONGEST_FIRST.index)]
    done = run_in_processes(tasks, workers, on_configuration)
    return {(run.pass_policy, run.getopen_policy): run for run in done.values()}


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
    cached = [read_json(tests / f"trial_{trial:03d}.json") for trial in range(exp.trials)]
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
    write_table2(out, exp, Timing.read(tests), tables)
    return tables


__all__ = [
    "FIXED_RECORD",
    "TOGETHER",
    "cross_test_trial",
    "experiment_game",
    "figure3",
    "run_configuration",
    "run_configurations",
    "run_in_workers",
    "table2",
    "train_together",
    "trained_configuration",
    "with_counterpart",
]

"""``keepaway train`` and ``keepaway evaluate``: learning runs and frozen evaluations of their policies
(docs/players.md §8; :mod:`trainer.train`)."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import click

from keepaway.core.options import FiniteFloatRange
from keepaway.runner.cli import (
    ARENAS_HELP,
    COUNT_TYPE,
    SEED_TYPE,
    Command,
    arena_count,
    game_options,
    game_params,
    placement,
    placement_options,
    with_options,
)
from keepaway.trainer.schedule import POLICY_NAMES

if TYPE_CHECKING:
    from keepaway.runner.job import Backend, Behaviours
    from keepaway.trainer.train import TrainConfig

POLICY_CHOICES = click.Choice(POLICY_NAMES)


MIN_CURVE_POINTS = 5  # a learning curve of fewer evaluations has hardly a shape


def warn_sparse_curve(config: TrainConfig) -> None:
    """One line on stderr when ``--eval-every`` leaves the learning curve fewer than
    :data:`MIN_CURVE_POINTS` points and a smaller one would give more, naming one that does."""
    from keepaway.trainer.schedule import denser_eval_every, evaluation_points

    points = evaluation_points(config.schedule, config.eval_every)
    if len(points) >= MIN_CURVE_POINTS:
        return
    every = denser_eval_every(config.schedule, config.eval_every, config.generation_episodes, MIN_CURVE_POINTS)
    if every is None:
        return
    at = ", ".join(f"{p:,}" for p in points[:-1]) + f" and {points[-1]:,}"
    click.echo(f"keepaway train: --eval-every {config.eval_every} gives the learning curve only {len(points)} points "
               f"(at {at} episodes); --eval-every {every} gives it "
               f"{len(evaluation_points(config.schedule, every))}", err=True)


def prepare_kernels(kernel_sets: tuple[str, ...]) -> None:
    """Compile the kernel sets this command's processes use, once, saying so (``runner.kernels``)."""
    from keepaway.runner.cli import announce
    from keepaway.runner.kernels import CompileError, ensure_compiled

    try:
        ensure_compiled(kernel_sets, announce)
    except CompileError as exc:
        raise click.ClickException(str(exc)) from None
def learning_options(command: Command) -> Command:
    """Ours, beyond the paper, off by default (docs/design.md, "Learning options"): how Sarsa's step size
    and the CEM's variance change as learning goes on. ``keepaway train`` and ``keepaway experiment``."""
    options = [
        click.option("--pass-alpha-halflife", type=click.IntRange(min=0), default=0, show_default=True,
                     help="Learned Pass: Sarsa's alpha 0.125 h / (h + n) after n Pass-learning "
                          "episodes (0: constant, the paper)."),
        click.option("--pass-hive-mind", is_flag=True,
                     help="Learned Pass, batched: the keepers of an arena learn one shared Sarsa table "
                          "(tjpalmer's hive mind; the paper: one table each)."),
        click.option("--cem-extra-noise", type=FiniteFloatRange(min=0.0), default=0.0, show_default=True,
                     help="Noisy CEM: variance added to each refit (0: the paper's CEM)."),
        click.option("--cem-noise-generations", type=click.IntRange(min=0), default=0, show_default=True,
                     help="Generations over which --cem-extra-noise falls linearly to 0 (0: it stays)."),
        click.option("--cem-play", type=click.Choice(["best", "mean"]), default="best", show_default=True,
                     help="GetOpen net played after each CEM generation (evaluations, Pass phases, policy "
                          "file): the best candidate so far (the paper) or the CEM's mean."),
    ]
    return with_options(options, command)


# Options that define a training; with --resume the stored configuration is used and these must not be given.
CONFIG_OPTIONS = ("pass_policy", "getopen_policy", "episodes", "schedule", "trials", "eval_every", "eval_episodes",
                  "arenas", "seed", "population", "elite", "candidate_episodes", "keepers", "takers",
                  "field_size", "parameter_set", "getopen_inputs", "pass_alpha_halflife", "pass_hive_mind",
                  "cem_extra_noise", "cem_noise_generations", "cem_play")


@click.command("train")
@click.option("--pass", "pass_policy", type=POLICY_CHOICES, default="random", show_default=True,
              help="Keepers' Pass policy (learned: SMDP Sarsa).")
@click.option("--getopen", "getopen_policy", type=POLICY_CHOICES, default="learned", show_default=True,
              help="Keepers' GetOpen policy (learned: CEM).")
@click.option("--episodes", type=COUNT_TYPE, default=None,
              help="Training episodes [30,000; with both learned: the schedule's length].")
@click.option("--schedule", default=None, metavar="B:N,...",
              help="Phases, e.g. getopen:5000,pass:5000,getopen:15000,pass:5000 (Algorithm 3, the default "
                   "when both learn); ours: both:N learns GetOpen and Pass in the same N episodes.")
@click.option("--trials", type=COUNT_TYPE, default=1, show_default=True, help="Independent trials.")
@click.option("--eval-every", type=COUNT_TYPE, default=2500, show_default=True,
              help="Training episodes between frozen evaluations.")
@click.option("--eval-episodes", type=COUNT_TYPE, default=500, show_default=True, help="Episodes per evaluation.")
@click.option("--arenas", type=COUNT_TYPE, default=None,
              help=ARENAS_HELP)
@placement_options
@click.option("--seed", type=SEED_TYPE, default=0, show_default=True, help="Seed of the whole training.")
@click.option("--population", type=COUNT_TYPE, default=20, show_default=True, help="CEM candidates per generation.")
@click.option("--elite", type=COUNT_TYPE, default=5, show_default=True,
              help="CEM candidates refitted to (at most --population).")
@click.option("--candidate-episodes", type=COUNT_TYPE, default=125, show_default=True,
              help="Episodes per CEM candidate.")
@game_options
@click.option("--getopen-inputs", type=click.Choice(["scaled", "raw"]), default="scaled", show_default=True,
              help="GO:L net inputs: scaled by agents.getopen.GetOpenScaling, or raw metres and degrees.")
@learning_options
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("train_out"),
              show_default=True, help="Directory for curves, policies, traces and the summary.")
@click.option("--resume", type=click.Path(file_okay=False, exists=True, path_type=Path), default=None,
              help="Continue the training in this directory from its last checkpoint.")
@click.option("--no-progress", is_flag=True, help="No progress bars.")
def train_command(pass_policy: str, getopen_policy: str, episodes: int | None, schedule: str | None, trials: int,
                  eval_every: int, eval_episodes: int, arenas: int | None, mode: str, attach: tuple[str, ...],
                  backend: str, ray_address: str | None, threads: int | None, keys: Path | None, seed: int,
                  population: int, elite: int, candidate_episodes: int, keepers: int, takers: int,
                  field_size: float, parameter_set: str, getopen_inputs: str, pass_alpha_halflife: int,
                  pass_hive_mind: bool, cem_extra_noise: float, cem_noise_generations: int, cem_play: str, out: Path,
                  resume: Path | None, no_progress: bool) -> None:
    """Learn GetOpen (CEM), Pass (Sarsa) or both (Algorithm 3) with frozen evaluations along the way."""
    from keepaway.agents.policy_file import getopen_theta_size
    from keepaway.core.exits import EXIT_INTERRUPTED
    from keepaway.runner.launch import ArenaFailure, interrupt_on_sigterm
    from keepaway.trainer.cem import CEMConfig
    from keepaway.trainer.schedule import parse_schedule, training_schedule
    from keepaway.trainer.train import TrainConfig, hive_mind_sarsa, load_checkpoint, read_config, train

    ctx = click.get_current_context()
    if resume is not None:
        try:  # every stored file is checked before anything starts
            stored = read_config(resume)
            for trial in range(stored.trials):
                load_checkpoint(resume, trial)
        except (FileNotFoundError, ValueError) as exc:
            raise click.UsageError(str(exc)) from None
        mode = stored.mode
    where = placement(mode, attach, backend, ray_address, threads, keys, "training" if resume else None)
    if resume is not None:
        given = [f"--{name.replace('_', '-')}" for name in CONFIG_OPTIONS
                 if ctx.get_parameter_source(name) is not click.core.ParameterSource.DEFAULT]
        if given:
            raise click.UsageError(f"--resume uses the stored configuration; drop {', '.join(given)}")
        config = None
    else:
        game_params(parameter_set, field_size)  # the region's own one-line refusal, before the configuration's
        try:
            phases = training_schedule(pass_policy, getopen_policy, episodes,
                                       parse_schedule(schedule) if schedule else None)
            cem = CEMConfig(n_params=getopen_theta_size(keepers, takers), population=population, elite=elite,
                            episodes_per_candidate=candidate_episodes, extra_noise=cem_extra_noise,
                            extra_noise_generations=cem_noise_generations, play=cem_play)
            config = TrainConfig(pass_policy, getopen_policy, phases, trials, eval_every, eval_episodes,
                                 arena_count(mode, attach, arenas),
                                 seed, keepers, takers, field_size, parameter_set, cem, mode=mode,
                                 getopen_inputs=getopen_inputs, pass_alpha_halflife=pass_alpha_halflife,
                                 sarsa=hive_mind_sarsa(pass_hive_mind))
        except ValueError as exc:
            raise click.UsageError(str(exc)) from None
        warn_sparse_curve(config)
    interrupt_on_sigterm()
    prepare_kernels(where.kernel_sets(mode))
    try:
        summary = train(config, resume or out, resume=resume is not None,  # type: ignore[arg-type]
                        progress=not no_progress, placement=where)
    except (FileExistsError, FileNotFoundError) as exc:
        raise click.UsageError(str(exc)) from None
    except ArenaFailure as exc:
        click.echo(f"keepaway train: an arena failed: {exc}; continue with --resume {resume or out}", err=True)
        sys.exit(1)
    except KeyboardInterrupt:
        click.echo(f"keepaway train: interrupted; continue with --resume {resume or out}", err=True)
        sys.exit(EXIT_INTERRUPTED)
    from keepaway.runner.report import format_hold
    from keepaway.trainer.curves import stderr_basis

    trials = len(summary["trials"])
    basis = stderr_basis(trials, summary["config"]["eval_episodes"])
    click.echo(f"{summary['name']}: {trials} trial(s); final evaluation "
               f"{format_hold(summary['final_mean_hold_time_s'], summary['final_stderr_hold_time_s'], basis)} "
               f"-> {resume or out}")


def _policy_files(path: Path) -> list[Path]:
    """The policy file ``path``, or those of a training directory (``trial_*/policy.npz``), or every
    ``.npz`` directly in a directory."""
    if path.is_file():
        return [path]
    files = sorted(path.glob("trial_*/policy.npz")) or sorted(path.glob("*.npz"))
    if not files:
        raise click.UsageError(f"{path}: no policy files (trial_*/policy.npz or *.npz)")
    return files


@click.command("evaluate")
@click.option("--policy", "policy_path", type=click.Path(exists=True, path_type=Path), required=True,
              help="A policy file, or a training directory (each trial's policy).")
@click.option("--episodes", type=COUNT_TYPE, default=500, show_default=True, help="Episodes per policy.")
@click.option("--seed", type=SEED_TYPE, default=0, show_default=True, help="Seed of the evaluation.")
@click.option("--pass", "pass_policy", type=POLICY_CHOICES, default=None,
              help="Pass policy to play [the one the file was trained with].")
@click.option("--getopen", "getopen_policy", type=POLICY_CHOICES, default=None,
              help="GetOpen policy to play [the one the file was trained with].")
@click.option("--arenas", type=COUNT_TYPE, default=None,
              help=ARENAS_HELP)
@placement_options
@click.option("--json", "as_json", is_flag=True, help="Print machine-readable summaries.")
@click.option("--no-progress", is_flag=True, help="No progress bar.")
def evaluate_command(policy_path: Path, episodes: int, seed: int, pass_policy: str | None,
                     getopen_policy: str | None, arenas: int | None, mode: str, attach: tuple[str, ...],
                     backend: str, ray_address: str | None, threads: int | None, keys: Path | None,
                     as_json: bool, no_progress: bool) -> None:
    """Play saved policies frozen (greedy Pass, no learning) for --episodes episodes each; print the summary.

    Every mode plays the same episodes from one seed."""
    import tempfile
    from itertools import groupby

    from keepaway.agents.player import sarsa_config
    from keepaway.agents.policy_file import PolicyFileError, load_policy, unpack_pass_arrays
    from keepaway.core.exits import EXIT_INTERRUPTED
    from keepaway.protocol.params import parameter_set as make_params
    from keepaway.runner.backends import open_backend
    from keepaway.runner.job import Behaviours, Game
    from keepaway.runner.launch import ArenaFailure, interrupt_on_sigterm
    from keepaway.runner.report import dump_json, summary_table

    where = placement(mode, attach, backend, ray_address, threads, keys)
    plays = []  # every file is checked before the kernels are compiled and anything is played
    for path in _policy_files(policy_path):
        try:
            policy = load_policy(path)
            config = policy.config
            parameter_set = config.get("parameter_set", "classic")
            params = make_params(parameter_set, keepaway_length=config.get("field_size", 20.0),
                                 keepaway_width=config.get("field_size", 20.0))
            game = Game(params, policy.n_keepers, policy.n_takers, sarsa_config(policy))
        except (PolicyFileError, ValueError) as exc:
            raise click.UsageError(str(exc)) from None
        playing_pass = pass_policy or config.get("pass", "handcoded")
        behaviours = Behaviours(playing_pass, getopen_policy or config.get("getopen", "handcoded"),
                                policy.getopen_theta,
                                # the file's Pass weights only where its learned Pass plays (--pass may replace it)
                                unpack_pass_arrays(policy.pass_arrays, policy.n_keepers)
                                if policy.pass_arrays and playing_pass == "learned" else None,
                                policy.getopen_inputs)
        if behaviours.getopen_policy == "learned" and behaviours.getopen_theta is None:
            raise click.UsageError(f"{path}: --getopen learned needs GetOpen parameters; the file has none")
        if behaviours.pass_policy == "learned" and behaviours.pass_arrays is None:
            raise click.UsageError(f"{path}: --pass learned needs Pass weights; the file has no Pass weights")
        plays.append((path, game, parameter_set, behaviours))
    interrupt_on_sigterm()
    prepare_kernels(where.kernel_sets(mode))
    arenas = arena_count(mode, attach, arenas)
    logs = Path(tempfile.gettempdir()) / f"keepaway-evaluate-{os.getpid()}"  # arenas of processes started here
    results = []
    try:
        for (game, parameter_set), group in groupby(plays, key=lambda play: play[1:3]):  # one backend per game
            backend = open_backend(mode, game, parameter_set, arenas, logs, where)
            try:
                for path, _, _, behaviours in group:
                    results.append(_evaluate_one(backend, path, behaviours, seed, episodes, no_progress or as_json))
                    if not as_json:
                        click.echo(f"{path}  (Pass {behaviours.pass_policy}, GetOpen {behaviours.getopen_policy})")
                        click.echo(summary_table(results[-1]) + "\n")
            finally:
                backend.close()
    except ArenaFailure as exc:
        click.echo(f"keepaway evaluate: an arena failed: {exc}", err=True)
        sys.exit(1)
    except KeyboardInterrupt:
        click.echo("keepaway evaluate: interrupted; every arena was stopped", err=True)
        sys.exit(EXIT_INTERRUPTED)
    if as_json:
        click.echo(dump_json(results[0] if len(results) == 1 else results))


def _evaluate_one(backend: Backend, path: Path, behaviours: Behaviours, seed: int, episodes: int,
                  quiet: bool) -> dict:
    """The summary of one policy file's frozen evaluation, with a progress bar unless ``quiet``."""
    from tqdm import tqdm

    from keepaway.trainer.train import evaluate

    with tqdm(total=episodes, unit="ep", desc=str(path), disable=quiet, dynamic_ncols=True) as bar:
        try:
            result = evaluate(backend, behaviours, seed, episodes, bar.update)
        except ValueError as exc:  # Pass weights that do not fit the game's learners
            raise click.UsageError(f"{path}: {exc}") from None
    return {"policy": str(path), "pass": behaviours.pass_policy, "getopen": behaviours.getopen_policy,
            **result.summary()}


commands = [train_command, evaluate_command]

"""``keepaway experiment figure3`` and ``keepaway experiment table2``: the paper's experiments on any backend
(docs/players.md §8.3; :mod:`trainer.experiments`)."""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from keepaway.runner.cli import (
    ARENAS_HELP,
    COUNT_TYPE,
    SEED_TYPE,
    Command,
    arena_count,
    placement,
    placement_options,
    with_options,
)
from keepaway.trainer.train_cli import learning_options

if TYPE_CHECKING:
    from keepaway.runner.backends import Placement


def experiment_options(command: Command) -> Command:
    """The options both experiments share: the size of the run (a short version fits on a laptop) and
    where it goes."""
    options = [
        click.option("--trials", type=COUNT_TYPE, default=20, show_default=True,
                     help="Independent trials per configuration."),
        click.option("--episodes", type=COUNT_TYPE, default=30_000, show_default=True,
                     help="Training episodes per trial (Algorithm 3 is scaled to it: a multiple of 6)."),
        click.option("--eval-every", type=COUNT_TYPE, default=None,
                     help="Training episodes between frozen evaluations [--episodes / 12: the paper's 2,500]."),
        click.option("--eval-episodes", type=COUNT_TYPE, default=500, show_default=True,
                     help="Episodes per evaluation."),
        click.option("--arenas", type=COUNT_TYPE, default=None,
                     help=ARENAS_HELP),
        click.option("--population", type=COUNT_TYPE, default=20, show_default=True,
                     help="CEM candidates per generation."),
        click.option("--elite", type=COUNT_TYPE, default=5, show_default=True,
                     help="CEM candidates refitted to (at most --population)."),
        click.option("--candidate-episodes", type=COUNT_TYPE, default=125, show_default=True,
                     help="Episodes per CEM candidate."),
        learning_options,
        click.option("--seed", type=SEED_TYPE, default=0, show_default=True,
                     help="Seed of the whole experiment."),
        click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("experiment_out"),
                     show_default=True, help="Directory of the experiment: one subdirectory per configuration; "
                                             "running again continues it."),
        placement_options,
        click.option("--workers", type=COUNT_TYPE, default=1, show_default=True,
                     help="Configurations trained at once, each in its own process on one thread (unless "
                          "--threads says otherwise), the longest first: one per core is the fastest way "
                          "through a study. The results are the same."),
        click.option("--together", is_flag=True,
                     help="Train the learning configurations side by side in this process instead: each round "
                          "is one step of every configuration's trials, their arenas in shared batches of "
                          "--threads threads (the batched backend). The results are the same."),
        click.option("--no-progress", is_flag=True, help="No progress bars."),
    ]
    return with_options(options, command)


def _experiment(trials: int, episodes: int, eval_every: int | None, eval_episodes: int, arenas: int | None,
                population: int, elite: int, candidate_episodes: int, seed: int, pass_alpha_halflife: int,
                pass_hive_mind: bool, cem_extra_noise: float, cem_noise_generations: int, cem_play: str, mode: str,
                attach: tuple[str, ...], backend: str, ray_address: str | None, threads: int | None,
                keys: Path | None) -> tuple[Any, Placement]:
    """The experiment the shared options describe (:func:`experiment_options`) and where its arenas run; a
    usage error if it cannot run."""
    from keepaway.trainer.cem import CEMConfig
    from keepaway.trainer.configurations import ExperimentConfig, default_eval_every

    where = placement(mode, attach, backend, ray_address, threads, keys)
    try:
        cem = CEMConfig(population=population, elite=elite, episodes_per_candidate=candidate_episodes,
                        extra_noise=cem_extra_noise, extra_noise_generations=cem_noise_generations, play=cem_play)
        exp = ExperimentConfig(trials, episodes, default_eval_every(episodes) if eval_every is None else eval_every,
                               eval_episodes, arena_count(mode, attach, arenas), seed, cem, pass_alpha_halflife,
                               mode, pass_hive_mind)
        exp.check()
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    return exp, where


def _report(run: Any) -> None:
    from keepaway.runner.report import format_hold
    from keepaway.trainer.experiments import TOGETHER
    from keepaway.trainer.timing import TIMING

    final = run.final()
    state = "finished before, skipped" if run.skipped else "done"
    # a configuration trained together with others has no sittings of its own
    timing = run.timing.text() if run.timing.sittings else f"timed with the others in {TOGETHER}/{TIMING}"
    click.echo(f"{run.name}: {state}; final evaluation "
               f"{format_hold(final.mean_hold_time_s, final.stderr_hold_time_s, run.stderr_basis())}; {timing}")


def _run(what: Callable[..., Any], exp: Any, where: Placement, out: Path, no_progress: bool) -> Any:
    from keepaway.core.exits import EXIT_INTERRUPTED
    from keepaway.runner.launch import ArenaFailure, interrupt_on_sigterm
    from keepaway.trainer.train_cli import prepare_kernels

    interrupt_on_sigterm()
    prepare_kernels(where.kernel_sets(exp.mode))
    try:
        return what(exp, out, placement=where, progress=not no_progress, on_configuration=_report)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    except ArenaFailure as exc:
        click.echo(f"keepaway experiment: an arena failed: {exc}; run the same command again to continue in {out}",
                   err=True)
        sys.exit(1)
    except KeyboardInterrupt:
        click.echo(f"keepaway experiment: interrupted; run the same command again to continue in {out}", err=True)
        sys.exit(EXIT_INTERRUPTED)


@click.group("experiment")
def experiment_group() -> None:
    """The paper's experiments: Figure 3's learning curves and Table 2's specialisation cross-tests."""


@experiment_group.command("figure3")
@experiment_options
@click.option("--only", "only", multiple=True, metavar="P:X-GO:Y",
              help="Run just this configuration (repeat for more) and draw nothing: split the nine across "
                   "processes sharing --out, then run once without --only to draw the figure.")
def figure3_command(out: Path, no_progress: bool, only: tuple[str, ...], workers: int, together: bool,
                    **settings: Any) -> None:
    """Train the nine Pass x GetOpen configurations and plot them grouped by Pass and by GetOpen."""
    from keepaway.trainer.configurations import parse_configurations
    from keepaway.trainer.experiments import figure3

    exp, where = _experiment(**settings)
    try:
        chosen = parse_configurations(only) if only else None
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--only") from None
    _run(functools.partial(figure3, only=chosen, workers=workers, together=together), exp, where, out, no_progress)
    if chosen is None:
        click.echo(f"figure: {out / 'figure3.png'}; final evaluations: {out / 'figure3.csv'}, {out / 'figure3.json'}")
    else:
        click.echo(f"ran {len(chosen)} of 9 configurations; run without --only to draw the figure")


@experiment_group.command("table2")
@experiment_options
def table2_command(out: Path, no_progress: bool, workers: int, together: bool, **settings: Any) -> None:
    """Test each learned Pass policy with every GetOpen and each learned GetOpen with every Pass."""
    from keepaway.trainer.experiments import table2

    exp, where = _experiment(**settings)
    tables = _run(functools.partial(table2, workers=workers, together=together), exp, where, out, no_progress)
    click.echo("")
    for table in tables:
        click.echo(table.markdown())
        hits = sum(table.best_on_diagonal())
        click.echo(f"best entry from the policy trained with the same counterpart in {hits} of 3 columns\n")
    click.echo(f"tables: {out / 'table2.md'}, {out / 'table2.json'}")


commands = [experiment_group]

"""``keepaway run``: the trainer package's part of the command line."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from trainer.run import MODES


@click.command("run")
@click.option("--episodes", type=int, default=20, show_default=True, help="Episodes to play.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the whole run.")
@click.option("--pass", "pass_policy", type=click.Choice(["random", "handcoded", "learned", "hold"]),
              default="handcoded", show_default=True, help="Keepers' Pass policy.")
@click.option("--getopen", "getopen_policy", type=click.Choice(["random", "handcoded", "handcoded-cone", "learned"]),
              default="handcoded", show_default=True, help="Keepers' GetOpen policy.")
@click.option("--policy", "policy_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Policy file (.npz) for learned policies.")
@click.option("--keepers", type=int, default=3, show_default=True)
@click.option("--takers", type=int, default=2, show_default=True)
@click.option("--field-size", type=float, default=20.0, show_default=True, help="Side of the square region (m).")
@click.option("--params", "parameter_set", type=click.Choice(["classic", "current"]), default="classic",
              show_default=True, help="Server parameter set.")
@click.option("--mode", type=click.Choice(MODES), default="distributed", show_default=True,
              help="Separate processes over ZeroMQ, one process without sockets, or many arenas at once.")
@click.option("--batch", type=int, default=1024, show_default=True, help="Arenas stepped at once (batched mode).")
@click.option("--realtime", is_flag=True, help="100 ms cycles (distributed mode) instead of synchronous stepping.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("out"), show_default=True,
              help="Directory for the .kwy / .jsonl logs (and process logs).")
@click.option("--json", "as_json", is_flag=True, help="Print a machine-readable summary instead of the table.")
@click.option("--no-progress", is_flag=True, help="No progress bar.")
def run_command(episodes: int, seed: int, pass_policy: str, getopen_policy: str, policy_path: Path | None,
                keepers: int, takers: int, field_size: float, parameter_set: str, mode: str, batch: int,
                realtime: bool, out: Path, as_json: bool, no_progress: bool) -> None:
    """Play Keepaway: a whole arena (server, coach, keepers, takers) for --episodes episodes."""
    from agents.policy_file import PolicyFileError, load_policy
    from protocol.params import parameter_set as make_params
    from trainer.embedded import ArenaSpec
    from trainer.launch import ArenaFailure, interrupt_on_sigterm
    from trainer.run import RunOptions, dump_json, run, summary_table

    if episodes < 1:
        raise click.UsageError("--episodes must be at least 1")
    if realtime and mode != "distributed":
        raise click.UsageError("--realtime needs --mode distributed")
    if mode == "batched" and batch < 1:
        raise click.UsageError("--batch must be at least 1")
    try:
        params = make_params(parameter_set, keepaway_length=field_size, keepaway_width=field_size)
        policy = load_policy(policy_path) if policy_path is not None else None
    except (ValueError, PolicyFileError) as exc:
        raise click.UsageError(str(exc)) from None
    spec = ArenaSpec(params, keepers, takers, seed, pass_policy, getopen_policy, policy)
    opts = RunOptions(spec, episodes, mode, batch, realtime, out, policy_path, parameter_set)
    interrupt_on_sigterm()
    try:
        result = run(opts, progress=not no_progress and not as_json)
    except ArenaFailure as exc:
        click.echo(f"keepaway run: {exc}", err=True)
        sys.exit(1)
    except KeyboardInterrupt:
        click.echo("keepaway run: interrupted; every process was stopped", err=True)
        sys.exit(130)
    summary = result.summary()
    click.echo(dump_json(summary) if as_json else summary_table(summary))


commands = [run_command]

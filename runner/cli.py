"""``keepaway run`` and ``keepaway compile``: the runner package's part of the command line, and the options
every command that plays shares: what a seed, a team or a region can be, and where the arenas run."""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import click

from keepaway.core.options import FiniteFloatRange
from keepaway.protocol.messages import GETOPEN_NOTE_MODES, MAX_SEED
from keepaway.protocol.params import KEEPAWAY_KEEPERS, KEEPAWAY_TAKERS
from keepaway.protocol.security import keys_option
from keepaway.runner import MODES
from keepaway.runner.kernels import KERNEL_SETS

if TYPE_CHECKING:
    from keepaway.protocol.params import ServerParams
    from keepaway.runner.backends import Placement

# Option types shared by run, train, evaluate and experiment: what a seed, a count, a Keepaway team and
# a region can be.
SEED_TYPE = click.IntRange(0, MAX_SEED)
COUNT_TYPE = click.IntRange(min=1)
KEEPERS_TYPE = click.IntRange(KEEPAWAY_KEEPERS.low, KEEPAWAY_KEEPERS.high)
TAKERS_TYPE = click.IntRange(KEEPAWAY_TAKERS.low, KEEPAWAY_TAKERS.high)
FIELD_SIZE_TYPE = FiniteFloatRange(min=0.0, min_open=True)
KEEPERS_HELP = "Number of keepers (at least 2: Pass needs a keeper to pass to)."
TAKERS_HELP = "Number of takers."
FIELD_SIZE_HELP = "Side of the square region (m), at most the pitch width."

Command = Callable[..., None]


def with_options(options: Sequence[Callable[[Command], Command]], command: Command) -> Command:
    """``command`` decorated with ``options`` in the order given (as if stacked above it top to bottom): a
    group of options that several commands share."""
    return functools.reduce(lambda f, option: option(f), reversed(options), command)


def game_options(command: Command) -> Command:
    """The game of ``keepaway run`` and ``train``: the teams, the region and the parameter set."""
    options = [
        click.option("--keepers", type=KEEPERS_TYPE, default=3, show_default=True, help=KEEPERS_HELP),
        click.option("--takers", type=TAKERS_TYPE, default=2, show_default=True, help=TAKERS_HELP),
        click.option("--field-size", type=FIELD_SIZE_TYPE, default=20.0, show_default=True, help=FIELD_SIZE_HELP),
        click.option("--params", "parameter_set", type=click.Choice(["classic", "current"]), default="classic",
                     show_default=True, help="Server parameter set."),
    ]
    return with_options(options, command)


def game_params(parameter_set: str, field_size: float) -> ServerParams:
    """The server parameters :func:`game_options` choose; a region that does not fit the pitch is refused
    in one line naming ``--field-size``, the option that sets it."""
    from keepaway.protocol.params import parameter_set as make_params
    from keepaway.protocol.params import with_square_region

    try:
        return with_square_region(make_params(parameter_set), field_size)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="'--field-size'") from None


# Where distributed arenas are started, for every command that plays (run's one arena, the others' many).
BACKEND_OPTION = click.option("--backend", type=click.Choice(["local", "ray"]), default="local", show_default=True,
                              help="distributed: start the arenas on this machine, or on a Ray cluster (pip install "
                                   "'keepaway[ray]'; see --ray-address).")
RAY_ADDRESS_OPTION = click.option("--ray-address", default=None,
                                  help="Ray cluster to join [RAY_ADDRESS, or a local Ray].")


def check_ray_address(backend: str, ray_address: str | None) -> None:
    """A usage error in one line for ``--ray-address`` without ``--backend ray``, which would ignore it."""
    if ray_address is not None and backend != "ray":
        raise click.UsageError("--ray-address names the Ray cluster of --backend ray:"
                               " add --backend ray or leave it out")


def placement_options(command: Command) -> Command:
    """Where the arenas of ``keepaway train``, ``evaluate`` and ``experiment`` run (``runner.backends``);
    :func:`placement` checks them."""
    options = [
        click.option("--mode", type=click.Choice(MODES), default="batched", show_default=True,
                     help="batched: in-process arenas stepped together; embedded: one in-process arena played as "
                          "a distributed one (the same results); distributed: arenas of server, coach and player "
                          "processes."),
        click.option("--arena", "attach", multiple=True, metavar="ENDPOINT",
                     help="distributed: drive this running arena (a coach's arena endpoint, e.g. tcp://host:6003) "
                          "instead of starting arenas; repeat for more."),
        BACKEND_OPTION,
        RAY_ADDRESS_OPTION,
        click.option("--threads", type=COUNT_TYPE, default=None,
                     help="Threads stepping batched arenas [numba's thread count]."),
        keys_option,
    ]
    return with_options(options, command)


def placement(mode: str, attach: tuple[str, ...], backend: str, ray_address: str | None, threads: int | None,
              keys: Path | None = None, stored_as: str | None = None) -> Placement:
    """The placement :func:`placement_options` describe for ``mode`` (a mode read from a stored ``stored_as``,
    e.g. "training", if it is one); a usage error in one line for options that do not go together."""
    from keepaway.runner.backends import Placement

    check_ray_address(backend, ray_address)
    if (attach or backend != "local") and mode != "distributed":
        fix = f"this {stored_as} is {mode}" if stored_as else "add --mode distributed"
        raise click.UsageError(f"--arena and --backend choose where distributed arenas run; {fix}")
    keys_for_distributed(keys, mode)
    if attach and backend != "local":
        raise click.UsageError("--arena attaches to running arenas; --backend ray starts its own: choose one")
    launcher = None
    if backend == "ray":
        from keepaway.runner.ray_backend import ray_launcher

        try:
            launcher = ray_launcher(ray_address, keys, announce)
        except RuntimeError as exc:
            raise click.UsageError(str(exc)) from None
    return Placement(threads, attach, launcher, keys)


def keys_for_distributed(keys: Path | None, mode: str) -> None:
    """A usage error in one line for ``--keys`` with a mode that opens no connection."""
    if keys is not None and mode != "distributed":
        raise click.UsageError(f"--keys secures the connections of distributed arenas; {mode} has none: "
                               f"add --mode distributed")


ARENAS_HELP = ("distributed: arenas of processes started [2] (the games do not depend on it: every mode "
               "plays each job in chunks of episodes, a chunk per arena).")


def arena_count(mode: str, attach: tuple[str, ...], arenas: int | None) -> int:
    """``--arenas``, or when not given the running arenas attached to, else 2 arenas of processes; a usage
    error in one line if given for a mode that starts no arenas of processes (batched and embedded play
    every chunk in an in-process arena of its own)."""
    if arenas is not None and mode != "distributed":
        from keepaway.runner.job import CHUNK_EPISODES

        raise click.UsageError(f"--arenas counts the distributed mode's arenas of processes; the {mode} mode "
                               f"plays each chunk of {CHUNK_EPISODES} episodes in an arena of its own: leave it out")
    return arenas or len(attach) or 2


@click.command("run")
@click.option("--episodes", type=int, default=20, show_default=True, help="Episodes to play.")
@click.option("--seed", type=SEED_TYPE, default=0, show_default=True, help="Seed of the whole run.")
@click.option("--pass", "pass_policy", type=click.Choice(["random", "handcoded", "learned", "hold"]),
              default="handcoded", show_default=True, help="Keepers' Pass policy.")
@click.option("--getopen", "getopen_policy", type=click.Choice(["random", "handcoded", "handcoded-cone", "learned"]),
              default="handcoded", show_default=True, help="Keepers' GetOpen policy.")
@click.option("--policy", "policy_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Policy file (.npz) for learned policies.")
@game_options
@click.option("--mode", type=click.Choice(MODES), default="distributed", show_default=True,
              help="Many arenas at once, one process without sockets, or separate processes over ZeroMQ.")
@click.option("--batch", type=int, default=1024, show_default=True, help="Arenas stepped at once (batched mode).")
@click.option("--realtime", is_flag=True, help="100 ms cycles (distributed mode) instead of synchronous stepping.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("out"), show_default=True,
              help="Directory for the .kwy / .jsonl logs (and process logs).")
@click.option("--no-game-log", is_flag=True,
              help="Do not write the game log (keepaway.rcg: every cycle, for rcssmonitor, soccerwindow2 and "
                   "keepaway view); faster.")
@click.option("--game-log-arenas", default="", metavar="B,B,...",
              help="Batched mode: write the game logs of these arenas (keepaway-arena<B>.rcg; none by default).")
@click.option("--view", is_flag=True,
              help="Distributed mode: open a browser viewer of the arena (keepaway view) and print its URL; it "
                   "stops with the run (add --realtime to watch at 10 cycles a second).")
@click.option("--getopen-notes", type=click.Choice(GETOPEN_NOTE_MODES), default=None,
              help="Distributed and embedded modes: the keepers note their GetOpen target (and the grid points' "
                   "values) in the game log and, distributed, in the monitor frames a viewer draws "
                   "[values with --view, else none].")
@click.option("--json", "as_json", is_flag=True, help="Print a machine-readable summary instead of the table.")
@click.option("--no-progress", is_flag=True, help="No progress bar.")
@BACKEND_OPTION
@RAY_ADDRESS_OPTION
@keys_option
def run_command(episodes: int, seed: int, pass_policy: str, getopen_policy: str, policy_path: Path | None,
                keepers: int, takers: int, field_size: float, parameter_set: str, mode: str, batch: int,
                realtime: bool, out: Path, no_game_log: bool, game_log_arenas: str, view: bool,
                getopen_notes: str | None, as_json: bool, no_progress: bool, backend: str, ray_address: str | None,
                keys: Path | None) -> None:
    """Play Keepaway: a whole arena (server, coach, keepers, takers) for --episodes episodes."""
    from keepaway.agents.policy_file import PolicyFileError, load_policy
    from keepaway.core.exits import EXIT_INTERRUPTED
    from keepaway.runner.embedded import ArenaSpec
    from keepaway.runner.kernels import CompileError
    from keepaway.runner.launch import ArenaFailure, interrupt_on_sigterm
    from keepaway.runner.report import dump_json, summary_table
    from keepaway.runner.run import RunOptions, RunStopped, run

    if episodes < 1:
        raise click.UsageError("--episodes must be at least 1")
    if realtime and mode != "distributed":
        raise click.UsageError("--realtime needs --mode distributed")
    keys_for_distributed(keys, mode)
    if view and mode != "distributed":
        raise click.UsageError("--view follows an arena's monitor port: it needs --mode distributed")
    check_ray_address(backend, ray_address)
    if backend == "ray":
        if mode != "distributed":
            raise click.UsageError(f"--backend ray places the distributed mode's arena; the {mode} mode plays in "
                                   "this process: add --mode distributed or leave --backend out")
        if view:
            raise click.UsageError("--view serves a viewer of an arena on this machine; with --backend ray the "
                                   "arena runs on a Ray node: leave one out")
    if getopen_notes is None:
        getopen_notes = "values" if view else "none"
    elif getopen_notes != "none" and mode == "batched":
        raise click.UsageError("--getopen-notes: the batched mode's keepers send no notes; use --mode "
                               "distributed or embedded")
    if mode == "batched" and batch < 1:
        raise click.UsageError("--batch must be at least 1")
    logged_arenas = arena_list(game_log_arenas, batch if mode == "batched" else 0, "--game-log-arenas")
    if logged_arenas and no_game_log:
        raise click.UsageError("--game-log-arenas chooses game logs to write; --no-game-log writes none: choose one")
    params = game_params(parameter_set, field_size)
    try:
        policy = load_policy(policy_path) if policy_path is not None else None
    except (ValueError, PolicyFileError) as exc:
        raise click.UsageError(str(exc)) from None
    if policy is None:
        warn_untrained(pass_policy, getopen_policy, mode)
    spec = ArenaSpec(params, keepers, takers, seed, pass_policy, getopen_policy, policy)
    opts = RunOptions(spec, episodes, mode, batch, realtime, out, policy_path, parameter_set, keys,
                      game_log=not no_game_log, game_log_arenas=logged_arenas, view=view,
                      getopen_notes=getopen_notes)
    elsewhere = None
    if backend == "ray":  # joins the cluster: after every other check
        from keepaway.runner.ray_backend import ray_run

        try:
            elsewhere = ray_run(ray_address, announce)
        except RuntimeError as exc:
            raise click.UsageError(str(exc)) from None
    interrupt_on_sigterm()
    show = (lambda result: click.echo(dump_json(result.summary()) if as_json else summary_table(result.summary())))
    try:
        result = run(opts, progress=not no_progress and not as_json, announce=announce, elsewhere=elsewhere)
    except RunStopped as stop:
        if stop.result.episodes:
            show(stop.result)
        finished = f"the summary covers the {len(stop.result.episodes)} of {episodes} episodes that finished"
        if isinstance(stop.cause, KeyboardInterrupt):
            click.echo(f"keepaway run: interrupted; every process was stopped; {finished}", err=True)
            sys.exit(EXIT_INTERRUPTED)
        click.echo(f"keepaway run: {stop.cause}; {finished}", err=True)
        sys.exit(1)
    except (ArenaFailure, CompileError) as exc:
        click.echo(f"keepaway run: {exc}", err=True)
        sys.exit(1)
    except KeyboardInterrupt:
        click.echo("keepaway run: interrupted; every process was stopped", err=True)
        sys.exit(EXIT_INTERRUPTED)
    show(result)


def warn_untrained(pass_policy: str, getopen_policy: str, mode: str) -> None:
    """Learned policies without a policy file start from zero weights (agents/cli.py's players wait for a
    coach's; ``keepaway run`` has none to send): one line on stderr naming the option to add. The batched
    mode's kernels play only a given GetOpen net (``BatchedArenas``): a usage error there."""
    untrained = [f"--{flag} learned" for flag, name in (("pass", pass_policy), ("getopen", getopen_policy))
                 if name == "learned"]
    if getopen_policy == "learned" and mode == "batched":
        raise click.UsageError("--getopen learned in the batched mode plays a policy file's net: add --policy FILE "
                               "(e.g. a training's trial_000/policy.npz)")
    if untrained:
        verb = "start" if len(untrained) > 1 else "starts"
        click.echo(f"keepaway run: {' and '.join(untrained)} without --policy {verb} from zero weights (an untrained "
                   f"policy): add --policy FILE (e.g. a training's trial_000/policy.npz)", err=True)


def arena_list(text: str, batch: int, option: str) -> tuple[int, ...]:
    """``"0,3"`` -> ``(0, 3)``: distinct arena indices below ``batch`` (0: the option needs the batched mode);
    a usage error in one line otherwise."""
    if not text.strip():
        return ()
    if batch == 0:
        raise click.UsageError(f"{option} needs --mode batched")
    try:
        arenas = tuple(sorted({int(part) for part in text.split(",")}))
    except ValueError:
        raise click.UsageError(f"{option}: expected arena numbers separated by commas, e.g. 0,3;"
                               f" got {text!r}") from None
    if arenas[0] < 0 or arenas[-1] >= batch:
        raise click.UsageError(f"{option}: arenas are numbered 0..{batch - 1} (--batch {batch}); got {text!r}")
    return arenas


def announce(line: str) -> None:
    """One line on stderr about what a command is doing (stdout stays machine-readable)."""
    click.echo(f"keepaway: {line}", err=True)


@click.command("compile")
@click.option("--only", "only", multiple=True, type=click.Choice(KERNEL_SETS),
              help="Compile this kernel set in this process (repeatable) [all sets, side by side].")
@click.option("--quiet", is_flag=True, help="Print nothing.")
def compile_command(only: tuple[str, ...], quiet: bool) -> None:
    """Compile the numba kernels into the cache once, e.g. while building an image or before tests.

    Every later server, player, embedded or batched run of this version of the source loads them from
    the cache instead of compiling (keepaway run and train also do this by themselves when needed).
    """
    from keepaway.core.jit import cache_dir
    from keepaway.runner.kernels import CompileError, compile_set, ensure_compiled

    if only:
        for kernel_set in only:
            seconds = compile_set(kernel_set)
            if not quiet:
                click.echo(f"keepaway compile: {kernel_set} kernels ready in {seconds:.0f} s")
        return
    try:
        done = ensure_compiled(KERNEL_SETS, None if quiet else announce)
    except CompileError as exc:
        click.echo(f"keepaway compile: {exc}", err=True)
        sys.exit(1)
    if not quiet:
        click.echo(f"keepaway compile: {'compiled ' + ', '.join(done) if done else 'already compiled'}; "
                   f"cache {cache_dir()}")


commands = [run_command, compile_command]

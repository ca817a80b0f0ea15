"""``keepaway server`` (and ``keepaway replay-trace``): the server package's part of the command line."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import click

from keepaway.core.options import FiniteFloatRange, configure_logging
from keepaway.protocol.messages import GETOPEN_NOTE_MODES
from keepaway.protocol.params import TEAM_SIZE, ServerParams, parameter_set, with_square_region
from keepaway.protocol.security import SecurityError, keys_option
from keepaway.server.config import (
    AT_LEAST_ONE,
    HANG_POLICIES,
    PORT,
    SEED,
    START_ON,
    TIMING_MODES,
    ServerConfig,
    load_toml,
)

PORT_TYPE = click.IntRange(PORT.low, PORT.high)
TEAM_SIZE_TYPE = click.IntRange(TEAM_SIZE.low, TEAM_SIZE.high)
COUNT_TYPE = click.IntRange(min=AT_LEAST_ONE.low)
POSITIVE_TYPE = FiniteFloatRange(min=0.0, min_open=True)


def _parse_overrides(pairs: tuple[str, ...]) -> dict[str, float]:
    out: dict[str, float] = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep:
            raise click.BadParameter(f"expected NAME=VALUE, got {pair!r}", param_hint="--param")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise click.BadParameter(f"{name}: {value!r} is not a number", param_hint="--param") from None
    return out


def build_config(config_file: Path | None, parameter_set_name: str | None, overrides: dict[str, float],
                 keepaway_launch: bool, field_size: float | None, **settings: Any) -> ServerConfig:
    """Defaults, then the TOML file, then flags (only those given); raises ValueError in one line, or a
    usage error naming ``--field-size`` for a region that does not fit the pitch."""
    data: dict[str, Any] = load_toml(config_file) if config_file is not None else {}
    file_params = data.pop("params", {}) or {}
    set_name = parameter_set_name or data.pop("parameter_set", "classic")
    data.pop("parameter_set", None)
    param_changes = {**file_params, **overrides}
    if field_size is not None:  # it sets the region, whatever the file or --param said
        param_changes.pop("keepaway_length", None)
        param_changes.pop("keepaway_width", None)
    params: ServerParams = parameter_set(set_name, keepaway_launch=keepaway_launch, **param_changes)
    if field_size is not None:
        try:
            params = with_square_region(params, field_size)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="'--field-size'") from None
    data.update({k: v for k, v in settings.items() if v is not None})
    for name in ("log_dir", "keys"):
        if data.get(name) is not None:
            data[name] = Path(data[name])
    return ServerConfig(params=params, **data)


@click.command("server")
@click.option("--config", "config_file", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="TOML file: ServerConfig fields at top level, [params] for parameter overrides.")
@click.option("--host", default=None, help="Bind address (default 127.0.0.1).")
@keys_option
@click.option("--players-port", type=PORT_TYPE, default=None, help="Players ROUTER port (default 6000; 0 = free port).")
@click.option("--coach-port", type=PORT_TYPE, default=None, help="Coach ROUTER port (default 6001; 0 = free port).")
@click.option("--monitor-port", type=PORT_TYPE, default=None, help="Monitor PUB port (default 6002; 0 = free port).")
@click.option("--keepers", type=TEAM_SIZE_TYPE, default=None, help="Number of keepers (default 3).")
@click.option("--takers", type=TEAM_SIZE_TYPE, default=None, help="Number of takers (default 2).")
@click.option("--field-size", type=POSITIVE_TYPE, default=None,
              help="Side of the square region in m, at most the pitch width (default 20).")
@click.option("--mode", type=click.Choice(TIMING_MODES), default=None, help="Timing (default sync).")
@click.option("--seed", type=click.IntRange(SEED.low, SEED.high), default=None,
              help="Seed of all server randomness (default 0).")
@click.option("--params", "parameter_set_name", type=click.Choice(["classic", "current"]), default=None,
              help="Parameter set: rcssserver 11 (classic, default) or 19 (current).")
@click.option("--param", "param_pairs", multiple=True, metavar="NAME=VALUE",
              help="Override one server parameter (repeatable).")
@click.option("--no-keepaway-launch", is_flag=True,
              help="Do not apply keepaway.sh's stamina_inc_max=3500 and visible_angle=360.")
@click.option("--episodes", type=COUNT_TYPE, default=None, help="Stop after this many episodes.")
@click.option("--max-cycles", type=COUNT_TYPE, default=None, help="Stop after this many cycles.")
@click.option("--cycle-timeout", "cycle_timeout_s", type=POSITIVE_TYPE, default=None,
              help="Sync mode: seconds to wait for every player per cycle (default 1.25).")
@click.option("--max-missed", "max_missed_cycles", type=COUNT_TYPE, default=None,
              help="Consecutive missed cycles before a player counts as hung (default 20).")
@click.option("--on-hang", type=click.Choice(HANG_POLICIES), default=None,
              help="What to do with a hung player: continue without it (default) or stop.")
@click.option("--start-on", type=click.Choice(START_ON), default=None,
              help="Start when all players connected (default) or when a coach says start.")
@click.option("--log-dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Write the .kwy and .jsonl episode logs and the .rcg game log here.")
@click.option("--kwy-name", default=None, help="Fixed log name (default keepaway).")
@click.option("--no-game-log", is_flag=True,
              help="With --log-dir: do not write the game log (keepaway.rcg, rcssserver's .rcg version 5).")
@click.option("--getopen-notes", type=click.Choice(GETOPEN_NOTE_MODES), default=None,
              help="Ask the keepers for notes of their GetOpen decisions, written to the game log and "
                   "published in monitor frames for viewers: their target point, or target and the grid "
                   "points' values (default none).")
@click.option("--rcss-port", type=PORT_TYPE, default=None,
              help="Also seat rcssserver's UDP text clients (e.g. the keepaway-0.6 C++ players) through an "
                   "rcssserver-protocol front on this UDP port (0 = free port; docs/protocol.md §16).")
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
def server_command(config_file: Path | None, parameter_set_name: str | None, param_pairs: tuple[str, ...],
                   no_keepaway_launch: bool, field_size: float | None, no_game_log: bool,
                   verbose: int, **settings: Any) -> None:
    """Run the Keepaway simulation server (one arena) until its episodes are done or it is stopped.

    Prints one line with the bound endpoints (useful with port 0), then logs to stderr.
    """
    from keepaway.server.app import Server  # imported here so `keepaway --help` does not compile kernels

    configure_logging(verbose)
    if no_game_log:
        settings["game_log"] = False
    try:
        config = build_config(config_file, parameter_set_name, _parse_overrides(param_pairs),
                              not no_keepaway_launch, field_size, **settings)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None

    def announce(ports: Any) -> None:
        h = config.host
        text = "" if ports.rcss is None else f" rcss=udp://{h}:{ports.rcss}"
        click.echo(f"keepaway server listening players=tcp://{h}:{ports.players} "
                   f"coach=tcp://{h}:{ports.coach} monitor=tcp://{h}:{ports.monitor}{text}")
        sys.stdout.flush()

    server = Server(config, on_ready=announce)
    server.install_signal_handlers()
    try:
        server.bind()
    except SecurityError as exc:
        raise click.BadParameter(str(exc), param_hint="--keys") from None
    except Exception as exc:  # zmq.ZMQError, OSError: address in use etc.
        raise click.ClickException(f"cannot bind: {exc}") from None
    code = server.run()
    if code:
        click.echo(f"keepaway server: {server.stop_reason}", err=True)
    sys.exit(code)


@click.command("replay-trace")
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True))
@click.option("--show", default=5, show_default=True, help="Mismatches printed per failing file.")
def replay_trace_command(paths: tuple[str, ...], show: int) -> None:
    """Replay rcssserver physics traces (FILEs or directories of *.json) against our physics."""
    from keepaway.server.trace_replay import is_physics_trace, replay_trace, trace_files  # loads numba

    failed = False
    for path in trace_files(paths):
        if not is_physics_trace(json.loads(path.read_text())):
            click.echo(f"SKIP {path.name}: not a physics trace")
            continue
        report = replay_trace(path)
        if report.ok:
            click.echo(f"OK {report.scenario} {report.cycles} cycles, max error {report.max_abs_error:.3g}")
            continue
        failed = True
        click.echo(f"FAIL {report.scenario}: {len(report.mismatches)} mismatches in {report.cycles} cycles")
        for mismatch in report.mismatches[:show]:
            click.echo(f"  {mismatch}")
    if failed:
        raise SystemExit(1)


commands = [server_command, replay_trace_command]

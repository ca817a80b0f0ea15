"""``keepaway coach``: the coach package's part of the command line."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from keepaway.core.options import FiniteFloatRange, configure_logging
from keepaway.protocol.endpoints import parse_endpoint
from keepaway.protocol.security import SecurityError, keys_option, open_keys


@click.command("coach")
@click.option("--server", "server_endpoint", required=True, metavar="tcp://HOST:PORT",
              help="The server's coach port.")
@click.option("--arena-port", type=click.IntRange(0, 65535), default=None,
              help="Serve trainers on this port (0 = a free port, printed); default: no arena endpoint.")
@click.option("--host", default="127.0.0.1", help="Bind address of the arena port.")
@click.option("--idle", is_flag=True,
              help="With --arena-port: keep the game paused until a trainer's first request (default: it "
                   "plays freely until then).")
@click.option("--episodes", "stop_after", type=click.IntRange(min=1), default=None,
              help="Stop the server after this many episodes.")
@click.option("--connect-timeout", type=FiniteFloatRange(min=0.0, min_open=True), default=60.0, show_default=True,
              help="Seconds to wait for the server.")
@click.option("--json", "as_json", is_flag=True, help="Print the episode record as JSON at the end.")
@keys_option
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
def coach_command(server_endpoint: str, arena_port: int | None, host: str, idle: bool, stop_after: int | None,
                  connect_timeout: float, as_json: bool, keys: Path | None, verbose: int) -> None:
    """Run an arena's online coach: the ground-truth episode record and the trainer's endpoint."""
    from keepaway.coach.coach import Coach

    configure_logging(verbose)
    if idle and arena_port is None:
        raise click.UsageError("--idle keeps the game paused for a trainer: it needs --arena-port")
    try:
        parse_endpoint(server_endpoint)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--server") from None
    try:
        coach = Coach(server_endpoint, host=host, arena_port=arena_port, stop_after=stop_after,
                      connect_timeout_s=connect_timeout, idle=idle, keys=open_keys(keys))
    except SecurityError as exc:
        raise click.BadParameter(str(exc), param_hint="--keys") from None
    coach.install_signal_handlers()
    try:
        coach.connect()
    except (ConnectionError, SecurityError) as exc:
        coach.close()
        click.echo(f"keepaway coach: {exc}", err=True)
        sys.exit(2)
    if coach.bound_arena_port is not None:
        click.echo(f"keepaway coach arena=tcp://{host}:{coach.bound_arena_port}")
        sys.stdout.flush()
    coach.run()
    if as_json:
        click.echo(json.dumps(coach.summary()))


commands = [coach_command]

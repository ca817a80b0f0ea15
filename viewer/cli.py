"""``keepaway view`` and ``keepaway render``: the viewer package's part of the command line."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from keepaway.core.options import FiniteFloatRange
from keepaway.protocol.endpoints import parse_endpoint
from keepaway.protocol.security import is_loopback, keys_option, open_keys

FIELD_SIZE_TYPE = FiniteFloatRange(min=0.0, min_open=True)


def _read(path: Path, kwy: Path | None):
    from keepaway.server.game_log import read_rcg

    try:
        return read_rcg(path, kwy)
    except ValueError as exc:
        raise click.ClickException(str(exc)) from None


@click.command("view")
@click.argument("game_log", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--server", "monitor", default=None, metavar="tcp://HOST:PORT",
              help="Follow a running arena's monitor port instead of replaying a game log.")
@click.option("--host", default="127.0.0.1", show_default=True, help="Address the page is served on.")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True,
              help="Port of the page (0: a free port).")
@click.option("--kwy", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Episode log for a game log without referee messages [the .kwy beside it, if any].")
@click.option("--field-size", type=FIELD_SIZE_TYPE, default=20.0, show_default=True,
              help="Live: side of the arena's square region (m); a game log says its own.")
@keys_option
def view_command(game_log: Path | None, monitor: str | None, host: str, port: int, kwy: Path | None,
                 field_size: float, keys: Path | None) -> None:
    """Watch Keepaway in the browser: replay GAME_LOG (.rcg; play, pause, step, speed, jump to an
    episode) or follow a running arena (--server tcp://HOST:MONITORPORT).

    Prints the page's URL (http://HOST:PORT/) and serves it until Ctrl-C.
    """
    if (game_log is None) == (monitor is None):
        raise click.UsageError("give a game log to replay or --server tcp://HOST:PORT to follow, not both")
    try:
        from keepaway.viewer.app import LiveSource, ReplaySource, serve
    except ImportError as exc:
        raise click.ClickException(f"the viewer needs aiohttp ({exc}): pip install 'keepaway[view]'") from None
    if monitor is not None:
        try:
            parse_endpoint(monitor)
        except ValueError as exc:
            raise click.UsageError(f"--server: {exc}") from None
        source = LiveSource(monitor, (field_size, field_size), keys=open_keys(keys))
    else:
        source = ReplaySource(_read(game_log, kwy), game_log.name)

    if not is_loopback(host):  # the page only shows the game, but to anyone who can reach it
        click.echo(f"keepaway view: serving on {host}: anyone who can reach this port can watch the game; "
                   f"bind 127.0.0.1 to keep it to this machine", err=True)

    def announce(url: str) -> None:
        click.echo(f"keepaway view: {url}")
        sys.stdout.flush()

    try:
        serve(source, host, port, announce)
    except OSError as exc:
        raise click.ClickException(f"cannot serve on {host}:{port}: {exc.strerror or exc}") from None


@click.command("render")
@click.argument("game_log", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--episode", type=click.IntRange(min=1), default=1, show_default=True, help="Episode to draw (from 1).")
@click.option("-o", "--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Output file: .gif (Pillow) or .mp4 (pip install 'keepaway[render]').")
@click.option("--scale", type=FiniteFloatRange(min=2.0, max=200.0), default=24.0, show_default=True,
              help="Pixels per metre.")
@click.option("--fps", type=FiniteFloatRange(min=1.0, max=100.0), default=10.0, show_default=True,
              help="Frames per second (10: real time).")
@click.option("--kwy", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Episode log for a game log without referee messages [the .kwy beside it, if any].")
def render_command(game_log: Path, episode: int, out: Path, scale: float, fps: float, kwy: Path | None) -> None:
    """Draw one episode of GAME_LOG (.rcg) to a GIF or an MP4, for papers and slides."""
    from keepaway.viewer.render import render

    record = _read(game_log, kwy)
    try:
        count = render(record, episode, out, scale, fps)
    except (ValueError, RuntimeError) as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"keepaway render: episode {episode}, {count} frames -> {out}")


commands = [view_command, render_command]

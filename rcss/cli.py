"""``keepaway rcss-front``: the rcssserver-protocol front as a process of its own, between rcssserver's UDP
text clients and a running server's players port (``keepaway server --rcss-port`` runs the same front in
the server's process; docs/protocol.md §16)."""

from __future__ import annotations

import signal
import sys
import threading
from typing import Any

import click

from keepaway.core.options import configure_logging
from keepaway.protocol.endpoints import DEFAULT_PORTS, parse_endpoint
from keepaway.protocol.security import SecurityError, keys_option, open_keys

DEFAULT_SERVER = f"tcp://127.0.0.1:{DEFAULT_PORTS['players']}"


@click.command("rcss-front")
@click.option("--server", "server", default=DEFAULT_SERVER, show_default=True,
              help="The players endpoint of the keepaway server to seat the text clients at.")
@click.option("--host", default="127.0.0.1", show_default=True, help="UDP bind address.")
@click.option("--port", type=click.IntRange(0, 65535), default=6000, show_default=True,
              help="UDP port of the clients' (init ...) (rcssserver's player port; 0 = free port).")
@keys_option
@click.option("-v", "--verbose", count=True, help="More log output (-v info, -vv debug).")
def rcss_front_command(server: str, host: str, port: int, keys: Any, verbose: int) -> None:
    """Seat rcssserver's UDP text clients (the keepaway-0.6 C++ players, any rcssserver client of protocol
    versions 8-19) at a keepaway server. Prints one line with the bound port, then logs to stderr."""
    from keepaway.rcss.front import FrontConfig, serve

    configure_logging(verbose)
    try:
        parse_endpoint(server)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--server") from None
    try:
        key_dir = open_keys(keys)
    except SecurityError as exc:
        raise click.BadParameter(str(exc), param_hint="--keys") from None
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())

    def announce(bound: int) -> None:
        click.echo(f"keepaway rcss-front listening rcss=udp://{host}:{bound} server={server}")
        sys.stdout.flush()

    try:
        serve(FrontConfig(server=server, host=host, port=port, keys=key_dir), stop.is_set, announce)
    except OSError as exc:
        raise click.ClickException(f"cannot bind udp://{host}:{port}: {exc.strerror or exc}") from None


commands = [rcss_front_command]

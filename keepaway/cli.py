"""The ``keepaway`` command: one click group, each package contributes its subcommands."""

from __future__ import annotations

import click


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="keepaway")
def main() -> None:
    """RoboCup Keepaway: server, players, coach and trainer over ZeroMQ."""


def _register() -> None:
    from server.cli import commands as server_commands
    from agents.cli import commands as agent_commands

    for command in server_commands + agent_commands:
        main.add_command(command)


_register()

"""The ``keepaway`` command: one click group, each package contributes its subcommands."""

from __future__ import annotations

import click


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="keepaway")
def main() -> None:
    """RoboCup Keepaway: server, players, coach and trainer over ZeroMQ."""


def _register() -> None:
    from agents.cli import commands as agent_commands
    from coach.cli import commands as coach_commands
    from protocol.security import keys_command
    from runner.cli import commands as runner_commands
    from server.cli import commands as server_commands
    from trainer.experiment_cli import commands as experiment_commands
    from trainer.train_cli import commands as train_commands
    from viewer.cli import commands as viewer_commands

    for command in (server_commands + agent_commands + coach_commands + runner_commands + train_commands
                    + experiment_commands + viewer_commands + [keys_command]):
        main.add_command(command)


_register()

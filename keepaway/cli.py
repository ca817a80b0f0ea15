"""The ``keepaway`` command: one click group, each package contributes its subcommands."""

from __future__ import annotations

import sys

import click

from keepaway.core.exits import EXIT_INTERRUPTED


class _Keepaway(click.Group):
    """The group, with one answer to an interrupt that no command took itself (say, during a command's
    start-up): one line and exit code 130, where click would print "Aborted!" and exit 1, the code of a
    failure. The commands that run for long (``run``, ``train``, ``experiment``, ...) catch it first and
    say what they kept."""

    def invoke(self, ctx: click.Context) -> object:
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            name = f"keepaway {ctx.invoked_subcommand}" if ctx.invoked_subcommand else "keepaway"
            click.echo(f"{name}: interrupted", err=True)
            sys.exit(EXIT_INTERRUPTED)


@click.group(cls=_Keepaway, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="keepaway")
def main() -> None:
    """RoboCup Keepaway: server, players, coach and trainer over ZeroMQ."""


def _register() -> None:
    from keepaway.agents.cli import commands as agent_commands
    from keepaway.coach.cli import commands as coach_commands
    from keepaway.protocol.security import keys_command
    from keepaway.rcss.cli import commands as rcss_commands
    from keepaway.runner.cli import commands as runner_commands
    from keepaway.server.cli import commands as server_commands
    from keepaway.trainer.experiment_cli import commands as experiment_commands
    from keepaway.trainer.train_cli import commands as train_commands
    from keepaway.viewer.cli import commands as viewer_commands

    for command in (server_commands + agent_commands + coach_commands + runner_commands + train_commands
                    + experiment_commands + viewer_commands + rcss_commands + [keys_command]):
        main.add_command(command)


try:
    _register()
except KeyboardInterrupt:  # Ctrl-C while the commands' modules load, the command line's first half-second
    click.echo("keepaway: interrupted", err=True)
    sys.exit(EXIT_INTERRUPTED)

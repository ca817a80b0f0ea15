"""Our atomic commands as rcssserver's command text: ``AtomicCommand("dash", (100.0, 0.0))`` ->
``(dash 100 0)`` (rcssserver ``player_command_parser.ypp``, ``player_command_tok.lpp``)."""

from __future__ import annotations

from keepaway.protocol.messages import AtomicCommand


def _number(value: float) -> str:
    """A number as rcssserver's lexer reads it back exactly: an integral value as an integer, any other as
    Python's shortest round-trip form (``0.1``, ``1e-05``)."""
    if float(value).is_integer() and abs(value) < 2**53:
        return str(int(value))
    return repr(float(value))


def command_text(command: AtomicCommand) -> str:
    """One command: numbers exact, a say's message quoted, the other words (a view width) as they are."""
    args = " ".join(f'"{arg}"' if command.name == "say" else arg if isinstance(arg, str) else _number(arg)
                    for arg in command.args)
    return f"({command.name} {args})" if args else f"({command.name})"


def commands_text(commands: tuple[AtomicCommand, ...]) -> str:
    """Several commands in one text, as one datagram carries them: ``(dash 100 0)(turn_neck -19)``."""
    return "".join(command_text(command) for command in commands)

"""Our atomic commands as rcssserver's command text: ``AtomicCommand("dash", (100.0, 0.0))`` ->
``(dash 100 0)`` (rcssserver ``player_command_parser.ypp``, ``player_command_tok.lpp``)."""

from __future__ import annotations

from keepaway.protocol.messages import AtomicCommand


def command_text(command: AtomicCommand) -> str:
    """One command: a say's message quoted, a word (a view width) as it is, a number as rcssserver's lexer
    reads it back exactly (an integral value as an integer, any other in Python's shortest round-trip form,
    ``0.1``, ``1e-05``)."""
    words = [command.name]
    for arg in command.args:
        if command.name == "say":
            words.append(f'"{arg}"')
        elif isinstance(arg, str):
            words.append(arg)
        elif float(arg).is_integer() and abs(arg) < 2**53:
            words.append(str(int(arg)))
        else:
            words.append(repr(float(arg)))
    return f"({' '.join(words)})"


def commands_text(commands: tuple[AtomicCommand, ...]) -> str:
    """Several commands in one text, as one datagram carries them: ``(dash 100 0)(turn_neck -19)``."""
    return "".join(command_text(command) for command in commands)

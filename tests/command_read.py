"""What the server's kernel reads of a command frame (``server.command_frame.read_command_frame``), in the
full decoder's terms, for the tests that compare the two (``test_command_frame.py``, ``test_command_wire.py``)."""

from __future__ import annotations

from typing import NamedTuple

from keepaway.server.command_frame import (
    COMMAND_NAMES,
    MAX_FRAME_BYTES,
    SAY,
    TEXT_COMMAND,
    CommandBuffer,
    read_command_frame,
)


class Read(NamedTuple):
    """A command frame as the kernel read it, in the decoder's terms: ``Command``'s fields, each command
    an (name, args) pair as an ``AtomicCommand`` unpacks."""

    cycle: int
    commands: tuple[tuple[str, tuple], ...]
    getopen: tuple[float, ...]


BUFFER = CommandBuffer.empty()


def read(frame: bytes) -> Read | None:
    """What the kernel reads of ``frame`` (:class:`Read`); None if it leaves the frame to the full decoder."""
    if len(frame) > MAX_FRAME_BYTES:
        return None
    cycle, count, noted = read_command_frame(frame, len(frame), BUFFER)
    if cycle < 0:
        return None
    commands = []
    for (code, n_args, start, length), args in zip(BUFFER.command[:count].tolist(), BUFFER.args[:count].tolist()):
        if code == SAY:
            commands.append((TEXT_COMMAND, (frame[start:start + length].decode("ascii"),)))
        else:
            commands.append((COMMAND_NAMES[code], tuple(args[:n_args])))
    return Read(cycle, tuple(commands), tuple(BUFFER.note[:noted].tolist()))

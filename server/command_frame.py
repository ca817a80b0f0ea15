"""A player's ``command`` frame straight from its msgpack bytes to the server's command slots, compiled.

The server of the distributed mode is one thread, and every cycle each player sends it one command
frame. Through the full decoder a frame goes msgpack -> dicts and lists -> the loaders of
``protocol.messages.Command`` and ``_atomic_command``, Python all the way: about 18 us a frame, nearly
a hundred of every cycle's microseconds with five players. :func:`read_command_frame` reads the same
bytes once, in a kernel (on ``core.msgpack_in``'s readers, as the players read their sees:
``agents.frames``), into a :class:`CommandBuffer`: the ``Command``'s cycle, its commands as codes and
numbers, its GetOpen note; ``server.command_slots.take_command_frame`` takes the commands into the
arena's slots in the same call (``Arena.submit_frame``). The server and the embedded mode then treat
a frame alike whichever path decoded it: one ``bad_cycle`` check, one set of slot rules.

The kernel takes exactly the command frames that the full decoder takes as they are: a map of
``type`` ``"command"``, ``cycle`` (an int in the cycle range) and optionally ``commands`` and
``getopen``, each key once and no other; at most ``MAX_COMMANDS`` commands, each an array of a name of
``COMMAND_ARGUMENTS`` whose arguments are all numbers (dash, turn, kick, turn_neck, tackle, move, catch,
done), with as many arguments as the table allows, or ``say`` with an ASCII str of at most
``MAX_SAY_CHARS``; numbers are finite doubles or ints within ``MAX_EXACT_INT`` (taken as floats, as
``protocol.codec.number`` takes them); a GetOpen note of the shape ``getopen_note`` allows. Any other
frame, valid or not (``change_view``, a float32, a non-ASCII say, a duplicate key, a bool for a
number, trailing bytes, ...), is refused, and the server gives it to the full decoder, which takes it
or reports what is wrong exactly as before (``tests/test_command_frame.py`` checks every command of a
game, variants and corrupted frames against it).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from keepaway.core.jit import borrowing
from keepaway.core.msgpack_in import BAD, ascii, read_array, read_double, read_int, read_map, read_str, str_equals
from keepaway.core.msgpack_out import FLOAT64
from keepaway.protocol import messages as m
from keepaway.protocol.codec import MAX_EXACT_INT, number
from keepaway.protocol.messages import (
    COMMAND_ARGUMENTS,
    MAX_COMMANDS,
    MAX_CYCLE,
    MAX_NOTE_NUMBERS,
    MAX_SAY_CHARS,
)

TEXT_COMMAND = "say"
"""The one command with a text argument the kernel reads (``text(MAX_SAY_CHARS)`` in the table)."""

COMMAND_NAMES: tuple[str, ...] = tuple(
    name for name, (required, extra) in COMMAND_ARGUMENTS.items()
    if name == TEXT_COMMAND or all(load is number for load in required + extra)
)
"""The commands the kernel reads, its command codes being their indices: those whose every argument is
a ``number``, and ``say``."""

_FEWEST = np.array([len(COMMAND_ARGUMENTS[name][0]) for name in COMMAND_NAMES], dtype=np.int64)
_MOST = np.array([sum(map(len, COMMAND_ARGUMENTS[name])) for name in COMMAND_NAMES], dtype=np.int64)
SAY = COMMAND_NAMES.index(TEXT_COMMAND)
assert _FEWEST[SAY] == _MOST[SAY] == 1, "the kernel reads say's one text argument"
_NAME_BYTES = ascii("".join(COMMAND_NAMES))  # the names end to end, name i at _NAME_START[i]:[i + 1]
_NAME_START = np.cumsum([0] + [len(name) for name in COMMAND_NAMES]).astype(np.int64)
MAX_ARGUMENTS = int(_MOST.max())

_KEY_TYPE, _KEY_CYCLE = ascii("type"), ascii("cycle")
_KEY_COMMANDS, _KEY_GETOPEN = ascii("commands"), ascii("getopen")
_COMMAND = ascii(m.Command.TYPE)
_MAX_DOUBLE = np.finfo(np.float64).max
_ASCII_END = 0x80
# No frame the kernel takes is longer (every header and number in its widest form): longer frames
# are refused unread.
_HEADER, _NUMBER = 5, 9
MAX_FRAME_BYTES = (
    _HEADER + 4 * (_HEADER + len("commands")) + _HEADER + len(m.Command.TYPE) + _NUMBER
    + _HEADER + MAX_COMMANDS * (_HEADER + _HEADER + max(map(len, COMMAND_NAMES))
                                + max(MAX_ARGUMENTS * _NUMBER, _HEADER + MAX_SAY_CHARS))
    + _HEADER + MAX_NOTE_NUMBERS * _NUMBER
)


class CommandBuffer(NamedTuple):
    """What the kernel read of a frame's commands and note: command i is ``COMMAND_NAMES[code]`` with
    ``args[i, :n_args]``, or for ``say`` the text at ``frame[start:start + length]``, where
    ``command[i]`` is (code, n_args, start, length). ``Arena.submit`` writes a decoded ``Command``'s
    commands into one for the slot rules' kernel (``server.command_slots``)."""

    command: np.ndarray  # (MAX_COMMANDS, 4) int64
    args: np.ndarray  # (MAX_COMMANDS, MAX_ARGUMENTS) float64
    note: np.ndarray  # (MAX_NOTE_NUMBERS,) float64

    @classmethod
    def empty(cls) -> CommandBuffer:
        return cls(np.zeros((MAX_COMMANDS, 4), np.int64), np.zeros((MAX_COMMANDS, MAX_ARGUMENTS)),
                   np.zeros(MAX_NOTE_NUMBERS))


@borrowing
def _number(buf, n, end) -> tuple:
    """A finite double, or an int of at most MAX_EXACT_INT in magnitude as a float (``codec.number``)."""
    if n < end and buf[n] == FLOAT64:
        value, n = read_double(buf, n, end)
        if n == BAD or not -_MAX_DOUBLE <= value <= _MAX_DOUBLE:
            return 0.0, BAD
        return value, n
    whole, n = read_int(buf, n, end)
    if n == BAD or not -MAX_EXACT_INT <= whole <= MAX_EXACT_INT:
        return 0.0, BAD
    return float(whole), n


@borrowing
def _command_code(buf, start, length) -> int:
    """The code of the command named by the str at ``buf[start:start + length]``; -1 for another name."""
    for code in range(len(_NAME_START) - 1):
        first = _NAME_START[code]
        if _NAME_START[code + 1] - first != length:
            continue
        same = True
        for i in range(length):
            if buf[start + i] != _NAME_BYTES[first + i]:
                same = False
                break
        if same:
            return code
    return -1


@borrowing
def _say_text(buf, n, end) -> tuple:
    """(start, length, next) of an ASCII str of at most MAX_SAY_CHARS (as many characters as bytes)."""
    start, length, n = read_str(buf, n, end)
    if n == BAD or length > MAX_SAY_CHARS:
        return 0, 0, BAD
    for i in range(length):
        if buf[start + i] >= _ASCII_END:
            return 0, 0, BAD
    return start, length, n


@borrowing
def _commands(buf, n, end, out) -> tuple:
    """(count, next): the ``commands`` array into ``out``."""
    count, n = read_array(buf, n, end)
    if n == BAD or count > MAX_COMMANDS:
        return 0, BAD
    for i in range(count):
        size, n = read_array(buf, n, end)
        if n == BAD or size < 1:
            return 0, BAD
        start, length, n = read_str(buf, n, end)
        if n == BAD:
            return 0, BAD
        code = _command_code(buf, start, length)
        given = size - 1
        if code < 0 or not _FEWEST[code] <= given <= _MOST[code]:
            return 0, BAD
        out.command[i, 0] = code
        out.command[i, 1] = given
        if code == SAY:
            start, length, n = _say_text(buf, n, end)
            out.command[i, 2] = start
            out.command[i, 3] = length
            if n == BAD:
                return 0, BAD
        else:
            for k in range(given):
                value, n = _number(buf, n, end)
                if n == BAD:
                    return 0, BAD
                out.args[i, k] = value
    return count, n


@borrowing
def _note(buf, n, end, out) -> tuple:
    """(numbers, next): a GetOpen note into ``out.note``: [], [tx, ty] or [tx, ty] and triples."""
    size, n = read_array(buf, n, end)
    if n == BAD or size > MAX_NOTE_NUMBERS or size == 1 or (size > 2 and (size - 2) % 3):
        return 0, BAD
    for k in range(size):
        value, n = _number(buf, n, end)
        if n == BAD:
            return 0, BAD
        out.note[k] = value
    return size, n


@borrowing
def read_command_frame(buf: np.ndarray, end: int, out: CommandBuffer) -> tuple:
    """The command frame ``buf[:end]``: (cycle, commands, note numbers), the commands and the note in
    ``out``; cycle -1 if the frame is not one this kernel takes (module docstring), and then the caller
    decodes it in full."""
    fields, n = read_map(buf, 0, end)
    if n == BAD or not 2 <= fields <= 4:
        return -1, 0, 0
    seen = 0  # a bit per key, each once
    cycle = count = noted = 0
    for _ in range(fields):
        start, length, n = read_str(buf, n, end)
        if n == BAD:
            return -1, 0, 0
        if str_equals(buf, start, length, _KEY_TYPE):
            bit = 1
            start, length, n = read_str(buf, n, end)
            if n != BAD and not str_equals(buf, start, length, _COMMAND):
                n = BAD
        elif str_equals(buf, start, length, _KEY_CYCLE):
            bit = 2
            cycle, n = read_int(buf, n, end)
            if n != BAD and not 0 <= cycle <= MAX_CYCLE:
                n = BAD
        elif str_equals(buf, start, length, _KEY_COMMANDS):
            bit = 4
            count, n = _commands(buf, n, end, out)
        elif str_equals(buf, start, length, _KEY_GETOPEN):
            bit = 8
            noted, n = _note(buf, n, end, out)
        else:
            return -1, 0, 0
        if n == BAD or seen & bit:
            return -1, 0, 0
        seen |= bit
    if n != end or seen & 3 != 3:  # trailing bytes, or no type or cycle: the full decoder reports them
        return -1, 0, 0
    return cycle, count, noted


__all__ = ["COMMAND_NAMES", "CommandBuffer", "MAX_FRAME_BYTES", "SAY", "TEXT_COMMAND", "read_command_frame"]

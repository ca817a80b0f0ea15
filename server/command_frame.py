"""A player's ``command`` frame straight from its msgpack bytes to the server's command slots, compiled.

The server of the distributed mode is one thread, and every cycle each player sends it one command
frame. Through the full decoder a frame goes msgpack -> dicts and lists -> the loaders of
``protocol.messages.Command`` and ``_atomic_command``, Python all the way: about 18 us a frame, nearly
a hundred of every cycle's microseconds with five players. :class:`CommandReader` reads the same bytes
once, in a kernel (:func:`read_command_frame`, on ``core.msgpack_in``'s readers, as the players read
their sees: ``agents.frames``), into a :class:`CommandFrame`: the decoded ``Command``'s cycle, note
and commands, these as the (name, args) pairs an ``AtomicCommand`` unpacks to. The server and the
embedded mode then take either alike: one ``bad_cycle`` check, one ``Arena.submit`` and its slot rules,
whichever path decoded the frame.

The kernel takes exactly the command frames that the full decoder takes as they are: a map of
``type`` ``"command"``, ``cycle`` (an int in the cycle range) and optionally ``commands`` and
``getopen``, each key once and no other; at most ``MAX_COMMANDS`` commands, each an array of a name of
``COMMAND_ARGUMENTS`` whose arguments are all numbers (dash, turn, kick, turn_neck, tackle, move, catch,
done), with as many arguments as the table allows, or ``say`` with an ASCII str of at most
``MAX_SAY_CHARS``; numbers are finite doubles or ints within ``MAX_EXACT_INT`` (taken as floats, as
``protocol.codec.number`` takes them); a GetOpen note of the shape ``getopen_note`` allows. Any other
frame, valid or not (``change_view``, a float32, a non-ASCII say, a duplicate key, a bool for a
number, trailing bytes, ...), is refused, and :meth:`CommandReader.decode` gives it to the full
decoder, which takes it or reports what is wrong exactly as before (``tests/test_command_frame.py``
checks every command of a game, variants and corrupted frames against it).
"""

from __future__ import annotations

from typing import NamedTuple, Union

import numpy as np

from core.jit import SteadyCall, borrowing
from core.msgpack_in import BAD, ascii, read_array, read_double, read_int, read_map, read_str, str_equals
from core.msgpack_out import FLOAT64
from protocol import messages as m
from protocol.codec import MAX_EXACT_INT, number
from protocol.endpoints import DEFAULT_MAX_MESSAGE_BYTES
from protocol.messages import (
    COMMAND_ARGUMENTS,
    MAX_COMMANDS,
    MAX_CYCLE,
    MAX_NOTE_NUMBERS,
    MAX_SAY_CHARS,
    decode_from_player,
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
_SAY = COMMAND_NAMES.index(TEXT_COMMAND)
assert _FEWEST[_SAY] == _MOST[_SAY] == 1, "the kernel reads say's one text argument"
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


class CommandFrame(NamedTuple):
    """A command frame as the kernel read it: ``protocol.messages.Command``'s fields, each command an
    (name, args) pair as an ``AtomicCommand`` unpacks. Pairs, not messages: building the dataclasses
    took most of the fast path's time, and ``Arena.submit`` needs only the pairs."""

    cycle: int
    commands: tuple[tuple[str, tuple], ...]
    getopen: tuple[float, ...]


PlayerMessage = Union[m.Message, CommandFrame]
"""What :meth:`CommandReader.decode` gives: a decoded message, or a command frame the kernel read."""


class CommandBuffer(NamedTuple):
    """What the kernel read of a frame's commands and note: command i is ``COMMAND_NAMES[code]`` with
    ``args[i, :n_args]``, or for ``say`` the text at ``frame[start:start + length]``, where
    ``command[i]`` is (code, n_args, start, length). Two arrays for the commands, not five: the server
    takes them into Python every frame, a few hundred nanoseconds a ``tolist``."""

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
        if code == _SAY:
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


class CommandReader:
    """Decodes a player's frames with command frames read by :func:`read_command_frame` (module
    docstring): one per receiving loop, reusing its buffers."""

    def __init__(self, max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> None:
        self.max_bytes = max_bytes
        self._frame_bytes = min(max_bytes, MAX_FRAME_BYTES)  # the longest frame the kernel reads
        self._out = CommandBuffer.empty()
        self._read = SteadyCall(read_command_frame)

    def read(self, data: bytes) -> CommandFrame | None:
        """The command frame ``data`` as the full decoder decodes it (as pairs), if the kernel takes it;
        else None."""
        if type(data) is not bytes or len(data) > self._frame_bytes:
            return None
        out = self._out
        cycle, count, noted = self._read(data, len(data), out)
        if cycle < 0:
            return None
        commands = []
        for (code, n_args, start, length), args in zip(out.command[:count].tolist(), out.args[:count].tolist()):
            if code == _SAY:
                commands.append((TEXT_COMMAND, (data[start:start + length].decode("ascii"),)))
            else:
                commands.append((COMMAND_NAMES[code], tuple(args[:n_args])))
        return CommandFrame(cycle, tuple(commands), tuple(out.note[:noted].tolist()) if noted else ())

    def decode(self, data: bytes) -> PlayerMessage:
        """``protocol.messages.decode_from_player(data, max_bytes)``, but a command frame the kernel takes
        read by it (:meth:`read`): the same message (as a :class:`CommandFrame`), or the same
        ``ProtocolError``."""
        command = self.read(data)
        return decode_from_player(data, self.max_bytes) if command is None else command


__all__ = ["COMMAND_NAMES", "CommandBuffer", "CommandFrame", "CommandReader", "MAX_FRAME_BYTES", "PlayerMessage",
           "read_command_frame"]

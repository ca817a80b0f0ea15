"""A player's ``command`` frame written by a kernel, byte for byte as ``encode(protocol.messages.Command(...))``.

Every cycle each player answers with one command frame: its main command (dash, turn or kick), its neck's
turn, its say and, when the server asks for them, a GetOpen note. Built as ``AtomicCommand``\\ s and a
``Command``, then packed, that cost a keeper about 16 of its 49 us of a think (docs/design.md, "Processes
and sockets"). :func:`write_command` writes the same bytes from the decision's output arrays and the
say's codes into a buffer; ``tests/test_command_wire.py`` checks them against ``encode`` for every kind of
command, and ``tests/test_player_frames.py`` for every command of a game. A caller that wants the message decodes the
frame (``protocol.messages.decode_from_player``): the frame is the one definition of a player's command.
"""

from __future__ import annotations

import numpy as np

from keepaway.agents.say import CHAR_BYTES, MAX_CHARS, Talk
from keepaway.core.jit import borrowing
from keepaway.core.msgpack_out import (
    FLOAT_BYTES,
    MAX_ARRAY_HEADER_BYTES,
    MAX_INT_BYTES,
    packed,
    put_array,
    put_float,
    put_int,
    put_raw,
)
from keepaway.core.objects import CMD_DASH, CMD_KICK, CMD_TURN
from keepaway.protocol import messages as m
from keepaway.protocol.messages import MAX_NOTE_NUMBERS

MAIN_COMMANDS = {CMD_DASH: ("dash", 1), CMD_TURN: ("turn", 1), CMD_KICK: ("kick", 2)}
"""The main commands a player's decision gives, by code (``core.objects``): their names and how many of
the decision's two arguments they take."""

_CODES = max(MAIN_COMMANDS) + 1
# each main command's packed name, end to end (code c's at _NAME_START[c]:_NAME_START[c + 1]; empty for
# the codes that send none), and its number of arguments
_NAMES = [packed(MAIN_COMMANDS[c][0]) if c in MAIN_COMMANDS else np.zeros(0, np.uint8) for c in range(_CODES)]
_NAME_BYTES = np.concatenate(_NAMES)
_NAME_START = np.cumsum([0] + [len(name) for name in _NAMES]).astype(np.int64)
_N_ARGS = np.array([MAIN_COMMANDS[c][1] if c in MAIN_COMMANDS else -1 for c in range(_CODES)], dtype=np.int64)
# the frame's constant parts: the header of its map of four (in encode's order: type, cycle, commands,
# getopen) with the type and the cycle's key, the other keys, the neck's and the say's names
_HEAD = np.concatenate([np.array([0x84], np.uint8), packed("type"), packed(m.Command.TYPE), packed("cycle")])
_COMMANDS_KEY = packed("commands")
_GETOPEN_KEY = packed("getopen")
_TURN_NECK = packed("turn_neck")
_SAY = packed("say")
MAX_COMMAND_BYTES = (_HEAD.shape[0] + MAX_INT_BYTES + _COMMANDS_KEY.shape[0] + 4 * MAX_ARRAY_HEADER_BYTES
                     + _NAME_BYTES.shape[0] + 3 * FLOAT_BYTES + _TURN_NECK.shape[0] + _SAY.shape[0] + 1
                     + MAX_CHARS + _GETOPEN_KEY.shape[0] + MAX_ARRAY_HEADER_BYTES + MAX_NOTE_NUMBERS * FLOAT_BYTES)


@borrowing
def write_command(buf: np.ndarray, cycle: int, main: int, a1: float, a2: float, neck: float, talk: Talk, r: int,
                  note: np.ndarray, noted: int) -> int:
    """The command frame of ``cycle`` into ``buf`` (at least MAX_COMMAND_BYTES); returns its length. The
    commands: ``main`` with its first arguments of (a1, a2) if it is one of MAIN_COMMANDS, turn_neck
    ``neck``, and say row ``r``'s message of ``talk`` if it has one; the note ``note[:noted]``."""
    said_len = talk.said_len[r]
    n = put_raw(buf, 0, _HEAD)
    n = put_int(buf, n, cycle)
    n = put_raw(buf, n, _COMMANDS_KEY)
    n_args = _N_ARGS[main] if 0 <= main < _CODES else -1
    n = put_array(buf, n, 1 + (n_args >= 0) + (said_len > 0))
    if n_args >= 0:
        n = put_array(buf, n, 1 + n_args)
        for i in range(_NAME_START[main], _NAME_START[main + 1]):
            buf[n] = _NAME_BYTES[i]
            n += 1
        n = put_float(buf, n, a1)
        if n_args > 1:
            n = put_float(buf, n, a2)
    n = put_array(buf, n, 2)
    n = put_raw(buf, n, _TURN_NECK)
    n = put_float(buf, n, neck)
    if said_len > 0:
        n = put_array(buf, n, 2)
        n = put_raw(buf, n, _SAY)
        buf[n] = 0xA0 | said_len  # a fixstr: a say is at most MAX_CHARS (< 32) characters
        n += 1
        for i in range(said_len):
            buf[n] = CHAR_BYTES[talk.said[r, i]]
            n += 1
    n = put_raw(buf, n, _GETOPEN_KEY)
    n = put_array(buf, n, noted)
    for i in range(noted):
        n = put_float(buf, n, note[i])
    return n


__all__ = ["MAIN_COMMANDS", "MAX_COMMAND_BYTES", "write_command"]

"""agents.command_wire.write_command: a player's command frame written from its decision's numbers, byte for
byte as ``encode`` packs the ``Command`` made of them (the main command and its arguments, the neck's turn,
the say, the GetOpen note), and read back by the server's reader as that command."""

from __future__ import annotations

import math

import numpy as np
import pytest
from command_read import read

from keepaway.agents.command_wire import MAIN_COMMANDS, MAX_COMMAND_BYTES, write_command
from keepaway.agents.say import MAX_CHARS, NUM_CHARS, VALID_CHARS, new_talk
from keepaway.core.objects import CMD_DASH, CMD_KICK, CMD_NONE, CMD_TURN
from keepaway.protocol import encode
from keepaway.protocol import messages as m
from keepaway.protocol.messages import MAX_NOTE_NUMBERS, decode_from_player


def _reference(cycle, main, a1, a2, neck, codes, note) -> bytes:
    """The frame as the player built it before the kernel: AtomicCommands, a Command, encode."""
    commands = [m.AtomicCommand("turn_neck", (neck,))]
    if main in MAIN_COMMANDS:
        name, n_args = MAIN_COMMANDS[main]
        commands.insert(0, m.AtomicCommand(name, (a1, a2)[:n_args]))
    if len(codes):
        commands.append(m.AtomicCommand("say", ("".join(VALID_CHARS[c] for c in codes),)))
    return encode(m.Command(cycle=cycle, commands=tuple(commands), getopen=tuple(note)))


def _written(cycle, main, a1, a2, neck, codes, note) -> bytes:
    buf = np.zeros(MAX_COMMAND_BYTES, np.uint8)
    talk = new_talk(1)
    talk.said[0, :len(codes)] = codes
    talk.said_len[0] = len(codes)
    notes = np.zeros(MAX_NOTE_NUMBERS)
    notes[:len(note)] = note
    n = write_command(buf, cycle, main, a1, a2, neck, talk, 0, notes, len(note))
    return buf[:n].tobytes()


def test_every_kind_of_command_is_written_as_encode_packs_it():
    rng = np.random.default_rng(5)
    edges = [0.0, -0.0, 1.0, -180.0, 100.0, 1e-300, -1e300, 5e-324, math.pi]
    checked = 0
    for cycle in (0, 1, 127, 128, 255, 256, 65535, 65536, 2**31):
        for main in (CMD_NONE, CMD_DASH, CMD_TURN, CMD_KICK):
            for length in (0, 1, 5, MAX_CHARS):
                for note_length in (0, 2, 14, 17, MAX_NOTE_NUMBERS):
                    a1, a2, neck = rng.choice(edges), float(rng.normal() * 100), float(rng.uniform(-180, 180))
                    codes = rng.integers(0, NUM_CHARS, length)
                    note = rng.normal(size=note_length) * 50
                    expected = _reference(cycle, main, a1, a2, neck, codes, note)
                    assert _written(cycle, main, a1, a2, neck, codes, note) == expected
                    checked += 1
    assert checked == 9 * 4 * 4 * 5


@pytest.mark.parametrize("main", [CMD_NONE, CMD_DASH, CMD_KICK])
def test_the_server_reads_the_written_frame_as_the_command_it_decodes(main):
    codes = [1, 2, 40, 70]
    data = _written(77, main, 55.5, -12.25, 30.0, np.array(codes), (1.0, 2.0))
    command = decode_from_player(data)
    assert read(data) == (command.cycle, tuple((c.name, c.args) for c in command.commands),
                                          command.getopen)
    assert command.commands[-1] == m.AtomicCommand("say", ("12E<",)) == m.AtomicCommand("say", ("".join(
        VALID_CHARS[c] for c in codes),))

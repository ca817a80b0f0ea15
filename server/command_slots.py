"""The server's rules for a player's commands of a cycle (`server-physics.md` 1 "Commands"), compiled.

One main command (dash, turn, kick, tackle, move, catch) and one turn_neck per cycle, the first accepted
winning; under the classic parameters (``failed_kick_uses_slot`` off) a kick that cannot reach the ball
is not accepted and leaves the main slot free. A main slot is taken when its command code is not
``CMD_NONE`` and a neck slot when ``has_neck`` is set: ``Commands`` is the slots' only state, cleared
by the step. Says are counted here, and a say's text is checked here (:func:`say_allowed`: at most
``say_msg_size`` characters of :data:`SAY_ALPHABET`); queueing it for the listeners, the warning for a
dropped one and change_view are ``Arena``'s.

One definition for every path: :func:`take_command_frame` reads a command frame and takes its commands
in one kernel call, its says checked too (the server's and the embedded mode's every-cycle path: reading
the frame into Python pairs and applying the rules in Python took 17.7 us a frame, this 6.5);
``Arena.submit`` writes a decoded ``Command``'s numbers into the same buffer (:func:`put_command`) for
:func:`take_commands`, and so do the trace replays (``server.trace_replay``) with rcssserver's text
commands; the batched mode's players (``runner.batched.decide``) take their commands with
:func:`take_main` and :func:`take_neck`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from keepaway.core.jit import borrowing
from keepaway.core.objects import CMD_CATCH, CMD_DASH, CMD_KICK, CMD_MOVE, CMD_NONE, CMD_TACKLE, CMD_TURN
from keepaway.server.command_frame import COMMAND_NAMES, SAY, read_command_frame
from keepaway.server.physics import kick_possible
from keepaway.server.world import COUNT_SAY

MAIN_SLOT = {"dash": CMD_DASH, "turn": CMD_TURN, "kick": CMD_KICK, "tackle": CMD_TACKLE, "move": CMD_MOVE,
             "catch": CMD_CATCH}
"""The commands of the main slot, by name, and their ``Commands.main`` codes."""

SAY_ALPHABET = "[-0-9a-zA-Z ().+*/?<>_]"
"""The characters a say may use (spec 3 "say"), as a regular expression's class."""

DROPPED_SAY = -1
"""The code :func:`take_command_frame` gives a say that :func:`say_allowed` refuses, in its buffer."""

COMMAND_CODES = {name: code for code, name in enumerate(COMMAND_NAMES)}
"""The code of each command a ``CommandBuffer`` holds (``server.command_frame``)."""

_MAIN_CODE = np.array([MAIN_SLOT.get(name, CMD_NONE) for name in COMMAND_NAMES], dtype=np.int8)
_TURN_NECK = COMMAND_CODES["turn_neck"]
_SAY_BYTE = np.array([re.fullmatch(SAY_ALPHABET, chr(byte)) is not None for byte in range(256)])


@borrowing
def say_allowed(buf: np.ndarray, start: int, length: int, kp) -> bool:
    """Whether the say text ``buf[start:start + length]`` (bytes; ASCII: one a character) keeps the rules:
    at most ``say_msg_size`` characters, each of :data:`SAY_ALPHABET`."""
    if length > kp.say_msg_size:
        return False
    for i in range(start, start + length):
        if not _SAY_BYTE[buf[i]]:
            return False
    return True


def put_command(out, i: int, code: int, args: Sequence[float]) -> None:
    """Command ``i`` of ``out`` (a ``CommandBuffer``): ``code`` (:data:`COMMAND_CODES`) with the numbers
    ``args``, as :func:`take_commands` takes it (a say's text is the caller's: give a say no args)."""
    out.command[i, :2] = code, len(args)
    out.args[i, :len(args)] = args


@borrowing(inline="always")
def take_main(b: int, c, obj: int, code: int, arg1: float, arg2: float, w, kp) -> None:
    """Player ``obj``'s main command ``code`` into arena ``b``'s slots, if the slot is free and the
    command is accepted (a classic kick must reach the ball: ``physics.kick_possible``)."""
    if c.main[b, obj] != CMD_NONE:
        return
    if code == CMD_KICK and kp.failed_kick_uses_slot == 0.0 and not kick_possible(b, w, obj, kp):
        return
    c.main[b, obj] = code
    c.arg1[b, obj] = arg1
    c.arg2[b, obj] = arg2


@borrowing(inline="always")
def take_neck(b: int, c, obj: int, moment: float) -> None:
    """Player ``obj``'s turn_neck into arena ``b``'s slots, if it has none yet this cycle."""
    if not c.has_neck[b, obj]:
        c.has_neck[b, obj] = True
        c.neck[b, obj] = moment


@borrowing(inline="always")
def take_say(b: int, obj: int, w) -> None:
    """Player ``obj``'s say counted in arena ``b`` (sense_body's say count: every say the server takes,
    heard or not)."""
    w.counts[b, obj, COUNT_SAY] += 1


@borrowing
def take_commands(out, count: int, c, obj: int, w, kp) -> int:
    """The first ``count`` commands of ``out`` (a ``CommandBuffer``), player ``obj``'s, into the slots of
    the one arena of ``c`` and ``w``, in order; each say counted, and their number returned. Arguments a
    command does not give are 0 (``out`` keeps a longer command's numbers beyond them)."""
    says = 0
    for i in range(count):
        code = out.command[i, 0]
        given = out.command[i, 1]
        main = _MAIN_CODE[code]
        if main != CMD_NONE:
            take_main(0, c, obj, main, out.args[i, 0] if given > 0 else 0.0, out.args[i, 1] if given > 1 else 0.0,
                      w, kp)
        elif code == _TURN_NECK:
            take_neck(0, c, obj, out.args[i, 0])
        elif code == SAY:
            take_say(0, obj, w)
            says += 1
    return says


@borrowing
def take_command_frame(buf: np.ndarray, end: int, out, now: int, c, obj: int, w, kp) -> tuple:
    """The command frame ``buf[:end]`` read into ``out`` (``read_command_frame``) and, if its cycle is
    ``now`` or earlier, its commands taken (:func:`take_commands`) and its says checked
    (:func:`say_allowed`; a refused one's code in ``out`` becomes :data:`DROPPED_SAY`). Returns (cycle,
    commands, note numbers, says allowed, says dropped, the first allowed say's start and length in
    ``buf``): the caller queues the says, their texts being Python's; cycle -1 if the kernel does not read
    the frame (then nothing is taken: the caller decodes it in full)."""
    cycle, count, noted = read_command_frame(buf, end, out)
    allowed = dropped = first_start = first_length = 0
    if 0 <= cycle <= now and take_commands(out, count, c, obj, w, kp):
        for i in range(count):
            if out.command[i, 0] != SAY:
                continue
            if not say_allowed(buf, out.command[i, 2], out.command[i, 3], kp):
                out.command[i, 0] = DROPPED_SAY
                dropped += 1
                continue
            if allowed == 0:
                first_start, first_length = out.command[i, 2], out.command[i, 3]
            allowed += 1
    return cycle, count, noted, allowed, dropped, first_start, first_length


__all__ = ["COMMAND_CODES", "DROPPED_SAY", "MAIN_SLOT", "SAY_ALPHABET", "put_command", "say_allowed",
           "take_command_frame", "take_commands", "take_main", "take_neck", "take_say"]

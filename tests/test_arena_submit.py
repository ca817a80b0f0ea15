"""The server's rules for a player's commands of a cycle (``server.command_slots``, spec `server-physics.md`
1 "Commands", docs/protocol.md): one main command (dash, turn, kick, ...) and one turn_neck per cycle, the
first accepted winning; a kick that cannot reach the ball does not use the main slot under the classic
parameters (``failed_kick_uses_slot``) but does under the current ones; says and change_views are counted
and unlimited, a say that breaks the size or alphabet rule is dropped with a warning. These are the rules
every path to the arena goes through, so they are pinned here command by command through both: a decoded
``Command`` (``Arena.submit_command``) and a frame as the server and the embedded mode take it
(``Arena.submit_frame``: read and taken by the kernel, or decoded in full when the kernel leaves it, as a
change_view). A frame's cycle decides whether it is taken and whether its GetOpen note counts."""

from __future__ import annotations

import pytest

from keepaway.core.objects import BALL, CMD_DASH, CMD_KICK, CMD_NONE, CMD_TURN
from keepaway.protocol import encode
from keepaway.protocol import messages as m
from keepaway.protocol.params import parameter_set
from keepaway.server.arena import Arena
from keepaway.server.world import COUNT_CHANGE_VIEW, COUNT_SAY

KEEPER = 1  # object 1: keeper 1


def _arena(params: str = "classic", ball_at: float = 0.5) -> Arena:
    """An arena with every player connected and keeper 1 ``ball_at`` metres from the ball."""
    arena = Arena(parameter_set(params), keepers=3, takers=2, seed=0)
    for team in ["keepers"] * 3 + ["takers"] * 2:
        arena.connect(team)
    w = arena.world
    w.pos[0, KEEPER] = (0.0, 0.0)
    w.pos[0, BALL] = (ball_at, 0.0)
    return arena


def _slot(arena: Arena) -> tuple[int, float, float, float, bool]:
    """Keeper 1's queued main command, its two arguments, its turn_neck and whether it has one."""
    c = arena.commands
    return (int(c.main[0, KEEPER]), float(c.arg1[0, KEEPER]), float(c.arg2[0, KEEPER]),
            float(c.neck[0, KEEPER]), bool(c.has_neck[0, KEEPER]))


def _command(arena: Arena, commands: list[tuple[str, tuple]], cycle: int | None = None,
             getopen: tuple[float, ...] = ()) -> m.Command:
    return m.Command(cycle=arena.cycle if cycle is None else cycle,
                     commands=tuple(m.AtomicCommand(name, args) for name, args in commands), getopen=getopen)


def _decoded(arena: Arena, obj: int, commands: list[tuple[str, tuple]]) -> list[str]:
    return arena.submit_command(obj, _command(arena, commands))


def _frame(arena: Arena, obj: int, commands: list[tuple[str, tuple]]) -> list[str]:
    frame = encode(_command(arena, commands))
    taken = arena.submit_frame(obj, frame)
    if taken is None:  # left to the full decoder (change_view)
        assert any(name == "change_view" for name, _ in commands)
        return arena.submit_command(obj, m.decode_from_player(frame))
    assert taken[0] == arena.cycle
    return taken[1]


@pytest.fixture(params=[_decoded, _frame], ids=["decoded", "frame"])
def submit(request):
    """``submit(arena, obj, commands) -> warnings``, by one path to the slot rules."""
    return request.param


def test_the_first_main_command_and_the_first_turn_neck_of_a_cycle_win(submit):
    arena = _arena()
    assert submit(arena, KEEPER, [("dash", (80.0,)), ("turn_neck", (30.0,)), ("turn", (45.0,)),
                                 ("turn_neck", (-60.0,))]) == []
    # a later frame of the same cycle cannot take the slots either
    assert submit(arena, KEEPER, [("kick", (50.0, 10.0)), ("turn_neck", (5.0,))]) == []
    assert _slot(arena) == (CMD_DASH, 80.0, 0.0, 30.0, True)


def test_a_command_takes_its_own_arguments_and_zero_for_those_it_has_not(submit):
    arena = _arena()
    submit(arena, KEEPER, [("kick", (50.0, -20.0))])
    assert _slot(arena) == (CMD_KICK, 50.0, -20.0, 0.0, False)
    arena = _arena()
    submit(arena, KEEPER, [("turn", (-45.0,))])
    assert _slot(arena) == (CMD_TURN, -45.0, 0.0, 0.0, False)


def test_the_slots_are_free_again_after_the_step(submit):
    arena = _arena()
    submit(arena, KEEPER, [("dash", (80.0,)), ("turn_neck", (30.0,))])
    arena.step()
    assert _slot(arena) == (CMD_NONE, 0.0, 0.0, 0.0, False)
    submit(arena, KEEPER, [("turn", (10.0,)), ("turn_neck", (-10.0,))])
    assert _slot(arena) == (CMD_TURN, 10.0, 0.0, -10.0, True)


@pytest.mark.parametrize("params, uses_slot", [("classic", False), ("current", True)])
def test_a_kick_that_cannot_reach_the_ball_uses_the_slot_only_if_failed_kick_uses_slot(submit, params, uses_slot):
    arena = _arena(params, ball_at=10.0)
    submit(arena, KEEPER, [("kick", (100.0, 0.0)), ("dash", (60.0,))])
    assert _slot(arena)[:3] == ((CMD_KICK, 100.0, 0.0) if uses_slot else (CMD_DASH, 60.0, 0.0))


def test_a_kick_within_reach_uses_the_slot_under_either_parameter_set(submit):
    for params in ("classic", "current"):
        arena = _arena(params, ball_at=1.0)  # within 0.3 + 0.7 + 0.085 m
        submit(arena, KEEPER, [("kick", (100.0, 0.0)), ("dash", (60.0,))])
        assert _slot(arena)[:3] == (CMD_KICK, 100.0, 0.0)


def test_says_are_counted_and_queued_and_a_bad_one_is_dropped_with_a_warning(submit):
    arena = _arena()
    size = int(arena.params.say_msg_size)
    warnings = submit(arena, KEEPER, [("say", ("1aaaa18aa1"[:size],)), ("say", ("x" * (size + 1),)),
                                     ("say", ("bad!text",)), ("say", ("",)), ("say", ("ab\n",)),
                                     ("say", ("x" * size,))])
    assert warnings == [f"say dropped: at most {size} characters from [-0-9a-zA-Z ().+*/?<>_]"] * 3
    assert arena.pending_says == [(KEEPER, "1aaaa18aa1"[:size]), (KEEPER, ""), (KEEPER, "x" * size)]
    assert int(arena.world.counts[0, KEEPER, COUNT_SAY]) == 6  # every say counts, taken or not
    assert _slot(arena) == (CMD_NONE, 0.0, 0.0, 0.0, False)  # no slot used


def test_change_view_is_counted_sets_the_width_and_refuses_low_quality_with_a_warning(submit):
    arena = _arena()
    assert submit(arena, KEEPER, [("change_view", ("wide",))]) == []
    assert arena.slot(KEEPER).view_width == "wide"
    assert submit(arena, KEEPER, [("change_view", ("narrow", "low"))]) == [
        "change_view: low quality is not supported; the view stays high"]
    assert arena.slot(KEEPER).view_width == "narrow"
    assert int(arena.world.counts[0, KEEPER, COUNT_CHANGE_VIEW]) == 2


def test_one_players_commands_leave_the_others_slots_alone(submit):
    arena = _arena()
    submit(arena, KEEPER, [("dash", (80.0,)), ("turn_neck", (30.0,))])
    c = arena.commands
    for obj in range(2, arena.world.n_objects):
        assert int(c.main[0, obj]) == CMD_NONE and not bool(c.has_neck[0, obj])
    submit(arena, 2, [("turn", (15.0,))])  # keeper 2 has its own slot
    assert int(c.main[0, 2]) == CMD_TURN and _slot(arena)[0] == CMD_DASH


NOTE = (1.0, 2.0, 3.0, 4.0, 0.5)  # a target and one rated point


def test_a_frame_is_taken_up_to_its_cycle_and_its_note_counts_in_its_own_cycle_only():
    arena = _arena()
    later = encode(_command(arena, [("dash", (80.0,))], cycle=arena.cycle + 1, getopen=NOTE))
    assert arena.submit_frame(KEEPER, later) == (arena.cycle + 1, [])  # the server's bad_cycle
    assert _slot(arena) == (CMD_NONE, 0.0, 0.0, 0.0, False)
    arena.step()
    assert arena.step_notes == ()
    earlier = encode(_command(arena, [("dash", (80.0,)), ("say", ("x" * 200,))], cycle=arena.cycle - 1, getopen=NOTE))
    size = int(arena.params.say_msg_size)
    assert arena.submit_frame(KEEPER, earlier) == (arena.cycle - 1, [
        f"say dropped: at most {size} characters from [-0-9a-zA-Z ().+*/?<>_]"])  # taken, the note not
    assert _slot(arena)[:2] == (CMD_DASH, 80.0)
    arena.step()
    assert arena.step_notes == ()
    own = encode(_command(arena, [("turn", (5.0,))], getopen=NOTE))
    assert arena.submit_frame(KEEPER, own) == (arena.cycle, [])
    arena.step()
    assert arena.step_notes == ((1, NOTE),)


def test_a_decoded_command_is_taken_up_to_its_cycle_and_its_note_counts_in_its_own_cycle_only():
    arena = _arena()
    assert arena.submit_command(KEEPER, _command(arena, [("dash", (80.0,))], cycle=arena.cycle + 1,
                                                 getopen=NOTE)) == []
    assert _slot(arena) == (CMD_NONE, 0.0, 0.0, 0.0, False)
    arena.step()
    arena.submit_command(KEEPER, _command(arena, [("dash", (80.0,))], cycle=arena.cycle - 1, getopen=NOTE))
    assert _slot(arena)[:2] == (CMD_DASH, 80.0)
    arena.step()
    assert arena.step_notes == ()
    arena.submit_command(KEEPER, _command(arena, [("turn", (5.0,))], getopen=NOTE))
    arena.step()
    assert arena.step_notes == ((1, NOTE),)


def test_more_commands_than_a_frame_holds_are_all_taken_in_order():
    arena = _arena()
    says = [("say", (str(i),)) for i in range(2 * m.MAX_COMMANDS)]
    assert arena.submit(KEEPER, [*says, ("turn_neck", (7.0,)), ("turn", (3.0,)), ("dash", (1.0,))]) == []
    assert int(arena.world.counts[0, KEEPER, COUNT_SAY]) == 2 * m.MAX_COMMANDS
    assert arena.pending_says == [(KEEPER, text) for _, (text,) in says]
    assert _slot(arena) == (CMD_TURN, 3.0, 0.0, 7.0, True)

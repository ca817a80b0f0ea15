"""The server's rules for a player's commands of a cycle (``server.arena.Arena.submit``, spec
`server-physics.md` 1 "Commands", docs/protocol.md): one main command (dash, turn, kick, ...) and one
turn_neck per cycle, the first accepted winning; a kick that cannot reach the ball does not use the main
slot under the classic parameters (``failed_kick_uses_slot``) but does under the current ones; says and
change_views are counted and unlimited, a say that breaks the size or alphabet rule is dropped with a
warning. These are the rules every path to the arena goes through (the server's reader of command frames,
the decoded messages, the embedded mode), so they are pinned here directly, command by command."""

from __future__ import annotations

import pytest

from core.objects import BALL, CMD_DASH, CMD_KICK, CMD_NONE, CMD_TURN
from protocol.params import parameter_set
from server.arena import Arena
from server.world import COUNT_CHANGE_VIEW, COUNT_SAY

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


def test_the_first_main_command_and_the_first_turn_neck_of_a_cycle_win():
    arena = _arena()
    assert arena.submit(KEEPER, [("dash", (80.0,)), ("turn_neck", (30.0,)), ("turn", (45.0,)),
                                 ("turn_neck", (-60.0,))]) == []
    # a later frame of the same cycle cannot take the slots either
    assert arena.submit(KEEPER, [("kick", (50.0, 10.0)), ("turn_neck", (5.0,))]) == []
    assert _slot(arena) == (CMD_DASH, 80.0, 0.0, 30.0, True)


def test_a_command_takes_its_own_arguments_and_zero_for_those_it_has_not():
    arena = _arena()
    arena.submit(KEEPER, [("kick", (50.0, -20.0))])
    assert _slot(arena) == (CMD_KICK, 50.0, -20.0, 0.0, False)
    arena = _arena()
    arena.submit(KEEPER, [("turn", (-45.0,))])
    assert _slot(arena) == (CMD_TURN, -45.0, 0.0, 0.0, False)


def test_the_slots_are_free_again_after_the_step():
    arena = _arena()
    arena.submit(KEEPER, [("dash", (80.0,)), ("turn_neck", (30.0,))])
    arena.step()
    assert _slot(arena) == (CMD_NONE, 0.0, 0.0, 0.0, False)
    arena.submit(KEEPER, [("turn", (10.0,)), ("turn_neck", (-10.0,))])
    assert _slot(arena) == (CMD_TURN, 10.0, 0.0, -10.0, True)


@pytest.mark.parametrize("params, uses_slot", [("classic", False), ("current", True)])
def test_a_kick_that_cannot_reach_the_ball_uses_the_slot_only_if_failed_kick_uses_slot(params, uses_slot):
    arena = _arena(params, ball_at=10.0)
    arena.submit(KEEPER, [("kick", (100.0, 0.0)), ("dash", (60.0,))])
    assert _slot(arena)[:3] == ((CMD_KICK, 100.0, 0.0) if uses_slot else (CMD_DASH, 60.0, 0.0))


def test_a_kick_within_reach_uses_the_slot_under_either_parameter_set():
    for params in ("classic", "current"):
        arena = _arena(params, ball_at=1.0)  # within 0.3 + 0.7 + 0.085 m
        arena.submit(KEEPER, [("kick", (100.0, 0.0)), ("dash", (60.0,))])
        assert _slot(arena)[:3] == (CMD_KICK, 100.0, 0.0)


def test_says_are_counted_and_queued_and_a_bad_one_is_dropped_with_a_warning():
    arena = _arena()
    size = int(arena.params.say_msg_size)
    warnings = arena.submit(KEEPER, [("say", ("1aaaa18aa1"[:size],)), ("say", ("x" * (size + 1),)),
                                     ("say", ("bad!text",)), ("say", ("",))])
    assert warnings == [f"say dropped: at most {size} characters from [-0-9a-zA-Z ().+*/?<>_]"] * 2
    assert arena.pending_says == [(KEEPER, "1aaaa18aa1"[:size]), (KEEPER, "")]
    assert int(arena.world.counts[0, KEEPER, COUNT_SAY]) == 4  # every say counts, taken or not
    assert _slot(arena) == (CMD_NONE, 0.0, 0.0, 0.0, False)  # no slot used


def test_change_view_is_counted_sets_the_width_and_refuses_low_quality_with_a_warning():
    arena = _arena()
    assert arena.submit(KEEPER, [("change_view", ("wide",))]) == []
    assert arena.slot(KEEPER).view_width == "wide"
    assert arena.submit(KEEPER, [("change_view", ("narrow", "low"))]) == [
        "change_view: low quality is not supported; the view stays high"]
    assert arena.slot(KEEPER).view_width == "narrow"
    assert int(arena.world.counts[0, KEEPER, COUNT_CHANGE_VIEW]) == 2


def test_one_players_commands_leave_the_others_slots_alone():
    arena = _arena()
    arena.submit(KEEPER, [("dash", (80.0,)), ("turn_neck", (30.0,))])
    c = arena.commands
    for obj in range(2, arena.world.n_objects):
        assert int(c.main[0, obj]) == CMD_NONE and not bool(c.has_neck[0, obj])
    arena.submit(2, [("turn", (15.0,))])  # keeper 2 has its own slot
    assert int(c.main[0, 2]) == CMD_TURN and _slot(arena)[0] == CMD_DASH

"""A player's think, from what it heard to the frame of its command, in one kernel call.

At each think a player hears its teammates' says (``agents.say.hear_row``), writes its belief
(``agents.tracking.write_belief_row``), decides (``keeper_decide`` / ``taker_decide``), tells its world
model the commands it sends (they act in the next step) and composes its say (``agents.say.say_row``).
The batched mode runs these steps inside its chunk loop (``runner.batched.decide``, with its learners and
the server's slots between the decision and the rest). A player process called each step from Python, a
kernel call and its Python glue apiece: 24 us of a keeper's think, of which the kernels' own work is
less than half (docs/design.md, "A think in one kernel call"). :func:`think` runs them, and writes the
command's frame (``agents.command_wire.write_command``), in one call; :func:`decide_row` and
:func:`commit_row` are the steps both modes share, written once, and :func:`finish_row` sends a decision that
Python finished (a note, a learner's or an outside action) as :func:`think` sends its own.
"""

from __future__ import annotations

import numpy as np

from keepaway.agents.belief import AgentMemory, Belief, Decisions
from keepaway.agents.command_wire import write_command
from keepaway.agents.keeper import GETOPEN_DECISION, NO_PASS_DECISION, keeper_decide
from keepaway.agents.say import Talk, hear_row, say_row
from keepaway.agents.taker import taker_decide
from keepaway.agents.tracking import ModelState, sent_row, write_belief_row
from keepaway.core.jit import borrowing

NOT_WRITTEN = -1
""":func:`think`'s frame length when it wrote no frame: the decision is its caller's to finish."""


@borrowing(inline="always")
def decide_row(r: int, hear: bool, model: ModelState, talk: Talk, bel: Belief, mem: AgentMemory, theta, sums, kp, cfg,
               is_keeper: bool, out: Decisions) -> int:
    """Row ``r``'s decision on what it has heard (unless ``hear`` is false: the C++ ignores what it hears
    while it has the full state): its model written to belief row ``r`` and decided there into row ``r`` of
    ``out`` (a keeper's Pass state too). Returns ``keeper_decide``'s decision (NO_PASS_DECISION for a
    taker), also kept in ``out.decision``."""
    if hear:
        hear_row(r, model, bel.n_keepers, cfg, talk)
    write_belief_row(r, model, bel, r)
    if is_keeper:
        decision = keeper_decide(bel, r, mem, theta, sums, kp, cfg, out)
    else:
        taker_decide(bel, r, mem, sums, kp, cfg, out)
        decision = NO_PASS_DECISION
    out.decision[r] = decision
    return decision


@borrowing(inline="always")
def commit_row(r: int, model: ModelState, main: int, a1: float, a2: float, neck: float, n_keepers: int, kp, cfg,
               talk: Talk) -> None:
    """The commands model row ``r`` sends (main command ``main`` with its arguments ``a1``, ``a2``; turn_neck
    ``neck``), told to its world model (``sent_row``), and its say of this cycle."""
    sent_row(r, model, main, a1, a2, neck)
    say_row(r, model, main, a1, a2, n_keepers, kp, cfg, talk)


@borrowing
def finish_row(cycle: int, model: ModelState, talk: Talk, n_keepers: int, kp, cfg, out: Decisions, buf: np.ndarray,
               note: np.ndarray, noted: int) -> int:
    """The decision in row 0 of ``out`` sent: :func:`commit_row`, then the command's frame of ``cycle`` into
    ``buf`` with the GetOpen note ``note[:noted]``. Returns the frame's length."""
    main = np.int64(out.main[0])
    a1, a2, neck = out.arg1[0], out.arg2[0], out.neck[0]
    commit_row(0, model, main, a1, a2, neck, n_keepers, kp, cfg, talk)
    return write_command(buf, cycle, main, a1, a2, neck, talk, 0, note, noted)


@borrowing
def think(cycle: int, hear: bool, model: ModelState, talk: Talk, bel: Belief, mem: AgentMemory, theta, sums, kp,
          cfg, is_keeper: bool, out: Decisions, finish_pass: bool, finish: bool, buf: np.ndarray,
          note: np.ndarray) -> tuple[int, int]:
    """A player's think at ``cycle`` (row 0 of its model, belief and decisions): :func:`decide_row`, then,
    unless the decision is left to the caller, :func:`finish_row` with no GetOpen note. Left to the caller:
    every decision if ``finish`` is false (the caller adds a note), a Pass decision point if ``finish_pass``
    is false (an outside decision or a learner in Python), and the GetOpen decision of GETOPEN_EXTERNAL.
    Returns (decision, the frame's length or NOT_WRITTEN)."""
    decision = decide_row(0, hear, model, talk, bel, mem, theta, sums, kp, cfg, is_keeper, out)
    if not finish or decision == GETOPEN_DECISION or (decision != NO_PASS_DECISION and not finish_pass):
        return decision, NOT_WRITTEN
    return decision, finish_row(cycle, model, talk, bel.n_keepers, kp, cfg, out, buf, note, 0)  # no note


__all__ = ["NOT_WRITTEN", "commit_row", "decide_row", "finish_row", "think"]

"""The server's percepts, as their frames or as decoded messages, written into a player's world model.

A player process takes each ``see``, ``sense_body`` and ``fullstate`` (docs/rules.md §5) into row 0 of its
model's arrays (`agents/tracking.py`). Most go straight from their msgpack bytes (:func:`frame_row`:
``agents.frames.decode_frame`` and the model's kernel in one call); the others arrive decoded (a fullstate
always, a frame the kernel leaves to the full decoder), and :func:`see_into_buffer` writes a see as
``decode_frame`` writes its frame, :func:`fullstate_into_model` a fullstate's exact state.
``agents.worldmodel.WorldModel`` decides which percepts to take (none of a cycle a fullstate gave exactly).
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from keepaway.agents.frames import (
    EFFORT,
    HEAD_ANGLE,
    NO_SIDE,
    NO_UNUM,
    SEE,
    SENSE_BODY,
    SIDE_CODES,
    SPEED_AMOUNT,
    SPEED_DIRECTION,
    STAMINA,
    decode_frame,
)
from keepaway.agents.tracking import ModelState, SeeBuffer, see_row, sense_body_row
from keepaway.core.jit import borrowing
from keepaway.core.objects import BALL

# The largest frame on_frame's kernel reads (bytes): the server's sees, its largest per-cycle
# frames, are at most 3,444 bytes in 3v2, 4,991 in 11v11 (server.percept_wire.see_frame_bytes). A larger
# one is decoded in full.
FRAME_BYTES = 8192


@borrowing
def frame_row(buf, end: int, s: ModelState, see: SeeBuffer, flag_pos: np.ndarray, values: np.ndarray, exact_cycle: int,
              n_keepers: int, kp, cfg) -> tuple:
    """The frame ``buf[:end]`` read by ``agents.frames.decode_frame`` (a see into row 0 of ``see``, other
    values into ``values``) and, if it is a see or sense_body of another cycle than ``exact_cycle`` (a
    fullstate's), taken into model row 0 as :func:`see_row` and :func:`sense_body_row` take them; a hear's
    or think's values are left in ``values``. Returns decode_frame's (kind, cycle)."""
    kind, cycle = decode_frame(buf, end, 0, see, flag_pos.shape[0], values)
    if cycle != exact_cycle:
        if kind == SEE:
            see_row(0, s, see, flag_pos, n_keepers, kp, cfg)
        elif kind == SENSE_BODY:
            sense_body_row(0, s, cycle, values[SPEED_AMOUNT], values[SPEED_DIRECTION], int(values[HEAD_ANGLE]),
                           values[STAMINA], values[EFFORT], n_keepers, kp, cfg)
    return kind, cycle


def see_into_buffer(msg: Mapping[str, Any], buf: SeeBuffer, landmarks: int) -> None:
    """A see payload (docs/rules.md §5.2) in row 0 of ``buf``, as ``decode_frame`` writes a see's frame:
    anonymous flags are skipped, and so are flags whose id lies beyond init_ok's ``landmarks`` (the
    protocol allows ids up to 255: a server that sends one has no position for it); omitted fields
    become NaN."""
    flags = [f for f in msg["flags"] if f[0] is not None and f[0] < landmarks]
    n = len(flags)
    buf.n_flags[0] = n
    if n:
        rows = np.array([f[:3] for f in flags], dtype=np.float64)
        buf.flag_id[0, :n] = rows[:, 0]
        buf.flag_obs[0, :n] = rows[:, 1:]
    ball = msg["ball"]
    buf.ball_seen[0] = ball is not None
    if ball is not None:
        buf.ball_obs[0] = [np.nan if v is None else v for v in ball]
    players = msg["players"][: buf.player_obs.shape[1]]
    n = len(players)
    buf.n_players[0] = n
    if n:
        buf.player_side[0, :n] = [SIDE_CODES.get(p[0], NO_SIDE) for p in players]
        buf.player_unum[0, :n] = [NO_UNUM if p[1] is None else p[1] for p in players]
        buf.player_obs[0, :n] = [[np.nan if v is None else v for v in p[2:]] for p in players]
    buf.cycle[0] = int(msg["cycle"])


def fullstate_into_model(msg: Mapping[str, Any], s: ModelState, n_keepers: int) -> None:
    """A fullstate payload (docs/rules.md §5.4) in row 0 of ``s``: every object known exactly at the
    message's cycle, seen and observed then, and my stamina and effort."""
    cycle = int(msg["cycle"])
    me = s.me[0]
    s.time[0] = cycle
    s.pos[0, BALL] = msg["ball"][:2]
    s.vel[0, BALL] = msg["ball"][2:4]
    for p in msg["players"]:
        obj = p[1] if p[0] == "l" else n_keepers + p[1]
        s.pos[0, obj] = p[2:4]
        s.vel[0, obj] = p[4:6]
        s.body[0, obj] = p[6]
        s.neck[0, obj] = p[7]
        if obj == me:
            s.stamina[0] = p[8]
            s.effort[0] = p[9]
    s.seen[0, :] = cycle
    s.obs_pos[0] = s.pos[0]
    s.obs_time[0, :] = cycle
    s.ball_chg[0] = cycle
    s.err[0, :] = 0.0


__all__ = ["FRAME_BYTES", "frame_row", "fullstate_into_model", "see_into_buffer"]

"""A player process's world model: its percepts in, its belief out (docs/players.md §4).

:class:`WorldModel` holds one row of the world model's arrays (B = 1; the kernels are `agents/tracking.py`'s,
which the batched mode runs on a row per player) and takes each of the server's percepts into it, from the
frame's bytes (``on_frame``) or as a decoded message (``on_see``, ``on_sense_body``, ``on_fullstate``), as
`agents/percept_wire.py` writes them. The decisions read :meth:`WorldModel.belief`.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from keepaway.agents.belief import Belief, empty_belief
from keepaway.agents.config import AgentConfig
from keepaway.agents.frames import FRAME_VALUES, NOT_TAKEN, SIDE_CODES
from keepaway.agents.percept_wire import FRAME_BYTES, frame_row, fullstate_into_model, see_into_buffer
from keepaway.agents.tracking import (
    forget_row,
    hold_exact_ball_row,
    new_model_state,
    new_see_buffer,
    see_row,
    sense_body_row,
    sent_row,
    write_belief_row,
)
from keepaway.core.jit import SteadyCall
from keepaway.protocol.params import ServerParams


class WorldModel:
    """The world model of one player process (B = 1): feed it the decoded percepts of each cycle and
    the commands sent, read :meth:`belief` before deciding.

    ``flags`` is the landmark table of ``init_ok`` (``[[name, x, y], ...]``): see flag ids index it.
    Keepers are side 'l', takers side 'r' (docs/players.md §1); ``me`` follows `core/objects.py`.
    ``config``: the players' settings (default ``AgentConfig()``), of which the ball rules use
    ``player_conf_threshold``.
    """

    def __init__(self, params: ServerParams, side: str, unum: int, n_keepers: int, n_takers: int,
                 flags: Sequence[Sequence[Any]], config: AgentConfig | None = None) -> None:
        if side not in SIDE_CODES:
            raise ValueError(f"unknown side {side!r}")
        limit = n_keepers if side == "l" else n_takers
        if not 1 <= unum <= limit:
            raise ValueError(f"no player {side} {unum} with {n_keepers} keepers and {n_takers} takers")
        self.kp = params.kernel()
        self.cfg = (config or AgentConfig()).kernel()
        self.n_keepers = n_keepers
        self.n_takers = n_takers
        self.me = unum if side == "l" else n_keepers + unum
        self.flag_pos = np.array([[f[1], f[2]] for f in flags], dtype=np.float64).reshape(-1, 2)
        # read-only like protocol.landmarks.FLAG_POSITIONS, which the batched mode passes: numba types
        # the two alike, so both modes load one compiled see_row
        self.flag_pos.setflags(write=False)
        self.state = new_model_state(1, n_keepers, n_takers, self.me, params)
        self.see_buffer = new_see_buffer(1, len(self.flag_pos), 1 + n_keepers + n_takers)
        self.belief_rows = empty_belief(1, n_keepers, n_takers)  # what belief() writes (and agents.think)
        self._exact_cycle = -1
        # the kernels of every percept, called without numba's typing of their arguments at each call
        self._sense_body_row = SteadyCall(sense_body_row)
        self._see_row = SteadyCall(see_row)
        self._hold_exact_ball_row = SteadyCall(hold_exact_ball_row)
        self._write_belief_row = SteadyCall(write_belief_row)
        self._frame_row = SteadyCall(frame_row)
        self.frame_values = np.zeros(FRAME_VALUES)  # the values of the last frame on_frame read

    def _is_exact(self, msg: Mapping[str, Any]) -> bool:
        """Whether a fullstate already gave the exact state of the message's cycle."""
        return int(msg["cycle"]) == self._exact_cycle

    def on_sense_body(self, msg: Mapping[str, Any]) -> None:
        """A sense_body payload (docs/rules.md §5.3): my neck, velocity, stamina and effort of its cycle."""
        cycle = int(msg["cycle"])
        if cycle == self._exact_cycle:
            return
        speed, stamina = msg["speed"], msg["stamina"]
        self._sense_body_row(0, self.state, cycle, float(speed[0]), float(speed[1]), int(msg["head_angle"]),
                             float(stamina[0]), float(stamina[1]), self.n_keepers, self.kp, self.cfg)

    def on_see(self, msg: Mapping[str, Any]) -> None:
        """A see payload (docs/rules.md §5.2), written into the see buffer (``see_into_buffer``) and taken."""
        if self._is_exact(msg):
            return
        see_into_buffer(msg, self.see_buffer, len(self.flag_pos))
        self._see_row(0, self.state, self.see_buffer, self.flag_pos, self.n_keepers, self.kp, self.cfg)

    def on_frame(self, data: bytes) -> tuple[int, int]:
        """A frame's msgpack bytes, read by ``agents.frames.decode_frame`` if it is in the form that kernel
        takes (every see, sense_body, player's hear and think the server sends is), in one kernel call
        (``agents.percept_wire.frame_row``): returns (kind, cycle), the kind an index of
        ``agents.frames.FRAME_TYPES``. A see or sense_body is taken as :meth:`on_see` or
        :meth:`on_sense_body` takes the decoded message; a hear's or think's values are left in
        :attr:`frame_values` for the agent. Returns (``NOT_TAKEN``, -1) for any other frame, which is then
        the caller's to decode in full, and this model is as it was but for the see buffer's scratch."""
        if type(data) is not bytes:
            data = bytes(data)  # the kernel takes the frame as bytes (core.msgpack_in)
        size = len(data)
        if size > FRAME_BYTES:
            return NOT_TAKEN, -1
        return self._frame_row(data, size, self.state, self.see_buffer, self.flag_pos, self.frame_values,
                               self._exact_cycle, self.n_keepers, self.kp, self.cfg)

    def on_fullstate(self, msg: Mapping[str, Any]) -> None:
        """Exact state (docs/rules.md §5.4): every object known exactly at the message's cycle
        (``fullstate_into_model``); percepts of the same cycle are then ignored."""
        self._exact_cycle = int(msg["cycle"])
        fullstate_into_model(msg, self.state, self.n_keepers)
        self._hold_exact_ball_row(0, self.state, self.n_keepers, self.kp, self.cfg)

    def on_own_commands(self, main: int, a1: float, a2: float, neck: float = 0.0) -> None:
        """The commands I sent this cycle (``agents.tracking.sent_row``)."""
        sent_row(0, self.state, int(main), float(a1), float(a2), float(neck))

    def forget(self) -> None:
        """Episode boundary: forget every object but me."""
        forget_row(0, self.state)

    def belief(self) -> Belief:
        """The current belief (B = 1). The arrays are reused: copy them to keep a snapshot."""
        self._write_belief_row(0, self.state, self.belief_rows, 0)
        return self.belief_rows


__all__ = ["WorldModel"]

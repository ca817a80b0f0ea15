"""The state of a batch of arenas as flat numpy arrays (the form every kernel takes).

Object 0 of every arena is the ball; objects 1..K are the keepers (left side, uniform numbers 1..K) and
objects K+1..K+T the takers (right side, uniform numbers 1..T). A single world is a batch of one.
Shapes: ``B`` arenas, ``N = 1 + K + T`` objects.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from keepaway.core.jit import njit
from keepaway.core.objects import BALL, CMD_NONE
from keepaway.core.rng import seed_streams
from keepaway.protocol.params import ServerParams

# Command counters, in sense_body order: kick, dash, turn, catch, move, turn_neck, change_view, say.
COUNT_KICK, COUNT_DASH, COUNT_TURN, COUNT_CATCH, COUNT_MOVE, COUNT_TURN_NECK, COUNT_CHANGE_VIEW, COUNT_SAY = range(8)
N_COUNTS = 8

# Collision flags of the last step (bit set).
COLLIDED_BALL = 1
COLLIDED_PLAYER = 2

# Parked position of a disabled player (rcssserver parks players that said bye off the pitch).
PARKED_Y = -37.0


@njit(cache=True, inline="always")
def player_unum(obj: int, n_keepers: int) -> int:
    """Uniform number of player object ``obj``: the keepers are objects 1..n_keepers, the takers follow
    (the one definition, for the kernels and :meth:`World.unum`)."""
    return obj if obj <= n_keepers else obj - n_keepers


class World(NamedTuple):
    """State of ``B`` arenas. Kernels take it as is (numba accepts NamedTuples of arrays) and update the
    arrays in place; the tuple itself never changes."""

    pos: np.ndarray  # (B, N, 2) float64, m
    vel: np.ndarray  # (B, N, 2) float64, m/cycle (stored, i.e. post-decay)
    acc: np.ndarray  # (B, N, 2) float64, m/cycle^2 (pending for the next step)
    body: np.ndarray  # (B, N) float64, deg, global
    neck: np.ndarray  # (B, N) float64, deg, relative to body
    body_pending: np.ndarray  # (B, N) body angle that becomes effective at the next step
    neck_pending: np.ndarray  # (B, N)
    stamina: np.ndarray  # (B, N)
    effort: np.ndarray  # (B, N)
    recovery: np.ndarray  # (B, N)
    capacity: np.ndarray  # (B, N)
    enabled: np.ndarray  # (B, N) bool; the ball is always enabled
    collision: np.ndarray  # (B, N) uint8 bits COLLIDED_* of the last step
    kicked: np.ndarray  # (B, N) bool: kicked in the last cycle
    counts: np.ndarray  # (B, N, 8) int64 command counters
    time: np.ndarray  # (B,) int64 cycle
    rng: np.ndarray  # (B,) uint64 random stream per arena
    n_keepers: int
    n_takers: int

    @property
    def batch(self) -> int:
        return self.pos.shape[0]

    @property
    def n_objects(self) -> int:
        return self.pos.shape[1]

    def side(self, obj: int) -> str:
        """'l' for keepers, 'r' for takers (rcssserver sides); the ball has no side."""
        if obj == BALL:
            raise ValueError("the ball has no side")
        return "l" if obj <= self.n_keepers else "r"

    def unum(self, obj: int) -> int:
        """Uniform number of player object ``obj``."""
        return player_unum.py_func(obj, self.n_keepers)

    def player_object(self, side: str, unum: int) -> int:
        """Object index of the player ``unum`` of ``side`` ('l' keepers, 'r' takers)."""
        if side == "l" and 1 <= unum <= self.n_keepers:
            return unum
        if side == "r" and 1 <= unum <= self.n_takers:
            return self.n_keepers + unum
        raise ValueError(f"no player {side} {unum}")

    def copy(self) -> "World":
        return World(*(v.copy() if isinstance(v, np.ndarray) else v for v in self))


def new_world(params: ServerParams, n_keepers: int, n_takers: int, batch: int = 1, seed: int = 0) -> World:
    """A batch of arenas with every player disabled and parked, the ball at the centre, full stamina.

    Players are enabled when they connect (distributed mode) or by the arena (embedded/batched); the
    referee's reset then places them (spec 5).
    """
    if n_keepers < 1 or n_takers < 1:
        raise ValueError("an arena needs at least one keeper and one taker")
    n = 1 + n_keepers + n_takers
    zeros2 = np.zeros((batch, n, 2))
    pos = zeros2.copy()
    pos[:, 1:, 0] = -3.0 * np.arange(1, n)
    pos[:, 1:, 1] = PARKED_Y
    body = np.zeros((batch, n))
    body[:, 1 + n_keepers :] = 180.0
    enabled = np.zeros((batch, n), dtype=np.bool_)
    enabled[:, BALL] = True
    return World(
        pos=pos,
        vel=zeros2.copy(),
        acc=zeros2.copy(),
        body=body,
        neck=np.zeros((batch, n)),
        body_pending=body.copy(),
        neck_pending=np.zeros((batch, n)),
        stamina=np.full((batch, n), params.stamina_max),
        effort=np.full((batch, n), params.effort_init),
        recovery=np.full((batch, n), params.recover_init),
        capacity=np.full((batch, n), params.stamina_capacity),
        enabled=enabled,
        collision=np.zeros((batch, n), dtype=np.uint8),
        kicked=np.zeros((batch, n), dtype=np.bool_),
        counts=np.zeros((batch, n, N_COUNTS), dtype=np.int64),
        time=np.zeros(batch, dtype=np.int64),
        rng=seed_streams(seed, batch),
        n_keepers=n_keepers,
        n_takers=n_takers,
    )


class Commands(NamedTuple):
    """One cycle's commands of every player of every arena (what the step consumes).

    The main slot is already resolved (one command per player, spec 3); out-of-range arguments are
    clamped by the kernels exactly as rcssserver clamps them."""

    main: np.ndarray  # (B, N) int8 CMD_* code
    arg1: np.ndarray  # (B, N) float64: dash power / turn moment / kick power / tackle power / move x
    arg2: np.ndarray  # (B, N) float64: dash direction / kick direction / move y
    neck: np.ndarray  # (B, N) float64 turn_neck moment
    has_neck: np.ndarray  # (B, N) bool

    @classmethod
    def empty(cls, batch: int, n_objects: int) -> "Commands":
        return cls(
            main=np.zeros((batch, n_objects), dtype=np.int8),
            arg1=np.zeros((batch, n_objects)),
            arg2=np.zeros((batch, n_objects)),
            neck=np.zeros((batch, n_objects)),
            has_neck=np.zeros((batch, n_objects), dtype=np.bool_),
        )

    def clear(self) -> None:
        self.main[:] = CMD_NONE
        self.arg1[:] = 0.0
        self.arg2[:] = 0.0
        self.neck[:] = 0.0
        self.has_neck[:] = False

"""What a deciding player believes about its arena, remembers of its own decisions and decided last: the
rows every skill and policy kernel reads and writes.

The world model (`agents/tracking.py`) turns noisy percepts into one row of a ``Belief``; the decisions
keep their memory in an ``AgentMemory`` row and write their command into a ``Decisions`` row. The batched
mode stacks the rows of all players of all arenas. Object indexing is the server's (`core/objects.py`): 0
ball, 1..K keepers, K+1..K+T takers. Confidence follows the keepaway world model: conf = 1 - (cycles since
seen)/100, 1 for myself (docs/players.md §4.1).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from keepaway.core.jit import borrowing


class Belief(NamedTuple):
    """``B`` rows of belief, one per deciding player (a player process uses B = 1)."""

    time: np.ndarray  # (B,) int64 current cycle
    me: np.ndarray  # (B,) int64 my object index
    pos: np.ndarray  # (B, N, 2) float64 estimated global position, m (rcssserver frame, +y down)
    vel: np.ndarray  # (B, N, 2) float64 estimated velocity, m/cycle (stored, post-decay)
    body: np.ndarray  # (B, N) float64 global body angle, deg
    neck: np.ndarray  # (B, N) float64 neck angle relative to the body, deg
    conf: np.ndarray  # (B, N) float64 confidence in [0, 1]
    effort: np.ndarray  # (B,) float64 my effort
    n_keepers: int
    n_takers: int

    @property
    def batch(self) -> int:
        return self.pos.shape[0]

    @property
    def n_objects(self) -> int:
        return self.pos.shape[1]


def empty_belief(batch: int, n_keepers: int, n_takers: int) -> Belief:
    """A zeroed belief (no object known: conf 0) to be filled in place by a world model."""
    n = 1 + n_keepers + n_takers
    return Belief(
        time=np.zeros(batch, dtype=np.int64),
        me=np.zeros(batch, dtype=np.int64),
        pos=np.zeros((batch, n, 2)),
        vel=np.zeros((batch, n, 2)),
        body=np.zeros((batch, n)),
        neck=np.zeros((batch, n)),
        conf=np.zeros((batch, n)),
        effort=np.ones(batch),
        n_keepers=n_keepers,
        n_takers=n_takers,
    )


def belief_from_truth(
    world_pos: np.ndarray,
    world_vel: np.ndarray,
    body: np.ndarray,
    neck: np.ndarray,
    me: np.ndarray | int,
    time: np.ndarray | int,
    n_keepers: int,
    n_takers: int,
    effort: np.ndarray | float = 1.0,
) -> Belief:
    """A perfect belief (every conf 1) from exact state, for tests, fullstate agents and batched mode.

    ``world_pos`` is ``(N, 2)`` for one row or ``(B, N, 2)``; ``me``/``time``/``effort`` are scalars or
    ``(B,)``. The arrays are copied, so the belief does not alias the world.
    """
    pos = np.asarray(world_pos, dtype=np.float64)
    single = pos.ndim == 2
    if single:
        pos = pos[None]
    batch, n = pos.shape[0], pos.shape[1]
    if n != 1 + n_keepers + n_takers:
        raise ValueError(f"{n} objects given for {n_keepers} keepers and {n_takers} takers")

    def rows(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        return np.array(np.broadcast_to(np.asarray(a, dtype=np.float64), shape))

    return Belief(
        time=np.array(np.broadcast_to(np.asarray(time, dtype=np.int64), (batch,))),
        me=np.array(np.broadcast_to(np.asarray(me, dtype=np.int64), (batch,))),
        pos=pos.copy(),
        vel=rows(world_vel, (batch, n, 2)),
        body=rows(body, (batch, n)),
        neck=rows(neck, (batch, n)),
        conf=np.ones((batch, n)),
        effort=rows(effort, (batch,)),
        n_keepers=n_keepers,
        n_takers=n_takers,
    )


class AgentMemory(NamedTuple):
    """What each deciding player remembers of its own past decisions, one row per belief row.

    Kept apart from the belief because the world model never touches it; the caller clears a row at an
    episode boundary with ``forget_episode`` (docs/players.md §2 step 1)."""

    last_action: np.ndarray  # (B,) int64 last Pass action, -1 none (docs/players.md §2 step 3c)
    t_last: np.ndarray  # (B,) int64 cycle of the last Pass decision or kick, -1 none
    intercept_point: np.ndarray  # (B, 2) float64 last chosen interception point (docs/players.md §5.2 step 2)
    intercept_time: np.ndarray  # (B,) int64 cycle it was chosen, -1 none
    target: np.ndarray  # (B, 2) float64 committed GetOpen point of GO:R (docs/players.md §7.3)
    has_target: np.ndarray  # (B,) bool
    search_sign: np.ndarray  # (B,) float64 +1/-1 turning side of the ball search (docs/players.md §5.6)
    search_time: np.ndarray  # (B,) int64 cycle of the last search turn, -1 none
    rng: np.ndarray  # (B,) uint64 per-agent random stream (`core/rng.py`)
    getopen_point: np.ndarray  # (B, 2) float64 the point the last GetOpen decision moved towards
    getopen_time: np.ndarray  # (B,) int64 the cycle of that decision, -1 none (for notes, never read back)
    # (B,) int64 backward dashes sent standing still since I last moved (interception.intercept)
    stuck_dashes: np.ndarray


def new_memory(batch: int, seeds: np.ndarray) -> AgentMemory:
    """Fresh memories; ``seeds`` is one uint64 per row (e.g. ``core.rng.seed_streams(seed, batch)``)."""
    seeds = np.asarray(seeds, dtype=np.uint64).reshape(batch).copy()
    return AgentMemory(
        last_action=np.full(batch, -1, dtype=np.int64),
        t_last=np.full(batch, -1, dtype=np.int64),
        intercept_point=np.zeros((batch, 2)),
        intercept_time=np.full(batch, -1, dtype=np.int64),
        target=np.zeros((batch, 2)),
        has_target=np.zeros(batch, dtype=np.bool_),
        search_sign=np.ones(batch),
        search_time=np.full(batch, -1, dtype=np.int64),
        rng=seeds,
        getopen_point=np.zeros((batch, 2)),
        getopen_time=np.full(batch, -1, dtype=np.int64),
        stuck_dashes=np.zeros(batch, dtype=np.int64),
    )


@borrowing
def forget_episode(mem: AgentMemory, r: int) -> None:
    """Episode boundary for row ``r``: no last action, no decision time, no committed targets
    (docs/players.md §2 step 1; the learner's endEpisode is the caller's)."""
    mem.last_action[r] = -1
    mem.t_last[r] = -1
    mem.intercept_time[r] = -1
    mem.has_target[r] = False
    mem.search_time[r] = -1
    mem.stuck_dashes[r] = 0


class Decisions(NamedTuple):
    """What each deciding player decided last, one row per belief row: written by the decision kernels
    (``keeper_decide`` / ``taker_decide`` and what they call) and read by whoever sends the command."""

    # (B, 4K + 2T - 3) a keeper's Pass state at its last Pass decision point (the learner's input)
    pass_state: np.ndarray
    decision: np.ndarray  # (B,) int8 keeper_decide's NO_PASS_DECISION / PASS_DECISION_* / GETOPEN_DECISION
    main: np.ndarray  # (B,) int8 CMD_* main command
    arg1: np.ndarray  # (B,) float64 its first argument
    arg2: np.ndarray  # (B,) float64 its second argument (a kick's direction)
    neck: np.ndarray  # (B,) float64 turn_neck moment


def new_decisions(batch: int, state_size: int) -> Decisions:
    """Zeroed decisions of ``batch`` rows, with Pass states of ``state_size`` variables
    (``agents.state_vars.pass_state_size``)."""
    return Decisions(
        pass_state=np.zeros((batch, state_size)),
        decision=np.zeros(batch, dtype=np.int8),
        main=np.zeros(batch, dtype=np.int8),
        arg1=np.zeros(batch),
        arg2=np.zeros(batch),
        neck=np.zeros(batch),
    )


@borrowing
def write_action(r: int, code: int, a1: float, a2: float, neck: float, out: Decisions) -> None:
    """Store one decision (main command ``code`` with its arguments, and the neck's moment) in row ``r``
    of ``out``."""
    out.main[r] = code
    out.arg1[r] = a1
    out.arg2[r] = a2
    out.neck[r] = neck


__all__ = ["AgentMemory", "Belief", "Decisions", "belief_from_truth", "empty_belief", "forget_episode", "new_decisions",
           "new_memory", "write_action"]

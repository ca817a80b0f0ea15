"""One simulation cycle of a batch of arenas, in rcssserver's order (spec `server-physics.md` 2).

apply commands -> move objects -> collisions -> time += 1 -> Keepaway referee -> stamina. The same
compiled loop serves the distributed server (batch of one) and the batched mode (many arenas).
"""

from __future__ import annotations

import numpy as np
from keepaway.core.jit import borrowing

from keepaway.server.physics import apply_commands, move_objects, resolve_collisions, update_stamina
from keepaway.server.referee import keepaway_referee


@borrowing
def step_arena(b, w, c, r, kp) -> int:
    """Advance arena ``b`` one cycle; returns the referee's episode-end code (0: goes on). The batched
    mode composes it with percepts and decisions in its own loop over arenas."""
    apply_commands(b, w, c, kp)
    move_objects(b, w, kp)
    resolve_collisions(b, w, kp)
    w.time[b] += 1
    cause = keepaway_referee(b, w, r, kp)
    update_stamina(b, w, kp)
    return cause


@borrowing
def simulate_cycle(w, c, r, kp, causes):
    """Advance every arena one cycle; ``causes[b]`` gets the referee's episode-end code (0: goes on)."""
    for b in range(w.pos.shape[0]):
        causes[b] = step_arena(b, w, c, r, kp)


def new_causes(batch: int) -> np.ndarray:
    """The per-arena episode-end output array :func:`simulate_cycle` fills."""
    return np.zeros(batch, dtype=np.int8)

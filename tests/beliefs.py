"""A perfect belief row for the players' kernels (agents.belief.belief_from_truth), shared by the kernel
tests: the world as it is, seen by player ``me``."""

from __future__ import annotations

import numpy as np

from keepaway.agents.belief import Belief, belief_from_truth


def belief(pos, me: int, vel=None, body=None, n_keepers: int = 3, n_takers: int = 2, time: int = 100) -> Belief:
    """One perfect-belief row; ``pos`` lists ball, keepers, takers (velocities and body angles 0 unless
    given)."""
    pos = np.asarray(pos, dtype=float)
    n = pos.shape[0]
    vel = np.zeros((n, 2)) if vel is None else np.asarray(vel, dtype=float)
    body = np.zeros(n) if body is None else np.asarray(body, dtype=float)
    return belief_from_truth(pos, vel, body, np.zeros(n), me, time, n_keepers, n_takers)

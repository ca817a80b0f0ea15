"""State variables of the Pass and GetOpen decisions (spec `keepaway-task.md` 3-4,
`keepaway-agents.md` 4).

Both share one block computed around a vertex V (K1 for Pass, the imagined position P for GetOpen):
distances from V to the other keepers, distances from V to the takers, each other keeper's distance to
its nearest taker and each other keeper's smallest angle ang(Ki, V, Tj). Pass prepends the distances to
the region centre C = (0, 0) (the region is centred on the origin, spec `keepaway-agents.md` header);
GetOpen appends the two lane variables. For K keepers and T takers the Pass vector has 4K + 2T - 3
entries (3v2: 13, 4v3: 19) and the GetOpen vector 3K + T - 1 (3v2: 10).
"""

from __future__ import annotations

import math

import numpy as np
from core.jit import borrowing, njit

from agents.belief import Belief
from agents.geometry import distance, vertex_angle
from agents.skills import closest_to_ball, sort_by_distance


@borrowing
def pass_state_size(n_keepers: int, n_takers: int) -> int:
    """4K + 2T - 3 (spec `keepaway-agents.md` 4, generalisation)."""
    return 4 * n_keepers + 2 * n_takers - 3


@borrowing
def getopen_state_size(n_keepers: int, n_takers: int) -> int:
    """3K + T - 1 (spec `keepaway-task.md` 4 generalised like the Pass variables)."""
    return 3 * n_keepers + n_takers - 1


# The kinds of GetOpen variable, in the order of getopen_state; each kind has one input scaling rule
# (agents.getopen.GetOpenScaling). Kinds ending in "distance" are in metres, the others in degrees.
GETOPEN_KINDS = ("teammate_distance", "taker_distance", "teammate_taker_distance", "teammate_taker_angle",
                 "pass_distance", "lane_angle")


def getopen_state_kinds(n_keepers: int, n_takers: int) -> tuple[str, ...]:
    """The kind of each GetOpen variable (:data:`GETOPEN_KINDS`): dist(K1', Ki') and min_j dist(Ki', Tj')
    and min_j ang(Ki', K1', Tj') for the K - 1 other keepers, dist(K1', Tj') for the T takers, then the
    pass distance and the lane angle (3v2: `keepaway-task.md` 4 variables 1-2, 3-4, 5-6, 7-8, 9, 10)."""
    others = n_keepers - 1
    return (("teammate_distance",) * others + ("taker_distance",) * n_takers
            + ("teammate_taker_distance",) * others + ("teammate_taker_angle",) * others
            + ("pass_distance", "lane_angle"))


@borrowing
def _around_vertex(
    bel: Belief, r: int, vx: float, vy: float, keepers, nk: int, takers, nt: int, out, at: int
) -> int:
    """The shared block (module docstring) written from ``out[at]``; returns the next free index."""
    for i in range(nk):
        out[at + i] = distance(vx, vy, bel.pos[r, keepers[i], 0], bel.pos[r, keepers[i], 1])
    at += nk
    for j in range(nt):
        out[at + j] = distance(vx, vy, bel.pos[r, takers[j], 0], bel.pos[r, takers[j], 1])
    at += nt
    for i in range(nk):
        kx, ky = bel.pos[r, keepers[i], 0], bel.pos[r, keepers[i], 1]
        near, narrow = math.inf, math.inf
        for j in range(nt):
            tx, ty = bel.pos[r, takers[j], 0], bel.pos[r, takers[j], 1]
            near = min(near, distance(kx, ky, tx, ty))
            narrow = min(narrow, vertex_angle(kx, ky, vx, vy, tx, ty))
        out[at + i] = near
        out[at + nk + i] = narrow
    return at + 2 * nk


@njit(cache=True)
def pass_state(bel: Belief, r: int, cfg, out) -> bool:
    """The Pass variables of row ``r`` into ``out`` (length 4K + 2T - 3), in `keepaway-task.md` 3 order:
    dist(K1, C), dist(Ki, C) i >= 2, dist(Tj, C), dist(K1, Ki), dist(K1, Tj), min_j dist(Ki, Tj),
    min_j ang(Ki, K1, Tj). K1 = keeper closest to the ball; the others and the takers sorted by distance
    from K1. Returns False (``out`` then undefined) when some player is not usable (conf < 0.88) or no
    keeper can be K1 (spec `keepaway-agents.md` 1 step 3a)."""
    k, t = bel.n_keepers, bel.n_takers
    for j in range(1, k + t + 1):
        if j != bel.me[r] and bel.conf[r, j] < cfg.player_conf_threshold:
            return False
    k1 = closest_to_ball(bel, r, 1, k, -1, cfg)
    if k1 < 0:
        return False
    keepers = np.empty(k, dtype=np.int64)
    takers = np.empty(t, dtype=np.int64)
    vx, vy = bel.pos[r, k1, 0], bel.pos[r, k1, 1]
    nk = sort_by_distance(bel, r, vx, vy, 1, k, k1, keepers)
    nt = sort_by_distance(bel, r, vx, vy, k + 1, k + t, -1, takers)
    out[0] = math.hypot(vx, vy)
    for i in range(nk):
        out[1 + i] = math.hypot(bel.pos[r, keepers[i], 0], bel.pos[r, keepers[i], 1])
    for j in range(nt):
        out[1 + nk + j] = math.hypot(bel.pos[r, takers[j], 0], bel.pos[r, takers[j], 1])
    _around_vertex(bel, r, vx, vy, keepers, nk, takers, nt, out, 1 + nk + nt)
    return True


@njit(cache=True)
def getopen_state(bel: Belief, r: int, px: float, py: float, ox: float, oy: float, out) -> None:
    """The GetOpen variables of point P = (px, py) for the deciding keeper of row ``r`` into ``out``
    (length 3K + T - 1), `keepaway-task.md` 4 order: I imagine myself K1' at P; the other keepers and the
    takers (positions unchanged) sorted by distance from P; then dist(O, P) and min_j ang(P, O, Tj), where
    the lane origin O = (ox, oy) is the position of K1, the current keeper closest to the ball (the
    paper's variables 9-10), or another point the pass would start from (``agents.getopen.lane_origin``)."""
    k, t = bel.n_keepers, bel.n_takers
    keepers = np.empty(k, dtype=np.int64)
    takers = np.empty(t, dtype=np.int64)
    nk = sort_by_distance(bel, r, px, py, 1, k, bel.me[r], keepers)
    nt = sort_by_distance(bel, r, px, py, k + 1, k + t, -1, takers)
    at = _around_vertex(bel, r, px, py, keepers, nk, takers, nt, out, 0)
    out[at] = distance(ox, oy, px, py)
    lane = math.inf
    for j in range(nt):
        lane = min(lane, vertex_angle(px, py, ox, oy, bel.pos[r, takers[j], 0], bel.pos[r, takers[j], 1]))
    out[at + 1] = lane

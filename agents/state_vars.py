"""State variables of the Pass and GetOpen decisions (docs/players.md §6.1,
§7.4).

Both share one block computed around a vertex V (K1 for Pass, the imagined position P for GetOpen):
distances from V to the other keepers, distances from V to the takers, each other keeper's distance to
its nearest taker and each other keeper's smallest angle ang(Ki, V, Tj). Pass prepends the distances to
the region centre C = (0, 0) (the region is centred on the origin, docs/players.md §1);
GetOpen appends the two lane variables. For K keepers and T takers the Pass vector has 4K + 2T - 3
entries (3v2: 13, 4v3: 19) and the GetOpen vector 3K + T - 1 (3v2: 10).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from keepaway.agents.belief import Belief
from keepaway.agents.geometry import (
    ACOS_ESTIMATE_ERROR,
    DECIDE_SLACK,
    acos_estimate,
    closest_to_ball,
    distance,
    distances_from,
    ray_cosine,
    sort_by_distance,
)
from keepaway.core.jit import borrowing, njit


@borrowing
def pass_state_size(n_keepers: int, n_takers: int) -> int:
    """4K + 2T - 3 (docs/players.md §6.1)."""
    return 4 * n_keepers + 2 * n_takers - 3


@borrowing
def getopen_state_size(n_keepers: int, n_takers: int) -> int:
    """3K + T - 1 (docs/players.md §7.4, generalised like the Pass variables)."""
    return 3 * n_keepers + n_takers - 1


# The kinds of GetOpen variable, in the order of getopen_state; each kind has one input scaling rule
# (agents.getopen.GetOpenScaling). Kinds ending in "distance" are in metres, the others in degrees.
GETOPEN_KINDS = ("teammate_distance", "taker_distance", "teammate_taker_distance", "teammate_taker_angle",
                 "pass_distance", "lane_angle")


def getopen_state_kinds(n_keepers: int, n_takers: int) -> tuple[str, ...]:
    """The kind of each GetOpen variable (:data:`GETOPEN_KINDS`): dist(K1', Ki') and min_j dist(Ki', Tj')
    and min_j ang(Ki', K1', Tj') for the K - 1 other keepers, dist(K1', Tj') for the T takers, then the
    pass distance and the lane angle (3v2: docs/players.md §7.4, variables 1-2, 3-4, 5-6, 7-8, 9, 10)."""
    others = n_keepers - 1
    return (("teammate_distance",) * others + ("taker_distance",) * n_takers
            + ("teammate_taker_distance",) * others + ("teammate_taker_angle",) * others
            + ("pass_distance", "lane_angle"))


# GO:L first scores its grid points on estimated variables (agents.getopen.learned_target): distances by
# one sqrt instead of hypot (a few ulps apart; ESTIMATE_DISTANCE_ERROR, relative, is far beyond that),
# cosines from those distances (so off by at most ESTIMATE_COSINE_ERROR), angles by acos_estimate: off by
# at most ESTIMATE_ANGLE_ERROR degrees, since acos moves by at most acos(1 - e) <= 1.01 sqrt(2 e) when its
# argument moves by e.
ESTIMATE_DISTANCE_ERROR = 1e-13
ESTIMATE_COSINE_ERROR = 1e-12
ESTIMATE_ANGLE_ERROR = math.degrees(ACOS_ESTIMATE_ERROR + 1.01 * math.sqrt(2.0 * ESTIMATE_COSINE_ERROR)) + 1e-12
_TINY_SQUARE = 1e-200  # a sum of squares below it may have underflowed: no estimate


class VertexScratch(NamedTuple):
    """Work arrays of the variables around a vertex: made once per decision and reused for every vertex
    (GetOpen's 25 grid points), so that what no vertex changes is computed once. Indexed by object
    where noted (1..K keepers, K+1..K+T takers)."""

    keepers: np.ndarray  # int64 (K,): the other keepers, sorted by distance from the vertex
    takers: np.ndarray  # int64 (T,): the takers, sorted likewise
    dist: np.ndarray  # (K + T + 1,) by object: distance from the vertex
    near: np.ndarray  # (K + T + 1,) by keeper object: distance to its nearest taker
    lane: np.ndarray  # (K + T + 1,) by taker object: distance from the GetOpen lane origin


@njit(cache=True)
def vertex_scratch(n_keepers: int, n_takers: int) -> VertexScratch:
    n = n_keepers + n_takers + 1
    return VertexScratch(np.empty(n_keepers, dtype=np.int64), np.empty(n_takers, dtype=np.int64), np.empty(n),
                         np.empty(n), np.empty(n))


@borrowing
def nearest_taker_distances(bel: Belief, r: int, skip: int, near) -> None:
    """``near[i]`` = min_j dist(Ki, Tj) for every keeper object i but ``skip`` (inf without takers)."""
    k, t = bel.n_keepers, bel.n_takers
    for i in range(1, k + 1):
        if i == skip:
            continue
        kx, ky = bel.pos[r, i, 0], bel.pos[r, i, 1]
        closest = math.inf
        for j in range(k + 1, k + t + 1):
            closest = min(closest, distance(kx, ky, bel.pos[r, j, 0], bel.pos[r, j, 1]))
        near[i] = closest


@borrowing
def smallest_angle(bel: Belief, r: int, ux: float, uy: float, nu: float, cx: float, cy: float, objs, n: int,
                   norms, estimate: bool) -> float:
    """min_j ray_angle(u, Pj - C) over the players ``objs[:n]`` (``norms[o]`` = dist(C, Po); inf for no
    player): decided by the cosines, the largest naming the smallest angle; only the angles within
    DECIDE_SLACK of it in cosine are taken (the arccosine of a clearly smaller cosine is clearly larger,
    far beyond its rounding), so the minimum is the one every angle would give. ``estimate``: the
    largest cosine's :func:`acos_estimate` instead."""
    largest = -math.inf
    for j in range(n):
        o = objs[j]
        largest = max(largest, ray_cosine(ux, uy, nu, bel.pos[r, o, 0] - cx, bel.pos[r, o, 1] - cy, norms[o]))
    if estimate:
        return math.degrees(acos_estimate(largest)) if n > 0 else math.inf
    angle = math.inf
    for j in range(n):
        o = objs[j]
        c = ray_cosine(ux, uy, nu, bel.pos[r, o, 0] - cx, bel.pos[r, o, 1] - cy, norms[o])
        if c >= largest - DECIDE_SLACK:
            angle = min(angle, math.degrees(math.acos(c)))
    return angle


@borrowing
def _around_vertex(bel: Belief, r: int, vx: float, vy: float, s: VertexScratch, nk: int, nt: int, out,
                   at: int, estimate: bool) -> int:
    """The shared block (module docstring) written from ``out[at]``, from ``s`` filled for V (its sorted
    players, their distances from V, the keepers' nearest-taker distances); returns the next free index.
    ``estimate``: the angles by :func:`acos_estimate`."""
    for i in range(nk):
        out[at + i] = s.dist[s.keepers[i]]
    at += nk
    for j in range(nt):
        out[at + j] = s.dist[s.takers[j]]
    at += nt
    for i in range(nk):
        ki = s.keepers[i]
        out[at + i] = s.near[ki]
        out[at + nk + i] = smallest_angle(bel, r, bel.pos[r, ki, 0] - vx, bel.pos[r, ki, 1] - vy, s.dist[ki], vx,
                                          vy, s.takers, nt, s.dist, estimate)
    return at + 2 * nk


@borrowing
def _sort_around(bel: Belief, r: int, vx: float, vy: float, skip: int, s: VertexScratch) -> tuple:
    """Fill ``s.dist`` from V and sort the keepers but ``skip`` and the takers by it; (nk, nt)."""
    k, t = bel.n_keepers, bel.n_takers
    distances_from(bel, r, vx, vy, k + t, skip, s.dist)
    return (sort_by_distance(s.dist, 1, k, skip, s.keepers), sort_by_distance(s.dist, k + 1, k + t, -1, s.takers))


@njit(cache=True)
def pass_state(bel: Belief, r: int, cfg, out) -> bool:
    """The Pass variables of row ``r`` into ``out`` (length 4K + 2T - 3), in the paper's order (docs/players.md §6.1):
    dist(K1, C), dist(Ki, C) i >= 2, dist(Tj, C), dist(K1, Ki), dist(K1, Tj), min_j dist(Ki, Tj),
    min_j ang(Ki, K1, Tj). K1 = keeper closest to the ball; the others and the takers sorted by distance
    from K1. Returns False (``out`` then undefined) when some player is not usable (conf < 0.88) or no
    keeper can be K1 (docs/players.md §2 step 3a)."""
    k, t = bel.n_keepers, bel.n_takers
    for j in range(1, k + t + 1):
        if j != bel.me[r] and bel.conf[r, j] < cfg.player_conf_threshold:
            return False
    k1 = closest_to_ball(bel, r, 1, k, -1, cfg)
    if k1 < 0:
        return False
    s = vertex_scratch(k, t)
    vx, vy = bel.pos[r, k1, 0], bel.pos[r, k1, 1]
    nk, nt = _sort_around(bel, r, vx, vy, k1, s)
    nearest_taker_distances(bel, r, k1, s.near)
    out[0] = math.hypot(vx, vy)
    for i in range(nk):
        out[1 + i] = math.hypot(bel.pos[r, s.keepers[i], 0], bel.pos[r, s.keepers[i], 1])
    for j in range(nt):
        out[1 + nk + j] = math.hypot(bel.pos[r, s.takers[j], 0], bel.pos[r, s.takers[j], 1])
    _around_vertex(bel, r, vx, vy, s, nk, nt, out, 1 + nk + nt, False)
    return True


@borrowing
def getopen_setup(bel: Belief, r: int, ox: float, oy: float, s: VertexScratch) -> None:
    """What :func:`getopen_point_state` takes from ``s`` that no grid point changes, for the deciding
    keeper of row ``r`` and the lane origin O = (ox, oy): the other keepers' nearest-taker distances and
    the takers' distances from O."""
    k, t = bel.n_keepers, bel.n_takers
    nearest_taker_distances(bel, r, bel.me[r], s.near)
    for j in range(k + 1, k + t + 1):
        s.lane[j] = distance(ox, oy, bel.pos[r, j, 0], bel.pos[r, j, 1])


@borrowing
def getopen_point_state(bel: Belief, r: int, px: float, py: float, ox: float, oy: float, s: VertexScratch,
                        out) -> None:
    """:func:`getopen_state` of point P from ``s`` set up for this decision (:func:`getopen_setup`)."""
    nk, nt = _sort_around(bel, r, px, py, bel.me[r], s)
    at = _around_vertex(bel, r, px, py, s, nk, nt, out, 0, False)
    out[at] = distance(ox, oy, px, py)
    out[at + 1] = smallest_angle(bel, r, px - ox, py - oy, out[at], ox, oy, s.takers, nt, s.lane, False)


@borrowing
def _distance_estimate(ax: float, ay: float, bx: float, by: float) -> float:
    """distance(A, B) by one sqrt (within ESTIMATE_DISTANCE_ERROR of it, relative); NaN where the sum of
    squares could have underflowed or is not finite."""
    dx, dy = bx - ax, by - ay
    d2 = dx * dx + dy * dy
    return math.sqrt(d2) if _TINY_SQUARE < d2 < math.inf else math.nan


@borrowing
def _clearly_apart(dist, objs, n: int) -> bool:
    """The sorted ``objs[:n]``'s distances each more than DECIDE_SLACK beyond the one before: an order
    the exact distances give too."""
    for i in range(1, n):
        before = dist[objs[i - 1]]
        if not dist[objs[i]] - before > DECIDE_SLACK * (1.0 + before):
            return False
    return True


@borrowing
def getopen_point_estimate(bel: Belief, r: int, px: float, py: float, ox: float, oy: float, s: VertexScratch,
                           out) -> bool:
    """:func:`getopen_point_state`'s variables estimated: distances within ESTIMATE_DISTANCE_ERROR of
    theirs (relative), angles within ESTIMATE_ANGLE_ERROR degrees, the nearest-taker distances exact.
    False (``out`` then undefined) where an estimate cannot stand for them: two players so nearly at one
    distance from P that the exact sort could order them the other way, P (nearly) on a player or on the
    lane origin, a variable not finite. ``s`` set up as for getopen_point_state; its ``near`` and
    ``lane`` are left as they are."""
    k, t = bel.n_keepers, bel.n_takers
    me = bel.me[r]
    for j in range(1, k + t + 1):
        if j != me:
            s.dist[j] = _distance_estimate(px, py, bel.pos[r, j, 0], bel.pos[r, j, 1])
            if math.isnan(s.dist[j]):
                return False
    nk = sort_by_distance(s.dist, 1, k, me, s.keepers)
    nt = sort_by_distance(s.dist, k + 1, k + t, -1, s.takers)
    if not (_clearly_apart(s.dist, s.keepers, nk) and _clearly_apart(s.dist, s.takers, nt)):
        return False
    at = _around_vertex(bel, r, px, py, s, nk, nt, out, 0, True)
    out[at] = _distance_estimate(ox, oy, px, py)
    out[at + 1] = smallest_angle(bel, r, px - ox, py - oy, out[at], ox, oy, s.takers, nt, s.lane, True)
    for i in range(at + 2):
        if not abs(out[i]) < math.inf:
            return False
    return True


@njit(cache=True)
def getopen_state(bel: Belief, r: int, px: float, py: float, ox: float, oy: float, out) -> None:
    """The GetOpen variables of point P = (px, py) for the deciding keeper of row ``r`` into ``out``
    (length 3K + T - 1), in the order of docs/players.md §7.4: I imagine myself K1' at P; the other keepers and the
    takers (positions unchanged) sorted by distance from P; then dist(O, P) and min_j ang(P, O, Tj), where
    the lane origin O = (ox, oy) is the position of K1, the current keeper closest to the ball (the
    paper's variables 9-10), or another point the pass would start from (``agents.getopen.lane_origin``).
    A caller scoring many points sets up once (:func:`getopen_setup`, :func:`getopen_point_state`)."""
    s = vertex_scratch(bel.n_keepers, bel.n_takers)
    getopen_setup(bel, r, ox, oy, s)
    getopen_point_state(bel, r, px, py, ox, oy, s, out)



"""GetOpen: where a keeper without the ball should stand (spec `keepaway-task.md` 4,
`keepaway-agents.md` 2.5-2.7).

Candidate targets are a grid over the region. The policies differ only in how a target is chosen:
GO:R keeps a random grid point until reached, GO:HC takes the least congested point whose passing lane
from predictedBallPos is open (the paper's 18.4 deg rule, or the framework's cone as an option), GO:L
takes the argmax of a 10-5-5-1 net over each point's state variables. The movement is shared.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from agents.belief import AgentMemory, Belief
from agents.geometry import distance, in_cone, vertex_angle
from agents.skills import (
    GETOPEN_HANDCODED_CONE,
    GETOPEN_LEARNED,
    GETOPEN_RANDOM,
    ball_in,
    closest_to_ball,
    go_to_point,
    turn_to_point,
)
from agents.state_vars import getopen_state, getopen_state_size
from server.rng import randint

NET_HIDDEN = 5  # keepaway-task.md 4: two hidden layers of 5 units
SCALED_TANH_A = 1.7159  # keepaway-task.md 4: Haykin's scaled tanh a tanh(b x)
SCALED_TANH_B = 2.0 / 3.0


def net_size(n_inputs: int = 10) -> int:
    """Parameters of the n-5-5-1 net: 5n + 5 + 25 + 5 + 5 + 1 (91 for the 10 GetOpen inputs)."""
    return NET_HIDDEN * n_inputs + NET_HIDDEN + NET_HIDDEN * NET_HIDDEN + NET_HIDDEN + NET_HIDDEN + 1


@njit(cache=True)
def net_value(theta, x) -> float:
    """The GO:L value f_theta(x) (spec `keepaway-task.md` 4). Layout of ``theta``: W1 (5 x n, row-major,
    row = hidden unit), b1 (5), W2 (5 x 5, row-major), b2 (5), W3 (1 x 5), b3 (1); hidden units
    1.7159 tanh(2z/3), linear output."""
    n = x.shape[0]
    h1 = np.empty(NET_HIDDEN)
    at = NET_HIDDEN * n
    for u in range(NET_HIDDEN):
        z = theta[at + u]
        for i in range(n):
            z += theta[u * n + i] * x[i]
        h1[u] = SCALED_TANH_A * math.tanh(SCALED_TANH_B * z)
    w2 = at + NET_HIDDEN
    b2 = w2 + NET_HIDDEN * NET_HIDDEN
    w3 = b2 + NET_HIDDEN
    out = theta[w3 + NET_HIDDEN]
    for u in range(NET_HIDDEN):
        z = theta[b2 + u]
        for i in range(NET_HIDDEN):
            z += theta[w2 + u * NET_HIDDEN + i] * h1[i]
        out += theta[w3 + u] * SCALED_TANH_A * math.tanh(SCALED_TANH_B * z)
    return out


@njit(cache=True)
def grid_size(cfg) -> int:
    return int(cfg.grid_points) * int(cfg.grid_points)


@njit(cache=True)
def grid_point(k: int, kp, cfg) -> tuple:
    """Grid point ``k`` (x outer, y inner, both ascending): x = xmin + 0.15 L + i 0.175 L for a 5 x 5 grid
    with 15 % margins (spec `keepaway-agents.md` 2.5 step 2; 20 m: -7, -3.5, 0, 3.5, 7)."""
    n = int(cfg.grid_points)
    i, j = k // n, k % n
    span = (1.0 - 2.0 * cfg.grid_margin) / (n - 1)
    length, width = kp.keepaway_length, kp.keepaway_width
    x = -length / 2.0 + cfg.grid_margin * length + i * span * length
    y = -width / 2.0 + cfg.grid_margin * width + j * span * width
    return x, y


@njit(cache=True)
def predicted_ball_pos(bel: Belief, r: int, cycles: int, kp, cfg) -> tuple:
    """predictedBallPos: the ball after ``cycles``, the fastest keeper's interception time from
    ``fastest_to_ball`` (0 if a keeper has it; capped at the horizon if nobody reaches it)
    (spec `keepaway-agents.md` 2.5 step 1)."""
    return ball_in(bel, r, min(cycles, int(cfg.intercept_horizon)), kp)


@njit(cache=True)
def congestion(bel: Belief, r: int, px: float, py: float, cfg) -> float:
    """Sum over the other usable players not exactly at P of 1 / dist(player, P) (spec
    `keepaway-agents.md` 2.5 step 3; -value(P) of GO:HC, `keepaway-task.md` 4)."""
    total = 0.0
    for j in range(1, bel.n_keepers + bel.n_takers + 1):
        if j == bel.me[r] or bel.conf[r, j] < cfg.player_conf_threshold:
            continue
        d = distance(px, py, bel.pos[r, j, 0], bel.pos[r, j, 1])
        if d > 0.0:
            total += 1.0 / d
    return total


@njit(cache=True)
def lane_open(bel: Belief, r: int, px: float, py: float, bx: float, by: float, cone: bool, cfg) -> bool:
    """Whether the lane from predictedBallPos B to P is open: the paper's min_j ang(P, B, Tj) >= 18.4 deg
    (`keepaway-task.md` 4), or with ``cone`` no taker in the framework's cone of half-width 0.3
    (`keepaway-agents.md` 2.5 step 4). Takers with conf < 0.88 are ignored."""
    for j in range(bel.n_keepers + 1, bel.n_keepers + bel.n_takers + 1):
        if bel.conf[r, j] < cfg.player_conf_threshold:
            continue
        tx, ty = bel.pos[r, j, 0], bel.pos[r, j, 1]
        if cone:
            if in_cone(bx, by, px, py, tx, ty, cfg.go_cone_ratio):
                return False
        elif vertex_angle(px, py, bx, by, tx, ty) < cfg.go_safety_angle:
            return False
    return True


@njit(cache=True)
def handcoded_target(bel: Belief, r: int, ball_cycles: int, cone: bool, kp, cfg) -> tuple:
    """GO:HC: the admissible grid point with the lowest congestion (strict <, scan order wins ties);
    the region centre if none is admissible (spec `keepaway-agents.md` 2.5 steps 4-5).
    ``ball_cycles``: the fastest keeper's interception time (``fastest_to_ball``)."""
    bx, by = predicted_ball_pos(bel, r, ball_cycles, kp, cfg)
    best_x, best_y, best = 0.0, 0.0, math.inf
    for k in range(grid_size(cfg)):
        px, py = grid_point(k, kp, cfg)
        if not lane_open(bel, r, px, py, bx, by, cone, cfg):
            continue
        c = congestion(bel, r, px, py, cfg)
        if c < best:
            best_x, best_y, best = px, py, c
    return best_x, best_y


@njit(cache=True)
def learned_target(bel: Belief, r: int, theta, kp, cfg) -> tuple:
    """GO:L: the grid point with the highest net value of its GetOpen state (first wins ties)
    (spec `keepaway-task.md` 4)."""
    k1 = closest_to_ball(bel, r, 1, bel.n_keepers, -1, cfg)
    if k1 < 0:
        k1 = bel.me[r]
    x = np.empty(getopen_state_size(bel.n_keepers, bel.n_takers))
    best_x, best_y, best = 0.0, 0.0, -math.inf
    for k in range(grid_size(cfg)):
        px, py = grid_point(k, kp, cfg)
        getopen_state(bel, r, px, py, k1, x)
        v = net_value(theta, x)
        if v > best:
            best_x, best_y, best = px, py, v
    return best_x, best_y


@njit(cache=True)
def random_target(bel: Belief, r: int, mem: AgentMemory, kp, cfg) -> tuple:
    """GO:R: a uniformly drawn grid point, kept until I am within the arrival radius of it
    (spec `keepaway-agents.md` 2.6)."""
    me = bel.me[r]
    if (not mem.has_target[r]) or distance(
        bel.pos[r, me, 0], bel.pos[r, me, 1], mem.target[r, 0], mem.target[r, 1]
    ) < cfg.arrival_radius:
        px, py = grid_point(randint(mem.rng, r, grid_size(cfg)), kp, cfg)
        mem.target[r, 0] = px
        mem.target[r, 1] = py
        mem.has_target[r] = True
    return mem.target[r, 0], mem.target[r, 1]


@njit(cache=True)
def move_to_spot(bel: Belief, r: int, px: float, py: float, kp, cfg) -> tuple:
    """Within the arrival radius turn the body to the ball and stand; else GoToPoint(P, 7 deg)
    (spec `keepaway-agents.md` 2.5 step 6)."""
    me = bel.me[r]
    if distance(bel.pos[r, me, 0], bel.pos[r, me, 1], px, py) < cfg.arrival_radius:
        return turn_to_point(bel, r, bel.pos[r, 0, 0], bel.pos[r, 0, 1], 1.0, kp)
    return go_to_point(bel, r, px, py, kp, cfg)


@njit(cache=True)
def getopen(bel: Belief, r: int, mem: AgentMemory, theta, ball_cycles: int, kp, cfg) -> tuple:
    """GetOpen with the policy ``cfg.getopen_policy``, re-evaluated every cycle (spec
    `keepaway-agents.md` 2.5 step 7); ``theta`` is this row's net parameters (used by GO:L only),
    ``ball_cycles`` the fastest keeper's interception time."""
    policy = int(cfg.getopen_policy)
    if policy == GETOPEN_RANDOM:
        px, py = random_target(bel, r, mem, kp, cfg)
    elif policy == GETOPEN_LEARNED:
        px, py = learned_target(bel, r, theta, kp, cfg)
    else:
        px, py = handcoded_target(bel, r, ball_cycles, policy == GETOPEN_HANDCODED_CONE, kp, cfg)
    return move_to_spot(bel, r, px, py, kp, cfg)

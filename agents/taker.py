"""The hand-coded taker (docs/players.md §3).

Per cycle: ball lost -> search; ball kickable and I am the taker closest to it -> HoldBall (ratio 0.3);
with more than two takers, the third and further takers mark the least covered keeper; if another taker
already controls the ball -> face it and do not interfere; else intercept. In 3v2 both takers chase.

Literal, as the C++ takers: they plan their interception with the ball they believe in. Holding the
ball still in their belief while a keeper controls it is the world model's work (the C++ rule in
``agents/tracking.py``); an earlier deviation that planned with a held ball at rest is gone
(docs/design.md, "The players' skills").
"""

from __future__ import annotations

import math

from keepaway.agents.belief import AgentMemory, Belief, Decisions, write_action
from keepaway.agents.geometry import (
    ball_kickable,
    closest_to_ball,
    compared_hypot,
    distance,
    in_cone,
    kickable_distance,
)
from keepaway.agents.getopen import move_to_spot
from keepaway.agents.interception import UNKNOWN_FIRST, fastest_to_ball, intercept
from keepaway.agents.kicks import hold_ball
from keepaway.agents.movement import neck_to_ball, neck_with_body, search_ball, turn_to_point
from keepaway.core.jit import borrowing

# The chasers: the closest and the second-closest taker to the ball never mark (docs/players.md §3 step 3).
CHASING_TAKERS = 2


@borrowing
def takers_closer_to_ball(bel: Belief, r: int, cfg) -> int:
    """How many usable takers are closer to the ball than me (ties: lower index counts as closer)."""
    me = bel.me[r]
    bx, by = bel.pos[r, 0, 0], bel.pos[r, 0, 1]
    mine = distance(bel.pos[r, me, 0], bel.pos[r, me, 1], bx, by)
    count = 0
    for j in range(bel.n_keepers + 1, bel.n_keepers + bel.n_takers + 1):
        if j == me or bel.conf[r, j] < cfg.player_conf_threshold:
            continue
        d = compared_hypot(bx - bel.pos[r, j, 0], by - bel.pos[r, j, 1], mine)  # exact near mine: == decides too
        if d < mine or (d == mine and j < me):
            count += 1
    return count


@borrowing
def mark_point(bel: Belief, r: int, sums, kp, cfg) -> tuple:
    """Where to mark (docs/players.md §3 step 3): for each keeper on the pitch count the takers in the cone (half-width
    0.3) from the keeper fastest to the ball towards it; take the keeper with the fewest (first on ties,
    the ball holder included: a framework quirk) and stand 4 m from it on its line to the ball."""
    k, t = bel.n_keepers, bel.n_takers
    origin, _ = fastest_to_ball(bel, r, 1, k, sums, kp, cfg)
    if origin < 0:
        origin = closest_to_ball(bel, r, 1, k, -1, cfg)
    ox, oy = bel.pos[r, 0, 0], bel.pos[r, 0, 1]
    if origin >= 0:
        ox, oy = bel.pos[r, origin, 0], bel.pos[r, origin, 1]
    target, fewest = -1, t + 1
    for i in range(1, k + 1):
        kx, ky = bel.pos[r, i, 0], bel.pos[r, i, 1]
        if abs(ky) > 0.5 * kp.pitch_width:  # off the pitch: not in play (a keeper that left is parked there)
            continue
        covered = 0
        for j in range(k + 1, k + t + 1):
            usable = bel.conf[r, j] >= cfg.player_conf_threshold
            if usable and in_cone(ox, oy, kx, ky, bel.pos[r, j, 0], bel.pos[r, j, 1], cfg.mark_cone_ratio):
                covered += 1
        if covered < fewest:
            target, fewest = i, covered
    if target < 0:
        return bel.pos[r, 0, 0], bel.pos[r, 0, 1]
    kx, ky = bel.pos[r, target, 0], bel.pos[r, target, 1]
    dx, dy = bel.pos[r, 0, 0] - kx, bel.pos[r, 0, 1] - ky
    length = math.hypot(dx, dy)
    if length == 0.0:
        return kx, ky
    return kx + cfg.mark_distance * dx / length, ky + cfg.mark_distance * dy / length


@borrowing
def taker_decide(bel: Belief, r: int, mem: AgentMemory, sums, kp, cfg, out: Decisions) -> None:
    """One taker decision for row ``r`` (docs/players.md §3 steps 1-5), written into row ``r`` of ``out``;
    ``sums``: the players' ``agents.interception.decay_sums``."""
    me = bel.me[r]
    if bel.conf[r, 0] < cfg.ball_conf_threshold:
        code, a1, a2 = search_ball(bel, r, mem, kp, cfg)
        write_action(r, code, a1, a2, neck_with_body(bel, r), out)
        return
    rank = takers_closer_to_ball(bel, r, cfg)
    if rank == 0 and ball_kickable(bel, r, me, kp):
        code, a1, a2 = hold_ball(bel, r, cfg.hold_ratio_taker, kp, cfg)
    elif bel.n_takers > CHASING_TAKERS and rank >= CHASING_TAKERS:
        px, py = mark_point(bel, r, sums, kp, cfg)
        code, a1, a2 = move_to_spot(bel, r, px, py, kp, cfg)
    else:
        nearest = closest_to_ball(bel, r, 1, bel.n_keepers + bel.n_takers, -1, cfg)
        kickable = kickable_distance(kp)
        if (
            nearest != me
            and nearest > bel.n_keepers
            and compared_hypot(bel.pos[r, 0, 0] - bel.pos[r, nearest, 0], bel.pos[r, 0, 1] - bel.pos[r, nearest, 1],
                               kickable) < kickable
        ):
            code, a1, a2 = turn_to_point(bel, r, bel.pos[r, 0, 0], bel.pos[r, 0, 1], 1.0, kp)
            write_action(r, code, a1, a2, neck_with_body(bel, r), out)
            return
        code, a1, a2 = intercept(bel, r, mem, sums, kp, cfg, UNKNOWN_FIRST)
    write_action(r, code, a1, a2, neck_to_ball(bel, r, code, a1, kp), out)


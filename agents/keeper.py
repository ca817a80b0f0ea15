"""The keeper's per-cycle decision (docs/players.md §2, §6).

``keeper_decide`` runs one row: ball lost -> search; ball kickable -> the Pass decision with its macro-
action persistence; fastest keeper to the ball -> intercept; else GetOpen. The episode boundary
(``agents.belief.forget_episode`` plus the learner's endEpisode) is the caller's.

Pass learners plug in from outside: with ``PASS_EXTERNAL`` the kernel stops at a Pass decision point,
leaves the outputs unwritten and returns PASS_DECISION_START or PASS_DECISION_STEP with the state
vector written; the caller computes the reward ``bel.time[r] - mem.t_last[r]`` (for a step), asks its
learner for an action and calls ``execute_pass_action``. The built-in policies (random, hand-coded,
always hold) decide and act inside the kernel and return the same codes for information. GetOpen plugs in
the same way: with ``GETOPEN_EXTERNAL`` the kernel returns GETOPEN_DECISION at a GetOpen decision and
the caller picks a grid point and calls ``execute_getopen_action``.
"""

from __future__ import annotations

from keepaway.agents.belief import AgentMemory, Belief, Decisions, write_action
from keepaway.agents.config import GETOPEN_EXTERNAL, PASS_EXTERNAL, PASS_HANDCODED, PASS_RANDOM
from keepaway.agents.geometry import ball_kickable
from keepaway.agents.getopen import getopen, grid_point, move_to_spot, note_getopen
from keepaway.agents.interception import fastest_to_ball, intercept
from keepaway.agents.kicks import hold_ball, pass_ball
from keepaway.agents.movement import neck_to_ball, neck_to_point, neck_with_body, search_ball
from keepaway.agents.state_vars import pass_state
from keepaway.core.jit import borrowing
from keepaway.core.rng import randint

NO_PASS_DECISION = 0
PASS_DECISION_START = 1  # learner: startEpisode(state)
PASS_DECISION_STEP = 2  # learner: step(reward = time - t_last, state)
GETOPEN_DECISION = 3  # GETOPEN_EXTERNAL: the caller picks a grid point (execute_getopen_action)


@borrowing
def handcoded_pass(state, n_keepers: int, n_takers: int, cfg) -> int:
    """P:HC (docs/players.md §6.2): hold if dist(K1, T1) > C1; else val_i = C2 min_j ang(Ki, K1, Tj)
    + min_j dist(Ki, Tj) for i >= 2, pass to the best if above C3 (first wins ties), else hold.
    Action k >= 1 passes to K(k+1)."""
    k, t = n_keepers, n_takers
    if state[2 * k + t - 1] > cfg.hc_hold_distance:
        return 0
    dist_at = 2 * k + 2 * t - 1
    ang_at = dist_at + k - 1
    action, best = 0, cfg.hc_pass_threshold
    for i in range(k - 1):
        v = cfg.hc_angle_weight * state[ang_at + i] + state[dist_at + i]
        if v > best:
            action, best = i + 1, v
    return action


@borrowing
def execute_pass_action(bel: Belief, r: int, mem: AgentMemory, action: int, kp, cfg, out: Decisions) -> None:
    """Record and execute Pass action ``action`` (0 = HoldBall, k = PassBall to the k-th nearest
    teammate), neck to the ball (docs/players.md §2 steps 3c-3d)."""
    mem.last_action[r] = action
    mem.t_last[r] = bel.time[r]
    if action == 0:
        code, a1, a2 = hold_ball(bel, r, cfg.hold_ratio_keeper, kp, cfg)
    else:
        code, a1, a2 = pass_ball(bel, r, action, kp, cfg)
    write_action(r, code, a1, a2, neck_to_ball(bel, r, code, a1, kp), out)


@borrowing
def execute_getopen_action(bel: Belief, r: int, mem: AgentMemory, point: int, kp, cfg, out: Decisions) -> None:
    """Move towards grid point ``point`` (``agents.getopen.grid_point``) as every GetOpen policy does,
    neck to the region centre (docs/players.md §7.5)."""
    px, py = grid_point(point, kp, cfg)
    note_getopen(bel, r, mem, px, py)
    code, a1, a2 = move_to_spot(bel, r, px, py, kp, cfg)
    write_action(r, code, a1, a2, neck_to_point(bel, r, code, a1, 0.0, 0.0, kp), out)


@borrowing
def keeper_decide(bel: Belief, r: int, mem: AgentMemory, theta, sums, kp, cfg, out: Decisions) -> int:
    """One keeper decision for row ``r`` (docs/players.md §2 steps 2-5), its command written into row ``r``
    of ``out`` and, at a Pass decision point, its Pass state into ``out.pass_state[r]``. ``theta`` is the
    row's GetOpen net parameters, ``sums`` the players' ``agents.interception.decay_sums``. Returns
    NO_PASS_DECISION, PASS_DECISION_START, PASS_DECISION_STEP or GETOPEN_DECISION (module docstring)."""
    me = bel.me[r]
    if bel.conf[r, 0] < cfg.ball_conf_threshold:
        code, a1, a2 = search_ball(bel, r, mem, kp, cfg)
        write_action(r, code, a1, a2, neck_with_body(bel, r), out)
        return NO_PASS_DECISION
    if ball_kickable(bel, r, me, kp):
        state = out.pass_state[r]
        if not pass_state(bel, r, cfg, state):
            code, a1, a2 = hold_ball(bel, r, cfg.hold_ratio_keeper, kp, cfg)
            neck = neck_to_ball(bel, r, code, a1, kp)
            write_action(r, code, a1, a2, neck, out)
            return NO_PASS_DECISION
        now = bel.time[r]
        if mem.t_last[r] >= 0 and mem.t_last[r] == now - 1 and mem.last_action[r] > 0:
            execute_pass_action(bel, r, mem, mem.last_action[r], kp, cfg, out)
            return NO_PASS_DECISION
        decision = PASS_DECISION_START if mem.t_last[r] < 0 else PASS_DECISION_STEP
        policy = int(cfg.pass_policy)
        if policy == PASS_EXTERNAL:
            return decision
        if policy == PASS_RANDOM:
            action = randint(mem.rng, r, bel.n_keepers)
        elif policy == PASS_HANDCODED:
            action = handcoded_pass(state, bel.n_keepers, bel.n_takers, cfg)
        else:
            action = 0
        execute_pass_action(bel, r, mem, action, kp, cfg, out)
        return decision
    chaser, ball_cycles = fastest_to_ball(bel, r, 1, bel.n_keepers, sums, kp, cfg)
    if chaser == me:
        # fastest_to_ball already found my first reachable cycle: ball_cycles
        code, a1, a2 = intercept(bel, r, mem, sums, kp, cfg, ball_cycles)
        write_action(r, code, a1, a2, neck_to_ball(bel, r, code, a1, kp), out)
        return NO_PASS_DECISION
    if int(cfg.getopen_policy) == GETOPEN_EXTERNAL:
        return GETOPEN_DECISION
    code, a1, a2 = getopen(bel, r, mem, theta, ball_cycles, kp, cfg)
    neck = neck_to_point(bel, r, code, a1, 0.0, 0.0, kp)
    write_action(r, code, a1, a2, neck, out)
    return NO_PASS_DECISION


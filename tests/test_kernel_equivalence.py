"""The optimised decision and world-model kernels decide exactly as the straightforward code they replaced.

``agents/interception.py`` fuses the interception travel simulation (decay sums from a table, the body's cosine
and sine kept between turns, an early stop once the target is provably out of reach), a keeper reuses its
``fastest_to_ball`` result in ``interception_point``, ``agents/tracking.py`` computes each flag's
trigonometry once in ``localise_row``, the travel simulation, GO:HC's lane and congestion tests and the
dash's speed cap decide their comparisons on sqrt estimates unless they are within a hair of the
threshold (``agents.geometry.DECIDE_SLACK``), the Sarsa tile hashing sums each tile's table words from
parts shared by its tilings, and the Pass and GetOpen variables take each distance once per vertex (and
what no grid point changes once per decision) and the smallest of several angles from the largest
cosine. None of this may change a decision or a belief by one bit. The
references below are the pre-optimisation kernels kept verbatim as plain step-by-step code
(docs/players.md §4.3, §5.2 step 2; the Procrustes fit of ``localise_row``), compiled by numba
without caching so their floating-point arithmetic is the kernels' (Python's own ``math.hypot`` rounds
differently). They are compared on hand-built beliefs and on every belief row of a short batched game.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from keepaway.agents.belief import AgentMemory, belief_from_truth, new_memory
from keepaway.agents.config import AgentConfig
from keepaway.agents.geometry import (
    ACOS_ESTIMATE_ERROR,
    acos_estimate,
    closest_to_ball,
    compared_hypot,
    direction,
    distance,
    final_position,
    nearer_than,
    normalize_angle,
    rolled_out,
)
from keepaway.agents.getopen import (
    TANH_ESTIMATE_ERROR,
    grid_point,
    grid_size,
    handcoded_target,
    lane_origin,
    learned_target,
    net_estimate_error,
    net_first_layer,
    net_output,
    net_output_estimate,
    net_value,
    predicted_ball_pos,
    tanh_estimate,
)
from keepaway.agents.interception import (
    UNKNOWN_FIRST,
    _longest_run,
    decay_sums,
    fastest_to_ball,
    interception_point,
    travel,
)
from keepaway.agents.sarsa import (
    CHECK_INCREMENT,
    EMPTY_SLOT,
    INDEX_INCREMENT,
    MAX_LONG_INT,
    SarsaConfig,
    load_policy_arrays,
    load_tiles,
    policy_arrays,
    quantize,
    tiling_coordinate,
    unh_hash,
)
from keepaway.agents.sarsa import new_memory as new_sarsa_memory
from keepaway.agents.state_vars import (
    ESTIMATE_ANGLE_ERROR,
    ESTIMATE_DISTANCE_ERROR,
    getopen_point_estimate,
    getopen_point_state,
    getopen_setup,
    getopen_state,
    pass_state,
    vertex_scratch,
)
from keepaway.agents.tracking import ModelState, SeeBuffer, localise_row, whole_degree_table
from keepaway.core.objects import CMD_DASH, CMD_TURN
from keepaway.core.rng import seed_streams
from keepaway.protocol.landmarks import FLAG_POSITIONS
from keepaway.protocol.params import parameter_set
from keepaway.runner.batched import BatchedArenas

PARAMS = parameter_set("classic")
KP = PARAMS.kernel()
CFG = AgentConfig().kernel()
SUMS = decay_sums(KP, CFG)
K, T = 3, 2
N = 1 + K + T


# ---------------------------------------------------------------------------------------- references


@njit
def _ref_geometric_sum(decay, n):
    return (1.0 - decay**n) / (1.0 - decay)


@njit
def _ref_rolled_out(px, py, vx, vy, n, decay):
    f = _ref_geometric_sum(decay, n)
    return px + vx * f, py + vy * f


@njit
def _ref_turn_moment(angle, speed, kp):
    m = angle * (1.0 + kp.inertia_moment * speed)
    return min(kp.max_moment, max(kp.min_moment, m))


@njit
def _ref_dash_power_for(dx, dy, body, vx, vy, effort, cycles, kp):
    rad = math.radians(body)
    cs, sn = math.cos(rad), math.sin(rad)
    forward = dx * cs + dy * sn
    n = max(1.0, cycles)
    speed = forward / _ref_geometric_sum(kp.player_decay, n)
    speed = min(speed, kp.player_speed_max)
    speed -= vx * cs + vy * sn
    power = speed / (kp.dash_power_rate * effort)
    return min(kp.max_dash_power, max(kp.min_power, power))  # the C++ players' belief: min_power


@njit
def _ref_player_step(px, py, vx, vy, body, effort, cmd, a1, kp):
    if cmd == CMD_DASH:
        power = min(kp.max_dash_power, max(kp.min_power, a1))
        acc = effort * power * kp.dash_power_rate
        acc = min(acc, kp.player_accel_max) if acc > 0.0 else max(acc, -kp.player_accel_max)
        rad = math.radians(body)
        vx += acc * math.cos(rad)
        vy += acc * math.sin(rad)
        speed = math.hypot(vx, vy)
        if speed > kp.player_speed_max:
            vx *= kp.player_speed_max / speed
            vy *= kp.player_speed_max / speed
    elif cmd == CMD_TURN:
        m = min(kp.max_moment, max(kp.min_moment, a1))
        body = normalize_angle(body + m / (1.0 + kp.inertia_moment * math.hypot(vx, vy)))
    px += vx
    py += vy
    return px, py, vx * kp.player_decay, vy * kp.player_decay, body


@njit
def _ref_intercept_move(px, py, vx, vy, body, effort, tx, ty, cycles, kp, cfg):
    qx, qy = _ref_rolled_out(px, py, vx, vy, min(cycles, cfg.intercept_roll_cycles), kp.player_decay)
    angle = normalize_angle(direction(tx - qx, ty - qy) - body)
    ahead = distance(qx, qy, tx, ty)
    far = distance(px, py, tx, ty)
    if far > cfg.turn_far_distance:
        ratio = cfg.turn_ratio_far
    elif far > cfg.turn_mid_distance:
        ratio = cfg.turn_ratio_mid
    else:
        ratio = cfg.turn_ratio_near
    off_line = ahead * abs(math.sin(math.radians(angle)))
    back_distance = cfg.intercept_back_distance
    behind = ahead > back_distance and abs(angle) > 90.0
    kickable = kp.player_size + kp.kickable_margin + kp.ball_size
    if off_line > ratio * kickable or behind:
        # WorldModel::predictCommandTurnTowards: count the turns (at most 5) that bring the point within
        # ratio x kickable of the body line; more than one, close and soon -> turn the back to it instead
        turns, b, speed = 0, body, math.hypot(vx, vy)
        while turns < 5 and (
            ahead * abs(math.sin(math.radians(direction(tx - qx, ty - qy) - b))) > ratio * kickable or behind
        ):
            a = normalize_angle(direction(tx - qx, ty - qy) - b)
            b = normalize_angle(b + min(kp.max_moment, max(kp.min_moment, _ref_turn_moment(a, speed, kp)))
                                / (1.0 + kp.inertia_moment * speed))
            speed *= kp.player_decay
            turns += 1
        if turns > 1 and cycles < 4 and ahead < back_distance:
            back = normalize_angle(direction(tx - qx, ty - qy) + 180.0 - body)
            m = _ref_turn_moment(back, math.hypot(vx, vy), kp)
            nb = body + min(kp.max_moment, max(kp.min_moment, m)) / (1.0 + kp.inertia_moment * math.hypot(vx, vy))
            if ahead * abs(math.sin(math.radians(direction(tx - qx, ty - qy) - nb))) < 0.9 * kickable:
                return CMD_TURN, m
        return CMD_TURN, _ref_turn_moment(angle, math.hypot(vx, vy), kp)
    return CMD_DASH, _ref_dash_power_for(tx - px, ty - py, body, vx, vy, effort, cycles, kp)


@njit
def _ref_travel(px, py, vx, vy, body, effort, tx, ty, radius, n, kp, cfg):
    """Every one of the n moves simulated (no early stop but the original one before the loop)."""
    reached = n + 1
    if distance(px, py, tx, ty) - radius > n * max(kp.player_speed_max, math.hypot(vx, vy)):
        return reached, math.inf
    for c in range(n + 1):
        if reached > n and distance(px, py, tx, ty) < radius:
            reached = c
        if c == n:
            break
        code, a1 = _ref_intercept_move(px, py, vx, vy, body, effort, tx, ty, n - c, kp, cfg)
        px, py, vx, vy, body = _ref_player_step(px, py, vx, vy, body, effort, code, a1, kp)
    return reached, distance(px, py, tx, ty)


@njit
def _ref_player_travel(pos, vel, body, effort, me, obj, tx, ty, n, kp, cfg):
    eff = effort if obj == me else kp.effort_init
    kickable = kp.player_size + kp.kickable_margin + kp.ball_size
    return _ref_travel(pos[obj, 0], pos[obj, 1], vel[obj, 0], vel[obj, 1], body[obj], eff, tx, ty, kickable,
                       n, kp, cfg)


@njit
def _ref_ball_plan(pos, vel, n, kp):
    return rolled_out(pos[0, 0], pos[0, 1], vel[0, 0], vel[0, 1], n, kp.ball_decay)


@njit
def _ref_interception_point(pos, vel, body, effort, me, time, last_x, last_y, last_time, kp, cfg):
    """Returns (i, x, y): every candidate cycle's travel simulated in full."""
    fx, fy = final_position(pos[me, 0], pos[me, 1], vel[me, 0], vel[me, 1], kp.player_decay)
    kickable = kp.player_size + kp.kickable_margin + kp.ball_size
    ball_speed = math.hypot(vel[0, 0], vel[0, 1])
    recent = last_time >= 0 and time - last_time <= cfg.stability_window
    first, stable = -1, -1
    for i in range(int(cfg.intercept_horizon) + 1):
        if first >= 0 and i > first + cfg.stability_window:
            break
        bx, by = _ref_ball_plan(pos, vel, i, kp)
        if abs(bx) > kp.pitch_length / 2.0 or abs(by) > kp.pitch_width / 2.0:
            break
        if distance(fx, fy, bx, by) / kp.player_speed_max > i + kickable:
            continue
        reached, end = _ref_player_travel(pos, vel, body, effort, me, me, bx, by, i, kp, cfg)
        if reached > i:
            continue
        if first < 0:
            first = i
            if not recent:
                break
        if (
            stable < 0
            and i <= first + cfg.stability_window
            and distance(bx, by, last_x, last_y) < cfg.stability_radius
            and end < cfg.stability_margin * kickable
            and ball_speed * kp.ball_decay**i > cfg.stability_ball_speed
        ):
            stable = i
    chosen = stable if stable >= 0 else first
    if chosen < 0:  # none within reach: the C++ heads for the ball 100 cycles ahead
        x, y = _ref_ball_plan(pos, vel, cfg.no_intercept_cycles, kp)
        return -1, x, y
    x, y = _ref_ball_plan(pos, vel, chosen, kp)
    return chosen, x, y


@njit
def _ref_fastest_to_ball(pos, vel, body, effort, conf, me, first, last, kp, cfg):
    horizon = int(cfg.intercept_horizon)
    for i in range(horizon + 1):
        bx, by = rolled_out(pos[0, 0], pos[0, 1], vel[0, 0], vel[0, 1], i, kp.ball_decay)
        best, best_c = -1, i + 1
        for j in range(first, last + 1):
            if j != me and conf[j] < cfg.player_conf_threshold:
                continue
            c, _ = _ref_player_travel(pos, vel, body, effort, me, j, bx, by, i, kp, cfg)
            if c < best_c:
                best, best_c = j, c
        if best >= 0:
            return best, i
    return -1, horizon + 1


@njit
def _ref_localise(flag_obs, flag_id, n, flag_pos, body, neck, kp):
    """(x, y, body) of ``localise_row`` as first written: the trigonometry evaluated in both sums."""
    rel = (kp.quantize_step_l ** 2 + math.radians(1.0) ** 2) / 12.0
    sw = mqx = mqy = mfx = mfy = 0.0
    for i in range(n):
        d = flag_obs[i, 0]
        a = math.radians(flag_obs[i, 1])
        w = 1.0 / (d * d * rel + 0.1 ** 2 / 12.0)
        sw += w
        mqx += w * d * math.cos(a)
        mqy += w * d * math.sin(a)
        mfx += w * flag_pos[flag_id[i], 0]
        mfy += w * flag_pos[flag_id[i], 1]
    mqx /= sw
    mqy /= sw
    mfx /= sw
    mfy /= sw
    if n >= 2:
        dot = cross = 0.0
        for i in range(n):
            d = flag_obs[i, 0]
            a = math.radians(flag_obs[i, 1])
            w = 1.0 / (d * d * rel + 0.1 ** 2 / 12.0)
            qx = d * math.cos(a) - mqx
            qy = d * math.sin(a) - mqy
            fx = flag_pos[flag_id[i], 0] - mfx
            fy = flag_pos[flag_id[i], 1] - mfy
            dot += w * (qx * fx + qy * fy)
            cross += w * (qx * fy - qy * fx)
        head = math.degrees(math.atan2(cross, dot))
    else:
        head = body + neck
    h = math.radians(head)
    c = math.cos(h)
    sn = math.sin(h)
    return mfx - (c * mqx - sn * mqy), mfy - (sn * mqx + c * mqy), normalize_angle(head - neck)


@njit
def _ref_vertex_angle(ax, ay, bx, by, cx, cy):
    ux, uy = ax - bx, ay - by
    vx, vy = cx - bx, cy - by
    nu = math.hypot(ux, uy)
    nv = math.hypot(vx, vy)
    if nu == 0.0 or nv == 0.0:
        return 0.0
    return math.degrees(math.acos(min(1.0, max(-1.0, (ux * vx + uy * vy) / (nu * nv)))))


@njit
def _ref_handcoded_target(pos, conf, me, bx, by, kp, cfg):
    """GO:HC as it was: every lane's angle by acos, every admissible point's congestion by hypots."""
    best_x, best_y, best = 0.0, 0.0, math.inf
    for k in range(grid_size(cfg)):
        px, py = grid_point(k, kp, cfg)
        open_lane = True
        for j in range(1 + K, 1 + K + T):
            if conf[j] >= cfg.player_conf_threshold and _ref_vertex_angle(
                    px, py, bx, by, pos[j, 0], pos[j, 1]) < cfg.go_safety_angle:
                open_lane = False
        if not open_lane:
            continue
        c = 0.0
        for j in range(1, 1 + K + T):
            if j == me or conf[j] < cfg.player_conf_threshold:
                continue
            d = math.hypot(pos[j, 0] - px, pos[j, 1] - py)
            if d > 0.0:
                c += 1.0 / d
        if c < best:
            best_x, best_y, best = px, py, c
    return best_x, best_y


@njit
def _ref_sorted(pos, vx, vy, first, last, skip):
    out = np.empty(last - first + 1, dtype=np.int64)
    n = 0
    for j in range(first, last + 1):
        if j == skip:
            continue
        d = math.hypot(pos[j, 0] - vx, pos[j, 1] - vy)
        k = n
        while k > 0 and math.hypot(pos[out[k - 1], 0] - vx, pos[out[k - 1], 1] - vy) > d:
            out[k] = out[k - 1]
            k -= 1
        out[k] = j
        n += 1
    return out[:n]


@njit
def _ref_around_vertex(pos, vx, vy, keepers, takers, out, at):
    """The shared block as it was: every distance and every angle computed where it is used."""
    nk, nt = keepers.shape[0], takers.shape[0]
    for i in range(nk):
        out[at + i] = math.hypot(pos[keepers[i], 0] - vx, pos[keepers[i], 1] - vy)
    at += nk
    for j in range(nt):
        out[at + j] = math.hypot(pos[takers[j], 0] - vx, pos[takers[j], 1] - vy)
    at += nt
    for i in range(nk):
        kx, ky = pos[keepers[i], 0], pos[keepers[i], 1]
        near, narrow = math.inf, math.inf
        for j in range(nt):
            tx, ty = pos[takers[j], 0], pos[takers[j], 1]
            near = min(near, math.hypot(tx - kx, ty - ky))
            narrow = min(narrow, _ref_vertex_angle(kx, ky, vx, vy, tx, ty))
        out[at + i] = near
        out[at + nk + i] = narrow
    return at + 2 * nk


@njit
def _ref_getopen_state(pos, me, px, py, ox, oy):
    out = np.empty(3 * K + T - 1)
    takers = _ref_sorted(pos, px, py, K + 1, K + T, -1)
    at = _ref_around_vertex(pos, px, py, _ref_sorted(pos, px, py, 1, K, me), takers, out, 0)
    out[at] = math.hypot(px - ox, py - oy)
    lane = math.inf
    for j in range(takers.shape[0]):
        lane = min(lane, _ref_vertex_angle(px, py, ox, oy, pos[takers[j], 0], pos[takers[j], 1]))
    out[at + 1] = lane
    return out


@njit
def _ref_pass_state(pos, k1):
    out = np.empty(4 * K + 2 * T - 3)
    vx, vy = pos[k1, 0], pos[k1, 1]
    keepers = _ref_sorted(pos, vx, vy, 1, K, k1)
    takers = _ref_sorted(pos, vx, vy, K + 1, K + T, -1)
    out[0] = math.hypot(vx, vy)
    for i in range(keepers.shape[0]):
        out[1 + i] = math.hypot(pos[keepers[i], 0], pos[keepers[i], 1])
    for j in range(takers.shape[0]):
        out[1 + K - 1 + j] = math.hypot(pos[takers[j], 0], pos[takers[j], 1])
    _ref_around_vertex(pos, vx, vy, keepers, takers, out, K + T)
    return out


def _check_state_variables(bel, r, kp=KP) -> None:
    """Every grid point's GetOpen variables and the Pass variables of row ``r`` as the reference's."""
    pos, me = bel.pos[r], int(bel.me[r])
    if me <= K:
        _, cycles = fastest_to_ball(bel, r, 1, K, decay_sums(kp, CFG), kp, CFG)
        ox, oy = lane_origin(bel, r, cycles, kp, CFG)
        out = np.empty(3 * K + T - 1)
        for k in range(grid_size(CFG)):
            px, py = grid_point(k, kp, CFG)
            getopen_state(bel, r, px, py, ox, oy, out)
            np.testing.assert_array_equal(out, _ref_getopen_state(pos, me, px, py, ox, oy),
                                          err_msg=f"row {r} point {k}")
    out = np.empty(4 * K + 2 * T - 3)
    if pass_state(bel, r, CFG, out):
        np.testing.assert_array_equal(out, _ref_pass_state(pos, closest_to_ball(bel, r, 1, K, -1, CFG)),
                                      err_msg=f"row {r}")


def _ref_load_tiles(config: SarsaConfig, state, check_table: np.ndarray | None = None,
                    counts: np.ndarray | None = None) -> np.ndarray:
    """LinearSarsaAgent::loadTiles with tiles2.cc's safe hash, tile by tile through ``unh_hash``, on
    ``check_table`` (a fresh one if None) and counting into ``counts`` (calls, clear hits, collisions):
    the slots in hashing order."""
    mem = new_sarsa_memory(config, K, T, 1, 0)
    if check_table is None:
        check_table = np.full(mem.hash_check.shape[1], EMPTY_SLOT, dtype=np.int64)
    counts = np.zeros(3, dtype=np.int64) if counts is None else counts
    m = check_table.shape[0]
    tilings = config.tilings
    slots = []
    for cv, v in enumerate(mem.code_order):
        q = quantize(state[v], mem.widths[v], tilings)
        for a in range(mem.tiles.shape[1]):
            for j in range(tilings):
                c = tiling_coordinate(q, j, tilings)
                index = unh_hash(c, j, a, cv, INDEX_INCREMENT, m)
                check = unh_hash(c, j, a, cv, CHECK_INCREMENT, MAX_LONG_INT)
                stride = 1 + 2 * unh_hash(c, j, a, cv, INDEX_INCREMENT, MAX_LONG_INT // 4)
                counts[0] += 1
                counts[1] += check_table[index] in (check, EMPTY_SLOT)
                while check_table[index] not in (check, EMPTY_SLOT):
                    counts[2] += 1
                    index = (index + stride) % m
                check_table[index] = check
                slots.append(index)
    return np.array(slots)


def _loaded_slots(mem) -> np.ndarray:
    """Row 0's loaded tile slots in hashing order (variable, action, tiling)."""
    tilings = mem.tiles.shape[2] // len(mem.code_order)
    return np.concatenate([mem.tiles[0, a].reshape(-1, tilings)[cv]
                           for cv in range(len(mem.code_order)) for a in range(mem.tiles.shape[1])])


# ------------------------------------------------------------------------------------------ helpers


def _memory(last_point: tuple[float, float] | None, last_time: int) -> AgentMemory:
    mem = new_memory(1, seed_streams(0, 1))
    if last_point is not None:
        mem.intercept_point[0] = last_point
        mem.intercept_time[0] = last_time
    return mem


def _check_interception(bel, r: int, last_point, last_time: int, kp=KP) -> None:
    """The kernel's interception point of row ``r`` equals the reference's, bit for bit."""
    me, time = int(bel.me[r]), int(bel.time[r])
    lx, ly = last_point if last_point is not None else (0.0, 0.0)
    ref = _ref_interception_point(bel.pos[r], bel.vel[r], bel.body[r], bel.effort[r], me, time, lx, ly,
                                  last_time if last_point is not None else -1, kp, CFG)
    one = belief_from_truth(bel.pos[r], bel.vel[r], bel.body[r], bel.neck[r], me, time, K, T, bel.effort[r])
    one.conf[0] = bel.conf[r]
    got = interception_point(one, 0, _memory(last_point, last_time), decay_sums(kp, CFG), kp, CFG, UNKNOWN_FIRST)
    assert got == ref


@njit
def _ref_net_value(theta, x):
    """The GO:L net as it was before tanh was estimated: every unit squashed by libm's tanh."""
    n = x.shape[0]
    at = 5 * n
    h1 = np.empty(5)
    for u in range(5):
        z = theta[at + u]
        for i in range(n):
            z += theta[u * n + i] * x[i]
        h1[u] = 1.7159 * math.tanh((2.0 / 3.0) * z)
    w2 = at + 5
    b2 = w2 + 25
    w3 = b2 + 5
    out = theta[w3 + 5]
    for u in range(5):
        z = theta[b2 + u]
        for i in range(5):
            z += theta[w2 + u * 5 + i] * h1[i]
        out += theta[w3 + u] * 1.7159 * math.tanh((2.0 / 3.0) * z)
    return out


def _ref_learned_target(bel, r, theta, kp=KP):
    """GO:L scoring every grid point exactly, in scan order, exact ties to the point nearest to me."""
    _, cycles = fastest_to_ball(bel, r, 1, K, decay_sums(kp, CFG), kp, CFG)
    ox, oy = lane_origin(bel, r, cycles, kp, CFG)
    me = int(bel.me[r])
    x = np.empty(3 * K + T - 1)
    best_xy, best, best_d = (0.0, 0.0), -math.inf, math.inf
    for k in range(grid_size(CFG)):
        px, py = grid_point(k, kp, CFG)
        getopen_state(bel, r, px, py, ox, oy, x)
        v = _ref_net_value(theta, x)
        d = distance(bel.pos[r, me, 0], bel.pos[r, me, 1], px, py)
        if v > best or (v == best and d < best_d):
            best_xy, best, best_d = (px, py), v, d
    return best_xy, cycles


def _random_beliefs(count: int, seed: int):
    """Beliefs of a 3v2 game in a 20 m region: players anywhere near it, slow; the ball fast or slow."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-12.0, 12.0, (count, N, 2))
    vel = rng.uniform(-0.3, 0.3, (count, N, 2))
    vel[:, 0] = rng.uniform(-2.2, 2.2, (count, 2)) * rng.uniform(0.0, 1.0, (count, 1))
    body = rng.uniform(-180.0, 180.0, (count, N))
    me = rng.integers(1, N, count)
    effort = rng.uniform(0.6, 1.0, count)
    return belief_from_truth(pos, vel, body, np.zeros((count, N)), me, 100, K, T, effort)


# -------------------------------------------------------------------------------------------- tests


def test_interception_of_a_ball_rolling_towards_me_matches_the_reference():
    # the case of test_skills: ball from (-10, 0) at 1.5 m/cycle towards me at (0, 0) facing it -> i = 5
    pos = np.array([[-10.0, 0.0], [0.0, 0.0], [9.0, 0.0], [0.0, 9.0], [-20.0, -20.0], [-20.0, 20.0]])
    vel = np.zeros((N, 2))
    vel[0] = (1.5, 0.0)
    bel = belief_from_truth(pos, vel, [0, 180, 0, 0, 0, 0], np.zeros(N), 1, 50, K, T)
    ref = _ref_interception_point(pos, vel, bel.body[0], 1.0, 1, 50, 0.0, 0.0, -1, KP, CFG)
    assert ref[0] == 5
    _check_interception(bel, 0, None, -1)
    # chosen last cycle near x_6 = -10 + 25 (1 - 0.94^6) = -2.25: the stability rule may prefer it
    _check_interception(bel, 0, (-2.25, 0.0), 49)


@pytest.mark.parametrize("params", ["classic", "current"])  # current: no backward dashes
def test_interception_point_matches_the_reference_on_random_beliefs(params):
    kp = parameter_set(params).kernel()
    bel = _random_beliefs(150, seed=11)
    for r in range(bel.batch):
        _check_interception(bel, r, None, -1, kp)
        # recently intercepted near the ball's position 3 cycles ahead: the stability scan runs
        bx, by = rolled_out(bel.pos[r, 0, 0], bel.pos[r, 0, 1], bel.vel[r, 0, 0], bel.vel[r, 0, 1], 3.0,
                            kp.ball_decay)
        _check_interception(bel, r, (bx, by), int(bel.time[r]) - 1, kp)


def test_fastest_to_ball_matches_the_reference_on_random_beliefs():
    bel = _random_beliefs(150, seed=5)
    bel.conf[:, 2] = np.where(np.arange(bel.batch) % 3 == 0, 0.5, 1.0)  # keeper 2 sometimes unusable
    for r in range(bel.batch):
        ref = _ref_fastest_to_ball(bel.pos[r], bel.vel[r], bel.body[r], bel.effort[r], bel.conf[r],
                                   int(bel.me[r]), 1, K, KP, CFG)
        assert fastest_to_ball(bel, r, 1, K, SUMS, KP, CFG) == ref


def test_travel_stops_early_only_where_the_full_simulation_misses_the_target():
    """Targets placed within a few centimetres either side of the longest run (``_longest_run``), where the
    early stop decides: every answer is the full simulation's, for every player speed and heading."""
    rng = np.random.default_rng(61)
    kickable = KP.player_size + KP.kickable_margin + KP.ball_size
    stopped = 0
    for _ in range(3000):
        n = int(rng.integers(0, 16))
        speed, heading, body = rng.uniform(0.0, 1.3), rng.uniform(-180.0, 180.0), rng.uniform(-180.0, 180.0)
        vx, vy = speed * math.cos(math.radians(heading)), speed * math.sin(math.radians(heading))
        effort = rng.choice([1.0, rng.uniform(0.6, 1.0)])
        aim = math.radians(rng.choice([heading, body, rng.uniform(-180.0, 180.0)]))
        far = kickable + _longest_run(speed, n, effort, SUMS, KP) + rng.uniform(-0.05, 0.05)
        tx, ty = 1.0 + far * math.cos(aim), -2.0 + far * math.sin(aim)
        for need_end in (False, True):
            got = travel(1.0, -2.0, vx, vy, body, effort, tx, ty, kickable, n, need_end, SUMS, KP, CFG)
            ref = _ref_travel(1.0, -2.0, vx, vy, body, effort, tx, ty, kickable, n, KP, CFG)
            assert got[0] == ref[0]
            if need_end and got[0] <= n:
                assert got[1] == ref[1]
            stopped += got[1] == math.inf
    assert stopped > 1000  # the early stop was exercised, not only the simulation


@njit
def _libm_hypot(dx, dy):
    return math.hypot(dx, dy)


def test_compared_hypot_compares_as_the_exact_hypot():
    """On thresholds at the exact length, a float either side of it, at the sqrt estimate and anywhere,
    and on lengths that are not finite: <, <= and > come out as with libm's hypot (the kernels')."""
    rng = np.random.default_rng(67)
    cases = [(math.inf, 1.0), (math.nan, 1.0), (math.inf, math.nan), (1e200, 1e200), (1e-200, 0.0), (0.0, 0.0)]
    cases += [tuple(rng.uniform(-30.0, 30.0, 2) * rng.choice([1e-3, 1.0, 1e3])) for _ in range(2000)]
    differ = 0
    for dx, dy in cases:
        exact, rough = _libm_hypot(dx, dy), math.sqrt(dx * dx + dy * dy)
        differ += exact != rough
        for t in (exact, np.nextafter(exact, 0.0), np.nextafter(exact, math.inf), rough, 0.0, 1.0, 25.0):
            got = compared_hypot(dx, dy, t)
            assert (got < t, got <= t, got > t) == (exact < t, exact <= t, exact > t)
    assert differ > 100  # the estimate does differ from hypot in the last bit, often


def test_nearer_than_is_the_exact_hypot_of_nearer_points_only():
    """On the cases of the test above and limits at, beside and far from the exact length (inf: the
    first point of a search): libm's hypot where it is below the limit, inf where it is not."""
    rng = np.random.default_rng(71)
    cases = [(math.inf, 1.0), (math.nan, 1.0), (1e200, 1e200), (1e-200, 0.0), (0.0, 0.0), (3.0, 4.0)]
    cases += [tuple(rng.uniform(-30.0, 30.0, 2) * rng.choice([1e-3, 1.0, 1e3])) for _ in range(2000)]
    for dx, dy in cases:
        exact = _libm_hypot(dx, dy)
        for t in (exact, np.nextafter(exact, 0.0), np.nextafter(exact, math.inf), 0.0, 5.0, 25.0, math.inf):
            got = nearer_than(dx, dy, t)
            assert got == (exact if exact < t else math.inf), (dx, dy, t)
    assert nearer_than(3.0, 4.0, 5.5) == 5.0 and nearer_than(3.0, 4.0, 5.0) == math.inf


def test_every_belief_of_a_batched_game_decides_as_the_reference():
    """Beliefs of real play (noisy world models, held and passed balls): the interception point with and
    without the keeper's ``fastest_to_ball`` hint, and ``fastest_to_ball`` itself, equal the reference."""
    arenas = BatchedArenas(PARAMS, batch=4, seed=7, threads=1)
    checked = hinted = 0
    for _ in range(20):
        arenas.run(max_cycles=15)
        bel, mem = arenas.players.belief, arenas.players.memory
        for r in range(bel.batch):
            if bel.conf[r, 0] < CFG.ball_conf_threshold:
                continue
            me, last = int(bel.me[r]), (float(mem.intercept_point[r, 0]), float(mem.intercept_point[r, 1]))
            _check_interception(bel, r, last, int(mem.intercept_time[r]))
            fastest = fastest_to_ball(bel, r, 1, K, SUMS, KP, CFG)
            assert fastest == _ref_fastest_to_ball(bel.pos[r], bel.vel[r], bel.body[r], bel.effort[r],
                                                   bel.conf[r], me, 1, K, KP, CFG)
            checked += 1
            if fastest[0] == me:
                for last_time in (int(mem.intercept_time[r]), -1):
                    plain, hint = _memory(last, last_time), _memory(last, last_time)
                    one = belief_from_truth(bel.pos[r], bel.vel[r], bel.body[r], bel.neck[r], me, bel.time[r],
                                            K, T, bel.effort[r])
                    assert (interception_point(one, 0, hint, SUMS, KP, CFG, fastest[1])
                            == interception_point(one, 0, plain, SUMS, KP, CFG, UNKNOWN_FIRST))
                    assert np.array_equal(hint.intercept_point, plain.intercept_point)
                hinted += 1
    assert checked > 300 and hinted > 40  # the game gave the kernels something to decide (400 and 80)


def test_localisation_matches_the_reference_on_real_sees():
    """Every see row of a short batched game localises as the two-pass reference."""
    arenas = BatchedArenas(PARAMS, batch=4, seed=2, threads=1)
    arenas.run(max_cycles=30)
    see, model = arenas.players.see, arenas.players.model
    state = ModelState(*[a.copy() for a in model])
    for r in range(see.cycle.shape[0]):
        for n in (int(see.n_flags[r]), 2, 1):
            one = SeeBuffer(*[a.copy() for a in see])
            one.n_flags[r] = n
            me = state.me[r]
            ref = _ref_localise(one.flag_obs[r], one.flag_id[r], n, FLAG_POSITIONS, state.body[r, me],
                                state.neck[r, me], KP)
            s = ModelState(*[a.copy() for a in state])
            localise_row(r, s, one, FLAG_POSITIONS, KP)
            assert (s.pos[r, me, 0], s.pos[r, me, 1], s.body[r, me]) == ref


def _check_handcoded_target(bel, r: int, kp=KP) -> tuple[float, float]:
    _, cycles = fastest_to_ball(bel, r, 1, K, decay_sums(kp, CFG), kp, CFG)
    bx, by = predicted_ball_pos(bel, r, cycles, kp, CFG)
    ref = _ref_handcoded_target(bel.pos[r], bel.conf[r], int(bel.me[r]), bx, by, kp, CFG)
    assert handcoded_target(bel, r, cycles, False, kp, CFG) == ref
    return ref


@pytest.mark.parametrize("params", ["classic", "current"])
def test_handcoded_getopen_matches_the_reference_on_random_and_boundary_beliefs(params):
    kp = parameter_set(params).kernel()
    bel = _random_beliefs(200, seed=23)
    bel.conf[:, K + 1] = np.where(np.arange(bel.batch) % 4 == 0, 0.5, 1.0)  # a taker sometimes unusable
    bel.vel[:, 0] = 0.0  # the ball stays where it is: predictedBallPos is its position
    for r in range(bel.batch):
        if r % 2:
            # taker 1 exactly on the safety angle seen from the ball, for grid point 7 (and a keeper
            # exactly on point 12): the estimates cannot decide there, the exact code must
            px, py = grid_point(7, kp, CFG)
            bx, by = bel.pos[r, 0]
            a = math.atan2(py - by, px - bx) + math.radians(CFG.go_safety_angle)
            bel.pos[r, K + 1] = (bx + 4.0 * math.cos(a), by + 4.0 * math.sin(a))
            bel.pos[r, 2] = grid_point(12, kp, CFG)
        elif r % 4 == 2:
            # everyone on the x axis: each point off it ties exactly with its mirror image, and the
            # first in scan order (y < 0) must win, though the two estimates cannot tell them apart
            bel.pos[r, :, 1] = 0.0
            assert _check_handcoded_target(bel, r, kp)[1] <= 0.0
        _check_handcoded_target(bel, r, kp)


def _keeper_beliefs(arenas: BatchedArenas, rounds: int):
    """(belief, row) of every keeper that sees the ball, every 20 cycles of ``arenas``' game."""
    for _ in range(rounds):
        arenas.run(max_cycles=20)
        bel = arenas.players.belief
        for r in range(bel.batch):
            if bel.me[r] <= K and bel.conf[r, 0] >= CFG.ball_conf_threshold:
                yield bel, r


def test_handcoded_getopen_of_a_batched_game_matches_the_reference():
    checked = 0
    for bel, r in _keeper_beliefs(BatchedArenas(PARAMS, batch=4, seed=3, threads=1), 15):
        _check_handcoded_target(bel, r)
        checked += 1
    assert checked > 100


def test_state_variables_match_the_reference_on_random_and_boundary_beliefs():
    bel = _random_beliefs(200, seed=29)
    bel.conf[:] = 1.0
    bel.me[:] = np.arange(bel.batch) % K + 1
    for r in range(bel.batch):
        px, py = grid_point(r % grid_size(CFG), KP, CFG)
        if r % 4 == 1:  # the takers mirror images about the line from point to keeper: equal angles
            kx, ky = bel.pos[r, 2 if bel.me[r] != 2 else 3]
            tx, ty = bel.pos[r, K + 1]
            ux, uy = (kx - px) / math.hypot(kx - px, ky - py), (ky - py) / math.hypot(kx - px, ky - py)
            along = (tx - px) * ux + (ty - py) * uy
            bel.pos[r, K + 2] = (2 * (px + along * ux) - tx, 2 * (py + along * uy) - ty)
        elif r % 4 == 2:  # a keeper and a taker on a grid point: degenerate rays (angle 0)
            bel.pos[r, 2 if bel.me[r] != 2 else 3] = (px, py)
            bel.pos[r, K + 1] = grid_point((r + 5) % grid_size(CFG), KP, CFG)
        elif r % 4 == 3:  # two takers at one spot: equal cosines
            bel.pos[r, K + 2] = bel.pos[r, K + 1]
        _check_state_variables(bel, r)
        # GO:L decides there as scoring every point exactly (its estimates stand back where unsure)
        theta = np.random.default_rng(r).normal(0.0, 0.3, 91)
        (tx, ty), cycles = _ref_learned_target(bel, r, theta)
        assert learned_target(bel, r, theta, cycles, KP, CFG) == (tx, ty), f"row {r}"


def test_state_variables_and_learned_targets_of_a_batched_game_match_the_reference():
    rng = np.random.default_rng(4)
    nets = rng.normal(0.0, 0.3, (4, 91))
    arenas = BatchedArenas(PARAMS, batch=4, seed=5, getopen_policy="learned", getopen_theta=nets, threads=1)
    checked = 0
    for bel, r in _keeper_beliefs(arenas, 10):
        _check_state_variables(bel, r)
        theta = nets[r // (N - 1)]  # the arena's net
        (px, py), cycles = _ref_learned_target(bel, r, theta)
        assert learned_target(bel, r, theta, cycles, KP, CFG) == (px, py)
        checked += 1
    assert checked > 50


@pytest.mark.parametrize("spread", [0.0, 1e-6, 0.3, 1.0, 5.0, 1e4])
def test_learned_getopen_decided_on_estimates_is_the_exact_argmax(spread):
    # Nets from flat (every point ties: the nearest wins) through nearly flat (values closer than the
    # estimate's error: all scored exactly) to saturated (many exact ties) and huge (a loose bound).
    rng = np.random.default_rng(31)
    bel = _random_beliefs(120, seed=37)
    bel.conf[:] = 1.0
    bel.me[:] = np.arange(bel.batch) % K + 1
    for r in range(bel.batch):
        theta = rng.normal(0.0, spread, 91)
        if spread == 1e-6:
            theta[90] = 3.0
        (px, py), cycles = _ref_learned_target(bel, r, theta)
        assert learned_target(bel, r, theta, cycles, KP, CFG) == (px, py), f"row {r}"
        x = rng.uniform(-30.0, 30.0, 3 * K + T - 1)
        assert net_value(theta, x) == _ref_net_value(theta, x)


def test_the_tanh_estimate_stays_within_its_bound_and_the_net_estimate_within_its_own():
    z = np.linspace(-12.0, 12.0, 2_400_001)
    off = np.abs(np.array([tanh_estimate(v) for v in z[::100]]) - np.tanh(z[::100]))
    assert off.max() <= TANH_ESTIMATE_ERROR / 2 < off.max() * 2.1  # the bound is twice the worst seen
    # nets whose units land anywhere on tanh, including where the estimate is worst (|2z/3| near 5)
    rng = np.random.default_rng(41)
    worst = 0.0
    for _ in range(300):
        theta = rng.normal(0.0, rng.choice([0.3, 1.0, 3.0]), 91)
        bound = net_estimate_error(theta, 10, 0.0, 0.0)
        for x in rng.uniform(-20.0, 20.0, (20, 10)):
            z1 = np.empty(5)
            net_first_layer(theta, x, z1)
            estimate = net_output_estimate(theta, 10, z1, np.empty(5))
            exact = net_output(theta, 10, z1.copy())
            assert exact == _ref_net_value(theta, x)
            assert abs(estimate - exact) <= bound
            worst = max(worst, abs(estimate - exact) / bound)
    assert worst > 0.01  # the estimates do differ: the bound is what keeps the decisions exact


def test_the_net_estimate_bound_covers_inputs_off_by_their_error():
    rng = np.random.default_rng(53)
    worst = 0.0
    for _ in range(300):
        theta = rng.normal(0.0, rng.choice([0.03, 0.3, 1.0, 3.0]), 91)
        off = rng.choice([1e-6, 1e-3, 0.1])
        bound = net_estimate_error(theta, 10, off, 21.0)
        assert bound > net_estimate_error(theta, 10, 0.0, 0.0)
        for x in rng.uniform(-20.0, 20.0, (20, 10)):
            z1, z1_off = np.empty(5), np.empty(5)
            net_first_layer(theta, x, z1)
            net_first_layer(theta, x + rng.choice([-off, off], 10), z1_off)
            estimate = net_output_estimate(theta, 10, z1_off, np.empty(5))
            exact = net_output(theta, 10, z1)
            assert abs(estimate - exact) <= bound
            worst = max(worst, abs(estimate - exact) / bound)
    assert worst > 0.01


def test_the_acos_estimate_stays_within_its_bound():
    c = np.concatenate([np.linspace(-1.0, 1.0, 400_001), [-1.0, 1.0, 0.0, -0.0, 1.0 - 1e-16, -1.0 + 1e-16]])
    off = np.abs(np.array([acos_estimate(v) for v in c]) - np.arccos(c))
    assert off.max() <= ACOS_ESTIMATE_ERROR / 2 < off.max() * 2.1  # the bound is twice the worst seen


def test_estimated_getopen_variables_stay_within_their_bounds():
    bel = _random_beliefs(300, seed=47)
    bel.conf[:] = 1.0
    bel.me[:] = np.arange(bel.batch) % K + 1
    n = 3 * K + T - 1
    exact, ours = np.empty(n), np.empty(n)
    unsure, worst = 0, 0.0
    for r in range(bel.batch):
        if r % 5 == 4:  # two takers at one spot, a keeper on a grid point: estimates must stand back
            bel.pos[r, K + 2] = bel.pos[r, K + 1]
            bel.pos[r, 2 if bel.me[r] != 2 else 3] = grid_point(r % grid_size(CFG), KP, CFG)
        ox, oy = bel.pos[r, bel.me[r] % K + 1]
        s = vertex_scratch(K, T)
        getopen_setup(bel, r, ox, oy, s)
        for k in range(grid_size(CFG)):
            px, py = grid_point(k, KP, CFG)
            sure = getopen_point_estimate(bel, r, px, py, ox, oy, s, ours)
            getopen_point_state(bel, r, px, py, ox, oy, s, exact)
            if not sure:
                unsure += 1
                continue
            off = np.abs(ours - exact)
            assert np.all(off <= ESTIMATE_ANGLE_ERROR + ESTIMATE_DISTANCE_ERROR * np.abs(exact)), (r, k)
            worst = max(worst, off.max())
    points = bel.batch * grid_size(CFG)
    assert bel.batch // 5 * grid_size(CFG) <= unsure < bel.batch // 5 * grid_size(CFG) + points // 100
    assert worst > 0.0  # the estimates do differ from the exact variables


def test_tile_slots_match_tile_by_tile_hashing():
    config = SarsaConfig(table_size=1 << 12)  # a small table: the hash collides and re-probes
    rng = np.random.default_rng(4)
    for _ in range(3):
        state = rng.uniform(-30.0, 30.0, 13)  # negative coordinates too
        mem = new_sarsa_memory(config, K, T, 1, 0)
        load_tiles(mem, 0, state)
        assert np.array_equal(_loaded_slots(mem), _ref_load_tiles(config, state))


@pytest.mark.parametrize("table_size", [1 << 15, 1 << 20])
def test_remembered_tile_slots_are_the_slots_hashing_gives_with_the_same_counts(table_size):
    # states revisiting quantised values (remembered) and new ones (hashed, filling the table further),
    # values beyond what is remembered and negative ones; a small table collides and re-probes often
    config = SarsaConfig(table_size=table_size)
    rng = np.random.default_rng(7)
    pool = rng.uniform(0.0, 25.0, (6, 13))
    mem = new_sarsa_memory(config, K, T, 1, 0)
    check_table = np.full(table_size, EMPTY_SLOT, dtype=np.int64)
    counts = np.zeros(3, dtype=np.int64)
    for i in range(60):
        state = pool[i % len(pool)] + (rng.uniform(0.0, 0.05, 13) if i % 4 == 3 else 0.0)
        if i % 10 == 9:
            state = rng.uniform(-30.0, 300.0, 13)
        load_tiles(mem, 0, state)
        assert np.array_equal(_loaded_slots(mem), _ref_load_tiles(config, state, check_table, counts)), i
        assert np.array_equal(mem.hash_check[0], check_table) and np.array_equal(mem.hash_counts[0], counts), i
    assert (mem.memo_slots != EMPTY_SLOT).any()


def test_a_loaded_table_is_hashed_afresh_not_from_remembered_slots():
    config = SarsaConfig(table_size=1 << 13)
    state = np.random.default_rng(8).uniform(0.0, 25.0, 13)
    mem = new_sarsa_memory(config, K, T, 1, 0)
    load_tiles(mem, 0, np.random.default_rng(9).uniform(0.0, 25.0, 13))  # other tiles first: other slots
    load_tiles(mem, 0, state)
    filled = policy_arrays(mem, 0)
    load_policy_arrays(mem, 0, policy_arrays(new_sarsa_memory(config, K, T, 1, 0), 0))  # an empty table
    load_tiles(mem, 0, state)
    assert np.array_equal(_loaded_slots(mem), _ref_load_tiles(config, state))
    load_policy_arrays(mem, 0, filled)
    check_table = filled["pass_hash_check"].astype(np.int64)
    load_tiles(mem, 0, state)
    assert np.array_equal(_loaded_slots(mem), _ref_load_tiles(config, state, check_table))


@njit
def _whole_degree(d):
    return math.cos(math.radians(d)), math.sin(math.radians(d))


def test_the_whole_degree_table_holds_what_the_kernels_compute():
    table = whole_degree_table()
    for d in range(-180, 181):
        assert tuple(table[d + 180]) == _whole_degree(float(d))

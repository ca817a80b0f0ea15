"""Geometry and one-step motion prediction shared by every skill (docs/players.md §5.1;
physics as in docs/rules.md §1, §2).

Angles are degrees in the rcssserver frame (+y down, direction = atan2(y, x)). All functions are numba
kernels, on scalars so skills can call them inside their own per-row loops, and the last ones on a row of a
``Belief``: where the ball will be, who can kick it, who is nearest to it, who are my opponents and which
way my own frame faces.
"""

from __future__ import annotations

import math

from keepaway.agents.belief import Belief
from keepaway.core.jit import borrowing
from keepaway.core.objects import CMD_DASH, CMD_TURN

# How far a quick estimate (one sqrt where the exact code takes hypot, a cosine instead of acos) may lie
# from a comparison's threshold and still decide it: far above the few ulps by which the two
# computations differ, far below any difference that matters. Inside it the exact code decides.
DECIDE_SLACK = 1.0e-9


@borrowing
def near(value: float, threshold: float) -> bool:
    """Whether an estimate within a few ulps of the exact value could fall on the other side of
    ``threshold`` from it: within DECIDE_SLACK of it, relative to its size beyond 1."""
    return abs(value - threshold) <= DECIDE_SLACK * (1.0 + abs(threshold))


@borrowing
def compared_hypot(dx: float, dy: float, threshold: float) -> float:
    """|(dx, dy)| for comparing with ``threshold`` alone: the sqrt estimate, or libm's exact hypot when
    the estimate is within a hair of the threshold (``near``) or not finite, so any comparison of the
    result with ``threshold`` (<, <=, >) comes out as the exact one would. Cheaper than hypot, which
    took a tenth of a game's time spread over a dozen such tests."""
    d = math.sqrt(dx * dx + dy * dy)
    if d < math.inf and not near(d, threshold):
        return d
    return math.hypot(dx, dy)


@borrowing
def nearer_than(dx: float, dy: float, limit: float) -> float:
    """hypot(dx, dy) if it is below ``limit``, else inf: the exact distance of a nearer point, for a
    search for the nearest one (``if d < best_d``) that computes libm's hypot only for the points that
    improve on the best so far (and the first), a sqrt for the rest. The same answers as comparing
    hypot itself."""
    d = math.sqrt(dx * dx + dy * dy)
    if d < math.inf and not near(d, limit) and d >= limit:
        return math.inf
    exact = math.hypot(dx, dy)
    return exact if exact < limit else math.inf


@borrowing
def normalize_angle(a: float) -> float:
    """Angle in (-180, 180]."""
    a -= 360.0 * math.floor((a + 180.0) / 360.0)
    return 180.0 if a == -180.0 else a


@borrowing
def direction(dx: float, dy: float) -> float:
    """Global direction of the vector (dx, dy), degrees."""
    return math.degrees(math.atan2(dy, dx))


@borrowing
def distance(ax: float, ay: float, bx: float, by: float) -> float:
    return math.hypot(bx - ax, by - ay)


@borrowing
def vertex_angle(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    """ang(A, B, C): unsigned angle at vertex B between rays B->A and B->C, in [0, 180]
    (docs/players.md §1). A degenerate ray (A or C on B) gives 0: nothing separates them."""
    ux, uy = ax - bx, ay - by
    vx, vy = cx - bx, cy - by
    return ray_angle(ux, uy, math.hypot(ux, uy), vx, vy, math.hypot(vx, vy))


@borrowing
def ray_angle(ux: float, uy: float, nu: float, vx: float, vy: float, nv: float) -> float:
    """:func:`vertex_angle` of the rays u and v of lengths ``nu`` = hypot(u) and ``nv`` = hypot(v), for a
    caller that has those lengths already (the same hypot calls: the same angle)."""
    return math.degrees(math.acos(ray_cosine(ux, uy, nu, vx, vy, nv)))


@borrowing
def ray_cosine(ux: float, uy: float, nu: float, vx: float, vy: float, nv: float) -> float:
    """The cosine :func:`ray_angle` takes the arccosine of, clamped to [-1, 1]; 1 (angle 0) for a
    degenerate ray. The arccosine falls as the cosine grows, so the largest of several cosines names the
    smallest angle (:func:`agents.state_vars.smallest_angle`)."""
    if nu == 0.0 or nv == 0.0:
        return 1.0
    return min(1.0, max(-1.0, (ux * vx + uy * vy) / (nu * nv)))


# acos(c) = sqrt(1 - c) P(c) on [0, 1] (a least-squares fit of degree 9 on Chebyshev nodes; off by at
# most 5.4e-10 rad on a grid of 5e-8), pi minus that of -c below 0: for scores that decide only where
# they are sure (agents.getopen.learned_target); the bound used is twice the worst seen.
_C0, _C1, _C2, _C3, _C4 = (1.570796326261536, -0.21460172591626298, 0.08904479608169266, -0.05074080130028918,
                           0.03331491441921143)
_C5, _C6, _C7, _C8, _C9 = (-0.02284457171242803, 0.014575916982925145, -0.007445645640447434,
                           0.002518626136655123, -0.0004042733343090698)
ACOS_ESTIMATE_ERROR = 1.1e-9


@borrowing
def acos_estimate(c: float) -> float:
    """acos(c) for c in [-1, 1] within ACOS_ESTIMATE_ERROR, without libm's acos."""
    a = abs(c)
    a2 = a * a
    a4 = a2 * a2
    p = ((_C0 + a * _C1) + a2 * (_C2 + a * _C3)) + a4 * (((_C4 + a * _C5) + a2 * (_C6 + a * _C7))
                                                   + a4 * (_C8 + a * _C9))
    p *= math.sqrt(1.0 - a)
    return p if c >= 0.0 else math.pi - p  # (Estrin's form above: short dependency chains)


@borrowing
def vertex_angle_below(ax: float, ay: float, bx: float, by: float, cx: float, cy: float, limit: float,
                       cos_limit: float) -> bool:
    """``vertex_angle(A, B, C) < limit`` (``cos_limit`` = cos(limit)), decided as that comparison decides
    it but without its two hypots and its acos unless the angle is within a hair of the limit: acos
    decreases, so a cosine (from one sqrt) more than DECIDE_SLACK from cos(limit) settles it. The same
    answer in every case, so the same games; several times cheaper (GO:HC tests 25 lanes per cycle)."""
    ux, uy = ax - bx, ay - by
    vx, vy = cx - bx, cy - by
    norms = (ux * ux + uy * uy) * (vx * vx + vy * vy)
    if 0.0 < norms < math.inf:  # the cosine dot / length, compared without its division
        dot, length = ux * vx + uy * vy, math.sqrt(norms)
        if dot < (cos_limit - DECIDE_SLACK) * length:
            return False
        if dot > (cos_limit + DECIDE_SLACK) * length:
            return True
    return vertex_angle(ax, ay, bx, by, cx, cy) < limit


@borrowing
def geometric_sum(decay: float, n: float) -> float:
    """1 + d + ... + d^(n-1) = (1 - d^n) / (1 - d): distance factor of a decaying velocity over n cycles."""
    return (1.0 - decay**n) / (1.0 - decay)


@borrowing
def rolled_out(px: float, py: float, vx: float, vy: float, n: float, decay: float) -> tuple:
    """Position after n cycles without acceleration: pos + vel (1 - d^n)/(1 - d) (docs/players.md §4.3;
    velocities are the stored post-decay ones, so the next position is pos + vel)."""
    f = geometric_sum(decay, n)
    return px + vx * f, py + vy * f


@borrowing
def final_position(px: float, py: float, vx: float, vy: float, decay: float) -> tuple:
    """Position once the current velocity has died out: pos + vel / (1 - d) (docs/players.md §5.1)."""
    f = 1.0 / (1.0 - decay)
    return px + vx * f, py + vy * f


@borrowing
def kick_rate(px: float, py: float, body: float, bx: float, by: float, kp) -> float:
    """Effective kick power rate for a ball at (bx, by) and a player at (px, py) with ``body``:
    kick_power_rate (1 - 0.25 |dir|/180 - 0.25 (dist - player_size - ball_size)/kickable_margin)
    (docs/rules.md §2, "kick")."""
    dir_diff = abs(normalize_angle(direction(bx - px, by - py) - body))
    dist_ball = distance(px, py, bx, by) - kp.player_size - kp.ball_size
    return kp.kick_power_rate * (1.0 - 0.25 * dir_diff / 180.0 - 0.25 * dist_ball / kp.kickable_margin)


@borrowing
def turn_moment(angle: float, speed: float, kp) -> float:
    """Moment to send so that a player moving at ``speed`` turns by ``angle``: angle (1 + inertia v),
    clipped to the moment range (docs/players.md §5.1)."""
    m = angle * (1.0 + kp.inertia_moment * speed)
    return min(kp.max_moment, max(kp.min_moment, m))


@borrowing
def turn_effect(moment: float, speed: float, kp) -> float:
    """Body rotation produced by ``moment`` at ``speed`` (noise-free docs/rules.md §2, "turn")."""
    m = min(kp.max_moment, max(kp.min_moment, moment))
    return m / (1.0 + kp.inertia_moment * speed)


@borrowing
def dash_power_for(
    dx: float, dy: float, body: float, vx: float, vy: float, effort: float, cycles: float, kp
) -> float:
    """Dash power to cover the forward component of (dx, dy) in ``cycles`` cycles (docs/players.md §5.5): first-cycle
    speed d (1 - decay)/(1 - decay^n), capped at player_speed_max, minus the current forward speed, over
    dash_power_rate * effort, clipped to the power range."""
    rad = math.radians(body)
    n = max(1.0, cycles)
    decay_sum = geometric_sum(kp.player_decay, n)
    return dash_power_along(dx, dy, math.cos(rad), math.sin(rad), vx, vy, effort, decay_sum, kp)


@borrowing
def believed_dash_power(power: float, kp) -> float:
    """A dash power clipped to the range the players believe in, [min_power, max_dash_power]: keepaway-0.6
    reads one minimum for kicks and dashes (``ServerSettings::getMinPower``, -100), so its players believe a
    negative power dashes backwards. rcssserver clips a dash at min_dash_power, 0 with CURRENT (17.0 on),
    and such a dash then does nothing; the players keep the C++ belief, as the reference stack's do
    (docs/design.md, "The ball in the players' world model"), and ``interception._unstuck`` ends the deadlock it
    can lead to."""
    return min(kp.max_dash_power, max(kp.min_power, power))


@borrowing
def dash_power_along(
    dx: float, dy: float, cs: float, sn: float, vx: float, vy: float, effort: float, decay_sum: float, kp
) -> float:
    """``dash_power_for`` from the body's cosine and sine and the geometric sum of the cycles, for
    callers that reuse them across steps (the same arithmetic)."""
    forward = dx * cs + dy * sn
    speed = forward / decay_sum
    speed = min(speed, kp.player_speed_max)
    speed -= vx * cs + vy * sn
    power = speed / (kp.dash_power_rate * effort)
    return believed_dash_power(power, kp)


@borrowing
def dash_velocity(vx: float, vy: float, cs: float, sn: float, effort: float, power: float, kp) -> tuple:
    """Velocity after a dash of ``power`` along the body (cosine ``cs``, sine ``sn``), before the move:
    effort * power * dash_power_rate capped at player_accel_max, the speed at player_speed_max
    (docs/rules.md §2, "dash", noise-free), the power as the players believe it (``believed_dash_power``)."""
    power = believed_dash_power(power, kp)
    acc = effort * power * kp.dash_power_rate
    acc = min(acc, kp.player_accel_max) if acc > 0.0 else max(acc, -kp.player_accel_max)
    vx += acc * cs
    vy += acc * sn
    if compared_hypot(vx, vy, kp.player_speed_max) > kp.player_speed_max:
        speed = math.hypot(vx, vy)
        vx *= kp.player_speed_max / speed
        vy *= kp.player_speed_max / speed
    return vx, vy


@borrowing
def player_step(
    px: float, py: float, vx: float, vy: float, body: float, effort: float, cmd: int, a1: float, kp
) -> tuple:
    """Noise-free player state after one command (docs/rules.md §1, §2): dash adds effort * power *
    dash_power_rate along the body (capped at accel/speed max), turn rotates with inertia, then the
    player moves and decays. ``cmd`` is a CMD_* code of `core/objects.py`; anything but a dash or a turn
    leaves the player coasting. Returns (x, y, vx, vy, body)."""
    if cmd == CMD_DASH:
        rad = math.radians(body)
        vx, vy = dash_velocity(vx, vy, math.cos(rad), math.sin(rad), effort, a1, kp)
    elif cmd == CMD_TURN:
        body = normalize_angle(body + turn_effect(a1, math.hypot(vx, vy), kp))
    px += vx
    py += vy
    return px, py, vx * kp.player_decay, vy * kp.player_decay, body


@borrowing
def ball_after_kick(
    bx: float, by: float, bvx: float, bvy: float, rate: float, power: float, kick_dir: float, body: float, kp
) -> tuple:
    """Ball position and stored velocity one cycle after a kick of ``power`` at ``kick_dir`` relative to
    ``body`` with effective ``rate`` (noise-free docs/rules.md §2, "kick"). Returns (x, y, vx, vy)."""
    acc = min(rate * power, kp.ball_accel_max)
    rad = math.radians(body + kick_dir)
    vx = bvx + acc * math.cos(rad)
    vy = bvy + acc * math.sin(rad)
    speed = math.hypot(vx, vy)
    if speed > kp.ball_speed_max:
        vx *= kp.ball_speed_max / speed
        vy *= kp.ball_speed_max / speed
    return bx + vx, by + vy, vx * kp.ball_decay, vy * kp.ball_decay


@borrowing
def in_cone(ox: float, oy: float, tx: float, ty: float, qx: float, qy: float, ratio: float) -> bool:
    """Whether q lies in the cone from o towards t of half-width ``ratio`` (perpendicular distance <
    ratio * distance along the line), projected between o and t and closer to o than t is
    (docs/players.md §7.2, §3 step 3)."""
    lx, ly = tx - ox, ty - oy
    length = math.hypot(lx, ly)
    if length == 0.0:
        return False
    ux, uy = lx / length, ly / length
    rx, ry = qx - ox, qy - oy
    along = rx * ux + ry * uy
    perp = abs(rx * uy - ry * ux)
    return 0.0 < along < length and perp < ratio * along and math.hypot(rx, ry) < length


@borrowing
def kickable_distance(kp) -> float:
    """player_size + kickable_margin + ball_size = 1.085 m (docs/players.md §1)."""
    return kp.player_size + kp.kickable_margin + kp.ball_size


# -------------------------------------------------------------------------------- on a belief's rows


@borrowing
def ball_in(bel: Belief, r: int, n: float, kp) -> tuple:
    """The believed ball position after ``n`` cycles (docs/players.md §4.3)."""
    return rolled_out(
        bel.pos[r, 0, 0], bel.pos[r, 0, 1], bel.vel[r, 0, 0], bel.vel[r, 0, 1], n, kp.ball_decay
    )


@borrowing
def ball_kickable(bel: Belief, r: int, obj: int, kp) -> bool:
    """Whether player ``obj`` can kick the ball (centre distance < kickable distance, docs/players.md §1)."""
    kickable = kickable_distance(kp)
    return compared_hypot(bel.pos[r, 0, 0] - bel.pos[r, obj, 0], bel.pos[r, 0, 1] - bel.pos[r, obj, 1],
                          kickable) < kickable


@borrowing
def closest_to_ball(bel: Belief, r: int, first: int, last: int, skip: int, cfg) -> int:
    """The usable player (conf >= threshold, not ``skip``) among objects first..last closest to the ball,
    -1 if none; ties go to the lower index."""
    best = -1
    best_d = math.inf
    for j in range(first, last + 1):
        if j == skip or (j != bel.me[r] and bel.conf[r, j] < cfg.player_conf_threshold):
            continue
        d = nearer_than(bel.pos[r, 0, 0] - bel.pos[r, j, 0], bel.pos[r, 0, 1] - bel.pos[r, j, 1], best_d)
        if d < best_d:
            best, best_d = j, d
    return best


@borrowing
def distances_from(bel: Belief, r: int, ox: float, oy: float, last: int, skip: int, out) -> None:
    """``out[j]`` = distance((ox, oy), object j) for the players j = 1..last except ``skip``."""
    for j in range(1, last + 1):
        if j != skip:
            out[j] = distance(ox, oy, bel.pos[r, j, 0], bel.pos[r, j, 1])


@borrowing
def sort_by_distance(dist, first: int, last: int, skip: int, out) -> int:
    """Write the objects first..last except ``skip`` into ``out`` by increasing ``dist[j]`` (their
    :func:`distances_from` a point; stable: lower index first on ties); returns how many were written."""
    n = 0
    for j in range(first, last + 1):
        if j == skip:
            continue
        d = dist[j]
        k = n
        while k > 0 and dist[out[k - 1]] > d:
            out[k] = out[k - 1]
            k -= 1
        out[k] = j
        n += 1
    return n


@borrowing
def opponent_range(obj: int, n_keepers: int, n_players: int) -> tuple:
    """Object index range (first, last), inclusive, of the opponents of player ``obj`` among objects
    1..n_players (keepers first): the takers for a keeper, the keepers for a taker."""
    if 1 <= obj <= n_keepers:
        return n_keepers + 1, n_players
    return 1, n_keepers


@borrowing
def opponents(bel: Belief, obj: int) -> tuple:
    """Object index range (first, last) of the opponents of player ``obj``."""
    return opponent_range(obj, bel.n_keepers, bel.n_keepers + bel.n_takers)


@borrowing
def frame_sign(obj: int, n_keepers: int) -> float:
    """+1 if player ``obj``'s own frame is the server's (a keeper), -1 if it is mirrored (a taker):
    :func:`own_frame_sign` on an object index."""
    return 1.0 if 1 <= obj <= n_keepers else -1.0


@borrowing
def own_frame_sign(bel: Belief, r: int) -> float:
    """+1 if my own frame is the server's, -1 if it is mirrored. The C++ players mirror the field for the
    right-hand team, the takers (rcssserver keepaway mode: keepers left), so where their code says
    "global 0", "forward in x" or "the opponent goal" a taker means the server's 180 deg, -x and the
    left goal."""
    return frame_sign(bel.me[r], bel.n_keepers)


@borrowing
def forward_angle(bel: Belief, r: int) -> float:
    """The server-frame direction that my own frame calls 0 deg (``own_frame_sign``)."""
    return 0.0 if own_frame_sign(bel, r) > 0.0 else 180.0

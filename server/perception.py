"""What each player perceives: ``see``, ``sense_body``, the says it hears and ``fullstate`` (docs/rules.md §5;
rcssserver src/visualsenderplayer.cpp, src/bodysender.cpp, src/fullstatesender.cpp).

The kernels mirror rcssserver's ``VisualSenderPlayerV1``/``BodySenderPlayerV6`` arithmetic step by step
(angles are turned into radians with the server's ``DEG2RAD`` and back with ``RAD2DEG``; distances get
the same log/exp quantisation, read from an exact lookup table), so a ``see`` computed here equals the
real server's to the printed digit. A kernel works on one observer of one arena and writes into preallocated
:class:`SeeBuffers`/:class:`SenseBodyBuffers`, which hold every observer of every arena, so the batched
mode runs without Python objects. Who hears whose say is :func:`hear_picks`, and from where
:func:`hear_direction`. ``server.percept_wire`` writes these percepts as their messages' msgpack frames.

Object slots of a see record: ``0 .. N_FLAGS-1`` are the flags (:data:`protocol.landmarks.FLAGS`), slot
``N_FLAGS + i`` is world object ``i`` (``i = 0`` the ball, then the players). Observer row ``p`` belongs
to player object ``p + 1``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from keepaway.core.jit import borrowing, njit
from keepaway.core.objects import BALL
from keepaway.core.rng import randint, uniform
from keepaway.protocol.landmarks import FLAG_POSITIONS, LINE_LEFT, LINE_RIGHT, LINE_TOP, N_FLAGS, N_LINES
from keepaway.protocol.params import KernelParams
from keepaway.server.world import N_COUNTS, World

# rcssserver's angle conversions (utility.h): multiply by these constants, not by math.degrees.
DEG2RAD = math.pi / 180.0
RAD2DEG = 180.0 / math.pi
_TWO_PI = 2.0 * math.pi
_HALF_PI = 0.5 * math.pi
# Added to a distance before its logarithm (rcssserver's EPS), so distance 0 quantises to 0.
DIST_EPS = 1.0e-10
# Fixed final steps of rcssserver's quantisation: every seen distance, the sense_body speed.
DIST_STEP = 0.1
SPEED_STEP = 0.01

# How much of an object a see reveals (docs/rules.md §5.2).
UNSEEN = 0
CLOSE = 1  # outside the view cone within visible_distance: anonymous (F) (G) (B) (P), dist and dir
NAMELESS = 2  # player too far for its team: (p) dist dir
PARTIAL = 3  # flag/ball without the change pair; player with team but no unum, changes or facing
FULL = 4  # everything: name, dist_chg, dir_chg (players also unum, body_dir, head_dir)

# View cone width factors applied to visible_angle (docs/rules.md §5.1).
VIEW_WIDTH_FACTOR: dict[str, float] = {"narrow": 0.5, "normal": 1.0, "wide": 2.0}
SYNCH_SEE_WIDTH_FACTOR: dict[str, float] = {"narrow": 2.0 / 3.0, "normal": 4.0 / 3.0, "wide": 2.0}


@njit(cache=True)
def see_due(cycle: int, step_ms: float, period_ms: float, phase_ms: float) -> bool:
    """Synchronous-mode see schedule in virtual time (docs/rules.md §5.1): a see is due every ``period_ms`` from
    ``phase_ms`` (the player's connection time), and one whose time falls in ((cycle - 1) step, cycle
    step] comes with cycle's percepts (normal width: 2 sees per 3 cycles: 0, 2, 3, 5, 6, ...)."""
    hi = cycle * step_ms - phase_ms
    return math.floor(hi / period_ms) > math.floor((hi - step_ms) / period_ms)


def cone_factor(view_width: str, synch_see: bool = False) -> float:
    """Factor on ``visible_angle`` giving the full view cone for a view width: asynchronous sees use
    narrow 0.5 / normal 1 / wide 2, synch-see (v18+ clients) 2/3, 4/3, 2 (docs/rules.md §5.1)."""
    table = SYNCH_SEE_WIDTH_FACTOR if synch_see else VIEW_WIDTH_FACTOR
    try:
        return table[view_width]
    except KeyError:
        raise ValueError(f"unknown view width {view_width!r}") from None


# --------------------------------------------------------------------------------------------------
# Quantisation and angles (docs/rules.md §5.2)


@njit(cache=True, inline="always")
def quantize(v: float, q: float) -> float:
    """rcssserver's Quantize: round half to even (C ``rint``) to a multiple of ``q``."""
    return np.rint(v / q) * q


@njit(cache=True, inline="always")
def quantize_distance(d: float, q: float) -> float:
    """Seen distance Q(exp(Q(ln(d + EPS), q)), 0.1): q is quantize_step (ball, players) or
    quantize_step_l (flags, goals, lines)."""
    return quantize(math.exp(quantize(math.log(d + DIST_EPS), q)), DIST_STEP)


# Exact table form of quantize_distance, used by the kernels: the same numbers without a log and an exp
# per object. k(x) = rint(ln(x) / q) never decreases with x, so each k owns an interval of x; a table
# holds every interval's lower end (found by bisection with the very log of the formula) and its
# distance Q(exp(k q), 0.1). The exponent and top mantissa bits of x pick a bucket of relative width
# at most 1/256 < q, which starts in interval k and ends in k or k + 1.
_BUCKET_SHIFT = np.int64(52 - 8)  # float64 bits >> 44: exponent and top 8 mantissa bits
_TABLE_LOW = 2.0**-4  # tabulated x range, m (outside it the formula runs)
_TABLE_HIGH = 2.0**11


class DistanceTable(NamedTuple):
    """:func:`quantize_distance` for one step ``q`` on [2**-4, 2**11) m."""

    q: float
    lower: np.ndarray  # (K + 1,) float64: lower end of interval j; lower[K] is the table's end
    value: np.ndarray  # (K,) float64: quantised distance of interval j
    bucket: np.ndarray  # (n_buckets,) int32: interval holding each bucket's lower edge


@njit(cache=True, inline="always")
def _bucket_key(x: float) -> int:
    return np.float64(x).view(np.int64) >> _BUCKET_SHIFT


@njit(cache=True)
def _log_step(x: float, q: float) -> float:
    return np.rint(math.log(x) / q)


@njit(cache=True)
def _distance_table_arrays(q: float) -> tuple:
    k_low = _log_step(_TABLE_LOW, q)
    n = int(_log_step(_TABLE_HIGH, q) - k_low) + 1
    lower = np.empty(n + 1)
    value = np.empty(n)
    lower[0] = _TABLE_LOW
    lower[n] = _TABLE_HIGH
    for j in range(n):
        k = k_low + j
        value[j] = quantize(math.exp(k * q), DIST_STEP)
        if j == 0:
            continue
        lo = lower[j - 1]
        hi = _TABLE_HIGH
        while True:
            mid = 0.5 * (lo + hi)
            if mid <= lo or mid >= hi:
                break
            if _log_step(mid, q) >= k:
                hi = mid
            else:
                lo = mid
        lower[j] = hi
    first = _bucket_key(_TABLE_LOW)
    bucket = np.empty(_bucket_key(_TABLE_HIGH) - first, dtype=np.int32)
    for i in range(bucket.shape[0]):
        edge = np.int64((first + i) << _BUCKET_SHIFT).view(np.float64)
        bucket[i] = np.searchsorted(lower, edge, side="right") - 1
    return lower, value, bucket


def distance_table(q: float) -> DistanceTable:
    """The lookup table of :func:`quantize_distance` for step ``q`` (``q`` > ln(1 + 1/256))."""
    if not q > math.log1p(1.0 / 256.0):
        raise ValueError(f"quantize step {q} is too fine for the distance table")
    return DistanceTable(float(q), *_distance_table_arrays(float(q)))


@njit(cache=True, inline="always")
def table_distance(table: DistanceTable, d: float) -> float:
    """``quantize_distance(d, table.q)``, bit for bit, by table lookup."""
    x = d + DIST_EPS
    i = _bucket_key(x) - _bucket_key(_TABLE_LOW)
    if i < 0 or i >= table.bucket.shape[0]:
        return quantize(math.exp(quantize(math.log(x), table.q)), DIST_STEP)
    j = table.bucket[i]
    if x >= table.lower[j + 1]:
        j += 1
    return table.value[j]


@njit(cache=True, inline="always")
def normalize_rad(a: float) -> float:
    """rcssserver's normalize_angle: into [-pi, pi] (pi stays pi, so an object exactly behind has
    |bearing| = pi)."""
    if abs(a) > _TWO_PI:
        a = np.fmod(a, _TWO_PI)
    if a < -math.pi:
        a += _TWO_PI
    if a > math.pi:
        a -= _TWO_PI
    return a


# A see's directions are whole degrees, so the bearing's arctangent needs only enough accuracy to tell
# which degree it rounds to (docs/design.md, "GO:L's variables and the see's bearings, estimated too"): it is
# estimated by an odd polynomial (_A0.._A9: atan(t) = t P(t^2) on [0, 1], a least-squares fit on
# Chebyshev nodes; off by at most 9.8e-10 rad on a grid of 5e-8, ATAN_ESTIMATE_ERROR twice that), and
# libm's atan2 is taken only where the estimate leaves the bearing within BEARING_SLACK of a half
# degree, of the view cone's edge or of +-pi (where normalising could pick the other representative).
_A0, _A1, _A2, _A3, _A4 = (0.9999999841277829, -0.33333194738706656, 0.19996626041674614, -0.1424841859931687,
                           0.10882237728944788)
_A5, _A6, _A7, _A8, _A9 = (-0.08222729238655788, 0.055144768566235916, -0.02858193151035763,
                           0.009606583454704465, -0.0015164540504979357)
ATAN_ESTIMATE_ERROR = 2e-9
BEARING_SLACK = 1e-7  # rad: far above the estimate's error and the normalisations' rounding


@njit(cache=True, inline="always")
def atan2_estimate(y: float, x: float) -> float:
    """atan2(y, x) within ATAN_ESTIMATE_ERROR: the octant's arctangent of min / max by the polynomial,
    reflected (libm's at the origin and for NaN)."""
    ax, ay = abs(x), abs(y)
    if not (ax > 0.0 or ay > 0.0):
        return math.atan2(y, x)
    # selects rather than branches (the octant is as good as random from one object to the next), and
    # the polynomial in Estrin's form: short dependency chains
    t = min(ax, ay) / max(ax, ay)
    u = t * t
    u2 = u * u
    u4 = u2 * u2
    p01 = _A0 + u * _A1
    p23 = _A2 + u * _A3
    p45 = _A4 + u * _A5
    p67 = _A6 + u * _A7
    p89 = _A8 + u * _A9
    a = t * ((p01 + u2 * p23) + u4 * ((p45 + u2 * p67) + u4 * p89))
    a = _HALF_PI - a if ay > ax else a
    a = math.pi - a if x < 0.0 else a
    return math.copysign(a, y)


@njit(cache=True, inline="always")
def see_bearing(dx: float, dy: float, body: float, neck: float, half_cone: float) -> float:
    """normalize(normalize(atan2(dy, dx) - body) - neck) (rad), exact wherever a see can tell: from
    :func:`atan2_estimate` unless that bearing lies within BEARING_SLACK of a half degree (where
    :func:`round_deg` could round the other way), of +-``half_cone`` or of +-pi; there from libm's atan2."""
    bearing = _relative(atan2_estimate(dy, dx), body, neck)
    degrees = bearing * RAD2DEG
    size = abs(bearing)
    if (abs(degrees - math.floor(degrees) - 0.5) <= BEARING_SLACK * RAD2DEG or abs(size - half_cone) <= BEARING_SLACK
            or size >= math.pi - BEARING_SLACK or not size < math.inf):
        bearing = _relative(math.atan2(dy, dx), body, neck)
    return bearing


@njit(cache=True, inline="always")
def _relative(direction: float, body: float, neck: float) -> float:
    """A global direction (rad) relative to the observer's head, as rcssserver normalises it twice."""
    return normalize_rad(normalize_rad(direction - body) - neck)


@njit(cache=True, inline="always")
def round_deg(rad: float) -> int:
    """Rad2IDegRound: integer degrees, rounded half to even (protocol v7+ directions)."""
    return int(np.rint(rad * RAD2DEG))


@njit(cache=True, inline="always")
def trunc_deg(rad: float) -> int:
    """Rad2IDeg: integer degrees truncated towards zero (sense_body speed direction, head_angle)."""
    return int(rad * RAD2DEG)


@njit(cache=True, inline="always")
def _decide(rng: np.ndarray, b: int, prob: float) -> bool:
    """True with probability ``prob`` (certain at >= 1, never at <= 0, no draw then), as rcssserver's
    ``decide``."""
    if prob >= 1.0:
        return True
    if prob <= 0.0:
        return False
    return uniform(rng, b, 0.0, 1.0) < prob


@njit(cache=True, inline="always")
def _far_probability(quant_dist: float, far: float, too_far: float) -> float:
    return (quant_dist - far) / (too_far - far)


@njit(cache=True, inline="always")
def _player_level(rng: np.ndarray, b: int, quant_dist: float, kp) -> int:
    """Identity of a player inside the cone (docs/rules.md §5.2): CLASSIC drops the team at
    d' >= team_too_far_length, CURRENT with p(team lengths); then the unum with p(unum lengths)."""
    if kp.team_loss_probabilistic != 0.0:
        if _decide(rng, b, _far_probability(quant_dist, kp.team_far_length, kp.team_too_far_length)):
            return NAMELESS
    elif quant_dist >= kp.team_too_far_length:
        return NAMELESS
    if _decide(rng, b, _far_probability(quant_dist, kp.unum_far_length, kp.unum_too_far_length)):
        return PARTIAL
    return FULL


class SeeBuffers(NamedTuple):
    """See records of every observer of ``B`` arenas. Shapes: ``P = N - 1`` observers (row ``p`` is
    player object ``p + 1``), ``M = N_FLAGS + N`` object slots (module docstring). Floats are NaN and
    integers 0 where the record omits them; ``level`` says which fields exist."""

    level: np.ndarray  # (B, P, M) int8: UNSEEN, CLOSE, NAMELESS, PARTIAL, FULL
    dist: np.ndarray  # (B, P, M) float64, quantised m
    direction: np.ndarray  # (B, P, M) int32, deg relative to the observer's head, clockwise (+y down)
    dist_chg: np.ndarray  # (B, P, M) float64 (FULL only)
    dir_chg: np.ndarray  # (B, P, M) float64, deg/cycle (FULL only)
    body_dir: np.ndarray  # (B, P, M) int32 (FULL players only)
    head_dir: np.ndarray  # (B, P, M) int32 (FULL players only)
    line_seen: np.ndarray  # (B, P, N_LINES) bool
    line_dist: np.ndarray  # (B, P, N_LINES) float64
    line_dir: np.ndarray  # (B, P, N_LINES) int32
    table_l: DistanceTable  # kernel input: quantize_distance for kp.quantize_step_l (flags, lines)
    table: DistanceTable  # kernel input: quantize_distance for kp.quantize_step (ball, players)

    @classmethod
    def empty(cls, batch: int, n_objects: int, kp: KernelParams) -> "SeeBuffers":
        """Buffers for ``batch`` arenas of ``n_objects`` world objects (ball included), with the distance
        tables of ``kp``'s quantisation steps."""
        shape = (batch, n_objects - 1, N_FLAGS + n_objects)
        lines = (batch, n_objects - 1, N_LINES)
        return cls(
            level=np.zeros(shape, dtype=np.int8),
            dist=np.full(shape, np.nan),
            direction=np.zeros(shape, dtype=np.int32),
            dist_chg=np.full(shape, np.nan),
            dir_chg=np.full(shape, np.nan),
            body_dir=np.zeros(shape, dtype=np.int32),
            head_dir=np.zeros(shape, dtype=np.int32),
            line_seen=np.zeros(lines, dtype=np.bool_),
            line_dist=np.full(lines, np.nan),
            line_dir=np.zeros(lines, dtype=np.int32),
            table_l=distance_table(kp.quantize_step_l),
            table=distance_table(kp.quantize_step),
        )


class SenseBodyBuffers(NamedTuple):
    """sense_body values of every observer of ``B`` arenas (row ``p`` is player object ``p + 1``)."""

    stamina: np.ndarray  # (B, P) float64
    effort: np.ndarray  # (B, P) float64
    capacity: np.ndarray  # (B, P) float64
    speed: np.ndarray  # (B, P) float64, Q(|v|, 0.01)
    speed_dir: np.ndarray  # (B, P) int32, deg relative to body + neck, truncated
    head_angle: np.ndarray  # (B, P) int32, neck relative to body, truncated
    counts: np.ndarray  # (B, P, N_COUNTS) int64
    collision: np.ndarray  # (B, P) uint8 COLLIDED_* bits

    @classmethod
    def empty(cls, batch: int, n_objects: int) -> "SenseBodyBuffers":
        shape = (batch, n_objects - 1)
        return cls(
            stamina=np.zeros(shape),
            effort=np.zeros(shape),
            capacity=np.zeros(shape),
            speed=np.zeros(shape),
            speed_dir=np.zeros(shape, dtype=np.int32),
            head_angle=np.zeros(shape, dtype=np.int32),
            counts=np.zeros(shape + (N_COUNTS,), dtype=np.int64),
            collision=np.zeros(shape, dtype=np.uint8),
        )


# --------------------------------------------------------------------------------------------------
# see


@borrowing
def see_arena(b: int, w: World, obs: int, width_factor: float, kp: KernelParams, out: SeeBuffers) -> None:
    """Compute player object ``obs``'s see of arena ``b`` into row ``obs - 1`` of ``out``.

    ``width_factor`` multiplies ``kp.visible_angle`` into the full view cone (:func:`cone_factor`).
    Identity-loss draws come from ``w.rng[b]`` in sending order (flags, ball, players); docs/rules.md §5.2.
    """
    p = obs - 1
    ox = w.pos[b, obs, 0]
    oy = w.pos[b, obs, 1]
    ovx = w.vel[b, obs, 0]
    ovy = w.vel[b, obs, 1]
    body = w.body[b, obs] * DEG2RAD
    neck = w.neck[b, obs] * DEG2RAD
    half_cone = kp.visible_angle * width_factor * DEG2RAD * 0.5
    strict = kp.see_behind_strict != 0.0
    visible_distance2 = kp.visible_distance * kp.visible_distance
    unum_far = kp.unum_far_length
    unum_too_far = kp.unum_too_far_length
    level_row = out.level[b, p]
    dist_row = out.dist[b, p]
    dir_row = out.direction[b, p]
    dist_chg_row = out.dist_chg[b, p]
    dir_chg_row = out.dir_chg[b, p]
    body_row = out.body_dir[b, p]
    head_row = out.head_dir[b, p]
    for slot in range(N_FLAGS + w.pos.shape[1]):
        i = slot - N_FLAGS  # world object, < 0 for a flag
        level = UNSEEN
        quant_dist = np.nan
        direction = 0
        dist_chg = np.nan
        dir_chg = np.nan
        body_dir = 0
        head_dir = 0
        if i < 0 or (i != obs and w.enabled[b, i]):
            if i < 0:
                dx = FLAG_POSITIONS[slot, 0] - ox
                dy = FLAG_POSITIONS[slot, 1] - oy
                rvx = 0.0 - ovx  # flags stand still (0 - v as rcssserver, so no -0.0)
                rvy = 0.0 - ovy
            else:
                dx = w.pos[b, i, 0] - ox
                dy = w.pos[b, i, 1] - oy
                rvx = w.vel[b, i, 0] - ovx
                rvy = w.vel[b, i, 1] - ovy
            dist2 = dx * dx + dy * dy
            bearing = see_bearing(dx, dy, body, neck, half_cone)
            in_cone = abs(bearing) < half_cone if strict else abs(bearing) <= half_cone
            if in_cone or dist2 <= visible_distance2:
                dist = math.sqrt(dist2)
                # (the tables are read in place: binding one to a variable costs reference counting)
                quant_dist = table_distance(out.table_l, dist) if i < 0 else table_distance(out.table, dist)
                direction = round_deg(bearing)
                if not in_cone:
                    level = CLOSE
                elif i > BALL:
                    level = _player_level(w.rng, b, quant_dist, kp)
                elif _decide(w.rng, b, _far_probability(quant_dist, unum_far, unum_too_far)):
                    level = PARTIAL
                else:
                    level = FULL
                if level == FULL:
                    dist_chg, dir_chg = _changes(dist, quant_dist, dx, dy, rvx, rvy, kp)
                    if i > BALL:
                        other_body = w.body[b, i] * DEG2RAD
                        body_dir = round_deg(normalize_rad(other_body - body - neck))
                        head_dir = round_deg(normalize_rad(w.neck[b, i] * DEG2RAD + other_body - body - neck))
        level_row[slot] = level
        dist_row[slot] = quant_dist
        dir_row[slot] = direction
        dist_chg_row[slot] = dist_chg
        dir_chg_row[slot] = dir_chg
        body_row[slot] = body_dir
        head_row[slot] = head_dir
    _see_lines(b, p, ox, oy, body + neck, kp, out)


@njit(cache=True, inline="always")
def _changes(dist: float, quant_dist: float, dx: float, dy: float, rvx: float, rvy: float, kp) -> tuple:
    """dist_chg and dir_chg from the relative stored velocity (rcssserver ``calcVel``,
    docs/rules.md §5.2): both 0 at distance 0; an exact 0 direction change stays 0 instead of being quantised."""
    if dist == 0.0:
        return 0.0, 0.0
    ex = dx / dist
    ey = dy / dist
    dist_chg = rvx * ex + rvy * ey
    dir_chg = (rvy * ex - rvx * ey) / dist * RAD2DEG
    dir_chg = 0.0 if dir_chg == 0.0 else quantize(dir_chg, kp.dir_chg_step)
    return quant_dist * quantize(dist_chg / dist, kp.dist_chg_step), dir_chg


@njit(cache=True, inline="always")
def _see_lines(b: int, p: int, ox: float, oy: float, head: float, kp, out: SeeBuffers) -> None:
    """The pitch lines the line of sight crosses (rcssserver ``sendLines``/``sendLine``): at most one
    from inside the pitch, two from outside; distance |perpendicular / cos(sight-to-normal angle)|
    quantised with quantize_step_l; direction = that angle -/+ 90 deg (docs/rules.md §5.2)."""
    half_length = kp.pitch_length * 0.5
    half_width = kp.pitch_width * 0.5
    inside = abs(ox) < half_length and abs(oy) < half_width
    max_lines = 1 if inside else 2
    n_seen = 0
    for k in range(N_LINES):
        out.line_seen[b, p, k] = False
        out.line_dist[b, p, k] = np.nan
        out.line_dir[b, p, k] = 0
        if n_seen >= max_lines:
            continue
        if k == LINE_LEFT or k == LINE_RIGHT:
            line_at = -half_length if k == LINE_LEFT else half_length
            outward = math.pi if k == LINE_LEFT else 0.0
            beyond = ox < line_at if k == LINE_LEFT else ox > line_at
            to_line = line_at - ox
            extent = half_width
            vertical = True
        else:
            line_at = -half_width if k == LINE_TOP else half_width
            outward = -_HALF_PI if k == LINE_TOP else _HALF_PI
            beyond = oy < line_at if k == LINE_TOP else oy > line_at
            to_line = line_at - oy
            extent = half_length
            vertical = False
        normal = outward + math.pi if beyond else outward
        sight = normalize_rad(normal - head)
        if abs(sight) >= _HALF_PI:
            continue
        offset = to_line * math.tan(sight)
        cross = oy - offset if vertical else ox + offset
        if cross < -extent or cross > extent:
            continue
        n_seen += 1
        out.line_seen[b, p, k] = True
        out.line_dist[b, p, k] = table_distance(out.table_l, abs(to_line / math.cos(sight)))
        out.line_dir[b, p, k] = round_deg(sight - _HALF_PI if sight > 0.0 else sight + _HALF_PI)


@borrowing
def see_batch(w: World, width_factor: np.ndarray, due: np.ndarray, kp: KernelParams, out: SeeBuffers) -> None:
    """Every due, enabled observer of every arena: ``due`` and ``width_factor`` are (B, P)."""
    for b in range(w.pos.shape[0]):
        for p in range(w.pos.shape[1] - 1):
            if due[b, p] and w.enabled[b, p + 1]:
                see_arena(b, w, p + 1, width_factor[b, p], kp, out)


# --------------------------------------------------------------------------------------------------
# sense_body


@borrowing
def sense_body_arena(b: int, w: World, obs: int, out: SenseBodyBuffers) -> None:
    """Player object ``obs``'s sense_body values into row ``obs - 1`` (rcssserver BodySenderPlayerV6+,
    docs/rules.md §5.3): speed Q(|v|, 0.01) of the stored velocity, its direction relative to body +
    neck and the neck angle, both truncated to integer degrees."""
    p = obs - 1
    vx = w.vel[b, obs, 0]
    vy = w.vel[b, obs, 1]
    body = w.body[b, obs] * DEG2RAD
    neck = w.neck[b, obs] * DEG2RAD
    out.stamina[b, p] = w.stamina[b, obs]
    out.effort[b, p] = w.effort[b, obs]
    out.capacity[b, p] = w.capacity[b, obs]
    out.speed[b, p] = quantize(math.sqrt(vx * vx + vy * vy), SPEED_STEP)
    out.speed_dir[b, p] = trunc_deg(normalize_rad(math.atan2(vy, vx) - body - neck))
    out.head_angle[b, p] = trunc_deg(neck)
    for c in range(N_COUNTS):
        out.counts[b, p, c] = w.counts[b, obs, c]
    out.collision[b, p] = w.collision[b, obs]


@borrowing
def sense_body_batch(w: World, out: SenseBodyBuffers) -> None:
    """sense_body of every enabled player of every arena."""
    for b in range(w.pos.shape[0]):
        for p in range(w.pos.shape[1] - 1):
            if w.enabled[b, p + 1]:
                sense_body_arena(b, w, p + 1, out)


# --------------------------------------------------------------------------------------------------
# hear


@njit(cache=True)
def hear_picks(b: int, w: World, speakers: np.ndarray, listener: int, hear_max: float, cut: float,
               picks: np.ndarray) -> int:
    """Which of this cycle's says ``listener`` hears from other players (docs/rules.md §5.5): ``speakers``
    holds the speaker of each say, in object order; of those other than the listener within ``cut``
    (audio_cut_dist), at most ``hear_max`` from its own team, then at most ``hear_max`` from the other,
    each drawn at random from arena ``b``'s stream. Writes their indices into ``speakers`` to ``picks``
    in the order drawn; returns how many. The one rule of the server (``server.arena.Arena``) and the
    batched mode."""
    n_picked = 0
    candidates = np.empty(speakers.shape[0], dtype=np.int64)
    mine = listener <= w.n_keepers
    for own_team in (True, False):
        n = 0
        for i in range(speakers.shape[0]):
            speaker = speakers[i]
            if speaker == listener or ((speaker <= w.n_keepers) == mine) != own_team:
                continue
            dx = w.pos[b, speaker, 0] - w.pos[b, listener, 0]
            dy = w.pos[b, speaker, 1] - w.pos[b, listener, 1]
            if math.hypot(dx, dy) > cut:
                continue
            candidates[n] = i
            n += 1
        for _ in range(min(int(hear_max), n)):
            k = randint(w.rng, b, n)
            picks[n_picked] = candidates[k]
            n_picked += 1
            n -= 1
            for j in range(k, n):
                candidates[j] = candidates[j + 1]
    return n_picked


@borrowing
def hear_direction(b: int, w: World, listener: int, speaker: int) -> int:
    """Where ``listener`` hears ``speaker`` from: the direction to it relative to the listener's body,
    in whole degrees truncated towards zero (-180..180), as rcssserver 8+ writes it to a player
    (src/audio.cpp, AudioSenderPlayerv8::sendCachedNonSelfPlayerAudio: Rad2IDeg of angleFromBody)."""
    dx = w.pos[b, speaker, 0] - w.pos[b, listener, 0]
    dy = w.pos[b, speaker, 1] - w.pos[b, listener, 1]
    return trunc_deg(normalize_rad(math.atan2(dy, dx) - w.body[b, listener] * DEG2RAD))


# --------------------------------------------------------------------------------------------------
# fullstate


def fullstate(w: World, b: int) -> dict:
    """Exact global state of arena ``b`` (rcssserver fullstate, docs/rules.md §5.4): ball x y vx vy; every enabled
    player side, unum, x y vx vy, body, neck (deg, neck relative to body), stamina effort recovery
    capacity. Not mirrored for the right team."""
    ball = np.concatenate((w.pos[b, BALL], w.vel[b, BALL])).tolist()
    players = np.flatnonzero(w.enabled[b, 1:]) + 1
    state = np.column_stack(
        (
            w.pos[b, players],
            w.vel[b, players],
            w.body[b, players],
            w.neck[b, players],
            w.stamina[b, players],
            w.effort[b, players],
            w.recovery[b, players],
            w.capacity[b, players],
        )
    ).tolist()
    return {
        "ball": ball,
        "players": [[w.side(i), w.unum(i), *row] for i, row in zip(players.tolist(), state)],
    }


__all__ = [
    "CLOSE",
    "DEG2RAD",
    "DistanceTable",
    "FULL",
    "NAMELESS",
    "PARTIAL",
    "RAD2DEG",
    "SYNCH_SEE_WIDTH_FACTOR",
    "SeeBuffers",
    "SenseBodyBuffers",
    "UNSEEN",
    "VIEW_WIDTH_FACTOR",
    "cone_factor",
    "distance_table",
    "fullstate",
    "hear_direction",
    "hear_picks",
    "normalize_rad",
    "quantize",
    "quantize_distance",
    "round_deg",
    "see_arena",
    "see_batch",
    "see_due",
    "sense_body_arena",
    "sense_body_batch",
    "table_distance",
    "trunc_deg",
]

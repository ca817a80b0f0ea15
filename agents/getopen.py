"""GetOpen: where a keeper without the ball should stand (docs/players.md §7).

Candidate targets are a grid over the region. The policies differ only in how a target is chosen:
GO:R keeps a random grid point until reached, GO:HC takes the least congested point whose passing lane
from predictedBallPos is open (the paper's 18.4 deg rule, or the framework's cone as an option), GO:L
takes the argmax of a 10-5-5-1 net over each point's state variables, seen through the policy's input
scaling (:class:`InputScaling`, by default :class:`GetOpenScaling`; docs/design.md, "Learning options"), and
breaks exact ties towards the point nearest the keeper. The movement is shared.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from keepaway.agents.belief import AgentMemory, Belief
from keepaway.agents.config import GETOPEN_HANDCODED, GETOPEN_HANDCODED_CONE, GETOPEN_LEARNED, GETOPEN_RANDOM
from keepaway.agents.geometry import (
    DECIDE_SLACK,
    ball_in,
    closest_to_ball,
    compared_hypot,
    distance,
    in_cone,
    vertex_angle_below,
)
from keepaway.agents.interception import fastest_to_ball
from keepaway.agents.movement import go_to_point, turn_to_point
from keepaway.agents.state_vars import (
    ESTIMATE_ANGLE_ERROR,
    ESTIMATE_DISTANCE_ERROR,
    getopen_point_estimate,
    getopen_point_state,
    getopen_setup,
    getopen_state_kinds,
    getopen_state_size,
    vertex_scratch,
)
from keepaway.core.jit import borrowing, njit
from keepaway.core.rng import randint

NET_HIDDEN = 5  # docs/players.md §7.4: two hidden layers of 5 units
SCALED_TANH_A = 1.7159  # docs/players.md §7.4: Haykin's scaled tanh a tanh(b x)
SCALED_TANH_B = 2.0 / 3.0


def net_size(n_inputs: int = 10) -> int:
    """Parameters of the n-5-5-1 net: 5n + 5 + 25 + 5 + 5 + 1 (91 for the 10 GetOpen inputs)."""
    return NET_HIDDEN * n_inputs + NET_HIDDEN + NET_HIDDEN * NET_HIDDEN + NET_HIDDEN + NET_HIDDEN + 1


@njit(cache=True)
def net_value(theta, x) -> float:
    """The GO:L value f_theta(x) (docs/players.md §7.4). Layout of ``theta``: W1 (5 x n, row-major,
    row = hidden unit), b1 (5), W2 (5 x 5, row-major), b2 (5), W3 (1 x 5), b3 (1); hidden units
    1.7159 tanh(2z/3), linear output."""
    return net_value_into(theta, x, np.empty(NET_HIDDEN))


@borrowing
def net_value_into(theta, x, h1) -> float:
    """:func:`net_value` with the first hidden layer in ``h1`` (5 values), for a caller that scores many
    points."""
    n = x.shape[0]
    net_first_layer(theta, x, h1)
    return net_output(theta, n, h1)


@borrowing
def net_first_layer(theta, x, z1) -> None:
    """The first hidden layer's net inputs z (before the squashing) into ``z1``."""
    n = x.shape[0]
    at = NET_HIDDEN * n
    for u in range(NET_HIDDEN):
        z = theta[at + u]
        for i in range(n):
            z += theta[u * n + i] * x[i]
        z1[u] = z


@borrowing
def net_output(theta, n: int, h1) -> float:
    """The net's value from its first layer's net inputs in ``h1`` (:func:`net_first_layer`), which
    become that layer's outputs."""
    return _upper_layers(theta, n, h1, False)


@borrowing
def net_output_estimate(theta, n: int, z1, h1) -> float:
    """:func:`net_output` of the first layer's net inputs ``z1`` (left as they are; ``h1``: 5 values of
    scratch) with :func:`tanh_estimate` for tanh: within :func:`net_estimate_error` of it."""
    for u in range(NET_HIDDEN):
        h1[u] = z1[u]
    return _upper_layers(theta, n, h1, True)


@borrowing
def _upper_layers(theta, n: int, h1, estimate: bool) -> float:
    """:func:`net_output`, with libm's tanh or (``estimate``) :func:`tanh_estimate`."""
    at = NET_HIDDEN * n
    for u in range(NET_HIDDEN):
        h1[u] = SCALED_TANH_A * _tanh(SCALED_TANH_B * h1[u], estimate)
    w2 = at + NET_HIDDEN
    b2 = w2 + NET_HIDDEN * NET_HIDDEN
    w3 = b2 + NET_HIDDEN
    out = theta[w3 + NET_HIDDEN]
    for u in range(NET_HIDDEN):
        z = theta[b2 + u]
        for i in range(NET_HIDDEN):
            z += theta[w2 + u * NET_HIDDEN + i] * h1[i]
        out += theta[w3 + u] * SCALED_TANH_A * _tanh(SCALED_TANH_B * z, estimate)
    return out


# GO:L decides on estimates where it is sure (docs/design.md, "Compiled kernels"): tanh by its [7/6] Pade
# approximant, +-1 beyond TANH_ESTIMATE_CLAMP, off by at most 9.65e-5 (measured on a grid of 1e-6 over [0,
# 12]; odd on both sides); the bound used is twice that.
TANH_ESTIMATE_CLAMP = 4.97
TANH_ESTIMATE_ERROR = 2e-4


@borrowing
def _tanh(z: float, estimate: bool) -> float:
    return tanh_estimate(z) if estimate else math.tanh(z)


@borrowing
def tanh_estimate(z: float) -> float:
    """tanh(z) within TANH_ESTIMATE_ERROR, without libm."""
    if z > TANH_ESTIMATE_CLAMP:
        return 1.0
    if z < -TANH_ESTIMATE_CLAMP:
        return -1.0
    z2 = z * z
    return z * (135135.0 + z2 * (17325.0 + z2 * (378.0 + z2))) / (135135.0 + z2 * (62370.0 + z2 * (3150.0 + z2 * 28.0)))


@borrowing
def net_estimate_error(theta, n: int, input_error: float, input_size: float) -> float:
    """A bound on |net_output_estimate(z1') - net_output(z1)| where z1' is the first layer's net input of
    inputs each off by at most ``input_error`` from z1's, all at most ``input_size`` in size (0 and 0:
    the same z1): each first-layer net input is off by its weights' absolute sum times ``input_error``,
    each squashed unit by at most a (TANH_ESTIMATE_ERROR + the error passed to it times b) (tanh' <= 1),
    each weighted sum by its weights' absolute sum times its inputs' error; plus a margin for the two
    paths' rounding (each sum's terms are at most its weights times its inputs' size). Infinite (or NaN)
    for a net with infinite weights."""
    z_error = 0.0
    for u in range(NET_HIDDEN):
        spread = 0.0
        for i in range(n):
            spread += abs(theta[u * n + i])
        size = abs(theta[NET_HIDDEN * n + u]) + spread * input_size
        z_error = max(z_error, spread * input_error + 1e-12 * size)
    e1 = SCALED_TANH_A * (TANH_ESTIMATE_ERROR + SCALED_TANH_B * z_error)
    w2 = NET_HIDDEN * n + NET_HIDDEN
    b2 = w2 + NET_HIDDEN * NET_HIDDEN
    w3 = b2 + NET_HIDDEN
    out_error = 0.0
    scale = abs(theta[w3 + NET_HIDDEN])
    for u in range(NET_HIDDEN):
        spread, size = 0.0, abs(theta[b2 + u])
        for i in range(NET_HIDDEN):
            spread += abs(theta[w2 + u * NET_HIDDEN + i])
        size += spread * SCALED_TANH_A
        z_error = spread * e1 + 1e-12 * size
        out_error += abs(theta[w3 + u]) * SCALED_TANH_A * (SCALED_TANH_B * z_error + TANH_ESTIMATE_ERROR)
        scale += abs(theta[w3 + u]) * SCALED_TANH_A
    return out_error * (1.0 + 1e-9) + 1e-12 * scale + 1e-12


@dataclass(frozen=True)
class InputScaling:
    """The affine scaling of a GO:L net's inputs, part of the policy: the net sees (x - mean) / scale for
    the raw state variables x (metres, degrees). A policy file stores it with the net's parameters, so a
    saved policy plays as trained; the identity is the paper's unscaled net (docs/design.md, "Learning options")."""

    mean: tuple[float, ...]
    scale: tuple[float, ...]

    def __post_init__(self) -> None:
        mean, scale = np.asarray(self.mean, dtype=np.float64), np.asarray(self.scale, dtype=np.float64)
        if mean.ndim != 1 or mean.shape != scale.shape or mean.size == 0:
            raise ValueError(f"input scaling needs as many means as scales, got {mean.shape} and {scale.shape}")
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(scale)) and np.all(scale > 0.0)):
            raise ValueError("input scaling needs finite means and finite positive scales")
        object.__setattr__(self, "mean", tuple(float(v) for v in mean))
        object.__setattr__(self, "scale", tuple(float(v) for v in scale))

    @classmethod
    def identity(cls, n_inputs: int) -> InputScaling:
        """No scaling: the net sees the raw variables (policy files written before scaling existed)."""
        return cls((0.0,) * n_inputs, (1.0,) * n_inputs)

    @property
    def n_inputs(self) -> int:
        return len(self.mean)

    def standardise(self, x: np.ndarray) -> np.ndarray:
        """(x - mean) / scale, over the last axis."""
        return (np.asarray(x, dtype=np.float64) - np.array(self.mean)) / np.array(self.scale)

    def fold(self, theta: np.ndarray) -> np.ndarray:
        """The parameters of the same net on the raw variables, the form :func:`net_value` and every kernel
        take: W1' = W1 / scale (per input), b1' = b1 - W1 (mean / scale); the rest unchanged. So
        ``net_value(fold(theta), x) == net_value(theta, standardise(x))`` up to rounding (docs/design.md,
        "Learning options", has the measured error); the identity returns ``theta`` bit for bit."""
        theta = np.asarray(theta, dtype=np.float64)
        n = self.n_inputs
        if theta.shape != (net_size(n),):
            raise ValueError(f"a net on {n} inputs has {net_size(n)} parameters, not shape {theta.shape}")
        w1 = theta[:NET_HIDDEN * n].reshape(NET_HIDDEN, n)
        scale = np.array(self.scale)
        out = theta.copy()
        out[:NET_HIDDEN * n] = (w1 / scale).ravel()
        out[NET_HIDDEN * n:NET_HIDDEN * (n + 1)] -= w1 @ (np.array(self.mean) / scale)
        return out

    def to_json(self) -> dict[str, list[float]]:
        return {"mean": list(self.mean), "scale": list(self.scale)}

    @classmethod
    def from_json(cls, data: Any, n_inputs: int) -> InputScaling:
        """The scaling of :meth:`to_json` for a net on ``n_inputs`` inputs; ValueError (one line) if it is
        not that."""
        if type(data) is not dict or set(data) != {"mean", "scale"}:
            raise ValueError("getopen_inputs must be a map with exactly mean and scale")
        values = [data["mean"], data["scale"]]
        if any(type(v) is not list or len(v) != n_inputs or any(type(e) not in (int, float) for e in v)
               for v in values):
            raise ValueError(f"getopen_inputs mean and scale must be lists of {n_inputs} numbers")
        return cls(tuple(values[0]), tuple(values[1]))


@dataclass(frozen=True)
class GetOpenScaling:
    """The rule that scales GO:L's inputs (ours: the paper states none; docs/design.md, "Learning options").
    Each kind of variable (``agents.state_vars.GETOPEN_KINDS``) has a (mean, standard deviation): for
    distances as fractions of the region's side, for angles in degrees, so every K, T and field size gets
    a scaling (:meth:`inputs`). The defaults are the pooled means and standard deviations, per kind, of
    the GetOpen states of every grid point of every GetOpen decision the keepers took in P:HC-GO:HC play,
    3v2 on 20 m, classic parameters: ``benchmarks/getopen_scaling.py --episodes 1000`` (seed 0, 50
    arenas, every 5th cycle: 65,307 decisions x 25 points = 1,632,675 states), rounded to 3 digits."""

    teammate_distance: tuple[float, float] = (0.475, 0.224)  # dist(K1', Ki'), 3v2 on 20 m: 9.50 +- 4.48 m
    taker_distance: tuple[float, float] = (0.400, 0.187)  # dist(K1', Tj'): 8.00 +- 3.74 m
    teammate_taker_distance: tuple[float, float] = (0.398, 0.231)  # min_j dist(Ki', Tj'): 7.96 +- 4.62 m
    teammate_taker_angle: tuple[float, float] = (51.1, 44.4)  # min_j ang(Ki', K1', Tj'), degrees
    pass_distance: tuple[float, float] = (0.470, 0.220)  # dist(K1, K1'): 9.40 +- 4.40 m
    lane_angle: tuple[float, float] = (44.1, 38.0)  # min_j ang(K1', K1, Tj), degrees

    def inputs(self, n_keepers: int, n_takers: int, region_size: float) -> InputScaling:
        """The scaling of the 3K + T - 1 GetOpen variables on a square region of side ``region_size`` m."""
        pairs = []
        for kind in getopen_state_kinds(n_keepers, n_takers):
            mean, sd = getattr(self, kind)
            unit = region_size if kind.endswith("distance") else 1.0
            pairs.append((mean * unit, sd * unit))
        return InputScaling(*(tuple(v) for v in zip(*pairs)))


# A training's choice of GO:L input scaling (``trainer.train.TrainConfig.getopen_inputs``).
SCALED_INPUTS = "scaled"  # GetOpenScaling() for the game's K, T and field size
RAW_INPUTS = "raw"  # the identity: the paper's literal net on metres and degrees
GETOPEN_INPUTS = (SCALED_INPUTS, RAW_INPUTS)


def getopen_input_scaling(name: str, n_keepers: int, n_takers: int, region_size: float) -> InputScaling:
    """The input scaling named ``name`` (:data:`GETOPEN_INPUTS`) for a game of K keepers, T takers on a
    square region of side ``region_size`` m."""
    if name == SCALED_INPUTS:
        return GetOpenScaling().inputs(n_keepers, n_takers, region_size)
    if name == RAW_INPUTS:
        return InputScaling.identity(getopen_state_size(n_keepers, n_takers))
    raise ValueError(f"GetOpen inputs must be one of {', '.join(GETOPEN_INPUTS)}, not {name!r}")


@borrowing
def grid_size(cfg) -> int:
    return int(cfg.grid_points) * int(cfg.grid_points)


@borrowing
def grid_point(k: int, kp, cfg) -> tuple:
    """Grid point ``k`` (x outer, y inner, both ascending): x = xmin + 0.15 L + i 0.175 L for a 5 x 5 grid
    with 15 % margins (docs/players.md §7.1; 20 m: -7, -3.5, 0, 3.5, 7)."""
    n = int(cfg.grid_points)
    i, j = k // n, k % n
    span = (1.0 - 2.0 * cfg.grid_margin) / (n - 1)
    length, width = kp.keepaway_length, kp.keepaway_width
    x = -length / 2.0 + cfg.grid_margin * length + i * span * length
    y = -width / 2.0 + cfg.grid_margin * width + j * span * width
    return x, y


@borrowing
def predicted_ball_pos(bel: Belief, r: int, cycles: int, kp, cfg) -> tuple:
    """predictedBallPos: the ball after ``cycles``, the fastest keeper's interception time from
    ``fastest_to_ball`` (0 if a keeper has it; capped at the horizon if nobody reaches it)
    (docs/players.md §7.1)."""
    return ball_in(bel, r, min(cycles, int(cfg.intercept_horizon)), kp)


@borrowing
def congestion(bel: Belief, r: int, px: float, py: float, cfg) -> float:
    """Sum over the other usable players not exactly at P of 1 / dist(player, P)
    (docs/players.md §7.2; -value(P) of GO:HC)."""
    total = 0.0
    for j in range(1, bel.n_keepers + bel.n_takers + 1):
        if j == bel.me[r] or bel.conf[r, j] < cfg.player_conf_threshold:
            continue
        d = distance(px, py, bel.pos[r, j, 0], bel.pos[r, j, 1])
        if d > 0.0:
            total += 1.0 / d
    return total


@borrowing
def congestion_estimate(bel: Belief, r: int, px: float, py: float, cfg) -> float:
    """``congestion`` with one sqrt per player instead of hypot: within a few ulps of it per term, which
    is all ``handcoded_target`` needs to pass over a point that is clearly worse than the best so far.
    NaN (undecided) where a player is so close to P that the squares might underflow."""
    total = 0.0
    for j in range(1, bel.n_keepers + bel.n_takers + 1):
        if j == bel.me[r] or bel.conf[r, j] < cfg.player_conf_threshold:
            continue
        dx, dy = bel.pos[r, j, 0] - px, bel.pos[r, j, 1] - py
        squared = dx * dx + dy * dy
        if squared < 1.0e-100:
            if dx != 0.0 or dy != 0.0:
                return math.nan
            continue
        total += 1.0 / math.sqrt(squared)
    return total


@borrowing
def safety_cosine(cfg) -> float:
    """cos(go_safety_angle), for ``lane_open``'s test."""
    return math.cos(math.radians(cfg.go_safety_angle))


@borrowing
def lane_open(bel: Belief, r: int, px: float, py: float, bx: float, by: float, cone: bool, cos_limit: float,
              cfg) -> bool:
    """Whether the lane from predictedBallPos B to P is open: the paper's min_j ang(P, B, Tj) >= 18.4 deg
    (docs/players.md §7.2), or with ``cone`` no taker in the framework's cone of half-width 0.3
    (same section). Takers with conf < 0.88 are ignored. ``cos_limit``: the cosine of
    the safety angle (``safety_cosine``), computed once for all grid points."""
    for j in range(bel.n_keepers + 1, bel.n_keepers + bel.n_takers + 1):
        if bel.conf[r, j] < cfg.player_conf_threshold:
            continue
        tx, ty = bel.pos[r, j, 0], bel.pos[r, j, 1]
        if cone:
            if in_cone(bx, by, px, py, tx, ty, cfg.go_cone_ratio):
                return False
        elif vertex_angle_below(px, py, bx, by, tx, ty, cfg.go_safety_angle, cos_limit):
            return False
    return True


@borrowing
def handcoded_target(bel: Belief, r: int, ball_cycles: int, cone: bool, kp, cfg) -> tuple:
    """GO:HC: the admissible grid point with the lowest congestion (strict <, scan order wins ties);
    the region centre if none is admissible (docs/players.md §7.2).
    ``ball_cycles``: the fastest keeper's interception time (``fastest_to_ball``).

    Points are compared on congestion estimates (one sqrt a player) wherever these differ by more than
    DECIDE_SLACK, far beyond their error, and on the exact congestions (hypot) only where they do not:
    the same point as comparing exact congestions throughout."""
    bx, by = predicted_ball_pos(bel, r, ball_cycles, kp, cfg)
    cos_limit = safety_cosine(cfg)
    # the best point so far, its congestion estimate (or exact value) and its exact value (NaN: not
    # computed yet; inf: no point yet, which any finite congestion beats)
    best, best_e, best_c = -1, math.inf, math.inf
    for k in range(grid_size(cfg)):
        px, py = grid_point(k, kp, cfg)
        if not lane_open(bel, r, px, py, bx, by, cone, cos_limit, cfg):
            continue
        e = congestion_estimate(bel, r, px, py, cfg)
        if best >= 0 and e - best_e > DECIDE_SLACK * (1.0 + best_e):
            continue  # clearly not lower: the exact congestion cannot win (nor tie) either
        if e < math.inf and (best < 0 or best_e - e > DECIDE_SLACK * (1.0 + e)):
            best, best_e, best_c = k, e, math.nan  # clearly lower (or the first, finite): it wins exactly too
            continue
        if math.isnan(best_c):  # too close to call on estimates: the exact congestions decide
            qx, qy = grid_point(best, kp, cfg)
            best_c = congestion(bel, r, qx, qy, cfg)
        c = congestion(bel, r, px, py, cfg)
        if c < best_c:
            best, best_e, best_c = k, c, c
    if best < 0:
        return 0.0, 0.0
    return grid_point(best, kp, cfg)


@borrowing
def lane_origin(bel: Belief, r: int, ball_cycles: int, kp, cfg) -> tuple:
    """Where GO:L's variables 9-10 measure the pass from: the keeper now closest to the ball (K1,
    docs/players.md §7.4; myself if no keeper is usable), or with
    ``cfg.getopen_lane_from_predicted_ball`` predictedBallPos, as GO:HC's lane test."""
    if cfg.getopen_lane_from_predicted_ball:
        return predicted_ball_pos(bel, r, ball_cycles, kp, cfg)
    k1 = closest_to_ball(bel, r, 1, bel.n_keepers, -1, cfg)
    if k1 < 0:
        k1 = bel.me[r]
    return bel.pos[r, k1, 0], bel.pos[r, k1, 1]


@njit(cache=True)
def learned_target(bel: Belief, r: int, theta, ball_cycles: int, kp, cfg) -> tuple:
    """GO:L: the grid point with the highest net value of its GetOpen state (docs/players.md §7.4).
    Exact ties (a saturated net gives many points the very same value) go to the tied point nearest to
    me, not to the first in scan order (a corner): a keeper heading for that point stays nearest to it,
    so re-evaluating every cycle does not make it switch targets (docs/design.md, "Learning options").
    ``theta`` takes the raw state variables (a scaling folded in: ``InputScaling.fold``);
    ``ball_cycles``: the fastest keeper's interception time (``fastest_to_ball``).

    Every point is first scored on estimates: its variables (:func:`getopen_point_estimate`: a sqrt for
    each hypot, a polynomial for each acos) and tanh (:func:`net_output_estimate`); its exact variables
    and value are computed only where the estimate lies within twice its error bound
    (:func:`net_estimate_error` of the variables' error) of the best estimate, or could not be made. Any
    other point's exact value lies below the best point's, so it could neither win nor tie: the same
    target as scoring every point exactly, in the same scan order."""
    ox, oy = lane_origin(bel, r, ball_cycles, kp, cfg)
    me = bel.me[r]
    mx, my = bel.pos[r, me, 0], bel.pos[r, me, 1]
    n = getopen_state_size(bel.n_keepers, bel.n_takers)
    points = grid_size(cfg)
    x = np.empty(n)
    z1 = np.empty(NET_HIDDEN)
    h1 = np.empty(NET_HIDDEN)
    estimate = np.empty(points)
    sure = np.empty(points, dtype=np.bool_)
    s = vertex_scratch(bel.n_keepers, bel.n_takers)
    getopen_setup(bel, r, ox, oy, s)
    top, size = -math.inf, 0.0
    for k in range(points):
        px, py = grid_point(k, kp, cfg)
        sure[k] = getopen_point_estimate(bel, r, px, py, ox, oy, s, x)
        if not sure[k]:
            continue
        for i in range(n):
            size = max(size, abs(x[i]))
        net_first_layer(theta, x, z1)
        estimate[k] = net_output_estimate(theta, n, z1, h1)
        if estimate[k] > top:
            top = estimate[k]
    error = net_estimate_error(theta, n, ESTIMATE_ANGLE_ERROR + ESTIMATE_DISTANCE_ERROR * size, size)
    floor = top - error if error < math.inf else -math.inf  # the best point's exact value is above it
    best_x, best_y, best, best_d = 0.0, 0.0, -math.inf, math.inf
    for k in range(points):
        if sure[k] and estimate[k] + error < floor:  # NaN estimates are scored exactly, as all are without a bound
            continue
        px, py = grid_point(k, kp, cfg)
        getopen_point_state(bel, r, px, py, ox, oy, s, x)
        net_first_layer(theta, x, z1)
        v = net_output(theta, n, z1)
        d = distance(mx, my, px, py)
        if v > best or (v == best and d < best_d):
            best_x, best_y, best, best_d = px, py, v, d
    return best_x, best_y


@njit(cache=True)
def grid_states(bel: Belief, r: int, sums, kp, cfg, out) -> None:
    """The GetOpen variables of every grid point into ``out`` (one row per point, ``grid_point`` order,
    3K + T - 1 columns) for the deciding keeper of row ``r``: what GO:L scores (:func:`learned_target`),
    for a GetOpen decided outside (``agents.config.GETOPEN_EXTERNAL``)."""
    _, ball_cycles = fastest_to_ball(bel, r, 1, bel.n_keepers, sums, kp, cfg)
    ox, oy = lane_origin(bel, r, ball_cycles, kp, cfg)
    s = vertex_scratch(bel.n_keepers, bel.n_takers)
    getopen_setup(bel, r, ox, oy, s)
    for k in range(grid_size(cfg)):
        px, py = grid_point(k, kp, cfg)
        getopen_point_state(bel, r, px, py, ox, oy, s, out[k])


@borrowing
def random_target(bel: Belief, r: int, mem: AgentMemory, kp, cfg) -> tuple:
    """GO:R: a uniformly drawn grid point, kept until I am within the arrival radius of it
    (docs/players.md §7.3)."""
    me = bel.me[r]
    if (not mem.has_target[r]) or compared_hypot(
        mem.target[r, 0] - bel.pos[r, me, 0], mem.target[r, 1] - bel.pos[r, me, 1], cfg.arrival_radius
    ) < cfg.arrival_radius:
        px, py = grid_point(randint(mem.rng, r, grid_size(cfg)), kp, cfg)
        mem.target[r, 0] = px
        mem.target[r, 1] = py
        mem.has_target[r] = True
    return mem.target[r, 0], mem.target[r, 1]


@borrowing
def move_to_spot(bel: Belief, r: int, px: float, py: float, kp, cfg) -> tuple:
    """Within the arrival radius turn the body to the ball and stand; else GoToPoint(P, 7 deg)
    (docs/players.md §7.5)."""
    me = bel.me[r]
    if compared_hypot(px - bel.pos[r, me, 0], py - bel.pos[r, me, 1], cfg.arrival_radius) < cfg.arrival_radius:
        return turn_to_point(bel, r, bel.pos[r, 0, 0], bel.pos[r, 0, 1], 1.0, kp)
    return go_to_point(bel, r, px, py, kp, cfg)


@borrowing
def getopen(bel: Belief, r: int, mem: AgentMemory, theta, ball_cycles: int, kp, cfg) -> tuple:
    """GetOpen with the policy ``cfg.getopen_policy``, re-evaluated every cycle
    (docs/players.md §7); ``theta`` is this row's net parameters (used by GO:L only),
    ``ball_cycles`` the fastest keeper's interception time."""
    policy = int(cfg.getopen_policy)
    if policy == GETOPEN_RANDOM:
        px, py = random_target(bel, r, mem, kp, cfg)
    elif policy == GETOPEN_LEARNED:
        px, py = learned_target(bel, r, theta, ball_cycles, kp, cfg)
    else:
        px, py = handcoded_target(bel, r, ball_cycles, policy == GETOPEN_HANDCODED_CONE, kp, cfg)
    note_getopen(bel, r, mem, px, py)
    return move_to_spot(bel, r, px, py, kp, cfg)


@borrowing
def note_getopen(bel: Belief, r: int, mem: AgentMemory, px: float, py: float) -> None:
    """Remember this cycle's GetOpen point: what a keeper's GetOpen note reports (docs/protocol.md §5,
    "command"); nothing decides on it."""
    mem.getopen_point[r, 0] = px
    mem.getopen_point[r, 1] = py
    mem.getopen_time[r] = bel.time[r]


@njit(cache=True)
def grid_values(bel: Belief, r: int, theta, sums, kp, cfg, out) -> int:
    """How the keeper's GetOpen policy rates each grid point, higher better, as rows ``(x, y, value)`` of
    ``out`` (at least grid-size rows); returns the number of rows. GO:HC: minus the congestion of each
    admissible point (the others are no candidates and get no row); GO:L: the net's value; GO:R: no rows.
    For the notes a viewer draws (docs/protocol.md §5, "command"), computed only when asked for: the
    decision itself (:func:`getopen`) never fills them."""
    policy = int(cfg.getopen_policy)
    if policy != GETOPEN_LEARNED and policy != GETOPEN_HANDCODED and policy != GETOPEN_HANDCODED_CONE:
        return 0
    _, ball_cycles = fastest_to_ball(bel, r, 1, bel.n_keepers, sums, kp, cfg)
    bx, by = predicted_ball_pos(bel, r, ball_cycles, kp, cfg)
    cos_limit = safety_cosine(cfg)
    ox, oy = lane_origin(bel, r, ball_cycles, kp, cfg)
    x = np.empty(getopen_state_size(bel.n_keepers, bel.n_takers))
    h1 = np.empty(NET_HIDDEN)
    s = vertex_scratch(bel.n_keepers, bel.n_takers)
    getopen_setup(bel, r, ox, oy, s)
    n = 0
    for k in range(grid_size(cfg)):
        px, py = grid_point(k, kp, cfg)
        if policy == GETOPEN_LEARNED:
            getopen_point_state(bel, r, px, py, ox, oy, s, x)
            value = net_value_into(theta, x, h1)
        elif lane_open(bel, r, px, py, bx, by, policy == GETOPEN_HANDCODED_CONE, cos_limit, cfg):
            value = -congestion(bel, r, px, py, cfg)
        else:
            continue
        out[n, 0] = px
        out[n, 1] = py
        out[n, 2] = value
        n += 1
    return n

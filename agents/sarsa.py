"""SMDP Sarsa(lambda) over 1-D tile codings: the Pass learner (spec `keepaway-agents.md` 5,
`keepaway-task.md` 5).

A re-creation of the keepaway player's `LinearSarsaAgent.cc` and `tiles2.cc`. Each state variable gets
32 offset 1-D tilings per action, so a (state, action) pair activates 32 tiles per variable (416 for the
13 Pass variables of 3v2) and Q(s, a) is the sum of their weights. Tiles are hashed into one table of
2^20 weights by the UNH hash with a safe (re-probing) collision table, whose random table is drawn as
the C++ player draws it (glibc ``rand()`` right after ``srand(0)``), and variables enter the hash by
their index in the C++ state vector: fed the same states in the same order, the weight indices are
the original's.

Every learning keeper is one row of a ``SarsaMemory``: its own eligibility traces, cached Q values,
exploration stream, mode and a ring buffer of its SMDP transitions, and a weight table (weights and
collision table) of its own, or, with the hive mind (``SarsaConfig.hive_mind``, tjpalmer's
LinearSarsaAgent option: `keepaway-agents.md` 5), one table shared by the keepers of a team, each
updating it through its own traces. Kernels take the row index ``r`` so a batched loop can drive many
learners inside one njit loop (``runner.batched.learn_pass``); ``SarsaLearner`` wraps one row for a keeper
process.

Memory per row at the default sizes: weights 8 MB, collision table 4 MB (int32: the check values are
below 2^31), trace slots 4 MB, trace list 1.6 MB.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from keepaway.core.jit import borrowing

from keepaway.core.rng import randint, seed_streams, uniform
from keepaway.protocol.advice import PASS_MODES

# Modes, switchable between episodes (spec `keepaway-agents.md` 5, evaluation mode).
MODE_LEARN = 0  # epsilon-greedy actions, weight updates (player -e 1)
MODE_GREEDY = 1  # greedy actions, no updates: the frozen policy of evaluations (player -e 0)
MODE_EXPLORE = 2  # epsilon-greedy actions, no updates: training behaviour with frozen weights
MODE_NAMES = dict(zip(PASS_MODES, (MODE_LEARN, MODE_GREEDY, MODE_EXPLORE), strict=True))  # as the advice names them
NO_ACTION = -1

# tiles2.cc / tiles2.h constants of the UNH hash.
UNH_TABLE_SIZE = 2048  # rndseq[2048]
INDEX_INCREMENT = 449  # hash_UNH increment for the weight index and the probe stride
CHECK_INCREMENT = 457  # hash_UNH increment for the collision check value
MAX_LONG_INT = 2147483647  # MaxLONGINT
EMPTY_SLOT = -1  # collision_table::reset
MIN_TRACE_GROWTH = 1.1  # LinearSarsaAgent::increaseMinTrace
# Quantised values (32 per tile width) whose tile slots load_tiles remembers, per variable and action:
# 20 tile widths, past 180 degrees at 10 and 40 m at 3 (others are hashed each time, as before).
MEMO_VALUES = 640
# Columns of SarsaMemory.hash_counts (collision_table calls / clearhits / collisions).
HASH_CALLS = 0
HASH_CLEAR_HITS = 1
HASH_COLLISIONS = 2

GLIBC_MODULUS = 2147483647  # glibc srandom_r: Park-Miller seeding
GLIBC_MULTIPLIER = 16807
GLIBC_DEGREE = 31  # TYPE_3 state words
GLIBC_SEP = 3
GLIBC_DISCARD = 310  # results dropped by srandom_r (10 * degree) after the 3 copied words


@dataclass(frozen=True)
class SarsaConfig:
    """The learner's constants, each with its source."""

    alpha: float = 0.125  # LinearSarsaAgent.cc; keepaway-agents.md 5
    epsilon: float = 0.01  # LinearSarsaAgent.cc; keepaway-task.md 5
    gamma: float = 1.0  # LinearSarsaAgent.cc: the SMDP update assumes no discounting
    trace_decay: float = 0.0  # lambda, LinearSarsaAgent.cc (keepaway-agents.md 5: UNCONFIRMED in papers)
    min_trace: float = 0.01  # LinearSarsaAgent.cc minimumTrace
    tilings: int = 32  # LinearSarsaAgent::loadTiles tilingsPerGroup
    distance_width: float = 3.0  # keepaway-task.md 5 / AB05: every distance, m
    angle_width: float = 10.0  # keepaway-task.md 5 / AB05 and the code: angles, deg
    code_widths: bool = False  # the code's per-variable widths instead (keepaway-agents.md 4)
    table_size: int = 1 << 20  # LinearSarsaAgent.h RL_MEMORY_SIZE
    max_traces: int = 100_000  # LinearSarsaAgent.h RL_MAX_NONZERO_TRACES
    transition_log_size: int = 4096  # ours: SMDP transitions kept per row for reporting
    # tjpalmer's LinearSarsaAgent hive mind (keepaway-agents.md 5), off in the original and the paper: the
    # keepers of a team read and update one weight table, each through its own traces (new_memory's team)
    hive_mind: bool = False

    def __post_init__(self) -> None:
        if self.gamma != 1.0:
            raise ValueError("the SMDP update bootstraps undiscounted (LinearSarsaAgent.cc assumes gamma 1)")
        if self.table_size < 2 or self.table_size & (self.table_size - 1):
            raise ValueError(f"table_size must be a power of 2 (collision_table), got {self.table_size}")
        if not 0.0 < self.min_trace <= 1.0 or not 0.0 <= self.trace_decay <= 1.0:
            raise ValueError("need 0 < min_trace <= 1 and 0 <= trace_decay <= 1")
        if self.tilings < 1 or self.max_traces < 1 or self.transition_log_size < 1:
            raise ValueError("tilings, max_traces and transition_log_size must be positive")

    def kernel(self) -> SarsaParams:
        """The step-size constants as the NamedTuple of floats the kernels take."""
        return SarsaParams(float(self.alpha), float(self.epsilon), float(self.gamma), float(self.trace_decay))


class SarsaParams(NamedTuple):
    alpha: float
    epsilon: float
    gamma: float
    trace_decay: float


class SarsaMemory(NamedTuple):
    """``R`` learners (rows): V state variables, A actions, T tilings, M weights, C trace slots, L logged
    transitions."""

    weights: np.ndarray  # (W, M) float64 weight tables, start at 0
    hash_check: np.ndarray  # (W, M) int32 collision check value per slot, -1 = empty
    hash_counts: np.ndarray  # (W, 3) int64 calls, clear hits, collisions
    table: np.ndarray  # (R,) int64 the weight table (row of the three above) learner r reads and updates
    trace_slot: np.ndarray  # (R, M) int32 position of a weight in the trace list, -1 = no trace
    trace_feature: np.ndarray  # (R, C) int64 weight index of each live trace
    trace_value: np.ndarray  # (R, C) float64 its value
    n_traces: np.ndarray  # (R,) int64 live traces
    min_trace: np.ndarray  # (R,) float64 traces below this are dropped (grows if the list fills)
    tiles: np.ndarray  # (R, A, V * T) int64 active weight indices of the last state, per action
    q: np.ndarray  # (R, A) float64 Q(s, .) of the last state (Q(s, a) refreshed after an update)
    last_action: np.ndarray  # (R,) int64 action of the open SMDP step, -1 = none this episode
    last_state: np.ndarray  # (R, V) float64 the state it was taken in
    mode: np.ndarray  # (R,) int64 MODE_*
    rng: np.ndarray  # (R,) uint64 exploration and tie-breaking streams (core/rng.py)
    log_state: np.ndarray  # (R, L, V) float64 transition ring buffer: state
    log_action: np.ndarray  # (R, L) int64 action taken in it
    log_reward: np.ndarray  # (R, L) float64 reward (cycles) until the next decision or the end
    log_next_action: np.ndarray  # (R, L) int64 next action, -1 when terminal
    log_terminal: np.ndarray  # (R, L) bool
    log_count: np.ndarray  # (R,) int64 transitions ever written (the next sequence number)
    widths: np.ndarray  # (V,) float64 tile width per variable, state (task) order
    code_order: np.ndarray  # (V,) int64 state index of the C++ player's variable 0, 1, ...
    # (W, V, A, Q, T) int32: the slots of the T tiles of (code variable, action, quantised value 0..Q-1),
    # EMPTY_SLOT until hashed (load_tiles); (W, V, A, Q, 3) int64 what hashing them added to hash_counts
    memo_slots: np.ndarray
    memo_counts: np.ndarray


def code_variable_order(n_keepers: int, n_takers: int) -> np.ndarray:
    """For each variable index of the C++ state vector (`WorldModelKeepaway.cc` keeperStateVars:
    dist(K1, C), dist(K1, Ki), dist(K1, Tj), dist(Ki, C), dist(Tj, C), min dist, min angle), its index in
    ``agents.state_vars.pass_state`` (`keepaway-task.md` 3 order). 3v2: [0, 5, 6, 7, 8, 1, 2, 3, 4, 9,
    10, 11, 12]."""
    k, t = n_keepers - 1, n_takers
    centre_keepers, centre_takers = 1, 1 + k
    from_k1_keepers, from_k1_takers = 1 + k + t, 1 + 2 * k + t
    tail = 1 + 2 * k + 2 * t
    order = [0]
    order += [from_k1_keepers + i for i in range(k)]
    order += [from_k1_takers + j for j in range(t)]
    order += [centre_keepers + i for i in range(k)]
    order += [centre_takers + j for j in range(t)]
    order += [tail + i for i in range(2 * k)]
    return np.array(order, dtype=np.int64)


def _c_div(a: int, b: int) -> int:
    """C integer division (truncates towards zero)."""
    return int(a / b)


def tile_widths(config: SarsaConfig, n_keepers: int, n_takers: int) -> np.ndarray:
    """Tile width of each Pass variable in ``pass_state`` order: 3.0 m for distances and 10 deg for the
    K - 1 angles (`keepaway-task.md` 5), or with ``code_widths`` the C++ player's
    ``keeperStateRangesAndResolutions`` (integer arithmetic included: 2.0 m for dist(K1, T1) in 3v2)."""
    n = 4 * n_keepers + 2 * n_takers - 3
    angles = n_keepers - 1
    if not config.code_widths:
        return np.array([config.distance_width] * (n - angles) + [config.angle_width] * angles)
    if n_keepers < 3 or n_takers < 2:
        raise ValueError("the code's widths need at least 3 keepers and 2 takers")
    keepers = [2.0 + _c_div(i - 1, n_keepers - 2) for i in range(1, n_keepers)]
    code = [2.0] + keepers + [3.0 + _c_div(j - 1, n_takers - 1) for j in range(n_takers)]
    code += keepers + [3.0] * n_takers + [4.0] * angles + [config.angle_width] * angles
    widths = np.empty(n)
    widths[code_variable_order(n_keepers, n_takers)] = code
    return widths


def glibc_rand(seed: int, count: int) -> np.ndarray:
    """The first ``count`` results of glibc ``rand()`` after ``srand(seed)``: the TYPE_3 additive
    feedback generator r_i = r_(i-31) + r_(i-3) mod 2^32 seeded by Park-Miller, first 310 dropped,
    output r_i >> 1 (srand(1) starts 1804289383, 846930886; srand(0) is srand(1))."""
    r = [seed if seed != 0 else 1]
    for i in range(1, GLIBC_DEGREE):
        r.append(GLIBC_MULTIPLIER * r[i - 1] % GLIBC_MODULUS)
    r += r[:GLIBC_SEP]
    first = GLIBC_DEGREE + GLIBC_SEP + GLIBC_DISCARD
    while len(r) < first + count:
        r.append((r[-GLIBC_DEGREE] + r[-GLIBC_SEP]) & 0xFFFFFFFF)
    return np.array([v >> 1 for v in r[first:]], dtype=np.int64)


def unh_random_table() -> np.ndarray:
    """hash_UNH's rndseq: 2048 words, each four low bytes of successive ``rand()`` calls, big end first,
    drawn right after ``srand(0)`` (`LinearSarsaAgent.cc` constructor's dummy GetTiles call)."""
    low_bytes = (glibc_rand(0, 4 * UNH_TABLE_SIZE) & 0xFF).reshape(UNH_TABLE_SIZE, 4)
    return (low_bytes[:, 0] << 24) | (low_bytes[:, 1] << 16) | (low_bytes[:, 2] << 8) | low_bytes[:, 3]


_UNH_TABLE = unh_random_table()


@borrowing
def _unh_word(value: int, offset: int) -> int:
    """rndseq[(value + offset) mod 2048], the mod of a power of two as a mask: the mathematical mod for a
    negative tile coordinate too, as ``%`` on Python ints, without its sign branch."""
    return _UNH_TABLE[(value + offset) & (UNH_TABLE_SIZE - 1)]


@borrowing
def unh_hash(coordinate: int, tiling: int, action: int, variable: int, increment: int, m: int) -> int:
    """tiles2.cc hash_UNH of the coordinates (tile coordinate, tiling j, action a, variable v):
    sum_i rndseq[(c_i + increment * i) mod 2048] mod m. (``load_tiles`` sums the same words itself.)"""
    total = (_unh_word(coordinate, 0) + _unh_word(tiling, increment) + _unh_word(action, 2 * increment)
             + _unh_word(variable, 3 * increment))
    return total % m


@borrowing
def tile_index(hash_check, hash_counts, r: int, index_words: int, check_words: int) -> int:
    """tiles2.cc ``hash`` in safe mode on weight table ``r``'s collision table (``SarsaMemory.hash_check`` and
    ``hash_counts``, passed alone to keep this per-tile call cheap), for a tile whose ``unh_hash`` word sums
    (before the modulus) are ``index_words`` (increment INDEX_INCREMENT) and ``check_words``
    (CHECK_INCREMENT): the home slot if it is empty or holds this tile's check value, else re-probe with
    an odd stride until one does (so distinct tiles never share a weight)."""
    m = hash_check.shape[1]
    index = index_words % m
    check = check_words % MAX_LONG_INT
    hash_counts[r, HASH_CALLS] += 1
    stored = hash_check[r, index]
    if stored == check or stored == EMPTY_SLOT:
        hash_counts[r, HASH_CLEAR_HITS] += 1
        hash_check[r, index] = check
        return index
    stride = 1 + 2 * (index_words % (MAX_LONG_INT // 4))
    for _ in range(m):
        hash_counts[r, HASH_COLLISIONS] += 1
        index = (index + stride) % m
        stored = hash_check[r, index]
        if stored == check:
            return index
        if stored == EMPTY_SLOT:
            hash_check[r, index] = check
            return index
    raise RuntimeError("Sarsa weight table full (tiles2.cc: Out of Memory)")


@borrowing
def quantize(value: float, width: float, tilings: int) -> int:
    """q = floor(tilings * x), x = value / width rounded to float32 as the C++ ``float`` argument of
    GetTiles is (spec `keepaway-agents.md` 5)."""
    return int(math.floor(np.float64(np.float32(value / width)) * tilings))


@borrowing
def tiling_coordinate(q: int, tiling: int, tilings: int) -> int:
    """Coordinate of the tile of tiling j holding quantised value q: q - ((q - j) mod tilings)
    (tilings offset by 1/tilings of a tile each; spec `keepaway-agents.md` 5)."""
    return q - (q - tiling) % tilings


@borrowing
def load_tiles(mem: SarsaMemory, r: int, state) -> None:
    """The active weight indices of ``state`` for every action into ``mem.tiles[r]``, hashed in the C++
    order (variable, then action, then tiling; `LinearSarsaAgent::loadTiles`), which fixes how the
    collision table fills.

    A tile's slot never changes once hashed: the collision table only fills empty slots, so the probe
    sequence that found it finds it again after the same number of probes. So the slots of a (variable,
    action, quantised value)'s tilings, and what hashing them adds to ``hash_counts``, are remembered
    in ``mem.memo_slots`` the first time (:func:`forget_tiles` when a table is replaced) and read from
    there after: the same slots, the same counts, the same table, without the 32 scattered reads of the
    collision table (a fifth of a learned-Pass game's time)."""
    n_vars = mem.code_order.shape[0]
    tilings = mem.tiles.shape[2] // n_vars
    table = mem.table[r]
    for cv in range(n_vars):
        v = mem.code_order[cv]
        q = quantize(state[v], mem.widths[v], tilings)
        remembered = 0 <= q < mem.memo_slots.shape[3]
        for a in range(mem.tiles.shape[1]):
            if remembered and mem.memo_slots[table, cv, a, q, 0] != EMPTY_SLOT:
                for j in range(tilings):
                    mem.tiles[r, a, cv * tilings + j] = mem.memo_slots[table, cv, a, q, j]
                for c in range(3):
                    mem.hash_counts[table, c] += mem.memo_counts[table, cv, a, q, c]
                continue
            counts_before = (mem.hash_counts[table, 0], mem.hash_counts[table, 1], mem.hash_counts[table, 2])
            # unh_hash's four table words for (coordinate, j, a, cv) with each increment; the words of a
            # and cv are the same for every tiling, so they are looked up once (the sums are integers:
            # the same sums, the same slots)
            index_base = _unh_word(a, 2 * INDEX_INCREMENT) + _unh_word(cv, 3 * INDEX_INCREMENT)
            check_base = _unh_word(a, 2 * CHECK_INCREMENT) + _unh_word(cv, 3 * CHECK_INCREMENT)
            for j in range(tilings):
                coordinate_word = _unh_word(tiling_coordinate(q, j, tilings), 0)
                index = tile_index(mem.hash_check, mem.hash_counts, table,
                                   coordinate_word + _unh_word(j, INDEX_INCREMENT) + index_base,
                                   coordinate_word + _unh_word(j, CHECK_INCREMENT) + check_base)
                mem.tiles[r, a, cv * tilings + j] = index
            if remembered:  # tiling 0's slot last: it marks the group complete
                for j in range(tilings - 1, -1, -1):
                    mem.memo_slots[table, cv, a, q, j] = mem.tiles[r, a, cv * tilings + j]
                for c in range(3):
                    mem.memo_counts[table, cv, a, q, c] = mem.hash_counts[table, c] - counts_before[c]


def forget_tiles(mem: SarsaMemory, table: int) -> None:
    """Forget the slots :func:`load_tiles` remembered for weight table ``table``: for a collision table
    that was replaced rather than filled by hashing."""
    mem.memo_slots[table] = EMPTY_SLOT


@borrowing
def action_value(mem: SarsaMemory, r: int, a: int) -> float:
    """Q(s, a) = sum of the weights of a's active tiles in the loaded state."""
    total = 0.0
    table = mem.table[r]
    for f in mem.tiles[r, a]:
        total += mem.weights[table, f]
    return total


@borrowing
def load_action_values(mem: SarsaMemory, r: int) -> None:
    """Q(s, .) of the loaded state into ``mem.q[r]``."""
    for a in range(mem.q.shape[1]):
        mem.q[r, a] = action_value(mem, r, a)


@borrowing
def select_action(mem: SarsaMemory, r: int, explore: bool, sp: SarsaParams) -> int:
    """Epsilon-greedy on ``mem.q[r]`` (uniform random action with probability epsilon when ``explore``),
    argmax ties broken uniformly (reservoir draw; the C++ argmaxQ never resets its tie count, which only
    matters for 4 or more actions)."""
    n = mem.q.shape[1]
    if explore and uniform(mem.rng, r, 0.0, 1.0) < sp.epsilon:
        return randint(mem.rng, r, n)
    best, ties = 0, 1
    for a in range(1, n):
        if mem.q[r, a] > mem.q[r, best]:
            best, ties = a, 1
        elif mem.q[r, a] == mem.q[r, best]:
            ties += 1
            if randint(mem.rng, r, ties) == 0:
                best = a
    return best


@borrowing
def _drop_trace(trace_slot, trace_feature, trace_value, n_traces, r: int, slot: int) -> None:
    """Remove trace list entry ``slot`` of row ``r`` by moving the last entry into it
    (clearExistentTrace); takes the trace arrays alone to keep this per-tile call cheap."""
    trace_slot[r, trace_feature[r, slot]] = EMPTY_SLOT
    last = n_traces[r] - 1
    n_traces[r] = last
    if slot != last:
        moved = trace_feature[r, last]
        trace_feature[r, slot] = moved
        trace_value[r, slot] = trace_value[r, last]
        trace_slot[r, moved] = slot


@borrowing
def decay_traces(mem: SarsaMemory, r: int, rate: float) -> None:
    """Multiply every trace by ``rate`` and drop those below the minimum trace (rate 0 clears all)."""
    for slot in range(mem.n_traces[r] - 1, -1, -1):
        mem.trace_value[r, slot] *= rate
        if mem.trace_value[r, slot] < mem.min_trace[r]:
            _drop_trace(mem.trace_slot, mem.trace_feature, mem.trace_value, mem.n_traces, r, slot)


@borrowing
def clear_action_traces(mem: SarsaMemory, r: int, a: int) -> None:
    """Drop the traces of action ``a``'s active tiles in the loaded state."""
    for f in mem.tiles[r, a]:
        slot = mem.trace_slot[r, f]
        if slot != EMPTY_SLOT:
            _drop_trace(mem.trace_slot, mem.trace_feature, mem.trace_value, mem.n_traces, r, slot)


@borrowing
def set_action_traces(mem: SarsaMemory, r: int, a: int) -> None:
    """Replacing traces: the traces of action ``a``'s active tiles become 1 (setTrace). A full list
    raises the minimum trace by 10 % and culls until there is room (increaseMinTrace)."""
    for f in mem.tiles[r, a]:
        slot = mem.trace_slot[r, f]
        if slot != EMPTY_SLOT:
            mem.trace_value[r, slot] = 1.0
            continue
        while mem.n_traces[r] >= mem.trace_feature.shape[1]:
            mem.min_trace[r] *= MIN_TRACE_GROWTH
            decay_traces(mem, r, 1.0)
        n = mem.n_traces[r]
        mem.trace_feature[r, n] = f
        mem.trace_value[r, n] = 1.0
        mem.trace_slot[r, f] = n
        mem.n_traces[r] = n + 1


@borrowing
def update_weights(mem: SarsaMemory, r: int, delta: float, sp: SarsaParams) -> None:
    """w += (alpha / active tiles) * delta * e over the live traces."""
    step_size = delta * sp.alpha / mem.tiles.shape[2]
    table = mem.table[r]
    for slot in range(mem.n_traces[r]):
        mem.weights[table, mem.trace_feature[r, slot]] += step_size * mem.trace_value[r, slot]


@borrowing
def _keep_state(mem: SarsaMemory, r: int, state) -> None:
    """Row ``r``'s last state := ``state``, element by element (a borrowing kernel copies no slices)."""
    for v in range(state.shape[0]):
        mem.last_state[r, v] = state[v]


@borrowing
def _log_transition(mem: SarsaMemory, r: int, reward: float, next_action: int, terminal: bool) -> None:
    """Append (last state, last action, reward, next action, terminal) to row ``r``'s ring buffer."""
    slot = mem.log_count[r] % mem.log_action.shape[1]
    for v in range(mem.last_state.shape[1]):
        mem.log_state[r, slot, v] = mem.last_state[r, v]
    mem.log_action[r, slot] = mem.last_action[r]
    mem.log_reward[r, slot] = reward
    mem.log_next_action[r, slot] = next_action
    mem.log_terminal[r, slot] = terminal
    mem.log_count[r] += 1


@borrowing
def start_episode(mem: SarsaMemory, r: int, state, sp: SarsaParams) -> int:
    """startEpisode(s): clear all traces, compute Q(s, .), choose a (epsilon-greedy unless greedy mode),
    set a's traces to 1 (spec `keepaway-agents.md` 5)."""
    decay_traces(mem, r, 0.0)
    load_tiles(mem, r, state)
    load_action_values(mem, r)
    a = select_action(mem, r, mem.mode[r] != MODE_GREEDY, sp)
    mem.last_action[r] = a
    _keep_state(mem, r, state)
    set_action_traces(mem, r, a)
    return a


@borrowing
def step(mem: SarsaMemory, r: int, reward: float, state, sp: SarsaParams) -> int:
    """step(r, s') (spec `keepaway-agents.md` 5): delta = r - Q(s, a) with Q(s, a) cached after the
    previous update; compute Q(s', .) and choose a'. Learning only: delta += Q(s', a'); w += (alpha / n)
    delta e; recompute Q(s', a'); decay traces by gamma lambda; clear the traces of the other actions'
    tiles in s' and set a''s to 1. A step with no open decision this episode starts the episode."""
    a_prev = mem.last_action[r]
    if a_prev == NO_ACTION:
        return start_episode(mem, r, state, sp)
    delta = reward - mem.q[r, a_prev]
    load_tiles(mem, r, state)
    load_action_values(mem, r)
    a = select_action(mem, r, mem.mode[r] != MODE_GREEDY, sp)
    _log_transition(mem, r, reward, a, False)
    mem.last_action[r] = a
    _keep_state(mem, r, state)
    if mem.mode[r] != MODE_LEARN:
        return a
    delta += mem.q[r, a]
    update_weights(mem, r, delta, sp)
    mem.q[r, a] = action_value(mem, r, a)
    decay_traces(mem, r, sp.gamma * sp.trace_decay)
    if mem.n_traces[r] > 0:  # else nothing to clear: with the paper's lambda = 0 the decay empties the list
        for other in range(mem.tiles.shape[1]):
            if other != a:
                clear_action_traces(mem, r, other)
    set_action_traces(mem, r, a)
    return a


@borrowing
def end_episode(mem: SarsaMemory, r: int, reward: float, sp: SarsaParams) -> None:
    """endEpisode(r) (spec `keepaway-agents.md` 5): if a decision was made this episode, log the terminal
    transition and, when learning, w += (alpha / n) (r - Q(s, a)) e with no bootstrap; then forget it."""
    a = mem.last_action[r]
    if a == NO_ACTION:
        return
    _log_transition(mem, r, reward, NO_ACTION, True)
    if mem.mode[r] == MODE_LEARN:
        update_weights(mem, r, reward - mem.q[r, a], sp)
    mem.last_action[r] = NO_ACTION



def new_memory(
    config: SarsaConfig, n_keepers: int, n_takers: int, rows: int, seed: int, mode: int = MODE_LEARN
) -> SarsaMemory:
    """``rows`` fresh learners (weights 0, empty collision tables and traces) for K vs T Pass states;
    row r's exploration stream is ``seed``'s r-th child (core/rng.py). With ``config.hive_mind`` the
    rows are teams of ``n_keepers`` consecutive learners (rows k t .. k t + k - 1), each team sharing one
    weight table; else every row has its own."""
    n_vars = 4 * n_keepers + 2 * n_takers - 3
    m, log = config.table_size, config.transition_log_size
    if config.hive_mind and rows % n_keepers:
        raise ValueError(f"hive-mind learners come in teams of {n_keepers}; {rows} rows do not")
    table = np.arange(rows, dtype=np.int64) // (n_keepers if config.hive_mind else 1)
    tables = int(table[-1]) + 1 if rows else 0
    mem = SarsaMemory(
        weights=np.zeros((tables, m)),
        hash_check=np.full((tables, m), EMPTY_SLOT, dtype=np.int32),
        hash_counts=np.zeros((tables, 3), dtype=np.int64),
        table=table,
        trace_slot=np.empty((rows, m), dtype=np.int32),
        trace_feature=np.empty((rows, config.max_traces), dtype=np.int64),
        trace_value=np.empty((rows, config.max_traces)),
        n_traces=np.empty(rows, dtype=np.int64),
        min_trace=np.empty(rows),
        tiles=np.empty((rows, n_keepers, n_vars * config.tilings), dtype=np.int64),
        q=np.empty((rows, n_keepers)),
        last_action=np.empty(rows, dtype=np.int64),
        last_state=np.empty((rows, n_vars)),
        mode=np.empty(rows, dtype=np.int64),
        rng=seed_streams(seed, rows),
        log_state=np.empty((rows, log, n_vars)),
        log_action=np.empty((rows, log), dtype=np.int64),
        log_reward=np.empty((rows, log)),
        log_next_action=np.empty((rows, log), dtype=np.int64),
        log_terminal=np.empty((rows, log), dtype=np.bool_),
        log_count=np.empty(rows, dtype=np.int64),
        widths=tile_widths(config, n_keepers, n_takers),
        code_order=code_variable_order(n_keepers, n_takers),
        memo_slots=np.full((tables, n_vars, n_keepers, MEMO_VALUES, config.tilings), EMPTY_SLOT, dtype=np.int32),
        memo_counts=np.zeros((tables, n_vars, n_keepers, MEMO_VALUES, 3), dtype=np.int64),
    )
    restart_learners(mem, config, mode)  # the learners' own state, as every fresh start sets it
    return mem


def weight_snapshot(mem: SarsaMemory, r: int) -> tuple[np.ndarray, np.ndarray]:
    """Row ``r``'s non-zero weights as sparse (index, value) pairs, for reporting to the coach."""
    weights = mem.weights[mem.table[r]]
    indices = np.flatnonzero(weights)
    return indices, weights[indices].copy()


def transitions(mem: SarsaMemory, r: int, since: int = 0) -> dict[str, np.ndarray]:
    """Row ``r``'s logged SMDP transitions with sequence number >= ``since`` that are still in the ring
    buffer, oldest first. Pass the last ``sequence`` + 1 back as ``since`` to read only new ones."""
    count, size = int(mem.log_count[r]), mem.log_action.shape[1]
    sequence = np.arange(max(since, count - size, 0), count, dtype=np.int64)
    slots = sequence % size
    return {
        "sequence": sequence,
        "state": mem.log_state[r, slots],
        "action": mem.log_action[r, slots],
        "reward": mem.log_reward[r, slots],
        "next_action": mem.log_next_action[r, slots],
        "terminal": mem.log_terminal[r, slots],
    }


def policy_arrays(mem: SarsaMemory, r: int) -> dict[str, np.ndarray]:
    """Row ``r``'s learned Pass policy as policy-file arrays: the weights and the collision table state
    that maps tiles to them (the C++ weights file holds the same: weights, then collision_table::save).
    The learners of a hive mind give the same arrays."""
    table = mem.table[r]
    return {
        "pass_weights": mem.weights[table].copy(),
        "pass_hash_check": mem.hash_check[table].copy(),
        "pass_hash_counts": mem.hash_counts[table].copy(),
    }


def restart_learners(mem: SarsaMemory, config: SarsaConfig, mode: int | np.ndarray) -> None:
    """Every row of ``mem`` as fresh learners (``config``, ``mode``: one for all or one per row) into which its own
    :func:`policy_arrays` were loaded, in place: the weights, collision tables and their counts are kept;
    traces, open decisions, transition logs and the minimum trace start afresh (:func:`new_memory` sets
    them here too). The exploration streams are the caller's to seed. For learners that go on in fresh
    arenas without copying their tables out and back."""
    mem.trace_slot.fill(EMPTY_SLOT)
    mem.trace_feature.fill(0)
    mem.trace_value.fill(0.0)
    mem.n_traces.fill(0)
    mem.min_trace.fill(config.min_trace)
    mem.tiles.fill(0)
    mem.q.fill(0.0)
    mem.last_action.fill(NO_ACTION)
    mem.last_state.fill(0.0)
    mem.mode[:] = mode
    for log in (mem.log_state, mem.log_action, mem.log_reward, mem.log_next_action, mem.log_terminal,
                mem.log_count):
        log.fill(0)


def load_policy_arrays(mem: SarsaMemory, r: int, arrays: dict[str, np.ndarray]) -> None:
    """Restore row ``r``'s weight table from ``policy_arrays`` output (same table size); traces and the
    open decision are cleared, as after the C++ loadWeights, for every learner of the table (a hive
    mind's other keepers' traces would point into the weights just replaced)."""
    table = mem.table[r]
    for name, target in (("pass_weights", mem.weights), ("pass_hash_check", mem.hash_check),
                         ("pass_hash_counts", mem.hash_counts)):
        value = np.asarray(arrays[name])
        if value.shape != target.shape[1:]:
            raise ValueError(f"{name}: shape {value.shape}, this learner needs {target.shape[1:]}")
        target[table] = value
    forget_tiles(mem, table)
    team = mem.table == table
    mem.trace_slot[team] = EMPTY_SLOT
    mem.n_traces[team] = 0
    mem.last_action[team] = NO_ACTION


class SarsaLearner:
    """One keeper's Pass learner (a keeper process owns one): the C++ SMDPAgent interface
    ``start(state)``, ``step(reward, state)``, ``end(reward)`` over a one-row ``SarsaMemory``."""

    def __init__(
        self,
        n_keepers: int = 3,
        n_takers: int = 2,
        config: SarsaConfig = SarsaConfig(),
        seed: int = 0,
        mode: int = MODE_LEARN,
    ) -> None:
        self.config = config
        self.params = config.kernel()
        # alone in its process, a keeper's learner has a table of its own even if its policy was learned
        # by a hive mind (whose keepers' tables are copies of one another)
        self.memory = new_memory(replace(config, hive_mind=False), n_keepers, n_takers, 1, seed, mode)

    @property
    def mode(self) -> int:
        return int(self.memory.mode[0])

    @mode.setter
    def mode(self, mode: int) -> None:
        """Switch learn / greedy / explore; only between episodes (spec `keepaway-agents.md` 5)."""
        if mode not in (MODE_LEARN, MODE_GREEDY, MODE_EXPLORE):
            raise ValueError(f"unknown Sarsa mode {mode}")
        if self.memory.last_action[0] != NO_ACTION:
            raise RuntimeError("the Sarsa mode can only change between episodes")
        self.memory.mode[0] = mode

    def reseed(self, seed: int) -> None:
        """Restart the exploration stream as a learner constructed with ``seed`` starts it (a coach's
        ``seed`` advice, docs/advice.md); the weights, collision table and mode are kept."""
        self.memory.rng[:] = seed_streams(seed, 1)

    def start(self, state: np.ndarray) -> int:
        return int(start_episode(self.memory, 0, np.asarray(state, dtype=np.float64), self.params))

    def step(self, reward: float, state: np.ndarray) -> int:
        return int(step(self.memory, 0, float(reward), np.asarray(state, dtype=np.float64), self.params))

    def end(self, reward: float) -> None:
        end_episode(self.memory, 0, float(reward), self.params)

    def q_values(self) -> np.ndarray:
        """Q(s, .) of the last state seen."""
        return self.memory.q[0].copy()

    def snapshot(self) -> tuple[np.ndarray, np.ndarray]:
        return weight_snapshot(self.memory, 0)

    def transitions(self, since: int = 0) -> dict[str, np.ndarray]:
        return transitions(self.memory, 0, since)

    def save(self) -> dict[str, np.ndarray]:
        return policy_arrays(self.memory, 0)

    def load(self, arrays: dict[str, np.ndarray]) -> None:
        load_policy_arrays(self.memory, 0, arrays)


__all__ = [
    "MODE_EXPLORE",
    "MODE_GREEDY",
    "MODE_LEARN",
    "NO_ACTION",
    "SarsaConfig",
    "SarsaLearner",
    "SarsaMemory",
    "SarsaParams",
    "action_value",
    "clear_action_traces",
    "code_variable_order",
    "end_episode",
    "forget_tiles",
    "glibc_rand",
    "load_policy_arrays",
    "load_tiles",
    "new_memory",
    "policy_arrays",
    "quantize",
    "restart_learners",
    "select_action",
    "set_action_traces",
    "start_episode",
    "step",
    "tile_index",
    "tile_widths",
    "tiling_coordinate",
    "transitions",
    "unh_hash",
    "unh_random_table",
    "weight_snapshot",
]

"""The batched mode: many Keepaway arenas, each with five full noisy players, stepped in one process.

The same simulator core and the same agent kernels as the distributed mode, composed in one numba loop
over arenas. Per arena and cycle, in the distributed server's synchronous order (``server/app.py``
``_run_sync``, ``server/arena.py``):

1. percepts of every player, in object order: sense_body; the referee's episode message
   (`training Keepaway 1`, heard in the first cycle of a new episode) -> world-model forget and
   ``forget_episode``; the see when due (``see_due``: phase 0 for players connected before the start,
   2 sees per 3 cycles at normal width), written from the server's :class:`SeeBuffers` row straight into
   the world model's :class:`SeeBuffer` row (:func:`see_to_model_row`, the same numbers the wire carries);
2. the decision (``keeper_decide`` / ``taker_decide``) on the player's belief row;
3. its commands into the server's :class:`Commands` (with the server's slot rule for kicks out of reach)
   and into the world model as the commands it sent (``agents.tracking.sent_row``);
4. the step (``server.simulation.step_arena``).

Python runs only between chunks of cycles, to collect the episodes that ended. Randomness: arena ``b``
of a batch seeded ``seed`` plays the game of a single arena seeded ``seed + b`` (:func:`arena_seed`):
its server stream is the one the distributed server draws with that seed, and each player's stream is
derived from it, its side and uniform number as a player process derives it (:func:`agent_seed`). So
an arena's episodes depend neither on the batch size nor on the thread that steps it, and equal those
of the embedded game (``tests/test_batched.py``).

Every arena plays its own policies (:class:`ArenaPolicies`: its players' agent-config record, with its
Pass and GetOpen policy codes, and its learners' step size and rows), so arenas of different
configurations share a batch. Pass learning (``pass_policy="learned"``,
docs/players.md §6.3): every keeper of every such arena owns one row of an ``agents.sarsa.SarsaMemory``
(rows ``l * K .. l * K + K - 1`` for the keepers of the l-th learning arena: its own weights, as in the
original, where each keeper process learns alone).
At ``keeper_decide``'s external decision points (``PASS_EXTERNAL``, ``agents.belief.Decisions``
``decision``/``pass_state``) the row starts its episode or steps with reward = cycles since the keeper's
last kicking cycle (``time - t_last``; docs/players.md §2 step 3b), and the keeper executes the action; when an
episode ends, every keeper that decided in it gets the terminal update with reward = first cycle of the
new episode - its ``t_last`` (the cycle in which a player process hears the referee; docs/players.md §6.3), keepers
that never had the ball none. All of it runs inside the compiled chunk loop. A learner row draws its
exploration from the stream a player process's learner gets (:func:`learner_seed`), so a learning arena
of the batched mode learns the very weights of the embedded game with learning players
(``tests/test_batched_learning.py``).

The Sarsa mode (learn / greedy / explore) is per arena and changes only at an episode start
(:meth:`BatchedArenas.set_pass_mode`), like the coach's ``pass_mode`` advice to a player process. The
weight table defaults to 2^16 slots per keeper (``runner.job.BATCHED_SARSA``), not the original 2^20: a 3v2
keeper touches some 15,000 distinct tiles (13 variables x 3 actions x 32 tilings x ~12 coordinates), so
2^16 holds them with few re-probes (the table is collision-safe: distinct tiles never share a weight),
while 2^20 would cost 18 MB per keeper, 55 GB for 1024 arenas. At 2^16 a keeper costs ~1.1 MB (weights
8 B, collision check 4 B and trace slot 4 B per slot, plus 4,096 trace entries and a 64-transition log),
~3.3 GB for 1024 arenas of 3 keepers; learn with up to a few hundred arenas, or a smaller table.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numba
import numpy as np

from keepaway.agents.belief import (
    AgentMemory,
    Belief,
    Decisions,
    empty_belief,
    forget_episode,
    new_decisions,
    new_memory,
)
from keepaway.agents.config import GETOPEN_POLICIES, PASS_EXTERNAL, PASS_POLICIES, AgentConfig
from keepaway.agents.frames import NO_SIDE, SIDE_CODES
from keepaway.agents.getopen import net_size
from keepaway.agents.interception import decay_sums
from keepaway.agents.keeper import NO_PASS_DECISION, PASS_DECISION_START, execute_pass_action
from keepaway.agents.player import agent_seed_sequence
from keepaway.agents.player import learner_seed as player_learner_seed
from keepaway.agents.sarsa import (
    MODE_NAMES,
    SarsaConfig,
    SarsaMemory,
    SarsaParams,
    end_episode,
    load_policy_arrays,
    policy_arrays,
    restart_learners,
    start_episode,
)
from keepaway.agents.sarsa import (
    new_memory as new_sarsa_memory,
)
from keepaway.agents.sarsa import (
    step as sarsa_step,
)
from keepaway.agents.say import Talk, new_talk
from keepaway.agents.state_vars import getopen_state_size, pass_state_size
from keepaway.agents.think import commit_row, decide_row
from keepaway.agents.tracking import (
    ModelState,
    SeeBuffer,
    forget_row,
    new_model_state,
    new_see_buffer,
    see_row,
    sense_body_row,
)
from keepaway.core.jit import borrowing
from keepaway.core.objects import BALL, CMD_KICK, CMD_NONE
from keepaway.core.rng import seed_streams
from keepaway.protocol.landmarks import FLAG_POSITIONS, N_FLAGS
from keepaway.protocol.params import ServerParams
from keepaway.runner.job import BATCHED_SARSA, EpisodeTable
from keepaway.server.arena import PlayerSlot
from keepaway.server.command_slots import take_main, take_neck, take_say
from keepaway.server.perception import (
    FULL,
    PARTIAL,
    UNSEEN,
    SeeBuffers,
    SenseBodyBuffers,
    cone_factor,
    hear_picks,
    see_arena,
    see_due,
    sense_body_arena,
)
from keepaway.server.referee import END_NONE, RefereeState, new_referee_state, start_game
from keepaway.server.simulation import step_arena
from keepaway.server.world import Commands, World, new_world, player_unum

# The learner memory of arenas without Pass learning: no rows (kernels never touch it).
_NO_LEARNERS = SarsaConfig(table_size=2, max_traces=1, transition_log_size=1)
# Cycles per compiled call: Python collects the ended episodes and checks the stop rules in between.
CHUNK_CYCLES = 100
# The view mode of the players (the server's default for a new connection, never changed by them).
VIEW_WIDTH = "normal"
_UNLIMITED = -1
_SIDE_KEEPERS = SIDE_CODES["l"]
_SIDE_TAKERS = SIDE_CODES["r"]


def arena_seed(seed: int, b: int) -> int:
    """The seed of arena ``b`` of a batch seeded ``seed``: it plays the game a single arena (batched with
    batch 1, or the distributed server) started with this seed would play."""
    return int(seed) + b


def agent_seed(seed: int, obj: int, n_keepers: int) -> np.uint64:
    """The random stream of player object ``obj`` of the arena seeded ``seed`` (its exploration and
    random policies; docs/advice.md §2, "seed"): the player process's own derivation
    (``agents/player.py``, ``SeedSequence([seed, side, unum])``, side 0 keepers, 1 takers)."""
    side, unum = (_SIDE_KEEPERS, obj) if obj <= n_keepers else (_SIDE_TAKERS, obj - n_keepers)
    return agent_seed_sequence(seed, side, unum).generate_state(1, dtype=np.uint64)[0]


def learner_seed(seed: int, keeper: int) -> int:
    """The seed of the Pass learner of keeper ``keeper`` (uniform number) in the arena seeded ``seed``: a
    player process's (``agents/player.py``: the first child of ``SeedSequence([seed, 0, unum])``, whose
    first word seeds its ``SarsaLearner``)."""
    return player_learner_seed(agent_seed_sequence(seed, _SIDE_KEEPERS, keeper).spawn(1)[0])


class Players(NamedTuple):
    """Every player of every arena, one row each: row ``b * P + p`` is player object ``p + 1`` of arena
    ``b`` (``P = K + T`` players per arena). Updated in place by the kernels."""

    model: ModelState
    see: SeeBuffer
    belief: Belief  # the belief of the last decision
    memory: AgentMemory
    out: Decisions  # each row's last decision (agents/belief.py)
    talk: Talk  # say and hear (agents/say.py)
    decay_sums: np.ndarray  # the travel simulations' table (agents.interception.decay_sums), one for all rows
    hear_scratch: np.ndarray  # (2, rows) int64: deliver_says' speakers and picks, in each arena's columns


class ArenaPolicies(NamedTuple):
    """What each arena's keepers play, one entry per arena, so arenas of different configurations share
    a batch (and its threads)."""

    cfg: np.ndarray  # (B,) agents.config.AgentConfig.kernel() records, each with its arena's policy codes
    alpha: np.ndarray  # (B,) float64 the Sarsa step size of its Pass learners
    learner: np.ndarray  # (B,) int64 the Sarsa row of its keeper 1 (keeper k: + k - 1); -1: no Pass learners


class Bookkeeping(NamedTuple):
    """Per-arena run state and the episodes that ended in the last chunk (at most one per cycle)."""

    episode_message: np.ndarray  # (B,) bool: the referee's episode message is due in the next percepts
    pass_mode: np.ndarray  # (B,) int64 Sarsa MODE_* the arena's keepers take up at their next episode start
    active: np.ndarray  # (B,) bool: the arena still runs in this call
    episodes_left: np.ndarray  # (B,) int64 episodes to run in this call, -1 unlimited
    stop_cycle: np.ndarray  # (B,) int64 cycle at which the arena stops in this call, -1 unlimited
    stepped: np.ndarray  # (B,) int64 cycles simulated in the last chunk
    n_ended: np.ndarray  # (B,) int64 episodes ended in the last chunk
    episode: np.ndarray  # (B, CHUNK_CYCLES) int64 their numbers
    start_cycle: np.ndarray  # (B, CHUNK_CYCLES) int64
    end_cycle: np.ndarray  # (B, CHUNK_CYCLES) int64
    end: np.ndarray  # (B, CHUNK_CYCLES) int8 END_OUT / END_TAKEN


# --------------------------------------------------------------------------------------------------
# kernels


@borrowing
def see_to_model_row(out: SeeBuffers, b: int, obs: int, cycle: int, n_keepers: int, see: SeeBuffer,
                     row: int) -> None:
    """Observer ``obs``'s see of arena ``b`` as the world model's see row ``row``: what
    ``see_payload`` puts on the wire and ``WorldModel.on_see`` unpacks, without the wire. Flags with an
    id (PARTIAL, FULL) in slot order; the ball; every seen player in slot order, its side if PARTIAL or
    FULL, its unum and facing if FULL; omitted fields NaN (docs/rules.md §5.2)."""
    p = obs - 1
    n_flags = 0
    for slot in range(N_FLAGS):
        level = out.level[b, p, slot]
        if level == PARTIAL or level == FULL:
            see.flag_id[row, n_flags] = slot
            see.flag_obs[row, n_flags, 0] = out.dist[b, p, slot]
            see.flag_obs[row, n_flags, 1] = out.direction[b, p, slot]
            n_flags += 1
    see.n_flags[row] = n_flags
    ball = N_FLAGS + BALL
    see.ball_seen[row] = out.level[b, p, ball] != UNSEEN
    if see.ball_seen[row]:
        see.ball_obs[row, 0] = out.dist[b, p, ball]
        see.ball_obs[row, 1] = out.direction[b, p, ball]
        see.ball_obs[row, 2] = out.dist_chg[b, p, ball]
        see.ball_obs[row, 3] = out.dir_chg[b, p, ball]
    n_players = 0
    for slot in range(ball + 1, out.level.shape[2]):
        level = out.level[b, p, slot]
        if level == UNSEEN or n_players == see.player_obs.shape[1]:
            continue
        i = slot - N_FLAGS
        keeper = i <= n_keepers
        see.player_side[row, n_players] = NO_SIDE
        if level == PARTIAL or level == FULL:
            see.player_side[row, n_players] = _SIDE_KEEPERS if keeper else _SIDE_TAKERS
        see.player_unum[row, n_players] = 0
        obs_row = see.player_obs[row, n_players]
        obs_row[0] = out.dist[b, p, slot]
        obs_row[1] = out.direction[b, p, slot]
        obs_row[2] = out.dist_chg[b, p, slot]
        obs_row[3] = out.dir_chg[b, p, slot]
        obs_row[4] = np.nan
        obs_row[5] = np.nan
        if level == FULL:
            see.player_unum[row, n_players] = player_unum(i, n_keepers)
            obs_row[4] = out.body_dir[b, p, slot]
            obs_row[5] = out.head_dir[b, p, slot]
        n_players += 1
    see.n_players[row] = n_players
    see.cycle[row] = cycle


@borrowing(inline="always")
def perceive(b: int, obs: int, row: int, w: World, with_see: bool, episode_message: bool, cone: float, kp, cfg,
             pl: Players, see_out: SeeBuffers, body_out: SenseBodyBuffers) -> None:
    """Player ``obs``'s percepts of this cycle into its world-model row, in the server's order
    (sense_body, hears, see; ``server.arena.Arena.cycle_frames``)."""
    p = obs - 1
    cycle = w.time[b]
    sense_body_arena(b, w, obs, body_out)
    # an int64 head angle, as a player process passes it: one compiled sense_body_row for both (numba compiles
    # a kernel again for each new argument type; docs/design.md, "One version per type")
    sense_body_row(row, pl.model, cycle, body_out.speed[b, p], float(body_out.speed_dir[b, p]),
                   np.int64(body_out.head_angle[b, p]), body_out.stamina[b, p], body_out.effort[b, p], w.n_keepers,
                   kp, cfg)
    if episode_message:
        forget_row(row, pl.model)
        forget_episode(pl.memory, row)
    if with_see:
        see_arena(b, w, obs, cone, kp, see_out)
        see_to_model_row(see_out, b, obs, cycle, w.n_keepers, pl.see, row)
        see_row(row, pl.model, pl.see, FLAG_POSITIONS, w.n_keepers, kp, cfg)


@borrowing(inline="always")
def learn_pass(learner: int, obs: int, row: int, kp, cfg, pl: Players, sarsa: SarsaMemory, sp) -> None:
    """Keeper ``obs``'s Pass decision point (``keeper_decide`` returned PASS_DECISION_*): its learner row
    (``learner``: its arena's keeper 1's row, :class:`ArenaPolicies`) starts its episode or steps with
    reward = now - t_last (cycles since its last kicking cycle, docs/players.md §2 step 3b), and
    the keeper executes the chosen action."""
    out = pl.out
    r = learner + obs - 1
    if out.decision[row] == PASS_DECISION_START:
        action = start_episode(sarsa, r, out.pass_state[row], sp)
    else:
        reward = float(pl.belief.time[row] - pl.memory.t_last[row])  # float64, as a player process's learner
        action = sarsa_step(sarsa, r, reward, out.pass_state[row], sp)
    execute_pass_action(pl.belief, row, pl.memory, action, kp, cfg, out)


@borrowing(inline="always")
def end_pass_episodes(b: int, learner: int, w: World, pl: Players, sarsa: SarsaMemory, sp) -> None:
    """The episode of arena ``b`` (its keepers' learner rows from ``learner`` on) ended: each keeper that
    decided in it gets its terminal update with reward = the new episode's first cycle (``w.time`` after
    the step, when a player process hears the referee) - its last kicking cycle
    (docs/players.md §2 step 1, §6.3); ``end_episode`` skips keepers that never had the ball."""
    for p in range(w.n_keepers):
        row = b * (w.pos.shape[1] - 1) + p
        end_episode(sarsa, learner + p, float(w.time[b] - pl.memory.t_last[row]), sp)


@borrowing(inline="always")
def decide(b: int, obs: int, row: int, w: World, c: Commands, theta: np.ndarray, kp, cfg, learner: int,
           pl: Players, sarsa: SarsaMemory, sp) -> None:
    """Player ``obs``'s decision on its belief, sent as the player process sends it (``agents/player.py``:
    the main command and always a turn_neck) into the server's slots by the server's rules
    (``server.command_slots``: a kick that cannot reach the ball does not take the main slot unless
    ``failed_kick_uses_slot``) and
    remembered by its world model as sent (``agents.tracking.sent_row``): the steps of a player process's
    think (``agents.think``: ``decide_row``, ``commit_row``) around the slots. With PASS_EXTERNAL the
    keeper's Pass decisions come from its Sarsa row (:func:`learn_pass`; ``learner``: the arena's
    keeper 1's)."""
    out = pl.out
    decision = decide_row(row, True, pl.model, pl.talk, pl.belief, pl.memory, theta, pl.decay_sums, kp, cfg,
                          obs <= w.n_keepers, out)
    if decision != NO_PASS_DECISION and int(cfg.pass_policy) == PASS_EXTERNAL:
        learn_pass(learner, obs, row, kp, cfg, pl, sarsa, sp)
    code = np.int64(out.main[row])  # int64, as a player process's think passes it on to its say
    c.main[b, obs] = CMD_NONE  # the slots as the server's step leaves them (the batched step keeps them)
    c.arg1[b, obs] = 0.0
    c.arg2[b, obs] = 0.0
    c.has_neck[b, obs] = False
    take_main(b, c, obs, code, out.arg1[row], out.arg2[row] if code == CMD_KICK else 0.0, w, kp)  # dash, turn: 1
    take_neck(b, c, obs, out.neck[row])
    commit_row(row, pl.model, code, out.arg1[row], out.arg2[row], out.neck[row], w.n_keepers, kp, cfg, pl.talk)
    if pl.talk.said_len[row] > 0:
        take_say(b, obs, w)


@borrowing
def deliver_says(b: int, w: World, talk: Talk, kp, scratch: np.ndarray) -> None:
    """After the step, who heard which of this cycle's says, as the server delivers them
    (``server.arena.Arena``: a say longer than say_msg_size is dropped, the rest go through
    ``hear_picks``); a teammate's message becomes the listener's last heard one (an opponent's is drawn
    for but ignored, as the players ignore it). ``scratch``: (2, rows) int64, the speakers and the picks
    of arena ``b`` in its rows' columns (``Players.hear_scratch``)."""
    n_players = w.pos.shape[1] - 1
    base = b * n_players
    said = scratch[0, base:base + n_players]
    n = 0
    for p in range(n_players):
        if 0 < talk.said_len[base + p] <= kp.say_msg_size:
            said[n] = p + 1
            n += 1
    if n == 0:
        return
    speakers = said[:n]
    picks = scratch[1, base:base + n]
    for listener in range(1, n_players + 1):
        keeper = listener <= w.n_keepers
        for i in range(hear_picks(b, w, speakers, listener, kp.hear_max, kp.audio_cut_dist, picks)):
            speaker = speakers[picks[i]]
            if (speaker <= w.n_keepers) != keeper:
                continue
            src, dst = base + speaker - 1, base + listener - 1
            for j in range(talk.said.shape[1]):  # element by element: a slice copy would allocate
                talk.heard[dst, j] = talk.said[src, j]
            talk.heard_len[dst] = talk.said_len[src]
            talk.heard_new[dst] = True


@borrowing(inline="always")
def arena_cycle(b: int, w: World, c: Commands, ref: RefereeState, theta: np.ndarray, kp, cfg, learner: int,
                pl: Players, sarsa: SarsaMemory, sp, see_out: SeeBuffers, body_out: SenseBodyBuffers,
                episode_message: bool, see_period_ms: float, cone: float) -> int:
    """One synchronous cycle of arena ``b`` (its players' configuration ``cfg``, its keepers' learner rows
    from ``learner`` on): every player perceives, decides and sends its commands, then the step; returns
    the referee's end code (module docstring)."""
    n_players = w.pos.shape[1] - 1
    with_see = see_due(w.time[b], kp.simulator_step_ms, see_period_ms, 0.0)
    for p in range(n_players):
        obs = p + 1
        row = b * n_players + p
        perceive(b, obs, row, w, with_see, episode_message, cone, kp, cfg, pl, see_out, body_out)
        decide(b, obs, row, w, c, theta, kp, cfg, learner, pl, sarsa, sp)
    cause = step_arena(b, w, c, ref, kp)
    deliver_says(b, w, pl.talk, kp, pl.hear_scratch)
    return cause


@borrowing(nogil=True)
def run_chunk(first: int, stride: int, n_cycles: int, w: World, c: Commands, ref: RefereeState,
              theta: np.ndarray, kp, policies: ArenaPolicies, pl: Players, sarsa: SarsaMemory, sp,
              see_out: SeeBuffers, body_out: SenseBodyBuffers, book: Bookkeeping, see_period_ms: float,
              cone: float) -> None:
    """Up to ``n_cycles`` cycles of every active arena ``first, first + stride, ...``, each playing its
    own ``policies`` entry, recording ended episodes in ``book``. An arena stops after its last episode or
    at its stop cycle. An arena's Pass learners (if any) learn with its own step size (the rest of ``sp``
    is the batch's), take up ``book.pass_mode`` at each episode start and get their terminal updates at
    each end (module docstring). Arenas share no state, so disjoint sets of them run on parallel threads
    (the GIL is released)."""
    n_keepers = w.n_keepers
    for b in range(first, w.pos.shape[0], stride):
        book.stepped[b] = 0
        book.n_ended[b] = 0
        cfg = policies.cfg[b]
        learner = policies.learner[b]
        arena_sp = SarsaParams(policies.alpha[b], sp.epsilon, sp.gamma, sp.trace_decay)
        for _ in range(n_cycles):
            if not book.active[b]:
                break
            if learner >= 0 and book.episode_message[b]:
                sarsa.mode[learner:learner + n_keepers] = book.pass_mode[b]
            cause = arena_cycle(b, w, c, ref, theta[b], kp, cfg, learner, pl, sarsa, arena_sp, see_out, body_out,
                                book.episode_message[b], see_period_ms, cone)
            book.stepped[b] += 1
            book.episode_message[b] = cause != END_NONE
            if cause != END_NONE:
                if learner >= 0:
                    end_pass_episodes(b, learner, w, pl, sarsa, arena_sp)
                k = book.n_ended[b]
                book.episode[b, k] = ref.episode[b] - 1
                book.start_cycle[b, k] = ref.last_start_cycle[b]
                book.end_cycle[b, k] = ref.end_cycle[b]
                book.end[b, k] = cause
                book.n_ended[b] = k + 1
                if book.episodes_left[b] > 0:
                    book.episodes_left[b] -= 1
                    if book.episodes_left[b] == 0:
                        book.active[b] = False
            if book.stop_cycle[b] >= 0 and w.time[b] >= book.stop_cycle[b]:
                book.active[b] = False


@borrowing
def _start_games(w: World, ref: RefereeState, kp) -> None:
    for b in range(w.pos.shape[0]):
        start_game(b, w, ref, kp)


# --------------------------------------------------------------------------------------------------
# the Python surface


def _policy_code(table: dict[str, int], name: str, what: str) -> int:
    try:
        return table[name]
    except KeyError:
        raise ValueError(f"unknown {what} {name!r}; choose one of {', '.join(table)}") from None


def _per_arena(value, batch: int, what: str) -> list:
    """``value`` for every arena: one for all (a str or a number) or a sequence of ``batch``."""
    if isinstance(value, (str, int, float, np.number)):
        return [value] * batch
    values = list(value)
    if len(values) != batch:
        raise ValueError(f"give one {what} or {batch} (one per arena), not {len(values)}")
    return values


def episode_shares(episodes: int, arenas: int) -> np.ndarray:
    """``episodes`` shared out among ``arenas``: ``episodes // arenas`` each plus one in the first
    ``episodes % arenas`` (fixed quotas, :meth:`BatchedArenas.run`)."""
    return episodes // arenas + (np.arange(arenas) < episodes % arenas)


class BatchedArenas:
    """``batch`` Keepaway arenas (``keepers`` vs ``takers``, every player connected before the start),
    stepped together by compiled kernels. ``seed``: arena b plays the game of one arena seeded
    ``seed + b`` (:func:`arena_seed`), or a sequence gives every arena its own seed, so that arenas of
    unrelated jobs (other trials, other candidates, other configurations) can share one batch.
    ``pass_policy`` and ``getopen_policy`` are one name for every arena or one per arena: an arena plays
    as it would in a batch of its own policies. ``getopen_theta`` is the GO:L net per arena ((batch, n) or
    (n,) for all; n = 91 in 3v2; the rows of other arenas are not read), required with a learned GetOpen
    only. ``threads`` (default numba's thread count, ``NUMBA_NUM_THREADS``) step disjoint sets of arenas
    side by side; the results do not depend on it. The games continue across :meth:`run` calls.

    An arena of ``pass_policy="learned"``: each of its keepers learns its own Pass policy by SMDP Sarsa
    (module docstring) with the constants and sizes of ``sarsa`` (default ``runner.job.BATCHED_SARSA``) and
    the arena's step size ``alpha`` (one for all or one per arena; default ``sarsa``'s), from zero weights,
    in the arena's ``pass_mode`` (a name of :data:`agents.sarsa.MODE_NAMES`, one or one per arena) until
    :meth:`set_pass_mode` says otherwise; or, with ``learners`` (another batch's ``sarsa``, the same shape and
    Sarsa configuration: as many learning arenas), each keeper goes on from the weights of the learner in its
    place there, as if they had been copied out and loaded (:meth:`pass_policy_arrays`,
    :meth:`load_pass_arrays`) without the copies: the arenas of a learning job's next chunk take over the
    last chunk's tables. The learner rows are the learning arenas' keepers, in arena order
    (:attr:`learner_arenas`).
    Arenas learn independently: a trainer that wants more experience per policy picks the best row
    (:meth:`pass_policy_arrays`) and shares it with :meth:`load_pass_arrays`. Averaging weights is only
    meaningful between rows whose collision tables agree (the tile -> slot map depends on the order in
    which tiles were first met), e.g. rows that all started from one loaded policy."""

    def __init__(self, params: ServerParams, batch: int, seed: int | Sequence[int], keepers: int = 3, takers: int = 2,
                 pass_policy: str | Sequence[str] = "handcoded", getopen_policy: str | Sequence[str] = "handcoded",
                 getopen_theta: np.ndarray | None = None, agent_config: AgentConfig = AgentConfig(),
                 threads: int | None = None, sarsa: SarsaConfig | None = None,
                 pass_mode: str | Sequence[str] = "learn", learners: SarsaMemory | None = None,
                 alpha: float | Sequence[float] | None = None) -> None:
        if batch < 1:
            raise ValueError("batch must be at least 1")
        passes = [_policy_code(PASS_POLICIES, name, "Pass policy")
                  for name in _per_arena(pass_policy, batch, "Pass policy")]
        getopens = [_policy_code(GETOPEN_POLICIES, name, "GetOpen policy")
                    for name in _per_arena(getopen_policy, batch, "GetOpen policy")]
        modes = [_policy_code(MODE_NAMES, name, "Sarsa mode") for name in _per_arena(pass_mode, batch, "Sarsa mode")]
        learning = np.array(passes) == PASS_POLICIES["learned"]
        self.learning = bool(learning.any())
        if sarsa is not None and not self.learning:
            raise ValueError("a Sarsa configuration needs pass_policy='learned'")
        self.threads = max(1, min(batch, numba.config.NUMBA_NUM_THREADS if threads is None else threads))
        self.params = params
        self.kp = params.kernel()
        # arena 0's record; the arenas differ in their policy codes only (self.policies.cfg)
        self.cfg = dataclasses.replace(agent_config, pass_policy=passes[0], getopen_policy=getopens[0]).kernel()
        self.theta = self._thetas(getopen_theta, GETOPEN_POLICIES["learned"] in getopens, batch, keepers, takers)
        seeds = [arena_seed(seed, b) for b in range(batch)] if isinstance(seed, (int, np.integer)) else list(seed)
        if len(seeds) != batch:
            raise ValueError(f"give one seed or {batch} (one per arena), not {len(seeds)}")
        self.sarsa_config = (sarsa or BATCHED_SARSA) if self.learning else _NO_LEARNERS
        self.sarsa_params = self.sarsa_config.kernel()
        self.learner_arenas = np.flatnonzero(learning)
        self.policies = ArenaPolicies(
            cfg=np.array([dataclasses.replace(agent_config, pass_policy=p, getopen_policy=g).kernel()
                          for p, g in zip(passes, getopens)], dtype=self.cfg.dtype),
            alpha=np.array(_per_arena(self.sarsa_config.alpha if alpha is None else alpha, batch, "step size"),
                           dtype=np.float64),
            learner=np.full(batch, -1, dtype=np.int64),
        )
        self.policies.learner[self.learner_arenas] = np.arange(len(self.learner_arenas)) * keepers
        learner_modes = np.repeat(np.array(modes, dtype=np.int64)[self.learner_arenas], keepers)
        if learners is None:
            self.sarsa = new_sarsa_memory(self.sarsa_config, keepers, takers, len(learner_modes), seeds[0])
            self.sarsa.mode[:] = learner_modes
        else:
            self.sarsa = self._go_on_with(learners, learner_modes)
        self.sarsa.rng[:] = [seed_streams(learner_seed(seeds[b], k), 1)[0] for b in self.learner_arenas
                             for k in range(1, keepers + 1)]
        self.world = new_world(params, keepers, takers, batch=batch)
        self.world.rng[:] = [seed_streams(s, 1)[0] for s in seeds]
        self.world.enabled[:] = True
        n_objects = self.world.n_objects
        n_players = n_objects - 1
        rows = batch * n_players
        self.commands = Commands.empty(batch, n_objects)
        self.referee = new_referee_state(batch)
        self.see_out = SeeBuffers.empty(batch, n_objects, params.kernel())
        self.body_out = SenseBodyBuffers.empty(batch, n_objects)
        me = np.tile(np.arange(1, n_objects), batch)
        self.players = Players(
            model=new_model_state(rows, keepers, takers, me, params),
            see=new_see_buffer(rows, N_FLAGS, n_objects),
            belief=empty_belief(rows, keepers, takers),
            memory=new_memory(rows, np.array([agent_seed(s, obj, keepers) for s in seeds
                                              for obj in range(1, n_objects)], dtype=np.uint64)),
            out=new_decisions(rows, pass_state_size(keepers, takers)),
            talk=new_talk(rows),
            decay_sums=decay_sums(self.kp, self.cfg),
            hear_scratch=np.zeros((2, rows), dtype=np.int64),
        )
        self.book = Bookkeeping(
            episode_message=np.zeros(batch, dtype=np.bool_),
            pass_mode=np.array(modes, dtype=np.int64),
            active=np.zeros(batch, dtype=np.bool_),
            episodes_left=np.zeros(batch, dtype=np.int64),
            stop_cycle=np.zeros(batch, dtype=np.int64),
            stepped=np.zeros(batch, dtype=np.int64),
            n_ended=np.zeros(batch, dtype=np.int64),
            episode=np.zeros((batch, CHUNK_CYCLES), dtype=np.int64),
            start_cycle=np.zeros((batch, CHUNK_CYCLES), dtype=np.int64),
            end_cycle=np.zeros((batch, CHUNK_CYCLES), dtype=np.int64),
            end=np.zeros((batch, CHUNK_CYCLES), dtype=np.int8),
        )
        slot = PlayerSlot(obj=1, side="l", unum=1, view_width=VIEW_WIDTH)
        self.see_period_ms = slot.see_period_ms(params.send_step_ms)
        self.cone = cone_factor(VIEW_WIDTH, slot.synch_see)
        _start_games(self.world, self.referee, self.kp)

    @staticmethod
    def _thetas(theta: np.ndarray | None, needed: bool, batch: int, keepers: int, takers: int) -> np.ndarray:
        n = net_size(getopen_state_size(keepers, takers))
        if theta is None:
            if needed:
                raise ValueError("the learned GetOpen policy needs getopen_theta")
            return np.zeros((batch, n))
        theta = np.asarray(theta, dtype=np.float64)
        if theta.shape not in ((n,), (batch, n)):
            raise ValueError(f"getopen_theta must have shape ({n},) or ({batch}, {n}), not {theta.shape}")
        # a fresh writable array whatever was given: a read-only one (a policy file's, or the view
        # broadcast_to makes) is another numba type, for which the kernels would compile again
        return np.array(np.broadcast_to(theta, (batch, n)), order="C")

    @property
    def batch(self) -> int:
        return self.world.batch

    @property
    def keepers(self) -> int:
        return self.world.n_keepers

    def _need_learning(self) -> None:
        if not self.learning:
            raise ValueError("this batch has no Pass learners (pass_policy is not 'learned')")

    def set_pass_mode(self, mode: str) -> None:
        """Every arena's keepers switch to Sarsa ``mode`` ("learn", "greedy" or "explore") at the start of
        the arena's next episode (at once in arenas that have not played a cycle yet): an episode never
        changes mode midway. After ``run(episodes_per_arena=...)`` every arena is at an episode end, so
        the next run plays entirely in the new mode."""
        self._need_learning()
        code = _policy_code(MODE_NAMES, mode, "Sarsa mode")
        self.book.pass_mode[:] = code
        self.sarsa.mode.reshape(-1, self.keepers)[self.world.time[self.learner_arenas] == 0] = code

    def _go_on_with(self, learners: SarsaMemory, modes: np.ndarray) -> SarsaMemory:
        """``learners`` restarted for these arenas' learner rows, in Sarsa ``modes`` (one per row;
        ``learners`` in :meth:`__init__`)."""
        if not self.learning:
            raise ValueError("learners to go on with need pass_policy='learned'")
        c, rows = self.sarsa_config, len(modes)
        shape = (len(learners.mode), learners.weights.shape[1], learners.trace_feature.shape[1],
                 learners.log_action.shape[1])
        if shape != (rows, c.table_size, c.max_traces, c.transition_log_size):
            raise ValueError(f"the learners to go on with must be {rows} of this Sarsa configuration "
                             f"(rows, table, traces, log: {shape})")
        restart_learners(learners, self.sarsa_config, modes)
        return learners

    def pass_policy_arrays(self) -> list[list[dict[str, np.ndarray]] | None]:
        """Every keeper's learned Pass policy, ``[arena][keeper]``, as policy-file arrays
        (``agents.sarsa.policy_arrays``; save one with ``agents.policy_file.save_policy(path,
        pass_arrays=..., config={"sarsa": dataclasses.asdict(self.sarsa_config), ...})`` for a player
        process); None for an arena without Pass learners. Episodes that have ended have had their terminal
        updates."""
        self._need_learning()
        return [self.arena_pass_arrays(b) if self.policies.learner[b] >= 0 else None for b in range(self.batch)]

    def arena_pass_arrays(self, arena: int) -> list[dict[str, np.ndarray]]:
        """The learned Pass policy of every keeper of ``arena`` (a row of :meth:`pass_policy_arrays`)."""
        return [policy_arrays(self.sarsa, r) for r in self._learner_rows(arena)]

    def _learner_rows(self, arena: int) -> range:
        """The Sarsa rows of ``arena``'s keepers; ValueError if it has no Pass learners."""
        self._need_learning()
        first = int(self.policies.learner[arena])
        if first < 0:
            raise ValueError(f"arena {arena} has no Pass learners (its pass_policy is not 'learned')")
        return range(first, first + self.keepers)

    def load_pass_arrays(
        self, arrays: dict[str, np.ndarray] | list[dict[str, np.ndarray]] | list[list[dict[str, np.ndarray]] | None]
    ) -> None:
        """Load Pass policies (``pass_policy_arrays`` entries or a policy file's ``pass_arrays``, of this
        batch's table size) into the arenas with Pass learners: one for every keeper of every such arena, a
        list with one per keeper (the same team in every arena), or ``[arena][keeper]`` (None, or anything,
        for an arena without learners). Traces and open decisions are cleared (as
        ``agents.sarsa.load_policy_arrays``); a keeper in mid-episode starts a fresh SMDP episode at its
        next decision."""
        self._need_learning()
        k = self.keepers
        if isinstance(arrays, dict):
            grid = [[arrays] * k for _ in range(self.batch)]
        elif len(arrays) == k and all(isinstance(a, dict) for a in arrays):
            grid = [list(arrays)] * self.batch
        elif len(arrays) == self.batch and all(self.policies.learner[b] < 0 or (
                row is not None and not isinstance(row, dict) and len(row) == k) for b, row in enumerate(arrays)):
            grid = arrays
        else:
            raise ValueError(f"give one policy, {k} (one per keeper) or [{self.batch}][{k}]")
        for b in self.learner_arenas:
            for r, policy in zip(self._learner_rows(b), grid[b]):
                load_policy_arrays(self.sarsa, r, policy)

    def run(self, episodes_per_arena: int | np.ndarray | None = None, total_episodes: int | None = None,
            max_cycles: int | None = None, progress: Callable[[int], None] | None = None) -> EpisodeTable:
        """Play on until every arena has ended its quota of episodes or played ``max_cycles`` more
        cycles (at least one limit is needed). The quota is ``episodes_per_arena`` (one for all, or one per
        arena, 0 for an arena that plays no more); ``total_episodes``
        shares that many out, ``total // batch`` per arena plus one in the first ``total % batch``
        arenas (the smaller quota wins if both are given). Fixed quotas rather than the first episodes
        to end keep the hold times unbiased: the short ones end first. ``progress`` is called with the
        number of episodes collected after each chunk. The episodes of :meth:`chunks`, in one table."""
        parts = []
        collected = 0
        for part in self.chunks(episodes_per_arena, total_episodes, max_cycles):
            parts.append(part)
            collected += len(part)
            if progress is not None:
                progress(collected)
        return EpisodeTable.concatenate(parts)

    def chunks(self, episodes_per_arena: int | np.ndarray | None = None, total_episodes: int | None = None,
               max_cycles: int | None = None, cycles_per_chunk: int = CHUNK_CYCLES) -> Iterator[EpisodeTable]:
        """:meth:`run`'s play (the same limits, checked at once), one chunk of ``cycles_per_chunk`` cycles
        (at most ``CHUNK_CYCLES``) at a time: yields each chunk's ended episodes and arena-cycles as it
        finishes, for a caller that shows them as they come. Chunks of one cycle let a caller look at
        every cycle of every arena (``trainer.behaviour``); the games do not depend on the chunk size."""
        limits = (episodes_per_arena, total_episodes, max_cycles)
        if all(v is None for v in limits):
            raise ValueError("give episodes_per_arena, total_episodes or max_cycles")
        if np.ndim(episodes_per_arena) == 1:
            if len(episodes_per_arena) != self.batch or np.min(episodes_per_arena) < 0:
                raise ValueError(f"per-arena quotas need {self.batch} values >= 0")
            limits = limits[1:]
        if any(v is not None and v < 1 for v in limits):
            raise ValueError("limits must be at least 1")
        if not 1 <= cycles_per_chunk <= CHUNK_CYCLES:
            raise ValueError(f"cycles_per_chunk must be in 1..{CHUNK_CYCLES}")
        book, w = self.book, self.world
        quota = np.full(self.batch, _UNLIMITED if episodes_per_arena is None else episodes_per_arena)
        if total_episodes is not None:
            share = episode_shares(total_episodes, self.batch)
            quota = np.where(quota == _UNLIMITED, share, np.minimum(quota, share))
        book.episodes_left[:] = quota
        book.active[:] = quota != 0
        book.stop_cycle[:] = _UNLIMITED if max_cycles is None else w.time + max_cycles
        return self._chunks(cycles_per_chunk)

    def _chunks(self, n_cycles: int) -> Iterator[EpisodeTable]:
        while self.book.active.any():
            self._run_chunk(n_cycles)
            yield self._ended()

    def _run_chunk(self, n_cycles: int = CHUNK_CYCLES) -> None:
        """One chunk of ``n_cycles`` cycles of every arena; thread k steps arenas k, k + threads, ...
        (finished arenas are spread evenly)."""
        args = (n_cycles, self.world, self.commands, self.referee, self.theta, self.kp, self.policies,
                self.players, self.sarsa, self.sarsa_params, self.see_out, self.body_out, self.book,
                self.see_period_ms, self.cone)
        if self.threads == 1:
            run_chunk(0, 1, *args)
            return
        with ThreadPoolExecutor(self.threads) as pool:
            for done in [pool.submit(run_chunk, k, self.threads, *args) for k in range(self.threads)]:
                done.result()

    def _ended(self) -> EpisodeTable:
        """The episodes ended in the last chunk, ordered by end cycle, then arena, and its arena-cycles."""
        book = self.book
        mask = np.arange(CHUNK_CYCLES)[None, :] < book.n_ended[:, None]
        arena = np.broadcast_to(np.arange(self.batch)[:, None], mask.shape)[mask]
        end_cycle = book.end_cycle[mask]
        order = np.lexsort((arena, end_cycle))
        return EpisodeTable(arena=arena[order].astype(np.int64), episode=book.episode[mask][order],
                            start_cycle=book.start_cycle[mask][order], end_cycle=end_cycle[order],
                            end=book.end[mask][order].astype(np.int8), cycles=int(book.stepped.sum()))


__all__ = [
    "BATCHED_SARSA",
    "CHUNK_CYCLES",
    "ArenaPolicies",
    "BatchedArenas",
    "EpisodeTable",
    "GETOPEN_POLICIES",
    "PASS_POLICIES",
    "Players",
    "agent_seed",
    "arena_cycle",
    "arena_seed",
    "episode_shares",
    "end_pass_episodes",
    "learn_pass",
    "learner_seed",
    "run_chunk",
    "see_to_model_row",
]

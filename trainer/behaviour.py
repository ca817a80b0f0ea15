"""Behaviour statistics of Keepaway games: ours, recorded from the batched mode, beside the reference stack's.

The reference is rcssserver 19.0.0 with the keepaway-0.6 C++ players, measured from its game logs
(``tests/data/rcss-behaviour``). The statistics follow the definitions of the reference measurement's
own analysis script (tests/data/rcss-behaviour/README.md), so that both stacks are measured by one rule
(t = cycles since the episode's reset; row t = 0 is the reset placement; the state after the last step,
already the next reset, is not a row of the episode):

* hold time = episode length in cycles x the simulator step; s.e. = sd / sqrt(n) (sd with n - 1).
* hold-time spread: sd, median, p10, p90 (linear interpolation), each with a bootstrap standard error
  (:func:`spread_estimates`).
* taker within 1 m: the first t at which a taker's centre is within 1.0 m of the ball's, if it happens;
  likewise within 5 m and 2 m (the approach, which the reference file's first campaigns lack).
* kicks: successful kicks only (the kick reached the ball), every step of the episode, the last one
  (end - 1 -> end) included. Passes: keeper kicks after which the next kick by anyone (in step order,
  players in object order within a step) is by a different keeper. Fast kicks: keeper kicks after which
  the ball moves at >= 1.5 m/cycle (kicks in the last step are not counted: the ball is already reset).
* taker-ball distance curve: for t = 0..29, the mean over the episodes still running at t of each
  taker's distance to the ball and of the nearer taker's.
* keeper-nearest-taker distance: for every row and keeper, the distance to the nearer taker; the mean
  over all rows and keepers (pooled) and the mean of the episodes' means.
* takers near a held ball: the taker rows (not the last of an episode) in which a keeper is within 1 m of
  the ball and the taker 1-3 m from it; of these, the share in which the taker's dash was executed in the
  step that follows, and the share of its turns (the "dash/turn shares"; s.e. with the episodes
  as clusters, :func:`ratio_estimate`).

:func:`behaviour_statistics` is the sans-IO core (arrays in, statistics out); :func:`record_batched`
plays a :class:`runner.batched.BatchedArenas` one cycle at a time to record its episodes without
changing them; :func:`load_reference` reads the reference file, :func:`compare` sets the two side
by side and :func:`judge` weighs ours against every campaign of a policy. :func:`game_log_episodes`
cuts a game log (.rcg, ours or rcssserver's) into the same episodes, so that the reference stack played
live is measured by the same code; :func:`reference_entry` writes statistics back in the reference
file's format. ``benchmarks/side_by_side.py`` prints the comparison.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.stats import bootstrap

from keepaway.agents.config import AgentConfig
from keepaway.core.objects import BALL
from keepaway.protocol.params import ServerParams
from keepaway.runner.batched import BatchedArenas
from keepaway.runner.job import EpisodeTable
from keepaway.server.episode_log import EpisodeRecord
from keepaway.server.game_log import STATE_KICK, STATE_KICK_FAULT, GameRecord, Show
from keepaway.server.referee import END_CAUSES, END_OUT, END_TAKEN
from keepaway.server.world import COUNT_DASH, COUNT_KICK, COUNT_TURN

# The reference analysis's definitions (its stats.py docstring), not server parameters.
TAKER_REACH_M = 1.0
APPROACH_M = (5.0, 2.0)  # the approach: first t within these distances too
HELD_BALL_M = 1.0  # a keeper this near the ball holds it
NEAR_HELD_M = (1.0, 3.0)  # takers this near a held ball (inclusive band)
BOOTSTRAP_RESAMPLES = 1000
# The command counters the statistics read (the server's and the game log's .rcg counts share this order).
COMMAND_COUNTS = [COUNT_KICK, COUNT_DASH, COUNT_TURN]
FAST_KICK_SPEED = 1.5  # m/cycle
CURVE_CYCLES = 30
# A difference within this many combined standard errors or this share of the reference, whichever is
# larger, is within tolerance (the reference's campaigns differ by more than their s.e.:
# tests/data/rcss-behaviour/README.md).
TOLERANCE_SE = 3.0
TOLERANCE_SHARE = 0.10
# Our Pass policies and the reference file's campaigns of the same policy (the first recorded; the later
# ones named by their server seed: "hand14", "hold12", "rand21"; "hold31", "rand31", "hand31" played live
# by benchmarks/side_by_side.py --reference; seeds 51-53 likewise, with the statistics the first lack).
REFERENCE_CAMPAIGNS = {
    "hold": ("hold", "hold12", "hold31", "hold51", "hold52", "hold53", "hold51b", "hold52b", "hold53b"),
    "random": ("rand", "rand21", "rand31", "rand51", "rand52", "rand53", "rand51b", "rand52b", "rand53b"),
    "handcoded": ("hand", "hand14", "hand31", "hand51", "hand52", "hand53", "hand51b", "hand52b", "hand53b"),
}


@dataclass(frozen=True, eq=False)
class Episode:
    """One recorded episode of ``d`` cycles: rows t = 0 .. d-1, row 0 the reset placement. Objects in
    server order: 0 the ball, 1..K the keepers, K+1..K+T the takers."""

    pos: np.ndarray  # (d, N, 2) m
    ball_vel: np.ndarray  # (d, 2) m/cycle, as the server stores it (after the decay)
    kicks: np.ndarray  # (d, N) bool: kicks[t, i], object i's kick reached the ball in the step t -> t+1
    dashes: np.ndarray  # (d, N) bool: object i's dash was executed in the step t -> t+1
    turns: np.ndarray  # (d, N) bool: its turn was
    end: int  # server.referee END_OUT / END_TAKEN

    @property
    def cycles(self) -> int:
        return len(self.pos)


@dataclass(frozen=True)
class Estimate:
    """A statistic and its standard error (None where there is none, e.g. a pooled mean or a reference
    that does not give one)."""

    value: float
    se: float | None = None


@dataclass(frozen=True, eq=False)
class BehaviourStats:
    """The statistics of one set of episodes (module docstring); the same fields for ours and for the
    reference's (:meth:`from_reference`)."""

    episodes: int
    hold_s: Estimate
    hold_sd_s: Estimate
    hold_median_s: Estimate
    hold_p10_s: Estimate
    hold_p90_s: Estimate
    share_out: Estimate
    share_taken: Estimate
    taker_within_1m_share: Estimate
    taker_within_1m_t: Estimate  # cycles, over the episodes where it happens
    keeper_kicks: Estimate  # per episode
    taker_kicks: Estimate
    passes: Estimate
    fast_kicks: Estimate
    keeper_nearest_taker_m: Estimate  # pooled over rows and keepers
    keeper_nearest_taker_episode_mean_m: Estimate
    curve_running: np.ndarray  # (CURVE_CYCLES,) int: episodes still running at t
    curve_takers: np.ndarray  # (T, CURVE_CYCLES) m, taker j's mean distance to the ball at t
    curve_nearer: np.ndarray  # (CURVE_CYCLES,) m, the nearer taker's
    # Not in the reference file's first campaigns (None there):
    taker_within_5m_t: Estimate | None = None
    taker_within_2m_t: Estimate | None = None
    taker_dash_share_near_held: Estimate | None = None
    taker_turn_share_near_held: Estimate | None = None
    hold_cycles: np.ndarray | None = None  # (episodes,) int, each episode's length

    def scalars(self) -> dict[str, Estimate]:
        """Every single-number statistic it has by name, in the order the comparison lists them."""
        every = {
            "hold time (s)": self.hold_s,
            "hold time sd (s)": self.hold_sd_s,
            "hold time median (s)": self.hold_median_s,
            "hold time p10 (s)": self.hold_p10_s,
            "hold time p90 (s)": self.hold_p90_s,
            "share ended out": self.share_out,
            "share ended taken": self.share_taken,
            "taker within 5 m: first t (cycles)": self.taker_within_5m_t,
            "taker within 2 m: first t (cycles)": self.taker_within_2m_t,
            "share with a taker within 1 m": self.taker_within_1m_share,
            "taker within 1 m: first t (cycles)": self.taker_within_1m_t,
            "takers 1-3 m from a held ball: dash share": self.taker_dash_share_near_held,
            "takers 1-3 m from a held ball: turn share": self.taker_turn_share_near_held,
            "keeper kicks / episode": self.keeper_kicks,
            "taker kicks / episode": self.taker_kicks,
            "passes / episode": self.passes,
            "fast keeper kicks / episode": self.fast_kicks,
            "keeper-nearest-taker distance, pooled (m)": self.keeper_nearest_taker_m,
            "keeper-nearest-taker distance, mean of episodes (m)": self.keeper_nearest_taker_episode_mean_m,
        }
        return {name: e for name, e in every.items() if e is not None}

    @classmethod
    def from_reference(cls, entry: dict) -> BehaviourStats:
        """One policy's entry of the reference file (``stats_real.json``, written by its ``stats.py``, or by
        :func:`reference_entry` with the statistics that file's first campaigns lack)."""
        n = entry["episodes"]
        within = entry["taker_within_1m"]
        curve = entry["taker_ball_distance_curve"]
        takers = sorted((k for k in curve if k[0] == "r" and k[1:].isdigit()), key=lambda k: int(k[1:]))
        near = entry["keeper_nearest_taker_m"]
        spread_se = entry.get("hold_spread_se_s", {})
        approach = entry.get("taker_within_m", {})
        held = entry.get("takers_near_held_ball", {})

        def per_episode(key: str) -> Estimate:
            return Estimate(entry[key + "_per_episode"]["mean"], entry[key + "_per_episode"]["se"])

        def spread(key: str) -> Estimate:
            return Estimate(entry[f"hold_{key}_s"], spread_se.get(key))

        def optional(table: dict, key: str, mean: str = "mean", se: str = "se") -> Estimate | None:
            return Estimate(table[key][mean], table[key][se]) if key in table else None

        return cls(
            episodes=n,
            hold_s=Estimate(entry["hold_mean_s"], entry["hold_se_s"]),
            hold_sd_s=spread("sd"),
            hold_median_s=spread("median"),
            hold_p10_s=spread("p10"),
            hold_p90_s=spread("p90"),
            share_out=share_estimate(entry["share_out"], n),
            share_taken=share_estimate(entry["share_taken"], n),
            taker_within_1m_share=share_estimate(within["share_of_episodes"], n),
            taker_within_1m_t=Estimate(within["mean_t"], within["se_t"]),
            keeper_kicks=per_episode("kicks_keepers"),
            taker_kicks=per_episode("kicks_takers"),
            passes=per_episode("passes"),
            fast_kicks=per_episode("fast_kicks"),
            keeper_nearest_taker_m=Estimate(near["pooled"]),
            keeper_nearest_taker_episode_mean_m=Estimate(near["mean_of_episode_means"]),
            curve_running=np.array(curve["n_episodes_running"]),
            curve_takers=np.array([curve[k] for k in takers]),
            curve_nearer=np.array(curve["nearer"]),
            taker_within_5m_t=optional(approach, "5", "mean_t", "se_t"),
            taker_within_2m_t=optional(approach, "2", "mean_t", "se_t"),
            taker_dash_share_near_held=optional(held, "dash_share"),
            taker_turn_share_near_held=optional(held, "turn_share"),
            hold_cycles=np.array(entry["hold_cycles"]) if "hold_cycles" in entry else None,
        )


def share_estimate(share: float, n: int) -> Estimate:
    """A share of ``n`` episodes with its binomial standard error."""
    return Estimate(share, math.sqrt(share * (1.0 - share) / n))


def mean_estimate(values: Sequence[float] | np.ndarray) -> Estimate:
    """The mean and its standard error sd / sqrt(n) (sd with n - 1; none for fewer than two values)."""
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        return Estimate(math.nan)
    se = float(values.std(ddof=1) / math.sqrt(len(values))) if len(values) > 1 else None
    return Estimate(float(values.mean()), se)


def spread_estimates(hold_s: np.ndarray) -> tuple[Estimate, Estimate, Estimate, Estimate]:
    """The hold times' sd (n - 1), median, p10 and p90, each with its bootstrap standard error
    (``BOOTSTRAP_RESAMPLES`` resamples from a fixed seed, so that the same episodes give the same figures;
    none for fewer than two episodes). Analytic errors would need the distribution's density at each
    percentile, and hold times come in whole cycles."""
    def sd(x: np.ndarray, axis: int = -1) -> np.ndarray:
        return np.std(x, ddof=1, axis=axis)

    def percentile(q: float):
        return lambda x, axis=-1: np.percentile(x, q, axis=axis)

    statistics = (sd, percentile(50), percentile(10), percentile(90))
    if len(hold_s) < 2:
        only = float(hold_s[0])
        return Estimate(0.0), Estimate(only), Estimate(only), Estimate(only)
    rng = np.random.default_rng(0)
    return tuple(Estimate(float(f(hold_s)), float(bootstrap((hold_s,), f, n_resamples=BOOTSTRAP_RESAMPLES,
                                                            method="percentile", random_state=rng).standard_error))
                 for f in statistics)


def ratio_estimate(hits: np.ndarray, counts: np.ndarray) -> Estimate | None:
    """sum(hits) / sum(counts) over clusters (episodes), with the clustered standard error
    sqrt(sum((hits_e - r counts_e)^2) / (m (m - 1))) / mean(counts) of m clusters: rows of one episode
    are not independent. None if no cluster has a row."""
    total = counts.sum()
    if total == 0:
        return None
    r = hits.sum() / total
    m = len(counts)
    se = math.sqrt(((hits - r * counts) ** 2).sum() / (m * (m - 1))) / counts.mean() if m > 1 else None
    return Estimate(float(r), se)


def kick_counts(episode: Episode, n_keepers: int) -> tuple[int, int, int, int]:
    """An episode's keeper kicks, taker kicks, passes and fast keeper kicks (module docstring)."""
    steps, kickers = np.nonzero(episode.kicks)  # in step order, then object order
    by_keeper = (kickers >= 1) & (kickers <= n_keepers)
    passes = by_keeper[:-1] & by_keeper[1:] & (kickers[:-1] != kickers[1:])
    visible = steps[by_keeper]
    visible = visible[visible < episode.cycles - 1]  # the ball after a kick in the last step is reset
    fast = np.linalg.norm(episode.ball_vel[visible + 1], axis=1) >= FAST_KICK_SPEED
    return int(by_keeper.sum()), int((kickers > n_keepers).sum()), int(passes.sum()), int(fast.sum())


def behaviour_statistics(episodes: Sequence[Episode], n_keepers: int, seconds_per_cycle: float) -> BehaviourStats:
    """The statistics of ``episodes`` (module docstring), each episode with ``n_keepers`` keepers first."""
    if not episodes:
        raise ValueError("no episodes")
    n_takers = episodes[0].pos.shape[1] - 1 - n_keepers
    keepers, takers = slice(1, 1 + n_keepers), slice(1 + n_keepers, None)
    cycles = np.array([e.cycles for e in episodes])
    ends = np.array([e.end for e in episodes])
    reach_m = (*APPROACH_M, TAKER_REACH_M)
    within_t = {m: [] for m in reach_m}
    keeper_kicks, taker_kicks, passes, fast = [], [], [], []
    near_held, dashed, turned = (np.zeros(len(episodes), dtype=np.int64) for _ in range(3))
    curve_sum = np.zeros((n_takers + 1, CURVE_CYCLES))
    curve_running = np.zeros(CURVE_CYCLES, dtype=np.int64)
    near_sum, near_rows, near_episode_means = 0.0, 0, []
    for i, e in enumerate(episodes):
        taker_ball = np.linalg.norm(e.pos[:, takers] - e.pos[:, BALL, None], axis=2)  # (d, T)
        nearer = taker_ball.min(axis=1)
        for m in reach_m:
            reached = np.flatnonzero(nearer <= m)
            if len(reached):
                within_t[m].append(reached[0])
        held = np.linalg.norm(e.pos[:-1, keepers] - e.pos[:-1, BALL, None], axis=2).min(axis=1) <= HELD_BALL_M
        band = held[:, None] & (taker_ball[:-1] >= NEAR_HELD_M[0]) & (taker_ball[:-1] <= NEAR_HELD_M[1])
        near_held[i] = band.sum()
        dashed[i] = (band & e.dashes[:-1, takers]).sum()
        turned[i] = (band & e.turns[:-1, takers]).sum()
        shown = min(e.cycles, CURVE_CYCLES)
        curve_sum[:n_takers, :shown] += taker_ball[:shown].T
        curve_sum[n_takers, :shown] += nearer[:shown]
        curve_running[:shown] += 1
        keeper_taker = np.linalg.norm(e.pos[:, keepers, None] - e.pos[:, None, takers], axis=3)
        keeper_nearest = keeper_taker.min(axis=2)  # (d, K)
        near_sum += keeper_nearest.sum()
        near_rows += keeper_nearest.size
        near_episode_means.append(keeper_nearest.mean())
        for tally, count in zip((keeper_kicks, taker_kicks, passes, fast), kick_counts(e, n_keepers)):
            tally.append(count)
    with np.errstate(invalid="ignore"):
        curve = curve_sum / curve_running  # NaN where no episode runs that long
    hold_s = cycles * seconds_per_cycle
    sd, median, p10, p90 = spread_estimates(hold_s)
    n = len(episodes)
    return BehaviourStats(
        episodes=n,
        hold_s=mean_estimate(hold_s),
        hold_sd_s=sd,
        hold_median_s=median,
        hold_p10_s=p10,
        hold_p90_s=p90,
        share_out=share_estimate(float(np.mean(ends == END_OUT)), n),
        share_taken=share_estimate(float(np.mean(ends == END_TAKEN)), n),
        taker_within_1m_share=share_estimate(len(within_t[TAKER_REACH_M]) / n, n),
        taker_within_1m_t=mean_estimate(within_t[TAKER_REACH_M]),
        keeper_kicks=mean_estimate(keeper_kicks),
        taker_kicks=mean_estimate(taker_kicks),
        passes=mean_estimate(passes),
        fast_kicks=mean_estimate(fast),
        keeper_nearest_taker_m=Estimate(float(near_sum / near_rows)),
        keeper_nearest_taker_episode_mean_m=Estimate(float(np.mean(near_episode_means))),
        curve_running=curve_running,
        curve_takers=curve[:n_takers],
        curve_nearer=curve[n_takers],
        taker_within_5m_t=mean_estimate(within_t[APPROACH_M[0]]),
        taker_within_2m_t=mean_estimate(within_t[APPROACH_M[1]]),
        taker_dash_share_near_held=ratio_estimate(dashed, near_held),
        taker_turn_share_near_held=ratio_estimate(turned, near_held),
        hold_cycles=cycles,
    )


# An episode this long (10 minutes of play at 100 ms a cycle) is stuck: the limit for any episode.
MAX_EPISODE_CYCLES = 6000


def record_batched(arenas: BatchedArenas, total_episodes: int,
                   max_episode_cycles: int = MAX_EPISODE_CYCLES) -> tuple[EpisodeTable, list[Episode]]:
    """Play ``total_episodes`` more episodes of ``arenas`` (quotas as :meth:`BatchedArenas.run`) one
    cycle per chunk, and return them as ``run`` would, with each one's :class:`Episode` (same order).
    RuntimeError (one line) as soon as an episode has lasted ``max_episode_cycles`` cycles: its players
    are stuck, and every further cycle would only add snapshots until memory runs out.

    After every chunk each arena that played has advanced exactly one cycle, so snapshot k of arena b
    is its state at cycle time0[b] + k. A successful kick is the one the server counts (its kick counter
    grows only when the kick reaches the ball, ``server.physics.kick``): the counter's growth between two
    snapshots; ``world.kicked`` would also flag kicks that miss. The chunk size does not change the game
    (``tests/test_behaviour.py``). Every arena must be at an episode start (new, or after ``run`` with
    an episode quota): an episode begun before would lack its first rows."""
    w = arenas.world
    if np.any(arenas.referee.start_cycle != w.time):
        raise ValueError("record from episode starts: some arenas are in mid-episode")
    time0 = w.time.copy()
    snapshots = []

    def snapshot() -> None:
        snapshots.append((w.pos.copy(), w.vel[:, BALL].copy(), w.counts[:, :, COMMAND_COUNTS].copy()))

    snapshot()
    parts = []
    before = time0.copy()
    for part in arenas.chunks(total_episodes=total_episodes, cycles_per_chunk=1):
        parts.append(part)
        snapshot()
        stuck = (w.time != before) & (w.time - arenas.referee.start_cycle >= max_episode_cycles)
        if stuck.any():
            b = int(np.flatnonzero(stuck)[0])
            raise RuntimeError(f"arena {b}: an episode has lasted {max_episode_cycles} cycles without ending; "
                               "its players are stuck")
        before[:] = w.time
    table = EpisodeTable.concatenate(parts)
    pos, ball_vel, counts = (np.stack(arrays) for arrays in zip(*snapshots))
    episodes = []
    for b, start, end, cause in zip(table.arena, table.start_cycle, table.end_cycle, table.end):
        rows = slice(start - time0[b], end - time0[b])
        grew = counts[rows.start + 1:rows.stop + 1, b] > counts[rows, b]  # (d, N, 3)
        episodes.append(Episode(pos=pos[rows, b], ball_vel=ball_vel[rows, b], kicks=grew[..., 0],
                                dashes=grew[..., 1], turns=grew[..., 2], end=int(cause)))
    return table, episodes


def measure_policy(params: ServerParams, pass_policy: str, episodes: int, seed: int, batch: int = 100,
                   getopen_policy: str = "handcoded") -> BehaviourStats:
    """Our players' statistics over ``episodes`` episodes of 3v2 with Pass ``pass_policy``, batched on one
    thread (``batch`` arenas seeded ``seed``, ``seed + 1``, ...), the reference's setting otherwise."""
    arenas = BatchedArenas(params, batch=batch, seed=seed, pass_policy=pass_policy, getopen_policy=getopen_policy,
                           agent_config=AgentConfig(), threads=1)
    _, recorded = record_batched(arenas, episodes)
    return behaviour_statistics(recorded, arenas.keepers, params.simulator_step_ms / 1000.0)


def show_arrays(show: Show, n_keepers: int, n_takers: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A show's positions (N, 2) in server object order (ball, keepers l1..lK, takers r1..rT), the ball's
    velocity (2,), which objects' kicks reached the ball in the step that led to it (N,): the kick flag
    without the kick-fault flag, as rcssserver sets them (``server.game_log.WorldShows``), and each
    player's dash and turn counters (N, 2; the ball's 0). ValueError if a player is missing (one that
    joined late, for instance)."""
    players = {(p.side, p.unum): p for p in show.players}
    order = [("l", u) for u in range(1, n_keepers + 1)] + [("r", u) for u in range(1, n_takers + 1)]
    missing = [f"{side}{unum}" for side, unum in order if (side, unum) not in players]
    if missing:
        raise ValueError(f"show {show.cycle}: player {', '.join(missing)} is not on the pitch")
    pos = np.array([show.ball[:2]] + [(players[key].x, players[key].y) for key in order])
    kicked = np.array([False] + [players[key].state & (STATE_KICK | STATE_KICK_FAULT) == STATE_KICK
                                 for key in order])
    counts = np.array([(0, 0)] + [[players[key].counts[c] for c in COMMAND_COUNTS[1:]] for key in order])
    return pos, np.array(show.ball[2:]), kicked, counts


def game_log_episodes(record: GameRecord, episodes: Sequence[EpisodeRecord], n_keepers: int,
                      n_takers: int) -> list[Episode]:
    """The :class:`Episode` of each finished episode (``episodes``: the ``.kwy``'s) whose shows, from its
    start to its end cycle, are all in the game log (the last one of a stopped run may lack its end).

    The show of cycle ``start`` is the reset placement (row 0); the show of the end cycle is already the
    next episode's reset, but its kick flags belong to the episode's last step (rcssserver's referee
    resets the field inside that step), so the episode's kicks are those of shows start+1 .. end, and its
    dashes and turns the counters' growth from each show to the next up to the end's. Of two
    shows of one cycle (a play-mode change) the later one counts, as in the reference's ``parse_rcg.py``.
    """
    by_cycle = {show.cycle: show for show in record.shows}
    codes = {name: code for code, name in END_CAUSES.items()}
    result = []
    for e in episodes:
        cycles = range(e.start_cycle, e.end_cycle + 1)
        if any(c not in by_cycle for c in cycles):
            continue
        pos, vel, kicked, counts = (np.stack(a) for a in zip(*(show_arrays(by_cycle[c], n_keepers, n_takers)
                                                                  for c in cycles)))
        grew = counts[1:] > counts[:-1]  # (d, N, 2): dash, turn
        result.append(Episode(pos=pos[:-1], ball_vel=vel[:-1], kicks=kicked[1:], dashes=grew[..., 0],
                              turns=grew[..., 1], end=codes[e.end]))
    return result


def reference_entry(stats: BehaviourStats, campaign: str, seed: int) -> dict:
    """``stats`` as an entry of the reference file (``stats_real.json``, the format its ``stats.py``
    writes): the keys :meth:`BehaviourStats.from_reference` reads, ``run`` with the seed, and where
    ``stats`` has them the statistics that file's first campaigns lack (the spread's standard errors, the
    approach, the takers near a held ball) and each episode's length in cycles."""
    def per_episode(e: Estimate) -> dict:
        return {"mean": e.value, "se": e.se}

    curve = {f"r{j + 1}": stats.curve_takers[j].tolist() for j in range(len(stats.curve_takers))}
    entry = {
        "policy": campaign,
        "episodes": stats.episodes,
        "hold_mean_s": stats.hold_s.value,
        "hold_se_s": stats.hold_s.se,
        "hold_sd_s": stats.hold_sd_s.value,
        "hold_median_s": stats.hold_median_s.value,
        "hold_p10_s": stats.hold_p10_s.value,
        "hold_p90_s": stats.hold_p90_s.value,
        "share_out": stats.share_out.value,
        "share_taken": stats.share_taken.value,
        "taker_within_1m": {"share_of_episodes": stats.taker_within_1m_share.value,
                            "mean_t": stats.taker_within_1m_t.value, "se_t": stats.taker_within_1m_t.se},
        "kicks_keepers_per_episode": per_episode(stats.keeper_kicks),
        "kicks_takers_per_episode": per_episode(stats.taker_kicks),
        "passes_per_episode": per_episode(stats.passes),
        "fast_kicks_per_episode": per_episode(stats.fast_kicks),
        "taker_ball_distance_curve": {"n_episodes_running": stats.curve_running.tolist(), **curve,
                                      "nearer": stats.curve_nearer.tolist()},
        "keeper_nearest_taker_m": {"pooled": stats.keeper_nearest_taker_m.value,
                                   "mean_of_episode_means": stats.keeper_nearest_taker_episode_mean_m.value},
        "run": {"seed": seed},
    }
    spread = {"sd": stats.hold_sd_s, "median": stats.hold_median_s, "p10": stats.hold_p10_s, "p90": stats.hold_p90_s}
    if all(e.se is not None for e in spread.values()):
        entry["hold_spread_se_s"] = {key: e.se for key, e in spread.items()}
    approach = {"5": stats.taker_within_5m_t, "2": stats.taker_within_2m_t}
    if all(e is not None for e in approach.values()):
        entry["taker_within_m"] = {key: {"mean_t": e.value, "se_t": e.se} for key, e in approach.items()}
    held = {"dash_share": stats.taker_dash_share_near_held, "turn_share": stats.taker_turn_share_near_held}
    if all(e is not None for e in held.values()):
        entry["takers_near_held_ball"] = {key: per_episode(e) for key, e in held.items()}
    if stats.hold_cycles is not None:
        entry["hold_cycles"] = stats.hold_cycles.tolist()
    return entry


def load_reference(path: Path) -> dict[str, BehaviourStats]:
    """The reference file's statistics by campaign name ("hold", "rand", "hand", "hand14")."""
    return {entry["policy"]: BehaviourStats.from_reference(entry) for entry in json.loads(path.read_text())}


@dataclass(frozen=True)
class Compared:
    """One statistic of ours beside the reference's."""

    statistic: str
    ours: Estimate
    reference: Estimate

    @property
    def difference(self) -> float:
        return self.ours.value - self.reference.value

    @property
    def combined_se(self) -> float | None:
        """sqrt(s.e. ours^2 + s.e. reference^2) (None unless both have one)."""
        if self.ours.se is None or self.reference.se is None:
            return None
        return math.hypot(self.ours.se, self.reference.se)

    @property
    def z(self) -> float | None:
        """The difference in combined standard errors (None without them)."""
        return self.difference / self.combined_se if self.combined_se else None

    @property
    def tolerance(self) -> float:
        """How far ours may be from the reference: TOLERANCE_SE combined standard errors or TOLERANCE_SHARE
        of the reference, whichever is larger."""
        return max(TOLERANCE_SE * (self.combined_se or 0.0), TOLERANCE_SHARE * abs(self.reference.value))

    @property
    def within_tolerance(self) -> bool:
        return abs(self.difference) <= self.tolerance

    @property
    def percent(self) -> float | None:
        """The difference in percent of the reference (None for a reference of 0)."""
        return 100.0 * self.difference / self.reference.value if self.reference.value else None


def compare(ours: BehaviourStats, reference: BehaviourStats) -> list[Compared]:
    """Every single-number statistic of ours beside the reference's, those both have
    (:meth:`BehaviourStats.scalars`)."""
    theirs = reference.scalars()
    return [Compared(name, value, theirs[name]) for name, value in ours.scalars().items() if name in theirs]


@dataclass(frozen=True)
class Verdict:
    """One statistic of ours beside every reference campaign that has it."""

    statistic: str
    ours: Estimate
    rows: tuple[Compared, ...]

    @property
    def reference_range(self) -> tuple[float, float]:
        values = [row.reference.value for row in self.rows]
        return min(values), max(values)

    @property
    def within_tolerance(self) -> bool:
        """Within tolerance of one campaign, or between the campaigns' lowest and highest value: the
        reference's campaigns differ by more than their standard errors (tests/data/rcss-behaviour/README.md),
        so any value between two of them is one the reference stack itself produces."""
        low, high = self.reference_range
        return low <= self.ours.value <= high or any(row.within_tolerance for row in self.rows)


def judge(ours: BehaviourStats, campaigns: Sequence[BehaviourStats]) -> list[Verdict]:
    """Each statistic of ours against the campaigns that have it (:class:`Verdict`), in
    :meth:`BehaviourStats.scalars` order; a statistic no campaign has is left out."""
    rows: dict[str, list[Compared]] = {}
    for campaign in campaigns:
        for row in compare(ours, campaign):
            rows.setdefault(row.statistic, []).append(row)
    return [Verdict(name, value, tuple(rows[name])) for name, value in ours.scalars().items() if name in rows]


__all__ = [
    "BehaviourStats",
    "Compared",
    "Episode",
    "Estimate",
    "REFERENCE_CAMPAIGNS",
    "TOLERANCE_SE",
    "TOLERANCE_SHARE",
    "Verdict",
    "behaviour_statistics",
    "compare",
    "game_log_episodes",
    "judge",
    "kick_counts",
    "load_reference",
    "mean_estimate",
    "measure_policy",
    "ratio_estimate",
    "record_batched",
    "reference_entry",
    "share_estimate",
    "spread_estimates",
    "show_arrays",
]

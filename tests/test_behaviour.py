"""Behaviour statistics (trainer/behaviour.py): the definitions on hand-made episodes, the recorder of the
batched mode, and our players beside the reference stack (rcssserver 19.0.0 + keepaway-0.6,
``tests/data/rcss-behaviour``)."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest

from protocol.params import parameter_set
from runner.embedded import ArenaSpec
from runner.run import RunOptions, run
from server.episode_log import read_kwy
from server.game_log import read_rcg
from server.referee import END_OUT, END_TAKEN
from core.objects import BALL
from server.world import COUNT_KICK
from runner.batched import BatchedArenas
from trainer.behaviour import (
    CURVE_CYCLES,
    REFERENCE_CAMPAIGNS,
    Compared,
    Episode,
    Estimate,
    BehaviourStats,
    behaviour_statistics,
    compare,
    game_log_episodes,
    load_reference,
    measure_policy,
    record_batched,
    reference_entry,
)

DATA = Path(__file__).resolve().parent / "data" / "rcss-behaviour"
REFERENCE = load_reference(DATA / "stats_real.json")
CURRENT = parameter_set("current")
K, T = 3, 2
N = 1 + K + T
KEEPER_1, KEEPER_2, TAKER_1 = 1, 2, K + 1
STEP_S = 0.1
# Hold times of the reference stack over its measurement campaigns: every campaign of the data file
# (tests/data/rcss-behaviour/README.md), and hand-coded Pass's earlier campaign that the file lacks (the
# issue's 10.50 s): always hold 2.80-2.98 s, random 5.21-5.34 s, hand-coded 10.50-12.15 s.
EARLIER_CAMPAIGNS_S = {"hold": (), "random": (), "handcoded": (10.50,)}


def reference_hold_range(policy: str) -> tuple[float, float]:
    holds = [REFERENCE[c].hold_s.value for c in REFERENCE_CAMPAIGNS[policy]] + list(EARLIER_CAMPAIGNS_S[policy])
    return min(holds), max(holds)


REFERENCE_HOLD_S = {policy: reference_hold_range(policy) for policy in REFERENCE_CAMPAIGNS}
HOLD_TOLERANCE = 0.05  # of the range's ends
# The documented side-by-side run (docs/design.md, "Side by side with the reference stack").
EPISODES, SEED = 1000, 7


def episode(cycles: int, end: int = END_TAKEN, kicks: dict[int, list[int]] | None = None,
            ball_speed: dict[int, float] | None = None, taker_distance: list[float] | None = None,
            keeper_taker_m: float = 10.0) -> Episode:
    """A 3v2 episode of ``cycles`` rows: the ball at the origin, the takers ``taker_distance[t]`` (default
    5 m) either side of it on the x axis, each keeper ``keeper_taker_m`` straight above or below a taker
    (its nearest). ``kicks``: step -> objects whose kick reached the ball; ``ball_speed``: row -> speed."""
    d = np.full(cycles, 5.0) if taker_distance is None else np.asarray(taker_distance, dtype=float)
    pos = np.zeros((cycles, N, 2))
    pos[:, TAKER_1, 0] = -d
    pos[:, TAKER_1 + 1, 0] = d
    for keeper, (taker, side) in zip(range(1, K + 1), ((TAKER_1, 1), (TAKER_1 + 1, 1), (TAKER_1, -1))):
        pos[:, keeper] = pos[:, taker] + (0.0, side * keeper_taker_m)
    vel = np.zeros((cycles, 2))
    for t, speed in (ball_speed or {}).items():
        vel[t] = (0.0, speed)
    kicked = np.zeros((cycles, N), dtype=bool)
    for step, objects in (kicks or {}).items():
        kicked[step, objects] = True
    return Episode(pos=pos, ball_vel=vel, kicks=kicked, end=end)


def stats(*episodes: Episode):
    return behaviour_statistics(list(episodes), K, STEP_S)


# --------------------------------------------------------------------------------------------------
# the definitions, on hand-made episodes


def test_hold_time_spread_and_end_shares():
    s = stats(episode(10, END_OUT), episode(20), episode(30), episode(40, END_OUT))
    sd = math.sqrt(5.0 / 3.0)  # of 1, 2, 3, 4 s with n - 1
    assert s.episodes == 4
    assert s.hold_s.value == pytest.approx(2.5) and s.hold_s.se == pytest.approx(sd / 2.0)
    assert s.hold_sd_s == pytest.approx(sd)
    assert (s.hold_median_s, s.hold_p10_s, s.hold_p90_s) == pytest.approx((2.5, 1.3, 3.7))  # linear
    assert s.share_out.value == s.share_taken.value == 0.5
    assert s.share_out.se == pytest.approx(0.25)  # sqrt(0.5 * 0.5 / 4)


def test_a_pass_is_a_keeper_kick_whose_next_kick_is_another_keepers():
    # keeper 1 dribbles, passes to keeper 2 (one pass), keeper 2 kicks, a taker kicks, keeper 2 again:
    # after the taker's kick keeper 2's kick is no pass, and its last kick has no next kick.
    s = stats(episode(8, kicks={0: [KEEPER_1], 1: [KEEPER_1], 3: [KEEPER_2], 4: [KEEPER_2], 5: [TAKER_1],
                                7: [KEEPER_2]}))
    assert (s.keeper_kicks.value, s.taker_kicks.value, s.passes.value) == (5, 1, 1)


def test_kicks_in_one_step_are_ordered_by_object():
    # keeper 1 and keeper 2 kick in the same step: keeper 1's kick is followed by keeper 2's (a pass);
    # then keeper 2 and a taker in one step: keeper 2's next kick is the taker's.
    s = stats(episode(4, kicks={1: [KEEPER_1, KEEPER_2], 2: [KEEPER_2, TAKER_1]}))
    assert (s.keeper_kicks.value, s.taker_kicks.value, s.passes.value) == (3, 1, 1)


def test_fast_kicks_leave_the_ball_at_1_5_m_per_cycle_or_more_before_the_last_step():
    s = stats(episode(6, kicks={0: [KEEPER_1], 1: [KEEPER_2], 2: [TAKER_1], 3: [KEEPER_1], 5: [KEEPER_2]},
                      ball_speed={1: 1.5, 2: 2.0, 3: 2.0, 4: 1.49, 5: 3.0}))
    # step 0 -> row 1 at 1.5: fast; step 1 -> 2.0: fast; the taker's: not a keeper's; step 3 -> 1.49: slow;
    # step 5 is the last step (its ball is the next reset): not counted.
    assert s.fast_kicks.value == 2 and s.keeper_kicks.value == 4


def test_taker_within_1_m_is_the_first_such_row_and_some_episodes_have_none():
    s = stats(episode(5, taker_distance=[3.0, 2.0, 1.0, 0.5, 0.2]),  # exactly 1 m at t = 2
              episode(6, taker_distance=[3.0, 2.0, 1.5, 1.2, 0.9, 2.0]),  # t = 4
              episode(4, taker_distance=[3.0, 2.0, 1.5, 1.01]))  # never
    assert s.taker_within_1m_share.value == pytest.approx(2 / 3)
    assert s.taker_within_1m_t.value == 3.0 and s.taker_within_1m_t.se == pytest.approx(1.0)


def test_distance_curves_average_the_episodes_still_running():
    s = stats(episode(2, taker_distance=[4.0, 2.0]), episode(1, taker_distance=[6.0]))
    assert s.curve_running.tolist() == [2, 1] + [0] * (CURVE_CYCLES - 2)
    np.testing.assert_allclose(s.curve_nearer[:2], [5.0, 2.0])
    np.testing.assert_allclose(s.curve_takers[:, :2], [[5.0, 2.0], [5.0, 2.0]])
    assert np.isnan(s.curve_nearer[2:]).all()


def test_keeper_nearest_taker_distance_pools_rows_and_averages_episodes():
    s = stats(episode(3, keeper_taker_m=4.0), episode(1, keeper_taker_m=8.0))
    assert s.keeper_nearest_taker_m.value == pytest.approx((3 * 4.0 + 8.0) / 4)
    assert s.keeper_nearest_taker_episode_mean_m.value == pytest.approx(6.0)


def test_comparison_in_standard_errors_and_percent():
    row = Compared("x", Estimate(11.0, 0.3), Estimate(10.0, 0.4))
    assert row.difference == 1.0 and row.z == pytest.approx(2.0) and row.percent == pytest.approx(10.0)
    no_se = Compared("x", Estimate(1.0), Estimate(0.0, 0.1))
    assert no_se.z is None and no_se.percent is None


def test_tolerance_is_three_standard_errors_or_ten_percent_whichever_is_larger():
    wide = Compared("x", Estimate(11.6, 0.3), Estimate(10.0, 0.4))  # 3 s.e. = 1.5 > 10 % = 1.0
    assert wide.tolerance == pytest.approx(1.5) and not wide.within_tolerance
    narrow = Compared("x", Estimate(10.9, 0.03), Estimate(10.0, 0.04))  # 10 % = 1.0 > 3 s.e. = 0.15
    assert narrow.tolerance == pytest.approx(1.0) and narrow.within_tolerance
    assert Compared("x", Estimate(8.9), Estimate(10.0)).tolerance == pytest.approx(1.0)


def test_the_reference_file_reads_into_the_same_statistics():
    assert sorted(REFERENCE) == ["hand", "hand14", "hand31", "hold", "hold12", "hold31", "rand", "rand21", "rand31"]
    assert sorted(c for campaigns in REFERENCE_CAMPAIGNS.values() for c in campaigns) == sorted(REFERENCE)
    assert REFERENCE["rand21"].episodes == 1006 and REFERENCE["rand21"].hold_s.value == pytest.approx(5.21, abs=0.005)
    hold = REFERENCE["hold"]
    assert hold.episodes == 601 and hold.hold_s.value == pytest.approx(2.80, abs=0.005)
    assert hold.curve_takers.shape == (T, CURVE_CYCLES) and hold.curve_running[0] == 601
    assert all(row.difference == 0 for row in compare(hold, hold))
    assert REFERENCE["rand31"].episodes == 1000 and REFERENCE["rand31"].hold_s.value == pytest.approx(5.32, abs=0.005)
    assert {p: tuple(round(x, 2) for x in r) for p, r in REFERENCE_HOLD_S.items()} == {
        "hold": (2.80, 2.98), "random": (5.21, 5.34), "handcoded": (10.50, 12.15)}


# --------------------------------------------------------------------------------------------------
# the recorder


def test_recording_does_not_change_the_games_and_sees_every_cycle_and_kick():
    recorded = BatchedArenas(CURRENT, 4, 5, pass_policy="random", threads=1)
    plain = BatchedArenas(CURRENT, 4, 5, pass_policy="random", threads=1)
    table, episodes = record_batched(recorded, 10)
    expected = plain.run(total_episodes=10)
    for name in ("arena", "episode", "start_cycle", "end_cycle", "end"):
        np.testing.assert_array_equal(getattr(table, name), getattr(expected, name))
    assert table.cycles == expected.cycles
    for a, b in zip(recorded.world, plain.world):
        np.testing.assert_array_equal(a, b)
    assert [e.cycles for e in episodes] == table.hold_cycles.tolist()
    half_l, half_w = CURRENT.keepaway_length / 2, CURRENT.keepaway_width / 2
    for e in episodes:  # row 0 is the reset placement: the ball at rest 4 m inside the corner
        np.testing.assert_allclose(e.pos[0, BALL], (-half_l + 4.0, -half_w + 4.0))
        assert not e.ball_vel[0].any()
    kicks = np.zeros((4, N), dtype=np.int64)
    for arena, e in zip(table.arena, episodes):
        kicks[arena] += e.kicks.sum(axis=0)
    np.testing.assert_array_equal(kicks, recorded.world.counts[:, :, COUNT_KICK])  # every arena from cycle 0
    assert kicks[:, 1:K + 1].sum() > 0 and kicks[:, K + 1:].sum() > 0


def test_recording_starts_at_episode_starts():
    arenas = BatchedArenas(CURRENT, 2, 5, threads=1)
    arenas.run(max_cycles=3)
    with pytest.raises(ValueError, match="mid-episode"):
        record_batched(arenas, 2)
    arenas.run(episodes_per_arena=1)
    table, episodes = record_batched(arenas, 2)
    assert table.episode.tolist() == [2, 2] and episodes[0].cycles == table.hold_cycles[0]


def test_recording_stops_at_an_episode_that_does_not_end():
    # hand-coded Pass holds the ball longer than 40 cycles in some of the first episodes of 4 arenas;
    # with a 40-cycle limit the recorder names the first such arena instead of recording on
    arenas = BatchedArenas(CURRENT, 4, 5, threads=1)
    with pytest.raises(RuntimeError, match=r"arena \d: an episode has lasted 40 cycles without ending"):
        record_batched(arenas, 8, max_episode_cycles=40)


# --------------------------------------------------------------------------------------------------
# game logs: the reference stack's and ours, cut into the same episodes


def test_a_reference_game_log_gives_its_episodes_with_the_kicks_of_their_shows():
    # rcssserver 19.0.0 + keepaway-0.6, always hold: episode 1 is cycles 0-25 (taken); the head of the log
    # ends at show 39, before episode 2's end (47), so only episode 1 is whole. Keeper 3's successful
    # kicks are the shows 6-17 (flags 0x3; 0x7 at shows 5, 20 and 23 are kicks that missed), taker 2's the
    # shows 22-25, the last one in the show of the end cycle, already the next reset.
    record = read_rcg(DATA / "ref_hold2_head.rcg", kwy=DATA / "ref_hold2_head.kwy")
    (e,) = game_log_episodes(record, read_kwy(DATA / "ref_hold2_head.kwy"), K, T)
    assert e.cycles == 25 and e.end == END_TAKEN
    np.testing.assert_allclose(e.pos[0, BALL], (-6.0, -6.0))
    assert np.flatnonzero(e.kicks[:, 3]).tolist() == list(range(5, 17))
    assert np.flatnonzero(e.kicks[:, 5]).tolist() == [21, 22, 23, 24]
    assert e.kicks.sum() == 16
    s = stats(e)
    assert (s.keeper_kicks.value, s.taker_kicks.value, s.passes.value) == (12, 4, 0)


def test_a_game_log_missing_a_player_is_refused_in_one_line():
    record = read_rcg(DATA / "ref_hold2_head.rcg", kwy=DATA / "ref_hold2_head.kwy")
    with pytest.raises(ValueError, match="player r3 is not on the pitch"):
        game_log_episodes(record, read_kwy(DATA / "ref_hold2_head.kwy"), K, 3)


def test_our_game_log_gives_the_recorders_episodes(tmp_path):
    spec = ArenaSpec(CURRENT, seed=5, pass_policy="random")
    run(RunOptions(spec, episodes=8, mode="batched", batch=1, out=tmp_path, parameter_set="current",
                   game_log_arenas=(0,)), progress=False)
    from_log = game_log_episodes(read_rcg(tmp_path / "keepaway-arena0.rcg"), read_kwy(tmp_path / "keepaway.kwy"),
                                 K, T)
    _, recorded = record_batched(BatchedArenas(CURRENT, 1, 5, pass_policy="random", threads=1), 8)
    assert len(from_log) == len(recorded) == 8
    for a, b in zip(from_log, recorded):
        assert (a.cycles, a.end) == (b.cycles, b.end)
        np.testing.assert_allclose(a.pos, b.pos, atol=1e-4)  # the log's precision
        np.testing.assert_allclose(a.ball_vel, b.ball_vel, atol=1e-4)
        np.testing.assert_array_equal(a.kicks, b.kicks)
    assert sum(e.kicks.sum() for e in recorded) > 0


def test_statistics_written_as_a_reference_entry_read_back_the_same():
    s = stats(episode(10, END_OUT, kicks={1: [KEEPER_1], 3: [KEEPER_2]}, ball_speed={2: 2.0}),
              episode(40, taker_distance=np.linspace(6.0, 0.5, 40)), episode(35, kicks={2: [TAKER_1]}))
    back = BehaviourStats.from_reference(reference_entry(s, "rand99", 99))
    assert back.scalars() == s.scalars()
    for field in ("curve_running", "curve_takers", "curve_nearer"):
        np.testing.assert_array_equal(getattr(back, field), getattr(s, field))
    assert back.episodes == 3


# --------------------------------------------------------------------------------------------------
# our players beside the reference stack


@functools.cache
def ours(policy: str):
    return measure_policy(CURRENT, policy, EPISODES, SEED)


@pytest.mark.slow
@pytest.mark.parametrize("policy", ["hold", "random", "handcoded"])
def test_hold_time_is_within_5_percent_of_the_reference_range(policy):
    low, high = REFERENCE_HOLD_S[policy]
    hold = ours(policy).hold_s
    print(f"{policy}: {hold.value:.2f} +- {hold.se:.2f} s, reference {low:.2f}-{high:.2f} s")
    assert (1 - HOLD_TOLERANCE) * low <= hold.value <= (1 + HOLD_TOLERANCE) * high


@pytest.mark.slow
def test_always_hold_takers_reach_the_ball_when_the_reference_takers_do():
    row = Compared("t", ours("hold").taker_within_1m_t, REFERENCE["hold"].taker_within_1m_t)
    print(f"first t within 1 m: {row.ours.value:.1f} vs {row.reference.value:.1f} (tolerance {row.tolerance:.1f})")
    assert row.within_tolerance

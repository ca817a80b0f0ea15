"""Behaviour statistics (trainer/behaviour.py): the definitions on hand-made episodes, the recorder of the
batched mode, and our players beside the reference stack (rcssserver 19.0.0 + keepaway-0.6,
``tests/data/rcss-behaviour``)."""

from __future__ import annotations

import functools
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from keepaway.protocol.params import parameter_set
from keepaway.runner.embedded import ArenaSpec
from keepaway.runner.run import RunOptions, run
from keepaway.server.episode_log import read_kwy
from keepaway.server.game_log import read_rcg
from keepaway.server.referee import END_OUT, END_TAKEN
from keepaway.core.objects import BALL
from keepaway.server.world import COUNT_DASH, COUNT_KICK, COUNT_TURN
from keepaway.runner.batched import BatchedArenas
from keepaway.trainer.behaviour import (
    CURVE_CYCLES,
    REFERENCE_CAMPAIGNS,
    Compared,
    Episode,
    Estimate,
    BehaviourStats,
    Verdict,
    behaviour_statistics,
    compare,
    game_log_episodes,
    judge,
    load_reference,
    measure_policy,
    record_batched,
    reference_entry,
    spread_estimates,
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
# issue's 10.50 s): always hold 2.77-2.98 s, random 5.09-5.34 s, hand-coded 10.39-12.15 s.
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
            keeper_taker_m: float = 10.0, dashes: dict[int, list[int]] | None = None,
            turns: dict[int, list[int]] | None = None) -> Episode:
    """A 3v2 episode of ``cycles`` rows: the ball at the origin, the takers ``taker_distance[t]`` (default
    5 m) either side of it on the x axis, each keeper ``keeper_taker_m`` straight above or below a taker
    (its nearest). ``kicks``: step -> objects whose kick reached the ball; ``ball_speed``: row -> speed;
    ``dashes``, ``turns``: step -> objects whose dash (turn) was executed."""
    d = np.full(cycles, 5.0) if taker_distance is None else np.asarray(taker_distance, dtype=float)
    pos = np.zeros((cycles, N, 2))
    pos[:, TAKER_1, 0] = -d
    pos[:, TAKER_1 + 1, 0] = d
    for keeper, (taker, side) in zip(range(1, K + 1), ((TAKER_1, 1), (TAKER_1 + 1, 1), (TAKER_1, -1))):
        pos[:, keeper] = pos[:, taker] + (0.0, side * keeper_taker_m)
    vel = np.zeros((cycles, 2))
    for t, speed in (ball_speed or {}).items():
        vel[t] = (0.0, speed)
    kicked, dashed, turned = (np.zeros((cycles, N), dtype=bool) for _ in range(3))
    for flags, steps in ((kicked, kicks), (dashed, dashes), (turned, turns)):
        for step, objects in (steps or {}).items():
            flags[step, objects] = True
    return Episode(pos=pos, ball_vel=vel, kicks=kicked, dashes=dashed, turns=turned, end=end)


def stats(*episodes: Episode):
    return behaviour_statistics(list(episodes), K, STEP_S)


# --------------------------------------------------------------------------------------------------
# the definitions, on hand-made episodes


def test_hold_time_spread_and_end_shares():
    s = stats(episode(10, END_OUT), episode(20), episode(30), episode(40, END_OUT))
    sd = math.sqrt(5.0 / 3.0)  # of 1, 2, 3, 4 s with n - 1
    assert s.episodes == 4
    assert s.hold_s.value == pytest.approx(2.5) and s.hold_s.se == pytest.approx(sd / 2.0)
    assert s.hold_sd_s.value == pytest.approx(sd)
    assert (s.hold_median_s.value, s.hold_p10_s.value, s.hold_p90_s.value) == pytest.approx((2.5, 1.3, 3.7))  # linear
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


def test_the_approach_is_the_first_row_within_5_m_and_within_2_m():
    s = stats(episode(4, taker_distance=[6.0, 5.0, 2.5, 2.0]),  # 5 m at t = 1, 2 m at t = 3
              episode(3, taker_distance=[4.0, 3.0, 1.0]))  # 5 m at t = 0, 2 m at t = 2
    assert (s.taker_within_5m_t.value, s.taker_within_5m_t.se) == pytest.approx((0.5, 0.5))  # sd of 1, 0: 0.707
    assert (s.taker_within_2m_t.value, s.taker_within_2m_t.se) == pytest.approx((2.5, 0.5))


def test_takers_near_a_held_ball_count_their_dashes_and_turns_with_episodes_as_clusters():
    # A: keeper 1 holds the ball (0.5 m) in rows 0-2; both takers 2 m away in rows 0-1, 4 m in row 2: four
    # taker rows in the band, three dashes and one turn in them; row 3 is the last row, not counted.
    a = episode(4, taker_distance=[2.0, 2.0, 4.0, 2.0], dashes={0: [TAKER_1], 1: [TAKER_1, TAKER_1 + 1], 3: [TAKER_1]},
                turns={0: [TAKER_1 + 1], 2: [TAKER_1]})
    a.pos[:3, KEEPER_1] = (0.0, 0.5)
    # B: held in every row, takers 1.5 m away: rows 0-1 count (four taker rows), one dash, no turn.
    b = episode(3, taker_distance=[1.5] * 3, dashes={0: [TAKER_1], 2: [TAKER_1]})
    b.pos[:, KEEPER_1] = (0.0, -1.0)  # exactly 1 m: held
    s = stats(a, b)
    # dash: (3 + 1) / 8; residuals 3 - 0.5 * 4 = 1 and -1: sqrt(2 / (2 * 1)) / 4
    assert (s.taker_dash_share_near_held.value, s.taker_dash_share_near_held.se) == pytest.approx((0.5, 0.25))
    # turn: 1 / 8; residuals 0.5 and -0.5: sqrt(0.5 / 2) / 4
    assert (s.taker_turn_share_near_held.value, s.taker_turn_share_near_held.se) == pytest.approx(
        (0.125, math.sqrt(0.25) / 4))
    assert stats(episode(3)).taker_dash_share_near_held is None  # no keeper near the ball: no such rows


def test_the_spread_has_reproducible_bootstrap_standard_errors():
    rng = np.random.default_rng(3)
    hold_s = rng.normal(10.0, 1.0, 2000)
    sd, median, p10, p90 = spread_estimates(hold_s)
    assert (sd.value, median.value) == pytest.approx((hold_s.std(ddof=1), np.median(hold_s)))
    # large-sample errors of a normal sample: sd / sqrt(2 (n - 1)); the median's sqrt(pi / 2) sd / sqrt(n);
    # a quantile's sqrt(p (1 - p) / n) / density (p = 0.1: density 0.1755 / sd)
    assert sd.se == pytest.approx(1.0 / math.sqrt(2 * 1999), rel=0.15)
    assert median.se == pytest.approx(math.sqrt(math.pi / 2) / math.sqrt(2000), rel=0.15)
    for q in (p10, p90):
        assert q.se == pytest.approx(math.sqrt(0.09 / 2000) / 0.1755, rel=0.15)
    assert spread_estimates(hold_s) == (sd, median, p10, p90)  # a fixed seed
    assert spread_estimates(np.array([2.5])) == (Estimate(0.0), Estimate(2.5), Estimate(2.5), Estimate(2.5))


def test_a_statistic_is_within_tolerance_of_a_campaign_or_between_campaigns():
    def verdict(ours: float) -> Verdict:
        return Verdict("x", Estimate(ours), (Compared("x", Estimate(ours), Estimate(10.0, 0.1)),
                                             Compared("x", Estimate(ours), Estimate(13.0, 0.1))))

    assert verdict(11.0).within_tolerance  # 10 % of 10
    assert verdict(11.5).within_tolerance and not any(r.within_tolerance for r in verdict(11.5).rows)  # between
    assert verdict(14.29).within_tolerance and not verdict(14.31).within_tolerance  # 10 % of 13
    assert not verdict(8.99).within_tolerance and verdict(8.99).reference_range == (10.0, 13.0)


def test_campaigns_without_a_statistic_are_left_out_of_its_verdict():
    s = stats(episode(10, END_OUT), episode(20, taker_distance=np.linspace(6.0, 0.5, 20)), episode(30))
    old = reference_entry(s, "hold99", 99)
    for key in ("hold_spread_se_s", "taker_within_m", "takers_near_held_ball", "hold_cycles"):
        old.pop(key, None)  # as the reference file's first campaigns (no held ball here: never written)
    verdicts = {v.statistic: v for v in judge(s, [BehaviourStats.from_reference(old), s])}
    assert len(verdicts["hold time (s)"].rows) == len(verdicts["hold time sd (s)"].rows) == 2
    assert verdicts["hold time sd (s)"].rows[0].reference.se is None
    assert len(verdicts["taker within 5 m: first t (cycles)"].rows) == 1
    assert "takers 1-3 m from a held ball: dash share" not in verdicts  # no held ball in these episodes
    assert all(v.within_tolerance for v in verdicts.values())


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
    live = [f"{policy}{seed}" for policy in ("hand", "hold", "rand") for seed in (31, 51, 52, 53)]
    again = [f"{c}b" for c in live if not c.endswith("31")]  # the same server seeds played again (the data's README)
    assert sorted(REFERENCE) == sorted(["hand", "hand14", "hold", "hold12", "rand", "rand21", *live, *again])
    assert sorted(c for campaigns in REFERENCE_CAMPAIGNS.values() for c in campaigns) == sorted(REFERENCE)
    assert REFERENCE["rand21"].episodes == 1006 and REFERENCE["rand21"].hold_s.value == pytest.approx(5.21, abs=0.005)
    hold = REFERENCE["hold"]
    assert hold.episodes == 601 and hold.hold_s.value == pytest.approx(2.80, abs=0.005)
    assert hold.curve_takers.shape == (T, CURVE_CYCLES) and hold.curve_running[0] == 601
    assert all(row.difference == 0 for row in compare(hold, hold))
    assert REFERENCE["rand31"].episodes == 1000 and REFERENCE["rand31"].hold_s.value == pytest.approx(5.32, abs=0.005)
    assert {p: tuple(round(x, 2) for x in r) for p, r in REFERENCE_HOLD_S.items()} == {
        "hold": (2.77, 2.98), "random": (5.09, 5.34), "handcoded": (10.39, 12.15)}
    # the later live campaigns carry every statistic, and each episode's length
    hand53 = REFERENCE["hand53"]
    assert len(hand53.scalars()) == 19 and hand53.hold_sd_s.se > 0 and hand53.taker_dash_share_near_held.se > 0
    assert len(hand53.hold_cycles) == 1000 and hand53.hold_cycles.mean() / 10 == pytest.approx(hand53.hold_s.value)


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
    for flags, count in (("kicks", COUNT_KICK), ("dashes", COUNT_DASH), ("turns", COUNT_TURN)):
        seen = np.zeros((4, N), dtype=np.int64)
        for arena, e in zip(table.arena, episodes):
            seen[arena] += getattr(e, flags).sum(axis=0)
        np.testing.assert_array_equal(seen, recorded.world.counts[:, :, count])  # every arena from cycle 0
        assert seen[:, 1:K + 1].sum() > 0 and seen[:, K + 1:].sum() > 0, flags


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
    # the takers' dash and turn counters, shows 0 -> 25: taker 1's 15 -> 31 and 10 -> 19, taker 2's
    # 15 -> 31 and 10 -> 15
    assert e.dashes[:, K + 1:].sum(axis=0).tolist() == [16, 16] and e.turns[:, K + 1:].sum(axis=0).tolist() == [9, 5]
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
        for flags in ("kicks", "dashes", "turns"):
            np.testing.assert_array_equal(getattr(a, flags), getattr(b, flags))
    assert sum(e.kicks.sum() for e in recorded) > 0


def test_statistics_written_as_a_reference_entry_read_back_the_same():
    held = episode(35, kicks={2: [TAKER_1]}, taker_distance=[2.0] * 35, dashes={0: [TAKER_1]}, turns={1: [TAKER_1]})
    held.pos[:, KEEPER_1] = (0.0, 0.5)
    s = stats(episode(10, END_OUT, kicks={1: [KEEPER_1], 3: [KEEPER_2]}, ball_speed={2: 2.0}),
              episode(40, taker_distance=np.linspace(6.0, 0.5, 40)), held)
    back = BehaviourStats.from_reference(reference_entry(s, "rand99", 99))
    assert len(back.scalars()) == 19 and back.scalars() == s.scalars()
    np.testing.assert_array_equal(back.hold_cycles, [10, 40, 35])
    for field in ("curve_running", "curve_takers", "curve_nearer"):
        np.testing.assert_array_equal(getattr(back, field), getattr(s, field))
    assert back.episodes == 3


# --------------------------------------------------------------------------------------------------
# the harness's command line (benchmarks/side_by_side.py)

HARNESS = Path(__file__).resolve().parent.parent / "benchmarks" / "side_by_side.py"


def harness(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(HARNESS), *args], capture_output=True, text=True, timeout=300)


def test_the_harness_refuses_two_references_and_logs_it_cannot_read_in_one_line(tmp_path):
    both = harness("--reference", str(tmp_path), "--reference-logs", str(tmp_path))
    assert both.returncode == 2 and both.stderr.splitlines()[-1].endswith("give one")
    missing = harness("--reference-logs", str(tmp_path), "--policies", "hold", "--episodes", "4")
    assert missing.returncode == 1 and missing.stderr.count("\n") == 1
    assert missing.stderr.startswith("side_by_side: cannot read ") and "hold/game.rcg" in missing.stderr


def test_the_harness_measures_kept_logs_as_the_reference(tmp_path):
    # our own game log of 6 always-hold episodes, kept as the reference stack's --log-dir would keep it
    spec = ArenaSpec(CURRENT, seed=5, pass_policy="hold")
    run(RunOptions(spec, episodes=6, mode="batched", batch=1, out=tmp_path, parameter_set="current",
                   game_log_arenas=(0,)), progress=False)
    kept = tmp_path / "logs" / "hold"
    kept.mkdir(parents=True)
    (tmp_path / "keepaway-arena0.rcg").rename(kept / "game.rcg")
    (tmp_path / "keepaway.kwy").rename(kept / "game.kwy")
    measured = harness("--reference-logs", str(tmp_path / "logs"), "--policies", "hold", "--episodes", "5",
                       "--batch", "2", "--seed", "5")
    assert measured.returncode == 0, measured.stderr
    assert "hold: reference logs, 5 episodes" in measured.stderr
    verdicts = [line for line in measured.stdout.splitlines() if line.startswith("| hold | ")]
    assert len(verdicts) == 19 and "(1) |" in verdicts[0]  # every statistic, against the one logged campaign


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
@pytest.mark.parametrize("policy", ["hold", "random", "handcoded"])
def test_every_behaviour_statistic_is_within_tolerance_of_the_reference_campaigns(policy):
    verdicts = judge(ours(policy), [REFERENCE[c] for c in REFERENCE_CAMPAIGNS[policy]])
    for v in verdicts:
        low, high = v.reference_range
        print(f"{policy}: {v.statistic}: {v.ours.value:.3f} against {low:.3f}-{high:.3f} "
              f"({'within' if v.within_tolerance else 'BEYOND'})")
    assert len(verdicts) == len(ours(policy).scalars()) == 19  # the campaigns together have every statistic
    assert [v.statistic for v in verdicts if not v.within_tolerance] == []

"""Pass learning in the batched mode (runner/batched.py, ``pass_policy="learned"``).

docs/players.md §2 and §6.3: each keeper of each arena learns its own SMDP
Sarsa Pass policy; rewards are cycles between its decisions, the terminal reward runs to the new
episode's first cycle; the mode changes only between episodes. The reference is the embedded game of
``tests/test_batched.py`` with learning player agents (``agents.player.sarsa_pass_factory``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from keepaway.agents.player import sarsa_pass_factory
from keepaway.agents.policy_file import getopen_theta_size
from keepaway.agents.sarsa import MODE_EXPLORE, MODE_GREEDY, MODE_LEARN, NO_ACTION, SarsaConfig
from keepaway.protocol.params import parameter_set
from keepaway.runner.batched import BatchedArenas
from keepaway.runner.embedded import ArenaSpec, EmbeddedGame, embedded_episodes
from keepaway.runner.job import BATCHED_SARSA
from keepaway.trainer.curves import welch_p_value
from test_batched import table_rows

PARAMS = parameter_set("classic")
K, T = 3, 2
SMALL = SarsaConfig(table_size=1 << 15, max_traces=1024, transition_log_size=256)


def learning(batch: int, seed: int, **kw) -> BatchedArenas:
    kw.setdefault("sarsa", SMALL)
    return BatchedArenas(PARAMS, batch, seed, pass_policy="learned", threads=kw.pop("threads", 1), **kw)


def test_a_learning_arena_learns_the_weights_of_the_embedded_game_with_learning_players():
    # Batched arena 0 seeded 4 and the embedded game seeded 4 whose keepers run Sarsa in learn mode from
    # zero weights: the same episodes, the same transitions and, once the keepers have heard the
    # boundary of the fifth episode (their terminal update), the same weights and collision tables.
    factory = sarsa_pass_factory(None, MODE_LEARN, SMALL)
    game = EmbeddedGame(ArenaSpec(PARAMS, K, T, 4, pass_policy="learned"), pass_learner=factory)
    batched = learning(1, 4)
    records = []
    while len(records) < 5:
        record = game.cycle()
        if record is not None:
            records.append(record)
    table = batched.run(episodes_per_arena=5)
    assert table_rows(table)[:, :3].tolist() == [[r.episode, r.start_cycle, r.end_cycle] for r in records]
    game.perceive()  # the next cycle's percepts carry the referee's episode message
    decided = 0
    for k in range(K):
        mem = game.players[k][1].learner.memory
        for name in ("weights", "hash_check", "log_count", "log_action", "log_reward", "log_terminal"):
            np.testing.assert_array_equal(getattr(batched.sarsa, name)[k], getattr(mem, name)[0], err_msg=name)
        assert batched.sarsa.last_action[k] == NO_ACTION  # every episode closed
        decided += int(mem.log_count[0] > 0)
    assert decided >= 2 and np.any(batched.sarsa.weights != 0.0)


def test_rewards_are_cycles_and_the_terminal_reward_reaches_the_next_episodes_first_cycle():
    # Episode by episode (batch 1), each keeper's new transitions: whole cycles >= 1, the last one
    # terminal (next action none) and no other; the rewards telescope from its first decision d >=
    # start to the next episode's first cycle = end, so they sum to end - d <= end - start.
    arenas = learning(1, 8)
    seen = np.zeros(K, dtype=np.int64)
    closed = 0
    for _ in range(6):
        table = arenas.run(episodes_per_arena=1)
        length = int(table.hold_cycles[0])
        for k in range(K):
            new = slice(int(seen[k]), int(arenas.sarsa.log_count[k]))
            seen[k] = arenas.sarsa.log_count[k]
            reward, terminal = arenas.sarsa.log_reward[k, new], arenas.sarsa.log_terminal[k, new]
            if len(reward) == 0:
                continue  # never had the ball: no update
            closed += 1
            assert np.all(reward >= 1.0) and np.all(reward == np.round(reward))
            assert terminal.tolist() == [False] * (len(reward) - 1) + [True]
            assert arenas.sarsa.log_next_action[k, new][-1] == NO_ACTION
            assert reward.sum() <= length
    assert closed >= 6


def test_same_seed_learns_the_same_weights_whatever_the_threads():
    runs = [learning(3, 2, threads=threads) for threads in (1, 2)]
    tables = [r.run(episodes_per_arena=5) for r in runs]
    np.testing.assert_array_equal(table_rows(tables[0]), table_rows(tables[1]))
    np.testing.assert_array_equal(runs[0].sarsa.weights, runs[1].sarsa.weights)
    assert np.any(runs[0].sarsa.weights != 0.0)
    other = learning(3, 3)
    other.run(episodes_per_arena=5)
    assert not np.array_equal(other.sarsa.weights, runs[0].sarsa.weights)
    # each keeper its own weights: no two rows equal (five episodes: every keeper has decided)
    rows = runs[0].sarsa.weights
    assert len({rows[i].tobytes() for i in range(len(rows))}) == len(rows)


def test_modes_change_only_at_an_episode_start_and_only_learn_updates():
    arenas = learning(2, 5)
    arenas.run(max_cycles=30)  # mid-episode
    arenas.set_pass_mode("greedy")
    assert np.all(arenas.sarsa.mode == MODE_LEARN)  # the running episodes finish learning
    first = arenas.run(total_episodes=2)  # one episode per arena: the one under way
    assert np.all(arenas.sarsa.mode == MODE_LEARN) and len(first) == 2
    weights = arenas.sarsa.weights.copy()
    logged = arenas.sarsa.log_count.copy()
    arenas.run(episodes_per_arena=3)
    assert np.all(arenas.sarsa.mode == MODE_GREEDY)
    np.testing.assert_array_equal(arenas.sarsa.weights, weights)  # greedy: no updates
    assert np.all(arenas.sarsa.log_count >= logged) and arenas.sarsa.log_count.sum() > logged.sum()
    arenas.set_pass_mode("explore")
    arenas.run(episodes_per_arena=3)
    assert np.all(arenas.sarsa.mode == MODE_EXPLORE)
    np.testing.assert_array_equal(arenas.sarsa.weights, weights)  # explore: no updates either
    arenas.set_pass_mode("learn")
    arenas.run(episodes_per_arena=3)
    assert not np.array_equal(arenas.sarsa.weights, weights)


def test_a_mode_set_before_the_first_cycle_applies_at_once():
    arenas = learning(1, 5)
    arenas.set_pass_mode("greedy")
    assert np.all(arenas.sarsa.mode == MODE_GREEDY)
    arenas.run(episodes_per_arena=2)
    np.testing.assert_array_equal(arenas.sarsa.weights, 0.0)
    assert BatchedArenas(PARAMS, 1, 0, pass_policy="learned", pass_mode="explore",
                         sarsa=SMALL).sarsa.mode.tolist() == [MODE_EXPLORE] * K


def test_policies_export_and_import_per_keeper_or_shared():
    trained = learning(2, 6)
    trained.run(episodes_per_arena=3)
    grid = trained.pass_policy_arrays()
    assert len(grid) == 2 and all(len(row) == K for row in grid)
    np.testing.assert_array_equal(grid[1][2]["pass_weights"], trained.sarsa.weights[1 * K + 2])
    fresh = learning(2, 9)
    fresh.load_pass_arrays(grid[0][1])  # one policy for every keeper of every arena
    assert all(np.array_equal(w, grid[0][1]["pass_weights"]) for w in fresh.sarsa.weights)
    fresh.load_pass_arrays(grid[1])  # one team, the same in every arena
    for b in range(2):
        for k in range(K):
            np.testing.assert_array_equal(fresh.sarsa.hash_check[b * K + k], grid[1][k]["pass_hash_check"])
    fresh.load_pass_arrays(grid)
    np.testing.assert_array_equal(fresh.sarsa.weights, trained.sarsa.weights)
    with pytest.raises(ValueError, match="give one policy"):
        fresh.load_pass_arrays(grid[0][:2])
    with pytest.raises(ValueError, match="shape"):
        fresh.load_pass_arrays({"pass_weights": np.zeros(8), "pass_hash_check": np.zeros(8, np.int32),
                                "pass_hash_counts": np.zeros(3, np.int64)})
    with pytest.raises(ValueError, match="no Pass learners"):
        BatchedArenas(PARAMS, 1, 0).set_pass_mode("greedy")


# (pass policy, GetOpen policy, Sarsa mode, step size) of the arenas of one mixed batch: learners of two
# step sizes and two modes, a learned GetOpen with and without Pass learners, hand-coded and random Pass
MIXED = (("handcoded", "handcoded", "learn", SMALL.alpha), ("learned", "learned", "learn", 0.5),
         ("random", "learned", "learn", SMALL.alpha), ("learned", "handcoded", "explore", SMALL.alpha),
         ("handcoded", "random", "greedy", SMALL.alpha), ("learned", "handcoded", "learn", 0.03))


def test_arenas_of_different_configurations_share_a_batch_and_each_plays_and_learns_as_alone():
    theta = np.random.default_rng(4).uniform(-0.5, 0.5, getopen_theta_size(K, T))
    seeds = [40 + a for a in range(len(MIXED))]
    passes, getopens, modes, alphas = (list(column) for column in zip(*MIXED))
    mixed = BatchedArenas(PARAMS, len(MIXED), seeds, pass_policy=passes, getopen_policy=getopens,
                          getopen_theta=theta, pass_mode=modes, alpha=alphas, sarsa=SMALL, threads=2)
    assert mixed.learner_arenas.tolist() == [1, 3, 5] and len(mixed.sarsa.mode) == 3 * K
    table = mixed.run(episodes_per_arena=4)
    grid = mixed.pass_policy_arrays()
    assert [row is None for row in grid] == [p != "learned" for p in passes]
    for a, (pass_policy, getopen_policy, mode, alpha) in enumerate(MIXED):
        learns = pass_policy == "learned"
        alone = BatchedArenas(PARAMS, 1, [seeds[a]], pass_policy=pass_policy, getopen_policy=getopen_policy,
                              getopen_theta=theta if getopen_policy == "learned" else None, pass_mode=mode,
                              alpha=alpha, sarsa=SMALL if learns else None, threads=1)
        np.testing.assert_array_equal(table_rows(table, a), table_rows(alone.run(episodes_per_arena=4)))
        if learns:
            for mine, theirs in zip(grid[a], alone.arena_pass_arrays(0), strict=True):
                for name in mine:
                    np.testing.assert_array_equal(mine[name], theirs[name], err_msg=f"arena {a} {name}")
    weights = [np.abs(row[0]["pass_weights"]).sum() for row in grid if row is not None]
    assert weights[0] > 0.0 and weights[1] == 0.0 and weights[2] > 0.0  # explore does not update
    with pytest.raises(ValueError, match="arena 0 has no Pass learners"):
        mixed.arena_pass_arrays(0)
    mixed.load_pass_arrays(grid)  # None where an arena has no learners
    with pytest.raises(ValueError, match="one per arena"):
        BatchedArenas(PARAMS, 2, 0, pass_policy=["learned"])


def test_the_batched_default_table_is_small_and_holds_a_keepers_tiles():
    # 2^16 slots: 16 B per slot (weight 8, check 4, trace slot 4) = 1 MiB per keeper, against 16 MiB at
    # the original 2^20 (runner/batched.py docstring).
    assert BATCHED_SARSA.table_size == 1 << 16
    arenas = BatchedArenas(PARAMS, 1, 1, pass_policy="learned")
    per_row = sum(a[0].nbytes for a in (arenas.sarsa.weights, arenas.sarsa.hash_check, arenas.sarsa.trace_slot))
    assert per_row == (1 << 16) * 16
    arenas.run(episodes_per_arena=20)
    used = (arenas.sarsa.hash_check != -1).sum(axis=1)
    assert np.all(used < (1 << 16) // 4)


@pytest.mark.slow
def test_learned_pass_holds_the_ball_longer_than_the_untrained_policy():
    # P:L-GO:HC: 4 arenas learn for 4 x 1,600 = 6,400 episodes; then their greedy policies and the
    # untrained ones (zero weights, greedy = uniform ties, i.e. random passing) play 416 episodes each;
    # Welch t-test on the hold times. Experience per learner is what counts (arenas learn
    # independently). With players that follow the C++ skills and talk, 800 episodes per learner gain
    # about 4 cycles, too little to tell apart on 208 episodes (p 0.01-0.2 by seed); 1,600 gain 11-14
    # (p ~ 1e-12 on seeds 0 and 1).
    trained = learning(4, 0, sarsa=BATCHED_SARSA)
    trained.run(episodes_per_arena=1600)
    trained.set_pass_mode("greedy")
    learned = trained.run(episodes_per_arena=104).hold_cycles
    untrained = learning(16, 1000, sarsa=BATCHED_SARSA, pass_mode="greedy").run(episodes_per_arena=26).hold_cycles
    p_value = welch_p_value(learned, untrained)
    print(f"P:L {learned.mean():.1f} cycles, untrained {untrained.mean():.1f} cycles, Welch p = {p_value:.2g}")
    assert learned.mean() > untrained.mean()
    assert p_value < 0.05


def test_a_hive_mind_arena_learns_one_table_per_team_whatever_the_threads():
    # The three keepers of an arena update one table (their exported policies are the same arrays), two
    # arenas learn two tables, and the games do not depend on how many threads step them.
    hive = replace(SMALL, hive_mind=True)
    one, two = learning(2, 6, sarsa=hive), learning(2, 6, sarsa=hive, threads=2)
    first, second = one.run(episodes_per_arena=4), two.run(episodes_per_arena=4)
    assert table_rows(first).tolist() == table_rows(second).tolist()
    np.testing.assert_array_equal(one.sarsa.weights, two.sarsa.weights)
    assert one.sarsa.weights.shape[0] == 2 and np.all(np.any(one.sarsa.weights != 0.0, axis=1))
    grid = one.pass_policy_arrays()
    for row in grid:
        assert all(np.array_equal(p["pass_weights"], row[0]["pass_weights"]) for p in row)
    assert not np.array_equal(grid[0][0]["pass_weights"], grid[1][0]["pass_weights"])
    decided = [int(n) for n in one.sarsa.log_count[:K]]
    assert sum(n > 0 for n in decided) >= 2  # more than one keeper of arena 0 wrote into its table
    fresh = learning(2, 9, sarsa=hive)
    fresh.load_pass_arrays(grid)
    np.testing.assert_array_equal(fresh.sarsa.weights, one.sarsa.weights)


def test_a_policy_files_pass_weights_play_greedily_in_the_batched_mode_as_in_the_embedded(tmp_path):
    """``keepaway run --mode batched --pass learned --policy FILE`` plays the file's Pass weights greedily,
    with the file's tile coding, as the embedded mode's players do: the same episodes; without the file the
    batched keepers start from zero weights and play other episodes."""
    from dataclasses import asdict
    from itertools import islice

    from keepaway.agents.policy_file import load_policy, pack_pass_arrays, save_policy
    from keepaway.runner.run import RunOptions, batched_episodes

    trained = learning(1, 11)
    trained.run(episodes_per_arena=40)
    path = tmp_path / "policy.npz"
    save_policy(path, pass_arrays=pack_pass_arrays(trained.arena_pass_arrays(0)), config={"sarsa": asdict(SMALL)})
    spec = ArenaSpec(PARAMS, K, T, 5, pass_policy="learned", policy=load_policy(path))

    def ends(episodes) -> list[tuple[int, int]]:
        return [(record.start_cycle, record.end_cycle) for record, _ in islice(episodes, 6)]

    batched = ends(batched_episodes(RunOptions(spec, 6, mode="batched", batch=1, out=tmp_path, game_log=False)))
    embedded = ends(embedded_episodes(spec))
    untrained = ends(batched_episodes(RunOptions(replace(spec, policy=None), 6, mode="batched", batch=1,
                                                 out=tmp_path, game_log=False)))
    assert batched == embedded
    assert batched != untrained

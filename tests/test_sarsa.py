"""SMDP Sarsa with tile coding, the Pass learner (spec `keepaway-agents.md` 5, `keepaway-task.md` 5)."""

from __future__ import annotations

import numpy as np
import pytest

from keepaway.agents.keeper import NO_PASS_DECISION, PASS_DECISION_START, PASS_DECISION_STEP
from keepaway.agents.sarsa import (
    MODE_EXPLORE,
    MODE_GREEDY,
    MODE_LEARN,
    NO_ACTION,
    SarsaConfig,
    SarsaLearner,
    action_value,
    code_variable_order,
    glibc_rand,
    load_policy_arrays,
    new_memory,
    policy_arrays,
    quantize,
    restart_learners,
    start_episode,
    step,
    tile_widths,
    tiling_coordinate,
    unh_hash,
    unh_random_table,
)

ALPHA_PER_TILE = 0.125 / 416  # alpha / active tiles: each active weight moves by this times delta
DETERMINISTIC = SarsaConfig(epsilon=0.0)


def far_state(k: int) -> np.ndarray:
    """Every variable at 40 k: states k != k' are more than a tile width (3 m, 10 deg) apart in every
    variable, so they share no tile."""
    return np.full(13, 40.0 * k)


def test_glibc_rand_sequence():
    # glibc: srand(1) -> 1804289383, 846930886, 1681692777, 1714636915; srand(0) behaves as srand(1).
    expected = [1804289383, 846930886, 1681692777, 1714636915]
    assert glibc_rand(1, 4).tolist() == expected
    assert glibc_rand(0, 4).tolist() == expected


def test_unh_table_packs_low_bytes_of_rand():
    # Low bytes of 0x6B8B4567, 0x327B23C6, 0x643C9869, 0x66334873 -> 0x67C66973.
    table = unh_random_table()
    assert table.shape == (2048,)
    assert table[0] == 0x67C66973


def test_tile_coordinates_by_hand():
    # x = 7.3 m / 3.0 m = 2.4333; q = floor(32 * 2.4333) = floor(77.87) = 77.
    # coordinate_j = q - ((q - j) mod 32): j=0: 77 - 13 = 64; j=5: 77 - 8 = 69; j=13: 77 - 0 = 77;
    # j=14: 77 - 31 = 46; j=31: 77 - 14 = 63.
    q = quantize(7.3, 3.0, 32)
    assert q == 77
    assert [tiling_coordinate(q, j, 32) for j in (0, 5, 13, 14, 31)] == [64, 69, 77, 46, 63]
    # 45 deg / 10 deg = 4.5 -> q = 144; j=0: 144 - 16 = 128; j=17: 144 - 31 = 113.
    assert quantize(45.0, 10.0, 32) == 144
    assert [tiling_coordinate(144, j, 32) for j in (0, 17)] == [128, 113]
    # q = 0, j = 5: 0 - ((0 - 5) mod 32) = 0 - 27 = -27.
    assert tiling_coordinate(0, 5, 32) == -27


def test_quantize_rounds_through_float32_like_the_cpp_float_argument():
    # 1 - 1e-9 is 1.0 in float32 (spacing 2^-24 ~ 6e-8 below 1): q = 32, not 31.
    assert quantize(1.0 - 1e-9, 1.0, 32) == 32


def test_unh_hash_is_a_sum_of_table_words():
    # hash_UNH(coords, m, inc) = sum_i rndseq[(c_i + inc * i) mod 2048] mod m; coords (coordinate 64,
    # tiling 0, action 1, variable 2) at increment 449: slots 64, 449, 1 + 898 = 899, 2 + 1347 = 1349.
    t = unh_random_table()
    words = int(t[64]) + int(t[449]) + int(t[899]) + int(t[1349])
    assert unh_hash(64, 0, 1, 2, 449, 1 << 20) == words % (1 << 20)
    # A negative coordinate wraps into the table like the C++ loop: -27 -> 2021.
    words = int(t[2021]) + int(t[5 + 449]) + int(t[898]) + int(t[1347])
    assert unh_hash(-27, 5, 0, 0, 449, 2147483647) == words % 2147483647


def test_widths_paper_and_code():
    paper = tile_widths(SarsaConfig(), 3, 2)
    np.testing.assert_array_equal(paper, [3.0] * 11 + [10.0] * 2)
    # Code widths (keepaway-agents.md 4) in pass_state order: dist(K1,C) 2, dist(K2,C) 2, dist(K3,C) 3,
    # dist(T1,C) 3, dist(T2,C) 3, dist(K1,K2) 2, dist(K1,K3) 3, dist(K1,T1) 2, dist(K1,T2) 3, 4, 4, 10, 10.
    code = tile_widths(SarsaConfig(code_widths=True), 3, 2)
    np.testing.assert_array_equal(code, [2, 2, 3, 3, 3, 2, 3, 2, 3, 4, 4, 10, 10])
    # C++ order dist(K1,C), dist(K1,K2..3), dist(K1,T1..2), dist(K2..3,C), dist(T1..2,C), min dist, angle.
    assert code_variable_order(3, 2).tolist() == [0, 5, 6, 7, 8, 1, 2, 3, 4, 9, 10, 11, 12]
    assert len(tile_widths(SarsaConfig(), 4, 3)) == 19


def test_416_distinct_active_tiles_per_action():
    learner = SarsaLearner()
    learner.start(np.linspace(1.0, 90.0, 13))
    tiles = learner.memory.tiles[0]
    assert tiles.shape == (3, 416)
    assert all(len(set(tiles[a].tolist())) == 416 for a in range(3))
    assert len(set(tiles.ravel().tolist())) == 3 * 416


def test_collision_table_gives_distinct_tiles_distinct_weights():
    # 1248 tiles in 2048 slots: many home slots collide, re-probing still separates them; loading the
    # same state again walks the same probe sequences to the same slots (twice the probes, no new slot).
    learner = SarsaLearner(config=SarsaConfig(table_size=2048))
    state = np.linspace(1.0, 90.0, 13)
    learner.start(state)
    first = learner.memory.tiles[0].copy()
    calls, clear_hits, collisions = learner.memory.hash_counts[0]
    assert len(set(first.ravel().tolist())) == 1248
    assert calls == 1248 and collisions > 0
    learner.start(state)
    np.testing.assert_array_equal(learner.memory.tiles[0], first)
    assert learner.memory.hash_counts[0, 2] == 2 * collisions
    assert np.count_nonzero(learner.memory.hash_check[0] != -1) == 1248


def test_full_table_raises():
    learner = SarsaLearner(config=SarsaConfig(table_size=1024))
    with pytest.raises(RuntimeError):
        learner.start(far_state(0))


def test_first_step_moves_each_active_weight_by_alpha_over_416_delta():
    # Weights 0: Q(s0, a0) = 0, Q(s1, a1) = 0; reward 5 -> delta = 5 - 0 + 0 = 5; each of a0's 416
    # tiles in s0 gets 0.125 / 416 * 5 = 0.0015024; Q(s0, a0) becomes 416 * that = 0.625 = alpha delta.
    learner = SarsaLearner(config=DETERMINISTIC)
    a0 = learner.start(far_state(0))
    tiles0 = learner.memory.tiles[0, a0].copy()
    learner.step(5.0, far_state(1))
    weights = learner.memory.weights[0]
    np.testing.assert_allclose(weights[tiles0], ALPHA_PER_TILE * 5.0)
    assert np.count_nonzero(weights) == 416
    assert weights[tiles0].sum() == pytest.approx(0.625)


def test_terminal_update_has_no_bootstrap():
    # start(s0) -> a0, end(10): delta = 10 - 0 -> each tile 0.125 / 416 * 10, Q(s0, a0) = 1.25.
    # Next episode from s0 (greedy picks a0): end(10) -> delta = 10 - 1.25 = 8.75, Q = 1.25 + 0.125 * 8.75.
    learner = SarsaLearner(config=DETERMINISTIC)
    a0 = learner.start(far_state(0))
    tiles0 = learner.memory.tiles[0, a0].copy()
    learner.end(10.0)
    np.testing.assert_allclose(learner.memory.weights[0, tiles0], ALPHA_PER_TILE * 10.0)
    assert learner.memory.last_action[0] == NO_ACTION
    learner.end(99.0)  # no decision this episode: nothing happens
    np.testing.assert_allclose(learner.memory.weights[0, tiles0], ALPHA_PER_TILE * 10.0)
    assert learner.start(far_state(0)) == a0
    assert learner.q_values()[a0] == pytest.approx(1.25)
    learner.end(10.0)
    assert learner.memory.weights[0, tiles0].sum() == pytest.approx(1.25 + 0.125 * 8.75)


def test_step_bootstraps_and_recomputes_the_chosen_value_after_the_update():
    # Episode 1: start(s0) -> a, end(8): Q(s0, a) = 0.125 * 8 = 1.
    # Episode 2: start(s0) -> a (Q 1 > 0); step(4, s0) -> a again; delta = 4 - 1 + 1 = 4 ->
    # Q(s0, a) = 1 + 0.125 * 4 = 1.5, cached as the recomputed Q(s', a').
    # end(0): delta = 0 - 1.5 -> Q(s0, a) = 1.5 - 0.125 * 1.5 = 1.3125 (a stale cache would give 1.375).
    learner = SarsaLearner(config=DETERMINISTIC)
    a = learner.start(far_state(0))
    learner.end(8.0)
    assert learner.start(far_state(0)) == a
    assert learner.step(4.0, far_state(0)) == a
    assert learner.q_values()[a] == pytest.approx(1.5)
    learner.end(0.0)
    assert learner.memory.weights[0, learner.memory.tiles[0, a]].sum() == pytest.approx(1.3125)


def test_greedy_mode_leaves_weights_unchanged_and_takes_the_argmax():
    learner = SarsaLearner(config=DETERMINISTIC)
    a0 = learner.start(far_state(0))
    learner.end(10.0)
    learner.mode = MODE_GREEDY
    before = learner.memory.weights.copy()
    for _ in range(50):
        assert learner.start(far_state(0)) == a0
        learner.step(3.0, far_state(1))
        learner.step(7.0, far_state(0))
        learner.end(2.0)
    np.testing.assert_array_equal(learner.memory.weights, before)


def test_mode_changes_only_between_episodes():
    learner = SarsaLearner()
    learner.start(far_state(0))
    with pytest.raises(RuntimeError):
        learner.mode = MODE_GREEDY
    learner.end(1.0)
    learner.mode = MODE_GREEDY
    assert learner.mode == MODE_GREEDY
    with pytest.raises(ValueError):
        learner.mode = 7


@pytest.mark.parametrize("mode", [MODE_LEARN, MODE_EXPLORE])
def test_epsilon_exploration_frequency(mode):
    # Q(s0, a0) = 1.25 > 0: a non-greedy action needs the epsilon draw (0.01) and then one of the 2
    # other actions (2/3): p = 0.00667; over 30000 starts sd = sqrt(p (1 - p) / 30000) = 0.00047.
    learner = SarsaLearner(seed=5)
    learner.mode = MODE_GREEDY
    a0 = learner.start(far_state(0))
    learner.memory.weights[0, learner.memory.tiles[0, a0]] = 1.25 / 416
    learner.end(0.0)
    learner.mode = mode
    before = learner.memory.weights.copy()
    n = 30000
    actions = np.array([learner.start(far_state(0)) for _ in range(n)])
    assert abs(np.mean(actions != a0) - 0.01 * 2 / 3) < 5 * 0.00047
    if mode == MODE_EXPLORE:
        learner.step(5.0, far_state(1))
        learner.end(5.0)
        np.testing.assert_array_equal(learner.memory.weights, before)


def test_greedy_ties_are_broken_uniformly():
    # All Q = 0: each of 3 actions with p = 1/3; over 3000 starts sd = sqrt(3000 / 3 * 2 / 3) = 25.8.
    learner = SarsaLearner(seed=2, mode=MODE_GREEDY)
    counts = np.bincount([learner.start(far_state(0)) for _ in range(3000)], minlength=3)
    assert np.all(np.abs(counts - 1000) < 5 * 25.8)


def test_traces_with_lambda_by_hand():
    # lambda = 0.5, c = 0.125 / 416, states share no tiles, all Q start at 0.
    # step(2, s1): delta = 2 -> w[T0] = 2c; traces T0 -> 0.5, T1 = 1.
    # step(3, s2): delta = 3 - Q(s1, a1) + Q(s2, a2) = 3 -> w[T0] += 3 * 0.5 c = 3.5c total, w[T1] = 3c;
    #              traces T0 0.25, T1 0.5, T2 1.
    # end(4): delta = 4 - Q(s2, a2) = 4 -> w[T0] += 4 * 0.25 c = 4.5c, w[T1] += 4 * 0.5 c = 5c, w[T2] = 4c.
    learner = SarsaLearner(config=SarsaConfig(epsilon=0.0, trace_decay=0.5))
    tiles = []
    for k, reward in enumerate([None, 2.0, 3.0]):
        a = learner.start(far_state(0)) if reward is None else learner.step(reward, far_state(k))
        tiles.append(learner.memory.tiles[0, a].copy())
    learner.end(4.0)
    w = learner.memory.weights[0]
    np.testing.assert_allclose(w[tiles[0]], 4.5 * ALPHA_PER_TILE)
    np.testing.assert_allclose(w[tiles[1]], 5.0 * ALPHA_PER_TILE)
    np.testing.assert_allclose(w[tiles[2]], 4.0 * ALPHA_PER_TILE)
    assert np.count_nonzero(w) == 3 * 416


def test_traces_below_the_minimum_are_dropped():
    # lambda = 0.5: a trace 0.5^k survives while >= 0.01, i.e. k <= 6 (0.5^6 = 0.0156, 0.5^7 = 0.0078):
    # at most 7 generations of 416 tiles live at once.
    learner = SarsaLearner(config=SarsaConfig(trace_decay=0.5))
    learner.start(far_state(0))
    live = []
    for k in range(1, 9):
        learner.step(1.0, far_state(k))
        live.append(int(learner.memory.n_traces[0]))
    assert live == [416 * g for g in (2, 3, 4, 5, 6, 7, 7, 7)]


def test_replacing_traces_clear_the_other_actions_tiles():
    # lambda = 0.5, s' = s, a' != a: a's traces would decay to 0.5 but are cleared as tiles of another
    # action in s'; only a''s 416 traces (value 1) remain.
    learner = SarsaLearner(config=SarsaConfig(epsilon=0.0, trace_decay=0.5))
    a = learner.start(far_state(0))
    other = (a + 1) % 3
    learner.memory.weights[0, learner.memory.tiles[0, other]] = 1.0
    assert learner.step(1.0, far_state(0)) == other
    n = int(learner.memory.n_traces[0])
    assert n == 416
    assert set(learner.memory.trace_feature[0, :n].tolist()) == set(learner.memory.tiles[0, other].tolist())
    np.testing.assert_array_equal(learner.memory.trace_value[0, :n], 1.0)


def test_transitions_are_logged_in_a_ring():
    learner = SarsaLearner(config=SarsaConfig(transition_log_size=2))
    a0 = learner.start(far_state(0))
    a1 = learner.step(3.0, far_state(1))
    learner.end(4.0)
    log = learner.transitions()
    assert log["sequence"].tolist() == [0, 1]
    np.testing.assert_array_equal(log["state"], [far_state(0), far_state(1)])
    assert log["action"].tolist() == [a0, a1]
    assert log["reward"].tolist() == [3.0, 4.0]
    assert log["next_action"].tolist() == [a1, NO_ACTION]
    assert log["terminal"].tolist() == [False, True]
    a2 = learner.start(far_state(2))
    learner.end(6.0)
    log = learner.transitions()
    assert log["sequence"].tolist() == [1, 2]
    assert log["action"].tolist() == [a1, a2]
    assert learner.transitions(since=2)["reward"].tolist() == [6.0]


def test_weight_snapshot_is_sparse():
    learner = SarsaLearner(config=DETERMINISTIC)
    a0 = learner.start(far_state(0))
    tiles0 = np.sort(learner.memory.tiles[0, a0])
    learner.end(10.0)
    indices, values = learner.snapshot()
    np.testing.assert_array_equal(indices, tiles0)
    np.testing.assert_allclose(values, ALPHA_PER_TILE * 10.0)


def test_save_load_reproduces_values_and_tile_indices():
    # A small table makes collisions common, so which slot a new tile gets depends on the collision
    # table's history: a copy of the weights alone would map new tiles elsewhere.
    config = SarsaConfig(table_size=8192)
    rng = np.random.default_rng(0)
    teacher = SarsaLearner(config=config, seed=1)
    for _ in range(3):
        teacher.start(rng.uniform(0, 30, 13))
        teacher.step(2.0, rng.uniform(0, 30, 13))
        teacher.end(5.0)
    saved = teacher.save()
    assert set(saved) == {"pass_weights", "pass_hash_check", "pass_hash_counts"}
    student = SarsaLearner(config=config, seed=2)
    student.load(saved)
    weights_only = SarsaLearner(config=config, seed=2)
    weights_only.memory.weights[0] = saved["pass_weights"]
    new_state = rng.uniform(0, 30, 13)
    for learner in (teacher, student, weights_only):
        learner.mode = MODE_GREEDY
        learner.start(new_state)
    np.testing.assert_array_equal(student.memory.tiles, teacher.memory.tiles)
    np.testing.assert_array_equal(student.q_values(), teacher.q_values())
    assert not np.array_equal(weights_only.memory.tiles, teacher.memory.tiles)
    with pytest.raises(ValueError):
        SarsaLearner().load(saved)


@pytest.mark.parametrize("hive_mind", [False, True])
def test_restarted_learners_are_fresh_ones_with_their_own_policies_loaded(hive_mind):
    # Mid-episode learners with traces, a raised minimum trace and a logged transition: restarted in
    # place they must be, array for array, fresh learners into which each row's saved policy was loaded.
    config = SarsaConfig(table_size=1 << 15, max_traces=500, trace_decay=0.9, hive_mind=hive_mind)
    params = config.kernel()
    rng = np.random.default_rng(3)
    used = new_memory(config, 3, 2, rows=6, seed=1)
    for r in range(6):
        start_episode(used, r, rng.uniform(0, 30, 13), params)
        for _ in range(3):
            step(used, r, 2.0, rng.uniform(0, 30, 13), params)
    assert used.n_traces.min() > 0 and used.min_trace.max() > config.min_trace and used.log_count.min() > 0
    expected = new_memory(config, 3, 2, rows=6, seed=1, mode=MODE_GREEDY)
    for r in range(6):
        load_policy_arrays(expected, r, policy_arrays(used, r))
    restart_learners(used, config, MODE_GREEDY)
    for name, value in expected._asdict().items():
        # the caller seeds the streams; the remembered tile slots are a cache of what hashing gives
        # (tests/test_kernel_equivalence.py), kept by a restart and not carried by a policy
        if name != "rng" and not name.startswith("memo_"):
            np.testing.assert_array_equal(getattr(used, name), value, err_msg=name)


def pass_decisions(mem, decision, reward, state, out_action, sp) -> None:
    """Each row's learner call after keeper_decide, as ``runner.batched.learn_pass`` makes it: a row with
    PASS_DECISION_START starts its episode, one with PASS_DECISION_STEP steps with ``reward[r]``;
    ``out_action[r]`` gets the action; other rows are left alone."""
    for r in range(len(decision)):
        if decision[r] == PASS_DECISION_START:
            out_action[r] = start_episode(mem, r, state[r], sp)
        elif decision[r] == PASS_DECISION_STEP:
            out_action[r] = step(mem, r, reward[r], state[r], sp)


def test_pass_decisions_drives_independent_rows():
    # Row 0 starts then steps, row 1 never decides, row 2 gets a step with no open decision (starts).
    config = DETERMINISTIC
    mem = new_memory(config, 3, 2, rows=3, seed=4)
    params = config.kernel()
    states = np.stack([far_state(0), far_state(1), far_state(2)])
    actions = np.full(3, -9, dtype=np.int64)
    pass_decisions(mem, np.array([PASS_DECISION_START, NO_PASS_DECISION, PASS_DECISION_STEP]),
                   np.zeros(3), states, actions, params)
    assert actions[1] == -9
    assert mem.last_action.tolist() == [actions[0], NO_ACTION, actions[2]]
    assert not mem.weights.any()
    first = actions[0]
    tiles0 = mem.tiles[0, first].copy()
    pass_decisions(mem, np.array([PASS_DECISION_STEP, NO_PASS_DECISION, NO_PASS_DECISION]),
                   np.array([6.0, 0.0, 0.0]), states[[1, 1, 1]], actions, params)
    np.testing.assert_allclose(mem.weights[0, tiles0], ALPHA_PER_TILE * 6.0)
    assert np.count_nonzero(mem.weights[0]) == 416
    assert not mem.weights[1:].any()


def test_a_hive_mind_team_updates_one_table_through_its_own_traces():
    # tjpalmer's hive mind: keepers 0-2 share table 0, keepers 3-5 table 1; each keeper's traces are its
    # own, so keeper 1's step updates only the tiles keeper 1 decided in, in the table keeper 0 reads.
    config = SarsaConfig(epsilon=0.0, hive_mind=True)
    mem = new_memory(config, 3, 2, rows=6, seed=4)
    assert mem.table.tolist() == [0, 0, 0, 1, 1, 1] and mem.weights.shape[0] == 2
    params = config.kernel()
    states = np.stack([far_state(k) for k in range(6)])
    actions = np.zeros(6, dtype=np.int64)
    start = np.array([NO_PASS_DECISION, PASS_DECISION_START, NO_PASS_DECISION, NO_PASS_DECISION,
                      NO_PASS_DECISION, NO_PASS_DECISION])
    pass_decisions(mem, start, np.zeros(6), states, actions, params)
    tiles1 = mem.tiles[1, actions[1]].copy()
    assert mem.n_traces.tolist() == [0, 416, 0, 0, 0, 0]  # the team's other keepers hold no traces
    decisions = np.array([PASS_DECISION_START, PASS_DECISION_STEP, NO_PASS_DECISION, NO_PASS_DECISION,
                     NO_PASS_DECISION, NO_PASS_DECISION])  # keeper 0 starts, keeper 1 steps with reward 8
    pass_decisions(mem, decisions, np.array([0.0, 8.0, 0.0, 0.0, 0.0, 0.0]), states[[0, 2, 2, 3, 4, 5]], actions,
                   params)
    np.testing.assert_allclose(mem.weights[0, tiles1], ALPHA_PER_TILE * 8.0)
    assert np.count_nonzero(mem.weights[0]) == 416 and not mem.weights[1].any()
    # keeper 2 (never decided) reads keeper 1's update: Q = 416 tiles x 8 alpha / 416 = 1.0
    mem.tiles[2, 0] = mem.tiles[4, 0] = tiles1
    assert action_value(mem, 2, 0) == pytest.approx(0.125 * 8.0)
    assert action_value(mem, 4, 0) == 0.0  # the other team's table is untouched
    team = [policy_arrays(mem, r)["pass_weights"] for r in range(3)]
    assert all(np.array_equal(w, team[0]) for w in team)


def test_a_hive_mind_needs_whole_teams_and_a_lone_learner_keeps_a_table_of_its_own():
    with pytest.raises(ValueError, match="teams of 3"):
        new_memory(SarsaConfig(hive_mind=True), 3, 2, rows=4, seed=0)
    alone = SarsaLearner(config=SarsaConfig(hive_mind=True))  # a player process playing a hive mind's file
    assert alone.memory.table.tolist() == [0] and alone.memory.weights.shape[0] == 1

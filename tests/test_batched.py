"""The batched mode (runner/batched.py): many arenas with full noisy players in one process.

One arena of the batched mode must play the
game the distributed server and its player processes play. The reference here is the embedded game
(``runner.embedded.EmbeddedGame``): a ``server.arena.Arena`` and five ``agents.player.PlayerAgent``
exchanging encoded messages in the synchronous order.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from keepaway.agents.belief import empty_belief
from keepaway.agents.config import AgentConfig
from keepaway.agents.getopen import net_size
from keepaway.agents.sarsa import SarsaConfig
from keepaway.agents.tracking import new_model_state, new_see_buffer, see_row, write_belief_row
from keepaway.agents.worldmodel import WorldModel
from keepaway.protocol import encode
from keepaway.protocol import messages as m
from keepaway.protocol.landmarks import FLAG_POSITIONS, N_FLAGS, to_wire
from keepaway.protocol.messages import decode_for_player
from keepaway.protocol.params import parameter_set
from keepaway.runner.batched import CHUNK_CYCLES, BatchedArenas, see_to_model_row
from keepaway.runner.embedded import ArenaSpec, EmbeddedGame
from keepaway.server.arena import Arena
from keepaway.server.percept_wire import see_payload
from keepaway.server.perception import (
    CLOSE,
    FULL,
    NAMELESS,
    PARTIAL,
    UNSEEN,
    SeeBuffers,
    cone_factor,
    see_arena,
    see_due,
)
from keepaway.server.referee import END_OUT, END_TAKEN
from keepaway.server.world import new_world
from keepaway.trainer.curves import welch_p_value

PARAMS = parameter_set("classic")
KP = PARAMS.kernel()
K, T = 3, 2
N = 1 + K + T
THETA_SIZE = 91  # 10-5-5-1 net: 10*5 + 5 + 5*5 + 5 + 5 + 1


def wire(msg):
    """A message as the other side receives it (encoded, then decoded)."""
    return decode_for_player(encode(msg))


def table_rows(table, arena=None):
    keep = slice(None) if arena is None else table.arena == arena
    return np.column_stack((table.episode[keep], table.start_cycle[keep], table.end_cycle[keep], table.end[keep]))


# --------------------------------------------------------------------------------------------------
# percepts


def test_see_schedule_is_the_distributed_servers():
    # send_step 150 ms, step 100 ms, phase 0: a see falls in (100 (t-1), 100 t] for t = 0 (0 ms), 2 (150),
    # 3 (300), 5 (450), 6 (600); none for t = 1 (0, 100] or t = 4 (300, 400].
    assert [see_due(t, 100.0, 150.0, 0.0) for t in range(7)] == [True, False, True, True, False, True, True]
    arena = Arena(PARAMS, K, T, 0)
    slot = arena.connect("keepers")
    period = slot.see_period_ms(PARAMS.send_step_ms)
    assert [see_due(t, PARAMS.simulator_step_ms, period, 0.0) for t in range(300)] == \
        [arena.see_due(slot, t) for t in range(300)]


@pytest.mark.parametrize("params, levels_seen", [
    (parameter_set("classic"), {UNSEEN, NAMELESS, PARTIAL, FULL}),
    (parameter_set("current", keepaway_launch=False), {UNSEEN, CLOSE, NAMELESS, PARTIAL, FULL}),
])
def test_direct_see_gives_the_belief_of_the_wire_see(params, levels_seen):
    # Worlds over 100 x 60 m so every identity level occurs: NAMELESS players beyond team_far_length,
    # PARTIAL, FULL, and with a 90 deg cone (keepaway_launch=False) CLOSE objects behind; only the
    # observer's own slot is UNSEEN at 360 deg.
    kp = params.kernel()
    rng = np.random.default_rng(7)
    flags = to_wire()["flags"]
    levels = set()
    for trial in range(40):
        w = new_world(params, K, T, seed=trial)
        w.enabled[:] = True
        w.pos[0] = rng.uniform((-50.0, -30.0), (50.0, 30.0), size=(N, 2))
        w.vel[0] = rng.uniform(-0.5, 0.5, size=(N, 2))
        w.body[0] = rng.uniform(-180.0, 180.0, size=N)
        w.neck[0] = rng.uniform(-90.0, 90.0, size=N)
        out = SeeBuffers.empty(1, N, kp)
        for obs in range(1, N):
            see_arena(0, w, obs, cone_factor("normal"), kp, out)
            levels |= set(out.level[0, obs - 1].tolist())
            side, unum = ("l", obs) if obs <= K else ("r", obs - K)
            wm = WorldModel(params, side, unum, K, T, flags)
            wm.on_see(wire(m.See(cycle=5, **see_payload(out, 0, obs, K))).to_wire())
            state = new_model_state(1, K, T, obs, params)
            see = new_see_buffer(1, N_FLAGS, N)
            see_to_model_row(out, 0, obs, 5, K, see, 0)
            see_row(0, state, see, FLAG_POSITIONS, K, kp, AgentConfig().kernel())
            direct = empty_belief(1, K, T)
            write_belief_row(0, state, direct, 0)
            expected = wm.belief()
            for name in ("time", "pos", "vel", "body", "neck", "conf", "effort"):
                np.testing.assert_array_equal(getattr(direct, name), getattr(expected, name), err_msg=name)
    assert levels == levels_seen


def test_batched_arena_plays_the_embedded_game_with_the_same_beliefs():
    # Every player's belief after each cycle's percepts, and the episodes, of batched arena 0 (seed 3)
    # equal those of the embedded game seeded 3 (server stream and agents' streams alike).
    game = EmbeddedGame(ArenaSpec(PARAMS, K, T, 3))
    batched = BatchedArenas(PARAMS, 1, 3, threads=1)
    records = []
    table_parts = []
    while len(records) < 2:
        record = game.cycle()
        table_parts.append(batched.run(max_cycles=1))
        beliefs = batched.players.belief
        for p, (_, agent) in enumerate(game.players):
            bel = agent.wm.belief()
            for name in ("time", "pos", "vel", "body", "neck", "conf"):
                np.testing.assert_array_equal(getattr(beliefs, name)[p], getattr(bel, name)[0], err_msg=name)
        if record is not None:
            records.append(record)
    np.testing.assert_array_equal(batched.world.pos, game.arena.world.pos)
    ended = [t for t in table_parts if len(t)]
    assert [(int(t.episode[0]), int(t.start_cycle[0]), int(t.end_cycle[0])) for t in ended] == \
        [(r.episode, r.start_cycle, r.end_cycle) for r in records]


# --------------------------------------------------------------------------------------------------
# episodes


def test_hand_coded_episodes_end_both_ways_and_follow_each_other():
    table = BatchedArenas(PARAMS, 32, 11, threads=1).run(episodes_per_arena=10)
    assert len(table) == 320
    assert set(table.end.tolist()) == {END_OUT, END_TAKEN}
    assert np.all(np.diff(table.end_cycle) >= 0)  # in the order they ended
    for b in range(32):
        rows = table_rows(table, b)
        np.testing.assert_array_equal(rows[:, 0], np.arange(1, 11))
        assert rows[0, 1] == 0
        np.testing.assert_array_equal(rows[1:, 1], rows[:-1, 2])  # the next starts where one ends
        assert np.all(rows[:, 2] > rows[:, 1])
    assert table.cycles >= table.hold_cycles.sum()


@pytest.mark.slow
def test_hand_coded_keepers_hold_the_ball_longer_than_random_ones():
    hc = BatchedArenas(PARAMS, 32, 1, pass_policy="handcoded", getopen_policy="handcoded", threads=1)
    rnd = BatchedArenas(PARAMS, 32, 1, pass_policy="random", getopen_policy="random", threads=1)
    step_s = PARAMS.simulator_step_ms / 1000.0
    hold_hc = hc.run(episodes_per_arena=7).hold_cycles * step_s
    hold_rnd = rnd.run(episodes_per_arena=7).hold_cycles * step_s
    print(f"P:HC-GO:HC {hold_hc.mean():.2f} s, P:R-GO:R {hold_rnd.mean():.2f} s over {len(hold_hc)} episodes")
    assert hold_hc.mean() > hold_rnd.mean()
    assert welch_p_value(hold_hc, hold_rnd) < 0.01


def test_same_seed_gives_the_same_table_whatever_the_threads():
    tables = [BatchedArenas(PARAMS, 6, 5, threads=threads).run(episodes_per_arena=2) for threads in (1, 1, 2)]
    for other in tables[1:]:
        np.testing.assert_array_equal(table_rows(other), table_rows(tables[0]))
        np.testing.assert_array_equal(other.arena, tables[0].arena)
        assert other.cycles == tables[0].cycles
    different = BatchedArenas(PARAMS, 6, 6, threads=1).run(episodes_per_arena=2)
    assert not np.array_equal(table_rows(different, 0), table_rows(tables[0], 0))


def test_arena_b_of_a_batch_plays_the_single_arena_seeded_seed_plus_b():
    batch = BatchedArenas(PARAMS, 4, 20, pass_policy="random", getopen_policy="random", threads=1)
    table = batch.run(episodes_per_arena=3)
    for b in range(4):
        single = BatchedArenas(PARAMS, 1, 20 + b, pass_policy="random", getopen_policy="random", threads=1)
        np.testing.assert_array_equal(table_rows(single.run(episodes_per_arena=3)), table_rows(table, b))
        np.testing.assert_array_equal(single.world.pos[0], batch.world.pos[b])


def test_arenas_with_their_own_seeds_and_quotas_play_as_alone():
    # What lets unrelated jobs share a batch (runner.batched_backend): arena b seeded seeds[b], quota[b].
    seeds, quotas = [31, 7, 12], np.array([2, 0, 3])
    batch = BatchedArenas(PARAMS, 3, seeds, pass_policy="random", threads=2)
    table = batch.run(episodes_per_arena=quotas)
    assert np.bincount(table.arena, minlength=3).tolist() == [2, 0, 3] and batch.world.time[1] == 0
    for b in (0, 2):
        single = BatchedArenas(PARAMS, 1, seeds[b], pass_policy="random", threads=1)
        np.testing.assert_array_equal(table_rows(single.run(episodes_per_arena=int(quotas[b]))), table_rows(table, b))
    with pytest.raises(ValueError, match="one per arena"):
        BatchedArenas(PARAMS, 2, [1, 2, 3])
    for bad in (np.array([1, 1]), np.array([1, -1, 1])):
        with pytest.raises(ValueError, match="per-arena quotas"):
            batch.run(episodes_per_arena=bad)


def test_learned_getopen_uses_each_arenas_own_theta():
    rng = np.random.default_rng(0)
    thetas = rng.uniform(-0.5, 0.5, size=(2, THETA_SIZE))
    assert net_size(10) == THETA_SIZE
    pair = BatchedArenas(PARAMS, 2, 40, getopen_policy="learned", getopen_theta=thetas, threads=1)
    table = pair.run(episodes_per_arena=2)
    for b in range(2):
        single = BatchedArenas(PARAMS, 1, 40 + b, getopen_policy="learned", getopen_theta=thetas[b], threads=1)
        np.testing.assert_array_equal(table_rows(single.run(episodes_per_arena=2)), table_rows(table, b))
    swapped = BatchedArenas(PARAMS, 1, 40, getopen_policy="learned", getopen_theta=thetas[1], threads=1)
    assert not np.array_equal(table_rows(swapped.run(episodes_per_arena=2)), table_rows(table, 0))


@pytest.mark.parametrize("shape", [(THETA_SIZE,), (2, THETA_SIZE)])
def test_every_getopen_theta_reaches_the_kernels_as_one_numba_type(shape):
    # a policy file's arrays are read-only, and numba types a read-only array apart from a writable one:
    # passed as given, a CEM generation's (batch, n) thetas compiled the whole batched loop again at
    # run time, minutes after `keepaway compile` had said it was done
    theta = np.zeros(shape)
    theta.setflags(write=False)
    arenas = BatchedArenas(PARAMS, 2, 0, getopen_policy="learned", getopen_theta=theta, threads=1)
    assert numba.typeof(arenas.theta) == numba.typeof(np.zeros((2, THETA_SIZE)))
    assert arenas.theta.flags.writeable and not np.shares_memory(arenas.theta, theta)


def test_the_players_and_the_batched_mode_pass_see_row_one_type_of_flag_positions():
    model = WorldModel(PARAMS, "l", 1, K, T, to_wire()["flags"])
    assert numba.typeof(model.flag_pos) == numba.typeof(FLAG_POSITIONS)


def test_run_limits():
    arenas = BatchedArenas(PARAMS, 3, 9, threads=1)
    first = arenas.run(max_cycles=250)
    assert first.cycles == 3 * 250 and np.all(arenas.world.time == 250)
    assert np.all(first.end_cycle <= 250)
    more = arenas.run(total_episodes=5)
    # quotas 5 // 3 = 1 each plus one for the first 5 % 3 = 2 arenas: 2, 2, 1
    assert np.bincount(more.arena).tolist() == [2, 2, 1]
    assert np.all(more.end_cycle > 250)
    assert np.all(np.diff(more.end_cycle) >= 0)
    for b in range(3):
        before = first.episode[first.arena == b]
        assert more.episode[more.arena == b][0] == (before.max() + 1 if len(before) else 1)
    seen = []
    capped = arenas.run(episodes_per_arena=4, total_episodes=9, progress=seen.append)
    assert np.bincount(capped.arena).tolist() == [3, 3, 3]
    assert seen == sorted(seen) and seen[-1] == 9
    time_before = arenas.world.time.copy()
    single = arenas.run(total_episodes=1)
    assert single.arena.tolist() == [0]
    np.testing.assert_array_equal(arenas.world.time[1:], time_before[1:])  # arenas without a quota rest


@pytest.mark.parametrize("kw, message", [
    ({"pass_policy": "clever"}, "unknown Pass policy"),
    ({"pass_policy": "learned", "pass_mode": "clever"}, "unknown Sarsa mode"),
    ({"sarsa": SarsaConfig()}, "needs pass_policy='learned'"),
    ({"getopen_policy": "clever"}, "unknown GetOpen policy"),
    ({"getopen_policy": "learned"}, "needs getopen_theta"),
    ({"getopen_theta": np.zeros(90)}, "must have shape"),
])
def test_bad_configurations_are_refused(kw, message):
    with pytest.raises(ValueError, match=message):
        BatchedArenas(PARAMS, 2, 0, **kw)


def test_a_run_needs_a_limit():
    with pytest.raises(ValueError, match="give episodes_per_arena"):
        BatchedArenas(PARAMS, 1, 0).run()


@pytest.mark.parametrize("cycles_per_chunk", [0, CHUNK_CYCLES + 1])
def test_chunks_hold_one_to_chunk_cycles_cycles(cycles_per_chunk):
    with pytest.raises(ValueError, match="cycles_per_chunk"):
        BatchedArenas(PARAMS, 1, 0).chunks(max_cycles=1, cycles_per_chunk=cycles_per_chunk)

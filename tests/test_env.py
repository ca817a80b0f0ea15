"""``keepaway.env.parallel_env``: PettingZoo's own API test in every mode, whole episodes of random actions
inside the declared spaces, reproducible seeds, and the environment playing the very game of the
embedded arena when the caller feeds it the project's own hand-coded choices."""

from __future__ import annotations

import itertools
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

from conftest import REPO, keepaway_command
from keepaway.agents.getopen import grid_point, handcoded_target
from keepaway.agents.interception import fastest_to_ball
from keepaway.agents.keeper import handcoded_pass
from keepaway.agents.player import OUTSIDE_BODY, OUTSIDE_PASS, PlayerAgent
from keepaway.env import parallel_env, random_action
from keepaway.protocol.params import parameter_set
from keepaway.runner.embedded import ArenaSpec, embedded_episodes

MODES = {"pass": {}, "getopen": {"getopen_action": True}, "low_level": {"low_level": True}}


def play(env, episodes: int, choose, seed: int | None = None) -> list[tuple[float, list]]:
    """``episodes`` episodes with ``choose(obs, agent)`` for every keeper; each episode's return of
    keeper_1 and every step's observations."""
    obs, _ = env.reset(seed=seed)
    played, ret, seen = [], 0.0, [obs]
    while len(played) < episodes:
        obs, rewards, terminations, truncations, _ = env.step({a: choose(obs, a) for a in env.agents})
        seen.append(obs)
        ret += rewards["keeper_1"]
        assert len(set(rewards.values())) == 1 and not any(truncations.values())
        if all(terminations.values()):
            played.append((ret, seen))
            obs, _ = env.reset()
            ret, seen = 0.0, [obs]
    return played


def handcoded_pass_choice(env):
    """P:HC's choice on each keeper's observation, the no-op for a keeper without a decision."""
    cfg = PlayerAgent("keepers").config.kernel()

    def choose(obs, agent):
        o = obs[agent]
        if o["action_mask"][-1]:
            return env.noop
        return handcoded_pass(o["observation"], env.n_keepers, env.n_takers, cfg)

    return choose


@pytest.mark.parametrize("mode", sorted(MODES))
def test_every_mode_passes_pettingzoos_parallel_api_test_without_a_warning(mode):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parallel_api_test(parallel_env(**MODES[mode]), num_cycles=1000)


@pytest.mark.parametrize("mode", sorted(MODES))
def test_random_actions_play_whole_episodes_inside_the_declared_spaces(mode):
    env = parallel_env(**MODES[mode])
    rng = np.random.default_rng(1)
    played = play(env, 4, lambda obs, a: random_action(env.action_space(a), obs[a], rng), seed=11)
    for ret, seen in played:
        assert ret > 0.0
        for obs in seen:
            assert set(obs) == set(env.possible_agents)
            for agent, o in obs.items():
                assert env.observation_space(agent).contains(o), (agent, o)
        if mode != "low_level":  # at least one keeper decides in every step, the others send the no-op
            for obs in seen[:-1]:
                masks = np.array([o["action_mask"] for o in obs.values()])
                assert (masks[:, -1] == 0).any()
            assert all(o["action_mask"][-1] == 1 for o in seen[-1].values())


def test_the_same_seed_and_actions_give_the_same_observations():
    runs = []
    for _ in range(2):
        env = parallel_env(getopen_action=True)
        rng = np.random.default_rng(3)
        runs.append(play(env, 3, lambda obs, a: random_action(env.action_space(a), obs[a], rng), seed=5))
    for (ret_a, seen_a), (ret_b, seen_b) in zip(*runs):
        assert ret_a == ret_b and len(seen_a) == len(seen_b)
        for obs_a, obs_b in zip(seen_a, seen_b):
            for agent in obs_a:
                for key in obs_a[agent]:
                    np.testing.assert_array_equal(obs_a[agent][key], obs_b[agent][key])
    other = parallel_env(getopen_action=True)
    rng = np.random.default_rng(3)
    assert [r for r, _ in play(other, 3, lambda obs, a: random_action(other.action_space(a), obs[a], rng), seed=6)] \
        != [r for r, _ in runs[0]]


def test_the_hand_coded_pass_fed_through_the_env_plays_the_embedded_arenas_episodes():
    """Feeding P:HC's choice on each observation gives the episodes of ``keepaway run --mode embedded``
    with hand-coded Pass, the same seed: the environment plays the same game and its returns are the
    hold times."""
    env = parallel_env()
    returns = [ret for ret, _ in play(env, 6, handcoded_pass_choice(env), seed=21)]
    records = [rec for rec, _ in itertools.islice(embedded_episodes(ArenaSpec(parameter_set("classic"), seed=21)), 6)]
    assert returns == pytest.approx([rec.hold_time_s for rec in records], abs=1e-9)


def test_the_hand_coded_getopen_fed_through_the_env_plays_the_embedded_arenas_episodes():
    env = parallel_env(getopen_action=True)
    cfg = PlayerAgent("keepers").config.kernel()
    points = {grid_point(k, env.params.kernel(), cfg): k for k in range(env.n_points)}

    pass_choice = handcoded_pass_choice(env)

    def handcoded(obs, agent):
        if not obs[agent]["action_mask"][env.n_keepers]:  # a Pass decision or none
            return pass_choice(obs, agent)
        keeper = env._game.keepers[env.possible_agents.index(agent)]
        bel = keeper.wm.belief()
        _, ball_cycles = fastest_to_ball(bel, 0, 1, bel.n_keepers, keeper.decay_sums, keeper.kp, cfg)
        target = handcoded_target(bel, 0, ball_cycles, False, keeper.kp, cfg)
        return env.n_keepers + points[target]

    returns = [ret for ret, _ in play(env, 4, handcoded, seed=22)]
    records = [rec for rec, _ in itertools.islice(embedded_episodes(ArenaSpec(parameter_set("classic"), seed=22)), 4)]
    assert returns == pytest.approx([rec.hold_time_s for rec in records], abs=1e-9)


def test_a_wrong_or_missing_action_is_refused_in_one_line_and_changes_nothing():
    env = parallel_env()
    obs, _ = env.reset(seed=2)
    actor = next(a for a in env.agents if not obs[a]["action_mask"][-1])
    idle = {a: env.noop for a in env.agents}
    with pytest.raises(ValueError, match=f"{actor}'s action .* not allowed"):
        env.step(idle)
    with pytest.raises(ValueError, match="no action for"):
        env.step({actor: 0})
    _, rewards, *_ = env.step({**idle, actor: 0})
    assert rewards[actor] > 0.0


def test_with_fallback_a_disallowed_action_plays_the_lowest_allowed_and_says_so():
    """``disallowed="fallback"``: the deciding keeper's no-op becomes its lowest allowed action (HoldBall), an
    idle keeper's pass the no-op, each named in its infos; the episode is the one those actions play."""
    env, same = parallel_env(disallowed="fallback"), parallel_env()
    obs, _ = env.reset(seed=2)
    same.reset(seed=2)
    actor = next(a for a in env.agents if not obs[a]["action_mask"][-1])
    idle = next(a for a in env.agents if a != actor)
    sent = {a: env.noop for a in env.agents} | {idle: 1}
    out, *_, infos = env.step(sent)
    expected, *_, plain = same.step({a: env.noop for a in env.agents} | {actor: 0})
    assert infos[actor]["disallowed"] == (env.noop, 0) and infos[idle]["disallowed"] == (1, env.noop)
    assert all("disallowed" not in info for agent, info in infos.items() if agent not in (actor, idle))
    assert all(np.array_equal(out[a]["observation"], expected[a]["observation"]) for a in env.agents)
    assert all("disallowed" not in info for info in plain.values())


def test_pettingzoos_seed_test_passes_with_fallback_and_a_render_mode_is_refused():
    """PettingZoo's ``parallel_seed_test`` samples without masks: it passes with ``disallowed="fallback"``.
    The environment has no render mode: ``render_mode`` is None, and asking for one is refused in one line."""
    from pettingzoo.test import parallel_seed_test

    parallel_seed_test(lambda: parallel_env(disallowed="fallback"))
    assert parallel_env().render_mode is None
    with pytest.raises(ValueError, match="does not render"):
        parallel_env(render_mode="human")
    with pytest.raises(ValueError, match="refuse, fallback"):
        parallel_env(disallowed="ignore")


def test_supersuits_vector_wrappers_play_whole_episodes_with_fallback():
    """SuperSuit's vector wrappers (one keeper per vector slot, two environments concatenated) sample without
    masks: with ``disallowed="fallback"`` they play whole episodes, each step's reward the time since the last."""
    import supersuit

    venv = supersuit.concat_vec_envs_v1(supersuit.pettingzoo_env_to_vec_env_v1(parallel_env(disallowed="fallback")),
                                        2, num_cpus=0, base_class="gymnasium")
    obs, _ = venv.reset(seed=1)
    assert venv.num_envs == 6 and obs["action_mask"].shape == (6, 4)
    ended = 0
    for _ in range(300):
        obs, rewards, terminations, truncations, _ = venv.step(np.array([venv.action_space.sample()
                                                                         for _ in range(venv.num_envs)]))
        assert rewards.shape == (6,) and (rewards > 0).all() and not truncations.any()
        ended += int(terminations.sum())
    assert ended >= 6  # every keeper of both games saw an episode end
    venv.close()


def test_a_keeper_leaves_only_known_decisions_outside():
    with pytest.raises(ValueError, match="decisions made outside"):
        PlayerAgent("keepers", outside=("kick",))
    with pytest.raises(ValueError, match="only keepers"):
        PlayerAgent("takers", outside=(OUTSIDE_PASS,))
    with pytest.raises(ValueError, match="comes alone"):
        PlayerAgent("keepers", outside=(OUTSIDE_BODY, OUTSIDE_PASS))
    with pytest.raises(ValueError, match="no decision is awaited"):
        PlayerAgent("keepers", outside=(OUTSIDE_PASS,)).act(0)
    with pytest.raises(ValueError, match="choose one of getopen_action and low_level"):
        parallel_env(getopen_action=True, low_level=True)


def test_attached_to_a_running_server_the_env_passes_the_api_test_and_plays_the_embedded_games(processes, tmp_path):
    """The keepers join a real ``keepaway server`` (port 0) beside two real taker processes: PettingZoo's
    API test passes, and the hand-coded Pass fed through the env plays the episodes of the embedded arena
    with the server's seed."""
    seed = 21
    server = processes.start_server(tmp_path, "--mode", "sync", "--seed", str(seed), "--cycle-timeout", "600")
    for _ in range(2):
        processes.popen(keepaway_command("player", "--team", "takers", "--server", server.players_endpoint,
                                         "--seed", str(seed)))
    env = parallel_env(server=server.players_endpoint)
    try:
        returns = [ret for ret, _ in play(env, 4, handcoded_pass_choice(env), seed=seed)]
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            parallel_api_test(env, num_cycles=1000)
    finally:
        env.close()
    records = itertools.islice(embedded_episodes(ArenaSpec(parameter_set("classic"), seed=seed)), 4)
    assert returns == pytest.approx([rec.hold_time_s for rec, _ in records], abs=1e-9)
    assert server.proc.poll() is None, server.stderr_text()


# In a fresh process (a test's own process may have loaded any kernel already): the kernels a server and
# a player load before a game, then three environments played with random actions; prints every kernel
# the environments called from Python with argument types the warm-ups did not load.
_UNWARMED_KERNELS = """
import sys
import numpy as np
from numba.core.registry import CPUDispatcher
from keepaway.agents.player import compile_kernels
from keepaway.env import parallel_env, random_action
from keepaway.protocol.params import parameter_set
from keepaway.server.arena import compile_kernels as compile_server_kernels

def loaded():
    return {f"{d.py_func.__module__}.{d.py_func.__name__}": set(d.overloads)
            for name, module in list(sys.modules.items()) if name.split(".")[0] in ("agents", "server", "core")
            for d in vars(module).values() if isinstance(d, CPUDispatcher)}

compile_server_kernels(parameter_set("classic"), 3, 2)
compile_kernels()
before = loaded()
rng = np.random.default_rng(0)
for kw in ({}, {"getopen_action": True}, {"low_level": True}):
    env = parallel_env(**kw)
    obs, _ = env.reset(seed=1)
    for _ in range(400):
        obs, *_ = env.step({a: random_action(env.action_space(a), obs[a], rng) for a in env.agents})
        if not env.agents:
            obs, _ = env.reset()
print(sorted(name for name, sigs in loaded().items() if sigs - before.get(name, set())))
"""


def test_the_environment_calls_only_kernels_the_warm_ups_loaded():
    # a kernel called from Python with types that `keepaway compile` never used is compiled in the user's
    # process at its first call, seconds after the compile said it was done (grid_states and
    # execute_getopen_action for GetOpen actions, neck_to_ball for low-level ones, the server's see_due
    # and kick reach test were)
    done = subprocess.run([sys.executable, "-c", _UNWARMED_KERNELS], capture_output=True, text=True, cwd=REPO,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip() == "[]"


def example_blocks(example: str, *args: str) -> list[tuple[int, int, float]]:
    """Run ``examples/<example>`` with ``args``; the (first, last episode, mean hold time) of its blocks."""
    done = subprocess.run([sys.executable, str(REPO / "examples" / example), *args], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    rows = re.findall(r"^episodes +(\d+)- +(\d+): +([\d.]+) \+- ([\d.]+|nan) s", done.stdout, flags=re.MULTILINE)
    return [(int(a), int(b), float(mean)) for a, b, mean, _ in rows]


@pytest.mark.parametrize("example", ["train_pass.py", "train_pass_sklearn.py"])
def test_the_pass_training_examples_print_their_blocks_of_hold_times(example):
    blocks = example_blocks(example, "--episodes", "4", "--trials", "2", "--block", "2")
    assert [(a, b) for a, b, _ in blocks] == [(1, 2), (3, 4)]
    assert all(mean > 0.0 for _, _, mean in blocks)


@pytest.mark.slow
def test_the_scikit_learn_example_learns_to_pass():
    """Linear Sarsa on scikit-learn's random Fourier features, through the environment: from random Pass
    (about 5.3 s) to a clearly longer hold within 200 episodes (seeded: the same run every time; 5.95 s in
    the first 100, 7.63 s in the next 100, 9.28 s in a third)."""
    blocks = example_blocks("train_pass_sklearn.py", "--episodes", "200", "--trials", "1", "--block", "100")
    first, *_, last = [mean for _, _, mean in blocks]
    assert first < 6.0 and last > first + 1.0, blocks

"""``keepaway.env.parallel_env()``: the keepers' decisions as a PettingZoo Parallel environment.

The learning agents are the keepers ``keeper_1`` .. ``keeper_K`` (uniform numbers); the takers and every
behaviour that is not an action play the project's own hand-coded policies. The game is the embedded
arena (``runner.embedded.EmbeddedGame``: the server's arena and the players' agents exchanging the
distributed mode's messages in this process) or, with ``server=``, a running ``keepaway server`` to which
the environment connects the keepers as clients over the real protocol. Either way each keeper is the
project's ``PlayerAgent`` (world model, skills, say and hear) with some decisions left to the caller
(``agents.player``, "Decisions made outside"); the environment plays cycle by cycle and stops in a cycle
where some keeper waits for one.

Modes (docs/env.md has the spaces, the rewards and why):

* default, the Pass SMDP of Stone et al.: a keeper with the ball in reach decides HoldBall (0) or
  PassBall to its k-th nearest teammate (k); its observation is the 4K + 2T - 3 Pass state variables
  (13 in 3v2). GetOpen is ``getopen`` (hand-coded by default).
* ``getopen_action=True``: as above, and a keeper in GetOpen chooses every cycle one of the 25 grid
  points (``agents.getopen.grid_point``) to move to, seeing each point's 3K + T - 1 GetOpen variables.
* ``low_level=True``: every keeper sends its own main command every cycle, ``(command, parameters)``:
  command 0 dash(power), 1 turn(moment), 2 kick(power, direction), parameters a Box of the four values.

Every live keeper is in every step's dictionaries. In the discrete modes the observation is a dict with
``action_mask``; a keeper with no decision in the step has only the no-op (the last action) allowed and
its other entries are zeros. A disallowed action is refused, or with ``disallowed="fallback"`` played as
the keeper's lowest allowed action and named in its infos.

The reward of every keeper is the simulated time in seconds since the previous step, so a keeper's
rewards between two of its decisions sum to the SMDP reward of the first (Stone et al.: the time until its
next decision or the episode's end) and every keeper's return is the episode's hold time. An episode is
one Keepaway episode (terminated, never truncated).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from keepaway.agents.config import AgentConfig
from keepaway.agents.getopen import grid_size, grid_states
from keepaway.agents.player import OUTSIDE_BODY, OUTSIDE_GETOPEN, OUTSIDE_PASS, PlayerAgent
from keepaway.agents.state_vars import getopen_state_size, pass_state_size
from keepaway.core.objects import CMD_DASH, CMD_KICK, CMD_TURN
from keepaway.protocol.params import ServerParams, parameter_set
from keepaway.runner.embedded import ArenaSpec
from keepaway.runner.outside import AttachedKeepers, EmbeddedKeepers

AGENT_PREFIX = "keeper_"
# The low-level commands in the order of the action's first element.
LOW_LEVEL_COMMANDS = (CMD_DASH, CMD_TURN, CMD_KICK)
# Per object (ball, me, the other keepers, the takers): x, y, vx, vy, confidence; then my body and neck.
OBJECT_FEATURES = 5
SEED_WORDS = 2**63  # reset seeds drawn by the environment are in 0 .. 2^63 - 1 (protocol.messages.MAX_SEED)
# What a disallowed action of a discrete mode does: a one-line ValueError and no change, or the keeper's
# lowest allowed action played instead (the no-op when it decides nothing), said in its infos.
DISALLOWED = ("refuse", "fallback")


class KeepawayParallelEnv(ParallelEnv):
    """The environment of :func:`parallel_env` (module docstring)."""

    metadata = {"name": "keepaway_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, keepers: int = 3, takers: int = 2, field_size: float = 20.0,
                 params: str | ServerParams = "classic", getopen_action: bool = False, low_level: bool = False,
                 getopen: str = "handcoded", server: str | None = None, keys: str | Path | None = None,
                 disallowed: str = "refuse", render_mode: str | None = None) -> None:
        if disallowed not in DISALLOWED:
            raise ValueError(f"disallowed={disallowed!r}: one of {', '.join(DISALLOWED)}")
        if render_mode is not None:
            raise ValueError(f"render_mode={render_mode!r}: the environment does not render (keepaway view "
                             f"and keepaway render show a game's log)")
        if getopen_action and low_level:
            raise ValueError("low_level already leaves GetOpen to the keepers: choose one of getopen_action "
                             "and low_level")
        if isinstance(params, str):
            params = parameter_set(params, keepaway_length=field_size, keepaway_width=field_size)
        self.params = params
        self.n_keepers, self.n_takers = keepers, takers
        self.getopen_action, self.low_level = getopen_action, low_level
        self.getopen_policy = getopen
        self.server = server
        self.keys = keys
        self.disallowed = disallowed
        self.render_mode = render_mode
        self._replaced: dict[str, tuple[int, int]] = {}  # this step's disallowed actions: agent -> (sent, played)
        self.outside = ((OUTSIDE_BODY,) if low_level
                        else (OUTSIDE_PASS, OUTSIDE_GETOPEN) if getopen_action else (OUTSIDE_PASS,))
        self.possible_agents = [f"{AGENT_PREFIX}{k}" for k in range(1, keepers + 1)]
        self.agents: list[str] = []
        self.step_s = params.simulator_step_ms / 1000.0
        self.n_pass = pass_state_size(keepers, takers)
        self.n_getopen = getopen_state_size(keepers, takers)
        self.n_points = grid_size(AgentConfig().kernel())
        self.n_actions = keepers + (self.n_points if getopen_action else 0) + 1
        self.noop = self.n_actions - 1
        self._game: EmbeddedKeepers | AttachedKeepers | None = None
        self._in_episode = False
        self._last_cycle = 0
        self._np_random = np.random.default_rng()
        self._observation_space = self._make_observation_space()
        self._action_space = self._make_action_space()

    # -- spaces --------------------------------------------------------------------------------------
    def _make_observation_space(self) -> spaces.Space:
        if self.low_level:
            n = OBJECT_FEATURES * (1 + self.n_keepers + self.n_takers) + 2
            return spaces.Box(-np.inf, np.inf, (n,), np.float64)
        parts = {"observation": spaces.Box(-np.inf, np.inf, (self.n_pass,), np.float64),
                 "action_mask": spaces.Box(0, 1, (self.n_actions,), np.int8)}
        if self.getopen_action:
            parts["getopen"] = spaces.Box(-np.inf, np.inf, (self.n_points, self.n_getopen), np.float64)
        return spaces.Dict(parts)

    def _make_action_space(self) -> spaces.Space:
        if not self.low_level:
            return spaces.Discrete(self.n_actions)
        p = self.params
        low = np.array([p.min_dash_power, p.min_moment, p.min_power, p.min_moment])
        high = np.array([p.max_dash_power, p.max_moment, p.max_power, p.max_moment])
        return spaces.Tuple((spaces.Discrete(len(LOW_LEVEL_COMMANDS)), spaces.Box(low, high, dtype=np.float64)))

    def observation_space(self, agent: str) -> spaces.Space:
        return self._observation_space

    def action_space(self, agent: str) -> spaces.Space:
        return self._action_space

    # -- the game ------------------------------------------------------------------------------------
    def _new_game(self, seed: int) -> EmbeddedKeepers | AttachedKeepers:
        if self.server is not None:
            return AttachedKeepers(self.server, self.n_keepers, lambda: PlayerAgent(
                "keepers", getopen_policy=self.getopen_policy, seed=seed, outside=self.outside), self.keys)
        spec = ArenaSpec(self.params, self.n_keepers, self.n_takers, seed=seed, getopen_policy=self.getopen_policy)
        return EmbeddedKeepers(spec, self.outside)

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        """Start an episode: with ``seed`` a fresh arena seeded with it (the same seed and the same actions
        give the same episodes); without, the arena's next episode, or, mid-episode or before any game, a
        fresh arena whose seed comes from the last seed given. Attached to a server (``server=``), the
        keepers join at the first reset (seeded with its seed, else 0) and stay: the server's game cannot
        be reseeded from here, and a reset mid-episode plays the running episode out with random allowed
        actions first. ``options`` are not used."""
        if seed is not None:
            self._np_random = np.random.default_rng(seed)
        if self.server is not None:
            if self._game is None:
                self._game = self._new_game(seed or 0)
            elif self._in_episode:
                self._play_out()
        elif seed is not None or self._game is None or self._in_episode:
            self.close()
            self._game = self._new_game(seed if seed is not None else int(self._np_random.integers(SEED_WORDS)))
        self.agents = list(self.possible_agents)
        self._in_episode = True
        self._replaced = {}
        while self._game.advance() is not None:  # an episode over before any decision has no step
            pass
        self._last_cycle = self._game.episode_start
        return self._observations(), self._infos()

    def _play_out(self) -> None:
        """The running episode to its end with random allowed actions (from the seeded stream)."""
        observations = self._observations()
        while self.agents:
            observations = self.step({agent: random_action(self._action_space, obs, self._np_random)
                                      for agent, obs in observations.items()})[0]

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        """Every keeper waiting for a decision takes its action; the others must send the no-op (the
        low-level mode has no no-op: every keeper acts every cycle). ValueError on a missing or wrong
        action; the game is then unchanged."""
        if not self.agents:
            raise ValueError("the episode is over: call reset()")
        game = self._game
        self._replaced = {}
        chosen = [self._command(i, keeper, actions) for i, keeper in enumerate(game.keepers)]
        for i, (keeper, action) in enumerate(zip(game.keepers, chosen)):
            if action is not None:
                game.send(i, keeper.act_frame(action))
        ended = game.advance()
        now = ended if ended is not None else self._decision_cycle()
        rewards = {agent: (now - self._last_cycle) * self.step_s for agent in self.agents}
        self._last_cycle = now
        over = ended is not None
        observations, infos = self._observations(), self._infos()
        terminations = {agent: over for agent in self.agents}
        truncations = {agent: False for agent in self.agents}
        if over:
            self.agents = []
            self._in_episode = False
        return observations, rewards, terminations, truncations, infos

    def close(self) -> None:
        if self._game is not None:
            self._game.close()
            self._game = None

    # -- actions and observations --------------------------------------------------------------------
    def _command(self, index: int, keeper: PlayerAgent, actions: dict[str, Any]) -> Any:
        """The ``agents.player`` action of keeper ``index`` (None: it waits for nothing)."""
        agent = self.possible_agents[index]
        if agent not in actions:
            raise ValueError(f"no action for {agent}")
        action = actions[agent]
        if self.low_level:
            command, values = action
            values = np.asarray(values, dtype=np.float64)
            if not 0 <= int(command) < len(LOW_LEVEL_COMMANDS) or values.shape != (4,):
                raise ValueError(f"{agent}'s action {action!r} is not (command 0-2, four parameters)")
            code = LOW_LEVEL_COMMANDS[int(command)]
            args = {CMD_DASH: (values[0], 0.0), CMD_TURN: (values[1], 0.0), CMD_KICK: (values[2], values[3])}[code]
            return code, *args
        action = int(action)
        mask = self._mask(keeper)
        if not (0 <= action < self.n_actions and mask[action]):
            if self.disallowed == "refuse":
                raise ValueError(f"{agent}'s action {action} is not allowed now (its action_mask)")
            played = int(np.flatnonzero(mask)[0])
            self._replaced[agent] = (action, played)
            action = played
        if action == self.noop:
            return None
        return action if action < self.n_keepers else action - self.n_keepers

    def _mask(self, keeper: PlayerAgent) -> np.ndarray:
        mask = np.zeros(self.n_actions, dtype=np.int8)
        waiting = keeper.awaiting.decision if keeper.awaiting is not None else None
        if waiting == OUTSIDE_PASS:
            mask[:self.n_keepers] = 1
        elif waiting == OUTSIDE_GETOPEN:
            mask[self.n_keepers:self.n_keepers + self.n_points] = 1
        else:
            mask[self.noop] = 1
        return mask

    def _decision_cycle(self) -> int:
        return next(k.awaiting.cycle for k in self._game.keepers if k.awaiting is not None)

    def _observations(self) -> dict[str, Any]:
        return {agent: self._observation(keeper) for agent, keeper in zip(self.possible_agents, self._game.keepers)}

    def _observation(self, keeper: PlayerAgent) -> Any:
        waiting = keeper.awaiting.decision if keeper.awaiting is not None else None
        if self.low_level:
            return body_observation(keeper)
        obs = {"observation": keeper.pass_state.copy() if waiting == OUTSIDE_PASS else np.zeros(self.n_pass),
               "action_mask": self._mask(keeper)}
        if self.getopen_action:
            obs["getopen"] = np.zeros((self.n_points, self.n_getopen))
            if waiting == OUTSIDE_GETOPEN:
                grid_states(keeper.wm.belief(), 0, keeper.decay_sums, keeper.kp, keeper.cfg, obs["getopen"])
        return obs

    def _infos(self) -> dict[str, dict]:
        """What each keeper decides now; with ``disallowed="fallback"``, a keeper whose action of the step was
        not allowed also has ``"disallowed": (sent, played)``."""
        infos = {agent: {"decision": keeper.awaiting.decision if keeper.awaiting is not None else None}
                 for agent, keeper in zip(self.possible_agents, self._game.keepers)}
        for agent, replaced in self._replaced.items():
            infos[agent]["disallowed"] = replaced
        return infos


def random_action(space: spaces.Space, observation: Any, rng: np.random.Generator) -> Any:
    """A uniformly drawn action of ``space`` allowed by ``observation``'s action mask, if it has one, from
    ``rng`` (a low-level action: a command and uniform parameters)."""
    if isinstance(observation, dict):
        return int(rng.choice(np.flatnonzero(observation["action_mask"])))
    return int(rng.integers(space[0].n)), rng.uniform(space[1].low, space[1].high)


def body_observation(keeper: PlayerAgent) -> np.ndarray:
    """A low-level keeper's view (module docstring): x, y, vx, vy and confidence of the ball, itself, the
    other keepers (uniform-number order) and the takers, then its body angle and neck angle (degrees)."""
    bel = keeper.wm.belief()
    me = int(bel.me[0])
    order = [0, me] + [j for j in range(1, bel.n_keepers + bel.n_takers + 1) if j != me]
    rows = np.column_stack([bel.pos[0, order], bel.vel[0, order], bel.conf[0, order]])
    return np.concatenate([rows.ravel(), [bel.body[0, me], bel.neck[0, me]]])


def parallel_env(**kwargs: Any) -> KeepawayParallelEnv:
    """The Keepaway keepers' environment (module docstring); keyword arguments of
    :class:`KeepawayParallelEnv`."""
    return KeepawayParallelEnv(**kwargs)


__all__ = ["KeepawayParallelEnv", "body_observation", "parallel_env", "random_action"]

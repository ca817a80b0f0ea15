"""Train the keepers' Pass through ``keepaway.env`` with scikit-learn: linear SMDP Sarsa on random Fourier
features, the recipe of scikit-learn's own function approximators and nothing of the project's learners.

    pip install -e ".[examples]"
    python examples/train_pass_sklearn.py --episodes 1000 --trials 3

The three keepers share one action-value function (their state variables are egocentric, so one
function serves all; tjpalmer's "hive mind"): per action an ``SGDRegressor`` over an ``RBFSampler``
embedding of the standardised 13 Pass state variables, both fitted on the states of a few random-Pass
episodes played first. A keeper's SMDP reward is the sum of the environment's rewards (seconds) between
two of its decisions; an episode's end closes every keeper's last decision. Prints the mean hold time of
every block of episodes, per trial and over the trials (+- standard error).
"""

from __future__ import annotations

import numpy as np
from sklearn.kernel_approximation import RBFSampler
from sklearn.linear_model import SGDRegressor
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from train_pass import main as report  # the command line and the report of examples/train_pass.py

from keepaway.env import parallel_env

EPSILON = 0.05  # exploration: a random allowed action this often
STEP_SIZE = 0.05  # SGDRegressor's constant learning rate
FEATURES = 400  # random Fourier features (RBFSampler components)
RBF_GAMMA = 0.05  # their kernel exp(-gamma |x - y|^2) over standardised states: broad in 13 dimensions
WARM_UP_EPISODES = 20  # random-Pass episodes whose states fit the scaler and the features


class LinearPassValues:
    """Q(s, a) = w_a . phi(s): one SGDRegressor per action on a shared feature map ``phi``."""

    def __init__(self, states: np.ndarray, n_actions: int, seed: int) -> None:
        self.phi = make_pipeline(StandardScaler(),
                                 RBFSampler(gamma=RBF_GAMMA, n_components=FEATURES, random_state=seed))
        self.phi.fit(states)
        self.models = [SGDRegressor(learning_rate="constant", eta0=STEP_SIZE, random_state=seed + a)
                       for a in range(n_actions)]
        zero = self.features(states[0])
        for model in self.models:  # start every value at 0
            model.partial_fit(zero, [0.0])

    def features(self, state: np.ndarray) -> np.ndarray:
        return self.phi.transform(state.reshape(1, -1))

    def values(self, phi: np.ndarray) -> np.ndarray:
        return np.array([model.predict(phi)[0] for model in self.models])

    def update(self, phi: np.ndarray, action: int, target: float) -> None:
        self.models[action].partial_fit(phi, [target])


def warm_up_states(env, seed: int) -> np.ndarray:
    """The Pass states of a few episodes of random allowed actions."""
    rng = np.random.default_rng(seed)
    states = []
    obs, _ = env.reset(seed=seed)
    for _ in range(WARM_UP_EPISODES):
        while env.agents:
            actions = {}
            for agent, o in obs.items():
                allowed = np.flatnonzero(o["action_mask"])
                actions[agent] = int(rng.choice(allowed))
                if not o["action_mask"][-1]:
                    states.append(o["observation"])
            obs, *_ = env.step(actions)
        obs, _ = env.reset()
    return np.array(states)


def train(episodes: int, seed: int) -> list[float]:
    """Hold times (s) of ``episodes`` learning episodes from ``seed``."""
    env = parallel_env()
    rng = np.random.default_rng(seed)
    q = LinearPassValues(warm_up_states(env, seed), env.n_keepers, seed)
    holds = []
    obs, _ = env.reset(seed=seed + 1)
    while len(holds) < episodes:
        pending = {}  # agent -> (features, action, reward since) of its last decision
        hold, done = 0.0, False
        while not done:
            actions = {}
            for agent, o in obs.items():
                if o["action_mask"][-1]:  # no decision for this keeper now
                    actions[agent] = env.noop
                    continue
                phi = q.features(o["observation"])
                values = q.values(phi)
                action = int(rng.integers(env.n_keepers)) if rng.random() < EPSILON else int(np.argmax(values))
                if agent in pending:  # Sarsa: the last decision's target is its reward plus this value
                    last_phi, last_action, reward = pending[agent]
                    q.update(last_phi, last_action, reward + values[action])
                pending[agent] = (phi, action, 0.0)
                actions[agent] = action
            obs, rewards, terminations, _, _ = env.step(actions)
            for agent, (phi, action, reward) in pending.items():
                pending[agent] = (phi, action, reward + rewards[agent])
            hold += rewards[env.possible_agents[0]]
            done = all(terminations.values())
        for phi, action, reward in pending.values():  # the episode's end closes every last decision
            q.update(phi, action, reward)
        holds.append(hold)
        obs, _ = env.reset()
    return holds


if __name__ == "__main__":
    report(train, __doc__)

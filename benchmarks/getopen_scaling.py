"""Derive GO:L's input scaling (``agents.getopen.GetOpenScaling``) from hand-coded play, and show why.

``python benchmarks/getopen_scaling.py [--keepers 3 --takers 2 --field-size 20 --episodes 1000]``

Plays P:HC-GO:HC in the batched mode (classic parameters) and, every ``--every`` cycles, records the
GetOpen state (docs/players.md §7.4, ``agents.state_vars.getopen_state``) of every grid point of every
keeper that runs GetOpen in that cycle (ball known, not kickable by it, not the fastest to the ball: the
branch ``agents.keeper.keeper_decide`` takes), on the keeper's own belief. Prints:

* per variable: mean and standard deviation;
* per variable kind (``agents.state_vars.GETOPEN_KINDS``): the pooled mean and standard deviation,
  distances also as fractions of the field's side: the constants of ``GetOpenScaling``;
* each variable's mean and standard deviation after the per-kind scaling of ``GetOpenScaling()`` (what
  the net sees; near 0 and 1 if the table fits this game);
* for the CEM's first generation (nets drawn from N(0, I)) on raw and on scaled inputs: the share of
  first-layer units with |tanh| > 0.99, the median |z| of a first-layer unit, and the share of GetOpen
  decisions whose best value is shared by several grid points (exact ties).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository, before benchmarks/

from keepaway.agents.config import AgentConfig  # noqa: E402
from keepaway.agents.geometry import ball_kickable  # noqa: E402
from keepaway.agents.getopen import (  # noqa: E402
    NET_HIDDEN,
    SCALED_TANH_B,
    GetOpenScaling,
    grid_point,
    grid_size,
    lane_origin,
    net_size,
    net_value,
)
from keepaway.agents.interception import fastest_to_ball  # noqa: E402
from keepaway.agents.state_vars import GETOPEN_KINDS, getopen_state, getopen_state_kinds, getopen_state_size  # noqa: E402
from keepaway.protocol.params import parameter_set  # noqa: E402
from keepaway.runner.batched import BatchedArenas  # noqa: E402

SATURATED = 0.99  # |tanh| above this: the unit acts as a threshold


@njit
def record_states(bel, n_players, n_keepers, sums, kp, cfg, out, n):
    """Append to ``out`` (from row ``n``) the GetOpen state of every grid point of every keeper row that
    runs GetOpen on its belief; returns the new row count (stops when ``out`` is full)."""
    points = grid_size(cfg)
    for r in range(bel.pos.shape[0]):
        if r % n_players >= n_keepers or n + points > out.shape[0]:
            continue
        me = bel.me[r]
        if bel.conf[r, 0] < cfg.ball_conf_threshold or ball_kickable(bel, r, me, kp):
            continue
        chaser, ball_cycles = fastest_to_ball(bel, r, 1, bel.n_keepers, sums, kp, cfg)
        if chaser == me:
            continue
        ox, oy = lane_origin(bel, r, ball_cycles, kp, cfg)
        for k in range(points):
            px, py = grid_point(k, kp, cfg)
            getopen_state(bel, r, px, py, ox, oy, out[n])
            n += 1
    return n


@njit
def net_values(theta, states):
    """net_value of every row of ``states``."""
    out = np.empty(states.shape[0])
    for i in range(states.shape[0]):
        out[i] = net_value(theta, states[i])
    return out


def record(keepers: int, takers: int, field_size: float, episodes: int, every: int, arenas: int, seed: int,
           agent: AgentConfig, max_states: int) -> tuple[np.ndarray, int, int]:
    """(states, episodes played, cycles sampled) of P:HC-GO:HC play (module docstring)."""
    params = parameter_set("classic", keepaway_length=field_size, keepaway_width=field_size)
    play = BatchedArenas(params, arenas, seed, keepers=keepers, takers=takers, pass_policy="handcoded",
                         getopen_policy="handcoded", agent_config=agent)
    cfg, kp = play.cfg, play.kp
    out = np.empty((max_states, getopen_state_size(keepers, takers)))
    n = played = samples = 0
    while played < episodes and n < max_states:
        played += len(play.run(max_cycles=every))
        n = record_states(play.players.belief, keepers + takers, keepers, play.players.decay_sums, kp, cfg, out, n)
        samples += 1
    return out[:n], played, samples


def first_layer(theta: np.ndarray, states: np.ndarray) -> np.ndarray:
    """z of every first-layer unit, (states, hidden)."""
    n = states.shape[1]
    w1 = theta[:NET_HIDDEN * n].reshape(NET_HIDDEN, n)
    return states @ w1.T + theta[NET_HIDDEN * n:NET_HIDDEN * (n + 1)]


def generation_zero(states: np.ndarray, scaled: np.ndarray, points: int, nets: int, seed: int) -> None:
    """Saturation and ties of ``nets`` N(0, I) nets on raw and on scaled inputs (module docstring)."""
    rng = np.random.default_rng(seed)
    thetas = rng.standard_normal((nets, net_size(states.shape[1])))
    for name, x in (("raw", states), ("scaled", scaled)):
        z = np.concatenate([np.abs(first_layer(t, x)).ravel() for t in thetas])
        saturated = np.mean(np.abs(np.tanh(SCALED_TANH_B * z)) > SATURATED)
        ties = []
        for theta in thetas:
            values = net_values(theta, x).reshape(-1, points)
            ties.append(np.mean((values == values.max(axis=1, keepdims=True)).sum(axis=1) > 1))
        print(f"  {name:6s} inputs: {100 * saturated:5.1f} % of first-layer units at |tanh| > {SATURATED}, "
              f"median |z| {np.median(z):6.2f}; {100 * np.mean(ties):5.1f} % of decisions with tied best points")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keepers", type=int, default=3)
    parser.add_argument("--takers", type=int, default=2)
    parser.add_argument("--field-size", type=float, default=20.0)
    parser.add_argument("--episodes", type=int, default=1000, help="episodes of P:HC-GO:HC to record")
    parser.add_argument("--every", type=int, default=5, help="cycles between recorded cycles")
    parser.add_argument("--arenas", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-states", type=int, default=2_000_000)
    parser.add_argument("--nets", type=int, default=20, help="N(0, I) nets of the saturation check")
    parser.add_argument("--lane-from-predicted-ball", action="store_true",
                        help="variables 9-10 from predictedBallPos (AgentConfig.getopen_lane_from_predicted_ball)")
    args = parser.parse_args()
    agent = AgentConfig(getopen_lane_from_predicted_ball=args.lane_from_predicted_ball)
    k, t, size = args.keepers, args.takers, args.field_size
    states, played, samples = record(k, t, size, args.episodes, args.every, args.arenas, args.seed, agent,
                                     args.max_states)
    points = grid_size(agent.kernel())
    print(f"P:HC-GO:HC {k}v{t} on {size:g} m, classic parameters, seed {args.seed}: {played} episodes in "
          f"{args.arenas} arenas, every {args.every}th cycle ({samples} cycles): {len(states) // points} GetOpen "
          f"decisions x {points} grid points = {len(states)} states")
    kinds = getopen_state_kinds(k, t)
    print("\nper variable (metres, degrees):")
    for i, kind in enumerate(kinds):
        print(f"  {i + 1:2d} {kind:24s} mean {states[:, i].mean():8.3f}  sd {states[:, i].std():8.3f}")
    print(f"\nper kind (the GetOpenScaling constants; distances / {size:g} m):")
    for kind in GETOPEN_KINDS:
        values = states[:, [i for i, name in enumerate(kinds) if name == kind]].ravel()
        unit = size if kind.endswith("distance") else 1.0
        print(f"  {kind}: tuple[float, float] = ({values.mean() / unit:.4g}, {values.std() / unit:.4g})")
    scaling = GetOpenScaling().inputs(k, t, size)
    scaled = scaling.standardise(states)
    print("\neach variable after GetOpenScaling() (mean, sd):")
    print("  " + "  ".join(f"{i + 1}: {scaled[:, i].mean():+.2f} {scaled[:, i].std():.2f}" for i in range(len(kinds))))
    print(f"\nCEM generation 0, {args.nets} nets from N(0, I):")
    generation_zero(states, scaled, points, args.nets, args.seed)


if __name__ == "__main__":
    main()

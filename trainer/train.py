"""``keepaway train``: learn GetOpen (CEM), Pass (Sarsa) or both (Algorithm 3).

docs/players.md §8. A training is ``trials`` independent trials of one configuration, each a
walk through the schedule (:mod:`trainer.schedule`) in steps:

* a GetOpen phase advances one CEM generation per step: every candidate plays
  ``episodes_per_candidate`` episodes with Pass fixed and frozen; all candidates of a generation play
  arenas with the same seeds (common random numbers), so their fitness differs by the policy, not by
  the luck of the draw;
* a Pass phase runs Sarsa in one arena (each keeper learns its own Pass policy from its own experience,
  docs/players.md §6.3) up to the next evaluation point or the phase's end, GetOpen fixed at the best
  candidate so far;
* at 0, every ``eval_every`` episodes and the end, learning is frozen and both policies play
  ``eval_episodes`` episodes; their mean hold time and standard error form the learning curve.

A learned behaviour that has not learned yet plays: in Algorithm 3 its random policy (P:R, GO:R: "start from
P:R and GO:R", docs/players.md §8.2); alone, GO:L a net drawn from U[-0.5, 0.5] (docs/players.md §8.1) and P:L
fresh Sarsa learners (weights 0). The GetOpen policy a trial hands on (to Pass phases, evaluations and its
policy file) is the CEM's best candidate so far; the CEM's distribution carries over from one GetOpen phase to
the next. The nets drawn and searched see their inputs scaled (``TrainConfig.getopen_inputs``:
``agents.getopen.GetOpenScaling`` by default, or raw; docs/design.md, "Learning options") and play with the
scaling folded into their first layer (``Behaviours.getopen_net``); the policy file records the scaling.

The steps are played by a backend of ``config.mode`` (``runner.job.Backend``: batched, embedded or
distributed; ``runner.backends.open_backend``) as jobs (``runner.job.Job``: one may learn Pass). The
trials advance together (:func:`advance`): the jobs of the same step of every trial, and a CEM
generation's candidates, go to the backend at once (``play_all``), which plays them side by side, each
as it would alone; so the trials of a training fill the machine and each ends as if trained by itself.

Every random stream is derived from ``(seed, trial, stream, index)`` (the registry: ``runner.job``), and
each step starts fresh arenas (or arenas restarted) from such a seed; so a step's outcome depends only on
the trial's state before it. After every step the trial's state is written atomically to
``checkpoint.npz`` and the outputs are derived from it; a killed training resumed from the last checkpoint
(``resume=True``) therefore ends exactly as an uninterrupted one.

Output directory: ``config.json``, ``summary.json``, ``curves.png`` and per trial ``trial_NNN/`` with
``curve.csv`` (episodes trained, mean hold time, standard error), ``trace.jsonl`` (one line per
generation / Pass block: CEM fitness values, training hold times), ``policy.npz`` (the learned policies,
``agents.policy_file`` format) and ``checkpoint.npz``; in the embedded and distributed modes also
``transitions/pass_to_NNNNNN.npz``, the SMDP transitions every keeper reported during the Pass block that
ended at that many episodes (``keeper<k>_state``, ``_action``, ``_reward``, ``_next_action``,
``_terminal``, ``_dropped``).
"""

from __future__ import annotations

import io
import json
import os
import time
from collections.abc import Callable, Generator, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from keepaway.agents.getopen import RAW_INPUTS, SCALED_INPUTS, InputScaling, getopen_input_scaling
from keepaway.agents.policy_file import getopen_theta_size, pack_pass_arrays, read_npz, save_policy, unpack_pass_arrays
from keepaway.agents.sarsa import SarsaConfig
from keepaway.protocol.params import ServerParams, parameter_set
from keepaway.runner.backends import Placement, open_backend
from keepaway.runner.job import (
    BATCHED_SARSA,
    CHUNK_EPISODES,
    GREEDY,
    LEARN,
    MODES,
    STREAM_CEM,
    STREAM_EVALUATION,
    STREAM_GENERATION,
    STREAM_INITIAL_NET,
    STREAM_PASS_BLOCK,
    Backend,
    Behaviours,
    Game,
    Job,
    Played,
    Progress,
    RunResult,
    Transitions,
    derive_seed,
)
from keepaway.runner.report import dump_json
from keepaway.trainer.cem import CEM, CEMConfig
from keepaway.trainer.curves import (
    CurvePoint,
    curve_summary,
    mean_curve,
    plot_curves,
    stderr_basis,
    write_atomic,
    write_curve_csv,
)
from keepaway.trainer.schedule import (
    BOTH,
    CEM_PHASES,
    GETOPEN,
    LEARNED,
    PASS,
    POLICY_NAMES,
    TRAINING_EPISODES,
    Phase,
    check_generations,
    evaluation_points,
    format_schedule,
    parse_schedule,
)

CHECKPOINT_VERSION = 1
INITIAL_NET_RANGE = 0.5  # docs/players.md §8.1: a random-initialised GO:L net draws from U[-0.5, 0.5]


@dataclass(frozen=True)
class TrainConfig:
    """Everything a training's results depend on (thread counts and progress bars do not)."""

    pass_policy: str = "random"
    getopen_policy: str = LEARNED
    schedule: tuple[Phase, ...] = (Phase(GETOPEN, TRAINING_EPISODES),)
    trials: int = 1
    eval_every: int = 2_500  # docs/players.md §8.3
    eval_episodes: int = 500  # docs/players.md §8.3
    arenas: int = 2  # distributed: arenas of processes (where the chunks play, no part of any result)
    seed: int = 0
    keepers: int = 3
    takers: int = 2
    field_size: float = 20.0
    parameter_set: str = "classic"
    cem: CEMConfig = CEMConfig()
    sarsa: SarsaConfig = BATCHED_SARSA  # the batched mode's table size (runner/batched.py), in every mode
    mode: str = "batched"  # runner.job.MODES
    getopen_inputs: str = SCALED_INPUTS  # ours: how GO:L's inputs are scaled (agents.getopen.GETOPEN_INPUTS)
    # Ours, off (0) by default: Sarsa's step size annealed over Pass learning (:meth:`pass_alpha`).
    pass_alpha_halflife: int = 0
    chunk_episodes: int = CHUNK_EPISODES  # every job cut into chunks of this many (runner.job), in every mode

    def __post_init__(self) -> None:
        if self.pass_policy not in POLICY_NAMES or self.getopen_policy not in POLICY_NAMES:
            raise ValueError(f"Pass and GetOpen must each be one of {', '.join(POLICY_NAMES)}")
        learned = {GETOPEN: self.getopen_policy == LEARNED, PASS: self.pass_policy == LEARNED}
        learned[BOTH] = learned[GETOPEN] and learned[PASS]
        if not self.schedule or not all(learned[p.behaviour] for p in self.schedule):
            raise ValueError(f"the schedule {format_schedule(self.schedule)!r} must train learned behaviours only")
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, not {self.mode!r}")
        if min(self.trials, self.eval_episodes, self.arenas, self.chunk_episodes) < 1:
            raise ValueError("trials, eval_episodes, arenas and chunk_episodes must be at least 1")
        if self.cem.n_params != getopen_theta_size(self.keepers, self.takers):
            raise ValueError(f"the CEM searches {self.cem.n_params} parameters; the GetOpen net of "
                             f"{self.keepers}v{self.takers} has {getopen_theta_size(self.keepers, self.takers)}")
        if self.pass_alpha_halflife < 0:
            raise ValueError(f"pass_alpha_halflife must be at least 0, not {self.pass_alpha_halflife}")
        if self.pass_alpha_halflife and self.pass_policy != LEARNED:
            raise ValueError("an annealed Pass step size (--pass-alpha-halflife) needs learned Pass")
        if self.sarsa.hive_mind and (self.pass_policy != LEARNED or self.mode != "batched"):
            raise ValueError("a hive-mind Pass (--pass-hive-mind) needs learned Pass and the batched mode "
                             "(the keepers sharing a table must be in one process)")
        check_generations(self.schedule, self.eval_every, self.generation_episodes)
        self.params()
        self.input_scaling()

    @property
    def generation_episodes(self) -> int:
        return self.cem.population * self.cem.episodes_per_candidate

    @property
    def total_episodes(self) -> int:
        return sum(p.episodes for p in self.schedule)

    @property
    def name(self) -> str:
        """The configuration's name in the paper's notation, e.g. ``P:R-GO:L`` (docs/players.md §8.3)."""
        short = {"random": "R", "handcoded": "HC", LEARNED: "L"}
        return f"P:{short[self.pass_policy]}-GO:{short[self.getopen_policy]}"

    def params(self) -> ServerParams:
        return parameter_set(self.parameter_set, keepaway_length=self.field_size, keepaway_width=self.field_size)

    def game(self) -> Game:
        return Game(self.params(), self.keepers, self.takers, self.sarsa)

    def pass_alpha(self, pass_episodes: int) -> float:
        """Sarsa's step size for a Pass block that begins after ``pass_episodes`` episodes of Pass learning:
        the original's constant 0.125 (docs/players.md §6.3), or with a half-life h the harmonic schedule
        0.125 h / (h + n), constant within a block (blocks end at the evaluation points). The paper
        suggests annealing against the dips of its learning curves; docs/design.md, "Learning options", has
        what it does here."""
        h = self.pass_alpha_halflife
        return self.sarsa.alpha if h == 0 else self.sarsa.alpha * h / (h + pass_episodes)

    def input_scaling(self) -> InputScaling:
        """The scaling the CEM's nets see their inputs through (docs/design.md, "Learning options")."""
        return getopen_input_scaling(self.getopen_inputs, self.keepers, self.takers, self.field_size)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON values; :meth:`from_dict` inverts it."""
        out = asdict(self)
        out["schedule"] = format_schedule(self.schedule)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrainConfig:
        values = dict(data)
        values["schedule"] = parse_schedule(values["schedule"])
        values["cem"] = CEMConfig(**values["cem"])
        values["sarsa"] = SarsaConfig(**values["sarsa"])
        values.setdefault("getopen_inputs", RAW_INPUTS)  # trainings begun before scaling had raw nets
        return cls(**values)


def hive_mind_sarsa(hive_mind: bool) -> SarsaConfig:
    """A training's Sarsa configuration: the batched mode's, with the keepers of an arena sharing one
    table if ``hive_mind`` (ours, off by default: docs/design.md, "Learning options")."""
    return replace(BATCHED_SARSA, hive_mind=hive_mind)


def initial_behaviours(config: TrainConfig, trial: int) -> Behaviours:
    """What a trial plays before it has learned anything (module docstring)."""
    both = config.pass_policy == LEARNED and config.getopen_policy == LEARNED
    if both:
        return Behaviours("random", "random")
    if config.getopen_policy == LEARNED:
        rng = np.random.default_rng(derive_seed(config.seed, trial, STREAM_INITIAL_NET))
        theta = rng.uniform(-INITIAL_NET_RANGE, INITIAL_NET_RANGE, config.cem.n_params)
        return Behaviours(config.pass_policy, config.getopen_policy, theta, getopen_inputs=config.input_scaling())
    return Behaviours(config.pass_policy, config.getopen_policy)


@dataclass
class TrialState:
    """A trial's progress: everything its next step and its outputs need (module docstring)."""

    trial: int
    behaviours: Behaviours
    episodes: int = 0  # training episodes played
    curve: list[CurvePoint] = field(default_factory=list)
    trace: list[dict[str, Any]] = field(default_factory=list)
    cem: CEM | None = None
    wall_s: float = 0.0  # wall-clock seconds its steps took (a resumed trial adds up its runs)
    # the last Pass block's keeper transitions (backends that report them), until written; not checkpointed
    transitions: Transitions | None = field(default=None, repr=False)

    def finished(self, config: TrainConfig) -> bool:
        return len(self.curve) == len(evaluation_points(config.schedule, config.eval_every))


# -- playing -----------------------------------------------------------------------------------------
def evaluation_job(behaviours: Behaviours, seed: int, episodes: int) -> Job:
    """The frozen policies (no learning, greedy Pass) over ``episodes`` episodes (docs/players.md §8.3)."""
    return Job(behaviours, seed, episodes, GREEDY)


def evaluate(backend: Backend, behaviours: Behaviours, seed: int, episodes: int,
             progress: Progress | None = None) -> RunResult:
    """:func:`evaluation_job` played on ``backend``."""
    return backend.play_all([evaluation_job(behaviours, seed, episodes)], progress)[0].result


def open_training_backend(config: TrainConfig, out: Path, placement: Placement = Placement()) -> Backend:
    """The backend of ``config.mode`` for the training ``config``, its arenas placed by ``placement``
    (``runner.backends.open_backend``; arenas of processes started here log under ``out/arenas``)."""
    return open_backend(config.mode, config.game(), config.parameter_set, config.arenas, out / "arenas", placement,
                        config.chunk_episodes)


def _point(episodes: int, result: RunResult) -> CurvePoint:
    summary = result.summary()
    return CurvePoint(episodes, summary["mean_hold_time_s"], summary["stderr_hold_time_s"])


# -- one step of a trial -----------------------------------------------------------------------------
def phase_at(schedule: tuple[Phase, ...], episodes: int) -> tuple[Phase, int]:
    """The phase under way after ``episodes`` training episodes, and the episode it ends at."""
    end = 0
    for phase in schedule:
        end += phase.episodes
        if episodes < end:
            return phase, end
    raise ValueError(f"episode {episodes} is past the schedule's end ({end})")


def step(config: TrainConfig, state: TrialState, backend: Backend, progress: Progress | None = None) -> str:
    """Advance ``state`` by one step (an evaluation, a CEM generation or a Pass block) on ``backend``;
    returns what it was (e.g. "GetOpen generation 3")."""
    return advance(config, [state], backend, progress)[0]


def advance(config: TrainConfig, states: list[TrialState], backend: Backend,
            progress: Progress | None = None) -> list[str]:
    """One step of every trial in ``states``, their jobs played together round by round
    (``Backend.play_all``): a step is one round of jobs (an evaluation, a Pass block, a generation's
    candidates) or, in a ``both`` phase, one round per candidate. Trials are independent and every job
    plays as it would alone, so each trial ends exactly as if it had been trained by itself."""
    return advance_trainings([(config, state) for state in states], backend, progress)


def advance_trainings(trials: Sequence[tuple[TrainConfig, TrialState]], backend: Backend,
                      progress: Progress | None = None) -> list[str]:
    """:func:`advance` of trials of several trainings of the backend's game (an experiment's
    configurations): one step of each, all their jobs played together round by round; the batched
    backend plays arenas of different policies in one batch, so each round fills its threads."""
    if any(config.game() != backend.game for config in {id(config): config for config, _ in trials}.values()):
        raise ValueError("trainings advanced together must play the backend's game")
    steps = [_step_jobs(config, state) for config, state in trials]
    asked: dict[int, list[Job]] = {i: next(jobs) for i, jobs in enumerate(steps)}
    what: dict[int, str] = {}
    while asked:
        order = list(asked)
        played = backend.play_all([job for i in order for job in asked[i]], progress)
        for i in order:
            mine, played = played[:len(asked[i])], played[len(asked[i]):]
            try:
                asked[i] = steps[i].send(mine)
            except StopIteration as stop:
                what[i] = stop.value
                del asked[i]
    return [what[i] for i in range(len(steps))]


StepJobs = Generator[list[Job], list[Played], str]  # a step: yields rounds of jobs, gets their outcomes


def _step_jobs(config: TrainConfig, state: TrialState) -> StepJobs:
    """The next step of ``state`` (:func:`step`) as rounds of jobs; returns what it was."""
    points = evaluation_points(config.schedule, config.eval_every)
    if state.episodes == points[len(state.curve)]:
        seed = derive_seed(config.seed, state.trial, STREAM_EVALUATION, state.episodes)
        [played] = yield [evaluation_job(state.behaviours, seed, config.eval_episodes)]
        state.curve.append(_point(state.episodes, played.result))
        return f"evaluation at {state.episodes}"
    phase, phase_end = phase_at(config.schedule, state.episodes)
    if phase.behaviour in CEM_PHASES:
        return (yield from _cem_generation(config, state, learn_pass=phase.behaviour == BOTH))
    return (yield from _pass_block(config, state, min(phase_end, points[len(state.curve)]) - state.episodes))


def _cem_generation(config: TrainConfig, state: TrialState, learn_pass: bool = False) -> StepJobs:
    """One CEM generation (docs/players.md §8.1): every candidate plays the same arena seeds with the
    current Pass policy frozen; or, with ``learn_pass`` (a ``both`` phase), one after another in one arena
    each, Sarsa learning Pass in every episode and handing its learners on to the next candidate."""
    if state.cem is None:
        state.cem = CEM(config.cem, seed=derive_seed(config.seed, state.trial, STREAM_CEM))
    cem = state.cem
    generation = cem.generation
    seed = derive_seed(config.seed, state.trial, STREAM_GENERATION, generation)
    inputs = config.input_scaling()
    episodes = config.cem.episodes_per_candidate
    candidates = [replace(state.behaviours, getopen_policy=LEARNED, getopen_theta=theta, getopen_inputs=inputs)
                  for theta in cem.ask()]
    entry: dict[str, Any] = {"phase": BOTH if learn_pass else GETOPEN, "generation": generation}
    if learn_pass:
        alpha = config.pass_alpha(_pass_episodes_learned(state))
        results = []
        for candidate in candidates:
            learner = replace(candidate, pass_policy=LEARNED, pass_arrays=state.behaviours.pass_arrays)
            [played] = yield [Job(learner, seed, episodes, LEARN, alpha if config.pass_alpha_halflife else None)]
            results.append(played.result)
            state.behaviours.pass_arrays, state.transitions = played.pass_arrays, played.transitions
        state.behaviours.pass_policy = LEARNED
        entry.update(block_episodes=config.generation_episodes, alpha=alpha)
    else:
        results = [p.result for p in (yield [evaluation_job(c, seed, episodes) for c in candidates])]
    fitness = [result.summary()["mean_hold_time_s"] for result in results]
    cem.tell(np.array(fitness))
    state.behaviours.getopen_policy = LEARNED
    state.behaviours.getopen_theta = cem.played()
    state.behaviours.getopen_inputs = inputs
    state.episodes += config.generation_episodes
    entry.update(episodes=state.episodes, fitness=fitness, best_fitness=cem.best_fitness,
                 mean_variance=float(cem.variance.mean()))
    state.trace.append(entry)
    return f"{'GetOpen and Pass' if learn_pass else 'GetOpen'} generation {generation + 1}"


def _pass_episodes_learned(state: TrialState) -> int:
    """Episodes of Pass learning so far (Pass blocks and ``both`` generations), for the annealed alpha."""
    return sum(r["block_episodes"] for r in state.trace if r["phase"] in (PASS, BOTH))


def _pass_block(config: TrainConfig, state: TrialState, episodes: int) -> StepJobs:
    """Sarsa learns Pass for ``episodes`` episodes in one fresh arena, GetOpen fixed (docs/players.md §6.3, §8.2)."""
    learner = replace(state.behaviours, pass_policy=LEARNED)
    seed = derive_seed(config.seed, state.trial, STREAM_PASS_BLOCK, state.episodes)
    alpha = config.pass_alpha(_pass_episodes_learned(state))
    [played] = yield [Job(learner, seed, episodes, LEARN, alpha if config.pass_alpha_halflife else None)]
    state.behaviours.pass_policy = LEARNED
    state.behaviours.pass_arrays = played.pass_arrays
    state.transitions = played.transitions
    state.episodes += episodes
    summary = played.result.summary()
    state.trace.append({"phase": PASS, "episodes": state.episodes, "block_episodes": episodes,
                        "mean_hold_time_s": summary["mean_hold_time_s"],
                        "stderr_hold_time_s": summary["stderr_hold_time_s"], "alpha": alpha})
    return f"Pass block to {state.episodes}"


# -- checkpoints and outputs -------------------------------------------------------------------------
def trial_dir(out: Path, trial: int) -> Path:
    return out / f"trial_{trial:03d}"


def save_checkpoint(out: Path, state: TrialState) -> None:
    """The trial's state as one ``checkpoint.npz`` (a JSON header and the arrays), written atomically."""
    b = state.behaviours
    header: dict[str, Any] = {
        "version": CHECKPOINT_VERSION, "trial": state.trial, "episodes": state.episodes,
        "keepers": len(b.pass_arrays) if b.pass_arrays is not None else None,
        "curve": [asdict(p) for p in state.curve], "trace": state.trace,
        "pass_policy": b.pass_policy, "getopen_policy": b.getopen_policy, "cem": None, "wall_s": state.wall_s,
        "getopen_inputs": None if b.getopen_inputs is None else b.getopen_inputs.to_json(),
    }
    arrays: dict[str, np.ndarray] = {}
    if b.getopen_theta is not None:
        arrays["getopen_theta"] = b.getopen_theta
    if b.pass_arrays is not None:
        arrays.update({f"behaviour_{name}": v for name, v in pack_pass_arrays(b.pass_arrays).items()})
    if state.cem is not None:
        cem = state.cem.state_dict()
        for name in ("mean", "variance", "best_params"):
            if cem[name] is not None:
                arrays[f"cem_{name}"] = cem.pop(name)
        header["cem"] = {k: v for k, v in cem.items() if k not in ("mean", "variance", "best_params")}
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    write_atomic(trial_dir(out, state.trial) / "checkpoint.npz", buffer.getvalue())


def _unreadable(exc: Exception) -> str:
    """Why a stored file could not be used, in one line."""
    return f"no {exc}" if isinstance(exc, KeyError) else " ".join(str(exc).split()) or type(exc).__name__


STORED_FILE_ERRORS = (OSError, ValueError, KeyError, TypeError, AttributeError)
_JSON_TYPES = {int: "an integer", float: "a number", str: "a string", dict: "a map", bool: "true or false"}


def load_checkpoint(out: Path, trial: int) -> TrialState | None:
    """The trial's last checkpoint, or None if it has none. One that cannot be used (truncated,
    overwritten, of another trial) is a ValueError in one line naming the file and the way out."""
    path = trial_dir(out, trial) / "checkpoint.npz"
    if not path.is_file():
        return None
    try:
        arrays = read_npz(path)
        header = json.loads(arrays.pop("header").tobytes().decode())
        if header.get("version") != CHECKPOINT_VERSION or header.get("trial") != trial:
            raise ValueError(f"not a version {CHECKPOINT_VERSION} checkpoint of trial {trial}")
        packed = {k.removeprefix("behaviour_"): v for k, v in arrays.items() if k.startswith("behaviour_")}
        behaviours = Behaviours(header["pass_policy"], header["getopen_policy"], arrays.get("getopen_theta"),
                                unpack_pass_arrays(packed, header["keepers"]) if packed else None)
        if header.get("getopen_inputs") is not None:  # absent: a checkpoint of a net on raw inputs
            behaviours.getopen_inputs = InputScaling.from_json(header["getopen_inputs"],
                                                               len(header["getopen_inputs"]["mean"]))
        cem = None
        if header["cem"] is not None:
            cem = CEM.from_state_dict({**header["cem"], "mean": arrays["cem_mean"], "variance": arrays["cem_variance"],
                                       "best_params": arrays.get("cem_best_params")})
        return TrialState(trial, behaviours, header["episodes"], [CurvePoint(**p) for p in header["curve"]],
                          header["trace"], cem, wall_s=header.get("wall_s", 0.0))
    except STORED_FILE_ERRORS as exc:
        raise ValueError(f"{path}: unusable checkpoint ({_unreadable(exc)}); restore it from a copy, or delete it "
                         f"to play trial {trial} again from its start (the other trials are kept)") from None


def write_transitions(out: Path, state: TrialState) -> None:
    """The last Pass block's keeper transitions (if any) as ``transitions/pass_to_NNNNNN.npz``, written
    atomically; then they are dropped from the state."""
    if state.transitions is None:
        return
    arrays = {f"keeper{unum}_{name}": value for unum, keeper in state.transitions.items()
              for name, value in keeper.items()}
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    where = trial_dir(out, state.trial) / "transitions"
    where.mkdir(exist_ok=True)
    write_atomic(where / f"pass_to_{state.episodes:06d}.npz", buffer.getvalue())
    state.transitions = None


def write_trial_outputs(config: TrainConfig, out: Path, state: TrialState) -> None:
    """``curve.csv``, ``trace.jsonl`` and (once something is learned) ``policy.npz`` of a trial, each
    derived from its state and written atomically."""
    where = trial_dir(out, state.trial)
    write_curve_csv(where / "curve.csv", state.curve)
    write_atomic(where / "trace.jsonl", "".join(json.dumps(t) + "\n" for t in state.trace).encode())
    b = state.behaviours
    learned_getopen = config.getopen_policy == LEARNED and b.getopen_policy == LEARNED
    learned_pass = config.pass_policy == LEARNED and b.pass_arrays is not None
    if not (learned_getopen or learned_pass):
        return
    header = {"keepers": config.keepers, "takers": config.takers, "pass": b.pass_policy,
              "getopen": b.getopen_policy, "field_size": config.field_size,
              "parameter_set": config.parameter_set, "sarsa": asdict(config.sarsa), "trial": state.trial,
              "episodes": state.episodes, "train": config.to_dict()}
    tmp = where / ".policy.tmp.npz"
    save_policy(tmp, getopen_theta=b.getopen_theta if learned_getopen else None,
                pass_arrays=pack_pass_arrays(b.pass_arrays) if learned_pass else None, config=header,
                seed=config.seed, getopen_inputs=b.getopen_inputs if learned_getopen else None)
    os.replace(tmp, where / "policy.npz")


def summarise(config: TrainConfig, states: list[TrialState]) -> dict[str, Any]:
    """``summary.json``: the configuration, every trial's curve and the curve over trials with its final
    point; ``stderr_over`` says what the curve's standard errors are over: "trials", or with one trial
    "episodes" (of each evaluation; ``trainer.curves.mean_curve``). Undefined values are None."""
    return {
        "name": config.name,
        "config": config.to_dict(),
        "trials": [{"trial": s.trial, "episodes": s.episodes, "finished": s.finished(config), "wall_s": s.wall_s,
                    "curve": [asdict(p) for p in s.curve],
                    "best_fitness": None if s.cem is None else s.cem.best_fitness} for s in states],
        **curve_summary([s.curve for s in states]),
    }


def write_summary(config: TrainConfig, out: Path, states: list[TrialState]) -> dict[str, Any]:
    """``summary.json`` (strict JSON) and ``curves.png`` over the trials so far. The plot marks the random
    keepers' level (P:R-GO:R) where the training measured it: its evaluation at 0 when the trial starts
    from random policies (Algorithm 3)."""
    summary = summarise(config, states)
    write_atomic(out / "summary.json", dump_json(summary, indent=1).encode())
    curve = mean_curve([s.curve for s in states])
    start = initial_behaviours(config, 0)
    references = {}
    if curve and curve[0].episodes == 0 and (start.pass_policy, start.getopen_policy) == ("random", "random"):
        references["P:R-GO:R (evaluation at 0)"] = curve[0].mean_hold_time_s
    label = f"{config.name} (band: {stderr_basis(len(states), config.eval_episodes)})"
    plot_curves(out / "curves.png", {label: curve}, f"Keepaway {config.keepers}v{config.takers}: {config.name}",
                references)
    return summary


# -- the training ------------------------------------------------------------------------------------
def write_config(config: TrainConfig, out: Path) -> None:
    """Start a training in ``out`` (created): its ``config.json``. Refuses a directory that already holds
    a training (continue that with ``resume``)."""
    out.mkdir(parents=True, exist_ok=True)
    if (out / "config.json").exists():
        raise FileExistsError(f"{out} already holds a training; continue it with --resume {out}")
    write_atomic(out / "config.json", json.dumps(config.to_dict(), indent=1).encode())


def read_config(out: Path) -> TrainConfig:
    """The configuration of the training in ``out``: FileNotFoundError if it holds none, ValueError (one
    line naming the file and the way out) if its ``config.json`` cannot be used."""
    path = out / "config.json"
    if not path.is_file():
        raise FileNotFoundError(f"{out} holds no training (no config.json)")
    try:
        data = json.loads(path.read_text())
        if type(data) is not dict:
            raise ValueError("not a JSON object")
        defaults = TrainConfig().to_dict()
        unknown = sorted(set(data) - set(defaults))
        if unknown:
            raise ValueError(f"unknown setting(s) {', '.join(unknown)}")
        if data.get("mode", "batched") == "batched" and "chunk_episodes" not in data:
            raise ValueError("begun by the batched mode before it played chunks as the other modes do: "
                             "resumed now it would go on with other games")
        for key, default in defaults.items():
            value = data.get(key, default)
            if type(value) is not type(default) and not (type(default) is float and type(value) is int):
                raise ValueError(f"{key} is {value!r}, expected {_JSON_TYPES[type(default)]}")
        return TrainConfig.from_dict(data)
    except STORED_FILE_ERRORS as exc:
        raise ValueError(f"{path}: unusable training configuration ({_unreadable(exc)}); restore it from a copy, "
                         f"or start a new training in another --out directory") from None


def load_trials(config: TrainConfig, out: Path) -> list[TrialState]:
    """Every trial of the training in ``out`` (begun by :func:`write_config`) at its last checkpoint, or
    at its start."""
    states = []
    for trial in range(config.trials):
        trial_dir(out, trial).mkdir(exist_ok=True)
        states.append(load_checkpoint(out, trial) or TrialState(trial, initial_behaviours(config, trial)))
    return states


def run_trials(config: TrainConfig, out: Path, states: list[TrialState], backend: Backend,
               progress: Progress | None = None,
               on_step: Callable[[TrialState], None] | None = None) -> list[TrialState]:
    """Train the trials ``states`` (:func:`load_trials`) of the training in ``out`` to their end on
    ``backend``; returns them. The trials advance together, a step each at a time (:func:`advance`: a
    backend plays their jobs side by side), and each ends as it would alone; a trial's ``wall_s`` is its
    share of the steps' wall time. ``progress`` hears of every episode played, ``on_step`` of every step."""
    while running := [state for state in states if not state.finished(config)]:
        start = time.perf_counter()
        advance(config, running, backend, progress)
        share = (time.perf_counter() - start) / len(running)
        for state in running:
            record_step(config, out, state, share)
            if on_step is not None:
                on_step(state)
    for state in states:
        write_trial_outputs(config, out, state)
    return states


def record_step(config: TrainConfig, out: Path, state: TrialState, wall_s: float) -> None:
    """After a step of ``state`` (of the training in ``out``) that took ``wall_s`` of its share of the wall
    time: its transitions, checkpoint and outputs written."""
    state.wall_s += wall_s
    write_transitions(out, state)
    save_checkpoint(out, state)
    write_trial_outputs(config, out, state)


def played_episodes(config: TrainConfig, state: TrialState) -> int:
    """Episodes a trial has played so far, training and evaluation (for progress bars)."""
    return state.episodes + len(state.curve) * config.eval_episodes


def planned_episodes(config: TrainConfig) -> int:
    """Episodes a trial plays in all, training and evaluation."""
    return config.total_episodes + len(evaluation_points(config.schedule, config.eval_every)) * config.eval_episodes


def train(config: TrainConfig, out: Path, resume: bool = False, progress: bool = True,
          placement: Placement = Placement()) -> dict[str, Any]:
    """Run (or with ``resume`` continue) the training ``config`` in ``out``; returns the summary.
    With ``resume`` the configuration is the one stored in ``out``. ``placement`` says where the arenas
    run (:func:`open_training_backend`)."""
    from tqdm import tqdm

    if resume:
        config = read_config(out)
    else:
        write_config(config, out)

    def on_step(state: TrialState) -> None:  # the last evaluation, short enough to leave the bar room
        if state.curve:
            last = state.curve[-1]
            trial = f"trial {state.trial + 1} " if config.trials > 1 else ""
            bar.set_postfix_str(f"{trial}eval {last.mean_hold_time_s:.2f} s @{last.episodes}")

    backend = open_training_backend(config, out, placement)
    try:
        states = load_trials(config, out)
        bar = tqdm(total=planned_episodes(config) * config.trials, unit="ep", dynamic_ncols=True,
                   initial=sum(played_episodes(config, state) for state in states),
                   desc=f"{config.name}, {config.trials} trial{'s' if config.trials > 1 else ''}",
                   disable=not progress)
        with bar:
            run_trials(config, out, states, backend, bar.update, on_step)
        write_summary(config, out, states)
    finally:
        backend.close()
    return summarise(config, states)


__all__ = [
    "TrainConfig",
    "TrialState",
    "advance",
    "advance_trainings",
    "evaluate",
    "evaluation_job",
    "initial_behaviours",
    "load_checkpoint",
    "load_trials",
    "open_training_backend",
    "phase_at",
    "read_config",
    "record_step",
    "run_trials",
    "save_checkpoint",
    "step",
    "summarise",
    "train",
    "write_config",
    "write_summary",
    "write_trial_outputs",
]

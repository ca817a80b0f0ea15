"""Training schedules: which behaviour learns in which stretch of episodes (docs/players.md §8.2, §8.3).

A schedule is a sequence of phases, each one behaviour learning for a number of episodes while the other
stays fixed at its current value. Algorithm 3 alternates GetOpen (CEM) and Pass (Sarsa) phases; the
single-behaviour trainings (P:L with GetOpen fixed, GO:L with Pass fixed) are one phase. Written on the
command line as ``getopen:5000,pass:5000,getopen:15000,pass:5000``.

Ours, beyond the paper: a ``both`` phase learns the two behaviours at once. It runs CEM generations as a
GetOpen phase does, but its candidates play one after another with Sarsa learning Pass in every episode,
the learners carried from candidate to candidate (``trainer.train``); so each behaviour learns in every
episode of the phase instead of in its share of them (docs/design.md, "Learning options").
"""

from __future__ import annotations

from dataclasses import dataclass

GETOPEN = "getopen"
PASS = "pass"
BOTH = "both"  # ours: GetOpen's CEM and Pass's Sarsa learn in the same episodes (module docstring)
BEHAVIOURS = (GETOPEN, PASS, BOTH)
CEM_PHASES = (GETOPEN, BOTH)  # phases that advance one CEM generation per step
LEARNED = "learned"
POLICY_NAMES = ("random", "handcoded", LEARNED)  # what train and evaluate offer for Pass and for GetOpen
TRAINING_EPISODES = 30_000  # docs/players.md §8.3: training length


@dataclass(frozen=True)
class Phase:
    """``behaviour`` learns for ``episodes`` episodes; the other behaviour is fixed (``both``: neither is)."""

    behaviour: str
    episodes: int

    def __post_init__(self) -> None:
        if self.behaviour not in BEHAVIOURS:
            raise ValueError(f"unknown behaviour {self.behaviour!r}; choose one of {', '.join(BEHAVIOURS)}")
        if self.episodes < 1:
            raise ValueError(f"a {self.behaviour} phase needs at least one episode, got {self.episodes}")


# docs/players.md §8.2: 2 CEM generations, 5,000 Sarsa episodes, 6 CEM generations, 5,000 Sarsa episodes.
ALGORITHM_3 = (Phase(GETOPEN, 5_000), Phase(PASS, 5_000), Phase(GETOPEN, 15_000), Phase(PASS, 5_000))


def parse_schedule(text: str) -> tuple[Phase, ...]:
    """``"getopen:5000,pass:5000"`` as phases; ValueError (one line) for anything else."""
    phases = []
    for item in text.split(","):
        behaviour, sep, episodes = item.strip().partition(":")
        if not sep or not episodes.strip().isdigit():
            raise ValueError(f"schedule item {item.strip()!r} is not BEHAVIOUR:EPISODES")
        phases.append(Phase(behaviour.strip(), int(episodes)))
    return tuple(phases)


def format_schedule(phases: tuple[Phase, ...]) -> str:
    """The inverse of :func:`parse_schedule`."""
    return ",".join(f"{p.behaviour}:{p.episodes}" for p in phases)


def training_schedule(pass_policy: str, getopen_policy: str, episodes: int | None = None,
                      schedule: tuple[Phase, ...] | None = None) -> tuple[Phase, ...]:
    """The phases of a training of Pass ``pass_policy`` and GetOpen ``getopen_policy`` (each random,
    handcoded or learned). Both learned: ``schedule``, by default Algorithm 3 (``episodes``, if given,
    must be its length). One learned: one phase of ``episodes`` (default 30,000) of that behaviour. A
    given ``schedule`` must only name behaviours that learn."""
    learners = tuple(b for b, name in ((GETOPEN, getopen_policy), (PASS, pass_policy)) if name == LEARNED)
    if not learners:
        raise ValueError("nothing to learn: make --pass or --getopen learned (keepaway evaluate plays fixed policies)")
    if schedule is None:
        if len(learners) == 2:
            schedule = ALGORITHM_3
        else:
            schedule = (Phase(learners[0], TRAINING_EPISODES if episodes is None else episodes),)
    fixed = sorted({p.behaviour for p in schedule} - set(learners + ((BOTH,) if len(learners) == 2 else ())))
    if fixed:
        raise ValueError(f"the schedule trains {', '.join(fixed)}, which is not learned in this configuration"
                         + (" (a both phase needs Pass and GetOpen learned)" if BOTH in fixed else ""))
    total = sum(p.episodes for p in schedule)
    if episodes is not None and episodes != total:
        raise ValueError(f"--episodes {episodes} differs from the schedule's {total} episodes")
    return tuple(schedule)


def evaluation_points(phases: tuple[Phase, ...], eval_every: int) -> list[int]:
    """Episodes trained at which learning is frozen and evaluated: 0, every ``eval_every`` and the end
    (docs/players.md §8.3: every 2,500 of 30,000)."""
    if eval_every < 1:
        raise ValueError("the evaluation interval must be at least one episode")
    total = sum(p.episodes for p in phases)
    return sorted(set(range(0, total, eval_every)) | {total})


def check_generations(phases: tuple[Phase, ...], eval_every: int, generation_episodes: int) -> None:
    """A GetOpen phase advances a whole CEM generation at a time, so its length and every evaluation
    point inside it must fall on a generation boundary; ValueError naming the first that does not."""
    points = evaluation_points(phases, eval_every)
    start = 0
    for p in phases:
        end = start + p.episodes
        if p.behaviour in CEM_PHASES:
            for e in [end] + [e for e in points if start < e < end]:
                if (e - start) % generation_episodes:
                    raise ValueError(f"episode {e} falls inside a CEM generation of {generation_episodes} "
                                     f"episodes (GetOpen phase {start}-{end}); choose the schedule and "
                                     f"--eval-every as multiples of it")
        start = end


def denser_eval_every(phases: tuple[Phase, ...], eval_every: int, generation_episodes: int,
                      points: int) -> int | None:
    """An evaluation interval for a curve of about ``points`` points, evenly spread: the largest multiple of
    a CEM generation (of an episode, without GetOpen phases) up to ``total / (points - 1)`` that
    :func:`check_generations` accepts; None if there is none or it gives no more points than ``eval_every``."""
    total = sum(p.episodes for p in phases)
    unit = generation_episodes if any(p.behaviour in CEM_PHASES for p in phases) else 1
    for every in range(total // (points - 1) // unit * unit, 0, -unit):
        try:
            check_generations(phases, every, generation_episodes)
        except ValueError:
            continue
        more = len(evaluation_points(phases, every)) > len(evaluation_points(phases, eval_every))
        return every if more else None
    return None


__all__ = [
    "ALGORITHM_3",
    "BEHAVIOURS",
    "BOTH",
    "CEM_PHASES",
    "GETOPEN",
    "LEARNED",
    "PASS",
    "POLICY_NAMES",
    "TRAINING_EPISODES",
    "Phase",
    "check_generations",
    "denser_eval_every",
    "evaluation_points",
    "format_schedule",
    "parse_schedule",
    "training_schedule",
]

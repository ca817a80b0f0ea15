"""The server/player parameter table, shared by the server and every client.

One frozen dataclass holds every physical, perceptual and referee constant by name, as rcssserver's
``server_param``/``player_param`` do (docs/rules.md §9; rcssserver src/serverparam.cpp). Two named sets
exist:

* ``classic`` (default): rcssserver 11.1.1, the server generation the Keepaway experiments used;
* ``current``: rcssserver 19.0.0 defaults (polar noise, kick noise, bipedal-era dash rates, capacity).

The set actually used by a server is sent to every client in ``init_ok`` so both sides agree. Kernels
receive ``params.kernel()``, a flat record of floats that numba takes as one pointer (``core.records``).
"""

from __future__ import annotations

import dataclasses
import math
from collections import namedtuple
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from keepaway.core.records import kernel_record

# Enumerations stored as floats in the kernel record (numba wants one field type).
NOISE_AXIS = 0.0  # CLASSIC: per-axis U(-r, r)
NOISE_POLAR = 1.0  # 12.0+: polar, length U(0, r), direction U(-pi, pi)


@dataclass(frozen=True)
class Range:
    """The interval a setting's value must lie in; ``low_open``/``high_open`` exclude that bound."""

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False

    def __contains__(self, value: float) -> bool:
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return above and below

    def __str__(self) -> str:
        low, high = (str(b) if isinstance(b, int) else f"{b:g}" for b in (self.low, self.high))
        return f"{'(' if self.low_open else '['}{low}, {high}{')' if self.high_open else ']'}"


@dataclass(frozen=True)
class OneOf:
    """The values a setting may take."""

    values: tuple

    def __contains__(self, value: Any) -> bool:
        return value in self.values

    def __str__(self) -> str:
        return "{" + ", ".join(v if isinstance(v, str) else f"{v:g}" for v in self.values) + "}"


ANY = Range(low_open=True, high_open=True)
POSITIVE = Range(0.0, low_open=True, high_open=True)
NON_NEGATIVE = Range(0.0, high_open=True)
FRACTION = Range(0.0, 1.0)
ANGLE = Range(-180.0, 180.0)
CYCLES = Range(1.0, high_open=True)
FLAG = OneOf((0, 1))  # a bool parameter (False/True, or 0/1 from the command line)


@dataclass(frozen=True)
class ServerParams:
    """Every constant of the simulation, named as in rcssserver (units: m, m/cycle, deg, cycles, ms)."""

    name: str = "classic"

    # timing (docs/rules.md §8)
    simulator_step_ms: float = 100.0
    sense_body_step_ms: float = 100.0
    send_step_ms: float = 150.0

    # field (docs/rules.md §6)
    pitch_length: float = 105.0
    pitch_width: float = 68.0

    # ball (docs/rules.md §1)
    ball_size: float = 0.085
    ball_decay: float = 0.94
    ball_rand: float = 0.05
    ball_speed_max: float = 2.7
    ball_accel_max: float = 2.7

    # player type 0 (docs/rules.md §1)
    player_size: float = 0.3
    player_decay: float = 0.4
    player_rand: float = 0.1
    player_speed_max: float = 1.2
    player_accel_max: float = 1.0
    inertia_moment: float = 5.0
    kickable_margin: float = 0.7
    movement_noise: float = NOISE_AXIS

    # dash (docs/rules.md §2, "dash")
    dash_power_rate: float = 0.006
    min_dash_power: float = -100.0
    max_dash_power: float = 100.0
    min_dash_angle: float = 0.0
    max_dash_angle: float = 0.0
    dash_angle_step: float = 1.0
    side_dash_rate: float = 0.4
    back_dash_rate: float = 0.7

    # turn / neck (docs/rules.md §2, "turn")
    min_moment: float = -180.0
    max_moment: float = 180.0
    min_neck_moment: float = -180.0
    max_neck_moment: float = 180.0
    min_neck_angle: float = -90.0
    max_neck_angle: float = 90.0

    # kick (docs/rules.md §2, "kick")
    min_power: float = -100.0
    max_power: float = 100.0
    kick_power_rate: float = 0.027
    kick_rand: float = 0.0
    kick_noise: float = NOISE_AXIS
    failed_kick_uses_slot: bool = False

    # stamina (docs/rules.md §4)
    stamina_max: float = 4000.0
    stamina_inc_max: float = 45.0
    extra_stamina: float = 0.0
    stamina_capacity: float = -1.0  # negative: no capacity model
    recover_dec_thr: float = 0.3
    recover_dec: float = 0.002
    recover_min: float = 0.5
    recover_init: float = 1.0
    effort_dec_thr: float = 0.3
    effort_dec: float = 0.005
    effort_min: float = 0.6
    effort_max: float = 1.0
    effort_inc_thr: float = 0.6
    effort_inc: float = 0.01
    effort_init: float = 1.0
    effort_inc_uses_dec_thr: bool = True  # the CLASSIC bug: effort grows above effort_dec_thr

    # tackle (docs/rules.md §2; accepted, not used by the Keepaway agents)
    tackle_cycles: float = 10.0

    # perception (docs/rules.md §5)
    visible_angle: float = 90.0
    visible_distance: float = 3.0
    quantize_step: float = 0.1
    quantize_step_l: float = 0.01
    dir_chg_step: float = 0.1
    dist_chg_step: float = 0.02
    unum_far_length: float = 20.0
    unum_too_far_length: float = 40.0
    team_far_length: float = 40.0
    team_too_far_length: float = 60.0
    team_loss_probabilistic: bool = False  # CURRENT: team dropped with p(40/60); CLASSIC: cut at 60
    see_behind_strict: bool = True  # |bearing| < cone/2 strictly, so an object exactly behind is unseen

    # hearing (docs/rules.md §5.5)
    audio_cut_dist: float = 50.0
    hear_max: float = 1.0
    hear_inc: float = 1.0
    hear_decay: float = 1.0
    say_msg_size: float = 10.0

    # keepaway referee (docs/rules.md §7)
    keepaway_length: float = 20.0
    keepaway_width: float = 20.0
    take_cycles: float = 4.0
    reset_restores_stamina: bool = False
    ball_stuck_area: float = 3.0
    drop_ball_time: float = 200.0

    def __post_init__(self) -> None:
        """Refuse, in one line, a value outside its :data:`PARAMETER_RANGES` entry or a bound pair of
        :data:`ORDERED_PARAMETERS` in the wrong order: every way of building a set is checked alike."""
        if not isinstance(self.name, str):
            raise ValueError(f"server parameter name={self.name!r} is not a string")
        for key in PARAMETER_RANGES:
            check_parameter(key, getattr(self, key))
        for low, high, strict in ORDERED_PARAMETERS:
            a, b = getattr(self, low), getattr(self, high)
            if a > b or (strict and a == b):
                raise ValueError(f"server parameter {low}={a!r} must {'be below' if strict else 'not exceed'} "
                                 f"{high}={b!r}")

    # derived quantities
    @property
    def kickable_distance(self) -> float:
        """Centre distance at which a player can kick the ball: 0.3 + 0.7 + 0.085 = 1.085 m."""
        return self.player_size + self.kickable_margin + self.ball_size

    def replace(self, **changes: Any) -> "ServerParams":
        """A copy with some values changed; unknown names and values outside :data:`PARAMETER_RANGES`
        are a ValueError."""
        for key in changes:
            if key != "name" and key not in PARAMETER_RANGES:
                raise ValueError(f"unknown server parameter {key!r}")
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Wire form (string keys, plain values), as sent in ``init_ok``."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "ServerParams":
        """Inverse of :meth:`to_dict`; rejects unknown names and wrong types."""
        if not isinstance(data, dict):
            raise ValueError("server parameters must be a map")
        base = cls()
        return base.replace(**data)

    def kernel(self) -> np.record:
        """The numeric fields (:data:`KernelParams`) as a record of floats, the form numba kernels take
        (``core.records``)."""
        return kernel_record(KernelParams(*(float(getattr(self, n)) for n in KernelParams._fields)))


NOISE_MODELS = OneOf((NOISE_AXIS, NOISE_POLAR))

# The physically meaningful values of every parameter (docs/rules.md §9): decays, rates and
# noise amplitudes are fractions; sizes, steps and speeds are positive; angles lie in [-180, 180].
PARAMETER_RANGES: dict[str, Range | OneOf] = {
    # timing
    "simulator_step_ms": POSITIVE, "sense_body_step_ms": POSITIVE, "send_step_ms": POSITIVE,
    # field
    "pitch_length": POSITIVE, "pitch_width": POSITIVE,
    # ball
    "ball_size": POSITIVE, "ball_decay": FRACTION, "ball_rand": FRACTION, "ball_speed_max": POSITIVE,
    "ball_accel_max": POSITIVE,
    # player type 0
    "player_size": POSITIVE, "player_decay": FRACTION, "player_rand": FRACTION, "player_speed_max": POSITIVE,
    "player_accel_max": POSITIVE, "inertia_moment": NON_NEGATIVE, "kickable_margin": POSITIVE,
    "movement_noise": NOISE_MODELS,
    # dash (dash_angle_step 0: any direction)
    "dash_power_rate": POSITIVE, "min_dash_power": ANY, "max_dash_power": ANY, "min_dash_angle": ANGLE,
    "max_dash_angle": ANGLE, "dash_angle_step": NON_NEGATIVE, "side_dash_rate": FRACTION,
    "back_dash_rate": FRACTION,
    # turn / neck
    "min_moment": ANGLE, "max_moment": ANGLE, "min_neck_moment": ANGLE, "max_neck_moment": ANGLE,
    "min_neck_angle": ANGLE, "max_neck_angle": ANGLE,
    # kick
    "min_power": ANY, "max_power": ANY, "kick_power_rate": POSITIVE, "kick_rand": FRACTION,
    "kick_noise": NOISE_MODELS, "failed_kick_uses_slot": FLAG,
    # stamina (stamina_capacity < 0: no capacity model)
    "stamina_max": POSITIVE, "stamina_inc_max": NON_NEGATIVE, "extra_stamina": NON_NEGATIVE,
    "stamina_capacity": ANY, "recover_dec_thr": FRACTION, "recover_dec": FRACTION, "recover_min": FRACTION,
    "recover_init": FRACTION, "effort_dec_thr": FRACTION, "effort_dec": FRACTION, "effort_min": FRACTION,
    "effort_max": FRACTION, "effort_inc_thr": FRACTION, "effort_inc": FRACTION, "effort_init": FRACTION,
    "effort_inc_uses_dec_thr": FLAG,
    # tackle
    "tackle_cycles": NON_NEGATIVE,
    # perception
    "visible_angle": Range(0.0, 360.0, low_open=True), "visible_distance": NON_NEGATIVE,
    "quantize_step": POSITIVE, "quantize_step_l": POSITIVE, "dir_chg_step": POSITIVE, "dist_chg_step": POSITIVE,
    "unum_far_length": NON_NEGATIVE, "unum_too_far_length": NON_NEGATIVE, "team_far_length": NON_NEGATIVE,
    "team_too_far_length": NON_NEGATIVE, "team_loss_probabilistic": FLAG, "see_behind_strict": FLAG,
    # hearing
    "audio_cut_dist": NON_NEGATIVE, "hear_max": NON_NEGATIVE, "hear_inc": NON_NEGATIVE,
    "hear_decay": NON_NEGATIVE, "say_msg_size": NON_NEGATIVE,
    # keepaway referee (ball_stuck_area or drop_ball_time 0: no BallStuck referee)
    "keepaway_length": POSITIVE, "keepaway_width": POSITIVE, "take_cycles": CYCLES,
    "reset_restores_stamina": FLAG, "ball_stuck_area": NON_NEGATIVE, "drop_ball_time": NON_NEGATIVE,
}

# Pairs (low, high, strict) whose values must be ordered: low <= high, or low < high if strict (the
# far/too-far lengths divide by their difference); the Keepaway region lies within the pitch.
ORDERED_PARAMETERS: tuple[tuple[str, str, bool], ...] = (
    ("min_dash_power", "max_dash_power", False),
    ("min_dash_angle", "max_dash_angle", False),
    ("min_moment", "max_moment", False),
    ("min_neck_moment", "max_neck_moment", False),
    ("min_neck_angle", "max_neck_angle", False),
    ("min_power", "max_power", False),
    ("effort_min", "effort_max", False),
    ("unum_far_length", "unum_too_far_length", True),
    ("team_far_length", "team_too_far_length", True),
    ("keepaway_length", "pitch_length", False),
    ("keepaway_width", "pitch_width", False),
)


def check_parameter(name: str, value: Any) -> None:
    """Raise ValueError (one line: the parameter, the value and what is allowed) unless ``value`` is a
    finite number in :data:`PARAMETER_RANGES` ``[name]`` (true/false or 0/1 for a flag)."""
    allowed = PARAMETER_RANGES.get(name)
    if allowed is None:
        raise ValueError(f"unknown server parameter {name!r}")
    flag = allowed is FLAG
    if type(value) not in ((bool, int, float) if flag else (int, float)):
        raise ValueError(f"server parameter {name}={value!r} is not {'true/false' if flag else 'a number'}")
    if not math.isfinite(value):
        raise ValueError(f"server parameter {name}={value!r} is not a finite number")
    if value not in allowed:
        raise ValueError(f"server parameter {name}={value!r} is out of range: allowed {allowed}")


KernelParams = namedtuple(
    "KernelParams", [f.name for f in fields(ServerParams) if f.name != "name"]
)
KernelParams.__module__ = __name__

CLASSIC = ServerParams()

CURRENT = ServerParams(
    name="current",
    ball_speed_max=3.0,
    player_speed_max=1.05,
    movement_noise=NOISE_POLAR,
    min_dash_power=0.0,
    min_dash_angle=-180.0,
    max_dash_angle=180.0,
    kick_rand=0.1,
    kick_noise=NOISE_POLAR,
    failed_kick_uses_slot=True,
    stamina_max=8000.0,
    extra_stamina=50.0,
    stamina_capacity=130600.0,
    effort_inc_uses_dec_thr=False,
    team_loss_probabilistic=True,
    reset_restores_stamina=True,
    drop_ball_time=100.0,
)

PARAMETER_SETS: dict[str, ServerParams] = {"classic": CLASSIC, "current": CURRENT}

# keepaway.sh launch settings (docs/rules.md §9; keepaway-0.6 keepaway.sh).
KEEPAWAY_LAUNCH: dict[str, float] = {"stamina_inc_max": 3500.0, "visible_angle": 360.0}


# Team sizes (docs/players.md §1): uniform numbers run from 1 to 11 on each side. A server
# simulates any such teams; the Keepaway task needs a keeper to pass to (Pass chooses HoldBall or
# PassBall-k, k = 2..K) and a taker to end episodes.
MAX_TEAM_SIZE = 11
TEAM_SIZE = Range(1, MAX_TEAM_SIZE)
KEEPAWAY_KEEPERS = Range(2, MAX_TEAM_SIZE)
KEEPAWAY_TAKERS = Range(1, MAX_TEAM_SIZE)


def parameter_set(name: str, /, keepaway_launch: bool = True, **overrides: Any) -> ServerParams:
    """The named set, with keepaway.sh's launch settings (unless disabled) and then ``overrides``."""
    if not isinstance(name, str) or name not in PARAMETER_SETS:
        raise ValueError(f"unknown parameter set {name!r}; choose one of {', '.join(PARAMETER_SETS)}")
    base = PARAMETER_SETS[name]
    changes: dict[str, Any] = dict(KEEPAWAY_LAUNCH) if keepaway_launch else {}
    changes.update(overrides)
    return base.replace(**changes) if changes else base


def with_square_region(params: ServerParams, side: float) -> ServerParams:
    """``params`` with a square Keepaway region of ``side`` m (the commands' ``--field-size``); a ValueError
    that speaks of the side, not of the two parameters it sets, when the region is empty or does not fit
    the pitch."""
    try:
        return params.replace(keepaway_length=side, keepaway_width=side)
    except ValueError:
        most = min(params.pitch_length, params.pitch_width)
        raise ValueError(f"a square region of side {side:g} m does not fit the pitch ({params.pitch_length:g} x "
                         f"{params.pitch_width:g} m): its side must be above 0 and at most {most:g} m") from None


__all__ = [
    "CLASSIC",
    "CURRENT",
    "KEEPAWAY_LAUNCH",
    "KernelParams",
    "NOISE_AXIS",
    "NOISE_POLAR",
    "PARAMETER_SETS",
    "ServerParams",
    "parameter_set",
    "with_square_region",
]

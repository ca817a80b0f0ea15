"""The server/player parameter table, shared by the server and every client.

One frozen dataclass holds every physical, perceptual and referee constant by name, as rcssserver's
``server_param``/``player_param`` do (spec `server-physics.md`). Two named sets exist:

* ``classic`` (default): rcssserver 11.1.1, the server generation the Keepaway experiments used;
* ``current``: rcssserver 19.0.0 defaults (polar noise, kick noise, bipedal-era dash rates, capacity).

The set actually used by a server is sent to every client in ``init_ok`` so both sides agree. Kernels
receive ``params.kernel()``, a flat NamedTuple of floats that numba can take as an argument.
"""

from __future__ import annotations

import dataclasses
import math
from collections import namedtuple
from dataclasses import dataclass, fields
from typing import Any

# Enumerations stored as floats in the kernel record (numba wants one field type).
NOISE_AXIS = 0.0  # CLASSIC: per-axis U(-r, r)
NOISE_POLAR = 1.0  # 12.0+: polar, length U(0, r), direction U(-pi, pi)


@dataclass(frozen=True)
class ServerParams:
    """Every constant of the simulation, named as in rcssserver (units: m, m/cycle, deg, cycles, ms)."""

    name: str = "classic"

    # timing (spec 1)
    simulator_step_ms: float = 100.0
    sense_body_step_ms: float = 100.0
    send_step_ms: float = 150.0

    # field (spec 2)
    pitch_length: float = 105.0
    pitch_width: float = 68.0

    # ball (spec 2)
    ball_size: float = 0.085
    ball_decay: float = 0.94
    ball_rand: float = 0.05
    ball_speed_max: float = 2.7
    ball_accel_max: float = 2.7

    # player type 0 (spec 2)
    player_size: float = 0.3
    player_decay: float = 0.4
    player_rand: float = 0.1
    player_speed_max: float = 1.2
    player_accel_max: float = 1.0
    inertia_moment: float = 5.0
    kickable_margin: float = 0.7
    movement_noise: float = NOISE_AXIS

    # dash (spec 3)
    dash_power_rate: float = 0.006
    min_dash_power: float = -100.0
    max_dash_power: float = 100.0
    min_dash_angle: float = 0.0
    max_dash_angle: float = 0.0
    dash_angle_step: float = 1.0
    side_dash_rate: float = 0.4
    back_dash_rate: float = 0.7

    # turn / neck (spec 3)
    min_moment: float = -180.0
    max_moment: float = 180.0
    min_neck_moment: float = -180.0
    max_neck_moment: float = 180.0
    min_neck_angle: float = -90.0
    max_neck_angle: float = 90.0

    # kick (spec 3)
    min_power: float = -100.0
    max_power: float = 100.0
    kick_power_rate: float = 0.027
    kick_rand: float = 0.0
    kick_noise: float = NOISE_AXIS
    failed_kick_uses_slot: bool = False

    # stamina (spec 3)
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

    # tackle (spec 3; accepted, not used by the Keepaway agents)
    tackle_cycles: float = 10.0

    # perception (spec 4)
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

    # hearing (spec 4)
    audio_cut_dist: float = 50.0
    hear_max: float = 1.0
    hear_inc: float = 1.0
    hear_decay: float = 1.0
    say_msg_size: float = 10.0

    # keepaway referee (spec 5)
    keepaway_length: float = 20.0
    keepaway_width: float = 20.0
    take_cycles: float = 4.0
    reset_restores_stamina: bool = False
    ball_stuck_area: float = 3.0
    drop_ball_time: float = 200.0

    # derived quantities
    @property
    def kickable_distance(self) -> float:
        """Centre distance at which a player can kick the ball: 0.3 + 0.7 + 0.085 = 1.085 m."""
        return self.player_size + self.kickable_margin + self.ball_size

    def replace(self, **changes: Any) -> "ServerParams":
        """A copy with some values changed; unknown names and non-finite values are a ValueError."""
        known = {f.name: f for f in fields(self)}
        for key, value in changes.items():
            if key not in known:
                raise ValueError(f"unknown server parameter {key!r}")
            if key != "name" and not _finite_number(value):
                raise ValueError(f"server parameter {key}={value!r} is not a finite number")
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

    def kernel(self) -> tuple:
        """The numeric fields as a NamedTuple of floats, the form numba kernels take."""
        return KernelParams(*(float(getattr(self, n)) for n in KernelParams._fields))


def _finite_number(value: Any) -> bool:
    if isinstance(value, bool):
        return True
    return isinstance(value, (int, float)) and math.isfinite(value)


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

# keepaway.sh launch settings (spec `server-physics.md`, "Standard Keepaway launch").
KEEPAWAY_LAUNCH: dict[str, float] = {"stamina_inc_max": 3500.0, "visible_angle": 360.0}


def parameter_set(name: str, keepaway_launch: bool = True, **overrides: Any) -> ServerParams:
    """The named set, with keepaway.sh's launch settings (unless disabled) and then ``overrides``."""
    try:
        base = PARAMETER_SETS[name]
    except KeyError:
        raise ValueError(
            f"unknown parameter set {name!r}; choose one of {', '.join(PARAMETER_SETS)}"
        ) from None
    changes: dict[str, Any] = dict(KEEPAWAY_LAUNCH) if keepaway_launch else {}
    changes.update(overrides)
    return base.replace(**changes) if changes else base


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
]

"""rcssserver's parameter messages, as a text client gets them after its ``init`` reply: ``server_param``,
``player_param`` and a ``player_type`` for each heterogeneous type (rcssserver src/initsender.cpp,
``InitSenderCommonV8``; formats of src/serializercommonstdv8.cpp and src/heteroplayer.cpp).

rcssserver keeps its parameters in a map by name: a message lists, in name order, every parameter of the
client's protocol version or older, as ``(name value)`` with no space between two: an integer as an
integer, a flag as 0 or 1, a real number as a C++ stream prints it (6 significant digits) and a string
in double quotes. :data:`SERVER_PARAMS` and :data:`PLAYER_PARAMS` are rcssserver 19.0.0's tables: each
parameter's name, the first protocol version that gets it, and its default, whose type is the
parameter's (the 19.0.0 sources' ``addParams``; the two parameters of version 999, ``coach_msg_file``
and ``max_monitors``, reach no client). A server of ours sends its own ``ServerParams`` under rcssserver's
names (:data:`RCSS_PARAM_NAMES`; :data:`NOT_IN_RCSSSERVER` are ours alone), the settings its caller gives
for the parameters ``ServerParams`` does not hold (the ports, ``synch_mode``, ...), and rcssserver's
defaults for the rest.

**One player type.** Every player of ours is type 0, rcssserver's default type (docs/rules.md §1):
``player_param`` says ``player_types 1`` (``pt_max`` 1, ``subs_max`` 0, ``random_seed`` -1: no type
was drawn) and one ``player_type`` follows, ``(id 0)``, with our parameters. That is what rcssserver
itself sends when started with ``player::player_types=1``; the keepaway-0.6 players read a
``player_type`` message per type up to their limit of 18 (``SenseHandler::analyzePlayerTypeMessage``)
and every name of ``player_param`` they look for is there.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from keepaway.protocol.params import ServerParams

ParamValue = bool | int | float | str

# (name, first protocol version that gets it, rcssserver 19.0.0's default)
SERVER_PARAMS: tuple[tuple[str, int, ParamValue], ...] = (
    ("audio_cut_dist", 7, 50.0),
    ("auto_mode", 9, False),
    ("back_dash_rate", 13, 0.7),
    ("back_passes", 8, True),
    ("ball_accel_max", 7, 2.7),
    ("ball_decay", 7, 0.94),
    ("ball_rand", 7, 0.05),
    ("ball_size", 7, 0.085),
    ("ball_speed_max", 7, 3.0),
    ("ball_stuck_area", 11, 3.0),
    ("ball_weight", 7, 0.2),
    ("catch_ban_cycle", 7, 5),
    ("catch_probability", 7, 1.0),
    ("catchable_area_l", 7, 1.2),
    ("catchable_area_w", 7, 1.0),
    ("ckick_margin", 7, 1.0),
    ("clang_advice_win", 7, 1),
    ("clang_define_win", 7, 1),
    ("clang_del_win", 8, 1),
    ("clang_info_win", 7, 1),
    ("clang_mess_delay", 7, 50),
    ("clang_mess_per_cycle", 7, 1),
    ("clang_meta_win", 7, 1),
    ("clang_rule_win", 8, 1),
    ("clang_win_size", 7, 300),
    ("coach", 7, False),
    ("coach_port", 8, 6001),
    ("coach_w_referee", 7, False),
    ("connect_wait", 9, 300),
    ("control_radius", 7, 2.0),
    ("dash_angle_step", 13, 1.0),
    ("dash_power_rate", 7, 0.006),
    ("dist_noise_rate", 19, 0.0125),
    ("drop_ball_time", 7, 100),
    ("effort_dec", 7, 0.005),
    ("effort_dec_thr", 7, 0.3),
    ("effort_inc", 7, 0.01),
    ("effort_inc_thr", 7, 0.6),
    ("effort_init", 7, 1.0),
    ("effort_min", 7, 0.6),
    ("extra_half_time", 13, 100),
    ("extra_stamina", 12, 50.0),
    ("fixed_teamname_l", 16, ""),
    ("fixed_teamname_r", 16, ""),
    ("focus_dist_noise_rate", 19, 0.0125),
    ("forbid_kick_off_offside", 7, True),
    ("foul_cycles", 14, 5),
    ("foul_detect_probability", 14, 0.5),
    ("foul_exponent", 14, 10.0),
    ("free_kick_faults", 8, True),
    ("freeform_send_period", 8, 20),
    ("freeform_wait_period", 8, 600),
    ("fullstate_l", 7, False),
    ("fullstate_r", 7, False),
    ("game_log_compression", 8, 0),
    ("game_log_dated", 8, True),
    ("game_log_dir", 8, "./"),
    ("game_log_fixed", 8, False),
    ("game_log_fixed_name", 8, "rcssserver"),
    ("game_log_version", 8, 6),
    ("game_logging", 8, True),
    ("game_over_wait", 9, 100),
    ("goal_width", 7, 14.02),
    ("goalie_max_moves", 7, 2),
    ("golden_goal", 14, False),
    ("half_time", 7, 300),
    ("hear_decay", 7, 1),
    ("hear_inc", 7, 1),
    ("hear_max", 7, 1),
    ("illegal_defense_dist_x", 16, 16.5),
    ("illegal_defense_duration", 16, 20),
    ("illegal_defense_number", 16, 0),
    ("illegal_defense_width", 16, 40.32),
    ("inertia_moment", 7, 5.0),
    ("keepaway", 9, False),
    ("keepaway_length", 9, 20.0),
    ("keepaway_log_dated", 9, True),
    ("keepaway_log_dir", 9, "./"),
    ("keepaway_log_fixed", 9, False),
    ("keepaway_log_fixed_name", 9, "rcssserver"),
    ("keepaway_logging", 9, True),
    ("keepaway_start", 9, -1),
    ("keepaway_width", 9, 20.0),
    ("kick_off_wait", 9, 100),
    ("kick_power_rate", 7, 0.027),
    ("kick_rand", 7, 0.1),
    ("kick_rand_factor_l", 7, 1.0),
    ("kick_rand_factor_r", 7, 1.0),
    ("kickable_margin", 7, 0.7),
    ("land_dist_noise_rate", 19, 0.00125),
    ("land_focus_dist_noise_rate", 19, 0.00125),
    ("landmark_file", 8, "~/.rcssserver-landmark.xml"),
    ("log_date_format", 8, "%Y%m%d%H%M%S-"),
    ("log_times", 8, False),
    ("max_back_tackle_power", 12, 0.0),
    ("max_catch_angle", 17, 90.0),
    ("max_dash_angle", 13, 180.0),
    ("max_dash_power", 13, 100.0),
    ("max_goal_kicks", 8, 3),
    ("max_tackle_power", 12, 100.0),
    ("maxmoment", 7, 180.0),
    ("maxneckang", 7, 90.0),
    ("maxneckmoment", 7, 180.0),
    ("maxpower", 7, 100.0),
    ("min_catch_angle", 17, -90.0),
    ("min_dash_angle", 13, -180.0),
    ("min_dash_power", 13, 0.0),
    ("minmoment", 7, -180.0),
    ("minneckang", 7, -90.0),
    ("minneckmoment", 7, -180.0),
    ("minpower", 7, -100.0),
    ("nr_extra_halfs", 9, 2),
    ("nr_normal_halfs", 9, 2),
    ("offside_active_area_size", 7, 2.5),
    ("offside_kick_margin", 7, 9.15),
    ("olcoach_port", 8, 6002),
    ("old_coach_hear", 7, False),
    ("pen_allow_mult_kicks", 9, True),
    ("pen_before_setup_wait", 9, 10),
    ("pen_coach_moves_players", 9, True),
    ("pen_dist_x", 9, 42.5),
    ("pen_max_extra_kicks", 9, 5),
    ("pen_max_goalie_dist_x", 9, 14.0),
    ("pen_nr_kicks", 9, 5),
    ("pen_random_winner", 9, False),
    ("pen_ready_wait", 9, 10),
    ("pen_setup_wait", 9, 70),
    ("pen_taken_wait", 9, 150),
    ("penalty_shoot_outs", 9, True),
    ("player_accel_max", 7, 1.0),
    ("player_decay", 7, 0.4),
    ("player_rand", 7, 0.1),
    ("player_size", 7, 0.3),
    ("player_speed_max", 7, 1.05),
    ("player_speed_max_min", 12, 0.75),
    ("player_weight", 7, 60.0),
    ("point_to_ban", 8, 5),
    ("point_to_duration", 8, 20),
    ("port", 8, 6000),
    ("prand_factor_l", 7, 1.0),
    ("prand_factor_r", 7, 1.0),
    ("profile", 8, False),
    ("proper_goal_kicks", 8, False),
    ("quantize_step", 7, 0.1),
    ("quantize_step_l", 7, 0.01),
    ("record_messages", 8, False),
    ("recover_dec", 7, 0.002),
    ("recover_dec_thr", 7, 0.3),
    ("recover_init", 9, 1.0),
    ("recover_min", 7, 0.5),
    ("recv_step", 7, 10),
    ("red_card_probability", 15, 0.0),
    ("say_coach_cnt_max", 7, 128),
    ("say_coach_msg_size", 7, 128),
    ("say_msg_size", 7, 10),
    ("send_comms", 8, False),
    ("send_step", 7, 150),
    ("send_vi_step", 7, 100),
    ("sense_body_step", 7, 100),
    ("side_dash_rate", 13, 0.4),
    ("simulator_step", 7, 100),
    ("slow_down_factor", 7, 1),
    ("slowness_on_top_for_left_team", 8, 1.0),
    ("slowness_on_top_for_right_team", 8, 1.0),
    ("stamina_capacity", 13, 130600.0),
    ("stamina_inc_max", 7, 45.0),
    ("stamina_max", 7, 8000.0),
    ("start_goal_l", 7, 0),
    ("start_goal_r", 7, 0),
    ("stopped_ball_vel", 8, 0.01),
    ("synch_micro_sleep", 8, 1),
    ("synch_mode", 8, False),
    ("synch_offset", 8, 60),
    ("synch_see_offset", 12, 0),
    ("tackle_back_dist", 8, 0.0),
    ("tackle_cycles", 8, 10),
    ("tackle_dist", 8, 2.0),
    ("tackle_exponent", 8, 6.0),
    ("tackle_power_rate", 8, 0.027),
    ("tackle_rand_factor", 14, 2.0),
    ("tackle_width", 8, 1.25),
    ("team_actuator_noise", 7, False),
    ("team_l_start", 9, ""),
    ("team_r_start", 9, ""),
    ("text_log_compression", 8, 0),
    ("text_log_dated", 8, True),
    ("text_log_dir", 8, "./"),
    ("text_log_fixed", 8, False),
    ("text_log_fixed_name", 8, "rcssserver"),
    ("text_logging", 8, True),
    ("use_offside", 7, True),
    ("verbose", 8, False),
    ("visible_angle", 7, 90.0),
    ("visible_distance", 7, 3.0),
    ("wind_ang", 7, 0.0),
    ("wind_dir", 7, 0.0),
    ("wind_force", 7, 0.0),
    ("wind_none", 7, False),
    ("wind_rand", 7, 0.0),
    ("wind_random", 7, False),
)

PLAYER_PARAMS: tuple[tuple[str, int, ParamValue], ...] = (
    ("allow_mult_default_type", 12, False),
    ("catchable_area_l_stretch_max", 14, 1.3),
    ("catchable_area_l_stretch_min", 14, 1.0),
    ("dash_power_rate_delta_max", 7, 0.0),
    ("dash_power_rate_delta_min", 7, 0.0),
    ("effort_max_delta_factor", 7, -0.004),
    ("effort_min_delta_factor", 7, -0.004),
    ("extra_stamina_delta_max", 7, 50.0),
    ("extra_stamina_delta_min", 7, 0.0),
    ("foul_detect_probability_delta_factor", 14, 0.0),
    ("inertia_moment_delta_factor", 7, 25.0),
    ("kick_power_rate_delta_max", 14, 0.0),
    ("kick_power_rate_delta_min", 14, 0.0),
    ("kick_rand_delta_factor", 7, 1.0),
    ("kickable_margin_delta_max", 7, 0.1),
    ("kickable_margin_delta_min", 7, -0.1),
    ("new_dash_power_rate_delta_max", 8, 0.0008),
    ("new_dash_power_rate_delta_min", 8, -0.0012),
    ("new_stamina_inc_max_delta_factor", 8, -6000.0),
    ("player_decay_delta_max", 7, 0.1),
    ("player_decay_delta_min", 7, -0.1),
    ("player_size_delta_factor", 7, -100.0),
    ("player_speed_max_delta_max", 7, 0.0),
    ("player_speed_max_delta_min", 7, 0.0),
    ("player_types", 7, 18),
    ("pt_max", 7, 1),
    ("random_seed", 8, -1),
    ("stamina_inc_max_delta_factor", 7, 0.0),
    ("subs_max", 7, 3),
)

# Our parameter names that rcssserver spells otherwise; parameters rcssserver's server_param does not have
# (our modelling switches, the pitch size, what rcssserver keeps per player type) are left out of it.
RCSS_PARAM_NAMES = {
    "simulator_step_ms": "simulator_step", "sense_body_step_ms": "sense_body_step", "send_step_ms": "send_step",
    "min_moment": "minmoment", "max_moment": "maxmoment", "min_neck_moment": "minneckmoment",
    "max_neck_moment": "maxneckmoment", "min_neck_angle": "minneckang", "max_neck_angle": "maxneckang",
    "min_power": "minpower", "max_power": "maxpower",
}
NOT_IN_RCSSSERVER = frozenset({
    "name", "pitch_length", "pitch_width", "movement_noise", "kick_noise", "failed_kick_uses_slot", "effort_max",
    "effort_inc_uses_dec_thr", "dir_chg_step", "dist_chg_step", "unum_far_length", "unum_too_far_length",
    "team_far_length", "team_too_far_length", "team_loss_probabilistic", "see_behind_strict", "take_cycles",
    "reset_restores_stamina",
})
# player_param of a server whose every player is type 0 (module docstring)
ONE_PLAYER_TYPE: dict[str, ParamValue] = {"player_types": 1, "pt_max": 1, "subs_max": 0, "random_seed": -1}
# The fields of a player_type message after its (id N), in order, with the first version that gets each
# (rcssserver src/heteroplayer.cpp, HeteroPlayer::printParamsSExp).
PLAYER_TYPE_FIELDS: tuple[tuple[str, int], ...] = (
    ("player_speed_max", 8), ("stamina_inc_max", 8), ("player_decay", 8), ("inertia_moment", 8),
    ("dash_power_rate", 8), ("player_size", 8), ("kickable_margin", 8), ("kick_rand", 8), ("extra_stamina", 8),
    ("effort_max", 8), ("effort_min", 8),
    ("kick_power_rate", 14), ("foul_detect_probability", 14), ("catchable_area_l_stretch", 14),
    ("unum_far_length", 18), ("unum_too_far_length", 18), ("team_far_length", 18), ("team_too_far_length", 18),
    ("player_max_observation_length", 18), ("ball_vel_far_length", 18), ("ball_vel_too_far_length", 18),
    ("ball_max_observation_length", 18), ("flag_chg_far_length", 18), ("flag_chg_too_far_length", 18),
    ("flag_max_observation_length", 18),
    ("dist_noise_rate", 19), ("focus_dist_noise_rate", 19), ("land_dist_noise_rate", 19),
    ("land_focus_dist_noise_rate", 19),
)
DEFAULT_TYPE = 0
# The player_type fields our table holds, those of every version (the perception lengths of 18 and later stay
# our perception's): what a player of ours reads from rcssserver's (player_type (id 0) ...) (``rcss.read``).
PLAYER_TYPE_PARAMS = tuple(name for name, since in PLAYER_TYPE_FIELDS if since < 18 and hasattr(ServerParams, name))


def cpp_number(value: float) -> str:
    """A number as a default C++ ostream prints it (6 significant digits, no trailing zeros)."""
    return format(value, ".6g")


def param_text(value: ParamValue) -> str:
    """A parameter's value as rcssserver writes it: a flag as 0 or 1, a string in double quotes."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return cpp_number(value)
    return f'"{value}"'


def param_line(head: str, values: Mapping[str, ParamValue]) -> str:
    """``(head (name value)(name value)...)``, the form of every parameter message (rcssserver
    src/serializercommonstdv8.cpp)."""
    return f"({head} " + "".join(f"({name} {param_text(value)})" for name, value in values.items()) + ")"


def _typed(name: str, value: object, default: ParamValue) -> ParamValue:
    """``value`` as the type of rcssserver's parameter ``name`` (that of its ``default``); ValueError if it
    is not one."""
    if isinstance(default, bool):
        if isinstance(value, bool) or value in (0, 1):
            return bool(value)
    elif isinstance(default, int):
        if isinstance(value, (int, float)) and not isinstance(value, bool) and float(value).is_integer():
            return int(value)
    elif isinstance(default, float):
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            return float(value)
    elif isinstance(value, str):
        return value
    kind = {bool: "a flag", int: "an integer", float: "a finite number", str: "a string"}[type(default)]
    raise ValueError(f"rcssserver's {name} is {kind}: {value!r} is not")


def our_server_params(params: ServerParams) -> dict[str, float | bool]:
    """Our parameters that rcssserver's server_param has, by rcssserver's names."""
    return {RCSS_PARAM_NAMES.get(key, key): value for key, value in params.to_dict().items()
            if key not in NOT_IN_RCSSSERVER}


def server_param_values(params: ServerParams,
                        settings: Mapping[str, ParamValue] | None = None) -> dict[str, ParamValue]:
    """Every rcssserver server parameter by name: ``params`` where it holds the parameter, else
    ``settings`` (by rcssserver's names, only for parameters ``params`` does not hold), else rcssserver's
    default. ValueError for a name rcssserver does not have, a setting ``params`` holds, or a value not of
    the parameter's type."""
    values: dict[str, ParamValue] = {name: default for name, _, default in SERVER_PARAMS}
    ours = our_server_params(params)
    settings = dict(settings or {})
    clash = sorted(ours.keys() & settings.keys())
    if clash:
        raise ValueError(f"server parameter {clash[0]} comes from the parameter set, not from the settings")
    for name, value in {**ours, **settings}.items():
        if name not in values:
            raise ValueError(f"rcssserver has no server parameter {name!r}")
        values[name] = _typed(name, value, values[name])
    return values


def player_type_values(params: ServerParams, server_values: Mapping[str, ParamValue]) -> dict[str, ParamValue]:
    """Type 0's ``player_type`` fields: our parameters, where we have none the server parameter rcssserver
    gives type 0 (``server_values``, :func:`server_param_values`). Our perception loses a flag's and the
    ball's changes as a player's number (``unum_far_length``, ``unum_too_far_length``) and sees any object
    on the pitch: the longest distance on it is every maximum observation length, as rcssserver's. The
    team's far lengths are ours too (40 and 60 m in both sets), where rcssserver 19.0.0 gives clients of
    version 18 and later the longest distance on the pitch (it never takes the team from what they see)."""
    anywhere = math.hypot(params.pitch_length, params.pitch_width)
    return {
        "player_speed_max": params.player_speed_max, "stamina_inc_max": params.stamina_inc_max,
        "player_decay": params.player_decay, "inertia_moment": params.inertia_moment,
        "dash_power_rate": params.dash_power_rate, "player_size": params.player_size,
        "kickable_margin": params.kickable_margin, "kick_rand": params.kick_rand,
        "extra_stamina": params.extra_stamina, "effort_max": params.effort_max, "effort_min": params.effort_min,
        "kick_power_rate": params.kick_power_rate, "foul_detect_probability": server_values["foul_detect_probability"],
        "catchable_area_l_stretch": 1.0,
        "unum_far_length": params.unum_far_length, "unum_too_far_length": params.unum_too_far_length,
        "team_far_length": params.team_far_length, "team_too_far_length": params.team_too_far_length,
        "player_max_observation_length": anywhere,
        "ball_vel_far_length": params.unum_far_length, "ball_vel_too_far_length": params.unum_too_far_length,
        "ball_max_observation_length": anywhere,
        "flag_chg_far_length": params.unum_far_length, "flag_chg_too_far_length": params.unum_too_far_length,
        "flag_max_observation_length": anywhere,
        **{name: server_values[name] for name in ("dist_noise_rate", "focus_dist_noise_rate", "land_dist_noise_rate",
                                                  "land_focus_dist_noise_rate")},
    }


def parameter_lines(params: ServerParams, version: int, settings: Mapping[str, ParamValue] | None = None) -> list[str]:
    """``server_param``, ``player_param`` and type 0's ``player_type`` for a client of protocol
    ``version`` (8 or later), in the order rcssserver sends them (src/player.cpp, Player::sendInit)."""
    server_values = server_param_values(params, settings)
    player_values = {name: ONE_PLAYER_TYPE.get(name, default) for name, _, default in PLAYER_PARAMS}
    type_values = player_type_values(params, server_values)
    return [
        param_line("server_param", {name: server_values[name] for name, since, _ in SERVER_PARAMS if since <= version}),
        param_line("player_param", {name: player_values[name] for name, since, _ in PLAYER_PARAMS if since <= version}),
        param_line("player_type", {"id": DEFAULT_TYPE, **{name: type_values[name] for name, since in PLAYER_TYPE_FIELDS
                                                           if since <= version}}),
    ]

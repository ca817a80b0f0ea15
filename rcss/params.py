"""Our parameter table under rcssserver's names, both ways: the names a game log's ``server_param`` and
``player_type`` lines are written with (``server.game_log``) and the names a player reads rcssserver's own
``(server_param ...)`` and ``(player_type ...)`` messages by (``rcss.read``).

rcssserver declares its parameters in ``serverparam.cpp`` and the heterogeneous types' in
``heteroplayer.cpp``; most of ours carry the same name (``protocol/params.py``), a few are spelt otherwise,
and some are our modelling switches that rcssserver does not have (its behaviour is one of their values).
"""

from __future__ import annotations

# Our parameter names that rcssserver's server_param spells otherwise.
RCSS_PARAM_NAMES = {
    "simulator_step_ms": "simulator_step", "sense_body_step_ms": "sense_body_step", "send_step_ms": "send_step",
    "min_moment": "minmoment", "max_moment": "maxmoment", "min_neck_moment": "minneckmoment",
    "max_neck_moment": "maxneckmoment", "min_neck_angle": "minneckang", "max_neck_angle": "maxneckang",
    "min_power": "minpower", "max_power": "maxpower",
}
# Parameters rcssserver's server_param does not have: our modelling switches, the pitch size (a constant
# there), and the perception lengths it keeps per player type.
NOT_IN_RCSSSERVER = frozenset({
    "name", "pitch_length", "pitch_width", "movement_noise", "kick_noise", "failed_kick_uses_slot", "effort_max",
    "effort_inc_uses_dec_thr", "dir_chg_step", "dist_chg_step", "unum_far_length", "unum_too_far_length",
    "team_far_length", "team_too_far_length", "team_loss_probabilistic", "see_behind_strict", "take_cycles",
    "reset_restores_stamina",
})
# The parameters of a heterogeneous player type (``player_type``) that our table holds: every player of ours
# is type 0, rcssserver's default type, whose values are the server_param's.
PLAYER_TYPE_PARAMS = ("player_speed_max", "stamina_inc_max", "player_decay", "inertia_moment", "dash_power_rate",
                      "player_size", "kickable_margin", "kick_rand", "extra_stamina", "effort_max", "effort_min",
                      "kick_power_rate")

"""The players' own settings: which Pass and GetOpen policies they play, and the constants of their skills.

The Pass and GetOpen policies are codes that the decision kernels branch on (docs/players.md §6, §7), named
as the command line, configurations and the coach's advice name them (``protocol.advice``).
:class:`AgentConfig` holds every constant of the players that is not the server's, each with the section of
docs/players.md or the keepaway-0.6 function it comes from; the kernels read it as the record
``AgentConfig.kernel()`` returns (``cfg``), as they read the server's parameters (``kp``).
"""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass, fields

import numpy as np

from keepaway.core.records import kernel_record
from keepaway.protocol.advice import GETOPEN_POLICY_NAMES, PASS_POLICY_NAMES

# Pass policies (docs/players.md §6.2); EXTERNAL: the caller's learner picks the action.
PASS_RANDOM = 0
PASS_HANDCODED = 1
PASS_EXTERNAL = 2
PASS_HOLD = 3
# GetOpen policies (docs/players.md §7; HANDCODED_CONE: the framework variant, docs/players.md §7.2).
GETOPEN_RANDOM = 0
GETOPEN_HANDCODED = 1
GETOPEN_HANDCODED_CONE = 2
GETOPEN_LEARNED = 3
GETOPEN_EXTERNAL = 4  # the caller picks the grid point (agents.player, outside decisions); no CLI name
# The policies' names on the command line, in configurations and in the coach's advice (declared with
# the advice, protocol.advice), shared by every mode, and their codes.
PASS_POLICIES = dict(zip(PASS_POLICY_NAMES, (PASS_RANDOM, PASS_HANDCODED, PASS_EXTERNAL, PASS_HOLD), strict=True))
GETOPEN_POLICIES = dict(zip(GETOPEN_POLICY_NAMES,
                            (GETOPEN_RANDOM, GETOPEN_HANDCODED, GETOPEN_HANDCODED_CONE, GETOPEN_LEARNED), strict=True))


@dataclass(frozen=True)
class AgentConfig:
    """The players' own constants (not the server's), each with the section of docs/players.md or the C++
    function it comes from."""

    pass_policy: int = PASS_HANDCODED  # docs/players.md §6
    getopen_policy: int = GETOPEN_HANDCODED  # docs/players.md §7
    ball_conf_threshold: float = 0.90  # docs/players.md §4.1: ball "known"
    player_conf_threshold: float = 0.88  # docs/players.md §4.1: player usable
    pass_end_speed: float = 1.2  # docs/players.md §5.4: PlayerSettings default
    hold_ratio_keeper: float = 0.7  # docs/players.md §5.3
    hold_ratio_taker: float = 0.3  # docs/players.md §5.3
    hold_opponent_radius: float = 5.0  # docs/players.md §5.3 step 1
    hold_escape_angle: float = 45.0  # docs/players.md §5.3 step 1
    hold_ball_tolerance: float = 0.3  # docs/players.md §5.3 step 2
    hold_turn_safety: float = 0.85  # docs/players.md §5.3 step 2 (x kickable distance)
    still_ball_speed: float = 0.1  # docs/players.md §5.3 step 3
    freeze_keep_ratio: float = 0.8  # docs/players.md §5.3 step 3 (x kickable distance)
    freeze_target_ratio: float = 0.7  # docs/players.md §5.3 step 3 (x kickable distance)
    freeze_inset: float = 0.1  # BasicPlayer::freezeBall, docs/players.md §5.3 step 3
    pitch_pullback: float = 0.2  # BasicPlayer::kickBallCloseToBody, docs/players.md §5.3 step 3
    pass_speed_ratio: float = 0.85  # BasicPlayer::kickTo, PlayerWhenToKick (x ball_accel_max)
    pass_kick_rate_ratio: float = 0.85  # docs/players.md §5.4 (x kick_power_rate)
    reposition_ratio: float = 0.16  # docs/players.md §5.4
    pass_power_ok: float = 105.0  # docs/players.md §5.4
    pass_power_pressed: float = 130.0  # docs/players.md §5.4
    pass_pressure_radius: float = 2.0  # docs/players.md §5.4
    turn_threshold: float = 7.0  # docs/players.md §5.5 (GetOpen's moveToPos angle)
    max_sim_turns: float = 5.0  # docs/players.md §5.5
    max_direct_turns: float = 2.0  # docs/players.md §5.5: 1-2 turns -> turn, 3+ -> brake
    turn_aim_cycles: float = 2.0  # docs/players.md §5.5: turn aimed at my position 2 cycles ahead
    intercept_horizon: float = 30.0  # docs/players.md §4.3, §5.2 step 2
    no_intercept_cycles: float = 100.0  # predictCommandToInterceptBall: no point reachable -> the ball 100 ahead
    intercept_roll_cycles: float = 4.0  # WorldModel::predictCommandTurnTowards: position min(i, 4) ahead
    intercept_back_distance: float = 2.5  # WorldModel::predictCommandToMoveToPos default dDistBack
    turn_ratio_near: float = 0.9  # WorldModel::predictCommandTurnTowards dRatioTurn (<= 10 m)
    turn_ratio_mid: float = 2.0  # same (10-20 m)
    turn_ratio_far: float = 3.0  # same (> 20 m)
    turn_mid_distance: float = 10.0  # same
    turn_far_distance: float = 20.0  # same
    close_radius_margin: float = 1.0 / 6.0  # docs/players.md §5.2 step 1 (x kickable_margin)
    close_margin: float = 0.95  # BasicPlayer::interceptClose: one dash succeeds (x kickable distance)
    close_turn_margin: float = 0.8  # same: a turn (or a stopping dash) keeps the ball (x kickable distance)
    close_near_margin: float = 0.7  # same, ball beyond close range: ball already at my feet (x kickable)
    close_heading_tolerance: float = 25.0  # same, angThreshold: body close enough to the desired heading
    close_opponent_radius: float = 3.0  # same, bOppClose: an opponent this near -> dash first
    close_range_dash_cycles: float = 3.0  # same: close range 3 player_speed_max + (1 + ball_decay)
    back_turn_margin: float = 0.9  # WorldModel::predictCommandTurnTowards: turn with the back (x kickable)
    back_turn_max_cycles: float = 4.0  # same: only when arriving in fewer cycles
    close_max_cycle: float = 3.0  # docs/players.md §5.2 step 3
    stability_radius: float = 1.0  # docs/players.md §5.2 step 2
    stability_margin: float = 0.7  # docs/players.md §5.2 step 2 (x kickable distance)
    stability_ball_speed: float = 0.6  # docs/players.md §5.2 step 2
    stability_window: float = 2.0  # docs/players.md §5.2 step 2 (cycles)
    intercept_stay_radius: float = 0.5  # docs/players.md §5.2 step 3
    # Not in the framework (a deviation, docs/design.md, "The players' skills"): a player that has sent this
    # many backward dashes while standing still, since it last moved, turns to its interception point instead
    # of the next one.
    stuck_dash_limit: float = 30.0
    still_speed: float = 0.01  # standing still: sensed speed below this (m/cycle)
    search_turn: float = 60.0  # docs/players.md §5.6
    search_memory: float = 3.0  # BasicPlayer::searchBall: side kept for 3 cycles
    hc_hold_distance: float = 5.0  # docs/players.md §6.2, P:HC C1
    hc_angle_weight: float = 0.25  # docs/players.md §6.2, P:HC C2
    hc_pass_threshold: float = 22.5  # docs/players.md §6.2, P:HC C3
    go_safety_angle: float = 18.4  # docs/players.md §7.2, GO:HC
    go_cone_ratio: float = 0.3  # docs/players.md §7.2
    grid_points: float = 5.0  # docs/players.md §7.1 (per side)
    grid_margin: float = 0.15  # docs/players.md §7.1
    arrival_radius: float = 1.5  # docs/players.md §7.5, §7.3
    mark_distance: float = 4.0  # docs/players.md §3 step 3
    mark_cone_ratio: float = 0.3  # docs/players.md §3 step 3
    # Not in the paper (an option, off by default): GO:L's variables 9-10 measured from predictedBallPos
    # (as GO:HC's lane test) instead of from the keeper now closest to the ball (docs/players.md §7);
    # the measurements that kept the paper's definition: docs/design.md, "Learning options".
    getopen_lane_from_predicted_ball: bool = False
    # Say and hear (agents/say.py; KeepawayPlayer::makeSayMessage, WorldModelSayMsgTypes.cc). Off: silent
    # players that hear nothing, to measure what talking changes.
    say_messages: bool = True
    say_ball_range: float = 20.0  # makeSayMessage: a ball seen with its change pair within this is said
    say_pass_margin: float = 0.2  # same: a kick taking the ball this far beyond kickable distance is a pass
    hear_ball_near: float = 3.0  # WMBallInfo::process: a heard ball is not taken this close to me
    hear_ball_stale_cycles: float = 3.0  # same: a ball whose change pair is older than this is replaced
    hear_velocity_gap: float = 0.3  # same, and processPerfectHearInfoBall: a velocity this different

    def kernel(self) -> np.record:
        """The fields (:data:`AgentKernel`) as a record of floats, the form numba kernels take
        (``core.records``)."""
        return kernel_record(AgentKernel(*(float(getattr(self, n)) for n in AgentKernel._fields)))


AgentKernel = namedtuple("AgentKernel", [f.name for f in fields(AgentConfig)])
AgentKernel.__module__ = __name__


__all__ = ["GETOPEN_EXTERNAL", "GETOPEN_HANDCODED", "GETOPEN_HANDCODED_CONE", "GETOPEN_LEARNED", "GETOPEN_POLICIES",
           "GETOPEN_RANDOM", "PASS_EXTERNAL", "PASS_HANDCODED", "PASS_HOLD", "PASS_POLICIES", "PASS_RANDOM",
           "AgentConfig", "AgentKernel"]

"""The Keepaway referee (rcssserver ``KeepawayRef``) and the ball-stuck referee, as per-arena kernels.

Spec `server-physics.md` 5 (and 2, step 4, for where the referees run): after movement, collisions and
``time += 1``, every play_on cycle ends the episode when the ball leaves the keepaway region ('o') or a
taker has been near the ball in ``take_cycles`` counted cycles ('t'); an end resets the field and the
next episode starts in the same cycle. Kernels take the arena index ``b`` so a caller can compose them
with the physics in one njit loop over the batch; :func:`referee_step` is the plain batch entry.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from keepaway.core.jit import borrowing

from keepaway.server import episode_log
from keepaway.core.rng import randint, uniform
from keepaway.core.objects import BALL
from keepaway.server.world import World

# End causes (the kwy log's 'o' and 't').
END_NONE = 0
END_OUT = 1
END_TAKEN = 2
END_CAUSES = {END_OUT: episode_log.END_OUT, END_TAKEN: episode_log.END_TAKEN}  # names in the logs

# Reset jitter (spec 5 Reset): corners get U(0, 3) inwards, keepers in slot >= 3 U(-1, 1) about the
# centre; the ball sits this far inside the slot-0 corner on both axes.
_CORNER_JITTER = 3.0
_CENTRE_JITTER = 1.0
_BALL_INSET = 4.0


class RefereeState(NamedTuple):
    """Referee state of ``B`` arenas. Kernels update the arrays in place.

    ``ended``/``end_cause``/``end_cycle``/``last_start_cycle``/``dropped`` describe the last referee
    call only: the episode that ended in it is number ``episode - 1`` and ran from
    ``last_start_cycle`` to ``end_cycle``.
    """

    take_count: np.ndarray  # (B,) int64: counted cycles with a taker near the ball
    episode: np.ndarray  # (B,) int64: number of the running episode (0 before the first play_on)
    start_cycle: np.ndarray  # (B,) int64: cycle the running episode started
    stuck_anchor: np.ndarray  # (B, 2) float64: ball-stuck anchor point
    stuck_cycle: np.ndarray  # (B,) int64: cycle the anchor was set
    ended: np.ndarray  # (B,) bool: an episode ended in the last call
    end_cause: np.ndarray  # (B,) int8 END_*
    end_cycle: np.ndarray  # (B,) int64
    last_start_cycle: np.ndarray  # (B,) int64: start cycle of the episode that ended
    dropped: np.ndarray  # (B,) bool: the ball-stuck referee dropped the ball in the last call


def new_referee_state(batch: int) -> RefereeState:
    """Referee state before the first play_on (episode 0, nothing ended)."""
    return RefereeState(
        take_count=np.zeros(batch, dtype=np.int64),
        episode=np.zeros(batch, dtype=np.int64),
        start_cycle=np.zeros(batch, dtype=np.int64),
        stuck_anchor=np.zeros((batch, 2)),
        stuck_cycle=np.zeros(batch, dtype=np.int64),
        ended=np.zeros(batch, dtype=np.bool_),
        end_cause=np.zeros(batch, dtype=np.int8),
        end_cycle=np.zeros(batch, dtype=np.int64),
        last_start_cycle=np.zeros(batch, dtype=np.int64),
        dropped=np.zeros(batch, dtype=np.bool_),
    )


@borrowing
def reset_field(b: int, w: World, kp) -> None:
    """Place the players and the ball for a new episode (spec 5 Reset; agents spec 6).

    Random draws from ``w.rng`` in rcssserver's order: the start slot, then x before y for each enabled
    player in object order (keepers 1..K, then takers). K is the number of enabled keepers, so the
    three corners are occupied by a random rotation. Velocities and accelerations become 0; body and
    neck angles (also the pending ones) are kept. CURRENT (``reset_restores_stamina``) restores stamina,
    effort, recovery and stamina capacity of every enabled player (``Player::recoverAll``).
    """
    half_l = 0.5 * kp.keepaway_length
    half_w = 0.5 * kp.keepaway_width
    first_taker = 1 + w.n_keepers
    n_enabled_keepers = 0
    for i in range(1, first_taker):
        if w.enabled[b, i]:
            n_enabled_keepers += 1
    slot = randint(w.rng, b, n_enabled_keepers) if n_enabled_keepers > 0 else 0
    for i in range(1, w.pos.shape[1]):
        if not w.enabled[b, i]:
            continue
        if i < first_taker:
            if slot == 0:
                x = -half_l + uniform(w.rng, b, 0.0, _CORNER_JITTER)
                y = -half_w + uniform(w.rng, b, 0.0, _CORNER_JITTER)
            elif slot == 1:
                x = half_l - uniform(w.rng, b, 0.0, _CORNER_JITTER)
                y = -half_w + uniform(w.rng, b, 0.0, _CORNER_JITTER)
            elif slot == 2:
                x = half_l - uniform(w.rng, b, 0.0, _CORNER_JITTER)
                y = half_w - uniform(w.rng, b, 0.0, _CORNER_JITTER)
            else:
                x = uniform(w.rng, b, -_CENTRE_JITTER, _CENTRE_JITTER)
                y = uniform(w.rng, b, -_CENTRE_JITTER, _CENTRE_JITTER)
            slot = (slot + 1) % n_enabled_keepers
        else:
            x = -half_l + uniform(w.rng, b, 0.0, _CORNER_JITTER)
            y = half_w - uniform(w.rng, b, 0.0, _CORNER_JITTER)
        w.pos[b, i, 0] = x
        w.pos[b, i, 1] = y
        w.vel[b, i, :] = 0.0
        w.acc[b, i, :] = 0.0
        if kp.reset_restores_stamina != 0.0:
            w.stamina[b, i] = kp.stamina_max
            w.recovery[b, i] = kp.recover_init
            w.effort[b, i] = kp.effort_max
            w.capacity[b, i] = kp.stamina_capacity
    w.pos[b, BALL, 0] = -half_l + _BALL_INSET
    w.pos[b, BALL, 1] = -half_w + _BALL_INSET
    w.vel[b, BALL, :] = 0.0
    w.acc[b, BALL, :] = 0.0


@borrowing
def _clear_end_record(b: int, r: RefereeState) -> None:
    r.ended[b] = False
    r.end_cause[b] = END_NONE
    r.dropped[b] = False


@borrowing
def _anchor_ball(b: int, w: World, r: RefereeState) -> None:
    r.stuck_anchor[b, 0] = w.pos[b, BALL, 0]
    r.stuck_anchor[b, 1] = w.pos[b, BALL, 1]
    r.stuck_cycle[b] = w.time[b]


@borrowing
def start_game(b: int, w: World, r: RefereeState, kp) -> None:
    """The first play_on (spec 5 Start): reset the field; episode 1 starts at the current cycle.

    The ball-stuck anchor is the ball's position before the reset, where rcssserver's BallStuck
    referee last saw it outside play_on.
    """
    _anchor_ball(b, w, r)
    _clear_end_record(b, r)
    reset_field(b, w, kp)
    r.take_count[b] = 0
    r.episode[b] = 1
    r.start_cycle[b] = w.time[b]


@borrowing
def _ball_stuck(b: int, w: World, r: RefereeState, kp) -> None:
    """BallStuck referee (spec 5 "Other referees"): a ball that stays within ``ball_stuck_area`` of
    its anchor for ``drop_ball_time`` cycles is dropped where it is (velocity 0) and re-anchored;
    a ball that leaves the area becomes the new anchor."""
    if kp.ball_stuck_area <= 0.0 or kp.drop_ball_time <= 0.0:
        return
    dx = w.pos[b, BALL, 0] - r.stuck_anchor[b, 0]
    dy = w.pos[b, BALL, 1] - r.stuck_anchor[b, 1]
    if dx * dx + dy * dy > kp.ball_stuck_area * kp.ball_stuck_area:
        _anchor_ball(b, w, r)
    elif w.time[b] - r.stuck_cycle[b] >= kp.drop_ball_time:
        w.vel[b, BALL, :] = 0.0
        w.acc[b, BALL, :] = 0.0
        r.dropped[b] = True
        _anchor_ball(b, w, r)


@borrowing
def _near_ball(b: int, w: World, first: int, stop: int, kickable2: float) -> bool:
    """Whether an enabled player among objects ``first..stop-1`` has centre distance < kickable area."""
    bx = w.pos[b, BALL, 0]
    by = w.pos[b, BALL, 1]
    for i in range(first, stop):
        if w.enabled[b, i]:
            dx = w.pos[b, i, 0] - bx
            dy = w.pos[b, i, 1] - by
            if dx * dx + dy * dy < kickable2:
                return True
    return False


@borrowing
def keepaway_referee(b: int, w: World, r: RefereeState, kp) -> int:
    """The referees of one play_on cycle of arena ``b``; returns the END_* cause (0: episode goes on).

    Run after movement, collisions and ``time += 1``. In rcssserver's referee order (spec 2 step 4)
    BallStuck comes before Keepaway; a drop does not move the ball, so it never changes the Keepaway
    decision of the same cycle. Keepaway (spec 5 "Every play_on cycle"): out test first (the ball not
    strictly inside the region centred on (0, 0)), then ``take_count >= take_cycles``, else the
    proximity update: any enabled taker nearer than the kickable area counts (even with a keeper
    near), otherwise a keeper that near resets the count, otherwise it stays. An end fills the end
    record, resets the field, and the next episode starts in this cycle. Before :func:`start_game`
    (not play_on) only the ball-stuck anchor follows the ball.
    """
    _clear_end_record(b, r)
    if r.episode[b] == 0:
        _anchor_ball(b, w, r)
        return END_NONE
    _ball_stuck(b, w, r, kp)

    cause = END_NONE
    if not (abs(w.pos[b, BALL, 0]) < 0.5 * kp.keepaway_length
            and abs(w.pos[b, BALL, 1]) < 0.5 * kp.keepaway_width):
        cause = END_OUT
    elif r.take_count[b] >= kp.take_cycles:
        cause = END_TAKEN
    else:
        kickable = kp.player_size + kp.kickable_margin + kp.ball_size
        kickable2 = kickable * kickable
        first_taker = 1 + w.n_keepers
        if _near_ball(b, w, first_taker, w.pos.shape[1], kickable2):
            r.take_count[b] += 1
        elif _near_ball(b, w, 1, first_taker, kickable2):
            r.take_count[b] = 0

    if cause != END_NONE:
        r.ended[b] = True
        r.end_cause[b] = cause
        r.end_cycle[b] = w.time[b]
        r.last_start_cycle[b] = r.start_cycle[b]
        reset_field(b, w, kp)
        r.take_count[b] = 0
        r.episode[b] += 1
        r.start_cycle[b] = w.time[b]
    return cause


@borrowing
def _referee_batch(w: World, r: RefereeState, kp, causes: np.ndarray) -> None:
    for b in range(w.pos.shape[0]):
        causes[b] = keepaway_referee(b, w, r, kp)


def referee_step(w: World, r: RefereeState, kp) -> np.ndarray:
    """Run :func:`keepaway_referee` on every arena; returns the END_* cause per arena (int8, (B,))."""
    causes = np.zeros(w.batch, dtype=np.int8)
    _referee_batch(w, r, kp, causes)
    return causes


__all__ = [
    "END_CAUSES",
    "END_NONE",
    "END_OUT",
    "END_TAKEN",
    "RefereeState",
    "keepaway_referee",
    "new_referee_state",
    "referee_step",
    "reset_field",
    "start_game",
]

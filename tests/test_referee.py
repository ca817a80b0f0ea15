"""The Keepaway and ball-stuck referees (spec `server-physics.md` 5; `keepaway-agents.md` 6)."""

from __future__ import annotations

import numpy as np
import pytest

from keepaway.protocol.params import parameter_set
from keepaway.server.referee import (
    END_CAUSES,
    END_NONE,
    END_OUT,
    END_TAKEN,
    new_referee_state,
    referee_step,
    reset_field,
    start_game,
)
from keepaway.core.rng import randint, uniform
from keepaway.core.objects import BALL
from keepaway.server.world import new_world

CLASSIC = parameter_set("classic")
KP = CLASSIC.kernel()
KICKABLE = CLASSIC.kickable_distance  # 0.3 + 0.7 + 0.085 = 1.085


def started(n_keepers=3, n_takers=2, batch=1, seed=0, params=CLASSIC):
    """A batch with every player enabled and the game started (episode 1 from cycle 0)."""
    w = new_world(params, n_keepers, n_takers, batch=batch, seed=seed)
    w.enabled[:] = True
    r = new_referee_state(batch)
    kp = params.kernel()
    for b in range(batch):
        start_game(b, w, r, kp)
    return w, r


def place(w, ball=(0.0, 0.0), near=()):
    """Ball at ``ball``; the objects in ``near`` 0.5 m from it; everyone else far away (> 5 m)."""
    w.pos[0, BALL] = ball
    for i in range(1, w.n_objects):
        w.pos[0, i] = (ball[0] + 0.5, ball[1]) if i in near else (ball[0] + 5.0 + i, ball[1] + 5.0)


def cycle(w, r, kp=KP):
    """time += 1, then the referees (what the step does after movement and collisions)."""
    w.time[:] += 1
    return int(referee_step(w, r, kp)[0])


# Objects of a 3v2 world: keepers 1..3, takers 4..5.
KEEPER, TAKER = 1, 4


def test_taken_after_four_counted_cycles_not_necessarily_consecutive():
    # Spec 5: taker near in 1, 2; nobody in 3 (count unchanged); taker near in 4, 5 -> count 4 after
    # cycle 5; the check at cycle 6 ends the episode 't' whatever the positions then.
    w, r = started()
    for near, count in [((TAKER,), 1), ((TAKER,), 2), ((), 2), ((TAKER,), 3), ((TAKER,), 4)]:
        place(w, near=near)
        assert cycle(w, r) == END_NONE
        assert r.take_count[0] == count
    place(w, near=())
    assert cycle(w, r) == END_TAKEN
    assert (r.ended[0], r.end_cause[0], r.end_cycle[0], r.last_start_cycle[0]) == (True, END_TAKEN, 6, 0)
    assert (r.episode[0], r.start_cycle[0], r.take_count[0]) == (2, 6, 0)
    assert END_CAUSES[END_TAKEN] == "taken"


def test_keeper_only_cycle_resets_the_take_count():
    # taker 1, 2, 3 -> 3; keeper alone at 4 -> 0; taker 5, 6, 7, 8 -> 4; ends at the check of 9.
    w, r = started()
    for _ in range(3):
        place(w, near=(TAKER,))
        cycle(w, r)
    place(w, near=(KEEPER,))
    cycle(w, r)
    assert r.take_count[0] == 0
    for t in range(5, 9):
        place(w, near=(TAKER,))
        assert cycle(w, r) == END_NONE, t
    assert cycle(w, r) == END_TAKEN
    assert r.end_cycle[0] == 9


def test_taker_next_to_a_keeper_still_counts():
    # Both near every cycle: counts 1..4 in cycles 1..4, taken at the check of cycle 5.
    w, r = started()
    for count in range(1, 5):
        place(w, near=(KEEPER, TAKER + 1))
        assert cycle(w, r) == END_NONE
        assert r.take_count[0] == count
    place(w, near=(KEEPER, TAKER + 1))
    assert cycle(w, r) == END_TAKEN
    assert r.end_cycle[0] == 5


@pytest.mark.parametrize("offset, counted", [(KICKABLE, False), (KICKABLE - 1e-9, True)])
def test_taker_must_be_strictly_inside_the_kickable_area(offset, counted):
    # rcssserver: distance2 < kickable_area**2 with kickable_area = 1.085; at exactly 1.085 it is out.
    w, r = started()
    place(w, near=())
    w.pos[0, TAKER] = (offset, 0.0)
    cycle(w, r)
    assert r.take_count[0] == int(counted)


def test_disabled_players_are_ignored():
    w, r = started()
    place(w, near=(TAKER,))
    w.enabled[0, TAKER] = False
    cycle(w, r)
    assert r.take_count[0] == 0
    r.take_count[0] = 2
    place(w, near=(KEEPER,))
    w.enabled[0, KEEPER] = False
    cycle(w, r)
    assert r.take_count[0] == 2  # a disabled keeper resets nothing


@pytest.mark.parametrize(
    "ball, out",
    [
        ((10.0, 0.0), True),  # exactly on the line |x| = L/2 = 10: not strictly inside
        ((-10.0, 0.0), True),
        ((0.0, 10.0), True),
        ((0.0, -10.0), True),
        ((10.3, -12.0), True),
        ((9.999, 9.999), False),
        ((-9.999, -9.999), False),
    ],
)
def test_ball_out_of_the_region_ends_the_episode(ball, out):
    w, r = started()
    place(w, ball=ball)
    assert cycle(w, r) == (END_OUT if out else END_NONE)
    assert bool(r.ended[0]) == out


def test_region_is_read_from_the_parameters():
    params = parameter_set("classic", keepaway_length=30.0, keepaway_width=16.0)
    w, r = started(params=params)
    place(w, ball=(14.0, 0.0))  # inside |x| < 15
    assert cycle(w, r, params.kernel()) == END_NONE
    place(w, ball=(0.0, 8.0))  # |y| = W/2 = 8: out
    assert cycle(w, r, params.kernel()) == END_OUT


def test_out_is_tested_before_taken():
    w, r = started()
    r.take_count[0] = 4
    place(w, ball=(11.0, 0.0), near=(TAKER,))
    assert cycle(w, r) == END_OUT


def test_end_record_lasts_one_call_and_episodes_chain():
    # Episode 1: 0..3 out; episode 2 starts at 3 and ends out at 5.
    w, r = started()
    place(w)
    cycle(w, r)
    cycle(w, r)
    place(w, ball=(0.0, -10.5))
    assert cycle(w, r) == END_OUT
    assert (r.episode[0], r.last_start_cycle[0], r.end_cycle[0], r.start_cycle[0]) == (2, 0, 3, 3)
    place(w)
    assert cycle(w, r) == END_NONE
    assert not r.ended[0] and r.end_cause[0] == END_NONE
    place(w, ball=(-20.0, 0.0))
    assert cycle(w, r) == END_OUT
    assert (r.episode[0], r.last_start_cycle[0], r.end_cycle[0]) == (3, 3, 5)


def test_episode_end_resets_the_field():
    w, r = started()
    place(w, ball=(10.0, 3.0))
    w.vel[0, :] = 0.4
    cycle(w, r)
    np.testing.assert_array_equal(w.pos[0, BALL], [-6.0, -6.0])
    np.testing.assert_array_equal(w.vel[0], 0.0)
    assert np.all(np.abs(w.pos[0, 1:]) <= 10.0)


def test_nothing_is_judged_before_the_first_play_on():
    w = new_world(CLASSIC, 3, 2)
    w.enabled[:] = True
    r = new_referee_state(1)
    w.pos[0, BALL] = (30.0, 0.0)
    assert cycle(w, r) == END_NONE
    assert r.episode[0] == 0
    np.testing.assert_array_equal(r.stuck_anchor[0], [30.0, 0.0])  # BallStuck follows the ball


def test_arenas_of_a_batch_are_independent():
    w, r = started(batch=2)
    w.pos[:, BALL] = (0.0, 0.0)
    w.pos[:, 1:] = (5.0, 5.0)
    w.pos[1, BALL] = (12.0, 0.0)
    w.time[:] += 1
    causes = referee_step(w, r, KP)
    assert causes.tolist() == [END_NONE, END_OUT]
    assert r.episode.tolist() == [1, 2]
    np.testing.assert_array_equal(w.pos[0, BALL], [0.0, 0.0])


# --- reset -------------------------------------------------------------------------------------

def _corner_slot(x, y, half_l, half_w, jitter=3.0):
    """Which reset slot box (spec 5) contains (x, y): 0..2 the keeper corners, 3 the centre, 4 the
    takers' corner, -1 none."""
    boxes = [
        ((-half_l, -half_l + jitter), (-half_w, -half_w + jitter)),
        ((half_l - jitter, half_l), (-half_w, -half_w + jitter)),
        ((half_l - jitter, half_l), (half_w - jitter, half_w)),
        ((-1.0, 1.0), (-1.0, 1.0)),
        ((-half_l, -half_l + jitter), (half_w - jitter, half_w)),
    ]
    for slot, ((x0, x1), (y0, y1)) in enumerate(boxes):
        if x0 <= x <= x1 and y0 <= y <= y1:
            return slot
    return -1


@pytest.mark.parametrize("n_keepers, n_takers, length, width",
                         [(3, 2, 20.0, 20.0), (4, 3, 20.0, 20.0), (3, 2, 30.0, 30.0)])
def test_reset_places_keepers_by_a_rotation_of_slots_and_takers_in_the_fourth_corner(
        n_keepers, n_takers, length, width):
    params = parameter_set("classic", keepaway_length=length, keepaway_width=width)
    batch = 300
    w, r = started(n_keepers, n_takers, batch=batch, seed=7, params=params)
    half_l, half_w = length / 2, width / 2
    first_slots = set()
    for b in range(batch):
        slots = [_corner_slot(*w.pos[b, i], half_l, half_w) for i in range(1, 1 + n_keepers)]
        first_slots.add(slots[0])
        # keeper i+1 takes the next slot mod K (slots >= 3 all map to the centre box)
        expected = [min((slots[0] + i) % n_keepers, 3) for i in range(n_keepers)]
        assert slots == expected, (b, slots)
        for i in range(1 + n_keepers, w.n_objects):
            assert _corner_slot(*w.pos[b, i], half_l, half_w) == 4
        # ball 4 m inside the slot-0 corner: (-6, -6) for 20 x 20, (-11, -11) for 30 x 30
        np.testing.assert_array_equal(w.pos[b, BALL], [-half_l + 4.0, -half_w + 4.0])
    assert first_slots == set(range(min(n_keepers, 4)))


def test_reset_keeps_angles_zeroes_motion_and_skips_disabled_players():
    w, r = started()
    angles = np.array([[0.0, 10.0, -20.0, 30.0, 170.0, -170.0]])
    for field in (w.body, w.neck, w.body_pending, w.neck_pending):
        field[:] = angles
    w.vel[:] = 0.7
    w.acc[:] = 0.2
    w.enabled[0, 2] = False
    parked = w.pos[0, 2].copy()
    reset_field(0, w, KP)
    for field in (w.body, w.neck, w.body_pending, w.neck_pending):
        np.testing.assert_array_equal(field, angles)
    enabled = [0, 1, 3, 4, 5]
    np.testing.assert_array_equal(w.vel[0, enabled], 0.0)
    np.testing.assert_array_equal(w.acc[0, enabled], 0.0)
    np.testing.assert_array_equal(w.pos[0, 2], parked)
    np.testing.assert_array_equal(w.vel[0, 2], 0.7)
    # two enabled keepers take two consecutive slots mod 2: {0, 1}
    slots = {_corner_slot(*w.pos[0, i], 10.0, 10.0) for i in (1, 3)}
    assert slots == {0, 1}


def test_reset_draws_in_rcssserver_order():
    # s = randint(K); then for keepers 1..3 (slot s, s+1, ...) and takers 1..2: x before y.
    w, r = started(seed=11)
    rng = w.rng.copy()
    reset_field(0, w, KP)
    s = randint(rng, 0, 3)
    expected = []
    for _ in range(3):
        u, v = uniform(rng, 0, 0.0, 3.0), uniform(rng, 0, 0.0, 3.0)
        expected.append([(-10 + u, -10 + v), (10 - u, -10 + v), (10 - u, 10 - v)][s])
        s = (s + 1) % 3
    for _ in range(2):
        u, v = uniform(rng, 0, 0.0, 3.0), uniform(rng, 0, 0.0, 3.0)
        expected.append((-10 + u, 10 - v))
    np.testing.assert_array_equal(w.pos[0, 1:], expected)
    assert w.rng[0] == rng[0]


def test_start_slot_is_uniform_over_seeds():
    # 3000 arenas: keeper 1's slot is 0, 1 or 2 with probability 1/3 each; sd of a count
    # sqrt(3000 * 1/3 * 2/3) = 25.8, so each count within 1000 +- 130 (5 sd).
    batch = 3000
    w, r = started(batch=batch, seed=3)
    slots = [_corner_slot(*w.pos[b, 1], 10.0, 10.0) for b in range(batch)]
    counts = np.bincount(slots, minlength=3)
    assert counts.shape == (3,)
    assert np.all(np.abs(counts - 1000) < 130), counts


@pytest.mark.parametrize("name, restores", [("classic", False), ("current", True)])
def test_current_reset_restores_stamina(name, restores):
    params = parameter_set(name)
    w, r = started(params=params)
    w.stamina[:] = 100.0
    w.effort[:] = 0.7
    w.recovery[:] = 0.6
    w.capacity[:] = 5.0
    reset_field(0, w, params.kernel())
    if restores:  # Player::recoverAll: stamina_max 8000, effort_max 1, recovery 1, capacity 130600
        np.testing.assert_array_equal(w.stamina[0, 1:], 8000.0)
        np.testing.assert_array_equal(w.effort[0, 1:], 1.0)
        np.testing.assert_array_equal(w.recovery[0, 1:], 1.0)
        np.testing.assert_array_equal(w.capacity[0, 1:], 130600.0)
    else:
        np.testing.assert_array_equal(w.stamina[0, 1:], 100.0)
        np.testing.assert_array_equal(w.effort[0, 1:], 0.7)


# --- ball stuck --------------------------------------------------------------------------------

@pytest.mark.parametrize("name, drop_time", [("classic", 200), ("current", 100)])
def test_ball_stuck_is_dropped_after_drop_ball_time_cycles(name, drop_time):
    # Cycle 1: ball to (7.5, 0), > 3 m from the anchor (0, 0) set at start -> re-anchored at cycle 1.
    # It then alternates between (5, 0) and (7.5, 0), within 3 m of the anchor; time - anchor cycle
    # reaches drop_ball_time at cycle 1 + drop_time (201 CLASSIC, 101 CURRENT).
    params = parameter_set(name)
    kp = params.kernel()
    w, r = started(params=params)
    for t in range(1, drop_time + 2):
        place(w, ball=(5.0 + 2.5 * (t % 2), 0.0))
        w.vel[0, BALL] = (0.3, 0.1)
        assert cycle(w, r, kp) == END_NONE
        dropped = t == 1 + drop_time
        assert bool(r.dropped[0]) == dropped, t
        assert np.all(w.vel[0, BALL] == 0.0) == dropped, t
    assert r.stuck_cycle[0] == 1 + drop_time
    np.testing.assert_array_equal(w.pos[0, BALL], [7.5, 0.0])  # dropped where it is


def test_ball_leaving_the_stuck_area_re_anchors():
    # Anchored at cycle 1 at (5, 0); at cycle 100 the ball is 3.5 m away -> new anchor, no drop at 201.
    w, r = started()
    for t in range(1, 202):
        place(w, ball=(8.5, 0.0) if t >= 100 else (5.0, 0.0))
        cycle(w, r)
        assert not r.dropped[0], t
    assert r.stuck_cycle[0] == 100
    np.testing.assert_array_equal(r.stuck_anchor[0], [8.5, 0.0])

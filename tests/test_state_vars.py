"""Pass and GetOpen state variables on hand-placed 3v2 positions (docs/players.md §6.1, §7.4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from beliefs import belief
from keepaway.agents.config import AgentConfig
from keepaway.agents.state_vars import getopen_state, getopen_state_size, pass_state, pass_state_size, smallest_angle

CFG = AgentConfig().kernel()
ANGLE_3_4_5 = math.degrees(math.acos(0.8))  # 36.8699 deg: cos = 0.8 in a 3-4-5 triangle


# ball, keepers 1..3, takers 4..5. Keeper 1 holds the ball; from K1 = (-3, -4): keeper 3 at (1, -1) is
# 5 m away (K2), keeper 2 at (3, 4) 10 m (K3); taker 5 at (-3, -2) 2 m (T1), taker 4 at (1, -4) 4 m (T2).
PASS_POSITION = [[-2.5, -4.0], [-3.0, -4.0], [3.0, 4.0], [1.0, -1.0], [1.0, -4.0], [-3.0, -2.0]]


def test_state_sizes_generalise():
    assert pass_state_size(3, 2) == 13
    assert pass_state_size(4, 3) == 19
    assert getopen_state_size(3, 2) == 10


def test_pass_state_13_variables_by_hand():
    out = np.full(13, np.nan)
    assert pass_state(belief(PASS_POSITION, 1), 0, CFG, out)
    expected = [
        5.0,  # dist(K1, C): |(-3, -4)|
        math.sqrt(2.0),  # dist(K2, C): |(1, -1)|
        5.0,  # dist(K3, C): |(3, 4)|
        math.sqrt(13.0),  # dist(T1, C): |(-3, -2)|
        math.sqrt(17.0),  # dist(T2, C): |(1, -4)|
        5.0,  # dist(K1, K2): |(4, 3)|
        10.0,  # dist(K1, K3): |(6, 8)|
        2.0,  # dist(K1, T1): |(0, 2)|
        4.0,  # dist(K1, T2): |(4, 0)|
        3.0,  # min dist(K2, Tj): (1,-1)-(1,-4) = 3 < (1,-1)-(-3,-2) = sqrt(17)
        math.sqrt(68.0),  # min dist(K3, Tj): (3,4)-(1,-4) = sqrt(68) < (3,4)-(-3,-2) = sqrt(72)
        ANGLE_3_4_5,  # min ang(K2, K1, Tj): rays (4,3)/(0,2): cos 0.6 (53.13); (4,3)/(4,0): cos 0.8
        ANGLE_3_4_5,  # min ang(K3, K1, Tj): rays (6,8)/(0,2): cos 0.8; (6,8)/(4,0): cos 0.6
    ]
    assert out == pytest.approx(expected)


def test_pass_state_is_the_same_from_any_keeper():
    # K1 is the keeper closest to the ball, not the deciding one
    a, b = np.zeros(13), np.zeros(13)
    assert pass_state(belief(PASS_POSITION, 1), 0, CFG, a)
    assert pass_state(belief(PASS_POSITION, 3), 0, CFG, b)
    assert a == pytest.approx(b)


def test_pass_state_invalid_when_a_player_is_unsure():
    bel = belief(PASS_POSITION, 1)
    bel.conf[0, 5] = 0.87  # below 0.88
    assert not pass_state(bel, 0, CFG, np.zeros(13))
    bel.conf[0, 5] = 0.88
    assert pass_state(bel, 0, CFG, np.zeros(13))


def test_getopen_state_for_a_point_by_hand():
    # keeper 2 (at (5, 5)) evaluates P = (0, 0). K1 = keeper 1 at (-6, 0) (ball at (-5.5, 0)).
    # Other keepers by distance from P: keeper 3 (3, 4) 5 m = K2', keeper 1 (-6, 0) 6 m = K3'.
    # Takers by distance from P: taker 4 (0, -2) 2 m = T1', taker 5 (-3, 3) sqrt(18) = T2'.
    pos = [[-5.5, 0.0], [-6.0, 0.0], [5.0, 5.0], [3.0, 4.0], [0.0, -2.0], [-3.0, 3.0]]
    out = np.full(10, np.nan)
    getopen_state(belief(pos, 2), 0, 0.0, 0.0, -6.0, 0.0, out)  # lane origin O = K1 = keeper 1
    expected = [
        5.0,  # dist(K1', K2')
        6.0,  # dist(K1', K3')
        2.0,  # dist(K1', T1')
        math.sqrt(18.0),  # dist(K1', T2')
        math.sqrt(37.0),  # min dist(K2', Tj'): (3,4)-(-3,3) = sqrt(37) < (3,4)-(0,-2) = sqrt(45)
        math.sqrt(18.0),  # min dist(K3', Tj'): (-6,0)-(-3,3) = sqrt(18) < (-6,0)-(0,-2) = sqrt(40)
        # rays (3,4)/(-3,3): cos 3/(5 sqrt 18) = 81.87 < (3,4)/(0,-2): 143.13
        math.degrees(math.acos(3.0 / (5.0 * math.sqrt(18.0)))),
        45.0,  # rays (-6,0)/(-3,3): 45 < (-6,0)/(0,-2): 90
        6.0,  # dist(K1, P)
        math.degrees(math.atan(1.0 / 3.0)),  # at K1: rays (6,0)/(6,-2): 18.43 < (6,0)/(3,3): 45
    ]
    assert out == pytest.approx(expected)


@pytest.mark.parametrize("estimate", [False, True])
def test_smallest_angle_by_hand(estimate):
    # from C = (1, 1), ray u = (2, 0) (length 2); takers 4 and 5 at 30 and 60 degrees from it, 2 m and 3 m
    # from C: 30 degrees; the same two at one spot: the one angle; taker 4 on C: a degenerate ray, 0
    c30, s30 = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))
    pos = [[0.0, 0.0], [1.0, 1.0], [5.0, 5.0], [3.0, 4.0], [1.0 + 2 * c30, 1.0 + 2 * s30],
           [1.0 + 1.5, 1.0 + 1.5 * 3 ** 0.5]]
    bel = belief(pos, 1)
    takers, norms = np.array([4, 5]), np.array([0.0, 0.0, 0.0, 0.0, 2.0, 3.0])
    assert smallest_angle(bel, 0, 2.0, 0.0, 2.0, 1.0, 1.0, takers, 2, norms, estimate) == pytest.approx(30.0)
    reversed_takers = takers[::-1].copy()
    assert smallest_angle(bel, 0, 2.0, 0.0, 2.0, 1.0, 1.0, reversed_takers, 2, norms, estimate) == pytest.approx(30.0)
    assert smallest_angle(bel, 0, 2.0, 0.0, 2.0, 1.0, 1.0, takers, 0, norms, estimate) == math.inf  # no takers
    bel.pos[0, 5] = bel.pos[0, 4]
    norms[5] = 2.0
    assert smallest_angle(bel, 0, 2.0, 0.0, 2.0, 1.0, 1.0, takers, 2, norms, estimate) == pytest.approx(30.0)
    bel.pos[0, 4] = (1.0, 1.0)
    norms[4] = 0.0
    assert smallest_angle(bel, 0, 2.0, 0.0, 2.0, 1.0, 1.0, takers, 2, norms, estimate) == 0.0

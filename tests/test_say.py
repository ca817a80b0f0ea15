"""Say and hear as the keepaway-0.6 C++ players (agents/say.py): the saymsglib code against hand-computed
values, what a player says, what a listener takes in, who hears whom (server.perception.hear_picks) and the
hear frames the server writes (server.percept_wire.hear_frames)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from keepaway.agents.config import AgentConfig
from keepaway.agents.say import (
    BYTE_CODES,
    MAX_CHARS,
    VALID_CHARS,
    X_LOW,
    X_SPAN,
    Y_LOW,
    Y_SPAN,
    decode_value,
    encode_position,
    encode_velocity,
    hear_bytes,
    hear_row,
    hear_text,
    new_talk,
    say_row,
    to_text,
)
from keepaway.agents.tracking import new_model_state
from keepaway.core.objects import BALL, CMD_DASH, CMD_KICK, CMD_TURN
from keepaway.protocol.codec import encode
from keepaway.protocol.messages import Hear
from keepaway.protocol.params import parameter_set
from keepaway.server.percept_wire import HEAR_FRAME_BYTES, HEAR_SENDERS, HearBuffers, hear_frames, write_hear
from keepaway.server.perception import hear_picks
from keepaway.server.world import new_world

K, T = 3, 2
PARAMS = parameter_set("current")
KP = PARAMS.kernel()
CFG = AgentConfig().kernel()
NOW = 50


def model(me: int, positions: dict, seen: dict | None = None, ball_chg: int = NOW, vel: dict | None = None):
    """A one-row world model of player ``me`` at cycle NOW: objects at ``positions`` (object -> (x, y)),
    each seen at NOW unless ``seen`` says otherwise."""
    s = new_model_state(1, K, T, me, PARAMS)
    s.time[0] = NOW
    for obj, xy in positions.items():
        s.pos[0, obj] = xy
        s.seen[0, obj] = (seen or {}).get(obj, NOW)
        s.obs_time[0, obj] = s.seen[0, obj]
    for obj, v in (vel or {}).items():
        s.vel[0, obj] = v
    s.ball_chg[0] = ball_chg
    return s


# ------------------------------------------------------------------------------------------ the code


def test_position_codes_are_the_floor_of_73_levels():
    # (0 + 53) / 106 * 73 = 36.5 -> 36, the 37th character 'A'; it decodes to 36/73*106 - 53 = -0.7260
    assert encode_position(0.0, X_LOW, X_SPAN) == 36 and VALID_CHARS[36] == "A"
    assert decode_value(36, X_LOW, X_SPAN) == pytest.approx(36 / 73 * 106 - 53, abs=1e-5)
    # (10 + 34) / 68 * 73 = 47.235 -> 47; the field's ends clip to the first and last character
    assert encode_position(10.0, Y_LOW, Y_SPAN) == 47
    assert encode_position(-60.0, X_LOW, X_SPAN) == 0 and encode_position(60.0, X_LOW, X_SPAN) == 72


def test_velocity_codes():
    # (1.0 + 2.7) / 5.4 * 73 = 50.02 -> 50; decoded 50/73*5.4 - 2.7 = 0.99863
    assert encode_velocity(1.0) == 50
    assert decode_value(50, -2.7, 5.4) == pytest.approx(50 / 73 * 5.4 - 2.7, abs=1e-6)
    # a pass faster than the range's end is sent as its last character (2.626 m/cycle)
    assert encode_velocity(3.0) == 72 and encode_velocity(-3.0) == 0


def test_positions_are_coded_in_single_precision():
    # x = -53 + 106 * 30 / 73 is code 30 exactly in real arithmetic; in float its code is whatever the
    # float expression gives, never off by more than one
    x = -53.0 + 106.0 * 30 / 73
    f = np.float32
    expected = int(f(f(f(x) + f(53.0)) / f(106.0)) * f(73.0))
    assert encode_position(x, X_LOW, X_SPAN) == expected and expected in (29, 30)


# ----------------------------------------------------------------------------------------- saying


def test_a_keeper_passing_says_the_ball_after_its_kick_with_cycleno_0_then_its_own_position():
    # keeper 1 at the origin facing 0 deg, the ball 0.5 m ahead: kick at power 100 straight ahead
    s = model(1, {BALL: (0.5, 0.0), 1: (0.0, 0.0), 2: (10.0, 0.0), 4: (8.0, 8.0)})
    talk = new_talk(1)
    say_row(0, s, CMD_KICK, 100.0, 0.0, K, KP, CFG, talk)
    text = to_text(talk, 0)
    # rate = 0.027 (1 - 0.25 * (0.5 - 0.385) / 0.7) = 0.025891; v = 2.5891 (under ball_speed_max 3.0)
    rate = 0.027 * (1 - 0.25 * (0.5 - 0.3 - 0.085) / 0.7)
    v = rate * 100
    assert text[0] == "1" and len(text) == 9  # BallInfo, then OurPos: no opponent within 3 m
    assert text[1] == VALID_CHARS[encode_position(0.5 + v, X_LOW, X_SPAN)]
    assert text[3] == VALID_CHARS[encode_velocity(v * 0.94)]
    assert text[5] == "0"  # a pass: the ball ends 3.09 m from me, beyond 1.085 + 0.2
    assert text[6:] == "0" + VALID_CHARS[36] + VALID_CHARS[36]  # OurPos: still at (0, 0)


def test_a_keeper_holding_says_the_ball_where_it_is_with_no_velocity_and_the_nearest_taker():
    s = model(1, {BALL: (0.5, 0.0), 1: (0.0, 0.0), 4: (2.0, 0.0), 5: (2.5, 0.0)}, vel={BALL: (0.3, 0.0)})
    talk = new_talk(1)
    say_row(0, s, CMD_KICK, 10.0, 90.0, K, KP, CFG, talk)  # a small kick: the ball stays kickable
    text = to_text(talk, 0)
    assert text[:6] == "1" + VALID_CHARS[encode_position(0.5, X_LOW, X_SPAN)] + "A" + 2 * VALID_CHARS[
        encode_velocity(0.0)] + "1"
    # OppPos of taker 1 (object 4, 2 m away): id 8, then x, y and cycleno 1; no room for OurPos
    assert text[6:] == "8" + VALID_CHARS[encode_position(2.0, X_LOW, X_SPAN)] + "A" + "1"


def test_a_taker_speaks_in_its_mirrored_frame():
    s = model(4, {BALL: (5.0, 2.0), 4: (0.0, 0.0)})
    talk = new_talk(1)
    say_row(0, s, CMD_DASH, 100.0, 0.0, K, KP, CFG, talk)
    text = to_text(talk, 0)
    assert text[1] == VALID_CHARS[encode_position(-5.0, X_LOW, X_SPAN)]
    assert text[2] == VALID_CHARS[encode_position(-2.0, Y_LOW, Y_SPAN)]


def test_nothing_is_said_in_cycle_0_without_a_ball_seen_or_when_silent():
    talk = new_talk(1)
    s = model(1, {BALL: (15.0, 0.0), 1: (0.0, 0.0)}, seen={BALL: NOW - 1})
    say_row(0, s, CMD_TURN, 30.0, 0.0, K, KP, CFG, talk)
    assert to_text(talk, 0) == "0AA"  # no fresh ball, no opponent: my position only
    s.time[0] = 0
    talk.last_say[0] = -5
    say_row(0, s, CMD_TURN, 30.0, 0.0, K, KP, CFG, talk)
    assert talk.said_len[0] == 0
    s.time[0] = NOW
    silent = AgentConfig(say_messages=False).kernel()
    say_row(0, s, CMD_TURN, 30.0, 0.0, K, KP, silent, talk)
    assert talk.said_len[0] == 0


# ---------------------------------------------------------------------------------------- hearing


def heard(s, text: str, cfg=CFG):
    talk = new_talk(1)
    hear_text(talk, 0, text)
    hear_row(0, s, K, cfg, talk)
    assert not talk.heard_new[0]  # processed once
    return s


def pass_message(x: float, y: float, vx: float, vy: float, cycleno: int) -> str:
    return ("1" + VALID_CHARS[encode_position(x, X_LOW, X_SPAN)] + VALID_CHARS[encode_position(y, Y_LOW, Y_SPAN)]
            + VALID_CHARS[encode_velocity(vx)] + VALID_CHARS[encode_velocity(vy)] + VALID_CHARS[cycleno])


def test_a_pass_heard_in_a_cycle_without_a_see_replaces_a_ball_believed_still():
    # keeper 2 at (10, 0) believes the ball still at keeper 1's feet (last change pair a cycle ago)
    s = model(2, {BALL: (0.5, 0.0), 2: (10.0, 0.0)}, seen={BALL: NOW - 1}, ball_chg=NOW - 1)
    heard(s, pass_message(3.0, 0.0, 2.4, 0.0, 0))
    assert s.pos[0, BALL, 0] == pytest.approx(decode_value(encode_position(3.0, X_LOW, X_SPAN), X_LOW, X_SPAN))
    assert s.vel[0, BALL, 0] == pytest.approx(decode_value(encode_velocity(2.4), -2.7, 5.4))
    assert s.seen[0, BALL] == NOW - 1  # confidence 0.99: a cycle old


def test_a_heard_ball_is_not_taken_after_a_see_close_by_or_when_it_agrees():
    s = model(2, {BALL: (0.5, 0.0), 2: (10.0, 0.0)})  # seen with its change pair this cycle
    heard(s, pass_message(3.0, 0.0, 2.4, 0.0, 0))
    assert tuple(s.pos[0, BALL]) == (0.5, 0.0)
    s = model(2, {BALL: (0.5, 0.0), 2: (2.0, 0.0)}, seen={BALL: NOW - 1}, ball_chg=NOW - 1)  # within 3 m
    heard(s, pass_message(3.0, 0.0, 2.4, 0.0, 0))
    assert tuple(s.pos[0, BALL]) == (0.5, 0.0)
    # cycleno 1 (not a pass): the change pair must be over 3 cycles old
    s = model(2, {BALL: (0.5, 0.0), 2: (10.0, 0.0)}, seen={BALL: NOW - 1}, ball_chg=NOW - 1)
    heard(s, pass_message(3.0, 0.0, 2.4, 0.0, 1))
    assert tuple(s.pos[0, BALL]) == (0.5, 0.0)


def test_a_ball_never_seen_is_taken_rolled_on_by_cycleno():
    s = model(2, {2: (10.0, 0.0)})
    heard(s, pass_message(0.0, 0.0, 1.0, 0.0, 1))
    v = decode_value(encode_velocity(1.0), -2.7, 5.4)
    assert s.pos[0, BALL, 0] == pytest.approx(decode_value(36, X_LOW, X_SPAN) + v)
    assert s.vel[0, BALL, 0] == pytest.approx(v * 0.94)
    assert s.seen[0, BALL] == NOW - 2  # confidence 0.98


def test_an_opponent_heard_is_taken_only_when_mine_is_older_and_our_pos_changes_nothing():
    s = model(2, {4: (5.0, 5.0), 5: (1.0, 1.0)}, seen={4: NOW - 3, 5: NOW - 1}, vel={4: (0.5, 0.0)})
    opp = ("8" + VALID_CHARS[encode_position(6.0, X_LOW, X_SPAN)] + VALID_CHARS[encode_position(6.0, Y_LOW, Y_SPAN)]
           + "1")
    opp2 = "9" + opp[1:]
    heard(s, opp + "0AA")
    assert s.pos[0, 4, 0] == pytest.approx(decode_value(encode_position(6.0, X_LOW, X_SPAN), X_LOW, X_SPAN))
    assert tuple(s.vel[0, 4]) == (0.0, 0.0) and s.seen[0, 4] == NOW - 2
    heard(s, opp2)  # taker 2 was seen a cycle ago: confidence 0.99 is not below 0.98
    assert tuple(s.pos[0, 5]) == (1.0, 1.0)
    before = s.pos.copy()
    heard(s, "0" + "B" * 2)  # OurPos: the C++ applies it to the listener itself, i.e. not at all
    assert np.array_equal(s.pos, before)


@pytest.mark.parametrize("text", ["2aaa", "1aaaa", "1aaaa1x", "1aaaa1@", "1aaaa18aa1aaa"])
def test_a_message_that_does_not_decode_is_dropped_whole(text):
    s = model(2, {2: (10.0, 0.0)})
    heard(s, text)
    assert s.seen[0, BALL] < 0  # the ball (never seen) was not taken from a partly decoded message


def _heard_by_the_rule(talk, r: int, text: str) -> None:
    """The hearing rule written out: each character's place in the alphabet; a text longer than the
    encoder's or with a character outside it is kept as undecodable (length -1, codes untouched)."""
    codes = [VALID_CHARS.find(ch) for ch in text]
    ok = len(codes) <= MAX_CHARS and min(codes, default=0) >= 0
    talk.heard_len[r] = len(codes) if ok else -1
    if ok:
        talk.heard[r, :len(codes)] = codes
    talk.heard_new[r] = True


def test_a_text_heard_from_its_bytes_leaves_the_row_as_heard_from_its_str():
    """``hear_bytes`` (a hear frame's text, read where it lies) and ``hear_text`` (the decoded
    message's) against the rule written out: the same codes, length and flag on random texts, valid,
    too long, with characters outside the alphabet or beyond ASCII, over rows that held other messages
    before."""
    rng = np.random.default_rng(4)
    alphabet = VALID_CHARS + " @#!~\x7f\x80\xff\u00e9\u20ac\ud800"
    by_rule, by_str, by_bytes = new_talk(2), new_talk(2), new_talk(2)
    for _ in range(600):
        r = int(rng.integers(2))
        text = "".join(rng.choice(list(alphabet), size=int(rng.integers(0, 14))))
        data = bytes(min(ord(ch), 0xFF) for ch in text)  # one byte a character: beyond ASCII stays beyond it
        frame = bytes(rng.integers(0, 256, size=int(rng.integers(0, 5)), dtype=np.uint8)) + data
        start = len(frame) - len(data)
        _heard_by_the_rule(by_rule, r, text)
        hear_text(by_str, r, text)
        hear_bytes(by_bytes, r, frame, start, len(data), BYTE_CODES)
        for got, want in zip(by_bytes, by_rule):
            assert np.array_equal(got, want), text
        for got, want in zip(by_str, by_rule):
            assert np.array_equal(got, want), text


# -------------------------------------------------------------------------------- who hears whom


def test_each_listener_hears_one_teammate_and_one_opponent_at_random():
    w = new_world(PARAMS, K, T, batch=1, seed=3)
    w.pos[0, 1:] = [(0, 0), (5, 0), (10, 0), (0, 5), (5, 5)]
    speakers = np.arange(1, K + T + 1)
    picks = np.empty(len(speakers), dtype=np.int64)
    chosen = set()
    for _ in range(40):
        n = hear_picks(0, w, speakers, 1, KP.hear_max, KP.audio_cut_dist, picks)
        assert n == 2
        mate, opp = speakers[picks[:2]]
        assert mate in (2, 3) and opp in (4, 5)
        chosen.add(mate)
    assert chosen == {2, 3}
    # beyond audio_cut_dist nobody is heard
    assert hear_picks(0, w, speakers, 1, KP.hear_max, 4.0, picks) == 0


def test_a_hear_frame_is_the_encoded_hear():
    """The server's hears of players' says, written by a kernel, are ``encode(Hear(...))`` exactly: every
    sender of a say, with and without direction and number, texts of every msgpack str width, and
    cycles of every msgpack int width."""
    buf = np.empty(HEAR_FRAME_BYTES + 300, dtype=np.uint8)
    texts = ("", "0uq", "1EsAA10vy", "(b 1.2 -3.4)+*/?<>_", "x" * 31, "x" * 32, "x" * 255, "y" * 256)
    for cycle in (0, 1, 127, 128, 255, 65_536, 2**31 - 1):
        for sender, direction, unum in (("self", None, None), ("our", -180, 2), ("our", -33, 1), ("our", 37, 11),
                                        ("opp", 180, None), ("opp", -32, None), ("opp", 0, None)):
            for text in texts:
                n = write_hear(buf, 0, cycle, HEAR_SENDERS.index(sender), direction or 0, unum or 0,
                               np.frombuffer(bytearray(text, "ascii"), dtype=np.uint8))
                assert buf[:n].tobytes() == encode(Hear(cycle=cycle, sender=sender, direction=direction, unum=unum,
                                                        message=text))


def _hears_by_hand(w, says, listeners, cycle):
    """What each listener hears of ``says`` ((speaker, text) in object order), as the server's rule says:
    its own says, then ``hear_picks``' draws with the direction from its body (rcssserver's: the angle in
    radians normalised to [-pi, pi], then whole degrees truncated towards zero) and, from a teammate, the
    number; encoded as ``Hear`` messages."""
    speakers = np.array([speaker for speaker, _ in says], dtype=np.int64)
    picks = np.empty(len(says), dtype=np.int64)
    heard = []
    for listener in listeners:
        heard += [(listener, "self", encode(Hear(cycle=cycle, sender="self", direction=None, unum=None, message=text)))
                  for speaker, text in says if speaker == listener]
        for pick in picks[:hear_picks(0, w, speakers, listener, KP.hear_max, KP.audio_cut_dist, picks)]:
            speaker, text = says[pick]
            (lx, ly), (sx, sy) = w.pos[0, listener].tolist(), w.pos[0, speaker].tolist()
            a = math.atan2(sy - ly, sx - lx) - float(w.body[0, listener]) * (math.pi / 180.0)
            a = a + 2 * math.pi if a < -math.pi else a - 2 * math.pi if a > math.pi else a
            direction = int(a * (180.0 / math.pi))
            ours = (speaker <= K) == (listener <= K)
            heard.append((listener, "our" if ours else "opp",
                          encode(Hear(cycle=cycle, sender="our" if ours else "opp", direction=direction,
                                      unum=(speaker if speaker <= K else speaker - K) if ours else None,
                                      message=text))))
    return heard


@pytest.mark.parametrize("seed", range(20))
def test_the_hear_frames_of_a_cycle_are_the_draws_directions_and_texts_of_the_rule(seed):
    """``hear_frames``, the server's one call a cycle, against the rule written out in Python: random
    places and bodies (some players beyond the audio cut, some silent, one saying twice), the same
    frames for the same listeners in the same order, and the same draws from the arena's stream."""
    rng = np.random.default_rng(seed)
    w = new_world(PARAMS, K, T, batch=1, seed=seed)
    w.pos[0, 1:] = rng.uniform(-30, 30, size=(K + T, 2))
    w.body[0, 1:] = rng.uniform(-180, 180, size=K + T)
    w.pos[0, 2] = w.pos[0, 1] + [3.0, 3.0]  # a direction of exactly 45 degrees from keeper 1 before its body
    w.body[0, 1] = 0.5 * rng.integers(-360, 360)  # a half-degree body: directions ending in .5 (truncated)
    speakers = sorted(rng.choice(np.arange(1, K + T + 1), size=rng.integers(1, K + T + 1), replace=False).tolist())
    says = [(speaker, "".join(rng.choice(list("0123456789abcXYZ (.)"), size=rng.integers(0, 11))))
            for speaker in speakers]
    says.insert(1, (says[0][0], "again"))
    listeners = sorted(rng.choice(np.arange(1, K + T + 1), size=rng.integers(1, K + T + 1), replace=False).tolist())
    cycle = int(rng.integers(0, 100_000))
    before = w.rng.copy()
    expected = _hears_by_hand(w, says, listeners, cycle)
    drawn = w.rng.copy()
    w.rng[:] = before
    hears = HearBuffers.empty(len(says), len(listeners), int(PARAMS.say_msg_size))
    texts = "".join(text for _, text in says).encode("ascii")
    hears.texts[:len(texts)] = np.frombuffer(texts, dtype=np.uint8)
    hears.text_ends[:len(says)] = np.cumsum([len(text) for _, text in says])
    hears.speakers[:len(says)] = [speaker for speaker, _ in says]
    hears.listeners[:len(listeners)] = listeners
    n = hear_frames(0, w, hears, len(says), len(listeners), KP.hear_max, KP.audio_cut_dist, cycle)
    frame_listener, frame_sender, frame_end = hears.frame_listener, hears.frame_sender, hears.frame_end
    starts = [0, *frame_end[:n - 1].tolist()]
    got = [(listeners[frame_listener[f]], HEAR_SENDERS[frame_sender[f]], hears.frames[starts[f]:frame_end[f]].tobytes())
           for f in range(n)]
    assert got == expected
    np.testing.assert_array_equal(w.rng, drawn)


def test_says_reach_teammates_in_a_game_and_keepers_hear_passes():
    from keepaway.runner.batched import BatchedArenas

    arenas = BatchedArenas(PARAMS, 2, 11, pass_policy="random", threads=1)
    arenas.run(total_episodes=6)
    talk = arenas.players.talk
    assert (talk.said_len > 0).all()  # everyone talks every cycle
    heard_any = (talk.heard_len > 0)
    assert heard_any.all()
    assert math.isfinite(float(arenas.players.model.pos.sum()))

"""Say and hear as the keepaway-0.6 C++ players do them (docs/players.md §4.5).

What a player says (tjpalmer/keepaway ``player/KeepawayPlayer.cc``, ``makeSayMessage``): every
hear_decay cycles from its cycle 1 (:func:`new_talk`), right after deciding, at most 10 characters of the saymsglib code
(``SayMsgTypes.h``, ``SayMsgDataTypes.h``), built from its world model and the command it just chose:

* **BallInfo** (6 characters) if it has good information about the ball: it saw the ball this cycle with
  its change pair within 20 m, or saw it within visible_distance, or has it within kickable distance and
  its command takes the ball out of reach. A kick that leaves the ball more than kickable distance + 0.2 m
  from where I will be is a pass: the ball's position and velocity after the kick, ``cycleno`` 0;
  otherwise, with the ball kickable, its present position and no velocity, ``cycleno`` 1; otherwise what
  I believe, ``cycleno`` 1.
* **OppPos** (4) the opponent nearest to me among those seen this cycle within visible_distance.
* **OurPos** (3) my position after the command, if at most 7 characters are used so far.

Positions and velocities are in the speaker's own frame (the takers' C++ mirrors the field) and each
takes one character of 73: X in [-53, 53) (steps of 1.45 m), Y in [-34, 34) (0.93 m), velocities in
[-2.7, 2.7) (0.074 m/cycle), rounded down in single precision, out-of-range values clipped.

What a listener does with it (``SenseHandler::analyzePlayerMessage``, ``WorldModel::processPlayerMessage``,
``WorldModelSayMsgTypes.cc``): it keeps the last message heard from a teammate (the opponents' are
ignored) and processes it once, after that cycle's see and before deciding:

* BallInfo: the ball rolled ``cycleno`` cycles on (decay 0.94) replaces my ball if I never saw the ball,
  or if it is more than 3 m away and either its change pair is over 3 cycles old or it is older than
  ``cycleno`` cycles and the heard velocity differs from mine by more than 0.3 m/cycle; and then only
  if my ball's confidence is below the message's (1 - cycleno/100 - 0.01) or the velocities differ by
  more than 0.3. The ball is then "seen" 1-2 cycles ago (the confidence's age).
* OppPos, TeammatePos: the player's position, with no velocity, if my confidence in it is below the
  message's.
* OurPos: nothing. The C++ decoder is given the listener's own uniform number as the sender's, so the
  teammate it updates is the listener itself, which ``processPerfectHearInfo`` skips.

In CURRENT and CLASSIC keepaway (360 deg vision, 2 sees per 3 cycles) this leaves one effect that
matters: a pass said in a cycle before one without a see reaches a listener more than 3 m away a cycle
before he sees it.

Messages are arrays of character codes (0..72, :data:`VALID_CHARS`), so the batched mode passes them
between rows without strings; a player process writes them into its command frame
(``agents.command_wire``, with :data:`CHAR_BYTES`) and reads them from its hear frames (:func:`hear_bytes`)
or a decoded hear's text (:func:`hear_text`); :func:`to_text` gives a message as text. The server's side
(who hears whom) is ``server.perception.hear_picks``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from keepaway.agents.geometry import (
    ball_after_kick,
    compared_hypot,
    frame_sign,
    kick_rate,
    kickable_distance,
    nearer_than,
    opponent_range,
    player_step,
)
from keepaway.agents.tracking import NEVER, ModelState, confidence
from keepaway.core.jit import borrowing
from keepaway.core.objects import BALL, CMD_DASH, CMD_KICK, CMD_NONE

# saymsglib's alphabet (SayMsgDataTypes.h validchars): a character is its index, 0..72.
VALID_CHARS = "0123456789abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ().+-*/?<>_"
NUM_CHARS = len(VALID_CHARS)
CHAR_BYTES = np.frombuffer(VALID_CHARS.encode("ascii"), dtype=np.uint8)  # code -> its character's byte
# The encoder's length (SayMsgEncoder's default maxsize, whatever the server's say_msg_size).
MAX_CHARS = 10
# Message unit ids (SayMsgIDs.h; 2 is unused) and their lengths in characters (SayMsgTypes.h getCost).
OUR_POS_ID = 0
BALL_INFO_ID = 1
OPP_POS_ID = 8  # + player number - 1, for players 1..11
TEAMMATE_POS_ID = 19  # likewise
# 0 OurPos, 1 BallInfo, 3 WeHaveBall, 4 OppHasBall, 5 PassToPlayer, 6 PassToCoord, 7 WantPass, 8-29 positions
UNIT_COST = np.array([3, 6, 0, 2, 2, 2, 3, 1] + [4] * 22, dtype=np.int64)
# Field ranges (SayMsgDataTypes.h): value = low + code / 73 * span.
X_LOW, X_SPAN = -53.0, 106.0
Y_LOW, Y_SPAN = -34.0, 68.0
V_LOW, V_SPAN = -2.7, 5.4
# WorldModelSayMsgTypes.cc rolls a heard ball on with this decay, not the server's ball_decay.
HEARD_BALL_DECAY = 0.94
# KeepawayPlayer's first say time: "long ago".
NEVER_SAID = -5
# The code of each ASCII byte, -1 outside the alphabet (hear_bytes).
BYTE_CODES = np.full(128, -1, dtype=np.int64)
BYTE_CODES[[ord(c) for c in VALID_CHARS]] = np.arange(len(VALID_CHARS))


class Talk(NamedTuple):
    """What ``R`` players (a row each) said this cycle and last heard from a teammate."""

    said: np.ndarray  # (R, MAX_CHARS) int64 character codes of this cycle's message
    said_len: np.ndarray  # (R,) int64 its length, 0: nothing said
    start: np.ndarray  # (R,) int64 the cycle I count as my cycle 0 (a reseeded player's is its reseed's)
    last_say: np.ndarray  # (R,) int64 cycle of my last say
    heard: np.ndarray  # (R, MAX_CHARS) int64 the last teammate message heard
    heard_len: np.ndarray  # (R,) int64 its length, -1: it does not decode
    heard_new: np.ndarray  # (R,) bool: heard since last processed


def new_talk(rows: int, start: int = 0) -> Talk:
    """Nothing said or heard yet, by players whose cycle 0 is ``start``: a player process reseeded by
    the coach starts afresh at the cycle of its reseed (docs/advice.md §2, "seed"), as a fresh player at 0."""
    return Talk(said=np.zeros((rows, MAX_CHARS), dtype=np.int64), said_len=np.zeros(rows, dtype=np.int64),
                start=np.full(rows, start, dtype=np.int64), last_say=np.full(rows, start + NEVER_SAID, dtype=np.int64),
                heard=np.zeros((rows, MAX_CHARS), dtype=np.int64), heard_len=np.zeros(rows, dtype=np.int64),
                heard_new=np.zeros(rows, dtype=np.bool_))


def to_text(talk: Talk, r: int) -> str:
    """Row ``r``'s message of this cycle as text ("" if it says nothing)."""
    return CHAR_BYTES[talk.said[r, :talk.said_len[r]]].tobytes().decode("ascii")


def hear_text(talk: Talk, r: int, text: str) -> None:
    """Row ``r`` heard ``text`` from a teammate (:func:`hear_bytes` of its UTF-8 bytes: a text in the
    alphabet is ASCII, one byte a character, and any other character makes a byte beyond the alphabet)."""
    data = text.encode("utf-8", "surrogatepass")
    hear_bytes(talk, r, data, 0, len(data), BYTE_CODES)


@borrowing
def hear_bytes(talk: Talk, r: int, buf, start: int, length: int, codes) -> None:
    """Row ``r`` heard from a teammate the text whose bytes lie at ``buf[start:start + length]`` (a hear
    frame's, ``agents.frames``, read where it lies: a player hears its teammates' says every cycle), with
    ``codes`` = :data:`BYTE_CODES`. It replaces any message not yet processed (the C++ keeps the last
    one). Text longer than the encoder's or with a character outside the alphabet (a byte beyond ASCII
    among them) is kept as undecodable: the C++ decoder fails on it and processes none of it."""
    ok = length <= MAX_CHARS
    if ok:
        for i in range(length):
            byte = buf[start + i]
            if byte >= codes.shape[0] or codes[byte] < 0:
                ok = False
                break
    if ok:
        for i in range(length):
            talk.heard[r, i] = codes[buf[start + i]]
    talk.heard_len[r] = length if ok else -1
    talk.heard_new[r] = True


# ---------------------------------------------------------------------------------------------------
# the code: one character per value, in single precision as the C++ floats


@borrowing
def _clip_code(i) -> int:
    """``get_printable_char``: the index truncated towards zero, clipped to the alphabet."""
    code = int(i)
    if code < 0:
        return 0
    return min(code, NUM_CHARS - 1)


@borrowing
def encode_position(value: float, low: float, span: float) -> int:
    """X and Y: ``(v - low) / span * 73`` all in float (the C++ literals are integers)."""
    v = np.float32(np.float32(value) - np.float32(low))
    return _clip_code(np.float32(np.float32(v / np.float32(span)) * np.float32(NUM_CHARS)))


@borrowing
def encode_velocity(value: float) -> int:
    """dX and dY: the float value, then ``(v + 2.7) / 5.4 * 73`` in double (double literals)."""
    return _clip_code((float(np.float32(value)) - V_LOW) / V_SPAN * NUM_CHARS)


@borrowing
def decode_value(code: int, low: float, span: float) -> float:
    """``(float)code / 73 * span + low`` stored in a float."""
    return float(np.float32(float(np.float32(code) / np.float32(NUM_CHARS)) * span + low))


# ---------------------------------------------------------------------------------------------------
# saying


@borrowing
def _ball_after_command(r: int, s: ModelState, main: int, power: float, angle: float, kp) -> tuple:
    """``WorldModel::predictBallInfoAfterCommand``: the ball a step on, after my kick if I kick (power and
    angle truncated to integers as the C++ does, the kick rate of the ball where it is): position and
    velocity."""
    me = s.me[r]
    bx, by, vx, vy = s.pos[r, BALL, 0], s.pos[r, BALL, 1], s.vel[r, BALL, 0], s.vel[r, BALL, 1]
    if main != CMD_KICK:
        return bx + vx, by + vy, vx * kp.ball_decay, vy * kp.ball_decay
    rate = kick_rate(s.pos[r, me, 0], s.pos[r, me, 1], s.body[r, me], bx, by, kp)
    return ball_after_kick(bx, by, vx, vy, rate, float(int(power)), float(int(angle)), s.body[r, me], kp)


@borrowing
def _me_after(r: int, s: ModelState, main: int, power: float, kp) -> tuple:
    """``WorldModel::predictAgentPosAfterCommand``: my next position after a dash of ``power``, any other
    command coasting, no command (the C++ CMD_ILLEGAL) a dash of 0.01."""
    me = s.me[r]
    if main == CMD_NONE:
        main, power = CMD_DASH, 0.01
    x, y, _, _, _ = player_step(s.pos[r, me, 0], s.pos[r, me, 1], s.vel[r, me, 0], s.vel[r, me, 1],
                                s.body[r, me], s.effort[r], main, power, kp)
    return x, y


@borrowing
def _put_position(talk: Talk, r: int, at: int, x: float, y: float) -> int:
    talk.said[r, at] = encode_position(x, X_LOW, X_SPAN)
    talk.said[r, at + 1] = encode_position(y, Y_LOW, Y_SPAN)
    return at + 2


@borrowing
def say_row(r: int, s: ModelState, main: int, a1: float, a2: float, n_keepers: int, kp, cfg,
            talk: Talk) -> None:
    """Row ``r``'s message for this cycle (module docstring) after deciding ``main`` with arguments
    ``a1``, ``a2`` (dash: power; turn: moment; kick: power, direction), into ``talk.said``; length 0
    if it says nothing this cycle."""
    talk.said_len[r] = 0
    now = s.time[r]
    if not cfg.say_messages or now <= talk.start[r] or now - talk.last_say[r] < kp.hear_decay:
        return
    talk.last_say[r] = now
    me = s.me[r]
    sign = frame_sign(me, n_keepers)
    kickable = kickable_distance(kp)
    # my distance to the ball is only compared with thresholds: compared_hypot decides each exactly
    bdx, bdy = s.pos[r, BALL, 0] - s.pos[r, me, 0], s.pos[r, BALL, 1] - s.pos[r, me, 1]
    ball_kickable = compared_hypot(bdx, bdy, kickable) < kickable
    ball_now = s.seen[r, BALL] == now
    pbx, pby, pvx, pvy = _ball_after_command(r, s, main, a1, a2, kp)
    mx, my = _me_after(r, s, main, a1, kp)
    at = 0
    if ((s.ball_chg[r] == now and ball_now and compared_hypot(bdx, bdy, cfg.say_ball_range) < cfg.say_ball_range)
            or (ball_now and compared_hypot(bdx, bdy, kp.visible_distance) < kp.visible_distance)
            or (ball_kickable and compared_hypot(pbx - mx, pby - my, kickable) > kickable)):
        bx, by, vx, vy = s.pos[r, BALL, 0], s.pos[r, BALL, 1], s.vel[r, BALL, 0], s.vel[r, BALL, 1]
        passed = False
        if ball_kickable:
            if main == CMD_KICK:
                bx, by, vx, vy = pbx, pby, pvx, pvy
                rx, ry = _me_after(r, s, CMD_KICK, 0.0, kp)  # predictAgentPos(1, 0): coasting
                gone = kickable + cfg.say_pass_margin
                passed = compared_hypot(bx - rx, by - ry, gone) > gone
            if not passed:
                bx, by = s.pos[r, BALL, 0], s.pos[r, BALL, 1]
                vx = vy = 0.0
        talk.said[r, 0] = BALL_INFO_ID
        _put_position(talk, r, 1, sign * bx, sign * by)
        talk.said[r, 3] = encode_velocity(sign * vx)
        talk.said[r, 4] = encode_velocity(sign * vy)
        talk.said[r, 5] = 0 if passed else 1
        at = 6
    first, last = opponent_range(me, n_keepers, s.pos.shape[1] - 1)
    nearest, nearest_d = -1, math.inf
    for obj in range(first, last + 1):
        if s.seen[r, obj] != now:
            continue
        limit = min(kp.visible_distance, nearest_d)
        d = nearer_than(s.pos[r, obj, 0] - s.pos[r, me, 0], s.pos[r, obj, 1] - s.pos[r, me, 1], limit)
        if d < limit:
            nearest, nearest_d = obj, d
    if nearest >= 0:
        talk.said[r, at] = OPP_POS_ID + nearest - first
        _put_position(talk, r, at + 1, sign * s.pos[r, nearest, 0], sign * s.pos[r, nearest, 1])
        talk.said[r, at + 3] = 1
        at += 4
    if at <= MAX_CHARS - UNIT_COST[OUR_POS_ID]:  # my own confidence is always above the C++'s 0.92
        talk.said[r, at] = OUR_POS_ID
        at = _put_position(talk, r, at + 1, sign * mx, sign * my)
    talk.said_len[r] = at


# ---------------------------------------------------------------------------------------------------
# hearing


@borrowing
def _decodes(codes: np.ndarray, n: int) -> bool:
    """``SayMsgDecoder::decodeStr``: the message splits into known units, each complete."""
    if n < 0:
        return False
    at = 0
    while at < n:
        unit = codes[at]
        if unit >= UNIT_COST.shape[0] or UNIT_COST[unit] == 0:
            return False
        at += UNIT_COST[unit]
    return at == n


@borrowing
def _confidence_from_age(cycles: int) -> float:
    """``Object::getConfidenceFromTimeDiff``."""
    return max(0.0, 1.0 - cycles / 100.0)


@borrowing
def _seen_for_confidence(now: int, conf: float) -> int:
    """``WorldModel::getTimeFromConfidence``: the time a confidence dates an object to."""
    return now - int((1.00 - conf) * 100)


@borrowing
def _hear_ball(r: int, s: ModelState, codes: np.ndarray, at: int, sign: float, cfg) -> None:
    """``WMBallInfo::process`` and ``WorldModel::processPerfectHearInfoBall``."""
    px = sign * decode_value(codes[at + 1], X_LOW, X_SPAN)
    py = sign * decode_value(codes[at + 2], Y_LOW, Y_SPAN)
    vx = sign * decode_value(codes[at + 3], V_LOW, V_SPAN)
    vy = sign * decode_value(codes[at + 4], V_LOW, V_SPAN)
    cycles = codes[at + 5]
    for _ in range(cycles):
        px += vx
        py += vy
        vx *= HEARD_BALL_DECAY
        vy *= HEARD_BALL_DECAY
    me, now = s.me[r], s.time[r]
    dx, dy = s.pos[r, BALL, 0] - s.pos[r, me, 0], s.pos[r, BALL, 1] - s.pos[r, me, 1]
    far = compared_hypot(dx, dy, cfg.hear_ball_near) > cfg.hear_ball_near
    gap = cfg.hear_velocity_gap
    differs = compared_hypot(vx - s.vel[r, BALL, 0], vy - s.vel[r, BALL, 1], gap) > gap
    if not (s.seen[r, BALL] == NEVER
            or (s.ball_chg[r] < now - cfg.hear_ball_stale_cycles and far)
            or (s.ball_chg[r] < now - cycles and differs and far)):
        return
    conf = _confidence_from_age(cycles) - 0.01
    if confidence(r, s, BALL) < conf or differs:
        s.pos[r, BALL, 0], s.pos[r, BALL, 1] = px, py
        s.vel[r, BALL, 0], s.vel[r, BALL, 1] = vx, vy
        s.seen[r, BALL] = _seen_for_confidence(now, conf)


@borrowing
def _hear_player(r: int, s: ModelState, obj: int, px: float, py: float, conf: float) -> None:
    """``WorldModel::processPerfectHearInfo`` for a player other than me."""
    if obj == s.me[r] or confidence(r, s, obj) >= conf:
        return
    s.pos[r, obj, 0], s.pos[r, obj, 1] = px, py
    s.vel[r, obj, 0] = s.vel[r, obj, 1] = 0.0
    s.seen[r, obj] = _seen_for_confidence(s.time[r], conf)


@borrowing
def hear_row(r: int, s: ModelState, n_keepers: int, cfg, talk: Talk) -> None:
    """Process row ``r``'s last heard teammate message, once (module docstring); call after the cycle's
    see, before the decision. A message that does not decode is dropped whole, as the C++ drops it."""
    if not talk.heard_new[r]:
        return
    talk.heard_new[r] = False
    codes, n = talk.heard[r], talk.heard_len[r]
    if not _decodes(codes, n):
        return
    me = s.me[r]
    sign = frame_sign(me, n_keepers)
    opp_first, opp_last = opponent_range(me, n_keepers, s.pos.shape[1] - 1)
    mate_first, mate_last = opponent_range(opp_first, n_keepers, s.pos.shape[1] - 1)
    at = 0
    while at < n:
        unit = codes[at]
        if unit == BALL_INFO_ID:
            _hear_ball(r, s, codes, at, sign, cfg)
        elif unit >= OPP_POS_ID:
            mate = unit >= TEAMMATE_POS_ID
            obj = mate_first + unit - TEAMMATE_POS_ID if mate else opp_first + unit - OPP_POS_ID
            if obj <= (mate_last if mate else opp_last):
                conf = _confidence_from_age(codes[at + 3]) - (0.0 if mate else 0.01)
                _hear_player(r, s, obj, sign * decode_value(codes[at + 1], X_LOW, X_SPAN),
                             sign * decode_value(codes[at + 2], Y_LOW, Y_SPAN), conf)
        at += UNIT_COST[unit]


__all__ = [
    "BYTE_CODES",
    "CHAR_BYTES",
    "MAX_CHARS",
    "NUM_CHARS",
    "Talk",
    "VALID_CHARS",
    "decode_value",
    "encode_position",
    "encode_velocity",
    "hear_bytes",
    "hear_row",
    "hear_text",
    "new_talk",
    "say_row",
    "to_text",
]

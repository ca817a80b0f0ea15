"""A Keepaway taker that speaks rcssserver's UDP text protocol only: the standard library, nothing of this
project. It plays on rcssserver as on `keepaway server --rcss-port` (docs/protocol.md §16).

    keepaway server --rcss-port 6000 --takers 1     # prints ... rcss=udp://127.0.0.1:6000
    keepaway player --team keepers                  # three times
    python examples/rcss_text_taker.py --port 6000 --version 12

It sends `(init takers (version V))` (any version 8-19), then talks to the port the reply came from, as
rcssserver's clients do from version 8 on. It keeps the last ball it saw (`((b) DIST DIR ...)` in a
`see`, the direction relative to its head) and its neck angle (`head_angle` of `sense_body`), and acts
once a cycle: on `(think)` in synchronous mode, ending with `(done)`; on `sense_body` in real-time mode.
It turns towards the ball when it is more than 10 degrees off the body, dashes at it otherwise, stands
still next to it, turns to look for it when it has seen none; a cycle without a new `see` it dashes on
if it was dashing, else waits (a turn on a stale direction would overshoot). It exits 0 after `--cycles` cycles, or when
the server has been silent for 10 s.
"""

from __future__ import annotations

import argparse
import re
import socket
import sys

SILENCE_S = 10.0
AIM_DEG = 10.0
NEAR_M = 0.8
BALL = re.compile(r"\(\(b\) ([-\d.e]+) ([-\d.e]+)")
HEAD_ANGLE = re.compile(r"\(head_angle ([-\d.e]+)\)")
TIME = re.compile(r"^\((?:sense_body|see) (\d+)")


def decide(ball: tuple[float, float] | None, neck: float, fresh: bool, last: str) -> str:
    """The cycle's command from the last ball seen (distance, direction relative to the head), the neck
    angle (relative to the body), whether that see is new since the last command, and the last command."""
    if not fresh:
        return last if last == "(dash 100)" else "(turn 0)"
    if ball is None:
        return "(turn 60)"
    dist, to_ball = ball[0], ball[1] + neck
    if dist < NEAR_M:
        return "(turn 0)"
    if abs(to_ball) > AIM_DEG:
        return f"(turn {to_ball:g})"
    return "(dash 100)"


def play(host: str, port: int, team: str, version: float, cycles: int) -> int:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.settimeout(SILENCE_S)
    sock.sendto(f"(init {team} (version {version:g}))\0".encode(), (host, port))
    reply, server = sock.recvfrom(8192)
    if not reply.startswith(b"(init "):
        print(f"rcss_text_taker: refused: {reply.rstrip(bytes(1)).decode(errors='replace')}", file=sys.stderr)
        return 2
    synchronous = True
    ball: tuple[float, float] | None = None
    neck, last_time, acted = 0.0, -1, 0
    fresh, last = False, ""
    while acted < cycles:
        try:
            data, server = sock.recvfrom(8192)
        except TimeoutError:
            return 0
        text = data.rstrip(bytes(1)).decode(errors="replace")
        if text.startswith("(server_param"):
            synchronous = "(synch_mode 1)" in text or "(synch_mode true)" in text
        time_match = TIME.match(text)
        if time_match:
            last_time = int(time_match.group(1))
        if text.startswith("(see"):
            found = BALL.search(text)
            ball = None if found is None else (float(found.group(1)), float(found.group(2)))
            fresh = True
        elif text.startswith("(sense_body"):
            neck = float(HEAD_ANGLE.search(text).group(1))
            if not synchronous and last_time > 0:
                last, fresh = decide(ball, neck, fresh, last), False
                sock.sendto(f"{last}\0".encode(), server)
                acted += 1
        elif text.startswith("(think") and synchronous:
            last, fresh = decide(ball, neck, fresh, last), False
            sock.sendto(f"{last}\0".encode(), server)
            sock.sendto(b"(done)\0", server)
            acted += last_time > 0
    sock.sendto(b"(bye)\0", server)
    return 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=6000)
    parser.add_argument("--team", default="takers")
    parser.add_argument("--version", type=float, default=19.0)
    parser.add_argument("--cycles", type=int, default=1_000_000, help="stop after this many cycles played")
    args = parser.parse_args()
    sys.exit(play(args.host, args.port, args.team, args.version, args.cycles))


if __name__ == "__main__":
    main()

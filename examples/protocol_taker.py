"""A Keepaway taker written from docs/protocol.md alone: pyzmq and msgpack, nothing of this project.

    keepaway server --players-port 0          # prints players=tcp://127.0.0.1:PORT ...
    keepaway player --team keepers --server tcp://127.0.0.1:PORT    # three times
    keepaway player --team takers --server tcp://127.0.0.1:PORT     # once
    python examples/protocol_taker.py --server tcp://127.0.0.1:PORT

It joins as a taker (`init`), keeps the last ball it saw (`see`: distance and direction relative to its
head) and its neck angle (`sense_body`), and answers every `think` with one `command`: turn towards the
ball when it is more than 10 degrees off the body, dash at it otherwise, stand still next to it (the
referee counts a taker within the kickable distance towards a take, docs/rules.md §7), turn to look
for it when it has seen none. It ignores `hear`, `waiting` and any message type it does not know (the
protocol's version rule), and exits 0 on `shutdown`. A template for an agent in any language: the same
messages over a ZeroMQ DEALER socket, one msgpack map per frame.
"""

from __future__ import annotations

import argparse
import sys

import msgpack
import zmq

PROTOCOL_VERSION = 1
SILENCE_S = 30.0  # the server sends something at least every second (a `waiting` before the kick-off)
AIM_DEG = 10.0  # dash once the ball is this close to straight ahead
NEAR_M = 0.8  # stand still this close to the ball: within the kickable distance (1.085 m), with a margin


def decide(ball: list | None, neck_deg: int) -> list:
    """The cycle's atomic command from the last ball seen (``[dist, dir, ...]``, ``dir`` relative to the
    head, or None) and the neck angle (relative to the body)."""
    if ball is None:
        return ["turn", 60.0]
    dist, to_ball = ball[0], ball[1] + neck_deg  # relative to the body: the head is body + neck
    if dist < NEAR_M:
        return ["turn", 0.0]
    if abs(to_ball) > AIM_DEG:
        return ["turn", float(to_ball)]
    return ["dash", 100.0]


def play(endpoint: str) -> int:
    """Join the server at ``endpoint`` as a taker and play until it shuts down; the exit code."""
    sock = zmq.Context.instance().socket(zmq.DEALER)
    sock.setsockopt(zmq.LINGER, 0)
    sock.connect(endpoint)
    send = lambda message: sock.send(msgpack.packb(message))  # noqa: E731
    send({"type": "init", "version": PROTOCOL_VERSION, "team": "takers", "client": "protocol-taker"})
    joined, ball, neck, thinks = False, None, 0, 0
    while True:
        if not sock.poll(int(SILENCE_S * 1000)):
            print(f"protocol-taker: nothing from {endpoint} for {SILENCE_S:g} s; giving up", file=sys.stderr)
            return 4
        message = msgpack.unpackb(sock.recv(), raw=False)
        kind = message.get("type")
        if kind == "init_ok":
            joined = True
            print(f"protocol-taker: joined as taker {message['unum']} ({message['play_mode']})", flush=True)
        elif kind == "error":
            print(f"protocol-taker: {message['code']}: {message['message']}", file=sys.stderr)
            if not joined:
                return 2
        elif kind == "sense_body":
            neck = message["head_angle"]
        elif kind == "see":
            ball = message["ball"] if message["ball"] is not None else ball
        elif kind == "hear" and message["sender"] == "referee" and message["message"].startswith("training"):
            ball = None  # an episode ended: the field is reset, the ball seen before is elsewhere
        elif kind == "think":
            send({"type": "command", "cycle": message["cycle"], "commands": [decide(ball, neck)]})
            thinks += 1
        elif kind == "shutdown":
            print(f"protocol-taker: the server shut down ({message['reason']}) after {thinks} cycles", flush=True)
            return 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--server", default="tcp://127.0.0.1:6000", help="the server's players endpoint")
    sys.exit(play(parser.parse_args().server))


if __name__ == "__main__":
    main()

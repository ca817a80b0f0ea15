"""The object layout and command codes that the server's kernels and the players' kernels share.

Object 0 of every arena is the ball; objects 1..K are the keepers (left side, uniform numbers 1..K) and
objects K+1..K+T the takers (right side, uniform numbers 1..T). A player's main command (one per cycle:
the shared dash/turn/kick/tackle/move/catch slot) travels between kernels as one of these codes. Also
here: the one rule of rcssserver's physics that the players' world model copies.
"""

BALL = 0

CMD_NONE = 0
CMD_DASH = 1
CMD_TURN = 2
CMD_KICK = 3
CMD_TACKLE = 4
CMD_MOVE = 5
CMD_CATCH = 6

# A colliding object's velocity is multiplied by this (rcssserver MPObject::updateCollisionVel); the
# players' world model does the same to the ball when it guesses a collision (agents/tracking.py).
COLLISION_VEL_FACTOR = -0.1

__all__ = ["BALL", "CMD_CATCH", "CMD_DASH", "CMD_KICK", "CMD_MOVE", "CMD_NONE", "CMD_TACKLE", "CMD_TURN",
           "COLLISION_VEL_FACTOR"]

"""The field's landmarks: the 55 flags and goals and the four lines every ``see`` refers to.

rcssserver (11+) builds the same table from its default landmark file (``landmarkreader.cpp``) and sends
flags in this order; the server sends the table to every client in ``init_ok``, so a flag id on the wire
is an index into :data:`FLAGS`. Coordinates are rcssserver's global frame (docs/protocol.md §4):
origin at the centre, +x towards the right goal, +y towards the *bottom* touch line, so the ``t`` flags
lie at y = -39.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# rcssserver's fixed field geometry (ServerParam::PITCH_*; goal flags at half the 14.02 m goal width;
# penalty area 16.5 m deep and 40.32 m wide; outer flags 5 m outside the lines).
PITCH_HALF_LENGTH = 52.5
PITCH_HALF_WIDTH = 34.0
GOAL_FLAG_Y = 7.01
PENALTY_AREA_X = 36.0
PENALTY_AREA_HALF_WIDTH = 20.16
OUTER_FLAG_X = 57.5
OUTER_FLAG_Y = 39.0


@dataclass(frozen=True)
class Landmark:
    """A named point (flag or goal) or line. For a line, ``x``/``y`` locate it: a vertical line has its
    x and y = 0, a horizontal one x = 0 and its y."""

    name: str
    x: float
    y: float


def _flags() -> tuple[Landmark, ...]:
    L, W = PITCH_HALF_LENGTH, PITCH_HALF_WIDTH
    flags = [
        Landmark("f c", 0.0, 0.0),
        Landmark("f c t", 0.0, -W),
        Landmark("f c b", 0.0, W),
        Landmark("f r t", L, -W),
        Landmark("f r b", L, W),
        Landmark("f l t", -L, -W),
        Landmark("f l b", -L, W),
        Landmark("f g r b", L, GOAL_FLAG_Y),
        Landmark("g r", L, 0.0),
        Landmark("f g r t", L, -GOAL_FLAG_Y),
        Landmark("f g l b", -L, GOAL_FLAG_Y),
        Landmark("g l", -L, 0.0),
        Landmark("f g l t", -L, -GOAL_FLAG_Y),
        Landmark("f p r b", PENALTY_AREA_X, PENALTY_AREA_HALF_WIDTH),
        Landmark("f p r c", PENALTY_AREA_X, 0.0),
        Landmark("f p r t", PENALTY_AREA_X, -PENALTY_AREA_HALF_WIDTH),
        Landmark("f p l b", -PENALTY_AREA_X, PENALTY_AREA_HALF_WIDTH),
        Landmark("f p l c", -PENALTY_AREA_X, 0.0),
        Landmark("f p l t", -PENALTY_AREA_X, -PENALTY_AREA_HALF_WIDTH),
    ]
    for edge, y in (("t", -OUTER_FLAG_Y), ("b", OUTER_FLAG_Y)):
        flags.append(Landmark(f"f {edge} 0", 0.0, y))
        for side, sign in (("r", 1.0), ("l", -1.0)):
            flags.extend(Landmark(f"f {edge} {side} {m}", sign * m, y) for m in range(10, 60, 10))
    for side, x in (("r", OUTER_FLAG_X), ("l", -OUTER_FLAG_X)):
        flags.append(Landmark(f"f {side} 0", x, 0.0))
        for edge, sign in (("t", -1.0), ("b", 1.0)):
            flags.extend(Landmark(f"f {side} {edge} {m}", x, sign * m) for m in range(10, 40, 10))
    return tuple(flags)


FLAGS: tuple[Landmark, ...] = _flags()
"""Flags and goals in rcssserver's sending order; a flag's id is its index."""

LINES: tuple[Landmark, ...] = (
    Landmark("l l", -PITCH_HALF_LENGTH, 0.0),
    Landmark("l r", PITCH_HALF_LENGTH, 0.0),
    Landmark("l t", 0.0, -PITCH_HALF_WIDTH),
    Landmark("l b", 0.0, PITCH_HALF_WIDTH),
)
"""The four pitch lines in rcssserver's sending order; a line's id is its index."""

LINE_LEFT, LINE_RIGHT, LINE_TOP, LINE_BOTTOM = range(4)

FLAG_INDEX: dict[str, int] = {flag.name: i for i, flag in enumerate(FLAGS)}
LINE_INDEX: dict[str, int] = {line.name: i for i, line in enumerate(LINES)}

FLAG_POSITIONS: np.ndarray = np.array([(f.x, f.y) for f in FLAGS], dtype=np.float64)
"""(n_flags, 2) global positions, the form perception kernels take."""
FLAG_POSITIONS.setflags(write=False)

N_FLAGS = len(FLAGS)
N_LINES = len(LINES)


def to_wire() -> dict[str, list]:
    """The table as sent in ``init_ok``: names and positions, ids implied by the order."""
    return {
        "flags": [[f.name, f.x, f.y] for f in FLAGS],
        "lines": [[line.name, line.x, line.y] for line in LINES],
    }


__all__ = [
    "FLAGS",
    "FLAG_INDEX",
    "FLAG_POSITIONS",
    "LINES",
    "LINE_BOTTOM",
    "LINE_INDEX",
    "LINE_LEFT",
    "LINE_RIGHT",
    "LINE_TOP",
    "Landmark",
    "N_FLAGS",
    "N_LINES",
    "to_wire",
]

"""Randomly corrupted frames, for the tests of the kernels that read frames straight from their bytes
(``test_see_frame.py``, ``test_player_frames.py``, ``test_command_frame.py``): each checks that what its
kernel takes of them the full decoder takes alike."""

from __future__ import annotations

import random
from collections.abc import Iterator, Sequence


def mutated_frames(frames: Sequence[bytes], count: int, most_changes: int, seed: int) -> Iterator[bytes]:
    """``count`` frames, each one of ``frames`` (drawn at random) with 1 to ``most_changes`` of its bytes
    set to random values, from the stream seeded ``seed``."""
    rng = random.Random(seed)
    for _ in range(count):
        frame = bytearray(rng.choice(frames))
        for _ in range(rng.randint(1, most_changes)):
            frame[rng.randrange(len(frame))] = rng.randrange(256)
        yield bytes(frame)

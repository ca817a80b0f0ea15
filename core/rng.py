"""Counter-based random numbers for the kernels: one splitmix64 stream per arena.

All server randomness (movement/kick/turn noise, perception identity loss, reset placement, the object
shuffle) flows from one seed (spec `architecture.md`, Determinism). Each arena of a batch owns one
uint64 state, so a batch of arenas draws exactly what the same arenas would draw one at a time.
"""

from __future__ import annotations

import numpy as np
from keepaway.core.jit import njit

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_TO_UNIT = 1.0 / 9007199254740992.0  # 2**-53


@njit(cache=True, inline="always")
def next_u64(rng: np.ndarray, b: int) -> np.uint64:
    """Advance arena ``b``'s stream and return 64 random bits (splitmix64)."""
    rng[b] = rng[b] + _GOLDEN
    z = rng[b]
    z = (z ^ (z >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    return z ^ (z >> _S31)


@njit(cache=True, inline="always")
def uniform(rng: np.ndarray, b: int, low: float, high: float) -> float:
    """U(low, high) from arena ``b``'s stream (53-bit resolution)."""
    return low + (high - low) * (float(next_u64(rng, b) >> _S11) * _TO_UNIT)


@njit(cache=True, inline="always")
def randint(rng: np.ndarray, b: int, n: int) -> int:
    """Uniform integer in [0, n) from arena ``b``'s stream."""
    return min(int(uniform(rng, b, 0.0, 1.0) * n), n - 1)


def seed_streams(seed: int, batch: int) -> np.ndarray:
    """One independent uint64 state per arena, derived from ``seed`` (arena b gets seed's b-th child)."""
    seq = np.random.SeedSequence(int(seed))
    states = seq.generate_state(batch, dtype=np.uint64)
    return np.asarray(states, dtype=np.uint64).reshape(batch)


__all__ = ["next_u64", "randint", "seed_streams", "uniform"]

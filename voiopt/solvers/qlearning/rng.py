"""splitmix64: the random numbers of Algorithm 1, the same stream in the kernel and in the
plain-Python reference (reference.py), so the two can be compared bit for bit."""

from __future__ import annotations

import numpy as np

from voiopt.runtime.jit import njit

_M64 = (1 << 64) - 1
GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
TWO_M53 = 1.0 / 9007199254740992.0


@njit(cache=True, inline="always")
def mix(z):
    z = (z ^ (z >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    return z ^ (z >> _S31)


@njit(cache=True, inline="always")
def draw(state):
    """The next uniform in [0, 1) of the stream: (the advanced state, the number)."""
    state += GOLDEN
    return state, float(mix(state) >> S11) * TWO_M53


def seed_state(seed: int) -> int:
    """The splitmix64 state for a user seed (the seed itself, as an unsigned 64-bit word)."""
    return int(seed) & _M64

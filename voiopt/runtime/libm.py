"""libm's log, log1p, exp and expm1 of every element of a large array, compiled.

physics takes its logarithms and exponentials from libm, element by element, so that a plan
simulates to the same bits on every machine (numpy's SIMD versions differ in the last bit).
Through Python's ``math`` that costs a few hundred nanoseconds an element: valuing a plan of
T = 10^6 slots took 4 to 5 s, after the stop rule had fired. A numba kernel calls the same
libm functions (numba lowers ``math.log`` to a call of the C library's ``log``, and with no
vector library, which numba sets up only when Intel's SVML is installed, the calls stay
scalar) for about 20 ns an element, with the edge cases of physics' wrappers: the same bits
(tests/test_physics.py). physics sends only large arrays here (``physics.COMPILED_FROM``), so
that commands that never load numba do not start it for a few thousand elements.
"""

from __future__ import annotations

import math

import numpy as np

from voiopt.runtime.jit import USING_SVML, njit

LOG, LOG1P, EXP, EXPM1 = 0, 1, 2, 3
ready = False  # whether _apply is loaded in this process


@njit(cache=True, nogil=True)
def _apply(code, x, out):
    for i in range(x.size):
        v = x[i]
        if code == LOG:
            out[i] = math.log(v) if v > 0 else (-math.inf if v == 0 else math.nan)
        elif code == LOG1P:
            if v > -1:
                out[i] = v if v == 0 else math.log1p(v)  # Python's log1p keeps the sign of a zero
            else:
                out[i] = -math.inf if v == -1 else math.nan
        elif code == EXP:
            out[i] = math.exp(v)
        else:
            out[i] = math.expm1(v)


def apply(code: int, a: np.ndarray) -> np.ndarray | None:
    """libm's function ``code`` (LOG, LOG1P, EXP or EXPM1) of every element of float array a;
    None where numba uses Intel's SVML (its vectorised log and exp are not libm's bits)."""
    if USING_SVML:
        return None
    global ready
    from voiopt.runtime import numba_start

    numba_start.start()
    flat = np.ascontiguousarray(a, dtype=float).reshape(-1)
    out = np.empty(flat.size)
    _apply(code, flat, out)
    ready = True
    return out.reshape(a.shape)

"""numba's first start in a `voiopt` command, without its BLAS check.

The first time a process compiles or loads a numba kernel, numba initialises its CPU target,
and `numba.np.arraymath` imports `scipy.linalg.cython_blas` to learn whether `np.dot` and
`np.linalg` can be compiled. That import is 0.2 to 0.3 s of a `voiopt solve`'s start-up,
mostly scipy.linalg importing its array-API layer (which touches numpy.f2py and
numpy.testing). voiopt's kernels use no BLAS. So the command line, which runs voiopt's kernels
alone, sets ``QUICK``, and the kernels' warm-ups call ``start()`` first: it initialises numba
by loading a trivial kernel while scipy.linalg is hidden, so the check finds no BLAS at no
cost; scipy.linalg imports normally afterwards. The library leaves numba as it is, because a
user's own kernels in the same process may need BLAS.
"""

from __future__ import annotations

import sys

QUICK = False  # set by the command line (voiopt.cli.main.run), which imports this module but not numba
_started = False


def _first(x: int) -> int:  # compiled by start(): numba is imported only by commands that use it
    return x + 1


def start() -> None:
    """Initialise numba (once per process): without its BLAS check if QUICK and scipy.linalg
    has not been imported yet, else as numba does by itself."""
    global _started
    if _started:
        return
    import numba as nb

    hide = QUICK and "numba.np.arraymath" not in sys.modules and "scipy.linalg" not in sys.modules
    if hide:
        sys.modules["scipy.linalg"] = None  # an ImportError for it and its submodules
    try:
        nb.njit(cache=True)(_first)(1)
        _started = True
    finally:
        if hide and "scipy.linalg" in sys.modules and sys.modules["scipy.linalg"] is None:
            del sys.modules["scipy.linalg"]

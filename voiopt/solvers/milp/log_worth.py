"""The worths of ``min-voi`` as natural logarithms, for an exported model other solvers resolve.

``min-voi`` maximises min over (i, t) of V_i(t). The logarithm is increasing, so
max min ln V = ln max min V, and the single-z epigraph on ln V is the same problem: the same
optimal plans, its optimum the logarithm of the optimum. Where V spans 1e-20 .. 1e7 bit/s the
bit/s model asks a solver to tell 1e-20 from 0 under absolute tolerances of 1e-6 (it cannot:
issue 47); in nats the same worths span about -46 .. 16, every coefficient of the worth rows is
a log-ratio of two worths (within ln(1e308 / 1e-308) = 1418), and a solver's absolute tolerance
eps becomes a relative error of about eps in V.

Levels and their telescoping increments keep their meaning (solvers/milp/formulation.py): the
increment of level l is ln w_l(t) - ln w_(l-1)(t), so the worth row of (i, t) sums to
ln w_best(t), and H below its indicator only lowers it; the epigraph is exact for integral x, y.

Precision: the lookup values are the simulator's own V (``physics.voi``) through ``np.log``,
exact to 1e-15 relative. A V of 0 (underflow: a stale packet of a small rho) and subnormal
V are written as ln of the smallest normal double, LOG_FLOOR = -708.4, so worths below 2.2e-308
bit/s are one value to the model. Level increments below a solver's smallest matrix entry
(HiGHS: 1e-9) may be dropped by it, which undervalues that level by less than 1e-9 relative.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from voiopt.objectives import Worth
from voiopt.solvers.milp.uploads import Structure

TINY = float(np.finfo(float).tiny)  # smallest normal double: V below it is one value
LOG_FLOOR = math.log(TINY)


def log_of(worth: np.ndarray) -> np.ndarray:
    """ln V, V clipped below at TINY; nan (a level not yet reachable) stays nan."""
    w = np.asarray(worth, dtype=float)
    with np.errstate(invalid="ignore"):
        return np.where(np.isnan(w), np.nan, np.log(np.maximum(w, TINY)))


def log_view(st: Structure) -> Structure:
    """``st`` with every worth (the initial packets' and the levels') replaced by its natural
    logarithm: caps, floors and level increments built from it are those of ln V, because
    the logarithm preserves every comparison, minimum and maximum."""
    if st.kind != Worth.VOI:
        raise ValueError(f"log worths exist for VoI, not {st.kind}")
    return dataclasses.replace(st, worth0=log_of(st.worth0), level_worth=[log_of(w) for w in st.level_worth])

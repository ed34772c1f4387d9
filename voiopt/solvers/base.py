"""What every solver shares: the checks of the common options (time_limit in seconds,
memory_limit in GB, seed, threads), the Incumbent, the best simulated plan so far, and the
once-per-process warm-up of a solver's kernels.

A solver is a function ``solve(instance, objective, *, progress=False, <options>) -> Result``
registered in solvers/__init__.py. It stops by the rule of voiopt.runtime.stop and returns its
incumbent; the Result's value is always the simulator's.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.plan import Plan
from voiopt.core.simulate import simulate_indices
from voiopt.errors import MemoryLimitError, OptionError
from voiopt.grid import lattice as lattice_mod
from voiopt.runtime.stop import GB, starting

DP_MAX_ROBOTS = 2  # dp plans jointly for at most this many robots
DEFAULT_MEMORY_GB = 4.0  # every method's memory limit unless told otherwise


def _number(v) -> bool:
    return not isinstance(v, bool) and isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(v)


def check_limits(time_limit: float | None, memory_limit: float | None) -> None:
    if time_limit is not None and not (_number(time_limit) and time_limit > 0):
        raise OptionError(f"--time-limit: must be a number of seconds > 0, got {time_limit!r}")
    if memory_limit is not None and not (_number(memory_limit) and memory_limit > 0):
        raise OptionError(f"--memory-limit: must be a number of GB > 0, got {memory_limit!r}")


MAX_THREADS = 256  # far past any machine's use here; HiGHS refuses >= 2**31 and misbehaves at 1e5 (over its limit)


def check_threads(threads: int | None) -> None:
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))
                                or not 1 <= threads <= MAX_THREADS):
        raise OptionError(f"--threads: must be an integer from 1 to {MAX_THREADS}, got {threads!r}")


def require_memory(nbytes: float, memory_limit: float | None, what: str) -> None:
    """Refuse, before allocating, work whose tables alone would pass the memory limit: there is
    no plan yet to return, so this is a one-line error (exit 2), not a status."""
    if memory_limit is not None and nbytes > memory_limit * GB:
        raise MemoryLimitError(
            f"--memory-limit: {what} need about {nbytes / GB:.3g} GB, over the limit of {memory_limit:g} GB "
            "(raise --memory-limit, or make the instance smaller)"
        )


def lattice_bytes(instance: Instance) -> float:
    """The size of the lattice tables every method builds: distances and ranges per sensor
    and point (lattice.build)."""
    n = lattice_mod.n_points(instance)
    return instance.n_sensors * n * 9.0 + n * 100.0


def points_in_range(instance: Instance) -> float:
    """An upper bound on the lattice points within d_th of one sensor (no lattice needed): at
    most the lattice's points, however large d_th (a review found dp refusing the case study,
    28.5 GB, at d_th = 1000, though any d_th past the area's diagonal is the same network)."""
    return min((2.0 * instance.channel.d_th / instance.step + 2.0) ** 2, float(lattice_mod.n_points(instance)))


class Incumbent:
    """The best plan offered so far, by its simulated value (never a solver's own number)."""

    def __init__(self, instance: Instance, objective: str) -> None:
        self.instance = instance
        self.objective = objective
        self.idx: np.ndarray | None = None
        self.sched: np.ndarray | None = None
        self.value: float | None = None
        self.source: str | None = None
        self.offers: list[tuple[str, float]] = []  # (source, simulated value) of every offer

    def offer(self, idx, sched, source: str) -> float:
        """Simulate a plan given as point indices and schedule (-1 = none); keep it if it is
        strictly better. Returns its simulated value."""
        idx, sched = np.asarray(idx, np.int64), np.asarray(sched, np.int64)
        value = simulate_indices(self.instance, idx, sched).metrics[self.objective]
        self.offers.append((source, value))
        if self.value is None or objectives.better(self.objective, value, self.value):
            self.idx, self.sched, self.value, self.source = idx, sched, value, source
        return value

    @property
    def plan(self) -> Plan | None:
        return None if self.idx is None else Plan.from_indices(self.instance, self.idx, self.sched)


_WARM: set[str] = set()  # the families of kernels warmed up in this process


def warm_up_once(family: str, load: Callable[[], object]) -> float:
    """Compile (or load from numba's cache) a family of kernels once per process, by ``load()``
    running them on a tiny instance, so that a solve's runtime_s and time limit measure the
    work alone; returns the seconds this took (0 when already done). The family counts as warm
    from the start, so that ``load`` may call the very solver it warms up."""
    if family in _WARM:
        return 0.0
    _WARM.add(family)
    from voiopt.runtime import numba_start

    t0 = time.perf_counter()
    with starting():  # a Ctrl-C now stops the solve that is starting, not only the warm-up's
        numba_start.start()
        load()
    return time.perf_counter() - t0


def idle_plan(instance: Instance) -> Plan:
    """The plan of a solver stopped before it has one: no uploads, the fewest moves to end (or
    staying where there is none). It keeps every rule of MODEL.md section 9."""
    lat = lattice_mod.build(instance)
    T = instance.horizon
    return Plan.from_indices(instance, [lat.start, *lat.walk_home(lat.start, T - 1)], np.full(T, -1))

"""One stop rule for every solver, sweep and figure run: a time limit, a memory limit, or a
request by Ctrl-C or SIGTERM. Long work calls ``stop.check()`` at safe points and, once it
says why, returns its best plan and proven bound with that reason as the status."""

from __future__ import annotations

import signal
import threading
import time
from contextlib import contextmanager

TIME_LIMIT, MEMORY_LIMIT, INTERRUPTED = "time_limit", "memory_limit", "interrupted"
GB = 1e9  # memory limits are given in GB (10^9 bytes) everywhere


class Stop:
    """Why a run must stop now, if it must: ``reason`` is None, or one of the three statuses."""

    def __init__(self, time_limit: float | None = None, memory_limit: float | None = None) -> None:
        self.t0 = time.perf_counter()
        self.time_limit = time_limit
        self.memory_limit = memory_limit
        self.deadline = None if time_limit is None else self.t0 + float(time_limit)
        self.memory_bytes = None if memory_limit is None else float(memory_limit) * GB
        self.reason: str | None = None
        self.signal: int | None = None  # the signal that asked to stop, if one did

    @property
    def requested(self) -> bool:
        return self.reason is not None

    def request(self, reason: str = INTERRUPTED, signum: int | None = None) -> None:
        if self.reason is None:
            self.reason = reason
            self.signal = signum

    def elapsed(self) -> float:
        return time.perf_counter() - self.t0

    def remaining(self) -> float | None:
        """Seconds left before the time limit (None: no limit)."""
        return None if self.deadline is None else self.deadline - time.perf_counter()

    def fits(self, nbytes: float) -> bool:
        """Does holding ``nbytes`` stay within the memory limit?"""
        return self.memory_bytes is None or nbytes <= self.memory_bytes

    def check(self, memory_used: float = 0.0) -> str | None:
        """The reason to stop now (and remember it), or None to go on."""
        if self.reason is None:
            if self.deadline is not None and time.perf_counter() >= self.deadline:
                self.reason = TIME_LIMIT
            elif not self.fits(memory_used):
                self.reason = MEMORY_LIMIT
        return self.reason

    def describe(self) -> str:
        """One line on why the run stopped, for ``solver.stopped``."""
        if self.reason == TIME_LIMIT:
            return f"time limit of {self.time_limit:g} s reached"
        if self.reason == MEMORY_LIMIT:
            return f"memory limit of {self.memory_limit:g} GB reached"
        if self.reason == INTERRUPTED:
            name = signal.Signals(self.signal).name if self.signal else "a stop request"
            return f"interrupted by {name}"
        return "not stopped"


@contextmanager
def watch(time_limit: float | None = None, memory_limit: float | None = None, stop: Stop | None = None):
    """A Stop for the block. In the main thread the first Ctrl-C or SIGTERM requests the stop;
    a second one raises KeyboardInterrupt at once. Elsewhere (worker threads) signals cannot
    be caught and only the limits apply. An enclosing watch may pass its own ``stop``."""
    stop = stop or Stop(time_limit, memory_limit)
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}

    def handler(signum, frame):
        if stop.reason == INTERRUPTED:
            for s, h in previous.items():
                signal.signal(s, h)
            raise KeyboardInterrupt
        stop.request(INTERRUPTED, signum)

    for s in previous:
        signal.signal(s, handler)
    try:
        yield stop
    finally:
        for s, h in previous.items():
            signal.signal(s, h)

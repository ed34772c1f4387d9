"""Back memory before it is first written, on another core.

The first write to a page of a fresh allocation stops the writing thread while the OS (and, on a
virtual machine, the host) finds a page for it: on the 2-core VM voiopt is measured on, about
0.5 to 1.7 ms per MB. A growing Q-table writes hundreds of MB that way. ``populate`` asks Linux
(``madvise(MADV_POPULATE_WRITE)``, kernel 5.14 or later) to back a range in a background
thread instead, while the kernel works on. Populating never changes what the memory holds, so
it may run while the range is being read and written. Where it is not available (another OS,
an older kernel) it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import queue
import sys
import threading

import numpy as np

MADV_POPULATE_WRITE = 23
PAGE = 4096
PIECE = 8 << 20  # bytes per madvise call: a job can be cancelled between pieces

_libc = None
_jobs: queue.SimpleQueue | None = None
_lock = threading.Lock()


def _madvise():
    """libc's madvise, or None where populating is not supported."""
    global _libc
    if _libc is None:
        _libc = False
        if sys.platform.startswith("linux"):
            try:
                libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
                libc.madvise.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int)
                probe = np.empty(2 * PAGE, np.uint8)
                start = -probe.ctypes.data % PAGE + probe.ctypes.data
                if libc.madvise(start, PAGE, MADV_POPULATE_WRITE) == 0:
                    _libc = libc.madvise
            except (OSError, AttributeError):
                pass
    return _libc or None


class Job:
    """A range scheduled for backing; ``cancel()`` stops it between pieces and lets go of its array."""

    def __init__(self, owner: np.ndarray, start: int, end: int) -> None:
        self.owner, self.start, self.end = owner, start, end
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True


def _worker(jobs: queue.SimpleQueue) -> None:
    madvise = _madvise()
    while True:
        job = jobs.get()
        if isinstance(job, threading.Event):  # flush()
            job.set()
            continue
        while job.start < job.end and not job.cancelled:
            n = min(PIECE, job.end - job.start)
            if madvise(job.start, n, MADV_POPULATE_WRITE) != 0:  # out of memory: the pages are backed on first write
                break
            job.start += n
        job.owner = None
        del job


def populate(array: np.ndarray, first: int = 0, last: int | None = None) -> Job | None:
    """Back the pages of ``array.reshape(-1)[first:last]`` in a background thread; returns the
    job (None if nothing was scheduled). ``array`` must be contiguous; the job holds it until it
    is done or cancelled."""
    if _madvise() is None or not array.flags.c_contiguous:
        return None
    flat = array.reshape(-1)
    last = len(flat) if last is None else min(last, len(flat))
    start = flat.ctypes.data + max(first, 0) * flat.itemsize
    end = flat.ctypes.data + last * flat.itemsize
    start += -start % PAGE  # whole pages inside the range only
    end -= end % PAGE
    if end <= start:
        return None
    job = Job(array, start, end)
    _queue().put(job)
    return job


def flush(timeout: float | None = None) -> bool:
    """Wait until every range scheduled so far is backed (or given up); False on timeout."""
    if _madvise() is None:
        return True
    done = threading.Event()
    _queue().put(done)
    return done.wait(timeout)


def _forget_thread() -> None:
    """In a forked child, which has no copy of the thread: start a new one on first use."""
    global _jobs, _lock
    _jobs, _lock = None, threading.Lock()


os.register_at_fork(after_in_child=_forget_thread)


def _queue() -> queue.SimpleQueue:
    """The background thread's jobs, starting the thread on first use."""
    global _jobs
    with _lock:
        if _jobs is None:
            _jobs = queue.SimpleQueue()
            threading.Thread(target=_worker, args=(_jobs,), name="voiopt-prefault", daemon=True).start()
    return _jobs

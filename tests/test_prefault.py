"""voiopt/prefault.py: memory backed in a background thread, its contents untouched."""

from __future__ import annotations

import multiprocessing
import platform
import sys
import threading

import numpy as np
import pytest

from voiopt.solvers.qlearning import prefault

MB = 1 << 20


def _kernel_version() -> tuple[int, int]:
    parts = platform.release().split(".")
    return int(parts[0]), int("".join(c for c in parts[1] if c.isdigit()) or 0)


SUPPORTED = sys.platform.startswith("linux") and _kernel_version() >= (5, 14)


def _thread_faults() -> int:
    """Minor page faults of the calling thread so far (Linux)."""
    with open(f"/proc/self/task/{threading.get_native_id()}/stat") as f:
        return int(f.read().rsplit(")", 1)[1].split()[7])


def test_available_where_linux_has_it():
    assert (prefault._madvise() is not None) == SUPPORTED


@pytest.mark.skipif(not SUPPORTED, reason="MADV_POPULATE_WRITE needs Linux 5.14 or later")
def test_backed_pages_are_written_without_faults():
    fresh = np.empty(64 * MB // 8)  # a fresh mapping: no page backed yet
    assert prefault.populate(fresh)
    assert prefault.flush(30)
    before = _thread_faults()
    fresh[::512] = 1.0  # one write per page
    backed_faults = _thread_faults() - before

    control = np.empty(64 * MB // 8)
    before = _thread_faults()
    control[::512] = 1.0
    control_faults = _thread_faults() - before
    # numpy asks for huge pages on large arrays: 32 faults of 2 MiB each, or 16384 of 4 KiB
    assert control_faults >= 32  # the measure sees first writes...
    assert backed_faults <= control_faults / 8  # ...and populate spared almost all of them


def test_contents_unchanged_while_written():
    """Populating never changes memory, even a range being written at the same time."""
    a = np.empty(32 * MB // 8)
    b = np.zeros(32 * MB // 8)
    prefault.populate(a)
    prefault.populate(b)
    a[:] = np.arange(len(a), dtype=np.float64)  # written while the thread may be populating it
    assert prefault.flush(30)
    assert np.array_equal(a, np.arange(len(a), dtype=np.float64))
    assert not b.any()


def test_refuses_what_it_cannot_populate():
    assert not prefault.populate(np.zeros(8))  # less than a page
    assert not prefault.populate(np.zeros((1024, 1024))[:, ::2])  # not contiguous
    assert not prefault.populate(np.zeros(4 * MB // 8), 10, 10)  # an empty range


def _child(out):
    a = np.empty(8 * MB // 8)
    prefault.populate(a)
    out.put(prefault.flush(10))


@pytest.mark.skipif(not SUPPORTED, reason="MADV_POPULATE_WRITE needs Linux 5.14 or later")
def test_forked_child_gets_its_own_thread():
    prefault.populate(np.empty(4 * MB // 8))  # the parent's thread runs
    assert prefault.flush(30)
    ctx = multiprocessing.get_context("fork")
    out = ctx.Queue()
    child = ctx.Process(target=_child, args=(out,))
    child.start()
    assert out.get(timeout=30) is True  # without a thread of its own the child's flush would time out
    child.join(30)
    assert child.exitcode == 0


@pytest.mark.skipif(not SUPPORTED, reason="MADV_POPULATE_WRITE needs Linux 5.14 or later")
def test_a_cancelled_job_stops_early_and_lets_go_of_its_array():
    a = np.empty(512 * MB // 8)  # 64 pieces: far more than the thread backs before the cancel
    job = prefault.populate(a)
    job.cancel()
    assert prefault.flush(30)
    assert job.owner is None and job.start < job.end

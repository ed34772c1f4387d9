"""One stop rule for every solver, sweep and figure run: a time limit, a memory limit, or a
request by Ctrl-C, SIGTERM or SIGHUP (the terminal hung up). Long work calls ``stop.check()``
at safe points and, once it says why, returns its best plan and proven bound with that reason
as the status."""

from __future__ import annotations

import os
import signal
import stat
import threading
import time
from contextlib import contextmanager

TIME_LIMIT, MEMORY_LIMIT, INTERRUPTED = "time_limit", "memory_limit", "interrupted"
GB = 1e9  # memory limits are given in GB (10^9 bytes) everywhere


class Stop:
    """Why a run must stop now, if it must: ``reason`` is None, or one of the three statuses."""

    def __init__(self, time_limit: float | None = None, memory_limit: float | None = None,
                 labels_limit: int | None = None) -> None:
        self.t0 = time.perf_counter()
        self.time_limit = time_limit
        self.memory_limit = memory_limit
        self.deadline = None if time_limit is None else self.t0 + float(time_limit)
        self.memory_bytes = None if memory_limit is None else float(memory_limit) * GB
        self.labels_limit = labels_limit  # a clock counted in work, not seconds: dp's labels (``spend``)
        self.labels = 0
        self.reason: str | None = None
        self.signal: int | None = None  # the signal that asked to stop, if one did
        self.signalled = False  # a signal came, also after a limit had stopped the work

    @property
    def requested(self) -> bool:
        return self.reason is not None

    def request(self, reason: str = INTERRUPTED, signum: int | None = None) -> None:
        self.signalled = self.signalled or signum is not None
        if self.reason is None:
            self.reason = reason
            self.signal = signum

    def elapsed(self) -> float:
        return time.perf_counter() - self.t0

    def remaining(self) -> float | None:
        """Seconds left before the time limit (None: no limit)."""
        return None if self.deadline is None else self.deadline - time.perf_counter()

    def spend(self, labels: int) -> None:
        """Count ``labels`` against ``labels_limit``. It stops work as a time limit does, with
        the same status, but at the same point on every run: dp gives its subsets such an
        allowance when the solve has no time limit, so that the solve is deterministic."""
        self.labels += int(labels)

    def fits(self, nbytes: float) -> bool:
        """Does holding ``nbytes`` stay within the memory limit?"""
        return self.memory_bytes is None or nbytes <= self.memory_bytes

    def check(self, memory_used: float = 0.0) -> str | None:
        """The reason to stop now (and remember it), or None to go on."""
        if self.reason is None:
            if (self.deadline is not None and time.perf_counter() >= self.deadline) or \
                    (self.labels_limit is not None and self.labels >= self.labels_limit):
                self.reason = TIME_LIMIT
            elif not self.fits(memory_used):
                self.reason = MEMORY_LIMIT
        return self.reason

    def describe(self) -> str:
        """One line on why the run stopped, for ``solver.stopped``."""
        if self.reason == TIME_LIMIT and self.time_limit is not None:
            return f"time limit of {self.time_limit:g} s reached"
        if self.reason == TIME_LIMIT:
            return "time limit reached" if self.labels_limit is None else \
                f"allowance of {self.labels_limit:,} labels reached"
        if self.reason == MEMORY_LIMIT:
            return f"memory limit of {self.memory_limit:g} GB reached"
        if self.reason == INTERRUPTED:
            name = signal.Signals(self.signal).name if self.signal else "a stop request"
            return f"interrupted by {name}"
        return "not stopped"


def resident_bytes() -> float | None:
    """This process's resident memory now (Linux: /proc/self/statm), or None where unknown. For
    work whose memory voiopt cannot count itself (HiGHS's), its growth stands in for it."""
    try:
        with open("/proc/self/statm", "rb") as f:
            return float(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


class Stopped(Exception):
    """Work that cannot hand over a partial result (a table, a model) was cut short: the stop
    rule said stop. Its caller falls back on a plan it can make at once."""


def halt_if_asked(stop: Stop | None, memory_used: float = 0.0) -> None:
    """Between the blocks of such work: raise Stopped if ``stop`` (None: no stop rule) says stop."""
    if stop is not None and stop.check(memory_used) is not None:
        raise Stopped(stop.reason)


class Interrupted(KeyboardInterrupt):
    """Work stopped by a signal as a whole (a sweep, or a second Ctrl-C). ``exit_code`` is
    128 + the signal number: 130 for Ctrl-C, 143 for SIGTERM, 129 for SIGHUP."""

    def __init__(self, signum: int | None = None) -> None:
        self.signum = signum or signal.SIGINT
        super().__init__(signal.Signals(self.signum).name)

    @property
    def exit_code(self) -> int:
        return 128 + int(self.signum)

    def __reduce__(self):  # it may cross a process boundary
        return (Interrupted, (int(self.signum),))


_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
_active: list[Stop] = []  # the Stops of the watches open in the main thread, outermost first
_previous: dict = {}  # the handlers before the outermost watch


_last_signal: list[int] = []
_held: list[int] = []  # a stop asked for while a solver was starting, for the watch of its solve (``starting``)


def last_signal() -> int | None:
    """The signal that last asked this process to stop (None: none did)."""
    return _last_signal[-1] if _last_signal else None


def signals_seen() -> int:
    """How many signals have asked this process to stop so far (a wait compares two counts)."""
    return len(_last_signal)


def _silence_lost_terminal(signum: int) -> None:
    """After a SIGHUP (other signals: nothing): standard streams on a terminal that has hung up
    fail every write (EIO), which would end the command in a traceback before it writes its
    ``-o`` file; point them at /dev/null instead. A terminal still there (a ``kill -HUP`` by
    hand) answers ``isatty`` and keeps its output; files and pipes are not character devices
    and are left alone."""
    if signum != signal.SIGHUP:
        return
    try:
        null = os.open(os.devnull, os.O_RDWR)
    except OSError:
        return
    for fd in (0, 1, 2):
        try:
            if stat.S_ISCHR(os.fstat(fd).st_mode) and not os.isatty(fd):  # a hung-up terminal fails isatty
                os.dup2(null, fd)
        except OSError:  # fd not open
            pass
    os.close(null)


def _catches(signum: int) -> bool:
    """Whether a watch takes over this signal: a hang-up ignored (``nohup``) stays ignored."""
    return signum != signal.SIGHUP or signal.getsignal(signum) is not signal.SIG_IGN


def _handler(signum, frame) -> None:
    _last_signal.append(signum)
    _silence_lost_terminal(signum)
    # the second request stops at once, also where a limit had stopped the work before the
    # first (greedy valuing a plan of 10^6 slots for 2 s swallowed every Ctrl-C)
    if any(s.signalled or s.reason == INTERRUPTED for s in _active):
        _restore()
        raise Interrupted(signum)
    for s in _active:
        s.request(INTERRUPTED, signum)


def _restore() -> None:
    for s, h in _previous.items():
        signal.signal(s, h)
    _previous.clear()


@contextmanager
def watch(time_limit: float | None = None, memory_limit: float | None = None, labels_limit: int | None = None):
    """A Stop for the block. In the main thread the first Ctrl-C, SIGTERM or SIGHUP (unless
    ignored, as under ``nohup``) requests a stop of every watch open (a sweep and the solve
    inside it alike); a second one raises Interrupted at once. Elsewhere (worker threads)
    signals cannot be caught and only the limits apply."""
    stop = Stop(time_limit, memory_limit, labels_limit)
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    for outer in _active:  # a stop asked for before this watch opened still holds inside it
        if outer.reason == INTERRUPTED:
            stop.request(INTERRUPTED, outer.signal)
    if _held:
        stop.request(INTERRUPTED, _held.pop())
    try:  # a signal raising anywhere in the set-up (a command's SIGTERM, a first Ctrl-C) leaves no stale watch
        _active.append(stop)  # before the handler goes in: no signal can fall between the two
        if len(_active) == 1:
            _previous.update({s: signal.getsignal(s) for s in _SIGNALS if _catches(s)})
            for s in list(_previous):
                signal.signal(s, _handler)
        yield stop
    finally:
        if stop in _active:  # not yet in it if the signal came before the append (a Stop is equal only to itself)
            _active.remove(stop)
        if not _active:
            _restore()


@contextmanager
def starting():
    """A block in which a solver starts: it warms up its kernels on a tiny instance, whose own
    solves open and close their watches. A Ctrl-C or SIGTERM in it stops that work, and, unless
    a watch outside the block carries it already, is held for the next watch, which opens
    stopped: the solve that was starting stops too, instead of running on as if no one had
    asked (docs/reliability.md)."""
    outside = bool(_active)
    with watch() as stop:
        yield stop
    if stop.reason == INTERRUPTED and not outside and threading.current_thread() is threading.main_thread():
        _held[:] = [stop.signal]


def _forget_after_fork() -> None:
    """A forked child (a pool worker) starts with no watch open and default handlers: the
    parent's sweep and its stop state are not the child's."""
    if _active:
        for s, h in _previous.items():
            signal.signal(s, h)
    _active.clear()
    _previous.clear()
    _last_signal.clear()
    _held.clear()


os.register_at_fork(after_in_child=_forget_after_fork)

ORPHAN_POLL_S = 0.2  # how often a pool worker looks whether its sweep is still there


def pool_worker(parent: int) -> None:
    """The signals of a sweep's pool worker (``parent``: the sweep's process id). It leaves
    Ctrl-C to the solver's own stop rule (and to the parent), and a hang-up of the terminal to
    the parent, which stops it as it stops a sweep; a SIGTERM between runs ends it (the
    command's own handler, ``sigterm_raises``, is not its). It kills itself when the sweep is
    gone: a sweep killed outright (SIGKILL, the OOM killer) left its workers running their
    solves to the end, orphaned, and then the runs queued to them (hours at --episodes 1e9;
    found 2026-12-03). Not by a parent-death signal, which reaches only a sweep's own children
    (a forkserver's, Python 3.14's default, are not): a thread looks every ORPHAN_POLL_S whether
    the worker's parent has changed (its parent died: the sweep, or the forkserver, which ends
    with the sweep) or the sweep is gone. SIGKILL: a solve's stop rule catches SIGTERM, and the
    worker went on to its next run. Nothing is lost: no one is left to store its result."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    first = os.getppid()

    def orphaned() -> bool:
        if os.getppid() != first:
            return True
        try:
            os.kill(parent, 0)
        except ProcessLookupError:
            return True
        except OSError:  # there, but not ours to signal
            pass
        return False

    def watch_parent() -> None:
        while not orphaned():
            time.sleep(ORPHAN_POLL_S)
        os.kill(os.getpid(), signal.SIGKILL)

    threading.Thread(target=watch_parent, name="voiopt-orphan-watch", daemon=True).start()


@contextmanager
def sigterm_raises():
    """While a file is written, and while a command runs: a SIGTERM that would kill the process
    outright (its default action, as after a solve's stop rule is gone) raises Interrupted
    instead, so that a temporary file is removed and the command ends with status 143 and a
    line that says so (a fuzz campaign found .tmp files left by a second signal during the
    write of a result; a probe, a silent end of `bench score`). A SIGHUP likewise (the terminal
    hung up). Only in the main thread and where the signal has its default action; a solve's
    stop rule installs its own meanwhile."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    taken = [s for s in (signal.SIGTERM, signal.SIGHUP) if signal.getsignal(s) is signal.SIG_DFL]

    def interrupt(signum, frame):
        _silence_lost_terminal(signum)
        raise Interrupted(signum)

    for s in taken:
        signal.signal(s, interrupt)
    try:
        yield
    finally:
        for s in taken:
            signal.signal(s, signal.SIG_DFL)

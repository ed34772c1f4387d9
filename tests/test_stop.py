"""The one stop rule: limits, signals, nesting."""

from __future__ import annotations

import os
import signal
import time

import pytest

from voiopt.runtime.stop import (
    INTERRUPTED,
    MEMORY_LIMIT,
    TIME_LIMIT,
    Interrupted,
    Stop,
    starting,
    watch,
)


def test_limits_give_their_own_reasons():
    stop = Stop(time_limit=0.05, memory_limit=1.0)
    assert stop.check(memory_used=0.5e9) is None
    assert stop.check(memory_used=2e9) == MEMORY_LIMIT and "memory limit of 1 GB" in stop.describe()
    stop = Stop(time_limit=0.05)
    time.sleep(0.06)
    assert stop.check() == TIME_LIMIT and stop.remaining() < 0


def test_a_label_allowance_stops_as_a_time_limit_does_at_the_same_count_on_every_run():
    stop = Stop(labels_limit=100)
    stop.spend(99)
    assert stop.check() is None and stop.remaining() is None
    stop.spend(1)
    assert stop.check() == TIME_LIMIT and "allowance of 100 labels" in stop.describe()
    with watch(None, None, 5) as inner:
        inner.spend(5)
        assert inner.check() == TIME_LIMIT
    told = Stop()  # a solver's own clock (HiGHS's) ran out, with no limit of ours
    told.request(TIME_LIMIT)
    assert told.describe() == "time limit reached"


def test_a_signal_stops_every_open_watch_and_one_asked_before_a_watch_opens_holds_inside_it():
    before = signal.getsignal(signal.SIGTERM)
    with watch() as outer:
        with watch() as inner:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.01)
            assert inner.reason == outer.reason == INTERRUPTED and inner.signal == signal.SIGTERM
        with watch() as later:  # e.g. the next solve of a sweep, or one still starting up
            assert later.requested and later.signal == signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) is before  # restored


def test_a_signal_while_a_solver_starts_is_held_for_the_watch_of_its_solve_once():
    with starting() as warm:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)
        assert warm.reason == INTERRUPTED
    with watch() as solve:  # the solve that was starting
        assert solve.requested and solve.signal == signal.SIGTERM
    with watch() as later:  # one signal stops one solve
        assert not later.requested
    with watch() as outer:  # within a sweep the sweep's watch carries it: nothing is held
        with starting():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.01)
    assert outer.reason == INTERRUPTED
    with watch() as after:
        assert not after.requested


def test_a_signal_while_dp_warms_up_stops_the_solve_not_only_the_warm_up(monkeypatch):
    """A Ctrl-C or SIGTERM in the warm-up used to stop only its tiny solves: the real solve then
    ran to the end with status optimal (found by a fuzz campaign, 2026-12-02)."""
    import voiopt
    from voiopt.solvers import base
    from voiopt.solvers.dp import solver as dp

    real, sent = dp.build_tables, []

    def tables_and_a_signal(*args, **kwargs):  # in the warm-up's first tiny solve
        if not sent:
            sent.append(os.kill(os.getpid(), signal.SIGTERM))
            time.sleep(0.01)
        return real(*args, **kwargs)

    monkeypatch.setattr(base, "_WARM", set())  # the next solve warms up again
    monkeypatch.setattr(dp, "build_tables", tables_and_a_signal)
    before = signal.getsignal(signal.SIGTERM)
    inst = voiopt.generate(6, 30, seed=3)
    r = dp.solve(inst, "mean-min-voi")
    assert r.status == INTERRUPTED and r.solver["stopped"] == "interrupted by SIGTERM"
    assert r.metrics == voiopt.evaluate(inst, r.plan)  # the best plan so far, as the simulator values it
    assert signal.getsignal(signal.SIGTERM) is before
    assert dp.solve(voiopt.generate(3, 8, seed=3), "mean-min-voi").status == "optimal"  # the next solve runs


def test_a_second_signal_raises_at_once():
    """(The handler is restored to what it was: the default, or SIG_IGN under nohup or '&'.)"""
    before = signal.getsignal(signal.SIGINT)
    with pytest.raises(Interrupted) as e, watch():
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)
    assert e.value.exit_code == 130
    assert signal.getsignal(signal.SIGINT) is before


def test_after_a_limit_stopped_the_work_a_second_signal_still_raises_at_once():
    """Stopped by its time limit, greedy valued its plan of 10^6 slots for 2 s, and every Ctrl-C
    meanwhile was swallowed: the stop had a reason already, so none counted as a first (an
    outside probe, 2026-12-03). The first is noted; the second raises."""
    with pytest.raises(Interrupted), watch(time_limit=1e-9) as stop:
        time.sleep(0.001)
        assert stop.check() == TIME_LIMIT
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)
        assert stop.reason == TIME_LIMIT  # the result still says what stopped the work
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)


def test_in_a_loop_of_solves_one_signal_stops_one_solve_and_is_remembered():
    """The library's rule (docs/reliability.md): the stopped solve returns, the next one starts
    afresh, and last_signal() tells a script's loop that it was asked to stop."""
    from voiopt.runtime.stop import last_signal

    with watch() as first:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)
        assert first.reason == INTERRUPTED
    with watch() as second:
        assert not second.requested and second.check() is None
    assert last_signal() == signal.SIGTERM


def test_a_signal_that_raises_during_a_watchs_set_up_leaves_no_watch_open(monkeypatch):
    """A command's SIGTERM handler raises (stop.sigterm_raises); landing just after a watch was
    registered, before its handlers went in, it left that watch open for good: later watches
    in the process installed no handler and a Ctrl-C was swallowed (a review, 2026-12-03)."""
    from voiopt.runtime import stop as stop_mod

    class Raising(list):
        def append(self, item):
            super().append(item)
            raise Interrupted(signal.SIGTERM)  # as the raising handler would, right there

    monkeypatch.setattr(stop_mod, "_active", Raising())
    before = signal.getsignal(signal.SIGINT)
    with pytest.raises(Interrupted):
        with watch():
            pass
    assert list(stop_mod._active) == [] and signal.getsignal(signal.SIGINT) is before


def test_outside_a_solve_a_hang_up_raises_as_sigterm_does():
    """While a command writes its files (stop.sigterm_raises), SIGHUP raises, so a temporary file
    is removed and the command ends with 129, not killed half-way; an ignored one stays ignored."""
    from voiopt.runtime.stop import sigterm_raises

    before = signal.signal(signal.SIGHUP, signal.SIG_DFL)  # as in a terminal, even if pytest runs under nohup
    try:
        with pytest.raises(Interrupted) as e, sigterm_raises():
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(0.01)
        assert e.value.exit_code == 129 and signal.getsignal(signal.SIGHUP) is signal.SIG_DFL
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
        with sigterm_raises():
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(0.01)
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, before)

"""Coupled outcome scenarios and Monte Carlo under lossy links (MODEL.md section 11).

A scenario w is a uniform U(t, i) for every slot t and sensor i, drawn whether or not i
uploads; an upload of i in slot t from distance d succeeds iff U(t, i) < p_i(d). Policies
run on the same scenarios meet the same outcomes (common random numbers). A plan's expected
value is exact (voiopt.core.expectation); Monte Carlo is for policies, and for checking.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance, show
from voiopt.core.links import success_table
from voiopt.core.plan import FleetPlan, Plan
from voiopt.core.simulate import check_plan, simulate, simulate_indices
from voiopt.errors import OptionError
from voiopt.grid import lattice as lattice_mod
from voiopt.runtime.progress import progress_bar
from voiopt.runtime.stop import Stop, Stopped, halt_if_asked

CONFIDENCE = 0.95


class Estimate(NamedTuple):
    """A Monte Carlo estimate: the sample mean, its two-sided 95 % Student-t confidence interval
    [low, high], and the number of scenarios."""

    mean: float
    ci: tuple[float, float]
    count: int


def sample_scenarios(instance: Instance, count: int, seed: int) -> np.ndarray:
    """(count, T, N) uniforms U(t, i) in [0, 1), from numpy's default Generator seeded with
    ``seed``: the same seed gives the same scenarios, and scenario k is the same whatever
    ``count`` is (drawn row by row)."""
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise OptionError(f"count: must be an integer >= 1, got {show(count)}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise OptionError(f"seed: must be an integer >= 0, got {show(seed)}")
    rng = np.random.default_rng(seed)
    return rng.random((count, instance.horizon, instance.n_sensors))


def successes(instance: Instance, idx: np.ndarray, sched: np.ndarray, u_row: np.ndarray,
              table: np.ndarray | None = None) -> np.ndarray:
    """Bool array of sched's shape: True where an upload is scheduled and succeeds in scenario
    ``u_row`` ((T, N) uniforms), U(t, i) < p_i(d) (``table``: the instance's success_table)."""
    table = success_table(instance, lattice_mod.build(instance)) if table is None else table
    t = np.broadcast_to(np.arange(instance.horizon), sched.shape)
    up = sched >= 0
    out = np.zeros(sched.shape, dtype=bool)
    i, pt = sched[up], idx[up]
    out[up] = u_row[t[up], i] < table[pt, i]
    return out


def realise(instance: Instance, plan: Plan | FleetPlan, u_row: np.ndarray) -> Plan | FleetPlan:
    """The lossless plan that ``plan`` becomes in scenario ``u_row``: each failed upload becomes
    None (a failed upload acts exactly as an unscheduled slot); the simulator values it."""
    idx, sched = check_plan(instance, plan)
    ok = successes(instance, idx, sched, _row(instance, u_row))
    return Plan.from_indices(instance, idx, np.where(ok, sched, -1))


def monte_carlo(instance: Instance, plan_or_run: Plan | FleetPlan | Callable[[np.ndarray], Plan | FleetPlan],
                scenarios: np.ndarray, objective: str, *, stop: Stop | None = None, progress: bool = False) -> Estimate:
    """The mean of ``objective`` over the scenarios, with its 95 % Student-t CI. Given a plan,
    each scenario's realised plan is simulated; given a function (a policy's run), it is called
    with each scenario's (T, N) uniforms and must return the realised lossless plan of that run
    (checked and simulated here). ``stop`` (voiopt.runtime.stop.Stop: time, memory, Ctrl-C) is checked
    between scenarios; once it stops, the estimate is over the scenarios done (its ``count``
    says how many), or voiopt.runtime.stop.Stopped if fewer than two were."""
    objectives.get(objective)
    scenarios = np.asarray(scenarios, dtype=float)
    if scenarios.ndim != 3 or scenarios.shape[1:] != (instance.horizon, instance.n_sensors) or len(scenarios) < 2:
        raise OptionError(f"scenarios: must be an array (count >= 2, T = {instance.horizon}, N = {instance.n_sensors}), "
                          f"got shape {scenarios.shape}")
    if isinstance(plan_or_run, (Plan, FleetPlan)):
        idx, sched = check_plan(instance, plan_or_run)
        table = success_table(instance, lattice_mod.build(instance))

        def value(u: np.ndarray) -> float:
            return simulate_indices(instance, idx, np.where(successes(instance, idx, sched, u, table), sched, -1)
                                    ).metrics[objective]
    else:
        def value(u: np.ndarray) -> float:
            return simulate(instance, plan_or_run(u)).metrics[objective]
    values: list[float] = []
    with progress_bar(progress) as bar:
        task = bar.add_task("monte carlo", total=len(scenarios))
        for u in scenarios:
            try:  # a run may stop inside a scenario too (a policy that solves as it goes)
                halt_if_asked(stop)
                v = value(u)
            except Stopped:
                if len(values) < 2:
                    raise
                break
            values.append(v)
            bar.advance(task)
    return estimate(values)


def estimate(values) -> Estimate:
    """Mean and two-sided 95 % Student-t confidence interval of i.i.d. samples (at least 2)."""
    # the Student-t quantile; scipy.stats would take seconds to import
    from scipy.special import stdtrit

    x = np.asarray(values, dtype=float)
    n = len(x)
    mean = float(x.mean())
    half = float(stdtrit(n - 1, 0.5 + CONFIDENCE / 2) * x.std(ddof=1) / math.sqrt(n))
    return Estimate(mean, (mean - half, mean + half), n)


def _row(instance: Instance, u_row) -> np.ndarray:
    u = np.asarray(u_row, dtype=float)
    if u.shape != (instance.horizon, instance.n_sensors):
        raise OptionError(f"u_row: must have shape (T, N) = ({instance.horizon}, {instance.n_sensors}), got {u.shape}")
    return u

"""``--method dp`` for two robots (MODEL.md section 10, docs/dp.md "Several robots").

An exact label-setting programme over the product state (``solvers.labels.fleet_search``):
one pass without uploads finds a legal joint plan (or proves there is none), a beam pass gives
a good incumbent, and the full pass with bounds and dominance proves the optimum. Stopped before
any plan, it returns what its caller's ``stopped`` gives (dp's: greedy's plan). It declines, in one
line, more than two robots and product states that would not fit the memory limit.
"""

from __future__ import annotations

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.result import Result
from voiopt.core.simulate import simulate
from voiopt.grid import lattice as lattice_mod
from voiopt.runtime.status import Status
from voiopt.runtime.stop import Stopped, watch
from voiopt.solvers.base import (
    DEFAULT_MEMORY_GB,
    Incumbent,
    check_limits,
    require_memory,
    warm_up_once,
)
from voiopt.solvers.labels.fleet_search import (  # noqa: F401  (MAX_ROBOTS, FLEET_BEAM: dp's own for two robots)
    FLEET_BEAM,
    MAX_ROBOTS,
    Pass,
    build_joint,
    check_fleet,
    legal_pass,
    search,
)
from voiopt.solvers.labels.tables import table_bytes


def solve(instance: Instance, objective: str, *, progress: bool = False, time_limit: float | None = None,
          memory_limit: float = DEFAULT_MEMORY_GB, warm_start=None, beam: int = FLEET_BEAM,
          bounding: bool = True, stopped=None) -> Result:
    """The optimal joint plan of two robots; on a time or memory limit or Ctrl-C the best plan
    found and a proven bound, with the stop's reason as the status. Stopped before the tables
    are built, the result of ``stopped`` (dp passes baselines.stopped_result: greedy's plan,
    stopped at once), else status error."""
    objective = objectives.get(objective)
    check_limits(time_limit, memory_limit)
    check_fleet(instance, memory_limit)
    require_memory(table_bytes(instance), memory_limit, "dp's tables")
    startup_s = warm_up()
    with watch(time_limit, memory_limit) as stop:
        return _solve(instance, objective, stop, startup_s, warm_start, beam, bounding, progress, stopped)


def warm_up() -> float:
    """Compile (or load from numba's cache) the kernels on a tiny two-robot instance once per
    process, so that runtime_s and the time limit measure the search alone."""

    def load():
        from voiopt.core.instance import from_dict
        from voiopt.networks.generate import generate
        from voiopt.objectives import OBJECTIVES

        d = generate(2, 3, width=1.0, height=1.0, seed=0, name="warm-up").to_dict()
        del d["start"]
        d["robots"] = [{"start": [0, 0]}, {"start": [1, 1]}]
        tiny = from_dict(d)
        for objective in OBJECTIVES:
            solve(tiny, objective)

    return warm_up_once("fleet_dp", load)


def _solve(instance, objective, stop, startup_s, warm_start, beam, bounding, progress, stopped=None) -> Result:
    try:
        jt = build_joint(instance, objective, stop)
    except Stopped:
        where, solver = "stopped while building the tables", {"startup_s": startup_s}
        if stopped is not None:  # dp's: greedy's plan, stopped at once (baselines.stopped_result)
            return stopped(instance, "dp", objective, stop, solver, where)
        return Result.from_plan(instance, "dp", objective, None, status=Status.ERROR, runtime_s=stop.elapsed(),
                                solver={**solver, "note": f"{where}, before any plan", "stopped": stop.describe()})
    scale = jt.tab.to_internal  # objective value * scale = the kernels' maximised value
    best = Incumbent(instance, objective)
    passes: dict[str, Pass] = {}

    def offer(plan, source):
        best.offer(*plan, source)

    def inc() -> float:
        return best.value * scale if bounding and best.value is not None else -np.inf

    if warm_start is not None:
        simulate(instance, warm_start)  # a PlanError names what breaks the rules
        offer(_indices(instance, warm_start), "warm_start")
    first = passes["legal"] = legal_pass(jt, stop, limited=stopped is not None)
    if first.plan is not None:
        offer(first.plan, "legal")
    elif first.complete:
        return Result.from_plan(instance, "dp", objective, None, status=Status.INFEASIBLE, runtime_s=stop.elapsed(),
                                solver={"passes": {"legal": first.summary()}})
    elif best.value is None:  # stopped before any plan: dp's fallback (greedy's plan, stopped at once)
        return stopped(instance, "dp", objective, stop, {"startup_s": startup_s, "passes": {"legal": first.summary()}},
                       "stopped in the pass that looks for a legal joint plan")
    if beam > 0 and not stop.requested:
        b = passes[f"beam {beam}"] = search(jt, inc(), stop, beam=beam)
        if b.plan is not None:
            offer(b.plan, f"beam {beam}")
    out = passes["exact"] = search(jt, inc(), stop, progress=progress) if not stop.requested else \
        Pass(-np.inf, None, False, np.inf)
    if out.plan is not None:
        offer(out.plan, "dp")
    if best.value is None:  # cannot be: the legal pass gave a plan
        raise RuntimeError("dp: no plan after the legal pass found one")
    value = best.value * scale
    if out.complete:
        bound, status = max(value, out.value), Status.OPTIMAL
    else:
        bound, status = max(value, out.open_bound), stop.reason or Status.TIME_LIMIT
    solver = {"passes": {k: p.summary() for k, p in passes.items()},
              "labels": sum(p.labels for p in passes.values()),
              "peak_label_bytes": max(p.peak_bytes for p in passes.values()),
              "incumbents": best.offers, "startup_s": startup_s,
              "options": {"beam": beam, "bounding": bounding, "time_limit": stop.time_limit,
                          "memory_limit": stop.memory_limit, "robots": 2}}
    if not out.complete:
        solver["stopped"] = stop.describe()
    return Result.from_plan(instance, "dp", objective, best.plan, status=status,
                            bound=None if not np.isfinite(bound) else bound / scale, runtime_s=stop.elapsed(),
                            solver=solver)


def _indices(instance: Instance, plan) -> tuple[np.ndarray, np.ndarray]:
    """A FleetPlan as (K, T) point indices and schedule (-1 for none)."""
    lat = lattice_mod.build(instance)
    idx = [[lat.index(x, y) for x, y in p.positions] for p in plan.robots]
    sched = [[-1 if u is None else u for u in p.schedule] for p in plan.robots]
    return np.array(idx, np.int64), np.array(sched, np.int64)

"""A fleet's first legal plan for milp (MODEL.md section 10): the warm start of its search and
the plan it returns if stopped at once. ``run`` is milp's ``_Run`` (its incumbent, details,
stop rule and HiGHS runner)."""

from __future__ import annotations

import math

import numpy as np

from voiopt.core.plan import Plan
from voiopt.core.simulate import check_plan
from voiopt.errors import PlanError
from voiopt.runtime.status import Status
from voiopt.runtime.stop import Stopped
from voiopt.solvers.milp import formulation as milp_formulation

# the repair of a fleet's conflicting greedy plans is a warm start, not the solve: at most this
# share of the time left (at least 1 s; REPAIR_S without a limit), to this gap in agreement
REPAIR_SHARE, REPAIR_S, REPAIR_GAP = 0.1, 10.0, 0.05


def first_fleet_plan(run, warm_start: Plan | None) -> str | None:
    """A fleet's first legal plan into the incumbent: the given one; else the fleet greedy's
    (baselines.greedy plans jointly, without conflicts, in the time left; where every robot
    staying at its start is legal, it has at least that plan); if it found none, milp stops
    here if the time is up; else each robot's greedy plan alone, if together they keep
    section 10's rules (a sensor serving two robots in one slot stays with the first); else
    their repair: the plan of the path model (no cover rows) that keeps most of their
    positions, moves and uploads. None once there is a plan, INFEASIBLE when
    HiGHS proves there is none, else the limit that stopped it (TIME_LIMIT; ERROR if none did)."""
    inst = run.instance
    if warm_start is not None:
        run.incumbent.offer(*check_plan(inst, warm_start), source="warm start")
        run.details["warm_start"] = "given"
        return None
    from voiopt.solvers.baselines.heuristics import greedy

    left = run.stop.remaining()
    joint = greedy(inst, run.objective, time_limit=None if left is None else max(left, 1e-3),
                   memory_limit=run.stop.memory_limit)
    if joint.plan is not None:  # the fleet greedy's conflict-free joint plan
        run.incumbent.offer(*check_plan(inst, joint.plan), source="warm start")
        run.details["warm_start"] = "greedy"
        return None
    if joint.status == Status.INFEASIBLE:  # greedy only says so with a proof (an exhausted exact search)
        run.details["note"] = f"no legal joint plan: {joint.solver.get('note')} (MODEL.md section 10)"
        return Status.INFEASIBLE
    # (where every robot staying at its start is legal, greedy has returned that plan)
    idx, sched = np.empty((2, inst.n_robots, inst.horizon), dtype=np.int64)
    for k in range(inst.n_robots):
        left = run.stop.remaining()
        plan = greedy(inst.robot(k), run.objective, time_limit=None if left is None else max(left, 1e-3),
                      memory_limit=run.stop.memory_limit).plan
        idx[k], sched[k] = check_plan(inst.robot(k), plan)
        sched[k, (sched[:k] == sched[k]).any(axis=0)] = -1
    try:
        run.incumbent.offer(*check_plan(inst, Plan.from_indices(inst, idx, sched)), source="warm start")
        run.details["warm_start"] = "greedy (each robot alone)"
        return None
    except PlanError as e:
        run.details["warm_start"] = f"greedy repaired by the path model (the robots' greedy plans conflict: {e})"
    if run.stop.check():  # greedy spent the time left (its walker stopped, and gave up): no time to repair
        run.details["warm_start"] += "; stopped before the repair"
        return _no_plan_yet(run, f"greedy: {joint.solver.get('note')}")
    import highspy

    try:
        model = milp_formulation.build_covering(inst, run.objective, -math.inf, run.stop)  # no cover rows: the paths alone
    except Stopped:
        return _no_plan_yet(run, "the path model was not built")
    left = run.remaining()
    cap = REPAIR_S if left is None else min(left, max(1.0, REPAIR_SHARE * left))
    # maximise agreement with the greedy plans within the cap, else any plan in the time left
    for cost, limit in ((model.solution_from_plan(idx, sched), cap), (np.zeros(model.n_cols), None)):
        model.cost = cost
        h = run.highs(model)
        if limit is not None:
            h.setOptionValue("time_limit", limit)
            h.setOptionValue("mip_rel_gap", REPAIR_GAP)
        ms, info = run.run_highs(h)
        if run.has_solution(h, info):
            run.incumbent.offer(*model.plan_from_solution(np.asarray(h.getSolution().col_value)), source="warm start")
            return None
        if ms == highspy.HighsModelStatus.kInfeasible or run.stop.requested:
            break

    if ms == highspy.HighsModelStatus.kInfeasible:
        run.details["note"] = ("no legal joint plan: the robots cannot all keep their ends and budgets without sharing "
                               "a point or swapping points (MODEL.md section 10); HiGHS proved the path model infeasible")
        return Status.INFEASIBLE
    limited = ms in (highspy.HighsModelStatus.kTimeLimit, highspy.HighsModelStatus.kInterrupt)
    return _no_plan_yet(run, f"HiGHS: {h.modelStatusToString(ms)}", Status.TIME_LIMIT if limited else Status.ERROR)


def _no_plan_yet(run, why: str, otherwise: Status = Status.ERROR) -> Status:
    """No plan yet: the status says which limit stopped the work (``time_limit`` also when
    HiGHS's own clock, set to the time left, stopped it first), else ``otherwise``."""
    run.details["note"] = f"stopped before any legal joint plan was found ({why})"
    return run.stop.reason or otherwise

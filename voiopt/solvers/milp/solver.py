"""The exact solver: the time-expanded MILP of voiopt.solvers.milp on HiGHS (highspy).

- ``min-voi`` and ``max-aoi``: bisection over the sorted finite set of candidate worths; each
  step is a pure 0-1 covering problem, so no VoI value is ever compared inside the LP. The
  bound is the largest candidate not proven infeasible.
- ``mean-min-voi`` and ``mean-max-aoi``: one MILP with per-slot z_t, scaled by the warm start's
  value, mip_rel_gap 0 by default. HiGHS's dual bound is widened by a safety margin for its
  tolerances, and an "optimal" whose simulated value falls short of the bound by more than
  5e-7 relative is re-checked with a cutoff row "objective >= value (1 + 5e-7)".

Every plan is re-simulated; the result's value is the simulator's. A time limit or Ctrl-C
returns the best plan found (at worst the warm start) with the proven bound.

Several robots (MODEL.md section 10) use the same two methods on the fleet model of
models/milp/fleet.py; their first plan comes from _milp_fleet_start (the given one, else the
fleet greedy's, else each robot's greedy plan, else their repair on the path model, whose
infeasibility is the status ``infeasible``).
"""

from __future__ import annotations

import math
import sys
import threading
import time
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.plan import Plan
from voiopt.core.result import Result
from voiopt.core.simulate import check_plan
from voiopt.errors import OptionError
from voiopt.grid import lattice as lattice_mod
from voiopt.objectives import DEFAULT, Worth
from voiopt.runtime.status import Status
from voiopt.runtime.stop import TIME_LIMIT, Stop, Stopped, resident_bytes, watch
from voiopt.solvers import options
from voiopt.solvers.base import (
    DEFAULT_MEMORY_GB,
    Incumbent,
    check_limits,
    check_threads,
    lattice_bytes,
    points_in_range,
    require_memory,
)
from voiopt.solvers.milp import formulation as milp_formulation
from voiopt.solvers.milp import model as milp_model
from voiopt.solvers.milp import uploads as milp_uploads
from voiopt.solvers.milp.fleet_start import first_fleet_plan

METHOD = "milp"
PATCH_RTOL = 5e-7  # an "optimal" must be met to this relative gap (half of Result's 1e-6)
# Safety margin added to HiGHS's dual bound for its tolerances: relative, plus an absolute
# 100 x the feasibility tolerance in worth units (with the default tolerance 1e-6 HiGHS's
# presolve "proved" a bound 3.6e-6 below the true optimum on a tiny instance; see docs/milp.md).
BOUND_RTOL = 1e-8
BOUND_ABS_FACTOR = 100.0
TOLERANCES = {
    "mip_feasibility_tolerance": 1e-9,
    "primal_feasibility_tolerance": 1e-9,
    "dual_feasibility_tolerance": 1e-9,
    "mip_abs_gap": 1e-10,
}


@dataclass(frozen=True)
class Options(options.Options):
    """milp's options (``solve``'s keywords)."""

    gap: float | None = None
    threads: int | None = None
    warm_start: Plan | None = None
    verbose: bool = False

def solve(
    instance: Instance,
    objective: str = DEFAULT,
    *,
    progress: bool = False,
    time_limit: float | None = None,
    gap: float | None = None,
    threads: int | None = None,
    warm_start: Plan | None = None,
    verbose: bool = False,
    memory_limit: float = DEFAULT_MEMORY_GB,
) -> Result:
    """Solve ``instance`` exactly for ``objective`` (within ``time_limit`` seconds, if given).
    ``verbose`` shows HiGHS's own log on stderr."""
    objective = objectives.get(objective)
    check_limits(time_limit, memory_limit)
    if gap is not None and not gap >= 0:
        raise OptionError(f"--gap: must be >= 0, got {gap:g}")
    check_threads(threads)
    T, n = instance.horizon, lattice_mod.n_points(instance)
    columns = T * n * (1 + 6 * len(instance.fleet)) + T * instance.n_sensors * points_in_range(instance) * (2 if objectives.get(objective).per_slot else 1)
    require_memory(lattice_bytes(instance) + 2000.0 * columns, memory_limit, "the MILP and HiGHS")
    with watch(time_limit, memory_limit) as stop:
        run = _Run(instance, objective, verbose, stop, gap, threads)
        status, bound = None, None
        if instance.fleet:
            status = first_fleet_plan(run, warm_start)
        else:
            run.incumbent.offer(*_warm_plan(instance, objective, warm_start, stop), source="warm start")
            run.details["warm_start"] = "given" if warm_start is not None else "greedy"
        run.details["warm_start_s"] = stop.elapsed()
        if status is not None:  # a fleet without a first plan: proven infeasible, or stopped first
            pass
        elif objectives.get(objective).per_slot:
            status, bound = run.solve_mean()
        else:
            status, bound = run.solve_bisection()
    run.details["plan_source"] = run.incumbent.source
    if status == TIME_LIMIT and not stop.requested:  # HiGHS's own clock ran out first
        stop.request(TIME_LIMIT)
    if stop.requested:  # a proof completed as the stop came is kept: the result is whole (exit status 0)
        run.details["stopped"] = stop.describe() + ("; the optimum was proven by then" if status == Status.OPTIMAL else "")
    return Result.from_plan(
        instance, METHOD, objective, run.incumbent.plan, status=status, bound=bound,
        runtime_s=stop.elapsed(), solver=run.details,
    )


def _warm_plan(instance: Instance, objective: str, warm_start: Plan | None, stop: Stop) -> tuple[np.ndarray, np.ndarray]:
    """The given plan, else the greedy baseline's (within the time left; stopped, greedy hands
    back a legal plan all the same): the MILP always has a plan to return."""
    if warm_start is not None:
        return check_plan(instance, warm_start)  # PlanError (exit 2) if it does not fit
    from voiopt.solvers.baselines.heuristics import greedy

    left = stop.remaining()
    return check_plan(instance, greedy(instance, objective, time_limit=None if left is None else max(left, 1e-3),
                                       memory_limit=stop.memory_limit).plan)


def _stopped_statuses() -> tuple:
    import highspy

    K = highspy.HighsModelStatus
    return (K.kTimeLimit, K.kInterrupt, K.kSolutionLimit, K.kIterationLimit)


_STOPPED = _stopped_statuses()


class _Run:
    """State of one solve: the incumbent plan, the clock, the HiGHS options and the details."""

    def __init__(self, instance, objective, verbose, stop: Stop, gap, threads) -> None:
        self.instance = instance
        self.objective = objective
        self.kind = objectives.get(objective).worth
        self.verbose = verbose
        self.stop = stop
        self.gap = 0.0 if gap is None else float(gap)
        self.threads = threads
        self.incumbent = Incumbent(instance, objective)
        self.resident0: float | None = None  # the process's resident memory before HiGHS got its model
        self.details: dict[str, Any] = {
            "options": {"mip_rel_gap": self.gap, "threads": threads, **TOLERANCES},
            "nodes": 0, "solves": 0, "build_s": 0.0, "solve_s": 0.0,
        }

    # ----------------------------------------------------------------------- plans

    def worth(self, value: float) -> float:
        """An objective value as a worth (AoI objectives are minimised: worth = -A)."""
        return value if self.kind == Worth.VOI else -value

    def remaining(self) -> float | None:
        return self.stop.remaining()

    def out_of_time(self) -> bool:
        return self.stop.check() is not None

    # ----------------------------------------------------------------------- HiGHS

    def highs(self, model: milp_model.Model):
        import highspy

        t = time.perf_counter()
        self.resident0 = resident_bytes()  # HiGHS's memory: the process's growth from here (not numba's, greedy's)
        h = milp_model.new_highs(self.verbose)
        # verbose: HiGHS's log of the one big MILP, on stderr (stdout stays for results)
        log = self.verbose and model.aggregate != "covering"
        h.setOptionValue("output_flag", log)
        if log:
            h.setOptionValue("log_to_console", False)
            h.cbLogging.subscribe(lambda event: sys.stderr.write(event.message))
        h.setOptionValue("mip_rel_gap", self.gap)
        for k, v in TOLERANCES.items():
            h.setOptionValue(k, v)
        h.setOptionValue("random_seed", 0)
        if self.threads is not None:
            # HiGHS keeps one global thread pool; a different size needs a fresh one
            highspy.Highs.resetGlobalScheduler(True)
            h.setOptionValue("threads", int(self.threads))
        r = self.remaining()
        if r is not None:
            h.setOptionValue("time_limit", max(r, 1e-3))
        h.passModel(model.to_highs_lp())
        stop = self.stop

        def interrupt(event) -> None:
            if stop.requested:
                event.interrupt()

        h.cbMipInterrupt.subscribe(interrupt)
        h.cbSimplexInterrupt.subscribe(interrupt)
        self.details["build_s"] += time.perf_counter() - t
        self.details["model"] = model.size()
        return h

    def run_highs(self, h) -> tuple[Any, Any]:
        """Run HiGHS (see _run_once); should it end with a solve error (a presolve fault: the
        model is sound), run it once more with presolve off."""
        import highspy

        ms, info = self._run_once(h)
        if ms == highspy.HighsModelStatus.kSolveError and not self.stop.requested:
            self.details["presolve_off_retries"] = self.details.get("presolve_off_retries", 0) + 1
            h.clearSolver()
            h.setOptionValue("presolve", "off")
            ms, info = self._run_once(h)
        return ms, info

    def _run_once(self, h) -> tuple[Any, Any]:
        """Run HiGHS in a thread while this one watches the stop rule: HiGHS's interrupt
        callbacks then see the request, and where HiGHS does not answer within HIGHS_GRACE_S
        (its presolve polls no callback) it is left behind and the incumbent returned."""
        import highspy

        t = time.perf_counter()
        worker = threading.Thread(target=h.run, daemon=True)
        worker.start()
        asked = None
        while worker.is_alive():
            worker.join(WATCH_S)
            if asked is None and self.stop.check(self.memory_used()) is not None:
                asked = time.perf_counter()
            if asked is not None and worker.is_alive() and time.perf_counter() - asked > HIGHS_GRACE_S:
                self.details["note"] = "HiGHS did not answer the stop request in time and was left behind"
                self.details["solve_s"] += time.perf_counter() - t
                return highspy.HighsModelStatus.kInterrupt, _NO_INFO
        self.details["solve_s"] += time.perf_counter() - t
        self.details["solves"] += 1
        info = h.getInfo()
        self.details["nodes"] += int(max(info.mip_node_count, 0))
        return h.getModelStatus(), info

    def memory_used(self) -> float:
        """What the memory limit counts while HiGHS runs: the process's resident memory grown
        since HiGHS was given its model (its own allocations are opaque; the estimate made before
        the solve, 2000 bytes a column, fell 5x short on a factory floor, 1.4 GB resident)."""
        now = resident_bytes()
        return 0.0 if now is None or self.resident0 is None else max(now - self.resident0, 0.0)

    @staticmethod
    def has_solution(h, info) -> bool:
        return info.primal_solution_status == 2  # kSolutionStatusFeasible

    # ------------------------------------------------------- min-voi, max-aoi: bisection

    def _stopped_building(self, t: float, what: str):
        """Stopped while building (since ``t``): the best plan so far, the warm start's, and no bound."""
        self.details["build_s"] += time.perf_counter() - t
        self.details["note"] = f"stopped while {what}; the plan is the warm start's"
        return self.stop.reason, None

    def solve_bisection(self) -> tuple[str, float]:
        """Largest candidate worth J such that every sensor can be kept >= J in every slot."""
        import highspy

        t = time.perf_counter()
        try:
            st = milp_uploads.structure(self.instance, self.kind, self.stop)
            cand = st.candidates(self.stop)
        except Stopped:  # the best plan so far (the warm start), no bound
            return self._stopped_building(t, "the uploads' worths were computed (T^2 of them)")
        top = int(np.searchsorted(cand, st.min_worth_cap()[1:].min(), side="right")) - 1
        lo = self._feasible_index(cand, self.worth(self.incumbent.value))
        hi = top  # cand[hi + 1:] are proven infeasible (or exceed the relaxation)
        self.details["build_s"] += time.perf_counter() - t
        self.details["candidates"] = int(top - max(lo, 0) + 1)
        steps = []
        status = Status.OPTIMAL
        while lo < hi:
            if self.out_of_time():
                status = self.stop.reason or TIME_LIMIT
                break
            mid = (lo + hi + 1) // 2
            t = time.perf_counter()
            model = milp_formulation.build_covering(self.instance, self.objective, float(cand[mid]))
            self.details["build_s"] += time.perf_counter() - t
            if model is None:
                steps.append("unreachable")
                hi = mid - 1
                continue
            h = self.highs(model)
            ms, info = self.run_highs(h)
            if self.has_solution(h, info):
                idx, sched = model.plan_from_solution(np.asarray(h.getSolution().col_value))
                value = self.incumbent.offer(idx, sched, source="covering model")
                lo = max(mid, self._feasible_index(cand, self.worth(value)))
                steps.append("feasible")
            elif ms == highspy.HighsModelStatus.kInfeasible:
                hi = mid - 1
                steps.append("infeasible")
            elif ms in _STOPPED:  # time limit or interrupt before a decision
                status = self.stop.reason or TIME_LIMIT
                steps.append(h.modelStatusToString(ms))
                break
            else:
                raise RuntimeError(f"milp: HiGHS ended a covering problem with {h.modelStatusToString(ms)!r}")
            if self.verbose:
                print(
                    f"milp {self.objective}: threshold {self.worth(float(cand[mid])):.6g} {steps[-1]}; "
                    f"best {self.incumbent.value:.6g}, bound {self.worth(float(cand[hi])):.6g}",
                    file=sys.stderr, flush=True,
                )
        self.details["bisection"] = steps
        bound_worth = float(cand[hi]) if hi >= 0 else float(cand[0])
        return status, self.worth(bound_worth)

    @staticmethod
    def _feasible_index(cand: np.ndarray, worth: float) -> int:
        return int(np.searchsorted(cand, worth, side="right")) - 1

    # -------------------------------------------------- mean-min-voi, mean-max-aoi: one MILP

    def solve_mean(self) -> tuple[str, float | None]:
        import highspy

        t = time.perf_counter()
        warm_worth = self.worth(self.incumbent.value)
        scale = warm_worth if self.kind == Worth.VOI and warm_worth > 0 else None
        try:
            model = milp_formulation.build(self.instance, self.objective, scale=scale, stop=self.stop)
        except Stopped:
            return self._stopped_building(t, "the MILP was built (it grows as T^2)")
        self.details["scale"] = model.scale
        self.details["build_s"] += time.perf_counter() - t
        h = self.highs(model)
        h.setSolution(_solution(model, self.incumbent.idx, self.incumbent.sched))
        ms, info = self.run_highs(h)
        K = highspy.HighsModelStatus
        if self.has_solution(h, info):
            idx, sched = model.plan_from_solution(np.asarray(h.getSolution().col_value))
            self.incumbent.offer(idx, sched, source="HiGHS")
        self.details["highs_status"] = h.modelStatusToString(ms)
        self.details["mip_gap"] = float(info.mip_gap) if math.isfinite(info.mip_gap) else None
        bound = self._dual_bound_worth(model, info)
        if ms == K.kOptimal:
            status = Status.OPTIMAL
            bound = self._patch(model, bound)
        elif ms in _STOPPED:
            status = self.stop.reason or TIME_LIMIT
        else:  # keep the best plan, claim nothing
            self.details["note"] = f"HiGHS ended with {self.details['highs_status']!r}"
            return (self.stop.reason if self.stop.requested else Status.FEASIBLE), None
        value = self.worth(self.incumbent.value)
        if status == Status.OPTIMAL and self.stop.requested and bound is not None and _above(bound, value):
            # HiGHS proved its bound but, stopped, did not hand over the plan that meets it
            status = self.stop.reason
        if bound is not None and _above(value, bound):
            # a plan it found beats its "proven" bound: HiGHS's numerics failed, so its bound is no proof
            self.details["note"] = (f"HiGHS's bound {self.worth(bound):.10g} fell below the simulated value of a plan it "
                                    "found: no proof from it; the bound is the relaxation's (docs/milp.md)")
            bound = self._dual_bound_worth(model, _NO_INFO)
            status = Status.FEASIBLE if status == Status.OPTIMAL else status
        return status, (None if bound is None else self.worth(bound))

    def _dual_bound_worth(self, model: milp_model.Model, info) -> float | None:
        """HiGHS's dual bound as a worth, widened by BOUND_RTOL for its tolerances; where HiGHS
        has none yet (stopped in the root LP), the relaxation "each slot's weakest sensor as
        fresh as it could possibly be" (the mean of the z caps)."""
        w = float(model.levels.cap.mean())
        b = info.mip_dual_bound
        if math.isfinite(b):
            highs_w = model.worth_of_objective(b)
            w = min(w, highs_w + BOUND_RTOL * abs(highs_w) + _abs_slack(model))
        if self.kind == Worth.AOI:  # sum over slots of integer ages: round down to a multiple of 1/T
            T = self.instance.horizon
            w = math.floor(w * T + 1e-6) / T
        return w

    def _patch(self, model: milp_model.Model, bound: float | None) -> float | None:
        """HiGHS says optimal; make sure the simulated value really meets the bound to
        PATCH_RTOL, else ask for a plan better by PATCH_RTOL (and take it, or its bound)."""
        import highspy

        for _ in range(3):
            value = self.worth(self.incumbent.value)
            if bound is None or not _above(bound, value):
                return bound
            if self.out_of_time():
                return bound
            # worths of AoI plans are multiples of 1/T: ask for the next multiple
            step = 0.5 / self.instance.horizon if self.kind == Worth.AOI else PATCH_RTOL * abs(value)
            cutoff = value + step
            h = self.highs(model)
            z = model.z_cols
            h.addRow(cutoff / model.scale, highspy.kHighsInf, len(z), z.astype(np.int32), model.cost[z])
            ms, info = self.run_highs(h)
            self.details["patched"] = self.details.get("patched", 0) + 1
            if self.has_solution(h, info):
                idx, sched = model.plan_from_solution(np.asarray(h.getSolution().col_value))
                self.incumbent.offer(idx, sched, source="HiGHS (patch)")
            if ms == highspy.HighsModelStatus.kInfeasible:  # as sure as HiGHS's tolerances (_abs_slack)
                return min(bound, value if self.kind == Worth.AOI else cutoff + _abs_slack(model))
            if ms != highspy.HighsModelStatus.kOptimal:
                return bound
            new = self._dual_bound_worth(model, info)
            bound = bound if new is None else min(bound, max(new, self.worth(self.incumbent.value)))
        return bound


WATCH_S = 0.05  # how often the stop rule is checked while HiGHS runs
HIGHS_GRACE_S = 1.0  # how long HiGHS may take to honour a stop request
_NO_INFO = SimpleNamespace(mip_dual_bound=math.inf, mip_gap=math.inf, primal_solution_status=0, mip_node_count=0)


def _above(a: float, b: float) -> bool:
    """Worth a is above worth b by more than PATCH_RTOL (relative)."""
    return a - b > PATCH_RTOL * max(abs(a), abs(b))


def _abs_slack(model: milp_model.Model) -> float:
    """An absolute allowance for HiGHS's feasibility tolerances on the z rows, in worth units."""
    return BOUND_ABS_FACTOR * TOLERANCES["mip_feasibility_tolerance"] * model.scale


def _solution(model: milp_model.Model, idx: np.ndarray, sched: np.ndarray) -> Any:
    import highspy

    sol = highspy.HighsSolution()
    sol.col_value = model.solution_from_plan(idx, sched).tolist()
    sol.value_valid = True
    return sol

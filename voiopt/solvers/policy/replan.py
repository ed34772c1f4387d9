"""``--method replan``: the re-planning policy under lossy links (MODEL.md section 11), the
baseline a careful engineer would deploy. In each slot it re-solves the remaining horizon as a
lossless problem from the observed state (position, moves used, every sensor's A and q) with
dp (exact) or beam, takes that plan's first action, and observes the outcome.

Its value is exact where the states it reaches can be enumerated (forward enumeration,
voiopt.core.policy_value), else Monte Carlo over coupled scenarios with a 95 % CI. Its bound
is the lossless optimum's proven bound (the slot-0 problem is the lossless problem itself),
or, with ``ir_samples``, the information-relaxation bound capped by it (statistical).

The saved policy is the table of every decision the evaluation asked for; an observation
outside it gets the Policy's stated fallback, not a new solve (re-planning needs a solver,
which a loaded policy file does not carry).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

from voiopt.core.instance import Instance
from voiopt.core.links import without_links
from voiopt.core.policy import Policy
from voiopt.core.policy_value import DEFAULT_SAMPLES, value_under
from voiopt.core.result import Evaluation
from voiopt.errors import OptionError
from voiopt.runtime.progress import progress_bar
from voiopt.runtime.status import Status
from voiopt.runtime.stop import Stopped, watch
from voiopt.solvers import options
from voiopt.solvers.base import DEFAULT_MEMORY_GB, check_limits
from voiopt.solvers.lossy_plans import lossless_bound
from voiopt.solvers.policy.relaxation import policy_bound
from voiopt.solvers.policy.report import policy_result
from voiopt.solvers.policy.solver import check_averaged

PLANNERS = ("dp", "beam")
EXACT_STATES = 2000  # states of a slot up to which replan's value is computed exactly


class ReplanPolicy(Policy):
    """A Policy that decides an unseen state by solving the rest of the horizon, losslessly."""

    def __init__(self, instance: Instance, objective: str, planner: str, stop=None) -> None:
        super().__init__(instance, objective, "replan", table={})
        self.planner, self.stop = planner, stop
        self.base = without_links(instance)
        self.solves = 0
        self.tick = None  # called after each solve (progress)
        self.first: object = None  # the slot-0 solve's Result: the lossless optimum

    def missing(self, t: int, state: tuple, key: tuple) -> tuple[int, int]:
        if self.stop is not None and self.stop.check() is not None:
            raise Stopped(self.stop.reason)
        hit = self.table[key] = self._replan(t, state)
        return hit

    def _replan(self, t: int, state: tuple) -> tuple[int, int]:
        from voiopt.solvers.dp import beam
        from voiopt.solvers.dp import solver as dp

        p, k, ages, qs = state
        lat = self.steps.lat
        sensors = tuple(dataclasses.replace(s, initial_aoi=int(a), initial_distance=float(q))
                        for s, a, q in zip(self.base.sensors, ages, qs, strict=True))
        budget = None if self.base.max_moves is None else self.base.max_moves - k
        start = (float(lat.points[p, 0]), float(lat.points[p, 1]))
        rest = dataclasses.replace(self.base, horizon=self.steps.T - t, start=start, sensors=sensors,
                                   max_moves=budget, name=f"{self.base.name}@{t}")
        solver = dp.solve if self.planner == "dp" else beam.solve
        result = solver(rest, self.objective)
        self.solves += 1
        if self.tick is not None:
            self.tick()
        if t == 0 and self.first is None:
            self.first = result
        idx = [lat.index(*xy) for xy in result.plan.positions[:2]]
        u = result.plan.schedule[0]
        m = 0 if len(idx) < 2 else lat.move(idx[0], idx[1])
        return (-1 if u is None else int(u), m)


@dataclass(frozen=True)
class Options(options.Options):
    """replan's options (``solve``'s keywords)."""

    planner: str = "dp"
    samples: int = DEFAULT_SAMPLES
    seed: int = 0
    ir_samples: int = 0


def solve(instance: Instance, objective: str, *, progress: bool = False, time_limit: float | None = None,
          memory_limit: float = DEFAULT_MEMORY_GB, planner: str = "dp", samples: int = DEFAULT_SAMPLES,
          seed: int = 0, ir_samples: int = 0):
    """The re-planning policy, its value (exact or Monte Carlo over ``samples`` coupled
    scenarios drawn from ``seed``) and its bound."""
    check_averaged(objective, "replan")
    check_limits(time_limit, memory_limit)
    if planner not in PLANNERS:
        raise OptionError(f"planner: must be one of {', '.join(PLANNERS)}, got {planner!r}")
    t0 = time.perf_counter()
    with watch(time_limit, memory_limit) as stop, progress_bar(progress) as bar:
        task = bar.add_task(f"replan ({planner}): lossless solves", total=None)
        policy = ReplanPolicy(instance, objective, planner, stop)
        policy.tick = lambda: bar.update(task, advance=1)
        solver = {"planner": planner}
        try:  # exact within half the time left, else Monte Carlo over the scenarios done in time
            evaluation, cut, why = value_under(stop, policy, objective, samples, seed, EXACT_STATES, exact_share=0.5)
            if why:
                solver["evaluation_note"] = why
        except Stopped:
            evaluation, cut = None, stop.check() or Status.TIME_LIMIT
        status = cut or Status.FEASIBLE
        if cut:
            solver["stopped"] = stop.describe() if stop.check() else str(cut)
        solver["solves"] = policy.solves
        first = policy.first or _lossless(instance, objective, planner)  # the slot-0 solve: its bound, its plan
        if evaluation is None:  # stopped: the open-loop lossless plan (the slot-0 solve), valued exactly
            from voiopt.core.expectation import expected_metrics

            policy = Policy(instance, objective, "replan", plan=first.plan)
            evaluation = {"value": expected_metrics(instance, first.plan)[objective], "evaluation": Evaluation.EXACT}
            solver["note"] = "stopped before re-planning was valued: the policy is the slot-0 plan, open-loop"
        lossless = first.bound
        if lossless is None:  # the beam planner proves nothing: dp's bound on the lossless instance
            lossless, solver["lossless_bound_from"] = lossless_bound(instance, objective, {
                "time_limit": max(stop.remaining(), 0.3) if stop.time_limit else None, "memory_limit": memory_limit})
        bound, kind, extra, ir = policy_bound(instance, objective, lossless, seed=seed, stop=stop,
                                              ir_samples=ir_samples if status == Status.FEASIBLE else 0)
        if ir is not None:
            solver["information_relaxation"] = ir
    solver["lossless_bound"] = lossless
    return policy_result(instance, "replan", objective, policy, evaluation, status=status, bound=bound,
                         bound_kind=kind, runtime_s=time.perf_counter() - t0, solver=solver, **extra, stop=stop)


def _lossless(instance: Instance, objective: str, planner: str):
    from voiopt.solvers.dp import beam
    from voiopt.solvers.dp import solver as dp

    return (dp.solve if planner == "dp" else beam.solve)(without_links(instance), objective)

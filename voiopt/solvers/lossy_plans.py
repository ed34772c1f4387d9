"""Plan methods on lossy instances (MODEL.md section 11): a plan method solves the lossless
problem, and its plan is valued by its exact expected objectives.

A plan is open-loop, not a policy, so a plan method never claims ``optimal`` on a lossy
instance: its status becomes ``feasible`` (or stays the limit that stopped it). Its bound is
the lossless solve's proven bound, which bounds every policy (any realised run is a lossless
plan), labelled ``lossless``; a heuristic without one has none.
"""

from __future__ import annotations

from voiopt.core.expectation import expected_metrics
from voiopt.instance import Instance
from voiopt.result import Result


def plan_result(instance: Instance, lossless: Result) -> Result:
    """The result on the lossy ``instance`` of a plan method's result on its lossless instance."""
    solver = dict(lossless.solver)
    solver["lossless_status"] = lossless.status
    solver["lossless_value"] = lossless.value
    status = "feasible" if lossless.status == "optimal" else lossless.status
    if lossless.plan is None:  # infeasible or an error: nothing to value
        return Result(instance.name, lossless.method, lossless.objective, status, None, lossless.bound, None,
                      lossless.runtime_s, None, None, solver, evaluation="exact",
                      bound_kind=None if lossless.bound is None else "lossless")
    return Result.lossy(instance, lossless.method, lossless.objective, status=status,
                        metrics=expected_metrics(instance, lossless.plan), evaluation="exact", plan=lossless.plan,
                        bound=lossless.bound, bound_kind=None if lossless.bound is None else "lossless",
                        runtime_s=lossless.runtime_s, solver=solver)

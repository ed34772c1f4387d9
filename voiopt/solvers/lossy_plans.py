"""Plan methods on lossy instances (MODEL.md section 11): a plan method solves the lossless
problem, and its plan is valued by its exact expected objectives (``plan_method``).

A plan is open-loop, not a policy, so a plan method never claims ``optimal`` on a lossy
instance: its status becomes ``feasible`` (or stays the limit that stopped it). Its bound is
the lossless solve's proven bound, which bounds every policy (any realised run is a lossless
plan), labelled ``lossless``; a heuristic without one has none.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

from voiopt.core.expectation import expected_metrics
from voiopt.core.instance import Instance
from voiopt.core.links import is_lossy, without_links
from voiopt.core.result import BoundKind, Evaluation, Result
from voiopt.runtime.status import Status


def plan_method(fn: Callable[..., Result]) -> Callable[..., Result]:
    """A plan method's ``solve(instance, objective, **options)`` that, on a lossy instance, solves
    the lossless instance and values its plan exactly (``plan_result``); on any other instance
    it is ``fn`` itself, call for call. The registry (``solvers.solver_function``) hands out
    every plan method wrapped so, so that no caller can skip it."""

    @functools.wraps(fn)
    def solve(instance: Instance, objective: str, **options) -> Result:
        if not is_lossy(instance):
            return fn(instance, objective, **options)
        return plan_result(instance, fn(without_links(instance), objective, **options))

    return solve


def plan_result(instance: Instance, lossless: Result) -> Result:
    """The result on the lossy ``instance`` of a plan method's result on its lossless instance."""
    solver = dict(lossless.solver)
    solver["lossless_status"] = Status(lossless.status).value
    solver["lossless_value"] = lossless.value
    status = Status.FEASIBLE if lossless.status == Status.OPTIMAL else Status(lossless.status)
    if lossless.plan is None:  # infeasible or an error: nothing to value
        return Result(instance.name, lossless.method, lossless.objective, status, None, lossless.bound, None,
                      lossless.runtime_s, None, None, solver, evaluation=Evaluation.EXACT,
                      bound_kind=None if lossless.bound is None else BoundKind.LOSSLESS)
    return Result.lossy(instance, lossless.method, lossless.objective, status=status,
                        metrics=expected_metrics(instance, lossless.plan), evaluation=Evaluation.EXACT, plan=lossless.plan,
                        bound=lossless.bound, bound_kind=None if lossless.bound is None else BoundKind.LOSSLESS,
                        runtime_s=lossless.runtime_s, solver=solver)

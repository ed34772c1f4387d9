"""Plan methods on lossy instances (MODEL.md section 11): a plan method solves the lossless
problem, and its plan is valued by its exact expected objectives (``plan_method``).

A plan is open-loop, not a policy, so a plan method never claims ``optimal`` on a lossy
instance: its status becomes ``feasible`` (or stays the limit that stopped it). Its bound is
the lossless solve's proven bound, which bounds every policy (any realised run is a lossless
plan), labelled ``lossless``. A method with no proven bound of its own (beam, greedy,
shortest-path, Q-learning) gets dp's on the lossless instance (``lossless_bound``), within
the method's time limit (LOSSLESS_BOUND_S when it has none): dp's proven bound, also where dp
stopped early, never its incumbent.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

from voiopt.core.expectation import expected_metrics
from voiopt.core.instance import Instance
from voiopt.core.links import is_lossy, without_links
from voiopt.core.result import BoundKind, Evaluation, Result
from voiopt.errors import VoioptError
from voiopt.runtime.status import Status
from voiopt.solvers.base import DEFAULT_MEMORY_GB


def plan_method(fn: Callable[..., Result]) -> Callable[..., Result]:
    """A plan method's ``solve(instance, objective, **options)`` that, on a lossy instance, solves
    the lossless instance and values its plan exactly (``plan_result``); on any other instance
    it is ``fn`` itself, call for call. The registry (``solvers.solver_function``) hands out
    every plan method wrapped so, so that no caller can skip it."""

    @functools.wraps(fn)
    def solve(instance: Instance, objective: str, **options) -> Result:
        if not is_lossy(instance):
            return fn(instance, objective, **options)
        return plan_result(instance, fn(without_links(instance), objective, **options), options)

    return solve


LOSSLESS_BOUND_S = 60.0  # dp's time for the bound of a method without one, when the method has no time limit


def lossless_bound(instance: Instance, objective: str, options: dict) -> tuple[float | None, str]:
    """dp's proven bound on the lossless optimum of the lossy ``instance`` (None where dp takes
    no such instance), and how it was found, in words."""
    from voiopt.solvers.dp import solver as dp

    limit = options.get("time_limit") or LOSSLESS_BOUND_S
    try:
        r = dp.solve(without_links(instance), objective, time_limit=limit, progress=bool(options.get("progress")),
                     memory_limit=options.get("memory_limit") or DEFAULT_MEMORY_GB)
    except VoioptError as e:
        return None, f"none: dp takes no such instance ({e})"
    return r.bound, f"dp on the lossless instance ({r.status}, {r.runtime_s:.3g} s of at most {limit:g} s)"


def plan_result(instance: Instance, lossless: Result, options: dict | None = None) -> Result:
    """The result on the lossy ``instance`` of a plan method's result on its lossless instance
    (``options``: the method's, whose time and memory limits a missing bound's dp run keeps)."""
    solver = dict(lossless.solver)
    solver["lossless_status"] = Status(lossless.status).value
    solver["lossless_value"] = lossless.value
    if lossless.bound is None and lossless.plan is not None:
        bound, solver["lossless_bound_from"] = lossless_bound(instance, lossless.objective, options or {})
        solver["lossless_bound"] = bound
        lossless = dataclasses.replace(lossless, bound=bound)
    status = Status.FEASIBLE if lossless.status == Status.OPTIMAL else Status(lossless.status)
    if lossless.plan is None:  # infeasible or an error: nothing to value
        return Result(instance.name, lossless.method, lossless.objective, status, None, lossless.bound, None,
                      lossless.runtime_s, None, None, solver, evaluation=Evaluation.EXACT,
                      bound_kind=None if lossless.bound is None else BoundKind.LOSSLESS)
    return Result.lossy(instance, lossless.method, lossless.objective, status=status,
                        metrics=expected_metrics(instance, lossless.plan), evaluation=Evaluation.EXACT, plan=lossless.plan,
                        bound=lossless.bound, bound_kind=None if lossless.bound is None else BoundKind.LOSSLESS,
                        runtime_s=lossless.runtime_s, solver=solver)

"""The time-expanded MILP as a ``cvxpy.Problem`` (the ``[cvxpy]`` extra), to solve with any
cvxpy MILP back-end (HiGHS, SCIP, GLPK_MI, Gurobi, ...).

    import cvxpy as cp
    from voiopt.solvers.milp import cvxpy_problem
    problem, to_plan = cvxpy_problem(instance, objective)
    problem.solve(solver=cp.HIGHS)
    result = voiopt.Result.from_plan(instance, "cvxpy", objective, to_plan(), status="feasible", runtime_s=0)

It is the model ``voiopt export`` writes (solvers/milp/export.py: ``min-voi`` in log-worths,
the others with z in units of the model's ``scale``), built from the same arrays: one vector
variable with integer entries where the model has binaries, its bounds, and ``A @ x``
against the row bounds with the scipy sparse matrix. ``problem.value`` is in the model's
units (ln V for ``min-voi``, the mean worth / ``scale`` for the mean objectives, minus the
age for AoI): the plan ``to_plan()`` reads from the solution is what counts, valued by the
simulator.

A solve by HiGHS or SCIP without gap options runs to a relative gap of 0 (HiGHS's default
stops at 1e-4, which on these models can return a plan 1e-4 short of the optimum); pass
``mip_rel_gap`` (HiGHS) or ``scip_params={"limits/gap": g}`` to choose another.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from voiopt.core.instance import Instance
from voiopt.core.plan import FleetPlan, Plan
from voiopt.errors import MissingExtraError, OptionError
from voiopt.solvers.milp.export import export_model


def cvxpy_problem(instance: Instance, objective: str) -> tuple[Any, Callable[[], Plan | FleetPlan]]:
    """``(problem, to_plan)``: the MILP of ``objective`` as a cvxpy Problem (maximised), and a
    function that, after ``problem.solve(...)``, reads the solution's x and y into a plan
    (OptionError if the problem holds no solution)."""
    try:
        import cvxpy as cp
    except ImportError:
        raise MissingExtraError("cvxpy", "cvxpy") from None
    model = export_model(instance, objective)
    n = model.n_cols
    ints = np.flatnonzero(model.integrality)
    col = cp.Variable(n, name="col", integer=(ints,)) if len(ints) else cp.Variable(n, name="col")
    A, lo, up = model.matrix.tocsr(), model.row_lower, model.row_upper
    eq = np.flatnonzero(lo == up)
    le = np.flatnonzero((lo != up) & np.isfinite(up))
    ge = np.flatnonzero((lo != up) & np.isfinite(lo))
    constraints = [col >= model.col_lower, col <= model.col_upper]
    if len(eq):
        constraints.append(A[eq] @ col == up[eq])
    if len(le):
        constraints.append(A[le] @ col <= up[le])
    if len(ge):
        constraints.append(A[ge] @ col >= lo[ge])
    problem = _exact_problem_class(cp)(cp.Maximize(model.cost @ col), constraints)

    def to_plan() -> Plan | FleetPlan:
        value = col.value
        if value is None:
            raise OptionError(f"cvxpy_problem: the problem holds no solution to read (status {problem.status!r}): "
                              "solve it first, with a MILP back-end such as solver=cvxpy.HIGHS")
        idx, sched = model.plan_from_solution(np.asarray(value, dtype=float))
        return Plan.from_indices(instance, idx, sched)

    return problem, to_plan


_CLASS: dict[str, type] = {}


def _exact_problem_class(cp) -> type:
    """cvxpy.Problem whose solve by HiGHS or SCIP defaults to a relative gap of 0."""
    if "class" not in _CLASS:

        class ExactProblem(cp.Problem):
            """A cvxpy.Problem; solved by HiGHS or SCIP it runs to a relative gap of 0 unless
            the call says otherwise."""

            def solve(self, *args, **kwargs):
                solver = str(kwargs.get("solver", args[0] if args else "")).upper()
                if solver == cp.HIGHS and "mip_rel_gap" not in kwargs.get("highs_options", {}):
                    kwargs.setdefault("mip_rel_gap", 0.0)
                elif solver == cp.SCIP:
                    kwargs["scip_params"] = {"limits/gap": 0.0, **kwargs.get("scip_params", {})}
                return super().solve(*args, **kwargs)

        _CLASS["class"] = ExactProblem
    return _CLASS["class"]

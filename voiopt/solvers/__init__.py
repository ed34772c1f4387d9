"""The solver registry: method name -> ``solve(instance, objective, **options) -> Result``.

Modules are imported only when their method is used, so optional extras and numba
compilation cost nothing until needed. Options a method does not take are rejected with a
one-line error naming the option.
"""

from __future__ import annotations

import importlib
import inspect
from typing import Any

from voiopt.core import instance as instance_mod
from voiopt.core.instance import Instance
from voiopt.core.result import Result
from voiopt.errors import OptionError
from voiopt.objectives import DEFAULT, check_objective
from voiopt.solvers import lossy_plans
from voiopt.solvers.base import DP_MAX_ROBOTS

# method name -> (module, function); each function is
#   solve(instance, objective, *, progress=False, <its own keyword options>) -> Result
METHODS: dict[str, tuple[str, str]] = {
    "milp": ("voiopt.solvers.milp.solver", "solve"),
    "dp": ("voiopt.solvers.dp.solver", "solve"),
    "qlearning": ("voiopt.solvers.qlearning", "solve"),
    "aoi-qlearning": ("voiopt.solvers.qlearning", "solve_aoi"),
    "shortest-path": ("voiopt.solvers.baselines.heuristics", "shortest_path"),
    "greedy": ("voiopt.solvers.baselines.heuristics", "greedy"),
    "beam": ("voiopt.solvers.dp.beam", "solve"),
    "policy-dp": ("voiopt.solvers.policy.solver", "solve"),
    "replan": ("voiopt.solvers.policy.replan", "solve"),
}

# methods that return a policy and value it themselves under lossy links (MODEL.md section 11);
# every other method's plan is valued by its exact expectation (voiopt.solvers.lossy_plans)
POLICY_METHODS: frozenset[str] = frozenset({"policy-dp", "replan", "qlearning", "aoi-qlearning"})

# methods whose plan depends on the seed: a gap of theirs is reported over several seeds
RANDOMISED = frozenset({"qlearning", "aoi-qlearning"})

# methods that plan for several robots (MODEL.md section 10); the others plan for one
FLEET: frozenset[str] = frozenset({"milp", "dp", "qlearning", "aoi-qlearning", "shortest-path", "greedy"})


def check_robots(instance: Instance, method: str) -> None:
    """Refuse, in one line, a fleet instance for a method that plans for one robot."""
    if instance.fleet and method not in FLEET:
        others = ", ".join(m for m in METHODS if m in FLEET) or "none yet"
        raise OptionError(f"method: {method!r} plans for one robot, but the instance has {instance.n_robots} robots "
                          f"(methods for several robots: {others})")


def solver_function(method: str):
    if method not in METHODS:
        raise OptionError(f"method: unknown method {method!r} (choose from {', '.join(METHODS)})")
    module, function = METHODS[method]
    fn = getattr(importlib.import_module(module), function)
    return fn if method in POLICY_METHODS else lossy_plans.plan_method(fn)  # MODEL.md 11: a plan, valued exactly


def default_method(instance: Instance) -> str:
    """The fastest exact method that takes the instance: dp, or milp for more robots than dp
    plans for jointly."""
    return "dp" if instance.n_robots <= DP_MAX_ROBOTS else "milp"


def solve(instance: Instance, method: str | None = None, objective: str = DEFAULT, **options: Any) -> Result:
    """Solve ``instance`` (an Instance, or an instance file's path) with ``method`` (by default
    ``default_method``: dp, or milp for three robots or more) for ``objective``; every value
    in the Result is simulated."""
    instance = instance_mod.as_instance(instance, "instance")
    method = default_method(instance) if method is None else method
    check_objective(objective)
    fn = solver_function(method)
    check_robots(instance, method)
    params = inspect.signature(fn).parameters
    if not any(p.kind is p.VAR_KEYWORD for p in params.values()):
        for key in options:
            if key not in params:
                takes = [k for k, p in params.items() if p.kind is p.KEYWORD_ONLY and k != "progress"]
                raise OptionError(f"--{key.replace('_', '-')} ({key}= in Python): not an option of method {method!r} "
                                  f"(it takes {', '.join(takes)})")
    return fn(instance, objective, **options)

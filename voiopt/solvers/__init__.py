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
}

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
    return getattr(importlib.import_module(module), function)


def default_method(instance: Instance) -> str:
    """The fastest exact method that takes the instance: dp, or milp for more robots than dp
    plans for jointly."""
    return "dp" if instance.n_robots <= DP_MAX_ROBOTS else "milp"


class UnknownOption(OptionError):
    """A keyword a method does not take; it lists the keywords it does (the command line
    rephrases it with its own flags)."""

    def __init__(self, key: str, method: str, takes: list[str]) -> None:
        super().__init__(f"{key}: not an option of method {method!r} (it takes {', '.join(takes)})")
        self.key, self.method, self.takes = key, method, takes


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
                raise UnknownOption(key, method, takes)
    return fn(instance, objective, **options)

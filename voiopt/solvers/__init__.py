"""The solver registry: method name -> its ``Solver`` (``solve(instance, objective, **options) -> Result``)
and its options' dataclass.

Modules are imported only when their method is used, so optional extras and numba
compilation cost nothing until needed. Options a method does not take are rejected with a
one-line error naming the option.
"""

from __future__ import annotations

import importlib
from typing import Any, NamedTuple, Protocol, runtime_checkable

from voiopt import objectives
from voiopt.core import instance as instance_mod
from voiopt.core.instance import Instance
from voiopt.core.result import Result
from voiopt.errors import OptionError
from voiopt.objectives import DEFAULT, Objective
from voiopt.solvers import lossy_plans
from voiopt.solvers.base import DP_MAX_ROBOTS
from voiopt.solvers.options import Options, UnknownOption  # noqa: F401  (UnknownOption: the CLI rephrases it)


@runtime_checkable
class Solver(Protocol):
    """What every registry entry is: a function of an instance and an objective, with keyword
    options (its ``Options``), that returns a Result whose values the simulator computed."""

    def __call__(self, instance: Instance, objective: Objective, *, progress: bool = False,
                 time_limit: float | None = None, memory_limit: float = ...) -> Result: ...


class Method(NamedTuple):
    """A registry entry: the module of a method, its solve function and its options' class."""

    module: str
    function: str
    options: str


METHODS: dict[str, Method] = {
    "milp": Method("voiopt.solvers.milp.solver", "solve", "Options"),
    "dp": Method("voiopt.solvers.dp.solver", "solve", "Options"),
    "qlearning": Method("voiopt.solvers.qlearning.solver", "solve", "Options"),
    "aoi-qlearning": Method("voiopt.solvers.qlearning.solver", "solve_aoi", "Options"),
    "shortest-path": Method("voiopt.solvers.baselines.heuristics", "shortest_path", "ShortestPathOptions"),
    "greedy": Method("voiopt.solvers.baselines.heuristics", "greedy", "GreedyOptions"),
    "beam": Method("voiopt.solvers.dp.beam", "solve", "Options"),
    "policy-dp": Method("voiopt.solvers.policy.solver", "solve", "Options"),
    "replan": Method("voiopt.solvers.policy.replan", "solve", "Options"),
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


def _entry(method: str) -> Method:
    if method not in METHODS:
        raise OptionError(f"method: unknown method {method!r} (choose from {', '.join(METHODS)})")
    return METHODS[method]


def solver_function(method: str) -> Solver:
    """The solve function of ``method``; a plan method's is wrapped so that, on a lossy
    instance, its plan is valued exactly (MODEL.md section 11, ``lossy_plans``)."""
    entry = _entry(method)
    fn = getattr(importlib.import_module(entry.module), entry.function)
    return fn if method in POLICY_METHODS else lossy_plans.plan_method(fn)


def options_class(method: str) -> type[Options]:
    """The options' dataclass of ``method``."""
    entry = _entry(method)
    return getattr(importlib.import_module(entry.module), entry.options)


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
    objective = objectives.get(objective)
    fn = solver_function(method)
    check_robots(instance, method)
    given = options_class(method).of(method, options)
    return fn(instance, objective, **given.keywords())

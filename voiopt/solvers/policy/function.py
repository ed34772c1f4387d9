"""Any policy given as a function, valued and certified like voiopt's own (MODEL.md section 11,
docs/policy.md "Policies as objects").

``evaluate_function(instance, objective, act)`` makes ``act`` (observation -> (sensor or None,
move)) a Policy table (voiopt.core.function_policy), asking it once for each observed state the
evaluation reaches, and returns its Result: the value exact by forward enumeration where no
slot has more than ``max_states`` states, else Monte Carlo over ``samples`` coupled scenarios
drawn from ``seed`` (voiopt.core.scenarios: the same U(t, i) as every other policy valued with
that seed, so comparisons are paired) with its 95 % CI and sample count. The bound is the
given one with its kind, or by default the lossless optimum's proven bound (dp on the instance
without links). ``optimal`` is claimed only for an exact value equal to an exact bound.

A time limit, the memory limit or Ctrl-C stops the Monte Carlo between scenarios: the estimate
is over the scenarios done (its sample count says how many) and the status names the stop.
Stopped during the exact enumeration, or before two scenarios were valued, there is no value
to keep: voiopt.runtime.stop.Stopped is raised.
"""

from __future__ import annotations

import time

from voiopt import objectives
from voiopt.core.function_policy import Act, FunctionPolicy
from voiopt.core.instance import Instance, show
from voiopt.core.policy_value import DEFAULT_SAMPLES, exact_value, run
from voiopt.core.result import OPTIMAL_RTOL, BoundKind, Evaluation, Result
from voiopt.core.scenarios import monte_carlo, sample_scenarios
from voiopt.errors import OptionError
from voiopt.runtime.status import Status
from voiopt.runtime.stop import watch
from voiopt.solvers.base import DEFAULT_MEMORY_GB, check_limits
from voiopt.solvers.policy.report import policy_result
from voiopt.solvers.policy.solver import check_averaged, lossless_optimum

EXACT_STATES = 20_000  # states of a slot up to which a function's policy is valued exactly (each asks it once)


def evaluate_function(instance: Instance, objective: str, act: Act, *, method: str = "function",
                      samples: int = DEFAULT_SAMPLES, seed: int = 0, max_states: int = EXACT_STATES,
                      bound: float | None = None, bound_kind: BoundKind | str | None = None, progress: bool = False,
                      time_limit: float | None = None, memory_limit: float = DEFAULT_MEMORY_GB) -> Result:
    """The Result of the policy ``act`` on ``instance``: value (exact or Monte Carlo), bound
    (``bound`` of ``bound_kind``, else the lossless optimum's), and the Policy table of every
    decision asked for (``result.policy``; ``solver["decisions"]`` counts them)."""
    check_averaged(objective, method)
    check_limits(time_limit, memory_limit)
    if isinstance(max_states, bool) or not isinstance(max_states, int) or max_states < 0:
        raise OptionError(f"max_states: must be an integer >= 0, got {show(max_states)}")
    if (bound is None) != (bound_kind is None):
        raise OptionError(f"bound_kind: give a bound and its kind together, got bound {show(bound)} and "
                          f"bound_kind {show(bound_kind)}")
    if bound_kind is not None:
        try:
            bound_kind = BoundKind(bound_kind)
        except ValueError:
            raise OptionError(f"bound_kind: must be one of {', '.join(k.value for k in BoundKind)}, "
                              f"got {show(bound_kind)}") from None
    t0 = time.perf_counter()
    policy = FunctionPolicy(instance, objective, act, method)
    solver: dict = {}
    if bound is None:
        base = lossless_optimum(instance, objective, time_limit, memory_limit)
        bound, bound_kind = base.bound, (None if base.bound is None else BoundKind.LOSSLESS)
    status = Status.FEASIBLE
    with watch(time_limit, memory_limit) as stop:
        policy.stop = stop  # the enumeration asks at each new state; Monte Carlo between scenarios
        value = exact_value(policy, objective, max_states)
        policy.stop = None
        if value is not None:
            evaluation = {"value": value, "evaluation": Evaluation.EXACT}
            gap = objectives.gap(value, bound)
            if bound_kind == BoundKind.EXACT and gap is not None and gap <= OPTIMAL_RTOL:
                status = Status.OPTIMAL
        else:
            scenarios = sample_scenarios(instance, samples, seed)
            est = monte_carlo(instance, lambda u: run(policy, u), scenarios, objective, stop=stop, progress=progress)
            evaluation = {"value": est.mean, "evaluation": Evaluation.MONTE_CARLO, "samples": est.count,
                          "value_ci": list(est.ci), "scenario_seed": seed}
            if stop.reason is not None:
                status = stop.reason
                solver["stopped"] = stop.describe()
    solver["decisions"] = policy.calls
    return policy_result(instance, method, objective, policy, evaluation, status=status, bound=bound,
                         bound_kind=bound_kind, runtime_s=time.perf_counter() - t0, solver=solver, stop=stop)

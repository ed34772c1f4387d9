"""The Result of a policy (MODEL.md section 11): its value with how it was evaluated, its
bound with its kind, and the Policy itself, which ``voiopt solve`` saves beside the result.

Every value here is the policy's own, computed by voiopt.core.policy_value (exact forward
enumeration or Monte Carlo over coupled scenarios), never a solver's objective; Result.lossy
claims ``optimal`` only for an exact value equal, to a relative 1e-6, to an exact bound.
"""

from __future__ import annotations

from typing import Any

from voiopt.core.instance import Instance
from voiopt.core.policy import Policy
from voiopt.core.policy_value import AVERAGED, exact_value
from voiopt.core.result import Evaluation, Result
from voiopt.runtime.stop import Stop, Stopped


def policy_result(instance: Instance, method: str, objective: str, policy: Policy, evaluation: dict, *,
                  status: str, bound: float | None, bound_kind: str | None, runtime_s: float,
                  solver: dict[str, Any] | None = None, bound_samples: int | None = None,
                  bound_confidence: float | None = None, stop: Stop | None = None) -> Result:
    """A Result for ``policy`` whose value and evaluation are ``evaluation`` (policy_value's
    fields: value, evaluation, and samples and value_ci for Monte Carlo). Where the value is
    exact, both averaged objectives are given exactly in ``metrics``: the other one's
    enumeration honours ``stop`` (the run's stop rule), and is left out once it says stop."""
    solver = dict(solver or {})
    metrics = {objective: float(evaluation["value"])}
    if evaluation["evaluation"] == Evaluation.EXACT:
        for name in AVERAGED:
            if name != objective:
                try:
                    other = exact_value(policy, name, stop=stop)
                except Stopped:
                    solver["metrics_note"] = f"{name} not computed: {stop.describe()}"
                    continue
                if other is not None:
                    metrics[name] = other
    if evaluation.get("scenario_seed") is not None:
        solver["scenario_seed"] = evaluation["scenario_seed"]
    solver["policy_kind"] = policy.kind
    result = Result.lossy(instance, method, objective, status=status, metrics=metrics,
                          evaluation=evaluation["evaluation"], plan=policy.plan, bound=bound, bound_kind=bound_kind,
                          samples=evaluation.get("samples"), value_ci=evaluation.get("value_ci"),
                          bound_samples=bound_samples, bound_confidence=bound_confidence, runtime_s=runtime_s,
                          solver=solver)
    result.policy = policy  # saved beside the result by ``voiopt solve`` (--policy-out)
    return result

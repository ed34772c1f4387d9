"""The Result of a policy (MODEL.md section 11): its value with how it was evaluated, its
bound with its kind, and the Policy itself, which ``voiopt solve`` saves beside the result.

Every value here is the policy's own, computed by voiopt.core.policy_value (exact forward
enumeration or Monte Carlo over coupled scenarios), never a solver's objective. ``optimal``
is claimed only for an exact value equal, to a relative 1e-6, to an exact bound.
"""

from __future__ import annotations

import dataclasses
import dataclasses as dc
from typing import Any

from voiopt import instance as instance_mod
from voiopt import objectives
from voiopt.core.policy import Policy
from voiopt.core.policy_value import AVERAGED, exact_value
from voiopt.instance import Instance
from voiopt.result import OPTIMAL_RTOL, Result

LOSSY_FIELDS = ("evaluation", "samples", "value_ci", "bound_kind")


def lossless(instance: Instance) -> Instance:
    """The instance without its links: every upload succeeds (the lossless bound's problem)."""
    if instance.links is None:
        return instance
    d = instance.to_dict()
    d.pop("links", None)
    for s in d["sensors"]:
        s.pop("success", None)
    return instance_mod.from_dict(d, "instance")


def policy_result(instance: Instance, method: str, objective: str, policy: Policy, evaluation: dict, *,
                  status: str, bound: float | None, bound_kind: str | None, runtime_s: float,
                  solver: dict[str, Any] | None = None) -> Result:
    """A Result for ``policy`` whose value and evaluation are ``evaluation`` (policy_value's
    fields). The lossy fields are the Result's own where it has them, else in ``solver``."""
    solver = dict(solver or {})
    value = float(evaluation["value"])
    if bound is not None:
        maximise = objectives.get(objective).maximise
        violation = (value - bound) if maximise else (bound - value)
        exact = evaluation["evaluation"] == "exact" and bound_kind in ("exact", "lossless")
        if exact and violation > OPTIMAL_RTOL * max(abs(bound), abs(value), objectives.TINY):
            raise RuntimeError(f"{method}: bound {bound!r} is worse than the exact value {value!r} of its own policy")
        if exact and violation > 0:
            bound = value
    gap = objectives.gap(value, bound)
    if status == "optimal" and not (evaluation["evaluation"] == "exact" and bound_kind == "exact"
                                    and gap is not None and gap <= OPTIMAL_RTOL):
        solver.setdefault("note", "optimality not claimed: no exact value equal to an exact bound")
        status = "feasible"
    metrics = {name: exact_value(policy, name) for name in AVERAGED} if evaluation["evaluation"] == "exact" else None
    if metrics is not None and None in metrics.values():
        metrics = None
    if metrics is not None:
        metrics[objective] = value
    lossy = {"evaluation": evaluation["evaluation"], "samples": evaluation.get("samples"),
             "value_ci": evaluation.get("value_ci"), "bound_kind": bound_kind}
    if evaluation.get("scenario_seed") is not None:
        solver["scenario_seed"] = evaluation["scenario_seed"]
    names = {f.name for f in dc.fields(Result)}
    own = {k: v for k, v in lossy.items() if k in names}
    solver.update({k: v for k, v in lossy.items() if k not in names})
    solver["policy_kind"] = policy.kind
    result = Result(instance.name, method, objective, status, value, None if bound is None else float(bound), gap,
                    float(runtime_s), None, metrics, solver)
    if own:
        result = dataclasses.replace(result, **own)
    result.policy = policy  # saved beside the result by ``voiopt solve`` (--policy-out)
    return result

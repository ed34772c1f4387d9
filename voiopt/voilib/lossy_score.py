"""Scoring a result on a lossy VoI-Lib instance (MODEL.md section 11), never trusting its value:

- a plan: its exact expected objective (voiopt.core.expectation.expected_metrics);
- a policy (``solver.policy_file``, the policy saved beside the result; voiopt.core.policy):
  its exact value by forward enumeration (voiopt.core.policy_value) where every slot has at
  most MAX_STATES reachable states and the objective is averaged; otherwise a Monte Carlo
  estimate over the library's fixed scenarios (SCORE_SAMPLES drawn from SCORE_SEED, so every
  scorer's policy meets the same outcomes), with its 95 % CI and the count.

A stated value that an exact evaluation does not give is refused (ClaimError), unless the file
says its value is a Monte Carlo estimate (``evaluation``); a Monte Carlo score refuses nothing
(the file's value may be of other scenarios). Either way the row holds this module's value.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from voiopt.core.expectation import expected_metrics
from voiopt.core.instance import Instance, show
from voiopt.core.plan import Plan
from voiopt.core.policy import Policy
from voiopt.core.policy_value import MAX_STATES, exact_value, monte_carlo_value
from voiopt.core.result import Evaluation, agrees
from voiopt.core.scenarios import sample_scenarios
from voiopt.errors import OptionError, PlanError, VoioptError
from voiopt.objectives import BY_NAME
from voiopt.voilib.certificates import instance_hash
from voiopt.voilib.lossy import SCORE_SAMPLES, SCORE_SEED


class ClaimError(OptionError):
    """A submission's stated value is not what its plan (or policy) gives (``bench check``: exit 4)."""


def policy_file(result: dict[str, Any], source: str) -> str | None:
    """The policy file a result names in ``solver.policy_file``, or None."""
    solver = result.get("solver")
    name = solver.get("policy_file") if isinstance(solver, dict) else None
    if name is not None and (not isinstance(name, str) or not name):
        raise OptionError(f"{source}: solver.policy_file: must be a file name, got {show(name)}")
    return name


def load_policy(result: dict[str, Any], source: str, folder: Path, name: str, digest: str) -> Policy | None:
    """The policy a result names, beside it in ``folder``, checked to be of VoI-Lib's ``name``
    (sha256 ``digest``); None if it names none."""
    file = policy_file(result, source)
    if file is None:
        return None
    path = folder / file
    try:
        policy = Policy.load(path)
    except VoioptError as e:
        raise OptionError(f"{source}: solver.policy_file: {e}") from None
    if instance_hash(policy.instance) != digest:
        raise OptionError(f"{source}: solver.policy_file: {path} is a policy of another instance, not VoI-Lib's {name}")
    return policy


def policy_value(policy: Policy, objective: str, name: str) -> dict[str, Any]:
    """A policy's value for ``objective``: exact where it can be enumerated, else Monte Carlo
    on the library's scenarios. An illegal action is a PlanError naming the instance."""
    try:
        if BY_NAME[objective].per_slot:
            value = exact_value(policy, objective, MAX_STATES)
            if value is not None:
                return {"value": value, "evaluation": Evaluation.EXACT, "samples": None, "value_ci": None}
        est = monte_carlo_value(policy, sample_scenarios(policy.instance, SCORE_SAMPLES, SCORE_SEED), objective)
    except OptionError as e:  # an illegal action
        raise PlanError(f"{e} (checked against VoI-Lib's {name})") from None
    return {"value": est.mean, "evaluation": Evaluation.MONTE_CARLO, "samples": est.count,
            "value_ci": [float(est.ci[0]), float(est.ci[1])], "scenario_seed": SCORE_SEED}


def measure(result: dict[str, Any], source: str, folder: Path, name: str, inst: Instance, objective: str,
            stated: float | None) -> dict[str, Any]:
    """The value of a result's policy, or else of its plan, on the lossy instance ``inst``,
    labelled (``evaluation``, ``samples``, ``value_ci``, ``scored``: "policy" or "plan");
    ClaimError if an exactly computed value is not the ``stated`` one."""
    policy = load_policy(result, source, folder, name, instance_hash(inst))
    if policy is not None:
        measured = {**policy_value(policy, objective, name), "scored": "policy"}
        hint = ""
    else:
        if result.get("plan") is None:
            raise OptionError(f"{source}: plan: is required (or solver.policy_file: a policy saved beside the result)")
        try:
            metrics = expected_metrics(inst, Plan.from_dict({"plan": result["plan"]}))  # errors name plan.
        except PlanError as e:
            raise PlanError(f"{e} (checked against VoI-Lib's {name})") from None
        measured = {"value": metrics[objective], "evaluation": Evaluation.EXACT, "samples": None, "value_ci": None,
                    "scored": "plan"}
        hint = "; a plan's value on lossy links is its exact expected value (voiopt evaluate)"
    estimated = result.get("evaluation") == Evaluation.MONTE_CARLO  # the file's own value is an estimate
    if stated is not None and not estimated and measured["evaluation"] == Evaluation.EXACT \
            and not agrees(stated, measured["value"]):
        raise ClaimError(f"{source}: value: {stated!r} is not what its {measured['scored']} gives on VoI-Lib's "
                         f"{name} ({measured['value']!r}, exact): rejected{hint}")
    return measured

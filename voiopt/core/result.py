"""Result: the result JSON of MODEL.md section 6, written atomically, read losslessly.

``Result.from_plan`` is the only way solvers make a result: it simulates the plan, takes the
value from the simulator, checks the bound against it and claims ``optimal`` only when they
agree to a relative 1e-6.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance, show
from voiopt.core.plan import Plan
from voiopt.core.simulate import simulate
from voiopt.errors import VoioptError
from voiopt.objectives import TINY
from voiopt.runtime.files import read_json, write_json_atomic
from voiopt.runtime.status import Status, Word

STATUSES = tuple(s.value for s in Status)
OPTIMAL_RTOL = 1e-6


class Evaluation(Word):
    """How a lossy result's value was computed (MODEL.md section 11)."""

    EXACT = "exact"
    MONTE_CARLO = "monte-carlo"  # then with ``samples`` and ``value_ci``


class BoundKind(Word):
    """What a lossy result's bound is (MODEL.md section 11), and whether it is proven."""

    EXACT = "exact"  # the optimal policy's exact value
    LOSSLESS = "lossless"  # the lossless optimum (or its solver's proven bound): bounds every policy
    INFORMATION_RELAXATION = "information-relaxation"  # statistical: never called proven

    @property
    def proven(self) -> bool:
        return self is not BoundKind.INFORMATION_RELAXATION


LOSSY_FIELDS = ("evaluation", "samples", "value_ci", "bound_kind", "bound_samples", "bound_confidence")


@dataclass
class Result:
    instance: str
    method: str
    objective: str
    status: Status
    value: float | None
    bound: float | None
    gap: float | None
    runtime_s: float
    plan: Plan | None
    metrics: dict[str, float] | None
    solver: dict[str, Any] = field(default_factory=dict)
    # MODEL.md section 11, lossy instances only (None otherwise, and then absent from the JSON)
    evaluation: Evaluation | None = None  # how ``value`` and ``metrics`` were computed
    samples: int | None = None  # monte-carlo: the number of scenarios
    value_ci: tuple[float, float] | None = None  # monte-carlo: the 95 % confidence interval of ``value``
    bound_kind: BoundKind | None = None
    bound_samples: int | None = None  # information-relaxation: the number of scenarios
    bound_confidence: float | None = None  # information-relaxation: the one-sided confidence level

    @classmethod
    def from_plan(
        cls,
        instance: Instance,
        method: str,
        objective: str,
        plan: Plan | None,
        *,
        status: str,
        bound: float | None = None,
        runtime_s: float = 0.0,
        solver: dict[str, Any] | None = None,
    ) -> Result:
        """Simulate ``plan`` and build the result; the value is the simulator's, never the solver's."""
        objective, status = objectives.get(objective), _status(status)
        solver = dict(solver or {})
        if plan is None:
            if status.has_plan:
                raise ValueError(f"status {status!r} needs a plan")
            return cls(instance.name, method, objective, status, None, _clean(bound), None, runtime_s, None, None, solver)
        metrics = simulate(instance, plan).metrics
        value = metrics[objective]
        if bound is not None:
            bound = _clamped(objective, value, float(bound),
                             f"{method}: bound {bound!r} is worse than the simulated value {value!r} of its own plan")
        gap = objectives.gap(value, bound)
        if status == Status.OPTIMAL and (gap is None or gap > OPTIMAL_RTOL):
            solver.setdefault("note", "optimality not claimed: bound and simulated value differ")
            status = Status.FEASIBLE
        return cls(instance.name, method, objective, status, value, bound, gap, float(runtime_s), plan, metrics, solver)

    @classmethod
    def lossy(cls, instance: Instance, method: str, objective: str, *, status: str, metrics: dict[str, float],
              evaluation: str, plan: Plan | None = None, bound: float | None = None, bound_kind: str | None = None,
              samples: int | None = None, value_ci: tuple[float, float] | None = None,
              bound_samples: int | None = None, bound_confidence: float | None = None, runtime_s: float = 0.0,
              solver: dict[str, Any] | None = None) -> Result:
        """A result on a lossy instance (MODEL.md section 11): ``metrics`` are expectations,
        computed as ``evaluation`` says (never a solver's number). ``optimal`` is claimed only
        with an exact value equal, to a relative 1e-6, to an exact bound (MODEL.md section 11)."""
        objective, status = objectives.get(objective), _status(status)
        try:
            evaluation, bound_kind = Evaluation(evaluation), None if bound_kind is None else BoundKind(bound_kind)
            if (bound is None) != (bound_kind is None):
                raise ValueError
        except ValueError:
            raise ValueError(f"evaluation {evaluation!r}, bound {bound!r}, bound_kind {bound_kind!r}: "
                             "not a lossy result") from None
        solver = dict(solver or {})
        value = metrics[objective]
        bound = _clean(bound)
        if bound is not None and evaluation == Evaluation.EXACT and bound_kind.proven:
            bound = _clamped(objective, value, bound, f"{method}: {bound_kind} bound {bound!r} is worse than the exact value {value!r}")
        gap = objectives.gap(value, bound)
        if status == Status.OPTIMAL and not (evaluation == Evaluation.EXACT and bound_kind == BoundKind.EXACT and gap is not None
                                             and gap <= OPTIMAL_RTOL):
            solver.setdefault("note", "optimality not claimed: it needs an exact value equal to an exact bound")
            status = Status.FEASIBLE
        return cls(instance.name, method, objective, status, value, bound, gap, float(runtime_s), plan, dict(metrics),
                   solver, evaluation, samples, None if value_ci is None else tuple(map(float, value_ci)), bound_kind,
                   bound_samples, bound_confidence)

    def to_dict(self) -> dict[str, Any]:
        return {
            "instance": self.instance,
            "method": self.method,
            "objective": self.objective,
            "status": self.status,
            "value": self.value,
            "bound": self.bound,
            "gap": self.gap,
            "runtime_s": self.runtime_s,
            "plan": None if self.plan is None else self.plan.to_dict(),
            "metrics": self.metrics,
            "solver": _jsonable(self.solver),
            **({} if self.evaluation is None else {k: _jsonable(getattr(self, k)) for k in LOSSY_FIELDS}),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Result:
        if not isinstance(d, dict):
            raise VoioptError(f"result: must be a JSON object, got {type(d).__name__}")
        if "objective" not in d and "sensors" in d:
            raise VoioptError("result: this is an instance, not a result (voiopt solve -o writes results)")
        if d.get("status") not in STATUSES:  # a file's word is not taken: plot and evaluate show the status
            raise VoioptError(f"result: status: must be one of {', '.join(STATUSES)}, got {show(d.get('status'))}")
        try:
            objective = objectives.get(d["objective"])
            return cls(
                d["instance"], d["method"], objective, Status(d["status"]), d["value"], d["bound"],
                d["gap"], d["runtime_s"], None if d["plan"] is None else Plan.from_dict(d["plan"]),
                d["metrics"], d.get("solver", {}),
                **{**{k: d[k] for k in LOSSY_FIELDS if k in d}, **_words(d)},
            )
        except (KeyError, TypeError) as e:
            raise VoioptError(f"result: missing or malformed field {e}") from None

    def save(self, path: str | os.PathLike) -> None:
        """Write the result as JSON (atomically). A policy's result (one with a ``policy``, which
        its JSON cannot hold) saves the policy first, at RESULT.policy.json beside it, and names
        that file in ``solver.policy_file``, unless it already names one."""
        policy = getattr(self, "policy", None)
        if policy is not None and "policy_file" not in self.solver:
            target = beside(path)
            policy.save(target)
            self.solver["policy_file"] = os.path.basename(target)
        write_json_atomic(path, self.to_dict())

    def summary(self) -> str:
        val = "-" if self.value is None else f"{self.value:.6g}"
        bnd = "-" if self.bound is None else f"{self.bound:.6g}"
        gap = objectives.show_gap(self.gap, 4)
        startup = self.solver.get("startup_s") if isinstance(self.solver, dict) else None
        compiled = f"; start-up {startup:.1f} s" if isinstance(startup, (int, float)) and startup >= 1 else ""
        if self.evaluation is not None:  # lossy: the value is an expectation, the bound has a kind
            how = "exact" if self.evaluation == Evaluation.EXACT else f"monte-carlo, {self.samples} scenarios, 95 % CI " + (
                "-" if self.value_ci is None else f"[{self.value_ci[0]:.6g}, {self.value_ci[1]:.6g}]")
            val = f"{val} (expected, {how})"
            if self.bound is not None:
                bnd = f"{bnd} ({self.bound_kind}, {'proven' if self.bound_kind.proven else 'statistical'})"
            if self.gap is not None:
                gap += " (" + ("estimate" if self.evaluation != Evaluation.EXACT else
                               "proven" if self.bound_kind.proven else "statistical") + ")"
        return (
            f"{self.instance}  {self.method}  {self.objective}: {self.status}  "
            f"value {val}  bound {bnd}  gap {gap}  ({self.runtime_s:.2f} s{compiled})"
        )


def _words(d: dict[str, Any]) -> dict[str, Any]:
    """A result file's evaluation and bound kind, as their objects (a word not of MODEL.md
    section 11 is refused in one line naming the field)."""
    out = {}
    for key, word in (("evaluation", Evaluation), ("bound_kind", BoundKind)):
        if d.get(key) is not None:
            if d[key] not in {w.value for w in word}:
                raise VoioptError(f"result: {key}: must be one of {', '.join(w.value for w in word)}, got {show(d[key])}")
            out[key] = word(d[key])
    return out


def load_result(path: str | os.PathLike) -> Result:
    d = read_json(path, error=VoioptError)
    try:
        return Result.from_dict(d)
    except VoioptError as e:  # name the file
        raise VoioptError(f"{path}: {e}") from None


STORED_RTOL = 1e-9  # a number stored in a file (a result's, a submission's) against its plan re-simulated


def _clamped(objective, value: float, bound: float, worse: str) -> float:
    """A proven bound beside its plan's value: a bound can never be worse than a feasible plan;
    within OPTIMAL_RTOL that is solver noise and the value itself is the tightest valid bound.
    Past it, a RuntimeError saying ``worse``."""
    violation = (value - bound) if objective.maximise else (bound - value)
    if violation > OPTIMAL_RTOL * max(abs(bound), abs(value), TINY):
        raise RuntimeError(worse)
    return value if violation > 0 else bound


def _status(status: str) -> Status:
    """A status a solver gives, as the enum; an unknown word is a solver's bug."""
    if status not in STATUSES:
        raise ValueError(f"status: unknown status {status!r}")
    return Status(status)


def agrees(stored: Any, simulated: float) -> bool:
    """Whether a number a file states for its plan is what the simulator gives: a finite number
    within a relative STORED_RTOL of it (rounding only; the same simulator gives equal bits)."""
    return (not isinstance(stored, bool) and isinstance(stored, (int, float)) and finite(stored)
            and abs(stored - simulated) <= STORED_RTOL * max(abs(stored), abs(simulated), TINY))


def disagreement(stored: Any, metrics: dict[str, float]) -> str | None:
    """The first of a result file's stored metrics (a dict, or anything else: nothing stored)
    that its plan, re-simulated, does not give, as "NAME S stored, V simulated"; None if all
    agree. A plan re-simulated on another instance than it was solved on, or a file edited by
    hand, shows here."""
    if not isinstance(stored, dict):
        return None
    for name, v in metrics.items():
        if name in stored and not agrees(stored[name], v):
            return f"{name} {show(stored[name])} stored, {v!r} simulated"
    return None


def finite(x: float) -> bool:
    """A finite float, also for a JSON integer too large for one (10**400: float() overflows)."""
    try:
        return math.isfinite(x)
    except OverflowError:
        return False


def _clean(v: float | None) -> float | None:
    return None if v is None else float(v)


def _jsonable(obj: Any) -> Any:
    """Solver details may hold numpy scalars; make them plain JSON, non-finite as strings."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    return obj


def beside(result_path: str | os.PathLike) -> str:
    """RESULT.policy.json for a result file RESULT.json (or RESULT): where a policy is saved."""
    text = str(result_path)
    return (text[:-5] if text.endswith(".json") else text) + ".policy.json"

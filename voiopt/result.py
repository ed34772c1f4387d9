"""Plan and Result: the result JSON of MODEL.md section 6, written atomically, read losslessly.

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

from voiopt.errors import PlanError, VoioptError
from voiopt.instance import Instance, read_json, write_json_atomic
from voiopt.simulate import check_objective, sense, simulate

STATUSES = ("optimal", "feasible", "time_limit", "infeasible", "error")
OPTIMAL_RTOL = 1e-6
TINY = 1e-300


def _num(v: float) -> float | int:
    """Integral floats as ints, so lattice points read [1, 0] rather than [1.0, 0.0]."""
    return int(v) if float(v).is_integer() and abs(v) < 2**53 else float(v)


@dataclass(frozen=True)
class Plan:
    positions: tuple[tuple[float, float], ...]
    schedule: tuple[int | None, ...]

    @classmethod
    def from_dict(cls, d: Any) -> Plan:
        """A plan object, or a whole result JSON whose ``plan`` is used."""
        if isinstance(d, dict) and "plan" in d and "positions" not in d:
            d = d["plan"]
            where = "plan."
        else:
            where = ""
        if not isinstance(d, dict):
            raise PlanError(f"plan: must be an object with positions and schedule, got {type(d).__name__}")
        unknown = set(d) - {"positions", "schedule"}
        if unknown:
            raise PlanError(f"{where}{sorted(unknown)[0]}: unknown field (allowed: positions, schedule)")
        for key in ("positions", "schedule"):
            if not isinstance(d.get(key), list):
                raise PlanError(f"{where}{key}: must be a list, got {d.get(key)!r}")
        positions = []
        for t, p in enumerate(d["positions"]):
            ok = isinstance(p, list) and len(p) == 2 and all(
                isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in p
            )
            if not ok:
                raise PlanError(f"{where}positions[{t}]: must be a pair [x, y] of finite numbers, got {p!r}")
            positions.append((float(p[0]), float(p[1])))
        schedule = []
        for t, u in enumerate(d["schedule"]):
            if isinstance(u, float) and u.is_integer():
                u = int(u)
            if u is not None and (isinstance(u, bool) or not isinstance(u, int)):
                raise PlanError(f"{where}schedule[{t}]: must be a sensor index or null, got {u!r}")
            schedule.append(u)
        return cls(tuple(positions), tuple(schedule))

    def to_dict(self) -> dict[str, Any]:
        return {
            "positions": [[_num(x), _num(y)] for x, y in self.positions],
            "schedule": list(self.schedule),
        }

    @classmethod
    def from_indices(cls, instance: Instance, idx, sched) -> Plan:
        """A plan from lattice point indices and a schedule with -1 for none."""
        from voiopt import lattice

        pts = lattice.build(instance).points
        return cls(
            tuple((float(pts[p, 0]), float(pts[p, 1])) for p in idx),
            tuple(None if u < 0 else int(u) for u in sched),
        )


def load_plan(path: str | os.PathLike) -> Plan:
    return Plan.from_dict(read_json(path, error=PlanError))


@dataclass
class Result:
    instance: str
    method: str
    objective: str
    status: str
    value: float | None
    bound: float | None
    gap: float | None
    runtime_s: float
    plan: Plan | None
    metrics: dict[str, float] | None
    solver: dict[str, Any] = field(default_factory=dict)

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
        check_objective(objective)
        if status not in STATUSES:
            raise ValueError(f"status: unknown status {status!r}")
        solver = dict(solver or {})
        if plan is None:
            if status in ("optimal", "feasible", "time_limit"):
                raise ValueError(f"status {status!r} needs a plan")
            return cls(instance.name, method, objective, status, None, _clean(bound), None, runtime_s, None, None, solver)
        metrics = simulate(instance, plan).metrics
        value = metrics[objective]
        if bound is not None:
            bound = float(bound)
            maximise = sense(objective) == "max"
            violation = (value - bound) if maximise else (bound - value)
            if violation > 0:
                # A bound can never be worse than a feasible plan; within tolerance it is solver
                # noise and the plan's value is itself the tightest valid bound.
                if violation > OPTIMAL_RTOL * max(abs(bound), abs(value), TINY):
                    raise RuntimeError(
                        f"{method}: bound {bound!r} is worse than the simulated value {value!r} of its own plan"
                    )
                bound = value
        gap = None if bound is None else abs(bound - value) / max(abs(bound), TINY)
        if status == "optimal" and (gap is None or gap > OPTIMAL_RTOL):
            solver.setdefault("note", "optimality not claimed: bound and simulated value differ")
            status = "feasible"
        return cls(instance.name, method, objective, status, value, bound, gap, float(runtime_s), plan, metrics, solver)

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
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Result:
        try:
            return cls(
                d["instance"], d["method"], d["objective"], d["status"], d["value"], d["bound"],
                d["gap"], d["runtime_s"], None if d["plan"] is None else Plan.from_dict(d["plan"]),
                d["metrics"], d.get("solver", {}),
            )
        except (KeyError, TypeError) as e:
            raise VoioptError(f"result: missing or malformed field {e}") from None

    def save(self, path: str | os.PathLike) -> None:
        write_json_atomic(path, self.to_dict())

    def summary(self) -> str:
        val = "-" if self.value is None else f"{self.value:.6g}"
        bnd = "-" if self.bound is None else f"{self.bound:.6g}"
        gap = "-" if self.gap is None else f"{100 * self.gap:.4g} %"
        return (
            f"{self.instance}  {self.method}  {self.objective}: {self.status}  "
            f"value {val}  bound {bnd}  gap {gap}  ({self.runtime_s:.2f} s)"
        )


def load_result(path: str | os.PathLike) -> Result:
    return Result.from_dict(read_json(path, error=VoioptError))


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

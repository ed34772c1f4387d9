"""The story of a plan: what the viewer (``voiopt show``) and the animation show, slot by slot.

Every number is the simulator's (``voiopt.core.simulate.simulate``) of the plan: a result's own
metrics are checked against it, never drawn. One ``Entry`` per result or plan file; ``story``
turns entries on one instance into the compact JSON the page embeds.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from voiopt.core.instance import Instance, show
from voiopt.core.plan import FleetPlan, Plan, made_for, plan_of
from voiopt.core.result import BoundKind, Evaluation, Result, disagreement
from voiopt.core.simulate import Trajectory, check_plan, simulate
from voiopt.errors import OptionError, PlanError, VoioptError
from voiopt.objectives import DEFAULT, OBJECTIVES, show_gap
from voiopt.runtime.files import read_json, reading


@dataclass(frozen=True)
class Entry:
    """One plan to show: from a result (method, status, value, bound, gap) or a plan file."""

    label: str
    plan: Plan | FleetPlan | None  # None for a policy (lossy links), which ``policy`` holds
    objective: str
    method: str | None = None
    status: str | None = None
    value: float | None = None
    bound: float | None = None
    gap: float | None = None
    bound_kind: BoundKind | None = None
    evaluation: Evaluation | None = None  # lossy links (with samples and value_ci when monte-carlo)
    samples: int | None = None
    value_ci: tuple[float, float] | None = None
    policy: Any = None  # a voiopt.Policy, shown by one sampled run

    @property
    def gap_kind(self) -> str:
        """"statistical" for a bound estimated from samples, else "proven" (MODEL.md 6, 11)."""
        return "proven" if self.bound_kind is None or self.bound_kind.proven else "statistical"


def read_entry(path: str | os.PathLike) -> tuple[Entry, str | None]:
    """A result or plan file as an Entry, and the instance it names (None: it names none).
    Every error names the file."""
    name = os.fsdecode(path)
    d = read_json(path, error=VoioptError)
    if isinstance(d, dict) and "status" in d:  # a result of voiopt solve
        try:
            result = Result.from_dict(d)
        except VoioptError as e:
            raise VoioptError(f"{name}: {e}") from None
        policy = _policy_beside(name, d) if result.plan is None else None
        if result.plan is None and policy is None:
            raise OptionError(f"{name}: the result has no plan to show (status {result.status})")
        ci = d.get("value_ci") if isinstance(d.get("value_ci"), list) and len(d["value_ci"]) == 2 else None
        samples = d.get("samples") if isinstance(d.get("samples"), int) else None
        return Entry(Path(name).name, result.plan, result.objective, result.method, result.status, result.value,
                     result.bound, result.gap, result.bound_kind, result.evaluation, samples,
                     None if ci is None else (float(ci[0]), float(ci[1])), policy), result.instance
    plan = plan_of(d, name)  # a plan, or a plan with instance and objective (a VoI-Lib submission)
    objective = d.get("objective", DEFAULT) if isinstance(d, dict) else DEFAULT
    if objective not in OBJECTIVES:
        raise OptionError(f"{name}: objective: must be one of {', '.join(OBJECTIVES)}, got {show(objective)}")
    return Entry(Path(name).name, plan, objective), made_for(d) or (
        d.get("instance") if isinstance(d, dict) and isinstance(d.get("instance"), str) else None)


def _policy_beside(name: str, d: dict) -> Any:
    """The policy a policy result names (``solver.policy_file``, beside the result), or None."""
    solver = d.get("solver") if isinstance(d.get("solver"), dict) else {}
    file = solver.get("policy_file")
    if not isinstance(file, str):
        return None
    from voiopt.core.policy import Policy

    path = Path(name).parent / file
    with reading(f"{name}: its policy"):
        return Policy.load(path)


def policy_run(instance: Instance, policy: Any, seed: int) -> tuple[Plan | FleetPlan, Plan | FleetPlan, dict]:
    """One sampled run of a policy (scenario 0 of ``sample_scenarios(instance, 1, seed)``): the
    uploads it scheduled, then the lossless plan it realised and the page's ``run`` (``_realised``)."""
    from voiopt.core.policy_value import trace
    from voiopt.core.scenarios import sample_scenarios

    idx, sched, ok = trace(policy, sample_scenarios(instance, 1, seed)[0])
    return (Plan.from_indices(instance, idx, sched), *_realised(instance, idx, sched, ok, seed))


def _realised(instance: Instance, idx, sched, ok, seed: int) -> tuple[Plan | FleetPlan, dict]:
    """A run's lossless plan (each failed upload unscheduled, which the simulator then values)
    and the page's ``run``: its seed and, per robot and slot, whether a scheduled upload failed."""
    failed = (np.atleast_2d(sched) >= 0) & ~np.atleast_2d(ok)
    return Plan.from_indices(instance, idx, np.where(ok, sched, -1)), {"seed": seed, "failed": failed.tolist()}


def trajectory(instance: Instance, entry: Entry, where: str = "the instance") -> Trajectory:
    """The simulated trajectory of an entry; a result whose own value disagrees with it was
    solved on another instance (or edited), and is refused."""
    try:
        traj = simulate(instance, entry.plan)
    except PlanError as e:
        raise PlanError(f"{entry.label}: {e}") from None
    if entry.value is not None and entry.evaluation is None:  # a plan's value, not an estimate of a policy's
        differ = disagreement({entry.objective: entry.value}, traj.metrics)
        if differ:
            raise OptionError(f"{entry.label}: its plan on {where} does not give what the result says ({differ}): "
                              "give the instance it was solved on with --instance (or the file was edited)")
    return traj


def _number(v: Any) -> float | str | None:
    """A float for JSON: full precision (repr round-trips), non-finite values as strings
    ("Infinity") that the page turns back into numbers."""
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else str(v).replace("inf", "Infinity").replace("nan", "NaN")


def _rows(a) -> list:
    return [[_number(x) for x in row] for row in a.tolist()]


def sampled_run(instance: Instance, plan: Plan | FleetPlan, seed: int) -> tuple[Plan | FleetPlan, dict] | None:
    """Lossy links (MODEL.md section 11): one sampled run of the plan, as the lossless plan it
    becomes (each failed upload unscheduled, which the simulator then values) and the page's
    ``run``: its seed and, per robot and slot, whether a scheduled upload failed. The outcomes
    are scenario 0 of ``voiopt.core.scenarios.sample_scenarios(instance, 1, seed)`` (coupled
    uniforms U(t, i)). Without ``links`` every upload succeeds: None, and nothing is drawn."""
    if instance.links is None:
        return None
    from voiopt.core import scenarios

    idx, sched = check_plan(instance, plan)
    ok = scenarios.successes(instance, idx, sched, scenarios.sample_scenarios(instance, 1, seed)[0])
    return _realised(instance, idx, sched, ok, seed)


def story(instance: Instance, entries: list[Entry], where: str = "the instance", seed: int = 0) -> dict[str, Any]:
    """The page's data: the instance (area, blocked points, robots' starts and ends, sensors)
    and per entry its header and its simulated story: p_k(t) for t = 0..T-1, u_k(t) (-1: none),
    A_i(t) and V_i(t) for t = 0..T (row t: before slot t's upload takes effect). Under lossy
    links (``sampled_run``) the ages and values are those of one sampled run, seeded by ``seed``,
    and ``simulated`` holds that run's metrics, not the plan's expected ones."""
    T = instance.horizon
    out = []
    for e in entries:
        if e.policy is not None:  # a policy: one sampled run, its scheduled uploads drawn, failures marked
            shown, realised, run = policy_run(instance, e.policy, seed)
            robots, traj, sampled = shown.robots, simulate(instance, realised), (realised, run)
        else:
            traj = trajectory(instance, e, where)
            robots = e.plan.robots
            sampled = sampled_run(instance, e.plan, seed)
            if sampled is not None:  # the run's ages and values: the plan with its failed uploads unscheduled
                traj = simulate(instance, sampled[0])
        out.append({
            "label": e.label, "method": e.method, "objective": e.objective, "status": e.status,
            "value": _number(e.value), "bound": _number(e.bound), "gap": _number(e.gap),
            "gapText": show_gap(e.gap), "gapKind": e.gap_kind, "boundKind": e.bound_kind, "evaluation": e.evaluation,
            "samples": e.samples, "valueCi": None if e.value_ci is None else [_number(v) for v in e.value_ci],
            "simulated": {k: _number(v) for k, v in traj.metrics.items()},
            "x": [[_number(x) for x, _ in r.positions] for r in robots],
            "y": [[_number(y) for _, y in r.positions] for r in robots],
            "u": [[-1 if u is None else int(u) for u in r.schedule] for r in robots],
            "aoi": traj.aoi.tolist(), "voi": _rows(traj.voi),
            "run": None if sampled is None else sampled[1],
        })
    return {
        "instance": {
            "name": instance.name, "width": instance.width, "height": instance.height, "step": instance.step,
            "T": T, "d_th": instance.channel.d_th, "blocked": [list(p) for p in instance.blocked],
            "robots": [{"start": list(r.start), "end": None if r.end is None else list(r.end),
                        "max_moves": r.max_moves} for r in instance.robots],
            "sensors": [{"x": s.position[0], "y": s.position[1], "rho": s.rho} for s in instance.sensors],
        },
        "results": out,
    }

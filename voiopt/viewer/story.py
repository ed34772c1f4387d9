"""The story of a plan: what the viewer (``voiopt show``) and the animation show, slot by slot.

Every number is the simulator's (``voiopt.simulate.simulate``) of the plan: a result's own
metrics are checked against it, never drawn. One ``Entry`` per result or plan file; ``story``
turns entries on one instance into the compact JSON the page embeds.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from voiopt._files import read_json
from voiopt.errors import OptionError, PlanError, VoioptError
from voiopt.instance import Instance, show
from voiopt.objectives import DEFAULT, OBJECTIVES, show_gap
from voiopt.plan import FleetPlan, Plan, made_for, plan_of
from voiopt.result import Result, disagreement
from voiopt.simulate import Trajectory, simulate

STATISTICAL_BOUNDS = ("information-relaxation",)  # MODEL.md section 11: a bound estimated from samples


@dataclass(frozen=True)
class Entry:
    """One plan to show: from a result (method, status, value, bound, gap) or a plan file."""

    label: str
    plan: Plan | FleetPlan
    objective: str
    method: str | None = None
    status: str | None = None
    value: float | None = None
    bound: float | None = None
    gap: float | None = None
    bound_kind: str | None = None
    evaluation: str | None = None

    @property
    def gap_kind(self) -> str:
        """"statistical" for a bound estimated from samples, else "proven" (MODEL.md 6, 11)."""
        return "statistical" if self.bound_kind in STATISTICAL_BOUNDS else "proven"


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
        if result.plan is None:
            raise OptionError(f"{name}: the result has no plan to show (status {result.status})")
        kind = d.get("bound_kind")
        return Entry(Path(name).name, result.plan, result.objective, result.method, result.status, result.value,
                     result.bound, result.gap, kind if isinstance(kind, str) else None,
                     d.get("evaluation") if isinstance(d.get("evaluation"), str) else None), result.instance
    plan = plan_of(d, name)  # a plan, or a plan with instance and objective (a VoI-Lib submission)
    objective = d.get("objective", DEFAULT) if isinstance(d, dict) else DEFAULT
    if objective not in OBJECTIVES:
        raise OptionError(f"{name}: objective: must be one of {', '.join(OBJECTIVES)}, got {show(objective)}")
    return Entry(Path(name).name, plan, objective), made_for(d) or (
        d.get("instance") if isinstance(d, dict) and isinstance(d.get("instance"), str) else None)


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


def sampled_run(instance: Instance, entry: Entry, seed: int) -> dict | None:
    """The hook for lossy links (MODEL.md section 11): one sampled run of the plan, with its
    seed and each robot's failed uploads. Without ``links`` every upload succeeds and there is
    nothing to sample (None). The links model is not part of this version of voiopt, so an
    instance with links is refused here rather than shown as if lossless."""
    if getattr(instance, "links", None) is None:
        return None
    raise OptionError(f"{instance.name}: links: lossy links are not shown by this version of voiopt show")


def story(instance: Instance, entries: list[Entry], where: str = "the instance", seed: int = 0) -> dict[str, Any]:
    """The page's data: the instance (area, blocked points, robots' starts and ends, sensors)
    and per entry its header and its simulated story: p_k(t) for t = 0..T-1, u_k(t) (-1: none),
    A_i(t) and V_i(t) for t = 0..T (row t: before slot t's upload takes effect)."""
    T = instance.horizon
    out = []
    for e in entries:
        traj = trajectory(instance, e, where)
        robots = e.plan.robots
        out.append({
            "label": e.label, "method": e.method, "objective": e.objective, "status": e.status,
            "value": _number(e.value), "bound": _number(e.bound), "gap": _number(e.gap),
            "gapText": show_gap(e.gap), "gapKind": e.gap_kind, "boundKind": e.bound_kind, "evaluation": e.evaluation,
            "simulated": {k: _number(v) for k, v in traj.metrics.items()},
            "x": [[_number(x) for x, _ in r.positions] for r in robots],
            "y": [[_number(y) for _, y in r.positions] for r in robots],
            "u": [[-1 if u is None else int(u) for u in r.schedule] for r in robots],
            "aoi": traj.aoi.tolist(), "voi": _rows(traj.voi),
            "run": sampled_run(instance, e, seed),
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
